//! What a long run reports as it goes: units of work planned and done. `dataset` counts
//! frames, `evaluate` poses; the command line shows them as a bar or as plain lines.

/// A receiver of progress (a bar, a log line, or nothing: `()`).
pub trait Progress: Sync {
    /// `units` more units of work are planned.
    fn planned(&self, _units: u64) {}
    /// One unit is done (`computed` false: its result was already there, e.g. a frame's files).
    fn done(&self, _computed: bool) {}
}

impl Progress for () {}
