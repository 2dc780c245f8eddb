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

use serde::{Deserialize, Serialize};

use crate::camera_spec::ResolvedCamera;
use crate::radiometry::{Capture, photons_per_pixel};

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
        let luminance_nit = MID_GREY_REFLECTANCE * target_lux / std::f64::consts::PI;
        let photons = photons_per_pixel(
            luminance_nit,
            f64::from(spec.f_number),
            f64::from(spec.lens_transmittance),
            1.0,
            spec.exposure_s,
            f64::from(resolved.pixel_pitch_um),
        );
        // No light and no time: the black offset alone.
        let black = model.expected_mean_dn(0.0, 0.0, gain_db);
        let grey = model.expected_mean_dn(photons, spec.exposure_s, gain_db);
        let scale = if channels == 3 { 255.0 / model.max_dn() } else { 1.0 };
        Isp { black: black * scale, mid_grey_signal: ((grey - black) * scale).max(f64::MIN_POSITIVE) }
    }

    /// Output byte of one linear value (capture units).
    #[must_use]
    pub fn apply(&self, value: f64) -> u8 {
        let x = (MID_GREY_REFLECTANCE * (value - self.black) / self.mid_grey_signal).clamp(0.0, 1.0);
        (255.0 * srgb_encode(x)).round().clamp(0.0, 255.0) as u8
    }
}

/// The sRGB transfer function (IEC 61966-2-1), linear [0, 1] to encoded [0, 1].
#[must_use]
pub fn srgb_encode(x: f64) -> f64 {
    if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 }
}

/// Rec. 709 luma of a linear RGB triple.
fn luma(c: &[u16]) -> f64 {
    0.2126 * f64::from(c[0]) + 0.7152 * f64::from(c[1]) + 0.0722 * f64::from(c[2])
}

/// The 8-bit grey image of `cap` under `rule` (`isp` is used by [`OutputRule::Isp`] only).
#[must_use]
pub fn to_8bit(cap: &Capture, rule: OutputRule, isp: &Isp) -> Vec<u8> {
    match (rule, cap.channels) {
        (OutputRule::TopBits, 3) => cap.dn.chunks_exact(3).map(|c| luma(c).round().clamp(0.0, 255.0) as u8).collect(),
        (OutputRule::TopBits, _) => {
            let shift = cap.bits.saturating_sub(8);
            cap.dn.iter().map(|&v| (v >> shift).min(255) as u8).collect()
        }
        (OutputRule::Isp, 3) => cap.dn.chunks_exact(3).map(|c| isp.apply(luma(c))).collect(),
        (OutputRule::Isp, _) => {
            // One table entry per possible DN: the rule is a pure function of the value.
            let lut: Vec<u8> = (0..(1u32 << cap.bits.min(16))).map(|v| isp.apply(f64::from(v))).collect();
            cap.dn.iter().map(|&v| lut[usize::from(v).min(lut.len() - 1)]).collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera_spec::CameraSpec;
    use crate::sensor::Catalog;

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
        let cap = Capture { width: 2, height: 1, channels: 1, bits: 12, dn: vec![4095, 300] };
        let isp = Isp { black: 64.0, mid_grey_signal: 100.0 };
        assert_eq!(to_8bit(&cap, OutputRule::TopBits, &isp), vec![255, 18]);
        let out = to_8bit(&cap, OutputRule::Isp, &isp);
        assert_eq!(out[0], 255);
        assert_eq!(out[1], isp.apply(300.0));
    }
}
