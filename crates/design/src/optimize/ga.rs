//! The TaCOS genetic algorithm (docs/REFERENCE.md, "Genetic algorithm"): truncation selection of the
//! `parents` best, `elites` survivors, offspring by uniform crossover of two parents, then
//! multiplicative and additive mutation with clipping; the sensor index moves by a bounded
//! number of steps in area order.
//!
//! Every function here is pure given its random stream, so a generation can be re-created
//! from the previous one alone (which is what makes a run resumable without saving RNG state).

use rand::Rng;
use serde::{Deserialize, Serialize};

use super::config::GaConfig;
use super::genes::{Genome, Space, uniform};

/// Why a candidate is in its generation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Origin {
    /// Generation 0, drawn uniformly (shared by the GA and random search).
    Initial,
    /// One of the previous generation's best, carried over unchanged with its score.
    Elite,
    /// Bred by crossover and mutation.
    Offspring,
    /// Drawn uniformly by random search.
    Random,
}

impl Origin {
    /// Whether the candidate needs an evaluation (elites keep their score).
    #[must_use]
    pub fn evaluated(self) -> bool {
        self != Origin::Elite
    }

    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Origin::Initial => "initial",
            Origin::Elite => "elite",
            Origin::Offspring => "offspring",
            Origin::Random => "random",
        }
    }
}

/// Indices of `fitness` from best to worst; ties (and NaN, ranked last) keep index order.
#[must_use]
pub fn ranking(fitness: &[f64]) -> Vec<usize> {
    let key = |f: f64| if f.is_nan() { f64::NEG_INFINITY } else { f };
    let mut order: Vec<usize> = (0..fitness.len()).collect();
    order.sort_by(|&a, &b| key(fitness[b]).total_cmp(&key(fitness[a])).then(a.cmp(&b)));
    order
}

/// Uniform crossover: each gene (the sensor included) from `a` or `b` with equal chance.
pub fn crossover<R: Rng + ?Sized>(a: &Genome, b: &Genome, rng: &mut R) -> Genome {
    let sensor = if rng.random::<bool>() { a.sensor } else { b.sensor };
    let values = a.values.iter().zip(&b.values).map(|(&x, &y)| if rng.random::<bool>() { x } else { y }).collect();
    Genome { sensor, values }
}

/// TaCOS mutation: every continuous gene `x <- x * U(scale_min, scale_max) + U(-a, a)`, then
/// clipped; the sensor index moves by a uniform step in `[-sensor_max_step, sensor_max_step]`,
/// then clipped to the catalog.
pub fn mutate<R: Rng + ?Sized>(space: &Space, ga: &GaConfig, genome: &Genome, rng: &mut R) -> Genome {
    let step = ga.sensor_max_step as i64;
    let sensor = if space.sensor_enabled {
        let moved = genome.sensor as i64 + rng.random_range(-step..=step);
        moved.clamp(0, space.sensors.len() as i64 - 1) as usize
    } else {
        genome.sensor
    };
    let values = space
        .genes
        .iter()
        .zip(&genome.values)
        .map(|(g, &x)| {
            let scale = uniform(rng, ga.scale_min, ga.scale_max);
            let shift = uniform(rng, -g.range.additive, g.range.additive);
            x * scale + shift
        })
        .collect();
    space.clip(&Genome { sensor, values })
}

/// The next generation from the scored `previous` one: the `elites` best unchanged, then
/// `population - elites` offspring of two distinct parents drawn from the `parents` best.
#[must_use]
pub fn next_generation<R: Rng + ?Sized>(
    space: &Space,
    ga: &GaConfig,
    previous: &[(Genome, f64)],
    rng: &mut R,
) -> Vec<(Genome, Origin)> {
    let fitness: Vec<f64> = previous.iter().map(|(_, f)| *f).collect();
    let order = ranking(&fitness);
    let parents: Vec<&Genome> = order.iter().take(ga.parents.max(1)).map(|&i| &previous[i].0).collect();
    let mut next: Vec<(Genome, Origin)> =
        order.iter().take(ga.elites).map(|&i| (previous[i].0.clone(), Origin::Elite)).collect();
    while next.len() < ga.population {
        let a = rng.random_range(0..parents.len());
        let b = if parents.len() > 1 {
            // A second, different parent.
            (a + 1 + rng.random_range(0..parents.len() - 1)) % parents.len()
        } else {
            a
        };
        let child = crossover(parents[a], parents[b], rng);
        next.push((mutate(space, ga, &child, rng), Origin::Offspring));
    }
    next
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::config::OptimizeConfig;
    use proptest::prelude::*;
    use scene_gen_camera::sensor::Catalog;
    use scene_gen_core::rng::stream;

    fn space() -> (Space, GaConfig) {
        let config = OptimizeConfig::default();
        (Space::new(&config, &Catalog::embedded()), config.ga)
    }

    fn scored(space: &Space, seed: u64) -> Vec<(Genome, f64)> {
        let mut rng = stream(seed, "test/pop");
        (0..10).map(|i| (space.random(&mut rng), f64::from(i * 7 % 10))).collect()
    }

    #[test]
    fn ranking_is_descending_and_stable() {
        assert_eq!(ranking(&[1.0, 3.0, f64::NAN, 3.0, 2.0]), vec![1, 3, 4, 0, 2]);
    }

    proptest! {
        #[test]
        fn elites_survive_and_offspring_come_from_parents(seed in 0u64..500) {
            let (space, ga) = space();
            let prev = scored(&space, seed);
            let next = next_generation(&space, &ga, &prev, &mut stream(seed, "test/next"));
            prop_assert_eq!(next.len(), ga.population);
            let order = ranking(&prev.iter().map(|p| p.1).collect::<Vec<_>>());
            for (k, &i) in order.iter().take(ga.elites).enumerate() {
                prop_assert_eq!(&next[k].0, &prev[i].0);
                prop_assert_eq!(next[k].1, Origin::Elite);
            }
            let parents: Vec<&Genome> = order.iter().take(ga.parents).map(|&i| &prev[i].0).collect();
            for (child, origin) in &next[ga.elites..] {
                prop_assert_eq!(*origin, Origin::Offspring);
                // The sensor is within 3 steps of some parent's sensor.
                prop_assert!(parents.iter().any(|p| p.sensor.abs_diff(child.sensor) <= ga.sensor_max_step));
                for (j, gene) in space.genes.iter().enumerate() {
                    let x = child.values[j];
                    prop_assert!((gene.range.min..=gene.range.max).contains(&x));
                    // Some parent's gene maps onto the child's value under x*U(0.8,1.2)+U(-3,3)
                    // (before clipping, so a clipped value lies at the bound).
                    let reachable = parents.iter().any(|p| {
                        let v = p.values[j];
                        let (lo, hi) = (v.min(v * 0.8).min(v * 1.2) - 3.0, v.max(v * 0.8).max(v * 1.2) + 3.0);
                        (lo - 1e-6..=hi + 1e-6).contains(&x)
                            || (x == gene.range.min && lo <= gene.range.min)
                            || (x == gene.range.max && hi >= gene.range.max)
                    });
                    prop_assert!(reachable, "gene {} = {} not reachable from a parent", gene.name, x);
                }
            }
        }

        #[test]
        fn crossover_takes_every_gene_from_a_parent(seed in 0u64..500) {
            let (space, _) = space();
            let mut rng = stream(seed, "test/x");
            let (a, b) = (space.random(&mut rng), space.random(&mut rng));
            let c = crossover(&a, &b, &mut rng);
            prop_assert!(c.sensor == a.sensor || c.sensor == b.sensor);
            for j in 0..c.values.len() {
                prop_assert!(c.values[j] == a.values[j] || c.values[j] == b.values[j]);
            }
        }

        #[test]
        fn mutation_is_clipped_and_sensor_steps_are_bounded(seed in 0u64..500, extreme in any::<bool>()) {
            let (space, ga) = space();
            let mut rng = stream(seed, "test/m");
            let mut g = space.random(&mut rng);
            if extreme {
                // At the bounds, mutation pushes outside: clipping must hold it.
                g.sensor = if seed % 2 == 0 { 0 } else { space.sensors.len() - 1 };
                g.values = space.genes.iter().map(|gene| if seed % 2 == 0 { gene.range.min } else { gene.range.max }).collect();
            }
            let m = mutate(&space, &ga, &g, &mut rng);
            prop_assert!(m.sensor.abs_diff(g.sensor) <= 3);
            prop_assert!(m.sensor < space.sensors.len());
            for (gene, &x) in space.genes.iter().zip(&m.values) {
                prop_assert!((gene.range.min..=gene.range.max).contains(&x), "{} {}", gene.name, x);
            }
        }
    }

    #[test]
    fn mutation_moves_the_sensor_by_every_step_up_to_three() {
        let (space, ga) = space();
        let mut rng = stream(9, "test/steps");
        let mut g = space.random(&mut rng);
        g.sensor = 20;
        let mut seen = std::collections::BTreeSet::new();
        for _ in 0..500 {
            seen.insert(mutate(&space, &ga, &g, &mut rng).sensor as i64 - 20);
        }
        assert_eq!(seen.into_iter().collect::<Vec<_>>(), vec![-3, -2, -1, 0, 1, 2, 3]);
    }
}
