//! `scene-gen target chart|gap`: the test-chart image loop (see `scene_gen::target`).
//!
//! ```text
//! scene-gen target chart --camera CAMERA --out chart.png [--distance-m D] [--width-px W]
//!     chart.png (16-bit grey, DN at the ADC depth), chart.layout.json (patch boxes, edges),
//!     chart.mean.png (the noiseless expected image, DN x 16, for effect-injection tests)
//! scene-gen target gap MEASURED.png --camera CAMERA --out DIR [--json]
//!     DIR/report.md, DIR/report.json
//! scene-gen target colour --camera CAMERA --out DIR [--lighting day|night|both] [--json]
//!     DIR/colour_chart_<lighting>.png (8-bit sRGB), DIR/colour_chart_<lighting>_raw.png
//!     (16-bit mosaic), DIR/colour_chart.json (every patch's CIEDE2000)
//! ```
//!
//! The chart is simulated at most `--width-px` pixels across (the camera spec's `max_width_px`
//! wins when it is given): the loop re-simulates the chart many times.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, anyhow};
use clap::{Args, Subcommand};
use scene_gen::camera_spec::{CameraSpec, ResolvedCamera};
use scene_gen::capture::{illuminant, scenario_name, target_lux};
use scene_gen::colour_checker;
use scene_gen::export::write_atomic;
use scene_gen::scene::LightGroup;
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
    /// Photograph a ColorChecker through the camera's colour chain; CIEDE2000 of every patch.
    Colour(ColourArgs),
}

#[derive(Args, Debug)]
pub struct ColourArgs {
    /// Camera (a colour sensor): a TOML file or `SENSOR[,key=value]...`; e.g. add
    /// `noise=off,vignetting=false` to measure the colour chain alone.
    #[arg(long)]
    pub camera: String,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long, value_enum, default_value_t = super::render::Lighting::Day)]
    pub lighting: super::render::Lighting,
    /// Simulated width in pixels when the camera spec gives no `max_width_px`.
    #[arg(long, default_value_t = 320)]
    pub width_px: u32,
    /// Print only the JSON on stdout.
    #[arg(long)]
    pub json: bool,
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
        TargetCommand::Colour(a) => run_colour(a),
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
        let unexplained = result.unexplained();
        let list = |v: Vec<String>| if v.is_empty() { "none".to_string() } else { v.join(", ") };
        emit(&format!(
            "gap {:.3} -> {:.3} ({:.1} % smaller); named: {}; tentative: {}; unexplained: {}\nreport: {}\n",
            result.gap_initial.gap,
            result.gap_final.gap,
            result.shrink_percent(),
            list(named),
            list(result.tentative()),
            list(unexplained.into_iter().map(String::from).collect()),
            args.out.join("report.md").display()
        ));
    }
    Ok(())
}

/// The ColorChecker through each scenario of `--lighting`.
#[derive(serde::Serialize)]
struct ColourReport<'a> {
    camera: &'a str,
    sensor: &'a str,
    width: u32,
    height: u32,
    lightings: Vec<ColourLighting>,
}

#[derive(serde::Serialize)]
struct ColourLighting {
    lighting: &'static str,
    illuminant: String,
    target_lux: f32,
    gain_db: f64,
    #[serde(flatten)]
    score: colour_checker::ChartScore,
}

fn run_colour(args: &ColourArgs) -> Result<(), CliError> {
    let geometry = ChartGeometry { camera: args.camera.clone(), distance_m: 1.0, width_px: args.width_px };
    let resolved = resolve(&geometry)?;
    let groups: &[LightGroup] = match args.lighting {
        super::render::Lighting::Day => &[LightGroup::Day],
        super::render::Lighting::Night => &[LightGroup::Night],
        super::render::Lighting::Both => &[LightGroup::Day, LightGroup::Night],
    };
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    let mut lightings = Vec::new();
    for &group in groups {
        let photo = colour_checker::photograph(&resolved, group, (1, 1)).ok_or_else(|| {
            bad_input(anyhow!(
                "--camera: {} has no colour filter array (a monochrome sensor or the affine noise path)",
                resolved.sensor.model
            ))
        })?;
        let name = scenario_name(group);
        let (w, h) = (photo.raw.width, photo.raw.height);
        let rgb = image::RgbImage::from_raw(w, h, photo.srgb.clone()).ok_or_else(|| failure(anyhow!("image size")))?;
        let mut png = Vec::new();
        rgb.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).map_err(failure)?;
        files.push((format!("colour_chart_{name}.png"), png));
        files.push((format!("colour_chart_{name}_raw.png"), png16(&photo.raw.dn, w as usize, h as usize)?));
        lightings.push(ColourLighting {
            lighting: name,
            illuminant: format!("{:?}", illuminant(group)),
            target_lux: target_lux(group),
            gain_db: if group == LightGroup::Day { resolved.spec.gain_day_db } else { resolved.spec.gain_night_db },
            score: photo.score,
        });
    }
    let report = ColourReport {
        camera: &args.camera,
        sensor: &resolved.sensor.model,
        width: resolved.width_px,
        height: resolved.height_px,
        lightings,
    };
    let text = serde_json::to_string_pretty(&report).map_err(failure)?;
    files.push(("colour_chart.json".to_string(), format!("{text}\n").into_bytes()));
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))
        .map_err(failure)?;
    for (name, bytes) in &files {
        write_atomic(&args.out.join(name), bytes).map_err(failure)?;
    }
    if args.json {
        emit(&format!("{text}\n"));
        return Ok(());
    }
    let mut table = String::new();
    for l in &report.lightings {
        table.push_str(&format!("{} ({}, {} lux, {:.1} dB):\n", l.lighting, l.illuminant, l.target_lux, l.gain_db));
        for p in &l.score.patches {
            let m = p.measured_srgb;
            table.push_str(&format!(
                "  {:<14} sRGB {:>3} {:>3} {:>3} -> {:>5.1} {:>5.1} {:>5.1}  dE00 {:.2}\n",
                p.name, p.reference_srgb[0], p.reference_srgb[1], p.reference_srgb[2], m[0], m[1], m[2], p.delta_e_2000
            ));
        }
        table.push_str(&format!("  mean dE00 {:.2}, max {:.2}\n", l.score.mean_delta_e_2000, l.score.max_delta_e_2000));
    }
    table.push_str(&format!("wrote {} files to {}\n", files.len(), args.out.display()));
    emit(&table);
    Ok(())
}
