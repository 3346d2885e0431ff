//! Input records and the emulator run over them, shared by the accuracy and effect tests.

use geared_servo::{ActuatorParams, Plant, PlantState};
use std::f64::consts::PI;

/// `n` samples of a sine of amplitude `vpk` (V) at `f` (Hz), sampled every `h` (s) from 0.
pub fn sine(vpk: f64, f: f64, n: usize, h: f64) -> Vec<f64> {
    (0..n)
        .map(|k| vpk * (2.0 * PI * f * k as f64 * h).sin())
        .collect()
}

/// `n` samples of a ±`vpk` square wave of period `period_s`, starting positive.
pub fn square(vpk: f64, period_s: f64, n: usize, h: f64) -> Vec<f64> {
    (0..n)
        .map(|k| {
            if (k as f64 * h / period_s).fract() < 0.5 {
                vpk
            } else {
                -vpk
            }
        })
        .collect()
}

/// The emulator's tachometer record for `volts` from rest, in the measured-data convention:
/// row k is sampled before command k, so there are `volts.len() + 1` rows.
pub fn emulate(p: &ActuatorParams, volts: &[f64]) -> Vec<f64> {
    let plant = Plant::new(p).expect("valid parameters");
    let mut st = PlantState::REST;
    let mut out = vec![f64::from(plant.outputs(&st).tach_voltage_v)];
    for &v in volts {
        out.push(f64::from(plant.step(&mut st, v as f32).tach_voltage_v));
    }
    out
}
