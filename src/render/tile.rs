//! Every frame is traced in 8 x 8 pixel tiles.
//!
//! A tile's camera rays go through the BVH as one [`RayPacket`] (coherent rays from one origin:
//! about twice the speed of one ray at a time, docs/BENCHMARKS.md): the centre rays, then, with
//! `n x n` samples per pixel, one packet per sample. Each pixel is shaded as it would be alone,
//! from its own random stream in its own order, so a tiled frame is bit for bit the frame a
//! pixel-by-pixel trace gives, at any thread count. Shadow rays stay one at a time: traced as
//! packets per light and tile they were slower on real frames (rect-light samples and culled
//! lights give small, spread packets; measured in docs/BENCHMARKS.md).

use glam::Vec3;
use rayon::prelude::*;

use super::lights::Blockers;
use super::packet::{PACKET_RAYS, RayPacket};
use super::shade::{Primary, SurfaceHit, Tracer};
use super::{
    AnchorGrid, Camera, Frame, GroupRgb, Guide, PIXEL_STREAM, PixelOut, Renderer, Sampler, Strata, finite_radiance,
};
use crate::render::accel::Hit;

/// Side of a tile, pixels: one tile's rays fill one packet.
pub(super) const TILE: u32 = 8;
const _: () = assert!((TILE * TILE) as usize == PACKET_RAYS);

/// What a tile computes at each of its pixels.
#[derive(Clone, Copy)]
pub(super) enum Job<'g> {
    /// Depth, ids and normal only (black radiance).
    Labels,
    /// The full pixel from its centre ray (one camera ray per pixel); with a grid, the
    /// irradiance comes from its anchors where they allow.
    Shade(Option<&'g AnchorGrid>),
    /// Labels from the centre ray, radiance averaged over `n x n` stratified jittered camera
    /// rays (`samples_per_axis` n > 1).
    Samples,
}

/// Where the finished pixels of one band of tiles go: `slot` counts row-major from the band's
/// first cell.
pub(super) trait BandSink: Send {
    fn put(&mut self, slot: usize, pixel: PixelOut, guide: Option<Guide>);
}

/// Cells with their guides (the anchors of decoupled shading).
impl BandSink for &mut [(PixelOut, Option<Guide>)] {
    fn put(&mut self, slot: usize, pixel: PixelOut, guide: Option<Guide>) {
        self[slot] = (pixel, guide);
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

impl BandSink for FrameBand<'_> {
    fn put(&mut self, slot: usize, p: PixelOut, _: Option<Guide>) {
        self.day_nit[slot] = p.radiance[0].to_array();
        self.night_nit[slot] = p.radiance[1].to_array();
        self.depth_m[slot] = p.depth_m;
        self.instance_id[slot] = p.instance_id;
        self.class_id[slot] = p.class_id;
        self.normal[slot] = p.normal.to_array();
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

    /// The frame's buffers in bands of `TILE` rows.
    pub(super) fn bands(&mut self) -> Vec<FrameBand<'_>> {
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
            Some(FrameBand {
                day_nit: day.next()?,
                night_nit: night.next()?,
                depth_m: depth.next()?,
                instance_id: instance.next()?,
                class_id: class.next()?,
                normal: normal.next()?,
            })
        })
        .collect()
    }
}

impl Renderer<'_> {
    /// Runs `job` at the pixels of a `cols x rows` grid (cell `(cx, cy)` is pixel `at(cx, cy)`),
    /// tile by tile, one band of `TILE` rows of cells per sink in `bands`, bands in parallel.
    /// The grid is the whole frame, or the anchors of decoupled shading.
    pub(super) fn trace_grid<B: BandSink>(
        &self,
        camera: &Camera,
        (cols, rows): (u32, u32),
        at: impl Fn(u32, u32) -> (u32, u32) + Sync,
        job: Job<'_>,
        bands: Vec<B>,
    ) {
        bands.into_par_iter().enumerate().for_each(|(band, mut sink)| {
            let mut packet = RayPacket::new();
            let band_rows = (rows - band as u32 * TILE).min(TILE);
            for tx in 0..cols.div_ceil(TILE) {
                let x_end = (tx * TILE + TILE).min(cols);
                let tile: Vec<(usize, (u32, u32))> = (0..band_rows)
                    .flat_map(|dy| (tx * TILE..x_end).map(move |cx| (dy, cx)))
                    .map(|(dy, cx)| {
                        let cy = band as u32 * TILE + dy;
                        (dy as usize * cols as usize + cx as usize, at(cx, cy))
                    })
                    .filter(|&(slot, (x, y))| match job {
                        // The anchors of a decoupled frame are finished already.
                        Job::Shade(Some(grid)) => {
                            grid.index(x, y).map(|a| sink.put(slot, grid.pixels[a], None)).is_none()
                        }
                        _ => true,
                    })
                    .collect();
                self.trace_tile(camera, &tile, job, &mut packet, &mut |slot, pixel, guide| {
                    sink.put(slot, pixel, guide);
                });
            }
        });
    }

    /// One tile: `cells` are (slot, pixel); each finished pixel goes to `store(slot, ..)`.
    fn trace_tile(
        &self,
        camera: &Camera,
        cells: &[(usize, (u32, u32))],
        job: Job<'_>,
        packet: &mut RayPacket,
        store: &mut dyn FnMut(usize, PixelOut, Option<Guide>),
    ) {
        let basis = camera.basis();
        let origin = camera.position;
        packet.clear();
        let dirs: Vec<Vec3> =
            cells.iter().map(|&(_, (x, y))| camera.ray_direction_in(basis, x as f32 + 0.5, y as f32 + 0.5)).collect();
        for dir in &dirs {
            packet.push(origin, *dir, f32::INFINITY);
        }
        let mut hits: [Option<Hit>; PACKET_RAYS] = [None; PACKET_RAYS];
        self.accel.closest_hits(packet, &mut hits);
        let blockers = Blockers::new();
        let tracer = self.tracer(&blockers);
        let mut emitters = Vec::new();
        if !matches!(job, Job::Labels) {
            self.lights.emitters_in_reach(packet, &mut emitters);
        }
        let mut labels = Vec::with_capacity(cells.len());
        for (k, (&(slot, (x, y)), &dir)) in cells.iter().zip(&dirs).enumerate() {
            let hit = hits[k].map(|h| (h.t, self.accel.surface(&h, origin, dir)));
            let pixel_labels = self.labels(dir, basis, hit.as_ref());
            match job {
                Job::Labels => store(slot, pixel_labels, None),
                Job::Shade(grid) => {
                    let (pixel, guide) =
                        self.shade_centre(&tracer, camera, (x, y), dir, (hit, &emitters), pixel_labels, grid);
                    store(slot, pixel, guide);
                }
                Job::Samples => labels.push(pixel_labels),
            }
        }
        if let Job::Samples = job {
            for (&(slot, _), pixel) in cells.iter().zip(self.sample_tile(&tracer, camera, cells, labels, packet)) {
                store(slot, pixel, None);
            }
        }
    }

    /// [`Job::Samples`] over a tile whose centre rays gave `labels`: sample `(i, j)` of every
    /// pixel is traced in one packet. Each pixel draws from its own stream in the order it
    /// would alone (strata rotations, then per sample its jitter and its shading), so
    /// interleaving the pixels changes nothing.
    fn sample_tile(
        &self,
        tracer: &Tracer<'_>,
        camera: &Camera,
        cells: &[(usize, (u32, u32))],
        mut labels: Vec<PixelOut>,
        packet: &mut RayPacket,
    ) -> Vec<PixelOut> {
        let (basis, origin) = (camera.basis(), camera.position);
        let n = self.settings.samples_per_axis.max(1);
        let bounce_total = n * n * self.settings.indirect_rays;
        let rect_total = n * n * self.settings.rect_samples_per_axis.pow(2);
        let mut samplers: Vec<(Sampler, f32, f32)> = cells
            .iter()
            .map(|&(_, (x, y))| {
                let key = u64::from(y) * u64::from(camera.width_px) + u64::from(x);
                let mut sampler = Sampler::of_hashed(self.settings.seed, PIXEL_STREAM, key);
                let rotation = sampler.uniform();
                let rect_rotation = sampler.uniform();
                (sampler, rotation, rect_rotation)
            })
            .collect();
        let mut sums = vec![[Vec3::ZERO; 2]; cells.len()];
        let mut hits: [Option<Hit>; PACKET_RAYS] = [None; PACKET_RAYS];
        let mut emitters = Vec::new();
        for j in 0..n {
            for i in 0..n {
                packet.clear();
                let dirs: Vec<Vec3> = cells
                    .iter()
                    .zip(&mut samplers)
                    .map(|(&(_, (x, y)), (sampler, _, _))| {
                        let sx = (i as f32 + sampler.uniform()) / n as f32;
                        let sy = (j as f32 + sampler.uniform()) / n as f32;
                        let dir = camera.ray_direction_in(basis, x as f32 + sx, y as f32 + sy);
                        packet.push(origin, dir, f32::INFINITY);
                        dir
                    })
                    .collect();
                self.accel.closest_hits(packet, &mut hits);
                self.lights.emitters_in_reach(packet, &mut emitters);
                for (k, (sampler, rotation, rect_rotation)) in samplers.iter_mut().enumerate() {
                    let first = j * n + i;
                    let strata = Strata { first, stride: n * n, total: bounce_total, rotation: *rotation };
                    let rect = Strata { first, stride: n * n, total: rect_total, rotation: *rect_rotation };
                    let l = tracer.camera_ray(origin, dirs[k], hits[k], &emitters, strata, rect, sampler);
                    sums[k][0] += l[0];
                    sums[k][1] += l[1];
                }
            }
        }
        let inv = 1.0 / (n * n) as f32;
        for (pixel, sum) in labels.iter_mut().zip(sums) {
            pixel.radiance = finite_radiance(sum.map(|c| c * inv));
        }
        labels
    }

    /// Shades pixel `(x, y)` whose centre ray along `dir` found `hit`: `labels` plus radiance,
    /// and the pixel's [`Guide`] where its surface is diffuse. With `grid`, the irradiance comes
    /// from the anchors where they lie on the same surface.
    ///
    /// The pixel's stream draws the strata rotations first, then the irradiance samples, then
    /// the specular ones; the rotations are drawn only when a later draw needs them (an
    /// interpolated pixel without a mirror draws nothing), which leaves every used number
    /// where it was.
    #[allow(clippy::too_many_arguments)]
    fn shade_centre(
        &self,
        tracer: &Tracer<'_>,
        camera: &Camera,
        (x, y): (u32, u32),
        dir: Vec3,
        (hit, emitters): (Option<(f32, super::accel::SurfacePoint)>, &[u32]),
        labels: PixelOut,
        grid: Option<&AnchorGrid>,
    ) -> (PixelOut, Option<Guide>) {
        let t = hit.map_or(f32::INFINITY, |h| h.0);
        let s = match tracer.primary(camera.position, dir, hit, emitters) {
            Primary::Miss => return (labels, None),
            Primary::Emitter(l) => return (PixelOut { radiance: finite_radiance(l), ..labels }, None),
            Primary::Surface(s) => s,
        };
        let key = u64::from(y) * u64::from(camera.width_px) + u64::from(x);
        let mut sampler = Sampler::of_hashed(self.settings.seed, PIXEL_STREAM, key);
        let mut strata = None;
        let e = (s.response.diffuse != Vec3::ZERO).then(|| {
            grid.and_then(|g| g.irradiance(x, y, &s.surface, labels.instance_id, t)).unwrap_or_else(|| {
                let (bounce, rect) = *strata.insert(self.pixel_strata(&mut sampler));
                tracer.irradiance(&s.surface, bounce, rect, &mut sampler)
            })
        });
        if strata.is_none() && self.settings.specular && s.response.specular != Vec3::ZERO {
            self.pixel_strata(&mut sampler);
        }
        self.finish(tracer, labels, dir, &s, e, &mut sampler)
    }

    /// The pixel's bounce and rect-light strata, drawn first from its stream.
    pub(super) fn pixel_strata(&self, sampler: &mut Sampler) -> (Strata, Strata) {
        let rotation = sampler.uniform();
        let rect_rotation = sampler.uniform();
        let strata = Strata { first: 0, stride: 1, total: self.settings.indirect_rays, rotation };
        let rect_total = self.settings.rect_samples_per_axis.pow(2);
        (strata, Strata { first: 0, stride: 1, total: rect_total, rotation: rect_rotation })
    }

    /// A shaded pixel from its irradiance `e` (`None` without a diffuse part), with its
    /// [`Guide`] where it has one.
    pub(super) fn finish(
        &self,
        tracer: &Tracer<'_>,
        mut out: PixelOut,
        dir: Vec3,
        s: &SurfaceHit,
        e: Option<GroupRgb>,
        sampler: &mut Sampler,
    ) -> (PixelOut, Option<Guide>) {
        let guide = e.map(|irradiance| Guide {
            position: s.surface.position,
            normal: s.surface.shading_normal,
            material: s.surface.material,
            instance_id: out.instance_id,
            irradiance,
        });
        out.radiance = finite_radiance(tracer.surface_radiance(dir, s, e, sampler));
        (out, guide)
    }
}
