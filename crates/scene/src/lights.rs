//! Day and night lights in physical units.
//!
//! * **Day**: the sun, a directional light at a seeded azimuth and elevation, and the sky, one
//!   rectangular Lambertian emitter filling each window opening and shining into its room.
//! * **Night**: one ceiling light per room and one bulb in every lamp object.
//!
//! The intensities here are nominal, sized by a simple point-source estimate so that each
//! scenario lands near its target mean illuminance on a horizontal plane at table height
//! (20 lux by day and 2 lux by night, the reference system's scenarios). The renderer measures
//! the real illuminance with shadows and inter-reflection and rescales each group exactly; the
//! ratios between lights of one group are what this module fixes.

use glam::{Vec2, Vec3};
use rand::Rng;

use crate::config::GeneratorConfig;
use crate::floorplan::Floorplan;
use crate::scene::{Light, LightGroup, LightKind, LightUnit, Object, ObjectClass};

/// Target mean illuminance on the table-height plane by day (TaCOS day scenario).
pub const DAY_TARGET_LUX: f32 = 20.0;
/// Target mean illuminance on the table-height plane by night (TaCOS night scenario).
pub const NIGHT_TARGET_LUX: f32 = 2.0;
/// Height of the plane the targets refer to (a table top).
pub const TARGET_PLANE_M: f32 = 0.75;

/// Sunlight on a surface facing the sun, relative to the sky's contribution. Clear-sky
/// daylight is roughly 4:1 direct to diffuse on a horizontal surface (CIE clear sky models).
const SUN_TO_SKY_RATIO: f32 = 4.0;
/// Correlated colour temperatures as linear-sRGB tints (max component 1).
const SUN_RGB: [f32; 3] = [1.0, 0.94, 0.86]; // ~5500 K
const SKY_RGB: [f32; 3] = [0.78, 0.86, 1.0]; // ~8000 K
const CEILING_RGB: [f32; 3] = [1.0, 0.86, 0.70]; // ~3500 K
const LAMP_RGB: [f32; 3] = [1.0, 0.78, 0.56]; // ~2700 K
/// A night lamp's share of a room's light relative to the ceiling light.
const LAMP_SHARE: f32 = 0.35;
/// Ceiling lights hang this far below the ceiling.
const CEILING_DROP_M: f32 = 0.1;

/// Lights of both groups for a furnished floorplan; ids are indices.
#[must_use]
pub fn build(config: &GeneratorConfig, plan: &Floorplan, objects: &[Object]) -> Vec<Light> {
    let mut lights = Vec::new();
    let mut push = |mut light: Light| {
        light.id = lights.len() as u32;
        lights.push(light);
    };
    day_lights(config, plan).into_iter().for_each(&mut push);
    night_lights(config, plan, objects).into_iter().for_each(&mut push);
    lights
}

fn day_lights(config: &GeneratorConfig, plan: &Floorplan) -> Vec<Light> {
    let mut rng = scene_gen_core::rng::stream(config.seed, "lights");
    let azimuth = rng.random_range(0.0..std::f32::consts::TAU);
    let elevation = rng.random_range(20f32..55.0).to_radians();
    let towards_sun = Vec3::new(azimuth.cos() * elevation.cos(), azimuth.sin() * elevation.cos(), elevation.sin());

    let mut lights = Vec::new();
    for window in &plan.windows {
        let Some(room) = plan.rooms.get(window.room as usize) else { continue };
        let area_m2 = window.width_m * window.height_m;
        // A Lambertian window of luminance L and area A, seen at distance d along its normal,
        // gives E = L A / d^2; size L so a window lights its room's mean distance to DAY target.
        let d_m = (room.size_m().x * room.size_m().y).sqrt() * 0.5;
        let windows_in_room = plan.windows.iter().filter(|w| w.room == window.room).count() as f32;
        let luminance_nit = DAY_TARGET_LUX * d_m * d_m / (area_m2 * windows_in_room * (1.0 + SUN_TO_SKY_RATIO));
        let inward = -window.normal.extend(0.0);
        let along_wall = Vec2::new(-window.normal.y, window.normal.x).extend(0.0);
        lights.push(Light {
            id: 0,
            group: LightGroup::Day,
            kind: LightKind::Rect,
            position: Some(window.center),
            direction: Some(inward),
            rect_u: Some(along_wall * window.width_m),
            rect_v: Some(Vec3::Z * window.height_m),
            intensity: luminance_nit,
            unit: LightUnit::Nit,
            color: SKY_RGB,
            room: Some(window.room),
            object: None,
        });
    }
    // The sun enters only through windows; its illuminance is what a surface facing it
    // receives, so it is sized against the sky term it complements.
    let sky_lux = DAY_TARGET_LUX / (1.0 + SUN_TO_SKY_RATIO);
    lights.push(Light {
        id: 0,
        group: LightGroup::Day,
        kind: LightKind::Directional,
        position: None,
        direction: Some(-towards_sun),
        rect_u: None,
        rect_v: None,
        intensity: sky_lux * SUN_TO_SKY_RATIO / elevation.sin().max(0.2),
        unit: LightUnit::Lux,
        color: SUN_RGB,
        room: None,
        object: None,
    });
    lights
}

fn night_lights(config: &GeneratorConfig, plan: &Floorplan, objects: &[Object]) -> Vec<Light> {
    let ceiling_z = config.envelope.height_m - CEILING_DROP_M;
    let drop_m = ceiling_z - TARGET_PLANE_M;
    let mut lights = Vec::new();
    for room in &plan.rooms {
        // A point source of intensity I at height h over a plane gives E = I h / r^3 at radial
        // distance r; averaging over a room of area A gives about I / (h^2 + A / (2 pi)).
        let area_m2 = room.size_m().x * room.size_m().y;
        let lamps: Vec<&Object> =
            objects.iter().filter(|o| o.class == ObjectClass::Lamp && o.room == room.id && o.on.is_none()).collect();
        let effective_r2 = drop_m * drop_m + area_m2 / std::f32::consts::TAU;
        let room_candela = NIGHT_TARGET_LUX * effective_r2;
        let lamp_total = if lamps.is_empty() { 0.0 } else { room_candela * LAMP_SHARE };
        lights.push(point(room.center().extend(ceiling_z), room_candela - lamp_total, CEILING_RGB, room.id, None));
        for lamp in &lamps {
            lights.push(point(lamp_bulb(lamp), lamp_total / lamps.len() as f32, LAMP_RGB, room.id, Some(lamp.id)));
        }
    }
    // Table lamps stand on other objects; they add light of their own.
    for lamp in objects.iter().filter(|o| o.class == ObjectClass::Lamp && o.on.is_some()) {
        let candela = NIGHT_TARGET_LUX * 0.5 * (lamp.max.z - TARGET_PLANE_M).max(0.5).powi(2);
        lights.push(point(lamp_bulb(lamp), candela, LAMP_RGB, lamp.room, Some(lamp.id)));
    }
    lights
}

/// Where the bulb of a lamp sits: centred, a fifth of its height below its top (inside the
/// shade for every lamp variant).
fn lamp_bulb(lamp: &Object) -> Vec3 {
    let center = (lamp.min + lamp.max) * 0.5;
    Vec3::new(center.x, center.y, lamp.max.z - 0.2 * (lamp.max.z - lamp.min.z))
}

fn point(position: Vec3, candela: f32, color: [f32; 3], room: u32, object: Option<u32>) -> Light {
    Light { color, room: Some(room), object, ..Light::point(LightGroup::Night, position, candela) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Room, Window};

    fn plan() -> Floorplan {
        Floorplan {
            rooms: vec![Room { id: 0, room_type: "bedroom".into(), min: Vec2::ZERO, max: Vec2::new(5.0, 6.0) }],
            windows: vec![Window {
                id: 0,
                room: 0,
                wall: 0,
                center: Vec3::new(2.5, 0.0, 1.5),
                width_m: 1.2,
                height_m: 1.2,
                normal: Vec2::new(0.0, -1.0),
            }],
            ..Floorplan::default()
        }
    }

    fn lamp(on: Option<u32>) -> Object {
        Object {
            id: 3,
            class: ObjectClass::Lamp,
            instance_id: 4,
            room: 0,
            asset: "lamp/floor".into(),
            min: Vec3::new(1.0, 1.0, 0.0),
            max: Vec3::new(1.4, 1.4, 1.6),
            yaw_deg: 0.0,
            on,
        }
    }

    #[test]
    fn every_room_is_lit_in_both_groups() {
        let lights = build(&GeneratorConfig::default(), &plan(), &[lamp(None)]);
        let day: Vec<_> = lights.iter().filter(|l| l.group == LightGroup::Day).collect();
        let night: Vec<_> = lights.iter().filter(|l| l.group == LightGroup::Night).collect();
        assert_eq!(day.len(), 2, "one sky window and the sun");
        assert_eq!(night.len(), 2, "one ceiling light and the lamp");
        assert!(lights.iter().enumerate().all(|(i, l)| l.id == i as u32));
        assert!(lights.iter().all(|l| l.intensity.is_finite() && l.intensity > 0.0));
        let sky = day.iter().find(|l| l.kind == LightKind::Rect).unwrap();
        assert_eq!(sky.direction, Some(Vec3::Y), "sky light shines into the room");
        let sun = day.iter().find(|l| l.kind == LightKind::Directional).unwrap();
        assert!(sun.direction.unwrap().z < 0.0, "the sun shines downwards");
        let bulb = night.iter().find(|l| l.object == Some(3)).unwrap();
        let p = bulb.position.unwrap();
        assert!(p.z > 1.0 && p.z < 1.6, "bulb inside the lamp, got {p}");
    }

    #[test]
    fn night_estimate_meets_target_below_a_ceiling_light() {
        // Directly under the ceiling light, without lamps, E = I / h^2 must exceed the mean
        // target (the mean over the room is lower than the peak).
        let lights = build(&GeneratorConfig::default(), &plan(), &[]);
        let ceiling = lights.iter().find(|l| l.group == LightGroup::Night).unwrap();
        let h = ceiling.position.unwrap().z - TARGET_PLANE_M;
        let peak_lux = ceiling.intensity / (h * h);
        assert!(peak_lux > NIGHT_TARGET_LUX && peak_lux < 4.0 * NIGHT_TARGET_LUX, "{peak_lux}");
    }
}
