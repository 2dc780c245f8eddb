//! Unlabelled decoration: small things on tables, rugs on floors, curtains at windows and
//! pictures on walls.
//!
//! Decor carries no class label, but it carries texture: it is what gives ORB features and
//! detectors the clutter of a lived-in room. Pictures hang on the inner faces of walls, clear of
//! openings and of tall furniture; rugs lie flat near a room's centre and never reach a door.
//! Tables carry up to four small things (cups, bowls, bottles, books, a kettle) around whatever
//! object stands on them, each clear of the others and of the table's edge.
//! Curtains hang in pleats from a rod above a window, one panel each side, to the floor where
//! the floor beside the window is free, else to just below the sill, else to the sill; a panel
//! that would still meet furniture, a door leaf or another opening is left out.

use glam::{Mat4, Quat, Vec2, Vec3};
use rand::Rng;
use rand::seq::IndexedRandom;

use crate::config::GeneratorConfig;
use crate::floorplan::Floorplan;
use crate::materials::MaterialCatalog;
use crate::placement::{Rect, TableTop};
use crate::procedural::builder::MeshBuilder;
use crate::procedural::{SMALL_THING_REACH_M, small_thing};
use crate::scene::{Geometry, Mesh, OpeningKind, Primitive, Room, Semantic, Wall, Window};

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
/// Most small things standing on one table.
const MAX_TABLE_THINGS: u32 = 4;
/// Chance that a room's windows have curtains.
const CURTAINED_ROOM_CHANCE: f64 = 0.75;
/// Curtain rod: above the window head, and out from the wall face.
const ROD_ABOVE_HEAD_M: f32 = 0.12;
const ROD_OFF_WALL_M: f32 = 0.1;
/// Depth of a curtain's pleats (front to back) and thickness of its cloth.
const PLEAT_DEPTH_M: f32 = 0.05;
const CLOTH_M: f32 = 0.008;
/// How far a drawn-back panel reaches over the window's edge.
const PANEL_OVERLAP_M: f32 = 0.08;

/// Adds small things on `table_tops`, rugs, curtains and pictures to `geometry`; curtains and
/// pictures keep clear of `furniture`, the world boxes (min, max) of the placed objects,
/// furnishings and door leaves, and of the things on tables.
pub fn build(
    config: &GeneratorConfig,
    plan: &Floorplan,
    furniture: &[(Vec3, Vec3)],
    table_tops: &[TableTop],
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) {
    let mut furniture = furniture.to_vec();
    let mut things_rng = scene_gen_core::rng::stream(config.seed, "table_things");
    for (i, top) in table_tops.iter().enumerate() {
        if let Some(bounds) = add_table_things(i, top, &mut things_rng, materials, geometry) {
            furniture.push(bounds);
        }
    }
    // Curtains draw from their own stream, so rugs and pictures keep their draws.
    let mut curtain_rng = scene_gen_core::rng::stream(config.seed, "curtains");
    for room in &plan.rooms {
        if curtain_rng.random_bool(CURTAINED_ROOM_CHANCE) {
            let fabric = *["fabric", "linen"].choose(&mut curtain_rng).expect("non-empty");
            let material = materials
                .material(geometry, fabric, curtain_rng.random_range(0..VARIANTS))
                .expect("curtain fabrics are known surfaces");
            let rod = materials.material(geometry, "metal", 0).expect("metal is a known surface");
            for window in plan.windows.iter().filter(|w| w.room == room.id) {
                let width = curtain_rng.random_range(0.25..0.45);
                add_curtains(config, plan, room, window, width, [material, rod], &mut furniture, geometry);
            }
        }
    }
    let furniture = &furniture[..];
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
    let mesh = slab_mesh(format!("rug_{}", room.id), Vec3::new(size.x, size.y, RUG_HEIGHT_M), material);
    geometry.push_placed(mesh, Mat4::from_translation(center.extend(0.0)), Semantic::Decor { room: room.id });
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
    let mesh = slab_mesh(format!("picture_{id}"), Vec3::new(size.x, PICTURE_DEPTH_M, size.y), material);
    // The slab's +Y face carries the image; turn it to face into the room.
    let yaw = inward.y.atan2(inward.x) - std::f32::consts::FRAC_PI_2;
    let center = face.extend(PICTURE_CENTER_M - size.y * 0.5);
    let transform = Mat4::from_rotation_translation(Quat::from_rotation_z(yaw), center);
    geometry.push_placed(mesh, transform, Semantic::Decor { room: room.id });
}

/// Hangs a rod and two pleated panels of `width` at `window`, each panel as long as the
/// floor beside it allows, and records their boxes in `furniture`.
#[allow(clippy::too_many_arguments)]
fn add_curtains(
    config: &GeneratorConfig,
    plan: &Floorplan,
    room: &Room,
    window: &Window,
    width: f32,
    [cloth, rod]: [usize; 2],
    furniture: &mut Vec<(Vec3, Vec3)>,
    geometry: &mut Geometry,
) {
    let inward = -window.normal;
    // Curtain frame: x along the wall (window centre at 0), y into the room from the wall
    // face, z up; x is chosen so that x, y, z are right-handed.
    let along = Vec2::new(inward.y, -inward.x);
    let face = window.center.truncate() + inward * (0.5 * config.wall_thickness_m);
    let to_world = |x: f32, y: f32| face + along * x + inward * y;
    let sill = window.center.z - 0.5 * window.height_m;
    let top = (window.center.z + 0.5 * window.height_m + ROD_ABOVE_HEAD_M).min(config.envelope.height_m - 0.05);
    let (lo, hi) = room.interior(config.wall_thickness_m);
    let depth = (ROD_OFF_WALL_M - 0.5 * PLEAT_DEPTH_M - CLOTH_M, ROD_OFF_WALL_M + 0.5 * PLEAT_DEPTH_M + CLOTH_M);
    let wall = &plan.walls[window.wall as usize];
    let centre_offset = (window.center.truncate() - wall.a).length();
    let mut b = MeshBuilder::default();
    let mut span = (f32::INFINITY, f32::NEG_INFINITY);
    for side in [-1.0_f32, 1.0] {
        let inner = side * (0.5 * window.width_m - PANEL_OVERLAP_M);
        let x = if side < 0.0 { (inner - width, inner) } else { (inner, inner + width) };
        // The panel's stretch of wall, as offsets from the wall's `a`, keeps off other openings.
        let ends = [x.0, x.1].map(|x| centre_offset + x * along.dot(wall.b - wall.a).signum());
        let (s0, s1) = (ends[0].min(ends[1]), ends[0].max(ends[1]));
        let beside_opening = wall
            .openings
            .iter()
            .filter(|o| (o.kind, o.id) != (OpeningKind::Window, window.id))
            .any(|o| s0 < o.offset_m + 0.5 * o.width_m + 0.05 && s1 > o.offset_m - 0.5 * o.width_m - 0.05);
        // The slanted pleats at the panel's ends reach a little past its span.
        let corners = [to_world(x.0 - PLEAT_DEPTH_M, depth.0), to_world(x.1 + PLEAT_DEPTH_M, depth.1)];
        let (min2, max2) = (corners[0].min(corners[1]), corners[0].max(corners[1]));
        if beside_opening || min2.cmplt(lo).any() || max2.cmpgt(hi).any() {
            continue;
        }
        let free = |bottom: f32| {
            !furniture.iter().any(|(fmin, fmax)| {
                fmin.truncate().cmplt(max2).all()
                    && fmax.truncate().cmpgt(min2).all()
                    && fmin.z < top
                    && fmax.z > bottom
            })
        };
        let Some(bottom) = [0.02, sill - 0.1, sill + 0.01].into_iter().find(|&z| z < top - 0.3 && free(z)) else {
            continue;
        };
        pleated_panel(&mut b, x, bottom, top - 0.03);
        furniture.push((min2.extend(bottom), max2.extend(top)));
        span = (span.0.min(x.0), span.1.max(x.1));
    }
    if span.0 > span.1 {
        return;
    }
    b.box_in(
        "metal",
        Mat4::from_translation(Vec3::new(0.5 * (span.0 + span.1), ROD_OFF_WALL_M, top - 0.015)),
        Vec3::new(span.1 - span.0, 0.02, 0.02),
    );
    let id = geometry.nodes.len();
    let name = format!("curtains_{id}");
    let mesh = b.into_asset_mesh().to_mesh(&name, |surface| if surface == "metal" { rod } else { cloth });
    let yaw = along.y.atan2(along.x);
    let transform = Mat4::from_translation(face.extend(0.0)) * Mat4::from_rotation_z(yaw);
    geometry.push_placed(mesh, transform, Semantic::Decor { room: room.id });
}

/// A pleated panel across `x` (curtain frame), from `bottom` to `top`: a zigzag of cloth
/// strips around the rod's line, [`PLEAT_DEPTH_M`] deep.
fn pleated_panel(b: &mut MeshBuilder, x: (f32, f32), bottom: f32, top: f32) {
    let pleats = ((x.1 - x.0) / 0.07).round().max(3.0) as usize;
    let step = (x.1 - x.0) / pleats as f32;
    let slant = PLEAT_DEPTH_M.atan2(step);
    let length = step.hypot(PLEAT_DEPTH_M);
    for i in 0..pleats {
        let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
        let centre = Vec3::new(x.0 + (i as f32 + 0.5) * step, ROD_OFF_WALL_M, 0.5 * (bottom + top));
        let frame = Mat4::from_translation(centre) * Mat4::from_rotation_z(sign * slant);
        b.box_in("fabric", frame, Vec3::new(length, CLOTH_M, top - bottom));
    }
}

/// Stands up to [`MAX_TABLE_THINGS`] small things on `top`, clear of what stands on it, as one
/// decor node; returns their world box, or `None` when none found room.
fn add_table_things(
    index: usize,
    top: &TableTop,
    rng: &mut rand_chacha::ChaCha8Rng,
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) -> Option<(Vec3, Vec3)> {
    let wanted = rng.random_range(0..=MAX_TABLE_THINGS);
    let variant = rng.random_range(0..VARIANTS);
    let reach = Vec2::splat(SMALL_THING_REACH_M);
    let (lo, hi) = (top.rect.min + reach, top.rect.max - reach);
    if wanted == 0 || lo.cmpge(hi).any() {
        return None;
    }
    let mut taken: Vec<Rect> = top.occupied.clone();
    let mut b = MeshBuilder::default();
    for _ in 0..wanted {
        let spot = (0..6)
            .map(|_| Vec2::new(rng.random_range(lo.x..hi.x), rng.random_range(lo.y..hi.y)))
            .find(|&c| !taken.iter().any(|r| r.overlaps(&Rect { min: c - reach, max: c + reach }, 0.01)));
        if let Some(c) = spot {
            small_thing(&mut b, c, top.z_m, rng);
            taken.push(Rect { min: c - reach, max: c + reach });
        }
    }
    if b.parts.is_empty() {
        return None;
    }
    let (min, max) = b.bounds();
    let name = format!("table_things_{index}");
    let mesh = b.into_asset_mesh().to_mesh(&name, |surface| {
        materials.material(geometry, surface, variant).expect("small things use known surfaces")
    });
    geometry.push_placed(mesh, Mat4::IDENTITY, Semantic::Decor { room: top.room });
    Some((min, max))
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

/// A mesh of one [`slab`].
fn slab_mesh(name: String, size: Vec3, material: usize) -> Mesh {
    Mesh { name, primitives: vec![slab(size, material)] }
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
