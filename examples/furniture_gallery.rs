//! Renders the procedural furniture: one picture per class and furnishing, a row per generator, one shape per
//! column (shape seeds 1..=N), with scene-gen's own renderer and materials.
//!
//! ```text
//! cargo run --release --example furniture_gallery -- OUT_DIR [N]
//! ```
//!
//! Every shape is drawn at the middle of its variant's size range in the embedded library, then
//! scaled to fit a 1 m cell so small and large pieces show alike. Writes
//! `OUT_DIR/gallery_<class>.png` (daylight from a sun and the sky side, exposure from the
//! frame's median, sRGB): a visual check of the families, not a camera simulation.

use glam::{Mat4, Vec3};
use image::RgbImage;
use scene_gen::library::Library;
use scene_gen::materials::MaterialCatalog;
use scene_gen::render::test_util::{add_material, box_primitive, camera, directional_light, empty_scene};
use scene_gen::render::{RenderSettings, Renderer, luminance};
use scene_gen::scene::{Kind, LightGroup, Node, Semantic};

const CELL_M: f32 = 1.4;

fn encode(radiance: &[[f32; 3]], w: u32, h: u32) -> RgbImage {
    let mut lum: Vec<f32> = radiance.iter().map(|c| luminance(Vec3::from(*c))).collect();
    lum.sort_by(f32::total_cmp);
    let white = (2.5 * lum[lum.len() / 2]).max(1e-6);
    let srgb = |v: f32| {
        let v = (v / white).clamp(0.0, 1.0);
        let e = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
        (e * 255.0).round() as u8
    };
    RgbImage::from_fn(w, h, |x, y| {
        let c = radiance[(y * w + x) as usize];
        image::Rgb([srgb(c[0]), srgb(c[1]), srgb(c[2])])
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = std::path::PathBuf::from(args.next().unwrap_or_else(|| ".".into()));
    let columns: u32 = args.next().map_or(Ok(5), |n| n.parse())?;
    std::fs::create_dir_all(&out)?;
    let library = Library::embedded()?;
    for class in Kind::all() {
        let Some(entry) = library.furniture_class(class) else { continue };
        let variants: Vec<_> = entry.variants.iter().filter(|v| v.generator.is_some()).collect();
        let mut scene = empty_scene();
        let floor = add_material(&mut scene, "floor", [0.55, 0.55, 0.55], 0.0, 0.9);
        let (cols, rows) = (columns as f32, variants.len() as f32);
        scene.geometry.meshes.push(scene_gen::scene::Mesh {
            name: "floor".into(),
            primitives: vec![box_primitive(
                Vec3::new(-1.0, -1.0, -0.05),
                Vec3::new(cols * CELL_M + 1.0, rows * CELL_M + 1.0, 0.0),
                floor,
                false,
            )],
        });
        scene.geometry.nodes.push(Node {
            name: "floor".into(),
            mesh: 0,
            transform: Mat4::IDENTITY,
            semantic: Semantic::Floor { room: 0 },
        });
        let mut materials = MaterialCatalog::new(7);
        for (row, variant) in variants.iter().enumerate() {
            let generator = variant.generator.expect("filtered");
            for col in 0..columns {
                let mesh = generator.generate(variant.mesh.size(), entry.uniform_scale, u64::from(col) + 1);
                let fit = 1.0 / mesh.size().max_element();
                let mut error = None;
                let m = mesh.to_mesh(&format!("{}_{col}", generator.name), |s| {
                    materials.material(&mut scene.geometry, s, col).unwrap_or_else(|e| {
                        error = Some(e);
                        0
                    })
                });
                if let Some(e) = error {
                    return Err(e.into());
                }
                scene.geometry.meshes.push(m);
                let centre = Vec3::new((col as f32 + 0.5) * CELL_M, (row as f32 + 0.5) * CELL_M, 0.0);
                scene.geometry.nodes.push(Node {
                    name: format!("{}_{col}", generator.name),
                    mesh: scene.geometry.meshes.len() - 1,
                    transform: Mat4::from_translation(centre) * Mat4::from_scale(Vec3::splat(fit)),
                    semantic: Semantic::Decor { room: 0 },
                });
            }
        }
        scene.lights.push(directional_light(LightGroup::Day, Vec3::new(0.4, 0.6, -1.0), 20.0));
        scene.lights.push(directional_light(LightGroup::Day, Vec3::new(-0.3, -0.5, -1.0), 8.0));
        let renderer = Renderer::new(&scene, RenderSettings::standard());
        let width = 220 * columns;
        let height = (170.0 * rows + 260.0) as u32;
        // In front of the rows (fronts face +Y), looking down at them.
        let eye = Vec3::new(cols * CELL_M * 0.5, rows * CELL_M + 2.2 + rows * 0.6, 2.0 + rows * 0.9);
        let target = Vec3::new(cols * CELL_M * 0.5, rows * CELL_M * 0.5, 0.3);
        let d = target - eye;
        let pitch = d.z.atan2(d.truncate().length()).to_degrees();
        let mut cam = camera(width, height, eye, -90.0, pitch);
        cam.focal_mm = 5.0;
        cam.pixel_pitch_um = 4.0 * 1100.0 / width as f32;
        let frame = renderer.render(&cam)?;
        let day = frame.radiance(LightGroup::Day);
        let path = out.join(format!("gallery_{class}.png"));
        encode(day, frame.width, frame.height).save(&path)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
