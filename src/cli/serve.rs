//! `scene-gen serve`: the evaluator as a JSON-lines server on stdin/stdout, for any optimizer
//! (the protocol is documented in [`scene_gen::serve`]).

use std::io::IsTerminal;

use anyhow::anyhow;
use clap::Args;
use scene_gen::evaluate::{DetectorChoice, FrameWidth};
use scene_gen::serve::{PROTOCOL, ServeDefaults, parse_seeds, serve};

use super::house::HouseArgs;
use super::{CliError, bad_input, failure};

#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Default house seeds of a request that gives none: `A..B` (half-open), `A..=B` or one seed.
    #[arg(long, default_value = "0..1")]
    pub seeds: String,
    /// Default anchor frames per house.
    #[arg(long, default_value_t = scene_gen::evaluate::DEFAULT_FRAMES_PER_SCENE)]
    pub frames: u32,
    /// Default binned image width in pixels, or `native` (a request's `max_width` or its
    /// camera's `max_width_px` wins).
    #[arg(long, default_value_t = scene_gen::evaluate::FrameWidth::AtMost(scene_gen::evaluate::DEFAULT_MAX_WIDTH_PX).to_string())]
    pub max_width: String,
    /// The detector of every request: `cnn` (the learned detector), `model` (the fast
    /// detectability model) or an external command.
    #[arg(long, default_value = "cnn")]
    pub detector: String,
    /// The houses every request is evaluated in.
    #[command(flatten)]
    pub house: HouseArgs,
}

pub fn run(args: &ServeArgs) -> Result<(), CliError> {
    let seeds = parse_seeds(&args.seeds).map_err(|e| bad_input(anyhow!("--{e}")))?;
    if args.frames == 0 {
        return Err(bad_input(anyhow!("--frames must be at least 1")));
    }
    let max_width = FrameWidth::parse(&args.max_width).map_err(|e| bad_input(anyhow!("--max-width: {e}")))?;
    let house = args.house.checked()?;
    let detector =
        DetectorChoice::parse(&args.detector).ok_or_else(|| bad_input(anyhow!("--detector: the command is empty")))?;
    let defaults = ServeDefaults { seeds, frames: args.frames, max_width, house, detector };
    let stdin = std::io::stdin();
    if stdin.is_terminal() {
        eprintln!(
            "scene-gen serve ({PROTOCOL}): one JSON request per line, e.g. \
             {{\"id\": 1, \"camera\": \"IMX174,focal_mm=4\"}} or {{\"op\": \"describe\"}}; Ctrl-D ends"
        );
    }
    let stdout = std::io::stdout();
    serve(stdin.lock(), stdout.lock(), &defaults).map_err(|e| failure(anyhow!("serve: {e}")))?;
    Ok(())
}
