//! An independent `f64` integrator of the same physics, for accuracy tests and for records
//! that do not come from the emulator (the `foreign` diagnosis suite).
//!
//! Deliberately different from the emulator: absolute angles θm and θL (not the twist),
//! classical fourth-order Runge–Kutta at a fixed fine step (1 µs by default, 500 steps per
//! emulator step), the dead zone and Coulomb friction evaluated inside every RK stage, and
//! stick/slip decided after each fine step with stuck flags (a body whose velocity changes
//! sign while its driving torque is within static friction is stopped and held until that
//! torque exceeds it). The input delay is integrated piecewise: each sample period is split
//! at the instant the delayed command changes. It shares no code with `geared_servo::plant`;
//! it reads only the parameter struct and the derived N, k_eq and δ.
//!
//! The bench effects are modelled here as their definitions read (INTERFACES.md "Effect
//! names"), not as the emulator discretises them: the stiction ratio sets the static
//! friction in the stick/slip decision; gravity is −T sin θL inside every RK stage (no
//! linearisation); the dead band maps the voltage before the limit; the tachometer's lag is
//! an eighth state integrated with the rest, its pickup and offset are added at the output.
//!
//! Beyond the emulator's physics it can carry a second structural mode
//! ([`Reference::with_second_mode`]): an inertia joined to the load by a torsional spring and
//! damper (a fin's bending/torsion mode), which no effect of the library represents.

use geared_servo::{ActuatorParams, ParamError};

/// Number of states: i, θm, ωm, θL, ωL, θ2, ω2, and the tachometer filter's output y.
const NS: usize = 8;

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
    /// Static (breakaway) frictions, N·m.
    tsm: f64,
    tsl: f64,
    /// Gravity torque T, N·m.
    grav: f64,
    /// Drive dead band, V.
    vdb: f64,
    /// Tachometer pickup (V/A), offset (V) and lag (s).
    tach_r: f64,
    tach_off: f64,
    tach_tau: f64,
    cm: f64,
    cl: f64,
    cmesh: f64,
    kh: f64,
    n: f64,
    k: f64,
    delta: f64,
    vmax: f64,
    /// Input delay, s.
    delay: f64,
    /// Second structural mode: inertia J2 (kg·m²; 0 = no mode), spring k2 (N·m/rad) and
    /// damper c2 (N·m·s/rad) between the load and J2.
    j2: f64,
    k2: f64,
    c2: f64,
    /// Sample period, s.
    period: f64,
    /// Fine steps per sample period.
    pub substeps: usize,
    h: f64,
    /// State: i (A), θm (rad), ωm (rad/s), θL (rad), ωL (rad/s), θ2 (rad), ω2 (rad/s) (these
    /// two stay 0 without a second mode), tachometer filter y (V; stays 0 without a lag).
    pub s: [f64; NS],
    stuck_m: bool,
    stuck_l: bool,
    /// Commands applied so far, V (only those the delay still needs are kept).
    history: Vec<f64>,
}

impl Reference {
    /// Builds the reference from validated parameters, with `fine_step_s` as its RK4 step.
    pub fn new(p: &ActuatorParams, fine_step_s: f64) -> Result<Reference, ParamError> {
        let d = p.derived()?;
        let substeps = (p.sample_period_s / fine_step_s).round().max(1.0) as usize;
        let e = &p.effects;
        let stiction = if e.stiction_ratio > 0.0 {
            e.stiction_ratio
        } else {
            1.0
        };
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
            tsm: stiction * p.motor.coulomb_friction_nm,
            tsl: stiction * p.load.coulomb_friction_nm,
            grav: e.gravity_torque,
            vdb: e.drive_deadband,
            tach_r: e.tach_current_coupling,
            tach_off: e.tach_offset,
            tach_tau: e.tach_lag,
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
            delay: p.effects.input_delay.max(0.0),
            j2: 0.0,
            k2: 0.0,
            c2: 0.0,
            period: p.sample_period_s,
            substeps,
            h: p.sample_period_s / substeps as f64,
            s: [0.0; NS],
            stuck_m: true,
            stuck_l: true,
            history: Vec::new(),
        })
    }

    /// Adds a second structural mode outside the library's model: an inertia `j2` (kg·m²)
    /// joined to the load by a torsional spring `k2` (N·m/rad) and a damper `c2`
    /// (N·m·s/rad), e.g. a fin's bending or torsion mode. Its natural frequency on a held
    /// load is √(k2/j2)/2π. The load inertia of the parameters is then the rest of the load
    /// (hub and shaft). `j2 <= 0` means no mode.
    pub fn with_second_mode(mut self, j2: f64, k2: f64, c2: f64) -> Self {
        if j2 > 0.0 {
            self.j2 = j2;
            self.k2 = k2;
            self.c2 = c2;
        } else {
            self.j2 = 0.0;
            self.k2 = 0.0;
            self.c2 = 0.0;
        }
        self
    }

    fn gear_torque(&self, s: &[f64; NS]) -> f64 {
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

    /// Torque of the second mode's spring and damper on J2 (minus that on the load), N·m.
    fn mode_torque(&self, s: &[f64; NS]) -> f64 {
        if self.j2 > 0.0 {
            self.k2 * (s[3] - s[5]) + self.c2 * (s[4] - s[6])
        } else {
            0.0
        }
    }

    /// Torques on (motor, load) other than Coulomb friction.
    fn drives(&self, s: &[f64; NS]) -> (f64, f64) {
        let tl = self.gear_torque(s);
        (
            self.kt * s[0] - tl / self.n - self.cm * s[2],
            tl - self.cl * s[4] - self.kh * s[3] - self.grav * s[3].sin() - self.mode_torque(s),
        )
    }

    /// The tachometer circuit's signal k_ts ωm + r i (before its lag), V.
    fn tach_signal(&self, s: &[f64; NS]) -> f64 {
        self.kts * s[2] + self.tach_r * s[0]
    }

    /// Voltage at the winding for command `v`: the dead band, then the limit.
    fn drive_voltage(&self, v: f64) -> f64 {
        let v = if v.abs() <= self.vdb {
            0.0
        } else {
            v - self.vdb * v.signum()
        };
        v.clamp(-self.vmax, self.vmax)
    }

    /// Friction torque on a body of speed `speed` whose other torques sum to `drive`:
    /// holds it (up to the static friction `ts`) at zero speed, −tf sign(speed) sliding.
    fn coulomb(speed: f64, drive: f64, tf: f64, ts: f64) -> f64 {
        let dir = if speed != 0.0 {
            speed.signum()
        } else {
            drive.signum()
        };
        if speed == 0.0 && drive.abs() <= ts {
            -drive
        } else {
            -tf * dir
        }
    }

    fn deriv(&self, s: &[f64; NS], v: f64) -> [f64; NS] {
        let (dm, dl) = self.drives(s);
        let am = if self.stuck_m {
            0.0
        } else {
            (dm + Self::coulomb(s[2], dm, self.tfm, self.tsm)) / self.jm
        };
        let al = if self.stuck_l {
            0.0
        } else {
            (dl + Self::coulomb(s[4], dl, self.tfl, self.tsl)) / self.jl
        };
        let a2 = if self.j2 > 0.0 {
            self.mode_torque(s) / self.j2
        } else {
            0.0
        };
        [
            (v - self.r * s[0] - self.kb * s[2]) / self.l,
            s[2],
            am,
            s[4],
            al,
            s[6],
            a2,
            if self.tach_tau > 0.0 {
                (self.tach_signal(s) - s[7]) / self.tach_tau
            } else {
                0.0
            },
        ]
    }

    /// One RK4 step of length `h` with the voltage a function of time since `t0` (the
    /// step's start); the voltage is saturated here.
    fn rk4_fn(&mut self, v_of: &dyn Fn(f64) -> f64, t0: f64, h: f64) {
        let v = |t: f64| self.drive_voltage(v_of(t));
        let vs = [v(t0), v(t0 + h / 2.0), v(t0 + h)];
        self.rk4_with(h, vs);
    }

    /// One RK4 step of length `h` with the (already saturated) voltage at its start, middle
    /// and end.
    fn rk4_with(&mut self, h: f64, v: [f64; 3]) {
        let s = self.s;
        let add = |a: &[f64; NS], b: &[f64; NS], c: f64| {
            let mut o = *a;
            for (oi, bi) in o.iter_mut().zip(b) {
                *oi += c * bi;
            }
            o
        };
        let k1 = self.deriv(&s, v[0]);
        let k2 = self.deriv(&add(&s, &k1, h / 2.0), v[1]);
        let k3 = self.deriv(&add(&s, &k2, h / 2.0), v[1]);
        let k4 = self.deriv(&add(&s, &k3, h), v[2]);
        let mut n = s;
        for j in 0..NS {
            n[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
        }
        // Stick/slip after the fine step.
        let (dm, dl) = self.drives(&n);
        if self.stuck_m {
            n[2] = 0.0;
            if dm.abs() > self.tsm {
                self.stuck_m = false;
            }
        } else if ((s[2] > 0.0 && n[2] <= 0.0) || (s[2] < 0.0 && n[2] >= 0.0))
            && dm.abs() <= self.tsm
        {
            self.stuck_m = true;
            n[2] = 0.0;
        }
        if self.stuck_l {
            n[4] = 0.0;
            if dl.abs() > self.tsl {
                self.stuck_l = false;
            }
        } else if ((s[4] > 0.0 && n[4] <= 0.0) || (s[4] < 0.0 && n[4] >= 0.0))
            && dl.abs() <= self.tsl
        {
            self.stuck_l = true;
            n[4] = 0.0;
        }
        self.s = n;
    }

    /// Holds the command `v` (through the dead band and the limit) for `len` s, in fine
    /// steps of at most the fine step.
    fn hold(&mut self, v: f64, len: f64, steps: usize) {
        let v = self.drive_voltage(v);
        let h = len / steps as f64;
        for _ in 0..steps {
            self.rk4_with(h, [v, v, v]);
        }
    }

    /// Applies command `v` for one sample period (zero-order hold). With an input delay d
    /// the voltage at time t is the command of the period that held at t − d, saturated
    /// after the delay: the period is split where the delayed command changes.
    pub fn step(&mut self, v: f64) {
        if self.delay <= 0.0 {
            self.hold(v, self.period, self.substeps);
            return;
        }
        self.history.push(v);
        let ratio = self.delay / self.period;
        // Whole periods m and the fraction φ/h (a delay within 1e-9 period of a whole number
        // is taken as whole).
        let mut m = ratio.floor();
        let mut frac = ratio - m;
        if frac > 1.0 - 1e-9 {
            m += 1.0;
            frac = 0.0;
        } else if frac < 1e-9 {
            frac = 0.0;
        }
        let m = m as usize;
        let k = self.history.len() - 1;
        let cmd = |j: Option<usize>| j.and_then(|j| self.history.get(j)).copied().unwrap_or(0.0);
        let late = cmd(k.checked_sub(m));
        let early = cmd(k.checked_sub(m + 1));
        if frac > 0.0 {
            let first = frac * self.period;
            let n1 = ((first / self.h) - 1e-9).ceil().max(1.0) as usize;
            let n2 = (((self.period - first) / self.h) - 1e-9).ceil().max(1.0) as usize;
            self.hold(early, first, n1);
            self.hold(late, self.period - first, n2);
        } else {
            self.hold(late, self.period, self.substeps);
        }
        // Keep only the commands a later period can still need.
        if self.history.len() > m + 2 {
            let drop = self.history.len() - (m + 2);
            self.history.drain(..drop);
        }
    }

    /// Applies the continuous voltage `v_of(t)` (t in s from the start of this sample
    /// period) for one sample period. The input delay is not applied here: `v_of` is the
    /// command at the terminals (through the dead band, saturated by the voltage limit).
    pub fn step_fn(&mut self, v_of: &dyn Fn(f64) -> f64) {
        let h = self.h;
        for j in 0..self.substeps {
            self.rk4_fn(v_of, j as f64 * h, h);
        }
    }

    /// Tachometer voltage now (gain error, current pickup, lag and offset), V.
    pub fn tach(&self) -> f64 {
        let y = if self.tach_tau > 0.0 {
            self.s[7]
        } else {
            self.tach_signal(&self.s)
        };
        y + self.tach_off
    }

    /// Armature current now, A.
    pub fn current(&self) -> f64 {
        self.s[0]
    }

    /// Motor speed now, rad/s.
    pub fn motor_speed(&self) -> f64 {
        self.s[2]
    }

    /// Load angle now, rad.
    pub fn load_angle(&self) -> f64 {
        self.s[3]
    }

    /// Load speed now, rad/s.
    pub fn load_speed(&self) -> f64 {
        self.s[4]
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

    /// Tachometer (V), load angle (rad) and armature current (A) records for a voltage
    /// record, in the convention of [`Reference::run_tach`] (`volts.len() + 1` rows each).
    pub fn run_sensors(&mut self, volts: &[f64]) -> Sensed {
        let mut out = Sensed::with_capacity(volts.len() + 1);
        out.push(self);
        for &v in volts {
            self.step(v);
            out.push(self);
        }
        out
    }

    /// Tachometer (V) and load angle (rad) records for a voltage record, in the convention of
    /// [`Reference::run_tach`] (`volts.len() + 1` rows each).
    pub fn run_tach_and_angle(&mut self, volts: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let run = self.run_sensors(volts);
        (run.tach, run.angle)
    }
}

/// The sensors of a reference run, one sample per row ([`Reference::run_sensors`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sensed {
    /// Tachometer voltage, V.
    pub tach: Vec<f64>,
    /// Load angle, rad.
    pub angle: Vec<f64>,
    /// Armature current, A.
    pub current: Vec<f64>,
}

impl Sensed {
    fn with_capacity(n: usize) -> Sensed {
        Sensed {
            tach: Vec::with_capacity(n),
            angle: Vec::with_capacity(n),
            current: Vec::with_capacity(n),
        }
    }

    fn push(&mut self, r: &Reference) {
        self.tach.push(r.tach());
        self.angle.push(r.load_angle());
        self.current.push(r.current());
    }

    /// Keeps the first `n` rows of each.
    pub fn truncate(&mut self, n: usize) {
        self.tach.truncate(n);
        self.angle.truncate(n);
        self.current.truncate(n);
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

#[cfg(test)]
mod tests {
    use super::*;
    use geared_servo::REFERENCE;

    /// A 10 V step held for `n` samples, then 0 V.
    fn pulse(n: usize, off: usize) -> Vec<f64> {
        (0..n).map(|k| if k < off { 10.0 } else { 0.0 }).collect()
    }

    #[test]
    fn a_whole_step_delay_shifts_the_record_exactly() {
        let p0 = REFERENCE.with_backlash_deg(0.05);
        let v = pulse(400, 200);
        let y0 = Reference::new(&p0, 2e-6).unwrap().run_tach(&v);
        for m in [1usize, 3] {
            let mut p = p0;
            p.effects.input_delay = m as f64 * p0.sample_period_s;
            let y = Reference::new(&p, 2e-6).unwrap().run_tach(&v);
            assert!(y.iter().take(m + 1).all(|&x| x == 0.0));
            for k in 0..y0.len() - m {
                assert_eq!(y[k + m], y0[k], "delay {m}, row {k}");
            }
        }
    }

    #[test]
    fn a_fractional_delay_arrives_that_much_later() {
        // Frictionless and without backlash, so the current answers the moment the voltage
        // arrives: 1.5 periods of delay, the current is still 0 at t_1 and not at t_2.
        let mut p = REFERENCE.without_friction();
        let h = p.sample_period_s;
        p.effects.input_delay = 1.5 * h;
        let mut r = Reference::new(&p, 1e-6).unwrap();
        r.step(10.0);
        assert_eq!(r.current(), 0.0);
        r.step(10.0);
        assert!(r.current() > 0.01, "{}", r.current());
        // And it is the same as a reference at a quarter of the period with a whole delay of
        // six quarter periods (each command held for four).
        let v = pulse(200, 60);
        let fine_v: Vec<f64> = v.iter().flat_map(|&x| [x; 4]).collect();
        let mut q = p;
        q.sample_period_s = h / 4.0;
        let y = Reference::new(&p, 1e-6).unwrap().run_tach(&v);
        let yq = Reference::new(&q, 1e-6).unwrap().run_tach(&fine_v);
        for (k, a) in y.iter().enumerate() {
            let b = yq[4 * k];
            assert!(
                (a - b).abs() <= 1e-9 * (1.0 + b.abs()),
                "row {k}: {a} vs {b}"
            );
        }
    }

    #[test]
    fn the_voltage_limit_applies_after_the_delay() {
        let mut p = REFERENCE.without_friction();
        p.effects.voltage_limit = 5.0;
        let mut pd = p;
        pd.effects.input_delay = 2.0 * p.sample_period_s;
        let v = pulse(300, 100);
        let y = Reference::new(&p, 2e-6).unwrap().run_tach(&v);
        let yd = Reference::new(&pd, 2e-6).unwrap().run_tach(&v);
        for k in 0..y.len() - 2 {
            assert!((yd[k + 2] - y[k]).abs() <= 1e-12, "row {k}");
        }
    }

    #[test]
    fn a_stiff_second_mode_adds_its_inertia_to_the_load() {
        // Mode at about 1.6 kHz, well damped: below it, the extra inertia moves with the load.
        let p = REFERENCE.with_backlash_deg(0.05);
        let j2 = 0.2 * p.load.inertia_kg_m2;
        let k2 = j2 * (2.0 * std::f64::consts::PI * 1600.0f64).powi(2);
        let c2 = 2.0 * 0.5 * (k2 * j2).sqrt();
        let mut whole = p;
        whole.load.inertia_kg_m2 += j2;
        let v: Vec<f64> = (0..1000)
            .map(|k| if (k / 100) % 2 == 0 { 8.0 } else { -8.0 })
            .collect();
        let a = Reference::new(&p, 1e-6)
            .unwrap()
            .with_second_mode(j2, k2, c2)
            .run_tach(&v);
        let b = Reference::new(&whole, 1e-6).unwrap().run_tach(&v);
        let c = Reference::new(&p, 1e-6).unwrap().run_tach(&v);
        let e = relative_rms_error(&a, &b);
        let without = relative_rms_error(&c, &b);
        assert!(e < 0.02, "{e}");
        assert!(without > 5.0 * e, "{without} vs {e}");
    }

    #[test]
    fn no_second_mode_changes_nothing() {
        let p = REFERENCE.with_backlash_deg(0.05);
        let v = pulse(300, 150);
        let a = Reference::new(&p, 2e-6).unwrap().run_tach(&v);
        let b = Reference::new(&p, 2e-6)
            .unwrap()
            .with_second_mode(0.0, 100.0, 1.0)
            .run_tach(&v);
        assert_eq!(a, b);
    }
}
