//! Furniture placement: picks each room's objects from its room type, sizes and places them by
//! their class's rule, collision-free and clear of doors.
//!
//! For every room (in plan order) the requests of its room type ([`crate::library::RoomType`])
//! are expanded into items (a count drawn per request), each item draws a variant of its class
//! and is placed by the variant's [`Rule`]: standing `on` a support, `beside` an anchor, then
//! the floor rule (`wall`, `corner`, `center`). All draws come from
//! `rng::substream(seed, "placement", room.id)`, so one room's furniture never depends on
//! another's.
//!
//! Invariants (checked over many seeds by `tests/placement.rs`):
//! * footprints (world AABBs in x, y) of objects standing on the floor never intersect, and
//!   keep [`MIN_GAP_M`] between them; an object `on` another stands on the support's top
//!   surface (the largest upward flat area of its mesh: a table top, a mattress) with its
//!   footprint inside that surface, and is disjoint from the other objects on the same support;
//! * everything lies inside the room's interior;
//! * nothing stands in a door's clearance rectangle ([`DOOR_MARGIN_M`], [`DOOR_CLEAR_DEPTH_M`]);
//!   objects taller than a window's sill keep out of the strip in front of it;
//! * walkways: an agent [`WALKWAY_WIDTH_M`] wide can walk from each door of a room to every
//!   other door of it and into an open area of at least [`MIN_REACHABLE_M2`] (or half the
//!   walkable floor of the empty room, if less), so the house can be walked through. A
//!   candidate position that would cut these walks is refused (a flood fill on a
//!   [`WALK_CELL_M`] grid). Fixed corridors to the room centre were tried first; they left no
//!   room for a bed in a 3 m x 4 m bedroom with two doors.
//! * floor objects turn by multiples of 90 degrees, so their AABBs are tight; objects on a
//!   support may turn freely (their AABB is that of the rotated mesh);
//! * wall and corner pieces have their back within [`WALL_GAP_M`] of a wall's inner face.
//!
//! Requests that do not fit are skipped: a small room gets less furniture, never an error.

use std::collections::BTreeMap;
use std::rc::Rc;

use glam::{Mat4, Vec2, Vec3, Vec4};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::config::GeneratorConfig;
use crate::floor_grid::FloorGrid;
use crate::floorplan::Floorplan;
use crate::library::Library;
use crate::library::furniture::{FurnitureVariant, Place, Rule};
use crate::materials::MaterialCatalog;
use crate::scene::{Door, Furnishing, Geometry, Kind, Node, Object, ObjectClass, Room, Semantic, Threshold};
use scene_gen_core::rng;

/// Free width kept beside a door on each side, beyond its own width.
pub const DOOR_MARGIN_M: f32 = 0.3;
/// Depth kept free in front of a door, from the wall's inner face. At least 0.5 m lets
/// the agent reach the door; 1.0 m leaves room to turn through it.
pub const DOOR_CLEAR_DEPTH_M: f32 = 1.0;
/// Width of the agent that must be able to walk between the doors of a room (0.8 m: a
/// common minimum clear passage width in building codes).
pub const WALKWAY_WIDTH_M: f32 = 0.8;
/// Open floor an agent must reach from the doors of a room, when the empty room has twice that.
pub const MIN_REACHABLE_M2: f32 = 2.0;
/// Grid step of the walkway flood fill.
pub const WALK_CELL_M: f32 = 0.1;
/// Gap between a wall piece's back and the wall's inner face.
pub const WALL_GAP_M: f32 = 0.01;
/// Smallest gap between two floor objects.
pub const MIN_GAP_M: f32 = 0.02;
/// Depth of the strip in front of a window that tall objects keep out of.
pub const WINDOW_CLEAR_DEPTH_M: f32 = 0.3;
/// Distance free-standing (`center`) pieces keep from the walls when the room allows it.
pub const CENTER_MARGIN_M: f32 = 0.6;
/// Colour variants drawn per object from the material catalog.
pub const MATERIAL_VARIANTS: u32 = 4;
/// Candidate positions tried per rule before falling back to the next one.
const TRIES: usize = 40;

/// Why furniture could not be placed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlacementError {
    #[error("{0}")]
    Library(String),
}

/// An axis-aligned rectangle in the floor plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub min: Vec2,
    pub max: Vec2,
}

impl Rect {
    /// The bounding rectangle of points.
    #[must_use]
    pub fn around(points: impl IntoIterator<Item = Vec2>) -> Rect {
        let mut r = Rect { min: Vec2::MAX, max: Vec2::MIN };
        for p in points {
            r.min = r.min.min(p);
            r.max = r.max.max(p);
        }
        r
    }

    /// True when the interiors intersect, after growing `self` by `gap` on every side.
    #[must_use]
    pub fn overlaps(&self, other: &Rect, gap: f32) -> bool {
        self.min.x - gap < other.max.x
            && other.min.x < self.max.x + gap
            && self.min.y - gap < other.max.y
            && other.min.y < self.max.y + gap
    }

    /// True when `other` lies inside `self` (up to `eps`).
    #[must_use]
    pub fn contains(&self, other: &Rect, eps: f32) -> bool {
        other.min.x >= self.min.x - eps
            && other.min.y >= self.min.y - eps
            && other.max.x <= self.max.x + eps
            && other.max.y <= self.max.y + eps
    }
}

/// A floor area objects keep out of; only objects reaching higher than `above_m` are kept out
/// (doors: always; windows: objects above the sill).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Zone {
    pub rect: Rect,
    pub above_m: f32,
}

/// Which rule placed an object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlacedBy {
    On,
    Beside,
    Wall,
    Corner,
    Center,
}

/// The placed objects and furnishings with the rule that placed each (same orders).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Placement {
    pub objects: Vec<Object>,
    pub placed_by: Vec<PlacedBy>,
    pub furnishings: Vec<Furnishing>,
    pub furnishings_placed_by: Vec<PlacedBy>,
    /// Requests that did not fit: (room id, class), in the order they were tried.
    pub skipped: Vec<(u32, Kind)>,
    /// The tops of the tables, where small things may stand around what stands on them.
    pub table_tops: Vec<TableTop>,
}

/// The top of a placed table: its height, its rectangle and the footprints of the objects
/// standing on it.
#[derive(Clone, Debug, PartialEq)]
pub struct TableTop {
    pub room: u32,
    pub z_m: f32,
    pub rect: Rect,
    pub occupied: Vec<Rect>,
}

/// Places furniture in every room: the objects (instance ids from `first_instance_id`) and
/// the furnishings.
pub fn place(
    config: &GeneratorConfig,
    plan: &Floorplan,
    thresholds: &[Threshold],
    library: &Library,
    first_instance_id: u32,
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) -> Result<(Vec<Object>, Vec<Furnishing>), PlacementError> {
    place_detailed(config, plan, thresholds, library, first_instance_id, materials, geometry)
        .map(|p| (p.objects, p.furnishings))
}

/// [`place`], also saying which rule placed each object (for checks and debugging).
pub fn place_detailed(
    config: &GeneratorConfig,
    plan: &Floorplan,
    thresholds: &[Threshold],
    library: &Library,
    first_instance_id: u32,
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) -> Result<Placement, PlacementError> {
    let mut placed: Vec<Placed> = Vec::new();
    let mut skipped = Vec::new();
    for room in &plan.rooms {
        let room_type = library.rooms.iter().find(|t| t.name == room.room_type).ok_or_else(|| {
            PlacementError::Library(format!(
                "room {} has type '{}', which the room library lacks",
                room.id, room.room_type
            ))
        })?;
        let mut rng = rng::substream(config.seed, "placement", u64::from(room.id));
        let zones = keep_out_zones(plan, thresholds, room, config.wall_thickness_m);
        let (lo, hi) = room.interior(config.wall_thickness_m);
        let interior = Rect { min: lo, max: hi };
        let walk = WalkGrid::new(plan, room, interior, config.wall_thickness_m);
        let mut ctx = RoomContext { room: room.id, interior, zones, first: placed.len(), walk };

        let weight_here = |v: &FurnitureVariant| v.weight_in(&room.room_type);
        // Expand the requests, draw a variant per item, then place supports before what stands
        // on or beside them, biggest floor pieces first.
        let mut items: Vec<(Kind, &FurnitureVariant, bool)> = Vec::new();
        for request in &room_type.furniture {
            let Some(class) = library.furniture_class(request.class) else {
                if matches!(request.class, Kind::Furnishing(_)) {
                    continue; // a library without this furnishing: nothing to place
                }
                return Err(PlacementError::Library(format!("no furniture class '{}' in the library", request.class)));
            };
            let count = rng.random_range(request.min..=request.max);
            for _ in 0..count {
                let index = crate::library::furniture::weighted_index(&mut rng, class.variants.iter().map(weight_here));
                items.push((class.class, &class.variants[index], class.uniform_scale));
            }
        }
        let stage =
            |v: &FurnitureVariant| match (v.rule.on.is_empty(), v.rule.beside.is_empty() && v.rule.flank.is_empty()) {
                (false, _) => 2,
                (true, false) => 1,
                (true, true) => 0,
            };
        let nominal_area = |v: &FurnitureVariant| {
            let s = v.mesh.size();
            let h = v.size.height_m[1] / s.z;
            v.size.width_m.map_or(s.x * h, |w| w[1]) * v.size.depth_m.map_or(s.y * h, |d| d[1])
        };
        // Within a stage objects go before furnishings, so furnishing a room fills the space
        // its objects leave and never pushes an object out. Pieces that face an anchor (a TV
        // before a sofa) stay with the floor pieces: their anchors are larger, so they come
        // first, and the wall opposite is still free more often than not.
        let furnishing = |k: Kind| matches!(k, Kind::Furnishing(_));
        items.sort_by(|a, b| {
            stage(a.1)
                .cmp(&stage(b.1))
                .then(furnishing(a.0).cmp(&furnishing(b.0)))
                .then(nominal_area(b.1).partial_cmp(&nominal_area(a.1)).unwrap_or(std::cmp::Ordering::Equal))
        });
        for (class, mut variant, uniform) in items {
            // A variant that wants a support the room lacks (a monitor with no table) gives way
            // to a variant of its class that stands on the floor (a TV), when the class has one.
            let has_support = |v: &FurnitureVariant| {
                placed[ctx.first..].iter().any(|p| p.on.is_none() && v.rule.on.contains(&p.class))
            };
            if !variant.rule.on.is_empty() && !has_support(variant) {
                let entry = library.furniture_class(class).expect("checked above");
                let floor: Vec<&FurnitureVariant> =
                    entry.variants.iter().filter(|v| v.rule.on.is_empty() && weight_here(v) > 0.0).collect();
                if !floor.is_empty() {
                    variant = floor
                        [crate::library::furniture::weighted_index(&mut rng, floor.iter().copied().map(weight_here))];
                }
            }
            let (shape, scale) = instantiate(&mut rng, variant, uniform);
            let material_variant = rng.random_range(0..MATERIAL_VARIANTS);
            let mut result = place_one(&mut rng, &ctx, &placed, class, shape, scale);
            if result.is_none() {
                // One more go with another variant of the class (a single bed where a king
                // did not fit).
                let entry = library.furniture_class(class).expect("checked above");
                let other = &entry.variants
                    [crate::library::furniture::weighted_index(&mut rng, entry.variants.iter().map(weight_here))];
                if !std::ptr::eq(other, variant) {
                    let (shape, scale) = instantiate(&mut rng, other, uniform);
                    result = place_one(&mut rng, &ctx, &placed, class, shape, scale);
                }
            }
            match result {
                Some(p) => {
                    if let (Some(walk), None) = (ctx.walk.as_mut(), p.on) {
                        walk.block(&p.footprint());
                    }
                    placed.push(Placed { material_variant, ..p });
                }
                None => skipped.push((room.id, class)),
            }
        }
    }
    let mut placement = build_geometry(&placed, first_instance_id, materials, geometry)?;
    placement.skipped = skipped;
    placement.table_tops = table_tops(&placed);
    Ok(placement)
}

/// One placed object before geometry is made.
#[derive(Clone)]
struct Placed {
    class: Kind,
    room: u32,
    /// The object's own shape (generated), or its library variant's shared mesh.
    variant: Rc<FurnitureVariant>,
    scale: Vec3,
    yaw_deg: f32,
    translation: Vec3,
    min: Vec3,
    max: Vec3,
    on: Option<usize>,
    by: PlacedBy,
    material_variant: u32,
}

impl Placed {
    fn footprint(&self) -> Rect {
        Rect { min: self.min.truncate(), max: self.max.truncate() }
    }

    fn transform(&self) -> Mat4 {
        Mat4::from_translation(self.translation) * rotation_z(self.yaw_deg) * Mat4::from_scale(self.scale)
    }

    /// The top surface others may stand on: its world height and rectangle.
    fn support_top(&self) -> Option<(f32, Rect)> {
        let (z, lo, hi) = self.variant.support_top?;
        let m = self.transform();
        let corners = [lo, Vec2::new(hi.x, lo.y), hi, Vec2::new(lo.x, hi.y)];
        let rect = Rect::around(corners.map(|c| m.transform_point3(c.extend(z)).truncate()));
        Some((m.transform_point3(Vec3::new(0.0, 0.0, z)).z, rect))
    }
}

struct RoomContext {
    room: u32,
    interior: Rect,
    zones: Vec<Zone>,
    /// Index in the placed list of this room's first object.
    first: usize,
    /// `None` for rooms without doors, or whose doors cannot be joined even when empty.
    walk: Option<WalkGrid>,
}

/// Where the centre of an agent [`WALKWAY_WIDTH_M`] wide can stand in a room, on a
/// [`WALK_CELL_M`] grid: not within half that width of a wall or of a floor object.
#[derive(Clone, Debug)]
struct WalkGrid {
    grid: FloorGrid,
    blocked: Vec<bool>,
    /// Cells just inside each door of the room.
    entries: Vec<usize>,
    /// Cells the agent must reach from the doors.
    needed: usize,
}

impl WalkGrid {
    fn new(plan: &Floorplan, room: &Room, interior: Rect, wall_thickness_m: f32) -> Option<WalkGrid> {
        let radius = WALKWAY_WIDTH_M * 0.5;
        let size = interior.max - interior.min;
        if (size.x / WALK_CELL_M).floor() as usize == 0 || (size.y / WALK_CELL_M).floor() as usize == 0 {
            return None;
        }
        let grid = FloorGrid::covering(interior.min, size, WALK_CELL_M);
        let inner = Rect { min: interior.min + radius, max: interior.max - radius };
        let mut blocked: Vec<bool> = (0..grid.len())
            .map(|k| {
                let p = grid.centre(k);
                !(p.x > inner.min.x && p.x < inner.max.x && p.y > inner.min.y && p.y < inner.max.y)
            })
            .collect();
        let mut entries = Vec::new();
        for door in &plan.doors {
            let Some(entry) = door_entry(door, room.id, wall_thickness_m, radius) else { continue };
            let k = grid.cell(entry);
            // The agent squeezes through a door set close to a corner.
            blocked[k] = false;
            entries.push(k);
        }
        if entries.is_empty() {
            return None;
        }
        let free = blocked.iter().filter(|b| !**b).count();
        let needed = ((MIN_REACHABLE_M2 / (WALK_CELL_M * WALK_CELL_M)) as usize).min(free / 2);
        let walk = WalkGrid { grid, blocked, entries, needed };
        walk.walkable(&walk.blocked).then_some(walk)
    }

    fn mark(&self, r: &Rect, blocked: &mut [bool]) {
        let radius = WALKWAY_WIDTH_M * 0.5;
        let g = &self.grid;
        let lo = g.cell(r.min - radius);
        let hi = g.cell(r.max + radius);
        for y in lo / g.width..=hi / g.width {
            for x in lo % g.width..=hi % g.width {
                let k = x + y * g.width;
                let p = g.centre(k);
                if p.x > r.min.x - radius && p.x < r.max.x + radius && p.y > r.min.y - radius && p.y < r.max.y + radius
                {
                    blocked[k] = true;
                }
            }
        }
    }

    /// Adds a floor object's footprint.
    fn block(&mut self, r: &Rect) {
        let mut blocked = std::mem::take(&mut self.blocked);
        self.mark(r, &mut blocked);
        self.blocked = blocked;
    }

    /// Whether the doors stay joined, and open floor reachable, with `r` added.
    fn allows(&self, r: &Rect) -> bool {
        let mut blocked = self.blocked.clone();
        self.mark(r, &mut blocked);
        self.walkable(&blocked)
    }

    fn walkable(&self, blocked: &[bool]) -> bool {
        if self.entries.iter().any(|&e| blocked[e]) {
            return false;
        }
        let fill = self.grid.flood(blocked, &self.entries[..1]);
        fill.reached >= self.needed && self.entries.iter().all(|&e| fill.label[e] == 0)
    }
}

/// A rotation about +Z by `yaw_deg`, exact (no rounding noise) at multiples of 90 degrees so
/// that footprints of turned furniture stay tight.
#[must_use]
pub fn rotation_z(yaw_deg: f32) -> Mat4 {
    let (s, c) = sin_cos_deg(yaw_deg);
    Mat4::from_cols(Vec4::new(c, s, 0.0, 0.0), Vec4::new(-s, c, 0.0, 0.0), Vec4::Z, Vec4::W)
}

fn sin_cos_deg(yaw_deg: f32) -> (f32, f32) {
    let quarter = yaw_deg / 90.0;
    if quarter == quarter.round() {
        match (quarter as i64).rem_euclid(4) {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            _ => (-1.0, 0.0),
        }
    } else {
        yaw_deg.to_radians().sin_cos()
    }
}

/// Bounding box of the mesh scaled by `scale` and turned by `yaw_deg`, before translation.
fn local_bounds(variant: &FurnitureVariant, scale: Vec3, yaw_deg: f32) -> (Vec3, Vec3) {
    let m = rotation_z(yaw_deg) * Mat4::from_scale(scale);
    let (mut lo, mut hi) = (Vec3::MAX, Vec3::MIN);
    for p in variant.mesh.positions() {
        let q = m.transform_point3(p);
        lo = lo.min(q);
        hi = hi.max(q);
    }
    (lo, hi)
}

/// The shape of one object of `variant` and the scale it is placed at. An OBJ variant keeps
/// its shared mesh and draws a scale; a generator variant draws the size the same way, then a
/// 64-bit shape seed, and builds a mesh of exactly that size (scale one).
fn instantiate(rng: &mut ChaCha8Rng, variant: &FurnitureVariant, uniform: bool) -> (Rc<FurnitureVariant>, Vec3) {
    let scale = draw_scale(rng, variant, uniform);
    let Some(generator) = variant.generator else {
        return (Rc::new(variant.clone()), scale);
    };
    let shape_seed: u64 = rng.random();
    let mesh = generator.generate(variant.mesh.size() * scale, uniform, shape_seed);
    let shape = FurnitureVariant {
        name: format!("{}-{shape_seed:016x}", variant.name),
        weight: variant.weight,
        rooms: variant.rooms.clone(),
        size: variant.size,
        rule: variant.rule.clone(),
        support_top: mesh.support_top(),
        mesh,
        generator: Some(generator),
        had_normals: true,
        had_uvs: true,
    };
    (Rc::new(shape), Vec3::ONE)
}

fn draw_scale(rng: &mut ChaCha8Rng, variant: &FurnitureVariant, uniform: bool) -> Vec3 {
    let native = variant.mesh.size();
    let mut draw = |r: [f32; 2]| if r[1] > r[0] { rng.random_range(r[0]..=r[1]) } else { r[0] };
    let height = draw(variant.size.height_m);
    match (uniform, variant.size.width_m, variant.size.depth_m) {
        (false, Some(w), Some(d)) => Vec3::new(draw(w) / native.x, draw(d) / native.y, height / native.z),
        _ => Vec3::splat(height / native.z),
    }
}

/// A rectangle spanned from `origin` by `tangent` (lateral range) and `inward` (depth range).
fn span(origin: Vec2, tangent: Vec2, inward: Vec2, lateral: [f32; 2], depth: [f32; 2]) -> Rect {
    Rect::around(
        [(lateral[0], depth[0]), (lateral[1], depth[0]), (lateral[1], depth[1]), (lateral[0], depth[1])]
            .map(|(a, b)| origin + tangent * a + inward * b),
    )
}

/// The floor kept free in front of `door` on the side of room `room` (the door's width and
/// [`DOOR_MARGIN_M`] each side, [`DOOR_CLEAR_DEPTH_M`] deep from the wall face); `None` when
/// the door does not open on that room.
#[must_use]
pub fn door_clearance(door: &Door, room: u32, wall_thickness_m: f32) -> Option<Rect> {
    let inward = door.inward(room)?;
    let tangent = Vec2::new(-inward.y, inward.x);
    let half = door.width_m * 0.5 + DOOR_MARGIN_M;
    let depth = wall_thickness_m * 0.5 + DOOR_CLEAR_DEPTH_M;
    Some(span(door.center.truncate(), tangent, inward, [-half, half], [0.0, depth]))
}

/// Where an agent of `radius_m` stands just inside `door` in `room`: clear of the wall's face
/// by its radius and 5 cm. `None` when the door does not open on `room`.
#[must_use]
pub(crate) fn door_entry(door: &Door, room: u32, wall_thickness_m: f32, radius_m: f32) -> Option<Vec2> {
    let inward = door.inward(room)?;
    Some(door.center.truncate() + inward * (wall_thickness_m * 0.5 + radius_m + 0.05))
}

/// The rectangles kept free in `room`: door clearances, thresholds, and (for objects above the sill) strips in front of windows.
#[must_use]
pub fn keep_out_zones(plan: &Floorplan, thresholds: &[Threshold], room: &Room, wall_thickness_m: f32) -> Vec<Zone> {
    let face = wall_thickness_m * 0.5;
    let mut zones: Vec<Zone> = plan
        .doors
        .iter()
        .filter_map(|door| door_clearance(door, room.id, wall_thickness_m))
        .map(|rect| Zone { rect, above_m: -1.0 })
        .collect();
    for window in plan.windows.iter().filter(|w| w.room == room.id) {
        let inward = -window.normal;
        let tangent = Vec2::new(-inward.y, inward.x);
        let half = window.width_m * 0.5;
        let sill = window.center.z - window.height_m * 0.5;
        zones.push(Zone {
            rect: span(window.center.truncate(), tangent, inward, [-half, half], [0.0, face + WINDOW_CLEAR_DEPTH_M]),
            above_m: sill,
        });
    }
    for t in thresholds {
        zones.push(Zone { rect: Rect { min: t.min.truncate(), max: t.max.truncate() }, above_m: -1.0 });
    }
    zones
}

/// Tries the variant's rules in order; `None` when nothing fits.
fn place_one(
    rng: &mut ChaCha8Rng,
    ctx: &RoomContext,
    placed: &[Placed],
    class: Kind,
    variant: Rc<FurnitureVariant>,
    scale: Vec3,
) -> Option<Placed> {
    let rule = variant.rule.clone();
    let Rule { on, flank, face, beside, place } = &rule;
    let base = Placed {
        class,
        room: ctx.room,
        variant,
        scale,
        yaw_deg: 0.0,
        translation: Vec3::ZERO,
        min: Vec3::ZERO,
        max: Vec3::ZERO,
        on: None,
        by: PlacedBy::On,
        material_variant: 0,
    };
    let room_objects = &placed[ctx.first..];
    let ids = |f: &dyn Fn(&Placed) -> bool| -> Vec<usize> {
        room_objects.iter().enumerate().filter(|(_, p)| f(p)).map(|(i, _)| ctx.first + i).collect()
    };
    let supports = ids(&|p| p.on.is_none() && on.contains(&p.class) && p.variant.support_top.is_some());
    if !supports.is_empty() {
        for _ in 0..TRIES {
            let s = supports[rng.random_range(0..supports.len())];
            let Some((top_z, top)) = placed[s].support_top() else { continue };
            let yaw = (placed[s].yaw_deg + rng.random_range(-25.0_f32..=25.0)).rem_euclid(360.0);
            let (lo, hi) = local_bounds(&base.variant, scale, yaw);
            let (Some(x), Some(y)) =
                (draw_in(rng, top.min.x - lo.x, top.max.x - hi.x), draw_in(rng, top.min.y - lo.y, top.max.y - hi.y))
            else {
                continue;
            };
            let t = Vec3::new(x, y, top_z);
            let c = Placed {
                yaw_deg: yaw,
                translation: t,
                min: lo + t,
                max: hi + t,
                on: Some(s),
                by: PlacedBy::On,
                ..base.clone()
            };
            let fp = c.footprint();
            if top.contains(&fp, 1e-4)
                && !ctx.zones.iter().any(|z| c.max.z > z.above_m && z.rect.overlaps(&fp, 0.0))
                && !room_objects.iter().any(|p| p.on == Some(s) && p.footprint().overlaps(&fp, 0.0))
            {
                return Some(c);
            }
        }
    }
    // Flanking: beside an anchor standing against a wall, backs on the same wall, same yaw.
    let flanked =
        ids(&|p| p.on.is_none() && flank.contains(&p.class) && matches!(p.by, PlacedBy::Wall | PlacedBy::Corner));
    if !flanked.is_empty() {
        for _ in 0..TRIES {
            let anchor = &placed[flanked[rng.random_range(0..flanked.len())]];
            let a = anchor.footprint();
            let yaw = anchor.yaw_deg;
            let (lo, hi) = local_bounds(&base.variant, scale, yaw);
            let gap = rng.random_range(0.03_f32..=0.15);
            let first = rng.random_bool(0.5);
            // The anchor's back line and the axis along its wall, by its yaw (back at -Y turned).
            let t = match (yaw.round() as i32).rem_euclid(360) {
                0 => Vec2::new(if first { a.min.x - gap - hi.x } else { a.max.x + gap - lo.x }, a.min.y - lo.y),
                90 => Vec2::new(a.max.x - hi.x, if first { a.min.y - gap - hi.y } else { a.max.y + gap - lo.y }),
                180 => Vec2::new(if first { a.min.x - gap - hi.x } else { a.max.x + gap - lo.x }, a.max.y - hi.y),
                _ => Vec2::new(a.min.x - lo.x, if first { a.min.y - gap - hi.y } else { a.max.y + gap - lo.y }),
            }
            .extend(0.0);
            let c =
                Placed { yaw_deg: yaw, translation: t, min: lo + t, max: hi + t, by: PlacedBy::Beside, ..base.clone() };
            if fits_on_floor(ctx, room_objects, &c) {
                return Some(c);
            }
        }
    }
    // Facing: against the wall an anchor faces, across the room, turned towards it.
    let faced =
        ids(&|p| p.on.is_none() && face.contains(&p.class) && matches!(p.by, PlacedBy::Wall | PlacedBy::Corner));
    if !faced.is_empty() {
        for attempt in 0..TRIES {
            let anchor = &placed[faced[rng.random_range(0..faced.len())]];
            let yaw = (anchor.yaw_deg + 180.0).rem_euclid(360.0);
            let (lo, hi) = local_bounds(&base.variant, scale, yaw);
            let (a, r) = (anchor.footprint(), ctx.interior);
            // Centred on the anchor across the room, give or take a little more with each try.
            let slack = 0.3 + attempt as f32 * 0.05;
            let centre =
                (a.min + a.max) * 0.5 - ((lo + hi) * 0.5).truncate() + Vec2::splat(rng.random_range(-slack..=slack));
            // The anchor's back is on the wall its yaw names (0: south, 90: east, ...): this
            // one's back goes on the opposite wall.
            let t = match (anchor.yaw_deg.round() as i32).rem_euclid(360) {
                0 => Vec2::new(centre.x, r.max.y - WALL_GAP_M - hi.y),
                90 => Vec2::new(r.min.x + WALL_GAP_M - lo.x, centre.y),
                180 => Vec2::new(centre.x, r.min.y + WALL_GAP_M - lo.y),
                _ => Vec2::new(r.max.x - WALL_GAP_M - hi.x, centre.y),
            }
            .extend(0.0);
            let c =
                Placed { yaw_deg: yaw, translation: t, min: lo + t, max: hi + t, by: PlacedBy::Wall, ..base.clone() };
            if fits_on_floor(ctx, room_objects, &c) {
                return Some(c);
            }
        }
    }
    let anchors = ids(&|p| p.on.is_none() && beside.contains(&p.class));
    if !anchors.is_empty() {
        for _ in 0..TRIES {
            let a = placed[anchors[rng.random_range(0..anchors.len())]].footprint();
            // Side of the anchor (0 south, 1 east, 2 north, 3 west); the object faces the anchor.
            let side = rng.random_range(0..4_u32);
            let yaw = [0.0, 90.0, 180.0, 270.0][side as usize];
            let (lo, hi) = local_bounds(&base.variant, scale, yaw);
            let gap = rng.random_range(0.05_f32..=0.2);
            let along = |rng: &mut ChaCha8Rng, amin: f32, amax: f32, l: f32, h: f32| {
                let centre = (amin + amax) * 0.5 - (l + h) * 0.5;
                draw_in(rng, amin - l, amax - h).unwrap_or(centre)
            };
            let t = match side {
                0 => Vec2::new(along(rng, a.min.x, a.max.x, lo.x, hi.x), a.min.y - gap - hi.y),
                1 => Vec2::new(a.max.x + gap - lo.x, along(rng, a.min.y, a.max.y, lo.y, hi.y)),
                2 => Vec2::new(along(rng, a.min.x, a.max.x, lo.x, hi.x), a.max.y + gap - lo.y),
                _ => Vec2::new(a.min.x - gap - hi.x, along(rng, a.min.y, a.max.y, lo.y, hi.y)),
            };
            let t = t.extend(0.0);
            let c =
                Placed { yaw_deg: yaw, translation: t, min: lo + t, max: hi + t, by: PlacedBy::Beside, ..base.clone() };
            if fits_on_floor(ctx, room_objects, &c) {
                return Some(c);
            }
        }
    }
    for attempt in 0..TRIES {
        let side = rng.random_range(0..4_u32);
        let c = match place {
            Place::Wall | Place::Corner => {
                // The back faces the wall of `side` (0 south, 1 east, 2 north, 3 west).
                let yaw = [0.0, 90.0, 180.0, 270.0][side as usize];
                let (lo, hi) = local_bounds(&base.variant, scale, yaw);
                let r = ctx.interior;
                // Wall pieces also try the ends of the wall now and then: it packs small rooms.
                let corner = *place == Place::Corner || attempt % 3 == 2;
                let end = rng.random_bool(0.5);
                let along = |rng: &mut ChaCha8Rng, min: f32, max: f32, l: f32, h: f32| {
                    if corner {
                        Some(if end { min + WALL_GAP_M - l } else { max - WALL_GAP_M - h })
                    } else {
                        draw_in(rng, min + WALL_GAP_M - l, max - WALL_GAP_M - h)
                    }
                };
                let t = match side {
                    0 => along(rng, r.min.x, r.max.x, lo.x, hi.x).map(|x| Vec2::new(x, r.min.y + WALL_GAP_M - lo.y)),
                    1 => along(rng, r.min.y, r.max.y, lo.y, hi.y).map(|y| Vec2::new(r.max.x - WALL_GAP_M - hi.x, y)),
                    2 => along(rng, r.min.x, r.max.x, lo.x, hi.x).map(|x| Vec2::new(x, r.max.y - WALL_GAP_M - hi.y)),
                    _ => along(rng, r.min.y, r.max.y, lo.y, hi.y).map(|y| Vec2::new(r.min.x + WALL_GAP_M - lo.x, y)),
                };
                let Some(t) = t else { continue };
                let t = t.extend(0.0);
                let by = if *place == Place::Corner { PlacedBy::Corner } else { PlacedBy::Wall };
                Placed { yaw_deg: yaw, translation: t, min: lo + t, max: hi + t, by, ..base.clone() }
            }
            Place::Center => {
                let yaw = [0.0, 90.0, 180.0, 270.0][side as usize];
                let (lo, hi) = local_bounds(&base.variant, scale, yaw);
                let margin = if attempt < TRIES / 2 { CENTER_MARGIN_M } else { 0.2 };
                let r = ctx.interior;
                let (Some(x), Some(y)) = (
                    draw_in(rng, r.min.x + margin - lo.x, r.max.x - margin - hi.x),
                    draw_in(rng, r.min.y + margin - lo.y, r.max.y - margin - hi.y),
                ) else {
                    continue;
                };
                let t = Vec3::new(x, y, 0.0);
                Placed { yaw_deg: yaw, translation: t, min: lo + t, max: hi + t, by: PlacedBy::Center, ..base.clone() }
            }
        };
        if fits_on_floor(ctx, room_objects, &c) {
            return Some(c);
        }
    }
    None
}

/// A uniform draw in `[lo, hi]`, `None` when the range is empty.
fn draw_in(rng: &mut ChaCha8Rng, lo: f32, hi: f32) -> Option<f32> {
    if lo.is_nan() || hi.is_nan() || lo > hi {
        return None;
    }
    Some(if hi > lo { rng.random_range(lo..=hi) } else { lo })
}

fn fits_on_floor(ctx: &RoomContext, room_objects: &[Placed], c: &Placed) -> bool {
    let fp = c.footprint();
    ctx.interior.contains(&fp, 1e-4)
        && !ctx.zones.iter().any(|z| c.max.z > z.above_m && z.rect.overlaps(&fp, 0.0))
        && !room_objects.iter().any(|p| p.on.is_none() && p.footprint().overlaps(&fp, MIN_GAP_M))
        && ctx.walk.as_ref().is_none_or(|w| w.allows(&fp))
}

/// The tops of the floor-standing tables turned a multiple of 90 degrees (the top's rectangle
/// is then exactly its world box), with what stands on each.
fn table_tops(placed: &[Placed]) -> Vec<TableTop> {
    placed
        .iter()
        .enumerate()
        .filter(|(_, p)| p.class == Kind::Object(ObjectClass::Table) && p.on.is_none())
        .filter(|(_, p)| (p.yaw_deg / 90.0 - (p.yaw_deg / 90.0).round()).abs() < 1e-4)
        .filter_map(|(i, p)| {
            let (z_m, rect) = p.support_top()?;
            let occupied = placed.iter().filter(|q| q.on == Some(i)).map(Placed::footprint).collect();
            Some(TableTop { room: p.room, z_m, rect, occupied })
        })
        .collect()
}

/// Adds meshes (one per asset and colour variant, shared by instances), nodes and manifest
/// objects.
fn build_geometry(
    placed: &[Placed],
    first_instance_id: u32,
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) -> Result<Placement, PlacementError> {
    let mut meshes: BTreeMap<(String, u32), usize> = BTreeMap::new();
    let mut out = Placement::default();
    // Objects and furnishings are numbered apart; supports are always objects (the library
    // refuses `on` a furnishing), so an object's `on` maps through its support's object id.
    let mut object_id: Vec<Option<u32>> = Vec::with_capacity(placed.len());
    for p in placed {
        let asset = format!("{}/{}", p.class, p.variant.name);
        let key = (asset.clone(), p.material_variant);
        let mesh = match meshes.get(&key) {
            Some(&m) => m,
            None => {
                let mut error = None;
                let mesh =
                    p.variant.mesh.to_mesh(&format!("{}_{}", asset.replace('/', "_"), p.material_variant), |s| {
                        materials.material(geometry, s, p.material_variant).unwrap_or_else(|e| {
                            error = Some(e);
                            0
                        })
                    });
                if let Some(e) = error {
                    return Err(PlacementError::Library(format!("{asset}: {e}")));
                }
                geometry.meshes.push(mesh);
                meshes.insert(key, geometry.meshes.len() - 1);
                geometry.meshes.len() - 1
            }
        };
        // Node name and semantic by kind; the node itself is the same for both.
        let (id, semantic) = match p.class {
            Kind::Object(class) => {
                let id = out.objects.len() as u32;
                object_id.push(Some(id));
                let on = p.on.map(|s| object_id[s].expect("supports are objects, placed before what stands on them"));
                out.objects.push(Object {
                    id,
                    class,
                    instance_id: first_instance_id + id,
                    room: p.room,
                    asset,
                    min: p.min,
                    max: p.max,
                    yaw_deg: p.yaw_deg,
                    on,
                });
                out.placed_by.push(p.by);
                (id, Semantic::Object { id })
            }
            Kind::Furnishing(kind) => {
                let id = out.furnishings.len() as u32;
                object_id.push(None);
                out.furnishings.push(Furnishing {
                    id,
                    kind,
                    room: p.room,
                    asset,
                    min: p.min,
                    max: p.max,
                    yaw_deg: p.yaw_deg,
                });
                out.furnishings_placed_by.push(p.by);
                (id, Semantic::Furnishing { id })
            }
        };
        geometry.nodes.push(Node { name: format!("{}_{id}", p.class), mesh, transform: p.transform(), semantic });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn right_angle_rotations_are_exact() {
        for (yaw, x) in
            [(0.0, Vec3::X), (90.0, Vec3::Y), (180.0, Vec3::NEG_X), (270.0, Vec3::NEG_Y), (-90.0, Vec3::NEG_Y)]
        {
            assert_eq!(rotation_z(yaw).transform_vector3(Vec3::X), x, "yaw {yaw}");
        }
        let r = rotation_z(30.0).transform_vector3(Vec3::X);
        assert!((r - Vec3::new(0.866_025_4, 0.5, 0.0)).length() < 1e-6);
    }

    #[test]
    fn rect_overlap_respects_gap_and_touching() {
        let a = Rect { min: Vec2::ZERO, max: Vec2::ONE };
        let b = Rect { min: Vec2::new(1.0, 0.0), max: Vec2::new(2.0, 1.0) };
        assert!(!a.overlaps(&b, 0.0));
        assert!(a.overlaps(&b, 0.01));
        assert!(a.contains(&Rect { min: Vec2::splat(0.2), max: Vec2::splat(0.8) }, 0.0));
        assert!(!a.contains(&b, 0.0));
    }
}
