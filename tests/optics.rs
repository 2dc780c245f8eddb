//! Optics (src/optics.rs) on synthetic sensor-plane images, where the answer is known: energy
//! is conserved; a sharp edge blurs by the Airy/Gaussian width at two f-numbers; a plane at
//! the focus distance stays sharp and a plane off it blurs by the thin-lens circle of
//! confusion; forward motion leaves the focus of expansion sharp and streaks the periphery by
//! the projected length; results are deterministic. Then `scene-gen render`: bad optics
//! fields exit 2 naming the field, and a defocused render is softer with the same mean.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use glam::Vec3;
use scene_gen::camera_spec::{CameraSpec, NoiseKind, ResolvedCamera};
use scene_gen::optics::{self, OpticsInput};
use scene_gen::radiometry::{capture, capture_frame};
use scene_gen::render::Camera;
use scene_gen::sensor::Catalog;

mod common;
use common::{scene_gen, scratch};

/// A `w x h` camera looking along +X with every optical effect off unless `edit` turns it on;
/// pixel pitch forced to `pitch_um` (the physics only sees numbers).
fn camera(w: u32, h: u32, pitch_um: f32, edit: impl FnOnce(&mut CameraSpec)) -> (ResolvedCamera, Camera) {
    let mut spec = CameraSpec {
        vignetting: false,
        diffraction: false,
        noise: NoiseKind::Off,
        pitch_deg: 0.0,
        ..CameraSpec::new("IMX174")
    };
    edit(&mut spec);
    let mut r = spec.resolve(&Catalog::embedded()).unwrap();
    r.width_px = w;
    r.height_px = h;
    r.pixel_pitch_um = pitch_um;
    r.bin_factor = 1.0;
    let cam = r.camera(Vec3::new(0.0, 0.0, 1.0), 0.0);
    (r, cam)
}

/// Dark left half, bright right half; the edge on a pixel boundary.
fn edge(w: usize, h: usize) -> Vec<f32> {
    (0..w * h).map(|i| if i % w >= w / 2 { 100.0 } else { 0.0 }).collect()
}

/// Standard deviation (pixels) of the line-spread function measured on row `y` of a blurred
/// edge image: the differences of the edge profile, as weights of a distribution.
fn lsf_std(img: &[f32], w: usize, y: usize) -> f64 {
    let row: Vec<f64> = img[y * w..(y + 1) * w].iter().map(|&v| f64::from(v)).collect();
    let d: Vec<f64> = row.windows(2).map(|p| p[1] - p[0]).collect();
    let sum: f64 = d.iter().sum();
    let mean: f64 = d.iter().enumerate().map(|(i, v)| i as f64 * v).sum::<f64>() / sum;
    (d.iter().enumerate().map(|(i, v)| v * (i as f64 - mean).powi(2)).sum::<f64>() / sum).sqrt()
}

fn total(img: &[f32]) -> f64 {
    img.iter().map(|&v| f64::from(v)).sum()
}

#[test]
fn diffraction_edge_width_matches_the_airy_gaussian() {
    let (w, h) = (96, 24);
    let mut widths = Vec::new();
    for n in [4.0f32, 8.0] {
        // 1 um pixels so that diffraction is several pixels wide.
        let (r, cam) = camera(w as u32, h as u32, 1.0, |s| {
            s.diffraction = true;
            s.f_number = n;
        });
        let mut img = edge(w, h);
        optics::apply(&r, &cam, &mut img, None);
        let measured = lsf_std(&img, w, h / 2);
        // sigma = 0.42 lambda N at 550 nm, in 1 um pixels; plus the pixel's own box (1/12 px^2).
        let sigma = 0.42 * 0.55 * f64::from(n);
        let predicted = (sigma * sigma + 1.0 / 12.0).sqrt();
        eprintln!("diffraction f/{n}: LSF std measured {measured:.4} px, predicted {predicted:.4} px");
        assert!(
            (measured / predicted - 1.0).abs() < 0.10,
            "f/{n}: measured {measured:.3} px, predicted {predicted:.3}"
        );
        // The Airy first zero (1.22 lambda N) lies about 2.9 sigma out: the blur is inside it.
        assert!((optics::airy_first_zero_um(f64::from(n)) / sigma - 2.905).abs() < 0.01);
        widths.push(measured);
    }
    assert!(widths[1] > 1.8 * widths[0], "blur must grow with N: {widths:?}");

    // 5.86 um pixels at f/2: the PSF (sigma 0.08 px) is far below a pixel, the image is unchanged.
    let (r, cam) = camera(w as u32, h as u32, 5.86, |s| s.diffraction = true);
    let mut img = edge(w, h);
    optics::apply(&r, &cam, &mut img, None);
    assert_eq!(img, edge(w, h));
}

/// A fronto-parallel plane at depth `z` behind the edge image, with defocus on.
fn defocused_edge(z: f32, focus_m: f32) -> (Vec<f32>, f64) {
    let (w, h) = (160, 48);
    let (r, cam) = camera(w as u32, h as u32, 5.86, |s| {
        s.defocus = true;
        s.focus_m = Some(focus_m);
        s.focal_mm = 8.0;
        s.f_number = 2.0;
    });
    let depth = vec![z; w * h];
    let mut img = edge(w, h);
    let input = OpticsInput { depth_m: &depth, velocity_m_s: Vec3::ZERO };
    optics::apply(&r, &cam, &mut img, Some(&input));
    let c_px = optics::coc_diameter_m(8e-3, 2.0, f64::from(focus_m), f64::from(z)) / 5.86e-6;
    (img, c_px)
}

#[test]
fn defocus_in_focus_plane_is_sharp_and_off_plane_gets_the_thin_lens_coc() {
    let (img, c) = defocused_edge(1.0, 1.0);
    assert_eq!(c, 0.0);
    assert_eq!(img, edge(160, 48), "the plane at the focus distance must be unchanged");

    // In front of and behind the focus: a pillbox of diameter d has an LSF variance d^2/16
    // (plus the pixel box 1/12), so d = 4 sqrt(var - 1/12).
    for (z, expect_px) in [(0.3f32, 12.8), (0.5, 5.5), (4.0, 4.1)] {
        let (img, c) = defocused_edge(z, 1.0);
        assert!((c / expect_px - 1.0).abs() < 0.05, "z {z}: CoC {c:.2} px (hand figure {expect_px})");
        let s = lsf_std(&img, 160, 24);
        let measured = 4.0 * (s * s - 1.0 / 12.0).sqrt();
        eprintln!("defocus z {z} m: CoC measured {measured:.3} px, thin lens {c:.3} px");
        assert!((measured / c - 1.0).abs() < 0.10, "z {z}: measured CoC {measured:.2} px, thin lens {c:.2}");
        assert!((total(&img) / total(&edge(160, 48)) - 1.0).abs() < 1e-5);
    }
}

/// The disc is round: a horizontal edge (spread across rows, where small discs are sampled by
/// sub-rows) blurs as much as a vertical one.
#[test]
fn defocus_disc_is_isotropic() {
    let (w, h) = (48, 160);
    let (r, cam) = camera(w as u32, h as u32, 5.86, |s| {
        s.defocus = true;
        s.focus_m = Some(1.0);
        s.focal_mm = 8.0;
    });
    for z in [0.5f32, 0.75, 4.0] {
        let depth = vec![z; w * h];
        let mut img: Vec<f32> = (0..w * h).map(|i| if i / w >= h / 2 { 100.0 } else { 0.0 }).collect();
        optics::apply(&r, &cam, &mut img, Some(&OpticsInput { depth_m: &depth, velocity_m_s: Vec3::ZERO }));
        // Column 24, read as a row of the transposed image.
        let col: Vec<f32> = (0..h).map(|y| img[y * w + w / 2]).collect();
        let s = lsf_std(&col, h, 0);
        let vertical = 4.0 * (s * s - 1.0 / 12.0).sqrt();
        let (img_v, c) = defocused_edge(z, 1.0);
        let sv = lsf_std(&img_v, 160, 24);
        let horizontal = 4.0 * (sv * sv - 1.0 / 12.0).sqrt();
        eprintln!(
            "defocus z {z} m: CoC across rows {vertical:.3} px, across columns {horizontal:.3}, thin lens {c:.3}"
        );
        assert!((vertical / horizontal - 1.0).abs() < 0.05, "z {z}: {vertical} vs {horizontal}");
    }
}

#[test]
fn defocus_default_focus_is_hyperfocal() {
    let (r, _) = camera(64, 48, 5.86, |s| s.defocus = true);
    let hf = optics::focus_distance_m(&r);
    // f = 4 mm, f/2, CoC = 2 real pixels of the IMX174 (5.86 um): 16e-6 / 23.44e-6 + 0.004.
    assert!((hf - (16e-6 / 23.44e-6 + 0.004)).abs() < 1e-6, "{hf}");
    // Everything from H/2 to infinity is within the 2-pixel CoC.
    for z in [hf / 2.0 + 1e-3, hf, 5.0, 1e6] {
        assert!(optics::coc_diameter_m(4e-3, 2.0, hf, z) <= 2.0 * 5.86e-6 * 1.0001, "z {z}");
    }
}

/// Point sources on a dark `w x h` background at 1 m, the camera moving forward 0.1 m during
/// the exposure (3 m/s for 1/30 s).
fn moving_points(w: usize, h: usize, speed: f32, points: &[(usize, usize)]) -> Vec<f32> {
    let (r, cam) = camera(w as u32, h as u32, 5.86, |s| {
        s.motion_blur = true;
        s.exposure_s = 1.0 / 30.0;
    });
    let mut img = vec![0f32; w * h];
    for &(x, y) in points {
        img[y * w + x] = 1000.0;
    }
    let depth = vec![1.0f32; w * h];
    // The camera looks along +X (yaw 0, pitch 0): forward motion is +X.
    let input = OpticsInput { depth_m: &depth, velocity_m_s: Vec3::X * speed };
    optics::apply(&r, &cam, &mut img, Some(&input));
    img
}

#[test]
fn motion_blur_streaks_radially_from_the_focus_of_expansion() {
    // Odd size: pixel (200, 100)'s centre is the principal point, the focus of expansion.
    let (w, h) = (401, 201);
    let points = [(200, 100), (380, 100)];
    let img = moving_points(w, h, 3.0, &points);
    assert!((img[100 * w + 200] - 1000.0).abs() < 1e-3, "FOE must stay sharp: {}", img[100 * w + 200]);

    // The peripheral point, 180 px right of the FOE at 1 m: it moves from 180 Z / (Z + 0.05)
    // to 180 Z / (Z - 0.05), a segment of 18.05 px along the row (radially).
    let predicted = 180.0 * (1.0 / 0.95 - 1.0 / 1.05);
    let row = &img[100 * w..101 * w];
    let mass: f64 = row[300..].iter().map(|&v| f64::from(v)).sum();
    assert!((mass / 1000.0 - 1.0).abs() < 1e-4, "the streak stays on its row: {mass}");
    let mean = row[300..].iter().enumerate().map(|(i, &v)| (300 + i) as f64 * f64::from(v)).sum::<f64>() / mass;
    let var =
        row[300..].iter().enumerate().map(|(i, &v)| f64::from(v) * ((300 + i) as f64 - mean).powi(2)).sum::<f64>()
            / mass;
    // A uniform segment of length L has variance L^2 / 12; bilinear splatting adds 1/6 px^2.
    let measured = (12.0 * (var - 1.0 / 6.0)).sqrt();
    eprintln!("motion: streak measured {measured:.3} px, predicted {predicted:.3} px");
    assert!((measured / predicted - 1.0).abs() < 0.10, "streak {measured:.2} px, predicted {predicted:.2}");
    assert!(mean > 380.0, "the streak leans outwards (expansion): centroid {mean}");

    // Zero speed is the identity; energy is conserved.
    let still = moving_points(w, h, 0.0, &points);
    let mut expected = vec![0f32; w * h];
    for &(x, y) in &points {
        expected[y * w + x] = 1000.0;
    }
    assert_eq!(still, expected);
    assert!((total(&img) / 2000.0 - 1.0).abs() < 1e-5);
}

/// A textured image with a 16-pixel dark border, and a depth ramp.
fn textured(w: usize, h: usize) -> (Vec<f32>, Vec<f32>) {
    let img = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if x < 16 || y < 16 || x >= w - 16 || y >= h - 16 {
                0.0
            } else {
                (50 + (x * 7 + y * 13) % 97 + if (x / 9 + y / 5) % 2 == 0 { 200 } else { 0 }) as f32
            }
        })
        .collect();
    let depth = (0..w * h).map(|i| 0.3 + 4.0 * (i % w) as f32 / w as f32).collect();
    (img, depth)
}

fn all_on(w: usize, h: usize, img: &mut [f32], depth: &[f32], velocity: Vec3) {
    let (r, cam) = camera(w as u32, h as u32, 1.4, |s| {
        s.diffraction = true;
        s.defocus = true;
        s.focus_m = Some(1.0);
        s.motion_blur = true;
        s.f_number = 5.6;
        s.pitch_deg = -10.0;
    });
    let input = OpticsInput { depth_m: depth, velocity_m_s: velocity };
    optics::apply(&r, &cam, img, Some(&input));
}

#[test]
fn every_effect_conserves_energy_and_is_deterministic() {
    let (w, h) = (120, 90);
    let (img, depth) = textured(w, h);
    let mut a = img.clone();
    all_on(w, h, &mut a, &depth, Vec3::new(1.5, 0.5, 0.0));
    let ratio = total(&a) / total(&img);
    eprintln!("energy: all effects, total ratio {ratio:.7}");
    assert!((ratio - 1.0).abs() < 0.005, "mean irradiance changed by {:.4} %", 100.0 * (ratio - 1.0));
    assert_ne!(a, img, "the effects must do something here");
    let mut b = img.clone();
    all_on(w, h, &mut b, &depth, Vec3::new(1.5, 0.5, 0.0));
    assert_eq!(a, b);

    // Mirrored borders keep the mean even where light reaches the frame edge (no dark border).
    let full: Vec<f32> = (0..w * h).map(|i| 10.0 + (i % 17) as f32).collect();
    let mut c = full.clone();
    all_on(w, h, &mut c, &depth, Vec3::new(1.5, 0.5, 0.0));
    assert!((total(&c) / total(&full) - 1.0).abs() < 1e-4);
}

#[test]
fn capture_frame_without_optics_matches_capture() {
    let (w, h) = (48, 32);
    let (r, cam) = camera(w, h, 5.86, |s| {
        s.defocus = true;
        s.motion_blur = true;
        s.vignetting = true;
    });
    let radiance: Vec<[f32; 3]> = (0..w * h).map(|i| [(i % 7) as f32, 3.0, 1.0]).collect();
    let depth = vec![2.0f32; (w * h) as usize];
    let plain = capture(&r, &cam, &radiance, 5.0, 1, 2);
    assert_eq!(plain, capture_frame(&r, &cam, &radiance, None, 5.0, 1, 2));
    let input = OpticsInput { depth_m: &depth, velocity_m_s: Vec3::ZERO };
    let with = capture_frame(&r, &cam, &radiance, Some(input), 5.0, 1, 2);
    // Hyperfocal focus of 4 mm f/2 on 5.86 um pixels is 0.69 m; a plane at 2 m gets a 1.3 px CoC.
    assert_ne!(plain, with, "defocus must act when the depth is given");
}

fn scene_json() -> &'static Path {
    static SCENE: OnceLock<PathBuf> = OnceLock::new();
    SCENE.get_or_init(|| {
        let dir = scratch("scene");
        let out = scene_gen(&["--seed", "3", "--out", dir.to_str().unwrap()]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        dir.join("scene.json")
    })
}

#[test]
fn bad_optics_fields_exit_2_naming_the_field() {
    for (camera, field) in [
        ("IMX174,focus_m=0.001", "focus_m"),
        ("IMX174,focal_mm=8,focus_m=0.008", "focus_m"),
        ("IMX174,focus_m=-1", "focus_m"),
        ("IMX174,motion_speed_m_s=-0.5", "motion_speed_m_s"),
        ("IMX174,motion_speed_m_s=nan", "motion_speed_m_s"),
        ("IMX174,f_number=0", "f_number"),
        ("IMX174,defocus=maybe", "defocus"),
        ("IMX174,diffraction=1", "diffraction"),
    ] {
        let dir = scratch(&format!("bad-{}", scene_gen::rng::fnv1a64(camera.as_bytes())));
        let out = scene_gen(&[
            "render",
            "--scene",
            scene_json().to_str().unwrap(),
            "--camera",
            camera,
            "--out",
            dir.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{camera}: {err}");
        assert!(err.contains(field), "{camera}: expected '{field}' in {err}");
        assert!(!dir.exists(), "{camera}: output written");
    }
}

fn render_grey(camera: &str, name: &str) -> Vec<f64> {
    let dir = scratch(name);
    let args = [
        "render",
        "--scene",
        scene_json().to_str().unwrap(),
        "--camera",
        camera,
        "--out",
        dir.to_str().unwrap(),
        "--max-width",
        "160",
        "--quality",
        "preview",
        "--lighting",
        "day",
        "--raw",
    ];
    let out = scene_gen(&args);
    assert!(out.status.success(), "{camera}: {}", String::from_utf8_lossy(&out.stderr));
    let img = image::open(dir.join("frame_0000_day_raw.png")).unwrap().into_luma16();
    img.into_raw().into_iter().map(f64::from).collect()
}

/// Sum of squared differences between horizontal neighbours of the same CFA colour (two pixels
/// apart on a Bayer mosaic): high-frequency energy.
fn gradient_energy(img: &[f64], w: usize) -> f64 {
    img.chunks(w).map(|row| row.windows(3).map(|p| (p[2] - p[0]).powi(2)).sum::<f64>()).sum()
}

#[test]
fn render_defocus_softens_and_keeps_the_mean() {
    let sharp = render_grey("IMX174,noise=off,focal_mm=8", "sharp");
    // Focused at 5 cm: the room, 1-5 m away, is some 10 binned pixels out of focus.
    let soft = render_grey("IMX174,noise=off,focal_mm=8,defocus=true,focus_m=0.05", "soft");
    let still = render_grey("IMX174,noise=off,focal_mm=8,motion_blur=true,motion_speed_m_s=0", "still");
    assert_eq!(sharp, still, "motion blur at zero speed is the identity");
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    eprintln!(
        "render: mean DN {:.2} sharp, {:.2} defocused; gradient energy ratio {:.3}",
        mean(&sharp),
        mean(&soft),
        gradient_energy(&soft, 160) / gradient_energy(&sharp, 160)
    );
    assert!((mean(&soft) / mean(&sharp) - 1.0).abs() < 0.01, "mean {} vs {}", mean(&soft), mean(&sharp));
    let (gs, gb) = (gradient_energy(&sharp, 160), gradient_energy(&soft, 160));
    assert!(gb < 0.5 * gs, "defocus must soften: gradient energy {gb} vs {gs}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Every effect, on any image, depth and motion, hands out exactly the light it receives
    /// (mirrored borders) and makes no negative irradiance.
    #[test]
    fn blurs_conserve_energy_for_any_input(
        w in 3usize..40,
        h in 3usize..30,
        seed in 0u64..1_000_000,
        sigma in 0.0f64..4.0,
        t in proptest::array::uniform3(-0.3f64..0.3),
    ) {
        let mut rng = seed;
        let mut next = move || {
            rng = rng.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        let img: Vec<f32> = (0..w * h).map(|_| 1000.0 * next()).collect();
        let diam: Vec<f32> = (0..w * h).map(|_| 30.0 * next()).collect();
        let depth: Vec<f32> = (0..w * h).map(|_| 0.2 + 5.0 * next()).collect();
        let before = total(&img);
        let mut a = img.clone();
        optics::pillbox_blur(&mut a, w, h, &diam);
        let mut b = img.clone();
        optics::gaussian_blur(&mut b, w, h, sigma);
        let mut c = img.clone();
        optics::motion_blur(&mut c, w, h, 50.0, &depth, t);
        for out in [&a, &b, &c] {
            proptest::prop_assert!((total(out) / before - 1.0).abs() < 1e-5);
            proptest::prop_assert!(out.iter().all(|&v| v >= -1e-3 * before as f32 / (w * h) as f32));
        }
    }
}
