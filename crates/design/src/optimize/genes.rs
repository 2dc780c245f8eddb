//! Gene encoding: a [`Genome`] is a sensor index (into the catalog sorted by active area) and
//! the values of the enabled continuous genes; [`Space`] knows their ranges, draws, clips and
//! decodes genomes to [`CameraSpec`]s.

use rand::Rng;
use serde::{Deserialize, Serialize};

use super::config::{GeneRange, OptimizeConfig};
use scene_gen_camera::camera_spec::CameraSpec;
use scene_gen_camera::sensor::Catalog;

/// The neighbouring f32 above (`up`) or below `x` (finite `x`).
fn f32_step(x: f32, up: bool) -> f32 {
    if x == 0.0 {
        let tiny = f32::from_bits(1);
        return if up { tiny } else { -tiny };
    }
    let bits = x.to_bits();
    // Away from zero is +1 on the magnitude bits, whatever the sign.
    if (x > 0.0) == up { f32::from_bits(bits + 1) } else { f32::from_bits(bits - 1) }
}

/// One candidate's genes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Genome {
    /// Index into [`Space::sensors`] (area order).
    pub sensor: usize,
    /// Values of [`Space::genes`], in that order.
    pub values: Vec<f64>,
}

/// A continuous gene of the search.
#[derive(Clone, Debug, PartialEq)]
pub struct Gene {
    /// The camera-spec field it sets (`focal_mm`, `pitch_deg`, ...).
    pub name: &'static str,
    pub range: GeneRange,
}

impl Gene {
    /// Whether the spec field is single precision: its values are rounded to f32 so that the
    /// genome and the spec it decodes to hold the same number.
    fn is_f32(&self) -> bool {
        matches!(self.name, "focal_mm" | "pitch_deg" | "height_m")
    }

    /// Clips `x` to the range (and to the field's precision).
    #[must_use]
    pub fn clip(&self, x: f64) -> f64 {
        let x = if x.is_finite() { x.clamp(self.range.min, self.range.max) } else { self.range.min };
        if self.is_f32() {
            let r = f64::from(x as f32);
            // Rounding to f32 may step just outside the range; step back inside.
            if r < self.range.min {
                f64::from(f32_step(self.range.min as f32, true))
            } else if r > self.range.max {
                f64::from(f32_step(self.range.max as f32, false))
            } else {
                r
            }
        } else {
            x
        }
    }

    /// `x` as the CSV shows it: the shortest text that reads back to the same value.
    #[must_use]
    pub fn format(&self, x: f64) -> String {
        if self.is_f32() { format!("{}", x as f32) } else { format!("{x}") }
    }
}

/// The search space of one configuration.
#[derive(Clone, Debug)]
pub struct Space {
    /// Catalog model names sorted by active area (ties by name): the sensor gene's values.
    pub sensors: Vec<String>,
    /// Whether the sensor gene is searched; when not, every genome keeps `base_sensor`.
    pub sensor_enabled: bool,
    /// The index of the configured camera's sensor.
    pub base_sensor: usize,
    /// The enabled continuous genes, in the order of [`OptimizeConfig::gene_ranges`].
    pub genes: Vec<Gene>,
    /// The fixed part of every candidate.
    pub base: CameraSpec,
}

/// Catalog model names sorted by active area, ties broken by name.
#[must_use]
pub fn sensors_by_area(catalog: &Catalog) -> Vec<String> {
    let mut sensors: Vec<(f64, String)> = catalog.sensors().iter().map(|s| (s.area_mm2(), s.model.clone())).collect();
    sensors.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
    sensors.into_iter().map(|(_, m)| m).collect()
}

/// A uniform draw in `[lo, hi]` (`lo` when the interval is empty).
pub fn uniform<R: Rng + ?Sized>(rng: &mut R, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

impl Space {
    /// The space of `config` over `catalog`.
    ///
    /// # Panics
    /// Never for a validated configuration (its camera's sensor is in the catalog); an unknown
    /// sensor falls back to index 0.
    #[must_use]
    pub fn new(config: &OptimizeConfig, catalog: &Catalog) -> Space {
        let sensors = sensors_by_area(catalog);
        let base_model = catalog.get(&config.camera.sensor).map(|s| s.model.clone()).unwrap_or_default();
        let base_sensor = sensors.iter().position(|m| *m == base_model).unwrap_or(0);
        let genes = config
            .gene_ranges()
            .into_iter()
            .filter(|(_, r)| r.enabled)
            .map(|(name, range)| Gene { name, range })
            .collect();
        Space { sensors, sensor_enabled: config.genes.sensor.enabled, base_sensor, genes, base: config.camera.clone() }
    }

    /// A genome drawn uniformly: sensor over the catalog, each gene over its range.
    pub fn random<R: Rng + ?Sized>(&self, rng: &mut R) -> Genome {
        let sensor = if self.sensor_enabled { rng.random_range(0..self.sensors.len()) } else { self.base_sensor };
        let values = self.genes.iter().map(|g| g.clip(uniform(rng, g.range.min, g.range.max))).collect();
        Genome { sensor, values }
    }

    /// Clips every gene to its range and the sensor to the catalog.
    #[must_use]
    pub fn clip(&self, genome: &Genome) -> Genome {
        let sensor = if self.sensor_enabled { genome.sensor.min(self.sensors.len() - 1) } else { self.base_sensor };
        let values = self.genes.iter().zip(&genome.values).map(|(g, &x)| g.clip(x)).collect();
        Genome { sensor, values }
    }

    /// The camera spec of `genome`: the base camera with the genes written in.
    #[must_use]
    pub fn decode(&self, genome: &Genome) -> CameraSpec {
        let mut spec = self.base.clone();
        if self.sensor_enabled {
            spec.sensor.clone_from(&self.sensors[genome.sensor.min(self.sensors.len() - 1)]);
        }
        for (g, &x) in self.genes.iter().zip(&genome.values) {
            match g.name {
                "focal_mm" => spec.focal_mm = x as f32,
                "pitch_deg" => spec.pitch_deg = x as f32,
                "height_m" => spec.height_m = x as f32,
                "gain_day_db" => spec.gain_day_db = x,
                "gain_night_db" => spec.gain_night_db = x,
                "exposure_s" => spec.exposure_s = x,
                _ => {}
            }
        }
        spec
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene_gen_core::rng::stream;

    #[test]
    fn sensors_are_ordered_by_area() {
        let catalog = Catalog::embedded();
        let names = sensors_by_area(&catalog);
        assert_eq!(names.len(), catalog.len());
        let areas: Vec<f64> = names.iter().map(|n| catalog.get(n).unwrap().area_mm2()).collect();
        assert!(areas.windows(2).all(|w| w[0] <= w[1]), "{areas:?}");
    }

    #[test]
    fn random_genomes_lie_in_range_and_decode_to_valid_specs() {
        let mut config = OptimizeConfig::default();
        config.genes.height_m.enabled = true;
        config.genes.exposure_s.enabled = true;
        let catalog = Catalog::embedded();
        let space = Space::new(&config, &catalog);
        assert_eq!(
            space.genes.iter().map(|g| g.name).collect::<Vec<_>>(),
            ["focal_mm", "pitch_deg", "height_m", "exposure_s"]
        );
        let mut rng = stream(3, "test");
        for _ in 0..200 {
            let g = space.random(&mut rng);
            assert_eq!(space.clip(&g), g);
            for (gene, &x) in space.genes.iter().zip(&g.values) {
                assert!((gene.range.min..=gene.range.max).contains(&x), "{} {x}", gene.name);
            }
            let spec = space.decode(&g);
            spec.resolve(&catalog).unwrap();
            assert_eq!(f64::from(spec.focal_mm), g.values[0]);
        }
    }

    #[test]
    fn a_disabled_sensor_gene_keeps_the_base_sensor() {
        let mut config = OptimizeConfig::default();
        config.genes.sensor.enabled = false;
        let space = Space::new(&config, &Catalog::embedded());
        let g = space.random(&mut stream(1, "t"));
        assert_eq!(space.decode(&g).sensor, "IMX172");
    }
}
