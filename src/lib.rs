//! scene-gen: seeded indoor environments and a physical camera simulator, for designing
//! cameras for a task.
//!
//! The pipeline of DESIGN.md and the module that owns each stage:
//!
//! ```text
//! seed + envelope ─► floorplan ─► structure ─► placement ─► decor, lights ─► Scene ─┬─► export: glTF/GLB, OBJ, USD, plan.png
//!  (config)          (library:    walls,       (library:    day / night          │
//!                     rooms/)     thresholds    furniture/)                      ├─► trajectory: the agent's walk
//!                                                                                └─► render (obvhs BVH): radiance per light group,
//!                                                                                      depth, instance ids
//!                                                      camera_spec + sensor catalog ──► radiometry: nit → lux → photons → e-
//!                                                                                      → sensor noise model → DN
//!                                                                                    ──► detection (AP), orb (features)
//! measured data (EMVA 1288, CSV) ─► calibration ─► gap workflow ─► sensor model (TOML)
//! ```
//!
//! Generation:
//! * [`config`]: what is asked for ([`config::GeneratorConfig`]) and its validation.
//! * [`library`]: the room-type and furniture libraries (embedded, or folders at run time).
//! * [`generate`]: runs the stages in order and returns a [`scene::Scene`].
//! * [`floorplan`], [`structure`], [`placement`], [`decor`], [`lights`]: the stages.
//! * [`assets`]: furniture OBJ meshes (read with tobj) turned into scene meshes.
//! * [`materials`]: named surfaces to PBR materials with seeded procedural textures
//!   ([`textures`]).
//! * [`scene`]: the hub type; [`manifest`]: its `scene.json` form.
//! * [`export`]: glTF/GLB, OBJ, USD (through usd-core), the plan picture, atomic writes.
//!
//! Camera simulation:
//! * [`camera_spec`]: camera candidates (sensor, lens, mounting, exposure) from TOML or the
//!   inline `SENSOR,key=value` form, resolved against the catalog.
//! * [`house`]: a seeded house with the agent's walk, where render, evaluate and dataset start.
//! * [`trajectory`]: the agent's walk through every room and door (the evaluator's poses).
//! * [`render`]: the CPU ray tracer (radiance per light group, depth, instance/class ids).
//! * [`optics`]: diffraction, defocus and motion blur of the sensor-plane irradiance.
//! * [`radiometry`]: scene luminance to sensor illuminance, photons, electrons and DN.
//! * [`sensor`]: the sensor catalog and the EMVA 1288 noise model (photons to DN), shared by the
//!   renderer, the calibration and the gap workflow.
//!
//! Tasks and measurement:
//! * [`detection`]: ground truth from instance buffers, the built-in detectability model,
//!   COCO evaluation (pycocotools-exact AP) and threshold visibility.
//! * [`orb`]: OpenCV-compatible ORB features, cross-checked matching, RANSAC inliers.
//! * [`evaluate`]: a camera candidate's TaCOS scores (threshold accuracy, AP@0.5, ORB inliers)
//!   and fitness over seeded houses (`scene-gen evaluate`), cached per process.
//! * [`calibration`]: EMVA 1288 descriptors and photon-transfer CSVs to measured sensor
//!   parameters (`scene-gen calibrate`).
//! * [`gap`]: the sim-vs-measured gap workflow (`scene-gen gap`): names the effects the sensor
//!   model misses and adds them.
//! * [`dataset`]: COCO datasets (images, depth, instance masks, RLE annotations) over seed
//!   ranges, resumable and sharded across machines (`scene-gen dataset`).
//! * [`target`]: the same gap loop for images of a test chart (`scene-gen target`): lens blur,
//!   motion blur, illumination fall-off and single-frame noise effects.
//!
//! Design:
//! * [`optimize`]: the TaCOS genetic algorithm and a random-search baseline over camera genes
//!   (`scene-gen optimize`), resumable; [`plot`] draws its training curve.
//! * [`serve`]: the evaluator as a JSON-lines server any optimizer can drive (`scene-gen serve`).
//!
//! Speed:
//! * [`simd`]: run-time choice of an AVX2 + FMA clone of the render and sensor hot loops
//!   (bit-identical output; `SCENE_GEN_NO_SIMD=1` forces the baseline).
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
pub mod camera_spec;
pub mod config;
pub mod dataset;
pub mod decor;
pub mod detection;
pub mod evaluate;
pub mod export;
pub mod floorplan;
pub mod gap;
pub mod generate;
pub mod house;
pub mod isp;
pub mod library;
pub mod lights;
pub mod manifest;
pub mod materials;
pub mod optics;
pub mod optimize;
pub mod orb;
pub mod placement;
pub mod plot;
pub mod radiometry;
pub mod render;
pub mod rng;
pub mod scene;
pub mod seeds;
pub mod sensor;
pub mod serve;
pub mod simd;
pub mod structure;
pub mod target;
pub mod textures;
pub mod trajectory;
