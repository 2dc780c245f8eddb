//! `scene_gen._native`: the Rust half of the `scene_gen` Python package.
//!
//! The Python half (`python/scene_gen/`) is the public API: it turns the buffers returned here
//! into NumPy arrays and the manifest into Python objects, and carries the docstrings users
//! read. This module keeps to plain values (strings, numbers, lists, dicts, `bytearray`s of
//! little-endian samples) so it needs no NumPy at build time.
//!
//! Every long call releases the GIL while Rust works ([`Python::detach`]), so other Python
//! threads run meanwhile; progress callbacks take the GIL back for each report.
//!
//! Errors: bad input (a camera that does not parse, an unknown sensor, house options that do
//! not fit, a missing library folder) raises `ValueError`; a failure of the work itself raises
//! `RuntimeError`; a file that cannot be written raises `OSError`.

mod camera;
mod dataset;
mod evaluate;
mod frames;
mod house;
mod optimize;
mod progress;

use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

/// Bad input: `ValueError` with the message of `e` and its causes.
fn bad_input(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// A failure of the work: `RuntimeError`.
fn failure(e: impl std::fmt::Display) -> PyErr {
    PyRuntimeError::new_err(e.to_string())
}

/// An output that could not be written: `OSError`.
fn write_error(e: impl std::fmt::Display) -> PyErr {
    PyOSError::new_err(e.to_string())
}

/// The sensor catalog as JSON: one record per sensor (model, maker, resolution, pixel pitch,
/// bit depth, noise figures and their provenance).
#[pyfunction]
fn catalog_json() -> PyResult<String> {
    let catalog = scene_gen::sensor::Catalog::embedded();
    serde_json::to_string(&catalog.records()).map_err(failure)
}

/// The COCO categories of every dataset and evaluation as JSON: ids 1..10 the object classes,
/// 11 the door threshold.
#[pyfunction]
fn categories_json() -> PyResult<String> {
    serde_json::to_string(&scene_gen::dataset::categories()).map_err(failure)
}

/// The seeds of `A..B` (B excluded), `A..=B` or one seed, as the command line reads `--seeds`.
#[pyfunction]
fn seeds(text: &str) -> PyResult<Vec<u64>> {
    let range: scene_gen::seeds::SeedRange = text.parse().map_err(bad_input)?;
    Ok(range.iter().collect())
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<camera::Camera>()?;
    m.add_class::<house::Scene>()?;
    m.add_class::<dataset::Dataset>()?;
    m.add_function(wrap_pyfunction!(house::generate, m)?)?;
    m.add_function(wrap_pyfunction!(frames::render, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(optimize::optimize_config, m)?)?;
    m.add_function(wrap_pyfunction!(optimize::optimize, m)?)?;
    m.add_function(wrap_pyfunction!(optimize::score_candidates, m)?)?;
    m.add_function(wrap_pyfunction!(catalog_json, m)?)?;
    m.add_function(wrap_pyfunction!(categories_json, m)?)?;
    m.add_function(wrap_pyfunction!(seeds, m)?)?;
    Ok(())
}
