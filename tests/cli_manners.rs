//! What a user of a command-line tool expects beyond its outputs: `--version` naming the
//! commit, `generate` as a named command, shell completions, progress on stderr in a form a
//! job log can hold (and none with `--quiet`), and logging through `RUST_LOG`.

use std::process::{Command, Output};

mod common;
use common::{scene_gen, scratch};

fn run(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_scene-gen"));
    command.args(args).env_remove("RUST_LOG");
    for (k, v) in env {
        command.env(k, v);
    }
    let out = command.output().expect("scene-gen runs");
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    out
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn version_names_the_release_and_the_commit() {
    let out = run(&["--version"], &[]);
    let head = Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map_or_else(|| "unknown".to_string(), |o| text(&o.stdout).trim().to_string());
    let want = format!("scene-gen {} (commit {head})\n", env!("CARGO_PKG_VERSION"));
    assert_eq!(text(&out.stdout), want);
}

#[test]
fn generate_command_equals_the_top_level_form() {
    let (a, b) = (scratch("top"), scratch("named"));
    run(&["--seed", "9", "--envelope", "9x10x3", "--out", a.to_str().unwrap()], &[]);
    run(&["generate", "--seed", "9", "--envelope", "9x10x3", "--out", b.to_str().unwrap()], &[]);
    for name in ["scene.glb", "scene.json", "plan.png"] {
        assert_eq!(std::fs::read(a.join(name)).unwrap(), std::fs::read(b.join(name)).unwrap(), "{name}");
    }
    let _ = std::fs::remove_dir_all(a);
    let _ = std::fs::remove_dir_all(b);
}

#[test]
fn completions_cover_the_commands_and_options() {
    let bash = text(&run(&["completions", "bash"], &[]).stdout);
    for needle in ["complete -F _scene__gen", "evaluate", "dataset", "--envelope", "--quiet"] {
        assert!(bash.contains(needle), "bash completions lack {needle}");
    }
    let fish = text(&run(&["completions", "fish"], &[]).stdout);
    assert!(fish.contains("complete -c scene-gen"), "{fish:.200}");
    let out = scene_gen(&["completions", "tcsh"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn progress_is_plain_lines_off_a_terminal_and_silent_when_quiet() {
    let dir = scratch("render");
    let d = dir.to_str().unwrap();
    let args = ["render", "--seed", "3", "--camera", "IMX174,focal_mm=4", "--max-width", "48", "--quality", "preview"];
    let args = [&args[..], &["--lighting", "day", "--frames", "2", "--out", d]].concat();
    let out = run(&args, &[("SCENE_GEN_PROGRESS_S", "0")]);
    let stderr = text(&out.stderr);
    assert!(stderr.contains("render: 1/2 frames, "), "{stderr}");
    assert!(stderr.contains("render: 2/2 frames, "), "{stderr}");
    assert!(!stderr.contains('\r') && !stderr.contains('\u{1b}'), "no terminal control codes in a log: {stderr:?}");

    let quiet = run(&[&args[..], &["--quiet"]].concat(), &[("SCENE_GEN_PROGRESS_S", "0")]);
    assert_eq!(text(&quiet.stderr), "", "--quiet");
    // At the default period (10 s) a job this short writes its first step and its last line.
    let default = text(&run(&args, &[]).stderr);
    assert_eq!(default.lines().count(), 2, "{default}");

    let evaluate = ["evaluate", "--camera", "IMX172,focal_mm=4", "--seeds", "0", "--frames", "2", "--max-width", "48"];
    let out = run(&evaluate, &[("SCENE_GEN_PROGRESS_S", "0")]);
    let stderr = text(&out.stderr);
    let last = stderr.lines().last().unwrap_or_default();
    assert!(last.starts_with("evaluate: ") && last.contains(" poses, "), "{stderr}");
    let (done, total) = last["evaluate: ".len()..].split_once(' ').unwrap().0.split_once('/').unwrap();
    assert_eq!(done, total, "the last line counts every planned pose: {last}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn rust_log_shows_the_stages() {
    let dir = scratch("log");
    let out = run(&["--seed", "7", "--out", dir.to_str().unwrap()], &[("RUST_LOG", "info")]);
    let stderr = text(&out.stderr);
    assert!(stderr.contains("house 7: ") && stderr.contains(" objects"), "{stderr}");
    let out = run(&["--seed", "7", "--out", dir.to_str().unwrap()], &[]);
    assert_eq!(text(&out.stderr), "", "nothing logged by default");
    let _ = std::fs::remove_dir_all(dir);
}
