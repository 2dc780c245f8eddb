//! Photon-transfer CSV: already-reduced measurements, one row per operating point.
//!
//! Columns (header required, order free, names exact):
//!
//! | column            | unit   | required                                            |
//! |-------------------|--------|-----------------------------------------------------|
//! | `exposure_s`      | s      | yes                                                 |
//! | `gain_db`         | dB     | yes                                                 |
//! | `photons`         | photons per pixel | one of `photons` / `illuminance_lux`     |
//! | `illuminance_lux` | lux    | (QE cannot be measured from lux)                    |
//! | `mean_dn`         | DN     | yes: mean of the frame pair                         |
//! | `temporal_var_dn2`| DN^2   | yes: half the variance of the pair difference       |
//! | `spatial_var_dn2` | DN^2   | no                                                  |
//! | `dark_mean_dn`    | DN     | no: else rows with zero light are the dark points   |
//! | `dark_var_dn2`    | DN^2   | with `dark_mean_dn`                                 |
//! | `pixels`          | count  | no: pixels each row's statistics were computed over |
//!
//! `pixels` sets the sampling uncertainties of the gap workflow (`scene-gen gap` on a CSV);
//! calibration does not use it.
//!
//! Lines starting with `#` and blank lines are ignored.

use std::path::{Path, PathBuf};

/// A photon-transfer CSV could not be read.
#[derive(Debug, thiserror::Error)]
pub enum PtcError {
    #[error("cannot read {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {message}", path.display())]
    Syntax { path: PathBuf, line: usize, message: String },
}

/// One row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PtcRow {
    pub line: usize,
    pub exposure_s: f64,
    pub gain_db: f64,
    pub photons: Option<f64>,
    pub illuminance_lux: Option<f64>,
    pub mean_dn: f64,
    pub temporal_var_dn2: f64,
    pub spatial_var_dn2: Option<f64>,
    pub dark_mean_dn: Option<f64>,
    pub dark_var_dn2: Option<f64>,
    pub pixels: Option<f64>,
}

impl PtcRow {
    /// The light level of the row (photons, or lux when photons are not given).
    #[must_use]
    pub fn light(&self) -> f64 {
        self.photons.or(self.illuminance_lux).unwrap_or(0.0)
    }
}

const REQUIRED: [&str; 5] = ["exposure_s", "gain_db", "mean_dn", "temporal_var_dn2", "photons|illuminance_lux"];
const KNOWN: [&str; 10] = [
    "exposure_s",
    "gain_db",
    "photons",
    "illuminance_lux",
    "mean_dn",
    "temporal_var_dn2",
    "spatial_var_dn2",
    "dark_mean_dn",
    "dark_var_dn2",
    "pixels",
];

/// Reads a photon-transfer CSV file.
pub fn read_ptc(path: &Path) -> Result<Vec<PtcRow>, PtcError> {
    let text = std::fs::read_to_string(path).map_err(|source| PtcError::Io { path: path.to_path_buf(), source })?;
    parse_ptc(&text, path)
}

/// Parses photon-transfer CSV text; `path` names the file in errors.
pub fn parse_ptc(text: &str, path: &Path) -> Result<Vec<PtcRow>, PtcError> {
    let err = |line: usize, message: String| PtcError::Syntax { path: path.to_path_buf(), line, message };
    let mut lines =
        text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((header_line, header)) = lines.next() else {
        return Err(err(1, format!("empty file; expected a header with columns {}", REQUIRED.join(", "))));
    };
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    for c in &columns {
        if !KNOWN.contains(c) {
            return Err(err(header_line, format!("unknown column '{c}'; expected some of {}", KNOWN.join(", "))));
        }
    }
    let find = |name: &str| columns.iter().position(|c| *c == name);
    for name in ["exposure_s", "gain_db", "mean_dn", "temporal_var_dn2"] {
        if find(name).is_none() {
            return Err(err(header_line, format!("missing column '{name}'")));
        }
    }
    if find("photons").is_none() && find("illuminance_lux").is_none() {
        return Err(err(header_line, "missing column 'photons' or 'illuminance_lux'".into()));
    }
    if find("dark_mean_dn").is_some() != find("dark_var_dn2").is_some() {
        return Err(err(header_line, "columns 'dark_mean_dn' and 'dark_var_dn2' go together".into()));
    }
    let mut rows = Vec::new();
    for (line, text) in lines {
        let cells: Vec<&str> = text.split(',').map(str::trim).collect();
        if cells.len() != columns.len() {
            return Err(err(line, format!("{} fields; expected {} as in the header", cells.len(), columns.len())));
        }
        let get = |name: &str| -> Result<Option<f64>, PtcError> {
            let Some(i) = find(name) else { return Ok(None) };
            let s = cells[i];
            if s.is_empty() {
                return Ok(None);
            }
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(Some)
                .ok_or_else(|| err(line, format!("column '{name}': expected a number, found '{s}'")))
        };
        let need = |name: &str| -> Result<f64, PtcError> {
            get(name)?.ok_or_else(|| err(line, format!("column '{name}' is empty; expected a number")))
        };
        let row = PtcRow {
            line,
            exposure_s: need("exposure_s")?,
            gain_db: need("gain_db")?,
            photons: get("photons")?,
            illuminance_lux: get("illuminance_lux")?,
            mean_dn: need("mean_dn")?,
            temporal_var_dn2: need("temporal_var_dn2")?,
            spatial_var_dn2: get("spatial_var_dn2")?,
            dark_mean_dn: get("dark_mean_dn")?,
            dark_var_dn2: get("dark_var_dn2")?,
            pixels: get("pixels")?,
        };
        if row.pixels.is_some_and(|p| p < 1.0 || p.fract() != 0.0) {
            return Err(err(line, "column 'pixels': expected a whole number of at least 1".into()));
        }
        if row.photons.is_none() && row.illuminance_lux.is_none() {
            return Err(err(line, "no light level: expected 'photons' or 'illuminance_lux'".into()));
        }
        if row.temporal_var_dn2 < 0.0 || row.light() < 0.0 || row.exposure_s < 0.0 {
            return Err(err(line, "exposure, light and variance must be non-negative".into()));
        }
        rows.push(row);
    }
    if rows.is_empty() {
        return Err(err(header_line, "no data rows after the header".into()));
    }
    Ok(rows)
}
