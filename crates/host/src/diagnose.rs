//! `diagnose`: calibrate the default parameter set, analyse the residual, trace it to a
//! missing effect, add the effect, refit, repeat; report the error before and after.
//!
//! Tracing: every candidate effect that the model does not have yet is scored by a
//! one-dimensional search of its value on a grid around its natural scale (everything else
//! held at the current fit) — how much of the residual it can explain. The best few are
//! refitted together with the default set by Levenberg–Marquardt. The best refit is added
//! only if it earns its parameter by the Bayesian information criterion, computed with an
//! effective sample count n (1 − ρ₁)/(1 + ρ₁) (ρ₁: lag-1 autocorrelation of the residual, so
//! that a smooth, strongly correlated residual does not count as n independent samples), and,
//! when a validation record is given, only if it also lowers the validation error; it must
//! also explain at least 5 % of the residual energy. The loop
//! stops when the residual is white or no candidate earns its place; structure left then is
//! reported as unexplained, with the band and regime that hold its energy.

use crate::calibrate::{self, Data, Fit, Knob, Param};
use crate::error::HostError;
use crate::residual::{self, Analysis};
use geared_servo::{ActuatorParams, Effect};
use rayon::prelude::*;

/// Options of the search.
#[derive(Clone, Debug)]
pub struct Options {
    /// Candidate effects (default: all seven).
    pub candidates: Vec<Effect>,
    /// Most effects added.
    pub max_steps: usize,
    /// Candidates refitted fully per step (the best by their one-dimensional score).
    pub refit_top: usize,
    /// ΔBIC an effect must beat (negative: strong evidence at −10, Kass & Raftery 1995).
    pub bic_threshold: f64,
    /// Least share of the residual energy an effect must explain to be claimed (materiality:
    /// with a strongly structured residual a small gain can pass the BIC and still say
    /// nothing about the structure).
    pub min_explained: f64,
    /// Parameters to calibrate instead of the default set (key paths of
    /// [`calibrate::FITTABLE`]); `None`: the default set.
    pub fit: Option<Vec<String>>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            candidates: Effect::ALL.to_vec(),
            max_steps: 3,
            refit_top: 3,
            bic_threshold: -10.0,
            min_explained: 0.05,
            fit: None,
        }
    }
}

/// One effect added.
#[derive(Clone, Debug)]
pub struct Step {
    /// The effect.
    pub effect: Effect,
    /// Calibrated value, in the effect's unit.
    pub value: f64,
    /// Its standard error.
    pub std_error: f64,
    /// NRMSE (root mean square over records) before and after adding it.
    pub nrmse_before: f64,
    /// After.
    pub nrmse_after: f64,
    /// ΔBIC of adding it (negative = better).
    pub delta_bic: f64,
    /// Scores of every candidate at this step: (effect, predicted NRMSE, start value).
    pub scores: Vec<(Effect, f64, f64)>,
    /// The residual is still structured at the end: this effect earned its parameter but
    /// does not account for the structure, so it is not claimed with confidence.
    pub partial: bool,
    /// Other candidates that explained this record as well (within the BIC threshold):
    /// the data cannot tell them apart, and this one was chosen because it needs the least
    /// change of the parameters already calibrated.
    pub indistinguishable_from: Vec<Effect>,
}

/// Everything `diagnose` found.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The file's parameters (stiffness in measured form).
    pub nominal: ActuatorParams,
    /// Analysis of the nominal model on the first record.
    pub nominal_analysis: Analysis,
    /// Calibration of the default set, no effect added.
    pub base: Fit,
    /// Analysis after that calibration.
    pub base_analysis: Analysis,
    /// Effects added, in order.
    pub steps: Vec<Step>,
    /// Final calibration.
    pub final_fit: Fit,
    /// Final analysis on the first record.
    pub final_analysis: Analysis,
    /// Validation NRMSE of the nominal model and of the final one.
    pub validation: Option<(f64, f64)>,
    /// Residual still structured and no candidate explains it.
    pub unexplained: bool,
    /// Candidate scores of the last search: (effect, predicted NRMSE, start value).
    pub last_scores: Vec<(Effect, f64, f64)>,
    /// The best candidate of the last search when it did not earn its place:
    /// (effect, value, NRMSE after its refit).
    pub rejected: Option<(Effect, f64, f64)>,
}

fn rms_nrmse(cost: f64) -> f64 {
    cost.max(0.0).sqrt()
}

fn analyse(p: &ActuatorParams, d: &Data) -> Result<(Analysis, calibrate::Trace), HostError> {
    let t = calibrate::simulate(p, d)
        .ok_or_else(|| HostError::other("the calibrated parameters are invalid"))?;
    Ok((residual::analyse(&d.y, &t, &d.volts, d.sample_period_s), t))
}

/// Lag-1 autocorrelation of the stacked residuals of `p` (first record).
fn effective_samples(p: &ActuatorParams, data: &[Data]) -> f64 {
    let n: usize = data.iter().map(|d| d.y.len()).sum();
    let Some(d) = data.first() else { return 1.0 };
    let Some(t) = calibrate::simulate(p, d) else {
        return 1.0;
    };
    let e: Vec<f64> = d.y.iter().zip(&t.y).map(|(a, b)| a - b).collect();
    let m = e.iter().sum::<f64>() / e.len().max(1) as f64;
    let s0: f64 = e.iter().map(|x| (x - m).powi(2)).sum();
    let s1: f64 = e
        .iter()
        .zip(e.iter().skip(1))
        .map(|(a, b)| (a - m) * (b - m))
        .sum();
    let rho = if s0 > 0.0 {
        (s1 / s0).clamp(0.0, 0.999)
    } else {
        0.0
    };
    (n as f64 * (1.0 - rho) / (1.0 + rho)).max(2.0)
}

/// Grid of values tried for `effect` (whose knob is `k`) in the one-dimensional score.
fn grid(p: &ActuatorParams, effect: Effect, k: &Knob, max_abs_v: f64) -> Vec<f64> {
    let s = calibrate::effect_scale(p, effect, max_abs_v);
    let v: Vec<f64> = match effect {
        Effect::InputDelay => [0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0]
            .iter()
            .map(|f| f * s)
            .collect(),
        Effect::VoltageLimit => [0.3, 0.45, 0.6, 0.7, 0.8, 0.9, 0.95]
            .iter()
            .map(|f| f * s)
            .collect(),
        Effect::TachGain => vec![-0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3],
        _ => [1e-3, 3e-3, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0]
            .iter()
            .map(|f| f * s)
            .collect(),
    };
    v.into_iter().map(|x| x.clamp(k.lo, k.hi)).collect()
}

/// Linearised projection of the residual on each candidate: for every grid value v, the
/// residual change d_v that the effect at v causes (a secant from zero, so the kinks of
/// friction and backlash near zero do not matter), then the least-squares fit of the residual
/// by d_v together with the Jacobian of the current knobs (so that what the current knobs
/// already compensate is not credited to the effect). Returns (knob, predicted cost, start
/// value), best first.
fn score(
    cur: &Fit,
    cands: &[(Effect, Knob)],
    data: &[Data],
    max_v: f64,
) -> Vec<(Effect, Knob, f64, f64)> {
    let r0 = calibrate::residuals(&cur.params, data);
    let z: Vec<f64> = cur
        .knobs
        .iter()
        .map(|k| k.to_z(calibrate::get(&cur.params, k.param)))
        .collect();
    let j = calibrate::jacobian(&cur.params, &cur.knobs, data, &z);
    let base_pred = {
        let svd = j.clone().svd(true, true);
        match svd.solve(&r0, 1e-12) {
            Ok(x) => (&r0 - &j * x).norm_squared(),
            Err(_) => r0.norm_squared(),
        }
    };
    let mut out: Vec<(Effect, Knob, f64, f64)> = cands
        .iter()
        .map(|(e, k)| {
            let g = grid(&cur.params, *e, k, max_v);
            let best = g
                .par_iter()
                .filter_map(|&v| {
                    let mut q = cur.params;
                    calibrate::set(&mut q, k.param, v);
                    // d = r(v) − r0 is minus the model change; fit r0 ≈ −(J δ + α d).
                    let d = calibrate::residuals(&q, data) - &r0;
                    let mut a = j.clone().insert_column(j.ncols(), 0.0);
                    a.set_column(j.ncols(), &d);
                    let x = a.clone().svd(true, true).solve(&r0, 1e-12).ok()?;
                    let alpha = -x.get(j.ncols()).copied().unwrap_or(f64::NAN);
                    if alpha.is_nan() || alpha <= 0.0 {
                        return None;
                    }
                    let pred = (&r0 - &a * x).norm_squared();
                    let start = match e {
                        Effect::VoltageLimit => v,
                        _ => (v * alpha.clamp(0.3, 3.0)).clamp(k.lo, k.hi),
                    };
                    Some((pred, start))
                })
                .collect::<Vec<_>>()
                .into_iter()
                .fold((base_pred, 0.0), |b, x| if x.0 < b.0 { x } else { b });
            (*e, k.clone(), best.0, best.1)
        })
        .collect();
    out.sort_by(|a, b| a.2.total_cmp(&b.2));
    out
}

/// Picks the candidate to add from the screened refits. Fits whose costs differ by less
/// than `bic_margin` in BIC terms (`n_eff · ln(cost / best)`) explain the record equally
/// well: the data cannot separate them (e.g. motor viscous friction and a tachometer gain
/// error with rescaled inertias both lower the DC gain). Among those, the one that moves the
/// already-calibrated parameters least from the current fit wins — the file's values are the
/// prior, and an explanation that needs a 30 % change of every inertia is the less likely one.
/// Returns the fit, its effect, and the other indistinguishable candidates.
fn choose(
    cur: &Fit,
    fits: Vec<(Fit, Effect)>,
    n_eff: f64,
    bic_margin: f64,
) -> Option<(Fit, Effect, Vec<Effect>)> {
    let best = fits
        .iter()
        .map(|(f, _)| f.cost)
        .fold(f64::INFINITY, f64::min);
    if !best.is_finite() {
        return None;
    }
    let distortion = |f: &Fit| -> f64 {
        cur.knobs
            .iter()
            .zip(cur.values.iter())
            .zip(f.values.iter())
            .map(|((kn, a), b)| {
                let d = if kn.log {
                    kn.to_z(*b) - kn.to_z(*a)
                } else {
                    (b - a) / a.abs().max(f64::MIN_POSITIVE)
                };
                d * d
            })
            .sum()
    };
    let mut close: Vec<(Fit, Effect)> = fits
        .into_iter()
        .filter(|(f, _)| n_eff * (f.cost / best).ln() < bic_margin)
        .collect();
    close.sort_by(|(a, _), (b, _)| distortion(a).total_cmp(&distortion(b)));
    let mut it = close.into_iter();
    let (fit, effect) = it.next()?;
    let others = it.map(|(_, e)| e).collect();
    Some((fit, effect, others))
}

/// The parameters named in `names`, each one [`diagnose`] can calibrate
/// ([`calibrate::FITTABLE`]) and given a non-zero starting value by `params`.
pub fn fittable(params: &ActuatorParams, names: &[String]) -> Result<Vec<Param>, HostError> {
    let nominal = calibrate::with_measured_stiffness(params)?;
    names
        .iter()
        .map(|n| {
            let Some(param) = calibrate::FITTABLE.into_iter().find(|p| p.name() == n) else {
                let known: Vec<&str> = calibrate::FITTABLE.iter().map(|p| p.name()).collect();
                return Err(HostError::input(format!(
                    "`{n}` cannot be calibrated (known: {})",
                    known.join(", ")
                )));
            };
            let v = calibrate::get(&nominal, param);
            if v.is_nan() || v <= 0.0 {
                return Err(HostError::input(format!(
                    "`{n}` is 0 in the parameter file; give it a starting value there"
                )));
            }
            Ok(param)
        })
        .collect()
}

/// Runs the whole diagnosis on `data` (one or more records) from the file's parameters.
pub fn diagnose(
    file_params: &ActuatorParams,
    data: &[Data],
    validation: Option<&Data>,
    opts: &Options,
) -> Result<Outcome, HostError> {
    let first = data
        .first()
        .ok_or_else(|| HostError::input("no record to diagnose"))?;
    let mut nominal = calibrate::with_measured_stiffness(file_params)?;
    nominal.sample_period_s = first.sample_period_s;
    let max_v = data.iter().map(Data::max_abs_v).fold(0.0, f64::max);
    let (nominal_analysis, _) = analyse(&nominal, first)?;

    let knobs = match &opts.fit {
        None => calibrate::default_knobs(&nominal, max_v),
        Some(names) => {
            let mut ks = Vec::new();
            for param in fittable(file_params, names)? {
                ks.push(calibrate::knob(&nominal, param, max_v));
            }
            ks
        }
    };
    let base = calibrate::calibrate(&nominal, &knobs, data);
    let (base_analysis, _) = analyse(&base.params, first)?;

    let mut cur = base.clone();
    let mut cur_white = base_analysis.white;
    let mut steps = Vec::new();
    let mut last_scores = Vec::new();
    let mut rejected: Option<(Effect, f64, f64)> = None;
    let val_cost = |p: &ActuatorParams| validation.map(|v| calibrate::nrmse(p, v));
    while steps.len() < opts.max_steps && !cur_white {
        let cands: Vec<(Effect, Knob)> = opts
            .candidates
            .iter()
            .filter(|&&c| cur.params.effects.get(c) == 0.0)
            .map(|&c| (c, calibrate::knob(&cur.params, Param::Effect(c), max_v)))
            .collect();
        if cands.is_empty() {
            break;
        }
        let scores = score(&cur, &cands, data, max_v);
        let score_list: Vec<(Effect, f64, f64)> = scores
            .iter()
            .map(|(e, _, c, v)| (*e, rms_nrmse(*c), *v))
            .collect();
        // Refit the best few (those predicted to explain anything at all): coarse search of
        // every knob around the start, then Levenberg–Marquardt.
        let mut screened_fits: Vec<(Fit, Effect)> = Vec::new();
        for (e, k, c, v) in scores.iter().take(opts.refit_top) {
            if c.is_nan() || *c >= cur.cost || *v == 0.0 {
                continue;
            }
            let mut ks = cur.knobs.clone();
            ks.push(k.clone());
            // Two starts: the current fit, and the file's values (with the effects added so
            // far) — a large missing effect can drag the current fit far off, to the bounds.
            let mut from_file = nominal;
            for kn in &cur.knobs {
                if let Param::Effect(added) = kn.param {
                    from_file.effects.set(added, cur.params.effects.get(added));
                }
            }
            // The second start only when the current fit sits at a bound (dragged off).
            let starts: Vec<ActuatorParams> = if calibrate::at_bounds(&cur).is_empty() {
                vec![cur.params]
            } else {
                vec![cur.params, from_file]
            };
            for start in starts {
                // Start the effect at the better (by the actual cost) of the projection's
                // value and the best of its grid with everything else held: the projection
                // is linear and can undershoot a strongly nonlinear effect.
                let mut p = start;
                calibrate::set(&mut p, k.param, *v);
                let mut best_c = calibrate::cost(&p, data);
                let tried: Vec<(f64, ActuatorParams)> = grid(&start, *e, k, max_v)
                    .par_iter()
                    .map(|&g| {
                        let mut q = start;
                        calibrate::set(&mut q, k.param, g);
                        (calibrate::cost(&q, data), q)
                    })
                    .collect();
                for (c, q) in tried {
                    if c < best_c {
                        best_c = c;
                        p = q;
                    }
                }
                let (p1, _) = calibrate::coarse_search(&p, &ks, data, 1);
                // Screening refit (few iterations); the winner is polished below.
                let fit = calibrate::levenberg_marquardt_with(&p1, &ks, data, 4);
                let better = screened_fits
                    .iter()
                    .find(|(_, done)| done == e)
                    .is_none_or(|(f, _)| fit.cost < f.cost);
                if better {
                    screened_fits.retain(|(_, done)| done != e);
                    screened_fits.push((fit, *e));
                }
            }
        }
        last_scores = score_list.clone();
        let n_eff = effective_samples(&cur.params, data);
        let Some((screened, effect, alternatives)) =
            choose(&cur, screened_fits, n_eff, -opts.bic_threshold)
        else {
            break;
        };
        let fit = calibrate::levenberg_marquardt(&screened.params, &screened.knobs, data);
        rejected = Some((
            effect,
            fit.values.last().copied().unwrap_or(f64::NAN),
            rms_nrmse(fit.cost),
        ));
        let delta_bic = n_eff * (fit.cost / cur.cost).ln() + n_eff.ln();
        let val_ok = match (val_cost(&cur.params), val_cost(&fit.params)) {
            (Some(a), Some(b)) => b < a,
            _ => true,
        };
        let material = fit.cost <= (1.0 - opts.min_explained) * cur.cost;
        if delta_bic.is_nan() || delta_bic >= opts.bic_threshold || !val_ok || !material {
            break;
        }
        let idx = fit.knobs.len() - 1;
        steps.push(Step {
            effect,
            value: fit.values.get(idx).copied().unwrap_or(f64::NAN),
            std_error: fit.std_errors.get(idx).copied().unwrap_or(f64::NAN),
            nrmse_before: rms_nrmse(cur.cost),
            nrmse_after: rms_nrmse(fit.cost),
            delta_bic,
            scores: score_list,
            partial: false,
            indistinguishable_from: alternatives,
        });
        rejected = None;
        cur = fit;
        cur_white = analyse(&cur.params, first)?.0.white;
    }
    let (final_analysis, _) = analyse(&cur.params, first)?;
    for st in &mut steps {
        st.partial = !final_analysis.white;
    }
    let validation = match (val_cost(&nominal), val_cost(&cur.params)) {
        (Some(a), Some(b)) => Some((a, b)),
        _ => None,
    };
    Ok(Outcome {
        nominal,
        nominal_analysis,
        base_analysis,
        base,
        steps,
        unexplained: !final_analysis.white,
        final_analysis,
        final_fit: cur,
        validation,
        last_scores,
        rejected,
    })
}
