//! Room types: `rooms/<type>.toml`.
//!
//! ```toml
//! label = "Bedroom"            # shown on plan.png
//! weight = 3.0                 # relative chance of being drawn for a room
//! floor = ["wood_floor", "carpet"]   # floor surfaces to choose from (see materials::SURFACES)
//! walls = ["paint", "wallpaper"]     # wall surfaces to choose from
//!
//! [[furniture]]                # objects this room type holds
//! class = "bed"
//! count = [1, 1]               # inclusive range, drawn per room
//! ```
//!
//! The floorplan work extends this with plan rules (how many per plan, which types are
//! required); unknown keys are refused so a typo never passes silently.

use serde::Deserialize;
use toml::Spanned;

use super::{LibraryError, LibraryFile};
use crate::materials::MaterialCatalog;
use crate::scene::ObjectClass;

/// One room type.
#[derive(Clone, Debug, PartialEq)]
pub struct RoomType {
    /// The file stem, e.g. `bedroom`.
    pub name: String,
    /// Human name for plans.
    pub label: String,
    /// Relative chance of being drawn.
    pub weight: f32,
    pub floor: Vec<String>,
    pub walls: Vec<String>,
    pub furniture: Vec<FurnitureRequest>,
}

/// "This room type holds between `min` and `max` objects of `class`."
#[derive(Clone, Debug, PartialEq)]
pub struct FurnitureRequest {
    pub class: ObjectClass,
    pub min: u32,
    pub max: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RoomFile {
    label: String,
    #[serde(default = "one")]
    weight: Spanned<f32>,
    floor: Spanned<Vec<String>>,
    walls: Spanned<Vec<String>>,
    #[serde(default)]
    furniture: Vec<FurnitureEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FurnitureEntry {
    class: Spanned<String>,
    count: Spanned<[u32; 2]>,
}

fn one() -> Spanned<f32> {
    Spanned::new(0..0, 1.0)
}

/// Parses every `*.toml` file of the rooms library.
pub fn parse_room_types(files: &[LibraryFile]) -> Result<Vec<RoomType>, LibraryError> {
    let mut types = Vec::new();
    for file in files.iter().filter(|f| f.path.extension().is_some_and(|e| e == "toml")) {
        types.push(parse_room_type(file)?);
    }
    if types.is_empty() {
        return Err(LibraryError::new("rooms", None, "the room library has no *.toml room types"));
    }
    Ok(types)
}

fn parse_room_type(file: &LibraryFile) -> Result<RoomType, LibraryError> {
    let text = file.text()?;
    let at = |offset: usize, message: String| LibraryError::at_offset(&file.path, text, offset, message);
    let raw: RoomFile =
        toml::from_str(text).map_err(|e| at(e.span().map_or(0, |s| s.start), e.message().trim().to_string()))?;
    if !(raw.weight.get_ref().is_finite() && *raw.weight.get_ref() >= 0.0) {
        return Err(at(raw.weight.span().start, "weight must be a non-negative number".into()));
    }
    for list in [&raw.floor, &raw.walls] {
        if list.get_ref().is_empty() {
            return Err(at(list.span().start, "needs at least one surface".into()));
        }
        if let Some(bad) = list.get_ref().iter().find(|s| !MaterialCatalog::is_surface(s)) {
            return Err(at(list.span().start, format!("unknown surface '{bad}'")));
        }
    }
    let mut furniture = Vec::new();
    for entry in raw.furniture {
        let class = ObjectClass::from_name(entry.class.get_ref()).ok_or_else(|| {
            let known: Vec<_> = ObjectClass::ALL.iter().map(|c| c.name()).collect();
            at(
                entry.class.span().start,
                format!("unknown class '{}' (known: {})", entry.class.get_ref(), known.join(", ")),
            )
        })?;
        let [min, max] = *entry.count.get_ref();
        if min > max || max > 20 {
            return Err(at(
                entry.count.span().start,
                format!("count [{min}, {max}] must be [min, max] with min <= max <= 20"),
            ));
        }
        furniture.push(FurnitureRequest { class, min, max });
    }
    Ok(RoomType {
        name: file.path.file_stem().unwrap_or_default().to_string_lossy().into_owned(),
        label: raw.label,
        weight: raw.weight.into_inner(),
        floor: raw.floor.into_inner(),
        walls: raw.walls.into_inner(),
        furniture,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(text: &str) -> LibraryFile {
        LibraryFile { path: "rooms/test.toml".into(), bytes: text.as_bytes().to_vec() }
    }

    #[test]
    fn unknown_class_names_file_and_line() {
        let text = "label = \"T\"\nfloor = [\"wood_floor\"]\nwalls = [\"paint\"]\n\n[[furniture]]\nclass = \"piano\"\ncount = [1, 1]\n";
        let err = parse_room_type(&file(text)).unwrap_err();
        assert_eq!(err.line, Some(6));
        assert!(err.to_string().starts_with("rooms/test.toml:6: unknown class 'piano'"), "{err}");
    }

    #[test]
    fn broken_toml_names_line() {
        let err = parse_room_type(&file("label = \"T\"\nfloor = [\"wood_floor\"\n")).unwrap_err();
        assert!(err.line.is_some());
    }
}
