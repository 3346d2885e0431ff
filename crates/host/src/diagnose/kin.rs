//! Effects that records of one output often cannot tell apart, and what would separate them.

use crate::calibrate::{self, Knob, Param};
use geared_servo::{ActuatorParams, Effect};

/// One way to separate two effects: a record of an output the records lack (`needs`, a
/// column of `crate::record::OUTPUT_COLUMNS`), or another procedure (`None`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Separation {
    /// The output this way records; `None` for a procedure (another excitation).
    pub needs: Option<&'static str>,
    /// What to do, and why it separates them.
    pub how: &'static str,
}

/// A procedure that separates two effects ([`Separation`]).
const fn by(how: &'static str) -> Separation {
    Separation { needs: None, how }
}

/// A record of `output` that separates two effects ([`Separation`]).
const fn recording(output: &'static str, how: &'static str) -> Separation {
    Separation {
        needs: Some(output),
        how,
    }
}

const LOG_CURRENT_VISCOUS: Separation = recording(
    "current_a",
    "log the armature current (viscous friction draws current, a sensor error does not)",
);
const ANGLE_INDEPENDENT: Separation = recording(
    "load_angle_deg",
    "record the load angle with an independent sensor",
);
const TWO_AMPLITUDES_CONTACT: Separation = by(
    "a stepped sine at two amplitudes through the resonance (mesh damping acts only in contact)",
);
const TWO_AMPLITUDES_SATURATION: Separation =
    by("records at two amplitudes (saturation depends on the amplitude, a delay or a gain error does not)");

/// Pairs of effects that records of one output at one amplitude often cannot tell apart,
/// with what would separate them: the one list the search and the report use. When one of
/// a pair is among the candidates refitted, so is the other, so that a tie is reported as a
/// tie, not decided by which of the two the projection happened to rank higher.
pub const KIN: [(Effect, Effect, &[Separation]); 10] = [
    (
        Effect::TachGain,
        Effect::MotorViscous,
        &[LOG_CURRENT_VISCOUS, ANGLE_INDEPENDENT],
    ),
    (
        Effect::TachGain,
        Effect::LoadViscous,
        &[LOG_CURRENT_VISCOUS, ANGLE_INDEPENDENT],
    ),
    (
        Effect::MotorViscous,
        Effect::LoadViscous,
        &[
            by("a stepped sine with more periods through the anti-resonance"),
            recording(
                "load_angle_deg",
                "a record of the load angle (the two damp different masses)",
            ),
        ],
    ),
    (
        Effect::MeshDamping,
        Effect::LoadViscous,
        &[TWO_AMPLITUDES_CONTACT],
    ),
    (
        Effect::MeshDamping,
        Effect::MotorViscous,
        &[TWO_AMPLITUDES_CONTACT],
    ),
    (
        Effect::HingeStiffness,
        Effect::GravityTorque,
        &[
            by("a record with large load angles"),
            by("one that starts away from the hanging position (a spring is linear in the angle, gravity goes as its sine)"),
        ],
    ),
    (
        Effect::InputDelay,
        Effect::TachLag,
        &[
            by("a stepped sine well above 1/(2π τ) (a lag's phase stops at 90°, a delay's grows without bound)"),
            recording(
                "load_angle_deg",
                "a record of the load angle (a tachometer lag does not delay it)",
            ),
        ],
    ),
    (
        Effect::InputDelay,
        Effect::VoltageLimit,
        &[TWO_AMPLITUDES_SATURATION],
    ),
    (
        Effect::VoltageLimit,
        Effect::TachGain,
        &[TWO_AMPLITUDES_SATURATION],
    ),
    (
        Effect::StictionRatio,
        Effect::DriveDeadband,
        &[
            recording(
                "current_a",
                "log the armature current (a dead band cuts it off around zero voltage, stiction does not)",
            ),
            by("a slow voltage ramp through zero (the dead band holds the motor at the voltage's reversal, stiction at the speed's)"),
        ],
    ),
];

/// The effects paired with `e` in [`KIN`].
pub fn kin(e: Effect) -> Vec<Effect> {
    KIN.iter()
        .filter_map(|&(a, b, _)| {
            if a == e {
                Some(b)
            } else if b == e {
                Some(a)
            } else {
                None
            }
        })
        .collect()
}

/// What would separate `a` from `b` when records of the outputs `measured` (column names)
/// cannot ([`KIN`], or a general advice): the ways that need an output the records already
/// have are left out.
pub fn separating_measurement(a: Effect, b: Effect, measured: &[&str]) -> String {
    let has = |o: &str| measured.contains(&o);
    let found = KIN
        .iter()
        .find(|&&(x, y, _)| (a == x && b == y) || (a == y && b == x))
        .map(|&(_, _, ways)| ways);
    let ways: Vec<&str> = found
        .unwrap_or(&[])
        .iter()
        .filter(|w| w.needs.is_none_or(|o| !has(o)))
        .map(|w| w.how)
        .collect();
    if !ways.is_empty() {
        return ways.join(", or ");
    }
    let missing: Vec<&str> = [("current_a", "current"), ("load_angle_deg", "load angle")]
        .iter()
        .filter(|(c, _)| !has(c))
        .map(|(_, n)| *n)
        .collect();
    if missing.is_empty() {
        "records at two amplitudes".to_string()
    } else {
        format!(
            "records at two amplitudes and of other outputs ({})",
            missing.join(", ")
        )
    }
}

/// The back-EMF damping of `p`'s motor, `b_e = k_t k_b / R`, N·m·s/rad: the viscous
/// torque per motor speed that a voltage source driving the winding adds (the scale of the
/// motor's viscous friction, [`ActuatorParams::effect_scales`]).
fn back_emf_damping(p: &ActuatorParams) -> f64 {
    p.effect_scales(0.0).back_emf_damping
}

/// The model `p` with its motor speed scale changed by `c`: every internal speed and angle
/// divided by `c` and the tachometer gain multiplied by it, so that the tachometer reads
/// what it read. Inertias, the stiffness, the mesh damping, the load's viscous friction and
/// the hinge spring are multiplied by `c` (the torques stay the same at the scaled speeds
/// and angles), the backlash is divided by it, the friction torques stay, and the motor's
/// viscous friction takes up the change of the back-EMF damping `b_e` ([`back_emf_damping`])
/// that the scaled speed brings: `b_e + b_m' = c (b_e + b_m)`. Exact for a record of the
/// tachometer when the armature's inductance is negligible (its time constant L/R against
/// the record's periods), with no gravity torque (a sine of the angle) and no current
/// pick-up; the armature current and the angles change. `None` when the motor's viscous
/// friction would have to be negative, or the result is not a valid parameter set.
pub fn speed_rescaled(p: &ActuatorParams, c: f64) -> Option<ActuatorParams> {
    let b_e = back_emf_damping(p);
    let b_m = c * (b_e + p.effects.get(Effect::MotorViscous)) - b_e;
    // A friction that should come out 0, up to rounding.
    let b_m = if b_m < 0.0 && b_m > -1e-9 * b_e {
        0.0
    } else {
        b_m
    };
    if !(c.is_finite() && c > 0.0 && b_m >= 0.0) {
        return None;
    }
    let mut q = *p;
    q.motor.inertia_kg_m2 *= c;
    q.load.inertia_kg_m2 *= c;
    calibrate::set(
        &mut q,
        Param::StiffnessKeq,
        c * calibrate::get(p, Param::StiffnessKeq),
    );
    q.backlash_deg /= c;
    for e in [
        Effect::MeshDamping,
        Effect::LoadViscous,
        Effect::HingeStiffness,
    ] {
        q.effects.set(e, c * p.effects.get(e));
    }
    q.effects.set(Effect::MotorViscous, b_m);
    let g = c * (1.0 + p.effects.get(Effect::TachGain)) - 1.0;
    q.effects.set(Effect::TachGain, g);
    q.derived().ok()?;
    Some(q)
}

/// Whether [`mirror`] exchanges `from` for `to` by rescaling every mechanical quantity (a
/// tachometer gain against a viscous friction: exact only up to the winding's L/R, and for
/// the load's friction up to its reflection through the gear ratio) rather than by
/// exchanging one torque term (a hinge spring against gravity, one viscous friction against
/// the other).
pub fn rescales(from: Effect, to: Effect) -> bool {
    [from, to].contains(&Effect::TachGain)
}

/// The model that explains a tachometer record as `p` does, with the effect `from` set back
/// to `from_value` (the current model's) and `to` in its place, for the pairs of [`KIN`]
/// whose exchange needs every mechanical quantity rescaled ([`speed_rescaled`]): a
/// tachometer gain error against the motor's or the load's viscous friction. A tachometer
/// that reads low and a viscous friction both lower the steady reading at a voltage, and on
/// a record's fast parts the gain looks like an inertia. The load's viscous friction is
/// taken as the motor's through the gear ratio (`b_m = b_L / N²`, exact where the gears are
/// in contact). A local search cannot walk from one to the other (every calibrated quantity
/// moves by the gain), so the search judges this point as one more refit of `to`
/// ([`super::search::mirror_points`]).
///
/// A hinge spring and gravity are the other such pair, without a rescaling: gravity's
/// torque −T sin θ_L is, about the hanging position θ_L = 0 where the record starts, the
/// spring −T θ_L (the plant takes that linear part into its exact transitions, docs/model.md),
/// so the spring's extra stiffness k becomes a gravity torque T = k and back, every other
/// quantity kept. The two part only at large load angles; a refit of one that found its
/// basin through a global settle shows the other where its basin is (gravity_torque/50 and
/// /51 of the foreign suite: the spring's global refit at the unit's T, gravity's own refits
/// in a worse basin of the other parameters, so gravity was not even in the spring's class).
///
/// The motor's and the load's viscous friction are a third: in contact the load's b_L is the
/// motor's b_L / N², and the two part only where the gears do (their gap, rattle), which the
/// search weights out. On a record of the load angle alone (motor_viscous/1 of the foreign
/// suite) the load's friction found its basin through a global settle (1.92e-2 N·m·s/rad)
/// while the motor's local refit stayed at nothing (1.9e-7 against the unit's 7.4e-6), and
/// the motor's friction was not even in the load's class.
///
/// `None` for other pairs, or where the other explanation would need a negative friction (a
/// tachometer that reads high is no friction), a negative torque or stiffness.
pub fn mirror(
    p: &ActuatorParams,
    from: Effect,
    from_value: f64,
    to: Effect,
) -> Option<ActuatorParams> {
    let n2 = p.derived().ok()?.n_total.powi(2);
    let b_e = back_emf_damping(p);
    let b_m = p.effects.get(Effect::MotorViscous);
    let mut q = *p;
    match (from, to) {
        (Effect::MotorViscous | Effect::LoadViscous, Effect::TachGain) => {
            // The friction to be taken out, as the motor's; the motor keeps `keep`.
            let (extra, keep) = if from == Effect::MotorViscous {
                (b_m - from_value, from_value)
            } else {
                let extra = (p.effects.get(Effect::LoadViscous) - from_value) / n2;
                q.effects.set(Effect::LoadViscous, from_value);
                q.effects.set(Effect::MotorViscous, b_m + extra);
                (extra, b_m)
            };
            let mut r = speed_rescaled(&q, (b_e + keep) / (b_e + keep + extra))?;
            r.effects.set(from, from_value);
            r.effects.set(Effect::MotorViscous, keep);
            Some(r)
        }
        (Effect::TachGain, Effect::MotorViscous | Effect::LoadViscous) => {
            let g = p.effects.get(Effect::TachGain);
            let mut r = speed_rescaled(&q, (1.0 + from_value) / (1.0 + g))?;
            r.effects.set(Effect::TachGain, from_value);
            if to == Effect::LoadViscous {
                let extra = r.effects.get(Effect::MotorViscous) - b_m;
                r.effects.set(Effect::MotorViscous, b_m);
                r.effects.set(
                    Effect::LoadViscous,
                    r.effects.get(Effect::LoadViscous) + n2 * extra,
                );
            }
            r.derived().ok()?;
            Some(r)
        }
        (Effect::HingeStiffness, Effect::GravityTorque)
        | (Effect::GravityTorque, Effect::HingeStiffness)
        | (Effect::MotorViscous, Effect::LoadViscous)
        | (Effect::LoadViscous, Effect::MotorViscous) => {
            // The part of the spring (or gravity, or the one viscous friction) that the
            // refit added, as the other: the same torque, the load's viscous friction seen
            // at the motor through the gear ratio.
            let extra = p.effects.get(from) - from_value;
            if !extra.is_finite() || extra <= 0.0 {
                return None;
            }
            let scale = match (from, to) {
                (Effect::LoadViscous, Effect::MotorViscous) => 1.0 / n2,
                (Effect::MotorViscous, Effect::LoadViscous) => n2,
                _ => 1.0,
            };
            q.effects.set(from, from_value);
            q.effects.set(to, p.effects.get(to) + scale * extra);
            q.derived().ok()?;
            Some(q)
        }
        _ => None,
    }
}

/// The drive's dead band as the motor Coulomb friction a model without it took on: below
/// the dead band the drive applies nothing, beyond it V − sign(V)·V_db, which where the
/// motor turns with the voltage is a friction torque k_t·V_db/R. A model fitted without
/// the dead band so takes the motor's Coulomb friction up (drive_deadband/54 of the foreign
/// suite: +180 % in the base), and a refit that adds the dead band on top of that friction
/// starts in the wrong basin. This start moves what the friction took above the file's
/// value into the dead band (clamped to the knob `k`'s range); `None` when the friction is
/// not above the file's.
pub fn deadband_from_friction(
    p: &ActuatorParams,
    file: &ActuatorParams,
    k: &Knob,
) -> Option<ActuatorParams> {
    let extra = p.motor.coulomb_friction_nm - file.motor.coulomb_friction_nm;
    if extra.is_nan() || extra <= 0.0 || p.motor.torque_constant_nm_per_a <= 0.0 {
        return None;
    }
    let v_db = p.effects.get(Effect::DriveDeadband)
        + extra * p.motor.resistance_ohm / p.motor.torque_constant_nm_per_a;
    let mut q = *p;
    q.motor.coulomb_friction_nm = file.motor.coulomb_friction_nm;
    calibrate::set(&mut q, k.param, v_db.clamp(k.lo, k.hi));
    Some(q)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::calibrate::tests::data_of;
    use crate::calibrate::{nrmse, Data};
    use geared_servo::REFERENCE;

    const H: f64 = 5e-4;

    /// The reference actuator with a mesh damping that keeps its gears from rattling (with
    /// rattle no two models follow each other sample by sample: MODEL.md) and `effect` at
    /// `value`, stiffness in measured form, at 2 kHz.
    pub(crate) fn unit(effect: Effect, value: f64) -> ActuatorParams {
        let mut p = calibrate::with_measured_stiffness(&REFERENCE.with_backlash_deg(0.05)).unwrap();
        p.sample_period_s = H;
        p.effects.set(Effect::MeshDamping, 0.1);
        p.effects.set(effect, value);
        p
    }

    /// 2 s of a ±9 V square wave at 2 Hz with a 2 V multisine (7–230 Hz) on it, as the
    /// tachometer record of `p`.
    pub(crate) fn record(p: &ActuatorParams) -> Data {
        let volts = (0..4000)
            .map(|k| {
                let t = k as f64 * H;
                let sq = if (k / 500) % 2 == 0 { 9.0 } else { -9.0 };
                let ms: f64 = [7.0, 31.0, 83.0, 230.0]
                    .iter()
                    .enumerate()
                    .map(|(i, f)| 0.5 * (std::f64::consts::TAU * f * t + i as f64).sin())
                    .sum();
                sq + ms
            })
            .collect();
        let mut d = data_of(volts, H, Some(p));
        d.output = "tach_voltage_v".into();
        d
    }

    /// Relative difference of two parameter sets' entries that the mirror maps.
    fn farthest(a: &ActuatorParams, b: &ActuatorParams) -> f64 {
        let rel = |x: f64, y: f64| {
            if x == y {
                0.0
            } else {
                (x - y).abs() / x.abs().max(y.abs())
            }
        };
        let mut worst = [
            rel(a.motor.inertia_kg_m2, b.motor.inertia_kg_m2),
            rel(a.load.inertia_kg_m2, b.load.inertia_kg_m2),
            rel(a.backlash_deg, b.backlash_deg),
            rel(
                calibrate::get(a, Param::StiffnessKeq),
                calibrate::get(b, Param::StiffnessKeq),
            ),
        ]
        .into_iter()
        .fold(0.0, f64::max);
        for e in Effect::ALL {
            worst = worst.max(rel(a.effects.get(e), b.effects.get(e)));
        }
        worst
    }

    #[test]
    fn the_advice_leaves_out_the_outputs_the_records_have() {
        use Effect::*;
        let tach = ["tach_voltage_v"];
        let both = ["tach_voltage_v", "load_angle_deg"];
        let angle = ["load_angle_deg"];
        // A tachometer alone: every way, as it always read.
        assert_eq!(
            separating_measurement(MotorViscous, LoadViscous, &tach),
            "a stepped sine with more periods through the anti-resonance, or a record of the load angle (the two damp different masses)"
        );
        assert_eq!(
            separating_measurement(TachGain, MotorViscous, &tach),
            "log the armature current (viscous friction draws current, a sensor error does not), or record the load angle with an independent sensor"
        );
        // With the angle: not "record the angle".
        assert_eq!(
            separating_measurement(LoadViscous, MotorViscous, &both),
            "a stepped sine with more periods through the anti-resonance"
        );
        assert!(!separating_measurement(TachGain, LoadViscous, &both).contains("load angle"));
        // With the current: not "log the current", for any pair.
        let cur = ["tach_voltage_v", "current_a"];
        for &(a, b, _) in &KIN {
            let s = separating_measurement(a, b, &cur);
            assert!(!s.contains("log the armature current"), "{a} {b}: {s}");
            assert!(!s.is_empty(), "{a} {b}");
        }
        // No pair listed: the outputs the records lack.
        assert_eq!(
            separating_measurement(TachOffset, GravityTorque, &angle),
            "records at two amplitudes and of other outputs (current)"
        );
        assert_eq!(
            separating_measurement(TachOffset, GravityTorque, &["load_angle_deg", "current_a"]),
            "records at two amplitudes"
        );
    }

    #[test]
    fn a_viscous_friction_and_a_slow_tachometer_read_alike_through_the_mirror() {
        // A motor friction of a tenth of the back-EMF damping: the tachometer gain that
        // stands in for it is −b/(b_e + b), every mechanical quantity 1/(1 + g) smaller.
        let b_e = back_emf_damping(&unit(Effect::MotorViscous, 0.0));
        for (from, value) in [
            (Effect::MotorViscous, 0.1 * b_e),
            (Effect::LoadViscous, 0.02),
        ] {
            let p = unit(from, value);
            let d = record(&p);
            let m = mirror(&p, from, 0.0, Effect::TachGain).unwrap();
            assert_eq!(m.effects.get(from), 0.0);
            let g = m.effects.get(Effect::TachGain);
            if from == Effect::MotorViscous {
                assert!((g + 0.1 / 1.1).abs() < 1e-12, "{g}");
                assert!((m.motor.inertia_kg_m2 / p.motor.inertia_kg_m2 - (1.0 + g)).abs() < 1e-12);
            }
            // The same tachometer record, to a small part of a 2 % noise (measured: 2.8e-5
            // for the motor's friction, the winding's L/R; 1.2e-2 for the load's, the
            // twist and the gap of the gears that the reflection through the gear ratio
            // ignores: a start for a polish, not an identity).
            let e = nrmse(&m, &d);
            let bound = if from == Effect::MotorViscous {
                1e-3
            } else {
                2e-2
            };
            assert!(e < bound, "{from}: the mirror's NRMSE {e}");
            // Not a trivial property of the record: without the rescaling, the tachometer
            // gain alone reads far off (4.7e-2 and 0.21).
            let mut plain = p;
            plain.effects.set(from, 0.0);
            plain.effects.set(Effect::TachGain, g);
            assert!(nrmse(&plain, &d) > 10.0 * e, "{from}");
            // And back.
            let back = mirror(&m, Effect::TachGain, 0.0, from).unwrap();
            assert!(farthest(&back, &p) < 1e-9, "{from}: {back:?} against {p:?}");
        }
    }

    #[test]
    fn a_tachometer_that_reads_high_is_no_friction() {
        let p = unit(Effect::TachGain, 0.05);
        assert!(mirror(&p, Effect::TachGain, 0.0, Effect::MotorViscous).is_none());
        assert!(mirror(&p, Effect::TachGain, 0.0, Effect::LoadViscous).is_none());
        // Pairs that are not one model in other units have no mirror.
        assert!(mirror(&p, Effect::InputDelay, 0.0, Effect::TachLag).is_none());
    }

    /// 2 s of a `volts` V sine at 3 Hz, as the tachometer record of `p`: no burst that
    /// rattles (a multisine's would make two models part sample by sample whatever they are:
    /// MODEL.md), so that what the record shows of a model is its response.
    fn sine_record(p: &ActuatorParams, volts: f64) -> Data {
        let u = (0..4000)
            .map(|k| volts * (std::f64::consts::TAU * 3.0 * k as f64 * H).sin())
            .collect();
        let mut d = data_of(u, H, Some(p));
        d.output = "tach_voltage_v".into();
        d
    }

    /// The largest |θ_L| of `p` over `d`'s input, degrees.
    fn widest_swing_deg(p: &ActuatorParams, d: &Data) -> f64 {
        let mut q = *p;
        q.sample_period_s = H;
        let plant = geared_servo::Plant::new(&q).unwrap();
        let mut st = geared_servo::PlantState::REST;
        d.volts
            .iter()
            .map(|&v| f64::from(plant.step(&mut st, v as f32).load_angle_rad).abs())
            .fold(0.0, f64::max)
            .to_degrees()
    }

    #[test]
    fn a_dead_band_reads_as_motor_friction_and_the_start_takes_it_back() {
        // A dead band of 0.5 V: where the motor turns with the voltage it is a friction
        // torque k_t·V_db/R, so a model without it that took that torque into its motor
        // Coulomb friction follows the record far better than the model without either
        // (measured: NRMSE 2.4e-2 against 6.2e-2 on the square wave and multisine; not
        // an identity: the two part where the voltage and the speed differ in sign, and
        // below the dead band, where the drive applies nothing).
        let v_db = 0.5;
        let p = unit(Effect::DriveDeadband, v_db);
        let d = record(&p);
        let file = unit(Effect::DriveDeadband, 0.0);
        let torque = p.motor.torque_constant_nm_per_a * v_db / p.motor.resistance_ohm;
        let mut stand_in = file;
        stand_in.motor.coulomb_friction_nm += torque;
        let (e_stand, e_none) = (nrmse(&stand_in, &d), nrmse(&file, &d));
        eprintln!("dead band as motor friction: NRMSE {e_stand:.3e}, neither {e_none:.3e}");
        assert!(
            e_stand < 0.5 * e_none,
            "stand-in {e_stand}, neither {e_none}"
        );
        // The start moves the friction above the file's back into the dead band, exactly.
        let k = calibrate::knob(&file, Param::Effect(Effect::DriveDeadband), 10.0);
        let q = deadband_from_friction(&stand_in, &file, &k).unwrap();
        assert_eq!(q.motor.coulomb_friction_nm, file.motor.coulomb_friction_nm);
        let got = q.effects.get(Effect::DriveDeadband);
        assert!((got / v_db - 1.0).abs() < 1e-9, "{got}");
        assert!(nrmse(&q, &d) < 1e-3, "{}", nrmse(&q, &d));
        // No start where the friction is not above the file's.
        assert!(deadband_from_friction(&file, &file, &k).is_none());
    }

    #[test]
    fn the_loads_viscous_friction_is_the_motors_through_the_gear_ratio() {
        let b_l = 0.02;
        let p = unit(Effect::LoadViscous, b_l);
        let n2 = p.derived().unwrap().n_total.powi(2);
        let m = mirror(&p, Effect::LoadViscous, 0.0, Effect::MotorViscous).unwrap();
        assert_eq!(m.effects.get(Effect::LoadViscous), 0.0);
        assert!((m.effects.get(Effect::MotorViscous) * n2 / b_l - 1.0).abs() < 1e-12);
        // In contact the two are one torque; they part only in the gear's gap, which the
        // square wave's reversals cross: the mirror reads the record closer than a change of
        // 10 % of the friction does, and far closer than the model without it.
        let d = record(&p);
        let mut off = p;
        off.effects.set(Effect::LoadViscous, 1.1 * b_l);
        let mut none = p;
        none.effects.set(Effect::LoadViscous, 0.0);
        let (e_m, e_off, e_none) = (nrmse(&m, &d), nrmse(&off, &d), nrmse(&none, &d));
        eprintln!("mirror {e_m:.2e}, 10 % off {e_off:.2e}, without {e_none:.2e}");
        assert!(e_m < e_off && 10.0 * e_m < e_none, "{e_m} {e_off} {e_none}");
        // And back: only what the refit added moves.
        let back = mirror(&m, Effect::MotorViscous, 0.0, Effect::LoadViscous).unwrap();
        assert!((back.effects.get(Effect::LoadViscous) / b_l - 1.0).abs() < 1e-12);
        assert_eq!(back.effects.get(Effect::MotorViscous), 0.0);
        assert!(mirror(&p, Effect::LoadViscous, b_l, Effect::MotorViscous).is_none());
    }

    #[test]
    fn a_hanging_arm_swinging_a_little_is_a_hinge_spring_through_the_mirror() {
        // A gravity torque of 0.1 N·m is a spring of 0.1 N·m/rad about the hanging position.
        let p = unit(Effect::GravityTorque, 0.1);
        let m = mirror(&p, Effect::GravityTorque, 0.0, Effect::HingeStiffness).unwrap();
        assert_eq!(m.effects.get(Effect::GravityTorque), 0.0);
        assert_eq!(m.effects.get(Effect::HingeStiffness), 0.1);
        // What a change of 1 % of the torque does to a record, for scale.
        let mut off = p;
        off.effects.set(Effect::GravityTorque, 0.101);
        // Small swings (1 V: θ_L within 2°, sin θ_L = θ_L to 10⁻⁴): the two read alike, far
        // closer than a 1 % change of the torque (measured: 1.7e-5 against 2.2e-3). Wide ones
        // (20 V: θ_L to 87°) part them, several times further than that change (2.6e-2 against
        // 1.3e-3): a record of wide swings tells them apart, and the mirror is a start there.
        let small = sine_record(&p, 1.0);
        let wide = sine_record(&p, 20.0);
        let (a_small, a_wide) = (widest_swing_deg(&p, &small), widest_swing_deg(&p, &wide));
        assert!(a_small < 2.0 && a_wide > 60.0, "{a_small}° {a_wide}°");
        let e_small = nrmse(&m, &small);
        assert!(e_small < 1e-4, "small swings: the mirror's NRMSE {e_small}");
        assert!(nrmse(&off, &small) > 10.0 * e_small);
        let e_wide = nrmse(&m, &wide);
        assert!(e_wide > 10.0 * nrmse(&off, &wide), "wide swings: {e_wide}");
        // And back, from a model that had a spring of its own already (only what the refit
        // added moves); a refit that took some away has nothing to move.
        let mut s = unit(Effect::HingeStiffness, 0.3);
        let back = mirror(&s, Effect::HingeStiffness, 0.2, Effect::GravityTorque).unwrap();
        assert_eq!(back.effects.get(Effect::HingeStiffness), 0.2);
        assert!((back.effects.get(Effect::GravityTorque) - 0.1).abs() < 1e-12);
        s.effects.set(Effect::HingeStiffness, 0.1);
        assert!(mirror(&s, Effect::HingeStiffness, 0.2, Effect::GravityTorque).is_none());
    }
}
