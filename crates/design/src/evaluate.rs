//! The evaluator: the task scores of one camera candidate over seeded houses, as the reference
//! system scores them (docs/REFERENCE.md, "Tasks and score").
//!
//! An evaluation is a short sequence of steps, each a function below:
//!
//! 1. **Per house** (`Tally::add_house`): the house of the seed with the default
//!    configuration, the agent's walk at the spec's mounting height and at
//!    [`EvalConfig::speed_m_s`] (poses every 0.25 m), and a [`Capture`] of the camera in it
//!    by day and by night.
//! 2. **Which poses** (`plan_poses`): [`EvalConfig::frames_per_scene`] *anchor* poses evenly
//!    spread along the walk, each with its successor 0.25 m later (so ORB matches a genuine
//!    consecutive pair), and every pose in the threshold window before a door crossing.
//! 3. **Render and capture** (`render_pose`, poses in parallel): one trace per pose serves
//!    both scenarios (the lights scaled to 20 lux by day and 2 lux by night on the 0.75 m
//!    plane); per scenario the sensor image goes through the fixed ISP
//!    ([`EvalConfig::output`], `scene_gen_camera::isp`) to the 8-bit image ORB and the
//!    detector see. Window poses trace only ids, over the pixels each threshold's box can
//!    cover, which counts exactly the pixels a whole frame would.
//! 4. **Score** (`Tally::add_thresholds`, `Tally::add_orb`, `Tally::add_detections`),
//!    then, once over every house, the external detector if one is set
//!    (`Tally::run_external_detector`) and the scores and fitness per scenario
//!    (`Tally::score`).
//!
//! # Scores per scenario
//!
//! * **Threshold accuracy** ([`thresholds::threshold_score`]): a threshold counts as seen when
//!   enough of it was on screen within 0.5 s before the agent crossed it. The agent crosses
//!   when its body (a disc of the walk's radius) first touches the sill's footprint
//!   ([`EvalConfig::crossing_at_contact`], interpolated between poses): an obstacle must be
//!   seen before the body reaches it. At the default 1.0 m/s the window is 0.5 m of walk. The
//!   visible-pixel floor is [`thresholds::DEFAULT_MIN_VISIBLE_PX`] at 640 x 480, scaled with
//!   the pixel count. It is geometric, so the same in both scenarios.
//! * **AP@0.5** of the detector against the instance buffer's ground truth
//!   ([`frame_ground_truth`]), [`coco_eval::evaluate`] over every anchor of every seed (an AP
//!   of -1, no ground truth at all, counts as 0). The detector ([`EvalConfig::detector`]) is
//!   the learned detector (the default, `detection::cnn`) on each anchor's 8-bit image, sRGB
//!   for a colour camera; the built-in [`DetectabilityModel`] (`--detector model`), told the
//!   camera's noise at each output level (`detection::output_noise`) and drawing with one seed
//!   per pose for both scenarios; or an external program (`--detector "CMD ARGS"`) run once
//!   per evaluation under the plug-in protocol of `scene_gen_perception::detection`, on the
//!   anchors' 8-bit PNGs with a COCO ground-truth file beside them (`{gt}` in the command).
//! * **ORB** (2000 features, cross-checked matches, fundamental RANSAC at 3 px) on each
//!   (anchor, successor) pair: mean inliers per pair and the mean inlier ratio
//!   `inliers / (inliers + keypoints)`, keypoints of the anchor frame. An inlier counts when
//!   the ground truth confirms it ([`crate::true_matches`]: the anchor's depth and the
//!   successor's pose put the match within the same 3 px), so chance matches that happen to
//!   fit the epipolar geometry, which grow with image noise, earn nothing; every RANSAC
//!   inlier is reported beside it (`mean_ransac_inliers`).
//! * **Usable images**: anchors whose 8-bit image is neither nearly black nor saturated (mean
//!   in [[`USABLE_MIN_MEAN`], [`USABLE_MAX_MEAN`]], fewer than
//!   [`USABLE_MAX_CLIPPED_FRACTION`] of the pixels at 0 or 255) and that hold at least one
//!   counted object. A scenario with fewer than [`EvalConfig::min_usable_images`] (by default
//!   half its anchors, [`DEFAULT_MIN_USABLE_FRACTION`]) is scored on the threshold term only.
//! * **Fitness** = threshold accuracy + AP@0.5 + 0.0025 x mean inliers + 0.5 x inlier ratio
//!   ([`FitnessWeights`]).
//!
//! # Known limits
//!
//! The evaluator's render ([`eval_render_settings`]) takes light that bounced from the
//! house's irradiance volume (`scene_gen_render::irradiance_volume`): smooth, so contact
//! shadows of bounced light are softer than real; `--bounce-rays N` adds a final gather of N
//! rays per pixel over it. The day-versus-night figures are in docs/BENCHMARKS.md
//! ("Detection: day versus night").
//!
//! # Determinism and caching
//!
//! Every random draw is seeded by the seed, pose index and scenario, and results are gathered
//! in pose order, so the output does not depend on the thread count. Results are cached per
//! process, keyed by the normalised spec, the seeds and every configuration field.
//! [`Evaluation::timing_s`] says where the time went (not deterministic; the CLI prints it with
//! `--timing`); its `sensor` figure is wall time on the pose's worker thread, which may run other
//! poses' rendering while it waits for the stage's nested row tasks, so it overstates the stage.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::progress::Progress;
use crate::true_matches::PairTruth;
use scene_gen_camera::camera_spec::{CameraSpec, ResolvedCamera, SpecError};
use scene_gen_camera::capture::{Capture, CaptureError, PerceptionImage, scenario_name};
use scene_gen_camera::isp::OutputRule;
use scene_gen_camera::sensor::Catalog;
use scene_gen_perception::detection::cnn::{CnnDetector, ImageView};
use scene_gen_perception::detection::coco_eval::{self, CocoCategory, CocoGroundTruth, CocoImage, DetectionRecord};
use scene_gen_perception::detection::ground_truth::to_annotations;
use scene_gen_perception::detection::output_noise::{colour_output_noise_by_level, output_noise_by_level};
use scene_gen_perception::detection::plugin::{self, PluginError, PluginRequest};
use scene_gen_perception::detection::thresholds::{self, Crossing, FrameVisibility, ThresholdConfig};
use scene_gen_perception::detection::{
    DetectabilityModel, Detection, Detector, DetectorInput, GroundTruthConfig, GtObject, NoiseSource,
    frame_ground_truth,
};
use scene_gen_perception::orb::{FundamentalRansac, Orb, match_and_verify};
use scene_gen_render::{Camera, Frame, RenderError, RenderSettings, Renderer, ShadingRate};
use scene_gen_scene::house::{HouseError, HouseOptions, WalkedHouse, load_library, walked_house_with};
use scene_gen_scene::library::Library;
use scene_gen_scene::scene::{LightGroup, ObjectClass, Scene, THRESHOLD_CLASS_ID, THRESHOLD_CLASS_NAME};
use scene_gen_scene::trajectory::{self, Trajectory, TrajectoryParams};

/// Default anchor frames per house: small, so a candidate evaluates in seconds.
pub const DEFAULT_FRAMES_PER_SCENE: u32 = 25;
/// Default binned width of the evaluation images, px.
pub const DEFAULT_MAX_WIDTH_PX: u32 = 320;

/// How wide the evaluator's frames are: the sensor's own pixels, or the sensor binned down to
/// at most a width. Written `native` or a whole number of pixels, on the command line and in
/// configuration files alike.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameWidth {
    /// Every pixel of the sensor.
    Native,
    /// Binned to at most this many pixels across (at least 1), the field of view kept.
    AtMost(u32),
}

impl FrameWidth {
    /// `native` or a width of at least 1 pixel.
    ///
    /// # Errors
    /// A sentence saying what was expected, for anything else.
    pub fn parse(text: &str) -> Result<FrameWidth, String> {
        let text = text.trim();
        if text.eq_ignore_ascii_case("native") {
            return Ok(FrameWidth::Native);
        }
        match text.parse::<u32>() {
            Ok(0) => Err("0: must be at least 1 pixel, or `native`".to_string()),
            Ok(px) => Ok(FrameWidth::AtMost(px)),
            Err(_) => Err(format!("`{text}`: expected `native` or a width in pixels")),
        }
    }

    /// The camera spec's `max_width_px` for this width: `None` for the native width.
    #[must_use]
    pub fn max_width_px(self) -> Option<u32> {
        match self {
            FrameWidth::Native => None,
            FrameWidth::AtMost(px) => Some(px),
        }
    }
}

impl std::fmt::Display for FrameWidth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FrameWidth::Native => f.write_str("native"),
            FrameWidth::AtMost(px) => write!(f, "{px}"),
        }
    }
}

impl Serialize for FrameWidth {
    /// `"native"`, or the width as a number.
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self {
            FrameWidth::Native => serializer.serialize_str("native"),
            FrameWidth::AtMost(px) => serializer.serialize_u32(*px),
        }
    }
}

impl<'de> serde::Deserialize<'de> for FrameWidth {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        #[derive(serde::Deserialize)]
        #[serde(untagged)]
        enum Written {
            Px(i64),
            Word(String),
        }
        let parsed = match Written::deserialize(deserializer)? {
            Written::Px(px) => match u32::try_from(px) {
                Ok(px) if px > 0 => Ok(FrameWidth::AtMost(px)),
                _ => Err(format!("{px}: must be at least 1 pixel, or `native`")),
            },
            Written::Word(word) => FrameWidth::parse(&word),
        };
        parsed.map_err(serde::de::Error::custom)
    }
}
/// Default agent speed, m/s ([`trajectory::DEFAULT_SPEED_M_PER_S`], which says why).
pub const DEFAULT_SPEED_M_S: f64 = trajectory::DEFAULT_SPEED_M_PER_S as f64;
/// ORB features per frame (the reference system's 2000, docs/REFERENCE.md).
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
/// all of them. Full-rate shading makes a 320 px candidate about 10x dearer (24 against 2.4
/// user-s on the default camera, houses 0 and 1) for day / night RANSAC inliers of 147 / 132 against
/// 118 / 120 and the same AP (docs/BENCHMARKS.md, "Adaptive anchors").
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
/// its centre, bounced light from the irradiance volume) with every light traced (no culling
/// roulette),
/// [`EVAL_RECT_SAMPLES_PER_AXIS`]^2 visibility samples per window at each anchor pooled over
/// [`EVAL_VISIBILITY_FILTER_RADIUS`] anchors, and [`ShadingRate::Adaptive`] shading
/// (irradiance at anchors every [`EVAL_DECOUPLED_STRIDE`] pixels, filled coarse to fine and
/// interpolated over the same surface) on frames of any width ([`EVAL_DECOUPLED_MIN_WIDTH_PX`]).
///
/// Why anchors: shadow rays and light selection are most of a frame's cost and nearly all of it
/// is irradiance, which varies slowly over a surface, while texture and edges, which ORB and
/// the detector see, are still sampled at every pixel (docs/BENCHMARKS.md, "Adaptive anchors").
///
/// Why pooled window samples and no roulette: the render's own noise must stay well below what
/// the features and detections respond to. Since each view draws its own random numbers
/// ([`scene_gen_render::Camera::view_key`]), render noise is new in every frame, as a real
/// scene's is not, and it costs ORB inliers: on the default camera at 1936 px (seeds 0..2),
/// one window sample and culling gave 103 day RANSAC inliers per pair where 16 samples per anchor
/// give 360. Four per anchor pooled over their neighbours at stride 4 give 341 (night 228 of
/// 233) in 29.8 s (docs/BENCHMARKS.md, "Render noise and ORB inliers").
///
/// Light that bounced, any number of times, comes from the house's irradiance volume, traced
/// once per house and shared by every candidate of the process
/// (`scene_gen_render::IrradianceVolume::shared`). Set [`EvalConfig::render`] (and
/// `render_name`) to use others; `scene-gen evaluate --bounce-rays N` adds N final-gather
/// bounce rays per pixel.
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
    /// The reference system's weights (docs/REFERENCE.md, "Tasks and score"): 1, 1, 0.0025, 0.5.
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

/// Which detector scores the detection task.
///
/// In `evaluate`'s JSON record (`config.detector`) the learned detector is `"cnn"`, the model
/// `"model"` and an external program its `{program, args}` object.
///
/// The learned detector is the default since release 0.5.0: it detects objects in the frames
/// the camera makes, at 1.3x the model's evaluation time (docs/BENCHMARKS.md, "The learned
/// detector"). The model reads the ground truth and is the fast screen.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum DetectorChoice {
    /// The built-in [`DetectabilityModel`]: a detection probability from object size and
    /// contrast-to-noise, drawn per object (fast; reads the ground truth).
    Model,
    /// The learned detector ([`scene_gen_perception::detection::cnn`]) on each 8-bit image.
    #[default]
    Cnn,
    /// An external program under the plug-in protocol.
    External(ExternalDetector),
}

impl DetectorChoice {
    /// `cnn`, `model`, or an external command line (split on whitespace). `None` for a blank
    /// command.
    #[must_use]
    pub fn parse(text: &str) -> Option<DetectorChoice> {
        match text.trim() {
            "cnn" => Some(DetectorChoice::Cnn),
            "model" => Some(DetectorChoice::Model),
            command => ExternalDetector::parse(command).map(DetectorChoice::External),
        }
    }

    /// The external program, if this is one.
    #[must_use]
    pub fn external(&self) -> Option<&ExternalDetector> {
        match self {
            DetectorChoice::External(e) => Some(e),
            _ => None,
        }
    }
}

impl Serialize for DetectorChoice {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self {
            DetectorChoice::Model => serializer.serialize_str("model"),
            DetectorChoice::Cnn => serializer.serialize_str("cnn"),
            DetectorChoice::External(program) => program.serialize(serializer),
        }
    }
}

/// How a candidate is evaluated.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EvalConfig {
    /// Anchor poses per house, evenly spaced along the walk.
    pub frames_per_scene: u32,
    /// The frames' width: it replaces the camera spec's own `max_width_px`, and
    /// [`FrameWidth::Native`] judges every pixel of the sensor.
    pub max_width_px: FrameWidth,
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
    /// The detector of the detection task.
    pub detector: DetectorChoice,
    /// The built-in detector's parameters, when [`DetectorChoice::Model`] is the detector (left
    /// out of the record when default).
    #[serde(skip_serializing_if = "is_default_detectability")]
    pub detectability: DetectabilityModel,
    pub weights: FitnessWeights,
    /// The houses: envelope, smallest room, libraries (left out of the record when default).
    #[serde(skip_serializing_if = "HouseOptions::is_default")]
    pub house: HouseOptions,
}

impl Default for EvalConfig {
    fn default() -> Self {
        EvalConfig {
            frames_per_scene: DEFAULT_FRAMES_PER_SCENE,
            max_width_px: FrameWidth::AtMost(DEFAULT_MAX_WIDTH_PX),
            render: eval_render_settings(),
            render_name: "eval".to_string(),
            crossing_at_contact: true,
            threshold_window_s: thresholds::DEFAULT_WINDOW_S,
            speed_m_s: DEFAULT_SPEED_M_S,
            output: OutputRule::Isp,
            min_usable_images: None,
            detector: DetectorChoice::default(),
            detectability: DetectabilityModel::default(),
            weights: FitnessWeights::default(),
            house: HouseOptions::default(),
        }
    }
}

fn is_default_detectability(model: &DetectabilityModel) -> bool {
    *model == DetectabilityModel::default()
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
    /// Mean per ORB pair of the RANSAC inliers the ground truth confirms: the successor
    /// keypoint lies within 3 px of where the anchor keypoint's surface point images
    /// ([`crate::true_matches`]). Chance matches that fit the epipolar geometry do not count.
    pub mean_inliers: f64,
    /// Mean per pair of every RANSAC inlier, confirmed or not (what a tracker without ground
    /// truth would count).
    pub mean_ransac_inliers: f64,
    /// Mean per pair of `confirmed inliers / (confirmed inliers + anchor keypoints)`.
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
    /// A camera mounted at or above the ceiling sees the roof from outside: nothing to score.
    #[error("{0}")]
    AboveCeiling(String),
    #[error(transparent)]
    House(#[from] HouseError),
    #[error("rendering house {seed}: {source}")]
    Render {
        seed: u64,
        #[source]
        source: RenderError,
    },
    #[error(transparent)]
    Capture(#[from] CaptureError),
    #[error("COCO evaluation: {0}")]
    Coco(#[from] coco_eval::CocoError),
    #[error("learned detector: {0}")]
    Cnn(String),
    #[error("external detector: {0}")]
    Plugin(#[from] PluginError),
    #[error("writing detector input {path}: {why}")]
    Io { path: String, why: String },
}

impl EvalError {
    /// Whether the request itself is at fault (a bad camera or setting, exit status 2 on the
    /// command line), as against a failure while evaluating.
    #[must_use]
    pub fn is_bad_input(&self) -> bool {
        self.is_bad_camera() || matches!(self, EvalError::NoSeeds | EvalError::NoFrames | EvalError::BadSpeed(_))
    }

    /// Whether the camera is at fault: its spec, or where it is mounted.
    #[must_use]
    pub fn is_bad_camera(&self) -> bool {
        matches!(self, EvalError::Spec(_) | EvalError::AboveCeiling(_))
    }
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

/// As [`evaluate`], reporting its progress to `progress`.
///
/// # Errors
/// As [`evaluate`].
pub fn evaluate_with_progress(
    spec: &CameraSpec,
    seeds: &[u64],
    config: &EvalConfig,
    progress: &dyn Progress,
) -> Result<Evaluation, EvalError> {
    cached(spec, seeds, config, progress).map(|(e, _)| e)
}

/// As [`evaluate`], and whether the result came from the cache.
///
/// # Errors
/// As [`evaluate`].
pub fn evaluate_traced(spec: &CameraSpec, seeds: &[u64], config: &EvalConfig) -> Result<(Evaluation, bool), EvalError> {
    cached(spec, seeds, config, &())
}

/// The cached evaluation: the stored result of the same candidate and configuration, or a new one.
fn cached(
    spec: &CameraSpec,
    seeds: &[u64],
    config: &EvalConfig,
    progress: &dyn Progress,
) -> Result<(Evaluation, bool), EvalError> {
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
    let result = compute(&spec, &resolved, seeds, config, progress)?;
    cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner).insert(key, result.clone());
    Ok((result, false))
}

/// As [`evaluate`], always computed (the cache is neither read nor written).
///
/// # Errors
/// As [`evaluate`].
pub fn evaluate_uncached(spec: &CameraSpec, seeds: &[u64], config: &EvalConfig) -> Result<Evaluation, EvalError> {
    let (spec, resolved) = prepare(spec, seeds, config)?;
    compute(&spec, &resolved, seeds, config, &())
}

/// Checks the request and resolves the camera against the catalog; shared by the cached and
/// uncached entry points.
fn prepare(spec: &CameraSpec, seeds: &[u64], config: &EvalConfig) -> Result<(CameraSpec, ResolvedCamera), EvalError> {
    let mut spec = spec.clone();
    spec.max_width_px = config.max_width_px.max_width_px();
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
    config.house.validate().map_err(HouseError::Options)?;
    config.house.envelope.check_camera_height(spec.height_m).map_err(EvalError::AboveCeiling)?;
    let resolved = spec.resolve(&Catalog::embedded())?;
    Ok((spec, resolved))
}

/// The time the agent's body first touches the sill footprint `lo..hi` on its way to crossing
/// pose `pose_index`: going back from that pose over the poses whose centre lies within the
/// walk's radius of the footprint, then interpolated linearly in distance between the last pose
/// outside and the first inside (poses are 0.25 m apart).
fn contact_time_s(walk: &Trajectory, pose_index: usize, lo: glam::Vec2, hi: glam::Vec2) -> f64 {
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
    camera: &Camera,
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
#[derive(Default)]
struct PoseResult {
    /// Threshold instance id -> visible pixels.
    thresholds: Vec<(u32, u32)>,
    time_s: f64,
    /// Per scenario: what perception sees (anchors and successors only).
    images: Vec<PerceptionImage>,
    /// Ground truth and per-scenario built-in detections (anchors only).
    gt: Option<Vec<GtObject>>,
    detections: Vec<Vec<Detection>>,
    /// Per scenario: the anchor's image is usable.
    usable: Vec<bool>,
    /// The pinhole the pose was rendered through (anchors and successors).
    camera: Option<Camera>,
    /// The anchor's depth per pixel, for the ground truth of its ORB pair.
    depth_m: Vec<f32>,
    /// Thread-seconds: render, sensor, detection.
    times: [f64; 3],
}

/// Per-scenario accumulators.
#[derive(Default, Clone)]
struct Acc {
    seen: u32,
    missed: u32,
    inliers: f64,
    ransac_inliers: f64,
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

/// The two scenarios, in the order of every per-scenario vector.
const SCENARIO_GROUPS: [LightGroup; 2] = [LightGroup::Day, LightGroup::Night];

/// What a pose is rendered for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Role {
    /// Threshold visibility only: ids over the thresholds' boxes.
    Window,
    /// The image of an anchor's successor, for its ORB pair.
    Successor,
    /// An anchor: image, ground truth, detections.
    Anchor,
}

/// Which poses of a house's walk are rendered, and the threshold crossings they are scored on.
struct PosePlan {
    /// Anchor pose indices, ascending.
    anchors: Vec<usize>,
    /// Every pose to render with its role, ascending by pose.
    jobs: Vec<(usize, Role)>,
    crossings: Vec<Crossing>,
}

/// The anchors ([`EvalConfig::frames_per_scene`] poses evenly spread), their successors, and
/// every pose in the threshold window before a crossing (the same test as
/// [`thresholds::threshold_score`], on the same f64 times, so no window pose is left out).
fn plan_poses(walk: &Trajectory, scene: &Scene, config: &EvalConfig) -> PosePlan {
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
    let mut roles: BTreeMap<usize, Role> = BTreeMap::new();
    for &a in &anchors {
        roles.insert(a, Role::Anchor);
        if a + 1 < n {
            let r = roles.entry(a + 1).or_insert(Role::Successor);
            *r = (*r).max(Role::Successor);
        }
    }
    let crossings: Vec<Crossing> = walk
        .crossings
        .iter()
        .filter_map(|c| {
            scene.thresholds.get(c.threshold_id as usize).map(|t| Crossing {
                instance_id: t.instance_id,
                time_s: if config.crossing_at_contact {
                    contact_time_s(walk, c.pose_index, t.min.truncate(), t.max.truncate())
                } else {
                    f64::from(c.time_s)
                },
            })
        })
        .collect();
    for c in &crossings {
        for (i, p) in walk.poses.iter().enumerate() {
            let pt = f64::from(p.time_s);
            if pt <= c.time_s && pt >= c.time_s - config.threshold_window_s {
                roles.entry(i).or_insert(Role::Window);
            }
        }
    }
    PosePlan { anchors, jobs: roles.into_iter().collect(), crossings }
}

/// What stays the same over every pose of one house.
struct House<'a> {
    seed: u64,
    scene: &'a Scene,
    walk: &'a Trajectory,
    capture: &'a Capture<'a>,
    /// Per scenario: the camera's noise at each 8-bit output level, what the built-in detector
    /// divides contrast by (`scene_gen_perception::detection::output_noise` says why not the
    /// image's own estimate).
    noise_tables: Vec<Option<Vec<f64>>>,
    threshold_ids: BTreeSet<u32>,
}

/// The learned detector, loaded once per process from the built-in weights.
fn cnn_detector() -> Result<&'static CnnDetector, EvalError> {
    static DETECTOR: OnceLock<Result<CnnDetector, String>> = OnceLock::new();
    DETECTOR
        .get_or_init(|| CnnDetector::embedded().map_err(|e| e.to_string()))
        .as_ref()
        .map_err(|e| EvalError::Cnn(e.clone()))
}

/// Renders pose `i` for `role` and scores what can be scored on it alone: threshold pixels,
/// the scenarios' 8-bit images, ground truth and the built-in detector's answers. `spare`
/// holds frames finished with, for the next pose to render into.
fn render_pose(
    house: &House<'_>,
    config: &EvalConfig,
    (i, role): (usize, Role),
    spare: &Mutex<Vec<Frame>>,
) -> Result<PoseResult, EvalError> {
    let render_error = |source| EvalError::Render { seed: house.seed, source };
    let pose = house.walk.poses[i];
    let camera = house.capture.pinhole(&pose);
    let t0 = Instant::now();
    let time_s = f64::from(pose.time_s);
    if role == Role::Window {
        let thresholds = threshold_pixels_in_boxes(house.capture.renderer(), &camera, &house.scene.thresholds)
            .map_err(render_error)?;
        return Ok(PoseResult { thresholds, time_s, times: [secs(t0), 0.0, 0.0], ..PoseResult::default() });
    }
    let mut frame = spare.lock().map(|mut v| v.pop()).ok().flatten().unwrap_or_default();
    house.capture.render_into(&camera, &mut frame)?;
    let mut out = PoseResult {
        thresholds: threshold_pixels(&frame.class_id, &frame.instance_id, &house.threshold_ids),
        camera: Some(camera),
        depth_m: if role == Role::Anchor { frame.depth_m.clone() } else { Vec::new() },
        time_s,
        times: [secs(t0), 0.0, 0.0],
        ..PoseResult::default()
    };
    let t1 = Instant::now();
    let gt =
        (role == Role::Anchor).then(|| frame_ground_truth(&frame, house.scene, &camera, &GroundTruthConfig::default()));
    out.times[2] += secs(t1);
    let t1 = Instant::now();
    let images = house.capture.images_8bit(&frame, &camera, &pose, i as u64, config.output);
    out.times[1] += secs(t1);
    if let Some(objects) = &gt {
        let t1 = Instant::now();
        let detector = config.detectability;
        for (s, image) in images.iter().enumerate() {
            let grey = &image.grey;
            out.usable.push(image_usable(grey) && objects.iter().any(|o| o.counted));
            match &config.detector {
                DetectorChoice::Model => {
                    let image: Vec<f32> = grey.iter().map(|&v| f32::from(v)).collect();
                    let input = DetectorInput {
                        image_dn: &image,
                        width: camera.width_px,
                        height: camera.height_px,
                        instance_id: &frame.instance_id,
                        objects,
                        noise: house.noise_tables[s].as_deref().map_or(NoiseSource::Measured, NoiseSource::ByLevel),
                        // One draw seed per pose for both scenarios (common random numbers): an
                        // object is found by day and not at night only because its probability
                        // differs, not by the luck of the draw.
                        frame_seed: detector_seed(house.seed, i),
                    };
                    out.detections.push(detector.detect(&input));
                }
                DetectorChoice::Cnn => {
                    let (pixels, channels) = image.rgb.as_deref().map_or((grey.as_slice(), 1), |rgb| (rgb, 3));
                    let (width, height) = (camera.width_px as usize, camera.height_px as usize);
                    let view = ImageView { pixels, width, height, channels };
                    out.detections.push(cnn_detector()?.detect(view).map_err(|e| EvalError::Cnn(e.to_string()))?);
                }
                DetectorChoice::External(_) => {}
            }
        }
        out.times[2] += secs(t1);
    }
    out.images = images;
    out.gt = gt;
    if let Ok(mut frames) = spare.lock() {
        frames.push(frame);
    }
    Ok(out)
}

/// ORB on one (anchor, successor) pair of one scenario.
struct OrbPair {
    scenario: usize,
    /// RANSAC inliers the ground truth confirms ([`crate::true_matches`]).
    inliers: f64,
    /// Every RANSAC inlier, confirmed or not.
    ransac_inliers: f64,
    /// `inliers / (inliers + anchor keypoints)`.
    ratio: f64,
    keypoints: f64,
    thread_s: f64,
}

/// ORB on each (anchor, successor) pair of each scenario, in parallel.
fn orb_pairs(seed: u64, anchors: &[usize], by_pose: &BTreeMap<usize, PoseResult>, (w, h): (u32, u32)) -> Vec<OrbPair> {
    let orb = Orb::with_features(ORB_FEATURES);
    let jobs: Vec<(usize, usize)> = (0..SCENARIO_GROUPS.len())
        .flat_map(|s| anchors.iter().filter(|&&a| by_pose.contains_key(&(a + 1))).map(move |&a| (s, a)))
        .collect();
    jobs.par_iter()
        .map(|&(s, a)| {
            let t0 = Instant::now();
            let ga = &by_pose[&a].images[s].grey;
            let gb = &by_pose[&(a + 1)].images[s].grey;
            let (ka, da) = orb.detect_and_compute((ga.as_slice(), w as usize, h as usize)).unwrap_or_default();
            let (kb, db) = orb.detect_and_compute((gb.as_slice(), w as usize, h as usize)).unwrap_or_default();
            let ransac = FundamentalRansac {
                seed: scene_gen_core::rng::fnv1a64(format!("evaluate/ransac/{seed}/{a}/{s}").as_bytes()),
                ..FundamentalRansac::default()
            };
            let (matches, inl) = match_and_verify(&ka, &da, &kb, &db, &ransac);
            // Only RANSAC's inliers are checked against the ground truth, at its own threshold.
            let inliers = match (&by_pose[&a].camera, &by_pose[&(a + 1)].camera) {
                (Some(anchor), Some(successor)) => {
                    let truth = PairTruth { anchor, anchor_depth_m: &by_pose[&a].depth_m, successor };
                    let tolerance_px = ransac.threshold_px as f32;
                    matches.iter().zip(&inl).filter(|&(&m, &i)| i && truth.confirms(m, &ka, &kb, tolerance_px)).count()
                }
                _ => 0,
            } as f64;
            let ransac_inliers = inl.iter().filter(|&&b| b).count() as f64;
            let keypoints = ka.len() as f64;
            let ratio = if inliers + keypoints > 0.0 { inliers / (inliers + keypoints) } else { 0.0 };
            OrbPair { scenario: s, inliers, ransac_inliers, ratio, keypoints, thread_s: secs(t0) }
        })
        .collect()
}

/// The running totals of one evaluation, over its houses.
struct Tally {
    accs: Vec<Acc>,
    categories: Vec<CocoCategory>,
    threshold_config: ThresholdConfig,
    /// The external detector's image folder and its requests, by scenario.
    scratch: Option<ScratchDir>,
    requests: Vec<(usize, PluginRequest)>,
    next_image_id: u64,
    timing: Timing,
}

impl Tally {
    fn new(resolved: &ResolvedCamera, config: &EvalConfig) -> Result<Tally, EvalError> {
        let categories: Vec<CocoCategory> = ObjectClass::ALL
            .iter()
            .map(|c| CocoCategory { id: c.class_id(), name: c.name().to_string() })
            .chain(std::iter::once(CocoCategory { id: THRESHOLD_CLASS_ID, name: THRESHOLD_CLASS_NAME.to_string() }))
            .collect();
        let mut accs = vec![Acc::default(); SCENARIO_GROUPS.len()];
        for acc in &mut accs {
            acc.gt.categories.clone_from(&categories);
        }
        // The visible-pixel floor, given at 640 x 480, scales with the pixel count.
        let pixels = f64::from(resolved.width_px) * f64::from(resolved.height_px);
        let min_px = ((f64::from(thresholds::DEFAULT_MIN_VISIBLE_PX) * pixels / VGA_PIXELS).round() as u32).max(1);
        Ok(Tally {
            accs,
            categories,
            threshold_config: ThresholdConfig { window_s: config.threshold_window_s, min_visible_px: min_px },
            scratch: config.detector.external().map(|_| ScratchDir::new()).transpose()?,
            requests: Vec::new(),
            next_image_id: 1,
            timing: Timing::default(),
        })
    }

    /// Renders and scores the house of `seed`.
    fn add_house(
        &mut self,
        library: &Library,
        seed: u64,
        spec: &CameraSpec,
        resolved: &ResolvedCamera,
        config: &EvalConfig,
        progress: &dyn Progress,
    ) -> Result<(), EvalError> {
        let setup = Instant::now();
        let params = TrajectoryParams {
            height_m: spec.height_m,
            speed_m_per_s: config.speed_m_s as f32,
            ..TrajectoryParams::default()
        };
        let WalkedHouse { scene, walk } = walked_house_with(library, &config.house.config(seed), &params)?;
        let noise_label = format!("evaluate/{seed}/");
        let capture =
            Capture::new(&scene, resolved, &SCENARIO_GROUPS, config.render, params.speed_m_per_s, noise_label)?;
        let noise_tables = capture
            .scenarios()
            .iter()
            .map(|s| match (&s.colour, config.output) {
                (Some(colour), OutputRule::Isp) => {
                    Some(colour_output_noise_by_level(resolved, s.gain_db, colour, f64::from(s.light.target_lux)))
                }
                _ => output_noise_by_level(resolved, s.gain_db, config.output, &s.isp),
            })
            .collect();
        let threshold_ids = scene.thresholds.iter().map(|t| t.instance_id).collect();
        let house = House { seed, scene: &scene, walk: &walk, capture: &capture, noise_tables, threshold_ids };
        let plan = plan_poses(&walk, &scene, config);
        self.timing.setup += secs(setup);

        let spare_frames: Mutex<Vec<Frame>> = Mutex::new(Vec::new());
        progress.planned(plan.jobs.len() as u64);
        let results: Vec<Result<PoseResult, EvalError>> = plan
            .jobs
            .par_iter()
            .map(|&job| {
                let result = render_pose(&house, config, job, &spare_frames);
                progress.done(true);
                result
            })
            .collect();
        let mut by_pose: BTreeMap<usize, PoseResult> = BTreeMap::new();
        for (&(i, _), r) in plan.jobs.iter().zip(results) {
            let r = r?;
            self.timing.render += r.times[0];
            self.timing.sensor += r.times[1];
            self.timing.detection += r.times[2];
            by_pose.insert(i, r);
        }
        log::info!("evaluate: house {seed}: {} poses rendered and scored", plan.jobs.len());
        self.add_thresholds(&by_pose, &plan.crossings);
        self.add_orb(seed, &plan.anchors, &by_pose, (resolved.width_px, resolved.height_px));
        self.add_detections(seed, &plan.anchors, &by_pose, (resolved.width_px, resolved.height_px))
    }

    /// Threshold accuracy (geometric: the same in both scenarios).
    fn add_thresholds(&mut self, by_pose: &BTreeMap<usize, PoseResult>, crossings: &[Crossing]) {
        let vis: Vec<FrameVisibility> =
            by_pose.values().map(|p| FrameVisibility { time_s: p.time_s, visible_px: p.thresholds.clone() }).collect();
        let ts = thresholds::threshold_score(&vis, crossings, &self.threshold_config);
        for acc in &mut self.accs {
            acc.seen += ts.seen;
            acc.missed += ts.missed;
        }
    }

    /// ORB inliers and ratios of the anchor pairs.
    fn add_orb(&mut self, seed: u64, anchors: &[usize], by_pose: &BTreeMap<usize, PoseResult>, size: (u32, u32)) {
        for pair in orb_pairs(seed, anchors, by_pose, size) {
            let acc = &mut self.accs[pair.scenario];
            acc.inliers += pair.inliers;
            acc.ransac_inliers += pair.ransac_inliers;
            acc.ratio += pair.ratio;
            acc.keypoints += pair.keypoints;
            acc.pairs += 1;
            self.timing.orb += pair.thread_s;
        }
    }

    /// Ground truth and detections of every anchor, in pose order; one image id per (anchor,
    /// scenario). For an external detector, the anchors' images are written for it.
    fn add_detections(
        &mut self,
        seed: u64,
        anchors: &[usize],
        by_pose: &BTreeMap<usize, PoseResult>,
        (w, h): (u32, u32),
    ) -> Result<(), EvalError> {
        for &a in anchors {
            let p = &by_pose[&a];
            let objects = p.gt.as_deref().unwrap_or(&[]);
            for (s, acc) in self.accs.iter_mut().enumerate() {
                let image_id = self.next_image_id;
                self.next_image_id += 1;
                let file_name = format!("seed{seed}_pose{a:05}_{}.png", scenario_name(SCENARIO_GROUPS[s]));
                acc.frames += 1;
                acc.usable += usize::from(p.usable.get(s).copied().unwrap_or(false));
                acc.gt.images.push(CocoImage { id: image_id, width: w, height: h, file_name: file_name.clone() });
                let first = acc.gt.annotations.len() as u64 + 1;
                acc.gt.annotations.extend(to_annotations(objects, image_id, first));
                if let Some(dets) = p.detections.get(s) {
                    acc.dets.extend(dets.iter().map(|d| d.record(image_id)));
                }
                if let Some(dir) = &self.scratch {
                    let t0 = Instant::now();
                    let path = dir.0.join(&file_name);
                    // A colour camera's plug-in detector sees its sRGB image, a grey one's the grey.
                    let saved = match &p.images[s].rgb {
                        Some(rgb) => image::RgbImage::from_raw(w, h, rgb.clone()).map(|img| img.save(&path)),
                        None => image::GrayImage::from_raw(w, h, p.images[s].grey.clone()).map(|img| img.save(&path)),
                    };
                    saved.ok_or_else(|| io_error(&path, &"image size mismatch"))?.map_err(|e| io_error(&path, &e))?;
                    self.requests
                        .push((s, PluginRequest { image_id, path: path.display().to_string(), width: w, height: h }));
                    self.timing.detection += secs(t0);
                }
            }
        }
        Ok(())
    }

    /// Runs the external detector once over every anchor image of every house, both scenarios'
    /// ground truth in one COCO file beside them (ids are unique across them).
    fn run_external_detector(&mut self, det: &ExternalDetector) -> Result<(), EvalError> {
        let Some(dir) = &self.scratch else { return Ok(()) };
        let t0 = Instant::now();
        let mut all = CocoGroundTruth { categories: self.categories.clone(), ..CocoGroundTruth::default() };
        for acc in &self.accs {
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
        let reqs: Vec<PluginRequest> = self.requests.iter().map(|(_, r)| r.clone()).collect();
        let records = plugin::run(&det.program, &args, &reqs)?;
        let scenario_of: HashMap<u64, usize> = self.requests.iter().map(|(s, r)| (r.image_id, *s)).collect();
        for rec in records {
            if let Some(&s) = scenario_of.get(&rec.image_id) {
                self.accs[s].dets.push(rec);
            }
        }
        // Sorted by image then score so the result does not depend on the detector's answer order.
        for acc in &mut self.accs {
            acc.dets.sort_by(|a, b| a.image_id.cmp(&b.image_id).then(b.score.total_cmp(&a.score)));
        }
        self.timing.plugin = secs(t0);
        Ok(())
    }

    /// The scores of one scenario: COCO AP@0.5, threshold accuracy, ORB means and the fitness.
    fn score(acc: &Acc, config: &EvalConfig) -> Result<ScenarioScore, EvalError> {
        let weights = config.weights;
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
        Ok(ScenarioScore {
            threshold_accuracy,
            thresholds_seen: acc.seen,
            thresholds_missed: acc.missed,
            ap50,
            ground_truth_objects: acc.gt.annotations.len(),
            mean_inliers,
            mean_ransac_inliers: acc.ransac_inliers / pairs,
            inlier_ratio,
            mean_keypoints: acc.keypoints / pairs,
            frames: acc.frames,
            usable_images: acc.usable,
            min_usable_images: min_usable,
            threshold_only,
            fitness,
        })
    }
}

/// The evaluation itself: every house rendered and scored, then the scores combined.
fn compute(
    spec: &CameraSpec,
    resolved: &ResolvedCamera,
    seeds: &[u64],
    config: &EvalConfig,
    progress: &dyn Progress,
) -> Result<Evaluation, EvalError> {
    COMPUTED.fetch_add(1, Ordering::SeqCst);
    let wall = Instant::now();
    let library = load_library(&config.house)?;
    let mut tally = Tally::new(resolved, config)?;
    for &seed in seeds {
        tally.add_house(&library, seed, spec, resolved, config, progress)?;
    }
    if let Some(det) = config.detector.external() {
        tally.run_external_detector(det)?;
    }
    let day = Tally::score(&tally.accs[0], config)?;
    let night = Tally::score(&tally.accs[1], config)?;
    let fitness = Fitness { day: day.fitness, night: night.fitness, mean: 0.5 * (day.fitness + night.fitness) };
    tally.timing.wall = secs(wall);
    Ok(Evaluation {
        camera: spec.clone(),
        seeds: seeds.to_vec(),
        config: config.clone(),
        scenarios: Scenarios { day, night },
        fitness,
        timing_s: Some(tally.timing),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene_gen_camera::sensor::Catalog;

    #[test]
    fn frame_width_reads_native_or_a_positive_width_and_writes_it_back() {
        #[derive(serde::Deserialize, Serialize)]
        struct Holder {
            w: FrameWidth,
        }
        for (text, want) in [("w = \"native\"", FrameWidth::Native), ("w = 320", FrameWidth::AtMost(320))] {
            let read: Holder = toml::from_str(text).unwrap();
            assert_eq!(read.w, want, "{text}");
            assert_eq!(toml::to_string(&read).unwrap().trim(), text);
            assert_eq!(FrameWidth::parse(&want.to_string()), Ok(want));
        }
        for bad in ["w = 0", "w = -3", "w = \"wide\"", "w = 5000000000", "w = 1.5"] {
            assert!(toml::from_str::<Holder>(bad).is_err(), "{bad}");
        }
        assert_eq!(FrameWidth::parse(" Native "), Ok(FrameWidth::Native));
        assert!(FrameWidth::parse("0").is_err() && FrameWidth::parse("").is_err());
        assert_eq!(FrameWidth::Native.max_width_px(), None);
        assert_eq!(FrameWidth::AtMost(64).max_width_px(), Some(64));
    }

    /// Counting each threshold over its box's pixels gives the counts of the whole frame, on
    /// the poses before every crossing of a house (where thresholds are near, below and beside
    /// the camera) for a downward and a level camera.
    #[test]
    fn threshold_counts_in_boxes_equal_whole_frame_counts() {
        let library = scene_gen_scene::house::embedded_library().unwrap();
        for spec in ["IMX174,focal_mm=2.5,pitch_deg=-40", "IMX174,focal_mm=6,pitch_deg=0"] {
            let spec = CameraSpec { max_width_px: Some(96), ..CameraSpec::from_inline(spec).unwrap() };
            let resolved = spec.resolve(&Catalog::embedded()).unwrap();
            let params = TrajectoryParams { height_m: resolved.spec.height_m, ..TrajectoryParams::default() };
            let WalkedHouse { scene, walk } = scene_gen_scene::house::walked_house(&library, 1, &params).unwrap();
            // Ids only: no light, so no irradiance volume to trace.
            let renderer = Renderer::new(&scene, RenderSettings { indirect_volume: None, ..RenderSettings::preview() });
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
