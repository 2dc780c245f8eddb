//! Camera calibration by the EMVA 1288 linear model (release 4 formulas), from an EMVA 1288
//! descriptor with its images ([`emva`]) or from a photon-transfer CSV ([`ptc`]).
//!
//! Per illumination step the two frames A, B give the mean `mu_y = (mean A + mean B) / 2` and
//! the temporal variance `sigma_y^2 = mean((A - B)^2) / 2 - (mean A - mean B)^2 / 2`, dark
//! subtracted with the dark pair at the same exposure. From those:
//!
//! * system gain K: slope of `sigma_y^2 - sigma_y.dark^2` against `mu_y - mu_y.dark`, fitted
//!   through the origin (least squares) over the points up to 70 % of saturation;
//! * temporal dark noise `sigma_d = sqrt(sigma_y.dark^2 - 1/12) / K` electrons (the 1/12 DN^2
//!   is the quantization noise), `sigma_y.dark^2` the dark variance at zero exposure (the
//!   intercept of its fit against exposure when the darks span three or more exposures, else
//!   at the shortest), at least 0.24 DN^2 (below it the noise is quantization-limited and
//!   0.49 DN is an upper limit), as the EMVA 1288 reference implementation computes it;
//! * responsivity R: slope of `mu_y - mu_y.dark` against photons over the same range (through
//!   the origin), and
//!   quantum efficiency `R / K`;
//! * saturation: the step where the temporal variance peaks;
//! * linearity error: `(max delta - min delta) / 2` of the relative deviations `delta` from the
//!   linear fit of signal against photons over 5..95 % of saturation;
//! * dark current: slope of the dark mean against exposure when the darks span several
//!   exposures, else not measurable;
//! * DSNU and PRNU from the averaged stacks: spatial variance of the L-frame mean minus the
//!   residual temporal variance `sigma^2 / L`; also after a 5x5 box high-pass;
//! * the reference paper's affine coefficients at the measured gain, `sigma_p^2 = K` and
//!   `sigma_t^2 = K^2 sigma_d^2 + 1/12` (docs/REFERENCE.md, "Camera and noise").

pub mod emva;
pub mod ptc;

use std::path::{Path, PathBuf};

use serde::Serialize;

use emva::{BlockKind, EmvaError};
use ptc::PtcError;

/// Upper end of the range fitted for K and R, as a fraction of saturation (EMVA 1288 r4).
const FIT_MAX_FRACTION: f64 = 0.7;
/// Range of the linearity fit, fractions of saturation (EMVA 1288 r3/r4).
const LINEARITY_RANGE: (f64, f64) = (0.05, 0.95);
/// Quantization noise variance of an ideal ADC, DN^2.
const QUANTIZATION_VAR_DN2: f64 = 1.0 / 12.0;
/// Below this dark variance the temporal dark noise is quantization-limited and cannot be
/// measured; EMVA 1288 (and its reference implementation) then report the noise at this
/// floor, an upper limit (0.24 DN^2: 0.49 DN).
const QUANTIZATION_LIMITED_DARK_VAR_DN2: f64 = 0.24;
/// Variance gain of white noise through `y - box5(y)`: (24/25)^2 + 24 / 25^2.
const HIGHPASS_WHITE_GAIN: f64 = 0.96;

/// Calibration failed.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationError {
    #[error(transparent)]
    Emva(#[from] EmvaError),
    #[error(transparent)]
    Ptc(#[from] PtcError),
    #[error("{}: {message}", path.display())]
    Insufficient { path: PathBuf, message: String },
}

/// One photon-transfer point: a bright measurement and its dark reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PtcPoint {
    pub exposure_s: f64,
    /// Photons per pixel (or lux when `photons_known` is false).
    pub light: f64,
    pub mean_dn: f64,
    pub temporal_var_dn2: f64,
    pub dark_mean_dn: f64,
    pub dark_var_dn2: f64,
}

/// Averaged stacks for the spatial (non-uniformity) part.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialStacks {
    pub width: usize,
    pub height: usize,
    /// Mean image of the dark stack and its frame count and mean per-pixel temporal variance.
    pub dark_mean: Vec<f64>,
    pub dark_frames: usize,
    pub dark_temporal_var_dn2: f64,
    /// Same for the bright stack, when there is one.
    pub bright: Option<(Vec<f64>, usize, f64)>,
    pub bright_light: Option<f64>,
}

/// Dark current result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DarkCurrent {
    pub measurable: bool,
    pub dn_per_s: Option<f64>,
    pub e_per_s: Option<f64>,
    pub note: String,
}

/// Non-uniformity results.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Spatial {
    pub dark_frames: usize,
    pub bright_frames: Option<usize>,
    pub bright_photons: Option<f64>,
    /// DSNU, DN and electrons: all spatial variance of the dark stack (temporal part removed).
    pub dsnu_dn: f64,
    pub dsnu_e: f64,
    /// DSNU after the 5x5 box high-pass (white-noise corrected).
    pub dsnu_highpass_dn: f64,
    /// PRNU, per cent of the dark-subtracted mean, all spatial variance.
    pub prnu_percent: Option<f64>,
    /// PRNU after the 5x5 box high-pass.
    pub prnu_highpass_percent: Option<f64>,
}

/// Affine coefficients of the reference paper at the measured operating point, in the
/// measured camera's DN.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AffineCoefficients {
    pub sigma_p2: f64,
    pub sigma_t2_dn2: f64,
}

/// The result of a calibration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Calibration {
    pub source: String,
    pub adc_bits: Option<u32>,
    pub gain_db: Option<f64>,
    pub points: usize,
    pub k_fit_points: usize,
    /// System gain K, DN/e-: linearized when photon counts allow, else the standard fit.
    pub system_gain_k_dn_per_e: f64,
    /// "linearized" or "emva1288-r4" (see [`linearize`]).
    pub k_method: String,
    /// K by the plain EMVA 1288 r4 fit (biased by a nonlinear response).
    pub system_gain_k_standard_dn_per_e: f64,
    /// R / K with both from the plain EMVA 1288 r4 fits.
    pub quantum_efficiency_standard: Option<f64>,
    pub dark_mean_dn: f64,
    pub dark_noise_dn: f64,
    pub dark_noise_e: f64,
    pub responsivity_dn_per_photon: Option<f64>,
    pub quantum_efficiency: Option<f64>,
    pub saturation_mean_dn: f64,
    pub saturation_capacity_e: f64,
    /// True when the variance peaks before the last step (else the last step is used).
    pub saturation_reached: bool,
    pub dynamic_range_db: f64,
    pub linearity_error_percent: Option<f64>,
    pub dark_current: DarkCurrent,
    pub spatial: Option<Spatial>,
    pub affine: AffineCoefficients,
}

impl Calibration {
    /// A [`SensorModel`](scene_gen_camera::sensor::SensorModel) with the measured parameters, as the gap
    /// workflow's starting point: K, QE (1 when unknown), dark noise as read noise, dark level as
    /// black level, the saturation capacity as full well, DSNU (in electrons) and PRNU when
    /// measured, dark current when measurable. Effects not measured stay off.
    #[must_use]
    pub fn to_sensor_model(&self, name: &str, pattern_seed: u64) -> scene_gen_camera::sensor::SensorModel {
        use scene_gen_camera::sensor::noise::{self, Effects};
        let spatial = self.spatial.as_ref();
        let effects = Effects {
            black_level: noise::BlackLevel { enabled: true, offset_dn: self.dark_mean_dn },
            dark_current: noise::DarkCurrent {
                enabled: self.dark_current.measurable,
                rate_e_per_s: self.dark_current.e_per_s.unwrap_or(0.0).max(0.0),
            },
            quantization: noise::Quantization { enabled: true, dither_dn: 0.0 },
            saturation: noise::Saturation { enabled: true, full_well_e: self.saturation_capacity_e },
            dsnu: noise::Dsnu { enabled: spatial.is_some(), std_e: spatial.map_or(0.0, |s| s.dsnu_e) },
            prnu: noise::Prnu {
                enabled: spatial.and_then(|s| s.prnu_percent).is_some(),
                std_fraction: spatial.and_then(|s| s.prnu_percent).unwrap_or(0.0) / 100.0,
            },
            ..Effects::default()
        };
        scene_gen_camera::sensor::SensorModel {
            name: name.to_string(),
            quantum_efficiency: self.quantum_efficiency.unwrap_or(1.0).clamp(0.0, 1.0),
            system_gain_dn_per_e: self.system_gain_k_dn_per_e,
            read_noise_e: self.dark_noise_e,
            adc_bits: self.adc_bits.unwrap_or(16),
            pattern_seed,
            effects,
        }
    }
}

/// Calibrates from a file: `.csv` is a photon-transfer CSV (one result per gain), anything else
/// an EMVA 1288 descriptor.
pub fn calibrate_path(path: &Path) -> Result<Vec<Calibration>, CalibrationError> {
    let is_csv = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    if is_csv { calibrate_ptc(path) } else { Ok(vec![calibrate_emva(path)?]) }
}

fn pair_stats(a: &[f32], b: &[f32]) -> (f64, f64) {
    let n = a.len() as f64;
    let (mut sa, mut sb, mut sd2) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        let (x, y) = (f64::from(x), f64::from(y));
        sa += x;
        sb += y;
        sd2 += (x - y) * (x - y);
    }
    let (ma, mb) = (sa / n, sb / n);
    (0.5 * (ma + mb), 0.5 * sd2 / n - 0.5 * (ma - mb) * (ma - mb))
}

/// Mean image and mean per-pixel (unbiased) temporal variance of a stack.
fn stack_stats(
    frames: impl Iterator<Item = Result<Vec<f32>, EmvaError>>,
    n: usize,
) -> Result<(Vec<f64>, usize, f64), EmvaError> {
    let mut sum = vec![0f64; n];
    let mut sum2 = vec![0f64; n];
    let mut count = 0usize;
    for frame in frames {
        let frame = frame?;
        for ((s, s2), &v) in sum.iter_mut().zip(sum2.iter_mut()).zip(&frame) {
            let v = f64::from(v);
            *s += v;
            *s2 += v * v;
        }
        count += 1;
    }
    let l = count as f64;
    let mut var_sum = 0.0;
    for (s, s2) in sum.iter_mut().zip(&sum2) {
        let mean = *s / l;
        var_sum += (s2 - l * mean * mean) / (l - 1.0);
        *s = mean;
    }
    Ok((sum, count, var_sum / n as f64))
}

/// Calibrates from an EMVA 1288 descriptor and its images.
pub fn calibrate_emva(path: &Path) -> Result<Calibration, CalibrationError> {
    let d = emva::read_descriptor(path)?;
    let (w, h, bits) = (d.width, d.height, d.bits);
    let n = (w * h) as usize;
    let load = |p: &PathBuf| emva::load_image(p, w, h, bits);
    let mut bright_pairs = Vec::new(); // (exposure_s, photons, mean, var)
    let mut dark_pairs = Vec::new(); // (exposure_s, mean, var)
    let mut dark_stack = None;
    let mut bright_stack = None;
    for block in &d.blocks {
        let t = block.exposure_s();
        if block.images.len() == 2 {
            let (m, v) = pair_stats(&load(&block.images[0])?, &load(&block.images[1])?);
            match block.kind {
                BlockKind::Bright { photons } => bright_pairs.push((t, photons, m, v)),
                BlockKind::Dark => dark_pairs.push((t, m, v)),
            }
        } else {
            let stats = stack_stats(block.images.iter().map(load), n)?;
            match block.kind {
                BlockKind::Bright { photons } if bright_stack.is_none() => bright_stack = Some((stats, photons)),
                BlockKind::Dark if dark_stack.is_none() => dark_stack = Some(stats),
                _ => {}
            }
        }
    }
    let insufficient = |message: String| CalibrationError::Insufficient { path: path.to_path_buf(), message };
    if dark_pairs.is_empty() {
        return Err(insufficient("no dark pair ('d' block with 2 images); expected one per exposure time".into()));
    }
    let points: Vec<PtcPoint> = bright_pairs
        .iter()
        .map(|&(t, photons, m, v)| {
            let &(_, dm, dv) = dark_pairs
                .iter()
                .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
                .expect("dark pairs are not empty");
            PtcPoint {
                exposure_s: t,
                light: photons,
                mean_dn: m,
                temporal_var_dn2: v,
                dark_mean_dn: dm,
                dark_var_dn2: dv,
            }
        })
        .collect();
    let spatial = dark_stack.map(|(dark_mean, dark_frames, dark_var)| SpatialStacks {
        width: w as usize,
        height: h as usize,
        dark_mean,
        dark_frames,
        dark_temporal_var_dn2: dark_var,
        bright: bright_stack.as_ref().map(|(s, _)| s.clone()),
        bright_light: bright_stack.as_ref().map(|(_, p)| *p),
    });
    let dark_exposures: Vec<(f64, f64)> = dark_pairs.iter().map(|&(t, m, _)| (t, m)).collect();
    let mut cal = analyse(&points, true, &dark_exposures, spatial.as_ref(), path)?;
    cal.adc_bits = Some(bits);
    Ok(cal)
}

/// Calibrates from a photon-transfer CSV: one result per gain setting.
pub fn calibrate_ptc(path: &Path) -> Result<Vec<Calibration>, CalibrationError> {
    let rows = ptc::read_ptc(path)?;
    let photons_known = rows.iter().all(|r| r.photons.is_some());
    let mut gains: Vec<f64> = rows.iter().map(|r| r.gain_db).collect();
    gains.sort_by(f64::total_cmp);
    gains.dedup();
    let mut out = Vec::new();
    for gain in gains {
        let group: Vec<&ptc::PtcRow> = rows.iter().filter(|r| r.gain_db == gain).collect();
        let darks: Vec<&&ptc::PtcRow> = group.iter().filter(|r| r.light() == 0.0).collect();
        let mut points = Vec::new();
        for r in group.iter().filter(|r| r.light() > 0.0) {
            let (dm, dv) = match (r.dark_mean_dn, r.dark_var_dn2) {
                (Some(m), Some(v)) => (m, v),
                _ => {
                    let d = darks
                        .iter()
                        .min_by(|a, b| (a.exposure_s - r.exposure_s).abs().total_cmp(&(b.exposure_s - r.exposure_s).abs()))
                        .ok_or_else(|| CalibrationError::Insufficient {
                            path: path.to_path_buf(),
                            message: format!(
                                "line {}: no dark reference (no dark_mean_dn/dark_var_dn2 and no zero-light row at gain {gain} dB)",
                                r.line
                            ),
                        })?;
                    (d.mean_dn, d.temporal_var_dn2)
                }
            };
            points.push(PtcPoint {
                exposure_s: r.exposure_s,
                light: r.light(),
                mean_dn: r.mean_dn,
                temporal_var_dn2: r.temporal_var_dn2,
                dark_mean_dn: dm,
                dark_var_dn2: dv,
            });
        }
        let mut dark_exposures: Vec<(f64, f64)> = darks.iter().map(|r| (r.exposure_s, r.mean_dn)).collect();
        dark_exposures.extend(group.iter().filter_map(|r| r.dark_mean_dn.map(|m| (r.exposure_s, m))));
        let mut cal = analyse(&points, photons_known, &dark_exposures, None, path)?;
        cal.gain_db = Some(gain);
        out.push(cal);
    }
    Ok(out)
}

/// The photon-transfer points mapped onto the linear response.
#[derive(Debug, Clone, PartialEq)]
pub struct Linearized {
    /// Slope of the response at zero light, DN per photon.
    pub responsivity: f64,
    /// Signal of the linear response, `responsivity * photons`, DN.
    pub signal: Vec<f64>,
    /// Temporal variance divided by the squared local slope of the response relative to its
    /// slope at zero light, DN^2.
    pub noise: Vec<f64>,
}

/// Undoes a smooth nonlinear response before the gain fit (an extension of EMVA 1288, which
/// fits raw values and so reads a compressive response as a lower K).
///
/// With known photon counts `p`, the dark-subtracted signal is fitted by the polynomial
/// `s(p) = b1 p + b2 p^2 + b3 p^3 + b4 p^4` over the points below 95 % of saturation. A
/// response `s = f(s_lin)` scales temporal noise by `f'^2`, so each variance is divided by
/// `(s'(p) / b1)^2` and each signal replaced by `b1 p`. A linear camera gives `s'(p) = b1` and
/// changes nothing. Returns None when there are too few points or the fit is degenerate.
#[must_use]
pub fn linearize(photons: &[f64], signal: &[f64], noise: &[f64], sat: usize) -> Option<Linearized> {
    let limit = LINEARITY_RANGE.1 * signal[sat];
    let idx: Vec<usize> = (0..=sat).filter(|&i| signal[i] > 0.0 && signal[i] <= limit).collect();
    const DEGREE: usize = 4;
    if idx.len() < 2 * DEGREE {
        return None;
    }
    let scale = idx.iter().map(|&i| photons[i]).fold(0.0, f64::max);
    // The polynomial without constant term, in p / scale.
    let basis: Vec<[f64; DEGREE]> =
        idx.iter().map(|&i| std::array::from_fn(|d| (photons[i] / scale).powi(d as i32 + 1))).collect();
    let rows = basis.iter().zip(&idx).map(|(b, &i)| (&b[..], signal[i], 1.0));
    let coef = crate::least_squares::fit(rows, DEGREE)?.coefficients;
    let b1 = coef[0] / scale;
    if !(b1.is_finite() && b1 > 0.0) {
        return None;
    }
    let slope = |p: f64| -> f64 {
        let x = p / scale;
        (1..=DEGREE).map(|d| d as f64 * coef[d - 1] * x.powi(d as i32 - 1)).sum::<f64>() / scale
    };
    let noise = photons.iter().zip(noise).map(|(&p, &v)| v / (slope(p) / b1).powi(2)).collect();
    Some(Linearized { responsivity: b1, signal: photons.iter().map(|p| b1 * p).collect(), noise })
}

/// The temporal dark variance without dark current, DN^2, as the EMVA 1288 reference
/// implementation estimates it: with darks at three or more exposure times, the intercept at
/// zero exposure of the line fitted to dark variance against exposure; otherwise the dark
/// variance at the shortest exposure.
fn dark_variance_at_zero_exposure(points: &[PtcPoint]) -> f64 {
    let mut exposures: Vec<f64> = points.iter().map(|p| p.exposure_s).collect();
    exposures.sort_by(f64::total_cmp);
    exposures.dedup();
    if exposures.len() >= 3 {
        let xs: Vec<f64> = points.iter().map(|p| p.exposure_s).collect();
        let ys: Vec<f64> = points.iter().map(|p| p.dark_var_dn2).collect();
        return fit_line(&xs, &ys).0;
    }
    let shortest: Vec<f64> = points.iter().filter(|p| p.exposure_s == exposures[0]).map(|p| p.dark_var_dn2).collect();
    shortest.iter().sum::<f64>() / shortest.len() as f64
}

/// Least-squares slope `b` of `y = b x` (the line through the origin): dark-subtracted signal
/// and noise vanish with the light, so EMVA 1288 fits K and R without an offset.
fn fit_through_origin(xs: &[f64], ys: &[f64]) -> f64 {
    let sxy: f64 = xs.iter().zip(ys).map(|(x, y)| x * y).sum();
    let sxx: f64 = xs.iter().map(|x| x * x).sum();
    if sxx > 0.0 { sxy / sxx } else { 0.0 }
}

/// Least-squares line `y = a + b x`: (a, b).
fn fit_line(xs: &[f64], ys: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mx = xs.iter().sum::<f64>() / n;
    let my = ys.iter().sum::<f64>() / n;
    let sxy: f64 = xs.iter().zip(ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (my - b * mx, b)
}

/// The EMVA 1288 analysis of photon-transfer points and optional stacks.
pub fn analyse(
    points: &[PtcPoint],
    photons_known: bool,
    dark_exposures: &[(f64, f64)],
    spatial: Option<&SpatialStacks>,
    path: &Path,
) -> Result<Calibration, CalibrationError> {
    let insufficient = |message: String| CalibrationError::Insufficient { path: path.to_path_buf(), message };
    if points.len() < 3 {
        return Err(insufficient(format!("{} bright points; expected at least 3", points.len())));
    }
    let mut pts = points.to_vec();
    pts.sort_by(|a, b| a.light.total_cmp(&b.light));
    let signal: Vec<f64> = pts.iter().map(|p| p.mean_dn - p.dark_mean_dn).collect();
    let noise: Vec<f64> = pts.iter().map(|p| p.temporal_var_dn2 - p.dark_var_dn2).collect();
    let light: Vec<f64> = pts.iter().map(|p| p.light).collect();
    let sat = (0..pts.len()).max_by(|&a, &b| pts[a].temporal_var_dn2.total_cmp(&pts[b].temporal_var_dn2)).unwrap_or(0);
    let saturation_reached = sat + 1 < pts.len();
    let sat_signal = signal[sat];
    let in_fit: Vec<usize> =
        (0..=sat).filter(|&i| signal[i] > 0.0 && signal[i] <= FIT_MAX_FRACTION * sat_signal).collect();
    if in_fit.len() < 2 {
        return Err(insufficient("fewer than 2 points below 70 % of saturation; cannot fit the system gain".into()));
    }
    let pick = |v: &[f64]| in_fit.iter().map(|&i| v[i]).collect::<Vec<f64>>();
    let k_standard = fit_through_origin(&pick(&signal), &pick(&noise));
    if !(k_standard.is_finite() && k_standard > 0.0) {
        return Err(insufficient(format!("fitted system gain K = {k_standard} is not positive")));
    }
    let r_standard = fit_through_origin(&pick(&light), &pick(&signal));
    let linearized = if photons_known { linearize(&light, &signal, &noise, sat) } else { None };
    let (k, responsivity, k_method) = match &linearized {
        Some(lin) => {
            let k_lin = fit_through_origin(&pick(&lin.signal), &pick(&lin.noise));
            (k_lin, Some(lin.responsivity), "linearized")
        }
        None if photons_known => (k_standard, Some(r_standard), "emva1288-r4"),
        None => (k_standard, None, "emva1288-r4"),
    };
    if !(k.is_finite() && k > 0.0) {
        return Err(insufficient(format!("fitted system gain K = {k} is not positive")));
    }
    // Dark level and noise: the mean of the dark references used.
    let n = pts.len() as f64;
    let dark_mean_dn = pts.iter().map(|p| p.dark_mean_dn).sum::<f64>() / n;
    let dark_var = dark_variance_at_zero_exposure(&pts).max(QUANTIZATION_LIMITED_DARK_VAR_DN2);
    let dark_noise_dn = dark_var.sqrt();
    let dark_noise_e = (dark_var - QUANTIZATION_VAR_DN2).max(0.0).sqrt() / k;
    let qe = responsivity.map(|r| r / k);
    let saturation_capacity_e = match qe {
        Some(q) => q * light[sat],
        None => sat_signal / k,
    };
    let lin: Vec<usize> = (0..=sat)
        .filter(|&i| signal[i] >= LINEARITY_RANGE.0 * sat_signal && signal[i] <= LINEARITY_RANGE.1 * sat_signal)
        .collect();
    let linearity_error_percent = (lin.len() >= 3).then(|| {
        let xs: Vec<f64> = lin.iter().map(|&i| light[i]).collect();
        let ys: Vec<f64> = lin.iter().map(|&i| signal[i]).collect();
        let (a, b) = fit_line(&xs, &ys);
        let deltas: Vec<f64> = xs.iter().zip(&ys).map(|(x, y)| 100.0 * (y - (a + b * x)) / (a + b * x)).collect();
        let max = deltas.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = deltas.iter().copied().fold(f64::INFINITY, f64::min);
        (max - min) / 2.0
    });
    let dark_current = dark_current(dark_exposures, k);
    let spatial = spatial.map(|s| spatial_result(s, k));
    Ok(Calibration {
        source: path.display().to_string(),
        adc_bits: None,
        gain_db: None,
        points: pts.len(),
        k_fit_points: in_fit.len(),
        system_gain_k_dn_per_e: k,
        k_method: k_method.to_string(),
        system_gain_k_standard_dn_per_e: k_standard,
        quantum_efficiency_standard: photons_known.then(|| r_standard / k_standard),
        dark_mean_dn,
        dark_noise_dn,
        dark_noise_e,
        responsivity_dn_per_photon: responsivity,
        quantum_efficiency: qe,
        saturation_mean_dn: pts[sat].mean_dn,
        saturation_capacity_e,
        saturation_reached,
        dynamic_range_db: 20.0 * (saturation_capacity_e / dark_noise_e.max(f64::MIN_POSITIVE)).log10(),
        linearity_error_percent,
        dark_current,
        spatial,
        affine: AffineCoefficients {
            sigma_p2: k,
            sigma_t2_dn2: k * k * dark_noise_e * dark_noise_e + QUANTIZATION_VAR_DN2,
        },
    })
}

fn dark_current(darks: &[(f64, f64)], k: f64) -> DarkCurrent {
    let mut ts: Vec<f64> = darks.iter().map(|d| d.0).collect();
    ts.sort_by(f64::total_cmp);
    ts.dedup_by(|a, b| (*a - *b).abs() <= 1e-12);
    if ts.len() < 2 {
        return DarkCurrent {
            measurable: false,
            dn_per_s: None,
            e_per_s: None,
            note: "not measurable: all dark frames share one exposure time".into(),
        };
    }
    let xs: Vec<f64> = darks.iter().map(|d| d.0).collect();
    let ys: Vec<f64> = darks.iter().map(|d| d.1).collect();
    let (_, slope) = fit_line(&xs, &ys);
    DarkCurrent {
        measurable: true,
        dn_per_s: Some(slope),
        e_per_s: Some(slope / k),
        note: format!("slope of the dark mean over {} exposure times", ts.len()),
    }
}

fn variance(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)
}

/// `y - box5(y)` over the interior (2-pixel border dropped).
fn highpass(img: &[f64], w: usize, h: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(w.saturating_sub(4) * h.saturating_sub(4));
    for r in 2..h.saturating_sub(2) {
        for c in 2..w.saturating_sub(2) {
            let mut s = 0.0;
            for rr in r - 2..=r + 2 {
                s += img[rr * w + c - 2..=rr * w + c + 2].iter().sum::<f64>();
            }
            out.push(img[r * w + c] - s / 25.0);
        }
    }
    out
}

/// Spatial variance of a stack mean with the residual temporal variance removed: (all, high-pass).
fn spatial_var(mean: &[f64], frames: usize, temporal_var: f64, w: usize, h: usize) -> (f64, f64) {
    let residual = temporal_var / frames as f64;
    let all = (variance(mean) - residual).max(0.0);
    let hp = highpass(mean, w, h);
    let hp_var = if hp.len() > 1 { (variance(&hp) / HIGHPASS_WHITE_GAIN - residual).max(0.0) } else { f64::NAN };
    (all, hp_var)
}

fn spatial_result(s: &SpatialStacks, k: f64) -> Spatial {
    let (dark_all, dark_hp) = spatial_var(&s.dark_mean, s.dark_frames, s.dark_temporal_var_dn2, s.width, s.height);
    let dark_level = s.dark_mean.iter().sum::<f64>() / s.dark_mean.len() as f64;
    let (prnu, prnu_hp, frames) = match &s.bright {
        Some((mean, frames, tv)) => {
            let (all, hp) = spatial_var(mean, *frames, *tv, s.width, s.height);
            let signal = mean.iter().sum::<f64>() / mean.len() as f64 - dark_level;
            (
                Some(100.0 * (all - dark_all).max(0.0).sqrt() / signal),
                Some(100.0 * (hp - dark_hp).max(0.0).sqrt() / signal),
                Some(*frames),
            )
        }
        None => (None, None, None),
    };
    Spatial {
        dark_frames: s.dark_frames,
        bright_frames: frames,
        bright_photons: s.bright_light,
        dsnu_dn: dark_all.sqrt(),
        dsnu_e: dark_all.sqrt() / k,
        dsnu_highpass_dn: dark_hp.sqrt(),
        prnu_percent: prnu,
        prnu_highpass_percent: prnu_hp,
    }
}
