//! Pooling the sampled visibility of window light over neighbouring anchors
//! ([`RenderSettings::visibility_filter_radius`](super::RenderSettings::visibility_filter_radius)).
//!
//! A rect light's unshadowed irradiance is exact at every shading point (closed form,
//! [`super::lights`]); only the share of it that gets past the blockers is sampled, and that
//! share is what makes window light noisy in a penumbra. Heitz et al. (2018, "Combining
//! analytic direct illumination and stochastic shadows") split the two and denoise the ratio
//! alone. Here each anchor's rect light becomes its own exact unshadowed light times the pooled
//! ratio `sum(visible) / sum(unshadowed)` over the traced anchors within `radius` anchors (a
//! square) that lie on its surface (the test pixels use to borrow an anchor's irradiance):
//! where visibility is uniform over the neighbourhood the result is the anchor's own exact
//! light, in a penumbra it is the estimate of all the neighbours' samples together, and the
//! pooling never crosses an object's silhouette or a crease.
//!
//! What it costs in accuracy: a visibility edge within one surface (a window shadow on the
//! floor) is smoothed over `2 radius + 1` anchors. What it buys: the same noise with a fraction
//! of the shadow rays per anchor (docs/BENCHMARKS.md, "Render noise and ORB inliers").
//!
//! Every anchor is computed from the unfiltered grid alone, so frames stay the same at any
//! thread count.

use glam::Vec3;
use rayon::prelude::*;

use super::lights::RectShare;
use super::{AnchorGrid, GroupRgb};

/// Pools the rect-light visibility of `grid`'s traced anchors (those with a finished pixel)
/// over `radius` anchors either way (module docs); `eye` is the camera position (the ray
/// lengths of the surface test). A `radius` of 0 leaves the grid as it is. Every anchor whose
/// irradiance is replaced loses its finished pixel, so that the shading pass shades it from its
/// new irradiance. Interpolated anchors are left to their caller ([`super::refine`] takes the
/// mean of their pooled neighbours).
pub(super) fn pool(grid: &mut AnchorGrid, radius: u32, eye: Vec3) {
    if radius == 0 || grid.guides.is_empty() {
        return;
    }
    let cols = grid.cols as usize;
    let filtered: Vec<Option<GroupRgb>> = grid
        .guides
        .par_iter()
        .zip(&grid.pixels)
        .enumerate()
        .map(|(k, (guide, pixel))| {
            pixel.as_ref()?;
            pooled_irradiance(grid, k % cols, k / cols, radius as usize, eye, guide.as_ref()?)
        })
        .collect();
    for ((pixel, guide), e) in grid.pixels.iter_mut().zip(&mut grid.guides).zip(filtered) {
        if let (Some(g), Some(e)) = (guide.as_mut(), e) {
            g.irradiance = e;
            *pixel = None;
        }
    }
}

/// The irradiance of the anchor `(i, j)` whose guide is `g` with its rect light pooled, or
/// `None` where it has no rect light to pool.
fn pooled_irradiance(
    grid: &AnchorGrid,
    i: usize,
    j: usize,
    radius: usize,
    eye: Vec3,
    g: &super::Guide,
) -> Option<GroupRgb> {
    if g.rects.unshadowed == [Vec3::ZERO; 2] {
        return None;
    }
    let (cols, rows) = (grid.cols as usize, grid.rows as usize);
    let ray_length_m = (g.position - eye).length();
    let mut pooled = RectShare::default();
    for y in j.saturating_sub(radius)..=(j + radius).min(rows - 1) {
        for x in i.saturating_sub(radius)..=(i + radius).min(cols - 1) {
            let k = y * cols + x;
            // Traced anchors only: an interpolated one is the mean of traced ones already.
            let (Some(_), Some(n)) = (&grid.pixels[k], &grid.guides[k]) else { continue };
            if n.shares_surface(g.instance_id, g.material, g.position, g.normal, ray_length_m) {
                pooled.accumulate(&n.rects);
            }
        }
    }
    Some(std::array::from_fn(|group| {
        let (visible, unshadowed) = (pooled.visible[group], pooled.unshadowed[group]);
        let ratio = Vec3::select(unshadowed.cmpgt(Vec3::ZERO), visible / unshadowed, Vec3::ZERO);
        // The anchor's own estimate out, its exact light times the pooled share in.
        let rect = g.rects.unshadowed[group] * ratio;
        (g.irradiance[group] - g.rects.visible[group] + rect).max(Vec3::ZERO)
    }))
}
