//! Furniture classes: `furniture/<class>/<class>.toml`, with the OBJ meshes beside it or the
//! generators it names.
//!
//! ```toml
//! rooms = ["living_room", "office"]   # room types this class may be requested by
//! place = "wall"                      # wall | corner | center: where it stands on the floor
//! beside = ["table"]                  # optional: first try next to one of these classes, facing it
//! flank = ["bed"]                     # optional: first try beside one of these along its wall,
//!                                     #   facing the same way (a nightstand by a bed)
//! face = ["sofa"]                     # optional: first try against the wall one of these faces,
//!                                     #   across the room, turned towards it (a TV before a sofa)
//! on = ["table", "bed"]               # optional: first try standing on one of these
//! width_m = [1.5, 2.3]                # drawn size (x of the asset), inclusive range
//! depth_m = [0.8, 1.0]                # drawn size (y of the asset)
//! height_m = [0.7, 0.9]               # drawn size (z of the asset)
//! uniform_scale = false               # true: scale = drawn height / native height; no width/depth
//! up = "z"                            # "z" (scene-gen meshes) or "y" (Y up, front +Z)
//! default_surface = "plastic"         # surface for OBJ materials that are not surfaces
//! surfaces = { "Material.001" = "wood" }   # optional: OBJ material name -> surface
//!
//! [[variant]]
//! generator = "sofa"                  # a shape of its own per object (crate::procedural), or
//! # obj = "sofa_2seat"                # one mesh for all: furniture/sofa/sofa_2seat.obj (+ .mtl)
//! weight = 2.0                        # optional relative chance, default 1
//! rooms = ["living_room"]             # optional: only in these of the class's room types
//! width_m = [1.4, 1.8]                # optional per-variant overrides of the size ranges,
//! place = "corner"                    #   of place, beside, face and on
//! ```
//!
//! Placement tries, in order: standing `on` a support of a listed class in the same room,
//! then flanking (`flank`), facing (`face`) and then `beside` an object of a listed class,
//! then the `place` rule; an object that fits nowhere is skipped. `flank` and `face` take
//! anchors that stand against a wall.
//!
//! Class folders are the ten object classes or the furnishings (`wardrobe`, `bookshelf`,
//! `nightstand`, `counter`, `fridge`, `stove`, `toilet`: furniture that is not a detection target).
//! Furnishings stand on the floor; `on` names object classes only.
//!
//! A generator variant builds every object's shape at the size drawn for it; an OBJ variant
//! scales its one mesh to that size. Both may be mixed in one class.
//!
//! Surfaces: faces are drawn with the surface their OBJ material is named after (`usemtl
//! wood`, the names of [`crate::materials::SURFACES`]). A material name listed in `surfaces`
//! maps to that surface; any other name, and faces with no material (no `.mtl`, or a name the
//! `.mtl` does not define), fall back to `default_surface` (default `plastic`). User meshes
//! from any tool therefore load, and a `surfaces` table gives them proper materials.
//!
//! Every `[[furniture]]` request of a room type must name a class whose `rooms` list holds
//! that room type ([`check_room_requests`]), so a room never asks for what cannot go there.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;
use toml::Spanned;

use super::{LibraryError, LibraryFile, RoomType};
use crate::assets::{self, AssetMesh, UpAxis};
use crate::materials::MaterialCatalog;
use crate::procedural::Generator;
use crate::scene::Kind;

/// Surface for OBJ materials that name no surface, unless the class TOML says otherwise.
pub const DEFAULT_SURFACE: &str = "plastic";

/// Where an object stands on the floor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Place {
    /// Back against a wall, facing into the room.
    Wall,
    /// Back against a wall, side against the next wall.
    Corner,
    /// Free-standing, away from the walls.
    Center,
}

/// The placement rule of a variant: the preferences, then the floor fallback.
#[derive(Clone, Debug, PartialEq)]
pub struct Rule {
    pub on: Vec<Kind>,
    /// Beside one of these along the same wall, facing the same way (a nightstand by a bed).
    pub flank: Vec<Kind>,
    /// Against the wall one of these faces, turned towards it (a TV before a sofa).
    pub face: Vec<Kind>,
    pub beside: Vec<Kind>,
    pub place: Place,
}

/// Drawn-size ranges in metres, `[min, max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SizeRange {
    /// `None` with uniform scaling.
    pub width_m: Option<[f32; 2]>,
    pub depth_m: Option<[f32; 2]>,
    pub height_m: [f32; 2],
}

/// One mesh of a class.
#[derive(Clone, Debug, PartialEq)]
pub struct FurnitureVariant {
    /// The OBJ stem; the asset name is `<class>/<name>`.
    pub name: String,
    pub weight: f32,
    /// The room types this variant is drawn in; `None`: every room type of its class.
    pub rooms: Option<Vec<String>>,
    pub size: SizeRange,
    pub rule: Rule,
    pub mesh: AssetMesh,
    /// [`AssetMesh::support_top`] of `mesh`, computed once: where objects `on` this one stand.
    pub support_top: Option<(f32, glam::Vec2, glam::Vec2)>,
    /// The family that builds each object's own shape; `None` for an OBJ mesh shared by every
    /// object of the variant. With a generator, `mesh` is the family's prototype: placement
    /// sizes candidates by it, then builds the object's shape at the drawn size.
    pub generator: Option<&'static Generator>,
    /// Whether the OBJ carried normals and UVs (else they were computed).
    pub had_normals: bool,
    pub had_uvs: bool,
}

/// One furniture class and its variants.
#[derive(Clone, Debug, PartialEq)]
pub struct FurnitureClass {
    /// An object class (a detection target) or a furnishing.
    pub class: Kind,
    /// Room type names the class may be requested by.
    pub rooms: Vec<String>,
    pub uniform_scale: bool,
    pub variants: Vec<FurnitureVariant>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ClassFile {
    rooms: Spanned<Vec<String>>,
    place: Option<Spanned<Place>>,
    #[serde(default)]
    beside: Option<Spanned<Vec<String>>>,
    #[serde(default)]
    flank: Option<Spanned<Vec<String>>>,
    #[serde(default)]
    face: Option<Spanned<Vec<String>>>,
    #[serde(default)]
    on: Option<Spanned<Vec<String>>>,
    width_m: Option<Spanned<[f32; 2]>>,
    depth_m: Option<Spanned<[f32; 2]>>,
    height_m: Option<Spanned<[f32; 2]>>,
    #[serde(default)]
    uniform_scale: bool,
    up: Option<Spanned<String>>,
    default_surface: Option<Spanned<String>>,
    #[serde(default)]
    surfaces: BTreeMap<String, Spanned<String>>,
    #[serde(default)]
    variant: Vec<Spanned<VariantEntry>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct VariantEntry {
    obj: Option<Spanned<String>>,
    generator: Option<Spanned<String>>,
    weight: Option<Spanned<f32>>,
    width_m: Option<Spanned<[f32; 2]>>,
    depth_m: Option<Spanned<[f32; 2]>>,
    height_m: Option<Spanned<[f32; 2]>>,
    place: Option<Spanned<Place>>,
    rooms: Option<Spanned<Vec<String>>>,
    beside: Option<Spanned<Vec<String>>>,
    face: Option<Spanned<Vec<String>>>,
    on: Option<Spanned<Vec<String>>>,
}

/// Parses the furniture library: every `<class>/<class>.toml` with its OBJ files.
pub fn parse_furniture(files: &[LibraryFile]) -> Result<Vec<FurnitureClass>, LibraryError> {
    let mut classes: Vec<FurnitureClass> = Vec::new();
    for file in files.iter().filter(|f| f.path.extension().is_some_and(|e| e == "toml")) {
        let parsed = parse_class(file, files)?;
        if classes.iter().any(|c| c.class == parsed.class) {
            return Err(LibraryError::new(&file.path, None, format!("class '{}' is defined twice", parsed.class)));
        }
        classes.push(parsed);
    }
    if classes.is_empty() {
        return Err(LibraryError::new("furniture", None, "the furniture library has no <class>/<class>.toml files"));
    }
    classes.sort_by_key(|c| c.class);
    Ok(classes)
}

fn parse_class(file: &LibraryFile, all: &[LibraryFile]) -> Result<FurnitureClass, LibraryError> {
    let text = file.text()?;
    let at = |offset: usize, message: String| LibraryError::at_offset(&file.path, text, offset, message);
    let folder = file.path.parent().and_then(Path::file_name).map(|s| s.to_string_lossy().into_owned());
    let stem = file.path.file_stem().unwrap_or_default().to_string_lossy().into_owned();
    let known = || Kind::all().map(Kind::name).collect::<Vec<_>>().join(", ");
    let class = match folder.as_deref().and_then(Kind::from_name) {
        Some(c) => c,
        None => {
            let name = folder.unwrap_or_default();
            return Err(LibraryError::new(
                &file.path,
                None,
                format!("folder '{name}' is not a furniture class (known: {})", known()),
            ));
        }
    };
    if stem != class.name() {
        return Err(LibraryError::new(&file.path, None, format!("expected the class file to be named {class}.toml")));
    }
    let raw: ClassFile =
        toml::from_str(text).map_err(|e| at(e.span().map_or(0, |s| s.start), e.message().trim().to_string()))?;

    let classes_of = |list: &Spanned<Vec<String>>| -> Result<Vec<Kind>, LibraryError> {
        list.get_ref()
            .iter()
            .map(|n| {
                Kind::from_name(n)
                    .ok_or_else(|| at(list.span().start, format!("unknown class '{n}' (known: {})", known())))
            })
            .collect()
    };
    let range = |r: &Option<Spanned<[f32; 2]>>, what: &str| -> Result<Option<[f32; 2]>, LibraryError> {
        let Some(r) = r else { return Ok(None) };
        let [lo, hi] = *r.get_ref();
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi && hi <= 20.0) {
            return Err(at(
                r.span().start,
                format!("{what} [{lo}, {hi}] must be [min, max] with 0 < min <= max <= 20"),
            ));
        }
        Ok(Some([lo, hi]))
    };
    let surface = |s: &Spanned<String>| -> Result<String, LibraryError> {
        if MaterialCatalog::is_surface(s.get_ref()) {
            Ok(s.get_ref().clone())
        } else {
            Err(at(s.span().start, format!("unknown surface '{}'", s.get_ref())))
        }
    };

    let up = match raw.up.as_ref().map(|u| (u.get_ref().as_str(), u.span().start)) {
        None | Some(("z" | "Z", _)) => UpAxis::Z,
        Some(("y" | "Y", _)) => UpAxis::Y,
        Some((other, offset)) => return Err(at(offset, format!("up = '{other}': expected \"z\" or \"y\""))),
    };
    let default_surface = match &raw.default_surface {
        Some(s) => surface(s)?,
        None => DEFAULT_SURFACE.to_string(),
    };
    let mut surface_map = BTreeMap::new();
    for (name, s) in &raw.surfaces {
        surface_map.insert(name.clone(), surface(s)?);
    }
    let class_on = raw.on.as_ref().map(classes_of).transpose()?.unwrap_or_default();
    let class_beside = raw.beside.as_ref().map(classes_of).transpose()?.unwrap_or_default();
    let class_flank = raw.flank.as_ref().map(classes_of).transpose()?.unwrap_or_default();
    let class_face = raw.face.as_ref().map(classes_of).transpose()?.unwrap_or_default();
    let class_size =
        [range(&raw.width_m, "width_m")?, range(&raw.depth_m, "depth_m")?, range(&raw.height_m, "height_m")?];
    if raw.variant.is_empty() {
        return Err(at(0, "needs at least one [[variant]]".into()));
    }

    let mut variants = Vec::new();
    for entry in &raw.variant {
        let offset = entry.span().start;
        let v = entry.get_ref();
        let (name, source) = match (&v.obj, &v.generator) {
            (Some(obj), None) => (obj.get_ref().clone(), Source::Obj(obj.span().start)),
            (None, Some(g)) => {
                let Some(generator) = Generator::by_name(g.get_ref()) else {
                    let known: Vec<&str> =
                        crate::procedural::GENERATORS.iter().filter(|x| x.class == class).map(|x| x.name).collect();
                    return Err(at(
                        g.span().start,
                        format!("unknown generator '{}' (known for {class}: {})", g.get_ref(), known.join(", ")),
                    ));
                };
                if generator.class != class {
                    return Err(at(
                        g.span().start,
                        format!("generator '{}' builds {}, not {class}", generator.name, generator.class),
                    ));
                }
                (generator.name.to_string(), Source::Generator(generator))
            }
            _ => {
                return Err(at(
                    offset,
                    "a variant names exactly one of obj = \"<stem>\" or generator = \"<name>\"".into(),
                ));
            }
        };
        let weight = v.weight.as_ref().map_or(Ok(1.0), |w| {
            let x = *w.get_ref();
            if x.is_finite() && x >= 0.0 { Ok(x) } else { Err(at(w.span().start, "weight must be >= 0".into())) }
        })?;
        let pick = |own: Option<[f32; 2]>, class: Option<[f32; 2]>| own.or(class);
        let width_m = pick(range(&v.width_m, "width_m")?, class_size[0]);
        let depth_m = pick(range(&v.depth_m, "depth_m")?, class_size[1]);
        let Some(height_m) = pick(range(&v.height_m, "height_m")?, class_size[2]) else {
            return Err(at(offset, format!("variant '{name}' has no height_m (set it on the class or the variant)")));
        };
        match (raw.uniform_scale, width_m.is_some(), depth_m.is_some()) {
            (true, false, false) | (false, true, true) => {}
            (true, _, _) => {
                return Err(at(
                    offset,
                    format!("variant '{name}': uniform_scale takes only height_m, not width_m/depth_m"),
                ));
            }
            (false, _, _) => return Err(at(offset, format!("variant '{name}' needs width_m and depth_m"))),
        }
        let place = v.place.as_ref().or(raw.place.as_ref()).map(|p| *p.get_ref());
        let Some(place) = place else {
            return Err(at(offset, format!("variant '{name}' has no place (wall, corner or center)")));
        };
        let rule = Rule {
            on: v.on.as_ref().map(classes_of).transpose()?.unwrap_or_else(|| class_on.clone()),
            flank: class_flank.clone(),
            face: v.face.as_ref().map(classes_of).transpose()?.unwrap_or_else(|| class_face.clone()),
            beside: v.beside.as_ref().map(classes_of).transpose()?.unwrap_or_else(|| class_beside.clone()),
            place,
        };
        // Furnishings stand on the floor, and nothing stands on them: an object's `on` always
        // names an object, so the manifest's `on` ids stay object ids.
        let on_furnishing = rule.on.iter().any(|k| matches!(k, Kind::Furnishing(_)));
        if on_furnishing || (matches!(class, Kind::Furnishing(_)) && !rule.on.is_empty()) {
            return Err(at(
                offset,
                format!("variant '{name}': `on` may name object classes only, and furnishings stand on the floor"),
            ));
        }
        let size = SizeRange { width_m, depth_m, height_m };
        // The shape, whether it came with normals and UVs, and its generator if any.
        let (mesh, had_normals, had_uvs, generator) = match source {
            Source::Obj(span) => {
                let obj_path = file.path.with_file_name(format!("{name}.obj"));
                let Some(obj) = all.iter().find(|f| f.path == obj_path) else {
                    return Err(at(span, format!("no mesh {} for variant '{name}'", obj_path.display())));
                };
                let siblings: Vec<LibraryFile> =
                    all.iter().filter(|f| f.path.parent() == obj.path.parent()).cloned().collect();
                let (mesh, info) = assets::load_obj(obj, &siblings, up, |material| match material {
                    Some(m) if surface_map.contains_key(m) => surface_map[m].clone(),
                    Some(m) if MaterialCatalog::is_surface(m) => m.to_string(),
                    _ => default_surface.clone(),
                })?;
                (mesh, info.had_normals, info.had_uvs, None)
            }
            Source::Generator(generator) => {
                let mid = |r: [f32; 2]| (r[0] + r[1]) * 0.5;
                let height = mid(height_m);
                let nominal = glam::Vec3::new(width_m.map_or(height, mid), depth_m.map_or(height, mid), height);
                (generator.prototype(nominal, raw.uniform_scale), true, true, Some(generator))
            }
        };
        let rooms = match &v.rooms {
            Some(list) => {
                if let Some(r) = list.get_ref().iter().find(|r| !raw.rooms.get_ref().contains(r)) {
                    return Err(at(
                        list.span().start,
                        format!("variant '{name}': room type '{r}' is not among the class's rooms"),
                    ));
                }
                Some(list.get_ref().clone())
            }
            None => None,
        };
        let variant = FurnitureVariant {
            name,
            weight,
            rooms,
            size,
            rule,
            support_top: mesh.support_top(),
            mesh,
            generator,
            had_normals,
            had_uvs,
        };
        variants.push(variant);
    }
    if let Some(room) = raw.rooms.get_ref().iter().find(|r| variants.iter().all(|v| v.weight_in(r) <= 0.0)) {
        return Err(at(0, format!("no variant with a weight above 0 is drawn in '{room}'")));
    }
    Ok(FurnitureClass { class, rooms: raw.rooms.into_inner(), uniform_scale: raw.uniform_scale, variants })
}

/// Where a variant's shape comes from while its entry is parsed.
enum Source {
    /// An OBJ file; the offset of the `obj` value for errors.
    Obj(usize),
    Generator(&'static Generator),
}

#[derive(Deserialize)]
struct RoomRequests {
    #[serde(default)]
    furniture: Vec<RoomRequest>,
}

#[derive(Deserialize)]
struct RoomRequest {
    class: Spanned<String>,
}

/// Checks that every `[[furniture]]` request of every room type names a class the furniture
/// library has (furnishings may be absent: they are then not placed) and whose `rooms` list
/// includes that room type. Errors name the room file and the line of the request.
pub fn check_room_requests(
    room_files: &[LibraryFile],
    room_types: &[RoomType],
    furniture: &[FurnitureClass],
) -> Result<(), LibraryError> {
    for file in room_files.iter().filter(|f| f.path.extension().is_some_and(|e| e == "toml")) {
        let stem = file.path.file_stem().unwrap_or_default().to_string_lossy().into_owned();
        if !room_types.iter().any(|r| r.name == stem) {
            continue;
        }
        let text = file.text()?;
        // The room parser has already accepted this file; this pass only recovers spans.
        let Ok(raw) = toml::from_str::<RoomRequests>(text) else { continue };
        for request in raw.furniture {
            let name = request.class.get_ref();
            let at = |message: String| LibraryError::at_offset(&file.path, text, request.class.span().start, message);
            let Some(class) = Kind::from_name(name) else { continue };
            let Some(entry) = furniture.iter().find(|f| f.class == class) else {
                // Furnishings are optional: a library without them furnishes target objects only.
                if matches!(class, Kind::Furnishing(_)) {
                    continue;
                }
                return Err(at(format!("class '{name}' is not in the furniture library")));
            };
            if !entry.rooms.contains(&stem) {
                let rooms = if entry.rooms.is_empty() { "none".to_string() } else { entry.rooms.join(", ") };
                return Err(at(format!(
                    "class '{name}' does not go in room type '{stem}': add it to `rooms` in {name}/{name}.toml \
                     of the furniture library (now: {rooms})"
                )));
            }
        }
    }
    Ok(())
}

impl FurnitureVariant {
    /// The variant's weight in a room of type `room_type`: 0 where it is not drawn.
    #[must_use]
    pub fn weight_in(&self, room_type: &str) -> f32 {
        if self.rooms.as_ref().is_none_or(|rooms| rooms.iter().any(|r| r == room_type)) { self.weight } else { 0.0 }
    }
}

/// Weighted choice of an index; `weights` must hold a positive entry.
pub(crate) fn weighted_index(rng: &mut impl rand::Rng, weights: impl Iterator<Item = f32> + Clone) -> usize {
    let total: f32 = weights.clone().sum();
    let mut x = rng.random::<f32>() * total;
    let mut last = 0;
    for (i, w) in weights.enumerate() {
        if w > 0.0 {
            last = i;
            if x < w {
                return i;
            }
            x -= w;
        }
    }
    last
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::ObjectClass;

    fn lib(files: &[(&str, &str)]) -> Vec<LibraryFile> {
        files.iter().map(|(p, t)| LibraryFile { path: (*p).into(), bytes: t.as_bytes().to_vec() }).collect()
    }

    const BOX_OBJ: &str =
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nvt 0 0\nf 1//1 2//1 3//1\nf 1//1 3//1 5//1\n";
    const GOOD: &str = "rooms = [\"bedroom\"]\nplace = \"wall\"\nwidth_m = [1, 2]\ndepth_m = [1, 2]\nheight_m = [1, 2]\n\n[[variant]]\nobj = \"a\"\n";

    #[test]
    fn good_class_loads() {
        let classes = parse_furniture(&lib(&[("f/bed/bed.toml", GOOD), ("f/bed/a.obj", BOX_OBJ)])).unwrap();
        assert_eq!(classes.len(), 1);
        assert_eq!(classes[0].class, Kind::Object(ObjectClass::Bed));
        assert_eq!(classes[0].variants[0].rule.place, Place::Wall);
        assert_eq!(classes[0].variants[0].mesh.parts[0].surface, DEFAULT_SURFACE);
    }

    #[test]
    fn unknown_class_folder_is_refused() {
        let err = parse_furniture(&lib(&[("f/piano/piano.toml", GOOD), ("f/piano/a.obj", BOX_OBJ)])).unwrap_err();
        assert!(err.to_string().contains("folder 'piano' is not a furniture class"), "{err}");
    }

    #[test]
    fn unknown_class_in_rule_names_line() {
        let text = GOOD.replace("place = \"wall\"", "place = \"wall\"\non = [\"piano\"]");
        let err = parse_furniture(&lib(&[("f/bed/bed.toml", &text), ("f/bed/a.obj", BOX_OBJ)])).unwrap_err();
        assert_eq!(err.line, Some(3), "{err}");
        assert!(err.to_string().contains("unknown class 'piano'"), "{err}");
    }

    #[test]
    fn broken_toml_and_unknown_keys_name_the_line() {
        let broken = GOOD.replace("depth_m = [1, 2]", "depth_m = [1, 2");
        let err = parse_furniture(&lib(&[("f/bed/bed.toml", &broken), ("f/bed/a.obj", BOX_OBJ)])).unwrap_err();
        assert!(err.line.is_some(), "{err}");
        assert!(err.to_string().starts_with("f/bed/bed.toml:"), "{err}");
        let typo = GOOD.replace("height_m", "hieght_m");
        let err = parse_furniture(&lib(&[("f/bed/bed.toml", &typo), ("f/bed/a.obj", BOX_OBJ)])).unwrap_err();
        assert_eq!(err.line, Some(5), "{err}");
    }

    #[test]
    fn missing_mesh_and_bad_ranges_name_the_line() {
        let text = GOOD.replace("obj = \"a\"", "obj = \"nope\"");
        let err = parse_furniture(&lib(&[("f/bed/bed.toml", &text), ("f/bed/a.obj", BOX_OBJ)])).unwrap_err();
        assert_eq!(err.line, Some(8), "{err}");
        let text = GOOD.replace("width_m = [1, 2]", "width_m = [2, 1]");
        let err = parse_furniture(&lib(&[("f/bed/bed.toml", &text), ("f/bed/a.obj", BOX_OBJ)])).unwrap_err();
        assert_eq!(err.line, Some(3), "{err}");
    }

    #[test]
    fn variants_limited_to_room_types_weigh_nothing_elsewhere() {
        let two = GOOD.replace("rooms = [\"bedroom\"]", "rooms = [\"bedroom\", \"office\"]");
        let text = format!("{two}rooms = [\"office\"]\n\n[[variant]]\nobj = \"a\"\nweight = 3.0\n");
        let classes = parse_furniture(&lib(&[("f/bed/bed.toml", &text), ("f/bed/a.obj", BOX_OBJ)])).unwrap();
        let [only_office, anywhere] = [&classes[0].variants[0], &classes[0].variants[1]];
        assert_eq!((only_office.weight_in("office"), only_office.weight_in("bedroom")), (1.0, 0.0));
        assert_eq!((anywhere.weight_in("office"), anywhere.weight_in("bedroom")), (3.0, 3.0));
        let stray = GOOD.replace("obj = \"a\"", "obj = \"a\"\nrooms = [\"kitchen\"]");
        let err = parse_furniture(&lib(&[("f/bed/bed.toml", &stray), ("f/bed/a.obj", BOX_OBJ)])).unwrap_err();
        assert!(err.to_string().contains("room type 'kitchen' is not among the class's rooms"), "{err}");
        assert_eq!(err.line, Some(9), "{err}");
        let nowhere = format!("{two}rooms = [\"office\"]\n");
        let nowhere = nowhere.replacen("obj = \"a\"\n", "obj = \"a\"\nweight = 0.0\n", 1);
        let err = parse_furniture(&lib(&[("f/bed/bed.toml", &nowhere), ("f/bed/a.obj", BOX_OBJ)])).unwrap_err();
        assert!(err.to_string().contains("no variant with a weight above 0 is drawn in 'bedroom'"), "{err}");
    }

    #[test]
    fn generator_variants_load_and_bad_ones_name_the_line() {
        let text = GOOD.replace("obj = \"a\"", "generator = \"bed\"");
        let classes = parse_furniture(&lib(&[("f/bed/bed.toml", &text)])).unwrap();
        let v = &classes[0].variants[0];
        assert_eq!(v.generator.map(|g| g.name), Some("bed"));
        assert!(v.support_top.is_some() && v.mesh.triangle_count() > 12);
        let cases = [
            ("generator = \"piano\"", "unknown generator 'piano' (known for bed: bed)"),
            ("generator = \"sofa\"", "generator 'sofa' builds sofa, not bed"),
            ("obj = \"a\"\ngenerator = \"bed\"", "exactly one of obj"),
        ];
        for (variant, message) in cases {
            let text = GOOD.replace("obj = \"a\"", variant);
            let err = parse_furniture(&lib(&[("f/bed/bed.toml", &text), ("f/bed/a.obj", BOX_OBJ)])).unwrap_err();
            assert!(err.to_string().contains(message), "{err}");
            assert!(err.line.is_some_and(|l| l >= 7), "{err}");
        }
    }

    #[test]
    fn user_meshes_y_up_with_foreign_material_names() {
        let toml = "rooms = [\"bedroom\"]\nplace = \"center\"\nuniform_scale = true\nheight_m = [1, 1]\n\
                    up = \"y\"\ndefault_surface = \"metal\"\nsurfaces = { \"Oak.001\" = \"wood\" }\n\n[[variant]]\nobj = \"a\"\n";
        let obj = "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 2 0\nv 0 2 1\nusemtl Oak.001\nf 1 2 3\nusemtl Chrome\nf 1 3 4\n";
        let mtl = "newmtl Oak.001\nKd 1 1 1\nnewmtl Chrome\nKd 1 1 1\n";
        let files = lib(&[("f/toy/toy.toml", toml), ("f/toy/a.obj", obj), ("f/toy/a.mtl", mtl)]);
        let classes = parse_furniture(&files).unwrap();
        let v = &classes[0].variants[0];
        let surfaces: Vec<_> = v.mesh.parts.iter().map(|p| p.surface.as_str()).collect();
        assert_eq!(surfaces, ["wood", "metal"]);
        // Y up: the 2 m extent along OBJ y becomes the height.
        assert!((v.mesh.size().z - 2.0).abs() < 1e-6, "{:?}", v.mesh.size());
        let bad = toml.replace("\"wood\"", "\"oak\"");
        let err = parse_furniture(&lib(&[("f/toy/toy.toml", &bad), ("f/toy/a.obj", obj)])).unwrap_err();
        assert_eq!(err.line, Some(7), "{err}");
    }

    #[test]
    fn room_requests_must_match_class_rooms() {
        let classes = parse_furniture(&lib(&[("f/bed/bed.toml", GOOD), ("f/bed/a.obj", BOX_OBJ)])).unwrap();
        let room = "label = \"K\"\nfloor = [\"tile_floor\"]\nwalls = [\"paint\"]\n\n[[furniture]]\nclass = \"bed\"\ncount = [1, 1]\n";
        let files = lib(&[("rooms/kitchen.toml", room)]);
        let types = crate::library::rooms::parse_room_types(&files).unwrap();
        let err = check_room_requests(&files, &types, &classes).unwrap_err();
        assert_eq!(err.line, Some(6), "{err}");
        assert!(err.to_string().contains("does not go in room type 'kitchen'"), "{err}");
        let files = lib(&[("rooms/bedroom.toml", room)]);
        let types = crate::library::rooms::parse_room_types(&files).unwrap();
        check_room_requests(&files, &types, &classes).unwrap();
    }
}
