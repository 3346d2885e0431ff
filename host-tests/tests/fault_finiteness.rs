//! Once finite, always finite: whatever faults a caller puts in `PlantFaults` (extreme but
//! finite, NaN, ±∞), whatever the command (±1e30, NaN, ±∞) and whatever valid parameters,
//! every output and every state variable after every step is finite, and so are the
//! fault-free steps that follow. The fuzz target `plant_step` checks the same claim with
//! coverage guidance; this runs on every `cargo test`.

use geared_servo::{
    ActuatorParams, BrokenTooth, Jam, Outputs, Plant, PlantFaults, PlantState, Stiffness, Winding,
    REFERENCE,
};
use proptest::prelude::*;

/// Valid parameter sets over the fuzz target's range: each physical quantity of the
/// reference scaled by 10^(−3…3), backlash 0–10°, effects on or off, delay 0–2 ms, sample
/// period 5 µs–10 ms. Sets the constructor refuses are skipped.
fn params() -> impl Strategy<Value = ActuatorParams> {
    let f = || -3.0f64..3.0;
    (
        prop::array::uniform12(f()),
        0.0f64..10.0,
        (any::<bool>(), any::<bool>(), any::<bool>()),
        (0u8..20, -2.0f64..1.3),
    )
        .prop_map(|(e, backlash, (mesh, hinge, limit), (delay, h))| {
            let s = |k: usize| 10f64.powf(e[k]);
            let mut p = REFERENCE;
            p.motor.resistance_ohm *= s(0);
            p.motor.inductance_h *= s(1);
            p.motor.torque_constant_nm_per_a *= s(2);
            p.motor.back_emf_v_s_per_rad *= s(3);
            p.motor.inertia_kg_m2 *= s(4);
            p.motor.coulomb_friction_nm *= s(5);
            p.load.inertia_kg_m2 *= s(6);
            p.load.coulomb_friction_nm *= s(7);
            p.gears.stiffness = Stiffness::Measured {
                k1_nm_per_rad: 78.0 * s(8),
                k2_nm_per_rad: 700.0 * s(9),
            };
            p.backlash_deg = backlash;
            p.effects.mesh_damping = if mesh { 0.01 * s(10) } else { 0.0 };
            p.effects.hinge_stiffness = if hinge { 10.0 * s(11) } else { 0.0 };
            p.effects.voltage_limit = if limit { 30.0 * s(10) } else { 0.0 };
            p.effects.input_delay = f64::from(delay) * 0.0001;
            p.sample_period_s = 0.0005 * 10f64.powf(h);
            p
        })
        .prop_filter("parameters the constructor accepts", |p| {
            Plant::new(p).is_ok()
        })
}

/// Any number a caller may pass: ordinary magnitudes, extreme finite ones, NaN and ±∞.
fn number() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -10.0f32..10.0,
        2 => prop::sample::select(vec![
            0.0f32, -0.0, 1.0, -1.0, 1e-40, -1e-40, 1e6, -1e6, 1.7e9, -1.7e9, 1e30, -1e30,
            f32::MAX, f32::MIN, f32::MIN_POSITIVE,
        ]),
        1 => prop::sample::select(vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY]),
        1 => any::<f32>(),
    ]
}

fn faults() -> impl Strategy<Value = PlantFaults> {
    (
        number(),
        prop_oneof![
            Just(Jam::None),
            Just(Jam::Here),
            number().prop_map(Jam::AtAngle)
        ],
        number(),
        number(),
        prop::option::of((number(), number(), number())),
        prop::sample::select(vec![Winding::Normal, Winding::Open, Winding::Shorted]),
    )
        .prop_map(
            |(torque, jam, wear, friction, tooth, winding)| PlantFaults {
                load_torque_nm: torque,
                jam,
                extra_backlash_deg: wear,
                friction_factor: friction,
                broken_tooth: tooth.map(|(angle_rad, width_rad, torque_loss)| BrokenTooth {
                    angle_rad,
                    width_rad,
                    torque_loss,
                }),
                winding,
            },
        )
}

/// Steps of a fault sequence: each fault set held for 1–80 steps (a runaway needs a few
/// dozen steps to overflow) under random commands.
fn sequence() -> impl Strategy<Value = Vec<(PlantFaults, Vec<f32>)>> {
    prop::collection::vec((faults(), prop::collection::vec(number(), 1..80)), 1..12)
}

fn all_finite(o: &Outputs, s: &PlantState) -> bool {
    [
        o.tach_voltage_v,
        o.motor_speed_rad_s,
        o.motor_angle_rad,
        o.load_speed_rad_s,
        o.load_angle_rad,
        o.current_a,
        o.mean_current_a,
        o.transmitted_torque_nm,
        o.applied_voltage_v,
        s.current_a,
        s.motor_speed_rad_s,
        s.load_speed_rad_s,
        s.twist_rad,
        s.load_angle_rad,
    ]
    .iter()
    .all(|x| x.is_finite())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn faulty_steps_and_the_fault_free_steps_after_them_stay_finite(
        p in params(),
        seq in sequence(),
        after in prop::collection::vec(number(), 1..64),
    ) {
        let plant = Plant::new(&p).unwrap();
        let mut st = PlantState::REST;
        for (k, (f, volts)) in seq.iter().enumerate() {
            for &v in volts {
                let o = plant.step_with_faults(&mut st, v, f);
                prop_assert!(all_finite(&o, &st), "fault set {k}: {o:?} {st:?} after {v} under {f:?}");
                let o = plant.outputs_with_faults(&st, f);
                prop_assert!(all_finite(&o, &st), "fault set {k}: outputs {o:?} under {f:?}");
            }
        }
        for &v in &after {
            let o = plant.step(&mut st, v);
            prop_assert!(all_finite(&o, &st), "fault-free: {o:?} {st:?} after {v}");
        }
    }
}
