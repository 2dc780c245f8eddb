//! Cost of each optical effect (crates/camera/src/optics.rs) on one 640 x 480 frame, and of the whole
//! capture with and without them.
//!
//! ```sh
//! cargo run --release --example bench_optics [-- REPEATS]
//! ```
//!
//! The frame is synthetic (a textured sensor-plane image; depth rising from 0.5 m at the
//! bottom to 6 m at the top, like a floor seen from a robot), so the figures do not depend on
//! the renderer. Each line is the median of REPEATS runs (default 15), on one thread.

use std::time::Instant;

use glam::Vec3;
use scene_gen::camera_spec::{CameraSpec, NoiseKind, ResolvedCamera};
use scene_gen::optics::{self, OpticsInput, OpticsPlan};
use scene_gen::radiometry::capture_frame;
use scene_gen::render::Camera;
use scene_gen::sensor::Catalog;

const W: u32 = 640;

/// A benchmark case: name, pixel pitch (um), spec edit, camera velocity.
type Case = (&'static str, f32, Box<dyn Fn(&mut CameraSpec)>, Vec3);
const H: u32 = 480;

fn camera(pitch_um: f32, edit: impl FnOnce(&mut CameraSpec)) -> (ResolvedCamera, Camera) {
    let mut spec = CameraSpec { diffraction: false, noise: NoiseKind::Emva, ..CameraSpec::new("IMX174") };
    edit(&mut spec);
    let mut r = spec.resolve(&Catalog::embedded()).expect("catalog sensor");
    r.width_px = W;
    r.height_px = H;
    r.pixel_pitch_um = pitch_um;
    r.bin_factor = 1.0;
    let cam = r.camera(Vec3::new(0.0, 0.0, 0.8), 0.0);
    (r, cam)
}

fn median_ms(repeats: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..repeats)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn main() {
    let repeats: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(15);
    let n = (W * H) as usize;
    let image: Vec<f32> =
        (0..n).map(|i| (100 + (i * 7919) % 251 + if (i / 13) % 2 == 0 { 400 } else { 0 }) as f32).collect();
    let depth: Vec<f32> = (0..n).map(|i| 6.0 - 5.5 * (i / W as usize) as f32 / H as f32).collect();
    let radiance: Vec<[f32; 3]> = image.iter().map(|&v| [v * 0.01; 3]).collect();
    let walk = Vec3::X * 0.5;

    println!("{W} x {H} frame, median of {repeats} runs, one thread");
    let cases: Vec<Case> = vec![
        (
            "diffraction f/2.8, 1.12 um pixels",
            1.12,
            Box::new(|s| {
                s.diffraction = true;
                s.f_number = 2.8;
            }),
            Vec3::ZERO,
        ),
        (
            "diffraction f/8, 1.12 um pixels",
            1.12,
            Box::new(|s| {
                s.diffraction = true;
                s.f_number = 8.0;
            }),
            Vec3::ZERO,
        ),
        ("diffraction f/2, 5.86 um pixels (skipped)", 5.86, Box::new(|s| s.diffraction = true), Vec3::ZERO),
        ("defocus 4 mm f/2, hyperfocal", 5.86, Box::new(|s| s.defocus = true), Vec3::ZERO),
        (
            "defocus 8 mm f/1.4, focus 1 m",
            5.86,
            Box::new(|s| {
                s.defocus = true;
                s.focal_mm = 8.0;
                s.f_number = 1.4;
                s.focus_m = Some(1.0);
            }),
            Vec3::ZERO,
        ),
        ("motion 0.5 m/s, 1/30 s", 5.86, Box::new(|s| s.motion_blur = true), walk),
        ("motion 2 m/s, 1/30 s", 5.86, Box::new(|s| s.motion_blur = true), walk * 4.0),
    ];
    for (name, pitch, edit, velocity) in &cases {
        let (r, cam) = camera(*pitch, edit);
        let input = OpticsInput { depth_m: &depth, velocity_m_s: *velocity };
        let plan = OpticsPlan::new(&r, &cam, Some(&input));
        let mut out = image.clone();
        let ms = median_ms(repeats, || {
            out.copy_from_slice(&image);
            optics::apply_plan(&plan, &cam, &mut out, Some(&input));
        });
        println!("{name:<44} {ms:8.2} ms");
    }

    let (plain, cam) = camera(5.86, |_| {});
    let input = OpticsInput { depth_m: &depth, velocity_m_s: walk };
    let ms = median_ms(repeats, || {
        std::hint::black_box(capture_frame(&plain, &cam, &radiance, Some(input), 5.0, 1, 2));
    });
    println!("{:<44} {ms:8.2} ms", "capture (EMVA noise), every effect off");
    let (all, cam) = camera(5.86, |s| {
        s.diffraction = true;
        s.defocus = true;
        s.motion_blur = true;
    });
    let ms = median_ms(repeats, || {
        std::hint::black_box(capture_frame(&all, &cam, &radiance, Some(input), 5.0, 1, 2));
    });
    println!("{:<44} {ms:8.2} ms", "capture (EMVA noise), every effect on");
}
