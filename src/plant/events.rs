//! Events inside a step: the gap edge, friction reversal and sticking, breakaway. Each is
//! located within a sub-step and the remainder corrected by the impulse it implies.

use super::modes::{Input, Mode, Motion, Vec5};
use super::step::Ctx;
use super::{Plant, I, TH, WL, WM, X};
use crate::math::{self, abs, fraction};

impl Plant {
    /// One exact sub-step from `s0` in its mode `m` (`mode_at(s0)`), with event location
    /// and impulse correction; `f` is the mode's constant forcing ([`Plant::forcing`]). Returns the state at its end and whether an event changed
    /// anything; when none did, `m` is still the mode there (the twist stayed on its side of
    /// the edges, a sliding body kept its direction, a stuck body's drive stayed within its
    /// static friction: exactly the conditions `mode_at` tests), so the caller need not
    /// derive it again.
    #[inline(always)]
    pub(super) fn sub_step(
        &self,
        c: &Ctx,
        m: &Mode,
        f: (f32, f32),
        s0: &Vec5,
        inp: &Input,
    ) -> (Vec5, bool) {
        // Opaque to the optimiser: otherwise it hoists every load of the sub-step
        // transitions out of the caller's loop and spills them to the stack (measured on the
        // Cortex-M4F: some 280 extra instructions per sub-stepped step). No effect on values.
        let set = core::hint::black_box(&self.sub);
        let s1 = Self::advance(set, m, f, s0, inp);
        let motor_event = match m.motor {
            Motion::Slip(sg) => sg * s1[WM] <= 0.0,
            Motion::Stuck => abs(self.motor_drive(c, &s1)) > c.ts_m,
        };
        let load_event = match m.load {
            Motion::Slip(sg) => sg * s1[WL] <= 0.0,
            Motion::Stuck => !c.jammed && abs(self.load_drive(c, &s1)) > c.ts_l,
        };
        if self.gear_of(c, s1[X]) == m.gear && !motor_event && !load_event {
            return (s1, false);
        }
        let ([i0, wm0, wl0, x0, th0], [i1, wm1, wl1, x1, th1]) = (*s0, s1);
        let s0 = (i0, wm0, wl0, x0, th0);
        (
            self.correct(c, m, s0, i1, wm1, wl1, x1, th1, inp.v_eff),
            true,
        )
    }

    /// The corrections of a sub-step from `s0` in mode `m` that ended at `s1` (the mode's
    /// exact advance) with an event in it; `v` is the voltage of the closed forms.
    ///
    /// Out of line, as it is rarely needed; the states go as scalars (in registers), so the
    /// sub-step loop stores nothing for it.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn correct(
        &self,
        c: &Ctx,
        m: &Mode,
        (i0, wm0, wl0, x0, th0): (f32, f32, f32, f32, f32),
        i1: f32,
        wm1: f32,
        wl1: f32,
        x1: f32,
        th1: f32,
        v: f32,
    ) -> Vec5 {
        let s0 = &[i0, wm0, wl0, x0, th0];
        let mut s1 = [i1, wm1, wl1, x1, th1];
        let hs = self.sub.tau;
        let motor_free = !matches!(m.motor, Motion::Stuck);
        let load_free = !matches!(m.load, Motion::Stuck);

        // Gap edge crossed: the mode's transition applied its own contact law over the
        // whole sub-step. Replace that impulse by the true dead-zone impulse, both taken along
        // x linear over the sub-step. The dead-zone torque is continuous at the edge, so this
        // is exact to second order in the time past the edge (third after the position
        // correction); it covers entering, leaving, and passing through the whole gap.
        let g1 = self.gear_of(c, s1[X]);
        if g1 != m.gear {
            let true_impulse = self.dead_zone_impulse(c, s0[X], s1[X], hs);
            let mode_impulse = if m.gear == 0 {
                0.0
            } else {
                let b = if m.gear > 0 { c.delta } else { -c.delta };
                self.k * (0.5 * (s0[X] + s1[X]) - b) * hs + self.c_mesh * (s1[X] - s0[X])
            };
            let p = true_impulse - mode_impulse;
            // Time from the first edge crossing to the end of the sub-step.
            let edge = if m.gear == 0 {
                if g1 > 0 {
                    c.delta
                } else {
                    -c.delta
                }
            } else if m.gear > 0 {
                c.delta
            } else {
                -c.delta
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
                    let t0 = self.motor_drive(c, s0);
                    let t1 = self.motor_drive(c, &s1);
                    let t_star = t0 + alpha * (t1 - t0);
                    let w = s1[WM];
                    // Sticks where static friction holds the drive at zero speed.
                    if abs(t_star) <= c.ts_m {
                        s1[X] -= w * tau * 0.5 / self.n;
                        s1[WM] = 0.0;
                    } else {
                        let dw = 2.0 * c.tf_m * sg * tau / self.jm;
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
                let t1 = self.motor_drive(c, &s1);
                if abs(t1) > c.ts_m {
                    let dw = self.motor_breakaway(c, s0, &s1, t1, v, hs);
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
                    let t0 = self.load_drive(c, s0);
                    let t1 = self.load_drive(c, &s1);
                    let t_star = t0 + alpha * (t1 - t0);
                    let w = s1[WL];
                    if abs(t_star) <= c.ts_l {
                        s1[X] += w * tau * 0.5;
                        s1[TH] -= w * tau * 0.5;
                        s1[WL] = 0.0;
                    } else {
                        let dw = 2.0 * c.tf_l * sg * tau / self.jl;
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
                let t1 = self.load_drive(c, &s1);
                if !c.jammed && abs(t1) > c.ts_l {
                    let sg = if t1 > 0.0 { 1.0 } else { -1.0 };
                    let t0 = self.load_drive(c, s0);
                    let alpha = fraction(c.ts_l - sg * t0, sg * (t1 - t0));
                    let tau = (1.0 - alpha) * hs;
                    // Net torque grows linearly from T_s − T_f at breakaway (0 without
                    // stiction) to |t1| − T_f: Δω is its mean times τ, Δθ its double
                    // integral, τ² (2 (T_s − T_f) + |t1| − T_f) / (6 J_L).
                    let jump = c.ts_l - c.tf_l;
                    let dw = sg * ((sg * t1 - c.tf_l) + jump) * tau * 0.5 / self.jl;
                    let mut dth = dw * tau * (1.0 / 3.0);
                    if jump > 0.0 {
                        dth += sg * jump * tau * tau * (1.0 / 6.0) / self.jl;
                    }
                    s1[WL] = dw;
                    s1[X] -= dth;
                    s1[TH] += dth;
                }
            }
        }
        s1
    }

    /// ∫ T_L dt over a sub-step of length `hs` along x linear from `x0` to `x1`: the
    /// spring part over the stretches beyond ±δ and the mesh damping part c Δx over them.
    pub(super) fn dead_zone_impulse(&self, c: &Ctx, x0: f32, x1: f32, hs: f32) -> f32 {
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
        flank(c.delta, 1.0) + flank(-c.delta, -1.0)
    }

    /// Motor speed at the end of a sub-step in which it broke away from static friction,
    /// and the motor angle it gained, rad (at the motor). The breakaway instant follows the
    /// exponential rise of the current `i(t) = i∞ + (i0 − i∞) e^{−t/τe}` (the motor was
    /// stuck, so there is no back-EMF); the gear torque is taken as its sub-step mean.
    pub(super) fn motor_breakaway(
        &self,
        c: &Ctx,
        s0: &Vec5,
        s1: &Vec5,
        t1: f32,
        v: f32,
        hs: f32,
    ) -> (f32, f32) {
        let sg = if t1 > 0.0 { 1.0 } else { -1.0 };
        let tl_mean = 0.5
            * (self.transmitted(c, s0, self.gear_of(c, s0[X]))
                + self.transmitted(c, s1, self.gear_of(c, s1[X])));
        let i_inf = v / self.r;
        // σ·drive(t) = a + b e^{−t/τe}
        let a = sg * (self.kt * i_inf - tl_mean / self.n);
        let b = sg * self.kt * (s0[I] - i_inf);
        // Net torque past breakaway: the drive less the sliding friction, which starts at
        // T_s − T_f (0 without stiction) where the drive reaches the static friction T_s.
        let jump = c.ts_m - c.tf_m;
        let excess_end = (sg * t1 - c.tf_m) + jump;
        let (t_star, e_star) = {
            let r = (c.ts_m - a) / b;
            if b != 0.0 && r > 0.0 && r < 1.0 && a > c.ts_m {
                (-self.tau_e * math::ln(r), r)
            } else {
                // Not driven by the current's rise (the gear torque grew): linear.
                let t0 = sg * self.motor_drive(c, s0);
                let alpha = fraction(c.ts_m - t0, sg * t1 - t0);
                let t = alpha * hs;
                (t, math::exp(-t / self.tau_e))
            }
        };
        let tau = hs - t_star;
        if tau.is_nan() || tau <= 0.0 {
            return (0.0, 0.0);
        }
        let impulse = if b != 0.0 && a > c.ts_m {
            (a - c.tf_m) * tau + b * self.tau_e * (e_star - self.sub.decay)
        } else {
            excess_end * tau * 0.5
        };
        let w = sg * impulse / self.jm;
        (w, w * tau * 0.5)
    }
}
