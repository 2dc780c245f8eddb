//! A pinhole camera described by plain numbers (so it does not depend on the sensor catalog),
//! and the radiance-to-sensor-illuminance conversion.
//!
//! The image plane sits `focal_mm` behind the pinhole and is `width_px * pixel_pitch_um` by
//! `height_px * pixel_pitch_um` large, so the fields of view are
//! `hfov = 2 atan(sensor_width / (2 f))` and `vfov = 2 atan(sensor_height / (2 f))` (square
//! pixels, principal point at the image centre, no distortion). Pixel (0, 0) is the top-left;
//! image x runs right and y down; pixel (x, y) covers `[x, x + 1) x [y, y + 1)` in continuous
//! pixel coordinates.

use glam::Vec3;

use super::RenderError;
use scene_gen_trace::lanes::{Lanes, Lanes3, N};

/// Transmittance of a typical multi-element coated lens in the visible band, used when a
/// camera spec gives none (assumed; real lenses measure 0.8..0.95).
pub const DEFAULT_LENS_TRANSMITTANCE: f32 = 0.9;

/// A rectangle of whole pixels: columns `x0 .. x0 + width`, rows `y0 .. y0 + height`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
}

impl PixelRect {
    /// Number of pixels.
    #[must_use]
    pub fn area(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// Depth (metres along the optical axis) at which [`Camera::box_pixels`] clips a box: a
/// camera ray meets nothing at or behind the pinhole's plane.
const CLIP_DEPTH_M: f64 = 1e-9;

/// A pinhole camera in the world (Z up, metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub width_px: u32,
    pub height_px: u32,
    pub pixel_pitch_um: f32,
    pub focal_mm: f32,
    /// Only used by the sensor-plane conversion; a pinhole has no depth of field.
    pub f_number: f32,
    /// Centre of projection, world metres.
    pub position: Vec3,
    /// Heading: 0 looks along +X, counter-clockwise about +Z.
    pub yaw_deg: f32,
    /// Elevation of the optical axis, positive up.
    pub pitch_deg: f32,
    /// Apply the cos^4 natural fall-off in [`Camera::relative_illumination`].
    pub vignetting: bool,
}

impl Camera {
    /// A fingerprint of everything that places this view's pixels in the scene (size,
    /// intrinsics, pose): the renderer mixes it into every pixel's random stream
    /// ([`super::Renderer::pixel_seed`]), so two views share no pattern of sub-pixel jitter,
    /// light samples and roulette. Keyed by the pixel alone, that pattern stood still on the
    /// screen while the scene moved, and a tracker matched it from frame to frame: a
    /// translating camera's fundamental matrix is skew-symmetric, so a feature that stays at
    /// the same pixel is always an inlier (docs/BENCHMARKS.md, "Render noise and ORB inliers").
    #[must_use]
    pub fn view_key(&self) -> u64 {
        let numbers = [
            self.pixel_pitch_um,
            self.focal_mm,
            self.position.x,
            self.position.y,
            self.position.z,
            self.yaw_deg,
            self.pitch_deg,
        ];
        // On the stack: the renderer asks once per tile.
        let mut bytes = [0u8; 8 + 4 * 7];
        bytes[..4].copy_from_slice(&self.width_px.to_le_bytes());
        bytes[4..8].copy_from_slice(&self.height_px.to_le_bytes());
        for (chunk, v) in bytes[8..].chunks_exact_mut(4).zip(numbers) {
            chunk.copy_from_slice(&v.to_bits().to_le_bytes());
        }
        scene_gen_core::rng::fnv1a64(&bytes)
    }

    /// Checks that every number is finite and in range (positive sizes, |pitch| <= 90 deg;
    /// straight down is fine because roll is fixed by the yaw alone).
    ///
    /// # Errors
    /// [`RenderError::BadCamera`] naming the first offending field.
    pub fn validate(&self) -> Result<(), RenderError> {
        let bad = |field: &'static str, why: &str| Err(RenderError::BadCamera { field, why: why.to_string() });
        if self.width_px == 0 || self.height_px == 0 {
            return bad("width_px/height_px", "must be at least 1");
        }
        for (field, v) in
            [("pixel_pitch_um", self.pixel_pitch_um), ("focal_mm", self.focal_mm), ("f_number", self.f_number)]
        {
            if !(v.is_finite() && v > 0.0) {
                return bad(field, &format!("must be a positive number, got {v}"));
            }
        }
        if !self.position.is_finite() {
            return bad("position", "must be finite");
        }
        if !self.yaw_deg.is_finite() {
            return bad("yaw_deg", "must be finite");
        }
        if !(self.pitch_deg.is_finite() && self.pitch_deg.abs() <= 90.0) {
            return bad("pitch_deg", &format!("must be within [-90, 90], got {}", self.pitch_deg));
        }
        Ok(())
    }

    /// Sensor width, millimetres.
    #[must_use]
    pub fn sensor_width_mm(&self) -> f32 {
        self.width_px as f32 * self.pixel_pitch_um * 1e-3
    }

    /// Sensor height, millimetres.
    #[must_use]
    pub fn sensor_height_mm(&self) -> f32 {
        self.height_px as f32 * self.pixel_pitch_um * 1e-3
    }

    /// Horizontal field of view, `2 atan(w / 2f)`.
    #[must_use]
    pub fn hfov_deg(&self) -> f32 {
        2.0 * (self.sensor_width_mm() / (2.0 * self.focal_mm)).atan().to_degrees()
    }

    /// Vertical field of view, `2 atan(h / 2f)`.
    #[must_use]
    pub fn vfov_deg(&self) -> f32 {
        2.0 * (self.sensor_height_mm() / (2.0 * self.focal_mm)).atan().to_degrees()
    }

    /// Unit (forward, right, up) of the camera in the world; roll is zero, so `right` is
    /// horizontal.
    #[must_use]
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let (sy, cy) = self.yaw_deg.to_radians().sin_cos();
        let (sp, cp) = self.pitch_deg.to_radians().sin_cos();
        let forward = Vec3::new(cp * cy, cp * sy, sp);
        let right = Vec3::new(sy, -cy, 0.0);
        let up = right.cross(forward);
        (forward, right, up)
    }

    /// The whole frame as a [`PixelRect`].
    #[must_use]
    pub fn full_rect(&self) -> PixelRect {
        PixelRect { x0: 0, y0: 0, width: self.width_px, height: self.height_px }
    }

    /// A rectangle holding every pixel whose centre ray can meet the axis-aligned box
    /// `[min, max]` (world metres), or `None` when none can: the box is clipped to the space in
    /// front of the pinhole, its corners and clip points are projected, and their bounding
    /// rectangle is grown by one pixel on each side for rounding. Conservative, not tight:
    /// callers that count what rays hit inside it (ids of thresholds) get exactly the count of
    /// the whole frame, for a fraction of the rays.
    #[must_use]
    pub fn box_pixels(&self, min: Vec3, max: Vec3) -> Option<PixelRect> {
        let (forward, right, up) = self.basis();
        let corners: [[f64; 3]; 8] = std::array::from_fn(|i| {
            let p = Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            );
            let d = (p - self.position).as_dvec3();
            [d.dot(right.as_dvec3()), d.dot(up.as_dvec3()), d.dot(forward.as_dvec3())]
        });
        // The clipped box is the convex hull of its corners in front and of the points where
        // its 12 edges cross the clip plane; their projections bound its image.
        let mut points: Vec<[f64; 3]> = corners.iter().copied().filter(|c| c[2] >= CLIP_DEPTH_M).collect();
        for a in 0..8 {
            for bit in [1, 2, 4] {
                let b = a | bit;
                let (ca, cb) = (corners[a], corners[b]);
                if b != a && (ca[2] < CLIP_DEPTH_M) != (cb[2] < CLIP_DEPTH_M) {
                    let f = (CLIP_DEPTH_M - ca[2]) / (cb[2] - ca[2]);
                    points.push(std::array::from_fn(|k| ca[k] + f * (cb[k] - ca[k])));
                }
            }
        }
        if points.is_empty() {
            return None;
        }
        let px_per_m_at_unit_depth = f64::from(self.focal_mm) / (f64::from(self.pixel_pitch_um) * 1e-3);
        let (w, h) = (f64::from(self.width_px), f64::from(self.height_px));
        let (mut u0, mut u1, mut v0, mut v1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for [x, y, z] in points {
            let u = w * 0.5 + x / z * px_per_m_at_unit_depth;
            let v = h * 0.5 - y / z * px_per_m_at_unit_depth;
            (u0, u1, v0, v1) = (u0.min(u), u1.max(u), v0.min(v), v1.max(v));
        }
        // Pixel i's centre is i + 0.5: columns floor(u0 - 1) ..= ceil(u1 + 1), clamped.
        let x0 = (u0 - 1.0).floor().clamp(0.0, w);
        let x1 = (u1 + 1.0).ceil().clamp(0.0, w);
        let y0 = (v0 - 1.0).floor().clamp(0.0, h);
        let y1 = (v1 + 1.0).ceil().clamp(0.0, h);
        (x1 > x0 && y1 > y0).then_some(PixelRect {
            x0: x0 as u32,
            y0: y0 as u32,
            width: (x1 - x0) as u32,
            height: (y1 - y0) as u32,
        })
    }

    /// Where world point `p` images: continuous pixel coordinates (pixel `i`'s centre at
    /// `i + 0.5`, as for [`Camera::ray_direction`]) and its depth along the optical axis,
    /// metres; `None` for a point at or behind the pinhole's plane.
    #[must_use]
    pub fn project(&self, p: Vec3) -> Option<(f32, f32, f32)> {
        let (forward, right, up) = self.basis();
        let d = p - self.position;
        let depth_m = d.dot(forward);
        if depth_m <= CLIP_DEPTH_M as f32 {
            return None;
        }
        let px_per_m_at_unit_depth = self.focal_mm / (self.pixel_pitch_um * 1e-3);
        let px = self.width_px as f32 * 0.5 + d.dot(right) / depth_m * px_per_m_at_unit_depth;
        let py = self.height_px as f32 * 0.5 - d.dot(up) / depth_m * px_per_m_at_unit_depth;
        Some((px, py, depth_m))
    }

    /// The world point imaged at continuous pixel coordinates `(px, py)` at `depth_m` along
    /// the optical axis (the [`super::Frame::depth_m`] convention): the inverse of
    /// [`Camera::project`].
    #[must_use]
    pub fn point_at(&self, px: f32, py: f32, depth_m: f32) -> Vec3 {
        let (forward, right, up) = self.basis();
        let m_per_px_at_unit_depth = self.pixel_pitch_um * 1e-3 / self.focal_mm;
        let x = (px - self.width_px as f32 * 0.5) * m_per_px_at_unit_depth;
        let y = (self.height_px as f32 * 0.5 - py) * m_per_px_at_unit_depth;
        self.position + (forward + right * x + up * y) * depth_m
    }

    /// Unit world direction of the ray through continuous pixel coordinates `(px, py)`.
    #[must_use]
    pub fn ray_direction(&self, px: f32, py: f32) -> Vec3 {
        self.ray_direction_in(self.basis(), px, py)
    }

    /// [`Camera::ray_direction`] with the [`Camera::basis`] computed once by the caller.
    #[must_use]
    #[inline]
    pub fn ray_direction_in(&self, (forward, right, up): (Vec3, Vec3, Vec3), px: f32, py: f32) -> Vec3 {
        let pitch_mm = self.pixel_pitch_um * 1e-3;
        let x_mm = (px - self.width_px as f32 * 0.5) * pitch_mm;
        let y_mm = (self.height_px as f32 * 0.5 - py) * pitch_mm;
        (forward * self.focal_mm + right * x_mm + up * y_mm).normalize()
    }

    /// [`Camera::ray_direction_in`] of the pixel positions `(px[k], py[k])`, per axis: the
    /// same operations per ray, in vector loops over the rays ([`scene_gen_trace::lanes`]). One ray at a
    /// time, each waited on its square root and division (perf: 8 % of a 4-spp image).
    #[must_use]
    #[allow(clippy::needless_range_loop)] // Lane loops: the form the vectoriser takes.
    #[inline(always)]
    pub(crate) fn ray_directions_in(&self, (forward, right, up): (Vec3, Vec3, Vec3), px: &Lanes, py: &Lanes) -> Lanes3 {
        let pitch_mm = self.pixel_pitch_um * 1e-3;
        let (half_width, half_height) = (self.width_px as f32 * 0.5, self.height_px as f32 * 0.5);
        let ahead = forward * self.focal_mm;
        let mut v = [[0.0f32; N]; 3];
        for axis in 0..3 {
            for k in 0..N {
                let x_mm = (px[k] - half_width) * pitch_mm;
                let y_mm = (half_height - py[k]) * pitch_mm;
                v[axis][k] = ahead[axis] + right[axis] * x_mm + up[axis] * y_mm;
            }
        }
        // glam's `normalize`: `v * (1 / sqrt((x x + y y) + z z))`.
        let mut length_recip = [0.0f32; N];
        for k in 0..N {
            length_recip[k] = 1.0 / (v[0][k] * v[0][k] + v[1][k] * v[1][k] + v[2][k] * v[2][k]).sqrt();
        }
        for axis in 0..3 {
            for k in 0..N {
                v[axis][k] *= length_recip[k];
            }
        }
        v
    }

    /// Fraction of the on-axis sensor illuminance reaching continuous pixel coordinates
    /// `(px, py)`: `cos^4` of the off-axis angle with [`Camera::vignetting`], else 1.
    #[must_use]
    pub fn relative_illumination(&self, px: f32, py: f32) -> f32 {
        self.relative_illumination_in(self.basis(), px, py)
    }

    /// [`Camera::relative_illumination`] with the [`Camera::basis`] computed once by the caller
    /// (a whole image: the basis costs two sines and cosines per call).
    #[must_use]
    #[inline]
    pub fn relative_illumination_in(&self, basis: (Vec3, Vec3, Vec3), px: f32, py: f32) -> f32 {
        if !self.vignetting {
            return 1.0;
        }
        let c = self.ray_direction_in(basis, px, py).dot(basis.0);
        (c * c) * (c * c)
    }
}

/// Illuminance on the sensor (lux) behind a lens imaging a scene of luminance `luminance_nit`:
/// the camera equation for an object far away compared with the focal length,
/// `E = pi L T / (4 N^2) * R`, with `T` the lens transmittance, `N` the f-number and `R` the
/// relative illumination (`cos^4` of the field angle for natural vignetting, 1 on axis); see
/// S. F. Ray, *Applied Photographic Optics*, 3rd ed., Focal Press 2002, on image illuminance.
/// The sensor model turns this into photons with the exposure time and pixel area.
#[must_use]
#[inline]
pub fn sensor_illuminance_lux(
    luminance_nit: f32,
    f_number: f32,
    transmittance: f32,
    relative_illumination: f32,
) -> f32 {
    std::f32::consts::PI * luminance_nit * transmittance * relative_illumination / (4.0 * f_number * f_number)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera {
            width_px: 640,
            height_px: 480,
            pixel_pitch_um: 5.0,
            focal_mm: 4.0,
            f_number: 2.0,
            position: Vec3::new(0.0, 0.0, 1.0),
            yaw_deg: 90.0,
            pitch_deg: 0.0,
            vignetting: true,
        }
    }

    #[test]
    fn projection_inverts_the_point_at_a_pixel_and_depth() {
        let c = Camera { pitch_deg: -17.0, yaw_deg: 33.0, ..camera() };
        for (px, py, depth) in [(0.5, 0.5, 0.3), (320.0, 240.0, 2.0), (639.5, 100.25, 7.5)] {
            let p = c.point_at(px, py, depth);
            let (u, v, z) = c.project(p).expect("in front");
            assert!((u - px).abs() < 1e-3 && (v - py).abs() < 1e-3 && (z - depth).abs() < 1e-4, "{u} {v} {z}");
            // The pixel's ray runs through the point.
            let along = (p - c.position).normalize();
            assert!(along.dot(c.ray_direction(px, py)) > 1.0 - 1e-6);
        }
        assert!(c.project(c.position - c.basis().0).is_none(), "behind the camera");
    }

    #[test]
    fn fov_follows_sensor_and_focal_length() {
        let c = camera();
        // 3.2 mm wide sensor behind a 4 mm lens: 2 atan(0.4) = 43.6 deg.
        assert!((c.hfov_deg() - 43.602).abs() < 0.01, "{}", c.hfov_deg());
        assert!((c.vfov_deg() - 2.0 * (1.2f32 / 4.0).atan().to_degrees()).abs() < 1e-4);
    }

    #[test]
    fn yaw_pitch_and_image_axes() {
        let c = camera();
        let centre = c.ray_direction(320.0, 240.0);
        assert!((centre - Vec3::Y).length() < 1e-6, "yaw 90 looks along +Y, got {centre}");
        // Looking along +Y with Z up, image right is +X.
        assert!(c.ray_direction(640.0, 240.0).x > 0.0, "image x runs to the right");
        assert!(c.ray_direction(320.0, 0.0).z > 0.0, "image y runs down, so row 0 looks up");
        let up = Camera { pitch_deg: 30.0, yaw_deg: 0.0, ..c };
        let d = up.ray_direction(320.0, 240.0);
        assert!((d - Vec3::new(30f32.to_radians().cos(), 0.0, 30f32.to_radians().sin())).length() < 1e-6);
        assert_eq!(c.relative_illumination(320.0, 240.0), 1.0);
        assert!(c.relative_illumination(0.0, 0.0) < 0.9);
        assert!(Camera { pitch_deg: 95.0, ..c }.validate().is_err());
        assert!(c.validate().is_ok());
    }

    /// Whether the ray from `origin` along `dir` meets the box `[min, max]` (slab test, f64).
    fn ray_meets_box(origin: Vec3, dir: Vec3, min: Vec3, max: Vec3) -> bool {
        let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for k in 0..3 {
            let (lo, hi) = (f64::from(min[k]), f64::from(max[k]));
            if d[k] == 0.0 {
                if o[k] < lo || o[k] > hi {
                    return false;
                }
                continue;
            }
            let (a, b) = ((lo - o[k]) / d[k], (hi - o[k]) / d[k]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        t0 <= t1
    }

    #[test]
    fn box_pixels_in_front_behind_and_across_the_pinhole() {
        let c = camera(); // at (0, 0, 1) looking along +Y
        // A 0.2 m box 2 m ahead, on the axis: around the image centre.
        let r = c.box_pixels(Vec3::new(-0.1, 1.9, 0.9), Vec3::new(0.1, 2.1, 1.1)).unwrap();
        assert!(r.x0 < 320 && r.x0 + r.width > 320 && r.y0 < 240 && r.y0 + r.height > 240, "{r:?}");
        assert!(r.width < 200 && r.height < 200, "{r:?}");
        // Behind the camera: no pixel.
        assert_eq!(c.box_pixels(Vec3::new(-0.1, -2.1, 0.9), Vec3::new(0.1, -1.9, 1.1)), None);
        // Far to the side, out of the field of view: no pixel.
        assert_eq!(c.box_pixels(Vec3::new(10.0, 0.9, 0.9), Vec3::new(10.2, 1.1, 1.1)), None);
        // A wide floor strip from behind the camera to 10 m ahead (the floor is in view from
        // 3.3 m): the bottom rows, full width.
        let r = c.box_pixels(Vec3::new(-50.0, -1.0, 0.0), Vec3::new(50.0, 10.0, 0.02)).unwrap();
        assert_eq!((r.x0, r.width, r.y0 + r.height), (0, 640, 480), "{r:?}");
        assert!(r.y0 > 240, "{r:?}");
    }

    /// `ray_directions_in` gives each pixel position the direction `ray_direction_in` gives
    /// it alone, bit for bit.
    #[test]
    fn ray_directions_of_a_packet_are_those_of_each_position() {
        let camera = crate::test_util::camera(1936, 1216, Vec3::new(1.0, 2.0, 1.2), 37.0, -12.0);
        let basis = camera.basis();
        let px: [f32; 64] = std::array::from_fn(|k| (k as f32 * 30.7) % 1936.0 + 0.25);
        let py: [f32; 64] = std::array::from_fn(|k| (k as f32 * 19.1) % 1216.0 + 0.75);
        let packet = camera.ray_directions_in(basis, &px, &py);
        for k in 0..64 {
            let alone = camera.ray_direction_in(basis, px[k], py[k]);
            let lane = scene_gen_trace::lanes::lane3(&packet, k);
            assert_eq!(lane.to_array().map(f32::to_bits), alone.to_array().map(f32::to_bits), "ray {k}");
        }
    }

    proptest::proptest! {
        /// Every pixel whose centre ray meets a box lies in the box's `box_pixels`, for boxes in
        /// front, behind, around and across the camera, at any pose.
        #[test]
        fn box_pixels_hold_every_pixel_whose_ray_meets_the_box(
            centre in proptest::array::uniform3(-4.0f32..4.0),
            size in proptest::array::uniform3(0.001f32..3.0),
            yaw_deg in -180.0f32..180.0,
            pitch_deg in -80.0f32..80.0,
            focal_mm in 1.0f32..12.0,
        ) {
            let c = Camera { width_px: 40, height_px: 30, pixel_pitch_um: 60.0, focal_mm, yaw_deg, pitch_deg, ..camera() };
            let (min, max) = (Vec3::from(centre), Vec3::from(centre) + Vec3::from(size));
            let rect = c.box_pixels(min, max);
            for y in 0..c.height_px {
                for x in 0..c.width_px {
                    let dir = c.ray_direction(x as f32 + 0.5, y as f32 + 0.5);
                    if ray_meets_box(c.position, dir, min, max) {
                        let r = rect.unwrap_or_else(|| panic!("pixel ({x}, {y}) meets the box, no rect"));
                        proptest::prop_assert!(
                            x >= r.x0 && x < r.x0 + r.width && y >= r.y0 && y < r.y0 + r.height,
                            "pixel ({}, {}) outside {:?}", x, y, r
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn camera_equation() {
        // L = 100 nit at f/2 with a perfect lens: pi * 100 / 16.
        let e = sensor_illuminance_lux(100.0, 2.0, 1.0, 1.0);
        assert!((e - 19.634_954).abs() < 1e-4);
        assert!((sensor_illuminance_lux(100.0, 4.0, 0.9, 0.5) - e * 0.9 * 0.5 / 4.0).abs() < 1e-5);
    }
}
