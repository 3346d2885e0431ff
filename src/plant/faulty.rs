//! The fault path of the step: the context a fault set gives a step (its values clamped to
//! their physical range), the voltage of an open winding, and the last-resort bound on the
//! state. [`Plant::step`] never reaches any of it (`faults` is `None` there at compile time).

use super::modes::{Input, Vec5};
use super::step::Ctx;
use super::{Plant, I, MAX_ABS_FAULT_STATE, TH, WM, X};
use crate::faults::{
    Jam, PlantFaults, MAX_BACKLASH_WEAR_DEG, MAX_FAULT_ANGLE_RAD, MAX_FRICTION_FACTOR,
    MAX_LOAD_TORQUE_NM,
};
use crate::math::{self, abs};

/// `x` if finite, else `default`; then clamped to [lo, hi].
fn sane(x: f32, default: f32, lo: f32, hi: f32) -> f32 {
    let x = if x.is_finite() { x } else { default };
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

/// The angle of a [`Jam::AtAngle`] as the step uses it: clamped to ±[`MAX_FAULT_ANGLE_RAD`],
/// `None` (no block) when not finite.
#[inline(always)]
pub(super) fn jam_angle(a: f32) -> Option<f32> {
    if a.is_finite() {
        Some(a.clamp(-MAX_FAULT_ANGLE_RAD, MAX_FAULT_ANGLE_RAD))
    } else {
        None
    }
}

/// Clamps every variable of a state after a faulty step to ±[`MAX_ABS_FAULT_STATE`], a
/// non-finite one to 0. Out of line: it runs on the fault path only.
#[inline(never)]
pub(super) fn bound_state(s: &mut Vec5) {
    for v in s.iter_mut() {
        *v = sane(*v, 0.0, -MAX_ABS_FAULT_STATE, MAX_ABS_FAULT_STATE);
    }
}

impl Plant {
    /// The context of a step from state `s` under `f`. Out-of-range fault values are
    /// clamped to their physical range (NaN to "no fault"), so no input makes the step fail.
    #[inline(always)]
    pub(super) fn context(&self, f: &PlantFaults, s: &Vec5) -> Ctx {
        let mut c = self.nominal_at(s);
        if *f == PlantFaults::NONE {
            return c;
        }
        let wear = sane(f.extra_backlash_deg, 0.0, 0.0, MAX_BACKLASH_WEAR_DEG);
        c.delta += wear * (core::f32::consts::PI / 360.0);
        c.kd = self.k * c.delta;
        let ff = sane(f.friction_factor, 1.0, 0.0, MAX_FRICTION_FACTOR);
        c.tf_m *= ff;
        c.tf_l *= ff;
        c.ts_m *= ff;
        c.ts_l *= ff;
        let load = sane(
            f.load_torque_nm,
            0.0,
            -MAX_LOAD_TORQUE_NM,
            MAX_LOAD_TORQUE_NM,
        );
        // With gravity, its held remainder (`nominal_at`) is already there.
        c.t_load = if c.ext { c.t_load + load } else { load };
        c.ext = true;
        c.jammed = match f.jam {
            Jam::None => false,
            Jam::Here => true,
            // Snapped exactly onto the angle when it was reached (see `step_with_faults`).
            Jam::AtAngle(a) => jam_angle(a) == Some(s[TH]),
        };
        if let Some(t) = f.broken_tooth {
            let loss = sane(t.torque_loss, 0.0, 0.0, 1.0);
            let half = 0.5 * sane(t.width_rad, 0.0, 0.0, core::f32::consts::TAU);
            let centre = sane(t.angle_rad, 0.0, -MAX_FAULT_ANGLE_RAD, MAX_FAULT_ANGLE_RAD);
            let rel = math::wrap_angle(s[TH] - centre);
            if loss > 0.0 && abs(rel) < half {
                // The missing tooth carries `loss` of the gear torque: take it off both ends.
                let lost = loss * self.transmitted(&c, s, self.gear_of(&c, s[X]));
                c.t_load -= lost;
                c.t_motor += lost * self.inv_n;
                c.lost = lost;
            }
        }
        c
    }

    /// Terminal voltage of an open winding over a step from `s0` (current zero): the held
    /// voltage under which the step, in its starting mode, passes no net charge. The winding
    /// then does no net work over the step, and resetting the current to zero at its end
    /// only takes energy out. Holding the back-EMF of the step's start (`k_b ωm(0)`)
    /// instead acts as a speed hold, which pumps energy in at every step when the
    /// electromechanical mode is fast against the step (√(k_t k_b / (L J_m)) h ≫ 1; found
    /// by the fuzzer, the motor speed grew a hundredfold per step). The charge
    /// R ∫i dt = V h − k_b Δθm − L Δi is affine in V; its slope is the charge passed by the
    /// unit-voltage response from rest, positive for a passive winding.
    pub(super) fn open_voltage(&self, c: &Ctx, s0: &Vec5) -> f32 {
        let m = self.mode_at(c, s0);
        let f = self.forcing(c, &m);
        let free = Self::advance(&self.full, &m, f, s0, &Input::held(0.0));
        let unit = Self::advance(&self.full, &m, (0.0, 0.0), &[0.0; 5], &Input::held(1.0));
        let charge = |di: f32, dx: f32, dth: f32, v: f32| {
            v * self.h - self.kb * self.n * (dx + dth) - self.l * di
        };
        let q0 = charge(free[I] - s0[I], free[X] - s0[X], free[TH] - s0[TH], 0.0);
        let q1 = charge(unit[I], unit[X], unit[TH], 1.0);
        let v = -q0 / q1;
        if q1 > 0.0 && v.is_finite() {
            v
        } else {
            self.kb * s0[WM]
        }
    }
}
