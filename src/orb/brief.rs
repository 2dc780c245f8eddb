//! rBRIEF descriptors: OpenCV's 7x7 Gaussian pre-blur and its 256-pair rotated pattern.

use std::sync::OnceLock;

use super::pyramid::Level;

/// The 7-tap Gaussian of sigma 2 in OpenCV's integer filter path (Q8): getGaussianKernel(7, 2)
/// = 0.0702, 0.1311, 0.1907, 0.2161, ... scaled by 256 and rounded. The taps sum to 257, not 256;
/// OpenCV's 8-bit separable filter uses them as they are, so do we.
pub const BLUR_KERNEL_Q8: [u32; 7] = [18, 34, 49, 55, 49, 34, 18];

/// Blurs the level's pixels in place with [`BLUR_KERNEL_Q8`] horizontally then vertically,
/// reading the (unblurred) padding around it, as OpenCV's `GaussianBlur` on a level ROI with
/// BORDER_REFLECT_101: each output is `(sum_i k_i sum_j k_j p + 2^15) >> 16`, saturated.
pub(crate) fn blur_level(level: &mut Level, buf: &mut Vec<u16>) {
    let (w, h) = (level.width, level.height);
    assert!(level.border >= 3, "blur needs 3 pixels of padding");
    let rows = h + 6;
    buf.clear();
    buf.resize(rows * w, 0);
    let k = BLUR_KERNEL_Q8;
    for r in 0..rows {
        let start = level.index(-3, r as isize - 3);
        let src = &level.data[start..start + w + 6];
        let out = &mut buf[r * w..(r + 1) * w];
        hblur(src, out, &k);
    }
    for y in 0..h {
        let start = level.index(0, y as isize);
        let out = &mut level.data[start..start + w];
        let b = &buf[..];
        vblur(
            [
                &b[y * w..(y + 1) * w],
                &b[(y + 1) * w..(y + 2) * w],
                &b[(y + 2) * w..(y + 3) * w],
                &b[(y + 3) * w..(y + 4) * w],
                &b[(y + 4) * w..(y + 5) * w],
                &b[(y + 5) * w..(y + 6) * w],
                &b[(y + 6) * w..(y + 7) * w],
            ],
            out,
            &k,
        );
    }
}

#[inline(always)]
fn hblur(src: &[u8], out: &mut [u16], k: &[u32; 7]) {
    let n = out.len();
    let s = &src[..n + 6];
    for x in 0..n {
        let v = k[0] * u32::from(s[x])
            + k[1] * u32::from(s[x + 1])
            + k[2] * u32::from(s[x + 2])
            + k[3] * u32::from(s[x + 3])
            + k[4] * u32::from(s[x + 4])
            + k[5] * u32::from(s[x + 5])
            + k[6] * u32::from(s[x + 6]);
        // At most 257 * 255 = 65535: fits.
        out[x] = v as u16;
    }
}

#[inline(always)]
fn vblur(r: [&[u16]; 7], out: &mut [u8], k: &[u32; 7]) {
    let n = out.len();
    let r = r.map(|row| &row[..n]);
    for x in 0..n {
        let v = k[0] * u32::from(r[0][x])
            + k[1] * u32::from(r[1][x])
            + k[2] * u32::from(r[2][x])
            + k[3] * u32::from(r[3][x])
            + k[4] * u32::from(r[4][x])
            + k[5] * u32::from(r[5][x])
            + k[6] * u32::from(r[6][x]);
        out[x] = ((v + (1 << 15)) >> 16).min(255) as u8;
    }
}

/// The 256 point pairs (x1, y1, x2, y2) of OpenCV's 31x31 rBRIEF pattern, in bit order.
pub fn pattern() -> &'static [[i8; 4]; 256] {
    static PATTERN: OnceLock<[[i8; 4]; 256]> = OnceLock::new();
    PATTERN.get_or_init(|| {
        let mut out = [[0i8; 4]; 256];
        let mut n = 0;
        for line in PATTERN_31.lines() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') || line.starts_with('x') {
                continue;
            }
            let v: Vec<i8> =
                line.split(',').map(|t| t.trim().parse().expect("pattern_31.csv holds integers")).collect();
            out[n] = [v[0], v[1], v[2], v[3]];
            n += 1;
        }
        assert_eq!(n, 256, "pattern_31.csv holds 256 pairs");
        out
    })
}

/// OpenCV's bit_pattern_31_ (BSD licence, see LICENSE-orb-pattern.txt beside it).
pub const PATTERN_31: &str = include_str!("pattern_31.csv");

/// The descriptor of level pixel (x, y) with orientation `angle_deg`, read from the blurred
/// level: pattern points rotated by the angle in f32, rounded half to even, compared pairwise;
/// bit j of byte i is 1 when I(p1) < I(p2) for pair 8 i + j.
#[must_use]
pub fn descriptor_at(level: &Level, x: usize, y: usize, angle_deg: f32) -> [u8; 32] {
    let angle = angle_deg * (std::f64::consts::PI / 180.0) as f32;
    let a = f64::from(angle).cos() as f32;
    let b = f64::from(angle).sin() as f32;
    let centre = level.index(x as isize, y as isize) as isize;
    let stride = level.stride as isize;
    let d = &level.data;
    let value = |px: i8, py: i8| -> u8 {
        let (px, py) = (f32::from(px), f32::from(py));
        let rx = (px * a - py * b).round_ties_even() as isize;
        let ry = (px * b + py * a).round_ties_even() as isize;
        d[(centre + ry * stride + rx) as usize]
    };
    let mut desc = [0u8; 32];
    for (i, byte) in desc.iter_mut().enumerate() {
        let mut v = 0u8;
        for j in 0..8 {
            let [x1, y1, x2, y2] = pattern()[8 * i + j];
            v |= u8::from(value(x1, y1) < value(x2, y2)) << j;
        }
        *byte = v;
    }
    desc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blur_kernel_is_opencv_gaussian_in_q8() {
        let g: Vec<f64> = (-3..=3).map(|i: i32| (-f64::from(i * i) / 8.0).exp()).collect();
        let sum: f64 = g.iter().sum();
        let q: Vec<u32> = g.iter().map(|v| ((v / sum) as f32 * 256.0).round() as u32).collect();
        assert_eq!(q, BLUR_KERNEL_Q8.to_vec());
    }

    #[test]
    fn pattern_parses_with_256_pairs_inside_the_patch() {
        let p = pattern();
        assert_eq!(p[0], [8, -3, 9, 5]);
        assert!(p.iter().flatten().all(|v| v.abs() <= 15));
    }
}
