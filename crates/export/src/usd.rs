//! USD export (`scene.usda` or `scene.usdc` + `textures/*.png`) through Pixar's usd-core.
//!
//! Writing USD correctly (crate files, schemas, validation) is usd-core's job, so this module
//! does not encode USD itself. It lays the [`Scene`] out as a plain interchange, a JSON
//! description of every prim ([`UsdPlan`]) plus one little-endian binary of vertex arrays, and
//! runs `exporters/usd/write_usd.py` (embedded in the binary, written to a scratch folder) with
//! a Python that has usd-core. The script only transcribes the plan; every decision about the
//! stage's layout is made, and unit-tested, here.
//!
//! # The stage
//!
//! `metersPerUnit = 1`, `upAxis = "Z"` (the world frame as is), default prim `/World`:
//!
//! ```text
//! /World                              Xform; variant set `lighting` = day | night
//!   Looks/m000_<material>             UsdPreviewSurface materials (+ UsdUVTexture)
//!   Rooms/room_<id>                   Xform per room (customData room_id, room_type)
//!     floor_<id>, ceiling_<id>, ...   structure that belongs to one room
//!     Decor/<node>                    rugs, pictures
//!     Furnishings/<kind>_<id>         wardrobes, counters...: unlabelled (not detection targets)
//!     Objects/<class>_<id>            labelled object root, under the room it stands in
//!       <node>                        Xform with the node's transform
//!         mesh_<k>                    Mesh per material (points in the node frame)
//!   Structure/<node>                  walls, doors and windows (shared by two rooms)
//!   Thresholds/threshold_<id>         labelled threshold roots
//!   Objects/<class>_<id>              objects whose room is unknown (never for generated scenes)
//!   Lights/Day, Lights/Night          UsdLux lights; the variant deactivates the other group
//! ```
//!
//! Each labelled root carries both semantics forms in use: `UsdSemantics.LabelsAPI` with
//! taxonomy `class`, and Isaac Sim's legacy multiple-apply `SemanticsAPI:Semantics`
//! (`semanticType = "class"`, `semanticData = <class>`), plus the custom attributes
//! `scenegen:class_id`, `scenegen:instance_id` and `scenegen:room`. No instancing is used, so the
//! labels sit on the prims themselves.
//!
//! # Lights: our photometric units to UsdLux
//!
//! UsdLux's `inputs:intensity` (x `2^exposure`, x `color`) is a luminance in nits for an
//! unnormalized light; a *normalized* DistantLight reads it as illuminance in lux (UsdLux
//! schema documentation, "Quantities"). So:
//!
//! * directional, lux -> `DistantLight`, `normalize = true`, intensity = the lux value,
//!   `angle` = 0.53 deg (the sun's angular diameter);
//! * point, candela -> `SphereLight` of radius [`POINT_LIGHT_RADIUS_M`], unnormalized, intensity
//!   = I / (pi r^2) nits (a Lambertian sphere of luminance L has intensity L pi r^2 in every
//!   direction);
//! * rect, nit -> `RectLight`, unnormalized, intensity = the luminance, `width`/`height` = the
//!   rectangle's edges, emitting along its local -Z as our `direction`.
//!
//! Every light also keeps its source value in `scenegen:intensity` and `scenegen:unit`.

use std::collections::BTreeSet;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use glam::{Mat4, Vec3};
use serde::Serialize;

use scene_gen_scene::scene::{Light, LightGroup, LightKind, LightUnit, Scene, Semantic};

/// The usd-core release the script is written and tested against (pinned in
/// tests/interop/requirements.txt).
pub const USD_CORE_REQUIREMENT: &str = "usd-core==26.11";

/// Interchange schema tag shared with `exporters/usd/write_usd.py`.
pub const INTERCHANGE_SCHEMA: &str = "scene-gen/usd-interchange/1";

/// Radius of the SphereLight standing in for a point light: a bulb's size, small enough that
/// it reads as a point at room scale.
pub const POINT_LIGHT_RADIUS_M: f32 = 0.025;

/// Angular diameter of the sun, degrees (mean value, IAU).
pub const SUN_ANGLE_DEG: f32 = 0.53;

/// Exit status of the script when `import pxr` fails.
const SCRIPT_USD_CORE_MISSING: i32 = 3;

/// The script, embedded so the binary works from any folder.
const SCRIPT: &str = include_str!("../../../exporters/usd/write_usd.py");

/// USD layer encodings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UsdFormat {
    /// Text.
    Usda,
    /// Binary crate file.
    Usdc,
}

impl UsdFormat {
    /// File extension without the dot.
    #[must_use]
    pub fn extension(self) -> &'static str {
        match self {
            UsdFormat::Usda => "usda",
            UsdFormat::Usdc => "usdc",
        }
    }
}

/// Why a USD export failed.
#[derive(Debug, thiserror::Error)]
pub enum UsdError {
    /// No Python with usd-core: the user must install it.
    #[error(
        "USD export needs usd-core (Python package `pxr`), but {problem} (python: {python}).\n\
         Install it from the scene-gen repository root with:\n  \
         python3 -m venv .venv && .venv/bin/pip install {req}\n\
         or install it into any Python with `pip install {req}` and set SCENE_GEN_PYTHON to that python",
        python = python.display(),
        req = USD_CORE_REQUIREMENT
    )]
    UsdCoreMissing { python: PathBuf, problem: String },
    /// The script ran and failed.
    #[error("USD writer failed ({status}):\n{stderr}")]
    ScriptFailed { status: String, stderr: String },
    /// The scratch folder could not be written or read.
    #[error("USD export scratch file {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// The Python to run: `$SCENE_GEN_PYTHON`, else the repository's `.venv` (found from the
/// compile-time crate folder, then the current folder), else `python3` on the PATH.
#[must_use]
pub fn find_python() -> PathBuf {
    if let Some(python) = std::env::var_os("SCENE_GEN_PYTHON") {
        return PathBuf::from(python);
    }
    let venv_python = if cfg!(windows) { ".venv/Scripts/python.exe" } else { ".venv/bin/python" };
    let roots = [Some(Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")), std::env::current_dir().ok()];
    roots
        .into_iter()
        .flatten()
        .map(|root| root.join(venv_python))
        .find(|p| p.is_file())
        .unwrap_or_else(|| PathBuf::from("python3"))
}

/// Checks that `python` runs and imports usd-core. [`to_usd`] needs no such check first (its
/// script reports a missing usd-core itself, and nothing is written before it succeeds); this
/// is for callers that want to know early.
pub fn check_usd_core(python: &Path) -> Result<(), UsdError> {
    let missing = |problem: String| UsdError::UsdCoreMissing { python: python.to_path_buf(), problem };
    let out = Command::new(python)
        .args(["-c", "from pxr import Usd, UsdGeom, UsdShade, UsdLux, UsdSemantics"])
        .output()
        .map_err(|e| missing(format!("the Python interpreter could not be run: {e}")))?;
    if out.status.success() {
        return Ok(());
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    let last = stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no message");
    Err(missing(format!("it cannot be imported: {last}")))
}

/// Exports `scene` as USD with `python`: the files to write, as (relative path, bytes), the
/// scene layer first, then the textures. Nothing is written outside a scratch folder, which is
/// removed again, so a missing usd-core ([`UsdError::UsdCoreMissing`]) leaves no output.
pub fn to_usd(scene: &Scene, format: UsdFormat, python: &Path) -> Result<Vec<(String, Vec<u8>)>, UsdError> {
    let plan = UsdPlan::of(scene);
    let scratch = Scratch::new()?;
    let json = serde_json::to_vec(&plan.doc).expect("plan serialises");
    scratch.write("interchange.json", &json)?;
    scratch.write("geometry.bin", &plan.bin)?;
    scratch.write("write_usd.py", SCRIPT.as_bytes())?;
    let layer_name = format!("scene.{}", format.extension());
    let out = Command::new(python)
        .arg(scratch.0.join("write_usd.py"))
        .arg(&scratch.0)
        .arg(scratch.0.join(&layer_name))
        .output()
        .map_err(|e| UsdError::UsdCoreMissing {
            python: python.to_path_buf(),
            problem: format!("the Python interpreter could not be run: {e}"),
        })?;
    if out.status.code() == Some(SCRIPT_USD_CORE_MISSING) {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let last = stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no message");
        return Err(UsdError::UsdCoreMissing { python: python.to_path_buf(), problem: last.to_string() });
    }
    if !out.status.success() {
        return Err(UsdError::ScriptFailed {
            status: out.status.to_string(),
            stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        });
    }
    let layer = scratch.read(&layer_name)?;
    let mut files = vec![(layer_name, layer)];
    for (i, texture) in scene.geometry.textures.iter().enumerate() {
        files.push((texture_path(i, &texture.name), texture.png.to_vec()));
    }
    Ok(files)
}

/// A scratch folder under the system temp folder, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Result<Scratch, UsdError> {
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
        let path = std::env::temp_dir().join(format!("scene-gen-usd-{}-{nanos}", std::process::id()));
        std::fs::create_dir_all(&path).map_err(|source| UsdError::Io { path: path.clone(), source })?;
        Ok(Scratch(path))
    }

    fn write(&self, name: &str, bytes: &[u8]) -> Result<(), UsdError> {
        let path = self.0.join(name);
        std::fs::File::create(&path)
            .and_then(|mut f| f.write_all(bytes))
            .map_err(|source| UsdError::Io { path, source })
    }

    fn read(&self, name: &str) -> Result<Vec<u8>, UsdError> {
        let path = self.0.join(name);
        std::fs::read(&path).map_err(|source| UsdError::Io { path, source })
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Texture file of texture `index`, relative to the scene layer (the OBJ exporter's naming).
fn texture_path(index: usize, name: &str) -> String {
    format!("textures/{index:03}_{}.png", identifier(name))
}

/// `text` as a USD prim name: ASCII letters, digits and `_`, not starting with a digit.
fn identifier(text: &str) -> String {
    let mut id: String = text.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
    if id.is_empty() || id.starts_with(|c: char| c.is_ascii_digit()) {
        id.insert(0, '_');
    }
    id
}

/// The stage as the script will write it: the JSON document and the vertex-array binary.
#[derive(Clone, Debug)]
pub struct UsdPlan {
    pub doc: PlanDoc,
    /// Little-endian f32 (points, normals, st) and u32 (indices) arrays the meshes point into.
    pub bin: Vec<u8>,
}

/// The interchange JSON.
#[derive(Clone, Debug, Serialize)]
pub struct PlanDoc {
    pub schema: &'static str,
    pub seed: u64,
    pub up_axis: &'static str,
    pub meters_per_unit: f64,
    pub default_prim: &'static str,
    pub textures: Vec<String>,
    pub materials: Vec<MaterialPrim>,
    /// Xforms and Scopes, each after its parent.
    pub prims: Vec<XformPrim>,
    pub meshes: Vec<MeshPrim>,
    pub lights: Vec<LightPrim>,
    /// Paths of the light groups the `lighting` variants switch.
    pub light_groups: [(&'static str, String); 2],
}

/// A UsdPreviewSurface material.
#[derive(Clone, Debug, Serialize)]
pub struct MaterialPrim {
    pub path: String,
    /// Linear RGBA; the texture's scale when there is a texture.
    pub base_color: [f32; 4],
    pub metallic: f32,
    pub roughness: f32,
    /// Index into [`PlanDoc::textures`].
    pub texture: Option<usize>,
}

/// An Xform (or Scope) prim.
#[derive(Clone, Debug, Serialize)]
pub struct XformPrim {
    pub path: String,
    /// `Xform` or `Scope`.
    #[serde(rename = "type")]
    pub prim_type: &'static str,
    /// Local transform as `xformOp:transform`, column-major (= USD's row-major, row vectors).
    pub transform: Option<[f32; 16]>,
    pub label: Option<LabelSpec>,
    /// Room id and type, on room prims.
    pub room: Option<(u32, String)>,
}

/// The semantic label of an object or threshold root.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LabelSpec {
    pub class: String,
    pub class_id: u32,
    pub instance_id: u32,
    pub room: Option<u32>,
}

/// A byte range of `count` elements in the binary.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Span {
    pub offset: usize,
    pub count: usize,
}

/// A triangle mesh bound to one material.
#[derive(Clone, Debug, Serialize)]
pub struct MeshPrim {
    pub path: String,
    pub material: String,
    /// Vec3 f32.
    pub points: Span,
    /// Vec3 f32, vertex interpolation.
    pub normals: Span,
    /// Vec2 f32, `primvars:st`, vertex interpolation, v up (USD's texture convention).
    pub st: Span,
    /// u32, three per triangle.
    pub indices: Span,
}

/// A UsdLux light.
#[derive(Clone, Debug, Serialize)]
pub struct LightPrim {
    pub path: String,
    /// `DistantLight`, `SphereLight` or `RectLight`.
    #[serde(rename = "type")]
    pub light_type: &'static str,
    pub transform: [f32; 16],
    pub intensity: f32,
    pub normalize: bool,
    pub color: [f32; 3],
    pub radius: Option<f32>,
    pub width: Option<f32>,
    pub height: Option<f32>,
    pub angle: Option<f32>,
    /// Our own value and unit, kept as custom attributes.
    pub source_intensity: f32,
    pub source_unit: &'static str,
}

/// Hands out unique child names per parent.
#[derive(Default)]
struct Names(BTreeSet<String>);

impl Names {
    fn child(&mut self, parent: &str, name: &str) -> String {
        let base = format!("{parent}/{}", identifier(name));
        let mut path = base.clone();
        let mut n = 1;
        while !self.0.insert(path.clone()) {
            path = format!("{base}_{n}");
            n += 1;
        }
        path
    }
}

impl UsdPlan {
    /// Lays `scene` out as a USD stage; see the module docs for the hierarchy.
    #[must_use]
    pub fn of(scene: &Scene) -> UsdPlan {
        let g = &scene.geometry;
        let mut names = Names::default();
        let mut prims = Vec::new();
        let world = group(&mut prims, "/World".into(), "Xform");
        let looks = group(&mut prims, names.child(&world, "Looks"), "Scope");
        let rooms_root = group(&mut prims, names.child(&world, "Rooms"), "Xform");
        let structure = group(&mut prims, names.child(&world, "Structure"), "Xform");
        let thresholds_root = group(&mut prims, names.child(&world, "Thresholds"), "Xform");
        let mut room_paths = std::collections::BTreeMap::new();
        for room in &scene.rooms {
            let path = names.child(&rooms_root, &format!("room_{}", room.id));
            prims.push(XformPrim {
                path: path.clone(),
                prim_type: "Xform",
                transform: None,
                label: None,
                room: Some((room.id, room.room_type.clone())),
            });
            room_paths.insert(room.id, path);
        }
        // A room's prim, or its `group` child (created on first use); structure for unknown rooms.
        let room_children = |room: u32, group: Option<&str>, names: &mut Names, prims: &mut Vec<XformPrim>| {
            let parent = room_paths.get(&room).cloned().unwrap_or_else(|| structure.clone());
            let Some(group) = group else { return parent };
            once(names, prims, format!("{parent}/{group}"))
        };

        // Labelled roots, created on first use so every object or threshold gets exactly one.
        let mut label_roots: std::collections::BTreeMap<(bool, u32), String> = Default::default();
        let mut bin = Vec::new();
        let mut meshes = Vec::new();
        for node in &g.nodes {
            let parent = match node.semantic {
                Semantic::Object { id } | Semantic::Threshold { id } => {
                    let is_threshold = matches!(node.semantic, Semantic::Threshold { .. });
                    if let Some(path) = label_roots.get(&(is_threshold, id)) {
                        path.clone()
                    } else {
                        let label = scene.label(node.semantic).map(|l| LabelSpec {
                            class: l.class.to_string(),
                            class_id: l.class_id,
                            instance_id: l.instance_id,
                            room: l.room,
                        });
                        let group_parent = if is_threshold {
                            thresholds_root.clone()
                        } else {
                            match scene.objects.get(id as usize).map(|o| o.room) {
                                Some(room) if room_paths.contains_key(&room) => {
                                    room_children(room, Some("Objects"), &mut names, &mut prims)
                                }
                                _ => once(&mut names, &mut prims, format!("{world}/Objects")),
                            }
                        };
                        let name = match &label {
                            Some(l) => format!("{}_{id}", l.class),
                            None => node.name.clone(),
                        };
                        let path = names.child(&group_parent, &name);
                        prims.push(XformPrim {
                            path: path.clone(),
                            prim_type: "Xform",
                            transform: None,
                            label,
                            room: None,
                        });
                        label_roots.insert((is_threshold, id), path.clone());
                        path
                    }
                }
                Semantic::Floor { room } | Semantic::Ceiling { room } => {
                    room_children(room, None, &mut names, &mut prims)
                }
                Semantic::Decor { room } => room_children(room, Some("Decor"), &mut names, &mut prims),
                Semantic::Furnishing { id } => match scene.furnishings.get(id as usize).map(|f| f.room) {
                    Some(room) if room_paths.contains_key(&room) => {
                        room_children(room, Some("Furnishings"), &mut names, &mut prims)
                    }
                    _ => once(&mut names, &mut prims, format!("{world}/Furnishings")),
                },
                Semantic::Wall { .. } | Semantic::Opening { .. } => structure.clone(),
            };
            // Under a labelled root the geometry gets a name of its own: a child named like its
            // parent (`chair_5/chair_5`) makes importers such as Blender rename one of the two.
            let labelled = matches!(node.semantic, Semantic::Object { .. } | Semantic::Threshold { .. });
            let node_path = names.child(&parent, if labelled { "geom" } else { &node.name });
            prims.push(XformPrim {
                path: node_path.clone(),
                prim_type: "Xform",
                transform: Some(node.transform.to_cols_array()),
                label: None,
                room: None,
            });
            for (k, primitive) in g.meshes[node.mesh].primitives.iter().enumerate() {
                let points = push_f32(&mut bin, primitive.positions.iter().flat_map(|p| p.to_array()), 3);
                let normals = push_f32(&mut bin, primitive.normals.iter().flat_map(|n| n.to_array()), 3);
                // Our v runs down the image (glTF); USD's st runs up.
                let st = push_f32(&mut bin, primitive.uvs.iter().flat_map(|uv| [uv.x, 1.0 - uv.y]), 2);
                let indices = push_u32(&mut bin, &primitive.indices);
                meshes.push(MeshPrim {
                    path: names.child(&node_path, &format!("mesh_{k}")),
                    material: material_path(&looks, primitive.material, &g.materials[primitive.material].name),
                    points,
                    normals,
                    st,
                    indices,
                });
            }
        }

        let materials = g
            .materials
            .iter()
            .enumerate()
            .map(|(i, m)| MaterialPrim {
                path: material_path(&looks, i, &m.name),
                base_color: m.base_color,
                metallic: m.metallic,
                roughness: m.roughness,
                texture: m.base_color_texture,
            })
            .collect();

        let lights_root = group(&mut prims, names.child(&world, "Lights"), "Xform");
        let day = group(&mut prims, names.child(&lights_root, "Day"), "Xform");
        let night = group(&mut prims, names.child(&lights_root, "Night"), "Xform");
        let lights = scene
            .lights
            .iter()
            .filter_map(|light| {
                let parent = if light.group == LightGroup::Day { &day } else { &night };
                light_prim(light, names.child(parent, &format!("light_{}", light.id)))
            })
            .collect();

        UsdPlan {
            doc: PlanDoc {
                schema: INTERCHANGE_SCHEMA,
                seed: scene.seed,
                up_axis: "Z",
                meters_per_unit: 1.0,
                default_prim: "World",
                textures: g.textures.iter().enumerate().map(|(i, t)| texture_path(i, &t.name)).collect(),
                materials,
                prims,
                meshes,
                lights,
                light_groups: [("day", day), ("night", night)],
            },
            bin,
        }
    }
}

/// Adds a plain grouping prim at `path` and returns the path.
fn group(prims: &mut Vec<XformPrim>, path: String, prim_type: &'static str) -> String {
    prims.push(XformPrim { path: path.clone(), prim_type, transform: None, label: None, room: None });
    path
}

/// Adds the grouping Xform at `path` unless it exists already; returns the path.
fn once(names: &mut Names, prims: &mut Vec<XformPrim>, path: String) -> String {
    if names.0.insert(path.clone()) { group(prims, path, "Xform") } else { path }
}

fn material_path(looks: &str, index: usize, name: &str) -> String {
    format!("{looks}/m{index:03}_{}", identifier(name))
}

fn push_f32(bin: &mut Vec<u8>, values: impl Iterator<Item = f32>, per_element: usize) -> Span {
    let offset = bin.len();
    for v in values {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    Span { offset, count: (bin.len() - offset) / 4 / per_element }
}

fn push_u32(bin: &mut Vec<u8>, values: &[u32]) -> Span {
    let offset = bin.len();
    for v in values {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    Span { offset, count: values.len() }
}

/// A frame whose local -Z is `emit` (UsdLux lights emit along -Z), with local X along `x_hint`
/// where possible, placed at `origin`.
fn emitter_frame(emit: Vec3, x_hint: Vec3, origin: Vec3) -> Mat4 {
    let z = -emit.normalize_or(Vec3::NEG_Z);
    let mut x = x_hint.reject_from_normalized(z).normalize_or_zero();
    if x == Vec3::ZERO {
        x = z.any_orthonormal_vector();
    }
    let y = z.cross(x);
    Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), origin.extend(1.0))
}

/// The UsdLux form of `light` (see the module docs for the unit conversions); `None` when a
/// field its kind needs is missing.
fn light_prim(light: &Light, path: String) -> Option<LightPrim> {
    let unit = match light.unit {
        LightUnit::Cd => "cd",
        LightUnit::Lux => "lux",
        LightUnit::Nit => "nit",
    };
    let base = LightPrim {
        path,
        light_type: "",
        transform: Mat4::IDENTITY.to_cols_array(),
        intensity: light.intensity,
        normalize: false,
        color: light.color,
        radius: None,
        width: None,
        height: None,
        angle: None,
        source_intensity: light.intensity,
        source_unit: unit,
    };
    Some(match light.kind {
        LightKind::Directional => LightPrim {
            light_type: "DistantLight",
            transform: emitter_frame(light.direction?, Vec3::X, Vec3::ZERO).to_cols_array(),
            normalize: true,
            angle: Some(SUN_ANGLE_DEG),
            ..base
        },
        LightKind::Point => {
            let r = POINT_LIGHT_RADIUS_M;
            LightPrim {
                light_type: "SphereLight",
                transform: Mat4::from_translation(light.position?).to_cols_array(),
                intensity: light.intensity / (std::f32::consts::PI * r * r),
                radius: Some(r),
                ..base
            }
        }
        LightKind::Rect => {
            let (u, v) = (light.rect_u?, light.rect_v?);
            LightPrim {
                light_type: "RectLight",
                transform: emitter_frame(light.direction?, u, light.position?).to_cols_array(),
                width: Some(u.length()),
                height: Some(v.length()),
                ..base
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec2, Vec3};
    use scene_gen_scene::scene::{
        Door, Envelope, Geometry, Material, Mesh, Node, Object, ObjectClass, Primitive, Room, Threshold,
    };

    fn quad(material: usize) -> Primitive {
        Primitive {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            normals: vec![Vec3::Z; 4],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::new(0.0, 0.25)],
            indices: vec![0, 1, 2, 0, 2, 3],
            material,
        }
    }

    fn light(kind: LightKind, intensity: f32, unit: LightUnit) -> Light {
        Light {
            id: 0,
            group: LightGroup::Night,
            kind,
            position: Some(Vec3::new(1.0, 2.0, 2.5)),
            direction: Some(Vec3::new(0.0, 1.0, 0.0)),
            rect_u: Some(Vec3::new(1.2, 0.0, 0.0)),
            rect_v: Some(Vec3::new(0.0, 0.0, 0.8)),
            intensity,
            unit,
            color: [1.0, 0.9, 0.8],
            room: Some(0),
            object: None,
        }
    }

    fn scene() -> Scene {
        let material = Material {
            name: "oak wood".into(),
            base_color: [0.5, 0.4, 0.3, 1.0],
            metallic: 0.0,
            roughness: 0.7,
            base_color_texture: None,
        };
        let node = |name: &str, semantic| Node {
            name: name.into(),
            mesh: 0,
            transform: Mat4::from_translation(Vec3::new(1.0, 2.0, 0.0)),
            semantic,
        };
        Scene {
            seed: 3,
            envelope: Envelope::default(),
            wall_thickness_m: 0.1,
            house: scene_gen_scene::scene::HouseRecord::default(),
            palette: None,
            rooms: vec![Room { id: 0, room_type: "bedroom".into(), min: Vec2::ZERO, max: Vec2::new(5.0, 5.0) }],
            walls: vec![],
            doors: vec![Door {
                id: 0,
                rooms: [Some(0), None],
                wall: 0,
                center: Vec3::new(2.5, 0.0, 1.0),
                width_m: 0.9,
                height_m: 2.0,
                normal: Vec2::NEG_Y,
                leaf: None,
            }],
            windows: vec![],
            thresholds: vec![Threshold { id: 0, door: 0, instance_id: 1, min: Vec3::ZERO, max: Vec3::ONE }],
            objects: vec![Object {
                id: 0,
                class: ObjectClass::Chair,
                instance_id: 2,
                room: 0,
                asset: "chair/a".into(),
                min: Vec3::ZERO,
                max: Vec3::ONE,
                yaw_deg: 0.0,
                on: None,
            }],
            furnishings: Vec::new(),
            lights: vec![
                light(LightKind::Point, 10.0, LightUnit::Cd),
                Light { id: 1, group: LightGroup::Day, ..light(LightKind::Rect, 300.0, LightUnit::Nit) },
                Light { id: 2, group: LightGroup::Day, ..light(LightKind::Directional, 16.0, LightUnit::Lux) },
            ],
            geometry: Geometry {
                meshes: vec![Mesh { name: "quad".into(), primitives: vec![quad(0), quad(0)] }],
                materials: vec![material],
                textures: vec![],
                nodes: vec![
                    node("floor 0", Semantic::Floor { room: 0 }),
                    node("chair", Semantic::Object { id: 0 }),
                    node("chair", Semantic::Object { id: 0 }),
                    node("threshold", Semantic::Threshold { id: 0 }),
                    node("rug_0", Semantic::Decor { room: 0 }),
                ],
            },
        }
    }

    fn prim<'a>(plan: &'a UsdPlan, path: &str) -> &'a XformPrim {
        plan.doc.prims.iter().find(|p| p.path == path).unwrap_or_else(|| panic!("no prim {path}"))
    }

    #[test]
    fn labelled_roots_sit_under_their_room_and_carry_labels() {
        let plan = UsdPlan::of(&scene());
        let chair = prim(&plan, "/World/Rooms/room_0/Objects/chair_0");
        assert_eq!(chair.label, Some(LabelSpec { class: "chair".into(), class_id: 4, instance_id: 2, room: Some(0) }));
        // Two nodes of one object share one root; their geometry prims get unique names that
        // never repeat the root's own name (importers rename such pairs).
        prim(&plan, "/World/Rooms/room_0/Objects/chair_0/geom");
        prim(&plan, "/World/Rooms/room_0/Objects/chair_0/geom_1");
        let threshold = prim(&plan, "/World/Thresholds/threshold_0");
        assert_eq!(threshold.label.as_ref().map(|l| (l.class.as_str(), l.class_id)), Some(("threshold", 11)));
        prim(&plan, "/World/Rooms/room_0/floor_0");
        prim(&plan, "/World/Rooms/room_0/Decor/rug_0");
        assert_eq!(prim(&plan, "/World/Rooms/room_0").room, Some((0, "bedroom".into())));
        // Only the two labelled roots are labelled.
        assert_eq!(plan.doc.prims.iter().filter(|p| p.label.is_some()).count(), 2);
    }

    #[test]
    fn every_prim_comes_after_its_parent_and_paths_are_unique() {
        let plan = UsdPlan::of(&scene());
        let mut seen = BTreeSet::new();
        let paths = plan.doc.prims.iter().map(|p| &p.path).chain(plan.doc.meshes.iter().map(|m| &m.path));
        for path in paths {
            let parent = &path[..path.rfind('/').unwrap()];
            assert!(parent.is_empty() || seen.contains(parent), "{path} before its parent");
            assert!(seen.insert(path.as_str()), "{path} twice");
            assert!(path[1..].split('/').all(|n| !n.starts_with(|c: char| c.is_ascii_digit()) && !n.contains(' ')));
        }
        assert_eq!(plan.doc.meshes.len(), 10, "five nodes of two primitives each");
        assert!(plan.doc.meshes.iter().all(|m| m.material == "/World/Looks/m000_oak_wood"));
    }

    #[test]
    fn vertex_arrays_round_trip_through_the_binary_with_st_flipped() {
        let plan = UsdPlan::of(&scene());
        let mesh = &plan.doc.meshes[0];
        let f32_at = |i: usize| f32::from_le_bytes(plan.bin[i..i + 4].try_into().unwrap());
        assert_eq!((mesh.points.count, mesh.normals.count, mesh.st.count, mesh.indices.count), (4, 4, 4, 6));
        assert_eq!(f32_at(mesh.points.offset + 4 * 6), 1.0, "third point's x");
        // The last uv (0, 0.25) becomes st (0, 0.75).
        assert_eq!(f32_at(mesh.st.offset + 4 * 7), 0.75);
        let last_index =
            u32::from_le_bytes(plan.bin[mesh.indices.offset + 20..mesh.indices.offset + 24].try_into().unwrap());
        assert_eq!(last_index, 3);
    }

    #[test]
    fn lights_convert_to_usdlux_units_and_frames() {
        let plan = UsdPlan::of(&scene());
        let [point, rect, sun] = [0, 1, 2]
            .map(|i| plan.doc.lights.iter().find(|l| l.path.ends_with(&format!("light_{i}"))).unwrap().clone());
        assert!(point.path.starts_with("/World/Lights/Night/") && sun.path.starts_with("/World/Lights/Day/"));
        // 10 cd from a sphere of radius r: luminance 10 / (pi r^2).
        let r = POINT_LIGHT_RADIUS_M;
        assert!((point.intensity * std::f32::consts::PI * r * r - 10.0).abs() < 1e-3);
        assert_eq!((point.light_type, point.normalize, point.radius), ("SphereLight", false, Some(r)));
        assert_eq!(Mat4::from_cols_array(&point.transform).w_axis.truncate(), Vec3::new(1.0, 2.0, 2.5));
        // Rect: emits along its local -Z = our direction (+Y), keeps its luminance and size.
        let m = Mat4::from_cols_array(&rect.transform);
        assert!((-m.z_axis.truncate() - Vec3::Y).length() < 1e-6);
        assert!((m.x_axis.truncate() - Vec3::X).length() < 1e-6);
        assert!((m.x_axis.truncate().cross(m.y_axis.truncate()) - m.z_axis.truncate()).length() < 1e-6);
        assert_eq!((rect.intensity, rect.width, rect.height), (300.0, Some(1.2), Some(0.8)));
        // The sun: a normalized DistantLight reads intensity as lux.
        assert_eq!((sun.light_type, sun.normalize, sun.intensity), ("DistantLight", true, 16.0));
        assert_eq!(plan.doc.light_groups[0], ("day", "/World/Lights/Day".to_string()));
    }

    #[test]
    fn identifiers_are_valid_prim_names() {
        assert_eq!(identifier("3 legs-chair"), "_3_legs_chair");
        assert_eq!(identifier(""), "_");
        assert_eq!(identifier("table_2"), "table_2");
    }

    #[test]
    fn missing_python_names_the_install_command() {
        let err = check_usd_core(Path::new("/nonexistent/python3")).unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, UsdError::UsdCoreMissing { .. }));
        assert!(text.contains(".venv/bin/pip install usd-core==26.11"), "{text}");
    }
}
