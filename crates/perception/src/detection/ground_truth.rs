//! Ground truth of one rendered frame, from its instance buffer.
//!
//! For every instance id present in [`Frame::instance_id`] (objects and thresholds alike;
//! thresholds are COCO category 11):
//!
//! * **visible box**: the tight box of its pixels, `[x, y, w, h]` with pixel `(x, y)` covering
//!   `[x, x + 1) x [y, y + 1)`, so a single pixel is `[x, y, 1, 1]`;
//! * **visible pixels**: how many pixel centres see it (the renderer labels a pixel by the ray
//!   through its centre);
//! * **footprint**: the pixels it would cover with nothing in front of it, found by
//!   rasterising **its own mesh triangles** (every node whose semantic is that object or
//!   threshold, clipped at a 1 mm near plane) at pixel centres with the same pinhole as
//!   [`Camera::ray_direction`]. The mesh, not the bounding box: an AABB's projection would
//!   overstate the footprint of a chair by its empty space. `visible_fraction = visible /
//!   footprint` (clamped to 1; pixel-centre ties on silhouette edges can put a visible pixel
//!   outside the rasterised footprint; an instance with no mesh in the scene gets its visible
//!   pixels as footprint), and `occluded_fraction = 1 - visible_fraction`. The
//!   image border counts as occlusion only in that the footprint is clipped to the image too:
//!   an object cut by the frame edge is not "occluded".
//! * **distance**: camera centre to the **nearest visible point** of the object (the minimum
//!   over its pixels of `depth / cos(angle to the optical axis)`), the distance at which a
//!   detector would have to see it.
//! * **counted**: within [`GroundTruthConfig::max_distance_m`] (TaCOS: objects within 6 m)
//!   and with at least [`GroundTruthConfig::min_visible_px`] visible pixels.

use std::collections::BTreeMap;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::coco_eval::GtAnnotation;
use scene_gen_render::{Camera, Frame};
use scene_gen_scene::scene::Scene;

/// Default distance cut: TaCOS counted objects within 6 m (docs/REFERENCE.md, "Tasks and score").
pub const DEFAULT_MAX_DISTANCE_M: f32 = 6.0;

/// Default visible-pixel floor at 640 x 480: 100 px (a 10 x 10 patch, about 0.03 % of the
/// image), an engineering choice near the smallest objects COCO annotates well.
pub const DEFAULT_MIN_VISIBLE_PX_VGA: f64 = 100.0;

/// Pixels of the image size the floor is quoted at (640 x 480).
pub const VGA_PIXELS: f64 = 640.0 * 480.0;

/// Near clipping distance for the footprint rasteriser (metres).
const NEAR_M: f32 = 1e-3;

/// Which objects count as ground truth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroundTruthConfig {
    /// Objects whose nearest visible point is farther are not counted.
    pub max_distance_m: f32,
    /// The visible-pixel floor for a 640 x 480 image; other sizes scale it by their pixel
    /// count, so the floor is a fixed fraction of the image (the same object at the same
    /// place counts or not whatever the resolution).
    pub min_visible_px_vga: f64,
}

impl Default for GroundTruthConfig {
    fn default() -> Self {
        GroundTruthConfig { max_distance_m: DEFAULT_MAX_DISTANCE_M, min_visible_px_vga: DEFAULT_MIN_VISIBLE_PX_VGA }
    }
}

impl GroundTruthConfig {
    /// The visible-pixel floor for a `width x height` image.
    #[must_use]
    pub fn min_visible_px(&self, width: u32, height: u32) -> f64 {
        self.min_visible_px_vga * f64::from(width) * f64::from(height) / VGA_PIXELS
    }
}

/// One instance seen in a frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GtObject {
    pub instance_id: u32,
    /// COCO category id: 1..=10 objects, 11 threshold.
    pub class_id: u32,
    /// Tight box of the visible pixels, `[x, y, w, h]`.
    pub bbox: [f64; 4],
    pub visible_px: u32,
    /// Pixels the mesh covers in the image with nothing in front (at least `visible_px`).
    pub footprint_px: u32,
    /// `visible_px / footprint_px`, in (0, 1].
    pub visible_fraction: f64,
    /// Camera centre to the nearest visible point, metres.
    pub distance_m: f32,
    /// Passes the distance and pixel-floor tests.
    pub counted: bool,
}

impl GtObject {
    /// `1 - visible_fraction`.
    #[must_use]
    pub fn occluded_fraction(&self) -> f64 {
        1.0 - self.visible_fraction
    }
}

#[derive(Default)]
struct Acc {
    class_id: u32,
    count: u32,
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
    distance_m: f32,
}

/// Ground truth of every instance in `frame` (rendered from `camera` of `scene`), sorted by
/// instance id.
///
/// # Panics
/// If the frame's size differs from the camera's.
#[must_use]
pub fn frame_ground_truth(frame: &Frame, scene: &Scene, camera: &Camera, config: &GroundTruthConfig) -> Vec<GtObject> {
    assert_eq!((frame.width, frame.height), (camera.width_px, camera.height_px), "frame and camera sizes differ");
    let basis = camera.basis();
    let mut accs: BTreeMap<u32, Acc> = BTreeMap::new();
    for y in 0..frame.height {
        for x in 0..frame.width {
            let i = frame.index(x, y);
            let id = frame.instance_id[i];
            if id == 0 {
                continue;
            }
            let cos = camera.ray_direction_in(basis, x as f32 + 0.5, y as f32 + 0.5).dot(basis.0).max(1e-6);
            let d = frame.depth_m[i] / cos;
            let a = accs.entry(id).or_insert(Acc {
                class_id: u32::from(frame.class_id[i]),
                x0: x,
                y0: y,
                x1: x,
                y1: y,
                distance_m: f32::INFINITY,
                ..Acc::default()
            });
            a.count += 1;
            a.x0 = a.x0.min(x);
            a.y0 = a.y0.min(y);
            a.x1 = a.x1.max(x);
            a.y1 = a.y1.max(y);
            a.distance_m = a.distance_m.min(d);
        }
    }
    let min_px = config.min_visible_px(frame.width, frame.height);
    let mut stamp = vec![0u32; frame.width as usize * frame.height as usize];
    accs.into_iter()
        .map(|(instance_id, a)| {
            let footprint = footprint_px(scene, camera, instance_id, &mut stamp).max(a.count);
            GtObject {
                instance_id,
                class_id: a.class_id,
                bbox: [f64::from(a.x0), f64::from(a.y0), f64::from(a.x1 - a.x0 + 1), f64::from(a.y1 - a.y0 + 1)],
                visible_px: a.count,
                footprint_px: footprint,
                visible_fraction: f64::from(a.count) / f64::from(footprint),
                distance_m: a.distance_m,
                counted: a.distance_m <= config.max_distance_m && f64::from(a.count) >= min_px,
            }
        })
        .collect()
}

/// COCO annotations of the counted objects, ids from `first_id` upwards; `area` is the visible
/// pixel count (COCO's segment area).
#[must_use]
pub fn to_annotations(objects: &[GtObject], image_id: u64, first_id: u64) -> Vec<GtAnnotation> {
    objects
        .iter()
        .filter(|o| o.counted)
        .enumerate()
        .map(|(k, o)| GtAnnotation {
            id: first_id + k as u64,
            image_id,
            category_id: o.class_id,
            bbox: o.bbox,
            area: f64::from(o.visible_px),
            iscrowd: 0,
        })
        .collect()
}

/// Pixels whose centre the instance's triangles cover, unoccluded. `stamp` is a per-pixel
/// scratch buffer (marked with the instance id, so no clearing between instances).
fn footprint_px(scene: &Scene, camera: &Camera, instance_id: u32, stamp: &mut [u32]) -> u32 {
    let (forward, right, up) = camera.basis();
    let f_px = camera.focal_mm / (camera.pixel_pitch_um * 1e-3);
    let (w, h) = (camera.width_px as f32, camera.height_px as f32);
    let mut count = 0u32;
    for node in &scene.geometry.nodes {
        if scene.label(node.semantic).map(|l| l.instance_id) != Some(instance_id) {
            continue;
        }
        let Some(mesh) = scene.geometry.meshes.get(node.mesh) else { continue };
        for prim in &mesh.primitives {
            for tri in prim.indices.chunks_exact(3) {
                let cam: Vec<Vec3> = tri
                    .iter()
                    .filter_map(|&i| prim.positions.get(i as usize))
                    .map(|&p| {
                        let d = node.transform.transform_point3(p) - camera.position;
                        Vec3::new(d.dot(right), d.dot(up), d.dot(forward))
                    })
                    .collect();
                if cam.len() != 3 {
                    continue;
                }
                let poly = clip_near(&cam);
                if poly.len() < 3 {
                    continue;
                }
                let pts: Vec<(f32, f32)> =
                    poly.iter().map(|v| (w * 0.5 + f_px * v.x / v.z, h * 0.5 - f_px * v.y / v.z)).collect();
                for k in 1..pts.len() - 1 {
                    count += raster_triangle([pts[0], pts[k], pts[k + 1]], camera, instance_id, stamp);
                }
            }
        }
    }
    count
}

/// Sutherland-Hodgman clip of a camera-space triangle against `z >= NEAR_M`.
fn clip_near(tri: &[Vec3]) -> Vec<Vec3> {
    let mut out = Vec::with_capacity(4);
    for i in 0..tri.len() {
        let (a, b) = (tri[i], tri[(i + 1) % tri.len()]);
        let (ina, inb) = (a.z >= NEAR_M, b.z >= NEAR_M);
        if ina {
            out.push(a);
        }
        if ina != inb {
            let t = (NEAR_M - a.z) / (b.z - a.z);
            out.push(a + (b - a) * t);
        }
    }
    out
}

/// Marks the pixel centres inside a projected triangle; returns how many were new.
fn raster_triangle(p: [(f32, f32); 3], camera: &Camera, instance_id: u32, stamp: &mut [u32]) -> u32 {
    let edge = |a: (f32, f32), b: (f32, f32), c: (f32, f32)| (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
    let area = edge(p[0], p[1], p[2]);
    if area == 0.0 || !area.is_finite() {
        return 0;
    }
    let (w, h) = (camera.width_px, camera.height_px);
    let min_x = p.iter().map(|q| q.0).fold(f32::INFINITY, f32::min);
    let max_x = p.iter().map(|q| q.0).fold(f32::NEG_INFINITY, f32::max);
    let min_y = p.iter().map(|q| q.1).fold(f32::INFINITY, f32::min);
    let max_y = p.iter().map(|q| q.1).fold(f32::NEG_INFINITY, f32::max);
    // Pixel x has its centre at x + 0.5.
    let x0 = (min_x - 0.5).ceil().max(0.0);
    let x1 = (max_x - 0.5).floor().min(w as f32 - 1.0);
    let y0 = (min_y - 0.5).ceil().max(0.0);
    let y1 = (max_y - 0.5).floor().min(h as f32 - 1.0);
    if x0 > x1 || y0 > y1 {
        return 0;
    }
    let sign = area.signum();
    let mut new = 0;
    for y in y0 as u32..=y1 as u32 {
        for x in x0 as u32..=x1 as u32 {
            let c = (x as f32 + 0.5, y as f32 + 0.5);
            let inside = (0..3).all(|k| edge(p[k], p[(k + 1) % 3], c) * sign >= 0.0);
            if inside {
                let s = &mut stamp[y as usize * w as usize + x as usize];
                if *s != instance_id {
                    *s = instance_id;
                    new += 1;
                }
            }
        }
    }
    new
}
