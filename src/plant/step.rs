//! The per-step arithmetic: mode of a state, exact advance within a mode, whole-step check.

use super::modes::ModeSet;
use super::modes::{Extra, Input, Mode, Motion, Vec5, COL_V, MOTOR_STUCK, NO_TRANSITION};
use super::sine::SineDrive;
use super::{Plant, I, TH, WL, WM, X};
use crate::math::{abs, fraction};

impl Plant {
    #[inline(always)]
    pub(super) fn gear_of(&self, x: f32) -> i8 {
        if x > self.delta {
            1
        } else if x < -self.delta {
            -1
        } else {
            0
        }
    }

    #[inline(always)]
    pub(super) fn transmitted(&self, s: &Vec5, gear: i8) -> f32 {
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
    pub(super) fn motor_drive(&self, s: &Vec5) -> f32 {
        self.kt * s[I] - self.transmitted(s, self.gear_of(s[X])) * self.inv_n
    }

    #[inline(always)]
    pub(super) fn load_drive(&self, s: &Vec5) -> f32 {
        self.transmitted(s, self.gear_of(s[X])) - self.k_hinge * s[TH]
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
    pub(super) fn mode_at(&self, s: &Vec5) -> Mode {
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
    pub(super) fn forcing(&self, m: &Mode) -> (f32, f32) {
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
    pub(super) fn advance(&self, set: &ModeSet, m: &Mode, s: &Vec5, inp: &Input) -> Vec5 {
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
    pub(super) fn advance_step(&self, s0: &Vec5, v_early: f32, v_late: f32) -> Vec5 {
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
    pub(super) fn advance_step_sine(
        &self,
        s0: &Vec5,
        d: &SineDrive,
        a_cos: f32,
        a_sin: f32,
    ) -> Vec5 {
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
    pub(super) fn consistent(&self, m: &Mode, s0: &Vec5, s1: &Vec5) -> bool {
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
    pub(super) fn grazes(&self, gear: i8, s0: &Vec5, s1: &Vec5) -> bool {
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
}
