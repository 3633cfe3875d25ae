//! Progress for a person, shared by the long commands.

use indicatif::{ProgressBar, ProgressStyle};

/// Progress for a person: an indicatif bar on a terminal; without one (CI logs, cluster
/// jobs), where the bar would draw nothing, a plain line on stderr every tenth of the work or
/// every 30 s.
pub struct Progress {
    bar: ProgressBar,
    what: &'static str,
    plain: bool,
    started: std::time::Instant,
    last_line: std::time::Instant,
    last_tenth: u64,
}

impl Progress {
    /// A bar of `length` steps drawn with `template` (indicatif's default style if the
    /// template does not parse); `what` names the work in plain lines.
    pub fn new(length: u64, template: &str, what: &'static str) -> Self {
        use std::io::IsTerminal;
        let bar = ProgressBar::new(length);
        bar.set_style(
            ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        let now = std::time::Instant::now();
        Progress {
            bar,
            what,
            plain: !std::io::stderr().is_terminal(),
            started: now,
            last_line: now,
            last_tenth: 0,
        }
    }

    pub fn set_length(&self, length: u64) {
        self.bar.set_length(length);
    }

    /// Moves to `position` with `message` (built only when it is shown).
    pub fn update(&mut self, position: u64, message: impl FnOnce() -> String) {
        self.bar.set_position(position);
        if !self.plain {
            self.bar.set_message(message());
            return;
        }
        let length = self.bar.length().unwrap_or(0).max(1);
        let tenth = (10 * position / length).min(10);
        if tenth > self.last_tenth || self.last_line.elapsed().as_secs_f64() >= 30.0 {
            self.last_tenth = tenth;
            self.last_line = std::time::Instant::now();
            eprintln!(
                "{}: {} ({}%, {:.0} s wall)",
                self.what,
                message(),
                100 * position.min(length) / length,
                self.started.elapsed().as_secs_f64()
            );
        }
    }

    pub fn finish(&self) {
        self.end("done (100%, ")
    }

    /// Clears the bar and says the work stopped before its end.
    pub fn finish_interrupted(&self) {
        self.end("interrupted (")
    }

    fn end(&self, how: &str) {
        self.bar.finish_and_clear();
        if self.plain {
            eprintln!(
                "{}: {how}{:.0} s wall)",
                self.what,
                self.started.elapsed().as_secs_f64()
            );
        }
    }
}
