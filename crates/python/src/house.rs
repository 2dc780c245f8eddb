//! Houses: `generate` and `Scene` (the house, its manifest, its export and its walk).

use std::path::PathBuf;
use std::sync::Arc;

use pyo3::prelude::*;
use scene_gen::export::{SceneFormat, scene_files, write_files};
use scene_gen::generate::generate as generate_house;
use scene_gen::house::HouseOptions;
use scene_gen::manifest::Manifest;
use scene_gen::scene::{Envelope, Scene as House};
use scene_gen::trajectory::{self, TrajectoryParams};

use crate::{bad_input, failure, write_error};

/// The house options of a call over `base` (`None`: the base's value), checked: the envelope
/// and room size fit.
pub fn options_over(
    base: HouseOptions,
    envelope: Option<&str>,
    min_room: Option<f32>,
    rooms: Option<PathBuf>,
    furniture: Option<PathBuf>,
) -> PyResult<HouseOptions> {
    let envelope = match envelope {
        Some(text) => text.parse::<Envelope>().map_err(|e| bad_input(format!("envelope: {e}")))?,
        None => base.envelope,
    };
    let options = HouseOptions {
        envelope,
        min_room_m: min_room.unwrap_or(base.min_room_m),
        rooms: rooms.or(base.rooms),
        furniture: furniture.or(base.furniture),
    };
    options.validate().map_err(bad_input)?;
    Ok(options)
}

/// [`options_over`] the defaults.
pub fn options(
    envelope: Option<&str>,
    min_room: Option<f32>,
    rooms: Option<PathBuf>,
    furniture: Option<PathBuf>,
) -> PyResult<HouseOptions> {
    options_over(HouseOptions::default(), envelope, min_room, rooms, furniture)
}

/// [`options`], and the libraries they name load (so a bad folder is refused before any work).
pub fn checked_options(
    envelope: Option<&str>,
    min_room: Option<f32>,
    rooms: Option<PathBuf>,
    furniture: Option<PathBuf>,
) -> PyResult<HouseOptions> {
    let options = options(envelope, min_room, rooms, furniture)?;
    options.library().map_err(bad_input)?;
    Ok(options)
}

/// A generated house.
#[pyclass(frozen, module = "scene_gen._native")]
#[derive(Clone, Debug)]
pub struct Scene {
    pub house: Arc<House>,
    pub options: HouseOptions,
}

/// Generates the house of `seed` (the GIL is released meanwhile).
#[pyfunction]
#[pyo3(signature = (seed, envelope=None, min_room=None, rooms=None, furniture=None))]
pub fn generate(
    py: Python<'_>,
    seed: u64,
    envelope: Option<&str>,
    min_room: Option<f32>,
    rooms: Option<PathBuf>,
    furniture: Option<PathBuf>,
) -> PyResult<Scene> {
    let options = options(envelope, min_room, rooms, furniture)?;
    let house = py.detach(|| {
        let library = options.library().map_err(|e| e.to_string())?;
        generate_house(&options.config(seed), &library).map_err(|e| e.to_string())
    });
    Ok(Scene { house: Arc::new(house.map_err(bad_input)?), options })
}

#[pymethods]
impl Scene {
    /// The seed the house was generated from.
    #[getter]
    fn seed(&self) -> u64 {
        self.house.seed
    }

    /// The manifest (`scene.json`) as JSON text: rooms, walls, doors, windows, thresholds,
    /// objects and lights with their semantics, and what rebuilds the house.
    fn manifest_json(&self) -> String {
        Manifest::of(&self.house).to_json()
    }

    /// The house options (envelope, smallest room, library folders) as JSON.
    fn options_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.options).map_err(failure)
    }

    /// Writes the house in `format` (glb, gltf, obj, usda, usdc) into the folder `out`, with
    /// `scene.json` and `plan.png`, as `scene-gen --seed N` does; returns the files written.
    /// `python` runs the USD writer (it needs usd-core).
    fn export(&self, py: Python<'_>, out: PathBuf, format: &str, python: PathBuf) -> PyResult<Vec<PathBuf>> {
        let format: SceneFormat = format.parse().map_err(bad_input)?;
        let files = py.detach(|| scene_files(&self.house, format, &python)).map_err(|e| match e {
            scene_gen::export::usd::UsdError::UsdCoreMissing { .. } => bad_input(e),
            other => failure(other),
        })?;
        write_files(&out, &files).map_err(write_error)?;
        Ok(files.iter().map(|(name, _)| out.join(name)).collect())
    }

    /// The agent's walk at camera height `height_m`: poses `(x, y, z, yaw_deg, time_s)` and door
    /// crossings `(threshold_id, pose_index, time_s)`.
    #[pyo3(signature = (height_m=None))]
    #[allow(clippy::type_complexity)] // Plain tuples are what Python receives.
    fn walk(
        &self,
        py: Python<'_>,
        height_m: Option<f32>,
    ) -> PyResult<(Vec<(f32, f32, f32, f32, f32)>, Vec<(u32, usize, f32)>)> {
        let defaults = TrajectoryParams::default();
        let params = TrajectoryParams { height_m: height_m.unwrap_or(defaults.height_m), ..defaults };
        self.house.envelope.check_camera_height(params.height_m).map_err(bad_input)?;
        let walk = py.detach(|| trajectory::plan(&self.house, &params)).map_err(failure)?;
        let poses =
            walk.poses.iter().map(|p| (p.position.x, p.position.y, p.position.z, p.yaw_deg, p.time_s)).collect();
        let crossings = walk.crossings.iter().map(|c| (c.threshold_id, c.pose_index, c.time_s)).collect();
        Ok((poses, crossings))
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene(seed={}, rooms={}, objects={}, thresholds={})",
            self.house.seed,
            self.house.rooms.len(),
            self.house.objects.len(),
            self.house.thresholds.len()
        )
    }
}
