//! `scene-gen serve` driven as a real process, the way an optimizer drives it: requests on
//! stdin, one flushed response per request on stdout, in order, errors included.

use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};

use serde_json::Value;

fn serve_cmd(args: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_scene-gen"));
    cmd.arg("serve").args(args);
    cmd
}

fn kind(v: &Value) -> &str {
    v["error"]["kind"].as_str().unwrap_or("none")
}

/// Fitness of one scenario under `weights` from the scenario's own terms.
fn weighted(s: &Value, w: [f64; 4]) -> f64 {
    let f = |k: &str| s[k].as_f64().unwrap();
    w[0] * f("threshold_accuracy") + w[1] * f("ap50") + w[2] * f("mean_inliers") + w[3] * f("inlier_ratio")
}

#[test]
fn a_server_answers_every_line_in_order_survives_bad_requests_and_caches() {
    let mut child = serve_cmd(&["--seeds", "0", "--frames", "2", "--max-width", "64"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("scene-gen serve starts");
    let mut stdin = child.stdin.take().unwrap();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());

    // One request, then wait for its answer with stdin still open: responses are flushed.
    writeln!(stdin, r#"{{"id": "d", "op": "describe"}}"#).unwrap();
    let mut first = String::new();
    stdout.read_line(&mut first).unwrap();
    let describe: Value = serde_json::from_str(&first).unwrap();
    assert_eq!((describe["id"].as_str(), describe["ok"].as_bool()), (Some("d"), Some(true)));
    assert_eq!(describe["protocol"], "scene-gen/serve/2");
    assert!(describe["sensors"].as_array().unwrap().iter().any(|s| s == "IMX174"));
    assert_eq!(describe["defaults"]["frames"], 2);
    assert_eq!(describe["defaults"]["max_width"], 64);
    assert_eq!(describe["defaults"]["detector"], "cnn");

    let good = r#"{"sensor": "IMX174", "focal_mm": 2, "pitch_deg": -20}"#;
    let lines = [
        r#"{"id": 1, "camera": "#.to_string(),                     // line 2: malformed
        r#"{"id": 2, "camera": "IMX999,focal_mm=4"}"#.to_string(), // 3: unknown sensor
        r#"{"id": 3, "camera": {"sensor": "IMX174", "focal_mm": 0}}"#.to_string(), // 4: focal_mm <= 0
        format!(r#"{{"id": 4, "camera": {good}, "colour": 1}}"#),  // 5: unknown field
        String::new(),                                             // 6: blank, no answer
        format!(r#"{{"id": 5, "camera": {good}}}"#),               // 7: computed
        r#"{"id": 6, "camera": "imx174,pitch_deg=-20,focal_mm=2"}"#.to_string(), // 8: same, inline
        format!(r#"{{"id": 7, "camera": {good}, "weights": {{"threshold": 2}}}}"#), // 9: new weights
        r#"{"id": 8, "camera": "IMX174,focal_mm=4.5,pitch_deg=-20", "frames": 0}"#.to_string(), // 10
    ];
    for l in &lines {
        writeln!(stdin, "{l}").unwrap();
    }
    drop(stdin);
    let out: Vec<Value> =
        stdout.lines().map(|l| serde_json::from_str(&l.unwrap()).expect("each line is JSON")).collect();
    let status = child.wait().unwrap();
    assert!(status.success(), "end of input ends the server with 0: {status}");
    assert_eq!(out.len(), 8, "one response per non-blank request: {out:#?}");

    let ids: Vec<Value> = out.iter().map(|v| v["id"].clone()).collect();
    let expected: Vec<Value> =
        [Value::Null, 2.into(), 3.into(), 4.into(), 5.into(), 6.into(), 7.into(), 8.into()].into();
    assert_eq!(ids, expected, "in request order, each under its own id (malformed: null)");
    let kinds: Vec<&str> = out.iter().map(kind).collect();
    assert_eq!(
        kinds,
        ["bad_request", "bad_camera", "bad_camera", "bad_request", "none", "none", "none", "bad_request"]
    );
    let error_lines: Vec<u64> = out.iter().filter_map(|v| v["error"]["line"].as_u64()).collect();
    assert_eq!(error_lines, [2, 3, 4, 5, 10], "errors name the input line (blank lines count)");
    assert!(out[1]["error"]["message"].as_str().unwrap().contains("IMX999"));
    assert!(out[2]["error"]["message"].as_str().unwrap().contains("focal_mm"));
    assert!(out[3]["error"]["message"].as_str().unwrap().contains("colour"));

    let (a, b, c) = (&out[4], &out[5], &out[6]);
    for v in [a, b, c] {
        assert_eq!(v["ok"], true);
        assert_eq!(v["seeds"], serde_json::json!([0]));
        assert_eq!((v["frames"].as_u64(), v["max_width"].as_u64()), (Some(2), Some(64)));
        assert_eq!(v["camera"]["sensor"], "IMX174");
        assert!(v["seconds"].as_f64().unwrap() >= 0.0);
    }
    assert_eq!(a["cached"], false, "first evaluation is computed");
    assert_eq!(b["cached"], true, "the same candidate spelt inline comes from the cache");
    assert_eq!((&a["fitness"], &a["scenarios"]), (&b["fitness"], &b["scenarios"]), "same scores");
    let mean = a["fitness"]["mean"].as_f64().unwrap();
    assert!(mean > 0.0 && mean.is_finite(), "a wide, steep camera sees door sills: {mean}");
    for s in ["day", "night"] {
        let d = &a["scenarios"][s];
        let f = a["fitness"][s].as_f64().unwrap();
        assert!((f - weighted(d, [1.0, 1.0, 0.0025, 0.5])).abs() < 1e-9, "{s}: TaCOS weights");
    }
    assert_eq!(c["cached"], false, "other weights are another evaluation");
    for s in ["day", "night"] {
        let d = &c["scenarios"][s];
        let f = c["fitness"][s].as_f64().unwrap();
        assert!((f - weighted(d, [2.0, 1.0, 0.0025, 0.5])).abs() < 1e-9, "{s}: the request's threshold weight");
    }
    assert!(c["fitness"]["mean"].as_f64().unwrap() > mean);
}

#[test]
fn empty_input_exits_zero_with_no_output() {
    let out = serve_cmd(&[]).stdin(Stdio::null()).output().unwrap();
    assert!(out.status.success());
    assert!(out.stdout.is_empty());
}

#[test]
fn bad_defaults_are_usage_errors() {
    for args in [
        ["--frames", "0"],
        ["--max-width", "0"],
        ["--max-width", "full"],
        ["--seeds", "5..2"],
        ["--seeds", "x"],
        ["--detector", " "],
    ] {
        let out = serve_cmd(&args).stdin(Stdio::null()).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(out.stdout.is_empty());
        assert!(!out.stderr.is_empty());
    }
}

#[test]
fn the_detector_option_reaches_every_request() {
    let out = serve_cmd(&["--seeds", "0", "--frames", "2", "--max-width", "64", "--detector", "model"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .and_then(|mut child| {
            let mut stdin = child.stdin.take().unwrap();
            writeln!(stdin, r#"{{"id": 0, "op": "describe"}}"#).unwrap();
            writeln!(stdin, r#"{{"id": 1, "camera": "IMX174,focal_mm=4"}}"#).unwrap();
            drop(stdin);
            child.wait_with_output()
        })
        .unwrap();
    assert!(out.status.success());
    let answers: Vec<Value> =
        String::from_utf8_lossy(&out.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(answers[0]["defaults"]["detector"], "model");
    assert_eq!(answers[1]["ok"], true, "{}", answers[1]);
    // The same request through `evaluate --detector model` gives the same scores.
    let direct = Command::new(env!("CARGO_BIN_EXE_scene-gen"))
        .args(["evaluate", "--camera", "IMX174,focal_mm=4", "--seeds", "0", "--frames", "2", "--max-width", "64"])
        .args(["--detector", "model", "--json"])
        .output()
        .unwrap();
    let direct: Value = serde_json::from_slice(&direct.stdout).unwrap();
    assert_eq!(answers[1]["scenarios"], direct["scenarios"]);
}
