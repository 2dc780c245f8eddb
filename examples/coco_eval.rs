//! COCO bbox evaluation of a results file (or of an external detector's answers) against a
//! ground-truth file, printed as JSON: `{"ap", "ap50", "per_class": [...]}`. Used by
//! `tests/interop/check_coco.sh` to compare with pycocotools.
//!
//! ```text
//! cargo run --release --example coco_eval -- GT.json DETECTIONS.json
//! cargo run --release --example coco_eval -- GT.json --plugin PROGRAM [ARGS...]
//! ```
//!
//! With `--plugin`, every image of GT.json is sent to PROGRAM under the JSON-lines protocol of
//! `scene_gen::detection` (its `file_name` as the path) and the answers are evaluated.

use std::path::Path;
use std::process::ExitCode;

use scene_gen::detection::coco_eval::{CocoGroundTruth, evaluate, read_detections};
use scene_gen::detection::plugin::{self, PluginRequest};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: coco_eval GT.json DETECTIONS.json | coco_eval GT.json --plugin PROGRAM [ARGS...]");
        return ExitCode::from(2);
    }
    match run(&args) {
        Ok(json) => {
            println!("{json}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("coco_eval: {e}");
            ExitCode::from(1)
        }
    }
}

fn run(args: &[String]) -> Result<String, Box<dyn std::error::Error>> {
    let gt = CocoGroundTruth::read(Path::new(&args[0]))?;
    let detections = if args[1] == "--plugin" {
        let program = args.get(2).ok_or("--plugin needs a program")?;
        let requests: Vec<PluginRequest> = gt
            .images
            .iter()
            .map(|i| PluginRequest { image_id: i.id, path: i.file_name.clone(), width: i.width, height: i.height })
            .collect();
        plugin::run(program, &args[3..], &requests)?
    } else {
        read_detections(Path::new(&args[1]))?
    };
    Ok(serde_json::to_string(&evaluate(&gt, &detections)?)?)
}
