//! ORB features (oriented FAST + rotated BRIEF) computed the way OpenCV computes them, and the
//! matching the ORB paper evaluated them with (brute-force Hamming with cross-check, then a
//! RANSAC fundamental matrix).
//!
//! Why bit-compatible with OpenCV: the perception scores compare camera designs by how well a
//! standard feature pipeline copes with their images, and the reference numbers people know come
//! from `cv2.ORB_create`. Every step below follows OpenCV's arithmetic (fixed-point resize, its
//! f32 separable blur with a fused row pass, integer gradients with f32 Harris, its polynomial
//! atan2, half-to-even rounding) so keypoints and descriptors agree with OpenCV's, not just
//! resemble them: on the interop images 100 % of keypoints, angles and descriptors match.
//! Keypoints come out in a different order than OpenCV's (which follows its selection
//! algorithm), so cross-check ties between equal distances can pick different partners.
//! `tests/interop/check_orb.sh` measures the agreement against OpenCV itself.
//!
//! ```
//! use scene_gen_perception::orb::Orb;
//! let (w, h) = (160usize, 120usize);
//! let pixels: Vec<u8> = (0..w * h).map(|i| if (i % w / 20 + i / w / 20) % 2 == 0 { 40 } else { 200 }).collect();
//! let (keypoints, descriptors) = Orb::default().detect_and_compute((pixels.as_slice(), w, h)).unwrap();
//! assert_eq!(keypoints.len(), descriptors.len());
//! ```

mod brief;
mod fast;
mod harris;
mod matching;
mod orientation;
mod pyramid;
mod ransac;

pub use brief::{BLUR_KERNEL, PATTERN_31, descriptor_at};
pub use fast::{FastCorner, fast_detect};
pub use harris::harris_response;
pub use matching::{Match, hamming, match_cross_check};
pub use orientation::{UMAX_31, fast_atan2_deg, ic_angle};
pub use pyramid::{Level, features_per_level, level_scale, level_size, resize_linear_exact};
pub use ransac::{FundamentalRansac, Mat3, RansacResult, epipolar_error, fundamental_7point};

/// Errors of ORB extraction.
#[derive(Debug, thiserror::Error)]
pub enum OrbError {
    #[error("image buffer holds {got} bytes but {width}x{height} needs {need}")]
    BufferSize { got: usize, need: usize, width: usize, height: usize },
    #[error("image is empty ({width}x{height})")]
    Empty { width: usize, height: usize },
    #[error("bad ORB parameter: {0}")]
    Parameter(String),
}

/// A detected keypoint, in pixels of the input image (OpenCV's `cv::KeyPoint` fields).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct KeyPoint {
    pub x: f32,
    pub y: f32,
    /// Diameter of the described patch: 31 * 1.2^octave.
    pub size: f32,
    /// Orientation in degrees, 0..360, image y axis pointing down.
    pub angle_deg: f32,
    /// Harris response (OpenCV's scaling).
    pub response: f32,
    /// Pyramid level the keypoint was found on.
    pub octave: u32,
}

/// A borrowed 8-bit grey image: row-major, `width` bytes per row.
#[derive(Clone, Copy, Debug)]
pub struct GrayView<'a> {
    pub data: &'a [u8],
    pub width: usize,
    pub height: usize,
}

impl<'a> From<&'a image::GrayImage> for GrayView<'a> {
    fn from(img: &'a image::GrayImage) -> Self {
        GrayView { data: img.as_raw(), width: img.width() as usize, height: img.height() as usize }
    }
}

impl<'a> From<(&'a [u8], usize, usize)> for GrayView<'a> {
    fn from((data, width, height): (&'a [u8], usize, usize)) -> Self {
        GrayView { data, width, height }
    }
}

/// ORB parameters; `Default` is OpenCV's `ORB_create()` (WTA_K 2, Harris score, first level 0).
#[derive(Clone, Debug, PartialEq)]
pub struct Orb {
    pub n_features: usize,
    pub scale_factor: f64,
    pub n_levels: usize,
    pub edge_threshold: usize,
    pub fast_threshold: u8,
    /// Only 31 is supported: the embedded sampling pattern is OpenCV's 31x31 one.
    pub patch_size: usize,
}

impl Default for Orb {
    fn default() -> Self {
        // OpenCV ORB_create defaults (features2d/orb.cpp).
        Orb { n_features: 500, scale_factor: 1.2, n_levels: 8, edge_threshold: 31, fast_threshold: 20, patch_size: 31 }
    }
}

/// Harris detector free parameter used by OpenCV's ORB (HARRIS_K in orb.cpp).
const HARRIS_K: f32 = 0.04;
/// Harris block size used by OpenCV's ORB.
const HARRIS_BLOCK: usize = 7;

impl Orb {
    /// An ORB with OpenCV's defaults and `n_features` features.
    #[must_use]
    pub fn with_features(n_features: usize) -> Self {
        Orb { n_features, ..Orb::default() }
    }

    /// Padding of each pyramid level, as OpenCV: max(edge, ceil(half_patch * sqrt 2), 9 / 2) + 1.
    fn border(&self) -> usize {
        let half = self.patch_size / 2;
        let desc = (half as f64 * std::f64::consts::SQRT_2).ceil() as usize;
        self.edge_threshold.max(desc).max(9 / 2) + 1
    }

    fn validate(&self) -> Result<(), OrbError> {
        if self.patch_size != 31 {
            return Err(OrbError::Parameter(format!("patch_size {} (only 31 is supported)", self.patch_size)));
        }
        if !(self.scale_factor > 1.0 && self.scale_factor.is_finite()) {
            return Err(OrbError::Parameter(format!("scale_factor {} (must be > 1)", self.scale_factor)));
        }
        if self.n_levels == 0 || self.n_levels > 32 {
            return Err(OrbError::Parameter(format!("n_levels {} (must be 1..=32)", self.n_levels)));
        }
        Ok(())
    }

    /// The image pyramid OpenCV's ORB works on (padded levels, not yet blurred).
    pub fn pyramid<'a>(&self, image: impl Into<GrayView<'a>>) -> Result<Vec<Level>, OrbError> {
        self.validate()?;
        let img = image.into();
        check_view(&img)?;
        Ok(pyramid::build(&img, self.n_levels, self.scale_factor, self.border()))
    }

    /// Detects keypoints and computes their 256-bit descriptors.
    ///
    /// Keypoints come level by level (octave 0 first), in row-major order within a level.
    pub fn detect_and_compute<'a>(
        &self,
        image: impl Into<GrayView<'a>>,
    ) -> Result<(Vec<KeyPoint>, Vec<[u8; 32]>), OrbError> {
        let mut levels = self.pyramid(image)?;
        let per_level = features_per_level(self.n_features, self.scale_factor, levels.len());
        let mut keypoints = Vec::with_capacity(self.n_features + 16);
        let mut level_pos: Vec<(u32, u32)> = Vec::with_capacity(self.n_features + 16);
        let mut scratch = fast::Scratch::default();
        for (l, level) in levels.iter().enumerate() {
            let want = per_level[l];
            if want == 0 {
                continue;
            }
            let mut corners = fast::detect_in(level, self.fast_threshold, self.edge_threshold, &mut scratch);
            // Keep 2n by FAST score (ties at the cut kept), then n by Harris (ties kept).
            retain_best(&mut corners, 2 * want, |c| f32::from(c.score));
            let mut scored: Vec<(FastCorner, f32)> = corners
                .into_iter()
                .map(|c| {
                    let r = harris_response(level, c.x as usize, c.y as usize, HARRIS_BLOCK, HARRIS_K);
                    (c, r)
                })
                .collect();
            retain_best(&mut scored, want, |s| s.1);
            // Row-major order within the level, for a stable output.
            scored.sort_unstable_by_key(|(c, _)| (c.y, c.x));
            let scale = level_scale(l, self.scale_factor);
            let size = self.patch_size as f32 * scale;
            for (c, response) in scored {
                let angle = ic_angle(level, c.x as usize, c.y as usize);
                keypoints.push(KeyPoint {
                    x: c.x as f32 * scale,
                    y: c.y as f32 * scale,
                    size,
                    angle_deg: angle,
                    response,
                    octave: l as u32,
                });
                level_pos.push((c.x, c.y));
            }
        }
        // Descriptors are read from the blurred levels (the angles above used the raw ones).
        let mut blur_buf = Vec::new();
        for (l, level) in levels.iter_mut().enumerate() {
            if keypoints.iter().any(|k| k.octave == l as u32) {
                brief::blur_level(level, &mut blur_buf);
            }
        }
        let descriptors = keypoints
            .iter()
            .zip(&level_pos)
            .map(|(k, &(x, y))| descriptor_at(&levels[k.octave as usize], x as usize, y as usize, k.angle_deg))
            .collect();
        Ok((keypoints, descriptors))
    }
}

fn check_view(img: &GrayView<'_>) -> Result<(), OrbError> {
    if img.width == 0 || img.height == 0 {
        return Err(OrbError::Empty { width: img.width, height: img.height });
    }
    let need = img.width.saturating_mul(img.height);
    if img.data.len() != need {
        return Err(OrbError::BufferSize { got: img.data.len(), need, width: img.width, height: img.height });
    }
    Ok(())
}

/// OpenCV's `KeyPointsFilter::retainBest`: keeps the `n` items with the largest score and every
/// item tied with the n-th score, so the kept set does not depend on sort order.
pub fn retain_best<T>(items: &mut Vec<T>, n: usize, score: impl Fn(&T) -> f32) {
    if items.len() <= n {
        return;
    }
    if n == 0 {
        items.clear();
        return;
    }
    let mut scores: Vec<f32> = items.iter().map(&score).collect();
    let (_, nth, _) = scores.select_nth_unstable_by(n - 1, |a, b| b.total_cmp(a));
    let cut = *nth;
    items.retain(|t| score(t) >= cut);
}

/// Cross-checked Hamming matches from image A (query) to image B (train) and, per match,
/// whether it is a RANSAC inlier of a fundamental matrix (all false when RANSAC has too few
/// matches or finds no model).
#[must_use]
pub fn match_and_verify(
    keypoints_a: &[KeyPoint],
    descriptors_a: &[[u8; 32]],
    keypoints_b: &[KeyPoint],
    descriptors_b: &[[u8; 32]],
    ransac: &FundamentalRansac,
) -> (Vec<Match>, Vec<bool>) {
    let matches = match_cross_check(descriptors_a, descriptors_b);
    let p1: Vec<[f64; 2]> = matches
        .iter()
        .map(|m| {
            let k = keypoints_a[m.query as usize];
            [f64::from(k.x), f64::from(k.y)]
        })
        .collect();
    let p2: Vec<[f64; 2]> = matches
        .iter()
        .map(|m| {
            let k = keypoints_b[m.train as usize];
            [f64::from(k.x), f64::from(k.y)]
        })
        .collect();
    let inliers = ransac.run(&p1, &p2).map_or_else(|| vec![false; matches.len()], |r| r.inliers);
    (matches, inliers)
}
