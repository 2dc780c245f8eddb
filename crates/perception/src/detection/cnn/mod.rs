//! A learned detector for scene-gen's 11 categories: a small CenterNet-style network trained
//! on scene-gen's own datasets ([`train`]), run on the CPU in Rust by candle.
//!
//! Why CenterNet: one heat map per class and a box per peak, no anchors and no non-maximum
//! suppression, so decoding is a 3 x 3 peak test; the whole detector is one convolutional
//! graph, cheap at the evaluator's 320 px frames. The network ([`network`]), the boxes-to-maps
//! encoding ([`encoding`]) and the trainer share one definition, so what is trained is what
//! runs.
//!
//! The built-in weights were trained by `scripts/train_detector.py`, the same network, targets
//! and loss in PyTorch, which trains it about 13 times faster on the CPU; it writes the file
//! [`CnnDetector::from_safetensors`] reads, and the file is checked against [`network`]'s layer
//! names and shapes on loading. The weights (`models/detector/`, with their model card and
//! training log) are compiled into the library: [`CnnDetector::embedded`] needs no file.

pub mod encoding;
pub mod network;
pub mod train;

use std::collections::HashMap;

use candle_core::{Device, Tensor};

use super::Detection;
pub use encoding::{TargetBox, Targets, decode, encode};
pub use network::{ImageView, Network};

/// The project's trained weights (safetensors).
static EMBEDDED_WEIGHTS: &[u8] =
    include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/detector/detector.safetensors"));

/// Lowest score a detection is reported with: low enough that AP sees the whole
/// precision-recall curve, high enough to keep the list short.
pub const DEFAULT_MIN_SCORE: f32 = 0.05;

/// Width of the images the built-in weights were trained on (models/detector/README.md).
pub const TRAINED_WIDTH_PX: usize = 320;

/// The name of COCO category `id` (1..=10 the object classes, 11 threshold).
#[must_use]
pub fn category_name(id: u32) -> &'static str {
    match id {
        11 => "threshold",
        _ => {
            scene_gen_scene::scene::ObjectClass::ALL.get((id as usize).wrapping_sub(1)).map_or("unknown", |c| c.name())
        }
    }
}

/// Why the detector could not be built or run.
#[derive(Debug, thiserror::Error)]
pub enum CnnError {
    #[error("detector weights: {0}")]
    Weights(String),
    #[error("detector network: {0}")]
    Network(#[from] candle_core::Error),
    #[error("image is {width}x{height} with {channels} channels but holds {len} bytes")]
    BadImage { width: usize, height: usize, channels: usize, len: usize },
}

/// The trained network, ready to detect.
#[derive(Debug)]
pub struct CnnDetector {
    network: Network,
    /// Reported detections score at least this.
    pub min_score: f32,
    /// Wider images are resized to this width (aspect kept) before the network reads them,
    /// and the boxes scaled back: a convolutional detector finds objects at the sizes in
    /// pixels it was trained on, so 1280 px frames read as they are lose most of them (AP@0.5
    /// 0.105 against 0.600 resized, docs/BENCHMARKS.md). `None` (or 0) reads every image as
    /// it is.
    pub input_width_px: Option<usize>,
}

impl CnnDetector {
    /// The detector over the project's trained weights.
    ///
    /// # Errors
    /// [`CnnError::Weights`] if this build carries no valid weights.
    pub fn embedded() -> Result<CnnDetector, CnnError> {
        CnnDetector::from_safetensors(EMBEDDED_WEIGHTS)
    }

    /// The detector over weights in safetensors form (as [`train::train`] writes them).
    ///
    /// # Errors
    /// [`CnnError::Weights`] for a file that is not safetensors or lacks a layer.
    pub fn from_safetensors(bytes: &[u8]) -> Result<CnnDetector, CnnError> {
        let weights: HashMap<String, Tensor> =
            candle_core::safetensors::load_buffer(bytes, &Device::Cpu).map_err(|e| CnnError::Weights(e.to_string()))?;
        let network = Network::from_weights(&weights).map_err(CnnError::Weights)?;
        Ok(CnnDetector { network, min_score: DEFAULT_MIN_SCORE, input_width_px: Some(TRAINED_WIDTH_PX) })
    }

    /// Detections in one 8-bit image, best first, in the image's own pixels (the network reads
    /// it at [`CnnDetector::input_width_px`]).
    ///
    /// # Errors
    /// [`CnnError::BadImage`] for a buffer that does not match its size; candle's errors.
    pub fn detect(&self, image: ImageView<'_>) -> Result<Vec<Detection>, CnnError> {
        let expected = image.width * image.height * image.channels;
        if image.pixels.len() != expected || !matches!(image.channels, 1 | 3) || image.width == 0 || image.height == 0 {
            return Err(CnnError::BadImage {
                width: image.width,
                height: image.height,
                channels: image.channels,
                len: image.pixels.len(),
            });
        }
        match self.input_width_px {
            Some(width) if width > 0 && image.width > width => {
                let resized = resize_to_width(image, width);
                let view = ImageView { pixels: &resized.pixels, width: resized.width, height: resized.height, ..image };
                let (sx, sy) = (image.width as f64 / resized.width as f64, image.height as f64 / resized.height as f64);
                let mut found = self.detect_as_is(view)?;
                for d in &mut found {
                    d.bbox = [d.bbox[0] * sx, d.bbox[1] * sy, d.bbox[2] * sx, d.bbox[3] * sy];
                }
                Ok(found)
            }
            _ => self.detect_as_is(image),
        }
    }

    /// Detections in `image` read at its own size.
    fn detect_as_is(&self, image: ImageView<'_>) -> Result<Vec<Detection>, CnnError> {
        let padded = (network::padded(image.width), network::padded(image.height));
        let input = network::input_tensor(&[image], padded)?;
        let out = self.network.forward(&input)?;
        let heat = candle_nn::ops::sigmoid(&out.heat_logits)?.flatten_all()?.to_vec1::<f32>()?;
        let boxes = out.boxes.flatten_all()?.to_vec1::<f32>()?;
        let cells = (padded.0 / network::STRIDE_PX, padded.1 / network::STRIDE_PX);
        Ok(decode(&heat, &boxes, cells, (image.width, image.height), self.min_score))
    }
}

/// An image resized for the network.
struct Resized {
    pixels: Vec<u8>,
    width: usize,
    height: usize,
}

/// `image` resized to `width` (height in proportion, at least 1) with a triangle filter
/// stretched over the scale factor, so that every input pixel counts, as a camera's own
/// scaler or OpenCV's `INTER_AREA` would, rather than sampling every n-th pixel and keeping
/// its noise and aliasing.
fn resize_to_width(image: ImageView<'_>, width: usize) -> Resized {
    let height = ((image.height as f64 * width as f64 / image.width as f64).round() as usize).max(1);
    let (w, h) = (image.width as u32, image.height as u32);
    let (out_w, out_h, filter) = (width as u32, height as u32, image::imageops::FilterType::Triangle);
    // The buffers borrow the caller's pixels: a 12 MP frame is not copied to be read once.
    let pixels = if image.channels == 3 {
        let buffer = image::ImageBuffer::<image::Rgb<u8>, _>::from_raw(w, h, image.pixels).expect("size checked");
        image::imageops::resize(&buffer, out_w, out_h, filter).into_raw()
    } else {
        let buffer = image::ImageBuffer::<image::Luma<u8>, _>::from_raw(w, h, image.pixels).expect("size checked");
        image::imageops::resize(&buffer, out_w, out_h, filter).into_raw()
    };
    Resized { pixels, width, height }
}
