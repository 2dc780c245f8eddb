//! The sensor catalog: geometry, shutter, ADC depth and noise parameters of image sensors.
//!
//! The embedded catalog (`catalog.toml`, compiled in) holds the 43 sensors of the TaCOS
//! catalog, corrected where public datasheets contradict it (each correction carries a
//! `note`). Each noise figure that is not an estimate carries a `[[sensor.figure]]`: how it was
//! obtained ([`FigureKind`]), the camera measured, the source address and the formula; the
//! others are estimates by the pixel-size rule the entry's `source` states (`estimated = true`).
//! [`Sensor::provenance`] reports every field either way. A user file with the same schema adds
//! sensors; a model already present is replaced.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// The embedded catalog text.
const EMBEDDED: &str = include_str!("catalog.toml");

/// Allowed mismatch between `active_area_mm` and resolution x pitch, in mm (rounding of the
/// published figures).
const AREA_TOLERANCE_MM: f64 = 0.02;

/// Electronic shutter type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Shutter {
    Global,
    Rolling,
}

/// Colour filter: Bayer colour or monochrome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Colour {
    Colour,
    Mono,
}

/// One image sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sensor {
    pub maker: String,
    pub model: String,
    /// Active pixels, width x height.
    pub resolution: [u32; 2],
    pub pixel_pitch_um: f64,
    /// Active area, width x height in mm; must equal resolution x pitch.
    pub active_area_mm: [f64; 2],
    pub shutter: Shutter,
    pub colour: Colour,
    pub adc_bits: u32,
    /// Quantum efficiency near 550 nm (0..1).
    pub quantum_efficiency: f64,
    /// Full-well capacity (saturation capacity), electrons.
    pub full_well_e: f64,
    /// Temporal read (dark) noise, electrons rms.
    pub read_noise_e: f64,
    /// Dark current at about 25 C, electrons per second.
    pub dark_current_e_per_s: f64,
    /// True when any noise parameter is an estimate rather than a published figure.
    pub estimated: bool,
    /// Where the noise parameters come from: a URL or `"estimate: <rule>"`.
    pub source: String,
    /// Where the geometry comes from.
    #[serde(default)]
    pub spec_source: String,
    /// What was corrected against the reference catalog, and why.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub note: String,
    /// Where noise figures come from, one entry per field (`[[sensor.figure]]` in TOML). A field
    /// without one is estimated by the rule in `source` when `estimated` is true, and measured
    /// as `source` says when it is false (a user's own measurement needs no figures).
    #[serde(default, rename = "figure", skip_serializing_if = "Vec::is_empty")]
    pub figures: Vec<Figure>,
}

/// The noise fields whose provenance the catalog records.
pub const NOISE_FIELDS: [&str; 4] = ["quantum_efficiency", "full_well_e", "read_noise_e", "dark_current_e_per_s"];

/// How a figure was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FigureKind {
    /// Measured to EMVA 1288 on a camera built on the sensor.
    Measured,
    /// Computed from measured figures (e.g. saturation capacity from SNRmax, read noise from the
    /// dynamic range); `how` gives the formula and the figures.
    Derived,
    /// The sensor maker's data sheet.
    Datasheet,
    /// A rule of thumb (the sensor's `source` states it).
    Estimated,
}

/// The provenance of one noise figure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Figure {
    /// One of [`NOISE_FIELDS`].
    pub field: String,
    pub kind: FigureKind,
    /// The camera measured (maker, model, mono or colour).
    #[serde(default)]
    pub camera: String,
    /// The address of the page the figure comes from.
    pub source: String,
    /// How the value follows from the source (formula and inputs), or the quoted figure.
    #[serde(default)]
    pub how: String,
}

/// A sensor and the provenance of each noise field ([`Sensor::provenance`]).
#[derive(Debug, Clone, Serialize)]
pub struct SensorRecord<'a> {
    #[serde(flatten)]
    pub sensor: &'a Sensor,
    pub provenance: Vec<FieldProvenance>,
}

/// The provenance of a sensor's noise field, as `sensors` reports it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FieldProvenance {
    pub field: &'static str,
    pub value: f64,
    pub kind: FigureKind,
    pub camera: String,
    pub source: String,
    pub how: String,
}

impl Sensor {
    /// Pixel area in square micrometres.
    #[must_use]
    pub fn pixel_area_um2(&self) -> f64 {
        self.pixel_pitch_um * self.pixel_pitch_um
    }

    /// Active area in square millimetres.
    #[must_use]
    pub fn area_mm2(&self) -> f64 {
        self.active_area_mm[0] * self.active_area_mm[1]
    }

    /// The value of one of [`NOISE_FIELDS`].
    fn noise_value(&self, field: &str) -> Option<f64> {
        match field {
            "quantum_efficiency" => Some(self.quantum_efficiency),
            "full_well_e" => Some(self.full_well_e),
            "read_noise_e" => Some(self.read_noise_e),
            "dark_current_e_per_s" => Some(self.dark_current_e_per_s),
            _ => None,
        }
    }

    /// Every noise field with its value and where it comes from: its `[[sensor.figure]]`, or
    /// an estimate by the rule in `source`.
    #[must_use]
    pub fn provenance(&self) -> Vec<FieldProvenance> {
        NOISE_FIELDS
            .iter()
            .map(|&field| {
                let value = self.noise_value(field).expect("a noise field");
                match self.figures.iter().find(|f| f.field == field) {
                    Some(f) => FieldProvenance {
                        field,
                        value,
                        kind: f.kind,
                        camera: f.camera.clone(),
                        source: f.source.clone(),
                        how: f.how.clone(),
                    },
                    None if self.estimated => FieldProvenance {
                        field,
                        value,
                        kind: FigureKind::Estimated,
                        camera: String::new(),
                        source: String::new(),
                        how: self.source.clone(),
                    },
                    None => FieldProvenance {
                        field,
                        value,
                        kind: FigureKind::Measured,
                        camera: String::new(),
                        source: self.source.clone(),
                        how: String::new(),
                    },
                }
            })
            .collect()
    }

    /// The sensor with the provenance of its noise fields, as `sensors --json` writes it.
    #[must_use]
    pub fn record(&self) -> SensorRecord<'_> {
        SensorRecord { sensor: self, provenance: self.provenance() }
    }

    /// Whether every noise field is measured, derived or from a data sheet.
    fn fully_sourced(&self) -> bool {
        NOISE_FIELDS.iter().all(|&f| self.figures.iter().any(|g| g.field == f && g.kind != FigureKind::Estimated))
    }

    fn check(&self) -> Result<(), String> {
        let positive = [
            ("pixel_pitch_um", self.pixel_pitch_um),
            ("full_well_e", self.full_well_e),
            ("quantum_efficiency", self.quantum_efficiency),
        ];
        for (field, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{field} must be positive, got {v}"));
            }
        }
        if self.quantum_efficiency > 1.0 {
            return Err(format!("quantum_efficiency must be at most 1, got {}", self.quantum_efficiency));
        }
        if !(self.read_noise_e >= 0.0 && self.dark_current_e_per_s >= 0.0) {
            return Err("read_noise_e and dark_current_e_per_s must be non-negative".into());
        }
        if !(1..=16).contains(&self.adc_bits) {
            return Err(format!("adc_bits must be 1..16, got {}", self.adc_bits));
        }
        for (i, f) in self.figures.iter().enumerate() {
            if self.noise_value(&f.field).is_none() {
                return Err(format!("figure {}: field '{}' is not one of {}", i + 1, f.field, NOISE_FIELDS.join(", ")));
            }
            if self.figures[..i].iter().any(|g| g.field == f.field) {
                return Err(format!("figure {}: field '{}' has two figures", i + 1, f.field));
            }
            if f.kind != FigureKind::Estimated && f.source.trim().is_empty() {
                return Err(format!("figure {} ({}): a {:?} figure needs its source", i + 1, f.field, f.kind));
            }
        }
        if self.estimated && self.fully_sourced() {
            return Err("estimated = true but every noise field has a measured, derived or data-sheet figure".into());
        }
        if !self.estimated && self.figures.iter().any(|f| f.kind == FigureKind::Estimated) {
            return Err("estimated = false but a figure is estimated".into());
        }
        if self.resolution[0] == 0 || self.resolution[1] == 0 {
            return Err("resolution must be positive".into());
        }
        for (axis, (&n, &mm)) in ["width", "height"].iter().zip(self.resolution.iter().zip(&self.active_area_mm)) {
            let derived = f64::from(n) * self.pixel_pitch_um / 1000.0;
            if (derived - mm).abs() > AREA_TOLERANCE_MM {
                return Err(format!("active_area_mm {axis} {mm} does not match resolution x pitch = {derived:.4} mm"));
            }
        }
        Ok(())
    }
}

/// A catalog could not be read.
#[derive(Debug, thiserror::Error)]
pub enum CatalogError {
    #[error("cannot read {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {message}", path.display())]
    Parse { path: PathBuf, line: usize, message: String },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CatalogFile {
    #[serde(default)]
    sensor: Vec<toml::Spanned<Sensor>>,
}

/// A set of sensors, kept sorted by active area (smallest first), then model name.
#[derive(Debug, Clone, PartialEq)]
pub struct Catalog {
    sensors: Vec<Sensor>,
}

impl Catalog {
    /// The catalog compiled into the binary.
    ///
    /// # Panics
    /// Never in a released build: the embedded file is checked by the tests.
    #[must_use]
    pub fn embedded() -> Self {
        let sensors = parse(EMBEDDED, Path::new("<embedded>/catalog.toml")).expect("embedded sensor catalog is valid");
        let mut catalog = Catalog { sensors: Vec::new() };
        catalog.merge(sensors);
        catalog
    }

    /// Adds the sensors of a user TOML file (same schema as the embedded catalog); an entry
    /// whose model (case-insensitive) is already present replaces it.
    pub fn load_extra(&mut self, path: &Path) -> Result<(), CatalogError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| CatalogError::Io { path: path.to_path_buf(), source })?;
        let sensors = parse(&text, path)?;
        self.merge(sensors);
        Ok(())
    }

    /// The sensor named `model`, case-insensitively.
    #[must_use]
    pub fn get(&self, model: &str) -> Option<&Sensor> {
        self.sensors.iter().find(|s| s.model.eq_ignore_ascii_case(model))
    }

    /// Every sensor with the provenance of its noise fields, as `sensors --json` writes them.
    #[must_use]
    pub fn records(&self) -> Vec<SensorRecord<'_>> {
        self.sensors.iter().map(Sensor::record).collect()
    }

    /// All sensors, sorted by active area (smallest first); ties by model name.
    #[must_use]
    pub fn sensors(&self) -> &[Sensor] {
        &self.sensors
    }

    #[must_use]
    pub fn len(&self) -> usize {
        self.sensors.len()
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.sensors.is_empty()
    }

    fn merge(&mut self, sensors: Vec<Sensor>) {
        for s in sensors {
            self.sensors.retain(|old| !old.model.eq_ignore_ascii_case(&s.model));
            self.sensors.push(s);
        }
        self.sensors.sort_by(|a, b| a.area_mm2().total_cmp(&b.area_mm2()).then_with(|| a.model.cmp(&b.model)));
    }
}

fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].bytes().filter(|&b| b == b'\n').count() + 1
}

fn parse(text: &str, path: &Path) -> Result<Vec<Sensor>, CatalogError> {
    let err = |offset: usize, message: String| CatalogError::Parse {
        path: path.to_path_buf(),
        line: line_of(text, offset),
        message,
    };
    let file: CatalogFile = toml::from_str(text).map_err(|e| {
        let offset = e.span().map_or(0, |s| s.start);
        err(offset, e.message().to_string())
    })?;
    let mut out: Vec<Sensor> = Vec::with_capacity(file.sensor.len());
    for spanned in file.sensor {
        let start = spanned.span().start;
        let sensor = spanned.into_inner();
        sensor.check().map_err(|m| err(start, format!("sensor {}: {m}", sensor.model)))?;
        if out.iter().any(|o| o.model.eq_ignore_ascii_case(&sensor.model)) {
            return Err(err(start, format!("sensor {} appears twice in this file", sensor.model)));
        }
        out.push(sensor);
    }
    Ok(out)
}
