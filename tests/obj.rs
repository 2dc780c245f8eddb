//! OBJ export read back with tobj: the same labelled objects, with the same bounds as the
//! manifest (within 1 mm), and every texture the MTL names is written.

use std::collections::BTreeMap;

use glam::Vec3;
use scene_gen::config::GeneratorConfig;
use scene_gen::export::obj::to_obj;
use scene_gen::generate::generate;
use scene_gen::library::Library;

/// World-frame (Z up) bounds of each OBJ group, merging the models tobj splits per material.
fn group_bounds(obj: &[u8]) -> BTreeMap<String, (Vec3, Vec3)> {
    let (models, _) = tobj::load_obj_buf(
        &mut std::io::Cursor::new(obj),
        &tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() },
        |_| Ok(Default::default()),
    )
    .expect("tobj reads the export");
    let mut bounds = BTreeMap::new();
    for model in models {
        let entry = bounds.entry(model.name.clone()).or_insert((Vec3::MAX, Vec3::MIN));
        for p in model.mesh.positions.chunks_exact(3) {
            let world = Vec3::new(p[0], -p[2], p[1]); // Y-up OBJ back to Z-up world
            entry.0 = entry.0.min(world);
            entry.1 = entry.1.max(world);
        }
    }
    bounds
}

#[test]
fn objects_and_thresholds_round_trip_through_tobj() {
    let library = Library::embedded().unwrap();
    for seed in [1, 7, 42] {
        let scene = generate(&GeneratorConfig { seed, ..GeneratorConfig::default() }, &library).unwrap();
        let files = to_obj(&scene);
        let obj = &files.iter().find(|(n, _)| n == "scene.obj").unwrap().1;
        let bounds = group_bounds(obj);
        let labelled = scene
            .objects
            .iter()
            .map(|o| (format!("{}_{}", o.class, o.id), o.min, o.max))
            .chain(scene.thresholds.iter().map(|t| (format!("threshold_{}", t.id), t.min, t.max)));
        let mut checked = 0;
        for (name, min, max) in labelled {
            let (lo, hi) = bounds.get(&name).unwrap_or_else(|| panic!("seed {seed}: no group {name}"));
            assert!(
                lo.abs_diff_eq(min, 1e-3) && hi.abs_diff_eq(max, 1e-3),
                "seed {seed} {name}: OBJ {lo}..{hi}, manifest {min}..{max}"
            );
            checked += 1;
        }
        assert!(checked > 0, "seed {seed}: no labelled objects to check");
        assert_eq!(bounds.len(), scene.geometry.nodes.len(), "one group per node");
        let text = String::from_utf8(obj.clone()).unwrap();
        let objects: Vec<&str> = text.lines().filter_map(|l| l.strip_prefix("o ")).collect();
        let groups: Vec<&str> = text.lines().filter_map(|l| l.strip_prefix("g ")).collect();
        assert_eq!(objects.len(), scene.geometry.nodes.len(), "seed {seed}: one `o` line per node");
        assert_eq!(objects, groups, "seed {seed}: each object's group has its name");
        let mtl = String::from_utf8(files.iter().find(|(n, _)| n == "scene.mtl").unwrap().1.clone()).unwrap();
        for line in mtl.lines().filter_map(|l| l.strip_prefix("map_Kd ")) {
            assert!(files.iter().any(|(n, _)| n == line), "seed {seed}: MTL names missing texture {line}");
        }
    }
}
