//! `scene-gen --seed N`: generate a house and write it out.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use scene_gen::export;
use scene_gen::generate::generate;
use scene_gen::house::HouseOptions;

use super::house::HouseArgs;
use super::{CliError, bad_input, failure};

/// Scene file formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Binary glTF, one file.
    Glb,
    /// glTF JSON with a separate scene.bin and textures/*.png.
    Gltf,
    /// Wavefront OBJ + MTL + textures/, Y up, one object (`o` and `g`) per node.
    Obj,
    /// USD text layer + textures/, Z up, metres, semantics labels (needs usd-core).
    Usda,
    /// USD binary (crate) layer + textures/ (needs usd-core).
    Usdc,
}

#[derive(Args, Debug)]
pub struct GenerateArgs {
    /// Seed of the house; the same seed and version give the same bytes.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output folder (created if missing).
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Scene file format.
    #[arg(long, value_enum, default_value_t = Format::Glb)]
    pub format: Format,
    #[command(flatten)]
    pub house: HouseArgs,
}

pub fn run(args: &GenerateArgs) -> Result<(), CliError> {
    let options = args.house.over(HouseOptions::default());
    options.validate().map_err(bad_input)?;
    let library = options.library().map_err(bad_input)?;
    let scene = generate(&options.config(args.seed), &library).map_err(bad_input)?;

    // Everything is encoded before anything is written, so a failure leaves no partial output.
    let files = export::scene_files(&scene, args.format.into(), &export::usd::find_python()).map_err(|e| match e {
        // A missing usd-core is the user's to fix (exit 2, install command).
        export::usd::UsdError::UsdCoreMissing { .. } => bad_input(e),
        _ => failure(e),
    })?;
    export::write_files(&args.out, &files).map_err(failure)
}

impl From<Format> for export::SceneFormat {
    fn from(format: Format) -> export::SceneFormat {
        match format {
            Format::Glb => export::SceneFormat::Glb,
            Format::Gltf => export::SceneFormat::Gltf,
            Format::Obj => export::SceneFormat::Obj,
            Format::Usda => export::SceneFormat::Usda,
            Format::Usdc => export::SceneFormat::Usdc,
        }
    }
}
