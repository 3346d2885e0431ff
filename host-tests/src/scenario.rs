//! Synthetic diagnosis scenarios shared by the `diagnose_*` tests: a "true" actuator perturbed
//! 10–30 % from the reference file, records made from it with `synth`, and the noise floor.

use geared_servo::{ActuatorParams, REFERENCE};
use geared_servo_host::calibrate::{Data, Param};
use geared_servo_host::synth::{self, Excitation, SynthSpec, Synthetic};

/// The true actuator: every parameter of the default calibration set off by 15–25 %, in
/// both directions (the file given to `diagnose` is [`REFERENCE`]). The armature resistance
/// is not in that set (see `calibrate::BASE_KNOBS`: it is measured, not fitted).
pub fn perturbed() -> ActuatorParams {
    let mut p = REFERENCE;
    p.motor.inertia_kg_m2 *= 0.85;
    p.load.inertia_kg_m2 *= 1.15;
    p.motor.coulomb_friction_nm *= 1.25;
    p.load.coulomb_friction_nm *= 0.80;
    // Stiffness 18 % lower: scale both stages.
    let mut q = geared_servo_host::calibrate::with_measured_stiffness(&p).unwrap();
    let k = geared_servo_host::calibrate::get(&q, Param::StiffnessKeq);
    geared_servo_host::calibrate::set(&mut q, Param::StiffnessKeq, 0.82 * k);
    q
}

/// Tachometer noise of every scenario, V (about 2 % of the signal's RMS).
pub const NOISE_V: f64 = 0.01;

/// A 3 s, 2 kHz, 10 V random-phase multisine 2–300 Hz (the estimation record) or, with
/// `validation`, a 3 s log chirp 2–300 Hz with another seed.
pub fn spec(validation: bool, noise: f64) -> SynthSpec {
    SynthSpec {
        excitation: if validation {
            Excitation::Chirp
        } else {
            Excitation::Multisine
        },
        amplitude_v: 10.0,
        f_min_hz: 2.0,
        f_max_hz: 300.0,
        steps: 40,
        duration_s: 3.0,
        sample_period_s: 0.0005,
        tach_noise_v: noise,
        seed: if validation { 11 } else { 5 },
    }
}

/// Turns a synthetic record into fitting data.
pub fn data(s: &Synthetic) -> Data {
    let rec = geared_servo_host::record::Record {
        metadata: vec![],
        time_s: s.time_s.clone(),
        sample_period_s: 0.0005,
        motor_voltage_v: s.motor_voltage_v.clone(),
        outputs: vec![("tach_voltage_v".into(), s.tach_voltage_v.clone())],
        warnings: vec![],
    };
    Data::from_record(&rec, "synthetic").unwrap()
}

/// (noisy data, NRMSE of the noise alone: the floor no model can beat).
pub fn record(p: &ActuatorParams, validation: bool) -> (Data, f64) {
    let noisy = synth::synthesize(p, &spec(validation, NOISE_V)).unwrap();
    let clean = synth::synthesize(p, &spec(validation, 0.0)).unwrap();
    let d = data(&noisy);
    let e: f64 = noisy
        .tach_voltage_v
        .iter()
        .zip(&clean.tach_voltage_v)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let floor = e / d.norm;
    (d, floor)
}
