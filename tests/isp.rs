//! `scene-gen isp`: a raw mosaic developed to sRGB, and bad input refused with exit 2 and no
//! output.

mod common;

use common::{scene_gen, scratch};

/// Writes a one-channel PNG of `values` (8- or 16-bit).
fn write_raw(path: &std::path::Path, width: u32, values: &[u16], sixteen: bool) {
    let height = values.len() as u32 / width;
    if sixteen {
        image::ImageBuffer::<image::Luma<u16>, _>::from_raw(width, height, values.to_vec())
            .unwrap()
            .save(path)
            .unwrap();
    } else {
        let bytes: Vec<u8> = values.iter().map(|&v| v as u8).collect();
        image::GrayImage::from_raw(width, height, bytes).unwrap().save(path).unwrap();
    }
}

fn srgb8(linear: f64) -> u8 {
    let v = if linear <= 0.003_130_8 { 12.92 * linear } else { 1.055 * linear.powf(1.0 / 2.4) - 0.055 };
    (v * 255.0).round() as u8
}

#[test]
fn a_flat_raw_develops_to_its_white_balanced_grey() {
    let dir = scratch("flat");
    std::fs::create_dir_all(&dir).unwrap();
    // A 12-bit GRBG raw of a grey card under warm light: G 1064, R 2064, B 564 over black 64.
    let (w, h) = (10u32, 6u32);
    let values: Vec<u16> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            match (y % 2, x % 2) {
                (0, 1) => 2064,
                (1, 0) => 564,
                _ => 1064,
            }
        })
        .collect();
    let raw = dir.join("raw.png");
    write_raw(&raw, w, &values, true);
    let out = dir.join("rgb.png");
    let run = |extra: &[&str]| {
        let mut args = vec!["isp", raw.to_str().unwrap(), "--pattern", "GRBG", "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        scene_gen(&args)
    };
    let done = run(&["--bits", "12", "--black-level", "64", "--wb", "0.5,1,2"]);
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    let rgb = image::open(&out).unwrap().to_rgb8();
    assert_eq!(rgb.dimensions(), (w, h));
    let grey = srgb8(1000.0 / 4031.0);
    assert!(rgb.pixels().all(|p| p.0 == [grey, grey, grey]), "{:?} vs {grey}", rgb.get_pixel(3, 3));

    // Without white balance the card keeps its cast: red above green above blue.
    assert!(run(&["--bits", "12", "--black-level", "64"]).status.success());
    let [r, g, b] = image::open(&out).unwrap().to_rgb8().get_pixel(4, 2).0;
    assert!(r > g && g > b, "{r} {g} {b}");
}

#[test]
fn bad_input_is_refused_with_exit_2_and_nothing_written() {
    let dir = scratch("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let raw8 = dir.join("raw8.png");
    write_raw(&raw8, 4, &[10; 16], false);
    let colour = dir.join("colour.png");
    image::RgbImage::new(4, 4).save(&colour).unwrap();
    let out = dir.join("out.png");
    let missing = dir.join("missing.png");
    let o = out.to_str().unwrap();
    let cases: [(Vec<&str>, &str); 7] = [
        (vec!["isp", raw8.to_str().unwrap(), "--pattern", "RGBG", "--out", o], "RGBG"),
        (vec!["isp", raw8.to_str().unwrap(), "--pattern", "RGGB", "--demosaic", "nearest", "--out", o], "nearest"),
        (vec!["isp", colour.to_str().unwrap(), "--pattern", "RGGB", "--out", o], "one channel"),
        (vec!["isp", raw8.to_str().unwrap(), "--pattern", "RGGB", "--bits", "12", "--out", o], "--bits 12"),
        (vec!["isp", raw8.to_str().unwrap(), "--pattern", "RGGB", "--black-level", "300", "--out", o], "white level"),
        (vec!["isp", raw8.to_str().unwrap(), "--pattern", "RGGB", "--wb", "1,0,1", "--out", o], "white balance"),
        (vec!["isp", missing.to_str().unwrap(), "--pattern", "RGGB", "--out", o], "missing.png"),
    ];
    for (args, words) in cases {
        let done = scene_gen(&args);
        let stderr = String::from_utf8_lossy(&done.stderr);
        assert_eq!(done.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(words), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?} wrote output");
    }
}
