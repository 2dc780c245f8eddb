//! Lamps: floor, table and desk lamps with bases, stems and shades of several forms.

use std::f32::consts::TAU;

use glam::{Mat4, Vec2, Vec3};
use rand_chacha::ChaCha8Rng;

use super::Draw;
use super::builder::MeshBuilder;

/// A shade from `z` up by `h`, bottom radius `r`: a drum, an empire (wider at the bottom) or a
/// bell (a drum over a cone).
fn shade(b: &mut MeshBuilder, centre: Vec2, z: f32, r: f32, h: f32, rng: &mut ChaCha8Rng) {
    let at = Mat4::from_translation(centre.extend(z));
    match rng.count(0, 2) {
        0 => b.frustum("lampshade", at, r, r, h, 16, None, Some("lampshade")),
        1 => b.frustum("lampshade", at, r, r * rng.between(0.5, 0.75), h, 16, None, Some("lampshade")),
        _ => {
            b.frustum("lampshade", at, r, r * 0.55, h * 0.5, 16, None, None);
            b.frustum(
                "lampshade",
                at * Mat4::from_translation(Vec3::Z * (h * 0.5)),
                r * 0.55,
                r * 0.45,
                h * 0.5,
                16,
                None,
                Some("lampshade"),
            );
        }
    }
}

/// A floor lamp: a disc, square or tripod base, a pole, a shade, now and then a reading arm.
pub(super) fn floor(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let metal = rng.pick(&["metal", "wood", "plastic"]);
    let shade_h = s.z * rng.between(0.14, 0.22);
    let shade_r = s.z * rng.between(0.1, 0.15);
    let pole_top = s.z - shade_h * 0.7;
    match rng.count(0, 2) {
        0 => b.cylinder(metal, Vec3::ZERO, shade_r * rng.between(0.6, 0.9), 0.03, 16),
        1 => {
            let w = shade_r * 0.7;
            b.cuboid(metal, Vec3::new(-w, -w, 0.0), Vec3::new(w, w, 0.03));
        }
        _ => {
            // A tripod: three splayed legs meeting under the shade.
            let spread = shade_r * rng.between(0.8, 1.1);
            let leg_h = pole_top * rng.between(0.5, 0.7);
            for i in 0..3 {
                let a = TAU * i as f32 / 3.0;
                let foot = Vec3::new(a.cos() * spread, a.sin() * spread, 0.0);
                let dir = (Vec3::Z * leg_h - foot).normalize();
                let frame = Mat4::from_translation(foot) * Mat4::from_quat(glam::Quat::from_rotation_arc(Vec3::Z, dir));
                b.frustum(metal, frame, 0.012, 0.012, (Vec3::Z * leg_h - foot).length(), 6, Some(metal), Some(metal));
            }
        }
    }
    b.cylinder(metal, Vec3::Z * 0.03, rng.between(0.01, 0.018), pole_top - 0.03, 6);
    shade(&mut b, Vec2::ZERO, s.z - shade_h, shade_r, shade_h, rng);
    if rng.chance(0.3) {
        // A small reading lamp on an arm.
        let z = pole_top * rng.between(0.55, 0.7);
        let reach = shade_r * 1.2;
        b.cuboid(metal, Vec3::new(-0.006, 0.0, z - 0.006), Vec3::new(0.006, reach, z + 0.006));
        b.frustum(
            "lampshade",
            Mat4::from_translation(Vec3::new(0.0, reach, z - 0.08)),
            0.05,
            0.025,
            0.08,
            10,
            None,
            Some("lampshade"),
        );
    }
    b
}

/// A table lamp: a vase, column, block or stacked-ball base, a neck and a shade.
pub(super) fn table(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let base = rng.pick(&["ceramic", "ceramic", "metal", "wood", "plastic"]);
    let shade_h = s.z * rng.between(0.3, 0.42);
    let shade_r = s.z * rng.between(0.22, 0.32);
    let body_h = (s.z - shade_h) * rng.between(0.55, 0.8);
    let r = shade_r * rng.between(0.35, 0.6);
    match rng.count(0, 3) {
        0 => {
            b.cylinder(base, Vec3::ZERO, r * 0.7, 0.02, 12);
            b.ellipsoid(base, Vec3::Z * (body_h * 0.5 + 0.01), Vec3::new(r, r, body_h * 0.5), 12, 7);
        }
        1 => b.frustum(base, Mat4::IDENTITY, r, r * rng.between(0.5, 1.0), body_h, 12, Some(base), Some(base)),
        2 => b.cuboid(base, Vec3::new(-r * 0.8, -r * 0.8, 0.0), Vec3::new(r * 0.8, r * 0.8, body_h)),
        _ => {
            let balls = rng.count(2, 4);
            let step = body_h / balls as f32;
            for i in 0..balls {
                let rr = (step * 0.5).min(r);
                b.ellipsoid(base, Vec3::Z * (step * (i as f32 + 0.5)), Vec3::new(rr, rr, step * 0.5), 10, 6);
            }
        }
    }
    let shade_z = s.z - shade_h;
    b.cylinder("metal", Vec3::Z * (body_h - 0.005), 0.01, (shade_z - body_h + 0.03).max(0.02), 6);
    shade(&mut b, Vec2::ZERO, shade_z, shade_r, shade_h, rng);
    b
}

/// A desk lamp: a weighted foot, two arm segments at drawn angles and a head pointing down.
pub(super) fn desk(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let metal = rng.pick(&["metal", "plastic"]);
    let foot = Vec3::new(0.0, -s.z * 0.1, 0.0);
    if rng.chance(0.5) {
        b.cylinder(metal, foot, rng.between(0.07, 0.1), 0.025, 14);
    } else {
        b.cuboid(metal, foot + Vec3::new(-0.08, -0.06, 0.0), foot + Vec3::new(0.08, 0.06, 0.025));
    }
    let lower_len = s.z * rng.between(0.5, 0.65);
    let upper_len = s.z * rng.between(0.45, 0.65);
    let lower = Mat4::from_translation(foot + Vec3::Z * 0.025) * Mat4::from_rotation_x(rng.between(0.1, 0.5));
    b.frustum(metal, lower, 0.01, 0.01, lower_len, 6, None, Some(metal));
    let elbow = lower.transform_point3(Vec3::Z * lower_len);
    let upper = Mat4::from_translation(elbow) * Mat4::from_rotation_x(-rng.between(0.9, 1.5));
    b.frustum(metal, upper, 0.01, 0.01, upper_len, 6, None, Some(metal));
    let wrist = upper.transform_point3(Vec3::Z * upper_len);
    let head = Mat4::from_translation(wrist) * Mat4::from_rotation_x(-rng.between(2.4, 2.9));
    let (r0, r1) = if rng.chance(0.6) { (0.03, rng.between(0.06, 0.09)) } else { (0.05, 0.05) };
    b.frustum(metal, head, r0, r1, rng.between(0.1, 0.14), 12, Some(metal), None);
    b
}
