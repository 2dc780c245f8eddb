//! Threshold accuracy: did the camera see each threshold shortly before the agent crossed it?
//!
//! The reference system (docs/REFERENCE.md, "Tasks and score"): "a threshold counts as seen if it was on screen within
//! 0.5 s before the agent crossed it; accuracy = seen / (seen + missed)". "On screen" is made
//! concrete here as at least [`ThresholdConfig::min_visible_px`] visible pixels of the
//! threshold's instance in one frame whose time lies in `[t_cross - window_s, t_cross]`
//! (both ends included). Every crossing is scored on its own, so a threshold crossed twice
//! counts twice; thresholds never crossed are not counted at all.

use serde::{Deserialize, Serialize};

/// Window before a crossing in which a sighting counts (TaCOS: 0.5 s).
pub const DEFAULT_WINDOW_S: f64 = 0.5;

/// Default visible-pixel floor for "on screen": an engineering choice, roughly a 7 x 7 px
/// patch, enough for a detector to have anything to work with.
pub const DEFAULT_MIN_VISIBLE_PX: u32 = 50;

/// What counts as seeing a threshold.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThresholdConfig {
    pub window_s: f64,
    pub min_visible_px: u32,
}

impl Default for ThresholdConfig {
    fn default() -> Self {
        ThresholdConfig { window_s: DEFAULT_WINDOW_S, min_visible_px: DEFAULT_MIN_VISIBLE_PX }
    }
}

/// Visible pixels of threshold instances in one frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameVisibility {
    pub time_s: f64,
    /// `(threshold instance id, visible pixels)`; instances not listed have none.
    pub visible_px: Vec<(u32, u32)>,
}

/// The agent crossing a threshold at `time_s`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Crossing {
    pub instance_id: u32,
    pub time_s: f64,
}

/// Seen and missed crossings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ThresholdScore {
    pub seen: u32,
    pub missed: u32,
}

impl ThresholdScore {
    /// `seen / (seen + missed)`; `None` when nothing was crossed.
    #[must_use]
    pub fn accuracy(&self) -> Option<f64> {
        let n = self.seen + self.missed;
        (n > 0).then(|| f64::from(self.seen) / f64::from(n))
    }
}

/// Scores every crossing against the frames (in any order).
#[must_use]
pub fn threshold_score(frames: &[FrameVisibility], crossings: &[Crossing], config: &ThresholdConfig) -> ThresholdScore {
    let mut score = ThresholdScore::default();
    for c in crossings {
        let seen = frames.iter().any(|f| {
            f.time_s <= c.time_s
                && f.time_s >= c.time_s - config.window_s
                && f.visible_px.iter().any(|&(id, px)| id == c.instance_id && px >= config.min_visible_px)
        });
        if seen {
            score.seen += 1;
        } else {
            score.missed += 1;
        }
    }
    score
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(time_s: f64, visible: &[(u32, u32)]) -> FrameVisibility {
        FrameVisibility { time_s, visible_px: visible.to_vec() }
    }

    #[test]
    fn window_before_crossing() {
        let cfg = ThresholdConfig::default();
        // Threshold 7 is crossed at t = 10 s.
        let cross = [Crossing { instance_id: 7, time_s: 10.0 }];
        let early = [frame(9.4, &[(7, 500)]), frame(9.7, &[(8, 500)])];
        assert_eq!(threshold_score(&early, &cross, &cfg), ThresholdScore { seen: 0, missed: 1 }, "0.6 s before");
        let in_time = [frame(9.6, &[(7, 500)])];
        assert_eq!(threshold_score(&in_time, &cross, &cfg).seen, 1, "0.4 s before");
        let after = [frame(10.1, &[(7, 500)])];
        assert_eq!(threshold_score(&after, &cross, &cfg).seen, 0, "after the crossing does not count");
        let too_few = [frame(9.8, &[(7, 49)])];
        assert_eq!(threshold_score(&too_few, &cross, &cfg).seen, 0, "below the pixel floor");
        let enough = [frame(9.8, &[(7, 50)])];
        assert_eq!(threshold_score(&enough, &cross, &cfg).accuracy(), Some(1.0));
    }

    #[test]
    fn uncrossed_thresholds_do_not_count() {
        let cfg = ThresholdConfig::default();
        // Thresholds 1 and 2 are visible, only 2 is crossed (and seen), 3 is crossed unseen.
        let frames = [frame(1.0, &[(1, 900), (2, 900)]), frame(5.0, &[])];
        let crossings = [Crossing { instance_id: 2, time_s: 1.2 }, Crossing { instance_id: 3, time_s: 5.1 }];
        let s = threshold_score(&frames, &crossings, &cfg);
        assert_eq!(s, ThresholdScore { seen: 1, missed: 1 });
        assert_eq!(s.accuracy(), Some(0.5));
        assert_eq!(threshold_score(&frames, &[], &cfg).accuracy(), None);
    }
}
