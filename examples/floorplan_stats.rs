//! Floorplan statistics over many seeds: room counts, room types, openings, distinct layouts,
//! and the time per floorplan and per generated house (structure included).
//!
//! ```text
//! cargo run --release --example floorplan_stats -- [SEEDS] [WIDTHxDEPTHxHEIGHT]
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use scene_gen::config::GeneratorConfig;
use scene_gen::floorplan;
use scene_gen::generate::generate;
use scene_gen::library::Library;
use scene_gen::scene::Envelope;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let seeds: u64 = args.next().map_or(Ok(1000), |s| s.parse())?;
    let envelope = match args.next() {
        Some(spec) => {
            let v: Vec<f32> = spec.split('x').map(str::parse).collect::<Result<_, _>>()?;
            let [width_m, depth_m, height_m] = v[..] else { return Err("envelope is WIDTHxDEPTHxHEIGHT".into()) };
            Envelope { width_m, depth_m, height_m }
        }
        None => Envelope::default(),
    };
    let library = Library::embedded()?;
    let base = GeneratorConfig { envelope, ..GeneratorConfig::default() };

    let mut counts = BTreeMap::new();
    let mut types = BTreeMap::new();
    let mut layouts = BTreeSet::new();
    let (mut doors, mut exterior_doors, mut windows) = (0usize, 0usize, 0usize);
    let start = Instant::now();
    for seed in 0..seeds {
        let plan = floorplan::generate(&GeneratorConfig { seed, ..base.clone() }, &library.rooms)?;
        *counts.entry(plan.rooms.len()).or_insert(0u32) += 1;
        for r in &plan.rooms {
            *types.entry(r.room_type.clone()).or_insert(0u32) += 1;
        }
        layouts.insert(format!("{:?}", plan.rooms.iter().map(|r| (r.min, r.max)).collect::<Vec<_>>()));
        doors += plan.doors.len();
        exterior_doors += plan.doors.iter().filter(|d| d.rooms[1].is_none()).count();
        windows += plan.windows.len();
    }
    let plan_us = start.elapsed().as_secs_f64() * 1e6 / seeds as f64;
    let start = Instant::now();
    let mut triangles = 0usize;
    for seed in 0..seeds {
        let scene = generate(&GeneratorConfig { seed, ..base.clone() }, &library)?;
        triangles +=
            scene.geometry.meshes.iter().flat_map(|m| &m.primitives).map(|p| p.indices.len() / 3).sum::<usize>();
    }
    let scene_us = start.elapsed().as_secs_f64() * 1e6 / seeds as f64;

    let n = seeds as f64;
    println!("envelope {}x{}x{} m, {seeds} seeds", envelope.width_m, envelope.depth_m, envelope.height_m);
    println!("rooms per plan: {counts:?}");
    println!("room types: {types:?}");
    println!("distinct layouts: {}", layouts.len());
    println!(
        "per plan: {:.2} doors ({:.2} exterior), {:.2} windows, {:.0} structure triangles",
        doors as f64 / n,
        exterior_doors as f64 / n,
        windows as f64 / n,
        triangles as f64 / n
    );
    println!("time: {plan_us:.1} us per floorplan, {scene_us:.1} us per generated house");
    Ok(())
}
