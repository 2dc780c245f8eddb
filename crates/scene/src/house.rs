//! A seeded house with the agent's walk through it: where `evaluate`, `dataset` and `render`
//! all start, so they build the same house and walk for the same seed and fail with the same
//! words.

use crate::config::GeneratorConfig;
use crate::generate::generate;
use crate::library::Library;
use crate::scene::Scene;
use crate::trajectory::{self, Trajectory, TrajectoryError, TrajectoryParams};

/// The house of one seed (default generator settings) and the agent's walk through it.
#[derive(Debug)]
pub struct WalkedHouse {
    pub scene: Scene,
    pub walk: Trajectory,
}

/// Why a house or its walk could not be made.
#[derive(Debug, thiserror::Error)]
pub enum HouseError {
    #[error("libraries: {0}")]
    Library(String),
    #[error("house of seed {seed}: {why}")]
    Generate { seed: u64, why: String },
    #[error("walk in house {seed}: {source}")]
    Trajectory {
        seed: u64,
        #[source]
        source: TrajectoryError,
    },
}

/// The embedded room and furniture libraries, with the error callers report.
///
/// # Errors
/// [`HouseError::Library`] when an embedded library does not load (a build defect).
pub fn embedded_library() -> Result<Library, HouseError> {
    Library::embedded().map_err(|e| HouseError::Library(e.to_string()))
}

/// Generates the house of `seed` and plans the walk with `params`.
///
/// # Errors
/// [`HouseError::Generate`] or [`HouseError::Trajectory`], naming the seed.
pub fn walked_house(library: &Library, seed: u64, params: &TrajectoryParams) -> Result<WalkedHouse, HouseError> {
    let scene = generate(&GeneratorConfig { seed, ..GeneratorConfig::default() }, library)
        .map_err(|e| HouseError::Generate { seed, why: e.to_string() })?;
    let walk = trajectory::plan(&scene, params).map_err(|source| HouseError::Trajectory { seed, source })?;
    Ok(WalkedHouse { scene, walk })
}
