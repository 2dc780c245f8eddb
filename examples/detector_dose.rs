//! Dose-response of detection: AP@0.5 by day of the learned detector (and of the fast model
//! beside it) as the image worsens in one way at a time, on the evaluator's houses and frames:
//!
//! * **noise:** the exposure is cut by 4x and the gain raised 12 dB at each step, so the image
//!   is as bright but carries a quarter of the photons;
//! * **blur:** the lens is focused ever closer at f/1.4 (`defocus`), so the room, 1 to 6 m
//!   away, goes out of focus (at 0.05 m its blur circle is about 12 px of the 320 px image);
//! * **width:** the sensor is binned to narrower images (the field of view is kept).
//!
//! ```text
//! cargo run --release --example detector_dose -- [SEEDS] [FRAMES] [SWEEP]
//! ```
//!
//! SEEDS default 0..2, FRAMES 25, SWEEP `noise`, `blur`, `width` or `all` (the default).

use scene_gen::camera_spec::CameraSpec;
use scene_gen::evaluate::{DetectorChoice, EvalConfig, FrameWidth, evaluate};
use scene_gen::seeds::SeedRange;

const CAMERA: &str = "IMX172,focal_mm=4";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seeds: Vec<u64> = args.get(1).map_or("0..2", String::as_str).parse::<SeedRange>()?.iter().collect();
    let frames: u32 = args.get(2).map_or(Ok(25), |s| s.parse())?;
    let sweep = args.get(3).map_or("all", String::as_str);
    if !["noise", "blur", "width", "all"].contains(&sweep) {
        return Err(format!("SWEEP must be noise, blur, width or all, not '{sweep}'").into());
    }
    let noise: Vec<(String, String)> = (0..5)
        .map(|i| {
            let exposure = (1.0 / 30.0) / 4f64.powi(i);
            let gain = 5.0 + 12.0 * f64::from(i);
            (
                format!("exposure 1/{:.0} s, gain {gain:.0} dB", 1.0 / exposure),
                format!(",exposure_s={exposure},gain_day_db={gain}"),
            )
        })
        .collect();
    let blur: Vec<(String, String)> = std::iter::once(("in focus (no defocus)".to_string(), String::new()))
        .chain(
            [0.5, 0.2, 0.1, 0.05]
                .map(|f| (format!("f/1.4 focused at {f} m"), format!(",f_number=1.4,defocus=true,focus_m={f}"))),
        )
        .collect();
    let width: Vec<(String, u32)> = [320, 240, 160, 120, 80].map(|w| (format!("{w} px wide"), w)).to_vec();
    for (title, settings) in [("noise", &noise), ("blur", &blur)] {
        if sweep != "all" && sweep != title {
            continue;
        }
        println!("\n{title}:\n| setting | cnn AP@0.5 | model AP@0.5 |\n|---|---|---|");
        for (label, extra) in settings {
            let spec = CameraSpec::from_inline(&format!("{CAMERA}{extra}"))?;
            row(label, &spec, &seeds, EvalConfig { frames_per_scene: frames, ..EvalConfig::default() })?;
        }
    }
    if sweep != "all" && sweep != "width" {
        return Ok(());
    }
    println!("\nwidth:\n| setting | cnn AP@0.5 | model AP@0.5 |\n|---|---|---|");
    for (label, w) in &width {
        let spec = CameraSpec::from_inline(CAMERA)?;
        row(
            label,
            &spec,
            &seeds,
            EvalConfig { frames_per_scene: frames, max_width_px: FrameWidth::AtMost(*w), ..EvalConfig::default() },
        )?;
    }
    Ok(())
}

/// One table row: day AP@0.5 with the CNN and with the model.
fn row(label: &str, spec: &CameraSpec, seeds: &[u64], config: EvalConfig) -> Result<(), Box<dyn std::error::Error>> {
    let cnn = evaluate(spec, seeds, &EvalConfig { detector: DetectorChoice::Cnn, ..config.clone() })?;
    let model = evaluate(spec, seeds, &EvalConfig { detector: DetectorChoice::Model, ..config })?;
    println!("| {label} | {:.3} | {:.3} |", cnn.scenarios.day.ap50, model.scenarios.day.ap50);
    Ok(())
}
