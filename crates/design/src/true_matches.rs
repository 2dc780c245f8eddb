//! Which feature matches between two rendered frames the ground truth confirms.
//!
//! A tracker's RANSAC accepts any match that fits *some* epipolar geometry. Between two
//! frames of a camera moving forward, the epipolar lines of most points run through the
//! image nearly parallel, so a chance match between two unrelated corners lies within a few
//! pixels of its line about as often as the line's band covers the image: a noisy image
//! gives more keypoints, more chance matches and so more "inliers" (on the default camera,
//! more by night than by day). A renderer knows the truth instead: the anchor frame's depth
//! puts each keypoint in the world, and the successor's camera says where it must appear.
//! A match is *true* when its successor keypoint lies there, within the same tolerance the
//! RANSAC uses.
//!
//! What it cannot tell: between consecutive frames of a walk most of the scene moves less
//! than the tolerance (about 2 px at the image edge at 320 px), so a feature that stays on the
//! same pixels (a sensor's fixed pattern) is confirmed there too.

use scene_gen_perception::orb::{KeyPoint, Match};
use scene_gen_render::camera::Camera;

/// What the ground truth of a frame pair is: the anchor's camera and per-pixel depth
/// (metres along the optical axis, `f32::INFINITY` where nothing was hit) and the successor's
/// camera, at the resolution of the images the keypoints come from.
#[derive(Clone, Copy, Debug)]
pub struct PairTruth<'a> {
    pub anchor: &'a Camera,
    pub anchor_depth_m: &'a [f32],
    pub successor: &'a Camera,
}

impl PairTruth<'_> {
    /// Whether match `m` (indices into the `anchor` and `successor` keypoints) is true: its
    /// successor keypoint lies within `tolerance_px` (the evaluator passes its RANSAC
    /// threshold) of where the anchor keypoint's surface point images in the successor. A
    /// corner sits on an edge, often a depth edge, and its pixel may hold the far side's depth,
    /// so each of the 3 x 3 pixels round the keypoint is tried: the match is true when any of
    /// them confirms it.
    #[must_use]
    pub fn confirms(&self, m: Match, anchor: &[KeyPoint], successor: &[KeyPoint], tolerance_px: f32) -> bool {
        let (a, b) = (anchor[m.query as usize], successor[m.train as usize]);
        let (w, h) = (self.anchor.width_px as i64, self.anchor.height_px as i64);
        if self.anchor_depth_m.len() as i64 != w * h {
            return false;
        }
        // Keypoints are in OpenCV's convention (pixel i's centre at i); cameras put it at i + 0.5.
        let (ax, ay) = (a.x + 0.5, a.y + 0.5);
        let (bx, by) = (b.x + 0.5, b.y + 0.5);
        let (cx, cy) = (ax.floor() as i64, ay.floor() as i64);
        for y in (cy - 1)..=(cy + 1) {
            for x in (cx - 1)..=(cx + 1) {
                if x < 0 || y < 0 || x >= w || y >= h {
                    continue;
                }
                let depth_m = self.anchor_depth_m[(y * w + x) as usize];
                if !depth_m.is_finite() {
                    continue;
                }
                let world = self.anchor.point_at(ax, ay, depth_m);
                if let Some((u, v, _)) = self.successor.project(world)
                    && (u - bx).hypot(v - by) <= tolerance_px
                {
                    return true;
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn camera(x: f32) -> Camera {
        Camera {
            width_px: 64,
            height_px: 48,
            pixel_pitch_um: 10.0,
            focal_mm: 0.5,
            f_number: 2.0,
            position: Vec3::new(x, 0.0, 1.0),
            yaw_deg: 0.0,
            pitch_deg: 0.0,
            vignetting: false,
        }
    }

    fn keypoint(x: f32, y: f32) -> KeyPoint {
        KeyPoint { x, y, size: 31.0, angle_deg: 0.0, response: 1.0, octave: 0 }
    }

    /// A wall 2 m ahead, the camera stepping 0.2 m towards it: points move outwards from
    /// the image centre by the ratio of depths (2 / 1.8), and a keypoint matched to where its
    /// point went is true; one matched to where it stood, or to the mirror side, is not.
    #[test]
    fn a_match_is_true_where_the_moving_camera_sees_its_point() {
        let (a, b) = (camera(0.0), camera(0.2));
        let depth = vec![2.0f32; 64 * 48];
        let truth = PairTruth { anchor: &a, anchor_depth_m: &depth, successor: &b };
        // OpenCV coordinates: (42.5, 30.5) is 10.5 px right of and 6.5 px below the centre.
        let ka = keypoint(42.0, 30.0);
        let scale = 2.0 / 1.8;
        let moved = keypoint(32.0 + 10.5 * scale - 0.5, 24.0 + 6.5 * scale - 0.5);
        let stayed = keypoint(42.0, 30.0);
        let mirrored = keypoint(32.0 - 10.5 * scale - 0.5, 24.0 + 6.5 * scale - 0.5);
        let to = |train| Match { query: 0, train, distance: 0 };
        let successor = [moved, stayed, mirrored];
        let flags: Vec<bool> = (0..3).map(|i| truth.confirms(to(i), &[ka], &successor, 0.5)).collect();
        assert_eq!(flags, vec![true, false, false]);
        // Where nothing was hit, nothing is confirmed.
        let sky = vec![f32::INFINITY; 64 * 48];
        let blind = PairTruth { anchor: &a, anchor_depth_m: &sky, successor: &b };
        assert!(!blind.confirms(to(0), &[ka], &successor, 3.0));
    }
}
