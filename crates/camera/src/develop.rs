//! Developing a raw Bayer mosaic into an 8-bit sRGB image, the steps of a camera's ISP in
//! their usual order:
//!
//! 1. **Black level**: the ADC's offset is subtracted and the values are scaled by the white
//!    level, so 0 is no light and 1 is the top of the ADC's range.
//! 2. **White balance**: each CFA channel is multiplied by its gain, on the mosaic (a grey
//!    surface under the scene's light then has equal R, G and B).
//! 3. **Demosaicing** ([`crate::demosaic`]).
//! 4. **Colour correction matrix**: camera RGB to linear sRGB (row-major, applied to column
//!    vectors), then clamped to 0..1.
//! 5. **Tone curve**: the sRGB transfer function (IEC 61966-2-1), then 8 bits, rounded.
//!
//! With `only_demosaic` steps 2, 4 and 5 are skipped and the demosaiced values are scaled to
//! 8 bits linearly, so a mosaicked photograph comes back as comparable to the original.

use crate::demosaic::{CfaPattern, Demosaic, Mosaic, demosaic, directional_rows};

/// How a raw mosaic is developed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Develop {
    pub pattern: CfaPattern,
    pub demosaic: Demosaic,
    /// The ADC value of no light, DN.
    pub black_level_dn: f32,
    /// The ADC's largest value, DN (`2^bits - 1`).
    pub white_level_dn: f32,
    /// Gains of the R, G and B samples.
    pub white_balance: [f32; 3],
    /// Camera RGB to linear sRGB, row-major.
    pub colour_matrix: [[f32; 3]; 3],
    /// Demosaic only: no white balance, colour matrix or tone curve.
    pub only_demosaic: bool,
}

/// The identity colour matrix.
pub const IDENTITY: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

impl Develop {
    /// Neutral settings for a sensor of `bits`: no black level, unit gains, the identity
    /// matrix, the default demosaicing method.
    #[must_use]
    pub fn new(pattern: CfaPattern, bits: u32) -> Develop {
        Develop {
            pattern,
            demosaic: Demosaic::default(),
            black_level_dn: 0.0,
            white_level_dn: ((1u32 << bits.clamp(1, 16)) - 1) as f32,
            white_balance: [1.0; 3],
            colour_matrix: IDENTITY,
            only_demosaic: false,
        }
    }

    /// Checks the settings.
    ///
    /// # Errors
    /// The setting at fault and why.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |v: f32| v.is_finite();
        if !finite(self.black_level_dn) || self.black_level_dn < 0.0 {
            return Err(format!("black level {} DN: must be a number >= 0", self.black_level_dn));
        }
        if !finite(self.white_level_dn) || self.white_level_dn <= self.black_level_dn {
            return Err(format!(
                "white level {} DN: must be above the black level {} DN",
                self.white_level_dn, self.black_level_dn
            ));
        }
        if self.white_balance.iter().any(|&g| !finite(g) || g <= 0.0) {
            return Err(format!("white balance {:?}: every gain must be a positive number", self.white_balance));
        }
        if self.colour_matrix.iter().flatten().any(|&v| !finite(v)) {
            return Err("colour matrix: every entry must be a number".to_string());
        }
        Ok(())
    }
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in 0..1.
#[must_use]
pub fn srgb_encode(linear: f32) -> f32 {
    if linear <= 0.003_130_8 { 12.92 * linear } else { 1.055 * linear.powf(1.0 / 2.4) - 0.055 }
}

/// `round(255 srgb_encode(x))` for a linear `x` in 0..1 without a power function per value: the
/// smallest `x` that reaches each byte, found once by bisection over the f32 values with the
/// same arithmetic, so the bytes are exactly those of the direct formula (which is monotone).
/// A value is looked up in a table of `BINS` equal bins of 0..1 (the byte at the bin's start),
/// then moved up one byte if it has passed the next byte's threshold: bins are narrower than
/// the distance between thresholds (the curve's steepest slope, 12.92 x 255 bytes per unit,
/// puts thresholds at least 1 / 3295 apart), so one comparison settles it.
struct SrgbBytes {
    /// `first[b]`: the smallest f32 whose byte is at least `b + 1`; `first[255]` is above 1.
    first: [f32; 256],
    /// The byte at the start of each bin.
    at_bin: Vec<u8>,
}

/// Bins of [`SrgbBytes::at_bin`].
const BINS: usize = 1 << 14;

impl SrgbBytes {
    fn get() -> &'static SrgbBytes {
        static TABLE: std::sync::OnceLock<SrgbBytes> = std::sync::OnceLock::new();
        TABLE.get_or_init(|| {
            let direct = |x: f32| (srgb_encode(x) * 255.0).round() as u8;
            let first: [f32; 256] = std::array::from_fn(|b| {
                if b == 255 {
                    return f32::INFINITY;
                }
                // Non-negative f32 values are ordered as their bit patterns.
                let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
                while lo < hi {
                    let mid = lo + (hi - lo) / 2;
                    if usize::from(direct(f32::from_bits(mid))) > b { hi = mid } else { lo = mid + 1 }
                }
                f32::from_bits(lo)
            });
            let at_bin = (0..=BINS).map(|i| first.partition_point(|&t| t <= i as f32 / BINS as f32) as u8).collect();
            SrgbBytes { first, at_bin }
        })
    }

    /// The byte of a linear value in 0..1.
    #[inline]
    fn byte(&self, x: f32) -> u8 {
        let b = self.at_bin[(x * BINS as f32) as usize];
        b + u8::from(x >= self.first[usize::from(b)])
    }
}

/// Develops the `width * height` raw values `raw` with `settings` into interleaved 8-bit RGB.
///
/// # Panics
/// When `raw` does not hold `width * height` values.
#[must_use]
pub fn develop(raw: &[u16], width: usize, height: usize, settings: &Develop) -> Vec<u8> {
    assert_eq!(raw.len(), width * height, "raw size");
    let range = settings.white_level_dn - settings.black_level_dn;
    // Row by row, with the two gains of each row's CFA phase: a pixel's channel from its index
    // took a division and a remainder per pixel, a tenth of a developed frame.
    let mut samples = vec![0f32; raw.len()];
    for (y, (out, row)) in samples.chunks_exact_mut(width.max(1)).zip(raw.chunks_exact(width.max(1))).enumerate() {
        let gains = if settings.only_demosaic {
            [1.0; 2]
        } else {
            [0, 1].map(|x| settings.white_balance[settings.pattern.channel(x, y)])
        };
        for (x, (o, &v)) in out.iter_mut().zip(row).enumerate() {
            *o = (f32::from(v) - settings.black_level_dn) / range * gains[x & 1];
        }
    }
    let mosaic = Mosaic { width, height, pattern: settings.pattern, samples: &samples };
    let to_8bit = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    let m = &settings.colour_matrix;
    let curve = SrgbBytes::get();
    let mut bytes = vec![0u8; 3 * raw.len()];
    let mut write_row = |y: usize, row: &[[f32; 3]]| {
        let out = &mut bytes[3 * width * y..3 * width * (y + 1)];
        for (out, p) in out.chunks_exact_mut(3).zip(row) {
            if settings.only_demosaic {
                out.iter_mut().zip(p).for_each(|(b, &v)| *b = to_8bit(v));
            } else {
                for (b, row) in out.iter_mut().zip(m) {
                    *b = curve.byte((row[0] * p[0] + row[1] * p[1] + row[2] * p[2]).clamp(0.0, 1.0));
                }
            }
        }
    };
    match settings.demosaic {
        // Row by row: a whole float RGB image is 12 bytes a pixel of memory traffic for nothing.
        Demosaic::Directional => directional_rows(&mosaic, write_row),
        method => {
            for (y, row) in demosaic(&mosaic, method).chunks_exact(width.max(1)).enumerate() {
                write_row(y, row);
            }
        }
    }
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_srgb_curve_meets_its_published_points() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        // 18 % grey encodes to about 118 of 255; the linear toe ends at 0.0031308.
        assert!(((srgb_encode(0.18) * 255.0).round() - 118.0).abs() < 0.5);
        assert!((srgb_encode(0.003_130_8) - 0.040_45).abs() < 1e-4);
    }

    #[test]
    fn black_level_white_balance_and_matrix_are_applied_in_order() {
        // A flat 12-bit raw: R samples 1064, G 2064, B 564 with black level 64.
        let (w, h) = (6, 4);
        let pattern = CfaPattern::Rggb;
        let raw: Vec<u16> = (0..w * h).map(|i| [1064, 2064, 564][pattern.channel(i % w, i / w)]).collect();
        let settings = Develop { black_level_dn: 64.0, white_balance: [2.0, 1.0, 4.0], ..Develop::new(pattern, 12) };
        let out = develop(&raw, w, h, &settings);
        // (1000 * 2, 2000, 500 * 4) / 4031 = 0.496 each: a neutral grey.
        let expected = (srgb_encode(2000.0 / 4031.0) * 255.0).round() as u8;
        assert!(out.iter().all(|&v| v == expected), "{out:?} vs {expected}");
        // A matrix that swaps red and blue.
        let swap = Develop {
            colour_matrix: [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
            white_balance: [1.0; 3],
            ..settings
        };
        let out = develop(&raw, w, h, &swap);
        let encode = |v: f32| (srgb_encode(v / 4031.0) * 255.0).round() as u8;
        assert_eq!(&out[..3], &[encode(500.0), encode(2000.0), encode(1000.0)]);
    }

    #[test]
    fn the_curve_table_gives_the_bytes_of_the_formula() {
        let table = SrgbBytes::get();
        let direct = |x: f32| (srgb_encode(x) * 255.0).round() as u8;
        for i in 0..=200_000u32 {
            let x = i as f32 / 200_000.0;
            assert_eq!(table.byte(x), direct(x), "{x}");
        }
        for &b in &table.first[..255] {
            assert_eq!(table.byte(b), direct(b));
            let below = f32::from_bits(b.to_bits() - 1);
            assert_eq!(table.byte(below), direct(below));
        }
    }

    #[test]
    fn only_demosaic_scales_linearly() {
        let raw = vec![200u16; 16];
        let settings =
            Develop { only_demosaic: true, white_balance: [3.0, 1.0, 3.0], ..Develop::new(CfaPattern::Grbg, 8) };
        assert!(develop(&raw, 4, 4, &settings).iter().all(|&v| v == 200));
    }

    #[test]
    fn bad_settings_are_named() {
        let ok = Develop::new(CfaPattern::Rggb, 10);
        assert!(ok.validate().is_ok());
        assert!(Develop { black_level_dn: 2000.0, ..ok }.validate().unwrap_err().contains("white level"));
        assert!(Develop { white_balance: [1.0, 0.0, 1.0], ..ok }.validate().unwrap_err().contains("white balance"));
        assert!(Develop { black_level_dn: f32::NAN, ..ok }.validate().unwrap_err().contains("black level"));
    }
}
