//! Light by wavelength: illuminant spectra, the quantum efficiency curves of a sensor's colour
//! channels, and the matrix that turns a rendered linear-RGB radiance into electrons per
//! channel.
//!
//! The renderer works in linear sRGB (three numbers per ray, luminance in nit), which is what
//! makes a house render in seconds. A sensor does not see sRGB: each channel integrates the
//! spectral radiance against its own quantum efficiency curve. Between the two sits a spectral
//! reconstruction, done once per scenario, not per pixel:
//!
//! 1. A rendered value is read as `r = rho * tau`: the linear-sRGB reflectance `rho` of the
//!    surface times the tint `tau` of the scenario's light (normalised to unit luminance). The
//!    scene's lights carry such tints; the scenario's illuminant spectrum stands for them all
//!    (day: CIE D65, whose tint is white; night: warm-white indoor light, a 2800 K Planckian
//!    radiator, inside the 2700-3000 K of warm-white lamps).
//! 2. The reflectance becomes a spectrum `rho(l) = sum_k rho_k B_k(l)` on a smooth basis
//!    ([`reflectance_basis`]): three overlapping bands, corrected so that each `B_k` seen under
//!    D65 is exactly sRGB primary `k` and the three sum to 1 (a grey stays flat).
//! 3. The spectral radiance `rho(l) E(l)`, with `E` the illuminant normalised to 1 nit, is
//!    integrated against each channel's quantum efficiency `QE_c(l)` in photons
//!    (`l / hc` per joule).
//!
//! All three steps are linear, so they collapse to a 3x3 matrix ([`ChannelMatrix`]): electrons
//! of channel `c` = `sum_k S[c][k] P_k`, where `P_k` is what the monochromatic (555 nm)
//! photometric conversion of [`crate::radiometry`] gives for rendered channel `k`. The matrix
//! is "electrons per 555 nm-equivalent photon", the spectral counterpart of a single QE.
//!
//! Tables are at 10 nm from 400 to 700 nm: the CIE 1931 2-degree colour-matching functions and
//! the CIE D65 relative spectral power distribution (CIE 015:2018 / ISO 11664-2, 10 nm rows).
//!
//! The channels' curves ([`QeCurves::typical_bayer`]) are a documented typical shape for the
//! catalog's Sony and onsemi RGB Bayer CMOS parts, drawn after the relative spectral response
//! plots of their data sheets (blue peak near 455 nm, green near 535 nm, red rising from
//! 585 nm, an IR-cut filter at 650 nm) and scaled so the green peak is the catalog's quantum
//! efficiency. No catalog sensor has digitised published curves; `sensors` says "typical".

/// First wavelength of the tables, nm.
pub const FIRST_NM: f64 = 400.0;
/// Spacing of the tables, nm.
pub const STEP_NM: f64 = 10.0;
/// Samples per table (400, 410, ..., 700 nm).
pub const SAMPLES: usize = 31;

/// A quantity sampled at [`SAMPLES`] wavelengths from [`FIRST_NM`] in [`STEP_NM`] steps.
pub type Spectrum = [f64; SAMPLES];

/// Wavelength of sample `i`, nm.
#[must_use]
pub fn wavelength_nm(i: usize) -> f64 {
    FIRST_NM + STEP_NM * i as f64
}

/// Luminous efficacy of radiation at 555 nm, lm/W (the SI definition of the candela).
const LM_PER_W: f64 = 683.0;

/// Planck constant times the speed of light, J m (CODATA 2018 exact values).
const H_C_J_M: f64 = 6.626_070_15e-34 * 299_792_458.0;

/// CIE 1931 2-degree colour-matching functions x, y, z at 400, 410, ..., 700 nm.
const CIE_1931_XYZ: [[f64; 3]; SAMPLES] = [
    [0.014_31, 0.000_396, 0.067_85],
    [0.043_51, 0.001_21, 0.207_4],
    [0.134_38, 0.004_0, 0.645_6],
    [0.283_9, 0.011_6, 1.385_6],
    [0.348_28, 0.023_0, 1.747_06],
    [0.336_2, 0.038_0, 1.772_11],
    [0.290_8, 0.060_0, 1.669_2],
    [0.195_36, 0.090_98, 1.287_64],
    [0.095_64, 0.139_02, 0.812_95],
    [0.032_01, 0.208_02, 0.465_18],
    [0.004_9, 0.323_0, 0.272_0],
    [0.009_3, 0.503_0, 0.158_2],
    [0.063_27, 0.710_0, 0.078_25],
    [0.165_5, 0.862_0, 0.042_16],
    [0.290_4, 0.954_0, 0.020_3],
    [0.433_45, 0.994_95, 0.008_75],
    [0.594_5, 0.995_0, 0.003_9],
    [0.762_1, 0.952_0, 0.002_1],
    [0.916_3, 0.870_0, 0.001_65],
    [1.026_3, 0.757_0, 0.001_1],
    [1.062_2, 0.631_0, 0.000_8],
    [1.002_6, 0.503_0, 0.000_34],
    [0.854_45, 0.381_0, 0.000_19],
    [0.642_4, 0.265_0, 0.000_05],
    [0.447_9, 0.175_0, 0.000_02],
    [0.283_5, 0.107_0, 0.0],
    [0.164_9, 0.061_0, 0.0],
    [0.087_4, 0.032_0, 0.0],
    [0.046_77, 0.017_0, 0.0],
    [0.022_7, 0.008_21, 0.0],
    [0.011_359, 0.004_102, 0.0],
];

/// CIE standard illuminant D65, relative spectral power at 400, 410, ..., 700 nm (100 at 560).
const D65: Spectrum = [
    82.7549, 91.486, 93.4318, 86.6823, 104.865, 117.008, 117.812, 114.861, 115.923, 108.811, 109.354, 107.802, 104.790,
    107.689, 104.405, 104.046, 100.000, 96.3342, 95.788, 88.6856, 90.0062, 89.5991, 87.6987, 83.2886, 83.6992, 80.0268,
    80.2146, 82.2778, 78.2842, 69.7213, 71.6091,
];

/// CIE XYZ (D65 white) to linear sRGB, IEC 61966-2-1.
pub const XYZ_TO_LINEAR_SRGB: [[f64; 3]; 3] =
    [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]];

/// Rec. 709 / sRGB luma weights of linear R, G, B (the luminance of a linear-sRGB value).
pub const LUMA: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Correlated colour temperature of the night scenario's warm-white light, K.
pub const NIGHT_CCT_K: f64 = 2800.0;

/// A light's spectrum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Illuminant {
    /// CIE D65 daylight.
    D65,
    /// A Planckian (black-body) radiator at this temperature, K.
    Planck(f64),
}

impl Illuminant {
    /// Relative spectral power.
    #[must_use]
    pub fn spectrum(self) -> Spectrum {
        match self {
            Illuminant::D65 => D65,
            Illuminant::Planck(kelvin) => std::array::from_fn(|i| planck(kelvin, wavelength_nm(i))),
        }
    }

    /// The spectrum scaled to a radiance of 1 nit: W / (sr m^2 nm) per nit.
    #[must_use]
    pub fn per_nit(self) -> Spectrum {
        let s = self.spectrum();
        let nit = LM_PER_W * integrate(&s, |i| CIE_1931_XYZ[i][1]);
        s.map(|v| v / nit)
    }

    /// The illuminant's colour in linear sRGB, scaled to unit luminance.
    #[must_use]
    pub fn tint(self) -> [f64; 3] {
        let s = self.spectrum();
        let xyz: [f64; 3] = std::array::from_fn(|j| integrate(&s, |i| CIE_1931_XYZ[i][j]));
        let rgb = mat_vec(&XYZ_TO_LINEAR_SRGB, xyz);
        let y = dot(LUMA, rgb);
        rgb.map(|v| v / y)
    }
}

/// Spectral radiance of a black body at `kelvin` and `wavelength_nm`, relative units (Planck's
/// law without its constant factor, which cancels once a spectrum is normalised).
#[must_use]
pub fn planck(kelvin: f64, wavelength_nm: f64) -> f64 {
    // Second radiation constant c2 = h c / k_B, m K (CODATA 2018).
    const C2_M_K: f64 = 1.438_776_877e-2;
    let l_m = wavelength_nm * 1e-9;
    1.0 / (l_m.powi(5) * ((C2_M_K / (l_m * kelvin)).exp() - 1.0))
}

/// CIE 1931 chromaticity (x, y) of a spectrum.
#[must_use]
pub fn chromaticity(spectrum: &Spectrum) -> (f64, f64) {
    let xyz: [f64; 3] = std::array::from_fn(|j| integrate(spectrum, |i| CIE_1931_XYZ[i][j]));
    let sum = xyz[0] + xyz[1] + xyz[2];
    (xyz[0] / sum, xyz[1] / sum)
}

/// The reflectance basis: three spectra, each seen under D65 exactly as one sRGB primary (linear
/// sRGB (1,0,0), (0,1,0), (0,0,1) relative to the D65 white), summing to 1 at every wavelength.
///
/// Built from three smooth bands (blue below 490 nm, red above 585 nm, green between, logistic
/// edges 8 nm wide) mixed by the inverse of their own sRGB colours; the result may dip a little
/// below zero, which only matters for colours no surface has.
#[must_use]
pub fn reflectance_basis() -> [Spectrum; 3] {
    let logistic = |x: f64| 1.0 / (1.0 + (-x).exp());
    let bands: [Spectrum; 3] = {
        let red: Spectrum = std::array::from_fn(|i| logistic((wavelength_nm(i) - 585.0) / 8.0));
        let blue: Spectrum = std::array::from_fn(|i| logistic((490.0 - wavelength_nm(i)) / 8.0));
        let green: Spectrum = std::array::from_fn(|i| 1.0 - red[i] - blue[i]);
        [red, green, blue]
    };
    // colours[j][m]: linear sRGB channel j of band m under D65, white-normalised.
    let d65 = Illuminant::D65.spectrum();
    let white = integrate(&d65, |i| CIE_1931_XYZ[i][1]);
    let colour_of = |band: &Spectrum| -> [f64; 3] {
        let xyz: [f64; 3] = std::array::from_fn(|j| integrate(&d65, |i| band[i] * CIE_1931_XYZ[i][j]) / white);
        mat_vec(&XYZ_TO_LINEAR_SRGB, xyz)
    };
    let columns = bands.each_ref().map(colour_of);
    let colours: [[f64; 3]; 3] = std::array::from_fn(|j| std::array::from_fn(|m| columns[m][j]));
    // The sRGB white point is D65 to four digits, so normalise each row to make the bands'
    // sum (a flat spectrum) exactly white.
    let colours = colours.map(|row| {
        let sum: f64 = row.iter().sum();
        row.map(|v| v / sum)
    });
    let inverse = invert3(&colours).expect("the three bands have independent colours");
    std::array::from_fn(|k| std::array::from_fn(|i| (0..3).map(|m| bands[m][i] * inverse[m][k]).sum()))
}

/// Quantum efficiency curves of a sensor's channels (electrons per photon).
#[derive(Clone, Debug, PartialEq)]
pub struct QeCurves {
    /// One curve per channel: R, G, B for a Bayer sensor, one for a monochrome one.
    pub channels: Vec<Spectrum>,
}

impl QeCurves {
    /// The typical curves of an RGB Bayer CMOS sensor (module docs), scaled so the green
    /// channel peaks at `peak_qe`.
    #[must_use]
    pub fn typical_bayer(peak_qe: f64) -> QeCurves {
        let gauss = |l: f64, centre: f64, width: f64| (-((l - centre) / width).powi(2)).exp();
        let logistic = |x: f64| 1.0 / (1.0 + (-x).exp());
        // Dye leakage outside each filter's band.
        const FLOOR: f64 = 0.02;
        let curve = |dye: &dyn Fn(f64) -> f64| -> Spectrum {
            std::array::from_fn(|i| {
                let l = wavelength_nm(i);
                let silicon = gauss(l, 540.0, 190.0);
                let ir_cut = logistic((650.0 - l) / 8.0);
                silicon * (FLOOR + dye(l)) * ir_cut
            })
        };
        let red = curve(&|l| logistic((l - 585.0) / 12.0));
        let green = curve(&|l| gauss(l, 535.0, 42.0));
        let blue = curve(&|l| gauss(l, 455.0, 38.0));
        let peak = green.iter().copied().fold(0.0, f64::max);
        let scale = peak_qe / peak;
        QeCurves { channels: vec![red.map(|v| v * scale), green.map(|v| v * scale), blue.map(|v| v * scale)] }
    }
}

/// Photometric-to-spectral conversion of one scenario: `electrons[c] = sum_k m[c][k] P_k`, with
/// `P_k` the 555 nm-equivalent photons of rendered linear-RGB channel `k` (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelMatrix {
    pub m: [[f64; 3]; 3],
    /// The tint the renderer gave the scenario's light (linear sRGB, unit luminance): rendered
    /// values are divided by it before the illuminant's spectrum is applied.
    pub tint: [f64; 3],
}

impl ChannelMatrix {
    /// The matrix of the R, G, B channels of `curves` under `illuminant`, for a scene whose
    /// renderer gave that light the linear-sRGB colour `rendered_tint` (any scale; the
    /// illuminant's own [`Illuminant::tint`] when the renderer's light is the illuminant's
    /// colour).
    ///
    /// # Panics
    /// If `curves` does not hold three channels, or the tint has no positive luminance.
    #[must_use]
    pub fn new(curves: &QeCurves, illuminant: Illuminant, rendered_tint: [f64; 3]) -> ChannelMatrix {
        assert_eq!(curves.channels.len(), 3, "a channel matrix needs R, G and B curves");
        let luminance = dot(LUMA, rendered_tint);
        assert!(luminance > 0.0 && rendered_tint.iter().all(|&v| v > 0.0), "tint {rendered_tint:?}");
        let per_nit = illuminant.per_nit();
        let tint = rendered_tint.map(|v| v / luminance);
        let basis = reflectance_basis();
        let photons_per_lux = crate::radiometry::PHOTONS_PER_LUX_S_M2;
        let m = std::array::from_fn(|c| {
            std::array::from_fn(|k| {
                // Photons per joule at each wavelength: l / (h c).
                let electrons =
                    integrate(&per_nit, |i| basis[k][i] * curves.channels[c][i] * wavelength_nm(i) * 1e-9 / H_C_J_M);
                // Per nit of radiance; the lens maps nit to lux as it maps W/(sr m^2) to W/m^2,
                // so the geometry cancels against the PHOTONS_PER_LUX_S_M2 in P_k.
                electrons / photons_per_lux / tint[k]
            })
        });
        ChannelMatrix { m, tint }
    }

    /// Electrons of channel `c` per 555 nm-equivalent photon of a grey lit by the scenario's
    /// light (a rendered value `Y tint`): `sum_k m[c][k] tint[k]`.
    #[must_use]
    pub fn grey_response(&self, c: usize) -> f64 {
        (0..3).map(|k| self.m[c][k] * self.tint[k]).sum()
    }

    /// The colour matrix of an ISP that has white-balanced each channel to the grey response:
    /// white-balanced camera RGB to the linear-sRGB reflectance (rows sum to 1).
    #[must_use]
    pub fn colour_correction(&self) -> [[f64; 3]; 3] {
        let balanced: [[f64; 3]; 3] =
            std::array::from_fn(|c| std::array::from_fn(|k| self.m[c][k] * self.tint[k] / self.grey_response(c)));
        invert3(&balanced).expect("the three channels see independent colours")
    }
}

/// Sum of `spectrum[i] weight(i)` times the spacing (rectangle rule on the 10 nm grid).
fn integrate(spectrum: &Spectrum, weight: impl Fn(usize) -> f64) -> f64 {
    spectrum.iter().enumerate().map(|(i, &s)| s * weight(i)).sum::<f64>() * STEP_NM
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `m v` for a row-major 3x3 matrix.
#[must_use]
pub fn mat_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    m.map(|row| dot(row, v))
}

/// The inverse of a row-major 3x3 matrix, or `None` when it is singular.
#[must_use]
pub fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c = |r: usize, k: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
        m[r1][k1] * m[r2][k2] - m[r1][k2] * m[r2][k1]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    if det.abs() < 1e-12 {
        return None;
    }
    // Inverse = transpose of the cofactors over the determinant.
    Some(std::array::from_fn(|r| std::array::from_fn(|k| c(k, r) / det)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d65_sits_at_its_published_white_point() {
        // CIE 015: D65 is x = 0.31272, y = 0.32903 over 380-780 nm at 5 nm; the 400-700 nm
        // tables land within 0.002 of it.
        let (x, y) = chromaticity(&Illuminant::D65.spectrum());
        assert!((x - 0.3127).abs() < 0.002 && (y - 0.3290).abs() < 0.002, "({x}, {y})");
        // And its linear-sRGB tint is white.
        let tint = Illuminant::D65.tint();
        assert!(tint.iter().all(|&v| (v - 1.0).abs() < 0.02), "{tint:?}");
    }

    #[test]
    fn a_planckian_radiator_at_2856_k_is_illuminant_a() {
        // CIE illuminant A: x = 0.44757, y = 0.40745.
        let spectrum: Spectrum = std::array::from_fn(|i| planck(2856.0, wavelength_nm(i)));
        let (x, y) = chromaticity(&spectrum);
        assert!((x - 0.4476).abs() < 0.004 && (y - 0.4074).abs() < 0.004, "({x}, {y})");
        // Warm light is red-heavy: the tint's red exceeds its blue several times.
        let tint = Illuminant::Planck(NIGHT_CCT_K).tint();
        assert!(tint[0] > 2.0 * tint[2], "{tint:?}");
    }

    #[test]
    fn the_basis_reproduces_the_primaries_and_sums_to_one() {
        let basis = reflectance_basis();
        let d65 = Illuminant::D65.spectrum();
        let white = integrate(&d65, |i| CIE_1931_XYZ[i][1]);
        for (k, b) in basis.iter().enumerate() {
            let xyz: [f64; 3] = std::array::from_fn(|j| integrate(&d65, |i| b[i] * CIE_1931_XYZ[i][j]) / white);
            let rgb = mat_vec(&XYZ_TO_LINEAR_SRGB, xyz);
            // Within the 4-digit rounding of the sRGB matrix against the tabulated D65.
            for (j, v) in rgb.iter().enumerate() {
                let expected = if j == k { 1.0 } else { 0.0 };
                assert!((v - expected).abs() < 0.02, "basis {k} channel {j}: {v}");
            }
        }
        for i in 0..SAMPLES {
            let sum: f64 = basis.iter().map(|b| b[i]).sum();
            assert!((sum - 1.0).abs() < 1e-9, "{} nm: {sum}", wavelength_nm(i));
        }
    }

    #[test]
    fn one_nit_of_daylight_is_one_nit() {
        let per_nit = Illuminant::D65.per_nit();
        let nit = LM_PER_W * integrate(&per_nit, |i| CIE_1931_XYZ[i][1]);
        assert!((nit - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bayer_channels_peak_where_their_filters_pass() {
        let curves = QeCurves::typical_bayer(0.7);
        let argmax = |s: &Spectrum| wavelength_nm((0..SAMPLES).max_by(|&a, &b| s[a].total_cmp(&s[b])).unwrap());
        assert_eq!(argmax(&curves.channels[1]), 540.0);
        assert!((curves.channels[1].iter().copied().fold(0.0, f64::max) - 0.7).abs() < 1e-12);
        assert!((440.0..=470.0).contains(&argmax(&curves.channels[2])));
        assert!((590.0..=630.0).contains(&argmax(&curves.channels[0])));
        // The IR-cut filter: almost nothing at 700 nm.
        assert!(curves.channels.iter().all(|c| c[SAMPLES - 1] < 0.01));
    }

    #[test]
    fn the_channel_matrix_sees_colours_as_their_filters_do() {
        let m = ChannelMatrix::new(&QeCurves::typical_bayer(0.7), Illuminant::D65, [1.0; 3]);
        // Each channel answers most to its own primary.
        for c in 0..3 {
            let own = m.m[c][c];
            assert!((0..3).all(|k| k == c || m.m[c][k] < own), "{:?}", m.m);
        }
        // Green under daylight: a band of about 100 nm of a broadband spectrum at QE ~0.6 is
        // of the order of the single-wavelength rule's QE (0.7), not several times it.
        let g = m.grey_response(1);
        assert!((0.3..1.2).contains(&g), "{g}");
        // The colour matrix maps a white-balanced grey to grey.
        let ccm = m.colour_correction();
        for row in ccm {
            assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{ccm:?}");
        }
    }

    #[test]
    fn inverse_of_a_matrix() {
        let m = [[2.0, 1.0, 0.0], [0.0, 1.0, 3.0], [1.0, 0.0, 1.0]];
        let inv = invert3(&m).unwrap();
        for (r, row) in m.iter().enumerate() {
            for k in 0..3 {
                let v: f64 = row.iter().zip(&inv).map(|(a, inv_row)| a * inv_row[k]).sum();
                assert!((v - if r == k { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
        assert!(invert3(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }
}
