//! scene-gen: seeded indoor environments and a physical camera simulator, for designing
//! cameras for a task.
//!
//! This crate is the facade: it re-exports every stage's modules under one name, so users of
//! the library write `scene_gen::render::Renderer` whichever crate holds it. The stages are
//! crates of their own, each depending only on the ones before it:
//!
//! ```text
//! scene-gen-core        rng, seeds, simd, io, stats
//! scene-gen-scene       seed + envelope ─► floorplan ─► structure ─► placement ─► lights ─► Scene ─► trajectory
//! scene-gen-export      Scene ─► glTF/GLB, OBJ, USD, plan.png
//! scene-gen-trace       triangles ─► BVH ─► hits (single rays and packets)
//! scene-gen-render      Scene + pinhole ─► radiance per light group, depth, instance and class ids
//! scene-gen-camera      camera spec + catalog: radiance ─► optics ─► photons ─► e- ─► noise ─► DN ─► ISP
//! scene-gen-perception  frames ─► ORB features and matches, detections, COCO AP, thresholds seen
//! scene-gen-measure     EMVA 1288 data ─► calibration ─► gap workflow ─► sensor model; test charts
//! scene-gen-design      evaluate (fitness by day and night), optimize (GA), serve, dataset
//! ```
//!
//! Where each module comes from:
//! * scene-gen-core: [`rng`], [`seeds`], [`simd`], [`io`], [`stats`].
//! * scene-gen-scene: [`config`], [`library`], [`assets`], [`materials`], [`textures`],
//!   [`generate`], [`floorplan`], [`structure`], [`placement`], [`procedural`], [`decor`], [`lights`],
//!   [`scene`], [`manifest`], [`trajectory`], [`house`].
//! * scene-gen-export: [`export`]. scene-gen-trace: [`trace`]. scene-gen-render: [`render`].
//! * scene-gen-camera: [`camera_spec`], [`sensor`], [`optics`], [`radiometry`], [`isp`],
//!   [`demosaic`], [`develop`], [`capture`].
//! * scene-gen-perception: [`orb`], [`detection`].
//! * scene-gen-measure: [`calibration`], [`gap`], [`target`].
//! * scene-gen-design: [`evaluate`], [`optimize`], [`serve`], [`dataset`], [`plot`].
//!
//! ```no_run
//! use scene_gen::{config::GeneratorConfig, generate::generate, library::Library};
//! let library = Library::embedded()?;
//! let scene = generate(&GeneratorConfig { seed: 7, ..GeneratorConfig::default() }, &library)?;
//! println!("{} rooms, {} objects", scene.rooms.len(), scene.objects.len());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub use scene_gen_camera::{
    bayer, camera_spec, capture, colour_checker, demosaic, develop, isp, optics, path, radiometry, sensor, spectral,
    view,
};
pub use scene_gen_core::{io, rng, seeds, simd, stats};
pub use scene_gen_design::{dataset, evaluate, optimize, plot, progress, serve, true_matches};
pub use scene_gen_export as export;
pub use scene_gen_measure::{calibration, gap, target};
pub use scene_gen_perception::{detection, orb};
pub use scene_gen_render as render;
pub use scene_gen_scene::{
    assets, config, decor, floorplan, generate, house, library, lights, manifest, materials, placement, procedural,
    scene, structure, textures, trajectory,
};
pub use scene_gen_trace as trace;
