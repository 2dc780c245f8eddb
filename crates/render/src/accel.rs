//! The scene's opaque triangles in one BVH ([`scene_gen_trace::Bvh`]), with what shading
//! needs to know about each: interpolated normals and texture coordinates, material, node and
//! label, laid out per triangle in the BVH's own order.
//!
//! Glass (see [`crate::shade::is_transparent`]) is left out of the BVH: panes are
//! modelled as perfectly clear, so daylight and the camera both see through them.

use glam::{Mat3, Vec2, Vec3};
use obvhs::BvhBuildParams;
use scene_gen_trace::Bvh;
pub use scene_gen_trace::bvh::{Hit, NO_TRIANGLE, ShearedRay};

use scene_gen_scene::scene::Scene;
use scene_gen_trace::RayPacket;
use scene_gen_trace::lanes::{Lanes, Lanes3, N, lane3, negate_if, select};

/// Per-triangle attributes, in BVH primitive order: all that shading reads of a triangle in
/// one record. With indices into per-vertex arrays instead, a packet's surface stage read up
/// to seven cache lines per hit and computed three addresses (callgrind: a tenth of a 4-spp
/// image's instructions).
#[derive(Clone, Copy, Debug)]
struct TriAttr {
    /// The corners' world-space unit vertex normals (zero where the mesh has none).
    normals: [Vec3; 3],
    /// The corners' texture coordinates.
    uvs: [Vec2; 3],
    /// Index into `Geometry::materials`.
    material: u32,
    /// Index into `Geometry::nodes`.
    node: u32,
    /// Unit normal of the triangle's plane (the corners' winding), computed once: normalising
    /// a cross product per shaded sample was a few per cent of an image.
    geometric_normal: Vec3,
}

/// Per lane, the interpolated vertex normal `s` normalised (glam's `normalize_or_zero`), then,
/// as [`Accel::surface`] has it, the facing plane normal `ng` where it is zero, or turned to
/// `ng`'s side.
///
/// The last blends are bitwise ([`select`], [`negate_if`]): written with branches, two of the
/// three stores came out as AVX masked stores, which AMD cores run as slow microcode (perf put
/// this function at 6 % of a 4-spp image).
#[inline(always)]
fn normalise_shading_normals(s: &mut Lanes3, ng: &Lanes3) {
    for k in 0..N {
        let (x, y, z) = (s[0][k], s[1][k], s[2][k]);
        let rcp = 1.0 / (x * x + y * y + z * z).sqrt();
        let unit = rcp.is_finite() & (rcp > 0.0);
        let (x, y, z) = (select(unit, x * rcp, 0.0), select(unit, y * rcp, 0.0), select(unit, z * rcp, 0.0));
        let (gx, gy, gz) = (ng[0][k], ng[1][k], ng[2][k]);
        let zero = (x == 0.0) & (y == 0.0) & (z == 0.0);
        let behind = x * gx + y * gy + z * gz < 0.0;
        s[0][k] = select(zero, gx, negate_if(behind, x));
        s[1][k] = select(zero, gy, negate_if(behind, y));
        s[2][k] = select(zero, gz, negate_if(behind, z));
    }
}

/// The surfaces at the hits of a packet of rays, one lane per ray, structure of arrays
/// ([`Accel::surfaces`]): what [`Accel::surface`] gives each hit, the same numbers.
pub(crate) struct Surfaces {
    /// Lanes with a hit (bit `k` for lane `k`); the other lanes hold stale numbers.
    pub lanes: u64,
    /// Distance along the ray, metres.
    pub t: Lanes,
    pub position: Lanes3,
    pub geometric_normal: Lanes3,
    pub shading_normal: Lanes3,
    pub uv: [Lanes; 2],
    pub material: [u32; N],
    pub node: [u32; N],
}

impl Default for Surfaces {
    fn default() -> Self {
        Surfaces {
            lanes: 0,
            t: [0.0; N],
            position: [[0.0; N]; 3],
            geometric_normal: [[0.0; N]; 3],
            shading_normal: [[0.0; N]; 3],
            uv: [[0.0; N]; 2],
            material: [0; N],
            node: [0; N],
        }
    }
}

impl Surfaces {
    /// Lane `k` as one [`SurfacePoint`].
    #[must_use]
    #[inline(always)]
    pub fn point(&self, k: usize) -> SurfacePoint {
        SurfacePoint {
            position: self.position(k),
            geometric_normal: lane3(&self.geometric_normal, k),
            shading_normal: lane3(&self.shading_normal, k),
            uv: Vec2::new(self.uv[0][k], self.uv[1][k]),
            material: self.material[k] as usize,
            node: self.node[k] as usize,
        }
    }

    /// The hit point of lane `k`.
    #[must_use]
    #[inline(always)]
    pub fn position(&self, k: usize) -> Vec3 {
        lane3(&self.position, k)
    }
}

/// What a ray hit, interpolated.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub position: Vec3,
    /// Unit normal of the triangle plane, turned to face the incoming ray.
    pub geometric_normal: Vec3,
    /// Unit interpolated vertex normal, on the same side as `geometric_normal`.
    pub shading_normal: Vec3,
    /// Texture coordinates (metres of surface; repeats every 1.0).
    pub uv: Vec2,
    /// Index into `Geometry::materials`.
    pub material: usize,
    /// Index into `Geometry::nodes`.
    pub node: usize,
}

/// Label of a node, from [`Scene::label`]: 0 where the node is not an object or threshold.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NodeLabel {
    pub instance_id: u32,
    pub class_id: u16,
}

/// All opaque triangles of a scene in one BVH, with what shading needs to know about each.
pub struct Accel {
    bvh: Bvh,
    /// Per-triangle attributes, in BVH primitive order.
    attrs: Vec<TriAttr>,
    positions: Vec<Vec3>,
    labels: Vec<NodeLabel>,
}

impl std::fmt::Debug for Accel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Accel").field("triangles", &self.bvh.triangle_count()).finish_non_exhaustive()
    }
}

impl Accel {
    /// Flattens every node of `scene` into world space and builds the BVH with obvhs'
    /// `slow_build` preset (pre-split of large triangles, wider PLOC search, more reinsertion).
    /// On the seed-7 house (8,676 triangles) it traced primary rays about 20 % and shadow rays
    /// about 15 % faster than `medium_build`, for about 25 ms more build time
    /// (`examples/bench_render.rs`, docs/BENCHMARKS.md); a house's walls and floors are long
    /// triangles that `medium_build`'s boxes fit poorly. Degenerate (zero-area) triangles,
    /// out-of-range indices and glass are skipped.
    #[must_use]
    pub fn build(scene: &Scene) -> Accel {
        Accel::build_with(scene, BvhBuildParams::slow_build())
    }

    /// [`Accel::build`] with other obvhs build parameters (for benchmarks of BVH quality).
    #[must_use]
    pub fn build_with(scene: &Scene, params: BvhBuildParams) -> Accel {
        let geometry = &scene.geometry;
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut uvs = Vec::new();
        let mut triangles = Vec::new();
        let mut attrs = Vec::new();
        let mut labels = Vec::with_capacity(geometry.nodes.len());
        for (node_index, node) in geometry.nodes.iter().enumerate() {
            labels.push(
                scene
                    .label(node.semantic)
                    .map(|l| NodeLabel { instance_id: l.instance_id, class_id: l.class_id as u16 })
                    .unwrap_or_default(),
            );
            let Some(mesh) = geometry.meshes.get(node.mesh) else { continue };
            let linear = Mat3::from_mat4(node.transform);
            let normal_matrix =
                if linear.determinant().abs() > 1e-12 { linear.inverse().transpose() } else { Mat3::IDENTITY };
            for primitive in &mesh.primitives {
                let transparent = geometry.materials.get(primitive.material).is_some_and(super::shade::is_transparent);
                if transparent {
                    continue;
                }
                let base = positions.len() as u32;
                let n = primitive.positions.len();
                for (i, p) in primitive.positions.iter().enumerate() {
                    positions.push(node.transform.transform_point3(*p));
                    let normal =
                        primitive.normals.get(i).map_or(Vec3::ZERO, |v| (normal_matrix * *v).normalize_or_zero());
                    normals.push(normal);
                    uvs.push(primitive.uvs.get(i).copied().unwrap_or(Vec2::ZERO));
                }
                for tri in primitive.indices.chunks_exact(3) {
                    if tri.iter().any(|&i| i as usize >= n) {
                        continue;
                    }
                    let v = [tri[0] + base, tri[1] + base, tri[2] + base];
                    let [p0, p1, p2] = v.map(|i| positions[i as usize]);
                    if (p1 - p0).cross(p2 - p0).length_squared() <= 0.0
                        || !(p0.is_finite() && p1.is_finite() && p2.is_finite())
                    {
                        continue;
                    }
                    triangles.push([p0, p1, p2]);
                    attrs.push(TriAttr {
                        normals: v.map(|i| normals[i as usize]),
                        uvs: v.map(|i| uvs[i as usize]),
                        material: primitive.material as u32,
                        node: node_index as u32,
                        geometric_normal: (p1 - p0).cross(p2 - p0).normalize_or_zero(),
                    });
                }
            }
        }
        let (bvh, order) = Bvh::build(&triangles, params);
        let attrs = order.iter().map(|&i| attrs[i as usize]).collect();
        Accel { bvh, attrs, positions, labels }
    }

    /// The triangles' BVH, for queries the shading records play no part in.
    #[must_use]
    #[inline(always)]
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// The unit normal of triangle `triangle` (BVH order) as its vertices wind: the side the
    /// mesh calls its front, which [`Accel::surface`] does not keep (it faces the normal to the
    /// ray). A ray that meets a triangle from behind has entered a closed solid.
    #[must_use]
    #[inline(always)]
    pub fn face_normal(&self, triangle: u32) -> Vec3 {
        self.attrs[triangle as usize].geometric_normal
    }

    /// Number of triangles in the BVH.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.bvh.triangle_count()
    }

    /// [`Bvh::closest_hit`].
    #[must_use]
    #[inline(always)]
    pub fn closest_hit(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<Hit> {
        self.bvh.closest_hit(origin, direction, tmax)
    }

    /// [`Bvh::occluded`].
    #[must_use]
    #[inline(always)]
    pub fn occluded(&self, origin: Vec3, direction: Vec3, tmax: f32) -> bool {
        self.bvh.occluded(origin, direction, tmax)
    }

    /// [`Bvh::blocker`].
    #[must_use]
    #[inline(always)]
    pub fn blocker(&self, origin: Vec3, direction: Vec3, tmax: f32, hint: u32) -> Option<u32> {
        self.bvh.blocker(origin, direction, tmax, hint)
    }

    /// [`Bvh::closest_hits`].
    #[inline(always)]
    pub fn closest_hits(&self, packet: &mut RayPacket, hits: &mut [Option<Hit>]) {
        self.bvh.closest_hits(packet, hits);
    }

    /// [`Bvh::occluded_packet`].
    #[must_use]
    #[inline(always)]
    pub fn occluded_packet(&self, packet: &mut RayPacket) -> u64 {
        self.bvh.occluded_packet(packet)
    }

    /// Interpolated surface at `hit` of a ray travelling along `direction`.
    #[must_use]
    #[inline(always)]
    pub fn surface(&self, hit: &Hit, origin: Vec3, direction: Vec3) -> SurfacePoint {
        let attr = &self.attrs[hit.triangle as usize];
        let b0 = 1.0 - hit.b1 - hit.b2;
        let (n, uv) = (&attr.normals, &attr.uvs);
        let mut geometric = attr.geometric_normal;
        if geometric.dot(direction) > 0.0 {
            geometric = -geometric;
        }
        let mut shading = (n[0] * b0 + n[1] * hit.b1 + n[2] * hit.b2).normalize_or_zero();
        if shading == Vec3::ZERO {
            shading = geometric;
        } else if shading.dot(geometric) < 0.0 {
            shading = -shading;
        }
        SurfacePoint {
            // Along the ray rather than from barycentrics: the same point the depth buffer reports.
            position: origin + direction * hit.t,
            geometric_normal: geometric,
            shading_normal: shading,
            uv: uv[0] * b0 + uv[1] * hit.b1 + uv[2] * hit.b2,
            material: attr.material as usize,
            node: attr.node as usize,
        }
    }

    /// [`Accel::surface`] at each hit of the first `count` rays of a packet from `origin`
    /// along `d` (unit, per axis), into `out`, with the same numbers: the vertex attributes are
    /// gathered lane by lane and the arithmetic runs in vector loops over the lanes
    /// ([`scene_gen_trace::lanes`]). Hit by hit, the normalisation's square root and division were a
    /// chain each surface waited on (perf: a fifth of a 4-spp image).
    #[allow(clippy::needless_range_loop)] // Lane loops: the form the vectoriser takes.
    #[inline(always)]
    pub(crate) fn surfaces(&self, hits: &[Option<Hit>; N], count: usize, origin: Vec3, d: &Lanes3, out: &mut Surfaces) {
        out.lanes = 0;
        let Some(last) = self.attrs.len().checked_sub(1) else { return };
        let (mut tri, mut b1, mut b2) = ([0u32; N], [0.0f32; N], [0.0f32; N]);
        for (k, hit) in hits[..count].iter().enumerate() {
            if let Some(h) = hit {
                (tri[k], b1[k], b2[k], out.t[k]) = (h.triangle, h.b1, h.b2, h.t);
                out.lanes |= 1 << k;
            }
        }
        // Lane `k` reads the record at `(tri[k] as usize).min(last)`: lanes without a hit read
        // one too, and the `min` proves every index in bounds, so the loop has no bounds checks
        // and the records' fields go straight into vector registers. The results go straight
        // into `out`: staged in fresh arrays, their zeroing was a tenth of the instructions.
        for k in 0..N {
            let a = &self.attrs[(tri[k] as usize).min(last)];
            let b0 = 1.0 - b1[k] - b2[k];
            // The plane normal, turned to face against the ray as `Accel::surface` turns it
            // (glam's `dot`: (x x' + y y') + z z').
            let (x, y, z) = (a.geometric_normal.x, a.geometric_normal.y, a.geometric_normal.z);
            let flip = x * d[0][k] + y * d[1][k] + z * d[2][k] > 0.0;
            out.geometric_normal[0][k] = select(flip, -x, x);
            out.geometric_normal[1][k] = select(flip, -y, y);
            out.geometric_normal[2][k] = select(flip, -z, z);
            // The vertex normals interpolated, normalised below.
            let n = &a.normals;
            out.shading_normal[0][k] = n[0].x * b0 + n[1].x * b1[k] + n[2].x * b2[k];
            out.shading_normal[1][k] = n[0].y * b0 + n[1].y * b1[k] + n[2].y * b2[k];
            out.shading_normal[2][k] = n[0].z * b0 + n[1].z * b1[k] + n[2].z * b2[k];
            let uv = &a.uvs;
            out.uv[0][k] = uv[0].x * b0 + uv[1].x * b1[k] + uv[2].x * b2[k];
            out.uv[1][k] = uv[0].y * b0 + uv[1].y * b1[k] + uv[2].y * b2[k];
            (out.material[k], out.node[k]) = (a.material, a.node);
        }
        normalise_shading_normals(&mut out.shading_normal, &out.geometric_normal);
        for axis in 0..3 {
            for k in 0..N {
                out.position[axis][k] = origin[axis] + d[axis][k] * out.t[k];
            }
        }
    }

    /// The scene node of `triangle` (what [`Accel::surface`] reports as `node`).
    #[must_use]
    #[inline(always)]
    pub fn triangle_node(&self, triangle: u32) -> usize {
        self.attrs[triangle as usize].node as usize
    }

    /// Instance and class id of the node a triangle belongs to.
    #[must_use]
    #[inline(always)]
    pub fn label(&self, node: usize) -> NodeLabel {
        self.labels.get(node).copied().unwrap_or_default()
    }

    /// World-space positions of all vertices (for bounds and tests).
    #[must_use]
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_zero_direction_components_still_hit() {
        use crate::test_util::{add_material, add_mesh, empty_scene, quad};
        let mut scene = empty_scene();
        let m = add_material(&mut scene, "paint_0", [0.5; 3], 0.0, 1.0);
        for k in 0..20 {
            let c = Vec3::new(k as f32 * 0.5, 0.0, 0.0);
            add_mesh(
                &mut scene,
                quad(c, Vec3::X * 0.5, Vec3::Y * 3.0, m),
                glam::Mat4::IDENTITY,
                scene_gen_scene::scene::Semantic::Decor { room: 0 },
            );
        }
        let accel = Accel::build(&scene);
        assert_eq!(accel.triangle_count(), 40);
        let origin = Vec3::new(3.1, 0.0, 2.0);
        for d in [Vec3::new(-0.1, -0.0, -1.0), Vec3::new(-0.0, -0.0, -1.0), Vec3::new(0.1, 0.0, -1.0)] {
            let hit = accel.closest_hit(origin, d.normalize(), f32::INFINITY);
            assert!(hit.is_some_and(|h| (h.t - 2.0 / d.normalize().z.abs()).abs() < 1e-5), "{d:?}");
            assert!(accel.occluded(origin, d.normalize(), 10.0));
        }
    }

    /// A room of boxes with three odd panels: vertex normals of zero length (the fallback to
    /// the plane normal), reversed against the winding, and tilted ones.
    fn room_with_odd_normals() -> Scene {
        use crate::test_util::{add_material, add_mesh, quad, room_of_boxes};
        use scene_gen_scene::scene::Semantic;
        let mut scene = room_of_boxes(Vec3::new(4.0, 4.0, 3.0), 2);
        let paint = add_material(&mut scene, "paint_odd", [0.6, 0.6, 0.6], 0.0, 0.9);
        let panels = [(Vec3::ZERO, 0.0), (Vec3::NEG_X, 0.0), (Vec3::new(0.3, 0.8, 0.5), 0.7)];
        for (i, (normal, tilt)) in panels.into_iter().enumerate() {
            let centre = Vec3::new(0.01, 1.0 + i as f32, 1.5);
            let mut panel = quad(centre, Vec3::Y * 0.9, Vec3::Z * 0.9 + Vec3::X * tilt, paint);
            for (k, n) in panel.normals.iter_mut().enumerate() {
                *n = if normal == Vec3::ZERO { normal } else { (normal + Vec3::Y * k as f32 * 0.2).normalize() };
            }
            add_mesh(&mut scene, panel, glam::Mat4::IDENTITY, Semantic::Object { id: 0 });
        }
        scene
    }

    proptest::proptest! {
        /// `Accel::surfaces` gives every lane of a packet the numbers `Accel::surface` gives
        /// its hit alone, bit for bit, and marks the lanes with a hit.
        #[test]
        fn surfaces_of_a_packet_are_those_of_each_hit(
            origin in proptest::array::uniform3(0.2f32..3.8),
            yaw in 0.0f32..std::f32::consts::TAU,
            spread in 0.05f32..1.5,
        ) {
            use scene_gen_trace::packet::PACKET_RAYS;
            let accel = Accel::build(&room_with_odd_normals());
            let origin = Vec3::from(origin).min(Vec3::new(3.8, 3.8, 2.8));
            let dirs: [Vec3; PACKET_RAYS] = std::array::from_fn(|k| {
                let (a, b) = ((k % 8) as f32 / 7.0 - 0.5, (k / 8) as f32 / 7.0 - 0.5);
                let (s, c) = (yaw + a * spread * 3.0).sin_cos();
                Vec3::new(c, s, b * spread * 2.0).normalize()
            });
            let hits = dirs.map(|d| accel.closest_hit(origin, d, f32::INFINITY));
            let mut per_axis = [[0.0; PACKET_RAYS]; 3];
            for (k, d) in dirs.iter().enumerate() {
                (per_axis[0][k], per_axis[1][k], per_axis[2][k]) = (d.x, d.y, d.z);
            }
            let mut out = Surfaces::default();
            accel.surfaces(&hits, PACKET_RAYS, origin, &per_axis, &mut out);
            for (k, hit) in hits.iter().enumerate() {
                proptest::prop_assert_eq!(out.lanes >> k & 1 == 1, hit.is_some(), "lane {}", k);
                if let Some(h) = hit {
                        let alone = accel.surface(h, origin, dirs[k]);
                        let bits = |p: &SurfacePoint| {
                            let v = [p.position, p.geometric_normal, p.shading_normal];
                            (v.map(|v| v.to_array().map(f32::to_bits)), p.uv.to_array().map(f32::to_bits), p.material, p.node)
                        };
                        proptest::prop_assert_eq!(bits(&out.point(k)), bits(&alone), "lane {}", k);
                }
            }
        }
    }
}
