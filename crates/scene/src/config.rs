//! What the generator is asked for, checked before any work starts.

use crate::scene::Envelope;

/// Lowest ceiling the generator accepts: below this, doors of about 2 m do not fit under
/// the ceiling with a lintel.
pub const MIN_CEILING_M: f32 = 2.2;

/// Inputs to [`crate::generate::generate`] besides the libraries.
#[derive(Clone, Debug, PartialEq)]
pub struct GeneratorConfig {
    pub seed: u64,
    pub envelope: Envelope,
    /// Smallest room side, at wall centre lines.
    pub min_room_m: f32,
    pub wall_thickness_m: f32,
}

impl Default for GeneratorConfig {
    fn default() -> Self {
        GeneratorConfig { seed: 0, envelope: Envelope::default(), min_room_m: 5.0, wall_thickness_m: 0.1 }
    }
}

/// A request the generator cannot satisfy; names the offending value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    #[error("--envelope {width}x{depth}: each side must be at least --min-room {min_room} m")]
    EnvelopeTooSmall { width: f32, depth: f32, min_room: f32 },
    #[error("--envelope height {height} m is under the minimum ceiling height of {MIN_CEILING_M} m")]
    CeilingTooLow { height: f32 },
    #[error("--min-room {0} m is too small: rooms need at least 2.5 m to hold a door and furniture")]
    MinRoomTooSmall(f32),
    #[error("{field} = {value} must be a finite positive number")]
    NotPositive { field: &'static str, value: f32 },
    #[error("--envelope {width}x{depth}: at most 100 m on a side")]
    EnvelopeTooLarge { width: f32, depth: f32 },
}

impl GeneratorConfig {
    /// Checks that a house can be built from this request.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let e = self.envelope;
        for (field, value) in [
            ("envelope width", e.width_m),
            ("envelope depth", e.depth_m),
            ("envelope height", e.height_m),
            ("min-room", self.min_room_m),
            ("wall thickness", self.wall_thickness_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(ConfigError::NotPositive { field, value });
            }
        }
        if self.min_room_m < 2.5 {
            return Err(ConfigError::MinRoomTooSmall(self.min_room_m));
        }
        if e.width_m < self.min_room_m || e.depth_m < self.min_room_m {
            return Err(ConfigError::EnvelopeTooSmall {
                width: e.width_m,
                depth: e.depth_m,
                min_room: self.min_room_m,
            });
        }
        if e.width_m > 100.0 || e.depth_m > 100.0 {
            return Err(ConfigError::EnvelopeTooLarge { width: e.width_m, depth: e.depth_m });
        }
        if e.height_m < MIN_CEILING_M {
            return Err(ConfigError::CeilingTooLow { height: e.height_m });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_impossible_requests() {
        let ok = GeneratorConfig::default();
        assert!(ok.validate().is_ok());
        let narrow = GeneratorConfig { envelope: Envelope { width_m: 4.0, ..Envelope::default() }, ..ok.clone() };
        assert!(matches!(narrow.validate(), Err(ConfigError::EnvelopeTooSmall { .. })));
        let low = GeneratorConfig { envelope: Envelope { height_m: 2.1, ..Envelope::default() }, ..ok.clone() };
        assert!(matches!(low.validate(), Err(ConfigError::CeilingTooLow { .. })));
        let nan = GeneratorConfig { min_room_m: f32::NAN, ..ok };
        assert!(matches!(nan.validate(), Err(ConfigError::NotPositive { .. })));
    }
}
