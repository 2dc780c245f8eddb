//! The scale pyramid: level sizes, per-level feature budgets, OpenCV's bit-exact bilinear resize
//! (`INTER_LINEAR_EXACT`) and reflect-101 padding.

use super::GrayView;

/// One pyramid level: `width` x `height` pixels surrounded by `border` pixels of reflect-101
/// padding, stored row-major with `stride = width + 2 * border`.
#[derive(Clone, Debug)]
pub struct Level {
    pub width: usize,
    pub height: usize,
    pub border: usize,
    pub stride: usize,
    pub data: Vec<u8>,
}

impl Level {
    /// Index into `data` of level pixel (x, y); x, y may reach into the padding.
    #[inline(always)]
    #[must_use]
    pub fn index(&self, x: isize, y: isize) -> usize {
        ((y + self.border as isize) as usize) * self.stride + (x + self.border as isize) as usize
    }

    /// Pixel (x, y) of the level (padding reachable with coordinates down to -border).
    #[inline(always)]
    #[must_use]
    pub fn at(&self, x: isize, y: isize) -> u8 {
        self.data[self.index(x, y)]
    }

    /// Row `y` of the level, without padding.
    #[must_use]
    pub fn row(&self, y: usize) -> &[u8] {
        let start = self.index(0, y as isize);
        &self.data[start..start + self.width]
    }

    /// The level's pixels without padding, row-major.
    #[must_use]
    pub fn to_unpadded(&self) -> Vec<u8> {
        (0..self.height).flat_map(|y| self.row(y).iter().copied()).collect()
    }
}

/// Scale of level `l` relative to the input: `(float)pow(scale_factor, l)` as OpenCV's getScale.
#[must_use]
pub fn level_scale(l: usize, scale_factor: f64) -> f32 {
    scale_factor.powf(l as f64) as f32
}

/// Size of level `l`: round-half-even of (cols / scale, rows / scale) computed in f32, as OpenCV.
#[must_use]
pub fn level_size(width: usize, height: usize, l: usize, scale_factor: f64) -> (usize, usize) {
    let s = level_scale(l, scale_factor);
    let w = (width as f32 / s).round_ties_even().max(0.0) as usize;
    let h = (height as f32 / s).round_ties_even().max(0.0) as usize;
    (w, h)
}

/// Features wanted per level: a geometric series in f32 with each term rounded half to even,
/// the last level taking the remainder (OpenCV's ORB_Impl::detectAndCompute).
#[must_use]
pub fn features_per_level(n_features: usize, scale_factor: f64, n_levels: usize) -> Vec<usize> {
    if n_levels == 0 {
        return Vec::new();
    }
    let factor = (1.0 / scale_factor) as f32;
    let mut per_scale = n_features as f32 * (1.0 - factor) / (1.0 - f64::from(factor).powf(n_levels as f64) as f32);
    let mut out = Vec::with_capacity(n_levels);
    let mut sum = 0usize;
    for _ in 0..n_levels - 1 {
        let n = per_scale.round_ties_even().max(0.0) as usize;
        out.push(n);
        sum += n;
        per_scale *= factor;
    }
    out.push(n_features.saturating_sub(sum));
    out
}

/// OpenCV's `borderInterpolate` for BORDER_REFLECT_101 (`gfedcb|abcdefgh|gfedcba`).
#[must_use]
pub fn reflect101(mut p: isize, n: usize) -> usize {
    let n = n as isize;
    if n == 1 {
        return 0;
    }
    while p < 0 || p >= n {
        p = if p < 0 { -p } else { 2 * n - 2 - p };
    }
    p as usize
}

/// Per-output-sample source offset and Q8 weights of OpenCV's `interpolationLinear` for a
/// resize from `src` to `dst` samples: `fval = (1 / (dst / src)) * (d + 0.5) - 0.5` in f64,
/// weight of the right sample = round_half_even(frac * 256); outside the source the edge sample
/// is replicated.
fn linear_coeffs(src: usize, dst: usize) -> Vec<(u32, u32, u16, u16)> {
    let inv_scale = dst as f64 / src as f64;
    let scale = 1.0 / inv_scale;
    (0..dst)
        .map(|d| {
            let fval = scale * (d as f64 + 0.5) - 0.5;
            let ival = fval.floor();
            if ival >= 0.0 && src > 1 {
                let i = ival as usize;
                if i < src - 1 {
                    let c1 = ((fval - ival) * 256.0).round_ties_even() as u16;
                    (i as u32, i as u32 + 1, 256 - c1, c1)
                } else {
                    ((src - 1) as u32, (src - 1) as u32, 256, 0)
                }
            } else {
                (0, 0, 256, 0)
            }
        })
        .collect()
}

/// OpenCV's `resize(..., INTER_LINEAR_EXACT)` for 8-bit grey: a horizontal pass giving Q8 values
/// (`p0 * c0 + p1 * c1`, exact), a vertical pass in Q16, rounded half up and saturated.
///
/// `src`/`dst` are row-major with the given strides.
#[allow(clippy::too_many_arguments)]
pub fn resize_linear_exact(
    src: &[u8],
    src_stride: usize,
    sw: usize,
    sh: usize,
    dst: &mut [u8],
    dst_stride: usize,
    dw: usize,
    dh: usize,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        unsafe { resize_avx2(src, src_stride, sw, sh, dst, dst_stride, dw, dh) };
        return;
    }
    resize_impl(src, src_stride, sw, sh, dst, dst_stride, dw, dh);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
unsafe fn resize_avx2(
    src: &[u8],
    src_stride: usize,
    sw: usize,
    sh: usize,
    dst: &mut [u8],
    dst_stride: usize,
    dw: usize,
    dh: usize,
) {
    resize_impl(src, src_stride, sw, sh, dst, dst_stride, dw, dh);
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn resize_impl(
    src: &[u8],
    src_stride: usize,
    sw: usize,
    sh: usize,
    dst: &mut [u8],
    dst_stride: usize,
    dw: usize,
    dh: usize,
) {
    let xc = linear_coeffs(sw, dw);
    let yc = linear_coeffs(sh, dh);
    // Split the x table into arrays for the inner loop.
    let x0: Vec<usize> = xc.iter().map(|c| c.0 as usize).collect();
    let x1: Vec<usize> = xc.iter().map(|c| c.1 as usize).collect();
    let cx0: Vec<u16> = xc.iter().map(|c| c.2).collect();
    let cx1: Vec<u16> = xc.iter().map(|c| c.3).collect();
    // hline's unchecked loads rely on this.
    assert!(x0.iter().chain(&x1).all(|&x| x < sw), "resize offsets inside the source row");
    let mut rows: [Vec<u16>; 2] = [vec![0; dw], vec![0; dw]];
    let mut cached: [usize; 2] = [usize::MAX; 2];
    for (dy, &(y0, y1, cy0, cy1)) in yc.iter().enumerate() {
        let (y0, y1) = (y0 as usize, y1 as usize);
        if cached[0] != y0 {
            if cached[1] == y0 {
                rows.swap(0, 1);
                cached.swap(0, 1);
            } else {
                hline(&src[y0 * src_stride..y0 * src_stride + sw], &x0, &x1, &cx0, &cx1, &mut rows[0]);
                cached[0] = y0;
            }
        }
        if cached[1] != y1 {
            hline(&src[y1 * src_stride..y1 * src_stride + sw], &x0, &x1, &cx0, &cx1, &mut rows[1]);
            cached[1] = y1;
        }
        let drow = &mut dst[dy * dst_stride..dy * dst_stride + dw];
        vline(&rows[0], &rows[1], u32::from(cy0), u32::from(cy1), drow);
    }
}

/// Horizontal pass of one row. Callers guarantee every index in `x0`/`x1` is below
/// `srow.len()` (checked once per resize in `resize_impl`).
#[inline(always)]
fn hline(srow: &[u8], x0: &[usize], x1: &[usize], c0: &[u16], c1: &[u16], out: &mut [u16]) {
    let n = out.len();
    let (x0, x1, c0, c1) = (&x0[..n], &x1[..n], &c0[..n], &c1[..n]);
    for i in 0..n {
        // SAFETY: x0[i], x1[i] < srow.len(), established by resize_impl's assertion.
        let (a, b) = unsafe { (*srow.get_unchecked(x0[i]), *srow.get_unchecked(x1[i])) };
        out[i] = u16::from(a) * c0[i] + u16::from(b) * c1[i];
    }
}

#[inline(always)]
fn vline(r0: &[u16], r1: &[u16], c0: u32, c1: u32, out: &mut [u8]) {
    let n = out.len();
    let (r0, r1) = (&r0[..n], &r1[..n]);
    for i in 0..n {
        let v = (u32::from(r0[i]) * c0 + u32::from(r1[i]) * c1 + (1 << 15)) >> 16;
        out[i] = v.min(255) as u8;
    }
}

/// Fills the padding of `level` by reflect-101 of its pixels.
pub fn pad_reflect101(level: &mut Level) {
    let (w, h, b, s) = (level.width, level.height, level.border, level.stride);
    // Left/right padding on the level's own rows.
    for y in 0..h {
        let row = (y + b) * s;
        if w > b {
            // Common case: one reflection, no index folding.
            for i in 1..=b {
                level.data[row + b - i] = level.data[row + b + i];
                level.data[row + b + w - 1 + i] = level.data[row + b + w - 1 - i];
            }
            continue;
        }
        for i in 1..=b {
            level.data[row + b - i] = level.data[row + b + reflect101(-(i as isize), w)];
            level.data[row + b + w - 1 + i] = level.data[row + b + reflect101((w - 1 + i) as isize, w)];
        }
    }
    // Top/bottom padding rows copy whole padded rows.
    for i in 1..=b {
        let src_top = reflect101(-(i as isize), h) + b;
        let dst_top = b - i;
        level.data.copy_within(src_top * s..(src_top + 1) * s, dst_top * s);
        let src_bot = reflect101((h - 1 + i) as isize, h) + b;
        let dst_bot = b + h - 1 + i;
        level.data.copy_within(src_bot * s..(src_bot + 1) * s, dst_bot * s);
    }
}

/// Builds the padded pyramid: level 0 is the image, level l is resized from level l - 1.
pub(crate) fn build(img: &GrayView<'_>, n_levels: usize, scale_factor: f64, border: usize) -> Vec<Level> {
    let mut levels: Vec<Level> = Vec::with_capacity(n_levels);
    for l in 0..n_levels {
        let (w, h) = level_size(img.width, img.height, l, scale_factor);
        if w == 0 || h == 0 {
            break;
        }
        let stride = w + 2 * border;
        let mut level = Level { width: w, height: h, border, stride, data: vec![0; stride * (h + 2 * border)] };
        let off = border * stride + border;
        if l == 0 {
            for y in 0..h {
                level.data[off + y * stride..off + y * stride + w].copy_from_slice(&img.data[y * w..(y + 1) * w]);
            }
        } else {
            let prev = &levels[l - 1];
            let poff = prev.border * prev.stride + prev.border;
            resize_linear_exact(
                &prev.data[poff..],
                prev.stride,
                prev.width,
                prev.height,
                &mut level.data[off..],
                stride,
                w,
                h,
            );
        }
        pad_reflect101(&mut level);
        levels.push(level);
    }
    levels
}
