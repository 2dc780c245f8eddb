//! `--format usda|usdc` without usd-core: refused with the install command, exit status 2 and
//! nothing written. (The export itself is checked with usd-core in tests/interop/check_usd.sh.)

use std::process::{Command, Output};

mod common;
use common::scratch;

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

mod plan {
    use std::collections::BTreeSet;

    use proptest::prelude::*;
    use scene_gen::config::GeneratorConfig;
    use scene_gen::export::usd::UsdPlan;
    use scene_gen::generate::generate;
    use scene_gen::library::Library;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

        /// For every seed: prim paths are unique, valid names, each after its parent; one mesh
        /// prim per primitive of every node; one labelled root per object and threshold; every
        /// light in its group.
        #[test]
        fn usd_layout_is_well_formed_for_every_seed(seed in any::<u64>()) {
            let library = Library::embedded().unwrap();
            let scene = generate(&GeneratorConfig { seed, ..GeneratorConfig::default() }, &library).unwrap();
            let plan = UsdPlan::of(&scene);
            let doc = &plan.doc;
            let mut seen = BTreeSet::new();
            for path in doc.prims.iter().map(|p| &p.path).chain(doc.meshes.iter().map(|m| &m.path)) {
                let parent = &path[..path.rfind('/').unwrap()];
                prop_assert!(parent.is_empty() || seen.contains(parent), "{} before its parent", path);
                prop_assert!(seen.insert(path.clone()), "{} twice", path);
                for name in path[1..].split('/') {
                    prop_assert!(!name.is_empty() && !name.starts_with(|c: char| c.is_ascii_digit()));
                    prop_assert!(name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'), "{}", name);
                }
            }
            let primitives: usize =
                scene.geometry.nodes.iter().map(|n| scene.geometry.meshes[n.mesh].primitives.len()).sum();
            prop_assert_eq!(doc.meshes.len(), primitives);
            let labelled = doc.prims.iter().filter(|p| p.label.is_some()).count();
            prop_assert_eq!(labelled, scene.objects.len() + scene.thresholds.len());
            prop_assert_eq!(doc.lights.len(), scene.lights.len());
            for (light, prim) in scene.lights.iter().zip(&doc.lights) {
                let group = if light.group == scene_gen::scene::LightGroup::Day { "Day" } else { "Night" };
                let prefix = format!("/World/Lights/{group}/");
                prop_assert!(prim.path.starts_with(&prefix), "{} not under {}", prim.path, prefix);
                prop_assert!(prim.intensity.is_finite() && prim.intensity > 0.0);
            }
            let mesh_bytes: usize = doc.meshes.iter().map(|m| 4 * (3 * m.points.count + 3 * m.normals.count + 2 * m.st.count + m.indices.count)).sum();
            prop_assert_eq!(mesh_bytes, plan.bin.len());
        }
    }
}
