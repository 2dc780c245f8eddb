//! Throughput of the sensor noise model: simulates IMX174 frames (1936 x 1216) with every
//! sensor effect on and prints megapixels per second.
//!
//! `cargo run --release --example sensor_throughput [FRAMES]`

use std::time::Instant;

use scene_gen::sensor::noise::{self, Effects};
use scene_gen::sensor::{Catalog, SensorModel};

fn main() {
    let frames: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(10);
    let sensor = Catalog::embedded().get("IMX174").expect("IMX174 is in the catalog").clone();
    let mut model = SensorModel::from_sensor(&sensor, 1);
    model.effects = Effects {
        read_noise_split: noise::ReadNoiseSplit { enabled: true, post_gain_fraction: 0.3 },
        nonlinearity: noise::Nonlinearity { enabled: true, a: -0.02 },
        dsnu: noise::Dsnu { enabled: true, std_e: 5.0 },
        prnu: noise::Prnu { enabled: true, std_fraction: 0.01 },
        hot_pixels: noise::HotPixels { enabled: true, fraction: 1e-4, max_excess_e_per_s: 1e4 },
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
    let start = Instant::now();
    let mut checksum = 0u64;
    for f in 0..frames {
        let out = model.simulate_with(&pattern, &photons, 0.01, 6.0, f);
        checksum = checksum.wrapping_add(out.iter().map(|&v| u64::from(v)).sum::<u64>());
    }
    let s = start.elapsed().as_secs_f64();
    let mpx = (w * h) as f64 * frames as f64 / 1e6;
    println!(
        "{frames} frames {w}x{h}, {} threads: {:.1} ms/frame, {:.1} Mpx/s (fixed pattern {:.1} ms; checksum {checksum})",
        rayon::current_num_threads(),
        1e3 * s / frames as f64,
        mpx / s,
        1e3 * pattern_s
    );
}
