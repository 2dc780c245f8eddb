//! The evaluator on one seed with few, small frames: the scores move the way the camera
//! should move them, the output is deterministic and cached, and bad input exits 2.

use std::process::Command;

use scene_gen::camera_spec::CameraSpec;
use scene_gen::evaluate::{EvalConfig, evaluate, evaluate_traced, evaluate_uncached};

const SEED: u64 = 0;

/// 160 px wide (ORB needs room inside its 31 px border), 6 anchors.
fn small() -> EvalConfig {
    EvalConfig { frames_per_scene: 6, max_width_px: Some(160), ..EvalConfig::default() }
}

fn spec(text: &str) -> CameraSpec {
    CameraSpec::from_inline(text).expect("valid spec")
}

#[test]
fn a_camera_looking_up_sees_fewer_thresholds_than_a_wide_downward_one() {
    // The threshold is 0.1..0.35 m ahead in the 0.5 s before a crossing (0.5 m/s walk): only a
    // steep, wide view reaches it.
    let down = evaluate(&spec("IMX172,focal_mm=1.5,pitch_deg=-30"), &[SEED], &small()).unwrap();
    let up = evaluate(&spec("IMX172,focal_mm=20,pitch_deg=30"), &[SEED], &small()).unwrap();
    let (d, u) = (&down.scenarios.day, &up.scenarios.day);
    assert!(d.thresholds_seen + d.thresholds_missed > 0, "the walk crosses doors");
    assert!(
        d.threshold_accuracy > u.threshold_accuracy,
        "down {} vs up {}",
        d.threshold_accuracy,
        u.threshold_accuracy
    );
    assert_eq!(u.thresholds_seen, 0);
    assert!(down.fitness.mean > up.fitness.mean);
}

#[test]
fn night_noise_lowers_orb_inliers_and_ap() {
    let e = evaluate(&spec("IMX172"), &[SEED], &small()).unwrap();
    let (day, night) = (&e.scenarios.day, &e.scenarios.night);
    assert!(day.mean_inliers > 0.0 && day.ap50 > 0.0, "the day image is usable: {day:?}");
    assert!(night.mean_inliers < day.mean_inliers, "inliers night {} day {}", night.mean_inliers, day.mean_inliers);
    assert!(night.ap50 < day.ap50, "AP night {} day {}", night.ap50, day.ap50);
    assert!(e.fitness.night <= e.fitness.day);
    assert_eq!(day.frames, 6);
    let mean = 0.5 * (e.fitness.day + e.fitness.night);
    assert!((e.fitness.mean - mean).abs() < 1e-12);
    let expect = day.threshold_accuracy + day.ap50 + 0.0025 * day.mean_inliers + 0.5 * day.inlier_ratio;
    assert!((day.fitness - expect).abs() < 1e-12);
}

#[test]
fn same_inputs_give_the_same_json_at_any_thread_count() {
    let config = EvalConfig { frames_per_scene: 3, ..small() };
    let camera = spec("IMX172,focal_mm=3");
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let e = pool.install(|| evaluate_uncached(&camera, &[SEED], &config)).unwrap();
        serde_json::to_string(&e).unwrap()
    };
    let one = run(1);
    assert_eq!(one, run(3));
    assert_eq!(one, run(1));
}

#[test]
fn a_candidate_evaluated_twice_is_served_from_the_cache() {
    // A configuration no other test uses, so the first call must compute.
    let config = EvalConfig { frames_per_scene: 2, ..small() };
    let (first, cached) = evaluate_traced(&spec("IMX172,pitch_deg=-5"), &[SEED], &config).unwrap();
    assert!(!cached);
    // The same candidate written differently (case, explicit default) is the same key.
    let (second, cached) = evaluate_traced(&spec("imx172,pitch_deg=-5,focal_mm=4"), &[SEED], &config).unwrap();
    assert!(cached);
    assert_eq!(first.scenarios, second.scenarios);
    assert_eq!(first.fitness, second.fitness);
    // Another seed list is another candidate.
    let (_, cached) = evaluate_traced(&spec("IMX172,pitch_deg=-5"), &[SEED, SEED + 1], &config).unwrap();
    assert!(!cached);
}

fn cli(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_scene-gen")).arg("evaluate").args(args).output().expect("runs")
}

#[test]
fn bad_camera_specs_exit_2_without_output() {
    for camera in ["NOSUCHSENSOR", "IMX172,focal_mm=-1", "IMX172,bogus=3", "missing.toml"] {
        let out = cli(&["--camera", camera, "--frames", "1", "--max-width", "32", "--json"]);
        assert_eq!(out.status.code(), Some(2), "{camera}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(out.stdout.is_empty(), "{camera}: no partial output");
    }
    let out = cli(&["--camera", "IMX172", "--seeds", "3..3"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn json_output_has_exactly_the_documented_keys() {
    let out = cli(&["--camera", "IMX172", "--seeds", "0..1", "--frames", "2", "--max-width", "64", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON only on stdout");
    let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(keys, ["camera", "fitness", "scenarios", "seeds"]);
    assert_eq!(v["seeds"], serde_json::json!([0]));
    for s in ["day", "night"] {
        let sc = &v["scenarios"][s];
        for k in ["threshold_accuracy", "ap50", "mean_inliers", "inlier_ratio", "frames", "fitness"] {
            assert!(sc[k].is_number(), "{s}.{k}");
        }
    }
    for k in ["day", "night", "mean"] {
        assert!(v["fitness"][k].is_number());
    }
}
