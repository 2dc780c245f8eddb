//! `scene-gen detect IMAGE...`: the learned detector on any images, as COCO results; and
//! `scene-gen detector train`: trains it on datasets that `scene-gen dataset` wrote.

use std::path::PathBuf;

use anyhow::{Context, anyhow};
use clap::{Args, Subcommand};
use rayon::prelude::*;
use scene_gen::detection::cnn::train::{self, TrainConfig};
use scene_gen::detection::cnn::{CnnDetector, ImageView};
use serde::Serialize;

use super::{CliError, bad_input, failure, progress};

#[derive(Args, Debug)]
pub struct DetectArgs {
    /// Images to detect in (8-bit PNG, JPEG...; colour or grey).
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// Print a JSON list of COCO results, each with its image's `file_name`.
    #[arg(long)]
    pub json: bool,
    /// Lowest score reported.
    #[arg(long, default_value_t = scene_gen::detection::cnn::DEFAULT_MIN_SCORE)]
    pub min_score: f32,
    /// Weights to use instead of the built-in ones (a safetensors file `detector train` wrote).
    #[arg(long)]
    pub weights: Option<PathBuf>,
    /// Wider images are resized to this width before the network reads them (boxes are given
    /// in the image's own pixels): the width of the training images, 320 for the built-in
    /// weights. 0 reads every image at its own size.
    #[arg(long, default_value_t = scene_gen::detection::cnn::TRAINED_WIDTH_PX)]
    pub input_width: usize,
}

/// One detection as a COCO results record, with the image it was found in.
#[derive(Serialize)]
struct ResultRecord<'a> {
    file_name: &'a str,
    category_id: u32,
    bbox: [f64; 4],
    score: f64,
}

/// The detector the arguments name: the built-in weights or a file.
pub fn load_detector(weights: Option<&PathBuf>) -> Result<CnnDetector, CliError> {
    match weights {
        None => CnnDetector::embedded().map_err(failure),
        Some(path) => {
            let bytes = std::fs::read(path)
                .with_context(|| format!("cannot read weights {}", path.display()))
                .map_err(bad_input)?;
            CnnDetector::from_safetensors(&bytes)
                .with_context(|| format!("weights {}", path.display()))
                .map_err(bad_input)
        }
    }
}

pub fn run_detect(args: &DetectArgs) -> Result<(), CliError> {
    if !(0.0..=1.0).contains(&args.min_score) {
        return Err(bad_input(anyhow!("--min-score {} is outside 0..=1", args.min_score)));
    }
    let mut detector = load_detector(args.weights.as_ref())?;
    detector.min_score = args.min_score;
    detector.input_width_px = (args.input_width > 0).then_some(args.input_width);
    // Every image is read before any output, so a bad one leaves no partial answer.
    let samples = args
        .images
        .par_iter()
        .map(|path| {
            train::read_image(path).map_err(|why| bad_input(anyhow!("cannot read image {}: {why}", path.display())))
        })
        .collect::<Result<Vec<_>, CliError>>()?;
    let found = samples
        .par_iter()
        .map(|s| {
            detector.detect(ImageView { pixels: &s.pixels, width: s.width, height: s.height, channels: s.channels })
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(failure)?;
    let names: Vec<String> = args.images.iter().map(|p| p.display().to_string()).collect();
    if args.json {
        let records: Vec<ResultRecord<'_>> = names
            .iter()
            .zip(&found)
            .flat_map(|(name, dets)| {
                dets.iter().map(move |d| ResultRecord {
                    file_name: name,
                    category_id: d.category_id,
                    bbox: d.bbox,
                    score: d.score,
                })
            })
            .collect();
        println!("{}", serde_json::to_string(&records).map_err(failure)?);
        return Ok(());
    }
    for (name, dets) in names.iter().zip(&found) {
        println!("{name}: {} detections", dets.len());
        for d in dets {
            let class = scene_gen::detection::cnn::category_name(d.category_id);
            let [x, y, w, h] = d.bbox;
            println!("  {class:<10} {:.3}  x {x:.1} y {y:.1} w {w:.1} h {h:.1}", d.score);
        }
    }
    Ok(())
}

#[derive(Args, Debug)]
pub struct DetectorArgs {
    #[command(subcommand)]
    pub command: DetectorCommand,
}

#[derive(Subcommand, Debug)]
pub enum DetectorCommand {
    /// Train the detector on datasets `scene-gen dataset` wrote (`scripts/train_detector` makes them).
    Train(TrainArgs),
}

#[derive(Args, Debug)]
pub struct TrainArgs {
    /// Dataset folders to train on.
    #[arg(long = "data", required = true, num_args = 1..)]
    pub data: Vec<PathBuf>,
    /// A held-out dataset folder, scored (AP@0.5) after every epoch.
    #[arg(long)]
    pub validation: Option<PathBuf>,
    /// Output folder: detector.safetensors, train_log.tsv, validation.tsv.
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long, default_value_t = TrainConfig::default().epochs)]
    pub epochs: usize,
    /// Images per step.
    #[arg(long, default_value_t = TrainConfig::default().batch)]
    pub batch: usize,
    /// Peak learning rate (AdamW, warm-up then cosine decay).
    #[arg(long, default_value_t = TrainConfig::default().learning_rate)]
    pub learning_rate: f64,
    /// Seeds the initial weights, the image order and the flips.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

pub fn run_detector(args: &DetectorArgs) -> Result<(), CliError> {
    match &args.command {
        DetectorCommand::Train(t) => {
            for (name, ok) in [
                ("--epochs", t.epochs > 0),
                ("--batch", t.batch > 0),
                ("--learning-rate", t.learning_rate > 0.0 && t.learning_rate.is_finite()),
            ] {
                if !ok {
                    return Err(bad_input(anyhow!("{name} must be positive")));
                }
            }
            let config = TrainConfig {
                data: t.data.clone(),
                validation: t.validation.clone(),
                out: t.out.clone(),
                epochs: t.epochs,
                batch: t.batch,
                learning_rate: t.learning_rate,
                seed: t.seed,
            };
            let quiet = progress::is_quiet();
            train::train(&config, &mut |line| {
                if !quiet {
                    eprintln!("{line}");
                }
            })
            .map_err(|e| match e {
                train::TrainError::Data { .. } => bad_input(e),
                other => failure(other),
            })
        }
    }
}
