//! COCO bounding-box evaluation: AP@0.5, AP@[.5:.95] and per-class AP, computed the way
//! pycocotools' `COCOeval(iouType="bbox")` computes them (checked against pycocotools 2.0.11
//! by `tests/interop/check_coco.sh`).
//!
//! What is reproduced, step by step (names as in pycocotools' `cocoeval.py`):
//!
//! * **Grouping.** Images are the ground-truth file's `images`, sorted by id; categories its
//!   `categories`, sorted by id. Annotations and detections on other categories are dropped; a
//!   detection on an image the ground truth does not list is an error (pycocotools asserts).
//!   Within one (image, category) cell both lists keep their file order.
//! * **Detections** get `area = w * h` and `iscrowd = 0`, as `COCO.loadRes` gives them.
//! * **Ignore flags.** A ground-truth box is ignored when `iscrowd` is set or its `area` (from
//!   the file, not from the box) lies outside the area range "all", `[0, 1e10]`.
//! * **IoU** of box pairs as `maskApi.c`'s `bbIou`, in the same f64 operation order; for a crowd
//!   ground truth the union is the detection's area.
//! * **Matching** per (image, category) and IoU threshold: detections sorted by descending
//!   score with a stable sort (ties keep file order), at most [`MAX_DETS`] of them; ground
//!   truths with non-ignored ones first (stable). Each detection takes the unmatched (or crowd)
//!   ground truth of highest IoU at or above `min(t, 1 - 1e-10)`, preferring non-ignored ones
//!   and stopping at the first ignored one once it holds a non-ignored match; a detection
//!   matched to an ignored ground truth is ignored.
//! * **Accumulation** per category over all images: detections in descending score (stable
//!   sort over the concatenation in image order), cumulative TP/FP, `recall = tp / npig`,
//!   `precision = tp / (tp + fp + eps)` with `eps = 2^-52`, the monotone (right-to-left
//!   maximum) envelope, read at the 101 recall thresholds `0, 0.01, ..., 1` with a left
//!   `searchsorted`; thresholds beyond the last recall get precision 0.
//! * **AP** of a category: the mean of its precision entries (over the 101 recall points, and
//!   over the ten IoU thresholds `.50:.05:.95` for AP@[.5:.95]); `-1` for a category with no
//!   non-ignored ground truth, which the means over categories leave out.
//!
//! One deliberate difference: pycocotools marks matches with the ground truth's annotation id,
//! so a ground truth whose id is 0 never counts as matched; here a match is a flag, and ids
//! play no part.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

/// Detections kept per image and category (pycocotools' largest `maxDets`).
pub const MAX_DETS: usize = 100;

/// Upper bound of the area range "all" (pycocotools: `1e5 ** 2`).
pub const AREA_ALL_MAX: f64 = 1e10;

/// Number of recall thresholds (`np.linspace(0, 1, 101)`).
pub const RECALL_POINTS: usize = 101;

/// Number of IoU thresholds (`np.linspace(.5, .95, 10)`).
pub const IOU_THRESHOLDS: usize = 10;

/// Why an evaluation could not run.
#[derive(Debug, thiserror::Error)]
pub enum CocoError {
    #[error("detection {index} is on image {image_id}, which the ground truth does not list")]
    UnknownImage { index: usize, image_id: u64 },
    #[error("{what} {index}: {why}")]
    BadValue { what: &'static str, index: usize, why: String },
    #[error("reading {path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("parsing {path}: {source}")]
    Json { path: String, source: serde_json::Error },
}

/// An image entry of a COCO file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CocoImage {
    pub id: u64,
    #[serde(default)]
    pub width: u32,
    #[serde(default)]
    pub height: u32,
    #[serde(default)]
    pub file_name: String,
}

/// A category entry of a COCO file.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct CocoCategory {
    pub id: u32,
    #[serde(default)]
    pub name: String,
}

/// A ground-truth box: `bbox` is `[x, y, width, height]` in pixels from the top-left corner.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GtAnnotation {
    #[serde(default)]
    pub id: u64,
    pub image_id: u64,
    pub category_id: u32,
    pub bbox: [f64; 4],
    /// The area used for the area ranges (COCO: the segment's area; here usually `w * h` or
    /// the visible pixel count).
    pub area: f64,
    /// 0 or 1; crowd regions are ignored and may match any number of detections.
    #[serde(default)]
    pub iscrowd: u8,
}

/// A scored detection, as in a COCO results file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectionRecord {
    pub image_id: u64,
    pub category_id: u32,
    pub bbox: [f64; 4],
    pub score: f64,
}

/// A COCO ground-truth file: images, annotations, categories.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CocoGroundTruth {
    pub images: Vec<CocoImage>,
    pub annotations: Vec<GtAnnotation>,
    pub categories: Vec<CocoCategory>,
}

impl CocoGroundTruth {
    /// Reads a COCO ground-truth JSON file.
    ///
    /// # Errors
    /// [`CocoError::Io`] or [`CocoError::Json`] naming the file.
    pub fn read(path: &Path) -> Result<CocoGroundTruth, CocoError> {
        read_json(path)
    }

    /// The JSON text of this file.
    ///
    /// # Errors
    /// Only if serialisation fails (it does not for finite numbers).
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string(self)
    }
}

/// Reads a COCO results file (a JSON array of detections).
///
/// # Errors
/// [`CocoError::Io`] or [`CocoError::Json`] naming the file.
pub fn read_detections(path: &Path) -> Result<Vec<DetectionRecord>, CocoError> {
    read_json(path)
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, CocoError> {
    let text =
        std::fs::read_to_string(path).map_err(|source| CocoError::Io { path: path.display().to_string(), source })?;
    serde_json::from_str(&text).map_err(|source| CocoError::Json { path: path.display().to_string(), source })
}

/// AP of one category; `-1` where the category has no non-ignored ground truth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClassAp {
    pub category_id: u32,
    pub name: String,
    /// Non-ignored ground-truth boxes of the category.
    pub num_gt: usize,
    pub ap50: f64,
    /// AP@[.5:.95].
    pub ap: f64,
}

/// The summary numbers (area "all", 100 detections per image), pycocotools' `stats[0]` and
/// `stats[1]`, plus the per-category values they average.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CocoMetrics {
    /// AP@[.5:.95] (mAP in COCO's sense); `-1` when no category has ground truth.
    pub ap: f64,
    /// AP@0.5 (mAP@0.5 in the VOC sense); `-1` when no category has ground truth.
    pub ap50: f64,
    /// One entry per ground-truth category, in id order.
    pub per_class: Vec<ClassAp>,
}

/// The ten IoU thresholds `.50:.05:.95`, bit-identical to `np.linspace(.5, 0.95, 10)`.
#[must_use]
pub fn iou_thresholds() -> [f64; IOU_THRESHOLDS] {
    // numpy: step = (stop - start) / (num - 1); y = arange(num) * step + start; y[-1] = stop.
    let step = (0.95 - 0.5) / 9.0;
    std::array::from_fn(|i| if i == IOU_THRESHOLDS - 1 { 0.95 } else { i as f64 * step + 0.5 })
}

/// The 101 recall thresholds, bit-identical to `np.linspace(0, 1, 101)`.
#[must_use]
pub fn recall_thresholds() -> [f64; RECALL_POINTS] {
    let step = 1.0 / 100.0;
    std::array::from_fn(|i| if i == RECALL_POINTS - 1 { 1.0 } else { i as f64 * step })
}

/// IoU of a detection box and a ground-truth box (`[x, y, w, h]`), as `bbIou` in pycocotools'
/// `maskApi.c`: for a crowd ground truth the union is the detection's area.
#[must_use]
pub fn box_iou(dt: &[f64; 4], gt: &[f64; 4], crowd: bool) -> f64 {
    let ga = gt[2] * gt[3];
    let da = dt[2] * dt[3];
    let w = (dt[2] + dt[0]).min(gt[2] + gt[0]) - dt[0].max(gt[0]);
    if w <= 0.0 {
        return 0.0;
    }
    let h = (dt[3] + dt[1]).min(gt[3] + gt[1]) - dt[1].max(gt[1]);
    if h <= 0.0 {
        return 0.0;
    }
    let i = w * h;
    let u = if crowd { da } else { da + ga - i };
    i / u
}

/// Matching result of one (image, category) cell: per IoU threshold, per detection (sorted by
/// score, at most [`MAX_DETS`]) whether it matched and whether it is ignored; and the ignore
/// flags of its ground truth.
struct CellEval {
    scores: Vec<f64>,
    /// `[t][d]`
    matched: Vec<Vec<bool>>,
    /// `[t][d]`
    ignored: Vec<Vec<bool>>,
    gt_ignored: Vec<bool>,
}

/// Indices of `keys` in a stable ascending order (numpy's `argsort(kind='mergesort')`).
fn stable_argsort_desc(scores: &[f64]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..scores.len()).collect();
    // Descending by score == ascending by -score; total_cmp keeps it total for NaN-free input.
    idx.sort_by(|&a, &b| (-scores[a]).total_cmp(&(-scores[b])));
    idx
}

fn evaluate_cell(gts: &[&GtAnnotation], dts: &[&DetectionRecord], thresholds: &[f64; IOU_THRESHOLDS]) -> CellEval {
    let gt_ignore_raw: Vec<bool> =
        gts.iter().map(|g| g.iscrowd != 0 || !(0.0..=AREA_ALL_MAX).contains(&g.area)).collect();
    // Non-ignored ground truth first, stable.
    let mut gt_order: Vec<usize> = (0..gts.len()).collect();
    gt_order.sort_by_key(|&i| gt_ignore_raw[i]);
    let gt: Vec<&GtAnnotation> = gt_order.iter().map(|&i| gts[i]).collect();
    let gt_ignored: Vec<bool> = gt_order.iter().map(|&i| gt_ignore_raw[i]).collect();
    let scores_all: Vec<f64> = dts.iter().map(|d| d.score).collect();
    let mut dt_order = stable_argsort_desc(&scores_all);
    dt_order.truncate(MAX_DETS);
    let dt: Vec<&DetectionRecord> = dt_order.iter().map(|&i| dts[i]).collect();
    let crowd: Vec<bool> = gt.iter().map(|g| g.iscrowd != 0).collect();
    let ious: Vec<Vec<f64>> =
        dt.iter().map(|d| gt.iter().zip(&crowd).map(|(g, &c)| box_iou(&d.bbox, &g.bbox, c)).collect()).collect();
    let (n_t, n_d, n_g) = (thresholds.len(), dt.len(), gt.len());
    let mut matched = vec![vec![false; n_d]; n_t];
    let mut ignored = vec![vec![false; n_d]; n_t];
    for (ti, &t) in thresholds.iter().enumerate() {
        let mut gt_taken = vec![false; n_g];
        for di in 0..n_d {
            let mut best_iou = t.min(1.0 - 1e-10);
            let mut m: Option<usize> = None;
            for gi in 0..n_g {
                if gt_taken[gi] && !crowd[gi] {
                    continue;
                }
                if let Some(mi) = m
                    && !gt_ignored[mi]
                    && gt_ignored[gi]
                {
                    break;
                }
                if ious[di][gi] < best_iou {
                    continue;
                }
                best_iou = ious[di][gi];
                m = Some(gi);
            }
            if let Some(mi) = m {
                ignored[ti][di] = gt_ignored[mi];
                matched[ti][di] = true;
                gt_taken[mi] = true;
            }
        }
        // Unmatched detections outside the area range are ignored.
        for di in 0..n_d {
            let area = dt[di].bbox[2] * dt[di].bbox[3];
            if !matched[ti][di] && !(0.0..=AREA_ALL_MAX).contains(&area) {
                ignored[ti][di] = true;
            }
        }
    }
    CellEval { scores: dt.iter().map(|d| d.score).collect(), matched, ignored, gt_ignored }
}

/// Interpolated precision at the 101 recall thresholds for one category and one IoU
/// threshold, from its detections in descending score order.
fn precision_curve(tp_flags: &[bool], fp_flags: &[bool], npig: usize, rec_thr: &[f64; RECALL_POINTS]) -> Vec<f64> {
    let mut tp = 0.0f64;
    let mut fp = 0.0f64;
    let mut rc = Vec::with_capacity(tp_flags.len());
    let mut pr = Vec::with_capacity(tp_flags.len());
    for (&t, &f) in tp_flags.iter().zip(fp_flags) {
        tp += f64::from(u8::from(t));
        fp += f64::from(u8::from(f));
        rc.push(tp / npig as f64);
        pr.push(tp / (fp + tp + f64::EPSILON));
    }
    for i in (1..pr.len()).rev() {
        if pr[i] > pr[i - 1] {
            pr[i - 1] = pr[i];
        }
    }
    let mut q = vec![0.0; RECALL_POINTS];
    for (ri, &r) in rec_thr.iter().enumerate() {
        // searchsorted(side='left'): the first index with rc[i] >= r.
        let pi = rc.partition_point(|&x| x < r);
        if pi >= pr.len() {
            break;
        }
        q[ri] = pr[pi];
    }
    q
}

/// Evaluates `detections` against `gt` as pycocotools' `COCOeval` (bbox, area "all",
/// `maxDets = 100`) does; see the module docs for the exact procedure.
///
/// # Errors
/// [`CocoError::UnknownImage`] for a detection on an image the ground truth does not list;
/// [`CocoError::BadValue`] for a non-finite box, area or score.
pub fn evaluate(gt: &CocoGroundTruth, detections: &[DetectionRecord]) -> Result<CocoMetrics, CocoError> {
    for (index, a) in gt.annotations.iter().enumerate() {
        if !(a.bbox.iter().all(|v| v.is_finite()) && a.area.is_finite()) {
            return Err(CocoError::BadValue { what: "annotation", index, why: "bbox and area must be finite".into() });
        }
    }
    let image_ids: std::collections::BTreeSet<u64> = gt.images.iter().map(|i| i.id).collect();
    for (index, d) in detections.iter().enumerate() {
        if !(d.bbox.iter().all(|v| v.is_finite()) && d.score.is_finite()) {
            return Err(CocoError::BadValue { what: "detection", index, why: "bbox and score must be finite".into() });
        }
        if !image_ids.contains(&d.image_id) {
            return Err(CocoError::UnknownImage { index, image_id: d.image_id });
        }
    }
    let mut categories: Vec<&CocoCategory> = gt.categories.iter().collect();
    categories.sort_by_key(|c| c.id);
    categories.dedup_by_key(|c| c.id);
    // (category, image) -> items in file order.
    let mut gt_cells: BTreeMap<(u32, u64), Vec<&GtAnnotation>> = BTreeMap::new();
    for a in &gt.annotations {
        if image_ids.contains(&a.image_id) {
            gt_cells.entry((a.category_id, a.image_id)).or_default().push(a);
        }
    }
    let mut dt_cells: BTreeMap<(u32, u64), Vec<&DetectionRecord>> = BTreeMap::new();
    for d in detections {
        dt_cells.entry((d.category_id, d.image_id)).or_default().push(d);
    }
    let thresholds = iou_thresholds();
    let rec_thr = recall_thresholds();
    let mut per_class = Vec::with_capacity(categories.len());
    for cat in categories {
        let mut cells = Vec::new();
        for &img in &image_ids {
            let g = gt_cells.get(&(cat.id, img)).map_or(&[][..], Vec::as_slice);
            let d = dt_cells.get(&(cat.id, img)).map_or(&[][..], Vec::as_slice);
            if g.is_empty() && d.is_empty() {
                continue;
            }
            cells.push(evaluate_cell(g, d, &thresholds));
        }
        let npig = cells.iter().flat_map(|c| &c.gt_ignored).filter(|&&ig| !ig).count();
        if npig == 0 {
            per_class.push(ClassAp { category_id: cat.id, name: cat.name.clone(), num_gt: 0, ap50: -1.0, ap: -1.0 });
            continue;
        }
        // Concatenate in image order, then a stable sort by descending score.
        let scores: Vec<f64> = cells.iter().flat_map(|c| c.scores.iter().copied()).collect();
        let order = stable_argsort_desc(&scores);
        let mut sums = [0.0f64; IOU_THRESHOLDS];
        for (ti, sum) in sums.iter_mut().enumerate() {
            let matched: Vec<bool> = cells.iter().flat_map(|c| c.matched[ti].iter().copied()).collect();
            let ignored: Vec<bool> = cells.iter().flat_map(|c| c.ignored[ti].iter().copied()).collect();
            let tps: Vec<bool> = order.iter().map(|&i| matched[i] && !ignored[i]).collect();
            let fps: Vec<bool> = order.iter().map(|&i| !matched[i] && !ignored[i]).collect();
            *sum = precision_curve(&tps, &fps, npig, &rec_thr).iter().sum();
        }
        let ap50 = sums[0] / RECALL_POINTS as f64;
        let ap = sums.iter().sum::<f64>() / (RECALL_POINTS * IOU_THRESHOLDS) as f64;
        per_class.push(ClassAp { category_id: cat.id, name: cat.name.clone(), num_gt: npig, ap50, ap });
    }
    let mean = |f: fn(&ClassAp) -> f64| {
        let valid: Vec<f64> = per_class.iter().map(f).filter(|&v| v > -1.0).collect();
        if valid.is_empty() { -1.0 } else { valid.iter().sum::<f64>() / valid.len() as f64 }
    };
    Ok(CocoMetrics { ap: mean(|c| c.ap), ap50: mean(|c| c.ap50), per_class })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gt_file(boxes: &[(u64, u32, [f64; 4])]) -> CocoGroundTruth {
        let mut images: Vec<u64> = boxes.iter().map(|b| b.0).collect();
        images.sort_unstable();
        images.dedup();
        CocoGroundTruth {
            images: images
                .into_iter()
                .map(|id| CocoImage { id, width: 640, height: 480, file_name: String::new() })
                .collect(),
            annotations: boxes
                .iter()
                .enumerate()
                .map(|(i, &(image_id, category_id, bbox))| GtAnnotation {
                    id: i as u64 + 1,
                    image_id,
                    category_id,
                    bbox,
                    area: bbox[2] * bbox[3],
                    iscrowd: 0,
                })
                .collect(),
            categories: (1..=3).map(|id| CocoCategory { id, name: format!("c{id}") }).collect(),
        }
    }

    /// Precision is `tp / (tp + fp + eps)` as in pycocotools, so "1" is 1 - 2e-16.
    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    fn det(image_id: u64, category_id: u32, bbox: [f64; 4], score: f64) -> DetectionRecord {
        DetectionRecord { image_id, category_id, bbox, score }
    }

    #[test]
    fn thresholds_match_numpy_linspace() {
        let t = iou_thresholds();
        // Bit patterns printed by numpy 2.4.6 for np.linspace(.5, .95, 10).
        assert_eq!(t[1].to_bits(), 0x3FE1_9999_9999_999A);
        assert_eq!(t[3].to_bits(), 0x3FE4_CCCC_CCCC_CCCD);
        assert_eq!(t[9], 0.95);
        let r = recall_thresholds();
        assert_eq!(r[0], 0.0);
        assert_eq!(r[100], 1.0);
        assert_eq!(r[7], 7.0 * 0.01);
    }

    #[test]
    fn iou_of_boxes() {
        let a = [0.0, 0.0, 10.0, 10.0];
        assert_eq!(box_iou(&a, &a, false), 1.0);
        assert_eq!(box_iou(&[5.0, 0.0, 10.0, 10.0], &a, false), 50.0 / 150.0);
        assert_eq!(box_iou(&[10.0, 0.0, 10.0, 10.0], &a, false), 0.0, "touching boxes do not overlap");
        // Crowd: intersection over the detection's own area.
        assert_eq!(box_iou(&[5.0, 0.0, 10.0, 10.0], &a, true), 0.5);
    }

    #[test]
    fn perfect_detector_scores_one_and_absent_classes_are_minus_one() {
        let gt =
            gt_file(&[(1, 1, [0.0, 0.0, 10.0, 10.0]), (1, 2, [20.0, 20.0, 30.0, 5.0]), (2, 1, [5.0, 5.0, 8.0, 8.0])]);
        let dets: Vec<_> = gt.annotations.iter().map(|a| det(a.image_id, a.category_id, a.bbox, 0.9)).collect();
        let m = evaluate(&gt, &dets).unwrap();
        assert!(close(m.ap, 1.0));
        assert!(close(m.ap50, 1.0));
        assert_eq!(m.per_class[2].ap, -1.0, "class 3 has no ground truth");
        assert_eq!(m.per_class[0].num_gt, 2);
    }

    #[test]
    fn false_positive_above_the_true_positive_halves_precision() {
        let gt = gt_file(&[(1, 1, [0.0, 0.0, 10.0, 10.0])]);
        // Rank 1: a false positive far away; rank 2: the exact box. Precision at recall 1 is
        // 1/2 at every recall threshold (the envelope carries 0.5 back to recall 0).
        let dets = [det(1, 1, [100.0, 100.0, 10.0, 10.0], 0.9), det(1, 1, [0.0, 0.0, 10.0, 10.0], 0.8)];
        let m = evaluate(&gt, &dets).unwrap();
        assert!((m.ap50 - 0.5).abs() < 1e-12, "{}", m.ap50);
        assert!((m.ap - 0.5).abs() < 1e-12);
        // The same pair with the scores swapped is perfect.
        let dets = [det(1, 1, [100.0, 100.0, 10.0, 10.0], 0.7), det(1, 1, [0.0, 0.0, 10.0, 10.0], 0.8)];
        assert!(close(evaluate(&gt, &dets).unwrap().ap50, 1.0));
    }

    #[test]
    fn iou_threshold_and_half_recall() {
        // Two objects; one detection exact, the other shifted to IoU 1/3 (below 0.5): recall
        // 0.5, precision 1 up to it and then 0 -> AP = 51 / 101 (thresholds 0..0.50).
        let gt = gt_file(&[(1, 1, [0.0, 0.0, 10.0, 10.0]), (1, 1, [50.0, 0.0, 10.0, 10.0])]);
        let dets = [det(1, 1, [0.0, 0.0, 10.0, 10.0], 0.9), det(1, 1, [55.0, 0.0, 10.0, 10.0], 0.8)];
        let m = evaluate(&gt, &dets).unwrap();
        assert!((m.ap50 - 51.0 / 101.0).abs() < 1e-12, "{}", m.ap50);
        // A box with IoU exactly 0.5 matches at 0.5 (>=) and at no higher threshold.
        let dets = [det(1, 1, [0.0, 0.0, 10.0, 10.0], 0.9), det(1, 1, [50.0, 0.0, 10.0, 5.0], 0.8)];
        let m = evaluate(&gt, &dets).unwrap();
        assert!(close(m.ap50, 1.0));
        assert!((m.ap - (1.0 + 9.0 * 51.0 / 101.0) / 10.0).abs() < 1e-12, "{}", m.ap);
    }

    #[test]
    fn duplicates_are_false_positives_and_crowds_are_ignored() {
        let mut gt = gt_file(&[(1, 1, [0.0, 0.0, 10.0, 10.0]), (1, 1, [40.0, 40.0, 20.0, 20.0])]);
        gt.annotations[1].iscrowd = 1;
        // Two detections on the one real object: the second is a duplicate (FP) at rank 2;
        // a detection inside the crowd region is ignored, neither TP nor FP.
        let dets = [
            det(1, 1, [0.0, 0.0, 10.0, 10.0], 0.9),
            det(1, 1, [45.0, 45.0, 5.0, 5.0], 0.85),
            det(1, 1, [0.5, 0.0, 10.0, 10.0], 0.8),
        ];
        let m = evaluate(&gt, &dets).unwrap();
        assert_eq!(m.per_class[0].num_gt, 1);
        assert!(close(m.ap50, 1.0), "the duplicate ranks below full recall");
        let dets = [det(1, 1, [0.5, 0.0, 10.0, 10.0], 0.95), dets[0].clone()];
        let m = evaluate(&gt, &dets).unwrap();
        assert!(close(m.ap50, 1.0), "the better-scored duplicate takes the match");
    }

    #[test]
    fn unknown_image_is_an_error() {
        let gt = gt_file(&[(1, 1, [0.0, 0.0, 10.0, 10.0])]);
        assert!(matches!(
            evaluate(&gt, &[det(9, 1, [0.0, 0.0, 1.0, 1.0], 0.5)]),
            Err(CocoError::UnknownImage { image_id: 9, .. })
        ));
        assert!(evaluate(&gt, &[det(1, 1, [f64::NAN, 0.0, 1.0, 1.0], 0.5)]).is_err());
    }
}
