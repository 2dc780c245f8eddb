//! `evaluate`: a camera's perception scores and fitness by day and night.

use std::path::PathBuf;

use pyo3::prelude::*;
use scene_gen::evaluate::{DetectorChoice, EvalConfig, FrameWidth, evaluate_with_progress};

use crate::camera::Camera;
use crate::progress::Callback;
use crate::{bad_input, failure, house};

/// A frame width as Python gives it: a number of pixels or the word `"native"`.
#[derive(FromPyObject)]
pub enum WidthArg {
    Px(i64),
    Word(String),
}

impl WidthArg {
    /// The width this argument names ([`FrameWidth::parse`]).
    fn frame_width(&self) -> PyResult<FrameWidth> {
        let parsed = match self {
            WidthArg::Px(px) => FrameWidth::parse(&px.to_string()),
            WidthArg::Word(word) => FrameWidth::parse(word),
        };
        parsed.map_err(|e| bad_input(format!("max_width: {e}")))
    }
}

/// Evaluates `camera` on the houses of `seeds` as `scene-gen evaluate --json` does; returns the
/// evaluation as JSON. The GIL is released while Rust works.
#[pyfunction]
#[pyo3(signature = (camera, seeds, frames=None, max_width=None, detector=None, envelope=None, min_room=None, rooms=None, furniture=None, progress=None))]
#[allow(clippy::too_many_arguments)] // The keyword arguments of the Python call.
pub fn evaluate(
    py: Python<'_>,
    camera: &Camera,
    seeds: Vec<u64>,
    frames: Option<u32>,
    max_width: Option<WidthArg>,
    detector: Option<&str>,
    envelope: Option<&str>,
    min_room: Option<f32>,
    rooms: Option<PathBuf>,
    furniture: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let defaults = EvalConfig::default();
    if frames == Some(0) {
        return Err(bad_input("frames must be at least 1"));
    }
    let max_width = max_width.as_ref().map(WidthArg::frame_width).transpose()?;
    let detector = match detector {
        None => DetectorChoice::default(),
        Some(text) => DetectorChoice::parse(text).ok_or_else(|| bad_input("detector: the command is empty"))?,
    };
    let house = house::checked_options(envelope, min_room, rooms, furniture)?;
    let config = EvalConfig {
        frames_per_scene: frames.unwrap_or(defaults.frames_per_scene),
        max_width_px: max_width.unwrap_or(defaults.max_width_px),
        detector,
        house,
        ..defaults
    };
    let callback = Callback::new(progress, 0);
    let evaluation = py.detach(|| evaluate_with_progress(&camera.spec, &seeds, &config, &callback));
    callback.finish()?;
    let mut evaluation = evaluation.map_err(|e| if e.is_bad_input() { bad_input(e) } else { failure(e) })?;
    // The time breakdown is not deterministic; the command line prints it only on request.
    evaluation.timing_s = None;
    serde_json::to_string(&evaluation).map_err(failure)
}
