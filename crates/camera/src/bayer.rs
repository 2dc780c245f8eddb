//! The Bayer camera: how a colour sensor samples a scene through its colour filter array, and
//! the fixed ISP that develops its raw mosaic into an 8-bit sRGB image.
//!
//! ```text
//! rendered linear RGB (nit) ─► 555 nm-equivalent photons per rendered channel (camera equation)
//!   ─► optics (each plane) ─► electrons of the pixel's CFA channel (spectral::ChannelMatrix)
//!   ─► sensor noise on the mosaic (SensorModel) ─► raw DN ─► ISP ─► 8-bit sRGB
//! ```
//!
//! Every pixel collects the electrons of one channel only, as a real CFA does, so the noise
//! (shot, read, fixed pattern, quantisation) lands on the mosaic and demosaicing spreads it,
//! as it does in a camera. The channel's electrons come from the scenario's spectral matrix
//! ([`crate::spectral`]); the sensor model is then run with a quantum efficiency of 1, since
//! the matrix already holds the channel's QE.
//!
//! The ISP ([`ColourIsp`]) is fixed per camera and scenario, like [`crate::isp::Isp`]: no
//! statistics of the frame are used.
//!
//! 1. Black level: the model's output with no light and no exposure.
//! 2. White balance and digital gain in one gain per channel, set on an 18 % grey lit by the
//!    scenario's light at its target illuminance: each channel's expected signal for it is
//!    mapped to linear 0.18 (a camera's white-balance preset for the light, and the same
//!    exposure rule as the grey ISP).
//! 3. Demosaicing ([`crate::demosaic`], the directional method).
//! 4. Colour correction: the inverse of the white-balanced channels' response to the sRGB
//!    primaries ([`ChannelMatrix::colour_correction`]).
//! 5. The sRGB curve and 8 bits ([`crate::develop`]).

use crate::camera_spec::{NoiseKind, ResolvedCamera};
use crate::demosaic::CfaPattern;
use crate::develop::{Develop, develop};
use crate::isp::{MID_GREY_REFLECTANCE, mid_grey_photons};
use crate::optics::{OpticsInput, OpticsPlan, apply_plan};
use crate::radiometry::{PhotonsPerNit, SensorImage};
use crate::sensor::{Colour, SensorModel};
use crate::spectral::ChannelMatrix;
use scene_gen_render::Camera;

/// The colour filter layout of the catalog's colour sensors, as read out from the first row.
///
/// The catalog does not record a per-part layout; RGGB is the readout of the Sony parts'
/// default window and the one most of the catalog uses.
pub const CATALOG_PATTERN: CfaPattern = CfaPattern::Rggb;

/// The CFA layout `resolved` samples through: the catalog's for a colour sensor on the EMVA or
/// noiseless path, none for a monochrome sensor or the affine (8-bit RGB) path of the
/// reference paper.
#[must_use]
pub fn cfa_of(resolved: &ResolvedCamera) -> Option<CfaPattern> {
    (resolved.sensor.colour == Colour::Colour && resolved.spec.noise != NoiseKind::Affine).then_some(CATALOG_PATTERN)
}

/// The sensor model of a colour capture: the camera's, with a quantum efficiency of 1 because
/// the channel matrix already converts photons to electrons.
#[must_use]
pub fn electron_model(resolved: &ResolvedCamera, pattern_seed: u64) -> SensorModel {
    SensorModel { quantum_efficiency: 1.0, ..resolved.sensor_model(pattern_seed) }
}

/// Linear RGB radiance (nit) per pixel, row-major: one buffer, or the two light groups of a
/// frame weighted by a scenario ([`scene_gen_render::Frame::mix`], without making the buffer).
#[derive(Clone, Copy, Debug)]
pub enum Radiance<'a> {
    Rgb(&'a [[f32; 3]]),
    Mix { day: &'a [[f32; 3]], night: &'a [[f32; 3]], day_weight: f32, night_weight: f32 },
}

impl Radiance<'_> {
    fn len(&self) -> usize {
        match self {
            Radiance::Rgb(rgb) => rgb.len(),
            Radiance::Mix { day, .. } => day.len(),
        }
    }

    /// The radiance of pixel `i`; a mix is [`scene_gen_render::Frame::mix`]'s sum, term for term.
    #[inline(always)]
    fn at(&self, i: usize) -> [f32; 3] {
        match *self {
            Radiance::Rgb(rgb) => rgb[i],
            Radiance::Mix { day, night, day_weight, night_weight } => {
                let (d, n) = (day[i], night[i]);
                std::array::from_fn(|c| d[c] * day_weight + n[c] * night_weight)
            }
        }
    }
}

/// The raw mosaic of `radiance` (linear RGB nit per pixel, scaled to the scenario) seen by the
/// colour camera `resolved` as `camera` through `pattern`, with the scenario's spectral
/// `matrix`, at `gain_db`: with the sensor's noise, or its expected values rounded when the
/// spec's noise is off. `pattern_seed` fixes the sensor instance, `frame_seed` the temporal
/// noise; `optics` as in [`crate::radiometry::capture_frame`].
///
/// # Panics
/// If `radiance.len()` is not the camera's pixel count.
#[must_use]
#[allow(clippy::too_many_arguments)]
pub fn capture_mosaic(
    resolved: &ResolvedCamera,
    camera: &Camera,
    radiance: &[[f32; 3]],
    optics: Option<OpticsInput<'_>>,
    matrix: &ChannelMatrix,
    pattern: CfaPattern,
    gain_db: f64,
    (pattern_seed, frame_seed): (u64, u64),
) -> SensorImage {
    let scenario = MosaicScenario { radiance: Radiance::Rgb(radiance), matrix, gain_db, frame_seed };
    capture_mosaics(resolved, camera, optics, pattern, pattern_seed, &[scenario]).remove(0)
}

/// One scenario of a colour capture ([`capture_mosaics`]): its radiance, spectral matrix, gain
/// (dB) and temporal-noise seed.
#[derive(Clone, Copy, Debug)]
pub struct MosaicScenario<'a> {
    pub radiance: Radiance<'a>,
    pub matrix: &'a ChannelMatrix,
    pub gain_db: f64,
    pub frame_seed: u64,
}

/// [`capture_mosaic`] of several scenarios of one frame (day and night), in their order: the
/// camera equation's per-pixel factor is worked out once for all of them, in one pass from
/// radiance to electrons. Each mosaic is the one [`capture_mosaic`] makes of its scenario.
///
/// # Panics
/// If a radiance does not have the camera's pixel count.
#[must_use]
pub fn capture_mosaics(
    resolved: &ResolvedCamera,
    camera: &Camera,
    optics: Option<OpticsInput<'_>>,
    pattern: CfaPattern,
    pattern_seed: u64,
    scenarios: &[MosaicScenario<'_>],
) -> Vec<SensorImage> {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    let model = electron_model(resolved, pattern_seed);
    let t = resolved.spec.exposure_s;
    mosaic_electrons(resolved, camera, optics, pattern, scenarios)
        .into_iter()
        .zip(scenarios)
        .map(|(electrons, scenario)| {
            let gain_db = scenario.gain_db;
            let dn = if resolved.spec.noise == NoiseKind::Off {
                let max = model.max_dn();
                electrons
                    .iter()
                    .map(|&e| model.expected_mean_dn(f64::from(e), t, gain_db).round().clamp(0.0, max) as u16)
                    .collect()
            } else {
                model.simulate(&electrons, w, h, t, gain_db, scenario.frame_seed)
            };
            SensorImage {
                width: camera.width_px,
                height: camera.height_px,
                channels: 1,
                bits: model.adc_bits,
                cfa: Some(pattern),
                dn,
            }
        })
        .collect()
}

/// Mean electrons of each pixel's CFA channel, per scenario.
fn mosaic_electrons(
    resolved: &ResolvedCamera,
    camera: &Camera,
    optics: Option<OpticsInput<'_>>,
    pattern: CfaPattern,
    scenarios: &[MosaicScenario<'_>],
) -> Vec<Vec<f32>> {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    for s in scenarios {
        assert_eq!(s.radiance.len(), w * h, "radiance must have one value per pixel");
    }
    let spec = &resolved.spec;
    let plan = OpticsPlan::new(resolved, camera, optics.as_ref());
    let electrons_at = |matrix: &ChannelMatrix, x: usize, y: usize, photons: [f32; 3]| -> f32 {
        let row = &matrix.m[pattern.channel(x, y)];
        let e: f64 = (0..3).map(|k| row[k] * f64::from(photons[k])).sum();
        e.max(0.0) as f32
    };
    // The camera equation is linear in radiance: one photons-per-nit factor per pixel (its
    // fall-off) serves the three rendered channels of every scenario.
    let per_nit = PhotonsPerNit::new(camera, spec.lens_transmittance, spec.exposure_s);
    let mut electrons: Vec<Vec<f32>> = scenarios.iter().map(|_| vec![0f32; w * h]).collect();
    if plan.is_identity() {
        // One pass from radiance to electrons: no image in between.
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let f = per_nit.photons(1.0, x, y);
                for (s, out) in scenarios.iter().zip(electrons.iter_mut()) {
                    out[i] = electrons_at(s.matrix, x, y, s.radiance.at(i).map(|v| v.max(0.0) * f));
                }
            }
        }
        return electrons;
    }
    // 555 nm-equivalent photons of each rendered channel, through the optics (linear, so each
    // plane is blurred on its own).
    let factors: Vec<f32> = (0..w * h).map(|i| per_nit.photons(1.0, i % w, i / w)).collect();
    for (s, out) in scenarios.iter().zip(electrons.iter_mut()) {
        let planes: Vec<Vec<f32>> = (0..3)
            .map(|k| {
                let mut photons: Vec<f32> =
                    factors.iter().enumerate().map(|(i, &f)| s.radiance.at(i)[k].max(0.0) * f).collect();
                apply_plan(&plan, camera, &mut photons, optics.as_ref());
                photons
            })
            .collect();
        for (i, e) in out.iter_mut().enumerate() {
            *e = electrons_at(s.matrix, i % w, i / w, [planes[0][i], planes[1][i], planes[2][i]]);
        }
    }
    electrons
}

/// The fixed ISP of a colour camera in one scenario (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColourIsp {
    /// The scenario's spectral matrix.
    pub matrix: ChannelMatrix,
    /// Black level, gains, demosaicing and colour matrix.
    pub develop: Develop,
}

impl ColourIsp {
    /// The ISP of `resolved` through `pattern` at `gain_db`, for a scenario whose light has the
    /// spectral `matrix` and lights the scene to `target_lux`.
    #[must_use]
    pub fn for_scenario(
        resolved: &ResolvedCamera,
        pattern: CfaPattern,
        matrix: ChannelMatrix,
        gain_db: f64,
        target_lux: f64,
    ) -> ColourIsp {
        let spec = &resolved.spec;
        let model = electron_model(resolved, 0);
        let grey_photons = mid_grey_photons(resolved, target_lux);
        let black = model.expected_mean_dn(0.0, 0.0, gain_db);
        let range = model.max_dn() - black;
        let white_balance = std::array::from_fn(|c| {
            let signal =
                model.expected_mean_dn(grey_photons * matrix.grey_response(c), spec.exposure_s, gain_db) - black;
            (MID_GREY_REFLECTANCE * range / signal.max(f64::MIN_POSITIVE)) as f32
        });
        let colour_matrix = matrix.colour_correction().map(|row| row.map(|v| v as f32));
        let develop = Develop {
            black_level_dn: black as f32,
            white_balance,
            colour_matrix,
            ..Develop::new(pattern, model.adc_bits)
        };
        ColourIsp { matrix, develop }
    }

    /// The 8-bit sRGB image (interleaved RGB) of a raw mosaic.
    ///
    /// # Panics
    /// If `raw` is not a mosaic of this ISP's pattern.
    #[must_use]
    pub fn develop(&self, raw: &SensorImage) -> Vec<u8> {
        assert_eq!(raw.cfa, Some(self.develop.pattern), "a mosaic of the ISP's pattern");
        develop(&raw.dn, raw.width as usize, raw.height as usize, &self.develop)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera_spec::CameraSpec;
    use crate::sensor::Catalog;
    use crate::spectral::{Illuminant, NIGHT_CCT_K, QeCurves};
    use glam::Vec3;

    fn camera(noise: NoiseKind) -> ResolvedCamera {
        let spec = CameraSpec { vignetting: false, max_width_px: Some(32), noise, ..CameraSpec::new("IMX174") };
        spec.resolve(&Catalog::embedded()).unwrap()
    }

    /// A uniform grey at the scenario's mid-grey luminance develops to sRGB 118 in every channel,
    /// by day and by night (the white balance removes the warm light's tint).
    #[test]
    fn a_lit_mid_grey_develops_to_neutral_118() {
        let r = camera(NoiseKind::Off);
        let cam = r.camera(Vec3::ZERO, 0.0);
        let n = (cam.width_px * cam.height_px) as usize;
        let curves = QeCurves::typical_bayer(r.sensor.quantum_efficiency);
        for (illuminant, lux) in [(Illuminant::D65, 20.0), (Illuminant::Planck(NIGHT_CCT_K), 2.0)] {
            let matrix = ChannelMatrix::new(&curves, illuminant, illuminant.tint());
            let isp = ColourIsp::for_scenario(&r, CATALOG_PATTERN, matrix, 12.0, lux);
            let y = (MID_GREY_REFLECTANCE * lux / std::f64::consts::PI) as f32;
            let tinted = matrix.tint.map(|t| y * t as f32);
            let raw = capture_mosaic(&r, &cam, &vec![tinted; n], None, &matrix, CATALOG_PATTERN, 12.0, (1, 1));
            // Different channels see different signals on the mosaic ...
            let (r_dn, g_dn) = (raw.dn[0], raw.dn[1]);
            assert_ne!(r_dn, g_dn);
            // ... and the ISP brings them back to one grey.
            let out = isp.develop(&raw);
            assert!(out.iter().all(|&v| v.abs_diff(118) <= 2), "{illuminant:?}: {:?}", &out[..12]);
        }
    }

    /// A scenario's mix read in place gives the mosaic of the mixed buffer, bit for bit, alone or
    /// with a second scenario, with ideal optics (the one-pass path) and with defocus (the
    /// per-plane path).
    #[test]
    fn a_mix_read_in_place_matches_the_mixed_buffer() {
        let r = camera(NoiseKind::Emva);
        let cam = r.camera(Vec3::ZERO, 0.0);
        let n = (cam.width_px * cam.height_px) as usize;
        let day: Vec<[f32; 3]> =
            (0..n).map(|i| [0.3 + (i % 7) as f32 * 0.05, 0.2, 0.1 + (i % 3) as f32 * 0.1]).collect();
        let night: Vec<[f32; 3]> = (0..n).map(|i| [0.02, 0.01 * (i % 5) as f32, 0.03]).collect();
        let depth = vec![1.5f32; n];
        let matrix =
            ChannelMatrix::new(&QeCurves::typical_bayer(r.sensor.quantum_efficiency), Illuminant::D65, [1.0; 3]);
        let defocused = ResolvedCamera { spec: CameraSpec { defocus: true, ..r.spec.clone() }, ..r.clone() };
        for resolved in [&r, &defocused] {
            for (dw, nw) in [(3.5f32, 0.0f32), (0.0, 0.8), (1.0, 2.0)] {
                let mixed: Vec<[f32; 3]> =
                    day.iter().zip(&night).map(|(d, m)| std::array::from_fn(|c| d[c] * dw + m[c] * nw)).collect();
                let optics = || Some(OpticsInput { depth_m: &depth, velocity_m_s: Vec3::ZERO });
                let want = capture_mosaic(resolved, &cam, &mixed, optics(), &matrix, CATALOG_PATTERN, 6.0, (1, 2));
                let mix = Radiance::Mix { day: &day, night: &night, day_weight: dw, night_weight: nw };
                let scenario = MosaicScenario { radiance: mix, matrix: &matrix, gain_db: 6.0, frame_seed: 2 };
                let other = MosaicScenario { radiance: Radiance::Rgb(&day), frame_seed: 3, ..scenario };
                // Alone, and first of two scenarios taken together.
                let alone = capture_mosaics(resolved, &cam, optics(), CATALOG_PATTERN, 1, &[scenario]);
                let both = capture_mosaics(resolved, &cam, optics(), CATALOG_PATTERN, 1, &[scenario, other]);
                assert_eq!(alone[0], want, "defocus {} weights {dw} {nw}", resolved.spec.defocus);
                assert_eq!(both[0], want, "defocus {} weights {dw} {nw}", resolved.spec.defocus);
                assert_eq!(
                    both[1],
                    capture_mosaic(resolved, &cam, &day, optics(), &matrix, CATALOG_PATTERN, 6.0, (1, 3))
                );
            }
        }
    }

    #[test]
    fn noise_lands_on_the_mosaic() {
        let r = camera(NoiseKind::Emva);
        let cam = r.camera(Vec3::ZERO, 0.0);
        let n = (cam.width_px * cam.height_px) as usize;
        let matrix =
            ChannelMatrix::new(&QeCurves::typical_bayer(r.sensor.quantum_efficiency), Illuminant::D65, [1.0; 3]);
        // Dim light at high gain, so the binned pixels' noise spans many DN.
        let radiance = vec![[0.02f32; 3]; n];
        let gain = 30.0;
        let a = capture_mosaic(&r, &cam, &radiance, None, &matrix, CATALOG_PATTERN, gain, (1, 2));
        let b = capture_mosaic(&r, &cam, &radiance, None, &matrix, CATALOG_PATTERN, gain, (1, 3));
        assert_eq!(a, capture_mosaic(&r, &cam, &radiance, None, &matrix, CATALOG_PATTERN, gain, (1, 2)));
        assert_ne!(a.dn, b.dn, "a new frame seed draws new noise");
        // The mean of the green samples follows the expected mosaic.
        let off = ResolvedCamera { spec: CameraSpec { noise: NoiseKind::Off, ..r.spec.clone() }, ..r.clone() };
        let mean = capture_mosaic(&off, &cam, &radiance, None, &matrix, CATALOG_PATTERN, gain, (1, 2));
        let w = cam.width_px as usize;
        let greens = |img: &SensorImage| -> f64 {
            let v: Vec<f64> =
                (0..n).filter(|&i| CATALOG_PATTERN.channel(i % w, i / w) == 1).map(|i| f64::from(img.dn[i])).collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        assert!((greens(&a) / greens(&mean) - 1.0).abs() < 0.02, "{} vs {}", greens(&a), greens(&mean));
    }
}
