//! Named surfaces (`wood_floor`, `paint`, `fabric`, `gold`...) turned into PBR materials with
//! baked textures.
//!
//! Room and furniture TOML files, and the `usemtl` names in furniture OBJ files, refer to
//! surfaces by these names. A [`MaterialCatalog`] creates each (surface, variant) material the
//! first time it is asked for and returns the same index afterwards, so meshes can be shared.
//!
//! Every surface is textured ([`crate::textures`]): the texture holds the colour and pattern,
//! the material's base colour factor is white, except for gold (its linear base colour as
//! the factor, over a near-white brushed texture) and glass (alpha below 1, rendered blended).
//! The variant a caller passes (the scene seed picks it) selects colour and pattern
//! parameters; the house's [`Palette`] maps it to a variant in the house's colours for the
//! surfaces the palette names, and every variant is taken modulo [`VARIANTS`].

use std::collections::HashMap;

use crate::palette::Palette;
use crate::scene::{Geometry, Material, Texture};
pub use crate::textures::VARIANTS;

/// Every surface name a library file may use.
pub const SURFACES: &[&str] = &[
    "wood_floor",
    "tile_floor",
    "carpet",
    "paint",
    "wallpaper",
    "tile_wall",
    "ceiling",
    "wood",
    "fabric",
    "leather",
    "metal",
    "plastic",
    "ceramic",
    "glass",
    "screen",
    "leaf",
    "soil",
    "pot",
    "lampshade",
    "linen",
    "rug",
    "picture",
    "gold",
    "frame",
];

/// A surface name not in [`SURFACES`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown surface '{0}' (known: {known})", known = SURFACES.join(", "))]
pub struct UnknownSurface(pub String);

/// Fixed PBR parameters of a surface: (linear base colour factor, metallic, roughness).
///
/// Roughness values are typical of the materials (glTF sample-model practice: polished
/// ceramic ~0.15, painted plaster ~0.85, fabric ~0.9); gold's linear base colour
/// (1.0, 0.766, 0.336) is the measured reflectance of gold used in the glTF 2.0 specification,
/// Appendix B.
fn pbr(surface: &str) -> ([f32; 4], f32, f32) {
    const WHITE: [f32; 4] = [1.0, 1.0, 1.0, 1.0];
    match surface {
        "gold" => ([1.0, 0.766, 0.336, 1.0], 1.0, 0.3),
        "metal" => (WHITE, 1.0, 0.35),
        "glass" => ([1.0, 1.0, 1.0, 0.25], 0.0, 0.05),
        "ceramic" => (WHITE, 0.0, 0.15),
        "screen" => (WHITE, 0.0, 0.15),
        "tile_wall" => (WHITE, 0.0, 0.25),
        "tile_floor" => (WHITE, 0.0, 0.3),
        "plastic" => (WHITE, 0.0, 0.45),
        "wood_floor" => (WHITE, 0.0, 0.45),
        "leather" => (WHITE, 0.0, 0.5),
        "frame" => (WHITE, 0.0, 0.5),
        "wood" => (WHITE, 0.0, 0.55),
        "leaf" => (WHITE, 0.0, 0.6),
        "picture" => (WHITE, 0.0, 0.6),
        "pot" => (WHITE, 0.0, 0.7),
        "wallpaper" => (WHITE, 0.0, 0.8),
        "paint" | "linen" | "lampshade" => (WHITE, 0.0, 0.85),
        "ceiling" | "fabric" => (WHITE, 0.0, 0.9),
        _ => (WHITE, 0.0, 0.95), // carpet, rug, soil
    }
}

/// Creates materials on demand and remembers them: one material and one texture per
/// (surface, variant) in a [`Geometry`].
#[derive(Debug)]
pub struct MaterialCatalog {
    seed: u64,
    palette: Option<&'static Palette>,
    made: HashMap<(String, u32), usize>,
}

impl MaterialCatalog {
    /// The catalog of the house with `seed`, in the house's palette ([`Palette::of_seed`]).
    #[must_use]
    pub fn new(seed: u64) -> MaterialCatalog {
        MaterialCatalog::with_palette(seed, Some(Palette::of_seed(seed)))
    }

    /// A catalog in `palette`, or in every colour of every surface (`None`).
    #[must_use]
    pub fn with_palette(seed: u64, palette: Option<&'static Palette>) -> MaterialCatalog {
        MaterialCatalog { seed, palette, made: HashMap::new() }
    }

    /// The palette the catalog draws colours from, if any.
    #[must_use]
    pub fn palette(&self) -> Option<&'static Palette> {
        self.palette
    }

    /// The scene seed this catalog was made for (callers derive variants from it).
    #[must_use]
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Whether `name` is a known surface.
    #[must_use]
    pub fn is_surface(name: &str) -> bool {
        SURFACES.contains(&name)
    }

    /// Index in `geometry.materials` of `surface` in variant `variant` (through the palette,
    /// modulo [`VARIANTS`]), adding the material and its texture to `geometry` the first time.
    pub fn material(&mut self, geometry: &mut Geometry, surface: &str, variant: u32) -> Result<usize, UnknownSurface> {
        if !Self::is_surface(surface) {
            return Err(UnknownSurface(surface.to_string()));
        }
        let variant = self.palette.map_or(variant % VARIANTS, |p| p.variant(surface, variant));
        if let Some(&index) = self.made.get(&(surface.to_string(), variant)) {
            return Ok(index);
        }
        let name = format!("{surface}_{variant}");
        let baked = crate::textures::baked(surface, variant).expect("every known surface has a texture");
        geometry.textures.push(Texture {
            name: name.clone(),
            width: baked.width,
            height: baked.height,
            rgba8: baked.rgba8.clone(),
            png: baked.png.clone(),
        });
        let (base_color, metallic, roughness) = pbr(surface);
        geometry.materials.push(Material {
            name,
            base_color,
            metallic,
            roughness,
            base_color_texture: Some(geometry.textures.len() - 1),
        });
        let index = geometry.materials.len() - 1;
        self.made.insert((surface.to_string(), variant), index);
        Ok(index)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn materials_are_deduplicated_per_surface_and_variant() {
        let mut geometry = Geometry::default();
        let mut catalog = MaterialCatalog::with_palette(7, None);
        let a = catalog.material(&mut geometry, "wood", 1).unwrap();
        let b = catalog.material(&mut geometry, "wood", 1 + VARIANTS).unwrap();
        let c = catalog.material(&mut geometry, "wood", 2).unwrap();
        let d = catalog.material(&mut geometry, "paint", 1).unwrap();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(c, d);
        assert_eq!(geometry.materials.len(), 3);
        assert_eq!(geometry.textures.len(), 3);
        assert_eq!(geometry.materials[a].base_color_texture, Some(0));
        assert_eq!(catalog.material(&mut geometry, "velvet", 0), Err(UnknownSurface("velvet".into())));
    }

    #[test]
    fn gold_is_the_threshold_metal() {
        let mut geometry = Geometry::default();
        let gold = MaterialCatalog::new(0).material(&mut geometry, "gold", 0).unwrap();
        let m = &geometry.materials[gold];
        assert_eq!(m.base_color, [1.0, 0.766, 0.336, 1.0]);
        assert_eq!((m.metallic, m.roughness), (1.0, 0.3));
        // The brushed texture is near white so the factor carries the colour.
        let t = &geometry.textures[m.base_color_texture.unwrap()];
        let mean = t.rgba8.iter().map(|&b| f64::from(b)).sum::<f64>() / t.rgba8.len() as f64;
        assert!(mean > 225.0, "gold texture mean {mean}");
    }
}
