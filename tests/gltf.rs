//! The glTF/GLB exporter, read back with the `gltf` crate: structure, names, labels, the Z-up
//! to Y-up conversion, accessor bounds, shared meshes, textures, lights and determinism.

#[path = "../examples/gltf_feature_scene.rs"]
#[allow(dead_code)]
mod feature;

use feature::feature_scene;
use glam::{Mat4, Vec3};
use scene_gen::export::gltf::{to_glb, to_gltf, to_y_up};
use serde_json::Value;

fn parse(glb: &[u8]) -> gltf::Gltf {
    gltf::Gltf::from_slice(glb).expect("exported GLB parses")
}

fn extras(raw: &gltf::json::Extras) -> Value {
    serde_json::from_str(raw.as_ref().expect("extras present").get()).unwrap()
}

fn node<'a>(doc: &'a gltf::Document, name: &str) -> gltf::Node<'a> {
    doc.nodes().find(|n| n.name() == Some(name)).unwrap_or_else(|| panic!("no node {name}"))
}

#[test]
fn glb_container_is_well_formed() {
    let glb = to_glb(&feature_scene());
    assert_eq!(&glb[0..4], b"glTF");
    assert_eq!(u32::from_le_bytes(glb[4..8].try_into().unwrap()), 2);
    assert_eq!(u32::from_le_bytes(glb[8..12].try_into().unwrap()) as usize, glb.len());
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    assert_eq!(&glb[16..20], b"JSON");
    assert_eq!(json_len % 4, 0);
    let bin_at = 20 + json_len;
    let bin_len = u32::from_le_bytes(glb[bin_at..bin_at + 4].try_into().unwrap()) as usize;
    assert_eq!(&glb[bin_at + 4..bin_at + 8], b"BIN\0");
    assert_eq!(bin_at + 8 + bin_len, glb.len());
    let gltf = parse(&glb);
    assert_eq!(gltf.buffers().next().unwrap().length(), bin_len);
}

#[test]
fn nodes_are_named_and_labelled() {
    let scene = feature_scene();
    let gltf = parse(&to_glb(&scene));
    let doc = &gltf.document;
    assert_eq!(doc.nodes().count(), scene.geometry.nodes.len() + scene.lights.len());
    assert_eq!(doc.scenes().next().unwrap().nodes().count(), doc.nodes().count());
    let names: Vec<_> = doc.nodes().filter_map(|n| n.name().map(str::to_string)).collect();
    assert_eq!(
        names,
        [
            "floor_0",
            "ceiling_1",
            "table_0",
            "chair_1",
            "threshold_0",
            "window_0_glass",
            "light_0",
            "light_1",
            "light_2"
        ]
    );
    let table = extras(node(doc, "table_0").extras());
    assert_eq!(
        table,
        serde_json::json!({"class": "table", "class_id": 3, "instance_id": 2, "room": 0, "room_type": "living_room"})
    );
    let threshold = extras(node(doc, "threshold_0").extras());
    assert_eq!(
        threshold,
        serde_json::json!({"class": "threshold", "class_id": 11, "instance_id": 1, "room": 0,
                           "room_type": "living_room", "door": 0})
    );
    assert_eq!(extras(node(doc, "ceiling_1").extras()), serde_json::json!({"kind": "ceiling", "room": 1}));
    assert_eq!(extras(node(doc, "window_0_glass").extras()), serde_json::json!({"kind": "window", "id": 0}));
}

#[test]
fn meshes_are_shared_and_index_width_follows_vertex_count() {
    let scene = feature_scene();
    let gltf = parse(&to_glb(&scene));
    let doc = &gltf.document;
    assert_eq!(doc.meshes().count(), scene.geometry.meshes.len());
    let table = node(doc, "table_0").mesh().unwrap().index();
    assert_eq!(node(doc, "chair_1").mesh().unwrap().index(), table);
    assert_eq!(doc.meshes().nth(table).unwrap().primitives().count(), 2);
    let index_type =
        |name: &str| node(doc, name).mesh().unwrap().primitives().next().unwrap().indices().unwrap().data_type();
    assert_eq!(index_type("ceiling_1"), gltf::accessor::DataType::U32);
    assert_eq!(index_type("floor_0"), gltf::accessor::DataType::U16);
}

/// A known world point: the table's top corner. The world transform M of the node maps the
/// box corner (0.5, 0.5, 0.5) to W; in glTF, the node's transform applied to the stored vertex
/// must give C W, with C: (x, y, z) -> (x, z, -y).
#[test]
fn vertices_and_transforms_are_converted_to_y_up() {
    let scene = feature_scene();
    let gltf = parse(&to_glb(&scene));
    let blob = gltf.blob.as_deref().unwrap();
    let doc = &gltf.document;
    let table = node(doc, "table_0");
    let world = scene.geometry.nodes[2].transform.transform_point3(Vec3::splat(0.5));
    // Rotated 90 degrees about Z with extents 1.2 x 0.8 x 0.75 around (2, 3, 0.375):
    assert!(world.abs_diff_eq(Vec3::new(1.6, 3.6, 0.75), 1e-5), "{world}");
    let m = Mat4::from_cols_array_2d(&table.transform().matrix());
    let prim = table.mesh().unwrap().primitives().next().unwrap();
    let positions: Vec<Vec3> = prim.reader(|_| Some(blob)).read_positions().unwrap().map(Vec3::from).collect();
    let stored = to_y_up(Vec3::splat(0.5));
    assert!(positions.contains(&stored), "the box corner is stored converted");
    let got = m.transform_point3(stored);
    assert!(got.abs_diff_eq(Vec3::new(1.6, 0.75, -3.6), 1e-5), "{got}");
    // Floors face glTF +Y.
    let floor = node(doc, "floor_0").mesh().unwrap().primitives().next().unwrap();
    let normals: Vec<[f32; 3]> = floor.reader(|_| Some(blob)).read_normals().unwrap().collect();
    assert!(normals.iter().all(|n| *n == [0.0, 1.0, 0.0]));
}

#[test]
fn accessor_bounds_match_the_data() {
    let gltf = parse(&to_glb(&feature_scene()));
    let blob = gltf.blob.as_deref().unwrap();
    for mesh in gltf.document.meshes() {
        for prim in mesh.primitives() {
            let positions: Vec<[f32; 3]> = prim.reader(|_| Some(blob)).read_positions().unwrap().collect();
            let bounds = prim.bounding_box();
            for k in 0..3 {
                let lo = positions.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min);
                let hi = positions.iter().map(|p| p[k]).fold(f32::NEG_INFINITY, f32::max);
                assert_eq!((bounds.min[k], bounds.max[k]), (lo, hi));
            }
            for semantic in [gltf::Semantic::Normals, gltf::Semantic::TexCoords(0)] {
                let a = prim.get(&semantic).unwrap();
                assert!(a.min().is_some() && a.max().is_some());
            }
            let indices = prim.indices().unwrap();
            let read: Vec<u32> = prim.reader(|_| Some(blob)).read_indices().unwrap().into_u32().collect();
            let max = read.iter().copied().max().unwrap();
            assert_eq!(indices.max().unwrap(), serde_json::json!([max]));
            assert!((max as usize) < positions.len());
        }
    }
}

#[test]
fn materials_and_embedded_textures_round_trip() {
    let scene = feature_scene();
    let gltf = parse(&to_glb(&scene));
    let blob = gltf.blob.as_deref().unwrap();
    let doc = &gltf.document;
    assert_eq!(doc.materials().count(), scene.geometry.materials.len());
    for (m, ours) in doc.materials().zip(&scene.geometry.materials) {
        let pbr = m.pbr_metallic_roughness();
        assert_eq!(pbr.base_color_factor(), ours.base_color);
        assert_eq!((pbr.metallic_factor(), pbr.roughness_factor()), (ours.metallic, ours.roughness));
        let texture = pbr.base_color_texture().expect("every surface is textured").texture();
        let sampler = texture.sampler();
        assert_eq!(sampler.wrap_s(), gltf::texture::WrappingMode::Repeat);
        assert_eq!(sampler.min_filter(), Some(gltf::texture::MinFilter::LinearMipmapLinear));
        let gltf::image::Source::View { view, mime_type } = texture.source().source() else {
            panic!("GLB images are embedded");
        };
        assert_eq!(mime_type, "image/png");
        let png = &blob[view.offset()..view.offset() + view.length()];
        assert_eq!(png, &*scene.geometry.textures[ours.base_color_texture.unwrap()].png);
    }
    let gold = doc.materials().find(|m| m.name() == Some("gold_0")).unwrap();
    assert_eq!(gold.pbr_metallic_roughness().base_color_factor(), [1.0, 0.766, 0.336, 1.0]);
    let glass = doc.materials().find(|m| m.name() == Some("glass_0")).unwrap();
    assert_eq!(glass.alpha_mode(), gltf::material::AlphaMode::Blend);
}

#[test]
fn lights_are_placed_oriented_and_grouped() {
    use gltf::khr_lights_punctual::Kind;
    let scene = feature_scene();
    let gltf = parse(&to_glb(&scene));
    let doc = &gltf.document;
    for l in &scene.lights {
        let n = node(doc, &format!("light_{}", l.id));
        let light = n.light().expect("light node carries its light");
        let m = Mat4::from_cols_array_2d(&n.transform().matrix());
        let group = if l.group == scene_gen::scene::LightGroup::Day { "day" } else { "night" };
        assert_eq!(extras(light.extras()), serde_json::json!({"group": group, "id": l.id}));
        if let Some(p) = l.position {
            assert!(m.transform_point3(Vec3::ZERO).abs_diff_eq(to_y_up(p), 1e-5));
        }
        if let Some(d) = l.direction {
            let shines = m.transform_vector3(Vec3::NEG_Z);
            assert!(shines.abs_diff_eq(to_y_up(d), 1e-5), "light {} shines {shines}", l.id);
        }
        match (l.kind, light.kind()) {
            (scene_gen::scene::LightKind::Point, Kind::Point) => assert_eq!(light.intensity(), 120.0),
            (scene_gen::scene::LightKind::Directional, Kind::Directional) => assert_eq!(light.intensity(), 20000.0),
            (scene_gen::scene::LightKind::Rect, Kind::Spot { outer_cone_angle, .. }) => {
                // 2000 nit over 1.2 m x 1.0 m: 2400 cd on axis.
                assert!((light.intensity() - 2400.0).abs() < 1e-2);
                assert!(outer_cone_angle > 1.0 && outer_cone_angle <= std::f32::consts::FRAC_PI_2);
            }
            (ours, _) => panic!("light {} of kind {ours:?} exported as another kind", l.id),
        }
    }
}

#[test]
fn export_is_deterministic() {
    let a = to_glb(&feature_scene());
    let b = to_glb(&feature_scene());
    assert!(a == b, "two exports of the same scene differ");
    assert_eq!(to_gltf(&feature_scene()), to_gltf(&feature_scene()));
}

#[test]
fn gltf_files_reference_each_other() {
    let scene = feature_scene();
    let files = to_gltf(&scene);
    assert_eq!(files[0].0, "scene.gltf");
    assert_eq!(files[1].0, "scene.bin");
    assert_eq!(files.len(), 2 + scene.geometry.textures.len());
    let doc = gltf::Gltf::from_slice(&files[0].1).unwrap().document;
    let buffer = doc.buffers().next().unwrap();
    assert!(matches!(buffer.source(), gltf::buffer::Source::Uri("scene.bin")));
    assert_eq!(buffer.length(), files[1].1.len());
    for (image, (name, bytes)) in doc.images().zip(&files[2..]) {
        let gltf::image::Source::Uri { uri, .. } = image.source() else { panic!("images are files") };
        assert_eq!(uri, name);
        assert_eq!(&bytes[1..4], b"PNG");
    }
}

#[test]
fn generated_scene_exports() {
    use scene_gen::{config::GeneratorConfig, generate::generate, library::Library};
    let library = Library::embedded().unwrap();
    let scene = generate(&GeneratorConfig { seed: 7, ..GeneratorConfig::default() }, &library).unwrap();
    let glb = to_glb(&scene);
    let gltf = parse(&glb);
    assert_eq!(gltf.document.nodes().count(), scene.geometry.nodes.len() + scene.lights.len());
    assert_eq!(glb, to_glb(&generate(&GeneratorConfig { seed: 7, ..GeneratorConfig::default() }, &library).unwrap()));
}

#[test]
fn cli_writes_gltf_with_its_buffer_and_textures() {
    let out = std::env::temp_dir().join(format!("scene-gen-gltf-cli-{}", std::process::id()));
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_scene-gen"))
        .args(["--seed", "7", "--format", "gltf", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let json = std::fs::read(out.join("scene.gltf")).unwrap();
    let doc = gltf::Gltf::from_slice(&json).unwrap().document;
    let buffer = doc.buffers().next().unwrap();
    assert_eq!(std::fs::metadata(out.join("scene.bin")).unwrap().len() as usize, buffer.length());
    for image in doc.images() {
        let gltf::image::Source::Uri { uri, .. } = image.source() else { panic!("images are files") };
        assert!(std::fs::read(out.join(uri)).unwrap().starts_with(b"\x89PNG"), "{uri}");
    }
    assert!(!out.join("scene.glb").exists());
    std::fs::remove_dir_all(&out).unwrap();
}

/// Furnishings (wardrobes, counters...) are nodes named `<kind>_<id>` that carry their kind and
/// room but no class id or instance id: they are not detection targets.
#[test]
fn furnishings_are_unlabelled_nodes_with_their_kind() {
    use scene_gen::{config::GeneratorConfig, generate::generate, library::Library, scene::Semantic};
    let scene =
        generate(&GeneratorConfig { seed: 7, ..GeneratorConfig::default() }, &Library::embedded().unwrap()).unwrap();
    assert!(!scene.furnishings.is_empty(), "house 7 has furnishings");
    let gltf = parse(&to_glb(&scene));
    for f in &scene.furnishings {
        assert_eq!(scene.label(Semantic::Furnishing { id: f.id }), None);
        let name = format!("{}_{}", f.kind.name(), f.id);
        let e = extras(node(&gltf.document, &name).extras());
        let room_type = scene.room(f.room).map(|r| r.room_type.clone());
        assert_eq!(
            e,
            serde_json::json!({"kind": "furnishing", "id": f.id, "furnishing": f.kind.name(), "room": f.room,
                               "room_type": room_type}),
            "{name}"
        );
    }
}
