//! EMVA 1288 calibration: the reference data set 003 against its documented truth, a round
//! trip through the noise model, and the parsers' refusals.

mod common;

use common::data_dir;
use std::path::{Path, PathBuf};
use std::process::Command;

use scene_gen::calibration::{self, calibrate_emva, calibrate_ptc, emva};
use scene_gen::sensor::SensorModel;
use scene_gen::sensor::noise::{self, Effects};

fn set003() -> PathBuf {
    data_dir().join("emva1288-set003-crop/EMVA1288_Data.txt")
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("scene-gen-cal-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_scene-gen"))
}

fn within(measured: f64, truth: f64, tolerance: f64) -> bool {
    (measured / truth - 1.0).abs() <= tolerance
}

// ------------------------------------------------------------------ data set 003

/// Truth of set 003 (data/README.md) and what the centre crop shows of it:
/// * K = 0.1 DN/e- (within 2 %), QE 0.5, dark level 29.4 DN, dark noise 30 e- = 3.0 DN (5 %).
/// * DSNU: white 1.5 DN plus two sinusoids of amplitude 1.5 DN (variance 1.5^2 / 2 each; the
///   crop holds 6.4 periods of the 0.04 cycles/px one and 24 of the 0.2 cycles/px one, so both
///   are present): sqrt(1.5^2 + 2 * 1.5^2 / 2) = 2.121 DN. The ~6 hot pixels expected in the
///   crop (100 in 640 x 480) add about 0.02 DN^2: negligible.
/// * DSNU after the 5x5 box high-pass: the box nulls 0.2 cycles/px (period 5) so that sinusoid
///   passes whole, while only 6 % of the 0.04 cycles/px one survives; white noise is corrected
///   for by the /0.96: sqrt(1.5^2 + 1.5^2 / 2 / 0.96 + ~0) = 1.851 DN.
/// * PRNU: white 0.5 %. The quadratic fall-off (3 % at the full frame's edge) is a few hundredths
///   of a per cent inside the centre crop and is removed by the high-pass; the ~6 expected
///   low-sensitivity pixels (70..100 %) add about 0.3 % in quadrature when present. We compare
///   the high-pass PRNU with the white 0.5 % (15 %), and the plain PRNU with the range 0.5..0.6 %
///   the white part plus those outliers allow.
#[test]
fn set003_calibration_matches_the_documented_truth() {
    let c = calibrate_emva(&set003()).unwrap();
    assert_eq!((c.points, c.adc_bits), (50, Some(12)));
    assert!(within(c.system_gain_k_dn_per_e, 0.1, 0.02), "K {}", c.system_gain_k_dn_per_e);
    assert_eq!(c.k_method, "linearized");
    // The plain fit reads the 2 % compression at full scale as a lower gain.
    assert!(c.system_gain_k_standard_dn_per_e < c.system_gain_k_dn_per_e);
    assert!(within(c.dark_noise_e, 30.0, 0.05), "dark noise {} e-", c.dark_noise_e);
    assert!(within(c.dark_noise_dn, 3.0, 0.05), "dark noise {} DN", c.dark_noise_dn);
    assert!((c.dark_mean_dn - 29.4).abs() < 0.3, "dark level {}", c.dark_mean_dn);
    assert!(within(c.quantum_efficiency.unwrap(), 0.5, 0.03), "QE {:?}", c.quantum_efficiency);
    assert!(c.saturation_reached && c.saturation_mean_dn > 3900.0);
    assert!(!c.dark_current.measurable && c.dark_current.e_per_s.is_none());
    // A 2 % cubic compression at full scale: a linearity error of a few per cent, not zero.
    let le = c.linearity_error_percent.unwrap();
    assert!((0.5..5.0).contains(&le), "linearity error {le}");
    let s = c.spatial.as_ref().unwrap();
    assert_eq!((s.dark_frames, s.bright_frames), (100, Some(100)));
    let dsnu_truth = (1.5f64.powi(2) + 2.0 * 1.5f64.powi(2) / 2.0).sqrt();
    assert!(within(s.dsnu_dn, dsnu_truth, 0.15), "DSNU {} vs {dsnu_truth}", s.dsnu_dn);
    let dsnu_hp_truth = (1.5f64.powi(2) + 1.5f64.powi(2) / 2.0 / 0.96).sqrt();
    assert!(within(s.dsnu_highpass_dn, dsnu_hp_truth, 0.15), "DSNU hp {} vs {dsnu_hp_truth}", s.dsnu_highpass_dn);
    assert!(within(s.dsnu_e, dsnu_truth / 0.1, 0.15));
    let prnu_hp = s.prnu_highpass_percent.unwrap();
    assert!(within(prnu_hp, 0.5, 0.15), "PRNU hp {prnu_hp}");
    let prnu = s.prnu_percent.unwrap();
    assert!((0.5 * 0.85..0.6 * 1.15).contains(&prnu), "PRNU {prnu}");
    // Affine coefficients at this gain: sigma_p^2 = K, sigma_t^2 = K^2 sigma_d^2 + 1/12.
    let k = c.system_gain_k_dn_per_e;
    assert!((c.affine.sigma_p2 - k).abs() < 1e-12);
    assert!((c.affine.sigma_t2_dn2 - (k * k * c.dark_noise_e.powi(2) + 1.0 / 12.0)).abs() < 1e-9);
}

#[test]
fn a_calibrated_model_reproduces_set003_statistics() {
    let c = calibrate_emva(&set003()).unwrap();
    let model = c.to_sensor_model("set003", 1);
    assert_eq!(SensorModel::from_toml(&model.to_toml().unwrap()).unwrap(), model);
    // The model's dark and mid-range statistics are those measured (dark noise, K slope).
    let dark_var = model.expected_temporal_variance_dn2(0.0, 0.001, 0.0);
    assert!(within(dark_var, c.dark_noise_dn.powi(2), 0.01), "{dark_var} vs {}", c.dark_noise_dn.powi(2));
    let mid = model.expected_temporal_variance_dn2(20_000.0, 0.001, 0.0) - dark_var;
    let signal = model.expected_mean_dn(20_000.0, 0.001, 0.0) - model.expected_mean_dn(0.0, 0.001, 0.0);
    assert!(within(mid / signal, 0.1, 0.02));
    assert!(model.effects.dsnu.enabled && model.effects.prnu.enabled && !model.effects.dark_current.enabled);
}

#[test]
fn calibrate_command_prints_a_table_or_json_only() {
    let out = bin().arg("calibrate").arg(set003()).arg("--json").output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stdout is JSON only");
    let k = v[0]["system_gain_k_dn_per_e"].as_f64().unwrap();
    assert!(within(k, 0.1, 0.02));
    let out = bin().arg("calibrate").arg(set003()).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("system gain K") && text.contains("DSNU") && text.contains("not measurable"));
}

// ------------------------------------------------------------------ round trip

fn write_png(path: &Path, w: usize, h: usize, data: Vec<u16>) {
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w as u32, h as u32, data).unwrap().save(path).unwrap();
}

/// A 12-bit camera with K = 0.1 DN/e-, QE 0.5, read noise 20 e-, DSNU 10 e- (1 DN), PRNU 1 %,
/// dark current 1000 e-/s and the set-003 nonlinearity (a = -0.02).
fn known_camera() -> SensorModel {
    SensorModel {
        name: "known".into(),
        quantum_efficiency: 0.5,
        system_gain_dn_per_e: 0.1,
        read_noise_e: 20.0,
        adc_bits: 12,
        pattern_seed: 5,
        effects: Effects {
            black_level: noise::BlackLevel { enabled: true, offset_dn: 50.0 },
            dark_current: noise::DarkCurrent { enabled: true, rate_e_per_s: 1000.0 },
            quantization: noise::Quantization { enabled: true, dither_dn: 0.0 },
            saturation: noise::Saturation { enabled: true, full_well_e: 40_000.0 },
            nonlinearity: noise::Nonlinearity { enabled: true, a3: -0.02, ..noise::Nonlinearity::default() },
            dsnu: noise::Dsnu { enabled: true, std_e: 10.0 },
            prnu: noise::Prnu { enabled: true, std_fraction: 0.01 },
            ..Effects::default()
        },
    }
}

/// Writes a simulated EMVA 1288 measurement of `model` and returns its descriptor path.
fn write_measurement(dir: &Path, model: &SensorModel) -> PathBuf {
    let (w, h) = (64, 64);
    let pattern = model.fixed_pattern(w, h);
    let t_ns = 1_000_000.0;
    let mut desc = String::from("# simulated by scene-gen tests\nv 4.0\nn 12 64 64\n");
    let mut seed = 0;
    let mut frame = |name: &str, photons: f64, t_ns: f64, desc: &mut String| {
        seed += 1;
        let img = vec![photons as f32; w * h];
        write_png(&dir.join("img").join(name), w, h, model.simulate_with(&pattern, &img, t_ns * 1e-9, 0.0, seed));
        desc.push_str(&format!("i img\\{name}\n"));
    };
    std::fs::create_dir_all(dir.join("img")).unwrap();
    for step in 1..=30 {
        let photons = step as f64 * 3000.0;
        desc.push_str(&format!("b {t_ns} {photons}\n"));
        frame(&format!("b{step}a.png"), photons, t_ns, &mut desc);
        frame(&format!("b{step}b.png"), photons, t_ns, &mut desc);
    }
    for (i, t) in [t_ns, 100.0 * t_ns].into_iter().enumerate() {
        desc.push_str(&format!("d {t}\n"));
        frame(&format!("d{i}a.png"), 0.0, t, &mut desc);
        frame(&format!("d{i}b.png"), 0.0, t, &mut desc);
    }
    desc.push_str(&format!("b {t_ns} 40000\n"));
    for f in 0..25 {
        frame(&format!("bs{f}.png"), 40_000.0, t_ns, &mut desc);
    }
    desc.push_str(&format!("d {t_ns}\n"));
    for f in 0..25 {
        frame(&format!("ds{f}.png"), 0.0, t_ns, &mut desc);
    }
    let path = dir.join("desc.txt");
    std::fs::write(&path, desc).unwrap();
    path
}

#[test]
fn calibration_recovers_the_noise_model_that_made_the_data() {
    let dir = temp_dir("roundtrip");
    let model = known_camera();
    let c = calibrate_emva(&write_measurement(&dir, &model)).unwrap();
    // K from a 64 x 64 set varies with the noise realisation: over 200 pattern and frame seeds
    // (pattern 5 + 1000 s, frames from 10000 s, s < 200; a throw-away copy of this test run as
    // `NSEEDS=200 cargo test --release --test tmp_kspread -- --nocapture`, 2026-11-24) K / 0.1
    // had a mean of 0.9994 and a standard deviation of 0.0126, so 5.5 % is 4.4 sd (2 % was 1.6 sd:
    // 21 of the 200 failed it). These seeds give 0.0986.
    assert!(within(c.system_gain_k_dn_per_e, 0.1, 0.055), "K {}", c.system_gain_k_dn_per_e);
    assert!(within(c.quantum_efficiency.unwrap(), 0.5, 0.03), "QE {:?}", c.quantum_efficiency);
    // Dark pair at 1 ms: read noise 20 e- plus 1 e- of dark shot noise.
    assert!(within(c.dark_noise_e, (400.0f64 + 1.0).sqrt(), 0.05), "dark noise {}", c.dark_noise_e);
    let dc = c.dark_current.e_per_s.unwrap();
    assert!(within(dc, 1000.0, 0.05), "dark current {dc}");
    let s = c.spatial.unwrap();
    assert!(within(s.dsnu_dn, 1.0, 0.1), "DSNU {}", s.dsnu_dn);
    assert!(within(s.prnu_percent.unwrap(), 1.0, 0.1), "PRNU {:?}", s.prnu_percent);
    // Full well 40000 e- = 4000 DN above black (3925 DN after the compression): the variance
    // peaks a step or two before the mean reaches it (shot noise and PRNU clip pixels early).
    assert!(c.saturation_reached && (3600.0..4000.0).contains(&c.saturation_mean_dn), "{}", c.saturation_mean_dn);
}

// ------------------------------------------------------------------ photon-transfer CSV

#[test]
fn ptc_csv_gives_k_per_gain() {
    let dir = temp_dir("ptc");
    let mut m = known_camera();
    m.effects.nonlinearity.enabled = false;
    let mut csv = String::from(
        "# expected values of the model\nexposure_s,gain_db,photons,mean_dn,temporal_var_dn2,dark_mean_dn,dark_var_dn2\n",
    );
    for gain in [0.0, 6.0] {
        for step in 1..=10 {
            let p = step as f64 * 2000.0;
            csv.push_str(&format!(
                "0.001,{gain},{p},{},{},{},{}\n",
                m.expected_mean_dn(p, 0.001, gain),
                m.expected_temporal_variance_dn2(p, 0.001, gain),
                m.expected_mean_dn(0.0, 0.001, gain),
                m.expected_temporal_variance_dn2(0.0, 0.001, gain)
            ));
        }
    }
    let path = dir.join("ptc.csv");
    std::fs::write(&path, csv).unwrap();
    let results = calibrate_ptc(&path).unwrap();
    assert_eq!(results.len(), 2);
    for c in &results {
        let k = m.k_dn_per_e(c.gain_db.unwrap());
        assert!(within(c.system_gain_k_dn_per_e, k, 1e-6), "{} vs {k}", c.system_gain_k_dn_per_e);
        assert!(within(c.quantum_efficiency.unwrap(), 0.5, 1e-6));
    }
    assert!(within(results[0].dark_noise_e, (400.0f64 + 1.0).sqrt(), 1e-6));
}

#[test]
fn ptc_csv_errors_name_the_line() {
    let p = Path::new("m.csv");
    let err = calibration::ptc::parse_ptc("exposure_s,gain_db,photons,mean_dn\n", p).unwrap_err().to_string();
    assert!(err.contains("m.csv:1:") && err.contains("temporal_var_dn2"), "{err}");
    let err = calibration::ptc::parse_ptc("exposure_s,gain_db,photons,mean_dn,temporal_var_dn2,volts\n", p)
        .unwrap_err()
        .to_string();
    assert!(err.contains("unknown column 'volts'"), "{err}");
    let text = "exposure_s,gain_db,photons,mean_dn,temporal_var_dn2\n0.1,0,100,5,1\n\n0.1,0,abc,5,1\n";
    let err = calibration::ptc::parse_ptc(text, p).unwrap_err().to_string();
    assert!(err.contains("m.csv:4:") && err.contains("'photons'") && err.contains("abc"), "{err}");
    let err = calibration::ptc::parse_ptc("exposure_s,gain_db,photons,mean_dn,temporal_var_dn2\n0.1,0,100\n", p)
        .unwrap_err()
        .to_string();
    assert!(err.contains("m.csv:2:") && err.contains("3 fields; expected 5"), "{err}");
}

// ------------------------------------------------------------------ descriptor refusals

fn parse_err(text: &str) -> String {
    emva::parse_descriptor(text, Path::new("d/EMVA.txt")).unwrap_err().to_string()
}

#[test]
fn descriptor_parser_reads_blocks_and_windows_paths() {
    let text = "# c\nv 4.0\n\nn 12 8 6\nb 1000 12.5\ni img\\a.png\ni img/b.png\nd 1000\ni a.png\ni b.png\n";
    let d = emva::parse_descriptor(text, Path::new("/x/y/EMVA.txt")).unwrap();
    assert_eq!((d.release.as_deref(), d.bits, d.width, d.height), (Some("4.0"), 12, 8, 6));
    assert_eq!(d.blocks.len(), 2);
    assert_eq!(d.blocks[0].kind, emva::BlockKind::Bright { photons: 12.5 });
    assert_eq!(d.blocks[0].images[0], Path::new("/x/y/img/a.png"));
    assert_eq!(d.blocks[0].images[1], Path::new("/x/y/img/b.png"));
    assert_eq!((d.blocks[1].kind, d.blocks[1].line), (emva::BlockKind::Dark, 8));
}

#[test]
fn malformed_descriptors_are_refused_with_line_and_expectation() {
    assert!(parse_err("v 4\nn 12 8\n").contains("d/EMVA.txt:2: expected 'n <bits> <width> <height>'"));
    assert!(parse_err("n 20 8 6\n").contains(":1: expected bits as an integer 1..16, found '20'"));
    assert!(parse_err("b 1000 5\ni a.png\n").contains(":1: expected the 'n <bits> <width> <height>' line"));
    assert!(parse_err("n 12 8 6\nb 1000 -5\n").contains(":2: expected photons per pixel as a non-negative number"));
    assert!(parse_err("n 12 8 6\nb 1000 5\ni a.png\nd 1000\ni a\ni b\n").contains(":2: block has 1 image(s)"));
    assert!(parse_err("n 12 8 6\nq 1\n").contains(":2: unknown line type 'q'"));
    assert!(parse_err("n 12 8 6\ni a.png\n").contains(":2: image line before any"));
    assert!(parse_err("# only comments\n").contains("no 'n <bits> <width> <height>' line"));
}

#[test]
fn a_missing_or_wrong_image_is_named_and_exits_2() {
    let dir = temp_dir("missing");
    write_png(&dir.join("a.png"), 8, 6, vec![100; 48]);
    write_png(&dir.join("big.png"), 8, 6, vec![5000; 48]);
    let desc = dir.join("EMVA.txt");
    std::fs::write(&desc, "n 12 8 6\nb 1000 5\ni a.png\ni gone.png\n").unwrap();
    let out = bin().arg("calibrate").arg(&desc).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("gone.png") && err.contains("missing"), "{err}");
    assert!(out.stdout.is_empty());
    std::fs::write(&desc, "n 12 8 6\nb 1000 5\ni a.png\ni big.png\n").unwrap();
    let err = calibrate_emva(&desc).unwrap_err().to_string();
    assert!(err.contains("big.png") && err.contains("above the 12-bit maximum"), "{err}");
    std::fs::write(&desc, "n 12 9 6\nb 1000 5\ni a.png\ni a.png\n").unwrap();
    let err = calibrate_emva(&desc).unwrap_err().to_string();
    assert!(err.contains("is 8x6, the descriptor says 9x6"), "{err}");
    let out = bin().arg("calibrate").arg(dir.join("nothing.txt")).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
    /// Any text is parsed or refused, never a panic (a cheap stand-in for a fuzz target).
    #[test]
    fn parsers_never_panic(text in "(([vnbdi#] ?[-0-9a-z.\\\\/ ]{0,12})?\n){0,8}") {
        let _ = emva::parse_descriptor(&text, Path::new("x.txt"));
        let _ = calibration::ptc::parse_ptc(&text.replace(' ', ","), Path::new("x.csv"));
    }
}
