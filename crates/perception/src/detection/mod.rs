//! The detection and threshold tasks: ground truth from rendered frames, a built-in
//! detectability model, COCO evaluation, and threshold visibility.
//!
//! * [`ground_truth`]: per instance of a [`scene_gen_render::Frame`], its visible box, visible
//!   pixels, visible fraction (against its mesh rasterised alone) and distance; which objects
//!   count (within 6 m, above a pixel floor), as COCO annotations.
//! * [`detectability`]: the [`Detector`] trait and [`detectability::DetectabilityModel`], a
//!   Johnson-criteria detector driven by object size and contrast-to-noise on the noisy image.
//! * [`cnn`]: the learned detector, a small CenterNet-style network trained on scene-gen's own
//!   datasets and run on the CPU (candle), with its trainer.
//! * [`output_noise`]: the camera's noise at each level of the 8-bit image, from its sensor
//!   model and output rule: what the detector divides contrast by in the evaluator.
//! * [`coco_eval`]: AP@0.5, AP@[.5:.95] and per-class AP exactly as pycocotools computes them,
//!   and COCO JSON in and out.
//! * [`thresholds`]: threshold accuracy from per-frame visible pixels and crossing times.
//! * [`plugin`]: the protocol for an external detector process (below).
//!
//! ```text
//! Frame + Scene + Camera ─► ground_truth ─► GtObject ─┬─► COCO annotations ─┐
//! noisy DN image ─────────────────────────────────────┴─► Detector ─► DetectionRecord ─► coco_eval ─► AP
//! ```
//!
//! # External detector protocol (JSON lines)
//!
//! Any program can stand in for the built-in detector, for instance a real network on the
//! user's machine (`examples/detector_plugin/torch_detector.py`, a torchvision Faster R-CNN;
//! it is not run by the tests, which have no PyTorch). scene-gen starts the program, writes one
//! request per line on its standard input and closes it; the program writes one response per
//! request, in any order, on its standard output, and exits 0. Standard error is passed
//! through. Requests:
//!
//! ```json
//! {"image_id": 3, "path": "/abs/path/frame_0003.png", "width": 640, "height": 480}
//! ```
//!
//! The image at `path` is the camera's 8-bit image: sRGB for a colour sensor, grey for a
//! monochrome one (or under the `top_bits` output rule).
//!
//! Responses (bbox is `[x, y, width, height]` in pixels from the top-left corner; category ids
//! are scene-gen's COCO ids, 1..=10 objects, 11 threshold; scores in [0, 1]):
//!
//! ```json
//! {"image_id": 3, "detections": [{"category_id": 4, "bbox": [10.5, 20, 31, 40], "score": 0.93}]}
//! ```
//!
//! A missing response for a requested image, an unknown image id, or a line that is not valid
//! JSON is an error naming the line. `examples/detector_plugin/oracle_detector.py` answers with
//! the boxes of a COCO ground-truth file; `tests/interop/check_coco.sh` runs it through
//! [`plugin::run`] and checks that the round trip scores AP = 1.

pub mod cnn;
pub mod coco_eval;
pub mod detectability;
pub mod ground_truth;
pub mod output_noise;
pub mod plugin;
pub mod thresholds;

pub use coco_eval::{CocoGroundTruth, CocoMetrics, DetectionRecord, GtAnnotation, evaluate};
pub use detectability::{DetectabilityModel, Detector, DetectorInput, NoiseSource};
pub use ground_truth::{GroundTruthConfig, GtObject, frame_ground_truth};

/// A detection in one image, before it is given an image id.
#[derive(Clone, Debug, PartialEq)]
pub struct Detection {
    pub category_id: u32,
    /// `[x, y, width, height]`, pixels from the top-left corner.
    pub bbox: [f64; 4],
    pub score: f64,
}

impl Detection {
    /// The COCO results-file record of this detection on `image_id`.
    #[must_use]
    pub fn record(&self, image_id: u64) -> DetectionRecord {
        DetectionRecord { image_id, category_id: self.category_id, bbox: self.bbox, score: self.score }
    }
}
