//! Where a frame was seen from, in the form datasets carry: the intrinsic matrix `K` and the
//! camera-to-world pose, so that depth back-projects to points in the house.
//!
//! Conventions (stated once, used by `render`'s sidecars and `dataset`'s labels and COCO
//! entries): world Z up, metres; camera axes as OpenCV's, x right, y down, z forward (the
//! optical axis); pixel centres at integer coordinates, so the image centre is at
//! `(w/2 - 0.5, h/2 - 0.5)`. A depth pixel `(u, v)` holding z-depth `z` is the world point
//! `camera_to_world * [z (u - cx) / fx, z (v - cy) / fy, z, 1]`. The OpenGL form (x right,
//! y up, looking down -z) is `camera_to_world * diag(1, -1, -1, 1)`.

use serde::{Deserialize, Serialize};

use scene_gen_render::camera::Camera;

/// The intrinsics and pose of one view.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewGeometry {
    /// Intrinsic matrix, pixels: `[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`.
    #[serde(rename = "K")]
    pub k: [[f64; 3]; 3],
    /// Camera-to-world transform, row-major, OpenCV camera axes.
    pub camera_to_world: [[f64; 4]; 4],
}

impl ViewGeometry {
    /// The view of a pinhole camera, exactly as the renderer casts its rays.
    #[must_use]
    pub fn of(camera: &Camera) -> ViewGeometry {
        let focal_px = f64::from(camera.focal_mm) / (f64::from(camera.pixel_pitch_um) * 1e-3);
        let cx = f64::from(camera.width_px) * 0.5 - 0.5;
        let cy = f64::from(camera.height_px) * 0.5 - 0.5;
        let (forward, right, up) = camera.basis();
        // Columns: the camera's x (right), y (down) and z (forward) axes, then its centre.
        let columns = [right, -up, forward, camera.position];
        let mut camera_to_world = [[0.0; 4]; 4];
        for (c, v) in columns.iter().enumerate() {
            for (r, value) in v.to_array().into_iter().enumerate() {
                camera_to_world[r][c] = f64::from(value);
            }
        }
        camera_to_world[3][3] = 1.0;
        ViewGeometry { k: [[focal_px, 0.0, cx], [0.0, focal_px, cy], [0.0, 0.0, 1.0]], camera_to_world }
    }

    /// The world point of pixel `(u, v)` at z-depth `depth_m`.
    #[must_use]
    pub fn back_project(&self, u: f64, v: f64, depth_m: f64) -> [f64; 3] {
        let cam = [(u - self.k[0][2]) / self.k[0][0] * depth_m, (v - self.k[1][2]) / self.k[1][1] * depth_m, depth_m];
        let m = &self.camera_to_world;
        std::array::from_fn(|r| m[r][0] * cam[0] + m[r][1] * cam[1] + m[r][2] * cam[2] + m[r][3])
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn camera() -> Camera {
        Camera {
            width_px: 64,
            height_px: 48,
            pixel_pitch_um: 5.86,
            focal_mm: 4.0,
            f_number: 2.0,
            position: Vec3::new(1.0, 2.0, 0.8),
            yaw_deg: 30.0,
            pitch_deg: -10.0,
            vignetting: false,
        }
    }

    /// Back-projecting a pixel centre at depth z lands on the renderer's ray through that
    /// centre, z along the optical axis from the camera.
    #[test]
    fn back_projection_follows_the_renderers_rays() {
        let camera = camera();
        let view = ViewGeometry::of(&camera);
        let (forward, _, _) = camera.basis();
        for (x, y) in [(0u32, 0u32), (63, 0), (31, 23), (10, 40), (63, 47)] {
            let dir = camera.ray_direction(x as f32 + 0.5, y as f32 + 0.5);
            let depth = 2.5;
            // The renderer's point at z-depth 2.5: along its ray until 2.5 m along the axis.
            let want = camera.position + dir * (depth / dir.dot(forward));
            let got = view.back_project(f64::from(x), f64::from(y), f64::from(depth));
            for i in 0..3 {
                assert!((got[i] - f64::from(want[i])).abs() < 1e-5, "pixel ({x}, {y}): {got:?} vs {want}");
            }
        }
    }

    /// The pose's rotation is orthonormal with determinant +1 and its translation is the
    /// camera centre.
    #[test]
    fn pose_is_a_rigid_transform() {
        let view = ViewGeometry::of(&camera());
        let m = view.camera_to_world;
        let col = |c: usize| [m[0][c], m[1][c], m[2][c]];
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        for a in 0..3 {
            for b in 0..3 {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((dot(col(a), col(b)) - want).abs() < 1e-6);
            }
        }
        let (x, y, z) = (col(0), col(1), col(2));
        let cross = [x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]];
        assert!(dot(cross, z) > 0.999_999, "right-handed");
        assert_eq!([m[0][3], m[1][3], m[2][3], m[3][3]], [1.0, 2.0, f64::from(0.8f32), 1.0]);
        assert_eq!(view.k[0][2], 31.5);
        assert_eq!(view.k[1][2], 23.5);
    }
}
