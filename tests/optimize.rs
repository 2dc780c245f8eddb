//! The optimizer end to end: on an analytic objective (fast, exact) through the library, and
//! on a tiny real evaluation through `scene-gen optimize`.

use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::process::Command;

use scene_gen::camera_spec::CameraSpec;
use scene_gen::optimize::config::OptimizeConfig;
use scene_gen::optimize::genes::Genome;
use scene_gen::optimize::run::{Method, RunError, RunOptions, generation_stats, load_state, run};
use scene_gen::optimize::{Objective, ObjectiveError, Score};

const FILES: [&str; 5] = ["state.json", "candidates.csv", "generations.csv", "best_camera.toml", "curve.png"];

/// A fresh, empty folder under cargo's per-test temporary directory.
fn fresh_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("optimize-tests").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.parent().unwrap()).unwrap();
    dir
}

/// A smooth analytic fitness with its optimum at sensor 30, focal 12 mm, pitch 5 deg
/// (the maximum is 3).
fn analytic(genome: &Genome, spec: &CameraSpec) -> Score {
    let s = (genome.sensor as f64 - 30.0) / 43.0;
    let f = (f64::from(spec.focal_mm) - 12.0) / 19.0;
    let p = (f64::from(spec.pitch_deg) - 5.0) / 60.0;
    let day = 1.5 - 20.0 * (s * s + f * f);
    let night = 1.5 - 20.0 * (p * p + f * f);
    Score { day, night, fitness: day + night }
}

fn small_config(population: usize, generations: usize) -> OptimizeConfig {
    let mut c = OptimizeConfig::default();
    c.ga.population = population;
    c.ga.generations = generations;
    c.ga.parents = population / 2;
    c.ga.elites = (population / 2).clamp(1, 3);
    c.seed = 11;
    c
}

/// Runs `config` with the analytic objective; returns (summary complete, objective calls).
fn run_analytic(dir: &Path, method: Method, config: &OptimizeConfig, stop_after: Option<usize>) -> (bool, usize) {
    let calls = Cell::new(0);
    let mut objective = |g: &Genome, s: &CameraSpec| -> Result<Score, ObjectiveError> {
        calls.set(calls.get() + 1);
        Ok(analytic(g, s))
    };
    let summary = run(dir, method, config, &mut objective, RunOptions { stop_after, progress: None }).unwrap();
    (summary.complete, calls.get())
}

fn read_all(dir: &Path) -> Vec<Vec<u8>> {
    FILES.iter().map(|f| std::fs::read(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"))).collect()
}

#[test]
fn ga_beats_its_first_generation_on_an_analytic_objective() {
    let config = small_config(10, 20);
    let dir = fresh_dir("analytic-ga");
    run_analytic(&dir, Method::Ga, &config, None);
    let state = load_state(&dir).unwrap().unwrap();
    let stats = generation_stats(&state);
    assert_eq!(stats.len(), 20);
    let (first_best, last_best) = (stats[0].2, stats[19].4);
    assert!(last_best > first_best + 0.1, "GA did not improve: {first_best} -> {last_best}");
    assert!(last_best > 2.5, "GA should get close to the optimum 3, got {last_best}");
    // Elites make the best of each generation never worse than the previous one.
    assert!(stats.windows(2).all(|w| w[1].2 >= w[0].2), "{stats:?}");
}

#[test]
fn same_config_gives_the_same_bytes_and_a_new_seed_does_not() {
    let config = small_config(6, 4);
    let (a, b, c) = (fresh_dir("det-a"), fresh_dir("det-b"), fresh_dir("det-c"));
    run_analytic(&a, Method::Ga, &config, None);
    run_analytic(&b, Method::Ga, &config, None);
    assert_eq!(read_all(&a), read_all(&b));
    let mut other = config.clone();
    other.seed += 1;
    run_analytic(&c, Method::Ga, &other, None);
    assert_ne!(read_all(&a)[1], read_all(&c)[1]);
}

#[test]
fn an_interrupted_run_resumes_to_identical_files_without_re_evaluating() {
    let config = small_config(6, 5);
    let full = fresh_dir("resume-full");
    let (_, full_calls) = run_analytic(&full, Method::Ga, &config, None);
    assert_eq!(full_calls, config.budget());

    // Stop mid-generation twice (after 4 and then 5 more evaluations), then finish.
    let parts = fresh_dir("resume-parts");
    let (complete, c1) = run_analytic(&parts, Method::Ga, &config, Some(4));
    assert!(!complete && c1 == 4);
    let (complete, c2) = run_analytic(&parts, Method::Ga, &config, Some(5));
    assert!(!complete && c2 == 5);
    let (complete, c3) = run_analytic(&parts, Method::Ga, &config, None);
    assert!(complete);
    assert_eq!(c1 + c2 + c3, config.budget(), "a finished candidate was evaluated again");
    assert_eq!(read_all(&full), read_all(&parts));

    // Running a finished run again evaluates nothing and changes nothing.
    let (_, again) = run_analytic(&parts, Method::Ga, &config, None);
    assert_eq!(again, 0);
    assert_eq!(read_all(&full), read_all(&parts));
}

/// Scores whole generations at once, as a distributed objective does, recording batch sizes.
struct Batches {
    sizes: Vec<usize>,
    fail_at_batch: Option<usize>,
}

impl Objective for Batches {
    fn score(&mut self, _: &Genome, _: &CameraSpec) -> Result<Score, ObjectiveError> {
        Err(ObjectiveError::Other("the run must score by batch".into()))
    }

    fn score_batch(&mut self, batch: &[(Genome, CameraSpec)]) -> Result<Vec<Score>, ObjectiveError> {
        if self.fail_at_batch == Some(self.sizes.len()) {
            return Err(ObjectiveError::Other("worker lost".into()));
        }
        self.sizes.push(batch.len());
        // In reverse and back, as results gathered out of order and put back in place.
        let mut scored: Vec<(usize, Score)> =
            batch.iter().enumerate().rev().map(|(i, (g, s))| (i, analytic(g, s))).collect();
        scored.sort_by_key(|(i, _)| *i);
        Ok(scored.into_iter().map(|(_, s)| s).collect())
    }
}

#[test]
fn generations_scored_as_batches_give_the_same_files_and_resume() {
    let config = small_config(6, 4);
    let one_by_one = fresh_dir("batch-reference");
    run_analytic(&one_by_one, Method::Ga, &config, None);

    let batched = fresh_dir("batched");
    let mut objective = Batches { sizes: Vec::new(), fail_at_batch: None };
    let summary = run(&batched, Method::Ga, &config, &mut objective, RunOptions::default()).unwrap();
    assert!(summary.complete);
    // Generation 0 is scored whole; later ones all but their elites, which keep their scores.
    assert_eq!(objective.sizes[0], 6);
    assert!(objective.sizes[1..].iter().all(|&n| n == 6 - config.ga.elites), "{:?}", objective.sizes);
    assert_eq!(objective.sizes.iter().sum::<usize>(), config.budget());
    assert_eq!(read_all(&one_by_one), read_all(&batched));

    // A batch that fails records nothing of it; the run resumes from the generations before.
    let failed = fresh_dir("batch-failed");
    let mut objective = Batches { sizes: Vec::new(), fail_at_batch: Some(2) };
    let err = run(&failed, Method::Ga, &config, &mut objective, RunOptions::default()).unwrap_err();
    assert!(err.to_string().contains("worker lost"), "{err}");
    assert_eq!(load_state(&failed).unwrap().unwrap().candidates.len(), 12);
    let mut objective = Batches { sizes: Vec::new(), fail_at_batch: None };
    run(&failed, Method::Ga, &config, &mut objective, RunOptions::default()).unwrap();
    assert_eq!(objective.sizes.len(), 2);
    assert_eq!(read_all(&one_by_one), read_all(&failed));

    // `stop_after` cuts a batch short.
    let stopped = fresh_dir("batch-stopped");
    let mut objective = Batches { sizes: Vec::new(), fail_at_batch: None };
    let summary =
        run(&stopped, Method::Ga, &config, &mut objective, RunOptions { stop_after: Some(4), progress: None }).unwrap();
    assert!(!summary.complete && objective.sizes == [4]);
}

#[test]
fn more_generations_extend_a_shorter_run() {
    let long = small_config(6, 5);
    let mut short = long.clone();
    short.ga.generations = 2;
    let (a, b) = (fresh_dir("extend-long"), fresh_dir("extend-short"));
    run_analytic(&a, Method::Ga, &long, None);
    let (_, first) = run_analytic(&b, Method::Ga, &short, None);
    let (_, second) = run_analytic(&b, Method::Ga, &long, None);
    assert_eq!(first + second, long.budget());
    assert_eq!(read_all(&a), read_all(&b));
    // ...but a shorter configuration cannot continue a longer run.
    let calls = Cell::new(0);
    let mut objective = |g: &Genome, s: &CameraSpec| -> Result<Score, ObjectiveError> {
        calls.set(calls.get() + 1);
        Ok(analytic(g, s))
    };
    let err = run(&b, Method::Ga, &short, &mut objective, RunOptions::default()).unwrap_err();
    assert!(matches!(err, RunError::TooManyGenerations { .. }) && err.is_bad_input(), "{err}");
}

#[test]
fn a_folder_of_another_configuration_or_method_is_refused_untouched() {
    let config = small_config(6, 2);
    let dir = fresh_dir("mismatch");
    run_analytic(&dir, Method::Ga, &config, None);
    let before = read_all(&dir);
    let mut other = config.clone();
    other.genes.focal_mm.max = 10.0;
    for (method, cfg) in [(Method::Ga, &other), (Method::Random, &config)] {
        let mut objective = |g: &Genome, s: &CameraSpec| -> Result<Score, ObjectiveError> { Ok(analytic(g, s)) };
        let err = run(&dir, method, cfg, &mut objective, RunOptions::default()).unwrap_err();
        assert!(matches!(err, RunError::Mismatch { .. }) && err.is_bad_input(), "{err}");
    }
    let msg = {
        let mut objective = |g: &Genome, s: &CameraSpec| -> Result<Score, ObjectiveError> { Ok(analytic(g, s)) };
        run(&dir, Method::Ga, &other, &mut objective, RunOptions::default()).unwrap_err().to_string()
    };
    assert!(msg.contains("genes.focal_mm.max"), "the message names the differing key: {msg}");
    assert_eq!(read_all(&dir), before);
}

#[test]
fn random_search_spends_exactly_the_ga_budget() {
    let config = small_config(10, 6);
    let (ga_dir, rs_dir) = (fresh_dir("budget-ga"), fresh_dir("budget-rs"));
    let (_, ga_calls) = run_analytic(&ga_dir, Method::Ga, &config, None);
    let (_, rs_calls) = run_analytic(&rs_dir, Method::Random, &config, None);
    assert_eq!(ga_calls, config.budget());
    assert_eq!(rs_calls, ga_calls);
    let (ga, rs) = (load_state(&ga_dir).unwrap().unwrap(), load_state(&rs_dir).unwrap().unwrap());
    let (gs, rss) = (generation_stats(&ga), generation_stats(&rs));
    // Same evaluations after every generation, and the same generation 0.
    assert_eq!(gs.iter().map(|s| s.1).collect::<Vec<_>>(), rss.iter().map(|s| s.1).collect::<Vec<_>>());
    assert_eq!(gs[0], rss[0]);
    let csv = std::fs::read_to_string(rs_dir.join("candidates.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + config.budget());
    assert!(csv.lines().skip(1 + config.ga.population).all(|l| l.split(',').nth(2) == Some("random")));
}

// ---- through the binary, with a tiny real evaluation ----

fn cli(args: &[&str], stop_after: Option<usize>) -> std::process::Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_scene-gen"));
    cmd.arg("optimize").args(args);
    if let Some(n) = stop_after {
        cmd.env("SCENE_GEN_OPTIMIZE_STOP_AFTER", n.to_string());
    }
    cmd.output().expect("scene-gen runs")
}

/// A task small enough for a test: 96 px frames, too small for the learned detector, so the
/// detectability model scores detection.
const TINY: &str = "seed = 3\n\
[ga]\npopulation = 4\ngenerations = 2\nparents = 2\nelites = 1\n\
[evaluation]\nseeds = [0]\nframes_per_scene = 4\nmax_width_px = 96\ndetector = \"model\"\n";

fn write_config(name: &str, text: &str) -> PathBuf {
    let path = fresh_dir(name).with_extension("toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn cli_run_resumes_to_the_same_bytes_and_its_best_camera_loads() {
    let config = write_config("tiny-config", TINY);
    let (full, parts) = (fresh_dir("cli-full"), fresh_dir("cli-parts"));
    let c = config.to_str().unwrap();
    let out = cli(&["--config", c, "--out", full.to_str().unwrap()], None);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("best fitness"));
    let out = cli(&["--config", c, "--out", parts.to_str().unwrap()], Some(3));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("resume"));
    let state = load_state(&parts).unwrap().unwrap();
    assert_eq!(state.candidates.len(), 3);
    let out = cli(&["--config", c, "--out", parts.to_str().unwrap()], None);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("(4 now)"), "{}", String::from_utf8_lossy(&out.stdout));
    assert_eq!(read_all(&full), read_all(&parts));

    // The best camera is a camera spec `evaluate` and `render` read, and the best fitness.
    let best = full.join("best_camera.toml");
    let spec = CameraSpec::from_arg(best.to_str().unwrap()).expect("best_camera.toml loads");
    spec.resolve(&scene_gen::sensor::Catalog::embedded()).unwrap();
    let gens = std::fs::read_to_string(full.join("generations.csv")).unwrap();
    let rows = scene_gen::optimize::run::read_generations_csv(&gens).unwrap();
    assert_eq!(rows.len(), 2);
    let out = Command::new(env!("CARGO_BIN_EXE_scene-gen"))
        .args(["evaluate", "--camera", best.to_str().unwrap(), "--seeds", "0", "--frames", "4", "--max-width", "96"])
        .args(["--detector", "model", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mean = v["fitness"]["mean"].as_f64().unwrap();
    assert!(rows[1].4 > 0.0, "this tiny task scores some candidate above 0");
    assert!((mean - rows[1].4).abs() < 1e-9, "re-evaluated best {mean} vs best so far {}", rows[1].4);
    let png = std::fs::read(full.join("curve.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn cli_refuses_bad_configs_and_foreign_folders_with_exit_2() {
    let bad = write_config("bad-config", "seed = 1\n[ga]\npopulaton = 4\n");
    let out_dir = fresh_dir("cli-bad");
    let out = cli(&["--config", bad.to_str().unwrap(), "--out", out_dir.to_str().unwrap()], None);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad-config.toml:3") && err.contains("populaton"), "{err}");
    assert!(!out_dir.exists(), "nothing is written for a bad config");

    let out = cli(&["--config", "/nonexistent/optimize.toml", "--out", out_dir.to_str().unwrap()], None);
    assert_eq!(out.status.code(), Some(2));

    // A folder holding a run of another configuration.
    let config = write_config("foreign-config", TINY);
    let out = cli(&["--config", config.to_str().unwrap(), "--out", out_dir.to_str().unwrap()], Some(1));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let before = std::fs::read(out_dir.join("state.json")).unwrap();
    let other = write_config("foreign-other", &TINY.replace("seed = 3", "seed = 4"));
    let out = cli(&["--config", other.to_str().unwrap(), "--out", out_dir.to_str().unwrap()], None);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("different configuration"));
    let out =
        cli(&["--config", config.to_str().unwrap(), "--out", out_dir.to_str().unwrap(), "--method", "random"], None);
    assert_eq!(out.status.code(), Some(2));
    // `--detector` overrides the configuration's detector, so it is another configuration too.
    let out =
        cli(&["--config", config.to_str().unwrap(), "--out", out_dir.to_str().unwrap(), "--detector", "cnn"], None);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("different configuration"));
    let out = cli(&["--config", config.to_str().unwrap(), "--out", out_dir.to_str().unwrap(), "--detector", " "], None);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--detector"));
    assert_eq!(std::fs::read(out_dir.join("state.json")).unwrap(), before);
}

/// The example configurations of examples/optimize parse over the defaults and hold the tasks
/// their comments describe: `reduced.toml` one house, 10 anchors at 160 px; `native.toml` one
/// house, 5 anchors at every pixel of the sensor; both keep the default GA.
#[test]
fn example_configurations_parse_and_hold_their_tasks() {
    use scene_gen::evaluate::FrameWidth;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/optimize");
    let defaults = OptimizeConfig::from_toml("", Path::new("defaults")).unwrap();
    let expect = [("reduced.toml", 10, FrameWidth::AtMost(160)), ("native.toml", 5, FrameWidth::Native)];
    for (name, frames, width) in expect {
        let config = OptimizeConfig::from_file(&dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(config.evaluation.seeds, [0], "{name}");
        assert_eq!(config.evaluation.frames_per_scene, frames, "{name}");
        assert_eq!(config.evaluation.max_width_px, width, "{name}");
        assert_eq!(config.budget(), defaults.budget(), "{name}: the default GA's evaluations");
    }
}
