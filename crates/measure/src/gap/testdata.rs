//! Hidden-effect data sets: EMVA 1288 descriptors with 16-bit PNG frames, simulated by the
//! project's own noise model with zero, one or two effects switched on at random strengths, to
//! test that the gap workflow names exactly the hidden effects.
//!
//! Layout (small, so a case runs in well under a second): 64 x 48 pixels, 12 bit, 12 radiance
//! steps of 2 frames at 10 ms, dark pairs at 10, 40 and 160 ms (a dark exposure series, so
//! dark current is measurable), 16 bright frames at half scale and 16 dark frames at 10 ms.
//! `read_noise_split` needs two gains or more: [`random_multigain_case`] hides it in an
//! acquisition over several gains ([`layout_gains`]), written as one descriptor per gain
//! ([`write_multigain`]) or as one photon-transfer CSV ([`write_csv`]).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rand::Rng as _;

use super::fit::effect_names;
use super::{Acquisition, Block, GapModel, IlluminationFalloff, Light, Optics, simulate_acquisition};
use scene_gen_camera::sensor::SensorModel;
use scene_gen_camera::sensor::noise::{self, Effects};
use scene_gen_core::rng;

/// Effects a hidden case may switch on: every effect the workflow can try ([`super::fit::EFFECTS`]), so a
/// test can catch both a missed effect and one it never tries, less `read_noise_split`, which one
/// gain cannot show (only [`random_multigain_case`] hides it), and dithered `quantization`, which
/// shows only where the dark noise is below about half a DN (these cases' is several DN; the
/// EMVA 1288 reference simulator's sets in tests/interop hide it).
pub fn single_gain_hidden() -> Vec<&'static str> {
    effect_names().into_iter().filter(|e| *e != "read_noise_split" && *e != "quantization").collect()
}

const WIDTH: usize = 64;
const HEIGHT: usize = 48;
const BITS: u32 = 12;
/// Exposure of the photon-transfer steps and of the dark stack, s.
pub const EXPOSURE_S: f64 = 0.01;
const STEPS: usize = 12;
const STACK_FRAMES: usize = 16;

/// A hidden-effect case: the true model and the effects switched on.
#[derive(Debug, Clone)]
pub struct HiddenCase {
    pub hidden: Vec<&'static str>,
    pub model: GapModel,
}

/// Draws case `index`: `n_effects` distinct effects (0..=2) at random strengths on a random
/// clean camera (K 0.08..0.25 DN/e-, QE 0.4..0.8, read noise 6..20 e-).
#[must_use]
pub fn random_case(seed: u64, n_effects: usize) -> HiddenCase {
    let mut r = rng::stream(seed, "gap/testdata");
    let k = r.random_range(0.08..0.25);
    let read = r.random_range(6.0..20.0);
    let read_dn = k * read;
    let candidates = single_gain_hidden();
    let mut hidden: Vec<&'static str> = Vec::new();
    while hidden.len() < n_effects.min(2) {
        let e = candidates[r.random_range(0..candidates.len())];
        if !hidden.contains(&e) {
            hidden.push(e);
        }
    }
    hidden.sort_by_key(|e| candidates.iter().position(|h| h == e));
    let max = f64::from((1u32 << BITS) - 1);
    let mut e = Effects { quantization: noise::Quantization { enabled: true, dither_dn: 0.0 }, ..Effects::default() };
    let mut optics = Optics::default();
    for &h in &hidden {
        match h {
            "black_level" => {
                e.black_level = noise::BlackLevel { enabled: true, offset_dn: r.random_range(20.0..200.0) }
            }
            "dark_current" => {
                // 20..80 DN of dark signal at the longest dark exposure (160 ms).
                let dn = r.random_range(20.0..80.0);
                e.dark_current = noise::DarkCurrent { enabled: true, rate_e_per_s: dn / k / 0.16 };
            }
            "saturation" => {
                let fw_dn = r.random_range(0.55..0.75) * max;
                e.saturation = noise::Saturation { enabled: true, full_well_e: fw_dn / k };
            }
            "nonlinearity" => {
                // 4..10 % at full scale either way, bending as r, r^2 or r^3 (set 003's cubic
                // is one form of three).
                let a = r.random_range(0.04..0.1);
                let a = if r.random::<bool>() { a } else { -a };
                let mut terms = [0.0; 3];
                terms[r.random_range(0..3usize)] = a;
                let [a1, a2, a3] = terms;
                e.nonlinearity = noise::Nonlinearity { enabled: true, a1, a2, a3 };
            }
            "dsnu" => e.dsnu = noise::Dsnu { enabled: true, std_e: r.random_range(0.8..2.0) * read },
            "prnu" => e.prnu = noise::Prnu { enabled: true, std_fraction: r.random_range(0.01..0.03) },
            "hot_pixels" => {
                let x_dn = r.random_range(20.0..60.0) * read_dn;
                let x_e_per_s = x_dn / k / EXPOSURE_S;
                // Uniform in 0..X (set 003's form) or exponential with mean X / 4 (cut at its
                // 99.5th percentile), a form with a long tail and most pixels barely hot.
                let quantiles = r.random::<bool>().then(|| {
                    std::array::from_fn(|i| {
                        let p = i as f64 / (noise::HotPixels::QUANTILES - 1) as f64;
                        -0.25 * x_e_per_s * (1.0 - 0.995 * p).ln()
                    })
                });
                e.hot_pixels = noise::HotPixels {
                    enabled: true,
                    fraction: r.random_range(0.004..0.012),
                    max_excess_e_per_s: x_e_per_s,
                    excess_quantiles_e_per_s: quantiles,
                };
            }
            "row_column_noise" => {
                e.row_column_noise = noise::RowColumnNoise {
                    enabled: true,
                    row_std_dn: r.random_range(0.4..1.0) * read_dn,
                    column_std_dn: r.random_range(0.4..1.0) * read_dn,
                };
            }
            "periodic_pattern" => {
                e.periodic_pattern = noise::PeriodicPattern {
                    enabled: true,
                    amplitude_dn: r.random_range(0.8..2.0) * read_dn,
                    freq_x_cycles_per_px: r.random_range(0.06..0.4),
                    freq_y_cycles_per_px: r.random_range(0.06..0.4),
                    // Each wave has its own amplitude.
                    amplitude_y_dn: Some(r.random_range(0.8..2.0) * read_dn),
                    ..noise::PeriodicPattern::default()
                };
            }
            "illumination_falloff" => {
                optics.illumination_falloff =
                    IlluminationFalloff { enabled: true, corner_loss_fraction: r.random_range(0.06..0.2) };
            }
            _ => {}
        }
    }
    let sensor = SensorModel {
        name: format!("hidden-{seed}"),
        quantum_efficiency: r.random_range(0.4..0.8),
        system_gain_dn_per_e: k,
        read_noise_e: read,
        adc_bits: BITS,
        pattern_seed: seed ^ 0x5eed,
        effects: e,
    };
    HiddenCase { hidden, model: GapModel { sensor, optics } }
}

/// The acquisition layout of a case (frames empty): the top step reaches ~90 % of the ADC range
/// with the linear model.
#[must_use]
pub fn layout(model: &GapModel) -> Acquisition {
    let max = f64::from((1u32 << BITS) - 1);
    let responsivity = model.sensor.system_gain_dn_per_e * model.sensor.quantum_efficiency;
    let top = 0.9 * max / responsivity;
    let empty = |light, exposure_s, n: usize| Block::layout(light, exposure_s, 0, n);
    let mut blocks: Vec<Block> =
        (1..=STEPS).map(|i| empty(Light::Bright(top * i as f64 / STEPS as f64), EXPOSURE_S, 2)).collect();
    for t in [EXPOSURE_S, 4.0 * EXPOSURE_S, 16.0 * EXPOSURE_S] {
        blocks.push(empty(Light::Dark, t, 2));
    }
    blocks.push(empty(Light::Bright(0.5 * top), EXPOSURE_S, STACK_FRAMES));
    blocks.push(empty(Light::Dark, EXPOSURE_S, STACK_FRAMES));
    Acquisition { width: WIDTH, height: HEIGHT, bits: BITS, blocks, gains_db: vec![0.0] }
}

/// A case over several gains: a black level of 150..250 DN (EMVA 1288 requires the offset to
/// keep the dark signal unclipped; without it the dark frames at 12 dB clip at 0 DN, where mean
/// and variance of a pair are strongly correlated and the chi-square counts one fluctuation
/// twice), plus `read_noise_split` (post-gain fraction 0.3..0.8 of the read-noise variance) and
/// `n_other` (0..=1) further effects of [`single_gain_hidden`]; `n_other` None: no split and nothing else.
/// Every effect switched on is in `hidden`.
#[must_use]
pub fn random_multigain_case(seed: u64, n_other: Option<usize>) -> HiddenCase {
    let mut case = random_case(seed, n_other.unwrap_or(0).min(1));
    let mut r = rng::stream(seed, "gap/testdata/multigain");
    let e = &mut case.model.sensor.effects;
    if !e.black_level.enabled {
        e.black_level = noise::BlackLevel { enabled: true, offset_dn: r.random_range(150.0..250.0) };
        case.hidden.push("black_level");
    }
    if n_other.is_some() {
        e.read_noise_split = noise::ReadNoiseSplit { enabled: true, post_gain_fraction: r.random_range(0.3..0.8) };
        case.hidden.push("read_noise_split");
    }
    case.hidden.sort_unstable();
    case
}

/// [`layout`] at 0 dB (group 0, with the spatial stacks) plus, per further gain of `gains_db`,
/// its radiance steps (photons scaled down by the gain, so the top step stays near 90 % of the
/// range) and its dark pairs at 10, 40 and 160 ms.
#[must_use]
pub fn layout_gains(model: &GapModel, gains_db: &[f64]) -> Acquisition {
    let mut acq = layout(model);
    let base: Vec<Block> = acq.blocks.iter().filter(|b| b.frames.len() == 2).cloned().collect();
    acq.gains_db = vec![0.0];
    for &g in gains_db.iter().filter(|g| **g != 0.0) {
        let group = acq.gains_db.len();
        acq.gains_db.push(g);
        let f = noise::gain_factor(g);
        for b in &base {
            let light = match b.light {
                Light::Bright(p) => Light::Bright(p / f),
                Light::Dark => Light::Dark,
            };
            acq.blocks.push(Block { light, group, ..b.clone() });
        }
    }
    acq
}

/// Writes `acq` (simulated) as `dir/EMVA1288_Data.txt` and its images.
fn write_acquisition(dir: &Path, acq: &Acquisition) -> Result<PathBuf, WriteDataError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| WriteDataError::Io { path: path.clone(), source }
    };
    std::fs::create_dir_all(dir.join("images")).map_err(io(dir))?;
    let mut text = String::from("# hidden-effect data set written by scene_gen::gap::testdata\nv 3.0\n");
    let _ = writeln!(text, "n {} {} {}", acq.bits, acq.width, acq.height);
    for (bi, b) in acq.blocks.iter().enumerate() {
        let ns = (b.exposure_s * 1e9).round();
        match b.light {
            Light::Bright(p) => {
                let _ = writeln!(text, "b {ns} {p}");
            }
            Light::Dark => {
                let _ = writeln!(text, "d {ns}");
            }
        }
        for (fi, f) in b.frames.iter().enumerate() {
            let name = format!("images/b{bi:03}_{fi:03}.png");
            let path = dir.join(&name);
            let raw: Vec<u16> = f.iter().map(|&v| v as u16).collect();
            let img =
                image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(acq.width as u32, acq.height as u32, raw)
                    .ok_or_else(|| WriteDataError::Image { path: path.clone(), message: "size mismatch".into() })?;
            img.save(&path).map_err(|e| WriteDataError::Image { path: path.clone(), message: e.to_string() })?;
            let _ = writeln!(text, "i {name}");
        }
    }
    let desc = dir.join("EMVA1288_Data.txt");
    std::fs::write(&desc, text).map_err(io(&desc))?;
    Ok(desc)
}

/// Simulates `model` over a multi-gain `layout` ([`layout_gains`]) and writes one descriptor
/// per gain group, `dir/gain<i>/EMVA1288_Data.txt` (the gain itself is not written: the
/// workflow measures it); returns the descriptors, reference gain first.
pub fn write_multigain(
    dir: &Path,
    model: &GapModel,
    layout: &Acquisition,
    seed: u64,
) -> Result<Vec<PathBuf>, WriteDataError> {
    let acq = simulate_acquisition(model, layout, seed, None);
    (0..acq.gains_db.len())
        .map(|g| {
            let part = Acquisition {
                blocks: acq.blocks.iter().filter(|b| b.group == g).map(|b| Block { group: 0, ..b.clone() }).collect(),
                gains_db: vec![0.0],
                ..acq.clone()
            };
            write_acquisition(&dir.join(format!("gain{g}")), &part)
        })
        .collect()
}

/// Simulates `model` over `layout` and writes its photon-transfer CSV to `path` (see
/// [`super::csv::to_csv`]).
pub fn write_csv(path: &Path, model: &GapModel, layout: &Acquisition, seed: u64) -> Result<(), WriteDataError> {
    let acq = simulate_acquisition(model, layout, seed, None);
    std::fs::write(path, super::csv::to_csv(&acq))
        .map_err(|source| WriteDataError::Io { path: path.to_path_buf(), source })
}

/// A data-set writing failure.
#[derive(Debug, thiserror::Error)]
pub enum WriteDataError {
    #[error("cannot write {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot encode {}: {message}", path.display())]
    Image { path: PathBuf, message: String },
}

/// Simulates `model` over `layout` with `seed` and writes `dir/EMVA1288_Data.txt` and its
/// images; returns the descriptor path.
pub fn write_dataset(dir: &Path, model: &GapModel, layout: &Acquisition, seed: u64) -> Result<PathBuf, WriteDataError> {
    let acq = simulate_acquisition(model, layout, seed, None);
    write_acquisition(dir, &acq)
}

/// An effect outside the workflow's library ([`super::fit::EFFECTS`]), applied to a simulated
/// acquisition's frames, to test that the workflow reports misfit it cannot explain
/// ([`super::misfit`]) rather than naming a wrong effect for it. Each acts on the signal above
/// the black level, `s = y - black`, and the result is rounded and clipped to the ADC range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Foreign {
    /// A `fraction` of the pixels (a fixed seeded set) answer at `response` times the normal
    /// signal: weak or dead pixels.
    DeadPixels { fraction: f64, response: f64 },
    /// A response like a gamma curve: `s -> max (s / max)^gamma`, `max` the range above black.
    Gamma { gamma: f64 },
    /// Every column's signal scaled by its own `1 + g`, `g` normal with sd `std_fraction` (one
    /// amplifier or ADC per column).
    ColumnGain { std_fraction: f64 },
    /// Each pixel keeps `1 - 4 c` of its signal and gives `c` to each of its four neighbours
    /// (crosstalk; edges reflect), which blurs the temporal noise as well as the image.
    Crosstalk { coupling: f64 },
}

impl Foreign {
    /// The effect's name in reports and tests.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Foreign::DeadPixels { .. } => "dead_pixels",
            Foreign::Gamma { .. } => "gamma_response",
            Foreign::ColumnGain { .. } => "column_gain",
            Foreign::Crosstalk { .. } => "crosstalk",
        }
    }

    /// The statistic family where the effect shows most ([`super::stats::FAMILIES`]): dead
    /// pixels in the bright tail, a gamma in the mean response, column gain in the bright
    /// stack's column profile, crosstalk in the temporal noise's neighbour correlation.
    #[must_use]
    pub fn family(&self) -> &'static str {
        match self {
            Foreign::DeadPixels { .. } => "tails",
            Foreign::Gamma { .. } => "linearity",
            Foreign::ColumnGain { .. } => "spatial",
            Foreign::Crosstalk { .. } => "correlation",
        }
    }

    /// Applies the effect to every frame of `acq`, whose black level is `black_dn`; `seed`
    /// draws the pixel or column pattern (the same for every frame).
    pub fn apply(&self, acq: &mut Acquisition, black_dn: f64, seed: u64) {
        let (w, h) = (acq.width, acq.height);
        let max = f64::from((1u32 << acq.bits) - 1);
        let range = (max - black_dn).max(1.0);
        let mut r = rng::stream(seed, "gap/testdata/foreign");
        // Per pixel: the signal's scale (dead pixels, column gain); None for the others.
        let scale: Option<Vec<f64>> = match *self {
            Foreign::DeadPixels { fraction, response } => {
                Some((0..w * h).map(|_| if r.random::<f64>() < fraction { response } else { 1.0 }).collect())
            }
            Foreign::ColumnGain { std_fraction } => {
                // Box-Muller: a normal draw per column.
                let cols: Vec<f64> = (0..w)
                    .map(|_| {
                        let (u, v): (f64, f64) = (r.random::<f64>().max(1e-300), r.random());
                        1.0 + std_fraction * (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
                    })
                    .collect();
                Some((0..w * h).map(|i| cols[i % w]).collect())
            }
            Foreign::Gamma { .. } | Foreign::Crosstalk { .. } => None,
        };
        let finish = |v: f64| (black_dn + v).round().clamp(0.0, max) as f32;
        for frame in acq.blocks.iter_mut().flat_map(|b| b.frames.iter_mut()) {
            let signal: Vec<f64> = frame.iter().map(|&y| f64::from(y) - black_dn).collect();
            let out: Vec<f64> = match (*self, &scale) {
                (_, Some(scale)) => signal.iter().zip(scale).map(|(s, k)| s * k).collect(),
                (Foreign::Gamma { gamma }, None) => {
                    signal.iter().map(|&s| range * (s.max(0.0) / range).powf(gamma) + s.min(0.0)).collect()
                }
                (Foreign::Crosstalk { coupling }, None) => crosstalk(&signal, w, h, coupling),
                _ => signal,
            };
            *frame = out.into_iter().map(finish).collect();
        }
    }
}

/// `s` with each pixel keeping `1 - 4 c` and each 4-neighbour adding `c` (edges reflect).
fn crosstalk(s: &[f64], w: usize, h: usize, c: f64) -> Vec<f64> {
    let at = |x: isize, y: isize| {
        let x = if x < 0 {
            1
        } else if x as usize >= w {
            w as isize - 2
        } else {
            x
        };
        let y = if y < 0 {
            1
        } else if y as usize >= h {
            h as isize - 2
        } else {
            y
        };
        s[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize]
    };
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as isize, (i / w) as isize);
            (1.0 - 4.0 * c) * s[i] + c * (at(x - 1, y) + at(x + 1, y) + at(x, y - 1) + at(x, y + 1))
        })
        .collect()
}

/// The foreign effect of case `seed`: the four kinds in turn (`seed % 4`: dead pixels, gamma,
/// column gain, crosstalk) at strengths drawn in ranges a camera maker would call a defect
/// worth knowing: 0.2..0.8 % of pixels at 0..30 % response, gamma 0.85..0.92, column gain sd
/// 1..3 %, crosstalk 4..10 % to each neighbour.
#[must_use]
pub fn random_foreign(seed: u64) -> Foreign {
    let u: f64 = rng::stream(seed, "gap/testdata/foreign-kind").random();
    match seed % 4 {
        0 => Foreign::DeadPixels { fraction: 0.002 + 0.006 * u, response: 0.3 * u },
        1 => Foreign::Gamma { gamma: 0.85 + 0.07 * u },
        2 => Foreign::ColumnGain { std_fraction: 0.01 + 0.02 * u },
        _ => Foreign::Crosstalk { coupling: 0.04 + 0.06 * u },
    }
}

/// Simulates `model` over `layout`, applies `foreign` (see [`Foreign::apply`]; the black level
/// is the model's) and writes the descriptor and images to `dir`.
pub fn write_dataset_foreign(
    dir: &Path,
    model: &GapModel,
    layout: &Acquisition,
    seed: u64,
    foreign: Foreign,
) -> Result<PathBuf, WriteDataError> {
    let mut acq = simulate_acquisition(model, layout, seed, None);
    let bl = model.sensor.effects.black_level;
    foreign.apply(&mut acq, if bl.enabled { bl.offset_dn } else { 0.0 }, seed);
    write_acquisition(dir, &acq)
}
