//! `Camera`: a candidate camera (sensor, lens, mounting) as the command line's `--camera`
//! takes it.

use pyo3::prelude::*;
use scene_gen::camera_spec::{CameraSpec, ResolvedCamera};
use scene_gen::sensor::Catalog;

use crate::{bad_input, failure};

/// A camera candidate: its spec, checked against the sensor catalog.
#[pyclass(frozen, module = "scene_gen._native")]
#[derive(Clone, Debug)]
pub struct Camera {
    pub spec: CameraSpec,
}

#[pymethods]
impl Camera {
    /// `SENSOR[,key=value...]` or the path of a camera TOML file.
    #[new]
    fn new(text: &str) -> PyResult<Camera> {
        let spec = CameraSpec::from_arg(text).map_err(bad_input)?;
        Camera::checked(spec)
    }

    /// A spec given as JSON (the fields of a camera TOML file).
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Camera> {
        let spec: CameraSpec = serde_json::from_str(text).map_err(|e| bad_input(format!("camera: {e}")))?;
        spec.validate().map_err(bad_input)?;
        Camera::checked(spec)
    }

    /// The spec with every default filled in, as JSON.
    fn spec_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.spec).map_err(failure)
    }

    /// The sensor's catalog model name.
    #[getter]
    fn sensor(&self) -> PyResult<String> {
        Ok(self.resolved(None)?.sensor.model)
    }

    /// The simulated image size (width, height) in pixels, binned to at most `max_width`.
    #[pyo3(signature = (max_width=None))]
    fn resolution(&self, max_width: Option<u32>) -> PyResult<(u32, u32)> {
        let r = self.resolved(max_width)?;
        Ok((r.width_px, r.height_px))
    }

    fn __repr__(&self) -> String {
        format!("Camera({:?})", self.spec.sensor)
    }
}

impl Camera {
    /// The camera if its sensor is in the catalog.
    fn checked(spec: CameraSpec) -> PyResult<Camera> {
        spec.resolve(&Catalog::embedded()).map_err(bad_input)?;
        Ok(Camera { spec })
    }

    /// The camera resolved against the catalog, binned to at most `max_width` pixels.
    pub fn resolved(&self, max_width: Option<u32>) -> PyResult<ResolvedCamera> {
        let mut spec = self.spec.clone();
        if let Some(m) = max_width {
            if m == 0 {
                return Err(bad_input("max_width must be at least 1"));
            }
            spec.max_width_px = Some(m);
        }
        spec.resolve(&Catalog::embedded()).map_err(bad_input)
    }

    /// The spec binned to at most `max_width` pixels (checked as [`Camera::resolved`]).
    pub fn spec_binned(&self, max_width: Option<u32>) -> PyResult<CameraSpec> {
        self.resolved(max_width)?;
        Ok(CameraSpec { max_width_px: max_width.or(self.spec.max_width_px), ..self.spec.clone() })
    }
}
