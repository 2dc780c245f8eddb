//! The agent's walk through a house: the camera poses the evaluator renders.
//!
//! The agent is a disc of radius [`TrajectoryParams::radius_m`] (0.25 m by default, a small
//! home robot) that walks through every room and through every door, so it steps over every
//! threshold: the thresholds are what the camera must see in time, so they are *not* obstacles
//! to the planner.
//!
//! 1. **Occupancy grid** ([`OccupancyGrid`]): cells of [`TrajectoryParams::cell_m`] (0.1 m)
//!    over the house plus a margin. A cell is blocked when its centre is closer than the agent
//!    radius to a wall (less its door openings; windows have a sill, so a wall is solid at
//!    floor level under a window), to an open door leaf, or to the footprint of an object or
//!    furnishing that reaches below [`OBSTACLE_MAX_BOTTOM_M`]. Outside the house only an
//!    apron of [`APRON_M`] around each exterior door is free, so the agent can step out and
//!    back in but never walks around the house.
//! 2. **Goals**: a depth-first walk over the door graph from the first room (lowest id): the
//!    agent goes to each room's centre (the nearest reachable free cell), and for every door
//!    of the room in id order: to a point [`DOOR_STANDOFF_M`] before the door, through it to
//!    the same distance beyond, then (a door to an unvisited room) on into that room and
//!    recursively, or (a door to a visited room or to the outside) straight back. Every door
//!    is therefore passed at least once, every room is visited.
//! 3. **Paths**: 8-connected A* on the grid between consecutive goals (integer costs 10 and
//!    14, ties broken by cell index, so it is deterministic), shortened by line-of-sight
//!    (string pulling on the grid), then sampled every [`TrajectoryParams::step_m`] (0.25 m)
//!    of arc length at walking speed [`TrajectoryParams::speed_m_per_s`]
//!    ([`DEFAULT_SPEED_M_PER_S`], 1.0 m/s). Yaw follows the direction of travel.
//!
//! When a goal cannot be reached at the nominal radius (furniture close to a door), the whole
//! plan is retried with a smaller radius (see [`FALLBACK_RADII_M`]); the radius used is in
//! [`Trajectory::radius_m`].

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::{Vec2, Vec3};

use crate::scene::{OpeningKind, Scene};

/// Objects whose bounding box starts above this height (a wall shelf, a lamp on a table is
/// still counted through its table) do not block the agent's body, metres.
pub const OBSTACLE_MAX_BOTTOM_M: f32 = 1.0;

/// Free ground outside an exterior door, metres from the door centre.
pub const APRON_M: f32 = 1.2;

/// Distance before and beyond a door at which the agent lines up to pass it, metres.
pub const DOOR_STANDOFF_M: f32 = 0.6;

/// Radii tried in turn when the nominal radius leaves a goal unreachable, metres.
pub const FALLBACK_RADII_M: [f32; 3] = [0.2, 0.15, 0.1];

/// Default walking speed, m/s. The reference paper does not state its agent's speed. 1.0 m/s
/// sits at the slow end of human indoor walking (comfortable gait 1.2..1.4 m/s: R. W. Bohannon,
/// "Comfortable and maximum walking speed of adults aged 20-79 years", Age and Ageing 26, 1997)
/// and at the top of home and service robots' cruising speeds; it is the speed the 0.5 s
/// threshold window of the evaluator is read at (0.5 m of walk before a crossing). The earlier
/// 0.5 m/s left only the last 0.25 m before a door in that window, where a sill is under any
/// camera that is not pointed steeply down.
pub const DEFAULT_SPEED_M_PER_S: f32 = 1.0;

/// The agent's radius by default, metres: door leaves are hung to leave it room
/// ([`crate::doors`]).
pub const NOMINAL_RADIUS_M: f32 = 0.25;

/// How the agent walks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectoryParams {
    /// Agent radius: clearance kept from walls and furniture, metres.
    pub radius_m: f32,
    /// Occupancy grid cell size, metres.
    pub cell_m: f32,
    /// Arc length between poses, metres.
    pub step_m: f32,
    /// Walking speed, metres per second.
    pub speed_m_per_s: f32,
    /// Camera height above the floor, metres.
    pub height_m: f32,
}

impl Default for TrajectoryParams {
    fn default() -> Self {
        TrajectoryParams {
            radius_m: NOMINAL_RADIUS_M,
            cell_m: 0.1,
            step_m: 0.25,
            speed_m_per_s: DEFAULT_SPEED_M_PER_S,
            height_m: 0.8,
        }
    }
}

/// One camera pose on the walk.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Pose {
    /// Camera centre, world metres (z = mounting height).
    pub position: Vec3,
    /// Heading, degrees counter-clockwise from +X (the direction of travel).
    pub yaw_deg: f32,
    /// Time since the start of the walk, seconds.
    pub time_s: f32,
}

/// The agent passing a door (and stepping over its threshold).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Crossing {
    pub threshold_id: u32,
    /// First pose beyond the door plane.
    pub pose_index: usize,
    pub time_s: f32,
}

/// A planned walk.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Trajectory {
    pub poses: Vec<Pose>,
    /// Every door passage, in time order.
    pub crossings: Vec<Crossing>,
    /// The agent radius the plan used (the nominal one unless a fallback was needed).
    pub radius_m: f32,
}

/// Why no walk could be planned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrajectoryError {
    #[error("the scene has no rooms")]
    NoRooms,
    #[error("no free floor in room {room} even with a {radius_m} m agent")]
    NoFreeFloor { room: u32, radius_m: f32 },
    #[error("goal {goal} cannot be reached even with a {radius_m} m agent")]
    Unreachable { goal: usize, radius_m: f32 },
}

/// A boolean grid of blocked cells over the house.
#[derive(Clone, Debug)]
pub struct OccupancyGrid {
    pub origin: Vec2,
    pub cell_m: f32,
    pub nx: usize,
    pub ny: usize,
    pub blocked: Vec<bool>,
}

/// Solid wall pieces at floor level as (a, b, half thickness): each wall less its doors, and
/// the open door leaves.
fn wall_pieces(scene: &Scene) -> Vec<(Vec2, Vec2, f32)> {
    let mut out = Vec::new();
    for wall in &scene.walls {
        let len = wall.length_m();
        if len <= 0.0 {
            continue;
        }
        let dir = (wall.b - wall.a) / len;
        let mut start = 0.0f32;
        for o in wall.openings.iter().filter(|o| o.kind == OpeningKind::Door) {
            let (s0, s1) = (o.offset_m - 0.5 * o.width_m, o.offset_m + 0.5 * o.width_m);
            if s0 > start {
                out.push((wall.a + dir * start, wall.a + dir * s0, 0.5 * wall.thickness_m));
            }
            start = start.max(s1);
        }
        if start < len {
            out.push((wall.a + dir * start, wall.b, 0.5 * wall.thickness_m));
        }
    }
    // An open door leaf stands like a thin wall from its hinge to its free edge.
    out.extend(scene.doors.iter().filter_map(|d| d.leaf).map(|l| (l.hinge, l.free_edge(), 0.5 * l.thickness_m)));
    out
}

/// Distance from `p` to the segment `a..b` thickened by `half`; negative inside is clamped to 0.
fn dist_to_piece(p: Vec2, (a, b, half): (Vec2, Vec2, f32)) -> f32 {
    let ab = b - a;
    // Walls are boxes, not capsules: measure to the box around the segment.
    let dir = ab.normalize_or_zero();
    let along = (p - a).dot(dir);
    let across = (p - a).perp_dot(dir).abs();
    let len = ab.length();
    let dx = (if along < 0.0 {
        -along
    } else if along > len {
        along - len
    } else {
        0.0
    })
    .max(0.0);
    let dy = (across - half).max(0.0);
    (dx * dx + dy * dy).sqrt()
}

/// Distance from `p` to an axis-aligned rectangle.
fn dist_to_rect(p: Vec2, lo: Vec2, hi: Vec2) -> f32 {
    let d = (lo - p).max(p - hi).max(Vec2::ZERO);
    d.length()
}

/// Clearance of point `p` from the nearest wall or obstacle footprint, metres (0 inside).
#[must_use]
pub fn clearance_m(scene: &Scene, p: Vec2) -> f32 {
    let walls = wall_pieces(scene);
    clearance_with(scene, &walls, p)
}

fn clearance_with(scene: &Scene, walls: &[(Vec2, Vec2, f32)], p: Vec2) -> f32 {
    let w = walls.iter().map(|&piece| dist_to_piece(p, piece)).fold(f32::INFINITY, f32::min);
    let o = scene
        .objects
        .iter()
        .map(|o| (o.min, o.max))
        .chain(scene.furnishings.iter().map(|f| (f.min, f.max)))
        .filter(|(min, _)| min.z < OBSTACLE_MAX_BOTTOM_M)
        .map(|(min, max)| dist_to_rect(p, min.truncate(), max.truncate()))
        .fold(f32::INFINITY, f32::min);
    w.min(o)
}

fn in_any_room(scene: &Scene, p: Vec2) -> bool {
    scene.rooms.iter().any(|r| p.cmpge(r.min).all() && p.cmple(r.max).all())
}

impl OccupancyGrid {
    /// The grid of `scene` for an agent of `radius_m`.
    #[must_use]
    pub fn build(scene: &Scene, radius_m: f32, cell_m: f32) -> OccupancyGrid {
        let lo = scene.rooms.iter().fold(Vec2::splat(f32::INFINITY), |m, r| m.min(r.min)) - Vec2::splat(APRON_M + 0.5);
        let hi =
            scene.rooms.iter().fold(Vec2::splat(f32::NEG_INFINITY), |m, r| m.max(r.max)) + Vec2::splat(APRON_M + 0.5);
        let nx = ((hi.x - lo.x) / cell_m).ceil().max(1.0) as usize;
        let ny = ((hi.y - lo.y) / cell_m).ceil().max(1.0) as usize;
        let walls = wall_pieces(scene);
        let exterior_doors: Vec<Vec2> =
            scene.doors.iter().filter(|d| d.rooms[1].is_none()).map(|d| d.center.truncate()).collect();
        let mut grid = OccupancyGrid { origin: lo, cell_m, nx, ny, blocked: vec![false; nx * ny] };
        for j in 0..ny {
            for i in 0..nx {
                let p = grid.centre(i, j);
                let outside = !in_any_room(scene, p);
                let off_apron = outside && !exterior_doors.iter().any(|d| d.distance(p) <= APRON_M);
                grid.blocked[j * nx + i] = off_apron || clearance_with(scene, &walls, p) < radius_m;
            }
        }
        grid
    }

    /// Centre of cell (i, j).
    #[must_use]
    pub fn centre(&self, i: usize, j: usize) -> Vec2 {
        self.origin + Vec2::new(i as f32 + 0.5, j as f32 + 0.5) * self.cell_m
    }

    fn cell_of(&self, p: Vec2) -> Option<(usize, usize)> {
        let q = (p - self.origin) / self.cell_m;
        if q.x < 0.0 || q.y < 0.0 {
            return None;
        }
        let (i, j) = (q.x as usize, q.y as usize);
        (i < self.nx && j < self.ny).then_some((i, j))
    }

    fn free(&self, i: usize, j: usize) -> bool {
        !self.blocked[j * self.nx + i]
    }

    /// Cells reachable from `start` (flood fill over 8 neighbours).
    fn reachable(&self, start: usize) -> Vec<bool> {
        let mut seen = vec![false; self.blocked.len()];
        let mut stack = vec![start];
        seen[start] = true;
        while let Some(c) = stack.pop() {
            for (n, _) in self.neighbours(c) {
                if !seen[n] {
                    seen[n] = true;
                    stack.push(n);
                }
            }
        }
        seen
    }

    /// Free 8-neighbours of cell `c` with their step cost (10 straight, 14 diagonal); a
    /// diagonal step needs both side cells free, so paths never cut a blocked corner.
    fn neighbours(&self, c: usize) -> impl Iterator<Item = (usize, u32)> + '_ {
        let (i, j) = ((c % self.nx) as i64, (c / self.nx) as i64);
        const STEPS: [(i64, i64); 8] = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)];
        STEPS.iter().filter_map(move |&(di, dj)| {
            let ok = |a: i64, b: i64| a >= 0 && b >= 0 && (a as usize) < self.nx && (b as usize) < self.ny;
            let (a, b) = (i + di, j + dj);
            if !ok(a, b) || !self.free(a as usize, b as usize) {
                return None;
            }
            if di != 0
                && dj != 0
                && !(self.free((i + di) as usize, j as usize) && self.free(i as usize, (j + dj) as usize))
            {
                return None;
            }
            Some((b as usize * self.nx + a as usize, if di != 0 && dj != 0 { 14 } else { 10 }))
        })
    }

    /// A* from cell `s` to cell `g`: the cell sequence, or `None`.
    fn astar(&self, s: usize, g: usize) -> Option<Vec<usize>> {
        let (gi, gj) = ((g % self.nx) as i64, (g / self.nx) as i64);
        let h = |c: usize| -> u32 {
            let (dx, dy) = (((c % self.nx) as i64 - gi).unsigned_abs(), ((c / self.nx) as i64 - gj).unsigned_abs());
            let (lo, hi) = (dx.min(dy), dx.max(dy));
            (14 * lo + 10 * (hi - lo)) as u32
        };
        let mut cost = vec![u32::MAX; self.blocked.len()];
        let mut parent = vec![usize::MAX; self.blocked.len()];
        let mut open = BinaryHeap::new();
        cost[s] = 0;
        open.push(Reverse((h(s), s)));
        while let Some(Reverse((_, c))) = open.pop() {
            if c == g {
                let mut path = vec![g];
                let mut cur = g;
                while cur != s {
                    cur = parent[cur];
                    path.push(cur);
                }
                path.reverse();
                return Some(path);
            }
            let base = cost[c];
            for (n, step) in self.neighbours(c) {
                let nc = base + step;
                if nc < cost[n] {
                    cost[n] = nc;
                    parent[n] = c;
                    open.push(Reverse((nc + h(n), n)));
                }
            }
        }
        None
    }

    /// True when every cell the segment `a..b` passes (sampled every quarter cell) is free.
    fn line_free(&self, a: Vec2, b: Vec2) -> bool {
        let n = ((b - a).length() / (0.25 * self.cell_m)).ceil().max(1.0) as usize;
        (0..=n).all(|k| {
            let p = a.lerp(b, k as f32 / n as f32);
            self.cell_of(p).is_some_and(|(i, j)| self.free(i, j))
        })
    }
}

/// Plans the walk through `scene`.
///
/// # Errors
/// [`TrajectoryError`] when the scene has no rooms or a goal cannot be reached even at the
/// smallest fallback radius.
pub fn plan(scene: &Scene, params: &TrajectoryParams) -> Result<Trajectory, TrajectoryError> {
    let mut radii = vec![params.radius_m];
    radii.extend(FALLBACK_RADII_M.iter().copied().filter(|&r| r < params.radius_m));
    let mut last = TrajectoryError::NoRooms;
    for r in radii {
        match plan_with_radius(scene, params, r) {
            Ok(t) => return Ok(t),
            Err(e @ TrajectoryError::NoRooms) => return Err(e),
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// The goal points of the depth-first walk, each with the rectangle it must be snapped into.
fn goals(scene: &Scene) -> Vec<(Vec2, Vec2, Vec2)> {
    let mut rooms: Vec<&crate::scene::Room> = scene.rooms.iter().collect();
    rooms.sort_by_key(|r| r.id);
    let mut visited = vec![false; rooms.len()];
    let mut doors_done = vec![false; scene.doors.len()];
    let mut out = Vec::new();
    let interior = |id: u32| {
        let r = scene.room(id).expect("door rooms exist");
        r.interior(scene.wall_thickness_m)
    };
    let pos = |id: u32| rooms.iter().position(|r| r.id == id).expect("room exists");
    fn visit(
        scene: &Scene,
        room: u32,
        visited: &mut Vec<bool>,
        doors_done: &mut Vec<bool>,
        out: &mut Vec<(Vec2, Vec2, Vec2)>,
        interior: &dyn Fn(u32) -> (Vec2, Vec2),
        pos: &dyn Fn(u32) -> usize,
    ) {
        visited[pos(room)] = true;
        let (lo, hi) = interior(room);
        let centre = (lo + hi) * 0.5;
        out.push((centre, lo, hi));
        for (di, door) in scene.doors.iter().enumerate() {
            if doors_done[di] {
                continue;
            }
            let Some(inward_here) = door.inward(room) else { continue };
            doors_done[di] = true;
            let c = door.center.truncate();
            let other = if door.rooms[0] == Some(room) { door.rooms[1] } else { door.rooms[0] };
            let here = (c + inward_here * DOOR_STANDOFF_M, lo, hi);
            let beyond_p = c - inward_here * DOOR_STANDOFF_M;
            let beyond = match other {
                Some(o) => {
                    let (olo, ohi) = interior(o);
                    (beyond_p, olo, ohi)
                }
                None => (beyond_p, c - Vec2::splat(APRON_M), c + Vec2::splat(APRON_M)),
            };
            out.push(here);
            out.push(beyond);
            match other {
                Some(o) if !visited[pos(o)] => {
                    visit(scene, o, visited, doors_done, out, interior, pos);
                    out.push(beyond);
                    out.push(here);
                }
                _ => out.push(here),
            }
            // Back in this room: pass its centre again before the next door.
            out.push((centre, lo, hi));
        }
    }
    if let Some(first) = rooms.first() {
        visit(scene, first.id, &mut visited, &mut doors_done, &mut out, &interior, &pos);
    }
    // Rooms no door reaches (should not happen in a generated house) are left out.
    out
}

fn plan_with_radius(scene: &Scene, params: &TrajectoryParams, radius_m: f32) -> Result<Trajectory, TrajectoryError> {
    if scene.rooms.is_empty() {
        return Err(TrajectoryError::NoRooms);
    }
    let grid = OccupancyGrid::build(scene, radius_m, params.cell_m);
    let goals = goals(scene);
    // Start: the free cell nearest the first room's centre.
    let first = scene.rooms.iter().min_by_key(|r| r.id).expect("not empty");
    let (flo, fhi) = first.interior(scene.wall_thickness_m);
    let start = snap(&grid, None, (flo + fhi) * 0.5, flo, fhi)
        .ok_or(TrajectoryError::NoFreeFloor { room: first.id, radius_m })?;
    let reach = grid.reachable(start);
    // Each leg (goal to goal) is shortened on its own: shortening across a goal would cut
    // the out-and-back excursions through the doors.
    let centre = |c: usize| grid.centre(c % grid.nx, c / grid.nx);
    let mut smooth = vec![centre(start)];
    let mut from = start;
    for (k, &(p, lo, hi)) in goals.iter().enumerate() {
        let g = snap(&grid, Some(&reach), p, lo, hi).ok_or(TrajectoryError::Unreachable { goal: k, radius_m })?;
        let path = grid.astar(from, g).ok_or(TrajectoryError::Unreachable { goal: k, radius_m })?;
        let points: Vec<Vec2> = path.iter().map(|&c| centre(c)).collect();
        smooth.extend(string_pull(&grid, &points).into_iter().skip(1));
        from = g;
    }
    let poses = sample(&smooth, params);
    let crossings = crossings(scene, &poses);
    Ok(Trajectory { poses, crossings, radius_m })
}

/// The free (and, with `reach`, reachable) cell nearest `p` whose centre is in `lo..hi`.
fn snap(grid: &OccupancyGrid, reach: Option<&[bool]>, p: Vec2, lo: Vec2, hi: Vec2) -> Option<usize> {
    let mut best: Option<(f32, usize)> = None;
    for c in 0..grid.blocked.len() {
        if grid.blocked[c] || reach.is_some_and(|r| !r[c]) {
            continue;
        }
        let q = grid.centre(c % grid.nx, c / grid.nx);
        if !(q.cmpge(lo).all() && q.cmple(hi).all()) {
            continue;
        }
        let d = q.distance_squared(p);
        if best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, c));
        }
    }
    best.map(|(_, c)| c)
}

/// Greedy line-of-sight shortening: from each kept point, jump to the farthest later point
/// seen in a straight free line (within a window, to keep it linear-ish in time).
fn string_pull(grid: &OccupancyGrid, points: &[Vec2]) -> Vec<Vec2> {
    const WINDOW: usize = 60;
    let mut out = Vec::new();
    let mut i = 0;
    while i < points.len() {
        out.push(points[i]);
        if i + 1 >= points.len() {
            break;
        }
        let mut j = i + 1;
        let end = (i + WINDOW).min(points.len() - 1);
        for k in (i + 2..=end).rev() {
            if grid.line_free(points[i], points[k]) {
                j = k;
                break;
            }
        }
        i = j;
    }
    out
}

/// Poses every `step_m` of arc length along the polyline, yaw along the segment.
fn sample(points: &[Vec2], params: &TrajectoryParams) -> Vec<Pose> {
    let mut poses = Vec::new();
    let pose = |p: Vec2, dir: Vec2, s: f32| Pose {
        position: p.extend(params.height_m),
        yaw_deg: dir.y.atan2(dir.x).to_degrees(),
        time_s: s / params.speed_m_per_s,
    };
    let mut s_total = 0.0f32;
    let mut next = 0.0f32;
    let mut last_dir = Vec2::X;
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = a.distance(b);
        if len <= 1e-6 {
            continue;
        }
        let dir = (b - a) / len;
        last_dir = dir;
        while next <= s_total + len {
            poses.push(pose(a + dir * (next - s_total), dir, next));
            next += params.step_m;
        }
        s_total += len;
    }
    let end = *points.last().unwrap_or(&Vec2::ZERO);
    if poses.last().is_none_or(|p| p.position.truncate().distance(end) > 1e-4) {
        poses.push(pose(end, last_dir, s_total));
    }
    poses
}

/// Door passages: consecutive poses on opposite sides of a door's wall line, crossing it
/// within the door's width.
fn crossings(scene: &Scene, poses: &[Pose]) -> Vec<Crossing> {
    let mut out = Vec::new();
    for (k, w) in poses.windows(2).enumerate() {
        let (a, b) = (w[0].position.truncate(), w[1].position.truncate());
        for t in &scene.thresholds {
            let Some(door) = scene.doors.iter().find(|d| d.id == t.door) else { continue };
            let c = door.center.truncate();
            let (da, db) = ((a - c).dot(door.normal), (b - c).dot(door.normal));
            if da == db || (da < 0.0) == (db < 0.0) {
                continue;
            }
            let x = a + (b - a) * (da / (da - db));
            if (x - c).perp_dot(door.normal).abs() <= 0.5 * door.width_m {
                out.push(Crossing { threshold_id: t.id, pose_index: k + 1, time_s: w[1].time_s });
            }
        }
    }
    out
}
