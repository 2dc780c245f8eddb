//! The two SSE building blocks of the packet code's four-ray functions (preparing a quad,
//! testing a quad against a box, gathering a packet's bounds): loading a quad's four floats and
//! choosing per lane by a mask.

use std::arch::x86_64::{__m128, _mm_and_ps, _mm_andnot_ps, _mm_loadu_ps, _mm_or_ps};

use crate::packet::PACKET_RAYS;

/// The four floats `at..at + 4` of a per-ray packet array.
#[inline(always)]
pub(super) fn load(values: &[f32; PACKET_RAYS], at: usize) -> __m128 {
    let quad = &values[at..at + 4];
    // SAFETY: SSE is in every x86-64 CPU (the target's baseline), and `quad` holds the four
    // floats read (the slice index checks `at + 4 <= PACKET_RAYS`).
    unsafe { _mm_loadu_ps(quad.as_ptr()) }
}

/// Per lane, `a` where the mask `m` is all ones, else `b`.
#[inline(always)]
pub(super) fn select(m: __m128, a: __m128, b: __m128) -> __m128 {
    // SAFETY: SSE is in every x86-64 CPU (the target's baseline); no memory is touched.
    unsafe { _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)) }
}
