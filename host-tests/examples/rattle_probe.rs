//! How much of the foreign suite's records is unpredictable (gear rattle), and how well the
//! predictability ensemble finds it: for the clean unit of each draw (made by the independent
//! reference integrator, 2 % noise), the emulator at the *true* parameters against the
//! records, on the rows the ensemble keeps (NRMSE against the noise floor: 1.0 means the
//! ensemble removed exactly what no model can follow).
//!
//! `cargo run -p geared-servo-host-tests --example rattle_probe -- [MESH,...] [DRAWS] [x]
//! [ε_inertia,ε_friction,threshold]`: MESH overrides the unit's mesh damping (−1 keeps the
//! draw's own), `x` prints each burst (frequency: emulator-vs-reference gap / gap after a
//! 10⁻⁴ load-inertia perturbation / share weighted out), the last argument overrides the
//! ensemble's settings (default: the library's).
use geared_servo::ActuatorParams;
use geared_servo_host::calibrate::{self, Data, Param};
use geared_servo_host::predictability;
use geared_servo_host::record::Record;
use geared_servo_host_tests::foreign::{self, Kind, SteppedSine, SAMPLE_PERIOD_S};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

fn data(v: Vec<f64>, y: Vec<f64>, seed: u64) -> (Data, f64) {
    let rms = (y.iter().map(|a| a * a).sum::<f64>() / y.len() as f64).sqrt();
    let s = 0.02 * rms;
    let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let nd = Normal::new(0.0, s).unwrap();
    let yn: Vec<f64> = y.iter().map(|a| a + nd.sample(&mut r)).collect();
    let rec = Record {
        metadata: vec![],
        time_s: (0..v.len()).map(|k| k as f64 * SAMPLE_PERIOD_S).collect(),
        sample_period_s: SAMPLE_PERIOD_S,
        motor_voltage_v: v,
        outputs: vec![("tach_voltage_v".into(), yn)],
        warnings: vec![],
    };
    (Data::from_record(&rec, "probe").unwrap(), s)
}

fn seg_rel(a: &[f64], b: &[f64]) -> f64 {
    let e: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let n: f64 = b.iter().map(|y| y * y).sum();
    (e / n.max(1e-30)).sqrt()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let meshes: Vec<f64> = args
        .get(1)
        .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or(vec![-1.0]);
    let draws: u64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(3);
    let st: Vec<f64> = args
        .get(4)
        .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or_else(|| {
            let d = predictability::Settings::default();
            vec![d.inertia_perturbation, d.friction_perturbation, d.threshold]
        });
    let settings = predictability::Settings {
        inertia_perturbation: st[0],
        friction_perturbation: st[1],
        threshold: st[2],
        ..Default::default()
    };
    let ss = SteppedSine::default();
    let (nb, nr) = ss.period_samples(SAMPLE_PERIOD_S);
    let per = nb + nr;
    for &mesh in &meshes {
        for draw in 0..draws {
            let mut p: ActuatorParams = foreign::truth(Kind::Clean, draw).unwrap().params;
            if mesh >= 0.0 {
                p.effects.mesh_damping = mesh;
            }
            let ev = ss.volts(SAMPLE_PERIOD_S);
            let vv = foreign::validation_volts(1000 + draw, SAMPLE_PERIOD_S);
            let (et, _) = foreign::reference_run(&p, None, &ev, 2e-6).unwrap();
            let (vt, _) = foreign::reference_run(&p, None, &vv, 2e-6).unwrap();
            let (de, se) = data(ev, et.clone(), 7 + draw);
            let (dv, sv) = data(vv, vt.clone(), 77 + draw);
            // emulator at the truth and at a tiny perturbation
            let em = calibrate::simulate(&p, &de).unwrap().y;
            let mut q = p;
            calibrate::set(
                &mut q,
                Param::LoadInertia,
                calibrate::get(&p, Param::LoadInertia) * 1.0001,
            );
            let emq = calibrate::simulate(&q, &de).unwrap().y;
            let pr = predictability::assess_with(&p, &de, &settings);
            let mut line = String::new();
            let mut chaotic = 0;
            for i in 0..ss.bursts {
                let r = i * per..(i + 1) * per;
                let ref_vs_em = seg_rel(&em[r.clone()], &et[r.clone()]);
                let tiny = seg_rel(&emq[r.clone()], &em[r.clone()]);
                let excl =
                    pr.weight[r.clone()].iter().filter(|w| **w < 0.5).count() as f64 / per as f64;
                if tiny > 0.02 {
                    chaotic += 1;
                }
                line += &format!(
                    " {:.0}:{:.3}/{:.3}/{:.1}",
                    ss.frequency_hz(i),
                    ref_vs_em,
                    tiny,
                    excl
                );
            }
            let dw = de.with_weights(&pr.weight);
            let fl = geared_servo_host::noise::floor_nrmse(se, &dw.weight, dw.norm);
            let nw = calibrate::nrmse(&p, &dw);
            let prv = predictability::assess_with(&p, &dv, &settings);
            let dvw = dv.with_weights(&prv.weight);
            let flv = geared_servo_host::noise::floor_nrmse(sv, &dvw.weight, dvw.norm);
            println!(
                "mesh {:.4} draw {} | est: all {:.4} floor {:.4} excl {:.2} pred-nrmse {:.4} floor {:.4} ratio {:.2} chaotic(1e-4) {}/22 | val: all {:.4} excl {:.2} pred {:.4} floor {:.4} ratio {:.2}",
                p.effects.mesh_damping, draw, calibrate::nrmse(&p, &de),
                geared_servo_host::noise::floor_nrmse(se, &de.weight, de.norm), pr.excluded_share, nw, fl, nw / fl, chaotic,
                calibrate::nrmse(&p, &dv), prv.excluded_share, calibrate::nrmse(&p, &dvw), flv, calibrate::nrmse(&p, &dvw) / flv
            );
            if args.get(3).map(|a| a == "x").unwrap_or(false) {
                println!("   f:ref-vs-em/tiny/excl {line}");
            }
        }
    }
}
