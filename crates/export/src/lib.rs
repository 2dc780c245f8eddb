//! Writers for generated scenes: glTF/GLB, USD (through usd-core), OBJ, the plan picture, and
//! atomic file output.

pub mod gltf;
pub mod obj;
pub mod plan;
pub mod usd;

pub use scene_gen_core::io::{WriteError, write_atomic};
