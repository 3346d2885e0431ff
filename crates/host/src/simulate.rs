//! Time-domain runs of the plant on a voltage record (`geared-servo simulate`), from rest,
//! optionally with a fault scenario played step by step.

use crate::error::HostError;
use crate::scenario_file::HostScenario;
use geared_servo::{ActuatorParams, Outputs, Plant, PlantState};

/// What an output column measures: decides how a record of it is read (a speed sensor's
/// first sample says whether the record starts in motion, `calibrate::starts_in_motion`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// A speed (the tachometer's voltage included).
    Speed,
    /// An angle.
    Angle,
    /// A current.
    Current,
    /// Anything else (a torque, a flag).
    Other,
}

/// One output column of the model: what `simulate` writes, the FMU's outputs, and the
/// columns a measured record may carry ([`crate::record::OUTPUT_COLUMNS`]).
#[derive(Clone, Copy, Debug)]
pub struct Column {
    /// Column name (INTERFACES.md).
    pub name: &'static str,
    /// Its unit, spelt as the parameter list spells units (`crate::param_list::unit_of`).
    pub unit: &'static str,
    /// What it is, in words (the FMU's variable description).
    pub description: &'static str,
    /// What it measures.
    pub quantity: Quantity,
    /// Its value in one sample of the plant's outputs, in `unit`.
    pub value: fn(&Outputs) -> f32,
}

/// The output columns, in the order `simulate` writes them after `time_s` and
/// `motor_voltage_v` (the one list: names, units, descriptions and values).
pub const COLUMNS: [Column; 8] = [
    Column {
        name: "tach_voltage_v",
        unit: "V",
        description: "tachometer voltage",
        quantity: Quantity::Speed,
        value: |o| o.tach_voltage_v,
    },
    Column {
        name: "motor_speed_rad_s",
        unit: "rad/s",
        description: "motor speed",
        quantity: Quantity::Speed,
        value: |o| o.motor_speed_rad_s,
    },
    Column {
        name: "load_angle_deg",
        unit: "deg",
        description: "load angle",
        quantity: Quantity::Angle,
        value: |o| o.load_angle_deg(),
    },
    Column {
        name: "current_a",
        unit: "A",
        description: "armature current at the sample instant",
        quantity: Quantity::Current,
        value: |o| o.current_a,
    },
    Column {
        name: "load_speed_rad_s",
        unit: "rad/s",
        description: "load speed",
        quantity: Quantity::Speed,
        value: |o| o.load_speed_rad_s,
    },
    Column {
        name: "transmitted_torque_nm",
        unit: "N*m",
        description: "torque transmitted through the gears to the load",
        quantity: Quantity::Other,
        value: |o| o.transmitted_torque_nm,
    },
    Column {
        name: "in_contact",
        unit: crate::param_list::DIMENSIONLESS,
        description: "1 while the gear teeth are in contact, else 0",
        quantity: Quantity::Other,
        value: |o| if o.in_contact { 1.0 } else { 0.0 },
    },
    Column {
        name: "mean_current_a",
        unit: "A",
        description: "armature current averaged over the last sample period",
        quantity: Quantity::Current,
        value: |o| o.mean_current_a,
    },
];

/// The names of [`COLUMNS`], in their order.
pub const SIMULATE_COLUMNS: [&str; COLUMNS.len()] = {
    let mut names = [""; COLUMNS.len()];
    let mut i = 0;
    while i < COLUMNS.len() {
        names[i] = COLUMNS[i].name;
        i += 1;
    }
    names
};

/// The column named `name`, if the model has one.
pub fn column(name: &str) -> Option<&'static Column> {
    COLUMNS.iter().find(|c| c.name == name)
}

/// The values of [`COLUMNS`] for one sample, in their units (`in_contact`: 1 while the gears
/// touch, else 0). `simulate` writes them and the FMU's outputs are them.
pub fn row(o: &Outputs) -> [f64; COLUMNS.len()] {
    COLUMNS.map(|c| f64::from((c.value)(o)))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sensor_error_changes_its_own_column_and_nothing_else() {
        // Each effect that names a sensor column (Effect::sensor_column), at a value inside
        // its plausible range, changes that column of a square-wave run and leaves every
        // other column the record could carry as it was: a record without the column
        // cannot show it (`diagnose` does not try it there).
        use geared_servo::Effect;
        let volts: Vec<f64> = (0..4000)
            .map(|k| if (k / 400) % 2 == 0 { 8.0 } else { -8.0 })
            .collect();
        let base = simulate_columns(&geared_servo::REFERENCE, 5e-4, &volts).unwrap();
        let mut sensors = 0;
        for e in Effect::ALL {
            let Some(col) = e.sensor_column() else {
                continue;
            };
            sensors += 1;
            let (lo, hi) = e.plausible_range();
            let mut p = geared_servo::REFERENCE;
            p.effects.set(
                e,
                if hi > 0.0 {
                    0.5 * (lo.max(0.0) + hi)
                } else {
                    lo
                },
            );
            let run = simulate_columns(&p, 5e-4, &volts).unwrap();
            for (i, name) in SIMULATE_COLUMNS.iter().enumerate() {
                let same = run[i] == base[i];
                if *name == col {
                    assert!(!same, "{e} leaves {col} as it was");
                } else if crate::record::OUTPUT_COLUMNS.contains(name) {
                    assert!(same, "{e} changes {name}");
                }
            }
        }
        assert_eq!(sensors, 4);
    }

    #[test]
    fn every_column_has_the_unit_its_name_says() {
        for c in &COLUMNS {
            let by_name = crate::param_list::unit_of(c.name);
            assert_eq!(Some(c.unit), by_name, "{}", c.name);
        }
    }

    #[test]
    fn every_record_output_is_a_model_column() {
        for name in crate::record::OUTPUT_COLUMNS {
            assert!(column(name).is_some(), "{name}");
        }
        assert!(column("time_s").is_none());
    }

    #[test]
    fn each_column_holds_the_output_it_names() {
        let plant = Plant::new(&geared_servo::REFERENCE).unwrap();
        let mut st = PlantState::REST;
        let mut o = plant.outputs(&st);
        for _ in 0..200 {
            o = plant.step(&mut st, 6.0);
        }
        let r = row(&o);
        let at = |name: &str| r[COLUMNS.iter().position(|c| c.name == name).unwrap()];
        assert_eq!(at("tach_voltage_v"), f64::from(o.tach_voltage_v));
        assert_eq!(at("motor_speed_rad_s"), f64::from(o.motor_speed_rad_s));
        assert_eq!(at("load_angle_deg"), f64::from(o.load_angle_deg()));
        assert_eq!(at("current_a"), f64::from(o.current_a));
        assert_eq!(at("load_speed_rad_s"), f64::from(o.load_speed_rad_s));
        assert_eq!(
            at("transmitted_torque_nm"),
            f64::from(o.transmitted_torque_nm)
        );
        assert_eq!(at("mean_current_a"), f64::from(o.mean_current_a));
        assert_eq!(at("in_contact"), if o.in_contact { 1.0 } else { 0.0 });
        assert!(o.motor_speed_rad_s > 0.0 && o.current_a != o.mean_current_a);
    }
}
