//! Bathtubs and wash basins: open shells with a real cavity, and their taps. The back (-Y)
//! stands against the wall.

use glam::{Mat4, Vec2, Vec3};
use rand_chacha::ChaCha8Rng;

use super::Draw;
use super::builder::MeshBuilder;

/// A tap rising from `base`, its spout reaching `reach` towards +Y.
fn tap(b: &mut MeshBuilder, base: Vec3, height: f32, reach: f32, rng: &mut ChaCha8Rng) {
    let r = rng.between(0.012, 0.02);
    b.cylinder("metal", base, r, height, 8);
    if rng.chance(0.5) {
        b.cuboid("metal", base + Vec3::new(-r * 0.7, 0.0, height - 2.0 * r), base + Vec3::new(r * 0.7, reach, height));
    } else {
        let spout = Mat4::from_translation(base + Vec3::new(0.0, 0.0, height - r)) * Mat4::from_rotation_x(-1.3);
        b.frustum("metal", spout, r * 0.8, r * 0.6, reach, 8, None, Some("metal"));
    }
    // The handle.
    b.cuboid("metal", base + Vec3::new(-0.05, -0.01, height * 0.6), base + Vec3::new(0.05, 0.01, height * 0.6 + 0.015));
}

/// A built-in tub: a rectangular apron around a cavity of rounded or squarer outline, the tap
/// on the deck at one end.
pub(super) fn built_in_tub(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let half = Vec2::new(s.x, s.y) * 0.5;
    let deck = rng.between(0.06, 0.14);
    let tub_z = s.z * rng.between(0.82, 0.92);
    let inner = rng.between(2.5, 6.0);
    b.shell("ceramic", Vec2::ZERO, 0.0, half, [12.0, inner], tub_z, deck, 0.06, 32);
    if rng.chance(0.5) {
        // A panel front in another finish.
        b.cuboid(
            rng.pick(&["wood", "tile_wall", "plastic"]),
            Vec3::new(-half.x, half.y, 0.0),
            Vec3::new(half.x, half.y + 0.02, tub_z - 0.03),
        );
    }
    let end = if rng.chance(0.5) { -1.0 } else { 1.0 };
    tap(&mut b, Vec3::new(end * (half.x - deck * 0.5), 0.0, tub_z), s.z - tub_z, rng.between(0.08, 0.14), rng);
    b
}

/// A freestanding tub: an oval or rounded-rectangle shell on claw feet or a plinth, with a
/// floor-standing or rim-mounted tap.
pub(super) fn freestanding_tub(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let half = Vec2::new(s.x, s.y) * 0.5;
    let n = rng.between(2.0, 4.0);
    let feet = rng.chance(0.5);
    let z0 = if feet { rng.between(0.1, 0.18) } else { 0.0 };
    let tub_z = s.z * rng.between(0.78, 0.9);
    b.shell("ceramic", Vec2::ZERO, z0, half, [n, n], tub_z - z0, rng.between(0.04, 0.07), 0.06, 40);
    if feet {
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let c = Vec3::new(sx * half.x * 0.65, sy * half.y * 0.55, 0.0);
            b.frustum("metal", Mat4::from_translation(c), 0.05, 0.03, z0 + 0.02, 6, Some("metal"), None);
        }
    } else {
        let inset = half * rng.between(0.55, 0.8);
        b.shell("ceramic", Vec2::ZERO, 0.0, inset, [n, n], 0.03, 0.02, 0.02, 24);
    }
    if rng.chance(0.5) {
        // A floor-standing mixer beside one end.
        let x = if rng.chance(0.5) { -half.x } else { half.x - 0.04 };
        tap(&mut b, Vec3::new(x + 0.02, -half.y * 0.2, 0.0), s.z, 0.15, rng);
    } else {
        tap(&mut b, Vec3::new(0.0, -half.y + 0.03, tub_z), s.z - tub_z, 0.12, rng);
    }
    b
}

/// A bowl of outline exponent `n` sunk into or set on a counter at `top`.
fn bowl(b: &mut MeshBuilder, centre: Vec2, top: f32, half: Vec2, n: f32, depth: f32) {
    b.shell("ceramic", centre, top - depth, half, [n, n], depth, 0.015, 0.015, 28);
}

/// A pedestal basin: a column and a bowl, the tap at the back.
pub(super) fn pedestal_basin(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let rim = s.z * rng.between(0.8, 0.88);
    let depth = rng.between(0.12, 0.2);
    let half = Vec2::new(s.x, s.y) * 0.5;
    let n = rng.between(2.0, 5.0);
    bowl(&mut b, Vec2::ZERO, rim, half, n, depth);
    let column = rim - depth;
    if rng.chance(0.6) {
        let r = rng.between(0.08, 0.13).min(half.y * 0.6);
        b.frustum(
            "ceramic",
            Mat4::from_translation(Vec3::new(0.0, -half.y * 0.2, 0.0)),
            r,
            r * rng.between(0.6, 1.0),
            column,
            12,
            Some("ceramic"),
            None,
        );
    } else {
        let w = rng.between(0.12, 0.2);
        b.cuboid("ceramic", Vec3::new(-w * 0.5, -half.y + 0.02, 0.0), Vec3::new(w * 0.5, -half.y + 0.02 + w, column));
    }
    tap(&mut b, Vec3::new(0.0, -half.y + 0.03, rim), s.z - rim, half.y * 0.6, rng);
    b
}

/// A vanity: a cabinet with doors or drawers, a counter, one bowl (two on wide units) sunk into
/// it or standing on it.
pub(super) fn vanity_basin(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let half = Vec2::new(s.x, s.y) * 0.5;
    let cabinet = rng.pick(&["wood", "wood", "plastic"]);
    let counter_top = s.z * rng.between(0.78, 0.86);
    let plinth = if rng.chance(0.5) { 0.08 } else { 0.0 };
    let vessel = rng.chance(0.35);
    let bowls = if s.x > 1.0 { 2 } else { 1 };
    let counter = if vessel { counter_top - 0.15 } else { counter_top };
    if plinth > 0.0 {
        b.cuboid(cabinet, Vec3::new(-half.x + 0.04, -half.y, 0.0), Vec3::new(half.x - 0.04, half.y - 0.06, plinth));
    } else {
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let c = Vec2::new(sx * (half.x - 0.05), sy * (half.y - 0.05));
            b.cylinder("metal", c.extend(0.0), 0.015, 0.1, 6);
        }
    }
    let body0 = plinth.max(0.1);
    b.cuboid(
        cabinet,
        Vec3::new(-half.x + 0.01, -half.y, body0),
        Vec3::new(half.x - 0.01, half.y - 0.02, counter - 0.03),
    );
    // Fronts: doors or drawers with handles.
    let fronts = rng.count(1, 2) * bowls;
    let w = (s.x - 0.02) / fronts as f32;
    let drawers = rng.chance(0.4);
    for i in 0..fronts {
        let x0 = -half.x + 0.01 + w * i as f32;
        let rows = if drawers { 2 } else { 1 };
        let h = (counter - 0.03 - body0) / rows as f32;
        for r in 0..rows {
            let z = body0 + h * r as f32;
            b.cuboid(
                cabinet,
                Vec3::new(x0 + 0.005, half.y - 0.02, z + 0.005),
                Vec3::new(x0 + w - 0.005, half.y - 0.005, z + h - 0.005),
            );
            let c = Vec3::new(x0 + w * 0.5, half.y, z + h * 0.8);
            b.cuboid("metal", c + Vec3::new(-0.04, -0.005, -0.006), c + Vec3::new(0.04, 0.012, 0.006));
        }
    }
    let slab = rng.pick(&["ceramic", "wood", "tile_wall"]);
    let step = s.x / bowls as f32;
    let bowl_half = Vec2::new((step * 0.5 - 0.08).clamp(0.15, 0.28), (half.y - 0.1).clamp(0.12, 0.2));
    let n = rng.between(2.0, 6.0);
    if vessel {
        b.cuboid(slab, Vec3::new(-half.x, -half.y, counter - 0.03), Vec3::new(half.x, half.y, counter));
        for i in 0..bowls {
            let c = Vec2::new(-half.x + step * (i as f32 + 0.5), 0.02);
            b.shell("ceramic", c, counter, bowl_half * 0.85, [n, n], counter_top - counter, 0.012, 0.015, 28);
            tap(&mut b, Vec3::new(c.x, -half.y + 0.04, counter), s.z - counter, half.y * 0.5, rng);
        }
    } else {
        // A counter with one opening per bowl, each bowl sunk under its opening.
        let mut x = -half.x;
        let (y0, y1) = (0.02 - bowl_half.y, 0.02 + bowl_half.y);
        for i in 0..bowls {
            let cx = -half.x + step * (i as f32 + 0.5);
            let (bx0, bx1) = (cx - bowl_half.x, cx + bowl_half.x);
            b.cuboid(slab, Vec3::new(x, -half.y, counter - 0.03), Vec3::new(bx0, half.y, counter));
            b.cuboid(slab, Vec3::new(bx0, -half.y, counter - 0.03), Vec3::new(bx1, y0, counter));
            b.cuboid(slab, Vec3::new(bx0, y1, counter - 0.03), Vec3::new(bx1, half.y, counter));
            bowl(&mut b, Vec2::new(cx, 0.02), counter - 0.03, bowl_half, n.max(8.0), rng.between(0.1, 0.16));
            tap(&mut b, Vec3::new(cx, -half.y + 0.04, counter), s.z - counter, half.y * 0.45, rng);
            x = bx1;
        }
        b.cuboid(slab, Vec3::new(x, -half.y, counter - 0.03), Vec3::new(half.x, half.y, counter));
    }
    b
}

/// A toilet (a furnishing): a bowl on a pedestal, a seat and lid, a cistern against the wall
/// or a wall-hung pan with its frame boxed in.
pub(super) fn toilet(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let (hx, hy) = (s.x * 0.5, s.y * 0.5);
    let seat_z = rng.between(0.38, 0.44).min(s.z * 0.6);
    let cistern_d = rng.between(0.14, 0.2);
    let bowl_centre = Vec2::new(0.0, -hy + cistern_d + (s.y - cistern_d) * 0.5);
    let bowl_half = Vec2::new(hx * 0.9, (s.y - cistern_d) * 0.5);
    let wall_hung = rng.chance(0.35);
    if wall_hung {
        // The pan hangs from a boxed-in frame that carries the cistern.
        b.cuboid("tile_wall", Vec3::new(-hx, -hy, 0.0), Vec3::new(hx, -hy + cistern_d, s.z));
        b.cuboid(
            "metal",
            Vec3::new(-0.08, -hy + cistern_d, s.z - 0.3),
            Vec3::new(0.08, -hy + cistern_d + 0.01, s.z - 0.2),
        );
        let z0 = seat_z - 0.32;
        b.shell("ceramic", bowl_centre, z0, bowl_half, [2.5, 2.5], seat_z - 0.03 - z0, 0.03, 0.05, 24);
    } else {
        let foot = bowl_half * Vec2::new(0.5, 0.6);
        b.shell("ceramic", bowl_centre, 0.0, foot, [2.5, 2.5], seat_z * 0.5, 0.02, 0.02, 20);
        let z0 = seat_z * 0.45;
        b.shell("ceramic", bowl_centre, z0, bowl_half, [2.5, 2.5], seat_z - 0.03 - z0, 0.03, 0.05, 24);
        let top = s.z;
        b.cuboid("ceramic", Vec3::new(-hx * 0.85, -hy, z0), Vec3::new(hx * 0.85, -hy + cistern_d, top - 0.02));
        b.cuboid("ceramic", Vec3::new(-hx * 0.9, -hy, top - 0.02), Vec3::new(hx * 0.9, -hy + cistern_d + 0.01, top));
        b.cylinder("metal", Vec3::new(hx * 0.5, -hy + cistern_d * 0.5, top), 0.015, 0.01, 8);
    }
    // Seat ring and a lid, up against the cistern or down on the seat.
    let seat = rng.pick(&["plastic", "plastic", "wood"]);
    b.shell(seat, bowl_centre, seat_z - 0.03, bowl_half * 0.98, [2.5, 2.5], 0.025, 0.07, 0.005, 24);
    if rng.chance(0.5) {
        b.shell(seat, bowl_centre, seat_z - 0.005, bowl_half * 0.98, [2.5, 2.5], 0.02, 0.03, 0.017, 24);
    } else {
        let lid_h = (bowl_half.y * 2.0).min(s.z - seat_z);
        let y = -hy + cistern_d + 0.02;
        b.cuboid(
            seat,
            Vec3::new(-bowl_half.x * 0.9, y, seat_z),
            Vec3::new(bowl_half.x * 0.9, y + 0.02, seat_z + lid_h),
        );
    }
    b
}
