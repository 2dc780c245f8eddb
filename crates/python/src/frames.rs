//! `render`: frames of a camera in a house, as buffers the Python side turns into arrays.

use glam::Vec3;
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyDict};
use scene_gen::capture::{Capture, Image8};
use scene_gen::dataset::Lighting;
use scene_gen::path::{self, GivenPose, MAX_POSES};
use scene_gen::radiometry::SensorImage;
use scene_gen::render::Frame;
use scene_gen::render::camera::Camera as Pinhole;
use scene_gen::scene::LightGroup;
use scene_gen::trajectory::{self, Pose, TrajectoryParams};
use scene_gen::view::ViewGeometry;

use crate::camera::Camera;
use crate::dataset;
use crate::house::Scene;
use crate::progress::Callback;
use crate::{bad_input, failure};

/// A pose given from Python: `(x, y, z, yaw_deg, pitch_deg, time_s)`, `None` where the
/// camera's height, pitch or the walk's timing apply.
type PoseTuple = (f32, f32, Option<f32>, f32, Option<f32>, Option<f32>);

/// One lighting of one pose: the sensor's DN and the camera's 8-bit image.
struct Shot {
    lighting: &'static str,
    raw: SensorImage,
    image: Image8,
    gain_db: f64,
    plane_lux: f32,
    light_scale: f32,
}

/// One pose: what the renderer saw and the shots of every lighting.
struct PoseFrame {
    pose: Pose,
    pinhole: Pinhole,
    frame: Frame,
    shots: Vec<Shot>,
}

/// Poses from Python, checked as a path file's are: finite values, at most [`MAX_POSES`].
fn given_poses(poses: &[PoseTuple]) -> PyResult<Vec<GivenPose>> {
    if poses.is_empty() {
        return Err(bad_input("poses: no poses given"));
    }
    if poses.len() > MAX_POSES {
        return Err(bad_input(format!("poses: {} poses, at most {MAX_POSES}", poses.len())));
    }
    poses
        .iter()
        .enumerate()
        .map(|(i, &(x_m, y_m, z_m, yaw_deg, pitch_deg, time_s))| {
            let values = [Some(x_m), Some(y_m), z_m, Some(yaw_deg), pitch_deg, time_s];
            let names = ["x", "y", "z", "yaw_deg", "pitch_deg", "time_s"];
            if let Some((name, v)) =
                names.iter().zip(values).find_map(|(n, v)| v.filter(|v| !v.is_finite()).map(|v| (n, v)))
            {
                return Err(bad_input(format!("poses[{i}]: {name} = {v} is not a finite number")));
            }
            let time_s = time_s.unwrap_or_else(|| path::default_time_s(i));
            Ok(GivenPose { x_m, y_m, z_m, yaw_deg, pitch_deg, time_s })
        })
        .collect()
}

/// Renders `scene` through `camera` at the first `frames` poses of the walk, at `poses`, or at
/// the poses of the path file `poses_file`; the GIL is released while Rust renders.
#[pyfunction]
#[pyo3(signature = (scene, camera, poses=None, poses_file=None, frames=1, lighting="day", quality="standard", max_width=None, progress=None))]
#[allow(clippy::too_many_arguments)] // The keyword arguments of the Python call.
pub fn render<'py>(
    py: Python<'py>,
    scene: &Scene,
    camera: &Camera,
    poses: Option<Vec<PoseTuple>>,
    poses_file: Option<std::path::PathBuf>,
    frames: u32,
    lighting: &str,
    quality: &str,
    max_width: Option<u32>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let resolved = camera.resolved(max_width)?;
    let groups: Vec<LightGroup> = dataset::lighting(lighting)?.into_iter().map(Lighting::group).collect();
    let settings = dataset::quality(quality)?.settings();
    if frames == 0 {
        return Err(bad_input("frames must be at least 1"));
    }
    let given = match (poses, poses_file) {
        (Some(_), Some(_)) => return Err(bad_input("give poses or poses_file, not both")),
        (Some(p), None) => Some(given_poses(&p)?),
        (None, Some(file)) => Some(path::read(&file).map_err(bad_input)?),
        (None, None) => None,
    };
    let house = &*scene.house;
    if given.is_none() {
        house.envelope.check_camera_height(resolved.spec.height_m).map_err(bad_input)?;
    }
    let params = TrajectoryParams { height_m: resolved.spec.height_m, ..TrajectoryParams::default() };
    let views: Vec<(Pose, Pinhole)> = match &given {
        Some(given) => given.iter().map(|g| path::given_view(&resolved, g)).collect(),
        None => {
            let walk = py.detach(|| trajectory::plan(house, &params)).map_err(failure)?;
            path::walk_views(&resolved, &walk, frames as usize)
        }
    };
    let callback = Callback::new(progress, views.len() as u64);
    let rendered = py.detach(|| -> Result<Vec<PoseFrame>, String> {
        let noise_label = format!("{}/", house.seed);
        let capture = Capture::new(house, &resolved, &groups, settings, params.speed_m_per_s, noise_label)
            .map_err(|e| e.to_string())?;
        let mut out = Vec::with_capacity(views.len());
        for (k, &(pose, pinhole)) in (0u64..).zip(&views) {
            if callback.failed() {
                break;
            }
            let frame = capture.render(&pinhole).map_err(|e| e.to_string())?;
            let images = capture.sensor_images(&frame, &pinhole, &pose, k);
            let shots = capture
                .scenarios()
                .iter()
                .zip(images)
                .map(|(scenario, raw)| Shot {
                    image: scenario.image_8bit(&raw),
                    raw,
                    lighting: scenario.light.name(),
                    gain_db: scenario.gain_db,
                    plane_lux: scenario.light.target_lux,
                    light_scale: scenario.light.scale,
                })
                .collect();
            out.push(PoseFrame { pose, pinhole, frame, shots });
            scene_gen::progress::Progress::done(&callback, true);
        }
        Ok(out)
    });
    callback.finish()?;
    let rendered = rendered.map_err(failure)?;
    let exposure_s = resolved.spec.exposure_s;
    rendered.iter().enumerate().map(|(k, p)| pose_dict(py, k, p, exposure_s)).collect()
}

/// Little-endian bytes of a buffer of samples, as a `bytearray` (NumPy reads it writable).
fn le_bytes<'py, T: Copy, const N: usize>(
    py: Python<'py>,
    values: &[T],
    to_bytes: impl Fn(T) -> [u8; N],
) -> Bound<'py, PyByteArray> {
    let bytes: Vec<u8> = values.iter().flat_map(|&v| to_bytes(v)).collect();
    PyByteArray::new(py, &bytes)
}

/// The dict of one pose: buffers, geometry and its shots.
fn pose_dict<'py>(py: Python<'py>, k: usize, p: &PoseFrame, exposure_s: f64) -> PyResult<Bound<'py, PyDict>> {
    let f = &p.frame;
    let d = PyDict::new(py);
    let view = ViewGeometry::of(&p.pinhole);
    d.set_item("index", k)?;
    d.set_item("width", f.width)?;
    d.set_item("height", f.height)?;
    d.set_item("K", view.k)?;
    d.set_item("camera_to_world", view.camera_to_world)?;
    let pos: Vec3 = p.pinhole.position;
    d.set_item("position", pos.to_array())?;
    d.set_item("yaw_deg", p.pinhole.yaw_deg)?;
    d.set_item("pitch_deg", p.pinhole.pitch_deg)?;
    d.set_item("time_s", p.pose.time_s)?;
    d.set_item("depth", le_bytes(py, &f.depth_m, f32::to_le_bytes))?;
    d.set_item("instance_ids", le_bytes(py, &f.instance_id, u32::to_le_bytes))?;
    d.set_item("class_ids", le_bytes(py, &f.class_id, u16::to_le_bytes))?;
    let normals: Vec<f32> = f.normal.iter().flatten().copied().collect();
    d.set_item("normals", le_bytes(py, &normals, f32::to_le_bytes))?;
    let shots = p
        .shots
        .iter()
        .map(|s| {
            let shot = PyDict::new(py);
            shot.set_item("lighting", s.lighting)?;
            shot.set_item("raw", le_bytes(py, &s.raw.dn, u16::to_le_bytes))?;
            shot.set_item("channels", s.raw.channels)?;
            shot.set_item("bits", s.raw.bits)?;
            shot.set_item("image", PyByteArray::new(py, &s.image.bytes))?;
            shot.set_item("image_channels", s.image.channels)?;
            shot.set_item("cfa_pattern", s.raw.cfa.map(|p| p.name()))?;
            shot.set_item("exposure_s", exposure_s)?;
            shot.set_item("gain_db", s.gain_db)?;
            shot.set_item("plane_lux", s.plane_lux)?;
            shot.set_item("light_scale", s.light_scale)?;
            Ok(shot)
        })
        .collect::<PyResult<Vec<_>>>()?;
    d.set_item("shots", shots)?;
    Ok(d)
}
