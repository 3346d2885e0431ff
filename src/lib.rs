#![doc = include_str!("../docs/crate.md")]
#![no_std]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

#[cfg(test)]
extern crate std;

pub mod actuator;
pub mod analyser;
#[cfg(feature = "cortex-m")]
pub mod cortex_m;
pub mod describing;
pub mod discretise;
pub mod effects;
pub mod error;
pub mod faults;
pub mod hal;
pub mod linear;
pub mod math;
pub mod params;
pub mod plant;
pub mod scenario;
pub mod sensors;
pub mod stiffness;
pub mod trace;

pub use actuator::{Parts, VirtualActuator};
pub use analyser::{Analyser, AnalyserConfig, Harmonic, Hold, Measurement};
pub use effects::{Effect, Effects, UnknownEffect};
pub use error::ParamError;
pub use faults::{ActuatorFaults, BrokenTooth, Jam, PlantFaults, SensorFault, Winding};
pub use hal::{Drive, DriveConfig, DutyError};
pub use linear::{Complex, LinearModel};
pub use params::{
    ActuatorParams, Derived, GearTrain, LoadParams, MotorParams, Shaft, Stiffness, ToothGeometry,
    REFERENCE,
};
pub use plant::{Outputs, Plant, PlantState, SineDrive};
pub use sensors::{AdcChannel, EncoderConfig, EncoderShaft, Readings, SensorConfig};
