//! The `scene-gen` command line as a user meets it: outputs, determinism, and bad input
//! refused with a clear message, exit status 2 and nothing written.

use std::path::Path;
use std::process::Output;

mod common;
use common::{scene_gen, scratch};

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Asserts exit status 2, a message containing `needle`, and no output folder.
fn assert_refused(args: &[&str], out_dir: &Path, needle: &str) {
    let out = scene_gen(args);
    assert_eq!(out.status.code(), Some(2), "args {args:?}: stderr {}", stderr(&out));
    assert!(stderr(&out).contains(needle), "args {args:?}: expected '{needle}' in: {}", stderr(&out));
    assert!(!out_dir.exists(), "args {args:?}: {} was created", out_dir.display());
}

#[test]
fn generates_glb_manifest_and_plan() {
    let dir = scratch("ok");
    let out = scene_gen(&["--seed", "7", "--out", dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    for name in ["scene.glb", "scene.json", "plan.png"] {
        let meta = std::fs::metadata(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(meta.len() > 0, "{name} is empty");
    }
    let manifest: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("scene.json")).unwrap()).unwrap();
    assert_eq!(manifest["schema"], "scene-gen/scene/1");
    assert_eq!(manifest["seed"], 7);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn same_seed_same_bytes() {
    let (a, b) = (scratch("det-a"), scratch("det-b"));
    for dir in [&a, &b] {
        let out = scene_gen(&["--seed", "11", "--out", dir.to_str().unwrap()]);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    for name in ["scene.glb", "scene.json", "plan.png"] {
        assert_eq!(std::fs::read(a.join(name)).unwrap(), std::fs::read(b.join(name)).unwrap(), "{name} differs");
    }
    let _ = std::fs::remove_dir_all(a);
    let _ = std::fs::remove_dir_all(b);
}

#[test]
fn envelope_narrower_than_a_room_is_refused() {
    let dir = scratch("narrow");
    assert_refused(&["--seed", "1", "--envelope", "4x15x3", "--out", dir.to_str().unwrap()], &dir, "--min-room");
}

#[test]
fn low_ceiling_is_refused() {
    let dir = scratch("low");
    assert_refused(&["--seed", "1", "--envelope", "15x15x2.1", "--out", dir.to_str().unwrap()], &dir, "2.1");
}

#[test]
fn malformed_envelope_is_refused() {
    let dir = scratch("malformed");
    assert_refused(&["--envelope", "15x15", "--out", dir.to_str().unwrap()], &dir, "WIDTHxDEPTHxHEIGHT");
    assert_refused(&["--envelope", "15xabcx3", "--out", dir.to_str().unwrap()], &dir, "abc");
}

#[test]
fn broken_room_toml_names_file_and_line() {
    let dir = scratch("broken-rooms");
    let rooms = scratch("broken-rooms-lib");
    std::fs::create_dir_all(&rooms).unwrap();
    std::fs::write(rooms.join("den.toml"), "label = \"Den\"\nfloor = [\"wood_floor\"\nwalls = [\"paint\"]\n").unwrap();
    let den = rooms.join("den.toml");
    assert_refused(
        &["--rooms", rooms.to_str().unwrap(), "--out", dir.to_str().unwrap()],
        &dir,
        &format!("{}:", den.display()),
    );
    let _ = std::fs::remove_dir_all(rooms);
}

#[test]
fn unknown_class_names_file_and_line() {
    let dir = scratch("unknown-class");
    let rooms = scratch("unknown-class-lib");
    std::fs::create_dir_all(&rooms).unwrap();
    std::fs::write(
        rooms.join("den.toml"),
        "label = \"Den\"\nfloor = [\"wood_floor\"]\nwalls = [\"paint\"]\n\n[[furniture]]\nclass = \"piano\"\ncount = [1, 1]\n",
    )
    .unwrap();
    let expected = format!("{}:6: unknown class 'piano'", rooms.join("den.toml").display());
    assert_refused(&["--rooms", rooms.to_str().unwrap(), "--out", dir.to_str().unwrap()], &dir, &expected);
    let _ = std::fs::remove_dir_all(rooms);
}

#[test]
fn missing_library_folder_is_refused() {
    let dir = scratch("missing-lib");
    assert_refused(&["--furniture", "/nonexistent/furniture", "--out", dir.to_str().unwrap()], &dir, "/nonexistent");
}
