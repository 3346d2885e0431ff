//! Shared helpers for the host tests: an independent fine-step reference integrator of the
//! same physics, tolerance helpers, and the records of the foreign diagnosis suite.

#[cfg(feature = "host")]
pub mod catalogue;
#[cfg(feature = "host")]
pub mod cli;
#[cfg(feature = "host")]
pub mod foreign;
#[cfg(feature = "host")]
pub mod no_answer_catalogue;
pub mod records;
pub mod reference;
#[cfg(feature = "host")]
pub mod scenario;
