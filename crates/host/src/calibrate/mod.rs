//! Calibration: nonlinear least squares of a chosen set of parameters against one or more
//! records, on the simulation error (the `f32` plant run over the whole record from rest).
//!
//! Parameters are adjusted in an internal coordinate: the logarithm for positive quantities
//! (so a step is a relative change and the value cannot turn negative), the value itself for
//! signed or bounded ones, always projected into bounds. Following MODEL.md ("Calibrating
//! against measured data"), a coarse one-dimensional search per parameter runs before
//! Levenberg–Marquardt (the `levenberg-marquardt` crate, a port of MINPACK's `lmder`), the
//! finite-difference steps (2 % relative, central) are far above the kinks that Coulomb
//! friction and backlash put into the cost, and the report says whether the optimiser moved.

mod data;
mod lm;
mod search;

pub use crate::knobs::*;
pub use data::*;
pub use lm::*;
pub use search::*;

/// The records of the tests of [`data`], for other modules' tests.
#[cfg(test)]
pub(crate) use data::tests;

use geared_servo::ActuatorParams;

/// Result of a calibration.
#[derive(Clone, Debug)]
pub struct Fit {
    /// Calibrated parameters.
    pub params: ActuatorParams,
    /// The knobs that were adjusted.
    pub knobs: Vec<Knob>,
    /// Their calibrated values.
    pub values: Vec<f64>,
    /// Standard errors, in each parameter's unit (from the Gauss–Newton covariance, which
    /// assumes white residuals: optimistic when they are not).
    pub std_errors: Vec<f64>,
    /// Correlation matrix of the estimates (internal coordinates), row-major.
    pub correlations: Vec<Vec<f64>>,
    /// Mean over records of NRMSE², at the start and at the end.
    pub cost_start: f64,
    /// Final cost.
    pub cost: f64,
    /// Largest relative change of any knob (internal coordinate change for log knobs).
    pub moved: f64,
    /// Residual evaluations (simulations of every record) spent by the optimiser.
    pub evaluations: usize,
}

/// `fit` with its costs taken on `data` (plain least squares: what is reported and judged),
/// after a search on a robust loss.
fn plain(mut fit: Fit, p0: &ActuatorParams, data: &[Data]) -> Fit {
    fit.cost = cost(&fit.params, data);
    fit.cost_start = cost(p0, data);
    fit
}

/// Levenberg–Marquardt on the robust window loss ([`robust`]) from `p0`, with at most
/// `patience` (MINPACK's) evaluations per knob, reported with the plain costs on `data`.
pub fn polish(p0: &ActuatorParams, knobs: &[Knob], data: &[Data], patience: usize) -> Fit {
    let fit = levenberg_marquardt_with(p0, knobs, &robust(data), patience);
    plain(fit, p0, data)
}

/// [`polish`] without the standard errors: the point and its plain cost on `data`, for a
/// step whose result is searched or polished further.
pub fn polish_point(p0: &ActuatorParams, knobs: &[Knob], data: &[Data], patience: usize) -> Point {
    let (_, p, _, _) = lm_point(p0, knobs, &robust(data), patience);
    Point {
        params: p.params,
        cost: cost(&p.params, data),
    }
}

/// Levenberg–Marquardt on the plain least-squares loss of `data` from `p0` (no robust window
/// loss), with at most `patience` (MINPACK's) evaluations per knob, without the standard
/// errors: the point and its cost on `data`. For a profile, whose points are compared on
/// that loss ([`crate::diagnose::limits`]).
pub fn least_squares_point(
    p0: &ActuatorParams,
    knobs: &[Knob],
    data: &[Data],
    patience: usize,
) -> Point {
    lm_point(p0, knobs, data, patience).1
}

/// Calibrates `knobs` from `p0`: the cost is multimodal (MODEL.md: backlash lowers the notch
/// by an amount that depends on the amplitude, inertia does not, and a fit from the file can
/// stop in the basin that trades one for the other) and, on records of a rig, a patchwork of
/// basins (near a lightly damped resonance a gear train with backlash has coexisting
/// responses, and where it rattles it is chaotic: [`Robust`]). So the search is global and
/// derivative-free on the robust window loss: CMA-ES ([`evolve`]) from the file and from what
/// the record's own frequency response says (eqs. 17a/b), on every record's bursts or, for a
/// long stepped sine, on a share of them spread over its range ([`thinned`]), then
/// Levenberg–Marquardt on the same loss over every row from the best point. The fit is
/// reported with the plain least-squares costs.
pub fn calibrate(p0: &ActuatorParams, knobs: &[Knob], data: &[Data]) -> Fit {
    calibrate_seeded(p0, knobs, data, 0)
}

/// [`calibrate`] with the global search's random stream `seed`: independent searches, of
/// which a caller can keep the best.
pub fn calibrate_seeded(p0: &ActuatorParams, knobs: &[Knob], data: &[Data], seed: u64) -> Fit {
    if knobs.is_empty() {
        return levenberg_marquardt(p0, knobs, data);
    }
    let rdata = robust(data);
    let best = global_start(p0, knobs, data, &rdata, seed);
    let fit = levenberg_marquardt(&best, knobs, &rdata);
    let mut fit = plain(fit, p0, data);
    fit.moved = moved_from(p0, knobs, &fit.values);
    fit
}

/// [`calibrate_seeded`] without the standard errors, for a caller that polishes the point
/// further: its Levenberg–Marquardt also runs on the records as a global search sees them
/// ([`thinned`]). Returns the point with its plain cost on `data`, and how far it moved from
/// `p0` ([`Fit::moved`]).
pub fn calibrate_point(
    p0: &ActuatorParams,
    knobs: &[Knob],
    data: &[Data],
    seed: u64,
) -> (Point, f64) {
    if knobs.is_empty() {
        let f = levenberg_marquardt(p0, knobs, data);
        return (Point::from(&f), f.moved);
    }
    let rdata = robust(data);
    let best = global_start(p0, knobs, data, &rdata, seed);
    let (z, p, _, _) = lm_point(&best, knobs, &thinned(&rdata), 20);
    let values: Vec<f64> = knobs.iter().zip(&z).map(|(k, &zi)| k.from_z(zi)).collect();
    let point = Point {
        params: p.params,
        cost: cost(&p.params, data),
    };
    (point, moved_from(p0, knobs, &values))
}

/// The best point of the global search of [`calibrate_seeded`] (CMA-ES from `p0` and from
/// the first record's frequency response, on the robust records `rdata` thinned).
fn global_start(
    p0: &ActuatorParams,
    knobs: &[Knob],
    data: &[Data],
    rdata: &[Data],
    seed: u64,
) -> ActuatorParams {
    let has = |param: Param| knobs.iter().any(|k| k.param == param);
    let mut starts = vec![*p0];
    if has(Param::StiffnessKeq) && has(Param::MotorInertia) {
        if let Some(q) = data.first().and_then(|d| frf_start(p0, d)) {
            let inside = knobs.iter().all(|k| {
                let v = get(&q, k.param);
                v >= k.lo && v <= k.hi
            });
            if inside {
                starts.push(q);
            }
        }
    }
    let budget = EVALS_PER_KNOB * knobs.len() / starts.len();
    let search = thinned(rdata);
    starts
        .iter()
        .map(|q| evolve_with(q, knobs, &search, POPULATION, budget, 0.5, seed))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, q)| q)
        .unwrap_or(*p0)
}

/// Largest change of any knob from `p0` to `values`, in internal coordinates.
fn moved_from(p0: &ActuatorParams, knobs: &[Knob], values: &[f64]) -> f64 {
    let z: Vec<f64> = knobs.iter().zip(values).map(|(k, &v)| k.to_z(v)).collect();
    let z0: Vec<f64> = knobs.iter().map(|k| k.to_z(get(p0, k.param))).collect();
    largest_change(&z, &z0)
}

/// Largest |a − b| over the internal coordinates `a` and `b`.
fn largest_change(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// A local search around `p0` on the robust window loss: CMA-ES with a step of a tenth of
/// the exploration box ([`LOCAL`]), for when the rows being fitted have changed (new
/// predictability weights) and a derivative's view of the patchwork would stall; on the
/// records as a global search sees them ([`thinned`]). Returns the better of `p0` and what
/// it found (on those rows).
pub fn refine(p0: &ActuatorParams, knobs: &[Knob], data: &[Data]) -> ActuatorParams {
    if knobs.is_empty() {
        return *p0;
    }
    let (pop, per) = LOCAL;
    evolve_with(
        p0,
        knobs,
        &thinned(&robust(data)),
        pop,
        per * knobs.len(),
        0.1,
        0,
    )
    .1
}

/// Knobs that ended within 1 % (internal coordinate) of a bound: the fit wanted to go
/// further, a sign that the model lacks something or the bound is wrong (a knob whose lower
/// bound is a legitimate value, [`Knob::floor_ok`], only at its upper bound).
pub fn at_bounds(fit: &Fit) -> Vec<String> {
    fit.knobs
        .iter()
        .zip(&fit.values)
        .filter(|(k, &v)| {
            let (zl, zh, z) = (k.to_z(k.lo), k.to_z(k.hi), k.to_z(v));
            let w = (zh - zl).abs().max(1e-300);
            ((z - zl).abs() < 0.01 * w && !k.floor_ok) || (zh - z).abs() < 0.01 * w
        })
        .map(|(k, _)| k.name().to_string())
        .collect()
}

/// The knobs `after` has at a bound ([`at_bounds`]) that `before` does not: a refit that
/// runs a knob into its bound is bending to what the model lacks.
pub fn new_bounds(before: &Fit, after: &Fit) -> Vec<String> {
    let had = at_bounds(before);
    at_bounds(after)
        .into_iter()
        .filter(|n| !had.contains(n))
        .collect()
}

/// Whether `fit` took a background quantity (the mesh damping, [`Knob::floor_ok`]) to the
/// top of its range ([`at_bounds`]): the record wants more of it than every gear train has.
pub fn background_at_top(fit: &Fit) -> bool {
    let top = at_bounds(fit);
    fit.knobs
        .iter()
        .any(|k| k.floor_ok && top.iter().any(|t| t == k.name()))
}

/// Pairs of knobs whose estimates correlate beyond `limit` in magnitude: what the data
/// cannot separate.
pub fn inseparable(fit: &Fit, limit: f64) -> Vec<(String, String, f64)> {
    let mut out = Vec::new();
    for (a, row) in fit.correlations.iter().enumerate() {
        for (b, &r) in row.iter().enumerate().skip(a + 1) {
            if r.abs() > limit {
                if let (Some(ka), Some(kb)) = (fit.knobs.get(a), fit.knobs.get(b)) {
                    out.push((ka.name().to_string(), kb.name().to_string(), r));
                }
            }
        }
    }
    out
}
