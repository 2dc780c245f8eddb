//! Parametric furniture: every object of a house gets a shape of its own.
//!
//! A [`Generator`] is a family of shapes for one object class (a sofa, a dining chair, a
//! potted plant). It draws continuous proportions and discrete parts and styles (legs or a
//! plinth, arm shapes, cushions, headboards, tub outlines, pot forms, leaves placed one by one)
//! from a random stream and builds the mesh from boxes, frusta, ellipsoids and shells
//! ([`builder::MeshBuilder`]), with texture coordinates and one material slot per surface.
//! The result is scaled to the size placement drew, exactly, so the manifest box is the mesh's.
//!
//! Furniture class files name a generator with `generator = "<name>"` in place of
//! `obj = "<stem>"` (see [`crate::library::furniture`]). Placement draws the size of each
//! object, then one 64-bit shape seed, and calls [`Generator::generate`]: the shape depends on
//! that seed and the size alone, so a house is byte-identical for its seed and no two objects
//! share a mesh.
//!
//! The families follow the pieces of the reference system's furniture sets and of common
//! procedural generators (Infinigen Indoors builds every asset from such part grammars); the
//! proportions are those of ordinary furniture (seat heights 0.40-0.48 m, table tops at
//! 0.72-0.76 m, mattress tops at about 0.5 m).

pub mod builder;

mod bath;
mod beds;
mod furnishings;
pub(crate) use furnishings::{SMALL_THING_REACH_M, small_thing};
mod lamps;
mod plants;
mod screens;
mod seating;
mod tables;
mod toys;

use glam::Vec3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;

use crate::assets::AssetMesh;
use crate::scene::{FurnishingKind, Kind, ObjectClass};
use builder::MeshBuilder;

/// Builds a shape of roughly `size` (width x, depth y, height z, metres) from `rng`.
type Build = fn(Vec3, &mut ChaCha8Rng) -> MeshBuilder;

/// One family of shapes.
#[derive(Clone, Copy)]
pub struct Generator {
    /// The name class files use (`generator = "sofa"`).
    pub name: &'static str,
    /// The class (or furnishing) the shapes belong to.
    pub class: Kind,
    build: Build,
}

impl std::fmt::Debug for Generator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Generator").field("name", &self.name).field("class", &self.class).finish()
    }
}

impl PartialEq for Generator {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

/// Every generator, by class.
pub const GENERATORS: &[Generator] = &[
    Generator { name: "sofa", class: Kind::Object(ObjectClass::Sofa), build: seating::sofa },
    Generator { name: "sofa_corner", class: Kind::Object(ObjectClass::Sofa), build: seating::sofa_corner },
    Generator { name: "bed", class: Kind::Object(ObjectClass::Bed), build: beds::bed },
    Generator { name: "table_dining", class: Kind::Object(ObjectClass::Table), build: tables::dining },
    Generator { name: "table_round", class: Kind::Object(ObjectClass::Table), build: tables::round },
    Generator { name: "table_desk", class: Kind::Object(ObjectClass::Table), build: tables::desk },
    Generator { name: "table_coffee", class: Kind::Object(ObjectClass::Table), build: tables::coffee },
    Generator { name: "chair_dining", class: Kind::Object(ObjectClass::Chair), build: seating::dining_chair },
    Generator { name: "chair_stool", class: Kind::Object(ObjectClass::Chair), build: seating::stool },
    Generator { name: "chair_arm", class: Kind::Object(ObjectClass::Chair), build: seating::armchair },
    Generator { name: "bathtub_built_in", class: Kind::Object(ObjectClass::Bathtub), build: bath::built_in_tub },
    Generator {
        name: "bathtub_freestanding",
        class: Kind::Object(ObjectClass::Bathtub),
        build: bath::freestanding_tub,
    },
    Generator { name: "basin_pedestal", class: Kind::Object(ObjectClass::Basin), build: bath::pedestal_basin },
    Generator { name: "basin_vanity", class: Kind::Object(ObjectClass::Basin), build: bath::vanity_basin },
    Generator { name: "computer_tv", class: Kind::Object(ObjectClass::Computer), build: screens::tv },
    Generator { name: "computer_monitor", class: Kind::Object(ObjectClass::Computer), build: screens::monitor },
    Generator { name: "computer_laptop", class: Kind::Object(ObjectClass::Computer), build: screens::laptop },
    Generator { name: "plant_bush", class: Kind::Object(ObjectClass::Plant), build: plants::bush },
    Generator { name: "plant_tall", class: Kind::Object(ObjectClass::Plant), build: plants::tall },
    Generator { name: "plant_conifer", class: Kind::Object(ObjectClass::Plant), build: plants::conifer },
    Generator { name: "lamp_floor", class: Kind::Object(ObjectClass::Lamp), build: lamps::floor },
    Generator { name: "lamp_table", class: Kind::Object(ObjectClass::Lamp), build: lamps::table },
    Generator { name: "lamp_desk", class: Kind::Object(ObjectClass::Lamp), build: lamps::desk },
    Generator { name: "toy_ball", class: Kind::Object(ObjectClass::Toy), build: toys::ball },
    Generator { name: "toy_blocks", class: Kind::Object(ObjectClass::Toy), build: toys::blocks },
    Generator { name: "toy_teddy", class: Kind::Object(ObjectClass::Toy), build: toys::teddy },
    Generator { name: "toy_car", class: Kind::Object(ObjectClass::Toy), build: toys::car },
    Generator { name: "toy_stacker", class: Kind::Object(ObjectClass::Toy), build: toys::stacker },
    Generator { name: "wardrobe", class: Kind::Furnishing(FurnishingKind::Wardrobe), build: furnishings::wardrobe },
    Generator { name: "bookshelf", class: Kind::Furnishing(FurnishingKind::Bookshelf), build: furnishings::bookshelf },
    Generator {
        name: "nightstand",
        class: Kind::Furnishing(FurnishingKind::Nightstand),
        build: furnishings::nightstand,
    },
    Generator { name: "counter", class: Kind::Furnishing(FurnishingKind::Counter), build: furnishings::counter },
    Generator { name: "fridge", class: Kind::Furnishing(FurnishingKind::Fridge), build: furnishings::fridge },
    Generator { name: "stove", class: Kind::Furnishing(FurnishingKind::Stove), build: furnishings::stove },
    Generator { name: "toilet", class: Kind::Furnishing(FurnishingKind::Toilet), build: bath::toilet },
];

impl Generator {
    /// The generator called `name`.
    #[must_use]
    pub fn by_name(name: &str) -> Option<&'static Generator> {
        GENERATORS.iter().find(|g| g.name == name)
    }

    /// The shape for `shape_seed`, in the asset frame (footprint centred on the origin, resting
    /// on z = 0, front +Y) and exactly `size` in metres; with `uniform` only the height is
    /// matched and the width and depth follow the shape's own proportions.
    #[must_use]
    pub fn generate(&self, size: Vec3, uniform: bool, shape_seed: u64) -> AssetMesh {
        let mut rng = ChaCha8Rng::seed_from_u64(shape_seed);
        let mut b = (self.build)(size, &mut rng);
        b.recentre();
        let (lo, hi) = b.bounds();
        let built = (hi - lo).max(Vec3::splat(1e-4));
        let factor = if uniform { Vec3::splat(size.z / built.z) } else { size / built };
        b.scale(factor);
        let mut mesh = b.into_asset_mesh();
        // Exact box after scaling (rounding of the products aside).
        let (lo, hi) = mesh.positions().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| (lo.min(p), hi.max(p)));
        mesh.min = lo;
        mesh.max = hi;
        mesh
    }

    /// The shape placement sizes candidates by before drawing: the family's shape for a fixed
    /// seed at `size`.
    #[must_use]
    pub fn prototype(&self, size: Vec3, uniform: bool) -> AssetMesh {
        self.generate(size, uniform, 0)
    }
}

/// Small drawing helpers shared by the families.
pub(crate) trait Draw {
    /// Uniform in `[lo, hi]`.
    fn between(&mut self, lo: f32, hi: f32) -> f32;
    /// True with probability `p`.
    fn chance(&mut self, p: f64) -> bool;
    /// One of `options`, uniformly.
    fn pick<T: Copy>(&mut self, options: &[T]) -> T;
    /// Uniform integer in `lo..=hi`.
    fn count(&mut self, lo: u32, hi: u32) -> u32;
}

impl Draw for ChaCha8Rng {
    fn between(&mut self, lo: f32, hi: f32) -> f32 {
        if hi > lo { self.random_range(lo..=hi) } else { lo }
    }

    fn chance(&mut self, p: f64) -> bool {
        self.random_bool(p.clamp(0.0, 1.0))
    }

    fn pick<T: Copy>(&mut self, options: &[T]) -> T {
        options[self.random_range(0..options.len())]
    }

    fn count(&mut self, lo: u32, hi: u32) -> u32 {
        self.random_range(lo..=hi.max(lo))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_class_has_a_generator_and_names_are_unique() {
        for class in Kind::all() {
            assert!(GENERATORS.iter().any(|g| g.class == class), "no generator for {class}");
        }
        for (i, g) in GENERATORS.iter().enumerate() {
            assert!(GENERATORS[..i].iter().all(|h| h.name != g.name), "{} twice", g.name);
        }
    }

    #[test]
    fn shapes_have_the_asked_size_and_differ_by_seed() {
        for g in GENERATORS {
            let size = Vec3::new(0.9, 0.7, 0.8);
            for uniform in [false, true] {
                for seed in 3..40 {
                    check_mesh(g, &g.generate(size, uniform, seed));
                }
                let a = g.generate(size, uniform, 1);
                let b = g.generate(size, uniform, 2);
                let got = a.size();
                assert!((got.z - size.z).abs() < 1e-4, "{}: height {}", g.name, got.z);
                if !uniform {
                    assert!((got - size).abs().max_element() < 1e-4, "{}: size {got}", g.name);
                }
                assert!(a.min.z.abs() < 1e-5 && (a.min.x + a.max.x).abs() < 1e-4, "{}: not centred", g.name);
                assert_ne!(a, b, "{}: seeds 1 and 2 give one shape", g.name);
                assert_eq!(a, g.generate(size, uniform, 1), "{}: not deterministic", g.name);
                check_mesh(g, &a);
            }
        }
    }

    /// Surfaces, attribute counts, unit normals, finite positions, and every triangle
    /// counter-clockwise seen from outside (its face agrees with its first vertex's normal).
    fn check_mesh(g: &Generator, mesh: &AssetMesh) {
        for part in &mesh.parts {
            assert!(crate::materials::MaterialCatalog::is_surface(&part.surface), "{}: {}", g.name, part.surface);
            assert_eq!(part.positions.len(), part.normals.len());
            assert_eq!(part.positions.len(), part.uvs.len());
            assert!(part.indices.iter().all(|&i| (i as usize) < part.positions.len()));
            assert!(part.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-3), "{}: normal", g.name);
            assert!(part.positions.iter().all(|p| p.is_finite()), "{}: position", g.name);
            for t in part.indices.chunks_exact(3) {
                let [a, b, c] = [0, 1, 2].map(|k| part.positions[t[k] as usize]);
                let face = (b - a).cross(c - a);
                let n = part.normals[t[0] as usize];
                assert!(
                    face.dot(n) > 0.0,
                    "{} {}: triangle {a} {b} {c}, face {face}, normal {n}",
                    g.name,
                    part.surface
                );
            }
        }
    }
}
