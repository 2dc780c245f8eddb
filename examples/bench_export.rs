//! Benchmark: time each export format for one scene.
//!
//! ```text
//! cargo run --release --example bench_export -- [SEED=7] [REPEATS=5] [EXTRA_OBJECTS=0]
//! ```
//!
//! Generates the scene for SEED once (plus EXTRA_OBJECTS labelled stand-in objects of 1,024
//! triangles each, own mesh each, to stand for a furnished house while placement is a stub), then encodes and writes it REPEATS times per format (GLB,
//! OBJ, USDA, USDC) into a scratch folder and prints the median wall time and output size. The
//! USD figures include starting Python and importing usd-core (about 0.2 s of it on this
//! machine, measured by `usd start-up` below), since every export pays it. Needs usd-core in the
//! Python `scene-gen` finds (see crates/export/src/usd.rs); without it the USD rows say why.

use std::time::Instant;

use glam::{Mat4, Vec2, Vec3};
use scene_gen::config::GeneratorConfig;
use scene_gen::export::{gltf, obj, usd, write_atomic};
use scene_gen::generate::generate;
use scene_gen::library::Library;
use scene_gen::scene::{Mesh, Node, Object, ObjectClass, Primitive, Scene, Semantic};

type Files = Vec<(String, Vec<u8>)>;
/// One format's exporter: the files to write, or why it is unavailable.
type Exporter<'a> = &'a dyn Fn(&Scene) -> Result<Files, String>;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let seed: u64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(7);
    let repeats: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(5).max(1);
    let extra: u32 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(0);
    let library = Library::embedded()?;
    let mut scene = generate(&GeneratorConfig { seed, ..GeneratorConfig::default() }, &library)?;
    add_stand_ins(&mut scene, extra);
    let dir = std::env::temp_dir().join(format!("scene-gen-bench-export-{}", std::process::id()));
    let python = usd::find_python();
    let triangles: usize = scene
        .geometry
        .nodes
        .iter()
        .flat_map(|n| &scene.geometry.meshes[n.mesh].primitives)
        .map(|p| p.indices.len() / 3)
        .sum();
    println!(
        "seed {seed}: {} rooms, {} objects, {} nodes, {triangles} triangles; median of {repeats}",
        scene.rooms.len(),
        scene.objects.len(),
        scene.geometry.nodes.len()
    );
    println!("{:<14} {:>10} {:>12}", "format", "time ms", "size KiB");

    let formats: [(&str, Exporter); 4] = [
        ("glb", &|s| Ok(vec![("scene.glb".into(), gltf::to_glb(s))])),
        ("obj", &|s| Ok(obj::to_obj(s))),
        ("usda", &|s| usd::to_usd(s, usd::UsdFormat::Usda, &python).map_err(|e| e.to_string())),
        ("usdc", &|s| usd::to_usd(s, usd::UsdFormat::Usdc, &python).map_err(|e| e.to_string())),
    ];
    for (name, export) in formats {
        let mut times_ms = Vec::new();
        let mut size = 0;
        for _ in 0..repeats {
            let start = Instant::now();
            let files = match export(&scene) {
                Ok(files) => files,
                Err(e) => {
                    println!("{name:<14} unavailable: {}", e.lines().next().unwrap_or(""));
                    break;
                }
            };
            size = 0;
            for (path, bytes) in &files {
                let path = dir.join(path);
                std::fs::create_dir_all(path.parent().unwrap_or(&dir))?;
                write_atomic(&path, bytes)?;
                size += bytes.len();
            }
            times_ms.push(start.elapsed().as_secs_f64() * 1e3);
        }
        if !times_ms.is_empty() {
            times_ms.sort_by(f64::total_cmp);
            println!("{name:<14} {:>10.1} {:>12.1}", times_ms[times_ms.len() / 2], size as f64 / 1024.0);
        }
    }

    // What every USD export pays before any work: starting Python and importing usd-core.
    let mut startup_ms = Vec::new();
    for _ in 0..repeats {
        let start = Instant::now();
        if usd::check_usd_core(&python).is_err() {
            break;
        }
        startup_ms.push(start.elapsed().as_secs_f64() * 1e3);
    }
    if !startup_ms.is_empty() {
        startup_ms.sort_by(f64::total_cmp);
        println!("{:<14} {:>10.1}", "usd start-up", startup_ms[startup_ms.len() / 2]);
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// Adds `count` labelled objects, each its own wavy 32 x 16 quad grid (1,024 triangles), on a
/// grid over the first room.
fn add_stand_ins(scene: &mut Scene, count: u32) {
    let Some(room) = scene.rooms.first().cloned() else { return };
    let material = scene.geometry.materials.len().saturating_sub(1);
    let (nu, nv) = (32u32, 16u32);
    for i in 0..count {
        let mut p = Primitive { material, ..Primitive::default() };
        for v in 0..=nv {
            for u in 0..=nu {
                let (s, t) = (u as f32 / nu as f32, v as f32 / nv as f32);
                p.positions.push(Vec3::new(s * 0.6, t * 0.4, 0.3 + 0.05 * (s * 9.0 + i as f32).sin()));
                p.normals.push(Vec3::Z);
                p.uvs.push(Vec2::new(s * 0.6, t * 0.4));
            }
        }
        for v in 0..nv {
            for u in 0..nu {
                let a = v * (nu + 1) + u;
                p.indices.extend([a, a + 1, a + nu + 2, a, a + nu + 2, a + nu + 1]);
            }
        }
        let at = room.min + Vec2::new(0.5 + (i % 16) as f32 * 0.8, 0.5 + (i / 16 % 16) as f32 * 0.6);
        let transform = Mat4::from_translation(at.extend(0.0));
        let id = scene.objects.len() as u32;
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for q in &p.positions {
            lo = lo.min(transform.transform_point3(*q));
            hi = hi.max(transform.transform_point3(*q));
        }
        scene.geometry.meshes.push(Mesh { name: format!("stand_in_{i}"), primitives: vec![p] });
        let mesh = scene.geometry.meshes.len() - 1;
        scene.geometry.nodes.push(Node {
            name: format!("stand_in_{i}"),
            mesh,
            transform,
            semantic: Semantic::Object { id },
        });
        scene.objects.push(Object {
            id,
            class: ObjectClass::ALL[i as usize % ObjectClass::ALL.len()],
            instance_id: 1000 + id,
            room: room.id,
            asset: "stand_in/grid".into(),
            min: lo,
            max: hi,
            yaw_deg: 0.0,
            on: None,
        });
    }
}
