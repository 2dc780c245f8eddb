//! Benchmark: time each export format for one scene.
//!
//! ```text
//! cargo run --release --example bench_export -- [SEED=7] [REPEATS=5]
//! ```
//!
//! Generates the scene for SEED once, then encodes and writes it REPEATS times per format (GLB,
//! OBJ, USDA, USDC) into a scratch folder and prints the median wall time and output size. The
//! USD figures include starting Python and importing usd-core (about 0.2 s of it on this
//! machine, measured by `usd start-up` below), since every export pays it. Needs usd-core in the
//! Python `scene-gen` finds (see src/export/usd.rs); without it the USD rows say why.

use std::time::Instant;

use scene_gen::config::GeneratorConfig;
use scene_gen::export::{gltf, obj, usd, write_atomic};
use scene_gen::generate::generate;
use scene_gen::library::Library;
use scene_gen::scene::Scene;

type Files = Vec<(String, Vec<u8>)>;
/// One format's exporter: the files to write, or why it is unavailable.
type Exporter<'a> = &'a dyn Fn(&Scene) -> Result<Files, String>;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let seed: u64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(7);
    let repeats: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(5).max(1);
    let library = Library::embedded()?;
    let scene = generate(&GeneratorConfig { seed, ..GeneratorConfig::default() }, &library)?;
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
