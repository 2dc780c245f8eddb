//! How often the gap workflow reports misfit as unexplained, on hidden-effect sets written by
//! `scene_gen::gap::testdata`: clean sets and sets with library effects (where "unexplained"
//! is a false alarm) and sets with one effect outside the library (dead pixels, a gamma
//! response, column gain, crosstalk: where it is the right answer). Prints one line per set and
//! the rates (docs/BENCHMARKS.md, gap section):
//!
//! ```text
//! cargo run --release --example gap_unexplained -- [SEEDS (default 0..10)] [foreign|library|all]
//! ```
use scene_gen::gap::testdata;
use scene_gen::gap::{self, GapOptions};
use scene_gen::seeds::SeedRange;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seeds = args.first().map_or("0..10", String::as_str).parse::<SeedRange>()?;
    let which = args.get(1).map_or("all", String::as_str);
    if !["all", "library", "foreign"].contains(&which) {
        return Err(format!("expected all, library or foreign, got '{which}'").into());
    }
    let dir = std::env::temp_dir().join(format!("scene-gen-gap-unexplained-{}", std::process::id()));
    let (mut lib_sets, mut lib_alarms, mut lib_exact) = (0, 0, 0);
    let (mut foreign_sets, mut foreign_caught, mut foreign_no_false_name) = (0, 0, 0);
    // Per kind: sets, sets whose unexplained families include the kind's own family.
    let mut kinds: Vec<(&'static str, usize, usize)> = Vec::new();
    for seed in seeds.iter() {
        let case = testdata::random_case(seed, (seed % 3) as usize);
        let layout = testdata::layout(&case.model);
        let case_dir = dir.join(format!("case{seed}"));
        let mut hidden: Vec<String> = case.hidden.iter().map(|s| (*s).to_string()).collect();
        hidden.sort();
        if which != "foreign" {
            let desc = testdata::write_dataset(&case_dir.join("lib"), &case.model, &layout, seed + 1000)?;
            let r = gap::run(&desc, None, &GapOptions::default())?;
            let mut named = r.named();
            named.sort();
            let un = r.unexplained();
            lib_sets += 1;
            lib_alarms += usize::from(!un.is_empty());
            lib_exact += usize::from(named == hidden);
            println!(
                "library seed {seed}: hidden {hidden:?} named {named:?} tentative {:?} unexplained {un:?}",
                r.tentative()
            );
        }
        if which != "library" {
            let f = testdata::random_foreign(seed);
            let desc =
                testdata::write_dataset_foreign(&case_dir.join("foreign"), &case.model, &layout, seed + 1000, f)?;
            let r = gap::run(&desc, None, &GapOptions::default())?;
            let mut named = r.named();
            named.sort();
            let un = r.unexplained();
            let extra: Vec<&String> = named.iter().filter(|n| !hidden.contains(n)).collect();
            foreign_sets += 1;
            foreign_caught += usize::from(!un.is_empty());
            foreign_no_false_name += usize::from(extra.is_empty());
            if !kinds.iter().any(|k| k.0 == f.name()) {
                kinds.push((f.name(), 0, 0));
            }
            if let Some(k) = kinds.iter_mut().find(|k| k.0 == f.name()) {
                k.1 += 1;
                k.2 += usize::from(un.contains(&f.family()));
            }
            println!(
                "foreign seed {seed}: {f:?} with hidden {hidden:?}; named {named:?} (extra {extra:?}); tentative {:?}; unexplained {un:?}",
                r.tentative()
            );
        }
        let _ = std::fs::remove_dir_all(&case_dir);
    }
    if lib_sets > 0 {
        println!(
            "library sets: {lib_sets}; unexplained reported on {lib_alarms} (false alarms); named exactly {lib_exact}"
        );
    }
    if foreign_sets > 0 {
        println!(
            "foreign sets: {foreign_sets}; unexplained reported on {foreign_caught}; no extra name on {foreign_no_false_name}"
        );
        for (name, sets, own) in kinds {
            println!("  {name}: {own} of {sets} with its own family unexplained");
        }
    }
    Ok(())
}
