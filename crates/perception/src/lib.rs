//! What a robot's software does with the frames: the tasks a camera is scored on.
//!
//! * [`orb`]: OpenCV-compatible ORB features, cross-checked matching and RANSAC inliers.
//! * [`detection`]: ground truth from instance buffers, the built-in detectability model, a
//!   learned detector and its trainer, the plug-in protocol for other detectors, COCO evaluation (pycocotools-exact AP) and threshold
//!   visibility.

pub mod detection;
pub mod orb;
