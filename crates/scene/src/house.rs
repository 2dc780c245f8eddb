//! A seeded house with the agent's walk through it: where `evaluate`, `dataset` and `render`
//! all start, so they build the same house and walk for the same seed and fail with the same
//! words. [`HouseOptions`] is what every command takes besides the seed (`--envelope`,
//! `--min-room`, `--rooms`, `--furniture`), so a house means the same thing everywhere.

use std::path::PathBuf;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::config::{ConfigError, GeneratorConfig};
use crate::generate::generate;
use crate::library::{Library, LibraryError, LibrarySource};
use crate::scene::{Envelope, Scene};
use crate::trajectory::{self, Trajectory, TrajectoryError, TrajectoryParams};

/// How every house of a run is built besides its seed: the envelope, the smallest room and the
/// libraries. Serialised with the envelope as `WIDTHxDEPTHxHEIGHT` text, as on the command line.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HouseOptions {
    #[serde(serialize_with = "envelope_text", deserialize_with = "envelope_from_text")]
    pub envelope: Envelope,
    pub min_room_m: f32,
    /// Room-type library folder; `None`: the embedded library.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rooms: Option<PathBuf>,
    /// Furniture library folder; `None`: the embedded library.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub furniture: Option<PathBuf>,
}

impl Default for HouseOptions {
    fn default() -> Self {
        let config = GeneratorConfig::default();
        HouseOptions { envelope: config.envelope, min_room_m: config.min_room_m, rooms: None, furniture: None }
    }
}

fn source(folder: Option<&std::path::Path>) -> LibrarySource<'_> {
    folder.map_or(LibrarySource::Embedded, LibrarySource::Folder)
}

fn envelope_text<S: Serializer>(envelope: &Envelope, serializer: S) -> Result<S::Ok, S::Error> {
    serializer.collect_str(envelope)
}

fn envelope_from_text<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Envelope, D::Error> {
    String::deserialize(deserializer)?.parse().map_err(serde::de::Error::custom)
}

impl HouseOptions {
    /// True for the embedded libraries in the default 15 x 15 x 3 m envelope with 5 m rooms:
    /// records leave such options out, so default runs keep their bytes.
    #[must_use]
    pub fn is_default(&self) -> bool {
        *self == HouseOptions::default()
    }

    /// The generator's request for the house of `seed`.
    #[must_use]
    pub fn config(&self, seed: u64) -> GeneratorConfig {
        GeneratorConfig { seed, envelope: self.envelope, min_room_m: self.min_room_m, ..GeneratorConfig::default() }
    }

    /// Checks the envelope and room size, as the generator would for any seed.
    ///
    /// # Errors
    /// The [`ConfigError`] naming the option at fault.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.config(0).validate()
    }

    /// Loads the libraries these options name.
    ///
    /// # Errors
    /// A [`LibraryError`] naming the file (and line) at fault.
    pub fn library(&self) -> Result<Library, LibraryError> {
        Library::load(source(self.rooms.as_deref()), source(self.furniture.as_deref()))
    }
}

/// The house of one seed (default generator settings) and the agent's walk through it.
#[derive(Debug)]
pub struct WalkedHouse {
    pub scene: Scene,
    pub walk: Trajectory,
}

/// Why a house or its walk could not be made.
#[derive(Debug, thiserror::Error)]
pub enum HouseError {
    #[error(transparent)]
    Options(#[from] ConfigError),
    #[error("libraries: {0}")]
    Library(String),
    #[error("house of seed {seed}: {why}")]
    Generate { seed: u64, why: String },
    #[error("walk in house {seed}: {source}")]
    Trajectory {
        seed: u64,
        #[source]
        source: TrajectoryError,
    },
}

/// The libraries of `options`, with the error callers report.
///
/// # Errors
/// [`HouseError::Library`] naming the file at fault.
pub fn load_library(options: &HouseOptions) -> Result<Library, HouseError> {
    options.library().map_err(|e| HouseError::Library(e.to_string()))
}

/// The embedded room and furniture libraries, with the error callers report.
///
/// # Errors
/// [`HouseError::Library`] when an embedded library does not load (a build defect).
pub fn embedded_library() -> Result<Library, HouseError> {
    Library::embedded().map_err(|e| HouseError::Library(e.to_string()))
}

/// Generates the house of `seed` with the default options and plans the walk with `params`.
///
/// # Errors
/// [`HouseError::Generate`] or [`HouseError::Trajectory`], naming the seed.
pub fn walked_house(library: &Library, seed: u64, params: &TrajectoryParams) -> Result<WalkedHouse, HouseError> {
    walked_house_with(library, &GeneratorConfig { seed, ..GeneratorConfig::default() }, params)
}

/// Generates the house `config` asks for and plans the walk with `params`.
///
/// # Errors
/// [`HouseError::Generate`] or [`HouseError::Trajectory`], naming the seed.
pub fn walked_house_with(
    library: &Library,
    config: &GeneratorConfig,
    params: &TrajectoryParams,
) -> Result<WalkedHouse, HouseError> {
    let seed = config.seed;
    let scene = generate(config, library).map_err(|e| HouseError::Generate { seed, why: e.to_string() })?;
    let walk = trajectory::plan(&scene, params).map_err(|source| HouseError::Trajectory { seed, source })?;
    Ok(WalkedHouse { scene, walk })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The options read back what they wrote, with the envelope as command-line text, and the
    /// defaults write nothing that a default run would not.
    #[test]
    fn options_round_trip_as_text() {
        let options = HouseOptions {
            envelope: Envelope { width_m: 10.0, depth_m: 12.5, height_m: 2.8 },
            min_room_m: 4.0,
            rooms: Some(PathBuf::from("my/rooms")),
            furniture: None,
        };
        let json = serde_json::to_string(&options).unwrap();
        assert_eq!(json, r#"{"envelope":"10x12.5x2.8","min_room_m":4.0,"rooms":"my/rooms"}"#);
        assert_eq!(serde_json::from_str::<HouseOptions>(&json).unwrap(), options);
        assert!(HouseOptions::default().is_default());
        assert!(!options.is_default());
        let bad = serde_json::from_str::<HouseOptions>(r#"{"envelope":"10x12"}"#).unwrap_err();
        assert!(bad.to_string().contains("WIDTHxDEPTHxHEIGHT"), "{bad}");
    }

    /// A library copied to a folder has the embedded library's digest (paths are relative to
    /// its root), and one changed byte changes it.
    #[test]
    fn library_digest_names_the_content_not_the_place() {
        let embedded = Library::embedded().unwrap();
        let dir = std::env::temp_dir().join(format!("scene-gen-digest-{}", std::process::id()));
        let rooms = dir.join("rooms");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&rooms).unwrap();
        for file in
            crate::library::list_files(LibrarySource::Embedded, &crate::library::EMBEDDED_ROOMS, "rooms").unwrap()
        {
            let target = dir.join(&file.path);
            std::fs::create_dir_all(target.parent().unwrap()).unwrap();
            std::fs::write(target, &file.bytes).unwrap();
        }
        let options = HouseOptions { rooms: Some(rooms.clone()), ..HouseOptions::default() };
        let copied = options.library().unwrap();
        assert_eq!(copied.rooms_id.digest, embedded.rooms_id.digest);
        assert_eq!(copied.rooms_id.folder.as_deref(), Some(rooms.display().to_string().as_str()));
        assert_eq!(embedded.rooms_id.folder, None);

        let first = std::fs::read_dir(&rooms).unwrap().filter_map(Result::ok).find(|e| e.path().is_file()).unwrap();
        let mut text = std::fs::read_to_string(first.path()).unwrap();
        text.push_str("\n# edited\n");
        std::fs::write(first.path(), text).unwrap();
        let edited = options.library().unwrap();
        assert_ne!(edited.rooms_id.digest, embedded.rooms_id.digest);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
