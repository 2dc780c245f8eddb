//! Ray acceleration: every opaque scene triangle, in world space, in one obvhs compressed-wide
//! BVH ([`obvhs::cwbvh::CwBvh`]), intersected with a watertight ray/triangle test.
//!
//! obvhs' own triangle intersector documents a gap of up to a pixel along shared edges; here
//! the BVH only finds candidate primitives and [`ShearedRay::intersect`] decides, with the
//! algorithm of Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection", Journal of
//! Computer Graphics Techniques 2(1), 2013: the ray is sheared so it runs along +Z from the
//! origin, the triangle is projected into that frame and the three 2D edge functions decide
//! inclusion. Points exactly on a shared edge give a zero edge function in both triangles, and
//! the test accepts zero, so a ray never slips between two triangles that share an edge; the
//! edge functions are re-evaluated in f64 when they are exactly zero in f32, as the paper does.
//!
//! obvhs builds the tree; rays walk a copy of it with exact `f32` child boxes tested four lanes
//! at a time (`render::wide` says why), single rays there and coherent rays in packets
//! ([`super::packet`]). The build is sequential (obvhs' `parallel` feature is off), so the
//! tree, and with it which of two coincident triangles a ray reports, is the same on every run
//! and thread count.
//!
//! Glass (see [`crate::render::shade::is_transparent`]) is left out of the BVH: panes are
//! modelled as perfectly clear, so daylight and the camera both see through them.

use std::time::Duration;

use glam::{Mat3, Vec2, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::triangle::Triangle;

use super::lanes::{Lanes, Lanes3, N, lane3, negate_if, select};
use super::wide::{BoxRay, LeafTest, WideBvh, WideNode};
use crate::scene::Scene;

/// [`LeafTest`] of [`Accel::closest_hit`]: keeps the nearest hit and shrinks `tmax` to it.
struct Closest<'a> {
    sheared: ShearedRay,
    tris: &'a [[Vec3A; 3]],
    best: Option<Hit>,
}

impl LeafTest for Closest<'_> {
    #[inline(always)]
    fn test(&mut self, first: u32, count: u32, tmax: &mut f32) -> bool {
        for id in first..first + count {
            if let Some((t, b1, b2)) = self.sheared.intersect(&self.tris[id as usize], 0.0, *tmax) {
                // `intersect` only returns t < tmax, so this hit is the closest so far.
                self.best = Some(Hit { t, triangle: id, b1, b2 });
                *tmax = t;
            }
        }
        false
    }
}

/// [`LeafTest`] of [`Accel::blocker`]: the first triangle hit ends the walk.
struct AnyHit<'a> {
    sheared: ShearedRay,
    tris: &'a [[Vec3A; 3]],
    blocker: Option<u32>,
}

impl LeafTest for AnyHit<'_> {
    #[inline(always)]
    fn test(&mut self, first: u32, count: u32, tmax: &mut f32) -> bool {
        for id in first..first + count {
            if self.sheared.intersect(&self.tris[id as usize], 0.0, *tmax).is_some() {
                self.blocker = Some(id);
                return true;
            }
        }
        false
    }
}

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

/// A triangle index no BVH holds: "no hint" for [`Accel::blocker`].
pub const NO_TRIANGLE: u32 = u32::MAX;

/// The closest intersection of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction, metres.
    pub t: f32,
    /// Triangle, in the accelerator's own order.
    pub triangle: u32,
    /// Barycentric weights of the triangle's second and third vertices.
    pub b1: f32,
    pub b2: f32,
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

/// A ray transformed for the watertight test: the axis permutation `k` puts the dominant
/// direction component last, and `shear` maps the direction onto +Z.
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay {
    origin: Vec3A,
    k: [usize; 3],
    /// (Sx, Sy, Sz) of the paper.
    shear: Vec3,
}

impl ShearedRay {
    /// Prepares `direction` (need not be unit, must be non-zero) from `origin`.
    #[must_use]
    #[inline(always)]
    pub fn new(origin: Vec3, direction: Vec3) -> ShearedRay {
        let a = direction.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Keep the winding of the projected triangle when the dominant component is negative.
        if direction[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let sz = 1.0 / direction[kz];
        ShearedRay {
            origin: origin.into(),
            k: [kx, ky, kz],
            shear: Vec3::new(direction[kx] * sz, direction[ky] * sz, sz),
        }
    }

    /// The ray of `ShearedRay::parts` `(origin, k, shear)`.
    #[inline(always)]
    pub(super) fn from_parts(origin: Vec3A, k: [usize; 3], shear: Vec3) -> ShearedRay {
        ShearedRay { origin, k, shear }
    }

    /// The origin, the axis permutation `(kx, ky, kz)` and the shear `(Sx, Sy, Sz)`: for the
    /// four-ray test ([`super::quad`]), which must run this test's arithmetic.
    #[cfg(any(test, not(target_arch = "x86_64")))]
    #[inline(always)]
    pub(super) fn parts(&self) -> (Vec3A, [usize; 3], Vec3) {
        (self.origin, self.k, self.shear)
    }

    /// Intersects the triangle `tri` (both sides); returns `(t, b1, b2)` for `tmin < t < tmax`.
    /// Always inlined: it runs inside the traversal loop for every candidate triangle.
    #[inline(always)]
    #[must_use]
    pub fn intersect(&self, tri: &[Vec3A; 3], tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = self.k;
        let (sx, sy, sz) = (self.shear.x, self.shear.y, self.shear.z);
        let a = tri[0] - self.origin;
        let b = tri[1] - self.origin;
        let c = tri[2] - self.origin;
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Exactly on an edge in f32: decide with the exact-enough f64 products (the paper's
            // fallback), so the two triangles sharing the edge agree.
            let f = |p: f32, q: f32, r: f32, s: f32| (f64::from(p) * f64::from(q) - f64::from(r) * f64::from(s)) as f32;
            u = f(cx, by, cy, bx);
            v = f(ax, cy, ay, cx);
            w = f(bx, ay, by, ax);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let t_scaled = u * (sz * a[kz]) + v * (sz * b[kz]) + w * (sz * c[kz]);
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        if !(t > tmin && t < tmax) {
            return None;
        }
        Some((t, v * inv, w * inv))
    }
}

/// `v` with every -0.0 component turned into +0.0. obvhs 0.4 picks the child traversal octant
/// from the sign bits of the direction but its node test compares with zero, and a ray with a
/// -0.0 component (a camera looking straight down, the centre column) then misses every node;
/// adding +0.0 is exact for every other value.
#[inline]
pub(super) fn positive_zeros(v: Vec3) -> Vec3 {
    v + Vec3::ZERO
}

/// Label of a node, from [`Scene::label`]: 0 where the node is not an object or threshold.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NodeLabel {
    pub instance_id: u32,
    pub class_id: u16,
}

/// All opaque triangles of a scene in one BVH, with what shading needs to know about each.
pub struct Accel {
    /// obvhs' tree with exact `f32` child boxes ([`super::wide`]); `None` without triangles.
    wide: Option<WideBvh>,
    /// Triangle corners in BVH primitive order.
    tris: Vec<[Vec3A; 3]>,
    attrs: Vec<TriAttr>,
    positions: Vec<Vec3>,
    labels: Vec<NodeLabel>,
}

impl std::fmt::Debug for Accel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Accel").field("triangles", &self.tris.len()).finish_non_exhaustive()
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
                    triangles.push(Triangle { v0: p0.into(), v1: p1.into(), v2: p2.into() });
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
        let bvh = (!triangles.is_empty()).then(|| build_cwbvh_from_tris(&triangles, params, &mut Duration::default()));
        let (tris, attrs) = match &bvh {
            Some(bvh) => bvh
                .primitive_indices
                .iter()
                .map(|&i| {
                    let t = &triangles[i as usize];
                    ([t.v0, t.v1, t.v2], attrs[i as usize])
                })
                .unzip(),
            None => (Vec::new(), Vec::new()),
        };
        let wide = bvh.as_ref().map(|bvh| WideBvh::new(bvh, &tris));
        Accel { wide, tris, attrs, positions, labels }
    }

    /// Number of triangles in the BVH.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// The nodes of the BVH with exact boxes (node 0 the root), `None` for a scene without
    /// opaque triangles.
    pub(super) fn wide_nodes(&self) -> Option<&[WideNode]> {
        self.wide.as_ref().map(WideBvh::nodes)
    }

    /// Triangle corners in BVH primitive order (what a leaf's primitive ids index).
    pub(super) fn triangles(&self) -> &[[Vec3A; 3]] {
        &self.tris
    }

    /// The closest hit along `origin + t * direction` for `0 < t < tmax`; `direction` unit.
    #[must_use]
    #[inline(always)]
    pub fn closest_hit(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<Hit> {
        let wide = self.wide.as_ref()?;
        let direction = positive_zeros(direction);
        let mut closest = Closest { sheared: ShearedRay::new(origin, direction), tris: &self.tris, best: None };
        let mut tmax = tmax;
        wide.walk(&BoxRay::new(origin, direction), &mut tmax, true, &mut closest);
        closest.best
    }

    /// Whether anything lies on `origin + t * direction` for `0 < t < tmax` (a shadow ray).
    /// Any hit ends the traversal at once.
    #[must_use]
    #[inline(always)]
    pub fn occluded(&self, origin: Vec3, direction: Vec3, tmax: f32) -> bool {
        self.blocker(origin, direction, tmax, NO_TRIANGLE).is_some()
    }

    /// [`Accel::occluded`] that names a triangle blocking the ray (`None`: nothing does), and
    /// tries triangle `hint` before walking the BVH.
    ///
    /// Why the hint: neighbouring shading points lose a light to the same occluder (the wall
    /// between two rooms, the sofa's back), so the triangle that blocked the last ray to a light
    /// usually blocks the next one, and one triangle test answers what otherwise takes a
    /// traversal (the shadow cache of Haines and Greenberg, 1986). The hint is tried with the
    /// same watertight test and ray interval as the traversal's leaves, and any triangle of the
    /// BVH that the ray hits before `tmax` blocks it, so a hint never hides a blocker. Nor does
    /// it find one the walk would miss: the walk over exact boxes is conservative
    /// (`render::wide`), where obvhs' quantised box test dropped a few grazing rays (a sun ray
    /// leaving a wall 0.01 mm below a flat ceiling) that only the hint then caught. An
    /// out-of-range hint (such as [`NO_TRIANGLE`]) is skipped.
    #[must_use]
    #[inline(always)]
    pub fn blocker(&self, origin: Vec3, direction: Vec3, tmax: f32, hint: u32) -> Option<u32> {
        let wide = self.wide.as_ref()?;
        let direction = positive_zeros(direction);
        let sheared = ShearedRay::new(origin, direction);
        let tris = &self.tris;
        if tris.get(hint as usize).is_some_and(|tri| sheared.intersect(tri, 0.0, tmax).is_some()) {
            return Some(hint);
        }
        let mut any = AnyHit { sheared, tris, blocker: None };
        let mut tmax = tmax;
        wide.walk(&BoxRay::new(origin, direction), &mut tmax, false, &mut any);
        any.blocker
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
    /// ([`super::lanes`]). Hit by hit, the normalisation's square root and division were a
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
    fn sheared_test_hits_inside_and_misses_outside() {
        let tri = [Vec3A::new(0.0, 0.0, 0.0), Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(0.0, 1.0, 0.0)];
        let down = ShearedRay::new(Vec3::new(0.2, 0.3, 2.0), -Vec3::Z);
        let (t, b1, b2) = down.intersect(&tri, 0.0, f32::INFINITY).unwrap();
        assert!((t - 2.0).abs() < 1e-6 && (b1 - 0.2).abs() < 1e-6 && (b2 - 0.3).abs() < 1e-6);
        // From below (back side) it still hits: surfaces are two-sided.
        assert!(ShearedRay::new(Vec3::new(0.2, 0.3, -1.0), Vec3::Z).intersect(&tri, 0.0, 10.0).is_some());
        assert!(ShearedRay::new(Vec3::new(0.8, 0.8, 2.0), -Vec3::Z).intersect(&tri, 0.0, 10.0).is_none());
        assert!(down.intersect(&tri, 0.0, 1.5).is_none(), "beyond tmax");
    }

    #[test]
    fn shared_edge_is_hit_by_one_of_two_triangles() {
        // Two triangles sharing the diagonal; rays exactly on the diagonal, at awkward
        // coordinates, must hit at least one of them.
        let a = [Vec3A::new(0.0, 0.0, 0.0), Vec3A::new(1.3, 0.0, 0.1), Vec3A::new(1.3, 0.7, 0.3)];
        let b = [Vec3A::new(0.0, 0.0, 0.0), Vec3A::new(1.3, 0.7, 0.3), Vec3A::new(0.0, 0.7, 0.2)];
        for i in 1..1000 {
            let s = i as f32 / 1000.0;
            let p = Vec3::from(a[0]).lerp(Vec3::from(a[2]), s);
            let origin = p + Vec3::new(0.013, -0.021, 1.0);
            let dir = (p - origin).normalize();
            let r = ShearedRay::new(origin, dir);
            assert!(r.intersect(&a, 0.0, 10.0).is_some() || r.intersect(&b, 0.0, 10.0).is_some(), "leak at s = {s}");
        }
    }

    #[test]
    fn negative_zero_direction_components_still_hit() {
        use crate::render::test_util::{add_material, add_mesh, empty_scene, quad};
        let mut scene = empty_scene();
        let m = add_material(&mut scene, "paint_0", [0.5; 3], 0.0, 1.0);
        for k in 0..20 {
            let c = Vec3::new(k as f32 * 0.5, 0.0, 0.0);
            add_mesh(
                &mut scene,
                quad(c, Vec3::X * 0.5, Vec3::Y * 3.0, m),
                glam::Mat4::IDENTITY,
                crate::scene::Semantic::Decor { room: 0 },
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
        use crate::render::test_util::{add_material, add_mesh, quad, room_of_boxes};
        use crate::scene::Semantic;
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
            use crate::render::packet::PACKET_RAYS;
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
