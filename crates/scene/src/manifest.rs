//! The manifest `scene.json`: the semantic view of a [`Scene`] as the contract of docs/CONTRACTS.md
//! defines it. Other programs read this file; change its shape only with a schema bump.

use serde::{Deserialize, Serialize};

use crate::scene::{
    Door, Envelope, Furnishing, HouseRecord, Light, MANIFEST_SCHEMA, Object, Room, Scene, Threshold, Wall, Window,
};

/// `scene.json`, field for field.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub schema: String,
    pub seed: u64,
    pub generator_version: String,
    pub envelope: Envelope,
    pub wall_thickness_m: f32,
    /// The generator's options and libraries; absent in manifests written before it was
    /// recorded (readers then assume the defaults).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub house: Option<HouseRecord>,
    /// The house's colour palette ([`crate::palette::PALETTES`]); absent for scenes without
    /// one and in manifests written before palettes existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub palette: Option<String>,
    pub rooms: Vec<Room>,
    pub walls: Vec<Wall>,
    pub doors: Vec<Door>,
    pub windows: Vec<Window>,
    pub thresholds: Vec<Threshold>,
    pub objects: Vec<Object>,
    /// Non-target furniture; absent in manifests written before furnishings existed.
    #[serde(default)]
    pub furnishings: Vec<Furnishing>,
    pub lights: Vec<Light>,
}

impl Manifest {
    /// The manifest of `scene`.
    #[must_use]
    pub fn of(scene: &Scene) -> Manifest {
        Manifest {
            schema: MANIFEST_SCHEMA.to_string(),
            seed: scene.seed,
            generator_version: env!("CARGO_PKG_VERSION").to_string(),
            envelope: scene.envelope,
            wall_thickness_m: scene.wall_thickness_m,
            house: Some(scene.house.clone()),
            palette: scene.palette.map(|p| p.name.to_string()),
            rooms: scene.rooms.clone(),
            walls: scene.walls.clone(),
            doors: scene.doors.clone(),
            windows: scene.windows.clone(),
            thresholds: scene.thresholds.clone(),
            objects: scene.objects.clone(),
            furnishings: scene.furnishings.clone(),
            lights: scene.lights.clone(),
        }
    }

    /// Pretty JSON with a trailing newline.
    #[must_use]
    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("manifest serialises");
        s.push('\n');
        s
    }
}
