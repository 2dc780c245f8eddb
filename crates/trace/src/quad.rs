//! Four rays of a packet against one triangle at once: the watertight test of
//! [`ShearedRay::intersect`] with the rays in SSE lanes.
//!
//! The test permutes each ray's axes so that its dominant direction comes last; four rays that
//! share that permutation (a quad whose rays all run mostly along one axis, which neighbouring
//! camera rays, and shadow rays from neighbouring points to one light, almost always do) see
//! the triangle's corners in the same order, so each corner coordinate is one broadcast value
//! and every other step is lane-wise. Each lane runs the scalar test's operations in its order,
//! without fused multiply-adds, so its answers are the scalar test's bit for bit. A lane whose
//! edge functions come out exactly zero needs the scalar test's `f64` fallback and is handed
//! back for it ([`QuadHits::retry`]); a quad whose rays differ in permutation is tested ray by
//! ray by the caller.

use glam::{Vec3, Vec3A};

use crate::bvh::ShearedRay;
use crate::packet::PACKET_RAYS;

/// The sheared rays of a packet in structure of arrays, four to a quad.
#[derive(Clone, Debug)]
pub(super) struct QuadRays {
    /// Per ray, its origin's coordinates in its permuted order (`kx`, `ky`, `kz`).
    origin: [[f32; PACKET_RAYS]; 3],
    /// Per ray, the shear `(Sx, Sy, Sz)`.
    shear: [[f32; PACKET_RAYS]; 3],
    /// The permutation of each ray, packed by [`pack`]: a quad's first ray's for the quad's
    /// shared test, each ray's for its scalar test ([`QuadRays::sheared`]).
    ray_k: [u8; PACKET_RAYS],
    /// Bit `q`: every ray pushed to quad `q` has the permutation of its first ray.
    shared: u16,
}

/// What [`QuadRays::intersect`] found for the lanes it was asked about.
pub(super) struct QuadHits {
    /// Lanes (bits 0..4) whose ray hits the triangle within its interval.
    pub hit: u32,
    /// Lanes the scalar test must decide (an edge function exactly zero in `f32`).
    pub retry: u32,
    pub t: [f32; 4],
    pub b1: [f32; 4],
    pub b2: [f32; 4],
}

/// An axis permutation in one byte, two bits per index (a compare of three `usize`s per pushed
/// ray was a fifth of a shadow packet's time).
#[inline(always)]
const fn pack([kx, ky, kz]: [usize; 3]) -> u8 {
    (kx | ky << 2 | kz << 4) as u8
}

#[inline(always)]
fn unpack(k: u8) -> [usize; 3] {
    [usize::from(k & 3), usize::from(k >> 2 & 3), usize::from(k >> 4 & 3)]
}

impl Default for QuadRays {
    fn default() -> Self {
        QuadRays {
            origin: [[0.0; PACKET_RAYS]; 3],
            shear: [[0.0; PACKET_RAYS]; 3],
            ray_k: [pack([0, 1, 2]); PACKET_RAYS],
            shared: 0,
        }
    }
}

impl QuadRays {
    /// Stores `ray` as ray `index` of the packet; rays are stored in index order from 0. What
    /// [`QuadRays::prepare`] does four rays at a time, and what it is tested against.
    #[cfg(any(test, not(target_arch = "x86_64")))]
    #[inline(always)]
    pub(super) fn set(&mut self, index: usize, ray: &ShearedRay) {
        let (origin, k, shear): (Vec3A, [usize; 3], Vec3) = ray.parts();
        for axis in 0..3 {
            self.origin[axis][index] = origin[k[axis]];
            self.shear[axis][index] = shear[axis];
        }
        let (quad, bit, k) = (index / 4, 1u16 << (index / 4), pack(k));
        self.ray_k[index] = k;
        if index % 4 == 0 {
            self.shared |= bit;
        } else if self.ray_k[quad * 4] != k {
            self.shared &= !bit;
        }
    }

    /// Prepares quad `quad` from its rays' origins and directions (structure of arrays; unit
    /// directions without `-0.0` components): lanes `valid` (bits 0..4, lane 0 among them) are
    /// rays, the others are ignored. The result is `QuadRays::set` of each ray's
    /// [`ShearedRay::new`], bit for bit: SSE on x86-64, four rays' permutations chosen by lane
    /// masks with the scalar code's comparisons, and the same divisions and products.
    #[inline(always)]
    pub(super) fn prepare(
        &mut self,
        quad: usize,
        origin: &[[f32; PACKET_RAYS]; 3],
        direction: &[[f32; PACKET_RAYS]; 3],
        valid: u32,
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            self.prepare_sse(quad, origin, direction, valid);
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            for lane in (0..4).filter(|lane| valid >> lane & 1 == 1) {
                let r = quad * 4 + lane;
                let at = |a: &[[f32; PACKET_RAYS]; 3]| Vec3::new(a[0][r], a[1][r], a[2][r]);
                let ray = ShearedRay::new(at(origin), at(direction));
                self.set(r, &ray);
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn prepare_sse(
        &mut self,
        quad: usize,
        origin: &[[f32; PACKET_RAYS]; 3],
        direction: &[[f32; PACKET_RAYS]; 3],
        valid: u32,
    ) {
        use crate::sse::select;
        use std::arch::x86_64::{
            __m128, _mm_and_ps, _mm_andnot_ps, _mm_cmpgt_ps, _mm_cmplt_ps, _mm_div_ps, _mm_movemask_ps, _mm_mul_ps,
            _mm_set1_ps, _mm_setzero_ps, _mm_storeu_ps,
        };
        let at = quad * 4;
        // SAFETY: SSE and SSE2 are in every x86-64 CPU (the target's baseline), and each store
        // touches the four floats `at..at + 4` of a `PACKET_RAYS` array (the slice index checks
        // `at + 4 <= PACKET_RAYS`).
        let (x_major, y_major, negative) = unsafe {
            let load = |a: &[f32; PACKET_RAYS]| crate::sse::load(a, at);
            let o = [load(&origin[0]), load(&origin[1]), load(&origin[2])];
            let d = [load(&direction[0]), load(&direction[1]), load(&direction[2])];
            let abs = |v: __m128| _mm_andnot_ps(_mm_set1_ps(-0.0), v);
            let (ax, ay, az) = (abs(d[0]), abs(d[1]), abs(d[2]));
            // `ShearedRay::new`'s choice of kz: x if |x| > |y| and |x| > |z|, else y if
            // |y| > |z| (and not |x| > |y|), else z.
            let x_gt_y = _mm_cmpgt_ps(ax, ay);
            let x_major = _mm_and_ps(x_gt_y, _mm_cmpgt_ps(ax, az));
            let y_major = _mm_andnot_ps(x_gt_y, _mm_cmpgt_ps(ay, az));
            // Component `(kz + shift) % 3` of `v`, per lane.
            let pick = |v: &[__m128; 3], shift: usize| {
                select(x_major, v[shift % 3], select(y_major, v[(1 + shift) % 3], v[(2 + shift) % 3]))
            };
            let dz = pick(&d, 0);
            // kx = kz + 1 and ky = kz + 2 (mod 3), swapped where the dominant component is
            // negative, to keep the winding.
            let negative = _mm_cmplt_ps(dz, _mm_setzero_ps());
            let permute = |v: &[__m128; 3]| {
                let (next, after) = (pick(v, 1), pick(v, 2));
                [select(negative, after, next), select(negative, next, after), pick(v, 0)]
            };
            let (po, pd) = (permute(&o), permute(&d));
            let sz = _mm_div_ps(_mm_set1_ps(1.0), dz);
            let shear = [_mm_mul_ps(pd[0], sz), _mm_mul_ps(pd[1], sz), sz];
            for axis in 0..3 {
                _mm_storeu_ps(self.origin[axis][at..at + 4].as_mut_ptr(), po[axis]);
                _mm_storeu_ps(self.shear[axis][at..at + 4].as_mut_ptr(), shear[axis]);
            }
            (_mm_movemask_ps(x_major), _mm_movemask_ps(y_major), _mm_movemask_ps(negative))
        };
        // Per lane, by table (branches on the lane masks mispredicted): index 2 kz + negative.
        const PACKED: [u8; 6] =
            [pack([1, 2, 0]), pack([2, 1, 0]), pack([2, 0, 1]), pack([0, 2, 1]), pack([0, 1, 2]), pack([1, 0, 2])];
        for lane in 0..4 {
            let bit = |m: i32| (m >> lane & 1) as usize;
            let kz = 2 - 2 * bit(x_major) - bit(y_major);
            self.ray_k[at + lane] = PACKED[2 * kz + bit(negative)];
        }
        // Shared: every valid lane chose the same dominant axis and sign.
        let uniform = |m: i32| m as u32 & valid == 0 || m as u32 & valid == valid;
        let bit = 1u16 << quad;
        if uniform(x_major) && uniform(y_major) && uniform(negative) {
            self.shared |= bit;
        } else {
            self.shared &= !bit;
        }
    }

    /// Ray `r`, from origin `origin`, in the form of the scalar test: what
    /// [`ShearedRay::new`] gave, for a ray [prepared](QuadRays::prepare) with that origin.
    #[inline(always)]
    pub(super) fn sheared(&self, r: usize, origin: Vec3A) -> ShearedRay {
        let shear = Vec3::new(self.shear[0][r], self.shear[1][r], self.shear[2][r]);
        ShearedRay::from_parts(origin, unpack(self.ray_k[r]), shear)
    }

    /// Whether the rays of quad `quad` share one permutation (else test them one by one).
    #[inline(always)]
    pub(super) fn is_shared(&self, quad: usize) -> bool {
        self.shared & (1 << quad) != 0
    }

    /// Lanes `lanes` (bits 0..4) of quad `quad`, which must be [shared](QuadRays::is_shared),
    /// against triangle `tri`, each within `(tmin, tmax[ray])`.
    #[inline(always)]
    pub(super) fn intersect(
        &self,
        quad: usize,
        lanes: u32,
        tri: &[Vec3A; 3],
        tmin: f32,
        tmax: &[f32; PACKET_RAYS],
    ) -> QuadHits {
        #[cfg(target_arch = "x86_64")]
        {
            self.intersect_sse(quad, lanes, tri, tmin, tmax)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.intersect_lanes(quad, lanes, tri, tmin, tmax)
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn intersect_sse(
        &self,
        quad: usize,
        lanes: u32,
        tri: &[Vec3A; 3],
        tmin: f32,
        tmax: &[f32; PACKET_RAYS],
    ) -> QuadHits {
        use std::arch::x86_64::{
            __m128, _mm_add_ps, _mm_and_ps, _mm_andnot_ps, _mm_cmpeq_ps, _mm_cmpgt_ps, _mm_cmplt_ps, _mm_div_ps,
            _mm_movemask_ps, _mm_mul_ps, _mm_or_ps, _mm_set1_ps, _mm_setzero_ps, _mm_storeu_ps, _mm_sub_ps,
        };
        let at = quad * 4;
        let [kx, ky, kz] = unpack(self.ray_k[at]);
        let mut out = QuadHits { hit: 0, retry: 0, t: [0.0; 4], b1: [0.0; 4], b2: [0.0; 4] };
        // SAFETY: SSE and SSE2 are in every x86-64 CPU (the target's baseline), and each store
        // touches a four-float array.
        unsafe {
            let load = |a: &[f32; PACKET_RAYS]| crate::sse::load(a, at);
            let (ox, oy, oz) = (load(&self.origin[0]), load(&self.origin[1]), load(&self.origin[2]));
            let (sx, sy, sz) = (load(&self.shear[0]), load(&self.shear[1]), load(&self.shear[2]));
            // A corner relative to each origin, permuted, then sheared: (x, y, z) of the paper.
            let corner = |p: Vec3A| -> (__m128, __m128, __m128) {
                let x = _mm_sub_ps(_mm_set1_ps(p[kx]), ox);
                let y = _mm_sub_ps(_mm_set1_ps(p[ky]), oy);
                let z = _mm_sub_ps(_mm_set1_ps(p[kz]), oz);
                (_mm_sub_ps(x, _mm_mul_ps(sx, z)), _mm_sub_ps(y, _mm_mul_ps(sy, z)), z)
            };
            let (ax, ay, az) = corner(tri[0]);
            let (bx, by, bz) = corner(tri[1]);
            let (cx, cy, cz) = corner(tri[2]);
            let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
            let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
            let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
            let zero = _mm_setzero_ps();
            let on_edge = _mm_or_ps(_mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)), _mm_cmpeq_ps(w, zero));
            let negative = _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)), _mm_cmplt_ps(w, zero));
            let positive = _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)), _mm_cmpgt_ps(w, zero));
            let det = _mm_add_ps(_mm_add_ps(u, v), w);
            let t_scaled = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(u, _mm_mul_ps(sz, az)), _mm_mul_ps(v, _mm_mul_ps(sz, bz))),
                _mm_mul_ps(w, _mm_mul_ps(sz, cz)),
            );
            let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
            let t = _mm_mul_ps(t_scaled, inv);
            // Both comparisons are false for a NaN `t`, as in the scalar `!(t > tmin && t < tmax)`.
            let within = _mm_and_ps(_mm_cmpgt_ps(t, _mm_set1_ps(tmin)), _mm_cmplt_ps(t, load(tmax)));
            let rejected = _mm_or_ps(_mm_and_ps(negative, positive), _mm_cmpeq_ps(det, zero));
            let hit = _mm_andnot_ps(_mm_or_ps(rejected, on_edge), within);
            out.retry = _mm_movemask_ps(on_edge) as u32 & lanes;
            out.hit = _mm_movemask_ps(hit) as u32 & lanes;
            if out.hit != 0 {
                _mm_storeu_ps(out.t.as_mut_ptr(), t);
                _mm_storeu_ps(out.b1.as_mut_ptr(), _mm_mul_ps(v, inv));
                _mm_storeu_ps(out.b2.as_mut_ptr(), _mm_mul_ps(w, inv));
            }
        }
        out
    }

    /// The lane-wise test in plain scalar code, the same operations in the same order: the
    /// fallback off x86-64, and what the SSE path is tested against.
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    fn intersect_lanes(
        &self,
        quad: usize,
        lanes: u32,
        tri: &[Vec3A; 3],
        tmin: f32,
        tmax: &[f32; PACKET_RAYS],
    ) -> QuadHits {
        let [kx, ky, kz] = unpack(self.ray_k[quad * 4]);
        let mut out = QuadHits { hit: 0, retry: 0, t: [0.0; 4], b1: [0.0; 4], b2: [0.0; 4] };
        for lane in 0..4 {
            let r = quad * 4 + lane;
            let (o, s) = (self.origin.map(|a| a[r]), self.shear.map(|a| a[r]));
            let corner = |p: Vec3A| {
                let (x, y, z) = (p[kx] - o[0], p[ky] - o[1], p[kz] - o[2]);
                (x - s[0] * z, y - s[1] * z, z)
            };
            let ((ax, ay, az), (bx, by, bz), (cx, cy, cz)) = (corner(tri[0]), corner(tri[1]), corner(tri[2]));
            let u = cx * by - cy * bx;
            let v = ax * cy - ay * cx;
            let w = bx * ay - by * ax;
            let on_edge = u == 0.0 || v == 0.0 || w == 0.0;
            let rejected = (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0);
            let det = u + v + w;
            let t_scaled = u * (s[2] * az) + v * (s[2] * bz) + w * (s[2] * cz);
            let inv = 1.0 / det;
            let t = t_scaled * inv;
            let bit = 1 << lane;
            if on_edge {
                out.retry |= bit & lanes;
            } else if !rejected && det != 0.0 && t > tmin && t < tmax[r] {
                out.hit |= bit & lanes;
            }
            (out.t[lane], out.b1[lane], out.b2[lane]) = (t, v * inv, w * inv);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn vec3() -> impl Strategy<Value = Vec3> {
        (-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    /// Four rays from a few metres away towards points in and around a triangle (weights
    /// `spread`, outside the triangle where one is negative), their origins a few millimetres
    /// apart.
    fn quad_case(away: Vec3, spread: [Vec3; 4], tri: [Vec3; 3]) -> (QuadRays, [f32; PACKET_RAYS], [ShearedRay; 4]) {
        let mut quads = QuadRays::default();
        let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
        let origin = centroid + away.normalize_or(Vec3::Z) * 5.0;
        let rays = spread.map(|w| {
            let target = (tri[0] * w.x + tri[1] * w.y + tri[2] * w.z) / (w.x + w.y + w.z);
            ShearedRay::new(origin + w * 0.003, (target - origin).normalize_or(Vec3::Z))
        });
        for (i, ray) in rays.iter().enumerate() {
            quads.set(i, ray);
        }
        let mut tmax = [f32::INFINITY; PACKET_RAYS];
        tmax[1] = 5.0;
        (quads, tmax, rays)
    }

    fn weights() -> impl Strategy<Value = Vec3> {
        (-0.3f32..1.0, -0.3f32..1.0, 0.1f32..1.0).prop_map(|(a, b, c)| Vec3::new(a, b, c))
    }

    proptest! {
        /// Every lane of a shared quad gets the scalar test's answer, bit for bit (or is handed
        /// back for it); the SSE path and the plain lanes agree.
        #[test]
        fn lanes_answer_as_the_scalar_test(
            away in vec3(),
            spread in [weights(), weights(), weights(), weights()],
            tri in [vec3(), vec3(), vec3()],
            lanes in 0u32..16,
        ) {
            let tri_a = tri.map(Vec3A::from);
            let (quads, tmax, rays) = quad_case(away, spread, tri);
            prop_assume!(quads.is_shared(0));
            let got = quads.intersect(0, lanes, &tri_a, 0.0, &tmax);
            let plain = quads.intersect_lanes(0, lanes, &tri_a, 0.0, &tmax);
            prop_assert_eq!((got.hit, got.retry), (plain.hit, plain.retry));
            for (lane, ray) in rays.iter().enumerate() {
                let bit = 1 << lane;
                if lanes & bit == 0 {
                    prop_assert_eq!((got.hit | got.retry) & bit, 0);
                    continue;
                }
                if got.retry & bit != 0 {
                    continue;
                }
                let scalar = ray.intersect(&tri_a, 0.0, tmax[lane]);
                let vector = (got.hit & bit != 0).then(|| (got.t[lane], got.b1[lane], got.b2[lane]));
                prop_assert_eq!(scalar.map(|h| [h.0, h.1, h.2].map(f32::to_bits)), vector.map(|h| [h.0, h.1, h.2].map(f32::to_bits)));
                prop_assert_eq!(plain.hit & bit, got.hit & bit);
            }
        }
    }

    /// A direction from `pick`: an axis (either sign), a diagonal with tied components, or a
    /// general direction, so ties between the components and zero components occur.
    fn direction() -> impl Strategy<Value = Vec3> {
        (0usize..4, vec3(), -1.0f32..1.0).prop_map(|(kind, v, s)| {
            let d = match kind {
                0 => [Vec3::X, Vec3::Y, Vec3::Z][(s.abs() * 2.99) as usize] * s.signum(),
                1 => Vec3::new(s, s, v.z),
                2 => Vec3::new(v.x, -v.x, v.x),
                _ => v,
            };
            crate::bvh::positive_zeros(d.normalize_or(Vec3::Z))
        })
    }

    proptest! {
        /// Preparing a quad four rays at a time gives each valid ray the permuted origin,
        /// shear and permutation of `ShearedRay::new`, bit for bit, and the quad the same
        /// shared flag as storing the rays one by one.
        #[test]
        fn prepared_quads_are_the_scalar_rays(
            origins in [vec3(), vec3(), vec3(), vec3()],
            directions in [direction(), direction(), direction(), direction()],
            valid in (0u32..8).prop_map(|v| v << 1 | 1),
            quad in 0..PACKET_RAYS / 4,
        ) {
            let (mut origin, mut direction) = ([[0.0f32; PACKET_RAYS]; 3], [[0.0f32; PACKET_RAYS]; 3]);
            let (mut prepared, mut scalar) = (QuadRays::default(), QuadRays::default());
            for lane in 0..4 {
                let r = quad * 4 + lane;
                for axis in 0..3 {
                    origin[axis][r] = origins[lane][axis];
                    direction[axis][r] = directions[lane][axis];
                }
                if valid >> lane & 1 == 1 {
                    scalar.set(r, &ShearedRay::new(origins[lane], directions[lane]));
                }
            }
            prepared.prepare(quad, &origin, &direction, valid);
            for lane in (0..4).filter(|lane| valid >> lane & 1 == 1) {
                let r = quad * 4 + lane;
                let bits = |q: &QuadRays| (q.origin.map(|a| a[r].to_bits()), q.shear.map(|a| a[r].to_bits()), q.ray_k[r]);
                prop_assert_eq!(bits(&prepared), bits(&scalar), "lane {}", lane);
                let again = prepared.sheared(r, Vec3A::from(origins[lane])).parts();
                let new = ShearedRay::new(origins[lane], directions[lane]).parts();
                prop_assert_eq!((again.0.to_array(), again.1, again.2.to_array()), (new.0.to_array(), new.1, new.2.to_array()));
            }
            prop_assert_eq!(prepared.is_shared(quad), scalar.is_shared(quad));
        }
    }

    #[test]
    fn a_ray_through_a_shared_edge_is_handed_back() {
        // Straight down onto the diagonal of a unit square split into two triangles: the edge
        // function of the shared edge is exactly zero, so the scalar fallback must decide.
        let tri = [Vec3A::new(0.0, 0.0, 0.0), Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(1.0, 1.0, 0.0)];
        let mut quads = QuadRays::default();
        for i in 0..4 {
            quads.set(i, &ShearedRay::new(Vec3::new(0.5, 0.5 - 0.1 * i as f32, 1.0), -Vec3::Z));
        }
        assert!(quads.is_shared(0));
        let got = quads.intersect(0, 0b1111, &tri, 0.0, &[f32::INFINITY; PACKET_RAYS]);
        assert_eq!(got.retry, 0b0001, "only the ray on the diagonal is handed back");
        assert_eq!(got.hit, 0b1110);
    }

    #[test]
    fn a_quad_of_mixed_permutations_is_not_shared() {
        let mut quads = QuadRays::default();
        let dirs = [Vec3::Z, Vec3::Z, Vec3::X, Vec3::Z];
        for (i, d) in dirs.into_iter().enumerate() {
            quads.set(i, &ShearedRay::new(Vec3::ZERO, d));
        }
        assert!(!quads.is_shared(0));
        quads.set(4, &ShearedRay::new(Vec3::ZERO, Vec3::X));
        assert!(quads.is_shared(1));
    }
}
