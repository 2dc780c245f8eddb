//! Computers and screens: TVs on stands, monitors, laptops. The display faces +Y.

use glam::{Mat4, Vec3};
use rand_chacha::ChaCha8Rng;

use super::Draw;
use super::builder::MeshBuilder;

/// A display panel of `size` (width, thickness, height) with its lower edge centred on
/// `bottom`: a housing and the screen on its front face inside a bezel.
fn panel(b: &mut MeshBuilder, bottom: Vec3, size: Vec3, bezel: f32) {
    let h = size * 0.5;
    b.cuboid("plastic", bottom + Vec3::new(-h.x, -h.y, 0.0), bottom + Vec3::new(h.x, h.y, size.z));
    b.cuboid(
        "screen",
        bottom + Vec3::new(-h.x + bezel, h.y, bezel),
        bottom + Vec3::new(h.x - bezel, h.y + 0.003, size.z - bezel),
    );
}

/// A TV on a media unit (closed cabinet, open shelves, or a console on legs), on feet or a
/// central stand.
pub(super) fn tv(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let (hx, hy) = (s.x * 0.5, s.y * 0.5);
    let unit = rng.pick(&["wood", "wood", "plastic", "metal"]);
    let unit_top = s.z * rng.between(0.33, 0.45);
    match rng.count(0, 2) {
        0 => {
            let plinth = rng.between(0.0, 0.06);
            b.cuboid(unit, Vec3::new(-hx + 0.02, -hy + 0.02, 0.0), Vec3::new(hx - 0.02, hy - 0.03, plinth.max(0.001)));
            b.cuboid(unit, Vec3::new(-hx, -hy, plinth), Vec3::new(hx, hy, unit_top));
            let doors = rng.count(2, 4);
            let w = s.x / doors as f32;
            for i in 0..doors {
                let x = -hx + w * i as f32;
                b.cuboid(
                    unit,
                    Vec3::new(x + 0.005, hy, plinth + 0.01),
                    Vec3::new(x + w - 0.005, hy + 0.012, unit_top - 0.01),
                );
            }
        }
        1 => {
            // Open shelves between side panels.
            for x in [-hx, hx - 0.03] {
                b.cuboid(unit, Vec3::new(x, -hy, 0.0), Vec3::new(x + 0.03, hy, unit_top));
            }
            let shelves = rng.count(2, 3);
            for i in 0..shelves {
                let z = (unit_top - 0.025) * i as f32 / (shelves - 1) as f32;
                b.cuboid(unit, Vec3::new(-hx + 0.03, -hy, z), Vec3::new(hx - 0.03, hy, z + 0.025));
            }
        }
        _ => {
            let legs = rng.between(0.1, 0.2).min(unit_top * 0.5);
            b.legs("metal", glam::Vec2::new(hx - 0.03, hy - 0.03), 0.03, legs);
            b.cuboid(unit, Vec3::new(-hx, -hy, legs), Vec3::new(hx, hy, unit_top));
        }
    }
    let diagonal_aspect = 16.0 / 9.0;
    let screen_w = s.x * rng.between(0.6, 0.92);
    let screen_h = (screen_w / diagonal_aspect).min(s.z - unit_top - 0.08);
    let thick = rng.between(0.03, 0.07);
    let stand_h = rng.between(0.04, 0.1);
    if rng.chance(0.5) {
        // A central stand.
        b.cuboid("metal", Vec3::new(-0.15, -0.12, unit_top), Vec3::new(0.15, 0.1, unit_top + 0.015));
        b.cuboid("metal", Vec3::new(-0.04, -0.05, unit_top), Vec3::new(0.04, -0.02, unit_top + stand_h + 0.05));
    } else {
        // Two feet near the ends of the panel.
        for x in [-screen_w * 0.4, screen_w * 0.4] {
            b.cuboid("metal", Vec3::new(x - 0.02, -0.12, unit_top), Vec3::new(x + 0.02, 0.1, unit_top + 0.012));
            b.cuboid(
                "metal",
                Vec3::new(x - 0.01, -0.04, unit_top),
                Vec3::new(x + 0.01, -0.02, unit_top + stand_h + 0.04),
            );
        }
    }
    panel(
        &mut b,
        Vec3::new(0.0, -0.03, unit_top + stand_h),
        Vec3::new(screen_w, thick, screen_h),
        rng.between(0.005, 0.025),
    );
    b
}

/// A desk monitor: a plate, round or V-shaped foot, a neck and a panel of common aspect.
pub(super) fn monitor(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let foot = rng.pick(&["metal", "plastic"]);
    match rng.count(0, 2) {
        0 => b.cuboid(foot, Vec3::new(-0.11, -0.12, 0.0), Vec3::new(0.11, 0.06, 0.015)),
        1 => b.cylinder(foot, Vec3::new(0.0, -0.03, 0.0), 0.1, 0.015, 16),
        _ => {
            for yaw in [0.5_f32, -0.5] {
                let frame = Mat4::from_translation(Vec3::new(0.0, -0.02, 0.008)) * Mat4::from_rotation_z(yaw);
                b.box_in(foot, frame, Vec3::new(0.04, 0.26, 0.016));
            }
        }
    }
    let neck_h = rng.between(0.12, 0.2);
    b.cuboid(foot, Vec3::new(-0.025, -0.09, 0.0), Vec3::new(0.025, -0.06, neck_h + 0.08));
    let aspect = rng.pick(&[16.0 / 9.0, 16.0 / 10.0, 21.0 / 9.0]);
    let width = s.x;
    let height = width / aspect;
    let bottom = neck_h * rng.between(0.4, 0.8);
    panel(
        &mut b,
        Vec3::new(0.0, -0.04, bottom),
        Vec3::new(width, rng.between(0.02, 0.05), height),
        rng.between(0.006, 0.02),
    );
    if rng.chance(0.4) {
        // A chin under the screen.
        b.cuboid("plastic", Vec3::new(-width * 0.5, -0.02, bottom - 0.03), Vec3::new(width * 0.5, 0.0, bottom));
    }
    b
}

/// An open laptop: base with keyboard and touchpad, lid opened 95-130 degrees.
pub(super) fn laptop(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let (hx, hy) = (s.x * 0.5, s.y * 0.5);
    let shell = rng.pick(&["metal", "plastic"]);
    let base = rng.between(0.012, 0.022);
    b.cuboid(shell, Vec3::new(-hx, -hy, 0.0), Vec3::new(hx, hy, base));
    b.cuboid("plastic", Vec3::new(-hx + 0.02, -hy + 0.02, base), Vec3::new(hx - 0.02, 0.0, base + 0.002));
    b.cuboid("plastic", Vec3::new(-0.05, 0.02, base), Vec3::new(0.05, hy - 0.015, base + 0.001));
    let open = rng.between(95.0_f32, 130.0).to_radians();
    let lid_len = s.y * rng.between(0.9, 1.0);
    // The lid turns about the back edge, from lying flat (0) to `open`.
    let hinge =
        Mat4::from_translation(Vec3::new(0.0, -hy, base)) * Mat4::from_rotation_x(open - std::f32::consts::FRAC_PI_2);
    b.box_in(
        shell,
        hinge * Mat4::from_translation(Vec3::new(0.0, -0.004, lid_len * 0.5)),
        Vec3::new(s.x, 0.008, lid_len),
    );
    let bezel = rng.between(0.008, 0.02);
    b.box_in(
        "screen",
        hinge * Mat4::from_translation(Vec3::new(0.0, 0.001, lid_len * 0.5)),
        Vec3::new(s.x - 2.0 * bezel, 0.002, lid_len - 2.0 * bezel),
    );
    b
}
