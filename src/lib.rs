#![doc = include_str!("../README.md")]
#![cfg_attr(not(feature = "std"), no_std)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

pub mod analyser;
pub mod describing;
pub mod discretise;
pub mod error;
pub mod linear;
pub mod math;
pub mod params;
pub mod plant;
pub mod stiffness;

pub use analyser::{Analyser, AnalyserConfig, Harmonic, Hold, Measurement};
pub use error::ParamError;
pub use linear::{Complex, LinearModel};
pub use params::{
    ActuatorParams, Derived, Effects, GearTrain, LoadParams, MotorParams, Shaft, Stiffness,
    ToothGeometry, REFERENCE,
};
pub use plant::{Outputs, Plant, PlantState, SineDrive};

#[cfg(feature = "host")]
pub mod host;
