//! Closed-form sinusoidal steady state of the linear plant (gears in contact, no backlash, no
//! Coulomb friction), driven by a continuous sine on the winding.
//!
//! Used by the describing function (twist amplitude), by the frequency-response analyser
//! (a warm start that removes most of the transient) and by the tests (the analytic
//! `V_t/V_m`). Impedance form, every quantity a phasor per volt of input:
//!
//! ```text
//! K(s)   = (k + c s)/s                         gear spring (+ mesh damping), torque per speed
//! Z_L(s) = J_L s + b_L + k_g/s                  load (inertia, viscous, spring to ground)
//! Z_m(s) = J_m s + b_m + K Z_L / (N² (Z_L + K)) motor shaft as the motor sees it
//! Ωm/V   = k_t e^{−sτ} / ((L s + R) Z_m + k_t k_b)
//! V_t/V  = (k_ts Ωm/V + r I/V) / (1 + τ_t s)    tachometer (current pickup r, lag τ_t)
//! ```
//!
//! The spring to ground k_g is the hinge spring plus the gravity torque, linearised about
//! the hanging position (−T sin θ_L ≈ −T θ_L). The drive's dead band, stiction and the
//! tachometer's offset are not linear and are left out, like Coulomb friction.
//!
//! With b = c = k_h = 0 the zero of `Ωm/V` is eq. 17a and the zero of the current `I/V` is
//! eq. 17b (where `Ωm/T_m` has its pole the back-EMF cancels the applied voltage).

use crate::params::ActuatorParams;
use crate::{ParamError, PlantState};
use core::ops::{Add, Div, Mul, Sub};

/// A complex number (f64), just what the phasor algebra needs.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Complex {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Complex {
    /// `re + j im`.
    pub const fn new(re: f64, im: f64) -> Complex {
        Complex { re, im }
    }
    /// Modulus.
    pub fn abs(self) -> f64 {
        libm::hypot(self.re, self.im)
    }
    /// Argument, rad in (−π, π].
    pub fn arg(self) -> f64 {
        libm::atan2(self.im, self.re)
    }
    /// Real scale.
    pub fn scale(self, a: f64) -> Complex {
        Complex::new(self.re * a, self.im * a)
    }
}

impl core::ops::Add for Complex {
    type Output = Complex;
    fn add(self, o: Complex) -> Complex {
        Complex::new(self.re + o.re, self.im + o.im)
    }
}

impl core::ops::Sub for Complex {
    type Output = Complex;
    fn sub(self, o: Complex) -> Complex {
        Complex::new(self.re - o.re, self.im - o.im)
    }
}

impl core::ops::Mul for Complex {
    type Output = Complex;
    fn mul(self, o: Complex) -> Complex {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
}

/// Quotient (∞/NaN when the divisor is 0).
impl core::ops::Div for Complex {
    type Output = Complex;
    fn div(self, o: Complex) -> Complex {
        let d = o.re * o.re + o.im * o.im;
        Complex::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
}

/// Steady-state phasors per volt of the sine `V sin ωt` (input phasor V, real), at one
/// frequency. A quantity `q(t) = Im(Q V e^{jωt})`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearResponse {
    /// Tachometer voltage per volt, V/V: `V_t/V_m`.
    pub tach: Complex,
    /// Armature current per volt, A/V.
    pub current: Complex,
    /// Motor speed per volt, rad/s/V.
    pub motor_speed: Complex,
    /// Load speed per volt, rad/s/V.
    pub load_speed: Complex,
    /// Total twist x = θm/N − θL per volt, rad/V.
    pub twist: Complex,
    /// Load angle per volt, rad/V.
    pub load_angle: Complex,
}

/// The linear plant with a given gear stiffness (the describing function substitutes
/// `k_eff`), ready to evaluate at any frequency. Validated once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearModel {
    r: f64,
    l: f64,
    kt: f64,
    kb: f64,
    kts: f64,
    jm: f64,
    jl: f64,
    bm: f64,
    bl: f64,
    c: f64,
    kh: f64,
    n: f64,
    delay: f64,
    /// Tachometer current pickup, V/A.
    r_tach: f64,
    /// Tachometer lag, s.
    tau_tach: f64,
    /// Gear stiffness at the load used by this model, N·m/rad.
    pub k_nm_per_rad: f64,
}

impl LinearModel {
    /// The linear model of `params` with its own k_eq (eq. 16).
    pub fn new(params: &ActuatorParams) -> Result<LinearModel, ParamError> {
        let d = params.derived()?;
        Ok(Self::with_stiffness(params, d.n_total, d.k_eq_nm_per_rad))
    }

    fn with_stiffness(p: &ActuatorParams, n: f64, k: f64) -> LinearModel {
        let m = &p.motor;
        let e = &p.effects;
        LinearModel {
            r: m.resistance_ohm,
            l: m.inductance_h,
            kt: m.torque_constant_nm_per_a,
            kb: m.back_emf_v_s_per_rad,
            kts: m.tach_v_s_per_rad * (1.0 + e.tach_gain),
            jm: m.inertia_kg_m2,
            jl: p.load.inertia_kg_m2,
            bm: e.motor_viscous,
            bl: e.load_viscous,
            c: e.mesh_damping,
            kh: p.ground_stiffness_nm_per_rad(),
            n,
            delay: e.input_delay,
            r_tach: e.tach_current_coupling,
            tau_tach: e.tach_lag,
            k_nm_per_rad: k,
        }
    }

    /// The same plant with the gear stiffness replaced by `k_nm_per_rad` (N·m/rad at the load).
    pub fn with_k(mut self, k_nm_per_rad: f64) -> LinearModel {
        self.k_nm_per_rad = k_nm_per_rad;
        self
    }

    /// Total ratio N.
    pub fn ratio(&self) -> f64 {
        self.n
    }

    /// Anti-resonance of this model's stiffness, Hz (eq. 17a).
    pub fn f_ar_hz(&self) -> f64 {
        libm::sqrt(self.k_nm_per_rad / self.jl) / (2.0 * core::f64::consts::PI)
    }

    /// Resonance of `Ωm/T_m` for this model's stiffness, Hz (eq. 17b).
    pub fn f_r_hz(&self) -> f64 {
        let nj = self.n * self.n * self.jm;
        libm::sqrt(self.k_nm_per_rad * (nj + self.jl) / (nj * self.jl))
            / (2.0 * core::f64::consts::PI)
    }

    /// Steady-state response at `freq_hz` (Hz, > 0).
    pub fn response(&self, freq_hz: f64) -> LinearResponse {
        let w = 2.0 * core::f64::consts::PI * freq_hz;
        let s = Complex::new(0.0, w);
        let k = Complex::new(self.k_nm_per_rad, w * self.c).div(s);
        let zl = Complex::new(self.bl, w * self.jl).add(Complex::new(self.kh, 0.0).div(s));
        let zm0 = Complex::new(self.bm, w * self.jm);
        let el = Complex::new(self.r, w * self.l);
        let delay = Complex::new(libm::cos(w * self.delay), -libm::sin(w * self.delay));
        // Everything over D = Z_L + K, which vanishes at the anti-resonance.
        let dd = zl.add(k);
        let den = el
            .mul(zm0.mul(dd).add(k.mul(zl).scale(1.0 / (self.n * self.n))))
            .add(dd.scale(self.kt * self.kb));
        let drive = delay.scale(self.kt).div(den);
        let wm = drive.mul(dd);
        let current = delay.sub(wm.scale(self.kb)).div(el);
        let wl = drive.mul(k).scale(1.0 / self.n);
        let twist = drive.mul(zl).div(s).scale(1.0 / self.n);
        let lag = Complex::new(1.0, w * self.tau_tach);
        LinearResponse {
            tach: wm.scale(self.kts).add(current.scale(self.r_tach)).div(lag),
            current,
            motor_speed: wm,
            load_speed: wl,
            twist,
            load_angle: wl.div(s),
        }
    }
}

impl LinearModel {
    /// The plant state on the steady-state orbit of `amplitude_v · sin ωt` at t = 0 (phase 0):
    /// a warm start that spares the analyser most of the transient. Exact for the linear
    /// plant; an initial guess otherwise.
    pub fn steady_state(&self, freq_hz: f64, amplitude_v: f64) -> PlantState {
        let r = self.response(freq_hz);
        let im = |c: Complex| (c.im * amplitude_v) as f32;
        let mut s = PlantState::REST;
        s.current_a = im(r.current);
        s.motor_speed_rad_s = im(r.motor_speed);
        s.load_speed_rad_s = im(r.load_speed);
        s.twist_rad = im(r.twist);
        s.load_angle_rad = im(r.load_angle);
        if self.tau_tach > 0.0 {
            // The tachometer filter's own state (offset excluded, as the plant keeps it).
            s.tach_filter_v = im(r.tach);
        }
        s
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::params::REFERENCE;

    #[test]
    fn tach_zero_is_eq_17a_and_current_zero_is_eq_17b() {
        let p = REFERENCE.without_friction();
        let d = p.derived().unwrap();
        let m = LinearModel::new(&p).unwrap();
        assert!(m.response(d.f_ar_hz).tach.abs() < 1e-9);
        assert!(m.response(d.f_r_hz).current.abs() < 1e-9);
        assert!((m.f_ar_hz() - d.f_ar_hz).abs() < 1e-9);
        assert!((m.f_r_hz() - d.f_r_hz).abs() < 1e-9);
    }

    #[test]
    fn low_frequency_gain_tends_to_tach_over_back_emf() {
        // Below the mechanical pole the motor runs at V/k_b: V_t/V_m → k_ts/k_b = 0.5.
        let m = LinearModel::new(&REFERENCE).unwrap();
        let g = m.response(0.01).tach.abs();
        assert!((g - 0.5).abs() < 1e-3, "{g}");
    }
}
