//! `scene-gen render` as a user meets it: bad camera specs refused (exit 2, the field named,
//! nothing written), the files of a small render with their sizes and bit depths, sidecars that
//! agree with the images, night darker and relatively noisier than day, and determinism.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;

mod common;
use common::{scene_gen, scratch};

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// One generated house (seed 3) shared by the tests.
fn scene_json() -> &'static Path {
    static SCENE: OnceLock<PathBuf> = OnceLock::new();
    SCENE.get_or_init(|| {
        let dir = scratch("scene");
        let out = scene_gen(&["--seed", "3", "--out", dir.to_str().unwrap()]);
        assert!(out.status.success(), "{}", stderr(&out));
        dir.join("scene.json")
    })
}

fn render(camera: &str, out_dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        "--scene",
        scene_json().to_str().unwrap(),
        "--camera",
        camera,
        "--out",
        out_dir.to_str().unwrap(),
        "--max-width",
        "160",
        "--quality",
        "preview",
    ];
    args.extend_from_slice(extra);
    scene_gen(&args)
}

fn refused(camera: &str, scene: Option<&str>, needle: &str) {
    let dir = scratch(&format!("bad-{}", scene_gen::rng::fnv1a64(camera.as_bytes())));
    let scene = scene.map_or_else(|| scene_json().to_str().unwrap().to_string(), str::to_string);
    let out = scene_gen(&["render", "--scene", &scene, "--camera", camera, "--out", dir.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{camera}: {}", stderr(&out));
    assert!(stderr(&out).contains(needle), "{camera}: expected '{needle}' in: {}", stderr(&out));
    assert!(!dir.exists(), "{camera}: {} was created", dir.display());
}

#[test]
fn bad_inputs_exit_2_and_write_nothing() {
    refused("IMX17,focal_mm=4", None, "IMX174");
    refused("NOSUCHSENSOR", None, "unknown sensor 'NOSUCHSENSOR'");
    refused("IMX174,focal_mm=0", None, "focal_mm");
    refused("IMX174,focal_mm=-3", None, "focal_mm");
    refused("IMX174,focal_mm", None, "focal_mm");
    refused("IMX174,pitch_deg=abc", None, "pitch_deg");
    refused("IMX174,zoom=2", None, "zoom");
    refused("IMX174,height_m=3.2", None, "height_m");
    refused("IMX174", Some("/nonexistent/scene.json"), "/nonexistent/scene.json");
    let toml = scratch("cam-toml");
    std::fs::create_dir_all(&toml).unwrap();
    let file = toml.join("cam.toml");
    std::fs::write(&file, "sensor = \"IMX174\"\nfocal_mm = 4\nfocus = 2\n").unwrap();
    refused(file.to_str().unwrap(), None, "cam.toml:3");
    let _ = std::fs::remove_dir_all(toml);
}

fn read_png(path: &Path) -> image::DynamicImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// Values of a grey 8/16-bit or RGB8 image as f64.
fn values(img: &image::DynamicImage) -> Vec<f64> {
    match img {
        image::DynamicImage::ImageLuma16(b) => b.as_raw().iter().map(|&v| f64::from(v)).collect(),
        image::DynamicImage::ImageLuma8(b) => b.as_raw().iter().map(|&v| f64::from(v)).collect(),
        image::DynamicImage::ImageRgb8(b) => b.as_raw().iter().map(|&v| f64::from(v)).collect(),
        other => panic!("unexpected colour type {:?}", other.color()),
    }
}

fn mean_var(v: &[f64]) -> (f64, f64) {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (m, v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64)
}

#[test]
fn small_render_writes_consistent_files_deterministically() {
    let (a, b) = (scratch("small-a"), scratch("small-b"));
    for dir in [&a, &b] {
        let out = render("IMX174,focal_mm=4,pitch_deg=-10", dir, &["--raw"]);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let mut names: Vec<String> =
        std::fs::read_dir(&a).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    let expected = [
        "frame_0000_day.json",
        "frame_0000_day.png",
        "frame_0000_day_raw.png",
        "frame_0000_depth.png",
        "frame_0000_instances.png",
        "frame_0000_night.json",
        "frame_0000_night.png",
        "frame_0000_night_raw.png",
        "trajectory.json",
    ];
    assert_eq!(names, expected);
    for name in expected {
        assert_eq!(std::fs::read(a.join(name)).unwrap(), std::fs::read(b.join(name)).unwrap(), "{name} differs");
    }
    // IMX174 (1936 x 1216, 12 bit) binned to 160 px wide: 160 x 100 (1216 / 12.1 = 100.496, rounded).
    for name in
        ["frame_0000_day_raw.png", "frame_0000_night_raw.png", "frame_0000_depth.png", "frame_0000_instances.png"]
    {
        let img = read_png(&a.join(name));
        assert_eq!((img.width(), img.height()), (160, 100), "{name}");
        assert_eq!(img.color(), image::ColorType::L16, "{name}: 16-bit grey expected");
    }
    for lighting in ["day", "night"] {
        // The image opens as a normal photograph: 8-bit sRGB, mid-tones, colour.
        let img = read_png(&a.join(format!("frame_0000_{lighting}.png")));
        assert_eq!((img.width(), img.height(), img.color()), (160, 100, image::ColorType::Rgb8), "{lighting}");
        let rgb = img.into_rgb8();
        let (mean, _) = mean_var(&rgb.as_raw().iter().map(|&v| f64::from(v)).collect::<Vec<_>>());
        assert!((40.0..=200.0).contains(&mean), "{lighting}: 8-bit mean {mean}");
        let chroma = rgb.pixels().filter(|p| p.0.iter().max().unwrap() - p.0.iter().min().unwrap() > 12).count();
        assert!(chroma > rgb.len() / 30, "{lighting}: {chroma} coloured pixels of {}", rgb.len());
        let side = json(&a.join(format!("frame_0000_{lighting}.json")));
        assert_eq!(side["image_channels"], 3);
        assert_eq!(side["cfa_pattern"], "RGGB");
        assert_eq!(side["raw_file"], format!("frame_0000_{lighting}_raw.png"));
        let v = values(&read_png(&a.join(format!("frame_0000_{lighting}_raw.png"))));
        assert!(v.iter().all(|&x| x <= 4095.0), "{lighting}: values beyond 12 bits");
        let (m, var) = mean_var(&v);
        assert!((side["mean_dn"].as_f64().unwrap() - m).abs() < 1e-6, "{lighting}: sidecar mean vs {m}");
        assert!((side["variance_dn2"].as_f64().unwrap() - var).abs() < 1e-6 * var.max(1.0), "{lighting}: var");
        assert_eq!(side["bits"], 12);
        assert_eq!(side["width"], 160);
        let f = side["intrinsics"]["fx"].as_f64().unwrap();
        // fx = focal / binned pitch = 4 mm / (5.86 um x 12.1).
        assert!((f - 4000.0 / (5.86 * 12.1)).abs() < 1e-3, "fx {f}");
        let lux = side["plane_lux"].as_f64().unwrap();
        assert_eq!(lux, if lighting == "day" { 20.0 } else { 2.0 });
        assert_eq!(side["gain_db"].as_f64().unwrap(), if lighting == "day" { 5.0 } else { 15.0 });
    }
    let walk = json(&a.join("trajectory.json"));
    let first = &walk["poses"][0]["position"];
    let side = json(&a.join("frame_0000_day.json"));
    assert_eq!(first[0], side["pose"]["position"][0], "frame 0 is taken at the walk's first pose");
    assert!(!walk["crossings"].as_array().unwrap().is_empty(), "the walk passes doors");
    // Depth: some hits in range, in millimetres (the house is at most ~21 m across).
    let depth = values(&read_png(&a.join("frame_0000_depth.png")));
    let hits: Vec<f64> = depth.iter().copied().filter(|&d| d > 0.0).collect();
    assert!(hits.len() > depth.len() / 2, "most pixels see a surface");
    assert!(hits.iter().all(|&d| (50.0..=25_000.0).contains(&d)), "depth out of range");
    let _ = std::fs::remove_dir_all(a);
    let _ = std::fs::remove_dir_all(b);
}

/// Night (2 lux at 15 dB) against day (20 lux at 5 dB) on the same camera and view: less signal
/// above black, and more temporal noise relative to it. The noise is measured as the
/// difference between the EMVA image and the noiseless (`noise=off`) image of the same view.
#[test]
fn night_is_darker_and_relatively_noisier_than_day() {
    let (noisy, clean) = (scratch("dn-noisy"), scratch("dn-clean"));
    for (dir, noise) in [(&noisy, "emva"), (&clean, "off")] {
        let out = render(&format!("IMX174,focal_mm=4,noise={noise}"), dir, &["--raw"]);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let black = 4096.0 / 64.0;
    let mut stats = Vec::new();
    for lighting in ["day", "night"] {
        let n = values(&read_png(&noisy.join(format!("frame_0000_{lighting}_raw.png"))));
        let c = values(&read_png(&clean.join(format!("frame_0000_{lighting}_raw.png"))));
        let signal = mean_var(&c).0 - black;
        let diff: Vec<f64> = n.iter().zip(&c).map(|(a, b)| a - b).collect();
        let noise = mean_var(&diff).1.sqrt();
        stats.push((signal, noise / signal));
    }
    let ((day_signal, day_rel), (night_signal, night_rel)) = (stats[0], stats[1]);
    assert!(day_signal > 0.0 && night_signal > 0.0);
    assert!(night_signal < day_signal, "night {night_signal} DN vs day {day_signal} DN above black");
    assert!(night_rel > 1.5 * day_rel, "relative noise night {night_rel} vs day {day_rel}");
    let _ = std::fs::remove_dir_all(noisy);
    let _ = std::fs::remove_dir_all(clean);
}

#[test]
fn affine_noise_gives_rgb8_and_frames_follow_the_walk() {
    let dir = scratch("affine");
    let out = render("IMX174,noise=affine", &dir, &["--frames", "2", "--lighting", "night"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let img = read_png(&dir.join("frame_0001_night.png"));
    assert_eq!(img.color(), image::ColorType::Rgb8);
    assert!(!dir.join("frame_0000_day.png").exists(), "--lighting night writes no day frame");
    let (p0, p1) = (json(&dir.join("frame_0000_night.json")), json(&dir.join("frame_0001_night.json")));
    let pos = |v: &serde_json::Value| -> Vec<f64> {
        v["pose"]["position"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
    };
    let step = pos(&p0).iter().zip(pos(&p1)).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
    assert!(step > 0.2 && step <= 0.3, "consecutive frames {step} m apart");
    let _ = std::fs::remove_dir_all(dir);
}

/// Every file of a render folder but `trajectory.json`, by name.
fn frame_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap() != "trajectory.json")
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
        .collect();
    files.sort();
    files
}

/// `--poses` renders a given path: the walk's own poses given back give the walk's frames byte
/// for byte (JSON and CSV alike), a pose's height and pitch override the camera's, the render's
/// trajectory reads back, and bad files are refused with their line.
#[test]
fn given_poses_render_like_the_walk() {
    let camera = "IMX174,focal_mm=4,pitch_deg=-10";
    let walk = scratch("walk");
    let out = render(camera, &walk, &["--frames", "2", "--lighting", "day"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let trajectory = json(&walk.join("trajectory.json"));
    let first: Vec<serde_json::Value> = trajectory["poses"].as_array().unwrap()[..2].to_vec();
    let dir = scratch("poses-files");
    std::fs::create_dir_all(&dir).unwrap();
    let json_path = dir.join("poses.json");
    std::fs::write(&json_path, serde_json::json!({ "poses": first }).to_string()).unwrap();
    let mut csv = String::from("x,y,yaw_deg,time_s\n");
    for p in &first {
        let n = |v: &serde_json::Value| v.as_f64().unwrap() as f32;
        let q = &p["position"];
        csv.push_str(&format!("{},{},{},{}\n", n(&q[0]), n(&q[1]), n(&p["yaw_deg"]), n(&p["time_s"])));
    }
    let csv_path = dir.join("poses.csv");
    std::fs::write(&csv_path, csv).unwrap();
    for path in [&json_path, &csv_path] {
        let given = scratch(&format!("given-{}", path.extension().unwrap().to_string_lossy()));
        let out = render(camera, &given, &["--poses", path.to_str().unwrap(), "--lighting", "day"]);
        assert!(out.status.success(), "{}", stderr(&out));
        assert_eq!(frame_files(&given), frame_files(&walk), "{}", path.display());
        // The render's own trajectory of a given path reads back to the same frames.
        let again = scratch("again");
        let trajectory = given.join("trajectory.json");
        let out = render(camera, &again, &["--poses", trajectory.to_str().unwrap(), "--lighting", "day"]);
        assert!(out.status.success(), "{}", stderr(&out));
        assert_eq!(frame_files(&again), frame_files(&walk));
        let _ = std::fs::remove_dir_all(again);
        let _ = std::fs::remove_dir_all(given);
    }

    // A pose's own height and pitch.
    let p = &first[0];
    let csv = format!("x,y,z,yaw_deg,pitch_deg\n{},{},1.5,{},-30\n", p["position"][0], p["position"][1], p["yaw_deg"]);
    std::fs::write(&csv_path, csv).unwrap();
    let high = scratch("high");
    let out = render(camera, &high, &["--poses", csv_path.to_str().unwrap(), "--lighting", "day"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let sidecar = json(&high.join("frame_0000_day.json"));
    assert_eq!(
        (sidecar["pose"]["position"][2].as_f64(), sidecar["pose"]["pitch_deg"].as_f64()),
        (Some(1.5), Some(-30.0))
    );
    assert_eq!(sidecar["camera_to_world"][2][3].as_f64(), Some(1.5));
    assert_ne!(frame_files(&high), frame_files(&walk));

    // Bad files: the file and line named, nothing written.
    std::fs::write(&csv_path, "x,y,yaw_deg\n1,2,3\n1,2\n").unwrap();
    let bad = scratch("bad-poses");
    let out = render(camera, &bad, &["--poses", csv_path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("poses.csv: line 3: 2 values"), "{}", stderr(&out));
    let out = render(camera, &bad, &["--poses", json_path.to_str().unwrap(), "--frames", "2"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(!bad.exists());
    for d in [walk, dir, high] {
        let _ = std::fs::remove_dir_all(d);
    }
}
