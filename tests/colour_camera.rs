//! The colour camera inside a house: what `render` writes and what the evaluator sees are one
//! chain (CFA mosaic, ISP, luma), and the evaluator's noise table follows that chain.

use scene_gen::camera_spec::{CameraSpec, NoiseKind, ResolvedCamera};
use scene_gen::capture::{Capture, luma_of_srgb};
use scene_gen::detection::output_noise::colour_output_noise_by_level;
use scene_gen::house::{embedded_library, walked_house};
use scene_gen::isp::{self, OutputRule};
use scene_gen::render::RenderSettings;
use scene_gen::scene::LightGroup;
use scene_gen::sensor::Catalog;
use scene_gen::trajectory::TrajectoryParams;

/// `spec` binned to 96 px wide unless it says otherwise.
fn camera(spec: &str) -> ResolvedCamera {
    let spec = CameraSpec::from_arg(spec).unwrap();
    CameraSpec { max_width_px: spec.max_width_px.or(Some(96)), ..spec }.resolve(&Catalog::embedded()).unwrap()
}

#[test]
fn opencv_luma_of_primaries() {
    // cv2.cvtColor(RGB2GRAY) of white, black, pure red, green and blue.
    let rgb = [255, 255, 255, 0, 0, 0, 255, 0, 0, 0, 255, 0, 0, 0, 255];
    assert_eq!(luma_of_srgb(&rgb), vec![255, 0, 76, 150, 29]);
}

#[test]
fn the_evaluator_sees_the_luma_of_the_developed_mosaic() {
    let walked = walked_house(&embedded_library().unwrap(), 3, &TrajectoryParams::default()).unwrap();
    let groups = [LightGroup::Day, LightGroup::Night];
    for spec in ["IMX174,focal_mm=4", "IMX174,focal_mm=4,noise=affine"] {
        let resolved = camera(spec);
        let colour = resolved.spec.noise != NoiseKind::Affine;
        let capture = Capture::new(&walked.scene, &resolved, &groups, RenderSettings::preview(), 1.0, "t/").unwrap();
        let pose = walked.walk.poses[4];
        let pinhole = capture.pinhole(&pose);
        let frame = capture.render(&pinhole).unwrap();
        let raws = capture.sensor_images(&frame, &pinhole, &pose, 4);
        let isp_images = capture.images_8bit(&frame, &pinhole, &pose, 4, OutputRule::Isp);
        let top_bits = capture.images_8bit(&frame, &pinhole, &pose, 4, OutputRule::TopBits);
        for (((scenario, raw), seen), top) in capture.scenarios().iter().zip(&raws).zip(&isp_images).zip(&top_bits) {
            assert_eq!(raw.cfa.is_some(), colour, "{spec}");
            assert_eq!(seen.rgb.is_some(), colour, "{spec}");
            if colour {
                let developed = scenario.image_8bit(raw);
                assert_eq!(developed.channels, 3);
                assert_eq!(seen.rgb.as_deref(), Some(developed.bytes.as_slice()));
                assert_eq!(seen.grey, luma_of_srgb(&developed.bytes));
                assert_eq!(top.grey, isp::to_8bit(raw, OutputRule::TopBits, &scenario.isp));
            } else {
                assert_eq!(seen.grey, isp::to_8bit(raw, OutputRule::Isp, &scenario.isp));
            }
        }
    }
}

#[test]
fn the_colour_noise_table_follows_gain_and_noise() {
    let walked = walked_house(&embedded_library().unwrap(), 3, &TrajectoryParams::default()).unwrap();
    let table = |spec: &str, group: LightGroup| -> Vec<f64> {
        let resolved = camera(spec);
        let capture = Capture::new(&walked.scene, &resolved, &[group], RenderSettings::preview(), 1.0, "t/").unwrap();
        let s = &capture.scenarios()[0];
        colour_output_noise_by_level(&resolved, s.gain_db, s.colour.as_ref().unwrap(), f64::from(s.light.target_lux))
    };
    let day = table("IMX174", LightGroup::Day);
    let night = table("IMX174", LightGroup::Night);
    assert_eq!(day.len(), 256);
    // Mid-grey (118): night (2 lux, 15 dB) is noisier than day (20 lux, 5 dB), and neither is
    // at the rounding floor.
    assert!(night[118] > 1.5 * day[118], "night {} day {}", night[118], day[118]);
    // A 20x binned pixel is quiet by day (its noise is below the 8-bit rounding); a native
    // 5.86 um pixel is not.
    let native = table("IMX174,max_width_px=1936", LightGroup::Day);
    assert!(native[118] > 2.0 * day[118], "native {} vs binned {}", native[118], day[118]);
    // The table is smooth: neighbouring levels differ by far less than the noise itself.
    assert!(night.windows(2).all(|p| (p[1] - p[0]).abs() < 0.1 * p[0].max(p[1]) + 0.05), "{:?}", &night[100..130]);
    // Without noise only the rounding is left.
    let off = table("IMX174,noise=off", LightGroup::Night);
    assert!(off.iter().all(|&s| s < 0.6), "{:?}", &off[100..110]);
}
