//! The firmware-facing virtual actuator: plant, state, H-bridge and sensors in one value that
//! firmware owns (a `static` behind `cortex_m::Shared` with the `cortex-m` feature, or a local
//! in `main`).
//!
//! The control tick is: read [`VirtualActuator::readings`], write the bridge through
//! [`VirtualActuator::pwm`] / [`VirtualActuator::dir`] (or [`VirtualActuator::parts`] for all
//! handles at once), then [`VirtualActuator::step`] — which applies the latched voltage over one
//! sample period and samples the sensors at its end.
//!
//! ```
//! use embedded_hal::digital::OutputPin;
//! use embedded_hal::pwm::SetDutyCycle;
//! use geared_servo::{DriveConfig, Plant, SensorConfig, VirtualActuator, REFERENCE};
//!
//! let plant = Plant::new(&REFERENCE.with_backlash_deg(0.08))?;
//! let mut act = VirtualActuator::new(plant, &DriveConfig::REFERENCE, &SensorConfig::REFERENCE)?;
//! for _ in 0..100 {
//!     let parts = act.parts();
//!     let (mut pwm, mut dir) = (parts.pwm, parts.dir);
//!     let pot = parts.readings.pot_counts; // firmware logic reads only counts...
//!     let _ = dir.set_low(); // Infallible
//!     let _ = pwm.set_duty_cycle(if pot < 2100 { 250 } else { 0 }); // ...and writes the bridge
//!     act.step();
//! }
//! assert!(act.readings().pot_counts > 2047); // the fin moved positive from centre
//! # Ok::<(), geared_servo::ParamError>(())
//! ```

use crate::faults::ActuatorFaults;
use crate::hal::{Dir, Drive, DriveConfig, DutyError, Pwm};
use crate::sensors::{Physical, Readings, SensorConfig, Sensors};
use crate::{Outputs, ParamError, Plant, PlantState};

/// Plant + state + H-bridge + sensors; no heap. 2360 B on thumbv7em (of which [`Plant`]
/// 2132 B and [`PlantState`] 96 B; printed by the `fin_loop` example on target).
#[derive(Clone, Debug, PartialEq)]
pub struct VirtualActuator {
    plant: Plant,
    state: PlantState,
    drive: Drive,
    sensors: Sensors,
    outputs: Outputs,
    steps: u32,
    faults: ActuatorFaults,
}

/// Shows the step count, state, bridge and readings (the plant's matrices are left out).
#[cfg(feature = "defmt")]
impl defmt::Format for VirtualActuator {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "VirtualActuator {{ steps: {}, state: {}, drive: {}, readings: {} }}",
            self.steps,
            self.state,
            self.drive,
            self.sensors.readings()
        )
    }
}

/// Every firmware-facing handle of a [`VirtualActuator`] at once (disjoint borrows).
#[derive(Debug)]
pub struct Parts<'a> {
    /// PWM channel of the bridge.
    pub pwm: Pwm<'a>,
    /// Direction line of the bridge.
    pub dir: Dir<'a>,
    /// The latest sensor readings.
    pub readings: &'a Readings,
}

impl VirtualActuator {
    /// At rest ([`PlantState::REST`]), duty 0, sensors sampled once; configurations validated.
    pub fn new(
        plant: Plant,
        drive: &DriveConfig,
        sensors: &SensorConfig,
    ) -> Result<VirtualActuator, ParamError> {
        VirtualActuator::with_state(plant, PlantState::REST, drive, sensors)
    }

    /// As [`VirtualActuator::new`], starting from `state`.
    pub fn with_state(
        plant: Plant,
        state: PlantState,
        drive: &DriveConfig,
        sensors: &SensorConfig,
    ) -> Result<VirtualActuator, ParamError> {
        let outputs = plant.outputs(&state);
        Ok(VirtualActuator {
            drive: Drive::new(drive)?,
            sensors: Sensors::new(sensors, &outputs)?,
            plant,
            state,
            outputs,
            steps: 0,
            faults: ActuatorFaults::NONE,
        })
    }

    /// Applies the bridge's latched voltage for one sample period, then samples the sensors.
    /// Never fails, never allocates.
    #[inline]
    pub fn step(&mut self) -> &Readings {
        if self.faults == ActuatorFaults::NONE {
            self.outputs = self.plant.step(&mut self.state, self.drive.voltage_v());
            self.sensors.sample(&self.outputs);
        } else {
            let f = &self.faults;
            let v = match f.pwm_stuck {
                Some(duty) => self.drive.voltage_for_signed_duty(duty),
                None => self.drive.voltage_v(),
            };
            let bus = if f.bus_factor.is_finite() {
                f.bus_factor.clamp(0.0, crate::faults::MAX_BUS_FACTOR)
            } else {
                1.0
            };
            self.outputs = self
                .plant
                .step_with_faults(&mut self.state, v * bus, &f.plant);
            self.sensors.sample_faulty(&self.outputs, f);
        }
        self.steps = self.steps.wrapping_add(1);
        self.sensors.readings()
    }

    /// Puts `faults` in force from the next [`VirtualActuator::step`] on (see
    /// [`crate::scenario::Scenario`] for timed schedules). Any value is accepted: out-of-range
    /// numbers are clamped to their physical range when used.
    pub fn set_faults(&mut self, faults: &ActuatorFaults) {
        self.faults = *faults;
    }

    /// The faults in force.
    pub fn faults(&self) -> &ActuatorFaults {
        &self.faults
    }

    /// The latest sensor readings (what firmware may look at).
    #[inline]
    pub fn readings(&self) -> &Readings {
        self.sensors.readings()
    }

    /// The PWM channel handle.
    #[inline]
    pub fn pwm(&mut self) -> Pwm<'_> {
        self.drive.pwm()
    }

    /// The direction line handle.
    #[inline]
    pub fn dir(&mut self) -> Dir<'_> {
        self.drive.dir()
    }

    /// The physical values after the last step in Q16.16, as ideal sensors would give them
    /// to a fixed-point firmware (converted on each call, a few instructions per field).
    #[inline]
    pub fn physical(&self) -> Physical {
        Physical::from_outputs(&self.outputs)
    }

    /// PWM, direction and readings at once.
    #[inline]
    pub fn parts(&mut self) -> Parts<'_> {
        let (pwm, dir) = self.drive.split();
        Parts {
            pwm,
            dir,
            readings: self.sensors.readings(),
        }
    }

    /// Signed-duty mode, counts: see [`Drive::set_signed_duty`].
    #[inline]
    pub fn set_signed_duty(&mut self, duty: i32) -> Result<(), DutyError> {
        self.drive.set_signed_duty(duty)
    }

    /// The bridge (latched duty, direction, the voltage of the next step).
    pub fn drive(&self) -> &Drive {
        &self.drive
    }

    /// The sensor block (configuration and readings).
    pub fn sensors(&self) -> &Sensors {
        &self.sensors
    }

    /// The true plant outputs after the last step: for test benches and traces, not for
    /// the firmware under test.
    pub fn outputs(&self) -> &Outputs {
        &self.outputs
    }

    /// The plant state.
    pub fn state(&self) -> &PlantState {
        &self.state
    }

    /// The plant.
    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    /// Steps taken since construction (wrapping), steps.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Time since construction, s (steps × sample period; f32, so resolution degrades after
    /// hours).
    pub fn time_s(&self) -> f32 {
        self.steps as f32 * self.plant.sample_period_s()
    }
}
