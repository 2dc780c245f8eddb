//! What a robot's software does with the frames: the tasks a camera is scored on.
//!
//! * [`orb`]: OpenCV-compatible ORB features, cross-checked matching and RANSAC inliers.
//! * [`detection`]: ground truth from instance buffers, the built-in detectability model, the
//!   plug-in protocol for real detectors, COCO evaluation (pycocotools-exact AP) and threshold
//!   visibility.

pub mod detection;
pub mod orb;
