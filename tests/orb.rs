//! ORB and matching, checked without Python: FAST on hand-made corners, pyramid sizes and
//! per-level budgets from OpenCV's formulas, OpenCV's exact bilinear resize on small cases,
//! descriptor bit order, cross-check semantics, RANSAC on a synthetic two-view scene.

use rand::Rng;
use scene_gen::orb::{
    self, FundamentalRansac, Level, Match, Orb, descriptor_at, epipolar_error, fast_detect, features_per_level,
    fundamental_7point, hamming, level_size, match_cross_check, resize_linear_exact,
};

/// A level with `border` pixels of padding filled with `fill`, interior from `f(x, y)`.
fn level_from(w: usize, h: usize, border: usize, fill: u8, mut f: impl FnMut(usize, usize) -> u8) -> Level {
    let stride = w + 2 * border;
    let mut data = vec![fill; stride * (h + 2 * border)];
    for y in 0..h {
        for x in 0..w {
            data[(y + border) * stride + x + border] = f(x, y);
        }
    }
    Level { width: w, height: h, border, stride, data }
}

#[test]
fn fast_isolated_spot_scores_its_contrast_minus_one() {
    // A single pixel 40 brighter than a flat background: every circle pixel is darker by 40.
    let lvl = level_from(40, 40, 32, 60, |x, y| if (x, y) == (20, 20) { 100 } else { 60 });
    let c = fast_detect(&lvl, 20, 3);
    assert_eq!(c.len(), 1, "{c:?}");
    assert_eq!((c[0].x, c[0].y, c[0].score), (20, 20, 39));
    // Strict threshold: contrast 40 is not "more than 40".
    assert!(fast_detect(&lvl, 40, 3).is_empty());
    assert_eq!(fast_detect(&lvl, 39, 3).len(), 1);
}

#[test]
fn fast_finds_square_corners_not_edges_and_suppresses_weaker_neighbours() {
    // A bright square: corners at its four vertices, nothing along the straight sides. A flat
    // square would tie neighbouring scores and strict suppression would drop them all (as in
    // OpenCV), so its inside carries a small irregular texture.
    let inside = |x: usize, y: usize| (30..70).contains(&x) && (30..70).contains(&y);
    let lvl = level_from(100, 100, 32, 50, |x, y| if inside(x, y) { 200 - ((x * 7 + y * 13) % 11) as u8 } else { 50 });
    let c = fast_detect(&lvl, 20, 3);
    assert!(!c.is_empty());
    let vertices = [(30.0, 30.0), (69.0, 30.0), (30.0, 69.0), (69.0, 69.0)];
    for k in &c {
        let near =
            vertices.iter().any(|&(vx, vy)| (f64::from(k.x) - vx).abs() <= 3.0 && (f64::from(k.y) - vy).abs() <= 3.0);
        assert!(near, "corner {k:?} is not at a vertex of the square");
    }
    for &(vx, vy) in &vertices {
        let found = c.iter().any(|k| (f64::from(k.x) - vx).abs() <= 3.0 && (f64::from(k.y) - vy).abs() <= 3.0);
        assert!(found, "no corner near vertex ({vx}, {vy})");
    }
    // Two spots side by side: only the stronger survives 3x3 suppression.
    let two = level_from(40, 40, 32, 60, |x, y| match (x, y) {
        (20, 20) => 140,
        (21, 20) => 120,
        _ => 60,
    });
    let c = fast_detect(&two, 20, 3);
    assert!(c.iter().any(|k| (k.x, k.y) == (20, 20)));
    assert!(!c.iter().any(|k| (k.x, k.y) == (21, 20)));
}

#[test]
fn fast_respects_the_edge_threshold() {
    let lvl = level_from(100, 100, 32, 60, |x, y| if (x, y) == (20, 50) || (x, y) == (50, 50) { 200 } else { 60 });
    let near: Vec<_> = fast_detect(&lvl, 20, 3).into_iter().map(|k| (k.x, k.y)).collect();
    assert_eq!(near, vec![(20, 50), (50, 50)]);
    let far: Vec<_> = fast_detect(&lvl, 20, 31).into_iter().map(|k| (k.x, k.y)).collect();
    assert_eq!(far, vec![(50, 50)]);
}

#[test]
fn per_level_budgets_match_opencv() {
    assert_eq!(features_per_level(500, 1.2, 8), vec![109, 90, 75, 63, 52, 44, 36, 31]);
    assert_eq!(features_per_level(1000, 1.2, 8), vec![217, 181, 151, 126, 105, 87, 73, 60]);
    assert_eq!(features_per_level(2000, 1.2, 8).iter().sum::<usize>(), 2000);
}

#[test]
fn pyramid_levels_have_opencv_sizes() {
    let (w, h) = (640usize, 480usize);
    let img: Vec<u8> = (0..w * h).map(|i| (i * 7 % 251) as u8).collect();
    let levels = Orb::default().pyramid((img.as_slice(), w, h)).unwrap();
    assert_eq!(levels.len(), 8);
    for (l, lvl) in levels.iter().enumerate() {
        let s = 1.2f64.powi(l as i32);
        assert_eq!((lvl.width, lvl.height), ((w as f64 / s).round() as usize, (h as f64 / s).round() as usize));
        assert_eq!(lvl.border, 32);
    }
    assert_eq!(level_size(w, h, 1, 1.2), (533, 400));
    assert_eq!(level_size(w, h, 7, 1.2), (179, 134));
    // Level 0 is the image itself; padding is reflect-101.
    assert_eq!(levels[0].row(5), &img[5 * w..6 * w]);
    assert_eq!(levels[0].at(-1, 0), img[1]);
    assert_eq!(levels[0].at(0, -2), img[2 * w]);
}

#[test]
fn resize_matches_opencv_linear_exact() {
    // Reference outputs from cv2.resize(..., interpolation=cv2.INTER_LINEAR_EXACT), OpenCV 5.0.0.
    let mut out = [0u8; 4];
    resize_linear_exact(&[0, 255], 2, 2, 1, &mut out, 4, 4, 1);
    assert_eq!(out, [0, 64, 191, 255]);
    let a = [10u8, 200, 30, 40, 50, 250, 0, 90, 120];
    let mut out = [0u8; 4];
    resize_linear_exact(&a, 3, 3, 3, &mut out, 2, 2, 2);
    assert_eq!(out, [54, 104, 28, 134]);
    let mut out = [0u8; 20];
    resize_linear_exact(&a, 3, 3, 3, &mut out, 5, 5, 4);
    assert_eq!(out, [10, 86, 200, 98, 30, 29, 60, 106, 143, 168, 25, 41, 65, 147, 201, 0, 36, 90, 108, 120]);
}

/// The pattern pairs from the embedded CSV, parsed independently of the library.
fn pattern_pairs() -> Vec<[i32; 4]> {
    orb::PATTERN_31
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with('x') && !l.trim().is_empty())
        .map(|l| {
            let v: Vec<i32> = l.split(',').map(|t| t.trim().parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect()
}

#[test]
fn descriptor_bit_order_is_pair_8i_plus_j_lsb_first() {
    let pairs = pattern_pairs();
    assert_eq!(pairs.len(), 256);
    // Random patch, angle 0: every bit is I(p1) < I(p2) at the unrotated pattern points.
    let mut rng = scene_gen::rng::stream(1, "orb-test-patch");
    let lvl = level_from(64, 64, 32, 0, |_, _| rng.random());
    let (cx, cy) = (32usize, 32usize);
    let at = |dx: i32, dy: i32| lvl.at(cx as isize + dx as isize, cy as isize + dy as isize);
    let d = descriptor_at(&lvl, cx, cy, 0.0);
    for (k, [x1, y1, x2, y2]) in pairs.iter().copied().enumerate() {
        let bit = (d[k / 8] >> (k % 8)) & 1;
        assert_eq!(bit == 1, at(x1, y1) < at(x2, y2), "pair {k}");
    }
    // One bright pixel at pair 0's second point sets bit 0 of byte 0 (and nothing else that
    // does not involve that point).
    let [_, _, x2, y2] = pairs[0];
    let spot = level_from(64, 64, 32, 100, |x, y| if (x as i32 - 32, y as i32 - 32) == (x2, y2) { 200 } else { 100 });
    let d = descriptor_at(&spot, 32, 32, 0.0);
    assert_eq!(d[0] & 1, 1);
    for (k, [a, b, c, e]) in pairs.iter().copied().enumerate() {
        let expect = (c, e) == (x2, y2) && (a, b) != (x2, y2);
        assert_eq!((d[k / 8] >> (k % 8)) & 1 == 1, expect, "pair {k}");
    }
    // A quarter turn maps pattern point (x, y) to (-y, x).
    let d90 = descriptor_at(&lvl, cx, cy, 90.0);
    for (k, [x1, y1, x2, y2]) in pairs.iter().copied().enumerate() {
        let bit = (d90[k / 8] >> (k % 8)) & 1;
        assert_eq!(bit == 1, at(-y1, x1) < at(-y2, x2), "pair {k} at 90 degrees");
    }
}

#[test]
fn hamming_counts_differing_bits() {
    let a = [0u8; 32];
    let mut b = [0u8; 32];
    b[0] = 0b1011;
    b[31] = 0x80;
    assert_eq!(hamming(&a, &b), 4);
    assert_eq!(hamming(&[0xFF; 32], &a), 256);
}

/// A descriptor with the first `n` bits set.
fn ones(n: usize) -> [u8; 32] {
    let mut d = [0u8; 32];
    for k in 0..n {
        d[k / 8] |= 1 << (k % 8);
    }
    d
}

#[test]
fn cross_check_keeps_mutual_nearest_with_first_index_ties() {
    // Distances are differences in popcount here (nested bit sets).
    let query = [ones(10), ones(12), ones(100)];
    let train = [ones(11), ones(30), ones(100), ones(100)];
    let m = match_cross_check(&query, &train);
    // q0 <-> t0 (1 bit) is mutual; q1's nearest is t0 (1 bit) but t0 prefers q0 (first on the
    // 1-1 tie), so q1 gets nothing; q2 ties t2/t3 and takes the first, t2, whose nearest is q2.
    assert_eq!(m, vec![Match { query: 0, train: 0, distance: 1 }, Match { query: 2, train: 2, distance: 0 }]);
    assert!(match_cross_check(&[], &train).is_empty());
}

/// Projects world points through K [R | t].
fn project(k: f64, r: &[[f64; 3]; 3], t: [f64; 3], p: [f64; 3]) -> [f64; 2] {
    let c: Vec<f64> = (0..3).map(|i| r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2] + t[i]).collect();
    [k * c[0] / c[2] + 320.0, k * c[1] / c[2] + 240.0]
}

#[test]
fn ransac_recovers_the_epipolar_geometry_despite_outliers() {
    let mut rng = scene_gen::rng::stream(3, "orb-test-scene");
    let (a, k) = (0.1f64, 500.0);
    let r = [[a.cos(), 0.0, a.sin()], [0.0, 1.0, 0.0], [-a.sin(), 0.0, a.cos()]];
    let id = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let t = [-0.5, 0.05, 0.02];
    let (mut p1, mut p2, mut truth) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..200 {
        let w = [rng.random_range(-2.0..2.0), rng.random_range(-1.5..1.5), rng.random_range(4.0..8.0)];
        let (x1, mut x2) = (project(k, &id, [0.0; 3], w), project(k, &r, t, w));
        let outlier = i % 4 == 0;
        if outlier {
            x2 = [rng.random_range(0.0..640.0), rng.random_range(0.0..480.0)];
        } else {
            x2[0] += rng.random_range(-0.3..0.3);
            x2[1] += rng.random_range(-0.3..0.3);
        }
        p1.push(x1);
        p2.push(x2);
        truth.push(!outlier);
    }
    let res = FundamentalRansac::default().run(&p1, &p2).expect("a model");
    // Every true correspondence is an inlier; outliers that happen to lie within 3 px of their
    // epipolar line are legitimately inliers too, but they are few.
    for (i, &is_true) in truth.iter().enumerate() {
        if is_true {
            assert!(res.inliers[i], "true match {i} rejected");
        }
    }
    let false_inliers = truth.iter().zip(&res.inliers).filter(|&(&t, &m)| !t && m).count();
    assert!(false_inliers <= 8, "{false_inliers} outliers accepted");
    assert!(res.iterations < 1000, "adaptive stopping");
    // Same seed, same answer.
    assert_eq!(FundamentalRansac::default().run(&p1, &p2).unwrap(), res);
    // Too few matches: no model.
    assert!(FundamentalRansac::default().run(&p1[..14], &p2[..14]).is_none());
}

#[test]
fn seven_point_solution_fits_noise_free_views() {
    let mut rng = scene_gen::rng::stream(5, "orb-test-7pt");
    let a = -0.2f64;
    let r = [[a.cos(), -a.sin(), 0.0], [a.sin(), a.cos(), 0.0], [0.0, 0.0, 1.0]];
    let id = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let t = [0.3, -0.4, 0.1];
    let world: Vec<[f64; 3]> = (0..20)
        .map(|_| [rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0), rng.random_range(3.0..9.0)])
        .collect();
    let p1: Vec<[f64; 2]> = world.iter().map(|&w| project(600.0, &id, [0.0; 3], w)).collect();
    let p2: Vec<[f64; 2]> = world.iter().map(|&w| project(600.0, &r, t, w)).collect();
    let models = fundamental_7point(&p1[..7], &p2[..7]);
    assert!(!models.is_empty() && models.len() <= 3);
    let best = models
        .iter()
        .map(|f| (7..20).map(|i| epipolar_error(f, p1[i], p2[i])).fold(0.0, f64::max))
        .fold(f64::INFINITY, f64::min);
    assert!(best < 1e-6, "largest squared epipolar distance {best}");
}

#[test]
fn detect_and_compute_respects_budget_and_borders() {
    let (w, h) = (320usize, 240usize);
    let mut rng = scene_gen::rng::stream(9, "orb-test-image");
    let cells: Vec<u8> = (0..(w / 8) * (h / 8)).map(|_| rng.random()).collect();
    let img: Vec<u8> =
        (0..w * h).map(|i| cells[(i / w / 8) * (w / 8) + (i % w) / 8].wrapping_add((i * 7 % 13) as u8)).collect();
    let (kps, desc) = Orb::with_features(300).detect_and_compute((img.as_slice(), w, h)).unwrap();
    assert_eq!(kps.len(), desc.len());
    assert!((250..=320).contains(&kps.len()), "{} keypoints on a busy image", kps.len());
    for k in &kps {
        let s = 1.2f32.powi(k.octave as i32);
        let (lx, ly) = (k.x / s, k.y / s);
        assert!(lx >= 30.5 && ly >= 30.5, "{k:?} inside the edge threshold");
        assert!((0.0..360.0).contains(&k.angle_deg));
        assert!((k.size - 31.0 * s).abs() < 1e-3);
    }
    // Same input, same output; a wrong buffer size is an error, not a panic.
    assert_eq!(Orb::with_features(300).detect_and_compute((img.as_slice(), w, h)).unwrap().1, desc);
    assert!(Orb::default().detect_and_compute((&img[..10], w, h)).is_err());
}

#[test]
fn cli_rejects_an_unreadable_image_with_status_2() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_scene-gen"))
        .args(["orb", "/nonexistent/no_such_image.png", "--json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no_such_image.png"), "{err}");
    assert!(out.stdout.is_empty());
}

#[test]
fn tiny_and_degenerate_images_give_no_features_not_panics() {
    for (w, h) in [(1usize, 1usize), (2, 3), (7, 40), (40, 40), (70, 70)] {
        let img: Vec<u8> = (0..w * h).map(|i| (i * 97 % 256) as u8).collect();
        let (k, d) = Orb::default().detect_and_compute((img.as_slice(), w, h)).unwrap();
        assert_eq!(k.len(), d.len());
        // Nothing can lie 31 px inside an image narrower than 63 px.
        if w < 63 || h < 63 {
            assert!(k.is_empty(), "{w}x{h}");
        }
    }
    assert!(Orb::default().detect_and_compute((&[][..], 0, 0)).is_err());
    let (k, _) = Orb::with_features(0).detect_and_compute((&[0u8; 10_000][..], 100, 100)).unwrap();
    assert!(k.is_empty());
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

    /// Against a naive definition: (q, t) is a match exactly when t is q's first nearest train
    /// descriptor and q is t's first nearest query descriptor.
    #[test]
    fn cross_check_equals_the_naive_mutual_nearest(seed in 0u64..1_000_000, nq in 1usize..40, nt in 1usize..40) {
        let mut rng = scene_gen::rng::stream(seed, "orb-prop-descriptors");
        // Few distinct bits so that ties are common.
        let mut desc = |_| { let mut d = [0u8; 32]; d[0] = rng.random(); d[1] = rng.random::<u8>() & 3; d };
        let q: Vec<[u8; 32]> = (0..nq).map(&mut desc).collect();
        let t: Vec<[u8; 32]> = (0..nt).map(&mut desc).collect();
        let first_min = |it: &mut dyn Iterator<Item = u32>| {
            let v: Vec<u32> = it.collect();
            let m = *v.iter().min().unwrap();
            v.iter().position(|&x| x == m).unwrap()
        };
        let mut want = Vec::new();
        for (i, qd) in q.iter().enumerate() {
            let j = first_min(&mut t.iter().map(|td| hamming(qd, td)));
            let back = first_min(&mut q.iter().map(|qq| hamming(qq, &t[j])));
            if back == i {
                want.push(Match { query: i as u32, train: j as u32, distance: hamming(qd, &t[j]) });
            }
        }
        proptest::prop_assert_eq!(match_cross_check(&q, &t), want);
    }
}
