//! Times the materials and glTF stages on one thread:
//!
//! `cargo run --release --example gltf_timing`
//!
//! * cold: baking one texture (first use of a (surface, variant) in a process);
//! * warm: a MaterialCatalog resolving 24 materials (one per surface) into a fresh Geometry,
//!   i.e. what every scene after the first pays, served by the texture cache;
//! * `generate` (seed 7) + `to_glb` + write, and the feature scene's `to_glb` + write.
//!
//! Each figure is the median of many runs, in CPU time of this thread (from
//! /proc/thread-self/schedstat, so a machine loaded by other work does not inflate it; wall
//! time where that file is missing), plus the wall-time median for comparison.

#[path = "gltf_feature_scene.rs"]
#[allow(dead_code)]
mod feature;

use std::time::Instant;

use scene_gen::config::GeneratorConfig;
use scene_gen::export::{gltf::to_glb, write_atomic};
use scene_gen::generate::generate;
use scene_gen::library::Library;
use scene_gen::materials::{MaterialCatalog, SURFACES};
use scene_gen::scene::Geometry;

/// CPU time of this thread so far, ms (Linux), if known.
fn cpu_ms() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(text.split_whitespace().next()?.parse::<f64>().ok()? / 1e6)
}

/// Median over 9 batches of `batch` calls of `f` of the mean time per call: CPU ms (wall ms
/// without /proc; batching averages out the scheduler-tick granularity of schedstat), and
/// wall ms.
fn median_ms(batch: usize, mut f: impl FnMut()) -> (f64, f64) {
    let (mut cpu, mut wall): (Vec<f64>, Vec<f64>) = (0..9)
        .map(|_| {
            let (c, t) = (cpu_ms(), Instant::now());
            for _ in 0..batch {
                f();
            }
            let w = t.elapsed().as_secs_f64() * 1e3 / batch as f64;
            (c.zip(cpu_ms()).map_or(w, |(a, b)| (b - a) / batch as f64), w)
        })
        .unzip();
    cpu.sort_by(f64::total_cmp);
    wall.sort_by(f64::total_cmp);
    (cpu[4], wall[4])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::temp_dir().join(format!("scene-gen-timing-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let path = dir.join("scene.glb");

    let mut variant = 0;
    let cold = median_ms(3, || {
        let surface = SURFACES[variant % SURFACES.len()];
        std::hint::black_box(scene_gen::textures::bake(surface, 5));
        variant += 1;
    });
    println!(
        "bake one 256x256 texture + PNG (cold, uncached): {:.2} ms CPU ({:.2} ms wall), mean over surfaces",
        cold.0, cold.1
    );

    let mut slowest: Vec<(f64, &str)> = SURFACES
        .iter()
        .map(|s| (median_ms(1, || drop(std::hint::black_box(scene_gen::textures::bake(s, 6)))).1, *s))
        .collect();
    slowest.sort_by(|a, b| b.0.total_cmp(&a.0));
    let top: Vec<String> = slowest.iter().take(4).map(|(ms, s)| format!("{s} {ms:.2} ms")).collect();
    println!("slowest bakes (wall): {}", top.join(", "));

    let warm = median_ms(100, || {
        let mut geometry = Geometry::default();
        let mut catalog = MaterialCatalog::new(7);
        for s in SURFACES {
            catalog.material(&mut geometry, s, 1).unwrap();
        }
        std::hint::black_box(geometry);
    });
    println!(
        "materials for all {} surfaces (warm cache): {:.3} ms CPU ({:.3} ms wall)",
        SURFACES.len(),
        warm.0,
        warm.1
    );

    let library = Library::embedded()?;
    let config = GeneratorConfig { seed: 7, ..GeneratorConfig::default() };
    let generated = median_ms(10, || {
        let scene = generate(&config, &library).unwrap();
        write_atomic(&path, &to_glb(&scene)).unwrap();
    });
    let size = std::fs::metadata(&path)?.len();
    println!("generate seed 7 + to_glb + write: {:.3} ms CPU ({:.3} ms wall; {size} bytes)", generated.0, generated.1);

    let scene = feature::feature_scene();
    let encode = median_ms(5, || drop(std::hint::black_box(to_glb(&scene))));
    let written = median_ms(5, || write_atomic(&path, &to_glb(&scene)).unwrap());
    let size = std::fs::metadata(&path)?.len();
    println!(
        "feature scene to_glb: {:.3} ms CPU ({:.3} ms wall); to_glb + write: {:.3} ms CPU ({:.3} ms wall; {size} bytes)",
        encode.0, encode.1, written.0, written.1
    );
    // A stand-in for a furnished house: the feature scene plus one material (and texture) per
    // surface, every one embedded in the GLB.
    let full = median_ms(5, || {
        let mut scene = feature::feature_scene();
        let mut catalog = MaterialCatalog::new(7);
        for s in SURFACES {
            catalog.material(&mut scene.geometry, s, 3).unwrap();
        }
        write_atomic(&path, &to_glb(&scene)).unwrap();
    });
    let size = std::fs::metadata(&path)?.len();
    println!(
        "feature scene + {} surface materials (warm) + to_glb + write: {:.3} ms CPU ({:.3} ms wall; {size} bytes)",
        SURFACES.len(),
        full.0,
        full.1
    );
    let build = median_ms(5, || drop(std::hint::black_box(feature::feature_scene())));
    println!("feature scene build (6 materials, 90k vertices): {:.3} ms CPU ({:.3} ms wall)", build.0, build.1);
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}
