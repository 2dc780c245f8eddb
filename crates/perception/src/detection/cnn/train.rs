//! Training the detector on COCO datasets that `scene-gen dataset` wrote: focal loss on the
//! heat maps and L1 on the box map at object centres (CenterNet), AdamW with a warm-up and a
//! cosine decay, horizontal flips. After each epoch the weights are written and, given a
//! held-out dataset, scored there with [`crate::detection::coco_eval`] (pycocotools' AP).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use candle_core::{DType, Device, Tensor};
use candle_nn::optim::{AdamW, Optimizer, ParamsAdamW};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::CnnDetector;
use super::encoding::{TargetBox, encode};
use super::network::{self, BOX_CHANNELS, BatchNorms, ImageView, NUM_CLASSES, Network, Output, STRIDE_PX};
use crate::detection::coco_eval::{self, CocoGroundTruth, DetectionRecord};

/// What to train on and how long.
#[derive(Clone, Debug)]
pub struct TrainConfig {
    /// Dataset folders (each with `annotations/instances_*.json` and `images/`).
    pub data: Vec<PathBuf>,
    /// A held-out dataset folder scored after each epoch.
    pub validation: Option<PathBuf>,
    /// Where the weights and logs go.
    pub out: PathBuf,
    pub epochs: usize,
    pub batch: usize,
    /// Peak learning rate (AdamW).
    pub learning_rate: f64,
    /// Seeds the initial weights, the order of images and the flips.
    pub seed: u64,
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            data: Vec::new(),
            validation: None,
            out: PathBuf::from("models/detector"),
            epochs: 12,
            batch: 16,
            learning_rate: 3e-3,
            seed: 0,
        }
    }
}

/// Why training stopped.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    #[error("{path}: {why}")]
    Data { path: PathBuf, why: String },
    #[error("training: {0}")]
    Network(#[from] candle_core::Error),
    #[error("training: {0}")]
    Internal(String),
    #[error("writing {path}: {source}")]
    Write { path: PathBuf, source: std::io::Error },
    #[error("{0}")]
    Detector(#[from] super::CnnError),
}

/// One training image in memory.
#[derive(Clone, Debug)]
pub struct Sample {
    pub pixels: Vec<u8>,
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub boxes: Vec<TargetBox>,
}

impl Sample {
    fn view(&self) -> ImageView<'_> {
        ImageView { pixels: &self.pixels, width: self.width, height: self.height, channels: self.channels }
    }

    /// The image mirrored left to right, with its boxes.
    fn flipped(&self) -> Sample {
        let (w, c) = (self.width, self.channels);
        let mut pixels = vec![0u8; self.pixels.len()];
        for y in 0..self.height {
            for x in 0..w {
                let (src, dst) = ((y * w + x) * c, (y * w + (w - 1 - x)) * c);
                pixels[dst..dst + c].copy_from_slice(&self.pixels[src..src + c]);
            }
        }
        let boxes = self
            .boxes
            .iter()
            .map(|b| TargetBox {
                class: b.class,
                bbox: [w as f32 - b.bbox[0] - b.bbox[2], b.bbox[1], b.bbox[2], b.bbox[3]],
            })
            .collect();
        Sample { pixels, boxes, ..*self }
    }
}

/// One COCO file of a dataset folder: its ground truth and its images, in the file's order.
#[derive(Debug)]
pub struct DatasetPart {
    pub ground_truth: CocoGroundTruth,
    pub samples: Vec<Sample>,
}

/// Reads every `annotations/instances_*.json` of a dataset folder and the images they name.
///
/// # Errors
/// [`TrainError::Data`] naming the file that is missing or unreadable.
pub fn load_dataset(folder: &Path) -> Result<Vec<DatasetPart>, TrainError> {
    let data_error = |path: &Path, why: String| TrainError::Data { path: path.to_path_buf(), why };
    let annotations = folder.join("annotations");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&annotations)
        .map_err(|e| data_error(&annotations, e.to_string()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("instances_") && n.ends_with(".json"))
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(data_error(&annotations, "holds no instances_*.json".into()));
    }
    files
        .iter()
        .map(|file| {
            let ground_truth = CocoGroundTruth::read(file).map_err(|e| data_error(file, e.to_string()))?;
            let samples = ground_truth
                .images
                .par_iter()
                .map(|image| {
                    let path = folder.join("images").join(&image.file_name);
                    let mut sample = read_image(&path).map_err(|why| data_error(&path, why))?;
                    sample.boxes = ground_truth
                        .annotations
                        .iter()
                        .filter(|a| {
                            a.image_id == image.id
                                && a.iscrowd == 0
                                && (1..=NUM_CLASSES as u32).contains(&a.category_id)
                        })
                        .map(|a| TargetBox { class: a.category_id as usize - 1, bbox: a.bbox.map(|v| v as f32) })
                        .collect();
                    Ok(sample)
                })
                .collect::<Result<Vec<_>, TrainError>>()?;
            Ok(DatasetPart { ground_truth, samples })
        })
        .collect()
}

/// An 8-bit image file as a sample without boxes: RGB stays RGB, anything else becomes grey.
///
/// # Errors
/// The decoder's message.
pub fn read_image(path: &Path) -> Result<Sample, String> {
    let image = image::open(path).map_err(|e| e.to_string())?;
    let (width, height) = (image.width() as usize, image.height() as usize);
    let (pixels, channels) = match image {
        image::DynamicImage::ImageRgb8(rgb) => (rgb.into_raw(), 3),
        image::DynamicImage::ImageRgba8(_)
        | image::DynamicImage::ImageRgb16(_)
        | image::DynamicImage::ImageRgba16(_) => (image.to_rgb8().into_raw(), 3),
        other => (other.to_luma8().into_raw(), 1),
    };
    Ok(Sample { pixels, width, height, channels, boxes: Vec::new() })
}

/// A batch as tensors: input, heat targets, box targets, box mask.
struct Batch {
    input: Tensor,
    heat: Tensor,
    boxes: Tensor,
    mask: Tensor,
}

fn make_batch(samples: &[Sample]) -> candle_core::Result<Batch> {
    let pw = network::padded(samples.iter().map(|s| s.width).max().unwrap_or(1));
    let ph = network::padded(samples.iter().map(|s| s.height).max().unwrap_or(1));
    let (cw, ch) = (pw / STRIDE_PX, ph / STRIDE_PX);
    let views: Vec<ImageView<'_>> = samples.iter().map(Sample::view).collect();
    let input = network::input_tensor(&views, (pw, ph))?;
    let (mut heat, mut boxes, mut mask) = (Vec::new(), Vec::new(), Vec::new());
    for s in samples {
        let t = encode(&s.boxes, cw, ch);
        heat.extend(t.heat);
        boxes.extend(t.boxes);
        mask.extend(t.mask);
    }
    let b = samples.len();
    Ok(Batch {
        input,
        heat: Tensor::from_vec(heat, (b, NUM_CLASSES, ch, cw), &Device::Cpu)?,
        boxes: Tensor::from_vec(boxes, (b, BOX_CHANNELS, ch, cw), &Device::Cpu)?,
        mask: Tensor::from_vec(mask, (b, 1, ch, cw), &Device::Cpu)?,
    })
}

/// The loss parts of one batch: total, heat-map focal loss, box L1, both per object.
struct Loss {
    total: Tensor,
    heat: f32,
    boxes: f32,
}

/// CenterNet's loss: the penalty-reduced focal loss (alpha 2, beta 4) over every heat-map cell
/// and the L1 loss of the box map at centre cells, each divided by the number of objects.
fn loss(out: &Output, batch: &Batch) -> candle_core::Result<Loss> {
    let p = candle_nn::ops::sigmoid(&out.heat_logits)?.clamp(1e-4f32, 1.0f32 - 1e-4)?;
    let not_p = p.affine(-1.0, 1.0)?;
    let centre = batch.heat.ge(1.0f32)?.to_dtype(DType::F32)?;
    let objects = centre.sum_all()?.to_scalar::<f32>()?.max(1.0);
    let pos = p.log()?.mul(&not_p.sqr()?)?.mul(&centre)?.sum_all()?;
    let away = batch.heat.affine(-1.0, 1.0)?.sqr()?.sqr()?;
    let neg = not_p.log()?.mul(&p.sqr()?)?.mul(&away)?.sum_all()?;
    let heat = pos.add(&neg)?.affine(-1.0 / f64::from(objects), 0.0)?;
    let boxes = out
        .boxes
        .sub(&batch.boxes)?
        .abs()?
        .broadcast_mul(&batch.mask)?
        .sum_all()?
        .affine(1.0 / f64::from(objects), 0.0)?;
    let (h, b) = (heat.to_scalar::<f32>()?, boxes.to_scalar::<f32>()?);
    Ok(Loss { total: heat.add(&boxes)?, heat: h, boxes: b })
}

/// Learning rate at `step` of `total`: linear warm-up over the first steps, then a cosine
/// down to 2 % of the peak.
fn learning_rate(peak: f64, step: usize, total: usize) -> f64 {
    let warm = 300.min(total / 10).max(1);
    if step < warm {
        return peak * (0.1 + 0.9 * step as f64 / warm as f64);
    }
    let t = (step - warm) as f64 / (total - warm).max(1) as f64;
    peak * (0.02 + 0.98 * 0.5 * (1.0 + (std::f64::consts::PI * t).cos()))
}

/// The weights file [`train`] writes in its output folder.
pub const WEIGHTS_FILE: &str = "detector.safetensors";

/// Trains from fresh weights. Writes `detector.safetensors` after every epoch, `train_log.tsv`
/// (one line per 20 batches) and, with a validation set, `validation.tsv` (AP@0.5 per epoch).
/// `report` hears one line per log entry.
///
/// # Errors
/// [`TrainError`] for unreadable data, or failure to write the outputs.
pub fn train(config: &TrainConfig, report: &mut dyn FnMut(&str)) -> Result<(), TrainError> {
    let mut samples = Vec::new();
    for folder in &config.data {
        samples.extend(load_dataset(folder)?.into_iter().flat_map(|p| p.samples));
    }
    if samples.is_empty() {
        return Err(TrainError::Data { path: config.out.clone(), why: "no training images".into() });
    }
    let validation = config.validation.as_deref().map(load_dataset).transpose()?;
    fit(&samples, validation.as_deref(), config, report)
}

/// Trains from fresh weights on `samples` (as [`train`], with the data in memory).
///
/// # Errors
/// As [`train`].
pub fn fit(
    samples: &[Sample],
    validation: Option<&[DatasetPart]>,
    config: &TrainConfig,
    report: &mut dyn FnMut(&str),
) -> Result<(), TrainError> {
    std::fs::create_dir_all(&config.out).map_err(write_error(&config.out))?;
    report(&format!(
        "{} training images, {} objects; {} parameters",
        samples.len(),
        samples.iter().map(|s| s.boxes.len()).sum::<usize>(),
        Network::parameter_count()
    ));
    let vars = Network::init_vars(config.seed)?;
    let network = Network::from_vars(&vars).map_err(TrainError::Internal)?;
    let mut norms = BatchNorms::from_vars(&vars).map_err(TrainError::Internal)?;
    let params = ParamsAdamW { lr: config.learning_rate, weight_decay: 1e-4, ..ParamsAdamW::default() };
    let mut optimizer = AdamW::new(vars.iter().map(|(_, v)| v.clone()).collect(), params)?;
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed ^ 0x5eed_da7a);
    let batch = config.batch.max(1);
    let steps_per_epoch = samples.len().div_ceil(batch);
    let total_steps = steps_per_epoch * config.epochs;
    let mut log = String::from("epoch\tstep\tloss\theat_loss\tbox_loss\tlearning_rate\telapsed_s\n");
    let mut val_log = String::from("epoch\tap50\tap\telapsed_s\n");
    let start = Instant::now();
    let mut order: Vec<usize> = (0..samples.len()).collect();
    let mut step = 0;
    for epoch in 0..config.epochs {
        order.shuffle(&mut rng);
        let mut sums = (0.0f64, 0.0f64, 0usize);
        for chunk in order.chunks(batch) {
            let picked: Vec<Sample> = chunk
                .iter()
                .map(|&i| if rng.random_bool(0.5) { samples[i].flipped() } else { samples[i].clone() })
                .collect();
            let b = make_batch(&picked)?;
            let out = network.forward_with(&b.input, &mut |i, z| norms.apply(i, z))?;
            let l = loss(&out, &b)?;
            let lr = learning_rate(config.learning_rate, step, total_steps);
            optimizer.set_learning_rate(lr);
            optimizer.backward_step(&l.total)?;
            sums = (sums.0 + f64::from(l.heat), sums.1 + f64::from(l.boxes), sums.2 + 1);
            step += 1;
            if step % 20 == 0 || step == total_steps {
                let (h, bx) = (sums.0 / sums.2 as f64, sums.1 / sums.2 as f64);
                let line = format!(
                    "{epoch}\t{step}\t{:.4}\t{h:.4}\t{bx:.4}\t{lr:.6}\t{:.0}",
                    h + bx,
                    start.elapsed().as_secs_f64()
                );
                report(&line);
                let _ = writeln!(log, "{line}");
                sums = (0.0, 0.0, 0);
            }
        }
        let weights_path = config.out.join(WEIGHTS_FILE);
        let weights = norms.folded_weights(&vars).map_err(TrainError::Internal)?;
        candle_core::safetensors::save(&weights, &weights_path)?;
        std::fs::write(config.out.join("train_log.tsv"), &log).map_err(write_error(&config.out))?;
        if let Some(parts) = validation {
            let detector =
                CnnDetector::from_safetensors(&std::fs::read(&weights_path).map_err(write_error(&weights_path))?)?;
            let (ap50, ap) = score(&detector, parts)?;
            let line = format!("{epoch}\t{ap50:.4}\t{ap:.4}\t{:.0}", start.elapsed().as_secs_f64());
            report(&format!("validation {line}"));
            let _ = writeln!(val_log, "{line}");
            std::fs::write(config.out.join("validation.tsv"), &val_log).map_err(write_error(&config.out))?;
        }
    }
    Ok(())
}

/// The error of a failed write to `path`.
fn write_error(path: &Path) -> impl FnOnce(std::io::Error) -> TrainError {
    let path = path.to_path_buf();
    move |source| TrainError::Write { path, source }
}

/// AP@0.5 and AP@[.5:.95] of `detector` over held-out parts (their images together).
///
/// # Errors
/// candle's errors, or a COCO evaluation error.
pub fn score(detector: &CnnDetector, parts: &[DatasetPart]) -> Result<(f64, f64), TrainError> {
    let mut gt = CocoGroundTruth::default();
    let mut records: Vec<DetectionRecord> = Vec::new();
    for (p, part) in parts.iter().enumerate() {
        // Image ids are unique within a file; offset them so parts never collide.
        let offset = (p as u64) << 40;
        let found: Vec<Vec<DetectionRecord>> = part
            .ground_truth
            .images
            .par_iter()
            .zip(part.samples.par_iter())
            .map(|(image, sample)| {
                detector.detect(sample.view()).map(|d| d.iter().map(|d| d.record(image.id + offset)).collect())
            })
            .collect::<Result<_, _>>()?;
        records.extend(found.into_iter().flatten());
        gt.images
            .extend(part.ground_truth.images.iter().map(|i| coco_eval::CocoImage { id: i.id + offset, ..i.clone() }));
        gt.annotations.extend(part.ground_truth.annotations.iter().map(|a| coco_eval::GtAnnotation {
            id: a.id + offset,
            image_id: a.image_id + offset,
            ..a.clone()
        }));
        gt.categories.clone_from(&part.ground_truth.categories);
    }
    let metrics = coco_eval::evaluate(&gt, &records)
        .map_err(|e| TrainError::Data { path: PathBuf::from("validation"), why: e.to_string() })?;
    Ok((metrics.ap50, metrics.ap))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grey room with a bright square and a dark bar: two objects a network can learn.
    fn synthetic(shift: usize) -> Sample {
        let (width, height) = (96, 64);
        let mut pixels = vec![110u8; width * height * 3];
        let mut paint = |x0: usize, y0: usize, w: usize, h: usize, rgb: [u8; 3]| {
            for y in y0..y0 + h {
                for x in x0..x0 + w {
                    pixels[(y * width + x) * 3..][..3].copy_from_slice(&rgb);
                }
            }
        };
        paint(10 + shift, 12, 24, 24, [240, 220, 60]);
        paint(50, 40 - shift / 2, 36, 8, [20, 30, 160]);
        let boxes = vec![
            TargetBox { class: 7, bbox: [10.0 + shift as f32, 12.0, 24.0, 24.0] },
            TargetBox { class: 10, bbox: [50.0, 40.0 - (shift / 2) as f32, 36.0, 8.0] },
        ];
        Sample { pixels, width, height, channels: 3, boxes }
    }

    #[test]
    fn flipping_mirrors_pixels_and_boxes() {
        let s = synthetic(0);
        let f = s.flipped();
        assert_eq!(f.pixels[..3], s.pixels[(s.width - 1) * 3..s.width * 3]);
        assert_eq!(f.boxes[0].bbox, [96.0 - 10.0 - 24.0, 12.0, 24.0, 24.0]);
        assert_eq!(f.flipped().pixels, s.pixels);
    }

    #[test]
    fn the_learning_rate_warms_up_then_decays() {
        let total = 1000;
        assert!(learning_rate(1.0, 0, total) < learning_rate(1.0, 50, total));
        assert!((learning_rate(1.0, 100, total) - 1.0).abs() < 1e-9);
        assert!(learning_rate(1.0, 999, total) < 0.05);
    }

    /// Training end to end: a few hundred steps on four synthetic images teach the network to
    /// find both objects, with the classes and boxes it was shown (a broken loss, encoding or
    /// decoding fails this).
    #[test]
    fn training_learns_to_find_what_it_was_shown() {
        let samples: Vec<Sample> = (0..4).map(|i| synthetic(i * 6)).collect();
        let out = std::env::temp_dir().join(format!("scene-gen-cnn-train-{}", std::process::id()));
        let config =
            TrainConfig { out: out.clone(), epochs: 60, batch: 4, learning_rate: 3e-3, ..TrainConfig::default() };
        let mut lines = Vec::new();
        fit(&samples, None, &config, &mut |l| lines.push(l.to_string())).unwrap();
        let first: f64 = lines[1].split('\t').nth(2).unwrap().parse().unwrap();
        let last: f64 = lines.last().unwrap().split('\t').nth(2).unwrap().parse().unwrap();
        assert!(last < first * 0.75, "loss {first} -> {last}");
        let detector = CnnDetector::from_safetensors(&std::fs::read(out.join(WEIGHTS_FILE)).unwrap()).unwrap();
        let probe = synthetic(3);
        let found = detector.detect(probe.view()).unwrap();
        for want in &probe.boxes {
            let best = found
                .iter()
                .filter(|d| d.category_id == want.class as u32 + 1)
                .map(|d| coco_eval::box_iou(&d.bbox, &want.bbox.map(f64::from), false))
                .fold(0.0, f64::max);
            assert!(best > 0.5, "class {} best IoU {best}: {found:?}", want.class + 1);
        }
        std::fs::remove_dir_all(out).ok();
    }
}
