//! The ColorChecker test: a 24-patch colour chart photographed through a camera's whole colour
//! chain (spectral response, CFA, noise, ISP), scored by CIEDE2000 against the chart's
//! published colours.
//!
//! The chart is the ColorChecker Classic (McCamy, Marcus and Davidson, 1976), 4 rows of 6
//! patches, with the manufacturer's published sRGB values (X-Rite; the table Wikipedia's
//! "ColorChecker" article reproduces). Each patch is a Lambertian surface whose linear-sRGB
//! reflectance is its decoded sRGB value, lit by the scenario's light at its target
//! illuminance, so the ISP's exposure rule (an 18 % grey to sRGB 118) puts a perfect camera's
//! patches at their published values. Patches are measured as the mean over their central half,
//! away from the demosaicing of their edges, converted to CIELAB (D65 white, the sRGB white) and
//! compared with CIEDE2000 (Sharma, Wu and Dalal, "The CIEDE2000 color-difference formula:
//! implementation notes, supplementary test data, and mathematical observations", Color
//! Research & Application 30(1), 2005).

use serde::Serialize;

use crate::bayer::{self, ColourIsp};
use crate::camera_spec::ResolvedCamera;
use crate::capture::{illuminant, target_lux};
use crate::develop::srgb_encode;
use crate::radiometry::SensorImage;
use crate::spectral::{ChannelMatrix, QeCurves};
use crate::spectral::{XYZ_TO_LINEAR_SRGB, invert3, mat_vec};
use scene_gen_scene::scene::LightGroup;

/// The 24 patches: name and published 8-bit sRGB, row by row from the top left.
pub const PATCHES: [(&str, [u8; 3]); 24] = [
    ("dark skin", [115, 82, 68]),
    ("light skin", [194, 150, 130]),
    ("blue sky", [98, 122, 157]),
    ("foliage", [87, 108, 67]),
    ("blue flower", [133, 128, 177]),
    ("bluish green", [103, 189, 170]),
    ("orange", [214, 126, 44]),
    ("purplish blue", [80, 91, 166]),
    ("moderate red", [193, 90, 99]),
    ("purple", [94, 60, 108]),
    ("yellow green", [157, 188, 64]),
    ("orange yellow", [224, 163, 46]),
    ("blue", [56, 61, 150]),
    ("green", [70, 148, 73]),
    ("red", [175, 54, 60]),
    ("yellow", [231, 199, 31]),
    ("magenta", [187, 86, 149]),
    ("cyan", [8, 133, 161]),
    ("white 9.5", [243, 243, 242]),
    ("neutral 8", [200, 200, 200]),
    ("neutral 6.5", [160, 160, 160]),
    ("neutral 5", [122, 122, 121]),
    ("neutral 3.5", [85, 85, 85]),
    ("black 2", [52, 52, 52]),
];

/// Columns and rows of the chart.
pub const COLUMNS: usize = 6;
pub const ROWS: usize = 4;

/// Reflectance of the chart's frame between the patches (the card's black).
const FRAME_REFLECTANCE: f32 = 0.03;

/// Inverse of the sRGB transfer function, encoded 0..1 to linear.
#[must_use]
pub fn srgb_decode(encoded: f64) -> f64 {
    if encoded <= 0.040_45 { encoded / 12.92 } else { ((encoded + 0.055) / 1.055).powf(2.4) }
}

/// The linear-sRGB reflectance of a patch's published 8-bit colour.
#[must_use]
pub fn reflectance(srgb8: [u8; 3]) -> [f64; 3] {
    srgb8.map(|v| srgb_decode(f64::from(v) / 255.0))
}

/// Where patch `index` lies in a `width x height` image: its (x0, y0, x1, y1), in pixels. Patches
/// are squares on a grid of equal cells, a frame of a fifth of a cell between them.
#[must_use]
pub fn patch_box(index: usize, width: usize, height: usize) -> (usize, usize, usize, usize) {
    let cell = (width / COLUMNS).min(height / ROWS);
    let (ox, oy) = ((width - cell * COLUMNS) / 2, (height - cell * ROWS) / 2);
    let gap = cell / 10;
    let (col, row) = (index % COLUMNS, index / COLUMNS);
    let (x0, y0) = (ox + col * cell + gap, oy + row * cell + gap);
    (x0, y0, x0 + cell - 2 * gap, y0 + cell - 2 * gap)
}

/// The chart's radiance image, linear RGB nit: each patch's reflectance times `tint`, the light's
/// linear-sRGB colour at unit luminance, times `lux / pi` (a Lambertian surface).
#[must_use]
pub fn radiance(width: usize, height: usize, lux: f64, tint: [f64; 3]) -> Vec<[f32; 3]> {
    let mut out = vec![[0.0f32; 3]; width * height];
    let scale =
        |rho: [f64; 3]| -> [f32; 3] { std::array::from_fn(|c| (rho[c] * tint[c] * lux / std::f64::consts::PI) as f32) };
    let frame = scale([f64::from(FRAME_REFLECTANCE); 3]);
    out.iter_mut().for_each(|p| *p = frame);
    for (index, (_, srgb)) in PATCHES.iter().enumerate() {
        let value = scale(reflectance(*srgb));
        let (x0, y0, x1, y1) = patch_box(index, width, height);
        for y in y0..y1 {
            out[y * width + x0..y * width + x1].iter_mut().for_each(|p| *p = value);
        }
    }
    out
}

/// The central half of patch `index` (x0, y0, x1, y1; x1 and y1 exclusive): the pixels it is
/// measured over.
#[must_use]
pub fn measured_region(index: usize, width: usize, height: usize) -> [usize; 4] {
    let (x0, y0, x1, y1) = patch_box(index, width, height);
    let (qx, qy) = ((x1 - x0) / 4, (y1 - y0) / 4);
    [x0 + qx, y0 + qy, x1 - qx, y1 - qy]
}

/// The mean 8-bit sRGB of each patch's [`measured_region`] in an interleaved RGB image.
#[must_use]
pub fn measure(rgb8: &[u8], width: usize, height: usize) -> Vec<[f64; 3]> {
    (0..PATCHES.len())
        .map(|index| {
            let [x0, y0, x1, y1] = measured_region(index, width, height);
            let mut sum = [0.0f64; 3];
            for y in y0..y1 {
                for p in rgb8[(y * width + x0) * 3..(y * width + x1) * 3].chunks_exact(3) {
                    (0..3).for_each(|c| sum[c] += f64::from(p[c]));
                }
            }
            let n = ((x1 - x0) * (y1 - y0)).max(1) as f64;
            sum.map(|s| s / n)
        })
        .collect()
}

/// CIELAB (D65 reference white) of an 8-bit sRGB colour (fractional values allowed).
#[must_use]
pub fn srgb8_to_lab(srgb8: [f64; 3]) -> [f64; 3] {
    let linear = srgb8.map(|v| srgb_decode(v / 255.0));
    let to_xyz = invert3(&XYZ_TO_LINEAR_SRGB).expect("the sRGB matrix is invertible");
    let xyz = mat_vec(&to_xyz, linear);
    let white = mat_vec(&to_xyz, [1.0; 3]);
    let f = |t: f64| {
        const DELTA: f64 = 6.0 / 29.0;
        if t > DELTA.powi(3) { t.cbrt() } else { t / (3.0 * DELTA * DELTA) + 4.0 / 29.0 }
    };
    let [fx, fy, fz] = std::array::from_fn(|i| f(xyz[i] / white[i]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// The CIEDE2000 colour difference of two CIELAB colours (Sharma, Wu and Dalal 2005; unit
/// weights kL = kC = kH = 1).
#[must_use]
pub fn ciede2000(lab1: [f64; 3], lab2: [f64; 3]) -> f64 {
    let [l1, a1, b1] = lab1;
    let [l2, a2, b2] = lab2;
    let c_mean = (a1.hypot(b1) + a2.hypot(b2)) / 2.0;
    let c7 = c_mean.powi(7);
    let g = 0.5 * (1.0 - (c7 / (c7 + 25f64.powi(7))).sqrt());
    let (a1p, a2p) = ((1.0 + g) * a1, (1.0 + g) * a2);
    let (c1p, c2p) = (a1p.hypot(b1), a2p.hypot(b2));
    let hue = |b: f64, a: f64| if b == 0.0 && a == 0.0 { 0.0 } else { b.atan2(a).to_degrees().rem_euclid(360.0) };
    let (h1p, h2p) = (hue(b1, a1p), hue(b2, a2p));
    let dl = l2 - l1;
    let dc = c2p - c1p;
    let dh = if c1p * c2p == 0.0 {
        0.0
    } else if (h2p - h1p).abs() <= 180.0 {
        h2p - h1p
    } else if h2p - h1p > 180.0 {
        h2p - h1p - 360.0
    } else {
        h2p - h1p + 360.0
    };
    let dh_big = 2.0 * (c1p * c2p).sqrt() * (dh / 2.0).to_radians().sin();
    let l_mean = (l1 + l2) / 2.0;
    let cp_mean = (c1p + c2p) / 2.0;
    let h_mean = if c1p * c2p == 0.0 {
        h1p + h2p
    } else if (h1p - h2p).abs() <= 180.0 {
        (h1p + h2p) / 2.0
    } else if h1p + h2p < 360.0 {
        (h1p + h2p + 360.0) / 2.0
    } else {
        (h1p + h2p - 360.0) / 2.0
    };
    let t = 1.0 - 0.17 * (h_mean - 30.0).to_radians().cos()
        + 0.24 * (2.0 * h_mean).to_radians().cos()
        + 0.32 * (3.0 * h_mean + 6.0).to_radians().cos()
        - 0.20 * (4.0 * h_mean - 63.0).to_radians().cos();
    let d_theta = 30.0 * (-((h_mean - 275.0) / 25.0).powi(2)).exp();
    let cp7 = cp_mean.powi(7);
    let rc = 2.0 * (cp7 / (cp7 + 25f64.powi(7))).sqrt();
    let sl = 1.0 + 0.015 * (l_mean - 50.0).powi(2) / (20.0 + (l_mean - 50.0).powi(2)).sqrt();
    let sc = 1.0 + 0.045 * cp_mean;
    let sh = 1.0 + 0.015 * cp_mean * t;
    let rt = -(2.0 * d_theta).to_radians().sin() * rc;
    let (tl, tc, th) = (dl / sl, dc / sc, dh_big / sh);
    (tl * tl + tc * tc + th * th + rt * tc * th).sqrt()
}

/// One patch of a chart measurement.
#[derive(Clone, Debug, Serialize)]
pub struct PatchScore {
    pub name: &'static str,
    /// The pixels measured: x0, y0, x1, y1 (x1, y1 exclusive).
    pub region_px: [usize; 4],
    /// The published sRGB, 8-bit.
    pub reference_srgb: [u8; 3],
    /// The camera's mean sRGB over the patch's central half.
    pub measured_srgb: [f64; 3],
    pub reference_lab: [f64; 3],
    pub measured_lab: [f64; 3],
    pub delta_e_2000: f64,
}

/// Every patch of a chart image scored against the published colours.
#[derive(Clone, Debug, Serialize)]
pub struct ChartScore {
    pub patches: Vec<PatchScore>,
    pub mean_delta_e_2000: f64,
    pub max_delta_e_2000: f64,
}

/// Scores an interleaved 8-bit sRGB image of the chart laid out by [`patch_box`].
#[must_use]
pub fn score(rgb8: &[u8], width: usize, height: usize) -> ChartScore {
    let patches: Vec<PatchScore> = measure(rgb8, width, height)
        .into_iter()
        .zip(PATCHES)
        .enumerate()
        .map(|(index, (measured, (name, reference)))| {
            let reference_lab = srgb8_to_lab(reference.map(f64::from));
            let measured_lab = srgb8_to_lab(measured);
            PatchScore {
                name,
                region_px: measured_region(index, width, height),
                reference_srgb: reference,
                measured_srgb: measured,
                reference_lab,
                measured_lab,
                delta_e_2000: ciede2000(reference_lab, measured_lab),
            }
        })
        .collect();
    let mean = patches.iter().map(|p| p.delta_e_2000).sum::<f64>() / patches.len() as f64;
    let max = patches.iter().map(|p| p.delta_e_2000).fold(0.0, f64::max);
    ChartScore { patches, mean_delta_e_2000: mean, max_delta_e_2000: max }
}

/// A photograph of the chart through a colour camera.
#[derive(Clone, Debug)]
pub struct ChartPhoto {
    /// The raw mosaic.
    pub raw: SensorImage,
    /// The developed 8-bit sRGB image, interleaved.
    pub srgb: Vec<u8>,
    pub score: ChartScore,
}

/// Photographs the chart filling the frame of `resolved` (its simulated resolution) under the
/// light of `group`'s scenario at its target illuminance and the spec's gain for it, through the
/// whole colour chain, and scores it. `seeds` are the sensor instance's and the frame's noise
/// seeds. `None` for a camera without a colour filter array ([`bayer::cfa_of`]).
#[must_use]
pub fn photograph(resolved: &ResolvedCamera, group: LightGroup, seeds: (u64, u64)) -> Option<ChartPhoto> {
    let pattern = bayer::cfa_of(resolved)?;
    let camera = resolved.camera(glam::Vec3::ZERO, 0.0);
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    let light = illuminant(group);
    let lux = f64::from(target_lux(group));
    let gain_db = match group {
        LightGroup::Day => resolved.spec.gain_day_db,
        LightGroup::Night => resolved.spec.gain_night_db,
    };
    let matrix = ChannelMatrix::new(&QeCurves::typical_bayer(resolved.sensor.quantum_efficiency), light, light.tint());
    let isp = ColourIsp::for_scenario(resolved, pattern, matrix, gain_db, lux);
    let scene = radiance(w, h, lux, matrix.tint);
    let raw = bayer::capture_mosaic(resolved, &camera, &scene, None, &matrix, pattern, gain_db, seeds);
    let srgb = isp.develop(&raw);
    let score = score(&srgb, w, h);
    Some(ChartPhoto { raw, srgb, score })
}

/// Encodes a linear value to 8-bit sRGB, for building test images.
#[must_use]
pub fn srgb8(linear: f64) -> u8 {
    (f64::from(srgb_encode(linear.clamp(0.0, 1.0) as f32)) * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pairs from Sharma, Wu and Dalal's supplementary test data (Table 1), rounded there to
    /// four decimals.
    #[test]
    fn ciede2000_meets_the_published_test_pairs() {
        let pairs = [
            ([50.0, 2.6772, -79.7751], [50.0, 0.0, -82.7485], 2.0425),
            ([50.0, 3.1571, -77.2803], [50.0, 0.0, -82.7485], 2.8615),
            ([50.0, 2.8361, -74.0200], [50.0, 0.0, -82.7485], 3.4412),
            ([50.0, 0.0, 0.0], [50.0, -1.0, 2.0], 2.3669),
            ([50.0, 2.5, 0.0], [73.0, 25.0, -18.0], 27.1492),
            ([50.0, 2.5, 0.0], [61.0, -5.0, 29.0], 22.8977),
            ([60.2574, -34.0099, 36.2677], [60.4626, -34.1751, 39.4387], 1.2644),
        ];
        for (a, b, expected) in pairs {
            let de = ciede2000(a, b);
            assert!((de - expected).abs() < 1e-4, "{a:?} {b:?}: {de} vs {expected}");
            assert!((ciede2000(b, a) - de).abs() < 1e-9, "symmetric");
        }
    }

    /// The whole colour chain, noise off: under D65 the published colours come back within
    /// CIEDE2000 3 on average. The night figures are printed, not gated: at 2 lux a binned 10-bit
    /// sensor has a few tens of DN per channel, and quantisation alone moves dark patches by
    /// several units, as it would in the camera.
    #[test]
    fn catalog_cameras_render_the_chart_within_three_de2000() {
        use crate::camera_spec::{CameraSpec, NoiseKind};
        let catalog = crate::sensor::Catalog::embedded();
        for model in ["IMX172", "IMX174", "PYTHON300"] {
            let spec = CameraSpec {
                noise: NoiseKind::Off,
                vignetting: false,
                max_width_px: Some(240),
                ..CameraSpec::new(model)
            };
            let resolved = spec.resolve(&catalog).unwrap();
            for group in [LightGroup::Day, LightGroup::Night] {
                let photo = photograph(&resolved, group, (1, 1)).expect("a colour sensor");
                for p in &photo.score.patches {
                    eprintln!(
                        "{model} {group:?} {:>14}: {:?} -> {:.1?} dE00 {:.2}",
                        p.name, p.reference_srgb, p.measured_srgb, p.delta_e_2000
                    );
                }
                let s = &photo.score;
                eprintln!("{model} {group:?}: mean dE00 {:.2}, max {:.2}", s.mean_delta_e_2000, s.max_delta_e_2000);
                if group == LightGroup::Day {
                    assert!(s.mean_delta_e_2000 <= 3.0, "{model}: mean {:.2}", s.mean_delta_e_2000);
                }
            }
        }
    }

    #[test]
    fn lab_of_srgb_white_and_grey() {
        let white = srgb8_to_lab([255.0; 3]);
        assert!((white[0] - 100.0).abs() < 1e-6 && white[1].abs() < 1e-6 && white[2].abs() < 1e-6, "{white:?}");
        // sRGB 118 is linear 0.18, L* = 49.5.
        let grey = srgb8_to_lab([118.0; 3]);
        assert!((grey[0] - 49.5).abs() < 0.2, "{grey:?}");
    }

    #[test]
    fn a_perfect_image_of_the_chart_scores_zero_and_a_tinted_one_does_not() {
        let (w, h) = (120, 80);
        let radiance = radiance(w, h, std::f64::consts::PI, [1.0; 3]);
        let perfect: Vec<u8> = radiance.iter().flat_map(|p| p.map(|v| srgb8(f64::from(v)))).collect();
        let s = score(&perfect, w, h);
        assert!(s.max_delta_e_2000 < 0.5, "{s:?}");
        let tinted: Vec<u8> = radiance
            .iter()
            .flat_map(|p| [srgb8(f64::from(p[0]) * 1.2), srgb8(f64::from(p[1])), srgb8(f64::from(p[2]))])
            .collect();
        assert!(score(&tinted, w, h).mean_delta_e_2000 > 2.0);
    }
}
