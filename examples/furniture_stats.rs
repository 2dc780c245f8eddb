//! Furniture variety and density over many seeds: distinct shapes per class and furnishing
//! kind, objects and furnishings per room and per square metre by room type, triangles per
//! piece, door leaves, curtains and small things on tables, the houses drawn per colour
//! palette, and the time per house.
//!
//! ```text
//! cargo run --release --example furniture_stats -- [SEEDS=100] [--furniture DIR]
//! ```
//!
//! A shape is told apart by the exact bits of its vertex positions, so two objects count as one
//! shape only when their meshes are identical (objects of an OBJ variant share one). Density is
//! over each room's interior floor area (inside the walls). Times are wall-clock medians per
//! house on the calling thread: the floorplan alone, and the whole house (structure, furniture,
//! lights and the walk's scene included).

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use scene_gen::config::GeneratorConfig;
use scene_gen::floorplan;
use scene_gen::generate::generate;
use scene_gen::library::{Library, LibrarySource};
use scene_gen::scene::{Kind, Semantic};

/// Per-class tallies.
#[derive(Default)]
struct ClassStats {
    objects: usize,
    shapes: BTreeSet<Vec<u32>>,
    triangles: usize,
}

/// Per-room-type tallies.
#[derive(Default)]
struct RoomStats {
    rooms: usize,
    objects: usize,
    furnishings: usize,
    area_m2: f64,
}

fn print_room(name: &str, r: &RoomStats) {
    let n = r.rooms.max(1) as f64;
    let pieces = (r.objects + r.furnishings) as f64;
    println!(
        "| {name} | {} | {:.2} | {:.2} | {:.2} | {:.3} | {:.1} |",
        r.rooms,
        r.objects as f64 / n,
        r.furnishings as f64 / n,
        pieces / n,
        pieces / r.area_m2.max(1e-9),
        r.area_m2 / n
    );
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mut seeds = 100_u64;
    let mut furniture: Option<std::path::PathBuf> = None;
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--furniture" => furniture = Some(args.next().ok_or("--furniture needs a folder")?.into()),
            n => seeds = n.parse().map_err(|_| format!("'{n}' is neither a seed count nor --furniture"))?,
        }
    }
    let library = match &furniture {
        Some(dir) => Library::load(LibrarySource::Embedded, LibrarySource::Folder(dir))?,
        None => Library::embedded()?,
    };
    let mut classes: BTreeMap<Kind, ClassStats> = BTreeMap::new();
    let mut rooms: BTreeMap<String, RoomStats> = BTreeMap::new();
    let (mut plan_ms, mut house_ms) = (Vec::new(), Vec::new());
    let mut open_deg: Vec<f64> = Vec::new();
    let (mut doors, mut windows, mut curtains) = (0, 0, 0);
    let (mut tables, mut tables_with_things) = (0, 0);
    let mut palettes: BTreeMap<&str, usize> = BTreeMap::new();
    for seed in 0..seeds {
        let config = GeneratorConfig { seed, ..GeneratorConfig::default() };
        let start = Instant::now();
        floorplan::generate(&config, &library.rooms)?;
        plan_ms.push(start.elapsed().as_secs_f64() * 1e3);
        let start = Instant::now();
        let scene = generate(&config, &library)?;
        house_ms.push(start.elapsed().as_secs_f64() * 1e3);

        doors += scene.doors.len();
        open_deg.extend(scene.doors.iter().filter_map(|d| d.leaf).map(|l| f64::from(l.open_deg)));
        windows += scene.windows.len();
        curtains += scene.geometry.nodes.iter().filter(|n| n.name.starts_with("curtains_")).count();
        tables += scene.objects.iter().filter(|o| o.class == scene_gen::scene::ObjectClass::Table).count();
        tables_with_things += scene.geometry.nodes.iter().filter(|n| n.name.starts_with("table_things_")).count();
        *palettes.entry(scene.palette.map_or("none", |p| p.name)).or_default() += 1;
        for room in &scene.rooms {
            let (lo, hi) = room.interior(scene.wall_thickness_m);
            let entry = rooms.entry(room.room_type.clone()).or_default();
            entry.rooms += 1;
            entry.area_m2 += f64::from((hi - lo).x * (hi - lo).y);
            entry.objects += scene.objects.iter().filter(|o| o.room == room.id).count();
            entry.furnishings += scene.furnishings.iter().filter(|f| f.room == room.id).count();
        }
        for node in &scene.geometry.nodes {
            let class = match node.semantic {
                Semantic::Object { id } => Kind::Object(scene.objects[id as usize].class),
                Semantic::Furnishing { id } => Kind::Furnishing(scene.furnishings[id as usize].kind),
                _ => continue,
            };
            let mesh = &scene.geometry.meshes[node.mesh];
            let bits: Vec<u32> = mesh
                .primitives
                .iter()
                .flat_map(|p| &p.positions)
                .flat_map(|p| p.to_array().map(f32::to_bits))
                .collect();
            let entry = classes.entry(class).or_default();
            entry.objects += 1;
            entry.triangles += mesh.primitives.iter().map(|p| p.indices.len() / 3).sum::<usize>();
            entry.shapes.insert(bits);
        }
    }

    let source = furniture.as_ref().map_or("embedded".to_string(), |d| d.display().to_string());
    println!("{seeds} houses (seeds 0..{seeds}, default envelope), furniture library: {source}\n");
    println!("| class or furnishing | pieces | distinct shapes | distinct share | triangles per piece |");
    println!("|---|---|---|---|---|");
    let (mut all_objects, mut all_shapes) = (0, 0);
    for (class, s) in &classes {
        all_objects += s.objects;
        all_shapes += s.shapes.len();
        println!(
            "| {class} | {} | {} | {:.3} | {:.0} |",
            s.objects,
            s.shapes.len(),
            s.shapes.len() as f64 / s.objects.max(1) as f64,
            s.triangles as f64 / s.objects.max(1) as f64
        );
    }
    println!("| all | {all_objects} | {all_shapes} | {:.3} | |", all_shapes as f64 / all_objects.max(1) as f64);
    println!(
        "\n| room type | rooms | objects per room | furnishings per room | pieces per room | pieces per m^2 | mean interior m^2 |"
    );
    println!("|---|---|---|---|---|---|---|");
    let mut all = RoomStats::default();
    for (name, r) in &rooms {
        all.rooms += r.rooms;
        all.objects += r.objects;
        all.furnishings += r.furnishings;
        all.area_m2 += r.area_m2;
        print_room(name, r);
    }
    print_room("all", &all);
    println!(
        "\nper house: {:.1} objects, {:.1} furnishings",
        all.objects as f64 / seeds as f64,
        all.furnishings as f64 / seeds as f64
    );
    let (plan, house) = (median(plan_ms), median(house_ms));
    let leaves = open_deg.len();
    println!(
        "\ndoors: {leaves} of {doors} have a leaf, open {:.0} degrees median (range {:.0} to {:.0}); \
         windows: {curtains} of {windows} curtained",
        if leaves > 0 { median(open_deg.clone()) } else { f64::NAN },
        open_deg.iter().copied().fold(f64::INFINITY, f64::min),
        open_deg.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    let drawn: Vec<String> = palettes.iter().map(|(name, n)| format!("{name} {n}")).collect();
    println!("palettes: {}", drawn.join(", "));
    println!("tables: {tables_with_things} of {tables} carry small things\n");
    println!("median per house: floorplan {plan:.2} ms, whole house {house:.1} ms (the rest: {:.1} ms)", house - plan);
    Ok(())
}
