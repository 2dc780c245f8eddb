//! `scene-gen target chart|gap`: the test-chart image loop (see `scene_gen::target`).
//!
//! ```text
//! scene-gen target chart --camera CAMERA --out chart.png [--distance-m D] [--width-px W]
//!     chart.png (16-bit grey, DN at the ADC depth), chart.layout.json (patch boxes, edges),
//!     chart.mean.png (the noiseless expected image, DN x 16, for effect-injection tests)
//! scene-gen target gap MEASURED.png --camera CAMERA --out DIR [--json]
//!     DIR/report.md, DIR/report.json
//! ```
//!
//! The chart is simulated at most `--width-px` pixels across (the camera spec's `max_width_px`
//! wins when it is given): the loop re-simulates the chart many times.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, anyhow};
use clap::{Args, Subcommand};
use scene_gen::camera_spec::{CameraSpec, ResolvedCamera};
use scene_gen::export::write_atomic;
use scene_gen::sensor::Catalog;
use scene_gen::target::{self, LoopOptions, chart};

use super::progress::activity;
use super::sensors::emit;
use super::{CliError, bad_input, failure};

#[derive(Args, Debug)]
pub struct TargetArgs {
    #[command(subcommand)]
    pub command: TargetCommand,
}

#[derive(Subcommand, Debug)]
pub enum TargetCommand {
    /// Simulate the test chart as the camera sees it; writes the PNG and its layout JSON.
    Chart(ChartArgs),
    /// Compare a photograph of the chart with its simulation; name the missing effects.
    Gap(TargetGapArgs),
}

/// Arguments both commands share: they fix the layout.
#[derive(Args, Debug)]
pub struct ChartGeometry {
    /// Camera: a TOML file or `SENSOR[,key=value]...`.
    #[arg(long)]
    pub camera: String,
    /// Distance of the chart, metres (sets its size in metres; the pixel layout is the same).
    #[arg(long, default_value_t = 1.0)]
    pub distance_m: f64,
    /// Simulated width in pixels when the camera spec gives no `max_width_px`.
    #[arg(long, default_value_t = 320)]
    pub width_px: u32,
}

#[derive(Args, Debug)]
pub struct ChartArgs {
    #[command(flatten)]
    pub geometry: ChartGeometry,
    /// Output PNG; the layout goes to `<stem>.layout.json`, the noiseless image to
    /// `<stem>.mean.png`.
    #[arg(long)]
    pub out: PathBuf,
    /// Seed of the temporal noise of this frame.
    #[arg(long, default_value_t = 1)]
    pub frame_seed: u64,
    /// Seed of the sensor instance's fixed patterns.
    #[arg(long, default_value_t = 1)]
    pub pattern_seed: u64,
}

#[derive(Args, Debug)]
pub struct TargetGapArgs {
    /// The measured photograph: a grey PNG registered to the chart layout.
    pub measured: PathBuf,
    #[command(flatten)]
    pub geometry: ChartGeometry,
    /// Output folder: report.md, report.json.
    #[arg(long)]
    pub out: PathBuf,
    /// Print only the JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
    /// Seed of the simulated frames.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
}

pub fn run(args: &TargetArgs) -> Result<(), CliError> {
    match &args.command {
        TargetCommand::Chart(a) => run_chart(a),
        TargetCommand::Gap(a) => run_gap(a),
    }
}

fn resolve(g: &ChartGeometry) -> Result<ResolvedCamera, CliError> {
    if !(g.distance_m.is_finite() && g.distance_m > 0.0) {
        return Err(bad_input(anyhow!("--distance-m must be a finite number > 0, got {}", g.distance_m)));
    }
    if !(16..=8192).contains(&g.width_px) {
        return Err(bad_input(anyhow!("--width-px must be in 16..8192, got {}", g.width_px)));
    }
    let mut spec = CameraSpec::from_arg(&g.camera).context("--camera").map_err(bad_input)?;
    spec.max_width_px = spec.max_width_px.or(Some(g.width_px));
    let resolved = spec.resolve(&Catalog::embedded()).context("--camera").map_err(bad_input)?;
    if resolved.width_px < 16 || resolved.height_px < 10 {
        return Err(bad_input(anyhow!(
            "the chart needs at least 16x10 pixels, got {}x{}",
            resolved.width_px,
            resolved.height_px
        )));
    }
    Ok(resolved)
}

fn png16(values: &[u16], w: usize, h: usize) -> Result<Vec<u8>, CliError> {
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(w as u32, h as u32, values.to_vec())
        .ok_or_else(|| failure(anyhow!("image buffer size")))?;
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).map_err(failure)?;
    Ok(bytes)
}

fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "chart".into());
    path.with_file_name(format!("{stem}{suffix}"))
}

fn run_chart(args: &ChartArgs) -> Result<(), CliError> {
    let resolved = resolve(&args.geometry)?;
    let layout = chart::chart_layout(&resolved, args.geometry.distance_m);
    let photons = chart::photon_image(&resolved, &layout);
    let model = resolved.sensor_model(args.pattern_seed);
    let (w, h) = (layout.width_px, layout.height_px);
    let noisy = png16(&chart::simulate(&model, &layout, &photons, args.frame_seed), w, h)?;
    let mean16: Vec<u16> = chart::expected(&model, &layout, &photons)
        .iter()
        .map(|v| (v * chart::MEAN_PNG_SCALE).round().clamp(0.0, 65535.0) as u16)
        .collect();
    let mean = png16(&mean16, w, h)?;
    let json = serde_json::to_string_pretty(&layout).map_err(failure)?;
    let (layout_path, mean_path) = (sibling(&args.out, ".layout.json"), sibling(&args.out, ".mean.png"));
    if let Some(dir) = args.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display())).map_err(failure)?;
    }
    write_atomic(&args.out, &noisy).map_err(failure)?;
    write_atomic(&layout_path, format!("{json}\n").as_bytes()).map_err(failure)?;
    write_atomic(&mean_path, &mean).map_err(failure)?;
    emit(&format!(
        "chart {w}x{h} ({} bit, {:.1} lux, {:.2} x {:.2} m at {} m): {}, {}, {}\n",
        layout.bits,
        layout.illuminance_lux,
        layout.chart_width_m,
        layout.chart_height_m,
        layout.distance_m,
        args.out.display(),
        layout_path.display(),
        mean_path.display()
    ));
    Ok(())
}

fn run_gap(args: &TargetGapArgs) -> Result<(), CliError> {
    if !args.measured.is_file() {
        return Err(bad_input(anyhow!("{}: no such file", args.measured.display())));
    }
    let resolved = resolve(&args.geometry)?;
    let options = LoopOptions { seed: args.seed, ..LoopOptions::default() };
    let result = activity("target gap", || target::run(&args.measured, &resolved, args.geometry.distance_m, &options))
        .map_err(bad_input)?;
    let summary = result.json();
    let text = serde_json::to_string_pretty(&summary).map_err(failure)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))
        .map_err(failure)?;
    write_atomic(&args.out.join("report.json"), format!("{text}\n").as_bytes()).map_err(failure)?;
    let md = result.markdown(&args.measured.display().to_string());
    write_atomic(&args.out.join("report.md"), md.as_bytes()).map_err(failure)?;
    if args.json {
        emit(&format!("{text}\n"));
    } else {
        let named = result.named();
        emit(&format!(
            "gap {:.3} -> {:.3} ({:.1} % smaller); named: {}\nreport: {}\n",
            result.gap_initial.gap,
            result.gap_final.gap,
            result.shrink_percent(),
            if named.is_empty() { "none".to_string() } else { named.join(", ") },
            args.out.join("report.md").display()
        ));
    }
    Ok(())
}
