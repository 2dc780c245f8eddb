//! The statistics compared between a measured and a simulated acquisition, their sampling
//! uncertainties, and the gap.
//!
//! Families (each entry is a value and the variance of its sampling error):
//!
//! * `linearity`: mean DN per photon-transfer step (mean against photons); variance of the
//!   frame mean from the larger of the row-profile, column-profile and pixel variances, so
//!   correlated fixed patterns count, and at least the rounding's `1 / (12 n)`.
//! * `photon_transfer`: temporal variance per step from the pair, `var (2/N) var^2`.
//! * `dark`: mean and temporal variance of every dark pair (dark signal against exposure).
//! * `spatial`: of the averaged dark and bright stacks, the residual variance after removing
//!   the row and column profiles (white DSNU / PRNU; trimmed at the tail thresholds), the
//!   variances of the row and column profiles (row/column patterns, fall-off), the row-profile
//!   variance of the dark pair's difference (temporal row noise), and the fall-off coefficient
//!   of the bright stack. Variances of variances: `2 v^2 / dof`. A periodic wave's frequency is
//!   refined between the periodogram's bins before it is removed.
//! * `correlation`: the lag-1 correlation along x and y of the temporal noise (a pair's
//!   difference, row and column profiles removed) of the first dark pair and the middle bright
//!   pair, variance `1 / n`: 0 for every effect of the model, positive with crosstalk.
//! * `spectrum`: peak-to-median ratios of the two largest local maxima of the dark stack's 2-D
//!   periodogram on a 2x oversampled grid: periodic patterns, separable or diagonal.
//! * `tails`: pixels of the dark residual above `T` and `3 T` (hot pixels) and of the bright
//!   residual below `-T` (dead / low pixels), in robust standard deviations of the measured
//!   residual: for the dark tail a Bonferroni bound at a 0.1 % false-alarm rate per set
//!   ([`tail_sigmas`]), for the bright tail six; compared by their Poisson deviance.
//!
//! Behaviour near saturation is in `linearity` and `photon_transfer` (mean plateau, variance
//! collapse at the top steps).

use rayon::prelude::*;
use serde::Serialize;

use super::{Acquisition, Light, radius2_map};
use scene_gen_camera::sensor::noise::{self, HotPixels};
pub use scene_gen_core::stats::{normal_tail, normal_tail_inverse};

/// Tail thresholds, fixed from the measured data and applied to both acquisitions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Thresholds {
    pub dark_dn: f64,
    pub bright_dn: f64,
}

/// One compared statistic.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Entry {
    pub family: &'static str,
    pub label: String,
    /// The abscissa for plots (photons, exposure), or 0.
    pub x: f64,
    pub value: f64,
    /// Variance of the sampling error of `value` (Gaussian entries).
    pub var: f64,
    /// Some: `value` is a Poisson count of tail pixels, compared by its likelihood deviance
    /// (see [`count_deviance`]), and this is the count the acquisition's Gaussian core alone
    /// would put beyond the threshold (`n Q(T / sd)`), the floor of a model's expectation.
    pub count_floor: Option<f64>,
}

/// Photon-transfer step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StepStats {
    /// Gain group (see [`Acquisition::gains_db`]).
    pub group: usize,
    pub photons: f64,
    pub exposure_s: f64,
    pub mean_dn: f64,
    pub var_dn2: f64,
}

/// Dark pair.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DarkStats {
    /// Gain group (see [`Acquisition::gains_db`]).
    pub group: usize,
    pub exposure_s: f64,
    pub mean_dn: f64,
    pub var_dn2: f64,
    /// Row-profile variance of `(A - B) / sqrt 2`.
    pub diff_row_var_dn2: f64,
}

/// An averaged stack.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StackStats {
    pub frames: usize,
    pub exposure_s: f64,
    pub photons: f64,
    pub mean_dn: f64,
    pub resid_var_dn2: f64,
    pub row_var_dn2: f64,
    pub col_var_dn2: f64,
    pub above_t: f64,
    pub above_3t: f64,
    pub below_t: f64,
    /// Mean residual of the pixels above `T`, DN (0 when none).
    pub above_t_mean_dn: f64,
    /// Residuals of the pixels above `T` at probabilities `0, 1/7, ..., 1` of their
    /// distribution, DN (all 0 when none): the measured shape of the hot pixels' excess.
    pub above_t_quantiles_dn: [f64; HotPixels::QUANTILES],
    /// Robust standard deviation of the tail residual (profiles and periodic waves removed), DN.
    pub tail_sd_dn: f64,
}

/// A periodogram peak.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Peak {
    /// Power over the median power of the grid.
    pub ratio: f64,
    pub fx_cycles_per_px: f64,
    pub fy_cycles_per_px: f64,
    /// Amplitude^2 of a sinusoid at the peak above the noise floor, DN^2.
    pub amp2_dn2: f64,
}

/// Every statistic of one acquisition.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stats {
    pub width: usize,
    pub height: usize,
    pub steps: Vec<StepStats>,
    pub darks: Vec<DarkStats>,
    pub dark_stack: Option<StackStats>,
    pub bright_stack: Option<StackStats>,
    /// Relative fall-off `c` of the bright stack over the dark stack and its variance.
    pub falloff: Option<(f64, f64)>,
    /// The two largest local maxima of the dark stack's 2-D periodogram.
    pub peaks: Vec<Peak>,
    pub entries: Vec<Entry>,
    /// The thresholds the tails were counted with.
    pub thresholds: Option<Thresholds>,
    /// Gain of each group, dB, as simulated (see [`Acquisition::gains_db`]).
    pub gains_db: Vec<f64>,
}

/// Families a photon-transfer CSV can support (no images: no spatial statistics).
pub const REDUCED_FAMILIES: [&str; 3] = ["linearity", "photon_transfer", "dark"];

impl Stats {
    /// Only the statistics of [`REDUCED_FAMILIES`], for comparison with a photon-transfer CSV.
    #[must_use]
    pub fn reduced(mut self) -> Stats {
        self.entries.retain(|e| REDUCED_FAMILIES.contains(&e.family));
        self
    }

    /// Photon-transfer steps of the reference gain group.
    pub fn base_steps(&self) -> impl Iterator<Item = &StepStats> {
        self.steps.iter().filter(|s| s.group == 0)
    }

    /// Dark pairs of the reference gain group.
    pub fn base_darks(&self) -> impl Iterator<Item = &DarkStats> {
        self.darks.iter().filter(|s| s.group == 0)
    }
}

pub(super) fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Sample variance (`n - 1` in the denominator).
pub(super) fn var(v: &[f64]) -> f64 {
    let m = mean(v);
    v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len().max(2) - 1) as f64
}

fn row_means(img: &[f64], w: usize, h: usize) -> Vec<f64> {
    (0..h).map(|r| mean(&img[r * w..(r + 1) * w])).collect()
}

fn col_means(img: &[f64], w: usize, h: usize) -> Vec<f64> {
    (0..w).map(|c| (0..h).map(|r| img[r * w + c]).sum::<f64>() / h as f64).collect()
}

/// Variance of a sequence's white part from its successive differences, `mean(d^2) / 2`.
fn diff_var(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return 0.0;
    }
    v.windows(2).map(|p| (p[1] - p[0]).powi(2)).sum::<f64>() / (2.0 * (v.len() - 1) as f64)
}

/// The image minus its row and column profiles (plus the grand mean).
fn residual(img: &[f64], w: usize, h: usize) -> Vec<f64> {
    let (rm, cm) = (row_means(img, w, h), col_means(img, w, h));
    let g = mean(img);
    img.iter().enumerate().map(|(i, v)| v - rm[i / w] - cm[i % w] + g).collect()
}

/// Median absolute deviation scaled to a Gaussian standard deviation.
fn robust_sd(v: &[f64]) -> f64 {
    // Selections, not sorts: the same elements, in linear time.
    let mut s = v.to_vec();
    let mid = s.len() / 2;
    let med = *s.select_nth_unstable_by(mid, f64::total_cmp).1;
    s.iter_mut().for_each(|x| *x = (*x - med).abs());
    1.4826 * *s.select_nth_unstable_by(mid, f64::total_cmp).1
}

fn stack_mean(frames: &[Vec<f32>]) -> Vec<f64> {
    let n = frames[0].len();
    let mut out = vec![0f64; n];
    for f in frames {
        out.iter_mut().zip(f).for_each(|(o, &v)| *o += f64::from(v));
    }
    let l = frames.len() as f64;
    out.iter_mut().for_each(|o| *o /= l);
    out
}

/// The 2-D periodogram of an image (mean removed): `P = 4 |DFT|^2 / N^2` (A^2 for a plane wave
/// of amplitude A), on a grid oversampled `over` times: fx in 0..0.5 (`over w / 2 + 1` values,
/// `k / (over w)`) and fy in -0.5..0.5 (`over h` values, `j / (over h) - 0.5`). Returns (fx, fy,
/// power with index `k * fy.len() + j`).
///
/// Computed with zero-padded FFTs, rows then columns (O(N log N)); the -0.5 offset of fy is a
/// `(-1)^r` modulation of row `r`. At 640x480 the direct sum this replaces cost ~0.5 G
/// multiply-adds per call (tests/gap.rs keeps it as the reference).
#[must_use]
pub fn periodogram_2d(img: &[f64], w: usize, h: usize, over: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    use rustfft::FftPlanner;
    use rustfft::num_complex::Complex;
    let m = mean(img);
    let (lx, ly) = (over * w, over * h);
    let nfx = lx / 2 + 1;
    let nfy = ly;
    let fx: Vec<f64> = (0..nfx).map(|k| k as f64 / lx as f64).collect();
    let fy: Vec<f64> = (0..nfy).map(|k| k as f64 / ly as f64 - 0.5).collect();
    let mut planner = FftPlanner::<f64>::new();
    // Along x for every row, zero-padded to `over w`; keep bins 0..nfx, stored column-major
    // (bin k's column of h rows padded to `over h`) for the second pass.
    let fft_x = planner.plan_fft_forward(lx);
    let mut rows = vec![Complex::new(0.0, 0.0); lx * h];
    for (r, chunk) in rows.chunks_exact_mut(lx).enumerate() {
        for (o, v) in chunk.iter_mut().zip(&img[r * w..(r + 1) * w]) {
            o.re = v - m;
        }
    }
    fft_x.process(&mut rows);
    let mut cols = vec![Complex::new(0.0, 0.0); nfx * ly];
    for r in 0..h {
        // (-1)^r shifts the y frequencies by -0.5 cycles per pixel.
        let sign = if r % 2 == 0 { 1.0 } else { -1.0 };
        for k in 0..nfx {
            cols[k * ly + r] = rows[r * lx + k] * sign;
        }
    }
    drop(rows);
    planner.plan_fft_forward(ly).process(&mut cols);
    let n2 = ((w * h) as f64).powi(2);
    let p: Vec<f64> = cols.iter().map(|c| 4.0 * c.norm_sqr() / n2).collect();
    (fx, fy, p)
}

/// Peaks of the 2-D periodogram of an image ([`periodogram_2d`], oversampled `over` times),
/// fx in 0..0.5 and fy in -0.5..0.5 (the half-plane), skipping |f| below 2 cycles per frame.
/// Returns the `top` largest local maxima as (power, fx, fy), and the median power of the grid.
#[must_use]
pub fn peaks_2d(img: &[f64], w: usize, h: usize, over: usize, top: usize) -> (Vec<(f64, f64, f64)>, f64) {
    let (fx, fy, p) = periodogram_2d(img, w, h, over);
    let (nfx, nfy) = (fx.len(), fy.len());
    let min_f = 2.0 / w.max(h) as f64;
    let mut on_grid: Vec<f64> = Vec::new();
    // The `top` largest local maxima so far, largest first (earlier bins first among equals).
    let mut found: Vec<(f64, f64, f64)> = Vec::with_capacity(top + 1);
    // A bin is a local maximum when none of its 8 neighbours is larger.
    let is_max = |k: usize, j: usize, v: f64| {
        for kk in k.saturating_sub(1)..(k + 2).min(nfx) {
            let column = &p[kk * nfy..(kk + 1) * nfy];
            for (jj, &q) in column.iter().enumerate().take((j + 2).min(nfy)).skip(j.saturating_sub(1)) {
                if (kk, jj) != (k, j) && q > v {
                    return false;
                }
            }
        }
        true
    };
    for k in 0..nfx {
        for j in 0..nfy {
            // Half-plane: fx > 0, or fx = 0 and fy > 0 (the rest mirrors it).
            if (fx[k] * fx[k] + fy[j] * fy[j]).sqrt() < min_f || (k == 0 && fy[j] <= 0.0) {
                continue;
            }
            let v = p[k * nfy + j];
            if k % over == 0 && j % over == 0 {
                on_grid.push(v);
            }
            let ranks = found.len() < top || found.last().is_some_and(|l| v > l.0);
            if ranks && is_max(k, j, v) {
                let at = found.iter().position(|f| v > f.0).unwrap_or(found.len());
                found.insert(at, (v, fx[k], fy[j]));
                found.truncate(top);
            }
        }
    }
    let median = if on_grid.is_empty() {
        0.0
    } else {
        let mid = on_grid.len() / 2;
        *on_grid.select_nth_unstable_by(mid, f64::total_cmp).1
    };
    (found, median)
}

/// Mean image of a stack (public for probes and tests).
#[must_use]
pub fn average(frames: &[Vec<f32>]) -> Vec<f64> {
    stack_mean(frames)
}

/// The statistics of a temporal pair, in two passes over its pixels without copies: the
/// row and column sums, then the central moments.
fn pair_stats(a: &[f32], b: &[f32], w: usize, h: usize) -> PairStats {
    let pixel = |x: f32, y: f32| {
        let (x, y) = (f64::from(x), f64::from(y));
        (0.5 * (x + y), (x - y) / std::f64::consts::SQRT_2)
    };
    let mut col_avg = vec![0.0; w];
    let (mut row_avg, mut row_diff) = (Vec::with_capacity(h), Vec::with_capacity(h));
    for (ra, rb) in a.chunks(w.max(1)).zip(b.chunks(w.max(1))).take(h) {
        let (mut sa, mut sd) = (0.0, 0.0);
        for ((c, &x), &y) in col_avg.iter_mut().zip(ra).zip(rb) {
            let (avg, d) = pixel(x, y);
            *c += avg;
            sa += avg;
            sd += d;
        }
        row_avg.push(sa / w as f64);
        row_diff.push(sd / w as f64);
    }
    col_avg.iter_mut().for_each(|c| *c /= h as f64);
    let (m, md) = (mean(&row_avg), mean(&row_diff));
    let (mut s2a, mut s2d, mut s4d) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        let (avg, d) = pixel(x, y);
        let (ea, ed) = (avg - m, (d - md) * (d - md));
        s2a += ea * ea;
        s2d += ed;
        s4d += ed * ed;
    }
    PairSums { row_avg, row_diff, col_avg, s2a, s2d, s4d }.finish()
}

/// The sums a temporal pair's statistics are finished from ([`PairSums::finish`]), whether
/// read off its pixels ([`pair_stats`]) or drawn from its pixels' moments by a simulation
/// (`gap::moment_pair`).
pub(super) struct PairSums {
    /// Row means of the pair average `(A + B) / 2`.
    pub row_avg: Vec<f64>,
    /// Row means of the difference `(A - B) / sqrt 2`.
    pub row_diff: Vec<f64>,
    /// Column means of the pair average.
    pub col_avg: Vec<f64>,
    /// Sum of squares of the average about its mean (the mean of `row_avg`).
    pub s2a: f64,
    /// Sum of squares of the difference about its mean (the mean of `row_diff`).
    pub s2d: f64,
    /// Sum of fourth powers of the difference about its mean.
    pub s4d: f64,
}

impl PairSums {
    pub(super) fn finish(self) -> PairStats {
        let (w, h) = (self.col_avg.len(), self.row_avg.len());
        let n = (w * h) as f64;
        let dof = (n - 1.0).max(1.0);
        // Variance of the frame mean: white, row-correlated or column-correlated patterns; the
        // profiles' variances from successive differences, so smooth shading (a deterministic
        // fall-off, not a sampling error) does not count.
        let mean_var =
            (self.s2a / dof / n).max(diff_var(&self.row_avg) / h as f64).max(diff_var(&self.col_avg) / w as f64);
        PairStats {
            mean_dn: mean(&self.row_avg),
            var_dn2: self.s2d / dof,
            mean_var,
            diff_row_var_dn2: var(&self.row_diff),
            m4: self.s4d / n,
        }
    }
}

/// What the statistics read of a temporal pair: its mean, temporal variance, the sampling
/// variance of its mean, and the row-profile variance and fourth moment of its difference. A
/// simulation that draws a pair from its pixels' moments keeps only these
/// ([`super::Block::pair`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PairStats {
    mean_dn: f64,
    /// Temporal variance, `var((A - B) / sqrt 2)`.
    var_dn2: f64,
    /// Sampling variance of `mean_dn`.
    mean_var: f64,
    /// Row-profile variance of the difference.
    diff_row_var_dn2: f64,
    /// Fourth central moment of the difference.
    m4: f64,
}

/// Lag-1 correlation along x and along y of a pair's difference `(A - B)`, its row and column
/// profiles removed. Every effect of the noise model draws each pixel's temporal noise on its
/// own (row and column noise aside, which the profiles take out), so both are 0 within
/// `1 / sqrt(n)`; charge or electrical crosstalk between pixels makes them positive.
fn neighbour_correlation(a: &[f32], b: &[f32], w: usize, h: usize) -> (f64, f64) {
    let diff: Vec<f64> = a.iter().zip(b).map(|(&x, &y)| f64::from(x) - f64::from(y)).collect();
    let r = residual(&diff, w, h);
    let ss: f64 = r.iter().map(|v| v * v).sum();
    if ss <= 0.0 || w < 2 || h < 2 {
        return (0.0, 0.0);
    }
    let sx: f64 =
        (0..h).flat_map(|y| (0..w - 1).map(move |x| (y, x))).map(|(y, x)| r[y * w + x] * r[y * w + x + 1]).sum();
    let sy: f64 = r[..(h - 1) * w].iter().zip(&r[w..]).map(|(a, b)| a * b).sum();
    (sx / ss, sy / ss)
}

/// Sampling variance of a temporal variance `v` estimated from `n` pixels in `h` rows whose
/// row-profile variance is `rv`: `(m4 - v^2) / n` from the fourth moment (at least the Gaussian
/// `2 v^2 / n`; clipped or hot-pixel data are heavy-tailed), plus the row-correlated part
/// `2 rv^2 / h`.
fn var_of_var(v: f64, m4: f64, rv: f64, n: f64, h: f64) -> f64 {
    ((m4 - v * v).max(2.0 * v * v) / n + 2.0 * rv * rv / h).max(QUANTIZED_VAR_OF_VAR / n)
}

/// Sampling variance of a mean of `n` pixel values, at least what rounding to whole DN leaves,
/// `1 / (12 n)`: a frame of clipped or constant pixels (a saturated plateau, a dark frame at
/// 0 DN) has almost no spread, and without the floor a difference of one DN in one pixel
/// would count as tens of sigmas.
fn quantized_mean_var(n: f64) -> f64 {
    1.0 / (12.0 * n.max(1.0))
}

/// The variance of the squared rounding error of a whole DN, `E[u^4] - E[u^2]^2` for `u`
/// uniform in (-1/2, 1/2): `1/80 - 1/144 = 1/180`; the floor of a temporal variance's sampling
/// variance, per pixel (see [`quantized_mean_var`]).
const QUANTIZED_VAR_OF_VAR: f64 = 1.0 / 180.0;

/// False-alarm rate of the hot-pixel tail per acquisition, `alpha`: the probability that a set
/// without hot pixels, whose averaged dark residual is Gaussian, puts any pixel above the dark
/// threshold `T` (a Bonferroni bound over the pixels, see [`tail_sigmas`]). It is also the
/// Gaussian core's expected count above `T` (the count floor of [`count_deviance`]), so one
/// pixel above `T` scores a deviance of `2 (ln(1 / alpha) - 1) = 11.8`, just enough to beat the
/// 2-parameter hot-pixel penalty `2 ln n` (9.5 at n = 115 statistics, see
/// [`super::fit::HotPixels`]) up to n = 365: a clean set names `hot_pixels` with probability
/// about `alpha`, and a single pixel far beyond the Gaussian core is evidence enough. At
/// `alpha = 0.01` (4.9 sigmas at 160x120) one pixel would score only 7.2.
pub const DARK_TAIL_FALSE_ALARM: f64 = 0.001;

/// Sigmas of the bright (dead-pixel) tail threshold: a fixed six (no effect is fitted to it).
pub const BRIGHT_TAIL_SIGMAS: f64 = 6.0;

/// Sigmas of the dark tail threshold for `pixels` pixels: `Q^-1(alpha / pixels)` with `alpha`
/// [`DARK_TAIL_FALSE_ALARM`], so by the union bound a Gaussian residual exceeds it anywhere with
/// probability below `alpha` (5.3 sigmas at 160x120, 5.8 at 640x480).
#[must_use]
pub fn tail_sigmas(pixels: usize) -> f64 {
    normal_tail_inverse(DARK_TAIL_FALSE_ALARM / pixels.max(1) as f64)
}

/// Thresholds from the measured acquisition, in robust standard deviations of the tail residual
/// of each averaged stack: for the dark stack, with its periodic waves removed (see
/// [`remove_waves`]), [`tail_sigmas`] of the image size; for the bright stack
/// [`BRIGHT_TAIL_SIGMAS`].
#[must_use]
pub fn thresholds(acq: &Acquisition) -> Thresholds {
    let (w, h) = (acq.width, acq.height);
    let mut t = Thresholds { dark_dn: f64::INFINITY, bright_dn: f64::INFINITY };
    for b in acq.blocks.iter().filter(|b| b.frames.len() > 2) {
        let img = b.mean_image();
        let mut r = residual(&img, w, h);
        let sigmas = if b.light == Light::Dark {
            r = remove_waves(&r, w, h, &waves(&img, w, h).1);
            tail_sigmas(w * h)
        } else {
            BRIGHT_TAIL_SIGMAS
        };
        let v = sigmas * robust_sd(&r).max(0.5);
        match b.light {
            Light::Dark if t.dark_dn.is_infinite() => t.dark_dn = v,
            Light::Bright(_) if t.bright_dn.is_infinite() => t.bright_dn = v,
            _ => {}
        }
    }
    t
}

/// Peak-to-median ratio above which a periodogram peak counts as a wave (a white 64 x 48 image's
/// largest bin reaches about 15 medians, 160 x 120 about 17).
pub const PEAK_RATIO: f64 = 40.0;

/// The two largest periodogram peaks of a dark image, and the frequencies `(fx, fy)` of those
/// that stand above [`PEAK_RATIO`] (the waves).
fn waves(img: &[f64], w: usize, h: usize) -> (Vec<Peak>, Vec<(f64, f64)>) {
    let (found, median) = peaks_2d(img, w, h, 2, 2);
    let median = median.max(1e-12);
    let floor = median / std::f64::consts::LN_2;
    // The periodogram's image: the mean removed, not the profiles (a wave along x alone is a
    // column profile).
    let r: Vec<f64> = if found.iter().any(|f| f.0 / median > PEAK_RATIO) {
        let m = mean(img);
        img.iter().map(|v| v - m).collect()
    } else {
        Vec::new()
    };
    let peaks: Vec<Peak> = found
        .into_iter()
        .map(|(p, fx, fy)| {
            let ratio = p / median;
            if ratio <= PEAK_RATIO {
                return Peak { ratio, fx_cycles_per_px: fx, fy_cycles_per_px: fy, amp2_dn2: (p - floor).max(0.0) };
            }
            let (fx, fy, a2) = refine_wave(&r, w, h, fx, fy);
            Peak { ratio, fx_cycles_per_px: fx, fy_cycles_per_px: fy, amp2_dn2: (a2 - floor).max(0.0) }
        })
        .collect();
    let waves =
        peaks.iter().filter(|p| p.ratio > PEAK_RATIO).map(|p| (p.fx_cycles_per_px, p.fy_cycles_per_px)).collect();
    (peaks, waves)
}

/// A wave's frequency between the periodogram's bins: the `(fx, fy)` near a grid peak whose
/// least-squares sinusoid explains most of the image `r` (mean removed; golden-section searches along fx,
/// fy, then fx again, over one bin of the 2x grid each way), and the fitted amplitude squared.
/// On the grid alone a wave's frequency is off by up to half a bin, so a model built from it
/// drifts out of phase across the frame and its removal leaves part of the wave behind. Each
/// line search projects the image once on the fixed axis's wave ([`Projection`]), so a trial
/// frequency costs one pass over a row or a column, not over the image.
fn refine_wave(r: &[f64], w: usize, h: usize, fx: f64, fy: f64) -> (f64, f64, f64) {
    let golden = |lo: f64, hi: f64, f: &dyn Fn(f64) -> f64| -> f64 {
        let g = (5f64.sqrt() - 1.0) / 2.0;
        let (mut a, mut b) = (lo, hi);
        let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
        let (mut fc, mut fd) = (f(c), f(d));
        for _ in 0..16 {
            if fc > fd {
                (b, d, fd) = (d, c, fc);
                c = b - g * (b - a);
                fc = f(c);
            } else {
                (a, c, fc) = (c, d, fd);
                d = a + g * (b - a);
                fd = f(d);
            }
        }
        0.5 * (a + b)
    };
    let (dx, dy) = (0.5 / w.max(1) as f64, 0.5 / h.max(1) as f64);
    let at_fy = Projection::along_y(r, w, fy);
    let mut x = golden(fx - dx, fx + dx, &|v| at_fy.fit(v).2);
    let at_x = Projection::along_x(r, w, x);
    let y = golden(fy - dy, fy + dy, &|v| at_x.fit(v).2);
    let at_y = Projection::along_y(r, w, y);
    x = golden(x - dx / 2.0, x + dx / 2.0, &|v| at_y.fit(v).2);
    let (a, b, _) = at_y.fit(x);
    // The half-plane convention of the periodogram: fx >= 0.
    if x < 0.0 { (-x, -y, a * a + b * b) } else { (x, y, a * a + b * b) }
}

/// `(cos, sin)` of `2 pi f k` for `k` in `0..n`: one axis of a plane wave.
fn wave_1d(n: usize, f: f64) -> Vec<(f64, f64)> {
    let tau = std::f64::consts::TAU;
    (0..n).map(|k| (tau * f * k as f64).sin_cos()).map(|(s, c)| (c, s)).collect()
}

/// An image projected on one axis's wave: the image's sums against `cos` and `sin` of that
/// axis's phase, one pair per line of the other axis, and the wave's own sums of squares along
/// it. A plane wave `cos(t + p)` is `cos t cos p - sin t sin p`, so every sum a least-squares fit
/// of it needs factors into these and the other axis's phases: a fit at any frequency of the
/// other axis costs one pass over the projection.
struct Projection {
    /// Per line of the other axis: `(sum r cos t, sum r sin t)` along the projected axis.
    sums: Vec<(f64, f64)>,
    /// `(sum cos^2 t, sum sin^2 t, sum cos t sin t)` along the projected axis.
    squares: (f64, f64, f64),
}

impl Projection {
    fn squares(table: &[(f64, f64)]) -> (f64, f64, f64) {
        table.iter().fold((0.0, 0.0, 0.0), |(a, b, x), &(c, s)| (a + c * c, b + s * s, x + c * s))
    }

    /// `r` (`w` wide) projected along x on the wave of `fx`: one pair per row, fitted at a `fy`.
    fn along_x(r: &[f64], w: usize, fx: f64) -> Projection {
        let table = wave_1d(w, fx);
        let sums = r
            .chunks(w.max(1))
            .map(|row| row.iter().zip(&table).fold((0.0, 0.0), |(p, q), (v, &(c, s))| (p + v * c, q + v * s)))
            .collect();
        Projection { sums, squares: Projection::squares(&table) }
    }

    /// `r` (`w` wide) projected along y on the wave of `fy`: one pair per column, fitted at an `fx`.
    fn along_y(r: &[f64], w: usize, fy: f64) -> Projection {
        let h = r.len() / w.max(1);
        let table = wave_1d(h, fy);
        let mut sums = vec![(0.0, 0.0); w];
        for (row, &(c, s)) in r.chunks(w.max(1)).zip(&table) {
            sums.iter_mut().zip(row).for_each(|((p, q), v)| (*p, *q) = (*p + v * c, *q + v * s));
        }
        Projection { sums, squares: Projection::squares(&table) }
    }

    /// Least-squares cosine and sine coefficients of the plane wave whose other axis has the
    /// frequency `f`, and the variance it explains.
    fn fit(&self, f: f64) -> (f64, f64, f64) {
        let (a2, b2, ab) = self.squares;
        let (mut cc, mut ss, mut cs, mut rc, mut rs) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (&(p, q), (co, so)) in self.sums.iter().zip(wave_1d(self.sums.len(), f)) {
            let (c2, s2, x) = (co * co, so * so, co * so);
            cc += c2 * a2 - 2.0 * x * ab + s2 * b2;
            ss += c2 * b2 + 2.0 * x * ab + s2 * a2;
            cs += (c2 - s2) * ab + x * (a2 - b2);
            rc += co * p - so * q;
            rs += co * q + so * p;
        }
        let det = cc * ss - cs * cs;
        if det.abs() < 1e-12 {
            return (0.0, 0.0, 0.0);
        }
        let a = (rc * ss - rs * cs) / det;
        let b = (rs * cc - rc * cs) / det;
        (a, b, a * rc + b * rs)
    }
}

/// `r` minus its least-squares plane waves at `waves`, each frequency first refined on a grid of
/// 1/8 of the periodogram's 2x-oversampled spacing (the residual of a wave fitted 1/4 bin off
/// would still be a broad pattern, not noise). A sinusoid that stands above the noise is a
/// pattern, not a tail: removing it puts the tail threshold in sigmas of the pixel noise.
#[must_use]
pub fn remove_waves(r: &[f64], w: usize, h: usize, waves: &[(f64, f64)]) -> Vec<f64> {
    let mut out = r.to_vec();
    let (dx, dy) = (1.0 / (8.0 * w as f64), 1.0 / (8.0 * h as f64));
    for &(fx0, fy0) in waves {
        let mut best = (f64::NEG_INFINITY, fx0, fy0, 0.0, 0.0);
        for j in -2i32..=2 {
            let fy = fy0 + f64::from(j) * dy;
            let at_fy = Projection::along_y(&out, w, fy);
            for i in -2i32..=2 {
                let fx = fx0 + f64::from(i) * dx;
                let (a, b, explained) = at_fy.fit(fx);
                if explained > best.0 {
                    best = (explained, fx, fy, a, b);
                }
            }
        }
        let (_, fx, fy, a, b) = best;
        // a cos(t + p) + b sin(t + p) = cos t (a cos p + b sin p) + sin t (b cos p - a sin p).
        let table_x = wave_1d(w, fx);
        for (row, (cy, sy)) in out.chunks_mut(w.max(1)).zip(wave_1d(h, fy)) {
            let (u, v) = (a * cy + b * sy, b * cy - a * sy);
            row.iter_mut().zip(&table_x).for_each(|(o, &(cx, sx))| *o -= cx * u + sx * v);
        }
    }
    out
}

/// Likelihood deviance of a measured tail count `m` against a simulated one `s`: the model's
/// expectation is `lambda = s + floor` (the simulated realisation plus the Gaussian core's own
/// tail, which a single realisation shows as 0), `D = 2 (m ln(m / lambda) - (m - lambda))`,
/// scaled by `lambda / (lambda + s)` for the simulated count's own Poisson noise (so large counts
/// get the two-sample `(m - s)^2 / (m + s)`). A chi-square with variance `m + s` would score one
/// pixel at 7 sigma, where the model expects 1e-7, as 1: the deviance scores it about 30.
#[must_use]
pub fn count_deviance(m: f64, s: f64, floor: f64) -> f64 {
    let lambda = (s + floor).max(1e-12);
    let d = 2.0 * (if m > 0.0 { m * (m / lambda).ln() } else { 0.0 } - (m - lambda));
    d.max(0.0) * lambda / (lambda + s)
}

/// Row and column means over the pixels not masked.
fn masked_profiles(img: &[f64], w: usize, h: usize, mask: &[bool]) -> (Vec<f64>, Vec<f64>, f64) {
    let (mut rs, mut rn) = (vec![0f64; h], vec![0usize; h]);
    let (mut cs, mut cn) = (vec![0f64; w], vec![0usize; w]);
    let (mut g, mut gn) = (0.0, 0usize);
    for (i, &v) in img.iter().enumerate() {
        if mask[i] {
            continue;
        }
        let (r, c) = (i / w, i % w);
        rs[r] += v;
        rn[r] += 1;
        cs[c] += v;
        cn[c] += 1;
        g += v;
        gn += 1;
    }
    let g = g / gn.max(1) as f64;
    let avg = |s: Vec<f64>, n: Vec<usize>| -> Vec<f64> {
        s.into_iter().zip(n).map(|(s, n)| if n > 0 { s / n as f64 } else { g }).collect()
    };
    (avg(rs, rn), avg(cs, cn), g)
}

/// Stack statistics. Pixels beyond the threshold `t` (hot, dead) are found on a first residual
/// and left out of the profiles, so one hot pixel does not shift its whole row and column. The
/// tails are counted on the residual with the plane waves `waves` removed ([`remove_waves`]).
fn stack_stats(
    img: Vec<f64>,
    frames: usize,
    exposure_s: f64,
    photons: f64,
    t: f64,
    (w, h): (usize, usize),
    waves: &[(f64, f64)],
) -> (StackStats, Vec<f64>) {
    let first = remove_waves(&residual(&img, w, h), w, h, waves);
    let mask: Vec<bool> = first.iter().map(|v| v.abs() > t).collect();
    let (rm, cm, g) = masked_profiles(&img, w, h, &mask);
    let r: Vec<f64> = img.iter().enumerate().map(|(i, v)| v - rm[i / w] - cm[i % w] + g).collect();
    let rt = remove_waves(&r, w, h, waves);
    let kept: Vec<f64> = r.iter().zip(&rt).filter(|(_, t2)| t2.abs() <= t).map(|(v, _)| *v).collect();
    let count = |f: &dyn Fn(f64) -> bool| rt.iter().filter(|&&v| f(v)).count() as f64;
    let mut hot: Vec<f64> = rt.iter().copied().filter(|&v| v > t).collect();
    let hot_mean_dn = if hot.is_empty() { 0.0 } else { mean(&hot) };
    hot.sort_by(f64::total_cmp);
    let s = StackStats {
        frames,
        exposure_s,
        photons,
        mean_dn: mean(&img),
        resid_var_dn2: if kept.len() > 1 { var(&kept) } else { 0.0 },
        row_var_dn2: var(&rm),
        col_var_dn2: var(&cm),
        above_t: hot.len() as f64,
        above_3t: count(&|v| v > 3.0 * t),
        below_t: count(&|v| v < -t),
        above_t_mean_dn: hot_mean_dn,
        above_t_quantiles_dn: if hot.is_empty() {
            [0.0; HotPixels::QUANTILES]
        } else {
            std::array::from_fn(|i| noise::quantile_at(&hot, i as f64 / (HotPixels::QUANTILES - 1) as f64))
        },
        tail_sd_dn: robust_sd(&rt),
    };
    (s, img)
}

/// ` at G dB` when the acquisition has several gain groups.
fn gain_label(acq: &Acquisition, group: usize) -> String {
    if acq.gains_db.len() > 1 {
        format!(" at {:.2} dB", acq.gains_db.get(group).copied().unwrap_or(0.0))
    } else {
        String::new()
    }
}

/// Computes every statistic of `acq` with the measured data's thresholds.
#[must_use]
pub fn compute(acq: &Acquisition, t: &Thresholds) -> Stats {
    let (w, h) = (acq.width, acq.height);
    let n = (w * h) as f64;
    let mut entries = Vec::new();
    let mut steps = Vec::new();
    let mut darks = Vec::new();
    let mut mean_vars = Vec::new();
    // The pairs, the first dark stack and the first bright stack, in parallel.
    let first_stack =
        |dark: bool| acq.blocks.iter().position(|b| b.frames.len() > 2 && (b.light == Light::Dark) == dark);
    let (pairs, (dark_result, bright_result)) = rayon::join(
        || -> Vec<Option<PairStats>> {
            acq.blocks
                .par_iter()
                .map(|b| {
                    (b.frames.len() == 2)
                        .then(|| b.pair.clone().unwrap_or_else(|| pair_stats(&b.frames[0], &b.frames[1], w, h)))
                })
                .collect()
        },
        || {
            rayon::join(
                || {
                    first_stack(true).map(|i| {
                        let b = &acq.blocks[i];
                        let img = b.mean_image();
                        let (p, wv) = waves(&img, w, h);
                        (stack_stats(img, b.frames.len(), b.exposure_s, 0.0, t.dark_dn, (w, h), &wv), p)
                    })
                },
                || {
                    first_stack(false).map(|i| {
                        let b = &acq.blocks[i];
                        let p = b.light.photons();
                        stack_stats(b.mean_image(), b.frames.len(), b.exposure_s, p, t.bright_dn, (w, h), &[])
                    })
                },
            )
        },
    );
    for (b, pair) in acq.blocks.iter().zip(pairs) {
        if let Some(p) = pair {
            let (m, v, mv, rv, m4) = (p.mean_dn, p.var_dn2, p.mean_var, p.diff_row_var_dn2, p.m4);
            match b.light {
                Light::Bright(p) => {
                    steps.push(StepStats {
                        group: b.group,
                        photons: p,
                        exposure_s: b.exposure_s,
                        mean_dn: m,
                        var_dn2: v,
                    });
                    mean_vars.push((mv, rv, m4));
                }
                Light::Dark => {
                    darks.push(DarkStats {
                        group: b.group,
                        exposure_s: b.exposure_s,
                        mean_dn: m,
                        var_dn2: v,
                        diff_row_var_dn2: rv,
                    });
                    entries.push(Entry {
                        family: "dark",
                        label: format!("dark mean {:.4} s{}", b.exposure_s, gain_label(acq, b.group)),
                        x: b.exposure_s,
                        value: m,
                        var: mv.max(quantized_mean_var(n)),
                        count_floor: None,
                    });
                    entries.push(Entry {
                        family: "dark",
                        label: format!("dark variance {:.4} s{}", b.exposure_s, gain_label(acq, b.group)),
                        x: b.exposure_s,
                        value: v,
                        var: var_of_var(v, m4, rv, n, h as f64),
                        count_floor: None,
                    });
                }
            }
        }
    }
    let (dark_stack, dark_img, peaks) = match dark_result {
        Some(((s, img), p)) => (Some(s), Some(img), p),
        None => (None, None, Vec::new()),
    };
    let (bright_stack, bright_img) = bright_result.map_or((None, None), |(s, img)| (Some(s), Some(img)));
    for (i, (s, (mv, rv, m4))) in steps.iter().zip(&mean_vars).enumerate() {
        entries.push(Entry {
            family: "linearity",
            label: format!("step {i} mean"),
            x: s.photons,
            value: s.mean_dn,
            var: mv.max(quantized_mean_var(n)),
            count_floor: None,
        });
        entries.push(Entry {
            family: "photon_transfer",
            label: format!("step {i} variance"),
            x: s.photons,
            value: s.var_dn2,
            var: var_of_var(s.var_dn2, *m4, *rv, n, h as f64),
            count_floor: None,
        });
    }
    if let Some(d) = darks.first() {
        entries.push(Entry {
            family: "spatial",
            label: "dark pair difference row-profile variance".into(),
            x: 0.0,
            value: d.diff_row_var_dn2,
            var: 2.0 * d.diff_row_var_dn2.powi(2) / h as f64,
            count_floor: None,
        });
    }
    entries.extend(correlation_entries(acq));
    let nr = ((w.saturating_sub(1)) * (h.saturating_sub(1))).max(1) as f64;
    for (name, s) in [("dark", &dark_stack), ("bright", &bright_stack)] {
        let Some(s) = s else { continue };
        let e = |label: &str, value: f64, dof: f64| Entry {
            family: "spatial",
            label: format!("{name} stack {label}"),
            x: 0.0,
            value,
            var: 2.0 * value * value / dof,
            count_floor: None,
        };
        entries.push(e("residual variance", s.resid_var_dn2, nr));
        entries.push(e("row-profile variance", s.row_var_dn2, h as f64));
        entries.push(e("column-profile variance", s.col_var_dn2, w as f64));
        let c = |label: &str, value: f64, threshold: f64| Entry {
            family: "tails",
            label: format!("{name} stack {label}"),
            x: 0.0,
            value,
            var: value + 0.5,
            count_floor: Some(n * normal_tail(threshold / s.tail_sd_dn.max(1e-9))),
        };
        if name == "dark" {
            entries.push(c("pixels above T", s.above_t, t.dark_dn));
            entries.push(c("pixels above 3T", s.above_3t, 3.0 * t.dark_dn));
        } else {
            entries.push(c("pixels below -T", s.below_t, t.bright_dn));
        }
    }
    let falloff = bright_img.as_ref().map(|b| {
        let r2 = radius2_map(w, h);
        let sig: Vec<f64> = match &dark_img {
            Some(d) => b.iter().zip(d).map(|(x, y)| x - y).collect(),
            None => b.clone(),
        };
        // Least squares of the signal on r^2, refitted without the pixels beyond six robust
        // sigmas of the first fit: a few dead or hot pixels are not shading.
        let fit = |keep: &dyn Fn(usize) -> bool| {
            let idx: Vec<usize> = (0..sig.len()).filter(|&i| keep(i)).collect();
            let k = idx.len().max(1) as f64;
            let sm = idx.iter().map(|&i| sig[i]).sum::<f64>() / k;
            let rm = idx.iter().map(|&i| r2[i]).sum::<f64>() / k;
            let sxx: f64 = idx.iter().map(|&i| (r2[i] - rm).powi(2)).sum();
            let slope = idx.iter().map(|&i| (r2[i] - rm) * (sig[i] - sm)).sum::<f64>() / sxx.max(1e-300);
            let resid: Vec<f64> = (0..sig.len()).map(|i| sig[i] - sm - slope * (r2[i] - rm)).collect();
            (sm, slope, sxx, resid)
        };
        let (_, _, _, first) = fit(&|_| true);
        let limit = 6.0 * robust_sd(&first).max(1e-12);
        let (sm, slope, sxx, resid) = fit(&|i| first[i].abs() <= limit);
        let kept: Vec<f64> = resid.iter().copied().filter(|r| r.abs() <= limit).collect();
        let c = -slope / sm.abs().max(1e-9);
        let vc = var(&kept) / sxx.max(1e-300) / (sm * sm).max(1e-18);
        (c, vc)
    });
    if let Some((c, vc)) = falloff {
        entries.push(Entry {
            family: "spatial",
            label: "bright stack fall-off".into(),
            x: 0.0,
            value: c,
            var: vc,
            count_floor: None,
        });
    }
    for (i, p) in peaks.iter().enumerate() {
        entries.push(Entry {
            family: "spectrum",
            label: format!("dark stack 2-D periodogram peak {} / median", i + 1),
            x: p.fx_cycles_per_px,
            value: p.ratio,
            // Noise only: the maximum of many exponential bins spreads by ~1.3 floors (1.85
            // medians); a sinusoid adds its cross term with the noise.
            var: 1.85f64.powi(2) + 2.0 * p.ratio,
            count_floor: None,
        });
    }
    Stats {
        width: w,
        height: h,
        steps,
        darks,
        dark_stack,
        bright_stack,
        falloff,
        peaks,
        entries,
        thresholds: Some(*t),
        gains_db: acq.gains_db.clone(),
    }
}

/// The pairs whose pixels the `correlation` entries read, by the layout alone: the first dark
/// pair of the reference gain and its middle bright pair in photons. A simulation draws these
/// two pairs pixel for pixel; the statistics of the others are sums ([`PairStats`]).
#[must_use]
pub fn correlation_pairs(acq: &Acquisition) -> [Option<usize>; 2] {
    let pairs = || acq.blocks.iter().enumerate().filter(|(_, b)| b.group == 0 && b.frames.len() == 2);
    let dark = pairs().find(|(_, b)| b.light == Light::Dark).map(|(i, _)| i);
    let mut bright: Vec<_> = pairs().filter(|(_, b)| b.light != Light::Dark).collect();
    bright.sort_by(|(_, a), (_, b)| a.light.photons().total_cmp(&b.light.photons()));
    [dark, bright.get(bright.len() / 2).map(|(i, _)| *i)]
}

/// The `correlation` entries: neighbour correlations of the temporal noise (see
/// [`neighbour_correlation`]) of the first dark pair of the reference gain and of its middle
/// bright pair in photons (chosen by the layout alone, so measured and simulated entries are
/// the same pairs), each `var 1 / n`.
fn correlation_entries(acq: &Acquisition) -> Vec<Entry> {
    let (w, h) = (acq.width, acq.height);
    let [dark, middle] = correlation_pairs(acq).map(|i| i.map(|i| &acq.blocks[i]));
    let mut out = Vec::new();
    for (name, pair) in [("dark", dark), ("middle bright", middle)] {
        let Some(b) = pair else { continue };
        let (cx, cy) = neighbour_correlation(&b.frames[0], &b.frames[1], w, h);
        for (axis, value) in [("x", cx), ("y", cy)] {
            out.push(Entry {
                family: "correlation",
                label: format!("{name} pair difference neighbour correlation along {axis}"),
                x: b.light.photons(),
                value,
                var: 1.0 / (w * h) as f64,
                count_floor: None,
            });
        }
    }
    out
}

/// The families in report order.
pub const FAMILIES: [&str; 7] = ["linearity", "photon_transfer", "dark", "spatial", "correlation", "spectrum", "tails"];

/// A family's chi-square.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FamilyGap {
    pub family: &'static str,
    pub chi2: f64,
    pub dof: usize,
    pub chi2_per_dof: f64,
}

/// The gap between two sets of statistics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Gap {
    /// Mean over families of chi-square per degree of freedom, minus 1: ~0 when the model
    /// matches within sampling noise.
    pub gap: f64,
    /// Sum of every entry's squared normalised residual (the BIC's likelihood term).
    pub chi2_total: f64,
    pub n: usize,
    pub families: Vec<FamilyGap>,
    /// Normalised residual `(measured - simulated) / sigma` per entry, in entry order.
    pub residuals: Vec<f64>,
}

/// Normalised residual of one entry: `(m - s) / sigma`, or for a tail count the signed square
/// root of its deviance ([`count_deviance`]).
fn entry_residual(m: &Entry, s: &Entry) -> f64 {
    match s.count_floor {
        Some(floor) => (m.value - s.value).signum() * count_deviance(m.value, s.value, floor).sqrt(),
        None => (m.value - s.value) / (m.var + s.var).max(1e-18).sqrt(),
    }
}

/// Compares simulated statistics with measured ones (entries must correspond one to one).
#[must_use]
pub fn gap(measured: &Stats, simulated: &Stats) -> Gap {
    let mut residuals = Vec::new();
    let mut families = Vec::new();
    let mut total = 0.0;
    for fam in FAMILIES {
        let (mut chi2, mut dof) = (0.0, 0usize);
        for (m, s) in measured.entries.iter().zip(&simulated.entries) {
            if m.family != fam {
                continue;
            }
            let z = entry_residual(m, s);
            chi2 += z * z;
            dof += 1;
        }
        if dof > 0 {
            total += chi2;
            families.push(FamilyGap { family: fam, chi2, dof, chi2_per_dof: chi2 / dof as f64 });
        }
    }
    for (m, s) in measured.entries.iter().zip(&simulated.entries) {
        residuals.push(entry_residual(m, s));
    }
    let n = residuals.len();
    let g = families.iter().map(|f| f.chi2_per_dof).sum::<f64>() / families.len().max(1) as f64 - 1.0;
    Gap { gap: g, chi2_total: total, n, families, residuals }
}

/// Per photon-transfer step, the squared normalised residuals of its mean and variance.
#[must_use]
pub fn gap_per_step(g: &Gap, measured: &Stats) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    for (e, r) in measured.entries.iter().zip(&g.residuals) {
        if e.family == "linearity" || e.family == "photon_transfer" {
            match out.iter_mut().find(|(x, _)| *x == e.x) {
                Some(o) => o.1 += r * r,
                None => out.push((e.x, r * r)),
            }
        }
    }
    out
}
