//! Which lights can reach which room: portal visibility over the floorplan.
//!
//! A shading point in a house sees a few of its lights: those of its own room and those whose
//! light comes in through a door. [`super::LightSet::direct`] used to weigh every light of the
//! house at every point and trace shadow rays to the ones its roulette picked, and about two
//! thirds of those rays were blocked, most of them by the walls between rooms
//! (docs/BENCHMARKS.md). A [`LightReach`] lists, per room, the lights that can reach some point
//! of it; a point inside a room considers only those.
//!
//! The lists are conservative: a light is left out of a room's list only when no straight line
//! from it can enter the room, so no light that could reach a point is ever dropped, and the
//! estimate keeps its expectation. The argument, in the top view of the floorplan:
//!
//! * the rooms are rectangles that tile the envelope, closed on every side by walls that are
//!   solid from the floor to the ceiling except where an opening is cut ([`closed_floorplan`]
//!   checks all of this and leaves every light everywhere when it does not hold);
//! * the envelope is convex, so a segment between two points inside it never leaves it: light
//!   passes from room to room only through the openings of interior walls, the *portals*;
//! * rooms are convex, so a line that enters a room through one portal leaves it through at most
//!   one other, and the rooms a line visits form a simple path of portals. A light in room `Q`
//!   reaches room `R` only if some line meets the light (a point, or the footprint of a rect
//!   light) and every portal of a path from `Q` to `R`. In 2D that is a line-stabbing problem:
//!   if any line stabs a family of convex sets, one through two of their vertices does
//!   ([`stabbable`]; Teller and Séquin, "Visibility preprocessing for interactive
//!   walkthroughs", SIGGRAPH 1991, use the same extreme-line argument in 3D).
//!
//! Heights (door lintels, window sills) and wall thickness are ignored, and every portal is
//! widened by [`PORTAL_MARGIN_M`]: each only keeps more lights in a list. The sun is not listed
//! here: it is always traced ([`super::LightSet::direct`] says why). A point outside every
//! room's interior (in a doorway, on a window frame, inside a wall) considers every light.

use glam::{Vec2, Vec3};

use scene_gen_scene::scene::Scene;
use scene_gen_trace::lanes::{Lanes, N};

/// How far each portal is widened at both ends, metres: far above the rounding of the plan's
/// coordinates, and it can only add lights to a list.
pub const PORTAL_MARGIN_M: f32 = 0.01;
/// How far a room's interior box is grown to hold the shading points on its own wall faces,
/// metres; well under half a wall, so a point in a wall or a doorway belongs to no room.
const INTERIOR_MARGIN_M: f32 = 1e-3;
/// Tolerance of the floorplan checks, metres.
const PLAN_TOLERANCE_M: f32 = 1e-3;
/// Distance within which a vertex counts as on a candidate line, metres (generous: it can only
/// keep a light).
const STAB_TOLERANCE_M: f32 = 1e-4;
/// Rooms a visibility search handles (a bit set of visited rooms); a larger plan keeps every
/// light everywhere.
const MAX_ROOMS: usize = 64;

/// Where a light shines from, in the top view: the point light's position, or the corners of a
/// rect light; with the room the scene puts it in.
#[derive(Clone, Debug)]
pub(crate) struct LightSource {
    pub room: Option<u32>,
    pub footprint: Vec<Vec2>,
}

/// Per room, the point and rect lights (indices into a [`super::LightSet`]'s lists) that can
/// reach some point of it; every light for points in no room.
#[derive(Clone, Debug, Default)]
pub(crate) struct LightReach {
    rooms: Vec<RoomLights>,
    everywhere: Lists,
}

/// Indices of point lights and of rect lights, ascending.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Lists {
    pub points: Vec<u32>,
    pub rects: Vec<u32>,
}

/// A room's interior box (grown by [`INTERIOR_MARGIN_M`]) and its lights.
#[derive(Clone, Debug)]
struct RoomLights {
    min: Vec2,
    max: Vec2,
    lights: Lists,
}

/// An opening in an interior wall: its centre-line segment (widened) and the rooms either side.
#[derive(Clone, Copy, Debug)]
struct Portal {
    a: Vec2,
    b: Vec2,
    rooms: [usize; 2],
}

impl LightReach {
    /// Every light everywhere: for scenes without a floorplan, or one that fails the checks.
    #[must_use]
    pub fn everywhere(points: usize, rects: usize) -> LightReach {
        LightReach { rooms: Vec::new(), everywhere: Lists::all(points, rects) }
    }

    /// The lists of `scene`'s rooms for the point lights `points` and rect lights `rects` (in
    /// [`super::LightSet`] order). A light whose room is unknown, or whose footprint is not in
    /// the room the scene gives it, is listed in every room.
    #[must_use]
    pub fn of_floorplan(scene: &Scene, points: &[LightSource], rects: &[LightSource]) -> LightReach {
        let everywhere = Lists::all(points.len(), rects.len());
        if !closed_floorplan(scene) {
            return LightReach { rooms: Vec::new(), everywhere };
        }
        let portals = portals(scene);
        let mut rooms: Vec<RoomLights> = scene
            .rooms
            .iter()
            .map(|room| {
                let (lo, hi) = room.interior(scene.wall_thickness_m);
                let grow = Vec2::splat(INTERIOR_MARGIN_M);
                RoomLights { min: lo - grow, max: hi + grow, lights: Lists::default() }
            })
            .collect();
        for (sources, is_rect) in [(points, false), (rects, true)] {
            for (i, source) in sources.iter().enumerate() {
                let reached = rooms_reached(scene, source, &portals);
                for (room, lights) in rooms.iter_mut().enumerate() {
                    if reached[room] {
                        let list = if is_rect { &mut lights.lights.rects } else { &mut lights.lights.points };
                        list.push(i as u32);
                    }
                }
            }
        }
        LightReach { rooms, everywhere }
    }

    /// The lights that may reach `point`: its room's, or every light outside every room.
    #[must_use]
    #[inline(always)]
    pub fn lights_at(&self, point: Vec3) -> &Lists {
        self.lists(self.room_of(point))
    }

    /// Which lists hold the lights that may reach `point`: the index of its room, or one past
    /// the last room for a point outside every room (for [`LightReach::lists`]).
    #[must_use]
    #[inline(always)]
    pub fn room_of(&self, point: Vec3) -> usize {
        // A loop over a handful of boxes; plain code for the AVX2 build of the tile loop.
        for (i, room) in self.rooms.iter().enumerate() {
            if point.x >= room.min.x && point.x <= room.max.x && point.y >= room.min.y && point.y <= room.max.y {
                return i;
            }
        }
        self.rooms.len()
    }

    /// [`LightReach::room_of`] of the points `(x[k], y[k], _)` of a packet's lanes, room by
    /// room over all lanes in vector loops ([`scene_gen_trace::lanes`]); the last room first, so where
    /// rooms overlap the first one wins, as in `room_of`.
    #[inline(always)]
    pub(crate) fn rooms_of(&self, x: &Lanes, y: &Lanes) -> [u32; N] {
        let mut room = [self.rooms.len() as u32; N];
        for (i, r) in self.rooms.iter().enumerate().rev() {
            for k in 0..N {
                let inside = (x[k] >= r.min.x) & (x[k] <= r.max.x) & (y[k] >= r.min.y) & (y[k] <= r.max.y);
                room[k] = if inside { i as u32 } else { room[k] };
            }
        }
        room
    }

    /// The lights of [`LightReach::room_of`]'s answer `room`.
    #[must_use]
    #[inline(always)]
    pub fn lists(&self, room: usize) -> &Lists {
        match self.rooms.get(room) {
            Some(r) => &r.lights,
            None => &self.everywhere,
        }
    }

    /// The lists of room `room`, if the floorplan passed the checks.
    #[cfg(test)]
    #[must_use]
    pub fn room_lights(&self, room: usize) -> Option<&Lists> {
        self.rooms.get(room).map(|r| &r.lights)
    }
}

impl Lists {
    fn all(points: usize, rects: usize) -> Lists {
        Lists { points: (0..points as u32).collect(), rects: (0..rects as u32).collect() }
    }
}

/// Per room of `scene`, whether light from `source` can enter it.
fn rooms_reached(scene: &Scene, source: &LightSource, portals: &[Portal]) -> Vec<bool> {
    let n = scene.rooms.len();
    let start = source.room.map(|r| r as usize).filter(|&r| r < n && footprint_in_room(scene, r, &source.footprint));
    let Some(start) = start else { return vec![true; n] };
    let mut reached = vec![false; n];
    reached[start] = true;
    // Depth-first over simple paths of portals, each path kept only while a line can stab the
    // source and all of its portals.
    let mut stack: Vec<(usize, Vec<usize>, u64)> = vec![(start, Vec::new(), 1 << start)];
    while let Some((room, path, visited)) = stack.pop() {
        for (p, portal) in portals.iter().enumerate() {
            let next = match portal.rooms {
                [a, b] if a == room => b,
                [a, b] if b == room => a,
                _ => continue,
            };
            if visited & (1 << next) != 0 {
                continue;
            }
            let mut objects: Vec<&[Vec2]> = vec![&source.footprint];
            let segments: Vec<[Vec2; 2]> = path.iter().chain([&p]).map(|&q| [portals[q].a, portals[q].b]).collect();
            objects.extend(segments.iter().map(|s| s.as_slice()));
            if stabbable(&objects) {
                reached[next] = true;
                let mut longer = path.clone();
                longer.push(p);
                stack.push((next, longer, visited | 1 << next));
            }
        }
    }
    reached
}

/// Whether one straight line meets every convex set of `objects` (each given by its vertices:
/// a point, a segment's ends, a polygon's corners).
///
/// If some line does, a line through two of the vertices does too: slide it sideways until it
/// touches a vertex, then turn it about that vertex until it touches another; it meets every
/// set all along. So trying the line through each pair of distinct vertices decides it. A set
/// is met when its vertices are not all strictly on one side ([`STAB_TOLERANCE_M`]).
#[must_use]
pub(crate) fn stabbable(objects: &[&[Vec2]]) -> bool {
    let vertices: Vec<Vec2> = objects.iter().flat_map(|o| o.iter().copied()).collect();
    let mut any_pair = false;
    for (i, &p) in vertices.iter().enumerate() {
        for &q in &vertices[i + 1..] {
            let Some(normal) = (q - p).perp().try_normalize() else { continue };
            any_pair = true;
            let meets = |o: &&[Vec2]| {
                let (lo, hi) = o
                    .iter()
                    .map(|v| normal.dot(*v - p))
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), d| (lo.min(d), hi.max(d)));
                lo <= STAB_TOLERANCE_M && hi >= -STAB_TOLERANCE_M
            };
            if objects.iter().all(meets) {
                return true;
            }
        }
    }
    // All vertices at one point: any line through it meets every set.
    !any_pair
}

/// Whether every point of `footprint` lies in room `room`'s footprint (at the wall centre
/// lines, where window lights sit).
fn footprint_in_room(scene: &Scene, room: usize, footprint: &[Vec2]) -> bool {
    let r = &scene.rooms[room];
    let (lo, hi) = (r.min - Vec2::splat(PLAN_TOLERANCE_M), r.max + Vec2::splat(PLAN_TOLERANCE_M));
    !footprint.is_empty() && footprint.iter().all(|p| p.cmpge(lo).all() && p.cmple(hi).all())
}

/// The openings of interior walls, widened by [`PORTAL_MARGIN_M`].
fn portals(scene: &Scene) -> Vec<Portal> {
    let mut out = Vec::new();
    for wall in &scene.walls {
        let [Some(r0), Some(r1)] = wall.rooms else { continue };
        let along = (wall.b - wall.a).normalize_or_zero();
        for o in &wall.openings {
            let half = 0.5 * o.width_m + PORTAL_MARGIN_M;
            out.push(Portal {
                a: wall.a + along * (o.offset_m - half),
                b: wall.a + along * (o.offset_m + half),
                rooms: [r0 as usize, r1 as usize],
            });
        }
    }
    out
}

/// Whether `scene`'s rooms are closed cells as the module docs require: at most [`MAX_ROOMS`]
/// rectangles inside the envelope that do not overlap and fill it, every side of every room
/// covered by walls that name the room, and every wall as high as the envelope (the ceiling).
fn closed_floorplan(scene: &Scene) -> bool {
    let rooms = &scene.rooms;
    let env = Vec2::new(scene.envelope.width_m, scene.envelope.depth_m);
    if rooms.is_empty() || rooms.len() > MAX_ROOMS {
        return false;
    }
    let tol = PLAN_TOLERANCE_M;
    let inside = rooms.iter().all(|r| r.min.cmpge(Vec2::splat(-tol)).all() && r.max.cmple(env + tol).all());
    let area: f32 = rooms.iter().map(|r| (r.max - r.min).x * (r.max - r.min).y).sum();
    let disjoint = rooms.iter().enumerate().all(|(i, a)| {
        rooms[i + 1..].iter().all(|b| {
            let overlap = (a.max.min(b.max) - a.min.max(b.min)).max(Vec2::ZERO);
            overlap.x * overlap.y <= tol * tol
        })
    });
    let full_height = scene.walls.iter().all(|w| w.height_m >= scene.envelope.height_m - tol);
    let closed = rooms.iter().enumerate().all(|(i, r)| room_sides_walled(scene, i, r.min, r.max));
    inside && (area - env.x * env.y).abs() <= tol * env.x.max(env.y) && disjoint && full_height && closed
}

/// Whether each side of the rectangle `min..max` (room `room`) is covered end to end by walls
/// on its line that have the room on one side.
fn room_sides_walled(scene: &Scene, room: usize, min: Vec2, max: Vec2) -> bool {
    let sides = [
        (Vec2::new(min.x, min.y), Vec2::new(max.x, min.y)),
        (Vec2::new(max.x, min.y), Vec2::new(max.x, max.y)),
        (Vec2::new(min.x, max.y), Vec2::new(max.x, max.y)),
        (Vec2::new(min.x, min.y), Vec2::new(min.x, max.y)),
    ];
    sides.iter().all(|&(a, b)| {
        let axis = (b - a).normalize_or_zero();
        let normal = axis.perp();
        let mut spans: Vec<(f32, f32)> = scene
            .walls
            .iter()
            .filter(|w| w.rooms.contains(&Some(room as u32)))
            .filter(|w| normal.dot(w.a - a).abs() <= PLAN_TOLERANCE_M && normal.dot(w.b - a).abs() <= PLAN_TOLERANCE_M)
            .map(|w| {
                let (s, t) = (axis.dot(w.a - a), axis.dot(w.b - a));
                (s.min(t), s.max(t))
            })
            .collect();
        spans.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut covered = 0.0f32;
        for (s, t) in spans {
            if s > covered + PLAN_TOLERANCE_M {
                break;
            }
            covered = covered.max(t);
        }
        covered >= (b - a).length() - PLAN_TOLERANCE_M
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene_gen_scene::scene::{Opening, OpeningKind, Room, Wall};

    fn seg(a: (f32, f32), b: (f32, f32)) -> [Vec2; 2] {
        [Vec2::new(a.0, a.1), Vec2::new(b.0, b.1)]
    }

    #[test]
    fn lines_through_aligned_openings_stab_them_and_offset_ones_do_not() {
        let light = [Vec2::new(1.0, 1.0)];
        // Two doors in walls at x = 2 and x = 4, both around y = 1: a horizontal line passes.
        let (d1, d2) = (seg((2.0, 0.6), (2.0, 1.4)), seg((4.0, 0.7), (4.0, 1.5)));
        assert!(stabbable(&[&light, &d1, &d2]));
        // The second door 3 m up: the line from the light through the first door cannot reach it.
        let far = seg((4.0, 4.0), (4.0, 4.8));
        assert!(!stabbable(&[&light, &d1, &far]));
        // From a wide window footprint instead of a point, a slanted line can make it.
        let window = seg((0.0, -3.0), (0.0, -1.0));
        assert!(stabbable(&[&window, &d1, &seg((4.0, 2.5), (4.0, 3.3))]));
        assert!(!stabbable(&[&light, &d1, &seg((4.0, 2.5), (4.0, 3.3))]));
        // Degenerate families: one point, or a point on a segment.
        assert!(stabbable(&[&light]));
        assert!(stabbable(&[&light, &seg((1.0, 0.0), (1.0, 2.0))]));
    }

    /// Three rooms in a row along x (A 0..5, B 5..10, C 10..15; 5 m deep), doors A-B at
    /// y = `door_ab` and B-C at y = `door_bc`, all walls 3 m high.
    fn row_of_rooms(door_ab: f32, door_bc: f32) -> Scene {
        let mut scene = crate::test_util::empty_scene();
        scene.envelope = scene_gen_scene::scene::Envelope { width_m: 15.0, depth_m: 5.0, height_m: 3.0 };
        scene.wall_thickness_m = 0.1;
        for (i, x) in [0.0f32, 5.0, 10.0].into_iter().enumerate() {
            scene.rooms.push(Room {
                id: i as u32,
                room_type: "living".into(),
                min: Vec2::new(x, 0.0),
                max: Vec2::new(x + 5.0, 5.0),
            });
        }
        let mut wall = |a: (f32, f32), b: (f32, f32), rooms: [Option<u32>; 2], door: Option<f32>| {
            let id = scene.walls.len() as u32;
            let openings = door
                .map(|y| Opening { kind: OpeningKind::Door, id, offset_m: y, width_m: 0.8, sill_m: 0.0, height_m: 2.0 })
                .into_iter()
                .collect();
            scene.walls.push(Wall {
                id,
                a: Vec2::new(a.0, a.1),
                b: Vec2::new(b.0, b.1),
                thickness_m: 0.1,
                height_m: 3.0,
                rooms,
                openings,
            });
        };
        for (i, x) in [0.0f32, 5.0, 10.0].into_iter().enumerate() {
            let r = Some(i as u32);
            wall((x, 0.0), (x + 5.0, 0.0), [r, None], None);
            wall((x, 5.0), (x + 5.0, 5.0), [r, None], None);
        }
        wall((0.0, 0.0), (0.0, 5.0), [Some(0), None], None);
        wall((5.0, 0.0), (5.0, 5.0), [Some(0), Some(1)], Some(door_ab));
        wall((10.0, 0.0), (10.0, 5.0), [Some(1), Some(2)], Some(door_bc));
        wall((15.0, 0.0), (15.0, 5.0), [Some(2), None], None);
        scene
    }

    fn point(room: u32, x: f32, y: f32) -> LightSource {
        LightSource { room: Some(room), footprint: vec![Vec2::new(x, y)] }
    }

    #[test]
    fn lights_reach_rooms_through_lined_up_doors_only() {
        // Doors in line at y = 1: a lamp at y = 1 in A reaches C; one at y = 4 reaches only B.
        let scene = row_of_rooms(1.0, 1.0);
        let reach = LightReach::of_floorplan(&scene, &[point(0, 2.5, 1.0), point(0, 2.5, 4.0)], &[]);
        let rooms: Vec<Vec<u32>> = (0..3).map(|r| reach.room_lights(r).unwrap().points.clone()).collect();
        assert_eq!(rooms, [vec![0, 1], vec![0, 1], vec![0]]);
        // Doors at opposite ends of the middle room: nothing in A reaches C.
        let scene = row_of_rooms(0.6, 4.4);
        let reach = LightReach::of_floorplan(&scene, &[point(0, 2.5, 1.0), point(0, 2.5, 4.0)], &[]);
        assert_eq!(reach.room_lights(2).unwrap().points, Vec::<u32>::new());
        assert_eq!(reach.room_lights(1).unwrap().points, [0, 1]);
        // A point in a doorway (in no room's interior) considers every light.
        assert_eq!(reach.lights_at(Vec3::new(10.0, 4.4, 0.01)).points, [0, 1]);
        assert_eq!(reach.lights_at(Vec3::new(12.0, 2.0, 0.5)).points, Vec::<u32>::new());
        // A light the scene puts in the wrong room, or in none, is everywhere.
        let reach = LightReach::of_floorplan(
            &scene,
            &[point(2, 2.5, 1.0), LightSource { room: None, ..point(0, 1.0, 1.0) }],
            &[],
        );
        assert_eq!(reach.room_lights(2).unwrap().points, [0, 1]);
    }

    /// On generated houses, every light left out of a room's list is blocked by the real
    /// geometry from every point tried in the room: free points of its interior and the surface
    /// points rays from them hit. Each room is tried from 60 points, each left-out point light
    /// once and each left-out rect light at 4 random points of its area.
    #[test]
    fn walls_block_every_light_left_out_of_a_room() {
        use rand::Rng;

        use crate::{Accel, LightSet};
        let library = scene_gen_scene::house::embedded_library().unwrap();
        let params = scene_gen_scene::trajectory::TrajectoryParams::default();
        let (mut checked, mut left_out_pairs, mut pairs) = (0usize, 0usize, 0usize);
        for seed in [1u64, 2, 3, 7] {
            let scene = scene_gen_scene::house::walked_house(&library, seed, &params).unwrap().scene;
            let (accel, set) = (Accel::build(&scene), LightSet::for_scene(&scene, [1.0, 1.0]));
            let mut rng = scene_gen_core::rng::stream(seed, "reach-test");
            for (r, room) in scene.rooms.iter().enumerate() {
                let lists = set.reach.room_lights(r).expect("generated plans are closed");
                let (points, rects) = (&lists.points, &lists.rects);
                let out_points: Vec<usize> = (0..set.points.len()).filter(|i| !points.contains(&(*i as u32))).collect();
                let out_rects: Vec<usize> = (0..set.rects.len()).filter(|i| !rects.contains(&(*i as u32))).collect();
                pairs += set.points.len() + set.rects.len();
                left_out_pairs += out_points.len() + out_rects.len();
                let (lo, hi) = room.interior(scene.wall_thickness_m);
                for _ in 0..60 {
                    let free = Vec3::new(
                        rng.random_range(lo.x + 0.01..hi.x - 0.01),
                        rng.random_range(lo.y + 0.01..hi.y - 0.01),
                        rng.random_range(0.01..scene.envelope.height_m - 0.01),
                    );
                    let dir = Vec3::new(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                    )
                    .normalize_or(Vec3::Z);
                    let mut tried = vec![free];
                    if let Some(hit) = accel.closest_hit(free, dir, f32::INFINITY) {
                        let surface = free + dir * (hit.t - 1e-3);
                        if std::ptr::eq(set.reach.lights_at(surface), set.reach.room_lights(r).unwrap()) {
                            tried.push(surface);
                        }
                    }
                    for p in tried {
                        let mut targets: Vec<Vec3> = out_points.iter().map(|&i| set.points[i].position).collect();
                        for &i in &out_rects {
                            let l = &set.rects[i];
                            for _ in 0..4 {
                                let (a, b): (f32, f32) = (rng.random(), rng.random());
                                targets.push(l.center + l.u * (a - 0.5) + l.v * (b - 0.5));
                            }
                        }
                        for q in targets {
                            let (d, dist) = ((q - p).normalize(), (q - p).length());
                            assert!(
                                accel.occluded(p, d, dist - 1e-3),
                                "seed {seed}, room {r}: a light left out of its list reaches {p} from {q}"
                            );
                            checked += 1;
                        }
                    }
                }
            }
        }
        // Not a vacuous pass: many rays tried, and the lists leave out a good part of the lights.
        assert!(checked > 10_000, "{checked} rays");
        assert!(left_out_pairs * 3 > pairs, "{left_out_pairs} of {pairs} (room, light) pairs left out");
    }

    #[test]
    fn an_open_or_low_walled_plan_keeps_every_light_everywhere() {
        let lamp = [point(0, 2.5, 4.0)];
        let mut scene = row_of_rooms(0.6, 4.4);
        assert!(LightReach::of_floorplan(&scene, &lamp, &[]).room_lights(0).is_some());
        scene.walls[3].height_m = 2.5;
        assert!(LightReach::of_floorplan(&scene, &lamp, &[]).room_lights(0).is_none());
        let mut scene = row_of_rooms(0.6, 4.4);
        scene.walls.remove(8); // the wall between B and C
        assert!(LightReach::of_floorplan(&scene, &lamp, &[]).room_lights(0).is_none());
        let reach = LightReach::of_floorplan(&scene, &lamp, &[]);
        assert_eq!(reach.lights_at(Vec3::new(12.0, 2.0, 0.5)).points, [0]);
    }
}
