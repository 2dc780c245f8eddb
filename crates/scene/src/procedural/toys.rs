//! Toys assembled from parts: balls, block piles, teddies, cars and ring stackers.

use std::f32::consts::{FRAC_PI_2, TAU};

use glam::{Mat4, Vec3};
use rand_chacha::ChaCha8Rng;

use super::Draw;
use super::builder::MeshBuilder;

/// A ball, now and then with a band round its equator.
pub(super) fn ball(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let r = s.z * 0.5;
    let surface = rng.pick(&["plastic", "leather", "fabric"]);
    b.ellipsoid(surface, Vec3::Z * r, Vec3::splat(r), rng.count(10, 16), rng.count(7, 10));
    if rng.chance(0.4) {
        b.frustum("plastic", Mat4::from_translation(Vec3::Z * (r * 0.9)), r * 1.01, r * 1.01, r * 0.2, 16, None, None);
    }
    b
}

/// A pile of two to six blocks, stacked and scattered, each turned its own way.
pub(super) fn blocks(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let unit = s.z * rng.between(0.25, 0.4);
    let mut z = 0.0;
    let stacked = rng.count(1, 4);
    for _ in 0..stacked {
        let size = unit * rng.between(0.7, 1.1);
        let frame = Mat4::from_translation(Vec3::new(
            rng.between(-0.1, 0.1) * unit,
            rng.between(-0.1, 0.1) * unit,
            z + size * 0.5,
        )) * Mat4::from_rotation_z(rng.between(-0.6, 0.6));
        b.box_in(rng.pick(&["wood", "plastic"]), frame, Vec3::splat(size));
        z += size;
    }
    for _ in 0..rng.count(0, 2) {
        let size = unit * rng.between(0.6, 1.0);
        let a = rng.between(0.0, TAU);
        let d = unit * rng.between(1.0, 1.6);
        let frame = Mat4::from_translation(Vec3::new(a.cos() * d, a.sin() * d, size * 0.5))
            * Mat4::from_rotation_z(rng.between(0.0, FRAC_PI_2));
        b.box_in(rng.pick(&["wood", "plastic"]), frame, Vec3::splat(size));
    }
    b
}

/// A sitting teddy bear of drawn proportions.
pub(super) fn teddy(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let fur = rng.pick(&["fabric", "fabric", "leather"]);
    let h = s.z;
    let body = Vec3::new(0.2, 0.18, 0.27) * h * rng.between(0.9, 1.15);
    b.ellipsoid(fur, Vec3::Z * body.z, body, 10, 6);
    let head_r = h * rng.between(0.15, 0.2);
    let head = Vec3::new(0.0, 0.02 * h, body.z * 2.0 + head_r * 0.7);
    b.ellipsoid(fur, head, Vec3::splat(head_r), 10, 6);
    let ear = head_r * rng.between(0.3, 0.45);
    for sx in [-1.0_f32, 1.0] {
        b.ellipsoid(fur, head + Vec3::new(sx * head_r * 0.75, 0.0, head_r * 0.7), Vec3::new(ear, ear * 0.5, ear), 8, 4);
        b.ellipsoid(fur, Vec3::new(sx * body.x * 1.05, 0.06 * h, body.z * 1.1), Vec3::new(0.07, 0.07, 0.15) * h, 8, 4);
        b.ellipsoid(fur, Vec3::new(sx * body.x * 0.6, body.y * 1.1, 0.08 * h), Vec3::new(0.08, 0.15, 0.08) * h, 8, 4);
        b.ellipsoid(
            "plastic",
            head + Vec3::new(sx * head_r * 0.35, head_r * 0.85, head_r * 0.2),
            Vec3::splat(head_r * 0.12),
            6,
            4,
        );
    }
    b.ellipsoid(fur, head + Vec3::new(0.0, head_r * 0.85, -head_r * 0.2), Vec3::new(0.45, 0.4, 0.35) * head_r, 8, 4);
    b
}

/// A toy car: a body, a cabin and four wheels.
pub(super) fn car(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let paint = rng.pick(&["plastic", "metal", "wood"]);
    let h = s.z;
    let length = h * rng.between(1.8, 2.8);
    let width = h * rng.between(0.9, 1.2);
    let wheel_r = h * rng.between(0.18, 0.25);
    let body_top = h * rng.between(0.55, 0.65);
    b.cuboid(
        paint,
        Vec3::new(-width * 0.5, -length * 0.5, wheel_r * 0.6),
        Vec3::new(width * 0.5, length * 0.5, body_top),
    );
    let cabin = length * rng.between(0.35, 0.55);
    let offset = rng.between(-0.15, 0.1) * length;
    b.cuboid(
        paint,
        Vec3::new(-width * 0.42, offset - cabin * 0.5, body_top),
        Vec3::new(width * 0.42, offset + cabin * 0.5, h),
    );
    b.cuboid(
        "screen",
        Vec3::new(-width * 0.38, offset + cabin * 0.5, body_top + 0.05 * h),
        Vec3::new(width * 0.38, offset + cabin * 0.5 + 0.005, h - 0.05 * h),
    );
    for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        let axle = Mat4::from_translation(Vec3::new(sx * width * 0.5, sy * length * 0.32, wheel_r))
            * Mat4::from_rotation_y(FRAC_PI_2);
        let outward = if sx > 0.0 { Mat4::IDENTITY } else { Mat4::from_translation(-Vec3::Z * (width * 0.15)) };
        b.frustum("plastic", axle * outward, wheel_r, wheel_r, width * 0.15, 12, Some("plastic"), Some("plastic"));
    }
    b
}

/// A ring stacker: a base, a pole and rings of decreasing size.
pub(super) fn stacker(s: Vec3, rng: &mut ChaCha8Rng) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let h = s.z;
    let r = h * rng.between(0.3, 0.4);
    b.cylinder("wood", Vec3::ZERO, r, h * 0.08, 16);
    b.cylinder("wood", Vec3::Z * (h * 0.08), r * 0.12, h * 0.82, 8);
    let rings = rng.count(3, 6);
    let ring_h = h * 0.7 / rings as f32;
    for i in 0..rings {
        let rr = r * (0.95 - 0.5 * i as f32 / rings as f32);
        b.frustum(
            "plastic",
            Mat4::from_translation(Vec3::Z * (h * 0.08 + ring_h * i as f32)),
            rr,
            rr * 0.85,
            ring_h * 0.95,
            14,
            Some("plastic"),
            Some("plastic"),
        );
    }
    b.ellipsoid("plastic", Vec3::Z * (h * 0.9), Vec3::splat(r * 0.3), 8, 5);
    b
}
