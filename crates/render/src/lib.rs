//! The CPU ray tracer: linear scene radiance per light group, depth, instance and class ids and
//! normals of a [`Scene`] seen by a pinhole [`Camera`].
//!
//! * [`accel`]: every opaque triangle in one BVH ([`scene_gen_trace::Bvh`]) with its shading
//!   record (normals, texture coordinates, material, label).
//! * [`camera`]: the pinhole camera from plain numbers, and [`camera::sensor_illuminance_lux`]
//!   (scene luminance to sensor-plane illuminance; the sensor model takes it from there).
//! * [`lights`]: direct illuminance from point, directional and rect lights with shadow rays.
//! * [`shade`]: textures, materials and the light transport estimate.
//! * [`irradiance_volume`]: light that bounced any number of times, computed once per scene.
//!
//! A [`Renderer`] owns the BVH and the prepared lights of one scene and renders any number of
//! views into [`Frame`]s. Radiance is traced once and kept per [`LightGroup`], so day and night
//! (and any mix, see [`Frame::mix`]) are weighted sums of one trace; [`LightScale`] finds the
//! weights that bring the mean illuminance on the table-height plane to a target.
//!
//! ```no_run
//! use scene_gen_render::{Camera, RenderSettings, Renderer};
//! use scene_gen_scene::{config::GeneratorConfig, generate::generate, library::Library};
//! let scene = generate(&GeneratorConfig { seed: 7, ..GeneratorConfig::default() }, &Library::embedded()?)?;
//! let renderer = Renderer::new(&scene, RenderSettings::default());
//! let camera = Camera {
//!     width_px: 640, height_px: 480, pixel_pitch_um: 5.86, focal_mm: 4.0, f_number: 2.0,
//!     position: glam::Vec3::new(1.0, 1.0, 1.2), yaw_deg: 45.0, pitch_deg: -10.0, vignetting: false,
//! };
//! let frame = renderer.render(&camera)?;
//! println!("centre depth {} m", frame.depth_m[frame.index(320, 240)]);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Determinism: every random number comes from [`scene_gen_core::rng::substream`] keyed by the
//! settings' seed and the pixel index (or the probe point), drawn in a fixed order within the pixel, so a
//! frame is bit-identical at any thread count.

pub mod accel;
pub mod camera;
mod hit_batch;
pub mod irradiance_volume;
pub mod lights;
mod reach;
mod refine;
mod responses;
pub mod shade;
pub mod test_util;
mod tile;
mod visibility_filter;

use glam::{Vec2, Vec3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

pub use accel::Accel;
pub use camera::{Camera, DEFAULT_LENS_TRANSMITTANCE, PixelRect, sensor_illuminance_lux};
pub use irradiance_volume::{IrradianceVolume, VolumeSettings};
use lights::RectShare;
pub use lights::{Blockers, LightSet, luminance};

use accel::{Hit, SurfacePoint};
use scene_gen_scene::scene::{LightGroup, Scene};
use shade::Tracer;
use tile::{Cells, Job};

/// Per-group linear RGB: index 0 is [`LightGroup::Day`], 1 is [`LightGroup::Night`].
pub type GroupRgb = [Vec3; 2];

/// Index of a group in a [`GroupRgb`].
#[must_use]
pub fn group_index(group: LightGroup) -> usize {
    match group {
        LightGroup::Day => 0,
        LightGroup::Night => 1,
    }
}

/// Why a render or a measurement could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RenderError {
    #[error("camera field {field}: {why}")]
    BadCamera { field: &'static str, why: String },
    #[error("pixel window {rect:?} is not inside the {width}x{height} frame")]
    BadWindow { rect: PixelRect, width: u32, height: u32 },
    #[error("no illuminance probe points: the scene has no room with free floor area")]
    NoProbePoints,
    #[error("{group:?} lights give no illuminance on the {height_m} m plane; cannot scale them to a target")]
    Unlit { group: LightGroup, height_m: f32 },
}

/// Default [`RenderSettings::indirect_clamp`]: an engineering choice, judged by eye on the
/// benchmark room of boxes (8 x 6 x 2.6 m, 36 boxes, a 20 cd bulb 0.1 m below the ceiling),
/// where it turns most white speckles into mild grain. Its cost there, measured with 1024
/// probe rays: the night indirect term on the 0.75 m plane drops from 1.66 to 1.05 lux (direct:
/// 1.52 lux); the day term (window light) is unchanged.
pub const DEFAULT_INDIRECT_CLAMP: f32 = 4.0;

/// Default [`RenderSettings::light_cull`]: lights giving less than a tenth of their group's
/// unshadowed total at a point are traced stochastically (an engineering choice: in a house
/// most such lights are in other rooms, behind walls).
pub const DEFAULT_LIGHT_CULL: f32 = 0.1;

/// Where the diffuse irradiance of a frame is computed ([`RenderSettings::shading`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadingRate {
    /// At every pixel (every camera sample).
    Full,
    /// Decoupled shading, a deferred-lighting approximation, for frames of one camera ray per
    /// pixel (`samples_per_axis` 1) at least `min_width_px` wide: the irradiance `E` (direct
    /// light and bounce, the part that costs shadow and bounce rays) is computed only at the
    /// *anchor* pixels, every `stride`-th pixel of every `stride`-th row plus the last column
    /// and row. Every other pixel still traces its own camera ray (depth, ids, normal, texture
    /// and albedo at full resolution) and takes `E` as the bilinear mix of the surrounding
    /// anchors that lie on the same surface (same instance and material, normals within about
    /// 18 degrees, within 1 % of the ray length of the anchor's tangent plane); a pixel with no
    /// such anchor is shaded in full. Radiance is then `rho / pi * E` per pixel, so texture
    /// stays sharp while shadow edges blur over `stride` pixels and the per-pixel light noise
    /// is averaged over neighbours. Ignored for `stride` below 2, narrower frames, or more than
    /// one camera ray per pixel.
    Decoupled { stride: u32, min_width_px: u32 },
    /// [`ShadingRate::Decoupled`] with its anchors filled coarse to fine: the anchors of twice
    /// the stride are shaded first, and an anchor between them is shaded too only where they
    /// do not lie on one surface, the sun reaches some and not others, or their night
    /// irradiance differs by more than 10 %; elsewhere it takes their mean. About a quarter less
    /// CPU per evaluator frame than `Decoupled` at stride 3, for a coarser grain of the day
    /// frame's window-light noise (docs/BENCHMARKS.md, "Adaptive anchors"). The same
    /// conditions of use as `Decoupled`.
    Adaptive { stride: u32, min_width_px: u32 },
}

/// Sample counts; a plain `Copy` struct with presets, each field a quality/time trade-off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// `n x n` stratified, jittered camera rays per pixel (anti-aliasing, soft-shadow noise).
    pub samples_per_axis: u32,
    /// `n x n` stratified area samples per rect light at a camera-ray hit (soft shadows).
    pub rect_samples_per_axis: u32,
    /// Cosine-weighted bounce rays per camera sample: a final gather, each bounce hit shaded
    /// with its direct light and the [`RenderSettings::indirect_volume`]'s light (sharper
    /// indirect detail than the volume alone, at the cost of noise). With 0, a hit reads the
    /// volume directly.
    pub indirect_rays: u32,
    /// The irradiance volume that carries light that bounced any number of times
    /// ([`irradiance_volume`]), built once per [`Renderer`]; `None` leaves only what the
    /// bounce rays see lit directly (one bounce), or direct light alone without them.
    pub indirect_volume: Option<VolumeSettings>,
    /// Trace mirror rays on metallic surfaces.
    pub specular: bool,
    /// Clamp of a bounce sample's radiance, in multiples of the group's reference radiance
    /// (see [`shade`]); `f32::INFINITY` for the unbiased, noisier estimate.
    pub indirect_clamp: f32,
    /// Russian-roulette light culling threshold, a fraction of a group's total unshadowed
    /// illuminance (see [`lights::LightSet::direct`]); 0 traces a shadow ray to every light.
    pub light_cull: f32,
    /// How densely the irradiance is computed; [`ShadingRate::Full`] in every preset.
    pub shading: ShadingRate,
    /// With anchors ([`ShadingRate::Decoupled`], [`ShadingRate::Adaptive`]): how many anchors
    /// either way each anchor pools the sampled visibility of its rect lights (windows) with,
    /// among those on its surface (`render::visibility_filter`); 0 in every preset (each
    /// anchor keeps its own estimate), ignored without anchors.
    pub visibility_filter_radius: u32,
    /// Rays for the indirect term of [`Renderer::illuminance_lux`].
    pub probe_indirect_rays: u32,
    /// Rect light samples per axis for [`Renderer::illuminance_lux`].
    pub probe_rect_samples_per_axis: u32,
    /// Seed of the sampling pattern (not of the scene).
    pub seed: u64,
}

impl RenderSettings {
    /// One ray per pixel with the irradiance volume's indirect light and no bounce rays: the
    /// fastest full render. The one ray goes through the pixel centre and gives both the
    /// labels and the radiance.
    #[must_use]
    pub const fn preview() -> RenderSettings {
        RenderSettings {
            samples_per_axis: 1,
            rect_samples_per_axis: 1,
            indirect_rays: 0,
            indirect_volume: Some(VolumeSettings::DEFAULT),
            specular: false,
            indirect_clamp: DEFAULT_INDIRECT_CLAMP,
            light_cull: DEFAULT_LIGHT_CULL,
            shading: ShadingRate::Full,
            visibility_filter_radius: 0,
            probe_indirect_rays: 16,
            probe_rect_samples_per_axis: 2,
            seed: 0,
        }
    }

    /// The default: 2x2 pixel samples, 2x2 rect samples, the volume's indirect light.
    #[must_use]
    pub const fn standard() -> RenderSettings {
        RenderSettings {
            samples_per_axis: 2,
            rect_samples_per_axis: 2,
            indirect_rays: 0,
            indirect_volume: Some(VolumeSettings::DEFAULT),
            specular: true,
            indirect_clamp: DEFAULT_INDIRECT_CLAMP,
            light_cull: DEFAULT_LIGHT_CULL,
            shading: ShadingRate::Full,
            visibility_filter_radius: 0,
            probe_indirect_rays: 64,
            probe_rect_samples_per_axis: 4,
            seed: 0,
        }
    }

    /// Low noise for reference images: 4x4 pixel samples, 3x3 rect samples, one final-gather
    /// bounce ray per sample over the volume.
    #[must_use]
    pub const fn high() -> RenderSettings {
        RenderSettings {
            samples_per_axis: 4,
            rect_samples_per_axis: 3,
            indirect_rays: 1,
            indirect_volume: Some(VolumeSettings::DEFAULT),
            specular: true,
            indirect_clamp: DEFAULT_INDIRECT_CLAMP,
            light_cull: DEFAULT_LIGHT_CULL,
            shading: ShadingRate::Full,
            visibility_filter_radius: 0,
            probe_indirect_rays: 256,
            probe_rect_samples_per_axis: 6,
            seed: 0,
        }
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings::standard()
    }
}

/// Uniform numbers in [0, 1) from a ChaCha8 stream owned by one pixel or probe.
///
/// The stream is seeded on the first draw, not at construction: most pixels of a decoupled
/// frame take their irradiance from anchors and draw nothing, and seeding a ChaCha stream
/// (and filling its first block) for each of them was about 5 % of such a frame (perf). The
/// numbers drawn are the same either way.
#[derive(Debug)]
pub struct Sampler {
    seed: u64,
    label_hash: u64,
    key: u64,
    rng: Option<ChaCha8Rng>,
}

/// [`scene_gen_core::rng::fnv1a64`] of the label of the per-pixel streams, `"render/pixel"`.
pub(crate) const PIXEL_STREAM: u64 = scene_gen_core::rng::fnv1a64(b"render/pixel");

/// [`scene_gen_core::rng::fnv1a64`] of `"render/tile"`: the stream of a sampled tile's sub-pixel jitter
/// and strata rotations, keyed by the tile's first pixel.
pub(crate) const TILE_STREAM: u64 = scene_gen_core::rng::fnv1a64(b"render/tile");

impl Sampler {
    /// The stream of `key` (a pixel index, a probe hash) under `seed` and `label`.
    #[must_use]
    #[inline(always)]
    pub fn new(seed: u64, label: &str, key: u64) -> Sampler {
        Sampler::of_hashed(seed, scene_gen_core::rng::fnv1a64(label.as_bytes()), key)
    }

    /// [`Sampler::new`] for a label hashed once with [`scene_gen_core::rng::fnv1a64`].
    #[must_use]
    pub(crate) const fn of_hashed(seed: u64, label_hash: u64, key: u64) -> Sampler {
        Sampler { seed, label_hash, key, rng: None }
    }

    /// The next number in [0, 1).
    #[inline(always)]
    pub fn uniform(&mut self) -> f32 {
        let (seed, label_hash, key) = (self.seed, self.label_hash, self.key);
        self.rng.get_or_insert_with(|| scene_gen_core::rng::substream_of(seed, label_hash, key)).random::<f32>()
    }

    /// The next `out.len()` numbers of [`Sampler::uniform`], in order: the stream's words are
    /// taken in blocks and turned into numbers in a vector loop, where each draw alone checked
    /// the stream's start and its buffer (a few per cent of a 4-spp image for the jitter).
    #[inline(always)]
    pub fn fill_uniform(&mut self, out: &mut [f32]) {
        let (seed, label_hash, key) = (self.seed, self.label_hash, self.key);
        let rng = self.rng.get_or_insert_with(|| scene_gen_core::rng::substream_of(seed, label_hash, key));
        let mut words = [0u32; 64];
        for chunk in out.chunks_mut(words.len()) {
            let words = &mut words[..chunk.len()];
            // The words `next_u32` would give one by one.
            rng.fill(words);
            for (x, &w) in chunk.iter_mut().zip(words.iter()) {
                // rand's `StandardUniform` for `f32`: the top 24 bits, scaled.
                *x = (w >> 8) as f32 * (1.0 / (1u32 << 24) as f32);
            }
        }
    }
}

/// Where a point's samples (bounce directions, rect light positions) sit in a 2D point set
/// shared by every camera sample of a pixel: sample `k` of this point is point
/// `i = first + k * stride` of the set, and the `i`-th of `total` points is
/// `((i + jitter) / total, frac(rotation + i / golden ratio))`, a jittered rank-1 (Fibonacci)
/// lattice. Stratifying over the whole pixel rather than within each
/// camera sample spreads a pixel's few bounce rays evenly over the hemisphere and its
/// few rect light samples evenly over the rectangle.
#[derive(Clone, Copy, Debug)]
pub struct Strata {
    /// Index of this point's first sample (the camera sample's index within the pixel).
    pub first: u32,
    /// Distance between this point's samples in the set (the camera samples per pixel), so
    /// each camera sample gets samples spread over the whole domain.
    pub stride: u32,
    /// Samples in the whole set.
    pub total: u32,
    /// Cranley-Patterson rotation of the second coordinate, in [0, 1).
    pub rotation: f32,
}

impl Strata {
    /// A set of one point: both coordinates independent uniform numbers.
    #[inline(always)]
    pub fn independent(sampler: &mut Sampler) -> Strata {
        Strata { first: 0, stride: 1, total: 1, rotation: sampler.uniform() }
    }

    /// The `k`-th sample of this point, in [0, 1)^2.
    #[inline(always)]
    pub fn point(&self, k: u32, sampler: &mut Sampler) -> (f32, f32) {
        // 1 / golden ratio: the lattice generator with the most uniform 1D projections.
        const INV_PHI: f64 = 0.618_033_988_749_894_9;
        let i = self.first + k * self.stride.max(1);
        let total = self.total.max(i + 1);
        let u1 = ((i as f32 + sampler.uniform()) / total as f32).min(1.0 - f32::EPSILON);
        let u2 = (f64::from(self.rotation) + f64::from(i) * INV_PHI).fract() as f32;
        (u1, u2)
    }
}

/// One rendered view. Buffers are row-major from the top-left pixel, `width * height` long.
/// The default is an empty frame, for [`Renderer::render_into`] to size.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance (nit per channel) from the day lights.
    pub day_nit: Vec<[f32; 3]>,
    /// Linear RGB radiance (nit per channel) from the night lights.
    pub night_nit: Vec<[f32; 3]>,
    /// Distance along the optical axis (z-depth), metres; `f32::INFINITY` where nothing is hit.
    pub depth_m: Vec<f32>,
    /// Instance id of the object or threshold at the pixel centre; 0 for none.
    pub instance_id: Vec<u32>,
    /// COCO class id (1..=10 objects, 11 threshold) at the pixel centre; 0 for none.
    pub class_id: Vec<u16>,
    /// Unit world shading normal facing the camera; zero where nothing is hit.
    pub normal: Vec<[f32; 3]>,
}

/// What a camera sees at each pixel centre of a rectangle of its frame, and nothing else: the
/// instance and class ids of [`Frame`] there (the same values, row-major over the rectangle)
/// without its radiance, depth and normal buffers. [`Renderer::render_ids`] traces one ray per
/// pixel and interpolates no surface, for callers that only count what is visible (threshold
/// visibility in the evaluator).
#[derive(Debug, Clone, PartialEq)]
pub struct IdFrame {
    /// The pixels covered, in the camera's frame.
    pub rect: PixelRect,
    /// Instance id of the object or threshold at the pixel centre; 0 for none.
    pub instance_id: Vec<u32>,
    /// COCO class id (1..=10 objects, 11 threshold) at the pixel centre; 0 for none.
    pub class_id: Vec<u16>,
}

impl Frame {
    /// Buffer index of pixel (x, y).
    #[must_use]
    pub fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// Radiance of one group.
    #[must_use]
    pub fn radiance(&self, group: LightGroup) -> &[[f32; 3]] {
        match group {
            LightGroup::Day => &self.day_nit,
            LightGroup::Night => &self.night_nit,
        }
    }

    /// `day_weight * day + night_weight * night`: a scenario as a weighted sum of the trace.
    #[must_use]
    pub fn mix(&self, day_weight: f32, night_weight: f32) -> Vec<[f32; 3]> {
        self.day_nit
            .iter()
            .zip(&self.night_nit)
            .map(|(d, n)| std::array::from_fn(|c| d[c] * day_weight + n[c] * night_weight))
            .collect()
    }

    /// Luminance (nit) of a radiance buffer, per pixel.
    #[must_use]
    pub fn luminance_nit(radiance: &[[f32; 3]]) -> Vec<f32> {
        radiance.iter().map(|c| luminance(Vec3::from(*c))).collect()
    }

    /// Speckle of the day luminance, for comparing sampling settings on one view: the mean over
    /// pixels of `|Y - m| / m`, `m` the median of the 5x5 neighbourhood, where `m > 0`; and how
    /// many pixels have `m = 0` (most neighbours black, the mark of a noisy estimate in a lit
    /// room). Edges and texture add a floor that no sampling change removes.
    #[must_use]
    pub fn day_speckle(&self) -> (f64, usize) {
        let y = Frame::luminance_nit(&self.day_nit);
        let (w, h) = (self.width, self.height);
        let (mut sum, mut n, mut zero) = (0.0f64, 0usize, 0usize);
        let mut window = Vec::with_capacity(25);
        for py in 2..h.saturating_sub(2) {
            for px in 2..w.saturating_sub(2) {
                window.clear();
                for dy in 0..5 {
                    for dx in 0..5 {
                        window.push(y[((py + dy - 2) * w + px + dx - 2) as usize]);
                    }
                }
                window.sort_by(f32::total_cmp);
                let m = window[12];
                if m > 0.0 {
                    sum += f64::from(((y[(py * w + px) as usize] - m) / m).abs());
                    n += 1;
                } else {
                    zero += 1;
                }
            }
        }
        (sum / n.max(1) as f64, zero)
    }
}

/// Per-pixel results before they are spread into the frame's buffers.
#[derive(Clone, Copy, Default)]
struct PixelOut {
    radiance: GroupRgb,
    depth_m: f32,
    instance_id: u32,
    class_id: u16,
    normal: Vec3,
}

/// An anchor pixel of [`ShadingRate::Decoupled`]: where its surface is and the irradiance it got.
#[derive(Clone, Copy)]
struct Guide {
    position: Vec3,
    normal: Vec3,
    material: usize,
    instance_id: u32,
    irradiance: GroupRgb,
    /// The rect lights' part of `irradiance`, for [`visibility_filter`].
    rects: RectShare,
}

impl Guide {
    /// Whether this anchor lies on the surface a ray of length `ray_length_m` hit at `position`
    /// (of `instance_id` and `material`, normal `normal`), as far as sharing its irradiance
    /// goes: same instance and material, normals within [`GUIDE_MIN_COS`], and the anchor within
    /// [`GUIDE_PLANE_TOLERANCE`] of the ray length from the point's tangent plane.
    #[inline(always)]
    fn shares_surface(
        &self,
        instance_id: u32,
        material: usize,
        position: Vec3,
        normal: Vec3,
        ray_length_m: f32,
    ) -> bool {
        self.instance_id == instance_id
            && self.material == material
            && self.normal.dot(normal) >= GUIDE_MIN_COS
            && (self.position - position).dot(normal).abs() <= GUIDE_PLANE_TOLERANCE * ray_length_m
    }
}

/// Anchors whose normal is within this cosine of a pixel's (about 18 degrees) may lend it their
/// irradiance. Engineering choice: curved furniture with smooth normals still shares, the faces
/// of a box (90 degrees apart) never do.
const GUIDE_MIN_COS: f32 = 0.95;
/// Anchors farther than this fraction of a pixel's ray length from its tangent plane lend it
/// nothing (1 %: 3 cm at 3 m, several pixel footprints at 1936 px; parallel shelves or a box on
/// the floor are farther apart). Engineering choice.
const GUIDE_PLANE_TOLERANCE: f32 = 0.01;

/// The anchors of a decoupled-shading frame, row-major, with their finished pixels (`None`
/// for an anchor whose irradiance was interpolated, not traced: its pixel is shaded like any
/// other, [`ShadingRate::Adaptive`]).
struct AnchorGrid {
    stride: u32,
    width: u32,
    height: u32,
    cols: u32,
    rows: u32,
    pixels: Vec<Option<PixelOut>>,
    guides: Vec<Option<Guide>>,
}

impl AnchorGrid {
    /// The layout of the anchors at every `stride`-th pixel of a `width x height` frame, with no
    /// pixels or guides yet.
    fn layout(stride: u32, width: u32, height: u32) -> AnchorGrid {
        let (cols, rows) = (AnchorGrid::count(width, stride), AnchorGrid::count(height, stride));
        AnchorGrid { stride, width, height, cols, rows, pixels: Vec::new(), guides: Vec::new() }
    }

    /// Anchor columns (or rows) of a frame side of `n` pixels: every `stride`-th and the last.
    fn count(n: u32, stride: u32) -> u32 {
        n.saturating_sub(1).div_ceil(stride) + 1
    }

    /// Pixel coordinate of anchor column (or row) `i` on a side of `n` pixels.
    #[inline(always)]
    fn coord(&self, i: u32, n: u32) -> u32 {
        (i * self.stride).min(n - 1)
    }

    /// Anchor column (or row) at pixel coordinate `v` of a side of `n` pixels, if it is one.
    #[inline(always)]
    fn anchor_at(&self, v: u32, n: u32) -> Option<u32> {
        if v % self.stride == 0 {
            Some(v / self.stride)
        } else if v == n - 1 {
            Some(Self::count(n, self.stride) - 1)
        } else {
            None
        }
    }

    /// Index of pixel (x, y) among the anchors, if it is one.
    #[inline(always)]
    fn index(&self, x: u32, y: u32) -> Option<usize> {
        let cx = self.anchor_at(x, self.width)?;
        let cy = self.anchor_at(y, self.height)?;
        Some(cy as usize * self.cols as usize + cx as usize)
    }

    /// The surrounding anchors of coordinate `v` and the weight of the second.
    #[inline(always)]
    fn span(&self, v: u32, n: u32, count: u32) -> (u32, u32, f32) {
        let i0 = (v / self.stride).min(count - 1);
        let i1 = (i0 + 1).min(count - 1);
        let (v0, v1) = (self.coord(i0, n), self.coord(i1, n));
        let f = if v1 > v0 { (v - v0) as f32 / (v1 - v0) as f32 } else { 0.0 };
        (i0, i1, f)
    }

    /// Irradiance at pixel (x, y), whose ray of length `t` hit `surface` (of `instance_id`), as
    /// the bilinear mix of the surrounding anchors on the same surface; `None` when there is none.
    #[inline(always)]
    fn irradiance(&self, x: u32, y: u32, surface: &SurfacePoint, instance_id: u32, t: f32) -> Option<GroupRgb> {
        let (cx0, cx1, fx) = self.span(x, self.width, self.cols);
        let (cy0, cy1, fy) = self.span(y, self.height, self.rows);
        let corners = [
            (cx0, cy0, (1.0 - fx) * (1.0 - fy)),
            (cx1, cy0, fx * (1.0 - fy)),
            (cx0, cy1, (1.0 - fx) * fy),
            (cx1, cy1, fx * fy),
        ];
        let n = surface.shading_normal;
        let mut sum = [Vec3::ZERO; 2];
        let mut weight = 0.0;
        for (cx, cy, w) in corners {
            if w <= 0.0 {
                continue;
            }
            let Some(g) = &self.guides[cy as usize * self.cols as usize + cx as usize] else { continue };
            if g.shares_surface(instance_id, surface.material, surface.position, n, t) {
                sum[0] += g.irradiance[0] * w;
                sum[1] += g.irradiance[1] * w;
                weight += w;
            }
        }
        (weight > 0.0).then(|| sum.map(|c| c / weight))
    }
}

/// A scene prepared for rendering: its BVH, its lights and the sample counts.
#[derive(Debug)]
pub struct Renderer<'a> {
    scene: &'a Scene,
    accel: Accel,
    lights: LightSet,
    /// The materials as a packet's hits are evaluated ([`responses`]).
    materials: responses::MaterialTable<'a>,
    /// Light that bounced more than once ([`RenderSettings::indirect_volume`]).
    volume: Option<std::sync::Arc<IrradianceVolume>>,
    settings: RenderSettings,
    /// Which build of the tile loop runs ([`scene_gen_core::simd`]; same frame either way).
    dispatch: scene_gen_core::simd::Dispatch,
    /// Whether several samples per pixel light each packet's hits with the point and
    /// directional lights together ([`hit_batch`]); off only in a test that compares the two
    /// ways.
    batch_lights: bool,
}

impl<'a> Renderer<'a> {
    /// Builds the BVH, prepares the lights at their nominal intensities and, where the
    /// settings ask for one, traces the irradiance volume (or reuses the one this process
    /// built for the same scene, [`IrradianceVolume::shared`]).
    #[must_use]
    pub fn new(scene: &'a Scene, settings: RenderSettings) -> Renderer<'a> {
        let accel = Accel::build(scene);
        let lights = LightSet::for_scene(scene, [1.0, 1.0]);
        let volume =
            settings.indirect_volume.map(|v| IrradianceVolume::shared(scene, &accel, &lights, &v, settings.seed));
        Renderer {
            scene,
            accel,
            lights,
            materials: responses::MaterialTable::new(scene),
            volume,
            settings,
            dispatch: scene_gen_core::simd::Dispatch::current(),
            batch_lights: true,
        }
    }

    /// The scene's BVH (for benchmarks and custom ray queries).
    #[must_use]
    pub fn accel(&self) -> &Accel {
        &self.accel
    }

    /// The sample counts in use.
    #[must_use]
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The irradiance volume, if the settings asked for one.
    #[must_use]
    pub fn volume(&self) -> Option<&IrradianceVolume> {
        self.volume.as_deref()
    }

    /// A tracer over this scene whose shadow rays keep their hints in `blockers` and whose
    /// pixel streams start from `pixel_seed`.
    #[inline(always)]
    fn tracer<'t>(&'t self, blockers: &'t Blockers, pixel_seed: u64) -> Tracer<'t> {
        Tracer {
            scene: self.scene,
            accel: &self.accel,
            lights: &self.lights,
            settings: &self.settings,
            blockers,
            pixel_seed,
            point_lights: lights::PointLights::Traced,
            volume: self.volume.as_deref(),
        }
    }

    /// The seed of every pixel's random stream in `camera`'s view: the settings' seed and the
    /// view's [`Camera::view_key`], so the same view renders the same bytes and two views
    /// share no noise pattern.
    #[must_use]
    pub fn pixel_seed(&self, camera: &Camera) -> u64 {
        let mut bytes = [0u8; 16];
        bytes[..8].copy_from_slice(&self.settings.seed.to_le_bytes());
        bytes[8..].copy_from_slice(&camera.view_key().to_le_bytes());
        scene_gen_core::rng::fnv1a64(&bytes)
    }

    /// Renders `camera`'s view; rows run in parallel on the current rayon pool, and the result
    /// does not depend on how many threads it has.
    ///
    /// # Errors
    /// [`RenderError::BadCamera`] for a camera that fails [`Camera::validate`].
    pub fn render(&self, camera: &Camera) -> Result<Frame, RenderError> {
        camera.validate()?;
        let mut frame = Frame::blank(camera.width_px, camera.height_px);
        self.render_into(camera, &mut frame)?;
        Ok(frame)
    }

    /// [`Renderer::render`] into `frame`, whose buffers are resized to the view and then
    /// overwritten pixel by pixel: the same frame, without a fresh allocation per view. A
    /// caller rendering many views of one size (the evaluator) keeps its frames: at 1936 x
    /// 1216 a frame is 110 MB, and fresh pages cost the kernel a page fault and a zeroing
    /// each.
    ///
    /// # Errors
    /// [`RenderError::BadCamera`] for a camera that fails [`Camera::validate`]; `frame` is
    /// then left as it was.
    pub fn render_into(&self, camera: &Camera, frame: &mut Frame) -> Result<(), RenderError> {
        camera.validate()?;
        frame.reshape(camera.width_px, camera.height_px);
        if self.settings.samples_per_axis > 1 {
            self.render_tiled(camera, Job::Samples, frame);
            return Ok(());
        }
        match self.settings.shading {
            ShadingRate::Decoupled { stride, min_width_px } if stride >= 2 && camera.width_px >= min_width_px => {
                self.render_decoupled(camera, stride, frame);
            }
            ShadingRate::Adaptive { stride, min_width_px } if stride >= 2 && camera.width_px >= min_width_px => {
                self.render_adaptive(camera, stride, frame);
            }
            _ => self.render_tiled(camera, Job::Shade(None), frame),
        }
        Ok(())
    }

    /// A frame of one centre ray per pixel, traced in tiles (see [`tile`]), into `frame` (of the
    /// camera's size, every pixel overwritten).
    fn render_tiled(&self, camera: &Camera, job: Job<'_>, frame: &mut Frame) {
        let (w, h) = (camera.width_px, camera.height_px);
        self.trace_grid(camera, (w, h), Cells::Pixels, job, frame.bands());
    }

    /// [`ShadingRate::Decoupled`]: the anchors first (shaded in full, in tiles of anchors), then
    /// every other pixel from its own camera ray and the anchors' irradiance.
    fn render_decoupled(&self, camera: &Camera, stride: u32, frame: &mut Frame) {
        let (w, h) = (camera.width_px, camera.height_px);
        let mut grid = AnchorGrid::layout(stride, w, h);
        let at = Cells::Anchors { stride, width: w, height: h };
        let anchors = self.trace_anchors(camera, (grid.cols, grid.rows), at);
        (grid.pixels, grid.guides) = anchors.into_iter().map(|(pixel, guide)| (Some(pixel), guide)).unzip();
        visibility_filter::pool(&mut grid, self.settings.visibility_filter_radius, camera.position);
        self.shade_from_anchors(camera, &grid, frame);
    }

    /// Every pixel of `camera`'s frame from its own camera ray, the finished anchors of `grid`
    /// copied, the irradiance of the others from `grid`'s guides ([`ShadingRate::Decoupled`]),
    /// into `frame` (of the camera's size, every pixel overwritten).
    fn shade_from_anchors(&self, camera: &Camera, grid: &AnchorGrid, frame: &mut Frame) {
        let (w, h) = (camera.width_px, camera.height_px);
        self.trace_grid(camera, (w, h), Cells::Pixels, Job::Shade(Some(grid)), frame.bands());
    }

    /// Depth, instance and class ids and normals of `camera`'s view, exactly as [`Renderer::render`]
    /// gives them, without shading (the radiance buffers are black): one ray per pixel, for
    /// callers that need only what is visible, e.g. threshold visibility in the evaluator.
    ///
    /// # Errors
    /// [`RenderError::BadCamera`] for a camera that fails [`Camera::validate`].
    pub fn render_labels(&self, camera: &Camera) -> Result<Frame, RenderError> {
        camera.validate()?;
        let mut frame = Frame::blank(camera.width_px, camera.height_px);
        self.render_tiled(camera, Job::Labels, &mut frame);
        Ok(frame)
    }

    /// The instance and class ids of `camera`'s view, exactly as [`Renderer::render`] gives
    /// them: one ray per pixel, no surface interpolated, no other buffer filled (14 MB of
    /// buffers at 1936x1216 where a [`Frame`] has 110 MB).
    ///
    /// # Errors
    /// [`RenderError::BadCamera`] for a camera that fails [`Camera::validate`].
    pub fn render_ids(&self, camera: &Camera) -> Result<IdFrame, RenderError> {
        self.render_ids_in(camera, camera.full_rect())
    }

    /// [`Renderer::render_ids`] over the pixels of `rect` only (the same rays through the same
    /// pixel centres, so the same ids); e.g. over [`Camera::box_pixels`] of an object, to count
    /// its visible pixels.
    ///
    /// # Errors
    /// [`RenderError::BadCamera`] for a camera that fails [`Camera::validate`],
    /// [`RenderError::BadWindow`] for a `rect` that is not inside the frame.
    pub fn render_ids_in(&self, camera: &Camera, rect: PixelRect) -> Result<IdFrame, RenderError> {
        camera.validate()?;
        let inside = |start: u32, len: u32, side: u32| start.checked_add(len).is_some_and(|end| end <= side);
        if !inside(rect.x0, rect.width, camera.width_px) || !inside(rect.y0, rect.height, camera.height_px) {
            return Err(RenderError::BadWindow { rect, width: camera.width_px, height: camera.height_px });
        }
        let mut frame = IdFrame::blank(rect);
        let at = Cells::Window { x0: rect.x0, y0: rect.y0 };
        self.trace_grid(camera, (rect.width, rect.height), at, Job::Ids, frame.bands());
        Ok(frame)
    }

    /// The ids of a centre ray's hit, without its surface: what [`Renderer::labels`] gives
    /// them.
    #[inline(always)]
    fn ids(&self, hit: Option<Hit>) -> PixelOut {
        match hit {
            Some(h) => {
                let label = self.accel.label(self.accel.triangle_node(h.triangle));
                PixelOut { instance_id: label.instance_id, class_id: label.class_id, ..PixelOut::default() }
            }
            None => PixelOut::default(),
        }
    }

    /// The labels (depth along the optical axis, ids, normal) of a centre ray's hit; black
    /// radiance.
    #[inline(always)]
    fn labels(&self, dir: Vec3, basis: (Vec3, Vec3, Vec3), hit: Option<&(f32, SurfacePoint)>) -> PixelOut {
        let mut out = PixelOut { depth_m: f32::INFINITY, ..PixelOut::default() };
        if let Some((t, surface)) = hit {
            let label = self.accel.label(surface.node);
            out.depth_m = t * dir.dot(basis.0);
            out.instance_id = label.instance_id;
            out.class_id = label.class_id;
            out.normal = surface.shading_normal;
        }
        out
    }

    /// Illuminance (lux, luminance-weighted over the RGB channels) from one group on a surface
    /// at `point` facing `normal`: direct light plus the indirect light, from the irradiance
    /// volume where there is one, else from [`RenderSettings::probe_indirect_rays`] bounce
    /// rays; rect lights with the probe sample counts. The point is treated as a free-floating
    /// receiver (nothing under it).
    #[must_use]
    pub fn illuminance_lux(&self, point: Vec3, normal: Vec3, group: LightGroup) -> f32 {
        let normal = normal.normalize_or(Vec3::Z);
        let key = [point.x, point.y, point.z, normal.x, normal.y, normal.z]
            .iter()
            .fold(0u64, |h, v| h.rotate_left(13) ^ scene_gen_core::rng::fnv1a64(&v.to_bits().to_le_bytes()));
        let mut sampler = Sampler::new(self.settings.seed, "render/probe", key);
        let blockers = Blockers::default();
        let tracer = self.tracer(&blockers, self.settings.seed);
        let rect_samples = self.settings.probe_rect_samples_per_axis.pow(2);
        let direct = self.lights.direct(
            &self.accel,
            point,
            normal,
            normal,
            rect_samples,
            Strata { first: 0, stride: 1, total: rect_samples, rotation: sampler.uniform() },
            self.settings.light_cull,
            &mut sampler,
            &blockers,
        );
        let rays = if self.volume.is_some() { 0 } else { self.settings.probe_indirect_rays };
        let strata = Strata { first: 0, stride: 1, total: rays, rotation: sampler.uniform() };
        let indirect = tracer.indirect_irradiance(point, normal, normal, rays, strata, &mut sampler);
        let g = group_index(group);
        let e = luminance(direct[g] + indirect[g]);
        if e.is_finite() { e.max(0.0) } else { 0.0 }
    }
}

/// Guards the contract "no NaN anywhere": a non-finite sample would poison the frame.
#[inline(always)]
fn finite_radiance(l: GroupRgb) -> GroupRgb {
    // Element by element, not `array::map`: its `try_map` stayed out of line, compiled for the
    // baseline CPU, and was 3 % of a 4-spp image (perf).
    let finite = |c: Vec3| if c.is_finite() { c.max(Vec3::ZERO) } else { Vec3::ZERO };
    [finite(l[0]), finite(l[1])]
}

/// Spacing of the illuminance probe grid in each room (metres).
pub const PROBE_SPACING_M: f32 = 0.5;

/// The illuminance probe points for `group` at `height_m`: over the rooms that group lights
/// (rooms with a light of the group; all rooms if none names a room), the centres of a
/// [`PROBE_SPACING_M`] grid over each room's interior, less the points inside an object's
/// bounding box. In room order, then row by row.
#[must_use]
pub fn probe_points(scene: &Scene, group: LightGroup, height_m: f32) -> Vec<Vec3> {
    let lit: Vec<_> =
        scene.rooms.iter().filter(|r| scene.lights.iter().any(|l| l.group == group && l.room == Some(r.id))).collect();
    let rooms = if lit.is_empty() { scene.rooms.iter().collect() } else { lit };
    let mut points = Vec::new();
    for room in rooms {
        let (lo, hi) = room.interior(scene.wall_thickness_m);
        let size = hi - lo;
        if !(size.x > 0.0 && size.y > 0.0) {
            continue;
        }
        // Cells of at least the spacing (less a rounding margin, so 4.0 m gives 8 cells even
        // when it is 3.9999995 in f32).
        let nx = (size.x / PROBE_SPACING_M + 1e-3).floor().max(1.0) as u32;
        let ny = (size.y / PROBE_SPACING_M + 1e-3).floor().max(1.0) as u32;
        for j in 0..ny {
            for i in 0..nx {
                let xy = lo + size * Vec2::new((i as f32 + 0.5) / nx as f32, (j as f32 + 0.5) / ny as f32);
                let p = xy.extend(height_m);
                if !scene.objects.iter().any(|o| p.cmpge(o.min).all() && p.cmple(o.max).all()) {
                    points.push(p);
                }
            }
        }
    }
    points
}

/// Mean illuminance (lux) from `group` on upward-facing probes at [`probe_points`], each
/// measured with [`Renderer::illuminance_lux`]. The TaCOS scenarios are 20 lux by day and
/// 2 lux by night on the 0.75 m plane (`scene_gen_scene::lights::{DAY_TARGET_LUX, NIGHT_TARGET_LUX,
/// TARGET_PLANE_M}`).
///
/// # Errors
/// [`RenderError::NoProbePoints`] when no room has a free probe point.
pub fn measure_mean_illuminance(renderer: &Renderer<'_>, group: LightGroup, height_m: f32) -> Result<f32, RenderError> {
    let points = probe_points(renderer.scene, group, height_m);
    if points.is_empty() {
        return Err(RenderError::NoProbePoints);
    }
    // Summed in a fixed order (collect, then fold) so the mean does not depend on threads.
    let values: Vec<f32> = points.par_iter().map(|p| renderer.illuminance_lux(*p, Vec3::Z, group)).collect();
    let sum: f64 = values.iter().map(|&v| f64::from(v)).sum();
    Ok((sum / points.len() as f64) as f32)
}

/// Multipliers that bring each light group to a target mean illuminance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightScale {
    pub day: f32,
    pub night: f32,
}

impl Default for LightScale {
    fn default() -> Self {
        LightScale { day: 1.0, night: 1.0 }
    }
}

impl LightScale {
    /// Measures both groups with [`measure_mean_illuminance`] at `height_m` and returns the
    /// factors that make them `day_lux` and `night_lux` (radiance is linear in the lights).
    ///
    /// # Errors
    /// [`RenderError::NoProbePoints`], or [`RenderError::Unlit`] when a group measures zero.
    pub fn to_targets(
        renderer: &Renderer<'_>,
        day_lux: f32,
        night_lux: f32,
        height_m: f32,
    ) -> Result<LightScale, RenderError> {
        let factor = |group: LightGroup, target: f32| -> Result<f32, RenderError> {
            let measured = measure_mean_illuminance(renderer, group, height_m)?;
            if measured > 0.0 { Ok(target / measured) } else { Err(RenderError::Unlit { group, height_m }) }
        };
        Ok(LightScale { day: factor(LightGroup::Day, day_lux)?, night: factor(LightGroup::Night, night_lux)? })
    }

    /// The factor of one group.
    #[must_use]
    pub fn factor(&self, group: LightGroup) -> f32 {
        match group {
            LightGroup::Day => self.day,
            LightGroup::Night => self.night,
        }
    }

    /// The scaled radiance of `group` only (the other group off).
    #[must_use]
    pub fn apply(&self, frame: &Frame, group: LightGroup) -> Vec<[f32; 3]> {
        match group {
            LightGroup::Day => frame.mix(self.day, 0.0),
            LightGroup::Night => frame.mix(0.0, self.night),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Sampler;

    /// `fill_uniform` gives the numbers `uniform` gives one by one, from a fresh stream and
    /// after draws that left the stream's buffer part-used, across its block boundaries.
    #[test]
    fn filled_numbers_are_the_ones_drawn_one_by_one() {
        for (skip, len) in [(0, 1), (0, 128), (3, 61), (15, 200), (17, 64)] {
            let (mut one, mut filled) = (Sampler::new(7, "t", 11), Sampler::new(7, "t", 11));
            for _ in 0..skip {
                assert_eq!(one.uniform().to_bits(), filled.uniform().to_bits());
            }
            let mut out = vec![0.0f32; len];
            filled.fill_uniform(&mut out);
            for (i, x) in out.iter().enumerate() {
                assert_eq!(x.to_bits(), one.uniform().to_bits(), "skip {skip}, number {i}");
            }
            assert_eq!(one.uniform().to_bits(), filled.uniform().to_bits(), "the next draw after {len}");
        }
    }
}
