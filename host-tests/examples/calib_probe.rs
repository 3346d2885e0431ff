//! Where `diagnose` lands on a case of the foreign suite, against the truth, and what a
//! further global search from there finds (a development probe: `cargo run --release -p
//! geared-servo-host-tests --example calib_probe -- KIND DRAWS`).
use geared_servo::ActuatorParams;
use geared_servo_host::calibrate::{self, Param, BASE_KNOBS};
use geared_servo_host::diagnose::Options;
use geared_servo_host::{noise, params_file, predictability};
use geared_servo_host_tests::foreign::{self, Kind};
use std::time::Instant;

/// The truth in the model's form with the file's resistance (mechanical quantities x s).
fn eq_truth(c: &foreign::ForeignCase) -> ActuatorParams {
    let s = c.resistance_scale;
    let mut t = calibrate::with_measured_stiffness(&c.truth).unwrap();
    t.motor.resistance_ohm = c.file.motor.resistance_ohm;
    for k in [
        Param::MotorInertia,
        Param::LoadInertia,
        Param::StiffnessKeq,
        Param::MotorFriction,
        Param::LoadFriction,
    ] {
        let v = calibrate::get(&t, k);
        calibrate::set(&mut t, k, v * s);
    }
    for (e, v) in c
        .expected
        .iter()
        .chain([(geared_servo::Effect::MeshDamping, t.effects.mesh_damping)].iter())
    {
        t.effects.set(*e, c.expected_fitted(*e, *v));
    }
    t.sample_period_s = c.estimation.sample_period_s;
    t
}

/// The file's values as the calibration starts from them: the stiffness in its measured
/// form, at the record's sample period `h`, s.
fn file_form(c: &foreign::ForeignCase, h: f64) -> ActuatorParams {
    let mut file = calibrate::with_measured_stiffness(&c.file).unwrap();
    file.sample_period_s = h;
    file
}

fn fmt(t: &ActuatorParams, p: &ActuatorParams) -> String {
    BASE_KNOBS
        .iter()
        .map(|&k| {
            format!(
                "{} {:+.1}%",
                k.name()
                    .split('.')
                    .next()
                    .unwrap()
                    .chars()
                    .take(4)
                    .collect::<String>()
                    + k.name()
                        .rsplit('.')
                        .next()
                        .unwrap()
                        .chars()
                        .take(3)
                        .collect::<String>()
                        .as_str(),
                100.0 * (calibrate::get(p, k) / calibrate::get(t, k) - 1.0)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
        + &format!(
            ", mesh {:.4}/{:.4}",
            p.effects.mesh_damping, t.effects.mesh_damping
        )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let kind = Kind::from_name(args.get(1).map(|s| s.as_str()).unwrap_or("clean")).unwrap();
    let draws: Vec<u64> = args
        .get(2)
        .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or(vec![0]);
    for draw in draws {
        // `GS_FOREIGN_SECONDS=20`: the estimation record's stepped sine that long, as in the
        // suite.
        let c = foreign::case_with(kind, draw, &foreign::Making::from_env()).unwrap();
        if std::env::var("UNIT").is_ok() {
            let (t, f) = (&c.truth.motor, &c.file.motor);
            println!(
                "{}: tach {:+.2}% Kt {:+.2}% Ke {:+.2}% R {:+.2}% L {:+.2}%",
                c.label(),
                100.0 * (t.tach_v_s_per_rad / f.tach_v_s_per_rad - 1.0),
                100.0 * (t.torque_constant_nm_per_a / f.torque_constant_nm_per_a - 1.0),
                100.0 * (t.back_emf_v_s_per_rad / f.back_emf_v_s_per_rad - 1.0),
                100.0 * (t.resistance_ohm / f.resistance_ohm - 1.0),
                100.0 * (t.inductance_h / f.inductance_h - 1.0),
            );
            continue;
        }
        if std::env::var("SIGMA").is_ok() {
            // The record's noise level as `diagnose` estimates it against the noise added.
            for (name, d, fl) in [
                ("estimation", &c.estimation, c.estimation_floor),
                ("validation", &c.validation, c.validation_floor),
            ] {
                let truth = fl * d.norm / (d.y.len() as f64).sqrt();
                let est = noise::sigma(&d.y);
                println!(
                    "SIGMA {} {name}: estimated {est:.4e}, added {truth:.4e}, ratio {:.3}",
                    c.label(),
                    est / truth
                );
            }
            continue;
        }
        if std::env::var("UNEXCUSE").is_ok() {
            unexcuse(&c);
            continue;
        }
        if std::env::var("IDENT").is_ok() {
            witness(&c, None);
            continue;
        }
        if std::env::var("ONLY").is_ok() {
            only(&c);
            continue;
        }
        if std::env::var("JUDGE").is_ok() {
            judge(&c);
            continue;
        }
        if std::env::var("PICKUP").is_ok() {
            pickup(&c);
            continue;
        }
        if std::env::var("TGAIN").is_ok() {
            tgain(&c);
            continue;
        }
        if std::env::var("KEPT").is_ok() {
            kept_bursts(&c);
            continue;
        }
        if std::env::var("SHARES").is_ok() {
            shares(&c);
            continue;
        }
        if std::env::var("ROBUSTAT").is_ok() {
            robust_at(&c);
            continue;
        }
        if std::env::var("VALPROBE").is_ok() {
            valprobe(&c);
            continue;
        }
        if std::env::var("SPANS").is_ok() {
            spans(&c);
            continue;
        }
        if std::env::var("ENSEMBLES").is_ok() {
            ensembles(&c);
            continue;
        }
        if std::env::var("SIMTIME").is_ok() {
            sim_time(&c);
            continue;
        }
        if std::env::var("BURSTS").is_ok() {
            bursts(&c);
            continue;
        }
        if std::env::var("VISIBILITY").is_ok() {
            visibility(&c);
            continue;
        }
        if std::env::var("SMOOTH").is_ok() {
            smooth(&c);
            continue;
        }
        if std::env::var("WIDTHS").is_ok() {
            widths(&c);
            continue;
        }
        if std::env::var("STRUCT").is_ok() {
            structural(&c);
            continue;
        }
        if std::env::var("FILEGRID").is_ok() {
            file_grid(&c);
            continue;
        }
        if std::env::var("MDSETTLE").is_ok() {
            md_settle(&c);
            continue;
        }
        if std::env::var("FRF").is_ok() {
            frf(&c);
            continue;
        }
        if std::env::var("BASE_ONLY").is_ok() {
            base_only(&c);
            continue;
        }
        let d = &c.estimation;
        let sigma = noise::sigma(&d.y);
        let te = eq_truth(&c);
        let t0 = Instant::now();
        let out = c.diagnose(&Options::default()).unwrap();
        if std::env::var("COVER").is_ok() {
            println!(
                "== {} ({:.1}s): steps {:?} final {:.4}",
                c.label(),
                t0.elapsed().as_secs_f64(),
                out.steps.iter().map(|s| s.effect).collect::<Vec<_>>(),
                out.final_fit.cost.sqrt()
            );
            cover(&c, &out);
            continue;
        }
        let w = d.with_weights(&out.weights[0]);
        let fl = noise::floor_nrmse(sigma, &w.weight, w.norm);
        println!(
            "== {} ({:.1}s): steps {:?}",
            c.label(),
            t0.elapsed().as_secs_f64(),
            out.steps
                .iter()
                .map(|s| format!(
                    "{}={:.3e} ({:.4}->{:.4}, dBIC {:.0}{})",
                    s.effect,
                    s.value,
                    s.nrmse_before,
                    s.nrmse_after,
                    s.delta_bic,
                    if s.partial { ", partial" } else { "" }
                ))
                .collect::<Vec<_>>()
        );
        for r in &out.rejected {
            println!(
                "  rejected {}={:.3e} ({:.4}): {}",
                r.effect, r.value, r.nrmse_after, r.reason
            );
        }
        println!(
            "  last scores {:?}",
            out.last_scores
                .iter()
                .map(|(e, c, v)| format!("{e} {c:.4} @{v:.3e}"))
                .collect::<Vec<_>>()
        );
        println!(
            "  knobs {:?}",
            out.final_fit
                .knobs
                .iter()
                .zip(&out.final_fit.values)
                .map(|(k, v)| format!("{}={:.4e}", k.name(), v))
                .collect::<Vec<_>>()
        );
        println!(
            "  validation {:?} floor {:?}; second pass from {:?}; unexplained {}",
            out.validation, out.validation_floor, out.validation_in_fit, out.unexplained
        );
        println!(
            "  base {:.4} [{}]",
            out.base.cost.sqrt(),
            fmt(&te, &out.base.params)
        );
        println!(
            "  final {:.4} floor {:.4} truth-on-these {:.4} excl {:.2} [{}]",
            out.final_fit.cost.sqrt(),
            fl,
            calibrate::nrmse(&te, &w),
            w.excluded_share(),
            fmt(&te, &out.final_fit.params)
        );
        let (wt, _) = predictability::weigh(&te, d);
        println!(
            "  truth on own weights {:.4} (excl {:.2}); final on truth weights {:.4}",
            calibrate::nrmse(&te, &wt),
            wt.excluded_share(),
            calibrate::nrmse(&out.final_fit.params, &wt)
        );
        with_expected(&c, &out);
        {
            // Materiality on the robust window loss: plain and robust NRMSE over their floors
            // on the final's kept rows, for the final and the truth.
            let rb = w.with_robust(Some(calibrate::Robust::new(
                out.noise_sigma[0],
                w.sample_period_s,
            )));
            let c0 = calibrate::Robust::noise_share();
            let rf = |p: &geared_servo::ActuatorParams| floor_ratios(p, &w, &rb, fl);
            if out.weights.len() > 1 {
                let v = c.validation.with_weights(&out.weights[1]);
                let sv = out
                    .noise_sigma
                    .get(1)
                    .copied()
                    .unwrap_or(out.noise_sigma[0]);
                let vf = noise::floor_nrmse(sv, &v.weight, v.norm);
                let vr = v.with_robust(Some(calibrate::Robust::new(sv, v.sample_period_s)));
                let both = [rb.clone(), vr.clone()];
                let floor2 = 0.5 * (fl * fl + vf * vf);
                let plain2 = 0.5
                    * (calibrate::nrmse(&out.final_fit.params, &w).powi(2)
                        + calibrate::nrmse(&out.final_fit.params, &v).powi(2));
                println!(
                    "  ROBUST2 {}: validation plain {:.2}x robust {:.2}x; both plain {:.2}x robust {:.2}x",
                    c.label(),
                    calibrate::nrmse(&out.final_fit.params, &v) / vf,
                    (calibrate::cost(&out.final_fit.params, std::slice::from_ref(&vr)) / (c0 * vf * vf)).sqrt(),
                    (plain2 / floor2).sqrt(),
                    (calibrate::cost(&out.final_fit.params, &both) / (c0 * floor2)).sqrt()
                );
            }
            println!(
                "  ROBUST {}: final plain {:.2}x robust {:.2}x; truth plain {:.2}x robust {:.2}x (unexplained {})",
                c.label(),
                rf(&out.final_fit.params).0,
                rf(&out.final_fit.params).1,
                rf(&te).0,
                rf(&te).1,
                out.unexplained
            );
        }
        if std::env::var("THIN").is_ok() {
            for (name, p) in [("truth", &te), ("base", &out.base.params)] {
                thin(name, p, d);
            }
            continue;
        }
        if std::env::var("TRAP").is_ok() {
            trap(&out.final_fit.params, &out.base.params, d, &te);
            continue;
        }
        if std::env::var("VSTART").is_ok() {
            valley_starts(&c, &out.final_fit);
            continue;
        }
        if std::env::var("WITNESS").is_ok() {
            witness(&c, Some((&out.final_fit.params, &out.final_fit.knobs)));
            continue;
        }
        if std::env::var("VAL").is_ok() {
            val(
                &c,
                &[
                    ("truth", &te),
                    ("base", &out.base.params),
                    ("final", &out.final_fit.params),
                ],
            );
            continue;
        }
        if std::env::var("VALLEY").is_ok() {
            valley(&c, &out.final_fit, &w, &te);
            continue;
        }
        if std::env::var("FINISH").is_ok() {
            finish(&c, &out, &te);
            continue;
        }
        if std::env::var("QUICK").is_ok() {
            continue;
        }
        let knobs = out.final_fit.knobs.clone();
        let t1 = Instant::now();
        let g = calibrate::calibrate(&out.final_fit.params, &knobs, std::slice::from_ref(&w));
        println!(
            "  global from final on final weights: {:.4} ({:.1}s) [{}]",
            g.cost.sqrt(),
            t1.elapsed().as_secs_f64(),
            fmt(&te, &g.params)
        );
        let (w2, _) = predictability::weigh(&g.params, d);
        let q = calibrate::refine(&g.params, &knobs, std::slice::from_ref(&w2));
        let f = calibrate::polish(&q, &knobs, std::slice::from_ref(&w2), 20);
        println!(
            "  reweigh+refine+polish: {:.4} truth-on-these {:.4} excl {:.2} [{}]",
            f.cost.sqrt(),
            calibrate::nrmse(&te, &w2),
            w2.excluded_share(),
            fmt(&te, &f.params)
        );
        let ft = calibrate::polish(&te, &knobs, std::slice::from_ref(&wt), 20);
        println!(
            "  polish from truth on truth weights: {:.4} [{}]",
            ft.cost.sqrt(),
            fmt(&te, &ft.params)
        );
    }
}

/// Each candidate effect alone at the file's values (with the background damping): the
/// best of its grid over the file's cost on the file's smooth rows (robust loss).
pub fn file_grid(c: &foreign::ForeignCase) {
    use geared_servo::Effect;
    for (name, d) in [("est", &c.estimation), ("val", &c.validation)] {
        let file = file_form(c, d.sample_period_s);
        let mv = d.max_abs_v();
        let start = calibrate::with_background_damping(&file, mv).unwrap();
        let w = calibrate::robust(&[predictability::weigh_smooth(&start, d).0]);
        let c0 = calibrate::cost(&start, &w);
        let mut out: Vec<(f64, Effect, f64)> = Options::default()
            .candidates
            .iter()
            .map(|&e| {
                let k = calibrate::knob(&start, Param::Effect(e), mv);
                let g = calibrate::effect_grid(&start, e, &k, mv).unwrap_or_else(|| {
                    let s = calibrate::effect_scale(&start, e, mv);
                    let f: Vec<f64> = match e {
                        Effect::InputDelay => vec![0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0],
                        Effect::VoltageLimit => vec![0.3, 0.45, 0.6, 0.7, 0.8, 0.9, 0.95],
                        Effect::TachGain => {
                            return vec![-0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3]
                        }
                        _ => vec![1e-3, 3e-3, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0],
                    };
                    f.iter().map(|x| (x * s).clamp(k.lo, k.hi)).collect()
                });
                g.iter()
                    .map(|&v| {
                        let mut q = start;
                        calibrate::set(&mut q, Param::Effect(e), v);
                        (calibrate::cost(&q, &w) / c0, e, v)
                    })
                    .fold(
                        (f64::INFINITY, e, 0.0),
                        |b, x| if x.0 < b.0 { x } else { b },
                    )
            })
            .collect();
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        println!(
            "FILEGRID {} {name}: {}",
            c.label(),
            out.iter()
                .take(5)
                .map(|(r, e, v)| format!("{e} {r:.3}@{v:.3e}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
}

/// The anti-resonance and resonance the global search's second start reads off the
/// estimation record (`calibrate::frf_notch_peak`), against the unit's own (its rigid
/// two-mass figures, eqs. 17a/b), per output the record has.
pub fn frf(c: &foreign::ForeignCase) {
    let t = eq_truth(c);
    let n = t.derived().unwrap().n_total;
    let (jm, jl, k) = (
        calibrate::get(&t, Param::MotorInertia),
        calibrate::get(&t, Param::LoadInertia),
        calibrate::get(&t, Param::StiffnessKeq),
    );
    let f_ar = (k / jl).sqrt() / (2.0 * std::f64::consts::PI);
    let f_r = f_ar * (1.0 + jl / (n * n * jm)).sqrt();
    let d = &c.estimation;
    let read = calibrate::frf_notch_peak(d);
    let file = file_form(c, d.sample_period_s);
    let start = calibrate::frf_start(&file, d);
    println!(
        "FRF {} output {}{}: truth f_AR {f_ar:.1} Hz f_R {f_r:.1} Hz; read {:?}; start k {:?} Jm {:?} (truth k {k:.1} Jm {jm:.3e})",
        c.label(),
        d.output,
        if d.steps { " steps" } else { "" },
        read.map(|(a, b)| format!("{a:.1}/{b:.1}")),
        start.map(|q| format!("{:.1}", calibrate::get(&q, Param::StiffnessKeq))),
        start.map(|q| format!("{:.3e}", calibrate::get(&q, Param::MotorInertia))),
    );
}

/// The structural search's global settle of the mesh damping from the file's values
/// (`diagnose::settle::settle_seeded` restated: three rounds on the smooth rows, the first
/// global, then the polish on the fit's own rows), against the truth on its predictable
/// rows. `MDSETTLE=V`: from the damping at V and at V·(1 + i·10⁻⁶), i = 1..7, with the
/// global search's seed 0 (how much the landing depends on chance); `MDSETTLE=1`: from 0.3,
/// 1 and 1.2 times the unit's value, the first round alone on the smooth and on the
/// predictable rows. `MDCSV=estimation.csv`: the record as the command line reads it
/// (`foreign_records DIR` wrote it).
pub fn md_settle(c: &foreign::ForeignCase) {
    // The record as `diagnose` has it: a further output's floor for the file's backlash.
    let d = &match std::env::var("MDCSV") {
        Ok(path) => {
            let rec = geared_servo_host::record::read(std::path::Path::new(&path), true).unwrap();
            calibrate::Data::from_record(&rec, &path).unwrap()
        }
        Err(_) => c.estimation.clone(),
    }
    .with_backlash(c.file.backlash_deg);
    let te = eq_truth(c);
    let file = file_form(c, d.sample_period_s);
    let mv = d.max_abs_v();
    let mut knobs = calibrate::default_knobs(&file, mv);
    let e = geared_servo::Effect::MeshDamping;
    knobs.push(calibrate::knob(&file, Param::Effect(e), mv));
    let (wt, _) = predictability::weigh(&te, d);
    let arg = std::env::var("MDSETTLE").unwrap_or_default();
    if let Some(v) = arg.parse::<f64>().ok().filter(|&v| v != 1.0) {
        for i in 0..8 {
            let from = v * (1.0 + 1e-6 * i as f64);
            let mut q = file;
            q.effects.set(e, from);
            for round in 0..3 {
                let w = predictability::weigh_smooth(&q, d).0;
                let w = std::slice::from_ref(&w);
                q = if round == 0 {
                    calibrate::calibrate_point(&q, &knobs, w, 0).0.params
                } else {
                    let r = calibrate::refine(&q, &knobs, w);
                    calibrate::polish_point(&r, &knobs, &calibrate::thinned(w), 20).params
                };
            }
            let f = calibrate::polish(&q, &knobs, &[predictability::weigh(&q, d).0], 20);
            let own = predictability::weigh(&f.params, d).0;
            println!(
                "MDSETTLE {} from {from:.10e}: own rows NRMSE {:.4} (kept {:.2}), on the truth's rows {:.4} (truth {:.4}) [{}]",
                c.label(),
                calibrate::nrmse(&f.params, &own),
                1.0 - own.excluded_share(),
                calibrate::nrmse(&f.params, &wt),
                calibrate::nrmse(&te, &wt),
                fmt(&te, &f.params)
            );
        }
        return;
    }
    for v in [0.3, 1.0, 1.2].map(|f| f * te.effects.mesh_damping) {
        let mut start = file;
        start.effects.set(e, v);
        for (name, w) in [
            ("smooth", predictability::weigh_smooth(&start, d).0),
            ("predictable", predictability::weigh(&start, d).0),
        ] {
            let t0 = Instant::now();
            let (pt, _) = calibrate::calibrate_point(&start, &knobs, std::slice::from_ref(&w), 0);
            println!(
                "MDSETTLE {} from {v:.4e} on {name} rows (kept {:.2}): on the truth's rows {:.4} (truth {:.4}) ({:.1}s) [{}]",
                c.label(),
                1.0 - w.excluded_share(),
                calibrate::nrmse(&pt.params, &wt),
                calibrate::nrmse(&te, &wt),
                t0.elapsed().as_secs_f64(),
                fmt(&te, &pt.params)
            );
        }
    }
}

/// Base calibration only: the global search from the file (+ background damping) on the
/// weights of the start, against the truth.
pub fn base_only(c: &foreign::ForeignCase) {
    let d = &c.estimation;
    let te = eq_truth(c);
    let file = file_form(c, d.sample_period_s);
    let mv = d.max_abs_v();
    let mut knobs = calibrate::default_knobs(&file, mv);
    let start = calibrate::with_background_damping(&file, mv).unwrap();
    knobs.push(calibrate::background_damping_knob(&file, mv));
    let (w0, _) = predictability::weigh(&start, d);
    let t0 = Instant::now();
    let f = calibrate::calibrate(&start, &knobs, std::slice::from_ref(&w0));
    let (wt, _) = predictability::weigh(&te, d);
    let t1 = Instant::now();
    let g = calibrate::calibrate(&start, &knobs, std::slice::from_ref(&wt));
    println!(
        "  global on truth weights: {:.4} (truth {:.4}) ({:.1}s) [{}]",
        g.cost.sqrt(),
        calibrate::nrmse(&te, &wt),
        t1.elapsed().as_secs_f64(),
        fmt(&te, &g.params)
    );
    // iterate: reweigh under the fit, global again from it
    let mut p = f.params;
    for i in 0..3 {
        let (wi, _) = predictability::weigh(&p, d);
        let h = calibrate::calibrate(&p, &knobs, std::slice::from_ref(&wi));
        p = h.params;
        println!(
            "  iter {i}: {:.4} on its weights (truth {:.4}); on truth weights {:.4} [{}]",
            h.cost.sqrt(),
            calibrate::nrmse(&te, &wi),
            calibrate::nrmse(&p, &wt),
            fmt(&te, &p)
        );
    }
    println!(
        "BASE {}: {:.4} on w0 (truth {:.4}) ({:.1}s) on truth weights {:.4} (truth {:.4}) [{}]",
        c.label(),
        f.cost.sqrt(),
        calibrate::nrmse(&te, &w0),
        t0.elapsed().as_secs_f64(),
        calibrate::nrmse(&f.params, &wt),
        calibrate::nrmse(&te, &wt),
        fmt(&te, &f.params)
    );
}

/// Width of the truth's basin: the robust cost on the truth's weights with one knob moved.
pub fn widths(c: &foreign::ForeignCase) {
    let d = &c.estimation;
    let te = eq_truth(c);
    let mv = d.max_abs_v();
    let mut knobs = calibrate::default_knobs(&te, mv);
    knobs.push(calibrate::knob(
        &te,
        Param::Effect(geared_servo::Effect::MeshDamping),
        mv,
    ));
    let (wt, _) = predictability::weigh(&te, d);
    let r = calibrate::robust(std::slice::from_ref(&wt));
    println!(
        "WIDTHS {} truth robust {:.4} plain {:.4}",
        c.label(),
        calibrate::cost(&te, &r).sqrt(),
        calibrate::nrmse(&te, &wt)
    );
    for k in &knobs {
        let v = calibrate::get(&te, k.param);
        let row: Vec<String> = [
            -0.1, -0.05, -0.02, -0.01, -0.005, 0.005, 0.01, 0.02, 0.05, 0.1,
        ]
        .iter()
        .map(|f| {
            let mut q = te;
            calibrate::set(&mut q, k.param, v * (1.0 + f));
            format!(
                "{:+.3}:{:.3}/{:.3}",
                f,
                calibrate::cost(&q, &r).sqrt(),
                calibrate::nrmse(&q, &wt)
            )
        })
        .collect();
        println!("  {:28} {}", k.name(), row.join(" "));
    }
}

/// The smoothness test: kept share at the truth, and a calibration on smooth rows.
pub fn smooth(c: &foreign::ForeignCase) {
    let d = &c.estimation;
    let te = eq_truth(c);
    let sigma = noise::sigma(&d.y);
    let s = predictability::Smoothness::default();
    let fl = |w: &calibrate::Data| noise::floor_nrmse(sigma, &w.weight, w.norm);
    let prt = predictability::assess_smooth(&te, d, &s, sigma);
    let wt = d.with_weights(&prt.weight);
    println!(
        "SMOOTH {}: at truth excl {:.2}, truth {:.4} floor {:.4}",
        c.label(),
        prt.excluded_share,
        calibrate::nrmse(&te, &wt),
        fl(&wt)
    );
    let file = file_form(c, d.sample_period_s);
    let mv = d.max_abs_v();
    let mut knobs = calibrate::default_knobs(&file, mv);
    let start = calibrate::with_background_damping(&file, mv).unwrap();
    knobs.push(calibrate::background_damping_knob(&file, mv));
    let mut p = start;
    for i in 0..3 {
        let t0 = Instant::now();
        let pr = predictability::assess_smooth(&p, d, &s, sigma);
        let w = d.with_weights(&pr.weight);
        let f = if i == 0 {
            calibrate::calibrate(&p, &knobs, std::slice::from_ref(&w))
        } else {
            calibrate::polish(
                &calibrate::refine(&p, &knobs, std::slice::from_ref(&w)),
                &knobs,
                std::slice::from_ref(&w),
                20,
            )
        };
        p = f.params;
        println!("  iter {i}: excl {:.2} fit {:.4} truth {:.4} floor {:.4} on truth-smooth rows: fit {:.4} ({:.1}s) [{}]", pr.excluded_share, f.cost.sqrt(), calibrate::nrmse(&te, &w), fl(&w), calibrate::nrmse(&p, &wt), t0.elapsed().as_secs_f64(), fmt(&te, &p));
    }
    let (wf, prf) = predictability::weigh(&p, d);
    let f = calibrate::polish(&p, &knobs, std::slice::from_ref(&wf), 20);
    println!(
        "  fine weights at the fit: excl {:.2} polish {:.4} truth {:.4} floor {:.4} [{}]",
        prf.excluded_share,
        f.cost.sqrt(),
        calibrate::nrmse(&te, &wf),
        fl(&wf),
        fmt(&te, &f.params)
    );
}

/// Debug: the expected effects set on the final fit, costs before and after a polish.
pub fn with_expected(c: &foreign::ForeignCase, out: &geared_servo_host::diagnose::Outcome) {
    let d = &c.estimation;
    let w = d.with_weights(&out.weights[0]);
    let mut q = out.final_fit.params;
    let mut knobs = out.final_fit.knobs.clone();
    for &(e, v) in &c.expected {
        q.effects.set(e, c.expected_fitted(e, v));
        knobs.push(calibrate::knob(
            &out.final_fit.params,
            Param::Effect(e),
            d.max_abs_v(),
        ));
    }
    let r = calibrate::robust(std::slice::from_ref(&w));
    println!(
        "  final: plain {:.4} robust {:.4}; with expected effects: plain {:.4} robust {:.4}",
        calibrate::nrmse(&out.final_fit.params, &w),
        calibrate::cost(&out.final_fit.params, &r).sqrt(),
        calibrate::nrmse(&q, &w),
        calibrate::cost(&q, &r).sqrt()
    );
    let f = calibrate::polish(&q, &knobs, std::slice::from_ref(&w), 20);
    println!(
        "  polished with them: plain {:.4} values {:?}",
        f.cost.sqrt(),
        f.values
    );
}

/// How visible the hidden effects are: the truth with and without them on the truth's rows.
pub fn visibility(c: &foreign::ForeignCase) {
    let d = &c.estimation;
    let te = eq_truth(c);
    let mut without = te;
    for &(e, _) in &c.expected {
        without.effects.set(e, 0.0);
    }
    let (wt, _) = predictability::weigh(&te, d);
    let sigma = noise::sigma(&d.y);
    let v = &c.validation;
    let (wv, _) = predictability::weigh(&te, v);
    println!(
        "VISIBILITY {}: estimation rows {:.2}: with {:.4} without {:.4} floor {:.4}; validation rows {:.2}: with {:.4} without {:.4}",
        c.label(), 1.0 - wt.excluded_share(),
        calibrate::nrmse(&te, &wt), calibrate::nrmse(&without, &wt), noise::floor_nrmse(sigma, &wt.weight, wt.norm),
        1.0 - wv.excluded_share(), calibrate::nrmse(&te, &wv), calibrate::nrmse(&without, &wv)
    );
}

/// Per burst: the emulator at the truth against the clean reference record, and against a
/// copy of itself with the load inertia moved by 1e-6 (chaos).
pub fn bursts(c: &foreign::ForeignCase) {
    let ss = foreign::SteppedSine::default();
    let v = ss.volts(foreign::SAMPLE_PERIOD_S);
    let (clean, _) =
        foreign::reference_run(&c.truth, c.second_mode.as_ref(), &v, foreign::FINE_STEP_S).unwrap();
    let mut t = c.truth;
    t.sample_period_s = foreign::SAMPLE_PERIOD_S;
    let em = calibrate::simulate(&t, &c.estimation).unwrap().y;
    let mut q = t;
    q.load.inertia_kg_m2 *= 1.000001;
    let em2 = calibrate::simulate(&q, &c.estimation).unwrap().y;
    let (nb, nr) = ss.period_samples(foreign::SAMPLE_PERIOD_S);
    let per = nb + nr;
    let rel = |a: &[f64], b: &[f64]| {
        let e: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
        let n: f64 = b.iter().map(|y| y * y).sum();
        (e / n.max(1e-30)).sqrt()
    };
    let line: Vec<String> = (0..ss.bursts)
        .map(|i| {
            let r = i * per..(i + 1) * per;
            format!(
                "{:.0}:{:.3}/{:.3}",
                ss.frequency_hz(i),
                rel(&em[r.clone()], &clean[r.clone()]),
                rel(&em2[r.clone()], &em[r])
            )
        })
        .collect();
    println!(
        "BURSTS {} (f: emulator-vs-reference / emulator-vs-1e-6): {}",
        c.label(),
        line.join(" ")
    );
}

/// Time of one simulation of the estimation record.
pub fn sim_time(c: &foreign::ForeignCase) {
    let mut t = c.truth;
    t.sample_period_s = foreign::SAMPLE_PERIOD_S;
    let t0 = Instant::now();
    let mut s = 0.0;
    for _ in 0..100 {
        s += calibrate::simulate(&t, &c.estimation).unwrap().y[1000];
    }
    let dt = t0.elapsed().as_secs_f64() / 100.0;
    println!(
        "SIM {}: {:.2} ms per run of {} rows ({:.0} ns/step) {s}",
        c.label(),
        dt * 1e3,
        c.estimation.y.len(),
        dt * 1e9 / c.estimation.y.len() as f64
    );
}

/// The truth on the rows each predictability setting keeps, over the floor.
pub fn ensembles(c: &foreign::ForeignCase) {
    let d = &c.estimation;
    let te = eq_truth(c);
    let sigma = noise::sigma(&d.y);
    let mut line = String::new();
    for (a, b, th) in [(1e-3, 5e-3, 0.05), (1e-2, 5e-2, 0.1)] {
        let s = predictability::Settings {
            inertia_perturbation: a,
            friction_perturbation: b,
            threshold: th,
            ..Default::default()
        };
        let pr = predictability::assess_with(&te, d, &s);
        let w = d.with_weights(&pr.weight);
        let fl = noise::floor_nrmse(sigma, &w.weight, w.norm);
        line += &format!(
            " [{a:.0e},{b:.0e},{th}]: kept {:.2} ratio {:.2}",
            1.0 - pr.excluded_share,
            calibrate::nrmse(&te, &w) / fl
        );
    }
    let a = predictability::assess_with(&te, d, &predictability::Settings::default());
    let b = predictability::assess_with(
        &te,
        d,
        &predictability::Settings {
            inertia_perturbation: 1e-2,
            friction_perturbation: 5e-2,
            threshold: 0.1,
            ..Default::default()
        },
    );
    let u: Vec<f64> = a
        .weight
        .iter()
        .zip(&b.weight)
        .map(|(x, y)| x.min(*y))
        .collect();
    let w = d.with_weights(&u);
    let fl = noise::floor_nrmse(sigma, &w.weight, w.norm);
    line += &format!(
        " union: kept {:.2} ratio {:.2}",
        1.0 - w.excluded_share(),
        calibrate::nrmse(&te, &w) / fl
    );
    println!("ENSEMBLES {}:{line}", c.label());
}

/// The share of each record's rows kept as predictable, and the NRMSE there against its
/// floor, under the truth and (`PARAMS=FILE.toml`, e.g. a diagnosis's calibrated model)
/// under another parameter set: does a model escape a record by calling it unpredictable?
fn shares(c: &foreign::ForeignCase) {
    // The truth as it is (a record with the current shows the resistance) and in the
    // model's form with the file's resistance (a tachometer's or an angle's record does not).
    let mut models = vec![
        ("truth".to_string(), c.truth),
        ("truth, file's R".to_string(), eq_truth(c)),
    ];
    if let Ok(path) = std::env::var("PARAMS") {
        let text = std::fs::read_to_string(&path).unwrap();
        models.push((path.clone(), params_file::parse(&text, &path).unwrap()));
    }
    for (name, p) in &models {
        let mut line = String::new();
        for (rec, d) in [("est", &c.estimation), ("val", &c.validation)] {
            let mut q = *p;
            q.sample_period_s = d.sample_period_s;
            let (w, _) = predictability::weigh(&q, d);
            let fl = noise::floor_nrmse(noise::sigma(&d.y), &w.weight, w.norm);
            let a = predictability::assess_with(&q, d, &predictability::Settings::default());
            let b = predictability::assess_with(&q, d, &predictability::WIDE);
            if std::env::var("SHARES_SPANS").is_ok() {
                let h = d.sample_period_s;
                let sp: Vec<String> = a
                    .spans
                    .iter()
                    .map(|(x, y)| format!("{:.3}-{:.3}", *x as f64 * h, *y as f64 * h))
                    .collect();
                println!("  {rec} default spans: {}", sp.join(" "));
            }
            if std::env::var("SHARES_RATIO").is_ok() && rec == "val" {
                let dm = d.motion();
                let center = calibrate::output(&q, &dm).unwrap();
                let scale: f64 = std::env::var("SHARES_RATIO")
                    .unwrap()
                    .parse()
                    .unwrap_or(1.0);
                let st = predictability::Settings {
                    inertia_perturbation: 1e-3 * scale,
                    friction_perturbation: 5e-3 * scale,
                    ..Default::default()
                };
                let ms: Vec<Vec<f64>> = (0..4)
                    .map(|m| calibrate::output(&predictability::member(&q, m, &st), &dm).unwrap())
                    .collect();
                // The assessment's own window (`Settings::window_s`).
                let w = ((st.window_s / d.sample_period_s).round() as usize).max(1);
                let mut out = String::new();
                for j in 0..center.len() / w {
                    let (mut sp, mut sg) = (0.0, 0.0);
                    for k in j * w..(j + 1) * w {
                        sg += center[k] * center[k];
                        sp += ms.iter().map(|y| (y[k] - center[k]).powi(2)).sum::<f64>()
                            / ms.len() as f64;
                    }
                    out += &format!(" {:.3}", (sp / sg).sqrt());
                }
                println!(
                    "  val spread/signal per {:.0} ms window:{out}",
                    st.window_s * 1e3
                );
            }
            let r = predictability::assess_restarts(&q, d);
            let r_out = r.iter().filter(|x| **x < 0.5).count() as f64 / r.len().max(1) as f64;
            line += &format!(
                "  {rec}: kept {:.3} (out: default {:.3}, wide {:.3}, restarts {:.3}), NRMSE {:.4} (floor {:.4}; on every row {:.4})",
                1.0 - w.excluded_share(),
                a.excluded_share,
                b.excluded_share,
                r_out,
                calibrate::nrmse(&q, &w),
                fl,
                calibrate::nrmse(&q, d)
            );
        }
        println!("SHARES {} under {name}:{line}", c.label());
    }
}

/// Per burst at the truth on the kept rows: kept share and residual energy over noise energy.
pub fn kept_bursts(c: &foreign::ForeignCase) {
    let d = &c.estimation;
    let te = eq_truth(c);
    let sigma = noise::sigma(&d.y);
    let pr = predictability::assess(&te, d);
    let em = calibrate::simulate(&te, d).unwrap().y;
    let ss = foreign::SteppedSine::default();
    let (nb, nr) = ss.period_samples(foreign::SAMPLE_PERIOD_S);
    let per = nb + nr;
    let line: Vec<String> = (0..ss.bursts)
        .map(|i| {
            let r = i * per..((i + 1) * per).min(d.y.len());
            let kept: f64 = pr.weight[r.clone()].iter().sum();
            let e: f64 = r
                .clone()
                .map(|k| pr.weight[k] * (d.y[k] - em[k]).powi(2))
                .sum();
            format!(
                "{:.0}:{:.2}/{:.1}",
                ss.frequency_hz(i),
                kept / per as f64,
                e / (sigma * sigma * kept.max(1.0))
            )
        })
        .collect();
    println!(
        "KEPT {} (f: kept share / residual over noise energy): {}",
        c.label(),
        line.join(" ")
    );
}

/// The current pickup term in the emulator and in the reference.
pub fn pickup(c: &foreign::ForeignCase) {
    let ss = foreign::SteppedSine::default();
    let v = ss.volts(foreign::SAMPLE_PERIOD_S);
    let mut t = c.truth;
    t.sample_period_s = foreign::SAMPLE_PERIOD_S;
    let mut t0 = t;
    t0.effects.tach_current_coupling = 0.0;
    let (rw, _) = foreign::reference_run(&t, None, &v, foreign::FINE_STEP_S).unwrap();
    let (r0, _) = foreign::reference_run(&t0, None, &v, foreign::FINE_STEP_S).unwrap();
    let ew = calibrate::simulate(&t, &c.estimation).unwrap().y;
    let e0 = calibrate::simulate(&t0, &c.estimation).unwrap().y;
    let (nb, nr) = ss.period_samples(foreign::SAMPLE_PERIOD_S);
    let per = nb + nr;
    for i in [17usize, 19, 20, 21] {
        let r = i * per..(i + 1) * per;
        let dr: Vec<f64> = r.clone().map(|k| rw[k] - r0[k]).collect();
        let de: Vec<f64> = r.clone().map(|k| ew[k] - e0[k]).collect();
        let base: Vec<f64> = r.clone().map(|k| e0[k] - r0[k]).collect();
        let rms = |x: &[f64]| (x.iter().map(|a| a * a).sum::<f64>() / x.len() as f64).sqrt();
        let diff: Vec<f64> = dr.iter().zip(&de).map(|(a, b)| a - b).collect();
        let lag: Vec<f64> = (1..de.len()).map(|k| dr[k] - de[k - 1]).collect();
        println!("PICKUP {} burst {:.0} Hz: rms pickup ref {:.4e} emu {:.4e} diff {:.4e} (vs emu one row late {:.4e}); no-pickup emu-ref {:.4e}; sigma {:.4e}", c.label(), ss.frequency_hz(i), rms(&dr), rms(&de), rms(&diff), rms(&lag), rms(&base), noise::sigma(&c.estimation.y));
    }
}

/// A candidate judged against a base: the truth with the effect, the base without it, on
/// each one's rows and on the common rows.
pub fn judge(c: &foreign::ForeignCase) {
    let d = &c.estimation;
    let te = eq_truth(c);
    let mut without = te;
    for &(e, _) in &c.expected {
        without.effects.set(e, 0.0);
    }
    let (wt, _) = predictability::weigh(&te, d);
    let (ww, _) = predictability::weigh(&without, d);
    let wc = d.with_rows_both_keep(&wt, &ww);
    println!("JUDGE {}: truth on own {:.4} (kept {:.2}); without on own {:.4} (kept {:.2}); common (kept {:.2}): truth {:.4} without {:.4}",
        c.label(), calibrate::nrmse(&te, &wt), 1.0 - wt.excluded_share(), calibrate::nrmse(&without, &ww), 1.0 - ww.excluded_share(),
        1.0 - wc.excluded_share(), calibrate::nrmse(&te, &wc), calibrate::nrmse(&without, &wc));
}

/// diagnose with only the case's effects as candidates.
pub fn only(c: &foreign::ForeignCase) {
    let opts = Options {
        candidates: c.expected.iter().map(|x| x.0).collect(),
        ..Options::default()
    };
    let out = c.diagnose(&opts).unwrap();
    println!(
        "ONLY {}: steps {:?} unexplained {} final {:.4} base {:.4} rejected {:?}",
        c.label(),
        out.steps
            .iter()
            .map(|s| format!("{}={:.3e}", s.effect, s.value))
            .collect::<Vec<_>>(),
        out.unexplained,
        out.final_fit.cost.sqrt(),
        out.base.cost.sqrt(),
        out.rejected
            .iter()
            .map(|r| format!("{} {:.3e}: {}", r.effect, r.value, r.reason))
            .collect::<Vec<_>>()
    );
    println!("  base [{}]", fmt(&eq_truth(c), &out.base.params));
}

/// The friction valley: the motor's and the load's Coulomb friction moved against each other
/// with their sum at the motor (T_m + T_L/N) held, from `fit`; the cost on `w` (plain and
/// robust) at each point, and where a polish from there ends.
pub fn valley(
    c: &foreign::ForeignCase,
    fit: &calibrate::Fit,
    w: &calibrate::Data,
    te: &ActuatorParams,
) {
    let n = 50.0;
    let p0 = fit.params;
    let tm = calibrate::get(&p0, Param::MotorFriction);
    let tl = calibrate::get(&p0, Param::LoadFriction);
    let total = tm + tl / n;
    let rw = calibrate::robust(std::slice::from_ref(w));
    println!(
        "  valley of {} (truth T_m {:.3e} T_L {:.3e}; fit {:.3e} {:.3e})",
        c.label(),
        calibrate::get(te, Param::MotorFriction),
        calibrate::get(te, Param::LoadFriction),
        tm,
        tl
    );
    for share in [0.3, 0.4, 0.5, 0.55, 0.6, 0.65, 0.7, 0.76, 0.8, 0.85] {
        let mut q = p0;
        calibrate::set(&mut q, Param::MotorFriction, share * total);
        calibrate::set(&mut q, Param::LoadFriction, (1.0 - share) * total * n);
        let plain = calibrate::nrmse(&q, w);
        let robust = calibrate::cost(&q, &rw);
        let f = calibrate::polish(&q, &fit.knobs, std::slice::from_ref(w), 20);
        println!(
            "  T_m share {share:.2}: plain {plain:.4} robust {robust:.1} -> polished {:.4} [{}]",
            f.cost.sqrt(),
            fmt(te, &f.params)
        );
    }
}

/// Which of the final fit, the base and the truth the search's objective prefers, on the
/// smooth rows (robust loss, thinned, as the global search sees them) and the predictable
/// rows (plain) of each.
pub fn trap(fin: &ActuatorParams, base: &ActuatorParams, d: &calibrate::Data, te: &ActuatorParams) {
    let who = [("final", fin), ("base", base), ("truth", te)];
    for (name, p) in who {
        let (ws, _) = predictability::weigh_smooth(p, d);
        let (wp, _) = predictability::weigh(p, d);
        let th = calibrate::thinned(std::slice::from_ref(&ws));
        let rs = calibrate::robust(&th);
        let rw = calibrate::robust(std::slice::from_ref(&ws));
        let costs: Vec<String> = who
            .iter()
            .map(|(n, q)| {
                format!(
                    "{n}: robust thinned {:.4e} whole {:.4e} plain thinned {:.4} whole {:.4} fine {:.4}",
                    calibrate::cost(q, &rs),
                    calibrate::cost(q, &rw),
                    calibrate::cost(q, &th).sqrt(),
                    calibrate::nrmse(q, &ws),
                    calibrate::nrmse(q, &wp)
                )
            })
            .collect();
        println!(
            "  rows of {name} (smooth excl {:.2}, fine excl {:.2}): {}",
            ws.excluded_share(),
            wp.excluded_share(),
            costs.join(" | ")
        );
    }
}

/// Per burst kept by the thinning: how far the run over the thinned record departs from the
/// whole run on the same rows (RMS of the difference over the RMS of the whole run), on the
/// smooth rows of `p`, in the first 0.1 s and after.
pub fn thin(name: &str, p: &ActuatorParams, d: &calibrate::Data) {
    let (ws, _) = predictability::weigh_smooth(p, d);
    let mut idx = ws.clone();
    idx.y = (0..idx.y.len()).map(|k| k as f64).collect();
    let map: Vec<usize> = idx
        .thinned(calibrate::SEARCH_ROWS)
        .y
        .iter()
        .map(|v| *v as usize)
        .collect();
    let th = ws.thinned(calibrate::SEARCH_ROWS);
    let whole = calibrate::output(p, &ws).unwrap();
    let part = calibrate::output(p, &th).unwrap();
    let starts = ws.restarts();
    let mut tot = (0.0, 0.0);
    for &(a, b) in &starts {
        let rows: Vec<(usize, usize)> = map
            .iter()
            .enumerate()
            .filter(|(_, &k)| k >= a && k < b)
            .map(|(i, &k)| (i, k))
            .collect();
        if rows.is_empty() {
            continue;
        }
        let mut e = [(0.0, 0.0, 0.0); 2];
        for &(i, k) in &rows {
            let j = if k - a < 200 { 0 } else { 1 };
            let wgt = ws.weight[k];
            e[j].0 += wgt * (part[i] - whole[k]).powi(2);
            e[j].1 += wgt * whole[k].powi(2);
            e[j].2 += wgt;
            tot.0 += wgt * (part[i] - whole[k]).powi(2);
            tot.1 += wgt * whole[k].powi(2);
        }
        let r = |x: (f64, f64, f64)| if x.1 > 0.0 { (x.0 / x.1).sqrt() } else { 0.0 };
        if r(e[0]) > 0.02 || r(e[1]) > 0.02 {
            println!("  {name} burst at {:.2} s: first 0.1 s {:.3} ({:.0} rows kept), after {:.3} ({:.0} rows kept)", a as f64 * d.sample_period_s, r(e[0]), e[0].2, r(e[1]), e[1].2);
        }
    }
    println!(
        "  {name}: thinned vs whole on kept smooth rows {:.4}",
        (tot.0 / tot.1).sqrt()
    );
}

/// The validation record under each model: its kept share, each model's NRMSE on each one's
/// kept rows, and the floor there.
pub fn val(c: &foreign::ForeignCase, ms: &[(&str, &ActuatorParams)]) {
    // `EST=1` beside `VAL=1`: the estimation record instead.
    let v = if std::env::var("EST").is_ok() {
        &c.estimation
    } else {
        &c.validation
    };
    let sigma = noise::sigma(&v.y);
    let ws: Vec<calibrate::Data> = ms
        .iter()
        .map(|(_, p)| predictability::weigh(p, v).0)
        .collect();
    for ((n, _), w) in ms.iter().zip(&ws) {
        let fl = noise::floor_nrmse(sigma, &w.weight, w.norm);
        let row: Vec<String> = ms
            .iter()
            .map(|(m, p)| format!("{m} {:.4}", calibrate::nrmse(p, w)))
            .collect();
        println!(
            "VAL rows of {n}: excl {:.3} kept {} floor {:.4}: {}",
            w.excluded_share(),
            w.weight.iter().filter(|x| **x > 0.5).count(),
            fl,
            row.join(", ")
        );
    }
}

/// Starts along the friction valley from `fin` (a model without stiction): the stiction
/// ratio r with both Coulomb frictions scaled by 2/(1 + r) (the mean of the breakaway and
/// the running friction kept), each weighted at its point, polished with the ratio free and
/// weighted anew (as `settle::polish_on_own_rows`); against `fin` on the rows both keep, on
/// each one's own rows, and the floor of each record there.
pub fn valley_starts(c: &foreign::ForeignCase, fin: &calibrate::Fit) {
    let data = [c.estimation.clone(), c.validation.clone()];
    let sig: Vec<f64> = data.iter().map(|d| noise::sigma(&d.y)).collect();
    let weigh = |p: &ActuatorParams| -> Vec<calibrate::Data> {
        data.iter().map(|d| predictability::weigh(p, d).0).collect()
    };
    let floor = |w: &[calibrate::Data]| -> f64 {
        let f: f64 = w
            .iter()
            .zip(&sig)
            .map(|(d, s)| noise::floor_nrmse(*s, &d.weight, d.norm).powi(2))
            .sum::<f64>()
            / w.len() as f64;
        f.sqrt()
    };
    let wf = weigh(&fin.params);
    let fc = calibrate::cost(&fin.params, &wf);
    println!(
        "VSTART {}: final {:.4} on its rows (floor {:.4})",
        c.label(),
        fc.sqrt(),
        floor(&wf)
    );
    let mv = c.estimation.max_abs_v().max(c.validation.max_abs_v());
    let mut knobs = fin.knobs.clone();
    knobs.push(calibrate::knob(
        &fin.params,
        Param::Effect(geared_servo::Effect::StictionRatio),
        mv,
    ));
    for r in [1.5, 2.0, 2.5, 3.0] {
        let mut q = fin.params;
        q.effects.set(geared_servo::Effect::StictionRatio, r);
        q.motor.coulomb_friction_nm *= 2.0 / (1.0 + r);
        q.load.coulomb_friction_nm *= 2.0 / (1.0 + r);
        let f = calibrate::polish(&q, &knobs, &weigh(&q), 20);
        let w = weigh(&f.params);
        let common: Vec<calibrate::Data> = data
            .iter()
            .zip(wf.iter().zip(&w))
            .map(|(d, (a, b))| d.with_rows_both_keep(a, b))
            .collect();
        println!(
            "VSTART {} r0 {r}: ratio {:.3}; own {:.4} (floor {:.4}); on the rows both keep {:.4} against the final's {:.4} (floor {:.4})",
            c.label(),
            f.params.effects.get(geared_servo::Effect::StictionRatio),
            calibrate::cost(&f.params, &w).sqrt(),
            floor(&w),
            calibrate::cost(&f.params, &common).sqrt(),
            calibrate::cost(&fin.params, &common).sqrt(),
            floor(&common)
        );
    }
}

/// The suite's identifiability witness ([`foreign::identifiability`]: the polish and the
/// local search then the polish, from the truth without the hidden effect) and, when given,
/// `fin` (what `diagnose` ended with, with its knobs `fk`, as it is and polished on the
/// truth's rows), each on the truth's predictable rows of each record as a ratio to the
/// truth's NRMSE there: whether a model without the effect follows the records as well as
/// the truth.
pub fn witness(c: &foreign::ForeignCase, fin: Option<(&ActuatorParams, &[calibrate::Knob])>) {
    if !matches!(c.kind, foreign::Kind::Single(_)) {
        return;
    }
    if let Some((f, _)) = fin {
        println!(
            "WITNESS {}: truth {:?}; final effects {:?}",
            c.label(),
            c.expected,
            geared_servo::Effect::ALL
                .iter()
                .filter(|e| f.effects.get(**e) != 0.0)
                .map(|e| (e.name(), f.effects.get(*e)))
                .collect::<Vec<_>>()
        );
    }
    let id = foreign::identifiability(c);
    let mut t = calibrate::with_measured_stiffness(&c.truth).unwrap();
    t.sample_period_s = c.estimation.sample_period_s;
    let we = predictability::weigh(&t, &c.estimation).0;
    let wv = predictability::weigh(&t, &c.validation).0;
    let both = [we.clone(), wv.clone()];
    // The final, polished on the truth's rows too (a witness may be polished there).
    let fp = fin.map(|(f, fk)| (*f, calibrate::polish(f, fk, &both, 20).params));
    for (i, (name, d)) in [("estimation", &we), ("validation", &wv)]
        .into_iter()
        .enumerate()
    {
        let tn = calibrate::nrmse(&t, d);
        let r = |p: &ActuatorParams| calibrate::nrmse(p, d) / tn;
        let tried: Vec<String> = id
            .tried
            .iter()
            .zip(["polished", "searched"])
            .map(|((_, n), what)| format!("{what} x{:.3}", n[2 * i + 1] / n[2 * i]))
            .collect();
        let finals = fp
            .map(|(f, p)| format!(", final x{:.3}, final polished x{:.3}", r(&f), r(&p)))
            .unwrap_or_default();
        println!(
            "WITNESS {} {name}: truth {tn:.4}; {}{finals}",
            c.label(),
            tried.join(", "),
        );
    }
}

/// The structural refit of the hidden effects, as `diagnose` would run it if it chose them:
/// the global calibration from the file (+ background damping) with the effects switched on
/// at `STRUCT`'s share of their expected values (default 1), their knobs added, on the
/// weights of the start, then reweighed and polished; against the truth on the same rows.
pub fn structural(c: &foreign::ForeignCase) {
    let d = &c.estimation;
    let te = eq_truth(c);
    let share: f64 = std::env::var("STRUCT")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    let file = file_form(c, d.sample_period_s);
    let mv = d.max_abs_v();
    let mut knobs = calibrate::default_knobs(&file, mv);
    let mut start = calibrate::with_background_damping(&file, mv).unwrap();
    knobs.push(calibrate::background_damping_knob(&file, mv));
    for &(e, v) in &c.expected {
        let x = c.expected_fitted(e, v);
        // A ratio (stiction) scales from 1, the others from 0.
        let x = if e == geared_servo::Effect::StictionRatio {
            1.0 + share * (x - 1.0)
        } else {
            share * x
        };
        start.effects.set(e, x);
        knobs.push(calibrate::knob(&file, Param::Effect(e), mv));
    }
    let t0 = Instant::now();
    let (w0, _) = predictability::weigh(&start, d);
    let f = calibrate::calibrate(&start, &knobs, std::slice::from_ref(&w0));
    let (w1, _) = predictability::weigh(&f.params, d);
    let g = calibrate::polish(&f.params, &knobs, std::slice::from_ref(&w1), 20);
    let (w2, _) = predictability::weigh(&g.params, d);
    println!(
        "STRUCT {} x{share}: {:.4} on own rows (truth {:.4}, floor {:.4}) ({:.1}s) [{}] effects {:?}",
        c.label(),
        calibrate::nrmse(&g.params, &w2),
        calibrate::nrmse(&te, &w2),
        noise::floor_nrmse(noise::sigma(&d.y), &w2.weight, w2.norm),
        t0.elapsed().as_secs_f64(),
        fmt(&te, &g.params),
        c.expected
            .iter()
            .map(|&(e, v)| format!(
                "{e} {:.4e} (expected {:.4e})",
                g.params.effects.get(e),
                c.expected_fitted(e, v)
            ))
            .collect::<Vec<_>>()
    );
    for (name, ww) in [("start rows", &w0), ("fit rows", &w2)] {
        let r = calibrate::robust(std::slice::from_ref(ww));
        println!(
            "  on the {name}: robust fit {:.4} truth {:.4}; plain fit {:.4} truth {:.4}; start robust {:.4}",
            calibrate::cost(&g.params, &r).sqrt(),
            calibrate::cost(&te, &r).sqrt(),
            calibrate::nrmse(&g.params, ww),
            calibrate::nrmse(&te, ww),
            calibrate::cost(&start, &r).sqrt(),
        );
    }
    if std::env::var("SEEDS").is_ok() {
        let r0 = calibrate::robust(std::slice::from_ref(&w0));
        for seed in 1..6 {
            let h = calibrate::calibrate_seeded(&start, &knobs, std::slice::from_ref(&w0), seed);
            println!(
                "  seed {seed}: robust {:.4} (truth {:.4}) [{}] effects {:?}",
                calibrate::cost(&h.params, &r0).sqrt(),
                calibrate::cost(&te, &r0).sqrt(),
                fmt(&te, &h.params),
                c.expected
                    .iter()
                    .map(|&(e, _)| h.params.effects.get(e))
                    .collect::<Vec<_>>()
            );
        }
    }
    if let Some(mult) = std::env::var("BUDGET")
        .ok()
        .and_then(|s| s.parse::<usize>().ok())
    {
        let r0 = calibrate::robust(std::slice::from_ref(&w0));
        for seed in 0..3 {
            let t1 = Instant::now();
            let (cst, p) = calibrate::evolve_with(
                &start,
                &knobs,
                &r0,
                calibrate::POPULATION
                    * if std::env::var("BIGPOP").is_ok() {
                        2
                    } else {
                        1
                    },
                mult * calibrate::EVALS_PER_KNOB * knobs.len() / 2,
                0.5,
                seed,
            );
            let h = calibrate::levenberg_marquardt(&p, &knobs, &r0);
            println!(
                "  budget x{mult} seed {seed}: evolve {:.4}, +LM {:.4} (truth {:.4}) ({:.1}s) [{}] effects {:?}",
                cst.sqrt(),
                calibrate::cost(&h.params, &r0).sqrt(),
                calibrate::cost(&te, &r0).sqrt(),
                t1.elapsed().as_secs_f64(),
                fmt(&te, &h.params),
                c.expected.iter().map(|&(e, _)| h.params.effects.get(e)).collect::<Vec<_>>()
            );
        }
    }
    if std::env::var("PROFILE").is_ok() {
        // The friction subspace searched alone from the fit (its inertias, stiffness and
        // backlash held), then everything polished.
        let r0 = calibrate::robust(std::slice::from_ref(&w0));
        let fk: Vec<calibrate::Knob> = knobs
            .iter()
            .filter(|k| matches!(k.param, Param::Effect(_)) || k.name().contains("coulomb"))
            .cloned()
            .collect();
        for seed in 0..3 {
            let t1 = Instant::now();
            let (cst, p) = calibrate::evolve_with(
                &g.params,
                &fk,
                &r0,
                calibrate::POPULATION,
                calibrate::EVALS_PER_KNOB * fk.len(),
                0.5,
                seed,
            );
            let h = calibrate::levenberg_marquardt(&p, &knobs, &r0);
            println!(
                "  profile seed {seed} ({} knobs): evolve {:.4}, +LM {:.4} (truth {:.4}, fit {:.4}) ({:.1}s) [{}] effects {:?}",
                fk.len(),
                cst.sqrt(),
                calibrate::cost(&h.params, &r0).sqrt(),
                calibrate::cost(&te, &r0).sqrt(),
                calibrate::cost(&g.params, &r0).sqrt(),
                t1.elapsed().as_secs_f64(),
                fmt(&te, &h.params),
                c.expected.iter().map(|&(e, _)| h.params.effects.get(e)).collect::<Vec<_>>()
            );
        }
    }
    if let Ok(which) = std::env::var("SCAN") {
        // `SCAN=truth`: on the truth's predictable rows; otherwise on the start's.
        let wt = predictability::weigh(&te, d).0;
        let r0 = calibrate::robust(std::slice::from_ref(if which == "truth" {
            &wt
        } else {
            &w0
        }));
        for k in &knobs {
            let line: Vec<String> = [0.5, 0.7, 0.85, 0.95, 1.0, 1.05, 1.15, 1.4, 2.0]
                .iter()
                .map(|f| {
                    let mut q = te;
                    let v = calibrate::get(&te, k.param);
                    let v = if k.param == Param::Effect(geared_servo::Effect::StictionRatio) {
                        1.0 + f * (v - 1.0)
                    } else {
                        f * v
                    };
                    calibrate::set(&mut q, k.param, v);
                    format!("{f}:{:.4}", calibrate::cost(&q, &r0).sqrt())
                })
                .collect();
            println!("  scan {}: {}", k.name(), line.join(" "));
        }
    }
    let ft = calibrate::polish(&te, &knobs, std::slice::from_ref(&w2), 20);
    println!(
        "  polished from the truth on the fit's rows: {:.4} [{}] values {:?}",
        ft.cost.sqrt(),
        fmt(&te, &ft.params),
        ft.values
    );
}

/// `FINISH=1`: what a further settle of the final model on both records reaches (`NEEDLE=1`:
/// and a small-step CMA-ES on the final's rows), each on its own rows, against the truth
/// (exact: the unit itself) on the same rows; deviations against the unit in the file's
/// constants.
fn finish(
    c: &foreign::ForeignCase,
    out: &geared_servo_host::diagnose::Outcome,
    _te: &ActuatorParams,
) {
    let data = [c.estimation.clone(), c.validation.clone()];
    if out.weights.len() < 2 {
        println!("  FINISH {}: no second pass", c.label());
        return;
    }
    let mut truth = calibrate::with_measured_stiffness(&c.truth).unwrap();
    truth.sample_period_s = c.estimation.sample_period_s;
    let mut eq =
        calibrate::with_measured_stiffness(&foreign::in_file_constants(&c.truth, &c.file)).unwrap();
    eq.sample_period_s = c.estimation.sample_period_s;
    let wf: Vec<calibrate::Data> = data
        .iter()
        .zip(&out.weights)
        .map(|(d, w)| d.with_weights(w))
        .collect();
    let report = |name: &str, p: &ActuatorParams, own: &[calibrate::Data], secs: f64| {
        let r0 = calibrate::nrmse(p, &own[0]) / calibrate::nrmse(&truth, &own[0]);
        let r1 = calibrate::nrmse(p, &own[1]) / calibrate::nrmse(&truth, &own[1]);
        println!(
            "  FINISH {} {name:>10}: own {:.4}/{:.4} = {r0:.2}x/{r1:.2}x truth{}; final's rows {:.4}/{:.4} (truth {:.4}/{:.4}) ({secs:.1}s) [{}]",
            c.label(),
            calibrate::nrmse(p, &own[0]),
            calibrate::nrmse(p, &own[1]),
            if r0 > 1.2 { " OVER" } else { "" },
            calibrate::nrmse(p, &wf[0]),
            calibrate::nrmse(p, &wf[1]),
            calibrate::nrmse(&truth, &wf[0]),
            calibrate::nrmse(&truth, &wf[1]),
            fmt(&eq, p)
        );
    };
    report("final", &out.final_fit.params, &wf, 0.0);
    // Like with like: the rows both the final and the truth keep.
    let both: Vec<calibrate::Data> = data
        .iter()
        .zip(&wf)
        .map(|(d, f)| d.with_rows_both_keep(f, &predictability::weigh(&truth, d).0))
        .collect();
    println!(
        "  FINISH {} on the rows final and truth keep ({:.1} % / {:.1} % of the records): final {:.4}/{:.4}, truth {:.4}/{:.4}, ratio {:.2}x/{:.2}x",
        c.label(),
        100.0 * (1.0 - both[0].excluded_share()),
        100.0 * (1.0 - both[1].excluded_share()),
        calibrate::nrmse(&out.final_fit.params, &both[0]),
        calibrate::nrmse(&out.final_fit.params, &both[1]),
        calibrate::nrmse(&truth, &both[0]),
        calibrate::nrmse(&truth, &both[1]),
        calibrate::nrmse(&out.final_fit.params, &both[0]) / calibrate::nrmse(&truth, &both[0]),
        calibrate::nrmse(&out.final_fit.params, &both[1]) / calibrate::nrmse(&truth, &both[1]),
    );
    let knobs = &out.final_fit.knobs;
    let t = Instant::now();
    let f = calibrate::polish(&eq, knobs, &wf, 20);
    report("eqpol", &f.params, &wf, t.elapsed().as_secs_f64());
    if std::env::var("NEEDLE").is_err() {
        return;
    }
    let thin = std::env::var("NEEDLE_THIN").is_ok();
    for step in [0.02, 0.05] {
        for seed in 0..2 {
            let t = Instant::now();
            let rw = calibrate::robust(&wf);
            let rows = if thin { calibrate::thinned(&rw) } else { rw };
            let (_, q) = calibrate::evolve_with(
                &out.final_fit.params,
                knobs,
                &rows,
                16,
                120 * knobs.len(),
                step,
                seed,
            );
            let f = calibrate::polish(&q, knobs, &wf, 20);
            report(
                &format!("n{step}/{seed}"),
                &f.params,
                &wf,
                t.elapsed().as_secs_f64(),
            );
            let w2: Vec<calibrate::Data> = data
                .iter()
                .map(|d| predictability::weigh(&f.params, d).0)
                .collect();
            let g = calibrate::polish(&f.params, knobs, &w2, 20);
            report(
                &format!("n{step}/{seed}rw"),
                &g.params,
                &w2,
                t.elapsed().as_secs_f64(),
            );
        }
    }
}

/// Rows a model with the effect keeps that the final model gives up (`COVER=1`): whether a
/// hidden stiction shows where the model without it calls the record unpredictable (on
/// stiction_ratio/9 and /10 it does not: the polished stiction model keeps no more rows and
/// follows every set of rows as the final model does; docs/dev/README.md, 22nd session).
pub fn cover(c: &foreign::ForeignCase, out: &geared_servo_host::diagnose::Outcome) {
    use geared_servo::Effect;
    let te = eq_truth(c);
    let f = out.final_fit.params;
    let stiction = if te.effects.stiction_ratio > 0.0 {
        te.effects.stiction_ratio
    } else {
        1.5
    };
    let mut s = f;
    s.effects.set(Effect::StictionRatio, stiction);
    let mv = c.estimation.max_abs_v().max(c.validation.max_abs_v());
    let mut knobs = out.final_fit.knobs.clone();
    knobs.push(calibrate::knob(
        &s,
        Param::Effect(Effect::StictionRatio),
        mv,
    ));
    for (name, d) in [("est", &c.estimation), ("val", &c.validation)] {
        let sigma = noise::sigma(&d.y);
        let (wf, _) = predictability::weigh(&f, d);
        let (ws0, _) = predictability::weigh(&s, d);
        let sp = calibrate::polish(&s, &knobs, std::slice::from_ref(&ws0), 8).params;
        let (ws, _) = predictability::weigh(&sp, d);
        let (wt, _) = predictability::weigh(&te, d);
        let extra: Vec<f64> = ws
            .weight
            .iter()
            .zip(&wf.weight)
            .map(|(a, b)| (a - b).max(0.0))
            .collect();
        let dx = d.with_weights(&extra);
        let share = |w: &[f64]| 100.0 * w.iter().sum::<f64>() / w.len() as f64;
        let row = |lab: &str, w: &calibrate::Data| {
            println!(
                "    {name} {lab:6} {:5.1}%: final {:.4} with-stiction {:.4} truth {:.4} floor {:.4}",
                share(&w.weight),
                calibrate::nrmse(&f, w),
                calibrate::nrmse(&sp, w),
                calibrate::nrmse(&te, w),
                noise::floor_nrmse(sigma, &w.weight, w.norm)
            )
        };
        row("R_F", &wf);
        row("R_S", &ws);
        row("R_T", &wt);
        // An empty set would be read as every row (`Data::with_weights`).
        if extra.iter().sum::<f64>() > 0.0 {
            row("S-F", &dx);
        }
        println!(
            "    {name} stiction polished {:.3} (truth {:.3})",
            sp.effects.stiction_ratio, te.effects.stiction_ratio
        );
    }
}

/// Each unpredictable span's level, measured against the model's and against the range of
/// perturbed copies' levels (the ensembles of `predictability::assess`), at the truth and
/// at the final model.
fn spans(c: &foreign::ForeignCase) {
    let d = &c.estimation;
    let sigma = noise::sigma(&d.y);
    let te = eq_truth(c);
    let out = c.diagnose(&Options::default()).unwrap();
    // `SPANS=x` scales the copies' perturbations by x (1 when not a number).
    let scale: f64 = std::env::var("SPANS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    let scaled = |s: predictability::Settings| predictability::Settings {
        inertia_perturbation: scale * s.inertia_perturbation,
        friction_perturbation: scale * s.friction_perturbation,
        ..s
    };
    let ensembles = [
        scaled(predictability::Settings::default()),
        scaled(predictability::WIDE),
    ];
    {
        let w0 = &out.weights[0];
        let m0 = calibrate::output(&out.final_fit.params, d).unwrap();
        let kept = w0.iter().filter(|x| **x >= 0.5).count();
        println!(
            "NLL {} final(diagnose's weights, {kept} rows) est: {}",
            c.label(),
            nll(&d.y, &m0, w0, sigma).1
        );
        let wf = predictability::assess(&out.final_fit.params, d).weight;
        let differ = w0
            .iter()
            .zip(&wf)
            .filter(|(a, b)| (**a >= 0.5) != (**b >= 0.5))
            .count();
        let mut runs = Vec::new();
        for k in 0..wf.len() {
            if (w0[k] >= 0.5) != (wf[k] >= 0.5)
                && (k == 0 || (w0[k - 1] >= 0.5) == (wf[k - 1] >= 0.5))
            {
                runs.push(format!(
                    "{:.3}s {}",
                    k as f64 * d.sample_period_s,
                    if wf[k] >= 0.5 { "now kept" } else { "now out" }
                ));
            }
        }
        println!(
            "  the final's own assessment differs on {differ} rows: {}",
            runs.join(", ")
        );
        let wd = d.weight.iter().filter(|x| **x >= 0.5).count();
        println!("  record's own weights keep {wd} of {}", d.weight.len());
    }
    if let Ok(e) = std::env::var("SPANS_ADD") {
        let effect = geared_servo::Effect::ALL
            .iter()
            .copied()
            .find(|x| x.name() == e)
            .unwrap();
        let mv = d.max_abs_v();
        let data = [d.clone(), c.validation.clone()];
        for start in [0.3, 1.0, 3.0] {
            let mut q = out.final_fit.params;
            let k = calibrate::knob(&q, Param::Effect(effect), mv);
            let v0 = if k.log {
                (k.lo * k.hi).sqrt() * start
            } else {
                k.lo + (k.hi - k.lo) * start / 6.0
            };
            calibrate::set(&mut q, Param::Effect(effect), v0);
            let mut knobs = out.final_fit.knobs.clone();
            knobs.push(k);
            let mut p = q;
            for round in 0..3 {
                let w: Vec<_> = data
                    .iter()
                    .map(|x| predictability::weigh(&p, x).0)
                    .collect();
                p = if round == 0 {
                    calibrate::calibrate(&p, &knobs, &w).params
                } else {
                    calibrate::polish(&p, &knobs, &w, 20).params
                };
            }
            let mut tot = 0.0;
            for (rn, rd) in [("est", &data[0]), ("val", &data[1])] {
                let rw = predictability::assess(&p, rd).weight;
                let rm = calibrate::output(&p, rd).unwrap();
                let r = nll(&rd.y, &rm, &rw, noise::sigma(&rd.y));
                tot += r.0;
                println!(
                    "NLL {} +{e} from {v0:.3e} -> {:.3e} {rn}: {}",
                    c.label(),
                    p.effects.get(effect),
                    r.1
                );
            }
            println!("NLL {} +{e} from {v0:.3e}: both {tot:.0}", c.label());
        }
    }
    for (name, p) in [("truth", te), ("final", out.final_fit.params)] {
        let w = predictability::assess(&p, d).weight;
        let model = calibrate::output(&p, d).unwrap();
        let mut members = Vec::new();
        for st in &ensembles {
            for m in 0..4 {
                members.push(calibrate::output(&predictability::member(&p, m, st), d).unwrap());
            }
        }
        let levels = predictability::span_levels(&d.y, &model, &w, sigma, d.sample_period_s);
        for (rn, rd) in [("est", d.clone()), ("val", c.validation.clone())] {
            let rw = predictability::assess(&p, &rd).weight;
            let rm = calibrate::output(&p, &rd).unwrap();
            let rs = noise::sigma(&rd.y);
            println!(
                "NLL {} {name} {rn}: {}",
                c.label(),
                nll(&rd.y, &rm, &rw, rs).1
            );
        }
        let kept = w.iter().filter(|x| **x >= 0.5).count() as f64 / w.len() as f64;
        println!(
            "SPANS {} {name}: kept {:.1}%, {} spans",
            c.label(),
            100.0 * kept,
            levels.len()
        );
        for l in &levels {
            let (a, b) = l.rows;
            let rms =
                |x: &[f64]| (x[a..b].iter().map(|v| v * v).sum::<f64>() / (b - a) as f64).sqrt();
            let mr: Vec<f64> = members.iter().map(|y| rms(y)).collect();
            let lo = mr
                .iter()
                .cloned()
                .fold(f64::INFINITY, f64::min)
                .min(l.model_rms);
            let hi = mr.iter().cloned().fold(0.0, f64::max).max(l.model_rms);
            let meas = l.measured_rms.max(sigma);
            let out_by = if meas < lo {
                lo / meas
            } else if meas > hi {
                meas / hi
            } else {
                1.0
            };
            println!(
                "  {:.3}-{:.3} s: measured {:.4} model {:.4} (x{:.2}) members {:.4}..{:.4} outside x{:.2}",
                l.seconds.0, l.seconds.1, l.measured_rms, l.model_rms, l.ratio(sigma), lo, hi, out_by
            );
        }
    }
}

/// Negative log-likelihood (nats, constant dropped) of `y` under the model: N(m, σ²) on the
/// predictable rows; on each unpredictable run of rows N(m, σ² + 2 L²), L the model's RMS
/// over the run (two independent signals of level L differ by √2 L in RMS). Returns the
/// total and a line with its parts.
fn nll(y: &[f64], m: &[f64], w: &[f64], sigma: f64) -> (f64, String) {
    let s2 = sigma * sigma;
    let n = y.len();
    let (mut pred, mut unpred, mut logv, mut np) = (0.0, 0.0, 0.0, 0usize);
    let mut k = 0;
    while k < n {
        if w[k] >= 0.5 {
            pred += (y[k] - m[k]).powi(2) / (2.0 * s2);
            np += 1;
            k += 1;
            continue;
        }
        let a = k;
        while k < n && w[k] < 0.5 {
            k += 1;
        }
        let l2 = m[a..k].iter().map(|v| v * v).sum::<f64>() / (k - a) as f64;
        let v = s2 + 2.0 * l2;
        for j in a..k {
            unpred += (y[j] - m[j]).powi(2) / (2.0 * v);
        }
        logv += 0.5 * (k - a) as f64 * (v / s2).ln();
    }
    let total = pred + unpred + logv;
    let line = format!(
        "total {:.0} = pred {:.0} ({} rows) + unpred {:.0} + logvar {:.0}",
        total, pred, np, unpred, logv
    );
    (total, line)
}

/// The truth (model form) on its own rows of both records, polished with its effects, then
/// with a tachometer gain as well: what a gain does at the truth.
pub fn tgain(c: &foreign::ForeignCase) {
    let t = eq_truth(c);
    let mv = c.estimation.max_abs_v().max(c.validation.max_abs_v());
    let we = predictability::weigh(&t, &c.estimation).0;
    let wv = predictability::weigh(&t, &c.validation).0;
    let both = [we, wv];
    let file = file_form(c, t.sample_period_s);
    let mut knobs = calibrate::default_knobs(&file, mv);
    knobs.push(calibrate::background_damping_knob(&file, mv));
    for (e, _) in &c.expected {
        knobs.push(calibrate::knob(&file, Param::Effect(*e), mv));
    }
    let a = calibrate::polish(&t, &knobs, &both, 20);
    knobs.push(calibrate::knob(
        &file,
        Param::Effect(geared_servo::Effect::TachGain),
        mv,
    ));
    let b = calibrate::polish(&t, &knobs, &both, 20);
    let n = |p: &ActuatorParams| [calibrate::nrmse(p, &both[0]), calibrate::nrmse(p, &both[1])];
    println!(
        "TGAIN {}: truth {:?}, polished {:?}, with a gain {:?} (gain {:.4e}); floors {:.4} {:.4}",
        c.label(),
        n(&t),
        n(&a.params),
        n(&b.params),
        b.params.effects.tach_gain,
        c.estimation_floor,
        c.validation_floor
    );
}

/// The bursts a diagnosis's final model weights out although its residual there is mostly
/// coherent with the burst (the unit answers plainly), and what a polish that counts them
/// finds: costs on the union of the model's own rows and those bursts.
fn unexcuse(c: &foreign::ForeignCase) {
    use geared_servo_host::repeat;
    let out = c.diagnose(&Options::default()).unwrap();
    let p = out.final_fit.params;
    let knobs = out.final_fit.knobs.clone();
    let te = eq_truth(c);
    let mut records = vec![c.estimation.clone()];
    if out.validation_in_fit.is_some() {
        records.push(c.validation.clone());
    }
    let mut own = Vec::new();
    let mut union = Vec::new();
    for (i, d) in records.iter().enumerate() {
        let (w, _) = predictability::weigh(&p, d);
        let y = calibrate::output(&p, d).unwrap();
        let e: Vec<f64> = d.y.iter().zip(&y).map(|(a, b)| a - b).collect();
        let sigma = noise::sigma(&d.y);
        let mut uw = w.weight.clone();
        for b in repeat::burst_parts(&d.volts, &e, d.sample_period_s, sigma) {
            let kept: f64 = w.weight[b.start..b.end].iter().sum::<f64>() / (b.end - b.start) as f64;
            println!(
                "  rec {i} burst {:6.1} Hz rows {}..{} kept {:.2} resid {:.2} sigma coherent share {:.2}{}",
                b.hz,
                b.start,
                b.end,
                kept,
                b.mean_square.sqrt() / sigma,
                b.share,
                if b.mostly_coherent { " MOSTLY COHERENT" } else { "" }
            );
            if b.mostly_coherent && kept < 0.5 {
                // Can the model itself reach the unit's response there: from another rest
                // position in the gap, or with its parameters moved a little?
                let delta = p.derived().unwrap().delta_rad as f32;
                let settle = (0.1 / d.sample_period_s) as usize;
                let ms_of = |yy: &[f64]| {
                    let r = (b.start + settle)..b.end;
                    r.clone().map(|k| (d.y[k] - yy[k]).powi(2)).sum::<f64>() / r.len() as f64
                };
                let base = ms_of(&y);
                let mut line = String::new();
                for j in 0..9 {
                    let x0 = -delta + j as f32 * delta / 4.0;
                    let yy = calibrate::output_with(&p, d, |k, st| {
                        if k == b.start {
                            st.twist_rad = x0;
                        }
                    })
                    .unwrap();
                    line += &format!(" {:.2}", ms_of(&yy) / base);
                }
                line += " | members";
                for s in [predictability::Settings::default(), predictability::WIDE] {
                    for m in 0..4 {
                        let q = predictability::member(&p, m, &s);
                        let yy = calibrate::output(&q, d).unwrap();
                        line += &format!(" {:.2}", ms_of(&yy) / base);
                    }
                }
                let yt = calibrate::output(&te, d).unwrap();
                println!(
                    "     restarts (ms / the model's):{line} | truth {:.2}",
                    ms_of(&yt) / base
                );
                for x in &mut uw[b.start..b.end] {
                    *x = 1.0;
                }
            }
        }
        own.push(w.clone());
        union.push(d.with_weights(&uw));
    }
    let q = calibrate::polish(&p, &knobs, &union, 20).params;
    let own_q: Vec<_> = records
        .iter()
        .map(|d| predictability::weigh(&q, d).0)
        .collect();
    let own_t: Vec<_> = records
        .iter()
        .map(|d| predictability::weigh(&te, d).0)
        .collect();
    let r = |x: f64| x.sqrt();
    println!(
        "== {} final {} | union: final {:.4} polished {:.4} truth {:.4} | own rows: final {:.4} polished {:.4} (kept {:.2}) truth {:.4}",
        c.label(),
        fmt(&te, &p),
        r(calibrate::cost(&p, &union)),
        r(calibrate::cost(&q, &union)),
        r(calibrate::cost(&te, &union)),
        r(calibrate::cost(&p, &own)),
        r(calibrate::cost(&q, &own_q)),
        1.0 - own_q[0].excluded_share(),
        r(calibrate::cost(&te, &own_t)),
    );
    println!("   polished {}", fmt(&te, &q));
}

/// The truth on each record's predictable rows (its own assessment): NRMSE over the floor,
/// and the worst 50 ms windows of the kept residual in noise levels.
fn valprobe(c: &foreign::ForeignCase) {
    let te = eq_truth(c);
    for (name, d) in [("est", &c.estimation), ("val", &c.validation)] {
        let sigma = noise::sigma(&d.y);
        let pr = predictability::assess(&te, d);
        let w = d.with_weights(&pr.weight);
        let m = calibrate::output(&te, d).unwrap();
        let fl = noise::floor_nrmse(sigma, &w.weight, w.norm);
        let nr = calibrate::nrmse_of(Some(&m), &w);
        println!(
            "VAL {} {name}: kept {:.1} %, truth {nr:.4} floor {fl:.4} (x{:.2})",
            c.label(),
            100.0 * (1.0 - pr.excluded_share),
            nr / fl
        );
        let win = (0.05 / d.sample_period_s).round() as usize;
        let mut rows: Vec<(f64, usize, f64)> = Vec::new();
        let mut excess = 0.0;
        for (i, start) in (0..d.y.len()).step_by(win.max(1)).enumerate() {
            let (mut e, mut n) = (0.0, 0.0);
            let end = (start + win).min(d.y.len());
            for ((y, mk), wk) in d.y[start..end]
                .iter()
                .zip(&m[start..end])
                .zip(&pr.weight[start..end])
            {
                e += wk * (y - mk).powi(2);
                n += wk;
            }
            if n > 0.0 {
                let r = (e / n).sqrt() / sigma;
                excess += (e - n * sigma * sigma).max(0.0);
                rows.push((r, i, n));
            }
        }
        rows.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap());
        let line: Vec<String> = rows
            .iter()
            .take(8)
            .map(|(r, i, n)| format!("{:.2}s:{r:.1}σ({n:.0})", *i as f64 * 0.05))
            .collect();
        println!(
            "VAL {} {name}: worst windows {} ; excess {:.3e}",
            c.label(),
            line.join(" "),
            excess
        );
    }
}

/// `ROBUSTAT=1 PARAMS=calibrated.toml`: the robust and plain ratios to the floor (the
/// `unexplained` line's measure, `Ctx::robust_ratio`, approximated with each record's first
/// output's noise level) of a calibrated model and of the truth (file's resistance), on the
/// rows the calibrated model keeps as predictable, each record and both.
fn robust_at(c: &foreign::ForeignCase) {
    let Ok(path) = std::env::var("PARAMS") else {
        println!("ROBUSTAT needs PARAMS=FILE.toml (e.g. diagnose --out DIR's calibrated.toml)");
        return;
    };
    let text = std::fs::read_to_string(&path).unwrap();
    let fin = params_file::parse(&text, &path).unwrap();
    let truth = eq_truth(c);
    let c0 = calibrate::Robust::noise_share();
    let mut both: Vec<(calibrate::Data, f64)> = Vec::new();
    for (rec, d) in [("est", &c.estimation), ("val", &c.validation)] {
        let d = d.with_backlash(c.file.backlash_deg);
        let mut q = fin;
        q.sample_period_s = d.sample_period_s;
        let (w, _) = predictability::weigh(&q, &d);
        let s = noise::sigma(&d.y);
        let fl = noise::floor_nrmse(s, &w.weight, w.norm);
        let rb = w.with_robust(Some(calibrate::Robust::new(s, d.sample_period_s)));
        let (f, t) = (
            floor_ratios(&fin, &w, &rb, fl),
            floor_ratios(&truth, &w, &rb, fl),
        );
        println!(
            "  {} {rec}: kept {:.1} %, floor {fl:.4}; final plain {:.2}x robust {:.2}x; truth plain {:.2}x robust {:.2}x",
            c.label(),
            100.0 * (1.0 - w.excluded_share()),
            f.0,
            f.1,
            t.0,
            t.1
        );
        both.push((rb, fl * fl));
    }
    let floor2 = both.iter().map(|b| b.1).sum::<f64>() / both.len() as f64;
    let rdata: Vec<calibrate::Data> = both.into_iter().map(|b| b.0).collect();
    let r = |p: &ActuatorParams| (calibrate::cost(p, &rdata) / (c0 * floor2)).sqrt();
    println!(
        "  {} both: final robust {:.2}x, truth robust {:.2}x",
        c.label(),
        r(&fin),
        r(&truth)
    );
}

/// The plain and the robust NRMSE of `p` over the floor `fl` of its rows: plain on `w`,
/// robust on `rb` (the same rows under the robust window loss), as `Ctx::robust_ratio` reads
/// the latter.
fn floor_ratios(
    p: &ActuatorParams,
    w: &calibrate::Data,
    rb: &calibrate::Data,
    fl: f64,
) -> (f64, f64) {
    let c0 = calibrate::Robust::noise_share();
    (
        calibrate::nrmse(p, w) / fl,
        (calibrate::cost(p, std::slice::from_ref(rb)) / (c0 * fl * fl)).sqrt(),
    )
}
