//! Day and night lights in physical units.
//!
//! STUB: replaced by the lights work (sun and sky through windows by day; ceiling lights and
//! lamp objects by night).

use crate::config::GeneratorConfig;
use crate::floorplan::Floorplan;
use crate::scene::{Light, Object};

/// Lights of both groups for a furnished floorplan.
#[must_use]
pub fn build(_config: &GeneratorConfig, _plan: &Floorplan, _objects: &[Object]) -> Vec<Light> {
    Vec::new()
}
