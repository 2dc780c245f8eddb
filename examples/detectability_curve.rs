//! AP of the built-in detectability model against noise and object size, on a synthetic frame
//! (15 squares, contrast 40 DN on a flat 60 DN background, white noise), averaged over 16
//! seeds. Shows how the model trades size and contrast-to-noise.
//!
//! ```text
//! cargo run --release --example detectability_curve
//! ```

use scene_gen::detection::coco_eval::{CocoCategory, CocoGroundTruth, CocoImage, evaluate};
use scene_gen::detection::ground_truth::to_annotations;
use scene_gen::detection::{DetectabilityModel, Detector, DetectorInput, GtObject, NoiseSource};
use scene_gen::sensor::noise::normal;

fn frame(side: u32, noise_dn: f64, seed: u64) -> (Vec<f32>, Vec<u32>, Vec<GtObject>) {
    let (w, h) = (320u32, 240u32);
    let mut ids = vec![0u32; (w * h) as usize];
    let mut objects = Vec::new();
    for gy in 0..3 {
        for gx in 0..5 {
            let instance_id = objects.len() as u32 + 1;
            let (x0, y0) = (gx * 64 + 8, gy * 64 + 8);
            for y in y0..y0 + side {
                for x in x0..x0 + side {
                    ids[(y * w + x) as usize] = instance_id;
                }
            }
            let s = f64::from(side);
            objects.push(GtObject {
                instance_id,
                class_id: 1,
                bbox: [f64::from(x0), f64::from(y0), s, s],
                visible_px: side * side,
                footprint_px: side * side,
                visible_fraction: 1.0,
                distance_m: 3.0,
                counted: true,
            });
        }
    }
    let mut rng = scene_gen::rng::stream(seed, "example/detectability");
    let image =
        ids.iter().map(|&id| (if id > 0 { 100.0 } else { 60.0 } + noise_dn * normal(&mut rng)) as f32).collect();
    (image, ids, objects)
}

fn ap(side: u32, noise_dn: f64, model: &DetectabilityModel) -> (f64, f64) {
    let runs = 16u64;
    let (mut ap, mut ap50) = (0.0, 0.0);
    for seed in 0..runs {
        let (image, ids, objects) = frame(side, noise_dn, seed);
        let input = DetectorInput {
            image_dn: &image,
            width: 320,
            height: 240,
            instance_id: &ids,
            objects: &objects,
            noise: NoiseSource::Measured,
            frame_seed: seed,
        };
        let dets: Vec<_> = model.detect(&input).iter().map(|d| d.record(1)).collect();
        let gt = CocoGroundTruth {
            images: vec![CocoImage { id: 1, width: 320, height: 240, file_name: String::new() }],
            annotations: to_annotations(&objects, 1, 1),
            categories: vec![CocoCategory { id: 1, name: "square".into() }],
        };
        let m = evaluate(&gt, &dets).expect("synthetic detections are on image 1");
        ap += m.ap / runs as f64;
        ap50 += m.ap50 / runs as f64;
    }
    (ap, ap50)
}

fn main() {
    let model = DetectabilityModel::default();
    println!("side_px noise_dn cnr_per_px  AP50   AP[.5:.95]");
    for side in [32, 16, 8, 4] {
        for noise in [1.0, 10.0, 20.0, 40.0, 80.0, 160.0] {
            let (a, a50) = ap(side, noise, &model);
            println!("{side:7} {noise:8.0} {:10.2} {a50:6.3} {a:8.3}", 40.0 / noise);
        }
    }
}
