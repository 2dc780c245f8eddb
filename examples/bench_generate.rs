//! Benchmark: generate a scene and write its GLB, over many seeds, on one thread.
//!
//! ```text
//! cargo run --release --example bench_generate -- [SEEDS=1000] [OUT_DIR=$TMPDIR]
//! ```
//!
//! Prints the median, p95 and max wall time per scene (generation + GLB encoding + writing the
//! file), the mean triangle count and the process's peak resident memory. A harness of its own
//! rather than criterion: the figure of interest is the spread over seeds, not one input's
//! mean.

use std::time::Instant;

use scene_gen::config::GeneratorConfig;
use scene_gen::export::{gltf, write_atomic};
use scene_gen::generate::generate;
use scene_gen::library::Library;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seeds: u64 = std::env::args().nth(1).map(|s| s.parse()).transpose()?.unwrap_or(1000);
    let library = Library::embedded()?;
    let parent = std::env::args().nth(2).map_or_else(std::env::temp_dir, std::path::PathBuf::from);
    let dir = parent.join(format!("scene-gen-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let path = dir.join("scene.glb");

    let mut times_ms = Vec::with_capacity(seeds as usize);
    let mut phase_ms = [0.0f64; 3]; // generate, encode, write
    let mut triangles = 0usize;
    let mut bytes = 0usize;
    for seed in 0..seeds {
        let start = Instant::now();
        let scene = generate(&GeneratorConfig { seed, ..GeneratorConfig::default() }, &library)?;
        let generated = Instant::now();
        let glb = gltf::to_glb(&scene);
        let encoded = Instant::now();
        write_atomic(&path, &glb)?;
        let written = Instant::now();
        times_ms.push((written - start).as_secs_f64() * 1e3);
        for (sum, (a, b)) in phase_ms.iter_mut().zip([(start, generated), (generated, encoded), (encoded, written)]) {
            *sum += (b - a).as_secs_f64() * 1e3;
        }
        triangles += scene.geometry.nodes.iter().map(|n| mesh_triangles(&scene, n.mesh)).sum::<usize>();
        bytes += glb.len();
    }
    std::fs::remove_dir_all(&dir)?;

    times_ms.sort_by(f64::total_cmp);
    let pick = |q: f64| times_ms[((times_ms.len() - 1) as f64 * q).round() as usize];
    println!("scenes:          {seeds} (seeds 0..{seeds}, 15x15x3 m, one thread, written to {})", parent.display());
    println!("median:          {:.2} ms", pick(0.5));
    println!("p95:             {:.2} ms", pick(0.95));
    println!("max:             {:.2} ms", pick(1.0));
    let n = seeds as f64;
    println!(
        "mean by phase:   generate {:.2} ms, encode GLB {:.2} ms, write {:.2} ms",
        phase_ms[0] / n,
        phase_ms[1] / n,
        phase_ms[2] / n
    );
    println!("mean triangles:  {}", triangles / seeds as usize);
    println!("mean GLB size:   {:.0} KiB", bytes as f64 / seeds as f64 / 1024.0);
    println!("peak memory:     {}", peak_memory().unwrap_or_else(|| "unknown (no /proc/self/status)".into()));
    Ok(())
}

fn mesh_triangles(scene: &scene_gen::scene::Scene, mesh: usize) -> usize {
    scene.geometry.meshes[mesh].primitives.iter().map(|p| p.indices.len() / 3).sum()
}

/// Peak resident set size (VmHWM) on Linux.
fn peak_memory() -> Option<String> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    Some(line.trim_start_matches("VmHWM:").trim().to_string())
}
