//! The 8-bit output rule: how a sensor's raw digital numbers become the 8-bit grey image that
//! ORB and the detectors see.
//!
//! Real pipelines never hand a detector the raw ADC value: an image signal processor (ISP)
//! subtracts the black level, applies a digital gain and a tone curve, and writes 8 bits. Feeding
//! the top 8 bits of a 12-bit ADC instead ([`OutputRule::TopBits`], the evaluator's first rule)
//! makes a 2 lux / 15 dB night frame about 3 DN bright, and ORB then finds no corners at all:
//! the night score measured the missing ISP, not the camera.
//!
//! [`OutputRule::Isp`] (the default) is a fixed, documented ISP, deterministic and independent of
//! image content (no per-frame auto-exposure or histogram statistics), so two cameras are compared
//! on the same footing:
//!
//! 1. **Black level**: subtract the sensor's black offset (the model's mean output with no light
//!    and no exposure time). Dark current is signal here, as it is to a real ISP.
//! 2. **Digital gain, fixed per scenario**: a Lambertian mid-grey surface (18 % reflectance,
//!    [`MID_GREY_REFLECTANCE`], the photographic reference grey of ISO 2720 light meters) lit at
//!    the scenario's target illuminance (20 lux by day, 2 lux by night) has luminance
//!    `L = 0.18 E / pi` nit; the camera equation, the exposure and the sensor model give its
//!    expected signal `S` in DN above black at the scenario gain. The digital gain maps `S` to
//!    linear 0.18, i.e. `x = 0.18 (DN - black) / S`. Day and night get the same brightness target,
//!    so a night frame is darker only in signal-to-noise ratio, not in mean: its larger gain
//!    amplifies its noise with it.
//! 3. **Tone curve**: the sRGB transfer function (IEC 61966-2-1: `12.92 x` below 0.0031308, else
//!    `1.055 x^(1/2.4) - 0.055`), clipped to [0, 1], so mid-grey lands at 118 of 255
//!    ([`MID_GREY_OUTPUT`]).
//! 4. **8 bits**: `round(255 y)`.
//!
//! Measured (`scene-gen evaluate --camera IMX174,focal_mm=4,pitch_deg=-10 --seeds 0..2`, 25
//! anchors, 320 px): with `top_bits` the night image averaged ~3 DN and ORB kept 1.6 keypoints
//! and 0 inliers per pair (day 183 keypoints, 88 inliers); with `isp` night has 565 keypoints and
//! 181 inliers per pair, day 1297 and 546: non-zero at night, still below day.
//!
//! A colour capture (the affine path, already 8-bit per channel) is reduced to linear luma
//! (Rec. 709 weights) first and goes through the same steps with its own black and mid-grey
//! levels scaled to 8 bits.
//!
//! [`to_8bit`] applies the rule to a [`SensorImage`]; [`capture_8bit`] is the evaluator's fused path
//! from a rendered frame's radiance to the 8-bit images of its scenarios, byte for byte the same
//! as [`crate::radiometry::capture_frame`] followed by [`to_8bit`], without the full-frame
//! intermediate buffers.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::camera_spec::{NoiseKind, ResolvedCamera};
use crate::optics::{OpticsInput, OpticsPlan};
use crate::radiometry::{SensorImage, capture_frame, photons_per_pixel};
use crate::sensor::noise::FrameSimulator;
use scene_gen_core::simd::Dispatch;
use scene_gen_render::{Camera, luminance};

/// Reflectance of the reference grey the digital gain is set on (18 %, the photographic
/// mid-grey that ISO 2720 reflected-light meters are calibrated to).
pub const MID_GREY_REFLECTANCE: f64 = 0.18;

/// 8-bit output of the reference grey under [`OutputRule::Isp`]: sRGB(0.18) x 255 = 117.6.
pub const MID_GREY_OUTPUT: f64 = 117.6;

/// How raw digital numbers become the 8-bit evaluation image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutputRule {
    /// Black level, fixed digital gain per scenario, sRGB curve, 8 bits (module docs).
    #[default]
    Isp,
    /// The top 8 bits of the ADC value (or the luma of an 8-bit colour capture), no gain.
    TopBits,
}

impl OutputRule {
    /// Parses `isp` or `top_bits`.
    ///
    /// # Errors
    /// A message naming the accepted values.
    pub fn parse(text: &str) -> Result<Self, String> {
        match text.trim().to_ascii_lowercase().replace('-', "_").as_str() {
            "isp" => Ok(OutputRule::Isp),
            "top_bits" => Ok(OutputRule::TopBits),
            other => Err(format!("output rule '{other}': expected isp or top_bits")),
        }
    }
}

/// The fixed ISP of one camera in one scenario.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Isp {
    /// Black offset subtracted, in the capture's units (ADC DN, or 8-bit values on the affine
    /// path).
    pub black: f64,
    /// Expected signal of the reference grey above black, same units.
    pub mid_grey_signal: f64,
}

impl Isp {
    /// The ISP for `resolved` at `gain_db` when the scenario's target illuminance is
    /// `target_lux`, for captures of `channels` channels (1: ADC DN; 3: the 8-bit affine path).
    #[must_use]
    pub fn for_scenario(resolved: &ResolvedCamera, gain_db: f64, target_lux: f64, channels: u8) -> Isp {
        let spec = &resolved.spec;
        let model = resolved.sensor_model(0);
        let photons = mid_grey_photons(resolved, target_lux);
        // No light and no time: the black offset alone.
        let black = model.expected_mean_dn(0.0, 0.0, gain_db);
        let grey = model.expected_mean_dn(photons, spec.exposure_s, gain_db);
        let scale = if channels == 3 { 255.0 / model.max_dn() } else { 1.0 };
        Isp { black: black * scale, mid_grey_signal: ((grey - black) * scale).max(f64::MIN_POSITIVE) }
    }

    /// Output byte of one linear value (capture units).
    #[must_use]
    pub fn apply(&self, value: f64) -> u8 {
        self.level(value).round().clamp(0.0, 255.0) as u8
    }

    /// The continuous output level in [0, 255] of one linear value, before rounding (what
    /// [`Isp::apply`] rounds; the detector's noise table carries noise through it).
    #[must_use]
    pub fn level(&self, value: f64) -> f64 {
        let x = (MID_GREY_REFLECTANCE * (value - self.black) / self.mid_grey_signal).clamp(0.0, 1.0);
        255.0 * srgb_encode(x)
    }
}

/// Mean 555 nm-equivalent photons per pixel, on axis, from the reference grey
/// ([`MID_GREY_REFLECTANCE`], Lambertian) lit at `target_lux`: what the ISPs set their gain on.
#[must_use]
pub fn mid_grey_photons(resolved: &ResolvedCamera, target_lux: f64) -> f64 {
    let spec = &resolved.spec;
    photons_per_pixel(
        MID_GREY_REFLECTANCE * target_lux / std::f64::consts::PI,
        f64::from(spec.f_number),
        f64::from(spec.lens_transmittance),
        1.0,
        spec.exposure_s,
        f64::from(resolved.pixel_pitch_um),
    )
}

/// The sRGB transfer function (IEC 61966-2-1), linear [0, 1] to encoded [0, 1].
#[must_use]
pub fn srgb_encode(x: f64) -> f64 {
    if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 }
}

/// Inverse of [`srgb_encode`] (IEC 61966-2-1), encoded [0, 1] to linear [0, 1].
#[must_use]
pub fn srgb_decode(e: f64) -> f64 {
    if e <= 0.040_45 { e / 12.92 } else { ((e + 0.055) / 1.055).powf(2.4) }
}

/// Rec. 709 luma of a linear RGB triple.
fn luma(c: &[u16]) -> f64 {
    0.2126 * f64::from(c[0]) + 0.7152 * f64::from(c[1]) + 0.0722 * f64::from(c[2])
}

/// The 8-bit grey image of `cap` under `rule` (`isp` is used by [`OutputRule::Isp`] only).
#[must_use]
pub fn to_8bit(cap: &SensorImage, rule: OutputRule, isp: &Isp) -> Vec<u8> {
    match (rule, cap.channels) {
        (OutputRule::TopBits, 3) => cap.dn.chunks_exact(3).map(|c| luma(c).round().clamp(0.0, 255.0) as u8).collect(),
        (OutputRule::Isp, 3) => cap.dn.chunks_exact(3).map(|c| isp.apply(luma(c))).collect(),
        (_, _) => {
            let lut = grey_lut(rule, cap.bits, isp);
            cap.dn.iter().map(|&v| lut[usize::from(v).min(lut.len() - 1)]).collect()
        }
    }
}

/// The output byte of every possible DN of a one-channel capture of `bits` bits: both rules are
/// pure functions of the value there.
fn grey_lut(rule: OutputRule, bits: u32, isp: &Isp) -> Vec<u8> {
    let values = 0..(1u32 << bits.min(16));
    match rule {
        OutputRule::Isp => values.map(|v| isp.apply(f64::from(v))).collect(),
        OutputRule::TopBits => {
            let shift = bits.saturating_sub(8);
            values.map(|v| (v >> shift).min(255) as u8).collect()
        }
    }
}

/// One scenario of [`capture_8bit`]: the frame's radiance is `day_weight x day + night_weight x
/// night` (as [`scene_gen_render::Frame::mix`]), captured at `gain_db` with temporal noise
/// `frame_seed`, and output through `isp`.
#[derive(Clone, Copy, Debug)]
pub struct Scenario<'a> {
    pub day_weight: f32,
    pub night_weight: f32,
    pub gain_db: f64,
    pub frame_seed: u64,
    pub isp: &'a Isp,
}

impl Scenario<'_> {
    /// The scenario's radiance of one pixel from its day and night radiance.
    #[must_use]
    #[inline]
    pub fn mix(&self, day: &[f32; 3], night: &[f32; 3]) -> [f32; 3] {
        std::array::from_fn(|c| day[c] * self.day_weight + night[c] * self.night_weight)
    }
}

/// The 8-bit images the evaluator sees of one rendered frame, one per scenario: the same bytes
/// as `to_8bit(&capture_frame(resolved, camera, &mix, optics, gain_db, pattern_seed,
/// frame_seed), rule, isp)` with `mix` the scenario's [`scene_gen_render::Frame::mix`].
///
/// Why a second path: that chain writes five full-frame buffers per image (the mixed RGB
/// radiance, luminance, photons, DN and bytes, 50 MB at 1936 x 1216, each a fresh allocation
/// the kernel must zero) and computes the cos^4 fall-off with the camera basis (two sines and
/// cosines) at every pixel. Here, when the capture is the EMVA model and the optics change
/// nothing (the evaluator's case), each row goes from radiance to bytes in one pass through
/// [`crate::sensor::noise::FrameSimulator::row`], rows in parallel, the fall-off computed once
/// per pixel for all scenarios; only the bytes are written. Other captures take the chain
/// above.
///
/// The rows run in the AVX2 + FMA build where the CPU has it ([`scene_gen_core::simd`]; the same bytes
/// either way, `SCENE_GEN_NO_SIMD=1` forces the baseline build).
///
/// # Panics
/// If `day_nit` or `night_nit` is not the camera's pixel count.
#[must_use]
#[allow(clippy::too_many_arguments)]
pub fn capture_8bit(
    resolved: &ResolvedCamera,
    camera: &Camera,
    day_nit: &[[f32; 3]],
    night_nit: &[[f32; 3]],
    optics: Option<OpticsInput<'_>>,
    pattern_seed: u64,
    rule: OutputRule,
    scenarios: &[Scenario<'_>],
) -> Vec<Vec<u8>> {
    capture_8bit_with(Dispatch::current(), resolved, camera, day_nit, night_nit, optics, pattern_seed, rule, scenarios)
}

/// [`capture_8bit`] with the fused rows in the build `dispatch` (downgraded to
/// [`Dispatch::Generic`] where the CPU lacks it): tests compare the two builds with it.
#[must_use]
#[allow(clippy::too_many_arguments)]
pub(crate) fn capture_8bit_with(
    dispatch: Dispatch,
    resolved: &ResolvedCamera,
    camera: &Camera,
    day_nit: &[[f32; 3]],
    night_nit: &[[f32; 3]],
    optics: Option<OpticsInput<'_>>,
    pattern_seed: u64,
    rule: OutputRule,
    scenarios: &[Scenario<'_>],
) -> Vec<Vec<u8>> {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    assert!(day_nit.len() == w * h && night_nit.len() == w * h, "radiance must have one value per pixel");
    let fused =
        resolved.spec.noise == NoiseKind::Emva && OpticsPlan::new(resolved, camera, optics.as_ref()).is_identity();
    if !fused || w == 0 {
        return scenarios
            .iter()
            .map(|s| {
                let radiance: Vec<[f32; 3]> = day_nit.iter().zip(night_nit).map(|(d, n)| s.mix(d, n)).collect();
                let cap = capture_frame(resolved, camera, &radiance, optics, s.gain_db, pattern_seed, s.frame_seed);
                to_8bit(&cap, rule, s.isp)
            })
            .collect();
    }
    let spec = &resolved.spec;
    let model = resolved.sensor_model(pattern_seed);
    let pattern = model.fixed_pattern(w, h);
    let sims: Vec<_> =
        scenarios.iter().map(|s| model.frame_simulator(&pattern, spec.exposure_s, s.gain_db, s.frame_seed)).collect();
    let luts: Vec<Vec<u8>> = scenarios.iter().map(|s| grey_lut(rule, model.adc_bits, s.isp)).collect();
    let fused = FusedRows {
        camera,
        basis: camera.basis(),
        day_nit,
        night_nit,
        scenarios,
        sims: &sims,
        luts: &luts,
        f_number: f64::from(camera.f_number),
        transmittance: f64::from(spec.lens_transmittance),
        pitch_um: f64::from(camera.pixel_pitch_um),
        exposure_s: spec.exposure_s,
    };
    let n = scenarios.len();
    let dispatch = dispatch.supported();
    // Row r of scenario s at [(r n + s) w, (r n + s + 1) w): one chunk per row for all scenarios.
    let mut rows = vec![0u8; n * w * h];
    rows.par_chunks_mut(n * w).enumerate().for_each_init(
        || (vec![0f32; w], vec![0f32; w]),
        |(falloff, photons), (r, out)| match dispatch {
            // SAFETY: `supported()` gives `Avx2Fma` only when this CPU has AVX2 and FMA.
            #[cfg(target_arch = "x86_64")]
            Dispatch::Avx2Fma => unsafe { fused.row_avx2(r, out, falloff, photons) },
            _ => fused.row(r, out, falloff, photons),
        },
    );
    (0..n)
        .map(|s| {
            let mut grey = Vec::with_capacity(w * h);
            rows.chunks_exact(w).skip(s).step_by(n).for_each(|row| grey.extend_from_slice(row));
            grey
        })
        .collect()
}

/// The per-frame inputs of [`capture_8bit`]'s fused rows.
struct FusedRows<'a> {
    camera: &'a Camera,
    basis: (glam::Vec3, glam::Vec3, glam::Vec3),
    day_nit: &'a [[f32; 3]],
    night_nit: &'a [[f32; 3]],
    scenarios: &'a [Scenario<'a>],
    sims: &'a [FrameSimulator<'a>],
    luts: &'a [Vec<u8>],
    f_number: f64,
    transmittance: f64,
    pitch_um: f64,
    exposure_s: f64,
}

impl FusedRows<'_> {
    /// [`FusedRows::row`] compiled with AVX2 and FMA enabled: the photon conversion, the noise
    /// draws of [`FrameSimulator::row`] and the look-up get AVX2 code.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA: call it only when [`Dispatch::supported`] returned
    /// [`Dispatch::Avx2Fma`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn row_avx2(&self, r: usize, out: &mut [u8], falloff: &mut [f32], photons: &mut [f32]) {
        self.row(r, out, falloff, photons);
    }

    /// Row `r` of every scenario into `out` (scenario `s` at `[s w, (s + 1) w)`), with
    /// `falloff` and `photons` one row of scratch each. Always inlined, so that each caller
    /// (the baseline loop and [`FusedRows::row_avx2`]) compiles its own copy.
    #[inline(always)]
    fn row(&self, r: usize, out: &mut [u8], falloff: &mut [f32], photons: &mut [f32]) {
        let w = falloff.len();
        let y = r as f32 + 0.5;
        for (c, v) in falloff.iter_mut().enumerate() {
            *v = self.camera.relative_illumination_in(self.basis, c as f32 + 0.5, y);
        }
        let (day, night) = (&self.day_nit[r * w..(r + 1) * w], &self.night_nit[r * w..(r + 1) * w]);
        for (s, scenario) in self.scenarios.iter().enumerate() {
            // radiometry::photon_image of the scenario's luminance.
            for (((p, d), nt), &fall) in photons.iter_mut().zip(day).zip(night).zip(falloff.iter()) {
                let l = luminance(glam::Vec3::from(scenario.mix(d, nt)));
                *p = photons_per_pixel(
                    f64::from(l.max(0.0)),
                    self.f_number,
                    self.transmittance,
                    f64::from(fall),
                    self.exposure_s,
                    self.pitch_um,
                ) as f32;
            }
            let (sim, lut) = (&self.sims[s], &self.luts[s]);
            let out = &mut out[s * w..(s + 1) * w];
            sim.row(r, photons, |c, v| out[c] = lut[usize::from(sim.to_u16(v)).min(lut.len() - 1)]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera_spec::CameraSpec;
    use crate::sensor::Catalog;

    #[test]
    fn srgb_decode_inverts_the_encoding() {
        for i in 0..=100 {
            let x = f64::from(i) / 100.0;
            assert!((srgb_decode(srgb_encode(x)) - x).abs() < 1e-9, "{x}");
        }
    }

    #[test]
    fn srgb_curve_and_mid_grey() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-12);
        assert!((255.0 * srgb_encode(0.18) - MID_GREY_OUTPUT).abs() < 0.1);
        // Continuous at the knee.
        assert!((12.92 * 0.003_130_8 - (1.055 * 0.003_130_8f64.powf(1.0 / 2.4) - 0.055)).abs() < 1e-5);
    }

    #[test]
    fn mid_grey_lands_at_the_same_level_by_day_and_night() {
        let r =
            CameraSpec { max_width_px: Some(64), ..CameraSpec::new("IMX174") }.resolve(&Catalog::embedded()).unwrap();
        let day = Isp::for_scenario(&r, 5.0, 20.0, 1);
        let night = Isp::for_scenario(&r, 15.0, 2.0, 1);
        // Night: a tenth of the light at 10 dB (3.16x) more gain -> 0.316x the signal, so ~3.16x
        // the digital gain.
        let ratio = day.mid_grey_signal / night.mid_grey_signal;
        assert!((ratio - 10f64.sqrt()).abs() < 0.05, "{ratio}");
        for isp in [day, night] {
            assert_eq!(isp.apply(isp.black + isp.mid_grey_signal), 118);
            assert_eq!(isp.apply(isp.black), 0);
            assert_eq!(isp.apply(isp.black + 100.0 * isp.mid_grey_signal), 255);
        }
        // The same raw step is brighter at night (larger gain): noise is amplified with it.
        assert!(night.apply(night.black + 20.0) > day.apply(day.black + 20.0));
    }

    #[test]
    fn rules_parse_and_top_bits_keeps_the_old_rule() {
        assert_eq!(OutputRule::parse("ISP"), Ok(OutputRule::Isp));
        assert_eq!(OutputRule::parse("top-bits"), Ok(OutputRule::TopBits));
        assert!(OutputRule::parse("auto").is_err());
        let cap = SensorImage { width: 2, height: 1, channels: 1, bits: 12, cfa: None, dn: vec![4095, 300] };
        let isp = Isp { black: 64.0, mid_grey_signal: 100.0 };
        assert_eq!(to_8bit(&cap, OutputRule::TopBits, &isp), vec![255, 18]);
        let out = to_8bit(&cap, OutputRule::Isp, &isp);
        assert_eq!(out[0], 255);
        assert_eq!(out[1], isp.apply(300.0));
    }

    /// A small camera and a random frame: day and night radiance, depth for the optics.
    type SmallFrame = (ResolvedCamera, Camera, Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<f32>);

    fn small_frame(spec: CameraSpec) -> SmallFrame {
        use rand::Rng;
        let resolved = CameraSpec { max_width_px: Some(48), ..spec }.resolve(&Catalog::embedded()).unwrap();
        let pose =
            scene_gen_scene::trajectory::Pose { position: glam::Vec3::new(1.0, 2.0, 1.0), yaw_deg: 30.0, time_s: 0.0 };
        let camera = resolved.camera_at(&pose);
        let n = (camera.width_px * camera.height_px) as usize;
        let mut rng = scene_gen_core::rng::stream(9, "test");
        // Dark to bright (0 to ~30 nit by day): both Poisson branches, clipping at the top.
        let mut radiance = |scale: f32| -> Vec<[f32; 3]> {
            (0..n).map(|_| std::array::from_fn(|_| scale * rng.random::<f32>().powi(3))).collect()
        };
        let (day, night) = (radiance(30.0), radiance(3.0));
        let depth = (0..n).map(|i| 0.5 + (i % 7) as f32).collect();
        (resolved, camera, day, night, depth)
    }

    /// The chain the fused path replaces: mix, capture_frame, to_8bit.
    fn chain(
        r: &ResolvedCamera,
        camera: &Camera,
        day: &[[f32; 3]],
        night: &[[f32; 3]],
        optics: Option<OpticsInput<'_>>,
        rule: OutputRule,
        s: &Scenario<'_>,
    ) -> Vec<u8> {
        let mix: Vec<[f32; 3]> = day.iter().zip(night).map(|(d, n)| s.mix(d, n)).collect();
        to_8bit(&capture_frame(r, camera, &mix, optics, s.gain_db, 3, s.frame_seed), rule, s.isp)
    }

    #[test]
    fn fused_capture_gives_the_bytes_of_the_chain() {
        let cases = [
            ("IMX174,focal_mm=4,pitch_deg=-10", OutputRule::Isp),
            ("IMX174,focal_mm=4,vignetting=false", OutputRule::Isp),
            ("IMX174,focal_mm=6", OutputRule::TopBits),
            // Not fused (optics that change the image, the affine noise): the chain itself.
            ("IMX174,focal_mm=4,motion_blur=true,motion_speed_m_s=3", OutputRule::Isp),
            ("IMX174,focal_mm=4,noise=affine", OutputRule::Isp),
        ];
        for (text, rule) in cases {
            let (r, camera, day, night, depth) = small_frame(CameraSpec::from_inline(text).unwrap());
            let channels = if r.spec.noise == NoiseKind::Affine { 3 } else { 1 };
            let isps = [Isp::for_scenario(&r, 5.0, 20.0, channels), Isp::for_scenario(&r, 15.0, 2.0, channels)];
            let scenarios = [
                Scenario { day_weight: 1.0, night_weight: 0.0, gain_db: 5.0, frame_seed: 11, isp: &isps[0] },
                Scenario { day_weight: 0.0, night_weight: 1.3, gain_db: 15.0, frame_seed: 12, isp: &isps[1] },
                Scenario { day_weight: 0.7, night_weight: 0.2, gain_db: 0.0, frame_seed: 13, isp: &isps[0] },
            ];
            let optics = OpticsInput { depth_m: &depth, velocity_m_s: glam::Vec3::new(1.0, 0.5, 0.0) };
            let fused = capture_8bit(&r, &camera, &day, &night, Some(optics), 3, rule, &scenarios);
            assert_eq!(fused.len(), scenarios.len());
            for (s, grey) in scenarios.iter().zip(&fused) {
                let want = chain(&r, &camera, &day, &night, Some(optics), rule, s);
                assert_eq!(grey, &want, "{text}: scenario {s:?}");
                // Not a constant image: the comparison means something.
                assert!(grey.iter().any(|&v| v != grey[0]), "{text}");
            }
        }
    }

    #[test]
    fn fused_capture_is_the_same_at_any_thread_count() {
        let (r, camera, day, night, _) = small_frame(CameraSpec::from_inline("IMX174,focal_mm=4").unwrap());
        let isp = Isp::for_scenario(&r, 15.0, 2.0, 1);
        let scenarios = [Scenario { day_weight: 0.0, night_weight: 1.0, gain_db: 15.0, frame_seed: 5, isp: &isp }];
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| capture_8bit(&r, &camera, &day, &night, None, 1, OutputRule::Isp, &scenarios))
        };
        let one = run(1);
        assert_eq!(one, run(3));
        // A different frame seed gives different noise.
        let other = [Scenario { frame_seed: 6, ..scenarios[0] }];
        assert_ne!(one, capture_8bit(&r, &camera, &day, &night, None, 1, OutputRule::Isp, &other));
    }

    /// The fused rows in the AVX2 clone give the baseline's bytes: day, night and a mix, with
    /// and without the cos^4 fall-off, both output rules.
    #[test]
    fn the_avx2_clone_captures_the_bytes_of_the_baseline() {
        use scene_gen_core::simd::Dispatch;
        for (text, rule) in [
            ("IMX174,focal_mm=4,pitch_deg=-10", OutputRule::Isp),
            ("IMX174,focal_mm=4,vignetting=false", OutputRule::Isp),
            ("IMX174,focal_mm=6", OutputRule::TopBits),
        ] {
            let (r, camera, day, night, _) = small_frame(CameraSpec::from_inline(text).unwrap());
            let isps = [Isp::for_scenario(&r, 5.0, 20.0, 1), Isp::for_scenario(&r, 15.0, 2.0, 1)];
            let scenarios = [
                Scenario { day_weight: 1.0, night_weight: 0.0, gain_db: 5.0, frame_seed: 11, isp: &isps[0] },
                Scenario { day_weight: 0.0, night_weight: 1.3, gain_db: 15.0, frame_seed: 12, isp: &isps[1] },
                Scenario { day_weight: 0.7, night_weight: 0.2, gain_db: 0.0, frame_seed: 13, isp: &isps[0] },
            ];
            let run = |d| capture_8bit_with(d, &r, &camera, &day, &night, None, 3, rule, &scenarios);
            let generic = run(Dispatch::Generic);
            assert!(generic.iter().all(|g| g.iter().any(|&v| v != g[0])), "{text}: a constant image");
            assert_eq!(generic, run(Dispatch::Avx2Fma), "{text}");
        }
    }
}
