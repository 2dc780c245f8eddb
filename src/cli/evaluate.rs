//! `scene-gen evaluate`: the perception scores and fitness of one camera candidate
//! ([`scene_gen::evaluate`]).

use anyhow::anyhow;
use clap::Args;
use scene_gen::camera_spec::CameraSpec;
use scene_gen::evaluate::{DetectorChoice, EvalConfig, Evaluation, FrameWidth, ScenarioScore, evaluate_with_progress};
use scene_gen::isp::OutputRule;
use scene_gen::render::RenderSettings;
use scene_gen::seeds::{SeedRange, SeedsError};

use super::house::HouseArgs;
use super::progress::Progress;
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
    /// Bin the sensor down to at most this width in pixels (keeps the field of view), or
    /// `native`: every pixel of the sensor (a camera file's own `max_width_px` is ignored).
    #[arg(long, default_value_t = scene_gen::evaluate::FrameWidth::AtMost(scene_gen::evaluate::DEFAULT_MAX_WIDTH_PX).to_string())]
    pub max_width: String,
    /// Agent walking speed, m/s (the 0.5 s threshold window is 0.5 m of walk at 1.0 m/s).
    #[arg(long, allow_negative_numbers = true, default_value_t = scene_gen::evaluate::DEFAULT_SPEED_M_S)]
    pub speed_m_s: f64,
    /// 8-bit output rule: `isp` (black level, fixed gain per scenario, sRGB curve) or `top_bits`.
    #[arg(long, default_value = "isp")]
    pub output: String,
    /// Usable images a scenario needs to be scored on detection and ORB (default: half its
    /// anchor frames, rounded up).
    #[arg(long)]
    pub min_usable: Option<u32>,
    /// The detector: `cnn` (the learned detector on each 8-bit frame, default), `model` (the
    /// fast detectability model, about 1.3x quicker, reading the ground truth), or an external
    /// command (split on whitespace) run under
    /// the plug-in protocol on the anchor frames, where `{gt}` is replaced by the COCO
    /// ground-truth file written next to them.
    #[arg(long)]
    pub detector: Option<String>,
    /// Final-gather bounce rays per pixel in the evaluator's render, each bounce lit by its
    /// direct light and the irradiance volume (default 0: the volume alone, see
    /// `eval_render_settings`); sharper bounced light near contacts, at about twice the render
    /// time per ray.
    #[arg(long, default_value_t = 0)]
    pub bounce_rays: u32,
    /// Fill the shading anchors coarse to fine (`ShadingRate::Adaptive`). The evaluator always
    /// does; the flag is accepted and changes nothing.
    #[arg(long)]
    pub adaptive_anchors: bool,
    /// Add a `timing_s` breakdown to the output (not deterministic).
    #[arg(long)]
    pub timing: bool,
    /// Print the evaluation as JSON only.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub house: HouseArgs,
}

/// Most bounce rays per pixel `--bounce-rays` takes: beyond a few, `standard` and `high`
/// renders are the better tool, and a typo like 100 would run for hours.
const MAX_BOUNCE_RAYS: u32 = 16;

/// `A..B`, `A..=B` or `N` ([`scene_gen::seeds`]).
fn parse_seeds(text: &str) -> Result<Vec<u64>, CliError> {
    let range: SeedRange = text.parse().map_err(|e: SeedsError| bad_input(anyhow!("--{e}")))?;
    Ok(range.iter().collect())
}

fn row(name: &str, s: &ScenarioScore) -> String {
    format!(
        "{name:<6} {:>9.3} {:>7}/{:<3} {:>7.3} {:>9.1} {:>8.3} {:>4}/{:<3}{:>8.3}{}",
        s.threshold_accuracy,
        s.thresholds_seen,
        s.thresholds_seen + s.thresholds_missed,
        s.ap50,
        s.mean_inliers,
        s.inlier_ratio,
        s.usable_images,
        s.frames,
        s.fitness,
        if s.threshold_only { "  (threshold only: too few usable images)" } else { "" }
    )
}

fn summary(e: &Evaluation) -> String {
    let mut out = format!(
        "camera {} (focal {} mm, pitch {} deg), seeds {:?}\n",
        e.camera.sensor, e.camera.focal_mm, e.camera.pitch_deg, e.seeds
    );
    out.push_str("scene  threshold    seen     AP50   inliers    ratio  usable  fitness\n");
    out.push_str(&row("day", &e.scenarios.day));
    out.push('\n');
    out.push_str(&row("night", &e.scenarios.night));
    out.push('\n');
    if let Some(t) = &e.timing_s {
        out.push_str(&format!(
            "time: {:.1} s wall; thread-seconds: setup {:.1}, render {:.1}, sensor {:.1}, detection {:.1}, orb {:.1}; \
             plugin {:.1} s\n",
            t.wall, t.setup, t.render, t.sensor, t.detection, t.orb, t.plugin
        ));
    }
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
    let width = FrameWidth::parse(&args.max_width).map_err(|e| bad_input(anyhow!("--max-width: {e}")))?;
    if !(args.speed_m_s.is_finite() && args.speed_m_s > 0.0) {
        return Err(bad_input(anyhow!("--speed-m-s must be a positive number of m/s")));
    }
    let output = OutputRule::parse(&args.output).map_err(|e| bad_input(anyhow!("--output: {e}")))?;
    let detector = match &args.detector {
        None => DetectorChoice::default(),
        Some(text) => {
            DetectorChoice::parse(text).ok_or_else(|| bad_input(anyhow!("--detector: the command is empty")))?
        }
    };
    if args.bounce_rays > MAX_BOUNCE_RAYS {
        return Err(bad_input(anyhow!("--bounce-rays {}: at most {MAX_BOUNCE_RAYS}", args.bounce_rays)));
    }
    let house = args.house.checked()?;
    let defaults = EvalConfig::default();
    let (render, render_name) = match args.bounce_rays {
        0 => (defaults.render, defaults.render_name.clone()),
        n => (RenderSettings { indirect_rays: n, ..defaults.render }, format!("{}+bounce{n}", defaults.render_name)),
    };
    let config = EvalConfig {
        render,
        render_name,
        frames_per_scene: args.frames,
        max_width_px: width,
        speed_m_s: args.speed_m_s,
        output,
        min_usable_images: args.min_usable,
        detector,
        house,
        ..defaults
    };
    let progress = Progress::new("evaluate", "poses", 0);
    let evaluation = evaluate_with_progress(&spec, &seeds, &config, &progress);
    progress.finish();
    let mut evaluation = evaluation.map_err(|e| if e.is_bad_input() { bad_input(e) } else { failure(e) })?;
    if !args.timing {
        evaluation.timing_s = None;
    }
    if args.json {
        let mut json = serde_json::to_string_pretty(&evaluation).map_err(failure)?;
        json.push('\n');
        print!("{json}");
    } else {
        print!("{}", summary(&evaluation));
    }
    Ok(())
}
