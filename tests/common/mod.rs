//! Helpers shared by the integration tests (each test file includes this with `mod common;`).
// Each test file uses only some of these helpers.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The shared data folder: `$SCENE_GEN_DATA`, else `shared/data` beside the repository (CI
/// layout) or one level further up (a worktree under `wt/`).
pub fn data_dir() -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut candidates: Vec<PathBuf> = std::env::var_os("SCENE_GEN_DATA").map(PathBuf::from).into_iter().collect();
    candidates.push(manifest.join("../shared/data"));
    candidates.push(manifest.join("../../shared/data"));
    candidates.iter().find(|p| p.join("emva1288-set003-crop").is_dir()).cloned().unwrap_or_else(|| {
        panic!(
            "EMVA 1288 data set 003 not found: looked for emva1288-set003-crop/ in {candidates:?}; \
             clone the shared/ folder beside the repository or set SCENE_GEN_DATA"
        )
    })
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
