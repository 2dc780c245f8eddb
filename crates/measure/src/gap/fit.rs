//! The sensor effects an EMVA 1288 measurement can show ([`EFFECTS`], one type each), their
//! closed-form fits from the statistics, and the measurement as a [`Problem`] of the effect
//! search ([`crate::search`], which says how effects are accepted).
//!
//! Each fit is incremental: it moves the current parameter by the residual of the statistic
//! that the effect drives (measured minus currently simulated), divided by the effect's known
//! sensitivity, so the same code both adds an effect and polishes it after the next one is in.

use super::misfit;
use super::stats::{self, Gap, Stats, Thresholds};
use super::{Acquisition, Block, Draws, GapModel, GapOptions, GapResult, Light, Step, Trial, simulate_rows};
use crate::least_squares;
use crate::search::{self, Effect, Problem};
use rayon::prelude::*;
use scene_gen_camera::sensor::{SensorModel, noise};
use std::sync::{Mutex, MutexGuard, PoisonError};
use std::time::Instant;

/// Factor on the BIC penalty of an effect whose evidence is a tail count (`hot_pixels`): its
/// statistics are Poisson counts scored by their likelihood deviance
/// ([`stats::count_deviance`]), whose variance is the model's own expectation, not estimated
/// from the data, so the plain BIC `k ln n` applies. Multiplicity over pixels is in the
/// threshold ([`stats::tail_sigmas`], [`stats::DARK_TAIL_FALSE_ALARM`]: a set without hot
/// pixels puts a pixel above it with probability below 0.1 %).
pub const COUNT_PENALTY_FACTOR: f64 = 1.0;

/// The effects the workflow can add, in the order they are tried (ties go to the earlier one).
pub const EFFECTS: [&dyn Effect<GapProblem>; 12] = [
    &BlackLevel,
    &DarkCurrent,
    &ReadNoiseSplit,
    &DitheredQuantization,
    &Saturation,
    &Nonlinearity,
    &Dsnu,
    &Prnu,
    &HotPixels,
    &RowColumnNoise,
    &PeriodicPattern,
    &IlluminationFalloff,
];

/// Effects a photon-transfer CSV can show (no images: no spatial effects).
pub const REDUCED_CANDIDATES: [&str; 5] =
    ["black_level", "dark_current", "read_noise_split", "saturation", "nonlinearity"];

/// The names of [`EFFECTS`], in order.
#[must_use]
pub fn effect_names() -> Vec<&'static str> {
    EFFECTS.iter().map(|e| e.name()).collect()
}

/// The effect called `name`, if the workflow has it.
#[must_use]
pub fn effect(name: &str) -> Option<&'static dyn Effect<GapProblem>> {
    EFFECTS.iter().copied().find(|e| e.name() == name)
}

/// What the fits read of a sensor: system gain K (DN/e-), ADC maximum (DN), black offset (DN).
struct Basics {
    k: f64,
    max: f64,
    black: f64,
}

impl Basics {
    fn of(sensor: &SensorModel) -> Basics {
        let e = &sensor.effects;
        Basics {
            k: sensor.system_gain_dn_per_e,
            max: sensor.max_dn(),
            black: if e.black_level.enabled { e.black_level.offset_dn } else { 0.0 },
        }
    }
}

/// `next` if its sensor is valid.
fn checked(next: GapModel) -> Option<GapModel> {
    next.sensor.validate().ok()?;
    Some(next)
}

/// An effect's parameters as JSON, without its `enabled` flag.
fn without_enabled(v: serde_json::Result<serde_json::Value>) -> serde_json::Value {
    let mut v = v.unwrap_or_else(|_| serde_json::json!({}));
    if let Some(o) = v.as_object_mut() {
        o.remove("enabled");
    }
    v
}

/// A model's simulated statistics and their gap to the measurement.
pub type GapSim = (Stats, Gap);

/// `black_level`: A constant offset of every pixel: the dark mean of the first dark pair, measured minus simulated.
#[derive(Debug)]
pub struct BlackLevel;

impl Effect<GapProblem> for BlackLevel {
    fn name(&self) -> &'static str {
        "black_level"
    }

    fn param_count(&self, _: &GapModel) -> usize {
        1
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, (s, _): &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        let mut next = model.clone();
        let e = &mut next.sensor.effects;
        let (dm, ds) = (m.base_darks().next()?, s.base_darks().next()?);
        let cur = if e.black_level.enabled { e.black_level.offset_dn } else { 0.0 };
        let shift_dn = dm.mean_dn - ds.mean_dn;
        e.black_level.enabled = true;
        e.black_level.offset_dn = cur + shift_dn;
        // The offset is added after the full-well clip, so it would move the saturation
        // plateau, which the data fix to a small fraction of a DN: the full well gives way.
        if e.saturation.enabled && e.saturation.full_well_e.is_finite() {
            let k = next.sensor.system_gain_dn_per_e;
            let e = &mut next.sensor.effects;
            e.saturation.full_well_e = (e.saturation.full_well_e - shift_dn / k).max(0.0);
        }
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.black_level))
    }
}

/// `dark_current`: Signal that grows with exposure in the dark: the slope of the dark means over exposure time (needs two or more dark exposures).
#[derive(Debug)]
pub struct DarkCurrent;

impl Effect<GapProblem> for DarkCurrent {
    fn name(&self) -> &'static str {
        "dark_current"
    }

    fn param_count(&self, _: &GapModel) -> usize {
        1
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, (s, _): &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        let mut next = model.clone();
        let Basics { k, .. } = Basics::of(&next.sensor);
        let e = &mut next.sensor.effects;
        if distinct_dark_exposures(m) < 2 {
            return None;
        }
        let ts: Vec<f64> = m.base_darks().map(|d| d.exposure_s).collect();
        let sm = slope(&ts, &m.base_darks().map(|d| d.mean_dn).collect::<Vec<_>>());
        let ss = slope(&ts, &s.base_darks().map(|d| d.mean_dn).collect::<Vec<_>>());
        let cur = if e.dark_current.enabled { e.dark_current.rate_e_per_s } else { 0.0 };
        let rate = (cur + (sm - ss) / k).max(0.0);
        if rate <= 0.0 {
            return None;
        }
        e.dark_current.enabled = true;
        e.dark_current.rate_e_per_s = rate;
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.dark_current))
    }
}

/// `quantization`, dithered: rounding after a uniform noise one DN wide
/// ([`scene_gen_camera::sensor::noise::Quantization::dither_dn`]), in place of plain rounding.
/// Seen where the dark noise is below about half a DN: plain rounding makes the dark means and
/// variances waver with the dark signal's fraction of a DN as it grows with exposure, dithered
/// rounding keeps them smooth. The read noise gives up the dither's variance (`1/12` DN^2), so
/// the dark variance stays where the data put it.
#[derive(Debug)]
pub struct DitheredQuantization;

/// Width of the dither [`DitheredQuantization`] fits, DN: one level, the EMVA 1288 reference
/// simulator's.
pub const DITHER_DN: f64 = 1.0;

impl Effect<GapProblem> for DitheredQuantization {
    fn name(&self) -> &'static str {
        "quantization"
    }

    fn param_count(&self, _: &GapModel) -> usize {
        1
    }

    fn fit(&self, _: &GapProblem, model: &GapModel, _: &GapSim) -> Option<GapModel> {
        let mut next = model.clone();
        let k = next.sensor.system_gain_dn_per_e;
        let q = &mut next.sensor.effects.quantization;
        if !q.enabled || q.dither_dn > 0.0 {
            return None;
        }
        q.dither_dn = DITHER_DN;
        let read_var_e2 = next.sensor.read_noise_e.powi(2) - DITHER_DN * DITHER_DN / 12.0 / (k * k);
        next.sensor.read_noise_e = read_var_e2.max(0.0).sqrt();
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.quantization))
    }
}

/// `read_noise_split`: Read noise split between before and after the analogue gain: seen as dark variances that do not scale with the square of the gain (needs several gains).
#[derive(Debug)]
pub struct ReadNoiseSplit;

impl Effect<GapProblem> for ReadNoiseSplit {
    fn name(&self) -> &'static str {
        "read_noise_split"
    }

    fn param_count(&self, _: &GapModel) -> usize {
        1
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, (s, _): &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        let mut next = model.clone();
        let Basics { k, .. } = Basics::of(&next.sensor);
        let sensor = &mut next.sensor;
        let e = &mut sensor.effects;
        // Dark variance at gain g: K^2 (g^2 (1 - f) + f) v + ...: its slope in the post-gain
        // fraction f is K^2 v (1 - g^2). Weighted mean of the per-pair corrections over the
        // dark pairs away from the reference gain (weights: squared slope over the variance of
        // the variance difference).
        let v = sensor.read_noise_e * sensor.read_noise_e;
        let split = e.read_noise_split;
        let cur = if split.enabled { split.post_gain_fraction } else { 0.0 };
        let (mut num, mut den) = (0.0, 0.0);
        for (dm, ds) in m.darks.iter().zip(&s.darks).filter(|(d, _)| d.group > 0) {
            let g0 = noise::gain_factor(s.gains_db.first().copied().unwrap_or(0.0));
            let g = noise::gain_factor(s.gains_db.get(dm.group).copied().unwrap_or(0.0));
            let slope = k * k * v * (g0 * g0 - g * g);
            let vv = 2.0 * (dm.var_dn2.powi(2) + ds.var_dn2.powi(2)) / (m.width * m.height).max(1) as f64;
            if slope.abs() < 1e-12 || vv <= 0.0 {
                continue;
            }
            let w = slope * slope / vv;
            num += w * (dm.var_dn2 - ds.var_dn2) / slope;
            den += w;
        }
        if den <= 0.0 {
            return None;
        }
        let f = (cur + num / den).clamp(0.0, 1.0);
        if f <= 0.0 {
            return None;
        }
        e.read_noise_split.enabled = true;
        e.read_noise_split.post_gain_fraction = f;
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.read_noise_split))
    }
}

/// `saturation`: A full well below the ADC limit: the plateau of the step means.
#[derive(Debug)]
pub struct Saturation;

impl Effect<GapProblem> for Saturation {
    fn name(&self) -> &'static str {
        "saturation"
    }

    fn param_count(&self, _: &GapModel) -> usize {
        1
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, _: &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        let mut next = model.clone();
        let Basics { k, max, black, .. } = Basics::of(&next.sensor);
        let e = &mut next.sensor.effects;
        if e.saturation.enabled {
            return None;
        }
        let plateau = m.base_steps().map(|p| p.mean_dn).fold(f64::NEG_INFINITY, f64::max);
        // At the ADC limit the full well cannot be told from the ADC clip.
        if plateau >= 0.98 * max {
            return None;
        }
        let target = plateau - black;
        let nl = e.nonlinearity;
        let mut y = target;
        for _ in 0..20 {
            y = target / nl.factor(y / max);
        }
        if y.is_nan() || y <= 0.0 {
            return None;
        }
        e.saturation.enabled = true;
        e.saturation.full_well_e = y / k;
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.saturation))
    }
}

/// `nonlinearity`: A response that bends away from linear, `y (1 + a1 r + a2 r^2 + a3 r^3)` with `r` the share of full scale, of the order (1 to 3) the penalty chooses; fitted jointly with a responsivity correction.
#[derive(Debug)]
pub struct Nonlinearity;

impl Nonlinearity {
    /// The order whose fit pays its penalty best: each order `n` (the terms `r^1..r^n`) is
    /// fitted to the mean residuals by weighted least squares, jointly with the responsivity
    /// nuisance, and scored by its chi-square plus the search's penalty on the order the model
    /// would have. The increments of the chosen fit, responsivity first.
    fn best_order(rows: &[MeanRow], max: f64, current_order: usize, ln_n: f64) -> Option<Vec<f64>> {
        let basis: Vec<[f64; 4]> = rows
            .iter()
            .map(|&(_, y, _)| {
                let r = y / max;
                [y, y * r, y * r * r, y * r * r * r]
            })
            .collect();
        (1..=noise::Nonlinearity::MAX_ORDER)
            .filter_map(|n| {
                let rows = basis.iter().zip(rows).map(|(b, &(resid, _, w))| (&b[..=n], resid, w));
                let fit = least_squares::fit(rows, n + 1)?;
                let order = n.max(current_order);
                Some((fit.chi2 + search::PENALTY_FACTOR * order as f64 * ln_n, fit.coefficients))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, c)| c)
    }
}

impl Effect<GapProblem> for Nonlinearity {
    fn name(&self) -> &'static str {
        "nonlinearity"
    }

    fn param_count(&self, model: &GapModel) -> usize {
        model.sensor.effects.nonlinearity.order().max(1)
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, sim: &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        let mut next = model.clone();
        let Basics { max, .. } = Basics::of(&next.sensor);
        let sensor = &mut next.sensor;
        let current = sensor.effects.nonlinearity;
        let (_, rows) = mean_rows(m, &sim.0, max)?;
        let increments = Self::best_order(&rows, max, current.order(), problem.ln_n(sim))?;
        let mut a = if current.enabled { current.coefficients() } else { [0.0; 3] };
        for (a, da) in a.iter_mut().zip(&increments[1..]) {
            *a += da;
        }
        sensor.effects.nonlinearity = noise::Nonlinearity { enabled: true, a1: a[0], a2: a[1], a3: a[2] };
        sensor.quantum_efficiency = (sensor.quantum_efficiency * (1.0 + increments[0])).clamp(0.0, 1.0);
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.nonlinearity))
    }
}

/// `dsnu`: Dark signal non-uniformity: spatial variance of the averaged dark stack beyond the model's.
#[derive(Debug)]
pub struct Dsnu;

impl Effect<GapProblem> for Dsnu {
    fn name(&self) -> &'static str {
        "dsnu"
    }

    fn param_count(&self, _: &GapModel) -> usize {
        1
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, (s, _): &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        let mut next = model.clone();
        let Basics { k, .. } = Basics::of(&next.sensor);
        let e = &mut next.sensor.effects;
        let (dm, ds) = (m.dark_stack?, s.dark_stack?);
        let cur = if e.dsnu.enabled { e.dsnu.std_e } else { 0.0 };
        let v = cur * cur + (dm.resid_var_dn2 - ds.resid_var_dn2) / (k * k);
        if v <= 0.0 {
            return None;
        }
        e.dsnu.enabled = true;
        e.dsnu.std_e = v.sqrt();
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.dsnu))
    }
}

/// `prnu`: Photo-response non-uniformity: spatial variance of the averaged bright stack beyond the model's and the dark stack's.
#[derive(Debug)]
pub struct Prnu;

impl Effect<GapProblem> for Prnu {
    fn name(&self) -> &'static str {
        "prnu"
    }

    fn param_count(&self, _: &GapModel) -> usize {
        1
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, (s, _): &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        let mut next = model.clone();
        let Basics { black, .. } = Basics::of(&next.sensor);
        let e = &mut next.sensor.effects;
        let (bm, bs) = (m.bright_stack?, s.bright_stack?);
        let dark = m.dark_stack.map_or(black, |d| d.mean_dn);
        let dark_excess = match (m.dark_stack, s.dark_stack) {
            (Some(a), Some(b)) => a.resid_var_dn2 - b.resid_var_dn2,
            _ => 0.0,
        };
        let signal = bm.mean_dn - dark;
        if signal <= 0.0 {
            return None;
        }
        let cur = if e.prnu.enabled { e.prnu.std_fraction } else { 0.0 };
        let v = cur * cur + (bm.resid_var_dn2 - bs.resid_var_dn2 - dark_excess) / (signal * signal);
        if v <= 0.0 {
            return None;
        }
        e.prnu.enabled = true;
        e.prnu.std_fraction = v.sqrt();
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.prnu))
    }
}

/// `hot_pixels`: Pixels with a large excess dark signal, its distribution the one seen above the tail threshold (uniform from 0 where fewer than eight are seen): counts of dark-stack pixels above the tail thresholds, scored by their Poisson deviance (its variance is the model's own, so its penalty factor is 1).
#[derive(Debug)]
pub struct HotPixels;

impl Effect<GapProblem> for HotPixels {
    fn name(&self) -> &'static str {
        "hot_pixels"
    }

    /// The fraction and the excess's scale, which the tail counts constrain; the shape of the
    /// excess is read off the seen pixels, not fitted to the statistics.
    fn param_count(&self, _: &GapModel) -> usize {
        2
    }

    fn penalty_factor(&self) -> f64 {
        COUNT_PENALTY_FACTOR
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, (s, _): &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        let mut next = model.clone();
        let Basics { k, .. } = Basics::of(&next.sensor);
        let e = &mut next.sensor.effects;
        if e.hot_pixels.enabled {
            return None;
        }
        let (dm, ds) = (m.dark_stack?, s.dark_stack?);
        if dm.exposure_s <= 0.0 {
            return None;
        }
        let t = m.thresholds?.dark_dn;
        let above = dm.above_t - ds.above_t;
        if above < 1.0 {
            return None;
        }
        let n = (m.width * m.height) as f64;
        let per_dn = 1.0 / (k * dm.exposure_s);
        let hp = &mut e.hot_pixels;
        hp.enabled = true;
        if above < noise::HotPixels::QUANTILES as f64 {
            // Too few seen to show a shape: uniform in 0..X DN, the pixels above T having mean
            // excess (T + X) / 2 and a fraction (1 - T/X) of hot pixels clearing T.
            let x = (2.0 * dm.above_t_mean_dn - t).max(1.05 * t);
            hp.fraction = (above / (n * (1.0 - t / x))).min(1.0);
            hp.max_excess_e_per_s = x * per_dn;
            hp.excess_quantiles_e_per_s = None;
        } else {
            let (fraction, quantiles_dn) = hot_excess_distribution(&dm.above_t_quantiles_dn, above, t, n)?;
            hp.fraction = fraction;
            hp.excess_quantiles_e_per_s = Some(quantiles_dn.map(|v| v * per_dn));
            hp.max_excess_e_per_s = quantiles_dn[noise::HotPixels::QUANTILES - 1] * per_dn;
        }
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.hot_pixels))
    }
}

/// The hot pixels' fraction and excess distribution (quantiles, DN) from the `above` pixels
/// seen above the threshold `t` (their residuals' quantiles `seen_dn`) among `n`. Below `t`
/// the excess is hidden in the noise; the distribution is continued there at its density just
/// above `t` (from the lower three sevenths of the seen values), which is exact for a uniform
/// excess and low for one that rises towards 0 (those pixels are not told from the noise).
fn hot_excess_distribution(
    seen_dn: &[f64; noise::HotPixels::QUANTILES],
    above: f64,
    t: f64,
    n: f64,
) -> Option<(f64, [f64; noise::HotPixels::QUANTILES])> {
    const Q: usize = noise::HotPixels::QUANTILES;
    let spread = seen_dn[Q - 1] - seen_dn[0];
    // Quantized data gives tied residuals: a floor on the spacing keeps the density finite.
    let spacing = (seen_dn[3] - seen_dn[0]).max(0.05 * spread);
    let below = if spacing > 0.0 { (3.0 / (Q - 1) as f64 * above / spacing * t).min(n - above) } else { 0.0 };
    let total = above + below.max(0.0);
    let w = below.max(0.0) / total;
    let quantiles = std::array::from_fn(|i| {
        let p = i as f64 / (Q - 1) as f64;
        if p <= w && w > 0.0 { p / w * t } else { noise::quantile_at(seen_dn, (p - w) / (1.0 - w)) }
    });
    let fraction = (total / n).min(1.0);
    (fraction > 0.0).then_some((fraction, quantiles))
}

/// `row_column_noise`: Noise shared along rows (temporal) and columns (fixed): row variance of a dark difference frame, column variance of the dark stack.
#[derive(Debug)]
pub struct RowColumnNoise;

impl Effect<GapProblem> for RowColumnNoise {
    fn name(&self) -> &'static str {
        "row_column_noise"
    }

    fn param_count(&self, _: &GapModel) -> usize {
        2
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, (s, _): &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        let mut next = model.clone();
        let e = &mut next.sensor.effects;
        let (dm, ds) = (m.base_darks().next()?, s.base_darks().next()?);
        let rc = e.row_column_noise;
        let (cr, cc) = if rc.enabled { (rc.row_std_dn, rc.column_std_dn) } else { (0.0, 0.0) };
        let row2 = (cr * cr + dm.diff_row_var_dn2 - ds.diff_row_var_dn2).max(0.0);
        let col2 = match (m.dark_stack, s.dark_stack) {
            (Some(a), Some(b)) => (cc * cc + a.col_var_dn2 - b.col_var_dn2).max(0.0),
            _ => cc * cc,
        };
        if row2 <= 0.0 && col2 <= 0.0 {
            return None;
        }
        e.row_column_noise.enabled = true;
        e.row_column_noise.row_std_dn = row2.sqrt();
        e.row_column_noise.column_std_dn = col2.sqrt();
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.row_column_noise))
    }
}

/// `periodic_pattern`: Up to two sinusoidal fixed patterns, each with its own frequency and
/// amplitude: peaks of the dark stack's periodogram well above a white image's.
#[derive(Debug)]
pub struct PeriodicPattern;

/// Peaks of two periodograms closer than this in both frequencies are the same wave, cycles/px.
const SAME_WAVE_CYCLES_PER_PX: f64 = 0.02;

fn same_wave(a: (f64, f64), b: (f64, f64)) -> bool {
    (a.0 - b.0).abs() < SAME_WAVE_CYCLES_PER_PX && (a.1 - b.1).abs() < SAME_WAVE_CYCLES_PER_PX
}

/// The waves of `pp` that are present, as ((fx, fy) cycles/px, amplitude DN).
fn model_waves(pp: &noise::PeriodicPattern) -> Vec<((f64, f64), f64)> {
    if !pp.enabled {
        return Vec::new();
    }
    let (ax, ay) = pp.amplitudes();
    let [x, y] = pp.waves_present();
    let mut waves = Vec::with_capacity(2);
    if x {
        waves.push(((pp.freq_x_cycles_per_px, pp.wave_x_freq_y_cycles_per_px), ax));
    }
    if y {
        waves.push(((pp.wave_y_freq_x_cycles_per_px, pp.freq_y_cycles_per_px), ay));
    }
    waves
}

impl Effect<GapProblem> for PeriodicPattern {
    fn name(&self) -> &'static str {
        "periodic_pattern"
    }

    /// Two frequencies and an amplitude per wave.
    fn param_count(&self, model: &GapModel) -> usize {
        3 * model_waves(&model.sensor.effects.periodic_pattern).len().max(1)
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, (s, _): &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        // The waves: measured peaks standing well above the ~15 medians a white image's
        // largest bin reaches. Each wave's amplitude^2 is the current model's plus the excess
        // of the measured peak's power over the simulated one's at the same frequency.
        let current = model_waves(&model.sensor.effects.periodic_pattern);
        let power_near = |peaks: &[stats::Peak], f: (f64, f64)| -> f64 {
            peaks
                .iter()
                .filter(|q| same_wave(f, (q.fx_cycles_per_px, q.fy_cycles_per_px)))
                .map(|q| q.amp2_dn2)
                .fold(0.0, f64::max)
        };
        let waves: Vec<((f64, f64), f64)> = m
            .peaks
            .iter()
            .filter(|p| p.ratio > stats::PEAK_RATIO)
            .take(2)
            .filter_map(|p| {
                let f = (p.fx_cycles_per_px, p.fy_cycles_per_px);
                let cur = current.iter().find(|(g, _)| same_wave(f, *g)).map_or(0.0, |(_, a)| a * a);
                let a2 = cur + p.amp2_dn2 - power_near(&s.peaks, f);
                (a2 > 0.0).then(|| (f, a2.sqrt()))
            })
            .collect();
        let &((fx, wx), ax) = waves.first()?;
        let mut next = model.clone();
        let p = &mut next.sensor.effects.periodic_pattern;
        p.enabled = true;
        p.amplitude_dn = ax;
        p.freq_x_cycles_per_px = fx;
        p.wave_x_freq_y_cycles_per_px = wx;
        // The second wave goes in the (wy, fy) slot; absent: zero frequencies, no wave.
        let ((wy, fy), ay) = waves.get(1).copied().unwrap_or(((0.0, 0.0), ax));
        p.wave_y_freq_x_cycles_per_px = wy;
        p.freq_y_cycles_per_px = fy;
        p.amplitude_y_dn = (ay != ax).then_some(ay);
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.sensor.effects.periodic_pattern))
    }
}

/// `illumination_falloff`: Light falling off towards the frame corners: the bright stack's mean ratio of corners to centre.
#[derive(Debug)]
pub struct IlluminationFalloff;

impl Effect<GapProblem> for IlluminationFalloff {
    fn name(&self) -> &'static str {
        "illumination_falloff"
    }

    fn param_count(&self, _: &GapModel) -> usize {
        1
    }

    fn fit(&self, problem: &GapProblem, model: &GapModel, (s, _): &GapSim) -> Option<GapModel> {
        let m = &problem.ev.m;
        let mut next = model.clone();
        let ((cm, _), (cs, _)) = (m.falloff?, s.falloff?);
        let f = &mut next.optics.illumination_falloff;
        let cur = if f.enabled { f.corner_loss_fraction } else { 0.0 };
        f.enabled = true;
        f.corner_loss_fraction = (cur + cm - cs).clamp(-0.9, 0.9);
        checked(next)
    }

    fn params(&self, model: &GapModel) -> serde_json::Value {
        without_enabled(serde_json::to_value(model.optics.illumination_falloff))
    }
}

/// Least-squares slope of y on x.
fn slope(xs: &[f64], ys: &[f64]) -> f64 {
    let n = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    let sxy: f64 = xs.iter().zip(ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    if sxx > 0.0 { sxy / sxx } else { 0.0 }
}

fn distinct_dark_exposures(m: &Stats) -> usize {
    let mut ts: Vec<f64> = m.base_darks().map(|d| d.exposure_s).collect();
    ts.sort_by(f64::total_cmp);
    ts.dedup_by(|a, b| (*a - *b).abs() <= 1e-12);
    ts.len()
}

/// (residual, simulated signal, weight) of one step.
type MeanRow = (f64, f64, f64);

/// Per unsaturated step (below 90 % of the measured plateau): residual of the signal above the
/// dark pair nearest in exposure (measured minus simulated), simulated signal, weight 1 /
/// variance. Offsets (black level, dark signal) cancel, so a responsivity fit leaves them to
/// their effects. Also the plateau.
fn mean_rows(m: &Stats, s: &Stats, max: f64) -> Option<(f64, Vec<MeanRow>)> {
    let plateau = m.base_steps().map(|p| p.mean_dn).fold(f64::NEG_INFINITY, f64::max).min(max);
    let dark = |st: &Stats, t: f64| -> Option<f64> {
        st.base_darks().min_by(|a, b| (a.exposure_s - t).abs().total_cmp(&(b.exposure_s - t).abs())).map(|d| d.mean_dn)
    };
    let vars: Vec<f64> = m.entries.iter().filter(|e| e.family == "linearity").map(|e| e.var).collect();
    let svars: Vec<f64> = s.entries.iter().filter(|e| e.family == "linearity").map(|e| e.var).collect();
    let floor = m.base_darks().next()?.mean_dn;
    let mut rows = Vec::new();
    for (i, (pm, ps)) in m.steps.iter().zip(&s.steps).enumerate() {
        if pm.group != 0 || pm.mean_dn > floor + 0.9 * (plateau - floor) {
            continue;
        }
        let (dm, ds) = (dark(m, pm.exposure_s)?, dark(s, ps.exposure_s)?);
        let v = vars.get(i).copied().unwrap_or(1.0) + svars.get(i).copied().unwrap_or(0.0);
        rows.push(((pm.mean_dn - dm) - (ps.mean_dn - ds), ps.mean_dn - ds, 1.0 / v.max(1e-12)));
    }
    (rows.len() >= 2).then_some((plateau, rows))
}

/// Response slope (DN per photon, through the origin) of gain group `group` of `st`, over the
/// steps whose measured signal is in the lower 40 % of the range above dark (`keep`).
fn response_slope(st: &Stats, group: usize, keep: &[bool]) -> Option<f64> {
    let dark = |t: f64| -> Option<f64> {
        st.darks
            .iter()
            .filter(|d| d.group == group)
            .min_by(|a, b| (a.exposure_s - t).abs().total_cmp(&(b.exposure_s - t).abs()))
            .map(|d| d.mean_dn)
    };
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (p, _) in st.steps.iter().zip(keep).filter(|(p, k)| p.group == group && **k) {
        let y = p.mean_dn - dark(p.exposure_s)?;
        sxy += p.photons * y;
        sxx += p.photons * p.photons;
    }
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Replaces the simulated dark stack's tail counts by their expectation under `model`: the
/// Gaussian core's `n Q(T / sd)` plus the hot pixels', `n f E_u[Q((T - u) / sd)]` over the
/// model's distribution of the excess `u` (`sd` the simulated tail residual's robust sd). One simulated
/// realisation of a count of a few pixels is itself Poisson noise; the measured count is scored
/// against the model's expected count instead (the entry's `count_floor`, the simulated value 0,
/// see [`stats::count_deviance`]), so the hot-pixel evidence is its exact Poisson deviance.
fn expect_dark_tails(s: &mut Stats, model: &GapModel, t: &Thresholds) {
    let Some(ds) = s.dark_stack else { return };
    let sd = ds.tail_sd_dn.max(1e-9);
    let n = (s.width * s.height) as f64;
    let hp = model.sensor.effects.hot_pixels;
    let gain = noise::gain_factor(s.gains_db.first().copied().unwrap_or(0.0));
    let per_e_per_s = model.sensor.system_gain_dn_per_e * gain * ds.exposure_s;
    let f = if hp.enabled { hp.fraction } else { 0.0 };
    let expect = |thr: f64| -> f64 {
        // Midpoint rule over the excess's probabilities, 256 nodes.
        let excess_dn = |j: u32| hp.excess_at((f64::from(j) + 0.5) / 256.0) * per_e_per_s;
        let hot = (0..256).map(|j| stats::normal_tail((thr - excess_dn(j)) / sd)).sum::<f64>();
        n * ((1.0 - f) * stats::normal_tail(thr / sd) + f * hot / 256.0)
    };
    for e in &mut s.entries {
        let thr = match e.label.as_str() {
            "dark stack pixels above T" => t.dark_dn,
            "dark stack pixels above 3T" => 3.0 * t.dark_dn,
            _ => continue,
        };
        e.value = 0.0;
        e.count_floor = Some(expect(thr));
    }
}

/// The value behind a lock of the evaluator's caches (a panic while one was held leaves
/// nothing half-written: entries are inserted whole).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Evaluates models against one measured acquisition.
struct Evaluator {
    /// The acquisition layout (frame counts, exposures, photons, gain groups); its gains are
    /// refined by [`Evaluator::refit_group_gains`].
    layout: Acquisition,
    /// Compare only the statistics of a photon-transfer CSV ([`Stats::reduced`]).
    reduced: bool,
    t: Thresholds,
    m: Stats,
    seed: u64,
    /// How simulations draw each block's pixels ([`super::block_draws`]).
    draws: Vec<Draws>,
    /// Index of the first dark pair (for the read-noise refit).
    dark_pair: usize,
    /// The last models evaluated, with the group gains they were simulated at, and their
    /// results: the search re-evaluates unchanged models (the start model after a gain refit
    /// that changed nothing, a polish proposal equal to the current model), and a simulation is
    /// deterministic, so a repeat is a lookup.
    cache: Mutex<Vec<EvalEntry>>,
    /// The simulations the search ran, by kind.
    counts: Mutex<Counts>,
}

/// Simulations a search ran, by kind (what its time goes to; logged at the end).
#[derive(Debug, Default, Clone, Copy)]
struct Counts {
    /// Full simulations.
    full: Tally,
    /// Evaluations answered from the cache.
    cached: usize,
    /// Screening windows simulated ([`Screen`]).
    windows: Tally,
    /// Dark-pair variances of the read-noise refits (from moments, or a one-pair simulation).
    dark_pairs: Tally,
}

/// How many of one kind of simulation ran, and their seconds (summed over the threads that ran
/// them side by side).
#[derive(Debug, Default, Clone, Copy)]
struct Tally {
    n: usize,
    seconds: f64,
}

impl Tally {
    /// One more, begun at `started`.
    fn add(&mut self, started: Instant) {
        self.n += 1;
        self.seconds += started.elapsed().as_secs_f64();
    }
}

/// A cached evaluation: model, group gains (dB), statistics and gap.
type EvalEntry = (GapModel, Vec<f64>, Stats, Gap);

/// Evaluations kept in [`Evaluator::cache`] (most recent first).
const EVAL_CACHE: usize = 8;

impl Evaluator {
    /// The blocks `which` (all when None) of the layout simulated with `model` from `seed`.
    fn simulate(&self, model: &GapModel, seed: u64, which: Option<&[usize]>) -> Acquisition {
        simulate_rows(model, &self.layout, seed, which, self.layout.height, &self.draws)
    }

    fn eval(&self, model: &GapModel) -> (Stats, Gap) {
        let hit = lock(&self.cache)
            .iter()
            .find(|(m, g, _, _)| m == model && *g == self.layout.gains_db)
            .map(|(_, _, s, g)| (s.clone(), g.clone()));
        if let Some(r) = hit {
            lock(&self.counts).cached += 1;
            return r;
        }
        let started = Instant::now();
        let sim = self.simulate(model, self.seed, None);
        let mut s = stats::compute(&sim, &self.t);
        drop(sim);
        expect_dark_tails(&mut s, model, &self.t);
        if self.reduced {
            s = s.reduced();
        }
        s.thresholds = Some(self.t);
        let g = stats::gap(&self.m, &s);
        lock(&self.counts).full.add(started);
        let mut cache = lock(&self.cache);
        cache.insert(0, (model.clone(), self.layout.gains_db.clone(), s.clone(), g.clone()));
        cache.truncate(EVAL_CACHE);
        (s, g)
    }

    /// Statistics of replicate `index` of `model`: fresh temporal noise and a fresh fixed
    /// pattern (another camera of the same model), computed as the measurement's are.
    fn replicate(&self, model: &GapModel, index: usize) -> Stats {
        let (seed, pattern_seed) = misfit::replicate_seeds(self.seed, "gap/replicate", index);
        let mut camera = model.clone();
        camera.sensor.pattern_seed = pattern_seed;
        let sim = self.simulate(&camera, seed, None);
        let mut s = stats::compute(&sim, &self.t);
        if self.reduced {
            s = s.reduced();
        }
        s.thresholds = Some(self.t);
        s
    }

    /// Temporal variance of the simulated first dark pair: expected from its pixels' moments
    /// where the search draws it from them ([`super::pair_variance_from_moments`]), else of
    /// its simulation.
    fn dark_var(&self, model: &GapModel) -> f64 {
        let started = Instant::now();
        let from_moments = (self.draws.get(self.dark_pair) == Some(&Draws::Moments))
            .then(|| super::pair_variance_from_moments(model, &self.layout, self.dark_pair, self.seed))
            .flatten();
        let var = from_moments.unwrap_or_else(|| self.simulated_dark_var(model));
        lock(&self.counts).dark_pairs.add(started);
        var
    }

    /// Temporal variance of the first dark pair simulated alone.
    fn simulated_dark_var(&self, model: &GapModel) -> f64 {
        let sim = self.simulate(model, self.seed, Some(&[self.dark_pair]));
        let b = &sim.blocks[self.dark_pair];
        let n = b.frames[0].len() as f64;
        let d: Vec<f64> = b.frames[0].iter().zip(&b.frames[1]).map(|(&x, &y)| f64::from(x) - f64::from(y)).collect();
        let md = d.iter().sum::<f64>() / n;
        d.iter().map(|v| (v - md) * (v - md)).sum::<f64>() / (n - 1.0) / 2.0
    }

    /// Refits the read noise so the simulated dark-pair variance matches the measured one
    /// (secant on the variance in e-^2; handles dark frames clipped at 0 DN).
    fn refit_read_noise(&self, model: &mut GapModel) {
        let target = self.m.darks[0].var_dn2;
        let k = model.sensor.system_gain_dn_per_e;
        let at = |model: &GapModel, v: f64| {
            let mut t = model.clone();
            t.sensor.read_noise_e = v.max(0.0).sqrt();
            self.dark_var(&t) - target
        };
        let mut x0 = model.sensor.read_noise_e.powi(2);
        let mut f0 = at(model, x0);
        let mut x1 = (x0 - f0 / (k * k)).max(0.0);
        if (x1 - x0).abs() < 1e-9 {
            return;
        }
        let mut f1 = at(model, x1);
        for _ in 0..6 {
            if (f1 - f0).abs() < 1e-12 || f1.abs() < 1e-4 * target {
                break;
            }
            let x2 = (x1 - f1 * (x1 - x0) / (f1 - f0)).max(0.0);
            (x0, f0) = (x1, f1);
            x1 = x2;
            f1 = at(model, x1);
        }
        let best = if f1.abs() <= f0.abs() { x1 } else { x0 };
        model.sensor.read_noise_e = best.max(0.0).sqrt();
    }

    /// Refits the responsivity (through QE) so the simulated step means match the measured
    /// ones below 90 % of the plateau (weighted least squares of a scale).
    fn refit_responsivity(&self, model: &mut GapModel, s: &Stats) {
        let Some((_, rows)) = mean_rows(&self.m, s, model.sensor.max_dn()) else { return };
        let num: f64 = rows.iter().map(|(r, y, w)| w * r * y).sum();
        let den: f64 = rows.iter().map(|(_, y, w)| w * y * y).sum();
        if den > 0.0 {
            let q = &mut model.sensor.quantum_efficiency;
            *q = (*q * (1.0 + num / den)).clamp(0.0, 1.0);
        }
    }

    /// Refits K (keeping the responsivity K QE) from the slope of temporal variance against
    /// mean below 90 % of the plateau, measured over simulated; offsets (dark level, clipped darks, read
    /// noise) do not enter a slope.
    fn refit_gain(&self, model: &mut GapModel, s: &Stats) {
        let plateau = self.m.base_steps().map(|p| p.mean_dn).fold(f64::NEG_INFINITY, f64::max);
        let floor = self.m.base_darks().next().map_or(0.0, |d| d.mean_dn);
        let keep: Vec<bool> =
            self.m.steps.iter().map(|p| p.group == 0 && p.mean_dn <= floor + 0.9 * (plateau - floor)).collect();
        // Weighted least-squares slope (weights 1 / var^2: the variance of a variance).
        let wslope = |st: &Stats| -> f64 {
            let pts: Vec<(f64, f64, f64)> = st
                .steps
                .iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(p, _)| (p.mean_dn, p.var_dn2, 1.0 / p.var_dn2.max(1e-9).powi(2)))
                .collect();
            let sw: f64 = pts.iter().map(|p| p.2).sum();
            let mx = pts.iter().map(|p| p.2 * p.0).sum::<f64>() / sw;
            let my = pts.iter().map(|p| p.2 * p.1).sum::<f64>() / sw;
            let sxy: f64 = pts.iter().map(|p| p.2 * (p.0 - mx) * (p.1 - my)).sum();
            let sxx: f64 = pts.iter().map(|p| p.2 * (p.0 - mx) * (p.0 - mx)).sum();
            sxy / sxx
        };
        if keep.iter().filter(|k| **k).count() < 3 {
            return;
        }
        let r = wslope(&self.m) / wslope(s);
        if r.is_finite() && r > 0.0 {
            let sensor = &mut model.sensor;
            let responsivity = sensor.system_gain_dn_per_e * sensor.quantum_efficiency;
            sensor.system_gain_dn_per_e *= r;
            sensor.quantum_efficiency = (responsivity / sensor.system_gain_dn_per_e).clamp(0.0, 1.0);
            sensor.read_noise_e /= r;
        }
    }

    /// Refits the gain of every group but the reference: its gain times the ratio of the
    /// measured to the simulated response slope over the lower 40 % of the range (a nuisance
    /// of the layout, like the responsivity of the model). Returns whether any changed.
    fn refit_group_gains(&mut self, s: &Stats) -> bool {
        let max = f64::from((1u32 << self.layout.bits) - 1);
        let mut changed = false;
        for group in 1..self.layout.gains_db.len() {
            let floor = self.m.darks.iter().find(|d| d.group == group).map_or(0.0, |d| d.mean_dn);
            let keep: Vec<bool> = self.m.steps.iter().map(|p| p.mean_dn - floor <= 0.4 * (max - floor)).collect();
            let (Some(a), Some(b)) = (response_slope(&self.m, group, &keep), response_slope(s, group, &keep)) else {
                continue;
            };
            if a > 0.0 && b > 0.0 {
                let d = 20.0 * (a / b).log10();
                if d.abs() > 1e-6 {
                    self.layout.gains_db[group] += d;
                    changed = true;
                }
            }
        }
        changed
    }

    /// Refits the nuisance parameters of the linear model: K, read noise, responsivity.
    fn refit_base(&self, model: &mut GapModel, s: &Stats) {
        self.refit_gain(model, s);
        self.refit_read_noise(model);
        let (s, _) = self.eval(model);
        self.refit_responsivity(model, &s);
    }
}

/// The gain of a polishing pass below which polishing stops, at a chi-square of `chi2`: 1, or a
/// ten-thousandth of the chi-square where that is larger. A large chi-square means large effects
/// are still missing, and the next round adds one of them (its drop is of the order of the
/// chi-square); refits that move it by tens leave that choice as it is, and near the end,
/// where the chi-square is of the order of the number of statistics, the threshold is 1.
fn polish_enough(chi2: f64) -> f64 {
    (1e-4 * chi2).max(1.0)
}

/// Frames of at least this many rows have their candidates screened (see `Screen`). Below it
/// (the hidden-effect sets, the 160x120 crop of set 003) every candidate is simulated in full.
pub const SCREEN_MIN_ROWS: usize = 240;

/// Most candidates per round simulated in full after screening: the largest screened drops
/// (fewer where the others' drops fall below [`SCREEN_KEEP_FRACTION`] of the best).
pub const SCREEN_KEEP: usize = 3;

/// A screened candidate whose drop on the window is below this fraction of the round's largest
/// is not simulated in full. On the 12-bit 640x480 set of docs/BENCHMARKS.md the window's drops
/// were 0.085 to 0.33 of the full ones (mostly a quarter, the top quarter of the rows), so a
/// candidate ten times behind on the window was never ahead in full; the fraction leaves that
/// factor of four of spread a margin of more than two.
pub const SCREEN_KEEP_FRACTION: f64 = 0.1;

/// How many of a round's screened candidates, ranked by their window drops `drops`, are
/// simulated in full: those within [`SCREEN_KEEP_FRACTION`] of the largest drop, at most
/// [`SCREEN_KEEP`] and at least one; all [`SCREEN_KEEP`] when no drop is positive.
fn screen_keep(drops: &[f64]) -> usize {
    let best = drops.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if best <= 0.0 {
        return SCREEN_KEEP;
    }
    drops.iter().filter(|&&d| d >= SCREEN_KEEP_FRACTION * best).count().clamp(1, SCREEN_KEEP)
}

/// Screening: the chi-square of a model on the top `1 / 4` of the sensor's rows, against the
/// measured statistics of the same rows. The window draws what the full simulation draws for
/// its top rows ([`simulate_rows`]), at a quarter of its cost; the search ranks a round's
/// candidates by their screened drop and simulates only the [`SCREEN_KEEP`] best in full, so
/// acceptance is always decided on the full acquisition.
struct Screen {
    rows: usize,
    m: Stats,
    cache: Mutex<Vec<(GapModel, Vec<f64>, f64)>>,
}

impl Screen {
    fn new(measured: &Acquisition, t: &Thresholds) -> Screen {
        let rows = measured.height / 4;
        let crop = measured.top_rows(rows);
        let mut m = stats::compute(&crop, t);
        m.thresholds = Some(*t);
        Screen { rows, m, cache: Default::default() }
    }

    /// Total chi-square of `model` on the window.
    fn chi2(&self, ev: &Evaluator, model: &GapModel) -> f64 {
        if let Some((_, _, c)) = lock(&self.cache).iter().find(|(m, g, _)| m == model && *g == ev.layout.gains_db) {
            return *c;
        }
        let started = Instant::now();
        let sim = simulate_rows(model, &ev.layout, ev.seed, None, self.rows, &ev.draws);
        let mut s = stats::compute(&sim, &ev.t);
        expect_dark_tails(&mut s, model, &ev.t);
        s.thresholds = Some(ev.t);
        let c = stats::gap(&self.m, &s).chi2_total;
        lock(&ev.counts).windows.add(started);
        let mut cache = lock(&self.cache);
        cache.insert(0, (model.clone(), ev.layout.gains_db.clone(), c));
        cache.truncate(2);
        c
    }
}

/// An EMVA 1288 acquisition (or a photon-transfer CSV) as a [`Problem`] of the effect search.
pub struct GapProblem {
    ev: Evaluator,
    /// The top-rows window for screening candidates, on large frames.
    screen: Option<Screen>,
    /// Refit K, the read noise and the responsivity (a calibrated start) as effects go in.
    refine: bool,
}

impl std::fmt::Debug for GapProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GapProblem").field("reduced", &self.ev.reduced).field("refine", &self.refine).finish()
    }
}

impl Problem for GapProblem {
    type Model = GapModel;
    type Sim = GapSim;

    fn effects(&self) -> &[&'static dyn Effect<Self>] {
        &EFFECTS
    }

    fn simulate(&self, model: &GapModel) -> GapSim {
        self.ev.eval(model)
    }

    /// Side by side, as the screened candidates ([`GapProblem::screen`]).
    fn simulate_all(&self, models: &[&GapModel]) -> Vec<GapSim> {
        models.par_iter().map(|m| self.ev.eval(m)).collect()
    }

    fn chi2((_, g): &GapSim) -> f64 {
        g.chi2_total
    }

    fn ln_n(&self, (_, g): &GapSim) -> f64 {
        (g.n.max(2) as f64).ln()
    }

    fn max_rounds(&self) -> usize {
        EFFECTS.len()
    }

    /// Every effect the model does not have yet, and on a photon-transfer CSV only those it can
    /// show ([`REDUCED_CANDIDATES`]).
    fn is_candidate(&self, effect: &dyn Effect<Self>, model: &GapModel, _: &[&'static str]) -> bool {
        let name = effect.name();
        !model.named().contains(&name) && (!self.ev.reduced || REDUCED_CANDIDATES.contains(&name))
    }

    fn propose(
        &self,
        effect: &dyn Effect<Self>,
        model: &GapModel,
        current: &GapSim,
    ) -> Option<(GapModel, Option<GapSim>)> {
        let mut proposal = effect.fit(self, model, current)?;
        if self.refine {
            self.ev.refit_read_noise(&mut proposal);
        }
        Some((proposal, None))
    }

    /// Ranks a round's proposals by their drop on the top rows when there are more than
    /// [`SCREEN_KEEP`] of them, and keeps the best within [`SCREEN_KEEP_FRACTION`] of the largest. The proposals are
    /// simulated side by side: each simulation runs its rows in parallel, but its statistics
    /// and set-up leave cores idle.
    fn screen(&self, model: &GapModel, proposals: &[GapModel]) -> Option<(Vec<f64>, usize)> {
        let sc = self.screen.as_ref().filter(|_| proposals.len() > SCREEN_KEEP)?;
        let base = sc.chi2(&self.ev, model);
        let drops: Vec<f64> = proposals.par_iter().map(|p| base - sc.chi2(&self.ev, p)).collect();
        let keep = screen_keep(&drops);
        Some((drops, keep))
    }

    /// Refits the responsivity and the linear model (with `refine`), the group gains and every
    /// effect in the model against the new residuals, each kept only if it lowers the
    /// chi-square, until a pass gains less than 1 or a ten-thousandth of the chi-square (closed
    /// forms are only approximate where frames clip at 0 DN or at the ADC limit).
    fn polish(&mut self, _: &[&'static str], model: GapModel, sim: GapSim) -> (GapModel, GapSim) {
        let simulations_before = lock(&self.ev.counts).full.n;
        let polished =
            if self.screen.is_some() { self.polish_screened(model, sim) } else { self.polish_full(model, sim) };
        log::debug!("polish: {} full simulations", lock(&self.ev.counts).full.n - simulations_before);
        polished
    }
}

impl GapProblem {
    /// [`Problem::polish`] with every refit simulated in full (frames below
    /// [`SCREEN_MIN_ROWS`]).
    fn polish_full(&mut self, mut model: GapModel, (mut s, mut g): GapSim) -> (GapModel, GapSim) {
        for _ in 0..5 {
            let before = g.chi2_total;
            if self.refine {
                let mut p = model.clone();
                self.ev.refit_responsivity(&mut p, &s);
                let (ps, pg) = self.ev.eval(&p);
                if pg.chi2_total < g.chi2_total {
                    (model, s, g) = (p, ps, pg);
                }
                let mut p = model.clone();
                self.ev.refit_base(&mut p, &s);
                let (ps, pg) = self.ev.eval(&p);
                if pg.chi2_total < g.chi2_total {
                    (model, s, g) = (p, ps, pg);
                }
            }
            if self.ev.refit_group_gains(&s) {
                (s, g) = self.ev.eval(&model);
            }
            for name in model.named() {
                let Some(effect) = effect(name) else { continue };
                let current = (s.clone(), g.clone());
                let Some((p, _)) = self.propose(effect, &model, &current) else { continue };
                let (ps, pg) = self.ev.eval(&p);
                if pg.chi2_total < g.chi2_total {
                    (model, s, g) = (p, ps, pg);
                }
            }
            if before - g.chi2_total < polish_enough(before) {
                break;
            }
        }
        (model, (s, g))
    }

    /// [`Problem::polish`] on large frames: within a pass every refit is judged on the
    /// screening window (a quarter of the cost of a full simulation) from the statistics of the
    /// pass's start, and only the pass's result is simulated in full; it is kept when the full
    /// chi-square drops, else the pass is undone and polishing stops. Most of a search's
    /// simulations were these refits, one full simulation each.
    fn polish_screened(&mut self, mut model: GapModel, (mut s, mut g): GapSim) -> (GapModel, GapSim) {
        for _ in 0..5 {
            let before = g.chi2_total;
            if self.ev.refit_group_gains(&s) {
                (s, g) = self.ev.eval(&model);
            }
            let start = model.clone();
            let Some(sc) = self.screen.as_ref() else { break };
            let window_start = sc.chi2(&self.ev, &model);
            let mut best = window_start;
            let mut consider = |p: GapModel, model: &mut GapModel| {
                let c = sc.chi2(&self.ev, &p);
                if c < best {
                    *model = p;
                    best = c;
                }
            };
            if self.refine {
                let mut p = model.clone();
                self.ev.refit_responsivity(&mut p, &s);
                consider(p, &mut model);
                let mut p = model.clone();
                self.ev.refit_gain(&mut p, &s);
                self.ev.refit_read_noise(&mut p);
                self.ev.refit_responsivity(&mut p, &s);
                consider(p, &mut model);
            }
            for name in model.named() {
                let Some(effect) = effect(name) else { continue };
                let current = (s.clone(), g.clone());
                let Some((p, _)) = self.propose(effect, &model, &current) else { continue };
                consider(p, &mut model);
            }
            // A pass whose refits gain less on the window than its share of the stopping
            // threshold would not pass it in full either: it ends polishing unsimulated.
            let share = sc.rows as f64 / self.ev.layout.height.max(1) as f64;
            if model == start || window_start - best < share * polish_enough(g.chi2_total) {
                model = start;
                break;
            }
            let (ps, pg) = self.ev.eval(&model);
            if pg.chi2_total >= g.chi2_total {
                model = start;
                break;
            }
            (s, g) = (ps, pg);
            if before - g.chi2_total < polish_enough(before) {
                break;
            }
        }
        (model, (s, g))
    }
}

/// The greedy search (see the module doc and [`crate::search`]) against the measured statistics
/// `m` of an acquisition with the layout `layout` (`reduced`: `m` holds only
/// [`stats::REDUCED_FAMILIES`]). `refine`: refit K and the read noise of the start model (the
/// calibrated start; a given model is taken as it is). The gains of groups other than the
/// reference are refitted either way.
#[must_use]
pub fn search(
    layout: &Acquisition,
    m: Stats,
    reduced: bool,
    start: GapModel,
    refine: bool,
    options: &GapOptions,
) -> GapResult {
    let t = m.thresholds.unwrap_or(Thresholds { dark_dn: f64::INFINITY, bright_dn: f64::INFINITY });
    let dark_pair = layout
        .blocks
        .iter()
        .position(|b| b.group == 0 && b.frames.len() == 2 && b.light == Light::Dark)
        .unwrap_or_default();
    let screen = (options.screen
        && !reduced
        && layout.height >= SCREEN_MIN_ROWS
        && layout.blocks.iter().all(|b| b.frames.iter().all(|f| f.len() == layout.width * layout.height)))
    .then(|| Screen::new(layout, &t));
    let draws = super::block_draws(layout, options.draws);
    let mut layout = layout.clone();
    layout.blocks.iter_mut().for_each(|b| *b = Block::layout(b.light, b.exposure_s, b.group, b.frames.len()));
    let mut ev = Evaluator {
        layout,
        reduced,
        t,
        m,
        seed: options.seed,
        draws,
        dark_pair,
        cache: Default::default(),
        counts: Default::default(),
    };
    let mut model = start;
    if refine {
        let (s, _) = ev.eval(&model);
        ev.refit_base(&mut model, &s);
    }
    for _ in 0..3 {
        let (s, _) = ev.eval(&model);
        if !ev.refit_group_gains(&s) {
            break;
        }
    }
    let initial = model.clone();
    let mut problem = GapProblem { ev, screen, refine };
    let outcome = search::greedy(&mut problem, model);
    let (initial_stats, gap_initial) = outcome.start_sim;
    let mut steps: Vec<Step> = outcome.accepted.iter().map(step).collect();
    let trials = outcome
        .trials
        .iter()
        .map(|t| Trial {
            round: t.round,
            effect: t.effect.to_string(),
            chi2_drop: t.chi2_drop,
            penalty: t.penalty,
            gap_after: t.sim.as_ref().map_or(f64::NAN, |(_, g)| g.gap),
            screened: t.sim.is_none(),
        })
        .collect();
    let (final_stats, gap_final) = outcome.sim;
    let ev = problem.ev;
    let gains_db = ev.layout.gains_db.clone();
    let counts = *lock(&ev.counts);
    log::info!(
        "gap search: {} full simulations ({:.1} s; {} answered from the cache), {} screening windows ({:.1} s), \
         {} dark-pair variances for the read-noise refits ({:.1} s), then {} replicates",
        counts.full.n,
        counts.full.seconds,
        counts.cached,
        counts.windows.n,
        counts.windows.seconds,
        counts.dark_pairs.n,
        counts.dark_pairs.seconds,
        options.replicates
    );
    let (simulations, cached_evaluations) = (counts.full.n, counts.cached);
    let misfit = (options.replicates > 0).then(|| {
        // Side by side, as the screened candidates (`GapProblem::screen`).
        let started = Instant::now();
        let replicates: Vec<Stats> =
            (0..options.replicates).into_par_iter().map(|i| ev.replicate(&outcome.model, i)).collect();
        log::info!("gap replicates: {:.1} s", started.elapsed().as_secs_f64());
        misfit::check(&ev.m, &final_stats, &gap_final, &replicates)
    });
    if let Some(m) = &misfit {
        for (st, a) in steps.iter_mut().zip(&outcome.accepted) {
            st.entangled = entangled(a, m);
        }
    }
    GapResult {
        initial,
        final_model: outcome.model,
        measured: ev.m,
        initial_stats,
        final_stats,
        gap_initial,
        gap_final,
        steps,
        trials,
        gains_db,
        simulations,
        cached_evaluations,
        misfit,
    }
}

/// [`misfit::Evidence::entangled`] for an effect the search accepted.
fn entangled(a: &search::Accepted<GapModel, GapSim>, m: &misfit::MisfitCheck) -> Vec<&'static str> {
    let before = misfit::Comparison::from(&a.before.1);
    misfit::Evidence { before, accepted: misfit::Comparison::from(&a.accepted.1), penalty: a.penalty }.entangled(m)
}

/// The report's record of an accepted effect: its parameters after polishing, the gap before
/// and after, and the evidence (the drop against the penalty, the families that improved).
fn step(a: &search::Accepted<GapModel, GapSim>) -> Step {
    let (g, tg) = (&a.before.1, &a.accepted.1);
    let improved: Vec<String> = g
        .families
        .iter()
        .zip(&tg.families)
        .filter(|(a, b)| b.chi2 < a.chi2 - 1.0)
        .map(|(a, b)| format!("{} {:.1} -> {:.1}", a.family, a.chi2_per_dof, b.chi2_per_dof))
        .collect();
    let effect = effect(a.effect).expect("an accepted effect is one of EFFECTS");
    let penalty = a.penalty;
    Step {
        effect: a.effect.to_string(),
        params: effect.params(&a.model),
        gap_before: g.gap,
        gap_after: a.after.1.gap,
        evidence: format!(
            "chi-square drop {:.1} > BIC penalty {penalty:.1} ({} parameter(s), ln {} statistics); {}",
            a.chi2_drop,
            a.param_count,
            a.after.1.n,
            if improved.is_empty() { "no family improved by more than 1".to_string() } else { improved.join(", ") }
        ),
        entangled: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn screening_keeps_the_candidates_near_the_best() {
        // Within a tenth of the best: two of four.
        assert_eq!(screen_keep(&[1000.0, 150.0, 99.0, -5.0]), 2);
        // Far ahead: the best alone.
        assert_eq!(screen_keep(&[24245.0, 259.0, 1504.0, 0.0]), 1);
        // Close together: no more than SCREEN_KEEP.
        assert_eq!(screen_keep(&[10.0, 9.0, 8.0, 7.0, 6.0]), SCREEN_KEEP);
        // Nothing gains on the window: the window decides nothing.
        assert_eq!(screen_keep(&[-3.0, -1.0, 0.0, -8.0]), SCREEN_KEEP);
    }
}
