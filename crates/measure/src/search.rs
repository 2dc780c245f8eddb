//! The effect search that `gap` (EMVA 1288 statistics) and `target` (test-chart statistics)
//! share: a greedy, penalised forward selection of named effects.
//!
//! A model starts without the effects the measurement may show. Each round every effect not yet
//! in the model is fitted on top of it ([`Effect::fit`], a closed-form increment from the
//! residuals of the statistics it drives) and simulated; the one with the largest drop of the
//! total chi-square is added when the drop beats its penalty, `factor * k * ln n` with `k` the
//! effect's fitted parameters and `n` the number of statistics: the difference in the Bayesian
//! information criterion of a Gaussian likelihood (Schwarz, "Estimating the dimension of a
//! model", Annals of Statistics 6(2), 1978). A parameter fitted to sampling noise lowers the
//! chi-square by about 1, far below `ln n`, so noise cannot pay for an effect. After each
//! addition the problem polishes the model ([`Problem::polish`]), and the search goes on until
//! no effect earns its place.
//!
//! What differs between measurements lives behind two traits: an [`Effect`] is one named
//! departure from the model (its parameters, how it is fitted, how it is reported); a
//! [`Problem`] is one kind of measurement (how a model is simulated and scored, which effects
//! it can show, how a fitted proposal settles, how the model is polished).

/// Factor on the BIC penalty `k ln n` of most effects: the variances of the statistics are
/// estimated from the same data, not known, and several candidates are tried per round, so the
/// plain BIC lets noise-level drops buy effects. With factor 1, drops of 4..10 from noise alone
/// bought an extra effect in 6 of 40 hidden-effect sets of `gap`, while every true effect there
/// dropped the chi-square by 60 or more: factor 2 costs no hit.
pub const PENALTY_FACTOR: f64 = 2.0;

/// One named effect a model can gain.
pub trait Effect<P: Problem + ?Sized> {
    /// The effect's name, from the effect list of docs/CONTRACTS.md.
    fn name(&self) -> &'static str;

    /// Parameters the fit sets in `model` (the `k` of the penalty): fixed for most effects, the
    /// chosen order for one whose form the fit chooses.
    fn param_count(&self, model: &P::Model) -> usize;

    /// Factor on the penalty `k ln n`: [`PENALTY_FACTOR`] unless the effect's evidence has a
    /// variance the model itself gives (Poisson counts: 1).
    fn penalty_factor(&self) -> f64 {
        PENALTY_FACTOR
    }

    /// The effect fitted on top of `model` (or refitted, when the model has it) from the
    /// measurement and the current simulation `current`; `None` when the data cannot show it.
    fn fit(&self, problem: &P, model: &P::Model, current: &P::Sim) -> Option<P::Model>;

    /// The effect's parameters in `model`, for reports.
    fn params(&self, model: &P::Model) -> serde_json::Value;

    /// `model` with this effect's size multiplied by `factor` (blur width, amplitude, ...), for
    /// problems that polish an effect's size by a one-dimensional search; `None`: not sizeable.
    fn scaled(&self, _model: &P::Model, _factor: f64) -> Option<P::Model> {
        None
    }
}

/// One kind of measurement that the search explains with effects.
pub trait Problem {
    /// What the search refines (a sensor model, optics).
    type Model: Clone;
    /// A model's simulated statistics and their misfit to the measurement.
    type Sim: Clone;

    /// The effects this measurement can show, in the order they are tried (ties go to the
    /// earlier one).
    fn effects(&self) -> &[&'static dyn Effect<Self>];

    /// Simulates `model` and scores it against the measurement.
    fn simulate(&self, model: &Self::Model) -> Self::Sim;

    /// Simulates `models` (a round's proposals that are simulated in full), in their order;
    /// a problem whose simulations leave cores idle runs them side by side.
    fn simulate_all(&self, models: &[&Self::Model]) -> Vec<Self::Sim> {
        models.iter().map(|m| self.simulate(m)).collect()
    }

    /// Total chi-square of a simulation against the measurement.
    fn chi2(sim: &Self::Sim) -> f64;

    /// `ln n`, `n` the number of statistics, given the start's simulation.
    fn ln_n(&self, start: &Self::Sim) -> f64;

    /// Most rounds (effects added).
    fn max_rounds(&self) -> usize;

    /// Whether `effect` is tried on `model` after `added` were added by this search.
    fn is_candidate(&self, effect: &dyn Effect<Self>, model: &Self::Model, added: &[&'static str]) -> bool;

    /// Fits `effect` on `model` and settles the proposal (refits of nuisance parameters, or a
    /// few fit-and-simulate steps); returns it with its simulation when settling made one.
    fn propose(
        &self,
        effect: &dyn Effect<Self>,
        model: &Self::Model,
        current: &Self::Sim,
    ) -> Option<(Self::Model, Option<Self::Sim>)> {
        effect.fit(self, model, current).map(|m| (m, None))
    }

    /// A cheap ranking of a round's proposals: the chi-square drop of each on a smaller
    /// simulation, and how many of the best to simulate in full. `None`: simulate every one.
    fn screen(&self, _model: &Self::Model, _proposals: &[Self::Model]) -> Option<(Vec<f64>, usize)> {
        None
    }

    /// Polishes the model after `added`'s last effect was accepted (refits against the new
    /// residuals); returns the polished model and its simulation.
    fn polish(&mut self, added: &[&'static str], model: Self::Model, sim: Self::Sim) -> (Self::Model, Self::Sim);
}

/// One effect tried in one round.
#[derive(Clone, Debug)]
pub struct Trial<M, S> {
    pub round: usize,
    pub effect: &'static str,
    /// Drop of the total chi-square (on the screening simulation when `sim` is `None`).
    pub chi2_drop: f64,
    pub penalty: f64,
    /// The fitted proposal.
    pub model: M,
    /// Its full simulation; `None` when it was only screened.
    pub sim: Option<S>,
}

/// One accepted effect.
#[derive(Clone, Debug)]
pub struct Accepted<M, S> {
    pub effect: &'static str,
    pub param_count: usize,
    pub chi2_drop: f64,
    pub penalty: f64,
    /// The simulation before the effect was added.
    pub before: S,
    /// The simulation of the accepted proposal, before polishing.
    pub accepted: S,
    /// The model and simulation after polishing.
    pub model: M,
    pub after: S,
}

/// What a search found.
#[derive(Clone, Debug)]
pub struct Outcome<M, S> {
    pub start_sim: S,
    pub model: M,
    pub sim: S,
    pub accepted: Vec<Accepted<M, S>>,
    pub trials: Vec<Trial<M, S>>,
}

/// A fitted candidate of one round.
struct Proposal<P: Problem + 'static> {
    effect: &'static dyn Effect<P>,
    model: P::Model,
    /// Its simulation, when settling the fit made one.
    sim: Option<P::Sim>,
}

/// Every candidate of a round fitted on `model`, in the problem's order.
fn proposals<P: Problem + 'static>(
    problem: &P,
    model: &P::Model,
    sim: &P::Sim,
    added: &[&'static str],
) -> Vec<Proposal<P>> {
    problem
        .effects()
        .iter()
        .filter(|effect| problem.is_candidate(**effect, model, added))
        .filter_map(|&effect| {
            let (model, sim) = problem.propose(effect, model, sim)?;
            Some(Proposal { effect, model, sim })
        })
        .collect()
}

/// Which proposals are simulated in full (all, unless the problem screens them), and the
/// screened drops of the others.
fn screen<P: Problem + 'static>(problem: &P, model: &P::Model, proposals: &[Proposal<P>]) -> (Vec<bool>, Vec<f64>) {
    let models: Vec<P::Model> = proposals.iter().map(|p| p.model.clone()).collect();
    let mut full = vec![true; proposals.len()];
    let Some((drops, keep)) = problem.screen(model, &models).filter(|(_, keep)| proposals.len() > *keep) else {
        return (full, vec![f64::NAN; proposals.len()]);
    };
    let mut order: Vec<usize> = (0..proposals.len()).collect();
    order.sort_by(|&a, &b| drops[b].total_cmp(&drops[a]).then(a.cmp(&b)));
    for &i in &order[keep..] {
        full[i] = false;
    }
    (full, drops)
}

/// The greedy search from `start` (see the module docs).
pub fn greedy<P: Problem + 'static>(problem: &mut P, start: P::Model) -> Outcome<P::Model, P::Sim> {
    let start_sim = problem.simulate(&start);
    let ln_n = problem.ln_n(&start_sim);
    let (mut model, mut sim) = (start, start_sim.clone());
    let mut accepted: Vec<Accepted<P::Model, P::Sim>> = Vec::new();
    let mut trials: Vec<Trial<P::Model, P::Sim>> = Vec::new();
    let mut added: Vec<&'static str> = Vec::new();
    for round in 1..=problem.max_rounds() {
        let proposals = proposals(problem, &model, &sim, &added);
        let (full, screened_drops) = screen(problem, &model, &proposals);
        let chi2 = P::chi2(&sim);
        let first = trials.len();
        let unsimulated: Vec<&P::Model> =
            proposals.iter().zip(&full).filter(|(p, f)| **f && p.sim.is_none()).map(|(p, _)| &p.model).collect();
        let mut simulated = problem.simulate_all(&unsimulated).into_iter();
        let mut best: Option<usize> = None;
        for (i, p) in proposals.into_iter().enumerate() {
            let penalty = p.effect.penalty_factor() * p.effect.param_count(&p.model) as f64 * ln_n;
            let (chi2_drop, full_sim) = if full[i] {
                let s = p.sim.or_else(|| simulated.next()).expect("simulate_all gives one simulation per model");
                (chi2 - P::chi2(&s), Some(s))
            } else {
                (screened_drops[i], None)
            };
            if full_sim.is_some() && chi2_drop > penalty && best.is_none_or(|b| chi2_drop > trials[b].chi2_drop) {
                best = Some(first + i);
            }
            trials.push(Trial { round, effect: p.effect.name(), chi2_drop, penalty, model: p.model, sim: full_sim });
        }
        let Some(b) = best else {
            log::info!(
                "effect search, round {round}: {} candidates, none pays its penalty; done",
                trials.len() - first
            );
            break;
        };
        let trial = &trials[b];
        log::info!(
            "effect search, round {round}: {} candidates, adds {} (statistic drop {:.1}, penalty {:.1})",
            trials.len() - first,
            trial.effect,
            trial.chi2_drop,
            trial.penalty
        );
        let (effect, candidate) = (trial.effect, trial.model.clone());
        let candidate_sim = trial.sim.clone().expect("the best trial was simulated in full");
        let param_count =
            problem.effects().iter().find(|e| e.name() == effect).map_or(0, |e| e.param_count(&candidate));
        added.push(effect);
        let before = std::mem::replace(&mut sim, candidate_sim.clone());
        (model, sim) = problem.polish(&added, candidate, candidate_sim.clone());
        accepted.push(Accepted {
            effect,
            param_count,
            chi2_drop: trials[b].chi2_drop,
            penalty: trials[b].penalty,
            before,
            accepted: candidate_sim,
            model: model.clone(),
            after: sim.clone(),
        });
    }
    Outcome { start_sim, model, sim, accepted, trials }
}
