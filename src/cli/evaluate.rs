//! `scene-gen evaluate`: the perception scores and fitness of one camera candidate
//! ([`scene_gen::evaluate`]).

use anyhow::anyhow;
use clap::Args;
use scene_gen::camera_spec::CameraSpec;
use scene_gen::evaluate::{EvalConfig, EvalError, Evaluation, ScenarioScore, evaluate};
use scene_gen::render::RenderSettings;

use super::{CliError, bad_input, failure};

#[derive(Args, Debug)]
pub struct EvaluateArgs {
    /// Camera: a TOML file or `SENSOR[,focal_mm=F][,pitch_deg=P][,height_m=H][,key=value...]`.
    #[arg(long)]
    pub camera: String,
    /// House seeds: `A..B` (half-open, as in Rust: `0..3` is 0, 1, 2), `A..=B`, or one seed.
    #[arg(long, default_value = "0..1")]
    pub seeds: String,
    /// Anchor frames per house, evenly spaced along the walk.
    #[arg(long, default_value_t = scene_gen::evaluate::DEFAULT_FRAMES_PER_SCENE)]
    pub frames: u32,
    /// Bin the sensor down to at most this width in pixels (keeps the field of view).
    #[arg(long, default_value_t = scene_gen::evaluate::DEFAULT_MAX_WIDTH_PX)]
    pub max_width: u32,
    /// Print the evaluation as JSON only.
    #[arg(long)]
    pub json: bool,
}

/// `A..B`, `A..=B` or `N`.
fn parse_seeds(text: &str) -> Result<Vec<u64>, CliError> {
    let bad = || bad_input(anyhow!("--seeds '{text}': expected A..B, A..=B or a seed"));
    let t = text.trim();
    let seeds: Vec<u64> = if let Some((a, b)) = t.split_once("..=") {
        let (a, b): (u64, u64) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
        (a..=b).collect()
    } else if let Some((a, b)) = t.split_once("..") {
        let (a, b): (u64, u64) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
        (a..b).collect()
    } else {
        vec![t.parse().map_err(|_| bad())?]
    };
    if seeds.is_empty() {
        return Err(bad_input(anyhow!("--seeds '{text}' is empty")));
    }
    Ok(seeds)
}

fn row(name: &str, s: &ScenarioScore) -> String {
    format!(
        "{name:<6} {:>9.3} {:>7}/{:<3} {:>7.3} {:>9.1} {:>8.3} {:>7} {:>8.3}",
        s.threshold_accuracy,
        s.thresholds_seen,
        s.thresholds_seen + s.thresholds_missed,
        s.ap50,
        s.mean_inliers,
        s.inlier_ratio,
        s.frames,
        s.fitness
    )
}

fn summary(e: &Evaluation) -> String {
    let mut out = format!(
        "camera {} (focal {} mm, pitch {} deg), seeds {:?}\n",
        e.camera.sensor, e.camera.focal_mm, e.camera.pitch_deg, e.seeds
    );
    out.push_str("scene  threshold    seen     AP50   inliers    ratio  frames  fitness\n");
    out.push_str(&row("day", &e.scenarios.day));
    out.push('\n');
    out.push_str(&row("night", &e.scenarios.night));
    out.push('\n');
    out.push_str(&format!(
        "fitness: day {:.3}, night {:.3}, mean {:.3}\n",
        e.fitness.day, e.fitness.night, e.fitness.mean
    ));
    out
}

pub fn run(args: &EvaluateArgs) -> Result<(), CliError> {
    let spec = CameraSpec::from_arg(&args.camera).map_err(bad_input)?;
    let seeds = parse_seeds(&args.seeds)?;
    if args.frames == 0 {
        return Err(bad_input(anyhow!("--frames must be at least 1")));
    }
    if args.max_width == 0 {
        return Err(bad_input(anyhow!("--max-width must be at least 1")));
    }
    let config = EvalConfig {
        frames_per_scene: args.frames,
        max_width_px: Some(args.max_width),
        render: RenderSettings::preview(),
        ..EvalConfig::default()
    };
    let evaluation = evaluate(&spec, &seeds, &config).map_err(|e| match e {
        EvalError::Spec(_) | EvalError::NoSeeds | EvalError::NoFrames => bad_input(e),
        other => failure(other),
    })?;
    if args.json {
        let mut json = serde_json::to_string_pretty(&evaluation).map_err(failure)?;
        json.push('\n');
        print!("{json}");
    } else {
        print!("{}", summary(&evaluation));
    }
    Ok(())
}
