//! Boxes to the network's training targets, and its output maps back to boxes (CenterNet:
//! an object is the peak of its class's heat map at its centre cell, and that cell holds the
//! centre's sub-cell offset and the box's log size).

use super::network::{BOX_CHANNELS, NUM_CLASSES, STRIDE_PX};
use crate::detection::Detection;

/// A ground-truth box in input pixels, `class` 0-based (COCO category - 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetBox {
    pub class: usize,
    /// `[x, y, width, height]` from the top-left corner, pixels.
    pub bbox: [f32; 4],
}

/// Training targets of one image over a `cells_w x cells_h` output grid, channel-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Targets {
    /// `[11, h, w]`: 1 at each object's centre cell, an elliptic Gaussian around it.
    pub heat: Vec<f32>,
    /// `[4, h, w]`: offset x, offset y, ln width, ln height (cells), at centre cells.
    pub boxes: Vec<f32>,
    /// `[1, h, w]`: 1 at centre cells, where the box map is trained.
    pub mask: Vec<f32>,
}

/// Gaussian spread as a fraction of the box side: TTFNet's alpha 0.54 over 6 sigmas, so the
/// heat falls to about 0.1 at the box's edge along each axis.
const GAUSSIAN_ALPHA: f32 = 0.54;
/// Smallest spread, cells: a tiny object still gives its neighbours a little heat.
const MIN_SIGMA_CELLS: f32 = 0.35;

/// Encodes `boxes` for a `cells_w x cells_h` grid. Larger boxes are written first, so where two
/// centres share a cell the smaller object's box wins (the larger one is seen elsewhere too).
#[must_use]
pub fn encode(boxes: &[TargetBox], cells_w: usize, cells_h: usize) -> Targets {
    let plane = cells_w * cells_h;
    let mut t = Targets {
        heat: vec![0.0; NUM_CLASSES * plane],
        boxes: vec![0.0; BOX_CHANNELS * plane],
        mask: vec![0.0; plane],
    };
    let mut order: Vec<&TargetBox> =
        boxes.iter().filter(|b| b.class < NUM_CLASSES && b.bbox[2] > 0.0 && b.bbox[3] > 0.0).collect();
    order.sort_by(|a, b| (b.bbox[2] * b.bbox[3]).total_cmp(&(a.bbox[2] * a.bbox[3])));
    let stride = STRIDE_PX as f32;
    for b in order {
        let [x, y, w, h] = b.bbox;
        let (cx, cy) = ((x + w / 2.0) / stride, (y + h / 2.0) / stride);
        let ix = (cx.floor() as isize).clamp(0, cells_w as isize - 1) as usize;
        let iy = (cy.floor() as isize).clamp(0, cells_h as isize - 1) as usize;
        let sx = (GAUSSIAN_ALPHA * w / stride / 6.0).max(MIN_SIGMA_CELLS);
        let sy = (GAUSSIAN_ALPHA * h / stride / 6.0).max(MIN_SIGMA_CELLS);
        let heat = &mut t.heat[b.class * plane..(b.class + 1) * plane];
        let (rx, ry) = ((3.0 * sx).ceil() as isize, (3.0 * sy).ceil() as isize);
        for gy in (iy as isize - ry).max(0)..=(iy as isize + ry).min(cells_h as isize - 1) {
            for gx in (ix as isize - rx).max(0)..=(ix as isize + rx).min(cells_w as isize - 1) {
                let (dx, dy) = ((gx - ix as isize) as f32, (gy - iy as isize) as f32);
                let g = (-(dx * dx) / (2.0 * sx * sx) - (dy * dy) / (2.0 * sy * sy)).exp();
                let cell = &mut heat[gy as usize * cells_w + gx as usize];
                *cell = cell.max(g);
            }
        }
        let at = iy * cells_w + ix;
        t.mask[at] = 1.0;
        let values = [cx - ix as f32, cy - iy as f32, (w / stride).ln(), (h / stride).ln()];
        for (c, v) in values.into_iter().enumerate() {
            t.boxes[c * plane + at] = v;
        }
    }
    t
}

/// Most detections kept per image, best first.
pub const MAX_DETECTIONS: usize = 100;

/// Boxes from one image's maps: `heat` the class probabilities `[11, h, w]` and `boxes` the
/// box map `[4, h, w]`. A detection is a cell whose probability is at least `min_score` and the
/// largest of its 3 x 3 neighbourhood in its class; its box is clipped to the `width x height`
/// image. At most [`MAX_DETECTIONS`], best first (ties by class, then cell, so the order is
/// the same on every machine).
#[must_use]
pub fn decode(
    heat: &[f32],
    boxes: &[f32],
    (cells_w, cells_h): (usize, usize),
    (width, height): (usize, usize),
    min_score: f32,
) -> Vec<Detection> {
    let plane = cells_w * cells_h;
    let mut peaks: Vec<(f32, usize, usize)> = Vec::new();
    for class in 0..NUM_CLASSES {
        let map = &heat[class * plane..(class + 1) * plane];
        for y in 0..cells_h {
            for x in 0..cells_w {
                let v = map[y * cells_w + x];
                if v < min_score || !is_local_max(map, (cells_w, cells_h), x, y) {
                    continue;
                }
                peaks.push((v, class, y * cells_w + x));
            }
        }
    }
    peaks.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    peaks.truncate(MAX_DETECTIONS);
    let stride = STRIDE_PX as f32;
    let (width, height) = (width as f32, height as f32);
    peaks
        .into_iter()
        .filter_map(|(score, class, at)| {
            let (ix, iy) = ((at % cells_w) as f32, (at / cells_w) as f32);
            let cx = (ix + boxes[at]) * stride;
            let cy = (iy + boxes[plane + at]) * stride;
            let w = boxes[2 * plane + at].clamp(-4.0, 6.0).exp() * stride;
            let h = boxes[3 * plane + at].clamp(-4.0, 6.0).exp() * stride;
            let (x0, y0) = ((cx - w / 2.0).clamp(0.0, width), (cy - h / 2.0).clamp(0.0, height));
            let (x1, y1) = ((cx + w / 2.0).clamp(0.0, width), (cy + h / 2.0).clamp(0.0, height));
            (x1 > x0 && y1 > y0).then(|| Detection {
                category_id: class as u32 + 1,
                bbox: [f64::from(x0), f64::from(y0), f64::from(x1 - x0), f64::from(y1 - y0)],
                score: f64::from(score),
            })
        })
        .collect()
}

/// Whether cell `(x, y)` holds the largest value of its 3 x 3 neighbourhood (ties keep the
/// first in reading order, so a flat top gives one peak).
fn is_local_max(map: &[f32], (w, h): (usize, usize), x: usize, y: usize) -> bool {
    let v = map[y * w + x];
    for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
        for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
            let n = map[ny * w + nx];
            let earlier = (ny, nx) < (y, x);
            if n > v || (earlier && n == v) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn logit_free_decode(t: &Targets, cells: (usize, usize), size: (usize, usize)) -> Vec<Detection> {
        decode(&t.heat, &t.boxes, cells, size, 0.5)
    }

    #[test]
    fn encoded_boxes_decode_to_themselves() {
        let boxes = [
            TargetBox { class: 0, bbox: [10.0, 20.0, 120.0, 60.0] },
            TargetBox { class: 9, bbox: [200.0, 150.0, 14.0, 11.0] },
            TargetBox { class: 10, bbox: [100.0, 200.0, 80.0, 9.0] },
        ];
        let t = encode(&boxes, 40, 30);
        let found = logit_free_decode(&t, (40, 30), (320, 240));
        assert_eq!(found.len(), 3, "{found:?}");
        for b in &boxes {
            let d = found.iter().find(|d| d.category_id == b.class as u32 + 1).unwrap();
            for (got, want) in d.bbox.iter().zip(b.bbox) {
                assert!((got - f64::from(want)).abs() < 1e-3, "{d:?} vs {b:?}");
            }
            assert!((d.score - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn heat_peaks_at_the_centre_and_falls_off() {
        let t = encode(&[TargetBox { class: 3, bbox: [80.0, 80.0, 64.0, 64.0] }], 40, 30);
        let plane = 40 * 30;
        let heat = &t.heat[3 * plane..4 * plane];
        let at = |x: usize, y: usize| heat[y * 40 + x];
        assert_eq!(at(14, 14), 1.0);
        assert!(at(15, 14) < 1.0 && at(15, 14) > at(16, 14) && at(16, 14) > 0.0);
        assert_eq!(t.mask.iter().sum::<f32>(), 1.0);
        assert!(t.heat[..3 * plane].iter().all(|&v| v == 0.0), "other classes stay cold");
    }

    #[test]
    fn a_plateau_gives_one_peak() {
        let heat = vec![0.9f32; NUM_CLASSES * 4];
        let boxes = vec![0.0f32; 4 * 4];
        let found = decode(&heat, &boxes, (2, 2), (16, 16), 0.5);
        assert_eq!(found.len(), NUM_CLASSES);
    }
}
