//! Progress as plain lines, for logs (stderr redirected to a file on a farm): a line when a phase
//! starts, at each frame (each message the stage sends), at least every interval while a phase
//! runs (a ticker thread, so that a long phase with no units of its own still shows it is
//! alive), and when it ends. Each line starts with the seconds since the command started, so a
//! wrangler can tell a hung job from a slow one:
//!
//! ```text
//! [   12.3 s] sim: 8400/24000 steps (35%), 702/s, ETA 22 s; frame 17/48, 355 broken bonds
//! ```

use std::sync::{Arc, Condvar, Mutex, MutexGuard, OnceLock};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use shatter_core::Progress;

/// The longest a running phase goes without a line, unless `SHATTER_LOG_EVERY_S` says otherwise.
pub const DEFAULT_INTERVAL: Duration = Duration::from_secs(10);

/// What the lines report.
#[derive(Debug)]
struct State {
    /// When the command started.
    origin: Instant,
    /// The running phase, if any: its name, units, units done, start and last message.
    phase: Option<Phase>,
    /// When the last line was printed.
    last_line: Instant,
    /// The last phase that finished, for the lines between phases.
    finished: Option<String>,
    /// Set when the ticker must stop.
    stopping: bool,
}

#[derive(Debug)]
struct Phase {
    name: String,
    total: u64,
    done: u64,
    started: Instant,
    message: String,
}

/// Plain progress lines on stderr.
#[derive(Debug)]
pub struct LogLines {
    shared: Arc<(Mutex<State>, Condvar)>,
    interval: Duration,
    ticker: Option<JoinHandle<()>>,
}

impl LogLines {
    /// Lines at least every `interval` while a phase runs.
    pub fn new(interval: Duration) -> LogLines {
        let now = Instant::now();
        let state = State { origin: origin(), phase: None, last_line: now, finished: None, stopping: false };
        let shared = Arc::new((Mutex::new(state), Condvar::new()));
        let ticker_shared = Arc::clone(&shared);
        let ticker =
            std::thread::Builder::new().name("progress-log".into()).spawn(move || tick(&ticker_shared, interval)).ok();
        LogLines { shared, interval, ticker }
    }

    fn state(&self) -> MutexGuard<'_, State> {
        lock(&self.shared.0)
    }
}

/// When the first stage of this command made its log: the zero of every line's time, so that a
/// `shatter run`'s stages count on from one another.
fn origin() -> Instant {
    static ORIGIN: OnceLock<Instant> = OnceLock::new();
    *ORIGIN.get_or_init(Instant::now)
}

/// The interval `SHATTER_LOG_EVERY_S` asks for (seconds, at least 0.05), else the default.
pub fn interval_from_env() -> Duration {
    std::env::var("SHATTER_LOG_EVERY_S")
        .ok()
        .and_then(|text| text.trim().parse::<f64>().ok())
        .filter(|seconds| seconds.is_finite() && *seconds >= 0.05 && *seconds <= 86_400.0)
        .map_or(DEFAULT_INTERVAL, Duration::from_secs_f64)
}

/// A poisoned lock still holds good figures: a panic elsewhere must not silence the log.
fn lock(state: &Mutex<State>) -> MutexGuard<'_, State> {
    state.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// The ticker: prints the running phase's line whenever `interval` passed without one.
fn tick(shared: &(Mutex<State>, Condvar), interval: Duration) {
    let (state, wake) = shared;
    let mut guard = lock(state);
    loop {
        if guard.stopping {
            return;
        }
        let since = guard.last_line.elapsed();
        if since >= interval {
            print_line(&mut guard);
            continue;
        }
        guard = match wake.wait_timeout(guard, interval - since) {
            Ok((guard, _)) => guard,
            Err(poisoned) => poisoned.into_inner().0,
        };
    }
}

/// Seconds as a log reads them: "42 s", "3m05s", "2h07m".
fn human(seconds: f64) -> String {
    let whole = seconds.round() as u64;
    match whole {
        0..=59 => format!("{whole} s"),
        60..=3599 => format!("{}m{:02}s", whole / 60, whole % 60),
        _ => format!("{}h{:02}m", whole / 3600, whole % 3600 / 60),
    }
}

/// Prints the running phase's line: units, percent, rate and ETA where it counts units, its
/// elapsed time where it does not, and its last message; between phases, that the command is
/// still working.
fn print_line(state: &mut State) {
    let Some(phase) = &state.phase else {
        let after = state.finished.as_deref().map_or(String::new(), |phase| format!(" (after {phase})"));
        eprintln!("[{:9.1} s] working{after}", state.origin.elapsed().as_secs_f64());
        state.last_line = Instant::now();
        return;
    };
    let elapsed = phase.started.elapsed().as_secs_f64();
    let mut line = format!("[{:9.1} s] {}: ", state.origin.elapsed().as_secs_f64(), phase.name);
    if phase.total > 0 {
        let rate = phase.done as f64 / elapsed.max(1e-9);
        let percent = 100.0 * phase.done as f64 / phase.total as f64;
        line.push_str(&format!("{}/{} ({percent:.0}%), {rate:.1}/s", phase.done, phase.total));
        if phase.done > 0 && phase.done < phase.total {
            line.push_str(&format!(", ETA {}", human((phase.total - phase.done) as f64 / rate)));
        }
    } else {
        line.push_str(&format!("running for {}", human(elapsed)));
    }
    if !phase.message.is_empty() {
        line.push_str("; ");
        line.push_str(&phase.message);
    }
    eprintln!("{line}");
    state.last_line = Instant::now();
}

impl Progress for LogLines {
    fn start(&self, phase: &str, total: u64) {
        let mut state = self.state();
        let now = Instant::now();
        state.phase = Some(Phase { name: phase.to_owned(), total, done: 0, started: now, message: String::new() });
        let units = if total > 0 { format!(" ({total} units)") } else { String::new() };
        eprintln!("[{:9.1} s] {phase}: started{units}", state.origin.elapsed().as_secs_f64());
        state.last_line = now;
    }

    fn advance(&self, units: u64) {
        let mut state = self.state();
        if let Some(phase) = &mut state.phase {
            phase.done += units;
        }
        if state.last_line.elapsed() >= self.interval {
            print_line(&mut state);
        }
    }

    fn message(&self, text: &str) {
        let mut state = self.state();
        if let Some(phase) = &mut state.phase {
            text.clone_into(&mut phase.message);
        }
        print_line(&mut state);
    }

    fn finish(&self) {
        let mut state = self.state();
        if let Some(phase) = state.phase.take() {
            let elapsed = human(phase.started.elapsed().as_secs_f64());
            eprintln!("[{:9.1} s] {}: done in {elapsed}", state.origin.elapsed().as_secs_f64(), phase.name);
            state.last_line = Instant::now();
            state.finished = Some(phase.name);
        }
    }
}

impl Drop for LogLines {
    fn drop(&mut self) {
        self.state().stopping = true;
        self.shared.1.notify_all();
        if let Some(ticker) = self.ticker.take() {
            let _ = ticker.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::human;

    #[test]
    fn durations_read_as_a_log_reads_them() {
        assert_eq!(human(4.4), "4 s");
        assert_eq!(human(185.0), "3m05s");
        assert_eq!(human(7620.0), "2h07m");
    }
}
