//! The generator: seed and libraries in, [`Scene`] out.
//!
//! Stages run in a fixed order, each drawing from its own seeded stream (see [`scene_gen_core::rng`]):
//! floorplan, structure (floors, ceilings, walls, windows, thresholds), furniture placement,
//! door leaves, decor (small things on tables, rugs, curtains, pictures), lights.

use crate::config::{ConfigError, GeneratorConfig};
use crate::floorplan::{self, FloorplanError};
use crate::library::Library;
use crate::materials::MaterialCatalog;
use crate::placement::{self, PlacementError};
use crate::scene::{Geometry, HouseRecord, Scene};
use crate::{decor, doors, lights, structure};

/// Why a scene could not be generated.
#[derive(Debug, thiserror::Error)]
pub enum GenerateError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("floorplan: {0}")]
    Floorplan(#[from] FloorplanError),
    #[error("structure: {0}")]
    Structure(#[from] structure::StructureError),
    #[error("furniture placement: {0}")]
    Placement(#[from] PlacementError),
}

/// Generates the house for `config` from `library`.
pub fn generate(config: &GeneratorConfig, library: &Library) -> Result<Scene, GenerateError> {
    config.validate()?;
    let started = std::time::Instant::now();
    let mut geometry = Geometry::default();
    let mut materials = MaterialCatalog::new(config.seed);
    let mut plan = floorplan::generate(config, &library.rooms)?;
    let thresholds = structure::build(config, &plan, &library.rooms, &mut materials, &mut geometry)?;
    let first_object_instance = thresholds.iter().map(|t| t.instance_id).max().unwrap_or(0) + 1;
    let placement::Placement { objects, furnishings, table_tops, .. } = placement::place_detailed(
        config,
        &plan,
        &thresholds,
        library,
        first_object_instance,
        &mut materials,
        &mut geometry,
    )?;
    let mut furniture: Vec<_> =
        objects.iter().map(|o| (o.min, o.max)).chain(furnishings.iter().map(|f| (f.min, f.max))).collect();
    let leaves = doors::build(config, &plan, &furniture, &mut materials, &mut geometry);
    for (door, leaf) in plan.doors.iter_mut().zip(leaves) {
        door.leaf = leaf;
    }
    // Pictures keep clear of leaves as of furniture.
    furniture.extend(plan.doors.iter().filter_map(|d| d.leaf).map(|leaf| doors::bounds(&leaf)));
    decor::build(config, &plan, &furniture, &table_tops, &mut materials, &mut geometry);
    let lights = lights::build(config, &plan, &objects);
    log::info!(
        "house {}: {} rooms, {} doors, {} objects, {} furnishings, {} mesh triangles in {:.0} ms",
        config.seed,
        plan.rooms.len(),
        plan.doors.len(),
        objects.len(),
        furnishings.len(),
        geometry.meshes.iter().map(|m| m.primitives.iter().map(|p| p.indices.len() / 3).sum::<usize>()).sum::<usize>(),
        started.elapsed().as_secs_f64() * 1e3
    );
    Ok(Scene {
        seed: config.seed,
        envelope: config.envelope,
        wall_thickness_m: config.wall_thickness_m,
        house: HouseRecord {
            min_room_m: config.min_room_m,
            rooms: library.rooms_id.clone(),
            furniture: library.furniture_id.clone(),
        },
        palette: materials.palette(),
        rooms: plan.rooms,
        walls: plan.walls,
        doors: plan.doors,
        windows: plan.windows,
        thresholds,
        objects,
        furnishings,
        lights,
        geometry,
    })
}
