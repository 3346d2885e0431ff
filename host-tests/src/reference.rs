//! An independent `f64` integrator of the same physics, for accuracy tests.
//!
//! Deliberately different from the emulator: absolute angles θm and θL (not the twist),
//! classical fourth-order Runge–Kutta at a fixed fine step (1 µs by default, 500 steps per
//! emulator step), the dead zone and Coulomb friction evaluated inside every RK stage, and
//! stick/slip decided after each fine step with stuck flags (a body whose velocity changes
//! sign while its driving torque is within static friction is stopped and held until that
//! torque exceeds it). It shares no code with `geared_servo::plant`; it reads only the
//! parameter struct and the derived N, k_eq and δ.

use geared_servo::{ActuatorParams, ParamError};

/// Fine-step reference simulator.
#[derive(Clone, Debug)]
pub struct Reference {
    r: f64,
    l: f64,
    kt: f64,
    kb: f64,
    kts: f64,
    jm: f64,
    jl: f64,
    tfm: f64,
    tfl: f64,
    cm: f64,
    cl: f64,
    cmesh: f64,
    kh: f64,
    n: f64,
    k: f64,
    delta: f64,
    vmax: f64,
    /// Fine steps per sample period.
    pub substeps: usize,
    h: f64,
    /// State: i, θm, ωm, θL, ωL.
    pub s: [f64; 5],
    stuck_m: bool,
    stuck_l: bool,
}

impl Reference {
    /// Builds the reference from validated parameters, with `fine_step_s` as its RK4 step.
    pub fn new(p: &ActuatorParams, fine_step_s: f64) -> Result<Reference, ParamError> {
        let d = p.derived()?;
        let substeps = (p.sample_period_s / fine_step_s).round().max(1.0) as usize;
        Ok(Reference {
            r: p.motor.resistance_ohm,
            l: p.motor.inductance_h,
            kt: p.motor.torque_constant_nm_per_a,
            kb: p.motor.back_emf_v_s_per_rad,
            kts: p.motor.tach_v_s_per_rad * (1.0 + p.effects.tach_gain),
            jm: p.motor.inertia_kg_m2,
            jl: p.load.inertia_kg_m2,
            tfm: p.motor.coulomb_friction_nm,
            tfl: p.load.coulomb_friction_nm,
            cm: p.effects.motor_viscous,
            cl: p.effects.load_viscous,
            cmesh: p.effects.mesh_damping,
            kh: p.effects.hinge_stiffness,
            n: d.n_total,
            k: d.k_eq_nm_per_rad,
            delta: d.delta_rad,
            vmax: if p.effects.voltage_limit > 0.0 {
                p.effects.voltage_limit
            } else {
                f64::INFINITY
            },
            substeps,
            h: p.sample_period_s / substeps as f64,
            s: [0.0; 5],
            stuck_m: true,
            stuck_l: true,
        })
    }

    fn gear_torque(&self, s: &[f64; 5]) -> f64 {
        let x = s[1] / self.n - s[3];
        let xd = s[2] / self.n - s[4];
        if x > self.delta {
            self.k * (x - self.delta) + self.cmesh * xd
        } else if x < -self.delta {
            self.k * (x + self.delta) + self.cmesh * xd
        } else {
            0.0
        }
    }

    /// Torques on (motor, load) other than Coulomb friction.
    fn drives(&self, s: &[f64; 5]) -> (f64, f64) {
        let tl = self.gear_torque(s);
        (
            self.kt * s[0] - tl / self.n - self.cm * s[2],
            tl - self.cl * s[4] - self.kh * s[3],
        )
    }

    fn coulomb(speed: f64, drive: f64, tf: f64) -> f64 {
        let dir = if speed != 0.0 {
            speed.signum()
        } else {
            drive.signum()
        };
        if speed == 0.0 && drive.abs() <= tf {
            -drive
        } else {
            -tf * dir
        }
    }

    fn deriv(&self, s: &[f64; 5], v: f64) -> [f64; 5] {
        let (dm, dl) = self.drives(s);
        let am = if self.stuck_m {
            0.0
        } else {
            (dm + Self::coulomb(s[2], dm, self.tfm)) / self.jm
        };
        let al = if self.stuck_l {
            0.0
        } else {
            (dl + Self::coulomb(s[4], dl, self.tfl)) / self.jl
        };
        [
            (v - self.r * s[0] - self.kb * s[2]) / self.l,
            s[2],
            am,
            s[4],
            al,
        ]
    }

    fn rk4(&mut self, v: f64) {
        self.rk4_fn(&|_| v, 0.0);
    }

    /// One RK4 step with the voltage a function of time since `t0` (the step's start).
    fn rk4_fn(&mut self, v_of: &dyn Fn(f64) -> f64, t0: f64) {
        let h = self.h;
        let s = self.s;
        let vmax = self.vmax;
        let v = |t: f64| v_of(t).clamp(-vmax, vmax);
        let add = |a: &[f64; 5], b: &[f64; 5], c: f64| {
            let mut o = *a;
            for (oi, bi) in o.iter_mut().zip(b) {
                *oi += c * bi;
            }
            o
        };
        let k1 = self.deriv(&s, v(t0));
        let k2 = self.deriv(&add(&s, &k1, h / 2.0), v(t0 + h / 2.0));
        let k3 = self.deriv(&add(&s, &k2, h / 2.0), v(t0 + h / 2.0));
        let k4 = self.deriv(&add(&s, &k3, h), v(t0 + h));
        let mut n = s;
        for j in 0..5 {
            n[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
        }
        // Stick/slip after the fine step.
        let (dm, dl) = self.drives(&n);
        if self.stuck_m {
            n[2] = 0.0;
            if dm.abs() > self.tfm {
                self.stuck_m = false;
            }
        } else if ((s[2] > 0.0 && n[2] <= 0.0) || (s[2] < 0.0 && n[2] >= 0.0))
            && dm.abs() <= self.tfm
        {
            self.stuck_m = true;
            n[2] = 0.0;
        }
        if self.stuck_l {
            n[4] = 0.0;
            if dl.abs() > self.tfl {
                self.stuck_l = false;
            }
        } else if ((s[4] > 0.0 && n[4] <= 0.0) || (s[4] < 0.0 && n[4] >= 0.0))
            && dl.abs() <= self.tfl
        {
            self.stuck_l = true;
            n[4] = 0.0;
        }
        self.s = n;
    }

    /// Applies `v` for one sample period (zero-order hold).
    pub fn step(&mut self, v: f64) {
        let v = v.clamp(-self.vmax, self.vmax);
        for _ in 0..self.substeps {
            self.rk4(v);
        }
    }

    /// Applies the continuous voltage `v_of(t)` (t in s from the start of this sample
    /// period) for one sample period.
    pub fn step_fn(&mut self, v_of: &dyn Fn(f64) -> f64) {
        for j in 0..self.substeps {
            self.rk4_fn(v_of, j as f64 * self.h);
        }
    }

    /// Tachometer voltage now, V.
    pub fn tach(&self) -> f64 {
        self.kts * self.s[2]
    }

    /// Load angle now, rad.
    pub fn load_angle(&self) -> f64 {
        self.s[3]
    }

    /// Tachometer record for a voltage record: element k is sampled at t_k, before
    /// `volts[k]` is applied (the measured-data convention), so it has `volts.len() + 1` rows.
    pub fn run_tach(&mut self, volts: &[f64]) -> Vec<f64> {
        let mut out = Vec::with_capacity(volts.len() + 1);
        out.push(self.tach());
        for &v in volts {
            self.step(v);
            out.push(self.tach());
        }
        out
    }
}

/// RMS of `a − b` divided by the RMS of `b`.
pub fn relative_rms_error(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    let den: f64 = b.iter().map(|y| y * y).sum();
    (num / den).sqrt()
}

/// RMS of a record.
pub fn rms(a: &[f64]) -> f64 {
    (a.iter().map(|x| x * x).sum::<f64>() / a.len() as f64).sqrt()
}

/// Least-squares first harmonic of `y` at `freq_hz` (samples every `dt`), with an offset:
/// returns the complex amplitude (re = cos coefficient … as `(a_sin, a_cos)`) so that
/// `y ≈ a_sin sin(ωt) + a_cos cos(ωt) + c`.
pub fn first_harmonic(y: &[f64], freq_hz: f64, dt: f64, t0: f64) -> (f64, f64) {
    // Normal equations of a 3-parameter fit.
    let w = 2.0 * std::f64::consts::PI * freq_hz;
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    for (k, &yk) in y.iter().enumerate() {
        let t = t0 + k as f64 * dt;
        let b = [(w * t).sin(), (w * t).cos(), 1.0];
        for i in 0..3 {
            r[i] += b[i] * yk;
            for j in 0..3 {
                m[i][j] += b[i] * b[j];
            }
        }
    }
    let x = solve3(m, r);
    (x[0], x[1])
}

fn solve3(mut m: [[f64; 3]; 3], mut r: [f64; 3]) -> [f64; 3] {
    for c in 0..3 {
        let p = (c..3)
            .max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))
            .unwrap_or(c);
        m.swap(c, p);
        r.swap(c, p);
        for row in (c + 1)..3 {
            let f = m[row][c] / m[c][c];
            let pivot = m[c];
            for (mj, pj) in m[row].iter_mut().zip(pivot.iter()).skip(c) {
                *mj -= f * pj;
            }
            r[row] -= f * r[c];
        }
    }
    let mut x = [0.0; 3];
    for c in (0..3).rev() {
        let mut acc = r[c];
        for (mj, xj) in m[c].iter().zip(x.iter()).skip(c + 1) {
            acc -= mj * xj;
        }
        x[c] = acc / m[c][c];
    }
    x
}
