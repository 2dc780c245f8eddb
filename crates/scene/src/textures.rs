//! Seeded, tileable procedural textures for the named surfaces of [`crate::materials`].
//!
//! Texture is what ORB features and object detectors feed on, so every surface gets a
//! pattern (plank seams and grain, tile grout, weave, veins...) rather than a flat colour.
//! Each image covers 1 m x 1 m of surface (texture coordinates are metres and samplers
//! repeat), and tiles seamlessly: every pattern is built from integer repeats per metre and
//! from value-noise lattices that wrap around.
//!
//! The pixels are a pure function of `(surface, variant)`: the variant seeds a ChaCha8 stream
//! (via [`scene_gen_core::rng::substream`]) that picks the palette, scale and pattern parameters. That
//! makes the result safe to memoise process-wide: [`baked`] keeps every texture it made in a
//! cache (only a cache: the bytes never depend on whether it was hit, or on threads), so
//! generating many scenes bakes each texture once.
//!
//! The noise is a small hand-written periodic value noise: the crates that offer noise
//! (`noise`, `fastnoise-lite`) do not tile on an integer period without extra work, and the
//! 40 lines here are all we need.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Width and height of every baked texture, pixels. 256 px per metre is 4 mm per pixel: finer
/// than any camera in the design space resolves at a metre or more, and cheap to bake.
pub const TEXTURE_SIZE: u32 = 256;

/// Number of distinct variants per surface; a caller's variant is taken modulo this, which
/// bounds the cache and lets materials be shared across scenes.
pub const VARIANTS: u32 = 16;

/// Base colours (sRGB hex) of the surfaces whose texture is drawn in one colour: variant `v`
/// takes entry `v` modulo the list's length, with a small brightness jitter of its own. House
/// palettes ([`crate::palette`]) choose among these entries.
pub const BASE_COLOURS: &[(&str, &[u32])] = &[
    ("wood_floor", &[0xa0703f, 0xc89a64, 0x6a4428, 0xd8b88c, 0x8a5a3a]),
    ("wood", &[0x8a5a36, 0xb98a5a, 0x5e3b24, 0xc9a27a, 0x6f4a2e]),
    ("frame", &[0x3b2a1e, 0x8a6a3a, 0xe8e2d6, 0x202020]),
    ("carpet", &[0x7a7f86, 0xa89a80, 0x5a6a5a, 0x8a5050, 0x4a5a7a, 0xc8c0b0]),
    (
        "fabric",
        &[0x6a7a8a, 0x8a6a5a, 0x4a5a4a, 0xb0a48c, 0x6e4e6e, 0xa4583a, 0x2e4a6e, 0x8a8f5a, 0x7a2a30, 0xc8c0b0, 0x505458],
    ),
    ("linen", &[0xeeeae0, 0xdfe6ee, 0xe8dccc, 0xf4f4f4]),
    ("lampshade", &[0xf0e6d0, 0xe8e8e0, 0xd8c8a8]),
    ("paint", &[0xece8e0, 0xdcd6c8, 0xc8d4d8, 0xd8dcc8, 0xe8d8d0, 0xf4f2ee, 0xc3ccb4, 0xa9b8c4, 0xd8bfa8, 0x8c9094]),
    ("ceiling", &[0xf2f1ee, 0xeeeeea, 0xf6f4f0]),
    ("wallpaper", &[0xe8e0d0, 0xd0d8e0, 0xe0d0c8, 0xd8e0d0, 0xf0ece4]),
    ("leather", &[0x4a2e20, 0x1e1a18, 0x7a4a2a, 0xa08060, 0x6a2020]),
    ("metal", &[0xb8bcc0, 0x9a9ea4, 0xc8c4bc]),
    ("plastic", &[0xe8e8e8, 0x303234, 0xc83a32, 0x3a6ac8, 0xe8c830, 0x48a048]),
    ("ceramic", &[0xf6f6f4, 0xeef2f4, 0xf2ece4]),
    ("screen", &[0x0c0d10, 0x101214, 0x08090c]),
    ("pot", &[0xa85a3a, 0x3a4a5a, 0xe8e0d4, 0x5a6a4a, 0x2a2a2a]),
    ("soil", &[0x3a2a1e, 0x2e221a, 0x4a3626]),
    ("leaf", &[0x3a6a2a, 0x2a5a2e, 0x4a7a30, 0x5a7a3a]),
];

/// The base colours of `surface`, if its texture is drawn in one colour.
#[must_use]
pub fn base_colours(surface: &str) -> Option<&'static [u32]> {
    BASE_COLOURS.iter().find(|(name, _)| *name == surface).map(|(_, colours)| *colours)
}

/// A baked texture: sRGB RGBA8 pixels and the same image as PNG (RGB, alpha is always opaque).
#[derive(Debug, PartialEq, Eq)]
pub struct BakedTexture {
    pub width: u32,
    pub height: u32,
    /// sRGB-encoded RGBA8, row-major from the top row.
    pub rgba8: Arc<[u8]>,
    /// The same pixels as a PNG file, encoded when first read.
    pub png: Png,
}

/// A texture's PNG file, encoded on first use and then shared by every clone (like
/// [`std::sync::LazyLock`], it dereferences to the bytes). Only exporters read it: encoding
/// every texture when it was baked cost each `evaluate` or `render` process about half a CPU
/// second of deflate (perf) for files it never wrote.
#[derive(Clone)]
pub struct Png(Arc<PngCell>);

struct PngCell {
    /// The RGBA8 pixels and their size, when the bytes are still to be encoded.
    source: Option<(Arc<[u8]>, u32, u32)>,
    bytes: OnceLock<Vec<u8>>,
}

impl Png {
    /// The PNG of a `width` x `height` sRGB RGBA8 image, saved as RGB (alpha is dropped: every
    /// baked texture is opaque), encoded when first read.
    #[must_use]
    pub fn of_rgba8(rgba8: Arc<[u8]>, width: u32, height: u32) -> Png {
        Png(Arc::new(PngCell { source: Some((rgba8, width, height)), bytes: OnceLock::new() }))
    }
}

/// Bytes that already are a PNG file (or none, for a texture that is never exported).
impl From<Vec<u8>> for Png {
    fn from(bytes: Vec<u8>) -> Png {
        Png(Arc::new(PngCell { source: None, bytes: OnceLock::from(bytes) }))
    }
}

impl std::ops::Deref for Png {
    type Target = [u8];

    fn deref(&self) -> &[u8] {
        self.0.bytes.get_or_init(|| match &self.0.source {
            Some((rgba8, width, height)) => {
                let rgb: Vec<u8> = rgba8.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
                encode_png(&rgb, *width, *height)
            }
            None => Vec::new(),
        })
    }
}

/// Two PNGs are equal when their bytes are (which encodes both).
impl PartialEq for Png {
    fn eq(&self, other: &Png) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || **self == **other
    }
}

impl Eq for Png {}

/// The state, not the bytes: printing a texture should not encode it.
impl std::fmt::Debug for Png {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0.bytes.get() {
            Some(bytes) => write!(f, "Png({} bytes)", bytes.len()),
            None => f.write_str("Png(not yet encoded)"),
        }
    }
}

type Cache = Mutex<HashMap<(String, u32), Arc<BakedTexture>>>;

/// The texture of `surface` in `variant` (modulo [`VARIANTS`]), from the process-wide cache;
/// `None` for a surface without a texture (not in [`crate::materials::SURFACES`]).
#[must_use]
pub fn baked(surface: &str, variant: u32) -> Option<Arc<BakedTexture>> {
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let variant = variant % VARIANTS;
    let cache = CACHE.get_or_init(Cache::default);
    let key = (surface.to_string(), variant);
    if let Some(hit) = cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner).get(&key) {
        return Some(Arc::clone(hit));
    }
    // Bake outside the lock; if two threads race, both bake identical bytes and the first
    // insert wins, so the result is the same either way.
    let texture = Arc::new(bake(surface, variant)?);
    let mut map = cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    Some(Arc::clone(map.entry(key).or_insert(texture)))
}

/// Bakes `surface` in `variant` (modulo [`VARIANTS`]) without the cache.
#[must_use]
pub fn bake(surface: &str, variant: u32) -> Option<BakedTexture> {
    let variant = variant % VARIANTS;
    let rgb = pixels(surface, variant, TEXTURE_SIZE as usize)?;
    let mut rgba8 = vec![255u8; rgb.len() / 3 * 4];
    for (dst, src) in rgba8.chunks_exact_mut(4).zip(rgb.chunks_exact(3)) {
        dst[..3].copy_from_slice(src);
    }
    let rgba8: Arc<[u8]> = rgba8.into();
    let png = Png::of_rgba8(Arc::clone(&rgba8), TEXTURE_SIZE, TEXTURE_SIZE);
    Some(BakedTexture { width: TEXTURE_SIZE, height: TEXTURE_SIZE, rgba8, png })
}

/// PNG at the default deflate level with adaptive filters. A texture is baked once per process
/// and then shared by every scene, while its bytes go into every GLB written: this halves the
/// GLB (about 2.2 MB instead of 4.3 MB for a 15 x 15 m house) and with it the per-scene encode
/// and write time, for about 10 ms more per texture on first use (examples/bench_generate.rs).
fn encode_png(rgb: &[u8], width: u32, height: u32) -> Vec<u8> {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let mut out = Vec::new();
    PngEncoder::new_with_quality(&mut out, CompressionType::Default, FilterType::Adaptive)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .expect("encoding an in-memory RGB8 image of the right length cannot fail");
    out
}

/// Colour in sRGB, components in 0..1.
type Rgb = [f32; 3];

/// A periodic lattice of random values, bilinearly interpolated with a smoothstep: value
/// noise that wraps after `nx` cells along u and `ny` along v, so it tiles the unit square.
struct Lattice {
    nx: usize,
    ny: usize,
    values: Vec<f32>,
}

impl Lattice {
    fn new(rng: &mut ChaCha8Rng, nx: usize, ny: usize) -> Lattice {
        Lattice { nx, ny, values: (0..nx * ny).map(|_| rng.random::<f32>()).collect() }
    }

    /// Noise in 0..1 at texture coordinates (u, v); any real u, v (wraps).
    #[inline]
    fn at(&self, u: f32, v: f32) -> f32 {
        // Wrap to [0, 1) first, then index with compares rather than integer division: this is
        // the hot loop of baking.
        let x = (u - floor(u) as f32) * self.nx as f32;
        let y = (v - floor(v) as f32) * self.ny as f32;
        let (x0, y0) = (floor(x), floor(y));
        let (fx, fy) = (smooth(x - x0 as f32), smooth(y - y0 as f32));
        // x0 is in 0..=n (n only when rounding makes the wrapped coordinate exactly 1).
        let wrap = |i: i64, n: usize| if i >= n as i64 { 0 } else { i.max(0) as usize };
        let (i0, j0) = (wrap(x0, self.nx), wrap(y0, self.ny));
        let i1 = if i0 + 1 == self.nx { 0 } else { i0 + 1 };
        let j1 = if j0 + 1 == self.ny { 0 } else { j0 + 1 };
        let row0 = j0 * self.nx;
        let row1 = j1 * self.nx;
        let a = lerp(self.values[row0 + i0], self.values[row0 + i1], fx);
        let b = lerp(self.values[row1 + i0], self.values[row1 + i1], fx);
        lerp(a, b, fy)
    }
}

/// Fractal sum of lattices, each octave twice as fine; result in 0..1.
struct Fbm {
    octaves: Vec<Lattice>,
}

impl Fbm {
    fn new(rng: &mut ChaCha8Rng, nx: usize, ny: usize, octaves: usize) -> Fbm {
        Fbm { octaves: (0..octaves).map(|k| Lattice::new(rng, nx << k, ny << k)).collect() }
    }

    fn at(&self, u: f32, v: f32) -> f32 {
        let (mut sum, mut amp, mut norm) = (0.0, 1.0, 0.0);
        for octave in &self.octaves {
            sum += amp * octave.at(u, v);
            norm += amp;
            amp *= 0.5;
        }
        sum / norm
    }
}

/// `x.floor()` as an integer without a libm call (baseline x86-64 has no SSE4.1 `roundss`).
fn floor(x: f32) -> i64 {
    let i = x as i64;
    if x < i as f32 { i - 1 } else { i }
}

fn smooth(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    [lerp(a[0], b[0], t), lerp(a[1], b[1], t), lerp(a[2], b[2], t)]
}

fn shade(c: Rgb, k: f32) -> Rgb {
    [c[0] * k, c[1] * k, c[2] * k]
}

fn srgb(hex: u32) -> Rgb {
    [((hex >> 16) & 0xff) as f32 / 255.0, ((hex >> 8) & 0xff) as f32 / 255.0, (hex & 0xff) as f32 / 255.0]
}

/// Palette entry `variant` (wrapping) with a small brightness jitter, so variants beyond the
/// palette length still differ.
fn pick(rng: &mut ChaCha8Rng, palette: &[u32], variant: u32) -> Rgb {
    let base = srgb(palette[variant as usize % palette.len()]);
    shade(base, rng.random_range(0.92..1.08))
}

/// Distance (in texture units) of `x` to the nearest multiple of `1 / n`.
fn to_line(x: f32, n: f32) -> f32 {
    let f = (x * n).rem_euclid(1.0);
    f.min(1.0 - f) / n
}

/// Fills a `size` x `size` RGB8 image from `f(u, v)`, u right and v down, at pixel centres.
fn paint(size: usize, f: impl Fn(f32, f32) -> Rgb) -> Vec<u8> {
    let mut out = vec![0u8; size * size * 3];
    let inv = 1.0 / size as f32;
    for (i, px) in out.chunks_exact_mut(3).enumerate() {
        let (u, v) = (((i % size) as f32 + 0.5) * inv, ((i / size) as f32 + 0.5) * inv);
        for (dst, c) in px.iter_mut().zip(f(u, v)) {
            *dst = (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        }
    }
    out
}

/// The RGB8 pixels of `surface` in `variant`, or `None` for an unknown surface.
fn pixels(surface: &str, variant: u32, size: usize) -> Option<Vec<u8>> {
    let label = format!("texture/{surface}");
    let mut rng = scene_gen_core::rng::substream(u64::from(variant), &label, 0);
    let rng = &mut rng;
    // Palette picks draw from their own stream, so they never shift the pattern's draws.
    let mut palette_rng = scene_gen_core::rng::substream(u64::from(variant), &label, 1);
    let base = base_colours(surface).map_or([1.0; 3], |colours| pick(&mut palette_rng, colours, variant));
    let px = 1.0 / size as f32;
    let image = match surface {
        "wood_floor" => planks(rng, base, size),
        "wood" | "frame" => grain(rng, base, size),
        "tile_floor" => tiles(rng, variant, size, [3, 4, 5], 2.5 * px, &[0xd8d2c4, 0x8f9290, 0xe9e6df, 0x6b5a4a]),
        "tile_wall" => tiles(rng, variant, size, [6, 8, 10], 1.5 * px, &[0xf2f2ee, 0xa8c8d0, 0xdfe8e0, 0x3c5a78]),
        "carpet" => fibres(rng, base, size),
        "fabric" => weave(rng, variant, base, size),
        "linen" | "lampshade" => weave(rng, 0, base, size),
        "paint" => roller(rng, base, size),
        "ceiling" => stipple(rng, base, 0.03, size),
        "wallpaper" => wallpaper(rng, variant, base, size),
        "leather" => leather(rng, base, size),
        "metal" => brushed(rng, base, size),
        "gold" => brushed(rng, [0.97, 0.97, 0.97], size),
        "plastic" => stipple(rng, base, 0.04, size),
        "ceramic" => stipple(rng, base, 0.02, size),
        "glass" => stipple(rng, [0.96, 0.97, 0.98], 0.02, size),
        "screen" => stipple(rng, base, 0.15, size),
        "pot" => pot(rng, base, size),
        "soil" => soil(rng, base, size),
        "leaf" => leaf(rng, base, size),
        "rug" => rug(rng, variant, size),
        "picture" => picture(rng, variant, size),
        _ => return None,
    };
    Some(image)
}

/// Wood planks along u: rows of boards with dark seams, per-board tone and grain.
fn planks(rng: &mut ChaCha8Rng, base: Rgb, size: usize) -> Vec<u8> {
    let rows = [5usize, 6, 8][rng.random_range(0..3)];
    let boards = rng.random_range(1..=2usize);
    let offsets: Vec<f32> = (0..rows).map(|_| rng.random()).collect();
    let tones: Vec<f32> = (0..rows * boards).map(|_| rng.random_range(0.82..1.12)).collect();
    let shifts: Vec<f32> = (0..rows * boards).map(|_| rng.random()).collect();
    let grain = Fbm::new(rng, 2, 48, 3);
    let rings = Fbm::new(rng, 2, 6, 2);
    let px = 1.0 / size as f32;
    let n_rows = rows as f32;
    paint(size, |u, v| {
        let row = ((v * n_rows) as usize).min(rows - 1);
        let along = (u + offsets[row]).rem_euclid(1.0) * boards as f32;
        let board = row * boards + (along as usize).min(boards - 1);
        let seam = to_line(v, n_rows).min(to_line(u + offsets[row], boards as f32));
        let s = shifts[board];
        let g = grain.at(u + s, v + s * 0.37);
        let ring = (std::f32::consts::TAU * (v * n_rows * 5.0 + rings.at(u + s, v) * 4.0 + s * 9.0)).sin();
        let k = tones[board] * (0.82 + 0.28 * g) * (1.0 - 0.08 * ring.abs().powi(8));
        let c = shade(base, k);
        if seam < px * 1.2 { shade(c, 0.45) } else { c }
    })
}

/// Continuous wood grain (furniture, frames): streaks along u with wavy growth rings.
fn grain(rng: &mut ChaCha8Rng, base: Rgb, size: usize) -> Vec<u8> {
    let streaks = Fbm::new(rng, 2, 64, 3);
    let warp = Fbm::new(rng, 2, 4, 2);
    let rings: f32 = rng.random_range(20.0..40.0_f32).round();
    paint(size, |u, v| {
        let ring = (std::f32::consts::TAU * (v * rings + warp.at(u, v) * 3.0)).sin() * 0.5 + 0.5;
        let k = 0.8 + 0.25 * streaks.at(u, v) - 0.12 * ring.powi(6);
        shade(base, k)
    })
}

/// Square (or, for odd variants, half-offset 2:1 "subway") tiles with grout lines.
fn tiles(rng: &mut ChaCha8Rng, variant: u32, size: usize, counts: [usize; 3], grout: f32, palette: &[u32]) -> Vec<u8> {
    let base = pick(rng, palette, variant);
    let grout_colour = if base.iter().sum::<f32>() > 1.8 { shade(base, 0.72) } else { [0.78, 0.77, 0.74] };
    let n = counts[rng.random_range(0..3)];
    let subway = variant % 2 == 1;
    let (cols, rows) = if subway { (n / 2, n) } else { (n, n) };
    let tones: Vec<f32> = (0..cols * rows).map(|_| rng.random_range(0.93..1.05)).collect();
    let mottle = Fbm::new(rng, 8, 8, 3);
    let speck = Lattice::new(rng, 128, 128);
    paint(size, |u, v| {
        let row = ((v * rows as f32) as usize).min(rows - 1);
        let shift = if subway && row % 2 == 1 { 0.5 / cols as f32 } else { 0.0 };
        let uu = u + shift;
        let col = ((uu.rem_euclid(1.0) * cols as f32) as usize).min(cols - 1);
        if to_line(v, rows as f32) < grout || to_line(uu, cols as f32) < grout {
            return shade(grout_colour, 0.95 + 0.1 * speck.at(u, v));
        }
        let k = tones[row * cols + col] * (0.94 + 0.08 * mottle.at(u, v)) + 0.03 * (speck.at(u, v) - 0.5);
        shade(base, k)
    })
}

/// Carpet pile: fine fibre noise over a soft mottle.
fn fibres(rng: &mut ChaCha8Rng, base: Rgb, size: usize) -> Vec<u8> {
    let fine = Lattice::new(rng, 128, 128);
    let mottle = Fbm::new(rng, 6, 6, 3);
    paint(size, |u, v| shade(base, 0.72 + 0.3 * fine.at(u, v) + 0.15 * mottle.at(u, v)))
}

/// Plain weave (over-under threads) with slubs; variants 2 and 5 add a woven check.
fn weave(rng: &mut ChaCha8Rng, variant: u32, base: Rgb, size: usize) -> Vec<u8> {
    let threads = (size / 4) as f32;
    let slub = Fbm::new(rng, 16, 16, 2);
    let check = variant % 3 == 2;
    let stripe = shade(base, 0.7);
    let checks: f32 = rng.random_range(6.0..12.0_f32).round();
    paint(size, |u, v| {
        let (cu, cv) = (u * threads, v * threads);
        let over_u = ((cu.floor() + cv.floor()) as i64) % 2 == 0;
        let t =
            if over_u { (std::f32::consts::PI * cv.fract()).sin() } else { (std::f32::consts::PI * cu.fract()).sin() };
        let k = 0.8 + 0.16 * t + 0.1 * (slub.at(u, v) - 0.5);
        let mut c = base;
        if check && (to_line(u, checks) < 0.012 || to_line(v, checks) < 0.012) {
            c = stripe;
        }
        shade(c, k)
    })
}

/// Painted wall: faint vertical roller marks and a fine stipple.
fn roller(rng: &mut ChaCha8Rng, base: Rgb, size: usize) -> Vec<u8> {
    let marks = Fbm::new(rng, 16, 2, 3);
    let fine = Lattice::new(rng, 128, 128);
    paint(size, |u, v| shade(base, 0.95 + 0.05 * marks.at(u, v) + 0.03 * fine.at(u, v)))
}

/// Near-uniform colour with a fine stipple of relative depth `depth`.
fn stipple(rng: &mut ChaCha8Rng, base: Rgb, depth: f32, size: usize) -> Vec<u8> {
    let fine = Fbm::new(rng, 64, 64, 2);
    let soft = Fbm::new(rng, 4, 4, 2);
    paint(size, |u, v| shade(base, 1.0 - depth + depth * (fine.at(u, v) + soft.at(u, v))))
}

/// Wallpaper: a subtle repeating motif (stripes, diamonds or dots) in a close tone.
fn wallpaper(rng: &mut ChaCha8Rng, variant: u32, base: Rgb, size: usize) -> Vec<u8> {
    let motif = shade(base, rng.random_range(0.84..0.9));
    let repeats: f32 = [6.0_f32, 8.0, 10.0][rng.random_range(0..3)];
    let style = variant % 3;
    let paper = Fbm::new(rng, 32, 32, 2);
    paint(size, |u, v| {
        let (fu, fv) = ((u * repeats).fract() - 0.5, (v * repeats).fract() - 0.5);
        let on = match style {
            0 => to_line(u, repeats) < 0.12 / repeats,
            1 => (fu.abs() + fv.abs() - 0.35).abs() < 0.04,
            _ => fu * fu + fv * fv < 0.03,
        };
        let c = if on { motif } else { base };
        shade(c, 0.98 + 0.04 * paper.at(u, v))
    })
}

/// Leather: pebbled grain with darker creases.
fn leather(rng: &mut ChaCha8Rng, base: Rgb, size: usize) -> Vec<u8> {
    let pebble = Fbm::new(rng, 48, 48, 2);
    let crease = Fbm::new(rng, 12, 12, 3);
    let soft = Fbm::new(rng, 4, 4, 2);
    paint(size, |u, v| {
        let c = 1.0 - ((crease.at(u, v) - 0.5).abs() * 12.0).min(1.0);
        shade(base, 0.85 + 0.2 * pebble.at(u, v) + 0.1 * soft.at(u, v) - 0.18 * c)
    })
}

/// Brushed metal: long fine streaks along u.
fn brushed(rng: &mut ChaCha8Rng, base: Rgb, size: usize) -> Vec<u8> {
    let streaks = Fbm::new(rng, 4, 192, 2);
    let soft = Fbm::new(rng, 2, 8, 2);
    paint(size, |u, v| shade(base, 0.9 + 0.08 * streaks.at(u, v) + 0.04 * soft.at(u, v)))
}

/// Terracotta or glazed pot: mottled colour with a few specks.
fn pot(rng: &mut ChaCha8Rng, base: Rgb, size: usize) -> Vec<u8> {
    let mottle = Fbm::new(rng, 8, 8, 4);
    let speck = Lattice::new(rng, 96, 96);
    paint(size, |u, v| {
        let s = speck.at(u, v);
        let k = 0.85 + 0.25 * mottle.at(u, v) - if s > 0.82 { 0.2 } else { 0.0 };
        shade(base, k)
    })
}

/// Soil: dark crumbly noise with light grains.
fn soil(rng: &mut ChaCha8Rng, base: Rgb, size: usize) -> Vec<u8> {
    let clumps = Fbm::new(rng, 16, 16, 3);
    let grains = Lattice::new(rng, 128, 128);
    paint(size, |u, v| {
        let g = grains.at(u, v);
        if g > 0.8 {
            return shade([0.55, 0.5, 0.42], 0.8 + g * 0.2);
        }
        shade(base, 0.6 + 0.7 * clumps.at(u, v))
    })
}

/// Leaf surface: a midrib every 1/8 m with lateral veins branching off it, over mottled green.
fn leaf(rng: &mut ChaCha8Rng, base: Rgb, size: usize) -> Vec<u8> {
    let mottle = Fbm::new(rng, 8, 8, 3);
    let vein = mix(base, [0.85, 0.9, 0.6], 0.45);
    let lanes = 8.0;
    paint(size, |u, v| {
        let x = (u * lanes).fract() - 0.5;
        let lateral = (v * lanes * 2.0 + x.abs() * 1.4).fract();
        let c = if x.abs() < 0.025 || (lateral < 0.05 && x.abs() > 0.03) { vein } else { base };
        shade(c, 0.82 + 0.3 * mottle.at(u, v))
    })
}

/// A patterned rug: border bands and a diamond lattice over fibre noise.
fn rug(rng: &mut ChaCha8Rng, variant: u32, size: usize) -> Vec<u8> {
    let field = pick(rng, &[0x8a2a2a, 0x2a3a6a, 0xc8b890, 0x3a5a4a, 0x5a3a5a], variant);
    let border = pick(rng, &[0x1e2a4a, 0x6a1e1e, 0x4a3a2a, 0xd8c8a0], variant + 1);
    let accent = pick(rng, &[0xe0c890, 0xd8d0c0, 0x9a4a2a, 0x2a6a8a], variant + 2);
    let diamonds: f32 = [3.0_f32, 4.0, 5.0][rng.random_range(0..3)];
    let fine = Lattice::new(rng, 128, 128);
    paint(size, |u, v| {
        let edge = u.min(1.0 - u).min(v).min(1.0 - v);
        let c = if edge < 0.07 {
            if (edge - 0.035).abs() < 0.008 { accent } else { border }
        } else {
            let (fu, fv) = ((u * diamonds).fract() - 0.5, (v * diamonds).fract() - 0.5);
            let d = fu.abs() + fv.abs();
            if (d - 0.3).abs() < 0.04 || d < 0.08 {
                accent
            } else if d > 0.42 {
                border
            } else {
                field
            }
        };
        shade(c, 0.8 + 0.3 * fine.at(u, v))
    })
}

/// A framed picture: a wooden frame around a painted landscape (even variants) or an abstract
/// composition of colour blocks (odd variants).
fn picture(rng: &mut ChaCha8Rng, variant: u32, size: usize) -> Vec<u8> {
    let frame = pick(rng, &[0x3a2a1e, 0xc8a860, 0x202020, 0xe8e4dc], variant);
    let sky = pick(rng, &[0x8ab4d8, 0xe8b890, 0xa8c0d0, 0x6a8ab8], variant);
    let land = pick(rng, &[0x5a7a3a, 0x8a7a4a, 0x4a6a5a, 0x7a5a3a], variant);
    let sun = [rng.random_range(0.25..0.75_f32), rng.random_range(0.2..0.35_f32)];
    let hills = Fbm::new(rng, 4, 1, 3);
    let brush = Fbm::new(rng, 32, 32, 2);
    let blocks: Vec<(f32, f32, Rgb)> = (0..6)
        .map(|_| {
            let c = [rng.random::<f32>(), rng.random::<f32>(), rng.random::<f32>()];
            (rng.random_range(0.1..0.9), rng.random_range(0.1..0.9), c)
        })
        .collect();
    let grain = Fbm::new(rng, 2, 32, 2);
    paint(size, |u, v| {
        let edge = u.min(1.0 - u).min(v).min(1.0 - v);
        if edge < 0.06 {
            return shade(frame, 0.8 + 0.3 * grain.at(u, v) - if edge > 0.05 { 0.25 } else { 0.0 });
        }
        let c = if variant % 2 == 0 {
            let horizon = 0.55 + 0.15 * (hills.at(u, 0.0) - 0.5) * 2.0;
            let (du, dv) = (u - sun[0], v - sun[1]);
            if v > horizon {
                shade(land, 0.9 + 0.3 * (v - horizon))
            } else if du * du + dv * dv < 0.004 {
                [1.0, 0.95, 0.8]
            } else {
                mix(sky, [0.95, 0.92, 0.88], v / horizon * 0.6)
            }
        } else {
            // Nearest block seed wins: a Voronoi patchwork with dark borders.
            let mut best = (f32::MAX, f32::MAX, [0.0; 3]);
            for &(bu, bv, c) in &blocks {
                let d = (u - bu).abs().max((v - bv).abs());
                if d < best.0 {
                    best = (d, best.0, c);
                } else if d < best.1 {
                    best.1 = d;
                }
            }
            if best.1 - best.0 < 0.01 { [0.1, 0.1, 0.1] } else { best.2 }
        };
        shade(c, 0.92 + 0.12 * brush.at(u, v))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::SURFACES;

    #[test]
    fn every_surface_bakes_and_unknown_does_not() {
        for s in SURFACES {
            let t = bake(s, 0).unwrap_or_else(|| panic!("{s} has no texture"));
            assert_eq!(t.rgba8.len(), (TEXTURE_SIZE * TEXTURE_SIZE * 4) as usize);
            assert_eq!(&t.png[1..4], b"PNG");
        }
        assert!(bake("velvet", 0).is_none());
    }

    /// The PNG is encoded on first read only, decodes to the texture's pixels, and is shared
    /// by the cache's clones (one encoding per texture and process).
    #[test]
    fn png_is_encoded_on_first_read_and_holds_the_pixels() {
        let t = bake("tile_floor", 5).unwrap();
        assert_eq!(format!("{:?}", t.png), "Png(not yet encoded)");
        let copy = t.png.clone();
        let decoded = image::load_from_memory(&t.png).unwrap().to_rgb8();
        assert_eq!(decoded.dimensions(), (TEXTURE_SIZE, TEXTURE_SIZE));
        let rgb: Vec<u8> = t.rgba8.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
        assert_eq!(decoded.into_raw(), rgb);
        assert!(format!("{copy:?}").ends_with(" bytes)"), "a clone shares the encoding: {copy:?}");
        assert!(std::ptr::eq(copy.as_ptr(), t.png.as_ptr()));
        assert_eq!(&*Png::from(b"bytes".to_vec()), b"bytes");
    }

    #[test]
    fn textures_are_not_flat_and_variants_differ() {
        for s in SURFACES {
            let a = baked(s, 0).unwrap();
            let (lo, hi) = a.rgba8.chunks(4).fold((255u8, 0u8), |(lo, hi), p| (lo.min(p[1]), hi.max(p[1])));
            assert!(hi > lo, "{s} is a flat colour");
            let b = baked(s, 1).unwrap();
            assert_ne!(a.rgba8, b.rgba8, "{s} variants 0 and 1 are identical");
        }
    }

    #[test]
    fn cache_returns_the_same_bytes_as_a_fresh_bake() {
        let cached = baked("wood_floor", 3).unwrap();
        let again = baked("wood_floor", 3 + VARIANTS).unwrap();
        assert!(Arc::ptr_eq(&cached, &again));
        assert_eq!(*cached, bake("wood_floor", 3).unwrap());
    }

    /// Tileable: the left column continues the right one, and the top row the bottom one,
    /// about as smoothly as neighbouring columns inside the image do.
    #[test]
    fn textures_tile_seamlessly() {
        let n = TEXTURE_SIZE as usize;
        for s in ["paint", "carpet", "metal", "leather", "soil", "ceiling"] {
            let t = bake(s, 2).unwrap();
            let g = |x: usize, y: usize| f32::from(t.rgba8[(y * n + x) * 4 + 1]);
            let col_diff = |a: usize, b: usize| (0..n).map(|y| (g(a, y) - g(b, y)).abs()).sum::<f32>();
            let row_diff = |a: usize, b: usize| (0..n).map(|x| (g(x, a) - g(x, b)).abs()).sum::<f32>();
            let inside = col_diff(n / 2, n / 2 + 1).max(row_diff(n / 2, n / 2 + 1)) + n as f32;
            assert!(col_diff(n - 1, 0) < 2.0 * inside, "{s}: seam between right and left edges");
            assert!(row_diff(n - 1, 0) < 2.0 * inside, "{s}: seam between bottom and top edges");
        }
    }
}
