//! The built-in detector: a detectability model in the spirit of Johnson's criteria and the
//! target-acquisition models built on them, run on the noisy image so that sensor, optics and
//! lighting change what is found.
//!
//! # The model, per counted ground-truth object
//!
//! 1. **Critical dimension** `D = sqrt(visible pixels)` (px): the square root of the visible
//!    area, the convention of the NVESD target-acquisition models (Vollmerhausen and Jacobs,
//!    "The Targeting Task Performance (TTP) Metric", NVESD report AMSEL-NV-TR-230, 2004), so
//!    occlusion shrinks it.
//! 2. **Contrast-to-noise ratio** `CNR = C / sigma`, on the noisy DN image. Object pixels are
//!    the instance's pixels, the ring is every other pixel of its box grown by `max(2, D / 4)`
//!    px on each side.
//!    * The contrast is the mean difference less what pixel-to-pixel variation adds to it:
//!      `C^2 = max(0, (m_o - m_r)^2 - v_o / n_o - v_r / n_r)`, with `m`, `v`, `n` the mean,
//!      sample variance and pixel count of object and ring. `(m_o - m_r)^2` alone is inflated
//!      by noise by `v_o / n_o + v_r / n_r` on average, so a featureless patch in noise would
//!      get a contrast; the correction makes `C^2` unbiased, and noise of any origin (the
//!      sensor's, or a renderer's sampling noise) never creates contrast.
//!    * `sigma` is the camera's noise at the levels of these pixels: with
//!      [`NoiseSource::ByLevel`], `sigma^2` is the mean of `table[level]^2` over the object's
//!      pixels and over the ring's, averaged; with [`NoiseSource::Uniform`] one value. The
//!      evaluator passes the table of [`super::output_noise`] (the sensor's EMVA 1288 noise
//!      through the ISP curve). [`NoiseSource::Measured`] estimates one value on the image,
//!      `1.4826 * median(|I(x+1, y) - I(x, y)|) / sqrt(2)` (a MAD estimate on horizontal
//!      differences, robust to edges), the fallback for an image of unknown origin: it
//!      measures every pixel-to-pixel variation, fine texture and a renderer's Monte Carlo
//!      noise included, not the camera's. Never below the 8-bit quantisation noise
//!      `1 / sqrt(12)` DN.
//! 3. **Resolvable cycles** `N = D / (2 s)`, with `s = max(1, k / CNR)` the smallest bar (px)
//!    that stands out of the noise: a bar of `s x s` pixels averages noise down by `s`, so its
//!    signal-to-noise ratio is `CNR s`, and it is seen when that reaches Rose's threshold
//!    `k` ([`ROSE_K`]). With a clean image (`CNR >= k`) `N` is the Nyquist count `D / 2`;
//!    with noise, the effective resolution coarsens and the object holds fewer cycles.
//! 4. **Probability** from the target-transfer probability function of the Johnson/ACQUIRE
//!    models, `P = (N / N50)^E / (1 + (N / N50)^E)`, `E = 2.7 + 0.7 N / N50` (J. A. Ratches
//!    et al., "Night Vision Laboratory Static Performance Model for Thermal Viewing Systems",
//!    ECOM-7043, 1975; the ACQUIRE form). `N50` is the cycles across the critical dimension for
//!    a 50 % chance ([`DEFAULT_N50_CYCLES`]).
//!
//! 5. **Truncation and occlusion**, off by default: `P` is multiplied by
//!    [`DetectabilityModel::truncated_factor`] when the object's visible box reaches the image
//!    border, and by `visible_fraction ^` [`DetectabilityModel::occlusion_exponent`]. A learned
//!    detector recognises a shape, and a cut or hidden one is harder than its pixel count
//!    says; `examples/detector_proxy.rs` fits both, with `N50`, to the learned detector.
//!
//! Each object is then detected with probability `P`: it is found when `P > u`, with `u`
//! uniform from the stream of (`frame_seed`, instance id); a detection carries `score = P` and
//! the visible box with each edge moved by a normal localisation error of standard deviation
//! `0.5 px + 4 %` of the box side on that axis (drawn from the same stream). The draw
//! matters: emitting every object with score `P` and no false positives would score AP = 1
//! however small `P` is, since AP only sees the ranking. `u` is the object's luck in that
//! view, not the image's: two versions of one frame given the same `frame_seed` (the
//! evaluator's day and night of a pose) draw the same `u` and box error per object, so an
//! object is found in one and missed in the other only because its `P` differs (common random
//! numbers), and raising `P` never loses a detection.
//!
//! **False positives** on textured clutter: the image is cut into cells of 32 px at 640 x 480
//! (scaled with the square root of the pixel count); a cell is clutter when its DN standard
//! deviation exceeds `3 sigma` at its mean level (structure, not noise) and none of it belongs to a counted
//! object (a box on part of a real object is a localisation error, not a false alarm on
//! clutter). Each clutter cell yields a false positive with probability
//! [`DetectabilityModel::false_positive_rate`] (default 2 %), of a uniformly drawn class
//! 1..=11, on the cell box (jittered like a detection), with a score uniform in
//! `[0, max_false_positive_score)` (default 0.5).
//!
//! # Calibration
//!
//! The constants are literature values, not fitted to a detector: Johnson (1958, "Analysis
//! of image forming systems", Image Intensifier Symposium) gave 1.0 +- 0.25 cycles for
//! detection and 4.0 for recognition; the default `N50 = 1.5` sits above detection because a
//! COCO match needs a box that overlaps by half, and [`DetectabilityModel::recognition`] gives
//! Johnson's 4.0 for a class-level task. `k = 5` is Rose's (A. Rose, "The sensitivity
//! performance of the human eye on an absolute scale", JOSA 38, 1948). The false-positive rate
//! and scores, and the localisation error, are engineering choices. Nothing was tuned to make
//! day score above night: the noise and contrast of step 2 are measurements, and the figures
//! below come from fixing what they measured.
//!
//! # Day and night
//!
//! On the evaluator's default camera (IMX174, 4 mm, pitch -10 deg, houses 0 and 1, 25
//! anchors, 320 px) this model used to score AP@0.5 0.74 by day and 0.97 at night. The noise
//! was measured on the image, and by day the image's pixel-to-pixel variation is mostly the
//! renderer's: one area-light sample per pixel on window-lit surfaces
//! ([`scene_gen_render::RenderSettings::preview`]). `examples/daynight_objects.rs`, on the 120
//! counted objects of those frames (means over objects, day / night):
//!
//! | noise figure | sigma (8-bit DN) | mean P |
//! | --- | --- | --- |
//! | measured on the image (the old rule) | 8.07 / 4.13 | 0.728 / 0.942 |
//! | the sensor's own: noisy minus noiseless capture, around each object | 0.90 / 4.61 | 0.947 / 0.934 |
//! | the camera's table ([`super::output_noise`], now) | 0.84 / 4.05 | 0.950 / 0.941 |
//!
//! With the sensor noise switched off the image estimate stays at 7.97 DN by day (1.09 at
//! night), and with 4 x 4 area-light samples and no light culling it falls to 2.3: it was the
//! renderer's noise, taken for the camera's. Turning false positives off changed nothing
//! because they were never the cause (their scores are below 0.5, under almost every true
//! detection). See `scene_gen_design::evaluate` ("Day versus night") for the AP figures now and what
//! is left.
//!
//! A real network can replace the whole model through the plug-in protocol of the
//! [module docs](super).

use rand::Rng;

use super::Detection;
use super::ground_truth::GtObject;
use scene_gen_camera::sensor::noise::normal;
use scene_gen_core::rng;

/// Rose's threshold signal-to-noise ratio for seeing a feature (Rose 1948).
pub const ROSE_K: f64 = 5.0;

/// Default `N50`: cycles across the critical dimension for a 50 % detection chance (see the
/// module docs for why 1.5 rather than Johnson's 1.0).
pub const DEFAULT_N50_CYCLES: f64 = 1.5;

/// Johnson's (1958) 50 % criterion for recognition, cycles across the critical dimension.
pub const JOHNSON_RECOGNITION_N50_CYCLES: f64 = 4.0;

/// Quantisation noise of integer DN, `1 / sqrt(12)`: the floor of the noise estimate.
pub const QUANTISATION_STD_DN: f64 = 0.288_675_134_594_812_9;

/// What a detector sees of one frame.
#[derive(Clone, Copy, Debug)]
pub struct DetectorInput<'a> {
    /// One channel (mono, or the luma of a colour image), DN, row-major `width x height`.
    pub image_dn: &'a [f32],
    pub width: u32,
    pub height: u32,
    /// The frame's instance buffer (0 = none), same layout.
    pub instance_id: &'a [u32],
    /// The frame's ground truth; only `counted` objects are candidates.
    pub objects: &'a [GtObject],
    /// Where the noise the contrast is divided by comes from.
    pub noise: NoiseSource<'a>,
    /// Seed of this frame's draws.
    pub frame_seed: u64,
}

/// The noise a [`DetectabilityModel`] divides contrast by (module docs, step 2).
#[derive(Clone, Copy, Debug)]
pub enum NoiseSource<'a> {
    /// Measured on the image ([`estimate_noise_std_dn`]): the fallback for an image of unknown
    /// origin. Texture and a renderer's sampling noise inflate it.
    Measured,
    /// One standard deviation for every pixel, DN.
    Uniform(f64),
    /// The standard deviation at each DN level: `table[round(DN)]` (the last entry beyond
    /// it), the camera's own noise through its output rule
    /// ([`super::output_noise::output_noise_by_level`]).
    ByLevel(&'a [f64]),
}

impl NoiseSource<'_> {
    /// The per-level table this source stands for on `input`'s image (one entry when the
    /// noise is the same at every level), each entry at least [`QUANTISATION_STD_DN`].
    #[must_use]
    pub fn table(&self, input: &DetectorInput<'_>) -> Vec<f64> {
        let floor = |s: f64| if s.is_finite() { s.max(QUANTISATION_STD_DN) } else { QUANTISATION_STD_DN };
        match *self {
            NoiseSource::Measured => vec![estimate_noise_std_dn(input.image_dn, input.width, input.height)],
            NoiseSource::Uniform(s) => vec![floor(s)],
            NoiseSource::ByLevel(t) if !t.is_empty() => t.iter().map(|&s| floor(s)).collect(),
            NoiseSource::ByLevel(_) => vec![QUANTISATION_STD_DN],
        }
    }
}

/// The entry of a per-level noise table for a DN value.
fn level_sigma(table: &[f64], dn: f32) -> f64 {
    let i = if dn.is_nan() || dn <= 0.0 { 0 } else { (dn.round() as usize).min(table.len() - 1) };
    table[i]
}

/// Anything that finds objects in a frame.
pub trait Detector {
    /// Detections in the frame, in a deterministic order.
    fn detect(&self, input: &DetectorInput<'_>) -> Vec<Detection>;
}

/// The Johnson-criteria detectability model of the module docs.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct DetectabilityModel {
    /// Cycles across the critical dimension for P = 0.5.
    pub n50_cycles: f64,
    /// Threshold SNR of a resolvable bar.
    pub rose_k: f64,
    /// Localisation error: constant part, px.
    pub loc_error_px: f64,
    /// Localisation error: fraction of the box side.
    pub loc_error_fraction: f64,
    /// Chance that a clutter cell yields a false positive.
    pub false_positive_rate: f64,
    /// False-positive scores are uniform in `[0, max)`.
    pub max_false_positive_score: f64,
    /// Clutter cell side at 640 x 480, px.
    pub clutter_cell_px_vga: f64,
    /// `P` of an object cut by the image border (its visible box touches an edge) is multiplied
    /// by this: a learned detector sees only part of the shape it was trained on. 1 (the
    /// default) leaves the Johnson model as it is; `examples/detector_proxy.rs` fits it.
    pub truncated_factor: f64,
    /// `P` is multiplied by `visible_fraction ^ occlusion_exponent`: an object partly hidden
    /// behind another is harder to recognise than its visible pixels alone say. 0 (the default)
    /// leaves the Johnson model as it is, whose critical dimension already shrinks with
    /// occlusion.
    pub occlusion_exponent: f64,
}

impl Default for DetectabilityModel {
    fn default() -> Self {
        DetectabilityModel::detection()
    }
}

impl DetectabilityModel {
    /// The defaults of the module docs (`N50 = 1.5`).
    #[must_use]
    pub const fn detection() -> DetectabilityModel {
        DetectabilityModel {
            n50_cycles: DEFAULT_N50_CYCLES,
            rose_k: ROSE_K,
            loc_error_px: 0.5,
            loc_error_fraction: 0.04,
            false_positive_rate: 0.02,
            max_false_positive_score: 0.5,
            clutter_cell_px_vga: 32.0,
            truncated_factor: 1.0,
            occlusion_exponent: 0.0,
        }
    }

    /// Johnson's recognition criterion (`N50 = 4`), the rest as [`Self::detection`].
    #[must_use]
    pub const fn recognition() -> DetectabilityModel {
        DetectabilityModel { n50_cycles: JOHNSON_RECOGNITION_N50_CYCLES, ..DetectabilityModel::detection() }
    }

    /// Resolvable cycles across a critical dimension of `critical_px` at contrast-to-noise
    /// ratio `cnr` (step 3 of the module docs).
    #[must_use]
    pub fn cycles(&self, critical_px: f64, cnr: f64) -> f64 {
        if cnr.is_nan() || cnr <= 0.0 {
            return 0.0;
        }
        let bar_px = (self.rose_k / cnr).max(1.0);
        critical_px / (2.0 * bar_px)
    }

    /// Detection probability from resolvable cycles (step 4).
    #[must_use]
    pub fn probability_from_cycles(&self, n: f64) -> f64 {
        if n.is_nan() || n <= 0.0 {
            return 0.0;
        }
        let r = n / self.n50_cycles;
        let e = 2.7 + 0.7 * r;
        let re = r.powf(e);
        if re.is_infinite() { 1.0 } else { re / (1.0 + re) }
    }

    /// Detection probability of an object of `critical_px` at `cnr`.
    #[must_use]
    pub fn probability(&self, critical_px: f64, cnr: f64) -> f64 {
        self.probability_from_cycles(self.cycles(critical_px, cnr))
    }
}

/// Robust temporal noise estimate of an image (DN): MAD of horizontal differences (see the
/// module docs), at least [`QUANTISATION_STD_DN`].
#[must_use]
pub fn estimate_noise_std_dn(image: &[f32], width: u32, height: u32) -> f64 {
    let w = width as usize;
    let mut diffs: Vec<f32> = Vec::with_capacity(image.len());
    for row in image.chunks_exact(w.max(1)).take(height as usize) {
        diffs.extend(row.windows(2).map(|p| (p[1] - p[0]).abs()));
    }
    if diffs.is_empty() {
        return QUANTISATION_STD_DN;
    }
    let mid = diffs.len() / 2;
    let (_, median, _) = diffs.select_nth_unstable_by(mid, f32::total_cmp);
    (1.4826 * f64::from(*median) / std::f64::consts::SQRT_2).max(QUANTISATION_STD_DN)
}

/// Contrast-to-noise ratio of an object against its ring (step 2 of the module docs), with the
/// noise from `sigma_by_level` ([`NoiseSource::table`]; a one-entry table is a uniform noise).
///
/// # Panics
/// If `sigma_by_level` is empty.
#[must_use]
pub fn object_cnr(input: &DetectorInput<'_>, object: &GtObject, sigma_by_level: &[f64]) -> f64 {
    assert!(!sigma_by_level.is_empty(), "a noise table needs at least one entry");
    let (w, h) = (input.width as i64, input.height as i64);
    let margin = (0.25 * f64::from(object.visible_px).sqrt()).max(2.0).round() as i64;
    let [bx, by, bw, bh] = object.bbox;
    let x0 = (bx as i64 - margin).max(0);
    let y0 = (by as i64 - margin).max(0);
    let x1 = ((bx + bw) as i64 + margin).min(w);
    let y1 = ((by + bh) as i64 + margin).min(h);
    // Sums of value, of its square and of the noise variance, object and ring.
    let (mut o, mut r) = ([0.0f64; 3], [0.0f64; 3]);
    let (mut no, mut nr) = (0u64, 0u64);
    for y in y0..y1 {
        for x in x0..x1 {
            let i = (y * w + x) as usize;
            let v = input.image_dn[i];
            let var = level_sigma(sigma_by_level, v).powi(2);
            let (acc, n) =
                if input.instance_id[i] == object.instance_id { (&mut o, &mut no) } else { (&mut r, &mut nr) };
            acc[0] += f64::from(v);
            acc[1] += f64::from(v) * f64::from(v);
            acc[2] += var;
            *n += 1;
        }
    }
    if no == 0 {
        return 0.0;
    }
    if nr == 0 {
        // The object fills the frame: nothing to contrast with, but nothing to miss either.
        return f64::INFINITY;
    }
    let (no, nr) = (no as f64, nr as f64);
    let (mo, mr) = (o[0] / no, r[0] / nr);
    // The squared mean difference less its expected inflation by pixel-to-pixel variation
    // (sample variances over the pixel counts): noise alone gives no contrast.
    let spread = (o[1] / no - mo * mo).max(0.0) / no + (r[1] / nr - mr * mr).max(0.0) / nr;
    let contrast = ((mo - mr).powi(2) - spread).max(0.0).sqrt();
    let sigma = (0.5 * (o[2] / no + r[2] / nr)).sqrt().max(QUANTISATION_STD_DN);
    contrast / sigma
}

/// Whether a visible box `[x, y, w, h]` reaches an edge of the `width x height` image.
fn touches_border([x, y, w, h]: [f64; 4], width: u32, height: u32) -> bool {
    x <= 0.5 || y <= 0.5 || x + w >= f64::from(width) - 0.5 || y + h >= f64::from(height) - 0.5
}

fn jitter_box(b: [f64; 4], model: &DetectabilityModel, width: u32, height: u32, rng: &mut impl Rng) -> [f64; 4] {
    let sx = model.loc_error_px + model.loc_error_fraction * b[2];
    let sy = model.loc_error_px + model.loc_error_fraction * b[3];
    let x0 = (b[0] + sx * normal(rng)).clamp(0.0, f64::from(width));
    let x1 = (b[0] + b[2] + sx * normal(rng)).clamp(0.0, f64::from(width));
    let y0 = (b[1] + sy * normal(rng)).clamp(0.0, f64::from(height));
    let y1 = (b[1] + b[3] + sy * normal(rng)).clamp(0.0, f64::from(height));
    let (x0, x1) = (x0.min(x1), x0.max(x1));
    let (y0, y1) = (y0.min(y1), y0.max(y1));
    [x0, y0, (x1 - x0).max(1.0), (y1 - y0).max(1.0)]
}

impl Detector for DetectabilityModel {
    /// Objects in instance-id order, then false positives in cell order.
    ///
    /// # Panics
    /// If the image or instance buffer is not `width x height`.
    fn detect(&self, input: &DetectorInput<'_>) -> Vec<Detection> {
        let n = input.width as usize * input.height as usize;
        assert_eq!(input.image_dn.len(), n, "image must be width x height");
        assert_eq!(input.instance_id.len(), n, "instance buffer must be width x height");
        let sigma = input.noise.table(input);
        let mut out = Vec::new();
        let mut objects: Vec<&GtObject> = input.objects.iter().filter(|o| o.counted).collect();
        objects.sort_by_key(|o| o.instance_id);
        for o in &objects {
            let p = self.object_probability(input, o, &sigma);
            let mut rng = rng::substream(input.frame_seed, "detection/object", u64::from(o.instance_id));
            if rng.random::<f64>() < p {
                out.push(Detection {
                    category_id: o.class_id,
                    bbox: jitter_box(o.bbox, self, input.width, input.height, &mut rng),
                    score: p,
                });
            }
        }
        self.false_positives(input, &sigma, &mut out);
        out
    }
}

impl DetectabilityModel {
    /// Detection probability of one object (steps 1 to 4 of the module docs), the noise from
    /// `sigma_by_level` ([`NoiseSource::table`]).
    #[must_use]
    pub fn object_probability(&self, input: &DetectorInput<'_>, object: &GtObject, sigma_by_level: &[f64]) -> f64 {
        let p = self.probability(f64::from(object.visible_px).sqrt(), object_cnr(input, object, sigma_by_level));
        let truncated =
            if touches_border(object.bbox, input.width, input.height) { self.truncated_factor } else { 1.0 };
        // `powf(0)` is 1 for every fraction, 0 included: the default exponent changes nothing.
        let occluded = object.visible_fraction.clamp(0.0, 1.0).powf(self.occlusion_exponent);
        (p * truncated * occluded).clamp(0.0, 1.0)
    }

    fn false_positives(&self, input: &DetectorInput<'_>, sigma_by_level: &[f64], out: &mut Vec<Detection>) {
        if self.false_positive_rate.is_nan() || self.false_positive_rate <= 0.0 {
            return;
        }
        let (w, h) = (input.width, input.height);
        let scale = (f64::from(w) * f64::from(h) / super::ground_truth::VGA_PIXELS).sqrt();
        let cell = (self.clutter_cell_px_vga * scale).round().max(8.0) as u32;
        let counted: Vec<u32> = input.objects.iter().filter(|o| o.counted).map(|o| o.instance_id).collect();
        let mut index = 0u64;
        for cy in (0..h).step_by(cell as usize) {
            for cx in (0..w).step_by(cell as usize) {
                index += 1;
                let (x1, y1) = ((cx + cell).min(w), (cy + cell).min(h));
                let (mut s, mut s2, mut k, mut on_object) = (0.0f64, 0.0f64, 0u64, 0u64);
                for y in cy..y1 {
                    for x in cx..x1 {
                        let i = y as usize * w as usize + x as usize;
                        let v = f64::from(input.image_dn[i]);
                        s += v;
                        s2 += v * v;
                        k += 1;
                        if counted.contains(&input.instance_id[i]) {
                            on_object += 1;
                        }
                    }
                }
                if k < 4 || on_object > 0 {
                    continue;
                }
                let mean = s / k as f64;
                let std = (s2 / k as f64 - mean * mean).max(0.0).sqrt();
                if std <= 3.0 * level_sigma(sigma_by_level, mean as f32) {
                    continue;
                }
                let mut rng = rng::substream(input.frame_seed, "detection/false_positive", index);
                if rng.random::<f64>() < self.false_positive_rate {
                    let category_id = rng.random_range(1..=scene_gen_scene::scene::THRESHOLD_CLASS_ID);
                    let b = [f64::from(cx), f64::from(cy), f64::from(x1 - cx), f64::from(y1 - cy)];
                    let bbox = jitter_box(b, self, w, h, &mut rng);
                    let score = rng.random::<f64>() * self.max_false_positive_score;
                    out.push(Detection { category_id, bbox, score });
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probability_is_half_at_n50_and_monotone() {
        let m = DetectabilityModel::detection();
        assert!((m.probability_from_cycles(1.5) - 0.5).abs() < 1e-12);
        assert_eq!(m.probability_from_cycles(0.0), 0.0);
        let mut last = 0.0;
        for i in 1..100 {
            let p = m.probability_from_cycles(f64::from(i) * 0.1);
            assert!(p > last, "P rises with cycles");
            last = p;
        }
        assert!(m.probability_from_cycles(6.0) > 0.999);
        // Clean: N = D / 2; noisy: the bar grows to k / CNR px.
        assert_eq!(m.cycles(20.0, 100.0), 10.0);
        assert_eq!(m.cycles(20.0, 0.5), 1.0);
        assert!(m.probability(20.0, 0.5) < m.probability(20.0, 2.0));
        assert!(m.probability(8.0, 10.0) < m.probability(16.0, 10.0));
        assert!(DetectabilityModel::recognition().probability(8.0, 10.0) < m.probability(8.0, 10.0));
    }

    #[test]
    fn noise_estimate_recovers_white_noise() {
        let mut r = rng::stream(1, "test");
        let (w, h) = (200u32, 100u32);
        // A step edge plus noise of std 4: the MAD estimate ignores the edge.
        let img: Vec<f32> =
            (0..w * h).map(|i| if i % w < w / 2 { 50.0 } else { 150.0 } + (4.0 * normal(&mut r)) as f32).collect();
        let s = estimate_noise_std_dn(&img, w, h);
        assert!((s - 4.0).abs() < 0.25, "{s}");
        assert_eq!(estimate_noise_std_dn(&vec![7.0; 100], 10, 10), QUANTISATION_STD_DN);
    }
}
