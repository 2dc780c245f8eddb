//! Candidate effects, their fits, and the greedy search.
//!
//! Each fit is an increment: it moves the current parameters by the residual (measured minus
//! simulated) of the statistics the effect drives over the effect's sensitivity, so the same
//! code adds an effect and polishes it after re-simulation ([`POLISH_STEPS`] times per trial).
//! The accepted effect's size is then refined by a parabola search of the total chi-square over
//! a factor on its parameters (the increments assume Gaussian-shaped widths, which a line
//! kernel is not).
//!
//! * `lens_blur`: Gaussian-equivalent variances of the four edge widths (a Gaussian's 10-90 %
//!   rise is 2.563 sigma, its 25-75 % rise 1.349 sigma); `sigma^2 += mean(w_m^2 - w_s^2) / c^2`.
//! * `motion_blur`: the same increments per direction: across x from the vertical edge, across
//!   y from the horizontal one; a line of length L at angle a has variance `L^2 cos^2 a / 12`
//!   across x and `L^2 sin^2 a / 12` across y.
//! * `illumination_falloff`: least squares of the patch-mean ratio
//!   `(m - black) / (s - black) - 1` on `r^2` and `r^4`, composed with the current gain.
//! * `prnu`, `dsnu`: least squares of the patch-variance residual on `1` and `S^2` (S the
//!   signal above black): `prnu` adds `(p S)^2`, `dsnu` adds `(K g d)^2`.
//!
//! Acceptance: the largest drop of the total chi-square must exceed
//! `PENALTY_FACTOR * k ln n` (BIC, k fitted parameters, n statistics). A parameter fitted to
//! sampling noise lowers the chi-square by about 1 per parameter, far below `2 ln 65 = 8.3`.

use serde_json::json;

use super::effects::{Falloff, LensBlur, MotionBlur};
use super::stats::{self, Gap, SimStats, Stats, Tolerance};
use super::{Simulator, Step, TargetModel, TargetResult, Trial};

/// Effects the loop can add, in the order they are tried (ties go to the earlier one).
pub const CANDIDATES: [&str; 5] = ["lens_blur", "motion_blur", "illumination_falloff", "prnu", "dsnu"];

/// Factor on the BIC penalty: five candidates are tried per round and the variances of some
/// statistics are estimated from a few realisations (as in `crate::gap::fit`).
pub const PENALTY_FACTOR: f64 = 2.0;

/// Re-simulations polishing each candidate's parameters.
pub const POLISH_STEPS: usize = 2;

/// Gaussian 10-90 % and 25-75 % rise over sigma: `2 z(0.9)` and `2 z(0.75)` of the normal.
const WIDTH_OVER_SIGMA: [f64; 4] = [2.5631, 1.3490, 2.5631, 1.3490];

/// Most rounds of the search.
const MAX_ROUNDS: usize = 4;

/// Number of fitted parameters (the BIC's k).
#[must_use]
pub fn param_count(effect: &str) -> usize {
    match effect {
        "motion_blur" | "illumination_falloff" => 2,
        _ => 1,
    }
}

/// Increments of the Gaussian-equivalent variance across x and across y.
fn width_increments(m: &Stats, s: &SimStats) -> (f64, f64) {
    let d: Vec<f64> = (0..4.min(m.edge.len()).min(s.mean.edge.len()))
        .map(|i| (m.edge[i].powi(2) - s.mean.edge[i].powi(2)) / WIDTH_OVER_SIGMA[i].powi(2))
        .collect();
    if d.len() < 4 {
        return (0.0, 0.0);
    }
    ((d[0] + d[1]) / 2.0, (d[2] + d[3]) / 2.0)
}

/// Least squares of `y` on the columns `a` (two of them).
fn lsq2(rows: &[([f64; 2], f64)]) -> Option<[f64; 2]> {
    let mut n = [[0.0f64; 3]; 2];
    for (x, y) in rows {
        for i in 0..2 {
            for j in 0..2 {
                n[i][j] += x[i] * x[j];
            }
            n[i][2] += x[i] * y;
        }
    }
    let det = n[0][0] * n[1][1] - n[0][1] * n[1][0];
    if det.abs() < 1e-300 {
        return None;
    }
    Some([(n[0][2] * n[1][1] - n[0][1] * n[1][2]) / det, (n[0][0] * n[1][2] - n[1][0] * n[0][2]) / det])
}

/// Proposes `effect` on top of `model` (or updates it when already on), fitted from the measured
/// statistics `m` and the current simulation `s`. None: the data do not call for it.
#[must_use]
pub fn propose(effect: &str, model: &TargetModel, m: &Stats, s: &SimStats, sim: &Simulator) -> Option<TargetModel> {
    let mut next = model.clone();
    let layout = &sim.layout;
    let black = layout.black_level_dn;
    match effect {
        "lens_blur" => {
            let (dx, dy) = width_increments(m, s);
            let cur = model.optics.lens_blur.map_or(0.0, |b| b.sigma_px);
            let v = cur * cur + (dx + dy) / 2.0;
            if v < 0.01 {
                return None;
            }
            next.optics.lens_blur = Some(LensBlur { sigma_px: v.sqrt() });
        }
        "motion_blur" => {
            let (dx, dy) = width_increments(m, s);
            let (l, a) = model.optics.motion_blur.map_or((0.0, 0.0), |b| (b.length_px, b.angle_deg.to_radians()));
            let vx = (l * l / 12.0 * a.cos().powi(2) + dx).max(0.0);
            let vy = (l * l / 12.0 * a.sin().powi(2) + dy).max(0.0);
            let length = (12.0 * (vx + vy)).sqrt();
            if length < 1.0 {
                return None;
            }
            next.optics.motion_blur =
                Some(MotionBlur { length_px: length, angle_deg: vy.sqrt().atan2(vx.sqrt()).to_degrees() });
        }
        "illumination_falloff" => {
            let rows: Vec<([f64; 2], f64)> = layout
                .patches
                .iter()
                .enumerate()
                .filter_map(|(i, p)| {
                    let (mm, ss) = (m.patch_mean[i] - black, s.mean.patch_mean[i] - black);
                    let u = p.radius * p.radius;
                    (ss > 0.0).then(|| ([u, u * u], mm / ss - 1.0))
                })
                .collect();
            let [a, b] = lsq2(&rows)?;
            let cur = model.optics.illumination_falloff.unwrap_or(Falloff { a: 0.0, b: 0.0 });
            next.optics.illumination_falloff = Some(Falloff { a: cur.a + a, b: cur.b + b + cur.a * a });
        }
        "prnu" | "dsnu" => {
            let rows: Vec<([f64; 2], f64)> = (0..m.patch_var.len())
                .map(|i| {
                    let sig = (s.mean.patch_mean[i] - black).max(0.0);
                    ([1.0, sig * sig], m.patch_var[i] - s.mean.patch_var[i])
                })
                .collect();
            let [c0, c1] = lsq2(&rows)?;
            let e = &mut next.sensor.effects;
            if effect == "prnu" {
                let cur = if e.prnu.enabled { e.prnu.std_fraction } else { 0.0 };
                let v = cur * cur + c1;
                if v <= 0.0 {
                    return None;
                }
                e.prnu.enabled = true;
                e.prnu.std_fraction = v.sqrt();
            } else {
                let k = model.sensor.k_dn_per_e(layout.gain_db);
                let cur = if e.dsnu.enabled { e.dsnu.std_e } else { 0.0 };
                let v = cur * cur + c0 / (k * k);
                if v <= 0.0 {
                    return None;
                }
                e.dsnu.enabled = true;
                e.dsnu.std_e = v.sqrt();
            }
        }
        _ => return None,
    }
    Some(next)
}

/// The parameters of `effect` in `model`, as JSON.
#[must_use]
pub fn params(effect: &str, model: &TargetModel) -> serde_json::Value {
    let o = &model.optics;
    let e = &model.sensor.effects;
    match effect {
        "lens_blur" => json!(o.lens_blur),
        "motion_blur" => json!(o.motion_blur),
        "illumination_falloff" => json!(o.illumination_falloff),
        "prnu" => json!({ "std_fraction": e.prnu.std_fraction }),
        "dsnu" => json!({ "std_e": e.dsnu.std_e }),
        _ => serde_json::Value::Null,
    }
}

/// Fits `effect` by [`propose`] and `steps` re-simulations; None when it is never proposed.
fn fit_effect(
    effect: &str,
    model: &TargetModel,
    m: &Stats,
    s: &SimStats,
    sim: &Simulator,
    steps: usize,
) -> Option<(TargetModel, SimStats)> {
    let mut cur = propose(effect, model, m, s, sim)?;
    let mut cur_s = sim.run(&cur);
    for _ in 0..steps {
        let Some(next) = propose(effect, &cur, m, &cur_s, sim) else { break };
        let next_s = sim.run(&next);
        cur = next;
        cur_s = next_s;
    }
    Some((cur, cur_s))
}

/// `model` with `effect`'s size multiplied by `f` (blur sigma or length, fall-off coefficients,
/// PRNU or DSNU standard deviation).
fn scaled(effect: &str, model: &TargetModel, f: f64) -> TargetModel {
    let mut m = model.clone();
    let o = &mut m.optics;
    let e = &mut m.sensor.effects;
    match effect {
        "lens_blur" => o.lens_blur.iter_mut().for_each(|b| b.sigma_px *= f),
        "motion_blur" => o.motion_blur.iter_mut().for_each(|b| b.length_px *= f),
        "illumination_falloff" => o.illumination_falloff.iter_mut().for_each(|b| {
            b.a *= f;
            b.b *= f;
        }),
        "prnu" => e.prnu.std_fraction *= f,
        "dsnu" => e.dsnu.std_e *= f,
        _ => {}
    }
    m
}

/// Polishes the size of `effect` in `model` by minimising the total chi-square over a factor:
/// three rounds of a parabola through the best factor and its neighbours at a shrinking step.
fn polish_scale(
    effect: &str,
    model: TargetModel,
    s: SimStats,
    g: Gap,
    m: &Stats,
    sim: &Simulator,
    tol: &Tolerance,
) -> (TargetModel, SimStats, Gap) {
    let eval = |f: f64| {
        let c = scaled(effect, &model, f);
        let cs = sim.run(&c);
        let cg = stats::gap(m, &cs, tol);
        (f, c, cs, cg)
    };
    let mut best = (1.0, model.clone(), s, g);
    let mut step = 0.08;
    for _ in 0..3 {
        let lo = eval(best.0 - step);
        let hi = eval(best.0 + step);
        let (y0, y1, y2) = (lo.3.chi2, best.3.chi2, hi.3.chi2);
        let curv = y0 - 2.0 * y1 + y2;
        let mut tried = vec![lo, hi];
        if curv > 0.0 {
            let x = best.0 + step * (y0 - y2) / (2.0 * curv);
            tried.push(eval(x.clamp(best.0 - 2.0 * step, best.0 + 2.0 * step).max(0.01)));
        }
        for t in tried {
            if t.3.chi2 < best.3.chi2 {
                best = t;
            }
        }
        step /= 3.0;
    }
    (best.1, best.2, best.3)
}

fn evidence(before: &Gap, after: &Gap, penalty: f64) -> String {
    let improved: Vec<String> = before
        .parts
        .iter()
        .zip(&after.parts)
        .filter(|(b, a)| a.value < 0.9 * b.value && b.value > 1.0)
        .map(|(b, a)| format!("{} {:.2}->{:.2}", b.family, b.value, a.value))
        .collect();
    format!("chi2 drop {:.1} > penalty {:.1}; improved: {}", before.chi2 - after.chi2, penalty, improved.join(", "))
}

/// The greedy search from `start`.
#[must_use]
pub fn search(m: &Stats, start: TargetModel, sim: &Simulator, tol: &Tolerance) -> TargetResult {
    let n = m.len().max(2) as f64;
    let initial_sim = sim.run(&start);
    let gap_initial = stats::gap(m, &initial_sim, tol);
    let (mut model, mut cur_s, mut cur_gap) = (start.clone(), initial_sim.clone(), gap_initial.clone());
    let mut steps = Vec::new();
    let mut trials = Vec::new();
    let mut added: Vec<&str> = Vec::new();
    for round in 1..=MAX_ROUNDS {
        let mut best: Option<(&str, TargetModel, SimStats, Gap, f64)> = None;
        for effect in CANDIDATES {
            if added.contains(&effect) {
                continue;
            }
            let Some((cand, cand_s)) = fit_effect(effect, &model, m, &cur_s, sim, POLISH_STEPS) else { continue };
            let g = stats::gap(m, &cand_s, tol);
            let penalty = PENALTY_FACTOR * param_count(effect) as f64 * n.ln();
            let drop = cur_gap.chi2 - g.chi2;
            trials.push(Trial {
                round,
                effect: effect.to_string(),
                params: params(effect, &cand),
                chi2_drop: drop,
                penalty,
                gap_after: g.gap,
            });
            if drop > penalty && best.as_ref().is_none_or(|b| drop > cur_gap.chi2 - b.3.chi2) {
                best = Some((effect, cand, cand_s, g, penalty));
            }
        }
        let Some((effect, cand, mut cand_s, mut g, penalty)) = best else { break };
        let before = cur_gap.clone();
        let mut refined = cand;
        added.push(effect);
        // Refit everything added so far against the new residuals (one increment, then the
        // size by a parabola search), keeping a refit only if it lowers the chi-square.
        for e in added.clone() {
            if let Some((r, rs)) = fit_effect(e, &refined, m, &cand_s, sim, 0) {
                let rg = stats::gap(m, &rs, tol);
                if rg.chi2 < g.chi2 {
                    refined = r;
                    cand_s = rs;
                    g = rg;
                }
            }
            (refined, cand_s, g) = polish_scale(e, refined, cand_s, g, m, sim, tol);
        }
        steps.push(Step {
            effect: effect.to_string(),
            params: params(effect, &refined),
            gap_before: before.gap,
            gap_after: g.gap,
            evidence: evidence(&before, &g, penalty),
        });
        model = refined;
        cur_s = cand_s;
        cur_gap = g;
    }
    TargetResult {
        initial: start,
        final_model: model,
        measured: m.clone(),
        initial_sim,
        final_sim: cur_s,
        gap_initial,
        gap_final: cur_gap,
        steps,
        trials,
    }
}
