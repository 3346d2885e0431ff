//! Time-domain runs of the plant on a voltage record (`geared-servo simulate`), from rest,
//! optionally with a fault scenario played step by step.

use crate::error::HostError;
use crate::scenario_file::HostScenario;
use geared_servo::{ActuatorParams, Outputs, Plant, PlantState};

/// Columns `simulate` writes, after `time_s` and `motor_voltage_v`.
pub const SIMULATE_COLUMNS: [&str; 8] = [
    "tach_voltage_v",
    "motor_speed_rad_s",
    "load_angle_deg",
    "current_a",
    "load_speed_rad_s",
    "transmitted_torque_nm",
    "in_contact",
    "mean_current_a",
];

/// The values of [`SIMULATE_COLUMNS`] for one sample, in their units (`in_contact`: 1 while
/// the gears touch, else 0). `simulate` writes them and the FMU's outputs are them.
pub fn row(o: &Outputs) -> [f64; SIMULATE_COLUMNS.len()] {
    [
        o.tach_voltage_v,
        o.motor_speed_rad_s,
        o.load_angle_deg(),
        o.current_a,
        o.load_speed_rad_s,
        o.transmitted_torque_nm,
        if o.in_contact { 1.0 } else { 0.0 },
        o.mean_current_a,
    ]
    .map(f64::from)
}

/// Simulates `volts` (one per row, applied after that row's sample) from rest at period
/// `dt`; returns the columns of [`SIMULATE_COLUMNS`], each `volts.len()` long.
pub fn simulate_columns(
    p: &ActuatorParams,
    dt: f64,
    volts: &[f64],
) -> Result<Vec<Vec<f64>>, HostError> {
    simulate_with_scenario(p, dt, volts, None)
}

/// [`simulate_columns`] with a fault scenario played step by step.
pub fn simulate_with_scenario(
    p: &ActuatorParams,
    dt: f64,
    volts: &[f64],
    mut scenario: Option<&mut HostScenario>,
) -> Result<Vec<Vec<f64>>, HostError> {
    let mut p = *p;
    p.sample_period_s = dt;
    let plant = Plant::new(&p).map_err(HostError::from)?;
    let mut st = PlantState::REST;
    let mut cols = vec![Vec::with_capacity(volts.len()); SIMULATE_COLUMNS.len()];
    let mut o = plant.outputs(&st);
    for (k, &v) in volts.iter().enumerate() {
        for (c, x) in cols.iter_mut().zip(row(&o)) {
            c.push(x);
        }
        o = match scenario.as_deref_mut() {
            Some(sc) => {
                let f = *sc.advance(k as u32);
                // Bus sag scales the applied voltage; sensor and PWM faults were refused
                // when the scenario was read (simulate has no sensors or bridge).
                let bus = f.bus_factor.clamp(0.0, 10.0);
                plant.step_with_faults(&mut st, v as f32 * bus, &f.plant)
            }
            None => plant.step(&mut st, v as f32),
        };
    }
    Ok(cols)
}
