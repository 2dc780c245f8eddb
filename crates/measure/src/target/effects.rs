//! Image effects of the optics the loop can add, under their names in docs/CONTRACTS.md, applied to the photon
//! image before the sensor (a lens blurs and shades the light, not the noise):
//!
//! * `lens_blur`: an isotropic Gaussian PSF of `sigma_px`.
//! * `motion_blur`: a straight line of `length_px` at `angle_deg` (from the image x axis, 0..90:
//!   two edges cannot tell +a from -a), the image of a camera moving during the exposure.
//! * `illumination_falloff`: a radial gain `1 + a r^2 + b r^4`, `r` the distance from the image
//!   centre over the half-diagonal; added on top of the camera spec's cos^4 vignetting.
//!
//! The noise effects are those of [`scene_gen_camera::sensor::SensorModel`] (see [`super`]).

use serde::{Deserialize, Serialize};

/// Gaussian lens blur.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LensBlur {
    pub sigma_px: f64,
}

/// Linear motion blur.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MotionBlur {
    pub length_px: f64,
    pub angle_deg: f64,
}

/// Radial gain `1 + a r^2 + b r^4`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Falloff {
    pub a: f64,
    pub b: f64,
}

impl Falloff {
    /// Gain at normalised radius squared `u = r^2`.
    #[must_use]
    pub fn gain(&self, u: f64) -> f64 {
        (1.0 + self.a * u + self.b * u * u).max(0.0)
    }
}

/// The optics effects switched on.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ImageEffects {
    pub lens_blur: Option<LensBlur>,
    pub motion_blur: Option<MotionBlur>,
    pub illumination_falloff: Option<Falloff>,
}

/// Normalised squared radius of pixel `(x, y)`'s centre (1 at the corners).
#[must_use]
pub fn radius2(x: usize, y: usize, width: usize, height: usize) -> f64 {
    let (cx, cy) = (width as f64 / 2.0, height as f64 / 2.0);
    let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
    (dx * dx + dy * dy) / (cx * cx + cy * cy)
}

impl ImageEffects {
    /// Applies fall-off, then the blurs, to a row-major `width x height` image.
    #[must_use]
    pub fn apply(&self, image: &[f32], width: usize, height: usize) -> Vec<f32> {
        let mut out: Vec<f32> = match self.illumination_falloff {
            Some(f) => image
                .iter()
                .enumerate()
                .map(|(i, &v)| v * f.gain(radius2(i % width, i / width, width, height)) as f32)
                .collect(),
            None => image.to_vec(),
        };
        if let Some(b) = self.lens_blur {
            out = gaussian_blur(&out, width, height, b.sigma_px);
        }
        if let Some(m) = self.motion_blur {
            out = convolve(&out, width, height, &line_kernel(m.length_px, m.angle_deg));
        }
        out
    }
}

/// Separable Gaussian blur, radius `ceil(4 sigma)`, edges replicated.
#[must_use]
pub fn gaussian_blur(image: &[f32], width: usize, height: usize, sigma: f64) -> Vec<f32> {
    if sigma <= 0.0 {
        return image.to_vec();
    }
    let r = (4.0 * sigma).ceil() as isize;
    let mut k: Vec<f64> = (-r..=r).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp()).collect();
    let s: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= s);
    let clampi = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    let mut tmp = vec![0f32; image.len()];
    for y in 0..height {
        for x in 0..width {
            let acc: f64 = k
                .iter()
                .enumerate()
                .map(|(j, w)| w * f64::from(image[y * width + clampi(x as isize + j as isize - r, width)]))
                .sum();
            tmp[y * width + x] = acc as f32;
        }
    }
    let mut out = vec![0f32; image.len()];
    for y in 0..height {
        for x in 0..width {
            let acc: f64 = k
                .iter()
                .enumerate()
                .map(|(j, w)| w * f64::from(tmp[clampi(y as isize + j as isize - r, height) * width + x]))
                .sum();
            out[y * width + x] = acc as f32;
        }
    }
    out
}

/// A normalised kernel `(size, weights)` for a line of `length` pixels at `angle_deg`: each
/// weight is the share of the segment's length inside that pixel's cell (points every 1/16 px
/// along it, each given to the pixel it falls in).
///
/// The photon image is already integrated over each pixel, so the kernel must not add a blur
/// of its own: a bilinear splat would widen the line by a tent of one pixel. A horizontal line
/// of whole length `L` is then the `L`-tap box filter.
#[must_use]
pub fn line_kernel(length: f64, angle_deg: f64) -> (usize, Vec<f64>) {
    let half = (length / 2.0).ceil() as usize + 1;
    let size = 2 * half + 1;
    let mut k = vec![0f64; size * size];
    let (dx, dy) = (angle_deg.to_radians().cos(), angle_deg.to_radians().sin());
    let n = ((length * 16.0).ceil() as usize).max(1);
    for i in 0..n {
        let t = if n == 1 { 0.0 } else { (i as f64 + 0.5) / n as f64 - 0.5 } * length;
        // Pixel `half` spans [half - 1/2, half + 1/2) about the kernel's centre.
        let (x, y) = ((half as f64 + t * dx + 0.5).floor(), (half as f64 + t * dy + 0.5).floor());
        if (0.0..size as f64).contains(&x) && (0.0..size as f64).contains(&y) {
            k[y as usize * size + x as usize] += 1.0;
        }
    }
    let s: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= s);
    (size, k)
}

/// 2-D convolution with an odd square kernel, edges replicated.
#[must_use]
pub fn convolve(image: &[f32], width: usize, height: usize, (size, k): &(usize, Vec<f64>)) -> Vec<f32> {
    let half = (*size / 2) as isize;
    let taps: Vec<(isize, isize, f64)> = k
        .iter()
        .enumerate()
        .filter(|(_, w)| **w > 0.0)
        .map(|(i, w)| ((i % size) as isize - half, (i / size) as isize - half, *w))
        .collect();
    let mut out = vec![0f32; image.len()];
    for y in 0..height {
        for x in 0..width {
            let acc: f64 = taps
                .iter()
                .map(|&(dx, dy, w)| {
                    let xs = (x as isize + dx).clamp(0, width as isize - 1) as usize;
                    let ys = (y as isize + dy).clamp(0, height as isize - 1) as usize;
                    w * f64::from(image[ys * width + xs])
                })
                .sum();
            out[y * width + x] = acc as f32;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blurs_keep_the_mean_and_spread_a_point() {
        let (w, h) = (31, 31);
        let mut img = vec![0f32; w * h];
        img[15 * w + 15] = 1.0;
        let g = gaussian_blur(&img, w, h, 1.5);
        assert!((g.iter().sum::<f32>() - 1.0).abs() < 1e-4);
        // Second moment along x equals sigma^2.
        let vx: f64 = g.iter().enumerate().map(|(i, v)| f64::from(*v) * ((i % w) as f64 - 15.0).powi(2)).sum();
        assert!((vx - 2.25).abs() < 0.02, "{vx}");
        let m = convolve(&img, w, h, &line_kernel(9.0, 0.0));
        let vy: f64 = m.iter().enumerate().map(|(i, v)| f64::from(*v) * ((i / w) as f64 - 15.0).powi(2)).sum();
        let vx: f64 = m.iter().enumerate().map(|(i, v)| f64::from(*v) * ((i % w) as f64 - 15.0).powi(2)).sum();
        assert!(vy < 1e-9, "{vy}");
        // The 9-tap box: weights 1/9 at -4..=4, variance (81 - 1) / 12.
        assert!((vx - 80.0 / 12.0).abs() < 1e-4, "{vx}");
        assert!((m[15 * w + 19] - 1.0 / 9.0).abs() < 1e-6 && m[15 * w + 20] == 0.0);
    }

    #[test]
    fn falloff_darkens_corners_only() {
        let f = ImageEffects { illumination_falloff: Some(Falloff { a: -0.3, b: 0.0 }), ..Default::default() };
        let out = f.apply(&[100.0; 16 * 10], 16, 10);
        // Corner pixel centre: r^2 = (7.5^2 + 4.5^2) / (8^2 + 5^2) = 0.86, gain 0.742.
        assert!((out[0] - 74.2).abs() < 0.1, "{}", out[0]);
        assert!(out[5 * 16 + 8] > 99.0);
    }
}
