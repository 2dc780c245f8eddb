//! Packet traversal: up to [`PACKET_RAYS`] rays walk the obvhs compressed-wide BVH together.
//!
//! obvhs traverses one ray at a time; a frame's camera rays, and the shadow rays from a tile of
//! shading points to one light, are coherent: neighbouring rays visit nearly the same nodes.
//! Walking them together decodes each visited node once for the whole packet, and most child
//! boxes are accepted or rejected with one or two tests instead of one per ray (Wald, Boulos and
//! Shirley, "Ray Tracing Deformable Scenes Using Dynamic Bounding Volume Hierarchies", ACM TOG
//! 26(1), 2007, section 4):
//!
//! 1. the child box is tested against the first ray of the packet still in the subtree: if
//!    it hits, the child is entered at once;
//! 2. otherwise an interval-arithmetic bound of the whole packet (its range of origins, of
//!    inverse directions and its largest `tmax`) rejects a box that no ray can reach;
//! 3. otherwise the remaining rays are tested until one hits.
//!
//! Leaf boxes are tested against every ray, and only the rays that reach a leaf test its
//! triangles, with the same watertight test as single rays
//! ([`crate::bvh::ShearedRay::intersect`], four rays at a time where they share its axis
//! permutation: `render::quad`, the same arithmetic per lane) and the same per-ray box
//! arithmetic as the single-ray walk. A ray in a packet therefore tests a superset of the
//! triangles it would test alone: an occlusion answer is the same, and a closest hit is the
//! same up to which of two triangles at exactly the same distance wins.

use glam::{Vec3, Vec3A};

use crate::bvh::{Bvh, Hit, positive_zeros};
use crate::lanes::{Lanes, Lanes3, bits, lane3};
use crate::quad::QuadRays;
use crate::wide::{BoxRay, Child, LANES, WideNode, entry_limit};

/// Rays per packet: an 8 x 8 pixel tile; one bit each in a `u64` mask.
pub const PACKET_RAYS: usize = 64;

/// Relative padding of the interval bounds, so rounding in the interval products never
/// rejects a box that a ray's own test (rounded differently) would enter.
const INTERVAL_PAD: f32 = 1e-4;

/// Up to [`PACKET_RAYS`] rays, structure of arrays.
///
/// [`RayPacket::push`] only stores a ray; the forms the tests take (reciprocal directions, the
/// watertight test's permuted and sheared rays) are computed four rays at a time when the packet
/// is traced (`RayPacket::prepare`). Why: computed ray by ray at each push, they took as long
/// as walking the BVH with the packet of shadow rays.
#[derive(Clone, Debug)]
pub struct RayPacket {
    len: usize,
    /// Rays `..prepared` have their reciprocals and sheared forms.
    prepared: usize,
    /// Origins, per axis.
    origin: [[f32; PACKET_RAYS]; 3],
    /// Unit directions without `-0.0` components ([`positive_zeros`]), per axis.
    direction: [[f32; PACKET_RAYS]; 3],
    /// Reciprocal directions as the box test of a single ray takes them ([`BoxRay::new`]), so a
    /// packet ray enters exactly the boxes it enters alone.
    inv: [[f32; PACKET_RAYS]; 3],
    tmax: [f32; PACKET_RAYS],
    /// The sheared rays, four to a quad, for the triangle test.
    quads: QuadRays,
}

impl Default for RayPacket {
    fn default() -> Self {
        RayPacket {
            len: 0,
            prepared: 0,
            origin: [[0.0; PACKET_RAYS]; 3],
            direction: [[0.0; PACKET_RAYS]; 3],
            inv: [[0.0; PACKET_RAYS]; 3],
            tmax: [0.0; PACKET_RAYS],
            quads: QuadRays::default(),
        }
    }
}

impl RayPacket {
    /// An empty packet.
    #[must_use]
    pub fn new() -> RayPacket {
        RayPacket::default()
    }

    /// Number of rays in the packet.
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the packet has no rays.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Removes every ray.
    pub fn clear(&mut self) {
        self.len = 0;
        self.prepared = 0;
    }

    /// Adds the ray `origin + t * direction`, `0 < t < tmax` (`direction` unit), and returns its
    /// index in the packet.
    ///
    /// # Panics
    /// When the packet is full.
    #[inline(always)]
    pub fn push(&mut self, origin: Vec3, direction: Vec3, tmax: f32) -> usize {
        assert!(self.len < PACKET_RAYS, "a ray packet holds at most {PACKET_RAYS} rays");
        let i = self.len;
        let direction = positive_zeros(direction);
        for axis in 0..3 {
            self.origin[axis][i] = origin[axis];
            self.direction[axis][i] = direction[axis];
        }
        self.tmax[i] = tmax;
        self.len += 1;
        i
    }

    /// Replaces the rays with those of the lanes in `lanes` (bit `k` for lane `k`), in lane
    /// order: [`RayPacket::push`] of each, as vector copies where `lanes` is a run from lane
    /// 0 (a packet's camera rays, the shadow rays of a fully lit tile), else lane by lane.
    #[allow(clippy::needless_range_loop)] // Lane loops: the form the vectoriser takes.
    #[inline(always)]
    pub fn set_lanes(&mut self, origin: &Lanes3, direction: &Lanes3, tmax: &Lanes, lanes: u64) {
        self.clear();
        let count = lanes.count_ones() as usize;
        if lanes != 0 && lanes == u64::MAX >> (64 - count) {
            for axis in 0..3 {
                for k in 0..PACKET_RAYS {
                    self.origin[axis][k] = origin[axis][k];
                    // `positive_zeros`.
                    self.direction[axis][k] = direction[axis][k] + 0.0;
                }
            }
            self.tmax = *tmax;
            self.len = count;
        } else {
            for k in bits(lanes) {
                self.push(lane3(origin, k), lane3(direction, k), tmax[k]);
            }
        }
    }

    /// Computes the reciprocals and sheared forms of the rays pushed since the last call, four
    /// at a time (a quad partly prepared before is prepared again, whole).
    #[inline(always)]
    fn prepare(&mut self) {
        if self.prepared == self.len {
            return;
        }
        for quad in self.prepared / 4..self.len.div_ceil(4) {
            let at = quad * 4;
            // Lanes past the last ray hold stale or zero values: every test masks them out.
            let valid = if at + 4 <= self.len { 0xF } else { (1u32 << (self.len - at)) - 1 };
            for axis in 0..3 {
                // One division per ray, as `BoxRay::new`'s vector division gives it (slices
                // of four: one `divps`).
                let (direction, inv) = (&self.direction[axis][at..at + 4], &mut self.inv[axis][at..at + 4]);
                for (inv, d) in inv.iter_mut().zip(direction) {
                    *inv = 1.0 / d;
                }
            }
            self.quads.prepare(quad, &self.origin, &self.direction, valid);
        }
        self.prepared = self.len;
    }

    /// Ray `r` as the box test of a single ray takes it.
    #[inline(always)]
    fn box_ray(&self, r: usize) -> BoxRay {
        // Element by element: `map` on the arrays would copy them whole first.
        let (o, i) = (&self.origin, &self.inv);
        BoxRay::from_parts([o[0][r], o[1][r], o[2][r]], [i[0][r], i[1][r], i[2][r]])
    }

    /// Ray `r`'s origin.
    #[inline(always)]
    fn origin(&self, r: usize) -> Vec3A {
        Vec3A::new(self.origin[0][r], self.origin[1][r], self.origin[2][r])
    }

    /// Rays of `rays` that enter child `lane` of `node` before their `tmax`, four at a time
    /// ([`WideNode::lane_enters`]); with `first_only`, only the lowest such ray.
    #[inline(always)]
    fn reach(&self, node: &WideNode, lane: usize, rays: u64, tmax: &[f32; PACKET_RAYS], first_only: bool) -> u64 {
        let mut reach = 0u64;
        for (quad, lanes) in quads(rays) {
            let entered = u64::from(node.lane_enters(lane, &self.origin, &self.inv, tmax, quad * 4) & lanes);
            if entered != 0 {
                if first_only {
                    return (entered & entered.wrapping_neg()) << (quad * 4);
                }
                reach |= entered << (quad * 4);
            }
        }
        reach
    }

    /// Calls `found(ray, (t, b1, b2), tmax)` for each ray of `rays` that hits `tri` within
    /// `(0, tmax[ray])`: four rays at a time where a quad's rays share their axis permutation
    /// ([`QuadRays`]), else, and for a lane on an edge, one ray at a time. A ray's `tmax` may be
    /// shortened by `found` before a later ray is tested, never its own before its test.
    #[inline(always)]
    fn for_each_hit(
        &self,
        tri: &[Vec3A; 3],
        rays: u64,
        tmax: &mut [f32; PACKET_RAYS],
        mut found: impl FnMut(usize, (f32, f32, f32), &mut [f32; PACKET_RAYS]),
    ) {
        for (quad, lanes) in quads(rays) {
            let one_by_one = if self.quads.is_shared(quad) {
                let quad_hits = self.quads.intersect(quad, lanes, tri, 0.0, tmax);
                for lane in bits(u64::from(quad_hits.hit)) {
                    let hit = (quad_hits.t[lane], quad_hits.b1[lane], quad_hits.b2[lane]);
                    found(quad * 4 + lane, hit, tmax);
                }
                quad_hits.retry
            } else {
                lanes
            };
            for lane in bits(u64::from(one_by_one)) {
                let r = quad * 4 + lane;
                if let Some(hit) = self.quads.sheared(r, self.origin(r)).intersect(tri, 0.0, tmax[r]) {
                    found(r, hit, tmax);
                }
            }
        }
    }

    /// Bit mask of every ray in the packet.
    #[inline(always)]
    fn all(&self) -> u64 {
        if self.len == PACKET_RAYS { u64::MAX } else { (1u64 << self.len) - 1 }
    }

    /// Keeps in `candidates` only the boxes (`bounds(i)` = `[lo, hi]`) that some ray of the
    /// packet may enter before its `tmax`: a box is dropped only when the packet's interval
    /// bounds prove that no ray reaches it. For culling per-ray tests that are not in the BVH
    /// (the rect emitters a camera ray may see) once per packet.
    #[inline(always)]
    pub fn keep_reachable(&mut self, candidates: &mut Vec<u32>, bounds: impl Fn(u32) -> (Vec3, Vec3)) {
        if self.len == 0 {
            candidates.clear();
        }
        if candidates.is_empty() {
            // Nothing to keep (a house lit only by lamps): no bounds to build.
            return;
        }
        self.prepare();
        let packet = PacketBounds::new(self, self.all(), &self.tmax);
        // A loop, not `retain` with a closure, which was compiled out of line, with baseline
        // code, in the AVX2 build of the tile loop (`scene_gen_core::simd`).
        let mut kept = 0;
        for k in 0..candidates.len() {
            let i = candidates[k];
            let (lo, hi) = bounds(i);
            if !packet.rejects(lo, hi) {
                candidates[kept] = i;
                kept += 1;
            }
        }
        candidates.truncate(kept);
    }
}

/// Interval bounds of a packet for the box rejection test: per axis the range of origins and,
/// where every ray's inverse direction is finite and of one sign, its range.
struct PacketBounds {
    origin_min: Vec3,
    origin_max: Vec3,
    inv_min: Vec3,
    inv_max: Vec3,
    /// Per axis: whether the inverse-direction range is usable.
    bounded: [bool; 3],
    tmax: f32,
}

impl PacketBounds {
    #[inline(always)]
    fn new(packet: &RayPacket, rays: u64, tmax: &[f32; PACKET_RAYS]) -> PacketBounds {
        let mut b = PacketBounds {
            origin_min: Vec3::INFINITY,
            origin_max: Vec3::NEG_INFINITY,
            inv_min: Vec3::INFINITY,
            inv_max: Vec3::NEG_INFINITY,
            bounded: [true; 3],
            tmax: 0.0,
        };
        b.gather(packet, rays, tmax);
        for axis in 0..3 {
            let (lo, hi) = (b.inv_min[axis], b.inv_max[axis]);
            b.bounded[axis] = lo.is_finite() && hi.is_finite() && (lo > 0.0 || hi < 0.0);
        }
        b
    }

    /// The ranges of origins and reciprocals and the largest `tmax` of `rays`: ray by ray off
    /// x86-64, a quad at a time with SSE on it (minima and maxima are exact, so the ranges are
    /// the same; no value is NaN).
    #[inline(always)]
    fn gather(&mut self, packet: &RayPacket, rays: u64, tmax: &[f32; PACKET_RAYS]) {
        #[cfg(target_arch = "x86_64")]
        {
            self.gather_sse(packet, rays, tmax);
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            for r in bits(rays) {
                let ray = packet.box_ray(r);
                self.origin_min = self.origin_min.min(ray.origin());
                self.origin_max = self.origin_max.max(ray.origin());
                self.inv_min = self.inv_min.min(ray.inv_direction());
                self.inv_max = self.inv_max.max(ray.inv_direction());
                self.tmax = self.tmax.max(tmax[r]);
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn gather_sse(&mut self, packet: &RayPacket, rays: u64, tmax: &[f32; PACKET_RAYS]) {
        use crate::sse::{load, select};
        use std::arch::x86_64::{
            __m128, _mm_and_si128, _mm_castsi128_ps, _mm_cmpeq_epi32, _mm_max_ps, _mm_min_ps, _mm_set_epi32,
            _mm_set1_epi32, _mm_set1_ps, _mm_storeu_ps,
        };
        // SAFETY: SSE and SSE2 are in every x86-64 CPU (the target's baseline), and each store
        // touches a four-float array.
        unsafe {
            let (inf, neg_inf, zero) = (_mm_set1_ps(f32::INFINITY), _mm_set1_ps(f32::NEG_INFINITY), _mm_set1_ps(0.0));
            let lane_bits = _mm_set_epi32(8, 4, 2, 1);
            let mut lo = [inf; 6];
            let mut hi = [neg_inf; 6];
            let mut far = zero;
            for (quad, lanes) in quads(rays) {
                let at = quad * 4;
                let lanes = _mm_set1_epi32(lanes as i32);
                let m = _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(lanes, lane_bits), lane_bits));
                for (k, values) in packet.origin.iter().chain(&packet.inv).enumerate() {
                    let v = load(values, at);
                    lo[k] = _mm_min_ps(lo[k], select(m, v, inf));
                    hi[k] = _mm_max_ps(hi[k], select(m, v, neg_inf));
                }
                far = _mm_max_ps(far, select(m, load(tmax, at), zero));
            }
            let lanes = |v: __m128| {
                let mut out = [0.0f32; 4];
                _mm_storeu_ps(out.as_mut_ptr(), v);
                out
            };
            let min = |v: __m128| lanes(v).into_iter().fold(f32::INFINITY, f32::min);
            let max = |v: __m128| lanes(v).into_iter().fold(f32::NEG_INFINITY, f32::max);
            self.origin_min = Vec3::new(min(lo[0]), min(lo[1]), min(lo[2]));
            self.origin_max = Vec3::new(max(hi[0]), max(hi[1]), max(hi[2]));
            self.inv_min = Vec3::new(min(lo[3]), min(lo[4]), min(lo[5]));
            self.inv_max = Vec3::new(max(hi[3]), max(hi[4]), max(hi[5]));
            self.tmax = max(far).max(0.0);
        }
    }

    /// Sets the far end of the interval to the largest `tmax` of `rays`: all a leaf changes
    /// when it shortens rays but removes none (closest hits), so the origin and direction
    /// ranges stay.
    #[inline(always)]
    fn refresh_tmax(&mut self, rays: u64, tmax: &[f32; PACKET_RAYS]) {
        self.tmax = 0.0;
        for r in bits(rays) {
            self.tmax = self.tmax.max(tmax[r]);
        }
    }

    /// Whether no ray of the packet can enter the box `[lo, hi]` within its `tmax`.
    #[inline(always)]
    fn rejects(&self, lo: Vec3, hi: Vec3) -> bool {
        let mut enter = 0.0f32;
        let mut exit = entry_limit(self.tmax);
        for axis in 0..3 {
            if !self.bounded[axis] {
                continue;
            }
            let (enter_lo, exit_hi) = self.slab(axis, lo[axis], hi[axis]);
            enter = enter.max(enter_lo - enter_lo.abs() * INTERVAL_PAD);
            exit = exit.min(exit_hi + exit_hi.abs() * INTERVAL_PAD);
        }
        enter > exit
    }

    /// Over all origins and inverse directions of the packet, the smallest distance to the
    /// entry plane and the largest to the exit plane of the slab `[lo, hi]` of a bounded axis.
    #[inline(always)]
    fn slab(&self, axis: usize, lo: f32, hi: f32) -> (f32, f32) {
        let (i0, i1) = (self.inv_min[axis], self.inv_max[axis]);
        let near_a = (lo - self.origin_max[axis], lo - self.origin_min[axis]);
        let far_a = (hi - self.origin_max[axis], hi - self.origin_min[axis]);
        let products = |a: (f32, f32)| [a.0 * i0, a.0 * i1, a.1 * i0, a.1 * i1];
        let (p_lo, p_hi) = (products(near_a), products(far_a));
        // Finite products (a bounded axis has finite, non-zero inverse directions), so plain
        // comparisons suffice.
        let min4 = |p: [f32; 4]| p.into_iter().fold(f32::INFINITY, |a, t| if t < a { t } else { a });
        let max4 = |p: [f32; 4]| p.into_iter().fold(f32::NEG_INFINITY, |a, t| if t > a { t } else { a });
        // Entry is the nearer plane, exit the farther, whichever way the rays point.
        if i0 > 0.0 { (min4(p_lo), max4(p_hi)) } else { (min4(p_hi), max4(p_lo)) }
    }

    /// [`PacketBounds::rejects`] for the eight child boxes of `node` at once: bit `lane` set
    /// where no ray can enter child `lane` (empty lanes' bits are meaningless). SSE on x86-64,
    /// four lanes at a time; the products are the same and the minima and maxima exact, so the
    /// answers are the scalar test's.
    #[inline(always)]
    fn rejects_lanes(&self, node: &WideNode) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            self.rejects_lanes_sse(node)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut mask = 0;
            for lane in 0..LANES {
                let (lo, hi) = node.child_box(lane);
                mask |= u32::from(self.rejects(lo, hi)) << lane;
            }
            mask
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn rejects_lanes_sse(&self, node: &WideNode) -> u32 {
        use std::arch::x86_64::{
            __m128, _mm_add_ps, _mm_andnot_ps, _mm_cmpgt_ps, _mm_loadu_ps, _mm_max_ps, _mm_min_ps, _mm_movemask_ps,
            _mm_mul_ps, _mm_set1_ps, _mm_sub_ps,
        };
        let mut mask = 0u32;
        for half in [0, 4] {
            // SAFETY: SSE is in every x86-64 CPU (the target's baseline), and each load touches
            // four floats at `half..half + 4` of an eight-float array.
            unsafe {
                let sign = _mm_set1_ps(-0.0);
                let pad = _mm_set1_ps(INTERVAL_PAD);
                // |x| * pad, as `f32::abs` (clear the sign bit) then the product.
                let widen = |x: __m128| _mm_mul_ps(_mm_andnot_ps(sign, x), pad);
                let mut enter = _mm_set1_ps(0.0);
                let mut exit = _mm_set1_ps(entry_limit(self.tmax));
                for axis in 0..3 {
                    if !self.bounded[axis] {
                        continue;
                    }
                    let (lo, hi) = node.slabs(axis);
                    let (lo, hi) = (_mm_loadu_ps(lo[half..].as_ptr()), _mm_loadu_ps(hi[half..].as_ptr()));
                    let (o_min, o_max) = (_mm_set1_ps(self.origin_min[axis]), _mm_set1_ps(self.origin_max[axis]));
                    let (i0, i1) = (_mm_set1_ps(self.inv_min[axis]), _mm_set1_ps(self.inv_max[axis]));
                    let products = |a0: __m128, a1: __m128| {
                        [_mm_mul_ps(a0, i0), _mm_mul_ps(a0, i1), _mm_mul_ps(a1, i0), _mm_mul_ps(a1, i1)]
                    };
                    let p_lo = products(_mm_sub_ps(lo, o_max), _mm_sub_ps(lo, o_min));
                    let p_hi = products(_mm_sub_ps(hi, o_max), _mm_sub_ps(hi, o_min));
                    let min4 = |p: [__m128; 4]| _mm_min_ps(_mm_min_ps(p[0], p[1]), _mm_min_ps(p[2], p[3]));
                    let max4 = |p: [__m128; 4]| _mm_max_ps(_mm_max_ps(p[0], p[1]), _mm_max_ps(p[2], p[3]));
                    let (enter_lo, exit_hi) =
                        if self.inv_min[axis] > 0.0 { (min4(p_lo), max4(p_hi)) } else { (min4(p_hi), max4(p_lo)) };
                    enter = _mm_max_ps(enter, _mm_sub_ps(enter_lo, widen(enter_lo)));
                    exit = _mm_min_ps(exit, _mm_add_ps(exit_hi, widen(exit_hi)));
                }
                mask |= (_mm_movemask_ps(_mm_cmpgt_ps(enter, exit)) as u32) << half;
            }
        }
        mask
    }
}

/// The quads (rays `4 q..4 q + 4`) holding a ray of `mask`, lowest first, each with the bits of
/// its rays in `mask` (bits 0..4).
#[inline(always)]
fn quads(mask: u64) -> impl Iterator<Item = (usize, u32)> {
    let mut rest = mask;
    std::iter::from_fn(move || {
        (rest != 0).then(|| {
            let quad = rest.trailing_zeros() as usize / 4;
            rest &= !(0xFu64 << (quad * 4));
            (quad, ((mask >> (quad * 4)) & 0xF) as u32)
        })
    })
}

/// What a packet traversal does at the triangles of a leaf.
trait LeafVisitor {
    /// Tests triangle `triangle` against the rays of `rays`; may shrink `tmax` and clear bits of
    /// `active`, and says whether it did (the packet's interval bounds are then out of date).
    fn visit(
        &mut self,
        accel: &Bvh,
        triangle: usize,
        rays: u64,
        tmax: &mut [f32; PACKET_RAYS],
        active: &mut u64,
    ) -> bool;
}

struct ClosestHits<'h> {
    packet: &'h RayPacket,
    hits: &'h mut [Option<Hit>],
}

impl LeafVisitor for ClosestHits<'_> {
    #[inline(always)]
    fn visit(&mut self, accel: &Bvh, triangle: usize, rays: u64, tmax: &mut [f32; PACKET_RAYS], _: &mut u64) -> bool {
        let mut changed = false;
        self.packet.for_each_hit(&accel.triangles()[triangle], rays, tmax, |r, (t, b1, b2), tmax| {
            self.hits[r] = Some(Hit { t, triangle: triangle as u32, b1, b2 });
            tmax[r] = t;
            changed = true;
        });
        changed
    }
}

struct AnyHits<'h> {
    packet: &'h RayPacket,
}

impl LeafVisitor for AnyHits<'_> {
    #[inline(always)]
    fn visit(
        &mut self,
        accel: &Bvh,
        triangle: usize,
        rays: u64,
        tmax: &mut [f32; PACKET_RAYS],
        active: &mut u64,
    ) -> bool {
        let before = *active;
        let mut blocked = 0u64;
        self.packet.for_each_hit(&accel.triangles()[triangle], rays & *active, tmax, |r, _, _| blocked |= 1 << r);
        *active &= !blocked;
        *active != before
    }
}

impl Bvh {
    /// The closest hit of every ray of `packet`, into `hits[i]` for ray `i` (`None` for a miss).
    /// The same hits as [`Bvh::closest_hit`] ray by ray (see the module docs for ties).
    ///
    /// # Panics
    /// When `hits` is shorter than the packet.
    #[inline(always)]
    pub fn closest_hits(&self, packet: &mut RayPacket, hits: &mut [Option<Hit>]) {
        packet.prepare();
        let packet = &*packet;
        let hits = &mut hits[..packet.len()];
        hits.fill(None);
        let mut tmax = packet.tmax;
        let mut active = packet.all();
        self.traverse_packet(packet, &mut tmax, &mut active, &mut ClosestHits { packet, hits });
    }

    /// Bit `i` set where ray `i` of `packet` is blocked (a shadow ray); the same answers as
    /// [`Bvh::occluded`] ray by ray.
    #[must_use]
    #[inline(always)]
    pub fn occluded_packet(&self, packet: &mut RayPacket) -> u64 {
        packet.prepare();
        let packet = &*packet;
        let mut tmax = packet.tmax;
        let all = packet.all();
        let mut active = all;
        self.traverse_packet(packet, &mut tmax, &mut active, &mut AnyHits { packet });
        all & !active
    }

    /// Walks the BVH with every ray of `active`, depth first, nearer children first.
    #[inline(always)]
    fn traverse_packet(
        &self,
        packet: &RayPacket,
        tmax: &mut [f32; PACKET_RAYS],
        active: &mut u64,
        leaf: &mut impl LeafVisitor,
    ) {
        let Some(nodes) = self.wide_nodes() else { return };
        if *active == 0 || nodes.is_empty() {
            return;
        }
        // (node, rays that may reach it): the mask narrows to the rays from the first one that
        // entered the node's box, as the rays before it missed.
        let mut stack: Vec<(u32, u64)> = Vec::with_capacity(64);
        stack.push((0, *active));
        let mut bounds = PacketBounds::new(packet, *active, tmax);
        // The rays `bounds` was built over: while they are all still active, a stale bound
        // needs only its far end refreshed.
        let mut bounded = *active;
        let mut stale = false;
        while let Some((index, rays)) = stack.pop() {
            let rays = rays & *active;
            if rays == 0 {
                continue;
            }
            if stale {
                if *active == bounded {
                    bounds.refresh_tmax(bounded, tmax);
                } else {
                    bounds = PacketBounds::new(packet, *active, tmax);
                    bounded = *active;
                }
                stale = false;
            }
            let node: &WideNode = &nodes[index as usize];
            // The first ray still in the subtree against all eight boxes, and the interval
            // bounds of the packet against all eight, each in one vector pass.
            let first = rays.trailing_zeros() as usize;
            let (first_near, first_enters) = node.enter(&packet.box_ray(first), tmax[first]);
            let rejected = bounds.rejects_lanes(node);
            let mut inner: [(f32, u32, u64); LANES] = [(0.0, 0, 0); LANES];
            let mut inner_count = 0;
            for (lane, &near_first) in first_near.iter().enumerate() {
                let Some(child) = node.child(lane) else { continue };
                let bit = 1u32 << lane;
                match child {
                    Child::Leaf { first: start, count } => {
                        if rejected & bit != 0 {
                            continue;
                        }
                        let reach = packet.reach(node, lane, rays, tmax, false);
                        if reach == 0 {
                            continue;
                        }
                        for triangle in start..start + count {
                            stale |= leaf.visit(self, triangle as usize, reach, tmax, active);
                        }
                        if *active == 0 {
                            return;
                        }
                    }
                    Child::Node(child) => {
                        let entered = if first_enters & bit != 0 {
                            Some((first, near_first))
                        } else if rejected & bit != 0 {
                            None
                        } else {
                            // The first other ray that enters, four rays tested at a time;
                            // its entry distance again by the one-ray test (the same bits).
                            let next = packet.reach(node, lane, rays & !(1u64 << first), tmax, true);
                            (next != 0)
                                .then(|| next.trailing_zeros() as usize)
                                .and_then(|r| node.lane_enter(lane, &packet.box_ray(r), tmax[r]).map(|near| (r, near)))
                        };
                        if let Some((r, near)) = entered {
                            inner[inner_count] = (near, child, rays & !((1u64 << r) - 1));
                            inner_count += 1;
                        }
                    }
                }
            }
            // Farther children go on the stack first, so the nearest is walked next.
            let inner = &mut inner[..inner_count];
            inner.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
            stack.extend(inner.iter().map(|&(_, child, mask)| (child, mask)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::quad;
    use obvhs::BvhBuildParams;

    /// A box room with a few blocks inside: many triangles, hits at many distances.
    fn room() -> Bvh {
        let walls = [
            (Vec3::new(0.0, 0.0, 0.0), Vec3::X * 6.0, Vec3::Y * 5.0),
            (Vec3::new(0.0, 0.0, 3.0), Vec3::X * 6.0, Vec3::Y * 5.0),
            (Vec3::new(0.0, 0.0, 0.0), Vec3::X * 6.0, Vec3::Z * 3.0),
            (Vec3::new(0.0, 5.0, 0.0), Vec3::X * 6.0, Vec3::Z * 3.0),
            (Vec3::new(0.0, 0.0, 0.0), Vec3::Y * 5.0, Vec3::Z * 3.0),
            (Vec3::new(6.0, 0.0, 0.0), Vec3::Y * 5.0, Vec3::Z * 3.0),
        ];
        let mut tris = Vec::new();
        for (corner, u, v) in walls {
            tris.extend(quad(corner + (u + v) * 0.5, u, v));
        }
        for k in 0..40 {
            let c = Vec3::new(0.5 + (k % 8) as f32 * 0.7, 0.5 + (k / 8) as f32 * 0.9, 0.2 + (k % 5) as f32 * 0.5);
            tris.extend(quad(c, Vec3::X * 0.3, Vec3::Y * 0.25));
            tris.extend(quad(c, Vec3::X * 0.3, Vec3::Z * 0.2));
        }
        Bvh::build(&tris, BvhBuildParams::slow_build()).0
    }

    fn directions(n: usize, spread: f32, seed: u32) -> Vec<Vec3> {
        (0..n)
            .map(|i| {
                let a = (i as f32 * 0.618 + seed as f32 * 0.37).fract() - 0.5;
                let b = (i as f32 * 0.414 + seed as f32 * 0.73).fract() - 0.5;
                Vec3::new(1.0, a * spread, b * spread - 0.2).normalize()
            })
            .collect()
    }

    #[test]
    fn packet_closest_hits_equal_single_ray_hits() {
        let accel = room();
        let origin = Vec3::new(0.3, 2.5, 1.4);
        for (spread, seed) in [(0.1, 0), (1.0, 1), (4.0, 2), (40.0, 3)] {
            let dirs = directions(PACKET_RAYS, spread, seed);
            let mut packet = RayPacket::new();
            for d in &dirs {
                packet.push(origin, *d, f32::INFINITY);
            }
            let mut hits = [None; PACKET_RAYS];
            accel.closest_hits(&mut packet, &mut hits);
            for (i, d) in dirs.iter().enumerate() {
                assert_eq!(hits[i], accel.closest_hit(origin, *d, f32::INFINITY), "ray {i}, spread {spread}");
                assert!(hits[i].is_some(), "a closed room is hit everywhere");
            }
        }
    }

    #[test]
    fn packet_occlusion_equals_single_ray_occlusion_for_mixed_origins_and_short_packets() {
        let accel = room();
        let light = Vec3::new(3.0, 2.5, 2.9);
        for len in [1, 7, PACKET_RAYS] {
            let mut packet = RayPacket::new();
            let mut rays = Vec::new();
            for i in 0..len {
                let p =
                    Vec3::new(0.1 + (i % 8) as f32 * 0.73, 0.1 + (i / 8) as f32 * 0.61, 0.01 + (i % 3) as f32 * 0.4);
                let d = light - p;
                let dist = d.length();
                rays.push((p, d / dist, dist - 1e-3));
                packet.push(p, d / dist, dist - 1e-3);
            }
            let blocked = accel.occluded_packet(&mut packet);
            let expected: u64 = rays
                .iter()
                .enumerate()
                .filter(|(_, (p, d, t))| accel.occluded(*p, *d, *t))
                .map(|(i, _)| 1u64 << i)
                .sum();
            assert_eq!(blocked, expected, "{len} rays");
            if len > 1 {
                assert!(expected != 0 && expected != packet.all(), "a mix of blocked and free rays");
            }
        }
    }

    #[test]
    fn the_vector_rejection_test_is_the_scalar_one_and_never_rejects_a_box_a_ray_enters() {
        let accel = room();
        let nodes = accel.wide_nodes().expect("a room has triangles");
        let (mut rejected, mut kept) = (0, 0);
        for (spread, seed, tmax) in [(0.1, 0, f32::INFINITY), (1.0, 1, 3.0), (4.0, 2, f32::INFINITY), (40.0, 3, 1.0)] {
            let mut packet = RayPacket::new();
            for (i, d) in directions(PACKET_RAYS, spread, seed).iter().enumerate() {
                let origin = Vec3::new(0.3 + (i % 8) as f32 * 0.01, 2.5, 1.4 + (i / 8) as f32 * 0.01);
                packet.push(origin, *d, tmax);
            }
            packet.prepare();
            let bounds = PacketBounds::new(&packet, packet.all(), &packet.tmax);
            for node in nodes {
                let lanes = bounds.rejects_lanes(node);
                for lane in (0..LANES).filter(|&lane| node.child(lane).is_some()) {
                    let (lo, hi) = node.child_box(lane);
                    let scalar = bounds.rejects(lo, hi);
                    assert_eq!(lanes >> lane & 1 == 1, scalar, "lane {lane}, spread {spread}");
                    if scalar {
                        rejected += 1;
                        for r in 0..packet.len() {
                            assert!(node.lane_enter(lane, &packet.box_ray(r), tmax).is_none(), "ray {r} enters");
                        }
                    } else {
                        kept += 1;
                    }
                }
            }
        }
        assert!(rejected > 0 && kept > 0, "both answers occur ({rejected} rejected, {kept} kept)");
    }

    #[test]
    fn four_ray_box_tests_and_bounds_are_the_one_ray_ones() {
        let accel = room();
        let nodes = accel.wide_nodes().expect("a room has triangles");
        let (mut entered, mut missed) = (0, 0);
        for (len, spread, seed) in [(PACKET_RAYS, 0.3, 0), (37, 4.0, 1), (5, 40.0, 2)] {
            let mut packet = RayPacket::new();
            for (i, d) in directions(len, spread, seed).iter().enumerate() {
                let origin = Vec3::new(0.3 + (i % 8) as f32 * 0.2, 2.5 - (i / 8) as f32 * 0.1, 1.4);
                // Axis-parallel rays too: a zero component, an infinite reciprocal.
                let d = if i % 9 == 0 { Vec3::new(0.0, 0.0, -1.0) } else { *d };
                packet.push(origin, d, 1.0 + (i % 5) as f32);
            }
            packet.prepare();
            let tmax = packet.tmax;
            // Every ray, every other ray, and a scattered few.
            for rays in [packet.all(), packet.all() & 0x5555_5555_5555_5555, packet.all() & 0x8000_0100_2000_0003] {
                for node in nodes {
                    for lane in (0..LANES).filter(|&lane| node.child(lane).is_some()) {
                        let one_by_one: u64 = bits(rays)
                            .filter(|&r| node.lane_enter(lane, &packet.box_ray(r), tmax[r]).is_some())
                            .map(|r| 1u64 << r)
                            .sum();
                        assert_eq!(packet.reach(node, lane, rays, &tmax, false), one_by_one);
                        let lowest = one_by_one & one_by_one.wrapping_neg();
                        assert_eq!(packet.reach(node, lane, rays, &tmax, true), lowest);
                        entered += one_by_one.count_ones();
                        missed += (rays & !one_by_one).count_ones();
                    }
                }
                let b = PacketBounds::new(&packet, rays, &tmax);
                let rays_of = || bits(rays).map(|r| packet.box_ray(r));
                let fold = |f: fn(Vec3, Vec3) -> Vec3, start: Vec3, part: fn(&BoxRay) -> Vec3| {
                    rays_of().fold(start, |acc, ray| f(acc, part(&ray)))
                };
                assert_eq!(b.origin_min, fold(Vec3::min, Vec3::INFINITY, BoxRay::origin));
                assert_eq!(b.origin_max, fold(Vec3::max, Vec3::NEG_INFINITY, BoxRay::origin));
                assert_eq!(b.inv_min, fold(Vec3::min, Vec3::INFINITY, BoxRay::inv_direction));
                assert_eq!(b.inv_max, fold(Vec3::max, Vec3::NEG_INFINITY, BoxRay::inv_direction));
                assert_eq!(b.tmax, bits(rays).map(|r| tmax[r]).fold(0.0, f32::max));
            }
        }
        assert!(entered > 0 && missed > 0, "both answers occur ({entered} entered, {missed} missed)");
    }

    #[test]
    fn an_empty_scene_and_an_empty_packet_hit_nothing() {
        let accel = Bvh::build(&[], BvhBuildParams::slow_build()).0;
        let mut packet = RayPacket::new();
        assert_eq!(accel.occluded_packet(&mut packet), 0);
        packet.push(Vec3::ZERO, Vec3::X, 10.0);
        let mut hits = [Some(Hit { t: 1.0, triangle: 0, b1: 0.0, b2: 0.0 })];
        accel.closest_hits(&mut packet, &mut hits);
        assert_eq!(hits, [None]);
        assert_eq!(accel.occluded_packet(&mut packet), 0);
    }
}
