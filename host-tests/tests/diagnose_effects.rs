//! `diagnose` names a hidden effect: for each candidate, data from an actuator perturbed
//! 15–25 % from the file, with that effect present and not declared, plus tachometer noise.

use geared_servo::{Effect, REFERENCE};
use geared_servo_host::diagnose::{diagnose, Options};
use geared_servo_host_tests::scenario::{perturbed, record};

/// True values: each large enough to matter (several times the noise) and physically
/// plausible for the reference actuator (see each comment).
const CASES: [(Effect, f64); 7] = [
    // Half the back-EMF damping k_t k_b / R = 1.23e-5 N*m*s/rad.
    (Effect::MotorViscous, 6.0e-6),
    // The same at the load: 0.3 of N^2 k_t k_b / R.
    (Effect::LoadViscous, 1.0e-2),
    // About 5 % of critical damping of the gear mode (MODEL.md's 0.05).
    (Effect::MeshDamping, 0.05),
    // A hinge spring putting a 9 Hz pole under the drive.
    (Effect::HingeStiffness, 5.0),
    // One and a half samples.
    (Effect::InputDelay, 0.75e-3),
    // Clips the 10 V excitation at 7 V.
    (Effect::VoltageLimit, 7.0),
    // A tachometer reading 10 % high.
    (Effect::TachGain, 0.10),
];

#[test]
fn each_hidden_effect_is_named_first_and_recovered() {
    let mut failures = Vec::new();
    for (name, value) in CASES {
        let mut truth = perturbed();
        truth.effects.set(name, value);
        let (d, floor) = record(&truth, false);
        let (v, vfloor) = record(&truth, true);
        let out = diagnose(&REFERENCE, &[d], Some(&v), &Options::default()).unwrap();
        let first = out.steps.first().map(|s| (s.effect, s.value));
        let nominal = out.nominal_analysis.nrmse;
        let fin = out.final_analysis.nrmse;
        let (vb, va) = out.validation.unwrap();
        eprintln!(
            "{name}: steps {:?}; nominal {nominal:.4} base {:.4} final {fin:.4} floor {floor:.4}; validation {vb:.4} -> {va:.4} floor {vfloor:.4}; base {:?}",
            out.steps.iter().map(|s| (s.effect, s.value, s.delta_bic)).collect::<Vec<_>>(),
            out.base_analysis.nrmse,
            out.base.values,
        );
        eprintln!(
            "   final {:?} rejected {:?}",
            out.final_fit.values, out.rejected
        );
        if let Some(s) = out.steps.first() {
            eprintln!("   scores {:?}", s.scores);
        } else {
            eprintln!("   scores {:?}", out.last_scores);
        }
        let ok = match &first {
            Some((n, x)) => *n == name && ((x - value) / value).abs() <= 0.2,
            None => false,
        } && fin <= 0.5 * nominal
            && fin <= 1.5 * floor
            && va <= 0.5 * vb
            && va <= 1.5 * vfloor;
        if !ok {
            failures.push(name);
        }
    }
    assert!(failures.is_empty(), "failed: {failures:?}");
}
