//! glTF 2.0 export (binary `.glb` or `.gltf` + `.bin` + textures).
//!
//! STUB: the glTF work replaces this.

use crate::scene::Scene;

/// Encodes `scene` as a GLB file.
#[must_use]
pub fn to_glb(_scene: &Scene) -> Vec<u8> {
    Vec::new()
}
