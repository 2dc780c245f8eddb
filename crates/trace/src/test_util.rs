//! Triangle soups for tests and benchmarks: quads, boxes, a closed room of boxes.

use glam::{Vec2, Vec3};

/// The rectangle `center + s u + t v`, s, t in [-0.5, 0.5], as two triangles wound to face
/// `u x v`.
#[must_use]
pub fn quad(center: Vec3, u: Vec3, v: Vec3) -> [[Vec3; 3]; 2] {
    let [a, b, c, d] = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)].map(|(s, t)| center + u * s + v * t);
    [[a, b, c], [a, c, d]]
}

/// A closed axis-aligned box, 12 triangles facing out (`inward` turns them in, for a room seen
/// from inside).
#[must_use]
pub fn box_triangles(min: Vec3, max: Vec3, inward: bool) -> Vec<[Vec3; 3]> {
    let c = (min + max) * 0.5;
    let e = max - min;
    let faces = [
        (Vec3::new(max.x, c.y, c.z), Vec3::Y * e.y, Vec3::Z * e.z),
        (Vec3::new(min.x, c.y, c.z), Vec3::Z * e.z, Vec3::Y * e.y),
        (Vec3::new(c.x, max.y, c.z), Vec3::Z * e.z, Vec3::X * e.x),
        (Vec3::new(c.x, min.y, c.z), Vec3::X * e.x, Vec3::Z * e.z),
        (Vec3::new(c.x, c.y, max.z), Vec3::X * e.x, Vec3::Y * e.y),
        (Vec3::new(c.x, c.y, min.z), Vec3::Y * e.y, Vec3::X * e.x),
    ];
    faces
        .into_iter()
        .flat_map(|(center, u, v)| if inward { quad(center, v, u) } else { quad(center, u, v) })
        .filter(|[a, b, c]| (*b - *a).cross(*c - *a).length_squared() > 0.0)
        .collect()
}

/// A closed `size` room (floor at z = 0, origin at a corner) seen from inside, with
/// `boxes_per_axis^2` boxes of varied heights standing on its floor. A zero-height room gives
/// a flat floor and ceiling only where the box has area.
#[must_use]
pub fn room_of_boxes(size: Vec3, boxes_per_axis: u32) -> Vec<[Vec3; 3]> {
    let mut tris = box_triangles(Vec3::ZERO, size, true);
    let n = boxes_per_axis.max(1);
    let cell = size.truncate() / n as f32;
    for j in 0..n {
        for i in 0..n {
            let centre = Vec2::new(i as f32 + 0.5, j as f32 + 0.5) * cell;
            let half = (cell * 0.3).extend(0.0);
            let height = 0.3 + 0.4 * (((i * 7 + j * 13) % 5) as f32 / 4.0);
            let (min, max) = (centre.extend(0.0) - half, centre.extend(height) + half.truncate().extend(0.0));
            tris.extend(box_triangles(min, max, false));
        }
    }
    tris
}
