//! The evaluator: perception scores of one camera candidate, TaCOS style
//! (reference/tacos_facts.md), over seeded houses.
//!
//! Per seed the house is generated with the default configuration, the agent's walk is planned
//! at the spec's mounting height ([`crate::trajectory`]), and frames are rendered at
//! [`EvalConfig::frames_per_scene`] *anchor* poses evenly spaced along the walk. Each anchor is
//! rendered together with its successor pose (0.25 m later) so ORB has a genuine consecutive
//! pair to match: anchors alone are metres apart and would give zero inliers whatever the camera.
//! The poses in the 0.5 s window before every door crossing are rendered as well, for
//! threshold visibility only: anchors are too sparse to ever fall in that window.
//!
//! ONE trace per pose serves day and night: the light groups are scaled so the mean
//! illuminance on the 0.75 m plane is 20 lux by day and 2 lux by night, exactly as
//! `scene-gen render` does ([`scenario_light_scales`]). Per scenario (day at the spec's
//! `gain_day_db`, night at `gain_night_db`) the noisy sensor image is reduced to 8-bit grey
//! (the top 8 bits of the ADC value, or the luma of an RGB capture), which ORB and the
//! detector see.
//!
//! Scores per scenario:
//! * threshold accuracy ([`thresholds::threshold_score`]); the visible-pixel floor is
//!   [`thresholds::DEFAULT_MIN_VISIBLE_PX`] at 640 x 480, scaled with the pixel count so tiny
//!   evaluation images are not penalised for their size. It is geometric, so it is the same in
//!   both scenarios;
//!   at the walk's 0.5 m/s the window is the last 0.25 m before the door plane, so the sill lies
//!   about 0.1..0.35 m ahead of a 0.8 m high camera: only a steep, wide view (e.g. 1.5 mm at
//!   -30 deg on an IMX172) sees it, and the default 4 mm / -10 deg camera scores 0;
//! * AP@0.5 of the [`DetectabilityModel`] on the anchors' noisy images against the instance
//!   buffer's ground truth ([`frame_ground_truth`]), [`coco_eval::evaluate`] over every anchor
//!   of every seed (an AP of -1, no ground truth at all, counts as 0);
//! * ORB (2000 features, cross-checked matches, fundamental RANSAC at 3 px) on each
//!   (anchor, successor) pair: mean inliers per pair, and the mean inlier ratio
//!   `inliers / (inliers + keypoints)`, keypoints of the anchor frame (tacos_facts.md);
//! * fitness = threshold accuracy + AP@0.5 + 0.0025 x mean inliers + 0.5 x inlier ratio
//!   (weights in [`FitnessWeights`]).
//!
//! Frames are rendered and scored in parallel (rayon); every random draw is seeded by the
//! seed, pose index and scenario, and results are gathered in pose order, so the output does not
//! depend on the thread count. Results are cached per process, keyed by the normalised spec
//! (its JSON), the seeds and the configuration.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};

use rayon::prelude::*;
use serde::Serialize;

use crate::camera_spec::{CameraSpec, ResolvedCamera, SpecError};
use crate::config::GeneratorConfig;
use crate::detection::coco_eval::{self, CocoCategory, CocoGroundTruth, CocoImage, DetectionRecord};
use crate::detection::ground_truth::to_annotations;
use crate::detection::thresholds::{self, Crossing, FrameVisibility, ThresholdConfig};
use crate::detection::{DetectabilityModel, Detector, DetectorInput, GroundTruthConfig, frame_ground_truth};
use crate::generate::generate;
use crate::library::Library;
use crate::lights::{DAY_TARGET_LUX, NIGHT_TARGET_LUX, TARGET_PLANE_M};
use crate::orb::{FundamentalRansac, Orb, match_and_verify};
use crate::radiometry::{Capture, capture};
use crate::render::{Frame, RenderError, RenderSettings, Renderer, measure_mean_illuminance};
use crate::scene::{LightGroup, ObjectClass, Scene, THRESHOLD_CLASS_ID, THRESHOLD_CLASS_NAME};
use crate::sensor::Catalog;
use crate::trajectory::{self, TrajectoryParams};

/// Default anchor frames per house: small, so a candidate evaluates in seconds.
pub const DEFAULT_FRAMES_PER_SCENE: u32 = 25;
/// Default binned width of the evaluation images, px.
pub const DEFAULT_MAX_WIDTH_PX: u32 = 320;
/// ORB features per frame (tacos_facts.md: 2000).
pub const ORB_FEATURES: usize = 2000;
/// Pixel count the threshold visibility floor is given for (640 x 480).
const VGA_PIXELS: f64 = 640.0 * 480.0;

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
    pub weights: FitnessWeights,
}

impl Default for EvalConfig {
    fn default() -> Self {
        EvalConfig {
            frames_per_scene: DEFAULT_FRAMES_PER_SCENE,
            max_width_px: Some(DEFAULT_MAX_WIDTH_PX),
            render: RenderSettings::preview(),
            render_name: "preview".to_string(),
            threshold_window_s: thresholds::DEFAULT_WINDOW_S,
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
    /// AP@0.5 of the built-in detector; 0 when no frame had ground truth.
    pub ap50: f64,
    pub ground_truth_objects: usize,
    pub mean_inliers: f64,
    pub inlier_ratio: f64,
    pub mean_keypoints: f64,
    /// Anchor frames scored.
    pub frames: usize,
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

/// A candidate's evaluation (the `--json` output).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Evaluation {
    pub camera: CameraSpec,
    pub seeds: Vec<u64>,
    pub scenarios: Scenarios,
    pub fitness: Fitness,
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
    #[error("libraries: {0}")]
    Library(String),
    #[error("house of seed {seed}: {why}")]
    Generate { seed: u64, why: String },
    #[error("walk in house {seed}: {source}")]
    Trajectory {
        seed: u64,
        #[source]
        source: trajectory::TrajectoryError,
    },
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
    // Normalised key: the resolved spec (canonical sensor name, defaults filled in) as JSON.
    let mut key_spec = resolved.spec.clone();
    key_spec.sensor = resolved.sensor.model.clone();
    let key = format!(
        "{}|{:?}|{}",
        serde_json::to_string(&key_spec).unwrap_or_default(),
        seeds,
        serde_json::to_string(config).unwrap_or_default()
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
    let resolved = spec.resolve(&Catalog::embedded())?;
    Ok((spec, resolved))
}

/// What one rendered pose contributes.
struct PoseResult {
    /// Threshold instance id -> visible pixels.
    thresholds: Vec<(u32, u32)>,
    time_s: f64,
    /// Per scenario: grey image (anchors and successors only).
    grey: Vec<Vec<u8>>,
    /// Ground truth and per-scenario detections (anchors only).
    gt: Option<Vec<crate::detection::GtObject>>,
    detections: Vec<Vec<crate::detection::Detection>>,
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
    gt: CocoGroundTruth,
    dets: Vec<DetectionRecord>,
}

fn to_grey(cap: &Capture) -> Vec<u8> {
    if cap.channels == 3 {
        cap.dn
            .chunks_exact(3)
            .map(|c| {
                let y = 0.2126 * f64::from(c[0]) + 0.7152 * f64::from(c[1]) + 0.0722 * f64::from(c[2]);
                y.round().clamp(0.0, 255.0) as u8
            })
            .collect()
    } else {
        let shift = cap.bits.saturating_sub(8);
        cap.dn.iter().map(|&v| (v >> shift).min(255) as u8).collect()
    }
}

#[allow(clippy::too_many_lines)]
fn compute(
    spec: &CameraSpec,
    resolved: &ResolvedCamera,
    seeds: &[u64],
    config: &EvalConfig,
) -> Result<Evaluation, EvalError> {
    COMPUTED.fetch_add(1, Ordering::SeqCst);
    let library = Library::embedded().map_err(|e| EvalError::Library(e.to_string()))?;
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
    let mut next_image_id = 1u64;

    for &seed in seeds {
        let scene: Scene = generate(&GeneratorConfig { seed, ..GeneratorConfig::default() }, &library)
            .map_err(|e| EvalError::Generate { seed, why: e.to_string() })?;
        let params = TrajectoryParams { height_m: spec.height_m, ..TrajectoryParams::default() };
        let walk = trajectory::plan(&scene, &params).map_err(|source| EvalError::Trajectory { seed, source })?;
        let renderer = Renderer::new(&scene, config.render);
        let scales = scenario_light_scales(&renderer, seed, &[LightGroup::Day, LightGroup::Night])?;
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
        for c in &walk.crossings {
            let t = f64::from(c.time_s);
            for (i, p) in walk.poses.iter().enumerate() {
                let pt = f64::from(p.time_s);
                if pt <= t && pt >= t - config.threshold_window_s {
                    roles.entry(i).or_insert(0);
                }
            }
        }
        let threshold_ids: BTreeSet<u32> = scene.thresholds.iter().map(|t| t.instance_id).collect();
        let jobs: Vec<(usize, u8)> = roles.into_iter().collect();
        let results: Vec<Result<PoseResult, RenderError>> = jobs
            .par_iter()
            .map(|&(i, role)| {
                let pose = walk.poses[i];
                let camera = resolved.camera_at(&pose);
                let frame: Frame = renderer.render(&camera)?;
                let mut counts: BTreeMap<u32, u32> = BTreeMap::new();
                for &id in &frame.instance_id {
                    if threshold_ids.contains(&id) {
                        *counts.entry(id).or_insert(0) += 1;
                    }
                }
                let mut out = PoseResult {
                    thresholds: counts.into_iter().collect(),
                    time_s: f64::from(pose.time_s),
                    grey: Vec::new(),
                    gt: None,
                    detections: Vec::new(),
                };
                if role == 0 {
                    return Ok(out);
                }
                let gt =
                    (role == 2).then(|| frame_ground_truth(&frame, &scene, &camera, &GroundTruthConfig::default()));
                for (s, &(_, _, scale, _)) in scales.iter().enumerate() {
                    let radiance = if s == 0 { frame.mix(scale, 0.0) } else { frame.mix(0.0, scale) };
                    let frame_seed = crate::rng::fnv1a64(format!("evaluate/{seed}/{i}/{}", names[s]).as_bytes());
                    let cap = capture(resolved, &camera, &radiance, gains[s], seed, frame_seed);
                    let grey = to_grey(&cap);
                    if let Some(objects) = &gt {
                        let image: Vec<f32> = grey.iter().map(|&v| f32::from(v)).collect();
                        let input = DetectorInput {
                            image_dn: &image,
                            width: cap.width,
                            height: cap.height,
                            instance_id: &frame.instance_id,
                            objects,
                            noise_std_dn: None,
                            frame_seed,
                        };
                        out.detections.push(model.detect(&input));
                    }
                    out.grey.push(grey);
                }
                out.gt = gt;
                Ok(out)
            })
            .collect();
        let mut by_pose: BTreeMap<usize, PoseResult> = BTreeMap::new();
        for (&(i, _), r) in jobs.iter().zip(results) {
            by_pose.insert(i, r.map_err(|source| EvalError::Render { seed, source })?);
        }

        // Thresholds (geometric: the same in both scenarios).
        let vis: Vec<FrameVisibility> =
            by_pose.values().map(|p| FrameVisibility { time_s: p.time_s, visible_px: p.thresholds.clone() }).collect();
        let crossings: Vec<Crossing> = walk
            .crossings
            .iter()
            .filter_map(|c| {
                scene
                    .thresholds
                    .get(c.threshold_id as usize)
                    .map(|t| Crossing { instance_id: t.instance_id, time_s: f64::from(c.time_s) })
            })
            .collect();
        let ts = thresholds::threshold_score(&vis, &crossings, &tcfg);

        // ORB pairs, in parallel over (scenario, anchor).
        let pair_jobs: Vec<(usize, usize)> =
            (0..2).flat_map(|s| anchors.iter().filter(|&&a| a + 1 < n).map(move |&a| (s, a))).collect();
        let pair_scores: Vec<(usize, f64, f64, f64)> = pair_jobs
            .par_iter()
            .map(|&(s, a)| {
                let ga = &by_pose[&a].grey[s];
                let gb = &by_pose[&(a + 1)].grey[s];
                let (ka, da) = orb.detect_and_compute((ga.as_slice(), w as usize, h as usize)).unwrap_or_default();
                let (kb, db) = orb.detect_and_compute((gb.as_slice(), w as usize, h as usize)).unwrap_or_default();
                let ransac = FundamentalRansac {
                    seed: crate::rng::fnv1a64(format!("evaluate/ransac/{seed}/{a}/{s}").as_bytes()),
                    ..FundamentalRansac::default()
                };
                let (_, inl) = match_and_verify(&ka, &da, &kb, &db, &ransac);
                let inliers = inl.iter().filter(|&&b| b).count() as f64;
                let kp = ka.len() as f64;
                let ratio = if inliers + kp > 0.0 { inliers / (inliers + kp) } else { 0.0 };
                (s, inliers, ratio, kp)
            })
            .collect();
        for (s, inliers, ratio, kp) in pair_scores {
            let acc = &mut accs[s];
            acc.inliers += inliers;
            acc.ratio += ratio;
            acc.keypoints += kp;
            acc.pairs += 1;
        }

        // Detection: every anchor, in pose order.
        for &a in &anchors {
            let p = &by_pose[&a];
            let image_id = next_image_id;
            next_image_id += 1;
            let objects = p.gt.as_deref().unwrap_or(&[]);
            for (s, acc) in accs.iter_mut().enumerate() {
                acc.frames += 1;
                acc.gt.images.push(CocoImage {
                    id: image_id,
                    width: w,
                    height: h,
                    file_name: format!("seed{seed}_pose{a:05}_{}", names[s]),
                });
                let first = acc.gt.annotations.len() as u64 + 1;
                acc.gt.annotations.extend(to_annotations(objects, image_id, first));
                if let Some(dets) = p.detections.get(s) {
                    acc.dets.extend(dets.iter().map(|d| d.record(image_id)));
                }
            }
        }
        for acc in &mut accs {
            acc.seen += ts.seen;
            acc.missed += ts.missed;
        }
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
        let fitness = weights.threshold * threshold_accuracy
            + weights.ap50 * ap50
            + weights.inliers * mean_inliers
            + weights.inlier_ratio * inlier_ratio;
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
            fitness,
        });
    }
    let night = scores.pop().expect("two scenarios");
    let day = scores.pop().expect("two scenarios");
    let fitness = Fitness { day: day.fitness, night: night.fitness, mean: 0.5 * (day.fitness + night.fitness) };
    Ok(Evaluation { camera: spec.clone(), seeds: seeds.to_vec(), scenarios: Scenarios { day, night }, fitness })
}
