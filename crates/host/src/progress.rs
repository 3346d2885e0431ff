//! Progress of long computations (sweeps, the paper's figures), reported to whatever the
//! caller supplies: a progress bar in the command line, a callback in a notebook, nothing.

/// A sink for progress reports. Both methods do nothing by default, so `&()` is a silent
/// sink. Reports may arrive from several threads at once.
pub trait Progress: Sync {
    /// `n` more units of work (frequency points, figure cases) are done.
    fn advance(&self, n: u64) {
        let _ = n;
    }
    /// The computation entered the stage `name` (e.g. `"fig 3"`).
    fn stage(&self, name: &str) {
        let _ = name;
    }
}

/// The silent sink.
impl Progress for () {}
