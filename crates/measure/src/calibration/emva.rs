//! EMVA 1288 descriptor files (releases 3 and 4) and their images.
//!
//! A descriptor is a text file of lines:
//!
//! ```text
//! v <release>                     optional
//! n <bits> <width> <height>       once, before any block
//! b <exposure_ns> <photons>       a bright block; its images follow
//! d <exposure_ns>                 a dark block; its images follow
//! i <image path>                  relative to the descriptor; '\' separators allowed
//! # comment                       comments and blank lines are ignored
//! ```
//!
//! A block of two images is a temporal pair; a block of more is a spatial stack.

use std::path::{Path, PathBuf};

/// A descriptor or one of its images could not be read.
#[derive(Debug, thiserror::Error)]
pub enum EmvaError {
    #[error("cannot read {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {message}", path.display())]
    Syntax { path: PathBuf, line: usize, message: String },
    #[error("image {}: {message}", path.display())]
    Image { path: PathBuf, message: String },
}

/// Bright (with its mean photons per pixel) or dark.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BlockKind {
    Bright { photons: f64 },
    Dark,
}

/// One `b` or `d` line and the images listed under it.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub kind: BlockKind,
    pub exposure_ns: f64,
    /// Image paths, resolved against the descriptor's folder.
    pub images: Vec<PathBuf>,
    /// Line of the `b`/`d` line in the descriptor.
    pub line: usize,
}

impl Block {
    #[must_use]
    pub fn exposure_s(&self) -> f64 {
        self.exposure_ns * 1e-9
    }
}

/// A parsed descriptor.
#[derive(Debug, Clone, PartialEq)]
pub struct Descriptor {
    pub path: PathBuf,
    pub release: Option<String>,
    pub bits: u32,
    pub width: u32,
    pub height: u32,
    pub blocks: Vec<Block>,
}

/// Reads and parses a descriptor file (images are not opened).
pub fn read_descriptor(path: &Path) -> Result<Descriptor, EmvaError> {
    let text = std::fs::read_to_string(path).map_err(|source| EmvaError::Io { path: path.to_path_buf(), source })?;
    parse_descriptor(&text, path)
}

/// Parses descriptor text; `path` names the file in errors and anchors relative image paths.
pub fn parse_descriptor(text: &str, path: &Path) -> Result<Descriptor, EmvaError> {
    let err = |line: usize, message: String| EmvaError::Syntax { path: path.to_path_buf(), line, message };
    let base = path.parent().unwrap_or(Path::new("."));
    let mut release = None;
    let mut geometry: Option<(u32, u32, u32)> = None;
    let mut blocks: Vec<Block> = Vec::new();
    for (idx, raw) in text.lines().enumerate() {
        let line_no = idx + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (tag, rest) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
        let fields: Vec<&str> = rest.split_whitespace().collect();
        let number = |s: &str, what: &str| -> Result<f64, EmvaError> {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| err(line_no, format!("expected {what} as a non-negative number, found '{s}'")))
        };
        match tag {
            "v" => {
                if fields.len() != 1 {
                    return Err(err(line_no, "expected 'v <release>'".into()));
                }
                release = Some(fields[0].to_string());
            }
            "n" => {
                if fields.len() != 3 {
                    return Err(err(line_no, "expected 'n <bits> <width> <height>'".into()));
                }
                if geometry.is_some() {
                    return Err(err(line_no, "a second 'n' line; expected one".into()));
                }
                let int = |s: &str, what: &str, max: u32| -> Result<u32, EmvaError> {
                    s.parse::<u32>()
                        .ok()
                        .filter(|v| (1..=max).contains(v))
                        .ok_or_else(|| err(line_no, format!("expected {what} as an integer 1..{max}, found '{s}'")))
                };
                geometry = Some((
                    int(fields[0], "bits", 16)?,
                    int(fields[1], "width", 1 << 16)?,
                    int(fields[2], "height", 1 << 16)?,
                ));
            }
            "b" | "d" => {
                if geometry.is_none() {
                    return Err(err(line_no, "expected the 'n <bits> <width> <height>' line before any block".into()));
                }
                let kind = if tag == "b" {
                    if fields.len() != 2 {
                        return Err(err(line_no, "expected 'b <exposure_ns> <photons>'".into()));
                    }
                    BlockKind::Bright { photons: number(fields[1], "photons per pixel")? }
                } else {
                    if fields.len() != 1 {
                        return Err(err(line_no, "expected 'd <exposure_ns>'".into()));
                    }
                    BlockKind::Dark
                };
                close_block(blocks.last(), &err)?;
                blocks.push(Block {
                    kind,
                    exposure_ns: number(fields[0], "exposure time in ns")?,
                    images: Vec::new(),
                    line: line_no,
                });
            }
            "i" => {
                if rest.trim().is_empty() {
                    return Err(err(line_no, "expected 'i <image path>'".into()));
                }
                let Some(block) = blocks.last_mut() else {
                    return Err(err(line_no, "image line before any 'b' or 'd' block".into()));
                };
                let rel: PathBuf = rest.trim().split(['\\', '/']).collect();
                block.images.push(base.join(rel));
            }
            other => {
                return Err(err(
                    line_no,
                    format!("unknown line type '{other}'; expected v, n, b, d, i or a # comment"),
                ));
            }
        }
    }
    close_block(blocks.last(), &err)?;
    let Some((bits, width, height)) = geometry else {
        return Err(err(text.lines().count().max(1), "no 'n <bits> <width> <height>' line".into()));
    };
    if blocks.is_empty() {
        return Err(err(text.lines().count().max(1), "no 'b' or 'd' block".into()));
    }
    Ok(Descriptor { path: path.to_path_buf(), release, bits, width, height, blocks })
}

fn close_block(block: Option<&Block>, err: &dyn Fn(usize, String) -> EmvaError) -> Result<(), EmvaError> {
    match block {
        Some(b) if b.images.len() < 2 => {
            Err(err(b.line, format!("block has {} image(s); expected at least 2 'i' lines after it", b.images.len())))
        }
        _ => Ok(()),
    }
}

/// Loads one grayscale image (8..16-bit PNG or TIFF) as raw DN values, checking its size and
/// that no value exceeds `2^bits - 1`.
pub fn load_image(path: &Path, width: u32, height: u32, bits: u32) -> Result<Vec<f32>, EmvaError> {
    let image_err = |message: String| EmvaError::Image { path: path.to_path_buf(), message };
    if !path.is_file() {
        return Err(image_err("missing (listed in the descriptor but not found)".into()));
    }
    let img = image::ImageReader::open(path)
        .map_err(|source| EmvaError::Io { path: path.to_path_buf(), source })?
        .with_guessed_format()
        .map_err(|source| EmvaError::Io { path: path.to_path_buf(), source })?
        .decode()
        .map_err(|e| image_err(e.to_string()))?;
    if img.width() != width || img.height() != height {
        return Err(image_err(format!("is {}x{}, the descriptor says {width}x{height}", img.width(), img.height())));
    }
    let values: Vec<f32> = match img {
        image::DynamicImage::ImageLuma8(b) => b.into_raw().into_iter().map(f32::from).collect(),
        image::DynamicImage::ImageLuma16(b) => b.into_raw().into_iter().map(f32::from).collect(),
        other => return Err(image_err(format!("expected a grayscale image, found {:?}", other.color()))),
    };
    let max = ((1u32 << bits) - 1) as f32;
    if let Some(v) = values.iter().find(|&&v| v > max) {
        return Err(image_err(format!("holds value {v}, above the {bits}-bit maximum {max}")));
    }
    Ok(values)
}
