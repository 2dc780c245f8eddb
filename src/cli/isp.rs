//! `scene-gen isp RAW.png --pattern RGGB --out RGB.png`: develops any raw Bayer mosaic (an 8- or
//! 16-bit one-channel PNG) into an 8-bit sRGB PNG: black level, white balance, demosaicing,
//! colour matrix and the sRGB curve ([`scene_gen::develop`]). `--only-demosaic` demosaics and
//! nothing else, so demosaicing can be checked on mosaicked photographs.

use std::path::PathBuf;

use anyhow::{Context, anyhow};
use clap::Args;
use scene_gen::demosaic::{CfaPattern, Demosaic};
use scene_gen::develop::{Develop, IDENTITY, develop};
use scene_gen::export::write_atomic;

use super::{CliError, bad_input, failure};

#[derive(Args, Debug)]
pub struct IspArgs {
    /// The raw mosaic: a one-channel 8- or 16-bit PNG.
    pub raw: PathBuf,
    /// The colour filter array's 2x2 tile: RGGB, BGGR, GRBG or GBRG.
    #[arg(long, value_parser = parse_pattern)]
    pub pattern: CfaPattern,
    /// Demosaicing method: bilinear, malvar (Malvar-He-Cutler) or directional (Hamilton-Adams
    /// green, colour-difference red and blue).
    #[arg(long, value_parser = parse_demosaic, default_value = "directional")]
    pub demosaic: Demosaic,
    /// Demosaic only: skip white balance, colour matrix and tone curve.
    #[arg(long)]
    pub only_demosaic: bool,
    /// Significant bits of the raw values [default: the PNG's bit depth].
    #[arg(long)]
    pub bits: Option<u32>,
    /// The ADC value of no light, DN.
    #[arg(long, default_value_t = 0.0)]
    pub black_level: f32,
    /// White-balance gains `R,G,B`.
    #[arg(long, value_parser = parse_gains, default_value = "1,1,1")]
    pub wb: [f32; 3],
    /// Colour matrix from camera RGB to linear sRGB, nine numbers row by row [default: identity].
    #[arg(long, value_parser = parse_matrix)]
    pub ccm: Option<[[f32; 3]; 3]>,
    /// The 8-bit sRGB PNG to write.
    #[arg(long)]
    pub out: PathBuf,
}

fn parse_pattern(text: &str) -> Result<CfaPattern, String> {
    text.parse()
}

fn parse_demosaic(text: &str) -> Result<Demosaic, String> {
    text.parse()
}

fn numbers(text: &str, count: usize) -> Result<Vec<f32>, String> {
    let values: Vec<f32> = text
        .split(',')
        .map(|v| v.trim().parse::<f32>().map_err(|_| format!("'{}' is not a number", v.trim())))
        .collect::<Result<_, _>>()?;
    if values.len() != count {
        return Err(format!("expected {count} comma-separated numbers, got {}", values.len()));
    }
    Ok(values)
}

fn parse_gains(text: &str) -> Result<[f32; 3], String> {
    let v = numbers(text, 3)?;
    Ok([v[0], v[1], v[2]])
}

fn parse_matrix(text: &str) -> Result<[[f32; 3]; 3], String> {
    let v = numbers(text, 9)?;
    Ok([[v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]]])
}

pub fn run(args: &IspArgs) -> Result<(), CliError> {
    let image = image::open(&args.raw)
        .with_context(|| format!("cannot read raw mosaic {}", args.raw.display()))
        .map_err(bad_input)?;
    let (width, height) = (image.width() as usize, image.height() as usize);
    let (raw, png_bits): (Vec<u16>, u32) = match image {
        image::DynamicImage::ImageLuma8(g) => (g.into_raw().into_iter().map(u16::from).collect(), 8),
        image::DynamicImage::ImageLuma16(g) => (g.into_raw(), 16),
        other => {
            return Err(bad_input(anyhow!(
                "{}: a raw mosaic has one channel, this image is {:?}",
                args.raw.display(),
                other.color()
            )));
        }
    };
    let bits = args.bits.unwrap_or(png_bits);
    if !(1..=png_bits).contains(&bits) {
        return Err(bad_input(anyhow!("--bits {bits}: must be 1..={png_bits} for a {png_bits}-bit PNG")));
    }
    let settings = Develop {
        demosaic: args.demosaic,
        black_level_dn: args.black_level,
        white_balance: args.wb,
        colour_matrix: args.ccm.unwrap_or(IDENTITY),
        only_demosaic: args.only_demosaic,
        ..Develop::new(args.pattern, bits)
    };
    settings.validate().map_err(|e| bad_input(anyhow!(e)))?;
    let rgb = develop(&raw, width, height, &settings);
    let mut png = Vec::new();
    image::RgbImage::from_raw(width as u32, height as u32, rgb)
        .ok_or_else(|| failure(anyhow!("developed image has the wrong size")))?
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(failure)?;
    write_atomic(&args.out, &png).map_err(failure)?;
    Ok(())
}
