//! The house options (`--envelope`, `--min-room`, `--rooms`, `--furniture`) mean the same house
//! in every command: the manifest records them, `render` rebuilds the house from that record
//! (and refuses options that contradict it), and `evaluate`, `dataset` and `serve` build and
//! record the houses they are given.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use scene_gen::house::{HouseOptions, load_library, walked_house_with};
use scene_gen::library::Library;
use scene_gen::trajectory::TrajectoryParams;

mod common;
use common::{scene_gen, scratch};

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn ok(args: &[&str]) -> Output {
    let out = scene_gen(args);
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    out
}

/// Exit status 2 with `needle` in the message, and `out_dir` not created.
fn refused(args: &[&str], out_dir: &Path, needle: &str) {
    let out = scene_gen(args);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
    assert!(stderr(&out).contains(needle), "{args:?}: expected '{needle}' in: {}", stderr(&out));
    assert!(!out_dir.exists(), "{args:?}: {} was created", out_dir.display());
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).unwrap()
}

/// The repository's room library, a folder with the embedded library's content.
fn rooms_folder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms")
}

/// Every file of the rendered folder, by name.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
        .collect();
    out.sort();
    out
}

#[test]
fn render_rebuilds_the_house_from_the_manifest_record() {
    let rooms = rooms_folder();
    let rooms = rooms.to_str().unwrap();
    let house = scratch("house");
    let h = house.to_str().unwrap();
    ok(&["--seed", "5", "--envelope", "10x12x2.8", "--min-room", "4", "--rooms", rooms, "--out", h]);

    let manifest = json(&house.join("scene.json"));
    let record = &manifest["house"];
    assert_eq!(record["min_room_m"], 4.0);
    assert_eq!(record["rooms"]["folder"], rooms);
    assert_eq!(record["furniture"]["folder"], serde_json::Value::Null);
    let embedded = Library::embedded().unwrap();
    assert_eq!(record["rooms"]["digest"], embedded.rooms_id.digest.as_str(), "same content, same digest");
    assert_eq!(record["furniture"]["digest"], embedded.furniture_id.digest.as_str());

    // The manifest alone is enough: no --min-room, --envelope or --rooms needed.
    let scene = house.join("scene.json");
    let scene = scene.to_str().unwrap();
    let camera = "IMX174,focal_mm=4";
    let common = ["--camera", camera, "--max-width", "64", "--quality", "preview", "--lighting", "day"];
    let from_manifest = scratch("from-manifest");
    ok(&[&["render", "--scene", scene, "--out", from_manifest.to_str().unwrap()][..], &common].concat());
    // The same options given directly build the same house: the same frames, byte for byte.
    let from_seed = scratch("from-seed");
    let args = ["render", "--seed", "5", "--envelope", "10x12x2.8", "--min-room", "4", "--rooms", rooms];
    ok(&[&args[..], &["--out", from_seed.to_str().unwrap()], &common].concat());
    assert_eq!(files(&from_manifest), files(&from_seed));
    // ... and the default house is another one.
    let default_house = scratch("default-house");
    ok(&[&["render", "--seed", "5", "--out", default_house.to_str().unwrap()][..], &common].concat());
    assert_ne!(files(&from_manifest), files(&default_house));

    // Options that contradict the record are refused, naming the option.
    let bad = scratch("contradicted");
    let b = bad.to_str().unwrap();
    refused(
        &[&["render", "--scene", scene, "--out", b, "--min-room", "5"][..], &common].concat(),
        &bad,
        "--min-room 5",
    );
    refused(
        &[&["render", "--scene", scene, "--out", b, "--envelope", "15x15x3"][..], &common].concat(),
        &bad,
        "--envelope 15x15x3",
    );
    // A rooms library whose content changed is not the one the house was made with.
    let edited = scratch("edited-rooms");
    std::fs::create_dir_all(&edited).unwrap();
    for entry in std::fs::read_dir(rooms_folder()).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, edited.join(path.file_name().unwrap())).unwrap();
    }
    let first = std::fs::read_dir(&edited).unwrap().map(|e| e.unwrap().path()).find(|p| p.is_file()).unwrap();
    std::fs::OpenOptions::new().append(true).open(&first).unwrap().write_all(b"\n# edited\n").unwrap();
    refused(
        &[&["render", "--scene", scene, "--out", b, "--rooms", edited.to_str().unwrap()][..], &common].concat(),
        &bad,
        "rooms library",
    );
    // Neither a manifest nor a seed: a usage error.
    refused(&["render", "--camera", camera, "--out", b], &bad, "--scene");
    for dir in [house, from_manifest, from_seed, default_house, edited] {
        let _ = std::fs::remove_dir_all(dir);
    }
}

/// Threshold crossings of the walk in the house of `seed` built with `options`.
fn crossings(options: &HouseOptions, seed: u64) -> usize {
    let library = load_library(options).unwrap();
    let params = TrajectoryParams { height_m: 0.8, ..TrajectoryParams::default() };
    walked_house_with(&library, &options.config(seed), &params).unwrap().walk.crossings.len()
}

#[test]
fn evaluate_dataset_and_serve_use_and_record_the_options() {
    let small = HouseOptions { envelope: "8x8x3".parse().unwrap(), min_room_m: 4.0, ..HouseOptions::default() };
    let (want_small, want_default) = (crossings(&small, 2), crossings(&HouseOptions::default(), 2));
    assert_ne!(want_small, want_default, "seed 2: the two houses should differ in their doors");

    let args = ["evaluate", "--camera", "IMX172,focal_mm=4", "--seeds", "2", "--frames", "2", "--max-width", "64"];
    let out = ok(&[&args[..], &["--json", "--envelope", "8x8x3", "--min-room", "4"]].concat());
    let evaluation: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(evaluation["config"]["house"], serde_json::json!({"envelope": "8x8x3", "min_room_m": 4.0}));
    let day = &evaluation["scenarios"]["day"];
    let crossed = day["thresholds_seen"].as_u64().unwrap() + day["thresholds_missed"].as_u64().unwrap();
    assert_eq!(crossed as usize, want_small, "evaluate walked another house: {day}");
    // The default house is not recorded (default runs keep their bytes).
    let out = ok(&[&args[..], &["--json"]].concat());
    let evaluation: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(evaluation["config"].get("house").is_none(), "{}", evaluation["config"]);
    let nowhere = scratch("nowhere");
    refused(&[&args[..], &["--min-room", "2"]].concat(), &nowhere, "--min-room 2");
    refused(&[&args[..], &["--furniture", "/nonexistent/furniture"]].concat(), &nowhere, "/nonexistent/furniture");

    let dataset = scratch("dataset");
    let d = dataset.to_str().unwrap();
    let args = ["dataset", "--seeds", "2", "--camera", "IMX172,focal_mm=4", "--frames", "1", "--max-width", "48"];
    let args = [&args[..], &["--quality", "preview", "--lighting", "day", "--out", d]].concat();
    ok(&[&args[..], &["--envelope", "8x8x3", "--min-room", "4"]].concat());
    let spec = json(&dataset.join("dataset.json"));
    assert_eq!(spec["house"], serde_json::json!({"envelope": "8x8x3", "min_room_m": 4.0}));
    // A shard with other house options does not mix into this dataset.
    let out = scene_gen(&[&args[..], &["--envelope", "8x8x3"]].concat());
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let _ = std::fs::remove_dir_all(dataset);

    let mut serve = Command::new(env!("CARGO_BIN_EXE_scene-gen"))
        .args(["serve", "--envelope", "8x8x3", "--min-room", "4"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    serve.stdin.take().unwrap().write_all(b"{\"op\": \"describe\"}\n").unwrap();
    let out = serve.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let describe: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(describe["defaults"]["house"], serde_json::json!({"envelope": "8x8x3", "min_room_m": 4.0}));
}
