//! The premise of comparing unpredictable spans by their level
//! (`geared_servo_host::predictability::span_levels`): where no model can be followed sample
//! by sample, two faithful models of the same unit still agree in RMS over every span of at
//! least `SPAN_MIN_S`. Here the faithful pair is the emulator at a unit's true parameters and
//! the unit's records made by the independent reference integrator (every parameter
//! perturbed from its data sheet, 2 % noise, bursts that rattle), over the spans the emulator
//! itself calls unpredictable.

use geared_servo::Effect;
use geared_servo_host::calibrate;
use geared_servo_host::noise;
use geared_servo_host::predictability::{self, SpanLevel};
use geared_servo_host_tests::foreign::{self, Kind};

/// The factor between the truth's and the record's level within which most spans agree
/// ([`MOST`] of them). Measured on 2026-12-01 over the 291 spans of these 24 units: 97.3 % within
/// 1.1, the median 1.003.
const LEVEL_FACTOR: f64 = 1.1;
/// Share of the spans that must agree within [`LEVEL_FACTOR`].
const MOST: f64 = 0.9;
/// Where the rig settled on the other of two coexisting responses (a burst after a rattling
/// one, the gears left elsewhere in the gap) the truth itself misses a span's level: by
/// 1.63 at most on these units (gravity_torque/1, 5.6-6.0 s: 0.119 measured, 0.073
/// modelled). No span may be further than this.
const ANY_FACTOR: f64 = 2.0;

#[test]
fn the_truth_and_its_unit_agree_in_level_over_every_unpredictable_span() {
    let kinds = [
        Kind::Clean,
        Kind::Single(Effect::StictionRatio),
        Kind::Single(Effect::MeshDamping),
        Kind::Single(Effect::GravityTorque),
        Kind::Single(Effect::InputDelay),
        Kind::Single(Effect::LoadViscous),
        Kind::Single(Effect::HingeStiffness),
        Kind::Pair,
    ];
    let mut factors = Vec::new();
    for kind in kinds {
        for draw in 0..3 {
            let c = foreign::case(kind, draw).unwrap();
            let mut t = calibrate::with_measured_stiffness(&c.truth).unwrap();
            t.sample_period_s = c.estimation.sample_period_s;
            for d in [&c.estimation, &c.validation] {
                let (w, _) = predictability::weigh(&t, d);
                let model = calibrate::simulate(&t, &w).unwrap();
                let sigma = noise::sigma(&d.y);
                let levels: Vec<SpanLevel> = predictability::span_levels(
                    &d.y,
                    &model.y,
                    &w.weight,
                    sigma,
                    d.sample_period_s,
                );
                for l in &levels {
                    let r = l.ratio(sigma);
                    let f = r.max(1.0 / r);
                    if f > LEVEL_FACTOR {
                        eprintln!(
                            "{} {:.3}-{:.3} s: measured {:.4} model {:.4} (x{r:.3})",
                            c.label(),
                            l.seconds.0,
                            l.seconds.1,
                            l.measured_rms,
                            l.model_rms
                        );
                    }
                    factors.push(f);
                }
            }
        }
    }
    let compared = factors.len();
    let worst = factors.iter().copied().fold(1.0f64, f64::max);
    eprintln!("{compared} spans compared, the furthest x{worst:.3}");
    assert!(compared >= 100, "too few spans to say anything: {compared}");
    let within = factors.iter().filter(|f| **f <= LEVEL_FACTOR).count() as f64 / compared as f64;
    eprintln!("{:.1} % within x{LEVEL_FACTOR}", 100.0 * within);
    assert!(
        within >= MOST,
        "{:.1} % of the spans within x{LEVEL_FACTOR}",
        100.0 * within
    );
    assert!(worst <= ANY_FACTOR, "a span off by x{worst:.3}");
}
