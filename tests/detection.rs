//! Detection task: ground truth from rendered instance buffers, and the built-in
//! detectability model scored with the COCO evaluator.

use glam::{Mat4, Vec3};
use scene_gen::detection::coco_eval::{CocoCategory, CocoGroundTruth, CocoImage, evaluate};
use scene_gen::detection::ground_truth::to_annotations;
use scene_gen::detection::{
    DetectabilityModel, Detector, DetectorInput, GroundTruthConfig, GtObject, NoiseSource, frame_ground_truth,
};
use scene_gen::render::test_util::{add_material, add_mesh, box_primitive, camera, empty_scene};
use scene_gen::render::{Camera, RenderSettings, Renderer};
use scene_gen::scene::{Object, ObjectClass, Scene, Semantic, THRESHOLD_CLASS_ID, Threshold};
use scene_gen::sensor::noise::normal;

/// A 1 m cube (chair, instance 1) 3 m ahead of a camera at the origin looking along +X, a
/// smaller box (table, instance 2) at 2 m hiding its left part (+Y is image left) when
/// `with_occluder`, and a threshold (instance 3) on the right.
fn scene(with_occluder: bool) -> Scene {
    let mut s = empty_scene();
    let m = add_material(&mut s, "grey", [0.5; 3], 0.0, 0.8);
    let object = |s: &mut Scene, class: ObjectClass, instance_id: u32, min: Vec3, max: Vec3| {
        let id = s.objects.len() as u32;
        s.objects.push(Object {
            id,
            class,
            instance_id,
            room: 0,
            asset: "test/box".into(),
            min,
            max,
            yaw_deg: 0.0,
            on: None,
        });
        add_mesh(s, box_primitive(min, max, m, false), Mat4::IDENTITY, Semantic::Object { id });
    };
    object(&mut s, ObjectClass::Chair, 1, Vec3::new(3.0, -0.5, 0.0), Vec3::new(4.0, 0.5, 1.0));
    if with_occluder {
        object(&mut s, ObjectClass::Table, 2, Vec3::new(2.0, 0.0, 0.2), Vec3::new(2.2, 0.4, 0.8));
    }
    let (min, max) = (Vec3::new(2.5, -0.9, 0.0), Vec3::new(2.7, -0.6, 0.3));
    s.thresholds.push(Threshold { id: 0, door: 0, instance_id: 3, min, max });
    add_mesh(&mut s, box_primitive(min, max, m, false), Mat4::IDENTITY, Semantic::Threshold { id: 0 });
    s
}

fn ground_truth(s: &Scene, config: &GroundTruthConfig) -> Vec<GtObject> {
    // 1 mm lens on a 0.8 x 0.6 mm sensor: 44 x 33 deg.
    let cam = Camera { focal_mm: 1.0, ..camera(160, 120, Vec3::new(0.0, 0.0, 0.5), 0.0, 0.0) };
    let frame = Renderer::new(s, RenderSettings::preview()).render(&cam).unwrap();
    let gt = frame_ground_truth(&frame, s, &cam, config);
    // The boxes are the tight boxes of the buffer's pixels.
    for o in &gt {
        let [x, y, w, h] = o.bbox.map(|v| v as u32);
        let inside = (0..frame.height)
            .flat_map(|py| (0..frame.width).map(move |px| (px, py)))
            .filter(|&(px, py)| frame.instance_id[frame.index(px, py)] == o.instance_id)
            .all(|(px, py)| px >= x && px < x + w && py >= y && py < y + h);
        assert!(inside, "instance {} has pixels outside its box", o.instance_id);
        let on_edges = [(x, y), (x + w - 1, y + h - 1)];
        assert!(
            on_edges
                .iter()
                .all(|&(px, _)| (0..frame.height).any(|py| frame.instance_id[frame.index(px, py)] == o.instance_id))
        );
    }
    gt
}

#[test]
fn ground_truth_boxes_occlusion_distance_and_classes() {
    let config = GroundTruthConfig::default();
    let alone = ground_truth(&scene(false), &config);
    let occluded = ground_truth(&scene(true), &config);
    let find = |gt: &[GtObject], id: u32| gt.iter().find(|o| o.instance_id == id).cloned().unwrap();
    let cube_alone = find(&alone, 1);
    // Alone, the rasterised mesh footprint is the rendered pixel set (to edge ties).
    assert!(cube_alone.visible_fraction > 0.98, "{cube_alone:?}");
    assert!((f64::from(cube_alone.footprint_px) / f64::from(cube_alone.visible_px) - 1.0).abs() < 0.03);
    // The occluder hides part of it; the footprint does not change.
    let cube = find(&occluded, 1);
    assert_eq!(cube.footprint_px, cube_alone.footprint_px);
    assert!(cube.visible_fraction < 0.9 && cube.visible_fraction > 0.3, "{cube:?}");
    assert!((cube.occluded_fraction() - (1.0 - cube.visible_fraction)).abs() < 1e-12);
    assert_eq!(cube.class_id, ObjectClass::Chair.class_id());
    // Nearest visible point of the cube: its front face at x = 3 (the centre ray meets it at
    // 3 m; the occluder hides part of the face but not the nearest point straight ahead).
    assert!((cube.distance_m - 3.0).abs() < 0.02, "{}", cube.distance_m);
    let table = find(&occluded, 2);
    assert!(table.visible_fraction > 0.97);
    assert!(table.distance_m > 2.0 && table.distance_m < 2.1, "{}", table.distance_m);
    let threshold = find(&occluded, 3);
    assert_eq!(threshold.class_id, THRESHOLD_CLASS_ID);
    assert!(occluded.iter().all(|o| o.counted), "all within 6 m and large enough at 160 x 120");
    // The pixel floor scales with the image: 100 px at 640 x 480 is 6.25 px at 160 x 120.
    assert_eq!(config.min_visible_px(160, 120), 6.25);
    let near = ground_truth(&scene(true), &GroundTruthConfig { max_distance_m: 2.5, ..config });
    let counted: Vec<u32> = near.iter().filter(|o| o.counted).map(|o| o.instance_id).collect();
    assert_eq!(counted, [2], "only the table is within 2.5 m");
    let floor = GroundTruthConfig { min_visible_px_vga: 4.0 * f64::from(threshold.visible_px + 1) * 16.0, ..config };
    assert!(!ground_truth(&scene(true), &floor).iter().find(|o| o.instance_id == 3).unwrap().counted);
    let anns = to_annotations(&near, 5, 10);
    assert_eq!(anns.len(), 1);
    assert_eq!((anns[0].id, anns[0].image_id, anns[0].category_id), (10, 5, ObjectClass::Table.class_id()));
}

/// A synthetic frame: a grid of `side x side` squares (alternating classes) on a flat
/// background, contrast 40 DN, white noise of `noise_dn`; its ground truth and COCO file.
struct Synthetic {
    width: u32,
    height: u32,
    image: Vec<f32>,
    ids: Vec<u32>,
    objects: Vec<GtObject>,
}

fn synthetic(side: u32, noise_dn: f64, seed: u64) -> Synthetic {
    let (width, height) = (320u32, 240u32);
    let mut ids = vec![0u32; (width * height) as usize];
    let mut objects = Vec::new();
    let pitch = 64;
    for gy in 0..3 {
        for gx in 0..5 {
            let instance_id = objects.len() as u32 + 1;
            let (x0, y0) = (gx * pitch + 8, gy * pitch + 8 + (instance_id % 3) * 2);
            for y in y0..y0 + side {
                for x in x0..x0 + side {
                    ids[(y * width + x) as usize] = instance_id;
                }
            }
            objects.push(GtObject {
                instance_id,
                class_id: 1 + instance_id % 2,
                bbox: [f64::from(x0), f64::from(y0), f64::from(side), f64::from(side)],
                visible_px: side * side,
                footprint_px: side * side,
                visible_fraction: 1.0,
                distance_m: 3.0,
                counted: true,
            });
        }
    }
    let mut rng = scene_gen::rng::stream(seed, "test/synthetic");
    let image =
        ids.iter().map(|&id| (if id > 0 { 100.0 } else { 60.0 } + noise_dn * normal(&mut rng)) as f32).collect();
    Synthetic { width, height, image, ids, objects }
}

fn mean_ap(side: u32, noise_dn: f64, model: &DetectabilityModel) -> (f64, f64) {
    let runs = 8;
    let (mut ap, mut ap50) = (0.0, 0.0);
    for seed in 0..runs {
        let s = synthetic(side, noise_dn, seed);
        let input = DetectorInput {
            image_dn: &s.image,
            width: s.width,
            height: s.height,
            instance_id: &s.ids,
            objects: &s.objects,
            noise: NoiseSource::Measured,
            frame_seed: seed,
        };
        let dets: Vec<_> = model.detect(&input).iter().map(|d| d.record(1)).collect();
        let gt = CocoGroundTruth {
            images: vec![CocoImage { id: 1, width: s.width, height: s.height, file_name: String::new() }],
            annotations: to_annotations(&s.objects, 1, 1),
            categories: (1..=11).map(|id| CocoCategory { id, name: String::new() }).collect(),
        };
        let m = evaluate(&gt, &dets).unwrap();
        ap += m.ap / f64::from(runs as u32);
        ap50 += m.ap50 / f64::from(runs as u32);
    }
    (ap, ap50)
}

#[test]
fn clean_large_objects_are_found() {
    let (ap, ap50) = mean_ap(40, 0.0, &DetectabilityModel::default());
    assert!(ap50 > 0.97, "AP50 {ap50}");
    // Localisation error (0.5 px + 4 % per edge) costs the strict IoU thresholds a little.
    assert!(ap > 0.6 && ap < ap50, "AP {ap}");
}

#[test]
fn ap_falls_as_noise_rises() {
    let model = DetectabilityModel::default();
    let aps: Vec<f64> = [2.0, 20.0, 60.0, 120.0, 240.0].iter().map(|&n| mean_ap(16, n, &model).1).collect();
    for w in aps.windows(2) {
        assert!(w[1] <= w[0] + 0.03, "AP50 by noise {aps:?}");
    }
    assert!(aps[0] > 0.9 && aps[4] < 0.3, "AP50 by noise {aps:?}");
}

#[test]
fn ap_falls_as_objects_shrink() {
    let model = DetectabilityModel::default();
    let aps: Vec<f64> = [32, 16, 8, 4, 2].iter().map(|&s| mean_ap(s, 20.0, &model).1).collect();
    for w in aps.windows(2) {
        assert!(w[1] <= w[0] + 0.03, "AP50 by size {aps:?}");
    }
    assert!(aps[0] > 0.9 && aps[4] < 0.3, "AP50 by size {aps:?}");
}

#[test]
fn false_positives_only_on_clutter_and_deterministic() {
    let mut s = synthetic(20, 1.0, 3);
    // A textured stripe (a checkerboard of 40 DN, far above the noise) along the bottom.
    for y in 200..240u32 {
        for x in 0..320u32 {
            s.image[(y * 320 + x) as usize] = if (x / 2 + y / 2) % 2 == 0 { 40.0 } else { 80.0 };
        }
    }
    let model = DetectabilityModel { false_positive_rate: 1.0, ..DetectabilityModel::default() };
    let input = DetectorInput {
        image_dn: &s.image,
        width: s.width,
        height: s.height,
        instance_id: &s.ids,
        objects: &s.objects,
        noise: NoiseSource::Uniform(1.0),
        frame_seed: 9,
    };
    let dets = model.detect(&input);
    let fps: Vec<_> = dets.iter().filter(|d| d.score < 0.5).collect();
    // 32 px cells at 640 x 480 are 16 px at 320 x 240: the stripe (rows 200..240) touches
    // three rows of 20 cells, and with rate 1 each yields one false positive; the flat
    // background and the cells on objects yield none.
    assert_eq!(fps.len(), 60, "{fps:?}");
    assert!(fps.iter().all(|d| d.bbox[1] + d.bbox[3] > 190.0), "false positives off the clutter: {fps:?}");
    assert_eq!(dets, model.detect(&input), "same seed, same detections");
    let other = model.detect(&DetectorInput { frame_seed: 10, ..input });
    assert_ne!(dets, other);
}

/// Random ground truth on 1..4 images: a box from each tuple `(image, class, x, y, w, h)`.
fn coco_file(boxes: &[(u64, u32, f64, f64, f64, f64)]) -> CocoGroundTruth {
    CocoGroundTruth {
        images: (1..=4).map(|id| CocoImage { id, width: 640, height: 480, file_name: String::new() }).collect(),
        annotations: boxes
            .iter()
            .enumerate()
            .map(|(i, &(image_id, category_id, x, y, w, h))| scene_gen::detection::GtAnnotation {
                id: i as u64 + 1,
                image_id,
                category_id,
                bbox: [x, y, w, h],
                area: w * h,
                iscrowd: 0,
            })
            .collect(),
        categories: (1..=11).map(|id| CocoCategory { id, name: String::new() }).collect(),
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// For any ground truth: the ground truth itself scores AP 1 on every class that has
    /// some; one extra false positive ranked first never raises AP; AP stays in [0, 1].
    #[test]
    fn ap_invariants(
        boxes in proptest::collection::vec((1u64..=4, 1u32..=11, 0.0..600.0f64, 0.0..440.0f64, 1.0..200.0f64, 1.0..200.0f64), 1..30),
        fp in (1u64..=4, 1u32..=11, 0.0..600.0f64, 0.0..440.0f64, 1.0..200.0f64, 1.0..200.0f64),
    ) {
        let gt = coco_file(&boxes);
        let perfect: Vec<_> = gt.annotations.iter().map(|a| scene_gen::detection::DetectionRecord {
            image_id: a.image_id, category_id: a.category_id, bbox: a.bbox, score: 0.5,
        }).collect();
        let m = evaluate(&gt, &perfect).unwrap();
        for c in &m.per_class {
            if c.num_gt > 0 {
                proptest::prop_assert!((c.ap - 1.0).abs() < 1e-9 && (c.ap50 - 1.0).abs() < 1e-9);
            } else {
                proptest::prop_assert_eq!(c.ap, -1.0);
            }
        }
        let mut with_fp = perfect.clone();
        with_fp.push(scene_gen::detection::DetectionRecord {
            image_id: fp.0, category_id: fp.1, bbox: [fp.2, fp.3, fp.4, fp.5], score: 0.9,
        });
        let m2 = evaluate(&gt, &with_fp).unwrap();
        proptest::prop_assert!(m2.ap50 <= m.ap50 + 1e-12 && m2.ap <= m.ap + 1e-12);
        proptest::prop_assert!((0.0..=1.0).contains(&m2.ap) && (0.0..=1.0).contains(&m2.ap50));
    }
}

/// The whole chain on a rendered room: render, ground truth, a DN image with noise, the
/// built-in detector, COCO AP. More noise must not help.
#[test]
fn rendered_room_end_to_end() {
    use scene_gen::render::test_util::room_of_boxes;
    let s = room_of_boxes(Vec3::new(6.0, 5.0, 2.6), 3);
    let cam = Camera { focal_mm: 1.2, ..camera(160, 120, Vec3::new(0.3, 0.3, 1.5), 40.0, -25.0) };
    let frame = Renderer::new(&s, RenderSettings::preview()).render(&cam).unwrap();
    let objects = frame_ground_truth(&frame, &s, &cam, &GroundTruthConfig::default());
    let counted = objects.iter().filter(|o| o.counted).count();
    assert!(counted >= 4, "{objects:?}");
    let lum = scene_gen::render::Frame::luminance_nit(&frame.day_nit);
    let mean = lum.iter().sum::<f32>() / lum.len() as f32;
    let gt = CocoGroundTruth {
        images: vec![CocoImage { id: 1, width: 160, height: 120, file_name: String::new() }],
        annotations: to_annotations(&objects, 1, 1),
        categories: (1..=11).map(|id| CocoCategory { id, name: String::new() }).collect(),
    };
    let ap50 = |noise_dn: f64| -> f64 {
        (0..6u64)
            .map(|seed| {
                let mut rng = scene_gen::rng::stream(seed, "test/rendered");
                let image: Vec<f32> =
                    lum.iter().map(|&l| (100.0 * l / mean) as f32 + (noise_dn * normal(&mut rng)) as f32).collect();
                let input = DetectorInput {
                    image_dn: &image,
                    width: 160,
                    height: 120,
                    instance_id: &frame.instance_id,
                    objects: &objects,
                    noise: NoiseSource::Uniform(noise_dn),
                    frame_seed: seed,
                };
                let dets: Vec<_> = DetectabilityModel::default().detect(&input).iter().map(|d| d.record(1)).collect();
                evaluate(&gt, &dets).unwrap().ap50
            })
            .sum::<f64>()
            / 6.0
    };
    let (clean, noisy) = (ap50(0.5), ap50(200.0));
    eprintln!("rendered room: {counted} counted objects, AP50 {clean:.3} at 0.5 DN noise, {noisy:.3} at 200 DN");
    assert!(clean > 0.6, "clean AP50 {clean}");
    assert!(noisy < clean, "noisy {noisy} vs clean {clean}");
}
