//! The sensor noise model: photons per pixel in, digital numbers out.
//!
//! One module shared by the renderer, the calibration and the gap workflow. Two models:
//!
//! * [`SensorModel`]: the physical linear camera model of EMVA 1288 (release 4, section 2),
//!   driven by catalog parameters, with each departure from it an effect that can be switched
//!   on and parameterised under the effect names of docs/CONTRACTS.md. A model is plain serde data, so
//!   it round-trips through a `model.toml`.
//! * [`AffineNoise`]: the reference paper's per-channel affine model on 8-bit values,
//!   `var = g sigma_p^2 I + g^2 sigma_t^2`.
//!
//! # The linear model, per pixel
//!
//! ```text
//! mu_e   = QE (1 + prnu) photons                         (prnu: fixed per pixel)
//! e      = Poisson(mu_e + (dark + hot) t) + dsnu + N(0, sigma_pre^2)
//! e      = min(e, full_well)                             (saturation)
//! y      = K g e  (g = 10^(gain_db/20))
//! y      = y (1 + a (y / y_max)^3)                       (nonlinearity, y_max = 2^bits - 1)
//! y     += N(0, sigma_post_dn^2) + row(t) + column + periodic + black_level
//! DN     = clamp(round(y), 0, 2^bits - 1)                (quantization, saturation)
//! ```
//!
//! The temporal variance of a pixel away from clipping is therefore
//! `K^2 g^2 (mu_e + dark t + sigma_pre^2) + sigma_post_dn^2 + row^2 + 1/12` (EMVA 1288 eq. 9
//! with the split read noise), which [`SensorModel::expected_temporal_variance_dn2`] returns.
//!
//! Optics effects (`illumination_falloff`, `lens_blur`, `motion_blur`) are not handled here:
//! see [`OPTICS_EFFECTS`].
//!
//! Randomness: temporal noise of row `r` comes from `rng::substream(frame_seed, SOURCE, r)`, one
//! stream per source (`"sensor/temporal"` for shot noise, `"sensor/read-pre"`,
//! `"sensor/read-post"`, `"sensor/dither"`, `"sensor/row-offset"`), and fixed patterns from `rng::substream(pattern_seed, "sensor/<map>",
//! r)`, so output bytes depend only on the seeds, never on the thread count.

use rand::Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::catalog::Sensor;
use scene_gen_core::rng;
use scene_gen_core::simd::Dispatch;
use std::borrow::Cow;
use std::sync::{Arc, Mutex, OnceLock};

/// Effects of the effect list (docs/CONTRACTS.md) that belong to the optics, not to this model.
pub const OPTICS_EFFECTS: [&str; 3] = ["illumination_falloff", "lens_blur", "motion_blur"];

/// Effects this model handles, by their names in docs/CONTRACTS.md.
pub const SENSOR_EFFECTS: [&str; 11] = [
    "black_level",
    "dark_current",
    "read_noise_split",
    "quantization",
    "saturation",
    "nonlinearity",
    "dsnu",
    "prnu",
    "hot_pixels",
    "row_column_noise",
    "periodic_pattern",
];

/// Default black level as a fraction of the ADC range: a stated convention (1/64, e.g. 64 DN at
/// 12 bit), not a datasheet figure; real cameras set it by register.
const BLACK_LEVEL_FRACTION: f64 = 1.0 / 64.0;

/// Linear factor of an analog gain in dB (amplitude dB: 20 log10).
#[must_use]
pub fn gain_factor(gain_db: f64) -> f64 {
    10f64.powf(gain_db / 20.0)
}

/// Constant offset added to every pixel, DN.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BlackLevel {
    pub enabled: bool,
    pub offset_dn: f64,
}

/// Thermal dark signal and its shot noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DarkCurrent {
    pub enabled: bool,
    pub rate_e_per_s: f64,
}

/// Read noise partly before the gain stage (scales with gain in DN) and partly after it
/// (fixed in DN). Off: all of `read_noise_e` is before the gain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReadNoiseSplit {
    pub enabled: bool,
    /// Fraction of the read-noise variance at 0 dB that arises after the gain stage (0..1).
    pub post_gain_fraction: f64,
}

/// Rounding to integer DN (its variance is 1/12 DN^2). Off: [`SensorModel::simulate_dn_with`]
/// returns continuous values; [`SensorModel::simulate`] must round to fill `u16` anyway.
///
/// `dither_dn`: the width of a uniform noise added before the rounding (0: none). An ADC whose
/// input carries noise of its own below one DN rounds as if dithered; the EMVA 1288 reference
/// implementation's camera simulator adds exactly such a noise, one DN wide, before rounding.
/// Dithered, the rounding's error no longer depends on where the signal falls between two
/// levels: where the temporal noise is below about half a DN, plain rounding makes the mean
/// and variance of a dark frame waver with the signal's fraction of a DN, and dithered
/// rounding keeps both smooth (variance `1/12 + dither^2 / 12` on top of the signal's).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Quantization {
    pub enabled: bool,
    pub dither_dn: f64,
}

/// Full-well clipping in electrons and clipping to the ADC range `0..2^bits-1`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Saturation {
    pub enabled: bool,
    pub full_well_e: f64,
}

/// Nonlinearity of the signal above black level, a polynomial in the signal's share of full
/// scale `r = y / y_max`: `y' = y (1 + a1 r + a2 r^2 + a3 r^3)`. Each coefficient is a relative
/// deviation at full scale (negative compresses, positive expands); the order is the highest
/// nonzero term ([`Nonlinearity::order`]). A pure cubic (`a3` alone, read also as `a`) is
/// the form of EMVA 1288 reference data set 003; `gap` chooses the order by its penalty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Nonlinearity {
    pub enabled: bool,
    pub a1: f64,
    pub a2: f64,
    #[serde(alias = "a")]
    pub a3: f64,
}

impl Nonlinearity {
    /// Terms of the polynomial, lowest first.
    pub const MAX_ORDER: usize = 3;

    /// The coefficients `[a1, a2, a3]`.
    #[must_use]
    pub fn coefficients(&self) -> [f64; 3] {
        [self.a1, self.a2, self.a3]
    }

    /// The factor `1 + a1 r + a2 r^2 + a3 r^3` on a signal at `r` of full scale (1 when off).
    #[inline]
    #[must_use]
    pub fn factor(&self, r: f64) -> f64 {
        if self.enabled { 1.0 + self.a1 * r + self.a2 * r * r + self.a3 * r * r * r } else { 1.0 }
    }

    /// Highest nonzero term, 0 when off or flat.
    #[must_use]
    pub fn order(&self) -> usize {
        if !self.enabled {
            return 0;
        }
        self.coefficients().iter().rposition(|&a| a != 0.0).map_or(0, |i| i + 1)
    }

    /// The polynomial on DN, `g(x) = x + c1 x^2 + c2 x^3 + c3 x^4` with `c_k = a_k / max^k`
    /// (identity when off).
    #[must_use]
    pub fn in_dn(&self, max_dn: f64) -> DnPolynomial {
        if !self.enabled {
            return DnPolynomial::default();
        }
        DnPolynomial { c: [self.a1 / max_dn, self.a2 / (max_dn * max_dn), self.a3 / (max_dn * max_dn * max_dn)] }
    }
}

/// A nonlinearity on DN values, `g(x) = x + c[0] x^2 + c[1] x^3 + c[2] x^4`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DnPolynomial {
    pub c: [f64; 3],
}

impl DnPolynomial {
    /// Whether `g` is the identity.
    #[must_use]
    pub fn is_identity(&self) -> bool {
        self.c == [0.0; 3]
    }

    /// `g(x)`.
    #[inline]
    #[must_use]
    pub fn apply(&self, x: f64) -> f64 {
        x + self.bend(x)
    }

    /// `g(x) - x`.
    #[inline]
    #[must_use]
    pub fn bend(&self, x: f64) -> f64 {
        let [c1, c2, c3] = self.c;
        c1 * x * x + c2 * x * x * x + c3 * x * x * x * x
    }

    /// `g'(x)`.
    #[inline]
    #[must_use]
    pub fn slope(&self, x: f64) -> f64 {
        let [c1, c2, c3] = self.c;
        1.0 + 2.0 * c1 * x + 3.0 * c2 * x * x + 4.0 * c3 * x * x * x
    }

    /// `g''(x)`.
    #[inline]
    #[must_use]
    pub fn curvature(&self, x: f64) -> f64 {
        let [c1, c2, c3] = self.c;
        2.0 * c1 + 6.0 * c2 * x + 12.0 * c3 * x * x
    }
}

/// Dark signal non-uniformity: a fixed Gaussian offset per pixel, electrons (before the gain).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Dsnu {
    pub enabled: bool,
    pub std_e: f64,
}

/// Photo response non-uniformity: a fixed Gaussian relative sensitivity per pixel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Prnu {
    pub enabled: bool,
    /// Standard deviation of the relative sensitivity (0.01 = 1 %).
    pub std_fraction: f64,
}

/// A fixed fraction of pixels with excess dark current. The excess follows the quantile
/// function `excess_quantiles_e_per_s` (values at probabilities `0, 1/7, ..., 1`, linear
/// between them) where it is given, as a measured distribution does; without it, uniform in
/// `0..max_excess_e_per_s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HotPixels {
    pub enabled: bool,
    pub fraction: f64,
    pub max_excess_e_per_s: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub excess_quantiles_e_per_s: Option<[f64; HotPixels::QUANTILES]>,
}

impl HotPixels {
    /// Points of the quantile function.
    pub const QUANTILES: usize = 8;

    /// The excess dark current at probability `p` (0..1) of the hot pixels' distribution, e-/s.
    #[must_use]
    pub fn excess_at(&self, p: f64) -> f64 {
        match &self.excess_quantiles_e_per_s {
            None => p * self.max_excess_e_per_s,
            Some(q) => quantile_at(q, p),
        }
    }
}

/// Piecewise-linear quantile function through `q` (at least one value) at evenly spaced
/// probabilities `0..=1`, at `p`.
#[must_use]
pub fn quantile_at(q: &[f64], p: f64) -> f64 {
    let last = q.len() - 1;
    let x = p.clamp(0.0, 1.0) * last as f64;
    let i = (x.floor() as usize).min(last.saturating_sub(1));
    let t = x - i as f64;
    q[i] + t * (q[(i + 1).min(last)] - q[i])
}

/// Row noise (a fresh offset per row and frame, temporal) and column fixed-pattern noise (a
/// fixed offset per column), both DN after the gain stage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RowColumnNoise {
    pub enabled: bool,
    pub row_std_dn: f64,
    pub column_std_dn: f64,
}

/// Fixed sinusoidal offsets, DN: `A sin(2 pi (fx x + wx y)) + B sin(2 pi (wy x + fy y))`, two
/// plane waves, each with its own amplitude (`B` is `amplitude_y_dn`, or `A` where that is
/// absent). With `wx = wy = 0` (the default) a column and a row sinusoid; the cross terms turn
/// them into diagonal waves, as in EMVA 1288 data set 003 (its 2-D spectrum peaks at (0.04,
/// 0.04) and (0.2, 0.2) cycles/px). A wave whose two frequencies are 0 is absent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PeriodicPattern {
    pub enabled: bool,
    /// Amplitude of the first (x) wave, and of the second where `amplitude_y_dn` is absent.
    pub amplitude_dn: f64,
    /// Amplitude of the second (y) wave.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub amplitude_y_dn: Option<f64>,
    pub freq_x_cycles_per_px: f64,
    pub freq_y_cycles_per_px: f64,
    /// y frequency of the first (x) wave, `wx`.
    pub wave_x_freq_y_cycles_per_px: f64,
    /// x frequency of the second (y) wave, `wy`.
    pub wave_y_freq_x_cycles_per_px: f64,
}

impl PeriodicPattern {
    /// Amplitudes of the first (x) and the second (y) wave, DN.
    #[must_use]
    pub fn amplitudes(&self) -> (f64, f64) {
        (self.amplitude_dn, self.amplitude_y_dn.unwrap_or(self.amplitude_dn))
    }

    /// Which of the two waves are present (a wave with both frequencies 0 is not).
    #[must_use]
    pub fn waves_present(&self) -> [bool; 2] {
        [
            self.freq_x_cycles_per_px != 0.0 || self.wave_x_freq_y_cycles_per_px != 0.0,
            self.freq_y_cycles_per_px != 0.0 || self.wave_y_freq_x_cycles_per_px != 0.0,
        ]
    }

    /// Spatial variance of the pattern over a whole number of periods, DN^2 (`A^2 / 2` per wave
    /// present).
    #[must_use]
    pub fn variance_dn2(&self) -> f64 {
        if !self.enabled {
            return 0.0;
        }
        let (a, b) = self.amplitudes();
        let [x, y] = self.waves_present();
        (if x { a * a / 2.0 } else { 0.0 }) + (if y { b * b / 2.0 } else { 0.0 })
    }
}

macro_rules! off_by_default {
    ($($t:ident { $($f:ident: $v:expr),* }),* $(,)?) => {
        $(impl Default for $t {
            fn default() -> Self { $t { enabled: false, $($f: $v),* } }
        })*
    };
}

off_by_default!(
    BlackLevel { offset_dn: 0.0 },
    DarkCurrent { rate_e_per_s: 0.0 },
    ReadNoiseSplit { post_gain_fraction: 0.5 },
    Quantization { dither_dn: 0.0 },
    Saturation { full_well_e: f64::INFINITY },
    Nonlinearity { a1: 0.0, a2: 0.0, a3: 0.0 },
    Dsnu { std_e: 0.0 },
    Prnu { std_fraction: 0.0 },
    HotPixels { fraction: 0.0, max_excess_e_per_s: 0.0, excess_quantiles_e_per_s: None },
    RowColumnNoise { row_std_dn: 0.0, column_std_dn: 0.0 },
    PeriodicPattern {
        amplitude_dn: 0.0,
        amplitude_y_dn: None,
        freq_x_cycles_per_px: 0.0,
        freq_y_cycles_per_px: 0.0,
        wave_x_freq_y_cycles_per_px: 0.0,
        wave_y_freq_x_cycles_per_px: 0.0
    },
);

/// Every effect, by its name in docs/CONTRACTS.md.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Effects {
    pub black_level: BlackLevel,
    pub dark_current: DarkCurrent,
    pub read_noise_split: ReadNoiseSplit,
    pub quantization: Quantization,
    pub saturation: Saturation,
    pub nonlinearity: Nonlinearity,
    pub dsnu: Dsnu,
    pub prnu: Prnu,
    pub hot_pixels: HotPixels,
    pub row_column_noise: RowColumnNoise,
    pub periodic_pattern: PeriodicPattern,
}

impl Effects {
    /// Names of the effects switched on, in the order of docs/CONTRACTS.md.
    #[must_use]
    pub fn enabled_names(&self) -> Vec<&'static str> {
        let on = [
            self.black_level.enabled,
            self.dark_current.enabled,
            self.read_noise_split.enabled,
            self.quantization.enabled,
            self.saturation.enabled,
            self.nonlinearity.enabled,
            self.dsnu.enabled,
            self.prnu.enabled,
            self.hot_pixels.enabled,
            self.row_column_noise.enabled,
            self.periodic_pattern.enabled,
        ];
        SENSOR_EFFECTS.iter().zip(on).filter(|(_, on)| *on).map(|(n, _)| *n).collect()
    }
}

/// A sensor model could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    #[error("sensor model, line {line}: {message}")]
    Parse { line: usize, message: String },
    #[error("sensor model: {0}")]
    Invalid(String),
    #[error("sensor model cannot be written: {0}")]
    Write(#[from] toml::ser::Error),
}

/// The EMVA 1288 linear camera model with switchable effects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorModel {
    /// The sensor this model describes (catalog model name or a measured camera).
    pub name: String,
    /// Quantum efficiency (electrons per photon) at the simulated wavelength.
    pub quantum_efficiency: f64,
    /// Overall system gain K at 0 dB analog gain, DN per electron.
    pub system_gain_dn_per_e: f64,
    /// Temporal read noise at 0 dB, electrons rms (split by `effects.read_noise_split`).
    pub read_noise_e: f64,
    pub adc_bits: u32,
    /// Seed of this sensor instance's fixed patterns (DSNU, PRNU, hot pixels, columns).
    pub pattern_seed: u64,
    #[serde(default)]
    pub effects: Effects,
}

/// The fixed-pattern maps of one sensor instance at one size (empty when the effect is off).
#[derive(Debug, Clone, PartialEq)]
pub struct FixedPattern {
    pub width: usize,
    pub height: usize,
    /// DSNU offset per pixel, electrons.
    pub dsnu_e: Vec<f32>,
    /// Relative sensitivity per pixel minus one.
    pub prnu: Vec<f32>,
    /// Excess dark current per pixel, electrons per second.
    pub hot_e_per_s: Vec<f32>,
    /// Column offset, DN.
    pub column_dn: Vec<f32>,
}

impl SensorModel {
    /// A model of a catalog sensor with the basic effects on (black level, dark current,
    /// quantization, saturation) and the others off.
    ///
    /// K at 0 dB is chosen so that the full well fills the ADC range, `K = (2^bits - 1) /
    /// full_well`: the usual design point of a camera's base gain (stated convention).
    #[must_use]
    pub fn from_sensor(sensor: &Sensor, pattern_seed: u64) -> Self {
        let max_dn = f64::from((1u32 << sensor.adc_bits) - 1);
        let effects = Effects {
            black_level: BlackLevel { enabled: true, offset_dn: (max_dn + 1.0) * BLACK_LEVEL_FRACTION },
            dark_current: DarkCurrent { enabled: true, rate_e_per_s: sensor.dark_current_e_per_s },
            quantization: Quantization { enabled: true, dither_dn: 0.0 },
            saturation: Saturation { enabled: true, full_well_e: sensor.full_well_e },
            ..Effects::default()
        };
        SensorModel {
            name: sensor.model.clone(),
            quantum_efficiency: sensor.quantum_efficiency,
            system_gain_dn_per_e: max_dn / sensor.full_well_e,
            read_noise_e: sensor.read_noise_e,
            adc_bits: sensor.adc_bits,
            pattern_seed,
            effects,
        }
    }

    /// Reads a model from TOML text (the `model.toml` form).
    pub fn from_toml(text: &str) -> Result<Self, ModelError> {
        let model: SensorModel = toml::from_str(text).map_err(|e| {
            let offset = e.span().map_or(0, |s| s.start);
            let line = text[..offset.min(text.len())].bytes().filter(|&b| b == b'\n').count() + 1;
            ModelError::Parse { line, message: e.message().to_string() }
        })?;
        model.validate()?;
        Ok(model)
    }

    /// The `model.toml` text of this model.
    pub fn to_toml(&self) -> Result<String, ModelError> {
        Ok(toml::to_string(self)?)
    }

    /// Checks parameter ranges.
    pub fn validate(&self) -> Result<(), ModelError> {
        let bad = |m: String| Err(ModelError::Invalid(m));
        if !(self.quantum_efficiency >= 0.0 && self.quantum_efficiency <= 1.0) {
            return bad(format!("quantum_efficiency must be in 0..1, got {}", self.quantum_efficiency));
        }
        if !(self.system_gain_dn_per_e.is_finite() && self.system_gain_dn_per_e > 0.0) {
            return bad(format!("system_gain_dn_per_e must be positive, got {}", self.system_gain_dn_per_e));
        }
        if !(self.read_noise_e.is_finite() && self.read_noise_e >= 0.0) {
            return bad(format!("read_noise_e must be non-negative, got {}", self.read_noise_e));
        }
        if !(1..=16).contains(&self.adc_bits) {
            return bad(format!("adc_bits must be 1..16, got {}", self.adc_bits));
        }
        let f = self.effects.read_noise_split.post_gain_fraction;
        if !(0.0..=1.0).contains(&f) {
            return bad(format!("read_noise_split.post_gain_fraction must be in 0..1, got {f}"));
        }
        let d = self.effects.quantization.dither_dn;
        if !(0.0..=4.0).contains(&d) {
            return bad(format!("quantization.dither_dn must be in 0..4, got {d}"));
        }
        let h = self.effects.hot_pixels.fraction;
        if !(0.0..=1.0).contains(&h) {
            return bad(format!("hot_pixels.fraction must be in 0..1, got {h}"));
        }
        if let Some(q) = &self.effects.hot_pixels.excess_quantiles_e_per_s {
            let ordered = q.windows(2).all(|w| w[0] <= w[1]);
            if !q.iter().all(|v| v.is_finite() && *v >= 0.0) || !ordered {
                return bad(format!(
                    "hot_pixels.excess_quantiles_e_per_s must be finite, non-negative and non-decreasing, got {q:?}"
                ));
            }
        }
        Ok(())
    }

    /// Largest output value, `2^bits - 1` DN.
    #[must_use]
    pub fn max_dn(&self) -> f64 {
        f64::from((1u32 << self.adc_bits) - 1)
    }

    /// System gain at `gain_db`, DN per electron.
    #[must_use]
    pub fn k_dn_per_e(&self, gain_db: f64) -> f64 {
        self.system_gain_dn_per_e * gain_factor(gain_db)
    }

    /// Mean dark-current electrons collected in `exposure_s`.
    #[must_use]
    pub fn dark_e(&self, exposure_s: f64) -> f64 {
        self.dark_rate() * exposure_s
    }

    /// Temporal read noise at `gain_db` (before and after the gain together), DN.
    #[must_use]
    pub fn read_noise_dn(&self, gain_db: f64) -> f64 {
        let k = self.k_dn_per_e(gain_db);
        let (pre, post) = self.read_variances();
        (k * k * pre + post).sqrt()
    }

    /// Charge a pixel holds before it clips, electrons; `None` when saturation is off.
    #[must_use]
    pub fn full_well_e(&self) -> Option<f64> {
        self.effects.saturation.enabled.then_some(self.effects.saturation.full_well_e)
    }

    fn black_dn(&self) -> f64 {
        let b = self.effects.black_level;
        if b.enabled { b.offset_dn } else { 0.0 }
    }

    fn dark_rate(&self) -> f64 {
        let d = self.effects.dark_current;
        if d.enabled { d.rate_e_per_s } else { 0.0 }
    }

    /// (pre-gain read noise variance in e-^2, post-gain read noise variance in DN^2).
    fn read_variances(&self) -> (f64, f64) {
        let v = self.read_noise_e * self.read_noise_e;
        let s = self.effects.read_noise_split;
        if s.enabled {
            let k = self.system_gain_dn_per_e;
            ((1.0 - s.post_gain_fraction) * v, s.post_gain_fraction * v * k * k)
        } else {
            (v, 0.0)
        }
    }

    fn full_well(&self) -> f64 {
        let s = self.effects.saturation;
        if s.enabled { s.full_well_e } else { f64::INFINITY }
    }

    fn nonlinear(&self, y: f64) -> f64 {
        let n = self.effects.nonlinearity;
        if n.enabled { y * n.factor(y / self.max_dn()) } else { y }
    }

    /// Mean output of a typical pixel (no fixed-pattern offsets, not hot), DN, for a mean of
    /// `photons` per pixel. Includes saturation and nonlinearity; the rounding bias is ignored.
    #[must_use]
    pub fn expected_mean_dn(&self, photons: f64, exposure_s: f64, gain_db: f64) -> f64 {
        let e = (self.quantum_efficiency * photons + self.dark_rate() * exposure_s).min(self.full_well());
        let y = self.nonlinear(self.k_dn_per_e(gain_db) * e) + self.black_dn();
        if self.effects.saturation.enabled { y.clamp(0.0, self.max_dn()) } else { y }
    }

    /// Temporal variance of a typical pixel away from clipping, DN^2, for a mean of `photons`
    /// per pixel: `K^2 g^2 (QE photons + dark t + sigma_pre^2) + sigma_post^2 + row^2 + 1/12`.
    /// Nonlinearity is ignored (it is a few per cent at full scale at most).
    #[must_use]
    pub fn expected_temporal_variance_dn2(&self, photons: f64, exposure_s: f64, gain_db: f64) -> f64 {
        let k = self.k_dn_per_e(gain_db);
        let (pre, post) = self.read_variances();
        let rc = self.effects.row_column_noise;
        let row = if rc.enabled { rc.row_std_dn * rc.row_std_dn } else { 0.0 };
        let quant = self.effects.quantization;
        let q = if quant.enabled { (1.0 + quant.dither_dn * quant.dither_dn) / 12.0 } else { 0.0 };
        k * k * (self.quantum_efficiency * photons + self.dark_rate() * exposure_s + pre) + post + row + q
    }

    /// Builds this instance's fixed patterns for a `width x height` frame.
    #[must_use]
    pub fn fixed_pattern(&self, width: usize, height: usize) -> FixedPattern {
        let e = &self.effects;
        let seed = self.pattern_seed;
        let map = |label: &str, f: &(dyn Fn(&mut rand_chacha::ChaCha8Rng) -> f32 + Sync)| -> Vec<f32> {
            let mut out = vec![0f32; width * height];
            out.par_chunks_mut(width.max(1)).enumerate().for_each(|(r, row)| {
                let mut rng = rng::substream(seed, label, r as u64);
                row.iter_mut().for_each(|v| *v = f(&mut rng));
            });
            out
        };
        let dsnu_e = if e.dsnu.enabled {
            let s = e.dsnu.std_e;
            map("sensor/dsnu", &|r| (s * standard_normal(r)) as f32)
        } else {
            Vec::new()
        };
        let prnu = if e.prnu.enabled {
            let s = e.prnu.std_fraction;
            map("sensor/prnu", &|r| (s * standard_normal(r)).max(-1.0) as f32)
        } else {
            Vec::new()
        };
        let hot_e_per_s = if e.hot_pixels.enabled {
            let hp = e.hot_pixels;
            map("sensor/hot", &|r| {
                let hot = r.random::<f64>() < hp.fraction;
                let excess = hp.excess_at(r.random::<f64>());
                if hot { excess as f32 } else { 0.0 }
            })
        } else {
            Vec::new()
        };
        let column_dn = if e.row_column_noise.enabled && e.row_column_noise.column_std_dn > 0.0 {
            let mut r = rng::stream(seed, "sensor/column");
            (0..width).map(|_| (e.row_column_noise.column_std_dn * standard_normal(&mut r)) as f32).collect()
        } else {
            Vec::new()
        };
        FixedPattern { width, height, dsnu_e, prnu, hot_e_per_s, column_dn }
    }

    /// Simulates one frame: `photons` (mean photons per pixel, row-major `width x height`) to
    /// DN. Same seeds give the same bytes at any thread count.
    ///
    /// # Panics
    /// If `photons.len() != width * height`.
    #[must_use]
    pub fn simulate(
        &self,
        photons: &[f32],
        width: usize,
        height: usize,
        exposure_s: f64,
        gain_db: f64,
        frame_seed: u64,
    ) -> Vec<u16> {
        let pattern = self.fixed_pattern(width, height);
        self.simulate_with(&pattern, photons, exposure_s, gain_db, frame_seed)
    }

    /// [`Self::simulate`] with a prebuilt fixed pattern (for many frames of one instance).
    ///
    /// # Panics
    /// If `photons.len()` differs from the pattern's size.
    #[must_use]
    pub fn simulate_with(
        &self,
        pattern: &FixedPattern,
        photons: &[f32],
        exposure_s: f64,
        gain_db: f64,
        frame_seed: u64,
    ) -> Vec<u16> {
        let sim = self.frame_simulator(pattern, exposure_s, gain_db, frame_seed);
        sim.frame(Dispatch::current(), photons, |y| sim.to_u16(y))
    }

    /// The frame before the final conversion to `u16`: rounded and clipped only when the
    /// `quantization` and `saturation` effects are on.
    ///
    /// # Panics
    /// If `photons.len()` differs from the pattern's size.
    #[must_use]
    pub fn simulate_dn_with(
        &self,
        pattern: &FixedPattern,
        photons: &[f32],
        exposure_s: f64,
        gain_db: f64,
        frame_seed: u64,
    ) -> Vec<f64> {
        self.frame_simulator(pattern, exposure_s, gain_db, frame_seed).frame(Dispatch::current(), photons, |y| y)
    }

    /// The per-frame constants of one simulated frame, so that callers can simulate it row by
    /// row, fused with their own per-row work (e.g. the evaluator's photon conversion before and
    /// its 8-bit output after; [`crate::isp::capture_8bit`]).
    #[must_use]
    pub fn frame_simulator<'a>(
        &'a self,
        pattern: &'a FixedPattern,
        exposure_s: f64,
        gain_db: f64,
        frame_seed: u64,
    ) -> FrameSimulator<'a> {
        let (width, height) = (pattern.width, pattern.height);
        let e = &self.effects;
        let (pre_var, post_var) = self.read_variances();
        let pp = e.periodic_pattern;
        let two_pi = std::f64::consts::TAU;
        // The waves from per-column and per-row tables, `sin(a + b) = sin a cos b + cos a sin b`
        // (w + h sin_cos calls per frame instead of two sines per pixel; the same tables for
        // every row window, so a row's bytes do not depend on how many rows are simulated).
        let col_waves: Vec<[(f64, f64); 2]> = if pp.enabled {
            (0..width)
                .map(|c| {
                    let cf = c as f64;
                    [
                        (two_pi * pp.freq_x_cycles_per_px * cf).sin_cos(),
                        (two_pi * pp.wave_y_freq_x_cycles_per_px * cf).sin_cos(),
                    ]
                })
                .collect()
        } else {
            Vec::new()
        };
        FrameSimulator {
            model: self,
            pattern,
            width,
            height,
            exposure_s,
            frame_seed,
            k: self.k_dn_per_e(gain_db),
            pre_sd: pre_var.sqrt(),
            post_sd: post_var.sqrt(),
            dark_mean: self.dark_rate() * exposure_s,
            full_well: self.full_well(),
            black: self.black_dn(),
            max: self.max_dn(),
            row_sd: if e.row_column_noise.enabled { e.row_column_noise.row_std_dn } else { 0.0 },
            separable: pp.wave_x_freq_y_cycles_per_px == 0.0 && pp.wave_y_freq_x_cycles_per_px == 0.0,
            col_waves,
            dark_table: OnceLock::new(),
            clip_table: OnceLock::new(),
        }
    }
}

/// One frame of a [`SensorModel`] with its fixed pattern, exposure, gain and frame seed: the
/// per-frame constants computed once, and [`FrameSimulator::row`] to simulate any row on its
/// own. Row `r`'s draws come from `rng::substream(frame_seed, SOURCE, r)` (module docs) whichever
/// rows are simulated and in whatever order, so output bytes never depend on the thread count.
#[derive(Debug, Clone)]
pub struct FrameSimulator<'a> {
    model: &'a SensorModel,
    pattern: &'a FixedPattern,
    /// Frame size, pixels (the pattern's).
    pub width: usize,
    pub height: usize,
    exposure_s: f64,
    frame_seed: u64,
    /// System gain at the frame's analog gain, DN per electron.
    k: f64,
    pre_sd: f64,
    post_sd: f64,
    dark_mean: f64,
    full_well: f64,
    black: f64,
    max: f64,
    row_sd: f64,
    separable: bool,
    col_waves: Vec<[(f64, f64); 2]>,
    /// The rounded moments of dark pixels over their fractional offset, built on first use
    /// ([`FrameSimulator::row_moments`]); `None` when their noise is too fine to tabulate.
    dark_table: OnceLock<Option<Arc<RoundingTable>>>,
    /// The same for dark pixels whose output reaches 0 DN, over their levels near the clip.
    clip_table: OnceLock<Option<Arc<ClipTable>>>,
}

/// What [`FrameSimulator::row_moments`] reads of each pixel that light, exposure and gain do
/// not change: the sensitivity `QE (1 + prnu)`, the hot-pixel excess, the DSNU and the fixed
/// offset (black level, column offset, periodic pattern). The same for every block of an
/// acquisition simulated with one model ([`FrameSimulator::pixel_constants`]), so computed
/// once instead of per block and row.
#[derive(Debug, Clone)]
pub struct PixelConstants {
    width: usize,
    height: usize,
    sens: Vec<f64>,
    /// Empty when hot pixels are off.
    hot_e_per_s: Vec<f64>,
    /// Empty when DSNU is off.
    dsnu_e: Vec<f64>,
    offset_dn: Vec<f64>,
    /// Smallest and largest DSNU, electrons (zeros when it is off).
    dsnu_range_e: [f64; 2],
    /// Smallest and largest fixed offset, DN.
    offset_range_dn: [f64; 2],
}

/// What [`FrameSimulator::row_moments`] needs of one pixel.
struct PixelInputs {
    /// Poisson mean, electrons: signal, dark current and hot-pixel excess.
    lambda_e: f64,
    /// No signal and no hot-pixel excess: the Poisson mean is the frame's dark mean.
    dark_only: bool,
    dsnu_e: f64,
    /// Black level, column offset and periodic pattern, DN.
    offset_dn: f64,
}

/// What [`FrameSimulator::row_moments`] needs of one row, one slice per quantity.
struct RowConstants<'a> {
    /// Poisson mean per pixel, electrons: signal, dark current and hot-pixel excess.
    lambda_e: Vec<f64>,
    /// DSNU per pixel, electrons (zeros when it is off).
    dsnu_e: Cow<'a, [f64]>,
    /// Black level, column offset and periodic pattern per pixel, DN.
    offset_dn: &'a [f64],
    /// Variance added after the gain (post-gain noise and dither), DN^2.
    extra_var: f64,
    /// Variance of the row offset, DN^2.
    row_var: f64,
}

/// Whether a row's pixels keep eight standard deviations from the full well and from the
/// ADC's clips ([`FrameSimulator::row_moments`]).
struct RowBounds {
    below_full_well: bool,
    inside: bool,
}

impl FrameSimulator<'_> {
    /// Every row of the frame of `photons`, rows in parallel, each value through `convert`; the
    /// rows run in the build `dispatch` of [`FrameSimulator::row`] ([`scene_gen_core::simd`], the same
    /// values either way).
    ///
    /// # Panics
    /// If `photons.len()` differs from the frame's size.
    fn frame<T: Copy + Default + Send>(
        &self,
        dispatch: Dispatch,
        photons: &[f32],
        convert: impl Fn(f64) -> T + Sync,
    ) -> Vec<T> {
        assert_eq!(photons.len(), self.width * self.height, "photon image size must be width x height");
        let mut out = vec![T::default(); photons.len()];
        out.par_chunks_mut(self.width.max(1)).zip(photons.par_chunks(self.width.max(1))).enumerate().for_each(
            |(r, (row_out, row_photons))| {
                self.row_dispatched(dispatch, r, row_photons, |c, y| row_out[c] = convert(y));
            },
        );
        out
    }

    /// [`FrameSimulator::row`] compiled with AVX2 and FMA enabled (the noise draws and the
    /// per-pixel arithmetic get AVX2 code; the values are the same).
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA: call it only when [`Dispatch::supported`] returned
    /// [`Dispatch::Avx2Fma`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn row_avx2(&self, r: usize, photons: &[f32], emit: impl FnMut(usize, f64)) {
        self.row(r, photons, emit);
    }

    /// Simulates row `r` from its mean photons per pixel (`photons.len()` = width), handing
    /// each pixel's value (before the final conversion, as [`SensorModel::simulate_dn_with`]) to
    /// `emit(column, value)` in column order.
    ///
    /// Always inlined, so that every caller compiles its own copy for its own CPU features (the
    /// AVX2 clones of [`scene_gen_core::simd`] among them).
    ///
    /// # Panics
    /// If `photons` is not one row long or `r` is outside the frame.
    #[inline(always)]
    pub fn row(&self, r: usize, photons: &[f32], mut emit: impl FnMut(usize, f64)) {
        let width = self.width;
        assert!(photons.len() == width && r < self.height, "row {r} of {} px must be in the frame", photons.len());
        let e = &self.model.effects;
        let p = self.pattern;
        let span = r * width..(r + 1) * width;
        // Row slices of the maps that are on (an effect that is off has an empty map).
        let prnu = p.prnu.get(span.clone());
        let hot = p.hot_e_per_s.get(span.clone());
        let dsnu = p.dsnu_e.get(span);
        let column = (p.column_dn.len() == width).then_some(p.column_dn.as_slice());
        let qe = self.model.quantum_efficiency;
        let nl = e.nonlinearity;
        let pp = e.periodic_pattern;
        let (pre_sd, post_sd, k, full_well) = (self.pre_sd, self.post_sd, self.k, self.full_well);
        let (quantize, saturate, max) = (e.quantization.enabled, e.saturation.enabled, self.max);
        let dither_dn = if quantize { e.quantization.dither_dn } else { 0.0 };
        let (exposure_s, dark_mean, black) = (self.exposure_s, self.dark_mean, self.black);

        // One stream per source of temporal noise (common random numbers): switching an effect
        // on or off, or changing its size, leaves every other source's draws as they were, so
        // two simulations that differ by one effect differ by that effect, not by a new draw of
        // everything else. The gap search compares such simulations by their chi-square.
        let stream = |source: &str| rng::substream(self.frame_seed, source, r as u64);
        let mut rng = stream("sensor/temporal");
        let mut pre_rng = stream("sensor/read-pre");
        let mut post_rng = stream("sensor/read-post");
        let mut dither_rng = stream("sensor/dither");
        let row_offset =
            if self.row_sd > 0.0 { self.row_sd * standard_normal(&mut stream("sensor/row-offset")) } else { 0.0 };
        let row_waves = self.row_waves(r);
        // The row in blocks of `ROW_BLOCK` pixels, three passes each: the arithmetic that needs
        // no random draw before (the mean electrons and PTRS's constants) and after (DN, the
        // effects, rounding) runs in loops without draws, which the compiler vectorises and the
        // CPU overlaps; only the draws themselves stay in a serial loop, in the stream's order.
        // Every value is computed by the same operations in the same order as one loop would.

        let mut mean_e = [0f64; ROW_BLOCK];
        let mut ptrs = [Ptrs::default(); ROW_BLOCK];
        let mut exp_neg = [0f64; ROW_BLOCK];
        // `exp(-mean)` of the last small mean met: pixels of one mean (a dark frame, an even
        // field without PRNU) share it.
        let mut last_small = (f64::NAN, 0.0);
        let mut drawn_e = [0f64; ROW_BLOCK];
        let mut pre_z = [0f64; ROW_BLOCK];
        let mut post_z = [0f64; ROW_BLOCK];
        let mut dither_u = [0f64; ROW_BLOCK];
        for (b, ph) in photons.chunks(ROW_BLOCK).enumerate() {
            let (c0, n) = (b * ROW_BLOCK, ph.len());
            let cols = c0..c0 + n;
            let prnu = prnu.map(|m| &m[cols.clone()]);
            let hot = hot.map(|m| &m[cols.clone()]);
            let dsnu = dsnu.map(|m| &m[cols.clone()]);
            let column = column.map(|m| &m[cols]);
            let (mean_e, ptrs, exp_neg) = (&mut mean_e[..n], &mut ptrs[..n], &mut exp_neg[..n]);
            let (drawn_e, pre_z, post_z) = (&mut drawn_e[..n], &mut pre_z[..n], &mut post_z[..n]);
            let dither_u = &mut dither_u[..n];
            // 1. Mean electrons, signal plus dark (hot pixels add to the dark mean), and PTRS's
            // constants (used only where the mean is >= 10).
            match prnu {
                Some(m) => {
                    for ((mu, &ph), &s) in mean_e.iter_mut().zip(ph).zip(m) {
                        *mu = qe * (1.0 + f64::from(s)) * f64::from(ph).max(0.0) + dark_mean;
                    }
                }
                None => {
                    for (mu, &ph) in mean_e.iter_mut().zip(ph) {
                        // `qe * 1.0` is `qe`: the value of `qe * sens * ph` with `sens = 1`.
                        *mu = qe * f64::from(ph).max(0.0) + dark_mean;
                    }
                }
            }
            if let Some(m) = hot {
                for (mu, &h) in mean_e.iter_mut().zip(m) {
                    *mu += f64::from(h) * exposure_s;
                }
            }
            for (t, &mu) in ptrs.iter_mut().zip(mean_e.iter()) {
                *t = Ptrs::new(mu);
            }
            // Inversion's `p_0 = exp(-mean)` (means below 10), once per run of equal means.
            for (e, &mu) in exp_neg.iter_mut().zip(mean_e.iter()) {
                if mu < POISSON_INVERSION_MAX {
                    if mu.to_bits() != last_small.0.to_bits() {
                        last_small = (mu, (-mu).exp());
                    }
                    *e = last_small.1;
                }
            }
            // 2. The draws, in the order of the stream.
            for i in 0..n {
                drawn_e[i] = poisson_with(&mut rng, mean_e[i], &ptrs[i], exp_neg[i]);
                if pre_sd > 0.0 {
                    pre_z[i] = standard_normal(&mut pre_rng);
                }
                if post_sd > 0.0 {
                    post_z[i] = standard_normal(&mut post_rng);
                }
                if dither_dn > 0.0 {
                    dither_u[i] = dither_rng.random::<f64>() - 0.5;
                }
            }
            // 3. DN and the effects after the draws.
            for i in 0..n {
                let mut electrons = drawn_e[i];
                electrons += dsnu.map_or(0.0, |m| f64::from(m[i]));
                if pre_sd > 0.0 {
                    electrons += pre_sd * pre_z[i];
                }
                electrons = electrons.min(full_well);
                let mut y = k * electrons;
                if nl.enabled {
                    y *= nl.factor(y / max);
                }
                if post_sd > 0.0 {
                    y += post_sd * post_z[i];
                }
                y += row_offset + black;
                y += column.map_or(0.0, |m| f64::from(m[i]));
                if pp.enabled {
                    y += self.periodic_dn(&row_waves, c0 + i);
                }
                if quantize {
                    if dither_dn > 0.0 {
                        y += dither_dn * dither_u[i];
                    }
                    y = round_exact(y);
                }
                if saturate {
                    y = y.clamp(0.0, max);
                }
                emit(c0 + i, y);
            }
        }
    }

    /// [`FrameSimulator::row`] in the build `dispatch` (the AVX2 copy where the CPU has it; the
    /// same values either way), for callers that simulate a frame row by row.
    ///
    /// # Panics
    /// As [`FrameSimulator::row`].
    pub fn row_dispatched(&self, dispatch: Dispatch, r: usize, photons: &[f32], emit: impl FnMut(usize, f64)) {
        match dispatch.supported() {
            // SAFETY: `supported()` gives `Avx2Fma` only when this CPU has AVX2 and FMA.
            #[cfg(target_arch = "x86_64")]
            Dispatch::Avx2Fma => unsafe { self.row_avx2(r, photons, emit) },
            _ => self.row(r, photons, emit),
        }
    }

    /// Standard deviation of the row offset of `row_column_noise`, DN: one draw per row and
    /// frame, shared by the row's pixels.
    #[must_use]
    pub fn row_offset_sd_dn(&self) -> f64 {
        self.row_sd
    }

    /// `sin_cos` of the periodic pattern's two phases along y at row `r` ([`Self::periodic_dn`]).
    fn row_waves(&self, r: usize) -> [(f64, f64); 2] {
        let pp = self.model.effects.periodic_pattern;
        let (two_pi, rf) = (std::f64::consts::TAU, r as f64);
        [(two_pi * pp.wave_x_freq_y_cycles_per_px * rf).sin_cos(), (two_pi * pp.freq_y_cycles_per_px * rf).sin_cos()]
    }

    /// The periodic pattern at column `c` of the row whose [`Self::row_waves`] are `row_waves`,
    /// DN (`sin(a + b) = sin a cos b + cos a sin b` from the column and row tables); call it
    /// only when the pattern is on.
    #[inline(always)]
    fn periodic_dn(&self, row_waves: &[(f64, f64); 2], c: usize) -> f64 {
        let (ax, ay) = self.model.effects.periodic_pattern.amplitudes();
        let [(sx, cx), (sy, cy)] = self.col_waves[c];
        if self.separable {
            ay * row_waves[1].0 + ax * sx
        } else {
            let [(sxr, cxr), (syr, cyr)] = *row_waves;
            let (x_wave, y_wave) = (sx * cxr + cx * sxr, sy * cyr + cy * syr);
            if ax == ay { ax * (x_wave + y_wave) } else { ax * x_wave + ay * y_wave }
        }
    }

    /// The mean and variance of every pixel of row `r` as this frame's output gives them (after
    /// rounding and clipping to `u16`), the row offset left out; `false` when the row holds a
    /// pixel whose moments cannot be had at a bounded cost: one within reach of the full well,
    /// or one whose exact sum (near a clip, or rounded so finely that rounding shifts its mean)
    /// would take more than [`EXACT_TERMS_MAX`] terms.
    ///
    /// Away from the clips a pixel's output is `round(A + noise)` with noise of variance `V`:
    /// shot noise, read noise, post-gain noise and dither. Its mean is `A` up to a periodic
    /// bias whose size is bounded by the noise's characteristic function at multiples of
    /// `2 pi` (rounding is a sawtooth; Sheppard's correction holds to the same bound), and
    /// its variance is `V + 1/12`. The row is accepted when that bound is below
    /// [`ROUNDING_BIAS_MAX_DN`] for its darkest pixel (the Poisson lattice smooths least where
    /// the mean is lowest) and every pixel's mean lies eight standard deviations inside the
    /// clips. The nonlinearity enters through the exact fourth moment of the electrons (the
    /// mean) and its slope and curvature (the variance). Other rows take exact moments pixel by
    /// pixel where the Gaussian ones fail: dark pixels from one table per frame over their
    /// level, near 0 DN as well; pixels against the ADC's top with a thousand electrons or more
    /// from their censored moments; the rest summed over their counts.
    ///
    /// # Panics
    /// If `photons`, `mean` or `var` is not one row long, or `r` is outside the frame.
    #[inline(always)]
    pub fn row_moments(
        &self,
        constants: &PixelConstants,
        r: usize,
        photons: &[f32],
        mean: &mut [f64],
        var: &mut [f64],
    ) -> bool {
        let width = self.width;
        assert!(
            photons.len() == width && mean.len() == width && var.len() == width && r < self.height,
            "row {r} of {} px must be in the frame",
            photons.len()
        );
        assert!(constants.width == width && constants.height == self.height, "constants of another frame size");
        let e = &self.model.effects;
        let dither_dn = if e.quantization.enabled { e.quantization.dither_dn } else { 0.0 };
        let g = self.nonlinearity_dn();
        let bends = !g.is_identity();
        let (row, bounds, darkest) = match Dispatch::current().supported() {
            // SAFETY: `supported()` gives `Avx2Fma` only when this CPU has AVX2 and FMA.
            #[cfg(target_arch = "x86_64")]
            Dispatch::Avx2Fma => unsafe {
                self.row_gaussian_moments_avx2(constants, r, photons, dither_dn, (&g, bends), (mean, var))
            },
            _ => self.row_gaussian_moments(constants, r, photons, dither_dn, (&g, bends), (mean, var)),
        };
        if !bounds.below_full_well {
            return false;
        }
        if bounds.inside {
            // The darkest pixel (the first of them): the Poisson lattice smooths least there.
            let (_, vy, slope) = self.pixel_moments::<true>(&row, &g, darkest);
            if self.rounding_is_smooth(row.lambda_e[darkest], slope, vy, dither_dn) {
                return true;
            }
        }
        self.exact_row_moments(constants, &self.row_inputs(constants, r, photons), mean, var)
    }

    /// What the moments of row `r` need of its pixels, as [`FrameSimulator::row`] adds them:
    /// the Poisson mean (signal, dark current and hot-pixel excess), the DSNU, the fixed offset
    /// (black level, column offset, periodic pattern), and the row's constants.
    #[inline(always)]
    fn row_constants<'a>(
        &self,
        constants: &'a PixelConstants,
        r: usize,
        photons: &[f32],
        dither_dn: f64,
    ) -> RowConstants<'a> {
        let span = r * self.width..(r + 1) * self.width;
        let mut lambda_e: Vec<f64> = constants.sens[span.clone()]
            .iter()
            .zip(photons)
            .map(|(s, p)| s * f64::from(*p).max(0.0) + self.dark_mean)
            .collect();
        if let Some(hot) = constants.hot_e_per_s.get(span.clone()) {
            lambda_e.iter_mut().zip(hot).for_each(|(l, h)| *l += h * self.exposure_s);
        }
        let dsnu_e = constants.dsnu_e.get(span.clone()).map_or_else(|| vec![0.0; self.width].into(), Cow::Borrowed);
        RowConstants {
            lambda_e,
            dsnu_e,
            offset_dn: &constants.offset_dn[span],
            extra_var: self.post_sd * self.post_sd + dither_dn * dither_dn / 12.0,
            row_var: self.row_sd * self.row_sd,
        }
    }

    /// Mean, variance before rounding and gain slope of pixel `i` of `row` (see
    /// [`FrameSimulator::row_moments`]); `BENDS`: the nonlinearity `g` is not the identity.
    #[inline(always)]
    fn pixel_moments<const BENDS: bool>(&self, row: &RowConstants, g: &DnPolynomial, i: usize) -> (f64, f64, f64) {
        let k = self.k;
        let lambda = row.lambda_e[i];
        let v = k * k * (lambda + self.pre_sd * self.pre_sd);
        let mu = k * (lambda + row.dsnu_e[i]);
        let (mut a, mut slope, mut curvature) = (mu, 1.0, 0.0);
        if BENDS {
            // E[x^2..4] from the cumulants of x = k e: Poisson's are all lambda, the read
            // noise adds to the second.
            let (k3, k4) = (k * k * k * lambda, k * k * k * k * lambda);
            let x2 = mu * mu + v;
            let x3 = mu * mu * mu + 3.0 * mu * v + k3;
            let x4 = mu * mu * mu * mu + 6.0 * mu * mu * v + 4.0 * mu * k3 + k4 + 3.0 * v * v;
            let [c1, c2, c3] = g.c;
            (a, slope, curvature) = (mu + c1 * x2 + c2 * x3 + c3 * x4, g.slope(mu), g.curvature(mu));
        }
        a += row.offset_dn[i];
        (a, slope * slope * v + 0.5 * curvature * curvature * v * v + row.extra_var, slope)
    }

    /// Every pixel's Gaussian moments ([`FrameSimulator::pixel_moments`], the variance with
    /// rounding's `1/12`) into `mean` and `var`, and whether the row clears the full well and
    /// the clips by eight standard deviations. One branch-free pass, so that it vectorises.
    #[inline(always)]
    fn gaussian_moments<const BENDS: bool>(
        &self,
        row: &RowConstants,
        g: &DnPolynomial,
        mean: &mut [f64],
        var: &mut [f64],
    ) -> RowBounds {
        let (pre_var, full_well, max) = (self.pre_sd * self.pre_sd, self.full_well, self.max);
        let (mut below_full_well, mut inside) = (true, true);
        let n = mean.len().min(var.len()).min(row.lambda_e.len()).min(row.dsnu_e.len()).min(row.offset_dn.len());
        for i in 0..n {
            let (a, vy, _) = self.pixel_moments::<BENDS>(row, g, i);
            let mean_e = row.lambda_e[i] + row.dsnu_e[i];
            let var_e = row.lambda_e[i] + pre_var;
            // Eight standard deviations, compared squared (no square root per pixel).
            let headroom = full_well - mean_e;
            below_full_well &= headroom > 0.0 && headroom * headroom > 64.0 * var_e;
            let (low, high) = (a + 0.5, max + 0.5 - a);
            let reach2 = 64.0 * (vy + row.row_var);
            inside &= low > 0.0 && high > 0.0 && low * low > reach2 && high * high > reach2;
            mean[i] = a;
            var[i] = vy + 1.0 / 12.0;
        }
        RowBounds { below_full_well, inside }
    }

    /// Row `r`'s constants ([`FrameSimulator::row_constants`]), its pixels' Gaussian moments
    /// ([`FrameSimulator::gaussian_moments`]) and the index of its darkest pixel (the first with
    /// the smallest Poisson mean).
    /// `(g, bends)`: the nonlinearity, and whether it is not the identity; the moments go to
    /// `(mean, var)`.
    #[inline(always)]
    fn row_gaussian_moments<'a>(
        &self,
        constants: &'a PixelConstants,
        r: usize,
        photons: &[f32],
        dither_dn: f64,
        (g, bends): (&DnPolynomial, bool),
        (mean, var): (&mut [f64], &mut [f64]),
    ) -> (RowConstants<'a>, RowBounds, usize) {
        let row = self.row_constants(constants, r, photons, dither_dn);
        let bounds = if bends {
            self.gaussian_moments::<true>(&row, g, mean, var)
        } else {
            self.gaussian_moments::<false>(&row, g, mean, var)
        };
        let lambda_min = row.lambda_e.iter().fold(f64::INFINITY, |m, &x| m.min(x));
        let darkest = row.lambda_e.iter().position(|&x| x == lambda_min).unwrap_or(0);
        (row, bounds, darkest)
    }

    /// [`FrameSimulator::row_gaussian_moments`] compiled with AVX2 and FMA enabled (the same
    /// values).
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA: call it only when [`Dispatch::supported`] returned
    /// [`Dispatch::Avx2Fma`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn row_gaussian_moments_avx2<'a>(
        &self,
        constants: &'a PixelConstants,
        r: usize,
        photons: &[f32],
        dither_dn: f64,
        nonlinearity: (&DnPolynomial, bool),
        moments: (&mut [f64], &mut [f64]),
    ) -> (RowConstants<'a>, RowBounds, usize) {
        self.row_gaussian_moments(constants, r, photons, dither_dn, nonlinearity, moments)
    }

    /// The per-pixel constants of this frame's moments ([`PixelConstants`]).
    #[must_use]
    pub fn pixel_constants(&self) -> PixelConstants {
        let (width, height) = (self.width, self.height);
        let p = self.pattern;
        let qe = self.model.quantum_efficiency;
        let periodic = self.model.effects.periodic_pattern.enabled;
        let column = (p.column_dn.len() == width).then_some(p.column_dn.as_slice());
        let mut offset_dn = vec![0.0; width * height];
        offset_dn.par_chunks_mut(width.max(1)).enumerate().for_each(|(r, row)| {
            let row_waves = self.row_waves(r);
            for (i, o) in row.iter_mut().enumerate() {
                *o = self.black + column.map_or(0.0, |m| f64::from(m[i]));
                if periodic {
                    *o += self.periodic_dn(&row_waves, i);
                }
            }
        });
        let sens = if p.prnu.is_empty() {
            vec![qe; width * height]
        } else {
            p.prnu.iter().map(|&s| qe * (1.0 + f64::from(s))).collect()
        };
        let widen = |m: &[f32]| m.iter().map(|&v| f64::from(v)).collect::<Vec<f64>>();
        let range = |m: &[f64]| {
            let bounds = m.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], &v| [lo.min(v), hi.max(v)]);
            if m.is_empty() { [0.0; 2] } else { bounds }
        };
        let dsnu_e = widen(&p.dsnu_e);
        let (dsnu_range_e, offset_range_dn) = (range(&dsnu_e), range(&offset_dn));
        let hot_e_per_s = widen(&p.hot_e_per_s);
        PixelConstants { width, height, sens, hot_e_per_s, dsnu_e, offset_dn, dsnu_range_e, offset_range_dn }
    }

    /// Whether rounding leaves the two moments of a pixel of `lambda_e` mean electrons, gain
    /// slope `slope` and variance `var_dn2` as `E y` and `Var y + 1/12`
    /// ([`rounding_error_bounds`]).
    fn rounding_is_smooth(&self, lambda_e: f64, slope: f64, var_dn2: f64, dither_dn: f64) -> bool {
        let smooth_var = (self.k * slope * self.pre_sd).powi(2) + self.post_sd * self.post_sd;
        // The sum's first Gaussian factor, exp(-2 pi^2 smooth_var), below 1e-12 already bounds
        // both errors far inside their limits (the sum stops there): no need to sum.
        if 2.0 * std::f64::consts::PI * std::f64::consts::PI * smooth_var > 27.7 && var_dn2 > 1e-6 {
            return true;
        }
        let r = rounding_error_bounds(lambda_e, self.k * slope, smooth_var, dither_dn, var_dn2);
        r.mean_dn <= ROUNDING_BIAS_MAX_DN && r.var_dn2 <= ROUNDING_VAR_ERROR_MAX * var_dn2
    }

    /// The nonlinearity as a polynomial on DN ([`Nonlinearity::in_dn`]).
    fn nonlinearity_dn(&self) -> DnPolynomial {
        self.model.effects.nonlinearity.in_dn(self.max)
    }

    /// Each pixel of row `r`: its Poisson mean, its DSNU and its fixed offset (black level,
    /// column offset, periodic pattern), as [`FrameSimulator::row`] adds them.
    fn row_inputs(&self, constants: &PixelConstants, r: usize, photons: &[f32]) -> Vec<PixelInputs> {
        let span = r * self.width..(r + 1) * self.width;
        let hot = constants.hot_e_per_s.get(span.clone());
        let dsnu = constants.dsnu_e.get(span.clone());
        let (sens, offset) = (&constants.sens[span.clone()], &constants.offset_dn[span]);
        (0..self.width)
            .map(|i| {
                let light_e = sens[i] * f64::from(photons[i]).max(0.0);
                let hot_e = hot.map_or(0.0, |m| m[i] * self.exposure_s);
                PixelInputs {
                    lambda_e: light_e + self.dark_mean + hot_e,
                    dark_only: light_e == 0.0 && hot_e == 0.0,
                    dsnu_e: dsnu.map_or(0.0, |m| m[i]),
                    offset_dn: offset[i],
                }
            })
            .collect()
    }

    /// The exact moments of a row's rounded, clipped outputs where rounding is too fine for
    /// `E y` and `Var y + 1/12` ([`rounded_moments`]): dark pixels from one of two tables (they
    /// share their Poisson mean): clear of the clips over the fractional offset, near 0 DN over
    /// the level ([`ClipTable`]); pixels whose own noise is smooth enough keep their Gaussian
    /// moments, the others are summed one by one; `false` when a pixel's sum would take more
    /// than [`EXACT_TERMS_MAX`] terms.
    fn exact_row_moments(
        &self,
        constants: &PixelConstants,
        pixels: &[PixelInputs],
        mean: &mut [f64],
        var: &mut [f64],
    ) -> bool {
        let k = self.k;
        let g = self.nonlinearity_dn();
        let dark = DarkLookup::new(self, constants);
        let (smooth_sd, dither_dn, row_var) = (dark.noise.smooth_sd, dark.noise.dither_dn, dark.row_var);
        // Without a nonlinearity, rounding that is smooth at one Poisson mean is smooth at
        // every larger one (the lattice's terms fall, the variance grows): the smallest mean
        // shown smooth so far spares the larger ones the test.
        let mut smooth_from_e = f64::INFINITY;
        let mut rounding_is_smooth = |lambda_e: f64, slope: f64, var_dn2: f64| {
            if g.is_identity() && lambda_e >= smooth_from_e {
                return true;
            }
            let smooth = self.rounding_is_smooth(lambda_e, slope, var_dn2, dither_dn);
            if smooth && g.is_identity() {
                smooth_from_e = lambda_e;
            }
            smooth
        };
        for (i, px) in pixels.iter().enumerate() {
            let base = k * px.dsnu_e + px.offset_dn;
            if px.dark_only
                && (g.is_identity() || g.bend(base + dark.reach_dn).abs() < ROUNDING_BIAS_MAX_DN)
                && let Some(m) = dark.moments(base)
            {
                (mean[i], var[i]) = m;
                continue;
            }
            let (low, high) = (mean[i] + 0.5, self.max + 0.5 - mean[i]);
            let reach2 = 64.0 * (var[i] - 1.0 / 12.0 + row_var);
            let slope = g.slope(k * (px.lambda_e + px.dsnu_e));
            let smooth = low > 0.0
                && high > 0.0
                && low * low > reach2
                && high * high > reach2
                && rounding_is_smooth(px.lambda_e, slope, var[i] - 1.0 / 12.0);
            if smooth {
                continue;
            }
            // Against the ADC's top with a large count: the censored Edgeworth moments (of a
            // Gaussian: not under a dither).
            if row_var == 0.0
                && dither_dn == 0.0
                && px.lambda_e >= TOP_CLIP_MIN_E
                && low > 0.0
                && low * low > reach2
                && rounding_is_smooth(px.lambda_e, slope, var[i] - 1.0 / 12.0)
            {
                let x = k * (px.lambda_e + px.dsnu_e);
                let v = k * k * (px.lambda_e + self.pre_sd * self.pre_sd);
                let (slope, curvature) = (g.slope(x), g.curvature(x));
                // Third cumulant of g(k N + read noise): the Poisson's through the slope, and
                // the skew the curvature gives a Gaussian (delta method).
                let k3 = slope.powi(3) * k.powi(3) * px.lambda_e + 3.0 * slope * slope * curvature * v * v;
                (mean[i], var[i]) = top_clipped_moments(mean[i], var[i] - 1.0 / 12.0, k3, self.max);
                continue;
            }
            if SumPlan::new(px.lambda_e, k, smooth_sd, dither_dn).terms() > EXACT_TERMS_MAX {
                return false;
            }
            let pixel = RoundedPixel {
                lambda_e: px.lambda_e,
                k,
                dsnu_e: px.dsnu_e,
                offset_dn: px.offset_dn,
                nonlinearity: g,
                dither_dn,
            };
            (mean[i], var[i]) = rounded_moments(&pixel, smooth_sd, 0.0, self.max);
        }
        true
    }

    /// The final conversion of one value of [`FrameSimulator::row`] to the `u16` of
    /// [`SensorModel::simulate_with`]: rounded (when quantization is off) and clipped to the ADC
    /// range.
    #[inline]
    #[must_use]
    pub fn to_u16(&self, y: f64) -> u16 {
        // Already whole numbers when quantization is on: no second rounding.
        let y = if self.model.effects.quantization.enabled { y } else { round_exact(y) };
        y.clamp(0.0, self.max) as u16
    }
}

/// Largest rounding bias of a pixel's mean, DN, for which [`FrameSimulator::row_moments`]
/// describes a pixel by its two moments: a seventh of the sampling error of the mean of a
/// 640x480 pair at 0.6 DN of noise.
pub const ROUNDING_BIAS_MAX_DN: f64 = 1e-4;

/// Largest error of `V + 1/12` as the variance of a rounded pixel, relative to `V`, for which
/// [`FrameSimulator::row_moments`] describes a pixel by its two moments: a tenth of the
/// sampling error of the temporal variance of a 640x480 pair.
pub const ROUNDING_VAR_ERROR_MAX: f64 = 2.5e-4;

/// Bounds on what rounding to whole DN does to the moments of `round(y)` beyond `E y` and
/// `Var y + 1/12` (Sheppard).
struct RoundingErrors {
    mean_dn: f64,
    var_dn2: f64,
}

/// [`RoundingErrors`] for `y = s N + (Gaussian of variance smooth_var) + (uniform of width
/// dither)`, `N` Poisson of mean `lambda` (lattice step `s` DN), of total variance `var`. With
/// `phi` the characteristic function of `y` and `p_j = |phi(2 pi j)|`, the sawtooth
/// `round(y) - y = sum_j (-1)^j sin(2 pi j y) / (pi j)` gives a mean error of at most
/// `sum_j p_j / (pi j)`, and its square `1/12 + sum_j (-1)^j cos(2 pi j y) / (pi j)^2` and its
/// covariance with `y` (Stein's identity, Poisson summation of the density at the
/// half-integers) a variance error of at most `sum_j p_j / (pi j)^2 + 4 var sum_j p_j`. Summed
/// until the Gaussian factor is below 1e-12; infinite when that takes more than 256 terms (a
/// noise so fine that nothing can be shown).
fn rounding_error_bounds(lambda: f64, s: f64, smooth_var: f64, dither: f64, var: f64) -> RoundingErrors {
    let (pi, two_pi) = (std::f64::consts::PI, std::f64::consts::TAU);
    let (mut s0, mut s1, mut s2) = (0.0, 0.0, 0.0);
    for j in 1..=256 {
        let jf = f64::from(j);
        let t = two_pi * jf;
        let gauss = (-0.5 * t * t * smooth_var).exp();
        let lattice = (-lambda * (1.0 - (s * t).cos())).exp();
        let uniform = if dither > 0.0 { ((pi * jf * dither).sin() / (pi * jf * dither)).abs() } else { 1.0 };
        let p = gauss * lattice * uniform;
        s0 += p;
        s1 += p / (pi * jf);
        s2 += p / (pi * jf * pi * jf);
        if gauss < 1e-12 {
            return RoundingErrors { mean_dn: s1, var_dn2: s2 + 4.0 * var * s0 };
        }
    }
    RoundingErrors { mean_dn: f64::INFINITY, var_dn2: f64::INFINITY }
}

/// Most terms of the exact sum of a pixel's rounded moments (one term is an `erfc`, about the cost of
/// drawing a pixel once): a pixel whose sum would take more (a bright pixel against the ADC's
/// top or on a coarse Poisson lattice, with hundreds of counts in reach) is not described by
/// [`FrameSimulator::row_moments`].
pub const EXACT_TERMS_MAX: usize = 64;

/// A pixel's output before rounding, `y = g(k (N + dsnu)) + offset + noise`, `N` Poisson of
/// mean `lambda_e`, through the nonlinearity `g` ([`rounded_moments`]).
struct RoundedPixel {
    lambda_e: f64,
    k: f64,
    dsnu_e: f64,
    offset_dn: f64,
    nonlinearity: DnPolynomial,
    /// Width of the uniform dither added before rounding, DN (0: none).
    dither_dn: f64,
}

impl RoundedPixel {
    /// A dark pixel of `noise` at level 0 DN.
    fn dark(noise: DarkNoise) -> RoundedPixel {
        let nonlinearity = DnPolynomial::default();
        RoundedPixel {
            lambda_e: noise.lambda_e,
            k: noise.k,
            dsnu_e: 0.0,
            offset_dn: 0.0,
            nonlinearity,
            dither_dn: noise.dither_dn,
        }
    }
}

/// How [`rounded_moments`] sums a pixel: over the Poisson counts `n_lo..=n_hi` with Gaussian
/// noise of `sd` DN each, or, where the lattice of `k` DN per electron is fine against the
/// Gaussian noise and the Poisson skew is lost in it (`k <= sd / 2`, third cumulant `k^3
/// lambda` below 1e-3 `sd^3`), one term at the mean with the shot noise added to `sd`.
struct SumPlan {
    n_lo: u64,
    n_hi: u64,
    sd: f64,
    collapsed: bool,
    /// Width of the dither, DN, which widens each window.
    dither_dn: f64,
}

impl SumPlan {
    fn new(lambda: f64, k: f64, smooth_sd: f64, dither_dn: f64) -> SumPlan {
        let sd = (smooth_sd * smooth_sd + k * k * lambda.max(0.0)).sqrt();
        if lambda > 0.0 && k <= 0.5 * smooth_sd && k * k * k * lambda <= 1e-3 * sd * sd * sd {
            return SumPlan { n_lo: 0, n_hi: 0, sd, collapsed: true, dither_dn };
        }
        let (n_lo, n_hi) = poisson_range(lambda);
        SumPlan { n_lo, n_hi, sd: smooth_sd, collapsed: false, dither_dn }
    }

    /// Terms of the sum, at most (before clipping narrows the windows).
    fn terms(&self) -> usize {
        let spread = 16.0 * self.sd + self.dither_dn;
        let window = if spread > 0.0 { spread.ceil() as usize + 2 } else { 1 };
        (self.n_hi - self.n_lo + 1) as usize * window
    }
}

/// The Poisson counts worth summing for mean `lambda`: all but about 1e-12 of the mass (the
/// upper end by walking the probabilities where the mean is small, eight deviations beyond it
/// otherwise).
fn poisson_range(lambda: f64) -> (u64, u64) {
    if lambda <= 0.0 {
        return (0, 0);
    }
    let spread = 8.0 * lambda.sqrt();
    let lo = (lambda - spread - 1.0).max(0.0).floor() as u64;
    if lambda > 30.0 {
        return (lo, (lambda + spread + 8.0).ceil() as u64);
    }
    let (mut p, mut cdf, mut n) = ((-lambda).exp(), (-lambda).exp(), 0u64);
    while 1.0 - cdf > 1e-12 && n < 200 {
        n += 1;
        p *= lambda / n as f64;
        cdf += p;
    }
    (lo, n)
}

/// Mean and variance of `clamp(round(y), lo, hi)` for the pixel `px` with Gaussian noise of
/// standard deviation `smooth_sd` DN (read noise through the gain, post-gain noise), summed
/// exactly over the Poisson counts and the output values within eight deviations of each
/// ([`SumPlan`], whose `terms` bound the cost).
fn rounded_moments(px: &RoundedPixel, smooth_sd: f64, lo: f64, hi: f64) -> (f64, f64) {
    let plan = SumPlan::new(px.lambda_e, px.k, smooth_sd, px.dither_dn);
    let (n_lo, n_hi, smooth_sd) = (plan.n_lo, plan.n_hi, plan.sd);
    let level = |n: f64| {
        let x = px.k * (n + px.dsnu_e);
        px.nonlinearity.apply(x) + px.offset_dn
    };
    let centre = round_exact(level(px.lambda_e));
    let dither = px.dither_dn;
    let cdf = |x: f64, mu: f64| {
        if dither > 0.0 { dithered_cdf(x - mu, smooth_sd, dither) } else { normal_cdf((x - mu) / smooth_sd) }
    };
    let mut p = if plan.collapsed {
        1.0
    } else if px.lambda_e > 0.0 {
        (-px.lambda_e + n_lo as f64 * px.lambda_e.ln() - ln_factorial(n_lo as f64)).exp()
    } else {
        1.0
    };
    let (mut s1, mut s2) = (0.0, 0.0);
    for n in n_lo..=n_hi {
        let mu = level(if plan.collapsed { px.lambda_e } else { n as f64 });
        if smooth_sd > 0.0 || dither > 0.0 {
            let m_lo = (mu - 8.0 * smooth_sd - 0.5 * dither).floor().clamp(lo, hi);
            let m_hi = (mu + 8.0 * smooth_sd + 0.5 * dither).ceil().clamp(lo, hi);
            // The lowest value takes all the mass below it, the highest all above it.
            let mut below = 0.0;
            let mut m = m_lo;
            while m <= m_hi {
                let upto = if m >= m_hi { 1.0 } else { cdf(m + 0.5, mu) };
                let (d, w) = (m - centre, p * (upto - below));
                s1 += w * d;
                s2 += w * d * d;
                below = upto;
                m += 1.0;
            }
        } else {
            let d = round_exact(mu).clamp(lo, hi) - centre;
            s1 += p * d;
            s2 += p * d * d;
        }
        p *= px.lambda_e / (n + 1) as f64;
    }
    (centre + s1, s2 - s1 * s1)
}

/// The exact moments of a frame's dark pixels from their level alone, for
/// [`FrameSimulator::row_moments`]: they share their Poisson mean and noise, so one
/// [`RoundingTable`] serves those clear of the clips and one [`ClipTable`] those near 0 DN,
/// each built on first use (or found in the cache) whichever row comes first.
struct DarkLookup<'s, 'a> {
    sim: &'s FrameSimulator<'a>,
    constants: &'s PixelConstants,
    noise: DarkNoise,
    /// How far a dark pixel's output reaches from its level, DN: its Poisson counts and eight
    /// deviations of the Gaussian noise and the row offset.
    reach_dn: f64,
    row_var: f64,
}

impl<'s, 'a> DarkLookup<'s, 'a> {
    fn new(sim: &'s FrameSimulator<'a>, constants: &'s PixelConstants) -> Self {
        let k = sim.k;
        let smooth_sd = (k * k * sim.pre_sd * sim.pre_sd + sim.post_sd * sim.post_sd).sqrt();
        let row_var = sim.row_sd * sim.row_sd;
        let q = sim.model.effects.quantization;
        let dither_dn = if q.enabled { q.dither_dn } else { 0.0 };
        let reach_dn = k * poisson_range(sim.dark_mean).1 as f64
            + 8.0 * (smooth_sd * smooth_sd + row_var).sqrt()
            + 0.5 * dither_dn;
        let noise = DarkNoise { lambda_e: sim.dark_mean, k, smooth_sd, max: sim.max, dither_dn };
        DarkLookup { sim, constants, noise, reach_dn, row_var }
    }

    /// Mean and variance of the rounded, clipped output of a dark pixel at level `base` DN
    /// (straight: the caller sees to the nonlinearity); `None` near the ADC's top, near 0 DN
    /// under a row offset (which moves the clip row by row), and where the noise is too fine
    /// to tabulate.
    fn moments(&self, base: f64) -> Option<(f64, f64)> {
        let (sim, reach, max) = (self.sim, self.reach_dn, self.noise.max);
        if base + reach >= max - 0.5 {
            return None;
        }
        if base - reach > 0.5 {
            let table = sim.dark_table.get_or_init(|| RoundingTable::cached(self.noise));
            return table.as_deref().map(|t| t.moments(base));
        }
        if self.row_var != 0.0 {
            return None;
        }
        if base + reach < -0.5 {
            return Some((0.0, 0.0));
        }
        let table = sim.clip_table.get_or_init(|| {
            let k = self.noise.k;
            let [dsnu_lo, dsnu_hi] = self.constants.dsnu_range_e;
            let [offset_lo, offset_hi] = self.constants.offset_range_dn;
            // Only the levels whose outputs reach 0 DN: those below always read 0 DN.
            let lo = (k * dsnu_lo + offset_lo).max(-0.5 - reach);
            let hi = (k * dsnu_hi + offset_hi).min(0.5 + reach);
            ClipTable::cached(self.noise, [lo, hi])
        });
        table.as_deref().map(|t| t.moments(base))
    }
}

/// Poisson means, electrons, from which a pixel against the ADC's top takes
/// [`top_clipped_moments`]: its skewness `1 / sqrt(lambda)` is then at most 0.03, and the
/// terms the first Edgeworth correction leaves out (of order its square) stay below 1e-3 of
/// the noise in the clipped mean.
const TOP_CLIP_MIN_E: f64 = 1000.0;

/// Deviations below the ADC's top beyond which [`top_clipped_moments`] keeps the Gaussian
/// moments: the clipped mass, 4e-11, moves them by less than 1e-9 of the noise.
const TOP_CLIP_FAR_SD: f64 = 6.5;

/// Mean and variance of `min(round(y), max)` for an output `y` of mean `mean_dn`, variance
/// `var_dn2` and third cumulant `k3_dn3` whose noise is smooth against rounding and far from
/// 0 DN: `y` as a Gaussian with its first Edgeworth term (density `phi(z) (1 + g He3(z) / 6)`,
/// `g` the skewness), whose truncated moments are closed forms (`int_-inf^a He_n phi =
/// -He_(n-1)(a) phi(a)`); the values below `max - 1/2` round over whole bins, so they keep
/// their mean and add `1/12` to their variance, and the rest read `max`. Summing the Poisson
/// counts instead would take thousands of terms per pixel at these means.
fn top_clipped_moments(mean_dn: f64, var_dn2: f64, k3_dn3: f64, max: f64) -> (f64, f64) {
    let sd = var_dn2.sqrt();
    let a = (max - 0.5 - mean_dn) / sd;
    if a > TOP_CLIP_FAR_SD {
        return (mean_dn, var_dn2 + 1.0 / 12.0);
    }
    let s = k3_dn3 / (var_dn2 * sd) / 6.0;
    let (pdf, cdf) = (normal_pdf(a), normal_cdf(a));
    // Below the clip: its mass, and the first two moments of z = (y - mean) / sd there.
    let below = cdf - s * (a * a - 1.0) * pdf;
    let m1 = -pdf - s * a * a * a * pdf;
    let m2 = cdf - a * pdf - s * (a.powi(4) + a * a + 2.0) * pdf;
    let top = max - mean_dn;
    let e1 = sd * m1 + top * (1.0 - below);
    let e2 = var_dn2 * m2 + below / 12.0 + top * top * (1.0 - below);
    (mean_dn + e1, (e2 - e1 * e1).max(0.0))
}

/// The standard normal distribution function (libm's erfc, exact to rounding: the moments
/// these serve are compared at 1e-5 DN, beyond `scene_gen_core::stats::normal_tail`'s fit).
fn normal_cdf(z: f64) -> f64 {
    0.5 * libm::erfc(-z / std::f64::consts::SQRT_2)
}

/// The standard normal density.
fn normal_pdf(z: f64) -> f64 {
    (-0.5 * z * z).exp() / std::f64::consts::TAU.sqrt()
}

/// `P(sd Z + dither U < t)`, `Z` standard normal and `U` uniform on `[-1/2, 1/2]`: the mean of
/// the normal distribution function over the dither, `(sd / dither) [Psi((t + dither/2) / sd) -
/// Psi((t - dither/2) / sd)]` with `Psi(z) = z Phi(z) + phi(z)` its antiderivative (the uniform
/// alone where `sd` is 0).
fn dithered_cdf(t: f64, sd: f64, dither: f64) -> f64 {
    if sd <= 0.0 {
        return (t / dither + 0.5).clamp(0.0, 1.0);
    }
    let psi = |z: f64| z * normal_cdf(z) + normal_pdf(z);
    (sd / dither * (psi((t + 0.5 * dither) / sd) - psi((t - 0.5 * dither) / sd))).clamp(0.0, 1.0)
}

/// Nodes of a [`RoundingTable`] over one DN.
const ROUNDING_TABLE_NODES: usize = 256;

/// Noise below this, DN, is too fine for a [`RoundingTable`]'s linear interpolation (the mean
/// of a rounded pixel then steps within a few nodes: at 0.1 DN its error reaches 1e-4 DN);
/// such pixels are summed one by one.
const ROUNDING_TABLE_MIN_SD: f64 = 0.1;

/// The rounded moments of a dark pixel as functions of its fractional offset: away from the
/// clips, `E round(y + f + m) = m + E round(y + f)` for whole `m`, so one table over `f` in
/// [0, 1) serves every dark pixel of a frame, whatever its DSNU, column offset or pattern.
#[derive(Debug, Clone)]
struct RoundingTable {
    /// `(E round(y + f) - f, Var round(y + f))` at `f = j / NODES`, `j = 0..=NODES`.
    nodes: Vec<(f64, f64)>,
}

impl RoundingTable {
    /// The table of `noise` from the cache of recent ones ([`table_cache`]), built on a miss.
    fn cached(noise: DarkNoise) -> Option<Arc<RoundingTable>> {
        static CACHE: TableCache<RoundingTable> = Mutex::new(Vec::new());
        table_cache(&CACHE, noise, |_| true, || RoundingTable::new(noise))
    }

    fn new(noise: DarkNoise) -> Option<RoundingTable> {
        let smooth_sd = noise.smooth_sd;
        if smooth_sd < ROUNDING_TABLE_MIN_SD {
            return None;
        }
        let nodes = (0..=ROUNDING_TABLE_NODES)
            .map(|j| {
                let f = j as f64 / ROUNDING_TABLE_NODES as f64;
                let px = RoundedPixel { offset_dn: f, ..RoundedPixel::dark(noise) };
                let (m, v) = rounded_moments(&px, smooth_sd, f64::NEG_INFINITY, f64::INFINITY);
                (m - f, v)
            })
            .collect();
        Some(RoundingTable { nodes })
    }

    /// Mean and variance of the rounded output of a dark pixel whose noise-free level is `base`
    /// DN (without the dark signal).
    fn moments(&self, base: f64) -> (f64, f64) {
        let whole = floor_exact(base);
        let x = (base - whole) * ROUNDING_TABLE_NODES as f64;
        let j = (x as usize).min(ROUNDING_TABLE_NODES - 1);
        let t = x - j as f64;
        let (a, b) = (self.nodes[j], self.nodes[j + 1]);
        (base + a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
    }
}

/// What the rounded moments of a frame's dark pixels depend on, beside their level: their
/// Poisson mean, electrons, the system gain, DN per electron, the Gaussian noise, DN, the
/// ADC's top, DN, and the width of the dither, DN.
#[derive(Debug, Clone, Copy, PartialEq)]
struct DarkNoise {
    lambda_e: f64,
    k: f64,
    smooth_sd: f64,
    max: f64,
    dither_dn: f64,
}

/// Recent tables and the noise each was built for.
type TableCache<T> = Mutex<Vec<(DarkNoise, Arc<T>)>>;

/// Tables kept by [`table_cache`]: one per dark exposure of a set of a few dozen, for the last
/// few models.
const TABLE_CACHE_LEN: usize = 128;

/// The table of `noise` for which `covers` holds, from `cache`, else `build`'s (kept). A
/// search simulates the same dark frames for many models that leave the dark noise as it was
/// (a screening window, a replicate, a candidate effect that touches lit pixels only), and
/// building a table costs tens of thousands of `erfc`s, about as much as drawing the frame.
/// A table is a function of its key, so the cache never changes a value.
fn table_cache<T>(
    cache: &TableCache<T>,
    noise: DarkNoise,
    covers: impl Fn(&T) -> bool,
    build: impl FnOnce() -> Option<T>,
) -> Option<Arc<T>> {
    let lock = || cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some((_, t)) = lock().iter().find(|(key, t)| *key == noise && covers(t)) {
        return Some(Arc::clone(t));
    }
    let table = Arc::new(build()?);
    let mut cache = lock();
    cache.insert(0, (noise, Arc::clone(&table)));
    cache.truncate(TABLE_CACHE_LEN);
    Some(table)
}

/// The rounded moments of a dark pixel whose output reaches 0 DN, as functions of its
/// noise-free level `base` (DSNU, black level, column offset and pattern, DN): near the clip
/// they are no longer periodic in `base`, so [`RoundingTable`]'s one DN does not serve, but
/// every dark pixel of a frame still shares its Poisson mean and noise, so one table over the
/// levels its pixels take does. Node `i` sits at `i / density` DN, `density` chosen from the
/// curvature of the moments so that linear interpolation errs by less than
/// [`CLIP_TABLE_ERROR_DN`].
#[derive(Debug, Clone)]
struct ClipTable {
    /// Index of the first node.
    first: i64,
    /// Nodes per DN.
    density: f64,
    /// `(E y, Var y)` of the clipped, rounded output at each node.
    nodes: Vec<(f64, f64)>,
}

/// Interpolation error a [`ClipTable`] is built for, DN (a fiftieth of the sampling error of
/// the mean of a 640x480 dark pair).
const CLIP_TABLE_ERROR_DN: f64 = 2e-5;

impl ClipTable {
    /// The table of `noise` over at least `[lo, hi]` DN from the cache of recent ones
    /// ([`table_cache`]), built on a miss; `None` when the noise is too fine to tabulate or
    /// the range is empty. Nodes sit at whole multiples of their spacing, so every table of
    /// one noise holds the same values at the nodes it has.
    fn cached(noise: DarkNoise, [lo, hi]: [f64; 2]) -> Option<Arc<ClipTable>> {
        static CACHE: TableCache<ClipTable> = Mutex::new(Vec::new());
        if noise.smooth_sd < ROUNDING_TABLE_MIN_SD || lo.partial_cmp(&hi).is_none_or(std::cmp::Ordering::is_gt) {
            return None;
        }
        let covers = |t: &ClipTable| {
            let [first, last] = ClipTable::span(t.density, [lo, hi]);
            t.first <= first && t.first + t.nodes.len() as i64 > last
        };
        table_cache(&CACHE, noise, covers, || Some(ClipTable::new(noise, [lo, hi])))
    }

    /// Nodes per DN for `noise`: interpolation errs by `h^2 / 8` times the moments' curvature,
    /// which is at most rounding's first harmonic, `4 pi exp(-2 pi^2 sd^2)`, plus the clip's,
    /// twice the noise's peak density and one (the variance's).
    fn density(noise: DarkNoise) -> f64 {
        let sd = (noise.smooth_sd.powi(2) + noise.k * noise.k * noise.lambda_e.max(0.0)).sqrt();
        let pi = std::f64::consts::PI;
        let curvature = 4.0 * pi * (-2.0 * pi * pi * sd * sd).exp() + 2.0 / (sd * std::f64::consts::TAU.sqrt()) + 1.0;
        (curvature / (8.0 * CLIP_TABLE_ERROR_DN)).sqrt().ceil().clamp(16.0, 4096.0)
    }

    /// The first and last node indices that bracket `[lo, hi]`.
    fn span(density: f64, [lo, hi]: [f64; 2]) -> [i64; 2] {
        [floor_exact(lo * density) as i64, floor_exact(hi * density) as i64 + 1]
    }

    /// The table over `[lo, hi]` DN for dark pixels of `noise`, clipped to `[0, max]` DN.
    fn new(noise: DarkNoise, range: [f64; 2]) -> ClipTable {
        let (smooth_sd, max) = (noise.smooth_sd, noise.max);
        let density = ClipTable::density(noise);
        let [first, last] = ClipTable::span(density, range);
        let nodes = (first..=last)
            .into_par_iter()
            .map(|i| {
                let base = i as f64 / density;
                let px = RoundedPixel { offset_dn: base, ..RoundedPixel::dark(noise) };
                rounded_moments(&px, smooth_sd, 0.0, max)
            })
            .collect();
        ClipTable { first, density, nodes }
    }

    /// Mean and variance of the clipped, rounded output of a dark pixel at level `base` DN
    /// (levels outside the table take its end).
    fn moments(&self, base: f64) -> (f64, f64) {
        let y = base * self.density;
        let whole = floor_exact(y);
        let last = self.nodes.len() as i64 - 1;
        let (j, t) = match whole as i64 - self.first {
            j if j < 0 => (0, 0.0),
            j if j >= last => (last, 0.0),
            j => (j, y - whole),
        };
        let a = self.nodes[j as usize];
        let b = self.nodes[(j + 1).min(last) as usize];
        (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
    }
}

/// Layers of the ziggurat of [`standard_normal`].
const ZIG_LAYERS: usize = 256;
/// Right edge of the base layer and area of every layer of a 256-layer ziggurat for the
/// unnormalised density `exp(-x^2 / 2)`: G. Marsaglia and W. W. Tsang, "The ziggurat method for
/// generating random variables", Journal of Statistical Software 5(8), 2000 (section 4's
/// 256-box constants `r = 3.6541528853610088`, `v = 0.00492867323399`).
const ZIG_R: f64 = 3.654_152_885_361_009;
const ZIG_V: f64 = 0.004_928_673_233_99;

/// The ziggurat's layer edges `x[i]` (`x[0]` the base layer's pseudo-width `v / f(r)`, `x[1] = r`,
/// decreasing to `x[256] = 0`) and densities `f[i] = exp(-x[i]^2 / 2)`, built once.
struct Ziggurat {
    x: [f64; ZIG_LAYERS + 1],
    f: [f64; ZIG_LAYERS + 1],
}

#[inline]
fn ziggurat() -> &'static Ziggurat {
    static TABLE: OnceLock<Ziggurat> = OnceLock::new();
    TABLE.get_or_init(|| {
        let pdf = |x: f64| (-0.5 * x * x).exp();
        let mut x = [0f64; ZIG_LAYERS + 1];
        x[0] = ZIG_V / pdf(ZIG_R);
        x[1] = ZIG_R;
        for i in 1..ZIG_LAYERS - 1 {
            // Each layer has area v: x[i] (f(x[i+1]) - f(x[i])) = v.
            x[i + 1] = (-2.0 * (ZIG_V / x[i] + pdf(x[i])).ln()).sqrt();
        }
        x[ZIG_LAYERS] = 0.0;
        let mut f = [0f64; ZIG_LAYERS + 1];
        for (fi, xi) in f.iter_mut().zip(&x) {
            *fi = pdf(*xi);
        }
        Ziggurat { x, f }
    })
}

/// A standard normal draw by the ziggurat method (Marsaglia and Tsang 2000, see `ZIG_R`):
/// exact in distribution; about 99 % of draws cost one 64-bit word, a table look-up and a
/// compare (no logarithm, no trigonometry). The noise model's draws use it; [`normal`] stays the
/// Box-Muller sampler for the callers that rely on its stream.
#[inline(always)]
pub fn standard_normal<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    let z = ziggurat();
    loop {
        let bits: u64 = rng.random();
        let i = (bits & 0xff) as usize;
        // 53 high bits: a uniform in (-1, 1) (the centre of each of 2^53 cells, never 0 or +-1).
        let u = 2.0 * (((bits >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)) - 1.0;
        let x = u * z.x[i];
        if x.abs() < z.x[i + 1] {
            return x;
        }
        if i == 0 {
            // The tail beyond r (Marsaglia 1964): x = -ln(u1) / r, y = -ln(u2), accept 2y > x^2.
            loop {
                let a = -(1.0 - rng.random::<f64>()).ln() / ZIG_R;
                let b = -(1.0 - rng.random::<f64>()).ln();
                if 2.0 * b > a * a {
                    return if u < 0.0 { -(ZIG_R + a) } else { ZIG_R + a };
                }
            }
        }
        // The wedge between layers i and i + 1.
        let y = z.f[i] + (z.f[i + 1] - z.f[i]) * rng.random::<f64>();
        if y < (-0.5 * x * x).exp() {
            return x;
        }
    }
}

/// A standard normal draw (Box-Muller, one output per two uniforms: simple and reproducible;
/// the detection code and tests draw their synthetic noise with it).
pub fn normal<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    let u1 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Pixels per block of [`FrameSimulator::row`]'s passes (its scratch arrays live on the stack).
const ROW_BLOCK: usize = 64;

/// Means below this are drawn by inversion, the others by PTRS ([`poisson`]).
const POISSON_INVERSION_MAX: f64 = 10.0;

/// [`poisson_inversion`] stops here: the mass above is below 1e-24 for means under 10, and
/// the cumulative sum, rounded, may stop short of a uniform just below 1.
const POISSON_INVERSION_MAX_K: f64 = 60.0;

/// A Poisson draw with mean `lambda` (0 for lambda <= 0).
///
/// Small means: inversion of the distribution function with one uniform (L. Devroye,
/// "Non-Uniform Random Variate Generation", Springer 1986, X.3.2). Means of 10 and above: the
/// transformed rejection method PTRS of W. Hoermann, "The transformed rejection method for
/// generating Poisson random variables", Insurance: Mathematics and Economics 12 (1993).
#[inline(always)]
pub fn poisson<R: Rng + ?Sized>(rng: &mut R, lambda: f64) -> f64 {
    let exp_neg = if lambda < POISSON_INVERSION_MAX { (-lambda).exp() } else { 0.0 };
    poisson_with(rng, lambda, &Ptrs::new(lambda), exp_neg)
}

/// [`poisson`] with PTRS's constants (`ptrs = Ptrs::new(lambda)`; not read when `lambda` is
/// below 10) and inversion's `exp_neg = exp(-lambda)` (read only below 10) computed
/// beforehand, so that a caller can compute them for many means in a loop without draws: the
/// same draws and values as [`poisson`].
#[inline(always)]
fn poisson_with<R: Rng + ?Sized>(rng: &mut R, lambda: f64, ptrs: &Ptrs, exp_neg: f64) -> f64 {
    if lambda.is_nan() || lambda <= 0.0 {
        return 0.0;
    }
    if lambda < POISSON_INVERSION_MAX {
        return poisson_inversion(rng, lambda, exp_neg);
    }
    ptrs_draw(rng, lambda, ptrs)
}

/// The constants of PTRS (Hoermann 1993, see [`poisson`]) for one mean: `a`, `b`, the squeeze
/// limit `vr`, and `2 a`. They depend on the mean alone, not on the draws.
#[derive(Debug, Clone, Copy, Default)]
struct Ptrs {
    two_a: f64,
    a: f64,
    b: f64,
    vr: f64,
}

impl Ptrs {
    #[inline(always)]
    fn new(lambda: f64) -> Ptrs {
        let slam = lambda.sqrt();
        let b = 0.931 + 2.53 * slam;
        let a = -0.059 + 0.02483 * b;
        let vr = 0.9277 - 3.6224 / (b - 2.0);
        // Exact (a doubling), so `two_a / us` is bit for bit Hoermann's `2 a / us`.
        Ptrs { two_a: 2.0 * a, a, b, vr }
    }
}

/// 2^-32: the grid of PTRS's uniforms `u` and `v`, which [`ptrs_draw`] takes from the two
/// halves of one 64-bit word (53-bit floats took a word each).
///
/// PTRS returns `k` for the points `(u, v)` under its acceptance curve in the strip of `u` that
/// maps to `k`. On the grid a strip holds a column more or less, and each column's accepted
/// height is rounded to half a cell. Bounded strip by strip for means from 10 to 10^5 (edges by
/// bisection, every `k` within 12 sd): within 4 sd of the mean P(k) moves by a relative 2e-7 at
/// mean 10, 2e-6 at 10^3 and 2e-5 at 10^5, and a chi-square test on any one count would need at
/// least 3e13 draws (ten million 1936 x 1216 frames) to see the change.
const PTRS_HALF_WORD: f64 = 1.0 / 4_294_967_296.0;

/// PTRS's rejection loop for `lambda >= 10` with its constants `ptrs`.
#[inline(always)]
fn ptrs_draw<R: Rng + ?Sized>(rng: &mut R, lambda: f64, ptrs: &Ptrs) -> f64 {
    let Ptrs { two_a, a, b, vr } = *ptrs;
    loop {
        // Hoermann's two uniforms from one 64-bit word, 32 bits each, at the centres of the
        // cells of a 2^-32 grid: u in (-0.5, 0.5), symmetric, and v in (0, 1) (exact: products
        // of a 32-bit integer and a power of two, sums on a 2^-33 grid). See `PTRS_HALF_WORD`.
        let bits = rng.next_u64();
        let u = (bits >> 32) as f64 * PTRS_HALF_WORD + (0.5 * PTRS_HALF_WORD - 0.5);
        let v = (bits & 0xffff_ffff) as f64 * PTRS_HALF_WORD + 0.5 * PTRS_HALF_WORD;
        let us = 0.5 - u.abs();
        let k = floor_exact((two_a / us + b) * u + lambda + 0.43);
        if us >= 0.07 && v <= vr {
            return k;
        }
        if k < 0.0 || (us < 0.013 && v > us) {
            continue;
        }
        if ptrs_accepts(lambda, k, us, v, a, b) {
            return k;
        }
    }
}

/// PTRS's exact acceptance test, for the draws its squeeze leaves (three in five at a mean of
/// 10, three in ten at 100, one in five at 10^4): Hoermann's `ln v + ln(1/alpha) - ln(a/us^2 +
/// b) <= -lambda + k ln lambda - ln k!`, the left side as one logarithm.
///
/// Not inlined on purpose: inlined into [`ptrs_draw`], the compiler hoisted `lambda.ln()` and
/// `1/alpha` (invariant in the rejection loop) above the loop, so that every draw paid for a
/// logarithm and a division that the squeeze makes unnecessary for most of them.
#[inline(never)]
fn ptrs_accepts(lambda: f64, k: f64, us: f64, v: f64, a: f64, b: f64) -> bool {
    let inv_alpha = 1.1239 + 1.1328 / (b - 3.4);
    (v * inv_alpha / (a / (us * us) + b)).ln() <= -lambda + k * lambda.ln() - ln_factorial(k)
}

/// A Poisson draw for a small mean (below 10) by sequential inversion: the smallest `k` whose
/// cumulative probability `P(X <= k)` reaches one uniform, the masses from `p_0 = exp(-lambda)`
/// by `p_k = p_(k-1) lambda / k`. One uniform per draw, where multiplying uniforms until their
/// product drops below `exp(-lambda)` (Knuth) takes `k + 1`. `exp_neg` is `exp(-lambda)`.
#[inline(always)]
fn poisson_inversion<R: Rng + ?Sized>(rng: &mut R, lambda: f64, exp_neg: f64) -> f64 {
    let u = rng.random::<f64>();
    let mut p = exp_neg;
    let mut cdf = p;
    let mut k = 0.0;
    while u > cdf && k < POISSON_INVERSION_MAX_K {
        k += 1.0;
        p *= lambda / k;
        cdf += p;
    }
    k
}

/// Below this, ln(k!) is the exact sum of logarithms, above Stirling's series.
const LN_FACTORIAL_EXACT: u32 = 20;
/// ln(k!) is looked up below this (2^14: 128 KiB, every count of a night image and most of a
/// day image; PTRS's exact test needs it for a fifth to three fifths of its draws).
const LN_FACTORIAL_TABLE: usize = 1 << 14;

/// ln(k!) for a non-negative integer k: exact sum below 20, Stirling's series above. Values
/// below [`LN_FACTORIAL_TABLE`] come from a table built once by the same two formulas, so they
/// are bit for bit those of computing at each call.
#[inline]
fn ln_factorial(k: f64) -> f64 {
    static TABLE: OnceLock<Vec<f64>> = OnceLock::new();
    if k < LN_FACTORIAL_TABLE as f64 {
        let table =
            TABLE.get_or_init(|| (0..LN_FACTORIAL_TABLE as u32).map(|k| ln_factorial_direct(f64::from(k))).collect());
        table[k as usize]
    } else {
        ln_factorial_direct(k)
    }
}

/// [`ln_factorial`] computed: the sum of ln 2 .. ln k below 20, Stirling's series above.
fn ln_factorial_direct(k: f64) -> f64 {
    if k < f64::from(LN_FACTORIAL_EXACT) {
        (2..=k as u32).map(|i| f64::from(i).ln()).sum()
    } else {
        let x = k + 1.0;
        (x - 0.5) * x.ln() - x + 0.5 * std::f64::consts::TAU.ln() + 1.0 / (12.0 * x) - 1.0 / (360.0 * x * x * x)
    }
}

/// 2^52: every f64 of at least this magnitude is a whole number.
const TWO_POW_52: f64 = 4_503_599_627_370_496.0;

/// [`f64::round`] (half away from zero), bit for bit, without a library call: on the baseline
/// x86-64 target (no SSE4.1 `roundsd`) `f64::round` is a call into a generic software routine,
/// which cost about a tenth of the sensor stage. `y - trunc(y)` is exact, so the comparison
/// with 0.5 is too (0.49999999999999994 stays 0, which `(y + 0.5).floor()` would get wrong).
#[inline]
#[must_use]
pub fn round_exact(y: f64) -> f64 {
    // False for NaN and infinities, which are returned as they are, like whole numbers.
    if y.abs() < TWO_POW_52 {
        let t = y as i64 as f64;
        let f = y - t;
        // Without branches: the fraction of a noisy value is as likely above 0.5 as below, so a
        // branch would be mispredicted for half the pixels.
        let r = t + f64::from(u8::from(f >= 0.5)) - f64::from(u8::from(f <= -0.5));
        // The sign of zero as `round` gives it (round(-0.3) = -0.0).
        r.copysign(y)
    } else {
        y
    }
}

/// [`f64::floor`], bit for bit, without a library call (see [`round_exact`]).
#[inline]
#[must_use]
pub fn floor_exact(x: f64) -> f64 {
    if x.abs() < TWO_POW_52 {
        let t = x as i64 as f64;
        (if t > x { t - 1.0 } else { t }).copysign(x)
    } else {
        x
    }
}

/// The reference paper's affine noise model on 8-bit values, per colour channel:
/// `var(I) = g sigma_p2 I + g^2 sigma_t2`, with `g = 10^((G - G0)/20) * (A_ref / A)` (linear
/// gain ratio times the pixel-area ratio, docs/REFERENCE.md).
///
/// `sigma_p2` and `sigma_t2` are variance coefficients: the released code (AddNoise.py) adds
/// noise of variance `sigma_p I + sigma_t` although it calls them sigma, so the released numbers
/// are stored here as they are, as variances. Channels are stored R, G, B (the release lists B,
/// G, R).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AffineNoise {
    /// Signal-dependent variance coefficient per channel (R, G, B), DN (8-bit) per DN.
    pub sigma_p2: [f64; 3],
    /// Signal-independent variance per channel (R, G, B), DN^2 (8-bit).
    pub sigma_t2: [f64; 3],
    /// Gain at which the coefficients were calibrated, dB.
    pub g0_db: f64,
    /// Pixel area of the calibrated camera, um^2.
    pub ref_pixel_area_um2: f64,
}

impl Default for AffineNoise {
    fn default() -> Self {
        Self::flir_imx172()
    }
}

impl AffineNoise {
    /// The released FLIR Flea3 (IMX172) coefficients at G0 = 15 dB, reference pixel area 2.4
    /// um^2 (1.55 um pitch). Source: TaCOS AddNoise.py as summarised in docs/REFERENCE.md
    /// (B, G, R: sigma_p = 0.24, 0.12, 0.29; sigma_t = 1.82, 0.91, 3.2).
    #[must_use]
    pub fn flir_imx172() -> Self {
        AffineNoise { sigma_p2: [0.29, 0.12, 0.24], sigma_t2: [3.2, 0.91, 1.82], g0_db: 15.0, ref_pixel_area_um2: 2.4 }
    }

    /// The affine coefficients of a camera measured with EMVA 1288 at its own gain and bit
    /// depth (docs/REFERENCE.md, "Camera and noise"): `sigma_p^2 = K`, `sigma_t^2 = K^2 sigma_d^2 + 1/12`, same for every
    /// channel; values are in the measured camera's DN, not 8-bit.
    #[must_use]
    pub fn from_emva(k_dn_per_e: f64, dark_noise_e: f64, gain_db: f64, pixel_area_um2: f64) -> Self {
        let t = k_dn_per_e * k_dn_per_e * dark_noise_e * dark_noise_e + 1.0 / 12.0;
        AffineNoise { sigma_p2: [k_dn_per_e; 3], sigma_t2: [t; 3], g0_db: gain_db, ref_pixel_area_um2: pixel_area_um2 }
    }

    /// `g` of the paper: linear gain ratio times the reference-to-candidate pixel-area ratio.
    #[must_use]
    pub fn g(&self, gain_db: f64, pixel_area_um2: f64) -> f64 {
        gain_factor(gain_db - self.g0_db) * self.ref_pixel_area_um2 / pixel_area_um2
    }

    /// Noise variance of an 8-bit value `value` in `channel` (0 R, 1 G, 2 B) at factor `g`.
    #[must_use]
    pub fn variance(&self, value: f64, channel: usize, g: f64) -> f64 {
        g * self.sigma_p2[channel] * value + g * g * self.sigma_t2[channel]
    }

    /// Adds the model's noise to an interleaved RGB 8-bit image (`width` pixels per row),
    /// rounding and clipping to 0..255. Row `r` draws from `substream(frame_seed,
    /// "sensor/affine", r)`.
    #[must_use]
    pub fn apply_rgb8(&self, rgb: &[u8], width: usize, gain_db: f64, pixel_area_um2: f64, frame_seed: u64) -> Vec<u8> {
        let g = self.g(gain_db, pixel_area_um2);
        let mut out = rgb.to_vec();
        out.par_chunks_mut((width * 3).max(3)).enumerate().for_each(|(r, row)| {
            let mut rng = rng::substream(frame_seed, "sensor/affine", r as u64);
            for (i, v) in row.iter_mut().enumerate() {
                let x = f64::from(*v);
                let sd = self.variance(x, i % 3, g).max(0.0).sqrt();
                *v = round_exact(x + sd * standard_normal(&mut rng)).clamp(0.0, 255.0) as u8;
            }
        });
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poisson_mean_and_variance_match_lambda() {
        for &lambda in &[0.5, 4.0, 12.0, 250.0, 40_000.0] {
            let mut rng = rng::stream(1, "test");
            let n = 40_000;
            let draws: Vec<f64> = (0..n).map(|_| poisson(&mut rng, lambda)).collect();
            let mean = draws.iter().sum::<f64>() / n as f64;
            let var = draws.iter().map(|d| (d - mean) * (d - mean)).sum::<f64>() / (n - 1) as f64;
            assert!((mean - lambda).abs() < 5.0 * (lambda / n as f64).sqrt() + 1e-9, "lambda {lambda}: mean {mean}");
            assert!((var / lambda - 1.0).abs() < 0.04, "lambda {lambda}: var {var}");
        }
    }

    #[test]
    fn poisson_matches_its_probability_mass() {
        // Inversion (lambda < 10), PTRS (lambda >= 10) and the switch: Pearson chi-square of the
        // counts of every k within 4 sd (the two tails pooled) against the exact mass
        // exp(k ln l - l - ln k!).
        for &lambda in &[0.3f64, 2.5, 7.7, 9.99, 10.0, 37.5, 900.0, 40_000.0] {
            let mut rng = rng::stream(4, "test");
            let n = 200_000;
            let sd: f64 = lambda.sqrt();
            let (lo, hi) = ((lambda - 4.0 * sd).floor().max(0.0) as usize, (lambda + 4.0 * sd).ceil() as usize);
            let mut counts = vec![0usize; hi - lo + 3];
            for _ in 0..n {
                let k = poisson(&mut rng, lambda) as usize;
                counts[if k < lo {
                    0
                } else if k > hi {
                    hi - lo + 2
                } else {
                    k - lo + 1
                }] += 1;
            }
            let pmf = |k: usize| (k as f64 * lambda.ln() - lambda - ln_factorial(k as f64)).exp();
            let inner: Vec<f64> = (lo..=hi).map(pmf).collect();
            let below: f64 = (0..lo).map(pmf).sum();
            let above = 1.0 - below - inner.iter().sum::<f64>();
            let mut chi2 = 0.0;
            let mut bins = 0;
            for (i, &c) in counts.iter().enumerate() {
                let p = if i == 0 {
                    below
                } else if i == counts.len() - 1 {
                    above
                } else {
                    inner[i - 1]
                };
                let e = n as f64 * p;
                if e < 5.0 {
                    continue;
                }
                chi2 += (c as f64 - e).powi(2) / e;
                bins += 1;
            }
            // Mean bins - 1, sd sqrt(2 (bins - 1)): 5 sd of slack.
            let dof = f64::from(bins - 1);
            assert!(chi2 < dof + 5.0 * (2.0 * dof).sqrt(), "lambda {lambda}: chi-square {chi2} over {bins} bins");
        }
    }

    #[test]
    fn normal_has_unit_variance() {
        let mut rng = rng::stream(2, "test");
        let n = 100_000;
        let d: Vec<f64> = (0..n).map(|_| normal(&mut rng)).collect();
        let mean = d.iter().sum::<f64>() / n as f64;
        let var = d.iter().map(|x| x * x).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.02 && (var - 1.0).abs() < 0.02, "mean {mean} var {var}");
    }

    #[test]
    fn ziggurat_layers_close_at_the_top() {
        let z = ziggurat();
        // The last layer's area v must reach the density's peak: f(x255) + v / x255 = 1.
        let top = z.f[ZIG_LAYERS - 1] + ZIG_V / z.x[ZIG_LAYERS - 1];
        assert!((top - 1.0).abs() < 1e-9, "top {top}");
        assert!(z.x.windows(2).skip(1).all(|p| p[0] > p[1]), "edges must decrease");
    }

    #[test]
    fn standard_normal_matches_the_distribution() {
        let mut rng = rng::stream(3, "test");
        let n = 400_000;
        let d: Vec<f64> = (0..n).map(|_| standard_normal(&mut rng)).collect();
        let nf = n as f64;
        let mean = d.iter().sum::<f64>() / nf;
        let var = d.iter().map(|x| x * x).sum::<f64>() / nf;
        let kurt = d.iter().map(|x| x.powi(4)).sum::<f64>() / nf;
        assert!(mean.abs() < 0.01 && (var - 1.0).abs() < 0.01 && (kurt - 3.0).abs() < 0.06, "{mean} {var} {kurt}");
        // Frequencies in bins of 0.25 sigma out to 4 sigma, and the tails beyond (the ziggurat's
        // base-layer tail starts at 3.65): Pearson chi-square against the exact bin masses.
        let cdf = |x: f64| 1.0 - scene_gen_core::stats::normal_tail(x);
        let edges: Vec<f64> = (-16..=16).map(|i| f64::from(i) * 0.25).collect();
        let mut counts = vec![0usize; edges.len() + 1];
        for x in &d {
            counts[edges.partition_point(|e| e <= x)] += 1;
        }
        let mut chi2 = 0.0;
        for (i, &c) in counts.iter().enumerate() {
            let lo = if i == 0 { 0.0 } else { cdf(edges[i - 1]) };
            let hi = if i == edges.len() { 1.0 } else { cdf(edges[i]) };
            let e = nf * (hi - lo);
            chi2 += (c as f64 - e).powi(2) / e;
        }
        // 33 degrees of freedom: the 99.9 % point is about 63.9.
        assert!(chi2 < 63.9, "chi-square {chi2} over {} bins", counts.len());
        let beyond = d.iter().filter(|x| x.abs() > 3.7).count() as f64;
        let expect = nf * 2.0 * scene_gen_core::stats::normal_tail(3.7);
        assert!((beyond - expect).abs() < 5.0 * expect.sqrt(), "beyond 3.7: {beyond}, expected {expect}");
    }

    /// A 12-bit (or 8-bit) camera with the effects `row_moments` must follow.
    fn moment_test_model(bits: u32, k: f64, read_noise_e: f64, black_dn: f64, nonlinear: bool) -> SensorModel {
        moment_test_model_dark(bits, k, read_noise_e, black_dn, nonlinear, 30.0)
    }

    /// [`moment_test_model`] with its dark current (e-/s); hot pixels only where it is not 0.
    fn moment_test_model_dark(
        bits: u32,
        k: f64,
        read_noise_e: f64,
        black_dn: f64,
        nonlinear: bool,
        dark_e_per_s: f64,
    ) -> SensorModel {
        // DSNU of several DN at the lowest gain, so the row's pixels sit at every fraction of
        // a DN and rounding shows.
        let dsnu_e = 0.8 / k;
        SensorModel {
            name: "moments".into(),
            quantum_efficiency: 0.6,
            system_gain_dn_per_e: k,
            read_noise_e,
            adc_bits: bits,
            pattern_seed: 5,
            effects: Effects {
                black_level: BlackLevel { enabled: black_dn > 0.0, offset_dn: black_dn },
                dark_current: DarkCurrent { enabled: true, rate_e_per_s: dark_e_per_s },
                quantization: Quantization { enabled: true, dither_dn: 0.0 },
                nonlinearity: Nonlinearity { enabled: nonlinear, a1: -0.02, a2: 0.015, a3: -0.03 },
                dsnu: Dsnu { enabled: true, std_e: dsnu_e },
                prnu: Prnu { enabled: true, std_fraction: 0.01 },
                hot_pixels: HotPixels {
                    enabled: dark_e_per_s > 0.0,
                    fraction: 0.01,
                    max_excess_e_per_s: 2000.0,
                    ..HotPixels::default()
                },
                ..Effects::default()
            },
        }
    }

    #[test]
    fn row_moments_match_the_pixels_they_describe() {
        // Each case: the row's predicted mean and variance per pixel against 4000 frames of the
        // same row drawn pixel by pixel, pooled over the row, within sampling error, in each
        // regime the moments cover: smooth noise (Gaussian moments), dark
        // pixels finely rounded (the table), dark pixels clipped at 0 DN (the clip table, with
        // and without dark current: an 8-bit camera whose dark frames sit a DN or two above 0;
        // under a dither one DN wide, as the EMVA 1288 reference simulator adds);
        // and rows against the ADC's top, straight and bent (the censored Edgeworth moments);
        // not described: the same clipped dark pixels under a row offset (which moves the clip
        // row by row) with more counts in reach than a pixel's sum takes, and a row at the
        // full well.
        let (w, h, frames) = (64, 4, 4000);
        let mut row_noise = moment_test_model(12, 0.08, 4.0, 0.0, false);
        row_noise.effects.row_column_noise = RowColumnNoise { enabled: true, row_std_dn: 0.3, column_std_dn: 0.0 };
        let dithered = |mut m: SensorModel| {
            m.effects.quantization.dither_dn = 1.0;
            m
        };
        let mut full_well = moment_test_model(12, 0.1, 6.0, 60.0, false);
        full_well.effects.saturation = Saturation { enabled: true, full_well_e: 40_000.0 };
        // (model, photons, expected to be described)
        let cases = [
            (moment_test_model(12, 0.1, 6.0, 60.0, true), 20_000.0f32, true),
            (moment_test_model(12, 0.1, 4.0, 60.0, false), 0.0, true),
            (moment_test_model(8, 0.02, 15.0, 8.0, false), 0.0, true),
            (moment_test_model_dark(12, 0.08, 4.0, 0.0, false, 0.0), 0.0, true),
            (moment_test_model_dark(12, 0.08, 4.0, 0.0, false, 30.0), 0.0, true),
            (moment_test_model_dark(8, 0.1, 4.3, 1.6, false, 400.0), 0.0, true),
            (dithered(moment_test_model_dark(8, 0.1, 4.3, 1.6, false, 400.0)), 0.0, true),
            (dithered(moment_test_model_dark(8, 0.05, 2.0, 0.0, false, 0.0)), 0.0, true),
            (dithered(moment_test_model_dark(8, 0.02, 5.0, 8.0, false, 0.0)), 0.0, true),
            (moment_test_model(12, 0.1, 6.0, 60.0, false), 67_000.0, true),
            (moment_test_model(12, 0.1, 6.0, 60.0, false), 68_500.0, true),
            (moment_test_model(12, 0.1, 6.0, 60.0, true), 70_000.0, true),
            (row_noise, 0.0, false),
            (full_well, 67_000.0, false),
        ];
        for (ci, (model, photons, described)) in cases.iter().enumerate() {
            let pattern = model.fixed_pattern(w, h);
            let ph = vec![*photons; w];
            let sim = model.frame_simulator(&pattern, 0.02, 0.0, 0);
            let (mut mean, mut var) = (vec![0.0; w], vec![0.0; w]);
            let ok = sim.row_moments(&sim.pixel_constants(), 1, &ph, &mut mean, &mut var);
            assert_eq!(ok, *described, "case {ci}: described");
            if !ok {
                continue;
            }
            let (mut s1, mut s2) = (vec![0.0; w], vec![0.0; w]);
            for f in 0..frames {
                let sim = model.frame_simulator(&pattern, 0.02, 0.0, 1000 + f as u64);
                sim.row(1, &ph, |c, y| {
                    let v = f64::from(sim.to_u16(y));
                    s1[c] += v;
                    s2[c] += v * v;
                });
            }
            // Pooled over the row: the summed difference of the means in units of its sampling
            // error, and the summed empirical variance against the predicted one (a pixel with
            // almost no variance, rounded to one value, weighs almost nothing).
            let n = frames as f64;
            let (mut diff, mut pred_var, mut emp_var) = (0.0, 0.0, 0.0);
            for c in 0..w {
                let m = s1[c] / n;
                diff += m - mean[c];
                pred_var += var[c];
                emp_var += (s2[c] - n * m * m) / (n - 1.0);
            }
            let z_mean = diff / (pred_var / n).sqrt();
            let rel_var = emp_var / pred_var - 1.0;
            assert!(z_mean.abs() < 4.0, "case {ci}: means off by {z_mean} sigma");
            assert!(rel_var.abs() < 8.0 * (2.0 / n / w as f64).sqrt(), "case {ci}: variance off by {rel_var}");
        }
    }

    #[test]
    fn top_clipped_moments_match_the_exact_sum() {
        // Pixels of a few thousand electrons at 0.2 DN/e placed from well below to beyond the
        // 12-bit top: the censored Edgeworth moments against the exact sum over every Poisson
        // count and output value: the mean within a thousandth of the noise, the variance within
        // two thousandths of it (the Gaussian alone, without the skew term, misses the variance
        // by three thousandths near the clip).
        let (k, read_sd_dn, max): (f64, f64, f64) = (0.2, 1.5, 4095.0);
        for lambda in [1000.0f64, 4000.0] {
            let noise_dn: f64 = (k * k * lambda + read_sd_dn * read_sd_dn).sqrt();
            for step in -6..=6 {
                let mean = max + f64::from(step) * noise_dn / 2.0;
                let offset = mean - k * lambda;
                let px = RoundedPixel {
                    lambda_e: lambda,
                    k,
                    dsnu_e: 0.0,
                    offset_dn: offset,
                    nonlinearity: DnPolynomial::default(),
                    dither_dn: 0.0,
                };
                let (m_exact, v_exact) = rounded_moments(&px, read_sd_dn, 0.0, max);
                let (m, v) = top_clipped_moments(mean, noise_dn * noise_dn, k.powi(3) * lambda, max);
                let ctx = format!("lambda {lambda}, mean {mean:.1}: ({m}, {v}) against ({m_exact}, {v_exact})");
                assert!((m - m_exact).abs() < 1e-3 * noise_dn, "{ctx}");
                assert!((v - v_exact).abs() < 2e-3 * noise_dn * noise_dn, "{ctx}");
            }
        }
    }

    #[test]
    fn signal_plus_dark_electrons_are_poisson_of_the_summed_mean() {
        // K = 1 DN/e, no read noise, no black level, no clipping: DN = the electron count, which
        // must follow Poisson(QE photons + dark t) exactly, on both sides of the inversion / PTRS
        // switch (mean 3.5 and 45.5), signal and dark drawn as one Poisson of the summed mean,
        // with and without hot pixels adding to the dark mean.
        for (photons, hot) in [(3.0f32, false), (45.0, false), (3.0, true)] {
            let model = SensorModel {
                name: "test".into(),
                quantum_efficiency: 1.0,
                system_gain_dn_per_e: 1.0,
                read_noise_e: 0.0,
                adc_bits: 16,
                pattern_seed: 1,
                effects: Effects {
                    dark_current: DarkCurrent { enabled: true, rate_e_per_s: 50.0 },
                    quantization: Quantization { enabled: true, dither_dn: 0.0 },
                    hot_pixels: HotPixels {
                        enabled: hot,
                        fraction: 1.0,
                        max_excess_e_per_s: 1e-9,
                        ..HotPixels::default()
                    },
                    ..Effects::default()
                },
            };
            let (w, h) = (500, 400);
            let dn = model.simulate(&vec![photons; w * h], w, h, 0.01, 0.0, 8);
            let lambda = f64::from(photons) + 0.5;
            let n = dn.len() as f64;
            let mut counts = std::collections::BTreeMap::new();
            for &v in &dn {
                *counts.entry(v).or_insert(0usize) += 1;
            }
            // Pearson chi-square over every count with at least 5 expected, the rest pooled.
            let pmf = |k: u16| (f64::from(k) * lambda.ln() - lambda - ln_factorial(f64::from(k))).exp();
            let (mut chi2, mut bins, mut pooled_obs, mut pooled_exp) = (0.0, 0, 0.0, 1.0);
            for k in 0..(lambda * 3.0) as u16 + 20 {
                let e = n * pmf(k);
                let o = *counts.get(&k).unwrap_or(&0) as f64;
                if e >= 5.0 {
                    chi2 += (o - e).powi(2) / e;
                    bins += 1;
                    pooled_exp -= pmf(k);
                } else {
                    pooled_obs += o;
                }
            }
            let beyond = dn.iter().filter(|&&v| f64::from(v) >= lambda * 3.0 + 20.0).count() as f64;
            let e = n * pooled_exp;
            chi2 += (pooled_obs + beyond - e).powi(2) / e;
            let dof = f64::from(bins);
            assert!(chi2 < dof + 5.0 * (2.0 * dof).sqrt(), "mean {lambda}: chi-square {chi2} over {bins} bins");
            let mean = dn.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
            assert!((mean - lambda).abs() < 5.0 * (lambda / n).sqrt(), "mean {mean}, expected {lambda}");
        }
    }

    #[test]
    fn round_and_floor_match_the_library_bit_for_bit() {
        let special = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            -2.5,
            0.49999999999999994,
            -0.49999999999999994,
            4503599627370495.5,
            -4503599627370495.5,
            4503599627370496.0,
            9.0e15,
            1e300,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
        ];
        let mut rng = rng::stream(5, "test");
        let random = (0..200_000).map(|i| {
            let x: f64 = rng.random::<f64>() * 2.0 - 1.0;
            // Scales from 1 to 2^60, and half-integers, which round must break away from zero.
            if i % 3 == 0 { (x * 8192.0).trunc() + 0.5 } else { x * 2f64.powi(i % 61) }
        });
        for x in special.into_iter().chain(random) {
            assert_eq!(round_exact(x).to_bits(), x.round().to_bits(), "round {x:e}");
            assert_eq!(floor_exact(x).to_bits(), x.floor().to_bits(), "floor {x:e}");
        }
        assert!(round_exact(f64::NAN).is_nan() && floor_exact(f64::NAN).is_nan());
    }

    #[test]
    fn ln_factorial_is_continuous_at_the_switch() {
        let exact: f64 = (2..=25u32).map(|i| f64::from(i).ln()).sum();
        assert!((ln_factorial(25.0) - exact).abs() < 1e-9);
        assert!((ln_factorial(19.0) - (2..=19u32).map(|i| f64::from(i).ln()).sum::<f64>()).abs() < 1e-12);
        // The table holds exactly the values it replaced, on both sides of the switches.
        for k in (0..100u32).chain([LN_FACTORIAL_TABLE as u32 - 1, LN_FACTORIAL_TABLE as u32, 40_000]) {
            let k = f64::from(k);
            assert_eq!(ln_factorial(k).to_bits(), ln_factorial_direct(k).to_bits(), "k {k}");
        }
    }

    /// The AVX2 clone of the row loop gives the baseline's values bit for bit with every sensor
    /// effect on (both Poisson branches on a dark-to-bright ramp, hot pixels, the periodic
    /// pattern in its non-separable form, unquantised output so no rounding hides a low-bit
    /// difference).
    #[test]
    fn the_avx2_clone_simulates_the_values_of_the_baseline() {
        let sensor = crate::sensor::Catalog::embedded().get("IMX174").unwrap().clone();
        let mut model = SensorModel::from_sensor(&sensor, 1);
        model.effects = Effects {
            read_noise_split: ReadNoiseSplit { enabled: true, post_gain_fraction: 0.3 },
            nonlinearity: Nonlinearity { enabled: true, a3: -0.02, ..Nonlinearity::default() },
            dsnu: Dsnu { enabled: true, std_e: 5.0 },
            prnu: Prnu { enabled: true, std_fraction: 0.01 },
            hot_pixels: HotPixels { enabled: true, fraction: 0.01, max_excess_e_per_s: 1e4, ..HotPixels::default() },
            row_column_noise: RowColumnNoise { enabled: true, row_std_dn: 0.5, column_std_dn: 0.5 },
            periodic_pattern: PeriodicPattern {
                enabled: true,
                amplitude_dn: 1.0,
                amplitude_y_dn: Some(0.7),
                freq_x_cycles_per_px: 0.04,
                freq_y_cycles_per_px: 0.2,
                wave_x_freq_y_cycles_per_px: 0.01,
                wave_y_freq_x_cycles_per_px: 0.03,
            },
            quantization: Quantization { enabled: false, dither_dn: 0.0 },
            ..model.effects
        };
        let (w, h) = (96, 12);
        let photons: Vec<f32> = (0..w * h).map(|i| (i % w) as f32 / w as f32 * 30_000.0).collect();
        let pattern = model.fixed_pattern(w, h);
        let sim = model.frame_simulator(&pattern, 0.01, 6.0, 3);
        let generic = sim.frame(Dispatch::Generic, &photons, f64::to_bits);
        assert_eq!(generic, sim.frame(Dispatch::Avx2Fma, &photons, f64::to_bits));
        // Noisy, not a constant: the comparison means something.
        assert!(generic.iter().filter(|&&v| v != generic[0]).count() > w * h / 2);
    }
}
