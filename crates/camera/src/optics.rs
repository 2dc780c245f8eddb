//! Lens and motion effects on the sensor-plane irradiance: diffraction, defocus and motion
//! blur, each switchable in the [`CameraSpec`].
//!
//! They act on the per-pixel sensor-plane signal **after** the camera equation (and cos^4
//! vignetting) and **before** photon noise, see [`crate::radiometry::capture_frame`]. The
//! buffer they see is the mean photon count per pixel, which is the irradiance times a
//! constant (exposure x pixel area x photons per lux-second), so blurring it is blurring the
//! irradiance. Each effect *moves* light: every one is written as a scatter in which each
//! source pixel hands out exactly its own value with weights that sum to one, so the total is
//! conserved to float rounding. Light that would leave the frame is mirrored back in at the
//! border (half-sample symmetric reflection): that stands in for the light the unseen scene
//! beyond the border would send in, assuming it looks like its mirror image, and it keeps the
//! image mean exact.
//!
//! Order: defocus, then motion blur, then diffraction. Defocus and motion blur depend on each
//! scene point's depth and act per source pixel; diffraction is the same everywhere and is
//! applied last to the result.
//!
//! # Diffraction (`diffraction`, default on)
//!
//! A circular aperture at f-number `N` images a point as the Airy pattern, whose first dark
//! ring has radius `1.22 lambda N` in the image plane (M. Born and E. Wolf, *Principles of
//! Optics*, 7th ed., sec. 8.5.2). We use its Gaussian approximation, sigma = 0.42 lambda N
//! (B. Zhang, J. Zerubia and J.-C. Olivo-Marin, "Gaussian approximations of fluorescence
//! microscope point-spread function models", Applied Optics 46(10), 2007: sigma = 0.21 lambda /
//! NA, and NA = 1 / (2N) for an object at a distance), at the radiometry's reference wavelength
//! lambda = 550 nm, converted to pixels by the simulated pixel pitch (binned pixels included).
//! The Gaussian matches the Airy core's width within a few per cent; it leaves out the rings
//! (about 16 % of the energy, spread far and thin). The kernel is the Gaussian integrated over
//! each pixel (separable, `erf` differences), cut at 4 sigma and renormalised. When sigma is
//! below [`DIFFRACTION_SKIP_SIGMA_PX`] (under 0.1 % of the light would leave the pixel in
//! either axis) the effect is the identity: at f/2 that is every pixel above 3.1 um, so on the
//! catalog's sensors diffraction only shows for small pixels or slow lenses.
//!
//! Default **on**: it is physical, it costs nothing when sub-pixel, and it is what makes a slow
//! lens on small pixels soft, a real trade-off of the design space.
//!
//! # Defocus (`defocus`, default off; `focus_m`)
//!
//! A thin lens of focal length `f` and aperture diameter `A = f / N`, focused at `Z_f`, images a
//! point at depth `Z` as a disc (the circle of confusion) of diameter
//! `c = A f |Z - Z_f| / (Z (Z_f - f))` on the sensor (E. Hecht, *Optics*, 5th ed., sec. 5.7; the
//! thin-lens equation applied to both distances). `Z` is the depth buffer's z-depth (distance
//! along the optical axis; no hit means infinity, `c = A f / (Z_f - f)`). Each source pixel
//! spreads its light uniformly (a pillbox, the geometric-optics PSF) over the disc of diameter
//! `c` / pixel pitch centred on itself, with area-weighted coverage of the border pixels
//! (sub-rows for small discs), so the blur varies per pixel. A disc under
//! [`DEFOCUS_SKIP_DIAMETER_PX`] keeps its light; one is capped at [`DEFOCUS_MAX_DIAMETER_PX`].
//! `focus_m` defaults to the hyperfocal distance `H = f^2 / (N c_max) + f` with
//! `c_max` = [`HYPERFOCAL_COC_PIXELS`] of the sensor's *real* (unbinned) pixels: everything from
//! `H / 2` to infinity is then sharp within two pixels, which is how fixed-focus robot lenses
//! are set, and binning does not move the focus.
//!
//! Approximation: a scatter from the pinhole image, not a layered or occlusion-aware one: a
//! blurred foreground edge does not uncover the background behind it, and the background does
//! not bleed behind a sharp foreground. Depth is sampled at pixel centres.
//!
//! Default **off**: the reference system (TaCOS) renders with ideal pinhole optics; with
//! defocus on, a long lens at the default hyperfocal focus is soft indoors (a 20 mm f/2 lens
//! focused at 17 m blurs a point at 2 m over some 15 pixels of 5.86 um), which changes which
//! designs win, so it is the user's choice to model it and set `focus_m`.
//!
//! # Motion blur (`motion_blur`, default off; `motion_speed_m_s`)
//!
//! The camera translates by `v t` during the exposure `t` (the frame's pose is the middle of
//! the exposure; rotation is left out: the walk turns at the poses). A static point at
//! camera-frame position `P` (from the pixel's ray and its depth) projects, at exposure
//! fraction `s` in [-1/2, 1/2], to `pi(P - s v t)`, the pinhole projection; for forward motion
//! that is the radial flow from the focus of expansion, of length about
//! `|v t| r / Z` pixels at `r` pixels from it (exact projection is used, not that
//! linearisation). Each source pixel is split into `K` equal parts placed at the midpoints of
//! `K` equal steps of `s` (one per pixel of path and one more, at most [`MOTION_MAX_SAMPLES`]) and
//! splatted bilinearly: deterministic, and exact in energy. Points with no depth (no hit, at
//! infinity) do not move under translation. The velocity comes from the caller
//! ([`OpticsInput::velocity_m_s`], world frame); [`agent_velocity`] gives the walk's, at the
//! spec's `motion_speed_m_s` when set.
//!
//! Default **off**: TaCOS renders still frames, and with 1/30 s at 0.5 m/s the camera moves
//! 17 mm, a few pixels at the image edge for near objects; turn it on to weigh exposure time
//! against noise.

use glam::Vec3;

use crate::camera_spec::{CameraSpec, ResolvedCamera};
use scene_gen_render::Camera;

/// The radiometry's reference wavelength, nm (the catalog's quantum efficiencies are quoted
/// near 550 nm; see [`crate::radiometry::PHOTONS_PER_LUX_S_M2`]).
pub const REFERENCE_WAVELENGTH_NM: f64 = 550.0;

/// First zero of the Airy pattern, in units of `lambda N` (Born and Wolf, sec. 8.5.2).
pub const AIRY_FIRST_ZERO_PER_LAMBDA_N: f64 = 1.22;

/// Gaussian sigma of the Airy core, in units of `lambda N` (Zhang et al., Applied Optics 2007).
pub const AIRY_GAUSSIAN_SIGMA_PER_LAMBDA_N: f64 = 0.42;

/// Diffraction is skipped below this sigma in pixels: the pixel-integrated Gaussian then keeps
/// over 99.9 % of a pixel's light in it along each axis (2 Phi(-0.5 / 0.15) = 8.6e-4).
pub const DIFFRACTION_SKIP_SIGMA_PX: f64 = 0.15;

/// Circle of confusion below which a pixel keeps its light, pixels (half a pixel: below the
/// pixel's own box blur).
pub const DEFOCUS_SKIP_DIAMETER_PX: f64 = 0.5;

/// Largest circle of confusion simulated, pixels (a cost bound; such a point is a blur anyway).
pub const DEFOCUS_MAX_DIAMETER_PX: f64 = 256.0;

/// Circle of confusion, in real sensor pixels, that defines the default (hyperfocal) focus.
pub const HYPERFOCAL_COC_PIXELS: f64 = 2.0;

/// Most samples along one pixel's motion path.
pub const MOTION_MAX_SAMPLES: usize = 256;

/// The depth-dependent inputs of one frame.
#[derive(Clone, Copy, Debug)]
pub struct OpticsInput<'a> {
    /// z-depth per pixel, metres, row-major as the frame (`f32::INFINITY` for no hit); see
    /// [`scene_gen_render::Frame::depth_m`].
    pub depth_m: &'a [f32],
    /// Camera velocity in the world frame during the exposure, m/s (non-finite: no motion).
    pub velocity_m_s: Vec3,
}

/// The camera's velocity on the walk: along the direction of travel `heading_deg` (the pose's
/// yaw, not the camera's, which adds the spec's yaw offset), at the spec's `motion_speed_m_s`
/// when set, else at `walk_speed_m_s`.
#[must_use]
pub fn agent_velocity(spec: &CameraSpec, heading_deg: f32, walk_speed_m_s: f32) -> Vec3 {
    let speed = spec.motion_speed_m_s.unwrap_or(walk_speed_m_s);
    let (s, c) = heading_deg.to_radians().sin_cos();
    Vec3::new(c, s, 0.0) * speed
}

/// Radius of the Airy pattern's first dark ring, micrometres, at 550 nm.
#[must_use]
pub fn airy_first_zero_um(f_number: f64) -> f64 {
    AIRY_FIRST_ZERO_PER_LAMBDA_N * REFERENCE_WAVELENGTH_NM * 1e-3 * f_number
}

/// Gaussian sigma of the diffraction PSF, micrometres, at 550 nm.
#[must_use]
pub fn diffraction_sigma_um(f_number: f64) -> f64 {
    AIRY_GAUSSIAN_SIGMA_PER_LAMBDA_N * REFERENCE_WAVELENGTH_NM * 1e-3 * f_number
}

/// Hyperfocal distance `f^2 / (N c) + f`, metres, for a circle of confusion `coc_um`.
#[must_use]
pub fn hyperfocal_m(focal_mm: f64, f_number: f64, coc_um: f64) -> f64 {
    let f = focal_mm * 1e-3;
    f * f / (f_number * coc_um * 1e-6) + f
}

/// The focus distance in use: the spec's `focus_m`, else the hyperfocal distance for
/// [`HYPERFOCAL_COC_PIXELS`] real pixels.
#[must_use]
pub fn focus_distance_m(resolved: &ResolvedCamera) -> f64 {
    let spec = &resolved.spec;
    spec.focus_m.map_or_else(
        || {
            hyperfocal_m(
                f64::from(spec.focal_mm),
                f64::from(spec.f_number),
                HYPERFOCAL_COC_PIXELS * resolved.sensor.pixel_pitch_um,
            )
        },
        f64::from,
    )
}

/// Thin-lens circle of confusion on the sensor, metres, of a point at depth `z_m` (infinite
/// or non-positive: at infinity) for a lens of focal length `focal_m` at f-number `f_number`
/// focused at `focus_m`. Depths inside 1.5 focal lengths are taken at 1.5 f (no real image
/// nearer; such depths do not occur in a house).
#[must_use]
pub fn coc_diameter_m(focal_m: f64, f_number: f64, focus_m: f64, z_m: f64) -> f64 {
    let a = focal_m / f_number;
    if !(z_m.is_finite() && z_m > 0.0) {
        return a * focal_m / (focus_m - focal_m);
    }
    let z = z_m.max(1.5 * focal_m);
    a * focal_m * (z - focus_m).abs() / (z * (focus_m - focal_m))
}

/// Standard normal cumulative distribution, via erf (Abramowitz and Stegun 7.1.26, absolute
/// error under 1.5e-7).
fn phi(x: f64) -> f64 {
    let z = x / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z.abs());
    let poly =
        t * (0.254_829_592 + t * (-0.284_496_736 + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    0.5 * (1.0 + if z >= 0.0 { erf } else { -erf })
}

/// Half-sample symmetric reflection of index `i` into `0..n`.
fn reflect(i: i64, n: usize) -> usize {
    if (0..n as i64).contains(&i) {
        return i as usize;
    }
    let n = n as i64;
    let m = i.rem_euclid(2 * n);
    (if m < n { m } else { 2 * n - 1 - m }) as usize
}

/// The pixel-integrated Gaussian of `sigma_px`, taps `-r..=r` (r = ceil(4 sigma)), summing to 1.
#[must_use]
pub fn gaussian_kernel(sigma_px: f64) -> Vec<f64> {
    let r = (4.0 * sigma_px).ceil().max(1.0) as i64;
    let mut k: Vec<f64> =
        (-r..=r).map(|i| phi((i as f64 + 0.5) / sigma_px) - phi((i as f64 - 0.5) / sigma_px)).collect();
    let sum: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    k
}

/// Separable Gaussian blur of a `w x h` image in place, as a scatter with mirrored borders (the
/// sum is conserved); sigma in pixels, pixel-integrated. Sigma below
/// [`DIFFRACTION_SKIP_SIGMA_PX`] leaves the image unchanged.
///
/// # Panics
/// If `image.len() != w * h`.
pub fn gaussian_blur(image: &mut [f32], w: usize, h: usize, sigma_px: f64) {
    assert_eq!(image.len(), w * h, "image must be w x h");
    if !(sigma_px.is_finite() && sigma_px >= DIFFRACTION_SKIP_SIGMA_PX) {
        return;
    }
    let k = gaussian_kernel(sigma_px);
    let r = (k.len() / 2) as i64;
    let mut row = vec![0f64; w];
    for y in 0..h {
        row.iter_mut().for_each(|v| *v = 0.0);
        for x in 0..w {
            let v = f64::from(image[y * w + x]);
            if v == 0.0 {
                continue;
            }
            for (j, &kw) in k.iter().enumerate() {
                row[reflect(x as i64 + j as i64 - r, w)] += v * kw;
            }
        }
        for x in 0..w {
            image[y * w + x] = row[x] as f32;
        }
    }
    let mut col = vec![0f64; h];
    for x in 0..w {
        col.iter_mut().for_each(|v| *v = 0.0);
        for y in 0..h {
            let v = f64::from(image[y * w + x]);
            if v == 0.0 {
                continue;
            }
            for (j, &kw) in k.iter().enumerate() {
                col[reflect(y as i64 + j as i64 - r, h)] += v * kw;
            }
        }
        for y in 0..h {
            image[y * w + x] = col[y] as f32;
        }
    }
}

/// Accumulates horizontal spans: full-pixel runs in a difference buffer (one add and one
/// subtract per run, whatever its length), partial end pixels directly.
struct SpanAccumulator {
    w: usize,
    h: usize,
    diff: Vec<f64>,
    direct: Vec<f64>,
}

impl SpanAccumulator {
    fn new(w: usize, h: usize) -> SpanAccumulator {
        SpanAccumulator { w, h, diff: vec![0.0; (w + 1) * h], direct: vec![0.0; w * h] }
    }

    /// Adds `density` per unit length over `[a, b)` (continuous x, pixel j covers [j, j + 1)) in
    /// row `y` (any integer; mirrored into the image).
    fn add_span(&mut self, y: i64, a: f64, b: f64, density: f64) {
        let row = reflect(y, self.h);
        let (j0, j1) = (a.floor() as i64, b.ceil() as i64 - 1);
        if j0 < 0 || j1 >= self.w as i64 {
            // Near a border: pixel by pixel, mirrored.
            for j in j0..=j1 {
                let cover = b.min(j as f64 + 1.0) - a.max(j as f64);
                if cover > 0.0 {
                    self.direct[row * self.w + reflect(j, self.w)] += density * cover;
                }
            }
            return;
        }
        let (j0u, j1u) = (j0 as usize, j1 as usize);
        if j0 == j1 {
            self.direct[row * self.w + j0u] += density * (b - a);
            return;
        }
        self.direct[row * self.w + j0u] += density * (j0 as f64 + 1.0 - a);
        self.direct[row * self.w + j1u] += density * (b - j1 as f64);
        if j1u > j0u + 1 {
            self.diff[row * (self.w + 1) + j0u + 1] += density;
            self.diff[row * (self.w + 1) + j1u] -= density;
        }
    }

    fn finish(self, image: &mut [f32]) {
        for y in 0..self.h {
            let mut run = 0.0;
            for x in 0..self.w {
                run += self.diff[y * (self.w + 1) + x];
                image[y * self.w + x] = (run + self.direct[y * self.w + x]) as f32;
            }
        }
    }
}

/// The horizontal spans of a disc of radius `r` pixels centred on a pixel centre, as
/// `(row offset, half width, weight)`, and the disc's area: each pixel row is cut into bands
/// (several for small discs, for a round shape) and each band gets the disc's exact area in it
/// as one span of the band's mean width.
fn disc_chords(r: f64, chords: &mut Vec<(i64, f64, f64)>) -> f64 {
    let sub: u32 = if r < 1.5 {
        4
    } else if r < 4.0 {
        2
    } else {
        1
    };
    chords.clear();
    let rows = r.ceil() as i64;
    // Area under the half-chord sqrt(r^2 - v^2) from 0 to v (clamped to the disc).
    let half_area = |v: f64| {
        let v = v.clamp(-r, r);
        0.5 * (v * (r * r - v * v).max(0.0).sqrt() + r * r * (v / r).asin())
    };
    let band = 1.0 / f64::from(sub);
    let mut area = 0.0;
    let mut below = half_area(-(rows as f64) - 0.5);
    for dy in -rows..=rows {
        for s in 0..sub {
            let above = half_area(dy as f64 - 0.5 + f64::from(s + 1) * band);
            let a = 2.0 * (above - below);
            below = above;
            if a > 0.0 {
                chords.push((dy, 0.5 * a / band, band));
                area += a;
            }
        }
    }
    area
}

/// Spatially varying pillbox (uniform disc) blur of a `w x h` image in place: each source pixel
/// spreads its value evenly over the disc of diameter `diameter_px[i]` centred on it, with
/// area-weighted coverage at the disc's edge (each pixel row gets the disc's exact area in it,
/// as a span of the row's mean chord), borders mirrored. The sum is conserved.
/// Diameters below [`DEFOCUS_SKIP_DIAMETER_PX`] keep the light in the pixel.
///
/// # Panics
/// If the buffers are not `w * h` long.
pub fn pillbox_blur(image: &mut [f32], w: usize, h: usize, diameter_px: &[f32]) {
    assert_eq!(image.len(), w * h, "image must be w x h");
    assert_eq!(diameter_px.len(), w * h, "diameters must be w x h");
    let mut acc = SpanAccumulator::new(w, h);
    // The disc of the previous pixel: depth is smooth, so neighbours mostly share it.
    let mut chords: Vec<(i64, f64, f64)> = Vec::new();
    let (mut chords_r, mut area) = (f64::NAN, 0.0);
    for (i, (&v, &d)) in image.iter().zip(diameter_px).enumerate() {
        let (x, y) = ((i % w) as f64, (i / w) as i64);
        let d = f64::from(d);
        if !(d.is_finite() && d >= DEFOCUS_SKIP_DIAMETER_PX) {
            acc.direct[i] += f64::from(v);
            continue;
        }
        if v == 0.0 {
            continue;
        }
        // Radius quantised to 1/256 px (far below anything visible) so discs can be reused.
        let r = (0.5 * d.min(DEFOCUS_MAX_DIAMETER_PX) * 256.0).round() / 256.0;
        if r != chords_r {
            area = disc_chords(r, &mut chords);
            chords_r = r;
        }
        let scale = f64::from(v) / area;
        for &(dy, half, weight) in &chords {
            acc.add_span(y + dy, x + 0.5 - half, x + 0.5 + half, scale * weight);
        }
    }
    acc.finish(image);
}

/// Adds `v` at continuous pixel-centre position `(px, py)` (pixel (x, y)'s centre is at
/// (x, y)) with bilinear weights, borders mirrored.
fn splat(out: &mut [f64], w: usize, h: usize, px: f64, py: f64, v: f64) {
    let (x0, y0) = (px.floor(), py.floor());
    let (tx, ty) = (px - x0, py - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    if x0 >= 0 && y0 >= 0 && x0 + 1 < w as i64 && y0 + 1 < h as i64 {
        let i = y0 as usize * w + x0 as usize;
        out[i] += v * (1.0 - tx) * (1.0 - ty);
        out[i + 1] += v * tx * (1.0 - ty);
        out[i + w] += v * (1.0 - tx) * ty;
        out[i + w + 1] += v * tx * ty;
        return;
    }
    for (dy, wy) in [(0, 1.0 - ty), (1, ty)] {
        if wy == 0.0 {
            continue;
        }
        let row = reflect(y0 + dy, h) * w;
        for (dx, wx) in [(0, 1.0 - tx), (1, tx)] {
            if wx != 0.0 {
                out[row + reflect(x0 + dx, w)] += v * wx * wy;
            }
        }
    }
}

/// Motion blur of a `w x h` image in place for a camera translating by `translation_cam`
/// (metres over the whole exposure, camera frame: right, up, forward) with focal length
/// `focal_px` pixels and the principal point at the image centre; `depth_m` is the z-depth
/// per pixel. Each pixel's light is spread along its image path (see the module doc). The sum
/// is conserved.
///
/// # Panics
/// If the buffers are not `w * h` long.
pub fn motion_blur(image: &mut [f32], w: usize, h: usize, focal_px: f64, depth_m: &[f32], translation_cam: [f64; 3]) {
    assert_eq!(image.len(), w * h, "image must be w x h");
    assert_eq!(depth_m.len(), w * h, "depth must be w x h");
    let [tr, tu, tf] = translation_cam;
    if !(tr.is_finite() && tu.is_finite() && tf.is_finite()) || (tr == 0.0 && tu == 0.0 && tf == 0.0) {
        return;
    }
    let mut out = vec![0f64; w * h];
    let (cx, cy) = (w as f64 * 0.5, h as f64 * 0.5);
    for (i, (&v, &z)) in image.iter().zip(depth_m).enumerate() {
        let v = f64::from(v);
        if v == 0.0 {
            continue;
        }
        let z = f64::from(z);
        if !(z.is_finite() && z > 0.0) {
            out[i] += v;
            continue;
        }
        let (x, y) = ((i % w) as f64, (i / w) as f64);
        // Camera-frame point through the pixel centre: right, up, forward.
        let (u, vv) = (x + 0.5 - cx, cy - (y + 0.5));
        let p = [u * z / focal_px, vv * z / focal_px, z];
        // Image position (pixel-centre coordinates) at exposure fraction s.
        let at = |s: f64| -> Option<(f64, f64)> {
            let q = [p[0] - s * tr, p[1] - s * tu, p[2] - s * tf];
            (q[2] > 1e-3 * z).then(|| (focal_px * q[0] / q[2] + cx - 0.5, cy - focal_px * q[1] / q[2] - 0.5))
        };
        let (Some(a), Some(b)) = (at(-0.5), at(0.5)) else {
            // The point passes behind the camera within the exposure: not modelled.
            out[i] += v;
            continue;
        };
        let len = (b.0 - a.0).hypot(b.1 - a.1);
        if len < 1e-3 {
            out[i] += v;
            continue;
        }
        let k = (len.ceil() as usize + 1).min(MOTION_MAX_SAMPLES);
        let part = v / k as f64;
        for j in 0..k {
            let s = -0.5 + (j as f64 + 0.5) / k as f64;
            let (px, py) = at(s).unwrap_or((x, y));
            splat(&mut out, w, h, px, py, part);
        }
    }
    for (o, v) in image.iter_mut().zip(out) {
        *o = v as f32;
    }
}

/// Which effects a spec turns on for one frame, with their parameters in pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct OpticsPlan {
    /// Diffraction Gaussian sigma, pixels; `None` when off or below the skip threshold.
    pub diffraction_sigma_px: Option<f64>,
    /// Focus distance, metres, when defocus is on (and depth given).
    pub focus_m: Option<f64>,
    /// Camera translation over the exposure, camera frame (right, up, forward), metres, when
    /// motion blur is on (and depth given) and the camera moves.
    pub translation_cam_m: Option<[f64; 3]>,
}

impl OpticsPlan {
    /// The plan of `resolved` seen as `camera` with the frame inputs `input` (effects that
    /// need depth are off without it).
    #[must_use]
    pub fn new(resolved: &ResolvedCamera, camera: &Camera, input: Option<&OpticsInput<'_>>) -> OpticsPlan {
        let spec = &resolved.spec;
        let sigma = diffraction_sigma_um(f64::from(camera.f_number)) / f64::from(camera.pixel_pitch_um);
        let diffraction_sigma_px = (spec.diffraction && sigma >= DIFFRACTION_SKIP_SIGMA_PX).then_some(sigma);
        let focus_m = (spec.defocus && input.is_some()).then(|| focus_distance_m(resolved));
        let translation_cam_m = input.filter(|_| spec.motion_blur).and_then(|inp| {
            let d = inp.velocity_m_s * spec.exposure_s as f32;
            if !d.is_finite() || d == Vec3::ZERO {
                return None;
            }
            let (forward, right, up) = camera.basis();
            Some([f64::from(d.dot(right)), f64::from(d.dot(up)), f64::from(d.dot(forward))])
        });
        OpticsPlan { diffraction_sigma_px, focus_m, translation_cam_m }
    }

    /// True when the plan changes nothing.
    #[must_use]
    pub fn is_identity(&self) -> bool {
        self.diffraction_sigma_px.is_none() && self.focus_m.is_none() && self.translation_cam_m.is_none()
    }
}

/// Applies the spec's optics to `image` (sensor-plane signal, one value per pixel of `camera`,
/// linear in irradiance): defocus and motion blur when `input` is given and they are on, then
/// diffraction when on.
///
/// # Panics
/// If `image` or `input.depth_m` is not the camera's pixel count.
pub fn apply(resolved: &ResolvedCamera, camera: &Camera, image: &mut [f32], input: Option<&OpticsInput<'_>>) {
    let plan = OpticsPlan::new(resolved, camera, input);
    apply_plan(&plan, camera, image, input);
}

/// [`apply`] with the plan made once (several channels of one frame).
///
/// # Panics
/// As [`apply`].
pub fn apply_plan(plan: &OpticsPlan, camera: &Camera, image: &mut [f32], input: Option<&OpticsInput<'_>>) {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    assert_eq!(image.len(), w * h, "image must have one value per pixel");
    let pitch_m = f64::from(camera.pixel_pitch_um) * 1e-6;
    let focal_m = f64::from(camera.focal_mm) * 1e-3;
    if let (Some(focus), Some(inp)) = (plan.focus_m, input) {
        assert_eq!(inp.depth_m.len(), w * h, "depth must have one value per pixel");
        let n = f64::from(camera.f_number);
        let diam: Vec<f32> =
            inp.depth_m.iter().map(|&z| (coc_diameter_m(focal_m, n, focus, f64::from(z)) / pitch_m) as f32).collect();
        pillbox_blur(image, w, h, &diam);
    }
    if let (Some(t), Some(inp)) = (plan.translation_cam_m, input) {
        assert_eq!(inp.depth_m.len(), w * h, "depth must have one value per pixel");
        motion_blur(image, w, h, focal_m / pitch_m, inp.depth_m, t);
    }
    if let Some(sigma) = plan.diffraction_sigma_px {
        gaussian_blur(image, w, h, sigma);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phi_matches_known_values() {
        assert!((phi(0.0) - 0.5).abs() < 1e-7);
        assert!((phi(1.0) - 0.841_344_746).abs() < 2e-7);
        assert!((phi(-1.959_964) - 0.025).abs() < 2e-7);
    }

    #[test]
    fn reflect_is_half_sample_symmetric() {
        let got: Vec<usize> = (-3..8).map(|i| reflect(i, 4)).collect();
        assert_eq!(got, vec![2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0]);
    }

    #[test]
    fn kernel_variance_is_sigma_squared_plus_pixel_box() {
        for sigma in [0.5, 1.0, 2.5] {
            let k = gaussian_kernel(sigma);
            let r = (k.len() / 2) as f64;
            let var: f64 = k.iter().enumerate().map(|(i, w)| w * (i as f64 - r).powi(2)).sum();
            // Sheppard's correction (+1/12) is asymptotic: within 3 % at sigma = 0.5.
            assert!((var / (sigma * sigma + 1.0 / 12.0) - 1.0).abs() < 0.03, "sigma {sigma}: var {var}");
            assert!((k.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn thin_lens_coc_by_hand() {
        // f = 4 mm, f/2 (A = 2 mm), focused at 1 m, point at 0.5 m:
        // c = 2e-3 * 4e-3 * 0.5 / (0.5 * 0.996) = 8.032 um.
        let c = coc_diameter_m(4e-3, 2.0, 1.0, 0.5);
        assert!((c / 8.032e-6 - 1.0).abs() < 1e-3, "{c}");
        assert_eq!(coc_diameter_m(4e-3, 2.0, 1.0, 1.0), 0.0);
        let inf = coc_diameter_m(4e-3, 2.0, 1.0, f64::INFINITY);
        assert!((inf - 2e-3 * 4e-3 / 0.996).abs() < 1e-12);
        // Hyperfocal: a point at infinity gets exactly the CoC the distance was made for.
        let hf = hyperfocal_m(4.0, 2.0, 11.72);
        assert!((coc_diameter_m(4e-3, 2.0, hf, f64::INFINITY) / 11.72e-6 - 1.0).abs() < 1e-9);
        assert!((coc_diameter_m(4e-3, 2.0, hf, hf / 2.0) / 11.72e-6 - 1.0).abs() < 0.01);
    }

    /// Bessel J1 by its integral (1/pi) int_0^pi cos(t - x sin t) dt (midpoint rule).
    fn bessel_j1(x: f64) -> f64 {
        let n = 2000;
        let h = std::f64::consts::PI / f64::from(n);
        (0..n).map(|i| (f64::from(i) + 0.5) * h).map(|t| (t - x * t.sin()).cos()).sum::<f64>() * h
            / std::f64::consts::PI
    }

    /// The Gaussian's half-maximum radius is within 5 % of the Airy pattern's (the Airy core is
    /// what the approximation stands for), and the Airy intensity vanishes at 1.22 lambda N.
    #[test]
    fn gaussian_matches_the_airy_core() {
        // Airy in units of lambda N: I(r) = (2 J1(pi r) / (pi r))^2.
        let airy = |r: f64| {
            let x = std::f64::consts::PI * r;
            (2.0 * bessel_j1(x) / x).powi(2)
        };
        let (mut lo, mut hi) = (0.1, 1.0);
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            if airy(mid) > 0.5 { lo = mid } else { hi = mid }
        }
        let gauss_half = AIRY_GAUSSIAN_SIGMA_PER_LAMBDA_N * (2.0 * std::f64::consts::LN_2).sqrt();
        assert!((gauss_half / lo - 1.0).abs() < 0.05, "half-max radius: Gaussian {gauss_half}, Airy {lo}");
        assert!(airy(AIRY_FIRST_ZERO_PER_LAMBDA_N) < 1e-4);
    }

    #[test]
    fn airy_zero_and_sigma_scale_with_n() {
        assert!((airy_first_zero_um(2.0) - 1.342).abs() < 1e-9);
        assert!((diffraction_sigma_um(4.0) / diffraction_sigma_um(2.0) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn pillbox_conserves_with_borders() {
        let (w, h) = (23, 17);
        let img: Vec<f32> = (0..w * h).map(|i| ((i * 37) % 11) as f32).collect();
        let diam: Vec<f32> = (0..w * h).map(|i| ((i * 13) % 29) as f32 * 0.7).collect();
        let mut out = img.clone();
        pillbox_blur(&mut out, w, h, &diam);
        let (a, b) = (img.iter().map(|&v| f64::from(v)).sum::<f64>(), out.iter().map(|&v| f64::from(v)).sum::<f64>());
        assert!((a - b).abs() < 1e-6 * a, "{a} vs {b}");
        assert_ne!(img, out);
        assert!(out.iter().all(|&v| v >= -1e-4));
    }
}
