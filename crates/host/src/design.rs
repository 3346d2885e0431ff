//! The design queries `max-backlash` and `min-voltage`: bisections on the simulated f_AR
//! ([`f_ar`]), which has no answer where the response has no resolvable anti-resonance
//! ([`crate::no_answer`]). An evaluation without one fails the bandwidth, except above the
//! Nyquist frequency, where the simulation cannot say and the query has no answer either.

use crate::error::HostError;
use crate::fr::{locate, Bench, Drives, LocateOptions, SweepOptions};
use crate::no_answer::{self, Answer, Cause, Expectation, Feature, NoAnswer};
use geared_servo::ActuatorParams;
use std::sync::Arc;

/// Top of the grid on which [`f_ar`] (and Fig. 6 of `paper`) look for the anti-resonance,
/// Hz: a little above the backlash-free f_AR (an upper bound; hinge spring included), at
/// least 20 Hz, below the Nyquist frequency.
pub fn f_ar_top_hz(params: &ActuatorParams) -> Result<f64, HostError> {
    let d = params.derived().map_err(HostError::from)?;
    let kh = params.effects.hinge_stiffness;
    let f0 = if kh > 0.0 {
        ((d.k_eq_nm_per_rad + kh) / params.load.inertia_kg_m2).sqrt() / (2.0 * std::f64::consts::PI)
    } else {
        d.f_ar_hz
    };
    Ok((f0 * 1.15).max(20.0).min(0.45 / params.sample_period_s))
}

/// Simulated f_AR of `params` at `vpk`, Hz (coarse grid from 10 Hz to [`f_ar_top_hz`], then
/// refinement): what the design queries bisect on. The model's reasons to rule it out are
/// checked first, and nothing is simulated when one applies.
pub fn f_ar(
    params: &ActuatorParams,
    opts: SweepOptions,
    tol_hz: f64,
) -> Result<Answer<f64>, HostError> {
    f_ar_with(params, opts, tol_hz, &Drives::shared())
}

/// [`f_ar`] with the sine drives of `drives`: a bisection's evaluations revisit the same
/// grid frequencies.
fn f_ar_with(
    params: &ActuatorParams,
    opts: SweepOptions,
    tol_hz: f64,
    drives: &Arc<Drives>,
) -> Result<Answer<f64>, HostError> {
    let lo = LocateOptions {
        from_hz: 10.0,
        to_hz: f_ar_top_hz(params)?,
        step_hz: 4.0,
        tol_hz,
        resonance: false,
    };
    let bench = Bench::with_drives(params, opts, Arc::clone(drives))?;
    let expect = Expectation::new(params, opts.vpk)?;
    if let Some(na) = expect.rules_out(Feature::AntiResonance, (lo.from_hz, lo.to_hz)) {
        return Ok(Err(na));
    }
    Ok(locate(&bench, &lo, &())?
        .0
        .anti_resonance
        .map(|l| l.freq_hz))
}

/// Result of a bisection: the answer and the points evaluated on the way.
#[derive(Clone, Debug, PartialEq)]
pub struct Design {
    /// The answer (deg for max-backlash, V for min-voltage), or why there is none.
    pub value: Answer<f64>,
    /// (argument, simulated f_AR in Hz or why there is none) of every evaluation, in order.
    pub trace: Vec<(f64, Answer<f64>)>,
}

/// The evaluations of one design query: each f_AR, and whether it meets the bandwidth.
struct Query<'a> {
    bandwidth_hz: f64,
    f_ar: &'a dyn Fn(f64) -> Result<Answer<f64>, HostError>,
    trace: Vec<(f64, Answer<f64>)>,
}

impl Query<'_> {
    /// Whether f_AR at `x` meets the bandwidth ([`no_answer::meets`]); `Err` when the
    /// simulation cannot say, with the argument named (`unit` after it).
    fn meets(&mut self, x: f64, unit: &str) -> Result<Result<bool, NoAnswer>, HostError> {
        let f = (self.f_ar)(x)?;
        let m = no_answer::meets(&f, self.bandwidth_hz).map_err(|na| NoAnswer {
            cause: na.cause,
            reason: format!("at {x} {unit}, {}", na.reason),
        });
        self.trace.push((x, f));
        Ok(m)
    }

    /// Why the last evaluation missed the bandwidth, as a clause.
    fn missed(&self) -> String {
        match self.trace.last() {
            Some((_, Ok(f))) => format!(
                "the simulated f_AR ({f:.3} Hz) is below {} Hz",
                self.bandwidth_hz
            ),
            Some((_, Err(na))) => format!("there is {}", na.reason),
            None => String::new(),
        }
    }

    fn done(self, value: Answer<f64>) -> Design {
        Design {
            value,
            trace: self.trace,
        }
    }
}

fn no(cause: Cause, reason: String) -> Answer<f64> {
    Err(NoAnswer { cause, reason })
}

/// Largest total backlash (deg) whose simulated f_AR at `vpk` is still ≥ `bandwidth_hz`, to
/// `tol_deg`. Brackets by doubling from 0.01°, then bisects. No answer when even no backlash
/// misses the bandwidth, when the model's largest backlash still meets it, or when an
/// evaluation cannot say ([`no_answer::meets`]).
pub fn max_backlash(
    params: &ActuatorParams,
    bandwidth_hz: f64,
    opts: SweepOptions,
    tol_deg: f64,
) -> Result<Design, HostError> {
    check_bandwidth(bandwidth_hz)?;
    let drives = Drives::shared();
    let eval = |b: f64| f_ar_with(&params.with_backlash_deg(b), opts, 0.002, &drives);
    let mut q = Query {
        bandwidth_hz,
        f_ar: &eval,
        trace: Vec::new(),
    };
    macro_rules! meets {
        ($x:expr) => {
            match q.meets($x, "deg of backlash")? {
                Ok(m) => m,
                Err(na) => return Ok(q.done(Err(na))),
            }
        };
    }
    if !meets!(0.0) {
        let why = format!("even without backlash {}", q.missed());
        return Ok(q.done(no(Cause::NeverReached, why)));
    }
    let max = geared_servo::params::MAX_BACKLASH_DEG;
    let (mut lo, mut hi) = (0.0, 0.01);
    while meets!(hi) {
        lo = hi;
        if hi >= max {
            let why = format!(
                "f_AR is still at or above {bandwidth_hz} Hz with {max} deg of backlash, the most the model accepts"
            );
            return Ok(q.done(no(Cause::AlwaysReached, why)));
        }
        hi = (hi * 2.0).min(max);
    }
    while hi - lo > tol_deg {
        let mid = 0.5 * (lo + hi);
        if meets!(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(q.done(Ok(lo)))
}

/// Smallest voltage amplitude (V) whose simulated f_AR at the parameters' backlash is
/// ≥ `bandwidth_hz`, to `tol_v`. Brackets by doubling from 1 V (up to 10 kV), then bisects.
/// No answer when 10 kV still misses the bandwidth, when every voltage tried meets it, or
/// when an evaluation cannot say ([`no_answer::meets`]).
pub fn min_voltage(
    params: &ActuatorParams,
    bandwidth_hz: f64,
    opts: SweepOptions,
    tol_v: f64,
) -> Result<Design, HostError> {
    check_bandwidth(bandwidth_hz)?;
    let drives = Drives::shared();
    let eval = |v: f64| f_ar_with(params, SweepOptions { vpk: v, ..opts }, 0.002, &drives);
    let mut q = Query {
        bandwidth_hz,
        f_ar: &eval,
        trace: Vec::new(),
    };
    macro_rules! meets {
        ($x:expr) => {
            match q.meets($x, "V_pk")? {
                Ok(m) => m,
                Err(na) => return Ok(q.done(Err(na))),
            }
        };
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    while !meets!(hi) {
        lo = hi;
        hi *= 2.0;
        if hi > 1.0e4 {
            let why = format!(
                "at {lo} V_pk, the last amplitude tried below 10 kV_pk, {}",
                q.missed()
            );
            return Ok(q.done(no(Cause::NeverReached, why)));
        }
    }
    while hi - lo > tol_v {
        let mid = 0.5 * (lo + hi);
        if meets!(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    if lo == 0.0 {
        let why = format!(
            "f_AR reaches {bandwidth_hz} Hz at every voltage tried, down to {hi} V_pk: the bandwidth does not need a voltage here"
        );
        return Ok(q.done(no(Cause::AlwaysReached, why)));
    }
    Ok(q.done(Ok(hi)))
}

fn check_bandwidth(f: f64) -> Result<(), HostError> {
    if f.is_finite() && f > 0.0 {
        Ok(())
    } else {
        Err(HostError::input(format!(
            "the bandwidth must be a positive frequency, got {f} Hz"
        )))
    }
}
