//! Named surfaces (`wood_floor`, `paint`, `fabric`, `gold`...) turned into PBR materials with
//! baked textures.
//!
//! Room and furniture TOML files, and the `usemtl` names in furniture OBJ files, refer to
//! surfaces by these names. A [`MaterialCatalog`] creates each (surface, variant) material the
//! first time it is asked for and returns the same index afterwards, so meshes can be shared.
//!
//! STUB: flat colours; the textures work replaces this with seeded procedural textures.

use std::collections::HashMap;

use crate::scene::{Geometry, Material};

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

/// Creates materials on demand and remembers them.
#[derive(Debug)]
pub struct MaterialCatalog {
    seed: u64,
    made: HashMap<(String, u32), usize>,
}

impl MaterialCatalog {
    #[must_use]
    pub fn new(seed: u64) -> MaterialCatalog {
        MaterialCatalog { seed, made: HashMap::new() }
    }

    /// Whether `name` is a known surface.
    #[must_use]
    pub fn is_surface(name: &str) -> bool {
        SURFACES.contains(&name)
    }

    /// Index in `geometry.materials` of `surface` in colour variant `variant`.
    pub fn material(&mut self, geometry: &mut Geometry, surface: &str, variant: u32) -> Result<usize, UnknownSurface> {
        if !Self::is_surface(surface) {
            return Err(UnknownSurface(surface.to_string()));
        }
        if let Some(&index) = self.made.get(&(surface.to_string(), variant)) {
            return Ok(index);
        }
        let _ = self.seed;
        let (metallic, roughness) = if surface == "gold" { (1.0, 0.3) } else { (0.0, 0.8) };
        let base = if surface == "gold" { [1.0, 0.766, 0.336, 1.0] } else { [0.6, 0.6, 0.6, 1.0] };
        geometry.materials.push(Material {
            name: format!("{surface}_{variant}"),
            base_color: base,
            metallic,
            roughness,
            base_color_texture: None,
        });
        let index = geometry.materials.len() - 1;
        self.made.insert((surface.to_string(), variant), index);
        Ok(index)
    }
}
