//! How library code reports progress: the CLI draws bars, tests stay silent.

/// Receives progress from long-running library code. Implementations must be cheap to call from
/// many threads; callers report in batches, not per item.
pub trait Progress: Sync {
    /// A new phase begins with `total` units of work (0 when unknown).
    fn start(&self, phase: &str, total: u64);
    /// `units` more units of the current phase are done.
    fn advance(&self, units: u64);
    /// The current phase is done.
    fn finish(&self);
    /// Live figures to show beside the bar (steps per second, broken bonds, energy).
    fn message(&self, _text: &str) {}
}

/// Ignores all progress.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _phase: &str, _total: u64) {}
    fn advance(&self, _units: u64) {}
    fn finish(&self) {}
}
