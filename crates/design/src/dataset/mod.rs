//! Datasets for training detectors: sensor images, depth, instance masks and COCO instance
//! annotations of a camera walking through many seeded houses (`scene-gen dataset`).
//!
//! A [`Dataset`] is a folder and the [`DatasetSpec`] that fixes every byte in it (seeds,
//! camera, lighting, frame selection, render quality, ground-truth rule), stored as
//! `DIR/dataset.json`. Work is split by seed:
//!
//! 1. [`Dataset::run_seed`] generates the house of one seed (default generator settings), plans
//!    the agent's walk ([`scene_gen_scene::trajectory`]) at the camera height, picks poses with
//!    [`FrameSelection`], and per pose renders, through the capture stage
//!    ([`scene_gen_camera::capture::Capture`]), ONE trace that serves day and night (lights
//!    scaled to 20 / 2 lux as in `render` and `evaluate`). Per pose it
//!    writes the sensor image of each lighting, the depth, the instance mask and the pose's
//!    labels; then the seed's **fragment** `fragments/seed_S.json`.
//! 2. [`Shard`] picks a machine's seeds (seed number in the range mod N);
//!    [`Dataset::run_shard`] runs them.
//! 3. [`Dataset::merge`] turns the fragments into `annotations/instances_<lighting>.json`, one
//!    COCO file per lighting, once every seed of the range has its fragment.
//!
//! Resumption: every file is written atomically (temporary file, then rename; see
//! `write_shared` for files several machines write), so a killed
//! run leaves only whole files. A pose whose files all exist is not rendered again; a seed
//! whose fragment exists is not even generated again. Determinism: nothing depends on the
//! shard, the thread count or the order runs finish in, so N shard runs and a merge give the
//! same bytes as one run.
//!
//! Ids ([`image_id`]): an image's id is `1 + 2 (seed 2^20 + pose) + lighting` (lighting 0 day,
//! 1 night), a function of what the image is, below 2^53. Annotation ids are 1, 2, ... in
//! image-id order within each COCO file, assigned at the merge.
//!
//! Which objects are annotated: those [`frame_ground_truth`] counts (within 6 m, above the
//! visible-pixel floor), categories 1..10 the object classes and 11 the door threshold. The
//! bbox, area and RLE segmentation all come from the instance mask: the annotation's mask is
//! exactly the pixels of its instance id in `masks/`.

pub mod png;
pub mod rle;
pub mod shard;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use scene_gen_camera::camera_spec::{CameraSpec, ResolvedCamera, SpecError};
use scene_gen_camera::capture::{Capture, CaptureError};
use scene_gen_camera::sensor::Catalog;
use scene_gen_camera::view::ViewGeometry;
use scene_gen_perception::detection::{GroundTruthConfig, frame_ground_truth};
use scene_gen_render::RenderSettings;
use scene_gen_scene::house::{HouseError, HouseOptions, WalkedHouse, load_library, walked_house_with};
use scene_gen_scene::scene::{LightGroup, ObjectClass, THRESHOLD_CLASS_ID, THRESHOLD_CLASS_NAME};
use scene_gen_scene::trajectory::TrajectoryParams;

use crate::evaluate::eval_render_settings;

pub use rle::{Rle, RleJson};
pub use shard::{SeedRange, Shard, ShardError, parse_seeds};

/// Schema of `dataset.json`.
/// Version 2: `images/` hold the camera's 8-bit image (sRGB for colour sensors) instead of the
/// raw capture, which `raw/` holds when [`DatasetSpec::raw`] is set.
pub const SCHEMA: &str = "scene-gen/dataset/2";

/// Poses per walk an image id can tell apart (20 bits).
pub const MAX_POSES: usize = 1 << 20;

/// Why a dataset could not be made.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    #[error(transparent)]
    Spec(#[from] SpecError),
    #[error(transparent)]
    Shard(#[from] ShardError),
    #[error("{0}")]
    Invalid(String),
    #[error(
        "{dir} holds a dataset made with other settings (its dataset.json differs); use another --out or the same \
         settings"
    )]
    Mismatch { dir: PathBuf },
    #[error(transparent)]
    House(#[from] HouseError),
    #[error(transparent)]
    Capture(#[from] CaptureError),
    #[error("house {seed}: {why}")]
    Limit { seed: u64, why: String },
    #[error(transparent)]
    Write(#[from] scene_gen_core::io::WriteError),
    #[error("{path}: {why}")]
    Read { path: PathBuf, why: String },
    #[error("cannot merge: {missing} of {total} seeds have no fragment yet (first: {first})")]
    Incomplete { missing: usize, total: u64, first: u64 },
}

/// Which poses of a walk become frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "rule")]
pub enum FrameSelection {
    /// Every pose (one every 0.25 m).
    All,
    /// Poses 0, step, 2 step, ...
    Every { step: u32 },
    /// `frames` poses evenly spaced from the first to the last (fewer on a short walk).
    Count { frames: u32 },
}

impl FrameSelection {
    /// Indices of the chosen poses of a walk of `poses` poses, increasing, without repeats.
    #[must_use]
    pub fn select(&self, poses: usize) -> Vec<usize> {
        if poses == 0 {
            return Vec::new();
        }
        match *self {
            FrameSelection::All => (0..poses).collect(),
            FrameSelection::Every { step } => (0..poses).step_by(step.max(1) as usize).collect(),
            FrameSelection::Count { frames } => {
                let k = (frames.max(1) as usize).min(poses);
                if k == 1 {
                    return vec![0];
                }
                (0..k)
                    .map(|i| ((i * (poses - 1)) as f64 / (k - 1) as f64).round() as usize)
                    .collect::<BTreeSet<_>>()
                    .into_iter()
                    .collect()
            }
        }
    }
}

/// A lighting scenario of the dataset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Lighting {
    Day,
    Night,
}

impl Lighting {
    /// `day` or `night`, as in file names.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Lighting::Day => "day",
            Lighting::Night => "night",
        }
    }

    /// The light group that is on.
    #[must_use]
    pub fn group(self) -> LightGroup {
        match self {
            Lighting::Day => LightGroup::Day,
            Lighting::Night => LightGroup::Night,
        }
    }

    /// The low bit of the image id.
    #[must_use]
    pub fn bit(self) -> u64 {
        match self {
            Lighting::Day => 0,
            Lighting::Night => 1,
        }
    }
}

/// Ray-tracer sample presets (as `scene-gen render --quality`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Quality {
    /// The evaluator's render ([`eval_render_settings`]): one ray per pixel, the irradiance
    /// at adaptive anchors every few pixels (texture and edges still at every pixel), every
    /// light traced, the volume's bounced light. The fastest preset, and the frames a
    /// candidate is judged on.
    Evaluator,
    /// One ray per pixel, shaded at every pixel ([`RenderSettings::preview`]).
    Preview,
    /// [`RenderSettings::standard`].
    Standard,
    /// [`RenderSettings::high`].
    High,
}

impl Quality {
    /// The renderer settings of the preset.
    #[must_use]
    pub fn settings(self) -> RenderSettings {
        match self {
            Quality::Evaluator => eval_render_settings(),
            Quality::Preview => RenderSettings::preview(),
            Quality::Standard => RenderSettings::standard(),
            Quality::High => RenderSettings::high(),
        }
    }
}

/// Everything that determines a dataset's bytes: `DIR/dataset.json`. The shard is not part
/// of it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatasetSpec {
    pub schema: String,
    pub generator_version: String,
    /// First and last seed (inclusive).
    pub seed_first: u64,
    pub seed_last: u64,
    /// The camera, as resolved (canonical sensor name, binning limit included).
    pub camera: CameraSpec,
    /// Day, night or both (in this order).
    pub lighting: Vec<Lighting>,
    pub frames: FrameSelection,
    pub quality: Quality,
    pub ground_truth: GroundTruthConfig,
    /// The houses: envelope, smallest room, libraries (absent when default).
    #[serde(default, skip_serializing_if = "HouseOptions::is_default")]
    pub house: HouseOptions,
    /// Also write the raw captures under `raw/` (DN at the ADC depth; a colour sensor's Bayer
    /// mosaic).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub raw: bool,
}

impl DatasetSpec {
    /// A spec with this binary's schema and version and the default ground-truth rule.
    #[must_use]
    pub fn new(
        seeds: SeedRange,
        camera: CameraSpec,
        lighting: Vec<Lighting>,
        frames: FrameSelection,
        quality: Quality,
    ) -> DatasetSpec {
        DatasetSpec {
            schema: SCHEMA.to_string(),
            generator_version: env!("CARGO_PKG_VERSION").to_string(),
            seed_first: seeds.first,
            seed_last: seeds.last,
            camera,
            lighting,
            frames,
            quality,
            ground_truth: GroundTruthConfig::default(),
            house: HouseOptions::default(),
            raw: false,
        }
    }

    /// The seed range.
    #[must_use]
    pub fn seeds(&self) -> SeedRange {
        SeedRange { first: self.seed_first, last: self.seed_last }
    }

    /// The `dataset.json` text.
    #[must_use]
    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("a spec serialises");
        s.push('\n');
        s
    }
}

/// The id of the image of `seed`, `pose` and `lighting`: `1 + 2 (seed 2^20 + pose) + bit`,
/// so it does not depend on which shard made it; below 2^53 for seeds up to
/// [`shard::MAX_SEED`] and poses below [`MAX_POSES`].
#[must_use]
pub fn image_id(seed: u64, pose: usize, lighting: Lighting) -> u64 {
    1 + 2 * ((seed << 20) + pose as u64) + lighting.bit()
}

/// One annotated instance of a frame (the pose's `labels/.../pose_P.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectLabel {
    /// Its id in the instance mask and the scene manifest.
    pub instance_id: u32,
    /// 1..10 object classes, 11 threshold.
    pub category_id: u32,
    /// Tight box of the mask, `[x, y, w, h]`.
    pub bbox: [u32; 4],
    /// Mask pixels.
    pub area: u64,
    pub segmentation: RleJson,
    /// Camera centre to the nearest visible point, metres.
    pub distance_m: f32,
    /// Visible pixels / unoccluded footprint.
    pub visible_fraction: f64,
}

/// The labels of one frame (shared by its day and night images).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameLabels {
    pub seed: u64,
    pub pose: usize,
    pub width: u32,
    pub height: u32,
    /// Intrinsics and camera-to-world pose ([`scene_gen_camera::view`] states the conventions);
    /// absent in labels written before frames carried them.
    #[serde(flatten, default, skip_serializing_if = "Option::is_none")]
    pub view: Option<ViewGeometry>,
    /// Time along the walk, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_s: Option<f32>,
    /// Exposure time, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure_s: Option<f64>,
    /// Analogue gain of each lighting's image, dB.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub gain_db: BTreeMap<Lighting, f64>,
    pub objects: Vec<ObjectLabel>,
}

/// The conventions of every `K` and `camera_to_world` a dataset writes.
pub const VIEW_AXES: &str = "world Z up, metres; camera x right, y down, z forward (OpenCV); pixel centres at integers";

/// `trajectories/seed_SSSSSSSSSS.json`: the camera path of one sequence (a seed's frames).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SequenceTrajectory {
    pub seed: u64,
    /// The conventions of `K` and `camera_to_world` ([`VIEW_AXES`]).
    pub axes: &'static str,
    pub frames: Vec<TrajectoryFrame>,
}

/// One frame of a [`SequenceTrajectory`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrajectoryFrame {
    pub pose: usize,
    pub time_s: f32,
    #[serde(flatten)]
    pub view: ViewGeometry,
}

/// A seed's fragment: the labels of all its frames, in pose order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fragment {
    pub seed: u64,
    pub frames: Vec<FrameLabels>,
}

/// An image entry of the merged COCO file (extra keys: where its depth and mask are).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CocoImageOut {
    pub id: u64,
    pub width: u32,
    pub height: u32,
    /// Relative to `DIR/images/`.
    pub file_name: String,
    pub seed: u64,
    pub pose: usize,
    pub lighting: Lighting,
    /// Relative to `DIR`.
    pub depth_file: String,
    /// Relative to `DIR`.
    pub mask_file: String,
    /// 8-bit class ids, relative to `DIR`.
    pub class_file: String,
    /// 16-bit RGB world normals, relative to `DIR`.
    pub normal_file: String,
    /// Intrinsics and camera-to-world pose (absent for labels written before frames had them).
    #[serde(flatten, default, skip_serializing_if = "Option::is_none")]
    pub view: Option<ViewGeometry>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure_s: Option<f64>,
    /// This image's analogue gain, dB.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gain_db: Option<f64>,
}

/// An annotation of the merged COCO file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CocoAnnotationOut {
    pub id: u64,
    pub image_id: u64,
    pub category_id: u32,
    pub bbox: [u32; 4],
    pub area: u64,
    pub iscrowd: u8,
    pub segmentation: RleJson,
    pub instance_id: u32,
}

/// A category entry.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct CocoCategoryOut {
    pub id: u32,
    pub name: String,
    pub supercategory: String,
}

/// The `info` block (no dates: the bytes depend only on the spec).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CocoInfo {
    pub description: String,
    pub version: String,
    pub lighting: Lighting,
}

/// A merged COCO instances file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CocoInstances {
    pub info: CocoInfo,
    pub licenses: Vec<serde_json::Value>,
    pub images: Vec<CocoImageOut>,
    pub annotations: Vec<CocoAnnotationOut>,
    pub categories: Vec<CocoCategoryOut>,
}

/// The eleven categories: the object classes (1..10) and the threshold (11).
#[must_use]
pub fn categories() -> Vec<CocoCategoryOut> {
    ObjectClass::ALL
        .iter()
        .map(|c| CocoCategoryOut { id: c.class_id(), name: c.name().to_string(), supercategory: "object".to_string() })
        .chain(std::iter::once(CocoCategoryOut {
            id: THRESHOLD_CLASS_ID,
            name: THRESHOLD_CLASS_NAME.to_string(),
            supercategory: "obstacle".to_string(),
        }))
        .collect()
}

/// Folder of one seed's files: `seed_SSSSSSSSSS` (ten digits, so names sort by seed).
#[must_use]
pub fn seed_dir(seed: u64) -> String {
    format!("seed_{seed:010}")
}

/// Writes a file several shard runs may write at once ([`scene_gen_core::io::write_atomic`] names
/// its temporary files uniquely across machines, and every writer writes the same bytes).
fn write_shared(path: &Path, bytes: &[u8]) -> Result<(), DatasetError> {
    Ok(scene_gen_core::io::write_atomic(path, bytes)?)
}

/// What a dataset run reports as it goes: frames planned and done (`false`: its files were
/// already there).
pub use crate::progress::Progress;

/// What [`Dataset::run_seed`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SeedReport {
    pub frames: usize,
    pub rendered: usize,
    pub skipped: usize,
}

/// A dataset folder and its spec.
#[derive(Debug)]
pub struct Dataset {
    pub dir: PathBuf,
    pub spec: DatasetSpec,
    resolved: ResolvedCamera,
}

impl Dataset {
    /// Checks `spec` and resolves its camera; writes nothing.
    ///
    /// # Errors
    /// [`DatasetError::Spec`] for a bad camera, [`DatasetError::Invalid`] for no lighting or a
    /// zero frame step/count.
    pub fn new(dir: &Path, mut spec: DatasetSpec) -> Result<Dataset, DatasetError> {
        if spec.lighting.is_empty() {
            return Err(DatasetError::Invalid("no lighting chosen".to_string()));
        }
        spec.lighting.sort_unstable();
        spec.lighting.dedup();
        match spec.frames {
            FrameSelection::Every { step: 0 } => {
                return Err(DatasetError::Invalid("--every must be at least 1".into()));
            }
            FrameSelection::Count { frames: 0 } => {
                return Err(DatasetError::Invalid("--frames must be at least 1".into()));
            }
            _ => {}
        }
        if spec.seed_last < spec.seed_first || spec.seed_last > shard::MAX_SEED {
            return Err(DatasetError::Invalid(format!("seeds {}..={} out of range", spec.seed_first, spec.seed_last)));
        }
        let resolved = spec.camera.resolve(&Catalog::embedded())?;
        spec.camera.clone_from(&resolved.spec);
        spec.camera.sensor.clone_from(&resolved.sensor.model);
        Ok(Dataset { dir: dir.to_path_buf(), spec, resolved })
    }

    /// `DIR/dataset.json`.
    #[must_use]
    pub fn spec_path(&self) -> PathBuf {
        self.dir.join("dataset.json")
    }

    /// Refuses a folder that holds a dataset of other settings; writes nothing.
    ///
    /// # Errors
    /// [`DatasetError::Mismatch`], or [`DatasetError::Read`] when the file cannot be read.
    pub fn check_dir(&self) -> Result<(), DatasetError> {
        let path = self.spec_path();
        match std::fs::read_to_string(&path) {
            Ok(text) if text == self.spec.to_json() => Ok(()),
            Ok(_) => Err(DatasetError::Mismatch { dir: self.dir.clone() }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(DatasetError::Read { path, why: e.to_string() }),
        }
    }

    /// Creates the folder and writes `dataset.json` if it is not there yet.
    ///
    /// # Errors
    /// As [`Dataset::check_dir`], or a write error.
    pub fn init(&self) -> Result<(), DatasetError> {
        self.check_dir()?;
        if !self.spec_path().exists() {
            std::fs::create_dir_all(&self.dir)
                .map_err(|e| DatasetError::Read { path: self.dir.clone(), why: e.to_string() })?;
            write_shared(&self.spec_path(), self.spec.to_json().as_bytes())?;
        }
        Ok(())
    }

    /// Image width and height in pixels.
    #[must_use]
    pub fn image_size(&self) -> (u32, u32) {
        (self.resolved.width_px, self.resolved.height_px)
    }

    fn image_rel(seed: u64, pose: usize, lighting: Lighting) -> String {
        format!("{}/pose_{pose:06}_{}.png", seed_dir(seed), lighting.name())
    }

    fn depth_rel(seed: u64, pose: usize) -> String {
        format!("depth/{}/pose_{pose:06}.png", seed_dir(seed))
    }

    fn mask_rel(seed: u64, pose: usize) -> String {
        format!("masks/{}/pose_{pose:06}.png", seed_dir(seed))
    }

    fn classes_rel(seed: u64, pose: usize) -> String {
        format!("classes/{}/pose_{pose:06}.png", seed_dir(seed))
    }

    fn normals_rel(seed: u64, pose: usize) -> String {
        format!("normals/{}/pose_{pose:06}.png", seed_dir(seed))
    }

    fn labels_path(&self, seed: u64, pose: usize) -> PathBuf {
        self.dir.join(format!("labels/{}/pose_{pose:06}.json", seed_dir(seed)))
    }

    /// `DIR/fragments/seed_S.json`.
    #[must_use]
    pub fn fragment_path(&self, seed: u64) -> PathBuf {
        self.dir.join(format!("fragments/{}.json", seed_dir(seed)))
    }

    /// `DIR/trajectories/seed_SSSSSSSSSS.json`: the camera path of the seed's frames.
    #[must_use]
    pub fn trajectory_path(&self, seed: u64) -> PathBuf {
        self.dir.join(format!("trajectories/{}.json", seed_dir(seed)))
    }

    /// `DIR/annotations/instances_<lighting>.json`.
    #[must_use]
    pub fn annotations_path(&self, lighting: Lighting) -> PathBuf {
        self.dir.join(format!("annotations/instances_{}.json", lighting.name()))
    }

    /// Every file of one frame, the labels last (written last).
    fn frame_files(&self, seed: u64, pose: usize) -> Vec<PathBuf> {
        let mut files: Vec<PathBuf> =
            self.spec.lighting.iter().map(|&l| self.dir.join("images").join(Self::image_rel(seed, pose, l))).collect();
        if self.spec.raw {
            files.extend(self.spec.lighting.iter().map(|&l| self.dir.join("raw").join(Self::image_rel(seed, pose, l))));
        }
        files.push(self.dir.join(Self::depth_rel(seed, pose)));
        files.push(self.dir.join(Self::mask_rel(seed, pose)));
        files.push(self.dir.join(Self::classes_rel(seed, pose)));
        files.push(self.dir.join(Self::normals_rel(seed, pose)));
        files.push(self.labels_path(seed, pose));
        files
    }

    /// Makes every frame of `seed` that is not complete yet, then the seed's fragment.
    ///
    /// # Errors
    /// [`DatasetError`] from any stage; files already written stay (they are whole).
    pub fn run_seed(&self, seed: u64, progress: &dyn Progress) -> Result<SeedReport, DatasetError> {
        if let Ok(text) = std::fs::read_to_string(self.fragment_path(seed)) {
            let fragment: Fragment = serde_json::from_str(&text)
                .map_err(|e| DatasetError::Read { path: self.fragment_path(seed), why: e.to_string() })?;
            let n = fragment.frames.len();
            progress.planned(n as u64);
            for _ in 0..n {
                progress.done(false);
            }
            return Ok(SeedReport { frames: n, rendered: 0, skipped: n });
        }
        let library = load_library(&self.spec.house)?;
        let params = TrajectoryParams { height_m: self.spec.camera.height_m, ..TrajectoryParams::default() };
        let WalkedHouse { scene, walk } = walked_house_with(&library, &self.spec.house.config(seed), &params)?;
        if walk.poses.len() > MAX_POSES {
            return Err(DatasetError::Limit {
                seed,
                why: format!("{} poses, image ids hold {MAX_POSES}", walk.poses.len()),
            });
        }
        let poses = self.spec.frames.select(walk.poses.len());
        progress.planned(poses.len() as u64);
        let todo: Vec<usize> =
            poses.iter().copied().filter(|&p| !self.frame_files(seed, p).iter().all(|f| f.exists())).collect();

        let mut rendered: Vec<FrameLabels> = Vec::new();
        if !todo.is_empty() {
            let groups: Vec<LightGroup> = self.spec.lighting.iter().map(|l| l.group()).collect();
            let settings = self.spec.quality.settings();
            let noise_label = format!("dataset/{seed}/");
            let capture = Capture::new(&scene, &self.resolved, &groups, settings, params.speed_m_per_s, noise_label)?;
            let gt_config = self.spec.ground_truth;
            rendered = todo
                .par_iter()
                .map(|&p| {
                    let pose = walk.poses[p];
                    let camera = capture.pinhole(&pose);
                    let frame = capture.render(&camera)?;
                    let gt = frame_ground_truth(&frame, &scene, &camera, &gt_config);
                    let counted: BTreeSet<u32> = gt.iter().filter(|o| o.counted).map(|o| o.instance_id).collect();
                    if let Some(&big) = counted.iter().find(|&&id| id > u32::from(u16::MAX)) {
                        return Err(DatasetError::Limit {
                            seed,
                            why: format!("instance id {big} does not fit a 16-bit mask"),
                        });
                    }
                    let masks = rle::encode_instances(&frame.instance_id, frame.width, frame.height, &counted);
                    let objects: Vec<ObjectLabel> = gt
                        .iter()
                        .filter_map(|o| {
                            let rle = masks.get(&o.instance_id)?;
                            Some(ObjectLabel {
                                instance_id: o.instance_id,
                                category_id: o.class_id,
                                bbox: rle.bbox()?,
                                area: rle.area(),
                                segmentation: rle.to_json(),
                                distance_m: o.distance_m,
                                visible_fraction: o.visible_fraction,
                            })
                        })
                        .collect();
                    let images = capture.sensor_images(&frame, &camera, &pose, p as u64);
                    for ((&lighting, raw), scenario) in self.spec.lighting.iter().zip(images).zip(capture.scenarios()) {
                        let image = png::image_png(&scenario.image_8bit(&raw));
                        self.write(&self.dir.join("images").join(Self::image_rel(seed, p, lighting)), &image)?;
                        if self.spec.raw {
                            let (bytes, _) = png::capture_png(&raw);
                            self.write(&self.dir.join("raw").join(Self::image_rel(seed, p, lighting)), &bytes)?;
                        }
                    }
                    self.write(&self.dir.join(Self::depth_rel(seed, p)), &png::depth_png(&frame))?;
                    self.write(&self.dir.join(Self::mask_rel(seed, p)), &png::instances_png(&frame))?;
                    self.write(&self.dir.join(Self::classes_rel(seed, p)), &png::classes_png(&frame))?;
                    self.write(&self.dir.join(Self::normals_rel(seed, p)), &png::normals_png(&frame))?;
                    let labels = FrameLabels {
                        seed,
                        pose: p,
                        width: frame.width,
                        height: frame.height,
                        view: Some(ViewGeometry::of(&camera)),
                        time_s: Some(pose.time_s),
                        exposure_s: Some(self.resolved.spec.exposure_s),
                        gain_db: self
                            .spec
                            .lighting
                            .iter()
                            .zip(capture.scenarios())
                            .map(|(&l, s)| (l, s.gain_db))
                            .collect(),
                        objects,
                    };
                    let text = serde_json::to_string(&labels).expect("labels serialise");
                    self.write(&self.labels_path(seed, p), text.as_bytes())?;
                    progress.done(true);
                    Ok(labels)
                })
                .collect::<Result<Vec<_>, DatasetError>>()?;
        }
        let mut frames = Vec::with_capacity(poses.len());
        let mut fresh = rendered.into_iter().peekable();
        for &p in &poses {
            if fresh.peek().is_some_and(|l| l.pose == p) {
                frames.push(fresh.next().expect("peeked"));
            } else {
                let path = self.labels_path(seed, p);
                let labels: FrameLabels = std::fs::read_to_string(&path)
                    .map_err(|e| e.to_string())
                    .and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string()))
                    .map_err(|why| DatasetError::Read { path, why })?;
                progress.done(false);
                frames.push(labels);
            }
        }
        let report = SeedReport { frames: poses.len(), rendered: todo.len(), skipped: poses.len() - todo.len() };
        log::info!(
            "dataset: seed {seed}: {} frames ({} rendered, {} already there)",
            report.frames,
            report.rendered,
            report.skipped
        );
        let trajectory = SequenceTrajectory {
            seed,
            axes: VIEW_AXES,
            frames: frames
                .iter()
                .filter_map(|f| Some(TrajectoryFrame { pose: f.pose, time_s: f.time_s?, view: f.view? }))
                .collect(),
        };
        let mut text = serde_json::to_string_pretty(&trajectory).expect("trajectory serialises");
        text.push('\n');
        self.write(&self.trajectory_path(seed), text.as_bytes())?;
        let text = serde_json::to_string(&Fragment { seed, frames }).expect("fragment serialises");
        self.write(&self.fragment_path(seed), text.as_bytes())?;
        Ok(report)
    }

    fn write(&self, path: &Path, bytes: &[u8]) -> Result<(), DatasetError> {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| DatasetError::Read { path: dir.to_path_buf(), why: e.to_string() })?;
        }
        write_shared(path, bytes)
    }

    /// Runs the seeds of `shard`, in order.
    ///
    /// # Errors
    /// The first seed's error.
    pub fn run_shard(&self, shard: Shard, progress: &dyn Progress) -> Result<SeedReport, DatasetError> {
        let mut total = SeedReport::default();
        for seed in shard.seeds(&self.spec.seeds()) {
            let r = self.run_seed(seed, progress)?;
            total.frames += r.frames;
            total.rendered += r.rendered;
            total.skipped += r.skipped;
        }
        Ok(total)
    }

    /// Seeds of the range without a fragment yet.
    #[must_use]
    pub fn missing_seeds(&self) -> Vec<u64> {
        self.spec.seeds().iter().filter(|&s| !self.fragment_path(s).exists()).collect()
    }

    /// The COCO file of each lighting from the fragments of every seed. A file whose bytes are
    /// already there is not rewritten. Returns the files written.
    ///
    /// # Errors
    /// [`DatasetError::Incomplete`] when a seed has no fragment yet; read or write errors.
    pub fn merge(&self) -> Result<Vec<PathBuf>, DatasetError> {
        let missing = self.missing_seeds();
        if let Some(&first) = missing.first() {
            return Err(DatasetError::Incomplete { missing: missing.len(), total: self.spec.seeds().len(), first });
        }
        let mut fragments = Vec::new();
        for seed in self.spec.seeds().iter() {
            let path = self.fragment_path(seed);
            let fragment: Fragment = std::fs::read_to_string(&path)
                .map_err(|e| e.to_string())
                .and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string()))
                .map_err(|why| DatasetError::Read { path, why })?;
            fragments.push(fragment);
        }
        let mut written = Vec::new();
        for &lighting in &self.spec.lighting {
            let coco = self.instances(&fragments, lighting);
            let mut text = serde_json::to_string(&coco).expect("COCO file serialises");
            text.push('\n');
            let path = self.annotations_path(lighting);
            if std::fs::read(&path).ok().as_deref() != Some(text.as_bytes()) {
                self.write(&path, text.as_bytes())?;
                written.push(path);
            }
        }
        Ok(written)
    }

    /// The COCO instances of one lighting.
    #[must_use]
    pub fn instances(&self, fragments: &[Fragment], lighting: Lighting) -> CocoInstances {
        let mut images = Vec::new();
        let mut annotations = Vec::new();
        for f in fragments {
            for frame in &f.frames {
                let id = image_id(f.seed, frame.pose, lighting);
                images.push(CocoImageOut {
                    id,
                    width: frame.width,
                    height: frame.height,
                    file_name: Self::image_rel(f.seed, frame.pose, lighting),
                    seed: f.seed,
                    pose: frame.pose,
                    lighting,
                    depth_file: Self::depth_rel(f.seed, frame.pose),
                    mask_file: Self::mask_rel(f.seed, frame.pose),
                    class_file: Self::classes_rel(f.seed, frame.pose),
                    normal_file: Self::normals_rel(f.seed, frame.pose),
                    view: frame.view,
                    exposure_s: frame.exposure_s,
                    gain_db: frame.gain_db.get(&lighting).copied(),
                });
                for o in &frame.objects {
                    annotations.push(CocoAnnotationOut {
                        id: annotations.len() as u64 + 1,
                        image_id: id,
                        category_id: o.category_id,
                        bbox: o.bbox,
                        area: o.area,
                        iscrowd: 0,
                        segmentation: o.segmentation.clone(),
                        instance_id: o.instance_id,
                    });
                }
            }
        }
        CocoInstances {
            info: CocoInfo {
                description: format!(
                    "scene-gen dataset: seeds {}, camera {}, {} lighting",
                    self.spec.seeds(),
                    self.spec.camera.sensor,
                    lighting.name()
                ),
                version: self.spec.generator_version.clone(),
                lighting,
            },
            licenses: Vec::new(),
            images,
            annotations,
            categories: categories(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_selection() {
        assert_eq!(FrameSelection::All.select(3), vec![0, 1, 2]);
        assert_eq!(FrameSelection::Every { step: 4 }.select(10), vec![0, 4, 8]);
        assert_eq!(FrameSelection::Count { frames: 3 }.select(11), vec![0, 5, 10]);
        assert_eq!(FrameSelection::Count { frames: 20 }.select(4), vec![0, 1, 2, 3]);
        assert_eq!(FrameSelection::Count { frames: 1 }.select(4), vec![0]);
        assert!(FrameSelection::All.select(0).is_empty());
    }

    #[test]
    fn image_ids_are_distinct_and_below_2_pow_53() {
        let a = image_id(5, 7, Lighting::Day);
        assert_ne!(a, image_id(5, 7, Lighting::Night));
        assert_ne!(a, image_id(5, 8, Lighting::Day));
        assert_ne!(a, image_id(6, 7, Lighting::Day));
        assert!(image_id(shard::MAX_SEED, MAX_POSES - 1, Lighting::Night) < 1 << 53);
        assert!(image_id(0, 0, Lighting::Day) >= 1);
    }

    #[test]
    fn categories_are_1_to_11() {
        let ids: Vec<u32> = categories().iter().map(|c| c.id).collect();
        assert_eq!(ids, (1..=11).collect::<Vec<_>>());
        assert_eq!(categories()[10].name, "threshold");
    }
}
