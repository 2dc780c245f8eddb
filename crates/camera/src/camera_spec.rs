//! Camera specs: a catalog sensor behind a lens, mounted on the agent, with the scenario
//! exposure settings; from a TOML file or the inline form of docs/CONTRACTS.md
//! `SENSOR[,focal_mm=F][,pitch_deg=P][,height_m=H]` (every field of [`CameraSpec`] may be
//! given inline as `key=value`).
//!
//! ```toml
//! sensor = "IMX174"
//! focal_mm = 4.0
//! pitch_deg = -10.0
//! noise = "emva"        # "emva" | "affine" | "off"
//! # Optics (crates/camera/src/optics.rs), each switchable:
//! vignetting = true      # cos^4 fall-off
//! diffraction = true     # Airy blur at 550 nm (Gaussian sigma 0.42 lambda N); no-op when sub-pixel
//! defocus = false        # thin-lens circle of confusion from the depth buffer
//! focus_m = 1.5          # focus distance (> focal length); omitted: hyperfocal, 2-pixel CoC
//! motion_blur = false    # camera translation during the exposure
//! motion_speed_m_s = 0.5 # omitted: the walk's speed, as the caller passes it
//! ```
//!
//! [`CameraSpec::resolve`] looks the sensor up in a [`Catalog`] and gives a [`ResolvedCamera`]:
//! the image size and pixel pitch, optionally binned down to `max_width_px` for cheap frames.
//!
//! **Binning** (`max_width_px`): a sensor wider than `max_width_px` is simulated as a
//! `max_width_px`-wide sensor of the same active area: the pixel pitch grows by the factor
//! `s = width / max_width_px`, so the field of view is kept (the height is rounded to whole
//! pixels, so the vertical FOV may change by under one pixel). Each simulated pixel stands for
//! the *average* of `s x s` real pixels: it collects `s^2` times the photons, its full well is
//! `s^2` times larger (so the DN scale, K = max DN / full well, stays that of the real sensor at
//! equal exposure), its dark current `s^2` and its read noise `s` times (independent pixels add
//! in variance). Signal levels in DN are therefore those of the full-resolution sensor, and the
//! noise is that of `s x s` averaging.

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::sensor::catalog::Colour;
use crate::sensor::{Catalog, Sensor, SensorModel};
use scene_gen_render::Camera;
use scene_gen_scene::trajectory::Pose;

/// Default focal length when a spec gives none, mm (a common wide M12 lens).
pub const DEFAULT_FOCAL_MM: f32 = 4.0;

/// Default exposure time, s. TaCOS keeps the exposure fixed (docs/REFERENCE.md) without giving
/// the value; 1/30 s is the longest exposure of a 30 fps video stream, the usual setting of a
/// robot camera indoors (an assumption, stated here).
pub const DEFAULT_EXPOSURE_S: f64 = 1.0 / 30.0;

/// The reference system's scenario gains (docs/REFERENCE.md, "Environment"): 5 dB by day, 15 dB by night.
pub const DEFAULT_GAIN_DAY_DB: f64 = 5.0;
pub const DEFAULT_GAIN_NIGHT_DB: f64 = 15.0;

/// Which noise model turns photons into the output image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum NoiseKind {
    /// The EMVA 1288 linear model of the catalog sensor (grey image at the ADC depth).
    #[default]
    Emva,
    /// The reference paper's affine model on 8-bit RGB values.
    Affine,
    /// The noiseless mean signal (grey image at the ADC depth).
    Off,
}

/// Which path a camera's light takes through its sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum ColourPath {
    /// The catalog part's own: through its colour filter array to sRGB when it has one, as
    /// luminance when it is monochrome.
    #[default]
    Catalog,
    /// The monochrome variant of the part: luminance at the ADC depth, no colour filter array,
    /// with the catalog's noise figures and quantum efficiency (makers sell many colour parts
    /// as monochrome ones too, with the same pixel).
    Mono,
}

impl ColourPath {
    fn parse(text: &str) -> Option<ColourPath> {
        match text.to_ascii_lowercase().as_str() {
            "catalog" => Some(ColourPath::Catalog),
            "mono" => Some(ColourPath::Mono),
            _ => None,
        }
    }

    fn is_catalog(&self) -> bool {
        *self == ColourPath::Catalog
    }
}

impl NoiseKind {
    fn parse(text: &str) -> Option<NoiseKind> {
        match text.to_ascii_lowercase().as_str() {
            "emva" => Some(NoiseKind::Emva),
            "affine" => Some(NoiseKind::Affine),
            "off" => Some(NoiseKind::Off),
            _ => None,
        }
    }
}

fn d_focal() -> f32 {
    DEFAULT_FOCAL_MM
}
fn d_f_number() -> f32 {
    2.0
}
fn d_pitch() -> f32 {
    -10.0
}
fn d_height() -> f32 {
    0.8
}
fn d_exposure() -> f64 {
    DEFAULT_EXPOSURE_S
}
fn d_gain_day() -> f64 {
    DEFAULT_GAIN_DAY_DB
}
fn d_gain_night() -> f64 {
    DEFAULT_GAIN_NIGHT_DB
}
fn d_transmittance() -> f32 {
    scene_gen_render::DEFAULT_LENS_TRANSMITTANCE
}
fn d_true() -> bool {
    true
}

/// A camera candidate as the user writes it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Catalog model name (case-insensitive).
    pub sensor: String,
    #[serde(default = "d_focal")]
    pub focal_mm: f32,
    #[serde(default = "d_f_number")]
    pub f_number: f32,
    /// Elevation of the optical axis, degrees, positive up.
    #[serde(default = "d_pitch")]
    pub pitch_deg: f32,
    /// Heading offset from the direction of travel, degrees counter-clockwise.
    #[serde(default)]
    pub yaw_offset_deg: f32,
    /// Mounting height of the camera above the floor, metres.
    #[serde(default = "d_height")]
    pub height_m: f32,
    #[serde(default = "d_exposure")]
    pub exposure_s: f64,
    #[serde(default = "d_gain_day")]
    pub gain_day_db: f64,
    #[serde(default = "d_gain_night")]
    pub gain_night_db: f64,
    #[serde(default = "d_transmittance")]
    pub lens_transmittance: f32,
    /// cos^4 natural fall-off towards the image corners.
    #[serde(default = "d_true")]
    pub vignetting: bool,
    #[serde(default)]
    pub noise: NoiseKind,
    /// The catalog part's colour path, or its monochrome variant ([`ColourPath`]); left out of
    /// a written spec when it is the catalog's.
    #[serde(default, skip_serializing_if = "ColourPath::is_catalog")]
    pub colour: ColourPath,
    /// Bin the sensor down to at most this many pixels across (see the module doc).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_width_px: Option<u32>,
    /// Diffraction blur (Gaussian approximation of the Airy pattern at 550 nm); see
    /// [`crate::optics`]. On by default: physical, and free when under a pixel.
    #[serde(default = "d_true")]
    pub diffraction: bool,
    /// Thin-lens defocus from the depth buffer, focused at `focus_m`; off by default (the
    /// reference system's ideal optics).
    #[serde(default)]
    pub defocus: bool,
    /// Focus distance, metres (> focal length); `None`: the hyperfocal distance for a 2-pixel
    /// circle of confusion ([`crate::optics::focus_distance_m`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub focus_m: Option<f32>,
    /// Motion blur from the camera's translation during the exposure; off by default.
    #[serde(default)]
    pub motion_blur: bool,
    /// Camera speed for motion blur, m/s (>= 0), along the direction of travel; `None`: the
    /// walk's speed, as the caller passes it ([`crate::optics::agent_velocity`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion_speed_m_s: Option<f32>,
}

/// A camera spec that cannot be used; each names the file/line or the field.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    #[error("cannot read camera spec {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {message}", path.display())]
    Toml { path: PathBuf, line: usize, message: String },
    #[error("camera spec field {field}: {why}")]
    Field { field: String, why: String },
    #[error("unknown sensor '{name}'{}", suggest(suggestions))]
    UnknownSensor { name: String, suggestions: Vec<String> },
}

fn suggest(names: &[String]) -> String {
    if names.is_empty() {
        " (see `scene-gen sensors` for the catalog)".to_string()
    } else {
        format!("; close names: {}", names.join(", "))
    }
}

fn field(field: &str, why: impl Into<String>) -> SpecError {
    SpecError::Field { field: field.to_string(), why: why.into() }
}

impl CameraSpec {
    /// A spec of `sensor` with every other field at its default.
    #[must_use]
    pub fn new(sensor: &str) -> CameraSpec {
        CameraSpec {
            sensor: sensor.to_string(),
            focal_mm: d_focal(),
            f_number: d_f_number(),
            pitch_deg: d_pitch(),
            yaw_offset_deg: 0.0,
            height_m: d_height(),
            exposure_s: d_exposure(),
            gain_day_db: d_gain_day(),
            gain_night_db: d_gain_night(),
            lens_transmittance: d_transmittance(),
            vignetting: true,
            noise: NoiseKind::Emva,
            colour: ColourPath::Catalog,
            max_width_px: None,
            diffraction: true,
            defocus: false,
            focus_m: None,
            motion_blur: false,
            motion_speed_m_s: None,
        }
    }

    /// A `--camera` argument: a TOML file when it names an existing file or ends in `.toml`,
    /// else the inline form.
    ///
    /// # Errors
    /// [`SpecError`] naming the file and line or the field.
    pub fn from_arg(arg: &str) -> Result<CameraSpec, SpecError> {
        let path = Path::new(arg);
        if path.is_file() || arg.to_ascii_lowercase().ends_with(".toml") {
            let text =
                std::fs::read_to_string(path).map_err(|source| SpecError::Io { path: path.to_path_buf(), source })?;
            CameraSpec::from_toml(&text, path)
        } else {
            CameraSpec::from_inline(arg)
        }
    }

    /// Parses TOML text (`path` is only for messages).
    ///
    /// # Errors
    /// [`SpecError::Toml`] with the line, or [`SpecError::Field`] from [`CameraSpec::validate`].
    pub fn from_toml(text: &str, path: &Path) -> Result<CameraSpec, SpecError> {
        let spec: CameraSpec = toml::from_str(text).map_err(|e| {
            let offset = e.span().map_or(0, |s| s.start);
            let line = text[..offset.min(text.len())].bytes().filter(|&b| b == b'\n').count() + 1;
            SpecError::Toml { path: path.to_path_buf(), line, message: e.message().to_string() }
        })?;
        spec.validate()?;
        Ok(spec)
    }

    /// Parses `SENSOR[,key=value]...`.
    ///
    /// # Errors
    /// [`SpecError::Field`] naming the key that is unknown, repeated or malformed.
    pub fn from_inline(text: &str) -> Result<CameraSpec, SpecError> {
        let mut parts = text.split(',').map(str::trim);
        let sensor = parts.next().unwrap_or("");
        if sensor.is_empty() || sensor.contains('=') {
            return Err(field("sensor", format!("'{text}' must start with a sensor name, e.g. IMX174,focal_mm=4")));
        }
        let mut spec = CameraSpec::new(sensor);
        let mut seen: Vec<&str> = Vec::new();
        for part in parts {
            let Some((key, value)) = part.split_once('=') else {
                return Err(field(part, format!("'{part}' is not key=value")));
            };
            let (key, value) = (key.trim(), value.trim());
            if seen.contains(&key) {
                return Err(field(key, "given twice"));
            }
            seen.push(key);
            let f32v = || value.parse::<f32>().map_err(|_| field(key, format!("'{value}' is not a number")));
            let f64v = || value.parse::<f64>().map_err(|_| field(key, format!("'{value}' is not a number")));
            let boolv = || value.parse::<bool>().map_err(|_| field(key, format!("'{value}' is not true or false")));
            match key {
                "focal_mm" => spec.focal_mm = f32v()?,
                "f_number" => spec.f_number = f32v()?,
                "pitch_deg" => spec.pitch_deg = f32v()?,
                "yaw_offset_deg" => spec.yaw_offset_deg = f32v()?,
                "height_m" => spec.height_m = f32v()?,
                "exposure_s" => spec.exposure_s = f64v()?,
                "gain_day_db" => spec.gain_day_db = f64v()?,
                "gain_night_db" => spec.gain_night_db = f64v()?,
                "lens_transmittance" => spec.lens_transmittance = f32v()?,
                "vignetting" => spec.vignetting = boolv()?,
                "diffraction" => spec.diffraction = boolv()?,
                "defocus" => spec.defocus = boolv()?,
                "motion_blur" => spec.motion_blur = boolv()?,
                "focus_m" => spec.focus_m = Some(f32v()?),
                "motion_speed_m_s" => spec.motion_speed_m_s = Some(f32v()?),
                "noise" => {
                    spec.noise = NoiseKind::parse(value)
                        .ok_or_else(|| field(key, format!("'{value}' is not emva, affine or off")))?;
                }
                "colour" => {
                    spec.colour = ColourPath::parse(value)
                        .ok_or_else(|| field(key, format!("'{value}' is not catalog or mono")))?;
                }
                "max_width_px" => {
                    spec.max_width_px =
                        Some(value.parse::<u32>().map_err(|_| field(key, format!("'{value}' is not a whole number")))?);
                }
                _ => return Err(field(key, "unknown field (see crates/camera/src/camera_spec.rs for the list)")),
            }
        }
        spec.validate()?;
        Ok(spec)
    }

    /// Checks every number's range.
    ///
    /// # Errors
    /// [`SpecError::Field`] naming the first offending field.
    pub fn validate(&self) -> Result<(), SpecError> {
        let positive32 = [("focal_mm", self.focal_mm), ("f_number", self.f_number), ("height_m", self.height_m)];
        for (name, v) in positive32 {
            if !(v.is_finite() && v > 0.0) {
                return Err(field(name, format!("must be a finite number > 0, got {v}")));
            }
        }
        if !(self.exposure_s.is_finite() && self.exposure_s > 0.0) {
            return Err(field("exposure_s", format!("must be a finite number > 0, got {}", self.exposure_s)));
        }
        if !(self.pitch_deg.is_finite() && self.pitch_deg.abs() <= 90.0) {
            return Err(field("pitch_deg", format!("must be within [-90, 90], got {}", self.pitch_deg)));
        }
        if !self.yaw_offset_deg.is_finite() {
            return Err(field("yaw_offset_deg", "must be finite"));
        }
        for (name, v) in [("gain_day_db", self.gain_day_db), ("gain_night_db", self.gain_night_db)] {
            if !v.is_finite() {
                return Err(field(name, format!("must be finite, got {v}")));
            }
        }
        if !(self.lens_transmittance > 0.0 && self.lens_transmittance <= 1.0) {
            return Err(field("lens_transmittance", format!("must be in (0, 1], got {}", self.lens_transmittance)));
        }
        if self.max_width_px == Some(0) {
            return Err(field("max_width_px", "must be at least 1"));
        }
        if let Some(z) = self.focus_m {
            let f_m = self.focal_mm * 1e-3;
            if !(z.is_finite() && z > f_m) {
                return Err(field(
                    "focus_m",
                    format!("must be a finite distance beyond the focal length ({f_m} m), got {z}"),
                ));
            }
        }
        if let Some(v) = self.motion_speed_m_s {
            if !(v.is_finite() && v >= 0.0) {
                return Err(field("motion_speed_m_s", format!("must be a finite number >= 0, got {v}")));
            }
        }
        Ok(())
    }

    /// Looks the sensor up and fixes the image size.
    ///
    /// # Errors
    /// [`SpecError::UnknownSensor`] listing close catalog names.
    pub fn resolve(&self, catalog: &Catalog) -> Result<ResolvedCamera, SpecError> {
        self.validate()?;
        let sensor = catalog.get(&self.sensor).ok_or_else(|| SpecError::UnknownSensor {
            name: self.sensor.clone(),
            suggestions: close_names(catalog, &self.sensor),
        })?;
        let mut sensor = sensor.clone();
        if self.colour == ColourPath::Mono {
            sensor.colour = Colour::Mono;
        }
        let [w, h] = sensor.resolution;
        let (width_px, height_px, bin) = match self.max_width_px {
            Some(m) if m < w => {
                let s = f64::from(w) / f64::from(m);
                (m, ((f64::from(h) / s).round() as u32).max(1), s)
            }
            _ => (w, h, 1.0),
        };
        Ok(ResolvedCamera {
            spec: self.clone(),
            pixel_pitch_um: (sensor.pixel_pitch_um * bin) as f32,
            sensor,
            width_px,
            height_px,
            bin_factor: bin,
        })
    }
}

/// Up to five catalog names close to `name`: by edit distance (case-insensitive), or sharing
/// its digits.
#[must_use]
pub fn close_names(catalog: &Catalog, name: &str) -> Vec<String> {
    let q = name.to_ascii_lowercase();
    let digits: String = q.chars().filter(char::is_ascii_digit).collect();
    let mut scored: Vec<(usize, String)> = catalog
        .sensors()
        .iter()
        .filter_map(|s| {
            let m = s.model.to_ascii_lowercase();
            let d = levenshtein(&q, &m);
            let shares_digits = digits.len() >= 3 && m.contains(&digits);
            (d <= 3 || shares_digits).then(|| (if shares_digits { d.min(1) } else { d }, s.model.clone()))
        })
        .collect();
    scored.sort();
    scored.into_iter().take(5).map(|(_, n)| n).collect()
}

fn levenshtein(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// A spec bound to its catalog sensor, at the simulated resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct ResolvedCamera {
    pub spec: CameraSpec,
    pub sensor: Sensor,
    pub width_px: u32,
    pub height_px: u32,
    /// Real pixels per simulated pixel along a side (1 without binning).
    pub bin_factor: f64,
    /// Simulated pixel pitch (the sensor's times the bin factor), micrometres.
    pub pixel_pitch_um: f32,
}

impl ResolvedCamera {
    /// The pinhole camera at an agent pose (yaw = pose heading + the spec's offset; height
    /// from the pose).
    #[must_use]
    pub fn camera(&self, position: Vec3, heading_deg: f32) -> Camera {
        Camera {
            width_px: self.width_px,
            height_px: self.height_px,
            pixel_pitch_um: self.pixel_pitch_um,
            focal_mm: self.spec.focal_mm,
            f_number: self.spec.f_number,
            position,
            yaw_deg: heading_deg + self.spec.yaw_offset_deg,
            pitch_deg: self.spec.pitch_deg,
            vignetting: self.spec.vignetting,
        }
    }

    /// [`ResolvedCamera::camera`] at a trajectory pose, at the spec's mounting height.
    #[must_use]
    pub fn camera_at(&self, pose: &Pose) -> Camera {
        self.camera(pose.position.truncate().extend(self.spec.height_m), pose.yaw_deg)
    }

    /// Focal length in pixels (fx = fy: square pixels).
    #[must_use]
    pub fn focal_px(&self) -> f64 {
        f64::from(self.spec.focal_mm) * 1000.0 / f64::from(self.pixel_pitch_um)
    }

    /// Simulated pixel area, square micrometres.
    #[must_use]
    pub fn pixel_area_um2(&self) -> f64 {
        f64::from(self.pixel_pitch_um) * f64::from(self.pixel_pitch_um)
    }

    /// The EMVA model of one simulated pixel (binning as in the module doc); `pattern_seed`
    /// fixes this sensor instance's fixed patterns.
    #[must_use]
    pub fn sensor_model(&self, pattern_seed: u64) -> SensorModel {
        let s2 = self.bin_factor * self.bin_factor;
        let binned = Sensor {
            full_well_e: self.sensor.full_well_e * s2,
            dark_current_e_per_s: self.sensor.dark_current_e_per_s * s2,
            read_noise_e: self.sensor.read_noise_e * self.bin_factor,
            ..self.sensor.clone()
        };
        SensorModel::from_sensor(&binned, pattern_seed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inline_defaults_and_fields() {
        let s = CameraSpec::from_inline("IMX174,focal_mm=6,pitch_deg=-20,height_m=1.1").unwrap();
        assert_eq!((s.sensor.as_str(), s.focal_mm, s.pitch_deg, s.height_m), ("IMX174", 6.0, -20.0, 1.1));
        assert_eq!(s.f_number, 2.0);
        let bare = CameraSpec::from_inline("IMX174").unwrap();
        assert_eq!(bare, CameraSpec::new("IMX174"));
        for (text, name) in [
            ("IMX174,focal_mm=0", "focal_mm"),
            ("IMX174,focal_mm=abc", "focal_mm"),
            ("IMX174,focal_mm=inf", "focal_mm"),
            ("IMX174,zoom=3", "zoom"),
            ("IMX174,pitch_deg", "pitch_deg"),
            ("focal_mm=4", "sensor"),
            ("IMX174,noise=loud", "noise"),
            ("IMX174,colour=grey", "colour"),
        ] {
            let e = CameraSpec::from_inline(text).unwrap_err().to_string();
            assert!(e.contains(name), "{text}: {e}");
        }
    }

    #[test]
    fn toml_errors_name_the_line() {
        let e = CameraSpec::from_toml("sensor = \"IMX174\"\nfocal = 4\n", Path::new("cam.toml")).unwrap_err();
        assert!(e.to_string().starts_with("cam.toml:2:"), "{e}");
        let ok = CameraSpec::from_toml("sensor = \"IMX174\"\nnoise = \"affine\"\n", Path::new("c.toml")).unwrap();
        assert_eq!(ok.noise, NoiseKind::Affine);
    }

    /// `colour = "mono"` takes a colour part's monochrome variant: no colour filter array, the
    /// same pixel figures; a written spec names the key only when it is set.
    #[test]
    fn mono_variant_leaves_the_colour_filter_out() {
        let catalog = Catalog::embedded();
        let colour = CameraSpec::from_inline("IMX174").unwrap().resolve(&catalog).unwrap();
        let mono = CameraSpec::from_inline("IMX174,colour=mono").unwrap().resolve(&catalog).unwrap();
        assert_eq!(colour.sensor.colour, Colour::Colour);
        assert!(crate::bayer::cfa_of(&colour).is_some());
        assert_eq!(mono.sensor.colour, Colour::Mono);
        assert!(crate::bayer::cfa_of(&mono).is_none());
        assert_eq!(mono.sensor.read_noise_e, colour.sensor.read_noise_e);
        assert_eq!(mono.sensor.quantum_efficiency, colour.sensor.quantum_efficiency);
        let written = toml::to_string(&mono.spec).unwrap();
        assert!(written.contains("colour = \"mono\""), "{written}");
        assert_eq!(CameraSpec::from_toml(&written, Path::new("m.toml")).unwrap(), mono.spec);
        assert!(!toml::to_string(&colour.spec).unwrap().contains("colour"));
    }

    #[test]
    fn unknown_sensor_lists_close_names() {
        let catalog = Catalog::embedded();
        let e = CameraSpec::new("IMX17").resolve(&catalog).unwrap_err().to_string();
        assert!(e.contains("IMX174") || e.contains("IMX178"), "{e}");
    }

    #[test]
    fn binning_keeps_the_field_of_view() {
        let catalog = Catalog::embedded();
        let full = CameraSpec::new("IMX174").resolve(&catalog).unwrap();
        let small = CameraSpec { max_width_px: Some(160), ..CameraSpec::new("IMX174") }.resolve(&catalog).unwrap();
        assert_eq!(small.width_px, 160);
        let (a, b) = (full.camera(Vec3::ZERO, 0.0), small.camera(Vec3::ZERO, 0.0));
        assert!((a.hfov_deg() - b.hfov_deg()).abs() < 1e-3);
        // The height is rounded to whole simulated pixels: within half a simulated pixel.
        let half_px_mm = 0.5 * f64::from(small.pixel_pitch_um) * 1e-3;
        assert!(f64::from((a.sensor_height_mm() - b.sensor_height_mm()).abs()) <= half_px_mm + 1e-6);
        // Same DN per photon per real-pixel area: K scales with 1 / bin^2.
        let (mf, ms) = (full.sensor_model(0), small.sensor_model(0));
        let s2 = small.bin_factor * small.bin_factor;
        assert!((mf.system_gain_dn_per_e / ms.system_gain_dn_per_e / s2 - 1.0).abs() < 1e-9);
    }
}
