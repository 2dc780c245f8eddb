//! Floorplans: the envelope split into rectangular rooms, room types assigned, walls, doors and
//! windows.
//!
//! STUB: one room filling the envelope; the floorplan work replaces this.

use glam::Vec2;

use crate::config::GeneratorConfig;
use crate::library::RoomType;
use crate::scene::{Door, Room, Wall, Window};

/// The rooms and openings of a house, before any geometry.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Floorplan {
    pub rooms: Vec<Room>,
    pub walls: Vec<Wall>,
    pub doors: Vec<Door>,
    pub windows: Vec<Window>,
}

/// Why no floorplan could be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FloorplanError {
    #[error("no room type can be assigned: {0}")]
    NoRoomType(String),
}

/// Builds the floorplan for `config`.
pub fn generate(config: &GeneratorConfig, room_types: &[RoomType]) -> Result<Floorplan, FloorplanError> {
    let room_type = room_types.first().ok_or_else(|| FloorplanError::NoRoomType("library is empty".into()))?;
    let e = config.envelope;
    Ok(Floorplan {
        rooms: vec![Room {
            id: 0,
            room_type: room_type.name.clone(),
            min: Vec2::ZERO,
            max: Vec2::new(e.width_m, e.depth_m),
        }],
        ..Floorplan::default()
    })
}
