//! Closest-hit and any-hit queries against a triangle soup: obvhs builds a compressed-wide BVH
//! ([`obvhs::cwbvh::CwBvh`]) and rays walk it with a watertight ray/triangle test.
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
//! at a time (the `wide` module says why), single rays here and coherent rays in packets
//! ([`crate::packet`]). The build is sequential (obvhs' `parallel` feature is off), so the
//! tree, and with it which of two coincident triangles a ray reports, is the same on every run
//! and thread count.

use std::time::Duration;

use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::triangle::Triangle;

use crate::wide::{BoxRay, LeafTest, WideBvh, WideNode};

/// [`LeafTest`] of [`Bvh::closest_hit`]: keeps the nearest hit and shrinks `tmax` to it.
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

/// [`LeafTest`] of [`Bvh::blocker`]: the first triangle hit ends the walk.
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

/// A triangle index no BVH holds: "no hint" for [`Bvh::blocker`].
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

/// Triangles in one BVH, in the BVH's primitive order (what [`Hit::triangle`] indexes).
pub struct Bvh {
    /// obvhs' tree with exact `f32` child boxes (the `wide` module); `None` without triangles.
    wide: Option<WideBvh>,
    /// Triangle corners in BVH primitive order.
    tris: Vec<[Vec3A; 3]>,
}

impl std::fmt::Debug for Bvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bvh").field("triangles", &self.tris.len()).finish_non_exhaustive()
    }
}

impl Bvh {
    /// Builds the BVH of `triangles` (corners in world space; none may be degenerate or
    /// non-finite) with obvhs' `params`. Returns it with, for each of its triangles in BVH
    /// primitive order, the index of that triangle in `triangles`, so a caller can lay out its
    /// own per-triangle records in the same order.
    #[must_use]
    pub fn build(triangles: &[[Vec3; 3]], params: BvhBuildParams) -> (Bvh, Vec<u32>) {
        if triangles.is_empty() {
            return (Bvh { wide: None, tris: Vec::new() }, Vec::new());
        }
        let obvhs_tris: Vec<Triangle> =
            triangles.iter().map(|&[p0, p1, p2]| Triangle { v0: p0.into(), v1: p1.into(), v2: p2.into() }).collect();
        let bvh = build_cwbvh_from_tris(&obvhs_tris, params, &mut Duration::default());
        let tris: Vec<[Vec3A; 3]> = bvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let t = &obvhs_tris[i as usize];
                [t.v0, t.v1, t.v2]
            })
            .collect();
        let wide = WideBvh::new(&bvh, &tris);
        (Bvh { wide: Some(wide), tris }, bvh.primitive_indices)
    }

    /// Number of triangles in the BVH.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// The nodes of the BVH with exact boxes (node 0 the root), `None` without triangles.
    pub(crate) fn wide_nodes(&self) -> Option<&[WideNode]> {
        self.wide.as_ref().map(WideBvh::nodes)
    }

    /// Triangle corners in BVH primitive order (what a leaf's primitive ids index).
    #[must_use]
    pub fn triangles(&self) -> &[[Vec3A; 3]] {
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

    /// [`Bvh::occluded`] that names a triangle blocking the ray (`None`: nothing does), and
    /// tries triangle `hint` before walking the BVH.
    ///
    /// Why the hint: neighbouring shading points lose a light to the same occluder (the wall
    /// between two rooms, the sofa's back), so the triangle that blocked the last ray to a light
    /// usually blocks the next one, and one triangle test answers what otherwise takes a
    /// traversal (the shadow cache of Haines and Greenberg, 1986). The hint is tried with the
    /// same watertight test and ray interval as the traversal's leaves, and any triangle of the
    /// BVH that the ray hits before `tmax` blocks it, so a hint never hides a blocker. Nor does
    /// it find one the walk would miss: the walk over exact boxes is conservative
    /// (the `wide` module), where obvhs' quantised box test dropped a few grazing rays (a sun ray
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
    pub(crate) fn from_parts(origin: Vec3A, k: [usize; 3], shear: Vec3) -> ShearedRay {
        ShearedRay { origin, k, shear }
    }

    /// The origin, the axis permutation `(kx, ky, kz)` and the shear `(Sx, Sy, Sz)`: for the
    /// four-ray test ([`crate::quad`]), which must run this test's arithmetic.
    #[cfg(any(test, not(target_arch = "x86_64")))]
    #[inline(always)]
    pub(crate) fn parts(&self) -> (Vec3A, [usize; 3], Vec3) {
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
pub fn positive_zeros(v: Vec3) -> Vec3 {
    v + Vec3::ZERO
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
}
