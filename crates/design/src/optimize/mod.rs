//! The camera-design optimizer (`scene-gen optimize`): the TaCOS genetic algorithm and a
//! random-search baseline at equal budget, over a sensor, a lens, a pitch and optionally the
//! mounting height, gains and exposure.
//!
//! * [`config`]: the TOML configuration over the embedded `optimize.toml` defaults.
//! * [`genes`]: genomes, ranges, clipping, the sensor index in area order, decoding to a
//!   [`CameraSpec`].
//! * [`ga`]: selection, elites, uniform crossover, mutation.
//! * [`random`]: the uniform random-search baseline.
//! * [`run`]: the run directory (CSV, state for resume, best camera, training curve).
//!
//! The fitness is pluggable ([`Objective`]): the evaluator ([`EvalObjective`]) in real runs,
//! any function of the genome in tests, or an outside driver's answers.

pub mod config;
pub mod ga;
pub mod genes;
pub mod random;
pub mod run;

use serde::{Deserialize, Serialize};

use crate::evaluate::{EvalConfig, EvalError, evaluate};
use config::{FitnessChoice, OptimizeConfig};
use genes::Genome;
use scene_gen_camera::camera_spec::CameraSpec;

/// A candidate's scores: the fitness the optimizer maximises, and the day and night fitness
/// it was made from (equal to it for objectives without scenarios).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Score {
    pub day: f64,
    pub night: f64,
    pub fitness: f64,
}

/// What the optimizer maximises.
pub trait Objective {
    /// Scores one candidate, given as its genome and the camera spec it decodes to.
    ///
    /// # Errors
    /// Any failure of the scoring; the run stops (and can be resumed).
    fn score(&mut self, genome: &Genome, spec: &CameraSpec) -> Result<Score, ObjectiveError>;

    /// Scores the candidates of one generation that need scoring, in order. The run hands a
    /// generation over at once so that an objective can score its candidates side by side, on
    /// other processes or machines (the Python package's Ray driver does); the default scores
    /// them one after another. The scores must be what [`Objective::score`] would give, so a
    /// run's files do not depend on how its candidates were scored.
    ///
    /// # Errors
    /// Any failure of the scoring; nothing of the batch is recorded.
    fn score_batch(&mut self, batch: &[(Genome, CameraSpec)]) -> Result<Vec<Score>, ObjectiveError> {
        batch.iter().map(|(genome, spec)| self.score(genome, spec)).collect()
    }
}

impl<F> Objective for F
where
    F: FnMut(&Genome, &CameraSpec) -> Result<Score, ObjectiveError>,
{
    fn score(&mut self, genome: &Genome, spec: &CameraSpec) -> Result<Score, ObjectiveError> {
        self(genome, spec)
    }
}

/// A scoring failure.
#[derive(Debug, thiserror::Error)]
pub enum ObjectiveError {
    #[error("evaluating {camera}: {source}")]
    Eval {
        camera: String,
        #[source]
        source: EvalError,
    },
    #[error("{0}")]
    Other(String),
}

/// The evaluator as an objective: `scene-gen evaluate` on the configured seeds and settings.
#[derive(Clone, Debug)]
pub struct EvalObjective {
    pub seeds: Vec<u64>,
    pub config: EvalConfig,
    pub fitness: FitnessChoice,
}

impl EvalObjective {
    /// The objective of an optimizer configuration.
    #[must_use]
    pub fn new(config: &OptimizeConfig) -> EvalObjective {
        EvalObjective {
            seeds: config.evaluation.seeds.clone(),
            config: config.eval_config(),
            fitness: config.evaluation.fitness,
        }
    }
}

impl EvalObjective {
    /// The score of the candidate `spec` (its genome does not matter to the evaluator).
    ///
    /// # Errors
    /// [`ObjectiveError::Eval`] naming the camera.
    pub fn score_spec(&self, spec: &CameraSpec) -> Result<Score, ObjectiveError> {
        let e = evaluate(spec, &self.seeds, &self.config)
            .map_err(|source| ObjectiveError::Eval { camera: spec.sensor.clone(), source })?;
        let fitness = match self.fitness {
            FitnessChoice::Mean => e.fitness.mean,
            FitnessChoice::Day => e.fitness.day,
            FitnessChoice::Night => e.fitness.night,
        };
        Ok(Score { day: e.fitness.day, night: e.fitness.night, fitness })
    }
}

impl Objective for EvalObjective {
    fn score(&mut self, _genome: &Genome, spec: &CameraSpec) -> Result<Score, ObjectiveError> {
        self.score_spec(spec)
    }
}
