//! A progress sink the library reports to, so that it never depends on a terminal UI.

/// Receives progress from long-running library calls (the CLI forwards it to indicatif).
pub trait Progress: Sync {
    /// Announces the total amount of work.
    fn set_total(&self, _total: u64) {}
    /// `n` more units are done.
    fn advance(&self, n: u64);
}

/// A sink that ignores everything.
pub struct NoProgress;

impl Progress for NoProgress {
    fn advance(&self, _n: u64) {}
}
