//! Unlabelled decoration: rugs on floors and pictures on walls.
//!
//! Decor carries no class label, but it carries texture: it is what gives ORB features and
//! detectors the clutter of a lived-in room. Pictures hang on the inner faces of walls, clear of
//! openings and of tall furniture; rugs lie flat near a room's centre and never reach a door.

use glam::{Mat4, Quat, Vec2, Vec3};
use rand::Rng;

use crate::config::GeneratorConfig;
use crate::floorplan::Floorplan;
use crate::materials::MaterialCatalog;
use crate::scene::{Geometry, Mesh, Node, Primitive, Room, Semantic, Wall};

/// Height of a picture's centre above the floor (eye level, gallery convention ~1.45 m).
const PICTURE_CENTER_M: f32 = 1.45;
/// Depth of a picture (frame and canvas).
const PICTURE_DEPTH_M: f32 = 0.03;
/// Clearance between a picture and an opening or a wall end.
const PICTURE_CLEARANCE_M: f32 = 0.3;
/// Thickness of a rug.
const RUG_HEIGHT_M: f32 = 0.01;
/// Rugs keep this far from a room's walls, so they never reach a doorway.
const RUG_WALL_MARGIN_M: f32 = 1.0;
/// Number of texture variants drawn for decor surfaces.
const VARIANTS: u32 = 8;

/// Adds rugs and pictures to `geometry`; pictures keep clear of `furniture`, the world boxes
/// (min, max) of the placed objects and furnishings.
pub fn build(
    config: &GeneratorConfig,
    plan: &Floorplan,
    furniture: &[(Vec3, Vec3)],
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) {
    let mut rng = scene_gen_core::rng::stream(config.seed, "decor");
    for room in &plan.rooms {
        if rng.random_bool(0.6) {
            add_rug(config, room, &mut rng, materials, geometry);
        }
        let walls: Vec<&Wall> = plan.walls.iter().filter(|w| w.rooms.contains(&Some(room.id))).collect();
        for wall in walls {
            if rng.random_bool(0.35) {
                add_picture(config, room, wall, furniture, &mut rng, materials, geometry);
            }
        }
    }
}

fn add_rug(
    config: &GeneratorConfig,
    room: &Room,
    rng: &mut impl Rng,
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) {
    let (lo, hi) = room.interior(config.wall_thickness_m);
    let room_size = hi - lo - Vec2::splat(2.0 * RUG_WALL_MARGIN_M);
    if room_size.min_element() < 1.0 {
        return;
    }
    let size = Vec2::new(
        rng.random_range(0.5..0.9) * room_size.x.min(3.0 / 0.5),
        rng.random_range(0.5..0.9) * room_size.y.min(3.0 / 0.5),
    )
    .min(Vec2::splat(3.5));
    let slack = room_size - size;
    let center = lo + Vec2::splat(RUG_WALL_MARGIN_M) + size * 0.5 + slack * Vec2::new(rng.random(), rng.random());
    let material = materials.material(geometry, "rug", rng.random_range(0..VARIANTS)).expect("rug is a known surface");
    let mesh = push_mesh(geometry, format!("rug_{}", room.id), slab(Vec3::new(size.x, size.y, RUG_HEIGHT_M), material));
    geometry.nodes.push(Node {
        name: format!("rug_{}", room.id),
        mesh,
        transform: Mat4::from_translation(center.extend(0.0)),
        semantic: Semantic::Decor { room: room.id },
    });
}

fn add_picture(
    config: &GeneratorConfig,
    room: &Room,
    wall: &Wall,
    furniture: &[(Vec3, Vec3)],
    rng: &mut impl Rng,
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) {
    let length = wall.length_m();
    let size = Vec2::new(rng.random_range(0.4..1.0), rng.random_range(0.3..0.7));
    let Some(offset) = free_offset(wall, length, size.x, rng) else { return };
    let dir = (wall.b - wall.a) / length;
    let mut inward = Vec2::new(-dir.y, dir.x);
    let on_wall = wall.a + dir * offset;
    if inward.dot(room.center() - on_wall) < 0.0 {
        inward = -inward;
    }
    let face = on_wall + inward * (config.wall_thickness_m * 0.5 + PICTURE_DEPTH_M * 0.5 + 0.001);
    let half_extent = (dir * size.x * 0.5).abs() + (inward * PICTURE_DEPTH_M * 0.5).abs();
    let blocked = furniture.iter().any(|(min, max)| {
        max.z > PICTURE_CENTER_M - size.y * 0.5 - 0.1
            && (face - half_extent - Vec2::splat(0.2)).cmplt(max.truncate()).all()
            && (face + half_extent + Vec2::splat(0.2)).cmpgt(min.truncate()).all()
    });
    if blocked {
        return;
    }
    let material =
        materials.material(geometry, "picture", rng.random_range(0..VARIANTS)).expect("picture is a known surface");
    let id = geometry.nodes.len();
    let mesh = push_mesh(geometry, format!("picture_{id}"), slab(Vec3::new(size.x, PICTURE_DEPTH_M, size.y), material));
    // The slab's +Y face carries the image; turn it to face into the room.
    let yaw = inward.y.atan2(inward.x) - std::f32::consts::FRAC_PI_2;
    let center = face.extend(PICTURE_CENTER_M - size.y * 0.5);
    geometry.nodes.push(Node {
        name: format!("picture_{id}"),
        mesh,
        transform: Mat4::from_rotation_translation(Quat::from_rotation_z(yaw), center),
        semantic: Semantic::Decor { room: room.id },
    });
}

/// An offset along the wall for an item of `width`, clear of wall ends and openings.
fn free_offset(wall: &Wall, length: f32, width: f32, rng: &mut impl Rng) -> Option<f32> {
    let lo = PICTURE_CLEARANCE_M + width * 0.5;
    let hi = length - lo;
    if hi <= lo {
        return None;
    }
    (0..8).map(|_| rng.random_range(lo..hi)).find(|&offset| {
        wall.openings.iter().all(|o| (o.offset_m - offset).abs() > (o.width_m + width) * 0.5 + PICTURE_CLEARANCE_M)
    })
}

fn push_mesh(geometry: &mut Geometry, name: String, primitive: Primitive) -> usize {
    geometry.meshes.push(Mesh { name, primitives: vec![primitive] });
    geometry.meshes.len() - 1
}

/// A box of `size`, centred on x = y = 0 and resting on z = 0. Its top (+Z) and front (+Y)
/// faces map the whole texture once (a rug's or a picture's image); the thin sides get a
/// sliver of it.
fn slab(size: Vec3, material: usize) -> Primitive {
    let h = size * 0.5;
    let c = Vec3::new(0.0, 0.0, h.z);
    // (normal, u axis, v axis) per face; v runs down the image.
    let faces = [
        (Vec3::Z, Vec3::X, -Vec3::Y),
        (-Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::Y, -Vec3::X, -Vec3::Z),
        (-Vec3::Y, Vec3::X, -Vec3::Z),
        (Vec3::X, Vec3::Y, -Vec3::Z),
        (-Vec3::X, -Vec3::Y, -Vec3::Z),
    ];
    let mut p = Primitive { material, ..Primitive::default() };
    for (n, u, v) in faces {
        let base = p.positions.len() as u32;
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            p.positions.push(c + n * h + u * h * su + v * h * sv);
            p.normals.push(n);
            p.uvs.push(Vec2::new((su + 1.0) * 0.5, (sv + 1.0) * 0.5));
        }
        // u x v = -n for every face above, so (0, 2, 1) winds counter-clockwise around n.
        p.indices.extend([base, base + 2, base + 1, base, base + 3, base + 2]);
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slab_is_closed_with_outward_ccw_faces() {
        let p = slab(Vec3::new(2.0, 1.0, 0.5), 0);
        assert_eq!(p.positions.len(), 24);
        for tri in p.indices.chunks(3) {
            let [a, b, c] = [0, 1, 2].map(|i| p.positions[tri[i] as usize]);
            let n = (b - a).cross(c - a).normalize();
            assert!(n.dot(p.normals[tri[0] as usize]) > 0.99, "triangle {tri:?} winds against its normal");
            let centroid = (a + b + c) / 3.0 - Vec3::new(0.0, 0.0, 0.25);
            assert!(n.dot(centroid) > 0.0, "face points inwards");
        }
        let (lo, hi) = p.positions.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &q| (lo.min(q), hi.max(q)));
        assert_eq!((lo, hi), (Vec3::new(-1.0, -0.5, 0.0), Vec3::new(1.0, 0.5, 0.5)));
    }
}
