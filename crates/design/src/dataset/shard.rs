//! Seed ranges and shards: which seeds one of N machines generates.
//!
//! The rule is fixed and independent of timing: the seeds of the range, in increasing order,
//! are numbered 0, 1, 2, ...; shard `I/N` takes those whose number is `I mod N`. Every seed
//! falls in exactly one shard, neighbouring seeds go to different machines (houses cost about
//! the same, so the shards balance), and nothing a shard writes depends on `N` or `I`: N shard
//! runs into one folder give the bytes one run would.

use std::fmt;
use std::str::FromStr;

pub use scene_gen_core::seeds::SeedRange;
use scene_gen_core::seeds::SeedsError;

/// Largest seed a dataset takes: image ids pack the seed into the top bits of a number that
/// must stay below 2^53 (exact in JSON readers that use doubles); see [`super::image_id`].
pub const MAX_SEED: u64 = (1 << 31) - 1;

/// Why a `--seeds` or `--shard` argument was refused.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ShardError {
    #[error("--{0}")]
    Seeds(#[from] SeedsError),
    #[error("--seeds '{text}': seeds must be at most {MAX_SEED} (image ids hold 31 bits of seed)")]
    SeedTooLarge { text: String },
    #[error("--shard '{0}': expected I/N with N >= 1 and 0 <= I < N, e.g. 0/4")]
    BadShard(String),
}

/// Parses a `--seeds` argument and checks it against [`MAX_SEED`].
///
/// # Errors
/// [`ShardError::Seeds`] for a malformed or empty range, [`ShardError::SeedTooLarge`] above
/// [`MAX_SEED`].
pub fn parse_seeds(text: &str) -> Result<SeedRange, ShardError> {
    let range: SeedRange = text.parse()?;
    if range.last > MAX_SEED {
        return Err(ShardError::SeedTooLarge { text: text.to_string() });
    }
    Ok(range)
}

/// Shard `index` of `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    /// The whole range in one run.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Whether the seed numbered `position` in its range (0 for the first) belongs here.
    #[must_use]
    pub fn owns_position(&self, position: u64) -> bool {
        position % u64::from(self.count) == u64::from(self.index)
    }

    /// This shard's seeds of `range`, in increasing order.
    #[must_use]
    pub fn seeds(&self, range: &SeedRange) -> Vec<u64> {
        range.iter().enumerate().filter(|&(k, _)| self.owns_position(k as u64)).map(|(_, s)| s).collect()
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = ShardError;

    /// `I/N`.
    fn from_str(text: &str) -> Result<Shard, ShardError> {
        let bad = || ShardError::BadShard(text.to_string());
        let (i, n) = text.trim().split_once('/').ok_or_else(bad)?;
        let index: u32 = i.trim().parse().map_err(|_| bad())?;
        let count: u32 = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_ranges() {
        assert_eq!(parse_seeds("3..6"), Ok(SeedRange { first: 3, last: 5 }));
        assert_eq!(parse_seeds("0..=2147483647").map(|r| r.last), Ok(MAX_SEED));
        assert!(matches!(parse_seeds("3..3"), Err(ShardError::Seeds(SeedsError::Empty(_)))));
        assert!(matches!(parse_seeds("a..4"), Err(ShardError::Seeds(SeedsError::Syntax(_)))));
        assert!(matches!(parse_seeds("0..=2147483648"), Err(ShardError::SeedTooLarge { .. })));
    }

    #[test]
    fn shards() {
        assert_eq!("1/3".parse(), Ok(Shard { index: 1, count: 3 }));
        for bad in ["3/2", "2/2", "0/0", "1", "a/2", "-1/2", "1/2/3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    proptest::proptest! {
        /// The shards of any range partition it: every seed in exactly one shard.
        #[test]
        fn shards_partition(first in 0u64..1000, len in 1u64..200, n in 1u32..9) {
            let range = SeedRange { first, last: first + len - 1 };
            let mut all: Vec<u64> = (0..n).flat_map(|i| Shard { index: i, count: n }.seeds(&range)).collect();
            all.sort_unstable();
            proptest::prop_assert_eq!(all, range.iter().collect::<Vec<_>>());
        }
    }
}
