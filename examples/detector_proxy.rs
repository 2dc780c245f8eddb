//! Does the fast detectability model rank cameras as the learned detector does? Evaluates
//! each candidate camera on the same houses and frames twice, with `--detector model` and
//! `--detector cnn`, and prints AP@0.5 of both per scenario with Spearman's rank correlation
//! over every (candidate, scenario) pair, by day, by night and over both.
//!
//! ```text
//! cargo run --release --example detector_proxy -- [SEEDS] [FRAMES]     (default 0..2, 25)
//! ```

use scene_gen::camera_spec::CameraSpec;
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

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seeds: Vec<u64> = args.get(1).map_or("0..2", String::as_str).parse::<SeedRange>()?.iter().collect();
    let frames: u32 = args.get(2).map_or(Ok(25), |s| s.parse())?;
    let config = |detector| EvalConfig { frames_per_scene: frames, detector, ..EvalConfig::default() };
    let (model_cfg, cnn_cfg) = (config(DetectorChoice::Model), config(DetectorChoice::Cnn));
    println!("| camera | day model | day cnn | night model | night cnn |");
    println!("|---|---|---|---|---|");
    let (mut model, mut cnn) = ([Vec::new(), Vec::new()], [Vec::new(), Vec::new()]);
    for text in CANDIDATES {
        let spec = CameraSpec::from_inline(text)?;
        let m = evaluate(&spec, &seeds, &model_cfg)?;
        let c = evaluate(&spec, &seeds, &cnn_cfg)?;
        let pairs = [(m.scenarios.day.ap50, c.scenarios.day.ap50), (m.scenarios.night.ap50, c.scenarios.night.ap50)];
        for (s, (a, b)) in pairs.into_iter().enumerate() {
            model[s].push(a);
            cnn[s].push(b);
        }
        println!("| `{text}` | {:.3} | {:.3} | {:.3} | {:.3} |", pairs[0].0, pairs[0].1, pairs[1].0, pairs[1].1);
    }
    let all = |v: &[Vec<f64>; 2]| [v[0].clone(), v[1].clone()].concat();
    println!();
    println!("Spearman rho, model against cnn AP@0.5 over {} candidates:", CANDIDATES.len());
    println!("  day   {:.3}", spearman(&model[0], &cnn[0]));
    println!("  night {:.3}", spearman(&model[1], &cnn[1]));
    println!("  both  {:.3}", spearman(&all(&model), &all(&cnn)));
    Ok(())
}
