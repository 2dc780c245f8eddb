//! Throughput of the sensor stage, two cases:
//!
//! * `model`: the noise model alone, IMX174 frames (1936 x 1216) with every sensor effect on,
//!   on a photon ramp; prints ms and megapixels per second.
//! * `stage`: what `scene-gen evaluate` does per image after rendering: one real 1936 x 1216
//!   preview frame of house 0 (the evaluator's camera `IMX174,focal_mm=4,pitch_deg=-10`, its
//!   render settings and its day / night light scales) is rendered once, then the day and the
//!   night image go through radiance -> photons -> noise -> DN -> ISP 8-bit output, `REPS`
//!   times, first by the chain of separate passes (`Frame::mix`, `capture_frame`, `to_8bit`),
//!   then by the fused `isp::capture_8bit` that the evaluator uses. Prints process CPU seconds
//!   per image (user + sys, from /proc/self/stat, so other load on the machine does not count)
//!   and a checksum of the 8-bit images (the two paths must agree).
//!
//! `cargo run --release --example sensor_throughput [model FRAMES | stage REPS [fused]]` (default:
//! both, 5 frames and 3 reps; `fused`: the fused path only, for profiling). `RAYON_NUM_THREADS` sets the thread count.

use std::time::Instant;

use scene_gen::camera_spec::CameraSpec;
use scene_gen::capture::light_scales;
use scene_gen::evaluate::eval_render_settings;
use scene_gen::house::{embedded_library, walked_house};
use scene_gen::isp::{Isp, OutputRule, Scenario, capture_8bit, to_8bit};
use scene_gen::optics::{OpticsInput, agent_velocity};
use scene_gen::radiometry::capture_frame;
use scene_gen::render::Renderer;
use scene_gen::scene::LightGroup;
use scene_gen::sensor::noise::{self, Effects};
use scene_gen::sensor::{Catalog, SensorModel};
use scene_gen::trajectory::TrajectoryParams;

/// CPU time of this process so far (user + sys), seconds, from /proc/self/stat (clock ticks of
/// 1/100 s on Linux).
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the parenthesised command name: state is field 3, utime 14, stime 15.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

fn model_case(frames: u64) {
    let sensor = Catalog::embedded().get("IMX174").expect("IMX174 is in the catalog").clone();
    let mut model = SensorModel::from_sensor(&sensor, 1);
    model.effects = Effects {
        read_noise_split: noise::ReadNoiseSplit { enabled: true, post_gain_fraction: 0.3 },
        nonlinearity: noise::Nonlinearity { enabled: true, a3: -0.02, ..noise::Nonlinearity::default() },
        dsnu: noise::Dsnu { enabled: true, std_e: 5.0 },
        prnu: noise::Prnu { enabled: true, std_fraction: 0.01 },
        hot_pixels: noise::HotPixels {
            enabled: true,
            fraction: 1e-4,
            max_excess_e_per_s: 1e4,
            ..noise::HotPixels::default()
        },
        row_column_noise: noise::RowColumnNoise { enabled: true, row_std_dn: 0.5, column_std_dn: 0.5 },
        periodic_pattern: noise::PeriodicPattern {
            enabled: true,
            amplitude_dn: 1.0,
            freq_x_cycles_per_px: 0.04,
            freq_y_cycles_per_px: 0.2,
            ..noise::PeriodicPattern::default()
        },
        ..model.effects
    };
    let (w, h) = (sensor.resolution[0] as usize, sensor.resolution[1] as usize);
    // A ramp from dark to near saturation, so both Poisson branches are exercised.
    let photons: Vec<f32> = (0..w * h).map(|i| (i % w) as f32 / w as f32 * 40_000.0).collect();
    let start = Instant::now();
    let pattern = model.fixed_pattern(w, h);
    let pattern_s = start.elapsed().as_secs_f64();
    let (start, cpu0) = (Instant::now(), cpu_s());
    let mut checksum = 0u64;
    for f in 0..frames {
        let out = model.simulate_with(&pattern, &photons, 0.01, 6.0, f);
        checksum = checksum.wrapping_add(out.iter().map(|&v| u64::from(v)).sum::<u64>());
    }
    let (s, cpu) = (start.elapsed().as_secs_f64(), cpu_s() - cpu0);
    let mpx = (w * h) as f64 * frames as f64 / 1e6;
    println!(
        "model: {frames} frames {w}x{h}, every effect on, {} threads: {:.1} ms/frame wall, {:.3} CPU-s/frame, \
         {:.1} Mpx/s (fixed pattern {:.1} ms; checksum {checksum})",
        rayon::current_num_threads(),
        1e3 * s / frames as f64,
        cpu / frames as f64,
        mpx / s,
        1e3 * pattern_s
    );
}

fn stage_case(reps: u32, chain: bool) {
    let catalog = Catalog::embedded();
    let spec = CameraSpec::from_inline("IMX174,focal_mm=4,pitch_deg=-10").expect("valid spec");
    let spec = CameraSpec { max_width_px: Some(1936), ..spec };
    let resolved = spec.resolve(&catalog).expect("resolves");
    let library = embedded_library().expect("embedded library");
    let params = TrajectoryParams { height_m: spec.height_m, ..TrajectoryParams::default() };
    let house = walked_house(&library, 0, &params).expect("house 0");
    let renderer = Renderer::new(&house.scene, eval_render_settings());
    let scales = light_scales(&renderer, 0, &[LightGroup::Day, LightGroup::Night]).expect("light scales");
    let pose = house.walk.poses[house.walk.poses.len() / 3];
    let camera = resolved.camera_at(&pose);
    let (t0, cpu0) = (Instant::now(), cpu_s());
    let frame = renderer.render(&camera).expect("renders");
    let (render_s, render_cpu) = (t0.elapsed().as_secs_f64(), cpu_s() - cpu0);
    let gains = [spec.gain_day_db, spec.gain_night_db];
    let isps: Vec<Isp> = scales
        .iter()
        .enumerate()
        .map(|(s, sc)| Isp::for_scenario(&resolved, gains[s], f64::from(sc.target_lux), 1))
        .collect();
    let optics = OpticsInput {
        depth_m: &frame.depth_m,
        velocity_m_s: agent_velocity(&spec, pose.yaw_deg, params.speed_m_per_s),
    };
    let report = |path: &str, images: f64, t0: Instant, cpu0: f64, checksum: u64, means: [f64; 2]| {
        let (s, cpu) = (t0.elapsed().as_secs_f64(), cpu_s() - cpu0);
        println!(
            "stage ({path}): {images} images {}x{} (day + night), {} threads: {:.3} CPU-s/image, {:.1} ms/image \
             wall; mean 8-bit day {:.2} night {:.2}; checksum {checksum:016x}",
            camera.width_px,
            camera.height_px,
            rayon::current_num_threads(),
            cpu / images,
            1e3 * s / images,
            means[0],
            means[1],
        );
    };
    let digest = |checksum: u64, grey: &[u8]| {
        grey.iter().fold(checksum, |h, &v| (h ^ u64::from(v)).wrapping_mul(0x0100_0000_01b3))
    };
    let mean = |grey: &[u8]| grey.iter().map(|&v| f64::from(v)).sum::<f64>() / grey.len() as f64 / f64::from(reps);
    let images = f64::from(2 * reps);
    println!("render of the frame: {render_cpu:.1} CPU-s, {render_s:.1} s wall");

    // The chain of separate passes (mix, capture_frame, to_8bit), which evaluate used before.
    let (t0, cpu0) = (Instant::now(), cpu_s());
    let (mut checksum, mut means) = (0u64, [0.0f64; 2]);
    for rep in 0..if chain { reps } else { 0 } {
        for (s, sc) in scales.iter().enumerate() {
            let radiance = sc.radiance(&frame);
            let frame_seed = 1000 * u64::from(rep) + s as u64;
            let cap = capture_frame(&resolved, &camera, &radiance, Some(optics), gains[s], 0, frame_seed);
            let grey = to_8bit(&cap, OutputRule::Isp, &isps[s]);
            checksum = digest(checksum, &grey);
            means[s] += mean(&grey);
        }
    }
    if chain {
        report("chain", images, t0, cpu0, checksum, means);
    }

    // The fused path evaluate uses now: both scenarios, row by row.
    let (t0, cpu0) = (Instant::now(), cpu_s());
    let (mut checksum, mut means) = (0u64, [0.0f64; 2]);
    for rep in 0..reps {
        let scenarios: Vec<Scenario<'_>> = scales
            .iter()
            .enumerate()
            .map(|(s, sc)| Scenario {
                day_weight: if s == 0 { sc.scale } else { 0.0 },
                night_weight: if s == 0 { 0.0 } else { sc.scale },
                gain_db: gains[s],
                frame_seed: 1000 * u64::from(rep) + s as u64,
                isp: &isps[s],
            })
            .collect();
        let greys = capture_8bit(
            &resolved,
            &camera,
            &frame.day_nit,
            &frame.night_nit,
            Some(optics),
            0,
            OutputRule::Isp,
            &scenarios,
        );
        for (s, grey) in greys.iter().enumerate() {
            checksum = digest(checksum, grey);
            means[s] += mean(grey);
        }
    }
    report("fused", images, t0, cpu0, checksum, means);
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n = |d: u64| args.get(1).and_then(|a| a.parse().ok()).unwrap_or(d);
    match args.first().map(String::as_str) {
        Some("model") => model_case(n(5)),
        Some("stage") => stage_case(n(3) as u32, args.get(2).is_none_or(|a| a != "fused")),
        _ => {
            model_case(5);
            stage_case(3, true);
        }
    }
}
