//! When a feature of the simulated frequency response has no answer, and why.
//!
//! The lowest point of a sampled |V_t/V_m| always exists; it is the anti-resonance only when
//! the physics puts a notch where the simulation can show it and the simulated points show
//! one. A located extremum is an answer when all of these hold, checked in this order (the
//! first that fails is the reason given):
//!
//! 1. **Below the Nyquist frequency** (from the model, before simulating): the
//!    describing-function frequency at the voltage amplitude ([`Expectation`]) lies below
//!    1/(2h) for the step h. Backlash only lowers f_AR (k_eff ≤ k_eq), and f_R lies above
//!    f_AR, so above Nyquist nothing in the simulated range is the feature.
//! 2. **The load is driven** (anti-resonance only, from the model): at the anti-resonance
//!    the motor stands still, so the current is V/|R + jωL| and the gears pass
//!    N·k_t·V/|R + jωL| to the load. Below the load's Coulomb friction the load does not
//!    move and there is no anti-resonance. A slow winding (its electrical pole R/(2πL) far
//!    below the notch) is what usually brings this about.
//! 3. **The response settled** at least at half of the simulated frequencies: a minimum
//!    among block averages of a response that has no steady state is not a notch.
//! 4. **Inside the range**: the coarse grid's extremum is not at an end of the searched
//!    grid (the feature, if any, lies beyond it).
//! 5. **Bounded**: on both sides, within the range, the response leaves the band of two
//!    standard errors around the extremum (otherwise the response is flat within its
//!    spread and no frequency stands out).
//! 6. **Deep enough** (the minima): within an octave on each side the response rises at
//!    least [`MIN_DEPTH_DB`] above the bottom. For the anti-resonance, a zero of `V_t/V_m`,
//!    the bottom is the minimum plus two standard errors, or what the analyser resolves (its
//!    absolute agreement, [`geared_servo::analyser::ABS_TOL`]) if that is higher: a response
//!    whose level near the notch sits at that floor (a winding so slow that the tachometer
//!    sees almost nothing) has no resolvable notch even if the plant has one. The
//!    resonance's dip in |I/V_m| is shallow with backlash (0.2–0.5 dB at the softening jump
//!    of the reference actuator at 3–10 V), so its bottom is the analyser's floor alone.
//!
//! The gain peak (a maximum) is held to 1 and 3–5. Model frequencies include the hinge
//! spring ([`Expectation`]).
//!
//! The design queries build on f_AR ([`meets`]): an evaluation with no anti-resonance fails
//! the bandwidth (there is no notch at or above it), except above the Nyquist frequency,
//! where the simulation cannot say and the query has no answer. A query also has none when
//! the bandwidth is reached nowhere or everywhere it may look ([`Cause::NeverReached`],
//! [`Cause::AlwaysReached`]).

use crate::error::HostError;
use crate::response::{Located, Point};
use geared_servo::{describing, ActuatorParams};
use std::f64::consts::PI;
use std::fmt;

/// Smallest depth of a notch below the response on either side, dB: the half-power ratio
/// (√2), the same 3 dB that defines a bandwidth. A dip shallower than that is a wiggle of a
/// friction- or rattle-dominated response, not a zero of the transfer function.
pub const MIN_DEPTH_DB: f64 = 3.0;

/// Why a frequency (or a design answer) has no answer. [`Cause::code`] is the stable name
/// written to JSON as `*_cause`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cause {
    /// The model puts the feature at or above the Nyquist frequency of the step.
    AboveNyquist,
    /// The torque the winding drives into the gears at the anti-resonance is below the load's
    /// Coulomb friction: the load does not move.
    LoadNotDriven,
    /// The response did not settle at most simulated frequencies.
    NotSettled,
    /// The extremum is at an end of the searched grid.
    AtRangeEdge,
    /// The response stays within its spread of the extremum up to an end of the range.
    Flat,
    /// Within an octave the response rises less than [`MIN_DEPTH_DB`] above the minimum
    /// (anti-resonance) or above the analyser's resolution (both minima).
    Shallow,
    /// Design query: the bandwidth is not reached anywhere the query may look.
    NeverReached,
    /// Design query: the bandwidth is reached everywhere the query may look.
    AlwaysReached,
}

impl Cause {
    /// Every cause, in the order of the module documentation.
    pub const ALL: [Cause; 8] = [
        Cause::AboveNyquist,
        Cause::LoadNotDriven,
        Cause::NotSettled,
        Cause::AtRangeEdge,
        Cause::Flat,
        Cause::Shallow,
        Cause::NeverReached,
        Cause::AlwaysReached,
    ];

    /// The stable name (JSON `*_cause`).
    pub fn code(self) -> &'static str {
        match self {
            Cause::AboveNyquist => "above_nyquist",
            Cause::LoadNotDriven => "load_not_driven",
            Cause::NotSettled => "not_settled",
            Cause::AtRangeEdge => "at_range_edge",
            Cause::Flat => "flat",
            Cause::Shallow => "shallow",
            Cause::NeverReached => "never_reached",
            Cause::AlwaysReached => "always_reached",
        }
    }

    /// One line on what the cause means.
    pub fn meaning(self) -> &'static str {
        match self {
            Cause::AboveNyquist => "the model puts the feature at or above the Nyquist frequency 1/(2h) of the step",
            Cause::LoadNotDriven => "at the anti-resonance the winding drives less torque into the gears than the load's Coulomb friction",
            Cause::NotSettled => "the response settled at fewer than half of the simulated frequencies",
            Cause::AtRangeEdge => "the extremum of the simulated grid is at an end of the searched range",
            Cause::Flat => "the response stays within two standard errors of the extremum up to an end of the range",
            Cause::Shallow => "within an octave the response rises less than 3 dB above the minimum (anti-resonance) or above the analyser's resolution",
            Cause::NeverReached => "design query: the bandwidth is not reached anywhere the query looks",
            Cause::AlwaysReached => "design query: the bandwidth is reached everywhere the query looks",
        }
    }
}

/// No answer, with the reason as one sentence for the user.
#[derive(Clone, Debug, PartialEq)]
pub struct NoAnswer {
    /// The cause.
    pub cause: Cause,
    /// The reason, one line (JSON `*_reason`).
    pub reason: String,
}

impl fmt::Display for NoAnswer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.reason)
    }
}

/// A value, or why there is none.
pub type Answer<T> = Result<T, NoAnswer>;

/// Which feature of the response.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    /// Minimum of |V_t/V_m|.
    AntiResonance,
    /// Minimum of |I/V_m| above the anti-resonance.
    Resonance,
    /// Maximum of |V_t/V_m| above the anti-resonance.
    GainPeak,
}

impl Feature {
    fn name(self) -> &'static str {
        match self {
            Feature::AntiResonance => "anti-resonance",
            Feature::Resonance => "resonance",
            Feature::GainPeak => "gain peak",
        }
    }
    fn extremum(self) -> &'static str {
        match self {
            Feature::AntiResonance => "the lowest |V_t/V_m|",
            Feature::Resonance => "the lowest |I/V_m|",
            Feature::GainPeak => "the highest |V_t/V_m|",
        }
    }
}

/// A frequency as the messages show it: whole numbers without decimals.
pub fn hz(f: f64) -> String {
    if f.fract() == 0.0 && f.abs() < 1e15 {
        format!("{f:.0}")
    } else if f >= 1000.0 {
        format!("{f:.1}")
    } else {
        format!("{f:.3}")
    }
}

/// What the model says about a parameter set at one voltage amplitude before anything is
/// simulated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Expectation {
    /// Describing-function anti-resonance with the hinge spring, √((k_eff + k_h)/J_L)/2π, Hz.
    pub f_ar_hz: f64,
    /// Describing-function resonance with the hinge spring (upper root of the two-mass
    /// system grounded through k_h), Hz.
    pub f_r_hz: f64,
    /// Backlash-free anti-resonance with the hinge spring, Hz: an upper bound of f_AR.
    pub f_ar_no_backlash_hz: f64,
    /// Nyquist frequency 1/(2h) of the step, Hz.
    pub nyquist_hz: f64,
    /// Electrical pole R/(2πL), Hz.
    pub electrical_pole_hz: f64,
    /// Current amplitude at the anti-resonance (motor at rest), V/|R + jωL|, A.
    pub current_at_ar_a: f64,
    /// Torque amplitude the gears pass to the load there, N·k_t·I, N·m.
    pub load_drive_nm: f64,
    /// The load's Coulomb friction, N·m.
    pub load_friction_nm: f64,
}

impl Expectation {
    /// The expectation for `params` driven at `vpk` (V; the amplifier limit applies).
    pub fn new(params: &ActuatorParams, vpk: f64) -> Result<Expectation, HostError> {
        let d = params.derived()?;
        let df = describing::predict(params, vpk)?;
        let m = &params.motor;
        let (jl, kh) = (params.load.inertia_kg_m2, params.effects.hinge_stiffness);
        let jm = d.n_total * d.n_total * m.inertia_kg_m2;
        let f_ar = |k: f64| ((k + kh) / jl).sqrt() / (2.0 * PI);
        // Poles of Ωm/T_m with the load grounded through k_h: Jm' J_L ω⁴ − (k (Jm' + J_L) +
        // k_h Jm') ω² + k k_h = 0; the upper root is eq. 17b when k_h = 0.
        let k = df.resonance.k_eff_nm_per_rad;
        let (a, b, c) = (jm * jl, k * (jm + jl) + kh * jm, k * kh);
        let w2 = (b + (b * b - 4.0 * a * c).max(0.0).sqrt()) / (2.0 * a);
        let f_ar_hz = f_ar(df.anti_resonance.k_eff_nm_per_rad);
        let v = if params.effects.voltage_limit > 0.0 {
            vpk.min(params.effects.voltage_limit)
        } else {
            vpk
        };
        let z = m.resistance_ohm.hypot(2.0 * PI * f_ar_hz * m.inductance_h);
        let current = v / z;
        Ok(Expectation {
            f_ar_hz,
            f_r_hz: w2.sqrt() / (2.0 * PI),
            f_ar_no_backlash_hz: f_ar(d.k_eq_nm_per_rad),
            nyquist_hz: 0.5 / params.sample_period_s,
            electrical_pole_hz: m.resistance_ohm / (2.0 * PI * m.inductance_h),
            current_at_ar_a: current,
            load_drive_nm: d.n_total * m.torque_constant_nm_per_a * current,
            load_friction_nm: params.load.coulomb_friction_nm,
        })
    }

    fn predicted(&self, feature: Feature) -> f64 {
        match feature {
            Feature::AntiResonance => self.f_ar_hz,
            Feature::Resonance | Feature::GainPeak => self.f_r_hz,
        }
    }

    /// Why the model rules `feature` out in `range` (Hz) whatever the simulation shows
    /// (criteria 1 and 2 of the module documentation), if it does.
    pub fn rules_out(&self, feature: Feature, range: (f64, f64)) -> Option<NoAnswer> {
        let f = self.predicted(feature);
        if f >= self.nyquist_hz {
            return Some(no_answer(
                feature,
                range,
                Cause::AboveNyquist,
                format!(
                    "the model puts it at {} Hz, at or above the {} Hz Nyquist frequency of the step",
                    hz(f),
                    hz(self.nyquist_hz)
                ),
            ));
        }
        if feature == Feature::AntiResonance && self.load_drive_nm < self.load_friction_nm {
            return Some(no_answer(
                feature,
                range,
                Cause::LoadNotDriven,
                format!(
                    "at the predicted {} Hz the motor stands still, so the winding (electrical pole at {} Hz) carries {:.3e} A and the gears pass {:.3e} N*m to the load, less than its Coulomb friction ({} N*m): the load does not move",
                    hz(f),
                    hz(self.electrical_pole_hz),
                    self.current_at_ar_a,
                    self.load_drive_nm,
                    self.load_friction_nm
                ),
            ));
        }
        None
    }

    /// Whether `f` lies outside `range`, as a clause for a reason.
    fn outside(&self, feature: Feature, range: (f64, f64)) -> String {
        let f = self.predicted(feature);
        if f < range.0 || f > range.1 {
            format!(
                "; the describing function puts it at {} Hz, outside the range",
                hz(f)
            )
        } else {
            String::new()
        }
    }
}

fn no_answer(feature: Feature, range: (f64, f64), cause: Cause, detail: String) -> NoAnswer {
    NoAnswer {
        cause,
        reason: format!(
            "no resolvable {} in {}–{} Hz: {detail}",
            feature.name(),
            hz(range.0),
            hz(range.1)
        ),
    }
}

/// A located extremum and the simulated points it was found on, for [`judge`].
pub struct Extremum<'a> {
    /// Which feature.
    pub feature: Feature,
    /// The range searched, Hz (for the message).
    pub range: (f64, f64),
    /// The coarse grid (all of it: the settled count is over the whole response).
    pub coarse: &'a [Point],
    /// First grid index the search may use.
    pub start: usize,
    /// Grid index of the coarse extremum.
    pub index: usize,
    /// The refined extremum.
    pub located: Located,
    /// Whether the band reached the first or last point searched.
    pub band_open: bool,
    /// Standard error of the value at the extremum.
    pub std_error: f64,
    /// The value searched (|V_t/V_m| or |I/V_m|; the gain peak's is the gain itself).
    pub value: &'a dyn Fn(&Point) -> f64,
    /// What the analyser resolves in this channel (its absolute agreement), for the depth
    /// of a minimum (unused for the gain peak, a maximum).
    pub floor: f64,
}

/// Judges a located extremum against criteria 3–6 of the module documentation; `expect`
/// adds where the model puts the feature when that explains the failure.
pub fn judge(x: &Extremum<'_>, expect: &Expectation) -> Option<NoAnswer> {
    let fail = |cause: Cause, detail: String| {
        let extra = match cause {
            Cause::AtRangeEdge | Cause::Flat | Cause::Shallow => expect.outside(x.feature, x.range),
            _ => String::new(),
        };
        Some(no_answer(x.feature, x.range, cause, detail + &extra))
    };
    let n = x.coarse.len();
    let settled = x.coarse.iter().filter(|p| p.settled).count();
    if 2 * settled < n {
        return fail(
            Cause::NotSettled,
            format!("the response settled at only {settled} of {n} frequencies"),
        );
    }
    let f = x.located.freq_hz;
    if x.index <= x.start || x.index + 1 >= n {
        return fail(
            Cause::AtRangeEdge,
            format!(
                "{} of the simulated grid is at its edge ({} Hz)",
                x.feature.extremum(),
                hz(f)
            ),
        );
    }
    if x.band_open {
        return fail(
            Cause::Flat,
            format!(
                "the response stays within two standard errors of {} from {} to {} Hz, an end of the range",
                x.feature.extremum(),
                hz(x.located.band_hz.0),
                hz(x.located.band_hz.1)
            ),
        );
    }
    if x.feature == Feature::GainPeak {
        return None;
    }
    // The response within an octave of the minimum: a zero shapes its neighbourhood, while
    // the level an octave or more away belongs to other parts of the response (the
    // rigid-body roll-off, the resonance).
    let side_max = |pts: &[Point]| {
        pts.iter()
            .filter(|p| p.freq_hz >= 0.5 * f && p.freq_hz <= 2.0 * f)
            .map(x.value)
            .fold(0.0f64, f64::max)
    };
    let left = side_max(x.coarse.get(x.start..x.index).unwrap_or(&[]));
    let right = side_max(x.coarse.get(x.index + 1..).unwrap_or(&[]));
    let (bottom, from) = if x.feature == Feature::AntiResonance {
        let b = x.located.value + 2.0 * x.std_error;
        if b > x.floor {
            (b, "the minimum plus two standard errors")
        } else {
            (x.floor, "the analyser's resolution")
        }
    } else {
        (x.floor, "the analyser's resolution")
    };
    let depth = 20.0 * (left.min(right) / bottom).log10();
    if depth.is_nan() || depth < MIN_DEPTH_DB {
        return fail(
            Cause::Shallow,
            format!(
                "within an octave of the minimum at {} Hz the response rises only to {:+.1} dB relative to {from} ({:.3e}); a notch needs {MIN_DEPTH_DB} dB",
                hz(f),
                depth.max(-999.0),
                bottom
            ),
        );
    }
    None
}

/// What an f_AR evaluation means for a design query: `Ok(true)` meets `bandwidth_hz`,
/// `Ok(false)` does not (a lower f_AR, or no anti-resonance at all), `Err` when the
/// simulation cannot say (the anti-resonance lies above the Nyquist frequency).
pub fn meets(f_ar: &Answer<f64>, bandwidth_hz: f64) -> Result<bool, NoAnswer> {
    match f_ar {
        Ok(f) => Ok(*f >= bandwidth_hz),
        Err(na) if na.cause == Cause::AboveNyquist => Err(na.clone()),
        Err(_) => Ok(false),
    }
}

/// Writes `{stem}_reason` and `{stem}_cause` into the JSON object `obj` when `a` has no
/// answer (the value's own key, null then, is the caller's). Nothing is added for an answer,
/// so the JSON of answered queries is unchanged.
pub fn add_reason<T>(obj: &mut serde_json::Value, stem: &str, a: &Answer<T>) {
    if let (serde_json::Value::Object(m), Err(na)) = (obj, a) {
        m.insert(format!("{stem}_reason"), na.reason.clone().into());
        m.insert(format!("{stem}_cause"), na.cause.code().into());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geared_servo::REFERENCE;

    #[test]
    fn expectation_without_hinge_or_backlash_is_the_closed_form() {
        let d = REFERENCE.derived().unwrap();
        let e = Expectation::new(&REFERENCE, 10.0).unwrap();
        assert!((e.f_ar_hz - d.f_ar_hz).abs() < 1e-9);
        assert!((e.f_r_hz - d.f_r_hz).abs() < 1e-9);
        assert_eq!(e.nyquist_hz, 1000.0);
    }

    #[test]
    fn a_hinge_spring_raises_the_expected_notch_to_its_zero() {
        // The zero of Ωm/V is where Z_L + K = 0: J_L ω² = k_eq + k_h (linear.rs).
        let mut p = REFERENCE;
        p.effects.hinge_stiffness = 3000.0;
        let d = p.derived().unwrap();
        let e = Expectation::new(&p, 10.0).unwrap();
        let want = ((d.k_eq_nm_per_rad + 3000.0) / p.load.inertia_kg_m2).sqrt() / (2.0 * PI);
        assert!((e.f_ar_hz - want).abs() < 1e-9);
        // The poles interlace the zero: the upper one stays above it.
        assert!(e.f_r_hz > e.f_ar_hz);
    }

    #[test]
    fn only_an_anti_resonance_above_nyquist_leaves_a_design_evaluation_undecided() {
        let na = |cause| {
            Err(NoAnswer {
                cause,
                reason: String::new(),
            })
        };
        assert_eq!(meets(&Ok(101.0), 100.0), Ok(true));
        assert_eq!(meets(&Ok(99.0), 100.0), Ok(false));
        for c in Cause::ALL {
            let m = meets(&na(c), 100.0);
            assert_eq!(m.is_err(), c == Cause::AboveNyquist, "{c:?}");
            if c != Cause::AboveNyquist {
                assert_eq!(m, Ok(false));
            }
        }
    }
}
