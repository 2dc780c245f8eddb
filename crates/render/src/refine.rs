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
//! grain of its noise grows from `stride` to `2 stride` pixels across. The frame-level error
//! against full-rate shading is measured by `bench_render --case decoupled --refine`
//! (docs/BENCHMARKS.md, "Adaptive anchors").
//!
//! With the visibility filter on ([`super::visibility_filter`]), the traced anchors pool their
//! window visibility once every anchor is placed, and each interpolated anchor then takes the
//! mean of its pooled coarse neighbours again: pooling it on its own would see only the coarse
//! anchors within its reach, a part of the interleaved lattice, and print that lattice's
//! pattern on the frame.
//!
//! The decisions are a function of the coarse anchors alone, so frames stay the same at any
//! thread count.

use glam::Vec3;

use rayon::prelude::*;

use super::lights::{Blockers, RectShare, luminance};
use super::tile::{BandSink, Cells, Job, TILE};
use super::{AnchorGrid, Camera, Frame, Guide, PixelOut, Renderer};

/// Largest spread (max - min) of the neighbouring coarse anchors' night irradiance luminance,
/// as a fraction of the largest, for an anchor to take their mean. Engineering
/// choice: 10 % keeps the error of an interpolated anchor well under the night sensor noise
/// (docs/BENCHMARKS.md, "Adaptive anchors", for the figures at other values).
pub const REFINE_TOLERANCE: f32 = 0.1;

/// Index of the night group in a [`super::GroupRgb`] (day 0, night 1).
const NIGHT: usize = 1;

/// The coarse anchors an interpolated anchor took the mean of: columns `xs[..nx]`, rows
/// `ys[..ny]` ([`coarse_neighbours`] along each axis).
type Parents = ([u32; 2], usize, [u32; 2], usize);

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
fn interpolate(grid: &AnchorGrid, suns: &[u32], xs: &[u32], ys: &[u32]) -> Option<Guide> {
    let mut first: Option<(Guide, f32, u32)> = None;
    let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
    for &y in ys {
        for &x in xs {
            let k = y as usize * grid.cols as usize + x as usize;
            let (Some(pixel), Some(g), sun) = (grid.pixels[k], grid.guides[k], suns[k]) else {
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
            let y = luminance(g.irradiance[NIGHT]);
            (lo, hi) = (lo.min(y), hi.max(y));
        }
    }
    if hi - lo > REFINE_TOLERANCE * hi {
        return None;
    }
    mean_guide(&grid.guides, grid.cols, xs, ys)
}

/// The guide of the first of the anchors `(x, y)` for `x` in `xs`, `y` in `ys` with their mean
/// position, irradiance and rect-light share; `None` if one has no guide.
fn mean_guide(guides: &[Option<Guide>], cols: u32, xs: &[u32], ys: &[u32]) -> Option<Guide> {
    let (mut position, mut irradiance, mut rects) = (Vec3::ZERO, [Vec3::ZERO; 2], RectShare::default());
    let mut first = None;
    for &y in ys {
        for &x in xs {
            let g = guides[y as usize * cols as usize + x as usize]?;
            first.get_or_insert(g);
            position += g.position;
            irradiance[0] += g.irradiance[0];
            irradiance[1] += g.irradiance[1];
            rects.accumulate(&g.rects);
        }
    }
    let n = (xs.len() * ys.len()) as f32;
    Some(Guide {
        position: position / n,
        irradiance: irradiance.map(|e| e / n),
        rects: rects.scaled(1.0 / n),
        ..first?
    })
}

impl Renderer<'_> {
    /// [`ShadingRate::Adaptive`](super::ShadingRate::Adaptive) at fine anchor spacing `stride`:
    /// the coarse anchors, then the fine ones that need tracing (module docs), then every other
    /// pixel as in [`ShadingRate::Decoupled`](super::ShadingRate::Decoupled).
    pub(super) fn render_adaptive(&self, camera: &Camera, stride: u32, frame: &mut Frame) {
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
        // The fine grid, filled in place: a traced anchor has its finished pixel, an
        // interpolated one only a guide, one still pending neither.
        let n = cols as usize * rows as usize;
        (grid.pixels, grid.guides) = (vec![None; n], vec![None; n]);
        let mut fine_suns = vec![0u32; n];
        for cj in 0..coarse_grid.1 {
            for ci in 0..coarse_grid.0 {
                let (i, j) = ((2 * ci).min(cols - 1), (2 * cj).min(rows - 1));
                let c = (cj * coarse_grid.0 + ci) as usize;
                let k = (j * cols + i) as usize;
                (grid.pixels[k], grid.guides[k], fine_suns[k]) = (Some(coarse[c].0), coarse[c].1, suns[c]);
            }
        }
        let mut todo: Vec<(u32, u32)> = Vec::new();
        let mut todo_index: Vec<usize> = Vec::new();
        // Each interpolated anchor and its coarse neighbours, to take their mean again once
        // their visibility is pooled.
        let mut interpolated: Vec<(usize, Parents)> = Vec::new();
        for j in 0..rows {
            let (ys, ny) = coarse_neighbours(j, rows);
            for i in 0..cols {
                let k = (j * cols + i) as usize;
                if grid.pixels[k].is_some() {
                    continue;
                }
                let (xs, nx) = coarse_neighbours(i, cols);
                match interpolate(&grid, &fine_suns, &xs[..nx], &ys[..ny]) {
                    Some(guide) => {
                        grid.guides[k] = Some(guide);
                        interpolated.push((k, (xs, nx, ys, ny)));
                    }
                    None => {
                        todo.push(((i * stride).min(w - 1), (j * stride).min(h - 1)));
                        todo_index.push(k);
                    }
                }
            }
        }
        if !todo.is_empty() {
            let todo_grid = (TILE, (todo.len() as u32).div_ceil(TILE));
            let traced = self.trace_anchors(camera, todo_grid, Cells::Listed { pixels: &todo });
            for (&k, &(pixel, guide)) in todo_index.iter().zip(&traced) {
                (grid.pixels[k], grid.guides[k]) = (Some(pixel), guide);
            }
        }
        let radius = self.settings.visibility_filter_radius;
        if radius > 0 {
            super::visibility_filter::pool(&mut grid, radius, camera.position);
            for (k, (xs, nx, ys, ny)) in interpolated {
                grid.guides[k] = mean_guide(&grid.guides, cols, &xs[..nx], &ys[..ny]);
            }
        }
        self.shade_from_anchors(camera, &grid, frame);
    }

    /// The cells `at` of a `cols x rows` grid shaded in full, row-major: pixels and guides.
    pub(super) fn trace_anchors(
        &self,
        camera: &Camera,
        (cols, rows): (u32, u32),
        at: Cells<'_>,
    ) -> Vec<(PixelOut, Option<Guide>)> {
        let mut anchors = vec![(PixelOut::default(), None); cols as usize * rows as usize];
        let bands = anchors.chunks_mut(cols as usize * TILE as usize).map(BandSink::Cells).collect();
        self.trace_grid(camera, (cols, rows), at, Job::Anchor, bands);
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
