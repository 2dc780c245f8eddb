//! The plug-in protocol: the evaluator as a long-lived process that any optimizer drives
//! (`scene-gen serve`; Optuna, Nevergrad, a cluster scheduler, a shell script).
//!
//! A driver starts `scene-gen serve`, writes one request per line on its standard input and
//! reads one response per request, in request order, on its standard output; each response is
//! flushed as soon as it is written, so a driver may send one request and wait for its answer.
//! Standard output carries responses only; standard error is free text for people. The
//! process keeps every evaluation it computed (the [`crate::evaluate`] cache is per process), so
//! a candidate an optimizer proposes twice is answered at once the second time. End of input
//! ends the server with exit status 0.
//!
//! # Protocol `scene-gen/serve/2` (JSON lines)
//!
//! Version 2 (release 0.2.0): `mean_inliers` and `inlier_ratio` count only the RANSAC inliers
//! the ground truth confirms (`crate::true_matches`), and `mean_ransac_inliers` gives every
//! RANSAC inlier (what version 1 called `mean_inliers`). The request is unchanged.
//!
//! **Evaluate** a camera candidate. `camera` is a [`CameraSpec`] object (the fields of a camera
//! TOML file, unknown fields rejected) or the inline string form `SENSOR[,key=value]...`:
//!
//! ```json
//! {"id": 7, "camera": {"sensor": "IMX174", "focal_mm": 4, "pitch_deg": -10}}
//! {"id": "b", "camera": "IMX174,focal_mm=4", "seeds": "0..3", "frames": 5, "max_width": 160}
//! ```
//!
//! Optional fields override the server's defaults (the `scene-gen serve` options) for this
//! request only:
//! * `seeds`: `"A..B"` (half-open), `"A..=B"`, one seed `3`, or a list `[0, 4, 9]`;
//! * `frames`: anchor frames per house (at least 1);
//! * `max_width`: bin the sensor to at most this many pixels across (at least 1), or
//!   `"native"` for every pixel of the sensor; without it the camera's own `max_width_px`, else
//!   the server default;
//! * `weights`: fitness weights, any of `{"threshold", "ap50", "inliers", "inlier_ratio"}`
//!   (the rest keep the TaCOS values);
//! * `id`: any JSON value, echoed in the response (`null` when absent).
//!
//! The answer (`fitness` and `scenarios` as in `scene-gen evaluate --json`; `camera` is the
//! candidate as evaluated, with the catalog's spelling of the sensor; `cached` says it came
//! from this process's cache; `seconds` is the wall time of this request):
//!
//! ```json
//! {"id": 7, "ok": true, "camera": {"sensor": "IMX174", "focal_mm": 4.0, ...}, "seeds": [0],
//!  "frames": 25, "max_width": 320, "fitness": {"day": 0.41, "night": 0.22, "mean": 0.31},
//!  "scenarios": {"day": {...}, "night": {...}}, "cached": false, "seconds": 1.2}
//! ```
//!
//! **Describe** the server, so a driver needs no hard-coded list:
//!
//! ```json
//! {"id": 0, "op": "describe"}
//! {"id": 0, "ok": true, "op": "describe", "protocol": "scene-gen/serve/2",
//!  "sensors": ["PYTHON300", "IMX219", ..., "AM41"],
//!  "genes": {"sensor": {"type": "categorical", "choices": "sensors"},
//!            "focal_mm": {"type": "float", "min": 1.0, "max": 20.0},
//!            "pitch_deg": {"type": "float", "min": -30.0, "max": 30.0}},
//!  "defaults": {"seeds": [0], "frames": 25, "max_width": 320, "detector": "cnn"},
//!  "weights": {"threshold": 1.0, "ap50": 1.0, "inliers": 0.0025, "inlier_ratio": 0.5}}
//! ```
//!
//! `sensors` are the catalog's model names ordered by active area, smallest first (the order
//! in which the TaCOS GA mutates the sensor gene); the gene ranges are TaCOS's design space
//! (docs/REFERENCE.md, "Genetic algorithm").
//!
//! **Errors** are responses too, in their place in the order; the server never stops on a bad
//! request:
//!
//! ```json
//! {"id": null, "ok": false, "error": {"kind": "bad_request", "message": "not JSON: ...", "line": 3}}
//! {"id": 9, "ok": false, "error": {"kind": "bad_camera", "message": "unknown sensor 'IMX999'; ...", "line": 4}}
//! ```
//!
//! `kind` is `bad_request` (not JSON, not an object, an unknown or ill-typed field, no camera,
//! bad seeds/frames/width), `bad_camera` (the camera spec is malformed, out of range, names
//! no catalog sensor or mounts the camera at or above the ceiling) or `failure` (the
//! evaluation itself failed; the same request may succeed on another server). `line` is the
//! 1-based line number of the request in the input. `id` is the request's id whenever the line
//! was a JSON object with one. Blank lines are ignored (no
//! response). A response always has `"ok"`; a driver checks it first.
//!
//! The version string changes when a field changes meaning or disappears; fields may be added
//! to responses within a version, so drivers ignore fields they do not know.

use std::io::{self, BufRead, Write};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::time::Instant;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::evaluate::{self, DetectorChoice, EvalConfig, Fitness, FitnessWeights, FrameWidth, Scenarios};
use scene_gen_camera::camera_spec::{CameraSpec, SpecError};
use scene_gen_camera::sensor::Catalog;
use scene_gen_core::seeds::SeedRange;
use scene_gen_scene::house::HouseOptions;

/// The protocol version every `describe` response names.
pub const PROTOCOL: &str = "scene-gen/serve/2";

/// TaCOS's focal-length gene range, mm (docs/REFERENCE.md: 1..20 mm).
pub const FOCAL_RANGE_MM: [f64; 2] = [1.0, 20.0];
/// TaCOS's pitch gene range, degrees (docs/REFERENCE.md: -30..30 deg).
pub const PITCH_RANGE_DEG: [f64; 2] = [-30.0, 30.0];

/// Most seeds one request may name: a typo like `0..1000000000` must be a bad request, not
/// an allocation of gigabytes and a day of rendering.
pub const MAX_SEEDS: usize = 4096;

/// What a request that does not say gets (the `scene-gen serve` options).
#[derive(Clone, Debug, PartialEq)]
pub struct ServeDefaults {
    pub seeds: Vec<u64>,
    pub frames: u32,
    pub max_width: FrameWidth,
    /// The houses every request is evaluated in (`serve --envelope ...`).
    pub house: HouseOptions,
    /// The detector of every request (`serve --detector`).
    pub detector: DetectorChoice,
}

impl Default for ServeDefaults {
    /// `scene-gen evaluate`'s defaults: seed 0, its frame count and width.
    fn default() -> Self {
        ServeDefaults {
            seeds: vec![0],
            frames: evaluate::DEFAULT_FRAMES_PER_SCENE,
            max_width: FrameWidth::AtMost(evaluate::DEFAULT_MAX_WIDTH_PX),
            house: HouseOptions::default(),
            detector: DetectorChoice::default(),
        }
    }
}

/// Why a request was refused or failed (the response's `error.kind`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorKind {
    /// Not JSON, not an object, an unknown or ill-typed field, missing camera, bad options.
    BadRequest,
    /// The camera spec is malformed, out of range, or names no catalog sensor.
    BadCamera,
    /// The evaluation failed while working.
    Failure,
}

/// A refused or failed request.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{kind:?}: {message}")]
pub struct RequestError {
    pub kind: ErrorKind,
    pub message: String,
}

impl RequestError {
    fn bad_request(message: impl Into<String>) -> Self {
        RequestError { kind: ErrorKind::BadRequest, message: message.into() }
    }
    fn bad_camera(message: impl Into<String>) -> Self {
        RequestError { kind: ErrorKind::BadCamera, message: message.into() }
    }
}

/// What a request asks for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Op {
    #[default]
    Evaluate,
    Describe,
}

/// A camera as a request gives it: the inline string form or a spec object.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(untagged, expecting = "`camera`: a camera spec object or an inline string SENSOR[,key=value]...")]
pub enum CameraField {
    Inline(String),
    /// Kept as JSON so a bad spec is reported as `bad_camera`, not as a bad request.
    Spec(serde_json::Map<String, Value>),
}

/// Seeds as a request gives them.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(untagged, expecting = "`seeds`: \"A..B\", \"A..=B\", a seed or a list of seeds (whole numbers >= 0)")]
pub enum SeedsField {
    One(u64),
    List(Vec<u64>),
    Range(String),
}

/// Fitness weights a request overrides; absent ones keep their default.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeightsField {
    pub threshold: Option<f64>,
    pub ap50: Option<f64>,
    pub inliers: Option<f64>,
    pub inlier_ratio: Option<f64>,
}

/// One request line.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Request {
    #[serde(default)]
    pub id: Value,
    #[serde(default)]
    pub op: Op,
    pub camera: Option<CameraField>,
    pub seeds: Option<SeedsField>,
    pub frames: Option<u32>,
    #[serde(default, deserialize_with = "max_width_field")]
    pub max_width: Option<FrameWidth>,
    pub weights: Option<WeightsField>,
}

/// A request checked and completed with the defaults: what is evaluated.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    pub camera: CameraSpec,
    pub seeds: Vec<u64>,
    pub frames: u32,
    pub max_width: FrameWidth,
    pub weights: FitnessWeights,
    pub house: HouseOptions,
    pub detector: DetectorChoice,
}

impl Job {
    /// The evaluator configuration of this job.
    #[must_use]
    pub fn config(&self) -> EvalConfig {
        EvalConfig {
            frames_per_scene: self.frames,
            max_width_px: self.max_width,
            weights: self.weights,
            house: self.house.clone(),
            detector: self.detector.clone(),
            ..EvalConfig::default()
        }
    }
}

/// An evaluation answer.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EvalResponse {
    pub id: Value,
    pub ok: bool,
    pub camera: CameraSpec,
    pub seeds: Vec<u64>,
    pub frames: u32,
    pub max_width: FrameWidth,
    pub fitness: Fitness,
    pub scenarios: Scenarios,
    pub cached: bool,
    pub seconds: f64,
}

/// A gene an optimizer searches.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Gene {
    /// One of the names listed under `choices` (`"sensors"`: the response's sensor list).
    Categorical {
        choices: String,
    },
    Float {
        min: f64,
        max: f64,
    },
}

/// The genes of the TaCOS design space.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Genes {
    pub sensor: Gene,
    pub focal_mm: Gene,
    pub pitch_deg: Gene,
}

/// The defaults as a describe response states them.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DefaultsOut {
    pub seeds: Vec<u64>,
    pub frames: u32,
    pub max_width: FrameWidth,
    #[serde(skip_serializing_if = "HouseOptions::is_default")]
    pub house: HouseOptions,
    pub detector: DetectorChoice,
}

/// A describe answer.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DescribeResponse {
    pub id: Value,
    pub ok: bool,
    pub op: &'static str,
    pub protocol: &'static str,
    /// Catalog model names, smallest active area first.
    pub sensors: Vec<String>,
    pub genes: Genes,
    pub defaults: DefaultsOut,
    pub weights: FitnessWeights,
}

/// The body of an error answer.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ErrorBody {
    pub kind: ErrorKind,
    pub message: String,
    pub line: u64,
}

/// An error answer.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ErrorResponse {
    pub id: Value,
    pub ok: bool,
    pub error: ErrorBody,
}

/// Counts of one run of the server, for the caller's log.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ServeSummary {
    /// Requests answered (blank lines excluded).
    pub requests: u64,
    /// Of which answered with an error.
    pub errors: u64,
}

/// `A..B` (half-open), `A..=B` or one seed; at most [`MAX_SEEDS`], at least one.
///
/// # Errors
/// A message naming the text when it is none of these forms, empty or too long.
pub fn parse_seeds(text: &str) -> Result<Vec<u64>, String> {
    let range: SeedRange = text.parse().map_err(|e: scene_gen_core::seeds::SeedsError| e.to_string())?;
    if range.len() > MAX_SEEDS as u64 {
        return Err(format!("seeds '{text}': at most {MAX_SEEDS} seeds per request"));
    }
    Ok(range.iter().collect())
}

fn seeds_of(field: &SeedsField) -> Result<Vec<u64>, RequestError> {
    let seeds = match field {
        SeedsField::One(s) => vec![*s],
        SeedsField::List(list) => list.clone(),
        SeedsField::Range(text) => parse_seeds(text).map_err(RequestError::bad_request)?,
    };
    if seeds.is_empty() {
        return Err(RequestError::bad_request("seeds: the list is empty"));
    }
    if seeds.len() > MAX_SEEDS {
        return Err(RequestError::bad_request(format!("seeds: at most {MAX_SEEDS} seeds per request")));
    }
    Ok(seeds)
}

fn spec_error(e: &SpecError) -> RequestError {
    RequestError::bad_camera(format!("camera: {e}"))
}

/// The camera of a request, checked against the catalog (sensor name as the catalog spells it).
///
/// # Errors
/// `bad_camera`: a malformed or out-of-range spec, or an unknown sensor.
pub fn camera_of(field: &CameraField, catalog: &Catalog) -> Result<CameraSpec, RequestError> {
    let mut spec = match field {
        CameraField::Inline(text) => CameraSpec::from_inline(text).map_err(|e| spec_error(&e))?,
        CameraField::Spec(map) => serde_json::from_value::<CameraSpec>(Value::Object(map.clone()))
            .map_err(|e| RequestError::bad_camera(format!("camera: {e}")))?,
    };
    spec.validate().map_err(|e| spec_error(&e))?;
    let resolved = spec.resolve(catalog).map_err(|e| spec_error(&e))?;
    spec.sensor = resolved.sensor.model;
    Ok(spec)
}

/// A request's `max_width`, its error naming the field (serde's own message does not).
fn max_width_field<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<Option<FrameWidth>, D::Error> {
    Option::<FrameWidth>::deserialize(deserializer).map_err(|e| serde::de::Error::custom(format!("max_width: {e}")))
}

fn positive(name: &str, v: Option<u32>, default: u32) -> Result<u32, RequestError> {
    match v {
        Some(0) => Err(RequestError::bad_request(format!("{name} must be at least 1"))),
        Some(n) => Ok(n),
        None => Ok(default),
    }
}

fn weights_of(field: Option<&WeightsField>) -> Result<FitnessWeights, RequestError> {
    let mut w = FitnessWeights::default();
    if let Some(f) = field {
        for (name, value, slot) in [
            ("threshold", f.threshold, &mut w.threshold),
            ("ap50", f.ap50, &mut w.ap50),
            ("inliers", f.inliers, &mut w.inliers),
            ("inlier_ratio", f.inlier_ratio, &mut w.inlier_ratio),
        ] {
            if let Some(v) = value {
                if !v.is_finite() {
                    return Err(RequestError::bad_request(format!("weights.{name} must be finite")));
                }
                *slot = v;
            }
        }
    }
    Ok(w)
}

/// Completes an evaluate request with the defaults and checks it.
///
/// # Errors
/// `bad_request` for the request's own fields, `bad_camera` for its camera.
pub fn job_of(request: &Request, defaults: &ServeDefaults, catalog: &Catalog) -> Result<Job, RequestError> {
    let camera_field = request.camera.as_ref().ok_or_else(|| RequestError::bad_request("missing field `camera`"))?;
    let seeds = match &request.seeds {
        Some(s) => seeds_of(s)?,
        None => defaults.seeds.clone(),
    };
    let frames = positive("frames", request.frames, defaults.frames)?;
    let weights = weights_of(request.weights.as_ref())?;
    let camera = camera_of(camera_field, catalog)?;
    // The request's width wins, then the camera's own, then the server's.
    let max_width =
        request.max_width.unwrap_or_else(|| camera.max_width_px.map_or(defaults.max_width, FrameWidth::AtMost));
    Ok(Job {
        camera,
        seeds,
        frames,
        max_width,
        weights,
        house: defaults.house.clone(),
        detector: defaults.detector.clone(),
    })
}

/// The describe answer.
#[must_use]
pub fn describe(id: Value, defaults: &ServeDefaults, catalog: &Catalog) -> DescribeResponse {
    DescribeResponse {
        id,
        ok: true,
        op: "describe",
        protocol: PROTOCOL,
        sensors: catalog.sensors().iter().map(|s| s.model.clone()).collect(),
        genes: Genes {
            sensor: Gene::Categorical { choices: "sensors".to_string() },
            focal_mm: Gene::Float { min: FOCAL_RANGE_MM[0], max: FOCAL_RANGE_MM[1] },
            pitch_deg: Gene::Float { min: PITCH_RANGE_DEG[0], max: PITCH_RANGE_DEG[1] },
        },
        defaults: DefaultsOut {
            seeds: defaults.seeds.clone(),
            frames: defaults.frames,
            max_width: defaults.max_width,
            house: defaults.house.clone(),
            detector: defaults.detector.clone(),
        },
        weights: FitnessWeights::default(),
    }
}

/// Runs a job through the evaluator (its per-process cache included).
///
/// # Errors
/// `bad_camera`/`bad_request` when the evaluator refuses the input, `failure` when it fails
/// while working or panics (the panic is caught: one candidate must not end the run).
pub fn run_job(id: Value, job: &Job) -> Result<EvalResponse, RequestError> {
    let start = Instant::now();
    let config = job.config();
    let outcome = catch_unwind(AssertUnwindSafe(|| evaluate::evaluate_traced(&job.camera, &job.seeds, &config)));
    let (evaluation, cached) = match outcome {
        Ok(Ok(v)) => v,
        Ok(Err(e)) => {
            let kind = if e.is_bad_camera() {
                ErrorKind::BadCamera
            } else if e.is_bad_input() {
                ErrorKind::BadRequest
            } else {
                ErrorKind::Failure
            };
            return Err(RequestError { kind, message: e.to_string() });
        }
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| (*s).to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            return Err(RequestError { kind: ErrorKind::Failure, message: format!("evaluator panicked: {what}") });
        }
    };
    let seconds = (start.elapsed().as_secs_f64() * 1000.0).round() / 1000.0;
    Ok(EvalResponse {
        id,
        ok: true,
        camera: job.camera.clone(),
        seeds: job.seeds.clone(),
        frames: job.frames,
        max_width: job.max_width,
        fitness: evaluation.fitness,
        scenarios: evaluation.scenarios,
        cached,
        seconds,
    })
}

fn error_line(id: Value, line: u64, e: RequestError) -> String {
    let response = ErrorResponse { id, ok: false, error: ErrorBody { kind: e.kind, message: e.message, line } };
    serde_json::to_string(&response).unwrap_or_else(|_| {
        format!(r#"{{"id":null,"ok":false,"error":{{"kind":"failure","message":"unserializable","line":{line}}}}}"#)
    })
}

fn ok_line<T: Serialize>(value: &T, id: Value, line: u64) -> String {
    serde_json::to_string(value).unwrap_or_else(|e| {
        error_line(id, line, RequestError { kind: ErrorKind::Failure, message: format!("response: {e}") })
    })
}

/// One response line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Answer {
    /// The JSON response, without the newline.
    pub json: String,
    /// False for an error response.
    pub ok: bool,
}

/// What a request line asks for, checked and completed with the defaults.
#[derive(Clone, Debug, PartialEq)]
pub enum Parsed {
    Describe,
    Evaluate(Box<Job>),
}

/// Parses and checks one request line: `Ok(None)` for a blank line, else the request with its
/// id, or the error with the id recovered as far as the line allows (for its answer).
///
/// # Errors
/// A line that is not a JSON object, a request with an unknown or bad field, or an evaluate
/// request whose camera, seeds or numbers are bad; never an evaluation.
pub fn parse_request(
    text: &str,
    defaults: &ServeDefaults,
    catalog: &Catalog,
) -> Result<Option<(Value, Parsed)>, (Value, RequestError)> {
    let text = text.trim();
    if text.is_empty() {
        return Ok(None);
    }
    let value: Value =
        serde_json::from_str(text).map_err(|e| (Value::Null, RequestError::bad_request(format!("not JSON: {e}"))))?;
    let Value::Object(map) = value else {
        return Err((Value::Null, RequestError::bad_request("a request is a JSON object")));
    };
    // The id is recovered before the full parse so even a request with a bad field is answered
    // under its own id.
    let id = map.get("id").cloned().unwrap_or(Value::Null);
    let request: Request = match serde_json::from_value(Value::Object(map)) {
        Ok(r) => r,
        Err(e) => return Err((id, RequestError::bad_request(e.to_string()))),
    };
    let parsed = match request.op {
        Op::Describe => {
            if request.camera.is_some()
                || request.seeds.is_some()
                || request.frames.is_some()
                || request.max_width.is_some()
                || request.weights.is_some()
            {
                return Err((id, RequestError::bad_request("describe takes no fields besides `id` and `op`")));
            }
            Parsed::Describe
        }
        Op::Evaluate => match job_of(&request, defaults, catalog) {
            Ok(job) => Parsed::Evaluate(Box::new(job)),
            Err(e) => return Err((id, e)),
        },
    };
    Ok(Some((id, parsed)))
}

/// The response to one input line (`line_no` 1-based), or `None` for a blank line.
#[must_use]
pub fn respond(text: &str, line_no: u64, defaults: &ServeDefaults, catalog: &Catalog) -> Option<Answer> {
    let fail = |id: Value, e: RequestError| Some(Answer { json: error_line(id, line_no, e), ok: false });
    let (id, parsed) = match parse_request(text, defaults, catalog) {
        Ok(None) => return None,
        Ok(Some(request)) => request,
        Err((id, e)) => return fail(id, e),
    };
    let answer = match parsed {
        Parsed::Describe => Ok(ok_line(&describe(id.clone(), defaults, catalog), id.clone(), line_no)),
        Parsed::Evaluate(job) => run_job(id.clone(), &job).map(|r| ok_line(&r, id.clone(), line_no)),
    };
    match answer {
        Ok(json) => Some(Answer { json, ok: true }),
        Err(e) => fail(id, e),
    }
}

/// Reads requests from `reader` until end of input and writes one flushed response line per
/// request to `writer` (the protocol of the module doc).
///
/// # Errors
/// Only I/O errors of `reader` or `writer`; a bad request is answered, never returned.
pub fn serve<R: BufRead, W: Write>(mut reader: R, mut writer: W, defaults: &ServeDefaults) -> io::Result<ServeSummary> {
    let catalog = Catalog::embedded();
    let mut summary = ServeSummary::default();
    let mut buf = Vec::new();
    let mut line_no = 0u64;
    loop {
        buf.clear();
        if reader.read_until(b'\n', &mut buf)? == 0 {
            return Ok(summary);
        }
        line_no += 1;
        let response = match std::str::from_utf8(&buf) {
            Ok(text) => respond(text, line_no, defaults, &catalog),
            Err(e) => Some(Answer {
                json: error_line(Value::Null, line_no, RequestError::bad_request(format!("not UTF-8: {e}"))),
                ok: false,
            }),
        };
        if let Some(answer) = response {
            summary.requests += 1;
            summary.errors += u64::from(!answer.ok);
            writer.write_all(answer.json.as_bytes())?;
            writer.write_all(b"\n")?;
            writer.flush()?;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn answer(line: &str) -> Value {
        let out = respond(line, 5, &ServeDefaults::default(), &Catalog::embedded()).expect("a response");
        let v: Value = serde_json::from_str(&out.json).expect("responses are JSON");
        assert_eq!(v["ok"].as_bool(), Some(out.ok));
        v
    }

    fn kind(v: &Value) -> &str {
        v["error"]["kind"].as_str().unwrap_or("none")
    }

    #[test]
    fn seeds_forms() {
        assert_eq!(parse_seeds("0..3"), Ok(vec![0, 1, 2]));
        assert_eq!(parse_seeds(" 2..=4 "), Ok(vec![2, 3, 4]));
        assert_eq!(parse_seeds("7"), Ok(vec![7]));
        assert!(parse_seeds("3..3").is_err());
        assert!(parse_seeds("4..=3").is_err());
        assert!(parse_seeds("a..b").is_err());
        assert!(parse_seeds("-1").is_err());
        assert!(parse_seeds("0..1000000000").unwrap_err().contains("at most"));
        assert_eq!(parse_seeds(&format!("0..{MAX_SEEDS}")).map(|s| s.len()), Ok(MAX_SEEDS));
        assert_eq!(parse_seeds(&format!("{}..={}", u64::MAX - 1, u64::MAX)), Ok(vec![u64::MAX - 1, u64::MAX]));
    }

    #[test]
    fn blank_lines_get_no_response() {
        assert_eq!(respond("  \r\n", 1, &ServeDefaults::default(), &Catalog::embedded()), None);
    }

    #[test]
    fn malformed_json_is_a_bad_request_without_id() {
        let v = answer(r#"{"id": 3, "camera": "#);
        assert_eq!(v["ok"], false);
        assert_eq!(v["id"], Value::Null);
        assert_eq!(kind(&v), "bad_request");
        assert_eq!(v["error"]["line"], 5);
        assert!(v["error"]["message"].as_str().unwrap().starts_with("not JSON"));
        assert_eq!(kind(&answer("[1, 2]")), "bad_request");
    }

    #[test]
    fn unknown_and_ill_typed_fields_keep_the_id() {
        let v = answer(r#"{"id": "x1", "camera": "IMX174", "colour": 3}"#);
        assert_eq!((v["id"].as_str(), kind(&v)), (Some("x1"), "bad_request"));
        assert!(v["error"]["message"].as_str().unwrap().contains("colour"));
        let v = answer(r#"{"id": 2, "camera": "IMX174", "frames": -1}"#);
        assert_eq!((v["id"].as_u64(), kind(&v)), (Some(2), "bad_request"));
        let v = answer(r#"{"id": 2, "camera": "IMX174", "frames": 0}"#);
        assert_eq!(kind(&v), "bad_request");
        let v = answer(r#"{"id": 2, "camera": "IMX174", "max_width": 0}"#);
        assert_eq!(kind(&v), "bad_request");
        let v = answer(r#"{"id": 2, "camera": "IMX174", "max_width": "full"}"#);
        assert_eq!(kind(&v), "bad_request");
        assert!(v["error"]["message"].as_str().unwrap().starts_with("max_width: "), "{v}");
        let v = answer(r#"{"id": 2, "camera": "IMX174", "seeds": "5..2"}"#);
        assert_eq!(kind(&v), "bad_request");
        let v = answer(r#"{"id": 2, "camera": "IMX174", "seeds": []}"#);
        assert_eq!(kind(&v), "bad_request");
        let v = answer(r#"{"id": 2, "camera": "IMX174", "weights": {"fps": 1}}"#);
        assert_eq!(kind(&v), "bad_request");
        let v = answer(r#"{"id": 2, "op": "train", "camera": "IMX174"}"#);
        assert_eq!(kind(&v), "bad_request");
        let v = answer(r#"{"id": 2, "camera": 5}"#);
        assert_eq!(kind(&v), "bad_request");
        assert!(v["error"]["message"].as_str().unwrap().contains("`camera`: a camera spec"), "{v}");
        let v = answer(r#"{"id": 2, "camera": "IMX174", "seeds": [-1]}"#);
        assert!(v["error"]["message"].as_str().unwrap().contains("`seeds`"), "{v}");
        let v = answer(r#"{"id": 4}"#);
        assert_eq!(kind(&v), "bad_request");
        assert!(v["error"]["message"].as_str().unwrap().contains("camera"));
    }

    #[test]
    fn bad_cameras_are_bad_camera() {
        for line in [
            r#"{"id": 1, "camera": "IMX999"}"#,
            r#"{"id": 1, "camera": {"sensor": "IMX999"}}"#,
            r#"{"id": 1, "camera": {"sensor": "IMX174", "focal_mm": 0}}"#,
            r#"{"id": 1, "camera": {"sensor": "IMX174", "focal_mm": -4}}"#,
            r#"{"id": 1, "camera": "IMX174,focal_mm=-1"}"#,
            r#"{"id": 1, "camera": {"sensor": "IMX174", "lens": "wide"}}"#,
            r#"{"id": 1, "camera": {"focal_mm": 4}}"#,
            r#"{"id": 1, "camera": "IMX174,zoom=3"}"#,
            r#"{"id": 1, "camera": "IMX174,height_m=3.5"}"#,
        ] {
            let v = answer(line);
            assert_eq!((v["ok"].as_bool(), v["id"].as_u64(), kind(&v)), (Some(false), Some(1), "bad_camera"), "{line}");
        }
        let v = answer(r#"{"id": 1, "camera": "IMX999"}"#);
        assert!(v["error"]["message"].as_str().unwrap().contains("unknown sensor 'IMX999'"));
    }

    #[test]
    fn jobs_take_defaults_and_overrides() {
        let catalog = Catalog::embedded();
        let defaults = ServeDefaults {
            seeds: vec![3, 4],
            frames: 6,
            max_width: FrameWidth::AtMost(100),
            ..ServeDefaults::default()
        };
        let req: Request = serde_json::from_str(r#"{"camera": "imx174,focal_mm=6"}"#).unwrap();
        let job = job_of(&req, &defaults, &catalog).unwrap();
        assert_eq!(job.camera.sensor, "IMX174", "the catalog's spelling");
        assert_eq!(job.camera.focal_mm, 6.0);
        assert_eq!((job.seeds.clone(), job.frames, job.max_width), (vec![3, 4], 6, FrameWidth::AtMost(100)));
        assert_eq!(job.weights, FitnessWeights::default());
        assert_eq!(job.config().max_width_px, FrameWidth::AtMost(100));
        assert_eq!(job.config().frames_per_scene, 6);

        let req: Request = serde_json::from_str(
            r#"{"camera": {"sensor": "IMX174", "pitch_deg": 12.5, "max_width_px": 80}, "seeds": [9, 1],
                "frames": 2, "weights": {"inliers": 0.01}}"#,
        )
        .unwrap();
        let job = job_of(&req, &defaults, &catalog).unwrap();
        assert_eq!(job.camera.pitch_deg, 12.5);
        assert_eq!(
            (job.seeds.clone(), job.frames, job.max_width),
            (vec![9, 1], 2, FrameWidth::AtMost(80)),
            "camera's own width"
        );
        assert_eq!(job.weights.inliers, 0.01);
        assert_eq!(job.weights.ap50, 1.0);

        let req: Request =
            serde_json::from_str(r#"{"camera": {"sensor": "IMX174", "max_width_px": 80}, "max_width": "native"}"#)
                .unwrap();
        let job = job_of(&req, &defaults, &catalog).unwrap();
        assert_eq!(job.max_width, FrameWidth::Native);
        assert_eq!(job.config().max_width_px, FrameWidth::Native, "every pixel of the sensor");

        let req: Request = serde_json::from_str(
            r#"{"camera": {"sensor": "IMX174", "max_width_px": 80}, "max_width": 64, "seeds": 5}"#,
        )
        .unwrap();
        let job = job_of(&req, &defaults, &catalog).unwrap();
        assert_eq!((job.seeds.clone(), job.max_width), (vec![5], FrameWidth::AtMost(64)), "the request's width wins");
        let req: Request = serde_json::from_str(r#"{"camera": "IMX174", "seeds": "1..=2"}"#).unwrap();
        assert_eq!(job_of(&req, &defaults, &catalog).unwrap().seeds, vec![1, 2]);
    }

    #[test]
    fn describe_lists_the_catalog_by_area_and_the_tacos_genes() {
        let catalog = Catalog::embedded();
        let v = answer(r#"{"id": 0, "op": "describe"}"#);
        assert_eq!((v["ok"].as_bool(), v["id"].as_u64()), (Some(true), Some(0)));
        assert_eq!(v["protocol"], PROTOCOL);
        let names: Vec<&str> = v["sensors"].as_array().unwrap().iter().map(|s| s.as_str().unwrap()).collect();
        assert_eq!(names.len(), catalog.len());
        let areas: Vec<f64> = names.iter().map(|n| catalog.get(n).unwrap().area_mm2()).collect();
        assert!(areas.windows(2).all(|w| w[0] <= w[1]), "ordered by area: {areas:?}");
        assert_eq!(v["genes"]["focal_mm"]["min"], 1.0);
        assert_eq!(v["genes"]["focal_mm"]["max"], 20.0);
        assert_eq!(v["genes"]["pitch_deg"]["min"], -30.0);
        assert_eq!(v["genes"]["pitch_deg"]["max"], 30.0);
        assert_eq!(v["genes"]["sensor"]["type"], "categorical");
        assert_eq!(v["defaults"]["frames"], evaluate::DEFAULT_FRAMES_PER_SCENE);
        assert_eq!(v["weights"]["inliers"], 0.0025);
        assert_eq!(kind(&answer(r#"{"id": 0, "op": "describe", "camera": "IMX174"}"#)), "bad_request");
    }

    #[test]
    fn serve_answers_every_request_in_order_and_counts_errors() {
        let input = b"{\"id\": 1, \"op\": \"describe\"}\n\n   \nnot json\n{\"id\": 2, \"camera\": \"NOPE\"}\n\xff\xfe\n{\"id\": 3, \"op\": \"describe\"}";
        let mut out = Vec::new();
        let summary = serve(&input[..], &mut out, &ServeDefaults::default()).unwrap();
        let lines: Vec<Value> =
            String::from_utf8(out).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        assert_eq!(lines.len(), 5);
        assert_eq!(summary, ServeSummary { requests: 5, errors: 3 });
        assert_eq!(lines[0]["id"], 1);
        assert_eq!((lines[1]["error"]["line"].as_u64(), kind(&lines[1])), (Some(4), "bad_request"));
        assert_eq!((lines[2]["id"].as_u64(), kind(&lines[2])), (Some(2), "bad_camera"));
        assert_eq!(lines[2]["error"]["line"], 5);
        assert_eq!((lines[3]["error"]["line"].as_u64(), kind(&lines[3])), (Some(6), "bad_request"));
        assert_eq!(
            (lines[4]["id"].as_u64(), lines[4]["ok"].as_bool()),
            (Some(3), Some(true)),
            "last line without newline"
        );
    }
}
