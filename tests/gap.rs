//! The sim-vs-measured gap workflow: hidden-effect data sets written by the project's own
//! simulator, EMVA 1288 data set 003, and the `scene-gen gap` command.

mod common;

use common::data_dir;
use std::path::{Path, PathBuf};
use std::process::Command;

use rand::Rng as _;
use scene_gen::gap::{self, GapOptions, stats, testdata};
use scene_gen::sensor::{SensorModel, noise};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("scene-gen-gap-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes hidden-effect case `seed` (with `n` effects) and returns its descriptor.
fn write_case(seed: u64, n: usize, dir: &Path) -> (testdata::HiddenCase, PathBuf) {
    let case = testdata::random_case(seed, n);
    let layout = testdata::layout(&case.model);
    let desc = testdata::write_dataset(dir, &case.model, &layout, seed + 1000).unwrap();
    (case, desc)
}

/// 40 random cases (seeds 0..40; seed % 3 effects: 14 clean sets, 13 with one effect, 13 with
/// two), strengths drawn at random from `testdata::random_case`'s ranges.
///
/// A hit: the named effects are exactly the hidden ones and, when something is hidden, the gap
/// shrinks by at least 80 %. These seeds give 30 of 40. The misses name the hidden effects
/// plus one extra: black_level (seeds 10, 16, 25: sets without a black level, whose dark frames
/// clip at 0 DN, where the closed-form fits are approximate), dithered quantization (5, 19,
/// both with misfit left over), dark_current (13), hot_pixels (26, 35), periodic_pattern (34);
/// and one clean set (12) is given illumination_falloff.
///
/// The count varies with the noise realisation.
///
/// Unexplained misfit (`gap::misfit`) on these sets, where every effect is in the library, is a
/// false alarm or a library effect fitted imperfectly: these seeds report it on 3 of 40 (a
/// periodic pattern's spatial misfit, a clean set's linearity, a DSNU with row and column noise),
/// and `cargo run --release --example gap_unexplained -- 40..120 library` on 11 of 80 (clean sets:
/// 3 of the 40 in cases 0..120); the test allows 8 of 40.
/// Measured over 31 seed sets (case seeds `100000 b + 0..40`, data seeds + 1000, `GapOptions::seed` 1288 + b,
/// b in 0..31; b = 0 is this test; a throw-away copy of this loop, run as
/// `GAPRATE_BASES=0..31 RAYON_NUM_THREADS=1 target/release/deps/tmp_gaprate-* --nocapture`,
/// 2026-11-24): before the merged draw (d4968cd) mean 27.7 hits, sd 4.1, range 17-35; after
/// (a0e57ba) mean 28.5, sd 3.1, range 22-33: the same within noise (difference 0.8, its
/// standard error 0.9). Pooled (62 runs): mean 28.1, sd 3.65. We assert 17 of 40, 3 sd below
/// the mean (4 sd, 13.5, would be under the 14 that naming nothing scores on the clean sets);
/// naming nothing fails it, and a workflow exact on under 40 % of the sets (under 16 expected)
/// fails it more often than not.
///
/// False names on clean sets: 23 of the 31 seed sets above named something on 1 to 7 of their
/// 14 clean sets, so none at all is luck, not a property. These seeds name one (seed 12). Those
/// figures were measured with one random stream for every temporal noise source; each source
/// has its own now (common random numbers, `scene_gen::sensor::noise`). The test allows at most 2 of 14: a workflow that names something on
/// many clean sets fails it, while the measured spread (0 to 7 per seed set) says a tighter
/// bound on one seed set would test the draw, not the workflow.
#[test]
fn hidden_effects_are_named_and_the_gap_shrinks() {
    let dir = temp_dir("hidden");
    let (mut hits, mut clean_false) = (0, Vec::new());
    let (mut misses, mut alarms) = (Vec::new(), Vec::new());
    for seed in 0..40u64 {
        let n = (seed % 3) as usize;
        let case_dir = dir.join(format!("case{seed}"));
        let (case, desc) = write_case(seed, n, &case_dir);
        let r = gap::run(&desc, None, &GapOptions::default()).unwrap();
        let mut named = r.named();
        named.sort();
        let mut hidden: Vec<String> = case.hidden.iter().map(|s| (*s).to_string()).collect();
        hidden.sort();
        let shrink_ok = hidden.is_empty() || r.gap_final.gap <= 0.2 * r.gap_initial.gap;
        if hidden.is_empty() && !named.is_empty() {
            clean_false.push((seed, named.clone()));
        }
        if !r.unexplained().is_empty() {
            alarms.push((seed, r.unexplained()));
        }
        if named == hidden && shrink_ok {
            hits += 1;
        } else {
            misses.push(format!(
                "seed {seed}: hidden {hidden:?} named {named:?} gap {:.2} -> {:.2}",
                r.gap_initial.gap, r.gap_final.gap
            ));
        }
        let _ = std::fs::remove_dir_all(&case_dir);
    }
    println!("single-gain hidden-effect hit rate: {hits}/40; misses: {misses:?}");
    assert!(clean_false.len() <= 2, "effects named on {} of 14 clean sets: {clean_false:?}", clean_false.len());
    assert!(hits >= 17, "hit rate {hits}/40; misses:\n{}", misses.join("\n"));
    assert!(
        alarms.len() <= 8,
        "misfit called unexplained on {} of 40 sets of library effects: {alarms:?}",
        alarms.len()
    );
}

/// Hidden-effect case 11 with a 20 DN black level (its dark frames clear 0 DN, so the moments
/// describe every row), a 3 e- DSNU and, when given, a PRNU of that fraction, on a `w x h`
/// layout of its acquisition.
fn case_11_above_zero(prnu: Option<f64>, (w, h): (usize, usize)) -> (gap::GapModel, gap::Acquisition) {
    let mut model = testdata::random_case(11, 2).model;
    let e = &mut model.sensor.effects;
    (e.black_level.enabled, e.black_level.offset_dn) = (true, 20.0);
    (e.dsnu.enabled, e.dsnu.std_e) = (true, 3.0);
    if let Some(fraction) = prnu {
        (e.prnu.enabled, e.prnu.std_fraction) = (true, fraction);
    }
    let mut layout = testdata::layout(&model);
    (layout.width, layout.height) = (w, h);
    (model, layout)
}

/// A temporal pair drawn from its pixels' moments keeps only its statistics
/// ([`gap::Block::pair`]), drawn from row and column sums. Over 300 seeds they follow the
/// distribution of the same pair drawn pixel by pixel: for every step and dark pair, the
/// mean and the temporal variance agree within their sampling error, their spreads over the
/// seeds within a quarter, and so do the sampling variances the gap divides by.
#[test]
fn pair_sums_follow_the_pixels_they_summarise() {
    let (model, layout) = case_11_above_zero(Some(0.01), (64, 48));
    let t = stats::Thresholds { dark_dn: f64::INFINITY, bright_dn: f64::INFINITY };
    let families = ["linearity", "photon_transfer", "dark"];
    let draw = |draws: gap::Draws, seed: u64| {
        let sim = gap::simulate_rows(&model, &layout, seed, None, layout.height, &vec![draws; layout.blocks.len()]);
        let summarised = sim.blocks.iter().filter(|b| b.pair.is_some()).count();
        let s = stats::compute(&sim, &t);
        let entries: Vec<(f64, f64)> =
            s.entries.iter().filter(|e| families.contains(&e.family)).map(|e| (e.value, e.var)).collect();
        (summarised, entries)
    };
    let runs = 300u64;
    let (mut sums, mut pixels) = (Vec::new(), Vec::new());
    for seed in 0..runs {
        let (summarised, entries) = draw(gap::Draws::Moments, seed);
        assert!(summarised >= 10, "only {summarised} pairs summarised");
        sums.push(entries);
        pixels.push(draw(gap::Draws::Pixels, 1000 + seed).1);
    }
    let moments = |runs: &[Vec<(f64, f64)>], j: usize| {
        let n = runs.len() as f64;
        let mean = runs.iter().map(|r| r[j].0).sum::<f64>() / n;
        let var = runs.iter().map(|r| (r[j].0 - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let sampling_var = runs.iter().map(|r| r[j].1).sum::<f64>() / n;
        (mean, var, sampling_var)
    };
    for j in 0..sums[0].len() {
        let ((ms, vs, ss), (mp, vp, sp)) = (moments(&sums, j), moments(&pixels, j));
        let z = (ms - mp) / ((vs + vp) / runs as f64).sqrt();
        assert!(z.abs() < 4.5, "entry {j}: mean {ms} against {mp} ({z:.1} sigma)");
        let spread = (vs / vp).sqrt();
        assert!((0.75..1.33).contains(&spread), "entry {j}: spread ratio {spread}");
        assert!((0.8..1.25).contains(&(ss / sp)), "entry {j}: sampling variance {ss} against {sp}");
    }
}

/// On a frame of 240 rows (the smallest the search draws from moments) the moment draws name
/// what pixel-by-pixel draws name: the hidden black level and hot pixels of case 11, from data
/// drawn pixel by pixel. Its dark frames clear 0 DN, so its dark blocks are drawn from moments
/// too (the exact rounded moments of their finely rounded pixels). Moment draws, like pixel
/// draws, give the same model at any thread count.
#[test]
fn moment_draws_name_what_pixel_draws_name() {
    let dir = temp_dir("moments");
    let case = testdata::random_case(11, 2);
    let mut layout = testdata::layout(&case.model);
    (layout.width, layout.height) = (256, gap::MOMENTS_MIN_ROWS);
    let desc = testdata::write_dataset(&dir, &case.model, &layout, 1011).unwrap();
    let measured = gap::load_acquisition(&desc, &GapOptions::default()).unwrap();
    let draws = gap::block_draws(&measured, gap::Draws::Moments);
    let mut dark = measured.blocks.iter().zip(&draws).filter(|(b, _)| b.light == gap::Light::Dark);
    assert!(dark.clone().count() > 0 && dark.all(|(_, d)| *d == gap::Draws::Moments), "{draws:?}");
    // The dark pair really is drawn from moments (values between whole DN), the dark stack as
    // its mean image.
    let sim = gap::simulate_rows(&case.model, &measured, 1, None, measured.height, &draws);
    let dark_pair = sim.blocks.iter().find(|b| b.light == gap::Light::Dark && b.frames.len() == 2).unwrap();
    assert!(dark_pair.frames[0].iter().any(|v| v.fract() != 0.0));
    assert!(sim.blocks.iter().any(|b| b.light == gap::Light::Dark && b.average.is_some()));
    let mut hidden: Vec<String> = case.hidden.iter().map(|s| s.to_string()).collect();
    hidden.sort();
    let run = |draws| gap::run(&desc, None, &GapOptions { draws, replicates: 0, ..GapOptions::default() }).unwrap();
    assert_eq!(sorted(run(gap::Draws::Pixels).named()), hidden, "pixel draws");
    let moments = run(gap::Draws::Moments);
    assert_eq!(sorted(moments.named()), hidden, "moment draws");
    // The same model on one thread as on the default pool.
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    assert_eq!(one.install(|| run(gap::Draws::Moments)).final_model, moments.final_model);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The same data set and seed give the same result: the workflow is deterministic.
#[test]
fn same_data_same_result() {
    let dir = temp_dir("determinism");
    let (_, desc) = write_case(2, 2, &dir);
    let a = gap::run(&desc, None, &GapOptions::default()).unwrap();
    let b = gap::run(&desc, None, &GapOptions::default()).unwrap();
    assert_eq!(a.named(), b.named());
    assert_eq!(a.gap_final.gap.to_bits(), b.gap_final.gap.to_bits());
    assert_eq!(a.final_model.sensor, b.final_model.sensor);
}

/// Fitted parameters land near the hidden truth (not only the names): a DSNU + PRNU case.
#[test]
fn fitted_parameters_are_close_to_the_truth() {
    let dir = temp_dir("params");
    let mut case = testdata::random_case(77, 0);
    let e = &mut case.model.sensor.effects;
    e.black_level.enabled = true;
    e.black_level.offset_dn = 80.0;
    e.dsnu.enabled = true;
    e.dsnu.std_e = 1.5 * case.model.sensor.read_noise_e;
    e.prnu.enabled = true;
    e.prnu.std_fraction = 0.02;
    let layout = testdata::layout(&case.model);
    let desc = testdata::write_dataset(&dir, &case.model, &layout, 5).unwrap();
    let r = gap::run(&desc, None, &GapOptions::default()).unwrap();
    let mut named = r.named();
    named.sort();
    assert_eq!(named, ["black_level", "dsnu", "prnu"]);
    let (t, f) = (&case.model.sensor, &r.final_model.sensor);
    let rel = |a: f64, b: f64| (a / b - 1.0).abs();
    assert!((f.effects.black_level.offset_dn - 80.0).abs() < 1.0, "{}", f.effects.black_level.offset_dn);
    // DSNU in DN (K times electrons): K itself is fitted.
    let dsnu_dn = |m: &SensorModel| m.effects.dsnu.std_e * m.system_gain_dn_per_e;
    assert!(rel(dsnu_dn(f), dsnu_dn(t)) < 0.1, "{} vs {}", dsnu_dn(f), dsnu_dn(t));
    assert!(rel(f.effects.prnu.std_fraction, 0.02) < 0.1, "{}", f.effects.prnu.std_fraction);
    assert!(rel(f.system_gain_dn_per_e, t.system_gain_dn_per_e) < 0.05);
}

/// Hot pixels whose excess is exponential (most barely hot, a long tail): the fit takes the
/// shape it sees above the threshold, so the number of pixels beyond each level of the tail
/// comes out as the truth's, where a uniform excess of the same mean would not.
#[test]
fn hot_pixel_excess_takes_its_measured_shape() {
    let dir = temp_dir("hot-shape");
    let mut case = testdata::random_case(5, 0);
    let s = &case.model.sensor;
    // Exponential with mean 12 read-noise sigmas (in DN at the dark stack's exposure).
    let mean_e_per_s = 12.0 * s.read_noise_e / testdata::EXPOSURE_S;
    let quantiles = std::array::from_fn(|i| {
        let p = i as f64 / (noise::HotPixels::QUANTILES - 1) as f64;
        -mean_e_per_s * (1.0 - 0.995 * p).ln()
    });
    case.model.sensor.effects.hot_pixels = noise::HotPixels {
        enabled: true,
        fraction: 0.15,
        max_excess_e_per_s: quantiles[noise::HotPixels::QUANTILES - 1],
        excess_quantiles_e_per_s: Some(quantiles),
    };
    let truth = case.model.sensor.effects.hot_pixels;
    let layout = testdata::layout(&case.model);
    let desc = testdata::write_dataset(&dir, &case.model, &layout, 9).unwrap();
    let r = gap::run(&desc, None, &GapOptions::default()).unwrap();
    assert!(r.named().contains(&"hot_pixels".to_string()), "named {:?}", r.named());
    let fit = r.final_model.sensor.effects.hot_pixels;
    // Expected fraction of all pixels with an excess above `u`, e-/s.
    let beyond = |h: &noise::HotPixels, u: f64| {
        h.fraction * (0..10_000).filter(|&j| h.excess_at((f64::from(j) + 0.5) / 1e4) > u).count() as f64 / 1e4
    };
    let uniform = noise::HotPixels { excess_quantiles_e_per_s: None, max_excess_e_per_s: 2.0 * mean_e_per_s, ..truth };
    for level in [1.0, 1.5, 2.5] {
        let u = level * mean_e_per_s;
        let (t, f) = (beyond(&truth, u), beyond(&fit, u));
        println!("beyond {level} means: fitted {f:.4}, truth {t:.4}, uniform {:.4}", beyond(&uniform, u));
        assert!((f / t - 1.0).abs() < 0.3, "beyond {level} means: fitted {f}, truth {t} ({fit:?})");
    }
    // Beyond the uniform form's end, a uniform excess with the truth's mean has no pixels.
    assert!(beyond(&uniform, 2.5 * mean_e_per_s) == 0.0);
}

/// Data set 003 (centre crop), stacks cut to their first 16 frames and every third
/// photon-transfer step (17 of 50) to keep the test profile under ~20 s. It must name every
/// documented effect the crop can show (black level, nonlinearity, DSNU, its periodic pattern,
/// PRNU, hot pixels), nothing outside the documented list but the in-crop fall-off (~0.2 %),
/// and shrink the gap by 99 %. Hot pixels: the crop holds ~6 (excess uniform in 0..15 DN against
/// ~1.7 DN of noise once the waves are removed); the dark tail threshold is the Bonferroni bound
/// of a 0.1 % false-alarm rate over 19,200 pixels (5.3 sigmas), which one of them clears (at
/// ~6.5 sigmas), where a Gaussian dark image expects 0.001 pixels.
#[test]
fn set003_names_its_documented_effects() {
    let desc = data_dir().join("emva1288-set003-crop/EMVA1288_Data.txt");
    let options = GapOptions { max_stack_frames: Some(16), step_stride: 3, ..GapOptions::default() };
    let r = gap::run(&desc, None, &options).unwrap();
    let named = r.named();
    println!(
        "set 003 crop: named {named:?}, gap {:.2} -> {:.2}, {} simulations ({} cached)",
        r.gap_initial.gap, r.gap_final.gap, r.simulations, r.cached_evaluations
    );
    for must in ["black_level", "nonlinearity", "dsnu", "periodic_pattern", "prnu", "hot_pixels"] {
        assert!(named.iter().any(|n| n == must), "{must} not named: {named:?}");
    }
    let documented = ["black_level", "nonlinearity", "dsnu", "periodic_pattern", "prnu", "hot_pixels"];
    for n in &named {
        assert!(documented.contains(&n.as_str()) || n == "illumination_falloff", "undocumented effect {n}");
    }
    assert!(r.gap_final.gap < 0.01 * r.gap_initial.gap, "{} -> {}", r.gap_initial.gap, r.gap_final.gap);
    let s = &r.final_model.sensor;
    let e = &s.effects;
    // Truth (data/README.md): K 0.1, dark 29.4 DN, nonlinearity -0.02, DSNU white 1.5 DN,
    // waves of 1.5 DN, PRNU 0.5 %.
    assert!((s.system_gain_dn_per_e - 0.1).abs() < 0.005, "K {}", s.system_gain_dn_per_e);
    assert!((e.black_level.offset_dn - 29.4).abs() < 0.3, "black {}", e.black_level.offset_dn);
    // Whatever order the penalty chooses, the response bends by -2 % at full scale.
    let bend = e.nonlinearity.factor(1.0) - 1.0;
    assert!((bend + 0.02).abs() < 0.005, "bend at full scale {bend} ({:?})", e.nonlinearity);
    let dsnu_dn = e.dsnu.std_e * s.system_gain_dn_per_e;
    assert!((dsnu_dn - 1.5).abs() < 0.3, "DSNU {dsnu_dn} DN");
    let (ax, ay) = e.periodic_pattern.amplitudes();
    assert!(e.periodic_pattern.waves_present() == [true, true], "two waves: {:?}", e.periodic_pattern);
    assert!((ax - 1.5).abs() < 0.2 && (ay - 1.5).abs() < 0.2, "wave amplitudes {ax}, {ay}");
    assert!((e.prnu.std_fraction - 0.005).abs() < 0.001, "PRNU {}", e.prnu.std_fraction);
}

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_scene-gen"))
}

/// `scene-gen gap --json`: only the summary on stdout, every output file written, the model
/// reads back; starting from the true model (`--model`) there is nothing to add.
#[test]
fn cli_writes_reports_and_prints_json() {
    let dir = temp_dir("cli");
    let (case, desc) = write_case(1, 1, &dir.join("data"));
    let out = dir.join("out");
    let o = bin().arg("gap").arg(&desc).arg("--out").arg(&out).arg("--json").env_remove("RUST_LOG").output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Off a terminal, progress is plain lines on stderr ending with the time taken.
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.lines().last().is_some_and(|l| l.starts_with("gap: done in ")), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("stdout is one JSON document");
    let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
    assert_eq!(keys, ["gap_final", "gap_initial", "named", "simulations", "steps", "tentative", "unexplained"]);
    assert_eq!(v["named"], serde_json::json!(case.hidden));
    let step = &v["steps"][0];
    for k in ["effect", "params", "gap_before", "gap_after", "evidence"] {
        assert!(step.get(k).is_some(), "step lacks {k}: {step}");
    }
    for f in [
        "report.md",
        "report.json",
        "model.toml",
        "optics.toml",
        "photon_transfer.png",
        "residuals.png",
        "gap_per_step.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let png = image::open(out.join("photon_transfer.png")).unwrap();
    assert_eq!((png.width(), png.height()), (720, 480));
    let model = SensorModel::from_toml(&std::fs::read_to_string(out.join("model.toml")).unwrap()).unwrap();
    assert!(model.effects.nonlinearity.enabled, "{:?}", model.effects);

    // The true model as the start: nothing left to name.
    std::fs::write(dir.join("true.toml"), case.model.sensor.to_toml().unwrap()).unwrap();
    let out2 = dir.join("out2");
    let o = bin()
        .arg("gap")
        .arg(&desc)
        .arg("--model")
        .arg(dir.join("true.toml"))
        .arg("--out")
        .arg(&out2)
        .arg("--json")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["named"], serde_json::json!([]), "{v}");
    assert!(v["gap_initial"].as_f64().unwrap() < 1.0, "{v}");
}

/// Bad input exits 2 with a message naming the file, and writes nothing.
#[test]
fn cli_refuses_bad_input_without_output() {
    let dir = temp_dir("bad");
    let out = dir.join("out");
    let missing = dir.join("nope.txt");
    let o = bin().arg("gap").arg(&missing).arg("--out").arg(&out).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nope.txt"));
    assert!(!out.exists());

    let bad = dir.join("bad.txt");
    std::fs::write(&bad, "n 12 8 8\nb 1000 10\ni a.png\n").unwrap();
    let o = bin().arg("gap").arg(&bad).arg("--out").arg(&out).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bad.txt"), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!out.exists());

    let (_, desc) = write_case(3, 0, &dir.join("data"));
    std::fs::write(dir.join("model.toml"), "name = \"x\"\nquantum_efficiency = 2.0\n").unwrap();
    let o =
        bin().arg("gap").arg(&desc).arg("--model").arg(dir.join("model.toml")).arg("--out").arg(&out).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("model.toml"));
    assert!(!out.exists());
}

/// A minimal descriptor (16 x 12 pixels, 4 steps, one dark pair, no spatial stacks) runs: no
/// stack statistics, no spatial candidates, the linear model refitted. (With 15 statistics the
/// BIC penalty is weak and a clean set this small can lose to a borderline candidate, so names
/// are not asserted here; the 40-case test covers naming.)
#[test]
fn minimal_descriptor_without_stacks() {
    let dir = temp_dir("minimal");
    let case = testdata::random_case(5, 0);
    let block = |light, n: usize| gap::Block::layout(light, 0.01, 0, n);
    let mut blocks: Vec<gap::Block> = (1..=4).map(|i| block(gap::Light::Bright(2000.0 * f64::from(i)), 2)).collect();
    blocks.push(block(gap::Light::Dark, 2));
    // 64x48: with 16x12 (192 pixels a pair) the fitted K spread by +-30 % over simulation seeds
    // (0.61 to 0.97 of the truth at seeds 1288, 7, 8, 9), wider than the 15 % asserted below.
    let layout = gap::Acquisition { width: 64, height: 48, bits: 12, blocks, gains_db: vec![0.0] };
    let desc = testdata::write_dataset(&dir, &case.model, &layout, 9).unwrap();
    let r = gap::run(&desc, None, &GapOptions::default()).unwrap();
    assert!(r.measured.dark_stack.is_none() && r.measured.bright_stack.is_none());
    // 4 means, 4 variances, the dark mean and variance, the dark pair's row-profile variance,
    // and the neighbour correlations (x, y) of the dark and the middle bright pair.
    assert_eq!(r.measured.entries.len(), 15);
    assert!(r.trials.iter().all(|t| !["dsnu", "prnu", "hot_pixels", "periodic_pattern"].contains(&t.effect.as_str())));
    let k = r.final_model.sensor.system_gain_dn_per_e / case.model.sensor.system_gain_dn_per_e;
    assert!((k - 1.0).abs() < 0.15, "K ratio {k}");
}

/// Names sorted, for comparison.
fn sorted(v: impl IntoIterator<Item = String>) -> Vec<String> {
    let mut v: Vec<String> = v.into_iter().collect();
    v.sort();
    v
}

/// Read noise split across gains: 12 random cases over two gains (0 and 12 dB), written as one
/// descriptor per gain (the gains are not written: the workflow measures them from the
/// response). Every case has a black level (see `testdata::random_multigain_case`); 4 have
/// nothing else, 4 hide `read_noise_split`, 4 hide it and one more effect. A hit: exactly the
/// hidden effects named. Prints the hit rate; asserts `read_noise_split` named in at most one of
/// the 4 cases without it, found in at least 7 of the 8 cases that hide it, and at least 6 of
/// 12 exact hits. These seeds give 10 of 12: the split found in all 8, named once where not
/// hidden (seed 9); the other miss names dithered quantization beside the black level (seed 0).
///
/// Measured over 31 seed sets (case seeds `100000 b + 300 + 0..12`, data seeds `100000 b + 77 +
/// 0..12`, `GapOptions::seed` 1288 + b, b in 0..31, b = 0 this test) with one random stream for
/// every temporal noise source: mean 10.4 exact hits, sd 1.4; the split found in all 8 in every
/// run and named where not hidden in 6 of the 31 sets, once each. We assert 6 hits, 3 sd below
/// that mean (4 sd, 4.9, is barely above the 4 of naming only the black level, which every case
/// has). The second gain is measured within 0.05 dB.
#[test]
fn read_noise_split_is_named_across_gains() {
    let dir = temp_dir("multigain");
    let (mut hits, mut misses, mut split_found, mut false_split) = (0, Vec::new(), 0, 0);
    for seed in 0..12u64 {
        let kind = match seed % 3 {
            0 => None,
            1 => Some(0),
            _ => Some(1),
        };
        let case = testdata::random_multigain_case(300 + seed, kind);
        let layout = testdata::layout_gains(&case.model, &[0.0, 12.0]);
        let case_dir = dir.join(format!("case{seed}"));
        let descs = testdata::write_multigain(&case_dir, &case.model, &layout, seed + 77).unwrap();
        assert_eq!(descs.len(), 2);
        let r = gap::run_inputs(&descs, None, &GapOptions::default()).unwrap();
        assert!((r.gains_db[1] - 12.0).abs() < 0.05, "gain {}", r.gains_db[1]);
        let named = sorted(r.named());
        let hidden = sorted(case.hidden.iter().map(|s| (*s).to_string()));
        if kind.is_none() {
            false_split += usize::from(named.iter().any(|n| n == "read_noise_split"));
        } else if named.iter().any(|n| n == "read_noise_split") {
            split_found += 1;
        }
        if named == hidden {
            hits += 1;
        } else {
            misses.push(format!("seed {seed}: hidden {hidden:?} named {named:?}"));
        }
        let _ = std::fs::remove_dir_all(&case_dir);
    }
    println!("two-gain hidden-effect hit rate: {hits}/12; misses: {misses:?}");
    assert!(false_split <= 1, "read_noise_split named in {false_split} of the 4 cases without it; {misses:?}");
    assert!(split_found >= 7, "read_noise_split found in {split_found}/8; {misses:?}");
    assert!(hits >= 6, "hit rate {hits}/12; misses: {misses:?}");
}

/// The fitted post-gain fraction lands near the truth (two descriptors at 0 and 12 dB).
#[test]
fn read_noise_split_fraction_is_close() {
    let dir = temp_dir("split-param");
    let mut case = testdata::random_multigain_case(41, Some(0));
    case.model.sensor.effects.read_noise_split.post_gain_fraction = 0.5;
    let layout = testdata::layout_gains(&case.model, &[0.0, 12.0]);
    let descs = testdata::write_multigain(&dir, &case.model, &layout, 3).unwrap();
    let r = gap::run_inputs(&descs, None, &GapOptions::default()).unwrap();
    assert_eq!(sorted(r.named()), ["black_level", "read_noise_split"]);
    let f = r.final_model.sensor.effects.read_noise_split.post_gain_fraction;
    assert!((f - 0.5).abs() < 0.1, "post-gain fraction {f}");
}

/// `gap` on photon-transfer CSVs written from the generator (three gains: 0, 6, 12 dB): a camera
/// with only its black level names only that; a hidden read-noise split, and with it a
/// nonlinearity, are named in every case, and nothing else in at least 2 of the 3 (with the
/// ziggurat normal draws, seed 502 buys an extra `dark_current`, a realisation-dependent miss
/// like those of the image hit-rate test). Spatial effects are never candidates on a CSV.
#[test]
fn csv_hidden_effects_are_named() {
    let dir = temp_dir("csv");
    let gains = [0.0, 6.0, 12.0];
    // Clean.
    let case = testdata::random_multigain_case(500, None);
    let path = dir.join("clean.csv");
    testdata::write_csv(&path, &case.model, &testdata::layout_gains(&case.model, &gains), 1).unwrap();
    let r = gap::run(&path, None, &GapOptions::default()).unwrap();
    assert_eq!(r.named(), ["black_level"], "black-level-only CSV");
    assert!(r.trials.iter().all(|t| !["dsnu", "prnu", "hot_pixels", "periodic_pattern"].contains(&t.effect.as_str())));
    // Split alone (with the black level), and split + nonlinearity.
    let mut exact = 0;
    for (seed, nonlinear) in [(501u64, false), (502, false), (503, true)] {
        let mut case = testdata::random_multigain_case(seed, Some(0));
        if nonlinear {
            let e = &mut case.model.sensor.effects;
            e.nonlinearity.enabled = true;
            e.nonlinearity.a3 = -0.06;
            case.hidden.push("nonlinearity");
        }
        let path = dir.join(format!("case{seed}.csv"));
        testdata::write_csv(&path, &case.model, &testdata::layout_gains(&case.model, &gains), seed).unwrap();
        let r = gap::run(&path, None, &GapOptions::default()).unwrap();
        let want = sorted(case.hidden.iter().map(|s| (*s).to_string()));
        let named = sorted(r.named());
        println!("CSV seed {seed}: hidden {want:?} named {named:?}");
        assert!(want.iter().all(|w| named.contains(w)), "seed {seed}: hidden {want:?} named {named:?}");
        exact += usize::from(named == want);
        assert!(r.gap_final.gap <= 0.2 * r.gap_initial.gap, "{} -> {}", r.gap_initial.gap, r.gap_final.gap);
    }
    assert!(exact >= 2, "{exact} of 3 CSV cases named exactly their hidden effects");
}

/// A malformed CSV is refused by `scene-gen gap` with its line number, exit 2, nothing written;
/// a CSV next to a descriptor is refused too.
#[test]
fn cli_refuses_malformed_csv_with_its_line() {
    let dir = temp_dir("csv-bad");
    let out = dir.join("out");
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "exposure_s,gain_db,photons,mean_dn,temporal_var_dn2\n0.01,0,0,10,4\n0.01,0,1000,x,9\n")
        .unwrap();
    let refused_with = |csv: &Path, place: &str, field: &str| {
        let o = bin().arg("gap").arg(csv).arg("--out").arg(&out).output().unwrap();
        assert_eq!(o.status.code(), Some(2));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(place) && err.contains(field), "{err}");
        assert!(!out.exists());
    };
    refused_with(&bad, "bad.csv:3", "mean_dn");
    let lux = dir.join("lux.csv");
    std::fs::write(&lux, "exposure_s,gain_db,illuminance_lux,mean_dn,temporal_var_dn2\n0.01,0,0,10,4\n0.01,0,5,90,9\n")
        .unwrap();
    refused_with(&lux, "lux.csv:2", "photons");
    let (_, desc) = write_case(4, 0, &dir.join("data"));
    let o = bin().arg("gap").arg(&desc).arg(&bad).arg("--out").arg(&out).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(!out.exists());
}

/// `scene-gen gap A.txt B.txt --json`: two descriptors of one camera at two gains.
#[test]
fn cli_takes_several_descriptors() {
    let dir = temp_dir("cli-multi");
    let case = testdata::random_multigain_case(61, Some(0));
    let layout = testdata::layout_gains(&case.model, &[0.0, 12.0]);
    let descs = testdata::write_multigain(&dir.join("data"), &case.model, &layout, 8).unwrap();
    let out = dir.join("out");
    let o = bin().arg("gap").args(&descs).arg("--out").arg(&out).arg("--json").output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(sorted(v["named"].as_array().unwrap().iter().map(|n| n.as_str().unwrap().to_string())), case.hidden);
    let model = SensorModel::from_toml(&std::fs::read_to_string(out.join("model.toml")).unwrap()).unwrap();
    assert!(model.effects.read_noise_split.enabled);
}

/// The direct 2-D DFT the FFT replaced (`stats::peaks_2d` before: along x per row, then along y
/// per frequency, with twiddle tables), kept as the reference.
fn direct_periodogram(img: &[f64], w: usize, h: usize, over: usize) -> Vec<f64> {
    let m = img.iter().sum::<f64>() / img.len() as f64;
    let nfx = over * w / 2 + 1;
    let nfy = over * h;
    let fx: Vec<f64> = (0..nfx).map(|k| k as f64 / (over * w) as f64).collect();
    let fy: Vec<f64> = (0..nfy).map(|k| k as f64 / (over * h) as f64 - 0.5).collect();
    let tw = std::f64::consts::TAU;
    let tx: Vec<(f64, f64)> =
        fx.iter().flat_map(|f| (0..w).map(move |c| ((tw * f * c as f64).cos(), -(tw * f * c as f64).sin()))).collect();
    let ty: Vec<(f64, f64)> =
        fy.iter().flat_map(|g| (0..h).map(move |r| ((tw * g * r as f64).cos(), -(tw * g * r as f64).sin()))).collect();
    let mut xr = vec![(0.0f64, 0.0f64); nfx * h];
    for r in 0..h {
        let row: Vec<f64> = img[r * w..(r + 1) * w].iter().map(|v| v - m).collect();
        for k in 0..nfx {
            let t = &tx[k * w..(k + 1) * w];
            let (mut re, mut im) = (0.0, 0.0);
            for (v, (c, s)) in row.iter().zip(t) {
                re += v * c;
                im += v * s;
            }
            xr[k * h + r] = (re, im);
        }
    }
    let n2 = ((w * h) as f64).powi(2);
    let mut p = vec![0f64; nfx * nfy];
    for k in 0..nfx {
        let col = &xr[k * h..(k + 1) * h];
        for j in 0..nfy {
            let t = &ty[j * h..(j + 1) * h];
            let (mut re, mut im) = (0.0, 0.0);
            for ((a, b), (c, s)) in col.iter().zip(t) {
                re += a * c - b * s;
                im += a * s + b * c;
            }
            p[k * nfy + j] = 4.0 * (re * re + im * im) / n2;
        }
    }
    p
}

/// The FFT periodogram equals the direct 2-D DFT it replaced, to rounding.
#[test]
fn fft_periodogram_equals_the_direct_sum() {
    let mut rng = scene_gen::rng::stream(7, "test/periodogram");
    // Odd and even sizes, oversampling 1..3 (odd `over h`: the -0.5 shift is not a bin).
    for (w, h, over) in [(24, 18, 2), (17, 13, 2), (20, 15, 3), (9, 11, 1)] {
        let img: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                10.0 + rng.random::<f64>() + 0.7 * (std::f64::consts::TAU * (0.13 * x + 0.31 * y)).cos()
            })
            .collect();
        let (fx, fy, p) = stats::periodogram_2d(&img, w, h, over);
        let q = direct_periodogram(&img, w, h, over);
        assert_eq!((fx.len(), fy.len()), (over * w / 2 + 1, over * h));
        assert_eq!(p.len(), q.len());
        let scale = q.iter().copied().fold(0.0, f64::max);
        assert!(scale > 0.05, "the wave stands out: {scale}");
        for (i, (a, b)) in p.iter().zip(&q).enumerate() {
            assert!((a - b).abs() <= 1e-12 * scale, "{w}x{h} over {over}: bin {i}: fft {a} direct {b}");
        }
    }
}

/// The largest periodogram peak of a plane wave is at its frequency, with power A^2.
#[test]
fn peaks_find_a_plane_wave() {
    let (w, h) = (64, 48);
    let img: Vec<f64> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            (std::f64::consts::TAU * (0.125 * x - 0.25 * y)).cos()
        })
        .collect();
    let (found, _) = stats::peaks_2d(&img, w, h, 2, 2);
    let (p, fx, fy) = found[0];
    assert!((fx - 0.125).abs() < 1e-9 && (fy + 0.25).abs() < 1e-9, "{fx} {fy}");
    assert!((p - 1.0).abs() < 1e-9, "A^2 of a unit wave: {p}");
}

/// Effects outside the library (`testdata::Foreign`: dead pixels, a gamma response, column
/// gain, crosstalk; three sets of each, on hidden-effect cases 0..12 with their library effects)
/// are reported as unexplained, in the family where each shows, with where the misfit lives.
/// `cargo run --release --example gap_unexplained -- 0..40 foreign` measured: its own family
/// unexplained on 10 of 10 sets of dead pixels, gamma and crosstalk, and on 7 of 10 of column
/// gain (sd 1..3 %, which a fitted fall-off or PRNU partly absorbs); 37 of 40 report something
/// unexplained. Effects whose evidence rests on the unexplained statistics are reported as
/// tentative, not named; still, 15 of the 40 name a library effect that is not there: black
/// level on 7 (also the commonest false name on library sets, whose dark frames clip at 0 DN),
/// and 8 more where the foreign misfit also moves a statistic the final model explains (a fall-off
/// or PRNU for column gain or dead pixels, DSNU or hot pixels for crosstalk). On cases 0..12 (this
/// test): 12 caught, each in its own family, no extra name on 7; the gates leave room for the
/// noise draw.
#[test]
fn effects_outside_the_library_are_reported_unexplained() {
    let dir = temp_dir("foreign");
    let (mut own_family, mut caught, mut no_extra) = (0, 0, 0);
    let mut report = Vec::new();
    for seed in 0..12u64 {
        let case = testdata::random_case(seed, (seed % 3) as usize);
        let layout = testdata::layout(&case.model);
        let foreign = testdata::random_foreign(seed);
        let case_dir = dir.join(format!("case{seed}"));
        let desc = testdata::write_dataset_foreign(&case_dir, &case.model, &layout, seed + 1000, foreign).unwrap();
        let r = gap::run(&desc, None, &GapOptions::default()).unwrap();
        let unexplained = r.unexplained();
        let extra: Vec<String> = r.named().into_iter().filter(|n| !case.hidden.contains(&n.as_str())).collect();
        own_family += usize::from(unexplained.contains(&foreign.family()));
        caught += usize::from(!unexplained.is_empty());
        no_extra += usize::from(extra.is_empty());
        // Where the misfit lives is said for every unexplained family.
        for u in r.misfit.iter().flat_map(|m| &m.unexplained) {
            assert!(u.r#where.starts_with(u.family) && !u.statistics.is_empty(), "{u:?}");
        }
        report.push(format!("{}: unexplained {unexplained:?}, extra names {extra:?}", foreign.name()));
        let _ = std::fs::remove_dir_all(&case_dir);
    }
    println!("{report:#?}");
    assert!(own_family >= 9, "the effect's own family unexplained on {own_family} of 12: {report:#?}");
    assert!(caught >= 10, "unexplained reported on {caught} of 12: {report:#?}");
    assert!(no_extra >= 5, "a library effect named for a foreign one on {} of 12: {report:#?}", 12 - no_extra);
}

/// The report says what is unexplained: report.md's section, report.json's `unexplained` and
/// `misfit_check`, and the `--json` summary.
#[test]
fn cli_reports_unexplained_misfit() {
    let dir = temp_dir("cli-unexplained");
    let case = testdata::random_case(0, 0);
    let layout = testdata::layout(&case.model);
    let dead = testdata::Foreign::DeadPixels { fraction: 0.005, response: 0.1 };
    let desc = testdata::write_dataset_foreign(&dir.join("data"), &case.model, &layout, 1000, dead).unwrap();
    let out = dir.join("out");
    let o = bin().arg("gap").arg(&desc).arg("--out").arg(&out).arg("--json").output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let families: Vec<&str> =
        summary["unexplained"].as_array().unwrap().iter().filter_map(|u| u["family"].as_str()).collect();
    assert!(families.contains(&"tails"), "{summary}");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("## Unexplained") && md.contains("**tails**"), "{md}");
    let full: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(full["misfit_check"]["replicates"], 8);
    // Without replicates the test is skipped and says so.
    let o =
        bin().arg("gap").arg(&desc).arg("--out").arg(dir.join("out0")).arg("--replicates").arg("0").output().unwrap();
    assert!(o.status.success());
    let md = std::fs::read_to_string(dir.join("out0").join("report.md")).unwrap();
    assert!(md.contains("Not tested (no replicates)."), "{md}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `remove_waves` fits each wave by least squares at the best of its refinement grid, from the
/// image projected on one axis: a pure plane wave 1/8 and 2/8 of a bin off the given frequency,
/// of any phase, is removed to rounding.
#[test]
fn remove_waves_takes_out_an_off_grid_plane_wave() {
    let (w, h) = (96, 64);
    let (fx0, fy0) = (0.1875, -0.09375);
    let (fx, fy) = (fx0 + 1.0 / (8.0 * w as f64), fy0 - 2.0 / (8.0 * h as f64));
    let img: Vec<f64> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            2.5 * (std::f64::consts::TAU * (fx * x + fy * y) + 0.7).cos()
        })
        .collect();
    let left = stats::remove_waves(&img, w, h, &[(fx0, fy0)]);
    let worst = left.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(worst < 1e-9, "left {worst} DN of a 2.5 DN wave");
    // Off the grid by half a step the fit is the least-squares one of the nearest node: it
    // removes most of the wave, not all of it.
    let between = stats::remove_waves(&img, w, h, &[(fx0 + 0.5 / (8.0 * w as f64), fy0)]);
    let rms = (between.iter().map(|v| v * v).sum::<f64>() / between.len() as f64).sqrt();
    assert!(rms > 1e-6 && rms < 0.5, "half a step off: {rms} DN rms left");
}

/// The read-noise refit's expected dark-pair variance from the pixels' moments agrees with the
/// variance of pixel-drawn dark pairs within their sampling error, and grows with the read
/// noise's variance as `K^2` (the refit's secant lands in a step or two).
#[test]
fn pair_variance_from_moments_matches_drawn_pairs() {
    let (model, layout) = case_11_above_zero(None, (320, 240));
    let dark = layout.blocks.iter().position(|b| b.frames.len() == 2 && b.light == gap::Light::Dark).unwrap();
    let expected = gap::pair_variance_from_moments(&model, &layout, dark, 7).expect("dark rows clear 0 DN");
    let n = (layout.width * layout.height) as f64;
    let seeds = 6u64;
    let mut drawn = 0.0;
    for seed in 0..seeds {
        let sim = gap::simulate_acquisition(&model, &layout, seed, Some(&[dark]));
        let b = &sim.blocks[dark];
        let d: Vec<f64> = b.frames[0].iter().zip(&b.frames[1]).map(|(&x, &y)| f64::from(x) - f64::from(y)).collect();
        let md = d.iter().sum::<f64>() / n;
        drawn += d.iter().map(|v| (v - md) * (v - md)).sum::<f64>() / (n - 1.0) / 2.0 / seeds as f64;
    }
    let sd = expected * (2.0 / (n * seeds as f64)).sqrt();
    assert!((drawn - expected).abs() < 4.0 * sd, "drawn {drawn} DN^2, moments {expected} ({sd} sd)");
    let k = model.sensor.system_gain_dn_per_e;
    let mut louder = model.clone();
    louder.sensor.read_noise_e = (model.sensor.read_noise_e.powi(2) + 4.0).sqrt();
    let more = gap::pair_variance_from_moments(&louder, &layout, dark, 7).unwrap();
    let slope = (more - expected) / (4.0 * k * k);
    assert!((slope - 1.0).abs() < 0.01, "{expected} -> {more} DN^2 at K {k}: {slope} K^2 per e-^2");
}
