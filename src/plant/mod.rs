//! The geared servo as a stepped plant: exact per-mode discretisation, event handling for the
//! backlash and for stick/slip friction, zero-order-hold voltage input.
//!
//! # Model
//! States (`f32`): armature current `i`, motor speed `ωm`, load speed `ωL`, total twist
//! `x = θm/N − θL` and load angle `θL` (MODEL.md, reduced dead-zone form):
//!
//! ```text
//! L di/dt   = V − R i − k_b ωm
//! J_m dωm/dt = k_t i − T_L/N − c_m ωm − T_fm sgn ωm
//! J_L dωL/dt = T_L − c_L ωL − k_h θL − T sin θL − T_fL sgn ωL
//! dx/dt = ωm/N − ωL,  dθL/dt = ωL
//! T_L = k_eq (x ∓ δ) + c_mesh ẋ  while |x| > δ (in contact), 0 inside the gap
//! V   = db(command) limited to ±voltage_limit, db(u) = 0 for |u| ≤ V_db, u ∓ V_db beyond
//! ```
//!
//! A body at rest stays stuck while its drive is within its static friction
//! `stiction_ratio · T_f` (T_f without stiction) and slides against T_f once it breaks
//! away. The tachometer (gain, pickup, lag, offset) is the measurement model of `tach`.
//!
//! # The bench effects, and why each stays exact or second order
//! - **Dead band**: a map of the command before the limit, like the limit itself; the
//!   voltage stays held over the step, so the exact transitions apply unchanged.
//! - **Stiction**: only the thresholds change. Sticking and breakaway are decided against
//!   the static friction (`Ctx::ts_m`, `ts_l`); the located breakaway then starts with the
//!   net torque T_s − T_f instead of 0, which the impulse correction integrates exactly for
//!   the linear rise it already assumes (`events`). With the ratio at 0 or 1 every value is
//!   bit for bit what it was.
//! - **Gravity**: −T sin θL is not linear in the state. Its linear part about the hanging
//!   position, −T θL, joins the hinge spring in the exact transitions (so small swings are
//!   exact), and the remainder T (θL − sin θL) is held over each step at its value at the
//!   predicted mid-step angle (`Plant::nominal_at`), second order in a slow torque.
//!
//! # Scheme, and why
//! Between events the system is linear with constant forcing in each *mode* (gears in contact
//! or not; each body sliding or stuck), so it is integrated **exactly**: `s ← Φ s + Γ u` with
//! `Φ = e^{Ah}`, `Γ = ∫e^{As}ds B` computed once in `f64` (see [`crate::discretise`]). This
//! is exact however stiff the electrical mode (L/R ≈ 25 µs against a 500 µs step) and
//! however close the resonance is to the step rate, and it costs one 5×5 product per step.
//!
//! A step is first taken whole in the mode at its start. If the end state contradicts that
//! mode (the twist crossed ±δ, or its Hermite interpolant grazed it; a sliding body reversed;
//! a stuck body's torque exceeds static friction), the step is redone as exact
//! sub-steps (each half of the step is first tried whole under the same check, so only the
//! half holding the event is sub-stepped). A step longer than 0.15 of the fastest
//! mechanical period (a bench record sampled slowly) could hide an event from that check,
//! so it is always taken in sub-steps; it too goes by blocks short enough for the check,
//! each tried whole first. Within the sub-step where an event falls, its
//! instant is located by interpolation and the part of the sub-step after it is corrected
//! by the impulse the mode change implies: the dead-zone torque is continuous at the gap
//! edge, so the contact impulse grows as `k v τ²/2` (corrected to third order); friction
//! reverses (`2 T_f τ`) or sticks (velocity set exactly to zero); a motor breaking away
//! from rest follows the exponential current rise, located in closed form. Stuck bodies keep
//! a velocity of exactly zero (Karnopp-style), so there is no chatter and no dependence on a
//! velocity threshold.
//!
//! Each mode keeps only the entries of its transition that its structure lets be non-zero
//! (a stuck body's speed row and column, the decoupled motor and load sides in the gap):
//! they are exactly zero in the full matrices, so the shorter products give the same values
//! (`modes::ModeSet`).
//!
//! Accuracy against an independent fine RK4 integration and against the analytic transfer
//! function is proved in `host-tests/tests/plant_accuracy.rs`.

mod events;
mod faulty;
mod modes;
mod sine;
mod step;
mod tach;

pub use sine::SineDrive;

use crate::effects::Effect;
use crate::error::ParamError;
use crate::faults::{Jam, PlantFaults, Winding};
use crate::math::{self, abs};
use crate::params::ActuatorParams;
use modes::{
    continuous, mode_set, sub_step_plan, to_f32, transition, ModeSet, Vec5, COL_V, MODE_FLAGS,
};
use step::Ctx;
use tach::Tach;

/// Fewest sub-steps a step with an event is split into.
pub const MIN_SUB_STEPS: usize = 8;

/// Most sub-steps a step is split into (sample periods far longer than the mechanical
/// periods, such as a bench record at 5.6 ms of a stiff gear train).
pub const MAX_SUB_STEPS: usize = 1024;

/// Largest magnitude of any state variable after a step with faults (A, rad/s, rad). No
/// fault setting is expected to come near it (fault values are clamped to their physical
/// range, and an open winding does no net work over a step); it is the last resort that
/// keeps the state finite should some combination of extreme parameters and faults still
/// run away: a faulty step clamps each variable to it, and a NaN or ±∞ to 0. Far enough
/// below `f32::MAX` that the products of a later step with the transition coefficients do
/// not overflow (`host-tests/tests/fault_finiteness.rs`).
pub const MAX_ABS_FAULT_STATE: f32 = 1.0e12;

/// Largest `effects.input_delay`, in sample periods.
pub const MAX_DELAY_STEPS: usize = 16;

/// Magnitude the applied voltage is limited to when `effects.voltage_limit` is 0, V. No
/// servo amplifier comes near it; it exists so that an absurd command (1e30 V) saturates
/// physically instead of overflowing.
pub const MAX_ABS_VOLTAGE_V: f32 = 1.0e5;

const I: usize = 0;
const WM: usize = 1;
const WL: usize = 2;
const X: usize = 3;
const TH: usize = 4;
const HISTORY: usize = MAX_DELAY_STEPS + 2;

/// Dynamic state of the plant. `Copy`; [`PlantState::REST`] is everything at rest at zero.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PlantState {
    /// Armature current i, A.
    pub current_a: f32,
    /// Motor (pinion 1) speed ωm, rad/s.
    pub motor_speed_rad_s: f32,
    /// Load (fin) speed ωL, rad/s.
    pub load_speed_rad_s: f32,
    /// Total twist x = θm/N − θL at the load, rad; the gears are in contact when |x| > δ.
    pub twist_rad: f32,
    /// Load angle θL, rad.
    pub load_angle_rad: f32,
    /// Commanded voltages of the last steps (ring buffer), V; used by `input_delay`.
    history: [f32; HISTORY],
    /// The tachometer filter's output without the offset, V; used by `tach_lag` (see
    /// `plant::tach`). 0 at rest, where the filter's input is 0.
    pub(crate) tach_filter_v: f32,
    /// Index of the newest command in `history`.
    head: u8,
}

impl PlantState {
    /// At rest: no current, no motion, zero angles, gears centred in the gap.
    pub const REST: PlantState = PlantState {
        current_a: 0.0,
        motor_speed_rad_s: 0.0,
        load_speed_rad_s: 0.0,
        twist_rad: 0.0,
        load_angle_rad: 0.0,
        history: [0.0; HISTORY],
        head: 0,
        tach_filter_v: 0.0,
    };

    /// At rest with the load at `load_angle_rad` and the twist at `twist_rad` (both rad).
    pub const fn at_rest(load_angle_rad: f32, twist_rad: f32) -> PlantState {
        let mut s = PlantState::REST;
        s.load_angle_rad = load_angle_rad;
        s.twist_rad = twist_rad;
        s
    }

    fn vec(&self) -> Vec5 {
        [
            self.current_a,
            self.motor_speed_rad_s,
            self.load_speed_rad_s,
            self.twist_rad,
            self.load_angle_rad,
        ]
    }

    fn set(&mut self, s: &Vec5) {
        self.current_a = s[I];
        self.motor_speed_rad_s = s[WM];
        self.load_speed_rad_s = s[WL];
        self.twist_rad = s[X];
        self.load_angle_rad = s[TH];
    }
}

impl Default for PlantState {
    fn default() -> Self {
        PlantState::REST
    }
}

/// What the plant's sensors and a debugger see after a step.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Outputs {
    /// Tachometer voltage, V: (1 + tach_gain) k_ts ωm, plus the current pickup
    /// `tach_current_coupling · i`, through the `tach_lag` filter, plus `tach_offset` (the
    /// tachometer's measurement model, `plant::tach`).
    pub tach_voltage_v: f32,
    /// Motor speed ωm, rad/s.
    pub motor_speed_rad_s: f32,
    /// Motor angle θm = N (x + θL), rad (loses resolution after many revolutions in `f32`).
    pub motor_angle_rad: f32,
    /// Load speed ωL, rad/s.
    pub load_speed_rad_s: f32,
    /// Load angle θL, rad.
    pub load_angle_rad: f32,
    /// Armature current at the sample instant, A.
    pub current_a: f32,
    /// Armature current averaged over the step just taken, A (what a current sensor
    /// filtered over the PWM period reads). Equal to `current_a` from [`Plant::outputs`].
    pub mean_current_a: f32,
    /// Torque transmitted through the gears to the load T_L, N·m.
    pub transmitted_torque_nm: f32,
    /// Whether the gear teeth are in contact (|x| > δ).
    pub in_contact: bool,
    /// Voltage applied to the winding during the step just taken (after delay and
    /// saturation; the late part when a fractional delay splits the step), V.
    pub applied_voltage_v: f32,
}

impl Outputs {
    /// Load angle in degrees.
    pub fn load_angle_deg(&self) -> f32 {
        self.load_angle_rad * (180.0 / core::f32::consts::PI)
    }
}
/// A parameter set turned into the stepped plant: everything precomputed, `step()` does
/// arithmetic only. Build once with [`Plant::new`], then drive any number of
/// [`PlantState`]s with it.
#[derive(Clone, Debug, PartialEq)]
pub struct Plant {
    full: ModeSet,
    /// The modes over a block of `block` sub-steps.
    block_set: ModeSet,
    sub: ModeSet,
    /// Γ column of the voltage over the late part (1 − f) h of a step split by a fractional
    /// input delay, per mode; all zero when the delay is a whole number of steps.
    late_v: [Vec5; 6],
    h: f32,
    r: f32,
    l: f32,
    kt: f32,
    kb: f32,
    jm: f32,
    jl: f32,
    n: f32,
    inv_n: f32,
    /// 1 / (R h), for the mean current.
    inv_rh: f32,
    k: f32,
    c_mesh: f32,
    /// Hinge spring, N·m/rad (for the stored energy).
    k_hinge: f32,
    /// Spring from the load to ground in the modes: hinge plus gravity's linear part T,
    /// N·m/rad.
    k_ground: f32,
    /// `effects.gravity_torque` T, N·m (0: off).
    gravity: f32,
    delta: f32,
    tf_m: f32,
    tf_l: f32,
    /// Breakaway (static) friction, N·m: `stiction_ratio` times the Coulomb friction, or the
    /// Coulomb friction itself when the ratio is 0 (off).
    ts_m: f32,
    ts_l: f32,
    tach: Tach,
    v_max: f32,
    /// `effects.drive_deadband`, V (0: off).
    v_db: f32,
    /// An input delay or a bench effect is on (stiction, gravity, dead band, tachometer
    /// offset, pickup or lag): [`Plant::step`] takes its general instance.
    general: bool,
    tau_e: f32,
    /// Sub-steps per step when a step is redone (see [`MIN_SUB_STEPS`]).
    sub_steps: u16,
    /// Every step is sub-stepped (the sample period is long against the mechanical periods).
    always_sub: bool,
    /// Sub-steps per block (0: none): a step that needs sub-steps first tries each block
    /// of this many whole, under the whole-step check (`modes::SubStepPlan::block`).
    block: u16,
    delay_steps: u8,
    /// There is an input delay (`delay_steps` or `delay_frac` non-zero).
    has_delay: bool,
    /// Fraction of a step during which the older command still applies.
    delay_frac: f32,
}

impl Plant {
    /// Validates `params` and precomputes the exact transitions of every mode at the step
    /// and at the sub-step. Costs some ten thousand `f64` operations: do it once, not in a loop.
    pub fn new(params: &ActuatorParams) -> Result<Plant, ParamError> {
        let d = params.derived()?;
        let h = params.sample_period_s;
        let full = mode_set(params, d.n_total, d.k_eq_nm_per_rad, h)?;
        let plan = sub_step_plan(params, d.n_total, d.k_eq_nm_per_rad);
        let sub = mode_set(params, d.n_total, d.k_eq_nm_per_rad, h / plan.n_sub as f64)?;
        // A block's length as a fraction of the step first: exactly h/2 for halves. Without
        // blocks the set is never used (the sub-step's is stored, not a copy of no meaning).
        let block_set = if plan.block > 0 {
            let share = plan.block as f64 / plan.n_sub as f64;
            mode_set(params, d.n_total, d.k_eq_nm_per_rad, h * share)?
        } else {
            sub
        };

        let delay = params.effects.input_delay / h;
        // Whole steps, and the fraction of a step the older command still covers. A delay
        // within 1e-9 step of a whole number is taken as whole (floating-point noise).
        let mut whole = libm::floor(delay);
        let mut frac = delay - whole;
        if frac > 1.0 - 1e-9 {
            whole += 1.0;
            frac = 0.0;
        } else if frac < 1e-9 {
            frac = 0.0;
        }
        let mut late_v = [[0.0f32; 5]; 6];
        if frac > 0.0 {
            for (slot, &(contact, mf, lf)) in late_v.iter_mut().zip(MODE_FLAGS.iter()) {
                let (a, b) = continuous(params, d.n_total, d.k_eq_nm_per_rad, contact, mf, lf);
                *slot = transition(&a, &b, (1.0 - frac) * h)?.cols[COL_V];
            }
        }

        let m = &params.motor;
        let tach = Tach::new(params, h)?;
        // Static over sliding friction; 0 (off) is the same as 1, exactly.
        let stiction = if params.effects.stiction_ratio > 0.0 {
            params.effects.stiction_ratio
        } else {
            1.0
        };
        let v_max = if params.effects.voltage_limit > 0.0 {
            to_f32(params.effects.voltage_limit, Effect::VoltageLimit.key())?.min(MAX_ABS_VOLTAGE_V)
        } else {
            MAX_ABS_VOLTAGE_V
        };
        Ok(Plant {
            full,
            block_set,
            sub,
            late_v,
            h: h as f32,
            r: to_f32(m.resistance_ohm, "motor.resistance_ohm")?,
            l: to_f32(m.inductance_h, "motor.inductance_h")?,
            kt: to_f32(m.torque_constant_nm_per_a, "motor.torque_constant_nm_per_a")?,
            kb: to_f32(m.back_emf_v_s_per_rad, "motor.back_emf_v_s_per_rad")?,
            jm: to_f32(m.inertia_kg_m2, "motor.inertia_kg_m2")?,
            jl: to_f32(params.load.inertia_kg_m2, "load.inertia_kg_m2")?,
            n: d.n_total as f32,
            inv_n: (1.0 / d.n_total) as f32,
            inv_rh: to_f32(1.0 / (m.resistance_ohm * h), "motor.resistance_ohm")?,
            k: to_f32(d.k_eq_nm_per_rad, "stiffness.k2_nm_per_rad")?,
            c_mesh: to_f32(params.effects.mesh_damping, Effect::MeshDamping.key())?,
            k_hinge: to_f32(params.effects.hinge_stiffness, Effect::HingeStiffness.key())?,
            k_ground: to_f32(
                params.ground_stiffness_nm_per_rad(),
                Effect::HingeStiffness.key(),
            )?,
            gravity: to_f32(params.effects.gravity_torque, Effect::GravityTorque.key())?,
            delta: d.delta_rad as f32,
            tf_m: to_f32(m.coulomb_friction_nm, "motor.coulomb_friction_nm")?,
            tf_l: to_f32(params.load.coulomb_friction_nm, "load.coulomb_friction_nm")?,
            ts_m: to_f32(
                m.coulomb_friction_nm * stiction,
                Effect::StictionRatio.key(),
            )?,
            ts_l: to_f32(
                params.load.coulomb_friction_nm * stiction,
                Effect::StictionRatio.key(),
            )?,
            tach,
            v_max,
            v_db: to_f32(params.effects.drive_deadband, Effect::DriveDeadband.key())?,
            general: whole > 0.0
                || frac > 0.0
                || stiction > 1.0
                || params.effects.gravity_torque != 0.0
                || params.effects.drive_deadband > 0.0
                || tach.extra(),
            tau_e: to_f32(m.inductance_h / m.resistance_ohm, "motor.inductance_h")?,
            sub_steps: plan.n_sub as u16,
            always_sub: plan.always,
            block: plan.block as u16,
            delay_steps: whole as u8,
            has_delay: whole > 0.0 || frac > 0.0,
            delay_frac: frac as f32,
        })
    }

    /// Step length h, s.
    pub fn sample_period_s(&self) -> f32 {
        self.h
    }

    /// Half gap δ, rad at the load.
    pub fn half_gap_rad(&self) -> f32 {
        self.delta
    }

    /// Total ratio N.
    pub fn ratio(&self) -> f32 {
        self.n
    }

    /// Applies `voltage_v` (V) to the winding for one step (zero-order hold) and returns the
    /// outputs at the end of the step.
    ///
    /// Never fails, never allocates, never panics. A NaN command is taken as 0 V; ±∞ and any
    /// magnitude beyond `effects.voltage_limit` (or [`MAX_ABS_VOLTAGE_V`]) saturate at it.
    ///
    /// Always inlined: the caller's loop then keeps the state in registers and receives the
    /// outputs without a copy through memory (measured: 408 → 392 instructions per step on
    /// the Cortex-M4F, 22–25 → 19–20 ns on the host; the rare sub-stepped path stays out of
    /// line).
    ///
    /// The input delay and the bench effects (stiction, gravity, dead band, the
    /// tachometer's offset, pickup and lag) run in a second, out-of-line instance of the
    /// step, the general one; a plant with none of them takes the inlined plain instance,
    /// where every test of them folds away. The one test of the flag replaces the delay's
    /// own tests (measured on the Cortex-M4F, docs/cost.md: testing the bench effects in
    /// the step cost 73 instructions per step, a flag for them alone 17).
    #[inline(always)]
    pub fn step(&self, state: &mut PlantState, voltage_v: f32) -> Outputs {
        if self.general {
            self.step_general(state, voltage_v)
        } else {
            self.step_in::<false>(state, voltage_v, None)
        }
    }

    /// The general instance of the step (see [`Plant::step`]); cold, so that the branch to
    /// it costs the plain instance no saved registers. Without faults (a separate function
    /// from the faulty one, so that every fault test folds away here too).
    #[cold]
    #[inline(never)]
    fn step_general(&self, state: &mut PlantState, voltage_v: f32) -> Outputs {
        self.step_in::<true>(state, voltage_v, None)
    }

    /// The general instance with faults ([`Plant::step_with_faults`]).
    #[cold]
    #[inline(never)]
    fn step_general_faulty(
        &self,
        state: &mut PlantState,
        voltage_v: f32,
        faults: &PlantFaults,
    ) -> Outputs {
        self.step_in::<true>(state, voltage_v, Some(faults))
    }

    /// [`Plant::step`] with run-time faults of the mechanics and the winding (see
    /// [`PlantFaults`]). Out-of-range fault values are clamped to the physical range each
    /// field documents (NaN: that fault off), so no fault setting makes the step fail, and
    /// the state stays finite whatever the faults and the command: a faulty step leaves
    /// every state variable within ±[`MAX_ABS_FAULT_STATE`]. With [`PlantFaults::NONE`] it
    /// is bit-identical to [`Plant::step`].
    pub fn step_with_faults(
        &self,
        state: &mut PlantState,
        voltage_v: f32,
        faults: &PlantFaults,
    ) -> Outputs {
        if self.general {
            self.step_general_faulty(state, voltage_v, faults)
        } else {
            self.step_in::<false>(state, voltage_v, Some(faults))
        }
    }

    /// The step. `None` (no fault) is known at compile time in [`Plant::step`], so every
    /// fault check folds away there; so does every test of the input delay and of the bench
    /// effects when `GENERAL` is false (the plant has none: `self.general`). With `GENERAL`
    /// true and all of them off, the values are the same.
    #[inline(always)]
    fn step_in<const GENERAL: bool>(
        &self,
        state: &mut PlantState,
        voltage_v: f32,
        faults: Option<&PlantFaults>,
    ) -> Outputs {
        let nominal = faults.is_none_or(|f| *f == PlantFaults::NONE);
        let faults = faults.unwrap_or(&PlantFaults::NONE);
        let cmd = self.saturate(if GENERAL && self.v_db > 0.0 {
            self.dead_band(voltage_v)
        } else {
            voltage_v
        });
        let (mut v_early, mut v_late) = if GENERAL && self.has_delay {
            self.delayed(state, cmd)
        } else {
            (cmd, cmd)
        };
        let mut s0 = state.vec();
        match faults.winding {
            Winding::Normal => {}
            Winding::Shorted => (v_early, v_late) = (0.0, 0.0),
            // No current: the winding's voltage is the back-EMF (set below, once the
            // context is known), nothing drives a current.
            Winding::Open => s0[I] = 0.0,
        }
        if faults.jam == Jam::Here {
            s0[WL] = 0.0;
        }
        let c = if nominal {
            if GENERAL {
                self.general_ctx(&s0)
            } else {
                self.plain()
            }
        } else {
            self.context(faults, &s0)
        };
        if faults.winding == Winding::Open {
            let v = self.open_voltage(&c, &s0);
            (v_early, v_late) = (v, v);
        }
        let (mut s1, gear) = self.advance_step::<GENERAL>(&c, &s0, v_early, v_late);
        if faults.winding == Winding::Open {
            s1[I] = 0.0;
        }
        if let Jam::AtAngle(a) = faults.jam {
            // Reached the block within the step: held exactly there; the motor side keeps
            // its angle, so the twist takes up the difference.
            if let Some(a) = faulty::jam_angle(a) {
                let (d0, d1) = (s0[TH] - a, s1[TH] - a);
                if !c.jammed && (d1 == 0.0 || (d0 > 0.0) != (d1 > 0.0)) {
                    s1[X] += s1[TH] - a;
                    s1[TH] = a;
                    s1[WL] = 0.0;
                }
            }
        }
        if !nominal {
            faulty::bound_state(&mut s1);
        }
        state.set(&s1);
        // Without a delay both parts are the command, and this mean is exactly it.
        let v_mean = if GENERAL && self.has_delay {
            v_early * self.delay_frac + v_late * (1.0 - self.delay_frac)
        } else {
            v_late
        };
        // Faults may move the state after the step (a jam) or change the contact: derive
        // the gear again there; nominally it is the mode's at the end of the step.
        let (c_end, gear) = if nominal {
            (c, gear)
        } else {
            let c_end = self.context(faults, &s1);
            (c_end, self.gear_of(&c_end, s1[X]))
        };
        let mean_current = if faults.winding == Winding::Open {
            0.0
        } else {
            self.mean_current(&s0, &s1, v_mean)
        };
        if GENERAL && self.tach.lagged() {
            self.sense(state, &s0, &s1, mean_current);
        }
        let mut out = self.outputs_gear::<GENERAL>(&c_end, state, gear);
        out.applied_voltage_v = v_late;
        out.mean_current_a = mean_current;
        out
    }

    /// Advances the tachometer's filter over the step from `s0` to `s1` (the state is
    /// already at `s1`), whose mean current was `mean_current` (A).
    #[inline(never)]
    fn sense(&self, state: &mut PlantState, s0: &Vec5, s1: &Vec5, mean_current: f32) {
        let mean_speed = self.n * ((s1[X] - s0[X]) + (s1[TH] - s0[TH])) / self.h;
        state.tach_filter_v = self.tach.advance(
            state.tach_filter_v,
            (s0[WM], s0[I]),
            (s1[WM], s1[I]),
            mean_speed,
            mean_current,
        );
    }

    /// Applies the continuous voltage `amplitude_v · sin(phase_rad + ω τ)` over one step
    /// (τ from the step's start, ω the drive's frequency) and returns the outputs at its end.
    /// The caller advances `phase_rad` by [`SineDrive::phase_step_rad`] each step.
    ///
    /// `effects.input_delay` shifts the phase (exact for a sine). A sine whose amplitude
    /// exceeds the voltage limit is not a sine at the winding: that step falls back to the
    /// held, saturated mid-step value. NaN is taken as 0 V. `applied_voltage_v` reports the
    /// mid-step value.
    pub fn step_sine(
        &self,
        state: &mut PlantState,
        drive: &SineDrive,
        amplitude_v: f32,
        phase_rad: f32,
    ) -> Outputs {
        let (sn, cs) = math::sin_cos(phase_rad - drive.delay_phase);
        let (a_cos, a_sin) = (amplitude_v * sn, amplitude_v * cs);
        let v_mid = a_cos * drive.half_full[0] + a_sin * drive.half_full[1];
        // Non-finite amplitude or phase, a sine beyond the limit, or through the drive's dead
        // band (then not a sine at the winding): the held path handles it (NaN as 0 V,
        // saturation, dead band).
        let usable = v_mid.is_finite() && abs(amplitude_v) <= self.v_max && self.v_db == 0.0;
        if !usable {
            return self.step(state, v_mid);
        }
        let s0 = state.vec();
        let s1 = self.advance_step_sine(&self.nominal_at(&s0), &s0, drive, a_cos, a_sin);
        state.set(&s1);
        // Exact mean of the sine over the step.
        let [c1, s1r] = drive.rot_full;
        let v_mean = if drive.omega_h > 0.0 {
            (a_cos * s1r + a_sin * (1.0 - c1)) / drive.omega_h
        } else {
            a_cos
        };
        let mean_current = self.mean_current(&s0, &s1, v_mean);
        if self.tach.lagged() {
            self.sense(state, &s0, &s1, mean_current);
        }
        let mut out = self.outputs(state);
        out.applied_voltage_v = v_mid;
        out.mean_current_a = mean_current;
        out
    }

    /// Outputs of `state` as sampled now (before any step: the initial row of a record).
    pub fn outputs(&self, state: &PlantState) -> Outputs {
        self.outputs_in(&self.nominal(), state)
    }

    /// Outputs of `state` under `faults` (worn backlash changes the contact, a broken tooth
    /// the transmitted torque).
    pub fn outputs_with_faults(&self, state: &PlantState, faults: &PlantFaults) -> Outputs {
        self.outputs_in(&self.context(faults, &state.vec()), state)
    }

    #[inline(always)]
    fn outputs_in(&self, c: &Ctx, state: &PlantState) -> Outputs {
        self.outputs_gear::<true>(c, state, self.gear_of(c, state.twist_rad))
    }

    /// Outputs of `state` whose gear contact (`gear_of`) is `gear`; without `GENERAL` the
    /// tachometer is its sensitivity times the speed (the plant has no bench effect).
    #[inline(always)]
    fn outputs_gear<const GENERAL: bool>(&self, c: &Ctx, state: &PlantState, gear: i8) -> Outputs {
        let s = state.vec();
        let applied = state
            .history
            .get(state.head as usize)
            .copied()
            .unwrap_or(0.0);
        // A broken tooth's lost share is an external torque pair in the context.
        let mut transmitted = self.transmitted(c, &s, gear);
        if c.ext {
            transmitted -= c.lost;
        }
        Outputs {
            tach_voltage_v: if GENERAL {
                self.tach.read(state.tach_filter_v, s[WM], s[I])
            } else {
                self.tach.plain(s[WM])
            },
            motor_speed_rad_s: s[WM],
            motor_angle_rad: self.n * (s[X] + s[TH]),
            load_speed_rad_s: s[WL],
            load_angle_rad: s[TH],
            current_a: s[I],
            mean_current_a: s[I],
            transmitted_torque_nm: transmitted,
            in_contact: gear != 0,
            applied_voltage_v: applied,
        }
    }

    /// Energy stored in the winding, the inertias, the gear spring, the hinge spring and
    /// the unbalanced load (T (1 − cos θL), zero where it hangs), J.
    pub fn stored_energy_j(&self, state: &PlantState) -> f64 {
        let s = state.vec().map(f64::from);
        let delta = f64::from(self.delta);
        let dz = if s[X] > delta {
            s[X] - delta
        } else if s[X] < -delta {
            s[X] + delta
        } else {
            0.0
        };
        0.5 * (f64::from(self.l) * s[I] * s[I]
            + f64::from(self.jm) * s[WM] * s[WM]
            + f64::from(self.jl) * s[WL] * s[WL]
            + f64::from(self.k) * dz * dz
            + f64::from(self.k_hinge) * s[TH] * s[TH])
            + f64::from(self.gravity) * (1.0 - libm::cos(s[TH]))
    }

    /// The voltage the drive applies for a command `v` (after the dead band): limited.
    #[inline(always)]
    fn saturate(&self, v: f32) -> f32 {
        if abs(v) <= self.v_max {
            v
        } else if v > 0.0 {
            self.v_max
        } else if v < 0.0 {
            -self.v_max
        } else {
            // NaN
            0.0
        }
    }

    /// `effects.drive_deadband`: 0 while |v| ≤ V_db, v − sign(v) V_db beyond (continuous at
    /// ±V_db). NaN stays NaN (and reads 0 V after the limit).
    #[inline(never)]
    fn dead_band(&self, v: f32) -> f32 {
        if abs(v) <= self.v_db {
            0.0
        } else if v > 0.0 {
            v - self.v_db
        } else if v < 0.0 {
            v + self.v_db
        } else {
            v
        }
    }

    /// Pushes the command and returns the voltages applied during the early (fraction
    /// `delay_frac`) and the late part of this step.
    #[inline(always)]
    fn delayed(&self, state: &mut PlantState, cmd: f32) -> (f32, f32) {
        let head = (state.head as usize + 1) % HISTORY;
        state.head = head as u8;
        if let Some(slot) = state.history.get_mut(head) {
            *slot = cmd;
        }
        let back = |k: usize| {
            let idx = (head + HISTORY - (k % HISTORY)) % HISTORY;
            state.history.get(idx).copied().unwrap_or(0.0)
        };
        let late = back(self.delay_steps as usize);
        let early = back(self.delay_steps as usize + 1);
        (early, late)
    }

    #[inline(always)]
    fn mean_current(&self, s0: &Vec5, s1: &Vec5, v: f32) -> f32 {
        // ∫ i dt over the step from the winding equation: (V h − k_b Δθm − L Δi) / R.
        let d_theta_m = self.n * ((s1[X] - s0[X]) + (s1[TH] - s0[TH]));
        (v * self.h - self.kb * d_theta_m - self.l * (s1[I] - s0[I])) * self.inv_rh
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::REFERENCE;

    #[test]
    fn rest_with_zero_input_stays_exactly_at_rest() {
        let p = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
        let mut s = PlantState::REST;
        for _ in 0..1000 {
            p.step(&mut s, 0.0);
        }
        assert_eq!(s, PlantState::REST);
    }

    #[test]
    fn dead_zone_transmits_no_torque_inside_gap() {
        let p = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
        let d = p.half_gap_rad();
        for x in [-0.999 * d, -0.5 * d, 0.0, 0.3 * d, 0.999 * d] {
            let o = p.outputs(&PlantState::at_rest(0.0, x));
            assert_eq!(o.transmitted_torque_nm, 0.0);
            assert!(!o.in_contact);
        }
        let o = p.outputs(&PlantState::at_rest(0.0, 2.0 * d));
        assert!(o.in_contact && o.transmitted_torque_nm > 0.0);
    }

    #[test]
    fn nan_and_infinite_commands_give_finite_outputs() {
        let p = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
        let mut s = PlantState::REST;
        for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30, 0.0] {
            for _ in 0..50 {
                let o = p.step(&mut s, v);
                assert!(o.tach_voltage_v.is_finite() && o.current_a.is_finite());
            }
        }
    }
}

#[cfg(test)]
mod general_instance_tests {
    use super::*;
    use crate::params::REFERENCE;

    /// The step's general instance without delay or bench effects computes what the plain
    /// instance computes, bit for bit (so switching instances by the flag changes nothing
    /// but speed): backlash, friction, mesh damping, events and a fault.
    #[test]
    fn general_instance_without_its_effects_is_the_plain_step() {
        let mut p = REFERENCE.with_backlash_deg(0.08);
        p.effects.mesh_damping = 0.01;
        let plain = Plant::new(&p).unwrap();
        assert!(!plain.general);
        let mut bench = plain.clone();
        bench.general = true;
        let faults = PlantFaults {
            load_torque_nm: 0.02,
            ..PlantFaults::NONE
        };
        let (mut a, mut b) = (PlantState::REST, PlantState::REST);
        for k in 0..3000u32 {
            let v = if (k / 150) % 2 == 0 { 9.0 } else { -7.5 } + 0.3 * (k % 7) as f32;
            let (oa, ob) = if k % 500 < 250 {
                (plain.step(&mut a, v), bench.step(&mut b, v))
            } else {
                (
                    plain.step_with_faults(&mut a, v, &faults),
                    bench.step_with_faults(&mut b, v, &faults),
                )
            };
            assert_eq!(oa, ob, "step {k}");
            assert_eq!(a, b, "step {k}");
        }
    }
}

#[cfg(test)]
mod block_tests {
    extern crate std;
    use super::*;
    use crate::params::REFERENCE;

    /// Relative RMS difference of the tachometer between `p` and `p` with every event step
    /// sub-stepped throughout (no blocks), under the voltage `v(t)` (t in s), over `steps`
    /// steps, and the number of contact changes.
    fn blocks_against_sub_steps(p: &Plant, v: impl Fn(f32) -> f32, steps: u32) -> (f64, u32) {
        let mut q = p.clone();
        q.block = 0;
        let (mut a, mut b) = (PlantState::REST, PlantState::REST);
        let (mut diff2, mut ref2, mut events) = (0.0f64, 0.0f64, 0u32);
        for k in 0..steps {
            let v = v(k as f32 * p.h);
            let before = p.outputs(&a).in_contact;
            let oa = p.step(&mut a, v);
            let ob = q.step(&mut b, v);
            events += u32::from(oa.in_contact != before);
            let d = f64::from(oa.tach_voltage_v - ob.tach_voltage_v);
            diff2 += d * d;
            ref2 += f64::from(ob.tach_voltage_v).powi(2);
        }
        ((diff2 / ref2).sqrt(), events)
    }

    /// Trying each half of an event step whole (with the whole-step check) gives the same
    /// trajectory as sub-stepping both halves, up to f32 rounding (Φ(h/2) against Φ(h/8)⁴):
    /// 10 V, 20 Hz sine with 0.08° backlash (the non-chaotic record of plant_accuracy.rs),
    /// tachometer over 0.2 s. Bound 1e-4 relative RMS: a hundredth of the 1 % accuracy
    /// budget against the RK4 reference; measured 6.5e-6 over 58 contact changes.
    #[test]
    fn trying_halves_whole_changes_only_rounding() {
        let p = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
        assert!(!p.always_sub, "the reference takes the whole-step path");
        assert_eq!(p.block * 2, p.sub_steps, "and tries halves");
        let w = 2.0 * core::f32::consts::PI * 20.0;
        let (rel, events) = blocks_against_sub_steps(&p, |t| 10.0 * libm::sinf(w * t), 400);
        std::println!("halves vs sub-steps: {rel:.2e} relative RMS over {events} contact changes");
        assert!(events > 10, "the record must have events ({events})");
        assert!(rel <= 1e-4, "{rel}");
    }

    /// A step long against the mechanical periods (a bench record at 5.625 ms) is always
    /// sub-stepped, by blocks each tried whole first; that too changes only rounding
    /// (Φ(10τ) against Φ(τ)¹⁰): the non-chaotic 10 V, 1 s square wave with 0.08° backlash of
    /// plant_accuracy.rs's long-period test, over 4 s (at 20 Hz this rattles at this step and
    /// any two schemes part, MODEL.md "Gear rattle"). Same bound as the halves; measured
    /// 1.6e-5 over 183 contact changes.
    #[test]
    fn trying_blocks_whole_on_a_long_step_changes_only_rounding() {
        let mut params = REFERENCE.with_backlash_deg(0.08);
        params.sample_period_s = 0.005625;
        let p = Plant::new(&params).unwrap();
        assert!(p.always_sub, "a 5.625 ms step is always sub-stepped");
        assert!(
            p.block >= 2 && p.sub_steps.is_multiple_of(p.block),
            "in whole blocks ({} of {})",
            p.block,
            p.sub_steps
        );
        let square = |t: f32| {
            if ((t / 0.5) as u32).is_multiple_of(2) {
                10.0
            } else {
                -10.0
            }
        };
        let (rel, events) = blocks_against_sub_steps(&p, square, 711);
        std::println!(
            "blocks of {} of {} sub-steps vs sub-steps: {rel:.2e} relative RMS over {events} contact changes",
            p.block,
            p.sub_steps
        );
        assert!(events > 10, "the record must have events ({events})");
        assert!(rel <= 1e-4, "{rel}");
    }
}
