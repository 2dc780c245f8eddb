//! Writes a contact sheet of every surface texture (columns: variants 0..4) to a PNG, to eyeball
//! the procedural textures: `cargo run --release --example texture_sheet -- sheet.png`.

use scene_gen::materials::SURFACES;
use scene_gen::textures::{TEXTURE_SIZE, baked};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "texture_sheet.png".into());
    let (cell, variants) = (TEXTURE_SIZE / 2, 4u32);
    let mut sheet = image::RgbaImage::new(cell * variants, cell * SURFACES.len() as u32);
    for (row, surface) in SURFACES.iter().enumerate() {
        for variant in 0..variants {
            let t = baked(surface, variant).ok_or("unknown surface")?;
            let full = image::RgbaImage::from_raw(t.width, t.height, t.rgba8.to_vec()).ok_or("bad size")?;
            // Top-left quarter at full resolution: 0.5 m x 0.5 m of surface.
            let part = image::imageops::crop_imm(&full, 0, 0, cell, cell).to_image();
            image::imageops::replace(&mut sheet, &part, i64::from(variant * cell), (row as u32 * cell).into());
        }
    }
    sheet.save(&out)?;
    println!("wrote {out}");
    Ok(())
}
