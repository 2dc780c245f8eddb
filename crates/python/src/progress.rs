//! Progress callbacks: a Python callable told `(done, planned)` after every unit of work.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use pyo3::prelude::*;
use scene_gen::progress::Progress;

/// Reports to an optional Python callable `callback(done, planned)`, from whichever thread
/// finished the unit (the GIL is taken for each report, and pending signals are handled). The first exception the callback raises
/// is kept, later reports are dropped, and [`Callback::finish`] raises it when the work returns.
#[derive(Debug)]
pub struct Callback {
    callback: Option<Py<PyAny>>,
    planned: AtomicU64,
    done: AtomicU64,
    error: Mutex<Option<PyErr>>,
}

impl Callback {
    /// A reporter to `callback` (none: nothing is reported), expecting `planned` units so far.
    pub fn new(callback: Option<Py<PyAny>>, planned: u64) -> Callback {
        Callback { callback, planned: AtomicU64::new(planned), done: AtomicU64::new(0), error: Mutex::new(None) }
    }

    /// Whether the callback has raised (the caller may stop early).
    pub fn failed(&self) -> bool {
        self.error.lock().map(|e| e.is_some()).unwrap_or(true)
    }

    /// The callback's exception, if it raised one.
    pub fn finish(self) -> PyResult<()> {
        match self.error.into_inner() {
            Ok(Some(e)) => Err(e),
            _ => Ok(()),
        }
    }
}

impl Progress for Callback {
    fn planned(&self, units: u64) {
        self.planned.fetch_add(units, Ordering::Relaxed);
    }

    fn done(&self, _computed: bool) {
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        if self.failed() {
            return;
        }
        let planned = self.planned.load(Ordering::Relaxed).max(done);
        // Ctrl-C arrives as a signal the interpreter handles only when asked (and only on its
        // main thread): ask at every unit, so an interrupt stops a render at the next frame.
        let result = Python::attach(|py| {
            py.check_signals()?;
            match &self.callback {
                Some(callback) => callback.call1(py, (done, planned)).map(drop),
                None => Ok(()),
            }
        });
        if let Err(e) = result {
            if let Ok(mut slot) = self.error.lock() {
                slot.get_or_insert(e);
            }
        }
    }
}
