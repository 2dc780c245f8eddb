//! Writes a full-size EMVA 1288 data set with the gap workflow's generator, for timing
//! `scene-gen calibrate` and `scene-gen gap` (docs/BENCHMARKS.md):
//!
//! ```text
//! cargo run --release --example emva_full_set -- OUT_DIR [WIDTH HEIGHT STACK_FRAMES]
//! ```
//!
//! Defaults: 640 x 480 pixels, 12 bit, set 003's layout (50 radiance steps of 2 frames at 1 ms,
//! a dark pair, then 100 bright frames at mid scale and 100 dark frames) and set 003's documented
//! camera (K 0.1 DN/e-, QE 0.5, dark noise 30 e-, dark level 29.4 DN, DSNU 1.5 DN with two waves
//! of 1.5 DN, 0.5 % PRNU, 100 hot pixels of 0..15 DN, nonlinearity -2 % at full scale).

use std::path::PathBuf;

use scene_gen::gap::{Acquisition, Block, GapModel, Light, Optics, testdata};
use scene_gen::sensor::SensorModel;
use scene_gen::sensor::noise::{self, Effects};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(out) = args.first().map(PathBuf::from) else {
        eprintln!("usage: emva_full_set OUT_DIR [WIDTH HEIGHT STACK_FRAMES]");
        std::process::exit(2);
    };
    let num = |i: usize, d: usize| args.get(i).map_or(Ok(d), |s| s.parse::<usize>()).unwrap_or(d);
    let (width, height, stack) = (num(1, 640), num(2, 480), num(3, 100));
    let exposure_s = 0.001;
    let k = 0.1;
    let effects = Effects {
        black_level: noise::BlackLevel { enabled: true, offset_dn: 29.4 },
        quantization: noise::Quantization { enabled: true, dither_dn: 0.0 },
        nonlinearity: noise::Nonlinearity { enabled: true, a3: -0.02, ..noise::Nonlinearity::default() },
        dsnu: noise::Dsnu { enabled: true, std_e: 1.5 / k },
        prnu: noise::Prnu { enabled: true, std_fraction: 0.005 },
        hot_pixels: noise::HotPixels {
            enabled: true,
            fraction: 100.0 / (640.0 * 480.0),
            max_excess_e_per_s: 15.0 / k / exposure_s,
            ..noise::HotPixels::default()
        },
        periodic_pattern: noise::PeriodicPattern {
            enabled: true,
            amplitude_dn: 1.5,
            freq_x_cycles_per_px: 0.04,
            freq_y_cycles_per_px: 0.2,
            ..noise::PeriodicPattern::default()
        },
        ..Effects::default()
    };
    let sensor = SensorModel {
        name: "emva-full-set".into(),
        quantum_efficiency: 0.5,
        system_gain_dn_per_e: k,
        read_noise_e: 30.0,
        adc_bits: 12,
        pattern_seed: 1288,
        effects,
    };
    let model = GapModel { sensor, optics: Optics::default() };
    let block = |light, n: usize| Block::layout(light, exposure_s, 0, n);
    let mut blocks: Vec<Block> = (1..=50).map(|i| block(Light::Bright(1659.66 * f64::from(i)), 2)).collect();
    blocks.push(block(Light::Dark, 2));
    blocks.push(block(Light::Bright(1659.66 * 25.0), stack));
    blocks.push(block(Light::Dark, stack));
    let layout = Acquisition { width, height, bits: 12, blocks, gains_db: vec![0.0] };
    match testdata::write_dataset(&out, &model, &layout, 3) {
        Ok(desc) => println!("{}", desc.display()),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
