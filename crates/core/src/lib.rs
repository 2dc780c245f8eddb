//! What every stage of scene-gen shares and nothing else: the seeded random streams that make
//! each stage a pure function of its seed ([`rng`]), seed ranges as the command line takes them
//! ([`seeds`]), the run-time choice of the AVX2 build of the hot loops ([`simd`]), atomic file
//! writes ([`io`]) and the normal distribution's tails ([`stats`]).
//!
//! ```
//! use rand::Rng;
//! let mut a = scene_gen_core::rng::stream(7, "floorplan");
//! let mut b = scene_gen_core::rng::stream(7, "floorplan");
//! assert_eq!(a.random::<u64>(), b.random::<u64>());
//! ```

pub mod io;
pub mod rng;
pub mod seeds;
pub mod simd;
pub mod stats;
