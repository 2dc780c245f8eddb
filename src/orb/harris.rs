//! Harris corner response as OpenCV's ORB computes it (orb.cpp `HarrisResponses`).

use super::pyramid::Level;

/// Harris response at level pixel (x, y) over a `block` x `block` window: integer Sobel-style
/// gradients (2 x centre difference + both diagonal differences), integer sums, then
/// `(a b - c^2 - k (a + b)^2) * (1 / (4 * block * 255))^4` in f32, in OpenCV's operation order
/// so that ties and the "keep n best" cut fall on the same points.
#[must_use]
pub fn harris_response(level: &Level, x: usize, y: usize, block: usize, k: f32) -> f32 {
    let r = (block / 2) as isize;
    let s = level.stride as isize;
    let d = &level.data;
    let (mut a, mut b, mut c) = (0i32, 0i32, 0i32);
    for i in 0..block as isize {
        let row = level.index(x as isize - r, y as isize - r + i) as isize;
        for j in 0..block as isize {
            let p = row + j;
            let at = |o: isize| i32::from(d[(p + o) as usize]);
            let ix = (at(1) - at(-1)) * 2 + (at(-s + 1) - at(-s - 1)) + (at(s + 1) - at(s - 1));
            let iy = (at(s) - at(-s)) * 2 + (at(s - 1) - at(-s - 1)) + (at(s + 1) - at(-s + 1));
            a += ix * ix;
            b += iy * iy;
            c += ix * iy;
        }
    }
    let scale = 1.0f32 / ((1 << 2) as f32 * block as f32 * 255.0);
    let scale4 = scale * scale * scale * scale;
    let (af, bf, cf) = (a as f32, b as f32, c as f32);
    (af * bf - cf * cf - k * (af + bf) * (af + bf)) * scale4
}
