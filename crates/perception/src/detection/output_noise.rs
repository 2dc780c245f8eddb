//! The camera's noise as the detector sees it: the standard deviation of the 8-bit evaluation
//! image at each of its 256 output levels, from the sensor's noise model carried through the
//! output rule ([`scene_gen_camera::isp`]).
//!
//! # Why the detector needs it
//!
//! The detectability model divides an object's contrast by the noise
//! ([`super::detectability`]). Measured on the image alone, that noise is everything that
//! varies from pixel to pixel: the sensor's noise, but also fine texture and the renderer's
//! Monte Carlo sampling noise, which a real camera never sees. With one area-light sample per
//! pixel ([`scene_gen_render::RenderSettings::preview`]) window-lit walls by day carry a sampling
//! noise of several DN: on the evaluator's default camera (IMX174, 4 mm, -10 deg, houses 0 and
//! 1, 25 anchors, 320 px) the image estimate averaged 8.1 DN by day and 4.1 DN at night, of
//! which the sensor's share (noisy minus noiseless capture, around each object) was 0.9 DN by
//! day and 4.6 DN at night (`examples/daynight_objects.rs`). The detector scored the renderer,
//! and by day, where the sensor is four times quieter, it found fewer objects.
//!
//! # The table
//!
//! For each output level `v`:
//!
//! 1. the raw mean `m` (DN) the output rule maps to `v`: under [`OutputRule::Isp`],
//!    `m = black + S x / 0.18` with `x` the sRGB decoding of `v / 255` (`S` the mid-grey
//!    signal, [`Isp`]); under [`OutputRule::TopBits`], `m = v 2^(bits - 8)`;
//! 2. the photon count that gives that mean ([`SensorModel::expected_mean_dn`], inverted by
//!    bisection) and the pixel's variance at it: the temporal variance of the EMVA 1288 model
//!    ([`SensorModel::expected_temporal_variance_dn2`]), plus the fixed-pattern terms that are
//!    switched on (DSNU, PRNU, column offsets, the periodic pattern), because to a detector
//!    that sees one frame a fixed pattern is noise like any other; hot pixels are left out
//!    (a sparse tail, not a spread). With `noise = "off"` only the ADC's rounding (1/12 DN^2)
//!    remains;
//! 3. the standard deviation of the output `f(clamp(m + sigma z, 0, max DN))` for a standard
//!    normal `z` (the output rule `f` without its final rounding, clipping included, so a
//!    level near black or white carries the compressed noise it really has), by quadrature on
//!    241 points of `z` in `[-6, 6]`, plus the output's own rounding, `1/12` DN^2.
//!
//! The affine colour path has its own noise model on 8-bit values; it gets no table and the
//! detector measures the noise on the image ([`super::detectability::NoiseSource::Measured`]).
//!
//! # Colour cameras
//!
//! A colour camera's grey image is the luma of its developed sRGB image: its noise has passed
//! through white balance, demosaicing (which averages neighbours) and the colour matrix (which
//! mixes channels and, off its diagonal, amplifies noise). No closed form follows it through
//! all of that, so [`colour_output_noise_by_level`] measures it: for each level, a flat grey
//! patch that develops to that level is captured with the camera's noise and developed, and the
//! standard deviation of its luma is taken (a fixed seed per level, so the table is the same on
//! every run).

use rayon::prelude::*;

use super::detectability::QUANTISATION_STD_DN;
use scene_gen_camera::bayer::{ColourIsp, capture_mosaic};
use scene_gen_camera::camera_spec::{NoiseKind, ResolvedCamera};
use scene_gen_camera::capture::luma_of_srgb;
use scene_gen_camera::isp::{Isp, MID_GREY_REFLECTANCE, OutputRule, srgb_decode};
use scene_gen_camera::sensor::noise::SensorModel;

/// Output levels of the 8-bit evaluation image.
pub const LEVELS: usize = 256;

/// The raw pixel variance (DN^2) at a mean of `photons` per pixel, fixed patterns included.
fn pixel_variance_dn2(model: &SensorModel, photons: f64, exposure_s: f64, gain_db: f64) -> f64 {
    let e = &model.effects;
    let k = model.k_dn_per_e(gain_db);
    let mut v = model.expected_temporal_variance_dn2(photons, exposure_s, gain_db);
    if e.dsnu.enabled {
        v += (k * e.dsnu.std_e).powi(2);
    }
    if e.prnu.enabled {
        v += (k * model.quantum_efficiency * photons * e.prnu.std_fraction).powi(2);
    }
    if e.row_column_noise.enabled {
        v += e.row_column_noise.column_std_dn.powi(2);
    }
    v += e.periodic_pattern.variance_dn2();
    v
}

/// Photons per pixel whose expected output is `mean_dn` (0 below the dark level; the
/// saturation point above the largest reachable mean).
fn photons_for_mean(model: &SensorModel, mean_dn: f64, exposure_s: f64, gain_db: f64) -> f64 {
    let at = |p: f64| model.expected_mean_dn(p, exposure_s, gain_db);
    if mean_dn <= at(0.0) {
        return 0.0;
    }
    let mut hi = 1.0;
    while at(hi) < mean_dn && hi < 1e12 {
        hi *= 2.0;
    }
    let mut lo = 0.0;
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if at(mid) < mean_dn {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Standard deviation of the 8-bit output at each level (module docs), for `resolved` at
/// `gain_db` under `rule` with the scenario's `isp`. `None` on the affine colour path.
#[must_use]
pub fn output_noise_by_level(resolved: &ResolvedCamera, gain_db: f64, rule: OutputRule, isp: &Isp) -> Option<Vec<f64>> {
    let spec = &resolved.spec;
    if spec.noise == NoiseKind::Affine {
        return None;
    }
    let model = resolved.sensor_model(0);
    let max_dn = model.max_dn();
    let shift = f64::from(1u32 << model.adc_bits.saturating_sub(8));
    // The output rule without its rounding, raw DN -> continuous 8-bit level.
    let output = |dn: f64| -> f64 {
        let dn = dn.clamp(0.0, max_dn);
        match rule {
            OutputRule::Isp => isp.level(dn),
            OutputRule::TopBits => (dn / shift).min(255.0),
        }
    };
    let raw_mean = |v: usize| -> f64 {
        match rule {
            OutputRule::Isp => isp.black + isp.mid_grey_signal * srgb_decode(v as f64 / 255.0) / MID_GREY_REFLECTANCE,
            OutputRule::TopBits => v as f64 * shift,
        }
    };
    // Quadrature nodes of a standard normal (Riemann sum on a fine grid, renormalised).
    let nodes: Vec<(f64, f64)> = (0..241)
        .map(|i| {
            let z = -6.0 + 0.05 * f64::from(i);
            (z, (-0.5 * z * z).exp())
        })
        .collect();
    let total: f64 = nodes.iter().map(|n| n.1).sum();
    let t = spec.exposure_s;
    let table = (0..LEVELS)
        .map(|v| {
            let m = raw_mean(v);
            let var = if spec.noise == NoiseKind::Off {
                1.0 / 12.0
            } else {
                pixel_variance_dn2(&model, photons_for_mean(&model, m, t, gain_db), t, gain_db)
            };
            let s = var.max(0.0).sqrt();
            let (mut m1, mut m2) = (0.0, 0.0);
            for &(z, w) in &nodes {
                let y = output(m + s * z);
                m1 += w * y;
                m2 += w * y * y;
            }
            let (m1, m2) = (m1 / total, m2 / total);
            ((m2 - m1 * m1).max(0.0) + 1.0 / 12.0).sqrt().max(QUANTISATION_STD_DN)
        })
        .collect();
    Some(table)
}

/// Side of the flat patch each sampled level of [`colour_output_noise_by_level`] is measured
/// on, px (4096 pixels).
const PATCH_PX: u32 = 64;

/// Levels between the ones [`colour_output_noise_by_level`] measures (the rest are
/// interpolated linearly; the noise changes slowly with level).
const LEVEL_STEP: usize = 8;

/// Standard deviation of a colour camera's 8-bit luma at each level (module docs, "Colour
/// cameras"), for `resolved` at `gain_db` with the scenario's colour ISP, whose light reaches
/// `target_lux` on the reference plane.
#[must_use]
pub fn colour_output_noise_by_level(
    resolved: &ResolvedCamera,
    gain_db: f64,
    colour: &ColourIsp,
    target_lux: f64,
) -> Vec<f64> {
    // A small, flat-fielded copy of the camera: same pixels, lens and sensor, no fall-off.
    let mut patch = resolved.clone();
    patch.width_px = PATCH_PX;
    patch.height_px = PATCH_PX;
    patch.spec.vignetting = false;
    let camera = patch.camera(glam::Vec3::ZERO, 0.0);
    let n = (PATCH_PX * PATCH_PX) as usize;
    let measure = |v: usize| -> f64 {
        // The luminance of a grey that the ISP maps to level v: the 18 % grey of the scenario's
        // light maps to linear 0.18.
        let linear = srgb_decode(v as f64 / 255.0);
        let nit = (linear * target_lux / std::f64::consts::PI) as f32;
        let radiance = vec![colour.matrix.tint.map(|t| nit * t as f32); n];
        let seeds = (0, scene_gen_core::rng::fnv1a64(format!("output-noise/{v}").as_bytes()));
        let pattern = colour.develop.pattern;
        let raw = capture_mosaic(&patch, &camera, &radiance, None, &colour.matrix, pattern, gain_db, seeds);
        let luma = luma_of_srgb(&colour.develop(&raw));
        let mean = luma.iter().map(|&y| f64::from(y)).sum::<f64>() / n as f64;
        let var = luma.iter().map(|&y| (f64::from(y) - mean).powi(2)).sum::<f64>() / n as f64;
        var.sqrt().max(QUANTISATION_STD_DN)
    };
    let sampled: Vec<usize> = (0..LEVELS).step_by(LEVEL_STEP).chain([LEVELS - 1]).collect();
    let raw: Vec<f64> = sampled.par_iter().map(|&v| measure(v)).collect();
    // The luma is whole numbers, so where the noise is near 1 DN its spread depends on where the
    // mean falls between two of them; a [1, 2, 1] average over neighbouring samples keeps that
    // rounding jitter out of the table.
    let measured: Vec<f64> = (0..raw.len())
        .map(|j| {
            let (a, b) = (raw[j.saturating_sub(1)], raw[(j + 1).min(raw.len() - 1)]);
            (a + 2.0 * raw[j] + b) / 4.0
        })
        .collect();
    (0..LEVELS)
        .map(|v| {
            let j = sampled.partition_point(|&s| s <= v) - 1;
            if sampled[j] == v || j + 1 == sampled.len() {
                return measured[j];
            }
            let t = (v - sampled[j]) as f64 / (sampled[j + 1] - sampled[j]) as f64;
            measured[j] * (1.0 - t) + measured[j + 1] * t
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene_gen_camera::camera_spec::CameraSpec;
    use scene_gen_camera::isp::to_8bit;
    use scene_gen_camera::radiometry::SensorImage;
    use scene_gen_camera::sensor::Catalog;

    fn camera(noise: NoiseKind) -> ResolvedCamera {
        CameraSpec { max_width_px: Some(1936), noise, ..CameraSpec::new("IMX174") }
            .resolve(&Catalog::embedded())
            .unwrap()
    }

    /// Mean and standard deviation of the 8-bit image of a flat field of `photons`.
    fn flat_field(r: &ResolvedCamera, photons: f32, gain_db: f64, isp: &Isp) -> (f64, f64) {
        let (w, h) = (200usize, 200usize);
        let model = r.sensor_model(0);
        let dn = model.simulate(&vec![photons; w * h], w, h, r.spec.exposure_s, gain_db, 7);
        let cap = SensorImage { width: w as u32, height: h as u32, channels: 1, bits: model.adc_bits, cfa: None, dn };
        let out = to_8bit(&cap, OutputRule::Isp, isp);
        let n = out.len() as f64;
        let mean = out.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let var = out.iter().map(|&v| (f64::from(v) - mean).powi(2)).sum::<f64>() / n;
        (mean, var.sqrt())
    }

    #[test]
    fn the_table_predicts_the_noise_of_simulated_flat_fields() {
        let r = camera(NoiseKind::Emva);
        for (gain_db, lux) in [(5.0, 20.0), (15.0, 2.0)] {
            let isp = Isp::for_scenario(&r, gain_db, lux, 1);
            let table = output_noise_by_level(&r, gain_db, OutputRule::Isp, &isp).unwrap();
            // Photons that put the mean at mid-grey, at a quarter of it and at twice it.
            let model = r.sensor_model(0);
            for frac in [0.25, 1.0, 2.0] {
                let target = isp.black + frac * isp.mid_grey_signal;
                let p = photons_for_mean(&model, target, r.spec.exposure_s, gain_db);
                let (mean, std) = flat_field(&r, p as f32, gain_db, &isp);
                let predicted = table[mean.round() as usize];
                assert!(
                    (predicted / std - 1.0).abs() < 0.1,
                    "{gain_db} dB, {frac} x mid-grey: level {mean:.1}, measured {std:.3}, table {predicted:.3}"
                );
            }
        }
    }

    #[test]
    fn night_output_is_noisier_than_day_and_off_is_only_rounding() {
        let r = camera(NoiseKind::Emva);
        let day_isp = Isp::for_scenario(&r, 5.0, 20.0, 1);
        let night_isp = Isp::for_scenario(&r, 15.0, 2.0, 1);
        let day = output_noise_by_level(&r, 5.0, OutputRule::Isp, &day_isp).unwrap();
        let night = output_noise_by_level(&r, 15.0, OutputRule::Isp, &night_isp).unwrap();
        // The ISP brings both to the same brightness from 10x fewer electrons at night: the
        // relative noise `sqrt(N + r^2) / N` grows by sqrt(10) where shot noise dominates, by up
        // to 10 where read noise does (dark levels).
        for v in 10..=245 {
            let ratio = night[v] / day[v];
            assert!(ratio > 0.9 * 10f64.sqrt() && ratio < 10.5, "level {v}: night {} day {}", night[v], day[v]);
        }
        let mid = night[118] / day[118];
        assert!(mid < 4.5, "mid-grey is shot-noise limited: {mid}");
        let off = camera(NoiseKind::Off);
        let t = output_noise_by_level(&off, 5.0, OutputRule::Isp, &Isp::for_scenario(&off, 5.0, 20.0, 1)).unwrap();
        // Noise off: the ADC's rounding alone, quieter than the sensor at every level, and at
        // most the 12-bit step seen through the steepest (darkest) part of the curve.
        assert!(t.iter().zip(&day).all(|(&o, &d)| o < d), "noise off: {t:?}");
        assert!(t.iter().all(|&s| s < 1.2) && t[200] < 0.3, "noise off: {t:?}");
        assert!(output_noise_by_level(&camera(NoiseKind::Affine), 5.0, OutputRule::Isp, &day_isp).is_none());
    }
}
