//! The run directory: it holds everything a run has done, so a run resumes where it stopped.
//!
//! Files (each written atomically):
//! * `state.json`: the method, the configuration and every scored candidate so far, saved
//!   after each evaluation. A generation is a pure function of the previous one and a seeded
//!   stream, so this is all a resume needs: finished candidates are never evaluated again.
//! * `candidates.csv`: every candidate of every finished generation: generation, index,
//!   origin, sensor, each gene, day/night fitness, fitness.
//! * `generations.csv`: per generation its evaluations so far, best, mean and best so far.
//! * `best_camera.toml`: the best candidate so far as a camera spec (`scene-gen evaluate
//!   --camera`, `scene-gen render --camera`).
//! * `curve.png`: best and mean fitness per generation.
//!
//! Outputs are rewritten from the state after each generation; none holds a time or a path,
//! so an interrupted and resumed run ends with the same bytes as an uninterrupted one.
//! Only `ga.generations` may differ between a run directory and the configuration that
//! continues it: a longer run extends a shorter one.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::config::OptimizeConfig;
use super::ga::{Origin, next_generation};
use super::genes::{Genome, Space};
use super::{Objective, ObjectiveError, Score, random};
use crate::plot::{Series, line_chart, to_png};
use scene_gen_camera::camera_spec::CameraSpec;
use scene_gen_camera::sensor::Catalog;
use scene_gen_core::io::{WriteError, write_atomic};
use scene_gen_core::rng::substream;

/// Schema tag of `state.json`.
pub const STATE_SCHEMA: &str = "scene-gen/optimize-state/1";

/// The search method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    Ga,
    Random,
}

impl Method {
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Method::Ga => "ga",
            Method::Random => "random",
        }
    }
}

/// One scored candidate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    pub generation: usize,
    pub index: usize,
    pub origin: Origin,
    pub genome: Genome,
    pub score: Score,
}

/// `state.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct State {
    pub schema: String,
    pub method: Method,
    pub config: OptimizeConfig,
    pub candidates: Vec<Candidate>,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(
        "{} holds a run with a different configuration or method ({what}); use another --out \
         folder, or the same configuration (only ga.generations may change)",
        dir.display()
    )]
    Mismatch { dir: PathBuf, what: String },
    #[error("{} holds {done} generations, more than the configuration's {asked}", dir.display())]
    TooManyGenerations { dir: PathBuf, done: usize, asked: usize },
    #[error("{}: not a readable optimizer state: {why}", path.display())]
    BadState { path: PathBuf, why: String },
    #[error("cannot create {}: {source}", path.display())]
    CreateDir {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Write(#[from] WriteError),
    #[error(transparent)]
    Objective(#[from] ObjectiveError),
    #[error("candidate {generation}/{index} scored a non-finite fitness ({fitness})")]
    NonFinite { generation: usize, index: usize, fitness: f64 },
}

impl RunError {
    /// Whether the user's input (the folder, its state) is at fault rather than the work.
    #[must_use]
    pub fn is_bad_input(&self) -> bool {
        matches!(self, RunError::Mismatch { .. } | RunError::TooManyGenerations { .. } | RunError::BadState { .. })
    }
}

/// Progress after each candidate.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// Evaluations done (including those of an earlier run this one resumed).
    pub evaluations: usize,
    /// Evaluations of the whole run.
    pub budget: usize,
    pub generation: usize,
    /// Best fitness so far.
    pub best: f64,
}

/// Options of [`run`] beyond the configuration.
#[derive(Default)]
#[allow(missing_debug_implementations)] // A callback has nothing to show.
pub struct RunOptions<'a> {
    /// Stop (as an interruption would) after this many evaluations in this call.
    pub stop_after: Option<usize>,
    /// Called after every candidate.
    pub progress: Option<&'a mut dyn FnMut(Progress)>,
}

/// What a call of [`run`] did.
#[derive(Clone, Debug)]
pub struct RunSummary {
    /// Whether every generation is done (false: stopped by `stop_after`).
    pub complete: bool,
    /// Evaluations done in this call.
    pub evaluated_now: usize,
    /// Evaluations of the run so far.
    pub evaluations: usize,
    /// The best candidate so far.
    pub best: Option<Candidate>,
    pub best_camera: Option<CameraSpec>,
}

/// The part of the configuration a run directory must agree on: everything but
/// `ga.generations`, plus the method.
fn compatibility_key(method: Method, config: &OptimizeConfig) -> serde_json::Value {
    let mut c = config.clone();
    c.ga.generations = 0;
    serde_json::json!({ "method": method, "config": c })
}

/// Top-level keys where two JSON values differ (for the mismatch message).
fn differing_keys(a: &serde_json::Value, b: &serde_json::Value, prefix: &str, out: &mut Vec<String>) {
    match (a, b) {
        (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            for k in keys {
                let name = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                match (x.get(k), y.get(k)) {
                    (Some(p), Some(q)) => differing_keys(p, q, &name, out),
                    _ => out.push(name),
                }
            }
        }
        _ if a != b => out.push(prefix.to_string()),
        _ => {}
    }
}

/// Reads `dir/state.json` when there is one.
///
/// # Errors
/// [`RunError::BadState`] when it cannot be read or parsed.
pub fn load_state(dir: &Path) -> Result<Option<State>, RunError> {
    let path = dir.join("state.json");
    if !path.exists() {
        return Ok(None);
    }
    let bad = |why: String| RunError::BadState { path: path.clone(), why };
    let text = std::fs::read_to_string(&path).map_err(|e| bad(e.to_string()))?;
    let state: State = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    if state.schema != STATE_SCHEMA {
        return Err(bad(format!("schema '{}', expected '{STATE_SCHEMA}'", state.schema)));
    }
    Ok(Some(state))
}

/// Checks that a run in `dir` (if any) can be continued by `config` and `method`, without
/// writing anything.
///
/// # Errors
/// [`RunError::Mismatch`], [`RunError::TooManyGenerations`] or [`RunError::BadState`].
pub fn check_dir(dir: &Path, method: Method, config: &OptimizeConfig) -> Result<Option<State>, RunError> {
    let Some(state) = load_state(dir)? else { return Ok(None) };
    let (old, new) = (compatibility_key(state.method, &state.config), compatibility_key(method, config));
    if old != new {
        let mut keys = Vec::new();
        differing_keys(&old, &new, "", &mut keys);
        return Err(RunError::Mismatch { dir: dir.to_path_buf(), what: format!("differs in {}", keys.join(", ")) });
    }
    let done = state.candidates.iter().map(|c| c.generation + 1).max().unwrap_or(0);
    if done > config.ga.generations {
        return Err(RunError::TooManyGenerations { dir: dir.to_path_buf(), done, asked: config.ga.generations });
    }
    Ok(Some(state))
}

/// The genomes of generation `g`, from the scored generation `g - 1`.
fn propose(
    space: &Space,
    method: Method,
    config: &OptimizeConfig,
    g: usize,
    previous: &[Candidate],
) -> Vec<(Genome, Origin)> {
    match method {
        Method::Random => random::generation(space, config, g),
        Method::Ga if g == 0 => random::initial(space, config),
        Method::Ga => {
            let scored: Vec<(Genome, f64)> = previous.iter().map(|c| (c.genome.clone(), c.score.fitness)).collect();
            let mut rng = substream(config.seed, "optimize/ga", g as u64);
            next_generation(space, &config.ga, &scored, &mut rng)
        }
    }
}

/// Runs (or resumes) the optimization of `config` with `method` in `dir`, scoring candidates
/// with `objective`.
///
/// # Errors
/// [`RunError`]: an incompatible folder, a write failure or a scoring failure (the state
/// saved so far stays, so the run can be resumed).
pub fn run(
    dir: &Path,
    method: Method,
    config: &OptimizeConfig,
    objective: &mut dyn Objective,
    mut options: RunOptions<'_>,
) -> Result<RunSummary, RunError> {
    let previous = check_dir(dir, method, config)?;
    std::fs::create_dir_all(dir).map_err(|source| RunError::CreateDir { path: dir.to_path_buf(), source })?;
    let space = Space::new(config, &Catalog::embedded());
    let mut state = State {
        schema: STATE_SCHEMA.to_string(),
        method,
        config: config.clone(),
        candidates: previous.map(|s| s.candidates).unwrap_or_default(),
    };
    let budget = config.budget();
    let mut evaluated_now = 0;
    let evaluations = |s: &State| s.candidates.iter().filter(|c| c.origin.evaluated()).count();
    for g in 0..config.ga.generations {
        let prev: Vec<Candidate> = state.candidates.iter().filter(|c| c.generation + 1 == g).cloned().collect();
        let proposals = propose(&space, method, config, g, &prev);
        let mut recorded = vec![false; proposals.len()];
        for done in state.candidates.iter().filter(|c| c.generation == g) {
            match proposals.get(done.index) {
                Some((genome, origin)) if done.genome == *genome && done.origin == *origin => {
                    recorded[done.index] = true;
                }
                _ => {
                    return Err(RunError::BadState {
                        path: dir.join("state.json"),
                        why: format!("candidate {g}/{} differs from what this configuration proposes", done.index),
                    });
                }
            }
        }
        // The generation's candidates still to score, up to what `stop_after` allows, in one batch.
        let allowance = options.stop_after.map_or(usize::MAX, |n| n.saturating_sub(evaluated_now));
        let to_score: Vec<usize> =
            (0..proposals.len()).filter(|&i| proposals[i].1.evaluated() && !recorded[i]).take(allowance).collect();
        let batch: Vec<(Genome, CameraSpec)> =
            to_score.iter().map(|&i| (proposals[i].0.clone(), space.decode(&proposals[i].0))).collect();
        let scores = if batch.is_empty() { Vec::new() } else { objective.score_batch(&batch)? };
        if scores.len() != batch.len() {
            return Err(RunError::Objective(ObjectiveError::Other(format!(
                "the objective scored {} of the {} candidates of generation {g}",
                scores.len(),
                batch.len()
            ))));
        }
        for (index, (genome, origin)) in proposals.into_iter().enumerate() {
            if recorded[index] {
                continue;
            }
            let score = if origin.evaluated() {
                let Some(k) = to_score.iter().position(|&i| i == index) else {
                    // Past what `stop_after` allows: stop as an interruption would.
                    write_outputs(dir, &space, &state)?;
                    return Ok(summary(&space, &state, false, evaluated_now));
                };
                let score = scores[k];
                if !score.fitness.is_finite() || !score.day.is_finite() || !score.night.is_finite() {
                    return Err(RunError::NonFinite { generation: g, index, fitness: score.fitness });
                }
                evaluated_now += 1;
                score
            } else {
                // An elite keeps the score it had in the previous generation.
                prev.iter().find(|c| c.genome == genome).map(|c| c.score).unwrap_or(Score {
                    day: f64::NAN,
                    night: f64::NAN,
                    fitness: f64::NAN,
                })
            };
            state.candidates.push(Candidate { generation: g, index, origin, genome, score });
            write_atomic(&dir.join("state.json"), &state_json(&state))?;
            if let Some(report) = options.progress.as_mut() {
                let best = best(&state).map_or(f64::NAN, |c| c.score.fitness);
                report(Progress { evaluations: evaluations(&state), budget, generation: g, best });
            }
        }
        write_outputs(dir, &space, &state)?;
    }
    // A run that was already complete still gets its outputs (re)written from the state.
    write_atomic(&dir.join("state.json"), &state_json(&state))?;
    write_outputs(dir, &space, &state)?;
    Ok(summary(&space, &state, true, evaluated_now))
}

fn summary(space: &Space, state: &State, complete: bool, evaluated_now: usize) -> RunSummary {
    let best = best(state).cloned();
    RunSummary {
        complete,
        evaluated_now,
        evaluations: state.candidates.iter().filter(|c| c.origin.evaluated()).count(),
        best_camera: best.as_ref().map(|c| space.decode(&c.genome)),
        best,
    }
}

fn state_json(state: &State) -> Vec<u8> {
    let mut v = serde_json::to_vec_pretty(state).unwrap_or_default();
    v.push(b'\n');
    v
}

/// The first candidate with the highest fitness.
fn best(state: &State) -> Option<&Candidate> {
    state.candidates.iter().fold(None, |b: Option<&Candidate>, c| match b {
        Some(b) if b.score.fitness >= c.score.fitness => Some(b),
        _ => Some(c),
    })
}

/// One finished generation: (generation, evaluations so far, best, mean, best so far).
pub type GenerationStats = (usize, usize, f64, f64, f64);

/// Per finished generation, its [`GenerationStats`].
#[must_use]
pub fn generation_stats(state: &State) -> Vec<GenerationStats> {
    let population = state.config.ga.population;
    let mut out = Vec::new();
    let (mut evaluations, mut best_so_far) = (0, f64::NEG_INFINITY);
    for g in 0.. {
        let members: Vec<&Candidate> = state.candidates.iter().filter(|c| c.generation == g).collect();
        let size = if state.method == Method::Random { random::batch_size(&state.config, g) } else { population };
        if members.is_empty() || members.len() < size {
            break;
        }
        evaluations += members.iter().filter(|c| c.origin.evaluated()).count();
        let best = members.iter().map(|c| c.score.fitness).fold(f64::NEG_INFINITY, f64::max);
        let mean = members.iter().map(|c| c.score.fitness).sum::<f64>() / members.len() as f64;
        best_so_far = best_so_far.max(best);
        out.push((g, evaluations, best, mean, best_so_far));
    }
    out
}

/// Rewrites the CSVs, the best camera and the curve from `state` (finished generations).
fn write_outputs(dir: &Path, space: &Space, state: &State) -> Result<(), WriteError> {
    let stats = generation_stats(state);
    let finished = stats.len();
    let mut csv = String::from("generation,index,origin,sensor_index,sensor");
    for g in &space.genes {
        let _ = write!(csv, ",{}", g.name);
    }
    csv.push_str(",fitness_day,fitness_night,fitness\n");
    for c in state.candidates.iter().filter(|c| c.generation < finished) {
        let _ = write!(
            csv,
            "{},{},{},{},{}",
            c.generation,
            c.index,
            c.origin.as_str(),
            c.genome.sensor,
            space.sensors[c.genome.sensor.min(space.sensors.len() - 1)]
        );
        for (g, &x) in space.genes.iter().zip(&c.genome.values) {
            let _ = write!(csv, ",{}", g.format(x));
        }
        let _ = writeln!(csv, ",{},{},{}", c.score.day, c.score.night, c.score.fitness);
    }
    write_atomic(&dir.join("candidates.csv"), csv.as_bytes())?;

    let mut gens = String::from("generation,evaluations,best,mean,best_so_far\n");
    for &(g, n, b, m, s) in &stats {
        let _ = writeln!(gens, "{g},{n},{b},{m},{s}");
    }
    write_atomic(&dir.join("generations.csv"), gens.as_bytes())?;

    let done = State {
        candidates: state.candidates.iter().filter(|c| c.generation < finished).cloned().collect(),
        ..state.clone()
    };
    if let Some(b) = best(&done) {
        let spec = space.decode(&b.genome);
        let body = toml::to_string(&spec).unwrap_or_default();
        let text = format!(
            "# Best camera of `scene-gen optimize` ({}): fitness {} (day {}, night {}),\n\
             # generation {}, candidate {}.\n{body}",
            state.method.as_str(),
            b.score.fitness,
            b.score.day,
            b.score.night,
            b.generation,
            b.index
        );
        write_atomic(&dir.join("best_camera.toml"), text.as_bytes())?;
    }

    let series = vec![
        Series {
            label: "best".into(),
            color: [200, 40, 40],
            points: stats.iter().map(|s| (s.0 as f64, s.2)).collect(),
        },
        Series {
            label: "mean".into(),
            color: [40, 80, 200],
            points: stats.iter().map(|s| (s.0 as f64, s.3)).collect(),
        },
    ];
    let title = format!("{} fitness per generation", state.method.as_str());
    write_atomic(&dir.join("curve.png"), &to_png(&line_chart(&title, &series, 640, 400)))?;
    Ok(())
}

/// Reads a `generations.csv` back: (generation, evaluations, best, mean, best so far).
///
/// # Errors
/// A message naming the line that does not parse.
pub fn read_generations_csv(text: &str) -> Result<Vec<GenerationStats>, String> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let bad = || format!("line {}: '{line}' is not generation,evaluations,best,mean,best_so_far", i + 1);
        if f.len() != 5 {
            return Err(bad());
        }
        out.push((
            f[0].parse().map_err(|_| bad())?,
            f[1].parse().map_err(|_| bad())?,
            f[2].parse().map_err(|_| bad())?,
            f[3].parse().map_err(|_| bad())?,
            f[4].parse().map_err(|_| bad())?,
        ));
    }
    Ok(out)
}
