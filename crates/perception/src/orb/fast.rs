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
    bright: Vec<u8>,
    dark: Vec<u8>,
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
/// The 16 arcs' minima and maxima side by side, over the circle written out to 24 entries.
#[inline(always)]
fn score_of(d: &[i16; 16]) -> i16 {
    // The circle written out to 24 entries; lane i of lo/hi is the min/max over arc i..i+9.
    let mut e = [0i16; 24];
    e[..16].copy_from_slice(d);
    e[16..].copy_from_slice(&d[..8]);
    let mut lo = [i16::MAX; 16];
    let mut hi = [i16::MIN; 16];
    for k in 0..9 {
        for i in 0..16 {
            lo[i] = lo[i].min(e[i + k]);
            hi[i] = hi[i].max(e[i + k]);
        }
    }
    let best_dark = lo.iter().copied().max().unwrap_or(i16::MIN);
    let best_bright = -hi.iter().copied().min().unwrap_or(i16::MAX);
    best_dark.max(best_bright) - 1
}

/// Pixels per block of [`corner_flags`]'s quick rejection: long enough for whole vectors, short
/// enough that a textured stretch does not send a flat one through the full test.
const QUICK_BLOCK: usize = 64;

/// Flags, for a run of `n` pixels, those whose circle holds 9 contiguous pixels brighter than
/// c + t or darker than c - t. Blocks in which no pixel passes the quick test of OpenCV's FAST
/// (two circle pixels a quarter turn apart, 0-4, 4-8, 8-12 or 12-0, on the same side: any 9-arc
/// holds such a pair) are flagged empty without the full test: most blocks of a rendered day
/// frame, few of a noisy night frame.
#[inline(always)]
fn corner_flags(c: &[u8], circle: &[&[u8]; 16], t: u8, bright: &mut [u8], dark: &mut [u8], out: &mut [u8]) {
    let n = out.len();
    let mut start = 0;
    while start < n {
        let end = (start + QUICK_BLOCK).min(n);
        let len = end - start;
        let centre = &c[start..end];
        let (q0, q1) = (&circle[0][start..end], &circle[4][start..end]);
        let (q2, q3) = (&circle[8][start..end], &circle[12][start..end]);
        let mut any = 0u8;
        for i in 0..len {
            let (hi, lo) = (centre[i].saturating_add(t), centre[i].saturating_sub(t));
            let (b0, b1, b2, b3) = (q0[i] > hi, q1[i] > hi, q2[i] > hi, q3[i] > hi);
            let (d0, d1, d2, d3) = (q0[i] < lo, q1[i] < lo, q2[i] < lo, q3[i] < lo);
            let bright = (b0 & b1) | (b1 & b2) | (b2 & b3) | (b3 & b0);
            let dark = (d0 & d1) | (d1 & d2) | (d2 & d3) | (d3 & d0);
            any |= u8::from(bright | dark);
        }
        if any == 0 {
            out[start..end].fill(0);
        } else {
            let circle: [&[u8]; 16] = std::array::from_fn(|k| &circle[k][start..end]);
            full_test(&c[start..end], &circle, t, bright, dark, &mut out[start..end]);
        }
        start = end;
    }
}

/// [`corner_flags`]' full test: the 16-bit masks of circle pixels brighter than c + t and
/// darker than c - t, and whether either holds a 9-run. Plain loops over slices so the compiler
/// vectorises them; `circle[k]` is the slice of circle pixel k.
#[inline(always)]
fn full_test(c: &[u8], circle: &[&[u8]; 16], t: u8, bright: &mut [u8], dark: &mut [u8], out: &mut [u8]) {
    let n = out.len();
    let c = &c[..n];
    // Masks of circle pixels 0..8 and 8..16 in separate u8 planes: u8 lanes only.
    let (b_lo, b_hi) = bright[..2 * n].split_at_mut(n);
    let (d_lo, d_hi) = dark[..2 * n].split_at_mut(n);
    for (half, (bp, dp)) in [(b_lo, d_lo), (b_hi, d_hi)].into_iter().enumerate() {
        bp.fill(0);
        dp.fill(0);
        for k in 0..8 {
            let src = &circle[8 * half + k][..n];
            for i in 0..n {
                let hi = c[i].saturating_add(t);
                let lo = c[i].saturating_sub(t);
                bp[i] |= u8::from(src[i] > hi) << k;
                dp[i] |= u8::from(src[i] < lo) << k;
            }
        }
    }
    let (b_lo, b_hi) = bright[..2 * n].split_at(n);
    let (d_lo, d_hi) = dark[..2 * n].split_at(n);
    for i in 0..n {
        let b = u32::from(b_lo[i]) | (u32::from(b_hi[i]) << 8);
        let d = u32::from(d_lo[i]) | (u32::from(d_hi[i]) << 8);
        out[i] = u8::from(has_run9(b) | has_run9(d));
    }
}

/// One row of FAST: flags every pixel of the run starting at `row` (`circle[k]` the run shifted
/// to circle pixel k), then scores the flagged ones into `scores` (the row's slice, indexed
/// from the run's first pixel) and lists their offsets in `flagged`.
#[inline(always)]
fn row_corners(data: &[u8], row: usize, circle: &[&[u8]; 16], t: u8, scratch: &mut RowScratch<'_>) {
    let n = circle[0].len();
    let flags = &mut scratch.flags[..n];
    corner_flags(&data[row..row + n], circle, t, scratch.bright, scratch.dark, flags);
    let mut i = 0;
    while i < n {
        // Skip runs of rejected pixels eight at a time.
        if i + 8 <= n && u64::from_ne_bytes(flags[i..i + 8].try_into().unwrap_or([0; 8])) == 0 {
            i += 8;
            continue;
        }
        if flags[i] != 0 {
            let c = i16::from(data[row + i]);
            // A loop, not `array::from_fn`: that was left out of line, in baseline code.
            let mut d = [0i16; 16];
            for (dk, ck) in d.iter_mut().zip(circle) {
                *dk = c - i16::from(ck[i]);
            }
            scratch.scores[i] = score_of(&d) as u8;
            scratch.flagged.push(i);
        }
        i += 1;
    }
}

/// The buffers [`row_corners`] works in.
struct RowScratch<'a> {
    flags: &'a mut [u8],
    bright: &'a mut [u8],
    dark: &'a mut [u8],
    scores: &'a mut [u8],
    flagged: &'a mut Vec<usize>,
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn row_corners_avx2(data: &[u8], row: usize, circle: &[&[u8]; 16], t: u8, scratch: &mut RowScratch<'_>) {
    row_corners(data, row, circle, t, scratch);
}

/// [`row_corners`] in its AVX2 build where the CPU has AVX2 (the same result either way).
fn row_corners_dispatch(data: &[u8], row: usize, circle: &[&[u8]; 16], t: u8, scratch: &mut RowScratch<'_>) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        unsafe { row_corners_avx2(data, row, circle, t, scratch) };
        return;
    }
    row_corners(data, row, circle, t, scratch);
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
    // The score plane is all zeros between calls: grown with zeros, and the scores a call
    // writes are zeroed again before it returns (clearing the whole plane per level was a few
    // per cent of an extraction).
    if scratch.scores.len() < w * h {
        scratch.scores.resize(w * h, 0);
    }
    scratch.flags.resize(x1 - x0, 0);
    scratch.bright.resize(2 * (x1 - x0), 0);
    scratch.dark.resize(2 * (x1 - x0), 0);
    let stride = level.stride as isize;
    let offs: [isize; 16] = CIRCLE.map(|(dx, dy)| dy * stride + dx);
    let data = &level.data;
    let mut candidates: Vec<(u32, u32)> = Vec::new();
    let mut flagged = Vec::new();
    let n = x1 - x0;
    for y in y0..y1 {
        let row = level.index(x0 as isize, y as isize);
        let circle: [&[u8]; 16] = std::array::from_fn(|k| {
            let p = (row as isize + offs[k]) as usize;
            &data[p..p + n]
        });
        flagged.clear();
        let mut row_scratch = RowScratch {
            flags: &mut scratch.flags,
            bright: &mut scratch.bright,
            dark: &mut scratch.dark,
            scores: &mut scratch.scores[y * w + x0..y * w + x0 + n],
            flagged: &mut flagged,
        };
        row_corners_dispatch(data, row, &circle, t, &mut row_scratch);
        candidates.extend(flagged.iter().map(|&i| ((x0 + i) as u32, y as u32)));
    }
    let sc = &scratch.scores;
    let corners = candidates
        .iter()
        .filter_map(|&(x, y)| {
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
        .collect();
    for &(x, y) in &candidates {
        scratch.scores[y as usize * w + x as usize] = 0;
    }
    corners
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

    proptest::proptest! {
        /// The quick rejection only skips blocks the full test would flag empty: on any run
        /// (whole blocks and a partial one) both flag the same pixels. Mostly flat rows with
        /// scattered dark and bright pixels, so that corners are sparse and whole blocks are
        /// rejected, next to blocks where one arc decides.
        #[test]
        fn quick_rejection_keeps_every_corner(
            rows in proptest::collection::vec(proptest::collection::vec(0u8..=255, 150), 17),
            t in 1u8..60,
        ) {
            let sparse = |v: u8| match v {
                0..30 => 40,
                30..60 => 220,
                _ => 128,
            };
            let rows: Vec<Vec<u8>> = rows.into_iter().map(|r| r.into_iter().map(sparse).collect()).collect();
            let circle: [&[u8]; 16] = std::array::from_fn(|k| rows[k + 1].as_slice());
            let (mut bright, mut dark) = (vec![0u8; 300], vec![0u8; 300]);
            let (mut quick, mut full) = (vec![0u8; 150], vec![0u8; 150]);
            corner_flags(&rows[0], &circle, t, &mut bright, &mut dark, &mut quick);
            full_test(&rows[0], &circle, t, &mut bright, &mut dark, &mut full);
            proptest::prop_assert_eq!(quick, full);
        }
    }
}
