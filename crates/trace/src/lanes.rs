//! Structure of arrays over the lanes of a packet: one lane per ray, one array per coordinate.
//!
//! The per-packet stages of the renderer (surfaces, materials, point lights) are written as
//! plain loops over the lanes that LLVM's loop vectoriser turns into vector code (eight lanes
//! at a time in the AVX2 build of the tile loop, `scene_gen_core::simd`). What it vectorises, found by
//! compiling with `-C remark=loop-vectorize`: a loop over `k` whose body names each coordinate
//! as its own variable and writes whole arrays, with choices made by [`select`] and conditions
//! joined by `&` and `|`. An inner loop over the three axes inside the loop over the lanes, or
//! a write read back in the same loop through a structure, left it scalar ("cannot identify
//! array bounds"); `&&` and `||` branch, and the cost model then kept a loop scalar. A store
//! of a nested branchy choice can come out as AVX masked stores (`vmaskmovps`, one per arm),
//! which AMD cores run as microcode: [`select`] and [`negate_if`] are bit operations for that
//! reason; check the assembly after writing a new loop.

use glam::Vec3;

pub use crate::packet::PACKET_RAYS as N;

/// One `f32` per lane.
pub type Lanes = [f32; N];
/// A vector per lane, stored per axis.
pub type Lanes3 = [Lanes; 3];

/// Lane `k` of a vector stored per axis.
#[must_use]
#[inline(always)]
pub fn lane3(v: &Lanes3, k: usize) -> Vec3 {
    Vec3::new(v[0][k], v[1][k], v[2][k])
}

/// `a` where `c` holds, else `b`: a blend in vector code, in bit operations. Why not
/// `if c { a } else { b }`: LLVM turned stores of such nested choices into AVX masked stores
/// (`vmaskmovps`, one per arm), which AMD cores run as slow microcode; with no branch to see,
/// it stores a blend. The same value bit for bit; in the other loops, the same code (the
/// instructions of an image, and of the ray batches, within 0.01 % by callgrind).
#[must_use]
#[inline(always)]
pub fn select(c: bool, a: f32, b: f32) -> f32 {
    let take_a = u32::from(c).wrapping_neg();
    f32::from_bits((a.to_bits() & take_a) | (b.to_bits() & !take_a))
}

/// `-x` where `c` holds, else `x`, by its sign bit (what `-x` does), with no branch.
#[must_use]
#[inline(always)]
pub fn negate_if(c: bool, x: f32) -> f32 {
    f32::from_bits(x.to_bits() ^ (u32::from(c) << 31))
}

/// Indices of the set bits of `mask`, lowest first.
#[inline(always)]
pub fn bits(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            i
        })
    })
}

/// The bits of the lanes where `c` holds.
#[must_use]
#[inline(always)]
pub fn mask_of(c: &[bool; N]) -> u64 {
    let mut mask = 0u64;
    for (k, &c) in c.iter().enumerate() {
        mask |= u64::from(c) << k;
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The bitwise forms give the branchy ones bit for bit, NaN, infinities and signed
        /// zeros included (any bit pattern is an `f32`).
        #[test]
        fn bitwise_blends_are_the_branchy_ones(c: bool, a_bits: u32, b_bits: u32) {
            let (a, b) = (f32::from_bits(a_bits), f32::from_bits(b_bits));
            prop_assert_eq!(select(c, a, b).to_bits(), (if c { a } else { b }).to_bits());
            prop_assert_eq!(negate_if(c, a).to_bits(), (if c { -a } else { a }).to_bits());
        }
    }
}
