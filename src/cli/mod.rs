//! Command-line definitions and dispatch.

mod calibrate;
mod dataset;
mod detect;
mod evaluate;
mod gap;
mod generate;
mod house;
mod isp;
mod optimize;
mod orb;
mod progress;
mod render;
mod sensors;
mod serve;
mod target;

use clap::{Parser, Subcommand};

/// A command's failure, classified for the exit status.
pub struct CliError {
    pub error: anyhow::Error,
    /// True when the input (arguments, files) was at fault: exit status 2.
    pub bad_input: bool,
}

impl CliError {
    pub fn status(&self) -> u8 {
        if self.bad_input { 2 } else { 1 }
    }
}

/// Marks an error as caused by the user's input (exit 2).
pub fn bad_input(error: impl Into<anyhow::Error>) -> CliError {
    CliError { error: error.into(), bad_input: true }
}

/// Marks an error as a failure while working (exit 1).
pub fn failure(error: impl Into<anyhow::Error>) -> CliError {
    CliError { error: error.into(), bad_input: false }
}

/// The release version and the commit it was built from.
const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), " (commit ", env!("SCENE_GEN_COMMIT"), ")");

/// Seeded indoor environments and camera simulation for task-specific camera design.
#[derive(Parser, Debug)]
#[command(name = "scene-gen", version = VERSION, about, args_conflicts_with_subcommands = true)]
pub struct Cli {
    /// No progress reports on stderr (errors are still written).
    #[arg(long, global = true)]
    pub quiet: bool,
    #[command(flatten)]
    pub generate: generate::GenerateArgs,
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Generate one house and write it out (the same as `scene-gen` with these options alone).
    Generate(generate::GenerateArgs),
    /// Print the sensor catalog.
    Sensors(sensors::SensorsArgs),
    /// EMVA 1288 calibration of a measured camera (descriptor + images, or photon-transfer CSV).
    Calibrate(calibrate::CalibrateArgs),
    /// Sim-vs-measured gap: names the effects the sensor model misses, adds them, reports.
    Gap(gap::GapArgs),
    /// ORB keypoints and descriptors of an image, as OpenCV's ORB computes them.
    Orb(orb::OrbArgs),
    /// Cross-checked ORB matches between two images and their RANSAC fundamental-matrix inliers.
    Match(orb::MatchArgs),
    /// Develop a raw Bayer mosaic (8- or 16-bit PNG) into an 8-bit sRGB PNG.
    Isp(isp::IspArgs),
    /// Sensor images, depth and instance masks of a camera walking through a generated house.
    Render(render::RenderArgs),
    /// Perception scores (thresholds, AP@0.5, ORB) and fitness of a camera candidate.
    Evaluate(evaluate::EvaluateArgs),
    /// The evaluator as a JSON-lines server (stdin requests, stdout scores) for any optimizer.
    Serve(serve::ServeArgs),
    /// COCO dataset (images, depth, instance masks, annotations) over a seed range, shardable.
    Dataset(dataset::DatasetArgs),
    /// The learned detector on any images: COCO results per image (`--json` for pycocotools).
    Detect(detect::DetectArgs),
    /// The learned detector's training.
    Detector(detect::DetectorArgs),
    /// Test-chart loop: simulate a chart image, or name the effects a chart photograph shows.
    Target(target::TargetArgs),
    /// Camera-design optimizer: the TaCOS genetic algorithm or random search, resumable.
    Optimize(optimize::OptimizeArgs),
    /// Shell completion script (bash, zsh, fish, elvish, powershell) on stdout.
    Completions(CompletionsArgs),
}

#[derive(clap::Args, Debug)]
pub struct CompletionsArgs {
    /// The shell, e.g. `scene-gen completions bash > ~/.local/share/bash-completion/completions/scene-gen`.
    #[arg(value_enum)]
    pub shell: clap_complete::Shell,
}

/// Writes the completion script of `shell` to stdout.
fn completions(args: &CompletionsArgs) -> Result<(), CliError> {
    use clap::CommandFactory as _;
    clap_complete::generate(args.shell, &mut Cli::command(), "scene-gen", &mut std::io::stdout());
    Ok(())
}

pub fn parse() -> Cli {
    Cli::parse()
}

pub fn run(cli: Cli) -> Result<(), CliError> {
    progress::set_quiet(cli.quiet);
    match cli.command {
        None => generate::run(&cli.generate),
        Some(Command::Generate(args)) => generate::run(&args),
        Some(Command::Sensors(args)) => sensors::run(&args),
        Some(Command::Calibrate(args)) => calibrate::run(&args),
        Some(Command::Gap(args)) => gap::run(&args),
        Some(Command::Orb(args)) => orb::run_orb(&args),
        Some(Command::Match(args)) => orb::run_match(&args),
        Some(Command::Isp(args)) => isp::run(&args),
        Some(Command::Render(args)) => render::run(&args),
        Some(Command::Evaluate(args)) => evaluate::run(&args),
        Some(Command::Serve(args)) => serve::run(&args),
        Some(Command::Dataset(args)) => dataset::run(&args),
        Some(Command::Detect(args)) => detect::run_detect(&args),
        Some(Command::Detector(args)) => detect::run_detector(&args),
        Some(Command::Target(args)) => target::run(&args),
        Some(Command::Optimize(args)) => optimize::run(&args),
        Some(Command::Completions(args)) => completions(&args),
    }
}
