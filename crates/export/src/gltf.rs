//! glTF 2.0 export: binary `.glb` ([`to_glb`]) or `.gltf` + `.bin` + PNG textures ([`to_gltf`]).
//!
//! Written with the `gltf-json` types. What a reader can rely on:
//!
//! * **Frame.** glTF is Y up, metres; the world is Z up (X east, Y north). Every vertex and
//!   normal is converted explicitly with `C: (x, y, z) -> (x, z, -y)` and every node transform
//!   `M` becomes `C M C^-1` (written as translation / rotation / scale), so each node carries
//!   its world-correct glTF transform and there is no hidden root node.
//! * **Nodes.** One glTF node per [`scene_gen_scene::scene::Node`], all roots of the one scene. Objects
//!   are named `<class>_<id>` with `extras` {class, class_id, instance_id, room, room_type};
//!   thresholds `threshold_<id>` with {class: "threshold", class_id: 11, instance_id, room,
//!   room_type, door}; structure and decor keep their names with {kind, room | wall | id}.
//! * **Meshes** are shared: one glTF mesh per scene mesh, whatever the number of nodes placing
//!   it. Accessors carry min/max; indices are u16 when every index fits below 65535 (the u16
//!   primitive-restart value), else u32.
//! * **Materials** are metallic-roughness with the baked texture as `baseColorTexture`; one
//!   sampler, REPEAT both ways with trilinear mipmapping (texture coordinates are metres).
//! * **Lights** use `KHR_lights_punctual`, each on its own node `light_<id>` with `extras`
//!   {group, id}; see the private `light` function for how rectangle lights are approximated.
//!
//! The output is a pure function of the scene: same scene, same bytes.

use std::collections::BTreeMap;

use glam::{Mat3, Mat4, Quat, Vec2, Vec3};
use gltf_json as json;
use json::extensions::scene::khr_lights_punctual as khr;
use json::validation::{Checked::Valid, USize64};
use serde_json::json as value;

use scene_gen_scene::scene::{Light, LightGroup, LightKind, OpeningKind, Scene, Semantic};

/// Encodes `scene` as one GLB file (JSON chunk + binary chunk holding geometry and PNGs).
#[must_use]
pub fn to_glb(scene: &Scene) -> Vec<u8> {
    let (root, bin) = build(scene, Images::Embedded);
    let mut json_bytes = root.to_vec().expect("glTF JSON of plain data always serialises");
    pad(&mut json_bytes, b' ');
    let total = 12 + 8 + json_bytes.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut prefix = Vec::with_capacity(total - bin.len());
    prefix.extend_from_slice(b"glTF");
    prefix.extend_from_slice(&2u32.to_le_bytes());
    prefix.extend_from_slice(&u32_len(total).to_le_bytes());
    prefix.extend_from_slice(&u32_len(json_bytes.len()).to_le_bytes());
    prefix.extend_from_slice(b"JSON");
    prefix.extend_from_slice(&json_bytes);
    if bin.is_empty() {
        return prefix;
    }
    prefix.extend_from_slice(&u32_len(bin.len()).to_le_bytes());
    prefix.extend_from_slice(b"BIN\0");
    // The binary buffer was allocated with headroom for this prefix: shifting it in place
    // touches no new memory, where copying megabytes into a fresh Vec spent most of the
    // export's time in page faults.
    let mut out = bin;
    out.splice(0..0, prefix);
    out
}

/// Name of the binary buffer file written by [`to_gltf`].
pub const BIN_FILE: &str = "scene.bin";

/// Encodes `scene` as separate files: `scene.gltf`, [`BIN_FILE`] and `textures/<n>_<name>.png`,
/// as (relative path, bytes) pairs in a fixed order.
#[must_use]
pub fn to_gltf(scene: &Scene) -> Vec<(String, Vec<u8>)> {
    let (root, bin) = build(scene, Images::Files);
    let mut files = vec![("scene.gltf".to_string(), root.to_vec_pretty().expect("glTF JSON always serialises"))];
    if !bin.is_empty() {
        files.push((BIN_FILE.to_string(), bin));
    }
    for (i, texture) in scene.geometry.textures.iter().enumerate() {
        files.push((texture_file(i, &texture.name), texture.png.to_vec()));
    }
    files
}

/// Relative path of texture `index` in the `.gltf` form; the name is reduced to a safe
/// character set and prefixed with the index, so paths are unique.
fn texture_file(index: usize, name: &str) -> String {
    let safe: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
    format!("textures/{index}_{safe}.png")
}

/// The world-to-glTF change of basis `C: (x, y, z) -> (x, z, -y)`.
#[must_use]
pub fn to_y_up(p: Vec3) -> Vec3 {
    // `0.0 - y` rather than `-y`: a zero stays +0.0 instead of becoming -0.0 in the JSON.
    Vec3::new(p.x, p.z, 0.0 - p.y)
}

/// `C` as a matrix (a rotation of -90 degrees about X).
fn basis() -> Mat4 {
    Mat4::from_cols(Vec3::X.extend(0.0), Vec3::NEG_Z.extend(0.0), Vec3::Y.extend(0.0), glam::Vec4::W)
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Images {
    /// PNGs in buffer views of the binary chunk (GLB).
    Embedded,
    /// PNGs as files next to the `.gltf`, referenced by URI.
    Files,
}

/// Appends `fill` bytes until the length is a multiple of 4 (GLB chunk and accessor
/// alignment).
fn pad(bytes: &mut Vec<u8>, fill: u8) {
    while bytes.len() % 4 != 0 {
        bytes.push(fill);
    }
}

fn u32_len(n: usize) -> u32 {
    u32::try_from(n).expect("a GLB larger than 4 GiB is not representable")
}

/// The document being built and its binary buffer.
struct Builder {
    root: json::Root,
    bin: Vec<u8>,
}

impl Builder {
    /// Adds `bytes` as a buffer view (4-byte aligned) and returns it.
    fn view(&mut self, bytes: &[u8], target: Option<json::buffer::Target>) -> json::Index<json::buffer::View> {
        self.view_with(target, |bin| bin.extend_from_slice(bytes))
    }

    /// Adds a buffer view (4-byte aligned) holding what `write` appends to the buffer; writing
    /// in place avoids an intermediate copy of every array.
    fn view_with(
        &mut self,
        target: Option<json::buffer::Target>,
        write: impl FnOnce(&mut Vec<u8>),
    ) -> json::Index<json::buffer::View> {
        pad(&mut self.bin, 0);
        let offset = self.bin.len();
        write(&mut self.bin);
        self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(self.bin.len() - offset),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: target.map(Valid),
            extensions: None,
            extras: None,
        })
    }

    /// Adds a vertex attribute accessor of `N`-component float vectors, with min/max.
    fn floats<const N: usize>(&mut self, data: impl ExactSizeIterator<Item = [f32; N]>) -> json::Index<json::Accessor> {
        let count = data.len();
        let (mut lo, mut hi) = ([f32::INFINITY; N], [f32::NEG_INFINITY; N]);
        let view = self.view_with(Some(json::buffer::Target::ArrayBuffer), |bin| {
            // Size once, then fill fixed-size chunks: no per-float capacity checks.
            let start = bin.len();
            bin.resize(start + count * N * 4, 0);
            for (chunk, v) in bin[start..].chunks_exact_mut(N * 4).zip(data) {
                for k in 0..N {
                    chunk[k * 4..k * 4 + 4].copy_from_slice(&v[k].to_le_bytes());
                    if v[k] < lo[k] {
                        lo[k] = v[k];
                    }
                    if v[k] > hi[k] {
                        hi[k] = v[k];
                    }
                }
            }
        });
        let type_ = match N {
            2 => json::accessor::Type::Vec2,
            3 => json::accessor::Type::Vec3,
            _ => unreachable!("only VEC2 and VEC3 attributes are written"),
        };
        let (lo, hi) = (value!(lo.as_slice()), value!(hi.as_slice()));
        self.accessor(view, count, json::accessor::ComponentType::F32, type_, lo, hi)
    }

    /// Adds an index accessor, u16 when every index is below 65535, else u32.
    fn indices(&mut self, indices: &[u32]) -> json::Index<json::Accessor> {
        let lo = indices.iter().copied().min().unwrap_or(0);
        let hi = indices.iter().copied().max().unwrap_or(0);
        let short = hi < 65535;
        let view = self.view_with(Some(json::buffer::Target::ElementArrayBuffer), |bin| {
            let start = bin.len();
            if short {
                bin.resize(start + indices.len() * 2, 0);
                for (chunk, &i) in bin[start..].chunks_exact_mut(2).zip(indices) {
                    chunk.copy_from_slice(&(i as u16).to_le_bytes());
                }
            } else {
                bin.resize(start + indices.len() * 4, 0);
                for (chunk, &i) in bin[start..].chunks_exact_mut(4).zip(indices) {
                    chunk.copy_from_slice(&i.to_le_bytes());
                }
            }
        });
        let component = if short { json::accessor::ComponentType::U16 } else { json::accessor::ComponentType::U32 };
        self.accessor(view, indices.len(), component, json::accessor::Type::Scalar, value!([lo]), value!([hi]))
    }

    fn accessor(
        &mut self,
        view: json::Index<json::buffer::View>,
        count: usize,
        component: json::accessor::ComponentType,
        type_: json::accessor::Type,
        min: json::Value,
        max: json::Value,
    ) -> json::Index<json::Accessor> {
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: None,
            type_: Valid(type_),
            min: Some(min),
            max: Some(max),
            name: None,
            normalized: false,
            sparse: None,
        })
    }
}

fn extras(v: &json::Value) -> json::Extras {
    Some(serde_json::value::to_raw_value(v).expect("a JSON value always serialises"))
}

/// Builds the glTF document and its binary buffer.
fn build(scene: &Scene, images: Images) -> (json::Root, Vec<u8>) {
    // Reserve the whole binary buffer up front (vertex data, indices, PNGs, alignment) so it is
    // written without reallocating: on big scenes the copies of a growing buffer dominated.
    let geometry = &scene.geometry;
    let vertex_bytes: usize = (geometry.meshes.iter().flat_map(|m| &m.primitives))
        .map(|p| p.positions.len() * 32 + p.indices.len() * 4 + 16)
        .sum();
    let png_bytes: usize = match images {
        Images::Embedded => geometry.textures.iter().map(|t| t.png.len() + 4).sum(),
        Images::Files => 0,
    };
    // Headroom for the GLB header and JSON chunk that [`to_glb`] shifts in front (a generous
    // estimate of the JSON: a few hundred bytes per node, accessor, material or texture).
    let items = geometry.nodes.len() + geometry.materials.len() + 3 * geometry.textures.len() + 2 * scene.lights.len();
    let accessors: usize = geometry.meshes.iter().map(|m| 8 * m.primitives.len()).sum();
    let headroom = 4096 + 320 * (items + accessors);
    let bin = Vec::with_capacity(vertex_bytes + png_bytes + headroom);
    let mut b = Builder { root: json::Root::default(), bin };
    b.root.asset =
        json::Asset { generator: Some(format!("scene-gen {}", env!("CARGO_PKG_VERSION"))), ..json::Asset::default() };

    // Textures: one image and one texture per scene texture, all with the one sampler.
    let sampler = (!geometry.textures.is_empty()).then(|| {
        b.root.push(json::texture::Sampler {
            mag_filter: Some(Valid(json::texture::MagFilter::Linear)),
            min_filter: Some(Valid(json::texture::MinFilter::LinearMipmapLinear)),
            wrap_s: Valid(json::texture::WrappingMode::Repeat),
            wrap_t: Valid(json::texture::WrappingMode::Repeat),
            ..json::texture::Sampler::default()
        })
    });
    for (i, texture) in geometry.textures.iter().enumerate() {
        let (buffer_view, uri) = match images {
            Images::Embedded => (Some(b.view(&texture.png, None)), None),
            Images::Files => (None, Some(texture_file(i, &texture.name))),
        };
        let image = b.root.push(json::Image {
            buffer_view,
            mime_type: Some(json::image::MimeType("image/png".into())),
            name: Some(texture.name.clone()),
            uri,
            extensions: None,
            extras: None,
        });
        b.root.push(json::Texture {
            name: Some(texture.name.clone()),
            sampler,
            source: image,
            extensions: None,
            extras: None,
        });
    }

    for material in &geometry.materials {
        let texture = material.base_color_texture.filter(|&t| t < geometry.textures.len()).map(|t| {
            json::texture::Info { index: json::Index::new(t as u32), tex_coord: 0, extensions: None, extras: None }
        });
        let blend = material.base_color[3] < 1.0;
        b.root.push(json::Material {
            name: Some(material.name.clone()),
            alpha_mode: Valid(if blend { json::material::AlphaMode::Blend } else { json::material::AlphaMode::Opaque }),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor(material.base_color),
                base_color_texture: texture,
                metallic_factor: json::material::StrengthFactor(material.metallic.clamp(0.0, 1.0)),
                roughness_factor: json::material::StrengthFactor(material.roughness.clamp(0.0, 1.0)),
                ..Default::default()
            },
            ..json::Material::default()
        });
    }

    // Meshes: None for a scene mesh without a drawable primitive (glTF needs at least one).
    let mut meshes = Vec::with_capacity(geometry.meshes.len());
    for mesh in &geometry.meshes {
        let mut primitives = Vec::new();
        for p in &mesh.primitives {
            let n = p.positions.len();
            if n == 0 || p.indices.is_empty() || p.normals.len() != n || p.uvs.len() != n {
                continue;
            }
            let positions = p.positions.iter().map(|&v| to_y_up(v).to_array());
            let normals = p.normals.iter().map(|&v| to_y_up(v).try_normalize().unwrap_or(Vec3::Y).to_array());
            let uvs = p.uvs.iter().map(|&v: &Vec2| v.to_array());
            let mut attributes = BTreeMap::new();
            attributes.insert(Valid(json::mesh::Semantic::Positions), b.floats(positions));
            attributes.insert(Valid(json::mesh::Semantic::Normals), b.floats(normals));
            attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), b.floats(uvs));
            let indices = b.indices(&p.indices);
            primitives.push(json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: None,
                indices: Some(indices),
                material: (p.material < geometry.materials.len()).then(|| json::Index::new(p.material as u32)),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            });
        }
        meshes.push((!primitives.is_empty()).then(|| {
            b.root.push(json::Mesh {
                extensions: None,
                extras: None,
                name: Some(mesh.name.clone()),
                primitives,
                weights: None,
            })
        }));
    }

    let c = basis();
    let c_inv = c.transpose();
    let mut roots = Vec::new();
    for node in &geometry.nodes {
        let (name, extra) = describe(scene, node.semantic, &node.name);
        let mut gltf_node = trs(c * node.transform * c_inv);
        gltf_node.name = Some(name);
        gltf_node.extras = extras(&extra);
        gltf_node.mesh = meshes.get(node.mesh).copied().flatten();
        roots.push(b.root.push(gltf_node));
    }

    // The extension structs gain an `others` field when gltf-json's `extensions` feature is on
    // (another crate in the build may enable it), hence `..Default::default()`.
    #[allow(clippy::needless_update)]
    if !scene.lights.is_empty() {
        let mut lights = Vec::with_capacity(scene.lights.len());
        for l in &scene.lights {
            let (gltf_light, mut node) = light(l);
            let index = json::Index::<khr::Light>::new(lights.len() as u32);
            lights.push(gltf_light);
            node.extensions = Some(json::extensions::scene::Node {
                khr_lights_punctual: Some(khr::KhrLightsPunctual { light: index }),
                ..Default::default()
            });
            roots.push(b.root.push(node));
        }
        b.root.extensions = Some(json::extensions::root::Root {
            khr_lights_punctual: Some(json::extensions::root::KhrLightsPunctual { lights }),
            ..Default::default()
        });
        b.root.extensions_used.push("KHR_lights_punctual".into());
    }

    let gltf_scene = b.root.push(json::Scene {
        extensions: None,
        extras: extras(&value!({ "seed": scene.seed })),
        name: Some(format!("scene_{}", scene.seed)),
        nodes: roots,
    });
    b.root.scene = Some(gltf_scene);

    pad(&mut b.bin, 0);
    if !b.bin.is_empty() {
        let uri = (images == Images::Files).then(|| BIN_FILE.to_string());
        b.root.push(json::Buffer {
            byte_length: USize64::from(b.bin.len()),
            name: None,
            uri,
            extensions: None,
            extras: None,
        });
    }
    (b.root, b.bin)
}

/// A node with the translation / rotation / scale of `m` (a glTF-frame matrix), identity parts
/// left out; or with `m` as a matrix when it is not a T R S product (a shear), which TRS cannot
/// represent.
fn trs(m: Mat4) -> json::Node {
    let (scale, rotation, translation) = m.to_scale_rotation_translation();
    let rotation = rotation.normalize();
    let recomposed = Mat4::from_scale_rotation_translation(scale, rotation, translation);
    let tolerance = 1e-4 * m.to_cols_array().iter().fold(1.0f32, |a, x| a.max(x.abs()));
    if !recomposed.abs_diff_eq(m, tolerance) {
        return json::Node { matrix: Some(m.to_cols_array()), ..json::Node::default() };
    }
    json::Node {
        translation: (translation != Vec3::ZERO).then(|| translation.to_array()),
        rotation: (rotation != Quat::IDENTITY).then(|| json::scene::UnitQuaternion(rotation.to_array())),
        scale: (!scale.abs_diff_eq(Vec3::ONE, 1e-6)).then(|| scale.to_array()),
        ..json::Node::default()
    }
}

/// Name and `extras` of the node of a semantic item.
fn describe(scene: &Scene, semantic: Semantic, name: &str) -> (String, json::Value) {
    let room_type = |room: Option<u32>| room.and_then(|r| scene.room(r)).map(|r| r.room_type.clone());
    match (semantic, scene.label(semantic)) {
        (Semantic::Object { id }, Some(label)) => (
            format!("{}_{id}", label.class),
            value!({
                "class": label.class, "class_id": label.class_id, "instance_id": label.instance_id,
                "room": label.room, "room_type": room_type(label.room),
            }),
        ),
        (Semantic::Threshold { id }, Some(label)) => (
            format!("threshold_{id}"),
            value!({
                "class": label.class, "class_id": label.class_id, "instance_id": label.instance_id,
                "room": label.room, "room_type": room_type(label.room),
                "door": scene.thresholds.get(id as usize).map(|t| t.door),
            }),
        ),
        (Semantic::Floor { room }, _) => (name.into(), value!({ "kind": "floor", "room": room })),
        (Semantic::Ceiling { room }, _) => (name.into(), value!({ "kind": "ceiling", "room": room })),
        (Semantic::Decor { room }, _) => (name.into(), value!({ "kind": "decor", "room": room })),
        (Semantic::Furnishing { id }, _) => {
            let f = scene.furnishings.get(id as usize);
            let room = f.map(|f| f.room);
            (
                name.into(),
                value!({
                    "kind": "furnishing", "id": id, "furnishing": f.map(|f| f.kind.name()),
                    "room": room, "room_type": room_type(room),
                }),
            )
        }
        (Semantic::Wall { wall }, _) => {
            let rooms = scene.walls.iter().find(|w| w.id == wall).map(|w| w.rooms);
            (name.into(), value!({ "kind": "wall", "wall": wall, "rooms": rooms }))
        }
        (Semantic::Opening { kind, id }, _) => {
            let kind = match kind {
                OpeningKind::Door => "door",
                OpeningKind::Window => "window",
            };
            (name.into(), value!({ "kind": kind, "id": id }))
        }
        // A label that does not resolve (an id out of range) keeps the node, unlabelled.
        (Semantic::Object { id }, None) => (name.into(), value!({ "kind": "object", "id": id })),
        (Semantic::Threshold { id }, None) => (name.into(), value!({ "kind": "threshold", "id": id })),
    }
}

/// Outer cone half-angle of the spot lights standing in for rectangle lights: just under the
/// 90 degrees `KHR_lights_punctual` allows (a Lambertian emitter lights a full hemisphere).
const RECT_OUTER_CONE_RAD: f32 = 1.5;

/// The `KHR_lights_punctual` light of `l` and the node that places it (glTF lights shine
/// along the node's local -Z).
///
/// * point: intensity in candela, as is;
/// * directional: illuminance in lux, as is, node oriented along `direction`;
/// * rect (a window or a ceiling panel): glTF has no area light, so it becomes a spot light at
///   the rectangle's centre pointing along `direction`, with the on-axis intensity of a
///   Lambertian rectangle, `I = L * A` (luminance in nit times area in m^2, giving candela),
///   no inner cone and a wide outer cone ([`RECT_OUTER_CONE_RAD`]). The node's local X is
///   laid along the rectangle's `u` edge so importers that rebuild area lights can.
fn light(l: &Light) -> (khr::Light, json::Node) {
    let position = to_y_up(l.position.unwrap_or(Vec3::ZERO));
    let direction = to_y_up(l.direction.unwrap_or(Vec3::NEG_Z)).try_normalize().unwrap_or(Vec3::NEG_Y);
    let (type_, intensity, spot) = match l.kind {
        LightKind::Point => (khr::Type::Point, l.intensity, None),
        LightKind::Directional => (khr::Type::Directional, l.intensity, None),
        LightKind::Rect => {
            let (u, v) = (l.rect_u.unwrap_or(Vec3::ZERO), l.rect_v.unwrap_or(Vec3::ZERO));
            let area_m2 = u.cross(v).length();
            let spot = khr::Spot { inner_cone_angle: 0.0, outer_cone_angle: RECT_OUTER_CONE_RAD };
            (khr::Type::Spot, l.intensity * area_m2, Some(spot))
        }
    };
    let rotation = match l.kind {
        LightKind::Point => Quat::IDENTITY,
        _ => orient(direction, l.rect_u.map(to_y_up)),
    };
    let group = match l.group {
        LightGroup::Day => "day",
        LightGroup::Night => "night",
    };
    let name = format!("light_{}", l.id);
    let gltf_light = khr::Light {
        color: l.color,
        extensions: None,
        extras: extras(&value!({ "group": group, "id": l.id })),
        intensity,
        name: Some(name.clone()),
        range: None,
        spot,
        type_: Valid(type_),
    };
    let mut node = trs(Mat4::from_rotation_translation(rotation, position));
    node.name = Some(name);
    node.extras = extras(&value!({ "group": group, "id": l.id }));
    (gltf_light, node)
}

/// The rotation taking local -Z to `direction` (unit, glTF frame), and local X to `x_hint`
/// projected perpendicular to it when that is possible.
fn orient(direction: Vec3, x_hint: Option<Vec3>) -> Quat {
    let z = -direction;
    // A hint (almost) along the direction says nothing about the roll: fall back to the
    // shortest rotation.
    let perpendicular = x_hint.map(|h| h - z * h.dot(z)).filter(|x| x.length() > 1e-3);
    if let Some(x) = perpendicular.and_then(Vec3::try_normalize) {
        let y = z.cross(x);
        Quat::from_mat3(&Mat3::from_cols(x, y, z)).normalize()
    } else {
        Quat::from_rotation_arc(Vec3::NEG_Z, direction)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn y_up_conversion_matches_the_basis_matrix() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        assert_eq!(to_y_up(p), Vec3::new(1.0, 3.0, -2.0));
        assert_eq!(basis().transform_point3(p), to_y_up(p));
        // C is a proper rotation, so its inverse is its transpose and handedness is kept.
        assert!((basis().determinant() - 1.0).abs() < 1e-6);
    }

    proptest::proptest! {
        /// For any placement T R S, the exported node transform is C M C^-1: a world point p
        /// placed by the node lands on C (M p).
        #[test]
        fn node_transforms_conjugate_by_the_basis(
            t in proptest::array::uniform3(-20.0f32..20.0),
            axis in proptest::array::uniform3(-1.0f32..1.0),
            angle in -3.1f32..3.1,
            s in proptest::array::uniform3(0.1f32..3.0),
            p in proptest::array::uniform3(-1.0f32..1.0),
        ) {
            let axis = Vec3::from(axis).try_normalize().unwrap_or(Vec3::Z);
            let m = Mat4::from_scale_rotation_translation(Vec3::from(s), Quat::from_axis_angle(axis, angle), Vec3::from(t));
            let node = trs(basis() * m * basis().transpose());
            let gltf_m = node.matrix.map(|a| Mat4::from_cols_array(&a)).unwrap_or_else(|| {
                Mat4::from_scale_rotation_translation(
                    Vec3::from(node.scale.unwrap_or([1.0; 3])),
                    Quat::from_array(node.rotation.map_or([0.0, 0.0, 0.0, 1.0], |q| q.0)),
                    Vec3::from(node.translation.unwrap_or([0.0; 3])),
                )
            });
            let p = Vec3::from(p);
            let want = to_y_up(m.transform_point3(p));
            let got = gltf_m.transform_point3(to_y_up(p));
            proptest::prop_assert!(got.abs_diff_eq(want, 1e-3), "{} vs {}", got, want);
        }

        /// Directional and rect lights shine (local -Z) along their converted direction.
        #[test]
        fn any_direction_is_reproduced(d in proptest::array::uniform3(-1.0f32..1.0), u in proptest::array::uniform3(-1.0f32..1.0)) {
            let Some(d) = Vec3::from(d).try_normalize() else { return Ok(()) };
            let q = orient(d, Some(Vec3::from(u)));
            proptest::prop_assert!(q.is_normalized());
            proptest::prop_assert!(q.mul_vec3(Vec3::NEG_Z).abs_diff_eq(d, 1e-4));
        }
    }

    #[test]
    fn lights_point_along_their_direction() {
        for (d, hint) in [(Vec3::NEG_Y, Some(Vec3::X)), (Vec3::new(0.3, -0.5, 0.8).normalize(), None), (Vec3::Z, None)]
        {
            let q = orient(d, hint);
            assert!(q.mul_vec3(Vec3::NEG_Z).abs_diff_eq(d, 1e-5), "{d:?}");
            if let Some(h) = hint {
                assert!(q.mul_vec3(Vec3::X).abs_diff_eq(h, 1e-5));
            }
        }
    }
}
