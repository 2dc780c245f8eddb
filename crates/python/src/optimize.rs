//! `optimize`: the camera-design optimizer, scored here or by a Python callable that scores a
//! generation's candidates wherever it likes (the Ray driver sends them to a cluster).

use std::path::PathBuf;

use pyo3::prelude::*;
use scene_gen::camera_spec::CameraSpec;
use scene_gen::optimize::config::OptimizeConfig;
use scene_gen::optimize::genes::Genome;
use scene_gen::optimize::run::{Method, Progress, RunOptions, run};
use scene_gen::optimize::{EvalObjective, Objective, ObjectiveError, Score};

use crate::{bad_input, failure, house};

/// The configuration of a run: the TOML file at `config` (default: the embedded
/// optimize.toml) with the house options given over its `[house]`, checked; as JSON.
#[pyfunction]
#[pyo3(signature = (config=None, envelope=None, min_room=None, rooms=None, furniture=None))]
pub fn optimize_config(
    config: Option<PathBuf>,
    envelope: Option<&str>,
    min_room: Option<f32>,
    rooms: Option<PathBuf>,
    furniture: Option<PathBuf>,
) -> PyResult<String> {
    let mut config = match &config {
        Some(path) => OptimizeConfig::from_file(path).map_err(bad_input)?,
        None => OptimizeConfig::default(),
    };
    config.house = house::options_over(config.house, envelope, min_room, rooms, furniture)?;
    config.house.library().map_err(bad_input)?;
    serde_json::to_string(&config).map_err(failure)
}

fn parse_config(config_json: &str) -> PyResult<OptimizeConfig> {
    let config: OptimizeConfig =
        serde_json::from_str(config_json).map_err(|e| bad_input(format!("optimizer configuration: {e}")))?;
    config.validate().map_err(|(field, why)| bad_input(format!("optimizer configuration: {field}: {why}")))?;
    Ok(config)
}

fn method(name: &str) -> PyResult<Method> {
    match name {
        "ga" => Ok(Method::Ga),
        "random" => Ok(Method::Random),
        other => Err(bad_input(format!("method '{other}': expected 'ga' or 'random'"))),
    }
}

/// Scores candidates given as camera-spec JSON with the evaluator, as `scene-gen optimize`
/// would in this configuration; returns `(day, night, fitness)` per candidate. This is what a
/// worker of a distributed run calls.
#[pyfunction]
pub fn score_candidates(py: Python<'_>, config_json: &str, specs_json: Vec<String>) -> PyResult<Vec<(f64, f64, f64)>> {
    let config = parse_config(config_json)?;
    let specs = specs_json
        .iter()
        .map(|s| serde_json::from_str::<CameraSpec>(s).map_err(|e| bad_input(format!("candidate: {e}"))))
        .collect::<PyResult<Vec<_>>>()?;
    let objective = EvalObjective::new(&config);
    let scores = py.detach(|| specs.iter().map(|spec| objective.score_spec(spec)).collect::<Result<Vec<Score>, _>>());
    Ok(scores.map_err(failure)?.into_iter().map(|s| (s.day, s.night, s.fitness)).collect())
}

/// A Python callable as the objective: given a generation's candidates as camera-spec JSON,
/// it returns their `(day, night, fitness)`.
struct Callable {
    score_batch: Py<PyAny>,
}

impl Objective for Callable {
    fn score(&mut self, genome: &Genome, spec: &CameraSpec) -> Result<Score, ObjectiveError> {
        let batch = [(genome.clone(), spec.clone())];
        self.score_batch(&batch)?.pop().ok_or_else(|| ObjectiveError::Other("no score returned".into()))
    }

    fn score_batch(&mut self, batch: &[(Genome, CameraSpec)]) -> Result<Vec<Score>, ObjectiveError> {
        let specs = batch
            .iter()
            .map(|(_, spec)| serde_json::to_string(spec))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| ObjectiveError::Other(e.to_string()))?;
        let scores: Vec<(f64, f64, f64)> = Python::attach(|py| {
            py.check_signals()?;
            self.score_batch.call1(py, (specs,))?.extract(py)
        })
        .map_err(|e: PyErr| ObjectiveError::Other(format!("score_batch: {e}")))?;
        Ok(scores.into_iter().map(|(day, night, fitness)| Score { day, night, fitness }).collect())
    }
}

/// Runs (or resumes) the optimization of `config_json` with `method` in the folder `out`, as
/// `scene-gen optimize` does; `score_batch` (a callable) scores each generation's candidates
/// instead of this process. Returns the run's summary as JSON.
#[pyfunction]
#[pyo3(signature = (out, config_json, method="ga", score_batch=None, progress=None, stop_after=None))]
pub fn optimize(
    py: Python<'_>,
    out: PathBuf,
    config_json: &str,
    method: &str,
    score_batch: Option<Py<PyAny>>,
    progress: Option<Py<PyAny>>,
    stop_after: Option<usize>,
) -> PyResult<String> {
    let config = parse_config(config_json)?;
    let method = self::method(method)?;
    let mut objective: Box<dyn Objective + Send> = match score_batch {
        Some(score_batch) => Box::new(Callable { score_batch }),
        None => Box::new(EvalObjective::new(&config)),
    };
    let mut callback_error: Option<PyErr> = None;
    let mut report = |p: Progress| {
        let Some(progress) = &progress else { return };
        if callback_error.is_none() {
            let result = Python::attach(|py| progress.call1(py, (p.evaluations, p.budget)).map(drop));
            callback_error = result.err();
        }
    };
    let summary = py.detach(|| {
        let options = RunOptions { stop_after, progress: Some(&mut report) };
        run(&out, method, &config, objective.as_mut(), options)
    });
    if let Some(e) = callback_error {
        return Err(e);
    }
    let summary = summary.map_err(|e| if e.is_bad_input() { bad_input(e) } else { failure(e) })?;
    let best = summary.best.as_ref().map(|c| {
        serde_json::json!({
            "generation": c.generation,
            "index": c.index,
            "day": c.score.day,
            "night": c.score.night,
            "fitness": c.score.fitness,
        })
    });
    let json = serde_json::json!({
        "complete": summary.complete,
        "evaluated_now": summary.evaluated_now,
        "evaluations": summary.evaluations,
        "best": best,
        "best_camera": summary.best_camera,
    });
    Ok(json.to_string())
}
