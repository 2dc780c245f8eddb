//! Helpers shared by the integration tests (each test file includes this with `mod common;`).

use std::path::{Path, PathBuf};

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
