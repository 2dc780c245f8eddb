//! Writers for generated scenes: glTF/GLB, USD (through usd-core), OBJ, the plan picture, and
//! atomic file output.

pub mod gltf;
pub mod obj;
pub mod plan;
pub mod usd;

use std::path::Path;

use scene_gen_scene::manifest::Manifest;
use scene_gen_scene::scene::Scene;
use usd::{UsdError, UsdFormat};

pub use scene_gen_core::io::{WriteError, write_atomic};

/// The scene file formats a house is written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneFormat {
    /// Binary glTF, one file.
    Glb,
    /// glTF JSON with a separate `scene.bin` and `textures/*.png`.
    Gltf,
    /// Wavefront OBJ + MTL + textures, Y up, one object (`o` and `g`) per node.
    Obj,
    /// USD text layer + textures, Z up, metres (needs usd-core).
    Usda,
    /// USD binary (crate) layer + textures (needs usd-core).
    Usdc,
}

impl std::str::FromStr for SceneFormat {
    type Err = String;

    fn from_str(text: &str) -> Result<SceneFormat, String> {
        match text.to_ascii_lowercase().as_str() {
            "glb" => Ok(SceneFormat::Glb),
            "gltf" => Ok(SceneFormat::Gltf),
            "obj" => Ok(SceneFormat::Obj),
            "usda" | "usd" => Ok(SceneFormat::Usda),
            "usdc" => Ok(SceneFormat::Usdc),
            other => Err(format!("unknown scene format '{other}' (known: glb, gltf, obj, usda, usdc)")),
        }
    }
}

/// Every file of a house written in `format`, named relative to the output folder: the scene
/// file(s), the manifest `scene.json` and the floor plan `plan.png`. Everything is encoded
/// before anything is written, so a failure leaves no partial output. `python` runs the USD
/// writer (usd-core); the other formats ignore it.
///
/// # Errors
/// [`UsdError`] when a USD layer cannot be written.
pub fn scene_files(scene: &Scene, format: SceneFormat, python: &Path) -> Result<Vec<(String, Vec<u8>)>, UsdError> {
    let mut files = match format {
        SceneFormat::Glb => vec![("scene.glb".to_string(), gltf::to_glb(scene))],
        SceneFormat::Gltf => gltf::to_gltf(scene),
        SceneFormat::Obj => obj::to_obj(scene),
        SceneFormat::Usda => usd::to_usd(scene, UsdFormat::Usda, python)?,
        SceneFormat::Usdc => usd::to_usd(scene, UsdFormat::Usdc, python)?,
    };
    files.push(("scene.json".into(), Manifest::of(scene).to_json().into_bytes()));
    files.push(("plan.png".into(), plan::to_png(scene)));
    Ok(files)
}

/// Writes `files` (as [`scene_files`] names them) under `out`, creating folders, each file
/// atomically.
///
/// # Errors
/// [`WriteError`] naming the file or folder that could not be written.
pub fn write_files(out: &Path, files: &[(String, Vec<u8>)]) -> Result<(), WriteError> {
    for (name, bytes) in files {
        let path = out.join(name);
        let dir = path.parent().unwrap_or(out);
        std::fs::create_dir_all(dir).map_err(|source| WriteError { path: dir.to_path_buf(), source })?;
        write_atomic(&path, bytes)?;
    }
    Ok(())
}
