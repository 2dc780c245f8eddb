//! Tables and desks: a flat top others stand on, and a base of legs, trestles, pedestals or
//! drawer units.

use glam::{Mat4, Vec2, Vec3};
use rand_chacha::ChaCha8Rng;

use super::Draw;
use super::builder::MeshBuilder;

/// Four legs of side or diameter `t` under the rectangle of half extents `half`, inset by
/// `inset`; square, round or tapered.
fn four_legs(b: &mut MeshBuilder, surface: &'static str, half: Vec2, inset: f32, t: f32, height: f32, style: u32) {
    for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        let c = Vec2::new(sx * (half.x - inset - t * 0.5), sy * (half.y - inset - t * 0.5));
        match style {
            0 => b.cuboid(surface, (c - Vec2::splat(t * 0.5)).extend(0.0), (c + Vec2::splat(t * 0.5)).extend(height)),
            1 => b.cylinder(surface, c.extend(0.0), t * 0.5, height, 10),
            _ => b.frustum(
                surface,
                Mat4::from_translation(c.extend(0.0)),
                t * 0.3,
                t * 0.5,
                height,
                8,
                Some(surface),
                Some(surface),
            ),
        }
    }
}

/// Rails under the edge of a rectangular top (an apron), `depth` deep.
fn apron(b: &mut MeshBuilder, surface: &'static str, half: Vec2, inset: f32, top_z: f32, depth: f32) {
    let (x, y) = (half.x - inset, half.y - inset);
    let t = 0.02;
    b.cuboid(surface, Vec3::new(-x, -y, top_z - depth), Vec3::new(x, -y + t, top_z));
    b.cuboid(surface, Vec3::new(-x, y - t, top_z - depth), Vec3::new(x, y, top_z));
    b.cuboid(surface, Vec3::new(-x, -y + t, top_z - depth), Vec3::new(-x + t, y - t, top_z));
    b.cuboid(surface, Vec3::new(x - t, -y + t, top_z - depth), Vec3::new(x, y - t, top_z));
}

/// A rectangular dining table on four legs, two trestles or two pedestals.
pub(super) fn dining(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let top = rng.pick(&["wood", "wood", "plastic", "ceramic"]);
    let base = rng.pick(&["wood", "metal"]);
    let half = Vec2::new(s.x, s.y) * 0.5;
    let thick = rng.between(0.025, 0.06);
    let under = s.z - thick;
    b.cuboid(top, (-half).extend(under), half.extend(s.z));
    let inset = rng.between(0.02, 0.12);
    match rng.count(0, 3) {
        0 | 1 => {
            let t = rng.between(0.04, 0.08);
            four_legs(&mut b, base, half, inset, t, under, rng.count(0, 2));
            if rng.chance(0.6) {
                apron(&mut b, base, half, inset + t * 0.3, under, rng.between(0.06, 0.12));
            }
        }
        2 => {
            // Trestles: a panel at each end joined by a stretcher.
            let x = half.x - inset - 0.1;
            for sx in [-1.0, 1.0] {
                b.cuboid(
                    base,
                    Vec3::new(sx * x - 0.03, -half.y + 0.08, 0.0),
                    Vec3::new(sx * x + 0.03, half.y - 0.08, 0.05),
                );
                b.cuboid(base, Vec3::new(sx * x - 0.025, -0.12, 0.05), Vec3::new(sx * x + 0.025, 0.12, under));
            }
            b.cuboid(base, Vec3::new(-x, -0.03, under * 0.35), Vec3::new(x, 0.03, under * 0.45));
        }
        _ => {
            for sx in [-1.0, 1.0] {
                let c = Vec3::new(sx * (half.x * 0.55), 0.0, 0.0);
                b.cylinder(base, c, rng.between(0.15, 0.25).min(half.y * 0.8), 0.03, 16);
                b.cylinder(base, c + Vec3::Z * 0.03, 0.05, under - 0.03, 10);
            }
        }
    }
    b
}

/// A round table (now and then a square one) on a pedestal, a cross foot or legs.
pub(super) fn round(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let top = rng.pick(&["wood", "wood", "plastic", "ceramic"]);
    let base = rng.pick(&["wood", "metal"]);
    let r = s.x.min(s.y) * 0.5;
    let thick = rng.between(0.025, 0.05);
    let under = s.z - thick;
    if rng.chance(0.75) {
        b.cylinder(top, Vec3::new(0.0, 0.0, under), r, thick, rng.count(20, 32));
    } else {
        b.cuboid(top, Vec3::new(-r, -r, under), Vec3::new(r, r, s.z));
    }
    match rng.count(0, 2) {
        0 => {
            let foot = r * rng.between(0.4, 0.6);
            b.frustum(base, Mat4::IDENTITY, foot, foot * rng.between(0.6, 1.0), 0.04, 16, Some(base), Some(base));
            let col = rng.between(0.035, 0.08);
            b.frustum(
                base,
                Mat4::from_translation(Vec3::Z * 0.04),
                col,
                col * rng.between(0.6, 1.2),
                under - 0.04,
                10,
                None,
                None,
            );
        }
        1 => {
            let arm = r * rng.between(0.55, 0.75);
            for yaw in [0.0, std::f32::consts::FRAC_PI_2] {
                b.box_in(
                    base,
                    Mat4::from_translation(Vec3::Z * 0.03) * Mat4::from_rotation_z(yaw),
                    Vec3::new(arm * 2.0, 0.06, 0.06),
                );
            }
            b.cuboid(base, Vec3::new(-0.04, -0.04, 0.06), Vec3::new(0.04, 0.04, under));
        }
        _ => {
            let legs = rng.count(3, 4);
            let t = rng.between(0.03, 0.05);
            for i in 0..legs {
                let a = std::f32::consts::TAU * (i as f32 + 0.5) / legs as f32;
                let c = Vec2::new(a.cos(), a.sin()) * (r * 0.7);
                b.frustum(base, Mat4::from_translation(c.extend(0.0)), t * 0.35, t * 0.5, under, 8, Some(base), None);
            }
        }
    }
    b
}

/// A drawer unit between `x0` and `x1` under a top at `under`, drawers facing +Y.
fn drawer_unit(b: &mut MeshBuilder, surface: &'static str, x0: f32, x1: f32, half_y: f32, under: f32, drawers: u32) {
    b.cuboid(surface, Vec3::new(x0, -half_y + 0.02, 0.0), Vec3::new(x1, half_y - 0.02, under));
    let h = under / drawers as f32;
    for i in 0..drawers {
        let z = h * i as f32;
        let mid = Vec3::new((x0 + x1) * 0.5, half_y - 0.02, z + h * 0.5);
        b.cuboid(
            surface,
            Vec3::new(x0 + 0.01, half_y - 0.02, z + 0.01),
            Vec3::new(x1 - 0.01, half_y - 0.005, z + h - 0.01),
        );
        b.cuboid("metal", mid + Vec3::new(-0.06, 0.015, -0.01), mid + Vec3::new(0.06, 0.03, 0.01));
    }
}

/// A desk: a top on legs, panel ends, or drawer units on one or both sides, now and then a
/// modesty panel at the back.
pub(super) fn desk(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let surface = rng.pick(&["wood", "wood", "plastic"]);
    let half = Vec2::new(s.x, s.y) * 0.5;
    let thick = rng.between(0.025, 0.04);
    let under = s.z - thick;
    b.cuboid(surface, (-half).extend(under), half.extend(s.z));
    let unit_w = rng.between(0.35, 0.45).min(s.x * 0.35);
    let (left, right) = match rng.count(0, 3) {
        0 => (false, false),
        1 => (true, false),
        2 => (false, true),
        _ => (true, true),
    };
    let drawers = rng.count(2, 4);
    let legs = rng.pick(&["metal", surface]);
    let t = rng.between(0.03, 0.05);
    for (side, unit) in [(-1.0_f32, left), (1.0, right)] {
        if unit {
            let (x0, x1) = if side < 0.0 { (-half.x, -half.x + unit_w) } else { (half.x - unit_w, half.x) };
            drawer_unit(&mut b, surface, x0, x1, half.y, under, drawers);
        } else if rng.chance(0.5) {
            let x = side * (half.x - 0.02);
            b.cuboid(surface, Vec3::new(x - 0.02, -half.y + 0.02, 0.0), Vec3::new(x + 0.02, half.y - 0.02, under));
        } else {
            for y in [-half.y + t, half.y - t] {
                let c = Vec2::new(side * (half.x - t), y);
                b.cuboid(legs, (c - Vec2::splat(t * 0.5)).extend(0.0), (c + Vec2::splat(t * 0.5)).extend(under));
            }
        }
    }
    if rng.chance(0.5) {
        b.cuboid(
            surface,
            Vec3::new(-half.x + 0.05, -half.y + 0.03, under * 0.4),
            Vec3::new(half.x - 0.05, -half.y + 0.05, under),
        );
    }
    b
}

/// A coffee table: a rectangular or round top, legs or a solid base, and a shelf below.
pub(super) fn coffee(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let top = rng.pick(&["wood", "plastic", "wood", "ceramic"]);
    let base = rng.pick(&["wood", "metal"]);
    let half = Vec2::new(s.x, s.y) * 0.5;
    let thick = rng.between(0.03, 0.06);
    let under = s.z - thick;
    b.cuboid(top, (-half).extend(under), half.extend(s.z));
    if rng.chance(0.25) {
        // A solid block base, set back from the top's edge.
        let inset = rng.between(0.05, 0.12);
        b.cuboid(base, (-half + Vec2::splat(inset)).extend(0.0), (half - Vec2::splat(inset)).extend(under));
        return b;
    }
    let t = rng.between(0.03, 0.06);
    four_legs(&mut b, base, half, rng.between(0.0, 0.06), t, under, rng.count(0, 2));
    if rng.chance(0.5) {
        let z = rng.between(0.08, under * 0.5);
        let inset = t + 0.02;
        b.cuboid(
            rng.pick(&[base, top]),
            (-half + Vec2::splat(inset)).extend(z),
            (half - Vec2::splat(inset)).extend(z + 0.02),
        );
    }
    b
}
