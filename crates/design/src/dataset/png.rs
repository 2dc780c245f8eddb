//! PNG encodings of a rendered frame, shared by `scene-gen render` and `scene-gen dataset`.

use scene_gen_camera::capture::Image8;
use scene_gen_camera::radiometry::SensorImage;
use scene_gen_render::Frame;

/// A 16-bit grey PNG of row-major values.
///
/// # Panics
/// If `values.len() != width * height`.
#[must_use]
pub fn png_gray16(width: u32, height: u32, values: Vec<u16>) -> Vec<u8> {
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(width, height, values).expect("sizes match");
    encode(&image::DynamicImage::ImageLuma16(img))
}

fn encode(img: &image::DynamicImage) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).expect("PNG encoding into memory");
    out.into_inner()
}

/// The PNG of a raw sensor capture and its bit depth: RGB captures (the affine path) as 8-bit
/// RGB, grey captures and Bayer mosaics of at most 8 bits as 8-bit grey, deeper ones as 16-bit
/// grey holding the DN unscaled.
#[must_use]
pub fn capture_png(cap: &SensorImage) -> (Vec<u8>, u8) {
    let (w, h) = (cap.width, cap.height);
    if cap.channels == 3 {
        let bytes: Vec<u8> = cap.dn.iter().map(|&v| v.min(255) as u8).collect();
        let img = image::RgbImage::from_raw(w, h, bytes).expect("sizes match");
        (encode(&image::DynamicImage::ImageRgb8(img)), 8)
    } else if cap.bits <= 8 {
        let bytes: Vec<u8> = cap.dn.iter().map(|&v| v.min(255) as u8).collect();
        let img = image::GrayImage::from_raw(w, h, bytes).expect("sizes match");
        (encode(&image::DynamicImage::ImageLuma8(img)), 8)
    } else {
        (png_gray16(w, h, cap.dn.clone()), 16)
    }
}

/// The PNG of an ISP's 8-bit image: grey or sRGB.
#[must_use]
pub fn image_png(img: &Image8) -> Vec<u8> {
    let (w, h, bytes) = (img.width, img.height, img.bytes.clone());
    if img.channels == 3 {
        encode(&image::DynamicImage::ImageRgb8(image::RgbImage::from_raw(w, h, bytes).expect("sizes match")))
    } else {
        encode(&image::DynamicImage::ImageLuma8(image::GrayImage::from_raw(w, h, bytes).expect("sizes match")))
    }
}

/// 16-bit z-depth in millimetres; 0 = no hit or beyond 65.535 m.
#[must_use]
pub fn depth_png(frame: &Frame) -> Vec<u8> {
    let mm = frame
        .depth_m
        .iter()
        .map(|&d| {
            let v = (f64::from(d) * 1000.0).round();
            if v.is_finite() && v > 0.0 && v <= 65535.0 { v as u16 } else { 0 }
        })
        .collect();
    png_gray16(frame.width, frame.height, mm)
}

/// 8-bit COCO class ids (1..=10 objects, 11 threshold; 0 = none).
#[must_use]
pub fn classes_png(frame: &Frame) -> Vec<u8> {
    let ids: Vec<u8> = frame.class_id.iter().map(|&c| u8::try_from(c).unwrap_or(u8::MAX)).collect();
    let img = image::GrayImage::from_raw(frame.width, frame.height, ids).expect("sizes match");
    encode(&image::DynamicImage::ImageLuma8(img))
}

/// 16-bit RGB world-space unit normals facing the camera: each component `n` is stored as
/// `round((n + 1) / 2 * 65535)`; `(0, 0, 0)` where nothing is hit (no unit normal encodes so).
#[must_use]
pub fn normals_png(frame: &Frame) -> Vec<u8> {
    let encode_component = |n: f32| ((f64::from(n).clamp(-1.0, 1.0) + 1.0) * 0.5 * 65535.0).round() as u16;
    let values: Vec<u16> =
        frame.normal.iter().flat_map(|n| if *n == [0.0; 3] { [0; 3] } else { n.map(encode_component) }).collect();
    let img = image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(frame.width, frame.height, values)
        .expect("sizes match");
    encode(&image::DynamicImage::ImageRgb16(img))
}

/// 16-bit instance ids (0 = none).
#[must_use]
pub fn instances_png(frame: &Frame) -> Vec<u8> {
    let ids = frame.instance_id.iter().map(|&i| u16::try_from(i).unwrap_or(u16::MAX)).collect();
    png_gray16(frame.width, frame.height, ids)
}
