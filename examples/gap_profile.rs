//! Timing breakdown of one evaluation of the gap workflow on an EMVA 1288 descriptor: loading,
//! thresholds, statistics, the FFT periodogram, the wave removal and whole-acquisition
//! simulations, drawn pixel by pixel and from moments, each after an untimed run that fills
//! the fixed-pattern cache both share (docs/BENCHMARKS.md, gap section):
//!
//! ```text
//! cargo run --release --example gap_profile -- DESCRIPTOR
//! ```
//!
//! Each simulation line also gives the process CPU time (user + sys, all threads) it took, so
//! figures taken on a loaded machine compare.
use std::time::Instant;

/// CPU time of this process so far, seconds (user + sys from /proc/self/stat, in clock ticks of
/// 1/100 s, the Linux USER_HZ); 0 where /proc is missing.
fn cpu_s() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // Fields after the parenthesised command name: state is field 3, utime 14, stime 15.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<f64> = rest.split_whitespace().skip(11).take(2).filter_map(|v| v.parse().ok()).collect();
    f.iter().sum::<f64>() / 100.0
}

use scene_gen::gap::{self, Draws, GapOptions, simulate_rows, stats};

fn main() {
    let Some(desc) = std::env::args().nth(1).map(std::path::PathBuf::from) else {
        eprintln!("usage: gap_profile DESCRIPTOR");
        std::process::exit(2);
    };
    let options = GapOptions::default();
    let t0 = Instant::now();
    let measured = gap::load_acquisition(&desc, &options).unwrap();
    println!("load {:.3}s", t0.elapsed().as_secs_f64());
    let model = gap::start_model(&desc, 1288).unwrap();
    let (w, h) = (measured.width, measured.height);
    let t0 = Instant::now();
    let t = stats::thresholds(&measured);
    println!("thresholds {:.3}s", t0.elapsed().as_secs_f64());
    let t0 = Instant::now();
    let _m = stats::compute(&measured, &t);
    println!("compute(measured) {:.3}s", t0.elapsed().as_secs_f64());
    let _ = simulate_rows(&model, &measured, 1288, None, h, &[]);
    for draws in [Draws::Pixels, Draws::Moments] {
        let (t0, c0) = (Instant::now(), cpu_s());
        let sim = simulate_rows(&model, &measured, 1288, None, h, &gap::block_draws(&measured, draws));
        println!("simulate (start model, {draws:?}) {:.3}s wall, {:.2}s CPU", t0.elapsed().as_secs_f64(), cpu_s() - c0);
        let (t0, c0) = (Instant::now(), cpu_s());
        let _s = stats::compute(&sim, &t);
        println!("compute(sim, {draws:?}) {:.3}s wall, {:.2}s CPU", t0.elapsed().as_secs_f64(), cpu_s() - c0);
    }
    let dark = measured.blocks.iter().find(|b| b.frames.len() > 2 && b.light == gap::Light::Dark).unwrap();
    let img = stats::average(&dark.frames);
    let t0 = Instant::now();
    let (pk, _) = stats::peaks_2d(&img, w, h, 2, 2);
    println!("peaks_2d {:.3}s {pk:?}", t0.elapsed().as_secs_f64());
    let t0 = Instant::now();
    let _ = stats::remove_waves(&img, w, h, &[(pk[0].1, pk[0].2), (pk[1].1, pk[1].2)]);
    println!("remove_waves (2 waves) {:.3}s", t0.elapsed().as_secs_f64());
    let mut full = model.clone();
    let e = &mut full.sensor.effects;
    e.black_level.enabled = true;
    e.black_level.offset_dn = 30.0;
    e.dsnu.enabled = true;
    e.dsnu.std_e = 15.0;
    e.prnu.enabled = true;
    e.prnu.std_fraction = 0.005;
    e.periodic_pattern.enabled = true;
    e.periodic_pattern.amplitude_dn = 1.5;
    e.periodic_pattern.freq_x_cycles_per_px = 0.04;
    e.periodic_pattern.wave_x_freq_y_cycles_per_px = 0.2;
    e.periodic_pattern.wave_y_freq_x_cycles_per_px = 0.1;
    e.periodic_pattern.freq_y_cycles_per_px = 0.05;
    let _ = simulate_rows(&full, &measured, 1288, None, h, &[]);
    for draws in [Draws::Pixels, Draws::Moments] {
        let (t0, c0) = (Instant::now(), cpu_s());
        let _ = simulate_rows(&full, &measured, 1288, None, h, &gap::block_draws(&measured, draws));
        println!(
            "simulate (black level, dsnu, prnu, diagonal waves, {draws:?}) {:.3}s wall, {:.2}s CPU",
            t0.elapsed().as_secs_f64(),
            cpu_s() - c0
        );
    }
}
