//! The fin position loop shared by the `fin_loop` example (host and Cortex-M4F) and the host
//! test that compares its figures with `examples/expected/fin_loop.txt`.
//!
//! The controller is firmware: it sees the actuator only through `embedded_hal` traits (PWM +
//! direction line) and the emulated sensors' counts. The test bench around it (reference
//! generator, figures of merit) uses the true load angle.

use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;
use geared_servo::trace::{Trace, TraceSample};
use geared_servo::{
    math, DriveConfig, Plant, PlantState, Readings, SensorConfig, VirtualActuator, REFERENCE,
};

/// Backlash of the emulated actuator, degrees at the load.
pub const BACKLASH_DEG: f64 = 0.08;
/// Step command, degrees.
pub const STEP_DEG: f32 = 5.0;
/// Sine command: amplitude (degrees) about the step level, frequency (Hz).
pub const SINE_AMPLITUDE_DEG: f32 = 1.0;
/// Sine frequency, Hz.
pub const SINE_HZ: f32 = 20.0;
/// Steps of each phase at 2 kHz: 0.25 s of step response, then 0.25 s (5 periods) of sine.
pub const PHASE_STEPS: u32 = 500;

/// Acceptance bounds: a fin servo spec, not fitted to this run.
pub const MAX_RISE_MS: f32 = 25.0;
/// Overshoot bound, % of the step.
pub const MAX_OVERSHOOT_PCT: f32 = 10.0;
/// Steady-state error bound, degrees (two potentiometer counts: 0.059°).
pub const MAX_SS_ERROR_DEG: f32 = 0.06;
/// RMS tracking error bound over the last 4 sine periods, degrees (10 % of the amplitude).
pub const MAX_TRACKING_RMS_DEG: f32 = 0.2;

/// Position loop on the potentiometer with tachometer velocity feedback and velocity /
/// acceleration feed-forward, in volts, converted to duty + direction.
pub struct FinController {
    sensors: SensorConfig,
    bus_voltage_v: f32,
    /// Tachometer gain, V·s/rad of motor speed.
    tach_v_s_per_rad: f32,
    ratio: f32,
    /// V per rad of load-angle error.
    kp: f32,
    /// V per rad/s of load-speed error.
    kv: f32,
    /// Mechanical time constant of the motor + reflected load, s (acceleration feed-forward).
    tau_m: f32,
    /// Back-EMF at the load, V per rad/s of load speed (velocity feed-forward).
    kb_load: f32,
    /// Load acceleration the controller plans with, rad/s².
    accel_limit: f32,
}

impl FinController {
    /// Gains from the actuator's nominal data (the datasheet a firmware engineer would use):
    /// the speed-loop plant is `1 / (kb_load · (τm s + 1))` rad/s per V; the loop is placed at
    /// ωn = 2π·40 Hz, ζ = 0.7.
    pub fn new(sensors: SensorConfig, drive: &DriveConfig) -> FinController {
        let m = &REFERENCE.motor;
        let ratio = 50.0f32;
        let kb = m.back_emf_v_s_per_rad as f32;
        let kt = m.torque_constant_nm_per_a as f32;
        let r = m.resistance_ohm as f32;
        let j_eq = m.inertia_kg_m2 as f32 + REFERENCE.load.inertia_kg_m2 as f32 / (ratio * ratio);
        let tau_m = j_eq * r / (kt * kb);
        let kb_load = kb * ratio;
        let wn = 2.0 * core::f32::consts::PI * 40.0;
        let zeta = 0.7;
        // Closed loop: kb_load τm s² + (kb_load + kv) s + kp.
        let kp = kb_load * tau_m * wn * wn;
        let kv = kb_load * (2.0 * zeta * wn * tau_m - 1.0);
        // 60 % of the stall acceleration on the bus, a margin for friction and back-EMF.
        let accel_limit = 0.6 * drive.bus_voltage_v / r * kt / (j_eq * ratio);
        FinController {
            accel_limit,
            sensors,
            bus_voltage_v: drive.bus_voltage_v,
            tach_v_s_per_rad: m.tach_v_s_per_rad as f32,
            ratio,
            kp,
            kv,
            tau_m,
            kb_load,
        }
    }

    /// One control tick: reference angle, speed and acceleration (rad, rad/s, rad/s²) and the
    /// latest readings in; duty and direction out. Returns false if the PWM refused the duty.
    pub fn update(
        &mut self,
        reference: (f32, f32, f32),
        readings: &Readings,
        pwm: &mut impl SetDutyCycle,
        dir: &mut impl OutputPin,
    ) -> bool {
        let angle = self.sensors.pot.to_physical(readings.pot_counts);
        let tach_v = self.sensors.tach.to_physical(readings.tach_counts);
        let load_speed = tach_v / self.tach_v_s_per_rad / self.ratio;
        let (r, r_dot, r_ddot) = reference;
        // kp·e + kv·(ṙ − ω) written as a speed loop on a speed demand (kp/kv)·e. Far from the
        // target the demand follows the braking curve √(2·a·|e|) instead, so that a large step
        // asks only for a deceleration the bus can deliver (the linear law would saturate the
        // bridge and overshoot).
        let e = r - angle;
        let linear = self.kp / self.kv * e;
        let braking = math::sqrt(2.0 * self.accel_limit * math::abs(e));
        let demand = if math::abs(linear) <= braking {
            linear
        } else if e > 0.0 {
            braking
        } else {
            -braking
        };
        let volts =
            self.kv * (demand + r_dot - load_speed) + self.kb_load * (r_dot + self.tau_m * r_ddot);
        let max = pwm.max_duty_cycle();
        let frac = math::abs(volts) / self.bus_voltage_v;
        let duty = if frac >= 1.0 {
            max
        } else {
            (frac * f32::from(max) + 0.5) as u16
        };
        let dir_ok = if volts < 0.0 {
            dir.set_high().is_ok()
        } else {
            dir.set_low().is_ok()
        };
        dir_ok && pwm.set_duty_cycle(duty.min(max)).is_ok()
    }
}

/// Figures of the run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Figures {
    /// 10 → 90 % rise time of the step, ms.
    pub rise_ms: f32,
    /// Overshoot above the step, % of the step.
    pub overshoot_pct: f32,
    /// Mean error over the last 50 ms of the step phase, degrees.
    pub ss_error_deg: f32,
    /// RMS tracking error over the last 4 sine periods, degrees.
    pub tracking_rms_deg: f32,
    /// Peak tracking error over the last 4 sine periods, degrees.
    pub tracking_max_deg: f32,
}

impl Figures {
    /// True when every figure is within the acceptance bounds.
    pub fn ok(&self) -> bool {
        self.rise_ms <= MAX_RISE_MS
            && self.overshoot_pct <= MAX_OVERSHOOT_PCT
            && math::abs(self.ss_error_deg) <= MAX_SS_ERROR_DEG
            && self.tracking_rms_deg <= MAX_TRACKING_RMS_DEG
    }
}

/// What `run` measured of `step()` when given a clock.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepCost {
    /// Clock ticks spent inside `VirtualActuator::step()`, summed, ticks.
    pub ticks: u64,
    /// Clock ticks of an empty timed interval (the measurement's own overhead), summed over
    /// as many intervals, ticks.
    pub overhead_ticks: u64,
    /// Number of timed steps.
    pub steps: u32,
    /// Steps that ended in the backlash gap.
    pub steps_in_gap: u32,
    /// Ticks inside `Plant::step()` alone, replaying the run's voltages on a fresh state
    /// (the same trajectory), summed, ticks.
    pub plant_ticks: u64,
    /// Of `plant_ticks`: the steps where the gears went into or out of contact (gap edge
    /// events, handled by sub-steps), ticks.
    pub plant_event_ticks: u64,
    /// Number of those steps.
    pub plant_event_steps: u32,
    /// True when the replay ended in exactly the state of the run (so the timed replay is
    /// the run's trajectory).
    pub replay_identical: bool,
}

/// A tick source for timing `step()` (SysTick on the target).
pub trait StepClock {
    /// The counter now, ticks.
    fn now(&self) -> u32;
    /// Ticks elapsed from reading `earlier` to reading `later`.
    fn ticks_between(&self, earlier: u32, later: u32) -> u32;
}

/// Runs the step then the sine, printing the figures through `line`; `clock` (a monotonic
/// tick count, wrapping) times each `step()`. Returns the figures and the timing, or `None`
/// if the actuator cannot be built or a duty was refused.
pub fn run(
    line: &mut dyn FnMut(core::fmt::Arguments),
    clock: Option<&dyn StepClock>,
) -> Option<(Figures, StepCost)> {
    let plant = Plant::new(&REFERENCE.with_backlash_deg(BACKLASH_DEG)).ok()?;
    let h = plant.sample_period_s();
    let drive = DriveConfig::REFERENCE;
    let sensors = SensorConfig::REFERENCE;
    let mut act = VirtualActuator::new(plant, &drive, &sensors).ok()?;
    let mut ctl = FinController::new(sensors, &drive);
    line(format_args!(
        "fin_loop: {} Hz control, backlash {} deg, bus {} V, pwm max {}, pot {} bits, tach {} bits",
        (1.0 / h + 0.5) as u32,
        BACKLASH_DEG,
        drive.bus_voltage_v,
        drive.max_duty,
        sensors.pot.bits,
        sensors.tach.bits
    ));

    let deg = core::f32::consts::PI / 180.0;
    let step = STEP_DEG * deg;
    let amp = SINE_AMPLITUDE_DEG * deg;
    let w = 2.0 * core::f32::consts::PI * SINE_HZ;
    let period_steps = (1.0 / (SINE_HZ * h) + 0.5) as u32;
    let mut fig = Figures::default();
    let mut cost = StepCost::default();
    let (mut t10, mut t90) = (None, None);
    let mut peak = f32::MIN;
    let (mut ss_sum, mut ss_n) = (0.0f32, 0u32);
    let (mut sq_sum, mut tr_n, mut tr_max) = (0.0f32, 0u32, 0.0f32);

    // The last 32 steps, dumped if a figure fails (what firmware would send after the fact).
    let mut trace: Trace<TraceSample, 32> = Trace::new();
    let mut volts: heapless::Vec<f32, { 2 * PHASE_STEPS as usize }> = heapless::Vec::new();
    for k in 0..2 * PHASE_STEPS {
        let (reference, sine_phase) = if k < PHASE_STEPS {
            ((step, 0.0, 0.0), false)
        } else {
            let t = (k - PHASE_STEPS) as f32 * h;
            let (s, c) = math::sin_cos(w * t);
            ((step + amp * s, amp * w * c, -amp * w * w * s), true)
        };
        let parts = act.parts();
        let (mut pwm, mut dir) = (parts.pwm, parts.dir);
        if !ctl.update(reference, parts.readings, &mut pwm, &mut dir) {
            return None;
        }
        if let Some(c) = clock {
            let t0 = c.now();
            act.step();
            let t1 = c.now();
            let t2 = c.now();
            cost.ticks += u64::from(c.ticks_between(t0, t1));
            cost.overhead_ticks += u64::from(c.ticks_between(t1, t2));
            cost.steps += 1;
        } else {
            act.step();
        }
        let o = act.outputs();
        volts.push(o.applied_voltage_v).ok()?;
        trace.record(TraceSample::capture(&act));
        cost.steps_in_gap += u32::from(!o.in_contact);
        let theta = o.load_angle_rad;
        let n = k + 1; // the outputs are at the end of step k
        if !sine_phase {
            if t10.is_none() && theta >= 0.1 * step {
                t10 = Some(n);
            }
            if t90.is_none() && theta >= 0.9 * step {
                t90 = Some(n);
            }
            peak = peak.max(theta);
            if n > PHASE_STEPS - 100 {
                ss_sum += (step - theta) / deg;
                ss_n += 1;
            }
        } else {
            // Reference at the instant of the outputs (end of this step).
            let t = n.wrapping_sub(PHASE_STEPS) as f32 * h;
            let (s, _) = math::sin_cos(w * t);
            let e = (step + amp * s - theta) / deg;
            if n > PHASE_STEPS + period_steps {
                sq_sum += e * e;
                tr_n += 1;
                tr_max = tr_max.max(math::abs(e));
            }
        }
    }
    if let Some(c) = clock {
        let plant = act.plant();
        let mut st = PlantState::REST;
        let mut contact = plant.outputs(&st).in_contact;
        for &v in volts.iter() {
            let t0 = c.now();
            let o = plant.step(&mut st, v);
            let t1 = c.now();
            let o = core::hint::black_box(o);
            let ticks = u64::from(c.ticks_between(t0, t1));
            cost.plant_ticks += ticks;
            if o.in_contact != contact {
                cost.plant_event_ticks += ticks;
                cost.plant_event_steps += 1;
            }
            contact = o.in_contact;
        }
        cost.replay_identical = st == *act.state();
    }
    fig.rise_ms = match (t10, t90) {
        (Some(a), Some(b)) => (b - a) as f32 * h * 1000.0,
        _ => f32::INFINITY,
    };
    fig.overshoot_pct = ((peak - step) / step * 100.0).max(0.0);
    fig.ss_error_deg = ss_sum / ss_n.max(1) as f32;
    fig.tracking_rms_deg = math::sqrt(sq_sum / tr_n.max(1) as f32);
    fig.tracking_max_deg = tr_max;

    line(format_args!(
        "step {} deg: rise_ms {} overshoot_pct {} ss_error_deg {}",
        STEP_DEG, fig.rise_ms, fig.overshoot_pct, fig.ss_error_deg
    ));
    line(format_args!(
        "sine {} Hz {} deg: tracking_rms_deg {} tracking_max_deg {}",
        SINE_HZ, SINE_AMPLITUDE_DEG, fig.tracking_rms_deg, fig.tracking_max_deg
    ));
    line(format_args!(
        "bounds: rise_ms <= {} overshoot_pct <= {} |ss_error_deg| <= {} tracking_rms_deg <= {}",
        MAX_RISE_MS, MAX_OVERSHOOT_PCT, MAX_SS_ERROR_DEG, MAX_TRACKING_RMS_DEG
    ));
    line(format_args!(
        "final: encoder {} pot {} tach {} steps_in_gap {}",
        act.readings().encoder_count,
        act.readings().pot_counts,
        act.readings().tach_counts,
        cost.steps_in_gap
    ));
    if !fig.ok() {
        line(format_args!("trace: {}", TraceSample::HEADER));
        trace.dump(|s| line(format_args!("trace: {}", s)));
    }
    line(format_args!(
        "result: {}",
        if fig.ok() { "ok" } else { "FAIL" }
    ));
    Some((fig, cost))
}
