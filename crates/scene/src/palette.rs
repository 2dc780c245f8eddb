//! House palettes: the colour scheme a house is decorated in.
//!
//! A house draws one palette from its seed. For the surfaces that carry a home's colour
//! (wall paint and wallpaper, floors and carpets, furniture woods, fabrics, leathers and
//! plastics) the palette names which of the surface's base colours
//! ([`crate::textures::BASE_COLOURS`]) the house may use; every material the house asks for
//! is drawn from those, so its rooms agree the way a decorated home's do, and houses differ
//! from one another in character rather than only in noise. Surfaces a palette does not
//! name (tiles, ceramics, metals, plants, rugs, pictures) keep every colour.
//!
//! The schemes follow common interior-design families (Scandinavian, warm traditional,
//! coastal, industrial, earthy, classic); each keeps at least three bright plastics, which
//! toys need.

use rand::Rng;

use crate::textures::{VARIANTS, base_colours};

/// An interior colour scheme: per surface, the base colours (sRGB hex) a house may use.
#[derive(Debug, PartialEq, Eq)]
pub struct Palette {
    pub name: &'static str,
    pub colours: &'static [(&'static str, &'static [u32])],
}

/// Every palette a house can draw.
pub const PALETTES: &[Palette] = &[
    Palette {
        name: "nordic",
        colours: &[
            ("paint", &[0xf4f2ee, 0xece8e0, 0xc8d4d8]),
            ("wallpaper", &[0xf0ece4, 0xd0d8e0]),
            ("wood_floor", &[0xd8b88c, 0xc89a64]),
            ("carpet", &[0xc8c0b0, 0x7a7f86]),
            ("wood", &[0xc9a27a, 0xb98a5a]),
            ("fabric", &[0x6a7a8a, 0xc8c0b0, 0x505458]),
            ("leather", &[0xa08060, 0x1e1a18]),
            ("plastic", &[0xe8e8e8, 0x303234, 0x3a6ac8, 0xe8c830, 0xc83a32]),
        ],
    },
    Palette {
        name: "warm",
        colours: &[
            ("paint", &[0xe8d8d0, 0xdcd6c8, 0xd8bfa8]),
            ("wallpaper", &[0xe0d0c8, 0xe8e0d0]),
            ("wood_floor", &[0xa0703f, 0x8a5a3a]),
            ("carpet", &[0xa89a80, 0x8a5050]),
            ("wood", &[0x8a5a36, 0x6f4a2e]),
            ("fabric", &[0xa4583a, 0xb0a48c, 0x8a6a5a]),
            ("leather", &[0x7a4a2a, 0x4a2e20]),
            ("plastic", &[0xe8e8e8, 0xc83a32, 0xe8c830, 0x48a048]),
        ],
    },
    Palette {
        name: "coastal",
        colours: &[
            ("paint", &[0xf4f2ee, 0xa9b8c4, 0xc8d4d8]),
            ("wallpaper", &[0xd0d8e0, 0xf0ece4]),
            ("wood_floor", &[0xd8b88c, 0xc89a64]),
            ("carpet", &[0x4a5a7a, 0xc8c0b0]),
            ("wood", &[0xc9a27a, 0xb98a5a]),
            ("fabric", &[0x2e4a6e, 0x6a7a8a, 0xc8c0b0]),
            ("leather", &[0xa08060]),
            ("plastic", &[0xe8e8e8, 0x3a6ac8, 0x48a048, 0xe8c830]),
        ],
    },
    Palette {
        name: "industrial",
        colours: &[
            ("paint", &[0x8c9094, 0xdcd6c8, 0xece8e0]),
            ("wallpaper", &[0xd0d8e0, 0xe8e0d0]),
            ("wood_floor", &[0x6a4428, 0x8a5a3a]),
            ("carpet", &[0x7a7f86, 0x5a6a5a]),
            ("wood", &[0x5e3b24, 0x6f4a2e]),
            ("fabric", &[0x505458, 0x6a7a8a, 0xa4583a]),
            ("leather", &[0x1e1a18, 0x4a2e20]),
            ("plastic", &[0x303234, 0xe8e8e8, 0xc83a32, 0xe8c830, 0x3a6ac8]),
        ],
    },
    Palette {
        name: "earthy",
        colours: &[
            ("paint", &[0xc3ccb4, 0xd8dcc8, 0xe8d8d0]),
            ("wallpaper", &[0xd8e0d0, 0xe8e0d0]),
            ("wood_floor", &[0xa0703f, 0xc89a64]),
            ("carpet", &[0x5a6a5a, 0xa89a80]),
            ("wood", &[0xb98a5a, 0x8a5a36]),
            ("fabric", &[0x8a8f5a, 0x4a5a4a, 0xb0a48c]),
            ("leather", &[0x7a4a2a, 0xa08060]),
            ("plastic", &[0xe8e8e8, 0x48a048, 0xe8c830, 0xc83a32]),
        ],
    },
    Palette {
        name: "classic",
        colours: &[
            ("paint", &[0xece8e0, 0xe8d8d0, 0xd8bfa8]),
            ("wallpaper", &[0xe0d0c8, 0xf0ece4]),
            ("wood_floor", &[0x6a4428, 0xa0703f]),
            ("carpet", &[0x8a5050, 0x4a5a7a]),
            ("wood", &[0x5e3b24, 0x8a5a36]),
            ("fabric", &[0x7a2a30, 0x2e4a6e, 0xb0a48c]),
            ("leather", &[0x6a2020, 0x4a2e20]),
            ("plastic", &[0xe8e8e8, 0x303234, 0xc83a32, 0x3a6ac8]),
        ],
    },
];

impl Palette {
    /// The palette of the house with `seed`.
    #[must_use]
    pub fn of_seed(seed: u64) -> &'static Palette {
        let mut rng = scene_gen_core::rng::stream(seed, "palette");
        &PALETTES[rng.random_range(0..PALETTES.len())]
    }

    /// The texture variant (below [`VARIANTS`]) of `surface` for a caller's `variant`: one
    /// whose base colour is in this palette, chosen by `variant` among them, or `variant`
    /// itself for a surface the palette does not name.
    #[must_use]
    pub fn variant(&self, surface: &str, variant: u32) -> u32 {
        let (Some(named), Some(base)) =
            (self.colours.iter().find(|(s, _)| *s == surface).map(|(_, c)| *c), base_colours(surface))
        else {
            return variant % VARIANTS;
        };
        let allowed: Vec<u32> = (0..VARIANTS).filter(|v| named.contains(&base[*v as usize % base.len()])).collect();
        allowed.get(variant as usize % allowed.len().max(1)).copied().unwrap_or(variant % VARIANTS)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_palette_colour_is_a_base_colour_of_its_surface() {
        for palette in PALETTES {
            for (surface, colours) in palette.colours {
                let base =
                    base_colours(surface).unwrap_or_else(|| panic!("{}: {surface} has no base colours", palette.name));
                for c in *colours {
                    assert!(base.contains(c), "{}: {surface} colour {c:06x} is not a base colour", palette.name);
                }
            }
        }
    }

    #[test]
    fn a_palette_keeps_its_surfaces_to_its_colours_and_leaves_the_rest() {
        let base = base_colours("paint").unwrap();
        for palette in PALETTES {
            let named = palette.colours.iter().find(|(s, _)| *s == "paint").unwrap().1;
            let mut seen = std::collections::BTreeSet::new();
            for v in 0..64 {
                let chosen = palette.variant("paint", v);
                assert!(chosen < VARIANTS);
                assert!(named.contains(&base[chosen as usize % base.len()]), "{} paint variant {chosen}", palette.name);
                seen.insert(base[chosen as usize % base.len()]);
            }
            assert_eq!(seen.len(), named.len(), "{}: every named paint colour is reachable", palette.name);
            assert_eq!(palette.variant("tile_floor", 21), 21 % VARIANTS);
        }
    }

    #[test]
    fn seeds_draw_every_palette() {
        let drawn: std::collections::BTreeSet<&str> = (0..200).map(|s| Palette::of_seed(s).name).collect();
        assert_eq!(drawn.len(), PALETTES.len());
    }
}
