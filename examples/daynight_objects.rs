//! Per-object figures of the built-in detectability model, by day and by night, on the frames
//! the evaluator scores (same houses, anchors, light scales, sensor, ISP and frame seeds as
//! `scene-gen evaluate`). One trace serves both scenarios, so the same ground-truth objects
//! appear in both columns. For every counted object: its critical dimension `D`, the mean 8-bit
//! level of the object and of its ring, and three noise figures with the probability each
//! gives:
//!
//! * `img`: the noise measured on the image (MAD of horizontal differences, the detector's
//!   fallback, what the evaluator used before);
//! * `sens`: the sensor's own noise around the object, measured as the RMS of (noisy capture
//!   minus the same capture with `noise = "off"`), object and ring;
//! * `tab`: the camera's noise table ([`scene_gen::detection::output_noise`]), what the
//!   evaluator uses now.
//!
//! The last lines give AP@0.5 of both scenarios with the noise table (as the evaluator scores
//! them) and the means over objects. Environment: `RECT=n` renders with `n x n` samples per
//! rect light, `CULL=x` sets the light-culling threshold (to see how much of the image
//! estimate is the renderer's sampling noise), `INDIRECT=n` traces `n` bounce rays per pixel.
//!
//! ```text
//! cargo run --release --example daynight_objects -- [CAMERA] [SEEDS] [FRAMES] [WIDTH]
//! cargo run --release --example daynight_objects -- IMX174,focal_mm=4,pitch_deg=-10 2 25 320
//! ```

use std::collections::BTreeSet;

use scene_gen::camera_spec::{CameraSpec, NoiseKind};
use scene_gen::capture::light_scales;
use scene_gen::detection::coco_eval::{CocoCategory, CocoGroundTruth, CocoImage, DetectionRecord, evaluate};
use scene_gen::detection::detectability::object_cnr;
use scene_gen::detection::ground_truth::to_annotations;
use scene_gen::detection::output_noise::output_noise_by_level;
use scene_gen::detection::{
    DetectabilityModel, Detector, DetectorInput, GroundTruthConfig, GtObject, NoiseSource, frame_ground_truth,
};
use scene_gen::evaluate::{capture_seed, detector_seed, eval_render_settings};
use scene_gen::house::{embedded_library, walked_house};
use scene_gen::isp::{Isp, OutputRule, to_8bit};
use scene_gen::optics::{OpticsInput, agent_velocity};
use scene_gen::radiometry::capture_frame;
use scene_gen::render::Renderer;
use scene_gen::scene::LightGroup;
use scene_gen::sensor::Catalog;
use scene_gen::trajectory::TrajectoryParams;

/// Per scenario: noise figures (image, sensor, table) and probabilities (same order).
#[derive(Clone, Copy, Default)]
struct Figures {
    mean_object: f64,
    mean_ring: f64,
    sigma: [f64; 3],
    p: [f64; 3],
}

#[allow(clippy::too_many_lines)]
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let camera = args.get(1).map_or("IMX174,focal_mm=4,pitch_deg=-10", String::as_str);
    let seeds: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(2);
    let frames: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(25);
    let width: u32 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(320);
    let mut spec = CameraSpec::from_inline(camera).expect("camera spec");
    spec.max_width_px = Some(width);
    let resolved = spec.resolve(&Catalog::embedded()).expect("resolves");
    // The same camera without sensor noise: noisy - clean is the sensor's noise alone.
    let clean_resolved =
        CameraSpec { noise: NoiseKind::Off, ..spec.clone() }.resolve(&Catalog::embedded()).expect("resolves");
    let library = embedded_library().expect("library");
    let model = DetectabilityModel::default();
    let gains = [spec.gain_day_db, spec.gain_night_db];
    let names = ["day", "night"];
    let channels = if spec.noise == NoiseKind::Affine { 3 } else { 1 };
    println!(
        "seed pose id class vis_px D | day: obj ring, sigma img/sens/tab, P img/sens/tab | night: the same | \
         zero % day/night"
    );
    let (mut sum_sigma, mut sum_p) = ([[0.0f64; 3]; 2], [[0.0f64; 3]; 2]);
    let mut count = 0usize;
    // AP@0.5 per scenario, with the noise table, with and without clutter false positives.
    let no_fp = DetectabilityModel { false_positive_rate: 0.0, ..model };
    let mut coco: Vec<CocoGroundTruth> = vec![CocoGroundTruth::default(); 2];
    for c in &mut coco {
        c.categories = (1..=11).map(|id| CocoCategory { id, name: String::new() }).collect();
    }
    let mut dets: Vec<[Vec<DetectionRecord>; 2]> = vec![[Vec::new(), Vec::new()], [Vec::new(), Vec::new()]];
    let mut image_id = 0u64;
    for seed in 0..seeds {
        let params = TrajectoryParams { height_m: spec.height_m, ..TrajectoryParams::default() };
        let walked = walked_house(&library, seed, &params).expect("house");
        let mut settings = eval_render_settings();
        if let Some(r) = std::env::var("RECT").ok().and_then(|v| v.parse().ok()) {
            settings.rect_samples_per_axis = r;
        }
        if let Some(c) = std::env::var("CULL").ok().and_then(|v| v.parse().ok()) {
            settings.light_cull = c;
        }
        if let Some(b) = std::env::var("INDIRECT").ok().and_then(|v| v.parse().ok()) {
            settings.indirect_rays = b;
        }
        let renderer = Renderer::new(&walked.scene, settings);
        let scales = light_scales(&renderer, seed, &[LightGroup::Day, LightGroup::Night]).expect("lights");
        let isps: Vec<Isp> = scales
            .iter()
            .enumerate()
            .map(|(s, light)| Isp::for_scenario(&resolved, gains[s], f64::from(light.target_lux), channels))
            .collect();
        let tables: Vec<Option<Vec<f64>>> = isps
            .iter()
            .enumerate()
            .map(|(s, isp)| output_noise_by_level(&resolved, gains[s], OutputRule::Isp, isp))
            .collect();
        let n = walked.walk.poses.len();
        let k = frames.min(n);
        let anchors: BTreeSet<usize> =
            (0..k).map(|i| ((i * (n - 1)) as f64 / (k.max(2) - 1) as f64).round() as usize).collect();
        for &i in &anchors {
            let pose = walked.walk.poses[i];
            let cam = resolved.camera_at(&pose);
            let frame = renderer.render(&cam).expect("render");
            let gt = frame_ground_truth(&frame, &walked.scene, &cam, &GroundTruthConfig::default());
            let mut rows = vec![[Figures::default(); 2]; gt.len()];
            let mut zeros = [0.0; 2];
            for (s, light) in scales.iter().enumerate() {
                let radiance = light.radiance(&frame);
                let frame_seed = capture_seed(seed, i, names[s]);
                let optics = || OpticsInput {
                    depth_m: &frame.depth_m,
                    velocity_m_s: agent_velocity(&resolved.spec, pose.yaw_deg, params.speed_m_per_s),
                };
                let cap = capture_frame(&resolved, &cam, &radiance, Some(optics()), gains[s], seed, frame_seed);
                let grey = to_8bit(&cap, OutputRule::Isp, &isps[s]);
                let cap0 = capture_frame(&clean_resolved, &cam, &radiance, Some(optics()), gains[s], seed, frame_seed);
                let clean = to_8bit(&cap0, OutputRule::Isp, &isps[s]);
                let image: Vec<f32> = grey.iter().map(|&v| f32::from(v)).collect();
                // DUMP=seed/pose writes that anchor's 8-bit images to /tmp.
                if std::env::var("DUMP").is_ok_and(|d| d == format!("{seed}/{i}")) {
                    let path = format!("/tmp/daynight_{seed}_{i}_{}.png", names[s]);
                    image::GrayImage::from_raw(cap.width, cap.height, grey.clone())
                        .expect("size")
                        .save(&path)
                        .expect("png");
                    let ids: Vec<u8> = frame.instance_id.iter().map(|&id| (id * 37 % 256) as u8).collect();
                    image::GrayImage::from_raw(cap.width, cap.height, ids)
                        .expect("size")
                        .save(format!("/tmp/daynight_{seed}_{i}_ids.png"))
                        .expect("png");
                }
                let diff: Vec<f32> = grey.iter().zip(&clean).map(|(&a, &b)| f32::from(a) - f32::from(b)).collect();
                zeros[s] = grey.iter().filter(|&&v| v == 0).count() as f64 / grey.len() as f64;
                let input = DetectorInput {
                    image_dn: &image,
                    width: cap.width,
                    height: cap.height,
                    instance_id: &frame.instance_id,
                    objects: &gt,
                    noise: NoiseSource::Measured,
                    frame_seed,
                };
                let measured = NoiseSource::Measured.table(&input);
                let table = tables[s].as_deref().map_or_else(|| measured.clone(), <[f64]>::to_vec);
                image_id += 1;
                let c = &mut coco[s];
                c.images.push(CocoImage {
                    id: image_id,
                    width: cap.width,
                    height: cap.height,
                    file_name: String::new(),
                });
                let first = c.annotations.len() as u64 + 1;
                c.annotations.extend(to_annotations(&gt, image_id, first));
                let detector_seed = detector_seed(seed, i);
                let by_table =
                    DetectorInput { noise: NoiseSource::ByLevel(&table), frame_seed: detector_seed, ..input };
                for (m, d) in [model, no_fp].iter().zip(dets.iter_mut()) {
                    d[s].extend(m.detect(&by_table).iter().map(|x| x.record(image_id)));
                }
                for (o, row) in gt.iter().zip(&mut rows) {
                    if !o.counted {
                        continue;
                    }
                    let (mean_object, mean_ring, sensor) = ring_figures(&input, o, &diff);
                    let d = f64::from(o.visible_px).sqrt();
                    let contrast = (mean_object - mean_ring).abs();
                    // The sigma a CNR implies: contrast / CNR.
                    let cnr_table = object_cnr(&input, o, &table);
                    let sigma = [measured[0], sensor, contrast / cnr_table];
                    let p = [
                        model.object_probability(&input, o, &measured),
                        model.probability(d, contrast / sensor),
                        model.object_probability(&input, o, &table),
                    ];
                    row[s] = Figures { mean_object, mean_ring, sigma, p };
                    for j in 0..3 {
                        sum_sigma[s][j] += sigma[j];
                        sum_p[s][j] += p[j];
                    }
                }
            }
            for (o, row) in gt.iter().zip(&rows) {
                if !o.counted {
                    continue;
                }
                count += 1;
                let f = |x: &Figures| {
                    format!(
                        "{:5.1} {:5.1}, {:5.2} {:5.2} {:5.2}, {:.2} {:.2} {:.2}",
                        x.mean_object, x.mean_ring, x.sigma[0], x.sigma[1], x.sigma[2], x.p[0], x.p[1], x.p[2]
                    )
                };
                println!(
                    "{seed} {i:4} {:4} {:2} {:5} {:5.1} | {} | {} | {:.0}/{:.0}",
                    o.instance_id,
                    o.class_id,
                    o.visible_px,
                    f64::from(o.visible_px).sqrt(),
                    f(&row[0]),
                    f(&row[1]),
                    100.0 * zeros[0],
                    100.0 * zeros[1],
                );
            }
        }
    }
    for (name, d) in ["with false positives", "without"].iter().zip(&dets) {
        let ap: Vec<f64> = (0..2).map(|s| evaluate(&coco[s], &d[s]).expect("coco").ap50).collect();
        let fps: Vec<usize> = (0..2).map(|s| d[s].iter().filter(|r| r.score < 0.5).count()).collect();
        println!(
            "AP@0.5 with the noise table, {name}: day {:.3} / night {:.3} ({} / {} scores below 0.5)",
            ap[0], ap[1], fps[0], fps[1]
        );
    }
    let c = count.max(1) as f64;
    println!("{count} counted objects; means over objects, day / night:");
    for (j, name) in ["image estimate", "sensor (noisy - clean)", "noise table"].iter().enumerate() {
        println!(
            "  {name:24} sigma {:5.2} / {:5.2} DN, P {:.3} / {:.3}",
            sum_sigma[0][j] / c,
            sum_sigma[1][j] / c,
            sum_p[0][j] / c,
            sum_p[1][j] / c
        );
    }
}

/// Mean level of the object and of its ring (the pixels `object_cnr` uses), and the RMS of the
/// sensor noise `diff` over them (object and ring weighted equally, as `object_cnr` does).
fn ring_figures(input: &DetectorInput<'_>, o: &GtObject, diff: &[f32]) -> (f64, f64, f64) {
    let (w, h) = (i64::from(input.width), i64::from(input.height));
    let margin = (0.25 * f64::from(o.visible_px).sqrt()).max(2.0).round() as i64;
    let [bx, by, bw, bh] = o.bbox;
    let (x0, y0) = ((bx as i64 - margin).max(0), (by as i64 - margin).max(0));
    let (x1, y1) = (((bx + bw) as i64 + margin).min(w), ((by + bh) as i64 + margin).min(h));
    let (mut so, mut vo, mut no, mut sr, mut vr, mut nr) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for y in y0..y1 {
        for x in x0..x1 {
            let i = (y * w + x) as usize;
            let v = f64::from(input.image_dn[i]);
            let d = f64::from(diff[i]);
            if input.instance_id[i] == o.instance_id {
                so += v;
                vo += d * d;
                no += 1.0;
            } else {
                sr += v;
                vr += d * d;
                nr += 1.0;
            }
        }
    }
    let (no, nr) = (f64::max(no, 1.0), f64::max(nr, 1.0));
    (so / no, sr / nr, (0.5 * (vo / no + vr / nr)).sqrt().max(0.2887))
}
