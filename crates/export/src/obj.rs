//! Wavefront OBJ export: `scene.obj`, `scene.mtl` and `textures/*.png`.
//!
//! OBJ has no node hierarchy and no instancing, so every node's mesh is written out in world
//! coordinates as one object (`o`) and group (`g`) of the same name: objects as `<class>_<id>`
//! (the label a user filters on), thresholds as `threshold_<id>`, structure and decor under
//! their node names. Coordinates are
//! Y up, metres, the convention OBJ importers (Blender, Unreal) assume: world (x, y, z) is
//! written as (x, z, -y).

use std::fmt::Write as _;

use glam::{Mat3, Mat4, Vec3};

use scene_gen_scene::scene::{Material, Scene, Semantic};

/// Z-up world to Y-up OBJ.
fn to_y_up(p: Vec3) -> Vec3 {
    // `+ 0.0` turns -0.0 into 0.0 so files never print "-0".
    Vec3::new(p.x, p.z, -p.y) + Vec3::ZERO
}

/// The files of an OBJ export, as (relative path, bytes), in a fixed order.
#[must_use]
pub fn to_obj(scene: &Scene) -> Vec<(String, Vec<u8>)> {
    let mut files = vec![
        ("scene.obj".to_string(), obj_text(scene).into_bytes()),
        ("scene.mtl".to_string(), mtl_text(scene).into_bytes()),
    ];
    for (i, texture) in scene.geometry.textures.iter().enumerate() {
        files.push((texture_path(i, &texture.name), texture.png.to_vec()));
    }
    files
}

/// Group name of a node: the class label for labelled nodes, else the node's own name.
#[must_use]
pub fn group_name(scene: &Scene, semantic: Semantic, node_name: &str) -> String {
    match (semantic, scene.label(semantic)) {
        (Semantic::Object { id } | Semantic::Threshold { id }, Some(label)) => format!("{}_{id}", label.class),
        _ => node_name.to_string(),
    }
}

fn texture_path(index: usize, name: &str) -> String {
    let safe: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
    format!("textures/{index:03}_{safe}.png")
}

fn material_name(index: usize, material: &Material) -> String {
    format!("m{index:03}_{}", material.name.replace(char::is_whitespace, "_"))
}

fn obj_text(scene: &Scene) -> String {
    let g = &scene.geometry;
    let mut out = String::with_capacity(1 << 20);
    out.push_str("# scene-gen OBJ export: Y up, metres; one group per node\n");
    let _ = writeln!(out, "# seed {} schema {}", scene.seed, scene_gen_scene::scene::MANIFEST_SCHEMA);
    out.push_str("mtllib scene.mtl\n");
    let mut base = 1usize; // OBJ indices are 1-based and global.
    for node in &g.nodes {
        // `o` keeps objects apart in importers that split by object (Blender's and trimesh's
        // defaults); `g` serves those that split by group.
        let name = group_name(scene, node.semantic, &node.name);
        let _ = writeln!(out, "o {name}\ng {name}");
        let normal_matrix = normal_matrix(node.transform);
        for primitive in &g.meshes[node.mesh].primitives {
            for p in &primitive.positions {
                let w = to_y_up(node.transform.transform_point3(*p));
                let _ = writeln!(out, "v {} {} {}", w.x, w.y, w.z);
            }
            for n in &primitive.normals {
                let w = to_y_up((normal_matrix * *n).normalize_or_zero());
                let _ = writeln!(out, "vn {} {} {}", w.x, w.y, w.z);
            }
            for uv in &primitive.uvs {
                // OBJ's v runs up the image; glTF's (and ours) runs down.
                let _ = writeln!(out, "vt {} {}", uv.x, 1.0 - uv.y);
            }
            let _ = writeln!(out, "usemtl {}", material_name(primitive.material, &g.materials[primitive.material]));
            for tri in primitive.indices.chunks_exact(3) {
                let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| base + i as usize);
                let _ = writeln!(out, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}");
            }
            base += primitive.positions.len();
        }
    }
    out
}

/// Inverse transpose of the upper 3x3: carries normals through non-uniform scales.
fn normal_matrix(transform: Mat4) -> Mat3 {
    Mat3::from_mat4(transform).inverse().transpose()
}

fn mtl_text(scene: &Scene) -> String {
    let g = &scene.geometry;
    let mut out = String::from("# scene-gen materials (PBR extension keys Pr/Pm as Blender reads them)\n");
    for (i, m) in g.materials.iter().enumerate() {
        let [r, gr, b, a] = m.base_color;
        let _ = writeln!(out, "\nnewmtl {}", material_name(i, m));
        let _ = writeln!(out, "Kd {r} {gr} {b}");
        let _ = writeln!(out, "d {a}");
        let _ = writeln!(out, "Pr {}", m.roughness);
        let _ = writeln!(out, "Pm {}", m.metallic);
        if let Some(t) = m.base_color_texture {
            let _ = writeln!(out, "map_Kd {}", texture_path(t, &g.textures[t].name));
        }
    }
    out
}
