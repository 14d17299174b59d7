//! Progress of long commands on stderr: a bar on a terminal, plain lines
//! when stderr is a file or a pipe (CI jobs, scripts, `2> log`), so that a
//! long silence there never looks like a hang.
//!
//! Plain mode prints a line when the stage (the message) changes and at
//! most one position line every [`PLAIN_INTERVAL`]; work that ends sooner
//! prints its stages only.
//!
//! ```ignore
//! let p = Progress::new(logs.len() as u64, "logs");
//! p.set_message("training");
//! for log in &logs { /* ... */ p.inc(1); }
//! p.finish();
//! ```

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// Least time between two plain position lines.
pub const PLAIN_INTERVAL: Duration = Duration::from_secs(5);

/// Progress of one piece of work counted in `unit`s (a length of 0 means
/// "not known yet": a spinner, or no count in plain lines).
pub struct Progress {
    kind: Kind,
}

enum Kind {
    Bar(ProgressBar),
    Plain(Mutex<Plain>),
    Hidden,
}

struct Plain {
    sink: Box<dyn Write + Send>,
    unit: String,
    interval: Duration,
    started: Instant,
    last_line: Instant,
    message: String,
    len: u64,
    pos: u64,
    printed: bool,
}

impl Progress {
    /// A bar on a terminal, plain lines otherwise.
    pub fn new(len: u64, unit: &str) -> Self {
        if std::io::stderr().is_terminal() {
            Self::bar(len, unit)
        } else {
            Self::plain(Box::new(std::io::stderr()), len, unit, PLAIN_INTERVAL)
        }
    }

    /// Shows nothing (work too short to be worth a line).
    pub fn hidden() -> Self {
        Self { kind: Kind::Hidden }
    }

    fn bar(len: u64, unit: &str) -> Self {
        // A total not known yet: a spinner until it is.
        let (bar, template) = if len == 0 {
            (
                ProgressBar::new_spinner(),
                format!("{{spinner}} {{msg}} [{{bar:30}}] {{pos}}/{{len}} {unit}"),
            )
        } else {
            (
                ProgressBar::new(len),
                format!("{{msg}} [{{bar:30}}] {{pos}}/{{len}} {unit} ({{eta}})"),
            )
        };
        bar.set_style(
            ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        Self {
            kind: Kind::Bar(bar),
        }
    }

    /// Plain lines into `sink`, a position line at most every `interval`.
    pub fn plain(sink: Box<dyn Write + Send>, len: u64, unit: &str, interval: Duration) -> Self {
        let now = Instant::now();
        Self {
            kind: Kind::Plain(Mutex::new(Plain {
                sink,
                unit: unit.to_string(),
                interval,
                started: now,
                last_line: now,
                message: String::new(),
                len,
                pos: 0,
                printed: false,
            })),
        }
    }

    fn with_plain(&self, f: impl FnOnce(&mut Plain)) {
        if let Kind::Plain(p) = &self.kind {
            if let Ok(mut p) = p.lock() {
                f(&mut p);
            }
        }
    }

    /// The stage in progress; plain mode prints a line when it changes.
    pub fn set_message(&self, message: impl Into<String>) {
        let message = message.into();
        match &self.kind {
            Kind::Bar(b) => b.set_message(message),
            Kind::Plain(_) => self.with_plain(|p| {
                if p.message != message {
                    p.message = message;
                    p.stage_line();
                }
            }),
            Kind::Hidden => {}
        }
    }

    /// The total, when it becomes known.
    pub fn set_length(&self, len: u64) {
        match &self.kind {
            Kind::Bar(b) => b.set_length(len),
            Kind::Plain(_) => self.with_plain(|p| p.len = len),
            Kind::Hidden => {}
        }
    }

    /// `pos` units done.
    pub fn set_position(&self, pos: u64) {
        match &self.kind {
            Kind::Bar(b) => b.set_position(pos),
            Kind::Plain(_) => self.with_plain(|p| {
                p.pos = pos;
                p.maybe_line();
            }),
            Kind::Hidden => {}
        }
    }

    /// `n` more units done.
    pub fn inc(&self, n: u64) {
        match &self.kind {
            Kind::Bar(b) => b.inc(n),
            Kind::Plain(_) => self.with_plain(|p| {
                p.pos += n;
                p.maybe_line();
            }),
            Kind::Hidden => {}
        }
    }

    /// Clears the bar; plain mode closes with a "done" line when it printed
    /// any position line.
    pub fn finish(&self) {
        match &self.kind {
            Kind::Bar(b) => b.finish_and_clear(),
            Kind::Plain(_) => self.with_plain(|p| {
                if p.printed {
                    let secs = p.started.elapsed().as_secs_f64();
                    let line = format!("{}: done in {secs:.1} s", p.label());
                    let _ = writeln!(p.sink, "{line}");
                }
            }),
            Kind::Hidden => {}
        }
    }
}

impl Plain {
    fn label(&self) -> &str {
        if self.message.is_empty() {
            "progress"
        } else {
            &self.message
        }
    }

    fn maybe_line(&mut self) {
        if self.last_line.elapsed() >= self.interval {
            self.line();
            self.printed = true;
        }
    }

    /// The stage alone, when it begins.
    fn stage_line(&mut self) {
        self.last_line = Instant::now();
        let line = self.label().to_string();
        let _ = writeln!(self.sink, "{line}");
    }

    /// The stage with the count done and the time since the start.
    fn line(&mut self) {
        self.last_line = Instant::now();
        let count = if self.len > 0 {
            format!(
                " {}/{} {} ({:.0} %)",
                self.pos,
                self.len,
                self.unit,
                100.0 * self.pos as f64 / self.len as f64
            )
        } else if self.pos > 0 {
            format!(" {} {}", self.pos, self.unit)
        } else {
            String::new()
        };
        let secs = self.started.elapsed().as_secs_f64();
        let line = format!("{}:{count} after {secs:.0} s", self.label());
        let _ = writeln!(self.sink, "{line}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    /// A sink the test can read back.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);

    impl Write for Shared {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Shared {
        fn lines(&self) -> Vec<String> {
            String::from_utf8(self.0.lock().unwrap().clone())
                .unwrap()
                .lines()
                .map(str::to_string)
                .collect()
        }
    }

    #[test]
    fn plain_lines_name_the_stage_and_the_count() {
        let out = Shared::default();
        let p = Progress::plain(Box::new(out.clone()), 4, "logs", Duration::ZERO);
        p.set_message("training");
        p.inc(1);
        p.set_position(4);
        p.finish();
        let lines = out.lines();
        assert_eq!(lines.len(), 4, "{lines:?}");
        assert_eq!(lines[0], "training");
        assert!(
            lines[1].starts_with("training: 1/4 logs (25 %)"),
            "{lines:?}"
        );
        assert!(
            lines[2].starts_with("training: 4/4 logs (100 %)"),
            "{lines:?}"
        );
        assert!(lines[3].starts_with("training: done in"), "{lines:?}");
    }

    #[test]
    fn plain_lines_are_rate_limited_but_stages_are_not() {
        let out = Shared::default();
        let p = Progress::plain(
            Box::new(out.clone()),
            1000,
            "rows",
            Duration::from_secs(3600),
        );
        p.set_message("segments");
        for i in 0..1000 {
            p.set_position(i);
        }
        p.set_message("fitting");
        p.finish();
        let lines = out.lines();
        assert_eq!(lines, ["segments", "fitting"]);
    }
}
