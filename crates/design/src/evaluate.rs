//! The evaluator: perception scores of one camera candidate, TaCOS style
//! (reference/tacos_facts.md), over seeded houses.
//!
//! Per seed the house is generated with the default configuration, the agent's walk is planned
//! at the spec's mounting height and at [`EvalConfig::speed_m_s`] ([`scene_gen_scene::trajectory`]; poses
//! every 0.25 m), and frames are rendered at [`EvalConfig::frames_per_scene`] *anchor* poses
//! evenly spaced along the walk. Each anchor is rendered together with its successor pose
//! (0.25 m later) so ORB has a genuine consecutive pair to match: anchors alone are metres apart
//! and would give zero inliers whatever the camera. The poses in the 0.5 s window before every
//! threshold crossing are rendered as well, for threshold visibility only (the same window test
//! as the score, so no window pose is left out): ids only, traced over the pixels each
//! threshold's box can cover ([`scene_gen_render::Camera::box_pixels`]), which counts exactly the
//! pixels a whole frame would.
//!
//! ONE trace per pose serves day and night: the light groups are scaled so the mean
//! illuminance on the 0.75 m plane is 20 lux by day and 2 lux by night, exactly as
//! `scene-gen render` does ([`scenario_light_scales`]). Per scenario (day at the spec's
//! `gain_day_db`, night at `gain_night_db`) the noisy sensor image becomes the 8-bit grey image
//! ORB and the detector see by [`EvalConfig::output`]: by default a fixed ISP (black level, a
//! digital gain fixed per scenario that puts an 18 % grey at the scenario's lux at the same
//! output level by day and night, sRGB curve; [`scene_gen_camera::isp`]), or the old top 8 bits of the ADC.
//!
//! # Agent speed and the threshold window
//!
//! TaCOS does not state its agent's speed; it is [`EvalConfig::speed_m_s`] (`--speed-m-s`),
//! 1.0 m/s by default ([`scene_gen_scene::trajectory::DEFAULT_SPEED_M_PER_S`] says why), so the 0.5 s
//! window is 0.5 m of walk. The agent *crosses* a threshold when its body (a disc of the walk's
//! radius, 0.25 m) first touches the sill's footprint ([`EvalConfig::crossing_at_contact`]; the
//! time is interpolated between poses): an obstacle must be seen before the body reaches it, not
//! before the camera centre passes the door. With the old 0.5 m/s and the crossing at the first
//! pose beyond the door plane, the window was the last 0.25 m before the plane, where the sill is
//! under the lower field edge of any camera not pointed steeply down (IMX174 4 mm at -10 deg and
//! 0.8 m sees the floor from 0.63 m ahead), and the default camera scored 0.
//!
//! Measured (`scene-gen evaluate --camera C --seeds 0..2`, 25 anchors, 320 px, houses 0 and 1,
//! 20 crossings), threshold accuracy:
//!
//! | camera | before (0.5 m/s, door plane) | now (1.0 m/s, contact) |
//! | --- | --- | --- |
//! | IMX174, 4 mm, pitch -10 deg (default) | 0.00 (0/20) | 0.80 (16/20) |
//! | IMX172, 20 mm, pitch +30 deg (up, long lens, small sensor) | 0.00 | 0.00 (0/20) |
//!
//! # Scores per scenario
//!
//! * threshold accuracy ([`thresholds::threshold_score`]); the visible-pixel floor is
//!   [`thresholds::DEFAULT_MIN_VISIBLE_PX`] at 640 x 480, scaled with the pixel count so tiny
//!   evaluation images are not penalised for their size. It is geometric, so it is the same in
//!   both scenarios;
//! * AP@0.5 of the detector against the instance buffer's ground truth ([`frame_ground_truth`]),
//!   [`coco_eval::evaluate`] over every anchor of every seed (an AP of -1, no ground truth at
//!   all, counts as 0). The detector is the built-in [`DetectabilityModel`] or an external
//!   program ([`EvalConfig::detector`], `--detector "CMD ARGS"`) run once per evaluation under
//!   the plug-in protocol of [`scene_gen_perception::detection`] on the anchors' 8-bit PNGs written to a
//!   temporary folder, with a COCO ground-truth file beside them (`{gt}` in the command is its
//!   path); its answers are scored by the same COCO code;
//! * ORB (2000 features, cross-checked matches, fundamental RANSAC at 3 px) on each
//!   (anchor, successor) pair: mean inliers per pair, and the mean inlier ratio
//!   `inliers / (inliers + keypoints)`, keypoints of the anchor frame (tacos_facts.md);
//! * usable images: anchors whose 8-bit image is neither nearly black nor saturated (mean in
//!   [[`USABLE_MIN_MEAN`], [`USABLE_MAX_MEAN`]] and fewer than [`USABLE_MAX_CLIPPED_FRACTION`] of
//!   the pixels at 0 or 255) and that hold at least one counted ground-truth object. TaCOS
//!   scores a candidate with fewer than 100 usable images on the threshold term only; here the
//!   floor is [`EvalConfig::min_usable_images`] (`--min-usable`), by default half the
//!   scenario's anchors ([`DEFAULT_MIN_USABLE_FRACTION`]), because an absolute 100 against
//!   25 anchors x 2 houses would zero every candidate;
//! * fitness = threshold accuracy + AP@0.5 + 0.0025 x mean inliers + 0.5 x inlier ratio
//!   (weights in [`FitnessWeights`]), or the threshold term alone below the usable floor.
//!
//! # Day versus night (issue 5: night should score no higher than day)
//!
//! * **Render speckle (fixed).** The light-culling roulette counted the sun's unshadowed
//!   illuminance in the day group's total, so behind walls and in corners the window lights were
//!   traced at random with weights up to 10x: salt-and-pepper by day, taken by ORB for corners
//!   and by the detector for noise. The sun is now always traced and left out of that total
//!   ([`scene_gen_render::LightSet::direct`]; docs/BENCHMARKS.md, "Speckle in preview day frames").
//! * **Black day frames (open).** [`RenderSettings::preview`] traces no bounce light, so by day
//!   every surface neither the sun nor a window reaches directly (window-less rooms, the hall,
//!   shadowed walls) is exactly black, while at night every room has its ceiling light. A
//!   camera with a narrow view often sees only such a surface, and its day frame has most
//!   pixels at 0: not usable ([`USABLE_MAX_CLIPPED_FRACTION`]). Saturation adds little: no day
//!   frame of these runs had more than 37 % of its pixels at 255, against up to 97 % at 0
//!   (the ADC clips on sun patches, little else). Measured on the default optimizer run
//!   (`--seeds 0..3`, 25 anchors, 320 px, 75 anchors per scenario, usable floor 38; day /
//!   night fitness; usable images in brackets):
//!
//!   | candidate | sun in the cull total | sun traced apart (now) | and one bounce ray |
//!   | --- | --- | --- | --- |
//!   | MT9V032, 16.09 mm, -8.46 deg | 0 (25) / 1.27 (43) | 0 (34) / 1.27 (43) | 1.82 (42) / 1.54 (44) |
//!   | IMX250, 10.47 mm, -1.53 deg | 0 (37) / 1.65 (57) | 2.40 (50) / 1.66 (57) | 2.28 (55) / 1.98 (57) |
//!
//!   One bounce ray per pixel (`indirect_rays: 1`, `scene-gen evaluate --bounce-rays 1`) costs 1.8x to 1.9x the CPU time of a
//!   candidate (MT9V032: 29.6 to 53.1 s user time). Not an exposure problem: an auto-exposure
//!   cannot brighten radiance that is exactly zero.
//! * **Detector noise (fixed).** The built-in [`DetectabilityModel`] divided contrast by a
//!   noise measured on the image, and by day that measured the renderer's one-sample
//!   area-light noise on window-lit surfaces, not the sensor's: 8.1 DN by day against 4.1 at
//!   night, where the sensor's own share (noisy minus noiseless capture) is 0.9 and 4.6 DN.
//!   Day scored as the noisier scenario: AP@0.5 rose with noise by day (IMX172 on house 0,
//!   0.6 at 1/30 s, 1.0 at 1 ms) and the default camera scored day 0.74 / night 0.97.
//!   The detector is now told the camera's noise at each output level
//!   ([`scene_gen_perception::detection::output_noise`], from the sensor model through the ISP), its contrast
//!   is corrected for what pixel noise adds to it, and day and night of a pose share the
//!   detector's draws (common random numbers). Day AP now falls with noise (1.0 to 0.4 on
//!   that case).
//! * **Lighting contrast (open, not the camera).** AP@0.5 of the default camera
//!   (`scene-gen evaluate --camera IMX174,focal_mm=4,pitch_deg=-10 --seeds 0..2`, 25 anchors,
//!   320 px): day 0.895 / night 0.944 (was 0.739 / 0.972); houses 2 and 3: 0.886 / 0.905.
//!   Over the 120 objects of houses 0 and 1 the mean detection probability is 0.90 by day
//!   and 0.94 at night (0.95 / 0.94 without the contrast correction, the day frames' sampling
//!   noise making weak contrasts look stronger); 12 objects lose more than 0.1 by day and 11
//!   gain. The losers have a mean contrast of 1.7 DN against their surroundings by day and
//!   19.5 DN at night: window light from the side, without bounce, leaves them at the level
//!   of what is behind them, the ceiling lamps do not. That is the scene's lighting (and the
//!   preview render), not the camera; and AP@0.5 averages over classes, so a few objects of
//!   a rare class swing it. Neither a cleaner render (8 x 8 area-light samples, no culling:
//!   0.903 / 0.949) nor one bounce ray (0.933 / 0.965) reverses it
//!   (`examples/daynight_objects.rs` prints the per-object figures). Threshold accuracy is
//!   geometric (equal), and ORB inliers are lower at night.
//!
//! Frames are rendered and scored in parallel (rayon); every random draw is seeded by the
//! seed, pose index and scenario (the built-in detector's by seed and pose only, shared by
//! both scenarios), and results are gathered in pose order, so the output does not
//! depend on the thread count. Results are cached per process, keyed by the normalised spec
//! (its JSON), the seeds and every configuration field (speed, output rule, usable floor,
//! detector, render settings). [`Evaluation::timing_s`] says where the time went (not
//! deterministic; the CLI prints it with `--timing`). Its `sensor` figure is wall time on the
//! pose's worker thread: the stage's rows are nested rayon tasks, and a thread waiting for them
//! may run other poses' rendering meanwhile, so it overstates the stage (docs/BENCHMARKS.md,
//! "The evaluator's sensor + ISP stage", compares it with a profile). Both scenarios' 8-bit
//! images come from one fused pass over the frame ([`scene_gen_camera::isp::capture_8bit`]).

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use scene_gen_camera::camera_spec::{CameraSpec, NoiseKind, ResolvedCamera, SpecError};
use scene_gen_camera::isp::{Isp, OutputRule, Scenario, capture_8bit};
use scene_gen_camera::optics::{OpticsInput, agent_velocity};
use scene_gen_camera::sensor::Catalog;
use scene_gen_perception::detection::coco_eval::{self, CocoCategory, CocoGroundTruth, CocoImage, DetectionRecord};
use scene_gen_perception::detection::ground_truth::to_annotations;
use scene_gen_perception::detection::output_noise::output_noise_by_level;
use scene_gen_perception::detection::plugin::{self, PluginError, PluginRequest};
use scene_gen_perception::detection::thresholds::{self, Crossing, FrameVisibility, ThresholdConfig};
use scene_gen_perception::detection::{
    DetectabilityModel, Detector, DetectorInput, GroundTruthConfig, NoiseSource, frame_ground_truth,
};
use scene_gen_perception::orb::{FundamentalRansac, Orb, match_and_verify};
use scene_gen_render::{Frame, RenderError, RenderSettings, Renderer, ShadingRate, measure_mean_illuminance};
use scene_gen_scene::house::{HouseError, WalkedHouse, embedded_library, walked_house};
use scene_gen_scene::lights::{DAY_TARGET_LUX, NIGHT_TARGET_LUX, TARGET_PLANE_M};
use scene_gen_scene::scene::{LightGroup, ObjectClass, THRESHOLD_CLASS_ID, THRESHOLD_CLASS_NAME};
use scene_gen_scene::trajectory::{self, TrajectoryParams};

/// Default anchor frames per house: small, so a candidate evaluates in seconds.
pub const DEFAULT_FRAMES_PER_SCENE: u32 = 25;
/// Default binned width of the evaluation images, px.
pub const DEFAULT_MAX_WIDTH_PX: u32 = 320;
/// Default agent speed, m/s ([`trajectory::DEFAULT_SPEED_M_PER_S`], which says why).
pub const DEFAULT_SPEED_M_S: f64 = trajectory::DEFAULT_SPEED_M_PER_S as f64;
/// ORB features per frame (tacos_facts.md: 2000).
pub const ORB_FEATURES: usize = 2000;
/// Pixel count the threshold visibility floor is given for (640 x 480).
const VGA_PIXELS: f64 = 640.0 * 480.0;
/// An 8-bit image whose mean is below this is "nearly black" (not usable): about 4 % of full
/// scale, where even the ISP's mid-grey target (118) is 12x away. Engineering choice.
pub const USABLE_MIN_MEAN: f64 = 10.0;
/// An 8-bit image whose mean is above this is "nearly saturated" (not usable). Engineering choice.
pub const USABLE_MAX_MEAN: f64 = 245.0;
/// An image with at least this fraction of its pixels at 0 or 255 is not usable.
pub const USABLE_MAX_CLIPPED_FRACTION: f64 = 0.5;
/// Default floor of usable images, as a fraction of a scenario's anchor frames (rounded up).
/// TaCOS's floor is an absolute 100 images out of a frame count it does not publish; with the
/// default 25 anchors x 2 houses the absolute 100 would zero every candidate. Half the anchors
/// keeps the rule's intent (a candidate that sees something on too few frames is not scored on
/// detection and ORB) at any frame count.
pub const DEFAULT_MIN_USABLE_FRACTION: f64 = 0.5;

/// Frames at least this wide are shaded at anchors ([`ShadingRate::Adaptive`]) by the evaluator:
/// all of them. Full-rate shading made a 320 px candidate 8x dearer than anchors (session 8: 24
/// against 3.0 user-s on the default camera, houses 0 and 1) for day / night inliers of 147 /
/// 132 against 123 / 125 and the same AP; the setting of session 9 takes 2.4 user-s there for
/// 118 / 120 (docs/BENCHMARKS.md, "Session 9").
pub const EVAL_DECOUPLED_MIN_WIDTH_PX: u32 = 0;
/// Anchor spacing of the evaluator's decoupled shading, pixels.
pub const EVAL_DECOUPLED_STRIDE: u32 = 4;
/// Visibility samples per axis of each window at each anchor of the evaluator's render (four in
/// all, pooled with the neighbours': [`EVAL_VISIBILITY_FILTER_RADIUS`]).
pub const EVAL_RECT_SAMPLES_PER_AXIS: u32 = 2;
/// Anchors either way whose window visibility each anchor of the evaluator's render pools
/// ([`RenderSettings::visibility_filter_radius`]): with the adaptive grid's coarse anchors two
/// apart, 3 x 3 of them, 36 interleaved samples.
pub const EVAL_VISIBILITY_FILTER_RADIUS: u32 = 2;

/// The evaluator's ray-tracer settings: [`RenderSettings::preview`] (one ray per pixel through
/// its centre, no bounce) with every light traced (no culling roulette),
/// [`EVAL_RECT_SAMPLES_PER_AXIS`]^2 visibility samples per window at each anchor pooled over
/// [`EVAL_VISIBILITY_FILTER_RADIUS`] anchors, and [`ShadingRate::Adaptive`] shading
/// (irradiance at anchors every [`EVAL_DECOUPLED_STRIDE`] pixels, filled coarse to fine and
/// interpolated over the same surface) on frames of any width ([`EVAL_DECOUPLED_MIN_WIDTH_PX`]).
///
/// Why anchors: shadow rays and light selection are most of a frame's cost and nearly all of it
/// is irradiance, which varies slowly over a surface, while texture and edges, which ORB and
/// the detector see, are still sampled at every pixel (docs/BENCHMARKS.md, "Decoupled shading",
/// "Adaptive anchors").
///
/// Why pooled window samples and no roulette: the render's own noise must stay well below what
/// the features and detections respond to. Since each view draws its own random numbers
/// ([`scene_gen_render::Camera::view_key`]), render noise is new in every frame, as a real
/// scene's is not, and it costs ORB inliers: on the default camera at 1936 px (seeds 0..2),
/// one window sample and culling gave 103 day inliers per pair where 16 samples per anchor
/// give 360. Nine samples per anchor at stride 3 (session 8) gave 307 in 38.7 s; four per
/// anchor pooled over their neighbours at stride 4 give 341 (night 228 of 233) in 29.8 s
/// (docs/BENCHMARKS.md, "Session 9").
///
/// Known problems (module docs, "Day versus night"): without bounce light, surfaces no sun or
/// window reaches directly are black by day, so narrow cameras lose usable day frames; one
/// bounce ray (`indirect_rays: 1`) restores them at about twice the CPU time. Set
/// [`EvalConfig::render`] (and `render_name`) to use others; `scene-gen evaluate
/// --bounce-rays N` adds N bounce rays per pixel.
#[must_use]
pub fn eval_render_settings() -> RenderSettings {
    RenderSettings {
        shading: ShadingRate::Adaptive { stride: EVAL_DECOUPLED_STRIDE, min_width_px: EVAL_DECOUPLED_MIN_WIDTH_PX },
        rect_samples_per_axis: EVAL_RECT_SAMPLES_PER_AXIS,
        visibility_filter_radius: EVAL_VISIBILITY_FILTER_RADIUS,
        light_cull: 0.0,
        ..RenderSettings::preview()
    }
}

/// Temporal-noise seed of the capture of pose `pose` of house `seed` in scenario `scenario`
/// (`"day"`, `"night"`): what the evaluator uses, for tools that replay its frames.
#[must_use]
pub fn capture_seed(seed: u64, pose: usize, scenario: &str) -> u64 {
    scene_gen_core::rng::fnv1a64(format!("evaluate/{seed}/{pose}/{scenario}").as_bytes())
}

/// The built-in detector's draw seed for pose `pose` of house `seed`, one for both scenarios
/// (common random numbers).
#[must_use]
pub fn detector_seed(seed: u64, pose: usize) -> u64 {
    scene_gen_core::rng::fnv1a64(format!("evaluate/detector/{seed}/{pose}").as_bytes())
}

/// Weights of the fitness terms.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FitnessWeights {
    pub threshold: f64,
    pub ap50: f64,
    pub inliers: f64,
    pub inlier_ratio: f64,
}

impl Default for FitnessWeights {
    /// TaCOS (tacos_facts.md): 1, 1, 0.0025, 0.5.
    fn default() -> Self {
        FitnessWeights { threshold: 1.0, ap50: 1.0, inliers: 0.0025, inlier_ratio: 0.5 }
    }
}

/// An external detector program run under the plug-in protocol of [`scene_gen_perception::detection`].
///
/// In `args`, `{gt}` is replaced by the path of the COCO ground-truth file scene-gen writes next
/// to the images (what `examples/detector_plugin/oracle_detector.py --gt {gt}` answers from) and
/// `{dir}` by the image folder.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ExternalDetector {
    pub program: String,
    pub args: Vec<String>,
}

impl ExternalDetector {
    /// Splits a command line on whitespace (no shell quoting): `"python3 det.py --gt {gt}"`.
    /// `None` for a blank command.
    #[must_use]
    pub fn parse(command: &str) -> Option<ExternalDetector> {
        let mut words = command.split_whitespace().map(str::to_string);
        let program = words.next()?;
        Some(ExternalDetector { program, args: words.collect() })
    }
}

/// How a candidate is evaluated.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EvalConfig {
    /// Anchor poses per house, evenly spaced along the walk.
    pub frames_per_scene: u32,
    /// Bin the sensor down to at most this width (`None`: the spec's own `max_width_px`).
    pub max_width_px: Option<u32>,
    /// Ray-tracer settings.
    #[serde(skip)]
    pub render: RenderSettings,
    /// Name of the render settings, part of the cache key.
    pub render_name: String,
    /// Window before a crossing in which a sighting counts, s.
    pub threshold_window_s: f64,
    /// Agent walking speed, m/s: with the 0.5 s window it sets how far before a door the
    /// threshold must be seen (0.5 m at the default 1.0 m/s).
    pub speed_m_s: f64,
    /// When the agent "crosses" a threshold: `true` (default) when its body (a disc of the
    /// walk's radius) first touches the sill's footprint, `false` at the first pose beyond the
    /// door plane (the camera centre past the door). See the module docs.
    pub crossing_at_contact: bool,
    /// How raw DN become the 8-bit image ORB and the detectors see ([`scene_gen_camera::isp`]).
    pub output: OutputRule,
    /// A scenario with fewer usable images scores the threshold term only (`None`:
    /// [`DEFAULT_MIN_USABLE_FRACTION`] of its anchor frames, rounded up).
    pub min_usable_images: Option<u32>,
    /// An external detector instead of the built-in [`DetectabilityModel`].
    pub detector: Option<ExternalDetector>,
    pub weights: FitnessWeights,
}

impl Default for EvalConfig {
    fn default() -> Self {
        EvalConfig {
            frames_per_scene: DEFAULT_FRAMES_PER_SCENE,
            max_width_px: Some(DEFAULT_MAX_WIDTH_PX),
            render: eval_render_settings(),
            render_name: "eval".to_string(),
            crossing_at_contact: true,
            threshold_window_s: thresholds::DEFAULT_WINDOW_S,
            speed_m_s: DEFAULT_SPEED_M_S,
            output: OutputRule::Isp,
            min_usable_images: None,
            detector: None,
            weights: FitnessWeights::default(),
        }
    }
}

/// Scores of one scenario.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScenarioScore {
    /// Seen / crossed; 0 when nothing was crossed.
    pub threshold_accuracy: f64,
    pub thresholds_seen: u32,
    pub thresholds_missed: u32,
    /// AP@0.5 of the detector (built-in or external); 0 when no frame had ground truth.
    pub ap50: f64,
    pub ground_truth_objects: usize,
    pub mean_inliers: f64,
    pub inlier_ratio: f64,
    pub mean_keypoints: f64,
    /// Anchor frames scored.
    pub frames: usize,
    /// Anchor frames whose 8-bit image is neither nearly black nor saturated and that hold at
    /// least one counted ground-truth object.
    pub usable_images: usize,
    /// The floor `usable_images` was held to.
    pub min_usable_images: usize,
    /// True when `usable_images < min_usable_images`: the fitness is the threshold term only.
    pub threshold_only: bool,
    pub fitness: f64,
}

/// Day, night and their mean.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fitness {
    pub day: f64,
    pub night: f64,
    pub mean: f64,
}

/// Scores of both scenarios.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Scenarios {
    pub day: ScenarioScore,
    pub night: ScenarioScore,
}

/// Where the time of one evaluation went, seconds. `wall` is elapsed time; the stage figures
/// are summed over worker threads (so they can add up to more than `wall` on several cores);
/// `plugin` is the external detector's elapsed time.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Timing {
    pub wall: f64,
    /// House generation, walk planning and light probes.
    pub setup: f64,
    /// Ray tracing.
    pub render: f64,
    /// Sensor simulation and the 8-bit output rule.
    pub sensor: f64,
    /// Ground truth and the built-in detector (or writing images for the external one).
    pub detection: f64,
    /// ORB extraction, matching and RANSAC.
    pub orb: f64,
    pub plugin: f64,
}

/// A candidate's evaluation (the `--json` output).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Evaluation {
    pub camera: CameraSpec,
    pub seeds: Vec<u64>,
    pub config: EvalConfig,
    pub scenarios: Scenarios,
    pub fitness: Fitness,
    /// Time breakdown (not deterministic: the CLI prints it only with `--timing`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timing_s: Option<Timing>,
}

/// Why a candidate could not be evaluated.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error(transparent)]
    Spec(#[from] SpecError),
    #[error("no seeds to evaluate")]
    NoSeeds,
    #[error("frames_per_scene must be at least 1")]
    NoFrames,
    #[error("speed_m_s must be finite and positive, got {0}")]
    BadSpeed(f64),
    #[error(transparent)]
    House(#[from] HouseError),
    #[error("rendering house {seed}: {source}")]
    Render {
        seed: u64,
        #[source]
        source: RenderError,
    },
    #[error("{group:?} lights give no light on the {TARGET_PLANE_M} m plane")]
    NoLight { group: LightGroup },
    #[error("COCO evaluation: {0}")]
    Coco(#[from] coco_eval::CocoError),
    #[error("external detector: {0}")]
    Plugin(#[from] PluginError),
    #[error("writing detector input {path}: {why}")]
    Io { path: String, why: String },
}

/// The light scale of each scenario: `(group, nominal lux, scale, target lux)`, the lights of
/// `group` scaled so the mean illuminance on the 0.75 m plane is the TaCOS target (20 lux by
/// day, 2 lux by night).
///
/// # Errors
/// A render error of the probe, or [`EvalError::NoLight`] when a group gives no light.
pub fn scenario_light_scales(
    renderer: &Renderer<'_>,
    seed: u64,
    groups: &[LightGroup],
) -> Result<Vec<(LightGroup, f32, f32, f32)>, EvalError> {
    let mut out = Vec::new();
    for &g in groups {
        let target = if g == LightGroup::Day { DAY_TARGET_LUX } else { NIGHT_TARGET_LUX };
        let nominal = measure_mean_illuminance(renderer, g, TARGET_PLANE_M)
            .map_err(|source| EvalError::Render { seed, source })?;
        if nominal <= 0.0 {
            return Err(EvalError::NoLight { group: g });
        }
        out.push((g, nominal, target / nominal, target));
    }
    Ok(out)
}

static CACHE: OnceLock<Mutex<HashMap<String, Evaluation>>> = OnceLock::new();
static COMPUTED: AtomicU64 = AtomicU64::new(0);

/// Evaluations computed (not served from the cache) in this process.
#[must_use]
pub fn computed_count() -> u64 {
    COMPUTED.load(Ordering::SeqCst)
}

/// Evaluates `spec` on the houses of `seeds` (served from the per-process cache when the same
/// candidate was evaluated before).
///
/// # Errors
/// [`EvalError`]: a bad spec, no seeds or frames, or a stage that failed.
pub fn evaluate(spec: &CameraSpec, seeds: &[u64], config: &EvalConfig) -> Result<Evaluation, EvalError> {
    evaluate_traced(spec, seeds, config).map(|(e, _)| e)
}

/// As [`evaluate`], and whether the result came from the cache.
///
/// # Errors
/// As [`evaluate`].
pub fn evaluate_traced(spec: &CameraSpec, seeds: &[u64], config: &EvalConfig) -> Result<(Evaluation, bool), EvalError> {
    let (spec, resolved) = prepare(spec, seeds, config)?;
    // Normalised key: the resolved spec (canonical sensor name, defaults filled in) as JSON,
    // and every serialised configuration field (speed, output rule, usable floor, detector...).
    let mut key_spec = resolved.spec.clone();
    key_spec.sensor = resolved.sensor.model.clone();
    let key = format!(
        "{}|{:?}|{}|{:?}",
        serde_json::to_string(&key_spec).unwrap_or_default(),
        seeds,
        serde_json::to_string(config).unwrap_or_default(),
        config.render
    );
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(hit) = cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner).get(&key) {
        return Ok((hit.clone(), true));
    }
    let result = compute(&spec, &resolved, seeds, config)?;
    cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner).insert(key, result.clone());
    Ok((result, false))
}

/// As [`evaluate`], always computed (the cache is neither read nor written).
///
/// # Errors
/// As [`evaluate`].
pub fn evaluate_uncached(spec: &CameraSpec, seeds: &[u64], config: &EvalConfig) -> Result<Evaluation, EvalError> {
    let (spec, resolved) = prepare(spec, seeds, config)?;
    compute(&spec, &resolved, seeds, config)
}

/// Checks the request and resolves the camera against the catalog; shared by the cached and
/// uncached entry points.
fn prepare(spec: &CameraSpec, seeds: &[u64], config: &EvalConfig) -> Result<(CameraSpec, ResolvedCamera), EvalError> {
    let mut spec = spec.clone();
    if config.max_width_px.is_some() {
        spec.max_width_px = config.max_width_px;
    }
    spec.validate()?;
    if seeds.is_empty() {
        return Err(EvalError::NoSeeds);
    }
    if config.frames_per_scene == 0 {
        return Err(EvalError::NoFrames);
    }
    if !(config.speed_m_s.is_finite() && config.speed_m_s > 0.0) {
        return Err(EvalError::BadSpeed(config.speed_m_s));
    }
    let resolved = spec.resolve(&Catalog::embedded())?;
    Ok((spec, resolved))
}

/// The time the agent's body first touches the sill footprint `lo..hi` on its way to crossing
/// pose `pose_index`: going back from that pose over the poses whose centre lies within the
/// walk's radius of the footprint, then interpolated linearly in distance between the last pose
/// outside and the first inside (poses are 0.25 m apart).
fn contact_time_s(walk: &trajectory::Trajectory, pose_index: usize, lo: glam::Vec2, hi: glam::Vec2) -> f64 {
    let r = walk.radius_m;
    let dist = |k: usize| {
        let p = walk.poses[k].position.truncate();
        (lo - p).max(p - hi).max(glam::Vec2::ZERO).length()
    };
    let mut k = pose_index.min(walk.poses.len().saturating_sub(1));
    while k > 0 && dist(k - 1) <= r {
        k -= 1;
    }
    let t_k = f64::from(walk.poses[k].time_s);
    if k == 0 || dist(k) > r {
        return t_k;
    }
    let (d0, d1) = (f64::from(dist(k - 1)), f64::from(dist(k)));
    let t0 = f64::from(walk.poses[k - 1].time_s);
    let frac = if d0 > d1 { (d0 - f64::from(r)) / (d0 - d1) } else { 1.0 };
    t0 + frac.clamp(0.0, 1.0) * (t_k - t0)
}

/// Visible pixels of each threshold in a frame's ids, by instance id (ascending).
fn threshold_pixels(class_id: &[u16], instance_id: &[u32], thresholds: &BTreeSet<u32>) -> Vec<(u32, u32)> {
    let mut counts: BTreeMap<u32, u32> = BTreeMap::new();
    // The class buffer finds threshold pixels first: a set lookup at every pixel of every pose
    // was about 8 % of a full-resolution evaluation (perf).
    let on_threshold = class_id.iter().zip(instance_id).filter(|(c, _)| u32::from(**c) == THRESHOLD_CLASS_ID);
    for (_, &id) in on_threshold {
        if thresholds.contains(&id) {
            *counts.entry(id).or_insert(0) += 1;
        }
    }
    counts.into_iter().collect()
}

/// How far (metres) a threshold's box is grown before it is projected: its mesh lies inside the
/// box it records, this only absorbs rounding.
const THRESHOLD_BOX_MARGIN_M: f32 = 0.01;

/// [`threshold_pixels`] of the frame `camera` sees, traced only over the pixels each threshold's
/// box can cover ([`scene_gen_render::Camera::box_pixels`]): the same rays through the same pixel
/// centres, so the same counts, for a small fraction of the rays of a whole frame.
fn threshold_pixels_in_boxes(
    renderer: &Renderer<'_>,
    camera: &scene_gen_render::Camera,
    thresholds: &[scene_gen_scene::scene::Threshold],
) -> Result<Vec<(u32, u32)>, RenderError> {
    let margin = glam::Vec3::splat(THRESHOLD_BOX_MARGIN_M);
    let mut counts: BTreeMap<u32, u32> = BTreeMap::new();
    for t in thresholds {
        let Some(rect) = camera.box_pixels(t.min - margin, t.max + margin) else { continue };
        let ids = renderer.render_ids_in(camera, rect)?;
        let on = ids
            .class_id
            .iter()
            .zip(&ids.instance_id)
            .filter(|&(&c, &id)| u32::from(c) == THRESHOLD_CLASS_ID && id == t.instance_id)
            .count();
        if on > 0 {
            *counts.entry(t.instance_id).or_insert(0) += on as u32;
        }
    }
    Ok(counts.into_iter().collect())
}

/// Whether an anchor's 8-bit image shows anything (module docs, "usable images").
fn image_usable(grey: &[u8]) -> bool {
    let n = grey.len().max(1) as f64;
    let mean = grey.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let clipped = grey.iter().filter(|&&v| v == 0 || v == 255).count() as f64 / n;
    (USABLE_MIN_MEAN..=USABLE_MAX_MEAN).contains(&mean) && clipped < USABLE_MAX_CLIPPED_FRACTION
}

/// What one rendered pose contributes.
struct PoseResult {
    /// Threshold instance id -> visible pixels.
    thresholds: Vec<(u32, u32)>,
    time_s: f64,
    /// Per scenario: 8-bit image (anchors and successors only).
    grey: Vec<Vec<u8>>,
    /// Ground truth and per-scenario built-in detections (anchors only).
    gt: Option<Vec<scene_gen_perception::detection::GtObject>>,
    detections: Vec<Vec<scene_gen_perception::detection::Detection>>,
    /// Per scenario: the anchor's image is usable.
    usable: Vec<bool>,
    /// Thread-seconds: render, sensor, detection.
    times: [f64; 3],
}

/// Per-scenario accumulators.
#[derive(Default, Clone)]
struct Acc {
    seen: u32,
    missed: u32,
    inliers: f64,
    ratio: f64,
    keypoints: f64,
    pairs: usize,
    frames: usize,
    usable: usize,
    gt: CocoGroundTruth,
    dets: Vec<DetectionRecord>,
}

/// A scratch folder for the external detector's images, removed when dropped.
struct ScratchDir(PathBuf);

impl ScratchDir {
    fn new() -> Result<ScratchDir, EvalError> {
        static N: AtomicU64 = AtomicU64::new(0);
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
        let dir = std::env::temp_dir().join(format!(
            "scene-gen-evaluate-{}-{}-{nanos}",
            std::process::id(),
            N.fetch_add(1, Ordering::SeqCst)
        ));
        std::fs::create_dir_all(&dir).map_err(|e| io_error(&dir, &e))?;
        Ok(ScratchDir(dir))
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        // Best effort: a leftover temp folder is harmless.
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn io_error(path: &Path, e: &dyn std::fmt::Display) -> EvalError {
    EvalError::Io { path: path.display().to_string(), why: e.to_string() }
}

fn secs(t: Instant) -> f64 {
    t.elapsed().as_secs_f64()
}

#[allow(clippy::too_many_lines)]
fn compute(
    spec: &CameraSpec,
    resolved: &ResolvedCamera,
    seeds: &[u64],
    config: &EvalConfig,
) -> Result<Evaluation, EvalError> {
    COMPUTED.fetch_add(1, Ordering::SeqCst);
    let wall = Instant::now();
    let mut timing = Timing::default();
    let library = embedded_library()?;
    let gains = [spec.gain_day_db, spec.gain_night_db];
    let names = ["day", "night"];
    let mut accs = vec![Acc::default(), Acc::default()];
    let categories: Vec<CocoCategory> = ObjectClass::ALL
        .iter()
        .map(|c| CocoCategory { id: c.class_id(), name: c.name().to_string() })
        .chain(std::iter::once(CocoCategory { id: THRESHOLD_CLASS_ID, name: THRESHOLD_CLASS_NAME.to_string() }))
        .collect();
    for acc in &mut accs {
        acc.gt.categories.clone_from(&categories);
    }
    let (w, h) = (resolved.width_px, resolved.height_px);
    let min_px = ((f64::from(thresholds::DEFAULT_MIN_VISIBLE_PX) * f64::from(w) * f64::from(h) / VGA_PIXELS).round()
        as u32)
        .max(1);
    let tcfg = ThresholdConfig { window_s: config.threshold_window_s, min_visible_px: min_px };
    let model = DetectabilityModel::default();
    let orb = Orb::with_features(ORB_FEATURES);
    let scratch = config.detector.as_ref().map(|_| ScratchDir::new()).transpose()?;
    let mut requests: Vec<(usize, PluginRequest)> = Vec::new();
    let mut next_image_id = 1u64;

    for &seed in seeds {
        let setup = Instant::now();
        let params = TrajectoryParams {
            height_m: spec.height_m,
            speed_m_per_s: config.speed_m_s as f32,
            ..TrajectoryParams::default()
        };
        let WalkedHouse { scene, walk } = walked_house(&library, seed, &params)?;
        let renderer = Renderer::new(&scene, config.render);
        let scales = scenario_light_scales(&renderer, seed, &[LightGroup::Day, LightGroup::Night])?;
        let isps: Vec<Isp> = scales
            .iter()
            .enumerate()
            .map(|(s, &(_, _, _, lux))| {
                Isp::for_scenario(
                    resolved,
                    gains[s],
                    f64::from(lux),
                    if spec.noise == NoiseKind::Affine { 3 } else { 1 },
                )
            })
            .collect();
        // The camera's noise at each output level per scenario, what the built-in detector
        // divides contrast by (detection::output_noise says why not the image's own estimate).
        let noise_tables: Vec<Option<Vec<f64>>> = isps
            .iter()
            .enumerate()
            .map(|(s, isp)| output_noise_by_level(resolved, gains[s], config.output, isp))
            .collect();
        timing.setup += secs(setup);
        let n = walk.poses.len();
        let k = (config.frames_per_scene as usize).min(n);
        let anchors: Vec<usize> = if k <= 1 {
            vec![0]
        } else {
            (0..k)
                .map(|i| ((i * (n - 1)) as f64 / (k - 1) as f64).round() as usize)
                .collect::<BTreeSet<_>>()
                .into_iter()
                .collect()
        };
        // Pose index -> role: 2 anchor, 1 successor (image), 0 threshold visibility only.
        let mut roles: BTreeMap<usize, u8> = BTreeMap::new();
        for &a in &anchors {
            roles.insert(a, 2);
            if a + 1 < n {
                let r = roles.entry(a + 1).or_insert(1);
                *r = (*r).max(1);
            }
        }
        let crossings: Vec<Crossing> = walk
            .crossings
            .iter()
            .filter_map(|c| {
                scene.thresholds.get(c.threshold_id as usize).map(|t| Crossing {
                    instance_id: t.instance_id,
                    time_s: if config.crossing_at_contact {
                        contact_time_s(&walk, c.pose_index, t.min.truncate(), t.max.truncate())
                    } else {
                        f64::from(c.time_s)
                    },
                })
            })
            .collect();
        // Every pose in the window before a crossing (the same test as threshold_score, on the
        // same f64 times, so no window pose is left unrendered).
        for c in &crossings {
            let t = c.time_s;
            for (i, p) in walk.poses.iter().enumerate() {
                let pt = f64::from(p.time_s);
                if pt <= t && pt >= t - config.threshold_window_s {
                    roles.entry(i).or_insert(0);
                }
            }
        }
        let threshold_ids: BTreeSet<u32> = scene.thresholds.iter().map(|t| t.instance_id).collect();
        let jobs: Vec<(usize, u8)> = roles.into_iter().collect();
        let builtin = config.detector.is_none();
        // Frames finished with, for the next pose to render into (`Renderer::render_into`):
        // as many as poses run at once, however many poses there are.
        let spare_frames: Mutex<Vec<Frame>> = Mutex::new(Vec::new());
        let results: Vec<Result<PoseResult, RenderError>> = jobs
            .par_iter()
            .map(|&(i, role)| {
                let pose = walk.poses[i];
                let camera = resolved.camera_at(&pose);
                let t0 = Instant::now();
                // Threshold-window poses need only each threshold's visible pixels: ids from
                // one ray per pixel, over the pixels its box can cover.
                if role == 0 {
                    return Ok(PoseResult {
                        thresholds: threshold_pixels_in_boxes(&renderer, &camera, &scene.thresholds)?,
                        time_s: f64::from(pose.time_s),
                        grey: Vec::new(),
                        gt: None,
                        detections: Vec::new(),
                        usable: Vec::new(),
                        times: [secs(t0), 0.0, 0.0],
                    });
                }
                let mut frame = spare_frames.lock().map(|mut v| v.pop()).ok().flatten().unwrap_or_default();
                renderer.render_into(&camera, &mut frame)?;
                let mut times = [secs(t0), 0.0, 0.0];
                let mut out = PoseResult {
                    thresholds: threshold_pixels(&frame.class_id, &frame.instance_id, &threshold_ids),
                    time_s: f64::from(pose.time_s),
                    grey: Vec::new(),
                    gt: None,
                    detections: Vec::new(),
                    usable: Vec::new(),
                    times,
                };
                let t1 = Instant::now();
                let gt =
                    (role == 2).then(|| frame_ground_truth(&frame, &scene, &camera, &GroundTruthConfig::default()));
                times[2] += secs(t1);
                let detector_seed = detector_seed(seed, i);
                // Sensor and ISP: both scenarios' 8-bit images from the one frame.
                let t1 = Instant::now();
                let frame_seeds: Vec<u64> = (0..scales.len()).map(|s| capture_seed(seed, i, names[s])).collect();
                let scenarios: Vec<Scenario<'_>> = scales
                    .iter()
                    .enumerate()
                    .map(|(s, &(_, _, scale, _))| Scenario {
                        day_weight: if s == 0 { scale } else { 0.0 },
                        night_weight: if s == 0 { 0.0 } else { scale },
                        gain_db: gains[s],
                        frame_seed: frame_seeds[s],
                        isp: &isps[s],
                    })
                    .collect();
                let optics = OpticsInput {
                    depth_m: &frame.depth_m,
                    velocity_m_s: agent_velocity(&resolved.spec, pose.yaw_deg, params.speed_m_per_s),
                };
                let greys = capture_8bit(
                    resolved,
                    &camera,
                    &frame.day_nit,
                    &frame.night_nit,
                    Some(optics),
                    seed,
                    config.output,
                    &scenarios,
                );
                times[1] += secs(t1);
                for (s, grey) in greys.into_iter().enumerate() {
                    if let Some(objects) = &gt {
                        let t1 = Instant::now();
                        out.usable.push(image_usable(&grey) && objects.iter().any(|o| o.counted));
                        if builtin {
                            let image: Vec<f32> = grey.iter().map(|&v| f32::from(v)).collect();
                            let input = DetectorInput {
                                image_dn: &image,
                                width: camera.width_px,
                                height: camera.height_px,
                                instance_id: &frame.instance_id,
                                objects,
                                noise: noise_tables[s].as_deref().map_or(NoiseSource::Measured, NoiseSource::ByLevel),
                                // One draw seed per pose for both scenarios (common random
                                // numbers): an object is found by day and not at night only
                                // because its probability differs, not by the luck of the draw.
                                frame_seed: detector_seed,
                            };
                            out.detections.push(model.detect(&input));
                        }
                        times[2] += secs(t1);
                    }
                    out.grey.push(grey);
                }
                out.gt = gt;
                out.times = times;
                if let Ok(mut spare) = spare_frames.lock() {
                    spare.push(frame);
                }
                Ok(out)
            })
            .collect();
        let mut by_pose: BTreeMap<usize, PoseResult> = BTreeMap::new();
        for (&(i, _), r) in jobs.iter().zip(results) {
            let r = r.map_err(|source| EvalError::Render { seed, source })?;
            timing.render += r.times[0];
            timing.sensor += r.times[1];
            timing.detection += r.times[2];
            by_pose.insert(i, r);
        }

        // Thresholds (geometric: the same in both scenarios).
        let vis: Vec<FrameVisibility> =
            by_pose.values().map(|p| FrameVisibility { time_s: p.time_s, visible_px: p.thresholds.clone() }).collect();
        let ts = thresholds::threshold_score(&vis, &crossings, &tcfg);

        // ORB pairs, in parallel over (scenario, anchor).
        let pair_jobs: Vec<(usize, usize)> =
            (0..2).flat_map(|s| anchors.iter().filter(|&&a| a + 1 < n).map(move |&a| (s, a))).collect();
        let pair_scores: Vec<(usize, f64, f64, f64, f64)> = pair_jobs
            .par_iter()
            .map(|&(s, a)| {
                let t0 = Instant::now();
                let ga = &by_pose[&a].grey[s];
                let gb = &by_pose[&(a + 1)].grey[s];
                let (ka, da) = orb.detect_and_compute((ga.as_slice(), w as usize, h as usize)).unwrap_or_default();
                let (kb, db) = orb.detect_and_compute((gb.as_slice(), w as usize, h as usize)).unwrap_or_default();
                let ransac = FundamentalRansac {
                    seed: scene_gen_core::rng::fnv1a64(format!("evaluate/ransac/{seed}/{a}/{s}").as_bytes()),
                    ..FundamentalRansac::default()
                };
                let (_, inl) = match_and_verify(&ka, &da, &kb, &db, &ransac);
                let inliers = inl.iter().filter(|&&b| b).count() as f64;
                let kp = ka.len() as f64;
                let ratio = if inliers + kp > 0.0 { inliers / (inliers + kp) } else { 0.0 };
                (s, inliers, ratio, kp, secs(t0))
            })
            .collect();
        for (s, inliers, ratio, kp, t) in pair_scores {
            let acc = &mut accs[s];
            acc.inliers += inliers;
            acc.ratio += ratio;
            acc.keypoints += kp;
            acc.pairs += 1;
            timing.orb += t;
        }

        // Detection: every anchor, in pose order; one image id per (anchor, scenario).
        for &a in &anchors {
            let p = &by_pose[&a];
            let objects = p.gt.as_deref().unwrap_or(&[]);
            for (s, acc) in accs.iter_mut().enumerate() {
                let image_id = next_image_id;
                next_image_id += 1;
                let file_name = format!("seed{seed}_pose{a:05}_{}.png", names[s]);
                acc.frames += 1;
                acc.usable += usize::from(p.usable.get(s).copied().unwrap_or(false));
                acc.gt.images.push(CocoImage { id: image_id, width: w, height: h, file_name: file_name.clone() });
                let first = acc.gt.annotations.len() as u64 + 1;
                acc.gt.annotations.extend(to_annotations(objects, image_id, first));
                if let Some(dets) = p.detections.get(s) {
                    acc.dets.extend(dets.iter().map(|d| d.record(image_id)));
                }
                if let Some(dir) = &scratch {
                    let t0 = Instant::now();
                    let path = dir.0.join(&file_name);
                    let img = image::GrayImage::from_raw(w, h, p.grey[s].clone())
                        .ok_or_else(|| io_error(&path, &"image size mismatch"))?;
                    img.save(&path).map_err(|e| io_error(&path, &e))?;
                    requests
                        .push((s, PluginRequest { image_id, path: path.display().to_string(), width: w, height: h }));
                    timing.detection += secs(t0);
                }
            }
        }
        for acc in &mut accs {
            acc.seen += ts.seen;
            acc.missed += ts.missed;
        }
    }

    if let (Some(det), Some(dir)) = (&config.detector, &scratch) {
        let t0 = Instant::now();
        // Both scenarios' ground truth in one COCO file (ids are unique across them).
        let mut all = CocoGroundTruth { categories: categories.clone(), ..CocoGroundTruth::default() };
        for acc in &accs {
            all.images.extend(acc.gt.images.iter().cloned());
            all.annotations.extend(acc.gt.annotations.iter().cloned());
        }
        for (k, a) in all.annotations.iter_mut().enumerate() {
            a.id = k as u64 + 1;
        }
        let gt_path = dir.0.join("ground_truth.json");
        let text = all.to_json().map_err(|e| io_error(&gt_path, &e))?;
        std::fs::write(&gt_path, text).map_err(|e| io_error(&gt_path, &e))?;
        let args: Vec<String> = det
            .args
            .iter()
            .map(|a| a.replace("{gt}", &gt_path.display().to_string()).replace("{dir}", &dir.0.display().to_string()))
            .collect();
        let reqs: Vec<PluginRequest> = requests.iter().map(|(_, r)| r.clone()).collect();
        let records = plugin::run(&det.program, &args, &reqs)?;
        let scenario_of: HashMap<u64, usize> = requests.iter().map(|(s, r)| (r.image_id, *s)).collect();
        for rec in records {
            if let Some(&s) = scenario_of.get(&rec.image_id) {
                accs[s].dets.push(rec);
            }
        }
        // Sorted by image then score so the result does not depend on the detector's answer order.
        for acc in &mut accs {
            acc.dets.sort_by(|a, b| a.image_id.cmp(&b.image_id).then(b.score.total_cmp(&a.score)));
        }
        timing.plugin = secs(t0);
    }

    let weights = config.weights;
    let mut scores = Vec::new();
    for acc in &accs {
        let metrics = coco_eval::evaluate(&acc.gt, &acc.dets)?;
        let ap50 = metrics.ap50.max(0.0);
        let threshold_accuracy =
            thresholds::ThresholdScore { seen: acc.seen, missed: acc.missed }.accuracy().unwrap_or(0.0);
        let pairs = acc.pairs.max(1) as f64;
        let mean_inliers = acc.inliers / pairs;
        let inlier_ratio = acc.ratio / pairs;
        let min_usable = config
            .min_usable_images
            .map_or_else(|| (DEFAULT_MIN_USABLE_FRACTION * acc.frames as f64).ceil() as usize, |m| m as usize);
        let threshold_only = acc.usable < min_usable;
        let fitness = if threshold_only {
            weights.threshold * threshold_accuracy
        } else {
            weights.threshold * threshold_accuracy
                + weights.ap50 * ap50
                + weights.inliers * mean_inliers
                + weights.inlier_ratio * inlier_ratio
        };
        scores.push(ScenarioScore {
            threshold_accuracy,
            thresholds_seen: acc.seen,
            thresholds_missed: acc.missed,
            ap50,
            ground_truth_objects: acc.gt.annotations.len(),
            mean_inliers,
            inlier_ratio,
            mean_keypoints: acc.keypoints / pairs,
            frames: acc.frames,
            usable_images: acc.usable,
            min_usable_images: min_usable,
            threshold_only,
            fitness,
        });
    }
    let night = scores.pop().expect("two scenarios");
    let day = scores.pop().expect("two scenarios");
    let fitness = Fitness { day: day.fitness, night: night.fitness, mean: 0.5 * (day.fitness + night.fitness) };
    timing.wall = secs(wall);
    Ok(Evaluation {
        camera: spec.clone(),
        seeds: seeds.to_vec(),
        config: config.clone(),
        scenarios: Scenarios { day, night },
        fitness,
        timing_s: Some(timing),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene_gen_camera::sensor::Catalog;

    /// Counting each threshold over its box's pixels gives the counts of the whole frame, on
    /// the poses before every crossing of a house (where thresholds are near, below and beside
    /// the camera) for a downward and a level camera.
    #[test]
    fn threshold_counts_in_boxes_equal_whole_frame_counts() {
        let library = embedded_library().unwrap();
        for spec in ["IMX174,focal_mm=2.5,pitch_deg=-40", "IMX174,focal_mm=6,pitch_deg=0"] {
            let spec = CameraSpec { max_width_px: Some(96), ..CameraSpec::from_inline(spec).unwrap() };
            let resolved = spec.resolve(&Catalog::embedded()).unwrap();
            let params = TrajectoryParams { height_m: resolved.spec.height_m, ..TrajectoryParams::default() };
            let WalkedHouse { scene, walk } = walked_house(&library, 1, &params).unwrap();
            let renderer = Renderer::new(&scene, RenderSettings::preview());
            let ids: BTreeSet<u32> = scene.thresholds.iter().map(|t| t.instance_id).collect();
            let mut seen = 0;
            for c in &walk.crossings {
                for i in c.pose_index.saturating_sub(4)..=c.pose_index {
                    let camera = resolved.camera_at(&walk.poses[i]);
                    let whole = renderer.render_ids(&camera).unwrap();
                    let expected = threshold_pixels(&whole.class_id, &whole.instance_id, &ids);
                    let boxed = threshold_pixels_in_boxes(&renderer, &camera, &scene.thresholds).unwrap();
                    assert_eq!(boxed, expected, "pose {i}");
                    seen += expected.len();
                }
            }
            assert!(seen > 0, "some threshold is in view on some pose");
        }
    }
}
