//! Hand-built scenes for tests, examples and benchmarks: quads, boxes, a closed room with a
//! window, a room full of boxes. Shared so tests and the benchmark render the same things.

use glam::{Mat4, Vec2, Vec3};

use scene_gen_scene::scene::{
    Envelope, Geometry, Light, LightGroup, LightKind, LightUnit, Material, Mesh, Node, Object, ObjectClass, Primitive,
    Room, Scene, Semantic,
};

use super::Camera;

/// A scene with nothing in it (seed 0, one default envelope, no rooms).
#[must_use]
pub fn empty_scene() -> Scene {
    Scene {
        seed: 0,
        envelope: Envelope::default(),
        wall_thickness_m: 0.0,
        house: scene_gen_scene::scene::HouseRecord::default(),
        palette: None,
        rooms: Vec::new(),
        walls: Vec::new(),
        doors: Vec::new(),
        windows: Vec::new(),
        thresholds: Vec::new(),
        objects: Vec::new(),
        furnishings: Vec::new(),
        lights: Vec::new(),
        geometry: Geometry::default(),
    }
}

/// Adds an untextured material; returns its index.
pub fn add_material(scene: &mut Scene, name: &str, rgb: [f32; 3], metallic: f32, roughness: f32) -> usize {
    scene.geometry.materials.push(Material {
        name: name.to_string(),
        base_color: [rgb[0], rgb[1], rgb[2], 1.0],
        metallic,
        roughness,
        base_color_texture: None,
    });
    scene.geometry.materials.len() - 1
}

/// Adds one mesh of one primitive and a node placing it with `transform`; returns the node
/// index. Normals default to the face normal of the first triangle when `normals` is empty.
pub fn add_mesh(scene: &mut Scene, primitive: Primitive, transform: Mat4, semantic: Semantic) -> usize {
    let name = format!("mesh_{}", scene.geometry.meshes.len());
    scene.geometry.meshes.push(Mesh { name: name.clone(), primitives: vec![primitive] });
    scene.geometry.nodes.push(Node { name, mesh: scene.geometry.meshes.len() - 1, transform, semantic });
    scene.geometry.nodes.len() - 1
}

/// The rectangle `center + s u + t v`, s, t in [-0.5, 0.5], facing `u x v`, as two triangles;
/// texture coordinates in metres along `u` and `v`.
#[must_use]
pub fn quad(center: Vec3, u: Vec3, v: Vec3, material: usize) -> Primitive {
    let n = u.cross(v).normalize();
    let corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)];
    Primitive {
        positions: corners.iter().map(|&(s, t)| center + u * s + v * t).collect(),
        normals: vec![n; 4],
        uvs: corners.iter().map(|&(s, t)| Vec2::new((s + 0.5) * u.length(), (0.5 - t) * v.length())).collect(),
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
    }
}

/// A closed axis-aligned box, 12 triangles with outward normals (`inward` flips them, for a
/// room seen from inside).
#[must_use]
pub fn box_primitive(min: Vec3, max: Vec3, material: usize, inward: bool) -> Primitive {
    let c = (min + max) * 0.5;
    let e = max - min;
    let faces = [
        (Vec3::new(max.x, c.y, c.z), Vec3::Y * e.y, Vec3::Z * e.z),
        (Vec3::new(min.x, c.y, c.z), Vec3::Z * e.z, Vec3::Y * e.y),
        (Vec3::new(c.x, max.y, c.z), Vec3::Z * e.z, Vec3::X * e.x),
        (Vec3::new(c.x, min.y, c.z), Vec3::X * e.x, Vec3::Z * e.z),
        (Vec3::new(c.x, c.y, max.z), Vec3::X * e.x, Vec3::Y * e.y),
        (Vec3::new(c.x, c.y, min.z), Vec3::Y * e.y, Vec3::X * e.x),
    ];
    let mut out = Primitive { material, ..Primitive::default() };
    for (center, u, v) in faces {
        let (u, v) = if inward { (v, u) } else { (u, v) };
        let q = quad(center, u, v, material);
        let base = out.positions.len() as u32;
        out.positions.extend(q.positions);
        out.normals.extend(q.normals);
        out.uvs.extend(q.uvs);
        out.indices.extend(q.indices.iter().map(|i| i + base));
    }
    out
}

/// A point light.
#[must_use]
pub fn point_light(group: LightGroup, position: Vec3, candela: f32) -> Light {
    Light::point(group, position, candela)
}

/// A directional light travelling along `direction`, `lux` on a surface facing it.
#[must_use]
pub fn directional_light(group: LightGroup, direction: Vec3, lux: f32) -> Light {
    Light {
        kind: LightKind::Directional,
        position: None,
        direction: Some(direction.normalize()),
        intensity: lux,
        unit: LightUnit::Lux,
        ..point_light(group, Vec3::ZERO, 0.0)
    }
}

/// A one-sided rect light of `nit` luminance centred at `center`, spanned by `u`, `v`,
/// emitting along `direction`.
#[must_use]
pub fn rect_light(group: LightGroup, center: Vec3, u: Vec3, v: Vec3, direction: Vec3, nit: f32) -> Light {
    Light {
        kind: LightKind::Rect,
        position: Some(center),
        direction: Some(direction.normalize()),
        rect_u: Some(u),
        rect_v: Some(v),
        intensity: nit,
        unit: LightUnit::Nit,
        ..point_light(group, Vec3::ZERO, 0.0)
    }
}

/// A camera with 5 um pixels, a 4 mm f/2 lens and no vignetting.
#[must_use]
pub fn camera(width_px: u32, height_px: u32, position: Vec3, yaw_deg: f32, pitch_deg: f32) -> Camera {
    Camera {
        width_px,
        height_px,
        pixel_pitch_um: 5.0,
        focal_mm: 4.0,
        f_number: 2.0,
        position,
        yaw_deg,
        pitch_deg,
        vignetting: false,
    }
}

/// A closed `size` room (floor at z = 0, origin at a corner) seen from inside, lit by day
/// through a "window": a 1.2 m square rect light just inside the -Y wall, shining into the
/// room (the wall behind it stays closed), and by night by a ceiling point light; with
/// `boxes_per_axis^2` boxes standing on the floor as labelled objects (tables, instance ids
/// from 1). Each box is 12 triangles; 90 x 90 boxes give about 97k triangles.
#[must_use]
pub fn room_of_boxes(size: Vec3, boxes_per_axis: u32) -> Scene {
    let mut scene = empty_scene();
    scene.rooms.push(Room { id: 0, room_type: "test".into(), min: Vec2::ZERO, max: size.truncate() });
    let wall = add_material(&mut scene, "paint_0", [0.7, 0.7, 0.7], 0.0, 0.8);
    let wood = add_material(&mut scene, "wood_0", [0.5, 0.35, 0.2], 0.0, 0.6);
    add_mesh(&mut scene, box_primitive(Vec3::ZERO, size, wall, true), Mat4::IDENTITY, Semantic::Floor { room: 0 });
    let n = boxes_per_axis.max(1);
    let cell = size.truncate() / n as f32;
    for j in 0..n {
        for i in 0..n {
            let centre = (Vec2::new(i as f32 + 0.5, j as f32 + 0.5)) * cell;
            let half = (cell * 0.3).extend(0.0);
            let height = 0.3 + 0.4 * (((i * 7 + j * 13) % 5) as f32 / 4.0);
            let (min, max) = (centre.extend(0.0) - half, centre.extend(height) + half.truncate().extend(0.0));
            let id = scene.objects.len() as u32;
            scene.objects.push(Object {
                id,
                class: ObjectClass::Table,
                instance_id: id + 1,
                room: 0,
                asset: "table/box".into(),
                min,
                max,
                yaw_deg: 0.0,
                on: None,
            });
            add_mesh(&mut scene, box_primitive(min, max, wood, false), Mat4::IDENTITY, Semantic::Object { id });
        }
    }
    let mut ceiling = point_light(LightGroup::Night, Vec3::new(size.x * 0.5, size.y * 0.5, size.z - 0.1), 20.0);
    ceiling.room = Some(0);
    let mut window = rect_light(
        LightGroup::Day,
        Vec3::new(size.x * 0.5, 0.01, size.z * 0.5),
        Vec3::X * 1.2,
        Vec3::Z * 1.2,
        Vec3::Y,
        500.0,
    );
    window.room = Some(0);
    scene.lights = vec![ceiling, window];
    for (i, l) in scene.lights.iter_mut().enumerate() {
        l.id = i as u32;
    }
    scene
}
