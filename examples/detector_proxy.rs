//! Does the fast detectability model rank cameras as the learned detector does? Evaluates
//! each candidate camera on the same houses and frames with `--detector cnn` and with the
//! model, and prints AP@0.5 of both per scenario with Spearman's rank correlation over every
//! (candidate, scenario) pair.
//!
//! Then fits the model to the detector: the even-numbered candidates are the fitting set, on
//! which a coordinate search picks `N50`, the truncation factor and the occlusion exponent
//! ([`DetectabilityModel`]) that maximise the rank correlation; the odd-numbered candidates,
//! never used in the fit, give the correlation of the fitted model.
//!
//! ```text
//! cargo run --release --example detector_proxy -- [SEEDS] [FRAMES]     (default 0..2, 25)
//! ```

use scene_gen::camera_spec::CameraSpec;
use scene_gen::detection::detectability::DetectabilityModel;
use scene_gen::evaluate::{DetectorChoice, EvalConfig, evaluate};
use scene_gen::seeds::SeedRange;
use scene_gen::stats::spearman;

/// Sensors from small to large pixels, focal lengths from very wide to narrow, pitches,
/// apertures and night gains: cameras the optimizer could propose.
const CANDIDATES: [&str; 24] = [
    "IMX172,focal_mm=4",
    "IMX172,focal_mm=8",
    "IMX172,focal_mm=4,gain_night_db=30",
    "IMX174,focal_mm=4,pitch_deg=-10",
    "IMX174,focal_mm=12",
    "IMX174,focal_mm=4,f_number=8",
    "IMX219,focal_mm=2.8",
    "IMX219,focal_mm=6",
    "IMX273,focal_mm=3.5",
    "IMX273,focal_mm=16",
    "PYTHON300,focal_mm=4",
    "PYTHON300,focal_mm=2",
    "IMX335,focal_mm=5,pitch_deg=-15",
    "IMX432,focal_mm=8",
    "AR0134,focal_mm=3",
    "MT9V022,focal_mm=2.5",
    "IMX415,focal_mm=4",
    "CMV4000,focal_mm=10",
    "IMX250,focal_mm=6,pitch_deg=-20",
    "LUX1310,focal_mm=5",
    "IMX326,focal_mm=1.6",
    "IMX178,focal_mm=25",
    "IMX287,focal_mm=3,pitch_deg=0",
    "IMX420,focal_mm=14,pitch_deg=-25",
];

/// Day and night AP@0.5 of one candidate.
type DayNight = [f64; 2];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seeds: Vec<u64> = args.get(1).map_or("0..2", String::as_str).parse::<SeedRange>()?.iter().collect();
    let frames: u32 = args.get(2).map_or(Ok(25), |s| s.parse())?;
    let specs: Vec<CameraSpec> = CANDIDATES.iter().map(|t| CameraSpec::from_inline(t)).collect::<Result<_, _>>()?;
    let config = |detector, detectability| EvalConfig {
        frames_per_scene: frames,
        detector,
        detectability,
        ..EvalConfig::default()
    };
    let ap = |spec: &CameraSpec, config: &EvalConfig| -> Result<DayNight, Box<dyn std::error::Error>> {
        let e = evaluate(spec, &seeds, config)?;
        Ok([e.scenarios.day.ap50, e.scenarios.night.ap50])
    };
    let default_model = DetectabilityModel::default();
    let cnn_config = config(DetectorChoice::Cnn, default_model);
    let model_config = config(DetectorChoice::Model, default_model);
    let mut cnn = Vec::new();
    let mut model = Vec::new();
    for spec in &specs {
        cnn.push(ap(spec, &cnn_config)?);
        model.push(ap(spec, &model_config)?);
    }
    let fit_set: Vec<usize> = (0..specs.len()).step_by(2).collect();
    let test_set: Vec<usize> = (1..specs.len()).step_by(2).collect();
    // Rank correlation of a model's APs with the CNN's over a set of candidates, day and night.
    let rho = |values: &dyn Fn(usize) -> DayNight, set: &[usize]| {
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for &i in set {
            a.extend(values(i));
            b.extend(cnn[i]);
        }
        spearman(&a, &b)
    };
    // Coordinate search on the fitting set, one parameter at a time from the defaults.
    let mut best = default_model;
    let mut best_rho = rho(&|i| model[i], &fit_set);
    let mut searched = vec![(best, best_rho)];
    type Setter = fn(&mut DetectabilityModel, f64);
    let axes: [(&str, Setter, &[f64]); 3] = [
        ("n50_cycles", |m, v| m.n50_cycles = v, &[3.0, 6.0, 10.0]),
        ("truncated_factor", |m, v| m.truncated_factor = v, &[0.6, 0.3]),
        ("occlusion_exponent", |m, v| m.occlusion_exponent = v, &[1.0, 2.0]),
    ];
    for (_, set, values) in axes {
        let start = best;
        for &v in values {
            let mut trial = start;
            set(&mut trial, v);
            let mut trial_ap = vec![[f64::NAN; 2]; specs.len()];
            for &i in &fit_set {
                trial_ap[i] = ap(&specs[i], &config(DetectorChoice::Model, trial))?;
            }
            let r = rho(&|i| trial_ap[i], &fit_set);
            searched.push((trial, r));
            if r > best_rho {
                (best, best_rho) = (trial, r);
            }
        }
    }
    let mut fitted = vec![[f64::NAN; 2]; specs.len()];
    for &i in &test_set {
        fitted[i] = ap(&specs[i], &config(DetectorChoice::Model, best))?;
    }
    println!("| camera | set | day model | day fitted | day cnn | night model | night fitted | night cnn |");
    println!("|---|---|---|---|---|---|---|---|");
    for (i, text) in CANDIDATES.iter().enumerate() {
        let set = if i % 2 == 0 { "fit" } else { "test" };
        let f = |v: f64| if v.is_nan() { "-".to_string() } else { format!("{v:.3}") };
        println!(
            "| `{text}` | {set} | {:.3} | {} | {:.3} | {:.3} | {} | {:.3} |",
            model[i][0],
            f(fitted[i][0]),
            cnn[i][0],
            model[i][1],
            f(fitted[i][1]),
            cnn[i][1]
        );
    }
    println!();
    println!("Coordinate search on the {} fitting candidates (rho over their day and night AP):", fit_set.len());
    for (m, r) in &searched {
        println!(
            "  n50 {:>4.1}  truncated {:.1}  occlusion {:.1}  rho {r:.3}",
            m.n50_cycles, m.truncated_factor, m.occlusion_exponent
        );
    }
    let all: Vec<usize> = (0..specs.len()).collect();
    let day_night = |s: usize, values: &[DayNight], set: &[usize]| {
        let a: Vec<f64> = set.iter().map(|&i| values[i][s]).collect();
        let b: Vec<f64> = set.iter().map(|&i| cnn[i][s]).collect();
        spearman(&a, &b)
    };
    println!();
    println!("Spearman rho against the CNN's AP@0.5:");
    println!(
        "  default model, all {} candidates: day {:.3}, night {:.3}, both {:.3}",
        all.len(),
        day_night(0, &model, &all),
        day_night(1, &model, &all),
        rho(&|i| model[i], &all)
    );
    println!("  default model, {} test candidates: both {:.3}", test_set.len(), rho(&|i| model[i], &test_set));
    println!(
        "  fitted model (n50 {:.1}, truncated {:.1}, occlusion {:.1}), {} test candidates: day {:.3}, night {:.3}, both {:.3}",
        best.n50_cycles,
        best.truncated_factor,
        best.occlusion_exponent,
        test_set.len(),
        day_night(0, &fitted, &test_set),
        day_night(1, &fitted, &test_set),
        rho(&|i| fitted[i], &test_set)
    );
    Ok(())
}
