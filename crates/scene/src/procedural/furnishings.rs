//! Furnishings: the furniture of a lived-in house that is not a detection target (wardrobes,
//! bookshelves, nightstands, kitchen counters, fridges, stoves). Back at -Y against the wall,
//! front at +Y.

use glam::{Vec2, Vec3};
use rand_chacha::ChaCha8Rng;

use super::Draw;
use super::builder::MeshBuilder;

/// Small things standing on a top at height `z` inside the rectangle `lo..hi` (cups, bowls,
/// bottles, a stack of books, a kettle): the clutter of a lived-in surface.
/// Nothing stands between `keep_clear.0` and `keep_clear.1` along x (a sink).
fn clutter(b: &mut MeshBuilder, lo: Vec2, hi: Vec2, z: f32, count: u32, keep_clear: (f32, f32), rng: &mut ChaCha8Rng) {
    for _ in 0..count {
        let c = Vec2::new(rng.between(lo.x + 0.08, hi.x - 0.08), rng.between(lo.y + 0.08, hi.y - 0.08));
        if c.x > keep_clear.0 - 0.12 && c.x < keep_clear.1 + 0.12 {
            continue;
        }
        small_thing(b, c, z, rng);
    }
}

/// The farthest any [`small_thing`] reaches from its centre in the floor plane, metres.
pub(crate) const SMALL_THING_REACH_M: f32 = 0.14;

/// One small thing standing at `c` on a top at height `z`: a cup, a bowl, a bottle, a stack
/// of books or a kettle.
pub(crate) fn small_thing(b: &mut MeshBuilder, c: Vec2, z: f32, rng: &mut ChaCha8Rng) {
    match rng.count(0, 4) {
        0 => b.frustum(
            "ceramic",
            glam::Mat4::from_translation(c.extend(z)),
            0.035,
            0.045,
            0.1,
            10,
            Some("ceramic"),
            None,
        ),
        1 => {
            b.frustum("ceramic", glam::Mat4::from_translation(c.extend(z)), 0.05, 0.1, 0.07, 12, Some("ceramic"), None)
        }
        2 => {
            let r = rng.between(0.03, 0.045);
            let h = rng.between(0.2, 0.3);
            let glass = rng.pick(&["plastic", "ceramic", "metal"]);
            b.cylinder(glass, c.extend(z), r, h * 0.75, 10);
            b.frustum(
                glass,
                glam::Mat4::from_translation(c.extend(z + h * 0.75)),
                r,
                r * 0.35,
                h * 0.25,
                10,
                None,
                Some(glass),
            );
        }
        3 => {
            let mut top = z;
            for _ in 0..rng.count(1, 4) {
                let size = Vec3::new(rng.between(0.14, 0.22), rng.between(0.1, 0.16), rng.between(0.02, 0.04));
                let frame = glam::Mat4::from_translation(c.extend(top + size.z * 0.5))
                    * glam::Mat4::from_rotation_z(rng.between(-0.3, 0.3));
                b.box_in(rng.pick(&["fabric", "plastic", "leather", "picture"]), frame, size);
                top += size.z;
            }
        }
        _ => {
            let r = rng.between(0.07, 0.09);
            b.frustum(
                "metal",
                glam::Mat4::from_translation(c.extend(z)),
                r,
                r * 0.8,
                0.18,
                12,
                Some("metal"),
                Some("plastic"),
            );
            b.cuboid(
                "plastic",
                c.extend(z + 0.05) + Vec3::new(r * 0.9, -0.01, 0.0),
                c.extend(z + 0.15) + Vec3::new(r * 0.9 + 0.03, 0.01, 0.0),
            );
        }
    }
}

/// A handle on a front at `centre` (on the front face), vertical or horizontal.
fn handle(b: &mut MeshBuilder, centre: Vec3, vertical: bool) {
    let half = if vertical { Vec3::new(0.008, 0.0, 0.07) } else { Vec3::new(0.07, 0.0, 0.008) };
    b.cuboid("metal", centre - half, centre + half + Vec3::Y * 0.02);
}

/// Door fronts covering the box `x0..x1`, `z0..z1` on the front face at `y`, `n` side by side,
/// with handles at their meeting edges.
#[allow(clippy::too_many_arguments)]
fn doors(b: &mut MeshBuilder, surface: &'static str, x0: f32, x1: f32, z0: f32, z1: f32, y: f32, n: u32) {
    let w = (x1 - x0) / n as f32;
    for i in 0..n {
        let a = x0 + w * i as f32;
        b.cuboid(surface, Vec3::new(a + 0.003, y, z0 + 0.003), Vec3::new(a + w - 0.003, y + 0.018, z1 - 0.003));
        let hx = if i % 2 == 0 { a + w - 0.05 } else { a + 0.05 };
        handle(b, Vec3::new(hx, y + 0.018, (z0 + z1) * 0.5), (z1 - z0) > 0.5);
    }
}

/// A wardrobe: a carcass on a plinth or feet, two to four doors, now and then a drawer row.
pub(super) fn wardrobe(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let surface = rng.pick(&["wood", "wood", "plastic", "paint"]);
    let (hx, hy) = (s.x * 0.5, s.y * 0.5);
    let base = rng.between(0.04, 0.12);
    b.cuboid(surface, Vec3::new(-hx + 0.02, -hy, 0.0), Vec3::new(hx - 0.02, hy - 0.04, base));
    b.cuboid(surface, Vec3::new(-hx, -hy, base), Vec3::new(hx, hy - 0.02, s.z));
    let n = ((s.x / rng.between(0.45, 0.6)).round() as u32).clamp(2, 4);
    let drawers = if rng.chance(0.4) { rng.between(0.25, 0.4) } else { 0.0 };
    doors(&mut b, surface, -hx + 0.01, hx - 0.01, base + drawers, s.z - 0.02, hy - 0.02, n);
    if drawers > 0.0 {
        doors(&mut b, surface, -hx + 0.01, hx - 0.01, base, base + drawers, hy - 0.02, 2);
    }
    b
}

/// A bookshelf: sides, three to six shelves, rows of books of drawn heights and colours, some
/// leaning, now and then a box or a vase.
pub(super) fn bookshelf(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let surface = rng.pick(&["wood", "wood", "paint", "metal"]);
    let (hx, hy) = (s.x * 0.5, s.y * 0.5);
    let t = 0.02;
    for x in [-hx, hx - t] {
        b.cuboid(surface, Vec3::new(x, -hy, 0.0), Vec3::new(x + t, hy, s.z));
    }
    b.cuboid(surface, Vec3::new(-hx + t, -hy, 0.0), Vec3::new(hx - t, -hy + 0.01, s.z));
    let shelves = ((s.z / rng.between(0.3, 0.4)).floor() as u32).clamp(3, 6);
    let step = (s.z - t) / shelves as f32;
    for i in 0..=shelves {
        let z = step * i as f32;
        b.cuboid(surface, Vec3::new(-hx + t, -hy, z), Vec3::new(hx - t, hy, z + t));
    }
    let covers = ["fabric", "plastic", "linen", "leather", "picture"];
    for i in 0..shelves {
        let z = step * i as f32 + t;
        let clear = step - t;
        let mut x = -hx + t + rng.between(0.0, 0.1);
        let end = hx - t;
        while x < end - 0.03 {
            if rng.chance(0.12) {
                // A gap, or an ornament in it.
                let gap = rng.between(0.08, 0.2).min(end - x);
                if rng.chance(0.5) && gap > 0.1 {
                    let r = (gap * 0.35).min(clear * 0.3);
                    b.cylinder(
                        rng.pick(&["ceramic", "pot", "glass"]),
                        Vec3::new(x + gap * 0.5, 0.0, z),
                        r,
                        clear * rng.between(0.4, 0.8),
                        10,
                    );
                }
                x += gap;
                continue;
            }
            let w = rng.between(0.015, 0.05).min(end - x);
            let h = clear * rng.between(0.6, 0.92);
            let d = s.y * rng.between(0.6, 0.9);
            b.cuboid(rng.pick(&covers), Vec3::new(x, -hy + 0.01, z), Vec3::new(x + w, -hy + 0.01 + d, z + h));
            x += w + 0.002;
        }
    }
    b
}

/// A nightstand: a small cabinet on legs or a plinth with a drawer or two and an open shelf.
pub(super) fn nightstand(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let surface = rng.pick(&["wood", "wood", "paint", "plastic"]);
    let (hx, hy) = (s.x * 0.5, s.y * 0.5);
    let legs = if rng.chance(0.5) { rng.between(0.08, 0.2) } else { 0.0 };
    if legs > 0.0 {
        b.legs(rng.pick(&["wood", "metal"]), Vec2::new(hx, hy), 0.03, legs);
    }
    b.cuboid(surface, Vec3::new(-hx, -hy, legs), Vec3::new(hx, hy - 0.02, s.z));
    let drawers = rng.count(1, 2);
    let h = (s.z - legs) * rng.between(0.4, 0.7) / drawers as f32;
    for i in 0..drawers {
        let z1 = s.z - 0.02 - h * i as f32;
        b.cuboid(surface, Vec3::new(-hx + 0.015, hy - 0.02, z1 - h + 0.005), Vec3::new(hx - 0.015, hy - 0.002, z1));
        handle(&mut b, Vec3::new(0.0, hy - 0.002, z1 - h * 0.5), false);
    }
    let things = rng.count(0, 2);
    clutter(&mut b, Vec2::new(-hx, -hy), Vec2::new(hx, hy), s.z, things, (f32::MAX, f32::MAX), rng);
    b
}

/// A run of kitchen base cabinets with a worktop, a plinth, doors and drawers, now and then a
/// sink with its tap.
pub(super) fn counter(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let body = rng.pick(&["wood", "paint", "plastic"]);
    let top = rng.pick(&["ceramic", "wood", "tile_wall", "metal"]);
    let (hx, hy) = (s.x * 0.5, s.y * 0.5);
    let worktop = rng.between(0.03, 0.05);
    let plinth = rng.between(0.08, 0.12);
    let under = s.z - worktop;
    let sink = rng.chance(0.5) && s.x > 0.9;
    let sink_depth = 0.18;
    b.cuboid(body, Vec3::new(-hx, -hy, 0.0), Vec3::new(hx, hy - 0.08, plinth));
    // The carcass; with a sink its top stops under the bowl, which the worktop frames.
    let carcass_top = if sink { under - sink_depth - 0.01 } else { under };
    b.cuboid(body, Vec3::new(-hx, -hy, plinth), Vec3::new(hx, hy - 0.03, carcass_top));
    let units = ((s.x / rng.between(0.45, 0.65)).round() as u32).max(1);
    let w = s.x / units as f32;
    for i in 0..units {
        let x0 = -hx + w * i as f32;
        if rng.chance(0.35) {
            let rows = rng.count(2, 3);
            let h = (under - plinth) / rows as f32;
            for r in 0..rows {
                let z = plinth + h * r as f32;
                b.cuboid(
                    body,
                    Vec3::new(x0 + 0.003, hy - 0.03, z + 0.003),
                    Vec3::new(x0 + w - 0.003, hy - 0.012, z + h - 0.003),
                );
                handle(&mut b, Vec3::new(x0 + w * 0.5, hy - 0.012, z + h * 0.75), false);
            }
        } else {
            doors(&mut b, body, x0, x0 + w, plinth, under, hy - 0.03, 1);
        }
    }
    let mut sink_span = (f32::MAX, f32::MAX);
    if sink {
        // A sink: the worktop and the carcass's top rails around a bowl, a tap behind it.
        let cx = rng.between(-hx + 0.35, hx - 0.35);
        let (bw, bd) = (rng.between(0.35, 0.5).min(s.x * 0.4), (s.y - 0.2).min(0.4));
        sink_span = (cx - bw * 0.5, cx + bw * 0.5);
        let (y0, y1) = (-bd * 0.5 + 0.03, bd * 0.5 + 0.03);
        let (x0, x1) = (cx - bw * 0.5, cx + bw * 0.5);
        for (material, z0, z1, back) in [(body, carcass_top, under, hy - 0.03), (top, under, s.z, hy)] {
            b.cuboid(material, Vec3::new(-hx, -hy, z0), Vec3::new(x0, back, z1));
            b.cuboid(material, Vec3::new(x1, -hy, z0), Vec3::new(hx, back, z1));
            b.cuboid(material, Vec3::new(x0, -hy, z0), Vec3::new(x1, y0, z1));
            b.cuboid(material, Vec3::new(x0, y1, z0), Vec3::new(x1, back, z1));
        }
        let bowl = Vec2::new(bw * 0.5, bd * 0.5);
        b.shell("metal", Vec2::new(cx, 0.03), under - sink_depth, bowl, [8.0, 8.0], sink_depth, 0.01, 0.01, 24);
        b.cylinder("metal", Vec3::new(cx, -hy + 0.05, s.z), 0.015, 0.25, 8);
        b.cuboid(
            "metal",
            Vec3::new(cx - 0.01, -hy + 0.05, s.z + 0.22),
            Vec3::new(cx + 0.01, -hy + 0.05 + bd * 0.5, s.z + 0.24),
        );
    } else {
        b.cuboid(top, Vec3::new(-hx, -hy, under), Vec3::new(hx, hy, s.z));
    }
    let things = rng.count(0, 3);
    clutter(&mut b, Vec2::new(-hx, -hy), Vec2::new(hx, -hy + s.y * 0.5), s.z, things, sink_span, rng);
    b
}

/// A fridge: one tall door or a fridge over a freezer, handles, feet.
pub(super) fn fridge(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let shell = rng.pick(&["plastic", "metal", "paint"]);
    let (hx, hy) = (s.x * 0.5, s.y * 0.5);
    b.cuboid("plastic", Vec3::new(-hx + 0.03, -hy + 0.03, 0.0), Vec3::new(hx - 0.03, hy - 0.08, 0.03));
    b.cuboid(shell, Vec3::new(-hx, -hy, 0.03), Vec3::new(hx, hy - 0.04, s.z));
    let split = if rng.chance(0.7) { s.z * rng.between(0.3, 0.4) } else { 0.03 };
    let right = rng.chance(0.5);
    for (z0, z1) in [(0.03, split), (split, s.z)] {
        if z1 - z0 < 0.1 {
            continue;
        }
        b.cuboid(shell, Vec3::new(-hx + 0.005, hy - 0.04, z0 + 0.005), Vec3::new(hx - 0.005, hy, z1 - 0.005));
        let x = if right { hx - 0.06 } else { -hx + 0.06 };
        let (a, c) = if z0 < 0.1 { (z1 - 0.25, z1 - 0.05) } else { (z0 + 0.05, z0 + 0.05 + (z1 - z0).min(0.6)) };
        b.cuboid("metal", Vec3::new(x - 0.012, hy, a), Vec3::new(x + 0.012, hy + 0.04, c));
    }
    b
}

/// A free-standing stove: an oven door with a window and handle, knobs, four hobs on top.
pub(super) fn stove(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let shell = rng.pick(&["metal", "plastic", "paint"]);
    let (hx, hy) = (s.x * 0.5, s.y * 0.5);
    b.cuboid(shell, Vec3::new(-hx, -hy, 0.0), Vec3::new(hx, hy - 0.02, s.z - 0.02));
    b.cuboid("screen", Vec3::new(-hx + 0.005, -hy + 0.005, s.z - 0.02), Vec3::new(hx - 0.005, hy - 0.025, s.z));
    let door_top = s.z * rng.between(0.62, 0.72);
    b.cuboid(shell, Vec3::new(-hx + 0.02, hy - 0.02, 0.1), Vec3::new(hx - 0.02, hy, door_top));
    b.cuboid("screen", Vec3::new(-hx + 0.1, hy, 0.22), Vec3::new(hx - 0.1, hy + 0.004, door_top - 0.12));
    b.cuboid(
        "metal",
        Vec3::new(-hx + 0.08, hy + 0.01, door_top - 0.07),
        Vec3::new(hx - 0.08, hy + 0.04, door_top - 0.05),
    );
    let knobs = rng.count(4, 6);
    for i in 0..knobs {
        let x = -hx + s.x * (i as f32 + 0.5) / knobs as f32;
        b.frustum(
            "plastic",
            glam::Mat4::from_translation(Vec3::new(x, hy - 0.02, s.z - 0.08))
                * glam::Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2),
            0.018,
            0.018,
            0.03,
            8,
            None,
            Some("plastic"),
        );
    }
    let r = (s.x.min(s.y) * 0.18).min(0.11);
    for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        let c = Vec3::new(sx * s.x * 0.24, sy * s.y * 0.22 - 0.01, s.z);
        b.cylinder("metal", c, r * rng.between(0.7, 1.0), 0.008, 14);
    }
    b
}
