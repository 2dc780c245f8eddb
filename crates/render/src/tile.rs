//! Every frame is traced in 8 x 8 pixel tiles.
//!
//! A tile's camera rays go through the BVH as one [`RayPacket`] (coherent rays from one origin:
//! about twice the speed of one ray at a time, docs/BENCHMARKS.md): the centre rays, then, with
//! `n x n` samples per pixel, one packet per sample. Each pixel is shaded as it would be alone,
//! from its own random stream in its own order, so a tiled frame is bit for bit the frame a
//! pixel-by-pixel trace gives, at any thread count. With several samples per pixel, a sample's
//! hits are lit by the point and directional lights together, their shadow rays to each light
//! traced as a packet ([`super::hit_batch`]); the sums then differ from shading each pixel
//! alone only in their order. Other shadow rays
//! (rect-light samples, bounces, anchors) stay one at a time: traced as packets per light and
//! tile they were slower on real frames (small, spread packets; docs/BENCHMARKS.md).
//!
//! Each band of tiles runs in one of two builds of the same source ([`scene_gen_core::simd`]): an AVX2 +
//! FMA clone where the CPU has both, else the baseline; the frame is the same bit for bit
//! (`SCENE_GEN_NO_SIMD=1` forces the baseline). The call tree under [`Renderer::trace_band`] is
//! `#[inline(always)]` down to the triangle test, since a function left out of line is compiled
//! once, for the baseline, and closures called from both builds are avoided for the same reason.

use glam::Vec3;
use rayon::prelude::*;

use super::hit_batch::HitBatch;
use super::lights::{Blockers, PointLights, RectShare};
use super::responses::Responses;
use super::shade::{Primary, SurfaceHit, Tracer};
use super::{
    AnchorGrid, Camera, Frame, GroupRgb, Guide, IdFrame, PIXEL_STREAM, PixelOut, PixelRect, Renderer, Sampler,
    ShadingRate, Strata, TILE_STREAM, finite_radiance,
};
use crate::accel::{Hit, Surfaces};
use scene_gen_core::simd::Dispatch;
use scene_gen_trace::lanes::{Lanes3, bits, lane3};
use scene_gen_trace::packet::{PACKET_RAYS, RayPacket};

/// Period, in anchors along each axis, of the interleaved rect-light samples of anchors
/// ([`Renderer::rect_plan`]): every 3 x 3 block of anchors holds the whole lattice, and so does
/// a radius-1 pool of a decoupled grid and a radius-2 pool of the coarse anchors of an adaptive
/// one (fine indices `i - 2`, `i`, `i + 2` differ modulo 3).
const INTERLEAVE_PERIOD: u32 = 3;

/// Side of a tile, pixels: one tile's rays fill one packet.
pub(super) const TILE: u32 = 8;
const _: () = assert!((TILE * TILE) as usize == PACKET_RAYS);

/// `v` in every lane.
#[inline(always)]
fn splat(v: Vec3) -> Lanes3 {
    [[v.x; PACKET_RAYS], [v.y; PACKET_RAYS], [v.z; PACKET_RAYS]]
}

/// The lanes `0..count`.
#[inline(always)]
fn first_lanes(count: usize) -> u64 {
    if count >= 64 { u64::MAX } else { (1u64 << count) - 1 }
}

/// A packet's hits in structure of arrays and a sampled tile's per-pixel state, kept from tile
/// to tile: the buffers of a band are zeroed and allocated once, not per tile (zeroing them per
/// tile was several per cent of an image's instructions; allocating the two vectors and two
/// more per tile, 1.5 % of a 4-spp image in `malloc` and `free`).
#[derive(Default)]
pub(super) struct Scratch {
    surfaces: Surfaces,
    responses: Responses,
    batch: HitBatch,
    /// A sampled tile's labels from its centre rays, then its pixels.
    labels: Vec<PixelOut>,
    /// A sampled tile's per-pixel streams (seeded on their first draw).
    samplers: Vec<Sampler>,
}

/// What a tile computes at each of its pixels.
#[derive(Clone, Copy)]
pub(super) enum Job<'g> {
    /// Instance and class ids only: no surface is interpolated (see [`IdBand`]).
    Ids,
    /// Depth, ids and normal only (black radiance).
    Labels,
    /// The full pixel from its centre ray (one camera ray per pixel); with a grid, the
    /// irradiance comes from its anchors where they allow.
    Shade(Option<&'g AnchorGrid>),
    /// An anchor of decoupled shading: [`Job::Shade`] without a grid, its rect-light samples
    /// interleaved with its neighbours' where the visibility filter pools them
    /// ([`Renderer::rect_plan`]).
    Anchor,
    /// Labels from the centre ray, radiance averaged over `n x n` stratified jittered camera
    /// rays (`samples_per_axis` n > 1).
    Samples,
}

/// The part of the tile loop a job runs, as a const parameter of [`Renderer::trace_tile`]: each
/// build compiles one function per part, so LLVM optimises three functions of a third of the
/// size, in separate units, instead of one that inlines every job (which had the render crate
/// compile on one core for most of its build).
const LABELS: u8 = 0;
/// One shaded ray per pixel ([`Job::Shade`], [`Job::Anchor`]).
const SHADE: u8 = 1;
/// Several samples per pixel ([`Job::Samples`]).
const SAMPLES: u8 = 2;

impl Job<'_> {
    /// The part of the tile loop that runs this job.
    #[inline(always)]
    fn kind(self) -> u8 {
        match self {
            Job::Ids | Job::Labels => LABELS,
            Job::Shade(_) | Job::Anchor => SHADE,
            Job::Samples => SAMPLES,
        }
    }
}

/// One build of the tile loop (the baseline, or the AVX2 clone): its tile function for each
/// kind of job, compiled for that build's CPU features.
pub(super) trait Build {
    /// [`Renderer::trace_tile`] of `job`'s kind.
    #[allow(clippy::too_many_arguments)]
    fn tile(
        r: &Renderer<'_>,
        camera: &Camera,
        cells: &[(usize, (u32, u32))],
        job: Job<'_>,
        packet: &mut RayPacket,
        scratch: &mut Scratch,
        sink: &mut BandSink<'_>,
    );
}

/// Which pixel each cell of a traced grid is: a plain `enum` with an `#[inline(always)]` method,
/// not a closure, because a closure called from both builds of the tile loop is compiled once,
/// out of line, for the baseline. With the `dyn` sink and the per-tile `Vec` it replaced, that
/// cost a third of a label frame (0.37 -> 0.25 s at 1936x1216, docs/BENCHMARKS.md).
#[derive(Clone, Copy)]
pub(super) enum Cells<'a> {
    /// Cell `(x, y)` is pixel `(x, y)`.
    Pixels,
    /// Cell `(x, y)` is pixel `(x0 + x, y0 + y)`: a window of the frame.
    Window { x0: u32, y0: u32 },
    /// Cell `(i, j)` is the anchor at pixel `(i stride, j stride)`, clamped to the last pixel of
    /// a `width x height` frame ([`AnchorGrid`]'s layout).
    Anchors { stride: u32, width: u32, height: u32 },
    /// Cell `(x, y)` of a grid `TILE` cells wide is pixel `pixels[y TILE + x]` (the last one
    /// past the end): a list of scattered pixels, traced 64 to a tile.
    Listed { pixels: &'a [(u32, u32)] },
}

impl Cells<'_> {
    /// The pixel of cell `(cx, cy)`.
    #[inline(always)]
    pub(super) fn pixel(self, cx: u32, cy: u32) -> (u32, u32) {
        match self {
            Cells::Pixels => (cx, cy),
            Cells::Window { x0, y0 } => (x0 + cx, y0 + cy),
            Cells::Anchors { stride, width, height } => ((cx * stride).min(width - 1), (cy * stride).min(height - 1)),
            Cells::Listed { pixels } => pixels[((cy * TILE + cx) as usize).min(pixels.len() - 1)],
        }
    }
}

/// Where the finished pixels of one band of tiles go: `slot` counts row-major from the band's
/// first cell.
///
/// An `enum`, not a trait the tile loop is generic over: the loop is inlined down to the
/// triangle test and compiled once per build (baseline and AVX2), and one instance per sink
/// type tripled the render crate's compile time. The sink of a band never changes, so the
/// match in [`BandSink::put`] is a branch the CPU always predicts.
pub(super) enum BandSink<'f> {
    /// Cells with their guides (the anchors of decoupled shading).
    Cells(&'f mut [(PixelOut, Option<Guide>)]),
    Frame(FrameBand<'f>),
    Ids(IdBand<'f>),
}

impl BandSink<'_> {
    #[inline(always)]
    fn put(&mut self, slot: usize, pixel: PixelOut, guide: Option<Guide>) {
        match self {
            BandSink::Cells(cells) => cells[slot] = (pixel, guide),
            BandSink::Frame(band) => band.put(slot, pixel),
            BandSink::Ids(band) => band.put(slot, pixel),
        }
    }
}

/// One band of a [`Frame`]'s buffers: pixels go straight into the frame, with no per-pixel
/// buffer to allocate and copy (at 1936x1216 that was about 110 MB of fresh pages per frame).
pub(super) struct FrameBand<'f> {
    day_nit: &'f mut [[f32; 3]],
    night_nit: &'f mut [[f32; 3]],
    depth_m: &'f mut [f32],
    instance_id: &'f mut [u32],
    class_id: &'f mut [u16],
    normal: &'f mut [[f32; 3]],
}

impl FrameBand<'_> {
    #[inline(always)]
    fn put(&mut self, slot: usize, p: PixelOut) {
        self.day_nit[slot] = p.radiance[0].to_array();
        self.night_nit[slot] = p.radiance[1].to_array();
        self.depth_m[slot] = p.depth_m;
        self.instance_id[slot] = p.instance_id;
        self.class_id[slot] = p.class_id;
        self.normal[slot] = p.normal.to_array();
    }
}

/// One band of an [`IdFrame`]: only the two id buffers are written (a [`Frame`] at 1936x1216
/// is about 110 MB of buffers to fill; its ids are 14 MB).
pub(super) struct IdBand<'f> {
    instance_id: &'f mut [u32],
    class_id: &'f mut [u16],
}

impl IdBand<'_> {
    #[inline(always)]
    fn put(&mut self, slot: usize, p: PixelOut) {
        self.instance_id[slot] = p.instance_id;
        self.class_id[slot] = p.class_id;
    }
}

impl IdFrame {
    /// Zeroed ids over `rect`, for [`Renderer::trace_grid`] to fill.
    pub(super) fn blank(rect: PixelRect) -> IdFrame {
        IdFrame { rect, instance_id: vec![0; rect.area()], class_id: vec![0; rect.area()] }
    }

    /// The frame's ids in bands of `TILE` rows.
    pub(super) fn bands(&mut self) -> Vec<BandSink<'_>> {
        let len = self.rect.width as usize * TILE as usize;
        if len == 0 {
            return Vec::new();
        }
        self.instance_id
            .chunks_mut(len)
            .zip(self.class_id.chunks_mut(len))
            .map(|(instance_id, class_id)| BandSink::Ids(IdBand { instance_id, class_id }))
            .collect()
    }
}

impl Frame {
    /// A `w x h` frame of zeroed buffers, for [`Renderer::trace_grid`] to fill.
    pub(super) fn blank(w: u32, h: u32) -> Frame {
        let n = w as usize * h as usize;
        Frame {
            width: w,
            height: h,
            day_nit: vec![[0.0; 3]; n],
            night_nit: vec![[0.0; 3]; n],
            depth_m: vec![0.0; n],
            instance_id: vec![0; n],
            class_id: vec![0; n],
            normal: vec![[0.0; 3]; n],
        }
    }

    /// Resizes every buffer to `w x h` pixels (new pixels zeroed; a frame of that size already
    /// keeps its buffers and their contents).
    pub(super) fn reshape(&mut self, w: u32, h: u32) {
        let n = w as usize * h as usize;
        (self.width, self.height) = (w, h);
        self.day_nit.resize(n, [0.0; 3]);
        self.night_nit.resize(n, [0.0; 3]);
        self.depth_m.resize(n, 0.0);
        self.instance_id.resize(n, 0);
        self.class_id.resize(n, 0);
        self.normal.resize(n, [0.0; 3]);
    }

    /// The frame's buffers in bands of `TILE` rows.
    pub(super) fn bands(&mut self) -> Vec<BandSink<'_>> {
        let len = self.width as usize * TILE as usize;
        if len == 0 {
            return Vec::new();
        }
        let mut day = self.day_nit.chunks_mut(len);
        let mut night = self.night_nit.chunks_mut(len);
        let mut depth = self.depth_m.chunks_mut(len);
        let mut instance = self.instance_id.chunks_mut(len);
        let mut class = self.class_id.chunks_mut(len);
        let mut normal = self.normal.chunks_mut(len);
        std::iter::from_fn(|| {
            Some(BandSink::Frame(FrameBand {
                day_nit: day.next()?,
                night_nit: night.next()?,
                depth_m: depth.next()?,
                instance_id: instance.next()?,
                class_id: class.next()?,
                normal: normal.next()?,
            }))
        })
        .collect()
    }
}

impl Renderer<'_> {
    /// Runs `job` at the pixels of a `cols x rows` grid (cell `(cx, cy)` is pixel `at.pixel(cx, cy)`),
    /// tile by tile, one band of `TILE` rows of cells per sink in `bands`, bands in parallel.
    /// The grid is the whole frame, a window of it, or the anchors of decoupled shading.
    ///
    /// Each band runs in the build of the tile loop that the renderer's [`Dispatch`] picks
    /// ([`scene_gen_core::simd`]): the AVX2 clone where the CPU has it, the same frame either way.
    pub(super) fn trace_grid(
        &self,
        camera: &Camera,
        grid: (u32, u32),
        at: Cells<'_>,
        job: Job<'_>,
        bands: Vec<BandSink<'_>>,
    ) {
        let dispatch = self.dispatch.supported();
        bands.into_par_iter().enumerate().for_each(|(band, sink)| match dispatch {
            // SAFETY: `supported()` gives `Avx2Fma` only when this CPU has AVX2 and FMA.
            #[cfg(target_arch = "x86_64")]
            Dispatch::Avx2Fma => unsafe { self.trace_band_avx2(camera, grid, at, job, band, sink) },
            _ => self.trace_band_baseline(camera, grid, at, job, band, sink),
        });
    }

    /// The renderer with its tile loop in the build `dispatch` (downgraded to
    /// [`Dispatch::Generic`] where the CPU lacks it): for tests that compare the two builds
    /// without touching the process environment.
    #[cfg(test)]
    #[must_use]
    pub(crate) fn with_dispatch(mut self, dispatch: Dispatch) -> Self {
        self.dispatch = dispatch;
        self
    }

    /// Band `band` of [`Renderer::trace_grid`]: its tiles left to right. Always inlined, so that
    /// each caller (`trace_band_baseline` and `trace_band_avx2`, the two builds) compiles its own
    /// copy for its own CPU features.
    #[inline(always)]
    pub(super) fn trace_band<B: Build>(
        &self,
        camera: &Camera,
        (cols, rows): (u32, u32),
        at: Cells<'_>,
        job: Job<'_>,
        band: usize,
        mut sink: BandSink<'_>,
    ) {
        let mut packet = RayPacket::new();
        let mut scratch = Scratch::default();
        let band_rows = (rows - band as u32 * TILE).min(TILE);
        let mut tile = [(0usize, (0u32, 0u32)); PACKET_RAYS];
        for tx in 0..cols.div_ceil(TILE) {
            let x_end = (tx * TILE + TILE).min(cols);
            let mut len = 0;
            for dy in 0..band_rows {
                let cy = band as u32 * TILE + dy;
                for cx in tx * TILE..x_end {
                    let slot = dy as usize * cols as usize + cx as usize;
                    let (x, y) = at.pixel(cx, cy);
                    // The anchors of a decoupled frame are finished already.
                    if let Job::Shade(Some(grid)) = job
                        && let Some(a) = grid.index(x, y)
                        && let Some(pixel) = grid.pixels[a]
                    {
                        sink.put(slot, pixel, None);
                        continue;
                    }
                    tile[len] = (slot, (x, y));
                    len += 1;
                }
            }
            B::tile(self, camera, &tile[..len], job, &mut packet, &mut scratch, &mut sink);
        }
    }

    /// One tile: `cells` are (slot, pixel); each finished pixel goes to `sink.put(slot, ..)`.
    /// `KIND` is `job`'s kind ([`Job::kind`]): the code of the other kinds folds away.
    #[inline(always)]
    fn trace_tile<const KIND: u8>(
        &self,
        camera: &Camera,
        cells: &[(usize, (u32, u32))],
        job: Job<'_>,
        packet: &mut RayPacket,
        scratch: &mut Scratch,
        sink: &mut BandSink<'_>,
    ) {
        let basis = camera.basis();
        let origin = camera.position;
        // Plain loops into fixed arrays rather than `collect`: the collecting `fold` was left
        // out of line, and so ran baseline code in the AVX2 clone too (perf).
        let (mut px, mut py) = ([0.0f32; PACKET_RAYS], [0.0f32; PACKET_RAYS]);
        for (c, &(_, (x, y))) in cells.iter().enumerate() {
            (px[c], py[c]) = (x as f32 + 0.5, y as f32 + 0.5);
        }
        let dirs = camera.ray_directions_in(basis, &px, &py);
        packet.set_lanes(&splat(origin), &dirs, &[f32::INFINITY; PACKET_RAYS], first_lanes(cells.len()));
        let mut hits: [Option<Hit>; PACKET_RAYS] = [None; PACKET_RAYS];
        self.accel.closest_hits(packet, &mut hits);
        if let Job::Ids = job {
            for (&(slot, _), hit) in cells.iter().zip(hits) {
                sink.put(slot, self.ids(hit), None);
            }
            return;
        }
        let blockers = Blockers::new();
        let tracer = self.tracer(&blockers, self.pixel_seed(camera));
        let mut emitters = Vec::new();
        if KIND != LABELS {
            self.lights.emitters_in_reach(packet, &mut emitters);
        }
        let labels = &mut scratch.labels;
        labels.clear();
        let surfaces = &mut scratch.surfaces;
        self.accel.surfaces(&hits, cells.len(), origin, &dirs, surfaces);
        for (k, &(slot, (x, y))) in cells.iter().enumerate() {
            let dir = lane3(&dirs, k);
            // A `match`, not `Option::map`: see `shade_centre`.
            #[allow(clippy::manual_map)]
            let hit = match hits[k] {
                Some(h) => Some((h.t, surfaces.point(k))),
                None => None,
            };
            let pixel_labels = self.labels(dir, basis, hit.as_ref());
            match KIND {
                // `Ids` returned above, before any surface was interpolated.
                LABELS => sink.put(slot, pixel_labels, None),
                SHADE => {
                    let (pixel, guide) =
                        self.shade_centre(&tracer, camera, (x, y), dir, hit, &emitters, pixel_labels, job);
                    sink.put(slot, pixel, guide);
                }
                _ => labels.push(pixel_labels),
            }
        }
        if KIND == SAMPLES {
            self.sample_tile(&tracer, camera, cells, packet, scratch);
            for (&(slot, _), &pixel) in cells.iter().zip(&scratch.labels) {
                sink.put(slot, pixel, None);
            }
        }
    }

    /// [`Job::Samples`] over a tile whose centre rays gave `scratch.labels`, which it finishes
    /// in place: sample `(i, j)` of every pixel is traced in one packet. The tile's stream gives
    /// every pixel its strata rotations, then per sample pass each pixel's jitter, in cell
    /// order; a pixel's shading draws from its own stream in the order it would alone, so
    /// interleaving the pixels changes nothing there.
    ///
    /// A pass lights its hits in three steps: what each ray sees, then the point and
    /// directional lights of all the hits together ([`super::hit_batch`]; their roulette
    /// draws come first in a pixel's stream, as they do alone), then, hit by hit, whatever
    /// else a hit needs (rect lights, bounces, mirrors).
    #[inline(always)]
    fn sample_tile(
        &self,
        tracer: &Tracer<'_>,
        camera: &Camera,
        cells: &[(usize, (u32, u32))],
        packet: &mut RayPacket,
        scratch: &mut Scratch,
    ) {
        let (basis, origin) = (camera.basis(), camera.position);
        let n = self.settings.samples_per_axis.max(1);
        let bounce_total = n * n * self.settings.indirect_rays;
        let rect_total = n * n * self.settings.rect_samples_per_axis.pow(2);
        let pixel_key = |(x, y): (u32, u32)| u64::from(y) * u64::from(camera.width_px) + u64::from(x);
        // The sub-pixel jitter and the strata rotations of the whole tile come from one stream,
        // keyed by the tile's first pixel; each pixel's own stream is seeded only if its shading
        // draws (rect-light samples, bounces). Seeding a ChaCha stream and filling its first
        // block per pixel, for the ten numbers a pixel of a 4-spp point-lit image draws, was 15 % of
        // such an image (perf).
        let mut jitter =
            Sampler::of_hashed(tracer.pixel_seed, TILE_STREAM, cells.first().map_or(0, |c| pixel_key(c.1)));
        let Scratch { surfaces, responses, batch, labels, samplers } = scratch;
        samplers.clear();
        let mut rotations = [(0.0f32, 0.0f32); PACKET_RAYS];
        for (&(_, pixel), rotation) in cells.iter().zip(&mut rotations) {
            samplers.push(Sampler::of_hashed(tracer.pixel_seed, PIXEL_STREAM, pixel_key(pixel)));
            *rotation = (jitter.uniform(), jitter.uniform());
        }
        let mut sums = [[Vec3::ZERO; 2]; PACKET_RAYS];
        let sums = &mut sums[..cells.len()];
        let mut hits: [Option<Hit>; PACKET_RAYS] = [None; PACKET_RAYS];
        let mut emitters = Vec::new();
        let batched = Tracer { point_lights: PointLights::Batched, ..*tracer };
        let tracer = if self.batch_lights { &batched } else { tracer };
        let origins = splat(origin);
        let mut draws = [0.0f32; 2 * PACKET_RAYS];
        // Whether any hit can need more than the point and directional lights.
        let may_need_more = self.settings.indirect_rays > 0
            || self.volume.is_some()
            || self.settings.specular
            || !self.lights.rects.is_empty();
        for j in 0..n {
            for i in 0..n {
                // Per cell, its jitter across then down, in cell order.
                let draws = &mut draws[..2 * cells.len()];
                jitter.fill_uniform(draws);
                let (mut px, mut py) = ([0.0f32; PACKET_RAYS], [0.0f32; PACKET_RAYS]);
                for (c, &(_, (x, y))) in cells.iter().enumerate() {
                    let sx = (i as f32 + draws[2 * c]) / n as f32;
                    let sy = (j as f32 + draws[2 * c + 1]) / n as f32;
                    (px[c], py[c]) = (x as f32 + sx, y as f32 + sy);
                }
                let dirs = camera.ray_directions_in(basis, &px, &py);
                packet.set_lanes(&origins, &dirs, &[f32::INFINITY; PACKET_RAYS], first_lanes(cells.len()));
                self.accel.closest_hits(packet, &mut hits);
                self.lights.emitters_in_reach(packet, &mut emitters);
                // A pixel's bounce and rect-light strata at this sample (a function, not a
                // closure: see `Cells`).
                #[inline(always)]
                fn strata(first: u32, n: u32, totals: (u32, u32), (rotation, rect): (f32, f32)) -> (Strata, Strata) {
                    (
                        Strata { first, stride: n * n, total: totals.0, rotation },
                        Strata { first, stride: n * n, total: totals.1, rotation: rect },
                    )
                }
                let (first, totals) = (j * n + i, (bounce_total, rect_total));
                if !self.batch_lights {
                    for (k, sampler) in samplers.iter_mut().enumerate() {
                        let (bounce, rect) = strata(first, n, totals, rotations[k]);
                        let l = tracer.camera_ray(origin, lane3(&dirs, k), hits[k], &emitters, bounce, rect, sampler);
                        sums[k][0] += l[0];
                        sums[k][1] += l[1];
                    }
                    continue;
                }
                let count = cells.len();
                self.accel.surfaces(&hits, count, origin, &dirs, surfaces);
                self.materials.evaluate(surfaces, responses);
                // What each ray sees: a rect light's emitter in front of its hit, its hit, or
                // nothing (`Tracer::primary`, lane by lane).
                let mut lit = surfaces.lanes;
                if !emitters.is_empty() {
                    for (k, sum) in sums.iter_mut().enumerate() {
                        let tmax = if lit >> k & 1 == 1 { surfaces.t[k] } else { f32::INFINITY };
                        let dir = lane3(&dirs, k);
                        let seen = self.lights.emitter_seen_among(origin, dir, tmax, emitters.iter().copied());
                        if let Some((_, group, rgb)) = seen {
                            sum[group] += rgb;
                            lit &= !(1 << k);
                        }
                    }
                }
                batch.fill(surfaces, responses, lit, &self.lights.reach);
                let mut more_lanes = 0u64;
                let lanes_needing_more = if may_need_more { lit } else { 0 };
                for k in bits(lanes_needing_more) {
                    if tracer.hit_has_more_than_point_lights(&responses.get(k), batch.room(k)) {
                        more_lanes |= 1 << k;
                    }
                }
                let cull = self.settings.light_cull;
                let blockers = tracer.blockers;
                self.lights.light_batch(&self.accel, surfaces, batch, cull, samplers, blockers, packet, sums);
                for k in bits(more_lanes) {
                    let s = SurfaceHit { surface: surfaces.point(k), response: responses.get(k) };
                    let (bounce, rect) = strata(first, n, totals, rotations[k]);
                    let l = tracer.hit_radiance(lane3(&dirs, k), &s, bounce, rect, &mut samplers[k]);
                    sums[k][0] += l[0];
                    sums[k][1] += l[1];
                }
            }
        }
        let inv = 1.0 / (n * n) as f32;
        for (pixel, sum) in labels.iter_mut().zip(sums.iter()) {
            pixel.radiance = finite_radiance([sum[0] * inv, sum[1] * inv]);
        }
    }

    /// Shades pixel `(x, y)` whose centre ray along `dir` found `hit`: `labels` plus radiance,
    /// and the pixel's [`Guide`] where its surface is diffuse. With a grid (`job` is
    /// `Shade(Some(grid))`), the irradiance comes from the anchors where they lie on the same
    /// surface.
    ///
    /// The pixel's stream draws the strata rotations first, then the irradiance samples, then
    /// the specular ones; the rotations are drawn only when a later draw needs them (an
    /// interpolated pixel without a mirror draws nothing), which leaves every used number
    /// where it was.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn shade_centre(
        &self,
        tracer: &Tracer<'_>,
        camera: &Camera,
        (x, y): (u32, u32),
        dir: Vec3,
        hit: Option<(f32, super::accel::SurfacePoint)>,
        emitters: &[u32],
        labels: PixelOut,
        job: Job<'_>,
    ) -> (PixelOut, Option<Guide>) {
        let grid = match job {
            Job::Shade(grid) => grid,
            _ => None,
        };
        let t = hit.map_or(f32::INFINITY, |h| h.0);
        let s = match tracer.primary(camera.position, dir, hit, emitters) {
            Primary::Miss => return (labels, None),
            Primary::Emitter(l) => return (PixelOut { radiance: finite_radiance(l), ..labels }, None),
            Primary::Surface(s) => s,
        };
        let key = u64::from(y) * u64::from(camera.width_px) + u64::from(x);
        let mut sampler = Sampler::of_hashed(tracer.pixel_seed, PIXEL_STREAM, key);
        let mut strata = None;
        // `match`es, not `then` / `unwrap_or_else` closures: a closure called from both builds
        // of the tile loop was compiled once, out of line, with baseline code (perf showed a
        // quarter of the AVX2 clone's eval frame in it).
        let interpolated = match grid {
            Some(g) if s.response.diffuse != Vec3::ZERO => g.irradiance(x, y, &s.surface, labels.instance_id, t),
            _ => None,
        };
        let e = match interpolated {
            _ if s.response.diffuse == Vec3::ZERO => None,
            Some(e) => Some((e, RectShare::default())),
            None => {
                let (bounce, rect) = *strata.insert(self.pixel_strata(&mut sampler));
                let (rect_samples, rect) = self.rect_plan(tracer, (x, y), job, rect);
                // Only an anchor's light is pooled, so only an anchor needs its unshadowed part.
                let unshadowed = matches!(job, Job::Anchor) && self.settings.visibility_filter_radius > 0;
                Some(tracer.irradiance_split(&s.surface, bounce, rect_samples, rect, &mut sampler, unshadowed))
            }
        };
        if strata.is_none() && self.settings.specular && s.response.specular != Vec3::ZERO {
            self.pixel_strata(&mut sampler);
        }
        self.finish(tracer, labels, dir, &s, e, &mut sampler)
    }

    /// The pixel's bounce and rect-light strata, drawn first from its stream.
    #[inline(always)]
    pub(super) fn pixel_strata(&self, sampler: &mut Sampler) -> (Strata, Strata) {
        let rotation = sampler.uniform();
        let rect_rotation = sampler.uniform();
        let strata = Strata { first: 0, stride: 1, total: self.settings.indirect_rays, rotation };
        let rect_total = self.settings.rect_samples_per_axis.pow(2);
        (strata, Strata { first: 0, stride: 1, total: rect_total, rotation: rect_rotation })
    }

    /// How many rect-light samples pixel `(x, y)` takes and where (`own`: its strata of
    /// [`Renderer::pixel_strata`]).
    ///
    /// Without the visibility filter, `own` and the setting's count. With it, the anchors pool
    /// their samples with their neighbours' ([`super::visibility_filter`]), so an anchor takes
    /// its place in a lattice of [`INTERLEAVE_PERIOD`]^2 times as many points, shared with
    /// the anchors around it, whose indices modulo the period differ: any
    /// `INTERLEAVE_PERIOD x INTERLEAVE_PERIOD` block of anchors covers the whole lattice, a
    /// stratified estimate where independent points would leave clumps and gaps (interleaved
    /// sampling, Keller and Heidrich 2001). The lattice's rotation is one per view, drawn from
    /// the view's seed, so the pattern is new in every frame. A decoupled pixel that no anchor
    /// lends its irradiance (a silhouette, a crease) pools with nobody: it takes a lattice of
    /// its own, as many points as a block of one-sample anchors holds, at least the setting's
    /// count.
    #[inline(always)]
    fn rect_plan(&self, tracer: &Tracer<'_>, (x, y): (u32, u32), job: Job<'_>, own: Strata) -> (u32, Strata) {
        let per_point = self.settings.rect_samples_per_axis.pow(2);
        let stride = match self.settings.shading {
            ShadingRate::Decoupled { stride, .. } | ShadingRate::Adaptive { stride, .. } => stride.max(1),
            ShadingRate::Full => 1,
        };
        let slots = INTERLEAVE_PERIOD * INTERLEAVE_PERIOD;
        match job {
            _ if self.settings.visibility_filter_radius == 0 => (per_point, own),
            Job::Anchor => {
                let (i, j) = (x / stride, y / stride);
                // Lattice points are ordered along the first coordinate, in thirds: the third is a
                // Latin square of (i, j), so each row and each column of a block spans all
                // three, and a pool cut short by the frame's edge or a silhouette still does.
                let third = (i + j) % INTERLEAVE_PERIOD;
                let slot = INTERLEAVE_PERIOD * third + j % INTERLEAVE_PERIOD;
                // One rotation for the whole view: a rotation per block of anchors measured
                // twice the error on house frames, since most pools straddle two blocks.
                let rotation = tracer.view_rotation();
                (per_point, Strata { first: slot, stride: slots, total: slots * per_point, rotation })
            }
            Job::Shade(Some(_)) => {
                let count = slots.max(per_point);
                (count, Strata { total: count, ..own })
            }
            _ => (per_point, own),
        }
    }

    /// A shaded pixel from its irradiance `e` and the rect lights' part of it (`None` without a
    /// diffuse part), with its [`Guide`] where it has one.
    #[inline(always)]
    pub(super) fn finish(
        &self,
        tracer: &Tracer<'_>,
        mut out: PixelOut,
        dir: Vec3,
        s: &SurfaceHit,
        e: Option<(GroupRgb, RectShare)>,
        sampler: &mut Sampler,
    ) -> (PixelOut, Option<Guide>) {
        let guide = e.map(|(irradiance, rects)| Guide {
            position: s.surface.position,
            normal: s.surface.shading_normal,
            material: s.surface.material,
            instance_id: out.instance_id,
            irradiance,
            rects,
        });
        out.radiance = finite_radiance(tracer.surface_radiance(dir, s, e.map(|(e, _)| e), sampler));
        (out, guide)
    }
}

/// The baseline build of the tile loop: the band loop, and one function per kind of job, each
/// in a module of its own, as LLVM optimises a crate's modules as separate units in parallel.
mod baseline {
    use super::{BandSink, Build, Cells, Job, LABELS, SHADE, Scratch};
    use crate::{Camera, Renderer};
    use scene_gen_trace::RayPacket;

    pub(super) struct Baseline;

    impl Build for Baseline {
        #[inline(always)]
        fn tile(
            r: &Renderer<'_>,
            camera: &Camera,
            cells: &[(usize, (u32, u32))],
            job: Job<'_>,
            packet: &mut RayPacket,
            scratch: &mut Scratch,
            sink: &mut BandSink<'_>,
        ) {
            match job.kind() {
                LABELS => labels::tile(r, camera, cells, job, packet, scratch, sink),
                SHADE => shade::tile(r, camera, cells, job, packet, scratch, sink),
                _ => samples::tile(r, camera, cells, job, packet, scratch, sink),
            }
        }
    }

    impl Renderer<'_> {
        /// [`Renderer::trace_band`] in the target's baseline build.
        #[inline(never)]
        pub(in crate::tile) fn trace_band_baseline(
            &self,
            camera: &Camera,
            grid: (u32, u32),
            at: Cells<'_>,
            job: Job<'_>,
            band: usize,
            sink: BandSink<'_>,
        ) {
            self.trace_band::<Baseline>(camera, grid, at, job, band, sink);
        }
    }

    /// The tile function of one kind of job.
    macro_rules! kind {
        ($module:ident, $kind:ident) => {
            mod $module {
                use super::super::{BandSink, Job, Scratch, $kind};
                use crate::{Camera, Renderer};
                use scene_gen_trace::RayPacket;

                #[inline(never)]
                pub(super) fn tile(
                    r: &Renderer<'_>,
                    camera: &Camera,
                    cells: &[(usize, (u32, u32))],
                    job: Job<'_>,
                    packet: &mut RayPacket,
                    scratch: &mut Scratch,
                    sink: &mut BandSink<'_>,
                ) {
                    r.trace_tile::<$kind>(camera, cells, job, packet, scratch, sink);
                }
            }
        };
    }
    kind!(labels, LABELS);
    kind!(shade, SHADE);
    kind!(samples, SAMPLES);
}

/// The AVX2 + FMA build of the tile loop, laid out as [`baseline`]: every function has the
/// target features, so everything inlined into them gets AVX2 code.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{BandSink, Build, Cells, Job, LABELS, SHADE, Scratch};
    use crate::{Camera, Renderer};
    #[cfg(doc)]
    use scene_gen_core::simd::Dispatch;
    use scene_gen_trace::RayPacket;

    pub(super) struct Avx2;

    impl Build for Avx2 {
        #[inline(always)]
        fn tile(
            r: &Renderer<'_>,
            camera: &Camera,
            cells: &[(usize, (u32, u32))],
            job: Job<'_>,
            packet: &mut RayPacket,
            scratch: &mut Scratch,
            sink: &mut BandSink<'_>,
        ) {
            // SAFETY: `Avx2` is only the build of `trace_band_avx2`, which runs only where the
            // CPU has AVX2 and FMA.
            unsafe {
                match job.kind() {
                    LABELS => labels::tile(r, camera, cells, job, packet, scratch, sink),
                    SHADE => shade::tile(r, camera, cells, job, packet, scratch, sink),
                    _ => samples::tile(r, camera, cells, job, packet, scratch, sink),
                }
            }
        }
    }

    impl Renderer<'_> {
        /// [`Renderer::trace_band`] compiled with AVX2 and FMA enabled: the body and everything
        /// inlined into it (tile, packet traversal, shading, shadow rays) get AVX2 code.
        ///
        /// # Safety
        /// The CPU must support AVX2 and FMA: call it only when [`Dispatch::supported`] returned
        /// [`Dispatch::Avx2Fma`].
        #[target_feature(enable = "avx2,fma")]
        pub(in crate::tile) unsafe fn trace_band_avx2(
            &self,
            camera: &Camera,
            grid: (u32, u32),
            at: Cells<'_>,
            job: Job<'_>,
            band: usize,
            sink: BandSink<'_>,
        ) {
            self.trace_band::<Avx2>(camera, grid, at, job, band, sink);
        }
    }

    /// The tile function of one kind of job.
    macro_rules! kind {
        ($module:ident, $kind:ident) => {
            mod $module {
                use super::super::{BandSink, Job, Scratch, $kind};
                use crate::{Camera, Renderer};
                use scene_gen_trace::RayPacket;

                /// # Safety
                /// The CPU must support AVX2 and FMA.
                #[target_feature(enable = "avx2,fma")]
                #[inline(never)]
                pub(super) unsafe fn tile(
                    r: &Renderer<'_>,
                    camera: &Camera,
                    cells: &[(usize, (u32, u32))],
                    job: Job<'_>,
                    packet: &mut RayPacket,
                    scratch: &mut Scratch,
                    sink: &mut BandSink<'_>,
                ) {
                    r.trace_tile::<$kind>(camera, cells, job, packet, scratch, sink);
                }
            }
        };
    }
    kind!(labels, LABELS);
    kind!(shade, SHADE);
    kind!(samples, SAMPLES);
}

#[cfg(test)]
mod tests {
    use crate::{Camera, Frame, RenderSettings, Renderer, ShadingRate};
    use scene_gen_core::simd::Dispatch;
    use scene_gen_scene::scene::Scene;

    /// House 0 (textures, windows lit by the sun, ceiling lights, metals) seen from the middle
    /// pose of its walk by a 4 mm lens on a 48 x 30 sensor of 236 um pixels (a 1936 x 1216,
    /// 5.86 um sensor binned): small enough for a debug build.
    fn house_view() -> (Scene, Camera) {
        let library = scene_gen_scene::house::embedded_library().unwrap();
        let params = scene_gen_scene::trajectory::TrajectoryParams::default();
        let house = scene_gen_scene::house::walked_house(&library, 0, &params).unwrap();
        let pose = house.walk.poses[house.walk.poses.len() / 2];
        let camera = Camera {
            width_px: 48,
            height_px: 30,
            pixel_pitch_um: 5.86 * 1936.0 / 48.0,
            focal_mm: 4.0,
            f_number: 2.0,
            position: pose.position,
            yaw_deg: pose.yaw_deg,
            pitch_deg: 0.0,
            vignetting: true,
        };
        (house.scene, camera)
    }

    /// Hits lit by the point lights and the sun together, their shadow rays in packets, give
    /// the frame that lighting each hit alone gives, up to the order of the sums (a few ulps):
    /// with the roulette of `standard` too, whose draws must come in the same order.
    #[test]
    fn hits_lit_together_give_the_frame_of_hits_lit_alone() {
        let (scene, camera) = house_view();
        let direct = RenderSettings {
            samples_per_axis: 2,
            rect_samples_per_axis: 1,
            indirect_rays: 0,
            specular: false,
            light_cull: 0.0,
            ..RenderSettings::preview()
        };
        for (name, settings) in [("direct", direct), ("standard", RenderSettings::standard())] {
            let render = |batch| {
                let mut renderer = Renderer::new(&scene, settings);
                renderer.batch_lights = batch;
                renderer.render(&camera).unwrap()
            };
            let (batched, alone) = (render(true), render(false));
            assert_eq!(batched.depth_m, alone.depth_m, "{name}");
            assert_eq!(batched.instance_id, alone.instance_id, "{name}");
            let pairs =
                batched.day_nit.iter().chain(&batched.night_nit).zip(alone.day_nit.iter().chain(&alone.night_nit));
            let (mut lit, mut worst) = (0, 0.0f32);
            for (a, b) in pairs {
                for (x, y) in a.iter().zip(b) {
                    worst = worst.max((x - y).abs() / y.abs().max(1e-3));
                    lit += usize::from(*y > 0.0);
                }
            }
            assert!(lit > batched.day_nit.len(), "{name}: a lit frame ({lit} lit values)");
            assert!(worst < 1e-5, "{name}: largest relative difference {worst}");
        }
    }

    /// Every job of the tile loop (labels, one centre ray, decoupled anchors and interpolation,
    /// several samples with bounces, rect samples and mirrors) gives the same frame in both
    /// builds of the loop. Bit equality holds because no `a * b + c` is contracted into an
    /// FMA (module docs of `scene_gen_core::simd`); a build that fused would change low bits here.
    #[test]
    fn the_avx2_clone_renders_the_frame_of_the_baseline() {
        let (scene, camera) = house_view();
        if Dispatch::Avx2Fma.supported() != Dispatch::Avx2Fma {
            eprintln!("this CPU has no AVX2 + FMA: both runs take the baseline path");
        }
        let decoupled = RenderSettings {
            shading: ShadingRate::Decoupled { stride: 3, min_width_px: 0 },
            ..RenderSettings::preview()
        };
        let adaptive = RenderSettings {
            shading: ShadingRate::Adaptive { stride: 2, min_width_px: 0 },
            ..RenderSettings::preview()
        };
        let pooled =
            RenderSettings { visibility_filter_radius: 2, rect_samples_per_axis: 2, light_cull: 0.0, ..adaptive };
        let cases = [
            ("preview", RenderSettings::preview()),
            ("decoupled", decoupled),
            ("adaptive", adaptive),
            ("adaptive, pooled windows", pooled),
            ("standard", RenderSettings { seed: 5, ..RenderSettings::standard() }),
        ];
        for (name, settings) in cases {
            let render = |dispatch| -> Frame {
                Renderer::new(&scene, settings).with_dispatch(dispatch).render(&camera).unwrap()
            };
            let generic = render(Dispatch::Generic);
            let avx2 = render(Dispatch::Avx2Fma);
            // Not a black frame: the comparison means something.
            assert!(generic.day_nit.iter().any(|c| c[1] > 0.0), "{name}");
            let bits = |f: &Frame| -> Vec<u32> {
                let rgb = f.day_nit.iter().chain(&f.night_nit).chain(&f.normal).flatten();
                rgb.chain(&f.depth_m).map(|v| v.to_bits()).collect()
            };
            assert_eq!(bits(&generic), bits(&avx2), "{name}: radiance, normals or depth differ");
            assert_eq!(generic, avx2, "{name}");
        }
        let labels = |dispatch| {
            Renderer::new(&scene, RenderSettings::preview()).with_dispatch(dispatch).render_labels(&camera).unwrap()
        };
        assert_eq!(labels(Dispatch::Generic), labels(Dispatch::Avx2Fma));
        // The ids-only pass gives the ids of a decoupled frame (anchors filled from their own
        // tiles), in both builds.
        let frame = Renderer::new(&scene, decoupled).render(&camera).unwrap();
        for dispatch in [Dispatch::Generic, Dispatch::Avx2Fma] {
            let ids = Renderer::new(&scene, decoupled).with_dispatch(dispatch).render_ids(&camera).unwrap();
            assert_eq!(ids.instance_id, frame.instance_id, "{dispatch:?}");
            assert_eq!(ids.class_id, frame.class_id, "{dispatch:?}");
        }
        assert!(frame.instance_id.iter().any(|&id| id != 0));
    }
}
