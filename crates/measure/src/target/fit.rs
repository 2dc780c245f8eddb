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
//! [`search::PENALTY_FACTOR`]` * k ln n` (BIC, k fitted parameters, n statistics). A parameter fitted to
//! sampling noise lowers the chi-square by about 1 per parameter, far below `2 ln 65 = 8.3`.

use serde_json::json;

use super::effects::{Falloff, LensBlur, MotionBlur};
use super::stats::{self, Gap, SimStats, Stats, Tolerance};
use super::{Simulator, Step, TargetModel, TargetResult, Trial, comparison};
use crate::gap::misfit::Evidence;
use crate::search::{self, Effect, Problem};

/// Re-simulations polishing each candidate's parameters.
pub const POLISH_STEPS: usize = 2;

/// Gaussian 10-90 % and 25-75 % rise over sigma: `2 z(0.9)` and `2 z(0.75)` of the normal.
const WIDTH_OVER_SIGMA: [f64; 4] = [2.5631, 1.3490, 2.5631, 1.3490];

/// Most rounds of the search.
const MAX_ROUNDS: usize = 4;

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

/// The effects the loop can add, in the order they are tried (ties go to the earlier one).
pub const EFFECTS: [&dyn Effect<ChartProblem>; 5] =
    [&LensBlurFit, &MotionBlurFit, &IlluminationFalloffFit, &PrnuFit, &DsnuFit];

/// The effect called `name`, if the loop has it.
#[must_use]
pub fn effect(name: &str) -> Option<&'static dyn Effect<ChartProblem>> {
    EFFECTS.iter().copied().find(|e| e.name() == name)
}

/// A model's simulated statistics and their gap to the measured image.
pub type ChartSim = (SimStats, Gap);

/// `lens_blur`: a Gaussian point spread, from the Gaussian-equivalent variances of the four edge
/// widths.
#[derive(Debug)]
pub struct LensBlurFit;

impl Effect<ChartProblem> for LensBlurFit {
    fn name(&self) -> &'static str {
        "lens_blur"
    }

    fn param_count(&self, _: &TargetModel) -> usize {
        1
    }

    fn fit(&self, problem: &ChartProblem, model: &TargetModel, (s, _): &ChartSim) -> Option<TargetModel> {
        let (dx, dy) = width_increments(&problem.measured, s);
        let cur = model.optics.lens_blur.map_or(0.0, |b| b.sigma_px);
        let v = cur * cur + (dx + dy) / 2.0;
        if v < 0.01 {
            return None;
        }
        let mut next = model.clone();
        next.optics.lens_blur = Some(LensBlur { sigma_px: v.sqrt() });
        Some(next)
    }

    fn params(&self, model: &TargetModel) -> serde_json::Value {
        json!(model.optics.lens_blur)
    }

    fn scaled(&self, model: &TargetModel, factor: f64) -> Option<TargetModel> {
        let mut m = model.clone();
        m.optics.lens_blur.iter_mut().for_each(|b| b.sigma_px *= factor);
        Some(m)
    }
}

/// `motion_blur`: a line point spread, its length and angle from the edge-width increments
/// across x and across y (a line of length L at angle a has variance `L^2 cos^2 a / 12` across x
/// and `L^2 sin^2 a / 12` across y).
#[derive(Debug)]
pub struct MotionBlurFit;

impl Effect<ChartProblem> for MotionBlurFit {
    fn name(&self) -> &'static str {
        "motion_blur"
    }

    fn param_count(&self, _: &TargetModel) -> usize {
        2
    }

    fn fit(&self, problem: &ChartProblem, model: &TargetModel, (s, _): &ChartSim) -> Option<TargetModel> {
        let (dx, dy) = width_increments(&problem.measured, s);
        let (l, a) = model.optics.motion_blur.map_or((0.0, 0.0), |b| (b.length_px, b.angle_deg.to_radians()));
        let vx = (l * l / 12.0 * a.cos().powi(2) + dx).max(0.0);
        let vy = (l * l / 12.0 * a.sin().powi(2) + dy).max(0.0);
        let length = (12.0 * (vx + vy)).sqrt();
        if length < 1.0 {
            return None;
        }
        let mut next = model.clone();
        next.optics.motion_blur =
            Some(MotionBlur { length_px: length, angle_deg: vy.sqrt().atan2(vx.sqrt()).to_degrees() });
        Some(next)
    }

    fn params(&self, model: &TargetModel) -> serde_json::Value {
        json!(model.optics.motion_blur)
    }

    fn scaled(&self, model: &TargetModel, factor: f64) -> Option<TargetModel> {
        let mut m = model.clone();
        m.optics.motion_blur.iter_mut().for_each(|b| b.length_px *= factor);
        Some(m)
    }
}

/// `illumination_falloff`: least squares of the patch-mean ratio `(m - black) / (s - black) - 1`
/// on `r^2` and `r^4`, composed with the current fall-off.
#[derive(Debug)]
pub struct IlluminationFalloffFit;

impl Effect<ChartProblem> for IlluminationFalloffFit {
    fn name(&self) -> &'static str {
        "illumination_falloff"
    }

    fn param_count(&self, _: &TargetModel) -> usize {
        2
    }

    fn fit(&self, problem: &ChartProblem, model: &TargetModel, (s, _): &ChartSim) -> Option<TargetModel> {
        let (m, layout) = (&problem.measured, &problem.sim.layout);
        let black = layout.black_level_dn;
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
        let mut next = model.clone();
        next.optics.illumination_falloff = Some(Falloff { a: cur.a + a, b: cur.b + b + cur.a * a });
        Some(next)
    }

    fn params(&self, model: &TargetModel) -> serde_json::Value {
        json!(model.optics.illumination_falloff)
    }

    fn scaled(&self, model: &TargetModel, factor: f64) -> Option<TargetModel> {
        let mut m = model.clone();
        m.optics.illumination_falloff.iter_mut().for_each(|b| {
            b.a *= factor;
            b.b *= factor;
        });
        Some(m)
    }
}

/// Least squares of the patch-variance residual on `1` and `S^2` (S the signal above black):
/// `(c0, c1)`, the constant (dark) and signal-squared (photo-response) parts.
fn variance_excess(problem: &ChartProblem, s: &SimStats) -> Option<[f64; 2]> {
    let (m, black) = (&problem.measured, problem.sim.layout.black_level_dn);
    let rows: Vec<([f64; 2], f64)> = (0..m.patch_var.len())
        .map(|i| {
            let sig = (s.mean.patch_mean[i] - black).max(0.0);
            ([1.0, sig * sig], m.patch_var[i] - s.mean.patch_var[i])
        })
        .collect();
    lsq2(&rows)
}

/// `prnu`: photo-response non-uniformity, `(p S)^2` of the patch-variance excess.
#[derive(Debug)]
pub struct PrnuFit;

impl Effect<ChartProblem> for PrnuFit {
    fn name(&self) -> &'static str {
        "prnu"
    }

    fn param_count(&self, _: &TargetModel) -> usize {
        1
    }

    fn fit(&self, problem: &ChartProblem, model: &TargetModel, (s, _): &ChartSim) -> Option<TargetModel> {
        let [_, c1] = variance_excess(problem, s)?;
        let mut next = model.clone();
        let e = &mut next.sensor.effects;
        let cur = if e.prnu.enabled { e.prnu.std_fraction } else { 0.0 };
        let v = cur * cur + c1;
        if v <= 0.0 {
            return None;
        }
        e.prnu.enabled = true;
        e.prnu.std_fraction = v.sqrt();
        Some(next)
    }

    fn params(&self, model: &TargetModel) -> serde_json::Value {
        json!({ "std_fraction": model.sensor.effects.prnu.std_fraction })
    }

    fn scaled(&self, model: &TargetModel, factor: f64) -> Option<TargetModel> {
        let mut m = model.clone();
        m.sensor.effects.prnu.std_fraction *= factor;
        Some(m)
    }
}

/// `dsnu`: dark signal non-uniformity, `(K g d)^2` of the patch-variance excess.
#[derive(Debug)]
pub struct DsnuFit;

impl Effect<ChartProblem> for DsnuFit {
    fn name(&self) -> &'static str {
        "dsnu"
    }

    fn param_count(&self, _: &TargetModel) -> usize {
        1
    }

    fn fit(&self, problem: &ChartProblem, model: &TargetModel, (s, _): &ChartSim) -> Option<TargetModel> {
        let [c0, _] = variance_excess(problem, s)?;
        let mut next = model.clone();
        let k = model.sensor.k_dn_per_e(problem.sim.layout.gain_db);
        let e = &mut next.sensor.effects;
        let cur = if e.dsnu.enabled { e.dsnu.std_e } else { 0.0 };
        let v = cur * cur + c0 / (k * k);
        if v <= 0.0 {
            return None;
        }
        e.dsnu.enabled = true;
        e.dsnu.std_e = v.sqrt();
        Some(next)
    }

    fn params(&self, model: &TargetModel) -> serde_json::Value {
        json!({ "std_e": model.sensor.effects.dsnu.std_e })
    }

    fn scaled(&self, model: &TargetModel, factor: f64) -> Option<TargetModel> {
        let mut m = model.clone();
        m.sensor.effects.dsnu.std_e *= factor;
        Some(m)
    }
}

/// A photograph of the test chart as a [`Problem`] of the effect search.
#[derive(Debug)]
pub struct ChartProblem {
    measured: Stats,
    sim: Simulator,
    tolerance: Tolerance,
}

impl ChartProblem {
    /// `effect` fitted on `model` and settled by `steps` fit-and-simulate rounds; with its
    /// simulation. None when it is never proposed.
    fn fit_effect(
        &self,
        effect: &dyn Effect<Self>,
        model: &TargetModel,
        current: &ChartSim,
        steps: usize,
    ) -> Option<(TargetModel, ChartSim)> {
        let mut cur = effect.fit(self, model, current)?;
        let mut cur_s = self.simulate(&cur);
        for _ in 0..steps {
            let Some(next) = effect.fit(self, &cur, &cur_s) else { break };
            let next_s = self.simulate(&next);
            cur = next;
            cur_s = next_s;
        }
        Some((cur, cur_s))
    }

    /// Polishes the size of `effect` in `model` by minimising the total chi-square over a
    /// factor: three rounds of a parabola through the best factor and its neighbours at a
    /// shrinking step.
    fn polish_scale(&self, effect: &dyn Effect<Self>, model: TargetModel, sim: ChartSim) -> (TargetModel, ChartSim) {
        let eval = |f: f64| {
            let c = effect.scaled(&model, f).unwrap_or_else(|| model.clone());
            let cs = self.simulate(&c);
            (f, c, cs)
        };
        let mut best = (1.0, model.clone(), sim);
        let mut step = 0.08;
        for _ in 0..3 {
            let lo = eval(best.0 - step);
            let hi = eval(best.0 + step);
            let (y0, y1, y2) = (lo.2.1.chi2, best.2.1.chi2, hi.2.1.chi2);
            let curv = y0 - 2.0 * y1 + y2;
            let mut tried = vec![lo, hi];
            if curv > 0.0 {
                let x = best.0 + step * (y0 - y2) / (2.0 * curv);
                tried.push(eval(x.clamp(best.0 - 2.0 * step, best.0 + 2.0 * step).max(0.01)));
            }
            for t in tried {
                if t.2.1.chi2 < best.2.1.chi2 {
                    best = t;
                }
            }
            step /= 3.0;
        }
        (best.1, best.2)
    }
}

impl Problem for ChartProblem {
    type Model = TargetModel;
    type Sim = ChartSim;

    fn effects(&self) -> &[&'static dyn Effect<Self>] {
        &EFFECTS
    }

    fn simulate(&self, model: &TargetModel) -> ChartSim {
        let s = self.sim.run(model);
        let g = stats::gap(&self.measured, &s, &self.tolerance);
        (s, g)
    }

    fn chi2((_, g): &ChartSim) -> f64 {
        g.chi2
    }

    fn ln_n(&self, _: &ChartSim) -> f64 {
        (self.measured.len().max(2) as f64).ln()
    }

    fn max_rounds(&self) -> usize {
        MAX_ROUNDS
    }

    fn is_candidate(&self, effect: &dyn Effect<Self>, _: &TargetModel, added: &[&'static str]) -> bool {
        !added.contains(&effect.name())
    }

    /// The fit settled by [`POLISH_STEPS`] re-simulations.
    fn propose(
        &self,
        effect: &dyn Effect<Self>,
        model: &TargetModel,
        current: &ChartSim,
    ) -> Option<(TargetModel, Option<ChartSim>)> {
        self.fit_effect(effect, model, current, POLISH_STEPS).map(|(m, s)| (m, Some(s)))
    }

    /// Refits everything added so far against the new residuals (one increment, kept only if it
    /// lowers the chi-square, then the size by a parabola search).
    fn polish(&mut self, added: &[&'static str], model: TargetModel, sim: ChartSim) -> (TargetModel, ChartSim) {
        let (mut refined, mut cur) = (model, sim);
        for e in added.iter().filter_map(|&name| effect(name)) {
            if let Some((r, rs)) = self.fit_effect(e, &refined, &cur, 0) {
                if rs.1.chi2 < cur.1.chi2 {
                    (refined, cur) = (r, rs);
                }
            }
            (refined, cur) = self.polish_scale(e, refined, cur);
        }
        (refined, cur)
    }
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

/// The greedy search from `start` ([`crate::search`]).
#[must_use]
pub fn search(m: &Stats, start: TargetModel, sim: &Simulator, tol: &Tolerance) -> TargetResult {
    let mut problem = ChartProblem { measured: m.clone(), sim: sim.clone(), tolerance: *tol };
    let outcome = search::greedy(&mut problem, start.clone());
    let (initial_sim, gap_initial) = outcome.start_sim;
    let steps = outcome
        .accepted
        .iter()
        .map(|a| Step {
            effect: a.effect.to_string(),
            params: effect(a.effect).map_or(serde_json::Value::Null, |e| e.params(&a.model)),
            gap_before: a.before.1.gap,
            gap_after: a.after.1.gap,
            evidence: evidence(&a.before.1, &a.after.1, a.penalty),
            entangled: Vec::new(),
        })
        .collect();
    let evidence = (outcome.accepted.iter())
        .map(|a| Evidence { before: comparison(&a.before.1), accepted: comparison(&a.accepted.1), penalty: a.penalty })
        .collect();
    let trials = outcome
        .trials
        .iter()
        .map(|t| Trial {
            round: t.round,
            effect: t.effect.to_string(),
            params: effect(t.effect).map_or(serde_json::Value::Null, |e| e.params(&t.model)),
            chi2_drop: t.chi2_drop,
            penalty: t.penalty,
            gap_after: t.sim.as_ref().map_or(f64::NAN, |(_, g)| g.gap),
        })
        .collect();
    let (final_sim, gap_final) = outcome.sim;
    TargetResult {
        initial: start,
        final_model: outcome.model,
        measured: m.clone(),
        initial_sim,
        final_sim,
        gap_initial,
        gap_final,
        steps,
        evidence,
        trials,
        misfit: None,
    }
}
