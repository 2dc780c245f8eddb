//! The agent's walk over many generated houses: it stays in free space, moves in small steps,
//! passes every door (so steps over every threshold) and visits every room, deterministically.

use scene_gen::config::GeneratorConfig;
use scene_gen::generate::generate;
use scene_gen::library::Library;
use scene_gen::scene::Scene;
use scene_gen::trajectory::{TrajectoryParams, clearance_m, plan};

/// Seeds checked; each generates a house and plans its walk.
const SEEDS: u64 = 200;

fn check(scene: &Scene) {
    let params = TrajectoryParams::default();
    let t = plan(scene, &params).unwrap_or_else(|e| panic!("seed {}: {e}", scene.seed));
    let seed = scene.seed;
    assert!(t.poses.len() > 2, "seed {seed}: {} poses", t.poses.len());
    // Free space: the disc of the radius used, less half a cell's diagonal (grid rounding).
    let margin = t.radius_m - 0.5 * params.cell_m * std::f32::consts::SQRT_2 - 1e-3;
    for (k, p) in t.poses.iter().enumerate() {
        let c = clearance_m(scene, p.position.truncate());
        assert!(c > 0.0 && c >= margin, "seed {seed}: pose {k} at {} has clearance {c} m", p.position);
        assert!((p.position.z - params.height_m).abs() < 1e-6);
    }
    for (k, w) in t.poses.windows(2).enumerate() {
        let d = w[0].position.distance(w[1].position);
        assert!(d <= 0.3, "seed {seed}: poses {k}..{} are {d} m apart", k + 1);
        assert!(w[1].time_s > w[0].time_s, "seed {seed}: time does not advance at pose {k}");
    }
    for th in &scene.thresholds {
        assert!(
            t.crossings.iter().any(|c| c.threshold_id == th.id),
            "seed {seed}: threshold {} (door {}) is never crossed",
            th.id,
            th.door
        );
    }
    for c in &t.crossings {
        assert!(c.pose_index < t.poses.len() && (t.poses[c.pose_index].time_s - c.time_s).abs() < 1e-6);
    }
    for room in &scene.rooms {
        let (lo, hi) = room.interior(scene.wall_thickness_m);
        assert!(
            t.poses.iter().any(|p| p.position.truncate().cmpge(lo).all() && p.position.truncate().cmple(hi).all()),
            "seed {seed}: room {} is never visited",
            room.id
        );
    }
    assert_eq!(plan(scene, &params).unwrap(), t, "seed {seed}: not deterministic");
}

#[test]
fn walks_are_free_dense_and_cross_every_threshold() {
    let library = Library::embedded().unwrap();
    let mut fallbacks = 0;
    for seed in 0..SEEDS {
        let scene = generate(&GeneratorConfig { seed, ..GeneratorConfig::default() }, &library).unwrap();
        check(&scene);
        if plan(&scene, &TrajectoryParams::default()).unwrap().radius_m < 0.25 {
            fallbacks += 1;
        }
    }
    // The placement keeps 0.8 m walkways between doors, so the nominal radius nearly always fits.
    assert!(fallbacks * 10 <= SEEDS, "{fallbacks} of {SEEDS} houses needed a smaller agent");
}

/// House 1228: a bedroom's door leaf, swung wide between its doorway and a table that stands
/// against a bed, once closed the room's only way to its other door (no walk even for a 0.1 m
/// agent). Leaves keep their room passable now, so the nominal agent walks the house.
#[test]
fn a_door_leaf_never_closes_the_way_through_its_room() {
    let library = Library::embedded().unwrap();
    let scene = generate(&GeneratorConfig { seed: 1228, ..GeneratorConfig::default() }, &library).unwrap();
    check(&scene);
    assert_eq!(plan(&scene, &TrajectoryParams::default()).unwrap().radius_m, 0.25);
}
