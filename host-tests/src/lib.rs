//! Shared helpers for the host tests: an independent fine-step reference integrator of the
//! same physics, and tolerance helpers.

pub mod catalogue;
pub mod records;
pub mod reference;
pub mod scenario;
