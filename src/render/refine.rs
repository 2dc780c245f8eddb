//! Adaptive decoupled shading ([`ShadingRate::Adaptive`](super::ShadingRate::Adaptive)): the
//! anchor grid of [`ShadingRate::Decoupled`](super::ShadingRate::Decoupled) filled coarse to
//! fine.
//!
//! Every other anchor of every other anchor row is traced first (a grid of twice the stride).
//! Each remaining anchor lies between two or four of those. Where they all lie on one surface
//! (the test pixels use to borrow an anchor's irradiance), the sun reaches all or none of them,
//! and their night irradiance agrees within [`REFINE_TOLERANCE`], the anchor takes their mean
//! instead of being traced; anywhere else (an edge, a shadow boundary, a light's fall-off) it
//! is traced as before. Flat, evenly lit walls and floors, most of a frame, then cost a quarter
//! of the anchors, and the rest keeps the fine grid.
//!
//! What it can miss: a shadow or highlight narrower than the coarse spacing that falls between
//! coarse anchors which agree, and the soft shadows of windows, which the test does not look at
//! ([`interpolate`] says why). Window light is then averaged over fewer samples per area: the
//! grain of its noise grows from `stride` to `2 stride` pixels across. The frame-level error against full-rate shading is measured by
//! `bench_render --case decoupled --refine` (docs/BENCHMARKS.md, "Adaptive anchors").
//!
//! The decisions are a function of the coarse anchors alone, so frames stay the same at any
//! thread count.

use glam::Vec3;

use rayon::prelude::*;

use super::lights::{Blockers, luminance};
use super::tile::{Cells, Job, TILE};
use super::{AnchorGrid, Camera, Frame, Guide, PixelOut, RenderError, Renderer};

/// Largest spread (max - min) of the neighbouring coarse anchors' night irradiance luminance,
/// as a fraction of the largest, for an anchor to take their mean. Engineering
/// choice: 10 % keeps the error of an interpolated anchor well under the night sensor noise
/// (docs/BENCHMARKS.md, "Adaptive anchors", for the figures at other values).
pub const REFINE_TOLERANCE: f32 = 0.1;

/// Index of the night group in a [`super::GroupRgb`] (day 0, night 1).
const NIGHT: usize = 1;

/// One anchor of the fine grid while it is being filled.
#[derive(Clone, Copy)]
enum Anchor {
    Pending,
    /// Shaded in full: its finished pixel, its guide where its surface is diffuse, and (coarse
    /// anchors only) which directional lights reach it
    /// ([`LightSet::directionals_reaching`](super::lights::LightSet::directionals_reaching)).
    Traced(PixelOut, Option<Guide>, u32),
    /// The mean of its coarse neighbours.
    Interpolated(Guide),
}

/// The coarse anchors beside fine anchor index `i` of `count` along one axis: itself where it
/// is coarse (even, or the last), else the two even indices around it.
fn coarse_neighbours(i: u32, count: u32) -> ([u32; 2], usize) {
    if i % 2 == 0 || i + 1 == count { ([i, i], 1) } else { ([i - 1, i + 1], 2) }
}

/// The mean guide of the traced anchors `(x, y)` for `x` in `xs`, `y` in `ys`, if they all lie on
/// one diffuse surface, the same directional lights (the sun) reach them all, and their night
/// irradiance agrees within [`REFINE_TOLERANCE`].
///
/// The day irradiance is not compared: in a window's penumbra an anchor's few visibility
/// samples make it noisy, and keeping only the anchors whose noisy values happen to agree
/// biases the mean (+4 % on the day frame with one window sample, before and after windows
/// were computed in closed form; docs/BENCHMARKS.md, "Adaptive anchors"). The sun's shadow
/// edges, its one sharp feature, are caught by the directional bits instead.
fn interpolate(anchors: &[Anchor], cols: u32, xs: &[u32], ys: &[u32]) -> Option<Guide> {
    let mut first: Option<(Guide, f32, u32)> = None;
    let (mut position, mut irradiance) = (Vec3::ZERO, [Vec3::ZERO; 2]);
    let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
    for &y in ys {
        for &x in xs {
            let Anchor::Traced(pixel, Some(g), sun) = anchors[y as usize * cols as usize + x as usize] else {
                return None;
            };
            match first {
                None => first = Some((g, pixel.depth_m, sun)),
                Some((f, depth_m, first_sun)) => {
                    if sun != first_sun || !g.shares_surface(f.instance_id, f.material, f.position, f.normal, depth_m) {
                        return None;
                    }
                }
            }
            position += g.position;
            let y = luminance(g.irradiance[NIGHT]);
            (lo, hi) = (lo.min(y), hi.max(y));
            irradiance[0] += g.irradiance[0];
            irradiance[1] += g.irradiance[1];
        }
    }
    if hi - lo > REFINE_TOLERANCE * hi {
        return None;
    }
    let (f, _, _) = first?;
    let n = (xs.len() * ys.len()) as f32;
    Some(Guide { position: position / n, irradiance: irradiance.map(|e| e / n), ..f })
}

impl Renderer<'_> {
    /// [`ShadingRate::Adaptive`](super::ShadingRate::Adaptive) at fine anchor spacing `stride`:
    /// the coarse anchors, then the fine ones that need tracing (module docs), then every other
    /// pixel as in [`ShadingRate::Decoupled`](super::ShadingRate::Decoupled).
    pub(super) fn render_adaptive(&self, camera: &Camera, stride: u32) -> Result<Frame, RenderError> {
        camera.validate()?;
        let (w, h) = (camera.width_px, camera.height_px);
        let mut grid = AnchorGrid::layout(stride, w, h);
        let (cols, rows) = (grid.cols, grid.rows);
        let coarse_stride = 2 * stride;
        let coarse_grid = (AnchorGrid::count(w, coarse_stride), AnchorGrid::count(h, coarse_stride));
        let coarse =
            self.trace_anchors(camera, coarse_grid, Cells::Anchors { stride: coarse_stride, width: w, height: h });
        // Per coarse row, with its own shadow hints, so the bits do not depend on the threads.
        let suns: Vec<u32> = coarse
            .par_chunks(coarse_grid.0 as usize)
            .map(|row| {
                let blockers = Blockers::new();
                let mut bits = Vec::with_capacity(row.len());
                for (_, guide) in row {
                    bits.push(match guide {
                        Some(g) => self.lights.directionals_reaching(&self.accel, g.position, g.normal, &blockers),
                        None => 0,
                    });
                }
                bits
            })
            .flatten()
            .collect();
        let mut anchors = vec![Anchor::Pending; cols as usize * rows as usize];
        for cj in 0..coarse_grid.1 {
            for ci in 0..coarse_grid.0 {
                let (i, j) = ((2 * ci).min(cols - 1), (2 * cj).min(rows - 1));
                let c = (cj * coarse_grid.0 + ci) as usize;
                let (pixel, guide) = coarse[c];
                anchors[(j * cols + i) as usize] = Anchor::Traced(pixel, guide, suns[c]);
            }
        }
        let mut todo: Vec<(u32, u32)> = Vec::new();
        let mut todo_index: Vec<usize> = Vec::new();
        for j in 0..rows {
            let (ys, ny) = coarse_neighbours(j, rows);
            for i in 0..cols {
                let k = (j * cols + i) as usize;
                if !matches!(anchors[k], Anchor::Pending) {
                    continue;
                }
                let (xs, nx) = coarse_neighbours(i, cols);
                match interpolate(&anchors, cols, &xs[..nx], &ys[..ny]) {
                    Some(guide) => anchors[k] = Anchor::Interpolated(guide),
                    None => {
                        todo.push(((i * stride).min(w - 1), (j * stride).min(h - 1)));
                        todo_index.push(k);
                    }
                }
            }
        }
        if !todo.is_empty() {
            let grid = (TILE, (todo.len() as u32).div_ceil(TILE));
            let traced = self.trace_anchors(camera, grid, Cells::Listed { pixels: &todo });
            for (&k, &(pixel, guide)) in todo_index.iter().zip(&traced) {
                anchors[k] = Anchor::Traced(pixel, guide, 0);
            }
        }
        (grid.pixels, grid.guides) = anchors
            .into_iter()
            .map(|a| match a {
                Anchor::Traced(pixel, guide, _) => (Some(pixel), guide),
                Anchor::Interpolated(guide) => (None, Some(guide)),
                // Every anchor is coarse, interpolated or traced by now.
                Anchor::Pending => (None, None),
            })
            .unzip();
        Ok(self.shade_from_anchors(camera, &grid))
    }

    /// The cells `at` of a `cols x rows` grid shaded in full, row-major: pixels and guides.
    pub(super) fn trace_anchors(
        &self,
        camera: &Camera,
        (cols, rows): (u32, u32),
        at: Cells<'_>,
    ) -> Vec<(PixelOut, Option<Guide>)> {
        let mut anchors = vec![(PixelOut::default(), None); cols as usize * rows as usize];
        let bands: Vec<&mut [(PixelOut, Option<Guide>)]> = anchors.chunks_mut(cols as usize * TILE as usize).collect();
        self.trace_grid(camera, (cols, rows), at, Job::Shade(None), bands);
        anchors
    }
}

#[cfg(test)]
mod tests {
    use super::coarse_neighbours;

    /// Every fine index is coarse or lies between two coarse ones (even, or the last).
    #[test]
    fn fine_anchors_lie_between_coarse_ones() {
        for count in 1..12u32 {
            let coarse = |i: u32| i % 2 == 0 || i + 1 == count;
            for i in 0..count {
                let (xs, n) = coarse_neighbours(i, count);
                assert!(xs[..n].iter().all(|&x| x < count && coarse(x)), "{i} of {count}");
                assert_eq!(n == 1, coarse(i), "{i} of {count}");
                if n == 2 {
                    assert_eq!((xs[0] + 1, xs[1] - 1), (i, i), "{i} of {count}");
                }
            }
        }
    }
}
