//! Progress of a terrain command on stderr: a bar on a terminal, a line
//! now and then elsewhere.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// Progress on stderr: a bar on a terminal; elsewhere (logs, CI) one line
/// `what: done/total (elapsed)` at most every TERRASLIP_PROGRESS_SECS
/// seconds (10 by default) and at the end of a step that took that long;
/// nothing when `quiet`.
pub(super) struct Progress {
    bar: Option<ProgressBar>,
    what: &'static str,
    n: u64,
    done: u64,
    plain: bool,
    every: Duration,
    start: Instant,
    last: Instant,
}

impl Progress {
    pub(super) fn new(n: u64, what: &'static str, quiet: bool) -> Self {
        let plain = !quiet && !std::io::stderr().is_terminal();
        let bar = (!quiet && !plain).then(|| {
            let bar = ProgressBar::new(n);
            bar.set_style(
                ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_message(what);
            bar
        });
        let every = std::env::var("TERRASLIP_PROGRESS_SECS")
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v >= 0.0)
            .map_or(Duration::from_secs(10), Duration::from_secs_f64);
        let now = Instant::now();
        Self {
            bar,
            what,
            n,
            done: 0,
            plain,
            every,
            start: now,
            last: now,
        }
    }

    pub(super) fn set(&mut self, done: u64) {
        self.done = done;
        if let Some(bar) = &self.bar {
            bar.set_position(done);
        } else if self.plain && self.last.elapsed() >= self.every {
            self.last = Instant::now();
            eprintln!(
                "{}: {done}/{} ({:.0} s)",
                self.what,
                self.n,
                self.start.elapsed().as_secs_f64()
            );
        }
    }

    pub(super) fn inc(&mut self) {
        self.set(self.done + 1);
    }

    pub(super) fn finish(self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
