//! The report of `diagnose`: the JSON object of INTERFACES.md, the human summary, and the
//! command itself (files in, plots and the calibrated parameter file out).

use crate::calibrate::{self, Data, Fit, Knob};
use crate::diagnose::Outcome;
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
                "indistinguishable_from": s.indistinguishable_from.iter().map(|e| e.name()).collect::<Vec<_>>(),
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
        if let Some((n, x, e)) = &self.rejected {
            insert(
                &mut v,
                "rejected",
                json!({"effect": n.name(), "value": x, "nrmse_after_refit": e, "reason": "did not earn its parameter (BIC or validation)"}),
            );
        }
        if self.unexplained {
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
            insert(
                &mut v,
                "validation",
                json!({"nrmse_before": a, "nrmse_after": b}),
            );
        }
        v
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
        for k in calibrate::at_bounds(&self.base) {
            let _ = writeln!(
                s,
                "  {k} is at its bound (the file value x30 or /30): the model lacks something"
            );
        }
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
                    "  [partial: structure remains, not claimed with confidence]"
                } else {
                    ""
                }
            );
        }
        if self.steps.is_empty() {
            let _ = writeln!(s, "no effect earned its parameter");
            if let Some((n, v, e)) = &self.rejected {
                let _ = writeln!(
                    s,
                    "  best candidate {n} = {v:.4e} {} would give NRMSE {e:.4}: not enough",
                    n.unit()
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
        }
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
        if let Some((a, bb)) = self.validation {
            let _ = writeln!(s, "validation:             NRMSE {a:.4} -> {bb:.4}");
        }
        if self.unexplained {
            let (lo, hi, sh) = f.dominant_band();
            let _ = writeln!(
                s,
                "UNEXPLAINED: residual still structured; {:.0} % of its energy in {:.0}-{:.0} Hz (peak {:.1} Hz)",
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
