//! Harris corner response as OpenCV's ORB computes it (orb.cpp `HarrisResponses`).

use super::pyramid::Level;

/// Harris response at level pixel (x, y) over a `block` x `block` window: integer Sobel-style
/// gradients (2 x centre difference + both diagonal differences), integer sums, then
/// `(a b - c^2 - k (a + b)^2) * (1 / (4 * block * 255))^4` in f32, in OpenCV's operation order
/// so that ties and the "keep n best" cut fall on the same points.
#[must_use]
pub fn harris_response(level: &Level, x: usize, y: usize, block: usize, k: f32) -> f32 {
    let (a, b, c) = if block == 7 { sums7_dispatch(level, x, y) } else { sums(level, x, y, block) };
    let scale = 1.0f32 / ((1 << 2) as f32 * block as f32 * 255.0);
    let scale4 = scale * scale * scale * scale;
    let (af, bf, cf) = (a as f32, b as f32, c as f32);
    (af * bf - cf * cf - k * (af + bf) * (af + bf)) * scale4
}

/// Gradient products summed over the block (any size), pixel by pixel.
fn sums(level: &Level, x: usize, y: usize, block: usize) -> (i32, i32, i32) {
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
    (a, b, c)
}

/// The 7x7 case in 8 lanes (the eighth masked off) so that it vectorises.
#[inline(always)]
fn sums7(level: &Level, x: usize, y: usize) -> (i32, i32, i32) {
    let d = &level.data;
    let load = |row: isize| -> [i32; 10] {
        let start = level.index(x as isize - 4, row);
        let s = &d[start..start + 10];
        std::array::from_fn(|i| i32::from(s[i]))
    };
    const LANE: [i32; 8] = [1, 1, 1, 1, 1, 1, 1, 0];
    let (mut a, mut b, mut c) = ([0i32; 8], [0i32; 8], [0i32; 8]);
    let mut m = load(y as isize - 4);
    let mut cen = load(y as isize - 3);
    for i in -3..=3isize {
        let p = load(y as isize + i + 1);
        for j in 0..8 {
            let ix = ((cen[j + 2] - cen[j]) * 2 + (m[j + 2] - m[j]) + (p[j + 2] - p[j])) * LANE[j];
            let iy = ((p[j + 1] - m[j + 1]) * 2 + (p[j] - m[j]) + (p[j + 2] - m[j + 2])) * LANE[j];
            a[j] += ix * ix;
            b[j] += iy * iy;
            c[j] += ix * iy;
        }
        m = cen;
        cen = p;
    }
    (a.iter().sum(), b.iter().sum(), c.iter().sum())
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn sums7_avx2(level: &Level, x: usize, y: usize) -> (i32, i32, i32) {
    sums7(level, x, y)
}

fn sums7_dispatch(level: &Level, x: usize, y: usize) -> (i32, i32, i32) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        return unsafe { sums7_avx2(level, x, y) };
    }
    sums7(level, x, y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectorised_7x7_sums_equal_the_pixel_loop() {
        let (w, h, border) = (40usize, 30usize, 8usize);
        let stride = w + 2 * border;
        let data: Vec<u8> = (0..stride * (h + 2 * border)).map(|i| ((i * 37) ^ (i >> 3)) as u8).collect();
        let level = Level { width: w, height: h, border, stride, data };
        for (x, y) in [(5, 5), (20, 13), (34, 24)] {
            assert_eq!(sums7(&level, x, y), sums(&level, x, y, 7));
        }
    }
}
