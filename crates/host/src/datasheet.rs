//! A rig from a data sheet (`geared-servo init`): the parameter file a user can write from
//! the figures a hobby gear motor's data sheet gives, with everything the data sheet cannot
//! give marked as a guess for `diagnose` to calibrate.
//!
//! The figures are the gear motor's, at its output shaft, on the supply voltage V: no-load
//! speed n₀ (rpm), stall torque T_s and/or stall current I_s, optionally the no-load current
//! I₀; the gear ratio N; the load's inertia (roughly); optionally the motor's inertia and
//! inductance. With k = k_t = k_b (SI units make them equal), the motor at no load and at
//! stall:
//!
//! ```text
//! no load   V = R I₀ + k ω₀            ω₀ = N n₀ 2π/60 (motor side)
//! stall     V = R I_s,  T_s / N = k I_s (an ideal gearbox)
//! ```
//!
//! - Stall current given: R = V / I_s, k = (V − R I₀) / ω₀. A stall torque given as well
//!   is then a check: T_s / (N k I_s) is the gearbox's efficiency at stall (reported; a
//!   value outside 0.2–1.1 means the figures do not describe one motor and is an error).
//! - Stall torque alone: eliminating R, k = V / (ω₀ + V I₀ / (T_s/N)), R = V k / (T_s/N).
//! - Motor friction: the torque the no-load current holds, k I₀ (at the motor: bearings,
//!   brushes and the gearbox's losses reflected); without I₀ a guess of 5 % of the stall
//!   torque.
//!
//! Guesses, each marked `GUESS` in the file: the gear train's stiffness (the stall torque
//! twisting it by 1°: plastic and sintered hobby gearboxes), the backlash (1° at the
//! output), the load's friction (1 % of the stall torque), and unless given the motor's
//! inertia (a mechanical time constant J R / k² of 15 ms) and inductance (L/R = 0.3 ms). The
//! tachometer constant is taken as k (a hobby motor has none: the value only scales
//! `tach_voltage_v`, which such a rig does not log). `diagnose` calibrates the motor and load
//! inertias, the stiffness, both frictions and the backlash by default, from these values;
//! it keeps R, k, L and the tachometer constant (R and the tachometer constant can be added
//! with `--fit`).

use crate::error::HostError;
use crate::params_file;
use geared_servo::params::{GearTrain, LoadParams, MotorParams, Stiffness};
use geared_servo::{ActuatorParams, Effects};

/// Mechanical time constant J_m R / k² assumed when the motor's inertia is not given, s.
pub const GUESS_MECHANICAL_TIME_CONSTANT_S: f64 = 0.015;
/// Electrical time constant L/R assumed when the inductance is not given, s.
pub const GUESS_ELECTRICAL_TIME_CONSTANT_S: f64 = 0.3e-3;
/// Twist of the gear train under the stall torque assumed for its stiffness, degrees.
pub const GUESS_STALL_TWIST_DEG: f64 = 1.0;
/// Backlash at the output assumed, degrees.
pub const GUESS_BACKLASH_DEG: f64 = 1.0;
/// Motor friction without a no-load current, as a share of the stall torque.
pub const GUESS_MOTOR_FRICTION_SHARE: f64 = 0.05;
/// Load friction, as a share of the stall torque at the output.
pub const GUESS_LOAD_FRICTION_SHARE: f64 = 0.01;

/// The data-sheet figures, SI except the speed in rpm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DataSheet {
    /// Supply voltage the figures are given at, V.
    pub supply_v: f64,
    /// No-load speed at the output shaft, rpm.
    pub no_load_rpm: f64,
    /// Stall torque at the output shaft, N·m.
    pub stall_torque_nm: Option<f64>,
    /// Stall current, A.
    pub stall_current_a: Option<f64>,
    /// No-load current, A.
    pub no_load_current_a: Option<f64>,
    /// Gear ratio N (motor turns per output turn), dimensionless.
    pub gear_ratio: f64,
    /// Load inertia at the output shaft, kg·m² (a rough figure does).
    pub load_inertia_kg_m2: f64,
    /// Rotor inertia, kg·m².
    pub motor_inertia_kg_m2: Option<f64>,
    /// Armature inductance, H.
    pub inductance_h: Option<f64>,
    /// Emulator step, s.
    pub sample_period_s: f64,
}

/// A parameter set derived from a [`DataSheet`], with the notes its file carries.
#[derive(Clone, Debug, PartialEq)]
pub struct Derived {
    /// The parameters.
    pub params: ActuatorParams,
    /// Keys (`motor.resistance_ohm`) that are guesses, with the reason, in file order.
    pub guesses: Vec<(&'static str, String)>,
    /// Keys derived from the figures, with the formula, in file order.
    pub derived: Vec<(&'static str, String)>,
    /// The gearbox's efficiency at stall implied by a stall torque and a stall current
    /// given together, dimensionless.
    pub stall_efficiency: Option<f64>,
}

/// `v` if it is a finite number greater than zero; otherwise an error naming `option`.
fn positive(v: f64, option: &str) -> Result<f64, HostError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(HostError::input(format!(
            "{option}: must be a finite number greater than zero (got {v})"
        )))
    }
}

/// Derives the parameter set of `d` (errors name the option: `--no-load-rpm`).
pub fn derive(d: &DataSheet) -> Result<Derived, HostError> {
    let v = positive(d.supply_v, "--supply-v")?;
    let rpm = positive(d.no_load_rpm, "--no-load-rpm")?;
    let n = positive(d.gear_ratio, "--gear-ratio")?;
    let jl = positive(d.load_inertia_kg_m2, "--load-inertia")?;
    let h = positive(d.sample_period_s, "--sample-period")?;
    let opt = |x: Option<f64>, name: &str| x.map(|x| positive(x, name)).transpose();
    let ts_out = opt(d.stall_torque_nm, "--stall-torque-nm")?;
    let is = opt(d.stall_current_a, "--stall-current-a")?;
    let i0 = match d.no_load_current_a {
        // Zero is a fine no-load current (no friction measured); negative is not.
        Some(0.0) => Some(0.0),
        x => opt(x, "--no-load-current-a")?,
    };
    let jm_given = opt(d.motor_inertia_kg_m2, "--motor-inertia")?;
    let l_given = opt(d.inductance_h, "--inductance-h")?;
    let w0 = rpm * n * std::f64::consts::PI / 30.0;
    let i0v = i0.unwrap_or(0.0);
    let mut derived: Vec<(&'static str, String)> = Vec::new();
    let mut guesses: Vec<(&'static str, String)> = Vec::new();
    let (r, k, ts_motor, efficiency) = match (is, ts_out) {
        (Some(is), ts) => {
            if i0v >= is {
                return Err(HostError::input(format!(
                    "--no-load-current-a: {i0v} A is not below the stall current {is} A"
                )));
            }
            let r = v / is;
            let k = (v - r * i0v) / w0;
            derived.push(("motor.resistance_ohm", "V / I_s".into()));
            derived.push(("motor.torque_constant_nm_per_a", "(V − R I₀) / ω₀".into()));
            let eff = ts.map(|t| t / (n * k * is));
            if let Some(e) = eff {
                if !(0.2..=1.1).contains(&e) {
                    return Err(HostError::input(format!(
                        "--stall-torque-nm: {} N*m at the output is {:.0} % of what the stall current gives through the ratio (N k I_s = {:.4} N*m): the figures do not describe one motor (20-110 % expected)",
                        ts.unwrap_or(0.0),
                        100.0 * e,
                        n * k * is
                    )));
                }
            }
            (r, k, k * is, eff)
        }
        (None, Some(ts)) => {
            let tsm = ts / n;
            let k = v / (w0 + v * i0v / tsm);
            let r = v * k / tsm;
            derived.push(("motor.resistance_ohm", "V k / (T_s/N)".into()));
            derived.push((
                "motor.torque_constant_nm_per_a",
                "V / (ω₀ + V I₀ / (T_s/N))".into(),
            ));
            (r, k, tsm, None)
        }
        (None, None) => {
            return Err(HostError::input(
                "--stall-torque-nm, --stall-current-a: give at least one (the stall figure sets the winding's resistance)",
            ))
        }
    };
    derived.push(("motor.back_emf_v_s_per_rad", "k_b = k_t (SI)".into()));
    guesses.push((
        "motor.tach_v_s_per_rad",
        "ASSUMED = k: no tachometer on the data sheet; scales only tach_voltage_v".into(),
    ));
    let jm = match jm_given {
        Some(j) => {
            derived.push(("motor.inertia_kg_m2", "given".into()));
            j
        }
        None => {
            guesses.push((
                "motor.inertia_kg_m2",
                format!(
                    "GUESS: J R / k² = {:.0} ms; diagnose calibrates it",
                    GUESS_MECHANICAL_TIME_CONSTANT_S * 1e3
                ),
            ));
            GUESS_MECHANICAL_TIME_CONSTANT_S * k * k / r
        }
    };
    let l = match l_given {
        Some(l) => {
            derived.push(("motor.inductance_h", "given".into()));
            l
        }
        None => {
            guesses.push((
                "motor.inductance_h",
                format!(
                    "GUESS: L/R = {:.1} ms; diagnose keeps it",
                    GUESS_ELECTRICAL_TIME_CONSTANT_S * 1e3
                ),
            ));
            GUESS_ELECTRICAL_TIME_CONSTANT_S * r
        }
    };
    let tfm = match i0 {
        Some(i0) => {
            derived.push(("motor.coulomb_friction_nm", "k I₀".into()));
            k * i0
        }
        None => {
            guesses.push((
                "motor.coulomb_friction_nm",
                format!(
                    "GUESS: {:.0} % of the stall torque; diagnose calibrates it",
                    100.0 * GUESS_MOTOR_FRICTION_SHARE
                ),
            ));
            GUESS_MOTOR_FRICTION_SHARE * ts_motor
        }
    };
    derived.push(("gear_stage_1.ratio", "N".into()));
    // The stall torque at the output: the data sheet's, else the ideal gearbox's.
    let ts_at_output = ts_out.unwrap_or(ts_motor * n);
    // [stiffness] with N_r = 1: k_eq = k1 k2 / (k1 + k2) = k1 / 2 for k1 = k2.
    let k_eq = ts_at_output / GUESS_STALL_TWIST_DEG.to_radians();
    guesses.push((
        "stiffness.k1_nm_per_rad",
        format!(
            "GUESS: the stall torque twists the train by {GUESS_STALL_TWIST_DEG}° (k_eq = {k_eq:.3e}); diagnose calibrates k_eq"
        ),
    ));
    guesses.push(("stiffness.k2_nm_per_rad", "GUESS: as k1".into()));
    derived.push(("load.inertia_kg_m2", "given (rough)".into()));
    guesses.push((
        "load.coulomb_friction_nm",
        format!(
            "GUESS: {:.0} % of the stall torque; diagnose calibrates it",
            100.0 * GUESS_LOAD_FRICTION_SHARE
        ),
    ));
    guesses.push((
        "backlash.total_deg",
        "GUESS: hobby spur gearbox; diagnose calibrates it".into(),
    ));
    let params = ActuatorParams {
        sample_period_s: h,
        motor: MotorParams {
            resistance_ohm: r,
            inductance_h: l,
            torque_constant_nm_per_a: k,
            back_emf_v_s_per_rad: k,
            tach_v_s_per_rad: k,
            inertia_kg_m2: jm,
            coulomb_friction_nm: tfm,
        },
        gears: GearTrain {
            stage1_ratio: n,
            stage2_ratio: 1.0,
            revolving: false,
            stiffness: Stiffness::Measured {
                k1_nm_per_rad: 2.0 * k_eq,
                k2_nm_per_rad: 2.0 * k_eq,
            },
        },
        load: LoadParams {
            inertia_kg_m2: jl,
            coulomb_friction_nm: GUESS_LOAD_FRICTION_SHARE * ts_at_output,
        },
        backlash_deg: GUESS_BACKLASH_DEG,
        effects: Effects::NONE,
    };
    params_file::validate(&params, "the data-sheet figures")?;
    Ok(Derived {
        params,
        guesses,
        derived,
        stall_efficiency: efficiency,
    })
}

impl Derived {
    /// The parameter file: a header naming the figures and what `diagnose` does with the
    /// guesses, and each derived or guessed key commented (`# GUESS: …`).
    pub fn to_toml(&self, d: &DataSheet) -> Result<String, HostError> {
        let opt = |x: Option<f64>, unit: &str| {
            x.map(|x| format!("{x} {unit}"))
                .unwrap_or_else(|| "not given".into())
        };
        let mut header = vec![
            format!(
                "A geared motor from its data sheet (geared-servo {} init): {} V, no-load {} rpm at the output, stall torque {}, stall current {}, no-load current {}, ratio {}, load inertia {} kg*m^2.",
                env!("CARGO_PKG_VERSION"),
                d.supply_v,
                d.no_load_rpm,
                opt(d.stall_torque_nm, "N*m"),
                opt(d.stall_current_a, "A"),
                opt(d.no_load_current_a, "A"),
                d.gear_ratio,
                d.load_inertia_kg_m2
            ),
            "Keys marked GUESS are not on a data sheet: `geared-servo diagnose` calibrates the inertias, the stiffness (k_eq), both frictions and the backlash from these starting values; R, k_t, k_b, the tachometer constant and L stay as written (`--fit motor.resistance_ohm,motor.tach_v_s_per_rad` adds the first and the last but one).".to_string(),
        ];
        if let Some(e) = self.stall_efficiency {
            header.push(format!(
                "The stall torque is {:.0} % of N k I_s: the gearbox's efficiency at stall (the model's gears are lossless; the friction carries the losses).",
                100.0 * e
            ));
        }
        let text = params_file::to_toml(&self.params, &header)?;
        let mut doc: toml_edit::DocumentMut = text
            .parse()
            .map_err(|e| HostError::other(format!("cannot annotate the parameter file: {e}")))?;
        let notes = self
            .derived
            .iter()
            .map(|(k, why)| (*k, format!("from the data sheet: {why}")))
            .chain(self.guesses.iter().map(|(k, why)| (*k, why.clone())));
        for (key, note) in notes {
            let Some((table, field)) = key.split_once('.') else {
                continue;
            };
            if let Some(v) = doc
                .get_mut(table)
                .and_then(|t| t.as_table_mut())
                .and_then(|t| t.get_mut(field))
                .and_then(|i| i.as_value_mut())
            {
                v.decor_mut().set_suffix(format!("   # {note}"));
            }
        }
        Ok(doc.to_string())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn sheet() -> DataSheet {
        DataSheet {
            supply_v: 12.0,
            no_load_rpm: 100.0,
            stall_torque_nm: Some(1.2),
            stall_current_a: None,
            no_load_current_a: Some(0.1),
            gear_ratio: 100.0,
            load_inertia_kg_m2: 2e-4,
            motor_inertia_kg_m2: None,
            inductance_h: None,
            sample_period_s: 5e-4,
        }
    }

    /// The closed forms, against the two operating points they come from.
    #[test]
    fn no_load_and_stall_points_are_reproduced() {
        let d = sheet();
        let p = derive(&d).unwrap().params;
        let m = &p.motor;
        let w0 = 100.0 * 100.0 * std::f64::consts::PI / 30.0;
        // No load: V = R I₀ + k ω₀; stall: k V / R = T_s / N.
        assert!((m.resistance_ohm * 0.1 + m.torque_constant_nm_per_a * w0 - 12.0).abs() < 1e-12);
        assert!((m.torque_constant_nm_per_a * 12.0 / m.resistance_ohm - 0.012).abs() < 1e-15);
        assert_eq!(m.torque_constant_nm_per_a, m.back_emf_v_s_per_rad);
        assert!((m.coulomb_friction_nm - m.torque_constant_nm_per_a * 0.1).abs() < 1e-15);
        assert_eq!(p.derived().unwrap().n_total, 100.0);
    }

    #[test]
    fn a_stall_current_sets_the_resistance_and_a_torque_then_checks_it() {
        let mut d = sheet();
        d.stall_current_a = Some(2.0);
        let out = derive(&d).unwrap();
        assert!((out.params.motor.resistance_ohm - 6.0).abs() < 1e-12);
        let k = out.params.motor.torque_constant_nm_per_a;
        let e = out.stall_efficiency.unwrap();
        assert!((e - 1.2 / (100.0 * k * 2.0)).abs() < 1e-12);
        // A stall torque ten times what that current gives is not the same motor.
        d.stall_torque_nm = Some(12.0);
        let err = derive(&d).unwrap_err();
        assert!(
            err.message.starts_with("--stall-torque-nm:"),
            "{}",
            err.message
        );
    }

    #[test]
    fn bad_figures_are_one_line_errors_naming_the_option() {
        type Edit = fn(&mut DataSheet);
        let cases: [(Edit, &str); 6] = [
            (|d| d.supply_v = 0.0, "--supply-v:"),
            (|d| d.no_load_rpm = f64::NAN, "--no-load-rpm:"),
            (|d| d.gear_ratio = -3.0, "--gear-ratio:"),
            (
                |d| d.stall_torque_nm = None,
                "--stall-torque-nm, --stall-current-a:",
            ),
            (|d| d.no_load_current_a = Some(-0.1), "--no-load-current-a:"),
            (
                |d| {
                    d.stall_current_a = Some(0.5);
                    d.no_load_current_a = Some(0.6);
                },
                "--no-load-current-a:",
            ),
        ];
        for (edit, start) in cases {
            let mut d = sheet();
            edit(&mut d);
            let e = derive(&d).unwrap_err();
            assert!(e.message.starts_with(start), "{}", e.message);
            assert!(!e.message.contains('\n'));
        }
    }

    /// The file reads back to the same parameters and marks every guess.
    #[test]
    fn the_file_reads_back_and_marks_the_guesses() {
        let d = sheet();
        let out = derive(&d).unwrap();
        let text = out.to_toml(&d).unwrap();
        let back = params_file::parse(&text, "rig.toml").unwrap();
        assert_eq!(format!("{back:?}"), format!("{:?}", out.params));
        for key in [
            "k1_nm_per_rad",
            "total_deg",
            "inertia_kg_m2 = ",
            "inductance_h",
        ] {
            assert!(
                text.lines().any(|l| l.contains(key) && l.contains("GUESS")),
                "{key}: {text}"
            );
        }
        assert!(text
            .lines()
            .any(|l| l.starts_with("resistance_ohm") && l.contains("data sheet")));
    }
}
