//! Beds: headboard at -Y against the wall, foot at +Y.

use glam::{Mat4, Vec2, Vec3};
use rand_chacha::ChaCha8Rng;

use super::Draw;
use super::builder::MeshBuilder;

/// A bed of width `s.x`, length `s.y` and headboard height `s.z`: a frame on legs or a
/// plinth, a mattress, a duvet or a bare sheet, pillows by width, a headboard of one of four
/// kinds and now and then a footboard and a throw.
pub(super) fn bed(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let (hx, hy) = (s.x * 0.5, s.y * 0.5);
    let frame = rng.pick(&["wood", "wood", "metal", "fabric"]);
    let board_t = rng.between(0.04, 0.1);
    let y_head = -hy + board_t;
    let leg_m = if rng.chance(0.3) { 0.0 } else { rng.between(0.06, 0.22) };
    let frame_top = rng.between(0.25, 0.35);
    let mattress_top = (frame_top + rng.between(0.18, 0.28)).min(s.z - 0.3);
    if leg_m > 0.0 {
        let t = rng.between(0.05, 0.09);
        b.legs(frame, Vec2::new(hx, hy - board_t * 0.5), t, leg_m);
        b.cuboid(frame, Vec3::new(-hx, y_head, leg_m), Vec3::new(hx, hy, frame_top));
    } else {
        // A plinth set back from the edges, the frame overhanging it.
        b.cuboid(frame, Vec3::new(-hx + 0.08, y_head + 0.08, 0.0), Vec3::new(hx - 0.08, hy - 0.08, 0.1));
        b.cuboid(frame, Vec3::new(-hx, y_head, 0.1), Vec3::new(hx, hy, frame_top));
    }
    let inset = rng.between(0.01, 0.04);
    b.cuboid(
        "linen",
        Vec3::new(-hx + inset, y_head + inset, frame_top),
        Vec3::new(hx - inset, hy - inset, mattress_top),
    );
    let duvet = rng.chance(0.8);
    let pillow_y = y_head + rng.between(0.05, 0.1);
    if duvet {
        let fold = pillow_y + rng.between(0.45, 0.7);
        let hang = rng.between(0.1, 0.25);
        let cloth = rng.pick(&["fabric", "linen"]);
        b.cuboid(
            cloth,
            Vec3::new(-hx - 0.02, fold, mattress_top),
            Vec3::new(hx + 0.02, hy + 0.02, mattress_top + 0.05),
        );
        b.cuboid(cloth, Vec3::new(-hx - 0.02, fold, mattress_top - hang), Vec3::new(-hx, hy + 0.02, mattress_top));
        b.cuboid(cloth, Vec3::new(hx, fold, mattress_top - hang), Vec3::new(hx + 0.02, hy + 0.02, mattress_top));
        if rng.chance(0.5) {
            // The turned-down edge.
            b.cuboid(
                cloth,
                Vec3::new(-hx - 0.02, fold, mattress_top + 0.05),
                Vec3::new(hx + 0.02, fold + rng.between(0.12, 0.22), mattress_top + 0.07),
            );
        }
    }
    let pillows = if s.x < 1.2 {
        1
    } else if s.x > 1.7 && rng.chance(0.4) {
        3
    } else {
        2
    };
    let w = (s.x - 0.16) / pillows as f32;
    for i in 0..pillows {
        let x0 = -hx + 0.08 + w * i as f32 + 0.03;
        let tilt = Mat4::from_translation(Vec3::new(x0 + (w - 0.06) * 0.5, pillow_y + 0.2, mattress_top + 0.07))
            * Mat4::from_rotation_x(rng.between(0.1, 0.35))
            * Mat4::from_rotation_z(rng.between(-0.06, 0.06));
        b.box_in("linen", tilt, Vec3::new(w - 0.06, 0.36, rng.between(0.1, 0.15)));
    }
    headboard(&mut b, s, frame, board_t, mattress_top, rng);
    if rng.chance(0.35) {
        let top = (mattress_top + rng.between(-0.1, 0.15)).max(frame_top + 0.05);
        b.cuboid(frame, Vec3::new(-hx, hy - board_t * 0.6, 0.0), Vec3::new(hx, hy, top));
    }
    if duvet && rng.chance(0.4) {
        // A throw across the foot, hanging over its end.
        let y = hy - rng.between(0.2, 0.35);
        b.cuboid(
            "fabric",
            Vec3::new(-hx - 0.03, y, mattress_top + 0.05),
            Vec3::new(hx + 0.03, hy + 0.03, mattress_top + 0.08),
        );
        b.cuboid(
            "fabric",
            Vec3::new(-hx - 0.03, hy + 0.02, mattress_top - 0.2),
            Vec3::new(hx + 0.03, hy + 0.04, mattress_top + 0.08),
        );
    }
    b
}

/// The headboard at -Y: a panel, an upholstered board, slats between posts, or posts with a
/// rail.
fn headboard(b: &mut MeshBuilder, s: Vec3, frame: &'static str, t: f32, mattress_top: f32, rng: &mut ChaCha8Rng) {
    let (hx, y0) = (s.x * 0.5, -s.y * 0.5);
    match rng.count(0, 3) {
        0 => b.cuboid(frame, Vec3::new(-hx, y0, 0.0), Vec3::new(hx, y0 + t, s.z)),
        1 => {
            b.cuboid(frame, Vec3::new(-hx, y0, 0.0), Vec3::new(hx, y0 + t * 0.5, s.z - 0.05));
            // Upholstered panels, tufted as vertical channels.
            let n = rng.count(1, 6);
            let w = s.x / n as f32;
            let cover = rng.pick(&["fabric", "leather"]);
            for i in 0..n {
                let x = -hx + w * i as f32;
                b.cuboid(
                    cover,
                    Vec3::new(x + 0.005, y0 + t * 0.5, mattress_top - 0.05),
                    Vec3::new(x + w - 0.005, y0 + t, s.z),
                );
            }
        }
        2 => {
            let post = rng.between(0.05, 0.08);
            for x in [-hx, hx - post] {
                b.cuboid(frame, Vec3::new(x, y0, 0.0), Vec3::new(x + post, y0 + t, s.z));
            }
            b.cuboid(frame, Vec3::new(-hx + post, y0, s.z - 0.08), Vec3::new(hx - post, y0 + t, s.z - 0.02));
            let n = rng.count(4, 12);
            let inner = s.x - 2.0 * post;
            let w = inner / (2 * n + 1) as f32;
            for i in 0..n {
                let x = -hx + post + w * (2 * i + 1) as f32;
                b.cuboid(
                    frame,
                    Vec3::new(x, y0 + t * 0.25, mattress_top - 0.1),
                    Vec3::new(x + w, y0 + t * 0.75, s.z - 0.08),
                );
            }
        }
        _ => {
            let r = rng.between(0.025, 0.045);
            for x in [-hx + r, hx - r] {
                b.cylinder(frame, Vec3::new(x, y0 + t * 0.5, 0.0), r, s.z - r, 10);
                b.ellipsoid(frame, Vec3::new(x, y0 + t * 0.5, s.z - r), Vec3::splat(r * 1.2), 8, 5);
            }
            for z in [mattress_top + 0.1, s.z - 0.15] {
                b.cuboid(frame, Vec3::new(-hx + r, y0 + t * 0.3, z), Vec3::new(hx - r, y0 + t * 0.7, z + 0.05));
            }
        }
    }
}
