//! The camera that looks at a house: what a candidate is, and how scene radiance becomes the
//! digital numbers and 8-bit images a robot's software sees.
//!
//! ```text
//! radiance (render) ─► optics ─► radiometry ─► sensor noise ─► DN ─► isp ─► 8-bit image
//!                      blur,      nit → lux →   (EMVA 1288 or
//!                      vignetting photons → e-   affine model)
//! ```
//!
//! * [`camera_spec`]: camera candidates (sensor, lens, mounting, exposure) from TOML or the
//!   inline `SENSOR,key=value` form, resolved against the [`sensor`] catalog.
//! * [`optics`]: diffraction, defocus and motion blur of the sensor-plane irradiance.
//! * [`radiometry`]: scene luminance to sensor illuminance, photons, electrons and DN.
//! * [`sensor`]: the sensor catalog and the noise model (photons to DN), shared with
//!   calibration and the gap workflow.
//! * [`isp`]: the fixed 8-bit output rule per scenario, and the fused sensor + ISP row the
//!   evaluator runs.
//! * [`demosaic`]: Bayer mosaics to RGB (bilinear, Malvar-He-Cutler, Hamilton-Adams
//!   directional), and [`develop`]: a raw mosaic to 8-bit sRGB (black level, white balance,
//!   demosaic, colour matrix, sRGB curve), as `scene-gen isp` runs it.
//! * [`spectral`]: illuminant spectra (D65, warm white), the colour channels' quantum efficiency
//!   curves, and the matrix from rendered linear RGB to electrons per channel; [`bayer`]: the
//!   colour sensor's CFA sampling, noise on the mosaic and fixed colour ISP; [`colour_checker`]:
//!   the 24-patch chart through that chain, scored by CIEDE2000.
//! * [`capture`]: the one place that chains them: a house, a camera and lighting scenarios in,
//!   frames out.
//! * [`view`]: a frame's intrinsics and camera-to-world pose, in the conventions datasets carry.
//! * [`path`]: a camera path the user gives (JSON or CSV poses) instead of the agent's walk.

pub mod bayer;
pub mod camera_spec;
pub mod capture;
pub mod colour_checker;
pub mod demosaic;
pub mod develop;
pub mod isp;
pub mod optics;
pub mod path;
pub mod radiometry;
pub mod sensor;
pub mod spectral;
pub mod view;
