//! `--format usda|usdc` without usd-core: refused with the install command, exit status 2 and
//! nothing written. (The export itself is checked with usd-core in tests/interop/check_usd.sh.)

use std::path::PathBuf;
use std::process::{Command, Output};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("scene-gen-usd-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn scene_gen_with_python(python: &str, format: &str, out: &std::path::Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_scene-gen"))
        .args(["--seed", "3", "--format", format, "--out", out.to_str().unwrap()])
        .env("SCENE_GEN_PYTHON", python)
        .output()
        .expect("scene-gen runs")
}

fn assert_refused_with_install_command(out: &Output, dir: &std::path::Path) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert!(stderr.contains("usd-core"), "{stderr}");
    assert!(stderr.contains("python3 -m venv .venv && .venv/bin/pip install usd-core==26.11"), "{stderr}");
    assert!(!dir.exists(), "{} was created", dir.display());
}

#[test]
fn nonexistent_python_is_refused_with_the_install_command() {
    for format in ["usda", "usdc"] {
        let dir = scratch(&format!("nopython-{format}"));
        let out = scene_gen_with_python("/nonexistent/bin/python3", format, &dir);
        assert_refused_with_install_command(&out, &dir);
        assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/bin/python3"));
    }
}

#[test]
#[cfg(unix)]
fn python_without_pxr_is_refused_with_the_install_command() {
    // A real Python without site-packages: the standard library imports, pxr cannot.
    let dir = scratch("nopxr");
    let fake = scratch("nopxr-python");
    std::fs::create_dir_all(&fake).unwrap();
    let python = fake.join("python");
    std::fs::write(&python, "#!/bin/sh\nexec python3 -I -S \"$@\"\n").unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&python, std::fs::Permissions::from_mode(0o755)).unwrap();
    let out = scene_gen_with_python(python.to_str().unwrap(), "usda", &dir);
    assert_refused_with_install_command(&out, &dir);
    assert!(String::from_utf8_lossy(&out.stderr).contains("No module named 'pxr'"));
    let _ = std::fs::remove_dir_all(fake);
}
