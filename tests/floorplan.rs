//! Floorplan and structure invariants over many seeds and envelopes, through the real
//! generator pipeline (`generate::generate` with the embedded libraries).

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use glam::{Vec2, Vec3};
use proptest::prelude::*;
use scene_gen::config::GeneratorConfig;
use scene_gen::floorplan::{self, Floorplan, max_rooms};
use scene_gen::generate::generate;
use scene_gen::library::Library;
use scene_gen::scene::{Envelope, OpeningKind, Scene, Semantic};

const EPS: f32 = 1e-3;

/// Envelopes tested: the default, a long and low one, a small one, and two that barely fit.
const ENVELOPES: [(f32, f32, f32); 5] =
    [(15.0, 15.0, 3.0), (20.0, 10.0, 2.8), (10.0, 10.0, 3.0), (5.0, 5.0, 2.5), (10.5, 5.0, 3.0)];

fn config(seed: u64, (width_m, depth_m, height_m): (f32, f32, f32)) -> GeneratorConfig {
    GeneratorConfig { seed, envelope: Envelope { width_m, depth_m, height_m }, ..GeneratorConfig::default() }
}

fn library() -> &'static Library {
    static LIB: std::sync::OnceLock<Library> = std::sync::OnceLock::new();
    LIB.get_or_init(|| Library::embedded().expect("embedded library"))
}

fn scene(config: &GeneratorConfig) -> Scene {
    generate(config, library()).unwrap_or_else(|e| panic!("seed {}: {e}", config.seed))
}

/// Every invariant of a generated house that this branch owns.
fn check(s: &Scene, config: &GeneratorConfig) {
    let plan = Floorplan {
        rooms: s.rooms.clone(),
        walls: s.walls.clone(),
        doors: s.doors.clone(),
        windows: s.windows.clone(),
    };
    check_plan(&plan, config);
    check_structure(s, config);
    check_geometry(s, config);
}

/// Invariants of the floorplan alone (cheap: no geometry, no materials).
fn check_plan(s: &Floorplan, config: &GeneratorConfig) {
    let e = config.envelope;
    let t = config.wall_thickness_m;
    let seed = config.seed;

    // Ids are indices.
    assert!(s.rooms.iter().enumerate().all(|(i, r)| r.id == i as u32));
    assert!(s.walls.iter().enumerate().all(|(i, w)| w.id == i as u32));
    assert!(s.doors.iter().enumerate().all(|(i, d)| d.id == i as u32));
    assert!(s.windows.iter().enumerate().all(|(i, w)| w.id == i as u32));

    // Rooms tile the envelope.
    let area: f32 = s.rooms.iter().map(|r| r.size_m().x * r.size_m().y).sum();
    assert!((area - e.width_m * e.depth_m).abs() < 1e-2, "seed {seed}: area {area}");
    for (i, r) in s.rooms.iter().enumerate() {
        assert!(r.min.cmpge(Vec2::splat(-EPS)).all(), "seed {seed}: {r:?}");
        assert!(r.max.cmple(Vec2::new(e.width_m, e.depth_m) + EPS).all(), "seed {seed}: {r:?}");
        assert!(r.size_m().min_element() >= config.min_room_m - EPS, "seed {seed}: room too small {r:?}");
        for q in &s.rooms[i + 1..] {
            let overlap = (r.max.min(q.max) - r.min.max(q.min)).max(Vec2::ZERO);
            assert!(overlap.x * overlap.y < 1e-4, "seed {seed}: {r:?} overlaps {q:?}");
        }
    }

    // Walls: one room or the outside on each side; exterior walls on the envelope boundary.
    let on_boundary =
        |p: Vec2| p.x.abs() < EPS || p.y.abs() < EPS || (p.x - e.width_m).abs() < EPS || (p.y - e.depth_m).abs() < EPS;
    for w in &s.walls {
        assert!(w.rooms[0].is_some() && w.rooms[0] != w.rooms[1], "seed {seed}: {w:?}");
        let mid = 0.5 * (w.a + w.b);
        assert_eq!(w.is_exterior(), on_boundary(mid), "seed {seed}: {w:?}");
        assert!((w.height_m - e.height_m).abs() < EPS && (w.thickness_m - t).abs() < EPS);
        let mut last_end = 0.2;
        for o in &w.openings {
            let (o0, o1) = (o.offset_m - 0.5 * o.width_m, o.offset_m + 0.5 * o.width_m);
            assert!(o0 >= last_end - EPS, "seed {seed}: openings overlap or sit at the wall end: {w:?}");
            last_end = o1;
            assert!(o.sill_m + o.height_m <= e.height_m - 0.1, "seed {seed}: no lintel {o:?}");
        }
        if !w.openings.is_empty() {
            assert!(last_end <= w.length_m() - 0.2 + EPS, "seed {seed}: opening at the wall end: {w:?}");
        }
    }

    // Doors.
    assert!(s.doors.iter().any(|d| d.rooms[1].is_none()), "seed {seed}: no exterior door");
    for d in &s.doors {
        let w = &s.walls[d.wall as usize];
        assert_eq!(d.rooms, w.rooms, "seed {seed}");
        assert!((0.8 - EPS..=1.0 + EPS).contains(&d.width_m), "seed {seed}: door width {}", d.width_m);
        assert!((1.95 - EPS..=2.05 + EPS).contains(&d.height_m), "seed {seed}: door height {}", d.height_m);
        assert!((d.center.z - 0.5 * d.height_m).abs() < EPS);
        assert!(distance_to_segment(d.center.truncate(), w.a, w.b) < EPS, "seed {seed}: door off its wall");
        assert!((d.normal.length() - 1.0).abs() < 1e-4);
        let room0 = &s.rooms[d.rooms[0].unwrap() as usize];
        assert!(d.normal.dot(d.center.truncate() - room0.center()) > 0.0, "seed {seed}: normal points into room a");
        if let Some(b) = d.rooms[1] {
            let room1 = &s.rooms[b as usize];
            assert!(d.normal.dot(room1.center() - d.center.truncate()) > 0.0, "seed {seed}: normal misses room b");
        }
        assert_eq!(
            w.openings.iter().filter(|o| o.kind == OpeningKind::Door && o.id == d.id).count(),
            1,
            "seed {seed}: door {} has no opening in wall {}",
            d.id,
            w.id
        );
    }

    // Front doors open into rooms whose type allows one, when some such room has an exterior wall.
    let allows = |room: u32| {
        let t = &s.rooms[room as usize].room_type;
        library().rooms.iter().find(|rt| &rt.name == t).is_some_and(|rt| rt.rules.entrance)
    };
    if s.walls.iter().any(|w| w.rooms[1].is_none() && w.length_m() > 1.5 && allows(w.rooms[0].unwrap())) {
        for d in s.doors.iter().filter(|d| d.rooms[1].is_none()) {
            assert!(
                allows(d.rooms[0].unwrap()),
                "seed {seed}: front door into a {}",
                s.rooms[d.rooms[0].unwrap() as usize].room_type
            );
        }
    }

    // Every room reachable from every other through doors.
    let mut seen = vec![false; s.rooms.len()];
    let mut queue = VecDeque::from([0u32]);
    seen[0] = true;
    while let Some(r) = queue.pop_front() {
        for d in &s.doors {
            if let [Some(a), Some(b)] = d.rooms {
                for (from, to) in [(a, b), (b, a)] {
                    if from == r && !seen[to as usize] {
                        seen[to as usize] = true;
                        queue.push_back(to);
                    }
                }
            }
        }
    }
    assert!(seen.iter().all(|&x| x), "seed {seed}: unreachable rooms {seen:?}");

    // Windows only in exterior walls, facing out, at least one per room with an exterior wall.
    for win in &s.windows {
        let w = &s.walls[win.wall as usize];
        assert_eq!(w.rooms, [Some(win.room), None], "seed {seed}: window in an interior wall");
        let out = win.center.truncate() + win.normal * 0.5;
        assert!(
            out.x < 0.0 || out.y < 0.0 || out.x > e.width_m || out.y > e.depth_m,
            "seed {seed}: window normal points inwards"
        );
        assert!((0.8 - EPS..=2.0 + EPS).contains(&win.width_m), "seed {seed}: window width {}", win.width_m);
        let sill = win.center.z - 0.5 * win.height_m;
        assert!((0.8 - EPS..=1.0 + EPS).contains(&sill), "seed {seed}: sill {sill}");
        assert!((1.0 - EPS..=1.4 + EPS).contains(&win.height_m), "seed {seed}: window height {}", win.height_m);
        assert!(w.openings.iter().any(|o| o.kind == OpeningKind::Window && o.id == win.id));
    }
    for r in &s.rooms {
        if s.walls.iter().any(|w| w.rooms == [Some(r.id), None]) {
            assert!(s.windows.iter().any(|w| w.room == r.id), "seed {seed}: room {} has no window", r.id);
        }
    }

    // Plan rules of the room library.
    let n = s.rooms.len() as u32;
    for rt in &library().rooms {
        let count = s.rooms.iter().filter(|r| r.room_type == rt.name).count() as u32;
        let rules = &rt.rules;
        if n < rules.min_plan_rooms {
            assert_eq!(count, 0, "seed {seed}: {} in a {n}-room plan", rt.name);
            continue;
        }
        assert!(count >= rules.min_per_plan, "seed {seed}: too few {}", rt.name);
        assert!(count <= rules.max_per_plan.unwrap_or(u32::MAX), "seed {seed}: too many {}", rt.name);
        if rules.required_from_rooms.is_some_and(|from| n >= from) {
            assert!(count >= 1, "seed {seed}: no {} in a {n}-room plan", rt.name);
        }
        for r in s.rooms.iter().filter(|r| r.room_type == rt.name) {
            assert!(r.size_m().x * r.size_m().y >= rules.min_area_m2 - EPS);
        }
    }
    if n >= 3 {
        assert!(s.rooms.iter().any(|r| r.room_type == "bathroom"), "seed {seed}: no bathroom");
    }
    // prefer_area: the living room is the largest room, a bathroom the smallest.
    let area = |r: &scene_gen::scene::Room| r.size_m().x * r.size_m().y;
    let largest = s.rooms.iter().map(area).fold(0.0, f32::max);
    let smallest = s.rooms.iter().map(area).fold(f32::INFINITY, f32::min);
    let living: Vec<_> = s.rooms.iter().filter(|r| r.room_type == "living_room").collect();
    assert_eq!(living.len(), 1, "seed {seed}: living rooms");
    assert!(area(living[0]) >= largest - EPS, "seed {seed}: the living room is not the largest room");
    if n >= 3 {
        assert!(
            s.rooms.iter().any(|r| r.room_type == "bathroom" && area(r) <= smallest + EPS),
            "seed {seed}: no bathroom is the smallest room"
        );
    }
}

/// Thresholds: exactly one per door, inside the door opening.
fn check_structure(s: &Scene, config: &GeneratorConfig) {
    let t = config.wall_thickness_m;
    let seed = s.seed;
    assert!(s.thresholds.iter().enumerate().all(|(i, th)| th.id == i as u32));
    // Exactly one threshold in each door opening, inside the opening's box.
    assert_eq!(s.thresholds.len(), s.doors.len());
    let instance_ids: BTreeSet<u32> = s.thresholds.iter().map(|th| th.instance_id).collect();
    assert_eq!(instance_ids, (1..=s.thresholds.len() as u32).collect());
    for d in &s.doors {
        let w = &s.walls[d.wall as usize];
        let dir = (w.b - w.a).normalize().extend(0.0);
        let across = d.normal.extend(0.0);
        let c = d.center.truncate().extend(0.0);
        let corners = [
            c - dir * 0.5 * d.width_m - across * 0.5 * t,
            c + dir * 0.5 * d.width_m + across * 0.5 * t + Vec3::Z * d.height_m,
        ];
        let (bmin, bmax) = (corners[0].min(corners[1]), corners[0].max(corners[1]));
        let inside: Vec<_> =
            s.thresholds.iter().filter(|th| th.min.cmpge(bmin - EPS).all() && th.max.cmple(bmax + EPS).all()).collect();
        assert_eq!(inside.len(), 1, "seed {seed}: door {} has {} thresholds", d.id, inside.len());
        let th = inside[0];
        assert_eq!(th.door, d.id);
        let height = th.max.z - th.min.z;
        assert!(th.min.z.abs() < 1e-5 && (0.02 - 1e-4..=0.05 + 1e-4).contains(&height), "seed {seed}: {th:?}");
        let span = (th.max - th.min).truncate().dot((w.b - w.a).normalize()).abs();
        assert!(span > d.width_m - 0.01, "seed {seed}: threshold does not span the door: {th:?}");
    }
}

fn distance_to_segment(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

fn check_geometry(s: &Scene, config: &GeneratorConfig) {
    let seed = s.seed;
    let g = &s.geometry;
    let h = config.envelope.height_m;
    let t = config.wall_thickness_m;
    for mesh in &g.meshes {
        for p in &mesh.primitives {
            let n = p.positions.len();
            assert!(n > 0 && p.normals.len() == n && p.uvs.len() == n, "seed {seed}: {}", mesh.name);
            assert!(p.indices.len() % 3 == 0 && p.indices.iter().all(|&i| (i as usize) < n));
            assert!(p.positions.iter().all(|v| v.is_finite()) && p.uvs.iter().all(|v| v.is_finite()));
            assert!(p.normals.iter().all(|v| (v.length() - 1.0).abs() < 1e-4), "seed {seed}: {}", mesh.name);
            assert!(p.material < g.materials.len());
            for tri in p.indices.chunks(3) {
                let [a, b, c] = [0, 1, 2].map(|k| p.positions[tri[k] as usize]);
                let face = (b - a).cross(c - a);
                let normal = p.normals[tri[0] as usize];
                assert!(face.dot(normal) > 0.0, "seed {seed}: {} has a clockwise or degenerate triangle", mesh.name);
            }
        }
    }
    // Floors at z = 0 facing up, ceilings at the envelope height facing down, one per room.
    for (kind, z, normal) in [("floor", 0.0, Vec3::Z), ("ceiling", h, Vec3::NEG_Z)] {
        let mut rooms = BTreeSet::new();
        for node in &g.nodes {
            let room = match (kind, node.semantic) {
                ("floor", Semantic::Floor { room }) | ("ceiling", Semantic::Ceiling { room }) => room,
                _ => continue,
            };
            rooms.insert(room);
            let r = &s.rooms[room as usize];
            let (lo, hi) = r.interior(t);
            for p in &g.meshes[node.mesh].primitives {
                let world: Vec<Vec3> = p.positions.iter().map(|&v| node.transform.transform_point3(v)).collect();
                assert!(world.iter().all(|v| (v.z - z).abs() < 1e-5), "seed {seed}: {kind} not at {z}");
                assert!(p.normals.iter().all(|&n| n == normal));
                let (min, max) = bounds(&world);
                assert!(
                    (min.truncate() - lo).abs().max_element() < 1e-4
                        && (max.truncate() - hi).abs().max_element() < 1e-4
                );
            }
        }
        assert_eq!(rooms.len(), s.rooms.len(), "seed {seed}: {kind}s");
    }
    // Walls: every junction square is solid, and no two wall boxes share volume.
    let wall_boxes: Vec<(Vec3, Vec3)> = g
        .nodes
        .iter()
        .filter(|n| matches!(n.semantic, Semantic::Wall { .. }))
        .map(|n| bounds(&g.meshes[n.mesh].primitives.iter().flat_map(|p| p.positions.clone()).collect::<Vec<_>>()))
        .collect();
    assert_eq!(wall_boxes.len(), s.walls.len());
    for w in &s.walls {
        for end in [w.a, w.b] {
            for corner in [Vec2::new(-1.0, -1.0), Vec2::new(1.0, -1.0), Vec2::new(1.0, 1.0), Vec2::new(-1.0, 1.0)] {
                let q = (end + corner * 0.45 * t).extend(0.5 * h);
                assert!(
                    wall_boxes.iter().any(|(min, max)| q.cmpge(*min).all() && q.cmple(*max).all()),
                    "seed {seed}: gap at the corner {end} of wall {}",
                    w.id
                );
            }
        }
    }
    for (i, a) in wall_boxes.iter().enumerate() {
        for b in &wall_boxes[i + 1..] {
            let d = (a.1.min(b.1) - a.0.max(b.0)).max(Vec3::ZERO);
            assert!(d.min_element() < 1e-4, "seed {seed}: wall boxes overlap: {a:?} {b:?}");
        }
    }
    // Wall solids are closed except at their ends (butt joints leave no cap): the area vectors
    // of their faces sum to zero across and up the wall. Frames and thresholds are closed boxes.
    for node in &g.nodes {
        let along = match node.semantic {
            Semantic::Wall { wall } => (s.walls[wall as usize].b - s.walls[wall as usize].a).normalize().extend(0.0),
            Semantic::Threshold { .. } | Semantic::Opening { .. } => Vec3::ZERO,
            _ => continue,
        };
        let mut sum = Vec3::ZERO;
        for p in &g.meshes[node.mesh].primitives {
            for tri in p.indices.chunks(3) {
                let [a, b, c] = [0, 1, 2].map(|k| p.positions[tri[k] as usize]);
                sum += 0.5 * (b - a).cross(c - a);
            }
        }
        let residual = sum - along * sum.dot(along);
        assert!(residual.length() < 1e-3, "seed {seed}: {} is not closed: {residual}", node.name);
    }
    // Thresholds and window frames have nodes with their semantics.
    let threshold_nodes = g.nodes.iter().filter(|n| matches!(n.semantic, Semantic::Threshold { .. })).count();
    assert_eq!(threshold_nodes, s.thresholds.len());
    let frames: BTreeSet<u32> = g
        .nodes
        .iter()
        .filter_map(|n| match n.semantic {
            Semantic::Opening { kind: OpeningKind::Window, id } => Some(id),
            _ => None,
        })
        .collect();
    assert_eq!(frames, (0..s.windows.len() as u32).collect());
}

fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    points.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)))
}

/// Seeds per envelope run through the whole pipeline (materials included); plan-only checks run
/// over 1000 seeds per envelope in `every_plan_is_valid_over_many_seeds`.
const FULL_PIPELINE_SEEDS: u64 = 500;

#[test]
fn every_seed_gives_a_valid_house_in_every_envelope() {
    for envelope in ENVELOPES {
        for seed in 0..FULL_PIPELINE_SEEDS {
            let config = config(seed, envelope);
            check(&scene(&config), &config);
        }
    }
}

#[test]
fn every_plan_is_valid_over_many_seeds() {
    for envelope in ENVELOPES {
        for seed in 0..1000 {
            let config = config(seed, envelope);
            check_plan(&floorplan::generate(&config, &library().rooms).unwrap(), &config);
        }
    }
}

#[test]
fn room_counts_span_one_to_the_most_that_fit() {
    for envelope in ENVELOPES {
        let most = max_rooms(envelope.0, envelope.1, 5.0);
        let mut counts = BTreeMap::new();
        let mut layouts = BTreeSet::new();
        for seed in 0..500 {
            let plan = floorplan::generate(&config(seed, envelope), &library().rooms).unwrap();
            *counts.entry(plan.rooms.len() as u32).or_insert(0) += 1;
            layouts.insert(format!("{:?}", plan.rooms.iter().map(|r| (r.min, r.max)).collect::<Vec<_>>()));
        }
        assert_eq!(counts.keys().copied().collect::<Vec<_>>(), (1..=most).collect::<Vec<_>>(), "{envelope:?}");
        if envelope == ENVELOPES[0] {
            assert_eq!(most, 9);
            // Every count is common, not a fluke.
            assert!(counts.values().all(|&c| c >= 20), "{counts:?}");
            assert!(layouts.len() > 200, "only {} distinct layouts", layouts.len());
        }
        if most > 1 {
            assert!(layouts.len() > most as usize, "{envelope:?}: {} layouts", layouts.len());
        }
    }
}

#[test]
fn same_seed_same_scene() {
    let c = config(42, ENVELOPES[0]);
    assert_eq!(scene(&c), scene(&c));
    assert_ne!(scene(&c).rooms, scene(&config(43, ENVELOPES[0])).rooms);
}

#[test]
fn unmeetable_rules_name_the_rule() {
    let mut lib = library().clone();
    for rt in &mut lib.rooms {
        rt.rules.min_per_plan = 2;
        rt.rules.max_per_plan = None;
        rt.rules.min_plan_rooms = 1;
    }
    let err = floorplan::generate(&config(0, (5.0, 5.0, 3.0)), &lib.rooms).unwrap_err();
    assert!(err.to_string().contains("min_per_plan"), "{err}");

    let mut lib = library().clone();
    for rt in &mut lib.rooms {
        rt.rules.max_per_plan = Some(0);
        rt.rules.min_per_plan = 0;
        rt.rules.required_from_rooms = None;
    }
    let err = floorplan::generate(&config(0, (15.0, 15.0, 3.0)), &lib.rooms).unwrap_err();
    assert!(err.to_string().contains("max_per_plan"), "{err}");

    let mut lib = library().clone();
    let bath = lib.rooms.iter_mut().find(|r| r.name == "bathroom").unwrap();
    bath.rules.min_area_m2 = 1000.0;
    let err = (0..50)
        .find_map(|seed| floorplan::generate(&config(seed, (15.0, 15.0, 3.0)), &lib.rooms).err())
        .expect("some plan needs a bathroom");
    assert!(err.to_string().contains("'bathroom'") && err.to_string().contains("min_area_m2"), "{err}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// Any seed, any envelope from 5 m up: a valid house.
    #[test]
    fn any_seed_any_envelope(seed in any::<u64>(), w in 5.0f32..22.0, d in 5.0f32..22.0, h in 2.2f32..3.5) {
        let config = config(seed, (w, d, h));
        check(&scene(&config), &config);
    }
}
