//! GA against random search: the best fitness so far of two `scene-gen optimize` run folders
//! against the evaluations spent, in one chart (docs/img/optimize_ga_vs_random.png).
//!
//! ```text
//! cargo run --release --example optimize_curves -- GA_DIR RANDOM_DIR OUT.png
//! ```

use std::path::Path;

use scene_gen::optimize::run::{GenerationStats, read_generations_csv};
use scene_gen::plot::{Series, line_chart, to_png};

fn read(dir: &str) -> Result<Vec<GenerationStats>, String> {
    let path = Path::new(dir).join("generations.csv");
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    read_generations_csv(&text).map_err(|e| format!("{}: {e}", path.display()))
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [ga, random, out] = args.as_slice() else {
        return Err("usage: optimize_curves GA_DIR RANDOM_DIR OUT.png".into());
    };
    let (ga, random) = (read(ga)?, read(random)?);
    let series = vec![
        Series {
            label: "GA best so far".into(),
            color: [200, 40, 40],
            points: ga.iter().map(|s| (s.1 as f64, s.4)).collect(),
        },
        Series {
            label: "random best so far".into(),
            color: [40, 80, 200],
            points: random.iter().map(|s| (s.1 as f64, s.4)).collect(),
        },
        Series {
            label: "GA generation mean".into(),
            color: [240, 160, 40],
            points: ga.iter().map(|s| (s.1 as f64, s.3)).collect(),
        },
    ];
    let img = line_chart("fitness vs evaluations: GA and random search", &series, 720, 420);
    scene_gen::export::write_atomic(Path::new(out), &to_png(&img)).map_err(|e| e.to_string())?;
    for (name, s) in [("GA", &ga), ("random", &random)] {
        if let Some(last) = s.last() {
            println!("{name}: {} evaluations, best so far {:.4}", last.1, last.4);
        }
    }
    Ok(())
}
