//! `scene-gen orb IMAGE` and `scene-gen match IMAGE_A IMAGE_B`: OpenCV-compatible ORB features
//! and cross-checked, RANSAC-verified matches, for scripts and the interop check.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use scene_gen::orb::{FundamentalRansac, KeyPoint, Orb, match_and_verify};
use serde_json::json;

use super::{CliError, bad_input, failure};

#[derive(Args, Debug)]
pub struct OrbArgs {
    /// Image file (PNG or TIFF; colour is converted to grey with OpenCV's weights).
    pub image: PathBuf,
    /// Number of features to keep (OpenCV's nfeatures).
    #[arg(long, default_value_t = 500)]
    pub features: usize,
    /// Print keypoints and descriptors as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct MatchArgs {
    /// First image (queries).
    pub image_a: PathBuf,
    /// Second image (train set).
    pub image_b: PathBuf,
    /// Number of features per image.
    #[arg(long, default_value_t = 500)]
    pub features: usize,
    /// RANSAC seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Print matches and inlier flags as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Loads an image as 8-bit grey; colour uses OpenCV's cvtColor RGB2GRAY fixed-point weights
/// (0.299, 0.587, 0.114 in Q14: 4899, 9617, 1868).
fn load_gray(path: &Path) -> Result<image::GrayImage, CliError> {
    let img = image::open(path).with_context(|| format!("cannot read image {}", path.display())).map_err(bad_input)?;
    Ok(match img {
        image::DynamicImage::ImageLuma8(g) => g,
        other => {
            let rgb = other.to_rgb8();
            image::GrayImage::from_fn(rgb.width(), rgb.height(), |x, y| {
                let [r, g, b] = rgb.get_pixel(x, y).0;
                let v = (u32::from(r) * 4899 + u32::from(g) * 9617 + u32::from(b) * 1868 + (1 << 13)) >> 14;
                image::Luma([v.min(255) as u8])
            })
        }
    })
}

/// An image with its keypoints and descriptors.
type Detected = (image::GrayImage, Vec<KeyPoint>, Vec<[u8; 32]>);

fn detect(path: &Path, features: usize) -> Result<Detected, CliError> {
    let img = load_gray(path)?;
    let (k, d) = Orb::with_features(features)
        .detect_and_compute(&img)
        .with_context(|| format!("ORB on {}", path.display()))
        .map_err(failure)?;
    Ok((img, k, d))
}

/// Writes `text` and a newline to stdout; a closed pipe (`| head`) ends the output quietly.
fn emit(text: &str) -> Result<(), CliError> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.write_all(b"\n")).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(failure(anyhow::Error::new(e).context("writing to stdout")))
        }
        _ => Ok(()),
    }
}

fn hex(d: &[u8; 32]) -> String {
    d.iter().map(|b| format!("{b:02x}")).collect()
}

pub fn run_orb(args: &OrbArgs) -> Result<(), CliError> {
    let (img, keypoints, descriptors) = detect(&args.image, args.features)?;
    if args.json {
        let kps: Vec<_> = keypoints
            .iter()
            .map(|k| {
                json!({"x": k.x, "y": k.y, "size": k.size, "angle": k.angle_deg, "response": k.response, "octave": k.octave})
            })
            .collect();
        let descs: Vec<String> = descriptors.iter().map(hex).collect();
        let out = json!({"width": img.width(), "height": img.height(), "keypoints": kps, "descriptors": descs});
        emit(&out.to_string())
    } else {
        let mut per_octave = std::collections::BTreeMap::new();
        for k in &keypoints {
            *per_octave.entry(k.octave).or_insert(0usize) += 1;
        }
        let mut text =
            format!("{}: {}x{}, {} keypoints", args.image.display(), img.width(), img.height(), keypoints.len());
        for (o, n) in per_octave {
            text.push_str(&format!("\n  octave {o}: {n}"));
        }
        emit(&text)
    }
}

pub fn run_match(args: &MatchArgs) -> Result<(), CliError> {
    let (_, ka, da) = detect(&args.image_a, args.features)?;
    let (_, kb, db) = detect(&args.image_b, args.features)?;
    let ransac = FundamentalRansac { seed: args.seed, ..FundamentalRansac::default() };
    let (matches, inliers) = match_and_verify(&ka, &da, &kb, &db, &ransac);
    let n_inliers = inliers.iter().filter(|&&b| b).count();
    if args.json {
        let out = json!({
            "keypoints_a": ka.len(),
            "keypoints_b": kb.len(),
            "matches": matches,
            "inliers": inliers,
            "n_matches": matches.len(),
            "n_inliers": n_inliers,
        });
        emit(&out.to_string())
    } else {
        emit(&format!(
            "{} keypoints in {}, {} in {}: {} cross-checked matches, {} RANSAC inliers",
            ka.len(),
            args.image_a.display(),
            kb.len(),
            args.image_b.display(),
            matches.len(),
            n_inliers
        ))
    }
}
