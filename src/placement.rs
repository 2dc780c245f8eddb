//! Furniture placement: picks each room's objects from its room type, sizes and places them by
//! their class's rule, collision-free and clear of doors.
//!
//! STUB: places nothing; the furniture work replaces this.

use crate::config::GeneratorConfig;
use crate::floorplan::Floorplan;
use crate::library::Library;
use crate::materials::MaterialCatalog;
use crate::scene::{Geometry, Object, Threshold};

/// Why furniture could not be placed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlacementError {
    #[error("{0}")]
    Library(String),
}

/// Places furniture in every room; object instance ids start at `first_instance_id`.
pub fn place(
    _config: &GeneratorConfig,
    _plan: &Floorplan,
    _thresholds: &[Threshold],
    _library: &Library,
    _first_instance_id: u32,
    _materials: &mut MaterialCatalog,
    _geometry: &mut Geometry,
) -> Result<Vec<Object>, PlacementError> {
    Ok(Vec::new())
}
