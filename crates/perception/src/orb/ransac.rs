//! Fundamental matrix by RANSAC over 7-point minimal samples, as OpenCV's
//! `findFundamentalMat(..., FM_RANSAC, threshold, confidence)` (calib3d fundam.cpp, ptsetreg.cpp):
//! a match's error is the larger of its two squared point-to-epipolar-line distances, inliers
//! have error <= threshold^2, the iteration count adapts to the best inlier ratio.

use rand::Rng;

/// A 3x3 matrix, row-major.
pub type Mat3 = [[f64; 3]; 3];

/// RANSAC settings; `Default` is the ORB paper's evaluation (3 px, 0.99, at least 15 matches)
/// with OpenCV's default iteration cap (1000).
#[derive(Clone, Debug, PartialEq)]
pub struct FundamentalRansac {
    pub threshold_px: f64,
    pub confidence: f64,
    pub max_iters: usize,
    pub min_matches: usize,
    /// Seed of the `scene_gen_core::rng` stream that draws the samples.
    pub seed: u64,
}

impl Default for FundamentalRansac {
    fn default() -> Self {
        FundamentalRansac { threshold_px: 3.0, confidence: 0.99, max_iters: 1000, min_matches: 15, seed: 0 }
    }
}

/// The best model and which correspondences agree with it.
#[derive(Clone, Debug, PartialEq)]
pub struct RansacResult {
    /// F with x2^T F x1 = 0 (first image's points on the right).
    pub f: Mat3,
    pub inliers: Vec<bool>,
    pub n_inliers: usize,
    /// Iterations run.
    pub iterations: usize,
}

/// Larger of the two squared distances: p2 to the epipolar line F p1, p1 to the line F^T p2
/// (OpenCV's FMEstimatorCallback::computeError).
#[must_use]
pub fn epipolar_error(f: &Mat3, p1: [f64; 2], p2: [f64; 2]) -> f64 {
    let a = f[0][0] * p1[0] + f[0][1] * p1[1] + f[0][2];
    let b = f[1][0] * p1[0] + f[1][1] * p1[1] + f[1][2];
    let c = f[2][0] * p1[0] + f[2][1] * p1[1] + f[2][2];
    let s2 = 1.0 / (a * a + b * b);
    let d2 = p2[0] * a + p2[1] * b + c;
    let a = f[0][0] * p2[0] + f[1][0] * p2[1] + f[2][0];
    let b = f[0][1] * p2[0] + f[1][1] * p2[1] + f[2][1];
    let c = f[0][2] * p2[0] + f[1][2] * p2[1] + f[2][2];
    let s1 = 1.0 / (a * a + b * b);
    let d1 = p1[0] * a + p1[1] * b + c;
    (d1 * d1 * s1).max(d2 * d2 * s2)
}

/// Hartley normalisation: centroid to the origin, mean distance sqrt 2.
fn normaliser(p: &[[f64; 2]]) -> (Mat3, Vec<[f64; 2]>) {
    let n = p.len() as f64;
    let (mx, my) = p.iter().fold((0.0, 0.0), |(x, y), q| (x + q[0] / n, y + q[1] / n));
    let mean_d = p.iter().map(|q| ((q[0] - mx).powi(2) + (q[1] - my).powi(2)).sqrt()).sum::<f64>() / n;
    let s = if mean_d > 1e-12 { std::f64::consts::SQRT_2 / mean_d } else { 1.0 };
    let t = [[s, 0.0, -s * mx], [0.0, s, -s * my], [0.0, 0.0, 1.0]];
    (t, p.iter().map(|q| [s * (q[0] - mx), s * (q[1] - my)]).collect())
}

fn det3(m: &Mat3) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

fn transpose(a: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| a[j][i]))
}

/// Real roots of c3 x^3 + c2 x^2 + c1 x + c0.
fn cubic_roots(c3: f64, c2: f64, c1: f64, c0: f64) -> Vec<f64> {
    let scale = c3.abs().max(c2.abs()).max(c1.abs()).max(c0.abs());
    if scale == 0.0 {
        return Vec::new();
    }
    if c3.abs() < 1e-12 * scale {
        // Quadratic (or linear).
        if c2.abs() < 1e-12 * scale {
            return if c1.abs() > 0.0 { vec![-c0 / c1] } else { Vec::new() };
        }
        let disc = c1 * c1 - 4.0 * c2 * c0;
        if disc < 0.0 {
            return Vec::new();
        }
        let q = -0.5 * (c1 + c1.signum() * disc.sqrt());
        let mut r = vec![q / c2];
        if q != 0.0 {
            r.push(c0 / q);
        }
        return r;
    }
    let (a, b, c) = (c2 / c3, c1 / c3, c0 / c3);
    let q = (a * a - 3.0 * b) / 9.0;
    let r = (2.0 * a * a * a - 9.0 * a * b + 27.0 * c) / 54.0;
    if r * r < q * q * q {
        let theta = (r / q.powf(1.5)).clamp(-1.0, 1.0).acos();
        let m = -2.0 * q.sqrt();
        let tau = 2.0 * std::f64::consts::PI;
        vec![
            m * (theta / 3.0).cos() - a / 3.0,
            m * ((theta + tau) / 3.0).cos() - a / 3.0,
            m * ((theta - tau) / 3.0).cos() - a / 3.0,
        ]
    } else {
        let big_a = -r.signum() * (r.abs() + (r * r - q * q * q).sqrt()).cbrt();
        let big_b = if big_a != 0.0 { q / big_a } else { 0.0 };
        vec![big_a + big_b - a / 3.0]
    }
}

/// The (up to three) fundamental matrices through 7 correspondences: the 2-D null space of the
/// epipolar constraints, and the combinations of its basis with zero determinant.
#[must_use]
pub fn fundamental_7point(p1: &[[f64; 2]], p2: &[[f64; 2]]) -> Vec<Mat3> {
    assert!(p1.len() == 7 && p2.len() == 7, "7 correspondences");
    let (t1, n1) = normaliser(p1);
    let (t2, n2) = normaliser(p2);
    let mut a = [[0.0f64; 9]; 7];
    for i in 0..7 {
        let ([x1, y1], [x2, y2]) = (n1[i], n2[i]);
        a[i] = [x2 * x1, x2 * y1, x2, y2 * x1, y2 * y1, y2, x1, y1, 1.0];
    }
    // Gauss-Jordan with full pivoting: 7 pivot columns, 2 free ones.
    let mut perm: [usize; 9] = std::array::from_fn(|i| i);
    for r in 0..7 {
        let (mut bi, mut bj, mut bv) = (r, r, 0.0);
        for (i, row) in a.iter().enumerate().skip(r) {
            for (j, v) in row.iter().enumerate().skip(r) {
                if v.abs() > bv {
                    (bi, bj, bv) = (i, j, v.abs());
                }
            }
        }
        if bv < 1e-10 {
            return Vec::new();
        }
        a.swap(r, bi);
        for row in &mut a {
            row.swap(r, bj);
        }
        perm.swap(r, bj);
        let p = a[r][r];
        for v in &mut a[r] {
            *v /= p;
        }
        let pivot_row = a[r];
        for (i, row) in a.iter_mut().enumerate() {
            if i != r {
                let f = row[r];
                if f != 0.0 {
                    for (v, pv) in row.iter_mut().zip(pivot_row) {
                        *v -= f * pv;
                    }
                }
            }
        }
    }
    let null = |free: usize| -> Mat3 {
        let mut x = [0.0; 9];
        x[perm[free]] = 1.0;
        for r in 0..7 {
            x[perm[r]] = -a[r][free];
        }
        [[x[0], x[1], x[2]], [x[3], x[4], x[5]], [x[6], x[7], x[8]]]
    };
    let (f1, f2) = (null(7), null(8));
    let comb =
        |al: f64| -> Mat3 { std::array::from_fn(|i| std::array::from_fn(|j| al * f1[i][j] + (1.0 - al) * f2[i][j])) };
    let (d0, d1, dm1, d2) = (det3(&comb(0.0)), det3(&comb(1.0)), det3(&comb(-1.0)), det3(&comb(2.0)));
    let c0 = d0;
    let c2 = 0.5 * (d1 + dm1) - c0;
    let s = 0.5 * (d1 - dm1);
    let u = d2 - 4.0 * c2 - c0;
    let c3 = (u - 2.0 * s) / 6.0;
    let c1 = s - c3;
    cubic_roots(c3, c2, c1, c0)
        .into_iter()
        .filter(|r| r.is_finite())
        .map(|al| {
            let f = mul(&mul(&transpose(&t2), &comb(al)), &t1);
            let norm = if f[2][2].abs() > f64::EPSILON { f[2][2] } else { 1.0 };
            f.map(|row| row.map(|v| v / norm))
        })
        .collect()
}

/// OpenCV's RANSACUpdateNumIters: iterations for `confidence` given the outlier ratio.
fn update_num_iters(confidence: f64, outlier_ratio: f64, model_points: i32, max_iters: usize) -> usize {
    let p = confidence.clamp(0.0, 1.0);
    let ep = outlier_ratio.clamp(0.0, 1.0);
    let num = (1.0 - p).max(f64::MIN_POSITIVE);
    let denom = 1.0 - (1.0 - ep).powi(model_points);
    if denom < f64::MIN_POSITIVE {
        return 0;
    }
    let (num, denom) = (num.ln(), denom.ln());
    if denom >= 0.0 || -num >= max_iters as f64 * -denom { max_iters } else { (num / denom).round() as usize }
}

impl FundamentalRansac {
    /// Runs RANSAC on correspondences `p1[i] <-> p2[i]`; `None` with fewer than
    /// `max(min_matches, 7)` of them or when no sample gives a model.
    #[must_use]
    pub fn run(&self, p1: &[[f64; 2]], p2: &[[f64; 2]]) -> Option<RansacResult> {
        let n = p1.len().min(p2.len());
        if n < self.min_matches.max(7) {
            return None;
        }
        let mut rng = scene_gen_core::rng::stream(self.seed, "orb-ransac-fundamental");
        let t = (self.threshold_px * self.threshold_px) as f32;
        let mut niters = self.max_iters;
        let mut best: Option<(Mat3, usize)> = None;
        let mut best_mask = vec![false; n];
        let mut mask = vec![false; n];
        let mut iter = 0;
        while iter < niters {
            iter += 1;
            let mut idx = [0usize; 7];
            let mut k = 0;
            while k < 7 {
                let c = rng.random_range(0..n);
                if !idx[..k].contains(&c) {
                    idx[k] = c;
                    k += 1;
                }
            }
            let s1: Vec<[f64; 2]> = idx.iter().map(|&i| p1[i]).collect();
            let s2: Vec<[f64; 2]> = idx.iter().map(|&i| p2[i]).collect();
            for f in fundamental_7point(&s1, &s2) {
                let mut count = 0;
                for i in 0..n {
                    let ok = (epipolar_error(&f, p1[i], p2[i]) as f32) <= t;
                    mask[i] = ok;
                    count += usize::from(ok);
                }
                if count > best.map_or(6, |b| b.1.max(6)) {
                    best = Some((f, count));
                    std::mem::swap(&mut best_mask, &mut mask);
                    niters = update_num_iters(self.confidence, (n - count) as f64 / n as f64, 7, niters);
                }
            }
        }
        best.map(|(f, n_inliers)| RansacResult { f, inliers: best_mask, n_inliers, iterations: iter })
    }
}
