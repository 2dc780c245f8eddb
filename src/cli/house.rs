//! The house options every command takes: `--envelope`, `--min-room`, `--rooms`, `--furniture`.

use std::path::PathBuf;

use anyhow::anyhow;
use clap::Args;
use scene_gen::house::HouseOptions;
use scene_gen::scene::Envelope;

use super::{CliError, bad_input};

/// How the houses are built besides their seeds. Options left out take the defaults (or, where
/// a command reads a record such as a manifest or a configuration, the record's values).
#[derive(Args, Debug, Clone, Default)]
pub struct HouseArgs {
    /// Envelope WIDTHxDEPTHxHEIGHT in metres [default: 15x15x3].
    #[arg(long, value_parser = parse_envelope)]
    pub envelope: Option<Envelope>,
    /// Smallest room side in metres, at wall centre lines [default: 5].
    #[arg(long)]
    pub min_room: Option<f32>,
    /// Room-type library folder [default: the embedded rooms/].
    #[arg(long)]
    pub rooms: Option<PathBuf>,
    /// Furniture library folder [default: the embedded furniture/].
    #[arg(long)]
    pub furniture: Option<PathBuf>,
}

fn parse_envelope(text: &str) -> Result<Envelope, String> {
    text.parse()
}

impl HouseArgs {
    /// The options given, over `base`.
    #[must_use]
    pub fn over(&self, base: HouseOptions) -> HouseOptions {
        HouseOptions {
            envelope: self.envelope.unwrap_or(base.envelope),
            min_room_m: self.min_room.unwrap_or(base.min_room_m),
            rooms: self.rooms.clone().or(base.rooms),
            furniture: self.furniture.clone().or(base.furniture),
        }
    }

    /// The options given over the defaults, checked: the envelope and room size fit, and the
    /// libraries load (so a bad folder is refused before any work).
    ///
    /// # Errors
    /// Bad input naming the option or library file at fault.
    pub fn checked(&self) -> Result<HouseOptions, CliError> {
        check(self.over(HouseOptions::default()))
    }
}

/// Checks `options` as [`HouseArgs::checked`] does.
pub fn check(options: HouseOptions) -> Result<HouseOptions, CliError> {
    options.validate().map_err(bad_input)?;
    options.library().map_err(|e| bad_input(anyhow!(e)))?;
    Ok(options)
}
