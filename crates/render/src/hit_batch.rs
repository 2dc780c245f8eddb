//! The point and directional lights of a packet's camera-ray hits, for all of them at once.
//!
//! A sampled frame lit its hits one at a time: per hit and light a chain of a square root and
//! three divisions, then a shadow ray queued, the queue sorted by light and cut into packets.
//! Here a packet's hits sit side by side, structure of arrays ([`Surfaces`], [`HitBatch`]), and
//! each light is a few passes of plain arithmetic loops over all its lanes, which the compiler
//! turns into vector code (eight lanes at a time in the AVX2 build of the tile loop,
//! [`scene_gen_core::simd`]); the shadow rays to one light then already form a packet.
//!
//! Each lane's numbers are the ones [`LightSet::direct_split`] computes for its point alone,
//! operation for operation (importance, roulette weight, direction, irradiance, ray interval),
//! and its roulette draws come from its own stream in the order `direct_split` draws them, so a
//! frame is the same either way up to the order of its sums.

// Lane loops index several arrays by lane: the form the vectoriser takes (`scene_gen_trace::lanes`).
#![allow(clippy::needless_range_loop)]

use glam::Vec3;

use super::accel::{Accel, Surfaces};
use super::lights::{Blockers, LightSet, MIN_SHADOW_PACKET, rect_importance, roulette};
use super::reach::{LightReach, Lists};
use super::responses::Responses;
use super::{GroupRgb, Sampler};
use scene_gen_trace::lanes::{Lanes, Lanes3, N, bits, lane3, mask_of, select};
use scene_gen_trace::packet::RayPacket;

/// Which hits of a packet the point and directional lights light, and what each reflects:
/// the surfaces themselves are the packet's [`Surfaces`].
pub(crate) struct HitBatch {
    /// Lanes holding a hit to light (bit `k` for lane `k`).
    lanes: u64,
    /// Radiance towards the camera per lux of irradiance, per channel: the diffuse albedo over pi.
    radiance_per_lux: Lanes3,
    /// The lane's room ([`LightReach::room_of`]): which lights may reach it.
    room: [u32; N],
}

impl Default for HitBatch {
    fn default() -> Self {
        HitBatch { lanes: 0, radiance_per_lux: [[0.0; N]; 3], room: [0; N] }
    }
}

impl HitBatch {
    /// The lanes of `lanes` with a diffuse part in `responses`, in the rooms of `reach`.
    #[inline(always)]
    pub fn fill(&mut self, surfaces: &Surfaces, responses: &Responses, lanes: u64, reach: &LightReach) {
        let rho = &responses.diffuse;
        let mut diffuse = [false; N];
        for k in 0..N {
            diffuse[k] = (rho[0][k] != 0.0) | (rho[1][k] != 0.0) | (rho[2][k] != 0.0);
        }
        for c in 0..3 {
            for k in 0..N {
                self.radiance_per_lux[c][k] = rho[c][k] * std::f32::consts::FRAC_1_PI;
            }
        }
        self.lanes = lanes & mask_of(&diffuse);
        self.room = reach.rooms_of(&surfaces.position[0], &surfaces.position[1]);
    }

    /// The room of lane `k` ([`LightReach::room_of`]) if it is in the batch.
    #[must_use]
    #[inline(always)]
    pub fn room(&self, k: usize) -> Option<usize> {
        (self.lanes >> k & 1 == 1).then_some(self.room[k] as usize)
    }

    /// The lanes in room `room`.
    #[inline(always)]
    fn lanes_in(&self, room: u32) -> u64 {
        let mut mask = 0u64;
        for (k, &r) in self.room.iter().enumerate() {
            mask |= u64::from(r == room) << k;
        }
        mask & self.lanes
    }
}

/// Per lane, the offset `d = to - position` to the point `to`, with `|d|^2`, `ns . d` and
/// `ng . d` (glam's `dot` order: `(x x' + y y') + z z'`).
#[inline(always)]
fn towards(surfaces: &Surfaces, to: Vec3) -> Towards {
    let (p, ns, ng) = (&surfaces.position, &surfaces.shading_normal, &surfaces.geometric_normal);
    let (mut d, mut dist2, mut ns_d, mut ng_d) = ([[0.0; N]; 3], [0.0; N], [0.0; N], [0.0; N]);
    for k in 0..N {
        let (dx, dy, dz) = (to.x - p[0][k], to.y - p[1][k], to.z - p[2][k]);
        (d[0][k], d[1][k], d[2][k]) = (dx, dy, dz);
        dist2[k] = dx * dx + dy * dy + dz * dz;
        ns_d[k] = ns[0][k] * dx + ns[1][k] * dy + ns[2][k] * dz;
        ng_d[k] = ng[0][k] * dx + ng[1][k] * dy + ng[2][k] * dz;
    }
    Towards { d, dist2, ns_d, ng_d }
}

/// Per lane, [`super::lights::ray_epsilon`] of the hit point.
#[inline(always)]
fn epsilon(surfaces: &Surfaces) -> Lanes {
    let p = &surfaces.position;
    let mut eps = [0.0; N];
    for (k, e) in eps.iter_mut().enumerate() {
        let [x, y, z] = [p[0][k].abs(), p[1][k].abs(), p[2][k].abs()];
        *e = 1e-4 * (1.0 + x.max(y.max(z)));
    }
    eps
}

/// Per lane, the hit point pushed off its surface by `eps` along the plane normal: a shadow
/// ray's origin (`point + ng * eps`).
#[inline(always)]
fn shadow_origins(surfaces: &Surfaces, eps: &Lanes) -> Lanes3 {
    let (p, ng) = (&surfaces.position, &surfaces.geometric_normal);
    let mut origin = [[0.0; N]; 3];
    for axis in 0..3 {
        for k in 0..N {
            origin[axis][k] = p[axis][k] + ng[axis][k] * eps[k];
        }
    }
    origin
}

/// From every lane to one point light: the offset, its squared length and its dot products
/// with the two normals.
struct Towards {
    d: Lanes3,
    dist2: Lanes,
    ns_d: Lanes,
    ng_d: Lanes,
}

impl Towards {
    /// Per lane, [`super::lights::point_importance`] of a light of intensity `luminous` cd.
    #[inline(always)]
    fn point_importance(&self, luminous: f32) -> Lanes {
        let mut b = [0.0; N];
        for k in 0..N {
            let (dist2, ns_d) = (self.dist2[k], self.ns_d[k]);
            let lit = (dist2 > 0.0) & (ns_d > 0.0) & (self.ng_d[k] > 0.0);
            b[k] = select(lit, luminous * ns_d / (dist2 * dist2.sqrt()), 0.0);
        }
        b
    }
}

/// The shadow rays of one light from the lanes of a batch, and what each adds where it is not
/// blocked.
struct LightRays {
    /// Lanes with a ray.
    lanes: u64,
    /// Per lane, unit direction towards the light.
    dir: Lanes3,
    /// Per lane, the ray's end.
    tmax: Lanes,
    /// Per lane, radiance towards the camera (nit per channel) if the ray is not blocked.
    add: Lanes3,
}

impl LightRays {
    /// The direction of lane `k`'s ray.
    #[inline(always)]
    fn dir(&self, k: usize) -> Vec3 {
        lane3(&self.dir, k)
    }
}

impl LightSet {
    /// Adds to `sums[k][group]` the radiance towards the camera that the point and directional
    /// lights give lane `k` of `hits` (at `surfaces`), as [`LightSet::direct_split`] would
    /// light it alone, times its radiance per lux. Lane `k` draws its roulette (`cull`) from `samplers[k]`.
    ///
    /// The lanes are taken room by room (a tile's hits are nearly always in one), each with
    /// the point lights of its room's list, then all of them with the directional lights. Per
    /// light, at least [`MIN_SHADOW_PACKET`] rays go through the BVH as one packet, fewer one at
    /// a time with the tile's hints in `blockers`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn light_batch(
        &self,
        accel: &Accel,
        surfaces: &Surfaces,
        hits: &HitBatch,
        cull: f32,
        samplers: &mut [Sampler],
        blockers: &Blockers,
        packet: &mut RayPacket,
        sums: &mut [GroupRgb],
    ) {
        let eps = epsilon(surfaces);
        let origins = shadow_origins(surfaces, &eps);
        let mut left = hits.lanes;
        while left != 0 {
            let room = hits.room[left.trailing_zeros() as usize];
            let lanes = hits.lanes_in(room);
            left &= !lanes;
            let lists = self.reach.lists(room as usize);
            // Each group's total importance, which only the roulette needs.
            let totals = if cull > 0.0 { self.total_importance(surfaces, lanes, lists) } else { [[0.0; N]; 2] };
            for &i in &lists.points {
                let rays = self.point_rays(i as usize, surfaces, hits, lanes, &eps, &totals, cull, samplers);
                let group = self.points[i as usize].group;
                trace_light(accel, &origins, &rays, i as usize, blockers, packet, group, sums);
            }
        }
        for i in 0..self.directionals.len() {
            let rays = self.directional_rays(i, surfaces, hits);
            let slot = self.points.len() + i;
            trace_light(accel, &origins, &rays, slot, blockers, packet, self.directionals[i].group, sums);
        }
    }

    /// Per group and lane of `lanes`, the total importance of the point and rect lights of
    /// `lists`, summed in `direct_split`'s order (points, then rects).
    #[inline(always)]
    fn total_importance(&self, surfaces: &Surfaces, lanes: u64, lists: &Lists) -> [Lanes; 2] {
        let mut totals = [[0.0f32; N]; 2];
        for &i in &lists.points {
            let light = &self.points[i as usize];
            let b = towards(surfaces, light.position).point_importance(light.luminous);
            for (total, b) in totals[light.group].iter_mut().zip(b) {
                *total += b;
            }
        }
        for &i in &lists.rects {
            let light = &self.rects[i as usize];
            for k in bits(lanes) {
                let (p, ns) = (surfaces.position(k), lane3(&surfaces.shading_normal, k));
                totals[light.group][k] += rect_importance(light, p, ns);
            }
        }
        totals
    }

    /// The shadow rays from `lanes` to point light `i`, and what each adds.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn point_rays(
        &self,
        i: usize,
        surfaces: &Surfaces,
        hits: &HitBatch,
        lanes: u64,
        eps: &Lanes,
        totals: &[Lanes; 2],
        cull: f32,
        samplers: &mut [Sampler],
    ) -> LightRays {
        let light = &self.points[i];
        let to = towards(surfaces, light.position);
        let b = to.point_importance(light.luminous);
        let mut lit = [false; N];
        for k in 0..N {
            lit[k] = b[k] > 0.0;
        }
        let mut weight = [1.0f32; N];
        let mut rays =
            LightRays { lanes: lanes & mask_of(&lit), dir: [[0.0; N]; 3], tmax: [0.0; N], add: [[0.0; N]; 3] };
        if cull > 0.0 {
            for k in bits(rays.lanes) {
                match roulette(b[k], totals[light.group][k], cull, &mut samplers[k]) {
                    Some(w) => weight[k] = w,
                    None => rays.lanes &= !(1 << k),
                }
            }
        }
        let (ns, rho) = (&surfaces.shading_normal, &hits.radiance_per_lux);
        let [r, g, b] = light.rgb_cd.to_array();
        for k in 0..N {
            let dist2 = to.dist2[k];
            let dist = dist2.sqrt();
            // `d / dist` per axis, as glam divides a vector by a scalar.
            let (x, y, z) = (to.d[0][k] / dist, to.d[1][k] / dist, to.d[2][k] / dist);
            (rays.dir[0][k], rays.dir[1][k], rays.dir[2][k]) = (x, y, z);
            let lux_per_cd = weight[k] * (ns[0][k] * x + ns[1][k] * y + ns[2][k] * z) / dist2;
            rays.add[0][k] = r * lux_per_cd * rho[0][k];
            rays.add[1][k] = g * lux_per_cd * rho[1][k];
            rays.add[2][k] = b * lux_per_cd * rho[2][k];
            rays.tmax[k] = dist - 2.0 * eps[k];
        }
        rays
    }

    /// The shadow rays from every lane of `hits` to directional light `i`, and what each adds.
    #[inline(always)]
    fn directional_rays(&self, i: usize, surfaces: &Surfaces, hits: &HitBatch) -> LightRays {
        let light = &self.directionals[i];
        let to = light.to_light;
        let mut rays = LightRays { lanes: 0, dir: [[0.0; N]; 3], tmax: [f32::INFINITY; N], add: [[0.0; N]; 3] };
        let (ng, ns, rho) = (&surfaces.geometric_normal, &surfaces.shading_normal, &hits.radiance_per_lux);
        let [r, g, b] = light.rgb_lux.to_array();
        let mut lit = [false; N];
        for k in 0..N {
            let ng_l = ng[0][k] * to.x + ng[1][k] * to.y + ng[2][k] * to.z;
            let ns_l = ns[0][k] * to.x + ns[1][k] * to.y + ns[2][k] * to.z;
            // `directional_importance` > 0.
            lit[k] = (ng_l > 0.0) & (light.luminous * ns_l.max(0.0) > 0.0);
            rays.add[0][k] = r * ns_l * rho[0][k];
            rays.add[1][k] = g * ns_l * rho[1][k];
            rays.add[2][k] = b * ns_l * rho[2][k];
        }
        for axis in 0..3 {
            rays.dir[axis] = [to[axis]; N];
        }
        rays.lanes = hits.lanes & mask_of(&lit);
        rays
    }
}

/// Traces `rays` from `origins` (to the light of [`Blockers`] slot `slot`, of light group
/// `group`) and adds each unblocked lane's light to `sums`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn trace_light(
    accel: &Accel,
    origins: &Lanes3,
    rays: &LightRays,
    slot: usize,
    blockers: &Blockers,
    packet: &mut RayPacket,
    group: usize,
    sums: &mut [GroupRgb],
) {
    let mut unblocked = 0u64;
    if (rays.lanes.count_ones() as usize) < MIN_SHADOW_PACKET {
        for k in bits(rays.lanes) {
            if !blockers.occluded(accel, slot, lane3(origins, k), rays.dir(k), rays.tmax[k]) {
                unblocked |= 1 << k;
            }
        }
    } else {
        packet.set_lanes(origins, &rays.dir, &rays.tmax, rays.lanes);
        // Ray `r` of the packet is the `r`-th lane of `rays.lanes`.
        let blocked = accel.occluded_packet(packet);
        for (r, k) in bits(rays.lanes).enumerate() {
            if blocked >> r & 1 == 0 {
                unblocked |= 1 << k;
            }
        }
    }
    for k in bits(unblocked) {
        sums[k][group] += lane3(&rays.add, k);
    }
}
