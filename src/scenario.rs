//! Fault scenarios: a fixed-capacity schedule of timed events that the emulator plays back
//! deterministically, step by step, on the host and on the target alike.
//!
//! Build one in firmware with [`Scenario::push`] (or in a `const` with [`Scenario::new`] and
//! pushes at start-up); on the host `geared-servo simulate --scenario FILE.toml` reads one.
//! Each step, [`Scenario::advance`] fires the events due at that step, in the order they were
//! scheduled, and returns the faults in force.
//!
//! A scheduled fault's values are validated where it is scheduled ([`Fault::validate`]):
//! NaN, ±∞, a negative friction factor or wear, and magnitudes beyond the bounds in
//! [`crate::faults`] are refused with a [`ScenarioError`] naming the field, where the step
//! itself would only clamp them.

use crate::faults::{
    ActuatorFaults, BrokenTooth, Jam, SensorFault, Winding, MAX_BACKLASH_WEAR_DEG, MAX_BUS_FACTOR,
    MAX_FAULT_ANGLE_RAD, MAX_FRICTION_FACTOR, MAX_GAIN_DRIFT, MAX_LOAD_TORQUE_NM, MAX_LOST_LSBS,
    MAX_NOISE_PEAK_COUNTS,
};
use core::fmt;

/// Shape of an external torque on the load over time.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TorqueProfile {
    /// A step to `amplitude_nm` (N·m) that lasts until cleared (hinge-moment step).
    Step {
        /// Torque, N·m.
        amplitude_nm: f32,
    },
    /// A "1 − cos" gust: `amplitude_nm/2 · (1 − cos 2π t/T)` over `duration_steps` steps,
    /// then zero.
    Gust {
        /// Peak torque, N·m.
        amplitude_nm: f32,
        /// Duration T in steps.
        duration_steps: u32,
    },
}

impl TorqueProfile {
    /// Torque `k` steps after the profile started, N·m.
    pub fn at(&self, k: u32) -> f32 {
        match *self {
            TorqueProfile::Step { amplitude_nm } => amplitude_nm,
            TorqueProfile::Gust {
                amplitude_nm,
                duration_steps,
            } => {
                if k >= duration_steps || duration_steps == 0 {
                    0.0
                } else {
                    let ph = core::f32::consts::TAU * k as f32 / duration_steps as f32;
                    0.5 * amplitude_nm * (1.0 - crate::math::sin_cos(ph).1)
                }
            }
        }
    }
}

/// One fault to apply or clear.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Fault {
    /// External torque on the load with this profile; cleared by [`Fault::ClearLoadTorque`].
    LoadTorque(TorqueProfile),
    /// Remove the external torque.
    ClearLoadTorque,
    /// Jam the load (or free it with [`Jam::None`]).
    Jam(Jam),
    /// Backlash grown by wear, degrees (0 clears).
    BacklashWear(f32),
    /// Factor on both Coulomb frictions (1 clears).
    FrictionFactor(f32),
    /// A broken output-gear tooth (`None` clears).
    BrokenTooth(Option<BrokenTooth>),
    /// State of the winding ([`Winding::Normal`] clears).
    Winding(Winding),
    /// A fault of one sensor channel ([`SensorFault::None`] clears).
    Sensor(SensorChannel, SensorFault),
    /// Factor on the bridge's bus voltage (1 clears).
    BusSag(f32),
    /// The bridge applies this signed duty whatever is commanded (`None` clears).
    PwmStuck(Option<i32>),
}

/// Which sensor a [`Fault::Sensor`] affects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SensorChannel {
    /// Tachometer ADC.
    Tach,
    /// Load potentiometer ADC.
    Pot,
    /// Quadrature encoder.
    Encoder,
}

/// An event: `fault` takes effect from step `step` on (counted from 0, the first step).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Event {
    /// Step at which the fault takes effect.
    pub step: u32,
    /// What happens.
    pub fault: Fault,
}

/// Why an event could not be scheduled. The value variants carry the offending field as
/// `Variant.field` of [`Fault`] (`"BrokenTooth.torque_loss"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ScenarioError {
    /// The schedule holds its capacity of events already.
    Full,
    /// Events must be pushed in step order; this one is earlier than the last.
    OutOfOrder,
    /// The event contradicts another at the same step (e.g. an open and a shorted winding).
    Contradiction,
    /// A fault's value is NaN or infinite.
    NonFinite(&'static str),
    /// A fault's value is negative where only zero or a positive value is physical.
    Negative(&'static str),
    /// A fault's value is finite and signed correctly but beyond its physical range (the
    /// bounds in [`crate::faults`]).
    OutOfRange(&'static str),
}

impl ScenarioError {
    /// The offending field of a value error (`"FrictionFactor"`), `None` for the others.
    pub const fn field(&self) -> Option<&'static str> {
        match *self {
            ScenarioError::NonFinite(f)
            | ScenarioError::Negative(f)
            | ScenarioError::OutOfRange(f) => Some(f),
            ScenarioError::Full | ScenarioError::OutOfOrder | ScenarioError::Contradiction => None,
        }
    }
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ScenarioError::Full => f.write_str("more events than the scenario's capacity"),
            ScenarioError::OutOfOrder => f.write_str("events must be in step order"),
            ScenarioError::Contradiction => {
                f.write_str("contradicts another event at the same step")
            }
            ScenarioError::NonFinite(field) => write!(f, "{field}: must be a finite number"),
            ScenarioError::Negative(field) => write!(f, "{field}: must not be negative"),
            ScenarioError::OutOfRange(field) => {
                write!(f, "{field}: ")?;
                match field {
                    "LoadTorque.amplitude_nm" => {
                        write!(f, "must be within ±{MAX_LOAD_TORQUE_NM} N·m")
                    }
                    "LoadTorque.duration_steps" => f.write_str("must be at least one step"),
                    "Jam.AtAngle" | "BrokenTooth.angle_rad" => {
                        write!(f, "must be within ±{MAX_FAULT_ANGLE_RAD} rad")
                    }
                    "BacklashWear" => write!(f, "must be at most {MAX_BACKLASH_WEAR_DEG} degrees"),
                    "FrictionFactor" => write!(f, "must be at most {MAX_FRICTION_FACTOR}"),
                    "BrokenTooth.width_rad" => {
                        f.write_str("must be at most one revolution (2π rad)")
                    }
                    "BrokenTooth.torque_loss" => f.write_str("must be at most 1 (all the torque)"),
                    "Sensor.GainDrift" => write!(f, "must be within -1 and {MAX_GAIN_DRIFT}"),
                    "Sensor.NoiseBurst" => {
                        write!(f, "must be at most {MAX_NOISE_PEAK_COUNTS} counts")
                    }
                    "Sensor.LostLsbs" => write!(f, "must be at most {MAX_LOST_LSBS} bits"),
                    "BusSag" => write!(f, "must be at most {MAX_BUS_FACTOR}"),
                    _ => f.write_str("is outside its physical range"),
                }
            }
        }
    }
}

impl core::error::Error for ScenarioError {}

/// `x` within [lo, hi], finite; a negative value where `lo` is 0 is [`ScenarioError::Negative`].
fn check(x: f32, lo: f32, hi: f32, field: &'static str) -> Result<(), ScenarioError> {
    if !x.is_finite() {
        Err(ScenarioError::NonFinite(field))
    } else if x < 0.0 && lo == 0.0 {
        Err(ScenarioError::Negative(field))
    } else if x < lo || x > hi {
        Err(ScenarioError::OutOfRange(field))
    } else {
        Ok(())
    }
}

impl Fault {
    /// Whether every value of the fault is within its physical range (the bounds in
    /// [`crate::faults`]); the error names the first field that is not.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        let angle = MAX_FAULT_ANGLE_RAD;
        match *self {
            Fault::LoadTorque(TorqueProfile::Step { amplitude_nm }) => check(
                amplitude_nm,
                -MAX_LOAD_TORQUE_NM,
                MAX_LOAD_TORQUE_NM,
                "LoadTorque.amplitude_nm",
            ),
            Fault::LoadTorque(TorqueProfile::Gust {
                amplitude_nm,
                duration_steps,
            }) => {
                check(
                    amplitude_nm,
                    -MAX_LOAD_TORQUE_NM,
                    MAX_LOAD_TORQUE_NM,
                    "LoadTorque.amplitude_nm",
                )?;
                if duration_steps == 0 {
                    return Err(ScenarioError::OutOfRange("LoadTorque.duration_steps"));
                }
                Ok(())
            }
            Fault::Jam(Jam::AtAngle(a)) => check(a, -angle, angle, "Jam.AtAngle"),
            Fault::BacklashWear(w) => check(w, 0.0, MAX_BACKLASH_WEAR_DEG, "BacklashWear"),
            Fault::FrictionFactor(k) => check(k, 0.0, MAX_FRICTION_FACTOR, "FrictionFactor"),
            Fault::BrokenTooth(Some(t)) => {
                check(t.angle_rad, -angle, angle, "BrokenTooth.angle_rad")?;
                let tau = core::f32::consts::TAU;
                check(t.width_rad, 0.0, tau, "BrokenTooth.width_rad")?;
                check(t.torque_loss, 0.0, 1.0, "BrokenTooth.torque_loss")
            }
            Fault::Sensor(_, SensorFault::GainDrift(g)) => {
                check(g, -1.0, MAX_GAIN_DRIFT, "Sensor.GainDrift")
            }
            Fault::Sensor(_, SensorFault::NoiseBurst(p)) => {
                check(p, 0.0, MAX_NOISE_PEAK_COUNTS, "Sensor.NoiseBurst")
            }
            Fault::Sensor(_, SensorFault::LostLsbs(bits)) if bits > MAX_LOST_LSBS => {
                Err(ScenarioError::OutOfRange("Sensor.LostLsbs"))
            }
            Fault::BusSag(k) => check(k, 0.0, MAX_BUS_FACTOR, "BusSag"),
            Fault::ClearLoadTorque
            | Fault::Jam(_)
            | Fault::BrokenTooth(None)
            | Fault::Winding(_)
            | Fault::Sensor(..)
            | Fault::PwmStuck(_) => Ok(()),
        }
    }
}

/// A schedule of up to `N` events and the faults they have put in force.
#[derive(Clone, Debug)]
pub struct Scenario<const N: usize> {
    events: heapless::Vec<Event, N>,
    next: usize,
    faults: ActuatorFaults,
    torque: Option<(TorqueProfile, u32)>,
}

impl<const N: usize> Default for Scenario<N> {
    fn default() -> Self {
        Scenario::new()
    }
}

impl<const N: usize> Scenario<N> {
    /// An empty schedule (no fault ever).
    pub const fn new() -> Self {
        Scenario {
            events: heapless::Vec::new(),
            next: 0,
            faults: ActuatorFaults::NONE,
            torque: None,
        }
    }

    /// Schedules `fault` from step `step` on. Its values must be within their physical range
    /// ([`Fault::validate`]); events must come in step order; two events at the same step
    /// may not set the same fault to different values.
    pub fn push(&mut self, step: u32, fault: Fault) -> Result<(), ScenarioError> {
        fault.validate()?;
        if let Some(last) = self.events.last() {
            if step < last.step {
                return Err(ScenarioError::OutOfOrder);
            }
        }
        let same_kind = |a: &Fault, b: &Fault| match (a, b) {
            (Fault::Sensor(ca, _), Fault::Sensor(cb, _)) => ca == cb,
            _ => core::mem::discriminant(a) == core::mem::discriminant(b),
        };
        let clears_torque = |a: &Fault, b: &Fault| {
            matches!(
                (a, b),
                (Fault::LoadTorque(_), Fault::ClearLoadTorque)
                    | (Fault::ClearLoadTorque, Fault::LoadTorque(_))
            )
        };
        if self.events.iter().filter(|e| e.step == step).any(|e| {
            (same_kind(&e.fault, &fault) && e.fault != fault) || clears_torque(&e.fault, &fault)
        }) {
            return Err(ScenarioError::Contradiction);
        }
        self.events
            .push(Event { step, fault })
            .map_err(|_| ScenarioError::Full)
    }

    /// The scheduled events, in order.
    pub fn events(&self) -> &[Event] {
        &self.events
    }

    /// Back to step 0 with no fault in force; the schedule is kept.
    pub fn rewind(&mut self) {
        self.next = 0;
        self.faults = ActuatorFaults::NONE;
        self.torque = None;
    }

    /// Fires every event due at `step` (in order) and returns the faults in force for the
    /// step `step`. Call once per step with increasing steps; an event whose step was skipped
    /// fires at the next call.
    pub fn advance(&mut self, step: u32) -> &ActuatorFaults {
        while let Some(e) = self.events.get(self.next) {
            if e.step > step {
                break;
            }
            let e = *e;
            self.apply(e);
            self.next += 1;
        }
        if let Some((profile, start)) = self.torque {
            self.faults.plant.load_torque_nm = profile.at(step.saturating_sub(start));
        }
        &self.faults
    }

    /// Faults in force after the last [`Scenario::advance`].
    pub fn faults(&self) -> &ActuatorFaults {
        &self.faults
    }

    fn apply(&mut self, e: Event) {
        let a = &mut self.faults;
        let f = &mut a.plant;
        match e.fault {
            Fault::LoadTorque(p) => self.torque = Some((p, e.step)),
            Fault::ClearLoadTorque => {
                self.torque = None;
                f.load_torque_nm = 0.0;
            }
            Fault::Jam(j) => f.jam = j,
            Fault::BacklashWear(w) => f.extra_backlash_deg = w,
            Fault::FrictionFactor(k) => f.friction_factor = k,
            Fault::BrokenTooth(t) => f.broken_tooth = t,
            Fault::Winding(w) => f.winding = w,
            Fault::Sensor(SensorChannel::Tach, s) => a.tach = s,
            Fault::Sensor(SensorChannel::Pot, s) => a.pot = s,
            Fault::Sensor(SensorChannel::Encoder, s) => a.encoder = s,
            Fault::BusSag(k) => a.bus_factor = k,
            Fault::PwmStuck(d) => a.pwm_stuck = d,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_fire_at_their_step_in_order() {
        let mut s: Scenario<4> = Scenario::new();
        s.push(2, Fault::Jam(Jam::Here)).unwrap();
        s.push(2, Fault::FrictionFactor(2.0)).unwrap();
        s.push(5, Fault::Jam(Jam::None)).unwrap();
        assert_eq!(s.advance(0).plant.jam, Jam::None);
        assert_eq!(s.advance(1).plant.jam, Jam::None);
        let f = s.advance(2).plant;
        assert_eq!((f.jam, f.friction_factor), (Jam::Here, 2.0));
        assert_eq!(s.advance(4).plant.jam, Jam::Here);
        assert_eq!(s.advance(5).plant.jam, Jam::None);
        assert_eq!(s.advance(5).plant.friction_factor, 2.0);
    }

    #[test]
    fn misuse_is_an_error_not_a_panic() {
        let mut s: Scenario<2> = Scenario::new();
        s.push(3, Fault::Winding(Winding::Open)).unwrap();
        assert_eq!(
            s.push(3, Fault::Winding(Winding::Shorted)),
            Err(ScenarioError::Contradiction)
        );
        assert_eq!(
            s.push(1, Fault::Jam(Jam::Here)),
            Err(ScenarioError::OutOfOrder)
        );
        s.push(4, Fault::Jam(Jam::Here)).unwrap();
        assert_eq!(s.push(9, Fault::Jam(Jam::None)), Err(ScenarioError::Full));
    }

    #[test]
    fn meaningless_fault_values_are_refused_naming_the_field() {
        extern crate std;
        use std::string::ToString;
        let tooth = |angle_rad, width_rad, torque_loss| {
            Fault::BrokenTooth(Some(BrokenTooth {
                angle_rad,
                width_rad,
                torque_loss,
            }))
        };
        let cases = [
            (
                Fault::FrictionFactor(-1.7e9),
                "FrictionFactor: must not be negative",
            ),
            (
                Fault::FrictionFactor(1e9),
                "FrictionFactor: must be at most 1000",
            ),
            (
                Fault::BacklashWear(-0.1),
                "BacklashWear: must not be negative",
            ),
            (
                Fault::BacklashWear(f32::NAN),
                "BacklashWear: must be a finite number",
            ),
            (
                Fault::LoadTorque(TorqueProfile::Step {
                    amplitude_nm: -1.7e9,
                }),
                "LoadTorque.amplitude_nm: must be within ±1000000 N·m",
            ),
            (
                Fault::LoadTorque(TorqueProfile::Gust {
                    amplitude_nm: f32::INFINITY,
                    duration_steps: 4,
                }),
                "LoadTorque.amplitude_nm: must be a finite number",
            ),
            (
                Fault::LoadTorque(TorqueProfile::Gust {
                    amplitude_nm: 1.0,
                    duration_steps: 0,
                }),
                "LoadTorque.duration_steps: must be at least one step",
            ),
            (
                Fault::Jam(Jam::AtAngle(-1.7e9)),
                "Jam.AtAngle: must be within ±1000000 rad",
            ),
            (
                tooth(0.0, 0.1, 2.0),
                "BrokenTooth.torque_loss: must be at most 1",
            ),
            (
                tooth(0.0, -0.1, 0.5),
                "BrokenTooth.width_rad: must not be negative",
            ),
            (
                tooth(f32::NAN, 0.1, 0.5),
                "BrokenTooth.angle_rad: must be a finite number",
            ),
            (
                Fault::Sensor(SensorChannel::Tach, SensorFault::GainDrift(-2.0)),
                "Sensor.GainDrift: must be within -1 and 1000",
            ),
            (
                Fault::Sensor(SensorChannel::Pot, SensorFault::NoiseBurst(-1.0)),
                "Sensor.NoiseBurst: must not be negative",
            ),
            (
                Fault::Sensor(SensorChannel::Encoder, SensorFault::LostLsbs(40)),
                "Sensor.LostLsbs: must be at most 31 bits",
            ),
            (Fault::BusSag(11.0), "BusSag: must be at most 10"),
        ];
        for (fault, want) in cases {
            let mut s: Scenario<2> = Scenario::new();
            let e = s.push(1, fault).unwrap_err();
            let msg = e.to_string();
            assert!(msg.starts_with(want), "{fault:?}: `{msg}`");
            assert_eq!(e.field(), msg.split(':').next());
            assert!(s.events().is_empty());
        }
    }

    #[test]
    fn gust_rises_and_falls_back_to_zero() {
        let mut s: Scenario<2> = Scenario::new();
        s.push(
            10,
            Fault::LoadTorque(TorqueProfile::Gust {
                amplitude_nm: 2.0,
                duration_steps: 20,
            }),
        )
        .unwrap();
        assert_eq!(s.advance(9).plant.load_torque_nm, 0.0);
        assert_eq!(s.advance(10).plant.load_torque_nm, 0.0);
        assert!((s.advance(20).plant.load_torque_nm - 2.0).abs() < 1e-6);
        assert_eq!(s.advance(30).plant.load_torque_nm, 0.0);
    }
}
