//! Room types: `rooms/<type>.toml`.
//!
//! ```toml
//! label = "Bedroom"            # shown on plan.png
//! weight = 3.0                 # relative chance of being drawn for a room
//! floor = ["wood_floor", "carpet"]   # floor surfaces to choose from (see materials::SURFACES)
//! walls = ["paint", "wallpaper"]     # wall surfaces to choose from
//!
//! # plan rules, all optional (see PlanRules)
//! min_per_plan = 0             # every plan has at least this many
//! max_per_plan = 4             # and at most this many (no limit when absent)
//! required_from_rooms = 3      # at least one in every plan of this many rooms or more
//! min_plan_rooms = 2           # never in plans with fewer rooms (a one-room plan is a studio)
//! min_area_m2 = 9.0            # only in rooms with at least this floor area (centre lines)
//! prefer_area = "smallest"     # required rooms take the smallest ("largest") free room
//! entrance = false             # no front door into this type (unless no other room can have one)
//!
//! [[furniture]]                # objects (and furnishings: wardrobe, counter, ...) it holds
//! class = "bed"
//! count = [1, 1]               # inclusive range, drawn per room
//! ```
//!
//! Unknown keys are refused so a typo never passes silently.

use serde::Deserialize;
use toml::Spanned;

use super::{LibraryError, LibraryFile};
use crate::materials::MaterialCatalog;
use crate::scene::Kind;

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
    /// How often this type appears in a plan.
    pub rules: PlanRules,
}

/// Plan rules of a room type: how many rooms of the type a floorplan has.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanRules {
    /// Every plan (of at least `min_plan_rooms` rooms) has at least this many.
    pub min_per_plan: u32,
    /// At most this many per plan; `None` for no limit.
    pub max_per_plan: Option<u32>,
    /// Plans with at least this many rooms have at least one of this type.
    pub required_from_rooms: Option<u32>,
    /// The type is never used in plans with fewer rooms.
    pub min_plan_rooms: u32,
    /// The type is only given to rooms with at least this footprint area (centre lines).
    pub min_area_m2: f32,
    /// Which free room a required room of this type takes.
    pub prefer_area: AreaPreference,
    /// Whether an exterior door may open into this type of room.
    pub entrance: bool,
}

/// Which room a required room type takes among those it may have.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AreaPreference {
    /// Any, drawn at random.
    #[default]
    Any,
    /// The smallest (a bathroom).
    Smallest,
    /// The largest (a living room).
    Largest,
}

impl Default for PlanRules {
    fn default() -> Self {
        PlanRules {
            min_per_plan: 0,
            max_per_plan: None,
            required_from_rooms: None,
            min_plan_rooms: 1,
            min_area_m2: 0.0,
            prefer_area: AreaPreference::Any,
            entrance: true,
        }
    }
}

/// "This room type holds between `min` and `max` objects of `class`."
#[derive(Clone, Debug, PartialEq)]
pub struct FurnitureRequest {
    /// An object class or a furnishing.
    pub class: Kind,
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
    min_per_plan: Option<Spanned<u32>>,
    max_per_plan: Option<Spanned<u32>>,
    required_from_rooms: Option<Spanned<u32>>,
    min_plan_rooms: Option<Spanned<u32>>,
    min_area_m2: Option<Spanned<f32>>,
    #[serde(default)]
    prefer_area: AreaPreference,
    entrance: Option<bool>,
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
    let rules = parse_rules(&raw, &at)?;
    let mut furniture = Vec::new();
    for entry in raw.furniture {
        let class = Kind::from_name(entry.class.get_ref()).ok_or_else(|| {
            let known: Vec<_> = Kind::all().map(Kind::name).collect();
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
        rules,
    })
}

/// Checks the plan rules of one file; each error points at the offending key.
fn parse_rules(raw: &RoomFile, at: &dyn Fn(usize, String) -> LibraryError) -> Result<PlanRules, LibraryError> {
    let get = |v: &Option<Spanned<u32>>| v.as_ref().map(|s| *s.get_ref());
    let span = |v: &Option<Spanned<u32>>| v.as_ref().map_or(0, |s| s.span().start);
    let mut rules = PlanRules {
        min_per_plan: get(&raw.min_per_plan).unwrap_or(0),
        max_per_plan: get(&raw.max_per_plan),
        required_from_rooms: get(&raw.required_from_rooms),
        min_plan_rooms: get(&raw.min_plan_rooms).unwrap_or(1),
        min_area_m2: 0.0,
        prefer_area: raw.prefer_area,
        entrance: raw.entrance.unwrap_or(true),
    };
    if let Some(area) = &raw.min_area_m2 {
        let a = *area.get_ref();
        if !(a.is_finite() && a >= 0.0) {
            return Err(at(area.span().start, format!("min_area_m2 = {a} must be a non-negative number")));
        }
        rules.min_area_m2 = a;
    }
    if let Some(max) = rules.max_per_plan {
        if max < rules.min_per_plan {
            return Err(at(
                span(&raw.max_per_plan),
                format!("max_per_plan = {max} is less than min_per_plan = {}", rules.min_per_plan),
            ));
        }
        if max == 0 && rules.required_from_rooms.is_some() {
            return Err(at(span(&raw.max_per_plan), "max_per_plan = 0 contradicts required_from_rooms".into()));
        }
    }
    if rules.min_plan_rooms == 0 {
        return Err(at(span(&raw.min_plan_rooms), "min_plan_rooms must be at least 1".into()));
    }
    if let Some(from) = rules.required_from_rooms {
        if from == 0 {
            return Err(at(span(&raw.required_from_rooms), "required_from_rooms must be at least 1".into()));
        }
        if from < rules.min_plan_rooms {
            return Err(at(
                span(&raw.required_from_rooms),
                format!(
                    "required_from_rooms = {from} is less than min_plan_rooms = {}: the type would be required where \
                     it is not allowed",
                    rules.min_plan_rooms
                ),
            ));
        }
    }
    Ok(rules)
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

    const HEAD: &str = "label = \"T\"\nfloor = [\"wood_floor\"]\nwalls = [\"paint\"]\n";

    #[test]
    fn plan_rules_parse() {
        let text = format!(
            "{HEAD}min_per_plan = 1\nmax_per_plan = 2\nrequired_from_rooms = 3\nmin_plan_rooms = 2\nmin_area_m2 = 12.5\n\
             prefer_area = \"largest\"\nentrance = false\n"
        );
        let rt = parse_room_type(&file(&text)).unwrap();
        assert_eq!(
            rt.rules,
            PlanRules {
                min_per_plan: 1,
                max_per_plan: Some(2),
                required_from_rooms: Some(3),
                min_plan_rooms: 2,
                min_area_m2: 12.5,
                prefer_area: AreaPreference::Largest,
                entrance: false,
            }
        );
        assert_eq!(parse_room_type(&file(HEAD)).unwrap().rules, PlanRules::default());
    }

    #[test]
    fn max_below_min_names_file_and_line() {
        let text = format!("{HEAD}min_per_plan = 2\nmax_per_plan = 1\n");
        let err = parse_room_type(&file(&text)).unwrap_err();
        assert_eq!(err.line, Some(5));
        assert!(err.to_string().starts_with("rooms/test.toml:5: max_per_plan = 1 is less than min_per_plan"), "{err}");
    }

    #[test]
    fn required_before_allowed_names_line() {
        let text = format!("{HEAD}min_plan_rooms = 3\nrequired_from_rooms = 2\n");
        let err = parse_room_type(&file(&text)).unwrap_err();
        assert_eq!(err.line, Some(5));
        assert!(err.to_string().contains("required_from_rooms = 2 is less than min_plan_rooms = 3"), "{err}");
    }

    #[test]
    fn bad_rule_values_name_line() {
        for (line, expect) in [
            ("min_area_m2 = -1.0", "min_area_m2 = -1 must be a non-negative number"),
            ("min_area_m2 = nan", "min_area_m2 = NaN must be a non-negative number"),
            ("required_from_rooms = 0", "required_from_rooms must be at least 1"),
            ("min_plan_rooms = 0", "min_plan_rooms must be at least 1"),
            ("max_per_room = 2", "unknown field `max_per_room`"),
            ("max_per_plan = -2", ""),
            ("prefer_area = \"middle\"", "unknown variant `middle`"),
        ] {
            let err = parse_room_type(&file(&format!("{HEAD}{line}\n"))).unwrap_err();
            assert_eq!(err.line, Some(4), "{line}: {err}");
            assert!(err.to_string().starts_with("rooms/test.toml:4: "), "{err}");
            assert!(err.to_string().contains(expect), "{line}: {err}");
        }
    }

    #[test]
    fn embedded_library_has_plan_rules() {
        let lib = crate::library::Library::embedded().unwrap();
        let bath = lib.rooms.iter().find(|r| r.name == "bathroom").expect("bathroom.toml");
        assert_eq!(bath.rules.required_from_rooms, Some(3));
        for name in ["bedroom", "bathroom", "living_room", "kitchen", "office"] {
            assert!(lib.rooms.iter().any(|r| r.name == name), "rooms/{name}.toml missing");
        }
    }

    #[test]
    fn broken_toml_names_line() {
        let err = parse_room_type(&file("label = \"T\"\nfloor = [\"wood_floor\"\n")).unwrap_err();
        assert!(err.line.is_some());
    }
}
