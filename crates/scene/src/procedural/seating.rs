//! Sofas and chairs. Back of every piece at -Y, front at +Y.

use glam::{Mat4, Vec2, Vec3};
use rand_chacha::ChaCha8Rng;

use super::Draw;
use super::builder::MeshBuilder;

/// What a sofa-like piece is made of and stands on, drawn once per piece.
struct Upholstery {
    cover: &'static str,
    /// Leg height (0 for a plinth reaching the floor).
    leg_m: f32,
    leg_surface: &'static str,
    round_legs: bool,
    /// 0 none, 1 box arms, 2 rolled arms (a box with a roll on top).
    arms: u32,
    arm_m: f32,
    seat_z: f32,
    back_m: f32,
    loose_back_cushions: bool,
}

fn upholstery(s: Vec3, rng: &mut ChaCha8Rng, arms_optional: bool) -> Upholstery {
    let plinth = rng.chance(0.25);
    Upholstery {
        cover: if rng.chance(0.75) { "fabric" } else { "leather" },
        leg_m: if plinth { 0.0 } else { rng.between(0.04, 0.16) },
        leg_surface: rng.pick(&["wood", "wood", "metal", "plastic"]),
        round_legs: rng.chance(0.5),
        arms: if arms_optional && rng.chance(0.15) { 0 } else { rng.pick(&[1, 1, 2]) },
        arm_m: rng.between(0.1, 0.22).min(s.x * 0.18),
        seat_z: s.z * rng.between(0.48, 0.56),
        back_m: rng.between(0.14, 0.24).min(s.y * 0.3),
        loose_back_cushions: rng.chance(0.6),
    }
}

/// Legs under the corners (and the middle of long pieces) of the rectangle `lo..hi`.
fn feet(b: &mut MeshBuilder, u: &Upholstery, lo: Vec2, hi: Vec2) {
    if u.leg_m <= 0.0 {
        return;
    }
    let t = 0.05;
    let mut xs = vec![lo.x + t, hi.x - t];
    if hi.x - lo.x > 1.8 {
        xs.push((lo.x + hi.x) * 0.5);
    }
    for x in xs {
        for y in [lo.y + t, hi.y - t] {
            if u.round_legs {
                b.frustum(
                    u.leg_surface,
                    Mat4::from_translation(Vec3::new(x, y, 0.0)),
                    0.018,
                    0.025,
                    u.leg_m,
                    8,
                    Some(u.leg_surface),
                    None,
                );
            } else {
                b.cuboid(u.leg_surface, Vec3::new(x - 0.025, y - 0.025, 0.0), Vec3::new(x + 0.025, y + 0.025, u.leg_m));
            }
        }
    }
}

/// One arm from `y0` to `y1` between `x0` and `x1`, of height `top`.
fn arm(b: &mut MeshBuilder, u: &Upholstery, x0: f32, x1: f32, y0: f32, y1: f32, top: f32) {
    match u.arms {
        0 => {}
        1 => b.cuboid(u.cover, Vec3::new(x0, y0, u.leg_m), Vec3::new(x1, y1, top)),
        _ => {
            let r = (x1 - x0) * 0.55;
            b.cuboid(u.cover, Vec3::new(x0, y0, u.leg_m), Vec3::new(x1, y1, top - r * 0.6));
            let roll = Mat4::from_translation(Vec3::new((x0 + x1) * 0.5, y0, top - r))
                * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
            b.frustum(u.cover, roll, r, r, y1 - y0, 12, Some(u.cover), Some(u.cover));
        }
    }
}

/// A straight sofa of `seats` seats, with an optional chaise on the right (`chaise` is its
/// depth beyond the seat's front).
fn sofa_body(b: &mut MeshBuilder, s: Vec3, u: &Upholstery, seats: u32, chaise: f32, rng: &mut ChaCha8Rng) {
    let (hx, d) = (s.x * 0.5, s.y - chaise);
    let (y0, y1) = (-s.y * 0.5, -s.y * 0.5 + d);
    let base_z = u.leg_m + rng.between(0.12, 0.2).min(u.seat_z - u.leg_m - 0.08);
    let arm_w = if u.arms == 0 { 0.0 } else { u.arm_m };
    let arm_top = u.seat_z + rng.between(0.12, 0.24);
    feet(b, u, Vec2::new(-hx, y0), Vec2::new(hx, y1));
    // Frame: base under the seats and the back.
    b.cuboid(u.cover, Vec3::new(-hx + arm_w, y0, u.leg_m), Vec3::new(hx - arm_w, y1, base_z));
    b.cuboid(
        u.cover,
        Vec3::new(-hx + arm_w, y0, base_z),
        Vec3::new(hx - arm_w, y0 + u.back_m, s.z * rng.between(0.7, 0.95)),
    );
    arm(b, u, -hx, -hx + arm_w, y0, y1, arm_top);
    let inner = s.x - 2.0 * arm_w;
    let w = inner / seats as f32;
    let gap = rng.between(0.004, 0.015);
    for i in 0..seats {
        let x0 = -hx + arm_w + w * i as f32 + gap;
        let x1 = x0 + w - 2.0 * gap;
        let front = if chaise > 0.0 && i == seats - 1 { s.y * 0.5 - 0.02 } else { y1 - 0.02 };
        b.cuboid(u.cover, Vec3::new(x0, y0 + u.back_m, base_z), Vec3::new(x1, front, u.seat_z));
        if u.loose_back_cushions {
            let tilt =
                Mat4::from_translation(Vec3::new((x0 + x1) * 0.5, y0 + u.back_m + 0.08, (u.seat_z + s.z) * 0.5 - 0.02))
                    * Mat4::from_rotation_x(rng.between(0.05, 0.2));
            b.box_in(u.cover, tilt, Vec3::new(x1 - x0, 0.14, (s.z - u.seat_z) * 0.9));
        }
    }
    if chaise > 0.0 {
        // The chaise's base and its own arm on the right.
        let x0 = hx - arm_w - w;
        b.cuboid(u.cover, Vec3::new(x0, y1, u.leg_m), Vec3::new(hx - arm_w, s.y * 0.5, base_z));
        feet(b, u, Vec2::new(x0, y1), Vec2::new(hx, s.y * 0.5));
        arm(b, u, hx - arm_w, hx, y0, s.y * 0.5, arm_top);
    } else {
        arm(b, u, hx - arm_w, hx, y0, y1, arm_top);
    }
    // Throw pillows leaning in the corners.
    for side in [-1.0_f32, 1.0] {
        if rng.chance(0.35) {
            let size = rng.between(0.3, 0.45).min((s.x - 2.0 * arm_w) * 0.35);
            let c = Vec3::new(side * (hx - arm_w - size * 0.5 - 0.03), y0 + u.back_m + 0.12, u.seat_z + size * 0.45);
            let frame = Mat4::from_translation(c)
                * Mat4::from_rotation_z(side * rng.between(0.1, 0.4))
                * Mat4::from_rotation_x(0.3);
            b.box_in(rng.pick(&["fabric", "linen", "leather"]), frame, Vec3::new(size, 0.12, size));
        }
    }
}

/// A straight sofa, one to four seats by its width.
pub(super) fn sofa(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let u = upholstery(s, rng, true);
    let seats = ((s.x - 2.0 * u.arm_m) / rng.between(0.55, 0.8)).round().clamp(1.0, 4.0) as u32;
    let mut b = MeshBuilder::default();
    sofa_body(&mut b, s, &u, seats, 0.0, rng);
    b
}

/// An L-shaped sofa: a chaise reaching forward on the right.
pub(super) fn sofa_corner(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let u = upholstery(s, rng, false);
    let seats = ((s.x - 2.0 * u.arm_m) / rng.between(0.6, 0.8)).round().clamp(2.0, 4.0) as u32;
    let chaise = (s.y - rng.between(0.85, 1.0)).max(0.3);
    let mut b = MeshBuilder::default();
    sofa_body(&mut b, s, &u, seats, chaise, rng);
    b
}

/// An upholstered armchair: a one-seat sofa.
pub(super) fn armchair(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut u = upholstery(s, rng, false);
    u.loose_back_cushions = rng.chance(0.4);
    let mut b = MeshBuilder::default();
    sofa_body(&mut b, s, &u, 1, 0.0, rng);
    b
}

/// Four legs under a seat of half extents `half` reaching `top`; the back legs (-Y) may rise
/// to `back_top` to carry the back.
fn chair_legs(b: &mut MeshBuilder, surface: &'static str, half: Vec2, t: f32, top: f32, back_top: f32, round: bool) {
    for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        let c = Vec2::new(sx * (half.x - t * 0.5), sy * (half.y - t * 0.5));
        let h = if sy < 0.0 { back_top } else { top };
        if round {
            b.frustum(
                surface,
                Mat4::from_translation(c.extend(0.0)),
                t * 0.35,
                t * 0.5,
                h,
                8,
                Some(surface),
                Some(surface),
            );
        } else {
            b.cuboid(surface, Vec3::new(c.x - t * 0.5, c.y - t * 0.5, 0.0), Vec3::new(c.x + t * 0.5, c.y + t * 0.5, h));
        }
    }
}

/// A dining chair: four legs, a seat, and a back of slats, rails, a panel or upholstery.
pub(super) fn dining_chair(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let frame = rng.pick(&["wood", "wood", "metal", "plastic"]);
    let half = Vec2::new(s.x * 0.5, s.y * 0.5);
    let seat_z = rng.between(0.42, 0.48).min(s.z * 0.55);
    let seat_t = rng.between(0.025, 0.05);
    let t = rng.between(0.03, 0.05);
    chair_legs(&mut b, frame, half, t, seat_z - seat_t, s.z, rng.chance(0.4));
    b.cuboid(frame, Vec3::new(-half.x, -half.y, seat_z - seat_t), Vec3::new(half.x, half.y, seat_z));
    if rng.chance(0.5) {
        b.cuboid(
            rng.pick(&["fabric", "leather"]),
            Vec3::new(-half.x + 0.02, -half.y + t, seat_z),
            Vec3::new(half.x - 0.02, half.y - 0.02, seat_z + 0.03),
        );
    }
    if rng.chance(0.5) {
        // Stretchers between the legs.
        let z = rng.between(0.12, 0.2);
        for y in [-half.y + t * 0.5, half.y - t * 0.5] {
            b.cuboid(frame, Vec3::new(-half.x + t, y - 0.01, z), Vec3::new(half.x - t, y + 0.01, z + 0.02));
        }
    }
    let (x0, x1, y) = (-half.x + t, half.x - t, -half.y);
    let (z0, z1) = (seat_z + rng.between(0.08, 0.15), s.z - rng.between(0.0, 0.04));
    match rng.count(0, 3) {
        0 => {
            // Vertical slats under a top rail.
            let n = rng.count(2, 6);
            b.cuboid(frame, Vec3::new(x0, y, z1 - 0.06), Vec3::new(x1, y + t * 0.7, z1));
            let w = (x1 - x0) / (2 * n + 1) as f32;
            for i in 0..n {
                let x = x0 + w * (2 * i + 1) as f32;
                b.cuboid(frame, Vec3::new(x, y + 0.005, z0), Vec3::new(x + w, y + t * 0.6, z1 - 0.06));
            }
        }
        1 => {
            // Horizontal rails (a ladder back).
            let n = rng.count(2, 4);
            for i in 0..n {
                let z = z0 + (z1 - z0 - 0.05) * i as f32 / (n - 1) as f32;
                b.cuboid(frame, Vec3::new(x0, y, z), Vec3::new(x1, y + t * 0.7, z + 0.05));
            }
        }
        2 => b.cuboid(frame, Vec3::new(x0, y, z0), Vec3::new(x1, y + 0.02, z1)),
        _ => b.cuboid(rng.pick(&["fabric", "leather"]), Vec3::new(-half.x, y, z0), Vec3::new(half.x, y + 0.06, z1)),
    }
    b
}

/// A stool: a round or square seat on three or four legs, a foot rest, now and then a low back.
pub(super) fn stool(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let frame = rng.pick(&["metal", "wood"]);
    let seat = rng.pick(&["leather", "wood", "plastic", "fabric"]);
    let back = rng.chance(0.3);
    let seat_z = if back { s.z * rng.between(0.65, 0.75) } else { s.z };
    let r = s.x.min(s.y) * 0.5;
    let round = rng.chance(0.6);
    let legs = if round { rng.count(3, 4) } else { 4 };
    let leg_r = r * rng.between(0.6, 0.85);
    let t = rng.between(0.012, 0.025);
    for i in 0..legs {
        let a = std::f32::consts::TAU * (i as f32 + 0.5) / legs as f32;
        let c = Vec2::new(a.cos(), a.sin()) * leg_r;
        b.frustum(frame, Mat4::from_translation(c.extend(0.0)), t, t, seat_z - 0.04, 6, Some(frame), None);
    }
    let rest_z = seat_z * rng.between(0.3, 0.45);
    b.frustum(frame, Mat4::from_translation(Vec3::new(0.0, 0.0, rest_z)), leg_r + t, leg_r + t, 0.02, 16, None, None);
    if round {
        b.cylinder(seat, Vec3::new(0.0, 0.0, seat_z - 0.04), r, 0.04, 20);
    } else {
        b.cuboid(seat, Vec3::new(-r, -r, seat_z - 0.04), Vec3::new(r, r, seat_z));
    }
    if back {
        b.cuboid(frame, Vec3::new(-r * 0.7, -r, seat_z), Vec3::new(-r * 0.5, -r + 0.02, s.z - 0.08));
        b.cuboid(frame, Vec3::new(r * 0.5, -r, seat_z), Vec3::new(r * 0.7, -r + 0.02, s.z - 0.08));
        b.cuboid(seat, Vec3::new(-r * 0.8, -r, s.z - 0.1), Vec3::new(r * 0.8, -r + 0.03, s.z));
    }
    b
}
