//! `scene-gen --seed N`: generate a house and write it out.

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use clap::{Args, ValueEnum};
use scene_gen::config::GeneratorConfig;
use scene_gen::export::{self, write_atomic};
use scene_gen::generate::generate;
use scene_gen::library::{Library, LibrarySource};
use scene_gen::manifest::Manifest;
use scene_gen::scene::Envelope;

use super::{CliError, bad_input, failure};

/// Scene file formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Binary glTF, one file.
    Glb,
    /// glTF JSON with a separate scene.bin and textures/*.png.
    Gltf,
    /// Wavefront OBJ + MTL + textures/, Y up, one group per object.
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
    /// Envelope WIDTHxDEPTHxHEIGHT in metres.
    #[arg(long, default_value = "15x15x3", value_parser = parse_envelope)]
    pub envelope: Envelope,
    /// Smallest room side in metres, at wall centre lines.
    #[arg(long, default_value_t = 5.0)]
    pub min_room: f32,
    /// Room-type library folder (default: the embedded rooms/).
    #[arg(long)]
    pub rooms: Option<PathBuf>,
    /// Furniture library folder (default: the embedded furniture/).
    #[arg(long)]
    pub furniture: Option<PathBuf>,
}

/// Parses `WxDxH` in metres.
fn parse_envelope(text: &str) -> Result<Envelope, String> {
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    let [w, d, h] = parts.as_slice() else {
        return Err(format!("'{text}' is not WIDTHxDEPTHxHEIGHT in metres, e.g. 15x15x3"));
    };
    let num = |s: &str, what: &str| {
        s.trim().parse::<f32>().map_err(|_| format!("'{s}' in '{text}' is not a number ({what})"))
    };
    Ok(Envelope { width_m: num(w, "width")?, depth_m: num(d, "depth")?, height_m: num(h, "height")? })
}

fn source(path: Option<&Path>) -> LibrarySource<'_> {
    path.map_or(LibrarySource::Embedded, LibrarySource::Folder)
}

pub fn run(args: &GenerateArgs) -> Result<(), CliError> {
    let library = Library::load(source(args.rooms.as_deref()), source(args.furniture.as_deref())).map_err(bad_input)?;
    let config = GeneratorConfig {
        seed: args.seed,
        envelope: args.envelope,
        min_room_m: args.min_room,
        ..GeneratorConfig::default()
    };
    config.validate().map_err(bad_input)?;
    let scene = generate(&config, &library).map_err(bad_input)?;

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
