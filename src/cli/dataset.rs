//! `scene-gen dataset`: images, depth, instance masks and COCO instance annotations of a camera
//! walking through the houses of a seed range ([`scene_gen::dataset`]; layout in
//! docs/DATASETS.md).
//!
//! Every argument is checked before anything is written: a bad `--seeds`, `--shard`,
//! `--camera` or a folder holding a dataset of other settings exits 2 with nothing written.
//! A run makes its shard's seeds (skipping finished frames), then merges the COCO files if
//! every seed of the range is done; `--merge` only merges (exit 1 when seeds are missing).

use std::path::PathBuf;

use anyhow::anyhow;
use clap::{Args, ValueEnum};
use scene_gen::camera_spec::CameraSpec;
use scene_gen::dataset::{Dataset, DatasetError, DatasetSpec, FrameSelection, Lighting, Quality, SeedRange, Shard};

use super::house::HouseArgs;
use super::progress::Progress;
use super::{CliError, bad_input, failure};

/// Which scenarios to make.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LightingArg {
    Day,
    Night,
    Both,
}

/// Sample-count presets of the ray tracer, for `dataset` and `render` ([`Quality`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum QualityArg {
    /// The evaluator's render: one ray per pixel, irradiance at adaptive anchors every 4 px
    /// (texture and edges at every pixel), every light traced; the fastest.
    Evaluator,
    /// One ray per pixel, shaded at every pixel; bounced light from the irradiance volume.
    Preview,
    /// 2x2 pixel samples; bounced light from the irradiance volume.
    Standard,
    /// 4x4 pixel samples; one final-gather bounce ray per sample over the volume.
    High,
}

impl From<QualityArg> for Quality {
    fn from(arg: QualityArg) -> Quality {
        match arg {
            QualityArg::Evaluator => Quality::Evaluator,
            QualityArg::Preview => Quality::Preview,
            QualityArg::Standard => Quality::Standard,
            QualityArg::High => Quality::High,
        }
    }
}

#[derive(Args, Debug)]
pub struct DatasetArgs {
    /// House seeds: `A..B` (B excluded), `A..=B`, or one seed.
    #[arg(long)]
    pub seeds: String,
    /// Camera: a TOML file or `SENSOR[,focal_mm=F][,pitch_deg=P][,height_m=H][,key=value...]`.
    #[arg(long)]
    pub camera: String,
    /// Output folder (created if missing; reruns resume in it).
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long, value_enum, default_value_t = LightingArg::Both)]
    pub lighting: LightingArg,
    /// This run's share of the seeds, `I/N` (0 <= I < N): the seeds numbered I mod N in the range.
    #[arg(long, default_value = "0/1")]
    pub shard: String,
    /// K frames per house, evenly spaced along the walk (default: every pose, one per 0.25 m).
    #[arg(long, conflicts_with = "every")]
    pub frames: Option<u32>,
    /// Every N-th pose of the walk.
    #[arg(long)]
    pub every: Option<u32>,
    /// Bin the sensor down to at most this width in pixels (keeps the field of view).
    #[arg(long)]
    pub max_width: Option<u32>,
    #[arg(long, value_enum, default_value_t = QualityArg::Standard)]
    pub quality: QualityArg,
    /// Only merge the seeds' fragments into the COCO files (after all shards ran).
    #[arg(long)]
    pub merge: bool,
    /// Also write the raw captures under `raw/` (DN at the ADC depth; a colour sensor's Bayer
    /// mosaic, RGGB).
    #[arg(long)]
    pub raw: bool,
    /// The houses (recorded in DIR/dataset.json; every shard must give the same).
    #[command(flatten)]
    pub house: HouseArgs,
}

fn classify(e: DatasetError) -> CliError {
    match e {
        DatasetError::Spec(_) | DatasetError::Shard(_) | DatasetError::Invalid(_) | DatasetError::Mismatch { .. } => {
            bad_input(e)
        }
        other => failure(other),
    }
}

pub fn run(args: &DatasetArgs) -> Result<(), CliError> {
    // Every input check before any work or write.
    let seeds: SeedRange = scene_gen::dataset::parse_seeds(&args.seeds).map_err(bad_input)?;
    let shard: Shard = args.shard.parse().map_err(|e: scene_gen::dataset::ShardError| bad_input(e))?;
    let mut camera = CameraSpec::from_arg(&args.camera).map_err(bad_input)?;
    if let Some(m) = args.max_width {
        if m == 0 {
            return Err(bad_input(anyhow!("--max-width must be at least 1")));
        }
        camera.max_width_px = Some(m);
    }
    let frames = match (args.frames, args.every) {
        (Some(k), _) => FrameSelection::Count { frames: k },
        (None, Some(n)) => FrameSelection::Every { step: n },
        (None, None) => FrameSelection::All,
    };
    let lighting = match args.lighting {
        LightingArg::Day => vec![Lighting::Day],
        LightingArg::Night => vec![Lighting::Night],
        LightingArg::Both => vec![Lighting::Day, Lighting::Night],
    };
    let quality = Quality::from(args.quality);
    let house = args.house.checked()?;
    house.envelope.check_camera_height(camera.height_m).map_err(|e| bad_input(anyhow!(e)))?;
    let spec = DatasetSpec { house, raw: args.raw, ..DatasetSpec::new(seeds, camera, lighting, frames, quality) };
    let dataset = Dataset::new(&args.out, spec).map_err(classify)?;
    dataset.check_dir().map_err(classify)?;

    if args.merge {
        let written = dataset.merge().map_err(classify)?;
        report_merge(&dataset, &written);
        return Ok(());
    }

    dataset.init().map_err(classify)?;
    let progress = Progress::new("dataset", "frames", 0);
    let (w, h) = dataset.image_size();
    let report = dataset.run_shard(shard, &progress).map_err(classify)?;
    progress.finish();
    println!(
        "shard {shard}: {} frames of {w}x{h} ({} rendered, {} already there) in {}",
        report.frames,
        report.rendered,
        report.skipped,
        args.out.display()
    );
    let missing = dataset.missing_seeds();
    if missing.is_empty() {
        let written = dataset.merge().map_err(classify)?;
        report_merge(&dataset, &written);
    } else {
        println!(
            "{} of {} seeds still to do (other shards); the last shard to finish merges, or run again with --merge",
            missing.len(),
            dataset.spec.seeds().len()
        );
    }
    Ok(())
}

fn report_merge(dataset: &Dataset, written: &[PathBuf]) {
    for &l in &dataset.spec.lighting {
        let path = dataset.annotations_path(l);
        let state = if written.contains(&path) { "wrote" } else { "up to date:" };
        println!("{state} {}", path.display());
    }
}
