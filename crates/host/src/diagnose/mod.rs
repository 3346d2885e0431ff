//! `diagnose`: calibrate the default parameter set, analyse the residual, trace it to a
//! missing effect, add the effect, refit, repeat; report the error before and after.
//!
//! It is built for records the emulator did not make (a real rig, or an independent
//! simulator), which differ from the model in three ways that decisions must respect:
//!
//! - **Unpredictable spans.** In gear-rattle regimes no model follows a rig sample by sample
//!   ([`crate::predictability`]). Those rows are weighted out of every fit and decision, and
//!   their share is reported.
//! - **Noise.** The noise level is estimated from the record itself ([`crate::noise`]); the
//!   NRMSE it alone causes is the floor. An effect must explain a material share of what lies
//!   *above* the floor, and the residual is "explained" when it is within
//!   [`Options::material_ratio`] of the floor — with 10⁴ samples every tiny mismatch is
//!   statistically significant, so significance (ΔBIC) is necessary but not sufficient.
//! - **Wrong basins and gross errors.** The default set is calibrated globally
//!   ([`calibrate::calibrate`]); when the calibrated residual is far above the floor, every
//!   candidate is refitted fully instead of being screened by a linear projection around a
//!   fit that a missing effect has bent.
//!
//! Tracing: each candidate effect the model does not have yet is scored by a linearised
//! projection of the residual; the best few (every one when the fit is poor, or when even
//! the best score explains under [`SCREEN_SHARE`] of the cost above the floor) are refitted
//! with the default set by Levenberg–Marquardt. A refit is *admissible* when the current
//! model leaves something to explain on the rows both it and the refit keep (its cost there
//! more than two standard deviations of the floor's uncertainty above the noise floor:
//! `judge::at_floor`), earns its parameter by the Bayesian information criterion
//! (effective sample count n (1 − ρ₁)/(1 + ρ₁), ρ₁ the residual's lag-1 autocorrelation),
//! explains at least [`Options::min_excess_share`]
//! of the cost above the floor (both measured against the best point of the model without a
//! new effect that any candidate's refit reached when its effect is switched off again), and
//! its value is plausible (within the effect's plausible range
//! of the registry, widened by [`Options::plausibility_slack`]). Admissible refits whose costs
//! the data cannot tell apart (within the BIC threshold) form one class, ordered by physical
//! likelihood: a value inside the plausible range first, then the least change of the
//! parameters already calibrated; when every member's value is implausible, a plausible kin
//! that the validation record does not show worse joins it, first (`judge::with_plausible_kin`);
//! a kin of the best that explains the best's own rows as well joins it, last
//! (`judge::with_kin_on_best_rows`). The first of the class that also holds on held-out data —
//! cross-validated segments of the record and, when given, the validation record — is added,
//! reported with the others of its class and the measurement that would separate them.
//! After each step, each earlier step is tested again (the backward step); at the end of each
//! pass every step, the last included (`judge::backward_review`).
//! Every diagnosis ends with a fine search on the rows the model is reported on
//! (`settle::fine_search`). `unexplained` is true when a material residual remains above
//! the floor on the predictable rows, spread over the record, and no candidate explains it.

mod judge;
mod kin;
pub mod limits;
mod search;
mod settle;

pub use kin::{kin, separating_measurement, KIN};

use crate::calibrate::{self, Data, Fit, Knob, Param, Robust};
use crate::error::HostError;
use crate::noise;
use crate::predictability;
use crate::progress::Progress;
use crate::repeat::{Coherent, Repeating};
use crate::residual::{self, Analysis};
use geared_servo::{ActuatorParams, Effect};
use settle::{
    better_on_common, better_or_nearer, common_rows, dissipation_from_start, first_floor_cost,
    floor_cost, settle, settle_seeded, weigh, weigh_one, weigh_smooth,
};

/// Share of the current fit's cost above the noise floor that the best of the linear
/// candidate scores must explain for the scores to choose which candidates are refitted;
/// below it every candidate is.
pub const SCREEN_SHARE: f64 = 0.5;

/// Options of the search.
#[derive(Clone, Debug)]
pub struct Options {
    /// Candidate effects (default: all of [`Effect::ALL`]).
    pub candidates: Vec<Effect>,
    /// Most effects added.
    pub max_steps: usize,
    /// Candidates refitted fully per step when the fit is good (the best by their projected
    /// score); when it is poor (NRMSE above [`Options::poor_ratio`] times the floor) all are.
    pub refit_top: usize,
    /// ΔBIC an effect must beat (negative: strong evidence at −10, Kass & Raftery 1995); also
    /// the width of a class of indistinguishable explanations.
    pub bic_threshold: f64,
    /// Least share of the cost above the noise floor an effect must explain (materiality).
    pub min_excess_share: f64,
    /// The residual is material while NRMSE exceeds this multiple of the noise floor.
    pub material_ratio: f64,
    /// The fit is poor (all candidates are refitted) above this multiple of the floor.
    pub poor_ratio: f64,
    /// Factor by which a value may leave the effect's plausible range and still be admissible
    /// (log scale for positive effects; the range's half-width for a gain error).
    pub plausibility_slack: f64,
    /// Weight out unpredictable spans ([`crate::predictability`]).
    pub predictability: bool,
    /// Parameters to calibrate instead of the default set (key paths of
    /// [`calibrate::FITTABLE`]); `None`: the default set.
    pub fit: Option<Vec<String>>,
    /// Effects to bound where the diagnosis did not add them ([`limits`]: the largest value
    /// the records do not rule out, a profile of refits per effect); empty (the default):
    /// none.
    pub limits: Vec<Effect>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            candidates: Effect::ALL.to_vec(),
            max_steps: 3,
            refit_top: 3,
            bic_threshold: -10.0,
            min_excess_share: 0.3,
            material_ratio: 1.2,
            poor_ratio: 2.0,
            plausibility_slack: 2.0,
            predictability: true,
            fit: None,
            limits: Vec::new(),
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
    /// NRMSE over the predictable rows (root mean square over records) before adding it: the
    /// rows both the model before and the model after keep.
    pub nrmse_before: f64,
    /// After.
    pub nrmse_after: f64,
    /// ΔBIC of adding it (negative = better).
    pub delta_bic: f64,
    /// Scores of every candidate at this step: (effect, predicted NRMSE, start value).
    pub scores: Vec<(Effect, f64, f64)>,
    /// A material residual remains at the end: this effect earned its parameter but does
    /// not account for everything, so it is not claimed with confidence.
    pub partial: bool,
    /// Other candidates that explained this record as well (within the BIC threshold), with
    /// their values: the data cannot tell them apart. This one was put first as the
    /// physically likelier (value inside its plausible range, least change of the parameters
    /// already calibrated).
    pub indistinguishable_from: Vec<(Effect, f64)>,
    /// What measurement would separate this effect from the first of
    /// `indistinguishable_from` (empty when there is none).
    pub separate_by: String,
    /// Held-out check: (NRMSE on held-out segments without the effect, with it).
    pub held_out: (f64, f64),
    /// Members of its class that the estimation records could not tell from it but the
    /// validation record could (chosen by it, or replaced by this one once it was fitted
    /// too): what they would give and why they were not kept.
    pub told_apart: Vec<Rejection>,
}

/// A candidate refitted and judged but not added.
#[derive(Clone, Debug)]
pub struct Rejection {
    /// The effect.
    pub effect: Effect,
    /// Its refitted value.
    pub value: f64,
    /// NRMSE (predictable rows) after its refit.
    pub nrmse_after: f64,
    /// Why it was not added.
    pub reason: String,
}

/// What the final residual is, against the noise floor of its predictable rows
/// ([`Options::material_ratio`] being the limit of "near the floor").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResidualKind {
    /// Within the limit of the floor: what is left is noise.
    AtFloor,
    /// Above the limit plainly, but not under the robust window loss: the excess sits in a
    /// few windows (spans where the unit moves on another branch of the motion than the
    /// model, rattle the predictability assessment kept), so it is not claimed as a missing
    /// effect.
    FewWindows,
    /// Above the limit plainly and under the robust window loss (spread over the record), or
    /// in a few windows that come back in every period of a periodic command, or that are
    /// coherent with a stepped sine's bursts, more than the limit allows
    /// ([`Outcome::repeating`], [`Outcome::coherent`]). With no candidate left to explain
    /// it, the diagnosis is *unexplained*.
    Systematic,
}

impl ResidualKind {
    /// Its name in `diagnose --json` (`noise.residual`).
    pub fn name(self) -> &'static str {
        match self {
            ResidualKind::AtFloor => "at_floor",
            ResidualKind::FewWindows => "few_windows",
            ResidualKind::Systematic => "systematic",
        }
    }
}

/// Everything `diagnose` found.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The file's parameters (stiffness in measured form).
    pub nominal: ActuatorParams,
    /// Analysis of the nominal model on the first record (every row).
    pub nominal_analysis: Analysis,
    /// Calibration of the default set, no effect added.
    pub base: Fit,
    /// Analysis after that calibration (predictable rows).
    pub base_analysis: Analysis,
    /// Effects added, in order.
    pub steps: Vec<Step>,
    /// Final calibration.
    pub final_fit: Fit,
    /// Final analysis on the first record (predictable rows).
    pub final_analysis: Analysis,
    /// NRMSE of the final model on every row of the first record.
    pub final_nrmse_all_rows: f64,
    /// Validation NRMSE (predictable rows) of the nominal model and of the final one.
    pub validation: Option<(f64, f64)>,
    /// The NRMSE the noise alone gives on the validation record's predictable rows.
    pub validation_floor: Option<f64>,
    /// When the validation record was added to the fit ([`diagnose`]): the NRMSE and floor
    /// on it of the model calibrated without it, which left a material residual there.
    /// `validation` is then no longer held out.
    pub validation_in_fit: Option<(f64, f64)>,
    /// A material residual remains above the noise floor, spread over the record (its
    /// robust window loss too is above 1.2× what noise gives: `robust_floor_ratio`), and no
    /// candidate explains it.
    pub unexplained: bool,
    /// The final model's residual on its predictable rows under the robust window loss
    /// ([`calibrate::Robust`]), RMS over what noise alone gives: near the plain NRMSE over
    /// the floor when the residual is spread over the record, much lower when it sits in a
    /// few windows.
    pub robust_floor_ratio: f64,
    /// What the final residual is (the verdict's two halves: the plain NRMSE and the robust
    /// ratio, each against `material_ratio`).
    pub residual: ResidualKind,
    /// The limit over the floor the residual was judged by ([`Options::material_ratio`]).
    pub material_ratio: f64,
    /// The ΔBIC an effect had to beat ([`Options::bic_threshold`]).
    pub bic_threshold: f64,
    /// Candidate scores of the last search: (effect, predicted NRMSE, start value).
    pub last_scores: Vec<(Effect, f64, f64)>,
    /// The candidates of the last search that were refitted and not added, best first.
    pub rejected: Vec<Rejection>,
    /// Estimated noise standard deviation of each record, in its output's unit.
    pub noise_sigma: Vec<f64>,
    /// NRMSE of the first output that the noise alone gives (root mean square over records,
    /// predictable rows): the floor.
    pub floor_nrmse: f64,
    /// The cost at the floor ([`calibrate::cost`]'s unit, every output fitted: each further
    /// output at its floor adds what the first at its noise does, [`calibrate::Channel`]);
    /// `floor_nrmse²` for records with one output.
    pub floor_cost: f64,
    /// The outputs fitted in each record, the first first ([`Data::columns`]).
    pub fitted_outputs: Vec<Vec<String>>,
    /// Candidates not tried: errors of a sensor whose output no record has
    /// ([`Effect::sensor_column`]; a tachometer's gain on records of the load angle alone).
    pub unseen: Vec<Effect>,
    /// Share of each record's rows weighted out as unpredictable, at the final fit.
    pub unpredictable_share: Vec<f64>,
    /// The row weights of each record at the final fit (1 predictable, 0 not).
    pub weights: Vec<Vec<f64>>,
    /// RMS of the measured and of the modelled output over the unpredictable rows of the
    /// first record (compared by statistics instead of sample by sample), when there are any.
    pub unpredictable_rms: Option<(f64, f64)>,
    /// The first record's unpredictable spans of at least
    /// [`predictability::SPAN_MIN_S`], each compared by its level, measured against the
    /// final model ([`predictability::span_levels`]): a span where the model's level is far
    /// from the record's is one it has not explained, only excused.
    pub unpredictable_spans: Vec<predictability::SpanLevel>,
    /// Per fitted record whose command is periodic ([`crate::repeat::command_period`]), the
    /// final model's residual over every row and the part of it that repeats with the
    /// command; `None` for a record whose command is not periodic. Rattle leaves a residual
    /// that does not repeat; a repeating part above what the floor's limit allows
    /// ([`Options::material_ratio`]) makes a residual in a few windows systematic.
    pub repeating: Vec<Option<Repeating>>,
    /// The same on the validation record, when it was given.
    pub validation_repeating: Option<Repeating>,
    /// How large each candidate that was not added may be ([`limits::limits`]), when
    /// [`Options::limits`] asked for it; empty otherwise.
    pub limits: Vec<limits::Limit>,
    /// Per fitted record whose command holds sine bursts ([`crate::repeat::sine_bursts`]:
    /// a stepped sine), the final model's residual over every row and the part of it
    /// coherent with the bursts' frequencies; `None` for a record without sine bursts. A
    /// burst where the unit rattles leaves a residual mostly incoherent; the coherent parts
    /// of the bursts where they are the majority, above what the floor's limit allows
    /// ([`Options::material_ratio`]), make a residual in a few windows systematic.
    pub coherent: Vec<Option<Coherent>>,
}

fn rms_nrmse(cost: f64) -> f64 {
    cost.max(0.0).sqrt()
}

fn analyse(p: &ActuatorParams, d: &Data) -> Result<(Analysis, calibrate::Trace), HostError> {
    let t = calibrate::simulate(p, d)
        .ok_or_else(|| HostError::other("the calibrated parameters are invalid"))?;
    Ok((analysis_of(d, &t), t))
}

/// The residual of the model run `t` over `d`, over its weighted rows: an angle fitted as
/// its steps judged on the angle they rebuild ([`residual::analyse_steps`]).
fn analysis_of(d: &Data, t: &calibrate::Trace) -> Analysis {
    if d.steps {
        residual::analyse_steps(&d.y, t, &d.volts, d.sample_period_s, &d.weight)
    } else {
        residual::analyse_weighted(&d.y, t, &d.volts, d.sample_period_s, &d.weight)
    }
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

/// Runs the whole diagnosis on `data` (one or more records) from the file's parameters,
/// checking what it finds on `validation` when given.
///
/// When the calibrated model leaves a material residual on the validation record (above
/// [`Options::material_ratio`] times that record's own floor, on its predictable rows), the
/// validation record shows what the estimation records could not (a stepped sine, whose slow
/// bursts rattle, hardly shows a tachometer gain error or gravity; a square wave does): the
/// diagnosis then goes on from the model found so far on all records together, and the
/// outcome says so
/// ([`Outcome::validation_in_fit`]); the held-out checks are then the cross-validated
/// segments alone.
pub fn diagnose(
    file_params: &ActuatorParams,
    data: &[Data],
    validation: Option<&Data>,
    opts: &Options,
) -> Result<Outcome, HostError> {
    diagnose_with(file_params, data, validation, opts, &())
}

/// A diagnosis's options from what a front end takes by name: the command line's
/// `--max-steps`, `--candidates`, `--limits` and `--fit`, the Python keywords of the same
/// names. Effect names are the canonical ones ([`Effect::from_name`]); `limits` naming none
/// bounds every candidate (`--limits` alone); `fit` is checked by [`fittable`]. `prefix` is
/// how the front end writes an option before its name in an error ("--" on the command
/// line, "" in Python), so that the one-line error names the option as the user typed it.
pub fn options_by_name(
    params: &ActuatorParams,
    max_steps: usize,
    candidates: Option<&[String]>,
    limits: Option<&[String]>,
    fit: Option<&[String]>,
    prefix: &str,
) -> Result<Options, HostError> {
    let named = |option: &str, names: &[String]| -> Result<Vec<Effect>, HostError> {
        names
            .iter()
            .map(|n| Effect::from_name(n))
            .collect::<Result<_, _>>()
            .map_err(|e| HostError::input(format!("{prefix}{option}: {e}")))
    };
    let mut opts = Options {
        max_steps,
        ..Options::default()
    };
    if let Some(c) = candidates {
        opts.candidates = named("candidates", c)?;
    }
    if let Some(l) = limits {
        opts.limits = if l.is_empty() {
            opts.candidates.clone()
        } else {
            named("limits", l)?
        };
    }
    if let Some(f) = fit {
        fittable(params, f).map_err(|e| HostError::input(format!("{prefix}fit: {}", e.message)))?;
        opts.fit = Some(f.to_vec());
    }
    Ok(opts)
}

/// [`diagnose`] reporting each phase it completes to `progress` ([`Progress::stage`], the
/// same lines as the debug trace, without its counts): a diagnosis takes minutes on long
/// records, and a command line or a notebook can show where it is. After each phase it
/// stops with an error ([`crate::progress::cancelled`]) when the sink asks
/// ([`Progress::cancelled`]).
pub fn diagnose_with(
    file_params: &ActuatorParams,
    data: &[Data],
    validation: Option<&Data>,
    opts: &Options,
    progress: &dyn Progress,
) -> Result<Outcome, HostError> {
    // Every output a record has is fitted, each in units of its own floor; a load angle's
    // holds where in the file's gap the load sits (`calibrate::Channel`).
    let b = file_params.backlash_deg;
    let data: Vec<Data> = data.iter().map(|d| d.with_backlash(b)).collect();
    let validation = validation.map(|v| v.with_backlash(b));
    let mut out = passes(file_params, &data, validation.as_ref(), opts, progress)?;
    if !opts.limits.is_empty() {
        let mut fitted = data;
        if let (Some(v), Some(_)) = (validation, out.validation_in_fit) {
            fitted.push(v);
        }
        out.limits = limits::limits(&out, &fitted, opts);
        let line = "limits of the effects not added";
        log::debug!("{line}");
        progress.stage(line);
    }
    Ok(out)
}

/// The passes of [`diagnose_with`] over the records (with the file's gap for an angle).
fn passes(
    file_params: &ActuatorParams,
    data: &[Data],
    validation: Option<&Data>,
    opts: &Options,
    progress: &dyn Progress,
) -> Result<Outcome, HostError> {
    let out = diagnose_records(
        file_params,
        data,
        validation,
        opts,
        progress,
        None,
        validation.is_none(),
    )?;
    let (Some(v), Some((_, after)), Some(v_floor)) =
        (validation, out.validation, out.validation_floor)
    else {
        return Ok(out);
    };
    // Over every row of the validation record, the residual's RMS and its repeating part's,
    // in noise levels (for the trace: whether what sends the diagnosis on is rattle).
    let over_every_row = out.validation_repeating.map(|r| {
        (
            r.mean_square.sqrt() / r.noise_sigma,
            r.repeating_mean_square.sqrt() / r.noise_sigma,
        )
    });
    log::debug!(
        "validation after the first pass: NRMSE {after:.4}, floor {v_floor:.4} (a second pass above x{}); over every row, residual and repeating part in noise levels: {over_every_row:.2?}",
        opts.material_ratio
    );
    // The model the first pass reports is the finished one (the fine search moves it, and
    // with it the rows of the validation record it calls predictable): a material residual
    // it leaves there sends the diagnosis on as well (second_mode/59 of the foreign suite:
    // 0.0542 at a floor of 0.0451 before the fine search, 0.0370 at 0.0210 after), and so
    // does a material part of its residual over every row that repeats with the command
    // (crate::repeat: what the rows it calls unpredictable hide, when it comes back period
    // after period, is a response the model gets wrong, not rattle; hinge_stiffness/60: 1.10
    // noise levels repeat, 0.25 once the validation record is fitted too).
    // What the second pass is for: an effect the estimation record did not show, which on a
    // periodic validation record leaves a residual that repeats with the command, and the
    // steps taken, judged again with both records fitted (a hinge spring and a gravity
    // torque differ at the large swings of the validation record). With no step taken and
    // nothing material repeating, a material residual on the rows kept is rattle the
    // model's assessment kept, and fitting it is fitting chaos (bench clean/1 of the foreign
    // suite: 2.42 noise levels over every row, 0.00 repeating; fitted in a second pass, it
    // moved the friction split from +4/-4 % to +13/-12 % of the unit's).
    let (out, after, v_floor) = if after <= opts.material_ratio * v_floor
        || out.no_step_and_nothing_repeats()
    {
        let fin = finished(file_params, data, validation, opts, progress, out)?;
        let (Some((_, fa)), Some(ff)) = (fin.validation, fin.validation_floor) else {
            return Ok(fin);
        };
        let repeats = fin
            .validation_repeating
            .is_some_and(|r| material_part(opts, r.repeating_mean_square, r.noise_sigma));
        let rattle = fin.no_step_and_nothing_repeats();
        log::debug!(
            "validation after the fine search: NRMSE {fa:.4}, floor {ff:.4}; a material part repeats with the command: {repeats}; no step and nothing repeats: {rattle}"
        );
        if (fa <= opts.material_ratio * ff && !repeats) || rattle {
            return Ok(fin);
        }
        (fin, fa, ff)
    } else {
        (out, after, v_floor)
    };
    let mut all = data.to_vec();
    all.push(v.clone());
    let mut both = diagnose_records(file_params, &all, None, opts, progress, Some(&out), true)?;
    let vn = weigh_one(&both.nominal, v, opts.predictability);
    let vc = weigh_one(&both.final_fit.params, v, opts.predictability);
    both.validation = Some((
        calibrate::nrmse(&both.nominal, &vn),
        calibrate::nrmse(&both.final_fit.params, &vc),
    ));
    both.validation_floor = Some(noise::floor_nrmse(v.sigma(), &vc.weight, vc.norm));
    both.validation_in_fit = Some((after, v_floor));
    Ok(both)
}

/// What every phase of one pass shares: the records, their noise and the options.
struct Ctx<'a> {
    /// The file's parameters (stiffness in measured form, the records' sample period).
    nominal: ActuatorParams,
    /// The estimation records.
    data: &'a [Data],
    /// Noise standard deviation of each record, in its output's unit.
    sigma: Vec<f64>,
    /// The validation record, when given.
    validation: Option<&'a Data>,
    /// Its noise standard deviation.
    val_sigma: Option<f64>,
    /// Largest |voltage| of the records, V.
    max_v: f64,
    opts: &'a Options,
    /// Where each completed phase is reported ([`Ctx::trace`]).
    progress: &'a dyn Progress,
}

impl<'a> Ctx<'a> {
    /// The context of a pass over `data` (with `validation` held out, when given) from the
    /// file's parameters `file_params`.
    fn new(
        file_params: &ActuatorParams,
        data: &'a [Data],
        validation: Option<&'a Data>,
        opts: &'a Options,
        progress: &'a dyn Progress,
    ) -> Result<Ctx<'a>, HostError> {
        let first = data
            .first()
            .ok_or_else(|| HostError::input("no record to diagnose"))?;
        let mut nominal = calibrate::with_measured_stiffness(file_params)?;
        nominal.sample_period_s = first.sample_period_s;
        Ok(Ctx {
            nominal,
            data,
            sigma: data.iter().map(Data::sigma).collect(),
            validation,
            val_sigma: validation.map(Data::sigma),
            max_v: data.iter().map(Data::max_abs_v).fold(0.0, f64::max),
            opts,
            progress,
        })
    }

    /// Reports a completed phase: to the progress sink, and with the simulations run so
    /// far to the debug log (`RUST_LOG=geared_servo_host=debug`, docs/cost.md). An error
    /// when the sink asks the diagnosis to stop ([`Progress::cancelled`]).
    fn trace(&self, what: std::fmt::Arguments) -> Result<(), HostError> {
        let line = what.to_string();
        if log::log_enabled!(log::Level::Debug) {
            let (runs, rows) = calibrate::runs();
            log::debug!("{line} ({runs} runs, {:.1} M rows)", rows as f64 * 1e-6);
        }
        self.progress.stage(&line);
        if self.progress.cancelled() {
            return Err(crate::progress::cancelled(&line));
        }
        Ok(())
    }

    /// The records weighted by their predictability under `p`.
    fn weigh(&self, p: &ActuatorParams) -> Vec<Data> {
        weigh(p, self.data, self.opts.predictability)
    }

    /// The records weighted by their smoothness under `p`.
    fn weigh_smooth(&self, p: &ActuatorParams) -> Vec<Data> {
        weigh_smooth(p, self.data, self.opts.predictability)
    }

    /// [`settle`] on the records.
    fn settle(&self, start: &ActuatorParams, knobs: &[Knob], global: bool) -> (Fit, Vec<Data>) {
        settle(start, knobs, self.data, self.opts.predictability, global)
    }

    /// A global [`settle_seeded`] on the records, with the search's random stream `seed`.
    fn settle_seeded(&self, start: &ActuatorParams, knobs: &[Knob], seed: u64) -> (Fit, Vec<Data>) {
        settle_seeded(
            start,
            knobs,
            self.data,
            self.opts.predictability,
            true,
            seed,
        )
    }

    /// The floor cost of `data` (weighted estimation records).
    fn floor(&self, data: &[Data]) -> f64 {
        floor_cost(data, &self.sigma)
    }

    /// A cost `c` on `data` is material: above [`Options::material_ratio`] times the floor.
    fn material(&self, c: f64, data: &[Data]) -> bool {
        c > self.opts.material_ratio.powi(2) * self.floor(data)
    }

    /// The residual of `p` on `data` as the robust window loss sees it (each record's windows
    /// compressed as [`calibrate::Robust`] does, at the record's own noise level), over what
    /// noise alone gives there: the RMS ratio. A residual spread over the record reads as its
    /// plain ratio to the floor (a little less); one that sits in a few windows on another
    /// branch of the motion (rows the predictability assessment kept under a model a few
    /// percent off, where the unit rattles on another response) counts as some tens of noisy
    /// windows each, not as hundreds.
    fn robust_ratio(&self, p: &ActuatorParams, data: &[Data]) -> f64 {
        let rdata: Vec<Data> = data
            .iter()
            .zip(&self.sigma)
            .map(|(d, s)| d.with_robust(Some(Robust::new(*s, d.sample_period_s))))
            .collect();
        let noise = Robust::noise_share() * self.floor(data);
        if noise > 0.0 {
            (calibrate::cost(p, &rdata) / noise).sqrt()
        } else {
            f64::INFINITY
        }
    }

    /// What a residual of cost `c` on its rows `data` is: material ([`Ctx::material`]) and
    /// systematic when its robust ratio `robust` ([`Ctx::robust_ratio`]) is above
    /// [`Options::material_ratio`] as well, or when on some record the part of it that
    /// repeats with a periodic command (`repeating`, one per record) is material
    /// ([`material_part`]), or the part coherent with a stepped sine's bursts
    /// (`coherent`, one per record) is. Only a systematic residual
    /// can be *unexplained*: what exceeds the floor in a few windows alone, and neither
    /// comes back period after period nor follows the bursts' frequencies, is rattle the
    /// assessment did not catch.
    ///
    /// A residual whose repeating part (taken over every row) is the majority of its excess
    /// over the noise ([`Repeating::mostly_repeats`]) and alone would make the fit poor
    /// ([`Options::poor_ratio`]: above (2² − 1) σ²) is systematic even when the rows kept as
    /// predictable are at the floor: what comes back period after period is predictable
    /// whatever the ensembles said of those rows. The stronger line than materiality is
    /// for the rows the ensembles weighted out, where even the unit's own model leaves a
    /// residual: on the validation records of 20 units of the foreign suite, each with the
    /// tachometer, the load angle alone and the current alone (`foreign_records`), the true
    /// parameters left 1.0–2.6 σ over every row, of which at most 0.63 σ repeated, never
    /// the majority. On the current alone, motor_viscous/1, the ensembles weighted out 97 %
    /// of the square wave, the rows kept sat at the floor, and 90 % of the final model's
    /// excess repeated, at 4.3 σ (the unit's own model: 1.45 times the floor over every
    /// row).
    fn residual_kind(
        &self,
        c: f64,
        robust: f64,
        data: &[Data],
        repeating: &[Option<Repeating>],
        coherent: &[Option<Coherent>],
    ) -> ResidualKind {
        let repeats =
            |r: &Repeating| material_part(self.opts, r.repeating_mean_square, r.noise_sigma);
        let poor = |r: &Repeating| {
            part_above(self.opts.poor_ratio, r.repeating_mean_square, r.noise_sigma)
        };
        if repeating
            .iter()
            .flatten()
            .any(|r| poor(r) && r.mostly_repeats())
        {
            ResidualKind::Systematic
        } else if !self.material(c, data) {
            ResidualKind::AtFloor
        } else if robust > self.opts.material_ratio
            || repeating.iter().flatten().any(repeats)
            || coherent.iter().any(|r| {
                r.is_some_and(|r| material_part(self.opts, r.coherent_mean_square, r.noise_sigma))
            })
        {
            ResidualKind::Systematic
        } else {
            ResidualKind::FewWindows
        }
    }

    /// A fit of cost `c` on its own rows `data` is poor: above [`Options::poor_ratio`] times
    /// their floor.
    fn poor(&self, c: f64, data: &[Data]) -> bool {
        c > self.opts.poor_ratio.powi(2) * self.floor(data)
    }

    /// Whether the records can show effect `e` at all: an error of a sensor
    /// ([`Effect::sensor_column`]) only where some record has that sensor's output.
    fn shows(&self, e: Effect) -> bool {
        e.sensor_column()
            .is_none_or(|col| self.measured().contains(&col))
    }

    /// The outputs some record fits (each once, in the records' order).
    fn measured(&self) -> Vec<&str> {
        let mut out: Vec<&str> = Vec::new();
        for m in self.data.iter().flat_map(|d| d.measured()) {
            if !out.contains(&m) {
                out.push(m);
            }
        }
        out
    }

    /// The validation record weighted by its predictability under `p`.
    fn val_weighted(&self, p: &ActuatorParams) -> Option<Data> {
        self.validation
            .map(|v| weigh_one(p, v, self.opts.predictability))
    }
}

/// The starts of a search from afar (a second start of the candidates' refits, their global
/// refits): the file's values with the effects `cur` added at its values, the background
/// mesh damping ([`calibrate::BACKGROUND_DAMPING`]) once where the base calibration started
/// it (`start`) and once where the current fit took it (the two coincide when it has not
/// moved). A missing effect drags the background damping as it drags the inertias, and
/// which of the two is the better start depends on the unit: pair/13 of the foreign suite,
/// whose load's viscous friction is missing, takes it to the top of its range (1.8e-2 for
/// the unit's 2.9e-3), and a start that kept it there found the motor's viscous friction
/// where the unit has the load's; tach_lag/16 and input_delay/16 find their effect only from
/// where their current fits took it.
fn restart_points(start: &ActuatorParams, cur: &Fit) -> Vec<ActuatorParams> {
    let mut p = *start;
    for kn in cur.knobs.iter().filter(|k| !k.floor_ok) {
        if let Param::Effect(added) = kn.param {
            p.effects.set(added, cur.params.effects.get(added));
        }
    }
    let mut q = p;
    for kn in cur.knobs.iter().filter(|k| k.floor_ok) {
        if let Param::Effect(bg) = kn.param {
            q.effects.set(bg, cur.params.effects.get(bg));
        }
    }
    if q == p {
        vec![p]
    } else {
        vec![p, q]
    }
}

/// A class member swapped in for a step's effect ([`judge::swap_in_class`]): the step
/// renamed with the member's value and evidence, the replaced effect listed as told apart,
/// and the model with the member adopted with its own rows.
fn apply_swap(
    steps: &mut [Step],
    cur: &mut Fit,
    wdata: &mut Vec<Data>,
    sw: judge::Swap,
    measured: &[&str],
) {
    if let Some(st) = steps.get_mut(sw.step) {
        let k = sw
            .fit
            .knobs
            .iter()
            .position(|k| k.param == Param::Effect(sw.effect));
        st.effect = sw.effect;
        st.value = k
            .and_then(|k| sw.fit.values.get(k).copied())
            .unwrap_or(f64::NAN);
        st.std_error = k
            .and_then(|k| sw.fit.std_errors.get(k).copied())
            .unwrap_or(f64::NAN);
        st.indistinguishable_from.retain(|(e, _)| *e != sw.effect);
        st.told_apart.retain(|r| r.effect != sw.effect);
        st.separate_by = st
            .indistinguishable_from
            .first()
            .map(|(o, _)| separating_measurement(sw.effect, *o, measured))
            .unwrap_or_default();
        st.nrmse_before = sw.nrmse_before;
        st.nrmse_after = sw.nrmse_after;
        st.delta_bic = sw.delta_bic;
        st.held_out = sw.held_out;
        st.told_apart.push(sw.replaced);
    }
    adopt(cur, sw.fit);
    *wdata = sw.own;
}

/// `cur` replaced by `fit`, keeping what `cur` says of the whole calibration (its start
/// cost and how far the global search moved).
fn adopt(cur: &mut Fit, fit: Fit) {
    let (cost_start, moved) = (cur.cost_start, cur.moved);
    *cur = fit;
    cur.cost_start = cost_start;
    cur.moved = moved;
}

/// [`diagnose`] without the second pass.
fn diagnose_records(
    file_params: &ActuatorParams,
    data: &[Data],
    validation: Option<&Data>,
    opts: &Options,
    progress: &dyn Progress,
    resume: Option<&Outcome>,
    finish: bool,
) -> Result<Outcome, HostError> {
    let cx = Ctx::new(file_params, data, validation, opts, progress)?;
    let pass = if resume.is_some() {
        "second pass"
    } else {
        "pass"
    };
    cx.trace(format_args!(
        "{pass}: {} record{}, their noise levels estimated",
        data.len(),
        if data.len() == 1 { "" } else { "s" }
    ))?;
    let (nominal, max_v) = (cx.nominal, cx.max_v);
    let first = data
        .first()
        .ok_or_else(|| HostError::input("no record to diagnose"))?;
    let nominal_analysis = {
        let t = calibrate::simulate(&nominal, first)
            .ok_or_else(|| HostError::other("the file's parameters are invalid"))?;
        // Over every row: the nominal model before any row is weighted out.
        analysis_of(&first.with_weights(&[]), &t)
    };

    let mut knobs = match &opts.fit {
        None => calibrate::default_knobs_measuring(&nominal, max_v, &cx.measured()),
        Some(names) => {
            let mut ks = Vec::new();
            for param in fittable(file_params, names)? {
                ks.push(calibrate::knob(&nominal, param, max_v));
            }
            ks
        }
    };
    // The default set carries a background mesh damping when the file declares none
    // (calibrate::BACKGROUND_DAMPING: a model without any damping cannot be calibrated
    // against a rig that rattles).
    let mut start = nominal;
    if opts.fit.is_none() {
        if let Some(q) = calibrate::with_background_damping(&nominal, max_v) {
            knobs.push(calibrate::background_damping_knob(&nominal, max_v));
            start = q;
        }
    }
    // Two independent global settles, the better on the rows both keep: one search lands
    // a few percent off now and then (the patchwork is fine-grained), two rarely both do.
    // When resuming (the second pass of `diagnose`), the model found so far is settled on
    // the records from where it stands and the search goes on from there.
    let (mut cur, mut wdata, mut base, steps_so_far) = match resume {
        None => {
            let (a, b) = rayon::join(
                || settle_seeded(&start, &knobs, data, opts.predictability, true, 0),
                || settle_seeded(&start, &knobs, data, opts.predictability, true, 1),
            );
            log::debug!(
                "base: seed 0 at NRMSE {:.4} on its rows ({:.1} % of the first record weighted out), seed 1 at {:.4} ({:.1} %)",
                rms_nrmse(a.0.cost),
                100.0 * a.1.first().map_or(0.0, Data::excluded_share),
                rms_nrmse(b.0.cost),
                100.0 * b.1.first().map_or(0.0, Data::excluded_share)
            );
            let (best, wbest, _) = better_on_common(a, b, data);
            // Both may follow the friction torque's sum and miss its split: one more, local,
            // settle with the dissipation set back to the start (settle::dissipation_from_start).
            let split = dissipation_from_start(&start, &best.params, &knobs);
            let (mut again, wagain) = settle(&split, &knobs, data, opts.predictability, false);
            again.moved = best.moved;
            let (mut base, wdata, took) = better_or_nearer(
                (best, wbest),
                (again, wagain),
                data,
                &start,
                &knobs,
                &cx.sigma,
                opts.material_ratio,
            );
            log::debug!(
                "base: the settle from the start's dissipation taken: {took} (NRMSE {:.4} on its rows)",
                rms_nrmse(base.cost)
            );
            base.cost_start = calibrate::cost(&nominal, &wdata);
            (base.clone(), wdata, base, Vec::new())
        }
        Some(r) => {
            let (settled, wsettled) = cx.settle(&r.final_fit.params, &r.final_fit.knobs, false);
            // The settle re-weighs the rows under each of its points and can end far worse
            // than where it started (pair/82 of the foreign suite: the first pass's model at
            // 0.086 on its rows of both records, its settle at 0.47; tach_gain/2: 0.047 and
            // 0.56; drive_deadband/86: 0.070 and 0.40): the first pass's model stays where
            // its settle follows its own rows more than `poor_ratio` times as badly as the
            // first pass's model follows its own. Anywhere else the settle, the fit of both
            // records, is the second pass's base: the first pass's model never saw the
            // validation record, and preferring it on the rows both keep, or wherever it
            // is better on its own rows, cost two verdicts of the suite's bench draw 2
            // (tach_lag/2: the settle at 0.0238 against 0.0249, refused on the rows both
            // keep, then a spurious 1 % tachometer gain; pair/2: 0.164 against 0.127, then
            // a current pickup and a motor friction for the load's friction and the delay,
            // both found from the settle).
            let wkept = weigh(&r.final_fit.params, data, opts.predictability);
            let mut kept = r.final_fit.clone();
            kept.cost = calibrate::cost(&kept.params, &wkept);
            log::debug!(
                "second pass: the first pass's model at NRMSE {:.4} on its rows of both records, its settle at {:.4}",
                rms_nrmse(kept.cost),
                rms_nrmse(settled.cost)
            );
            let took = settled.cost <= opts.poor_ratio.powi(2) * kept.cost;
            let (mut fit, wdata) = if took {
                (settled, wsettled)
            } else {
                (kept, wkept)
            };
            log::debug!("second pass: the settle taken: {took}");
            fit.cost_start = calibrate::cost(&nominal, &wdata);
            let mut base = r.base.clone();
            base.cost = calibrate::cost(&base.params, &wdata);
            base.cost_start = fit.cost_start;
            (fit, wdata, base, r.steps.clone())
        }
    };
    base.cost_start = calibrate::cost(&nominal, &wdata);
    cx.trace(format_args!(
        "{pass}: base settled, NRMSE {:.4}",
        rms_nrmse(cur.cost)
    ))?;
    let wfirst = wdata.first().unwrap_or(first);
    let (base_analysis, _) = analyse(&base.params, wfirst)?;

    let mut steps: Vec<Step> = steps_so_far;
    // With the validation record now fitted too, an effect put first in its class may be
    // told apart from another member (judge::swap_in_class).
    if resume.is_some() {
        let (swap, rejoin) = judge::swap_in_class(
            &cx,
            &cur,
            &wdata,
            &steps,
            "once the validation record was fitted too",
        );
        for (si, effect, value) in rejoin {
            if let Some(st) = steps.get_mut(si) {
                st.told_apart.retain(|r| r.effect != effect);
                st.indistinguishable_from.push((effect, value));
                if st.separate_by.is_empty() {
                    st.separate_by = separating_measurement(st.effect, effect, &first.measured());
                }
            }
        }
        if let Some(sw) = swap {
            apply_swap(&mut steps, &mut cur, &mut wdata, sw, &first.measured());
        }
    }
    let mut last_scores = Vec::new();
    let mut rejected: Vec<Rejection> = Vec::new();
    let mut resettled = false;
    let mut provisional: Option<Provisional> = None;
    let mut provisional_used = false;
    let mut stand_in_swapped = false;
    let mut reviewed = false;
    // A provisional step refuted goes back out, with the reason.
    let mut taken_back: Option<Rejection> = None;
    // A backward step takes a step back out, so the steps alone do not bound the rounds
    // (an effect removed could be added again): at most twice as many rounds as steps.
    let mut rounds = 0;
    'search: loop {
        while steps.len() < opts.max_steps
            && rounds < 2 * opts.max_steps + 2
            && (cx.material(cur.cost, &wdata)
                || (rounds == 0 && calibrate::background_at_top(&cur)))
        {
            // Below the material line the one candidate is the damping the fit took to the
            // top of its background range (the report says so as well): on the foreign
            // suite's mesh_damping/1 and /2 stripped to the current, the background stopped
            // at 2e-2 for the unit's 7.7e-2 with the fit at 1.12 and 1.15 times its floor,
            // and nothing was tried.
            let damping_only = !cx.material(cur.cost, &wdata);
            rounds += 1;
            // The rows a search from afar can use, under the current fit: a candidate's refit
            // searches there and is polished and judged on the fine rows.
            let sdata = cx.weigh_smooth(&cur.params);
            let rdata = calibrate::robust(&sdata);
            let rows = search::Rows {
                robust: &rdata,
                smooth: &sdata,
                fine: &wdata,
            };
            // A candidate must beat the model without it refitted the same way (the search is
            // stochastic: a refit that merely finds a better point of the base set must not be
            // credited to an effect).
            // Taken when better, unless it runs a knob into a bound the model is not at (on
            // the real record the background damping went to its top): a better point of
            // the base set that bends it is not a calibration (the rule of fine_search and
            // of a step, judge).
            let null = search::null_refit(&cur, &rows);
            if null.cost < cur.cost && calibrate::new_bounds(&cur, &null).is_empty() {
                adopt(&mut cur, null);
            }
            cx.trace(format_args!(
                "{pass}, round {rounds}: rows weighed, null refit"
            ))?;
            // An effect the model does not have yet, or one it carries only as a bounded
            // background (the mesh damping): its whole range is the candidate.
            let background = |c: Effect| {
                cur.knobs
                    .iter()
                    .any(|k| k.param == Param::Effect(c) && k.floor_ok)
            };
            let cands: Vec<(Effect, Knob)> = opts
                .candidates
                .iter()
                .filter(|&&c| cx.shows(c))
                .filter(|&&c| !damping_only || background(c))
                .filter(|&&c| cur.params.effects.get(c) == 0.0 || background(c))
                .map(|&c| (c, calibrate::knob(&cur.params, Param::Effect(c), max_v)))
                .collect();
            if cands.is_empty() {
                break;
            }
            let scores = search::score(&cur, &cands, &wdata, max_v);
            cx.trace(format_args!(
                "{pass}, round {rounds}: {} candidates scored",
                cands.len()
            ))?;
            let score_list: Vec<(Effect, f64, f64)> = scores
                .iter()
                .map(|(e, _, c, v)| (*e, rms_nrmse(*c), *v))
                .collect();
            last_scores = score_list.clone();
            let cur_poor = cx.poor(cur.cost, &wdata);
            // The scores are a linear projection around the current fit. Where even the best
            // explains less than `SCREEN_SHARE` of the cost above the floor, they cannot rank
            // the candidates (an effect that the calibrated quantities absorbed projects onto
            // their span: tach_gain/43 of the foreign suite, a −9.5 % gain taken up by the
            // inertias and the load friction, scored eleventh of thirteen and refitted first of
            // all), and every candidate is refitted locally.
            let floor_c = cx.floor(&wdata);
            let screen_weak = scores
                .first()
                .is_some_and(|s| cur.cost - s.2 < SCREEN_SHARE * (cur.cost - floor_c));
            let take = if cur_poor || screen_weak {
                scores.len()
            } else {
                opts.refit_top
            };
            let top: Vec<Effect> = scores.iter().take(take).map(|x| x.0).collect();
            let refitted: Vec<&(Effect, Knob, f64, f64)> = scores
                .iter()
                .filter(|x| top.contains(&x.0) || top.iter().any(|&t| kin(t).contains(&x.0)))
                .collect();
            // The file's values with the effects added so far: a second start when a missing
            // effect has dragged the current fit off (to a bound, or far above the floor).
            let from_file = restart_points(&start, &cur);
            let starts: Vec<ActuatorParams> = if cur_poor || !calibrate::at_bounds(&cur).is_empty()
            {
                std::iter::once(cur.params)
                    .chain(from_file.iter().copied())
                    .collect()
            } else {
                vec![cur.params]
            };
            let mut local = search::local_refits(&cx, &cur, &refitted, &starts, &rows);
            cx.trace(format_args!(
                "{pass}, round {rounds}: {} local refits from {} starts",
                local.len(),
                starts.len()
            ))?;
            search::kin_starts(&cx, &cur, &mut local, &rows);
            cx.trace(format_args!("{pass}, round {rounds}: kin starts"))?;
            let mut alts = search::structural_refits(&cx, &local, cur_poor, &from_file, &rows);
            cx.trace(format_args!(
                "{pass}, round {rounds}: {} global settles",
                alts.iter().map(Vec::len).sum::<usize>()
            ))?;
            let mirrors = search::mirror_points(&cur, &local, &alts, &rows);
            cx.trace(format_args!("{pass}, round {rounds}: mirror points"))?;
            // A kin's mirror is judged as one more refit of the candidate.
            for (a, m) in alts.iter_mut().zip(mirrors) {
                a.extend(m);
            }
            let judged = judge::judge(&cx, &cur, &wdata, local, alts);
            cx.trace(format_args!("{pass}, round {rounds}: judged"))?;
            if log::log_enabled!(log::Level::Debug) {
                for j in &judged {
                    log::debug!("  {}", j.summary());
                }
            }
            let class = judge::with_kin_on_best_rows(
                &judged,
                opts,
                judge::with_plausible_kin(&cx, &cur, &judged, judge::class(&judged, opts)),
            );
            let mut acc = judge::accept(&cx, &cur, &judged, &class, &mut rejected, true);
            if acc.is_none() {
                for j in judged.iter().filter(|j| j.admissible.is_err()) {
                    rejected.push(Rejection {
                        effect: j.effect,
                        value: j.value,
                        nrmse_after: rms_nrmse(j.fit.cost),
                        reason: j.admissible.clone().err().unwrap_or_default(),
                    });
                }
                rejected.sort_by(|a, b| a.nrmse_after.total_cmp(&b.nrmse_after));
                // Before giving up, once per search: the best candidate that holds on the
                // estimation record's held-out segments, though the validation record refused
                // it, taken provisionally ([`Provisional`]) — first, from the model that refused
                // it (from a resettled one the next effect can fall short where it would not).
                if !provisional_used && cx.validation.is_some() {
                    let mut ignored = Vec::new();
                    acc = judge::accept(&cx, &cur, &judged, &class, &mut ignored, false);
                    if let Some(j) = acc.as_ref().and_then(|a| judged.get(a.index)) {
                        provisional_used = true;
                        provisional = Some(Provisional {
                            taken: Rejection {
                                effect: j.effect,
                                value: j.value,
                                nrmse_after: rms_nrmse(j.fit.cost),
                                reason: String::new(),
                            },
                            cur: cur.clone(),
                            wdata: wdata.clone(),
                            steps: steps.clone(),
                            rejected: rejected.clone(),
                            last_scores: last_scores.clone(),
                            resettled,
                            rounds,
                            steps_after: 0,
                        });
                    }
                }
                // A step taken earlier was a stand-in when a member of its class, refitted
                // now, needs that step's effect at its bound (voltage_limit/59 of the foreign
                // suite: a motor friction taken first with the limit in its class; once in, the
                // limit's refit, 7.204 V for the unit's 7.256 V, needed the friction at 0 and
                // was refused): that refit, with the step's effect set back to the file's
                // value, is tried in the step's place ([`judge::swap_stand_in`]: its own rows
                // read by the robust loss), once per pass.
                if acc.is_none() && !stand_in_swapped {
                    let pair = judged
                        .iter()
                        .filter(|j| j.admissible.is_err())
                        .find_map(|j| {
                            let bounds = calibrate::at_bounds(&j.fit);
                            let si = steps.iter().position(|st| {
                                st.indistinguishable_from
                                    .iter()
                                    .any(|(e, _)| *e == j.effect)
                                    && j.fit.knobs.iter().any(|k| {
                                        k.param == Param::Effect(st.effect)
                                            && bounds.iter().any(|b| b == k.name())
                                    })
                            })?;
                            Some((si, j))
                        });
                    if let Some((si, j)) = pair {
                        stand_in_swapped = true;
                        let swap =
                            judge::swap_stand_in(&cx, &cur, &wdata, &steps, si, &j.fit, j.effect);
                        if let Some(sw) = swap {
                            apply_swap(&mut steps, &mut cur, &mut wdata, sw, &first.measured());
                            rejected.clear();
                            cx.trace(format_args!(
                                "{pass}, round {rounds}: a stand-in step swapped for its class member"
                            ))?;
                            continue;
                        }
                    }
                }
                if acc.is_none() {
                    // Before giving up, settle the current model once more from where it is,
                    // globally ([`resettle`]).
                    let moved = resettle_once(
                        &cx,
                        data,
                        &mut resettled,
                        &mut cur,
                        &mut wdata,
                        &mut rejected,
                    );
                    cx.trace(format_args!(
                        "{pass}, round {rounds}: nothing taken, resettled"
                    ))?;
                    if moved {
                        continue;
                    }
                    break;
                }
            }
            let Some(acc) = acc else { break };
            if let Some(pv) = provisional.as_mut() {
                pv.steps_after += 1;
            }
            rejected.clear();
            let (i, ho) = (acc.index, acc.held_out);
            let Some(chosen) = judged.get(i) else { break };
            // The class less the members the validation record told apart from the choice.
            let others: Vec<(Effect, f64)> = class
                .iter()
                .filter(|&&x| x != i && !acc.told_apart.iter().any(|t| t.0 == x))
                .filter_map(|&x| judged.get(x).map(|j| (j.effect, j.value)))
                .collect();
            let separate_by = others
                .first()
                .map(|(o, _)| separating_measurement(chosen.effect, *o, &first.measured()))
                .unwrap_or_default();
            // The effect can change where the model is predictable (mesh damping calms rattle):
            // settle again, locally.
            let (fit, w) = cx.settle(&chosen.fit.params, &chosen.fit.knobs, true);
            let (fit, w, _) =
                better_on_common((chosen.fit.clone(), chosen.own.clone()), (fit, w), data);
            // Before and after on the rows both models keep (each model's own rows differ: the
            // two numbers on different rows can even read as a step backwards).
            let both = common_rows(data, &wdata, &w);
            let nrmse_before = rms_nrmse(calibrate::cost(&cur.params, &both));
            let nrmse_after_step = rms_nrmse(calibrate::cost(&fit.params, &both));
            wdata = w;
            let idx = fit.knobs.len() - 1;
            steps.push(Step {
                effect: chosen.effect,
                value: fit.values.get(idx).copied().unwrap_or(f64::NAN),
                std_error: fit.std_errors.get(idx).copied().unwrap_or(f64::NAN),
                nrmse_before,
                nrmse_after: nrmse_after_step,
                delta_bic: chosen.delta_bic,
                scores: score_list,
                partial: false,
                indistinguishable_from: others,
                separate_by,
                held_out: ho,
                told_apart: acc.told_apart.into_iter().map(|t| t.1).collect(),
            });
            cur = fit;
            cx.trace(format_args!(
                "{pass}, round {rounds}: {} added and settled",
                chosen.effect.name()
            ))?;
            if let Some(r) = judge::backward_step(&cx, &cur, &wdata, &steps, chosen.effect) {
                remove_step(r, &mut steps, &mut rejected, &mut cur, &mut wdata);
            }
        }
        // A provisional step refuted goes back out, and the search resumes where it was taken,
        // as though it had not been: the resettle next.
        if let Some(pv) = provisional.take() {
            if let Some(why) = pv.refuted(&cx, &cur) {
                cur = pv.cur;
                wdata = pv.wdata;
                steps = pv.steps;
                rejected = pv.rejected;
                last_scores = pv.last_scores;
                resettled = pv.resettled;
                rounds = pv.rounds;
                taken_back = Some(Rejection {
                    reason: why,
                    ..pv.taken
                });
                if resettle_once(
                    &cx,
                    data,
                    &mut resettled,
                    &mut cur,
                    &mut wdata,
                    &mut rejected,
                ) {
                    continue 'search;
                }
            }
        }
        // Once per pass, every step is tested again as the backward step tests the earlier
        // ones, the last included, against the model it ended in ([`judge::backward_review`]);
        // one that goes is reported with the reason, and the search goes on from the model
        // without it when that leaves a material residual.
        if !reviewed {
            reviewed = true;
            if let Some(r) = judge::backward_review(&cx, &cur, &wdata, &steps) {
                let st = remove_step(r, &mut steps, &mut rejected, &mut cur, &mut wdata);
                cx.trace(format_args!(
                    "{pass}: {} removed in the review at the end",
                    st.effect.name()
                ))?;
                continue 'search;
            }
        }
        break;
    }
    if let Some(t) = taken_back {
        rejected.insert(0, t);
    }
    if finish {
        if let Some((fit, w)) = fine_search(&cx, &cur, &wdata)? {
            adopt(&mut cur, fit);
            wdata = w;
        }
    }
    conclude(
        &cx,
        Found {
            nominal_analysis,
            base,
            base_analysis,
            steps,
            cur,
            wdata,
            last_scores,
            rejected,
        },
    )
}

/// The sine bursts of record `d` with the parts of the residual `e` of `p` coherent with
/// them ([`crate::repeat::burst_parts`], noise standard deviation `sigma`), each mostly
/// coherent burst marked when `p` reaches the unit's response there from another rest
/// position of the gears ([`predictability::restart_reaches`]).
fn coherent_parts(
    p: &ActuatorParams,
    d: &Data,
    e: &[f64],
    sigma: f64,
) -> Vec<crate::repeat::BurstPart> {
    let mut parts = crate::repeat::burst_parts(&d.volts, e, d.sample_period_s, sigma);
    let spans: Vec<(usize, usize)> = parts
        .iter()
        .filter(|b| b.mostly_coherent)
        .map(|b| (b.start, b.end))
        .collect();
    let reached = predictability::restart_reaches(p, d, e, &spans, sigma);
    for (b, r) in parts.iter_mut().filter(|b| b.mostly_coherent).zip(reached) {
        b.other_response = r;
    }
    parts
}

/// A part of a residual (the part that repeats with the command, or the part coherent with
/// a stepped sine's bursts), of mean square `part_ms` over the record, is material: alone it
/// would take the NRMSE above [`Options::material_ratio`] times the floor (its mean square
/// above (ratio² − 1) σ², σ the record's noise standard deviation `sigma`).
fn material_part(opts: &Options, part_ms: f64, sigma: f64) -> bool {
    part_above(opts.material_ratio, part_ms, sigma)
}

/// A part of a residual of mean square `part_ms` would alone take the NRMSE above `ratio`
/// times the floor: its mean square above (ratio² − 1) σ², σ the record's noise standard
/// deviation `sigma`.
pub(crate) fn part_above(ratio: f64, part_ms: f64, sigma: f64) -> bool {
    part_ms > (ratio.powi(2) - 1.0) * sigma.powi(2)
}

/// The residual of `p` on every row of `d`; `None` when the model cannot be run on it.
fn residual_of(p: &ActuatorParams, d: &Data) -> Option<Vec<f64>> {
    let t = calibrate::simulate(p, d)?;
    Some(d.y.iter().zip(&t.y).map(|(a, b)| a - b).collect())
}

/// Takes the step of `r` out: reported among the candidates not added with the reason, the
/// model without it (`r.without`, on its rows `r.own`) the current one. Returns the step.
fn remove_step(
    r: judge::Removal,
    steps: &mut Vec<Step>,
    rejected: &mut Vec<Rejection>,
    cur: &mut Fit,
    wdata: &mut Vec<Data>,
) -> Step {
    let st = steps.remove(r.step);
    rejected.push(Rejection {
        effect: st.effect,
        value: st.value,
        nrmse_after: rms_nrmse(r.without.cost),
        reason: r.why,
    });
    adopt(cur, r.without);
    *wdata = r.own;
    st
}

/// Settle the current model `cur` (on its rows `wdata`) once more from where it is,
/// globally, before the search gives up: a base bent by a missing effect can sit in a basin
/// from which no single candidate's refit climbs out, and a better basin changes what the
/// candidates see. The settled model with its rows when it is better, else `None`.
fn resettle(cx: &Ctx, cur: &Fit, wdata: &[Data], data: &[Data]) -> Option<(Fit, Vec<Data>)> {
    let (g, w) = cx.settle(&cur.params, &cur.knobs, true);
    // Nor one that runs a knob into a bound the model is not at (the rule of the null
    // refit, of fine_search and of a step).
    if !calibrate::new_bounds(cur, &g).is_empty() {
        log::debug!("  resettle: a knob at a new bound");
        return None;
    }
    log::debug!(
        "  resettle: the current model at {:.3}x its rows' floor, the settle at {:.3}x its own",
        (cur.cost / cx.floor(wdata)).sqrt(),
        (g.cost / cx.floor(&w)).sqrt()
    );
    // A model that misses its own predictable rows grossly (NRMSE above `poor_ratio` times
    // their floor) where the settle from it follows its own is stuck: the rows both keep
    // leave out the very rows it misses, and it can win there (second_mode/1 of the foreign
    // suite before 56b2285, second pass: 0.23 on its own rows, 0.029 against 0.033 on the
    // rows both keep; second_mode/82 until the second pass kept the first pass's model where
    // its settle is worse (fd956fc): 3.35x its rows' floor, the settle 1.63x, the diagnosis
    // ending at 1.69x the floor with the rule and 4.3x without; since then it is never
    // stuck there, and the rule has no witness).
    // Only here, where the incumbent has come through a search that found nothing: between
    // the two fresh base settles the same rule picked the wrong basin (tach_gain/1, whose
    // seed at 2.7 times the floor on its own rows is the right one). (Each fit's cost is its
    // plain cost on its own rows.)
    if cx.poor(cur.cost, wdata) && !cx.poor(g.cost, &w) {
        return Some((g, w));
    }
    let (c2, w2, better) = better_on_common((cur.clone(), wdata.to_vec()), (g, w), data);
    log::debug!("  resettle: the settle better on the rows both keep: {better}");
    better.then_some((c2, w2))
}

/// The search's one [`resettle`]: unless it has run already (`resettled`), it runs, and a
/// better model it finds replaces `cur` with its rows `wdata` (the round's `rejected`
/// cleared: the next round judges afresh). Whether the search goes on from a new model.
fn resettle_once(
    cx: &Ctx,
    data: &[Data],
    resettled: &mut bool,
    cur: &mut Fit,
    wdata: &mut Vec<Data>,
    rejected: &mut Vec<Rejection>,
) -> bool {
    if std::mem::replace(resettled, true) {
        return false;
    }
    let Some((fit, w)) = resettle(cx, cur, wdata, data) else {
        return false;
    };
    adopt(cur, fit);
    *wdata = w;
    rejected.clear();
    true
}

/// A step the search took against the validation record's refusal, and the state to return
/// to. When the search would stop with a material residual and the best candidate holds on
/// the estimation record's held-out segments but is worse on the validation record, the
/// refusal may be the second missing effect's doing: the validation record carries it too,
/// and a base calibrated without both can be a stand-in (load inertia −28 to −96 %, a
/// friction ×7–×10 on the foreign suite's pair/12–14) on which the right first effect makes
/// the validation record worse (pair/12: input_delay at the unit's value, validation NRMSE
/// 0.26 → 0.38; with load_viscous added after it, 0.022 at the floor 0.020). The step is
/// taken once per search, from the model that refused it, before the search settles that
/// model once more ([`resettle`]: from the resettled model the second effect fell short of
/// the materiality rule on pair/12), and kept only when at least one more step follows it
/// and the validation record then agrees ([`Provisional::refuted`]); otherwise the search
/// returns to where the step was taken and goes on as though it had not been.
struct Provisional {
    /// The step taken, as it is reported when it goes back out.
    taken: Rejection,
    cur: Fit,
    wdata: Vec<Data>,
    steps: Vec<Step>,
    rejected: Vec<Rejection>,
    last_scores: Vec<(Effect, f64, f64)>,
    resettled: bool,
    rounds: usize,
    /// Steps taken since (the provisional one included).
    steps_after: usize,
}

impl Provisional {
    /// Why the provisional steps go back out, or `None` when they stand: they stand when a
    /// step followed the provisional one and the model reached explains at least
    /// [`Options::min_excess_share`] of the validation error above its floor that the
    /// model before them left (on the rows both keep).
    fn refuted(&self, cx: &Ctx, now: &Fit) -> Option<String> {
        let judged = judge::on_validation(
            cx,
            cx.val_weighted(&self.cur.params).as_ref(),
            cx.val_weighted(&now.params).as_ref(),
            &self.cur.params,
            &now.params,
        );
        let share = judged.map(|(a, b, f)| validation_share(a, b, f));
        match share {
            Some(s) if self.steps_after >= 2 && s >= cx.opts.min_excess_share => None,
            Some(s) => Some(format!(
                "held on the estimation record's held-out segments but was worse on the validation record; taken provisionally, with {} step(s) after it the validation record's error above its floor was {:.0} % explained (needs {:.0} % and a second step): taken back out",
                self.steps_after.saturating_sub(1),
                100.0 * s,
                100.0 * cx.opts.min_excess_share
            )),
            None => Some("taken provisionally without a validation record".to_string()),
        }
    }
}

/// The share of the validation error above its floor `f` that a model at NRMSE `b`
/// explains against one at `a` (0 when `a` is at the floor or below it).
fn validation_share(a: f64, b: f64, f: f64) -> f64 {
    let (ea, eb) = (a * a - f * f, (b * b - f * f).max(0.0));
    if ea > 0.0 {
        1.0 - eb / ea
    } else {
        0.0
    }
}

/// What a pass found, before it is concluded ([`conclude`]).
struct Found {
    nominal_analysis: Analysis,
    base: Fit,
    base_analysis: Analysis,
    steps: Vec<Step>,
    /// The model found, and the records weighted by its predictability.
    cur: Fit,
    wdata: Vec<Data>,
    last_scores: Vec<(Effect, f64, f64)>,
    rejected: Vec<Rejection>,
}

/// The last step of a diagnosis: a search at the scale of the calibration's own precision on
/// the rows the model is polished, judged and reported on ([`settle::fine_search`]), kept
/// when it is better on the rows both keep ([`better_on_common`]) and needs no knob at a
/// bound ([`calibrate::at_bounds`]) that `cur` is not at. A search at that scale refines the
/// model; one that runs a knob into its bound is following what the model lacks (the real
/// record's creep took the background damping to its top), and a step that does so is
/// refused for the same reason ([`judge`]). Returns the better fit with its own rows, or
/// `None` when the model stands.
fn fine_search(cx: &Ctx, cur: &Fit, wdata: &[Data]) -> Result<Option<(Fit, Vec<Data>)>, HostError> {
    let found = settle::fine_search(cur, wdata, cx.data, cx.opts.predictability);
    cx.trace(format_args!("fine search"))?;
    let Some(found) = found else {
        return Ok(None);
    };
    let new = calibrate::new_bounds(cur, &found.0);
    if !new.is_empty() {
        log::debug!("fine search: not taken, it needs {new:?} at a bound");
        return Ok(None);
    }
    let (fit, w, better) = better_on_common((cur.clone(), wdata.to_vec()), found, cx.data);
    Ok(better.then_some((fit, w)))
}

/// [`diagnose`]'s outcome when the validation record leaves no material residual (no second
/// pass): the first pass' outcome `out`, with its model finished ([`fine_search`]).
fn finished(
    file_params: &ActuatorParams,
    data: &[Data],
    validation: Option<&Data>,
    opts: &Options,
    progress: &dyn Progress,
    out: Outcome,
) -> Result<Outcome, HostError> {
    let cx = Ctx::new(file_params, data, validation, opts, progress)?;
    let wdata: Vec<Data> = data
        .iter()
        .zip(&out.weights)
        .map(|(d, w)| d.with_weights(w))
        .collect();
    let Some((fit, w)) = fine_search(&cx, &out.final_fit, &wdata)? else {
        return Ok(out);
    };
    let mut cur = out.final_fit;
    adopt(&mut cur, fit);
    conclude(
        &cx,
        Found {
            nominal_analysis: out.nominal_analysis,
            base: out.base,
            base_analysis: out.base_analysis,
            steps: out.steps,
            cur,
            wdata: w,
            last_scores: out.last_scores,
            rejected: out.rejected,
        },
    )
}

/// The outcome of a pass: the final analysis and verdict of the model found.
fn conclude(cx: &Ctx, found: Found) -> Result<Outcome, HostError> {
    let Found {
        nominal_analysis,
        base,
        base_analysis,
        mut steps,
        cur,
        wdata,
        last_scores,
        rejected,
    } = found;
    let (nominal, opts) = (cx.nominal, cx.opts);
    let first = cx
        .data
        .first()
        .ok_or_else(|| HostError::input("no record to diagnose"))?;
    let wfirst = wdata.first().unwrap_or(first);
    let (final_analysis, final_trace) = analyse(&cur.params, wfirst)?;
    let robust_ratio = cx.robust_ratio(&cur.params, &wdata);
    // A residual in a few windows is excused as rattle unless it comes back in every
    // period of a periodic command (crate::repeat): rattle does not repeat, a response the
    // model lacks does.
    // Nor unless, on a stepped sine, it follows the bursts' frequencies where it is large
    // (crate::repeat::coherent): rattle is chaotic at any frequency — unless the model
    // reaches the unit's response there from another rest position of the gears
    // (coherent_parts): the other of two coexisting responses.
    // The noise level of each record is the one Ctx estimated.
    let (repeating, coherent): (Vec<Option<Repeating>>, Vec<Option<Coherent>>) = wdata
        .iter()
        .zip(&cx.sigma)
        .map(|(d, &s)| match residual_of(&cur.params, d) {
            Some(e) => (
                crate::repeat::repeating(&d.volts, &e, &[], d.sample_period_s, s),
                Coherent::of(&coherent_parts(&cur.params, d, &e, s), &e, s),
            ),
            None => (None, None),
        })
        .unzip();
    let residual = cx.residual_kind(cur.cost, robust_ratio, &wdata, &repeating, &coherent);
    let unexplained = residual == ResidualKind::Systematic;
    for st in &mut steps {
        st.partial = unexplained;
    }
    let (validation, validation_floor) = match (
        cx.val_weighted(&cur.params),
        cx.val_weighted(&nominal),
        cx.val_sigma,
    ) {
        (Some(vc), Some(vn), Some(vs)) => (
            Some((
                calibrate::nrmse(&nominal, &vn),
                calibrate::nrmse(&cur.params, &vc),
            )),
            Some(noise::floor_nrmse(vs, &vc.weight, vc.norm)),
        ),
        _ => (None, None),
    };
    let unpredictable_rms = {
        let pick = |src: &[f64]| -> Vec<f64> {
            src.iter()
                .zip(&wfirst.weight)
                .filter(|(_, w)| **w < 0.5)
                .map(|(v, _)| *v)
                .collect()
        };
        let (a, b) = (pick(&wfirst.y), pick(&final_trace.y));
        let rms = |x: &[f64]| (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt();
        (!a.is_empty()).then(|| (rms(&a), rms(&b)))
    };
    let unpredictable_spans = predictability::span_levels(
        &wfirst.y,
        &final_trace.y,
        &wfirst.weight,
        cx.sigma.first().copied().unwrap_or(0.0),
        wfirst.sample_period_s,
    );
    Ok(Outcome {
        nominal,
        nominal_analysis,
        base_analysis,
        base,
        steps,
        unexplained,
        final_analysis,
        final_nrmse_all_rows: calibrate::nrmse(&cur.params, first),
        floor_nrmse: rms_nrmse(first_floor_cost(&wdata, &cx.sigma)),
        floor_cost: cx.floor(&wdata),
        fitted_outputs: wdata
            .iter()
            .map(|d| d.columns().iter().map(|c| c.to_string()).collect())
            .collect(),
        unseen: opts
            .candidates
            .iter()
            .copied()
            .filter(|&c| !cx.shows(c))
            .collect(),
        robust_floor_ratio: robust_ratio,
        residual,
        material_ratio: opts.material_ratio,
        bic_threshold: opts.bic_threshold,
        unpredictable_share: wdata.iter().map(Data::excluded_share).collect(),
        weights: wdata.iter().map(|d| d.weight.clone()).collect(),
        noise_sigma: cx.sigma.clone(),
        unpredictable_rms,
        unpredictable_spans,
        validation_repeating: cx.validation.zip(cx.val_sigma).and_then(|(v, s)| {
            let e = residual_of(&cur.params, v)?;
            crate::repeat::repeating(&v.volts, &e, &[], v.sample_period_s, s)
        }),
        repeating,
        coherent,
        final_fit: cur,
        validation,
        validation_floor,
        validation_in_fit: None,
        last_scores,
        rejected,
        limits: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::tests::data_of;
    use geared_servo::REFERENCE;

    /// [`options_by_name`]: the names a front end takes become the options, `limits` naming
    /// none bounds every candidate, and a bad name is a one-line error that names the option
    /// as the front end spells it.
    #[test]
    fn options_by_name_checks_each_name_and_names_the_option_in_its_error() {
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let c = names(&["load_viscous", "input_delay"]);
        let o = options_by_name(&REFERENCE, 2, Some(&c), Some(&[]), None, "--").unwrap();
        assert_eq!(o.max_steps, 2);
        assert_eq!(o.candidates, vec![Effect::LoadViscous, Effect::InputDelay]);
        assert_eq!(o.limits, o.candidates);
        let o = options_by_name(&REFERENCE, 3, None, None, None, "").unwrap();
        assert_eq!(o.candidates, Effect::ALL.to_vec());
        assert!(o.limits.is_empty() && o.fit.is_none());
        let o =
            options_by_name(&REFERENCE, 3, None, Some(&names(&["tach_gain"])), None, "").unwrap();
        assert_eq!(o.limits, vec![Effect::TachGain]);
        let fit = names(&["load.inertia_kg_m2"]);
        let o = options_by_name(&REFERENCE, 3, None, None, Some(&fit), "").unwrap();
        assert_eq!(o.fit, Some(fit));
        let bad = names(&["nope"]);
        let e = options_by_name(&REFERENCE, 3, Some(&bad), None, None, "--").unwrap_err();
        assert!(e.message.starts_with("--candidates: "), "{}", e.message);
        assert!(e.message.contains("nope") && !e.message.contains('\n'));
        let e = options_by_name(&REFERENCE, 3, None, Some(&bad), None, "").unwrap_err();
        assert!(e.message.starts_with("limits: "), "{}", e.message);
        let e = options_by_name(&REFERENCE, 3, None, None, Some(&bad), "--").unwrap_err();
        assert!(e.message.starts_with("--fit: "), "{}", e.message);
    }

    /// [`restart_points`]: the base set at the base calibration's start, whatever the current
    /// fit made of it; the background damping once there and once where the current fit
    /// took it; an effect added (the mesh damping too, once added as an effect on its full
    /// range) at the current fit's value, in one start only then.
    #[test]
    fn a_restart_from_the_file_keeps_the_effects_added_and_tries_the_background_both_ways() {
        let file = calibrate::with_measured_stiffness(&REFERENCE).unwrap();
        let start = calibrate::with_background_damping(&file, 5.0).unwrap();
        let bg = calibrate::background_damping_knob(&file, 5.0);
        let md = Param::Effect(Effect::MeshDamping);
        let delay = calibrate::knob(&file, Param::Effect(Effect::InputDelay), 5.0);
        let mut p = start;
        p.load.inertia_kg_m2 *= 1.4;
        calibrate::set(&mut p, md, bg.hi);
        calibrate::set(&mut p, Param::Effect(Effect::InputDelay), 1e-3);
        let fit = |knobs: Vec<Knob>, p: ActuatorParams| Fit {
            params: p,
            values: vec![0.0; knobs.len()],
            std_errors: vec![0.0; knobs.len()],
            knobs,
            correlations: Vec::new(),
            cost_start: 1.0,
            cost: 1.0,
            moved: 0.0,
            evaluations: 0,
        };
        let load = calibrate::knob(&file, Param::LoadInertia, 5.0);
        let cur = fit(vec![load.clone(), bg.clone(), delay.clone()], p);
        let r = restart_points(&start, &cur);
        assert_eq!(r.len(), 2);
        assert!(start.effects.mesh_damping < bg.hi);
        for q in &r {
            assert_eq!(q.load.inertia_kg_m2, start.load.inertia_kg_m2);
            assert_eq!(q.effects.input_delay, 1e-3);
        }
        assert_eq!(r[0].effects.mesh_damping, start.effects.mesh_damping);
        assert_eq!(r[1].effects.mesh_damping, bg.hi);
        // Where the background has not moved, one start.
        let mut still = p;
        still.effects.mesh_damping = start.effects.mesh_damping;
        let cur = fit(vec![load.clone(), bg.clone(), delay.clone()], still);
        assert_eq!(restart_points(&start, &cur).len(), 1);
        // The mesh damping added as an effect is carried like any other.
        let full = calibrate::knob(&file, md, 5.0);
        let cur = fit(vec![load, full, delay], p);
        let r = restart_points(&start, &cur);
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].effects.mesh_damping, bg.hi);
    }

    /// [`calibrate::new_bounds`], the rule of the resettle, the null refit and the fine
    /// search: the knobs a refit takes to a bound the model before it was not at. The
    /// background damping at its top counts (the real record's resettle took it there), at
    /// its floor it does not (a gear train may have almost none); a bound already held is
    /// not new.
    #[test]
    fn a_refit_is_known_by_the_bounds_it_runs_into() {
        let file = calibrate::with_measured_stiffness(&REFERENCE).unwrap();
        let load = calibrate::knob(&file, Param::LoadInertia, 5.0);
        let bg = calibrate::background_damping_knob(&file, 5.0);
        let fit = |values: Vec<f64>| Fit {
            params: file,
            std_errors: vec![0.0; values.len()],
            values,
            knobs: vec![load.clone(), bg.clone()],
            correlations: Vec::new(),
            cost_start: 1.0,
            cost: 1.0,
            moved: 0.0,
            evaluations: 0,
        };
        let inside = fit(vec![file.load.inertia_kg_m2, (bg.lo * bg.hi).sqrt()]);
        let top = fit(vec![load.hi, bg.hi]);
        let floor = fit(vec![load.lo, bg.lo]);
        let names = |ks: &[&Knob]| ks.iter().map(|k| k.name().to_string()).collect::<Vec<_>>();
        assert!(calibrate::new_bounds(&inside, &inside).is_empty());
        assert_eq!(calibrate::new_bounds(&inside, &top), names(&[&load, &bg]));
        assert!(calibrate::new_bounds(&top, &top).is_empty());
        assert_eq!(calibrate::new_bounds(&inside, &floor), names(&[&load]));
        assert!(calibrate::new_bounds(&top, &inside).is_empty());
    }

    /// [`Provisional::refuted`]'s measure: pair/12 of the foreign suite, validation NRMSE
    /// 0.26 before the provisional step and 0.022 after the second at a floor of 0.020, is
    /// all but fully explained; a model worse than the one before, or one already at the
    /// floor, explains nothing.
    #[test]
    fn the_validation_share_counts_only_what_lies_above_the_floor() {
        let s = validation_share(0.26, 0.022, 0.020);
        assert!(s > 0.99 && s < 1.0, "{s}");
        assert!(validation_share(0.26, 0.02, 0.02) == 1.0);
        assert!(validation_share(0.26, 0.30, 0.02) < 0.0);
        assert!(validation_share(0.02, 0.01, 0.02) == 0.0);
        // 0.26 -> 0.22: (0.0676 - 0.0484) / 0.0672 of the excess, under the 30 % rule.
        let s = validation_share(0.26, 0.22, 0.02);
        assert!(s > 0.28 && s < 0.29, "{s}");
    }

    /// A step that added `effect` at `value`, with neither class nor numbers.
    pub(super) fn bare_step(effect: Effect, value: f64) -> Step {
        Step {
            effect,
            value,
            std_error: f64::NAN,
            nrmse_before: f64::NAN,
            nrmse_after: f64::NAN,
            delta_bic: f64::NAN,
            scores: Vec::new(),
            partial: false,
            indistinguishable_from: Vec::new(),
            separate_by: String::new(),
            held_out: (f64::NAN, f64::NAN),
            told_apart: Vec::new(),
        }
    }

    /// A unit that differs from `file` as real units do (load inertia +12 %, stiffness
    /// −10 %, motor friction −15 %, load friction +20 %), the stiffness as measured.
    fn perturbed_unit(file: &ActuatorParams) -> ActuatorParams {
        let mut unit = calibrate::with_measured_stiffness(file).unwrap();
        for (param, factor) in [
            (Param::LoadInertia, 1.12),
            (Param::StiffnessKeq, 0.9),
            (Param::MotorFriction, 0.85),
            (Param::LoadFriction, 1.2),
        ] {
            let v = factor * calibrate::get(&unit, param);
            calibrate::set(&mut unit, param, v);
        }
        unit
    }

    /// 3 s of the validation procedure at step `h`, V: a 9 V, 2 Hz square wave and a 2 V
    /// multisine (3, 11, 37 Hz).
    fn square_and_multisine(h: f64) -> Vec<f64> {
        (0..(3.0 / h).round() as usize)
            .map(|k| {
                let t = k as f64 * h;
                let sq = if (t * 2.0).fract() < 0.5 { 9.0 } else { -9.0 };
                sq + [3.0, 11.0, 37.0]
                    .iter()
                    .map(|f| 2.0 / 3.0 * (std::f64::consts::TAU * f * t).sin())
                    .sum::<f64>()
            })
            .collect()
    }

    /// The root mean square of `y` (0 when empty).
    pub(super) fn rms_of(y: &[f64]) -> f64 {
        (y.iter().map(|v| v * v).sum::<f64>() / y.len().max(1) as f64).sqrt()
    }

    /// `clean` with Gaussian noise of 2 % of its RMS added.
    pub(super) fn noisy(clean: Data) -> Data {
        let mut d = clean.clone();
        d.y = clean
            .y
            .iter()
            .zip(noise(clean.y.len(), 0.02 * rms_of(&clean.y)))
            .map(|(v, e)| v + e)
            .collect();
        d
    }

    /// Gaussian noise of standard deviation `s`, deterministic (xorshift, Box–Muller).
    fn noise(n: usize, s: f64) -> Vec<f64> {
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut u = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            ((x >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| s * (-2.0 * u().ln()).sqrt() * (std::f64::consts::TAU * u()).cos())
            .collect()
    }

    /// The verdict's line ([`Ctx::residual_kind`]): noise alone is at the floor, a residual
    /// spread over the record is systematic (unexplained), and one larger still (plainly)
    /// that sits in a few windows is not, unless it comes back in every period of the
    /// command or follows a stepped sine's bursts.
    #[test]
    fn a_residual_in_a_few_windows_is_not_unexplained_unless_it_repeats() {
        let h = 5e-4;
        let mut p = REFERENCE;
        p.sample_period_s = h;
        // 2 s of a 7 V multisine (2.5, 25, 62.5 Hz: it repeats every 0.4 s).
        let volts: Vec<f64> = (0..4000)
            .map(|k| {
                let t = k as f64 * h;
                [2.5, 25.0, 62.5]
                    .iter()
                    .map(|f| 7.0 / 3.0 * (std::f64::consts::TAU * f * t).sin())
                    .sum()
            })
            .collect();
        let clean = data_of(volts, h, Some(&p));
        let rms = rms_of(&clean.y);
        let sigma = 0.02 * rms;
        let e = noise(clean.y.len(), sigma);
        let record = |extra: &dyn Fn(usize, f64) -> f64| -> Data {
            let y: Vec<f64> = clean
                .y
                .iter()
                .zip(&e)
                .enumerate()
                .map(|(k, (v, n))| v + n + extra(k, *v))
                .collect();
            let mut d = clean.clone();
            d.y = y;
            d.with_weights(&vec![1.0; d.y.len()])
        };
        let opts = Options::default();
        let verdict_with = |d: &Data, coherent: Option<Coherent>| {
            let data = std::slice::from_ref(d);
            let cx = Ctx {
                nominal: p,
                data,
                sigma: vec![sigma],
                validation: None,
                val_sigma: None,
                max_v: 7.0,
                opts: &opts,
                progress: &(),
            };
            let c = calibrate::cost(&p, data);
            let robust = cx.robust_ratio(&p, data);
            let repeating = [crate::repeat::repeating(
                &d.volts,
                &d.y.iter()
                    .zip(&clean.y)
                    .map(|(a, b)| a - b)
                    .collect::<Vec<_>>(),
                &[],
                h,
                sigma,
            )];
            let v = (
                (c / cx.floor(data)).sqrt(),
                robust,
                cx.residual_kind(c, robust, data, &repeating, &[coherent]),
            );
            eprintln!("plain {:.3}x robust {:.3}x {:?}", v.0, v.1, v.2);
            v
        };
        let verdict = |d: &Data| verdict_with(d, None);
        // Noise alone: both ratios near 1.
        let (plain, robust, kind) = verdict(&record(&|_, _| 0.0));
        assert!((0.9..1.1).contains(&plain), "plain {plain}");
        assert!((0.9..1.1).contains(&robust), "robust {robust}");
        assert_eq!(kind, ResidualKind::AtFloor);
        // A tachometer gain error of 3 %: 1.8x the floor everywhere, systematic.
        let (plain, robust, kind) = verdict(&record(&|_, v| 0.03 * v));
        assert!(plain > 1.5, "plain {plain}");
        assert!(robust > 1.4, "robust {robust}");
        assert_eq!(kind, ResidualKind::Systematic);
        // A larger plain size in 1 % of the 25 ms windows (another branch of the motion).
        let win = Robust::new(sigma, h).window;
        let (plain, robust, kind) = verdict(&record(&|k, _| {
            if (k / win) % 100 == 7 {
                0.4 * rms
            } else {
                0.0
            }
        }));
        assert!(plain > 1.5, "plain {plain}");
        assert!(robust < 1.2, "robust {robust}");
        assert_eq!(kind, ResidualKind::FewWindows);
        // Were the command a stepped sine, the same residual would be systematic when the
        // bursts' coherent parts (crate::repeat::coherent) exceed the limit's excess over
        // the record, (1.2² − 1) σ², and stay in a few windows below it.
        let at = |share_of_limit: f64| {
            let few = record(&|k, _| if (k / win) % 100 == 7 { 0.4 * rms } else { 0.0 });
            verdict_with(
                &few,
                Some(Coherent {
                    bursts: 20,
                    coherent_bursts: 1,
                    other_response_bursts: 0,
                    noise_sigma: sigma,
                    mean_square: 3.0 * sigma * sigma,
                    coherent_mean_square: share_of_limit * 0.44 * sigma * sigma,
                    worst_hz: 184.5,
                    worst_rms: 5.0 * sigma,
                    worst_share: 0.7,
                }),
            )
            .2
        };
        assert_eq!(at(1.05), ResidualKind::Systematic);
        assert_eq!(at(0.95), ResidualKind::FewWindows);
        // The command repeats every 0.4 s: the same excess in a few windows is systematic
        // when it comes back at the same phase of every period (a response the model
        // lacks), and stays in a few windows when each period has its own (rattle).
        let period = 800;
        let burst = |k: usize| k % period < win;
        let (plain, robust, kind) = verdict(&record(&|k, _| {
            if burst(k) {
                0.1 * rms * (0.3 * (k % period) as f64).sin()
            } else {
                0.0
            }
        }));
        assert!(plain > 1.2, "plain {plain}");
        assert!(robust < 1.2, "robust {robust}");
        assert_eq!(kind, ResidualKind::Systematic);
        let other = noise(2 * clean.y.len(), 1.0).split_off(clean.y.len());
        let (plain, robust, kind) = verdict(&record(&|k, _| {
            if burst(k) {
                0.1 * rms * other[k].signum() * (0.3 * (k % period) as f64).sin().abs()
            } else {
                0.0
            }
        }));
        assert!(plain > 1.2, "plain {plain}");
        assert!(robust < 1.2, "robust {robust}");
        assert_eq!(kind, ResidualKind::FewWindows);
        // The rows of the excess weighted out (spans the predictability assessment took for
        // rattle), the rows kept at the floor: what comes back period after period is still
        // systematic (its repeating part is taken over every row) once alone it would make
        // the fit poor, above (2² − 1) σ²; a merely material one is not enough there, and
        // what does not repeat is at the floor.
        let kept: Vec<f64> = (0..clean.y.len())
            .map(|k| if burst(k) { 0.0 } else { 1.0 })
            .collect();
        let weighted_out = |a: f64, repeats: bool| {
            let d = record(&|k, _| {
                let s = (0.3 * (k % period) as f64).sin();
                match (burst(k), repeats) {
                    (false, _) => 0.0,
                    (true, true) => a * rms * s,
                    (true, false) => a * rms * other[k].signum() * s.abs(),
                }
            });
            let (plain, _, kind) = verdict(&d.with_weights(&kept));
            assert!(plain < 1.1, "plain {plain}");
            let e: Vec<f64> = d.y.iter().zip(&clean.y).map(|(a, b)| a - b).collect();
            let r = crate::repeat::repeating(&d.volts, &e, &[], h, sigma);
            (
                kind,
                r.map_or(0.0, |r| r.repeating_mean_square / (sigma * sigma)),
            )
        };
        let (kind, x) = weighted_out(0.3, true);
        assert!(x > 3.0, "repeating {x} sigma^2");
        assert_eq!(kind, ResidualKind::Systematic);
        let (kind, x) = weighted_out(0.1, true);
        assert!((0.44..3.0).contains(&x), "repeating {x} sigma^2");
        assert_eq!(kind, ResidualKind::AtFloor);
        let (kind, x) = weighted_out(0.3, false);
        assert!(x < 0.44, "repeating {x} sigma^2");
        assert_eq!(kind, ResidualKind::AtFloor);
    }

    /// The swap of the second pass ([`judge::swap_in_class`]): a model that took a hanging
    /// arm's gravity for a hinge spring (the two are the same torque at small angles) is
    /// given a record with large load angles — a 9 V square wave with a 2 V multisine —
    /// made by a unit that differs from the file (load inertia +12 %, stiffness −10 %, motor
    /// friction −15 %, load friction +20 %) and carries gravity: gravity replaces the spring
    /// with its value. On the same record made with a spring instead, the spring stays.
    /// (The rule; the foreign suite's gravity cases test the diagnosis on records the
    /// emulator did not make.)
    #[test]
    fn a_record_with_large_angles_tells_gravity_from_a_spring() {
        let h = 5e-4;
        let mut file = REFERENCE;
        file.sample_period_s = h;
        let unit = perturbed_unit(&file);
        let volts = square_and_multisine(h);
        let g = 0.09;
        // `told`: gravity comes as a member the first pass told apart, not as one of the
        // class. Returns the swap, if any, and the members that rejoin the class.
        let review = |hidden: Effect, told: bool| {
            let mut truth = unit;
            truth.effects.set(hidden, g);
            let d = noisy(data_of(volts.clone(), h, Some(&truth)));
            let data = std::slice::from_ref(&d);
            let opts = Options::default();
            let cx = Ctx::new(&file, data, None, &opts, &()).unwrap();
            // The model with the spring the first records suggested, polished here.
            let mut q = cx.nominal;
            q.effects.set(Effect::HingeStiffness, g);
            let mut ks = calibrate::default_knobs(&cx.nominal, cx.max_v);
            ks.push(calibrate::knob(
                &cx.nominal,
                Param::Effect(Effect::HingeStiffness),
                cx.max_v,
            ));
            let wdata = cx.weigh(&q);
            let cur = calibrate::polish(&q, &ks, &wdata, 8);
            let wdata = cx.weigh(&cur.params);
            let step = Step {
                indistinguishable_from: if told {
                    Vec::new()
                } else {
                    vec![(Effect::GravityTorque, g)]
                },
                told_apart: if told {
                    vec![Rejection {
                        effect: Effect::GravityTorque,
                        value: g,
                        nrmse_after: f64::NAN,
                        reason: String::new(),
                    }]
                } else {
                    Vec::new()
                },
                ..bare_step(
                    Effect::HingeStiffness,
                    cur.params.effects.get(Effect::HingeStiffness),
                )
            };
            judge::swap_in_class(
                &cx,
                &cur,
                &wdata,
                std::slice::from_ref(&step),
                "once the validation record was fitted too",
            )
        };
        let verdict = |hidden: Effect| -> Option<(Effect, f64, judge::Swap)> {
            let sw = review(hidden, false).0?;
            let v = sw.fit.params.effects.get(sw.effect);
            eprintln!(
                "{hidden}: swapped to {} = {v:.4}: {}; its step: NRMSE {:.4} -> {:.4}, ΔBIC {:.0}, held out {:.4} -> {:.4}",
                sw.effect,
                sw.replaced.reason,
                sw.nrmse_before,
                sw.nrmse_after,
                sw.delta_bic,
                sw.held_out.0,
                sw.held_out.1
            );
            Some((sw.effect, v, sw))
        };
        let (e, v, sw) = verdict(Effect::GravityTorque).expect("gravity replaces the spring");
        assert_eq!(e, Effect::GravityTorque);
        assert!((v / g - 1.0).abs() < 0.1, "gravity {v} for {g}");
        // The step now reports the member's own evidence (against the model with neither
        // it nor the spring), not the spring's: a hinge load of this size is the bulk of the
        // error without it.
        assert!(
            sw.delta_bic < -10.0 && sw.nrmse_after < 0.5 * sw.nrmse_before,
            "gravity's step: {} -> {}, ΔBIC {}",
            sw.nrmse_before,
            sw.nrmse_after,
            sw.delta_bic
        );
        assert!(sw.held_out.1 < sw.held_out.0, "held out {:?}", sw.held_out);
        assert!(
            verdict(Effect::HingeStiffness).is_none(),
            "the spring stays"
        );
        // A member the first pass told apart is tried alike: gravity that is there replaces
        // the spring; gravity that is not neither replaces it nor rejoins its class (this
        // record's large angles tell them apart).
        let (sw, _) = review(Effect::GravityTorque, true);
        assert_eq!(sw.map(|s| s.effect), Some(Effect::GravityTorque));
        let (sw, rejoin) = review(Effect::HingeStiffness, true);
        assert!(sw.is_none() && rejoin.is_empty(), "{rejoin:?}");
    }

    /// [`judge::swap_stand_in`]: a motor viscous friction taken in place of a voltage limit
    /// (a saturated drive reads as speed-proportional loss) gives way to the limit's refit;
    /// a friction that is there does not give way to a limit that is not. (The rule, on
    /// emulator records; voltage_limit/59 of the foreign suite tests it on records the
    /// emulator did not make.)
    #[test]
    fn a_stand_in_friction_gives_way_to_the_limit_it_stood_in_for() {
        let h = 5e-4;
        let mut file = REFERENCE;
        file.sample_period_s = h;
        let unit = perturbed_unit(&file);
        let volts = square_and_multisine(h);
        let (limit, friction) = (7.0, 3e-6);
        let stand_in = |hidden: Effect| {
            let mut truth = unit;
            truth.effects.set(
                hidden,
                if hidden == Effect::VoltageLimit {
                    limit
                } else {
                    friction
                },
            );
            let d = noisy(data_of(volts.clone(), h, Some(&truth)));
            let data = std::slice::from_ref(&d);
            let opts = Options::default();
            let cx = Ctx::new(&file, data, None, &opts, &()).unwrap();
            let knob = |e: Effect| calibrate::knob(&cx.nominal, Param::Effect(e), cx.max_v);
            // The model with the friction the first records suggested, polished here.
            let mut q = cx.nominal;
            q.effects.set(Effect::MotorViscous, friction);
            let mut ks = calibrate::default_knobs(&cx.nominal, cx.max_v);
            ks.push(knob(Effect::MotorViscous));
            let cur = calibrate::polish(&q, &ks, &cx.weigh(&q), 8);
            let wdata = cx.weigh(&cur.params);
            // The limit's later refit, beside the friction.
            let mut q = cur.params;
            q.effects.set(Effect::VoltageLimit, limit);
            ks.push(knob(Effect::VoltageLimit));
            let refit = calibrate::polish(&q, &ks, &cx.weigh(&q), 8);
            let step = Step {
                indistinguishable_from: vec![(Effect::VoltageLimit, limit)],
                ..bare_step(
                    Effect::MotorViscous,
                    cur.params.effects.get(Effect::MotorViscous),
                )
            };
            judge::swap_stand_in(
                &cx,
                &cur,
                &wdata,
                std::slice::from_ref(&step),
                0,
                &refit,
                Effect::VoltageLimit,
            )
        };
        let sw = stand_in(Effect::VoltageLimit).expect("the limit replaces the friction");
        assert_eq!(sw.effect, Effect::VoltageLimit);
        assert_eq!(sw.fit.params.effects.motor_viscous, 0.0);
        let v = sw.fit.params.effects.voltage_limit;
        assert!((v / limit - 1.0).abs() < 0.05, "limit {v} for {limit}");
        assert_eq!(sw.replaced.effect, Effect::MotorViscous);
        assert!(
            stand_in(Effect::MotorViscous).is_none(),
            "the friction that is there stays"
        );
    }
}
