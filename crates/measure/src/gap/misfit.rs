//! What the fitted model leaves unexplained: the misfit left after the effect search, tested
//! against its own sampling distribution.
//!
//! The search adds an effect only when it pays its penalty, so misfit that no effect in the
//! library describes stays behind, spread over the statistics it touches. Whether that
//! leftover is more than noise is decided by simulation, not by the nominal chi-square: the
//! final model is simulated `R` more times with fresh noise *and* fresh fixed patterns (a
//! different camera of the same model, as the measured one is), each replicate is compared
//! with the final simulation exactly as the measurement was, and each family's chi-square of
//! the measurement is set against the family's `R` replicate chi-squares.
//!
//! The replicates' family chi-squares are summarised as a scaled chi-square `a chi2(nu)`
//! matching their mean and variance (Satterthwaite's approximation), with two guards for a
//! small `R`: the variance is taken at the 95 % upper confidence bound of the replicates' sample
//! variance, and `nu` never exceeds the family's count of statistics. The upper-tail
//! probability of the measured chi-square under it (Wilson and Hilferty's cube-root normal
//! approximation) is tested at [`FAMILY_FALSE_ALARM`] per set, Bonferroni-divided over the
//! families. The measured chi-square is, if anything, low against this null: the search fitted
//! the model's parameters to the measurement and not to the replicates.
//!
//! One statistic far out is not diluted by its family: it is also tested on its own, its
//! residual over the largest of its replicates' spread, its family's pooled spread and 1,
//! Bonferroni over every statistic.
//!
//! Where the misfit lives: each statistic's normalised residual is divided by its replicates'
//! root mean square (its own null spread), and the statistics of an unexplained family beyond
//! [`LOCATE_SIGMAS`] are listed: which photon-transfer steps (photon range), dark exposures,
//! spatial statistic (residual, row- or column-profile variance of which stack), periodogram
//! peak (its frequencies) or tail count (measured against expected pixels). The search then
//! calls an added effect *tentative* when its evidence rests on those statistics
//! ([`super::GapResult::tentative`]), or on a family left elevated ([`ELEVATED_SIGMAS`]) whose
//! remaining excess is larger than what the effect took from it. The test-chart loop runs the
//! same [`test()`] on its own statistics (`crate::target`).

use rand::Rng as _;
use serde::Serialize;

use super::stats::{self, Gap, Peak, Stats};
use scene_gen_core::rng;

/// Replicate simulations of the final model by default.
pub const DEFAULT_REPLICATES: usize = 8;

/// Probability, per data set, that some family of a correctly modelled camera is reported
/// unexplained (split evenly over the families compared).
pub const FAMILY_FALSE_ALARM: f64 = 0.01;

/// A statistic is listed as a place of the misfit beyond this many of its null spreads.
pub const LOCATE_SIGMAS: f64 = 3.0;

/// A family the final model leaves this many replicate standard deviations above their mean
/// is elevated: short of unexplained, yet not explained either.
pub const ELEVATED_SIGMAS: f64 = 2.0;

/// An effect improved a family when it lowered the family's chi-square by more than this (a
/// parameter fitted to noise lowers it by about 1).
const IMPROVED_CHI2: f64 = 1.0;

/// Families whose statistics sample one response curve: against photons or exposure (the
/// sensor workflow's), against reflectance or signal (the test chart's patch means and
/// variances) and against the field radius (the chart's radial profile).
pub const CURVE_FAMILIES: [&str; 6] = ["linearity", "photon_transfer", "dark", "patch_mean", "patch_var", "radial"];

/// Most statistics listed per unexplained family (the largest first).
const MAX_LISTED: usize = 8;

/// One family's measured chi-square against its replicates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FamilyNull {
    pub family: &'static str,
    /// Chi-square of the measurement against the final simulation.
    pub chi2: f64,
    pub dof: usize,
    /// Mean and standard deviation of the replicates' chi-squares.
    pub null_mean: f64,
    pub null_sd: f64,
    /// Upper-tail probability of `chi2` under the replicates' scaled chi-square.
    pub p_value: f64,
    pub unexplained: bool,
}

/// One statistic where an unexplained misfit shows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Place {
    pub statistic: String,
    /// The statistic's abscissa (photons, exposure s, cycles per pixel) or 0.
    pub x: f64,
    pub measured: f64,
    /// The final model's value (a tail count: its expectation).
    pub simulated: f64,
    /// Normalised residual of the measurement.
    pub z: f64,
    /// Root mean square of the replicates' normalised residuals on this statistic.
    pub null_rms: f64,
}

/// A family whose misfit is larger than its sampling distribution allows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Unexplained {
    pub family: &'static str,
    /// Indices (into the statistics' entries) of where the misfit lives. In a family of
    /// separate quantities (spatial, correlation, spectrum, tails) the statistics beyond
    /// [`LOCATE_SIGMAS`], or all of them when it is spread thinly; in a response curve
    /// ([`CURVE_FAMILIES`]) all of them, since a curve's misfit anywhere makes any effect fitted
    /// to its shape doubtful everywhere.
    #[serde(skip)]
    pub entries: Vec<usize>,
    pub p_value: f64,
    /// A sentence saying where the misfit lives.
    pub r#where: String,
    pub statistics: Vec<Place>,
}

/// The check's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MisfitCheck {
    pub replicates: usize,
    pub families: Vec<FamilyNull>,
    pub unexplained: Vec<Unexplained>,
}

impl MisfitCheck {
    /// The families reported unexplained, in report order.
    #[must_use]
    pub fn unexplained_families(&self) -> Vec<&'static str> {
        self.unexplained.iter().map(|u| u.family).collect()
    }
}

/// The seeds of replicate `index` of a check drawn from `seed` under `label`: its frame seed
/// and its fixed-pattern seed (another camera of the same model).
#[must_use]
pub fn replicate_seeds(seed: u64, label: &str, index: usize) -> (u64, u64) {
    let frame: u64 = rng::substream(seed, label, index as u64).random();
    (frame, rng::substream(frame, label, u64::MAX).random())
}

/// report.json's `unexplained` value: the unexplained families with where their misfit lives
/// (`[]` when none, or when the check did not run).
#[must_use]
pub fn unexplained_json(check: Option<&MisfitCheck>) -> serde_json::Value {
    serde_json::json!(check.map(|m| m.unexplained.clone()).unwrap_or_default())
}

/// report.json's `misfit_check` value: the replicate count and every family's test (null when
/// the check did not run).
#[must_use]
pub fn check_json(check: Option<&MisfitCheck>) -> serde_json::Value {
    serde_json::json!(check.map(|m| serde_json::json!({"replicates": m.replicates, "families": m.families})))
}

/// report.md's "Unexplained" section: each family's leftover chi-square against the replicates
/// and where an unexplained misfit lives.
#[must_use]
pub fn markdown(check: Option<&MisfitCheck>) -> String {
    let Some(m) = check else { return "\n## Unexplained\n\nNot tested (no replicates).\n".into() };
    let mut s = format!(
        "\n## Unexplained\n\nThe final model simulated {} more times with fresh noise and fixed patterns; \
         each family's chi-square against the final simulation, measured and in the replicates \
         (a family is unexplained when its p-value is below {FAMILY_FALSE_ALARM} divided over the families).\n\n\
         | family | statistics | measured | replicates (mean +- sd) | p | unexplained |\n|---|---|---|---|---|---|\n",
        m.replicates
    );
    for f in &m.families {
        let verdict = if f.unexplained { "**yes**" } else { "no" };
        s += &format!(
            "| {} | {} | {:.1} | {:.1} +- {:.1} | {:.2e} | {verdict} |\n",
            f.family, f.dof, f.chi2, f.null_mean, f.null_sd, f.p_value
        );
    }
    if m.unexplained.is_empty() {
        s += "\nNothing is left unexplained: every family's misfit is within its sampling spread.\n";
    }
    for u in &m.unexplained {
        s += &format!("\n- **{}**: {}\n", u.family, u.r#where);
    }
    s
}

/// One compared statistic, as the check sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct Statistic {
    pub family: &'static str,
    pub label: String,
    pub x: f64,
    pub measured: f64,
    /// The final model's value (a tail count: its expectation).
    pub simulated: f64,
}

/// One comparison against the final model's simulation: chi-square and statistics per family
/// (`(family, chi2, dof)`) and the normalised residual of every statistic.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    pub families: Vec<(&'static str, f64, usize)>,
    pub residuals: Vec<f64>,
}

impl From<&Gap> for Comparison {
    fn from(g: &Gap) -> Self {
        Comparison {
            families: g.families.iter().map(|f| (f.family, f.chi2, f.dof)).collect(),
            residuals: g.residuals.clone(),
        }
    }
}

/// What an accepted effect's place in the model rests on: the comparison before it was added,
/// the comparison of the search's proposal (before polishing), and the penalty its chi-square
/// drop had to beat.
#[derive(Debug, Clone, PartialEq)]
pub struct Evidence {
    pub before: Comparison,
    pub accepted: Comparison,
    pub penalty: f64,
}

impl Evidence {
    /// The unexplained families this evidence depends on: the chi-square drop, counted without
    /// the statistics where unexplained misfit lives ([`Unexplained::entries`]), no longer pays
    /// the penalty. Such an effect lowered the misfit, but what it absorbed may be an effect
    /// outside the library, so it is tentative. Empty: the evidence stands on statistics the
    /// final model explains.
    ///
    /// A family the final model leaves elevated ([`ELEVATED_SIGMAS`]) counts the same way when
    /// the effect's drop there is smaller than the excess the family keeps: the effect then
    /// absorbed a part of a misfit it does not explain.
    #[must_use]
    pub fn entangled(&self, check: &MisfitCheck) -> Vec<&'static str> {
        let unexplained = self.entangled_unexplained(check);
        if unexplained.is_empty() { self.entangled_elevated(check) } else { unexplained }
    }

    /// Chi-square of `family` before and at acceptance.
    fn family_drop(&self, family: &str) -> f64 {
        let chi2 = |c: &Comparison| c.families.iter().find(|f| f.0 == family).map_or(0.0, |f| f.1);
        chi2(&self.before) - chi2(&self.accepted)
    }

    fn entangled_elevated(&self, check: &MisfitCheck) -> Vec<&'static str> {
        // (family, its excess over the replicates' mean, the effect's drop there)
        let elevated: Vec<(&'static str, f64, f64)> = check
            .families
            .iter()
            .filter(|f| !f.unexplained && f.chi2 - f.null_mean > ELEVATED_SIGMAS * f.null_sd)
            .map(|f| (f.family, f.chi2 - f.null_mean, self.family_drop(f.family)))
            .filter(|&(_, _, drop)| drop > IMPROVED_CHI2)
            .collect();
        if elevated.is_empty() {
            return Vec::new();
        }
        let total: f64 = self.before.residuals.iter().zip(&self.accepted.residuals).map(|(b, c)| b * b - c * c).sum();
        let inside: f64 = elevated.iter().map(|&(_, _, drop)| drop).sum();
        let absorbed = elevated.iter().all(|&(_, excess, drop)| drop < excess);
        if total - inside > self.penalty || !absorbed {
            return Vec::new();
        }
        elevated.into_iter().map(|(family, _, _)| family).collect()
    }

    fn entangled_unexplained(&self, check: &MisfitCheck) -> Vec<&'static str> {
        if check.unexplained.is_empty() {
            return Vec::new();
        }
        let flagged: Vec<usize> = check.unexplained.iter().flat_map(|u| u.entries.iter().copied()).collect();
        let drop: f64 = (self.before.residuals.iter().zip(&self.accepted.residuals).enumerate())
            .filter(|(i, _)| !flagged.contains(i))
            .map(|(_, (b, c))| b * b - c * c)
            .sum();
        if drop > self.penalty {
            return Vec::new();
        }
        check.unexplained.iter().map(|u| u.family).filter(|f| self.family_drop(f) > IMPROVED_CHI2).collect()
    }
}

/// Tests the final misfit of `measured` against `final_stats` (their comparison `final_gap`)
/// with `replicates` ([`Stats`] of the final model simulated with fresh noise and patterns,
/// computed with the measured thresholds).
#[must_use]
pub fn check(measured: &Stats, final_stats: &Stats, final_gap: &Gap, replicates: &[Stats]) -> MisfitCheck {
    let nulls: Vec<Comparison> = replicates.iter().map(|r| Comparison::from(&stats::gap(r, final_stats))).collect();
    let statistics: Vec<Statistic> = measured
        .entries
        .iter()
        .enumerate()
        .map(|(i, e)| Statistic {
            family: e.family,
            label: e.label.clone(),
            x: e.x,
            measured: e.value,
            simulated: final_stats.entries.get(i).map_or(f64::NAN, |s| s.value + s.count_floor.unwrap_or(0.0)),
        })
        .collect();
    test(&statistics, &Comparison::from(final_gap), &nulls, &measured.peaks)
}

/// The check on any comparison: `statistics` and their `measured` comparison with the final
/// simulation, against the replicates' comparisons `nulls` (see the module docs). `peaks`: the
/// measured periodogram peaks, named where a `spectrum` family is unexplained.
#[must_use]
pub fn test(statistics: &[Statistic], measured: &Comparison, nulls: &[Comparison], peaks: &[Peak]) -> MisfitCheck {
    let compared = measured.families.len().max(1) as f64;
    let alpha = FAMILY_FALSE_ALARM / compared;
    // A single statistic far out is tested on its own too, against the largest of its own
    // replicates' spread, its family's pooled one and 1 (eight replicates cannot show a spread
    // narrower than nominal reliably), Bonferroni over every statistic.
    let z_single = stats::normal_tail_inverse(FAMILY_FALSE_ALARM / (2.0 * measured.residuals.len().max(1) as f64));
    let families: Vec<FamilyNull> = measured
        .families
        .iter()
        .map(|&(family, chi2, dof)| {
            let samples: Vec<f64> =
                nulls.iter().filter_map(|g| g.families.iter().find(|x| x.0 == family).map(|x| x.1)).collect();
            let (mean, var) = (stats::mean(&samples), if samples.len() > 1 { stats::var(&samples) } else { 0.0 });
            let p_chi2 = scaled_chi2_tail(chi2, dof, mean, var, samples.len());
            let pooled_rms = (mean / dof.max(1) as f64).sqrt();
            let largest = statistics
                .iter()
                .enumerate()
                .filter(|(_, e)| e.family == family)
                .map(|(i, _)| {
                    let z = measured.residuals.get(i).copied().unwrap_or(0.0).abs();
                    z / null_rms(nulls, i).max(pooled_rms).max(1.0)
                })
                .fold(0.0, f64::max);
            // The statistic's two-sided tail, scaled by the statistics compared, as a p-value
            // on the family's scale.
            let p_single = (2.0 * stats::normal_tail(largest) * measured.residuals.len() as f64 / compared).min(1.0);
            let p_value = if largest > z_single { p_chi2.min(p_single) } else { p_chi2 };
            FamilyNull {
                family,
                chi2,
                dof,
                null_mean: mean,
                null_sd: var.sqrt(),
                p_value,
                unexplained: !samples.is_empty() && p_value < alpha,
            }
        })
        .collect();
    let unexplained =
        families.iter().filter(|f| f.unexplained).map(|f| locate(f, statistics, measured, nulls, peaks)).collect();
    MisfitCheck { replicates: nulls.len(), families, unexplained }
}

/// Root mean square of the replicates' normalised residuals on statistic `i`.
fn null_rms(nulls: &[Comparison], i: usize) -> f64 {
    (nulls.iter().filter_map(|g| g.residuals.get(i)).map(|r| r * r).sum::<f64>() / nulls.len().max(1) as f64).sqrt()
}

/// Lower `q` quantile of chi-square with `k` degrees of freedom (Wilson-Hilferty).
fn chi2_quantile_lower(k: f64, q: f64) -> f64 {
    let z = -stats::normal_tail_inverse(q);
    let h = 2.0 / (9.0 * k);
    (k * (1.0 - h + z * h.sqrt()).powi(3)).max(1e-9)
}

/// Upper-tail probability of `x` under `a chi2(nu)` matched to a sample of `n` chi-squares with
/// mean `mean` and variance `var` (the variance at its 95 % upper confidence bound, `nu` at most
/// `dof`).
fn scaled_chi2_tail(x: f64, dof: usize, mean: f64, var: f64, n: usize) -> f64 {
    if n == 0 || mean <= 0.0 {
        return 1.0;
    }
    let var_upper = if n > 1 { var * (n - 1) as f64 / chi2_quantile_lower((n - 1) as f64, 0.05) } else { 0.0 };
    let nu = if var_upper > 0.0 { (2.0 * mean * mean / var_upper).min(dof as f64) } else { dof as f64 }.max(0.5);
    let a = mean / nu;
    // Wilson-Hilferty: (X / nu)^(1/3) is close to normal with mean 1 - 2/(9 nu), variance 2/(9 nu).
    let h = 2.0 / (9.0 * nu);
    let z = ((x / a / nu).max(0.0).cbrt() - (1.0 - h)) / h.sqrt();
    stats::normal_tail(z)
}

/// The statistics of family `f` where the misfit lives, and a sentence naming them.
fn locate(
    f: &FamilyNull,
    statistics: &[Statistic],
    measured: &Comparison,
    nulls: &[Comparison],
    peaks: &[Peak],
) -> Unexplained {
    let mut places: Vec<(f64, Place, usize)> = statistics
        .iter()
        .enumerate()
        .filter(|(_, e)| e.family == f.family)
        .map(|(i, e)| {
            let z = measured.residuals.get(i).copied().unwrap_or(0.0);
            let rms = null_rms(nulls, i).max(0.1);
            let place = Place {
                statistic: e.label.clone(),
                x: e.x,
                measured: e.measured,
                simulated: e.simulated,
                z,
                null_rms: rms,
            };
            ((z / rms).abs(), place, i)
        })
        .collect();
    places.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.2.cmp(&b.2)));
    let beyond = places.iter().filter(|p| p.0 > LOCATE_SIGMAS).count();
    let whole = beyond == 0 || CURVE_FAMILIES.contains(&f.family);
    let entries: Vec<usize> = places.iter().take(if whole { places.len() } else { beyond }).map(|p| p.2).collect();
    // A misfit spread thinly over many statistics has no single place: list the largest three.
    places.truncate(if beyond > 0 { beyond.min(MAX_LISTED) } else { 3 });
    let statistics: Vec<Place> = places.into_iter().map(|(_, p, _)| p).collect();
    let r#where = describe(f, &statistics, peaks, beyond);
    Unexplained { family: f.family, entries, p_value: f.p_value, r#where, statistics }
}

/// One sentence on where the misfit of family `f` lives.
fn describe(f: &FamilyNull, places: &[Place], peaks: &[Peak], beyond: usize) -> String {
    let head = format!(
        "{}: chi-square {:.1} over {} statistics against {:.1} +- {:.1} in replicates (p {:.1e})",
        f.family, f.chi2, f.dof, f.null_mean, f.null_sd, f.p_value
    );
    if beyond == 0 {
        return format!("{head}; spread thinly, no statistic beyond {LOCATE_SIGMAS} of its own spread");
    }
    let span = |unit: &str| {
        let lo = places.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
        let hi = places.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
        if lo == hi { format!("{lo:.4} {unit}") } else { format!("{lo:.4}..{hi:.4} {unit}") }
    };
    let sign = |p: &Place| if p.z > 0.0 { "above" } else { "below" };
    let detail = match f.family {
        "linearity" | "photon_transfer" => {
            let above = places.iter().filter(|p| p.z > 0.0).count();
            format!(
                "{beyond} photon-transfer steps beyond {LOCATE_SIGMAS} sigma over {}; measured {} the model at {above} of the {} listed",
                span("photons per pixel"),
                if f.family == "linearity" { "mean" } else { "variance" },
                places.len()
            )
        }
        "dark" => format!("dark pairs at {}", span("s")),
        "spectrum" => places
            .iter()
            .map(|p| {
                let peak = peaks.iter().find(|k| k.fx_cycles_per_px == p.x);
                match peak {
                    Some(k) => format!(
                        "dark-stack periodogram peak at ({:.3}, {:.3}) cycles/px, {:.1} x median, model {:.1}",
                        k.fx_cycles_per_px, k.fy_cycles_per_px, p.measured, p.simulated
                    ),
                    None => format!("{} {:.1}, model {:.1}", p.statistic, p.measured, p.simulated),
                }
            })
            .collect::<Vec<_>>()
            .join("; "),
        "tails" => places
            .iter()
            .map(|p| format!("{}: {:.0} measured, {:.1} expected", p.statistic, p.measured, p.simulated))
            .collect::<Vec<_>>()
            .join("; "),
        _ => places
            .iter()
            .map(|p| {
                format!(
                    "{} measured {} the model ({:.3e} against {:.3e})",
                    p.statistic,
                    sign(p),
                    p.measured,
                    p.simulated
                )
            })
            .collect::<Vec<_>>()
            .join("; "),
    };
    format!("{head}; {detail}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_hilferty_quantile_is_close() {
        // chi2(7) 5 % lower quantile is 2.167; chi2(30) 5 % is 18.49.
        assert!((chi2_quantile_lower(7.0, 0.05) - 2.167).abs() < 0.03);
        assert!((chi2_quantile_lower(30.0, 0.05) - 18.49).abs() < 0.1);
    }

    #[test]
    fn tail_of_the_null_mean_is_about_one_half_and_far_values_are_rare() {
        // Replicates of a plain chi2(20): mean 20, variance 40.
        let p_mid = scaled_chi2_tail(20.0, 20, 20.0, 40.0, 8);
        assert!((0.3..0.6).contains(&p_mid), "{p_mid}");
        // Eight replicates leave the spread uncertain; its upper bound widens the null (nu 6
        // instead of 20), so four times the mean is rare, six times very rare.
        assert!(scaled_chi2_tail(80.0, 20, 20.0, 40.0, 8) < 1e-3);
        assert!(scaled_chi2_tail(120.0, 20, 20.0, 40.0, 8) < 1e-5);
        // A wider null (correlated statistics) makes the same value less surprising.
        assert!(scaled_chi2_tail(60.0, 20, 20.0, 400.0, 8) > scaled_chi2_tail(60.0, 20, 20.0, 40.0, 8));
    }

    /// `dark` ends 33 above its replicates' mean (sd 7.7): elevated, not unexplained.
    fn elevated_dark_check() -> MisfitCheck {
        let family = |family, chi2, null_mean, null_sd| FamilyNull {
            family,
            chi2,
            dof: 40,
            null_mean,
            null_sd,
            p_value: 0.02,
            unexplained: false,
        };
        MisfitCheck {
            replicates: 8,
            families: vec![family("dark", 70.3, 37.4, 7.7), family("spatial", 4.9, 6.4, 3.4)],
            unexplained: Vec::new(),
        }
    }

    /// An evidence whose chi-square drops by `dark_drop` over two dark statistics and by
    /// `spatial_drop` over one spatial one.
    fn evidence(dark_drop: f64, spatial_drop: f64) -> Evidence {
        let before =
            Comparison { families: vec![("dark", 100.0, 2), ("spatial", 16.0, 1)], residuals: vec![7.0, 7.0, 4.0] };
        let d = (49.0 - dark_drop / 2.0).sqrt();
        let accepted = Comparison {
            families: vec![("dark", 100.0 - dark_drop, 2), ("spatial", 16.0 - spatial_drop, 1)],
            residuals: vec![d, d, (16.0 - spatial_drop).sqrt()],
        };
        Evidence { before, accepted, penalty: 9.1 }
    }

    #[test]
    fn a_small_drop_in_an_elevated_family_is_entangled_with_it() {
        let check = elevated_dark_check();
        // 12 of its 13.6 drop in `dark`, which keeps an excess of 33: tentative.
        assert_eq!(evidence(12.0, 1.6).entangled(&check), ["dark"]);
        // A drop larger than the excess the family keeps is evidence of its own.
        assert!(evidence(40.0, 1.6).entangled(&check).is_empty());
        // So is one that pays the penalty outside the elevated family.
        assert!(evidence(12.0, 10.0).entangled(&check).is_empty());
        // Nothing elevated: nothing entangled.
        let mut calm = check.clone();
        calm.families[0].chi2 = 40.0;
        assert!(evidence(12.0, 1.6).entangled(&calm).is_empty());
    }
}
