//! Structural geometry: floors, ceilings, walls with their openings cut out, window frames and
//! the gold door thresholds.
//!
//! Everything is built directly in world coordinates (node transforms are the identity), with
//! texture coordinates in metres of surface projected along the face's axis, so one texture
//! repeat covers 1 m x 1 m everywhere.
//!
//! Walls are solid boxes of the wall thickness around their centre-line segment. Corners close
//! without overlapping faces by one rule per wall end (see `end_extension`): walls along X
//! own the square where centre lines meet, walls along Y stop at its face, and collinear walls
//! butt at the centre point. Openings are cut by splitting each side face into columns.
//!
//! Surfaces are drawn from the `"structure"` stream of the seed: each room takes a floor and a
//! wall surface from its room type's lists (and a colour variant); the outside of the house
//! takes one facade finish.

use glam::{Mat4, Vec2, Vec3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::config::GeneratorConfig;
use crate::floorplan::{Floorplan, normal_away_from};
use crate::library::RoomType;
use crate::materials::{MaterialCatalog, UnknownSurface};
use crate::scene::{Geometry, Mesh, OpeningKind, Primitive, Semantic, Threshold, Wall};

/// Threshold heights drawn, metres: low enough to step over, high enough for a camera to have
/// to notice (the reference system's gold obstacles, docs/REFERENCE.md, "Environment").
pub const THRESHOLD_HEIGHT_M: (f32, f32) = (0.02, 0.05);
/// Threshold ends stop this short of the door jambs so no face is coplanar with a jamb.
const THRESHOLD_END_INSET_M: f32 = 0.002;
/// Window frame profile: width in the wall plane and depth through the wall, metres.
pub const FRAME_WIDTH_M: f32 = 0.05;
pub const FRAME_DEPTH_M: f32 = 0.06;
/// Gap between a frame and the reveal it sits in, so their faces are not coplanar.
const FRAME_INSET_M: f32 = 0.001;
/// Colour variants drawn per surface.
const SURFACE_VARIANTS: u32 = 4;
/// Facade finish of the outside of the house.
const FACADE_SURFACE: &str = "paint";

/// Why the structure could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StructureError {
    #[error("room {room}: room type '{room_type}' is not in the room library")]
    UnknownRoomType { room: u32, room_type: String },
    #[error(transparent)]
    Surface(#[from] UnknownSurface),
}

/// Adds the structure's meshes and nodes to `geometry` and returns the thresholds (one per
/// door, in door order, instance ids from 1).
pub fn build(
    config: &GeneratorConfig,
    plan: &Floorplan,
    room_types: &[RoomType],
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) -> Result<Vec<Threshold>, StructureError> {
    let mut rng = scene_gen_core::rng::stream(config.seed, "structure");
    let h = config.envelope.height_m;
    let t = config.wall_thickness_m;

    // Surfaces, one draw per room in room order, then the facade.
    let mut wall_material = Vec::with_capacity(plan.rooms.len());
    for room in &plan.rooms {
        let rt = room_types
            .iter()
            .find(|rt| rt.name == room.room_type)
            .ok_or_else(|| StructureError::UnknownRoomType { room: room.id, room_type: room.room_type.clone() })?;
        let floor = pick(&mut rng, &rt.floor);
        let floor = materials.material(geometry, floor, rng.random_range(0..SURFACE_VARIANTS))?;
        let walls = pick(&mut rng, &rt.walls);
        wall_material.push(materials.material(geometry, walls, rng.random_range(0..SURFACE_VARIANTS))?);
        let ceiling = materials.material(geometry, "ceiling", 0)?;

        let (lo, hi) = room.interior(t);
        let mut f = PrimBuilder::default();
        f.quad([lo.extend(0.0), Vec3::new(hi.x, lo.y, 0.0), hi.extend(0.0), Vec3::new(lo.x, hi.y, 0.0)], Vec3::Z);
        push_node(geometry, format!("floor_{}", room.id), vec![f.build(floor)], Semantic::Floor { room: room.id });
        let mut c = PrimBuilder::default();
        c.quad([lo.extend(h), Vec3::new(hi.x, lo.y, h), hi.extend(h), Vec3::new(lo.x, hi.y, h)], Vec3::NEG_Z);
        push_node(
            geometry,
            format!("ceiling_{}", room.id),
            vec![c.build(ceiling)],
            Semantic::Ceiling { room: room.id },
        );
    }
    let facade = materials.material(geometry, FACADE_SURFACE, rng.random_range(0..SURFACE_VARIANTS))?;
    let frame_material = materials.material(geometry, "frame", 0)?;
    let gold = materials.material(geometry, "gold", 0)?;

    for wall in &plan.walls {
        let Some(room0) = wall.rooms[0] else { continue };
        let frame = WallFrame::new(wall, normal_away_from(wall, &plan.rooms[room0 as usize]));
        let m0 = wall_material[room0 as usize];
        let m1 = wall.rooms[1].map_or(facade, |r| wall_material[r as usize]);
        let (side0, side1) = wall_mesh(wall, &frame, &plan.walls);
        let primitives = if m0 == m1 {
            let mut merged = side0;
            merged.append(side1);
            vec![merged.build(m0)]
        } else {
            vec![side0.build(m0), side1.build(m1)]
        };
        push_node(geometry, format!("wall_{}", wall.id), primitives, Semantic::Wall { wall: wall.id });

        for o in wall.openings.iter().filter(|o| o.kind == OpeningKind::Window) {
            let (s0, s1) = (o.offset_m - 0.5 * o.width_m + FRAME_INSET_M, o.offset_m + 0.5 * o.width_m - FRAME_INSET_M);
            let (z0, z1) = (o.sill_m + FRAME_INSET_M, o.sill_m + o.height_m - FRAME_INSET_M);
            let d = (-0.5 * FRAME_DEPTH_M, 0.5 * FRAME_DEPTH_M);
            let mut pb = PrimBuilder::default();
            frame.local_box(&mut pb, (s0, s0 + FRAME_WIDTH_M), d, (z0, z1));
            frame.local_box(&mut pb, (s1 - FRAME_WIDTH_M, s1), d, (z0, z1));
            frame.local_box(&mut pb, (s0 + FRAME_WIDTH_M, s1 - FRAME_WIDTH_M), d, (z0, z0 + FRAME_WIDTH_M));
            frame.local_box(&mut pb, (s0 + FRAME_WIDTH_M, s1 - FRAME_WIDTH_M), d, (z1 - FRAME_WIDTH_M, z1));
            push_node(
                geometry,
                format!("window_frame_{}", o.id),
                vec![pb.build(frame_material)],
                Semantic::Opening { kind: OpeningKind::Window, id: o.id },
            );
        }
    }

    let mut thresholds = Vec::with_capacity(plan.doors.len());
    for door in &plan.doors {
        let wall = &plan.walls[door.wall as usize];
        let room0 = &plan.rooms[wall.rooms[0].expect("a door's wall has a room") as usize];
        let frame = WallFrame::new(wall, normal_away_from(wall, room0));
        let offset = (door.center.truncate() - wall.a).length();
        let half = 0.5 * door.width_m - THRESHOLD_END_INSET_M;
        let height = rng.random_range(THRESHOLD_HEIGHT_M.0..=THRESHOLD_HEIGHT_M.1);
        let mut pb = PrimBuilder::default();
        frame.local_box(&mut pb, (offset - half, offset + half), (-0.5 * t, 0.5 * t), (0.0, height));
        let (min, max) = pb.bounds();
        let id = thresholds.len() as u32;
        push_node(geometry, format!("threshold_{id}"), vec![pb.build(gold)], Semantic::Threshold { id });
        thresholds.push(Threshold { id, door: door.id, instance_id: id + 1, min, max });
    }
    Ok(thresholds)
}

fn pick<'a>(rng: &mut ChaCha8Rng, list: &'a [String]) -> &'a str {
    if list.is_empty() { "paint" } else { &list[rng.random_range(0..list.len())] }
}

fn push_node(geometry: &mut Geometry, name: String, primitives: Vec<Primitive>, semantic: Semantic) {
    geometry.push_placed(Mesh { name, primitives }, Mat4::IDENTITY, semantic);
}

/// A wall's own coordinates: `s` along the centre line from `a`, `w` across it (positive away
/// from `rooms[0]`), `z` up.
struct WallFrame {
    origin: Vec2,
    along: Vec2,
    across: Vec2,
}

impl WallFrame {
    fn new(wall: &Wall, across: Vec2) -> WallFrame {
        WallFrame { origin: wall.a, along: (wall.b - wall.a).normalize(), across }
    }

    fn world(&self, s: f32, w: f32, z: f32) -> Vec3 {
        (self.origin + self.along * s + self.across * w).extend(z)
    }

    /// Face at `s` = const, spanning `w` and `z` ranges, with `normal_sign` x along.
    fn face_s(&self, pb: &mut PrimBuilder, s: f32, w: (f32, f32), z: (f32, f32), normal_sign: f32) {
        let c = [self.world(s, w.0, z.0), self.world(s, w.1, z.0), self.world(s, w.1, z.1), self.world(s, w.0, z.1)];
        pb.quad(c, (self.along * normal_sign).extend(0.0));
    }

    /// Face at `w` = const.
    fn face_w(&self, pb: &mut PrimBuilder, w: f32, s: (f32, f32), z: (f32, f32), normal_sign: f32) {
        let c = [self.world(s.0, w, z.0), self.world(s.1, w, z.0), self.world(s.1, w, z.1), self.world(s.0, w, z.1)];
        pb.quad(c, (self.across * normal_sign).extend(0.0));
    }

    /// Face at `z` = const.
    fn face_z(&self, pb: &mut PrimBuilder, z: f32, s: (f32, f32), w: (f32, f32), normal_sign: f32) {
        let c = [self.world(s.0, w.0, z), self.world(s.1, w.0, z), self.world(s.1, w.1, z), self.world(s.0, w.1, z)];
        pb.quad(c, Vec3::Z * normal_sign);
    }

    /// A closed box in wall coordinates.
    fn local_box(&self, pb: &mut PrimBuilder, s: (f32, f32), w: (f32, f32), z: (f32, f32)) {
        self.face_s(pb, s.0, w, z, -1.0);
        self.face_s(pb, s.1, w, z, 1.0);
        self.face_w(pb, w.0, s, z, -1.0);
        self.face_w(pb, w.1, s, z, 1.0);
        self.face_z(pb, z.0, s, w, -1.0);
        self.face_z(pb, z.1, s, w, 1.0);
    }
}

/// How far a wall box reaches past one end of its centre-line segment, and whether that end
/// needs a cap face.
///
/// Walls along X fill the square where centre lines cross (reach `+t/2`, capped) unless a
/// collinear wall continues (they butt at the point); walls along Y stop at the face of any
/// wall along X there (reach `-t/2`), butt against a collinear one, and are capped at a free
/// end. So every junction square is filled exactly once.
fn end_extension(wall: &Wall, end: Vec2, walls: &[Wall]) -> (f32, bool) {
    let half = 0.5 * wall.thickness_m;
    let along_x = (wall.b - wall.a).x.abs() > (wall.b - wall.a).y.abs();
    let mut collinear = false;
    let mut crossing_x = false;
    for other in walls.iter().filter(|o| o.id != wall.id) {
        if !on_segment(end, other.a, other.b) {
            continue;
        }
        let other_x = (other.b - other.a).x.abs() > (other.b - other.a).y.abs();
        if other_x == along_x {
            collinear = true;
        } else if other_x {
            crossing_x = true;
        }
    }
    if along_x {
        if collinear { (0.0, false) } else { (half, true) }
    } else if crossing_x {
        (-half, false)
    } else if collinear {
        (0.0, false)
    } else {
        (half, true)
    }
}

fn on_segment(p: Vec2, a: Vec2, b: Vec2) -> bool {
    let eps = 1e-4;
    let (lo, hi) = (a.min(b), a.max(b));
    p.x >= lo.x - eps && p.x <= hi.x + eps && p.y >= lo.y - eps && p.y <= hi.y + eps
}

/// The faces of one wall: those on the `rooms[0]` side (with top, bottom, caps and reveals) and
/// those on the other side.
fn wall_mesh(wall: &Wall, frame: &WallFrame, walls: &[Wall]) -> (PrimBuilder, PrimBuilder) {
    let len = wall.length_m();
    let h = wall.height_m;
    let half = 0.5 * wall.thickness_m;
    let (ext_a, cap_a) = end_extension(wall, wall.a, walls);
    let (ext_b, cap_b) = end_extension(wall, wall.b, walls);
    let (s0, s1) = (-ext_a, len + ext_b);
    let w = (-half, half);
    let mut side0 = PrimBuilder::default();
    let mut side1 = PrimBuilder::default();

    // Columns between opening edges; each column is solid or lies inside one opening.
    let mut cuts = vec![s0, s1];
    for o in &wall.openings {
        cuts.push(o.offset_m - 0.5 * o.width_m);
        cuts.push(o.offset_m + 0.5 * o.width_m);
    }
    cuts.sort_by(f32::total_cmp);
    cuts.dedup();
    for pair in cuts.windows(2) {
        let (u0, u1) = (pair[0], pair[1]);
        let mid = 0.5 * (u0 + u1);
        let hole = wall.openings.iter().find(|o| (mid - o.offset_m).abs() < 0.5 * o.width_m);
        let spans: Vec<(f32, f32)> = match hole {
            None => vec![(0.0, h)],
            Some(o) => vec![(0.0, o.sill_m), (o.sill_m + o.height_m, h)],
        };
        for (z0, z1) in spans.into_iter().filter(|(z0, z1)| z1 - z0 > 1e-5) {
            frame.face_w(&mut side0, w.0, (u0, u1), (z0, z1), -1.0);
            frame.face_w(&mut side1, w.1, (u0, u1), (z0, z1), 1.0);
        }
    }
    frame.face_z(&mut side0, h, (s0, s1), w, 1.0);
    // The bottom face stops at door openings, which reach the floor.
    let mut bottom_from = s0;
    for o in wall.openings.iter().filter(|o| o.sill_m <= 1e-5) {
        frame.face_z(&mut side0, 0.0, (bottom_from, o.offset_m - 0.5 * o.width_m), w, -1.0);
        bottom_from = o.offset_m + 0.5 * o.width_m;
    }
    frame.face_z(&mut side0, 0.0, (bottom_from, s1), w, -1.0);
    if cap_a {
        frame.face_s(&mut side0, s0, w, (0.0, h), -1.0);
    }
    if cap_b {
        frame.face_s(&mut side0, s1, w, (0.0, h), 1.0);
    }
    // Reveals: the faces of each hole through the wall, normals pointing into the hole.
    for o in &wall.openings {
        let (o0, o1) = (o.offset_m - 0.5 * o.width_m, o.offset_m + 0.5 * o.width_m);
        let z = (o.sill_m, o.sill_m + o.height_m);
        frame.face_s(&mut side0, o0, w, z, 1.0);
        frame.face_s(&mut side0, o1, w, z, -1.0);
        if o.sill_m > 1e-5 {
            frame.face_z(&mut side0, z.0, (o0, o1), w, 1.0);
        }
        frame.face_z(&mut side0, z.1, (o0, o1), w, -1.0);
    }
    (side0, side1)
}

/// Collects one primitive's vertices, with metre UVs.
#[derive(Default)]
struct PrimBuilder {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    indices: Vec<u32>,
}

impl PrimBuilder {
    /// A planar quad; wound counter-clockwise as seen from `normal` whatever the corner order.
    /// Degenerate quads are dropped.
    fn quad(&mut self, mut corners: [Vec3; 4], normal: Vec3) {
        let area = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        if area.length() < 1e-8 {
            return;
        }
        if area.dot(normal) < 0.0 {
            corners.reverse();
        }
        let base = self.positions.len() as u32;
        for p in corners {
            self.positions.push(p);
            self.normals.push(normal);
            self.uvs.push(metre_uv(p, normal));
        }
        self.indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }

    fn append(&mut self, other: PrimBuilder) {
        let base = self.positions.len() as u32;
        self.positions.extend(other.positions);
        self.normals.extend(other.normals);
        self.uvs.extend(other.uvs);
        self.indices.extend(other.indices.into_iter().map(|i| i + base));
    }

    fn bounds(&self) -> (Vec3, Vec3) {
        let min = self.positions.iter().fold(Vec3::splat(f32::INFINITY), |m, &p| m.min(p));
        let max = self.positions.iter().fold(Vec3::splat(f32::NEG_INFINITY), |m, &p| m.max(p));
        (min, max)
    }

    fn build(self, material: usize) -> Primitive {
        Primitive { positions: self.positions, normals: self.normals, uvs: self.uvs, indices: self.indices, material }
    }
}

/// Texture coordinates in metres, projected along the face's dominant axis; `v` grows
/// downwards on walls (glTF puts (0, 0) at the top-left of the image).
fn metre_uv(p: Vec3, normal: Vec3) -> Vec2 {
    let a = normal.abs();
    if a.z >= a.x && a.z >= a.y {
        Vec2::new(p.x, -p.y)
    } else if a.x >= a.y {
        Vec2::new(p.y, -p.z)
    } else {
        Vec2::new(p.x, -p.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Room;

    fn wall(id: u32, a: Vec2, b: Vec2) -> Wall {
        Wall { id, a, b, thickness_m: 0.2, height_m: 3.0, rooms: [Some(0), None], openings: Vec::new() }
    }

    #[test]
    fn corners_are_owned_by_walls_along_x() {
        // A 4 x 3 room: walls along X fill the corner squares, walls along Y stop at them.
        let walls = [
            wall(0, Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0)),
            wall(1, Vec2::new(4.0, 0.0), Vec2::new(4.0, 3.0)),
            wall(2, Vec2::new(0.0, 3.0), Vec2::new(4.0, 3.0)),
            wall(3, Vec2::new(0.0, 0.0), Vec2::new(0.0, 3.0)),
        ];
        assert_eq!(end_extension(&walls[0], walls[0].a, &walls), (0.1, true));
        assert_eq!(end_extension(&walls[1], walls[1].a, &walls), (-0.1, false));
        // A collinear continuation butts at the point.
        let mut more = walls.to_vec();
        more.push(wall(4, Vec2::new(4.0, 0.0), Vec2::new(8.0, 0.0)));
        assert_eq!(end_extension(&more[0], more[0].b, &more), (0.0, false));
    }

    #[test]
    fn one_room_house_is_closed_with_a_threshold() {
        let room = Room { id: 0, room_type: "t".into(), min: Vec2::ZERO, max: Vec2::new(4.0, 3.0) };
        let mut walls = vec![
            wall(0, Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0)),
            wall(1, Vec2::new(4.0, 0.0), Vec2::new(4.0, 3.0)),
            wall(2, Vec2::new(0.0, 3.0), Vec2::new(4.0, 3.0)),
            wall(3, Vec2::new(0.0, 0.0), Vec2::new(0.0, 3.0)),
        ];
        walls[0].openings.push(crate::scene::Opening {
            kind: OpeningKind::Door,
            id: 0,
            offset_m: 2.0,
            width_m: 0.9,
            sill_m: 0.0,
            height_m: 2.0,
        });
        let door = crate::scene::Door {
            id: 0,
            rooms: [Some(0), None],
            wall: 0,
            center: Vec3::new(2.0, 0.0, 1.0),
            width_m: 0.9,
            height_m: 2.0,
            normal: Vec2::NEG_Y,
            leaf: None,
        };
        let plan = Floorplan { rooms: vec![room], walls, doors: vec![door], windows: Vec::new() };
        let rt = RoomType {
            name: "t".into(),
            label: "T".into(),
            weight: 1.0,
            floor: vec!["wood_floor".into()],
            walls: vec!["paint".into()],
            furniture: Vec::new(),
            rules: Default::default(),
        };
        let config = GeneratorConfig { wall_thickness_m: 0.2, ..GeneratorConfig::default() };
        let mut geometry = Geometry::default();
        let thresholds =
            build(&config, &plan, &[rt], &mut MaterialCatalog::new(0), &mut geometry).expect("known surfaces");
        assert_eq!(thresholds.len(), 1);
        let th = &thresholds[0];
        assert!((th.min.x - 1.552).abs() < 1e-4 && (th.max.x - 2.448).abs() < 1e-4, "{th:?}");
        assert!((th.min.y + 0.1).abs() < 1e-5 && (th.max.y - 0.1).abs() < 1e-5 && th.min.z == 0.0);
        // The door wall's faces enclose its volume: 4.2 m (with both corner squares) x 0.2 m x
        // 3 m, less the 0.9 m x 0.2 m x 2 m door hole (divergence theorem on the faces).
        let node = geometry.nodes.iter().find(|n| n.semantic == Semantic::Wall { wall: 0 }).unwrap();
        let mut volume = 0.0;
        for p in &geometry.meshes[node.mesh].primitives {
            for t in p.indices.chunks(3) {
                let [a, b, c] = [0, 1, 2].map(|k| p.positions[t[k] as usize]);
                volume += a.dot(b.cross(c)) / 6.0;
            }
        }
        assert!((volume - (4.2 * 0.2 * 3.0 - 0.9 * 0.2 * 2.0)).abs() < 1e-3, "{volume}");
    }
}
