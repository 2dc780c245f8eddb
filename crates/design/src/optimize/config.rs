//! The optimizer's configuration: a TOML file read over the defaults of the repository's
//! `optimize.toml`, which is embedded in the binary and documents every key.
//!
//! Defaults work per key: a key the user's file leaves out takes its value from the embedded
//! file (a gene table, when given, must be complete, because its bounds only make sense
//! together). Unknown keys are refused, and every error names the file, the line and the field.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

use crate::evaluate::{DetectorChoice, EvalConfig, FitnessWeights, FrameWidth};
use scene_gen_camera::camera_spec::CameraSpec;
use scene_gen_scene::house::HouseOptions;

/// The default configuration, and the documentation of every key.
pub const EMBEDDED_TOML: &str = include_str!("../../../../optimize.toml");

/// Everything an optimization run depends on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OptimizeConfig {
    /// Seed of every random stream of the optimizer.
    #[serde(default = "d_seed")]
    pub seed: u64,
    /// The fixed part of every candidate; enabled genes overwrite its fields.
    #[serde(default = "d_camera")]
    pub camera: CameraSpec,
    #[serde(default = "d_ga")]
    pub ga: GaConfig,
    #[serde(default = "d_genes")]
    pub genes: Genes,
    #[serde(default = "d_evaluation")]
    pub evaluation: Evaluation,
    /// The houses candidates are evaluated in (`[house]`); left out of records when default.
    #[serde(default, skip_serializing_if = "HouseOptions::is_default")]
    pub house: HouseOptions,
}

/// The genetic algorithm's sizes and mutation (TaCOS: 10, 20, 5, 3, 0.8..1.2, +-3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaConfig {
    #[serde(default = "d_population")]
    pub population: usize,
    #[serde(default = "d_generations")]
    pub generations: usize,
    #[serde(default = "d_parents")]
    pub parents: usize,
    #[serde(default = "d_elites")]
    pub elites: usize,
    #[serde(default = "d_scale_min")]
    pub scale_min: f64,
    #[serde(default = "d_scale_max")]
    pub scale_max: f64,
    #[serde(default = "d_sensor_max_step")]
    pub sensor_max_step: usize,
}

/// The sensor gene: an index into the catalog sorted by active area.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorGene {
    #[serde(default = "d_true")]
    pub enabled: bool,
}

/// A continuous gene: its range and the `a` of its additive mutation U(-a, a).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeneRange {
    #[serde(default = "d_true")]
    pub enabled: bool,
    pub min: f64,
    pub max: f64,
    pub additive: f64,
}

/// Every gene the optimizer knows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Genes {
    #[serde(default = "d_sensor")]
    pub sensor: SensorGene,
    #[serde(default = "d_focal")]
    pub focal_mm: GeneRange,
    #[serde(default = "d_pitch")]
    pub pitch_deg: GeneRange,
    #[serde(default = "d_height")]
    pub height_m: GeneRange,
    #[serde(default = "d_gain_day")]
    pub gain_day_db: GeneRange,
    #[serde(default = "d_gain_night")]
    pub gain_night_db: GeneRange,
    #[serde(default = "d_exposure")]
    pub exposure_s: GeneRange,
}

/// Which fitness is maximised.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FitnessChoice {
    /// Mean of day and night (the default).
    Mean,
    Day,
    Night,
}

/// How a candidate is evaluated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Evaluation {
    #[serde(default = "d_seeds")]
    pub seeds: Vec<u64>,
    #[serde(default = "d_frames")]
    pub frames_per_scene: u32,
    #[serde(default = "d_max_width")]
    pub max_width_px: FrameWidth,
    #[serde(default = "d_fitness")]
    pub fitness: FitnessChoice,
    /// `cnn` (the learned detector), `model` (the fast detectability model) or an external
    /// command ([`DetectorChoice::parse`]).
    #[serde(default = "d_detector")]
    pub detector: String,
    #[serde(default = "d_weights")]
    pub weights: Weights,
}

/// Fitness weights (TaCOS: 1, 1, 0.0025, 0.5).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Weights {
    #[serde(default = "d_w_threshold")]
    pub threshold: f64,
    #[serde(default = "d_w_ap50")]
    pub ap50: f64,
    #[serde(default = "d_w_inliers")]
    pub inliers: f64,
    #[serde(default = "d_w_inlier_ratio")]
    pub inlier_ratio: f64,
}

/// A configuration that cannot be used; each names the file and, where it can, the line.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("cannot read optimizer config {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {}{message}", path.display(), key.as_ref().map(|k| format!("{k}: ")).unwrap_or_default())]
    Toml { path: PathBuf, line: usize, key: Option<String>, message: String },
    #[error("{}{}: field {field}: {why}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Field { path: PathBuf, line: Option<usize>, field: String, why: String },
}

/// The embedded defaults, parsed once. The embedded file gives every key, so parsing it never
/// calls the default functions below (a unit test checks that it parses).
fn embedded() -> &'static OptimizeConfig {
    static DEFAULTS: OnceLock<OptimizeConfig> = OnceLock::new();
    DEFAULTS.get_or_init(|| match toml::from_str(EMBEDDED_TOML) {
        Ok(config) => config,
        Err(e) => panic!("the embedded optimize.toml does not parse (a build defect): {e}"),
    })
}

fn d_true() -> bool {
    true
}
fn d_seed() -> u64 {
    embedded().seed
}
fn d_camera() -> CameraSpec {
    embedded().camera.clone()
}
fn d_ga() -> GaConfig {
    embedded().ga.clone()
}
fn d_population() -> usize {
    embedded().ga.population
}
fn d_generations() -> usize {
    embedded().ga.generations
}
fn d_parents() -> usize {
    embedded().ga.parents
}
fn d_elites() -> usize {
    embedded().ga.elites
}
fn d_scale_min() -> f64 {
    embedded().ga.scale_min
}
fn d_scale_max() -> f64 {
    embedded().ga.scale_max
}
fn d_sensor_max_step() -> usize {
    embedded().ga.sensor_max_step
}
fn d_genes() -> Genes {
    embedded().genes.clone()
}
fn d_sensor() -> SensorGene {
    embedded().genes.sensor.clone()
}
fn d_focal() -> GeneRange {
    embedded().genes.focal_mm
}
fn d_pitch() -> GeneRange {
    embedded().genes.pitch_deg
}
fn d_height() -> GeneRange {
    embedded().genes.height_m
}
fn d_gain_day() -> GeneRange {
    embedded().genes.gain_day_db
}
fn d_gain_night() -> GeneRange {
    embedded().genes.gain_night_db
}
fn d_exposure() -> GeneRange {
    embedded().genes.exposure_s
}
fn d_evaluation() -> Evaluation {
    embedded().evaluation.clone()
}
fn d_seeds() -> Vec<u64> {
    embedded().evaluation.seeds.clone()
}
fn d_frames() -> u32 {
    embedded().evaluation.frames_per_scene
}
fn d_max_width() -> FrameWidth {
    embedded().evaluation.max_width_px
}
fn d_fitness() -> FitnessChoice {
    embedded().evaluation.fitness
}
fn d_detector() -> String {
    embedded().evaluation.detector.clone()
}
fn d_weights() -> Weights {
    embedded().evaluation.weights
}
fn d_w_threshold() -> f64 {
    embedded().evaluation.weights.threshold
}
fn d_w_ap50() -> f64 {
    embedded().evaluation.weights.ap50
}
fn d_w_inliers() -> f64 {
    embedded().evaluation.weights.inliers
}
fn d_w_inlier_ratio() -> f64 {
    embedded().evaluation.weights.inlier_ratio
}

impl Default for OptimizeConfig {
    /// The embedded `optimize.toml`.
    fn default() -> Self {
        embedded().clone()
    }
}

/// The 1-based line of byte `offset` in `text`.
fn line_of_offset(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].bytes().filter(|&b| b == b'\n').count() + 1
}

/// The line where `field` (a dotted path) is set in `text`, found by its last key at the
/// start of a line; `None` when the value came from the defaults.
fn line_of_field(text: &str, field: &str) -> Option<usize> {
    let key = field.rsplit('.').next().unwrap_or(field);
    text.lines()
        .position(|l| {
            let l = l.trim_start();
            l.strip_prefix(key).is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map(|i| i + 1)
}

/// The dotted key set on 1-based `line` of `text` (`ga.population` for `population = ...`
/// under `[ga]`), or the table a header line opens; `None` for any other line. TOML's own
/// errors give the position but, for a wrongly typed value, not the key.
fn key_path_at_line(text: &str, line: usize) -> Option<String> {
    let mut table = String::new();
    for (i, l) in text.lines().enumerate().take(line) {
        let l = l.trim();
        let header = l.strip_prefix('[').map(|h| h.trim_start_matches('[').split(']').next().unwrap_or("").trim());
        if let Some(h) = header {
            table = h.to_string();
            if i + 1 == line {
                return (!table.is_empty()).then(|| table.clone());
            }
        } else if i + 1 == line {
            let key = l.split_once('=')?.0.trim().trim_matches('"');
            return (!key.is_empty())
                .then(|| if table.is_empty() { key.to_string() } else { format!("{table}.{key}") });
        }
    }
    None
}

impl OptimizeConfig {
    /// Reads the file at `path` over the defaults.
    ///
    /// # Errors
    /// [`ConfigError`] naming the file, line and field.
    pub fn from_file(path: &Path) -> Result<OptimizeConfig, ConfigError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| ConfigError::Io { path: path.to_path_buf(), source })?;
        OptimizeConfig::from_toml(&text, path)
    }

    /// Parses TOML text over the defaults (`path` is only for messages).
    ///
    /// # Errors
    /// [`ConfigError::Toml`] with the line, or [`ConfigError::Field`] from
    /// [`OptimizeConfig::validate`].
    pub fn from_toml(text: &str, path: &Path) -> Result<OptimizeConfig, ConfigError> {
        let config: OptimizeConfig = toml::from_str(text).map_err(|e| {
            let line = line_of_offset(text, e.span().map_or(0, |s| s.start));
            ConfigError::Toml {
                path: path.to_path_buf(),
                line,
                key: key_path_at_line(text, line),
                message: e.message().trim().to_string(),
            }
        })?;
        config.validate().map_err(|(field, why)| ConfigError::Field {
            path: path.to_path_buf(),
            line: line_of_field(text, &field),
            field,
            why,
        })?;
        Ok(config)
    }

    /// The continuous genes by their key, in the fixed order of the CSV columns.
    #[must_use]
    pub fn gene_ranges(&self) -> [(&'static str, GeneRange); 6] {
        let g = &self.genes;
        [
            ("focal_mm", g.focal_mm),
            ("pitch_deg", g.pitch_deg),
            ("height_m", g.height_m),
            ("gain_day_db", g.gain_day_db),
            ("gain_night_db", g.gain_night_db),
            ("exposure_s", g.exposure_s),
        ]
    }

    /// Checks every number; the error is `(dotted field, why)`.
    ///
    /// # Errors
    /// The first offending field.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let bad = |field: &str, why: String| Err((field.to_string(), why));
        if let Err(e) = self.house.validate() {
            return bad("house", e.to_string());
        }
        let ga = &self.ga;
        if ga.population < 2 {
            return bad("ga.population", format!("must be at least 2, got {}", ga.population));
        }
        if ga.generations < 1 {
            return bad("ga.generations", "must be at least 1".into());
        }
        if !(1..=ga.population).contains(&ga.parents) {
            return bad("ga.parents", format!("must be 1..=population ({}), got {}", ga.population, ga.parents));
        }
        if ga.elites >= ga.population {
            return bad("ga.elites", format!("must be below population ({}), got {}", ga.population, ga.elites));
        }
        if ga.elites > ga.parents {
            return bad("ga.elites", format!("must be at most parents ({}), got {}", ga.parents, ga.elites));
        }
        if !(ga.scale_min.is_finite() && ga.scale_max.is_finite() && ga.scale_min <= ga.scale_max) {
            return bad(
                "ga.scale_min",
                format!("need finite scale_min <= scale_max, got {} and {}", ga.scale_min, ga.scale_max),
            );
        }
        for (name, r) in self.gene_ranges() {
            let field = format!("genes.{name}");
            if !(r.min.is_finite() && r.max.is_finite() && r.min <= r.max) {
                return bad(&format!("{field}.min"), format!("need finite min <= max, got {} and {}", r.min, r.max));
            }
            if !(r.additive.is_finite() && r.additive >= 0.0) {
                return bad(&format!("{field}.additive"), format!("must be finite and >= 0, got {}", r.additive));
            }
            let positive = matches!(name, "focal_mm" | "height_m" | "exposure_s");
            if r.enabled && positive && r.min <= 0.0 {
                return bad(&format!("{field}.min"), format!("must be > 0, got {}", r.min));
            }
            if r.enabled && name == "pitch_deg" && (r.min < -90.0 || r.max > 90.0) {
                return bad(
                    &format!("{field}.min"),
                    format!("range must lie within -90..90, got {}..{}", r.min, r.max),
                );
            }
        }
        if let Err(e) = self.camera.validate() {
            return bad("camera", e.to_string());
        }
        // A camera at or above the ceiling sees the houses' roof from outside.
        let ceiling_m = self.house.envelope.height_m;
        let height = self.genes.height_m;
        if height.enabled && f64::from(ceiling_m) <= height.max {
            return bad(
                "genes.height_m.max",
                format!("must be below the envelope height {ceiling_m} m, got {}", height.max),
            );
        }
        if !height.enabled && self.camera.height_m >= ceiling_m {
            return bad(
                "camera.height_m",
                format!("must be below the envelope height {ceiling_m} m, got {}", self.camera.height_m),
            );
        }
        if scene_gen_camera::sensor::Catalog::embedded().get(&self.camera.sensor).is_none() {
            return bad("camera.sensor", format!("unknown sensor '{}' (see `scene-gen sensors`)", self.camera.sensor));
        }
        let ev = &self.evaluation;
        if ev.seeds.is_empty() {
            return bad("evaluation.seeds", "must name at least one house seed".into());
        }
        if ev.frames_per_scene == 0 {
            return bad("evaluation.frames_per_scene", "must be at least 1".into());
        }
        if DetectorChoice::parse(&ev.detector).is_none() {
            return bad("evaluation.detector", "must be \"cnn\", \"model\" or a detector command".into());
        }
        let w = ev.weights;
        for (name, v) in
            [("threshold", w.threshold), ("ap50", w.ap50), ("inliers", w.inliers), ("inlier_ratio", w.inlier_ratio)]
        {
            if !v.is_finite() {
                return bad(&format!("evaluation.weights.{name}"), format!("must be finite, got {v}"));
            }
        }
        Ok(())
    }

    /// The evaluator's settings for this configuration.
    #[must_use]
    pub fn eval_config(&self) -> EvalConfig {
        let w = self.evaluation.weights;
        EvalConfig {
            frames_per_scene: self.evaluation.frames_per_scene,
            max_width_px: self.evaluation.max_width_px,
            weights: FitnessWeights {
                threshold: w.threshold,
                ap50: w.ap50,
                inliers: w.inliers,
                inlier_ratio: w.inlier_ratio,
            },
            detector: DetectorChoice::parse(&self.evaluation.detector).unwrap_or_default(),
            house: self.house.clone(),
            ..EvalConfig::default()
        }
    }

    /// Evaluations of a run of `generations`: the first generation in full, then the offspring
    /// of each later one (elites keep their score). Random search gets the same budget.
    #[must_use]
    pub fn budget(&self) -> usize {
        self.ga.population + (self.ga.generations - 1) * (self.ga.population - self.ga.elites)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `[house]` reaches the evaluator, is recorded only when it is not the default, and an
    /// impossible house is refused naming the section.
    #[test]
    fn house_section_reaches_the_evaluator() {
        let path = Path::new("house.toml");
        assert!(OptimizeConfig::default().house.is_default());
        let c = OptimizeConfig::from_toml("[house]\nenvelope = \"9x11x2.6\"\nmin_room_m = 4.5\n", path).unwrap();
        assert_eq!(c.eval_config().house, c.house);
        assert_eq!((c.house.envelope.width_m, c.house.envelope.depth_m, c.house.min_room_m), (9.0, 11.0, 4.5));
        assert!(serde_json::to_string(&c).unwrap().contains("\"house\":{\"envelope\":\"9x11x2.6\""));
        assert!(!serde_json::to_string(&OptimizeConfig::default()).unwrap().contains("house"));
        let e = OptimizeConfig::from_toml("[house]\nmin_room_m = 1.0\n", path).unwrap_err().to_string();
        assert!(e.contains("house") && e.contains("--min-room 1"), "{e}");
        let e = OptimizeConfig::from_toml("[house]\nenvelope = \"9x11\"\n", path).unwrap_err().to_string();
        assert!(e.contains("house.toml:2") && e.contains("WIDTHxDEPTHxHEIGHT"), "{e}");
    }

    /// `evaluation.detector` reaches the evaluator: the learned detector unless it says otherwise.
    #[test]
    fn detector_key_chooses_the_evaluators_detector() {
        let path = Path::new("d.toml");
        assert_eq!(OptimizeConfig::default().eval_config().detector, DetectorChoice::Cnn);
        let c = OptimizeConfig::from_toml("[evaluation]\ndetector = \"model\"\n", path).unwrap();
        assert_eq!(c.eval_config().detector, DetectorChoice::Model);
        let c = OptimizeConfig::from_toml("[evaluation]\ndetector = \"python3 d.py --gt {gt}\"\n", path).unwrap();
        assert_eq!(c.eval_config().detector.external().map(|e| e.program.as_str()), Some("python3"));
        let e = OptimizeConfig::from_toml("[evaluation]\ndetector = \" \"\n", path).unwrap_err().to_string();
        assert!(e.contains("d.toml") && e.contains("evaluation.detector"), "{e}");
    }

    #[test]
    fn embedded_defaults_are_tacos() {
        let c = OptimizeConfig::default();
        assert_eq!((c.ga.population, c.ga.generations, c.ga.parents, c.ga.elites), (10, 20, 5, 3));
        assert_eq!((c.ga.scale_min, c.ga.scale_max, c.ga.sensor_max_step), (0.8, 1.2, 3));
        assert_eq!((c.genes.focal_mm.min, c.genes.focal_mm.max), (1.0, 20.0));
        assert_eq!((c.genes.pitch_deg.min, c.genes.pitch_deg.max), (-30.0, 30.0));
        assert!(c.genes.sensor.enabled && !c.genes.height_m.enabled);
        assert_eq!(c.evaluation.fitness, FitnessChoice::Mean);
        assert_eq!(c.budget(), 10 + 19 * 7);
        assert!(c.validate().is_ok());
    }

    #[test]
    fn a_file_overrides_single_keys_and_keeps_the_rest() {
        let c = OptimizeConfig::from_toml("[ga]\npopulation = 6\n[evaluation]\nseeds = [5]\n", Path::new("x.toml"))
            .unwrap();
        assert_eq!(c.ga.population, 6);
        assert_eq!(c.ga.generations, 20);
        assert_eq!(c.evaluation.seeds, vec![5]);
        assert_eq!(c.evaluation.frames_per_scene, 25);
        assert_eq!(c.genes, OptimizeConfig::default().genes);
    }

    #[test]
    fn unknown_keys_and_bad_values_name_file_line_and_field() {
        let e = OptimizeConfig::from_toml("seed = 1\n[ga]\npopulaton = 4\n", Path::new("c.toml")).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("c.toml:3:") && msg.contains("populaton"), "{msg}");
        let e = OptimizeConfig::from_toml("[ga]\nelites = 12\n", Path::new("c.toml")).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("c.toml:2") && msg.contains("ga.elites"), "{msg}");
        let e = OptimizeConfig::from_toml("[genes.focal_mm]\nmin = 0\nmax = 5\nadditive = 1\n", Path::new("c.toml"))
            .unwrap_err();
        assert!(e.to_string().contains("genes.focal_mm.min"), "{e}");
        let e = OptimizeConfig::from_toml("[genes.height_m]\nmin = 0.5\n", Path::new("c.toml")).unwrap_err();
        assert!(e.to_string().contains("max"), "{e}");
        // A wrongly typed value: TOML gives only the position; the message adds the key path.
        let e = OptimizeConfig::from_toml("seed = 1\n[ga]\npopulation = \"ten\"\n", Path::new("c.toml")).unwrap_err();
        assert!(e.to_string().starts_with("c.toml:3: ga.population: "), "{e}");
        let e = OptimizeConfig::from_toml("seed = \"x\"\n", Path::new("c.toml")).unwrap_err();
        assert!(e.to_string().starts_with("c.toml:1: seed: "), "{e}");
    }

    /// A camera that could be mounted at or above the ceiling is refused, by the fixed height
    /// or by the height gene's range, against the house envelope of the same file.
    #[test]
    fn a_camera_at_the_ceiling_is_refused() {
        let fixed = "[camera]\nsensor = \"IMX174\"\nheight_m = 2.5\n[house]\nenvelope = \"12x12x2.5\"\n";
        let e = OptimizeConfig::from_toml(fixed, Path::new("c.toml")).unwrap_err();
        assert!(e.to_string().contains("camera.height_m"), "{e}");
        let gene = "[genes.height_m]\nenabled = true\nmin = 0.5\nmax = 3.2\nadditive = 0.1\n";
        let e = OptimizeConfig::from_toml(gene, Path::new("c.toml")).unwrap_err();
        assert!(e.to_string().contains("genes.height_m.max"), "{e}");
        let tall = format!("{gene}[house]\nenvelope = \"12x12x3.5\"\n");
        assert!(OptimizeConfig::from_toml(&tall, Path::new("c.toml")).is_ok());
    }
}
