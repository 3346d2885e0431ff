//! Where `diagnose` lands on a case of the foreign suite, against the truth, and what a
//! further global search from there finds (a development probe: `cargo run --release -p
//! geared-servo-host-tests --example calib_probe -- KIND DRAWS`).
use geared_servo::ActuatorParams;
use geared_servo_host::calibrate::{self, Param, BASE_KNOBS};
use geared_servo_host::diagnose::{diagnose, Options};
use geared_servo_host::{noise, predictability};
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
        let c = foreign::case(kind, draw).unwrap();
        let d = &c.estimation;
        let sigma = noise::sigma(&d.y);
        let te = eq_truth(&c);
        let t0 = Instant::now();
        let out = diagnose(
            &c.file,
            std::slice::from_ref(d),
            Some(&c.validation),
            &Options::default(),
        )
        .unwrap();
        let w = d.with_weights(&out.weights[0]);
        let fl = noise::floor_nrmse(sigma, &w.weight, w.norm);
        println!(
            "== {} ({:.1}s): steps {:?}",
            c.label(),
            t0.elapsed().as_secs_f64(),
            out.steps
                .iter()
                .map(|s| format!("{}={:.3e}", s.effect, s.value))
                .collect::<Vec<_>>()
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
