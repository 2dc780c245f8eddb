//! Demosaicing: a Bayer mosaic (one colour sample per pixel) to a full RGB image.
//!
//! Three methods, all on linear values:
//!
//! * [`Demosaic::Bilinear`]: each missing colour is the weighted mean of the samples of that
//!   colour in the 3x3 neighbourhood (weights 4 / 2 / 1 for centre / edge / corner). The
//!   reference every other method is measured against.
//! * [`Demosaic::Malvar`]: Malvar, He and Cutler, "High-quality linear interpolation for
//!   demosaicing of Bayer-patterned color images" (ICASSP 2004): bilinear interpolation
//!   corrected by the Laplacian of the pixel's own channel, eight fixed 5x5 kernels.
//! * [`Demosaic::Directional`]: green by Hamilton and Adams' edge-directed interpolation
//!   (US patent 5,629,734, 1997): along the row or the column, whichever has the smaller
//!   gradient (first difference of green plus second difference of the pixel's channel), with
//!   the same second-order correction; then red and blue by bilinear interpolation of the colour
//!   differences R - G and B - G, which vary slowly across edges. The best of the three on
//!   photographs (tests/interop/check_demosaic.sh) and the ISP's default.
//!
//! Borders are handled by mirroring without repeating the edge (`dcb|abcd|cba`), which keeps the
//! CFA's phase, so every output pixel is computed the same way.

use std::fmt;
use std::str::FromStr;

/// Which colour a Bayer sensor samples at each pixel of a 2x2 tile, named by the tile's
/// top-left, top-right, bottom-left and bottom-right colours.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum CfaPattern {
    Rggb,
    Bggr,
    Grbg,
    Gbrg,
}

/// Channel indices of an RGB pixel.
const R: usize = 0;
const G: usize = 1;
const B: usize = 2;

impl CfaPattern {
    /// The channel (0 R, 1 G, 2 B) sampled at pixel (x, y).
    #[must_use]
    pub fn channel(self, x: usize, y: usize) -> usize {
        let tile = match self {
            CfaPattern::Rggb => [R, G, G, B],
            CfaPattern::Bggr => [B, G, G, R],
            CfaPattern::Grbg => [G, R, B, G],
            CfaPattern::Gbrg => [G, B, R, G],
        };
        tile[(y % 2) * 2 + x % 2]
    }

    /// The pattern's name, as [`CfaPattern::from_str`] reads it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            CfaPattern::Rggb => "RGGB",
            CfaPattern::Bggr => "BGGR",
            CfaPattern::Grbg => "GRBG",
            CfaPattern::Gbrg => "GBRG",
        }
    }
}

impl FromStr for CfaPattern {
    type Err = String;

    fn from_str(text: &str) -> Result<CfaPattern, String> {
        match text.to_ascii_uppercase().as_str() {
            "RGGB" => Ok(CfaPattern::Rggb),
            "BGGR" => Ok(CfaPattern::Bggr),
            "GRBG" => Ok(CfaPattern::Grbg),
            "GBRG" => Ok(CfaPattern::Gbrg),
            _ => Err(format!("unknown CFA pattern '{text}' (known: RGGB, BGGR, GRBG, GBRG)")),
        }
    }
}

impl fmt::Display for CfaPattern {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A demosaicing method (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Demosaic {
    Bilinear,
    Malvar,
    #[default]
    Directional,
}

impl Demosaic {
    /// The method's name, as [`Demosaic::from_str`] reads it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Demosaic::Bilinear => "bilinear",
            Demosaic::Malvar => "malvar",
            Demosaic::Directional => "directional",
        }
    }
}

impl FromStr for Demosaic {
    type Err = String;

    fn from_str(text: &str) -> Result<Demosaic, String> {
        match text.to_ascii_lowercase().as_str() {
            "bilinear" => Ok(Demosaic::Bilinear),
            "malvar" | "mhc" | "malvar-he-cutler" => Ok(Demosaic::Malvar),
            "directional" | "hamilton-adams" => Ok(Demosaic::Directional),
            _ => Err(format!("unknown demosaicing method '{text}' (known: bilinear, malvar, directional)")),
        }
    }
}

/// A Bayer mosaic: `width * height` samples, row-major, each of the colour `pattern` puts there.
#[derive(Clone, Copy, Debug)]
pub struct Mosaic<'a> {
    pub width: usize,
    pub height: usize,
    pub pattern: CfaPattern,
    pub samples: &'a [f32],
}

/// The mirror image of index `i` into `0..n` (`-1 -> 1`, `n -> n - 2`), repeated as needed.
fn mirror(i: isize, n: usize) -> usize {
    if n == 1 {
        return 0;
    }
    let period = 2 * (n as isize - 1);
    let m = i.rem_euclid(period);
    (if m < n as isize { m } else { period - m }) as usize
}

impl Mosaic<'_> {
    /// The sample at (x + dx, y + dy), mirrored at the borders.
    #[inline]
    fn at(&self, x: usize, y: usize, dx: isize, dy: isize) -> f32 {
        let (xx, yy) = (x as isize + dx, y as isize + dy);
        // Inside the frame (nearly every tap) no mirroring, which divides, is needed.
        let inside = |v: isize, n: usize| if (0..n as isize).contains(&v) { v as usize } else { mirror(v, n) };
        self.samples[inside(yy, self.height) * self.width + inside(xx, self.width)]
    }

    /// The channel sampled at (x + dx, y + dy), by the CFA's phase (mirroring keeps it; `& 1`
    /// is the parity of negative offsets too, in two's complement).
    #[inline]
    fn channel(&self, x: usize, y: usize, dx: isize, dy: isize) -> usize {
        self.pattern.channel(((x as isize + dx) & 1) as usize, ((y as isize + dy) & 1) as usize)
    }
}

/// The RGB image of `mosaic` by `method`, row-major. Values are not clamped: the edge-aware
/// methods may overshoot a little at edges, and the ISP clamps after its colour matrix.
///
/// # Panics
/// When `mosaic.samples` does not hold `width * height` values.
#[must_use]
pub fn demosaic(mosaic: &Mosaic<'_>, method: Demosaic) -> Vec<[f32; 3]> {
    assert_eq!(mosaic.samples.len(), mosaic.width * mosaic.height, "mosaic size");
    match method {
        Demosaic::Bilinear => {
            let near = Neighbourhoods::new(mosaic);
            (0..mosaic.height)
                .flat_map(|y| (0..mosaic.width).map(move |x| (x, y)))
                .map(|(x, y)| bilinear_pixel(mosaic, &near, x, y))
                .collect()
        }
        Demosaic::Malvar => map_pixels(mosaic, malvar_pixel),
        Demosaic::Directional => directional(mosaic),
    }
}

fn map_pixels(mosaic: &Mosaic<'_>, pixel: fn(&Mosaic<'_>, usize, usize) -> [f32; 3]) -> Vec<[f32; 3]> {
    (0..mosaic.height).flat_map(|y| (0..mosaic.width).map(move |x| pixel(mosaic, x, y))).collect()
}

/// The taps (dx, dy, weight) of one colour in the 3x3 neighbourhood of a pixel, in row order,
/// and their total weight (weights 4 / 2 / 1 for centre / edge / corner).
#[derive(Clone, Debug, Default)]
struct Taps3 {
    taps: Vec<(isize, isize, f32)>,
    weight: f32,
}

/// [`Taps3`] of each colour at each of the four CFA phases, found once per image so the
/// per-pixel loop visits only the taps it uses.
struct Neighbourhoods {
    /// Indexed `[y % 2][x % 2][channel]`.
    by_phase: [[[Taps3; 3]; 2]; 2],
}

impl Neighbourhoods {
    fn new(mosaic: &Mosaic<'_>) -> Neighbourhoods {
        let by_phase = std::array::from_fn(|py| {
            std::array::from_fn(|px| {
                std::array::from_fn(|channel| {
                    let mut t = Taps3::default();
                    for dy in -1..=1isize {
                        for dx in -1..=1isize {
                            if mosaic.channel(px, py, dx, dy) == channel {
                                let w = ((2 - dx.abs()) * (2 - dy.abs())) as f32;
                                t.taps.push((dx, dy, w));
                                t.weight += w;
                            }
                        }
                    }
                    t
                })
            })
        });
        Neighbourhoods { by_phase }
    }

    /// The weighted mean of the samples of `channel` in the 3x3 neighbourhood of (x, y) of
    /// `value(dx, dy)`, a plane laid out as the mosaic.
    #[inline]
    fn mean(&self, x: usize, y: usize, channel: usize, value: impl Fn(isize, isize) -> f32) -> f32 {
        let t = &self.by_phase[y % 2][x % 2][channel];
        let mut sum = 0.0;
        for &(dx, dy, w) in &t.taps {
            sum += w * value(dx, dy);
        }
        sum / t.weight
    }
}

fn bilinear_pixel(mosaic: &Mosaic<'_>, near: &Neighbourhoods, x: usize, y: usize) -> [f32; 3] {
    let own = mosaic.channel(x, y, 0, 0);
    let mut rgb = [0.0; 3];
    for (c, out) in rgb.iter_mut().enumerate() {
        *out = if c == own { mosaic.at(x, y, 0, 0) } else { near.mean(x, y, c, |dx, dy| mosaic.at(x, y, dx, dy)) };
    }
    rgb
}

/// A 5x5 kernel as (dx, dy, weight) taps, weights in eighths.
type Taps = &'static [(isize, isize, f32)];

/// Green at a red or blue pixel.
const MALVAR_G_AT_RB: Taps = &[
    (0, 0, 4.0),
    (-1, 0, 2.0),
    (1, 0, 2.0),
    (0, -1, 2.0),
    (0, 1, 2.0),
    (-2, 0, -1.0),
    (2, 0, -1.0),
    (0, -2, -1.0),
    (0, 2, -1.0),
];
/// Red (blue) at a green pixel whose row neighbours are red (blue).
const MALVAR_ALONG_ROW: Taps = &[
    (0, 0, 5.0),
    (-1, 0, 4.0),
    (1, 0, 4.0),
    (-2, 0, -1.0),
    (2, 0, -1.0),
    (-1, -1, -1.0),
    (1, -1, -1.0),
    (-1, 1, -1.0),
    (1, 1, -1.0),
    (0, -2, 0.5),
    (0, 2, 0.5),
];
/// Red (blue) at a green pixel whose column neighbours are red (blue).
const MALVAR_ALONG_COLUMN: Taps = &[
    (0, 0, 5.0),
    (0, -1, 4.0),
    (0, 1, 4.0),
    (0, -2, -1.0),
    (0, 2, -1.0),
    (-1, -1, -1.0),
    (1, -1, -1.0),
    (-1, 1, -1.0),
    (1, 1, -1.0),
    (-2, 0, 0.5),
    (2, 0, 0.5),
];
/// Red at a blue pixel, and blue at a red one.
const MALVAR_DIAGONAL: Taps = &[
    (0, 0, 6.0),
    (-1, -1, 2.0),
    (1, -1, 2.0),
    (-1, 1, 2.0),
    (1, 1, 2.0),
    (-2, 0, -1.5),
    (2, 0, -1.5),
    (0, -2, -1.5),
    (0, 2, -1.5),
];

fn apply(mosaic: &Mosaic<'_>, x: usize, y: usize, taps: Taps) -> f32 {
    taps.iter().map(|&(dx, dy, w)| w * mosaic.at(x, y, dx, dy)).sum::<f32>() / 8.0
}

fn malvar_pixel(mosaic: &Mosaic<'_>, x: usize, y: usize) -> [f32; 3] {
    let own = mosaic.channel(x, y, 0, 0);
    let mut rgb = [0.0; 3];
    rgb[own] = mosaic.at(x, y, 0, 0);
    if own == G {
        let row_neighbour = mosaic.channel(x, y, 1, 0);
        let column_neighbour = mosaic.channel(x, y, 0, 1);
        rgb[row_neighbour] = apply(mosaic, x, y, MALVAR_ALONG_ROW);
        rgb[column_neighbour] = apply(mosaic, x, y, MALVAR_ALONG_COLUMN);
    } else {
        rgb[G] = apply(mosaic, x, y, MALVAR_G_AT_RB);
        rgb[R + B - own] = apply(mosaic, x, y, MALVAR_DIAGONAL);
    }
    rgb
}

/// Green at a red or blue pixel by Hamilton-Adams: the row or column estimate with the
/// smaller gradient, their mean on a tie.
fn hamilton_adams_green(mosaic: &Mosaic<'_>, x: usize, y: usize) -> f32 {
    hamilton_adams(|dx, dy| mosaic.at(x, y, dx, dy))
}

/// Hamilton-Adams from the samples `at(dx, dy)` around a red or blue pixel.
#[inline(always)]
fn hamilton_adams(at: impl Fn(isize, isize) -> f32) -> f32 {
    let centre = at(0, 0);
    let row_second = 2.0 * centre - at(-2, 0) - at(2, 0);
    let column_second = 2.0 * centre - at(0, -2) - at(0, 2);
    let row_gradient = (at(-1, 0) - at(1, 0)).abs() + row_second.abs();
    let column_gradient = (at(0, -1) - at(0, 1)).abs() + column_second.abs();
    let along_row = (at(-1, 0) + at(1, 0)) / 2.0 + row_second / 4.0;
    let along_column = (at(0, -1) + at(0, 1)) / 2.0 + column_second / 4.0;
    if row_gradient < column_gradient {
        along_row
    } else if column_gradient < row_gradient {
        along_column
    } else {
        (along_row + along_column) / 2.0
    }
}

fn directional(mosaic: &Mosaic<'_>) -> Vec<[f32; 3]> {
    let mut rgb = Vec::with_capacity(mosaic.width * mosaic.height);
    directional_rows(mosaic, |_, row| rgb.extend_from_slice(row));
    rgb
}

/// [`Demosaic::Directional`] row by row: `emit(y, row)` receives each RGB row in order, so a
/// caller that turns rows into bytes ([`crate::develop`]) never holds the whole float image.
///
/// Away from the borders (two pixels for green, one for red and blue) the taps are read at
/// fixed offsets into the planes, without the mirroring test of every tap; the arithmetic is
/// the border path's, term for term, so both give the same bits.
pub(crate) fn directional_rows(mosaic: &Mosaic<'_>, mut emit: impl FnMut(usize, &[[f32; 3]])) {
    let (w, h) = (mosaic.width, mosaic.height);
    let green = green_plane(mosaic);
    // Colour differences (sample - green) at the red and blue pixels; 0 elsewhere (unused).
    let difference: Vec<f32> = mosaic.samples.iter().zip(&green).map(|(&s, &g)| s - g).collect();
    let plane = Mosaic { samples: &difference, ..*mosaic };
    let near = Neighbourhoods::new(mosaic);
    let flat = FlatTaps::by_phase(&near, w);
    let mut row = vec![[0.0f32; 3]; w];
    for y in 0..h {
        let inner_row = y >= 1 && y + 1 < h;
        for (x, out) in row.iter_mut().enumerate() {
            let i = y * w + x;
            let g = green[i];
            let own = mosaic.channel(x, y, 0, 0);
            let mut rgb = [0.0, g, 0.0];
            for c in [R, B] {
                rgb[c] = if c == own {
                    mosaic.samples[i]
                } else if inner_row && x >= 1 && x + 1 < w {
                    g + flat[y % 2][x % 2][c].mean(&difference, i)
                } else {
                    g + near.mean(x, y, c, |dx, dy| plane.at(x, y, dx, dy))
                };
            }
            *out = rgb;
        }
        emit(y, &row);
    }
}

/// The green plane of [`Demosaic::Directional`]: the samples at green pixels, Hamilton-Adams
/// elsewhere.
fn green_plane(mosaic: &Mosaic<'_>) -> Vec<f32> {
    let (w, h) = (mosaic.width, mosaic.height);
    let mut green = vec![0.0f32; w * h];
    for (y, out) in green.chunks_exact_mut(w.max(1)).enumerate() {
        let inner_row = y >= 2 && y + 2 < h;
        for (x, g) in out.iter_mut().enumerate() {
            *g = if mosaic.channel(x, y, 0, 0) == G {
                mosaic.samples[y * w + x]
            } else if inner_row && x >= 2 && x + 2 < w {
                hamilton_adams_green_inner(mosaic.samples, w, y * w + x)
            } else {
                hamilton_adams_green(mosaic, x, y)
            };
        }
    }
    green
}

/// [`hamilton_adams_green`] at flat index `i` of samples `s` of width `w`, two or more pixels
/// from every border: the taps at fixed offsets, no mirroring.
#[inline(always)]
fn hamilton_adams_green_inner(s: &[f32], w: usize, i: usize) -> f32 {
    hamilton_adams(|dx, dy| s[i.wrapping_add_signed(dy * w as isize + dx)])
}

/// The [`Taps3`] of one colour at one CFA phase as offsets into a row-major plane of width
/// `w`, for pixels one or more from every border (up to all nine of the 3x3 neighbourhood).
#[derive(Clone, Copy, Debug, Default)]
struct FlatTaps {
    offsets: [isize; 9],
    weights: [f32; 9],
    len: usize,
    weight: f32,
}

impl FlatTaps {
    /// Indexed `[y % 2][x % 2][channel]`, as [`Neighbourhoods`].
    fn by_phase(near: &Neighbourhoods, w: usize) -> [[[FlatTaps; 3]; 2]; 2] {
        std::array::from_fn(|py| {
            std::array::from_fn(|px| {
                std::array::from_fn(|c| {
                    let taps = &near.by_phase[py][px][c];
                    let mut flat = FlatTaps { weight: taps.weight, ..FlatTaps::default() };
                    for &(dx, dy, weight) in &taps.taps {
                        flat.offsets[flat.len] = dy * w as isize + dx;
                        flat.weights[flat.len] = weight;
                        flat.len += 1;
                    }
                    flat
                })
            })
        })
    }

    /// [`Neighbourhoods::mean`] of `plane` around flat index `i`, in the same order of terms.
    #[inline(always)]
    fn mean(&self, plane: &[f32], i: usize) -> f32 {
        let mut sum = 0.0;
        for k in 0..self.len {
            sum += self.weights[k] * plane[i.wrapping_add_signed(self.offsets[k])];
        }
        sum / self.weight
    }
}

/// The mosaic a sensor with `pattern` records of an RGB image: each pixel keeps the channel
/// the pattern puts there (for tests and for mosaicking photographs).
#[must_use]
pub fn mosaic_of(rgb: &[[f32; 3]], width: usize, pattern: CfaPattern) -> Vec<f32> {
    rgb.iter().enumerate().map(|(i, p)| p[pattern.channel(i % width, i / width)]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [Demosaic; 3] = [Demosaic::Bilinear, Demosaic::Malvar, Demosaic::Directional];
    const PATTERNS: [CfaPattern; 4] = [CfaPattern::Rggb, CfaPattern::Bggr, CfaPattern::Grbg, CfaPattern::Gbrg];

    fn run(rgb: &[[f32; 3]], width: usize, pattern: CfaPattern, method: Demosaic) -> Vec<[f32; 3]> {
        let samples = mosaic_of(rgb, width, pattern);
        demosaic(&Mosaic { width, height: rgb.len() / width, pattern, samples: &samples }, method)
    }

    #[test]
    fn a_flat_colour_comes_back_exactly_for_every_method_and_pattern() {
        let rgb = vec![[0.2, 0.5, 0.9]; 7 * 5];
        for pattern in PATTERNS {
            for method in ALL {
                for p in run(&rgb, 7, pattern, method) {
                    for c in 0..3 {
                        assert!((p[c] - rgb[0][c]).abs() < 1e-6, "{pattern} {method:?}: {p:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn samples_are_kept_where_the_sensor_took_them() {
        let rgb: Vec<[f32; 3]> = (0..48).map(|i| [i as f32, (i * 7 % 13) as f32, (i * 5 % 11) as f32]).collect();
        for pattern in PATTERNS {
            for method in ALL {
                let out = run(&rgb, 8, pattern, method);
                for (i, (o, p)) in out.iter().zip(&rgb).enumerate() {
                    let c = pattern.channel(i % 8, i / 8);
                    assert_eq!(o[c], p[c], "{pattern} {method:?} pixel {i}");
                }
            }
        }
    }

    #[test]
    fn the_edge_aware_methods_beat_bilinear_on_detail_with_correlated_channels() {
        // As in photographs, the channels move together: a tinted surface with a fine slanted
        // stripe texture and a slanted shadow edge, so every CFA phase meets both.
        let (w, h) = (48, 48);
        let rgb: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let shade = if x + 0.3 * y < 24.0 { 1.0 } else { 0.35 };
                let luminance = shade * (0.55 + 0.35 * (1.1 * x + 0.4 * y).sin());
                [0.9 * luminance, 0.7 * luminance, 0.45 * luminance]
            })
            .collect();
        let error = |method| {
            run(&rgb, w, CfaPattern::Rggb, method)
                .iter()
                .zip(&rgb)
                .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f32>())
                .sum::<f32>()
        };
        let bilinear = error(Demosaic::Bilinear);
        // Measured: bilinear 16.5, Malvar 6.6, directional 3.3 (sum of squared errors).
        assert!(error(Demosaic::Malvar) < 0.6 * bilinear, "malvar {} bilinear {bilinear}", error(Demosaic::Malvar));
        assert!(
            error(Demosaic::Directional) < 0.6 * error(Demosaic::Malvar),
            "directional {}",
            error(Demosaic::Directional)
        );
    }

    /// The per-pixel definition of [`Demosaic::Directional`], every tap mirrored.
    fn directional_reference(mosaic: &Mosaic<'_>) -> Vec<[f32; 3]> {
        let (w, h) = (mosaic.width, mosaic.height);
        let green: Vec<f32> = (0..h * w)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if mosaic.channel(x, y, 0, 0) == G { mosaic.at(x, y, 0, 0) } else { hamilton_adams_green(mosaic, x, y) }
            })
            .collect();
        let difference: Vec<f32> = mosaic.samples.iter().zip(&green).map(|(&s, &g)| s - g).collect();
        let plane = Mosaic { samples: &difference, ..*mosaic };
        let near = Neighbourhoods::new(mosaic);
        (0..h * w)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let own = mosaic.channel(x, y, 0, 0);
                let mut rgb = [0.0, green[i], 0.0];
                for c in [R, B] {
                    rgb[c] = if c == own {
                        mosaic.at(x, y, 0, 0)
                    } else {
                        green[i] + near.mean(x, y, c, |dx, dy| plane.at(x, y, dx, dy))
                    };
                }
                rgb
            })
            .collect()
    }

    /// The fixed-offset inner path gives the bits of the mirrored per-pixel definition, on
    /// noise-like mosaics of every pattern and of sizes around the border widths.
    #[test]
    fn directional_rows_match_the_per_pixel_definition_bit_for_bit() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        for (w, h) in [(1, 1), (2, 3), (4, 4), (5, 5), (6, 7), (17, 12), (64, 9)] {
            let samples: Vec<f32> = (0..w * h).map(|_| next()).collect();
            for pattern in PATTERNS {
                let mosaic = Mosaic { width: w, height: h, pattern, samples: &samples };
                let want = directional_reference(&mosaic);
                let got = demosaic(&mosaic, Demosaic::Directional);
                for (i, (a, b)) in got.iter().zip(&want).enumerate() {
                    assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "{w}x{h} {pattern} pixel {i}");
                }
            }
        }
    }

    #[test]
    fn tiny_mosaics_mirror_without_panicking() {
        for (w, h) in [(1, 1), (1, 4), (2, 1), (2, 2), (3, 2)] {
            let rgb = vec![[0.3, 0.3, 0.3]; w * h];
            for method in ALL {
                assert_eq!(run(&rgb, w, CfaPattern::Gbrg, method).len(), w * h);
            }
        }
    }

    #[test]
    fn names_read_back() {
        for p in PATTERNS {
            assert_eq!(p.name().parse::<CfaPattern>(), Ok(p));
        }
        for m in ALL {
            assert_eq!(m.name().parse::<Demosaic>(), Ok(m));
        }
        assert!("RGBG".parse::<CfaPattern>().is_err() && "nearest".parse::<Demosaic>().is_err());
    }
}
