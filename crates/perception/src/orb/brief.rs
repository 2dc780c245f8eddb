//! rBRIEF descriptors: OpenCV's 7x7 Gaussian pre-blur and its 256-pair rotated pattern.

use std::sync::OnceLock;

use super::pyramid::Level;

/// The 7-tap Gaussian of sigma 2 as OpenCV's `getGaussianKernel(7, 2, CV_32F)`:
/// exp(-i^2 / 8) normalised to sum 1, in f32 (bit patterns checked against OpenCV 5.0.0:
/// 0x3d8fafb1, 0x3e06387e, 0x3e434a39, 0x3e5d4ae0).
pub const BLUR_KERNEL: [f32; 7] = [
    f32::from_bits(0x3d8f_afb1),
    f32::from_bits(0x3e06_387e),
    f32::from_bits(0x3e43_4a39),
    f32::from_bits(0x3e5d_4ae0),
    f32::from_bits(0x3e43_4a39),
    f32::from_bits(0x3e06_387e),
    f32::from_bits(0x3d8f_afb1),
];

/// Blurs the level's pixels in place, reading the (unblurred) padding around them, as OpenCV's
/// `GaussianBlur(level_roi, 7x7, sigma 2, BORDER_REFLECT_101)` in ORB. On a sub-matrix OpenCV
/// skips its fixed-point path and runs the generic separable filter: a horizontal pass u8 -> f32
/// (taps accumulated left to right with fused multiply-adds, as its AVX2 row filter), a vertical
/// pass pairing symmetric taps, then rounding half to even with saturation. The fused row pass
/// took identical descriptors from 99.98 % to 100.00 % on the interop images. Integer approximations (the Q8 kernels) flip 20-75 % of descriptors on
/// near-ties, so the float arithmetic is kept.
pub(crate) fn blur_level(level: &mut Level, buf: &mut Vec<f32>) {
    let (w, h) = (level.width, level.height);
    assert!(level.border >= 3, "blur needs 3 pixels of padding");
    // A ring of 8 horizontally filtered rows (row r lives in slot r % 8) keeps the working set in
    // cache; output row y needs filtered rows y - 3 ..= y + 3, and is written only after the
    // source rows it needs were filtered (source row y + 3 is read before row y is overwritten).
    buf.clear();
    buf.resize(8 * w, 0.0);
    let filter_row = |level: &Level, buf: &mut [f32], r: isize| {
        let start = level.index(-3, r);
        let slot = (r + 3) as usize % 8;
        blur_dispatch_h(&level.data[start..start + w + 6], &mut buf[slot * w..(slot + 1) * w]);
    };
    for r in -3..3 {
        filter_row(level, buf, r);
    }
    for y in 0..h as isize {
        filter_row(level, buf, y + 3);
        let rows: [&[f32]; 7] = std::array::from_fn(|k| {
            let slot = (y as usize + k) % 8;
            &buf[slot * w..(slot + 1) * w]
        });
        let start = level.index(0, y);
        blur_dispatch_v(rows, &mut level.data[start..start + w]);
    }
}

#[inline(always)]
fn hblur(src: &[u8], out: &mut [f32]) {
    let k = BLUR_KERNEL;
    let n = out.len();
    let s = &src[..n + 6];
    for x in 0..n {
        let mut v = k[0] * f32::from(s[x]);
        v = k[1].mul_add(f32::from(s[x + 1]), v);
        v = k[2].mul_add(f32::from(s[x + 2]), v);
        v = k[3].mul_add(f32::from(s[x + 3]), v);
        v = k[4].mul_add(f32::from(s[x + 4]), v);
        v = k[5].mul_add(f32::from(s[x + 5]), v);
        v = k[6].mul_add(f32::from(s[x + 6]), v);
        out[x] = v;
    }
}

/// `rows` are 7 consecutive filtered rows; the output row is the middle one.
#[inline(always)]
fn vblur(rows: [&[f32]; 7], out: &mut [u8]) {
    let k = BLUR_KERNEL;
    let r: [&[f32]; 7] = rows.map(|row| &row[..out.len()]);
    for x in 0..out.len() {
        let mut v = k[3] * r[3][x];
        v += k[2] * (r[2][x] + r[4][x]);
        v += k[1] * (r[1][x] + r[5][x]);
        v += k[0] * (r[0][x] + r[6][x]);
        let r = round_half_even(v).clamp(0.0, 255.0);
        // SAFETY: r is finite (sums of finite products) and within 0..=255 after the clamp.
        out[x] = unsafe { r.to_int_unchecked::<i32>() } as u8;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn hblur_avx2(src: &[u8], out: &mut [f32]) {
    hblur(src, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn vblur_avx2(rows: [&[f32]; 7], out: &mut [u8]) {
    vblur(rows, out);
}

fn blur_dispatch_h(src: &[u8], out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports AVX2 and FMA (checked just above).
        unsafe { hblur_avx2(src, out) };
        return;
    }
    hblur(src, out);
}

fn blur_dispatch_v(rows: [&[f32]; 7], out: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        unsafe { vblur_avx2(rows, out) };
        return;
    }
    vblur(rows, out);
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

/// Round half to even for |x| < 2^22 (the default FP rounding mode applied by adding and
/// removing 1.5 * 2^23), as OpenCV's cvRound on x86; avoids a libm call where SSE4.1 is not
/// enabled at compile time.
#[inline(always)]
fn round_half_even(x: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0;
    (x + MAGIC) - MAGIC
}

/// The pattern as f32 columns (x of all 512 points, then y), for the vectorised rotation.
fn pattern_xy() -> &'static ([f32; 512], [f32; 512]) {
    static XY: OnceLock<([f32; 512], [f32; 512])> = OnceLock::new();
    XY.get_or_init(|| {
        let mut xs = [0f32; 512];
        let mut ys = [0f32; 512];
        for (i, [x1, y1, x2, y2]) in pattern().iter().enumerate() {
            xs[2 * i] = f32::from(*x1);
            ys[2 * i] = f32::from(*y1);
            xs[2 * i + 1] = f32::from(*x2);
            ys[2 * i + 1] = f32::from(*y2);
        }
        (xs, ys)
    })
}

/// Offsets (relative to the centre) of the 512 rotated, rounded pattern points.
#[inline(always)]
fn rotated_offsets(a: f32, b: f32, stride: i32, out: &mut [i32; 512]) {
    const MAGIC: f32 = 12_582_912.0;
    // Integer part of x + 1.5 * 2^23 sits in the low mantissa bits, offset by 0x4B40_0000.
    const BIAS: i32 = 0x4B40_0000;
    let (xs, ys) = pattern_xy();
    for k in 0..512 {
        let (px, py) = (xs[k], ys[k]);
        let rx = ((px * a - py * b) + MAGIC).to_bits() as i32 - BIAS;
        let ry = ((px * b + py * a) + MAGIC).to_bits() as i32 - BIAS;
        out[k] = ry * stride + rx;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn rotated_offsets_avx2(a: f32, b: f32, stride: i32, out: &mut [i32; 512]) {
    rotated_offsets(a, b, stride, out);
}

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
    // The patch around the centre: rotated pattern points stay within 19 pixels of it.
    let reach = 20 * stride + 20;
    let d = &level.data[(centre - reach) as usize..=(centre + reach) as usize];
    let mut offs = [0i32; 512];
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        unsafe { rotated_offsets_avx2(a, b, stride as i32, &mut offs) };
    } else {
        rotated_offsets(a, b, stride as i32, &mut offs);
    }
    #[cfg(not(target_arch = "x86_64"))]
    rotated_offsets(a, b, stride as i32, &mut offs);
    let value = |k: usize| d[(reach + offs[k] as isize) as usize];
    let mut desc = [0u8; 32];
    for (i, byte) in desc.iter_mut().enumerate() {
        let mut v = 0u8;
        for j in 0..8 {
            let k = 2 * (8 * i + j);
            v |= u8::from(value(k) < value(k + 1)) << j;
        }
        *byte = v;
    }
    desc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blur_kernel_is_the_normalised_gaussian() {
        let g: Vec<f64> = (-3..=3).map(|i: i32| (-f64::from(i * i) / 8.0).exp()).collect();
        let sum: f64 = g.iter().sum();
        for (k, v) in BLUR_KERNEL.iter().zip(&g) {
            assert_eq!(*k, (v / sum) as f32);
        }
    }

    #[test]
    fn dispatched_row_filter_equals_the_portable_one() {
        let src: Vec<u8> = (0..706u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8).collect();
        let (mut a, mut b) = (vec![0f32; 700], vec![0f32; 700]);
        hblur(&src, &mut a);
        blur_dispatch_h(&src, &mut b);
        assert_eq!(a, b);
    }

    #[test]
    fn magic_rounding_is_half_to_even() {
        for (x, want) in
            [(0.5f32, 0.0f32), (1.5, 2.0), (2.5, 2.0), (-0.5, 0.0), (-1.5, -2.0), (3.49, 3.0), (-7.51, -8.0)]
        {
            assert_eq!(round_half_even(x), want, "{x}");
        }
    }

    #[test]
    fn pattern_parses_with_256_pairs_inside_the_patch() {
        let p = pattern();
        assert_eq!(p[0], [8, -3, 9, 5]);
        assert!(p.iter().flatten().all(|v| v.abs() <= 15));
    }
}
