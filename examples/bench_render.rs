//! Benchmark: ray throughput of the renderer's BVH on a room full of boxes (~97k triangles).
//!
//! ```text
//! cargo run --release --example bench_render -- [--full]
//! ```
//!
//! For 640x480 and 1936x1216 on rayon pools of 1 and 2 threads, prints million rays per second
//! for primary rays (closest hit through every pixel centre) and shadow rays (any hit, from
//! every primary hit towards the ceiling light), each the best of three runs. With `--full`
//! it also times a complete 640x480 frame at the standard settings. A harness of its own
//! rather than criterion: the figures of interest are rays per second at fixed sizes.

use std::time::Instant;

use glam::Vec3;
use scene_gen::render::test_util::{camera, room_of_boxes};
use scene_gen::render::{Camera, RenderSettings, Renderer};
use scene_gen::scene::LightKind;

fn best_of_three(mut run: impl FnMut() -> usize) -> (f64, usize) {
    let mut best = f64::INFINITY;
    let mut rays = 0;
    for _ in 0..3 {
        let start = Instant::now();
        rays = run();
        best = best.min(start.elapsed().as_secs_f64());
    }
    (best, rays)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let full = std::env::args().any(|a| a == "--full");
    let size = Vec3::new(12.0, 10.0, 2.8);
    let scene = room_of_boxes(size, 90);
    let start = Instant::now();
    let renderer = Renderer::new(&scene, RenderSettings::standard());
    let accel = renderer.accel();
    println!("scene: {} triangles, BVH built in {:.0} ms", accel.triangle_count(), start.elapsed().as_secs_f64() * 1e3);
    let light = scene.lights.iter().find(|l| l.kind == LightKind::Point).and_then(|l| l.position).unwrap_or(size);

    println!("| resolution | threads | primary Mrays/s | shadow Mrays/s |");
    println!("|---|---|---|---|");
    for (w, h) in [(640u32, 480u32), (1936, 1216)] {
        let cam =
            Camera { pixel_pitch_um: 5.86 * 1936.0 / w as f32, ..camera(w, h, Vec3::new(0.3, 0.3, 1.5), 35.0, -15.0) };
        let directions: Vec<Vec3> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| cam.ray_direction(x as f32 + 0.5, y as f32 + 0.5))
            .collect();
        let points: Vec<Vec3> = directions
            .iter()
            .filter_map(|d| accel.closest_hit(cam.position, *d, f32::INFINITY).map(|hit| cam.position + *d * hit.t))
            .collect();
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
            use rayon::prelude::*;
            let (primary_s, primary_rays) = best_of_three(|| {
                pool.install(|| {
                    let hits = directions
                        .par_chunks(1024)
                        .map(|c| {
                            c.iter().filter(|d| accel.closest_hit(cam.position, **d, f32::INFINITY).is_some()).count()
                        })
                        .sum::<usize>();
                    std::hint::black_box(hits);
                });
                directions.len()
            });
            let (shadow_s, shadow_rays) = best_of_three(|| {
                pool.install(|| {
                    let blocked = points
                        .par_chunks(1024)
                        .map(|c| {
                            c.iter()
                                .filter(|p| {
                                    let to = light - **p;
                                    let dist = to.length();
                                    // Start a little towards the light, as the shader does.
                                    let dir = to / dist;
                                    accel.occluded(**p + dir * 1e-3, dir, dist - 2e-3)
                                })
                                .count()
                        })
                        .sum::<usize>();
                    std::hint::black_box(blocked);
                });
                points.len()
            });
            println!(
                "| {w}x{h} | {threads} | {:.2} | {:.2} |",
                primary_rays as f64 / primary_s / 1e6,
                shadow_rays as f64 / shadow_s / 1e6
            );
        }
    }

    if full {
        let cam =
            Camera { pixel_pitch_um: 5.86 * 1936.0 / 640.0, ..camera(640, 480, Vec3::new(0.3, 0.3, 1.5), 35.0, -15.0) };
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
            let start = Instant::now();
            let frame = pool.install(|| renderer.render(&cam))?;
            println!(
                "full 640x480 frame, standard settings, {threads} thread(s): {:.2} s ({} px)",
                start.elapsed().as_secs_f64(),
                frame.depth_m.len()
            );
        }
    }
    Ok(())
}
