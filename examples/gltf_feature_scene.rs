//! A small hand-made [`Scene`] that uses every feature the glTF exporter writes (shared meshes,
//! objects, a threshold, structure, a mesh large enough for u32 indices, textures, a
//! translucent material, point / rect / directional lights), written as a GLB:
//!
//! `cargo run --release --example gltf_feature_scene -- feature.glb`
//!
//! tests/gltf.rs reads it back and tests/interop/check_gltf.sh runs the Khronos validator on
//! it, so the exporter is checked on all features whatever the generator stages produce.

use glam::{Mat4, Quat, Vec2, Vec3};
use scene_gen::materials::MaterialCatalog;
use scene_gen::scene::{
    Door, Envelope, Geometry, Light, LightGroup, LightKind, LightUnit, Mesh, Node, Object, ObjectClass, Opening,
    OpeningKind, Primitive, Room, Scene, Semantic, Threshold, Wall,
};

/// A unit cube centred on the origin, 24 vertices with face normals and metre UVs.
pub fn unit_box(name: &str, material: usize) -> Mesh {
    let mut p = Primitive { material, ..Primitive::default() };
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let n = Vec3::AXES[axis] * sign;
            let (t, b) = (Vec3::AXES[(axis + 1) % 3] * sign, Vec3::AXES[(axis + 2) % 3]);
            let base = p.positions.len() as u32;
            for (s, r) in [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)] {
                p.positions.push(n * 0.5 + t * s + b * r);
                p.normals.push(n);
                p.uvs.push(Vec2::new(s + 0.5, 0.5 - r));
            }
            p.indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    Mesh { name: name.into(), primitives: vec![p] }
}

/// A flat grid in the z = `z` plane over `min..max`, `n` x `n` vertices, facing `normal_z`.
pub fn grid(name: &str, material: usize, min: Vec2, max: Vec2, z: f32, n: u32, normal_z: f32) -> Mesh {
    let mut p = Primitive { material, ..Primitive::default() };
    for j in 0..n {
        for i in 0..n {
            let t = Vec2::new(i as f32, j as f32) / (n - 1) as f32;
            let xy = min + (max - min) * t;
            p.positions.push(xy.extend(z));
            p.normals.push(Vec3::Z * normal_z);
            p.uvs.push(xy);
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n);
            if normal_z > 0.0 {
                p.indices.extend([a, b, c, a, c, d]);
            } else {
                p.indices.extend([a, c, b, a, d, c]);
            }
        }
    }
    Mesh { name: name.into(), primitives: vec![p] }
}

/// The feature scene. Room 0 is a living room (0..5 x 0..4 m), room 1 a bedroom (5..9 x 0..4 m),
/// joined by door 0 in wall 0 (x = 5) with threshold 0 in it.
pub fn feature_scene() -> Scene {
    let mut geometry = Geometry::default();
    let mut catalog = MaterialCatalog::new(7);
    let mut mat = |g: &mut Geometry, s: &str, v: u32| catalog.material(g, s, v).expect("known surface");
    let floor = mat(&mut geometry, "wood_floor", 1);
    let ceiling = mat(&mut geometry, "ceiling", 0);
    let wood = mat(&mut geometry, "wood", 2);
    let fabric = mat(&mut geometry, "fabric", 0);
    let gold = mat(&mut geometry, "gold", 0);
    let glass = mat(&mut geometry, "glass", 0);

    geometry.meshes.push(grid("floor_0", floor, Vec2::ZERO, Vec2::new(5.0, 4.0), 0.0, 2, 1.0));
    // 300 x 300 vertices: more than 65535, so this mesh needs u32 indices.
    geometry.meshes.push(grid("ceiling_1", ceiling, Vec2::new(5.0, 0.0), Vec2::new(9.0, 4.0), 2.8, 300, -1.0));
    let mut furniture = unit_box("box", wood);
    furniture.primitives.push(Primitive { material: fabric, ..unit_box("", fabric).primitives.remove(0) });
    geometry.meshes.push(furniture);
    geometry.meshes.push(unit_box("threshold", gold));
    geometry.meshes.push(grid("window_pane", glass, Vec2::new(-0.6, -0.5), Vec2::new(0.6, 0.5), 0.0, 2, 1.0));

    let node = |name: &str, mesh: usize, transform: Mat4, semantic: Semantic| Node {
        name: name.into(),
        mesh,
        transform,
        semantic,
    };
    geometry.nodes = vec![
        node("floor_0", 0, Mat4::IDENTITY, Semantic::Floor { room: 0 }),
        node("ceiling_1", 1, Mat4::IDENTITY, Semantic::Ceiling { room: 1 }),
        // The table: 1.2 x 0.8 x 0.75 m, turned 90 degrees, standing at (2, 3).
        node(
            "table",
            2,
            Mat4::from_scale_rotation_translation(
                Vec3::new(1.2, 0.8, 0.75),
                Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
                Vec3::new(2.0, 3.0, 0.375),
            ),
            Semantic::Object { id: 0 },
        ),
        // The chair shares the table's mesh.
        node(
            "chair",
            2,
            Mat4::from_scale_rotation_translation(Vec3::new(0.5, 0.5, 0.9), Quat::IDENTITY, Vec3::new(7.0, 1.0, 0.45)),
            Semantic::Object { id: 1 },
        ),
        node(
            "threshold",
            3,
            Mat4::from_scale_rotation_translation(Vec3::new(0.1, 0.9, 0.02), Quat::IDENTITY, Vec3::new(5.0, 2.0, 0.01)),
            Semantic::Threshold { id: 0 },
        ),
        // A window pane in the south wall (y = 0) of room 0, standing upright.
        node(
            "window_0_glass",
            4,
            Mat4::from_rotation_translation(
                Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
                Vec3::new(2.5, 0.0, 1.5),
            ),
            Semantic::Opening { kind: OpeningKind::Window, id: 0 },
        ),
    ];

    let light = |id, group, kind, unit, intensity| Light {
        id,
        group,
        kind,
        position: None,
        direction: None,
        rect_u: None,
        rect_v: None,
        intensity,
        unit,
        color: [1.0, 0.9, 0.8],
        room: Some(0),
        object: None,
    };
    let lights = vec![
        Light {
            position: Some(Vec3::new(2.0, 2.0, 2.5)),
            ..light(0, LightGroup::Night, LightKind::Point, LightUnit::Cd, 120.0)
        },
        Light {
            position: Some(Vec3::new(2.5, 0.0, 1.5)),
            direction: Some(Vec3::Y),
            rect_u: Some(Vec3::new(1.2, 0.0, 0.0)),
            rect_v: Some(Vec3::new(0.0, 0.0, 1.0)),
            ..light(1, LightGroup::Day, LightKind::Rect, LightUnit::Nit, 2000.0)
        },
        Light {
            direction: Some(Vec3::new(0.3, 0.5, -0.8).normalize()),
            room: None,
            ..light(2, LightGroup::Day, LightKind::Directional, LightUnit::Lux, 20000.0)
        },
    ];

    let object = |id, class, instance_id, room, asset: &str, min, max| Object {
        id,
        class,
        instance_id,
        room,
        asset: asset.into(),
        min,
        max,
        yaw_deg: 0.0,
        on: None,
    };
    Scene {
        seed: 7,
        envelope: Envelope { width_m: 9.0, depth_m: 4.0, height_m: 2.8 },
        wall_thickness_m: 0.1,
        house: scene_gen::scene::HouseRecord::default(),
        palette: None,
        rooms: vec![
            Room { id: 0, room_type: "living_room".into(), min: Vec2::ZERO, max: Vec2::new(5.0, 4.0) },
            Room { id: 1, room_type: "bedroom".into(), min: Vec2::new(5.0, 0.0), max: Vec2::new(9.0, 4.0) },
        ],
        walls: vec![Wall {
            id: 0,
            a: Vec2::new(5.0, 0.0),
            b: Vec2::new(5.0, 4.0),
            thickness_m: 0.1,
            height_m: 2.8,
            rooms: [Some(0), Some(1)],
            openings: vec![Opening {
                kind: OpeningKind::Door,
                id: 0,
                offset_m: 2.0,
                width_m: 0.9,
                sill_m: 0.0,
                height_m: 2.0,
            }],
        }],
        doors: vec![Door {
            id: 0,
            rooms: [Some(0), Some(1)],
            wall: 0,
            center: Vec3::new(5.0, 2.0, 1.0),
            width_m: 0.9,
            height_m: 2.0,
            normal: Vec2::X,
            leaf: None,
        }],
        windows: Vec::new(),
        thresholds: vec![Threshold {
            id: 0,
            door: 0,
            instance_id: 1,
            min: Vec3::new(4.95, 1.55, 0.0),
            max: Vec3::new(5.05, 2.45, 0.02),
        }],
        objects: vec![
            object(0, ObjectClass::Table, 2, 0, "table/box", Vec3::new(1.6, 2.4, 0.0), Vec3::new(2.4, 3.6, 0.75)),
            object(1, ObjectClass::Chair, 3, 1, "chair/box", Vec3::new(6.75, 0.75, 0.0), Vec3::new(7.25, 1.25, 0.9)),
        ],
        furnishings: Vec::new(),
        lights,
        geometry,
    }
}

#[allow(dead_code)] // unused when tests/gltf.rs includes this file as a module
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "feature.glb".into());
    scene_gen::export::write_atomic(std::path::Path::new(&out), &scene_gen::export::gltf::to_glb(&feature_scene()))?;
    println!("wrote {out}");
    Ok(())
}
