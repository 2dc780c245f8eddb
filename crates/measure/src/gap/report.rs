//! The workflow's outputs: report.md, report.json, PNG plots and model.toml / optics.toml.
//!
//! Plots are drawn by hand on an `image` RGB buffer with the font8x8 bitmap glyphs the plan
//! picture already uses: three simple charts do not justify plotters and its font stack.

use std::fmt::Write as _;
use std::path::Path;

use image::{Rgb, RgbImage};
use serde_json::json;

use super::misfit;
use super::stats::{self, FAMILIES};
use super::{GapError, GapResult};
use scene_gen_core::io::{WriteError, write_atomic};

/// Every output file, rendered in memory (name, bytes), so nothing is written on failure.
pub fn render(result: &GapResult, source: &str) -> Result<Vec<(String, Vec<u8>)>, GapError> {
    let model_toml = result.final_model.sensor.to_toml()?;
    let optics_toml = toml::to_string(&result.final_model.optics).unwrap_or_default();
    Ok(vec![
        ("report.md".into(), markdown(result, source).into_bytes()),
        ("report.json".into(), serde_json::to_vec_pretty(&full_json(result, source)).unwrap_or_default()),
        ("model.toml".into(), model_toml.into_bytes()),
        ("optics.toml".into(), optics_toml.into_bytes()),
        ("photon_transfer.png".into(), png(&ptc_plot(result))),
        ("residuals.png".into(), png(&residual_plot(result))),
        ("gap_per_step.png".into(), png(&step_plot(result))),
    ])
}

/// Writes the rendered files into `dir` (created when missing), each atomically.
pub fn write(dir: &Path, files: &[(String, Vec<u8>)]) -> Result<(), WriteError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError { path: dir.to_path_buf(), source })?;
    for (name, bytes) in files {
        write_atomic(&dir.join(name), bytes)?;
    }
    Ok(())
}

/// The `--json` summary: gap_initial, gap_final, steps, named.
#[must_use]
pub fn summary_json(result: &GapResult) -> serde_json::Value {
    json!({
        "gap_initial": result.gap_initial.gap,
        "gap_final": result.gap_final.gap,
        "steps": result.steps,
        "named": result.named(),
        "tentative": result.tentative(),
        "unexplained": misfit::unexplained_json(result.misfit.as_ref()),
        "simulations": result.simulations,
    })
}

fn full_json(result: &GapResult, source: &str) -> serde_json::Value {
    let entries: Vec<serde_json::Value> = result
        .measured
        .entries
        .iter()
        .enumerate()
        .map(|(i, e)| {
            json!({
                "family": e.family, "label": e.label, "x": e.x,
                "measured": e.value, "sigma_measured": e.var.sqrt(),
                // A tail count's model value is its expectation, the count plus its floor.
                "simulated_initial": result.initial_stats.entries.get(i).map(|s| s.value + s.count_floor.unwrap_or(0.0)),
                "simulated_final": result.final_stats.entries.get(i).map(|s| s.value + s.count_floor.unwrap_or(0.0)),
                "z_initial": result.gap_initial.residuals.get(i),
                "z_final": result.gap_final.residuals.get(i),
            })
        })
        .collect();
    json!({
        "schema": "scene-gen/gap/1",
        "source": source,
        "gap_definition": "mean over statistic families of chi-square per degree of freedom, minus 1; \
                           residual = (measured - simulated) / sqrt(var_measured + var_simulated)",
        "gap_initial": result.gap_initial.gap,
        "gap_final": result.gap_final.gap,
        "families_initial": result.gap_initial.families,
        "families_final": result.gap_final.families,
        "steps": result.steps,
        "named": result.named(),
        "tentative": result.tentative(),
        "unexplained": misfit::unexplained_json(result.misfit.as_ref()),
        "misfit_check": misfit::check_json(result.misfit.as_ref()),
        "trials": result.trials,
        "simulations": result.simulations,
        "cached_evaluations": result.cached_evaluations,
        "start_model": result.initial.sensor,
        "final_model": result.final_model.sensor,
        "final_optics": result.final_model.optics,
        "thresholds": result.measured.thresholds,
        "statistics": entries,
    })
}

fn markdown(r: &GapResult, source: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Sim-vs-measured gap: {source}\n");
    let _ = writeln!(
        s,
        "Gap = mean over statistic families of chi-square per degree of freedom, minus 1 (0: the \
         simulation matches the measurement within sampling noise). Residuals are (measured - \
         simulated) / sqrt(var_measured + var_simulated).\n"
    );
    let shrink = if r.gap_initial.gap > 0.0 { 100.0 * (1.0 - r.gap_final.gap / r.gap_initial.gap) } else { 0.0 };
    let _ = writeln!(
        s,
        "- gap initial: **{:.3}**\n- gap final: **{:.3}** ({shrink:.1} % smaller)\n- named: {}\n",
        r.gap_initial.gap,
        r.gap_final.gap,
        if r.steps.is_empty() { "none".to_string() } else { r.named().join(", ") }
    );
    let _ = writeln!(
        s,
        "## Steps\n\nParameters as fitted when the effect was added; later rounds refit them (final values \
         in model.toml).\n\n| effect | params | gap before | gap after | evidence |\n|---|---|---|---|---|"
    );
    for st in &r.steps {
        let _ = writeln!(
            s,
            "| {} | `{}` | {:.3} | {:.3} | {} |",
            st.effect, st.params, st.gap_before, st.gap_after, st.evidence
        );
    }
    let _ = writeln!(s, "\n## Families (chi-square / dof)\n\n| family | dof | initial | final |\n|---|---|---|---|");
    for f in FAMILIES {
        let a = r.gap_initial.families.iter().find(|x| x.family == f);
        let b = r.gap_final.families.iter().find(|x| x.family == f);
        if let (Some(a), Some(b)) = (a, b) {
            let _ = writeln!(s, "| {f} | {} | {:.2} | {:.2} |", a.dof, a.chi2_per_dof, b.chi2_per_dof);
        }
    }
    s += &misfit::markdown(r.misfit.as_ref());
    let _ = writeln!(
        s,
        "\n## Candidates tried\n\n| round | effect | chi-square drop | BIC penalty | gap after |\n|---|---|---|---|---|"
    );
    for t in &r.trials {
        let _ = if t.screened {
            writeln!(
                s,
                "| {} | {} | {:.1} (top-rows screen) | {:.1} | not simulated |",
                t.round, t.effect, t.chi2_drop, t.penalty
            )
        } else {
            writeln!(s, "| {} | {} | {:.1} | {:.1} | {:.3} |", t.round, t.effect, t.chi2_drop, t.penalty, t.gap_after)
        };
    }
    let gains: Vec<String> = r.gains_db.iter().map(|g| format!("{g:.2} dB")).collect();
    let _ = writeln!(
        s,
        "\nGain groups (first: reference; others measured from their response): {}. \
         `read_noise_split` is proposed only with two gains or more. ",
        gains.join(", ")
    );
    let _ = writeln!(
        s,
        "Plots: photon_transfer.png (measured, start model, final model), residuals.png \
         (normalised residual per statistic, start above, final below), gap_per_step.png \
         (chi-square of mean and variance per step). The final model is in model.toml, its \
         optics effects in optics.toml."
    );
    s
}

// ------------------------------------------------------------------ plots

const BG: Rgb<u8> = Rgb([255, 255, 255]);
const AXIS: Rgb<u8> = Rgb([40, 40, 40]);
const MEASURED: Rgb<u8> = Rgb([20, 20, 20]);
const INITIAL: Rgb<u8> = Rgb([210, 60, 40]);
const FINAL: Rgb<u8> = Rgb([30, 130, 60]);

struct Chart {
    img: RgbImage,
    x0: i32,
    y0: i32,
    w: i32,
    h: i32,
    xr: (f64, f64),
    yr: (f64, f64),
}

impl Chart {
    fn new(title: &str, xr: (f64, f64), yr: (f64, f64)) -> Self {
        let mut c = Chart { img: RgbImage::from_pixel(720, 480, BG), x0: 70, y0: 40, w: 620, h: 390, xr, yr };
        c.text(10, 10, title, AXIS);
        let (x0, y0, w, h) = (c.x0, c.y0, c.w, c.h);
        c.rect(x0, y0 + h, w, 1, AXIS);
        c.rect(x0, y0, 1, h, AXIS);
        c.text(x0 - 60, y0, &format!("{:.3e}", yr.1), AXIS);
        c.text(x0 - 60, y0 + h - 8, &format!("{:.3e}", yr.0), AXIS);
        c.text(x0, y0 + h + 12, &format!("{:.3e}", xr.0), AXIS);
        c.text(x0 + w - 72, y0 + h + 12, &format!("{:.3e}", xr.1), AXIS);
        c
    }

    fn rect(&mut self, x: i32, y: i32, w: i32, h: i32, color: Rgb<u8>) {
        for py in y.max(0)..(y + h).min(self.img.height() as i32) {
            for px in x.max(0)..(x + w).min(self.img.width() as i32) {
                self.img.put_pixel(px as u32, py as u32, color);
            }
        }
    }

    fn text(&mut self, x: i32, y: i32, text: &str, color: Rgb<u8>) {
        use font8x8::UnicodeFonts as _;
        for (i, ch) in text.chars().enumerate() {
            let Some(glyph) = font8x8::BASIC_FONTS.get(ch) else { continue };
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) != 0 {
                        self.rect(x + i as i32 * 8 + col, y + row as i32, 1, 1, color);
                    }
                }
            }
        }
    }

    fn px(&self, x: f64, y: f64) -> (i32, i32) {
        let fx = (x - self.xr.0) / (self.xr.1 - self.xr.0).max(1e-300);
        let fy = (y - self.yr.0) / (self.yr.1 - self.yr.0).max(1e-300);
        (self.x0 + (fx * f64::from(self.w)) as i32, self.y0 + self.h - (fy * f64::from(self.h)) as i32)
    }

    fn points(&mut self, pts: &[(f64, f64)], color: Rgb<u8>, size: i32) {
        for &(x, y) in pts {
            let (px, py) = self.px(x, y);
            self.rect(px - size / 2, py - size / 2, size, size, color);
        }
    }

    fn line(&mut self, pts: &[(f64, f64)], color: Rgb<u8>) {
        for pair in pts.windows(2) {
            let (a, b) = (self.px(pair[0].0, pair[0].1), self.px(pair[1].0, pair[1].1));
            let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).max(1);
            for i in 0..=n {
                let t = f64::from(i) / f64::from(n);
                let x = f64::from(a.0) + t * f64::from(b.0 - a.0);
                let y = f64::from(a.1) + t * f64::from(b.1 - a.1);
                self.rect(x as i32, y as i32, 2, 2, color);
            }
        }
    }

    fn legend(&mut self, items: &[(&str, Rgb<u8>)]) {
        for (i, (label, color)) in items.iter().enumerate() {
            let y = self.y0 + 8 + 14 * i as i32;
            self.rect(self.x0 + 12, y, 10, 8, *color);
            self.text(self.x0 + 28, y, label, AXIS);
        }
    }
}

fn range(vals: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) =
        vals.filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if lo.is_finite() && hi > lo { (lo, hi + 0.05 * (hi - lo)) } else { (0.0, 1.0) }
}

fn ptc_plot(r: &GapResult) -> RgbImage {
    let series = |s: &stats::Stats| -> Vec<(f64, f64)> { s.steps.iter().map(|p| (p.mean_dn, p.var_dn2)).collect() };
    let (m, i, f) = (series(&r.measured), series(&r.initial_stats), series(&r.final_stats));
    let all = || m.iter().chain(&i).chain(&f);
    let mut c = Chart::new(
        "photon transfer: temporal variance (DN^2) vs mean (DN)",
        range(all().map(|p| p.0)),
        (0.0, range(all().map(|p| p.1)).1),
    );
    c.line(&i, INITIAL);
    c.line(&f, FINAL);
    c.points(&m, MEASURED, 6);
    c.legend(&[("measured", MEASURED), ("start model", INITIAL), ("final model", FINAL)]);
    c.img
}

fn residual_plot(r: &GapResult) -> RgbImage {
    let clip = |z: f64| z.clamp(-20.0, 20.0);
    let n = r.gap_initial.residuals.len().max(1) as f64;
    let mut c = Chart::new(
        "normalised residual per statistic (clipped at +-20): start (top), final (bottom)",
        (0.0, n),
        (-42.0, 42.0),
    );
    let mid_top = c.px(0.0, 21.0).1;
    let mid_bot = c.px(0.0, -21.0).1;
    let (x0, w) = (c.x0, c.w);
    c.rect(x0, mid_top, w, 1, AXIS);
    c.rect(x0, mid_bot, w, 1, AXIS);
    let bw = (f64::from(c.w) / n).max(1.0) as i32;
    for (k, (zi, zf)) in r.gap_initial.residuals.iter().zip(&r.gap_final.residuals).enumerate() {
        for (z, base, color) in [(clip(*zi), 21.0, INITIAL), (clip(*zf), -21.0, FINAL)] {
            let (px, p0) = c.px(k as f64, base);
            let (_, p1) = c.px(k as f64, base + z);
            c.rect(px, p0.min(p1), (bw - 1).max(1), (p1 - p0).abs().max(1), color);
        }
    }
    let mut last = "";
    for (k, e) in r.measured.entries.iter().enumerate() {
        if e.family != last {
            last = e.family;
            let (px, _) = c.px(k as f64, 0.0);
            c.rect(px, c.y0, 1, c.h, Rgb([180, 180, 180]));
            c.text(px + 2, c.y0 + c.h / 2 - 4, &e.family[..e.family.len().min(6)], AXIS);
        }
    }
    c.img
}

fn step_plot(r: &GapResult) -> RgbImage {
    let i = stats::gap_per_step(&r.gap_initial, &r.measured);
    let f = stats::gap_per_step(&r.gap_final, &r.measured);
    let logy = |v: &[(f64, f64)]| -> Vec<(f64, f64)> { v.iter().map(|(x, y)| (*x, (1.0 + y).log10())).collect() };
    let (li, lf) = (logy(&i), logy(&f));
    let mut c = Chart::new(
        "chi-square of mean + variance per step, log10(1 + chi2) vs photons",
        range(li.iter().map(|p| p.0)),
        (0.0, range(li.iter().chain(&lf).map(|p| p.1)).1),
    );
    c.line(&li, INITIAL);
    c.points(&li, INITIAL, 6);
    c.line(&lf, FINAL);
    c.points(&lf, FINAL, 6);
    c.legend(&[("start model", INITIAL), ("final model", FINAL)]);
    c.img
}

fn png(img: &RgbImage) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    // Encoding an in-memory RGB buffer to PNG cannot fail short of running out of memory.
    let _ = img.write_to(&mut out, image::ImageFormat::Png);
    out.into_inner()
}
