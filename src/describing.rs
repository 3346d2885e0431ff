//! Describing function of the backlash dead zone (paper eqs. 18–19) and its prediction of the
//! anti-resonance and resonance at a given voltage amplitude.
//!
//! # The model behind the prediction
//! The dead zone on the total twist x (half gap δ) is replaced by its first-harmonic gain:
//! a sinusoidal twist of amplitude A transmits a torque whose fundamental is `N(A) k_eq A`,
//! so the gears act as a spring `k_eff = N(A) k_eq` (eq. 19, applied to the total stiffness
//! because [`crate::plant`] reduces k1, k2 and the gap exactly to one dead-zone spring at the
//! load). The amplitude depends on the stiffness, so it is solved consistently:
//!
//! 1. for a trial `k`, the linear plant with stiffness `k` ([`LinearModel`], voltage drive,
//!    electrical dynamics and back-EMF included) is evaluated at its own anti-resonance
//!    (eq. 17a with `k`) or resonance (17b with `k`), giving the twist amplitude `A(k)` for
//!    the voltage amplitude V;
//! 2. the consistent stiffness is the root of `N(A(k)) k_eq − k = 0` on `(0, k_eq]`, found by
//!    bisection (A falls as k rises, so the root is unique).
//!
//! At the anti-resonance the motor barely moves, so `A ≈ N k_t V / (|R + jωL| k)`: the twist
//! grows linearly with V and the stiffness deficit `1 − N(A) ≈ 4δ/(πA)` closes as 1/V. At the
//! resonance the back-EMF cancels the voltage (no current), the motor runs at V/k_b and
//! `A ≈ N J_m ω V/(k_b k)`.
//!
//! Ignored, as in the paper: Coulomb friction, higher harmonics, impacts (the dead zone's
//! output is not sinusoidal when A is close to δ), and any chaotic motion. The prediction is
//! trustworthy when A ≫ δ and the motion stays in contact most of the period.

use crate::linear::LinearModel;
use crate::params::ActuatorParams;
use crate::ParamError;

/// Normalised describing-function gain of a dead zone of half width `delta` (eq. 18) for a
/// sinusoid of amplitude `a` (same unit as `delta`): 1 without a gap, 0 inside it.
pub fn gain(delta: f64, a: f64) -> f64 {
    if delta <= 0.0 {
        return 1.0;
    }
    if a <= delta {
        return 0.0;
    }
    let r = delta / a;
    1.0 - (2.0 / core::f64::consts::PI) * (libm::asin(r) + r * libm::sqrt(1.0 - r * r))
}

/// Which frequency of the linearised plant the prediction is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    /// Anti-resonance (eq. 17a): the notch of `V_t/V_m`.
    AntiResonance,
    /// Resonance of `Ωm/T_m` (eq. 17b).
    Resonance,
}

/// Describing-function prediction of one frequency at one voltage amplitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    /// Predicted frequency, Hz.
    pub freq_hz: f64,
    /// Twist amplitude at that frequency, rad.
    pub twist_amplitude_rad: f64,
    /// Describing-function gain N(A), –.
    pub df_gain: f64,
    /// Effective stiffness N(A)·k_eq, N·m/rad.
    pub k_eff_nm_per_rad: f64,
}

/// Both predictions at one voltage amplitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DfPrediction {
    /// Anti-resonance.
    pub anti_resonance: Prediction,
    /// Resonance.
    pub resonance: Prediction,
}

/// Predicts f_AR and f_R of `params` (its backlash) for a sine of amplitude `vpk` (V) on the
/// winding, solving the twist amplitude and the effective stiffness consistently (see the
/// module documentation).
pub fn predict(params: &ActuatorParams, vpk: f64) -> Result<DfPrediction, ParamError> {
    let model = LinearModel::new(params)?;
    let delta = params.derived()?.delta_rad;
    Ok(DfPrediction {
        anti_resonance: predict_feature(&model, delta, vpk, Feature::AntiResonance),
        resonance: predict_feature(&model, delta, vpk, Feature::Resonance),
    })
}

/// One prediction for the linear model `model` (its stiffness is k_eq), half gap `delta`
/// (rad) and voltage amplitude `vpk` (V).
pub fn predict_feature(model: &LinearModel, delta: f64, vpk: f64, which: Feature) -> Prediction {
    let k_eq = model.k_nm_per_rad;
    let eval = |k: f64| -> (f64, f64) {
        let m = model.with_k(k);
        let f = match which {
            Feature::AntiResonance => m.f_ar_hz(),
            Feature::Resonance => m.f_r_hz(),
        };
        // With k = k_eff the linearised twist amplitude is the dead zone's input amplitude A.
        (f, m.response(f).twist.abs() * vpk.abs())
    };
    let (mut lo, mut hi) = (0.0, k_eq);
    if delta > 0.0 {
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            let (_, a) = eval(mid);
            if gain(delta, a) * k_eq > mid {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    } else {
        lo = k_eq;
    }
    let k = if delta > 0.0 { 0.5 * (lo + hi) } else { lo };
    let (f, a) = eval(k);
    Prediction {
        freq_hz: f,
        twist_amplitude_rad: a,
        df_gain: gain(delta, a),
        k_eff_nm_per_rad: k,
    }
}

/// The linear model a stepped-sine measurement at `vpk` (V) starts from (see
/// [`LinearModel::steady_state`]): the plant with the describing-function stiffness at the
/// anti-resonance. Exact without backlash; an initial guess that shortens the transient
/// otherwise.
pub fn warm_start_model(params: &ActuatorParams, vpk: f64) -> Result<LinearModel, ParamError> {
    let df = predict(params, vpk)?;
    Ok(LinearModel::new(params)?.with_k(df.anti_resonance.k_eff_nm_per_rad.max(1e-9)))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::params::REFERENCE;

    #[test]
    fn gain_limits_and_monotonic() {
        assert_eq!(gain(1.0, 0.5), 0.0);
        assert_eq!(gain(0.0, 0.5), 1.0);
        let mut prev = 0.0;
        for i in 1..200 {
            let g = gain(1.0, 1.0 + i as f64 * 0.1);
            assert!(g > prev && g < 1.0);
            prev = g;
        }
        // Large A: 1 − N(A) → 4δ/(πA).
        let a = 1e4;
        assert!(((1.0 - gain(1.0, a)) * a - 4.0 / core::f64::consts::PI).abs() < 1e-6);
    }

    #[test]
    fn prediction_without_backlash_is_the_closed_form() {
        let p = REFERENCE;
        let d = p.derived().unwrap();
        let pr = predict(&p, 10.0).unwrap();
        assert!((pr.anti_resonance.freq_hz - d.f_ar_hz).abs() < 1e-9);
        assert!((pr.resonance.freq_hz - d.f_r_hz).abs() < 1e-9);
    }

    #[test]
    fn prediction_rises_with_voltage_towards_the_closed_form() {
        let p = REFERENCE.with_backlash_deg(0.08);
        let d = p.derived().unwrap();
        let mut prev = 0.0;
        for v in [5.0, 10.0, 17.9, 30.0, 100.0, 1000.0] {
            let f = predict(&p, v).unwrap().anti_resonance.freq_hz;
            assert!(f > prev && f < d.f_ar_hz);
            prev = f;
        }
        assert!(d.f_ar_hz - prev < 0.02 * d.f_ar_hz);
    }
}
