//! Fault scenarios: a fixed-capacity schedule of timed events that the emulator plays back
//! deterministically, step by step, on the host and on the target alike.
//!
//! Build one in firmware with [`Scenario::push`] (or in a `const` with [`Scenario::new`] and
//! pushes at start-up); on the host `geared-servo simulate --scenario FILE.toml` reads one.
//! Each step, [`Scenario::advance`] fires the events due at that step, in the order they were
//! scheduled, and returns the faults in force.

use crate::faults::{ActuatorFaults, BrokenTooth, Jam, SensorFault, Winding};

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

/// Why an event could not be scheduled.
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
}

impl core::fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ScenarioError::Full => "more events than the scenario's capacity",
            ScenarioError::OutOfOrder => "events must be in step order",
            ScenarioError::Contradiction => "contradicts another event at the same step",
        })
    }
}

impl core::error::Error for ScenarioError {}

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

    /// Schedules `fault` from step `step` on. Events must come in step order; two events at
    /// the same step may not set the same fault to different values.
    pub fn push(&mut self, step: u32, fault: Fault) -> Result<(), ScenarioError> {
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
