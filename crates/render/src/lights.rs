//! The scene's lights prepared for shading, and direct illuminance with shadow rays.
//!
//! Units follow [`scene_gen_scene::scene::Light`]: point lights in candela, directional lights in lux on
//! a surface facing them, rect lights in nit. A light's linear-RGB `color` is a tint: it is
//! divided by its own luminance (ITU-R BT.709 / sRGB weights) so that the luminous quantity of a
//! light of intensity `I` is exactly `I` whatever its colour; each RGB channel then carries
//! `I * color / Y(color)`. All irradiance values here are per channel, in lux.
//!
//! * point: `E = I cos(theta) / d^2`, one shadow ray;
//! * directional: `E = E_perp cos(theta)`, one shadow ray to infinity;
//! * rect (one-sided Lambertian emitter of luminance `L`): the unshadowed `E = L x` (the
//!   polygon's form factor, in closed form, `rect_irradiance_per_nit`) times the fraction
//!   of it that gets through, estimated from stratified jittered area samples, one shadow ray
//!   each (soft shadows): `sum f V / sum f`, `f = cos(theta) cos(theta') / d^2`.

use std::cell::Cell;
use std::f32::consts::PI;

use glam::Vec3;

use super::accel::{Accel, NO_TRIANGLE};
use super::reach::{LightReach, LightSource};
use super::{GroupRgb, Sampler, Strata, group_index};
use scene_gen_scene::scene::{Light, LightKind, Scene};
use scene_gen_trace::packet::RayPacket;

/// Luminance weights of linear sRGB primaries (ITU-R BT.709-6, item 3.2).
pub const LUMA_BT709: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

/// Luminance of a linear-sRGB triple.
#[must_use]
#[inline(always)]
pub fn luminance(rgb: Vec3) -> f32 {
    rgb.dot(LUMA_BT709)
}

/// A tint scaled to unit luminance (black for a non-positive tint).
fn unit_luminance_tint(color: [f32; 3]) -> Vec3 {
    let c = Vec3::from(color).max(Vec3::ZERO);
    let y = luminance(c);
    if y > 0.0 && y.is_finite() { c / y } else { Vec3::ZERO }
}

/// Margin around a rect light's box when culling camera packets against it, metres.
const EMITTER_BOUNDS_PAD_M: f32 = 1e-3;

/// Lights (points, then directionals, then rects, in [`LightSet`] order) that get a
/// [`Blockers`] slot; a house has a few dozen, and further lights are traced without a hint.
const BLOCKER_SLOTS: usize = 128;

/// Fewest shadow rays to one light from a packet's hits that [`super::hit_batch`] traces as a
/// packet; fewer go one by one, where a hint often answers with one triangle test.
pub(super) const MIN_SHADOW_PACKET: usize = 8;

/// Per light, the triangle that blocked the last shadow ray traced to it, tried first on the
/// next one ([`Accel::blocker`] says why). A hint changes the work, not the answer; it is
/// still kept per tile (or per probe), never shared, started empty: what it holds is then a
/// function of the tile alone, and frames stay the same at any thread count by construction,
/// not only because the walk and the hint's test agree.
#[derive(Debug)]
pub struct Blockers {
    last: [Cell<u32>; BLOCKER_SLOTS],
}

impl Default for Blockers {
    fn default() -> Self {
        Blockers { last: std::array::from_fn(|_| Cell::new(NO_TRIANGLE)) }
    }
}

impl Blockers {
    /// No hints yet.
    #[must_use]
    pub fn new() -> Blockers {
        Blockers::default()
    }

    /// Whether the shadow ray to light `slot` is blocked, remembering what blocked it.
    #[inline(always)]
    pub(super) fn occluded(&self, accel: &Accel, slot: usize, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        let Some(last) = self.last.get(slot) else { return accel.occluded(origin, dir, tmax) };
        match accel.blocker(origin, dir, tmax, last.get()) {
            Some(triangle) => {
                last.set(triangle);
                true
            }
            None => false,
        }
    }
}

/// Who traces the shadow rays of the point and directional lights in
/// [`LightSet::direct_split`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PointLights {
    /// `direct_split` traces them, one ray at a time, and counts their light.
    Traced,
    /// The caller lights the point with them, together with the other hits of its packet
    /// ([`super::hit_batch`]): `direct_split` leaves them out and draws nothing for them.
    Batched,
}

#[derive(Clone, Copy, Debug)]
pub(super) struct PointLight {
    pub(super) position: Vec3,
    pub(super) rgb_cd: Vec3,
    /// Luminous intensity, cd.
    pub(super) luminous: f32,
    pub(super) group: usize,
    /// The room the scene puts it in.
    room: Option<u32>,
}

#[derive(Clone, Copy, Debug)]
pub(super) struct DirectionalLight {
    /// Unit vector towards the light (opposite to its travel).
    pub(super) to_light: Vec3,
    pub(super) rgb_lux: Vec3,
    /// Illuminance facing the light, lux.
    pub(super) luminous: f32,
    pub(super) group: usize,
}

/// A one-sided Lambertian rectangle.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RectLight {
    pub center: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    /// Unit normal of the emitting side.
    pub normal: Vec3,
    pub area_m2: f32,
    pub rgb_nit: Vec3,
    /// Luminance, nit.
    pub luminous: f32,
    pub group: usize,
    /// The room the scene puts it in.
    pub room: Option<u32>,
    /// The four corners `center + u * s + v * r`, `s, r` in {-0.5, 0.5}, for the importance test.
    pub corners: [Vec3; 4],
    /// The box a camera ray must enter to see the emitter ([`seen_bounds`]).
    pub seen_bounds: (Vec3, Vec3),
}

impl RectLight {
    /// Distance to the emitting face along a unit ray that meets it from the front, if it does.
    #[inline(always)]
    pub fn hit_front(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<f32> {
        let denom = direction.dot(self.normal);
        if denom >= 0.0 {
            return None;
        }
        let t = (self.center - origin).dot(self.normal) / denom;
        if !(t > 0.0 && t < tmax) {
            return None;
        }
        let local = origin + direction * t - self.center;
        let s = local.dot(self.u) / self.u.length_squared();
        let r = local.dot(self.v) / self.v.length_squared();
        (s.abs() <= 0.5 && r.abs() <= 0.5).then_some(t)
    }
}

/// The rect lights' (windows') part of a point's direct irradiance, per group and channel, lux.
///
/// `visible` is the estimate (each light's exact unshadowed light times its sampled visible
/// share); `unshadowed` the exact light with nothing in the way, where it was asked for (else
/// zero). Their ratio is the point's visible share of its window light: the noisy factor,
/// which `render::visibility_filter` pools over neighbours while `unshadowed` stays exact
/// (the split of Heitz et al. 2018, "Combining analytic direct illumination and stochastic
/// shadows").
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RectShare {
    pub visible: GroupRgb,
    pub unshadowed: GroupRgb,
}

impl RectShare {
    /// Adds `other`, group by group.
    #[inline(always)]
    pub fn accumulate(&mut self, other: &RectShare) {
        for (sum, add) in [(&mut self.visible, &other.visible), (&mut self.unshadowed, &other.unshadowed)] {
            sum[0] += add[0];
            sum[1] += add[1];
        }
    }

    /// Both parts times `k`.
    #[must_use]
    pub fn scaled(&self, k: f32) -> RectShare {
        RectShare { visible: self.visible.map(|e| e * k), unshadowed: self.unshadowed.map(|e| e * k) }
    }
}

/// All usable lights of a scene; lights missing a field their kind needs are skipped.
#[derive(Clone, Debug, Default)]
pub struct LightSet {
    pub(super) points: Vec<PointLight>,
    pub(super) directionals: Vec<DirectionalLight>,
    pub(crate) rects: Vec<RectLight>,
    /// Per group, the brightest radiance a white Lambertian surface gets from one light at a
    /// reference distance of 1 m (point: `I / pi`, directional: `E / pi`, rect: `L`); the unit
    /// of the bounce clamp. Linear in the lights, so clamping commutes with [`super::LightScale`].
    pub(crate) reference_nit: [f32; 2],
    /// Which point and rect lights a shading point weighs, by its room ([`super::reach`]).
    pub(super) reach: LightReach,
}

impl LightSet {
    /// Prepares `scene`'s lights, each multiplied by `scale[group]`, with the lists of the
    /// lights that can reach each of its rooms (`render::reach`): a shading point weighs and
    /// traces only those of its room. The same light as [`LightSet::new`] in expectation, with
    /// fewer wasted shadow rays and less roulette noise.
    #[must_use]
    pub fn for_scene(scene: &Scene, scale: [f32; 2]) -> LightSet {
        let mut set = LightSet::new(&scene.lights, scale);
        let points: Vec<LightSource> =
            set.points.iter().map(|l| LightSource { room: l.room, footprint: vec![l.position.truncate()] }).collect();
        let rects: Vec<LightSource> = set
            .rects
            .iter()
            .map(|l| LightSource { room: l.room, footprint: l.corners.iter().map(|c| c.truncate()).collect() })
            .collect();
        set.reach = LightReach::of_floorplan(scene, &points, &rects);
        set
    }

    /// Prepares `lights`, each multiplied by `scale[group]`; every point weighs every light.
    #[must_use]
    pub fn new(lights: &[Light], scale: [f32; 2]) -> LightSet {
        let mut set = LightSet::default();
        for light in lights {
            let group = group_index(light.group);
            let intensity = light.intensity * scale[group];
            if !(intensity.is_finite() && intensity > 0.0) {
                continue;
            }
            let rgb = unit_luminance_tint(light.color) * intensity;
            match light.kind {
                LightKind::Point => {
                    if let Some(position) = light.position.filter(|p| p.is_finite()) {
                        set.points.push(PointLight {
                            position,
                            rgb_cd: rgb,
                            luminous: intensity,
                            group,
                            room: light.room,
                        });
                        set.reference_nit[group] = set.reference_nit[group].max(intensity / PI);
                    }
                }
                LightKind::Directional => {
                    if let Some(d) = light.direction.map(Vec3::normalize_or_zero).filter(|d| *d != Vec3::ZERO) {
                        set.directionals.push(DirectionalLight {
                            to_light: -d,
                            rgb_lux: rgb,
                            luminous: intensity,
                            group,
                        });
                        set.reference_nit[group] = set.reference_nit[group].max(intensity / PI);
                    }
                }
                LightKind::Rect => {
                    let (Some(center), Some(u), Some(v)) = (light.position, light.rect_u, light.rect_v) else {
                        continue;
                    };
                    let cross = u.cross(v);
                    let area_m2 = cross.length();
                    let normal = light.direction.unwrap_or(cross).normalize_or_zero();
                    if area_m2 > 0.0 && normal != Vec3::ZERO && center.is_finite() {
                        let corners = RECT_CORNERS.map(|(s, r)| center + u * s + v * r);
                        set.rects.push(RectLight {
                            center,
                            u,
                            v,
                            normal,
                            area_m2,
                            rgb_nit: rgb,
                            luminous: intensity,
                            group,
                            room: light.room,
                            corners,
                            seen_bounds: seen_bounds(center, u, v, normal),
                        });
                        set.reference_nit[group] = set.reference_nit[group].max(intensity);
                    }
                }
            }
        }
        set.reach = LightReach::everywhere(set.points.len(), set.rects.len());
        set
    }

    /// Direct irradiance per group (lux per channel) at `point` on a surface whose geometric
    /// normal `ng` faces the side being lit and whose shading normal is `ns`; each rect light
    /// gets `rect_samples` area samples placed by `rect_strata`, which estimate only how much of
    /// its exact unshadowed light is blocked: a point that sees all of a window or none of it
    /// gets the exact value whatever the samples, one partly shadowed a ratio estimate that is
    /// consistent but biased where the blocked part of the window gives more or less light per
    /// area than the rest (at one sample it estimates the visible share of the window's area,
    /// not of its light).
    ///
    /// Light culling by Russian roulette (`cull` > 0), for point and rect lights only: each
    /// one's unshadowed contribution `b` (exact for point lights, `min(pi L, L A / d^2)` for
    /// rects) is compared with its group's total `B` over those lights; a light with
    /// `b < cull * B` is traced with probability `p = b / (cull * B)` and weighted `1 / p`, so
    /// the roulette adds no bias while the lights of other rooms, nearly always behind walls,
    /// cost few shadow rays. `p` depends only on ratios within a group, so culling commutes
    /// with light scaling.
    ///
    /// Directional lights (the sun) are always traced and left out of `B`. A house has one, so
    /// tracing it costs one shadow ray; but its unshadowed illuminance is large at every point
    /// that faces it, in the rooms and corners it cannot reach as well, so counted in `B` it
    /// pushed the windows that really light such a point below the threshold and they were
    /// traced with weights up to `1 / p`: salt-and-pepper speckle in one-sample day frames
    /// (docs/BENCHMARKS.md, "Speckle in preview day frames").
    #[allow(clippy::too_many_arguments)]
    #[must_use]
    #[inline(always)]
    pub fn direct(
        &self,
        accel: &Accel,
        point: Vec3,
        ng: Vec3,
        ns: Vec3,
        rect_samples: u32,
        rect_strata: Strata,
        cull: f32,
        sampler: &mut Sampler,
        blockers: &Blockers,
    ) -> GroupRgb {
        let (other, rects) = self.direct_split(
            accel,
            point,
            ng,
            ns,
            rect_samples,
            rect_strata,
            cull,
            sampler,
            blockers,
            false,
            PointLights::Traced,
        );
        [other[0] + rects.visible[0], other[1] + rects.visible[1]]
    }

    /// [`LightSet::direct`] in two parts: the point and directional lights, and the rect
    /// lights' [`RectShare`] (their estimated light and, with `unshadowed` set, the exact light
    /// they would give unshadowed, which costs the closed form of every rect light in reach,
    /// the fully shadowed and culled ones too). The draws are those of `direct`.
    ///
    /// With [`PointLights::Batched`], the point and directional lights are left out of the
    /// first part (zero) and nothing is drawn for them: the caller lights the point with them
    /// ([`super::hit_batch`]).
    #[allow(clippy::too_many_arguments)]
    #[must_use]
    #[inline(always)]
    pub(crate) fn direct_split(
        &self,
        accel: &Accel,
        point: Vec3,
        ng: Vec3,
        ns: Vec3,
        rect_samples: u32,
        rect_strata: Strata,
        cull: f32,
        sampler: &mut Sampler,
        blockers: &Blockers,
        unshadowed: bool,
        point_lights: PointLights,
    ) -> (GroupRgb, RectShare) {
        // Only the lights that can reach the point's room ([`super::reach`]): a light left out
        // of the list is blocked by walls wherever it is sampled, so it adds nothing but cost
        // and, through the group totals, roulette noise.
        let reach = self.reach.lights_at(point);
        let batched = point_lights == PointLights::Batched;
        if batched && reach.rects.is_empty() {
            return ([Vec3::ZERO; 2], RectShare::default());
        }
        // Each culled light's importance, computed once: it is needed for the group totals and
        // again for the roulette. The first `IMPORTANCE_CACHE` lights keep theirs on the stack
        // (no allocation per shading point); any further light is recomputed, to the same value.
        // Plain loops and `if`s, not iterator chains and closures: those were compiled out of
        // line, with baseline code, in the AVX2 build of the tile loop (`scene_gen_core::simd`).
        let mut cached = [0.0f32; IMPORTANCE_CACHE];
        let mut total = [0.0f32; 2];
        for (k, &i) in reach.points.iter().enumerate() {
            let light = &self.points[i as usize];
            let b = point_importance(light, point, ng, ns);
            total[light.group] += b;
            if k < IMPORTANCE_CACHE {
                cached[k] = b;
            }
        }
        let n_points = reach.points.len();
        for (k, &i) in reach.rects.iter().enumerate() {
            let light = &self.rects[i as usize];
            let b = rect_importance(light, point, ns);
            total[light.group] += b;
            if n_points + k < IMPORTANCE_CACHE {
                cached[n_points + k] = b;
            }
        }
        let mut e = [Vec3::ZERO; 2];
        let eps = ray_epsilon(point);
        let origin = point + ng * eps;
        let all_points = self.points.len();
        if !batched {
            for (k, &i) in reach.points.iter().enumerate() {
                let light = &self.points[i as usize];
                let b = if k < IMPORTANCE_CACHE { cached[k] } else { point_importance(light, point, ng, ns) };
                let Some(weight) = roulette(b, total[light.group], cull, sampler) else { continue };
                let d = light.position - point;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                let dir = d / dist;
                if !blockers.occluded(accel, i as usize, origin, dir, dist - 2.0 * eps) {
                    e[light.group] += light.rgb_cd * (weight * ns.dot(dir) / dist2);
                }
            }
            for (i, light) in self.directionals.iter().enumerate() {
                if directional_importance(light, ng, ns) <= 0.0 {
                    continue;
                }
                if !blockers.occluded(accel, all_points + i, origin, light.to_light, f32::INFINITY) {
                    e[light.group] += light.rgb_lux * ns.dot(light.to_light);
                }
            }
        }
        let count = rect_samples.max(1);
        let first_rect_slot = all_points + self.directionals.len();
        let mut share = RectShare::default();
        for (k, &i) in reach.rects.iter().enumerate() {
            let light = &self.rects[i as usize];
            let slot = n_points + k;
            let b = if slot < IMPORTANCE_CACHE { cached[slot] } else { rect_importance(light, point, ns) };
            // The exact unshadowed light, wanted whatever the samples say: a filter that pools
            // the visible share of neighbours needs the light that a shadowed point misses.
            let exact = if unshadowed { rect_irradiance_per_nit(light, point, ns) } else { 0.0 };
            share.unshadowed[light.group] += light.rgb_nit * exact;
            let Some(weight) = roulette(b, total[light.group], cull, sampler) else { continue };
            // The area samples estimate only what fraction of the light's exact unshadowed
            // irradiance gets through: sum(f V) / sum(f) over them, f the unshadowed integrand.
            let (mut f_sum, mut visible_f_sum) = (0.0f32, 0.0f32);
            for m in 0..count {
                let (a, b) = rect_strata.point(m, sampler);
                let q = light.center + light.u * (a - 0.5) + light.v * (b - 0.5);
                let d = q - point;
                let dist2 = d.length_squared();
                if dist2 <= 0.0 {
                    continue;
                }
                let dist = dist2.sqrt();
                let dir = d / dist;
                let cos_surface = ns.dot(dir);
                let cos_light = -light.normal.dot(dir);
                if cos_surface <= 0.0 || cos_light <= 0.0 || ng.dot(dir) <= 0.0 {
                    continue;
                }
                let f = cos_surface * cos_light / dist2;
                f_sum += f;
                if !blockers.occluded(accel, first_rect_slot + i as usize, origin, dir, dist - 2.0 * eps) {
                    visible_f_sum += f;
                }
            }
            if f_sum > 0.0 && visible_f_sum == 0.0 {
                continue; // Shadowed at every sample: nothing gets through.
            }
            let exact = if unshadowed { exact } else { rect_irradiance_per_nit(light, point, ns) };
            let visible = if f_sum > 0.0 {
                visible_f_sum / f_sum
            } else if exact > 0.0 {
                // Every sample fell on the part of the light below the surface's horizon (one
                // sample, a window beside the surface): one ray to the centre of what is above.
                let q = above_horizon_centre(light, point, ns);
                let d = q - point;
                let dist = d.length();
                let dir = d / dist;
                let reaches = dist > 2.0 * eps
                    && ng.dot(dir) > 0.0
                    && !blockers.occluded(accel, first_rect_slot + i as usize, origin, dir, dist - 2.0 * eps);
                if reaches { 1.0 } else { 0.0 }
            } else {
                0.0
            };
            share.visible[light.group] += light.rgb_nit * (exact * visible * weight);
        }
        (e, share)
    }

    /// Bit `i` set where directional light `i` (the first 32) reaches `point` on a surface of
    /// normal `n`: it faces the light and no triangle blocks the way. The sun's shadow edges
    /// are the sharpest, noise-free feature of a day frame; [`super::refine`] compares these
    /// bits, not the (noisy) day irradiance, to decide where anchors must be traced.
    #[must_use]
    pub(crate) fn directionals_reaching(&self, accel: &Accel, point: Vec3, n: Vec3, blockers: &Blockers) -> u32 {
        let origin = point + n * ray_epsilon(point);
        let mut mask = 0;
        for (i, light) in self.directionals.iter().take(32).enumerate() {
            if directional_importance(light, n, n) > 0.0
                && !blockers.occluded(accel, self.points.len() + i, origin, light.to_light, f32::INFINITY)
            {
                mask |= 1 << i;
            }
        }
        mask
    }

    /// The first rect light emitter seen along a unit ray before `tmax`: (distance, group,
    /// radiance in nit per channel).
    #[must_use]
    #[inline(always)]
    pub fn emitter_seen(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<(f32, usize, Vec3)> {
        self.emitter_seen_among(origin, direction, tmax, 0..self.rects.len() as u32)
    }

    /// [`LightSet::emitter_seen`] over the rect lights `among` (indices in ascending order, as
    /// [`LightSet::emitters_in_reach`] leaves them).
    #[must_use]
    #[inline(always)]
    pub fn emitter_seen_among(
        &self,
        origin: Vec3,
        direction: Vec3,
        tmax: f32,
        among: impl IntoIterator<Item = u32>,
    ) -> Option<(f32, usize, Vec3)> {
        let mut best: Option<(f32, usize, Vec3)> = None;
        for light in among.into_iter().filter_map(|i| self.rects.get(i as usize)) {
            if let Some(t) = light.hit_front(origin, direction, best.map_or(tmax, |b| b.0)) {
                best = Some((t, light.group, light.rgb_nit));
            }
        }
        best
    }

    /// The rect lights some ray of `packet` may see, into `out` (ascending). Why per packet:
    /// every camera ray tested every window, about 4 % of an evaluator frame, while most tiles
    /// can reach none.
    #[inline(always)]
    pub fn emitters_in_reach(&self, packet: &mut RayPacket, out: &mut Vec<u32>) {
        out.clear();
        out.extend(0..self.rects.len() as u32);
        packet.keep_reachable(out, |i| self.rects[i as usize].seen_bounds);
    }
}

/// Lights whose importance [`LightSet::direct`] keeps on the stack; a house has a few dozen.
const IMPORTANCE_CACHE: usize = 64;

/// The corners of a rect light in its own `(u, v)` coordinates.
const RECT_CORNERS: [(f32, f32); 4] = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)];

/// A box holding every point [`RectLight::hit_front`] accepts on the rect light at `center`
/// spanned by `u`, `v` with `normal`, grown by [`EMITTER_BOUNDS_PAD_M`] plus a relative `1e-4`
/// (far wider than the rounding of its `|s|, |r| <= 0.5`), so a ray that sees the emitter never
/// misses the box.
///
/// The accepted points lie on the plane through `center` normal to `normal`, where
/// `w = p - center` has `w . u = s |u|^2`, `w . v = r |v|^2`: when `u`, `v` and `normal` are not
/// orthogonal (a light's direction is its own field) that parallelogram is not the one spanned
/// by `u` and `v`, so its corners are solved for. Where the three are dependent the region is
/// unbounded and so is the box.
fn seen_bounds(center: Vec3, u: Vec3, v: Vec3, normal: Vec3) -> (Vec3, Vec3) {
    let rows = glam::Mat3::from_cols(u, v, normal).transpose();
    let det = rows.determinant();
    let independent = det.is_finite() && det.abs() > 1e-6 * u.length() * v.length() * normal.length();
    if !independent {
        return (Vec3::NEG_INFINITY, Vec3::INFINITY);
    }
    let inverse = rows.inverse();
    let (uu, vv) = (u.length_squared(), v.length_squared());
    let corners = RECT_CORNERS.map(|(s, r)| center + inverse * Vec3::new(s * uu, r * vv, 0.0));
    let lo = corners.iter().fold(Vec3::INFINITY, |a, &c| a.min(c));
    let hi = corners.iter().fold(Vec3::NEG_INFINITY, |a, &c| a.max(c));
    let pad = Vec3::splat(EMITTER_BOUNDS_PAD_M) + lo.abs().max(hi.abs()) * 1e-4;
    (lo - pad, hi + pad)
}

/// Russian roulette for a light of importance `b` in a group of total `total`: `Some(weight)`
/// when it is to be traced.
#[inline(always)]
pub(super) fn roulette(b: f32, total: f32, cull: f32, sampler: &mut Sampler) -> Option<f32> {
    if b <= 0.0 {
        return None;
    }
    let p = if cull > 0.0 { b / (cull * total) } else { 1.0 };
    if p >= 1.0 {
        Some(1.0)
    } else if sampler.uniform() < p {
        Some(1.0 / p)
    } else {
        None
    }
}

/// Unshadowed illuminance (lux) of a point light; 0 when it is behind the surface.
#[inline(always)]
pub(super) fn point_importance(light: &PointLight, point: Vec3, ng: Vec3, ns: Vec3) -> f32 {
    let d = light.position - point;
    let dist2 = d.length_squared();
    if dist2 <= 0.0 || ns.dot(d) <= 0.0 || ng.dot(d) <= 0.0 {
        return 0.0;
    }
    light.luminous * ns.dot(d) / (dist2 * dist2.sqrt())
}

/// Unshadowed illuminance (lux) of a directional light.
#[inline(always)]
pub(super) fn directional_importance(light: &DirectionalLight, ng: Vec3, ns: Vec3) -> f32 {
    if ng.dot(light.to_light) <= 0.0 {
        return 0.0;
    }
    light.luminous * ns.dot(light.to_light).max(0.0)
}

/// A rough size of a rect light's illuminance: `L A / d^2` from its centre, at most `pi L`
/// (a whole hemisphere of that luminance); 0 when the point is behind the emitter or the
/// emitter behind the surface.
#[inline(always)]
pub(super) fn rect_importance(light: &RectLight, point: Vec3, ns: Vec3) -> f32 {
    let to_point = point - light.center;
    if to_point.dot(light.normal) <= 0.0 {
        return 0.0;
    }
    // A loop, not `all` with a closure (see the importance pass of `LightSet::direct`).
    let mut all_behind = true;
    for &c in &light.corners {
        all_behind &= ns.dot(c - point) <= 0.0;
    }
    if all_behind {
        return 0.0;
    }
    let dist2 = to_point.length_squared().max(1e-12);
    (light.luminous * light.area_m2 / dist2).min(PI * light.luminous)
}

/// Unshadowed irradiance at `point` on a surface of normal `n` from rect light `light`, per
/// nit of its luminance: Lambert's formula for a uniformly emitting polygon, `E / L =
/// 1/2 sum_i theta_i (n . g_i)` over the edges of the polygon as seen from the point and cut at
/// the surface's horizon, `theta_i` the angle an edge subtends and `g_i` the unit normal of the
/// plane through the point and the edge (J. Arvo, "The irradiance Jacobian for partially
/// occluded polyhedral sources", SIGGRAPH 1994, eq. 1). 0 behind the emitting side.
///
/// Why analytic: one random point on a window per shading point gave each its own estimate of
/// the window's light, about 50 % off per point, which showed as grain all over a day frame.
/// With this, only the visibility is sampled, and a point that sees all of a window or none of
/// it gets the exact value (Heitz, Hill and McGuire, "Combining analytic direct illumination
/// and stochastic shadows", I3D 2018).
#[must_use]
#[inline(always)]
fn rect_irradiance_per_nit(light: &RectLight, point: Vec3, n: Vec3) -> f32 {
    let Some((poly, k)) = above_horizon(light, point, n) else { return 0.0 };
    // The corners need no normalising: the angle from atan2 and the plane's unit normal
    // `c / |c|` are the same for any lengths of `a` and `b`.
    let mut sum = 0.0f32;
    for i in 0..k {
        let (a, b) = (poly[i], poly[(i + 1) % k]);
        let c = a.cross(b);
        let sin = c.length();
        if sin > 0.0 {
            // From the sine and cosine, not acos of the dot product: exact for the small angles
            // of far lights.
            sum += atan2_nonnegative(sin, a.dot(b)) * c.dot(n) / sin;
        }
    }
    0.5 * sum.abs()
}

/// `y.atan2(x)` for `y >= 0` (an angle in [0, pi]) within 2e-6 rad, without a library call: a
/// libm `atan2` per polygon edge made a frame about 15 % slower, and out of line it runs
/// baseline code in the AVX2 build of the tile loop. `atan(t) = t P(t^2)` on [0, 1], `P` of
/// degree 5 fitted here (least squares on Chebyshev nodes, reweighted toward the smallest
/// largest error; 1.7e-6 rad in f32), with the octant reductions `pi/2 - atan(1/t)` and
/// `pi - angle`.
#[must_use]
#[inline(always)]
fn atan2_nonnegative(y: f32, x: f32) -> f32 {
    const P: [f32; 6] = [0.999_977_2, -0.332_622_83, 0.193_540_38, -0.116_426_48, 0.052_647_35, -0.011_719_135];
    let ax = x.abs();
    let (num, den) = if ax >= y { (y, ax) } else { (ax, y) };
    if den <= 0.0 {
        return 0.0;
    }
    let t = num / den;
    let t2 = t * t;
    let mut p = P[5];
    for &c in P[..5].iter().rev() {
        p = p * t2 + c;
    }
    let octant = t * p;
    let first_quadrant = if ax >= y { octant } else { std::f32::consts::FRAC_PI_2 - octant };
    if x < 0.0 { PI - first_quadrant } else { first_quadrant }
}

/// The polygon of `light` that lies above the horizon of a surface at `point` with normal `n`,
/// as corners relative to `point` (a quad cut by a plane keeps at most 5), and their count; `None`
/// when the point is behind the emitting side or nothing of the light is above the horizon.
#[inline(always)]
fn above_horizon(light: &RectLight, point: Vec3, n: Vec3) -> Option<([Vec3; 5], usize)> {
    if (point - light.center).dot(light.normal) <= 0.0 {
        return None;
    }
    let mut poly = [Vec3::ZERO; 5];
    let mut k = 0;
    for i in 0..4 {
        let (a, b) = (light.corners[i] - point, light.corners[(i + 1) % 4] - point);
        let (da, db) = (a.dot(n), b.dot(n));
        if da > 0.0 {
            poly[k] = a;
            k += 1;
        }
        if (da > 0.0) != (db > 0.0) && k < 5 {
            poly[k] = a + (b - a) * (da / (da - db));
            k += 1;
        }
    }
    (k >= 3).then_some((poly, k))
}

/// The centre (vertex mean) of the part of `light` above the horizon of a surface at `point`
/// with normal `n`, in world coordinates; the light's centre when none of it is.
#[inline(always)]
fn above_horizon_centre(light: &RectLight, point: Vec3, n: Vec3) -> Vec3 {
    match above_horizon(light, point, n) {
        Some((poly, k)) => {
            let mut sum = Vec3::ZERO;
            for v in &poly[..k] {
                sum += *v;
            }
            point + sum / k as f32
        }
        None => light.center,
    }
}

/// How far to push a ray origin off a surface at `point` so it does not re-hit that surface:
/// relative to the coordinates' magnitude, since f32 spacing grows with them.
#[must_use]
#[inline(always)]
pub fn ray_epsilon(point: Vec3) -> f32 {
    1e-4 * (1.0 + point.abs().max_element())
}

#[cfg(test)]
mod tests {
    use glam::Mat4;

    use super::*;
    use crate::test_util::{add_material, add_mesh, directional_light, empty_scene, quad, rect_light};
    use scene_gen_scene::scene::{LightGroup, Scene, Semantic};

    /// A floor point at the origin, a wall at x = 1 between it and a low sun in the +x sky,
    /// and a 1 m^2 window 1.4 m away on the other side (`L = 100` nit) shining at it: the sun's
    /// unshadowed illuminance (7071 lux) is 140 times the window's, the shadowed sun gives 0.
    fn sun_behind_a_wall(far_window: bool) -> Scene {
        let mut scene = empty_scene();
        let grey = add_material(&mut scene, "grey", [0.5, 0.5, 0.5], 0.0, 1.0);
        let wall = quad(Vec3::new(1.0, 0.0, 0.0), Vec3::Z * 20.0, Vec3::Y * 20.0, grey);
        add_mesh(&mut scene, wall, Mat4::IDENTITY, Semantic::Wall { wall: 0 });
        let day = LightGroup::Day;
        scene.lights.push(directional_light(day, Vec3::new(-1.0, 0.0, -1.0), 10_000.0));
        scene.lights.push(rect_light(day, Vec3::new(-1.0, 0.0, 1.0), Vec3::Y, Vec3::Z, Vec3::X, 100.0));
        if far_window {
            // A weaker skylight 8 m overhead: importance and illuminance 200 / 64 = 3.1 against
            // the near window's 50, so its p is 3.1 / (0.1 x 53.1) = 0.59.
            scene.lights.push(rect_light(day, Vec3::new(0.0, 0.0, 8.0), Vec3::X, Vec3::Y, -Vec3::Z, 200.0));
        }
        scene
    }

    /// Day illuminance (luminance of the lux triple) at the origin with sampler key `key`.
    fn day_lux(set: &LightSet, accel: &Accel, cull: f32, key: u64) -> f32 {
        let mut sampler = Sampler::new(0, "lights-test", key);
        let strata = Strata::independent(&mut sampler);
        let e = set.direct(accel, Vec3::ZERO, Vec3::Z, Vec3::Z, 1, strata, cull, &mut sampler, &Blockers::default());
        luminance(e[0])
    }

    #[test]
    fn a_window_lit_point_with_the_sun_behind_a_wall_traces_the_window_every_time() {
        let scene = sun_behind_a_wall(false);
        let (accel, set) = (Accel::build(&scene), LightSet::new(&scene.lights, [1.0, 1.0]));
        for key in 0..200 {
            let exact = day_lux(&set, &accel, 0.0, key);
            // The window alone, in closed form: about L A cos cos / d^2 = 100 x 1 x 0.7 x 0.7 /
            // 2 = 25 lux, the same at every key (the window is in full view).
            assert!(exact > 20.0 && exact < 30.0, "key {key}: {exact} lux");
            assert_eq!(exact, day_lux(&set, &accel, 0.0, 0), "key {key}");
            // When the sun counted in the cull total, the window's p was 50 / (0.1 x 7121) =
            // 0.07: most estimates were 0 and the rest 14x too bright.
            assert_eq!(day_lux(&set, &accel, 0.1, key), exact, "key {key}");
        }
    }

    #[test]
    fn the_sun_is_traced_without_roulette_where_it_reaches() {
        let mut scene = sun_behind_a_wall(false);
        scene.geometry = Default::default();
        let (accel, set) = (Accel::build(&scene), LightSet::new(&scene.lights, [1.0, 1.0]));
        for key in 0..50 {
            let e = day_lux(&set, &accel, 0.1, key);
            let window = day_lux(&LightSet::new(&scene.lights[1..], [1.0, 1.0]), &accel, 0.1, key);
            assert!((e - window - 10_000.0 * std::f32::consts::FRAC_1_SQRT_2).abs() < 0.05, "key {key}: {e}");
        }
    }

    #[test]
    fn a_weak_far_light_is_still_culled_without_bias_and_culling_commutes_with_scale() {
        let scene = sun_behind_a_wall(true);
        let accel = Accel::build(&scene);
        let set = LightSet::new(&scene.lights, [1.0, 1.0]);
        let brighter = LightSet::new(&scene.lights, [8.0, 1.0]);
        let n: u32 = 4000;
        let (mut exact, mut culled, mut skipped) = (0.0f64, 0.0f64, 0u32);
        for key in 0..u64::from(n) {
            let (e, c) = (day_lux(&set, &accel, 0.0, key), day_lux(&set, &accel, 0.1, key));
            exact += f64::from(e);
            culled += f64::from(c);
            skipped += u32::from(c < e);
            // The same draws decide at any scale: 8x the lights, 8x every estimate.
            let b = day_lux(&brighter, &accel, 0.1, key);
            assert!((b - 8.0 * c).abs() <= 1e-4 * b.max(1.0), "key {key}: {b} vs 8 x {c}");
        }
        // The skylight is skipped with probability 0.41 (and weighted 1 / 0.59 otherwise) ...
        assert!((1200..2100).contains(&skipped), "skipped on {skipped} of {n} keys");
        // ... yet the mean is that of tracing every light: the skylight is 11 % of it, and its
        // roulette adds about 0.15 % standard error.
        let (exact, culled) = (exact / f64::from(n), culled / f64::from(n));
        assert!((culled - exact).abs() < 0.01 * exact, "culled {culled} vs exact {exact}");
    }

    /// The one rect light of a scene holding only `light`.
    fn prepared_rect(light: Light) -> RectLight {
        LightSet::new(&[light], [1.0, 1.0]).rects[0]
    }

    /// `E / L` at `point` (surface normal `n`) from `light`, by the midpoint rule on a
    /// `cells x cells` grid over its area, in f64, each cell kept where `visible` says the
    /// segment from the point to it is clear: the reference for the closed form and for the
    /// visibility estimate.
    fn quadrature_per_nit(
        light: &RectLight,
        point: Vec3,
        n: Vec3,
        cells: usize,
        visible: impl Fn(Vec3) -> bool,
    ) -> f64 {
        let (c, u, v) = (light.center.as_dvec3(), light.u.as_dvec3(), light.v.as_dvec3());
        let (p, n, nl) = (point.as_dvec3(), n.as_dvec3(), light.normal.as_dvec3());
        let step = 1.0 / cells as f64;
        let mut sum = 0.0;
        for i in 0..cells {
            for j in 0..cells {
                let q = c + u * ((i as f64 + 0.5) * step - 0.5) + v * ((j as f64 + 0.5) * step - 0.5);
                let d = q - p;
                let d2 = d.length_squared();
                let dir = d / d2.sqrt();
                let (cos_surface, cos_light) = (n.dot(dir), -nl.dot(dir));
                if cos_surface > 0.0 && cos_light > 0.0 && visible(q.as_vec3()) {
                    sum += cos_surface * cos_light / d2;
                }
            }
        }
        sum * f64::from(light.area_m2) * step * step
    }

    #[test]
    fn atan2_nonnegative_is_within_2e_6_rad_of_libm() {
        let mut worst = 0.0f64;
        for i in 0..=400 {
            for j in -400i32..=400 {
                // From 1e-4 to 1e4 and exact zeros, both signs of x.
                let y = if i == 0 { 0.0 } else { 10f32.powf(-4.0 + 8.0 * i as f32 / 400.0) };
                let x = if j == 0 { 0.0 } else { j.signum() as f32 * 10f32.powf(-4.0 + 8.0 * j.abs() as f32 / 400.0) };
                let exact = f64::from(y).atan2(f64::from(x));
                worst = worst.max((f64::from(atan2_nonnegative(y, x)) - exact).abs());
            }
        }
        assert!(worst < 2e-6, "largest error {worst} rad");
    }

    #[test]
    fn a_square_window_overhead_gives_the_textbook_irradiance() {
        // A square of side 2a at height h centred over the point, facing it: four corner
        // rectangles of the handbook's parallel-rectangle form factor, E / L =
        // 4 A / sqrt(1 + A^2) atan(A / sqrt(1 + A^2)) with A = a / h.
        for (half_side, height) in [(0.5f64, 2.0f64), (1.0, 0.3), (0.05, 4.0), (3.0, 1.0)] {
            let side = 2.0 * half_side as f32;
            let light =
                rect_light(LightGroup::Day, Vec3::Z * height as f32, Vec3::X * side, Vec3::Y * side, -Vec3::Z, 1.0);
            let a = half_side / height;
            let s = (1.0 + a * a).sqrt();
            let expected = 4.0 * a / s * (a / s).atan();
            let got = f64::from(rect_irradiance_per_nit(&prepared_rect(light), Vec3::ZERO, Vec3::Z));
            assert!((got - expected).abs() < 1e-4 * expected, "a {half_side} h {height}: {got} vs {expected}");
        }
    }

    proptest::proptest! {
        /// The closed form equals quadrature for parallelograms anywhere around a point,
        /// facing it or not, above its horizon, below it or cut by it.
        #[test]
        fn rect_irradiance_matches_quadrature(
            centre in proptest::array::uniform3(-3.0f32..3.0),
            u in proptest::array::uniform3(-2.0f32..2.0),
            v in proptest::array::uniform3(-2.0f32..2.0),
            flip in proptest::bool::ANY,
            normal in proptest::array::uniform3(-1.0f32..1.0),
        ) {
            let (centre, u, v, n) = (Vec3::from(centre), Vec3::from(u), Vec3::from(v), Vec3::from(normal));
            proptest::prop_assume!(u.cross(v).length() > 0.05 && n.length() > 0.1);
            let facing = if flip { -u.cross(v) } else { u.cross(v) };
            let light = prepared_rect(rect_light(LightGroup::Day, centre, u, v, facing, 1.0));
            // Far enough from the light's plane for the quadrature's 1e-3.
            proptest::prop_assume!(centre.dot(light.normal).abs() > 0.15);
            let n = n.normalize();
            let got = f64::from(rect_irradiance_per_nit(&light, Vec3::ZERO, n));
            let reference = quadrature_per_nit(&light, Vec3::ZERO, n, 500, |_| true);
            proptest::prop_assert!(
                (got - reference).abs() <= 2e-3 * reference + 1e-5,
                "closed form {} vs quadrature {}", got, reference
            );
        }
    }

    /// A 1 m^2 window 2 m over the origin facing down (`L = 100` nit), and when `blocker_edge_x`
    /// is given an opaque sheet at z = 1 over every x below it.
    fn window_overhead(blocker_edge_x: Option<f32>) -> Scene {
        let mut scene = empty_scene();
        scene.lights.push(rect_light(LightGroup::Day, Vec3::Z * 2.0, Vec3::X, Vec3::Y, -Vec3::Z, 100.0));
        if let Some(edge) = blocker_edge_x {
            let grey = add_material(&mut scene, "grey", [0.5, 0.5, 0.5], 0.0, 1.0);
            let sheet = quad(Vec3::new(edge - 5.0, 0.0, 1.0), Vec3::X * 10.0, Vec3::Y * 10.0, grey);
            add_mesh(&mut scene, sheet, Mat4::IDENTITY, Semantic::Wall { wall: 0 });
        }
        scene
    }

    /// Day illuminance at the origin on a surface of normal `n` with `samples` stratified area
    /// samples.
    fn window_lux_at(n: Vec3, set: &LightSet, accel: &Accel, samples: u32, key: u64) -> f32 {
        let mut sampler = Sampler::new(0, "lights-test", key);
        let strata = Strata { first: 0, stride: 1, total: samples, rotation: sampler.uniform() };
        let e = set.direct(accel, Vec3::ZERO, n, n, samples, strata, 0.0, &mut sampler, &Blockers::default());
        luminance(e[0])
    }

    /// [`window_lux_at`] on a floor (normal +z).
    fn window_lux(set: &LightSet, accel: &Accel, samples: u32, key: u64) -> f32 {
        window_lux_at(Vec3::Z, set, accel, samples, key)
    }

    #[test]
    fn a_fully_visible_window_gives_its_exact_light_at_every_sample() {
        let scene = window_overhead(None);
        let (accel, set) = (Accel::build(&scene), LightSet::new(&scene.lights, [1.0, 1.0]));
        let exact = 100.0 * quadrature_per_nit(&set.rects[0], Vec3::ZERO, Vec3::Z, 500, |_| true);
        for samples in [1, 4] {
            for key in 0..100 {
                let e = f64::from(window_lux(&set, &accel, samples, key));
                assert!((e - exact).abs() < 1e-3 * exact, "{samples} samples, key {key}: {e} vs {exact}");
            }
        }
        // A surface facing +x sees the half of the window with x > 0: half the samples fall
        // behind it, and then one ray to the visible part's centre stands in for them.
        let tilted = Vec3::new(1.0, 0.0, 0.01).normalize();
        let exact = 100.0 * quadrature_per_nit(&set.rects[0], Vec3::ZERO, tilted, 500, |_| true);
        for key in 0..100 {
            let e = f64::from(window_lux_at(tilted, &set, &accel, 1, key));
            assert!((e - exact).abs() < 2e-3 * exact, "facing +x, key {key}: {e} vs {exact}");
        }
    }

    #[test]
    fn a_partly_shadowed_window_averages_to_its_visible_light() {
        // The sheet's edge at x = e hides the window's points with x < 2e, seen from the origin.
        let keys = 2000u64;
        for edge in [0.0f32, -0.125, 0.15] {
            let scene = window_overhead(Some(edge));
            let (accel, set) = (Accel::build(&scene), LightSet::new(&scene.lights, [1.0, 1.0]));
            let light = set.rects[0];
            let visible_lux = 100.0 * quadrature_per_nit(&light, Vec3::ZERO, Vec3::Z, 500, |q| q.x >= 2.0 * edge);
            let unshadowed_lux = 100.0 * quadrature_per_nit(&light, Vec3::ZERO, Vec3::Z, 500, |_| true);
            let mean =
                |samples| (0..keys).map(|k| f64::from(window_lux(&set, &accel, samples, k))).sum::<f64>() / keys as f64;
            // 16 stratified samples: the ratio's bias (the samples weigh the window's points
            // by area, the light by f) and noise stay within 1 % (0.25 % measured at the
            // 0.15 cut), where leaving out the shadow rays would be 25 % to 400 % off.
            let m16 = mean(16);
            assert!((m16 - visible_lux).abs() < 0.01 * visible_lux, "edge {edge}: {m16} vs {visible_lux}");
            // One sample: the unshadowed light times 0 or 1, so in expectation times the
            // visible share of the window's area, within 4 sd of the Bernoulli mean.
            let share = f64::from(0.5 - 2.0 * edge);
            let sd = unshadowed_lux * (share * (1.0 - share) / keys as f64).sqrt();
            let m1 = mean(1);
            assert!((m1 - unshadowed_lux * share).abs() < 4.0 * sd, "edge {edge}: {m1} vs {}", unshadowed_lux * share);
        }
    }
}
