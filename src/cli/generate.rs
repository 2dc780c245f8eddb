//! `scene-gen --seed N`: generate a house and write it out.

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use clap::{Args, ValueEnum};
use scene_gen::export::{self, write_atomic};
use scene_gen::generate::generate;
use scene_gen::house::HouseOptions;
use scene_gen::manifest::Manifest;

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

    // Encode everything before writing anything, so a failure leaves no partial output.
    let mut files = match args.format {
        Format::Glb => vec![("scene.glb".to_string(), export::gltf::to_glb(&scene))],
        Format::Gltf => export::gltf::to_gltf(&scene),
        Format::Obj => export::obj::to_obj(&scene),
        Format::Usda => usd(&scene, export::usd::UsdFormat::Usda)?,
        Format::Usdc => usd(&scene, export::usd::UsdFormat::Usdc)?,
    };
    files.push(("scene.json".into(), Manifest::of(&scene).to_json().into_bytes()));
    files.push(("plan.png".into(), export::plan::to_png(&scene)));
    write_all(&args.out, &files)
}

/// USD through usd-core; a missing usd-core is the user's to fix (exit 2, install command).
fn usd(scene: &scene_gen::scene::Scene, format: export::usd::UsdFormat) -> Result<Vec<(String, Vec<u8>)>, CliError> {
    use export::usd::UsdError;
    export::usd::to_usd(scene, format, &export::usd::find_python()).map_err(|e| match e {
        UsdError::UsdCoreMissing { .. } => bad_input(e),
        _ => failure(e),
    })
}

/// Writes every file under `out`, each atomically.
fn write_all(out: &Path, files: &[(String, Vec<u8>)]) -> Result<(), CliError> {
    for (name, bytes) in files {
        let path = out.join(name);
        let dir = path.parent().unwrap_or(out);
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create output folder {}", dir.display()))
            .map_err(failure)?;
        write_atomic(&path, bytes).map_err(|e| failure(anyhow!(e)))?;
    }
    Ok(())
}
