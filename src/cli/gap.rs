//! `scene-gen gap MEASURED [--model FILE] --out DIR [--json]`: the sim-vs-measured gap
//! workflow (see `scene_gen::gap`).

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use scene_gen::gap::{self, GapModel, GapOptions, Optics};
use scene_gen::sensor::SensorModel;

use super::progress::activity;
use super::sensors::emit;
use super::{CliError, bad_input, failure};

#[derive(Args, Debug)]
pub struct GapArgs {
    /// An EMVA 1288 descriptor with its images; or several descriptors of one camera at
    /// different gains (the first is the reference; the others' gains are measured from their
    /// response); or one photon-transfer CSV (`.csv`, with a gain column).
    #[arg(required = true, num_args = 1..)]
    pub measured: Vec<PathBuf>,
    /// Start from this sensor model (model.toml form) instead of the calibrated linear model.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Output folder: report.md, report.json, PNG plots, model.toml, optics.toml.
    #[arg(long)]
    pub out: PathBuf,
    /// Print only the JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
    /// Frames used of each spatial stack (the first ones); 0: all.
    #[arg(long, default_value_t = 32)]
    pub stack_frames: usize,
    /// Seed of the simulated acquisitions.
    #[arg(long, default_value_t = 1288)]
    pub seed: u64,
    /// Simulate every candidate in full instead of screening them on the top quarter of the
    /// rows first (frames of 240 rows or more; see `scene_gen::gap::GapOptions::screen`).
    #[arg(long)]
    pub no_screen: bool,
    /// Replicate simulations of the final model that the leftover misfit is tested against
    /// (report "Unexplained"); 0 skips the test.
    #[arg(long, default_value_t = scene_gen::gap::misfit::DEFAULT_REPLICATES)]
    pub replicates: usize,
    /// Simulate every pixel of every frame through the noise model instead of drawing pixels
    /// from their moments where those describe them (frames of 240 rows or more; slower; see
    /// `scene_gen::gap::Draws`).
    #[arg(long)]
    pub pixel_draws: bool,
}

pub fn run(args: &GapArgs) -> Result<(), CliError> {
    let model = match &args.model {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read {}", path.display()))
                .map_err(bad_input)?;
            let sensor =
                SensorModel::from_toml(&text).with_context(|| format!("{}", path.display())).map_err(bad_input)?;
            Some(GapModel { sensor, optics: Optics::default() })
        }
        None => None,
    };
    let options = GapOptions {
        seed: args.seed,
        max_stack_frames: (args.stack_frames > 0).then_some(args.stack_frames),
        screen: !args.no_screen,
        replicates: args.replicates,
        draws: if args.pixel_draws { gap::Draws::Pixels } else { gap::Draws::Moments },
        ..GapOptions::default()
    };
    let result = activity("gap", || gap::run_inputs(&args.measured, model, &options)).map_err(bad_input)?;
    let source = args.measured.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(" ");
    let files = gap::report::render(&result, &source).map_err(failure)?;
    gap::report::write(&args.out, &files).map_err(failure)?;
    if args.json {
        let text = serde_json::to_string_pretty(&gap::report::summary_json(&result)).map_err(failure)?;
        emit(&format!("{text}\n"));
    } else {
        let shrink = if result.gap_initial.gap > 0.0 {
            100.0 * (1.0 - result.gap_final.gap / result.gap_initial.gap)
        } else {
            0.0
        };
        let named = result.named();
        let unexplained = result.unexplained();
        emit(&format!(
            "gap {:.3} -> {:.3} ({shrink:.1} % smaller); named: {}; unexplained: {}\nreport: {}\n",
            result.gap_initial.gap,
            result.gap_final.gap,
            if named.is_empty() { "none".to_string() } else { named.join(", ") },
            if unexplained.is_empty() { "none".to_string() } else { unexplained.join(", ") },
            args.out.join("report.md").display()
        ));
    }
    Ok(())
}
