//! The data libraries the generator reads: room types (`rooms/*.toml`) and furniture classes
//! (`furniture/<class>/*.toml` with OBJ meshes).
//!
//! Both are embedded in the binary at compile time, so `scene-gen --seed 7` runs from any
//! folder, and either can be replaced by a folder at run time (`--rooms DIR`,
//! `--furniture DIR`). Parsers report errors with the file and line they come from.

pub mod furniture;
pub mod rooms;

use std::path::{Path, PathBuf};

use include_dir::{Dir, include_dir};
use scene_gen_core::rng::fnv1a64;

use crate::scene::LibraryId;

pub use furniture::FurnitureClass;
pub use rooms::RoomType;

pub(crate) static EMBEDDED_ROOMS: Dir<'static> = include_dir!("$CARGO_MANIFEST_DIR/../../rooms");
static EMBEDDED_FURNITURE: Dir<'static> = include_dir!("$CARGO_MANIFEST_DIR/../../furniture");

/// An error in a library file, located as precisely as the parser could.
#[derive(Debug, thiserror::Error)]
#[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct LibraryError {
    pub path: PathBuf,
    /// 1-based line, when known.
    pub line: Option<usize>,
    pub message: String,
}

impl LibraryError {
    pub fn new(path: impl Into<PathBuf>, line: Option<usize>, message: impl Into<String>) -> Self {
        LibraryError { path: path.into(), line, message: message.into() }
    }

    /// An error at byte `offset` of `text`.
    pub fn at_offset(path: impl Into<PathBuf>, text: &str, offset: usize, message: impl Into<String>) -> Self {
        LibraryError::new(path, Some(line_of_offset(text, offset)), message)
    }
}

/// 1-based line number of a byte offset.
#[must_use]
pub fn line_of_offset(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())].iter().filter(|&&b| b == b'\n').count() + 1
}

/// One file of a library, wherever it came from.
#[derive(Clone, Debug)]
pub struct LibraryFile {
    /// Path for messages: `rooms/bedroom.toml` when embedded, the real path otherwise.
    pub path: PathBuf,
    pub bytes: Vec<u8>,
}

impl LibraryFile {
    /// The file as UTF-8 text.
    pub fn text(&self) -> Result<&str, LibraryError> {
        std::str::from_utf8(&self.bytes).map_err(|e| LibraryError::new(&self.path, None, format!("not UTF-8: {e}")))
    }
}

/// Where a library comes from.
#[derive(Clone, Copy, Debug)]
pub enum LibrarySource<'a> {
    Embedded,
    Folder(&'a Path),
}

/// Every file under a library root, sorted by path so loading order never depends on the
/// file system.
pub fn list_files(
    source: LibrarySource<'_>,
    embedded: &'static Dir<'static>,
    label: &str,
) -> Result<Vec<LibraryFile>, LibraryError> {
    let mut files = Vec::new();
    match source {
        LibrarySource::Embedded => collect_embedded(embedded, label, &mut files),
        LibrarySource::Folder(root) => collect_folder(root, &mut files)?,
    }
    files.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(files)
}

fn collect_embedded(dir: &'static Dir<'static>, label: &str, out: &mut Vec<LibraryFile>) {
    for file in dir.files() {
        out.push(LibraryFile { path: Path::new(label).join(file.path()), bytes: file.contents().to_vec() });
    }
    for sub in dir.dirs() {
        collect_embedded(sub, label, out);
    }
}

fn collect_folder(dir: &Path, out: &mut Vec<LibraryFile>) -> Result<(), LibraryError> {
    let entries =
        std::fs::read_dir(dir).map_err(|e| LibraryError::new(dir, None, format!("cannot read folder: {e}")))?;
    for entry in entries {
        let entry = entry.map_err(|e| LibraryError::new(dir, None, format!("cannot read folder: {e}")))?;
        let path = entry.path();
        if path.is_dir() {
            collect_folder(&path, out)?;
        } else {
            let bytes =
                std::fs::read(&path).map_err(|e| LibraryError::new(&path, None, format!("cannot read: {e}")))?;
            out.push(LibraryFile { path, bytes });
        }
    }
    Ok(())
}

/// The identity of a library: the folder it came from and a digest of its files.
fn library_id(source: LibrarySource<'_>, label: &str, files: &[LibraryFile]) -> LibraryId {
    let root = match source {
        LibrarySource::Embedded => Path::new(label),
        LibrarySource::Folder(root) => root,
    };
    let mut bytes = Vec::new();
    for file in files {
        // Relative paths with '/' so the digest does not depend on where the folder is.
        let relative = file.path.strip_prefix(root).unwrap_or(&file.path);
        let name: Vec<String> = relative.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
        bytes.extend_from_slice(name.join("/").as_bytes());
        bytes.push(0);
        bytes.extend_from_slice(&(file.bytes.len() as u64).to_le_bytes());
        bytes.extend_from_slice(&file.bytes);
    }
    LibraryId {
        folder: match source {
            LibrarySource::Embedded => None,
            LibrarySource::Folder(root) => Some(root.display().to_string()),
        },
        digest: format!("fnv1a64:{:016x}", fnv1a64(&bytes)),
    }
}

/// Room types and furniture classes, validated against each other.
#[derive(Clone, Debug)]
pub struct Library {
    pub rooms: Vec<RoomType>,
    pub furniture: Vec<FurnitureClass>,
    /// Where the room types came from, recorded in every house's manifest.
    pub rooms_id: LibraryId,
    /// Where the furniture came from.
    pub furniture_id: LibraryId,
}

impl Library {
    /// The libraries compiled into the binary.
    pub fn embedded() -> Result<Library, LibraryError> {
        Library::load(LibrarySource::Embedded, LibrarySource::Embedded)
    }

    /// Loads and cross-checks both libraries.
    pub fn load(rooms: LibrarySource<'_>, furniture: LibrarySource<'_>) -> Result<Library, LibraryError> {
        let room_files = list_files(rooms, &EMBEDDED_ROOMS, "rooms")?;
        let furniture_files = list_files(furniture, &EMBEDDED_FURNITURE, "furniture")?;
        let rooms_id = library_id(rooms, "rooms", &room_files);
        let furniture_id = library_id(furniture, "furniture", &furniture_files);
        let rooms = rooms::parse_room_types(&room_files)?;
        let furniture = furniture::parse_furniture(&furniture_files)?;
        furniture::check_room_requests(&room_files, &rooms, &furniture)?;
        log::debug!(
            "libraries: {} room types from {} ({}), {} furniture classes from {} ({})",
            rooms.len(),
            rooms_id.folder.as_deref().unwrap_or("embedded"),
            rooms_id.digest,
            furniture.len(),
            furniture_id.folder.as_deref().unwrap_or("embedded"),
            furniture_id.digest
        );
        Ok(Library { rooms, furniture, rooms_id, furniture_id })
    }

    /// The furniture class entry for `class`, if the library has one.
    #[must_use]
    pub fn furniture_class(&self, class: impl Into<crate::scene::Kind>) -> Option<&FurnitureClass> {
        let class = class.into();
        self.furniture.iter().find(|f| f.class == class)
    }
}
