//! `scene-gen sensors`: print the sensor catalog.

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Args;
use scene_gen::camera_spec::{SpecError, close_names};
use scene_gen::sensor::{Catalog, Colour, FigureKind, Sensor, Shutter};

use super::{CliError, bad_input, failure};

#[derive(Args, Debug)]
pub struct SensorsArgs {
    /// One sensor (case-insensitive): its specification and, for each noise figure, how it was
    /// obtained, from which camera and source, and by which formula.
    pub model: Option<String>,
    /// Print a JSON array instead of a table (with MODEL: that sensor's JSON object).
    #[arg(long)]
    pub json: bool,
    /// Extra sensors (TOML, same schema as the embedded catalog); a model already present is
    /// replaced. May be given more than once.
    #[arg(long)]
    pub catalog: Vec<PathBuf>,
}

pub fn run(args: &SensorsArgs) -> Result<(), CliError> {
    let mut out = String::new();
    let mut catalog = Catalog::embedded();
    for path in &args.catalog {
        catalog.load_extra(path).map_err(bad_input)?;
    }
    if let Some(model) = &args.model {
        return show_one(&catalog, model, args.json);
    }
    if args.json {
        let text = serde_json::to_string_pretty(&catalog.records()).map_err(failure)?;
        emit(&format!("{text}\n"));
        return Ok(());
    }
    let _ = writeln!(
        out,
        "{:<11} {:<8} {:>11} {:>6} {:>15} {:>7} {:<6} {:>4} {:>5} {:>8} {:>5} {:>7}  QE FW RN DC",
        "maker", "model", "resolution", "px_um", "area_mm", "mm2", "shutr", "bits", "QE", "FW_e", "RN_e", "dark_e/s"
    );
    for s in catalog.sensors() {
        let colour = if s.colour == Colour::Mono { " mono" } else { "" };
        let _ = writeln!(
            out,
            "{:<11} {:<8} {:>11} {:>6.2} {:>15} {:>7.2} {:<6} {:>4} {:>5.2} {:>8.0} {:>5.2} {:>7.2}  {}{}",
            s.maker,
            s.model,
            format!("{}x{}", s.resolution[0], s.resolution[1]),
            s.pixel_pitch_um,
            format!("{:.3}x{:.3}", s.active_area_mm[0], s.active_area_mm[1]),
            s.area_mm2(),
            if s.shutter == Shutter::Global { "global" } else { "roll" },
            s.adc_bits,
            s.quantum_efficiency,
            s.full_well_e,
            s.read_noise_e,
            s.dark_current_e_per_s,
            provenance_letters(s),
            colour
        );
    }
    let _ = writeln!(
        out,
        "{} sensors, sorted by active area. Noise figures: m measured, d derived from measured figures, s data \
         sheet, e estimated ({} of them with measured or derived full well and read noise; --json gives each \
         figure's camera, source and formula)",
        catalog.len(),
        catalog.sensors().iter().filter(|s| measured_noise(s)).count()
    );
    emit(&out);
    Ok(())
}

/// `sensors MODEL`: one sensor's specification and the provenance of each noise figure.
fn show_one(catalog: &Catalog, model: &str, json: bool) -> Result<(), CliError> {
    let sensor = catalog.get(model).ok_or_else(|| {
        bad_input(SpecError::UnknownSensor { name: model.to_string(), suggestions: close_names(catalog, model) })
    })?;
    if json {
        let text = serde_json::to_string_pretty(&sensor.record()).map_err(failure)?;
        emit(&format!("{text}\n"));
    } else {
        emit(&describe(sensor));
    }
    Ok(())
}

/// The text of `sensors MODEL`.
fn describe(s: &Sensor) -> String {
    let mut out = String::new();
    let shutter = if s.shutter == Shutter::Global { "global" } else { "rolling" };
    let colour = if s.colour == Colour::Mono { "monochrome" } else { "colour (Bayer)" };
    let _ = writeln!(
        out,
        "{} {}: {}x{} pixels of {} um ({:.3} x {:.3} mm), {shutter} shutter, {} bits, {colour}",
        s.maker,
        s.model,
        s.resolution[0],
        s.resolution[1],
        s.pixel_pitch_um,
        s.active_area_mm[0],
        s.active_area_mm[1],
        s.adc_bits
    );
    let _ = writeln!(out, "specification: {}", s.spec_source);
    if !s.note.is_empty() {
        let _ = writeln!(out, "note: {}", s.note);
    }
    for p in s.provenance() {
        let _ = writeln!(out, "\n{} = {}  ({})", p.field, p.value, kind_names(p.kind).1);
        for (label, text) in [("camera", &p.camera), ("source", &p.source), ("how", &p.how)] {
            if !text.is_empty() {
                let _ = writeln!(out, "  {label}: {text}");
            }
        }
    }
    out
}

/// One letter per noise field (QE, full well, read noise, dark current): how it was obtained.
fn provenance_letters(sensor: &Sensor) -> String {
    let letters: Vec<&str> = sensor.provenance().iter().map(|p| kind_names(p.kind).0).collect();
    letters.join("  ")
}

/// A figure kind's letter in the table and its name in `sensors MODEL`.
fn kind_names(kind: FigureKind) -> (&'static str, &'static str) {
    match kind {
        FigureKind::Measured => ("m", "measured"),
        FigureKind::Derived => ("d", "derived"),
        FigureKind::Datasheet => ("s", "data sheet"),
        FigureKind::Estimated => ("e", "estimated"),
    }
}

/// Whether the sensor's full well and read noise are measured or derived from measurements.
fn measured_noise(sensor: &Sensor) -> bool {
    sensor
        .provenance()
        .iter()
        .filter(|p| p.field == "full_well_e" || p.field == "read_noise_e")
        .all(|p| matches!(p.kind, FigureKind::Measured | FigureKind::Derived))
}

/// Writes command output to stdout; a closed pipe (`| head`) is not an error.
pub fn emit(text: &str) {
    use std::io::Write;
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}
