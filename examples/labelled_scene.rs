//! A generated house with hand-placed labelled boxes, written in any export format: a scene
//! with objects and a threshold for the exporters' round-trip checks while the furniture stage
//! is still being written (tests/interop/check_usd.sh uses it).
//!
//! ```text
//! cargo run --release --example labelled_scene -- SEED usda|usdc|obj|glb OUT_DIR
//! ```
//!
//! Per room it adds a table (rotated 30 degrees, so its world bounds differ from its mesh's) and
//! a chair, plus one exterior door with its gold threshold in room 0. Manifest bounds are the
//! transformed mesh's exact bounds, as the furniture stage computes them.

use std::path::PathBuf;

use glam::{Mat4, Vec2, Vec3};
use image::ImageEncoder as _;
use scene_gen::config::GeneratorConfig;
use scene_gen::export::{gltf, obj, usd, write_atomic};
use scene_gen::generate::generate;
use scene_gen::library::Library;
use scene_gen::manifest::Manifest;
use scene_gen::scene::{
    Door, Material, Mesh, Node, Object, ObjectClass, Primitive, Scene, Semantic, Texture, Threshold,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [seed, format, out] = args.as_slice() else {
        return Err("usage: labelled_scene SEED usda|usdc|obj|glb OUT_DIR".into());
    };
    let library = Library::embedded()?;
    let mut scene = generate(&GeneratorConfig { seed: seed.parse()?, ..GeneratorConfig::default() }, &library)?;
    add_labelled_boxes(&mut scene);
    let mut files = match format.as_str() {
        "usda" => usd::to_usd(&scene, usd::UsdFormat::Usda, &usd::find_python())?,
        "usdc" => usd::to_usd(&scene, usd::UsdFormat::Usdc, &usd::find_python())?,
        "obj" => obj::to_obj(&scene),
        "glb" => vec![("scene.glb".into(), gltf::to_glb(&scene))],
        other => return Err(format!("unknown format '{other}'").into()),
    };
    files.push(("scene.json".into(), Manifest::of(&scene).to_json().into_bytes()));
    let out = PathBuf::from(out);
    for (name, bytes) in files {
        let path = out.join(name);
        std::fs::create_dir_all(path.parent().unwrap_or(&out))?;
        write_atomic(&path, &bytes)?;
    }
    Ok(())
}

/// Adds a table and a chair per room and a threshold in room 0.
fn add_labelled_boxes(scene: &mut Scene) {
    let g = &mut scene.geometry;
    g.textures.push(checker_texture());
    g.materials.push(Material {
        name: "box wood".into(),
        base_color: [0.55, 0.35, 0.2, 1.0],
        metallic: 0.0,
        roughness: 0.6,
        base_color_texture: Some(g.textures.len() - 1),
    });
    g.materials.push(Material {
        name: "box gold".into(),
        base_color: [1.0, 0.766, 0.336, 1.0],
        metallic: 1.0,
        roughness: 0.3,
        base_color_texture: None,
    });
    let (wood, gold) = (g.materials.len() - 2, g.materials.len() - 1);
    let mut next_instance = scene.thresholds.iter().map(|t| t.instance_id).max().unwrap_or(0) + 1;
    let rooms = scene.rooms.clone();

    if let Some(room) = rooms.first() {
        let center = Vec3::new(room.center().x, room.min.y, 0.0);
        let door_id = scene.doors.len() as u32;
        scene.doors.push(Door {
            id: door_id,
            rooms: [Some(room.id), None],
            wall: 0,
            center: center + Vec3::Z,
            width_m: 0.9,
            height_m: 2.0,
            normal: Vec2::NEG_Y,
        });
        let size = Vec3::new(0.9, 0.1, 0.03);
        let transform = Mat4::from_translation(center + Vec3::Z * size.z * 0.5);
        let id = scene.thresholds.len() as u32;
        let (min, max) = push_box(&mut scene.geometry, "threshold", size, gold, transform, Semantic::Threshold { id });
        scene.thresholds.push(Threshold { id, door: door_id, instance_id: next_instance, min, max });
        next_instance += 1;
    }

    for room in &rooms {
        let c = room.center();
        let pieces = [
            (ObjectClass::Table, Vec3::new(1.4, 0.8, 0.75), Vec2::new(c.x, c.y), 30.0f32),
            (ObjectClass::Chair, Vec3::new(0.45, 0.5, 0.9), Vec2::new(c.x + 1.2, c.y - 0.3), 0.0),
        ];
        for (class, size, at, yaw_deg) in pieces {
            let id = scene.objects.len() as u32;
            let transform =
                Mat4::from_translation(at.extend(size.z * 0.5)) * Mat4::from_rotation_z(yaw_deg.to_radians());
            let (min, max) =
                push_box(&mut scene.geometry, class.name(), size, wood, transform, Semantic::Object { id });
            scene.objects.push(Object {
                id,
                class,
                instance_id: next_instance,
                room: room.id,
                asset: format!("{}/box", class.name()),
                min,
                max,
                yaw_deg,
                on: None,
            });
            next_instance += 1;
        }
    }
}

/// Adds a centred box mesh placed by `transform`; returns its exact world bounds.
fn push_box(
    g: &mut scene_gen::scene::Geometry,
    name: &str,
    size: Vec3,
    material: usize,
    transform: Mat4,
    semantic: Semantic,
) -> (Vec3, Vec3) {
    let h = size * 0.5;
    let mut primitive = Primitive { material, ..Primitive::default() };
    // Each face: its normal and two in-plane axes with u x v = normal (counter-clockwise).
    for (n, u, v) in [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::NEG_X, Vec3::NEG_Y, Vec3::Z),
        (Vec3::Y, Vec3::NEG_X, Vec3::Z),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::X, Vec3::NEG_Y),
    ] {
        let base = primitive.positions.len() as u32;
        for (s, t) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let p = (n + u * s + v * t) * h;
            primitive.positions.push(p);
            primitive.normals.push(n);
            // Metres of surface, v down the image.
            primitive.uvs.push(Vec2::new((u * s * h).length() * s, -(v * t * h).length() * t));
        }
        primitive.indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in &primitive.positions {
        let w = transform.transform_point3(*p);
        min = min.min(w);
        max = max.max(w);
    }
    g.meshes.push(Mesh { name: name.to_string(), primitives: vec![primitive] });
    g.nodes.push(Node { name: name.to_string(), mesh: g.meshes.len() - 1, transform, semantic });
    (min, max)
}

/// An 8x8 two-tone checker, so the exporters' texture paths are exercised.
fn checker_texture() -> Texture {
    let (width, height) = (8u32, 8u32);
    let rgba8: Vec<u8> = (0..width * height)
        .flat_map(|i| if (i % width + i / width) % 2 == 0 { [200, 170, 130, 255] } else { [120, 90, 60, 255] })
        .collect();
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&rgba8, width, height, image::ExtendedColorType::Rgba8)
        .expect("in-memory PNG encoding");
    // `.into()`: the pixel buffers may be shared (`Arc<[u8]>`, the textures branch) or owned.
    #[allow(clippy::useless_conversion)]
    Texture { name: "checker".into(), width, height, rgba8: rgba8.into(), png: png.into() }
}
