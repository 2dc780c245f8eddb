//! COCO run-length encoding of binary masks, as pycocotools' `maskApi.c` defines it.
//!
//! A mask of `height x width` pixels is read in **column-major** order (down the first
//! column, then the next), and `counts` holds the lengths of alternating runs, starting with
//! a run of zeros (which is 0 long when the first pixel is set). The runs sum to
//! `height * width`.
//!
//! The compressed string form (`rleToString` / `rleFrString` in `maskApi.c`): each count,
//! after the first three minus the count two places back (so a run is stored as its change
//! from the previous run of the same value), is written as a little-endian sequence of 5-bit
//! groups, sign-extended from the top bit of the last group; each group becomes one
//! character `48 + group`, with bit `0x20` set on every group but the last.

use std::collections::{BTreeMap, BTreeSet};

use serde::{Deserialize, Serialize};

/// Why a compressed RLE string could not be read.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum RleError {
    #[error("RLE string: byte {index} ({byte:#04x}) is outside '0'..'o'")]
    BadByte { index: usize, byte: u8 },
    #[error("RLE string ends inside a count")]
    Truncated,
    #[error("RLE runs sum to {sum}, the mask has {pixels} pixels")]
    WrongLength { sum: i64, pixels: u64 },
}

/// A run-length encoded binary mask.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rle {
    pub height: u32,
    pub width: u32,
    /// Alternating run lengths (zeros first), column-major.
    pub counts: Vec<u32>,
}

/// The JSON form COCO stores: `{"size": [height, width], "counts": "<compressed>"}`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RleJson {
    pub size: [u32; 2],
    pub counts: String,
}

impl Rle {
    /// Encodes a row-major mask (`mask[y * width + x]`).
    ///
    /// # Panics
    /// If `mask.len() != width * height`.
    #[must_use]
    pub fn from_mask(mask: &[bool], width: u32, height: u32) -> Rle {
        let (w, h) = (width as usize, height as usize);
        assert_eq!(mask.len(), w * h, "mask size");
        let mut counts = Vec::new();
        let mut value = false;
        let mut run = 0u32;
        for x in 0..w {
            for y in 0..h {
                let v = mask[y * w + x];
                if v != value {
                    counts.push(run);
                    run = 0;
                    value = v;
                }
                run += 1;
            }
        }
        counts.push(run);
        Rle { height, width, counts }
    }

    /// The row-major mask.
    #[must_use]
    pub fn decode(&self) -> Vec<bool> {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut mask = vec![false; w * h];
        let mut p = 0usize;
        for (k, &c) in self.counts.iter().enumerate() {
            if k % 2 == 1 {
                for q in p..p + c as usize {
                    mask[(q % h) * w + q / h] = true;
                }
            }
            p += c as usize;
        }
        mask
    }

    /// Set pixels (COCO's segment `area`).
    #[must_use]
    pub fn area(&self) -> u64 {
        self.counts.iter().skip(1).step_by(2).map(|&c| u64::from(c)).sum()
    }

    /// Tight box of the set pixels, `[x, y, width, height]` (pixel `(x, y)` covers
    /// `[x, x + 1) x [y, y + 1)`); `None` for an empty mask.
    #[must_use]
    pub fn bbox(&self) -> Option<[u32; 4]> {
        let h = u64::from(self.height);
        let (mut x0, mut y0, mut x1, mut y1) = (u64::MAX, u64::MAX, 0u64, 0u64);
        let mut p = 0u64;
        for (k, &c) in self.counts.iter().enumerate() {
            let c = u64::from(c);
            if k % 2 == 1 && c > 0 {
                let (first, last) = (p, p + c - 1);
                let (ca, cb) = (first / h, last / h);
                x0 = x0.min(ca);
                x1 = x1.max(cb);
                if ca == cb {
                    y0 = y0.min(first % h);
                    y1 = y1.max(last % h);
                } else {
                    // A run past a column end covers the bottom row of one column and the top
                    // row of the next: the box spans every row.
                    y0 = 0;
                    y1 = h - 1;
                }
            }
            p += c;
        }
        (x0 != u64::MAX).then(|| [x0 as u32, y0 as u32, (x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32])
    }

    /// The compressed string (`rleToString`).
    #[must_use]
    pub fn to_compressed(&self) -> String {
        let mut s = String::new();
        for (i, &c) in self.counts.iter().enumerate() {
            let mut x = i64::from(c);
            if i > 2 {
                x -= i64::from(self.counts[i - 2]);
            }
            loop {
                let mut group = (x & 0x1f) as u8;
                x >>= 5;
                let more = if group & 0x10 != 0 { x != -1 } else { x != 0 };
                if more {
                    group |= 0x20;
                }
                s.push(char::from(group + 48));
                if !more {
                    break;
                }
            }
        }
        s
    }

    /// Reads the compressed string of a `height x width` mask (`rleFrString`).
    ///
    /// # Errors
    /// [`RleError`] for a byte outside the alphabet, a string cut inside a count, or runs that
    /// do not cover the mask exactly.
    pub fn from_compressed(text: &str, height: u32, width: u32) -> Result<Rle, RleError> {
        let bytes = text.as_bytes();
        let mut counts: Vec<i64> = Vec::new();
        let mut p = 0;
        while p < bytes.len() {
            let mut x = 0i64;
            let mut k = 0u32;
            loop {
                let Some(&b) = bytes.get(p) else { return Err(RleError::Truncated) };
                if !(48..48 + 64).contains(&b) || k > 12 {
                    return Err(RleError::BadByte { index: p, byte: b });
                }
                let group = i64::from(b - 48);
                x |= (group & 0x1f) << (5 * k);
                p += 1;
                k += 1;
                if group & 0x20 == 0 {
                    if group & 0x10 != 0 {
                        x |= -1i64 << (5 * k);
                    }
                    break;
                }
            }
            if counts.len() > 2 {
                x += counts[counts.len() - 2];
            }
            counts.push(x);
        }
        let pixels = u64::from(height) * u64::from(width);
        let sum: i64 = counts.iter().sum();
        if counts.iter().any(|&c| !(0..=i64::from(u32::MAX)).contains(&c)) || sum != pixels as i64 {
            return Err(RleError::WrongLength { sum, pixels });
        }
        Ok(Rle { height, width, counts: counts.into_iter().map(|c| c as u32).collect() })
    }

    /// The COCO JSON form.
    #[must_use]
    pub fn to_json(&self) -> RleJson {
        RleJson { size: [self.height, self.width], counts: self.to_compressed() }
    }
}

/// The RLE of every instance in `wanted`, from a row-major instance-id buffer, in one
/// column-major pass. Instances of `wanted` absent from the buffer are left out.
///
/// # Panics
/// If `ids.len() != width * height`.
#[must_use]
pub fn encode_instances(ids: &[u32], width: u32, height: u32, wanted: &BTreeSet<u32>) -> BTreeMap<u32, Rle> {
    let (w, h) = (width as usize, height as usize);
    assert_eq!(ids.len(), w * h, "instance buffer size");
    // Per instance: counts so far and the column-major position they cover up to.
    let mut acc: BTreeMap<u32, (Vec<u32>, usize)> = BTreeMap::new();
    for x in 0..w {
        for y in 0..h {
            let id = ids[y * w + x];
            if id == 0 || !wanted.contains(&id) {
                continue;
            }
            let p = x * h + y;
            let (counts, cursor) = acc.entry(id).or_insert_with(|| (Vec::new(), 0));
            if !counts.is_empty() && counts.len() % 2 == 0 && p == *cursor {
                *counts.last_mut().expect("non-empty") += 1;
            } else {
                counts.push((p - *cursor) as u32);
                counts.push(1);
            }
            *cursor = p + 1;
        }
    }
    acc.into_iter()
        .map(|(id, (mut counts, cursor))| {
            if cursor < w * h {
                counts.push((w * h - cursor) as u32);
            }
            (id, Rle { height, width, counts })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 3 rows x 2 columns:
    /// ```text
    /// 0 1
    /// 1 1
    /// 0 0
    /// ```
    /// Column-major: 0 1 0 | 1 1 0, runs 1 zero, 1 one, 1 zero, 2 ones, 1 zero.
    /// Compressed: 1, 1, 1 stay; then 2 - 1 = 1 and 1 - 1 = 0: "11110".
    #[test]
    fn hand_worked_example() {
        let mask = [false, true, true, true, false, false];
        let rle = Rle::from_mask(&mask, 2, 3);
        assert_eq!(rle.counts, vec![1, 1, 1, 2, 1]);
        assert_eq!(rle.to_compressed(), "11110");
        assert_eq!(rle.area(), 3);
        assert_eq!(rle.bbox(), Some([0, 0, 2, 2]));
        assert_eq!(Rle::from_compressed("11110", 3, 2).unwrap(), rle);
        assert_eq!(rle.decode(), mask.to_vec());
    }

    /// Multi-group and negative deltas: 100 = 3 * 32 + 4 -> groups 4 (| 0x20) and 3 -> "T3";
    /// a delta of -1 is the single group 31 -> 'O'.
    #[test]
    fn long_and_negative_counts() {
        let rle = Rle { height: 1, width: 204, counts: vec![100, 1, 1, 100, 2] };
        // counts[3] - counts[1] = 99 -> 99 = 3 * 32 + 3: groups 3 | 0x20 ('S'), 3 ('3');
        // counts[4] - counts[2] = 1 -> '1'.
        assert_eq!(rle.to_compressed(), "T311S31");
        let neg = Rle { height: 1, width: 6, counts: vec![1, 2, 1, 1, 1] };
        // counts[3] - counts[1] = -1 -> 'O'; counts[4] - counts[2] = 0 -> '0'.
        assert_eq!(neg.to_compressed(), "121O0");
        assert_eq!(Rle::from_compressed("121O0", 1, 6).unwrap(), neg);
        assert_eq!(Rle::from_compressed("T311S31", 1, 204).unwrap(), rle);
    }

    #[test]
    fn leading_one_and_empty_masks() {
        let rle = Rle::from_mask(&[true, false], 1, 2);
        assert_eq!(rle.counts, vec![0, 1, 1]);
        assert_eq!(rle.bbox(), Some([0, 0, 1, 1]));
        let empty = Rle::from_mask(&[false; 6], 3, 2);
        assert_eq!(empty.counts, vec![6]);
        assert_eq!(empty.bbox(), None);
        assert_eq!(empty.area(), 0);
    }

    #[test]
    fn bad_strings_are_refused() {
        assert!(matches!(Rle::from_compressed("1\u{7f}", 1, 1), Err(RleError::BadByte { .. })));
        assert_eq!(Rle::from_compressed("T", 1, 100), Err(RleError::Truncated));
        assert!(matches!(Rle::from_compressed("5", 2, 2), Err(RleError::WrongLength { .. })));
    }

    proptest::proptest! {
        /// Random masks: encode, compress, read back, decode; the instance encoder agrees with
        /// the single-mask one; bbox and area match a direct scan.
        #[test]
        fn round_trip(w in 1u32..12, h in 1u32..12, seed in 0u64..10_000) {
            let n = (w * h) as usize;
            let ids: Vec<u32> = (0..n)
                .map(|i| (scene_gen_core::rng::fnv1a64(format!("{seed}/{i}").as_bytes()) % 4) as u32)
                .collect();
            let wanted: BTreeSet<u32> = [1, 2, 3].into();
            let all = encode_instances(&ids, w, h, &wanted);
            for id in 1..4u32 {
                let mask: Vec<bool> = ids.iter().map(|&v| v == id).collect();
                let rle = Rle::from_mask(&mask, w, h);
                proptest::prop_assert_eq!(rle.counts.iter().map(|&c| u64::from(c)).sum::<u64>(), u64::from(w * h));
                let back = Rle::from_compressed(&rle.to_compressed(), h, w).unwrap();
                proptest::prop_assert_eq!(&back, &rle);
                proptest::prop_assert_eq!(back.decode(), mask.clone());
                let count = mask.iter().filter(|&&b| b).count() as u64;
                proptest::prop_assert_eq!(rle.area(), count);
                let mut bb: Option<[u32; 4]> = None;
                for y in 0..h {
                    for x in 0..w {
                        if mask[(y * w + x) as usize] {
                            bb = Some(match bb {
                                None => [x, y, x, y],
                                Some([a, b, c, d]) => [a.min(x), b.min(y), c.max(x), d.max(y)],
                            });
                        }
                    }
                }
                let bb = bb.map(|[a, b, c, d]| [a, b, c - a + 1, d - b + 1]);
                proptest::prop_assert_eq!(rle.bbox(), bb);
                proptest::prop_assert_eq!(all.get(&id).cloned(), (count > 0).then_some(rle));
            }
        }
    }
}
