//! Helpers shared by the integration tests (each test file includes this with `mod common;`).
// Each test file uses only some of these helpers.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository's test data folder (`data/`, see its README for sources and licences).
pub fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
}

/// Runs the `scene-gen` binary built for the tests.
pub fn scene_gen(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_scene-gen")).args(args).output().expect("scene-gen runs")
}

/// An empty-to-be scratch path in the temp folder, unique to this test binary and process
/// (removed if a previous run left it).
pub fn scratch(name: &str) -> PathBuf {
    let crate_name = env!("CARGO_CRATE_NAME");
    let dir = std::env::temp_dir().join(format!("scene-gen-{crate_name}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}
