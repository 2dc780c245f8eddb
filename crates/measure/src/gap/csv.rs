//! The gap workflow on a photon-transfer CSV ([`crate::calibration::ptc`]): already-reduced
//! statistics, no images.
//!
//! A CSV supports the statistics of [`stats::REDUCED_FAMILIES`]: photon transfer (mean against
//! temporal variance), linearity (mean against photons) and the dark mean and variance against
//! exposure, per gain. So the workflow can name [`fit::REDUCED_CANDIDATES`] (black level, dark
//! current, saturation, nonlinearity, and `read_noise_split` when there are two gains or more),
//! never a spatial effect.
//!
//! Layout of the simulation: one frame pair per bright row and per dark point (a zero-light row,
//! or the row's `dark_mean_dn` / `dark_var_dn2`, one per exposure and gain), each at its row's
//! gain, on a frame of `pixels` pixels (the CSV column; [`DEFAULT_PIXELS`] when absent), 256
//! pixels wide. The ADC depth is the smallest of 8, 10, 12, 14 and 16 bit that holds every mean.
//! Sampling variances of the measured entries: `(var_t / 2 + var_s) / N` for a mean (`var_s`
//! when given) and `2 var_t^2 / N` for a temporal variance.

use std::path::Path;

use super::stats::{self, DarkStats, Entry, Stats, StepStats};
use super::{Acquisition, Block, GapError, GapModel, GapOptions, GapResult, Light, Optics, fit};
use crate::calibration::{self, ptc};
use scene_gen_camera::sensor::noise::{self, Effects};

/// Pixels assumed behind each row when the CSV has no `pixels` column (a 256 x 256 region).
pub const DEFAULT_PIXELS: usize = 65536;

/// Width of the simulated frame.
const SIM_WIDTH: usize = 256;

/// One point of the CSV as the workflow uses it.
#[derive(Debug, Clone, Copy)]
struct Point {
    light: Light,
    exposure_s: f64,
    group: usize,
    mean_dn: f64,
    var_dn2: f64,
    spatial_var_dn2: f64,
}

/// The layout and measured statistics of a CSV.
pub fn measured(path: &Path) -> Result<(Acquisition, Stats), GapError> {
    let rows = ptc::read_ptc(path)?;
    let syntax = |line: usize, message: String| ptc::PtcError::Syntax { path: path.to_path_buf(), line, message };
    if let Some(r) = rows.iter().find(|r| r.photons.is_none()) {
        return Err(syntax(
            r.line,
            "no 'photons' value: the gap workflow simulates photons per pixel (lux alone cannot be)".into(),
        )
        .into());
    }
    let pixels = rows.iter().find_map(|r| r.pixels).map_or(DEFAULT_PIXELS, |p| p as usize);
    if let Some(r) = rows.iter().find(|r| r.pixels.is_some_and(|p| p as usize != pixels)) {
        return Err(syntax(r.line, format!("column 'pixels': expected {pixels} as on the first row")).into());
    }
    let mut gains: Vec<f64> = rows.iter().map(|r| r.gain_db).collect();
    gains.sort_by(f64::total_cmp);
    gains.dedup();
    let group_of = |g: f64| gains.iter().position(|x| *x == g).unwrap_or(0);
    let mut points: Vec<Point> = Vec::new();
    for (group, &gain) in gains.iter().enumerate() {
        let mut darks: Vec<Point> = Vec::new();
        let mut add_dark = |exposure_s: f64, mean_dn: f64, var_dn2: f64| {
            if !darks.iter().any(|d| (d.exposure_s - exposure_s).abs() <= 1e-12) {
                darks.push(Point { light: Light::Dark, exposure_s, group, mean_dn, var_dn2, spatial_var_dn2: 0.0 });
            }
        };
        for r in rows.iter().filter(|r| group_of(r.gain_db) == group) {
            if r.light() == 0.0 {
                add_dark(r.exposure_s, r.mean_dn, r.temporal_var_dn2);
            } else if let (Some(m), Some(v)) = (r.dark_mean_dn, r.dark_var_dn2) {
                add_dark(r.exposure_s, m, v);
            }
        }
        if darks.is_empty() {
            let line = rows.iter().find(|r| r.gain_db == gain).map_or(1, |r| r.line);
            return Err(syntax(
                line,
                format!("no dark point at gain {gain} dB: expected a zero-light row or dark_mean_dn/dark_var_dn2"),
            )
            .into());
        }
        points.extend(darks);
        for r in rows.iter().filter(|r| group_of(r.gain_db) == group && r.light() > 0.0) {
            points.push(Point {
                light: Light::Bright(r.photons.unwrap_or(0.0)),
                exposure_s: r.exposure_s,
                group,
                mean_dn: r.mean_dn,
                var_dn2: r.temporal_var_dn2,
                spatial_var_dn2: r.spatial_var_dn2.unwrap_or(0.0),
            });
        }
    }
    let bright = points.iter().filter(|p| p.group == 0 && matches!(p.light, Light::Bright(_))).count();
    if bright < 3 {
        return Err(GapError::Unusable {
            path: path.to_path_buf(),
            message: format!("{bright} bright rows at the lowest gain; the photon transfer needs at least 3"),
        });
    }
    let top = points.iter().map(|p| p.mean_dn).fold(0.0, f64::max);
    let bits = [8u32, 10, 12, 14, 16].into_iter().find(|b| f64::from((1u32 << b) - 1) >= top).unwrap_or(16);
    let width = SIM_WIDTH.min(pixels);
    let height = (pixels / width).max(1);
    let blocks = points.iter().map(|p| Block::layout(p.light, p.exposure_s, p.group, 2)).collect();
    let layout = Acquisition { width, height, bits, blocks, gains_db: gains.clone() };
    Ok((layout, measured_stats(&points, width * height, &gains)))
}

/// The measured statistics in [`stats::compute`]'s entry order (dark pairs as they come, then
/// every step), restricted to [`stats::REDUCED_FAMILIES`].
fn measured_stats(points: &[Point], n: usize, gains: &[f64]) -> Stats {
    let nf = n as f64;
    let label_gain = |g: usize| if gains.len() > 1 { format!(" at {:.2} dB", gains[g]) } else { String::new() };
    let mut entries = Vec::new();
    let mut steps = Vec::new();
    let mut darks = Vec::new();
    let entry = |family: &'static str, label: String, x: f64, value: f64, var: f64| Entry {
        family,
        label,
        x,
        value,
        var,
        count_floor: None,
    };
    for p in points.iter().filter(|p| p.light == Light::Dark) {
        darks.push(DarkStats {
            group: p.group,
            exposure_s: p.exposure_s,
            mean_dn: p.mean_dn,
            var_dn2: p.var_dn2,
            diff_row_var_dn2: 0.0,
        });
        let g = label_gain(p.group);
        entries.push(entry(
            "dark",
            format!("dark mean {:.4} s{g}", p.exposure_s),
            p.exposure_s,
            p.mean_dn,
            p.var_dn2 / (2.0 * nf),
        ));
        let var = 2.0 * p.var_dn2 * p.var_dn2 / nf;
        entries.push(entry("dark", format!("dark variance {:.4} s{g}", p.exposure_s), p.exposure_s, p.var_dn2, var));
    }
    for p in points {
        let Light::Bright(photons) = p.light else { continue };
        steps.push(StepStats {
            group: p.group,
            photons,
            exposure_s: p.exposure_s,
            mean_dn: p.mean_dn,
            var_dn2: p.var_dn2,
        });
    }
    for (i, p) in points.iter().filter(|p| p.light != Light::Dark).enumerate() {
        let x = match p.light {
            Light::Bright(x) => x,
            Light::Dark => 0.0,
        };
        let mean_var = (p.var_dn2 / 2.0 + p.spatial_var_dn2) / nf;
        entries.push(entry("linearity", format!("step {i} mean"), x, p.mean_dn, mean_var));
        let var = 2.0 * p.var_dn2 * p.var_dn2 / nf;
        entries.push(entry("photon_transfer", format!("step {i} variance"), x, p.var_dn2, var));
    }
    Stats {
        width: SIM_WIDTH.min(n),
        height: (n / SIM_WIDTH.min(n)).max(1),
        steps,
        darks,
        dark_stack: None,
        bright_stack: None,
        falloff: None,
        peaks: Vec::new(),
        entries,
        thresholds: None,
        gains_db: gains.to_vec(),
    }
}

/// The start model of a CSV: the linear model calibrated at the lowest gain (K referred to
/// 0 dB), every effect off but quantization.
fn start_model(path: &Path, bits: u32, gain0_db: f64, seed: u64) -> Result<GapModel, GapError> {
    let cals = calibration::calibrate_ptc(path)?;
    let cal = cals.first().ok_or_else(|| GapError::Unusable { path: path.to_path_buf(), message: "no gain".into() })?;
    let mut sensor = cal.to_sensor_model("measured", seed);
    sensor.system_gain_dn_per_e /= noise::gain_factor(gain0_db);
    sensor.adc_bits = bits;
    sensor.effects =
        Effects { quantization: noise::Quantization { enabled: true, dither_dn: 0.0 }, ..Effects::default() };
    sensor.validate()?;
    Ok(GapModel { sensor, optics: Optics::default() })
}

/// Runs the workflow on a photon-transfer CSV.
pub fn run(path: &Path, model: Option<GapModel>, options: &GapOptions) -> Result<GapResult, GapError> {
    let (layout, m) = measured(path)?;
    let refine = model.is_none();
    let start = match model {
        Some(mut m) => {
            m.sensor.adc_bits = layout.bits;
            m
        }
        None => start_model(path, layout.bits, layout.gains_db[0], options.seed)?,
    };
    Ok(fit::search(&layout, m, true, start, refine, options))
}

/// Writes the photon-transfer CSV of a simulated acquisition (one row per bright pair and per
/// dark pair, with `pixels`), for tests and examples: `acq` as simulated by
/// [`super::simulate_acquisition`].
#[must_use]
pub fn to_csv(acq: &Acquisition) -> String {
    let t = stats::Thresholds { dark_dn: f64::INFINITY, bright_dn: f64::INFINITY };
    let s = stats::compute(acq, &t);
    let n = acq.width * acq.height;
    let mut out = String::from("exposure_s,gain_db,photons,mean_dn,temporal_var_dn2,pixels\n");
    let gain = |g: usize| acq.gains_db.get(g).copied().unwrap_or(0.0);
    for d in &s.darks {
        out.push_str(&format!("{},{},0,{},{},{n}\n", d.exposure_s, gain(d.group), d.mean_dn, d.var_dn2));
    }
    for p in &s.steps {
        out.push_str(&format!("{},{},{},{},{},{n}\n", p.exposure_s, gain(p.group), p.photons, p.mean_dn, p.var_dn2));
    }
    out
}
