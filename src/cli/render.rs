//! `scene-gen render`: frames of a camera walking through a generated house, by day and night.
//!
//! The manifest `scene.json` holds the semantic view only, not the geometry, so the house is
//! **regenerated** from the manifest's seed, envelope, wall thickness and `house` record (the
//! smallest room and the libraries, found again by their folders and checked by digest); the
//! regenerated manifest must equal the file field for field, and the schema and generator
//! version must be this binary's, else the input is refused (exit 2): a house generated with
//! another version or other libraries cannot be rebuilt faithfully. `--seed N` with the house
//! options builds the house directly instead, as `scene-gen --seed N` would.
//!
//! Frames are taken at the first `--frames` poses of the agent's walk
//! ([`scene_gen::trajectory`]), or at every pose of a given path (`--poses FILE`, JSON or CSV,
//! [`scene_gen::path`]). Per frame `k` (`kkkk` zero-padded):
//!
//! * `frame_kkkk_day.png` / `frame_kkkk_night.png`: the camera's 8-bit image, as its ISP
//!   writes it ([`scene_gen::capture::Scenario::image_8bit`]): sRGB for a colour sensor (the
//!   raw Bayer mosaic through black level, white balance, demosaicing, colour matrix and the
//!   sRGB curve, [`scene_gen::bayer`]), grey for a monochrome one, the 8-bit RGB of the affine
//!   noise path as it is.
//! * with `--raw`, `frame_kkkk_day_raw.png` / `..._night_raw.png`: the raw capture, DN at the
//!   ADC depth: 8-bit PNG for sensors of at most 8 bits, else 16-bit PNG holding the DN
//!   unscaled (a 12-bit sensor's values stay in 0..4095). A colour sensor's is its Bayer mosaic
//!   (one grey channel; the sidecar's `cfa_pattern` gives the layout, `black_level_dn` the
//!   offset).
//! * `frame_kkkk_day.json` / `..._night.json`: intrinsics (fx, fy, cx, cy in px, OpenCV
//!   convention: pixel centres at integer coordinates) and the matrix `K`, the pose (position,
//!   yaw, pitch, time) and `camera_to_world` (4x4, OpenCV camera axes, [`scene_gen::view`]), exposure,
//!   gain, illuminance on the 0.75 m plane (the target after scaling and the value measured
//!   before), and the raw capture's description (`channels`, `bits`, `png_bit_depth`,
//!   `cfa_pattern`, `black_level_dn`, `raw_file` when written) with its mean and variance in DN
//!   (population variance over every value); `image_channels` is 3 for an sRGB image, 1 for
//!   grey.
//! * `frame_kkkk_depth.png`: 16-bit z-depth in millimetres; 0 = no hit or beyond 65.535 m.
//! * `frame_kkkk_instances.png`: 16-bit instance ids (0 = none; the manifest's
//!   `instance_id`s of objects and thresholds).
//!
//! and once, `trajectory.json`: the whole walk (poses with position, yaw_deg, time_s; the door
//! crossings with threshold_id, pose_index, time_s; the agent radius used), or for a given path
//! its poses as `--poses` reads them back.
//!
//! Day and night come from one trace: the lights of each group are scaled so the mean
//! illuminance on the 0.75 m plane is 20 lux by day and 2 lux by night (TaCOS).
//! Every output is encoded before the first file is written.

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use clap::{Args, ValueEnum};
use scene_gen::camera_spec::{CameraSpec, ResolvedCamera};
use scene_gen::capture::{Capture, Scenario};
use scene_gen::config::GeneratorConfig;
use scene_gen::dataset::Quality;
use scene_gen::dataset::png::{capture_png, depth_png, image_png, instances_png};
use scene_gen::demosaic::CfaPattern;
use scene_gen::export::write_atomic;
use scene_gen::generate::generate;
use scene_gen::house::HouseOptions;
use scene_gen::lights::TARGET_PLANE_M;
use scene_gen::manifest::Manifest;
use scene_gen::path;
use scene_gen::radiometry::SensorImage;
use scene_gen::render::camera::Camera;
use scene_gen::scene::{LibraryId, LightGroup, MANIFEST_SCHEMA, Scene};
use scene_gen::sensor::Catalog;
use scene_gen::trajectory::{self, Pose, TrajectoryParams};
use scene_gen::view::ViewGeometry;
use serde::Serialize;

use super::dataset::QualityArg;
use super::house::HouseArgs;
use super::progress::Progress;
use super::{CliError, bad_input, failure};

/// Which scenarios to render.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Lighting {
    Day,
    Night,
    Both,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The house's manifest, DIR/scene.json, as `scene-gen --seed N` wrote it.
    #[arg(long, required_unless_present = "seed")]
    pub scene: Option<PathBuf>,
    /// Build the house of this seed here instead of reading a manifest (with the house options
    /// below, as `scene-gen --seed N` would).
    #[arg(long, conflicts_with = "scene")]
    pub seed: Option<u64>,
    /// Camera: a TOML file or `SENSOR[,focal_mm=F][,pitch_deg=P][,height_m=H][,key=value...]`.
    #[arg(long)]
    pub camera: String,
    #[arg(long, value_enum, default_value_t = Lighting::Both)]
    pub lighting: Lighting,
    /// Output folder (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Frames, at the first poses of the walk (one every 0.25 m).
    #[arg(long, default_value_t = 1, conflicts_with = "poses")]
    pub frames: u32,
    /// A camera path instead of the walk: a frame at every pose of a JSON or CSV file
    /// (`scene_gen::path` documents both; `trajectory.json` of a render reads back).
    #[arg(long)]
    pub poses: Option<PathBuf>,
    /// Bin the sensor down to at most this width in pixels (keeps the field of view).
    #[arg(long)]
    pub max_width: Option<u32>,
    #[arg(long, value_enum, default_value_t = QualityArg::Standard)]
    pub quality: QualityArg,
    /// Also write each raw capture (`frame_kkkk_<lighting>_raw.png`, DN at the ADC depth; a
    /// colour sensor's Bayer mosaic).
    #[arg(long)]
    pub raw: bool,
    /// The house options. With `--scene` they default to the manifest's record; `--rooms` and
    /// `--furniture` then say where a library folder is now (its digest must match), and an
    /// `--envelope` or `--min-room` other than the manifest's is refused.
    #[command(flatten)]
    pub house: HouseArgs,
}

#[derive(Serialize)]
struct Intrinsics {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
}

#[derive(Serialize)]
struct PoseOut {
    position: [f32; 3],
    yaw_deg: f32,
    pitch_deg: f32,
    time_s: f32,
}

impl PoseOut {
    /// Where `camera` stands and looks at the time of `pose`. The heading is the camera's (the
    /// walk's heading turned by the mount's yaw offset).
    fn of(pose: &Pose, camera: &Camera) -> PoseOut {
        PoseOut { yaw_deg: camera.yaw_deg, ..PoseOut::as_given(pose, camera) }
    }

    /// The pose as `--poses` reads it: the heading before the mount's yaw offset.
    fn as_given(pose: &Pose, camera: &Camera) -> PoseOut {
        PoseOut {
            position: camera.position.to_array(),
            yaw_deg: pose.yaw_deg,
            pitch_deg: camera.pitch_deg,
            time_s: pose.time_s,
        }
    }
}

/// `trajectory.json` of a render along a given path: it reads back with `--poses`.
#[derive(Serialize)]
struct GivenPath {
    poses: Vec<PoseOut>,
}

#[derive(Serialize)]
struct Sidecar<'a> {
    scene_seed: u64,
    frame: u32,
    lighting: &'a str,
    sensor: &'a str,
    width: u32,
    height: u32,
    /// Channels of the 8-bit image: 3 (sRGB) or 1 (grey).
    image_channels: u8,
    /// The raw capture: its channels, ADC bits, PNG depth, CFA layout and black level.
    channels: u8,
    bits: u32,
    png_bit_depth: u8,
    cfa_pattern: Option<CfaPattern>,
    black_level_dn: f64,
    /// The raw capture's file, when `--raw` wrote it.
    raw_file: Option<String>,
    bin_factor: f64,
    pixel_pitch_um: f32,
    focal_mm: f32,
    f_number: f32,
    intrinsics: Intrinsics,
    pose: PoseOut,
    /// `K` and `camera_to_world` (conventions in `scene_gen::view`).
    #[serde(flatten)]
    view: ViewGeometry,
    exposure_s: f64,
    gain_db: f64,
    noise: scene_gen::camera_spec::NoiseKind,
    /// Mean illuminance on the 0.75 m plane after scaling the lights (the scenario target).
    plane_lux: f32,
    /// The same, measured with the lights at their nominal intensities.
    plane_lux_nominal: f32,
    light_scale: f32,
    mean_dn: f64,
    variance_dn2: f64,
}

/// Reads the manifest and regenerates its house with the options it records, or those given.
fn load_scene(path: &Path, given: &HouseArgs) -> Result<Scene, CliError> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read --scene {}", path.display()))
        .map_err(bad_input)?;
    let manifest: Manifest = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a scene-gen manifest", path.display()))
        .map_err(bad_input)?;
    if manifest.schema != MANIFEST_SCHEMA {
        return Err(bad_input(anyhow!("{}: schema '{}' is not '{MANIFEST_SCHEMA}'", path.display(), manifest.schema)));
    }
    let version = env!("CARGO_PKG_VERSION");
    if manifest.generator_version != version {
        return Err(bad_input(anyhow!(
            "{}: generated by scene-gen {}, this is {version}; the house cannot be rebuilt faithfully",
            path.display(),
            manifest.generator_version
        )));
    }
    let options = recorded_options(path, &manifest, given)?;
    let library = options.library().map_err(|e| bad_input(anyhow!(e)))?;
    if let Some(record) = &manifest.house {
        for (what, recorded, now) in
            [("rooms", &record.rooms, &library.rooms_id), ("furniture", &record.furniture, &library.furniture_id)]
        {
            if recorded.digest != now.digest {
                return Err(bad_input(anyhow!(
                    "{}: the house was made with the {what} library {} ({}), the one given here is {} ({}); \
                     pass --{what} with the folder it was made with",
                    path.display(),
                    recorded.folder.as_deref().unwrap_or("embedded"),
                    recorded.digest,
                    now.folder.as_deref().unwrap_or("embedded"),
                    now.digest
                )));
            }
        }
    }
    let config = GeneratorConfig { wall_thickness_m: manifest.wall_thickness_m, ..options.config(manifest.seed) };
    config.validate().map_err(bad_input)?;
    let scene = generate(&config, &library).map_err(bad_input)?;
    // The libraries matched by digest; where their folders are now does not matter.
    let regenerated = Manifest { house: manifest.house.clone(), ..Manifest::of(&scene) };
    if regenerated != manifest {
        return Err(bad_input(anyhow!(
            "{}: the house regenerated from seed {} and its recorded options differs from the manifest \
             (edited, or written without its options by an older build?)",
            path.display(),
            manifest.seed
        )));
    }
    Ok(scene)
}

/// The house options of a manifest: its record, with the libraries' folders given on the
/// command line; an envelope or room size that contradicts the record is refused.
fn recorded_options(path: &Path, manifest: &Manifest, given: &HouseArgs) -> Result<HouseOptions, CliError> {
    if let Some(envelope) = given.envelope.filter(|e| *e != manifest.envelope) {
        return Err(bad_input(anyhow!(
            "--envelope {envelope} contradicts {}, whose house has the envelope {}",
            path.display(),
            manifest.envelope
        )));
    }
    let record = manifest.house.as_ref();
    let min_room_m = match (record.map(|r| r.min_room_m), given.min_room) {
        (Some(recorded), Some(m)) if recorded != m => {
            return Err(bad_input(anyhow!(
                "--min-room {m} contradicts {}, whose house was made with --min-room {recorded}",
                path.display()
            )));
        }
        (Some(recorded), _) => recorded,
        (None, given) => given.unwrap_or(HouseOptions::default().min_room_m),
    };
    let folder = |id: Option<&LibraryId>| id.and_then(|id| id.folder.as_ref()).map(PathBuf::from);
    Ok(HouseOptions {
        envelope: manifest.envelope,
        min_room_m,
        rooms: given.rooms.clone().or_else(|| folder(record.map(|r| &r.rooms))),
        furniture: given.furniture.clone().or_else(|| folder(record.map(|r| &r.furniture))),
    })
}

/// The house `--seed` and the house options ask for (the generator checks the options).
fn build_scene(seed: u64, given: &HouseArgs) -> Result<Scene, CliError> {
    let options = given.over(HouseOptions::default());
    let library = options.library().map_err(|e| bad_input(anyhow!(e)))?;
    generate(&options.config(seed), &library).map_err(bad_input)
}

pub fn run(args: &RenderArgs) -> Result<(), CliError> {
    // Every input check before any work.
    let mut spec = CameraSpec::from_arg(&args.camera).map_err(bad_input)?;
    if let Some(m) = args.max_width {
        if m == 0 {
            return Err(bad_input(anyhow!("--max-width must be at least 1")));
        }
        spec.max_width_px = Some(m);
    }
    if args.frames == 0 {
        return Err(bad_input(anyhow!("--frames must be at least 1")));
    }
    let catalog = Catalog::embedded();
    let resolved = spec.resolve(&catalog).map_err(bad_input)?;
    let given = args.poses.as_deref().map(path::read).transpose().map_err(bad_input)?;
    let scene = match (&args.scene, args.seed) {
        (Some(path), _) => load_scene(path, &args.house)?,
        (None, Some(seed)) => build_scene(seed, &args.house)?,
        (None, None) => return Err(bad_input(anyhow!("give --scene DIR/scene.json or --seed N"))),
    };

    if given.is_none() {
        scene.envelope.check_camera_height(spec.height_m).map_err(|e| bad_input(anyhow!(e)))?;
    }
    let params = TrajectoryParams { height_m: spec.height_m, ..TrajectoryParams::default() };
    // The walk is planned only when no path is given; its first `--frames` poses are the views.
    let (views, walk): (Vec<(Pose, Camera)>, _) = match &given {
        Some(given) => (given.iter().map(|g| path::given_view(&resolved, g)).collect(), None),
        None => {
            let walk = trajectory::plan(&scene, &params).map_err(failure)?;
            (path::walk_views(&resolved, &walk, args.frames as usize), Some(walk))
        }
    };
    let settings = Quality::from(args.quality).settings();
    let groups: Vec<LightGroup> = match args.lighting {
        Lighting::Day => vec![LightGroup::Day],
        Lighting::Night => vec![LightGroup::Night],
        Lighting::Both => vec![LightGroup::Day, LightGroup::Night],
    };
    let noise_label = format!("{}/", scene.seed);
    let capture =
        Capture::new(&scene, &resolved, &groups, settings, params.speed_m_per_s, noise_label).map_err(failure)?;

    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    let progress = Progress::new("render", "frames", views.len() as u64);
    for (k, (pose, camera)) in (0u32..).zip(&views) {
        let (pose, camera) = (*pose, *camera);
        let frame = capture.renderer().render(&camera).map_err(bad_input)?;
        let stem = format!("frame_{k:04}");
        let images = capture.sensor_images(&frame, &camera, &pose, u64::from(k));
        for (scenario, raw) in capture.scenarios().iter().zip(images) {
            let name = scenario.light.name();
            let image = scenario.image_8bit(&raw);
            let (raw_png, depth) = capture_png(&raw);
            let (mean_dn, variance_dn2) = raw.mean_variance();
            let raw_file = args.raw.then(|| format!("{stem}_{name}_raw.png"));
            let sidecar = sidecar(&resolved, (scene.seed, k), scenario, &raw, depth, &pose, &camera);
            let sidecar = Sidecar {
                mean_dn,
                variance_dn2,
                image_channels: image.channels,
                raw_file: raw_file.clone(),
                ..sidecar
            };
            let mut json = serde_json::to_string_pretty(&sidecar).map_err(failure)?;
            json.push('\n');
            files.push((format!("{stem}_{name}.png"), image_png(&image)));
            if let Some(raw_file) = raw_file {
                files.push((raw_file, raw_png));
            }
            files.push((format!("{stem}_{name}.json"), json.into_bytes()));
        }
        files.push((format!("{stem}_depth.png"), depth_png(&frame)));
        files.push((format!("{stem}_instances.png"), instances_png(&frame)));
        progress.inc(1);
    }
    progress.finish();

    let mut walk_json = match &walk {
        Some(walk) => serde_json::to_string_pretty(walk),
        None => serde_json::to_string_pretty(&GivenPath {
            poses: views.iter().map(|(p, c)| PoseOut::as_given(p, c)).collect(),
        }),
    }
    .map_err(failure)?;
    walk_json.push('\n');
    files.push(("trajectory.json".to_string(), walk_json.into_bytes()));

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output folder {}", args.out.display()))
        .map_err(failure)?;
    for (name, bytes) in &files {
        write_atomic(&args.out.join(name), bytes).map_err(|e| failure(anyhow!(e)))?;
    }
    for s in capture.scenarios() {
        let l = &s.light;
        println!(
            "{:?}: {:.3} lux nominal on the {TARGET_PLANE_M} m plane, scaled x{:.4} to {} lux",
            l.group, l.nominal_lux, l.scale, l.target_lux
        );
    }
    println!("wrote {} files to {}", files.len(), args.out.display());
    Ok(())
}

/// The sidecar of frame `k` of the house of `seed` (its image statistics left at zero, no raw
/// file, a grey image).
fn sidecar<'a>(
    resolved: &'a ResolvedCamera,
    (seed, k): (u64, u32),
    scenario: &Scenario,
    cap: &SensorImage,
    png_bit_depth: u8,
    pose: &Pose,
    camera: &Camera,
) -> Sidecar<'a> {
    let light = &scenario.light;
    let spec = &resolved.spec;
    let f = resolved.focal_px();
    Sidecar {
        scene_seed: seed,
        frame: k,
        lighting: light.name(),
        sensor: &resolved.sensor.model,
        width: cap.width,
        height: cap.height,
        image_channels: 1,
        channels: cap.channels,
        bits: cap.bits,
        png_bit_depth,
        cfa_pattern: cap.cfa,
        black_level_dn: scenario.isp.black,
        raw_file: None,
        bin_factor: resolved.bin_factor,
        pixel_pitch_um: resolved.pixel_pitch_um,
        focal_mm: spec.focal_mm,
        f_number: spec.f_number,
        // OpenCV convention (pixel centres at integers): the image centre is at (w/2 - 0.5, h/2 - 0.5).
        intrinsics: Intrinsics {
            fx: f,
            fy: f,
            cx: f64::from(cap.width) * 0.5 - 0.5,
            cy: f64::from(cap.height) * 0.5 - 0.5,
        },
        pose: PoseOut::of(pose, camera),
        view: ViewGeometry::of(camera),
        exposure_s: spec.exposure_s,
        gain_db: scenario.gain_db,
        noise: spec.noise,
        plane_lux: light.target_lux,
        plane_lux_nominal: light.nominal_lux,
        light_scale: light.scale,
        mean_dn: 0.0,
        variance_dn2: 0.0,
    }
}
