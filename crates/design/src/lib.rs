//! Cameras judged and searched: the last stage of scene-gen.
//!
//! * [`evaluate`]: a camera candidate's task scores (threshold accuracy, AP@0.5, ORB inliers)
//!   and fitness by day and by night over seeded houses (`scene-gen evaluate`), cached per
//!   process.
//! * [`optimize`]: the genetic algorithm of the reference system and a random-search baseline
//!   over camera genes (`scene-gen optimize`), resumable; [`plot`] draws its training curve.
//! * [`serve`]: the evaluator as a JSON-lines server any optimizer can drive (`scene-gen serve`).
//! * [`true_matches`]: which ORB matches between two rendered frames the ground truth confirms.
//! * [`dataset`]: COCO datasets (images, depth, instance masks, RLE annotations) over seed
//!   ranges, resumable and sharded across machines (`scene-gen dataset`).

pub mod dataset;
pub mod evaluate;
pub mod optimize;
pub mod plot;
pub mod progress;
pub mod serve;
pub mod true_matches;
