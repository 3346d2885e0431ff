//! Progress of long computations (sweeps, the paper's figures, a diagnosis), reported to
//! whatever the caller supplies: a progress bar in the command line, a callback in a
//! notebook, nothing; a sink may also ask a diagnosis to stop.

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
    /// The caller asks the computation to stop (an interrupt in a notebook). Checked after
    /// each reported stage by the computations that say so (`diagnose_with`), which then
    /// return an error ([`cancelled`]); false by default.
    fn cancelled(&self) -> bool {
        false
    }
}

/// The error of a computation stopped because its progress sink asked it to
/// ([`Progress::cancelled`]), after the stage `stage`.
pub fn cancelled(stage: &str) -> crate::HostError {
    crate::HostError::other(format!("cancelled by the caller after: {stage}"))
}

/// The silent sink.
impl Progress for () {}
