//! The tachometer as a sensor: sensitivity (with `tach_gain`), `tach_offset`,
//! `tach_current_coupling` and `tach_lag`.
//!
//! This is the one measurement model of the tachometer. [`crate::Outputs::tach_voltage_v`]
//! is computed here, and everything that wants the tachometer voltage reads that field: the
//! host's `simulate`, the calibration and `diagnose` (which run the plant over a record) and
//! the firmware's emulated ADC ([`crate::Sensors`], which converts it to counts).
//!
//! ```text
//! u(t)   = k_ts (1 + g) ωm(t) + r i(t)       what the tachometer circuit carries, V
//! τ ẏ    = u − y                             its first-order lag (y = u when τ = 0)
//! V_t    = y + V_off                         the output, sampled at the end of each step
//! ```
//!
//! The lag is discretised exactly for the shapes its two inputs take within a step. Each
//! is known at both ends of the step and, exactly, on average over it (the mean speed
//! Δθm/h and the mean current `(V h − k_b Δθm − L Δi)/(R h)` follow from the state), and a
//! curve through those three facts is convolved with the filter's kernel in closed form:
//! - the current, which under a held voltage settles with the winding's time constant
//!   τe = L/R (25 µs on the reference, against a 500 µs step), as `α + β t + γ e^{−t/τe}`:
//!   exact for a winding driven by a speed linear over the step. Where τe exceeds half a
//!   step the exponential is smooth there and the current is taken as a quadratic.
//! - the speed as a quadratic in time plus the settling the current's exponential gives
//!   it while the motor slides, −(k_t τe / J_m) γ e^{−t/τe} (J_m ω̇ = k_t i − smooth
//!   torques).
//!
//! The error is that of these fits within one step, largest for a lag shorter than the step
//! on a fast record, where the output depends on the last part of the step: against the RK4
//! reference (host-tests/tests/bench_effects.rs) 0.19 % relative RMS on a 10 V, 150 Hz sine
//! with a 50 µs lag (0.38 % with the speed as a bare quadratic; 0.03 % without the lag),
//! 0.01–0.1 % for lags of 0.3–2 ms, within the plant's 1 % budget. τ ≪ h gives y = u at
//! the sample, τ ≫ h a pure integrator of the mean.
//!
//! Everything off (the default), the output is `k_ts (1 + g) ωm` exactly, as before these
//! effects existed; the filter state in [`crate::PlantState`] is then never read or written.

use super::modes::to_f32;
use crate::effects::Effect;
use crate::error::ParamError;
use crate::params::ActuatorParams;

/// The tachometer's configuration, precomputed (the filter's state lives in the plant state).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Tach {
    /// Sensitivity k_ts (1 + tach_gain), V·s/rad.
    k: f32,
    /// Current pickup r, V/A.
    r: f32,
    /// Output offset, V.
    offset: f32,
    /// Some effect beyond the gain is on (otherwise the output is `k ωm`, nothing else).
    extra: bool,
    /// The lag is on.
    lag: bool,
    /// Filter coefficients: y₁ = a y₀ + w0 u₀ + w1 u₁ plus, for each input, a weight times
    /// the departure of its mean from its ends' mean (the curvature of its curve within the
    /// step): `wq_speed k (ω̄ − (ω₀ + ω₁)/2)` and `wq_current r (ī − (i₀ + i₁)/2)`.
    a: f32,
    w0: f32,
    w1: f32,
    wq_speed: f32,
    wq_current: f32,
    /// Weight of k (ī − (i₀ + i₁)/2) for the speed's own settling (0 when the current is
    /// fitted as a quadratic).
    wq_speed_settling: f32,
}

/// Below this many winding time constants per step the current's settling is smooth over
/// the step and is fitted as a quadratic (the exponential fit's system becomes
/// ill-conditioned as λe → 0: its determinant falls as −λe²/12).
const EXP_FIT_MIN_STEPS: f64 = 2.0;

/// `(e^d − 1)/d`, 1 at d = 0, without cancellation.
fn expm1_ratio(d: f64) -> f64 {
    if d == 0.0 {
        1.0
    } else {
        libm::expm1(d) / d
    }
}

/// Weighted moments of the lag's kernel over one step, `λ = h/τ`: returns
/// `P_n = ∫₀¹ λ ρⁿ e^{−λρ} dρ` for n = 0, 1, 2 (ρ: time before the step's end, in steps).
/// A power series below λ = 1 (the closed forms cancel there), the closed forms above.
fn kernel_moments(lambda: f64) -> [f64; 3] {
    if lambda < 1.0 {
        // P_n = λ Σ_k (−λ)^k / (k! (n + k + 1)); 24 terms leave less than 1/24! ≈ 2e-24.
        let mut p = [0.0f64; 3];
        let mut term = lambda; // λ (−λ)^k / k!
        for k in 0..24u32 {
            for (n, pn) in p.iter_mut().enumerate() {
                *pn += term / f64::from(n as u32 + k + 1);
            }
            term *= -lambda / f64::from(k + 1);
        }
        p
    } else {
        let a = libm::exp(-lambda);
        [
            1.0 - a,
            (1.0 - a - lambda * a) / lambda,
            (2.0 - a * (lambda * lambda + 2.0 * lambda + 2.0)) / (lambda * lambda),
        ]
    }
}

impl Tach {
    /// The tachometer of `p` at the step `h` (s).
    pub(super) fn new(p: &ActuatorParams, h: f64) -> Result<Tach, ParamError> {
        let e = &p.effects;
        let k = to_f32(
            p.motor.tach_v_s_per_rad * (1.0 + e.tach_gain),
            Effect::TachGain.key(),
        )?;
        let r = to_f32(e.tach_current_coupling, Effect::TachCurrentCoupling.key())?;
        let offset = to_f32(e.tach_offset, Effect::TachOffset.key())?;
        let lag = e.tach_lag > 0.0;
        let (mut a, mut w0, mut w1, mut wq_speed, mut wq_current) = (0.0, 0.0, 1.0, 0.0, 0.0);
        let mut wq_speed_settling = 0.0;
        if lag {
            let lambda = h / e.tach_lag;
            let [p0, p1, p2] = kernel_moments(lambda);
            // ∫ kernel · (u₀ + (u₁ − u₀) σ + c σ (1 − σ)), σ = 1 − ρ the time in steps; the
            // bump σ (1 − σ) has mean 1/6, so c = 6 (ū − (u₀ + u₁)/2).
            a = libm::exp(-lambda);
            w0 = p1;
            w1 = p0 - p1;
            wq_speed = 6.0 * (p1 - p2);
            wq_current = wq_speed;
            let le = h * p.motor.resistance_ohm / p.motor.inductance_h;
            if le >= EXP_FIT_MIN_STEPS {
                // α + β σ + γ e^{−λe σ} through i₀, i₁ and the mean ī: γ = (ī − (i₀ + i₁)/2)/D
                // with D = M − (1 + E)/2, E = e^{−λe}, M = (1 − E)/λe its mean. Its kernel
                // integral is i₀ P1 + i₁ (P0 − P1) + γ (X − P0 + (1 − E)(P0 − P1)), with
                // X = ∫ λ e^{−λρ} e^{−λe (1 − ρ)} dρ = λ e^{−λe} (e^{λe − λ} − 1)/(λe − λ).
                let big_e = libm::exp(-le);
                let m = -libm::expm1(-le) / le;
                let d = m - 0.5 * (1.0 + big_e);
                let x = lambda * big_e * expm1_ratio(le - lambda);
                wq_current = (x - p0 + (1.0 - big_e) * (p0 - p1)) / d;
                // The speed's part −c γ e^{−λe σ}, c = k_t τe / J_m: the quadratic is fitted
                // to the rest (ends and mean shifted by c γ, c γ E, c γ M), so its kernel
                // integral gains c γ (w0 + w1 E + wq_speed D − X), with γ as above.
                let c = p.motor.torque_constant_nm_per_a * p.motor.inductance_h
                    / (p.motor.resistance_ohm * p.motor.inertia_kg_m2);
                wq_speed_settling = c * (w0 + w1 * big_e + wq_speed * d - x) / d;
            }
        }
        let key = Effect::TachLag.key();
        Ok(Tach {
            k,
            r,
            offset,
            extra: r != 0.0 || offset != 0.0 || lag,
            lag,
            a: to_f32(a, key)?,
            w0: to_f32(w0, key)?,
            w1: to_f32(w1, key)?,
            wq_speed: to_f32(wq_speed, key)?,
            wq_current: to_f32(wq_current, key)?,
            wq_speed_settling: to_f32(wq_speed_settling, key)?,
        })
    }

    /// Whether any effect beyond the gain is on (offset, pickup or lag).
    #[inline(always)]
    pub(super) fn extra(&self) -> bool {
        self.extra
    }

    /// The output without offset, pickup or lag: `k ωm`, V ([`Tach::read`] when none is on).
    #[inline(always)]
    pub(super) fn plain(&self, speed: f32) -> f32 {
        self.k * speed
    }

    /// Whether the lag is on (the plant then advances the filter each step).
    #[inline(always)]
    pub(super) fn lagged(&self) -> bool {
        self.lag
    }

    /// The circuit's signal u = k ωm + r i, V.
    #[inline(always)]
    fn signal(&self, speed: f32, current: f32) -> f32 {
        self.k * speed + self.r * current
    }

    /// The output V_t, V, for the filter state `filter` (V; unused without a lag), motor
    /// speed `speed` (rad/s) and current `current` (A) at the sample instant.
    #[inline(always)]
    pub(super) fn read(&self, filter: f32, speed: f32, current: f32) -> f32 {
        if !self.extra {
            self.k * speed
        } else if self.lag {
            filter + self.offset
        } else {
            self.signal(speed, current) + self.offset
        }
    }

    /// The filter state at the end of a step that went from (`speed0`, `current0`) to
    /// (`speed1`, `current1`) with mean speed `mean_speed` (rad/s) and mean current
    /// `mean_current` (A) over it.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn advance(
        &self,
        filter: f32,
        (speed0, current0): (f32, f32),
        (speed1, current1): (f32, f32),
        mean_speed: f32,
        mean_current: f32,
    ) -> f32 {
        let u0 = self.signal(speed0, current0);
        let u1 = self.signal(speed1, current1);
        let bend_speed = self.k * (mean_speed - 0.5 * (speed0 + speed1));
        let bend = mean_current - 0.5 * (current0 + current1);
        // The speed settles with the current only while the motor slides (stuck, it is 0).
        let settling = if speed0 != 0.0 && speed1 != 0.0 {
            self.wq_speed_settling * self.k
        } else {
            0.0
        };
        let y = self.a * filter
            + (self.w0 * u0 + self.w1 * u1)
            + (self.wq_speed * bend_speed + (self.wq_current * self.r + settling) * bend);
        // A non-finite state (from a non-finite plant state) would stay so forever.
        if y.is_finite() {
            y
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact response of the lag to the quadratic `u(t) = c0 + c1 t + c2 t²` from y₀ over h:
    /// y(h) = e^{−h/τ} y₀ + the particular solution's difference, by the standard
    /// polynomial solution y_p = c0 + c1 (t − τ) + c2 (t² − 2τ t + 2τ²).
    fn exact(tau: f64, h: f64, y0: f64, c: [f64; 3]) -> f64 {
        let yp =
            |t: f64| c[0] + c[1] * (t - tau) + c[2] * (t * t - 2.0 * tau * t + 2.0 * tau * tau);
        let a = (-h / tau).exp();
        yp(h) + (y0 - yp(0.0)) * a
    }

    const LAGS: [f64; 6] = [1e-6, 5e-5, 4.9e-4, 5.1e-4, 2e-3, 0.3];

    /// The coefficients reproduce the exact response to a speed quadratic in time for lags
    /// from far below to far above the step (both branches of the moments), to f32
    /// rounding.
    #[test]
    fn lag_is_exact_for_a_speed_quadratic_within_the_step() {
        let h = 5e-4;
        for tau in LAGS {
            let mut p = crate::params::REFERENCE;
            p.effects.tach_lag = tau;
            // u in volts directly: unit sensitivity, no pickup.
            let t = Tach {
                k: 1.0,
                r: 0.0,
                ..Tach::new(&p, h).unwrap()
            };
            let c = [0.7, 900.0, -3.0e6];
            let u = |s: f64| c[0] + c[1] * s + c[2] * s * s;
            let mean = c[0] + c[1] * h / 2.0 + c[2] * h * h / 3.0;
            let y0 = -0.2;
            let got = t.advance(
                y0 as f32,
                (u(0.0) as f32, 0.0),
                (u(h) as f32, 0.0),
                mean as f32,
                0.0,
            );
            let want = exact(tau, h, y0, c);
            assert!(
                (f64::from(got) - want).abs() <= 2e-6 * (1.0 + want.abs()),
                "τ {tau}: {got} vs {want}"
            );
        }
    }

    /// Exact response of the lag to `u(t) = α + β t + γ e^{−t/τe}` from y₀ over h: the
    /// polynomial part as in [`exact`], the exponential's particular solution
    /// γ e^{−t/τe} / (1 − τ/τe).
    fn exact_exp(tau: f64, tau_e: f64, h: f64, y0: f64, c: [f64; 3]) -> f64 {
        let g = c[2] / (1.0 - tau / tau_e);
        let yp = |t: f64| c[0] + c[1] * (t - tau) + g * (-t / tau_e).exp();
        yp(h) + (y0 - yp(0.0)) * (-h / tau).exp()
    }

    /// The current's settling (the winding's exponential plus a ramp) goes through the lag
    /// exactly, to f32 rounding, for the same lags.
    #[test]
    fn lag_is_exact_for_a_settling_current_within_the_step() {
        let h = 5e-4;
        let p0 = crate::params::REFERENCE;
        let tau_e = p0.motor.inductance_h / p0.motor.resistance_ohm;
        for tau in LAGS {
            let mut p = p0;
            p.effects.tach_lag = tau;
            let t = Tach {
                k: 0.0,
                r: 1.0,
                ..Tach::new(&p, h).unwrap()
            };
            let c = [0.3, 400.0, -0.25];
            let u = |s: f64| c[0] + c[1] * s + c[2] * (-s / tau_e).exp();
            let mean = c[0] + c[1] * h / 2.0 + c[2] * tau_e * (1.0 - (-h / tau_e).exp()) / h;
            let y0 = 0.1;
            let got = t.advance(
                y0 as f32,
                (0.0, u(0.0) as f32),
                (0.0, u(h) as f32),
                0.0,
                mean as f32,
            );
            let want = exact_exp(tau, tau_e, h, y0, c);
            assert!(
                (f64::from(got) - want).abs() <= 2e-6 * (1.0 + want.abs()),
                "τ {tau}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn kernel_moments_are_continuous_where_the_method_changes() {
        let below = kernel_moments(1.0 - 1e-12);
        let above = kernel_moments(1.0);
        for (a, b) in below.iter().zip(above.iter()) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
    }
}
