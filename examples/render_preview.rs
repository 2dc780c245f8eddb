//! Renders the benchmark's room of boxes by day and by night and writes quick-look PNGs.
//!
//! ```text
//! cargo run --release --example render_preview -- OUT_DIR
//! ```
//!
//! Writes `day.png`, `night.png` (radiance scaled so four times the frame's median luminance
//! is white, then sRGB-encoded: a preview, not a camera simulation), `depth.png` (0..10 m) and
//! `instances.png` (one grey level per instance id).

use glam::Vec3;
use image::{GrayImage, RgbImage};
use scene_gen::render::test_util::{camera, room_of_boxes};
use scene_gen::render::{Camera, Frame, LightScale, RenderSettings, Renderer, luminance};
use scene_gen::scene::LightGroup;

fn encode(radiance: &[[f32; 3]], w: u32, h: u32) -> RgbImage {
    let mut lum: Vec<f32> = radiance.iter().map(|c| luminance(Vec3::from(*c))).collect();
    lum.sort_by(f32::total_cmp);
    let white = (4.0 * lum[lum.len() / 2]).max(1e-6);
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
    let out = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    std::fs::create_dir_all(&out)?;
    let scene = room_of_boxes(Vec3::new(8.0, 6.0, 2.6), 6);
    let renderer = Renderer::new(&scene, RenderSettings::standard());
    let scale = LightScale::to_targets(&renderer, 20.0, 2.0, 0.75)?;
    println!("light scale: day x{:.3}, night x{:.3}", scale.day, scale.night);
    let cam = Camera { pixel_pitch_um: 10.0, ..camera(480, 320, Vec3::new(7.5, 5.5, 1.6), -140.0, -20.0) };
    let frame: Frame = renderer.render(&cam)?;
    let (w, h) = (frame.width, frame.height);
    encode(&scale.apply(&frame, LightGroup::Day), w, h).save(out.join("day.png"))?;
    encode(&scale.apply(&frame, LightGroup::Night), w, h).save(out.join("night.png"))?;
    GrayImage::from_fn(w, h, |x, y| image::Luma([(frame.depth_m[frame.index(x, y)] / 10.0 * 255.0).min(255.0) as u8]))
        .save(out.join("depth.png"))?;
    GrayImage::from_fn(w, h, |x, y| image::Luma([(frame.instance_id[frame.index(x, y)] * 37 % 256) as u8]))
        .save(out.join("instances.png"))?;
    println!("wrote {}", out.display());
    Ok(())
}
