//! The per-step arithmetic: mode of a state, exact advance within a mode, whole-step check.

use super::modes::ModeSet;
use super::modes::{Extra, Input, Mode, Motion, Transition, Vec5, MOTOR_STUCK};
use super::sine::SineDrive;
use super::{Plant, I, TH, WL, WM, X};
use crate::math::{abs, fraction, sin};

/// What may change from step to step: the parameters that faults alter, for this step.
#[derive(Clone, Copy, Debug)]
pub(super) struct Ctx {
    /// Half gap δ, rad.
    pub(super) delta: f32,
    /// k δ, N·m.
    pub(super) kd: f32,
    /// Coulomb (sliding) frictions, N·m.
    pub(super) tf_m: f32,
    pub(super) tf_l: f32,
    /// Breakaway (static) frictions, N·m: a stuck body stays stuck while its drive is within
    /// them, and a body whose velocity reaches zero sticks when its drive is. Equal to the
    /// sliding frictions unless `effects.stiction_ratio` is on.
    pub(super) ts_m: f32,
    pub(super) ts_l: f32,
    /// External torques on the motor and on the load over this step, N·m.
    pub(super) t_motor: f32,
    pub(super) t_load: f32,
    /// Gear torque lost at a broken tooth over this step, N·m at the load (part of the
    /// external pair above: −lost on the load, +lost/N on the motor).
    pub(super) lost: f32,
    /// The load is held (jammed).
    pub(super) jammed: bool,
    /// External torques present (false lets the nominal step skip adding zeros, which
    /// IEEE arithmetic cannot fold: −0 + 0 = +0). Set in every context built under a
    /// fault, so false means exactly the nominal context.
    pub(super) ext: bool,
}

impl Plant {
    /// The nominal context: no fault.
    #[inline(always)]
    pub(super) fn nominal(&self) -> Ctx {
        Ctx {
            delta: self.delta,
            kd: self.k * self.delta,
            tf_m: self.tf_m,
            tf_l: self.tf_l,
            ts_m: self.ts_m,
            ts_l: self.ts_l,
            t_motor: 0.0,
            t_load: 0.0,
            lost: 0.0,
            jammed: false,
            ext: false,
        }
    }

    /// The nominal context of a plant without bench effects ([`Plant::step`]'s plain
    /// instance): the static frictions are the sliding ones, the same values, so that the
    /// compiler keeps one register for each.
    #[inline(always)]
    pub(super) fn plain(&self) -> Ctx {
        Ctx {
            ts_m: self.tf_m,
            ts_l: self.tf_l,
            ..self.nominal()
        }
    }

    /// The nominal context of a step from `s`: with `effects.gravity_torque`, the part of
    /// the gravity torque that the modes' linear spring (−T θL, in `k_ground`) does not
    /// carry, T (θ̂ − sin θ̂), held over the step as an external torque on the load.
    ///
    /// θ̂ = θL + ωL h/2 is the predicted mid-step angle, so the held torque is the
    /// remainder's value at the step's midpoint to first order, and the step is second-order
    /// accurate in it (midpoint rule). The remainder is small and slow: it is O(θ³) near
    /// the hanging position, where the linear spring is exact, and its rate T (1 − cos θ) ωL
    /// is bounded by 2 T ωL; the pendulum's own frequency √(T/J_L) (5 Hz for 0.1 N·m on the
    /// reference load) is far below the 2 kHz step rate. Everything fast (the gear spring,
    /// the winding) stays in the exact transition. Measured against the RK4 reference on
    /// swings to ±90° and past the top: host-tests/tests/bench_effects.rs.
    #[inline(always)]
    pub(super) fn nominal_at(&self, s: &Vec5) -> Ctx {
        let mut c = self.nominal();
        if self.gravity != 0.0 {
            c.t_load = self.gravity_remainder(s);
            c.ext = true;
        }
        c
    }

    /// The nominal context of the step's general instance from `s`: [`Plant::nominal_at`]
    /// with the external torques always marked present (zero without gravity), so that the
    /// instance has no run-time test of them (measured: 60 instructions per step fewer on
    /// the Cortex-M4F than testing whether gravity put one there).
    #[inline(always)]
    pub(super) fn general_ctx(&self, s: &Vec5) -> Ctx {
        let mut c = self.nominal();
        c.t_load = if self.gravity != 0.0 {
            self.gravity_remainder(s)
        } else {
            0.0
        };
        c.ext = true;
        c
    }

    /// T (θ̂ − sin θ̂) at the predicted mid-step angle θ̂ (see [`Plant::nominal_at`]), N·m.
    /// Within ±π/2 by its own series (θ³/3! − θ⁵/5! + … to θ¹¹, truncation below 6e-8
    /// there), which has no cancellation near the hanging position; beyond by the f32 sine.
    #[inline(never)]
    pub(super) fn gravity_remainder(&self, s: &Vec5) -> f32 {
        let th = s[TH] + 0.5 * self.h * s[WL];
        let rest = if abs(th) <= core::f32::consts::FRAC_PI_2 {
            let t2 = th * th;
            let p = 1.0 / 362_880.0 - t2 * (1.0 / 39_916_800.0);
            let p = 1.0 / 5040.0 - t2 * p;
            let p = 1.0 / 120.0 - t2 * p;
            let p = 1.0 / 6.0 - t2 * p;
            th * t2 * p
        } else {
            th - sin(th)
        };
        self.gravity * rest
    }

    #[inline(always)]
    pub(super) fn gear_of(&self, c: &Ctx, x: f32) -> i8 {
        if x > c.delta {
            1
        } else if x < -c.delta {
            -1
        } else {
            0
        }
    }

    #[inline(always)]
    pub(super) fn transmitted(&self, c: &Ctx, s: &Vec5, gear: i8) -> f32 {
        if gear == 0 {
            0.0
        } else {
            let edge = if gear > 0 { c.delta } else { -c.delta };
            self.k * (s[X] - edge) + self.c_mesh * (s[WM] * self.inv_n - s[WL])
        }
    }

    /// Torque driving the motor apart from its own friction (viscous friction is zero at
    /// the instants this is used: at rest or at a velocity reversal).
    #[inline(always)]
    pub(super) fn motor_drive(&self, c: &Ctx, s: &Vec5) -> f32 {
        let d = self.kt * s[I] - self.transmitted(c, s, self.gear_of(c, s[X])) * self.inv_n;
        if c.ext {
            d + c.t_motor
        } else {
            d
        }
    }

    #[inline(always)]
    pub(super) fn load_drive(&self, c: &Ctx, s: &Vec5) -> f32 {
        let d = self.transmitted(c, s, self.gear_of(c, s[X])) - self.k_ground * s[TH];
        if c.ext {
            d + c.t_load
        } else {
            d
        }
    }

    #[inline(always)]
    pub(super) fn motion(speed: f32, drive: f32, friction: f32) -> Motion {
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
    pub(super) fn mode_at(&self, c: &Ctx, s: &Vec5) -> Mode {
        let gear = self.gear_of(c, s[X]);
        let motor = if s[WM] != 0.0 {
            Self::motion(s[WM], 0.0, 0.0)
        } else {
            Self::motion(0.0, self.motor_drive(c, s), c.ts_m)
        };
        let load = if c.jammed {
            Motion::Stuck
        } else if s[WL] != 0.0 {
            Self::motion(s[WL], 0.0, 0.0)
        } else {
            Self::motion(0.0, self.load_drive(c, s), c.ts_l)
        };
        Mode::new(gear, motor, load)
    }

    /// Constant torques of the mode: friction, the dead-zone offset ±k δ and external torques.
    #[inline(always)]
    pub(super) fn forcing(&self, c: &Ctx, m: &Mode) -> (f32, f32) {
        let kd = match m.gear {
            0 => 0.0,
            g if g > 0 => c.kd,
            _ => -c.kd,
        };
        let fm = match m.motor {
            Motion::Slip(sg) => -sg * c.tf_m,
            Motion::Stuck => 0.0,
        };
        let fl = match m.load {
            Motion::Slip(sg) => -sg * c.tf_l,
            Motion::Stuck => 0.0,
        };
        let (tm, tl) = (fm + kd * self.inv_n, fl - kd);
        if c.ext {
            (tm + c.t_motor, tl + c.t_load)
        } else {
            (tm, tl)
        }
    }

    /// Exact advance within one mode over the set's step with input `inp`.
    ///
    /// Each row is the same balanced sum of products as the full product
    /// `((p0 + p1) + (p2 + p3)) + ((p4 + p5) + (p6 + p7))` over `[i, ωm, ωL, x, θL, V, τm, τL]`
    /// with the mode's structurally zero products left out and its unit coefficients taken
    /// as they are (see [`ModeSet`]): the same value as the full product, with short
    /// dependency chains, exactly odd in (s, v, τ), and the same operations in the same order
    /// on every target, so the results are bit-identical everywhere.
    #[inline(always)]
    pub(super) fn advance(
        set: &ModeSet,
        m: &Mode,
        (tm, tl): (f32, f32),
        s: &Vec5,
        inp: &Input,
    ) -> Vec5 {
        let Some(idx) = m.index() else {
            // Both bodies stuck: only the current moves. Its row in a motor-stuck mode is
            // exactly that (no back-EMF), with every voltage column.
            let [pi, pv] = set.motor_stuck_gap.i;
            let mut i = pi * s[I] + pv * inp.v;
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
        let v = inp.v;
        let [si, wm, wl, x, th] = *s;
        let mut out = match idx {
            0 => {
                let t = &set.free_gap;
                let mot = |r: &[f32; 4]| (r[0] * si + r[1] * wm) + (r[2] * v + r[3] * tm);
                let load = |r: &[f32; 3]| r[0] * wl + (r[1] * th + r[2] * tl);
                let [m0, m1] = &t.motor;
                let [l0, l1] = &t.load;
                let r = &t.x;
                let xr = ((r[0] * si + r[1] * wm) + (r[2] * wl + x))
                    + ((r[3] * th + r[4] * v) + (r[5] * tm + r[6] * tl));
                [mot(m0), mot(m1), load(l0), xr, load(l1)]
            }
            1 => {
                let t = &set.motor_stuck_gap;
                let [l0, l1, l2] = &t.load;
                [
                    t.i[0] * si + t.i[1] * v,
                    0.0,
                    l0[0] * wl + (l0[1] * th + l0[2] * tl),
                    (l2[0] * wl + x) + (l2[1] * th + l2[2] * tl),
                    l1[0] * wl + (l1[1] * th + l1[2] * tl),
                ]
            }
            2 => {
                let [r0, r1, r2] = &set.load_stuck_gap.rows;
                let mot = |r: &[f32; 4]| (r[0] * si + r[1] * wm) + (r[2] * v + r[3] * tm);
                [
                    mot(r0),
                    mot(r1),
                    0.0,
                    ((r2[0] * si + r2[1] * wm) + x) + (r2[2] * v + r2[3] * tm),
                    th,
                ]
            }
            4 => {
                let t = &set.motor_stuck_contact;
                let load = |r: &[f32; 4]| (r[0] * wl + r[1] * x) + (r[2] * th + r[3] * tl);
                let [l0, l1, l2] = &t.load;
                [t.i[0] * si + t.i[1] * v, 0.0, load(l0), load(l1), load(l2)]
            }
            5 => {
                let [r0, r1, r2] = &set.load_stuck_contact.rows;
                let mot =
                    |r: &[f32; 5]| ((r[0] * si + r[1] * wm) + r[2] * x) + (r[3] * v + r[4] * tm);
                [mot(r0), mot(r1), 0.0, mot(r2), th]
            }
            _ => Self::full_product(&set.free_contact, &[si, wm, wl, x, th, v, tm, tl]),
        };
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

    /// The full product `Φ s + Γ u` of a transition with `u = [s, V, τm, τL]`.
    #[inline(always)]
    fn full_product(t: &Transition, u: &[f32; 8]) -> Vec5 {
        let c = &t.cols;
        macro_rules! row {
            ($r:literal) => {
                ((c[0][$r] * u[0] + c[1][$r] * u[1]) + (c[2][$r] * u[2] + c[3][$r] * u[3]))
                    + ((c[4][$r] * u[4] + c[5][$r] * u[5]) + (c[6][$r] * u[6] + c[7][$r] * u[7]))
            };
        }
        // On x86-64 rows 0–3 go as one SSE vector (`wide`), the same sums in the same order;
        // elsewhere (Cortex-M has no SIMD for f32) plain scalar code is shorter.
        #[cfg(target_arch = "x86_64")]
        let q = {
            let lanes = |j: usize| -> wide::f32x4 {
                let col = c.get(j).unwrap_or(&[0.0; 5]);
                let x = u.get(j).copied().unwrap_or(0.0);
                wide::f32x4::new([col[0], col[1], col[2], col[3]]) * wide::f32x4::splat(x)
            };
            (((lanes(0) + lanes(1)) + (lanes(2) + lanes(3)))
                + ((lanes(4) + lanes(5)) + (lanes(6) + lanes(7))))
            .to_array()
        };
        #[cfg(not(target_arch = "x86_64"))]
        let q = [row!(0), row!(1), row!(2), row!(3)];
        [q[0], q[1], q[2], q[3], row!(4)]
    }

    /// One held-voltage step: `v_early` over the first `delay_frac` of it, `v_late` after.
    /// Returns the state at its end and its gear contact (`gear_of` of its twist).
    #[inline(always)]
    pub(super) fn advance_step<const GENERAL: bool>(
        &self,
        c: &Ctx,
        s0: &Vec5,
        v_early: f32,
        v_late: f32,
    ) -> (Vec5, i8) {
        let m = self.mode_at(c, s0);
        let f = self.forcing(c, &m);
        // Only the general instance has a delay ([`Plant::step`]).
        let split = GENERAL && self.delay_frac > 0.0;
        let s1 = if split {
            let inp = Input {
                v: v_early,
                v_eff: v_late,
                extra: Extra::Late(&self.late_v, v_late - v_early),
            };
            Self::advance(&self.full, &m, f, s0, &inp)
        } else {
            Self::advance(&self.full, &m, f, s0, &Input::held(v_late))
        };
        if !self.always_sub && self.consistent(c, &m, s0, &s1) {
            return (s1, m.gear);
        }
        // The nominal context (no external torque) is rebuilt there rather than passed, and
        // the state goes in registers: nothing is stored for a call that rarely happens.
        let faulty = if c.ext { Some(c) } else { None };
        let [i, wm, wl, x, th] = *s0;
        self.sub_stepped(faulty, m, f, [i, wm, wl, x, th], v_early, v_late)
    }

    /// [`Plant::advance_step`] redone as sub-steps, from `s0` in its mode `m` with forcing
    /// `f`. Out of line (and its arguments by value): the step that needs no sub-steps then
    /// keeps its registers for itself (measured on the Cortex-M4F: fewer spills on every
    /// step).
    #[inline(never)]
    fn sub_stepped(
        &self,
        faulty: Option<&Ctx>,
        m: Mode,
        f: (f32, f32),
        [i, wm, wl, x, th]: Vec5,
        v_early: f32,
        v_late: f32,
    ) -> (Vec5, i8) {
        let c = &match faulty {
            Some(c) => *c,
            None => self.nominal(),
        };
        let s0 = [i, wm, wl, x, th];
        let split = self.delay_frac > 0.0;
        let (mut s, mut m, mut f) = (s0, m, f);
        let n_sub = self.sub_steps as usize;
        // Each block of the step (its halves on the whole-step path) is first tried whole in
        // its starting mode, with the same check as the whole step (exact within the mode;
        // the check is only safer over less time): an event then costs the sub-steps of its
        // block, not of the step.
        let block = if split { 0 } else { self.block as usize };
        // The whole step was tried and failed its check, so when every block before the
        // last held, the last holds the event: it is sub-stepped without a try.
        let tried_whole = !self.always_sub;
        let mut all_held = true;
        // Start of the next block (past the end without blocks).
        let mut next = if block > 0 { 0 } else { n_sub };
        let mut j = 0;
        while j < n_sub {
            if j == next && j + block <= n_sub {
                next += block;
                let last = next == n_sub;
                if !(tried_whole && all_held && last) {
                    // Opaque to the optimiser, like the sub-step transitions (no hoisting).
                    let set = core::hint::black_box(&self.block_set);
                    let s_b = Self::advance(set, &m, f, &s, &Input::held(v_late));
                    if self.consistent_over(c, &m, &s, &s_b, set.tau) {
                        // No event in this block: `m` holds at its end.
                        s = s_b;
                        j += block;
                        continue;
                    }
                }
                all_held = false;
            }
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
            let event;
            (s, event) = self.sub_step(c, &m, f, &s, &Input::held(v));
            if event {
                m = self.mode_at(c, &s);
                f = self.forcing(c, &m);
            }
            j += 1;
        }
        // After an event in the last sub-step `m` was derived at `s`; without one it still
        // holds there: either way its gear is `s`'s.
        (s, m.gear)
    }

    /// One step under the sinusoidal voltage `a_cos cos ωτ + a_sin sin ωτ`, τ from the
    /// step's start.
    pub(super) fn advance_step_sine(
        &self,
        c: &Ctx,
        s0: &Vec5,
        d: &SineDrive,
        a_cos: f32,
        a_sin: f32,
    ) -> Vec5 {
        let m = self.mode_at(c, s0);
        let v_mid = a_cos * d.half_full[0] + a_sin * d.half_full[1];
        let inp = Input {
            v: 0.0,
            v_eff: v_mid,
            extra: Extra::Sine(&d.full, a_cos, a_sin),
        };
        let f = self.forcing(c, &m);
        let s1 = Self::advance(&self.full, &m, f, s0, &inp);
        if !self.always_sub && self.consistent(c, &m, s0, &s1) {
            return s1;
        }
        let (mut s, mut m, mut f) = (*s0, m, f);
        let (mut ac, mut asn) = (a_cos, a_sin);
        let [cr, sr] = d.rot_sub;
        for _ in 0..self.sub_steps {
            let v_mid = ac * d.half_sub[0] + asn * d.half_sub[1];
            let inp = Input {
                v: 0.0,
                v_eff: v_mid,
                extra: Extra::Sine(&d.sub, ac, asn),
            };
            let event;
            (s, event) = self.sub_step(c, &m, f, &s, &inp);
            if event {
                m = self.mode_at(c, &s);
                f = self.forcing(c, &m);
            }
            // Move the phase origin to the next sub-step's start.
            (ac, asn) = (ac * cr + asn * sr, asn * cr - ac * sr);
        }
        s
    }

    /// Does the whole-step result agree with the mode it was computed in?
    #[inline(always)]
    pub(super) fn consistent(&self, c: &Ctx, m: &Mode, s0: &Vec5, s1: &Vec5) -> bool {
        self.consistent_over(c, m, s0, s1, self.h)
    }

    /// [`Plant::consistent`] for an advance over `tau` (s).
    #[inline(always)]
    pub(super) fn consistent_over(
        &self,
        c: &Ctx,
        m: &Mode,
        s0: &Vec5,
        s1: &Vec5,
        tau: f32,
    ) -> bool {
        if self.gear_of(c, s1[X]) != m.gear || self.grazes(c, m.gear, s0, s1, tau) {
            return false;
        }
        let motor_ok = match m.motor {
            Motion::Slip(sg) => sg * s1[WM] > 0.0,
            Motion::Stuck => abs(self.motor_drive(c, s1)) <= c.ts_m,
        };
        let load_ok = match m.load {
            Motion::Slip(sg) => sg * s1[WL] > 0.0,
            Motion::Stuck => c.jammed || abs(self.load_drive(c, s1)) <= c.ts_l,
        };
        motor_ok && load_ok
    }

    /// Whether the twist may have crossed a gap edge and come back within the step: the
    /// cubic Hermite interpolant of x (ends and slopes, over the advance's length `tau`, s)
    /// is checked at its turning point.
    #[inline(always)]
    pub(super) fn grazes(&self, c: &Ctx, gear: i8, s0: &Vec5, s1: &Vec5, tau: f32) -> bool {
        let m0 = (s0[WM] * self.inv_n - s0[WL]) * tau;
        let m1 = (s1[WM] * self.inv_n - s1[WL]) * tau;
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
            1 => p < c.delta,
            -1 => p > -c.delta,
            _ => p > c.delta || p < -c.delta,
        }
    }
}
