//! Surface appearance and the light transport estimate.
//!
//! What is physical and what is approximate:
//!
//! * **Physical**: Lambertian reflection `L = rho / pi * E` of the base colour (texture
//!   bilinear-sampled with repeat wrapping, sRGB-decoded, times the base-colour factor); direct
//!   illuminance from every light with shadow rays (see [`super::lights`]); light that bounced
//!   any number of times from the scene's irradiance volume ([`super::irradiance_volume`]),
//!   read at the point or, with bounce rays, gathered by cosine-weighted rays,
//!   `E_indirect = pi * mean(L_bounce)`, whose hits are shaded with direct light and the
//!   volume (a final gather). Without a volume the bounce hits get direct light only, and the
//!   second and later bounces are missing.
//! * **Biased on purpose**: a bounce ray's radiance is clamped to
//!   [`RenderSettings::indirect_clamp`] times the group's reference radiance (`I / pi` of its
//!   strongest point light at 1 m, `E / pi` of the sun, `L` of its brightest rect light). A
//!   ceiling 0.1 m above a bulb is hundreds of times brighter than the rest of the room and
//!   cosine-weighted bounce rays find it rarely: unclamped, it turns into white speckles. The
//!   clamp trades that noise for a darker indirect term near such hot spots; it is linear in
//!   the lights, so it commutes with [`super::LightScale`], and the illuminance probe applies
//!   the same clamp, so scaled frames still meet their targets.
//! * **Approximate**: metals. A material reflects a fraction `s = metallic * (1 - roughness)`
//!   specularly (a mirror ray, its direction jittered by `roughness`, tinted by the base colour
//!   as the Fresnel reflectance at normal incidence of a metal) and the rest diffusely with the
//!   base colour. Dielectrics get no specular highlight and no Fresnel term; delta lights
//!   (point, directional) give no highlight on metals; glass is perfectly clear (left out of the
//!   BVH) and mirrors see rect emitters and diffuse surfaces lit directly.

use std::sync::OnceLock;

use glam::{Vec2, Vec3};

use super::accel::{Accel, Hit, SurfacePoint};
use super::irradiance_volume::IrradianceVolume;
use super::lights::{Blockers, LightSet, PointLights, RectShare, luminance, ray_epsilon};
use super::{GroupRgb, RenderSettings, Sampler, Strata};
use scene_gen_scene::scene::{Material, Scene, Texture};

/// Whether a material is glass (clear, left out of the BVH): name `glass*`, or a base-colour
/// alpha below one half.
#[must_use]
pub fn is_transparent(material: &Material) -> bool {
    material.name.starts_with("glass") || material.base_color[3] < 0.5
}

/// The sRGB-encoded RGBA8 bytes of a texture. The one place that knows the buffer's type.
#[must_use]
#[inline(always)]
pub fn texels(texture: &Texture) -> &[u8] {
    &texture.rgba8
}

/// sRGB transfer function decoded to linear (IEC 61966-2-1), as a 256-entry table.
#[must_use]
#[inline(always)]
pub fn srgb_to_linear(byte: u8) -> f32 {
    srgb_table()[byte as usize]
}

/// The table behind [`srgb_to_linear`], for callers that decode many bytes: one check of the
/// lazy initialisation instead of one per byte.
#[inline(always)]
pub(super) fn srgb_table() -> &'static [f32; 256] {
    static LUT: OnceLock<[f32; 256]> = OnceLock::new();
    LUT.get_or_init(|| {
        std::array::from_fn(|i| {
            let c = i as f32 / 255.0;
            if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
        })
    })
}

/// `i.rem_euclid(n)` for `i` in `-n..2 * n`, without the integer division (a few per cent of
/// the texture lookups of a frame). A bilinear footprint's texel indices are in `-1..=n`.
#[inline(always)]
pub(super) fn wrap_once(i: i64, n: i64) -> i64 {
    let i = if i < 0 { i + n } else { i };
    if i >= n { i - n } else { i }
}

/// Bilinear sample of a texture's linear RGB at `uv` ((0, 0) = top-left, repeating every 1.0).
/// A texture whose buffer is shorter than its size says returns white.
#[must_use]
#[inline(always)]
pub fn sample_texture(texture: &Texture, uv: Vec2) -> Vec3 {
    let (w, h) = (texture.width as usize, texture.height as usize);
    let bytes = texels(texture);
    if w == 0 || h == 0 || bytes.len() < w * h * 4 || !uv.is_finite() {
        return Vec3::ONE;
    }
    // `v - floor(v)` is `v.rem_euclid(1.0)` to the bit (both are exact, and for negative `v`
    // both round the same exact sum once) without the `fmodf` call, which took a few per cent
    // of a render. Only a -0.0 comes out as +0.0, and -0.0 * w - 0.5 = +0.0 * w - 0.5.
    let x = (uv.x - uv.x.floor()) * w as f32 - 0.5;
    let y = (uv.y - uv.y.floor()) * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    // `x` is in [-0.5, w - 0.5] (the fraction above is in [0, 1]), so `x0` is in -1..w and
    // `x0 + 1` in 0..=w: one wrap brings each into range.
    let (i, j) = (x0 as i64, y0 as i64);
    let (xa, xb) = (wrap_once(i, w as i64) as usize, wrap_once(i + 1, w as i64) as usize);
    let (ya, yb) = (wrap_once(j, h as i64) as usize, wrap_once(j + 1, h as i64) as usize);
    let lut = srgb_table();
    // A function, not a closure: a closure cannot be marked `#[inline(always)]` and was left
    // out of line, running baseline code inside the AVX2 clone of the tile loop.
    #[inline(always)]
    fn texel(lut: &[f32; 256], bytes: &[u8], w: usize, x: usize, y: usize) -> Vec3 {
        let i = (y * w + x) * 4;
        Vec3::new(lut[bytes[i] as usize], lut[bytes[i + 1] as usize], lut[bytes[i + 2] as usize])
    }
    let top = texel(lut, bytes, w, xa, ya).lerp(texel(lut, bytes, w, xb, ya), fx);
    let bottom = texel(lut, bytes, w, xa, yb).lerp(texel(lut, bytes, w, xb, yb), fx);
    top.lerp(bottom, fy)
}

/// A material evaluated at a surface point.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceResponse {
    /// Lambertian albedo per channel.
    pub diffuse: Vec3,
    /// Specular (mirror-like) reflectance per channel.
    pub specular: Vec3,
    pub roughness: f32,
}

/// The material of `surface` evaluated at its texture coordinates; a missing material is a
/// mid-grey Lambertian.
#[must_use]
#[inline(always)]
pub fn surface_response(scene: &Scene, surface: &SurfacePoint) -> SurfaceResponse {
    let Some(material) = scene.geometry.materials.get(surface.material) else {
        return SurfaceResponse { diffuse: Vec3::splat(0.5), specular: Vec3::ZERO, roughness: 1.0 };
    };
    let mut base = Vec3::new(material.base_color[0], material.base_color[1], material.base_color[2]);
    if let Some(texture) = material.base_color_texture.and_then(|i| scene.geometry.textures.get(i)) {
        base *= sample_texture(texture, surface.uv);
    }
    let base = base.clamp(Vec3::ZERO, Vec3::ONE);
    let metallic = material.metallic.clamp(0.0, 1.0);
    let roughness = if material.roughness.is_finite() { material.roughness.clamp(0.0, 1.0) } else { 1.0 };
    let s = metallic * (1.0 - roughness);
    SurfaceResponse { diffuse: base * (1.0 - s), specular: base * s, roughness }
}

/// A camera ray's surface hit with its material evaluated.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SurfaceHit {
    pub surface: SurfacePoint,
    pub response: SurfaceResponse,
}

/// What a camera ray sees (see [`Tracer::primary`]).
pub(crate) enum Primary {
    /// Nothing: black.
    Miss,
    /// A rect light emitter in front of any surface: its radiance.
    Emitter(GroupRgb),
    /// A surface, to be shaded.
    Surface(SurfaceHit),
}

/// Everything a ray needs: the scene, its BVH, its lights and the sample counts.
pub(crate) struct Tracer<'a> {
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    pub lights: &'a LightSet,
    pub settings: &'a RenderSettings,
    /// Shadow-ray hints of the tile (or probe) being traced.
    pub blockers: &'a Blockers,
    /// Seed of the pixels' random streams in this view ([`super::Renderer::pixel_seed`]).
    pub pixel_seed: u64,
    /// Whether the point and directional lights are traced here or by the caller, for a
    /// packet's hits together ([`super::hit_batch`]; only camera-ray hits, never bounces).
    pub point_lights: PointLights,
    /// Light that bounced more than once, if the settings keep it.
    pub volume: Option<&'a IrradianceVolume>,
}

/// A unit vector in the hemisphere about `n`, cosine-distributed, from `(u1, u2)` in [0, 1)^2.
#[inline(always)]
fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let (t, b) = n.any_orthonormal_pair();
    let r = u1.sqrt();
    let phi = std::f32::consts::TAU * u2;
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt()).normalize_or(n)
}

#[inline(always)]
fn scale(e: GroupRgb, k: Vec3) -> GroupRgb {
    [e[0] * k, e[1] * k]
}

#[inline(always)]
fn add(a: GroupRgb, b: GroupRgb) -> GroupRgb {
    [a[0] + b[0], a[1] + b[1]]
}

impl Tracer<'_> {
    /// Radiance leaving a surface point diffusely (the shading of a bounce or a mirror's
    /// view), per group: its direct light with one sample per rect light, plus the volume's
    /// indirect light where there is a volume.
    #[inline(always)]
    fn diffuse_radiance(&self, surface: &SurfacePoint, sampler: &mut Sampler) -> GroupRgb {
        let response = surface_response(self.scene, surface);
        let mut e = self.lights.direct(
            self.accel,
            surface.position,
            surface.geometric_normal,
            surface.shading_normal,
            1,
            Strata::independent(sampler),
            self.settings.light_cull,
            sampler,
            self.blockers,
        );
        if let Some(volume) = self.volume {
            e = add(e, volume.irradiance(surface.position, surface.shading_normal));
        }
        scale(e, response.diffuse * std::f32::consts::FRAC_1_PI)
    }

    /// Indirect irradiance at a point: with no rays, the volume's (zero without a volume);
    /// else from `rays` cosine-weighted bounce rays, each bounce shaded by
    /// [`Tracer::diffuse_radiance`]; emitters seen by a bounce ray are not counted (direct
    /// light sampling already has them). The rays take their places `strata.first..` of a
    /// 2D point set spread over the whole pixel (see [`Strata`]).
    #[inline(always)]
    pub fn indirect_irradiance(
        &self,
        point: Vec3,
        ng: Vec3,
        ns: Vec3,
        rays: u32,
        strata: Strata,
        sampler: &mut Sampler,
    ) -> GroupRgb {
        let mut sum = [Vec3::ZERO; 2];
        if rays == 0 {
            return match self.volume {
                Some(volume) => volume.irradiance(point, ns),
                None => sum,
            };
        }
        let origin = point + ng * ray_epsilon(point);
        for k in 0..rays {
            let (u1, u2) = strata.point(k, sampler);
            let dir = cosine_direction(ns, u1, u2);
            if dir.dot(ng) <= 0.0 {
                continue;
            }
            if let Some(hit) = self.accel.closest_hit(origin, dir, f32::INFINITY) {
                let surface = self.accel.surface(&hit, origin, dir);
                let mut l = self.diffuse_radiance(&surface, sampler);
                for (g, c) in l.iter_mut().enumerate() {
                    let limit = self.settings.indirect_clamp * self.lights.reference_nit[g];
                    let y = luminance(*c);
                    if y > limit {
                        *c *= limit / y;
                    }
                }
                sum = add(sum, l);
            }
        }
        // E = pi * mean(L) for cosine-weighted directions.
        scale(sum, Vec3::splat(std::f32::consts::PI / rays as f32))
    }

    /// Radiance per group arriving along a camera ray whose closest hit is `hit` (traced with
    /// others in a packet, which may reach the rect lights `emitters`); its bounce rays use
    /// `strata` and its rect light samples `rect_strata`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn camera_ray(
        &self,
        origin: Vec3,
        dir: Vec3,
        hit: Option<Hit>,
        emitters: &[u32],
        strata: Strata,
        rect_strata: Strata,
        sampler: &mut Sampler,
    ) -> GroupRgb {
        match self.camera_ray_seen(origin, dir, hit, emitters) {
            Primary::Miss => [Vec3::ZERO; 2],
            Primary::Emitter(l) => l,
            Primary::Surface(s) => self.hit_radiance(dir, &s, strata, rect_strata, sampler),
        }
    }

    /// What a camera ray sees given its closest hit `hit`: [`Tracer::primary`] of the
    /// interpolated hit.
    #[inline(always)]
    pub fn camera_ray_seen(&self, origin: Vec3, dir: Vec3, hit: Option<Hit>, emitters: &[u32]) -> Primary {
        // A `match`, not `Option::map`: a closure called from both builds of the tile loop can
        // stay out of line, with baseline code (see `scene_gen_core::simd`).
        #[allow(clippy::manual_map)]
        let hit = match hit {
            Some(h) => Some((h.t, self.accel.surface(&h, origin, dir))),
            None => None,
        };
        self.primary(origin, dir, hit, emitters)
    }

    /// Radiance per group leaving the camera-ray hit `s` along `-dir`: its irradiance (bounce
    /// rays on `strata`, rect light samples on `rect_strata`) times its diffuse albedo over pi,
    /// plus its mirror reflection. Without the point and directional lights where those are
    /// [`PointLights::Batched`].
    #[inline(always)]
    pub fn hit_radiance(
        &self,
        dir: Vec3,
        s: &SurfaceHit,
        strata: Strata,
        rect_strata: Strata,
        sampler: &mut Sampler,
    ) -> GroupRgb {
        let e = if s.response.diffuse != Vec3::ZERO {
            Some(self.irradiance(&s.surface, strata, rect_strata, sampler))
        } else {
            None
        };
        self.surface_radiance(dir, s, e, sampler)
    }

    /// Whether [`Tracer::hit_radiance`] of a hit of material `response` in room `room`
    /// ([`super::reach::LightReach::room_of`]; `None` without a diffuse part) adds anything
    /// with the point and directional lights batched: rect lights in reach or bounce rays for
    /// a diffuse part, or a mirror.
    #[inline(always)]
    pub fn hit_has_more_than_point_lights(&self, response: &SurfaceResponse, room: Option<usize>) -> bool {
        // A `match`, not `is_some_and` with a closure (see `camera_ray_seen`).
        let rects_in_reach = match room {
            Some(room) => !self.lights.reach.lists(room).rects.is_empty(),
            None => false,
        };
        let indirect = self.settings.indirect_rays > 0 || self.volume.is_some();
        let diffuse = response.diffuse != Vec3::ZERO && (indirect || rects_in_reach);
        diffuse || (self.settings.specular && response.specular != Vec3::ZERO)
    }

    /// What a camera ray along `dir` sees, given its closest hit (distance and surface): an
    /// emitter in front of the hit, nothing, or a surface with its material evaluated.
    /// Only the rect lights `emitters` are looked for (those the ray's packet may reach,
    /// [`LightSet::emitters_in_reach`]).
    #[inline(always)]
    pub fn primary(&self, origin: Vec3, dir: Vec3, hit: Option<(f32, SurfacePoint)>, emitters: &[u32]) -> Primary {
        let tmax = hit.map_or(f32::INFINITY, |h| h.0);
        if let Some((_, group, rgb)) = self.lights.emitter_seen_among(origin, dir, tmax, emitters.iter().copied()) {
            let mut l = [Vec3::ZERO; 2];
            l[group] = rgb;
            return Primary::Emitter(l);
        }
        let Some((_, surface)) = hit else { return Primary::Miss };
        let response = surface_response(self.scene, &surface);
        Primary::Surface(SurfaceHit { surface, response })
    }

    /// Irradiance per group (lux per channel) the diffuse part of a camera-ray hit receives:
    /// direct light (rect samples placed by `rect_strata`) plus the bounce estimate (`strata`).
    #[inline(always)]
    pub fn irradiance(
        &self,
        surface: &SurfacePoint,
        strata: Strata,
        rect_strata: Strata,
        sampler: &mut Sampler,
    ) -> GroupRgb {
        let rect_samples = self.settings.rect_samples_per_axis.pow(2);
        self.irradiance_split(surface, strata, rect_samples, rect_strata, sampler, false).0
    }

    /// A rotation in [0, 1) drawn from the view's seed: the one every anchor of the view shares
    /// for its interleaved rect-light samples (`Renderer::rect_plan`).
    #[inline(always)]
    pub fn view_rotation(&self) -> f32 {
        let bits = scene_gen_core::rng::fnv1a64(&self.pixel_seed.to_le_bytes());
        (bits >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// [`Tracer::irradiance`] with `rect_samples` samples per rect light and the rect lights'
    /// part of it ([`RectShare`], its exact unshadowed light too where `unshadowed` is set),
    /// for the visibility filter of anchors.
    #[inline(always)]
    pub fn irradiance_split(
        &self,
        surface: &SurfacePoint,
        strata: Strata,
        rect_samples: u32,
        rect_strata: Strata,
        sampler: &mut Sampler,
        unshadowed: bool,
    ) -> (GroupRgb, RectShare) {
        let (p, ng, ns) = (surface.position, surface.geometric_normal, surface.shading_normal);
        let (other, rects) = self.lights.direct_split(
            self.accel,
            p,
            ng,
            ns,
            rect_samples,
            rect_strata,
            self.settings.light_cull,
            sampler,
            self.blockers,
            unshadowed,
            self.point_lights,
        );
        let indirect = self.indirect_irradiance(p, ng, ns, self.settings.indirect_rays, strata, sampler);
        (add(add(other, rects.visible), indirect), rects)
    }

    /// Radiance leaving a camera-ray hit towards the camera: `rho / pi * e` of the diffuse part
    /// (`e` its [`Tracer::irradiance`], computed at this point or interpolated from neighbours;
    /// `None` when the material has no diffuse part) plus the mirror reflection of metals.
    #[inline(always)]
    pub fn surface_radiance(&self, dir: Vec3, s: &SurfaceHit, e: Option<GroupRgb>, sampler: &mut Sampler) -> GroupRgb {
        let (response, surface) = (&s.response, &s.surface);
        let (p, ng, ns) = (surface.position, surface.geometric_normal, surface.shading_normal);
        let mut out = [Vec3::ZERO; 2];
        if let Some(e) = e {
            out = scale(e, response.diffuse * std::f32::consts::FRAC_1_PI);
        }
        if self.settings.specular && response.specular != Vec3::ZERO {
            let mirror = dir - 2.0 * dir.dot(ns) * ns;
            let jitter = cosine_direction(mirror, sampler.uniform(), sampler.uniform()) - mirror;
            let mut reflected = (mirror + jitter * response.roughness).normalize_or(mirror);
            if reflected.dot(ng) <= 0.0 {
                reflected = mirror;
            }
            if reflected.dot(ng) > 0.0 {
                let o = p + ng * ray_epsilon(p);
                out = add(out, scale(self.reflection(o, reflected, sampler), response.specular));
            }
        }
        out
    }

    /// Radiance seen in a mirror direction: an emitter, or a diffuse surface lit directly.
    #[inline(always)]
    fn reflection(&self, origin: Vec3, dir: Vec3, sampler: &mut Sampler) -> GroupRgb {
        let hit = self.accel.closest_hit(origin, dir, f32::INFINITY);
        let tmax = hit.map_or(f32::INFINITY, |h| h.t);
        if let Some((_, group, rgb)) = self.lights.emitter_seen(origin, dir, tmax) {
            let mut l = [Vec3::ZERO; 2];
            l[group] = rgb;
            return l;
        }
        match hit {
            Some(hit) => self.diffuse_radiance(&self.accel.surface(&hit, origin, dir), sampler),
            None => [Vec3::ZERO; 2],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert_eq!(srgb_to_linear(255), 1.0);
        assert!((srgb_to_linear(128) - 0.215_861).abs() < 1e-5);
    }

    #[test]
    fn wrap_once_is_rem_euclid_on_its_range() {
        for n in [1i64, 2, 3, 7, 256] {
            for i in -n..2 * n {
                assert_eq!(wrap_once(i, n), i.rem_euclid(n), "i {i}, n {n}");
            }
        }
    }

    #[test]
    fn bilinear_sampling_repeats() {
        // 2x1 texture: black, white. At u = 0 we are half-way between the last and first
        // texel (wrap), so the value is mid-way; at the texel centres it is exact.
        let texture = Texture {
            name: "t".into(),
            width: 2,
            height: 1,
            // Collected, so the test compiles whether the buffer is a Vec or an Arc<[u8]>.
            rgba8: [0u8, 0, 0, 255, 255, 255, 255, 255].into_iter().collect(),
            png: Vec::new().into(),
        };
        assert!((sample_texture(&texture, Vec2::new(0.25, 0.5)).x - 0.0).abs() < 1e-6);
        assert!((sample_texture(&texture, Vec2::new(0.75, 0.5)).x - 1.0).abs() < 1e-6);
        assert!((sample_texture(&texture, Vec2::new(0.0, 0.5)).x - 0.5).abs() < 1e-6);
        assert!((sample_texture(&texture, Vec2::new(3.25, -7.5)).x - 0.0).abs() < 1e-6);
    }

    #[test]
    fn cosine_directions_stay_in_the_hemisphere() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        for i in 0..100 {
            let d = cosine_direction(n, i as f32 / 100.0, (i * 37 % 100) as f32 / 100.0);
            assert!(d.dot(n) >= -1e-6 && (d.length() - 1.0).abs() < 1e-5);
        }
    }
}
