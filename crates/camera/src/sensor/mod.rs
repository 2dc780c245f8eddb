//! Image sensors: the catalog ([`catalog`]) and the noise model that turns photons into digital
//! numbers ([`noise`]).
//!
//! ```
//! use scene_gen_camera::sensor::{Catalog, SensorModel};
//! let catalog = Catalog::embedded();
//! let imx174 = catalog.get("imx174").expect("in the catalog");
//! let model = SensorModel::from_sensor(imx174, 1);
//! let frame = model.simulate(&[1000.0; 16], 4, 4, 0.01, 0.0, 7);
//! assert_eq!(frame.len(), 16);
//! ```

pub mod catalog;
pub mod noise;

pub use catalog::{
    Catalog, CatalogError, Colour, FieldProvenance, Figure, FigureKind, NOISE_FIELDS, Sensor, SensorRecord, Shutter,
};
pub use noise::{AffineNoise, Effects, FixedPattern, ModelError, SensorModel};
