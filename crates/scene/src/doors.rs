//! Door leaves: every door's leaf stands open into one of its rooms.
//!
//! A leaf hangs on a vertical hinge at one jamb, just off the wall face of the room it opens
//! into, and stands open at a seeded angle between 90 degrees (square to the wall) and as far
//! as it can swing: the swing stops before the leaf or its handles would meet a wall, a piece
//! of furniture, another door's clearance or another leaf. Open 90 degrees or more, a leaf
//! narrows its doorway by half its thickness at most, so the doorway and its threshold stay
//! passable: the agent walks through the middle of the doorway, and the
//! [`trajectory`] keeps clear of leaves as it does of furniture.
//!
//! A leaf swung wide can still close the way past it: stood out from the wall between its
//! doorway and a table, it can leave less than the agent's width where furniture left a
//! walkway. So a leaf must also keep its room passable (`Passage`): an agent of the walk's
//! radius that could go from each of the room's doorways to the others, and over the room's
//! floor, still can. Where the drawn angle fails, the leaf closes in steps towards 90 degrees,
//! then tries its other jamb and the other room.
//!
//! Leaves are hung after furniture placement (they fit around what is there) and before decor
//! (pictures keep clear of them). All the doors of a house share one finish, as a real
//! house's do.

use glam::{Mat4, Vec2, Vec3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::config::GeneratorConfig;
use crate::floor_grid::FloorGrid;
use crate::floorplan::Floorplan;
use crate::materials::{MaterialCatalog, VARIANTS};
use crate::placement::{self, Rect};
use crate::procedural::builder::MeshBuilder;
use crate::scene::{Door, DoorLeaf, Geometry, OpeningKind, Room, Semantic};
use crate::trajectory;

/// Leaf thickness (interior doors are 35-44 mm).
const THICKNESS_M: f32 = 0.04;
/// Gap between the leaf's edge and each jamb, and below the head, when it is shut.
const EDGE_GAP_M: f32 = 0.004;
/// Gap between the hinge side of the leaf and the wall face.
const HINGE_OFFSET_M: f32 = 0.003;
/// How far the lever handles stand off each face; the swing test pads the leaf by this much.
const HANDLE_REACH_M: f32 = 0.06;
/// Length of the stretch of a leaf, back from its free edge, that its handles span.
const HANDLE_SPAN_M: f32 = 0.18;
/// Handle height above the floor (EN 1906 lever handles: 0.9-1.05 m; 1.0 m typical).
const HANDLE_HEIGHT_M: f32 = 1.0;
/// The widest a leaf opens; 180 degrees would press the handle into the wall.
const MAX_OPEN_DEG: f32 = 175.0;
/// Step of the swing test, degrees.
const SWING_STEP_DEG: f32 = 5.0;
/// Radius of the agent a leaf must leave room for: the walk's own.
const PASSAGE_RADIUS_M: f32 = trajectory::NOMINAL_RADIUS_M;
/// Grid step of the passage test.
const PASSAGE_CELL_M: f32 = 0.1;
/// Finishes a house's doors take, one per house.
const FINISHES: [&str; 2] = ["wood", "paint"];

/// Hangs a leaf in every door that has room for one and adds their meshes and nodes to
/// `geometry`; `furniture` are the world boxes (min, max) of the placed objects and
/// furnishings. Returns one entry per door, in door order.
pub fn build(
    config: &GeneratorConfig,
    plan: &Floorplan,
    furniture: &[(Vec3, Vec3)],
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) -> Vec<Option<DoorLeaf>> {
    let mut rng = scene_gen_core::rng::stream(config.seed, "door_leaves");
    let finish = FINISHES[rng.random_range(0..FINISHES.len())];
    let variant = rng.random_range(0..VARIANTS);
    let furniture: Vec<Rect> =
        furniture.iter().map(|(min, max)| Rect { min: min.truncate(), max: max.truncate() }).collect();
    let mut leaves: Vec<Option<DoorLeaf>> = Vec::with_capacity(plan.doors.len());
    for door in &plan.doors {
        let hung: Vec<[Vec2; 4]> = leaves.iter().flatten().flat_map(solids).collect();
        let room_obstacles =
            |room: &Room| RoomObstacles::new(door, room, plan, &furniture, &hung, config.wall_thickness_m);
        let leaf = hang(door, plan, room_obstacles, config.wall_thickness_m, &mut rng);
        if let Some(leaf) = &leaf {
            add_mesh(door, leaf, finish, variant, materials, geometry);
        }
        leaves.push(leaf);
    }
    leaves
}

/// The world box of a leaf and its handles.
#[must_use]
pub fn bounds(leaf: &DoorLeaf) -> (Vec3, Vec3) {
    let footprint = leaf.footprint(HANDLE_REACH_M);
    let lo = footprint.iter().fold(Vec2::MAX, |m, p| m.min(*p));
    let hi = footprint.iter().fold(Vec2::MIN, |m, p| m.max(*p));
    (lo.extend(0.0), hi.extend(leaf.height_m))
}

/// What a leaf opening into one room must keep clear of.
struct RoomObstacles {
    /// The room's interior.
    lo: Vec2,
    hi: Vec2,
    /// Furniture footprints and the clearances of the room's other doors.
    rects: Vec<Rect>,
    /// The solids of the leaves hung already.
    hung: Vec<[Vec2; 4]>,
    /// Where the agent can walk in the room before this leaf is hung.
    passage: Passage,
}

impl RoomObstacles {
    fn new(
        door: &Door,
        room: &Room,
        plan: &Floorplan,
        furniture: &[Rect],
        hung: &[[Vec2; 4]],
        wall_thickness_m: f32,
    ) -> RoomObstacles {
        let (lo, hi) = room.interior(wall_thickness_m);
        let clearances = plan
            .doors
            .iter()
            .filter(|d| d.id != door.id)
            .filter_map(|d| placement::door_clearance(d, room.id, wall_thickness_m));
        let entries: Vec<Vec2> = plan
            .doors
            .iter()
            .filter_map(|d| placement::door_entry(d, room.id, wall_thickness_m, PASSAGE_RADIUS_M))
            .collect();
        let passage = Passage::new(lo, hi, furniture, hung, &entries);
        RoomObstacles {
            lo,
            hi,
            rects: furniture.iter().copied().chain(clearances).collect(),
            hung: hung.to_vec(),
            passage,
        }
    }

    /// Whether `leaf` and its handles stand inside the room, clear of everything.
    fn admit(&self, leaf: &DoorLeaf) -> bool {
        solids(leaf).iter().all(|solid| {
            solid.iter().all(|p| p.cmpge(self.lo - 1e-4).all() && p.cmple(self.hi + 1e-4).all())
                && !self.rects.iter().any(|r| overlaps(solid, r))
                && !self.hung.iter().any(|other| convex_overlap(solid, other))
        })
    }
}

/// The footprints of a leaf's slab and of the stretch near its free edge where the handles
/// stand off both faces.
fn solids(leaf: &DoorLeaf) -> [[Vec2; 4]; 2] {
    let slab = leaf.footprint(0.0);
    let across = leaf.direction.perp() * (0.5 * leaf.thickness_m + HANDLE_REACH_M);
    let (a, b) = (leaf.hinge + leaf.direction * (leaf.width_m - HANDLE_SPAN_M), leaf.free_edge());
    [slab, [a - across, b - across, b + across, a + across]]
}

/// The leaf of `door`: the first (room, hinge side) of a seeded order in which it can stand
/// square to the wall, opened a seeded fraction of the way to where its swing stops.
fn hang(
    door: &Door,
    plan: &Floorplan,
    obstacles_in: impl Fn(&Room) -> RoomObstacles,
    wall_thickness_m: f32,
    rng: &mut ChaCha8Rng,
) -> Option<DoorLeaf> {
    let first_room = rng.random_range(0..2usize);
    let first_side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let opening = rng.random::<f32>();
    let rooms = [door.rooms[first_room], door.rooms[1 - first_room]];
    for room_id in rooms.into_iter().flatten() {
        let room = plan.rooms.iter().find(|r| r.id == room_id)?;
        let obstacles = obstacles_in(room);
        for side in [first_side, -first_side] {
            let at = |open_deg: f32| leaf_at(door, room_id, side, open_deg, wall_thickness_m);
            if !obstacles.admit(&at(90.0)) {
                continue;
            }
            let mut widest = 90.0;
            while widest + SWING_STEP_DEG <= MAX_OPEN_DEG && obstacles.admit(&at(widest + SWING_STEP_DEG)) {
                widest += SWING_STEP_DEG;
            }
            // The swing was tested in steps: an angle between two steps may still graze a
            // corner that pokes in between them, and then the leaf stops at the step before.
            let open_deg = 90.0 + opening * (widest - 90.0);
            let drawn = at(open_deg);
            let below = ((open_deg - 90.0) / SWING_STEP_DEG).floor() as i32;
            let drawn = obstacles.admit(&drawn).then_some(drawn);
            // Then closing towards 90 degrees a step at a time, until the room stays passable.
            let closing = (0..=below).rev().map(|step| at(90.0 + step as f32 * SWING_STEP_DEG));
            if let Some(leaf) = drawn.into_iter().chain(closing).find(|l| obstacles.passage.keeps(&solids(l))) {
                return Some(leaf);
            }
        }
    }
    None
}

/// The floor of one room on a [`PASSAGE_CELL_M`] grid: cells where an agent of
/// [`PASSAGE_RADIUS_M`] stands clear of the walls, the furniture and the leaves hung already,
/// and the cells just inside each of the room's doorways.
struct Passage {
    grid: FloorGrid,
    blocked: Vec<bool>,
    entries: Vec<usize>,
    /// Component of each entry's cell (`usize::MAX`: none) and the cells the entries reach.
    components: Vec<usize>,
    reached: usize,
}

impl Passage {
    fn new(lo: Vec2, hi: Vec2, furniture: &[Rect], hung: &[[Vec2; 4]], entries: &[Vec2]) -> Passage {
        let grid = FloorGrid::covering(lo, hi - lo, PASSAGE_CELL_M);
        let r = PASSAGE_RADIUS_M;
        let mut blocked: Vec<bool> = (0..grid.len())
            .map(|k| {
                let c = grid.centre(k);
                c.x < lo.x + r || c.x > hi.x - r || c.y < lo.y + r || c.y > hi.y - r
            })
            .collect();
        let mut p = Passage { grid, blocked: Vec::new(), entries: Vec::new(), components: Vec::new(), reached: 0 };
        let rects: Vec<[Vec2; 4]> = furniture
            .iter()
            .filter(|f| f.max.cmpgt(lo).all() && f.min.cmplt(hi).all())
            .map(|f| [f.min, Vec2::new(f.max.x, f.min.y), f.max, Vec2::new(f.min.x, f.max.y)])
            .collect();
        for solid in rects.iter().chain(hung) {
            p.mark(solid, &mut blocked);
        }
        // The agent squeezes through a doorway set close to a corner (as placement assumes).
        p.entries = entries.iter().filter(|e| e.cmpge(lo).all() && e.cmple(hi).all()).map(|&e| grid.cell(e)).collect();
        for &e in &p.entries {
            blocked[e] = false;
        }
        p.blocked = blocked;
        (p.components, p.reached) = p.flood(&p.blocked);
        p
    }

    /// Blocks the cells where the agent's square (half side [`PASSAGE_RADIUS_M`], which holds
    /// its disc) would overlap `solid`.
    fn mark(&self, solid: &[Vec2; 4], blocked: &mut [bool]) {
        let r = Vec2::splat(PASSAGE_RADIUS_M);
        let lo = solid.iter().fold(Vec2::MAX, |m, p| m.min(*p)) - r;
        let hi = solid.iter().fold(Vec2::MIN, |m, p| m.max(*p)) + r;
        let g = &self.grid;
        let (a, b) = (g.cell(lo), g.cell(hi));
        for y in a / g.width..=b / g.width {
            for x in a % g.width..=b % g.width {
                let k = x + y * g.width;
                let c = g.centre(k);
                let square = [c - r, Vec2::new(c.x + r.x, c.y - r.y), c + r, Vec2::new(c.x - r.x, c.y + r.y)];
                if convex_overlap(solid, &square) {
                    blocked[k] = true;
                }
            }
        }
    }

    /// The component of each entry (`usize::MAX` where its cell is blocked) and how many
    /// cells the entries reach together.
    fn flood(&self, blocked: &[bool]) -> (Vec<usize>, usize) {
        let fill = self.grid.flood(blocked, &self.entries);
        (self.entries.iter().map(|&e| fill.label[e]).collect(), fill.reached)
    }

    /// Whether the room stays passable with `solids` added: doorways joined before stay
    /// joined, and the doorways reach at least half the floor they reached before.
    fn keeps(&self, solids: &[[Vec2; 4]]) -> bool {
        let mut blocked = self.blocked.clone();
        for solid in solids {
            self.mark(solid, &mut blocked);
        }
        let (after, reached) = self.flood(&blocked);
        let n = self.entries.len();
        let joined = |c: &[usize], i: usize, j: usize| c[i] != usize::MAX && c[i] == c[j];
        let kept = (0..n).all(|i| (i + 1..n).all(|j| !joined(&self.components, i, j) || joined(&after, i, j)));
        kept && 2 * reached >= self.reached
    }
}

/// The leaf of `door` opening into `room` with its hinge on the jamb at `side` (+1: the
/// jamb along the wall's tangent, -1: the other), `open_deg` from shut.
fn leaf_at(door: &Door, room: u32, side: f32, open_deg: f32, wall_thickness_m: f32) -> DoorLeaf {
    let inward = door.inward(room).expect("a leaf opens into one of its door's rooms");
    let tangent = inward.perp();
    let hinge = door.center.truncate()
        + tangent * (side * 0.5 * door.width_m)
        + inward * (0.5 * wall_thickness_m + HINGE_OFFSET_M + 0.5 * THICKNESS_M);
    let (sin, cos) = open_deg.to_radians().sin_cos();
    // Shut, the leaf runs from the hinge across the opening; it turns into the room.
    let shut = -tangent * side;
    DoorLeaf {
        room,
        hinge,
        direction: (shut * cos + inward * sin).normalize(),
        open_deg,
        width_m: door.width_m - 2.0 * EDGE_GAP_M,
        thickness_m: THICKNESS_M,
        height_m: door.height_m - EDGE_GAP_M,
    }
}

/// Adds the leaf's mesh (slab and a lever handle on each face) and its node.
fn add_mesh(
    door: &Door,
    leaf: &DoorLeaf,
    finish: &'static str,
    variant: u32,
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) {
    // Leaf frame: x from the hinge to the free edge, y across, z up from the floor.
    let mut b = MeshBuilder::default();
    let (w, t) = (leaf.width_m, leaf.thickness_m);
    let slab_h = leaf.height_m - DoorLeaf::UNDERCUT_M;
    b.box_in(
        finish,
        Mat4::from_translation(Vec3::new(0.5 * w, 0.0, DoorLeaf::UNDERCUT_M + 0.5 * slab_h)),
        Vec3::new(w, t, slab_h),
    );
    for face in [-1.0_f32, 1.0] {
        let stem = Vec3::new(w - 0.06, face * (0.5 * t + 0.5 * HANDLE_REACH_M), HANDLE_HEIGHT_M);
        b.box_in("metal", Mat4::from_translation(stem), Vec3::new(0.02, HANDLE_REACH_M, 0.02));
        let lever = Vec3::new(w - 0.11, face * (0.5 * t + HANDLE_REACH_M - 0.01), HANDLE_HEIGHT_M);
        b.box_in("metal", Mat4::from_translation(lever), Vec3::new(0.12, 0.02, 0.02));
    }
    let name = format!("door_leaf_{}", door.id);
    let mesh = b.into_asset_mesh().to_mesh(&name, |surface| {
        materials.material(geometry, surface, variant).expect("door finishes are known surfaces")
    });
    let yaw = leaf.direction.y.atan2(leaf.direction.x);
    geometry.push_placed(
        mesh,
        Mat4::from_translation(leaf.hinge.extend(0.0)) * Mat4::from_rotation_z(yaw),
        Semantic::Opening { kind: OpeningKind::Door, id: door.id },
    );
}

/// Whether a convex quadrilateral and a rectangle overlap (more than touching).
fn overlaps(quad: &[Vec2; 4], rect: &Rect) -> bool {
    let corners = [rect.min, Vec2::new(rect.max.x, rect.min.y), rect.max, Vec2::new(rect.min.x, rect.max.y)];
    convex_overlap(quad, &corners)
}

/// Separating-axis test for two convex polygons (corners in order): they overlap unless the
/// edge normal of one of them separates them.
fn convex_overlap(a: &[Vec2], b: &[Vec2]) -> bool {
    const EPS: f32 = 1e-4;
    let separated_by = |poly: &[Vec2]| {
        (0..poly.len()).any(|i| {
            let axis = (poly[(i + 1) % poly.len()] - poly[i]).perp();
            let project = |q: &[Vec2]| {
                q.iter()
                    .map(|p| p.dot(axis))
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)))
            };
            let ((a0, a1), (b0, b1)) = (project(a), project(b));
            let scale = axis.length().max(f32::MIN_POSITIVE);
            a1 <= b0 + EPS * scale || b1 <= a0 + EPS * scale
        })
    };
    !(separated_by(a) || separated_by(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separating_axes_tell_touching_from_overlapping() {
        let square = [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y];
        let shifted = square.map(|p| p + Vec2::new(0.5, 0.5));
        let touching = square.map(|p| p + Vec2::X);
        // A diamond whose corner pokes into the square's corner region only past a diagonal.
        let diamond = [Vec2::new(1.5, 0.9), Vec2::new(2.1, 1.5), Vec2::new(1.5, 2.1), Vec2::new(0.9, 1.5)];
        assert!(convex_overlap(&square, &shifted));
        assert!(!convex_overlap(&square, &touching));
        assert!(!convex_overlap(&square, &diamond), "separated by the diamond's edge normal");
        assert!(convex_overlap(&square, &diamond.map(|p| p - Vec2::splat(0.3))));
    }

    /// A 4 x 3 m room with doorways at both ends of its lower wall and a table leaving a 1 m
    /// walkway along that wall: a slab across the walkway closes it, one beside it does not,
    /// and one that boxes in the only doorway of a room is refused too.
    #[test]
    fn a_passage_refuses_a_solid_that_closes_the_walkway() {
        let (lo, hi) = (Vec2::ZERO, Vec2::new(4.0, 3.0));
        let table = Rect { min: Vec2::new(0.0, 1.0), max: Vec2::new(3.0, 3.0) };
        let entries = [Vec2::new(0.5, 0.35), Vec2::new(3.5, 0.35)];
        let passage = Passage::new(lo, hi, &[table], &[], &entries);
        assert_eq!(passage.components[0], passage.components[1], "the walkway joins the doorways");
        let slab = |a: Vec2, b: Vec2| [a, Vec2::new(b.x, a.y), b, Vec2::new(a.x, b.y)];
        let across = slab(Vec2::new(2.0, 0.0), Vec2::new(2.04, 0.95));
        assert!(!passage.keeps(&[across]), "0.05 m left under the slab's end");
        let short = slab(Vec2::new(2.0, 0.0), Vec2::new(2.04, 0.3));
        assert!(passage.keeps(&[short]), "0.7 m left beside a short slab");
        // One doorway, and a box of slabs around it: the floor is out of reach.
        let single = Passage::new(lo, hi, &[], &[], &entries[..1]);
        let pen = [slab(Vec2::new(1.2, 0.0), Vec2::new(1.24, 1.3)), slab(Vec2::new(0.0, 1.26), Vec2::new(1.24, 1.3))];
        assert!(!single.keeps(&pen));
        assert!(single.keeps(&pen[..1]));
    }

    #[test]
    fn a_leaf_at_90_degrees_stands_square_to_the_wall_beside_its_jamb() {
        let door = Door {
            id: 0,
            rooms: [Some(0), Some(1)],
            wall: 0,
            center: Vec3::new(2.0, 0.0, 1.0),
            width_m: 0.9,
            height_m: 2.0,
            normal: Vec2::Y,
            leaf: None,
        };
        // Into room 1 (the +Y side), hinged on the jamb at +X (side -1: the tangent is -X).
        let leaf = leaf_at(&door, 1, -1.0, 90.0, 0.1);
        assert!((leaf.direction - Vec2::Y).length() < 1e-6);
        assert!((leaf.hinge.x - 2.45).abs() < 1e-6 && leaf.hinge.y > 0.05);
        // The doorway loses at most half the leaf's thickness.
        let narrowest = leaf.footprint(0.0).iter().map(|p| p.x).fold(f32::INFINITY, f32::min);
        assert!(narrowest >= 2.45 - 0.5 * THICKNESS_M - 1e-6);
        // At 180 degrees it lies back against the wall face, on the room's side.
        let back = leaf_at(&door, 1, -1.0, 180.0, 0.1);
        assert!((back.direction - Vec2::X).length() < 1e-6);
        assert!(back.footprint(0.0).iter().all(|p| p.y >= 0.05));
        // Into room 0 the leaf turns the other way.
        assert!((leaf_at(&door, 0, 1.0, 90.0, 0.1).direction + Vec2::Y).length() < 1e-6);
    }
}
