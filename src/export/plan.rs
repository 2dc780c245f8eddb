//! `plan.png`: a top-down plan of a scene.
//!
//! STUB: replaced by the plan work.

use crate::scene::Scene;

/// Draws the plan of `scene` and returns it as PNG bytes.
#[must_use]
pub fn to_png(_scene: &Scene) -> Vec<u8> {
    Vec::new()
}
