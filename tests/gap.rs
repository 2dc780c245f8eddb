//! The gap workflow on hidden-effect data sets and on EMVA 1288 data set 003.

use std::path::PathBuf;

use scene_gen::gap::{self, GapOptions, testdata};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("scene-gen-gap-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn explore() {
    let n: u64 = std::env::var("GAP_N").ok().and_then(|v| v.parse().ok()).unwrap_or(6);
    for seed in 0..n {
        let case = testdata::random_case(seed, (seed % 3) as usize);
        let dir = temp_dir(&format!("x{seed}"));
        let layout = testdata::layout(&case.model);
        let desc = testdata::write_dataset(&dir, &case.model, &layout, seed + 1000).unwrap();
        let t = std::time::Instant::now();
        let r = gap::run(&desc, None, &GapOptions::default()).unwrap();
        let fams: Vec<String> =
            r.gap_initial.families.iter().map(|f| format!("{}={:.1}", f.family, f.chi2_per_dof)).collect();
        let famf: Vec<String> =
            r.gap_final.families.iter().map(|f| format!("{}={:.1}", f.family, f.chi2_per_dof)).collect();
        println!(
            "seed {seed} hidden {:?} named {:?} gap {:.3} -> {:.3} ({:.2}s)\n   init {:?}\n   final {:?}",
            case.hidden,
            r.named(),
            r.gap_initial.gap,
            r.gap_final.gap,
            t.elapsed().as_secs_f64(),
            fams,
            famf
        );
        for tr in r.trials.iter().filter(|t| t.chi2_drop > t.penalty || std::env::var("GAP_ALL").is_ok()) {
            println!("     r{} {} drop {:.1} pen {:.1}", tr.round, tr.effect, tr.chi2_drop, tr.penalty);
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn debug_case() {
    let Some(seed) = std::env::var("GAP_SEED").ok().and_then(|v| v.parse::<u64>().ok()) else { return };
    let case = testdata::random_case(seed, (seed % 3) as usize);
    println!("{:#?}", case.model);
    let dir = temp_dir(&format!("d{seed}"));
    let layout = testdata::layout(&case.model);
    let desc = testdata::write_dataset(&dir, &case.model, &layout, seed + 1000).unwrap();
    let r = gap::run(&desc, None, &GapOptions::default()).unwrap();
    println!("{:#?}", r.final_model);
    for (i, e) in r.measured.entries.iter().enumerate() {
        println!(
            "{:16} {:50} m {:12.5} s0 {:12.5} s {:12.5} z0 {:8.2} z {:8.2}",
            e.family,
            e.label,
            e.value,
            r.initial_stats.entries[i].value,
            r.final_stats.entries[i].value,
            r.gap_initial.residuals[i],
            r.gap_final.residuals[i]
        );
    }
    for tr in &r.trials {
        println!("     r{} {} drop {:.1} pen {:.1}", tr.round, tr.effect, tr.chi2_drop, tr.penalty);
    }
}

fn data_dir() -> PathBuf {
    let manifest = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut candidates: Vec<PathBuf> = std::env::var_os("SCENE_GEN_DATA").map(PathBuf::from).into_iter().collect();
    candidates.push(manifest.join("../shared/data"));
    candidates.push(manifest.join("../../shared/data"));
    candidates
        .iter()
        .find(|p| p.join("emva1288-set003-crop").is_dir())
        .cloned()
        .unwrap_or_else(|| panic!("EMVA 1288 data set 003 not found in {candidates:?}; set SCENE_GEN_DATA"))
}

#[test]
fn set003_probe() {
    if std::env::var("GAP_003").is_err() {
        return;
    }
    let desc = data_dir().join("emva1288-set003-crop/EMVA1288_Data.txt");
    let t = std::time::Instant::now();
    let opts = GapOptions { max_stack_frames: Some(16), step_stride: 2, ..GapOptions::default() };
    let r = gap::run(&desc, None, &opts).unwrap();
    println!(
        "named {:?} gap {:.3} -> {:.3} ({:.2}s)",
        r.named(),
        r.gap_initial.gap,
        r.gap_final.gap,
        t.elapsed().as_secs_f64()
    );
    println!("{:#?}", r.final_model);
    for (i, e) in r.measured.entries.iter().enumerate() {
        println!(
            "{:16} {:50} m {:12.5} s0 {:12.5} s {:12.5} z0 {:8.2} z {:8.2}",
            e.family,
            e.label,
            e.value,
            r.initial_stats.entries[i].value,
            r.final_stats.entries[i].value,
            r.gap_initial.residuals[i],
            r.gap_final.residuals[i]
        );
    }
    for tr in &r.trials {
        println!("     r{} {} drop {:.1} pen {:.1}", tr.round, tr.effect, tr.chi2_drop, tr.penalty);
    }
    for st in &r.steps {
        println!("{} {} {:.3}->{:.3} {}", st.effect, st.params, st.gap_before, st.gap_after, st.evidence);
    }
}

#[test]
fn set003_spectrum_probe() {
    if std::env::var("GAP_003S").is_err() {
        return;
    }
    let desc = data_dir().join("emva1288-set003-crop/EMVA1288_Data.txt");
    let opts = GapOptions { max_stack_frames: Some(16), step_stride: 2, ..GapOptions::default() };
    let acq = gap::load_acquisition(&desc, &opts).unwrap();
    let b = acq.blocks.iter().rev().find(|b| b.frames.len() > 2 && b.light == gap::Light::Dark).unwrap();
    let img = gap::stats::average(&b.frames);
    let t = std::time::Instant::now();
    let (p, med) = gap::stats::peaks_2d(&img, acq.width, acq.height, 2, 8);
    println!("{:.2}s median {med:.3e}", t.elapsed().as_secs_f64());
    for q in p {
        println!("{q:?}");
    }
}
