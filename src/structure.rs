//! Structural geometry: floors, ceilings, walls with their openings cut out, window panes and
//! the gold door thresholds.
//!
//! STUB: floors only; the floorplan work replaces this.

use glam::{Mat4, Vec2, Vec3};

use crate::config::GeneratorConfig;
use crate::floorplan::Floorplan;
use crate::materials::MaterialCatalog;
use crate::scene::{Geometry, Mesh, Node, Primitive, Semantic, Threshold};

/// Adds the structure's meshes and nodes to `geometry` and returns the thresholds, with
/// instance ids from 1.
pub fn build(
    _config: &GeneratorConfig,
    plan: &Floorplan,
    materials: &mut MaterialCatalog,
    geometry: &mut Geometry,
) -> Vec<Threshold> {
    for room in &plan.rooms {
        let material = materials.material(geometry, "wood_floor", 0).expect("known surface");
        let (a, b) = (room.min, room.max);
        let corners = [Vec2::new(a.x, a.y), Vec2::new(b.x, a.y), Vec2::new(b.x, b.y), Vec2::new(a.x, b.y)];
        geometry.meshes.push(Mesh {
            name: format!("floor_{}", room.id),
            primitives: vec![Primitive {
                positions: corners.iter().map(|c| c.extend(0.0)).collect(),
                normals: vec![Vec3::Z; 4],
                uvs: corners.to_vec(),
                indices: vec![0, 1, 2, 0, 2, 3],
                material,
            }],
        });
        geometry.nodes.push(Node {
            name: format!("floor_{}", room.id),
            mesh: geometry.meshes.len() - 1,
            transform: Mat4::IDENTITY,
            semantic: Semantic::Floor { room: room.id },
        });
    }
    Vec::new()
}
