//! The ray tracer against hand-computed answers: inverse-square point lights, directional and
//! rect lights, watertight meshes, depth, labels, shadows, determinism and light scaling.

use std::f32::consts::PI;

use glam::{Mat4, Vec2, Vec3};
use scene_gen::render::accel::NO_TRIANGLE;
use scene_gen::render::test_util::{
    add_material, add_mesh, box_primitive, camera, directional_light, empty_scene, point_light, quad, rect_light,
    room_of_boxes,
};
use scene_gen::render::{
    Accel, Camera, Frame, LightScale, LightSet, RenderSettings, Renderer, ShadingRate, measure_mean_illuminance,
    probe_points,
};
use scene_gen::scene::{LightGroup, Object, ObjectClass, Primitive, Room, Scene, Semantic, Texture};
use scene_gen::trace::packet::{PACKET_RAYS, RayPacket};

const ALBEDO: f32 = 0.5;

/// A 200 m square grey Lambertian floor at z = 0.
fn floor_scene() -> Scene {
    let mut scene = empty_scene();
    let grey = add_material(&mut scene, "paint_0", [ALBEDO; 3], 0.0, 1.0);
    add_mesh(
        &mut scene,
        quad(Vec3::ZERO, Vec3::X * 200.0, Vec3::Y * 200.0, grey),
        Mat4::IDENTITY,
        Semantic::Floor { room: 0 },
    );
    scene
}

/// A camera looking straight down from `position` with 50 um pixels (43.6 deg horizontal FOV).
fn down_camera(position: Vec3, w: u32, h: u32) -> Camera {
    Camera { pixel_pitch_um: 50.0, ..camera(w, h, position, 0.0, -90.0) }
}

fn lum(rgb: [f32; 3]) -> f32 {
    scene_gen::render::luminance(Vec3::from(rgb))
}

fn assert_close(got: f32, want: f32, rel: f32, what: &str) {
    assert!(((got - want) / want).abs() <= rel, "{what}: got {got}, want {want} (within {rel})");
}

/// Where the centre ray of pixel (x, y) meets the floor.
fn floor_point(cam: &Camera, x: u32, y: u32) -> Vec3 {
    let d = cam.ray_direction(x as f32 + 0.5, y as f32 + 0.5);
    cam.position + d * (-cam.position.z / d.z)
}

fn assert_no_nan(frame: &Frame) {
    for buffer in [&frame.day_nit, &frame.night_nit, &frame.normal] {
        assert!(buffer.iter().flatten().all(|v| v.is_finite()), "non-finite radiance or normal");
    }
    assert!(frame.depth_m.iter().all(|d| !d.is_nan()));
}

#[test]
fn point_light_over_a_plane_follows_inverse_square_and_cos_cubed() {
    let mut scene = floor_scene();
    let (intensity_cd, h) = (100.0, 2.0);
    scene.lights.push(point_light(LightGroup::Night, Vec3::new(0.0, 0.0, h), intensity_cd));
    let renderer = Renderer::new(&scene, RenderSettings::standard());
    let cam = down_camera(Vec3::new(0.0, 0.0, h), 64, 48);
    let frame = renderer.render(&cam).unwrap();
    assert_no_nan(&frame);
    // Nadir: L = rho / pi * I / h^2.
    let nadir = lum(frame.night_nit[frame.index(32, 24)]);
    assert_close(nadir, ALBEDO / PI * intensity_cd / (h * h), 0.02, "nadir radiance");
    // Off-axis pixels: L = rho / pi * I cos^3 / h^2.
    for (x, y) in [(2, 24), (60, 3), (10, 40)] {
        let p = floor_point(&cam, x, y);
        let cos = h / (p.length_squared() + h * h).sqrt();
        let want = ALBEDO / PI * intensity_cd * cos.powi(3) / (h * h);
        assert!(cos < 0.95, "the test must probe an oblique point");
        assert_close(lum(frame.night_nit[frame.index(x, y)]), want, 0.02, "off-axis radiance");
    }
    assert!(frame.day_nit.iter().all(|c| *c == [0.0; 3]), "no day light in this scene");
    // The probe agrees: E = I / h^2 at the nadir, a 0.75 m above the floor.
    let e = renderer.illuminance_lux(Vec3::new(0.0, 0.0, 0.75), Vec3::Z, LightGroup::Night);
    assert_close(e, intensity_cd / (1.25 * 1.25), 0.01, "probe illuminance");
}

#[test]
fn directional_light_gives_cosine_law() {
    let mut scene = floor_scene();
    let sun = Vec3::new(1.0, 0.5, -1.0);
    scene.lights.push(directional_light(LightGroup::Day, sun, 1000.0));
    let renderer = Renderer::new(&scene, RenderSettings::standard());
    let frame = renderer.render(&down_camera(Vec3::new(0.0, 0.0, 3.0), 32, 24)).unwrap();
    let cos = -sun.normalize().z;
    let want = ALBEDO / PI * 1000.0 * cos;
    for c in &frame.day_nit {
        assert_close(lum(*c), want, 0.001, "sunlit radiance");
    }
}

/// Illuminance under the corner of a parallel Lambertian rectangle `a x b` at distance `h`:
/// E = L/2 [a/sqrt(a^2+h^2) atan(b/sqrt(a^2+h^2)) + b/sqrt(b^2+h^2) atan(a/sqrt(b^2+h^2))]
/// (the differential-area-to-parallel-rectangle view factor times pi L).
fn corner_illuminance(l: f32, a: f32, b: f32, h: f32) -> f32 {
    let ra = (a * a + h * h).sqrt();
    let rb = (b * b + h * h).sqrt();
    0.5 * l * (a / ra * (b / ra).atan() + b / rb * (a / rb).atan())
}

#[test]
fn rect_light_matches_the_view_factor() {
    let mut scene = floor_scene();
    let (l_nit, h) = (1000.0, 1.0);
    // A 1 m x 1.5 m panel at 1 m, facing down.
    scene.lights.push(rect_light(LightGroup::Day, Vec3::new(0.0, 0.0, h), Vec3::X, Vec3::Y * 1.5, -Vec3::Z, l_nit));
    let renderer = Renderer::new(&scene, RenderSettings::high());
    let cam = down_camera(Vec3::new(0.0, 0.0, 0.5), 32, 24);
    let frame = renderer.render(&cam).unwrap();
    let e_centre = 4.0 * corner_illuminance(l_nit, 0.5, 0.75, h);
    assert_close(lum(frame.day_nit[frame.index(16, 12)]), ALBEDO / PI * e_centre, 0.01, "rect, under the centre");
    // The probe, close to the panel where the integrand is peaked, with many area samples.
    let fine = RenderSettings { probe_rect_samples_per_axis: 16, ..RenderSettings::high() };
    let e_probe = Renderer::new(&scene, fine).illuminance_lux(Vec3::new(0.0, 0.0, 0.5), Vec3::Z, LightGroup::Day);
    assert_close(e_probe, 4.0 * corner_illuminance(l_nit, 0.5, 0.75, 0.5), 0.01, "rect probe");
    // Looking up at the emitting face shows its luminance; from behind it shows nothing.
    let up = Camera { pitch_deg: 90.0, ..cam };
    let seen = renderer.render(&Camera { width_px: 4, height_px: 4, ..up }).unwrap();
    assert!(seen.day_nit.iter().all(|c| (lum(*c) - l_nit).abs() < 1e-2));
    assert!(seen.depth_m.iter().all(|d| d.is_infinite()), "an emitter is not geometry");
    let behind = Camera { position: Vec3::new(0.0, 0.0, 2.0), width_px: 4, height_px: 4, ..cam };
    let above = renderer.render(&behind).unwrap();
    assert!(above.day_nit.iter().all(|c| lum(*c) < l_nit * 0.5), "rect lights are one-sided");
}

/// A non-planar 40 x 40 grid mesh (3200 triangles sharing edges and vertices) at awkward
/// coordinates, and a fan of 97 thin triangles around one vertex.
fn shared_edge_scene() -> Scene {
    let mut scene = empty_scene();
    let m = add_material(&mut scene, "paint_0", [0.8; 3], 0.0, 1.0);
    let n = 40u32;
    let mut grid = Primitive { material: m, ..Primitive::default() };
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f32 * 0.1371 - 2.7, j as f32 * 0.1293 - 2.6);
            let z = 0.05 * (x * 3.1).sin() * (y * 2.3).cos();
            grid.positions.push(Vec3::new(x, y, z));
            grid.normals.push(Vec3::Z);
            grid.uvs.push(Vec2::new(x, y));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let k = j * (n + 1) + i;
            grid.indices.extend([k, k + 1, k + n + 2, k, k + n + 2, k + n + 1]);
        }
    }
    add_mesh(&mut scene, grid, Mat4::from_translation(Vec3::new(0.3, -0.2, 0.0)), Semantic::Floor { room: 0 });
    let mut fan = Primitive { material: m, ..Primitive::default() };
    let centre = Vec3::new(10.0, 10.0, 1.0);
    fan.positions.push(centre);
    let spokes = 97;
    for k in 0..=spokes {
        let a = k as f32 / spokes as f32 * std::f32::consts::TAU;
        fan.positions.push(centre + Vec3::new(a.cos() * 3.0, a.sin() * 3.0, 0.0));
    }
    fan.normals = vec![Vec3::Z; fan.positions.len()];
    fan.uvs = vec![Vec2::ZERO; fan.positions.len()];
    for k in 1..=spokes {
        fan.indices.extend([0, k, k + 1]);
    }
    add_mesh(&mut scene, fan, Mat4::IDENTITY, Semantic::Floor { room: 0 });
    scene
}

#[test]
fn shared_edges_and_vertices_never_leak() {
    let scene = shared_edge_scene();
    let renderer = Renderer::new(&scene, RenderSettings::preview());
    // Over the grid, obliquely, and straight down on the fan's centre vertex.
    let views = [
        Camera { pixel_pitch_um: 20.0, ..camera(200, 150, Vec3::new(0.1, 0.0, 0.9), 30.0, -60.0) },
        Camera { pixel_pitch_um: 20.0, ..camera(200, 150, Vec3::new(-0.3, 0.4, 1.3), 200.0, -75.0) },
        down_camera(Vec3::new(10.0, 10.0, 2.0), 201, 151),
    ];
    for cam in views {
        let frame = renderer.render(&cam).unwrap();
        assert_no_nan(&frame);
        let holes = frame.depth_m.iter().filter(|d| !d.is_finite()).count();
        assert_eq!(holes, 0, "background pixels through a closed mesh seen from {:?}", cam.position);
    }
}

#[test]
fn closed_box_seen_from_inside_has_no_holes() {
    let mut scene = empty_scene();
    let m = add_material(&mut scene, "paint_0", [0.8; 3], 0.0, 1.0);
    let rotation = Mat4::from_rotation_z(0.37) * Mat4::from_rotation_x(0.11);
    add_mesh(
        &mut scene,
        box_primitive(Vec3::new(-2.1, -1.7, -1.3), Vec3::new(2.9, 2.3, 1.7), m, true),
        rotation,
        Semantic::Floor { room: 0 },
    );
    let renderer = Renderer::new(&scene, RenderSettings::preview());
    for (yaw, pitch) in [(0.0, 0.0), (45.0, 35.0), (137.0, -80.0), (-100.0, 10.0)] {
        let cam = Camera { pixel_pitch_um: 30.0, ..camera(160, 120, Vec3::new(0.2, 0.1, 0.3), yaw, pitch) };
        let frame = renderer.render(&cam).unwrap();
        assert_eq!(frame.depth_m.iter().filter(|d| !d.is_finite()).count(), 0, "hole at yaw {yaw} pitch {pitch}");
        assert!(frame.normal.iter().all(|n| (Vec3::from(*n).length() - 1.0).abs() < 1e-4));
    }
}

#[test]
fn depth_is_distance_along_the_optical_axis() {
    let mut scene = empty_scene();
    let m = add_material(&mut scene, "paint_0", [0.8; 3], 0.0, 1.0);
    // A wall at x = 3 facing -X, seen from the origin looking along +X.
    add_mesh(
        &mut scene,
        quad(Vec3::new(3.0, 0.0, 0.0), Vec3::Z * 50.0, Vec3::Y * 50.0, m),
        Mat4::IDENTITY,
        Semantic::Wall { wall: 0 },
    );
    let renderer = Renderer::new(&scene, RenderSettings::preview());
    let cam = Camera { pixel_pitch_um: 40.0, ..camera(64, 48, Vec3::ZERO, 0.0, 0.0) };
    let frame = renderer.render(&cam).unwrap();
    for d in &frame.depth_m {
        assert!((d - 3.0).abs() < 1e-4, "z-depth {d}");
    }
    assert!(frame.normal.iter().all(|n| (Vec3::from(*n) + Vec3::X).length() < 1e-5), "normal faces the camera");
    // Turned away from the wall, nothing is hit.
    let away = renderer.render(&Camera { yaw_deg: 180.0, ..cam }).unwrap();
    assert!(away.depth_m.iter().all(|d| d.is_infinite()) && away.instance_id.iter().all(|&i| i == 0));
}

#[test]
fn labelled_object_fills_its_pixels_with_its_ids() {
    let mut scene = empty_scene();
    let m = add_material(&mut scene, "fabric_0", [0.4; 3], 0.0, 1.0);
    add_mesh(
        &mut scene,
        quad(Vec3::new(5.0, 0.0, 0.0), Vec3::Z * 50.0, Vec3::Y * 50.0, m),
        Mat4::IDENTITY,
        Semantic::Wall { wall: 0 },
    );
    let (min, max) = (Vec3::new(2.0, -0.3, -0.3), Vec3::new(2.6, 0.3, 0.3));
    scene.objects.push(Object {
        id: 0,
        class: ObjectClass::Chair,
        instance_id: 7,
        room: 0,
        asset: "chair/box".into(),
        min,
        max,
        yaw_deg: 0.0,
        on: None,
    });
    add_mesh(&mut scene, box_primitive(min, max, m, false), Mat4::IDENTITY, Semantic::Object { id: 0 });
    let renderer = Renderer::new(&scene, RenderSettings::preview());
    let cam = Camera { pixel_pitch_um: 40.0, ..camera(64, 48, Vec3::ZERO, 0.0, 0.0) };
    let frame = renderer.render(&cam).unwrap();
    let centre = frame.index(32, 24);
    assert_eq!((frame.instance_id[centre], frame.class_id[centre]), (7, ObjectClass::Chair.class_id() as u16));
    assert!((frame.depth_m[centre] - 2.0).abs() < 1e-4);
    let corner = frame.index(0, 0);
    assert_eq!((frame.instance_id[corner], frame.class_id[corner]), (0, 0), "the wall is unlabelled");
    // The box face at 2 m spans +-0.3 m: 2 * 0.15 * 4 mm / 40 um = 30 px each way, 900 px.
    let labelled = frame.instance_id.iter().filter(|&&i| i == 7).count();
    assert!((800..=1000).contains(&labelled), "{labelled} labelled pixels");
}

#[test]
fn occluders_cast_shadows() {
    let mut scene = floor_scene();
    // Two equal lights; a slab 1 m up blocks the left one for points near the origin.
    scene.lights.push(point_light(LightGroup::Night, Vec3::new(-0.5, 0.0, 2.0), 50.0));
    scene.lights.push(point_light(LightGroup::Night, Vec3::new(0.5, 0.0, 2.0), 50.0));
    let m = add_material(&mut scene, "wood_0", [0.0; 3], 0.0, 1.0);
    add_mesh(
        &mut scene,
        box_primitive(Vec3::new(-0.6, -0.3, 1.0), Vec3::new(-0.1, 0.3, 1.05), m, false),
        Mat4::IDENTITY,
        Semantic::Decor { room: 0 },
    );
    let settings = RenderSettings { indirect_rays: 0, probe_indirect_rays: 0, ..RenderSettings::standard() };
    let renderer = Renderer::new(&scene, settings);
    let p = Vec3::new(-0.3, 0.0, 0.0);
    let unshadowed = |light: Vec3| 50.0 * (light.z - p.z) / (light - p).length().powi(3);
    let e = renderer.illuminance_lux(p, Vec3::Z, LightGroup::Night);
    assert_close(e, unshadowed(Vec3::new(0.5, 0.0, 2.0)), 1e-3, "one light blocked");
    // Both blocked under the middle of a wide slab.
    add_mesh(
        &mut scene,
        box_primitive(Vec3::new(-3.0, -3.0, 1.0), Vec3::new(3.0, 3.0, 1.05), m, false),
        Mat4::IDENTITY,
        Semantic::Decor { room: 0 },
    );
    let renderer = Renderer::new(&scene, settings);
    assert_eq!(renderer.illuminance_lux(p, Vec3::Z, LightGroup::Night), 0.0);
}

/// A closed 6 x 4 x 2.5 m room lit only by a window rect light on its -Y wall, with a
/// partition that hides the east end from the window.
fn window_room() -> Scene {
    let mut scene = empty_scene();
    scene.rooms.push(Room { id: 0, room_type: "test".into(), min: Vec2::ZERO, max: Vec2::new(6.0, 4.0) });
    let paint = add_material(&mut scene, "paint_0", [0.7; 3], 0.0, 1.0);
    add_mesh(
        &mut scene,
        box_primitive(Vec3::ZERO, Vec3::new(6.0, 4.0, 2.5), paint, true),
        Mat4::IDENTITY,
        Semantic::Floor { room: 0 },
    );
    add_mesh(
        &mut scene,
        box_primitive(Vec3::new(3.0, 0.0, 0.0), Vec3::new(3.1, 3.0, 2.5), paint, false),
        Mat4::IDENTITY,
        Semantic::Wall { wall: 0 },
    );
    let mut window =
        rect_light(LightGroup::Day, Vec3::new(1.5, 0.001, 1.4), Vec3::X * 1.2, Vec3::Z * 1.0, Vec3::Y, 2000.0);
    window.room = Some(0);
    scene.lights.push(window);
    scene
}

#[test]
fn indirect_light_reaches_what_the_window_cannot_see() {
    let scene = window_room();
    // Looking down at the floor at the east end, behind the partition.
    let cam = Camera { pixel_pitch_um: 20.0, ..camera(16, 12, Vec3::new(4.5, 1.0, 2.0), 0.0, -90.0) };
    let direct_only = RenderSettings { indirect_rays: 0, indirect_volume: None, ..RenderSettings::standard() };
    let dark = Renderer::new(&scene, direct_only).render(&cam).unwrap();
    assert!(dark.day_nit.iter().all(|c| *c == [0.0; 3]), "no direct light behind the partition");
    let lit = Renderer::new(&scene, RenderSettings::standard()).render(&cam).unwrap();
    assert_no_nan(&lit);
    let mean = lit.day_nit.iter().map(|c| lum(*c)).sum::<f32>() / lit.day_nit.len() as f32;
    assert!(mean > 0.05, "bounced light lights the hidden floor, mean {mean} nit");
    assert!(lit.night_nit.iter().all(|c| *c == [0.0; 3]));
}

/// A closed 4 x 3 x 2.5 m box of albedo `albedo` seen from inside, with a 10 cd point light
/// in its middle; as one room of the floorplan when `as_room`, else a scene without rooms.
fn closed_box(albedo: f32, as_room: bool) -> Scene {
    let mut scene = empty_scene();
    let size = Vec3::new(4.0, 3.0, 2.5);
    if as_room {
        scene.wall_thickness_m = 0.0;
        scene.envelope.height_m = size.z;
        scene.rooms.push(Room { id: 0, room_type: "test".into(), min: Vec2::ZERO, max: size.truncate() });
    }
    let paint = add_material(&mut scene, "paint_0", [albedo; 3], 0.0, 1.0);
    add_mesh(&mut scene, box_primitive(Vec3::ZERO, size, paint, true), Mat4::IDENTITY, Semantic::Floor { room: 0 });
    scene.lights.push(point_light(LightGroup::Night, size * 0.5, 10.0));
    scene
}

/// Area-weighted mean illuminance over the inside of `closed_box`'s faces (points on a
/// 0.125 m grid of cell centres, 1 mm in front of each face).
fn mean_face_illuminance(renderer: &Renderer<'_>) -> f32 {
    let size = Vec3::new(4.0, 3.0, 2.5);
    let (mut sum, mut area) = (0.0f64, 0.0f64);
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let (nu, nv) = ((size[u] / 0.125).round() as usize, (size[v] / 0.125).round() as usize);
        for side in [0.0f32, 1.0] {
            let mut normal = Vec3::ZERO;
            normal[axis] = 1.0 - 2.0 * side;
            for i in 0..nu {
                for j in 0..nv {
                    let mut p = Vec3::ZERO;
                    p[axis] = side * size[axis] + normal[axis] * 1e-3;
                    p[u] = (i as f32 + 0.5) * size[u] / nu as f32;
                    p[v] = (j as f32 + 0.5) * size[v] / nv as f32;
                    sum += f64::from(renderer.illuminance_lux(p, normal, LightGroup::Night));
                    area += 1.0;
                }
            }
        }
    }
    // Every cell of a face has the same area, and the faces' cell sizes are equal.
    (sum / area) as f32
}

#[test]
fn bounced_light_conserves_energy_in_a_closed_room() {
    // In a closed room of uniform albedo rho, every lumen the lamp gives is absorbed at last:
    // flux = (1 - rho) * mean irradiance * area, so the mean irradiance over the faces is
    // 4 pi I / ((1 - rho) A) with every bounce, and 4 pi I / A from direct light alone.
    let area = 2.0 * (4.0 * 3.0 + 4.0 * 2.5 + 3.0 * 2.5);
    let flux_lm = 4.0 * PI * 10.0;
    for as_room in [true, false] {
        for albedo in [0.3f32, 0.7] {
            let scene = closed_box(albedo, as_room);
            let direct_only =
                RenderSettings { indirect_volume: None, probe_indirect_rays: 0, ..RenderSettings::preview() };
            let direct = Renderer::new(&scene, direct_only);
            assert_close(mean_face_illuminance(&direct), flux_lm / area, 0.02, "direct light alone");
            let lit = Renderer::new(&scene, RenderSettings::preview());
            let want = flux_lm / ((1.0 - albedo) * area);
            let what = format!("every bounce, albedo {albedo}, room {as_room}");
            // As a room the probes stand 2 cm in front of the faces; without rooms the grid
            // runs past the geometry and its probes stand anywhere, a few valid ones outside
            // the box (measured: within 1.6 % as a room, 3.6 % without).
            let tolerance = if as_room { 0.03 } else { 0.05 };
            assert_close(mean_face_illuminance(&lit), want, tolerance, &what);
        }
    }
}

#[test]
fn frames_do_not_depend_on_thread_count() {
    let scene = room_of_boxes(Vec3::new(6.0, 5.0, 2.6), 4);
    let renderer = Renderer::new(&scene, RenderSettings::standard());
    let cam = Camera { pixel_pitch_um: 20.0, ..camera(48, 32, Vec3::new(0.5, 0.5, 1.6), 40.0, -20.0) };
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let one = pool(1).install(|| renderer.render(&cam)).unwrap();
    let two = pool(2).install(|| renderer.render(&cam)).unwrap();
    assert_no_nan(&one);
    assert!(one.day_nit.iter().any(|c| lum(*c) > 0.0) && one.night_nit.iter().any(|c| lum(*c) > 0.0));
    assert!(one == two, "frames differ between 1 and 2 threads");
    let reseeded =
        Renderer::new(&scene, RenderSettings { seed: 1, ..RenderSettings::standard() }).render(&cam).unwrap();
    assert!(reseeded.day_nit != one.day_nit, "the sampling seed changes the noise");
    assert_eq!(reseeded.instance_id, one.instance_id, "but not the labels");
}

#[test]
fn each_view_draws_its_own_noise() {
    // The floor beyond the partition's end, in the window's penumbra, at one window sample per
    // pixel: noisy. A view turned by a thousandth of a degree sees the same floor (35 um at 2 m)
    // but draws its own numbers, so its noise is new: a pattern that stayed on the same pixels
    // from view to view would be matched by a feature tracker as if it were scene texture.
    let scene = window_room();
    let cam = Camera { pixel_pitch_um: 10.0, ..camera(64, 48, Vec3::new(3.5, 3.6, 2.0), 0.0, -90.0) };
    let turned = Camera { yaw_deg: cam.yaw_deg + 1e-3, ..cam };
    let renderer = Renderer::new(&scene, direct_preview());
    let (a, b) = (renderer.render(&cam).unwrap(), renderer.render(&turned).unwrap());
    let reseeded = Renderer::new(&scene, RenderSettings { seed: 1, ..direct_preview() }).render(&cam).unwrap();
    assert!(renderer.render(&cam).unwrap() == a, "the same view renders the same bytes");
    let differs = |x: [f32; 3], y: [f32; 3]| (lum(x) - lum(y)).abs() > 0.05 * lum(x).max(lum(y));
    let noisy: Vec<usize> = (0..a.day_nit.len()).filter(|&i| differs(a.day_nit[i], reseeded.day_nit[i])).collect();
    assert!(noisy.len() > 50, "{} noisy pixels in view", noisy.len());
    let new_noise = noisy.iter().filter(|&&i| differs(a.day_nit[i], b.day_nit[i])).count();
    assert!(new_noise * 2 > noisy.len(), "{new_noise} of {} noisy pixels changed with the view", noisy.len());
}

/// `preview` without the irradiance volume: direct light only, for the checks of how direct
/// light is sampled and shaded.
fn direct_preview() -> RenderSettings {
    RenderSettings { indirect_volume: None, ..RenderSettings::preview() }
}

/// [`direct_preview`] with [`ShadingRate::Decoupled`] at `stride` on frames of any width.
fn decoupled(stride: u32) -> RenderSettings {
    RenderSettings { shading: ShadingRate::Decoupled { stride, min_width_px: 0 }, ..direct_preview() }
}

/// A floor under a point light, seen from above: irradiance varies smoothly (cos^3 / h^2),
/// with no noise.
fn point_lit_floor() -> (Scene, Camera) {
    let mut scene = floor_scene();
    scene.lights.push(point_light(LightGroup::Night, Vec3::new(0.3, -0.2, 2.0), 100.0));
    (scene, down_camera(Vec3::new(0.0, 0.0, 1.5), 61, 47))
}

/// A box on a floor lit by a sun shining along `sun`, seen from above at an angle.
fn sunlit_box(sun: Vec3) -> (Scene, Camera) {
    let mut scene = floor_scene();
    scene.lights.push(directional_light(LightGroup::Day, sun, 1000.0));
    let m = add_material(&mut scene, "wood_0", [0.3, 0.6, 0.2], 0.0, 1.0);
    add_mesh(
        &mut scene,
        box_primitive(Vec3::new(-0.4, -0.3, 0.0), Vec3::new(0.3, 0.35, 0.6), m, false),
        Mat4::IDENTITY,
        Semantic::Decor { room: 0 },
    );
    (scene, Camera { pixel_pitch_um: 20.0, ..camera(80, 60, Vec3::new(-1.2, -1.4, 1.6), 45.0, -40.0) })
}

#[test]
fn decoupled_shading_interpolates_smooth_light_and_keeps_labels() {
    let (scene, cam) = point_lit_floor();
    let full = Renderer::new(&scene, RenderSettings::preview()).render(&cam).unwrap();
    let frame = Renderer::new(&scene, decoupled(3)).render(&cam).unwrap();
    assert_no_nan(&frame);
    assert_eq!((&frame.depth_m, &frame.instance_id, &frame.normal), (&full.depth_m, &full.instance_id, &full.normal));
    let (mut max_rel, mut differing) = (0.0f32, 0);
    for y in 0..cam.height_px {
        for x in 0..cam.width_px {
            let i = full.index(x, y);
            let (want, got) = (lum(full.night_nit[i]), lum(frame.night_nit[i]));
            let anchor = (x % 3 == 0 || x == cam.width_px - 1) && (y % 3 == 0 || y == cam.height_px - 1);
            if anchor {
                assert_eq!(full.night_nit[i], frame.night_nit[i], "anchor ({x}, {y}) is shaded in full");
            } else if got != want {
                differing += 1;
            }
            max_rel = max_rel.max(((got - want) / want).abs());
        }
    }
    // Interpolated, not recomputed: the in-between pixels differ (by rounding at least)...
    assert!(differing > 1000, "{differing} interpolated pixels differ from full shading");
    // ...by the bilinear error of a smooth field over 3 px (about 2 cm of floor here).
    assert!(max_rel < 2e-3, "largest relative error {max_rel}");
}

#[test]
fn decoupled_shading_never_blends_across_surfaces() {
    // Sun straight down on a floor and a box: the box's top and the floor get the same
    // irradiance, its sides none, its shadow hides under it. A pixel that took irradiance from
    // an anchor on another face (a side from the top or the floor) would be far off.
    let (scene, cam) = sunlit_box(-Vec3::Z);
    let full = Renderer::new(&scene, direct_preview()).render(&cam).unwrap();
    for stride in [2, 4] {
        let frame = Renderer::new(&scene, decoupled(stride)).render(&cam).unwrap();
        let sides = full.day_nit.iter().filter(|c| lum(**c) == 0.0 && c.iter().all(|v| *v == 0.0)).count();
        assert!(sides > 100, "{sides} px of unlit box sides in view");
        for (i, (a, b)) in full.day_nit.iter().zip(&frame.day_nit).enumerate() {
            let (a, b) = (Vec3::from(*a), Vec3::from(*b));
            assert!(
                (a - b).abs().max_element() <= 1e-4 * a.max_element().max(1.0),
                "stride {stride} pixel {i}: {a} vs {b}"
            );
        }
    }
}

/// [`direct_preview`] with [`ShadingRate::Adaptive`] at `stride` on frames of any width.
fn adaptive(stride: u32) -> RenderSettings {
    RenderSettings { shading: ShadingRate::Adaptive { stride, min_width_px: 0 }, ..direct_preview() }
}

#[test]
fn adaptive_shading_interpolates_smooth_light_from_fewer_anchors() {
    // The smooth point-light field of `decoupled_shading_interpolates_smooth_light_and_keeps_labels`:
    // most fine anchors agree with their coarse neighbours within the tolerance and are
    // interpolated, so the frame is not the decoupled one, but close to full shading.
    let (scene, cam) = point_lit_floor();
    let full = Renderer::new(&scene, RenderSettings::preview()).render(&cam).unwrap();
    let decoupled = Renderer::new(&scene, decoupled(3)).render(&cam).unwrap();
    let frame = Renderer::new(&scene, adaptive(3)).render(&cam).unwrap();
    assert_no_nan(&frame);
    assert_eq!((&frame.depth_m, &frame.instance_id, &frame.normal), (&full.depth_m, &full.instance_id, &full.normal));
    let differing = frame.night_nit.iter().zip(&decoupled.night_nit).filter(|(a, b)| a != b).count();
    assert!(differing > 500, "{differing} pixels differ from the decoupled frame: anchors were interpolated");
    let max_rel = full
        .night_nit
        .iter()
        .zip(&frame.night_nit)
        .map(|(a, b)| ((lum(*b) - lum(*a)) / lum(*a)).abs())
        .fold(0.0f32, f32::max);
    // The bilinear error of the smooth field over 6 px instead of 3.
    assert!(max_rel < 1e-2, "largest relative error {max_rel}");
}

#[test]
fn adaptive_shading_traces_the_anchors_along_a_sun_shadow_edge() {
    // A low sun: the box casts a shadow on the sunlit floor. The floor's irradiance is constant
    // on either side of the edge, so wherever the coarse anchors agree the mean is exact; where
    // the edge passes between them, the directional bits differ and the anchor is traced. Either
    // way every pixel gets the irradiance the decoupled frame gives it (the day group is never
    // compared, and there is no night light, so only the sun's bits decide).
    let (scene, cam) = sunlit_box(Vec3::new(-1.0, -0.6, -1.0).normalize());
    for stride in [2, 3] {
        let decoupled = Renderer::new(&scene, decoupled(stride)).render(&cam).unwrap();
        let frame = Renderer::new(&scene, adaptive(stride)).render(&cam).unwrap();
        let lit = decoupled.day_nit.iter().filter(|c| lum(**c) > 0.0).count();
        let dark = decoupled.day_nit.iter().filter(|c| lum(**c) == 0.0).count();
        assert!(lit > 500 && dark > 300, "stride {stride}: {lit} lit and {dark} shadowed px in view");
        for (i, (a, b)) in decoupled.day_nit.iter().zip(&frame.day_nit).enumerate() {
            let (a, b) = (Vec3::from(*a), Vec3::from(*b));
            assert!(
                (a - b).abs().max_element() <= 1e-4 * a.max_element().max(1.0),
                "stride {stride} pixel {i}: {a} decoupled vs {b} adaptive"
            );
        }
    }
}

/// `settings` with `n x n` window samples per anchor, every light traced, and the window
/// visibility pooled over `radius` anchors.
fn window_samples(settings: RenderSettings, n: u32, radius: u32) -> RenderSettings {
    RenderSettings { rect_samples_per_axis: n, light_cull: 0.0, visibility_filter_radius: radius, ..settings }
}

/// Mean absolute day luminance difference of `frame` from `reference`, relative to the
/// reference's mean.
fn day_error(frame: &Frame, reference: &Frame) -> f32 {
    let diff: f32 = frame.day_nit.iter().zip(&reference.day_nit).map(|(a, b)| (lum(*a) - lum(*b)).abs()).sum();
    diff / reference.day_nit.iter().map(|c| lum(*c)).sum::<f32>()
}

#[test]
fn pooled_window_visibility_cuts_the_noise_of_few_samples() {
    // The floor beyond the partition's end of `window_room`, in the window's penumbra (see
    // `each_view_draws_its_own_noise`). One window sample per anchor is noisy; pooling it over
    // the anchors on the same surface (interleaved, so a block of them holds a whole lattice of
    // samples) must bring it closer to a 64-sample frame than the 1-sample frame is, by more
    // than half. Labels do not change, nor does the frame with the thread count.
    let scene = window_room();
    let cam = Camera { pixel_pitch_um: 10.0, ..camera(96, 72, Vec3::new(3.5, 3.6, 2.0), 0.0, -90.0) };
    for (name, shading) in [("decoupled", decoupled(3)), ("adaptive", adaptive(3))] {
        let reference = Renderer::new(&scene, window_samples(shading, 8, 0)).render(&cam).unwrap();
        let one = Renderer::new(&scene, window_samples(shading, 1, 0)).render(&cam).unwrap();
        let pooled_renderer = Renderer::new(&scene, window_samples(shading, 1, 2));
        let pooled = pooled_renderer.render(&cam).unwrap();
        assert_no_nan(&pooled);
        let (e_one, e_pooled) = (day_error(&one, &reference), day_error(&pooled, &reference));
        assert!(e_one > 0.02, "{name}: the 1-sample frame is noisy ({e_one})");
        assert!(e_pooled < 0.5 * e_one, "{name}: pooled error {e_pooled} vs {e_one} unpooled");
        assert_eq!((&pooled.instance_id, &pooled.depth_m), (&one.instance_id, &one.depth_m), "{name}");
        let two_threads = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        assert!(two_threads.install(|| pooled_renderer.render(&cam)).unwrap() == pooled, "{name}: thread count");
    }
}

#[test]
fn pooling_leaves_a_fully_visible_window_exact() {
    // A window in the ceiling over an open floor: every anchor sees all of it, so its sampled
    // share is 1 everywhere and pooling must give back each anchor's exact light, to rounding.
    let mut scene = floor_scene();
    scene.lights.push(rect_light(LightGroup::Day, Vec3::new(0.2, 0.1, 2.5), Vec3::X, Vec3::Y, -Vec3::Z, 500.0));
    let cam = down_camera(Vec3::new(0.0, 0.0, 1.5), 61, 47);
    for shading in [decoupled(3), adaptive(3)] {
        let plain = Renderer::new(&scene, window_samples(shading, 1, 0)).render(&cam).unwrap();
        let pooled = Renderer::new(&scene, window_samples(shading, 1, 2)).render(&cam).unwrap();
        assert!(plain.day_nit.iter().all(|c| lum(*c) > 0.0));
        for (a, b) in plain.day_nit.iter().zip(&pooled.day_nit) {
            assert_close(lum(*b), lum(*a), 1e-5, "pooled vs own exact light");
        }
    }
}

#[test]
fn rendering_into_a_used_frame_gives_the_fresh_frame() {
    // `render_into` overwrites every pixel: a frame that held another view, or a view of
    // another size, comes out as `render` would make it, for every way of shading.
    let scene = room_of_boxes(Vec3::new(6.0, 5.0, 2.6), 4);
    let cam = Camera { pixel_pitch_um: 20.0, ..camera(48, 32, Vec3::new(0.5, 0.5, 1.6), 40.0, -20.0) };
    let other = Camera { yaw_deg: 130.0, ..cam };
    let larger = Camera { width_px: 64, height_px: 40, ..other };
    for settings in [RenderSettings::standard(), decoupled(2), window_samples(adaptive(3), 1, 2)] {
        let renderer = Renderer::new(&scene, settings);
        let fresh = renderer.render(&cam).unwrap();
        for previous in [other, larger] {
            let mut frame = renderer.render(&previous).unwrap();
            renderer.render_into(&cam, &mut frame).unwrap();
            assert!(frame == fresh, "{settings:?} after a {}x{} view", previous.width_px, previous.height_px);
        }
    }
    let mut frame = Frame::default();
    let bad = Camera { width_px: 0, ..cam };
    assert!(Renderer::new(&scene, RenderSettings::preview()).render_into(&bad, &mut frame).is_err());
    assert_eq!(frame, Frame::default(), "a bad camera leaves the frame as it was");
}

#[test]
fn decoupled_shading_applies_only_where_configured() {
    let scene = room_of_boxes(Vec3::new(6.0, 5.0, 2.6), 4);
    let cam = Camera { pixel_pitch_um: 20.0, ..camera(48, 32, Vec3::new(0.5, 0.5, 1.6), 40.0, -20.0) };
    let full = Renderer::new(&scene, direct_preview()).render(&cam).unwrap();
    let narrow = RenderSettings { shading: ShadingRate::Decoupled { stride: 2, min_width_px: 49 }, ..direct_preview() };
    assert!(Renderer::new(&scene, narrow).render(&cam).unwrap() == full, "narrower than min_width_px: full rate");
    assert!(Renderer::new(&scene, decoupled(1)).render(&cam).unwrap() == full, "stride 1 is full rate");
    let standard = RenderSettings { shading: decoupled(2).shading, ..RenderSettings::standard() };
    assert!(
        Renderer::new(&scene, standard).render(&cam).unwrap()
            == Renderer::new(&scene, RenderSettings::standard()).render(&cam).unwrap(),
        "several camera rays per pixel: full rate"
    );
    // Applied: thread-count independent, and different from full rate.
    let renderer = Renderer::new(&scene, decoupled(2));
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let a = pool(1).install(|| renderer.render(&cam)).unwrap();
    let b = pool(2).install(|| renderer.render(&cam)).unwrap();
    assert!(a == b, "decoupled frames differ between 1 and 2 threads");
    assert!(a.day_nit != full.day_nit, "decoupled shading was not applied");
    assert_eq!(a.instance_id, full.instance_id);
    let renderer = Renderer::new(&scene, adaptive(2));
    let c = pool(1).install(|| renderer.render(&cam)).unwrap();
    let d = pool(2).install(|| renderer.render(&cam)).unwrap();
    assert!(c == d, "adaptive frames differ between 1 and 2 threads");
    assert_eq!(c.instance_id, full.instance_id);
}

#[test]
fn light_scale_brings_each_group_to_its_target() {
    let scene = room_of_boxes(Vec3::new(6.0, 5.0, 2.6), 3);
    let settings = RenderSettings { probe_indirect_rays: 16, ..RenderSettings::standard() };
    let renderer = Renderer::new(&scene, settings);
    let scale = LightScale::to_targets(&renderer, 20.0, 2.0, 0.75).unwrap();
    assert!(scale.day > 0.0 && scale.night > 0.0 && scale.day != scale.night);
    let mut scaled = scene.clone();
    for light in &mut scaled.lights {
        light.intensity *= scale.factor(light.group);
    }
    let renderer = Renderer::new(&scaled, settings);
    assert_close(measure_mean_illuminance(&renderer, LightGroup::Day, 0.75).unwrap(), 20.0, 1e-3, "day");
    assert_close(measure_mean_illuminance(&renderer, LightGroup::Night, 0.75).unwrap(), 2.0, 1e-3, "night");
    assert!(measure_mean_illuminance(&Renderer::new(&empty_scene(), settings), LightGroup::Day, 0.75).is_err());
}

#[test]
fn textures_are_decoded_and_tinted() {
    let mut scene = floor_scene();
    scene.geometry.materials[0].base_color = [1.0, 1.0, 0.5, 1.0];
    // 1x1 sRGB (255, 128, 0): linear (1, 0.2159, 0).
    scene.geometry.textures.push(Texture {
        name: "orange".into(),
        width: 1,
        height: 1,
        rgba8: [255u8, 128, 0, 255].into_iter().collect(),
        png: Vec::new().into(),
    });
    scene.geometry.materials[0].base_color_texture = Some(0);
    scene.lights.push(directional_light(LightGroup::Day, -Vec3::Z, 100.0));
    let frame = Renderer::new(&scene, RenderSettings::preview()).render(&down_camera(Vec3::Z, 4, 4)).unwrap();
    let c = frame.day_nit[0];
    assert!((c[0] - 100.0 / PI).abs() < 1e-3 && (c[1] - 0.215_861 * 100.0 / PI).abs() < 1e-3 && c[2] == 0.0, "{c:?}");
}

#[test]
fn polished_metal_mirrors_an_emitter_tinted_by_its_base_colour() {
    let mut scene = empty_scene();
    let gold = add_material(&mut scene, "gold_0", [1.0, 0.5, 0.25], 1.0, 0.0);
    add_mesh(
        &mut scene,
        quad(Vec3::ZERO, Vec3::X * 50.0, Vec3::Y * 50.0, gold),
        Mat4::IDENTITY,
        Semantic::Floor { room: 0 },
    );
    let l_nit = 300.0;
    scene.lights.push(rect_light(
        LightGroup::Day,
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::X * 2.0,
        Vec3::Y * 2.0,
        -Vec3::Z,
        l_nit,
    ));
    let frame = Renderer::new(&scene, RenderSettings::standard()).render(&down_camera(Vec3::Z, 8, 6)).unwrap();
    let c = frame.day_nit[frame.index(4, 3)];
    assert!(
        (c[0] - l_nit).abs() < 1e-2 && (c[1] - 0.5 * l_nit).abs() < 1e-2 && (c[2] - 0.25 * l_nit).abs() < 1e-2,
        "{c:?}"
    );
    let no_mirrors = RenderSettings { specular: false, ..RenderSettings::standard() };
    let frame = Renderer::new(&scene, no_mirrors).render(&down_camera(Vec3::Z, 8, 6)).unwrap();
    assert_eq!(frame.day_nit[frame.index(4, 3)], [0.0; 3], "a polished metal has no diffuse part");
}

mod properties {
    use super::*;
    use proptest::prelude::*;
    use std::sync::OnceLock;

    fn room() -> &'static Scene {
        static SCENE: OnceLock<Scene> = OnceLock::new();
        SCENE.get_or_init(|| room_of_boxes(Vec3::new(6.0, 5.0, 2.6), 5))
    }

    /// The body of `packets_answer_as_single_rays_do`: a packet of `len` rays fanned `spread`
    /// wide from a camera at `position`, its closest hits and the shadow rays from them to
    /// `light` against the same rays traced one by one.
    fn packet_and_single_rays_agree(
        position: Vec3,
        yaw: f32,
        pitch: f32,
        spread: f32,
        len: usize,
        light: Vec3,
    ) -> Result<(), TestCaseError> {
        let accel = Accel::build(room());
        let cam = camera(8, 8, position, yaw, pitch);
        let (forward, right, up) = cam.basis();
        let origin = cam.position;
        let dirs: Vec<Vec3> = (0..len)
            .map(|i| {
                let (u, v) = ((i % 8) as f32 / 7.0 - 0.5, (i / 8) as f32 / 7.0 - 0.5);
                (forward + (right * u + up * v) * spread).normalize()
            })
            .collect();
        let mut packet = RayPacket::new();
        for d in &dirs {
            packet.push(origin, *d, f32::INFINITY);
        }
        let mut hits = [None; PACKET_RAYS];
        accel.closest_hits(&mut packet, &mut hits);
        let mut shadow = RayPacket::new();
        let mut expected = 0u64;
        for (i, d) in dirs.iter().enumerate() {
            let single = accel.closest_hit(origin, *d, f32::INFINITY);
            prop_assert_eq!(hits[i].map(|h| h.t.to_bits()), single.map(|h| h.t.to_bits()), "ray {}", i);
            let p = origin + *d * single.map_or(1.0, |h| h.t) * 0.999;
            let to = light - p;
            let (dir, dist) = (to.normalize_or(Vec3::Z), to.length());
            shadow.push(p, dir, dist);
            expected |= u64::from(accel.occluded(p, dir, dist)) << i;
        }
        prop_assert_eq!(accel.occluded_packet(&mut shadow), expected);
        Ok(())
    }

    /// A case the property found: ray 11 meets two triangles whose distances differ by one ulp
    /// where two leaf boxes touch. The single ray pruned the box of the nearer one (its rounded
    /// entry distance lay past the farther hit) while the packet, walking in another order,
    /// found it.
    #[test]
    fn a_packet_and_a_single_ray_agree_where_two_leaf_boxes_touch() {
        let position = Vec3::new(0.43144146, 3.6721191, 0.3);
        packet_and_single_rays_agree(position, 0.0, 0.0, 2.0196948, 12, Vec3::splat(0.1)).unwrap();
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// From anywhere inside a closed room, looking anywhere, every pixel hits geometry, and
        /// radiance is finite and non-negative.
        #[test]
        fn closed_room_views_are_hole_free_and_finite(
            x in 0.2f32..5.8, y in 0.2f32..4.8, z in 1.0f32..2.5,
            yaw in -180f32..180.0, pitch in -90f32..=90.0, seed in 0u64..1000,
        ) {
            let settings = RenderSettings { indirect_rays: 1, seed, ..RenderSettings::preview() };
            let renderer = Renderer::new(room(), settings);
            let cam = Camera { pixel_pitch_um: 40.0, ..camera(24, 16, Vec3::new(x, y, z), yaw, pitch) };
            let frame = renderer.render(&cam).unwrap();
            prop_assert!(frame.depth_m.iter().all(|d| d.is_finite() && *d > -1e-3));
            for c in frame.day_nit.iter().chain(&frame.night_nit) {
                prop_assert!(c.iter().all(|v| v.is_finite() && *v >= 0.0));
            }
        }

        /// Rays traced as a packet find what they find one by one: the same closest distance
        /// (bit for bit; which of two triangles at one distance is reported may differ) and the
        /// same shadow answers, for coherent and scattered packets of any size.
        #[test]
        fn packets_answer_as_single_rays_do(
            x in 0.2f32..5.8, y in 0.2f32..4.8, z in 0.3f32..2.5,
            yaw in -180f32..180.0, pitch in -90f32..=90.0, spread in 0.001f32..3.0,
            len in 1usize..=PACKET_RAYS, light in (0.1f32..5.9, 0.1f32..4.9, 0.1f32..2.5),
        ) {
            packet_and_single_rays_agree(Vec3::new(x, y, z), yaw, pitch, spread, len, Vec3::new(light.0, light.1, light.2))?;
        }

        /// Culling rect emitters per packet keeps every one a ray of the packet sees: each ray
        /// finds the same emitter (distance, group) among the packet's candidates as among all.
        #[test]
        fn packet_emitter_culling_keeps_what_rays_see(
            x in -3.0f32..3.0, y in -3.0f32..3.0, z in 0.2f32..2.5,
            yaw in -180f32..180.0, pitch in -90f32..=90.0, spread in 0.001f32..3.0,
            len in 1usize..=PACKET_RAYS,
        ) {
            let windows: Vec<_> = (0..6)
                .map(|k| {
                    let a = k as f32;
                    rect_light(
                        LightGroup::Day,
                        Vec3::new(2.0 * (a * 1.3).cos(), 2.0 * (a * 0.7).sin(), 0.5 + 0.3 * a),
                        Vec3::new(0.6, 0.1 * a, 0.0),
                        Vec3::new(0.0, 0.2, 0.9),
                        Vec3::new((a * 2.1).cos(), (a * 2.1).sin(), -0.3),
                        100.0,
                    )
                })
                .collect();
            let lights = LightSet::new(&windows, [1.0, 1.0]);
            let cam = camera(8, 8, Vec3::new(x, y, z), yaw, pitch);
            let (forward, right, up) = cam.basis();
            let mut packet = RayPacket::new();
            let dirs: Vec<Vec3> = (0..len)
                .map(|i| {
                    let (u, v) = ((i % 8) as f32 / 7.0 - 0.5, (i / 8) as f32 / 7.0 - 0.5);
                    let d = (forward + (right * u + up * v) * spread).normalize();
                    packet.push(cam.position, d, f32::INFINITY);
                    d
                })
                .collect();
            let mut candidates = Vec::new();
            lights.emitters_in_reach(&mut packet, &mut candidates);
            for d in &dirs {
                let all = lights.emitter_seen(cam.position, *d, f32::INFINITY).map(|e| (e.0.to_bits(), e.1));
                let among = lights
                    .emitter_seen_among(cam.position, *d, f32::INFINITY, candidates.iter().copied())
                    .map(|e| (e.0.to_bits(), e.1));
                prop_assert_eq!(all, among);
            }
        }

        /// A shadow ray's answer does not depend on the triangle tried first
        /// (`Accel::blocker`'s hint): not on an arbitrary one, not on the one that blocked the
        /// previous ray of a fan, not on none; and a triangle named as the blocker of a ray,
        /// given back as the hint, is named again. (Grazing rays, which obvhs' own box test
        /// could drop, are checked against every triangle in the tests of scene-gen-trace's `wide` module.)
        #[test]
        fn shadow_hints_never_change_the_answer(
            x in 0.2f32..5.8, y in 0.2f32..4.8, z in 0.3f32..2.5,
            light in (0.1f32..5.9, 0.1f32..4.9, 0.1f32..2.5), spread in 0.01f32..3.0, hint in 0u32..2000,
        ) {
            let accel = Accel::build(room());
            prop_assume!(accel.triangle_count() > 0);
            let hint = hint % (accel.triangle_count() as u32 + 8);
            let light = Vec3::new(light.0, light.1, light.2);
            let mut previous = NO_TRIANGLE;
            for i in 0..64 {
                let (u, v) = ((i % 8) as f32 / 7.0 - 0.5, (i / 8) as f32 / 7.0 - 0.5);
                let p = Vec3::new(x + u * spread, y + v * spread, z);
                let to = light - p;
                let (dir, dist) = (to.normalize_or(Vec3::Z), to.length());
                let expected = accel.occluded(p, dir, dist);
                prop_assert_eq!(accel.blocker(p, dir, dist, hint).is_some(), expected, "ray {}", i);
                let found = accel.blocker(p, dir, dist, previous);
                prop_assert_eq!(found.is_some(), expected, "ray {}", i);
                if let Some(b) = accel.blocker(p, dir, dist, NO_TRIANGLE) {
                    prop_assert_eq!(accel.blocker(p, dir, dist, b), Some(b));
                }
                previous = found.unwrap_or(previous);
            }
        }
    }
}

#[test]
fn light_culling_is_unbiased_and_saves_work() {
    // One bright light overhead and 40 weak ones scattered far away, all unoccluded.
    let mut scene = floor_scene();
    scene.lights.push(point_light(LightGroup::Night, Vec3::new(0.0, 0.0, 2.0), 100.0));
    for k in 0..40 {
        let a = k as f32 * 0.61;
        let r = 8.0 + (k % 7) as f32;
        scene.lights.push(point_light(LightGroup::Night, Vec3::new(a.cos() * r, a.sin() * r, 2.5), 30.0));
    }
    let exact_settings = RenderSettings { light_cull: 0.0, probe_indirect_rays: 0, ..RenderSettings::standard() };
    let culled_settings = RenderSettings { light_cull: 0.1, ..exact_settings };
    let (exact, culled) = (Renderer::new(&scene, exact_settings), Renderer::new(&scene, culled_settings));
    let points: Vec<Vec3> =
        (0..400).map(|i| Vec3::new((i % 20) as f32 * 0.1 - 1.0, (i / 20) as f32 * 0.1 - 1.0, 0.0)).collect();
    let mean =
        |r: &Renderer| points.iter().map(|p| r.illuminance_lux(*p, Vec3::Z, LightGroup::Night)).sum::<f32>() / 400.0;
    let (e_exact, e_culled) = (mean(&exact), mean(&culled));
    assert_close(e_culled, e_exact, 0.02, "culled mean illuminance");
    // Individual estimates do differ (the far lights are sampled), so culling did happen.
    let p = Vec3::new(0.3, 0.2, 0.0);
    assert!(
        exact.illuminance_lux(p, Vec3::Z, LightGroup::Night) != culled.illuminance_lux(p, Vec3::Z, LightGroup::Night)
    );
}

#[test]
fn probes_cover_lit_rooms_and_avoid_furniture() {
    let mut scene = empty_scene();
    scene.wall_thickness_m = 0.2;
    scene.rooms.push(Room { id: 0, room_type: "a".into(), min: Vec2::ZERO, max: Vec2::new(4.2, 3.2) });
    scene.rooms.push(Room { id: 1, room_type: "b".into(), min: Vec2::new(4.2, 0.0), max: Vec2::new(8.4, 3.2) });
    let mut lamp = point_light(LightGroup::Night, Vec3::new(1.0, 1.0, 2.5), 10.0);
    lamp.room = Some(0);
    scene.lights.push(lamp);
    // Interior 4 x 3 m: an 8 x 6 grid; a 1 m tall cupboard covers the 2 x 2 cells of one corner.
    scene.objects.push(Object {
        id: 0,
        class: ObjectClass::Table,
        instance_id: 1,
        room: 0,
        asset: "table/box".into(),
        min: Vec3::new(0.0, 0.0, 0.0),
        max: Vec3::new(1.1, 1.1, 1.0),
        yaw_deg: 0.0,
        on: None,
    });
    let night = probe_points(&scene, LightGroup::Night, 0.75);
    assert_eq!(night.len(), 8 * 6 - 4);
    assert!(night.iter().all(|p| p.x < 4.2 && p.z == 0.75 && !(p.x < 1.1 && p.y < 1.1)));
    // No day light names a room: every room is probed.
    assert_eq!(probe_points(&scene, LightGroup::Day, 0.75).len(), 2 * 8 * 6 - 4);
}

#[test]
fn generated_scenes_render_and_scale() {
    use scene_gen::config::GeneratorConfig;
    use scene_gen::library::Library;
    let library = Library::embedded().unwrap();
    let scene =
        scene_gen::generate::generate(&GeneratorConfig { seed: 7, ..GeneratorConfig::default() }, &library).unwrap();
    let settings = RenderSettings { probe_indirect_rays: 4, ..RenderSettings::preview() };
    let renderer = Renderer::new(&scene, settings);
    let room = &scene.rooms[0];
    let cam = Camera { pixel_pitch_um: 40.0, ..camera(32, 24, room.center().extend(1.5), 30.0, -30.0) };
    let frame = renderer.render(&cam).unwrap();
    assert_no_nan(&frame);
    assert!(frame.depth_m.iter().any(|d| d.is_finite()), "the floor is in view");
    // The label-only pass sees exactly what the full render labels, and shades nothing.
    let labels = renderer.render_labels(&cam).unwrap();
    assert_eq!(labels.instance_id, frame.instance_id);
    assert_eq!(labels.class_id, frame.class_id);
    assert_eq!(labels.depth_m, frame.depth_m);
    assert_eq!(labels.normal, frame.normal);
    assert!(frame.day_nit.iter().any(|c| c.iter().any(|&v| v > 0.0)), "the full render is lit");
    assert!(labels.day_nit.iter().chain(&labels.night_nit).all(|c| *c == [0.0; 3]));
    // So does the ids-only pass.
    let ids = renderer.render_ids(&cam).unwrap();
    assert_eq!((ids.rect.width, ids.rect.height), (32, 24));
    assert_eq!(ids.instance_id, frame.instance_id);
    assert_eq!(ids.class_id, frame.class_id);
    assert!(ids.instance_id.iter().any(|&id| id != 0), "some object or threshold is in view");
    let scale = LightScale::to_targets(&renderer, 20.0, 2.0, 0.75).unwrap();
    assert!(scale.day.is_finite() && scale.night.is_finite());
}

#[test]
fn one_bounce_from_a_sunlit_plane_fills_the_hemisphere() {
    // Below the probe an (effectively infinite) plane of albedo rho lit by E0 has radiance
    // rho E0 / pi in every direction, so a probe facing it receives E = pi L = rho E0.
    let mut scene = floor_scene();
    scene.lights.push(directional_light(LightGroup::Day, -Vec3::Z, 100.0));
    let renderer = Renderer::new(&scene, RenderSettings::standard());
    let e = renderer.illuminance_lux(Vec3::new(0.3, -0.2, 1.0), -Vec3::Z, LightGroup::Day);
    assert_close(e, ALBEDO * 100.0, 0.002, "indirect illuminance from the plane");
    // Facing up, the probe sees the sun directly and nothing bounces back down.
    assert_close(renderer.illuminance_lux(Vec3::new(0.3, -0.2, 1.0), Vec3::Z, LightGroup::Day), 100.0, 1e-4, "direct");
}
