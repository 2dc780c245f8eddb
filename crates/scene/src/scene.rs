//! The `Scene`: the one value every stage downstream of the generator reads.
//!
//! A `Scene` holds two views of the same house:
//!
//! * the **semantic view** (rooms, walls, doors, windows, thresholds, objects, lights), which is
//!   what the manifest `scene.json` serialises and what the evaluator reasons about; and
//! * the **geometry** ([`Geometry`]): shared meshes, PBR materials, baked textures and the nodes
//!   that place a mesh in the world and say which semantic item it belongs to. Renderers and
//!   exporters read only this, plus the lights.
//!
//! Everything is in the world frame of docs/CONTRACTS.md: metres, right-handed, Z up, X east, Y north,
//! floor at z = 0. Nothing downstream mutates a `Scene`.

use glam::{Mat4, Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// Manifest schema tag; bump the trailing number when the manifest contract changes.
pub const MANIFEST_SCHEMA: &str = "scene-gen/scene/1";

/// COCO category id of the gold door thresholds (object classes use 1..=10).
pub const THRESHOLD_CLASS_ID: u32 = 11;

/// Name used for the threshold class wherever a class name is written.
pub const THRESHOLD_CLASS_NAME: &str = "threshold";

/// The ten object classes, in the order that fixes their class ids (1..=10).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObjectClass {
    Sofa,
    Bed,
    Table,
    Chair,
    Bathtub,
    Basin,
    Computer,
    Plant,
    Lamp,
    Toy,
}

impl ObjectClass {
    /// All classes in class-id order.
    pub const ALL: [ObjectClass; 10] = [
        ObjectClass::Sofa,
        ObjectClass::Bed,
        ObjectClass::Table,
        ObjectClass::Chair,
        ObjectClass::Bathtub,
        ObjectClass::Basin,
        ObjectClass::Computer,
        ObjectClass::Plant,
        ObjectClass::Lamp,
        ObjectClass::Toy,
    ];

    /// COCO category id, 1..=10.
    #[must_use]
    pub fn class_id(self) -> u32 {
        self as u32 + 1
    }

    /// Lower-case name as written in manifests, TOML and labels.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ObjectClass::Sofa => "sofa",
            ObjectClass::Bed => "bed",
            ObjectClass::Table => "table",
            ObjectClass::Chair => "chair",
            ObjectClass::Bathtub => "bathtub",
            ObjectClass::Basin => "basin",
            ObjectClass::Computer => "computer",
            ObjectClass::Plant => "plant",
            ObjectClass::Lamp => "lamp",
            ObjectClass::Toy => "toy",
        }
    }

    /// Parses a class name; `None` for anything not in [`ObjectClass::ALL`].
    #[must_use]
    pub fn from_name(name: &str) -> Option<ObjectClass> {
        ObjectClass::ALL.into_iter().find(|c| c.name() == name)
    }
}

impl std::fmt::Display for ObjectClass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Furniture and fittings that make a house lived-in but are not detection targets: obstacles
/// and occluders, in the manifest's `furnishings`, never in COCO categories or instance masks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FurnishingKind {
    Wardrobe,
    Bookshelf,
    Nightstand,
    Counter,
    Fridge,
    Stove,
    Toilet,
}

impl FurnishingKind {
    /// Every kind, in manifest order.
    pub const ALL: [FurnishingKind; 7] = [
        FurnishingKind::Wardrobe,
        FurnishingKind::Bookshelf,
        FurnishingKind::Nightstand,
        FurnishingKind::Counter,
        FurnishingKind::Fridge,
        FurnishingKind::Stove,
        FurnishingKind::Toilet,
    ];

    /// Lower-case name as written in manifests and TOML.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            FurnishingKind::Wardrobe => "wardrobe",
            FurnishingKind::Bookshelf => "bookshelf",
            FurnishingKind::Nightstand => "nightstand",
            FurnishingKind::Counter => "counter",
            FurnishingKind::Fridge => "fridge",
            FurnishingKind::Stove => "stove",
            FurnishingKind::Toilet => "toilet",
        }
    }
}

/// What a furniture class of the library places: a detection target or a furnishing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kind {
    Object(ObjectClass),
    Furnishing(FurnishingKind),
}

impl Kind {
    /// Every kind: the ten object classes, then the furnishings.
    pub fn all() -> impl Iterator<Item = Kind> {
        ObjectClass::ALL.into_iter().map(Kind::Object).chain(FurnishingKind::ALL.into_iter().map(Kind::Furnishing))
    }

    /// Lower-case name as written in manifests and TOML.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Kind::Object(c) => c.name(),
            Kind::Furnishing(k) => k.name(),
        }
    }

    /// Parses a class or furnishing name.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Kind> {
        Kind::all().find(|k| k.name() == name)
    }

    /// The object class, for detection targets.
    #[must_use]
    pub fn object_class(self) -> Option<ObjectClass> {
        match self {
            Kind::Object(c) => Some(c),
            Kind::Furnishing(_) => None,
        }
    }
}

impl From<ObjectClass> for Kind {
    fn from(class: ObjectClass) -> Kind {
        Kind::Object(class)
    }
}

impl std::fmt::Display for Kind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The outer box the house fills.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Envelope {
    pub width_m: f32,
    pub depth_m: f32,
    pub height_m: f32,
}

impl Default for Envelope {
    fn default() -> Self {
        Envelope { width_m: 15.0, depth_m: 15.0, height_m: 3.0 }
    }
}

impl Envelope {
    /// Checks that a camera mounted `height_m` above the floor is inside the house: at or
    /// above the ceiling it would see the roof from outside, and every frame would be empty.
    ///
    /// # Errors
    /// The message names the camera spec field and the ceiling height.
    pub fn check_camera_height(&self, height_m: f32) -> Result<(), String> {
        if height_m < self.height_m {
            Ok(())
        } else {
            Err(format!(
                "camera spec field height_m: {height_m} m is not below the ceiling ({} m, the envelope height)",
                self.height_m
            ))
        }
    }
}

impl std::fmt::Display for Envelope {
    /// `WIDTHxDEPTHxHEIGHT` in metres, the form `--envelope` takes.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}x{}", self.width_m, self.depth_m, self.height_m)
    }
}

impl std::str::FromStr for Envelope {
    type Err = String;

    /// Parses `WIDTHxDEPTHxHEIGHT` in metres, e.g. `15x15x3`.
    fn from_str(text: &str) -> Result<Envelope, String> {
        let parts: Vec<&str> = text.split(['x', 'X']).collect();
        let [w, d, h] = parts.as_slice() else {
            return Err(format!("'{text}' is not WIDTHxDEPTHxHEIGHT in metres, e.g. 15x15x3"));
        };
        let num = |s: &str, what: &str| {
            s.trim().parse::<f32>().map_err(|_| format!("'{s}' in '{text}' is not a number ({what})"))
        };
        Ok(Envelope { width_m: num(w, "width")?, depth_m: num(d, "depth")?, height_m: num(h, "height")? })
    }
}

/// Where a library of a house came from and what it held: enough to find it again and to
/// tell whether it is the same.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LibraryId {
    /// The folder as it was given (`--rooms`, `--furniture`); `null` for the embedded library.
    pub folder: Option<String>,
    /// `fnv1a64:` and 16 hex digits over every file's path (relative to the library root)
    /// and bytes, in path order.
    pub digest: String,
}

/// What a house was generated with beyond its seed, envelope and wall thickness: what a
/// program needs to rebuild the same house.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HouseRecord {
    /// `--min-room`: the smallest room side, at wall centre lines.
    pub min_room_m: f32,
    pub rooms: LibraryId,
    pub furniture: LibraryId,
}

/// A rectangular room; `min`/`max` are its footprint at the wall centre lines.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Room {
    pub id: u32,
    /// Room type name, the stem of its `rooms/<type>.toml`.
    #[serde(rename = "type")]
    pub room_type: String,
    pub min: Vec2,
    pub max: Vec2,
}

impl Room {
    /// Footprint size at the wall centre lines.
    #[must_use]
    pub fn size_m(&self) -> Vec2 {
        self.max - self.min
    }

    /// Footprint centre.
    #[must_use]
    pub fn center(&self) -> Vec2 {
        (self.min + self.max) * 0.5
    }

    /// The free interior: the footprint shrunk by half a wall on every side.
    #[must_use]
    pub fn interior(&self, wall_thickness_m: f32) -> (Vec2, Vec2) {
        let half = Vec2::splat(wall_thickness_m * 0.5);
        (self.min + half, self.max - half)
    }
}

/// What fills a hole in a wall.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OpeningKind {
    Door,
    Window,
}

/// A rectangular hole in a wall, in the wall's own coordinates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Opening {
    pub kind: OpeningKind,
    /// Id of the door or window.
    pub id: u32,
    /// Distance along the wall from `a` to the centre of the opening.
    pub offset_m: f32,
    pub width_m: f32,
    /// Height of the bottom of the opening above the floor (0 for doors).
    pub sill_m: f32,
    pub height_m: f32,
}

/// A straight wall segment between two points on a wall centre line.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Wall {
    pub id: u32,
    pub a: Vec2,
    pub b: Vec2,
    pub thickness_m: f32,
    pub height_m: f32,
    /// Rooms on either side; `None` for the outside.
    pub rooms: [Option<u32>; 2],
    /// Openings sorted by `offset_m`, never overlapping.
    pub openings: Vec<Opening>,
}

impl Wall {
    #[must_use]
    pub fn length_m(&self) -> f32 {
        self.a.distance(self.b)
    }

    /// True when the wall has the outside on one side.
    #[must_use]
    pub fn is_exterior(&self) -> bool {
        self.rooms.iter().any(Option::is_none)
    }
}

/// A door opening between two rooms, or between a room and the outside.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Door {
    pub id: u32,
    /// `[a, b]`: `b` is `None` for an exterior door.
    pub rooms: [Option<u32>; 2],
    pub wall: u32,
    /// Centre of the opening: on the wall centre line, at half the door height.
    pub center: Vec3,
    pub width_m: f32,
    pub height_m: f32,
    /// Unit horizontal normal of the wall, pointing from room `a` towards `b`.
    pub normal: Vec2,
    /// The door's leaf, standing open; `None` where no leaf was hung (every door of a
    /// generated house has one unless nothing left it room to open, and manifests written
    /// before leaves existed have none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub leaf: Option<DoorLeaf>,
}

impl Door {
    /// Unit horizontal normal of the wall pointing into room `room`; `None` when the door
    /// does not open on it.
    #[must_use]
    pub fn inward(&self, room: u32) -> Option<Vec2> {
        if self.rooms[0] == Some(room) {
            Some(-self.normal)
        } else if self.rooms[1] == Some(room) {
            Some(self.normal)
        } else {
            None
        }
    }
}

/// The leaf of a door, standing open into one of the door's rooms: a slab hinged on a
/// vertical axis at one jamb, just off the wall's face.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DoorLeaf {
    /// The room it opens into.
    pub room: u32,
    /// The hinge axis, at floor level.
    pub hinge: Vec2,
    /// Unit horizontal direction from the hinge to the leaf's free edge.
    pub direction: Vec2,
    /// How far it stands open, degrees from closed: 90 is square to the wall, 180 back
    /// against it.
    pub open_deg: f32,
    /// Hinge to free edge.
    pub width_m: f32,
    pub thickness_m: f32,
    /// Top edge above the floor (the leaf clears the floor by [`DoorLeaf::UNDERCUT_M`]).
    pub height_m: f32,
}

impl DoorLeaf {
    /// Gap between the floor and the bottom of a leaf.
    pub const UNDERCUT_M: f32 = 0.01;

    /// The end of the leaf's centre line at its free edge, at floor level.
    #[must_use]
    pub fn free_edge(&self) -> Vec2 {
        self.hinge + self.direction * self.width_m
    }

    /// Corners of the leaf's footprint, counter-clockwise, with its faces grown by `pad_m`
    /// (handles, clearance).
    #[must_use]
    pub fn footprint(&self, pad_m: f32) -> [Vec2; 4] {
        let half = self.direction.perp() * (0.5 * self.thickness_m + pad_m);
        let (a, b) = (self.hinge, self.free_edge());
        [a - half, b - half, b + half, a + half]
    }
}

/// A window in an exterior wall.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Window {
    pub id: u32,
    pub room: u32,
    pub wall: u32,
    /// Centre of the opening on the wall centre line.
    pub center: Vec3,
    pub width_m: f32,
    pub height_m: f32,
    /// Unit horizontal normal pointing from the room to the outside.
    pub normal: Vec2,
}

/// The low gold box in a doorway: the obstacle the camera must see in time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Threshold {
    pub id: u32,
    pub door: u32,
    /// Unique over objects and thresholds, >= 1; 0 in an instance buffer is "no instance".
    pub instance_id: u32,
    pub min: Vec3,
    pub max: Vec3,
}

/// A piece of furniture (or a toy, a plant...) of one of the ten classes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Object {
    pub id: u32,
    pub class: ObjectClass,
    /// Unique over objects and thresholds, >= 1.
    pub instance_id: u32,
    pub room: u32,
    /// Asset name: `<class>/<file stem>` in the furniture library.
    pub asset: String,
    /// World-space axis-aligned bounding box of the placed mesh.
    pub min: Vec3,
    pub max: Vec3,
    /// Rotation about +Z of the asset's front (+Y in asset space), degrees counter-clockwise.
    pub yaw_deg: f32,
    /// Id of the object this one stands on (a lamp on a table), if any.
    pub on: Option<u32>,
}

/// A wardrobe, a bookshelf, a kitchen counter...: furniture that is not a detection target.
/// It stands on the floor, keeps every placement rule objects keep, and blocks the walk.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Furnishing {
    pub id: u32,
    pub kind: FurnishingKind,
    pub room: u32,
    /// Asset name, as for [`Object::asset`].
    pub asset: String,
    /// World-space axis-aligned bounding box of the placed mesh.
    pub min: Vec3,
    pub max: Vec3,
    /// Rotation about +Z of the asset's front (+Y in asset space), degrees counter-clockwise.
    pub yaw_deg: f32,
}

/// Which scenario a light belongs to; a render weights the groups separately.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LightGroup {
    Day,
    Night,
}

/// Light shapes the renderer and exporters understand.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LightKind {
    /// Isotropic point light; `intensity` in candela.
    Point,
    /// Parallel light (the sun); `direction` is where it travels; `intensity` in lux on a
    /// surface facing it.
    Directional,
    /// A one-sided Lambertian rectangle (a window letting sky light in, a ceiling panel);
    /// `intensity` is its luminance in nit (cd/m^2), emitted towards `direction`.
    Rect,
}

/// Photometric unit of [`Light::intensity`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LightUnit {
    /// candela (point lights)
    Cd,
    /// lux (directional lights)
    Lux,
    /// cd/m^2 (area lights)
    Nit,
}

/// A light in physical units. Which optional fields are set depends on `kind`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub id: u32,
    pub group: LightGroup,
    pub kind: LightKind,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<Vec3>,
    /// Direction of travel of the light (directional, rect).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<Vec3>,
    /// Rect lights: edge vectors spanning the rectangle from `position` (its centre): the
    /// rectangle is `position + s * u + t * v` for s, t in [-0.5, 0.5].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rect_u: Option<Vec3>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rect_v: Option<Vec3>,
    pub intensity: f32,
    pub unit: LightUnit,
    /// Linear RGB tint, max component 1.
    pub color: [f32; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub room: Option<u32>,
    /// The lamp object this light belongs to, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object: Option<u32>,
}

impl Light {
    /// An isotropic white point light of `candela` in `group`, in no room; set `color`,
    /// `room` and `object` on the result as needed. Ids are assigned by whoever collects lights.
    #[must_use]
    pub fn point(group: LightGroup, position: Vec3, candela: f32) -> Light {
        Light {
            id: 0,
            group,
            kind: LightKind::Point,
            position: Some(position),
            direction: None,
            rect_u: None,
            rect_v: None,
            intensity: candela,
            unit: LightUnit::Cd,
            color: [1.0; 3],
            room: None,
            object: None,
        }
    }
}

/// Triangle meshes, materials, textures and placed nodes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Geometry {
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub nodes: Vec<Node>,
}

impl Geometry {
    /// Adds `mesh` and one node of the same name placing it by `transform`: a mesh of its own
    /// (structure, decor, door leaves), not shared with other nodes.
    pub fn push_placed(&mut self, mesh: Mesh, transform: Mat4, semantic: Semantic) {
        self.nodes.push(Node { name: mesh.name.clone(), mesh: self.meshes.len(), transform, semantic });
        self.meshes.push(mesh);
    }
}

/// A mesh in its own frame; shared by every node that places it.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub name: String,
    pub primitives: Vec<Primitive>,
}

/// One material's triangles of a mesh. All vertex arrays have the same length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Primitive {
    pub positions: Vec<Vec3>,
    /// Unit vertex normals.
    pub normals: Vec<Vec3>,
    /// Texture coordinates; (0, 0) is the top-left of the texture image, as in glTF.
    pub uvs: Vec<Vec2>,
    /// Counter-clockwise triangles seen from the side the normal points to.
    pub indices: Vec<u32>,
    /// Index into [`Geometry::materials`].
    pub material: usize,
}

/// A metallic-roughness PBR material, as glTF and UsdPreviewSurface define it.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGBA factor, multiplied with the texture if there is one.
    pub base_color: [f32; 4],
    pub metallic: f32,
    pub roughness: f32,
    /// Index into [`Geometry::textures`] (sRGB base colour).
    pub base_color_texture: Option<usize>,
}

/// A baked texture, kept both as pixels (for the renderer) and as PNG bytes (for exporters).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// sRGB-encoded RGBA8, row-major from the top row. Shared (`Arc`) with the process-wide
    /// texture cache of [`crate::textures`], so scenes do not copy pixels.
    pub rgba8: std::sync::Arc<[u8]>,
    /// The same image encoded as PNG (RGB or RGBA), on first read.
    pub png: crate::textures::Png,
}

/// What a node is, for labels and instance buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "type")]
pub enum Semantic {
    /// An [`Object`] by id.
    Object { id: u32 },
    /// A [`Threshold`] by id.
    Threshold { id: u32 },
    /// Floor of a room.
    Floor { room: u32 },
    /// Ceiling of a room.
    Ceiling { room: u32 },
    /// A wall by id.
    Wall { wall: u32 },
    /// Glass, frame or leaf of a window or door, by door/window id.
    Opening { kind: OpeningKind, id: u32 },
    /// Unlabelled decoration (a rug, a picture) in a room.
    Decor { room: u32 },
    /// A [`Furnishing`] by id: not a detection target, so unlabelled.
    Furnishing { id: u32 },
}

/// A mesh placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    pub name: String,
    /// Index into [`Geometry::meshes`].
    pub mesh: usize,
    /// Mesh frame to world frame (Z up, metres).
    pub transform: Mat4,
    pub semantic: Semantic,
}

/// A complete generated house.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub seed: u64,
    pub envelope: Envelope,
    pub wall_thickness_m: f32,
    /// The generator's options and libraries this house was made with.
    pub house: HouseRecord,
    /// The colour scheme the house is decorated in (`None` for a scene built by hand).
    pub palette: Option<&'static crate::palette::Palette>,
    pub rooms: Vec<Room>,
    pub walls: Vec<Wall>,
    pub doors: Vec<Door>,
    pub windows: Vec<Window>,
    pub thresholds: Vec<Threshold>,
    pub objects: Vec<Object>,
    /// Non-target furniture (wardrobes, counters, ...).
    pub furnishings: Vec<Furnishing>,
    pub lights: Vec<Light>,
    pub geometry: Geometry,
}

impl Scene {
    /// The room with `id`, if any.
    #[must_use]
    pub fn room(&self, id: u32) -> Option<&Room> {
        self.rooms.iter().find(|r| r.id == id)
    }

    /// Class name, COCO class id and instance id of a semantic item, for labelled items only
    /// (objects and thresholds).
    #[must_use]
    pub fn label(&self, semantic: Semantic) -> Option<Label<'_>> {
        match semantic {
            Semantic::Object { id } => self.objects.get(id as usize).map(|o| Label {
                class: o.class.name(),
                class_id: o.class.class_id(),
                instance_id: o.instance_id,
                room: Some(o.room),
            }),
            Semantic::Threshold { id } => self.thresholds.get(id as usize).map(|t| Label {
                class: THRESHOLD_CLASS_NAME,
                class_id: THRESHOLD_CLASS_ID,
                instance_id: t.instance_id,
                room: self.doors.get(t.door as usize).and_then(|d| d.rooms[0]),
            }),
            _ => None,
        }
    }
}

/// The label of an object or threshold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Label<'a> {
    pub class: &'a str,
    pub class_id: u32,
    pub instance_id: u32,
    pub room: Option<u32>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn class_ids_follow_design_order() {
        let names: Vec<_> = ObjectClass::ALL.iter().map(|c| c.name()).collect();
        assert_eq!(names, ["sofa", "bed", "table", "chair", "bathtub", "basin", "computer", "plant", "lamp", "toy"]);
        for (i, c) in ObjectClass::ALL.iter().enumerate() {
            assert_eq!(c.class_id(), i as u32 + 1);
            assert_eq!(ObjectClass::from_name(c.name()), Some(*c));
        }
        assert_eq!(ObjectClass::from_name("piano"), None);
    }
}
