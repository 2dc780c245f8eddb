//! `scene-gen optimize`: the camera-design optimizer ([`scene_gen::optimize`]).

use std::path::PathBuf;

use anyhow::anyhow;
use clap::{Args, ValueEnum};
use scene_gen::evaluate::DetectorChoice;
use scene_gen::optimize::config::OptimizeConfig;
use scene_gen::optimize::run::{Method, Progress as OptimizeProgress, RunOptions, check_dir, run as run_dir};
use scene_gen::optimize::{EvalObjective, Objective};

use super::house::{HouseArgs, check};
use super::progress::Progress;
use super::{CliError, bad_input, failure};

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum MethodArg {
    /// The TaCOS genetic algorithm.
    Ga,
    /// Uniform random search with the GA's evaluation budget.
    Random,
}

#[derive(Args, Debug)]
pub struct OptimizeArgs {
    /// Configuration TOML read over the defaults (the repository's optimize.toml documents
    /// every key); without it, the defaults.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Run directory; a directory holding an unfinished run of the same configuration resumes.
    #[arg(long)]
    pub out: PathBuf,
    /// Search method.
    #[arg(long, value_enum, default_value = "ga")]
    pub method: MethodArg,
    /// The detector, over the configuration's `evaluation.detector`: `cnn`, `model` or an
    /// external command.
    #[arg(long)]
    pub detector: Option<String>,
    /// The houses candidates are evaluated in; each option given overrides the configuration's
    /// `[house]` value.
    #[command(flatten)]
    pub house: HouseArgs,
}

/// Test hook: stop after this many evaluations, as an interruption would
/// (`SCENE_GEN_OPTIMIZE_STOP_AFTER`).
fn stop_after() -> Option<usize> {
    std::env::var("SCENE_GEN_OPTIMIZE_STOP_AFTER").ok().and_then(|v| v.parse().ok())
}

pub fn run(args: &OptimizeArgs) -> Result<(), CliError> {
    let mut config = match &args.config {
        Some(path) => OptimizeConfig::from_file(path).map_err(bad_input)?,
        None => OptimizeConfig::default(),
    };
    config.house = check(args.house.over(config.house))?;
    if let Some(detector) = &args.detector {
        if DetectorChoice::parse(detector).is_none() {
            return Err(bad_input(anyhow!("--detector: the command is empty")));
        }
        config.evaluation.detector = detector.trim().to_string();
    }
    let method = match args.method {
        MethodArg::Ga => Method::Ga,
        MethodArg::Random => Method::Random,
    };
    // Refuse an incompatible folder before anything is written.
    let resumed = check_dir(&args.out, method, &config).map_err(bad_input)?;
    let budget = config.budget();
    let progress = Progress::new("optimize", "candidates", budget as u64);
    if let Some(state) = &resumed {
        progress.set_done(state.candidates.iter().filter(|c| c.origin.evaluated()).count() as u64);
    }
    let mut report = |p: OptimizeProgress| {
        progress.set_message(format!("generation {}, best {:.4}", p.generation, p.best));
        progress.set_done(p.evaluations as u64);
    };
    let mut objective = EvalObjective::new(&config);
    let options = RunOptions { stop_after: stop_after(), progress: Some(&mut report) };
    let result = run_dir(&args.out, method, &config, &mut objective as &mut dyn Objective, options);
    progress.finish();
    let summary = result.map_err(|e| if e.is_bad_input() { bad_input(e) } else { failure(e) })?;
    if !summary.complete {
        eprintln!("stopped after {} evaluations; run the same command again to resume", summary.evaluated_now);
        return Ok(());
    }
    if let (Some(best), Some(spec)) = (&summary.best, &summary.best_camera) {
        println!(
            "{}: {} evaluations ({} now); best fitness {:.4} (day {:.4}, night {:.4}) at generation {}: {} \
             focal {} mm, pitch {} deg",
            method.as_str(),
            summary.evaluations,
            summary.evaluated_now,
            best.score.fitness,
            best.score.day,
            best.score.night,
            best.generation,
            spec.sensor,
            spec.focal_mm,
            spec.pitch_deg
        );
        println!(
            "wrote {}/{{candidates.csv, generations.csv, best_camera.toml, curve.png, state.json}}",
            args.out.display()
        );
    }
    Ok(())
}
