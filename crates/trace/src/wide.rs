//! The BVH the renderer walks: obvhs' compressed-wide tree (CWBVH) with its quantised child
//! boxes replaced by exact `f32` boxes, laid out so one node's eight child boxes are tested with
//! eight-lane loops.
//!
//! Why not walk obvhs' nodes as they are: a CWBVH node stores each child box as 8-bit offsets on
//! a per-node grid (Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal on GPUs Through
//! Compressed Wide BVHs", HPG 2017), which saves memory bandwidth on a GPU. On a CPU the
//! dequantisation is the costliest part of obvhs' node test (its own comment says so), and the
//! rounded-out boxes are looser than the geometry. A house's BVH is a few hundred kilobytes
//! either way, so the tree is kept (obvhs builds it, with the topology and leaf order it chose)
//! and each child's box is recomputed exactly from its triangles, bottom up, into structure-of-
//! arrays planes: `lo[axis][lane]`, `hi[axis][lane]`. [`WideNode::enter`] tests them with SSE,
//! four lanes at a time: SSE is in the x86-64 baseline, so both builds of the tile loop
//! ([`scene_gen_core::simd`]) run the same instructions and get the same IEEE results, and
//! [`WideNode::lane_enter`] repeats the arithmetic for one lane, bit for bit.
//!
//! Robustness: a ray that hits a triangle must enter every box above it. The boxes are exact
//! and the slab distances are widened by Ize's bound ("Robust BVH Ray Traversal", JCGT 2(2),
//! 2013): the far distance is scaled by `1 + 2 gamma(3)`, which covers the rounding of the
//! subtraction, the product with the rounded reciprocal and the reciprocal itself. A closest-hit
//! walk also widens the other end: a box is pruned only when it begins past the nearest hit so
//! far by more than [`TMAX_SCALE`], so every walk order (one ray, or a packet) finds the same
//! nearest triangle.

use glam::{Vec3, Vec3A};
use obvhs::cwbvh::CwBvh;

use crate::packet::PACKET_RAYS;

/// Children per node: obvhs' CWBVH is eight wide.
pub(super) const LANES: usize = 8;

/// `1 + 2 gamma(3)` with `gamma(n) = n u / (1 - n u)`, `u = 2^-24`: Ize's factor for the far
/// slab distance, plus one ulp for the rounding of the product with it.
const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5) + f32::EPSILON;

/// How far past a ray's `tmax` a box may begin and still be entered: `1 + 64 u`.
///
/// Why pad `tmax` at all: a closest-hit walk shrinks `tmax` to the nearest hit so far and prunes
/// every box that begins past it. A box's entry distance is rounded up by as much as
/// `gamma(3)`, and a hit's distance from the watertight test by a few `u` either way, so a
/// triangle lying on a box's face can be nearer than the current hit while the box's rounded
/// entry lies past it. Unpadded, whether that triangle is found depended on the order of the
/// walk: a packet and a single ray could report hits one ulp apart. `64 u` covers both roundings
/// for any ray that is not grazing its triangle; the only cost is a leaf tested now and then
/// whose triangles all lie a few ulps too far.
const TMAX_SCALE: f32 = 1.0 + 32.0 * f32::EPSILON;

/// The farthest entry distance a box test accepts for a ray whose nearest hit may lie at
/// `tmax` ([`TMAX_SCALE`]); `+inf` stays `+inf`.
#[inline(always)]
pub(super) fn entry_limit(tmax: f32) -> f32 {
    tmax * TMAX_SCALE
}

/// A leaf child's `count` is its number of triangles (1..); an inner child's is 0.
const INNER: u32 = 0;

/// Entries the traversal stack holds before it spills to the heap: eight-wide trees are
/// shallow, and a node pushes at most seven.
const STACK: usize = 96;

/// One node: eight child boxes as planes, and what each child is.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct WideNode {
    /// Lower corners per axis and lane; `+inf` in an empty lane.
    lo: [[f32; LANES]; 3],
    /// Upper corners per axis and lane; `-inf` in an empty lane.
    hi: [[f32; LANES]; 3],
    /// An inner child's node index, or a leaf's first triangle (BVH primitive order).
    child: [u32; LANES],
    /// [`INNER`], or the leaf's triangle count.
    count: [u32; LANES],
}

/// A ray as the box test wants it: origin, reciprocal direction, and which plane of each slab it
/// meets first.
#[derive(Clone, Copy, Debug)]
pub(super) struct BoxRay {
    origin: [f32; 3],
    inv: [f32; 3],
    negative: [bool; 3],
}

impl BoxRay {
    /// `direction` must have no `-0.0` component ([`crate::bvh::positive_zeros`]), so a zero
    /// component gives `+inf` and the lower plane first.
    #[inline(always)]
    pub(super) fn new(origin: Vec3, direction: Vec3) -> BoxRay {
        // One vector division (`Vec3A`) for the three reciprocals; the same values as three
        // scalar ones.
        let inv = Vec3::from(Vec3A::from(direction).recip());
        BoxRay { origin: origin.to_array(), inv: inv.to_array(), negative: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0] }
    }

    /// The ray with origin `origin` and reciprocal direction `inv` (as [`BoxRay::new`] computes
    /// it): for rays whose reciprocals were computed four at a time.
    #[inline(always)]
    pub(super) fn from_parts(origin: [f32; 3], inv: [f32; 3]) -> BoxRay {
        BoxRay { origin, inv, negative: inv.map(|i| i < 0.0) }
    }

    /// The ray's origin.
    #[cfg(any(test, not(target_arch = "x86_64")))]
    #[inline(always)]
    pub(super) fn origin(&self) -> Vec3 {
        Vec3::from_array(self.origin)
    }

    /// The ray's reciprocal direction (`+inf` for a zero component).
    #[cfg(any(test, not(target_arch = "x86_64")))]
    #[inline(always)]
    pub(super) fn inv_direction(&self) -> Vec3 {
        Vec3::from_array(self.inv)
    }
}

/// What a traversal step found in a child: a node to descend into or triangles to test.
#[derive(Clone, Copy, Debug)]
pub(super) enum Child {
    Node(u32),
    Leaf { first: u32, count: u32 },
}

impl WideNode {
    /// A node of empty lanes.
    const EMPTY: WideNode = WideNode {
        lo: [[f32::INFINITY; LANES]; 3],
        hi: [[f32::NEG_INFINITY; LANES]; 3],
        child: [0; LANES],
        count: [INNER; LANES],
    };

    /// Entry distances of `ray` into the eight child boxes, and a bit per lane it enters
    /// before `tmax`.
    ///
    /// On x86-64: SSE, four lanes at a time (SSE2 is part of the baseline, so both builds of
    /// the tile loop run it; LLVM's auto-vectoriser split the far-plane half of the plain lane
    /// loop into scattered scalar pieces, which was slower than obvhs' own test). Elsewhere the
    /// plain loop. Both give [`WideNode::lane_enter`]'s answers bit for bit: `maxps(t, acc)` is
    /// `larger(acc, t)` and `minps(t, acc)` is `smaller(acc, t)`, NaN included.
    #[inline(always)]
    pub(super) fn enter(&self, ray: &BoxRay, tmax: f32) -> ([f32; LANES], u32) {
        #[cfg(target_arch = "x86_64")]
        {
            self.enter_sse(ray, tmax)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut near = [0.0f32; LANES];
            let mut mask = 0u32;
            for lane in 0..LANES {
                if let Some(t) = self.lane_enter(lane, ray, tmax) {
                    near[lane] = t;
                    mask |= 1 << lane;
                }
            }
            (near, mask)
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn enter_sse(&self, ray: &BoxRay, tmax: f32) -> ([f32; LANES], u32) {
        use std::arch::x86_64::{
            _mm_cmple_ps, _mm_loadu_ps, _mm_max_ps, _mm_min_ps, _mm_movemask_ps, _mm_mul_ps, _mm_set1_ps,
            _mm_setzero_ps, _mm_storeu_ps, _mm_sub_ps,
        };
        let planes = [0, 1, 2].map(|axis| self.planes(ray, axis));
        let mut near_out = [0.0f32; LANES];
        let mut mask = 0u32;
        for half in [0, 4] {
            // SAFETY: SSE and SSE2 are in every x86-64 CPU (the target's baseline), and each
            // load or store touches four floats at `half..half + 4` of an eight-float array.
            unsafe {
                let mut near = _mm_setzero_ps();
                let mut far = _mm_set1_ps(entry_limit(tmax));
                for (axis, (first, second)) in planes.iter().enumerate() {
                    let o = _mm_set1_ps(ray.origin[axis]);
                    let inv = _mm_set1_ps(ray.inv[axis]);
                    let t_first = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(first[half..].as_ptr()), o), inv);
                    let t_second = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(second[half..].as_ptr()), o), inv);
                    near = _mm_max_ps(t_first, near);
                    far = _mm_min_ps(_mm_mul_ps(t_second, _mm_set1_ps(FAR_SCALE)), far);
                }
                _mm_storeu_ps(near_out[half..].as_mut_ptr(), near);
                mask |= (_mm_movemask_ps(_mm_cmple_ps(near, far)) as u32) << half;
            }
        }
        (near_out, mask)
    }

    /// The near and far planes of axis `axis` for `ray`: the lower corners first where the ray
    /// runs towards `+axis`.
    #[inline(always)]
    fn planes(&self, ray: &BoxRay, axis: usize) -> (&[f32; LANES], &[f32; LANES]) {
        if ray.negative[axis] { (&self.hi[axis], &self.lo[axis]) } else { (&self.lo[axis], &self.hi[axis]) }
    }

    /// [`WideNode::enter`] for one lane, with the same arithmetic (same answers, bit for bit):
    /// for the packet traversal, which tests rays one by one against a child.
    #[inline(always)]
    pub(super) fn lane_enter(&self, lane: usize, ray: &BoxRay, tmax: f32) -> Option<f32> {
        let (mut near, mut far) = (0.0f32, entry_limit(tmax));
        for axis in 0..3 {
            let (first, second) = self.planes(ray, axis);
            let (o, inv) = (ray.origin[axis], ray.inv[axis]);
            near = larger(near, (first[lane] - o) * inv);
            far = smaller(far, (second[lane] - o) * inv * FAR_SCALE);
        }
        (near <= far).then_some(near)
    }

    /// [`WideNode::lane_enter`] for the four rays `at..at + 4` of a packet's structure of arrays
    /// (origins, reciprocal directions as [`BoxRay::new`] computes them, `tmax`): bit `i` set
    /// where ray `at + i` enters child `lane`. The same arithmetic per ray, bit for bit: SSE on
    /// x86-64, where a ray's near and far planes are picked by the sign of its reciprocal.
    #[inline(always)]
    pub(super) fn lane_enters(
        &self,
        lane: usize,
        origin: &[[f32; PACKET_RAYS]; 3],
        inv: &[[f32; PACKET_RAYS]; 3],
        tmax: &[f32; PACKET_RAYS],
        at: usize,
    ) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            self.lane_enters_sse(lane, origin, inv, tmax, at)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut mask = 0;
            for i in 0..4 {
                let r = at + i;
                let at = |a: &[[f32; PACKET_RAYS]; 3]| [a[0][r], a[1][r], a[2][r]];
                let ray = BoxRay::from_parts(at(origin), at(inv));
                mask |= u32::from(self.lane_enter(lane, &ray, tmax[r]).is_some()) << i;
            }
            mask
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn lane_enters_sse(
        &self,
        lane: usize,
        origin: &[[f32; PACKET_RAYS]; 3],
        inv: &[[f32; PACKET_RAYS]; 3],
        tmax: &[f32; PACKET_RAYS],
        at: usize,
    ) -> u32 {
        use crate::sse::select;
        use std::arch::x86_64::{
            _mm_cmple_ps, _mm_cmplt_ps, _mm_max_ps, _mm_min_ps, _mm_movemask_ps, _mm_mul_ps, _mm_set1_ps,
            _mm_setzero_ps, _mm_sub_ps,
        };
        // SAFETY: SSE and SSE2 are in every x86-64 CPU (the target's baseline); memory is read
        // only through `sse::load`.
        unsafe {
            let load = |a: &[f32; PACKET_RAYS]| crate::sse::load(a, at);
            let mut near = _mm_setzero_ps();
            let mut far = _mm_mul_ps(load(tmax), _mm_set1_ps(TMAX_SCALE));
            for axis in 0..3 {
                let (o, i) = (load(&origin[axis]), load(&inv[axis]));
                let (lo, hi) = (_mm_set1_ps(self.lo[axis][lane]), _mm_set1_ps(self.hi[axis][lane]));
                let negative = _mm_cmplt_ps(i, _mm_setzero_ps());
                let (first, second) = (select(negative, hi, lo), select(negative, lo, hi));
                near = _mm_max_ps(_mm_mul_ps(_mm_sub_ps(first, o), i), near);
                let t_second = _mm_mul_ps(_mm_sub_ps(second, o), i);
                far = _mm_min_ps(_mm_mul_ps(t_second, _mm_set1_ps(FAR_SCALE)), far);
            }
            _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32
        }
    }

    /// Child `lane`, `None` for an empty lane.
    #[inline(always)]
    pub(super) fn child(&self, lane: usize) -> Option<Child> {
        if self.lo[0][lane] > self.hi[0][lane] {
            return None;
        }
        Some(match self.count[lane] {
            INNER => Child::Node(self.child[lane]),
            count => Child::Leaf { first: self.child[lane], count },
        })
    }

    /// The lower and upper planes of axis `axis`, one per lane.
    #[inline(always)]
    pub(super) fn slabs(&self, axis: usize) -> (&[f32; LANES], &[f32; LANES]) {
        (&self.lo[axis], &self.hi[axis])
    }

    /// The box of child `lane` (meaningless for an empty lane).
    #[cfg(any(test, not(target_arch = "x86_64")))]
    #[inline(always)]
    pub(super) fn child_box(&self, lane: usize) -> (Vec3, Vec3) {
        let lo = Vec3::new(self.lo[0][lane], self.lo[1][lane], self.lo[2][lane]);
        let hi = Vec3::new(self.hi[0][lane], self.hi[1][lane], self.hi[2][lane]);
        (lo, hi)
    }
}

/// `t` where it is larger than `acc`, else `acc`; a NaN `t` (`0 * inf`: an axis-parallel ray
/// in a box's plane) is skipped. One `maxps` per lane.
#[inline(always)]
fn larger(acc: f32, t: f32) -> f32 {
    if t > acc { t } else { acc }
}

/// `t` where it is smaller than `acc`, else `acc`; NaN skipped, as in [`larger`].
#[inline(always)]
fn smaller(acc: f32, t: f32) -> f32 {
    if t < acc { t } else { acc }
}

/// obvhs' CWBVH with exact child boxes ([`WideNode`]); node 0 is the root.
#[derive(Clone, Debug)]
pub(super) struct WideBvh {
    nodes: Vec<WideNode>,
}

impl WideBvh {
    /// The tree of `bvh` with every child box recomputed from `triangles` (in `bvh`'s primitive
    /// order, as its leaves index them).
    pub(super) fn new(bvh: &CwBvh, triangles: &[[Vec3A; 3]]) -> WideBvh {
        let mut nodes = vec![WideNode::EMPTY; bvh.nodes.len()];
        if !bvh.nodes.is_empty() {
            fill(bvh, triangles, 0, &mut nodes);
        }
        WideBvh { nodes }
    }

    /// The nodes; node 0 is the root.
    #[inline(always)]
    pub(super) fn nodes(&self) -> &[WideNode] {
        &self.nodes
    }

    /// Walks the tree with one ray: the visitor tests the triangles of every leaf the ray
    /// enters before `tmax` (which it may shrink) and ends the walk by returning `true`.
    /// With `nearest_first`, the children a node's test accepts are walked nearest first, and
    /// a child farther than the shrunken `tmax` is skipped when its turn comes.
    #[inline(always)]
    pub(super) fn walk(&self, ray: &BoxRay, tmax: &mut f32, nearest_first: bool, leaf: &mut impl LeafTest) {
        let Some(root) = self.nodes.first() else { return };
        let mut stack = Stack::new();
        let mut node = root;
        loop {
            let (near, mut mask) = node.enter(ray, *tmax);
            let mut found = [(0.0f32, 0usize); LANES];
            let mut n = 0;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                found[n] = (near[lane], lane);
                n += 1;
            }
            if nearest_first && n > 1 {
                // Insertion sort, farthest first: the nearest ends on top of the stack.
                for i in 1..n {
                    let mut j = i;
                    while j > 0 && found[j - 1].0 < found[j].0 {
                        found.swap(j - 1, j);
                        j -= 1;
                    }
                }
            }
            for &(t, lane) in &found[..n] {
                stack.push(Entry { t, child: node.child[lane], count: node.count[lane] });
            }
            // The next inner node to enter; leaves are tested as they come off the stack.
            node = loop {
                let Some(entry) = stack.pop() else { return };
                if entry.t > entry_limit(*tmax) {
                    continue;
                }
                if entry.count == INNER {
                    break &self.nodes[entry.child as usize];
                }
                if leaf.test(entry.child, entry.count, tmax) {
                    return;
                }
            };
        }
    }
}

/// Tests a leaf's triangles for [`WideBvh::walk`].
pub(super) trait LeafTest {
    /// Tests triangles `first..first + count`; may shrink `tmax`; `true` ends the walk.
    fn test(&mut self, first: u32, count: u32, tmax: &mut f32) -> bool;
}

/// A child waiting on the stack: its entry distance and what it is (as in [`WideNode`]: a node
/// index with count [`INNER`], or a leaf's triangles). Empty lanes never get here: their
/// inverted boxes are entered by no ray.
#[derive(Clone, Copy)]
struct Entry {
    t: f32,
    child: u32,
    count: u32,
}

/// The traversal stack: a fixed array, not zeroed per ray, with a heap spill for trees deeper
/// than it allows.
struct Stack {
    len: usize,
    items: [std::mem::MaybeUninit<Entry>; STACK],
    spill: Vec<Entry>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Stack {
        Stack { len: 0, items: [const { std::mem::MaybeUninit::uninit() }; STACK], spill: Vec::new() }
    }

    #[inline(always)]
    fn push(&mut self, entry: Entry) {
        if self.len < STACK {
            self.items[self.len].write(entry);
            self.len += 1;
        } else {
            self.spill.push(entry);
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<Entry> {
        if let Some(entry) = self.spill.pop() {
            return Some(entry);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: items `0..len` were written by `push` before `len` passed them.
        Some(unsafe { self.items[self.len].assume_init_read() })
    }
}

/// Fills `nodes[index]` from obvhs' node `index` and returns the union of its children's boxes.
fn fill(bvh: &CwBvh, triangles: &[[Vec3A; 3]], index: usize, nodes: &mut [WideNode]) -> (Vec3A, Vec3A) {
    let source = &bvh.nodes[index];
    let mut node = WideNode::EMPTY;
    let (mut all_lo, mut all_hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for lane in 0..LANES {
        if source.is_child_empty(lane) {
            continue;
        }
        let (lo, hi) = if source.is_leaf(lane) {
            let (first, count) = source.child_primitives(lane);
            node.child[lane] = first;
            node.count[lane] = count;
            let mut b = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
            for tri in &triangles[first as usize..(first + count) as usize] {
                for v in tri {
                    b = (b.0.min(*v), b.1.max(*v));
                }
            }
            b
        } else {
            let child = source.child_node_index(lane);
            node.child[lane] = child;
            node.count[lane] = INNER;
            fill(bvh, triangles, child as usize, nodes)
        };
        for axis in 0..3 {
            node.lo[axis][lane] = lo[axis];
            node.hi[axis][lane] = hi[axis];
        }
        (all_lo, all_hi) = (all_lo.min(lo), all_hi.max(hi));
    }
    nodes[index] = node;
    (all_lo, all_hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{Bvh, ShearedRay};
    use crate::test_util::room_of_boxes;
    use proptest::prelude::*;

    /// A closed 6 x 5 x 3 m room (flat floor and ceiling: zero-thickness boxes) with 36 boxes
    /// on its floor.
    fn room() -> Bvh {
        Bvh::build(&room_of_boxes(Vec3::new(6.0, 5.0, 3.0), 6), obvhs::BvhBuildParams::slow_build()).0
    }

    /// The closest hit over every triangle, by the same watertight test: what the walk must find.
    fn brute_force(accel: &Bvh, origin: Vec3, dir: Vec3, tmax: f32) -> Option<f32> {
        let sheared = ShearedRay::new(origin, dir + Vec3::ZERO);
        let mut best = None;
        let mut t_best = tmax;
        for tri in accel.triangles() {
            if let Some((t, _, _)) = sheared.intersect(tri, 0.0, t_best) {
                (best, t_best) = (Some(t), t);
            }
        }
        best
    }

    fn check(accel: &Bvh, origin: Vec3, dir: Vec3) -> Result<(), TestCaseError> {
        let expected = brute_force(accel, origin, dir, f32::INFINITY);
        let found = accel.closest_hit(origin, dir, f32::INFINITY).map(|h| h.t);
        // The same distance up to the triangle test's own rounding (about 1e-7 of the room's
        // size): where two coplanar faces meet the ray (a box's bottom on the floor) either may
        // be reported; a lost surface would leave a gap of centimetres to metres.
        let close = match (found, expected) {
            (Some(f), Some(e)) => (f - e).abs() <= 1e-5,
            (f, e) => f == e,
        };
        prop_assert!(close, "closest {:?}, every triangle {:?}: from {} along {}", found, expected, origin, dir);
        for tmax in [0.5f32, 2.0] {
            let blocked = brute_force(accel, origin, dir, tmax).is_some();
            prop_assert_eq!(accel.occluded(origin, dir, tmax), blocked, "shadow ray of {} m", tmax);
        }
        Ok(())
    }

    #[test]
    fn an_empty_lane_is_entered_by_no_ray() {
        for dir in [Vec3::X, -Vec3::X, Vec3::new(1.0, -2.0, 0.5), Vec3::new(0.0, 0.0, -1.0) + Vec3::ZERO] {
            let (_, mask) = WideNode::EMPTY.enter(&BoxRay::new(Vec3::new(0.3, -0.2, 0.1), dir), f32::INFINITY);
            assert_eq!(mask, 0, "{dir}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// The walk finds the closest hit that testing every triangle finds and the same shadow
        /// answers, for rays in any direction.
        #[test]
        fn the_walk_finds_what_testing_every_triangle_finds(
            x in 0.05f32..5.95, y in 0.05f32..4.95, z in 0.05f32..2.95,
            d in (-1f32..1.0, -1f32..1.0, -1f32..1.0),
        ) {
            let dir = Vec3::new(d.0, d.1, d.2);
            prop_assume!(dir.length() > 1e-3);
            check(&room(), Vec3::new(x, y, z), dir.normalize())?;
        }

        /// Rays that start a hair below the flat ceiling (or above the floor) and run almost
        /// parallel to it: the grazing case a quantised, unpadded box test can drop.
        #[test]
        fn grazing_rays_along_flat_surfaces_are_not_lost(
            x in 0.05f32..5.95, y in 0.05f32..4.95, gap_exp in -7f32..-2.0, slope_exp in -7f32..-1.0,
            heading in 0f32..std::f32::consts::TAU, ceiling in any::<bool>(),
        ) {
            let (gap, slope) = (10f32.powf(gap_exp), 10f32.powf(slope_exp));
            let (z, dz) = if ceiling { (3.0 - gap, slope) } else { (gap, -slope) };
            let dir = Vec3::new(heading.cos(), heading.sin(), dz).normalize();
            check(&room(), Vec3::new(x, y, z), dir)?;
        }
    }
}
