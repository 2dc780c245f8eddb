//! Uniform random search, the GA's baseline at equal budget.
//!
//! It shares the GA's generation 0 (same stream, same draws: common random numbers make the
//! comparison less noisy) and then draws, per generation, as many new candidates as the GA
//! evaluates (its offspring), so after every generation both methods have spent the same
//! number of evaluations.

use super::config::OptimizeConfig;
use super::ga::Origin;
use super::genes::{Genome, Space};
use scene_gen_core::rng::{stream, substream};

/// Candidates evaluated in generation `generation` (GA and random search alike).
#[must_use]
pub fn batch_size(config: &OptimizeConfig, generation: usize) -> usize {
    if generation == 0 { config.ga.population } else { config.ga.population - config.ga.elites }
}

/// Generation 0, drawn uniformly from the optimizer seed (shared by both methods).
#[must_use]
pub fn initial(space: &Space, config: &OptimizeConfig) -> Vec<(Genome, Origin)> {
    let mut rng = stream(config.seed, "optimize/initial");
    (0..config.ga.population).map(|_| (space.random(&mut rng), Origin::Initial)).collect()
}

/// Generation `generation` of random search: generation 0 as the GA's, later ones fresh
/// uniform draws, [`batch_size`] of them.
#[must_use]
pub fn generation(space: &Space, config: &OptimizeConfig, generation: usize) -> Vec<(Genome, Origin)> {
    if generation == 0 {
        return initial(space, config);
    }
    let mut rng = substream(config.seed, "optimize/random", generation as u64);
    (0..batch_size(config, generation)).map(|_| (space.random(&mut rng), Origin::Random)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene_gen_camera::sensor::Catalog;

    #[test]
    fn random_search_spends_the_ga_budget() {
        let config = OptimizeConfig::default();
        let space = Space::new(&config, &Catalog::embedded());
        let total: usize = (0..config.ga.generations).map(|g| generation(&space, &config, g).len()).sum();
        assert_eq!(total, config.budget());
        assert_eq!(generation(&space, &config, 0), initial(&space, &config));
        assert_ne!(generation(&space, &config, 1), generation(&space, &config, 2));
    }
}
