//! The sim-vs-measured gap workflow (`scene-gen gap`): compare an EMVA 1288 measurement with the
//! same acquisition simulated by the project's noise model, name the effects the model is
//! missing, add them one at a time, and show the gap shrink.
//!
//! 1. Start model: the EMVA 1288 linear model fitted to the data (K, read noise, QE from
//!    [`crate::calibration`]; K and the read noise then refined by simulation so the photon
//!    transfer and the dark variance match, which also undoes the bias of dark frames clipped
//!    at 0 DN), every effect of docs/CONTRACTS.md off except quantization; or a given model.
//! 2. The acquisition is simulated block by block through the sensor model's frame simulator
//!    (the renderer's code path): same exposures, photons per pixel, frame counts and image
//!    size; fixed seeds, the same for every candidate model (common random numbers, so
//!    candidates differ by their parameters, not by their noise draws). On large frames the
//!    search draws each pixel from the two moments of its output wherever they describe it
//!    ([`Draws::Moments`]), and every pixel of every frame where they do not.
//! 3. [`stats`] computes the same statistics on both stacks, grouped in families.
//! 4. The gap: per family the chi-square per degree of freedom of the residuals, each divided
//!    by its sampling uncertainty (measured and simulated combined); the gap is the mean of
//!    the families' values minus one, so a model that matches within sampling noise scores
//!    about 0 ([`stats::gap`]).
//! 5. [`fit`]: every effect the data can show gets its parameters in closed form from the
//!    statistics; the candidate whose re-simulated chi-square drops most is added when the
//!    drop beats twice the Bayesian information criterion penalty, `2 k ln n` (k parameters, n
//!    statistics; the factor 2 because the sampling variances are estimated, see
//!    [`crate::search::PENALTY_FACTOR`]); after each addition the linear model's nuisance parameters
//!    (K, read noise, responsivity) and the added effects are refitted; repeat until no
//!    candidate earns its place.
//! 6. [`misfit`]: the leftover misfit of each family is tested against replicate simulations of
//!    the final model; what is larger than their spread is reported as unexplained, with where
//!    it lives, and an added effect whose evidence rests on it is reported as tentative instead
//!    of named.
//!
//! Hidden-effect data sets (tests/gap.rs, [`testdata`]): see the tests for the measured hit
//! rates (40 single-gain cases, 12 two-gain cases, CSVs). On EMVA 1288 data set 003 (centre
//! crop) it names black level, nonlinearity, DSNU, the diagonal periodic DSNU waves, PRNU, hot
//! pixels and the slight fall-off. Hot pixels: the tail is counted on the averaged dark residual
//! with its periodic waves removed ([`stats::remove_waves`]), above a threshold set by a stated
//! false-alarm rate over the pixels ([`stats::tail_sigmas`], [`stats::DARK_TAIL_FALSE_ALARM`]:
//! a Bonferroni bound, 5.3 sigmas of the pixel noise at 160x120, ~8.5 DN), and scored by its
//! Poisson deviance ([`stats::count_deviance`]) against the plain BIC penalty
//! ([`fit::COUNT_PENALTY_FACTOR`]: a count's variance is not estimated). The crop's ~6 hot
//! pixels (excess 0..15 DN) leave one pixel above the threshold (at 6.8 sigmas), which the
//! Gaussian core explains with probability ~1e-7 over the whole crop; its deviance, ~11, beats
//! the 2-parameter penalty of 9.5.
//!
//! Cost: most of a run is simulating the acquisition, tens of times. The statistics of a set
//! are sums over hundreds of thousands of pixels, so on frames of [`MOMENTS_MIN_ROWS`] rows or
//! more the search draws each pixel from its output's mean and variance ([`Draws::Moments`],
//! [`FrameSimulator::row_moments`]: shot, read and post-gain noise through the nonlinearity,
//! with the bias and variance that rounding to whole DN adds summed exactly where the noise is
//! too fine for Sheppard's correction), a spatial stack as its mean image, one draw per pixel,
//! and a temporal pair as its statistics alone, drawn from its rows' and columns' sums of
//! those moments (`moment_pair`; the two pairs whose neighbour correlation is read keep their
//! pixels). Lit blocks whose measurement touches 0 DN and rows near the full well are drawn
//! pixel by pixel as the hidden-effect sets are made ([`Draws::Pixels`],
//! [`block_draws`]). The statistics use FFTs ([`stats::periodogram_2d`]), separable wave
//! tables and run their pairs and stacks in parallel; the search keeps its last evaluations
//! ([`fit`]: an unchanged model is not simulated again) and the last fixed patterns; and on
//! frames of 240 rows or more the candidates of a round are screened on the top quarter of the
//! rows (bit for bit the full simulation's rows, [`simulate_rows`]) and only the best
//! [`fit::SCREEN_KEEP`] within [`fit::SCREEN_KEEP_FRACTION`] of the best window drop simulated
//! in full, side by side ([`GapOptions::screen`]), and the refits that polish the model after
//! each addition are judged on the same window, one full simulation per pass (none for a pass
//! whose window gain could not pass the stopping threshold). The read-noise refit matches the
//! dark pair's expected variance from its pixels' moments where they describe it
//! ([`pair_variance_from_moments`]). docs/BENCHMARKS.md has the figures.
//!
//! Inputs ([`run_inputs`]): one descriptor; several descriptors of one camera at different gains
//! (gain groups; the gains are measured from the response, [`load_acquisitions`]), where
//! `read_noise_split` becomes a candidate; or one photon-transfer CSV ([`csv`]: photon transfer,
//! linearity and dark statistics only, per gain). With one gain `read_noise_split` is never
//! proposed (it changes nothing there). `illumination_falloff` is an optics effect
//! ([`OPTICS_EFFECTS`]); the workflow models it on the photon image and writes it to
//! `optics.toml` beside `model.toml`.
//!
//! [`OPTICS_EFFECTS`]: scene_gen_camera::sensor::noise::OPTICS_EFFECTS

pub mod csv;
pub mod fit;
pub mod misfit;
pub mod report;
pub mod stats;
pub mod testdata;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use rand::Rng as _;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::calibration::emva::{self, BlockKind, EmvaError};
use crate::calibration::{self, CalibrationError};
use scene_gen_camera::sensor::SensorModel;
use scene_gen_camera::sensor::noise::{
    Dsnu, FixedPattern, FrameSimulator, HotPixels, ModelError, PixelConstants, Prnu, RowColumnNoise, standard_normal,
};
use scene_gen_core::rng;
use scene_gen_core::simd::Dispatch;

/// The workflow failed.
#[derive(Debug, thiserror::Error)]
pub enum GapError {
    #[error(transparent)]
    Emva(#[from] EmvaError),
    #[error(transparent)]
    Calibration(#[from] CalibrationError),
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error(transparent)]
    Ptc(#[from] calibration::ptc::PtcError),
    #[error("{}: {message}", path.display())]
    Unusable { path: PathBuf, message: String },
}

/// Options of the workflow.
#[derive(Debug, Clone)]
pub struct GapOptions {
    /// Seed of the simulated acquisitions (fixed patterns and temporal noise).
    pub seed: u64,
    /// Frames used of each spatial stack (the first ones); None: all. Averages of 32 frames
    /// already put the residual temporal variance at 1/32 of a frame's.
    pub max_stack_frames: Option<usize>,
    /// Use every n-th photon-transfer step (1: all).
    pub step_stride: usize,
    /// Screen the candidates of a round on the top quarter of the sensor's rows and simulate
    /// the whole acquisition only for the most promising ones ([`fit::SCREEN_KEEP`]); only on
    /// frames of at least [`fit::SCREEN_MIN_ROWS`] rows. False: every candidate in full.
    pub screen: bool,
    /// Replicate simulations of the final model that the leftover misfit is tested against
    /// ([`misfit`]); 0 skips the test.
    pub replicates: usize,
    /// How the search's simulations draw their pixels ([`Draws::Moments`] by default, on
    /// frames of [`MOMENTS_MIN_ROWS`] rows or more and blocks away from the clips, see
    /// [`block_draws`]; [`Draws::Pixels`] draws every pixel of every frame, the slow reference).
    pub draws: Draws,
}

impl Default for GapOptions {
    fn default() -> Self {
        GapOptions {
            seed: 1288,
            max_stack_frames: Some(32),
            step_stride: 1,
            screen: true,
            replicates: misfit::DEFAULT_REPLICATES,
            draws: Draws::Moments,
        }
    }
}

/// Bright (photons per pixel, mean over the frame) or dark.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Light {
    Bright(f64),
    Dark,
}

impl Light {
    /// Photons per pixel (0 in the dark).
    #[must_use]
    pub fn photons(self) -> f64 {
        match self {
            Light::Bright(p) => p,
            Light::Dark => 0.0,
        }
    }
}

/// One block of an acquisition: a temporal pair or a spatial stack.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub light: Light,
    pub exposure_s: f64,
    /// Gain group: index into [`Acquisition::gains_db`] (one group per input file or CSV gain).
    pub group: usize,
    /// Frames, row-major `width x height` DN values.
    pub frames: Vec<Vec<f32>>,
    /// The mean image of a spatial stack whose simulation drew it directly ([`Draws::Moments`]);
    /// `frames` then holds as many empty frames as the stack has.
    pub average: Option<Vec<f64>>,
    /// The statistics of a temporal pair whose simulation drew them from its pixels' moments
    /// ([`Draws::Moments`]); `frames` then holds two empty frames.
    pub pair: Option<stats::PairStats>,
}

impl Block {
    /// A block of `frames` empty frames: the layout of a measurement, without its pixels.
    #[must_use]
    pub fn layout(light: Light, exposure_s: f64, group: usize, frames: usize) -> Block {
        Block { light, exposure_s, group, frames: vec![Vec::new(); frames], average: None, pair: None }
    }

    /// The mean image of the block's frames.
    #[must_use]
    pub fn mean_image(&self) -> Vec<f64> {
        match &self.average {
            Some(img) => img.clone(),
            None => stats::average(&self.frames),
        }
    }
}

/// A measured or simulated EMVA 1288 acquisition.
#[derive(Debug, Clone, PartialEq)]
pub struct Acquisition {
    pub width: usize,
    pub height: usize,
    pub bits: u32,
    pub blocks: Vec<Block>,
    /// Analog gain of each group, dB (the model's K is at 0 dB). Group 0 is the reference: the
    /// first descriptor (0 dB, the others relative to it) or the lowest gain of a CSV.
    pub gains_db: Vec<f64>,
}

/// Loads the images of an EMVA 1288 descriptor (spatial stacks cut to `max_stack_frames`,
/// photon-transfer pairs thinned to every `step_stride`-th bright pair).
pub fn load_acquisition(path: &Path, options: &GapOptions) -> Result<Acquisition, GapError> {
    let d = emva::read_descriptor(path)?;
    let (w, h, bits) = (d.width, d.height, d.bits);
    let mut blocks = Vec::new();
    let mut bright_pair = 0usize;
    for b in &d.blocks {
        let pair = b.images.len() == 2;
        let light = match b.kind {
            BlockKind::Bright { photons } => Light::Bright(photons),
            BlockKind::Dark => Light::Dark,
        };
        if pair && matches!(light, Light::Bright(_)) {
            bright_pair += 1;
            if (bright_pair - 1) % options.step_stride.max(1) != 0 {
                continue;
            }
        }
        let take = if pair { 2 } else { options.max_stack_frames.unwrap_or(usize::MAX).max(2) };
        // Decoded side by side; the first unreadable image in descriptor order is the error.
        let frames: Vec<Result<Vec<f32>, EmvaError>> =
            b.images[..take.min(b.images.len())].par_iter().map(|p| emva::load_image(p, w, h, bits)).collect();
        let frames = frames.into_iter().collect::<Result<Vec<_>, _>>()?;
        blocks.push(Block { light, exposure_s: b.exposure_s(), group: 0, frames, average: None, pair: None });
    }
    Ok(Acquisition { width: w as usize, height: h as usize, bits, blocks, gains_db: vec![0.0] })
}

/// Illumination fall-off of the optics, applied to the photon image: photons at normalised
/// radius `rho` (1 at the corners) are `p (1 - c (rho^2 - mean rho^2))`, so the frame mean stays
/// the descriptor's photon count.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IlluminationFalloff {
    pub enabled: bool,
    /// Relative loss from the centre to the corners, `c`.
    pub corner_loss_fraction: f64,
}

/// The optics part of a model (what `optics.toml` holds).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Optics {
    pub illumination_falloff: IlluminationFalloff,
}

/// A sensor model and the optics effects it is simulated with.
#[derive(Debug, Clone, PartialEq)]
pub struct GapModel {
    pub sensor: SensorModel,
    pub optics: Optics,
}

impl GapModel {
    /// Names of the effects switched on. Plain rounding is always on and not named;
    /// `quantization` is named when it is dithered.
    #[must_use]
    pub fn named(&self) -> Vec<&'static str> {
        let dithered = self.sensor.effects.quantization.dither_dn > 0.0;
        let mut v: Vec<&'static str> =
            self.sensor.effects.enabled_names().into_iter().filter(|n| *n != "quantization" || dithered).collect();
        if self.optics.illumination_falloff.enabled {
            v.push("illumination_falloff");
        }
        v
    }
}

/// Normalised squared radius per pixel minus its mean (see [`IlluminationFalloff`]).
#[must_use]
pub fn radius2_map(width: usize, height: usize) -> Vec<f64> {
    let (cx, cy) = ((width as f64 - 1.0) / 2.0, (height as f64 - 1.0) / 2.0);
    let r2max = cx * cx + cy * cy;
    let mut v: Vec<f64> = (0..width * height)
        .map(|i| {
            let (x, y) = ((i % width) as f64 - cx, (i / width) as f64 - cy);
            if r2max > 0.0 { (x * x + y * y) / r2max } else { 0.0 }
        })
        .collect();
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    v.iter_mut().for_each(|r| *r -= mean);
    v
}

/// Seed of frame `frame` of block `block`.
fn frame_seed(seed: u64, block: usize, frame: usize) -> u64 {
    rng::substream(seed, "gap/frame", ((block as u64) << 24) | frame as u64).random::<u64>()
}

/// How a simulation draws the pixels of its frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Draws {
    /// Every pixel of every frame through the sensor model, as the renderer draws it: Poisson
    /// shot noise, Gaussian read noise, rounding and clipping. The hidden-effect sets
    /// ([`testdata`]) are made this way.
    #[default]
    Pixels,
    /// Each pixel from the two moments of its output, Gaussian, in every row where they
    /// describe it ([`FrameSimulator::row_moments`]: below the full well, and the bias and
    /// variance that rounding and the ADC's ends add summed exactly where they matter); other
    /// rows as [`Draws::Pixels`]. A spatial stack is drawn as its mean image, one draw per
    /// pixel, since its statistics read nothing else; a temporal pair whose every row they
    /// describe is drawn as its statistics alone ([`Block::pair`]), from the sums of its
    /// pixels' moments over rows and columns, but for the two pairs whose pixels
    /// [`stats::correlation_pairs`] reads. The statistics of a block are sums over
    /// its pixels, which see no difference between the two, and a moment draw costs a fraction
    /// of a Poisson draw and a stack of L frames `1 / L` of them. Every row drawn from moments
    /// draws the same normal deviates whatever the model, so candidates keep their common
    /// random numbers; the search draws from moments only the blocks its measurement shows
    /// away from the clips, where every candidate near the data is described too
    /// ([`block_draws`]).
    Moments,
}

/// Simulates the blocks `which` of `layout` (all when None) with `model`, pixel by pixel
/// ([`Draws::Pixels`]); other blocks are left empty. Block `i`, frame `j` always draws from the
/// same seed, whatever else is simulated.
#[must_use]
pub fn simulate_acquisition(model: &GapModel, layout: &Acquisition, seed: u64, which: Option<&[usize]>) -> Acquisition {
    simulate_rows(model, layout, seed, which, layout.height, &[])
}

/// Frames of fewer rows are drawn pixel by pixel whatever [`GapOptions::draws`] says: a
/// block's moments cost about as much as drawing a few hundred thousand pixels where rounding
/// must be summed exactly, which pays on large frames only.
pub const MOMENTS_MIN_ROWS: usize = 240;

/// How the search draws each block of `measured` under `draws`: [`Draws::Moments`] only on
/// frames of at least [`MOMENTS_MIN_ROWS`] rows, and for blocks whose frames hold no pixel at
/// 0 DN unless the block is dark (one in ten thousand allowed: a hot or dead pixel), so no
/// candidate near the data switches a block between the two ways of drawing; the others pixel
/// by pixel. [`FrameSimulator::row_moments`] describes for every candidate the pixels that
/// reach the clips in the blocks it is given: dark pixels near 0 DN, which share their Poisson
/// mean, from one table per frame, and bright pixels at the ADC's top, whose counts are large,
/// from censored moments; a lit pixel near 0 DN would be summed alone, over more counts than a
/// sum takes.
#[must_use]
pub fn block_draws(measured: &Acquisition, draws: Draws) -> Vec<Draws> {
    let draws = if measured.height < MOMENTS_MIN_ROWS { Draws::Pixels } else { draws };
    measured
        .blocks
        .iter()
        .map(|b| {
            let values = b.frames.iter().map(Vec::len).sum::<usize>();
            let lit = b.light != Light::Dark;
            let clipped = if lit { b.frames.iter().flatten().filter(|&&v| v <= 0.0).count() } else { 0 };
            if draws == Draws::Moments && values > 0 && clipped * 10_000 <= values {
                Draws::Moments
            } else {
                Draws::Pixels
            }
        })
        .collect()
}

/// [`simulate_acquisition`] cut to the first `rows` rows of the sensor, block `i` drawn as
/// `draws[i]` says ([`Draws::Pixels`] past its end): every fixed-pattern map and every frame's
/// temporal noise is drawn row by row from its own substream, whether a row is drawn from its
/// moments depends on that row alone, and the fall-off map is the full sensor's, so these rows
/// are bit for bit the full simulation's. A pair drawn as its statistics ([`Block::pair`])
/// shares its rows' draws with the full simulation, not its column means; and a window whose
/// rows are all described summarises a pair that the full frame, with a row near the full
/// well below it, draws pixel by pixel.
#[must_use]
pub fn simulate_rows(
    model: &GapModel,
    layout: &Acquisition,
    seed: u64,
    which: Option<&[usize]>,
    rows: usize,
    draws: &[Draws],
) -> Acquisition {
    let (w, full_h) = (layout.width, layout.height);
    let h = rows.min(full_h);
    let sensor = layout_sensor(model, layout);
    let pattern = fixed_pattern(&sensor, w, h);
    let photon_map = PhotonMap::new(model, layout, h);
    // The per-pixel constants of the moments (the same for every block: the model's patterns
    // and offsets), made by whichever block drawn from moments comes first.
    let constants = std::sync::OnceLock::new();
    // Pairs whose pixels the statistics read, not only their sums.
    let read_frames = stats::correlation_pairs(layout);
    let blocks = layout
        .blocks
        .par_iter()
        .enumerate()
        .map(|(bi, b)| {
            let (light, exposure_s, group) = (b.light, b.exposure_s, b.group);
            if which.is_some_and(|s| !s.contains(&bi)) {
                return Block::layout(light, exposure_s, group, 0);
            }
            let photons = photon_map.at(light.photons());
            let gain_db = layout.gains_db.get(group).copied().unwrap_or(0.0);
            let seeds: Vec<u64> = (0..b.frames.len()).map(|fi| frame_seed(seed, bi, fi)).collect();
            if seeds.is_empty() || draws.get(bi).copied().unwrap_or_default() == Draws::Pixels {
                let frames = seeds
                    .par_iter()
                    .map(|&s| {
                        let dn = sensor.simulate_with(&pattern, &photons, exposure_s, gain_db, s);
                        dn.into_iter().map(f32::from).collect()
                    })
                    .collect();
                return Block { frames, ..Block::layout(light, exposure_s, group, 0) };
            }
            let sims: Vec<FrameSimulator> =
                seeds.iter().map(|&s| sensor.frame_simulator(&pattern, exposure_s, gain_db, s)).collect();
            let constants = constants.get_or_init(|| sims[0].pixel_constants());
            let layout = Block::layout(light, exposure_s, group, sims.len());
            if sims.len() == 2
                && !read_frames.contains(&Some(bi))
                && let Some(sums) = PairMoments::of(&sims[0], constants, &photons, w)
            {
                return Block { pair: Some(moment_pair(&sims[0], &sums, seeds[0], w)), ..layout };
            }
            let moments = BlockMoments::of(&sims[0], constants, &photons, w);
            if sims.len() > 2 {
                Block { average: Some(moment_stack(&sims, &moments, &photons, seeds[0], w)), ..layout }
            } else {
                Block { frames: moment_frames(&sims, &moments, &photons, &seeds, w), ..layout }
            }
        })
        .collect();
    Acquisition { width: w, height: h, bits: layout.bits, blocks, gains_db: layout.gains_db.clone() }
}

/// The model's sensor with the layout's ADC depth.
fn layout_sensor(model: &GapModel, layout: &Acquisition) -> SensorModel {
    let mut sensor = model.sensor.clone();
    sensor.adc_bits = layout.bits;
    sensor
}

/// Mean photons per pixel of the first `rows` rows of a frame: uniform, or shaded by the
/// model's illumination fall-off (the full sensor's map, cut to the rows).
struct PhotonMap {
    falloff: IlluminationFalloff,
    /// Squared radius of each pixel, where the fall-off is on.
    r2: Option<Vec<f64>>,
    pixels: usize,
}

impl PhotonMap {
    fn new(model: &GapModel, layout: &Acquisition, rows: usize) -> PhotonMap {
        let (w, h) = (layout.width, rows.min(layout.height));
        let falloff = model.optics.illumination_falloff;
        let r2 = falloff.enabled.then(|| {
            let mut r2 = radius2_map(w, layout.height);
            r2.truncate(w * h);
            r2
        });
        PhotonMap { falloff, r2, pixels: w * h }
    }

    /// The map at `photons` on the axis.
    fn at(&self, photons: f64) -> Vec<f32> {
        match &self.r2 {
            Some(r2) => {
                r2.iter().map(|r| (photons * (1.0 - self.falloff.corner_loss_fraction * r)).max(0.0) as f32).collect()
            }
            None => vec![photons as f32; self.pixels],
        }
    }
}

/// The expected temporal variance of pair `block` of `layout` under `model`, DN^2 (half the
/// variance of the frames' difference): its pixels' mean output variance plus the row offset's,
/// from their moments ([`FrameSimulator::row_moments`]). `None` where a row is not described by
/// its moments; then only a pixel-drawn pair tells. The read-noise refit matches this to the
/// measured dark pair: it is linear in the read noise's variance, so the refit's secant ends in
/// a step or two, where a simulated pair would need a simulation each.
#[must_use]
pub fn pair_variance_from_moments(model: &GapModel, layout: &Acquisition, block: usize, seed: u64) -> Option<f64> {
    let b = layout.blocks.get(block)?;
    let (w, h) = (layout.width, layout.height);
    let sensor = layout_sensor(model, layout);
    let pattern = fixed_pattern(&sensor, w, h);
    let gain_db = layout.gains_db.get(b.group).copied().unwrap_or(0.0);
    let sim = sensor.frame_simulator(&pattern, b.exposure_s, gain_db, frame_seed(seed, block, 0));
    let photons = PhotonMap::new(model, layout, h).at(b.light.photons());
    let sums = PairMoments::of(&sim, &sim.pixel_constants(), &photons, w)?;
    let sum_v: f64 = sums.rows.iter().map(|r| r[2]).sum();
    Some(sum_v / (w * h).max(1) as f64 + sim.row_offset_sd_dn().powi(2))
}

/// The fixed patterns of `sensor` at `w x h`, from a cache of the last few: a search's
/// candidates mostly share them (a refit of K, the read noise or the black level leaves them
/// as they were), and drawing a 640x480 sensor's maps costs about a tenth of a simulation. A
/// pattern is a function of its key alone, so the cache never changes a value.
fn fixed_pattern(sensor: &SensorModel, w: usize, h: usize) -> Arc<FixedPattern> {
    // The effects `SensorModel::fixed_pattern` draws maps for (the row noise rides along with
    // the column noise: a few spurious misses, never a wrong hit).
    type Key = (u64, usize, usize, Dsnu, Prnu, HotPixels, RowColumnNoise);
    static CACHE: Mutex<Vec<(Key, Arc<FixedPattern>)>> = Mutex::new(Vec::new());
    let e = &sensor.effects;
    let key: Key = (sensor.pattern_seed, w, h, e.dsnu, e.prnu, e.hot_pixels, e.row_column_noise);
    let lock = || CACHE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some((_, p)) = lock().iter().find(|(k, _)| *k == key) {
        return Arc::clone(p);
    }
    let pattern = Arc::new(sensor.fixed_pattern(w, h));
    let mut cache = lock();
    cache.insert(0, (key, Arc::clone(&pattern)));
    cache.truncate(4);
    pattern
}

/// Row `r` of one frame, pixel by pixel ([`Draws::Pixels`]), as DN.
fn pixel_row(sim: &FrameSimulator, r: usize, photons: &[f32], out: &mut [f32]) {
    sim.row_dispatched(Dispatch::current(), r, photons, |c, y| out[c] = f32::from(sim.to_u16(y)));
}

/// The moments of every pixel of a block ([`FrameSimulator::row_moments`], the same for every
/// frame of it): per-pixel mean and standard deviation, and which rows they describe.
struct BlockMoments {
    mean: Vec<f64>,
    sd: Vec<f64>,
    described: Vec<bool>,
}

impl BlockMoments {
    fn of(sim: &FrameSimulator, constants: &PixelConstants, photons: &[f32], w: usize) -> BlockMoments {
        let (mut mean, mut sd) = (vec![0.0; photons.len()], vec![0.0; photons.len()]);
        let described = mean
            .par_chunks_mut(w.max(1))
            .zip(sd.par_chunks_mut(w.max(1)))
            .zip(photons.par_chunks(w.max(1)))
            .enumerate()
            .map(|(r, ((m, v), ph))| {
                let ok = sim.row_moments(constants, r, ph, m, v);
                v.iter_mut().for_each(|x| *x = x.sqrt());
                ok
            })
            .collect();
        BlockMoments { mean, sd, described }
    }
}

/// The frames of a block drawn by [`Draws::Moments`]: row `r` of frame `f` from
/// `rng::substream(seeds[f], "gap/moments", r)` (its row offset, then its pixels).
fn moment_frames(
    sims: &[FrameSimulator],
    moments: &BlockMoments,
    photons: &[f32],
    seeds: &[u64],
    w: usize,
) -> Vec<Vec<f32>> {
    sims.iter()
        .zip(seeds)
        .map(|(sim, &seed)| {
            let mut out = vec![0f32; photons.len()];
            out.par_chunks_mut(w.max(1)).zip(photons.par_chunks(w.max(1))).enumerate().for_each(|(r, (row, ph))| {
                if !moments.described[r] {
                    pixel_row(sim, r, ph, row);
                    return;
                }
                let span = r * w..(r + 1) * w;
                let mut rng = rng::substream(seed, "gap/moments", r as u64);
                let offset = sim.row_offset_sd_dn() * standard_normal(&mut rng);
                for ((o, m), sd) in row.iter_mut().zip(&moments.mean[span.clone()]).zip(&moments.sd[span]) {
                    *o = (m + offset + sd * standard_normal(&mut rng)) as f32;
                }
            });
            out
        })
        .collect()
}

/// The mean image of a stack drawn by [`Draws::Moments`]: each pixel of a row its moments
/// describe from the mean and variance of an average of L frames (the row offset averaged
/// too), from `rng::substream(seed, "gap/moments-stack", r)`; other rows as the average of
/// their L frames drawn pixel by pixel.
fn moment_stack(sims: &[FrameSimulator], moments: &BlockMoments, photons: &[f32], seed: u64, w: usize) -> Vec<f64> {
    let l = sims.len() as f64;
    let mut out = vec![0f64; photons.len()];
    out.par_chunks_mut(w.max(1)).zip(photons.par_chunks(w.max(1))).enumerate().for_each(|(r, (row, ph))| {
        if moments.described[r] {
            let span = r * w..(r + 1) * w;
            let mut rng = rng::substream(seed, "gap/moments-stack", r as u64);
            let offset = sims[0].row_offset_sd_dn() / l.sqrt() * standard_normal(&mut rng);
            for ((o, m), sd) in row.iter_mut().zip(&moments.mean[span.clone()]).zip(&moments.sd[span]) {
                *o = m + offset + sd / l.sqrt() * standard_normal(&mut rng);
            }
        } else {
            let mut frame_row = vec![0f32; w];
            for sim in sims {
                pixel_row(sim, r, ph, &mut frame_row);
                row.iter_mut().zip(&frame_row).for_each(|(o, &v)| *o += f64::from(v));
            }
            row.iter_mut().for_each(|o| *o /= l);
        }
    });
    out
}

/// Rows of a pair's moments summed at a time by [`PairMoments::of`]: a chunk's column sums
/// are its own, added in chunk order, so the sums do not depend on the thread count.
const PAIR_ROWS_PER_CHUNK: usize = 16;

/// What [`moment_pair`] reads of a block's pixel moments: per row the sum of the means, their
/// sum of squares about the row's mean, the sum of the variances and of their squares; per
/// column the sums of the means and of the variances. Summed row by row as the moments are
/// computed, so a pair costs one pass over its pixel constants and no per-pixel image.
struct PairMoments {
    rows: Vec<[f64; 4]>,
    col_m: Vec<f64>,
    col_v: Vec<f64>,
}

impl PairMoments {
    /// The sums of the block of `photons`; `None` when a row is not described by its moments
    /// ([`FrameSimulator::row_moments`]), and the pair is drawn frame by frame. The first such
    /// row stops every chunk, so a pair that falls back wastes few rows' moments.
    fn of(sim: &FrameSimulator, constants: &PixelConstants, photons: &[f32], w: usize) -> Option<PairMoments> {
        let w = w.max(1);
        let chunk = w * PAIR_ROWS_PER_CHUNK;
        let undescribed = AtomicBool::new(false);
        let chunks: Vec<Option<PairMoments>> = photons
            .par_chunks(chunk)
            .enumerate()
            .map(|(ci, ph)| {
                let (mut mean, mut var) = (vec![0.0; w], vec![0.0; w]);
                let mut sums = PairMoments { rows: Vec::new(), col_m: vec![0.0; w], col_v: vec![0.0; w] };
                for (j, row) in ph.chunks(w).enumerate() {
                    if undescribed.load(Ordering::Relaxed)
                        || !sim.row_moments(constants, ci * PAIR_ROWS_PER_CHUNK + j, row, &mut mean, &mut var)
                    {
                        undescribed.store(true, Ordering::Relaxed);
                        return None;
                    }
                    sums.rows.push(row_sums(&mean, &var));
                    sums.col_m.iter_mut().zip(&mean).for_each(|(c, x)| *c += x);
                    sums.col_v.iter_mut().zip(&var).for_each(|(c, v)| *c += v);
                }
                Some(sums)
            })
            .collect();
        let mut all =
            PairMoments { rows: Vec::with_capacity(photons.len() / w), col_m: vec![0.0; w], col_v: vec![0.0; w] };
        for c in chunks {
            let c = c?;
            all.rows.extend(c.rows);
            all.col_m.iter_mut().zip(&c.col_m).for_each(|(a, x)| *a += x);
            all.col_v.iter_mut().zip(&c.col_v).for_each(|(a, x)| *a += x);
        }
        Some(all)
    }
}

/// `[sum m, sum (m - mean m)^2, sum v, sum v^2]` of one row's pixel means `m` and variances
/// `v`: one pass over four interleaved lanes (independent additions), the means taken about
/// the row's first so that the sum of squares does not cancel.
fn row_sums(mean: &[f64], var: &[f64]) -> [f64; 4] {
    const LANES: usize = 4;
    let Some(&m0) = mean.first() else { return [0.0; 4] };
    let mut lanes = [[0.0f64; LANES]; 4];
    let (m_chunks, v_chunks) = (mean.chunks_exact(LANES), var.chunks_exact(LANES));
    let (m_tail, v_tail) = (m_chunks.remainder(), v_chunks.remainder());
    for (m, v) in m_chunks.zip(v_chunks) {
        for l in 0..LANES {
            let d = m[l] - m0;
            lanes[0][l] += d;
            lanes[1][l] += d * d;
            lanes[2][l] += v[l];
            lanes[3][l] += v[l] * v[l];
        }
    }
    let mut sums = lanes.map(|l| l.iter().sum::<f64>());
    for (m, v) in m_tail.iter().zip(v_tail) {
        let d = m - m0;
        sums[0] += d;
        sums[1] += d * d;
        sums[2] += v;
        sums[3] += v * v;
    }
    let n = mean.len() as f64;
    [n * m0 + sums[0], (sums[1] - sums[0] * sums[0] / n).max(0.0), sums[2], sums[3]]
}

/// The statistics of a temporal pair drawn by [`Draws::Moments`], every row of it described by
/// its moments, without drawing its pixels: what [`stats`] reads of a pair are its row and
/// column means and its sums of squares, and with each pixel Gaussian about its moments these
/// are drawn directly from the sums of its pixels' moments ([`PairMoments`]). Per row, from
/// `rng::substream(seed, "gap/moment-pair", 0)` in row order: the two frames' row offsets, the
/// noise of the row's sum of the average and of the difference (Gaussian, of variance
/// `sum v / 2` and `sum v`), and the spread of the difference about its row mean
/// (`sum v (1 - 1 / w)`, variance `2 sum v^2`: a sum of `w` weighted chi-squares, Gaussian to
/// `O(w^-1/2)`); then the noise of each column's mean. The sums of squares of the average and
/// the fourth moment of the difference, which only size sampling variances, are their
/// expectations. A row's draws are the same whatever the model, so candidates keep their
/// common random numbers.
fn moment_pair(sim: &FrameSimulator, sums: &PairMoments, seed: u64, w: usize) -> stats::PairStats {
    let w = w.max(1);
    let (wf, h) = (w as f64, sums.rows.len());
    let (rows, col_m, col_v) = (&sums.rows, &sums.col_m, &sums.col_v);
    let mut rng = rng::substream(seed, "gap/moment-pair", 0);
    let mut z = || standard_normal(&mut rng);
    let row_sd = sim.row_offset_sd_dn();
    let (mut row_avg, mut row_diff, mut spread) = (Vec::with_capacity(h), Vec::with_capacity(h), Vec::with_capacity(h));
    let mut offsets = 0.0;
    for &[sum_m, _, sum_v, sum_v2] in rows {
        let (o1, o2) = (row_sd * z(), row_sd * z());
        offsets += 0.5 * (o1 + o2);
        row_avg.push((sum_m + (0.5 * sum_v).sqrt() * z()) / wf + 0.5 * (o1 + o2));
        row_diff.push((o1 - o2) / std::f64::consts::SQRT_2 + sum_v.sqrt() * z() / wf);
        spread.push((sum_v * (1.0 - 1.0 / wf) + (2.0 * sum_v2).sqrt() * z()).max(0.0));
    }
    let col_avg = col_m.iter().zip(col_v).map(|(m, v)| (m + offsets + (0.5 * v).sqrt() * z()) / h as f64).collect();
    let (m, md) = (stats::mean(&row_avg), stats::mean(&row_diff));
    let (mut s2a, mut s2d, mut s4d) = (0.0, 0.0, 0.0);
    for (((&[_, ss_m, sum_v, sum_v2], a), d), q) in rows.iter().zip(&row_avg).zip(&row_diff).zip(&spread) {
        let delta = d - md;
        s2a += ss_m + 0.5 * sum_v * (1.0 - 1.0 / wf) + wf * (a - m) * (a - m);
        s2d += q + wf * delta * delta;
        s4d += 3.0 * sum_v2 + 6.0 * sum_v * delta * delta + wf * delta.powi(4);
    }
    stats::PairSums { row_avg, row_diff, col_avg, s2a, s2d, s4d }.finish()
}

impl Acquisition {
    /// The first `rows` rows of every frame (the sensor window [`simulate_rows`] simulates) of an
    /// acquisition that holds its pixels (a measurement).
    #[must_use]
    pub fn top_rows(&self, rows: usize) -> Acquisition {
        let h = rows.min(self.height);
        let blocks = self
            .blocks
            .iter()
            .map(|b| Block {
                light: b.light,
                exposure_s: b.exposure_s,
                group: b.group,
                frames: b.frames.iter().map(|f| f[..(self.width * h).min(f.len())].to_vec()).collect(),
                average: b.average.as_ref().map(|a| a[..(self.width * h).min(a.len())].to_vec()),
                // Sums of the whole frame cannot be cut to its top rows.
                pair: None,
            })
            .collect();
        Acquisition { width: self.width, height: h, bits: self.bits, blocks, gains_db: self.gains_db.clone() }
    }
}

/// The start model: the EMVA 1288 linear model of the calibration (K, QE, read noise) at the
/// descriptor's bit depth, every effect off but quantization.
pub fn start_model(path: &Path, seed: u64) -> Result<GapModel, GapError> {
    let cal = calibration::calibrate_emva(path)?;
    let mut sensor = cal.to_sensor_model("measured", seed);
    sensor.adc_bits = cal.adc_bits.unwrap_or(sensor.adc_bits);
    let q = sensor.effects.quantization;
    sensor.effects = scene_gen_camera::sensor::noise::Effects { quantization: q, ..Default::default() };
    sensor.effects.quantization.enabled = true;
    sensor.validate()?;
    Ok(GapModel { sensor, optics: Optics::default() })
}

/// One accepted step of the search.
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    pub effect: String,
    pub params: serde_json::Value,
    pub gap_before: f64,
    pub gap_after: f64,
    /// Drop of the total chi-square, the BIC penalty it had to beat, and the families that
    /// improved.
    pub evidence: String,
    /// The families left unexplained (or elevated) at the end ([`misfit`]) that the effect's evidence rests
    /// on: it may stand in for what the library lacks, so it is reported as tentative, not
    /// named.
    pub entangled: Vec<&'static str>,
}

/// One candidate tried in a round (for the report).
#[derive(Debug, Clone, Serialize)]
pub struct Trial {
    pub round: usize,
    pub effect: String,
    pub chi2_drop: f64,
    pub penalty: f64,
    pub gap_after: f64,
    /// True: only screened on the top rows of the sensor (see [`GapOptions::screen`]); the drop
    /// is then the chi-square drop on that window, and `gap_after` is NaN (not simulated).
    pub screened: bool,
}

/// The result of the workflow.
#[derive(Debug, Clone)]
pub struct GapResult {
    pub initial: GapModel,
    pub final_model: GapModel,
    pub measured: stats::Stats,
    pub initial_stats: stats::Stats,
    pub final_stats: stats::Stats,
    pub gap_initial: stats::Gap,
    pub gap_final: stats::Gap,
    pub steps: Vec<Step>,
    pub trials: Vec<Trial>,
    /// Gain of each input group as finally fitted, dB (group 0 the reference).
    pub gains_db: Vec<f64>,
    /// Whole-acquisition simulations the search ran (the read-noise refit's dark-pair
    /// simulations and the screening windows not counted).
    pub simulations: usize,
    /// Evaluations answered from the search's cache of recent models instead of simulated.
    pub cached_evaluations: usize,
    /// The leftover misfit tested against replicates of the final model (None: not tested).
    pub misfit: Option<misfit::MisfitCheck>,
}

impl GapResult {
    /// Effects the workflow added, in the order it added them, less the tentative ones.
    #[must_use]
    pub fn named(&self) -> Vec<String> {
        self.steps.iter().filter(|s| s.entangled.is_empty()).map(|s| s.effect.clone()).collect()
    }

    /// Effects the workflow added whose evidence lies in a family left unexplained: they lower
    /// the misfit, but may stand in for an effect outside the library.
    #[must_use]
    pub fn tentative(&self) -> Vec<String> {
        self.steps.iter().filter(|s| !s.entangled.is_empty()).map(|s| s.effect.clone()).collect()
    }

    /// Families whose leftover misfit is larger than noise ([`misfit`]).
    #[must_use]
    pub fn unexplained(&self) -> Vec<&'static str> {
        self.misfit.as_ref().map(misfit::MisfitCheck::unexplained_families).unwrap_or_default()
    }
}

/// Response slope of gain group `group` (DN per photon): least squares of the pair means minus
/// the dark pair nearest in exposure, over the steps in the lower 40 % of the range above dark.
/// Every group is fitted over the same DN window, so a nonlinearity (a function of DN) biases
/// every group's slope alike and their ratio, the relative gain, stays unbiased.
fn group_slope(acq: &Acquisition, group: usize) -> Option<f64> {
    let pair_mean = |b: &Block| -> f64 {
        let s: f64 = b.frames.iter().flat_map(|f| f.iter()).map(|&v| f64::from(v)).sum();
        s / (b.frames.len() * b.frames[0].len()).max(1) as f64
    };
    let pairs = || acq.blocks.iter().filter(|b| b.group == group && b.frames.len() == 2);
    let darks: Vec<(f64, f64)> =
        pairs().filter(|b| b.light == Light::Dark).map(|b| (b.exposure_s, pair_mean(b))).collect();
    let max = f64::from((1u32 << acq.bits) - 1);
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    for b in pairs() {
        let Light::Bright(p) = b.light else { continue };
        let &(_, d) = darks.iter().min_by(|a, c| (a.0 - b.exposure_s).abs().total_cmp(&(c.0 - b.exposure_s).abs()))?;
        let y = pair_mean(b) - d;
        if y <= 0.4 * (max - d) {
            xs.push(p);
            ys.push(y);
        }
    }
    if xs.len() < 2 {
        return None;
    }
    // Through the origin: the signal above dark is zero without light.
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| x * y).sum();
    let sxx: f64 = xs.iter().map(|x| x * x).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Loads several descriptors of one camera, taken at different gains, as one acquisition: file
/// `i` becomes gain group `i`. EMVA 1288 descriptors do not state the gain, so it is measured:
/// the ratio of each file's response slope to the first file's (`group_slope`), the first file
/// at 0 dB. The workflow refines these ratios as nuisance parameters.
pub fn load_acquisitions(paths: &[PathBuf], options: &GapOptions) -> Result<Acquisition, GapError> {
    let first = paths.first().ok_or_else(|| GapError::Unusable { path: PathBuf::new(), message: "no input".into() })?;
    let mut acq = load_acquisition(first, options)?;
    for (i, path) in paths.iter().enumerate().skip(1) {
        let next = load_acquisition(path, options)?;
        if (next.width, next.height, next.bits) != (acq.width, acq.height, acq.bits) {
            return Err(GapError::Unusable {
                path: path.clone(),
                message: format!(
                    "{} x {} pixels at {} bit; expected {} x {} at {} bit as in {} (one camera, several gains)",
                    next.width,
                    next.height,
                    next.bits,
                    acq.width,
                    acq.height,
                    acq.bits,
                    first.display()
                ),
            });
        }
        acq.blocks.extend(next.blocks.into_iter().map(|b| Block { group: i, ..b }));
        acq.gains_db.push(0.0);
    }
    let base = group_slope(&acq, 0);
    for (i, path) in paths.iter().enumerate().skip(1) {
        let slope = base.zip(group_slope(&acq, i)).filter(|(a, b)| *a > 0.0 && *b > 0.0);
        let Some((a, b)) = slope else {
            return Err(GapError::Unusable {
                path: path.clone(),
                message: "cannot measure its gain relative to the first input: each input needs a dark pair and 2 bright pairs in the lower 40 % of the range".into(),
            });
        };
        acq.gains_db[i] = 20.0 * (b / a).log10();
    }
    Ok(acq)
}

/// Is `path` a photon-transfer CSV (by its extension)?
#[must_use]
pub fn is_csv(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv"))
}

/// Runs the workflow on one measurement of a camera: an EMVA 1288 descriptor, several
/// descriptors of the same camera at different gains (see [`load_acquisitions`]), or one
/// photon-transfer CSV (see [`csv`]); from the calibrated start model, or from `model`.
pub fn run_inputs(paths: &[PathBuf], model: Option<GapModel>, options: &GapOptions) -> Result<GapResult, GapError> {
    let Some(first) = paths.first() else {
        return Err(GapError::Unusable { path: PathBuf::new(), message: "no measured input given".into() });
    };
    if paths.iter().any(|p| is_csv(p)) {
        if paths.len() > 1 {
            return Err(GapError::Unusable {
                path: first.clone(),
                message: "a photon-transfer CSV holds every gain itself: give it alone".into(),
            });
        }
        return csv::run(first, model, options);
    }
    let refine = model.is_none();
    // The start model is calibrated from the descriptor's files (every stack frame) while the
    // acquisition loads; load errors are reported first, as if one ran after the other.
    let (measured, start) = rayon::join(
        || load_acquisitions(paths, options),
        || match model {
            Some(m) => Ok(m),
            None => start_model(first, options.seed),
        },
    );
    let measured = measured?;
    let unusable = |message: String| GapError::Unusable { path: first.clone(), message };
    let pairs = measured
        .blocks
        .iter()
        .filter(|b| b.group == 0 && b.frames.len() == 2 && matches!(b.light, Light::Bright(_)))
        .count();
    if pairs < 3 {
        return Err(unusable(format!("{pairs} bright pairs; the photon transfer needs at least 3")));
    }
    if !measured.blocks.iter().any(|b| b.group == 0 && b.frames.len() == 2 && b.light == Light::Dark) {
        return Err(unusable("no dark pair ('d' block with 2 images)".into()));
    }
    let start = start?;
    let t = stats::thresholds(&measured);
    let mut m = stats::compute(&measured, &t);
    m.thresholds = Some(t);
    Ok(fit::search(&measured, m, false, start, refine, options))
}

/// Runs the workflow on one descriptor (see [`run_inputs`]).
pub fn run(path: &Path, model: Option<GapModel>, options: &GapOptions) -> Result<GapResult, GapError> {
    run_inputs(&[path.to_path_buf()], model, options)
}
