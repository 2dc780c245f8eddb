//! Furniture library and placement invariants, over hundreds of seeds, on hand-built floorplans
//! (several rooms, doors between them, exterior doors, windows) and through `generate()`.

use std::collections::{BTreeSet, VecDeque};

use glam::{Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use scene_gen::assets::{AssetMesh, AssetPart};
use scene_gen::config::GeneratorConfig;
use scene_gen::floorplan::Floorplan;
use scene_gen::generate::generate;
use scene_gen::library::{Library, LibrarySource};
use scene_gen::materials::MaterialCatalog;
use scene_gen::placement::{self, PlacedBy};
use scene_gen::scene::{Door, Furnishing, FurnishingKind, Geometry, Object, ObjectClass, Room, Semantic, Window};

#[allow(dead_code)]
#[path = "../examples/generate_furniture.rs"]
mod generate_furniture;

const WALL_M: f32 = 0.1;

/// The embedded library: every variant a generator.
fn library() -> Library {
    static LIBRARY: std::sync::OnceLock<Library> = std::sync::OnceLock::new();
    LIBRARY.get_or_init(|| Library::embedded().expect("embedded library loads")).clone()
}

/// The OBJ sample library (`examples/furniture_obj`), as `--furniture` loads it.
fn obj_library() -> Library {
    static LIBRARY: std::sync::OnceLock<Library> = std::sync::OnceLock::new();
    LIBRARY
        .get_or_init(|| {
            let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furniture_obj");
            Library::load(LibrarySource::Embedded, LibrarySource::Folder(&root)).expect("OBJ library loads")
        })
        .clone()
}

#[test]
fn libraries_have_three_variants_with_normals_and_uvs_per_class() {
    for (lib, max_triangles) in [(obj_library(), 500), (library(), 6000)] {
        check_variants(&lib, max_triangles);
    }
    assert!(library().furniture.iter().flat_map(|c| &c.variants).all(|v| v.generator.is_some()));
    assert!(obj_library().furniture.iter().flat_map(|c| &c.variants).all(|v| v.generator.is_none()));
}

fn check_variants(lib: &Library, max_triangles: usize) {
    for class in ObjectClass::ALL {
        let entry = lib.furniture_class(class).unwrap_or_else(|| panic!("no class {class}"));
        assert!(entry.variants.len() >= 3, "{class}: {} variants", entry.variants.len());
        for v in &entry.variants {
            assert!(v.had_normals && v.had_uvs, "{class}/{}: normals {} uvs {}", v.name, v.had_normals, v.had_uvs);
            let tris = v.mesh.triangle_count();
            assert!((12..=max_triangles).contains(&tris), "{class}/{}: {tris} triangles", v.name);
            assert!(v.mesh.min.z.abs() < 1e-6 && (v.mesh.min.x + v.mesh.max.x).abs() < 1e-4);
            for part in &v.mesh.parts {
                assert!(MaterialCatalog::is_surface(&part.surface), "{class}/{}: {}", v.name, part.surface);
                assert!(part.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-3));
            }
        }
    }
}

#[test]
fn supports_offer_their_real_top() {
    let lib = obj_library();
    for v in &lib.furniture_class(ObjectClass::Table).unwrap().variants {
        let (z, lo, hi) = v.support_top.unwrap_or_else(|| panic!("{} has no top", v.name));
        assert!((z - v.mesh.max.z).abs() < 0.01, "{}: top at {z}, mesh up to {}", v.name, v.mesh.max.z);
        let area = (hi - lo).x * (hi - lo).y;
        assert!(area > 0.3 * v.mesh.size().x * v.mesh.size().y, "{}: top {lo}..{hi}", v.name);
    }
    for v in &lib.furniture_class(ObjectClass::Bed).unwrap().variants {
        // The uncovered mattress (0.52 m in the generator), not the frame under it (0.30 m)
        // nor the headboard.
        let (z, lo, hi) = v.support_top.unwrap_or_else(|| panic!("{} has no top", v.name));
        assert!((z - 0.52).abs() < 0.01, "{}: top at {z}", v.name);
        assert!(hi.y - lo.y > 0.8 && hi.x - lo.x > 0.6, "{}: top {lo}..{hi}", v.name);
    }
}

#[test]
fn generated_supports_offer_their_real_top() {
    let lib = library();
    for v in &lib.furniture_class(ObjectClass::Table).unwrap().variants {
        let generator = v.generator.unwrap();
        for seed in 0..40 {
            let mesh = generator.generate(v.mesh.size(), false, seed);
            let (z, lo, hi) = mesh.support_top().unwrap_or_else(|| panic!("{} {seed}: no top", v.name));
            assert!((z - mesh.max.z).abs() < 0.01, "{} {seed}: top at {z}, mesh up to {}", v.name, mesh.max.z);
            let area = (hi - lo).x * (hi - lo).y;
            assert!(area > 0.3 * mesh.size().x * mesh.size().y, "{} {seed}: top {lo}..{hi}", v.name);
        }
    }
    let bed = &lib.furniture_class(ObjectClass::Bed).unwrap().variants[0];
    for seed in 0..40 {
        let mesh = bed.generator.unwrap().generate(Vec3::new(1.4, 2.0, 1.05), false, seed);
        // The mattress or the duvet on it, not the frame, a pillow or the headboard.
        let (z, lo, hi) = mesh.support_top().unwrap_or_else(|| panic!("bed {seed}: no top"));
        assert!((0.4..0.75).contains(&z), "bed {seed}: top at {z}");
        assert!(hi.y - lo.y > 0.5 && hi.x - lo.x > 0.6, "bed {seed}: top {lo}..{hi}");
    }
}

#[test]
fn generator_reproduces_committed_files() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furniture_obj");
    let generated = generate_furniture::generated_files();
    for (path, text) in &generated {
        let committed = std::fs::read_to_string(root.join(path)).unwrap_or_else(|e| panic!("{path}: {e}"));
        assert!(
            committed == *text,
            "examples/furniture_obj/{path} differs from the generator's output: run the example"
        );
    }
    // Every committed mesh is one the generator writes.
    for dir in std::fs::read_dir(&root).unwrap() {
        let dir = dir.unwrap().path();
        if !dir.is_dir() {
            continue;
        }
        for f in std::fs::read_dir(&dir).unwrap() {
            let f = f.unwrap().path();
            if f.extension().is_some_and(|e| e == "obj" || e == "mtl") {
                let rel = f.strip_prefix(&root).unwrap().to_string_lossy().replace('\\', "/");
                assert!(generated.iter().any(|(p, _)| *p == rel), "{rel} is not generated");
            }
        }
    }
}

/// A grid house of `nx` x `ny` rectangular rooms with random splits, a door between every
/// pair of neighbours at a random position, an exterior door and windows on the north side.
fn random_plan(seed: u64, lib: &Library) -> Floorplan {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (nx, ny) = (rng.random_range(1..=3_usize), rng.random_range(1..=2_usize));
    let mut axis = |n: usize| {
        let mut v = vec![0.0_f32];
        for _ in 0..n {
            let last = *v.last().unwrap();
            v.push(last + rng.random_range(2.6_f32..6.5));
        }
        v
    };
    let (xs, ys) = (axis(nx), axis(ny));
    let id = |i: usize, j: usize| (j * nx + i) as u32;
    let mut plan = Floorplan::default();
    for j in 0..ny {
        for i in 0..nx {
            let t = &lib.rooms[rng.random_range(0..lib.rooms.len())];
            plan.rooms.push(Room {
                id: id(i, j),
                room_type: t.name.clone(),
                min: Vec2::new(xs[i], ys[j]),
                max: Vec2::new(xs[i + 1], ys[j + 1]),
            });
        }
    }
    let mut door = |rng: &mut ChaCha8Rng, a: u32, b: Option<u32>, at: Vec2, normal: Vec2| {
        let width_m = rng.random_range(0.8_f32..1.0);
        let n = plan.doors.len() as u32;
        plan.doors.push(Door {
            id: n,
            rooms: [Some(a), b],
            wall: 0,
            center: at.extend(1.0),
            width_m,
            height_m: 2.0,
            normal,
            leaf: None,
        });
    };
    let along = |rng: &mut ChaCha8Rng, lo: f32, hi: f32| rng.random_range(lo + 0.6..hi - 0.6);
    for j in 0..ny {
        for i in 0..nx {
            if i + 1 < nx {
                let y = along(&mut rng, ys[j], ys[j + 1]);
                door(&mut rng, id(i, j), Some(id(i + 1, j)), Vec2::new(xs[i + 1], y), Vec2::X);
            }
            if j + 1 < ny {
                let x = along(&mut rng, xs[i], xs[i + 1]);
                door(&mut rng, id(i, j), Some(id(i, j + 1)), Vec2::new(x, ys[j + 1]), Vec2::Y);
            }
        }
    }
    let x = along(&mut rng, xs[0], xs[1]);
    door(&mut rng, id(0, 0), None, Vec2::new(x, 0.0), Vec2::NEG_Y);
    // An exterior door on the west side of the top-left room too, when there are two rows.
    if ny > 1 {
        let y = along(&mut rng, ys[ny - 1], ys[ny]);
        door(&mut rng, id(0, ny - 1), None, Vec2::new(0.0, y), Vec2::NEG_X);
    }
    for i in 0..nx {
        if rng.random_bool(0.7) {
            let width_m = rng.random_range(0.8_f32..1.6).min(xs[i + 1] - xs[i] - 0.4);
            let x = rng.random_range(xs[i] + 0.2 + width_m / 2.0..=xs[i + 1] - 0.2 - width_m / 2.0);
            let n = plan.windows.len() as u32;
            plan.windows.push(Window {
                id: n,
                room: id(i, ny - 1),
                wall: 0,
                center: Vec3::new(x, ys[ny], 1.5),
                width_m,
                height_m: 1.2,
                normal: Vec2::Y,
            });
        }
    }
    plan
}

fn overlap_area(a: &Object, b: &Object) -> f32 {
    let w = (a.max.x.min(b.max.x) - a.min.x.max(b.min.x)).max(0.0);
    let h = (a.max.y.min(b.max.y) - a.min.y.max(b.min.y)).max(0.0);
    w * h
}

fn rect_hits(obj: &Object, min: Vec2, max: Vec2) -> bool {
    obj.min.x < max.x - 1e-4 && min.x < obj.max.x - 1e-4 && obj.min.y < max.y - 1e-4 && min.y < obj.max.y - 1e-4
}

/// A door-relative rectangle: `lateral` along the wall, `depth` into `room` from the wall
/// centre line.
fn door_rect(door: &Door, inward: Vec2, lateral: f32, depth: f32) -> (Vec2, Vec2) {
    let c = door.center.truncate();
    let t = Vec2::new(-inward.y, inward.x);
    let pts = [c + t * lateral, c - t * lateral, c + t * lateral + inward * depth, c - t * lateral + inward * depth];
    (pts.iter().fold(Vec2::MAX, |a, p| a.min(*p)), pts.iter().fold(Vec2::MIN, |a, p| a.max(*p)))
}

fn inward(door: &Door, room: u32) -> Option<Vec2> {
    if door.rooms[0] == Some(room) {
        Some(-door.normal)
    } else if door.rooms[1] == Some(room) {
        Some(door.normal)
    } else {
        None
    }
}

/// True when an agent 0.6 m wide (a 0.3 m box around its centre, on a 5 cm grid) can walk
/// between every pair of doors of the room and reach open floor (1.5 m^2, or less in a tiny
/// room). Placement keeps 0.8 m passages; the narrower agent leaves room for grid rounding.
fn doors_connected(plan: &Floorplan, room: &Room, objects: &[Object]) -> Result<(), String> {
    const CELL: f32 = 0.05;
    const RADIUS: f32 = 0.3;
    let (lo, hi) = room.interior(WALL_M);
    let (w, h) = (((hi.x - lo.x) / CELL) as usize, ((hi.y - lo.y) / CELL) as usize);
    let blocked: Vec<bool> = (0..w * h)
        .map(|k| {
            let p = lo + Vec2::new((k % w) as f32 + 0.5, (k / w) as f32 + 0.5) * CELL;
            objects.iter().any(|o| {
                p.x > o.min.x - RADIUS && p.x < o.max.x + RADIUS && p.y > o.min.y - RADIUS && p.y < o.max.y + RADIUS
            })
        })
        .collect();
    let cell = |p: Vec2| {
        let q = ((p - lo) / CELL).floor();
        (q.x.clamp(0.0, w as f32 - 1.0) as usize) + (q.y.clamp(0.0, h as f32 - 1.0) as usize) * w
    };
    let entries: Vec<(u32, usize)> = plan
        .doors
        .iter()
        .filter_map(|d| {
            inward(d, room.id).map(|n| (d.id, cell(d.center.truncate() + n * (WALL_M * 0.5 + RADIUS + 0.05))))
        })
        .collect();
    let Some(&(_, start)) = entries.first() else { return Ok(()) };
    if blocked[start] {
        return Err(format!("room {}: a door entry is blocked", room.id));
    }
    let mut seen = vec![false; w * h];
    let mut queue = VecDeque::from([start]);
    seen[start] = true;
    let mut reached = 0;
    while let Some(k) = queue.pop_front() {
        reached += 1;
        let (x, y) = (k % w, k / w);
        let nbrs =
            [(x > 0).then(|| k - 1), (x + 1 < w).then(|| k + 1), (y > 0).then(|| k - w), (y + 1 < h).then(|| k + w)];
        for n in nbrs.into_iter().flatten() {
            if !seen[n] && !blocked[n] {
                seen[n] = true;
                queue.push_back(n);
            }
        }
    }
    if let Some((door, _)) = entries.iter().find(|(_, e)| !seen[*e]) {
        return Err(format!("room {}: door {door} cannot be reached from door {}", room.id, entries[0].0));
    }
    let open_m2 = reached as f32 * CELL * CELL;
    let size = hi - lo;
    let want = (1.5_f32).min(0.45 * (size.x - 0.8) * (size.y - 0.8));
    if open_m2 < want {
        return Err(format!("room {}: only {open_m2} m^2 reachable from the doors", room.id));
    }
    Ok(())
}

/// [`AssetMesh::support_top`] of a scene mesh, in its own frame.
fn support_top(mesh: &scene_gen::scene::Mesh) -> Option<(f32, Vec2, Vec2)> {
    let parts: Vec<AssetPart> = mesh
        .primitives
        .iter()
        .map(|p| AssetPart {
            surface: String::new(),
            positions: p.positions.clone(),
            normals: p.normals.clone(),
            uvs: p.uvs.clone(),
            indices: p.indices.clone(),
        })
        .collect();
    let (min, max) =
        parts.iter().flat_map(|p| &p.positions).fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    AssetMesh { parts, min, max }.support_top()
}

/// Checks every placement invariant of one furnished plan; `placed_by` when known.
/// The placed furniture of one plan: the objects and the furnishings, each with the rule that
/// placed it when known.
struct Furnished<'a> {
    objects: &'a [Object],
    placed_by: Option<&'a [PlacedBy]>,
    furnishings: &'a [Furnishing],
    furnishings_placed_by: Option<&'a [PlacedBy]>,
}

/// A furnishing seen as a floor object for the checks objects and furnishings share; its
/// class is a stand-in the checks never read for furnishings.
fn as_floor_object(f: &Furnishing) -> Object {
    Object {
        id: f.id,
        class: ObjectClass::Sofa,
        instance_id: 0,
        room: f.room,
        asset: f.asset.clone(),
        min: f.min,
        max: f.max,
        yaw_deg: f.yaw_deg,
        on: None,
    }
}

fn check(
    lib: &Library,
    plan: &Floorplan,
    furnished: &Furnished<'_>,
    geometry: &Geometry,
    first_instance_id: u32,
) -> Result<(), String> {
    const EPS: f32 = 1e-3;
    let objects = furnished.objects;
    // Objects first, then furnishings: (item, its node's semantic, is a furnishing, rule).
    let mut items: Vec<(Object, Semantic, bool, Option<PlacedBy>)> = Vec::new();
    for (i, o) in objects.iter().enumerate() {
        items.push((o.clone(), Semantic::Object { id: o.id }, false, furnished.placed_by.map(|b| b[i])));
    }
    for (i, f) in furnished.furnishings.iter().enumerate() {
        if f.id != i as u32 {
            return Err(format!("furnishing {} ({}): ids not consecutive", f.id, f.asset));
        }
        let by = furnished.furnishings_placed_by.map(|b| b[i]);
        items.push((as_floor_object(f), Semantic::Furnishing { id: f.id }, true, by));
    }
    for (i, (o, semantic, is_furnishing, by)) in items.iter().enumerate() {
        let is_furnishing = *is_furnishing;
        let kind =
            if is_furnishing { o.asset.split('/').next().unwrap_or("?").to_string() } else { o.class.to_string() };
        let tag = format!("{} {} ({}, {kind})", if is_furnishing { "furnishing" } else { "object" }, o.id, o.asset);
        if !is_furnishing && (o.id != i as u32 || o.instance_id != first_instance_id + i as u32) {
            return Err(format!("{tag}: ids not consecutive"));
        }
        let room = plan.rooms.iter().find(|r| r.id == o.room).ok_or(format!("{tag}: no room"))?;
        let (lo, hi) = room.interior(WALL_M);
        if o.min.x < lo.x - EPS || o.min.y < lo.y - EPS || o.max.x > hi.x + EPS || o.max.y > hi.y + EPS {
            return Err(format!("{tag}: outside the interior of room {}", room.id));
        }
        // Node transform reproduces the manifest box.
        let node = geometry.nodes.iter().find(|n| n.semantic == *semantic).ok_or(format!("{tag}: no node"))?;
        if node.name != format!("{kind}_{}", o.id) {
            return Err(format!("{tag}: node name {}", node.name));
        }
        let (mut bmin, mut bmax) = (Vec3::MAX, Vec3::MIN);
        for p in geometry.meshes[node.mesh].primitives.iter().flat_map(|p| &p.positions) {
            let q = node.transform.transform_point3(*p);
            bmin = bmin.min(q);
            bmax = bmax.max(q);
        }
        if (bmin - o.min).abs().max_element() > EPS || (bmax - o.max).abs().max_element() > EPS {
            return Err(format!("{tag}: node box {bmin}..{bmax} != manifest {}..{}", o.min, o.max));
        }
        // Uniformly scaled classes (balls, plants, lamps) keep their proportions.
        if !is_furnishing && lib.furniture_class(o.class).is_some_and(|c| c.uniform_scale) {
            let m = node.transform;
            let (sx, sy, sz) = (m.x_axis.length(), m.y_axis.length(), m.z_axis.length());
            if (sx - sz).abs() > 1e-4 * sz || (sy - sz).abs() > 1e-4 * sz {
                return Err(format!("{tag}: uniform class scaled by {sx} {sy} {sz}"));
            }
        }
        match o.on {
            None => {
                if o.min.z.abs() > EPS {
                    return Err(format!("{tag}: floor object floats at {}", o.min.z));
                }
                if (o.yaw_deg / 90.0).fract().abs() > 1e-6 {
                    return Err(format!("{tag}: floor object yaw {}", o.yaw_deg));
                }
            }
            Some(s) => {
                let sup = &objects[s as usize];
                let sup_node = geometry.nodes.iter().find(|n| n.semantic == Semantic::Object { id: s }).unwrap();
                // The support's top, found afresh from the mesh the scene holds.
                let (top_z, _, _) =
                    support_top(&geometry.meshes[sup_node.mesh]).ok_or(format!("{tag}: support has no top"))?;
                let z = sup_node.transform.transform_point3(Vec3::new(0.0, 0.0, top_z)).z;
                if (o.min.z - z).abs() > EPS || o.min.z > sup.max.z + EPS || sup.on.is_some() || sup.room != o.room {
                    return Err(format!("{tag}: does not rest on {} (z {} vs top {z})", sup.asset, o.min.z));
                }
                if o.min.x < sup.min.x - EPS
                    || o.min.y < sup.min.y - EPS
                    || o.max.x > sup.max.x + EPS
                    || o.max.y > sup.max.y + EPS
                {
                    return Err(format!("{tag}: footprint outside its support {}", sup.asset));
                }
            }
        }
        for (other, _, other_is_furnishing, _) in &items[..i] {
            let related = !is_furnishing && !other_is_furnishing && (o.on == Some(other.id) || other.on == Some(o.id));
            if related {
                continue;
            }
            if overlap_area(o, other) > 1e-6 {
                return Err(format!("{tag} intersects object {} ({})", other.id, other.asset));
            }
        }
        for door in &plan.doors {
            let Some(inward) = inward(door, o.room) else { continue };
            let (a, b) = door_rect(door, inward, door.width_m * 0.5 + 0.25, WALL_M * 0.5 + 0.9);
            if rect_hits(o, a, b) {
                return Err(format!("{tag}: in front of door {}", door.id));
            }
        }
        for window in plan.windows.iter().filter(|w| w.room == o.room) {
            let sill = window.center.z - window.height_m * 0.5;
            let fake = Door {
                id: 0,
                rooms: [Some(o.room), None],
                wall: 0,
                center: window.center,
                width_m: window.width_m,
                height_m: 0.0,
                normal: window.normal,
                leaf: None,
            };
            let (a, b) = door_rect(&fake, -window.normal, window.width_m * 0.5, WALL_M * 0.5 + 0.25);
            if o.max.z > sill + EPS && rect_hits(o, a, b) {
                return Err(format!("{tag}: taller than the sill in front of window {}", window.id));
            }
        }
        if let Some(by) = *by {
            if matches!(by, PlacedBy::Wall | PlacedBy::Corner) {
                let gap = match (o.yaw_deg.round() as i32).rem_euclid(360) {
                    0 => o.min.y - lo.y,
                    90 => hi.x - o.max.x,
                    180 => hi.y - o.max.y,
                    _ => o.min.x - lo.x,
                };
                if !(-EPS..=0.05).contains(&gap) {
                    return Err(format!("{tag}: back {gap} m from the wall"));
                }
            }
            if (by == PlacedBy::On) != o.on.is_some() {
                return Err(format!("{tag}: placed_by {by:?} but on {:?}", o.on));
            }
        }
    }
    for room in &plan.rooms {
        let floor: Vec<Object> =
            items.iter().map(|(o, ..)| o).filter(|o| o.room == room.id && o.on.is_none()).cloned().collect();
        doors_connected(plan, room, &floor)?;
    }
    Ok(())
}

#[test]
fn hand_built_plans_keep_every_invariant_over_500_seeds() {
    let lib = library();
    let mut classes = BTreeSet::new();
    let mut on_seen = 0;
    let mut total = 0;
    let mut skipped = 0;
    let mut skipped_by = std::collections::BTreeMap::new();
    for seed in 0..500_u64 {
        let plan = random_plan(seed, &lib);
        let config = GeneratorConfig { seed, ..GeneratorConfig::default() };
        let mut geometry = Geometry::default();
        let mut materials = MaterialCatalog::new(seed);
        let first = 1 + plan.doors.len() as u32;
        let placement =
            placement::place_detailed(&config, &plan, &[], &lib, first, &mut materials, &mut geometry).unwrap();
        let furnished = Furnished {
            objects: &placement.objects,
            placed_by: Some(&placement.placed_by),
            furnishings: &placement.furnishings,
            furnishings_placed_by: Some(&placement.furnishings_placed_by),
        };
        if let Err(e) = check(&lib, &plan, &furnished, &geometry, first) {
            panic!("seed {seed}: {e}");
        }
        // Same seed, same result.
        if seed % 50 == 0 {
            let mut g2 = Geometry::default();
            let again =
                placement::place_detailed(&config, &plan, &[], &lib, first, &mut MaterialCatalog::new(seed), &mut g2)
                    .unwrap();
            assert_eq!(again, placement, "seed {seed} not deterministic");
            assert_eq!(g2, geometry);
        }
        skipped += placement.skipped.len();
        for (room, class) in &placement.skipped {
            let t = &plan.rooms[*room as usize].room_type;
            *skipped_by.entry((t.clone(), *class)).or_insert(0_usize) += 1;
        }
        on_seen += placement.objects.iter().filter(|o| o.on.is_some()).count();
        total += placement.objects.len();
        classes.extend(placement.objects.iter().map(|o| o.class));
    }
    // Figures for the report (`cargo test --test placement hand_built -- --nocapture`).
    println!("500 plans: {total} objects placed, {on_seen} on a support, {skipped} requests skipped");
    println!("skipped by (room type, class): {skipped_by:?}");
    assert_eq!(classes.len(), 10, "classes seen: {classes:?}");
    assert!(skipped * 5 < total, "{skipped} skipped for {total} placed");
    assert!(on_seen > 50, "only {on_seen} objects stood on another");
    assert!(total > 500 * 4, "only {total} objects in 500 plans");
}

#[test]
fn obj_meshes_are_shared_and_generated_shapes_are_not() {
    for seed in 0..6 {
        let lib = obj_library();
        let plan = random_plan(seed, &lib);
        let mut geometry = Geometry::default();
        let config = GeneratorConfig { seed, ..GeneratorConfig::default() };
        let mut materials = MaterialCatalog::new(seed);
        let (objects, furnishings) =
            placement::place(&config, &plan, &[], &lib, 1, &mut materials, &mut geometry).unwrap();
        let names: BTreeSet<&str> = geometry.meshes.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names.len(), geometry.meshes.len(), "a mesh was added twice");
        assert!(geometry.meshes.len() <= objects.len());
        assert!(furnishings.is_empty(), "the OBJ library has no furnishing classes");
        let furnished =
            Furnished { objects: &objects, placed_by: None, furnishings: &furnishings, furnishings_placed_by: None };
        if let Err(e) = check(&lib, &plan, &furnished, &geometry, 1) {
            panic!("OBJ library, seed {seed}: {e}");
        }

        // The embedded library builds a shape per object: as many meshes as objects, no two
        // with the same vertices, and an asset name per object.
        let lib = library();
        let mut geometry = Geometry::default();
        let mut materials = MaterialCatalog::new(seed);
        let (objects, furnishings) =
            placement::place(&config, &plan, &[], &lib, 1, &mut materials, &mut geometry).unwrap();
        assert_eq!(geometry.meshes.len(), objects.len() + furnishings.len(), "seed {seed}");
        let shapes: BTreeSet<Vec<[u32; 3]>> = geometry
            .meshes
            .iter()
            .map(|m| m.primitives.iter().flat_map(|p| &p.positions).map(|p| p.to_array().map(f32::to_bits)).collect())
            .collect();
        assert_eq!(shapes.len(), geometry.meshes.len(), "seed {seed}: two objects share a shape");
        let assets: BTreeSet<&str> = objects.iter().map(|o| o.asset.as_str()).collect();
        assert_eq!(assets.len(), objects.len(), "seed {seed}: two objects share an asset name");
    }
}

#[test]
fn generate_places_furniture_by_the_rules() {
    let lib = library();
    let mut classes = BTreeSet::new();
    let mut kinds = BTreeSet::new();
    let (mut doors, mut leaves, mut curtains, mut tables_with_things) = (0, 0, 0, 0);
    let envelopes = [(15.0, 15.0, 3.0), (20.0, 10.0, 2.8), (10.0, 10.0, 3.0)];
    for (seed, (width_m, depth_m, height_m)) in (0..500_u64).flat_map(|s| envelopes.map(|e| (s, e))) {
        let envelope = scene_gen::scene::Envelope { width_m, depth_m, height_m };
        let config = GeneratorConfig { seed, envelope, ..GeneratorConfig::default() };
        let scene = generate(&config, &lib).unwrap();
        let plan = Floorplan {
            rooms: scene.rooms.clone(),
            walls: scene.walls.clone(),
            doors: scene.doors.clone(),
            windows: scene.windows.clone(),
        };
        let first = scene.thresholds.iter().map(|t| t.instance_id).max().unwrap_or(0) + 1;
        let furnished = Furnished {
            objects: &scene.objects,
            placed_by: None,
            furnishings: &scene.furnishings,
            furnishings_placed_by: None,
        };
        if let Err(e) = check(&lib, &plan, &furnished, &scene.geometry, first) {
            panic!("seed {seed}: {e}");
        }
        assert!(!scene.objects.is_empty(), "seed {seed}: no furniture");
        if let Err(e) =
            check_leaves(&scene).and_then(|()| check_curtains(&scene)).and_then(|()| check_table_things(&scene))
        {
            panic!("seed {seed}, envelope {width_m} x {depth_m}: {e}");
        }
        curtains += scene.geometry.nodes.iter().filter(|n| n.name.starts_with("curtains_")).count();
        tables_with_things += scene.geometry.nodes.iter().filter(|n| n.name.starts_with("table_things_")).count();
        doors += scene.doors.len();
        leaves += scene.doors.iter().filter(|d| d.leaf.is_some()).count();
        classes.extend(scene.objects.iter().map(|o| o.class));
        kinds.extend(scene.furnishings.iter().map(|f| f.kind));
    }
    assert_eq!(classes.len(), 10, "classes seen through generate() over 500 seeds x 3 envelopes: {classes:?}");
    assert_eq!(kinds.len(), FurnishingKind::ALL.len(), "furnishings seen: {kinds:?}");
    assert!(leaves * 100 >= doors * 95, "only {leaves} of {doors} doors have a leaf");
    assert!(curtains > 1000, "{curtains} curtained windows in 1500 houses");
    assert!(tables_with_things > 1000, "small things on {tables_with_things} tables in 1500 houses");
}

/// Every curtain hangs inside its room, and each of its boxes (pleats, rod) is clear of every
/// object and furnishing.
fn check_curtains(scene: &scene_gen::scene::Scene) -> Result<(), String> {
    for node in scene.geometry.nodes.iter().filter(|n| n.name.starts_with("curtains_")) {
        let Semantic::Decor { room } = node.semantic else { return Err(format!("{}: not decor", node.name)) };
        let (rlo, rhi) = scene.room(room).expect("curtain room exists").interior(scene.wall_thickness_m);
        let mesh = &scene.geometry.meshes[node.mesh];
        // The mesh is built of closed boxes, 24 vertices each.
        for cuboid in mesh.primitives.iter().flat_map(|p| p.positions.chunks(24)) {
            let (lo, hi) = cuboid
                .iter()
                .map(|&p| node.transform.transform_point3(p))
                .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| (lo.min(p), hi.max(p)));
            if lo.truncate().cmplt(rlo - 1e-3).any() || hi.truncate().cmpgt(rhi + 1e-3).any() {
                return Err(format!("{}: {lo} .. {hi} leaves room {room}", node.name));
            }
            let boxes =
                scene.objects.iter().map(|o| (o.min, o.max)).chain(scene.furnishings.iter().map(|f| (f.min, f.max)));
            for (min, max) in boxes {
                if min.cmplt(hi - 1e-3).all() && max.cmpgt(lo + 1e-3).all() {
                    return Err(format!("{}: {lo} .. {hi} meets furniture {min} .. {max}", node.name));
                }
            }
        }
    }
    Ok(())
}

/// The small things on a table stand on its top, inside its footprint, and clear of every
/// object (what stands on the table included).
fn check_table_things(scene: &scene_gen::scene::Scene) -> Result<(), String> {
    for node in scene.geometry.nodes.iter().filter(|n| n.name.starts_with("table_things_")) {
        let points: Vec<Vec3> = scene.geometry.meshes[node.mesh]
            .primitives
            .iter()
            .flat_map(|p| &p.positions)
            .map(|&p| node.transform.transform_point3(p))
            .collect();
        let (lo, hi) = points.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let table = scene.objects.iter().find(|t| {
            t.class == ObjectClass::Table
                && lo.truncate().cmpge(t.min.truncate() - 1e-3).all()
                && hi.truncate().cmple(t.max.truncate() + 1e-3).all()
                && (lo.z - t.max.z).abs() < 0.02
        });
        let Some(table) = table else { return Err(format!("{}: {lo} .. {hi} stands on no table top", node.name)) };
        for o in scene.objects.iter().filter(|o| o.id != table.id) {
            if points.iter().any(|p| p.cmpgt(o.min + 1e-3).all() && p.cmplt(o.max - 1e-3).all()) {
                return Err(format!(
                    "{}: a small thing on table {} is inside {} {}",
                    node.name,
                    table.id,
                    o.class.name(),
                    o.id
                ));
            }
        }
    }
    Ok(())
}

#[test]
fn televisions_face_a_sofa_across_the_room() {
    let lib = library();
    let (mut tvs, mut facing) = (0, 0);
    for seed in 0..300 {
        let scene = generate(&GeneratorConfig { seed, ..GeneratorConfig::default() }, &lib).unwrap();
        for tv in scene.objects.iter().filter(|o| o.asset.starts_with("computer/computer_tv")) {
            let sofas: Vec<&Object> =
                scene.objects.iter().filter(|o| o.room == tv.room && o.class == ObjectClass::Sofa).collect();
            if sofas.is_empty() {
                continue;
            }
            tvs += 1;
            let yaw = tv.yaw_deg.to_radians();
            let front = Vec2::new(-yaw.sin(), yaw.cos());
            let centre = |o: &Object| ((o.min + o.max) * 0.5).truncate();
            let faces = sofas.iter().any(|s| {
                let to_sofa = centre(s) - centre(tv);
                ((s.yaw_deg - tv.yaw_deg).rem_euclid(360.0) - 180.0).abs() < 1.0
                    && to_sofa.dot(front) > 0.9 * to_sofa.length()
            });
            facing += usize::from(faces);
        }
    }
    assert!(tvs >= 30, "only {tvs} televisions in rooms with a sofa");
    assert!(facing * 10 >= tvs * 8, "{facing} of {tvs} televisions face a sofa");
    println!("{facing} of {tvs} televisions in a room with a sofa face one");
}

#[test]
fn houses_are_decorated_in_their_palette() {
    let lib = library();
    let mut names = BTreeSet::new();
    for seed in 0..24 {
        let scene = generate(&GeneratorConfig { seed, ..GeneratorConfig::default() }, &lib).unwrap();
        let palette = scene.palette.expect("a generated house has a palette");
        names.insert(palette.name);
        let mut checked = 0;
        for material in &scene.geometry.materials {
            let Some((surface, variant)) = material.name.rsplit_once('_') else { continue };
            let variant: u32 = variant.parse().expect("materials are named <surface>_<variant>");
            if let Some((_, named)) = palette.colours.iter().find(|(s, _)| *s == surface) {
                let base = scene_gen::textures::base_colours(surface).expect("palette surfaces have base colours");
                let colour = base[variant as usize % base.len()];
                assert!(
                    named.contains(&colour),
                    "seed {seed}: {} is {colour:06x}, outside {}",
                    material.name,
                    palette.name
                );
                checked += 1;
            }
        }
        assert!(checked >= 4, "seed {seed}: only {checked} palette surfaces");
        let manifest = scene_gen::manifest::Manifest::of(&scene).to_json();
        assert!(manifest.contains(&format!("\"palette\": \"{}\"", palette.name)));
    }
    assert!(names.len() >= 4, "24 houses drew only {names:?}");
}

/// Distance from `p` to the segment `a..b`.
fn to_segment(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
    p.distance(a + (b - a) * t)
}

/// Every door leaf stands open (90 degrees or more) inside the room it opens into, clear of
/// every piece of furniture, with its node in the geometry, and leaves the doorway passable: the
/// straight walk through the middle of the doorway keeps 0.3 m from it.
fn check_leaves(scene: &scene_gen::scene::Scene) -> Result<(), String> {
    for door in &scene.doors {
        let Some(leaf) = door.leaf else { continue };
        let tag = format!("door {}", door.id);
        if !door.rooms.contains(&Some(leaf.room)) {
            return Err(format!("{tag}: leaf opens into room {}, not one of the door's", leaf.room));
        }
        if !(90.0..=175.0).contains(&leaf.open_deg) {
            return Err(format!("{tag}: leaf open {} degrees", leaf.open_deg));
        }
        let room = scene.room(leaf.room).expect("leaf room exists");
        let (lo, hi) = room.interior(scene.wall_thickness_m);
        let along: Vec<Vec2> =
            (0..=50).map(|i| leaf.hinge + leaf.direction * (leaf.width_m * i as f32 / 50.0)).collect();
        let half = 0.5 * leaf.thickness_m;
        if leaf.footprint(0.0).iter().any(|p| p.cmplt(lo - 1e-3).any() || p.cmpgt(hi + 1e-3).any()) {
            return Err(format!("{tag}: leaf leaves room {}", room.id));
        }
        // Points over the slab's footprint: along its length, on its centre line and both faces.
        let across = leaf.direction.perp() * (half - 1e-3);
        let slab: Vec<Vec2> = along.iter().flat_map(|&p| [p - across, p, p + across]).collect();
        let boxes =
            scene.objects.iter().map(|o| (o.min, o.max)).chain(scene.furnishings.iter().map(|f| (f.min, f.max)));
        for (min, max) in boxes {
            let (min, max) = (min.truncate() + Vec2::splat(1e-3), max.truncate() - Vec2::splat(1e-3));
            if slab.iter().any(|p| p.cmpgt(min).all() && p.cmplt(max).all()) {
                return Err(format!("{tag}: leaf runs into furniture at {min} .. {max}"));
            }
        }
        let centre = door.center.truncate();
        let walk = (centre - door.normal * 0.6, centre + door.normal * 0.6);
        let nearest = along.iter().map(|&p| to_segment(p, walk.0, walk.1)).fold(f32::INFINITY, f32::min) - half;
        if nearest < 0.3 {
            return Err(format!("{tag}: leaf comes within {nearest} m of the walk through the doorway"));
        }
        let named = format!("door_leaf_{}", door.id);
        if !scene.geometry.nodes.iter().any(|n| {
            n.name == named
                && n.semantic == Semantic::Opening { kind: scene_gen::scene::OpeningKind::Door, id: door.id }
        }) {
            return Err(format!("{tag}: no node {named}"));
        }
    }
    Ok(())
}

fn place_and_check(lib: &Library, seed: u64) -> Result<Vec<Object>, String> {
    let plan = random_plan(seed, lib);
    let config = GeneratorConfig { seed, ..GeneratorConfig::default() };
    let mut geometry = Geometry::default();
    let first = 1 + plan.doors.len() as u32;
    let placement =
        placement::place_detailed(&config, &plan, &[], lib, first, &mut MaterialCatalog::new(seed), &mut geometry)
            .map_err(|e| e.to_string())?;
    let furnished = Furnished {
        objects: &placement.objects,
        placed_by: Some(&placement.placed_by),
        furnishings: &placement.furnishings,
        furnishings_placed_by: Some(&placement.furnishings_placed_by),
    };
    check(lib, &plan, &furnished, &geometry, first)?;
    Ok(placement.objects)
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    #[test]
    fn any_seed_keeps_the_invariants(seed in proptest::prelude::any::<u64>()) {
        let lib = library();
        if let Err(e) = place_and_check(&lib, seed) {
            proptest::prop_assert!(false, "seed {}: {}", seed, e);
        }
    }

    #[test]
    fn class_toml_and_obj_parsers_never_panic(text in "\\PC{0,300}", obj in "(v -?[0-9] -?[0-9] -?[0-9]\n|f [0-9]( [0-9]){2,3}\n|vn 0 0 1\n|usemtl [a-z]{1,6}\n){0,12}") {
        use scene_gen::library::{LibraryFile, furniture::parse_furniture};
        let files = vec![
            LibraryFile { path: "f/toy/toy.toml".into(), bytes: text.into_bytes() },
            LibraryFile { path: "f/toy/a.obj".into(), bytes: obj.clone().into_bytes() },
        ];
        let _ = parse_furniture(&files);
        let good = "rooms = []\nplace = \"center\"\nuniform_scale = true\nheight_m = [0.1, 0.2]\n[[variant]]\nobj = \"a\"\n";
        let files = vec![
            LibraryFile { path: "f/toy/toy.toml".into(), bytes: good.as_bytes().to_vec() },
            LibraryFile { path: "f/toy/a.obj".into(), bytes: obj.into_bytes() },
        ];
        let _ = parse_furniture(&files);
    }
}
