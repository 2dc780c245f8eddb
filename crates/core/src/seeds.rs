//! House seed ranges as users write them on every command line and in every protocol:
//! `A..B` (half-open, as in Rust: `0..3` is 0, 1, 2), `A..=B` (inclusive), or one seed `A`.
//!
//! One parser, so `evaluate`, `dataset` and `serve` accept exactly the same spellings and
//! refuse the same mistakes with the same words.

use std::fmt;
use std::str::FromStr;

/// A non-empty, inclusive range of house seeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SeedRange {
    pub first: u64,
    pub last: u64,
}

/// Why a seed range was refused; the message quotes the text as given.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum SeedsError {
    #[error("seeds '{0}': expected A..B (B excluded), A..=B or one seed, e.g. 0..100")]
    Syntax(String),
    #[error("seeds '{0}' holds no seed")]
    Empty(String),
}

impl SeedRange {
    /// The seeds, in increasing order.
    pub fn iter(&self) -> impl Iterator<Item = u64> + use<> {
        self.first..=self.last
    }

    /// How many seeds.
    #[must_use]
    pub fn len(&self) -> u64 {
        self.last - self.first + 1
    }

    /// Never true: a range holds at least one seed.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        false
    }
}

impl fmt::Display for SeedRange {
    /// The canonical `A..=B` form.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}..={}", self.first, self.last)
    }
}

impl FromStr for SeedRange {
    type Err = SeedsError;

    fn from_str(text: &str) -> Result<SeedRange, SeedsError> {
        let num = |s: &str| s.trim().parse::<u64>().map_err(|_| SeedsError::Syntax(text.to_string()));
        let empty = || SeedsError::Empty(text.to_string());
        let t = text.trim();
        let (first, last) = if let Some((a, b)) = t.split_once("..=") {
            (num(a)?, num(b)?)
        } else if let Some((a, b)) = t.split_once("..") {
            let (a, b) = (num(a)?, num(b)?);
            (a, b.checked_sub(1).filter(|&last| last >= a).ok_or_else(empty)?)
        } else {
            let a = num(t)?;
            (a, a)
        };
        if last < first {
            return Err(empty());
        }
        Ok(SeedRange { first, last })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_spelling_and_every_mistake() {
        assert_eq!("3..6".parse(), Ok(SeedRange { first: 3, last: 5 }));
        assert_eq!(" 3..=6 ".parse(), Ok(SeedRange { first: 3, last: 6 }));
        assert_eq!("7".parse(), Ok(SeedRange { first: 7, last: 7 }));
        assert_eq!("0..1".parse::<SeedRange>().map(|r| r.iter().collect::<Vec<_>>()), Ok(vec![0]));
        assert_eq!("3..3".parse::<SeedRange>(), Err(SeedsError::Empty("3..3".into())));
        assert_eq!("0..0".parse::<SeedRange>(), Err(SeedsError::Empty("0..0".into())));
        assert!(matches!("5..=4".parse::<SeedRange>(), Err(SeedsError::Empty(_))));
        for bad in ["a..4", "-1..4", "", "1..2..3", "1.5", "0..=x"] {
            assert!(matches!(bad.parse::<SeedRange>(), Err(SeedsError::Syntax(_))), "{bad}");
        }
        assert_eq!("18446744073709551615".parse::<SeedRange>().map(|r| r.len()), Ok(1));
    }
}
