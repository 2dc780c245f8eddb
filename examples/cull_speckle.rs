//! Measurement: what the light-culling roulette of [`scene_gen::render::LightSet::direct`] does
//! to a `preview` day frame: speckle, mean day luminance (the roulette must leave it unbiased)
//! and CPU time, per culling threshold, at several poses of the benchmark house.
//!
//! ```text
//! cargo run --release --example cull_speckle -- [--res 640x480] [--cull 0.1,0] [--poses 6,20,40]
//! ```
//!
//! The view is that of `bench_render --case speckle` (house seed 7, IMX174 4 mm, the walk's pose
//! 6 by default, the full sensor's field of view at every resolution), rendered with
//! [`RenderSettings::preview`] on one thread. Each line of output is one JSON object: `cull`,
//! `pose`, `speckle` (mean over pixels of `|Y - m| / m`, `m` the 5 x 5 median of the day
//! luminance `Y`, where `m > 0`), `zero_median_px` (pixels whose 5 x 5 median is 0),
//! `mean_day_nit` (mean day luminance of the frame) and `cpu_s` (user + system CPU seconds of
//! the render). A last line per threshold sums the poses. The roulette is unbiased when
//! `mean_day_nit` agrees with `--cull 0` (every light traced) within the noise of one frame.

use scene_gen::camera_spec::CameraSpec;
use scene_gen::config::GeneratorConfig;
use scene_gen::generate::generate;
use scene_gen::library::Library;
use scene_gen::render::{Camera, Frame, RenderSettings, Renderer};
use scene_gen::sensor::Catalog;
use scene_gen::trajectory::{self, TrajectoryParams};

type BoxResult<T> = Result<T, Box<dyn std::error::Error + Send + Sync>>;

/// The house and sensor of `bench_render`.
const SEED: u64 = 7;
const SENSOR: &str = "IMX174";

/// CPU seconds (user + system, all threads) of this process, from `/proc/self/stat` (fields 14
/// and 15, in USER_HZ ticks of 1/100 s); 0 where it cannot be read.
fn process_cpu_s() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    let fields: Vec<&str> = stat.rsplit_once(')').map_or(vec![], |(_, rest)| rest.split_whitespace().collect());
    let ticks = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

/// (speckle, pixels whose 5 x 5 median is 0, mean luminance) of a frame's day radiance.
fn measure(frame: &Frame) -> (f64, usize, f64) {
    let y = Frame::luminance_nit(&frame.day_nit);
    let mean = y.iter().map(|&v| f64::from(v)).sum::<f64>() / y.len().max(1) as f64;
    let (speckle, zero) = frame.day_speckle();
    (speckle, zero, mean)
}

fn list<T: std::str::FromStr>(text: &str) -> BoxResult<Vec<T>>
where
    T::Err: std::error::Error + Send + Sync + 'static,
{
    text.split(',').map(|v| Ok(v.trim().parse::<T>()?)).collect()
}

fn main() -> BoxResult<()> {
    let (mut w, mut h) = (640u32, 480u32);
    let mut culls: Vec<f32> = vec![0.1, 0.0];
    let mut poses: Vec<usize> = vec![6];
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--res" => {
                let (a, b) = value.split_once('x').ok_or_else(|| format!("--res {value}: expected WxH"))?;
                (w, h) = (a.parse()?, b.parse()?);
            }
            "--cull" => culls = list(&value)?,
            "--poses" => poses = list(&value)?,
            _ => return Err(format!("unknown argument {flag}").into()),
        }
    }
    let scene = generate(&GeneratorConfig { seed: SEED, ..GeneratorConfig::default() }, &Library::embedded()?)?;
    let resolved = CameraSpec::new(SENSOR).resolve(&Catalog::embedded())?;
    let walk = trajectory::plan(&scene, &TrajectoryParams { height_m: resolved.spec.height_m, ..Default::default() })?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    for &cull in &culls {
        let renderer = Renderer::new(&scene, RenderSettings { light_cull: cull, ..RenderSettings::preview() });
        let (mut cpu, mut speckle, mut zero, mut mean) = (0.0, 0.0, 0usize, 0.0);
        for &pose in &poses {
            let full = resolved.camera_at(&walk.poses[pose.min(walk.poses.len() - 1)]);
            let camera = Camera {
                width_px: w,
                height_px: h,
                pixel_pitch_um: full.pixel_pitch_um * full.width_px as f32 / w as f32,
                ..full
            };
            let cpu0 = process_cpu_s();
            let frame = pool.install(|| renderer.render(&camera))?;
            let cpu_s = process_cpu_s() - cpu0;
            let (s, z, m) = measure(&frame);
            println!(
                "{}",
                serde_json::json!({"cull": cull, "pose": pose, "speckle": s, "zero_median_px": z,
                    "mean_day_nit": m, "cpu_s": cpu_s})
            );
            (cpu, speckle, zero, mean) = (cpu + cpu_s, speckle + s, zero + z, mean + m);
        }
        let n = poses.len().max(1) as f64;
        println!(
            "{}",
            serde_json::json!({"cull": cull, "poses": poses.len(), "mean_speckle": speckle / n,
                "zero_median_px": zero, "mean_day_nit": mean / n, "cpu_s": cpu})
        );
    }
    Ok(())
}
