//! The test chart: its layout in pixels and its image through the project's camera path.
//!
//! The chart is a flat, matte (Lambertian) board facing the camera at `distance_m`, sized to
//! fill the view exactly, so its layout in pixels does not depend on the distance (only its size
//! in metres does). It is cut into a grid of 8 x 5 cells:
//!
//! ```text
//!   col  0    1    2    3    4    5    6    7
//! row 0  P    P    P    P    P    P    P    P        P: grey patch (known reflectance)
//!     1  P    P   [ edge V  ][ edge H  ]  P    P      edge V: near-vertical edge, 5 deg off
//!     2  P    P   [         ][         ]  P    P              vertical (dark left, bright right)
//!     3  P    P   [   texture (random blocks)  ]  P    P      edge H: near-horizontal edge, 5 deg
//!     4  P    P    P    P    P    P    P    P                off horizontal (dark top)
//! ```
//!
//! The 28 grey patches sit at radii 0.5..1 of the half-diagonal, so their reflectance-normalised
//! brightness gives the radial fall-off; the two slanted edges give the edge spread across x and
//! across y (slanted-edge method, ISO 12233 style: the slant spreads pixel phases so the binned
//! ESF is oversampled); the texture gives ORB keypoints.
//!
//! Rendering: reflectance (4 x 4 supersampled per pixel, so edges are area-averaged) times the
//! chart illuminance gives luminance `L = E rho / pi`; [`scene_gen_camera::radiometry::photon_image`] turns
//! it into photons per pixel (camera equation, the spec's cos^4 vignetting, exposure, pixel
//! area), and [`SensorModel::simulate`] into DN. The illuminance is chosen so that a white patch
//! on axis reaches [`WHITE_FRACTION`] of the ADC range at the camera's day gain (auto exposure),
//! and recorded in the layout.

use rand::Rng as _;
use serde::{Deserialize, Serialize};

use scene_gen_camera::camera_spec::ResolvedCamera;
use scene_gen_camera::sensor::SensorModel;
use scene_gen_core::rng;
use scene_gen_render::Camera;

/// Schema tag of the layout JSON.
pub const LAYOUT_SCHEMA: &str = "scene-gen/target-layout/1";

/// Grid of the chart, cells across and down.
pub const GRID: (usize, usize) = (8, 5);

/// Reflectances the grey patches cycle through: roughly even steps in lightness from a dark
/// grey to a near white, like the grey row of a ColorChecker (stated design, not a product).
pub const PATCH_REFLECTANCES: [f64; 7] = [0.05, 0.10, 0.18, 0.30, 0.45, 0.65, 0.88];

/// Reflectances of the dark and bright sides of the slanted edges. A moderate contrast
/// (ISO 12233:2017 recommends about 4:1 for the slanted edge) keeps both sides off the clip.
pub const EDGE_DARK: f64 = 0.15;
pub const EDGE_BRIGHT: f64 = 0.60;

/// Slant of the edges from the pixel grid, degrees (ISO 12233 uses about 5 deg).
pub const EDGE_SLANT_DEG: f64 = 5.0;

/// A white patch on axis is exposed to this fraction of the ADC range (auto exposure).
pub const WHITE_FRACTION: f64 = 0.7;

/// Pixel box, half-open: `x0 <= x < x1`, `y0 <= y < y1`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PixelBox {
    pub x0: usize,
    pub y0: usize,
    pub x1: usize,
    pub y1: usize,
}

impl PixelBox {
    /// The box shrunk by `m` pixels on each side.
    #[must_use]
    pub fn inset(&self, m: usize) -> PixelBox {
        PixelBox { x0: self.x0 + m, y0: self.y0 + m, x1: self.x1.saturating_sub(m), y1: self.y1.saturating_sub(m) }
    }

    fn contains(&self, x: f64, y: f64) -> bool {
        x >= self.x0 as f64 && x < self.x1 as f64 && y >= self.y0 as f64 && y < self.y1 as f64
    }

    /// Centre in continuous pixel coordinates.
    #[must_use]
    pub fn centre(&self) -> (f64, f64) {
        ((self.x0 + self.x1) as f64 / 2.0, (self.y0 + self.y1) as f64 / 2.0)
    }
}

/// One grey patch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Patch {
    pub id: usize,
    pub reflectance: f64,
    /// The whole cell.
    pub cell: PixelBox,
    /// The region the statistics use: the cell inset by a quarter of its size, clear of blur
    /// from the neighbouring cells.
    pub roi: PixelBox,
    /// Distance of the centre from the image centre over the half-diagonal (0..1).
    pub radius: f64,
}

/// One slanted edge: the line through `point` with direction `angle_deg` (from the image x axis,
/// y down); the bright side is where `(p - point) . normal > 0`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Edge {
    /// "vertical" (its spread is across x) or "horizontal" (across y).
    pub id: String,
    pub cell: PixelBox,
    pub point: [f64; 2],
    pub angle_deg: f64,
    pub normal: [f64; 2],
    pub dark: f64,
    pub bright: f64,
}

impl Edge {
    /// Signed distance of a continuous pixel position from the edge line, pixels (positive on
    /// the bright side).
    #[must_use]
    pub fn distance(&self, x: f64, y: f64) -> f64 {
        (x - self.point[0]) * self.normal[0] + (y - self.point[1]) * self.normal[1]
    }

    /// Share of the unit pixel square centred on `(x, y)` that lies on the bright side, exact.
    ///
    /// Over the square, the signed distance is `d + nx u + ny v` with `u, v` uniform on
    /// `[-1/2, 1/2]`, so the share is `P(|nx| U + |ny| V > -d)`: the distribution function of a
    /// sum of two uniform variables (a trapezoid density), evaluated at `d`.
    #[must_use]
    pub fn bright_share(&self, x: f64, y: f64) -> f64 {
        let d = self.distance(x, y);
        let (a, b) = {
            let (p, q) = (self.normal[0].abs(), self.normal[1].abs());
            (p.max(q), p.min(q))
        };
        let (outer, inner) = ((a + b) / 2.0, (a - b) / 2.0);
        if d <= -outer {
            0.0
        } else if d >= outer {
            1.0
        } else if b < 1e-12 {
            (d + outer) / (2.0 * outer)
        } else if d <= -inner {
            (d + outer).powi(2) / (2.0 * a * b)
        } else if d <= inner {
            (d + inner) / a + b / (2.0 * a)
        } else {
            1.0 - (outer - d).powi(2) / (2.0 * a * b)
        }
    }
}

/// Where everything is, in pixels, and how the chart was exposed. The measured photograph is
/// assumed registered to this layout (same size, same framing); registration is out of scope.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Layout {
    pub schema: String,
    pub sensor: String,
    pub width_px: usize,
    pub height_px: usize,
    /// ADC depth of the DN values (a 16-bit PNG holds them unscaled).
    pub bits: u32,
    pub distance_m: f64,
    pub chart_width_m: f64,
    pub chart_height_m: f64,
    pub illuminance_lux: f64,
    pub exposure_s: f64,
    pub gain_db: f64,
    pub black_level_dn: f64,
    pub patches: Vec<Patch>,
    pub edges: Vec<Edge>,
    /// Random blocks for ORB keypoints.
    pub texture: PixelBox,
    /// Side of a texture block, pixels.
    pub texture_block_px: usize,
    /// Seed of the texture blocks.
    pub texture_seed: u64,
    /// Reflectances of the texture blocks, row-major over the texture box in blocks (the last
    /// column and row may be cut by the box), so that another tool can draw the same chart.
    #[serde(default)]
    pub texture_reflectances: Vec<f64>,
    /// How the chart was exposed and read out, so that another tool can draw the photograph
    /// with noise of its own.
    #[serde(default)]
    pub sensor_record: SensorRecord,
}

/// The exposure and the sensor's figures behind a chart image, at the chart's gain and
/// binning. A pixel of reflectance `rho` at field angle `theta` collects on average
/// `signal_e_per_reflectance * rho * cos^4(theta)` signal electrons (cos^4 where the camera
/// vignettes; `tan theta` is the offset on the chart over `distance_m`), plus `dark_e`; it
/// reads `black_offset_dn + system_gain_dn_per_e * electrons` plus read noise of
/// `read_noise_dn`, rounded and clipped to the ADC range; charge beyond `full_well_e` is lost.
/// The catalog's default sensor has no fixed-pattern noise, so these figures are all of it.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SensorRecord {
    /// Mean signal electrons of a pixel on the optical axis per unit reflectance.
    pub signal_e_per_reflectance: f64,
    /// Whether the relative illumination falls as cos^4 of the field angle.
    pub cos4_vignetting: bool,
    /// Mean dark-current electrons in the exposure.
    pub dark_e: f64,
    /// DN per electron at the chart's gain.
    pub system_gain_dn_per_e: f64,
    /// Output with no charge at all, DN.
    pub black_offset_dn: f64,
    /// Temporal read noise, DN.
    pub read_noise_dn: f64,
    /// Charge capacity of a pixel, electrons (`null`: charge is not clipped).
    pub full_well_e: Option<f64>,
}

/// Seed of the texture, fixed: the chart is one printed object.
const TEXTURE_SEED: u64 = 12233;

fn cell(c: usize, r: usize, w: usize, h: usize) -> PixelBox {
    let (gx, gy) = GRID;
    PixelBox { x0: c * w / gx, y0: r * h / gy, x1: (c + 1) * w / gx, y1: (r + 1) * h / gy }
}

fn merged(a: PixelBox, b: PixelBox) -> PixelBox {
    PixelBox { x0: a.x0.min(b.x0), y0: a.y0.min(b.y0), x1: a.x1.max(b.x1), y1: a.y1.max(b.y1) }
}

fn edge(id: &str, cell: PixelBox, angle_deg: f64) -> Edge {
    let (cx, cy) = cell.centre();
    let a = angle_deg.to_radians();
    // Normal: the direction rotated +90 deg (y down), then flipped so the bright side is right
    // (vertical edge) or below (horizontal edge).
    let mut n = [-a.sin(), a.cos()];
    if (id == "vertical" && n[0] < 0.0) || (id == "horizontal" && n[1] < 0.0) {
        n = [-n[0], -n[1]];
    }
    Edge { id: id.to_string(), cell, point: [cx, cy], angle_deg, normal: n, dark: EDGE_DARK, bright: EDGE_BRIGHT }
}

impl Layout {
    /// The layout for a camera at `width x height` pixels; exposure fields are filled by
    /// [`chart_layout`].
    #[must_use]
    pub fn grid(width: usize, height: usize) -> Layout {
        let (gx, gy) = GRID;
        let (cx, cy) = (width as f64 / 2.0, height as f64 / 2.0);
        let half_diag = (cx * cx + cy * cy).sqrt();
        let central = |c: usize, r: usize| (2..6).contains(&c) && (1..4).contains(&r);
        let mut patches = Vec::new();
        for r in 0..gy {
            for c in 0..gx {
                if central(c, r) {
                    continue;
                }
                let cellb = cell(c, r, width, height);
                let m = ((cellb.x1 - cellb.x0).min(cellb.y1 - cellb.y0) / 4).max(1);
                let (px, py) = cellb.centre();
                let radius = ((px - cx).powi(2) + (py - cy).powi(2)).sqrt() / half_diag;
                let id = patches.len();
                // Spread the reflectances over the rings: neighbours differ by 3 steps.
                let reflectance = PATCH_REFLECTANCES[(c * 3 + r * 5) % PATCH_REFLECTANCES.len()];
                patches.push(Patch { id, reflectance, cell: cellb, roi: cellb.inset(m), radius });
            }
        }
        let ev = merged(cell(2, 1, width, height), cell(3, 2, width, height));
        let eh = merged(cell(4, 1, width, height), cell(5, 2, width, height));
        let texture = merged(cell(2, 3, width, height), cell(5, 3, width, height));
        Layout {
            schema: LAYOUT_SCHEMA.to_string(),
            sensor: String::new(),
            width_px: width,
            height_px: height,
            bits: 8,
            distance_m: 0.0,
            chart_width_m: 0.0,
            chart_height_m: 0.0,
            illuminance_lux: 0.0,
            exposure_s: 0.0,
            gain_db: 0.0,
            black_level_dn: 0.0,
            patches,
            edges: vec![edge("vertical", ev, 90.0 + EDGE_SLANT_DEG), edge("horizontal", eh, EDGE_SLANT_DEG)],
            texture,
            texture_block_px: (width / 80).max(2),
            texture_seed: TEXTURE_SEED,
            texture_reflectances: Vec::new(),
            sensor_record: SensorRecord::default(),
        }
        .with_texture()
    }

    fn with_texture(mut self) -> Layout {
        self.texture_reflectances = self.texture_blocks();
        self
    }

    /// Reflectance at a continuous pixel position.
    #[must_use]
    pub fn reflectance(&self, x: f64, y: f64, texture: &[f64]) -> f64 {
        for e in &self.edges {
            if e.cell.contains(x, y) {
                return if e.distance(x, y) > 0.0 { e.bright } else { e.dark };
            }
        }
        if self.texture.contains(x, y) {
            let b = self.texture_block_px as f64;
            let tw = (self.texture.x1 - self.texture.x0).div_ceil(self.texture_block_px);
            let (i, j) = (((x - self.texture.x0 as f64) / b) as usize, ((y - self.texture.y0 as f64) / b) as usize);
            return texture[j * tw + i];
        }
        let (gx, gy) = GRID;
        let c = ((x * gx as f64 / self.width_px as f64) as usize).min(gx - 1);
        let r = ((y * gy as f64 / self.height_px as f64) as usize).min(gy - 1);
        self.patches.iter().find(|p| p.cell.contains(x, y)).map_or_else(
            // A position on a rounded cell border: the patch of the cell it falls in by grid.
            || {
                self.patches
                    .iter()
                    .find(|p| p.cell == cell(c, r, self.width_px, self.height_px))
                    .map_or(0.18, |p| p.reflectance)
            },
            |p| p.reflectance,
        )
    }

    /// Reflectances of the texture blocks, row-major.
    #[must_use]
    pub fn texture_blocks(&self) -> Vec<f64> {
        let b = self.texture_block_px;
        let (tw, th) =
            ((self.texture.x1 - self.texture.x0).div_ceil(b), (self.texture.y1 - self.texture.y0).div_ceil(b));
        let mut r = rng::stream(self.texture_seed, "target/texture");
        (0..tw * th).map(|_| 0.1 + 0.7 * r.random::<f64>()).collect()
    }

    /// Reflectance image, each pixel the exact mean over its area. Every boundary of the chart
    /// but the slanted edges falls on pixel borders (cells, patches and texture blocks start at
    /// whole pixels), so a pixel outside the edges' cells reads its centre, and one inside reads
    /// the share of its square on the bright side ([`Edge::bright_share`]).
    #[must_use]
    pub fn reflectance_image(&self) -> Vec<f64> {
        let tex = self.texture_blocks();
        let w = self.width_px;
        (0..w * self.height_px)
            .map(|i| {
                let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
                match self.edges.iter().find(|e| e.cell.contains(x, y)) {
                    Some(e) => e.dark + (e.bright - e.dark) * e.bright_share(x, y),
                    None => self.reflectance(x, y, &tex),
                }
            })
            .collect()
    }
}

/// The pinhole camera facing the chart (its pose does not matter: the chart fills the view and
/// the relative illumination depends only on the field angle).
#[must_use]
pub fn chart_camera(resolved: &ResolvedCamera) -> Camera {
    Camera { pitch_deg: 0.0, ..resolved.camera(glam::Vec3::ZERO, 0.0) }
}

/// The full layout of `resolved` at `distance_m`: geometry, chart size and exposure.
#[must_use]
pub fn chart_layout(resolved: &ResolvedCamera, distance_m: f64) -> Layout {
    let cam = chart_camera(resolved);
    let mut layout = Layout::grid(cam.width_px as usize, cam.height_px as usize);
    let model = resolved.sensor_model(0);
    let spec = &resolved.spec;
    let gain_db = spec.gain_day_db;
    // Photons per pixel on axis for 1 nit, then the luminance putting white at WHITE_FRACTION.
    let p1 = scene_gen_camera::radiometry::photons_per_pixel(
        1.0,
        f64::from(cam.f_number),
        f64::from(spec.lens_transmittance),
        1.0,
        spec.exposure_s,
        f64::from(cam.pixel_pitch_um),
    );
    let black = model.expected_mean_dn(0.0, spec.exposure_s, gain_db);
    let per_photon = (model.expected_mean_dn(1000.0, spec.exposure_s, gain_db) - black) / 1000.0;
    let white = *PATCH_REFLECTANCES.last().unwrap_or(&0.9);
    let photons = (WHITE_FRACTION * model.max_dn() - black).max(1.0) / per_photon;
    let lum = photons / p1;
    layout.sensor = resolved.sensor.model.clone();
    layout.bits = model.adc_bits;
    layout.distance_m = distance_m;
    layout.chart_width_m = distance_m * f64::from(cam.sensor_width_mm()) / f64::from(cam.focal_mm);
    layout.chart_height_m = distance_m * f64::from(cam.sensor_height_mm()) / f64::from(cam.focal_mm);
    layout.illuminance_lux = lum * std::f64::consts::PI / white;
    layout.exposure_s = spec.exposure_s;
    layout.gain_db = gain_db;
    layout.black_level_dn = black;
    let k = model.k_dn_per_e(gain_db);
    let dark_e = model.dark_e(spec.exposure_s);
    layout.sensor_record = SensorRecord {
        signal_e_per_reflectance: model.quantum_efficiency * p1 * layout.illuminance_lux / std::f64::consts::PI,
        cos4_vignetting: cam.vignetting,
        dark_e,
        system_gain_dn_per_e: k,
        black_offset_dn: black - k * dark_e,
        read_noise_dn: model.read_noise_dn(gain_db),
        full_well_e: model.full_well_e(),
    };
    layout
}

/// Mean photons per pixel of the chart (before any image effect and the sensor).
#[must_use]
pub fn photon_image(resolved: &ResolvedCamera, layout: &Layout) -> Vec<f32> {
    let cam = chart_camera(resolved);
    let lum: Vec<f32> = layout
        .reflectance_image()
        .iter()
        .map(|rho| (layout.illuminance_lux * rho / std::f64::consts::PI) as f32)
        .collect();
    scene_gen_camera::radiometry::photon_image(&cam, &lum, resolved.spec.lens_transmittance, layout.exposure_s)
}

/// One noisy chart frame, DN.
#[must_use]
pub fn simulate(model: &SensorModel, layout: &Layout, photons: &[f32], frame_seed: u64) -> Vec<u16> {
    model.simulate(photons, layout.width_px, layout.height_px, layout.exposure_s, layout.gain_db, frame_seed)
}

/// The noiseless chart, DN (expected value of a typical pixel, not rounded).
#[must_use]
pub fn expected(model: &SensorModel, layout: &Layout, photons: &[f32]) -> Vec<f64> {
    photons.iter().map(|&p| model.expected_mean_dn(f64::from(p), layout.exposure_s, layout.gain_db)).collect()
}

/// Scale of the noiseless chart PNG: it holds `round(MEAN_PNG_SCALE * DN)` so that the
/// sub-DN shading survives (at the binned resolution the darkest patches' noise is under 1 DN).
pub const MEAN_PNG_SCALE: f64 = 16.0;

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed form against a 200 x 200 grid of point samples over the pixel, for slants
    /// from axis-aligned to diagonal and offsets across the whole transition.
    #[test]
    fn bright_share_is_the_area_on_the_bright_side() {
        let n = 200;
        for angle_deg in [0.0, 5.0, 30.0, 45.0, 85.0, 95.0, 137.0] {
            let e = edge("vertical", PixelBox { x0: 0, y0: 0, x1: 10, y1: 10 }, angle_deg);
            for k in 0..=20 {
                let (x, y) = (5.0 + 0.07 * f64::from(k) - 0.7, 5.0 + 0.03 * f64::from(k));
                let sampled = (0..n * n)
                    .filter(|i| {
                        let (u, v) = (((i % n) as f64 + 0.5) / n as f64 - 0.5, ((i / n) as f64 + 0.5) / n as f64 - 0.5);
                        e.distance(x + u, y + v) > 0.0
                    })
                    .count() as f64
                    / (n * n) as f64;
                let exact = e.bright_share(x, y);
                assert!((exact - sampled).abs() < 0.01, "{angle_deg} deg at ({x}, {y}): {exact} vs {sampled}");
            }
        }
    }

    /// Away from the edges a pixel holds one reflectance, so the image is exactly the cell,
    /// block or patch value there, and the texture written into the layout is the one drawn.
    #[test]
    fn reflectance_image_is_exact_off_the_edges() {
        let layout = Layout::grid(160, 100);
        let img = layout.reflectance_image();
        let tex = layout.texture_blocks();
        assert_eq!(layout.texture_reflectances, tex);
        for p in &layout.patches {
            for y in p.cell.y0..p.cell.y1 {
                for x in p.cell.x0..p.cell.x1 {
                    assert_eq!(img[y * 160 + x], p.reflectance);
                }
            }
        }
        for e in &layout.edges {
            let row = e.cell.centre().1 as usize * 160;
            let mixed = (e.cell.x0..e.cell.x1).filter(|&x| img[row + x] > e.dark && img[row + x] < e.bright).count();
            assert!(mixed >= 1, "{}: no pixel of the middle row is mixed", e.id);
        }
    }
}
