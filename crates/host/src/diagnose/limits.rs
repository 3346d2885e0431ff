//! What the records allow of each effect the diagnosis did not add (`diagnose --limits`).
//!
//! "Nothing added" says that no effect earned its parameter; it does not say how large an
//! effect could be and still go unseen, which is what a test engineer needs next (is the
//! breakaway friction small, or do these records not show it at all?). The answer is a
//! profile: the effect held at a value, every parameter of the final model refitted
//! (Levenberg–Marquardt on the plain least-squares loss, from the previous point of the
//! walk), on the rows the final model keeps as predictable, and compared with the same refit
//! at the effect off (cost c_0). A value is ruled out when its refit (cost c_v) is worse by
//! both of the measures an effect must pass to be added, turned round:
//! - the evidence: n ln(c_v / c_0), twice the log-likelihood ratio under Gaussian residuals
//!   (n the residual's effective number of samples, `judge`'s lag-one estimate), beyond the
//!   decision's threshold ([`Options::bic_threshold`], 10);
//! - materiality: c_v − c_0 above (r² − 1) times the floor's cost (r =
//!   [`Options::material_ratio`], 1.2): the value leaves by itself the residual that takes a
//!   model at the noise floor to the line where a residual is material. The evidence alone
//!   assumes the model right to the noise, which a structured residual belies: on
//!   stiction_ratio/87 of the foreign suite it rules out a tachometer gain error of +0.07 %
//!   and favours −0.57 % by 191, while the final model sits below its floor.
//!
//! The walk goes up the effect's plausible range (the registry's prior, clamped into its
//! knob's bounds) on a log grid of [`GRID_POINTS`], stops at the first value disfavoured and
//! bisects [`BISECTIONS`] times between it and the last one allowed: a profile is assumed to
//! rise once it rises. A signed effect and a gain error are walked on both sides; the
//! voltage limit, which clips more the lower it is, is walked down from just below the
//! largest command (a limit above it does nothing) and its limit is the lowest value
//! allowed. The background mesh damping is fitted in every model and is not bounded here;
//! neither is an effect the final model has (its value has a standard error instead) or one
//! whose sensor no record carries.
//!
//! The rows are the final model's: a value that makes the model rattle on rows the final
//! model follows pays for it there, so a limit leans towards ruling values out rather than
//! in. On a record that cannot show the effect anywhere in its range the limit is the
//! range's top, reported as such.

use super::{judge, Options, Outcome};
use crate::calibrate::{self, Data, Param, Point};
use geared_servo::effects::Domain;
use geared_servo::{ActuatorParams, Effect};
use rayon::prelude::*;

/// Points of the walk over an effect's plausible range (log spaced, both ends included).
pub const GRID_POINTS: usize = 9;

/// Bisections between the last value allowed and the first disfavoured (geometric).
pub const BISECTIONS: usize = 3;

/// MINPACK's patience of each refit (evaluations per knob).
const PATIENCE: usize = 10;

/// Where a side's limit lies against the effect's plausible range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitKind {
    /// The records rule out even the low end of the plausible range: the limit lies below
    /// it (`Limit::value` is that end).
    BelowRange,
    /// Inside the plausible range.
    Within,
    /// Not ruled out anywhere in the plausible range (`Limit::value` is its top): these
    /// records cannot show the effect at any plausible size.
    BeyondRange,
}

impl LimitKind {
    /// Its name in `diagnose --json` (`limits[].kind`).
    pub fn name(self) -> &'static str {
        match self {
            LimitKind::BelowRange => "below_range",
            LimitKind::Within => "within",
            LimitKind::BeyondRange => "beyond_range",
        }
    }
}

/// How large one side of an effect the diagnosis did not add may be.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit {
    /// The effect.
    pub effect: Effect,
    /// The side walked: +1, or −1 for the negative side of a signed effect or a gain error.
    pub side: f64,
    /// The largest value on that side (signed, in the effect's unit) that the records do not
    /// rule out — for the voltage limit ([`descends`]) the lowest; see [`LimitKind`] for the
    /// ends of the range (for the voltage limit "below the range" is just below the largest
    /// command: every clipping is ruled out).
    pub value: f64,
    /// Where it lies against the plausible range.
    pub kind: LimitKind,
    /// The value of the walk the records favour most (signed, in the effect's unit), and
    /// its n ln(c_v / c_0) against the effect off ((0, 0) when no value beats the effect
    /// off).
    pub best: (f64, f64),
    /// Whether a value of the walk passed both measures of the module doc turned round
    /// (evidence below −10, a material share of the excess above the floor explained): the
    /// records favour the effect, yet the diagnosis refused it.
    pub favoured: bool,
}

/// The values walked on one side of `effect`, from the weakest to the strongest:
/// `GRID_POINTS` log spaced over the magnitude of its plausible range (a signed range by its
/// larger end, from a three-hundredth of it), clamped into its knob's bounds `(lo, hi)`. The
/// voltage limit is walked down, from just below the largest command `max_v` (a limit above
/// it does nothing) to the low end of its range. Empty when the side has no range.
fn walk(effect: Effect, side: f64, bounds: (f64, f64), max_v: f64) -> Vec<f64> {
    let (lo, hi) = effect.plausible_range();
    let (a, b) = match effect.domain() {
        _ if descends(effect) => (0.999 * max_v.min(hi), lo),
        Domain::Signed | Domain::GainError => {
            let m = lo.abs().max(hi.abs());
            (m / 300.0, m)
        }
        _ => (lo, hi),
    };
    if !(a > 0.0 && b > 0.0 && (b > a) != descends(effect)) {
        return Vec::new();
    }
    let n = GRID_POINTS.max(2);
    let mut v: Vec<f64> = (0..n)
        .map(|i| side * a * (b / a).powf(i as f64 / (n - 1) as f64))
        .map(|x| x.clamp(bounds.0, bounds.1))
        .filter(|x| *x != 0.0 && x.signum() == side)
        .collect();
    v.dedup();
    v
}

/// The sides walked for `effect`.
fn sides(effect: Effect) -> &'static [f64] {
    match effect.domain() {
        Domain::Signed | Domain::GainError => &[1.0, -1.0],
        _ => &[1.0],
    }
}

/// Whether `effect` is bounded here (module doc).
fn bounded(effect: Effect) -> bool {
    effect != Effect::MeshDamping
}

/// Whether `effect` grows stronger as its value falls (the voltage limit: a lower limit clips
/// more), so that its walk goes down and its limit is the lowest value allowed.
pub fn descends(effect: Effect) -> bool {
    effect == Effect::VoltageLimit
}

/// The limits of every effect of [`Options::limits`] that `out` did not add, on the records `data`
/// that its final model was fitted to (the validation record among them when it was
/// fitted; each weighted here by `out.weights`).
pub fn limits(out: &Outcome, data: &[Data], opts: &Options) -> Vec<Limit> {
    let wdata: Vec<Data> = data
        .iter()
        .zip(&out.weights)
        .map(|(d, w)| d.with_weights(w).with_robust(None))
        .collect();
    if wdata.is_empty() {
        return Vec::new();
    }
    let fin = &out.final_fit;
    let knobs = fin.knobs.clone();
    let max_v = data.iter().map(Data::max_abs_v).fold(0.0, f64::max);
    // The reference: the same refit with the effect off.
    let reference = calibrate::least_squares_point(&fin.params, &knobs, &wdata, PATIENCE);
    let n_eff = judge::effective_samples(&reference.params, &wdata);
    log::debug!(
        "limits: the final model refitted at cost {:.4e} (was {:.4e}), floor {:.4e}, n_eff {n_eff:.0}",
        reference.cost,
        fin.cost,
        out.floor_cost
    );
    let threshold = -opts.bic_threshold;
    let evidence = |p: &Point| n_eff * (p.cost / reference.cost).ln();
    let margin = (opts.material_ratio.powi(2) - 1.0) * out.floor_cost;
    let ruled_out = |p: &Point| evidence(p) > threshold && p.cost - reference.cost > margin;
    // Favoured: the evidence, and a material share of what the reference leaves above the
    // floor explained ([`Options::min_excess_share`]).
    let excess = reference.cost - out.floor_cost;
    let favours = |p: &Point| {
        evidence(p) < -threshold
            && excess > 0.0
            && reference.cost - p.cost >= opts.min_excess_share * excess
    };
    let tasks: Vec<(Effect, f64)> = opts
        .limits
        .iter()
        .copied()
        .filter(|&e| bounded(e) && fin.params.effects.get(e) == 0.0 && !out.unseen.contains(&e))
        .flat_map(|e| sides(e).iter().map(move |&s| (e, s)))
        .collect();
    tasks
        .par_iter()
        .filter_map(|&(effect, side)| {
            let k = calibrate::knob(&reference.params, Param::Effect(effect), max_v);
            let grid = walk(effect, side, (k.lo, k.hi), max_v);
            let first = *grid.first()?;
            let last = *grid.last()?;
            // The refit with the effect at `v` from `from`; `None` for a value the model
            // does not take (a delay beyond its history, say). A value the polish alone
            // would rule out is searched again locally (CMA-ES, `calibrate::refine`, then
            // the polish), and the better point kept: holding a breakaway friction can need
            // the running frictions moved by a tenth or more, which a derivative's view of
            // a cost with kinks does not reach (stiction_ratio/87 of the foreign suite:
            // polished from 1.39, the ratio 1.41 cost 4.9 times the effect off; searched,
            // 0.996 times).
            let at = |from: &ActuatorParams, v: f64| -> Option<Point> {
                let mut q = *from;
                q.effects.set(effect, v);
                q.derived().ok()?;
                let p = calibrate::least_squares_point(&q, &knobs, &wdata, PATIENCE);
                if p.cost.is_finite() && !ruled_out(&p) {
                    return Some(p);
                }
                let r = calibrate::refine(&q, &knobs, &wdata);
                let s = calibrate::least_squares_point(&r, &knobs, &wdata, PATIENCE);
                let best = if s.cost < p.cost || !p.cost.is_finite() { s } else { p };
                best.cost.is_finite().then_some(best)
            };
            let mut best = (0.0, 0.0);
            let mut favoured = false;
            // Records the point's evidence; whether it is allowed.
            let mut note = |v: f64, p: &Point| {
                let e = evidence(p);
                let out = ruled_out(p);
                log::debug!(
                    "  limits: {effect} at {v:.4e}: cost x{:.4} of the effect off, n ln ratio {e:.1}, {}",
                    p.cost / reference.cost,
                    if out { "ruled out" } else { "allowed" }
                );
                if e < best.1 {
                    best = (v, e);
                }
                favoured |= favours(p);
                !out
            };
            // The walk: the last value allowed (with its point) and the first disfavoured.
            let mut allowed: Option<(f64, Point)> = None;
            let mut refused: Option<f64> = None;
            for &v in &grid {
                let from = allowed.as_ref().map_or(reference.params, |a| a.1.params);
                match at(&from, v) {
                    Some(p) if note(v, &p) => allowed = Some((v, p)),
                    _ => {
                        refused = Some(v);
                        break;
                    }
                }
            }
            let (kind, value) = match (allowed, refused) {
                (None, _) => (LimitKind::BelowRange, first),
                (Some(_), None) => (LimitKind::BeyondRange, last),
                (Some((mut ok, mut point)), Some(mut bad)) => {
                    for _ in 0..BISECTIONS {
                        let m = side * (ok.abs() * bad.abs()).sqrt();
                        match at(&point.params, m) {
                            Some(p) if note(m, &p) => (ok, point) = (m, p),
                            _ => bad = m,
                        }
                    }
                    (LimitKind::Within, ok)
                }
            };
            Some(Limit {
                effect,
                side,
                value,
                kind,
                best,
                favoured,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_walk_spans_the_plausible_range_on_each_side_inside_the_knobs_bounds() {
        let v = walk(Effect::StictionRatio, 1.0, (1.0, 10.0), 10.0);
        assert_eq!(v.len(), GRID_POINTS);
        assert!((v[0] - 1.1).abs() < 1e-12 && (v[GRID_POINTS - 1] - 3.0).abs() < 1e-12);
        assert!(v.windows(2).all(|w| w[1] > w[0]));
        let neg = walk(Effect::TachOffset, -1.0, (-1.0, 1.0), 10.0);
        assert!(neg.iter().all(|x| *x < 0.0));
        assert!((neg[GRID_POINTS - 1] + 0.3).abs() < 1e-12);
        assert!((neg[0] + 0.001).abs() < 1e-12);
        // A delay's knob stops at its history: the walk stops there too, without repeats.
        let d = walk(Effect::InputDelay, 1.0, (0.0, 1e-3), 10.0);
        assert!(d.iter().all(|x| *x <= 1e-3) && d.windows(2).all(|w| w[1] > w[0]));
        assert_eq!(sides(Effect::TachGain), &[1.0, -1.0]);
        assert_eq!(sides(Effect::LoadViscous), &[1.0]);
        assert!(!bounded(Effect::MeshDamping) && bounded(Effect::VoltageLimit));
        // The voltage limit goes down from just below the largest command to its range's
        // low end; with every command below that end there is nothing to walk.
        let v = walk(Effect::VoltageLimit, 1.0, (0.2, 20.0), 10.0);
        assert_eq!(v.len(), GRID_POINTS);
        assert!((v[0] - 9.99).abs() < 1e-9 && (v[GRID_POINTS - 1] - 5.0).abs() < 1e-9);
        assert!(v.windows(2).all(|w| w[1] < w[0]));
        assert!(walk(Effect::VoltageLimit, 1.0, (0.08, 8.0), 4.0).is_empty());
    }
}
