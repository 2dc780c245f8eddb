//! Image statistics of a chart image and the normalised gap between two sets of them.
//!
//! Families (each a part of the gap):
//! * `patch_mean`, `patch_var`: mean and noise variance (from second differences along rows, so
//!   shading across the patch does not count) over each grey patch's ROI, DN and DN^2.
//! * `edge`: for the near-vertical edge (spread across x) and the near-horizontal one (across
//!   y), the 10-90 % and the 25-75 % rise of the edge spread function, pixels. Slanted-edge
//!   method: every pixel of the edge's cell is binned by its signed distance from the known
//!   edge line in quarter-pixel bins, giving an oversampled ESF. Two edges tell anisotropic
//!   (motion) from isotropic (lens) blur; two widths per edge tell a Gaussian's shape from a
//!   line's (a 45 deg line widens both edges like a Gaussian, but its ESF is a ramp: its 25-75
//!   over 10-90 ratio is 0.625 against a Gaussian's 0.53).
//! * `radial`: brightness over reflectance, `(mean - black) / rho`, averaged over the patches in
//!   rings of the normalised radius.
//! * `orb`: the ORB keypoint count ([`scene_gen_perception::orb::Orb`], up to 10 000 features) of the image
//!   scaled to 8 bits.
//!
//! The gap: per family the mean of squared residuals, each over its variance (sampling noise of
//! measured and simulated values plus a tolerance floor, see [`Tolerance`]); the gap is the mean
//! of the families' values. A model that matches within noise and tolerance scores about 1 or
//! less.

use serde::Serialize;

use super::chart::{Edge, Layout};
use scene_gen_perception::orb::Orb;

/// Family names, in report order.
pub const FAMILIES: [&str; 5] = ["patch_mean", "patch_var", "edge", "radial", "orb"];

/// Ring boundaries of the radial profile (normalised radius).
pub const RINGS: [f64; 5] = [0.0, 0.6, 0.75, 0.9, 1.01];

/// Oversampling of the ESF: bins per pixel.
const ESF_BINS_PER_PX: f64 = 4.0;

/// Statistics of one image.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stats {
    pub patch_mean: Vec<f64>,
    pub patch_var: Vec<f64>,
    /// Pixels per patch ROI.
    pub patch_n: Vec<usize>,
    /// [vertical 10-90, vertical 25-75, horizontal 10-90, horizontal 25-75], pixels.
    pub edge: Vec<f64>,
    pub radial: Vec<f64>,
    pub orb: Vec<f64>,
}

impl Stats {
    /// The values of family `name`.
    #[must_use]
    pub fn family(&self, name: &str) -> &[f64] {
        match name {
            "patch_mean" => &self.patch_mean,
            "patch_var" => &self.patch_var,
            "edge" => &self.edge,
            "radial" => &self.radial,
            _ => &self.orb,
        }
    }

    fn family_mut(&mut self, name: &str) -> &mut Vec<f64> {
        match name {
            "patch_mean" => &mut self.patch_mean,
            "patch_var" => &mut self.patch_var,
            "edge" => &mut self.edge,
            "radial" => &mut self.radial,
            _ => &mut self.orb,
        }
    }

    /// Number of statistics.
    #[must_use]
    pub fn len(&self) -> usize {
        FAMILIES.iter().map(|f| self.family(f).len()).sum()
    }

    /// True when there are no statistics.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The statistics of a DN image (row-major, the layout's size).
#[must_use]
pub fn measure(image: &[f64], layout: &Layout) -> Stats {
    let w = layout.width_px;
    let mut patch_mean = Vec::new();
    let mut patch_var = Vec::new();
    let mut patch_n = Vec::new();
    for p in &layout.patches {
        let r = p.roi;
        let vals: Vec<f64> = (r.y0..r.y1).flat_map(|y| (r.x0..r.x1).map(move |x| image[y * w + x])).collect();
        let n = vals.len().max(1) as f64;
        let mean = vals.iter().sum::<f64>() / n;
        // Noise variance from second differences along rows (`x[i-1] - 2 x[i] + x[i+1]` has
        // variance 6 v for white noise): shading across the patch (vignetting, fall-off),
        // linear over three pixels, does not enter.
        let d2: Vec<f64> = (r.y0..r.y1)
            .flat_map(|y| {
                (r.x0 + 1..r.x1.saturating_sub(1))
                    .map(move |x| image[y * w + x - 1] - 2.0 * image[y * w + x] + image[y * w + x + 1])
            })
            .collect();
        let var = d2.iter().map(|d| d * d).sum::<f64>() / (6.0 * d2.len().max(1) as f64);
        patch_mean.push(mean);
        patch_var.push(var);
        patch_n.push(vals.len());
    }
    let edge = layout.edges.iter().flat_map(|e| edge_widths(image, w, e)).collect();
    let black = layout.black_level_dn;
    let radial = RINGS
        .windows(2)
        .filter_map(|ring| {
            let v: Vec<f64> = layout
                .patches
                .iter()
                .zip(&patch_mean)
                .filter(|(p, _)| p.radius >= ring[0] && p.radius < ring[1])
                .map(|(p, m)| (m - black) / p.reflectance)
                .collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        })
        .collect();
    let max = f64::from((1u32 << layout.bits) - 1);
    let bytes: Vec<u8> = image.iter().map(|v| (v * 255.0 / max).round().clamp(0.0, 255.0) as u8).collect();
    let orb = Orb::with_features(10_000)
        .detect_and_compute((bytes.as_slice(), w, layout.height_px))
        .map_or(0.0, |(k, _)| k.len() as f64);
    Stats { patch_mean, patch_var, patch_n, edge, radial, orb: vec![orb] }
}

/// The 10-90 % and 25-75 % rise distances of an edge's ESF, pixels.
#[must_use]
pub fn edge_widths(image: &[f64], width: usize, e: &Edge) -> [f64; 2] {
    // Stay a tenth of the cell clear of its border: blur from the neighbouring cells would
    // tilt the plateaus.
    let side = (e.cell.x1 - e.cell.x0).min(e.cell.y1 - e.cell.y0);
    let c = e.cell.inset((side / 10).max(2));
    let half = ((c.x1 - c.x0).min(c.y1 - c.y0) as f64 / 2.0 - 2.0).max(4.0);
    let nb = (2.0 * half * ESF_BINS_PER_PX) as usize;
    let mut sum = vec![0f64; nb];
    let mut cnt = vec![0usize; nb];
    for y in c.y0..c.y1 {
        for x in c.x0..c.x1 {
            let d = e.distance(x as f64 + 0.5, y as f64 + 0.5);
            if d.abs() >= half {
                continue;
            }
            let b = (((d + half) * ESF_BINS_PER_PX) as usize).min(nb - 1);
            sum[b] += image[y * width + x];
            cnt[b] += 1;
        }
    }
    // Empty bins (none at a 5 deg slant over 20+ rows) take the previous bin's value.
    let mut esf = Vec::with_capacity(nb);
    let mut last = f64::NAN;
    for (s, n) in sum.iter().zip(&cnt) {
        if *n > 0 {
            last = s / *n as f64;
        }
        esf.push(last);
    }
    let first = esf.iter().copied().find(|v| v.is_finite()).unwrap_or(0.0);
    esf.iter_mut().for_each(|v| {
        if !v.is_finite() {
            *v = first;
        }
    });
    // Plateaus: a straight line fitted to the outer half of each side (shading such as
    // vignetting tilts them), extrapolated under the transition.
    let q = (nb / 4).max(2);
    let line = |range: std::ops::Range<usize>| -> (f64, f64) {
        let n = range.len() as f64;
        let xs: Vec<f64> = range.clone().map(|i| i as f64).collect();
        let mx = xs.iter().sum::<f64>() / n;
        let my = range.clone().map(|i| esf[i]).sum::<f64>() / n;
        let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
        let sxy: f64 = range.map(|i| (i as f64 - mx) * (esf[i] - my)).sum();
        let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
        (my - b * mx, b)
    };
    let (la, lb) = line(0..q);
    let (ha, hb) = line(nb - q..nb);
    let norm: Vec<f64> = esf
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let (lo, hi) = (la + lb * i as f64, ha + hb * i as f64);
            (v - lo) / (hi - lo)
        })
        .collect();
    let centre = nb / 2;
    let x_at = |level: f64| -> f64 {
        // The crossing nearest the centre: walk outwards from the middle bin.
        let pos = |i: usize| (i as f64 + 0.5) / ESF_BINS_PER_PX - half;
        if norm[centre] >= level {
            let mut i = centre;
            while i > 0 && norm[i - 1] >= level {
                i -= 1;
            }
            if i == 0 {
                return pos(0);
            }
            let t = (level - norm[i - 1]) / (norm[i] - norm[i - 1]);
            pos(i - 1) + t / ESF_BINS_PER_PX
        } else {
            let mut i = centre;
            while i + 1 < nb && norm[i + 1] < level {
                i += 1;
            }
            if i + 1 >= nb {
                return pos(nb - 1);
            }
            let t = (level - norm[i]) / (norm[i + 1] - norm[i]);
            pos(i) + t / ESF_BINS_PER_PX
        }
    };
    [x_at(0.9) - x_at(0.1), x_at(0.75) - x_at(0.25)]
}

/// Tolerance floors added to the sampling variance of each statistic: how closely the model is
/// expected to match at best (a chart's printed reflectances, registration, the ESF's binning),
/// so that matching beyond them buys nothing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Tolerance {
    /// Relative, on patch means and the radial profile.
    pub mean_rel: f64,
    /// Relative, on patch variances.
    pub var_rel: f64,
    /// Absolute, on edge widths, pixels.
    pub edge_px: f64,
    /// Relative, on the ORB count (at least 2 keypoints).
    pub orb_rel: f64,
}

impl Default for Tolerance {
    fn default() -> Self {
        Tolerance { mean_rel: 0.002, var_rel: 0.03, edge_px: 0.03, orb_rel: 0.03 }
    }
}

/// Mean and standard deviation, per statistic, of several simulated realisations.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimStats {
    pub mean: Stats,
    pub sd: Stats,
    pub frames: usize,
}

/// Summarises simulated realisations (at least one).
///
/// # Panics
/// If `runs` is empty.
#[must_use]
pub fn summarise(runs: &[Stats]) -> SimStats {
    assert!(!runs.is_empty(), "at least one realisation");
    let n = runs.len() as f64;
    let mut mean = runs[0].clone();
    let mut sd = runs[0].clone();
    for f in FAMILIES {
        let k = runs[0].family(f).len();
        let m: Vec<f64> = (0..k).map(|i| runs.iter().map(|r| r.family(f)[i]).sum::<f64>() / n).collect();
        let s: Vec<f64> = (0..k)
            .map(|i| {
                if runs.len() < 2 {
                    0.0
                } else {
                    (runs.iter().map(|r| (r.family(f)[i] - m[i]).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
                }
            })
            .collect();
        *mean.family_mut(f) = m;
        *sd.family_mut(f) = s;
    }
    SimStats { mean, sd, frames: runs.len() }
}

/// One family's part of the gap.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FamilyGap {
    pub family: String,
    pub chi2: f64,
    pub dof: usize,
    /// `chi2 / dof`.
    pub value: f64,
}

/// The gap and its parts.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Gap {
    pub gap: f64,
    pub chi2: f64,
    pub n: usize,
    pub parts: Vec<FamilyGap>,
    /// Signed normalised residual `(measured - simulated) / sigma` per statistic, families in
    /// [`FAMILIES`] order.
    #[serde(skip)]
    pub residuals: Vec<f64>,
}

/// Squared residuals over variances, per statistic and family (see the module doc).
#[must_use]
pub fn gap(measured: &Stats, sim: &SimStats, tol: &Tolerance) -> Gap {
    let nf = sim.frames as f64;
    let mut parts = Vec::new();
    let mut residuals = Vec::new();
    for f in FAMILIES {
        let (m, s, sd) = (measured.family(f), sim.mean.family(f), sim.sd.family(f));
        let mut chi2 = 0.0;
        for i in 0..m.len().min(s.len()) {
            let var = match f {
                "patch_mean" => {
                    let n = measured.patch_n[i].max(1) as f64;
                    measured.patch_var[i] / n + sim.mean.patch_var[i] / (n * nf) + (tol.mean_rel * s[i]).powi(2)
                }
                "patch_var" => {
                    // Overlapping second differences: about 3.9 v^2 / n (Gaussian noise; 2 v^2 / n
                    // for independent squares).
                    let n = measured.patch_n[i].max(2) as f64;
                    3.9 * (m[i] * m[i] + s[i] * s[i] / nf) / n + (tol.var_rel * s[i]).powi(2)
                }
                "edge" => sd[i] * sd[i] * (1.0 + 1.0 / nf) + tol.edge_px * tol.edge_px,
                "radial" => sd[i] * sd[i] * (1.0 + 1.0 / nf) + (tol.mean_rel * s[i]).powi(2),
                _ => sd[i] * sd[i] * (1.0 + 1.0 / nf) + (tol.orb_rel * s[i]).max(2.0).powi(2),
            };
            let z = (m[i] - s[i]) / var.max(1e-12).sqrt();
            chi2 += z * z;
            residuals.push(z);
        }
        let dof = m.len().min(s.len());
        parts.push(FamilyGap {
            family: f.to_string(),
            chi2,
            dof,
            value: if dof > 0 { chi2 / dof as f64 } else { 0.0 },
        });
    }
    let used: Vec<&FamilyGap> = parts.iter().filter(|p| p.dof > 0).collect();
    let gap = used.iter().map(|p| p.value).sum::<f64>() / used.len().max(1) as f64;
    Gap { gap, chi2: parts.iter().map(|p| p.chi2).sum(), n: parts.iter().map(|p| p.dof).sum(), parts, residuals }
}
