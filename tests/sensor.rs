//! The sensor catalog, its command, and the noise model's statistics against its own formulas.

use std::path::PathBuf;
use std::process::Command;

use proptest::prelude::*;
use scene_gen::sensor::noise::{self, Effects, gain_factor};
use scene_gen::sensor::{AffineNoise, Catalog, Colour, FigureKind, NOISE_FIELDS, SensorModel, Shutter};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("scene-gen-sensor-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_scene-gen"))
}

// ---------------------------------------------------------------- catalog

#[test]
fn catalog_holds_the_43_reference_sensors_with_corrections() {
    let c = Catalog::embedded();
    assert_eq!(c.len(), 43);
    let mt9v022 = c.get("mt9v022").unwrap();
    assert_eq!((mt9v022.pixel_pitch_um, mt9v022.resolution), (6.0, [752, 480]));
    assert!(!mt9v022.note.is_empty());
    assert_eq!(c.get("IMX335").unwrap().shutter, Shutter::Rolling);
    let imx334 = c.get("IMX334").unwrap();
    assert_eq!(imx334.pixel_pitch_um, 2.0);
    assert!((imx334.active_area_mm[0] - 7.68).abs() < 1e-9 && (imx334.active_area_mm[1] - 4.32).abs() < 1e-9);
    assert_eq!(c.get("PYTHON500").unwrap().resolution, [800, 600]);
    assert_eq!(c.get("PYTHON2000").unwrap().resolution, [1920, 1200]);
    // Rows the audit confirms stay as they were.
    let imx174 = c.get("IMX174").unwrap();
    assert_eq!((imx174.resolution, imx174.pixel_pitch_um, imx174.shutter), ([1936, 1216], 5.86, Shutter::Global));
    assert_eq!((imx174.full_well_e, imx174.read_noise_e, imx174.quantum_efficiency), (32691.0, 6.83, 0.77));
    assert_eq!(c.get("IMX219").unwrap().shutter, Shutter::Rolling);
}

#[test]
fn every_entry_is_consistent_sourced_and_sorted_by_area() {
    let c = Catalog::embedded();
    let makers: Vec<&str> = c.sensors().iter().map(|s| s.maker.as_str()).collect();
    assert_eq!(makers.iter().filter(|m| **m == "Sony").count(), 28);
    assert_eq!(makers.iter().filter(|m| **m == "onsemi").count(), 10);
    for s in c.sensors() {
        for axis in 0..2 {
            let derived = f64::from(s.resolution[axis]) * s.pixel_pitch_um / 1000.0;
            assert!((derived - s.active_area_mm[axis]).abs() < 0.01, "{}: area", s.model);
        }
        assert!(!s.source.is_empty(), "{} has no source", s.model);
        if s.estimated {
            assert!(s.source.contains("estimate") || s.source.contains("rule"), "{}: {}", s.model, s.source);
        }
        assert!((0.3..=0.9).contains(&s.quantum_efficiency), "{}", s.model);
        // CMOSIS global-shutter pixels read with 13 e- (CMV4000 data sheet).
        assert!((1.0..=20.0).contains(&s.read_noise_e), "{}", s.model);
        assert!([10, 12, 14].contains(&s.adc_bits), "{}", s.model);
        assert_eq!(s.colour, Colour::Colour);
    }
    let areas: Vec<f64> = c.sensors().iter().map(|s| s.area_mm2()).collect();
    assert!(areas.windows(2).all(|w| w[0] <= w[1]));
    assert_eq!(c.sensors()[0].model, "PYTHON300");
    assert_eq!(c.sensors().last().unwrap().model, "AM41");
}

/// Every noise figure says where it comes from; the derived ones follow from the EMVA 1288
/// figures their formula quotes.
#[test]
fn every_noise_figure_has_its_provenance() {
    let c = Catalog::embedded();
    let mut sourced = 0;
    for s in c.sensors() {
        let provenance = s.provenance();
        assert_eq!(provenance.iter().map(|p| p.field).collect::<Vec<_>>(), NOISE_FIELDS, "{}", s.model);
        for p in &provenance {
            match p.kind {
                FigureKind::Estimated => assert!(p.how.contains("estimate"), "{} {}: {}", s.model, p.field, p.how),
                _ => assert!(p.source.starts_with("https://") && !p.camera.is_empty(), "{} {}", s.model, p.field),
            }
            if p.kind == FigureKind::Derived {
                // "... SNRmax = 40.2 dB ..." or "... DR = 71.4 dB ...": recompute the value.
                let quoted = |key: &str| -> f64 {
                    let rest = &p.how[p.how.find(key).unwrap() + key.len()..];
                    rest.split_whitespace().next().unwrap().parse().unwrap()
                };
                let range = || 10f64.powf(quoted("DR = ") / 20.0);
                let expected = if p.how.contains("threshold = ") {
                    // saturation = absolute sensitivity threshold x dynamic range
                    quoted("threshold = ") * range()
                } else {
                    let saturation = 10f64.powf(quoted("SNRmax = ") / 10.0);
                    if p.field == "full_well_e" { saturation } else { saturation / range() }
                };
                assert!((p.value / expected - 1.0).abs() < 0.01, "{} {}: {} vs {expected}", s.model, p.field, p.value);
            }
        }
        let measured = |field: &str| {
            provenance.iter().any(|p| p.field == field && matches!(p.kind, FigureKind::Measured | FigureKind::Derived))
        };
        sourced += usize::from(measured("full_well_e") && measured("read_noise_e"));
    }
    assert!(sourced >= 12, "{sourced} sensors with measured or derived full well and read noise");
}

#[test]
fn a_figure_for_an_unknown_field_is_refused() {
    let dir = temp_dir("figure");
    let path = dir.join("figure.toml");
    let bad = format!("{EXTRA}\n[[sensor.figure]]\nfield = \"gain\"\nkind = \"measured\"\nsource = \"https://x\"\n");
    std::fs::write(&path, &bad).unwrap();
    let err = Catalog::embedded().load_extra(&path).unwrap_err().to_string();
    assert!(err.contains("sensor TINY1: figure 1: field 'gain'"), "{err}");
    let out = bin().args(["sensors", "--catalog"]).arg(&path).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
}

const EXTRA: &str = r#"
[[sensor]]
maker = "Sony"
model = "imx174"
resolution = [1936, 1216]
pixel_pitch_um = 5.86
active_area_mm = [11.345, 7.126]
shutter = "global"
colour = "mono"
adc_bits = 12
quantum_efficiency = 0.78
full_well_e = 30000
read_noise_e = 6.0
dark_current_e_per_s = 1.0
estimated = false
source = "my own EMVA measurement"

[[sensor]]
maker = "Acme"
model = "TINY1"
resolution = [100, 100]
pixel_pitch_um = 1.0
active_area_mm = [0.1, 0.1]
shutter = "rolling"
colour = "mono"
adc_bits = 8
quantum_efficiency = 0.6
full_well_e = 1000
read_noise_e = 2.0
dark_current_e_per_s = 0.1
estimated = true
source = "estimate: test"
"#;

#[test]
fn a_user_file_adds_and_overrides_sensors() {
    let dir = temp_dir("extra");
    let path = dir.join("mine.toml");
    std::fs::write(&path, EXTRA).unwrap();
    let mut c = Catalog::embedded();
    c.load_extra(&path).unwrap();
    assert_eq!(c.len(), 44);
    let imx174 = c.get("IMX174").unwrap();
    assert_eq!((imx174.colour, imx174.full_well_e), (Colour::Mono, 30000.0));
    assert_eq!(c.sensors()[0].model, "TINY1", "smallest area comes first");
}

#[test]
fn a_bad_user_file_is_refused_with_file_and_line() {
    let dir = temp_dir("bad");
    let path = dir.join("bad.toml");
    // Line 18 of the text (the second entry's resolution) is wrong.
    let bad = EXTRA.replace("resolution = [100, 100]", "resolution = [100, \"x\"]");
    std::fs::write(&path, &bad).unwrap();
    let err = Catalog::embedded().load_extra(&path).unwrap_err().to_string();
    let line = bad.lines().position(|l| l.contains("\"x\"")).unwrap() + 1;
    assert!(err.contains(&format!("bad.toml:{line}:")), "{err}");
    // An area that does not match resolution x pitch names the sensor's line.
    let bad = EXTRA.replace("active_area_mm = [0.1, 0.1]", "active_area_mm = [0.2, 0.1]");
    std::fs::write(&path, &bad).unwrap();
    let err = Catalog::embedded().load_extra(&path).unwrap_err().to_string();
    // The error points at the `[[sensor]]` header of the offending (second) entry.
    let header = bad.lines().enumerate().filter(|(_, l)| l.contains("[[sensor]]")).nth(1).unwrap().0 + 1;
    assert!(err.contains(&format!("bad.toml:{header}: sensor TINY1: active_area_mm")), "{err}");
    let out = bin().args(["sensors", "--catalog"]).arg(&path).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("bad.toml:"));
    assert!(out.stdout.is_empty(), "no partial output");
}

#[test]
fn sensors_command_prints_a_table_or_json() {
    let out = bin().args(["sensors", "--json"]).output().unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let arr = v.as_array().unwrap();
    assert_eq!(arr.len(), 43);
    assert!(arr.iter().any(|s| s["model"] == "IMX174" && s["full_well_e"] == 32691.0));
    let imx250 = arr.iter().find(|s| s["model"] == "IMX250").unwrap();
    let kinds: Vec<&str> =
        imx250["provenance"].as_array().unwrap().iter().map(|p| p["kind"].as_str().unwrap()).collect();
    assert_eq!(kinds, ["estimated", "derived", "derived", "estimated"]);
    let out = bin().arg("sensors").output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.lines().count() >= 44 && text.contains("MT9V022") && text.contains("752x480"));
}

/// `sensors MODEL` shows one sensor: each noise figure with its kind, camera, source and
/// formula as text, or the same record `--json` lists; an unknown name exits 2 with close names.
#[test]
fn sensors_model_shows_one_sensor_and_its_provenance() {
    let out = bin().args(["sensors", "imx250"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.starts_with("Sony IMX250: 2448x2048 pixels of 3.45 um"), "{text}");
    assert!(text.contains("full_well_e = 10715  (derived)"), "{text}");
    assert!(text.contains("how: saturation capacity = 10^(SNRmax / 10 dB)"), "{text}");
    assert!(text.contains("source: https://"), "{text}");
    assert!(text.contains("dark_current_e_per_s = 2.38  (estimated)"), "{text}");
    let one = bin().args(["sensors", "IMX250", "--json"]).output().unwrap();
    let all = bin().args(["sensors", "--json"]).output().unwrap();
    let one: serde_json::Value = serde_json::from_slice(&one.stdout).unwrap();
    let all: serde_json::Value = serde_json::from_slice(&all.stdout).unwrap();
    assert_eq!(Some(&one), all.as_array().unwrap().iter().find(|s| s["model"] == "IMX250"));
    let out = bin().args(["sensors", "IMX25"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("unknown sensor 'IMX25'") && err.contains("IMX250"), "{err}");
}

// ---------------------------------------------------------------- noise model helpers

/// A model with known parameters: K = 0.2 DN/e- at 0 dB, 12 bit, read noise 5 e- (1 DN: well
/// above the 0.5 DN where quantization stops adding 1/12 DN^2), full well 20000 e- (4000 DN).
fn test_model() -> SensorModel {
    let mut m = SensorModel::from_sensor(Catalog::embedded().get("IMX174").unwrap(), 11);
    m.system_gain_dn_per_e = 0.2;
    m.effects.saturation.full_well_e = 20_000.0;
    m.quantum_efficiency = 0.6;
    m.read_noise_e = 5.0;
    m.effects.black_level.offset_dn = 64.0;
    m.effects.dark_current.rate_e_per_s = 100.0;
    m
}

const W: usize = 128;
const H: usize = 128;

/// Mean and temporal variance of a flat field from a frame pair (EMVA 1288 pair formula).
fn pair(m: &SensorModel, photons: f32, t: f64, gain_db: f64, seed: u64) -> (f64, f64) {
    let img = vec![photons; W * H];
    let pattern = m.fixed_pattern(W, H);
    let a = m.simulate_with(&pattern, &img, t, gain_db, seed);
    let b = m.simulate_with(&pattern, &img, t, gain_db, seed + 1_000_000);
    let n = (W * H) as f64;
    let ma = a.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let mb = b.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let d2 = a.iter().zip(&b).map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2)).sum::<f64>() / n;
    (0.5 * (ma + mb), 0.5 * d2 - 0.5 * (ma - mb).powi(2))
}

fn mean(v: &[u16]) -> f64 {
    v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len() as f64
}

fn var(v: &[f64]) -> f64 {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64
}

fn fit(xs: &[f64], ys: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mx = xs.iter().sum::<f64>() / n;
    let my = ys.iter().sum::<f64>() / n;
    let b = xs.iter().zip(ys).map(|(x, y)| (x - mx) * (y - my)).sum::<f64>()
        / xs.iter().map(|x| (x - mx).powi(2)).sum::<f64>();
    (my - b * mx, b)
}

// ---------------------------------------------------------------- noise model statistics

#[test]
fn photon_transfer_slope_is_k_at_several_gains() {
    let m = test_model();
    let t = 0.01;
    for (i, gain_db) in [0.0, 6.0, 12.0].into_iter().enumerate() {
        let k = m.k_dn_per_e(gain_db);
        let (dark_mean, dark_var) = pair(&m, 0.0, t, gain_db, 100 + i as u64);
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for step in 1..=8 {
            // Up to about 60 % of the ADC range after gain.
            let photons = (step as f64 * 0.075 * 4095.0 / k / m.quantum_efficiency) as f32;
            let (mu, v) = pair(&m, photons, t, gain_db, 1000 * (i as u64 + 1) + step);
            let expected = m.expected_mean_dn(f64::from(photons), t, gain_db);
            assert!((mu - expected).abs() < 0.01 * expected, "gain {gain_db}: mean {mu} vs {expected}");
            xs.push(mu - dark_mean);
            ys.push(v - dark_var);
        }
        let (_, slope) = fit(&xs, &ys);
        assert!((slope / k - 1.0).abs() < 0.03, "gain {gain_db} dB: slope {slope} vs K {k}");
        // Dark: level and read noise + dark shot noise + quantization.
        let expected_dark_var = m.expected_temporal_variance_dn2(0.0, t, gain_db);
        assert!((dark_mean - m.expected_mean_dn(0.0, t, gain_db)).abs() < 0.05);
        assert!((dark_var / expected_dark_var - 1.0).abs() < 0.05, "gain {gain_db}: {dark_var} vs {expected_dark_var}");
    }
}

#[test]
fn dark_frames_give_the_dark_level_and_read_noise() {
    let mut m = test_model();
    m.effects.dark_current.enabled = false;
    let (mu, v) = pair(&m, 0.0, 0.01, 0.0, 5);
    assert!((mu - 64.0).abs() < 0.02, "{mu}");
    // (K sigma_r)^2 + 1/12 = 1 + 0.0833
    let expected = (0.2f64 * 5.0).powi(2) + 1.0 / 12.0;
    assert!((v / expected - 1.0).abs() < 0.05, "{v} vs {expected}");
}

#[test]
fn saturation_clips_at_full_well_and_at_max_dn() {
    let mut m = test_model();
    // K FW = 4000 DN at 0 dB, below the ADC max.
    let img = vec![1.0e7f32; 64];
    let out = m.simulate(&img, 8, 8, 0.001, 0.0, 3);
    let fw_dn = (64.0 + 0.2 * 20_000.0) as u16;
    assert!(out.iter().all(|&v| v.abs_diff(fw_dn) <= 3), "{out:?}");
    let out = m.simulate(&img, 8, 8, 0.001, 20.0, 3); // x10: full well is past 4095
    assert!(out.iter().all(|&v| v == 4095));
    m.effects.saturation.enabled = false;
    let out = m.simulate_dn_with(&m.fixed_pattern(8, 8), &img, 0.001, 0.0, 3);
    assert!(out.iter().all(|&v| v > 4095.0), "no clipping when saturation is off");
}

fn dark_stack_mean(m: &SensorModel, frames: u64, t: f64) -> Vec<f64> {
    let pattern = m.fixed_pattern(W, H);
    let mut acc = vec![0f64; W * H];
    for f in 0..frames {
        for (a, v) in acc.iter_mut().zip(m.simulate_with(&pattern, &vec![0.0; W * H], t, 0.0, f)) {
            *a += f64::from(v) / frames as f64;
        }
    }
    acc
}

#[test]
fn each_effect_changes_its_statistic() {
    let base = test_model();
    let t = 0.01;
    // black_level: shifts the mean by its offset.
    let mut m = base.clone();
    m.effects.black_level.offset_dn = 200.0;
    assert!((pair(&m, 0.0, t, 0.0, 1).0 - pair(&base, 0.0, t, 0.0, 1).0 - 136.0).abs() < 0.1);
    // dark_current: dark mean grows with exposure at K * rate.
    let d1 = pair(&base, 0.0, 1.0, 0.0, 2).0;
    let d0 = pair(&base, 0.0, 0.0, 0.0, 2).0;
    assert!(((d1 - d0) - 0.2 * 100.0).abs() < 0.1, "{d1} {d0}");
    // read_noise_split: half the variance after the gain makes dark variance grow less with gain.
    let mut m = base.clone();
    m.effects.read_noise_split = noise::ReadNoiseSplit { enabled: true, post_gain_fraction: 0.5 };
    let (v_split, v_all) = (pair(&m, 0.0, 0.0, 12.0, 3).1, pair(&base, 0.0, 0.0, 12.0, 3).1);
    let g2 = gain_factor(12.0).powi(2);
    let expected_split = 0.04 * 25.0 * (0.5 * g2 + 0.5) + 1.0 / 12.0;
    assert!((v_split / expected_split - 1.0).abs() < 0.05 && v_split < 0.7 * v_all, "{v_split} {v_all}");
    // quantization off: values are no longer integers and lack the 1/12 DN^2.
    let mut m = base.clone();
    m.effects.quantization.enabled = false;
    let raw = m.simulate_dn_with(&m.fixed_pattern(8, 8), &[500.0; 64], t, 0.0, 4);
    assert!(raw.iter().any(|v| v.fract() != 0.0));
    // nonlinearity: a = -0.1 compresses a half-scale signal by 0.1 * 0.5^3 = 1.25 %.
    let mut m = base.clone();
    m.effects.nonlinearity = noise::Nonlinearity { enabled: true, a3: -0.1, ..noise::Nonlinearity::default() };
    let photons = (0.5 * 4095.0 / 0.2 / 0.6) as f32;
    let (lin, non) = (pair(&base, photons, 0.0, 0.0, 5).0 - 64.0, pair(&m, photons, 0.0, 0.0, 5).0 - 64.0);
    assert!((non / lin - (1.0 - 0.1 * (lin / 4095.0).powi(3))).abs() < 0.002, "{lin} {non}");
    // dsnu: spatial variance of a 16-frame dark mean rises by (K std_e)^2 = 400 DN^2.
    let mut m = base.clone();
    m.effects.dsnu = noise::Dsnu { enabled: true, std_e: 100.0 };
    let s_on = var(&dark_stack_mean(&m, 16, 0.0));
    let s_off = var(&dark_stack_mean(&base, 16, 0.0));
    assert!(((s_on - s_off) / 400.0 - 1.0).abs() < 0.05, "{s_on} {s_off}");
    // prnu: spatial std of a bright stack mean rises to std_fraction * signal.
    let mut m = base.clone();
    m.effects.prnu = noise::Prnu { enabled: true, std_fraction: 0.02 };
    let bright = vec![25_000.0f32; W * H]; // 15000 e- -> 3000 DN
    let pattern = m.fixed_pattern(W, H);
    let mut acc = vec![0f64; W * H];
    for f in 0..16 {
        for (a, v) in acc.iter_mut().zip(m.simulate_with(&pattern, &bright, 0.0, 0.0, f)) {
            *a += f64::from(v) / 16.0;
        }
    }
    let prnu_dn = (var(&acc) - (3000.0 * 0.2 + 1.1) / 16.0).sqrt();
    assert!((prnu_dn / 60.0 - 1.0).abs() < 0.05, "{prnu_dn}");
    // hot_pixels: about `fraction` of pixels sit far above the dark level.
    let mut m = base.clone();
    m.effects.hot_pixels =
        noise::HotPixels { enabled: true, fraction: 0.01, max_excess_e_per_s: 1.0e6, ..noise::HotPixels::default() };
    let dark = m.simulate(&vec![0.0; W * H], W, H, 0.01, 0.0, 6);
    let hot = dark.iter().filter(|&&v| v > 64 + 50).count() as f64 / (W * H) as f64;
    assert!((0.006..0.014).contains(&hot), "{hot}");
    assert!(base.simulate(&vec![0.0; W * H], W, H, 0.01, 0.0, 6).iter().all(|&v| v < 64 + 50));
    // row_column_noise: row means vary from frame to frame.
    let mut m = base.clone();
    m.effects.row_column_noise = noise::RowColumnNoise { enabled: true, row_std_dn: 3.0, column_std_dn: 0.0 };
    let frame = m.simulate(&vec![0.0; W * H], W, H, 0.0, 0.0, 7);
    let rows: Vec<f64> = frame.chunks(W).map(mean).collect();
    assert!((var(&rows).sqrt() - 3.0).abs() < 0.6, "{}", var(&rows).sqrt());
    let base_rows: Vec<f64> = base.simulate(&vec![0.0; W * H], W, H, 0.0, 0.0, 7).chunks(W).map(mean).collect();
    assert!(var(&base_rows).sqrt() < 0.2);
    // periodic_pattern: a 0.25 cycles/px column sinusoid appears in the column means.
    let mut m = base.clone();
    m.effects.periodic_pattern = noise::PeriodicPattern {
        enabled: true,
        amplitude_dn: 4.0,
        freq_x_cycles_per_px: 0.25,
        freq_y_cycles_per_px: 0.0,
        ..noise::PeriodicPattern::default()
    };
    let frame = m.simulate(&vec![0.0; W * H], W, H, 0.0, 0.0, 8);
    let col = |c: usize| (0..H).map(|r| f64::from(frame[r * W + c])).sum::<f64>() / H as f64;
    assert!((col(1) - col(3) - 8.0).abs() < 0.3, "{} {}", col(1), col(3));
}

#[test]
fn same_seed_same_bytes_at_any_thread_count() {
    let mut m = test_model();
    m.effects.dsnu.enabled = true;
    m.effects.dsnu.std_e = 10.0;
    m.effects.prnu = noise::Prnu { enabled: true, std_fraction: 0.01 };
    let img: Vec<f32> = (0..W * H).map(|i| (i % 997) as f32 * 40.0).collect();
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| m.simulate(&img, W, H, 0.01, 6.0, 42))
    };
    let one = run(1);
    assert_eq!(one, run(4));
    assert_ne!(one, m.simulate(&img, W, H, 0.01, 6.0, 43));
}

#[test]
fn model_toml_round_trips_and_rejects_bad_values() {
    let mut m = test_model();
    m.effects.nonlinearity = noise::Nonlinearity { enabled: true, a3: -0.02, ..noise::Nonlinearity::default() };
    let text = m.to_toml().unwrap();
    assert!(text.contains("[effects.nonlinearity]"));
    assert_eq!(SensorModel::from_toml(&text).unwrap(), m);
    let bad = text.replace("post_gain_fraction = 0.5", "post_gain_fraction = 2.0");
    assert!(SensorModel::from_toml(&bad).unwrap_err().to_string().contains("post_gain_fraction"));
    let bad = text.replace("[effects.dsnu]", "[effects.dsnu]\nstd_dn = 1.0");
    let err = SensorModel::from_toml(&bad).unwrap_err().to_string();
    assert!(err.contains("line") && err.contains("std_dn"), "{err}");
    assert_eq!(Effects::default().enabled_names(), Vec::<&str>::new());
    assert_eq!(
        m.effects.enabled_names(),
        ["black_level", "dark_current", "quantization", "saturation", "nonlinearity"]
    );
}

#[test]
fn affine_model_uses_released_variances_gain_and_area() {
    let a = AffineNoise::flir_imx172();
    // At G0 and the reference pixel area, g = 1 and the variance is sigma_p2 I + sigma_t2.
    assert!((a.g(15.0, 2.4) - 1.0).abs() < 1e-12);
    assert!((a.variance(100.0, 0, 1.0) - (0.29 * 100.0 + 3.2)).abs() < 1e-9);
    assert!((a.variance(100.0, 2, 1.0) - (0.24 * 100.0 + 1.82)).abs() < 1e-9);
    // 5 dB day gain on a 4x larger pixel: g = 10^(-0.5) / 4.
    assert!((a.g(5.0, 9.6) - 10f64.powf(-0.5) / 4.0).abs() < 1e-12);
    // Applied noise has the model's variance (green channel, mid grey, night gain, IMX174 pixel).
    let (w, h) = (256, 256);
    let img = vec![100u8; w * h * 3];
    let noisy = a.apply_rgb8(&img, w, 15.0, 2.4, 9);
    let green: Vec<f64> = noisy.iter().skip(1).step_by(3).map(|&v| f64::from(v)).collect();
    let expected = 0.12 * 100.0 + 0.91 + 1.0 / 12.0;
    assert!((var(&green) / expected - 1.0).abs() < 0.05, "{} vs {expected}", var(&green));
    // From EMVA: sigma_p2 = K, sigma_t2 = K^2 sigma_d^2 + 1/12.
    let e = AffineNoise::from_emva(0.1, 30.0, 0.0, 1.0);
    assert!((e.sigma_p2[1] - 0.1).abs() < 1e-12 && (e.sigma_t2[1] - (9.0 + 1.0 / 12.0)).abs() < 1e-12);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]
    #[test]
    fn output_is_in_range_and_reproducible(seed in any::<u64>(), photons in 0.0f32..2.0e6, gain_db in 0.0f64..24.0) {
        let m = test_model();
        let img = vec![photons; 64];
        let a = m.simulate(&img, 8, 8, 0.01, gain_db, seed);
        prop_assert!(a.iter().all(|&v| v <= 4095));
        prop_assert_eq!(a, m.simulate(&img, 8, 8, 0.01, gain_db, seed));
    }
}
