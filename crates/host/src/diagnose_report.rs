//! The report of `diagnose`: the JSON object of INTERFACES.md, the human summary, and the
//! command itself (files in, plots and the calibrated parameter file out).

use crate::calibrate::{self, Data, Fit, Knob};
use crate::diagnose::limits::{descends, Limit, LimitKind};
use crate::diagnose::{part_above, Outcome, ResidualKind};
use crate::predictability;
use crate::repeat::{Coherent, Repeating};
use crate::residual;
use geared_servo::ActuatorParams;
use serde_json::{json, Map, Value};

fn rms_nrmse(cost: f64) -> f64 {
    cost.max(0.0).sqrt()
}

/// Adds `key` to a JSON object (no-op on anything else).
pub fn insert(v: &mut Value, key: &str, x: Value) {
    if let Some(o) = v.as_object_mut() {
        o.insert(key.to_string(), x);
    }
}

fn params_json(p: &ActuatorParams, knobs: &[Knob]) -> Value {
    let mut m = Map::new();
    for k in knobs {
        m.insert(k.name().to_string(), json!(calibrate::get(p, k.param)));
    }
    Value::Object(m)
}

fn fit_json(f: &Fit) -> Value {
    let mut se = Map::new();
    for (k, s) in f.knobs.iter().zip(&f.std_errors) {
        se.insert(k.name().to_string(), json!(s));
    }
    json!({
        "nrmse": rms_nrmse(f.cost),
        "parameters": params_json(&f.params, &f.knobs),
        "std_errors": se,
        "correlation_order": f.knobs.iter().map(Knob::name).collect::<Vec<_>>(),
        "correlations": f.correlations,
        "inseparable": calibrate::inseparable(f, 0.95).iter().map(|(a, b, r)| json!({"a": a, "b": b, "correlation": r})).collect::<Vec<_>>(),
        "at_bounds": calibrate::at_bounds(f),
        "optimiser_moved": f.moved,
        "evaluations": f.evaluations,
    })
}

impl Outcome {
    /// Unexplained although the rows kept as predictable sit within
    /// [`Outcome::material_ratio`] of their floor: the residual that repeats with the command
    /// over rows the predictability assessment weighted out made it so
    /// (`Ctx::residual_kind`).
    pub fn unexplained_where_weighted_out(&self) -> bool {
        self.unexplained && self.plain_floor_ratio() <= self.material_ratio
    }

    /// No effect added, and no material part of the residual on the validation record
    /// repeats with the command (`crate::repeat`; false when the record is not periodic or
    /// was not given): what remains there is rattle, not a response the model lacks.
    pub fn no_step_and_nothing_repeats(&self) -> bool {
        self.steps.is_empty()
            && self.validation_repeating.is_some_and(|r| {
                !part_above(self.material_ratio, r.repeating_mean_square, r.noise_sigma)
            })
    }

    /// The final fit's NRMSE over the floor on its rows, plainly (not under the robust
    /// window loss): the root of their costs' ratio.
    fn plain_floor_ratio(&self) -> f64 {
        (self.final_fit.cost / self.floor_cost).sqrt()
    }

    /// The calibrated parameter set, at the sample period of the file the diagnosis started
    /// from (`start`): what `diagnose --out` writes to `calibrated.toml`.
    pub fn calibrated(&self, start: &ActuatorParams) -> ActuatorParams {
        let mut p = self.final_fit.params;
        p.sample_period_s = start.sample_period_s;
        p
    }

    /// The header comments of `calibrated.toml`: the tool, the parameter file (`params_name`)
    /// and records (`data_names`) it came from, the error before and after, the effects added.
    pub fn calibrated_header(&self, params_name: &str, data_names: &[String]) -> Vec<String> {
        let mut header = vec![
            format!(
                "calibrated by geared-servo {} diagnose",
                env!("CARGO_PKG_VERSION")
            ),
            format!("from {params_name} against {}", data_names.join(", ")),
            format!(
                "NRMSE {:.4} (file) -> {:.4} (calibrated)",
                self.nominal_analysis.nrmse, self.final_analysis.nrmse
            ),
        ];
        if !self.steps.is_empty() {
            header.push(format!(
                "effects added: {}",
                self.steps
                    .iter()
                    .map(|s| s.effect.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        header
    }

    /// The JSON object of INTERFACES.md ("diagnose --json"), with more keys.
    pub fn to_json(&self, first: &Data) -> Value {
        let names: Vec<&str> = self.steps.iter().map(|s| s.effect.name()).collect();
        let mut v = json!({
            "samples": first.y.len(),
            "sample_period_s": first.sample_period_s,
            "output": first.output,
            "preroll_s": first.preroll as f64 * first.sample_period_s,
            "nominal": {
                "nrmse": self.nominal_analysis.nrmse,
                "fit_percent": self.nominal_analysis.fit_percent,
                "parameters": params_json(&self.nominal, &self.base.knobs),
            },
            "calibrated": fit_json(&self.base),
            "calibrated_residual": self.base_analysis.to_json(),
            "steps": self.steps.iter().map(|s| json!({
                "effect": s.effect.name(),
                "value": s.value,
                "std_error": s.std_error,
                "unit": s.effect.unit(),
                "nrmse_before": s.nrmse_before,
                "nrmse_after": s.nrmse_after,
                "delta_bic": s.delta_bic,
                "partial": s.partial,
                "indistinguishable_from": s.indistinguishable_from.iter().map(|(e, _)| e.name()).collect::<Vec<_>>(),
                "indistinguishable_values": s.indistinguishable_from.iter().map(|(e, x)| json!({"effect": e.name(), "value": x, "unit": e.unit()})).collect::<Vec<_>>(),
                "separate_by": s.separate_by,
                "held_out_nrmse": {"without": s.held_out.0, "with": s.held_out.1},
                "told_apart": s.told_apart.iter().map(|r| json!({"effect": r.effect.name(), "value": r.value, "unit": r.effect.unit(), "nrmse_after_refit": r.nrmse_after, "reason": r.reason})).collect::<Vec<_>>(),
                "candidate_scores": s.scores.iter().map(|(n, c, x)| json!({"effect": n.name(), "predicted_nrmse": c, "start_value": x})).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "added_effects": names,
            "final": {
                "nrmse": self.final_analysis.nrmse,
                "fit_percent": self.final_analysis.fit_percent,
                "residual_white": self.final_analysis.white,
                "fit": fit_json(&self.final_fit),
                "residual": self.final_analysis.to_json(),
            },
            "unexplained": self.unexplained,
            "last_candidate_scores": self.last_scores.iter().map(|(n, c, x)| json!({"effect": n.name(), "predicted_nrmse": c, "start_value": x})).collect::<Vec<_>>(),
        });
        let rej = |r: &crate::diagnose::Rejection| json!({"effect": r.effect.name(), "value": r.value, "nrmse_after_refit": r.nrmse_after, "reason": r.reason});
        if let Some(r) = self.rejected.first() {
            insert(&mut v, "rejected", rej(r));
        }
        insert(
            &mut v,
            "rejected_candidates",
            json!(self.rejected.iter().map(rej).collect::<Vec<_>>()),
        );
        insert(
            &mut v,
            "noise",
            json!({"sigma": self.noise_sigma, "floor_nrmse": self.floor_nrmse, "robust_floor_ratio": self.robust_floor_ratio, "residual": self.residual.name()}),
        );
        insert(&mut v, "fitted_outputs", json!(self.fitted_outputs));
        if !self.limits.is_empty() {
            insert(
                &mut v,
                "limits",
                json!(self
                    .limits
                    .iter()
                    .map(|l| json!({"effect": l.effect.name(), "unit": l.effect.unit(), "side": if l.side < 0.0 { "-" } else { "+" }, "limit": l.value, "kind": l.kind.name(), "most_favoured": {"value": l.best.0, "n_ln_cost_ratio": l.best.1, "strongly": l.favoured}}))
                    .collect::<Vec<_>>()),
            );
        }
        insert(
            &mut v,
            "unseen_candidates",
            json!(self.unseen.iter().map(|e| e.name()).collect::<Vec<_>>()),
        );
        if let Some(n) = v.get_mut("noise") {
            insert(
                n,
                "repeating",
                json!(self
                    .repeating
                    .iter()
                    .map(|r| r.map(repeating_json))
                    .collect::<Vec<_>>()),
            );
            insert(
                n,
                "coherent",
                json!(self
                    .coherent
                    .iter()
                    .map(|r| r.map(coherent_json))
                    .collect::<Vec<_>>()),
            );
        }
        insert(
            &mut v,
            "unpredictable_share",
            json!(self.unpredictable_share),
        );
        if let Some((a, b)) = self.unpredictable_rms {
            insert(
                &mut v,
                "unpredictable_rms",
                json!({"measured": a, "model": b}),
            );
        }
        insert(
            &mut v,
            "unpredictable_spans",
            json!(self
                .unpredictable_spans
                .iter()
                .map(|l| json!({
                    "start_s": l.seconds.0,
                    "end_s": l.seconds.1,
                    "rms_measured": l.measured_rms,
                    "rms_model": l.model_rms,
                }))
                .collect::<Vec<_>>()),
        );
        if let Some(f) = v.get_mut("final") {
            insert(f, "nrmse_all_rows", json!(self.final_nrmse_all_rows));
        }
        if self.unexplained {
            let rows = if self.unexplained_where_weighted_out() {
                "weighted_out"
            } else {
                "kept"
            };
            insert(&mut v, "unexplained_rows", json!(rows));
            let (lo, hi, sh) = self.final_analysis.dominant_band();
            insert(&mut v, "unexplained_band_hz", json!([lo, hi]));
            insert(&mut v, "unexplained_band_share", json!(sh));
            insert(
                &mut v,
                "unexplained_peak_hz",
                json!(self.final_analysis.peak_hz),
            );
            insert(
                &mut v,
                "unexplained_regimes",
                json!(self.final_analysis.concentrated_regimes()),
            );
        }
        if let Some((a, b)) = self.validation {
            let mut val = json!({"nrmse_before": a, "nrmse_after": b});
            if let Some(f) = self.validation_floor {
                insert(&mut val, "floor_nrmse", json!(f));
            }
            insert(
                &mut val,
                "used_in_fit",
                json!(self.validation_in_fit.is_some()),
            );
            if let Some((x, f)) = self.validation_in_fit {
                insert(
                    &mut val,
                    "held_out_nrmse",
                    json!({"nrmse": x, "floor_nrmse": f}),
                );
            }
            if let Some(r) = self.validation_repeating {
                insert(&mut val, "repeating", repeating_json(r));
            }
            insert(&mut v, "validation", val);
        }
        v
    }

    /// The summary's line on the unpredictable span whose level the final model misses most
    /// (modelled over measured RMS furthest from 1, [`predictability::SpanLevel::ratio`]),
    /// or `None` when no span was long enough to compare.
    fn worst_span_line(&self) -> Option<String> {
        let sigma = self.noise_sigma.first().copied().unwrap_or(0.0);
        let off = |l: &predictability::SpanLevel| l.ratio(sigma).ln().abs();
        let worst = self
            .unpredictable_spans
            .iter()
            .max_by(|a, b| off(a).total_cmp(&off(b)))?;
        Some(format!(
            "  span by span ({} of at least {} s): the furthest, {:.3}-{:.3} s, RMS {:.4} measured (noise taken out), {:.4} modelled (x{:.2})",
            self.unpredictable_spans.len(),
            predictability::SPAN_MIN_S,
            worst.seconds.0,
            worst.seconds.1,
            worst.measured_rms,
            worst.model_rms,
            worst.ratio(sigma)
        ))
    }

    /// The summary's lines of the limits, one per effect ([`crate::diagnose::limits`], which
    /// lists an effect's sides together).
    pub fn limit_lines(&self) -> Vec<String> {
        self.limits
            .chunk_by(|a, b| a.effect == b.effect)
            .filter_map(|sides| limit_line(sides, self.bic_threshold))
            .collect()
    }

    /// Human summary.
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let a0 = &self.nominal_analysis;
        let _ = writeln!(
            s,
            "nominal model (file):   NRMSE {:.4}  fit {:.1} %",
            a0.nrmse, a0.fit_percent
        );
        let shares: Vec<String> = self
            .unpredictable_share
            .iter()
            .map(|x| format!("{:.1} %", 100.0 * x))
            .collect();
        let _ = writeln!(
            s,
            "noise floor:            NRMSE {:.4} (noise sigma {}); unpredictable rows (gear rattle) weighted out: {}",
            self.floor_nrmse,
            self.noise_sigma
                .iter()
                .map(|x| format!("{x:.3e}"))
                .collect::<Vec<_>>()
                .join(", "),
            shares.join(", ")
        );
        if self.fitted_outputs.iter().any(|o| o.len() > 1) {
            let per: Vec<String> = self
                .fitted_outputs
                .iter()
                .enumerate()
                .map(|(i, o)| format!("record {}: {}", i + 1, o.join(", ")))
                .collect();
            let _ = writeln!(
                s,
                "fitted outputs:         {} (each further output in units of its own floor, scaled to the first's noise; an angle over each predictable span with its offset free: a fit's or an effect's NRMSE below is of them all together, in the first output's unit)",
                per.join("; ")
            );
        }
        if !self.unseen.is_empty() {
            let names: Vec<&str> = self.unseen.iter().map(|e| e.name()).collect();
            let cols: Vec<&str> = self.unseen.iter().filter_map(|e| e.sensor_column()).fold(
                Vec::new(),
                |mut v, c| {
                    if !v.contains(&c) {
                        v.push(c);
                    }
                    v
                },
            );
            let _ = writeln!(
                s,
                "not tried:              {} (errors of a sensor these records do not have: {})",
                names.join(", "),
                cols.join(", ")
            );
        }
        if let Some((a, m)) = self.unpredictable_rms {
            let _ = writeln!(
                s,
                "  over those rows the RMS is {a:.4} measured, {m:.4} modelled (compared by statistics, not sample by sample)"
            );
        }
        if let Some(line) = self.worst_span_line() {
            let _ = writeln!(s, "{line}");
        }
        let b = &self.base_analysis;
        let _ = writeln!(
            s,
            "calibrated ({} parameters): NRMSE {:.4}  fit {:.1} %  residual {}",
            self.base.knobs.len(),
            b.nrmse,
            b.fit_percent,
            if b.white { "white" } else { "structured" }
        );
        for (k, (v, se)) in self
            .base
            .knobs
            .iter()
            .zip(self.base.values.iter().zip(&self.base.std_errors))
        {
            let _ = writeln!(
                s,
                "  {:<28} {:>12.5e} ± {:.2e} {}   (file {:.5e})",
                k.param,
                v,
                se,
                k.param.unit(),
                calibrate::get(&self.nominal, k.param)
            );
        }
        if self.base.moved < 1e-3 && !b.white {
            let _ = writeln!(
                s,
                "  WARNING: the optimiser did not move from the file's values (largest change {:.1e}): check the start",
                self.base.moved
            );
        }
        bound_lines(&mut s, &self.base);
        for (a, bb, r) in calibrate::inseparable(&self.base, 0.95) {
            let _ = writeln!(s, "  cannot separate {a} and {bb} (correlation {r:+.3})");
        }
        for st in &self.steps {
            let _ = writeln!(
                s,
                "added {:<16} = {:.5e} ± {:.1e} {}: NRMSE {:.4} -> {:.4} (ΔBIC {:.1}){}",
                st.effect,
                st.value,
                st.std_error,
                st.effect.unit(),
                st.nrmse_before,
                st.nrmse_after,
                st.delta_bic,
                if st.partial {
                    "  [partial: a material residual remains, not claimed with confidence]"
                } else {
                    ""
                }
            );
            if !st.indistinguishable_from.is_empty() {
                let alts: Vec<String> = st
                    .indistinguishable_from
                    .iter()
                    .map(|(e, x)| {
                        let (lo, hi) = e.plausible_range();
                        let outside = if (lo..=hi).contains(x) {
                            String::new()
                        } else {
                            format!(" (outside its plausible range, {lo:e} to {hi:e})")
                        };
                        format!("{e} = {x:.4e} {}{outside}", e.unit())
                    })
                    .collect();
                let _ = writeln!(
                    s,
                    "  the record explains as well: {}; to separate them, {}",
                    alts.join(", "),
                    st.separate_by
                );
            }
            for r in &st.told_apart {
                let _ = writeln!(
                    s,
                    "  not {} = {:.4e} {}: {}",
                    r.effect,
                    r.value,
                    r.effect.unit(),
                    r.reason
                );
            }
        }
        if self.steps.is_empty() {
            let _ = writeln!(s, "no effect earned its parameter");
            for r in self.rejected.iter().take(3) {
                let _ = writeln!(
                    s,
                    "  candidate {} = {:.4e} {} would give NRMSE {:.4}: {}",
                    r.effect,
                    r.value,
                    r.effect.unit(),
                    r.nrmse_after,
                    r.reason
                );
            }
        } else {
            let _ = writeln!(s, "final parameters:");
            for (k, (v, se)) in self
                .final_fit
                .knobs
                .iter()
                .zip(self.final_fit.values.iter().zip(&self.final_fit.std_errors))
            {
                let _ = writeln!(
                    s,
                    "  {:<28} {:>12.5e} ± {:.2e} {}",
                    k.param,
                    v,
                    se,
                    k.param.unit()
                );
            }
            bound_lines(&mut s, &self.final_fit);
        }
        block(
            &mut s,
            &format!(
                "limits of the effects not added (each held at a value, the rest refitted on the final model's rows; ruled out where that refit is worse by n ln(cost ratio) > {:.0} and by a material residual, {}x the floor, on its own):",
                -self.bic_threshold,
                self.material_ratio
            ),
            self.limit_lines(),
        );
        let f = &self.final_analysis;
        let _ = writeln!(
            s,
            "final:                  NRMSE {:.4}  fit {:.1} %  residual {} ({} of {} lags outside 99 %)",
            f.nrmse,
            f.fit_percent,
            if f.white { "white" } else { "structured" },
            f.lags_outside,
            residual::LAGS
        );
        if let Some((x, f)) = self.validation_in_fit {
            let _ = writeln!(
                s,
                "validation held out:    NRMSE {x:.4} against its floor {f:.4}: a material residual the estimation record did not show, so both records were used for the fit below"
            );
        }
        if let Some((a, bb)) = self.validation {
            let _ = writeln!(
                s,
                "validation:             NRMSE {a:.4} -> {bb:.4}{}",
                if self.validation_in_fit.is_some() {
                    " (in the fit)"
                } else {
                    ""
                }
            );
        }
        let mut lines = per_record(&self.repeating, repeating_line);
        if self.validation_in_fit.is_none() {
            lines.extend(repeating_line(
                "the validation record (held out)",
                self.validation_repeating,
            ));
        }
        block(
            &mut s,
            "residual that repeats with the command (rattle does not):",
            lines,
        );
        block(
            &mut s,
            "residual coherent with the stepped sine's bursts (rattle is not):",
            per_record(&self.coherent, coherent_line),
        );
        if self.residual == ResidualKind::FewWindows {
            let material = self.material_ratio;
            let plain_ratio = self.plain_floor_ratio();
            let _ = writeln!(
                s,
                "residual above the floor in a few windows only: NRMSE {:.2}x the floor, {:.2}x under the robust window loss (at most {material}x): not spread over the record, so not claimed as a missing effect; most likely spans where the unit rattles on another response than the model (see time.svg)",
                plain_ratio, self.robust_floor_ratio
            );
        }
        if self.unexplained {
            // Unexplained with the predictable rows near their floor: the residual comes
            // back period after period over rows the assessment weighted out (Ctx::residual_kind).
            if self.unexplained_where_weighted_out() {
                let plain_ratio = self.plain_floor_ratio();
                let _ = writeln!(
                    s,
                    "UNEXPLAINED: the rows kept as predictable are near their floor ({plain_ratio:.2}x, at most {}x), but over every row most of the residual repeats with the command (above), enough alone to make the fit poor: a deterministic response the model lacks, in spans the predictability assessment weighted out",
                    self.material_ratio
                );
                return s;
            }
            // The first record's figures, then the ratios that decided (every output of every
            // record fitted: with a validation record in the fit they can differ a lot).
            let (lo, hi, sh) = f.dominant_band();
            let _ = writeln!(
                s,
                "UNEXPLAINED: a material residual remains above the noise floor (NRMSE {:.4} vs floor {:.4}; over every record and output fitted {:.2}x the floor, {:.2}x under the robust window loss, material above {}x); {:.0} % of its energy in {:.0}-{:.0} Hz (peak {:.1} Hz)",
                f.nrmse,
                self.floor_nrmse,
                self.plain_floor_ratio(),
                self.robust_floor_ratio,
                self.material_ratio,
                100.0 * sh,
                lo,
                hi,
                f.peak_hz
            );
            for r in f.concentrated_regimes() {
                let _ = writeln!(s, "  concentrated in {r}");
            }
        }
        s
    }
}

/// `noise.repeating`'s entry for one record (docs/INTERFACES.md).
fn repeating_json(r: Repeating) -> Value {
    json!({
        "period_s": r.period_s,
        "noise_sigma": r.noise_sigma,
        "periods": r.periods,
        "residual_rms": r.mean_square.sqrt(),
        "repeating_rms": r.repeating_mean_square.sqrt(),
    })
}

/// One summary line per record from `line` (given the record's name: "the record" when
/// there is one, else "record N"), for the records it has a line for.
fn per_record<T: Copy>(
    items: &[Option<T>],
    line: fn(&str, Option<T>) -> Option<String>,
) -> Vec<String> {
    items
        .iter()
        .enumerate()
        .filter_map(|(i, r)| {
            let what = if items.len() == 1 {
                "the record".to_string()
            } else {
                format!("record {}", i + 1)
            };
            line(&what, *r)
        })
        .collect()
}

/// One effect's limits for the summary (`sides`: its one or two [`Limit`]s), on one line,
/// with the value the walk found best where its evidence beats `bic_threshold` (negative).
fn limit_line(sides: &[Limit], bic_threshold: f64) -> Option<String> {
    let effect = sides.first()?.effect;
    let unit = effect.unit();
    // The voltage limit clips more the lower it is: its walk goes down.
    let (to, from) = if descends(effect) {
        ("down to", "below")
    } else {
        ("up to", "from")
    };
    let side = |l: &Limit| match l.kind {
        LimitKind::BelowRange => format!("ruled out {from} {:+.3e}", l.value),
        LimitKind::Within => format!("{to} {:+.3e}", l.value),
        LimitKind::BeyondRange => format!("not ruled out {to} {:+.3e}", l.value),
    };
    let mut line = format!(
        "  {:<22} {} {unit}",
        effect.name(),
        sides.iter().map(side).collect::<Vec<_>>().join(", ")
    );
    if sides.iter().all(|l| l.kind == LimitKind::BeyondRange) {
        line.push_str(": these records cannot show it anywhere in its plausible range");
    }
    let best = sides.iter().min_by(|a, b| a.best.1.total_cmp(&b.best.1));
    if let Some(l) = best.filter(|l| l.best.1 < bic_threshold) {
        let (v, e) = l.best;
        line.push_str(&if sides.iter().any(|l| l.favoured) {
            format!(" (favoured at {v:+.3e} by {e:.1}, not added: see the candidates refused)")
        } else {
            format!(" (leaning to {v:+.3e} by {e:.1}, an immaterial share of the residual)")
        });
    }
    Some(line)
}

/// Writes `title` and `lines` under it to `s`, nothing when there are no lines.
fn block(s: &mut String, title: &str, lines: Vec<String>) {
    use std::fmt::Write as _;
    if lines.is_empty() {
        return;
    }
    let _ = writeln!(s, "{title}");
    for line in lines {
        let _ = writeln!(s, "{line}");
    }
}

/// `noise.coherent`'s entry for one record (docs/INTERFACES.md).
fn coherent_json(c: Coherent) -> Value {
    json!({
        "bursts": c.bursts,
        "coherent_bursts": c.coherent_bursts,
        "noise_sigma": c.noise_sigma,
        "residual_rms": c.mean_square.sqrt(),
        "coherent_rms": c.coherent_mean_square.sqrt(),
        "worst_hz": if c.worst_hz.is_finite() { json!(c.worst_hz) } else { Value::Null },
        "worst_rms": c.worst_rms,
        "worst_share": c.worst_share,
        "other_response_bursts": c.other_response_bursts,
    })
}

/// The summary's line on the part of each residual coherent with a stepped sine's bursts
/// (`what` names the record), or `None` without sine bursts.
fn coherent_line(what: &str, c: Option<Coherent>) -> Option<String> {
    let c = c?;
    let worst = if c.worst_hz.is_finite() {
        format!(
            "; the largest at {:.1} Hz, RMS {:.4} ({:.0} % of that burst's residual above the noise)",
            c.worst_hz,
            c.worst_rms,
            100.0 * c.worst_share
        )
    } else {
        String::new()
    };
    let other = match c.other_response_bursts {
        0 => String::new(),
        k => format!(
            "; {k} more mostly coherent where the model reaches the unit's response from another rest position of the gears (the other of two coexisting responses, not counted)"
        ),
    };
    Some(format!(
        "  {what}: {} sine bursts, {} of them mostly coherent (a deterministic response the model lacks), their coherent part RMS {:.4} over the record (noise {:.4}){worst}{other}",
        c.bursts,
        c.coherent_bursts,
        c.coherent_mean_square.sqrt(),
        c.noise_sigma
    ))
}

/// The summary's line on the part of each residual that repeats with a periodic command
/// (`what` names the record), or `None` when the command is not periodic.
fn repeating_line(what: &str, r: Option<Repeating>) -> Option<String> {
    let r = r?;
    let sigma = r.noise_sigma;
    let excess = r.mean_square - sigma * sigma;
    let reading = if excess <= 0.0 {
        "the residual is within the noise".to_string()
    } else {
        format!(
            "{:.0} % of what exceeds the noise: {}",
            100.0 * r.repeating_mean_square / excess,
            if r.mostly_repeats() {
                "mostly a deterministic response the model lacks"
            } else {
                "mostly what does not repeat (noise, rattle)"
            }
        )
    };
    Some(format!(
        "  {what}: the command repeats every {:.4} s ({} periods); of the residual's RMS {:.4} (noise {:.4}), {:.4} repeats with it ({reading})",
        r.period_s,
        r.periods,
        r.mean_square.sqrt(),
        sigma,
        r.repeating_mean_square.sqrt(),
    ))
}

/// One line for each parameter of `fit` at a bound of the calibration.
fn bound_lines(s: &mut String, fit: &calibrate::Fit) {
    use std::fmt::Write as _;
    for k in calibrate::at_bounds(fit) {
        let background = fit.knobs.iter().any(|x| x.name() == k && x.floor_ok);
        let _ = if background {
            writeln!(
                s,
                "  {k} is at the top of the background damping every gear train has (calibrate::BACKGROUND_DAMPING): the record wants more damping"
            )
        } else {
            writeln!(
                s,
                "  {k} is at its bound (the file value x30 or /30): the model lacks something"
            )
        };
    }
}
