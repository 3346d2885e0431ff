//! The plant's modes and their exact transitions, built once from the parameters.

use super::{I, MAX_SUB_STEPS, MIN_SUB_STEPS, TH, WL, WM, X};
use crate::discretise::{self, Mat};
use crate::error::ParamError;
use crate::params::ActuatorParams;

/// Plant state as an array: i, ωm, ωL, x, θL.
pub(super) type Vec5 = [f32; 5];

/// Sub-step length as a fraction of the fastest mechanical period: events are located
/// within a sub-step and corrected to third order in its length.
pub(super) const SUB_STEP_PERIOD_FRACTION: f64 = 0.013;

/// Beyond this many fastest periods per step, the gears may touch and part within one
/// step without the whole-step check seeing it, so every step is sub-stepped.
pub(super) const WHOLE_STEP_PERIOD_FRACTION: f64 = 0.15;

/// How a step that needs sub-steps is taken ([`sub_step_plan`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SubStepPlan {
    /// Sub-steps per step.
    pub(super) n_sub: usize,
    /// Every step is sub-stepped: the step is longer than [`WHOLE_STEP_PERIOD_FRACTION`] of
    /// the fastest period, so the whole-step check could miss an event.
    pub(super) always: bool,
    /// Sub-steps per block, 0 for none: each block of this many sub-steps is first tried
    /// whole under the whole-step check, and only a block that fails it is sub-stepped. Half
    /// the sub-steps on the whole-step path; on the always-sub-stepped path the most
    /// sub-steps that stay within [`WHOLE_STEP_PERIOD_FRACTION`] of the fastest period,
    /// spread evenly over the step (the check is then as safe over a block as over a
    /// short whole step).
    pub(super) block: usize,
}

/// Sub-steps per step for these parameters, whether every step must be sub-stepped, and
/// the blocks a sub-stepped step is first tried in.
///
/// The fastest mechanical frequency is that of the gears in contact with both bodies free,
/// stiffened by the spring to ground (hinge and linearised gravity, `k_g`):
/// `√(k (1/J_L + 1/(N² J_m)) + k_g/J_L) / 2π` (eq. 17b with the hinge). The reference
/// actuator at 0.5 ms gets 8 sub-steps, the whole-step path and two blocks (halves); at
/// 5.625 ms (a bench record's period) 90 sub-steps in blocks of 10, every step
/// sub-stepped.
pub(super) fn sub_step_plan(p: &ActuatorParams, n: f64, k: f64) -> SubStepPlan {
    let jm = p.motor.inertia_kg_m2;
    let jl = p.load.inertia_kg_m2;
    let w2 = k * (1.0 / jl + 1.0 / (n * n * jm)) + p.ground_stiffness_nm_per_rad() / jl;
    let f_max = libm::sqrt(w2) / (2.0 * core::f64::consts::PI);
    let periods = p.sample_period_s * f_max;
    let wanted = libm::ceil(periods / SUB_STEP_PERIOD_FRACTION);
    let n_sub = if wanted.is_finite() {
        (wanted as usize).clamp(MIN_SUB_STEPS, MAX_SUB_STEPS)
    } else {
        MAX_SUB_STEPS
    };
    let always = periods > WHOLE_STEP_PERIOD_FRACTION;
    // Sub-steps that fit in the whole-step check's span.
    let fit = libm::floor(WHOLE_STEP_PERIOD_FRACTION * n_sub as f64 / periods);
    let (n_sub, block) = if !always {
        (n_sub, if n_sub % 2 == 0 { n_sub / 2 } else { 0 })
    } else if fit.is_nan() || fit < 2.0 {
        (n_sub, 0)
    } else {
        // As many blocks as the fit needs, of equal length; the sub-steps are rounded up to
        // fill them (shorter, never longer) when that stays within the cap, else the last
        // block is shorter and sub-stepped.
        let blocks = n_sub.div_ceil((fit as usize).min(n_sub));
        let block = n_sub.div_ceil(blocks);
        if blocks * block <= MAX_SUB_STEPS {
            (blocks * block, block)
        } else {
            (n_sub, block)
        }
    };
    SubStepPlan {
        n_sub,
        always,
        block,
    }
}

/// Motion state of one body within a mode: stuck by static friction, or sliding with the
/// given direction (the sign of its friction torque's opposite).
#[derive(Clone, Copy, PartialEq, Debug)]
pub(super) enum Motion {
    Stuck,
    Slip(f32),
}

#[derive(Clone, Copy, Debug)]
pub(super) struct Mode {
    /// +1 / −1 in contact on that flank, 0 in the gap.
    pub(super) gear: i8,
    pub(super) motor: Motion,
    pub(super) load: Motion,
    /// [`Mode::index`], 6 when both bodies are stuck: derived once per mode, not per use.
    idx: u8,
}

/// Exact transition of one mode over one (sub-)step: `s' = Φ s + Γ [V, τ_m, τ_L]`, with
/// τ_m, τ_L constant torques on the motor and the load. Stored by columns (`cols[j][r]`:
/// Φ's columns 0–4, then Γ's), so that the product runs down contiguous columns and
/// vectorises where the target has SIMD.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Transition {
    pub(super) cols: [Vec5; 8],
}

pub(super) const NO_TRANSITION: Transition = Transition {
    cols: [[0.0; 5]; 8],
};

/// Column of the held voltage in a [`Transition`].
pub(super) const COL_V: usize = 5;

/// Column of a [`Transition`] (and slot of the product's input vector): the five states,
/// then the held voltage and the constant torques on the motor and on the load.
const C_I: usize = 0;
const C_WM: usize = 1;
const C_WL: usize = 2;
const C_X: usize = 3;
const C_TH: usize = 4;
const C_V: usize = COL_V;
const C_TM: usize = 6;
const C_TL: usize = 7;

/// Both bodies sliding, gears apart. The motor side (i, ωm) and the load side (ωL, θL) are
/// decoupled, and nothing depends on the twist x (its own coefficient is exactly 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct FreeGap {
    /// Rows i and ωm over [i, ωm, V, τm].
    pub(super) motor: [[f32; 4]; 2],
    /// Rows ωL and θL over [ωL, θL, τL].
    pub(super) load: [[f32; 3]; 2],
    /// Row x over [i, ωm, ωL, θL, V, τm, τL].
    pub(super) x: [f32; 7],
}

/// Motor stuck, gears apart: the current decays alone (no back-EMF), the load moves on its
/// own, the twist follows the load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct MotorStuckGap {
    /// Row i over [i, V].
    pub(super) i: [f32; 2],
    /// Rows ωL, θL and x over [ωL, θL, τL] (x's own coefficient is exactly 1).
    pub(super) load: [[f32; 3]; 3],
}

/// Motor stuck, gears in contact: the current decays alone, the load side (ωL, x, θL) moves
/// against the gear spring.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct MotorStuckContact {
    /// Row i over [i, V].
    pub(super) i: [f32; 2],
    /// Rows ωL, x and θL over [ωL, x, θL, τL].
    pub(super) load: [[f32; 4]; 3],
}

/// Load stuck, gears apart: θL is held, nothing depends on x (its own coefficient is 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct LoadStuckGap {
    /// Rows i, ωm and x over [i, ωm, V, τm].
    pub(super) rows: [[f32; 4]; 3],
}

/// Load stuck, gears in contact: θL is held, the motor side (i, ωm, x) moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct LoadStuckContact {
    /// Rows i, ωm and x over [i, ωm, x, V, τm].
    pub(super) rows: [[f32; 5]; 3],
}

/// The six modes with dynamics over one (sub-)step, indexed (see [`Mode::index`])
/// `contact·3 + {both slide, motor stuck, load stuck}`; with both bodies stuck only the
/// current moves, which is done in closed form.
///
/// Only the entries a mode's structure lets be non-zero are kept: a stuck body's speed row
/// and column and its torque column vanish, and apart from the gears the motor and the
/// load sides are decoupled. The exponential and its integral are computed from sums of
/// products in which those entries are sums of exact zeros, so they are exactly 0 (and the
/// kept diagonal ones exactly 1) in the full matrices too; `modes::tests` checks it. A
/// product over the kept entries therefore equals the full product (up to the sign of a
/// zero result), and costs a third less storage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ModeSet {
    pub(super) free_gap: FreeGap,
    pub(super) motor_stuck_gap: MotorStuckGap,
    pub(super) load_stuck_gap: LoadStuckGap,
    /// Both sliding in contact: everything couples, the full transition.
    pub(super) free_contact: Transition,
    pub(super) motor_stuck_contact: MotorStuckContact,
    pub(super) load_stuck_contact: LoadStuckContact,
    /// e^{−R τ / L} over this set's step τ, for the both-stuck case.
    pub(super) decay: f32,
    /// Step length τ, s.
    pub(super) tau: f32,
}

/// Entry (row, col) of a full transition.
fn at(t: &Transition, row: usize, col: usize) -> f32 {
    t.cols
        .get(col)
        .and_then(|c| c.get(row))
        .copied()
        .unwrap_or(0.0)
}

/// Entries of `row` at `cols`.
fn pick<const K: usize>(t: &Transition, row: usize, cols: [usize; K]) -> [f32; K] {
    cols.map(|c| at(t, row, c))
}

impl ModeSet {
    /// Keeps the structurally non-zero entries of the six full transitions (in the order of
    /// [`MODE_FLAGS`]).
    fn compact(t: &[Transition; 6], decay: f32, tau: f32) -> ModeSet {
        let [fg, msg, lsg, fc, msc, lsc] = t;
        ModeSet {
            free_gap: FreeGap {
                motor: [
                    pick(fg, I, [C_I, C_WM, C_V, C_TM]),
                    pick(fg, WM, [C_I, C_WM, C_V, C_TM]),
                ],
                load: [
                    pick(fg, WL, [C_WL, C_TH, C_TL]),
                    pick(fg, TH, [C_WL, C_TH, C_TL]),
                ],
                x: pick(fg, X, [C_I, C_WM, C_WL, C_TH, C_V, C_TM, C_TL]),
            },
            motor_stuck_gap: MotorStuckGap {
                i: pick(msg, I, [C_I, C_V]),
                load: [
                    pick(msg, WL, [C_WL, C_TH, C_TL]),
                    pick(msg, TH, [C_WL, C_TH, C_TL]),
                    pick(msg, X, [C_WL, C_TH, C_TL]),
                ],
            },
            load_stuck_gap: LoadStuckGap {
                rows: [
                    pick(lsg, I, [C_I, C_WM, C_V, C_TM]),
                    pick(lsg, WM, [C_I, C_WM, C_V, C_TM]),
                    pick(lsg, X, [C_I, C_WM, C_V, C_TM]),
                ],
            },
            free_contact: *fc,
            motor_stuck_contact: MotorStuckContact {
                i: pick(msc, I, [C_I, C_V]),
                load: [
                    pick(msc, WL, [C_WL, C_X, C_TH, C_TL]),
                    pick(msc, X, [C_WL, C_X, C_TH, C_TL]),
                    pick(msc, TH, [C_WL, C_X, C_TH, C_TL]),
                ],
            },
            load_stuck_contact: LoadStuckContact {
                rows: [
                    pick(lsc, I, [C_I, C_WM, C_X, C_V, C_TM]),
                    pick(lsc, WM, [C_I, C_WM, C_X, C_V, C_TM]),
                    pick(lsc, X, [C_I, C_WM, C_X, C_V, C_TM]),
                ],
            },
            decay,
            tau,
        }
    }
}

impl Mode {
    #[inline(always)]
    pub(super) fn new(gear: i8, motor: Motion, load: Motion) -> Mode {
        let c = if gear != 0 { 3 } else { 0 };
        let idx = match (motor, load) {
            (Motion::Slip(_), Motion::Slip(_)) => c,
            (Motion::Stuck, Motion::Slip(_)) => c + 1,
            (Motion::Slip(_), Motion::Stuck) => c + 2,
            (Motion::Stuck, Motion::Stuck) => 6,
        };
        Mode {
            gear,
            motor,
            load,
            idx,
        }
    }

    /// Index into the six modes with dynamics; `None` when both bodies are stuck.
    #[inline(always)]
    pub(super) fn index(&self) -> Option<usize> {
        if self.idx < 6 {
            Some(self.idx as usize)
        } else {
            None
        }
    }
}

/// Voltage input over one (sub-)step.
#[derive(Clone, Copy)]
pub(super) struct Input<'a> {
    /// Weight of the held-voltage column Γ_V, V.
    pub(super) v: f32,
    /// Voltage used by the closed forms (both bodies stuck, motor breakaway), V: the held
    /// voltage, or the mid-step value of a sine.
    pub(super) v_eff: f32,
    pub(super) extra: Extra<'a>,
}

/// Voltage columns beyond the held one.
#[derive(Clone, Copy)]
pub(super) enum Extra<'a> {
    None,
    /// Per-mode column of the late part of a step split by a fractional delay, and the
    /// voltage change at the split, V.
    Late(&'a [Vec5; 6], f32),
    /// Per-mode responses to cos ωτ and sin ωτ over the step, and their amplitudes, V.
    Sine(&'a [[Vec5; 2]; 6], f32, f32),
}

impl<'a> Input<'a> {
    pub(super) fn held(v: f32) -> Input<'a> {
        Input {
            v,
            v_eff: v,
            extra: Extra::None,
        }
    }
}

#[allow(clippy::too_many_arguments)]
pub(super) fn continuous(
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
        // The hinge spring and gravity's linear part −T θ_L (the rest of −T sin θ_L is a
        // torque held over the step: `Plant::nominal_at`).
        a[WL][TH] = -p.ground_stiffness_nm_per_rad() / jl;
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

pub(super) fn to_f32(v: f64, field: &'static str) -> Result<f32, ParamError> {
    let f = v as f32;
    if f.is_finite() {
        Ok(f)
    } else {
        Err(ParamError::NotRepresentable(field))
    }
}

pub(super) fn transition(a: &Mat, b: &[[f64; 5]; 3], tau: f64) -> Result<Transition, ParamError> {
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
pub(super) const MOTOR_STUCK: usize = 1;

pub(super) const MODE_FLAGS: [(bool, bool, bool); 6] = [
    (false, true, true),
    (false, false, true),
    (false, true, false),
    (true, true, true),
    (true, false, true),
    (true, true, false),
];

pub(super) fn mode_set(
    p: &ActuatorParams,
    n: f64,
    k: f64,
    tau: f64,
) -> Result<ModeSet, ParamError> {
    let mut modes = [NO_TRANSITION; 6];
    for (slot, &(contact, motor_free, load_free)) in modes.iter_mut().zip(MODE_FLAGS.iter()) {
        let (a, b) = continuous(p, n, k, contact, motor_free, load_free);
        *slot = transition(&a, &b, tau)?;
    }
    let decay = libm::exp(-p.motor.resistance_ohm / p.motor.inductance_h * tau);
    Ok(ModeSet::compact(&modes, decay as f32, tau as f32))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::REFERENCE;

    /// The full transition a compact mode stands for: kept entries, unit diagonal entries
    /// the product takes as 1, zeros elsewhere. `None` for a stuck body's speed row (the
    /// step sets it to exactly zero).
    fn expand(set: &ModeSet, idx: usize) -> [[Option<f32>; 8]; 5] {
        let mut m = [[Some(0.0f32); 8]; 5];
        let mut put = |row: usize, cols: &[usize], vals: &[f32]| {
            for (&c, &v) in cols.iter().zip(vals) {
                m[row][c] = Some(v);
            }
        };
        match idx {
            0 => {
                let t = &set.free_gap;
                put(I, &[C_I, C_WM, C_V, C_TM], &t.motor[0]);
                put(WM, &[C_I, C_WM, C_V, C_TM], &t.motor[1]);
                put(WL, &[C_WL, C_TH, C_TL], &t.load[0]);
                put(TH, &[C_WL, C_TH, C_TL], &t.load[1]);
                put(X, &[C_I, C_WM, C_WL, C_TH, C_V, C_TM, C_TL], &t.x);
                put(X, &[C_X], &[1.0]);
            }
            1 => {
                let t = &set.motor_stuck_gap;
                put(I, &[C_I, C_V], &t.i);
                put(WL, &[C_WL, C_TH, C_TL], &t.load[0]);
                put(TH, &[C_WL, C_TH, C_TL], &t.load[1]);
                put(X, &[C_WL, C_TH, C_TL], &t.load[2]);
                put(X, &[C_X], &[1.0]);
                m[WM] = [None; 8];
            }
            2 => {
                let t = &set.load_stuck_gap;
                put(I, &[C_I, C_WM, C_V, C_TM], &t.rows[0]);
                put(WM, &[C_I, C_WM, C_V, C_TM], &t.rows[1]);
                put(X, &[C_I, C_WM, C_V, C_TM], &t.rows[2]);
                put(X, &[C_X], &[1.0]);
                put(TH, &[C_TH], &[1.0]);
                m[WL] = [None; 8];
            }
            3 => {
                for (c, col) in set.free_contact.cols.iter().enumerate() {
                    for (r, v) in col.iter().enumerate() {
                        m[r][c] = Some(*v);
                    }
                }
            }
            4 => {
                let t = &set.motor_stuck_contact;
                put(I, &[C_I, C_V], &t.i);
                put(WL, &[C_WL, C_X, C_TH, C_TL], &t.load[0]);
                put(X, &[C_WL, C_X, C_TH, C_TL], &t.load[1]);
                put(TH, &[C_WL, C_X, C_TH, C_TL], &t.load[2]);
                m[WM] = [None; 8];
            }
            _ => {
                let t = &set.load_stuck_contact;
                put(I, &[C_I, C_WM, C_X, C_V, C_TM], &t.rows[0]);
                put(WM, &[C_I, C_WM, C_X, C_V, C_TM], &t.rows[1]);
                put(X, &[C_I, C_WM, C_X, C_V, C_TM], &t.rows[2]);
                put(TH, &[C_TH], &[1.0]);
                m[WL] = [None; 8];
            }
        }
        m
    }

    /// The compact modes drop only entries that are exactly zero in the full f64-derived
    /// transitions and take as 1 only entries that are exactly 1, for parameter sets with and
    /// without every effect that adds couplings (viscous friction, mesh damping, hinge
    /// spring), at the step and at a sub-step: the compact product is the full product.
    #[test]
    fn compact_modes_drop_only_exact_zeros_and_ones() {
        let mut with_effects = REFERENCE.with_backlash_deg(0.3);
        with_effects.effects.motor_viscous = 2e-6;
        with_effects.effects.load_viscous = 1e-3;
        with_effects.effects.mesh_damping = 0.5;
        with_effects.effects.hinge_stiffness = 3.0;
        let mut long_step = REFERENCE.with_backlash_deg(0.08);
        long_step.sample_period_s = 5.6e-3;
        for p in [REFERENCE.with_backlash_deg(0.08), with_effects, long_step] {
            let d = p.derived().unwrap();
            let n_sub = sub_step_plan(&p, d.n_total, d.k_eq_nm_per_rad).n_sub;
            let h = p.sample_period_s;
            for tau in [h, h / n_sub as f64] {
                let set = mode_set(&p, d.n_total, d.k_eq_nm_per_rad, tau).unwrap();
                for (idx, &(contact, mf, lf)) in MODE_FLAGS.iter().enumerate() {
                    let (a, b) = continuous(&p, d.n_total, d.k_eq_nm_per_rad, contact, mf, lf);
                    let full = transition(&a, &b, tau).unwrap();
                    let compact = expand(&set, idx);
                    for (r, row) in compact.iter().enumerate() {
                        for (c, want) in row.iter().enumerate() {
                            if let Some(v) = want {
                                assert_eq!(at(&full, r, c), *v, "mode {idx} ({r}, {c}) τ {tau}");
                            }
                        }
                    }
                }
            }
        }
    }
}
