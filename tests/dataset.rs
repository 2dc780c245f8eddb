//! `scene-gen dataset` as a user meets it: shards plus the merge give the bytes of one run,
//! a rerun writes nothing and a damaged run is repaired frame by frame, every annotation's
//! area, box and RLE agree with the instance mask PNG, and bad input exits 2 with nothing
//! written.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use std::time::SystemTime;

use scene_gen::dataset::{CocoInstances, Rle};

mod common;
use common::{scene_gen, scratch};

/// Tiny settings: two houses, two frames each, 96 px wide, one ray per pixel.
const ARGS: [&str; 10] =
    ["--seeds", "0..2", "--camera", "IMX174", "--frames", "2", "--max-width", "96", "--quality", "preview"];

fn text(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

fn dataset(out_dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["dataset", "--out", out_dir.to_str().unwrap()];
    args.extend_from_slice(&ARGS);
    args.extend_from_slice(extra);
    scene_gen(&args)
}

/// Every file under `dir`, by relative path.
fn tree(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(root, &path, out);
            } else {
                let rel = path.strip_prefix(root).unwrap().to_string_lossy().into_owned();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

fn mtimes(dir: &Path) -> BTreeMap<String, SystemTime> {
    tree(dir).into_keys().map(|k| (k.clone(), std::fs::metadata(dir.join(&k)).unwrap().modified().unwrap())).collect()
}

/// One single-machine run shared by the tests.
fn single() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = scratch("single");
        let out = dataset(&dir, &[]);
        assert!(out.status.success(), "{}", text(&out));
        assert!(text(&out).contains("4 frames of 96x60 (4 rendered, 0 already there)"), "{}", text(&out));
        dir
    })
}

fn coco(dir: &Path, lighting: &str) -> CocoInstances {
    let path = dir.join(format!("annotations/instances_{lighting}.json"));
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn shards_and_merge_equal_one_run() {
    let a = tree(single());
    let dir = scratch("shards");
    let first = dataset(&dir, &["--shard", "1/2"]);
    assert!(first.status.success(), "{}", text(&first));
    assert!(text(&first).contains("1 of 2 seeds still to do"), "{}", text(&first));
    assert!(!dir.join("annotations").exists(), "merged before every seed was done");
    // --merge before the last shard: refused as a failure (exit 1), nothing merged.
    let early = dataset(&dir, &["--merge"]);
    assert_eq!(early.status.code(), Some(1), "{}", text(&early));
    assert!(text(&early).contains("1 of 2 seeds have no fragment"), "{}", text(&early));
    // The last shard to finish merges.
    let last = dataset(&dir, &["--shard", "0/2"]);
    assert!(last.status.success(), "{}", text(&last));
    let b = tree(&dir);
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (k, v) in &a {
        assert!(b[k] == *v, "{k} differs between the single run and the shards");
    }
    // An explicit merge afterwards changes nothing.
    let merge = dataset(&dir, &["--merge"]);
    assert!(merge.status.success() && text(&merge).contains("up to date"), "{}", text(&merge));
    assert_eq!(tree(&dir), b);
}

#[test]
fn concurrent_shards_equal_one_run() {
    let a = tree(single());
    let dir = scratch("concurrent");
    let spawn = |shard: &str| {
        let mut args = vec!["dataset", "--out", dir.to_str().unwrap(), "--shard", shard];
        args.extend_from_slice(&ARGS);
        Command::new(env!("CARGO_BIN_EXE_scene-gen")).args(&args).output()
    };
    // Both shards at once into one folder: both write dataset.json, one or both merge.
    let (x, y) = std::thread::scope(|s| {
        let x = s.spawn(|| spawn("0/2").expect("runs"));
        let y = s.spawn(|| spawn("1/2").expect("runs"));
        (x.join().unwrap(), y.join().unwrap())
    });
    assert!(x.status.success() && y.status.success(), "{}\n{}", text(&x), text(&y));
    assert_eq!(tree(&dir), a, "concurrent shards differ from the single run");
}

#[test]
fn rerun_skips_and_repairs() {
    let dir = scratch("rerun");
    let out = dataset(&dir, &["--lighting", "night"]);
    assert!(out.status.success(), "{}", text(&out));
    let before_bytes = tree(&dir);
    let before = mtimes(&dir);
    let again = dataset(&dir, &["--lighting", "night"]);
    assert!(again.status.success(), "{}", text(&again));
    assert!(text(&again).contains("(0 rendered, 4 already there)"), "{}", text(&again));
    assert_eq!(mtimes(&dir), before, "a rerun rewrote files");
    // A killed run: one frame lost its mask, the seed its fragment and the merge its files.
    let seed_dir = "seed_0000000001";
    let mask = std::fs::read_dir(dir.join("masks").join(seed_dir)).unwrap().next().unwrap().unwrap().path();
    std::fs::remove_file(&mask).unwrap();
    std::fs::remove_file(dir.join(format!("fragments/{seed_dir}.json"))).unwrap();
    std::fs::remove_dir_all(dir.join("annotations")).unwrap();
    let repair = dataset(&dir, &["--lighting", "night"]);
    assert!(repair.status.success(), "{}", text(&repair));
    assert!(text(&repair).contains("(1 rendered, 3 already there)"), "{}", text(&repair));
    assert_eq!(tree(&dir), before_bytes, "the repaired dataset differs");
    // No temporary files are left behind.
    assert!(tree(&dir).keys().all(|k| !k.contains(".tmp")));
}

#[test]
fn annotations_agree_with_the_masks() {
    let dir = single();
    let day = coco(dir, "day");
    let night = coco(dir, "night");
    assert_eq!(day.images.len(), 4);
    assert!(day.annotations.len() >= 4, "too few objects to test: {}", day.annotations.len());
    let ids: Vec<u32> = day.categories.iter().map(|c| c.id).collect();
    assert_eq!(ids, (1..=11).collect::<Vec<_>>());
    // Night labels are the day labels on other image ids.
    assert_eq!(night.annotations.len(), day.annotations.len());
    for (d, n) in day.annotations.iter().zip(&night.annotations) {
        assert_eq!((d.instance_id, d.area, d.bbox), (n.instance_id, n.area, n.bbox));
        assert_ne!(d.image_id, n.image_id);
    }
    let mut ann_ids: Vec<u64> = day.annotations.iter().map(|a| a.id).collect();
    ann_ids.dedup();
    assert_eq!(ann_ids, (1..=day.annotations.len() as u64).collect::<Vec<_>>());
    for image in &day.images {
        let mask = image::open(dir.join(&image.mask_file)).unwrap().into_luma16();
        assert_eq!((mask.width(), mask.height()), (image.width, image.height));
        assert!(dir.join("images").join(&image.file_name).is_file());
        for a in day.annotations.iter().filter(|a| a.image_id == image.id) {
            assert!((1..=11).contains(&a.category_id));
            assert_eq!(a.iscrowd, 0);
            let pixels: Vec<(u32, u32)> =
                mask.enumerate_pixels().filter(|p| u32::from(p.2.0[0]) == a.instance_id).map(|p| (p.0, p.1)).collect();
            assert_eq!(a.area, pixels.len() as u64, "area of instance {}", a.instance_id);
            let [x, y, w, h] = a.bbox;
            assert!(pixels.iter().all(|&(px, py)| px >= x && px < x + w && py >= y && py < y + h));
            // Tight: every edge of the box touches a mask pixel.
            assert!(pixels.iter().any(|p| p.0 == x) && pixels.iter().any(|p| p.0 == x + w - 1));
            assert!(pixels.iter().any(|p| p.1 == y) && pixels.iter().any(|p| p.1 == y + h - 1));
            let [rh, rw] = a.segmentation.size;
            assert_eq!((rw, rh), (image.width, image.height));
            let rle = Rle::from_compressed(&a.segmentation.counts, rh, rw).unwrap();
            let decoded = rle.decode();
            for (px, py, v) in mask.enumerate_pixels() {
                let inside = u32::from(v.0[0]) == a.instance_id;
                assert_eq!(decoded[(py * rw + px) as usize], inside, "RLE of {} at ({px}, {py})", a.instance_id);
            }
        }
    }
}

fn refused(args: &[&str], needle: &str) {
    let dir = scratch(&format!("bad-{}", scene_gen::rng::fnv1a64(args.join(" ").as_bytes())));
    let mut all = vec!["dataset", "--out", dir.to_str().unwrap()];
    all.extend_from_slice(args);
    let out = scene_gen(&all);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {}", text(&out));
    assert!(text(&out).contains(needle), "{args:?}: expected '{needle}' in: {}", text(&out));
    assert!(!dir.exists(), "{args:?}: {} was created", dir.display());
}

#[test]
fn bad_input_exits_2_and_writes_nothing() {
    refused(&["--seeds", "0..2", "--camera", "IMX174", "--shard", "3/2"], "--shard '3/2'");
    refused(&["--seeds", "0..2", "--camera", "IMX174", "--shard", "0/0"], "--shard '0/0'");
    refused(&["--seeds", "5..2", "--camera", "IMX174"], "--seeds '5..2'");
    refused(&["--seeds", "x", "--camera", "IMX174"], "--seeds 'x'");
    refused(&["--seeds", "0..2", "--camera", "NOPE123"], "NOPE123");
    refused(&["--seeds", "0..2", "--camera", "IMX174,focal_mm=-1"], "focal_mm");
    refused(&["--seeds", "0..2", "--camera", "IMX174,height_m=2.6", "--envelope", "12x12x2.5"], "height_m");
    refused(&["--seeds", "0..2", "--camera", "IMX174", "--frames", "0"], "--frames");
    refused(&["--seeds", "0..2", "--camera", "IMX174", "--max-width", "0"], "--max-width");
    refused(&["--seeds", "0..2", "--camera", "IMX174", "--frames", "2", "--every", "3"], "--every");
}

#[test]
fn other_settings_in_the_same_folder_are_refused() {
    let dir = single();
    let before = mtimes(dir);
    let mut args = vec!["dataset", "--out", dir.to_str().unwrap()];
    args.extend_from_slice(&ARGS);
    args[6] = "IMX174,focal_mm=6";
    let out = scene_gen(&args);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("other settings"), "{}", text(&out));
    assert_eq!(mtimes(dir), before);
}

/// Every image carries `K` and a rigid camera-to-world pose at the camera's height, the
/// sequence's trajectory file repeats them in pose order, and back-projected depth stays inside
/// the house's envelope. (`tests/interop/check_depth_fusion.sh` checks the points against the
/// house's surfaces.)
#[test]
fn frames_carry_their_camera() {
    let dir = single();
    let json = |path: PathBuf| -> serde_json::Value { serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap() };
    let day = json(dir.join("annotations/instances_day.json"));
    let images = day["images"].as_array().unwrap();
    assert_eq!(images.len(), 4);
    for image in images {
        let k: [[f64; 3]; 3] = serde_json::from_value(image["K"].clone()).unwrap();
        let m: [[f64; 4]; 4] = serde_json::from_value(image["camera_to_world"].clone()).unwrap();
        let (w, h) = (image["width"].as_f64().unwrap(), image["height"].as_f64().unwrap());
        assert_eq!((k[0][2], k[1][2], k[2]), (w / 2.0 - 0.5, h / 2.0 - 0.5, [0.0, 0.0, 1.0]));
        assert!(k[0][0] > 0.0 && k[0][0] == k[1][1], "square pixels: {k:?}");
        for a in 0..3 {
            for b in 0..3 {
                let dot: f64 = (0..3).map(|r| m[r][a] * m[r][b]).sum();
                assert!((dot - f64::from(u8::from(a == b))).abs() < 1e-6, "rotation not orthonormal: {m:?}");
            }
        }
        assert!((m[2][3] - 0.8).abs() < 1e-6 && m[3] == [0.0, 0.0, 0.0, 1.0], "camera at 0.8 m: {m:?}");
        assert!(image["exposure_s"].as_f64().unwrap() > 0.0 && image["gain_db"].is_number(), "{image}");

        let depth = image::open(dir.join(image["depth_file"].as_str().unwrap())).unwrap().into_luma16();
        let mut inside = 0;
        for (u, v, px) in depth.enumerate_pixels().filter(|(_, _, p)| p.0[0] > 0) {
            let z = f64::from(px.0[0]) / 1000.0;
            let cam = [(f64::from(u) - k[0][2]) / k[0][0] * z, (f64::from(v) - k[1][2]) / k[1][1] * z, z];
            let p: Vec<f64> =
                (0..3).map(|r| m[r][0] * cam[0] + m[r][1] * cam[1] + m[r][2] * cam[2] + m[r][3]).collect();
            // The outer walls (0.1 m thick) are centred on the envelope; window reveals lie in them.
            let (lo, hi) = (-0.06, 15.06);
            assert!(
                (lo..=hi).contains(&p[0]) && (lo..=hi).contains(&p[1]) && (-0.06..=3.06).contains(&p[2]),
                "{}: pixel ({u}, {v}) lands outside the 15 x 15 x 3 m house and its walls at {p:?}",
                image["file_name"]
            );
            inside += 1;
        }
        assert!(inside > 100, "{}: {inside} depth pixels", image["file_name"]);
    }
    for seed in [0, 1] {
        let trajectory = json(dir.join(format!("trajectories/seed_{seed:010}.json")));
        let frames = trajectory["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 2);
        for frame in frames {
            let image = images
                .iter()
                .find(|i| i["seed"] == seed && i["pose"] == frame["pose"])
                .unwrap_or_else(|| panic!("seed {seed}: no image of pose {}", frame["pose"]));
            assert_eq!(frame["camera_to_world"], image["camera_to_world"]);
            assert_eq!(frame["K"], image["K"]);
        }
        assert!(frames[0]["time_s"].as_f64().unwrap() < frames[1]["time_s"].as_f64().unwrap());
    }
}

/// The class PNG marks exactly the pixels the instance mask marks, with each annotated
/// instance's category; the normals PNG holds unit normals facing the camera where there is
/// depth and zeros where there is none.
#[test]
fn class_masks_and_normals_agree_with_the_frame() {
    let dir = single();
    let day = coco(dir, "day");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("annotations/instances_day.json")).unwrap()).unwrap();
    for (image, entry) in day.images.iter().zip(json["images"].as_array().unwrap()) {
        let classes = image::open(dir.join(&image.class_file)).unwrap();
        assert!(matches!(classes, image::DynamicImage::ImageLuma8(_)), "{}: 8-bit grey", image.class_file);
        let classes = classes.into_luma8();
        let masks = image::open(dir.join(&image.mask_file)).unwrap().into_luma16();
        let depth = image::open(dir.join(&image.depth_file)).unwrap().into_luma16();
        let normals = image::open(dir.join(&image.normal_file)).unwrap();
        assert!(matches!(normals, image::DynamicImage::ImageRgb16(_)), "{}: 16-bit RGB", image.normal_file);
        let normals = normals.into_rgb16();
        for a in day.annotations.iter().filter(|a| a.image_id == image.id) {
            let class = masks.pixels().zip(classes.pixels()).find(|(m, _)| u32::from(m.0[0]) == a.instance_id);
            assert_eq!(class.map(|(_, c)| u32::from(c.0[0])), Some(a.category_id), "instance {}", a.instance_id);
        }
        let m: [[f64; 4]; 4] = serde_json::from_value(entry["camera_to_world"].clone()).unwrap();
        let k: [[f64; 3]; 3] = serde_json::from_value(entry["K"].clone()).unwrap();
        let (mut facing, mut hits) = (0, 0);
        for (u, v, n) in normals.enumerate_pixels() {
            let (instance, class) = (masks.get_pixel(u, v).0[0], classes.get_pixel(u, v).0[0]);
            assert_eq!(
                instance > 0,
                class > 0,
                "{}: pixel ({u}, {v}) instance {instance}, class {class}",
                image.file_name
            );
            let decoded = n.0.map(|c| f64::from(c) / 65535.0 * 2.0 - 1.0);
            if depth.get_pixel(u, v).0[0] == 0 {
                assert_eq!(n.0, [0; 3], "{}: a normal where nothing is hit", image.file_name);
                continue;
            }
            let length = decoded.iter().map(|c| c * c).sum::<f64>().sqrt();
            assert!((length - 1.0).abs() < 1e-3, "{}: |n| = {length} at ({u}, {v})", image.file_name);
            // The view ray of the pixel in the world; a normal facing the camera opposes it.
            let cam = [(f64::from(u) - k[0][2]) / k[0][0], (f64::from(v) - k[1][2]) / k[1][1], 1.0];
            let ray: Vec<f64> = (0..3).map(|r| (0..3).map(|c| m[r][c] * cam[c]).sum()).collect();
            hits += 1;
            if (0..3).map(|i| decoded[i] * ray[i]).sum::<f64>() < 0.0 {
                facing += 1;
            }
        }
        // Shading normals are interpolated, so at grazing angles a few may lean past the view ray.
        assert!(
            hits > 100 && facing * 100 >= hits * 99,
            "{}: {facing} of {hits} normals face the camera",
            image.file_name
        );
    }
}

/// The `evaluator` preset shades at anchors: its images are rendered anew (not one byte like
/// `preview`'s) but as bright within a few per cent, and everything traced at every pixel
/// (depth, masks, classes, normals, the COCO files) is `preview`'s to the byte.
#[test]
fn evaluator_quality_changes_the_light_only() {
    let preview = single();
    let dir = scratch("evaluator");
    let mut args = vec!["dataset", "--out", dir.to_str().unwrap()];
    args.extend_from_slice(&ARGS);
    *args.last_mut().unwrap() = "evaluator";
    let out = scene_gen(&args);
    assert!(out.status.success(), "{}", text(&out));
    let (ours, theirs) = (tree(&dir), tree(preview));
    assert_eq!(ours.keys().collect::<Vec<_>>(), theirs.keys().collect::<Vec<_>>());
    let mut images = 0;
    for (rel, bytes) in &ours {
        if rel.starts_with("images/") {
            let mean = |b: &[u8]| {
                let img = image::load_from_memory(b).unwrap().into_rgb8();
                img.as_raw().iter().map(|&v| f64::from(v)).sum::<f64>() / img.as_raw().len() as f64
            };
            let (a, b) = (mean(bytes), mean(&theirs[rel]));
            assert_ne!(bytes, &theirs[rel], "{rel}: the same bytes as preview");
            assert!((a / b - 1.0).abs() < 0.05, "{rel}: mean {a:.1} against preview's {b:.1}");
            images += 1;
        } else if ["depth/", "masks/", "classes/", "normals/", "annotations/"].iter().any(|d| rel.starts_with(d)) {
            assert_eq!(bytes, &theirs[rel], "{rel}");
        }
    }
    assert_eq!(images, 8, "two houses, two frames, day and night");
    let spec: serde_json::Value = serde_json::from_slice(&ours["dataset.json"]).unwrap();
    assert_eq!(spec["quality"], "evaluator");
}
