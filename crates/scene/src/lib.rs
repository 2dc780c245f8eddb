//! A seeded house: the first stage of scene-gen.
//!
//! ```text
//! seed + envelope ─► floorplan ─► structure ─► placement ─► door leaves, decor, lights ─► Scene ─► trajectory
//!  (config)          (library:    walls,       (library:                 day / night              the agent's walk
//!                     rooms/)     thresholds    furniture/)
//! ```
//!
//! * [`config`]: what is asked for ([`config::GeneratorConfig`]) and its validation.
//! * [`library`]: the room-type and furniture libraries (embedded, or folders at run time);
//!   [`assets`] turns furniture OBJ meshes into scene meshes; [`procedural`] builds a shape of
//!   its own for every object from its class's generator.
//! * [`generate`]: runs the stages in order and returns a [`scene::Scene`].
//! * [`floorplan`], [`structure`], [`placement`], [`doors`], [`decor`], [`lights`]: the stages.
//! * [`materials`]: named surfaces to PBR materials with seeded procedural [`textures`], in
//!   the house's colour [`palette`].
//! * [`scene`]: the hub type every later stage reads; [`manifest`]: its `scene.json` form.
//! * [`trajectory`]: the agent's walk through every room and door; [`house`]: a seed's house
//!   with its walk, where rendering, evaluation and datasets start.
//!
//! ```no_run
//! use scene_gen_scene::{config::GeneratorConfig, generate::generate, library::Library};
//! let library = Library::embedded()?;
//! let scene = generate(&GeneratorConfig { seed: 7, ..GeneratorConfig::default() }, &library)?;
//! println!("{} rooms, {} objects", scene.rooms.len(), scene.objects.len());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod assets;
pub mod config;
pub mod decor;
pub mod doors;
mod floor_grid;
pub mod floorplan;
pub mod generate;
pub mod house;
pub mod library;
pub mod lights;
pub mod manifest;
pub mod materials;
pub mod palette;
pub mod placement;
pub mod procedural;
pub mod scene;
pub mod structure;
pub mod textures;
pub mod trajectory;
