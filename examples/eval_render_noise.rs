//! How much the evaluator's render noise moves its scores: the default camera (IMX174, 4 mm,
//! -10 deg) on houses 0 and 1, 25 frames each at 1936 px, under one render setting.
//!
//! ```text
//! cargo run --release --example eval_render_noise -- eval        # the evaluator's setting
//! cargo run --release --example eval_render_noise -- unpooled    # 9 samples per anchor, not pooled
//! cargo run --release --example eval_render_noise -- one-sample  # one sample per anchor, culling
//! cargo run --release --example eval_render_noise -- converged   # 16 window samples, no culling
//! cargo run --release --example eval_render_noise -- all-lights-4  # (or -1, -9) N samples, no culling
//! ```
//!
//! Prints one JSON line: the setting and the per-scenario scores (time it with
//! `/usr/bin/time`).
//! docs/BENCHMARKS.md, "Render noise and ORB inliers", has the figures.

use scene_gen::camera_spec::CameraSpec;
use scene_gen::evaluate::{
    DetectorChoice, EVAL_DECOUPLED_MIN_WIDTH_PX, EVAL_DECOUPLED_STRIDE, EvalConfig, FrameWidth, eval_render_settings,
    evaluate,
};
use scene_gen::render::{RenderSettings, ShadingRate};

type BoxResult<T> = Result<T, Box<dyn std::error::Error>>;

fn main() -> BoxResult<()> {
    let setting = std::env::args().nth(1).unwrap_or_else(|| "eval".to_string());
    let decoupled = ShadingRate::Decoupled { stride: EVAL_DECOUPLED_STRIDE, min_width_px: EVAL_DECOUPLED_MIN_WIDTH_PX };
    let render = match setting.as_str() {
        "eval" => eval_render_settings(),
        // Nine window samples per anchor, each anchor on its own, stride 3.
        "unpooled" => RenderSettings {
            shading: ShadingRate::Adaptive { stride: 3, min_width_px: 0 },
            rect_samples_per_axis: 3,
            light_cull: 0.0,
            ..RenderSettings::preview()
        },
        "one-sample" => RenderSettings { shading: decoupled, ..RenderSettings::preview() },
        // Every light traced, 1 to 16 window samples per anchor.
        "all-lights-1" | "all-lights-4" | "all-lights-9" | "converged" => {
            let per_axis = match setting.as_str() {
                "all-lights-1" => 1,
                "all-lights-4" => 2,
                "all-lights-9" => 3,
                _ => 4,
            };
            RenderSettings {
                shading: decoupled,
                light_cull: 0.0,
                rect_samples_per_axis: per_axis,
                ..RenderSettings::preview()
            }
        }
        other => {
            eprintln!(
                "eval_render_noise: setting '{other}': expected eval, unpooled, one-sample, \
                 all-lights-1, all-lights-4, all-lights-9 or converged"
            );
            std::process::exit(2);
        }
    };
    let spec = CameraSpec::from_arg("IMX174,focal_mm=4,pitch_deg=-10")?;
    let config = EvalConfig {
        frames_per_scene: 25,
        max_width_px: FrameWidth::AtMost(1936),
        render,
        render_name: setting.clone(),
        // The figure is about ORB inliers; the detectability model keeps detection cheap at
        // 1936 px and as it was measured.
        detector: DetectorChoice::Model,
        ..EvalConfig::default()
    };
    let e = evaluate(&spec, &[0, 1], &config)?;
    println!("{}", serde_json::json!({ "setting": setting, "scenarios": e.scenarios }));
    Ok(())
}
