//! The materials at a packet's hits, evaluated for all of them at once.
//!
//! [`super::shade::surface_response`] evaluates one hit: the material, its texture, four
//! texels through the sRGB table, each load waiting on the one before. Over a packet of hits
//! (one lane per ray, structure of arrays) the same work is split in steps: each lane's
//! material is read from a table prepared once per renderer ([`MaterialTable`]), the texel
//! addresses and bilinear weights of all lanes are computed in plain loops that the compiler
//! vectorises, the texels are fetched lane by lane (the loads of different lanes overlap), and
//! the filtering and the metal split run in vector loops again. The numbers are
//! `surface_response`'s, bit for bit (a test checks).

// Lane loops index several arrays by lane: the form the vectoriser takes (`scene_gen_trace::lanes`).
#![allow(clippy::needless_range_loop)]

use super::accel::Surfaces;
use super::shade::{SurfaceResponse, srgb_table, texels};
use scene_gen_scene::scene::Scene;
use scene_gen_trace::lanes::{Lanes, Lanes3, N, bits, lane3, select};

/// No texture (a lane's texture index).
const NO_TEXTURE: u32 = u32::MAX;

/// What `surface_response` reads of a material, resolved once.
#[derive(Clone, Copy, Debug)]
struct Prepared {
    /// Linear RGB factor.
    base: [f32; 3],
    /// Index into [`MaterialTable::textures`], or [`NO_TEXTURE`] (none, or one whose buffer is
    /// shorter than its size: white, as `sample_texture` has it).
    texture: u32,
    /// The fraction reflected as by a mirror: `metallic (1 - roughness)`.
    specular_fraction: f32,
    roughness: f32,
}

/// A missing material: the mid-grey Lambertian of `surface_response`.
const MISSING: Prepared = Prepared { base: [0.5; 3], texture: NO_TEXTURE, specular_fraction: 0.0, roughness: 1.0 };

/// A texture's sRGB-encoded RGBA8 texels and size.
#[derive(Clone, Copy, Debug)]
struct Image<'a> {
    texels: &'a [u8],
    width: u32,
    height: u32,
}

/// A scene's materials and textures as the packet evaluation reads them.
#[derive(Clone, Debug)]
pub(crate) struct MaterialTable<'a> {
    materials: Vec<Prepared>,
    textures: Vec<Image<'a>>,
}

impl<'a> MaterialTable<'a> {
    /// The table of `scene`'s materials.
    #[must_use]
    pub fn new(scene: &'a Scene) -> MaterialTable<'a> {
        let mut textures = Vec::new();
        let materials = scene
            .geometry
            .materials
            .iter()
            .map(|m| {
                let metallic = m.metallic.clamp(0.0, 1.0);
                let roughness = if m.roughness.is_finite() { m.roughness.clamp(0.0, 1.0) } else { 1.0 };
                let image = m.base_color_texture.and_then(|i| scene.geometry.textures.get(i)).and_then(|t| {
                    let (w, h) = (t.width as usize, t.height as usize);
                    let texels = texels(t);
                    (w > 0 && h > 0 && texels.len() >= w * h * 4).then_some(Image {
                        texels,
                        width: t.width,
                        height: t.height,
                    })
                });
                let texture = match image {
                    Some(image) => {
                        textures.push(image);
                        textures.len() as u32 - 1
                    }
                    None => NO_TEXTURE,
                };
                Prepared {
                    base: [m.base_color[0], m.base_color[1], m.base_color[2]],
                    texture,
                    specular_fraction: metallic * (1.0 - roughness),
                    roughness,
                }
            })
            .collect();
        MaterialTable { materials, textures }
    }

    /// The material response at every lane of `surfaces` with a hit, into `out` (other lanes:
    /// stale numbers).
    #[inline(always)]
    pub fn evaluate(&self, surfaces: &Surfaces, out: &mut Responses) {
        let mut lanes = MaterialLanes::default();
        for k in bits(surfaces.lanes) {
            let m = self.materials.get(surfaces.material[k] as usize).unwrap_or(&MISSING);
            for c in 0..3 {
                lanes.base[c][k] = m.base[c];
            }
            lanes.specular_fraction[k] = m.specular_fraction;
            out.roughness[k] = m.roughness;
            let uv_finite = surfaces.uv[0][k].is_finite() && surfaces.uv[1][k].is_finite();
            if let Some(image) = self.textures.get(m.texture as usize)
                && uv_finite
            {
                lanes.texture[k] = m.texture;
                lanes.size[0][k] = image.width as i32;
                lanes.size[1][k] = image.height as i32;
                lanes.textured |= 1 << k;
            }
        }
        let footprint = lanes.footprints(surfaces);
        let mut texel = [[[1.0f32; N]; 3]; 4];
        let lut = srgb_table();
        for k in bits(lanes.textured) {
            let bytes = self.textures[lanes.texture[k] as usize].texels;
            for (corner, texel) in texel.iter_mut().enumerate() {
                // One load per texel, RGBA from the lowest byte.
                let at = footprint.offset[corner][k] as usize;
                let rgba = match bytes.get(at..at + 4) {
                    Some(&[r, g, b, a]) => u32::from_le_bytes([r, g, b, a]),
                    _ => u32::MAX,
                };
                for (c, channel) in texel.iter_mut().enumerate() {
                    channel[k] = lut[(rgba >> (8 * c) & 0xFF) as usize];
                }
            }
        }
        let mut textured = [false; N];
        for k in 0..N {
            textured[k] = lanes.textured >> k & 1 == 1;
        }
        let (fx, fy) = (&footprint.weight[0], &footprint.weight[1]);
        for c in 0..3 {
            let [t00, t10, t01, t11] = [&texel[0][c], &texel[1][c], &texel[2][c], &texel[3][c]];
            let (base, diffuse, specular) = (&lanes.base[c], &mut out.diffuse[c], &mut out.specular[c]);
            for k in 0..N {
                // glam's `lerp`: `a (1 - s) + b s`, across, then down.
                let top = t00[k] * (1.0 - fx[k]) + t10[k] * fx[k];
                let bottom = t01[k] * (1.0 - fx[k]) + t11[k] * fx[k];
                let filtered = top * (1.0 - fy[k]) + bottom * fy[k];
                // glam's `clamp`: `max(min).min(max)`, which takes a NaN to 0 where
                // `f32::clamp` keeps it.
                #[allow(clippy::manual_clamp)]
                let rho = select(textured[k], base[k] * filtered, base[k]).max(0.0).min(1.0);
                let s = lanes.specular_fraction[k];
                diffuse[k] = rho * (1.0 - s);
                specular[k] = rho * s;
            }
        }
    }
}

/// A lane's material before its texture is sampled.
struct MaterialLanes {
    base: Lanes3,
    specular_fraction: Lanes,
    /// Lanes with a texture to sample (and finite texture coordinates).
    textured: u64,
    texture: [u32; N],
    /// Width and height of the lane's texture, texels.
    size: [[i32; N]; 2],
}

impl Default for MaterialLanes {
    fn default() -> Self {
        MaterialLanes {
            base: [[0.0; N]; 3],
            specular_fraction: [0.0; N],
            textured: 0,
            texture: [NO_TEXTURE; N],
            size: [[1; N]; 2],
        }
    }
}

/// The bilinear footprint of each lane's texture lookup.
struct Footprint {
    /// Byte offsets of the four texels: top-left, top-right, bottom-left, bottom-right.
    offset: [[u32; N]; 4],
    /// Weights of the right and the bottom texels.
    weight: [Lanes; 2],
}

impl MaterialLanes {
    /// The texels and weights of `sample_texture` at each lane's texture coordinates, with
    /// its arithmetic (repeat wrap, texel centres at half-integers).
    #[inline(always)]
    fn footprints(&self, surfaces: &Surfaces) -> Footprint {
        let mut f = Footprint { offset: [[0; N]; 4], weight: [[0.0; N]; 2] };
        // Per axis, the texel index of the near and the far side.
        let mut index = [[[0i32; N]; 2]; 2];
        for axis in 0..2 {
            let (uv, size, weight) = (&surfaces.uv[axis], &self.size[axis], &mut f.weight[axis]);
            let [near, far] = &mut index[axis];
            for k in 0..N {
                let (u, n) = (uv[k], size[k]);
                let x = (u - u.floor()) * n as f32 - 0.5;
                let x0 = x.floor();
                weight[k] = x - x0;
                // `x` is in [-0.5, n - 0.5], so `x0` is in -1..n and one wrap brings `x0` and
                // `x0 + 1` into 0..n (`shade::wrap_once`). Lanes without a texture compute
                // nonsense here, unread.
                // SAFETY: clamped into -1..=n, the value is finite and fits an `i32`: the
                // unchecked conversion is one vector instruction where `as` (saturating, NaN
                // to 0) was a scalar sequence per lane. On the lanes that sample, `x0` is in
                // range already and the clamp changes nothing.
                let i = unsafe { x0.max(-1.0).min(n as f32).to_int_unchecked::<i32>() };
                near[k] = wrap_once(i, n);
                far[k] = wrap_once(i + 1, n);
            }
        }
        let [[x0, x1], [y0, y1]] = &index;
        let w = &self.size[0];
        for k in 0..N {
            f.offset[0][k] = ((y0[k] * w[k] + x0[k]) * 4) as u32;
            f.offset[1][k] = ((y0[k] * w[k] + x1[k]) * 4) as u32;
            f.offset[2][k] = ((y1[k] * w[k] + x0[k]) * 4) as u32;
            f.offset[3][k] = ((y1[k] * w[k] + x1[k]) * 4) as u32;
        }
        f
    }
}

/// `i.rem_euclid(n)` for `i` in `-n..2 * n`: `shade::wrap_once` in the lanes' integers (a
/// function, not a closure: see `scene_gen_core::simd`).
#[inline(always)]
fn wrap_once(i: i32, n: i32) -> i32 {
    let i = if i < 0 { i + n } else { i };
    if i >= n { i - n } else { i }
}

/// The material responses of a packet's hits, one lane per ray, structure of arrays.
pub(crate) struct Responses {
    pub diffuse: Lanes3,
    pub specular: Lanes3,
    pub roughness: Lanes,
}

impl Default for Responses {
    fn default() -> Self {
        Responses { diffuse: [[0.0; N]; 3], specular: [[0.0; N]; 3], roughness: [0.0; N] }
    }
}

impl Responses {
    /// Lane `k` as one [`SurfaceResponse`].
    #[must_use]
    #[inline(always)]
    pub fn get(&self, k: usize) -> SurfaceResponse {
        SurfaceResponse {
            diffuse: lane3(&self.diffuse, k),
            specular: lane3(&self.specular, k),
            roughness: self.roughness[k],
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::accel::Accel;
    use crate::accel::Hit;
    use crate::shade::surface_response;

    /// House 3 (textured floors, walls and furniture, metals) and its BVH, built once.
    fn house() -> &'static (Scene, Accel) {
        static HOUSE: std::sync::OnceLock<(Scene, Accel)> = std::sync::OnceLock::new();
        HOUSE.get_or_init(|| {
            let library = scene_gen_scene::house::embedded_library().unwrap();
            let params = scene_gen_scene::trajectory::TrajectoryParams::default();
            let scene = scene_gen_scene::house::walked_house(&library, 3, &params).unwrap().scene;
            let accel = Accel::build(&scene);
            (scene, accel)
        })
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// Every lane of a packet gets `surface_response`'s numbers bit for bit, whatever its
        /// texture coordinates (far from the origin, negative, on texel edges) and material
        /// (textured, plain, metal, missing).
        #[test]
        fn responses_of_a_packet_are_those_of_each_hit(
            uvs in proptest::collection::vec((-300.0f32..300.0, -300.0f32..300.0), N),
            materials in proptest::collection::vec(0u32..12, N),
        ) {
            let (scene, accel) = house();
            let table = MaterialTable::new(scene);
            let count = scene.geometry.materials.len() as u32;
            // Any hit will do for the lanes' layout; the test overwrites what it varies.
            let hit = Hit { t: 1.0, triangle: 0, b1: 0.25, b2: 0.25 };
            let mut surfaces = Surfaces::default();
            accel.surfaces(&[Some(hit); N], N, Vec3::ZERO, &[[0.0; N], [0.0; N], [1.0; N]], &mut surfaces);
            for k in 0..N {
                // Every fourth lane: an exact texel edge; two in a packet: no finite
                // coordinates; material 11: past the end (missing).
                let (u, v) = match k % 32 {
                    1 => (f32::NAN, 0.5),
                    17 => (0.5, f32::INFINITY),
                    _ if k % 4 == 0 => (uvs[k].0.round() / 256.0, 0.5 / 256.0),
                    _ => uvs[k],
                };
                (surfaces.uv[0][k], surfaces.uv[1][k]) = (u, v);
                surfaces.material[k] = if materials[k] == 11 { count + 5 } else { materials[k] * 7 % count };
            }
            let mut out = Responses::default();
            table.evaluate(&surfaces, &mut out);
            for k in 0..N {
                let alone = surface_response(scene, &surfaces.point(k));
                let got = out.get(k);
                let bits = |r: &SurfaceResponse| {
                    (r.diffuse.to_array().map(f32::to_bits), r.specular.to_array().map(f32::to_bits), r.roughness.to_bits())
                };
                proptest::prop_assert_eq!(bits(&got), bits(&alone), "lane {}", k);
            }
        }
    }
}
