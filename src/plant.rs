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
//! J_L dωL/dt = T_L − c_L ωL − k_h θL − T_fL sgn ωL
//! dx/dt = ωm/N − ωL,  dθL/dt = ωL
//! T_L = k_eq (x ∓ δ) + c_mesh ẋ  while |x| > δ (in contact), 0 inside the gap
//! ```
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
//! sub-steps. Within the sub-step where an event falls, its instant is located by
//! interpolation and the part of the sub-step after it is corrected by the impulse the
//! mode change implies: the dead-zone torque is continuous at the gap edge, so the contact
//! impulse grows as `k v τ²/2` (corrected to third order); friction reverses (`2 T_f τ`) or
//! sticks (velocity set exactly to zero); a motor breaking away from rest follows the
//! exponential current rise, located in closed form. Stuck bodies keep a velocity of exactly
//! zero (Karnopp-style), so there is no chatter and no dependence on a velocity threshold.
//!
//! Accuracy against an independent fine RK4 integration and against the analytic transfer
//! function is proved in `host-tests/tests/plant_accuracy.rs`.

use crate::discretise::{self, Mat};
use crate::error::ParamError;
use crate::math::{self, abs, fraction};
use crate::params::ActuatorParams;

/// Fewest sub-steps a step with an event is split into.
pub const MIN_SUB_STEPS: usize = 8;

/// Most sub-steps a step is split into (sample periods far longer than the mechanical
/// periods, such as a bench record at 5.6 ms of a stiff gear train).
pub const MAX_SUB_STEPS: usize = 1024;

/// Sub-step length as a fraction of the fastest mechanical period: events are located
/// within a sub-step and corrected to third order in its length.
const SUB_STEP_PERIOD_FRACTION: f64 = 0.013;

/// Beyond this many fastest periods per step, the gears may touch and part within one
/// step without the whole-step check seeing it, so every step is sub-stepped.
const WHOLE_STEP_PERIOD_FRACTION: f64 = 0.15;

/// Sub-steps per step for these parameters, and whether every step must be sub-stepped.
///
/// The fastest mechanical frequency is that of the gears in contact with both bodies free,
/// stiffened by the hinge spring: `√(k (1/J_L + 1/(N² J_m)) + k_h/J_L) / 2π` (eq. 17b with
/// the hinge). The reference actuator at 0.5 ms gets 8 sub-steps and the whole-step path.
fn sub_step_plan(p: &ActuatorParams, n: f64, k: f64) -> (usize, bool) {
    let jm = p.motor.inertia_kg_m2;
    let jl = p.load.inertia_kg_m2;
    let w2 = k * (1.0 / jl + 1.0 / (n * n * jm)) + p.effects.hinge_stiffness / jl;
    let f_max = libm::sqrt(w2) / (2.0 * core::f64::consts::PI);
    let periods = p.sample_period_s * f_max;
    let wanted = libm::ceil(periods / SUB_STEP_PERIOD_FRACTION);
    let n_sub = if wanted.is_finite() {
        (wanted as usize).clamp(MIN_SUB_STEPS, MAX_SUB_STEPS)
    } else {
        MAX_SUB_STEPS
    };
    (n_sub, periods > WHOLE_STEP_PERIOD_FRACTION)
}

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

type Vec5 = [f32; 5];

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
    /// Tachometer voltage V_t = (1 + tach_gain) k_ts ωm, V.
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

/// Motion state of one body within a mode: stuck by static friction, or sliding with the
/// given direction (the sign of its friction torque's opposite).
#[derive(Clone, Copy, PartialEq, Debug)]
enum Motion {
    Stuck,
    Slip(f32),
}

#[derive(Clone, Copy, Debug)]
struct Mode {
    /// +1 / −1 in contact on that flank, 0 in the gap.
    gear: i8,
    motor: Motion,
    load: Motion,
}

/// Exact transition of one mode over one (sub-)step: `s' = Φ s + Γ [V, τ_m, τ_L]`, with
/// τ_m, τ_L constant torques on the motor and the load. Stored by columns (`cols[j][r]`:
/// Φ's columns 0–4, then Γ's), so that the product runs down contiguous columns and
/// vectorises where the target has SIMD.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Transition {
    cols: [Vec5; 8],
}

const NO_TRANSITION: Transition = Transition {
    cols: [[0.0; 5]; 8],
};

/// Column of the held voltage in a [`Transition`].
const COL_V: usize = 5;

/// The six modes with dynamics, indexed `contact·3 + {both slide, motor stuck, load stuck}`;
/// with both bodies stuck only the current moves, which is done in closed form.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ModeSet {
    modes: [Transition; 6],
    /// e^{−R τ / L} over this set's step τ, for the both-stuck case.
    decay: f32,
    /// Step length τ, s.
    tau: f32,
}

impl Mode {
    /// Index into the six modes with dynamics; `None` when both bodies are stuck.
    #[inline(always)]
    fn index(&self) -> Option<usize> {
        let c = if self.gear != 0 { 3 } else { 0 };
        match (self.motor, self.load) {
            (Motion::Slip(_), Motion::Slip(_)) => Some(c),
            (Motion::Stuck, Motion::Slip(_)) => Some(c + 1),
            (Motion::Slip(_), Motion::Stuck) => Some(c + 2),
            (Motion::Stuck, Motion::Stuck) => None,
        }
    }
}

/// Voltage input over one (sub-)step.
#[derive(Clone, Copy)]
struct Input<'a> {
    /// Weight of the held-voltage column Γ_V, V.
    v: f32,
    /// Voltage used by the closed forms (both bodies stuck, motor breakaway), V: the held
    /// voltage, or the mid-step value of a sine.
    v_eff: f32,
    extra: Extra<'a>,
}

/// Voltage columns beyond the held one.
#[derive(Clone, Copy)]
enum Extra<'a> {
    None,
    /// Per-mode column of the late part of a step split by a fractional delay, and the
    /// voltage change at the split, V.
    Late(&'a [Vec5; 6], f32),
    /// Per-mode responses to cos ωτ and sin ωτ over the step, and their amplitudes, V.
    Sine(&'a [[Vec5; 2]; 6], f32, f32),
}

impl<'a> Input<'a> {
    fn held(v: f32) -> Input<'a> {
        Input {
            v,
            v_eff: v,
            extra: Extra::None,
        }
    }
}

/// A parameter set turned into the stepped plant: everything precomputed, `step()` does
/// arithmetic only. Build once with [`Plant::new`], then drive any number of
/// [`PlantState`]s with it.
#[derive(Clone, Debug, PartialEq)]
pub struct Plant {
    full: ModeSet,
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
    k_hinge: f32,
    delta: f32,
    tf_m: f32,
    tf_l: f32,
    tach: f32,
    v_max: f32,
    tau_e: f32,
    /// Sub-steps per step when a step is redone (see [`MIN_SUB_STEPS`]).
    sub_steps: u16,
    /// Every step is sub-stepped (the sample period is long against the mechanical periods).
    always_sub: bool,
    delay_steps: u8,
    /// Fraction of a step during which the older command still applies.
    delay_frac: f32,
}

#[allow(clippy::too_many_arguments)]
fn continuous(
    p: &ActuatorParams,
    n: f64,
    k: f64,
    contact: bool,
    motor_free: bool,
    load_free: bool,
) -> (Mat, [[f64; 5]; 3]) {
    let m = &p.motor;
    let e = &p.effects;
    let (r, l, kt, kb, jm) = (
        m.resistance_ohm,
        m.inductance_h,
        m.torque_constant_nm_per_a,
        m.back_emf_v_s_per_rad,
        m.inertia_kg_m2,
    );
    let jl = p.load.inertia_kg_m2;
    let c = e.mesh_damping;
    let mut a = [[0.0f64; 5]; 5];
    a[I][I] = -r / l;
    if motor_free {
        a[I][WM] = -kb / l;
        a[WM][I] = kt / jm;
        a[WM][WM] = -e.motor_viscous / jm;
        a[X][WM] = 1.0 / n;
        if contact {
            // −T_L/N with T_L = k x + c (ωm/N − ωL)
            a[WM][X] = -k / (n * jm);
            a[WM][WM] -= c / (n * n * jm);
            if load_free {
                a[WM][WL] = c / (n * jm);
            }
        }
    }
    if load_free {
        a[WL][WL] = -e.load_viscous / jl;
        a[WL][TH] = -e.hinge_stiffness / jl;
        a[X][WL] = -1.0;
        a[TH][WL] = 1.0;
        if contact {
            a[WL][X] = k / jl;
            a[WL][WL] -= c / jl;
            if motor_free {
                a[WL][WM] = c / (n * jl);
            }
        }
    }
    let mut b = [[0.0f64; 5]; 3];
    b[0][I] = 1.0 / l;
    if motor_free {
        b[1][WM] = 1.0 / jm;
    }
    if load_free {
        b[2][WL] = 1.0 / jl;
    }
    (a, b)
}

fn to_f32(v: f64, field: &'static str) -> Result<f32, ParamError> {
    let f = v as f32;
    if f.is_finite() {
        Ok(f)
    } else {
        Err(ParamError::NotRepresentable(field))
    }
}

fn transition(a: &Mat, b: &[[f64; 5]; 3], tau: f64) -> Result<Transition, ParamError> {
    let (phi, psi) = discretise::exp_and_integral(a, tau);
    let mut t = NO_TRANSITION;
    let (state_cols, input_cols) = t.cols.split_at_mut(5);
    for (r, prow) in phi.iter().enumerate() {
        for (col, pv) in state_cols.iter_mut().zip(prow.iter()) {
            if let Some(slot) = col.get_mut(r) {
                *slot = to_f32(*pv, "sample_period_s")?;
            }
        }
    }
    for (col, bc) in input_cols.iter_mut().zip(b.iter()) {
        let g = discretise::apply(&psi, bc);
        for (slot, gv) in col.iter_mut().zip(g.iter()) {
            *slot = to_f32(*gv, "sample_period_s")?;
        }
    }
    Ok(t)
}

/// Index of the mode "in the gap, motor stuck, load sliding" (its current row serves the
/// both-stuck case).
const MOTOR_STUCK: usize = 1;

const MODE_FLAGS: [(bool, bool, bool); 6] = [
    (false, true, true),
    (false, false, true),
    (false, true, false),
    (true, true, true),
    (true, false, true),
    (true, true, false),
];

fn mode_set(p: &ActuatorParams, n: f64, k: f64, tau: f64) -> Result<ModeSet, ParamError> {
    let mut modes = [NO_TRANSITION; 6];
    for (slot, &(contact, motor_free, load_free)) in modes.iter_mut().zip(MODE_FLAGS.iter()) {
        let (a, b) = continuous(p, n, k, contact, motor_free, load_free);
        *slot = transition(&a, &b, tau)?;
    }
    let decay = libm::exp(-p.motor.resistance_ohm / p.motor.inductance_h * tau);
    Ok(ModeSet {
        modes,
        decay: decay as f32,
        tau: tau as f32,
    })
}

impl Plant {
    /// Validates `params` and precomputes the exact transitions of every mode at the step
    /// and at the sub-step. Costs some ten thousand `f64` operations: do it once, not in a loop.
    pub fn new(params: &ActuatorParams) -> Result<Plant, ParamError> {
        let d = params.derived()?;
        let h = params.sample_period_s;
        let full = mode_set(params, d.n_total, d.k_eq_nm_per_rad, h)?;
        let (sub_steps, always_sub) = sub_step_plan(params, d.n_total, d.k_eq_nm_per_rad);
        let sub = mode_set(params, d.n_total, d.k_eq_nm_per_rad, h / sub_steps as f64)?;

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
        let v_max = if params.effects.voltage_limit > 0.0 {
            to_f32(params.effects.voltage_limit, "effects.voltage_limit")?.min(MAX_ABS_VOLTAGE_V)
        } else {
            MAX_ABS_VOLTAGE_V
        };
        Ok(Plant {
            full,
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
            c_mesh: to_f32(params.effects.mesh_damping, "effects.mesh_damping")?,
            k_hinge: to_f32(params.effects.hinge_stiffness, "effects.hinge_stiffness")?,
            delta: d.delta_rad as f32,
            tf_m: to_f32(m.coulomb_friction_nm, "motor.coulomb_friction_nm")?,
            tf_l: to_f32(params.load.coulomb_friction_nm, "load.coulomb_friction_nm")?,
            tach: to_f32(
                m.tach_v_s_per_rad * (1.0 + params.effects.tach_gain),
                "effects.tach_gain",
            )?,
            v_max,
            tau_e: to_f32(m.inductance_h / m.resistance_ohm, "motor.inductance_h")?,
            sub_steps: sub_steps as u16,
            always_sub,
            delay_steps: whole as u8,
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
    pub fn step(&self, state: &mut PlantState, voltage_v: f32) -> Outputs {
        let cmd = self.saturate(voltage_v);
        let (v_early, v_late) = self.delayed(state, cmd);
        let s0 = state.vec();
        let s1 = self.advance_step(&s0, v_early, v_late);
        state.set(&s1);
        let v_mean = v_early * self.delay_frac + v_late * (1.0 - self.delay_frac);
        let mut out = self.outputs(state);
        out.applied_voltage_v = v_late;
        out.mean_current_a = self.mean_current(&s0, &s1, v_mean);
        out
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
        // Non-finite amplitude or phase, or a sine beyond the limit: the held path handles it
        // (NaN as 0 V, saturation).
        let usable = v_mid.is_finite() && abs(amplitude_v) <= self.v_max;
        if !usable {
            return self.step(state, v_mid);
        }
        let s0 = state.vec();
        let s1 = self.advance_step_sine(&s0, drive, a_cos, a_sin);
        state.set(&s1);
        // Exact mean of the sine over the step.
        let [c1, s1r] = drive.rot_full;
        let v_mean = if drive.omega_h > 0.0 {
            (a_cos * s1r + a_sin * (1.0 - c1)) / drive.omega_h
        } else {
            a_cos
        };
        let mut out = self.outputs(state);
        out.applied_voltage_v = v_mid;
        out.mean_current_a = self.mean_current(&s0, &s1, v_mean);
        out
    }

    /// Outputs of `state` as sampled now (before any step: the initial row of a record).
    pub fn outputs(&self, state: &PlantState) -> Outputs {
        let s = state.vec();
        let gear = self.gear_of(s[X]);
        let applied = state
            .history
            .get(state.head as usize)
            .copied()
            .unwrap_or(0.0);
        Outputs {
            tach_voltage_v: self.tach * s[WM],
            motor_speed_rad_s: s[WM],
            motor_angle_rad: self.n * (s[X] + s[TH]),
            load_speed_rad_s: s[WL],
            load_angle_rad: s[TH],
            current_a: s[I],
            mean_current_a: s[I],
            transmitted_torque_nm: self.transmitted(&s, gear),
            in_contact: gear != 0,
            applied_voltage_v: applied,
        }
    }

    /// Energy stored in the winding, the inertias, the gear spring and the hinge spring, J.
    pub fn stored_energy_j(&self, state: &PlantState) -> f64 {
        let s = state.vec().map(f64::from);
        let dz = if s[X] > f64::from(self.delta) {
            s[X] - f64::from(self.delta)
        } else if s[X] < -f64::from(self.delta) {
            s[X] + f64::from(self.delta)
        } else {
            0.0
        };
        0.5 * (f64::from(self.l) * s[I] * s[I]
            + f64::from(self.jm) * s[WM] * s[WM]
            + f64::from(self.jl) * s[WL] * s[WL]
            + f64::from(self.k) * dz * dz
            + f64::from(self.k_hinge) * s[TH] * s[TH])
    }

    #[inline(always)]
    fn saturate(&self, v: f32) -> f32 {
        if v > self.v_max {
            self.v_max
        } else if v < -self.v_max {
            -self.v_max
        } else if v.is_nan() {
            0.0
        } else {
            v
        }
    }

    /// Pushes the command and returns the voltages applied during the early (fraction
    /// `delay_frac`) and the late part of this step.
    #[inline(always)]
    fn delayed(&self, state: &mut PlantState, cmd: f32) -> (f32, f32) {
        if self.delay_steps == 0 && self.delay_frac == 0.0 {
            return (cmd, cmd);
        }
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

    fn mean_current(&self, s0: &Vec5, s1: &Vec5, v: f32) -> f32 {
        // ∫ i dt over the step from the winding equation: (V h − k_b Δθm − L Δi) / R.
        let d_theta_m = self.n * ((s1[X] - s0[X]) + (s1[TH] - s0[TH]));
        (v * self.h - self.kb * d_theta_m - self.l * (s1[I] - s0[I])) * self.inv_rh
    }

    #[inline(always)]
    fn gear_of(&self, x: f32) -> i8 {
        if x > self.delta {
            1
        } else if x < -self.delta {
            -1
        } else {
            0
        }
    }

    #[inline(always)]
    fn transmitted(&self, s: &Vec5, gear: i8) -> f32 {
        if gear == 0 {
            0.0
        } else {
            let edge = if gear > 0 { self.delta } else { -self.delta };
            self.k * (s[X] - edge) + self.c_mesh * (s[WM] * self.inv_n - s[WL])
        }
    }

    /// Torque driving the motor apart from its own friction (viscous friction is zero at
    /// the instants this is used: at rest or at a velocity reversal).
    #[inline(always)]
    fn motor_drive(&self, s: &Vec5) -> f32 {
        self.kt * s[I] - self.transmitted(s, self.gear_of(s[X])) * self.inv_n
    }

    #[inline(always)]
    fn load_drive(&self, s: &Vec5) -> f32 {
        self.transmitted(s, self.gear_of(s[X])) - self.k_hinge * s[TH]
    }

    #[inline(always)]
    fn motion(speed: f32, drive: f32, friction: f32) -> Motion {
        if speed > 0.0 {
            Motion::Slip(1.0)
        } else if speed < 0.0 {
            Motion::Slip(-1.0)
        } else if drive > friction {
            Motion::Slip(1.0)
        } else if drive < -friction {
            Motion::Slip(-1.0)
        } else {
            Motion::Stuck
        }
    }

    #[inline(always)]
    fn mode_at(&self, s: &Vec5) -> Mode {
        let gear = self.gear_of(s[X]);
        let motor = if s[WM] != 0.0 {
            Self::motion(s[WM], 0.0, 0.0)
        } else {
            Self::motion(0.0, self.motor_drive(s), self.tf_m)
        };
        let load = if s[WL] != 0.0 {
            Self::motion(s[WL], 0.0, 0.0)
        } else {
            Self::motion(0.0, self.load_drive(s), self.tf_l)
        };
        Mode { gear, motor, load }
    }

    /// Constant torques of the mode: friction and the dead-zone offset ±k δ.
    #[inline(always)]
    fn forcing(&self, m: &Mode) -> (f32, f32) {
        let kd = match m.gear {
            0 => 0.0,
            g if g > 0 => self.k * self.delta,
            _ => -self.k * self.delta,
        };
        let fm = match m.motor {
            Motion::Slip(sg) => -sg * self.tf_m,
            Motion::Stuck => 0.0,
        };
        let fl = match m.load {
            Motion::Slip(sg) => -sg * self.tf_l,
            Motion::Stuck => 0.0,
        };
        (fm + kd * self.inv_n, fl - kd)
    }

    /// Exact advance within one mode over the set's step with input `inp`.
    #[inline(always)]
    fn advance(&self, set: &ModeSet, m: &Mode, s: &Vec5, inp: &Input) -> Vec5 {
        let Some(idx) = m.index() else {
            // Both bodies stuck: only the current moves. Its row in a motor-stuck mode is
            // exactly that (no back-EMF), with every voltage column.
            let t = set.modes.get(MOTOR_STUCK).unwrap_or(&NO_TRANSITION);
            let mut i = t.cols[I][I] * s[I] + t.cols[COL_V][I] * inp.v;
            match inp.extra {
                Extra::None => {}
                Extra::Late(cols, dv) => i += cols.get(MOTOR_STUCK).map_or(0.0, |c| c[I]) * dv,
                Extra::Sine(cols, a_cos, a_sin) => {
                    if let Some([gc, gs]) = cols.get(MOTOR_STUCK) {
                        i += gc[I] * a_cos + gs[I] * a_sin;
                    }
                }
            }
            let mut out = *s;
            out[I] = i;
            out[WM] = 0.0;
            out[WL] = 0.0;
            return out;
        };
        let t = set.modes.get(idx).unwrap_or(&NO_TRANSITION);
        let (tm, tl) = self.forcing(m);
        let v = inp.v;
        let c = &t.cols;
        let u = [s[0], s[1], s[2], s[3], s[4], v, tm, tl];
        // Balanced sum per row: short dependency chains, the same tree in every row, and
        // still exactly odd in (s, v, τ). Rows 0–3 as four lanes with `wide` (SSE on
        // x86-64, plain f32 on Cortex-M; the results are bit-identical either way), row 4
        // alone.
        let lanes = |j: usize| -> wide::f32x4 {
            let col = c.get(j).unwrap_or(&[0.0; 5]);
            let x = u.get(j).copied().unwrap_or(0.0);
            wide::f32x4::new([col[0], col[1], col[2], col[3]]) * wide::f32x4::splat(x)
        };
        let q = ((lanes(0) + lanes(1)) + (lanes(2) + lanes(3)))
            + ((lanes(4) + lanes(5)) + (lanes(6) + lanes(7)));
        let q = q.to_array();
        let r4 = ((c[0][4] * u[0] + c[1][4] * u[1]) + (c[2][4] * u[2] + c[3][4] * u[3]))
            + ((c[4][4] * u[4] + c[5][4] * u[5]) + (c[6][4] * u[6] + c[7][4] * u[7]));
        let mut out = [q[0], q[1], q[2], q[3], r4];
        match inp.extra {
            Extra::None => {}
            Extra::Late(cols, dv) => {
                if let Some(col) = cols.get(idx) {
                    for (o, c) in out.iter_mut().zip(col.iter()) {
                        *o += c * dv;
                    }
                }
            }
            Extra::Sine(cols, a_cos, a_sin) => {
                if let Some([gc, gs]) = cols.get(idx) {
                    for ((o, c), sn) in out.iter_mut().zip(gc.iter()).zip(gs.iter()) {
                        *o += c * a_cos + sn * a_sin;
                    }
                }
            }
        }
        if let Motion::Stuck = m.motor {
            out[WM] = 0.0;
        }
        if let Motion::Stuck = m.load {
            out[WL] = 0.0;
        }
        out
    }

    /// One held-voltage step: `v_early` over the first `delay_frac` of it, `v_late` after.
    fn advance_step(&self, s0: &Vec5, v_early: f32, v_late: f32) -> Vec5 {
        let m = self.mode_at(s0);
        let split = self.delay_frac > 0.0;
        let s1 = if split {
            let inp = Input {
                v: v_early,
                v_eff: v_late,
                extra: Extra::Late(&self.late_v, v_late - v_early),
            };
            self.advance(&self.full, &m, s0, &inp)
        } else {
            self.advance(&self.full, &m, s0, &Input::held(v_late))
        };
        if !self.always_sub && self.consistent(&m, s0, &s1) {
            return s1;
        }
        let mut s = *s0;
        let n_sub = self.sub_steps as usize;
        for j in 0..n_sub {
            // Voltage over this sub-step: the time-weighted mean where the delay's split
            // point falls inside it.
            let v = if split {
                let t0 = j as f32 / n_sub as f32;
                let t1 = (j + 1) as f32 / n_sub as f32;
                let f = self.delay_frac;
                if t1 <= f {
                    v_early
                } else if t0 >= f {
                    v_late
                } else {
                    let w = (f - t0) * n_sub as f32;
                    v_early * w + v_late * (1.0 - w)
                }
            } else {
                v_late
            };
            s = self.sub_step(&s, &Input::held(v));
        }
        s
    }

    /// One step under the sinusoidal voltage `a_cos cos ωτ + a_sin sin ωτ`, τ from the
    /// step's start.
    fn advance_step_sine(&self, s0: &Vec5, d: &SineDrive, a_cos: f32, a_sin: f32) -> Vec5 {
        let m = self.mode_at(s0);
        let v_mid = a_cos * d.half_full[0] + a_sin * d.half_full[1];
        let inp = Input {
            v: 0.0,
            v_eff: v_mid,
            extra: Extra::Sine(&d.full, a_cos, a_sin),
        };
        let s1 = self.advance(&self.full, &m, s0, &inp);
        if !self.always_sub && self.consistent(&m, s0, &s1) {
            return s1;
        }
        let mut s = *s0;
        let (mut c, mut sn) = (a_cos, a_sin);
        let [cr, sr] = d.rot_sub;
        for _ in 0..self.sub_steps {
            let v_mid = c * d.half_sub[0] + sn * d.half_sub[1];
            let inp = Input {
                v: 0.0,
                v_eff: v_mid,
                extra: Extra::Sine(&d.sub, c, sn),
            };
            s = self.sub_step(&s, &inp);
            // Move the phase origin to the next sub-step's start.
            (c, sn) = (c * cr + sn * sr, sn * cr - c * sr);
        }
        s
    }

    /// Does the whole-step result agree with the mode it was computed in?
    #[inline(always)]
    fn consistent(&self, m: &Mode, s0: &Vec5, s1: &Vec5) -> bool {
        if self.gear_of(s1[X]) != m.gear || self.grazes(m.gear, s0, s1) {
            return false;
        }
        let motor_ok = match m.motor {
            Motion::Slip(sg) => sg * s1[WM] > 0.0,
            Motion::Stuck => abs(self.motor_drive(s1)) <= self.tf_m,
        };
        let load_ok = match m.load {
            Motion::Slip(sg) => sg * s1[WL] > 0.0,
            Motion::Stuck => abs(self.load_drive(s1)) <= self.tf_l,
        };
        motor_ok && load_ok
    }

    /// Whether the twist may have crossed a gap edge and come back within the step: the
    /// cubic Hermite interpolant of x (ends and slopes) is checked at its turning point.
    #[inline(always)]
    fn grazes(&self, gear: i8, s0: &Vec5, s1: &Vec5) -> bool {
        let m0 = (s0[WM] * self.inv_n - s0[WL]) * self.h;
        let m1 = (s1[WM] * self.inv_n - s1[WL]) * self.h;
        let turning = (m0 > 0.0 && m1 < 0.0) || (m0 < 0.0 && m1 > 0.0);
        if !turning {
            return false;
        }
        let t = fraction(m0, m0 - m1);
        let t2 = t * t;
        let t3 = t2 * t;
        let p = (2.0 * t3 - 3.0 * t2 + 1.0) * s0[X]
            + (t3 - 2.0 * t2 + t) * m0
            + (-2.0 * t3 + 3.0 * t2) * s1[X]
            + (t3 - t2) * m1;
        match gear {
            1 => p < self.delta,
            -1 => p > -self.delta,
            _ => p > self.delta || p < -self.delta,
        }
    }

    /// One exact sub-step with event location and impulse correction.
    fn sub_step(&self, s0: &Vec5, inp: &Input) -> Vec5 {
        let hs = self.sub.tau;
        let v = inp.v_eff;
        let m = self.mode_at(s0);
        let mut s1 = self.advance(&self.sub, &m, s0, inp);
        let motor_free = !matches!(m.motor, Motion::Stuck);
        let load_free = !matches!(m.load, Motion::Stuck);

        // Gap edge crossed: the mode's transition applied its own contact law over the
        // whole sub-step. Replace that impulse by the true dead-zone impulse, both taken along
        // x linear over the sub-step. The dead-zone torque is continuous at the edge, so this
        // is exact to second order in the time past the edge (third after the position
        // correction); it covers entering, leaving, and passing through the whole gap.
        let g1 = self.gear_of(s1[X]);
        if g1 != m.gear {
            let true_impulse = self.dead_zone_impulse(s0[X], s1[X], hs);
            let mode_impulse = if m.gear == 0 {
                0.0
            } else {
                let b = if m.gear > 0 { self.delta } else { -self.delta };
                self.k * (0.5 * (s0[X] + s1[X]) - b) * hs + self.c_mesh * (s1[X] - s0[X])
            };
            let p = true_impulse - mode_impulse;
            // Time from the first edge crossing to the end of the sub-step.
            let edge = if m.gear == 0 {
                if g1 > 0 {
                    self.delta
                } else {
                    -self.delta
                }
            } else if m.gear > 0 {
                self.delta
            } else {
                -self.delta
            };
            let tau = (1.0 - fraction(edge - s0[X], s1[X] - s0[X])) * hs;
            let dwm = if motor_free {
                -p / (self.n * self.jm)
            } else {
                0.0
            };
            let dwl = if load_free { p / self.jl } else { 0.0 };
            s1[WM] += dwm;
            s1[WL] += dwl;
            s1[X] += (dwm / self.n - dwl) * tau * (1.0 / 3.0);
            s1[TH] += dwl * tau * (1.0 / 3.0);
        }

        match m.motor {
            Motion::Slip(sg) => {
                if sg * s1[WM] <= 0.0 {
                    let alpha = fraction(s0[WM], s0[WM] - s1[WM]);
                    let tau = (1.0 - alpha) * hs;
                    let t0 = self.motor_drive(s0);
                    let t1 = self.motor_drive(&s1);
                    let t_star = t0 + alpha * (t1 - t0);
                    let w = s1[WM];
                    if abs(t_star) <= self.tf_m {
                        s1[X] -= w * tau * 0.5 / self.n;
                        s1[WM] = 0.0;
                    } else {
                        let dw = 2.0 * self.tf_m * sg * tau / self.jm;
                        let w_new = w + dw;
                        if sg * w_new > 0.0 {
                            s1[X] -= w * tau * 0.5 / self.n;
                            s1[WM] = 0.0;
                        } else {
                            s1[WM] = w_new;
                            s1[X] += dw * tau * 0.5 / self.n;
                        }
                    }
                }
            }
            Motion::Stuck => {
                let t1 = self.motor_drive(&s1);
                if abs(t1) > self.tf_m {
                    let dw = self.motor_breakaway(s0, &s1, t1, v, hs);
                    s1[WM] = dw.0;
                    s1[X] += dw.1 / self.n;
                }
            }
        }

        match m.load {
            Motion::Slip(sg) => {
                if sg * s1[WL] <= 0.0 {
                    let alpha = fraction(s0[WL], s0[WL] - s1[WL]);
                    let tau = (1.0 - alpha) * hs;
                    let t0 = self.load_drive(s0);
                    let t1 = self.load_drive(&s1);
                    let t_star = t0 + alpha * (t1 - t0);
                    let w = s1[WL];
                    if abs(t_star) <= self.tf_l {
                        s1[X] += w * tau * 0.5;
                        s1[TH] -= w * tau * 0.5;
                        s1[WL] = 0.0;
                    } else {
                        let dw = 2.0 * self.tf_l * sg * tau / self.jl;
                        let w_new = w + dw;
                        if sg * w_new > 0.0 {
                            s1[X] += w * tau * 0.5;
                            s1[TH] -= w * tau * 0.5;
                            s1[WL] = 0.0;
                        } else {
                            s1[WL] = w_new;
                            s1[X] -= dw * tau * 0.5;
                            s1[TH] += dw * tau * 0.5;
                        }
                    }
                }
            }
            Motion::Stuck => {
                let t1 = self.load_drive(&s1);
                if abs(t1) > self.tf_l {
                    let sg = if t1 > 0.0 { 1.0 } else { -1.0 };
                    let t0 = self.load_drive(s0);
                    let alpha = fraction(self.tf_l - sg * t0, sg * (t1 - t0));
                    let tau = (1.0 - alpha) * hs;
                    // Net torque grows linearly from 0 at breakaway to |t1| − T_f.
                    let dw = sg * (sg * t1 - self.tf_l) * tau * 0.5 / self.jl;
                    s1[WL] = dw;
                    s1[X] -= dw * tau * (1.0 / 3.0);
                    s1[TH] += dw * tau * (1.0 / 3.0);
                }
            }
        }
        s1
    }

    /// ∫ T_L dt over a sub-step of length `hs` along x linear from `x0` to `x1`: the
    /// spring part over the stretches beyond ±δ and the mesh damping part c Δx over them.
    fn dead_zone_impulse(&self, x0: f32, x1: f32, hs: f32) -> f32 {
        // One flank: part of [x0, x1] beyond `edge` on side `side` (+1: x > edge).
        let flank = |edge: f32, side: f32| -> f32 {
            let (a, b) = (side * (x0 - edge), side * (x1 - edge));
            if a <= 0.0 && b <= 0.0 {
                return 0.0;
            }
            // Fraction of the sub-step spent beyond the edge and the penetrations at its ends.
            let (frac, pa, pb) = if a > 0.0 && b > 0.0 {
                (1.0, a, b)
            } else if a > 0.0 {
                (fraction(a, a - b), a, 0.0)
            } else {
                (fraction(b, b - a), 0.0, b)
            };
            side * (self.k * 0.5 * (pa + pb) * frac * hs + self.c_mesh * (pb - pa))
        };
        flank(self.delta, 1.0) + flank(-self.delta, -1.0)
    }

    /// Motor speed at the end of a sub-step in which it broke away from static friction,
    /// and the motor angle it gained, rad (at the motor). The breakaway instant follows the
    /// exponential rise of the current `i(t) = i∞ + (i0 − i∞) e^{−t/τe}` (the motor was
    /// stuck, so there is no back-EMF); the gear torque is taken as its sub-step mean.
    fn motor_breakaway(&self, s0: &Vec5, s1: &Vec5, t1: f32, v: f32, hs: f32) -> (f32, f32) {
        let sg = if t1 > 0.0 { 1.0 } else { -1.0 };
        let tl_mean = 0.5
            * (self.transmitted(s0, self.gear_of(s0[X]))
                + self.transmitted(s1, self.gear_of(s1[X])));
        let i_inf = v / self.r;
        // σ·drive(t) = a + b e^{−t/τe}
        let a = sg * (self.kt * i_inf - tl_mean / self.n);
        let b = sg * self.kt * (s0[I] - i_inf);
        let excess_end = sg * t1 - self.tf_m;
        let (t_star, e_star) = {
            let r = (self.tf_m - a) / b;
            if b != 0.0 && r > 0.0 && r < 1.0 && a > self.tf_m {
                (-self.tau_e * math::ln(r), r)
            } else {
                // Not driven by the current's rise (the gear torque grew): linear.
                let t0 = sg * self.motor_drive(s0);
                let alpha = fraction(self.tf_m - t0, sg * t1 - t0);
                let t = alpha * hs;
                (t, math::exp(-t / self.tau_e))
            }
        };
        let tau = hs - t_star;
        if tau.is_nan() || tau <= 0.0 {
            return (0.0, 0.0);
        }
        let impulse = if b != 0.0 && a > self.tf_m {
            (a - self.tf_m) * tau + b * self.tau_e * (e_star - self.sub.decay)
        } else {
            excess_end * tau * 0.5
        };
        let w = sg * impulse / self.jm;
        (w, w * tau * 0.5)
    }
}

/// Exact response of every mode to a continuous sinusoidal voltage at one frequency, for
/// [`Plant::step_sine`].
///
/// A stepped-sine frequency response driven through the zero-order hold measures the
/// sampled, held system: its notch sits about 1 Hz above the closed-form anti-resonance of
/// the reference actuator (aliasing of the hold's images). The paper's simulation drives a
/// continuous sine and samples the output; this drive does the same, exactly: the sine is
/// generated by an oscillator appended to each mode's state and the augmented system is
/// discretised like the rest. Build it from the same parameters as the plant.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SineDrive {
    /// Per mode: responses over a step to cos ωτ and sin ωτ (unit amplitude).
    full: [[Vec5; 2]; 6],
    /// The same over a sub-step.
    sub: [[Vec5; 2]; 6],
    /// cos and sin of ω h_sub.
    rot_sub: [f32; 2],
    /// cos and sin of ω h_sub / 2.
    half_sub: [f32; 2],
    /// cos and sin of ω h / 2.
    half_full: [f32; 2],
    /// cos and sin of ω h.
    rot_full: [f32; 2],
    /// ω · input_delay, rad.
    delay_phase: f32,
    /// ω h, rad.
    omega_h: f32,
    /// Frequency, Hz.
    freq_hz: f32,
}

impl SineDrive {
    /// Precomputes the drive at `freq_hz` (Hz, finite and > 0) for the plant built from
    /// `params`. Twelve exponentials of a 7 × 7 matrix: do it once per frequency.
    pub fn new(params: &ActuatorParams, freq_hz: f64) -> Result<SineDrive, ParamError> {
        if !freq_hz.is_finite() {
            return Err(ParamError::NonFinite("sine.freq_hz"));
        }
        if freq_hz <= 0.0 {
            return Err(ParamError::NonPositive("sine.freq_hz"));
        }
        let d = params.derived()?;
        let h = params.sample_period_s;
        let w = 2.0 * core::f64::consts::PI * freq_hz;
        let columns = |tau: f64| -> Result<[[Vec5; 2]; 6], ParamError> {
            let mut out = [[[0.0f32; 5]; 2]; 6];
            for (slot, &(contact, mf, lf)) in out.iter_mut().zip(MODE_FLAGS.iter()) {
                let (a, b) = continuous(params, d.n_total, d.k_eq_nm_per_rad, contact, mf, lf);
                // [s; c; q]' = [[A, B_V c], …]: c = cos ωτ, q = sin ωτ from (c, q) = (1, 0).
                let mut aug = [[0.0f64; 7]; 7];
                for (ar, row) in aug.iter_mut().zip(a.iter()) {
                    for (av, v) in ar.iter_mut().zip(row.iter()) {
                        *av = *v;
                    }
                }
                for (ar, bv) in aug.iter_mut().zip(b[0].iter()) {
                    ar[5] = *bv;
                }
                aug[5][6] = -w;
                aug[6][5] = w;
                let (e, _) = discretise::exp_and_integral(&aug, tau);
                // Column 5: input cos ωτ. Column 6 starts the oscillator at (0, 1), whose
                // c component is −sin ωτ.
                let [gc, gs] = slot;
                for ((c, sn), row) in gc.iter_mut().zip(gs.iter_mut()).zip(e.iter()) {
                    *c = to_f32(row[5], "sine.freq_hz")?;
                    *sn = to_f32(-row[6], "sine.freq_hz")?;
                }
            }
            Ok(out)
        };
        let (n_sub, _) = sub_step_plan(params, d.n_total, d.k_eq_nm_per_rad);
        let hs = h / n_sub as f64;
        let cs = |x: f64| [libm::cos(x) as f32, libm::sin(x) as f32];
        Ok(SineDrive {
            full: columns(h)?,
            sub: columns(hs)?,
            rot_sub: cs(w * hs),
            half_sub: cs(0.5 * w * hs),
            half_full: cs(0.5 * w * h),
            rot_full: cs(w * h),
            delay_phase: (w * params.effects.input_delay) as f32,
            omega_h: (w * h) as f32,
            freq_hz: freq_hz as f32,
        })
    }

    /// Frequency, Hz.
    pub fn frequency_hz(&self) -> f32 {
        self.freq_hz
    }

    /// Phase advance per sample period ω h, rad.
    pub fn phase_step_rad(&self) -> f32 {
        self.omega_h
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
