//! The radiometric chain from rendered scene radiance to the digital numbers of a sensor.
//!
//! ```text
//! L (nit)  ──camera equation──►  E = pi L T R / (4 N^2)  (lux on the sensor; R = cos^4 with vignetting)
//!          ──exposure, pixel──►  photons = E t A K_ph     (A pixel area m^2, K_ph = PHOTONS_PER_LUX_S_M2)
//!          ──SensorModel──────►  e- = QE photons + noise ──► DN at the ADC depth and the scenario gain
//! ```
//!
//! The EMVA path works on luminance (one grey channel; the catalog QE is "near 550 nm"). The
//! affine path of the reference paper works per colour channel on 8-bit values: each channel's
//! radiance goes through the same chain to its noiseless mean DN, scaled to 8 bits, and then
//! gets the affine noise `var = g sigma_p^2 I + g^2 sigma_t^2` (see [`AffineNoise`]).
//!
//! Between the camera equation and the noise, the lens and motion effects of [`crate::optics`]
//! (diffraction, defocus, motion blur) redistribute the mean photons per pixel, which is the
//! sensor-plane irradiance up to a constant: [`capture_frame`] takes the depth buffer and the
//! camera velocity they need; [`capture`] applies only the ones that need neither.

use crate::camera_spec::{NoiseKind, ResolvedCamera};
use crate::demosaic::CfaPattern;
use crate::optics::{OpticsInput, OpticsPlan, apply_plan};
use crate::sensor::AffineNoise;
use scene_gen_render::{Camera, luminance, sensor_illuminance_lux};

/// Planck constant times the speed of light, J m (CODATA 2018 exact values).
const H_C_J_M: f64 = 6.626_070_15e-34 * 299_792_458.0;

/// Photons per second per square metre in one lux, for monochromatic light at 555 nm: a lux
/// is 1/683 W/m^2 there (the SI definition of the candela, 540 THz ~ 555 nm) and a photon
/// carries `h c / 555 nm = 3.58e-19 J`, so 1 lux = 4.09e15 photons/(s m^2). Chosen over the
/// broadband daylight figure (~1.1e16 over 400-700 nm) because the catalog's quantum
/// efficiencies are quoted near 550 nm and EMVA 1288 measures with monochromatic light: the
/// pair (QE, K_ph) is then consistent. Broadband light would give ~2.7x the photons at a
/// spectrally averaged (lower) QE.
pub const PHOTONS_PER_LUX_S_M2: f64 = 1.0 / 683.0 / (H_C_J_M / 555e-9);

/// Mean photons reaching one pixel: `E t A K_ph` with `E` from the camera equation.
#[must_use]
#[inline]
pub fn photons_per_pixel(
    luminance_nit: f64,
    f_number: f64,
    transmittance: f64,
    relative_illumination: f64,
    exposure_s: f64,
    pixel_pitch_um: f64,
) -> f64 {
    let e_lux = f64::from(sensor_illuminance_lux(
        luminance_nit as f32,
        f_number as f32,
        transmittance as f32,
        relative_illumination as f32,
    ));
    let area_m2 = (pixel_pitch_um * 1e-6) * (pixel_pitch_um * 1e-6);
    e_lux * exposure_s * area_m2 * PHOTONS_PER_LUX_S_M2
}

/// Mean photons per pixel of a `camera`'s frame for a per-pixel `luminance_nit` buffer
/// (row-major, `width * height`); the relative illumination is taken at each pixel centre.
#[must_use]
pub fn photon_image(camera: &Camera, luminance_nit: &[f32], transmittance: f32, exposure_s: f64) -> Vec<f32> {
    let per_nit = PhotonsPerNit::new(camera, transmittance, exposure_s);
    let w = camera.width_px as usize;
    luminance_nit.iter().enumerate().map(|(i, &l)| per_nit.photons(l, i % w, i / w)).collect()
}

/// The camera equation of one frame with what is the same for every pixel worked out once:
/// [`photon_image`] one pixel at a time, for passes that fuse it with their own per-pixel work.
#[derive(Clone, Copy, Debug)]
pub struct PhotonsPerNit<'a> {
    camera: &'a Camera,
    basis: (glam::Vec3, glam::Vec3, glam::Vec3),
    transmittance: f32,
    exposure_s: f64,
}

impl<'a> PhotonsPerNit<'a> {
    #[must_use]
    pub fn new(camera: &'a Camera, transmittance: f32, exposure_s: f64) -> PhotonsPerNit<'a> {
        PhotonsPerNit { camera, basis: camera.basis(), transmittance, exposure_s }
    }

    /// Mean photons at pixel (`x`, `y`) for a luminance of `luminance_nit` (negative read as 0).
    #[must_use]
    #[inline]
    pub fn photons(&self, luminance_nit: f32, x: usize, y: usize) -> f32 {
        let camera = self.camera;
        photons_per_pixel(
            f64::from(luminance_nit.max(0.0)),
            f64::from(camera.f_number),
            f64::from(self.transmittance),
            f64::from(camera.relative_illumination_in(self.basis, x as f32 + 0.5, y as f32 + 0.5)),
            self.exposure_s,
            f64::from(camera.pixel_pitch_um),
        ) as f32
    }
}

/// One simulated sensor image: the digital numbers the ADC reads out.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorImage {
    pub width: u32,
    pub height: u32,
    /// 1 (grey) or 3 (RGB, interleaved).
    pub channels: u8,
    /// Significant bits of a value: the ADC depth, or 8 on the affine path.
    pub bits: u32,
    /// The colour filter layout when the values are a raw Bayer mosaic (one channel).
    pub cfa: Option<CfaPattern>,
    /// Row-major values, `width * height * channels`.
    pub dn: Vec<u16>,
}

impl SensorImage {
    /// Mean and (population) variance over every value, DN and DN^2.
    #[must_use]
    pub fn mean_variance(&self) -> (f64, f64) {
        mean_variance(&self.dn)
    }
}

/// Mean and population variance of a buffer of values.
#[must_use]
pub fn mean_variance(values: &[u16]) -> (f64, f64) {
    let n = values.len().max(1) as f64;
    let mean = values.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let var = values.iter().map(|&v| (f64::from(v) - mean).powi(2)).sum::<f64>() / n;
    (mean, var)
}

/// Simulates the image of `radiance` (linear RGB nit per pixel, already scaled to the
/// scenario) seen by `resolved` as `camera`, at `gain_db`. `pattern_seed` fixes the sensor
/// instance, `frame_seed` the temporal noise. Of the optics only those that need no depth
/// (diffraction) apply; see [`capture_frame`].
///
/// # Panics
/// If `radiance.len()` is not the camera's pixel count.
#[must_use]
pub fn capture(
    resolved: &ResolvedCamera,
    camera: &Camera,
    radiance: &[[f32; 3]],
    gain_db: f64,
    pattern_seed: u64,
    frame_seed: u64,
) -> SensorImage {
    capture_frame(resolved, camera, radiance, None, gain_db, pattern_seed, frame_seed)
}

/// [`capture`] with the frame's depth buffer and camera velocity, so every optical effect the
/// spec turns on applies ([`crate::optics`]): defocus and motion blur need `optics`; with
/// `None` they are skipped.
///
/// # Panics
/// If `radiance.len()` or `optics.depth_m.len()` is not the camera's pixel count.
#[must_use]
pub fn capture_frame(
    resolved: &ResolvedCamera,
    camera: &Camera,
    radiance: &[[f32; 3]],
    optics: Option<OpticsInput<'_>>,
    gain_db: f64,
    pattern_seed: u64,
    frame_seed: u64,
) -> SensorImage {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    assert_eq!(radiance.len(), w * h, "radiance must have one value per pixel");
    let spec = &resolved.spec;
    let model = resolved.sensor_model(pattern_seed);
    let t = spec.exposure_s;
    let plan = OpticsPlan::new(resolved, camera, optics.as_ref());
    // Sensor-plane signal (mean photons, proportional to irradiance) through the optics.
    let sensor_plane = |values: &[f32]| -> Vec<f32> {
        let mut photons = photon_image(camera, values, spec.lens_transmittance, t);
        if !plan.is_identity() {
            apply_plan(&plan, camera, &mut photons, optics.as_ref());
        }
        photons
    };
    match spec.noise {
        NoiseKind::Emva => {
            let lum: Vec<f32> = radiance.iter().map(|c| luminance(glam::Vec3::from(*c))).collect();
            let photons = sensor_plane(&lum);
            let dn = model.simulate(&photons, w, h, t, gain_db, frame_seed);
            SensorImage {
                width: camera.width_px,
                height: camera.height_px,
                channels: 1,
                bits: model.adc_bits,
                cfa: None,
                dn,
            }
        }
        NoiseKind::Off => {
            let lum: Vec<f32> = radiance.iter().map(|c| luminance(glam::Vec3::from(*c))).collect();
            let photons = sensor_plane(&lum);
            let max = model.max_dn();
            let dn = photons
                .iter()
                .map(|&p| model.expected_mean_dn(f64::from(p), t, gain_db).round().clamp(0.0, max) as u16);
            SensorImage {
                width: camera.width_px,
                height: camera.height_px,
                channels: 1,
                bits: model.adc_bits,
                cfa: None,
                dn: dn.collect(),
            }
        }
        NoiseKind::Affine => {
            let scale = 255.0 / model.max_dn();
            let channel_photons: Vec<Vec<f32>> = (0..3)
                .map(|c| {
                    let l: Vec<f32> = radiance.iter().map(|px| px[c]).collect();
                    sensor_plane(&l)
                })
                .collect();
            let mut rgb8 = vec![0u8; w * h * 3];
            for (i, v) in rgb8.iter_mut().enumerate() {
                let p = channel_photons[i % 3][i / 3];
                *v = (model.expected_mean_dn(f64::from(p), t, gain_db) * scale).round().clamp(0.0, 255.0) as u8;
            }
            let noisy = AffineNoise::default().apply_rgb8(&rgb8, w, gain_db, resolved.pixel_area_um2(), frame_seed);
            SensorImage {
                width: camera.width_px,
                height: camera.height_px,
                channels: 3,
                bits: 8,
                cfa: None,
                dn: noisy.into_iter().map(u16::from).collect(),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera_spec::CameraSpec;
    use crate::sensor::Catalog;
    use glam::Vec3;

    #[test]
    fn lux_to_photon_constant() {
        // 1/683 W/m^2 over 3.58e-19 J per photon.
        assert!((PHOTONS_PER_LUX_S_M2 / 4.09e15 - 1.0).abs() < 2e-3, "{PHOTONS_PER_LUX_S_M2:e}");
    }

    /// A uniform 10 nit scene on axis, worked by hand: E = pi 10 0.9 / (4 2^2) = 1.76715 lux;
    /// IMX174 pixel 5.86 um -> A = 3.43396e-11 m^2; t = 1/30 s; photons = 1.76715 / 30
    /// 3.43396e-11 4.0906e15 = 8274.4; e- = QE (catalog) x that.
    #[test]
    fn uniform_luminance_by_hand() {
        let catalog = Catalog::embedded();
        let spec = CameraSpec {
            vignetting: false,
            max_width_px: Some(64),
            noise: NoiseKind::Off,
            ..CameraSpec::new("IMX174")
        };
        let mut r = spec.resolve(&catalog).unwrap();
        // Undo the binning's pitch change for the hand figure: one real pixel.
        r.pixel_pitch_um = 5.86;
        r.bin_factor = 1.0;
        let cam = r.camera(Vec3::new(0.0, 0.0, 1.0), 0.0);
        let e_lux = std::f64::consts::PI * 10.0 * 0.9 / 16.0;
        let photons_hand = e_lux / 30.0 * (5.86e-6f64 * 5.86e-6) * 4.0906e15;
        assert!((photons_hand - 8274.4).abs() < 1.0, "{photons_hand}");
        let photons = photon_image(&cam, &vec![10.0; (cam.width_px * cam.height_px) as usize], 0.9, 1.0 / 30.0);
        assert!((f64::from(photons[0]) / photons_hand - 1.0).abs() < 0.01, "{} vs {photons_hand}", photons[0]);

        // Mean DN with noise on, at the day gain: black + K g QE photons (+ dark t), within 1 %.
        let spec_n = CameraSpec { noise: NoiseKind::Emva, ..r.spec.clone() };
        let r = ResolvedCamera { spec: spec_n, ..r };
        let model = r.sensor_model(1);
        let qe = r.sensor.quantum_efficiency;
        let k = model.system_gain_dn_per_e * 10f64.powf(5.0 / 20.0);
        let black = f64::from(1u32 << model.adc_bits) / 64.0;
        let dark = r.sensor.dark_current_e_per_s / 30.0;
        let expected_dn = black + k * (qe * photons_hand + dark);
        let radiance = vec![[10.0f32; 3]; (cam.width_px * cam.height_px) as usize];
        let cap = capture(&r, &cam, &radiance, 5.0, 1, 2);
        let (mean, var) = cap.mean_variance();
        assert!((mean / expected_dn - 1.0).abs() < 0.01, "mean {mean} vs {expected_dn}");
        // Shot noise dominates: var ~ K^2 (QE photons + read^2) within 10 % (few pixels).
        let expected_var = k * k * (qe * photons_hand + dark + r.sensor.read_noise_e.powi(2)) + 1.0 / 12.0;
        assert!((var / expected_var - 1.0).abs() < 0.1, "var {var} vs {expected_var}");
    }

    #[test]
    fn vignetting_darkens_the_corners() {
        let catalog = Catalog::embedded();
        let r = CameraSpec { max_width_px: Some(40), ..CameraSpec::new("IMX174") }.resolve(&catalog).unwrap();
        let cam = r.camera(Vec3::ZERO, 0.0);
        let n = (cam.width_px * cam.height_px) as usize;
        let p = photon_image(&cam, &vec![5.0; n], 0.9, 0.01);
        let centre = p[(cam.height_px / 2 * cam.width_px + cam.width_px / 2) as usize];
        assert!(p[0] < 0.9 * centre, "corner {} centre {centre}", p[0]);
    }
}
