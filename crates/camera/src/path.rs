//! A camera path the user gives (`render --poses FILE`) instead of the agent's walk.
//!
//! Two forms, told apart by the file's extension:
//!
//! * **JSON** (`.json`): an array of poses, or an object with a `poses` array (so `render`'s own
//!   `trajectory.json` reads back). A pose is an object with `x`, `y` (or `position: [x, y]` /
//!   `[x, y, z]`), `yaw_deg`, and optionally `z`, `pitch_deg` and `time_s`.
//! * **CSV** (any other extension): a header row naming the columns, then one pose per row.
//!   Columns: `x`, `y`, `yaw_deg` (required), `z`, `pitch_deg`, `time_s` (optional), in any
//!   order.
//!
//! World coordinates in metres, Z up, as the manifest's. `yaw_deg` turns counter-clockwise from
//! +X; `pitch_deg` is positive up. A pose without `z` takes the camera's mounting height, one
//! without `pitch_deg` the camera's pitch, one without `time_s` the time of a 1 m/s walk with
//! 0.25 m steps (0.25 s apart). Every error names the file and the line (CSV) or pose (JSON).

use std::path::{Path, PathBuf};

use glam::Vec3;
use scene_gen_render::camera::Camera;
use scene_gen_scene::trajectory::{Pose, Trajectory};
use serde_json::Value;

use crate::camera_spec::ResolvedCamera;

/// Most poses a file may hold: a 0.25 m-step walk of 25 km.
pub const MAX_POSES: usize = 100_000;

/// One pose of a given path; `None` fields take the camera's values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GivenPose {
    pub x_m: f32,
    pub y_m: f32,
    pub z_m: Option<f32>,
    pub yaw_deg: f32,
    pub pitch_deg: Option<f32>,
    pub time_s: f32,
}

/// A path file that cannot be used, located.
#[derive(Debug, thiserror::Error)]
#[error("{}{}: {message}", path.display(), place.as_deref().map(|p| format!(": {p}")).unwrap_or_default())]
pub struct PathError {
    pub path: PathBuf,
    /// `line N` (CSV, JSON syntax) or `pose N` (JSON fields), when known.
    pub place: Option<String>,
    pub message: String,
}

impl PathError {
    fn new(path: &Path, place: Option<String>, message: impl Into<String>) -> PathError {
        PathError { path: path.to_path_buf(), place, message: message.into() }
    }
}

/// Reads the poses of `path`.
///
/// # Errors
/// [`PathError`] naming the file and where in it.
pub fn read(path: &Path) -> Result<Vec<GivenPose>, PathError> {
    let bytes = std::fs::read(path).map_err(|e| PathError::new(path, None, format!("cannot read: {e}")))?;
    let text = std::str::from_utf8(&bytes).map_err(|e| PathError::new(path, None, format!("not UTF-8: {e}")))?;
    parse(path, text)
}

/// The pose and pinhole camera of one pose of a given path: the camera's height and pitch
/// unless the pose says otherwise, its heading turned by the mount's yaw offset as the walk's
/// are.
#[must_use]
pub fn given_view(camera: &ResolvedCamera, given: &GivenPose) -> (Pose, Camera) {
    let z = given.z_m.unwrap_or(camera.spec.height_m);
    let pose = Pose { position: Vec3::new(given.x_m, given.y_m, z), yaw_deg: given.yaw_deg, time_s: given.time_s };
    let mut pinhole = camera.camera(pose.position, pose.yaw_deg);
    if let Some(pitch) = given.pitch_deg {
        pinhole.pitch_deg = pitch;
    }
    (pose, pinhole)
}

/// The first `frames` poses of a walk and the camera at each (the last pose repeats when the
/// walk is shorter).
#[must_use]
pub fn walk_views(camera: &ResolvedCamera, walk: &Trajectory, frames: usize) -> Vec<(Pose, Camera)> {
    let Some(last) = walk.poses.len().checked_sub(1) else { return Vec::new() };
    (0..frames).map(|k| walk.poses[k.min(last)]).map(|p| (p, camera.camera_at(&p))).collect()
}

/// Parses `text` as the file `path` (its extension picks the form).
///
/// # Errors
/// As [`read`].
pub fn parse(path: &Path, text: &str) -> Result<Vec<GivenPose>, PathError> {
    let is_json = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let poses = if is_json { parse_json(path, text)? } else { parse_csv(path, text)? };
    if poses.is_empty() {
        return Err(PathError::new(path, None, "no poses"));
    }
    if poses.len() > MAX_POSES {
        return Err(PathError::new(path, None, format!("{} poses, at most {MAX_POSES}", poses.len())));
    }
    Ok(poses)
}

/// The time of pose `index` when a path gives none: a 1 m/s walk with 0.25 m steps.
#[must_use]
pub fn default_time_s(index: usize) -> f32 {
    index as f32 * 0.25
}

fn finite(value: f64, what: &str) -> Result<f32, String> {
    let v = value as f32;
    if v.is_finite() { Ok(v) } else { Err(format!("{what} = {value} is not a finite number")) }
}

fn parse_json(path: &Path, text: &str) -> Result<Vec<GivenPose>, PathError> {
    let value: Value = serde_json::from_str(text)
        .map_err(|e| PathError::new(path, Some(format!("line {}", e.line())), e.to_string()))?;
    let list = match &value {
        Value::Array(list) => list,
        Value::Object(map) => match map.get("poses") {
            Some(Value::Array(list)) => list,
            _ => return Err(PathError::new(path, None, "an object needs a `poses` array")),
        },
        _ => return Err(PathError::new(path, None, "expected an array of poses or an object with `poses`")),
    };
    list.iter()
        .enumerate()
        .map(|(i, pose)| json_pose(i, pose).map_err(|m| PathError::new(path, Some(format!("pose {i}")), m)))
        .collect()
}

fn json_pose(index: usize, pose: &Value) -> Result<GivenPose, String> {
    let Value::Object(map) = pose else { return Err("a pose is an object".into()) };
    let number = |key: &str| -> Result<Option<f32>, String> {
        match map.get(key) {
            None | Some(Value::Null) => Ok(None),
            Some(Value::Number(n)) => n.as_f64().map(|v| finite(v, key)).transpose(),
            Some(other) => Err(format!("{key} = {other} is not a number")),
        }
    };
    let (mut x, mut y, mut z) = (number("x")?, number("y")?, number("z")?);
    if let Some(position) = map.get("position") {
        let Some(coords) = position.as_array().filter(|a| a.len() == 2 || a.len() == 3) else {
            return Err("position is [x, y] or [x, y, z]".into());
        };
        let coord = |i: usize| coords[i].as_f64().ok_or_else(|| format!("position[{i}] is not a number"));
        x = Some(finite(coord(0)?, "position[0]")?);
        y = Some(finite(coord(1)?, "position[1]")?);
        if coords.len() == 3 {
            z = Some(finite(coord(2)?, "position[2]")?);
        }
    }
    Ok(GivenPose {
        x_m: x.ok_or("missing x (or position)")?,
        y_m: y.ok_or("missing y (or position)")?,
        z_m: z,
        yaw_deg: number("yaw_deg")?.ok_or("missing yaw_deg")?,
        pitch_deg: number("pitch_deg")?,
        time_s: number("time_s")?.unwrap_or_else(|| default_time_s(index)),
    })
}

const CSV_COLUMNS: [&str; 6] = ["x", "y", "z", "yaw_deg", "pitch_deg", "time_s"];

fn parse_csv(path: &Path, text: &str) -> Result<Vec<GivenPose>, PathError> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((header_index, header)) = lines.next() else { return Ok(Vec::new()) };
    let at = |i: usize| Some(format!("line {}", i + 1));
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let mut column = [None; 6];
    for (i, name) in names.iter().enumerate() {
        let Some(slot) = CSV_COLUMNS.iter().position(|c| c == name) else {
            let known = CSV_COLUMNS.join(", ");
            return Err(PathError::new(path, at(header_index), format!("unknown column '{name}' (columns: {known})")));
        };
        if column[slot].replace(i).is_some() {
            return Err(PathError::new(path, at(header_index), format!("column '{name}' twice")));
        }
    }
    for required in [0, 1, 3] {
        if column[required].is_none() {
            let name = CSV_COLUMNS[required];
            return Err(PathError::new(
                path,
                at(header_index),
                format!("no '{name}' column (x, y, yaw_deg are needed)"),
            ));
        }
    }
    let mut poses = Vec::new();
    for (line_index, line) in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            let message = format!("{} values, the header names {}", cells.len(), names.len());
            return Err(PathError::new(path, at(line_index), message));
        }
        let value = |slot: usize| -> Result<Option<f32>, PathError> {
            let Some(i) = column[slot] else { return Ok(None) };
            let name = CSV_COLUMNS[slot];
            let parsed = cells[i].parse::<f64>().map_err(|_| format!("{name}: '{}' is not a number", cells[i]));
            parsed.and_then(|v| finite(v, name)).map(Some).map_err(|m| PathError::new(path, at(line_index), m))
        };
        let index = poses.len();
        poses.push(GivenPose {
            x_m: value(0)?.expect("required column"),
            y_m: value(1)?.expect("required column"),
            z_m: value(2)?,
            yaw_deg: value(3)?.expect("required column"),
            pitch_deg: value(4)?,
            time_s: value(5)?.unwrap_or_else(|| default_time_s(index)),
        });
    }
    Ok(poses)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_and_csv_give_the_same_poses() {
        let json = r#"{"poses": [{"x": 1, "y": 2, "yaw_deg": 90},
                                 {"position": [1.5, 2, 1.2], "yaw_deg": 45, "pitch_deg": -5, "time_s": 3}]}"#;
        let csv = "# a path\nyaw_deg, x, y, z, pitch_deg, time_s\n90, 1, 2, 0.8, 0, 0\n\n45,1.5,2,1.2,-5,3\n";
        let from_json = parse(Path::new("p.json"), json).unwrap();
        let from_csv = parse(Path::new("p.CSV"), csv).unwrap();
        assert_eq!(
            from_json[0],
            GivenPose { x_m: 1.0, y_m: 2.0, z_m: None, yaw_deg: 90.0, pitch_deg: None, time_s: 0.0 }
        );
        assert_eq!(
            from_json[1],
            GivenPose { x_m: 1.5, y_m: 2.0, z_m: Some(1.2), yaw_deg: 45.0, pitch_deg: Some(-5.0), time_s: 3.0 }
        );
        assert_eq!(from_csv[1], from_json[1]);
        assert_eq!(
            (from_csv[0].x_m, from_csv[0].y_m, from_csv[0].yaw_deg, from_csv[0].z_m),
            (1.0, 2.0, 90.0, Some(0.8))
        );
        assert_eq!(from_csv.len(), 2, "blank and comment lines are skipped");
    }

    #[test]
    fn errors_name_the_file_and_place() {
        let cases: [(&str, &str, &str); 8] = [
            ("p.json", "[{\"x\": 1, \"y\": 2}]", "p.json: pose 0: missing yaw_deg"),
            ("p.json", "[{\"x\": 1, \"y\": \"a\", \"yaw_deg\": 0}]", "p.json: pose 0: y = \"a\" is not a number"),
            ("p.json", "[\n{\"x\": 1,,}]", "p.json: line 2"),
            ("p.json", "[]", "p.json: no poses"),
            ("p.csv", "x,y\n1,2\n", "p.csv: line 1: no 'yaw_deg' column"),
            ("p.csv", "x,y,yaw_deg,roll\n", "p.csv: line 1: unknown column 'roll'"),
            ("p.csv", "x,y,yaw_deg\n1,2,3\n1,2,abc\n", "p.csv: line 3: yaw_deg: 'abc' is not a number"),
            ("p.csv", "x,y,yaw_deg\n1,2\n", "p.csv: line 2: 2 values, the header names 3"),
        ];
        for (name, text, want) in cases {
            let e = parse(Path::new(name), text).unwrap_err().to_string();
            assert!(e.starts_with(want), "{name} {text:?}: {e}");
        }
    }
}
