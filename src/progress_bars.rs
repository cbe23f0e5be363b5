//! Progress bars (indicatif) for the library's progress reports on a terminal, and the choice
//! between them and plain log lines ([`crate::progress_log`]) when stderr is a file or a pipe.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use shatter_core::Progress;

use crate::progress_log::LogLines;

/// Bars on a terminal, plain lines at least every `SHATTER_LOG_EVERY_S` (default 10 s) otherwise.
pub fn for_stderr() -> Box<dyn Progress> {
    if std::io::stderr().is_terminal() {
        Box::new(Bars::default())
    } else {
        Box::new(LogLines::new(crate::progress_log::interval_from_env()))
    }
}

/// Draws one bar per phase on stderr.
#[derive(Debug, Default)]
pub struct Bars {
    current: Mutex<Option<ProgressBar>>,
}

impl Bars {
    fn with_current(&self, f: impl FnOnce(&mut Option<ProgressBar>)) {
        // A panic elsewhere must not silence progress: take the bar even from a poisoned lock.
        let mut current = self.current.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        f(&mut current);
    }
}

impl Progress for Bars {
    fn start(&self, phase: &str, total: u64) {
        let bar = if total > 0 {
            ProgressBar::new(total).with_style(
                ProgressStyle::with_template(
                    "{prefix:>12} [{bar:40}] {human_pos}/{human_len} ({percent}%) {per_sec}, ETA {eta} {msg}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
            )
        } else {
            let bar = ProgressBar::new_spinner().with_style(
                ProgressStyle::with_template("{prefix:>12} {spinner} {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            bar.enable_steady_tick(Duration::from_millis(120));
            bar
        };
        bar.set_prefix(phase.to_string());
        self.with_current(|current| {
            if let Some(old) = current.replace(bar) {
                old.finish_and_clear();
            }
        });
    }

    fn advance(&self, units: u64) {
        self.with_current(|current| {
            if let Some(bar) = current {
                bar.inc(units);
            }
        });
    }

    fn message(&self, text: &str) {
        self.with_current(|current| {
            if let Some(bar) = current {
                bar.set_message(text.to_string());
            }
        });
    }

    fn finish(&self) {
        self.with_current(|current| {
            if let Some(bar) = current.take() {
                bar.finish_and_clear();
            }
        });
    }
}
