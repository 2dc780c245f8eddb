//! Progress of long commands on stderr: a bar on a terminal, a plain line every few seconds
//! when stderr is a file or a pipe (a cluster job's log), nothing with `--quiet`.
//!
//! The plain line's period is 10 s, or `SCENE_GEN_PROGRESS_S` seconds when set (0: every
//! step, which the tests use). Progress goes to stderr only, so stdout stays the command's
//! result.

use std::io::IsTerminal as _;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

static QUIET: AtomicBool = AtomicBool::new(false);

/// Silences every progress report of this process (`--quiet`).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// Whether `--quiet` silenced progress reports.
pub fn is_quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// How often a plain progress line is written.
fn period() -> Duration {
    let seconds = std::env::var("SCENE_GEN_PROGRESS_S").ok().and_then(|v| v.parse::<f64>().ok());
    Duration::from_secs_f64(seconds.filter(|s| s.is_finite() && *s >= 0.0).unwrap_or(10.0))
}

/// One long job's progress: `done` of `total` units.
#[derive(Debug)]
pub struct Progress {
    mode: Mode,
}

#[derive(Debug)]
enum Mode {
    Quiet,
    Bar(ProgressBar),
    Lines(Mutex<Lines>),
}

#[derive(Debug)]
struct Lines {
    /// The command, e.g. `dataset`.
    what: &'static str,
    /// The unit counted, e.g. `frames`.
    unit: &'static str,
    done: u64,
    total: u64,
    message: String,
    start: Instant,
    last_line: Option<Instant>,
    period: Duration,
}

impl Lines {
    fn line(&self) -> String {
        let elapsed = self.start.elapsed().as_secs_f64();
        let mut line = format!("{}: {}/{} {}, {elapsed:.0} s", self.what, self.done, self.total, self.unit);
        if self.done > 0 && self.done < self.total {
            let left = elapsed * (self.total - self.done) as f64 / self.done as f64;
            line.push_str(&format!(", about {left:.0} s left"));
        }
        if !self.message.is_empty() {
            line.push_str(&format!("; {}", self.message));
        }
        line
    }

    /// Writes a line if the period has passed since the last one.
    fn tick(&mut self) {
        let now = Instant::now();
        if self.last_line.is_none_or(|t| now.duration_since(t) >= self.period) {
            self.last_line = Some(now);
            eprintln!("{}", self.line());
        }
    }
}

impl Progress {
    /// Progress of `what` over `total` units of `unit` (more may be added).
    pub fn new(what: &'static str, unit: &'static str, total: u64) -> Progress {
        let mode = if QUIET.load(Ordering::Relaxed) {
            Mode::Quiet
        } else if std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(total);
            let template = format!("{{bar:30}} {{pos}}/{{len}} {unit} [{{elapsed_precise}} < {{eta_precise}}] {{msg}}");
            bar.set_style(ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()));
            Mode::Bar(bar)
        } else {
            let start = Instant::now();
            let lines =
                Lines { what, unit, done: 0, total, message: String::new(), start, last_line: None, period: period() };
            Mode::Lines(Mutex::new(lines))
        };
        Progress { mode }
    }

    fn lines(&self) -> Option<std::sync::MutexGuard<'_, Lines>> {
        match &self.mode {
            Mode::Lines(lines) => Some(lines.lock().unwrap_or_else(std::sync::PoisonError::into_inner)),
            _ => None,
        }
    }

    /// `n` more units are planned.
    pub fn add_total(&self, n: u64) {
        if let Mode::Bar(bar) = &self.mode {
            bar.inc_length(n);
        }
        if let Some(mut lines) = self.lines() {
            lines.total += n;
        }
    }

    /// `n` more units are done.
    pub fn inc(&self, n: u64) {
        if let Mode::Bar(bar) = &self.mode {
            bar.inc(n);
        }
        if let Some(mut lines) = self.lines() {
            lines.done += n;
            lines.tick();
        }
    }

    /// Sets how many units are done (a resumed job starts part way).
    pub fn set_done(&self, done: u64) {
        if let Mode::Bar(bar) = &self.mode {
            bar.set_position(done);
        }
        if let Some(mut lines) = self.lines() {
            lines.done = done;
            lines.tick();
        }
    }

    /// A note shown after the count, e.g. the best fitness so far.
    pub fn set_message(&self, message: String) {
        if let Mode::Bar(bar) = &self.mode {
            bar.set_message(message.clone());
        }
        if let Some(mut lines) = self.lines() {
            lines.message = message;
        }
    }

    /// Ends the report: the bar is cleared; the plain form writes its last line.
    pub fn finish(&self) {
        if let Mode::Bar(bar) = &self.mode {
            bar.finish_and_clear();
        }
        if let Some(lines) = self.lines() {
            eprintln!("{}", lines.line());
        }
    }
}

/// The library's runs (`dataset`'s frames, `evaluate`'s poses) report here.
impl scene_gen::progress::Progress for Progress {
    fn planned(&self, units: u64) {
        self.add_total(units);
    }
    fn done(&self, _computed: bool) {
        self.inc(1);
    }
}

/// Runs `work`, a job without a count, reporting its elapsed time: a spinner on a terminal,
/// otherwise a plain line every period (at least every half second) and, when it succeeds, one
/// at the end (a failure speaks for itself).
pub fn activity<T: Send, E: Send>(what: &'static str, work: impl FnOnce() -> Result<T, E> + Send) -> Result<T, E> {
    if QUIET.load(Ordering::Relaxed) {
        return work();
    }
    if std::io::stderr().is_terminal() {
        let spinner = ProgressBar::new_spinner();
        spinner.set_message(format!("{what} [working]"));
        spinner.enable_steady_tick(Duration::from_millis(120));
        let result = work();
        spinner.finish_and_clear();
        return result;
    }
    let start = Instant::now();
    let period = period().max(Duration::from_millis(500));
    let (done, finished) = std::sync::mpsc::channel::<()>();
    let result = std::thread::scope(|scope| {
        scope.spawn(move || {
            while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) = finished.recv_timeout(period) {
                eprintln!("{what}: working, {:.0} s", start.elapsed().as_secs_f64());
            }
        });
        let result = work();
        let _ = done.send(());
        result
    });
    if result.is_ok() {
        eprintln!("{what}: done in {:.1} s", start.elapsed().as_secs_f64());
    }
    result
}
