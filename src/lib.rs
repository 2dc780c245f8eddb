//! scene-gen: seeded indoor environments and a physical camera simulator, for designing
//! cameras for a task.
//!
//! The pipeline of DESIGN.md and the module that owns each stage:
//!
//! ```text
//! seed + envelope ─► floorplan ─► structure ─► placement ─► lights ─► Scene ─┬─► export (glTF/GLB, plan.png)
//!  (config)          (rooms/)     walls,       (furniture/)  day/night        │
//!                                 thresholds                                  └─► renderer, evaluator, ...
//! ```
//!
//! * [`config`]: what is asked for ([`config::GeneratorConfig`]) and its validation.
//! * [`library`]: the room-type and furniture libraries (embedded, or folders at run time).
//! * [`generate`]: runs the stages in order and returns a [`scene::Scene`].
//! * [`floorplan`], [`structure`], [`placement`], [`decor`], [`lights`]: the stages.
//! * [`assets`]: furniture OBJ meshes (read with tobj) turned into scene meshes.
//! * [`materials`]: named surfaces to PBR materials with seeded procedural textures
//!   ([`textures`]).
//! * [`scene`]: the hub type; [`manifest`]: its `scene.json` form.
//! * [`export`]: glTF/GLB, the plan picture, atomic writes.
//! * [`render`]: the CPU ray tracer (radiance per light group, depth, instance/class ids).
//! * [`sensor`]: the sensor catalog and the EMVA 1288 noise model (photons to DN), shared by the
//!   renderer, the calibration and the gap workflow.
//! * [`calibration`]: EMVA 1288 descriptors and photon-transfer CSVs to measured sensor
//!   parameters (`scene-gen calibrate`).
//! * [`gap`]: the sim-vs-measured gap workflow (`scene-gen gap`): names the effects the sensor
//!   model misses and adds them.
//!
//! ```no_run
//! use scene_gen::{config::GeneratorConfig, generate::generate, library::Library};
//! let library = Library::embedded()?;
//! let scene = generate(&GeneratorConfig { seed: 7, ..GeneratorConfig::default() }, &library)?;
//! println!("{} rooms, {} objects", scene.rooms.len(), scene.objects.len());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod assets;
pub mod calibration;
pub mod config;
pub mod decor;
pub mod export;
pub mod floorplan;
pub mod gap;
pub mod generate;
pub mod library;
pub mod lights;
pub mod manifest;
pub mod materials;
pub mod orb;
pub mod placement;
pub mod render;
pub mod rng;
pub mod scene;
pub mod sensor;
pub mod structure;
pub mod textures;
