//! Room types: `rooms/<type>.toml`.
//!
//! STUB: the floorplan work replaces this with the full schema (furniture counts, plan rules,
//! surfaces, lights).

use super::{LibraryError, LibraryFile};

/// One room type.
#[derive(Clone, Debug, PartialEq)]
pub struct RoomType {
    /// The file stem, e.g. `bedroom`.
    pub name: String,
}

/// Parses every `*.toml` file of the rooms library.
pub fn parse_room_types(files: &[LibraryFile]) -> Result<Vec<RoomType>, LibraryError> {
    let mut types = Vec::new();
    for file in files.iter().filter(|f| f.path.extension().is_some_and(|e| e == "toml")) {
        let text = file.text()?;
        let _: toml::Table = toml::from_str(text).map_err(|e| {
            LibraryError::at_offset(&file.path, text, e.span().map_or(0, |s| s.start), e.message().to_string())
        })?;
        let name = file.path.file_stem().unwrap_or_default().to_string_lossy().into_owned();
        types.push(RoomType { name });
    }
    if types.is_empty() {
        return Err(LibraryError::new("rooms", None, "the room library has no *.toml room types"));
    }
    Ok(types)
}
