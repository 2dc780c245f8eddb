//! Floorplans: the envelope split into rectangular rooms, room types assigned, walls, doors and
//! windows.
//!
//! [`generate`] runs four steps, all drawing from the `"floorplan"` stream of the seed:
//!
//! 1. **Split.** A target room count is drawn uniformly from 1 up to the most rooms of
//!    `min_room_m` that fit, then leaves of a guillotine tree are split (random leaf, random
//!    axis, random position on a 0.25 m grid) until the count is reached. A split is only taken
//!    if the rooms it leaves can still reach the target, so every count in the range occurs and
//!    layouts vary within a count. Drawing the count first is how the tree "decides to stop".
//! 2. **Types.** Room types are assigned from the room library, honouring each type's
//!    [`PlanRules`]: first the rooms a plan must have (each taking a random, the smallest or the
//!    largest free room, as its `prefer_area` says), then weighted draws for the rest.
//! 3. **Walls.** Every room edge is a wall centre line; lines are cut into [`Wall`] segments
//!    with exactly one room (or the outside) on each side.
//! 4. **Openings.** Doors on a random spanning tree of the room adjacency graph plus a few extra
//!    loops and at least one exterior door; then windows on exterior walls, at least one per
//!    room that has an exterior wall.
//!
//! Room `min`/`max` are wall centre lines; the outer walls' centre lines are the envelope
//! boundary. Ids are indices in their `Vec`.

use glam::{Vec2, Vec3};
use rand::Rng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use crate::config::GeneratorConfig;
use crate::library::RoomType;
use crate::library::rooms::{AreaPreference, PlanRules};
use crate::scene::{Door, Opening, OpeningKind, Room, Wall, Window};

/// Door leaf widths drawn, metres. 0.8 m is the common clear width of interior doors (e.g.
/// DIN 18101 nominal widths 0.76..1.01 m); 1.0 m is a generous front door.
pub const DOOR_WIDTH_M: (f32, f32) = (0.8, 1.0);
/// Door heights drawn, metres: around the 2.0 m standard door height (DIN 18101: 2.01 m).
pub const DOOR_HEIGHT_M: (f32, f32) = (1.95, 2.05);
/// Window widths drawn, metres.
pub const WINDOW_WIDTH_M: (f32, f32) = (0.8, 2.0);
/// Window sill heights drawn, metres (typical residential sills are 0.8..1.0 m).
pub const WINDOW_SILL_M: (f32, f32) = (0.8, 1.0);
/// Window opening heights drawn, metres.
pub const WINDOW_HEIGHT_M: (f32, f32) = (1.0, 1.4);
/// Clear distance kept between an opening and the end of its wall segment (a corner or a
/// T-junction), beyond half a wall thickness, metres.
pub const OPENING_END_CLEARANCE_M: f32 = 0.2;
/// Clear distance kept between two openings in the same wall, metres.
pub const OPENING_GAP_M: f32 = 0.3;
/// Least wall left above any opening (a lintel), metres.
pub const MIN_LINTEL_M: f32 = 0.15;
/// Chance that an interior wall that could hold a door but is not on the spanning tree gets one
/// anyway (a loop in the plan).
const EXTRA_DOOR_CHANCE: f64 = 0.2;
/// Chance of a second exterior door.
const SECOND_ENTRANCE_CHANCE: f64 = 0.3;
/// Grid of split positions, metres.
const SPLIT_STEP_M: f32 = 0.25;
/// Least distance between two parallel wall centre lines that are not the same line, metres.
const MIN_LINE_GAP_M: f32 = 0.3;
/// Tolerance on lengths, metres.
const EPS_M: f32 = 1e-4;

/// The rooms and openings of a house, before any geometry.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Floorplan {
    pub rooms: Vec<Room>,
    pub walls: Vec<Wall>,
    pub doors: Vec<Door>,
    pub windows: Vec<Window>,
}

/// Why no floorplan could be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FloorplanError {
    #[error("no room type can be assigned: {0}")]
    NoRoomType(String),
    /// A plan rule of a room type cannot be met; names the type and the rule.
    #[error("room type '{room_type}': rule {rule} cannot be met: {reason}")]
    Rule { room_type: String, rule: String, reason: String },
    /// Some room cannot be reached through doors (rooms too small to hold a door between them).
    #[error("room {room} cannot be reached through a door: --min-room is too small for doors of {min_door_m} m")]
    Unreachable { room: u32, min_door_m: f32 },
    /// No exterior wall is long enough for a front door.
    #[error("no exterior wall is long enough for a door")]
    NoEntrance,
}

/// Builds the floorplan for `config` with room types from `room_types`.
pub fn generate(config: &GeneratorConfig, room_types: &[RoomType]) -> Result<Floorplan, FloorplanError> {
    if room_types.is_empty() {
        return Err(FloorplanError::NoRoomType("library is empty".into()));
    }
    let mut rng = scene_gen_core::rng::stream(config.seed, "floorplan");
    let rects = split_envelope(config, &mut rng);
    let types = assign_types(&rects, room_types, &mut rng)?;
    let rooms: Vec<Room> = rects
        .iter()
        .zip(&types)
        .enumerate()
        .map(|(i, (r, &t))| Room { id: i as u32, room_type: room_types[t].name.clone(), min: r.min, max: r.max })
        .collect();
    let mut walls = build_walls(&rooms, config);
    let entrance_allowed: Vec<bool> = types.iter().map(|&t| room_types[t].rules.entrance).collect();
    let doors = place_doors(config, &rooms, &entrance_allowed, &mut walls, &mut rng)?;
    let windows = place_windows(config, &rooms, &mut walls, &mut rng);
    for wall in &mut walls {
        wall.openings.sort_by(|a, b| a.offset_m.total_cmp(&b.offset_m));
    }
    Ok(Floorplan { rooms, walls, doors, windows })
}

/// Most rooms with every side at least `min_room_m` that a guillotine split of a
/// `width_m` x `depth_m` envelope holds.
#[must_use]
pub fn max_rooms(width_m: f32, depth_m: f32, min_room_m: f32) -> u32 {
    fit(width_m, min_room_m) * fit(depth_m, min_room_m)
}

fn fit(len: f32, min: f32) -> u32 {
    (((len + EPS_M) / min).floor() as u32).max(1)
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Rect {
    min: Vec2,
    max: Vec2,
}

impl Rect {
    fn size(&self) -> Vec2 {
        self.max - self.min
    }
    fn capacity(&self, m: f32) -> u32 {
        max_rooms(self.size().x, self.size().y, m)
    }
}

/// Rounds to whole millimetres, so that equal coordinates computed along different paths are
/// bit-identical and wall lines can be matched exactly.
fn round_mm(v: f32) -> f32 {
    (v * 1000.0).round() / 1000.0
}

/// Split positions (absolute coordinates) along one axis of `[lo, hi]` that leave both parts at
/// least `m` long and do not fall within [`MIN_LINE_GAP_M`] of an existing parallel wall line
/// (`lines`) without lying on it: such near misses would make slivers of wall and jogs
/// thinner than a wall.
fn split_positions(lo: f32, hi: f32, m: f32, lines: &[f32]) -> Vec<f32> {
    let mut out: Vec<f32> = lines.iter().copied().filter(|&c| c > lo && c < hi).collect();
    let mut d = m;
    while lo + d <= hi - m + EPS_M {
        out.push(round_mm(lo + d));
        d += SPLIT_STEP_M;
    }
    out.push(round_mm(hi - m));
    out.retain(|&c| c - lo >= m - EPS_M && hi - c >= m - EPS_M);
    out.retain(|&c| lines.iter().all(|&x| x == c || (x - c).abs() >= MIN_LINE_GAP_M));
    out.sort_by(f32::total_cmp);
    out.dedup();
    out
}

/// The guillotine split of the envelope, rooms sorted south to north, then west to east.
fn split_envelope(config: &GeneratorConfig, rng: &mut ChaCha8Rng) -> Vec<Rect> {
    let m = config.min_room_m;
    let e = config.envelope;
    let envelope = Rect { min: Vec2::ZERO, max: Vec2::new(e.width_m, e.depth_m) };
    let target = rng.random_range(1..=envelope.capacity(m)) as usize;
    let mut leaves = vec![envelope];
    while leaves.len() < target {
        let total: u32 = leaves.iter().map(|r| r.capacity(m)).sum();
        let lines: [Vec<f32>; 2] = [0, 1].map(|axis| {
            let mut l: Vec<f32> = leaves.iter().flat_map(|r| [r.min[axis], r.max[axis]]).collect();
            l.sort_by(f32::total_cmp);
            l.dedup();
            l
        });
        // Every split that keeps the target reachable: (leaf, axis, position).
        let mut options: Vec<(usize, usize, f32)> = Vec::new();
        for (i, leaf) in leaves.iter().enumerate() {
            let others = total - leaf.capacity(m);
            for (axis, axis_lines) in lines.iter().enumerate() {
                for c in split_positions(leaf.min[axis], leaf.max[axis], m, axis_lines) {
                    let (a, b) = split_rect(leaf, axis, c);
                    if (others + a.capacity(m) + b.capacity(m)) as usize >= target {
                        options.push((i, axis, c));
                    }
                }
            }
        }
        if options.is_empty() {
            break; // only when min_room_m does not sit on the millimetre grid; fewer rooms is fine
        }
        // Pick a leaf first (uniformly among splittable ones), then a split of it, so long
        // leaves with many positions do not dominate.
        let mut splittable: Vec<usize> = options.iter().map(|o| o.0).collect();
        splittable.dedup();
        let leaf = splittable[rng.random_range(0..splittable.len())];
        let of_leaf: Vec<_> = options.iter().filter(|o| o.0 == leaf).collect();
        let &(i, axis, c) = of_leaf[rng.random_range(0..of_leaf.len())];
        let (a, b) = split_rect(&leaves[i], axis, c);
        leaves[i] = a;
        leaves.push(b);
    }
    leaves.sort_by(|a, b| a.min.y.total_cmp(&b.min.y).then(a.min.x.total_cmp(&b.min.x)));
    leaves
}

fn split_rect(r: &Rect, axis: usize, c: f32) -> (Rect, Rect) {
    let mut a = *r;
    let mut b = *r;
    a.max[axis] = c;
    b.min[axis] = c;
    (a, b)
}

/// Least and most rooms of one type in a plan of `n` rooms.
fn type_bounds(rules: &PlanRules, n: u32) -> (u32, u32) {
    if n < rules.min_plan_rooms {
        return (0, 0);
    }
    let required = u32::from(rules.required_from_rooms.is_some_and(|r| n >= r));
    let min = rules.min_per_plan.max(required);
    (min, rules.max_per_plan.unwrap_or(u32::MAX))
}

/// Index into `room_types` for every room.
fn assign_types(rects: &[Rect], room_types: &[RoomType], rng: &mut ChaCha8Rng) -> Result<Vec<usize>, FloorplanError> {
    let n = rects.len() as u32;
    let areas: Vec<f32> = rects.iter().map(|r| r.size().x * r.size().y).collect();
    let mut assigned: Vec<Option<usize>> = vec![None; rects.len()];
    let mut counts = vec![0u32; room_types.len()];
    // The rooms every plan of this size must have.
    let mut slots: Vec<usize> = Vec::new();
    let mut total_min = 0u32;
    for (t, rt) in room_types.iter().enumerate() {
        let (min, max) = type_bounds(&rt.rules, n);
        if rt.rules.min_per_plan > 0 && n < rt.rules.min_plan_rooms {
            return Err(rule_error(
                rt,
                format!("min_per_plan = {}", rt.rules.min_per_plan),
                format!("min_plan_rooms = {} excludes it from this {n}-room plan", rt.rules.min_plan_rooms),
            ));
        }
        if min > max {
            return Err(rule_error(rt, format!("max_per_plan = {max}"), format!("at least {min} are required")));
        }
        total_min += min;
        slots.extend(std::iter::repeat_n(t, min as usize));
    }
    if total_min > n {
        let names: Vec<_> = room_types
            .iter()
            .filter(|rt| type_bounds(&rt.rules, n).0 > 0)
            .map(|rt| format!("{} x{}", rt.name, type_bounds(&rt.rules, n).0))
            .collect();
        let first = room_types.iter().find(|rt| type_bounds(&rt.rules, n).0 > 0).expect("total_min > 0");
        return Err(rule_error(
            first,
            "min_per_plan/required_from_rooms".into(),
            format!("the plan has {n} rooms but the rules require {total_min} ({})", names.join(", ")),
        ));
    }
    // Types with an area preference choose first (so the living room does get the largest
    // room), the rest by larger area bound first. Each slot takes its preferred room among
    // those that leave the remaining slots satisfiable: with only lower bounds on area, the
    // remaining slots fit iff, for every k, at least k free rooms reach the k-th largest bound
    // (Hall's condition for nested sets).
    slots.sort_by(|&a, &b| {
        let (ra, rb) = (&room_types[a].rules, &room_types[b].rules);
        (ra.prefer_area == AreaPreference::Any)
            .cmp(&(rb.prefer_area == AreaPreference::Any))
            .then(rb.min_area_m2.total_cmp(&ra.min_area_m2))
    });
    let satisfiable = |assigned: &[Option<usize>], rest: &[usize]| {
        let mut bounds: Vec<f32> = rest.iter().map(|&t| room_types[t].rules.min_area_m2).collect();
        bounds.sort_by(|a, b| b.total_cmp(a));
        bounds.iter().enumerate().all(|(k, &bound)| {
            (0..areas.len()).filter(|&r| assigned[r].is_none() && areas[r] + EPS_M >= bound).count() > k
        })
    };
    if !satisfiable(&assigned, &slots) {
        let t = *slots
            .iter()
            .max_by(|&&a, &&b| room_types[a].rules.min_area_m2.total_cmp(&room_types[b].rules.min_area_m2))
            .expect("unsatisfiable slots are not empty");
        let rt = &room_types[t];
        return Err(rule_error(
            rt,
            format!("min_area_m2 = {}", rt.rules.min_area_m2),
            "not enough rooms are large enough for the rooms this plan requires".into(),
        ));
    }
    for (i, &t) in slots.iter().enumerate() {
        let mut eligible: Vec<usize> = (0..rects.len())
            .filter(|&r| assigned[r].is_none() && areas[r] + EPS_M >= room_types[t].rules.min_area_m2)
            .collect();
        match room_types[t].rules.prefer_area {
            AreaPreference::Any => eligible.shuffle(rng),
            AreaPreference::Smallest => eligible.sort_by(|&a, &b| areas[a].total_cmp(&areas[b])),
            AreaPreference::Largest => eligible.sort_by(|&a, &b| areas[b].total_cmp(&areas[a])),
        }
        let r = eligible
            .into_iter()
            .find(|&r| {
                assigned[r] = Some(t);
                let ok = satisfiable(&assigned, &slots[i + 1..]);
                assigned[r] = None;
                ok
            })
            .expect("a satisfiable set of slots has a choice that keeps it satisfiable");
        assigned[r] = Some(t);
        counts[t] += 1;
    }
    for r in 0..rects.len() {
        if assigned[r].is_some() {
            continue;
        }
        let eligible: Vec<usize> = (0..room_types.len())
            .filter(|&t| {
                let rules = &room_types[t].rules;
                counts[t] < type_bounds(rules, n).1 && areas[r] + EPS_M >= rules.min_area_m2
            })
            .collect();
        if eligible.is_empty() {
            return Err(FloorplanError::NoRoomType(format!(
                "a room of {:.1} m² in a {n}-room plan: every type has reached max_per_plan or needs more min_area_m2 \
                 or a larger plan (min_plan_rooms)",
                areas[r]
            )));
        }
        let weights: Vec<f32> = eligible.iter().map(|&t| room_types[t].weight.max(0.0)).collect();
        let total: f32 = weights.iter().sum();
        let t = if total > 0.0 {
            let mut x = rng.random_range(0.0..total);
            let mut pick = *eligible.last().expect("non-empty");
            for (&t, &w) in eligible.iter().zip(&weights) {
                if x < w {
                    pick = t;
                    break;
                }
                x -= w;
            }
            pick
        } else {
            eligible[rng.random_range(0..eligible.len())]
        };
        assigned[r] = Some(t);
        counts[t] += 1;
    }
    Ok(assigned.into_iter().map(|t| t.expect("every room assigned")).collect())
}

fn rule_error(rt: &RoomType, rule: String, reason: String) -> FloorplanError {
    FloorplanError::Rule { room_type: rt.name.clone(), rule, reason }
}

/// Wall segments along every room edge, vertical lines (west to east) first, then horizontal
/// lines (south to north).
fn build_walls(rooms: &[Room], config: &GeneratorConfig) -> Vec<Wall> {
    let mut walls = Vec::new();
    for axis in 0..2 {
        // axis 0: lines x = c (walls run along y); axis 1: lines y = c (walls run along x).
        let along = 1 - axis;
        let mut lines: Vec<f32> = rooms.iter().flat_map(|r| [r.min[axis], r.max[axis]]).collect();
        lines.sort_by(f32::total_cmp);
        lines.dedup();
        for c in lines {
            let touching: Vec<&Room> = rooms.iter().filter(|r| r.min[axis] == c || r.max[axis] == c).collect();
            let mut breaks: Vec<f32> = touching.iter().flat_map(|r| [r.min[along], r.max[along]]).collect();
            breaks.sort_by(f32::total_cmp);
            breaks.dedup();
            let mut current: Option<(f32, f32, Option<u32>, Option<u32>)> = None;
            let flush = |seg: Option<(f32, f32, Option<u32>, Option<u32>)>, walls: &mut Vec<Wall>| {
                if let Some((s0, s1, low, high)) = seg {
                    let rooms = match (low, high) {
                        (Some(l), h) => [Some(l), h],
                        (None, h) => [h, None],
                    };
                    let point = |s: f32| if axis == 0 { Vec2::new(c, s) } else { Vec2::new(s, c) };
                    walls.push(Wall {
                        id: walls.len() as u32,
                        a: point(s0),
                        b: point(s1),
                        thickness_m: config.wall_thickness_m,
                        height_m: config.envelope.height_m,
                        rooms,
                        openings: Vec::new(),
                    });
                }
            };
            for pair in breaks.windows(2) {
                let (s0, s1) = (pair[0], pair[1]);
                let mid = 0.5 * (s0 + s1);
                let covers = |r: &&&Room| r.min[along] <= mid && mid <= r.max[along];
                let low = touching.iter().find(|r| r.max[axis] == c && covers(r)).map(|r| r.id);
                let high = touching.iter().find(|r| r.min[axis] == c && covers(r)).map(|r| r.id);
                match current {
                    Some((c0, c1, l, h)) if l == low && h == high && c1 == s0 => current = Some((c0, s1, l, h)),
                    _ => {
                        flush(current.take(), &mut walls);
                        if low.is_some() || high.is_some() {
                            current = Some((s0, s1, low, high));
                        }
                    }
                }
            }
            flush(current, &mut walls);
        }
    }
    walls
}

/// Unit horizontal normal of `wall` pointing away from `room`.
#[must_use]
pub fn normal_away_from(wall: &Wall, room: &Room) -> Vec2 {
    let perp = (wall.b - wall.a).perp().normalize();
    let mid = 0.5 * (wall.a + wall.b);
    if perp.dot(mid - room.center()) < 0.0 { -perp } else { perp }
}

/// Least distance between an opening edge and the end of its wall centre-line segment.
fn end_margin(config: &GeneratorConfig) -> f32 {
    OPENING_END_CLEARANCE_M + 0.5 * config.wall_thickness_m
}

fn can_hold_door(wall: &Wall, config: &GeneratorConfig) -> bool {
    wall.length_m() >= DOOR_WIDTH_M.0 + 2.0 * end_margin(config)
}

fn place_doors(
    config: &GeneratorConfig,
    rooms: &[Room],
    entrance_allowed: &[bool],
    walls: &mut [Wall],
    rng: &mut ChaCha8Rng,
) -> Result<Vec<Door>, FloorplanError> {
    let room_of = |w: &Wall| w.rooms[0].expect("every wall has a room") as usize;
    // Random spanning tree (Kruskal over shuffled edges) plus a few extra loops.
    let mut edges: Vec<usize> = walls
        .iter()
        .enumerate()
        .filter(|(_, w)| w.rooms[1].is_some() && can_hold_door(w, config))
        .map(|(i, _)| i)
        .collect();
    edges.shuffle(rng);
    let mut parent: Vec<usize> = (0..rooms.len()).collect();
    fn find(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    let mut with_door = vec![false; walls.len()];
    for &w in &edges {
        let [Some(a), Some(b)] = walls[w].rooms else { continue };
        let (ra, rb) = (find(&mut parent, a as usize), find(&mut parent, b as usize));
        if ra != rb {
            parent[ra] = rb;
            with_door[w] = true;
        } else if rng.random_bool(EXTRA_DOOR_CHANCE) {
            with_door[w] = true;
        }
    }
    let root = find(&mut parent, 0);
    if let Some(room) = (0..rooms.len()).find(|&r| find(&mut parent, r) != root) {
        return Err(FloorplanError::Unreachable { room: room as u32, min_door_m: DOOR_WIDTH_M.0 });
    }
    let mut exterior: Vec<usize> = walls
        .iter()
        .enumerate()
        .filter(|(_, w)| w.rooms[1].is_none() && can_hold_door(w, config))
        .map(|(i, _)| i)
        .collect();
    if exterior.is_empty() {
        return Err(FloorplanError::NoEntrance);
    }
    // Front doors open into rooms whose type allows one, if any room can have one.
    let allowed: Vec<usize> = exterior.iter().copied().filter(|&w| entrance_allowed[room_of(&walls[w])]).collect();
    if !allowed.is_empty() {
        exterior = allowed;
    }
    exterior.shuffle(rng);
    let entrances = if exterior.len() > 1 && rng.random_bool(SECOND_ENTRANCE_CHANCE) { 2 } else { 1 };
    for &w in &exterior[..entrances] {
        with_door[w] = true;
    }

    let margin = end_margin(config);
    let mut doors = Vec::new();
    for (w, wall) in walls.iter_mut().enumerate() {
        if !with_door[w] {
            continue;
        }
        let len = wall.length_m();
        let width = rng.random_range(DOOR_WIDTH_M.0..=DOOR_WIDTH_M.1).min(len - 2.0 * margin);
        let height = rng.random_range(DOOR_HEIGHT_M.0..=DOOR_HEIGHT_M.1).min(config.envelope.height_m - MIN_LINTEL_M);
        let (lo, hi) = (margin + 0.5 * width, len - margin - 0.5 * width);
        let offset = if hi > lo { rng.random_range(lo..=hi) } else { 0.5 * len };
        let dir = (wall.b - wall.a) / len;
        let centre = wall.a + dir * offset;
        let room0 = &rooms[wall.rooms[0].expect("every wall has a room") as usize];
        let id = doors.len() as u32;
        doors.push(Door {
            id,
            rooms: wall.rooms,
            wall: w as u32,
            center: Vec3::new(centre.x, centre.y, 0.5 * height),
            width_m: width,
            height_m: height,
            normal: normal_away_from(wall, room0),
            leaf: None,
        });
        wall.openings.push(Opening {
            kind: OpeningKind::Door,
            id,
            offset_m: offset,
            width_m: width,
            sill_m: 0.0,
            height_m: height,
        });
    }
    Ok(doors)
}

/// Free stretches `[s0, s1]` of a wall: clear of its ends and of the openings it has.
fn free_intervals(wall: &Wall, margin: f32) -> Vec<(f32, f32)> {
    let mut free = vec![(margin, wall.length_m() - margin)];
    for o in &wall.openings {
        let (b0, b1) = (o.offset_m - 0.5 * o.width_m - OPENING_GAP_M, o.offset_m + 0.5 * o.width_m + OPENING_GAP_M);
        free = free
            .into_iter()
            .flat_map(|(s0, s1)| [(s0, s1.min(b0)), (s0.max(b1), s1)])
            .filter(|(s0, s1)| s1 > s0)
            .collect();
    }
    free
}

fn place_windows(config: &GeneratorConfig, rooms: &[Room], walls: &mut [Wall], rng: &mut ChaCha8Rng) -> Vec<Window> {
    let margin = end_margin(config);
    let h = config.envelope.height_m;
    let mut windows = Vec::new();
    for room in rooms {
        let exterior: Vec<usize> = walls
            .iter()
            .enumerate()
            .filter(|(_, w)| w.rooms == [Some(room.id), None])
            .filter(|(_, w)| free_intervals(w, margin).iter().any(|(s0, s1)| s1 - s0 >= WINDOW_WIDTH_M.0))
            .map(|(i, _)| i)
            .collect();
        if exterior.is_empty() {
            continue;
        }
        let forced = exterior[rng.random_range(0..exterior.len())];
        for w in exterior {
            if w != forced && !rng.random_bool(0.7) {
                continue;
            }
            let wall = &mut walls[w];
            let mut free = free_intervals(wall, margin);
            free.retain(|(s0, s1)| s1 - s0 >= WINDOW_WIDTH_M.0);
            // One window per free stretch, or two in a long one.
            let mut spans = Vec::new();
            for (s0, s1) in free {
                let mid = 0.5 * (s0 + s1);
                if s1 - s0 >= 2.0 * WINDOW_WIDTH_M.0 + OPENING_GAP_M + 3.0 && rng.random_bool(0.5) {
                    spans.push((s0, mid - 0.5 * OPENING_GAP_M));
                    spans.push((mid + 0.5 * OPENING_GAP_M, s1));
                } else {
                    spans.push((s0, s1));
                }
            }
            // Keep at most two windows per wall; the forced wall always keeps one.
            spans.shuffle(rng);
            spans.truncate(2);
            let len = wall.length_m();
            let dir = (wall.b - wall.a) / len;
            for (s0, s1) in spans {
                let width = rng.random_range(WINDOW_WIDTH_M.0..=WINDOW_WIDTH_M.1.min(s1 - s0));
                let offset = rng.random_range(s0 + 0.5 * width..=s1 - 0.5 * width);
                let sill_max = WINDOW_SILL_M.1.min(h - MIN_LINTEL_M - WINDOW_HEIGHT_M.0).max(WINDOW_SILL_M.0);
                let sill = rng.random_range(WINDOW_SILL_M.0..=sill_max);
                let height = rng.random_range(WINDOW_HEIGHT_M.0..=WINDOW_HEIGHT_M.1).min(h - MIN_LINTEL_M - sill);
                let centre = wall.a + dir * offset;
                let id = windows.len() as u32;
                windows.push(Window {
                    id,
                    room: room.id,
                    wall: w as u32,
                    center: Vec3::new(centre.x, centre.y, sill + 0.5 * height),
                    width_m: width,
                    height_m: height,
                    normal: normal_away_from(wall, room),
                });
                wall.openings.push(Opening {
                    kind: OpeningKind::Window,
                    id,
                    offset_m: offset,
                    width_m: width,
                    sill_m: sill,
                    height_m: height,
                });
            }
        }
    }
    windows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::library::Library;
    use crate::scene::Envelope;

    fn plan(seed: u64, width_m: f32, depth_m: f32) -> Floorplan {
        let config = GeneratorConfig {
            seed,
            envelope: Envelope { width_m, depth_m, height_m: 3.0 },
            ..GeneratorConfig::default()
        };
        generate(&config, &Library::embedded().unwrap().rooms).unwrap()
    }

    #[test]
    fn max_rooms_counts_whole_rooms() {
        assert_eq!(max_rooms(15.0, 15.0, 5.0), 9);
        assert_eq!(max_rooms(10.5, 5.0, 5.0), 2);
        assert_eq!(max_rooms(20.0, 10.0, 5.0), 8);
        assert_eq!(max_rooms(14.9, 14.9, 5.0), 4);
    }

    #[test]
    fn same_seed_same_plan_and_seeds_differ() {
        assert_eq!(plan(3, 15.0, 15.0), plan(3, 15.0, 15.0));
        let distinct: std::collections::BTreeSet<String> =
            (0..20).map(|s| format!("{:?}", plan(s, 15.0, 15.0).rooms)).collect();
        assert!(distinct.len() > 10, "{}", distinct.len());
    }

    #[test]
    fn walls_have_one_room_per_side() {
        for seed in 0..50 {
            let p = plan(seed, 15.0, 15.0);
            for w in &p.walls {
                assert!(w.rooms[0].is_some() && w.rooms[0] != w.rooms[1], "{w:?}");
                // Both rooms touch the wall along its whole length.
                for r in w.rooms.iter().flatten() {
                    let room = &p.rooms[*r as usize];
                    for pt in [w.a, w.b] {
                        assert!(pt.cmpge(room.min).all() && pt.cmple(room.max).all(), "{w:?} {room:?}");
                    }
                }
            }
        }
    }
}
