//! Potted plants: a pot of one of four forms with soil, and foliage of leaves placed one by
//! one (each an ellipsoid of its own size, tilt and turn) or of clustered crowns.

use std::f32::consts::{FRAC_PI_2, TAU};

use glam::{Mat4, Vec3};
use rand_chacha::ChaCha8Rng;

use super::Draw;
use super::builder::MeshBuilder;

/// The golden angle: successive leaves turned by it never line up (phyllotaxis).
const GOLDEN_ANGLE: f32 = 2.399_963;

/// A pot of top radius `r` and height `h`: tapered, straight, a bowl or a square planter,
/// with soil near its rim. Returns the soil height.
fn pot(b: &mut MeshBuilder, r: f32, h: f32, rng: &mut ChaCha8Rng) -> f32 {
    let surface = rng.pick(&["pot", "pot", "ceramic", "plastic"]);
    match rng.count(0, 3) {
        0 => b.frustum(surface, Mat4::IDENTITY, r * rng.between(0.65, 0.85), r, h, 14, Some(surface), None),
        1 => b.frustum(surface, Mat4::IDENTITY, r, r, h, 14, Some(surface), None),
        2 => {
            b.ellipsoid(surface, Vec3::new(0.0, 0.0, h * 0.55), Vec3::new(r * 1.05, r * 1.05, h * 0.55), 14, 6);
            b.cylinder(surface, Vec3::ZERO, r * 0.5, 0.02, 10);
        }
        _ => b.cuboid(surface, Vec3::new(-r, -r, 0.0), Vec3::new(r, r, h)),
    }
    if rng.chance(0.4) {
        // A rim.
        b.frustum(
            surface,
            Mat4::from_translation(Vec3::Z * (h - 0.03)),
            r * 1.06,
            r * 1.06,
            0.03,
            14,
            Some(surface),
            Some(surface),
        );
    }
    let soil = h - 0.025;
    b.frustum(
        "soil",
        Mat4::from_translation(Vec3::Z * (soil - 0.01)),
        r * 0.92,
        r * 0.92,
        0.01,
        12,
        None,
        Some("soil"),
    );
    soil
}

/// One leaf: a flattened ellipsoid `length` long from `base`, pointing at `yaw` around Z and
/// tilted `tilt` from vertical.
fn leaf(b: &mut MeshBuilder, base: Vec3, yaw: f32, tilt: f32, length: f32, width: f32) {
    let frame = Mat4::from_translation(base)
        * Mat4::from_rotation_z(yaw)
        * Mat4::from_rotation_x(-tilt)
        * Mat4::from_translation(Vec3::Z * (length * 0.5));
    b.diamond_in("leaf", frame, Vec3::new(width * 0.5, width * 0.06, length * 0.5));
}

/// A low plant: a bushy crown of clusters, or a rosette of long leaves from the soil.
pub(super) fn bush(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let pot_h = s.z * rng.between(0.3, 0.45);
    let r = s.z * rng.between(0.17, 0.25);
    let soil = pot(&mut b, r, pot_h, rng);
    let crown = s.z - soil;
    if rng.chance(0.5) {
        let n = rng.count(4, 9);
        for i in 0..n {
            let a = TAU * i as f32 / n as f32 + rng.between(0.0, 0.6);
            let d = r * rng.between(0.3, 0.9);
            let size = crown * rng.between(0.25, 0.4);
            let c = Vec3::new(a.cos() * d, a.sin() * d, soil + size * 0.8 + crown * rng.between(0.0, 0.35));
            b.ellipsoid("leaf", c, Vec3::new(size, size, size * 0.8), 8, 5);
        }
    } else {
        let n = rng.count(9, 22);
        let start = rng.between(0.0, TAU);
        for i in 0..n {
            let tilt = rng.between(0.2, 1.0);
            let length = crown * rng.between(0.8, 1.1) / tilt.cos().max(0.5);
            leaf(
                &mut b,
                Vec3::new(0.0, 0.0, soil),
                start + GOLDEN_ANGLE * i as f32,
                tilt,
                length,
                crown * rng.between(0.12, 0.25),
            );
        }
    }
    b
}

/// A tall plant: a stem (or several) with leaves placed along it, or a palm's crown of long
/// arching fronds at the top.
pub(super) fn tall(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let pot_h = s.z * rng.between(0.18, 0.26);
    let r = s.z * rng.between(0.09, 0.13);
    let soil = pot(&mut b, r, pot_h, rng);
    let stems = rng.count(1, 3);
    let palm = rng.chance(0.4);
    for k in 0..stems {
        let a = TAU * k as f32 / stems as f32;
        let foot = if stems > 1 { Vec3::new(a.cos(), a.sin(), 0.0) * r * 0.4 } else { Vec3::ZERO };
        let top = s.z * rng.between(if palm { 0.7 } else { 0.75 }, 0.9);
        b.cylinder("wood", foot + Vec3::Z * (soil - 0.01), rng.between(0.012, 0.025), top - soil, 6);
        let leaves = rng.count(if palm { 6 } else { 8 }, if palm { 10 } else { 18 });
        let start = rng.between(0.0, TAU);
        for i in 0..leaves {
            let yaw = start + GOLDEN_ANGLE * i as f32;
            if palm {
                let length = (s.z - top) * rng.between(1.5, 2.5);
                leaf(&mut b, foot + Vec3::Z * top, yaw, rng.between(0.6, 1.3), length, length * rng.between(0.2, 0.3));
            } else {
                let z = soil + (top - soil) * (0.35 + 0.65 * i as f32 / leaves as f32);
                let length = s.z * rng.between(0.1, 0.18);
                leaf(
                    &mut b,
                    foot + Vec3::Z * z,
                    yaw,
                    rng.between(0.7, FRAC_PI_2),
                    length,
                    length * rng.between(0.4, 0.6),
                );
            }
        }
    }
    b
}

/// A conifer: tiers of cones on a trunk, each tier narrower.
pub(super) fn conifer(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let pot_h = s.z * rng.between(0.18, 0.26);
    let r = s.z * rng.between(0.1, 0.14);
    let soil = pot(&mut b, r, pot_h, rng);
    let trunk = rng.between(0.05, 0.15) * s.z;
    b.cylinder("wood", Vec3::Z * (soil - 0.01), 0.02, trunk + 0.05, 6);
    let tiers = rng.count(2, 5);
    let crown = s.z - soil - trunk;
    let width = s.z * rng.between(0.18, 0.3);
    let tier_h = crown / (tiers as f32 * 0.6 + 0.4);
    for i in 0..tiers {
        let z = soil + trunk + tier_h * 0.6 * i as f32;
        let radius = width * (1.0 - 0.6 * i as f32 / tiers as f32);
        b.frustum(
            "leaf",
            Mat4::from_translation(Vec3::Z * z),
            radius,
            0.0,
            tier_h,
            rng.count(7, 11),
            Some("leaf"),
            None,
        );
    }
    b
}
