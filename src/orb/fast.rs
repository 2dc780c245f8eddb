//! FAST-9 corners (Rosten & Drummond) with OpenCV's score and 3x3 non-maximum suppression.

use super::pyramid::Level;

/// A FAST corner in level pixels, with OpenCV's score (largest threshold still detecting it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FastCorner {
    pub x: u32,
    pub y: u32,
    pub score: u8,
}

/// The 16-pixel Bresenham circle of radius 3 as (dx, dy), in OpenCV's order (fast.cpp
/// `offsets16`): index 0 is below the centre, 4 right, 8 above, 12 left.
pub const CIRCLE: [(isize, isize); 16] = [
    (0, 3),
    (1, 3),
    (2, 2),
    (3, 1),
    (3, 0),
    (3, -1),
    (2, -2),
    (1, -3),
    (0, -3),
    (-1, -3),
    (-2, -2),
    (-3, -1),
    (-3, 0),
    (-3, 1),
    (-2, 2),
    (-1, 3),
];

/// Reusable buffers for detection.
#[derive(Default)]
pub(crate) struct Scratch {
    scores: Vec<u8>,
    flags: Vec<u8>,
}

/// True when the 16-bit cyclic mask has a run of at least 9 set bits.
#[inline(always)]
fn has_run9(mask: u32) -> bool {
    let m = mask | (mask << 16);
    let a = m & (m >> 1);
    let b = a & (a >> 2);
    let c = b & (b >> 4);
    (c & (m >> 8)) & 0xFFFF != 0
}

/// OpenCV's FAST-9 score of a pixel given its 16 circle differences `d = centre - p`: the best,
/// over 9-pixel arcs and both polarities, of the smallest difference on the arc, minus one.
#[inline]
fn score_of(d: &[i16; 16]) -> i16 {
    let mut best = i16::MIN;
    for s in 0..16 {
        let mut lo = i16::MAX;
        let mut hi = i16::MIN;
        for j in 0..9 {
            let v = d[(s + j) & 15];
            lo = lo.min(v);
            hi = hi.max(v);
        }
        best = best.max(lo).max(-hi);
    }
    best - 1
}

/// Compass-point pre-test over a run of pixels: a 9-arc contains two neighbouring compass points
/// (0/4/8/12), so a pixel needs two neighbouring ones brighter than c + t or darker than c - t.
/// Written as a plain loop over u8 so the compiler vectorises it.
#[inline(always)]
fn compass_flags(c: &[u8], down: &[u8], right: &[u8], up: &[u8], left: &[u8], t: u8, out: &mut [u8]) {
    let n = out.len();
    let (c, down, right, up, left) = (&c[..n], &down[..n], &right[..n], &up[..n], &left[..n]);
    for i in 0..n {
        let hi = c[i].saturating_add(t);
        let lo = c[i].saturating_sub(t);
        let (bd, br, bu, bl) = (down[i] > hi, right[i] > hi, up[i] > hi, left[i] > hi);
        let (dd, dr, du, dl) = (down[i] < lo, right[i] < lo, up[i] < lo, left[i] < lo);
        let b = (bd & br) | (br & bu) | (bu & bl) | (bl & bd);
        let k = (dd & dr) | (dr & du) | (du & dl) | (dl & dd);
        out[i] = u8::from(b | k);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn compass_flags_avx2(c: &[u8], down: &[u8], right: &[u8], up: &[u8], left: &[u8], t: u8, out: &mut [u8]) {
    compass_flags(c, down, right, up, left, t, out);
}

fn compass_dispatch(c: &[u8], down: &[u8], right: &[u8], up: &[u8], left: &[u8], t: u8, out: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        unsafe { compass_flags_avx2(c, down, right, up, left, t, out) };
        return;
    }
    compass_flags(c, down, right, up, left, t, out);
}

/// FAST-9 corners of a whole level with threshold `t` (strict), 3x3 non-maximum suppression, and
/// OpenCV's border rule (keep `edge <= x < width - edge`, same for y). Row-major order.
#[must_use]
pub fn fast_detect(level: &Level, t: u8, edge: usize) -> Vec<FastCorner> {
    detect_in(level, t, edge, &mut Scratch::default())
}

pub(crate) fn detect_in(level: &Level, t: u8, edge: usize, scratch: &mut Scratch) -> Vec<FastCorner> {
    let (w, h) = (level.width, level.height);
    // Kept range, then the range whose scores the suppression needs (one more pixel around),
    // clipped to where FAST is defined (3 pixels from the level edge, as OpenCV).
    let edge = edge.max(3);
    let keep_x = (edge, w.saturating_sub(edge));
    let keep_y = (edge, h.saturating_sub(edge));
    if keep_x.0 >= keep_x.1 || keep_y.0 >= keep_y.1 {
        return Vec::new();
    }
    let x0 = keep_x.0.saturating_sub(1).max(3);
    let x1 = (keep_x.1 + 1).min(w.saturating_sub(3));
    let y0 = keep_y.0.saturating_sub(1).max(3);
    let y1 = (keep_y.1 + 1).min(h.saturating_sub(3));
    if x0 >= x1 || y0 >= y1 {
        return Vec::new();
    }
    scratch.scores.clear();
    scratch.scores.resize(w * h, 0);
    scratch.flags.clear();
    scratch.flags.resize(x1 - x0, 0);
    let stride = level.stride as isize;
    let offs: [isize; 16] = CIRCLE.map(|(dx, dy)| dy * stride + dx);
    let data = &level.data;
    let mut candidates: Vec<(u32, u32)> = Vec::new();
    let n = x1 - x0;
    for y in y0..y1 {
        let row = level.index(x0 as isize, y as isize);
        let up = row - 3 * level.stride;
        let down = row + 3 * level.stride;
        compass_dispatch(
            &data[row..row + n],
            &data[down..down + n],
            &data[row + 3..row + 3 + n],
            &data[up..up + n],
            &data[row - 3..row - 3 + n],
            t,
            &mut scratch.flags,
        );
        let flags = &scratch.flags;
        let mut i = 0;
        while i < n {
            // Skip runs of rejected pixels eight at a time.
            if i + 8 <= n && u64::from_ne_bytes(flags[i..i + 8].try_into().unwrap_or([0; 8])) == 0 {
                i += 8;
                continue;
            }
            if flags[i] != 0 {
                let p = row + i;
                let c = data[p];
                let hi = c.saturating_add(t);
                let lo = c.saturating_sub(t);
                let mut bright = 0u32;
                let mut dark = 0u32;
                let mut d = [0i16; 16];
                for (k, &o) in offs.iter().enumerate() {
                    let v = data[(p as isize + o) as usize];
                    bright |= u32::from(v > hi) << k;
                    dark |= u32::from(v < lo) << k;
                    d[k] = i16::from(c) - i16::from(v);
                }
                if has_run9(bright) || has_run9(dark) {
                    let s = score_of(&d);
                    let x = x0 + i;
                    scratch.scores[y * w + x] = s as u8;
                    candidates.push((x as u32, y as u32));
                }
            }
            i += 1;
        }
    }
    let sc = &scratch.scores;
    candidates
        .into_iter()
        .filter_map(|(x, y)| {
            let (xu, yu) = (x as usize, y as usize);
            if xu < keep_x.0 || xu >= keep_x.1 || yu < keep_y.0 || yu >= keep_y.1 {
                return None;
            }
            let i = yu * w + xu;
            let s = sc[i];
            let beats = s > sc[i - 1]
                && s > sc[i + 1]
                && s > sc[i - w - 1]
                && s > sc[i - w]
                && s > sc[i - w + 1]
                && s > sc[i + w - 1]
                && s > sc[i + w]
                && s > sc[i + w + 1];
            beats.then_some(FastCorner { x, y, score: s })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run9_detects_cyclic_runs_only() {
        assert!(has_run9(0x01FF));
        assert!(!has_run9(0x00FF));
        // A run wrapping through bit 15 -> bit 0.
        assert!(has_run9(0xF01F));
        assert!(!has_run9(0xF00F));
        assert!(has_run9(0xFFFF));
    }

    #[test]
    fn score_is_arc_minimum_minus_one() {
        let mut d = [0i16; 16];
        for (k, v) in d.iter_mut().enumerate().take(9) {
            *v = 30 + k as i16;
        }
        assert_eq!(score_of(&d), 29);
        let neg = d.map(|v| -v);
        assert_eq!(score_of(&neg), 29);
    }
}
