//! Times ORB extraction and cross-check matching on one thread:
//! `orb_bench IMAGE_A IMAGE_B [FEATURES] [REPS]` prints JSON with the median milliseconds.
//! tests/interop/orb_speed.py runs it beside OpenCV on the same images.

use std::time::Instant;

use scene_gen::orb::{FundamentalRansac, Orb, match_and_verify, match_cross_check};

/// Median and fastest of `reps` timed runs, in milliseconds.
fn times_ms(mut f: impl FnMut(), reps: usize) -> (f64, f64) {
    f();
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    (t[t.len() / 2], t[0])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: orb_bench IMAGE_A IMAGE_B [FEATURES] [REPS]".into());
    }
    let a = image::open(&args[1])?.to_luma8();
    let b = image::open(&args[2])?.to_luma8();
    let features: usize = args.get(3).map_or(Ok(2000), |s| s.parse())?;
    let reps: usize = args.get(4).map_or(Ok(30), |s| s.parse())?;
    let orb = Orb::with_features(features);
    let (ka, da) = orb.detect_and_compute(&a)?;
    let (kb, db) = orb.detect_and_compute(&b)?;
    let extract = times_ms(
        || {
            std::hint::black_box(orb.detect_and_compute(&a).map(|r| r.0.len()).unwrap_or(0));
        },
        reps,
    );
    let matching = times_ms(
        || {
            std::hint::black_box(match_cross_check(&da, &db).len());
        },
        reps,
    );
    let ransac = FundamentalRansac::default();
    let verify = times_ms(
        || {
            std::hint::black_box(match_and_verify(&ka, &da, &kb, &db, &ransac).0.len());
        },
        reps.min(10),
    );
    println!(
        "{{\"features\": {features}, \"keypoints_a\": {}, \"keypoints_b\": {}, \"extract_ms\": {:.3}, \"extract_min_ms\": {:.3}, \"match_ms\": {:.3}, \"match_min_ms\": {:.3}, \"match_ransac_ms\": {:.3}}}",
        ka.len(),
        kb.len(),
        extract.0,
        extract.1,
        matching.0,
        matching.1,
        verify.0
    );
    Ok(())
}
