//! Sensitivity of the reference integrator to a 1e-9 input perturbation.
use geared_servo::REFERENCE;
use geared_servo_host_tests::reference::{relative_rms_error, Reference};
fn main() {
    let a: Vec<f64> = std::env::args()
        .skip(1)
        .map(|s| s.parse().unwrap())
        .collect();
    let (b, vpk, per, kind) = (a[0], a[1], a[2], a[3]); // kind 0 = square(period), 1 = sine(freq)
    let p = REFERENCE.with_backlash_deg(b);
    let h = p.sample_period_s;
    let n = 2000;
    let v: Vec<f64> = (0..n)
        .map(|k| {
            let t = k as f64 * h;
            if kind == 0.0 {
                if (t / per).fract() < 0.5 {
                    vpk
                } else {
                    -vpk
                }
            } else {
                vpk * (2.0 * std::f64::consts::PI * per * t).sin()
            }
        })
        .collect();
    let vp: Vec<f64> = v.iter().map(|x| x * (1.0 + 1e-9)).collect();
    let y1 = Reference::new(&p, 1e-6).unwrap().run_tach(&v);
    let y2 = Reference::new(&p, 1e-6).unwrap().run_tach(&vp);
    let y3 = Reference::new(&p, 0.5e-6).unwrap().run_tach(&v);
    println!(
        "perturbed input: {:.4} %   half step: {:.4} %",
        100.0 * relative_rms_error(&y2, &y1),
        100.0 * relative_rms_error(&y3, &y1)
    );
}
