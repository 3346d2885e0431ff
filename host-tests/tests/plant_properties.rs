//! Properties of the stepped plant over random valid parameters and bounded inputs.

use geared_servo::{ActuatorParams, Plant, PlantState, REFERENCE};
use proptest::prelude::*;

/// Random parameter sets: every physical quantity of the reference scaled by 0.3–3×,
/// backlash 0–0.3°, frictions 0–5× the reference's (0 included).
fn params() -> impl Strategy<Value = ActuatorParams> {
    let scale = || 0.3f64..3.0;
    (
        (scale(), scale(), scale(), scale(), scale(), scale()),
        (scale(), scale(), 0.0f64..0.3),
        (
            prop_oneof![Just(0.0), 0.0f64..5.0],
            prop_oneof![Just(0.0), 0.0f64..5.0],
        ),
        (
            prop_oneof![Just(0.0), 0.0f64..0.2],
            prop_oneof![Just(0.0), 0.0f64..50.0],
        ),
    )
        .prop_map(
            |((r, l, kt, jm, jl, kts), (n1, k, b), (fm, fl), (mesh, hinge))| {
                let mut p = REFERENCE;
                p.motor.resistance_ohm *= r;
                p.motor.inductance_h *= l;
                p.motor.torque_constant_nm_per_a *= kt;
                p.motor.back_emf_v_s_per_rad *= kt;
                p.motor.tach_v_s_per_rad *= kts;
                p.motor.inertia_kg_m2 *= jm;
                p.motor.coulomb_friction_nm *= fm;
                p.load.inertia_kg_m2 *= jl;
                p.load.coulomb_friction_nm *= fl;
                p.gears.stage1_ratio *= n1;
                p.gears.stiffness = geared_servo::Stiffness::Measured {
                    k1_nm_per_rad: 78.36 * k,
                    k2_nm_per_rad: 700.0 * k,
                };
                p.backlash_deg = b;
                p.effects.mesh_damping = mesh;
                p.effects.hinge_stiffness = hinge;
                p
            },
        )
}

fn inputs() -> impl Strategy<Value = Vec<f32>> {
    prop::collection::vec(-40.0f32..40.0, 50..300)
}

fn run(plant: &Plant, v: &[f32]) -> Vec<geared_servo::Outputs> {
    let mut st = PlantState::REST;
    v.iter().map(|&x| plant.step(&mut st, x)).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn outputs_stay_finite(p in params(), v in inputs()) {
        let plant = Plant::new(&p).unwrap();
        for o in run(&plant, &v) {
            prop_assert!(o.tach_voltage_v.is_finite() && o.current_a.is_finite());
            prop_assert!(o.load_angle_rad.is_finite() && o.transmitted_torque_nm.is_finite());
            prop_assert!(o.mean_current_a.is_finite() && o.motor_angle_rad.is_finite());
        }
    }

    #[test]
    fn no_torque_through_the_gears_inside_the_gap(p in params(), v in inputs()) {
        let plant = Plant::new(&p).unwrap();
        let delta = plant.half_gap_rad();
        let mut st = PlantState::REST;
        for &x in &v {
            let o = plant.step(&mut st, x);
            if st.twist_rad.abs() <= delta {
                prop_assert_eq!(o.transmitted_torque_nm, 0.0);
                prop_assert!(!o.in_contact);
            } else {
                prop_assert!(o.in_contact);
            }
        }
    }

    #[test]
    fn negating_the_input_negates_the_outputs(p in params(), v in inputs()) {
        let plant = Plant::new(&p).unwrap();
        let neg: Vec<f32> = v.iter().map(|x| -x).collect();
        for (a, b) in run(&plant, &v).iter().zip(run(&plant, &neg).iter()) {
            // Bit-exact: every operation in the step is odd in the state and the input.
            prop_assert_eq!(a.tach_voltage_v, -b.tach_voltage_v);
            prop_assert_eq!(a.current_a, -b.current_a);
            prop_assert_eq!(a.load_angle_rad, -b.load_angle_rad);
            prop_assert_eq!(a.transmitted_torque_nm, -b.transmitted_torque_nm);
        }
    }

    #[test]
    fn at_rest_with_zero_input_stays_at_rest(p in params()) {
        let plant = Plant::new(&p).unwrap();
        let mut st = PlantState::REST;
        for _ in 0..200 {
            plant.step(&mut st, 0.0);
        }
        prop_assert_eq!(st, PlantState::REST);
    }

    #[test]
    fn a_voltage_below_breakaway_never_moves_the_motor(p in params(), signs in prop::collection::vec(any::<bool>(), 50..300), frac in 0.0f64..0.99) {
        let mut p = p;
        if p.motor.coulomb_friction_nm == 0.0 {
            p.motor.coulomb_friction_nm = REFERENCE.motor.coulomb_friction_nm;
        }
        let plant = Plant::new(&p).unwrap();
        // Stall torque k_t V / R below the motor's Coulomb friction.
        let v_max = frac * p.motor.coulomb_friction_nm * p.motor.resistance_ohm / p.motor.torque_constant_nm_per_a;
        let mut st = PlantState::REST;
        for s in signs {
            let o = plant.step(&mut st, if s { v_max as f32 } else { -v_max as f32 });
            prop_assert_eq!(o.motor_speed_rad_s, 0.0);
            prop_assert_eq!(o.load_angle_rad, 0.0);
        }
    }

    #[test]
    fn stored_energy_never_exceeds_energy_put_in(p in params(), v in inputs()) {
        let mut p = p;
        p.motor.coulomb_friction_nm = p.motor.coulomb_friction_nm.max(1e-5);
        p.load.coulomb_friction_nm = p.load.coulomb_friction_nm.max(1e-4);
        let plant = Plant::new(&p).unwrap();
        let h = f64::from(plant.sample_period_s());
        let mut st = PlantState::REST;
        let mut e_in = 0.0f64;
        let mut e_in_max = 0.0f64;
        for &x in &v {
            let o = plant.step(&mut st, x);
            // Power in over the step: V times the exact mean current.
            e_in += f64::from(x) * f64::from(o.mean_current_a) * h;
            e_in_max = e_in_max.max(e_in.abs());
            let stored = plant.stored_energy_j(&st);
            // Tolerance: f32 rounding of the states and of the mean current (relative
            // 1e-4 of the energy turned over) — the physics allows no excess at all.
            prop_assert!(stored <= e_in + 1e-4 * e_in_max + 1e-12,
                "stored {stored} J > put in {e_in} J");
        }
    }

    #[test]
    fn with_zero_input_stored_energy_never_rises(p in params(), v in inputs()) {
        // After a random drive the input is held at 0 V: no power enters, so the stored
        // energy may only fall (resistance, friction, damping). This is what exposes any
        // energy injected by the event corrections (contact impulses, friction reversal).
        let plant = Plant::new(&p).unwrap();
        let mut st = PlantState::REST;
        for &x in &v {
            plant.step(&mut st, x);
        }
        let mut prev = plant.stored_energy_j(&st);
        let scale = prev;
        for k in 0..400 {
            plant.step(&mut st, 0.0);
            let e = plant.stored_energy_j(&st);
            // Tolerance: f32 state rounding, relative 1e-5 of the energy at the start.
            prop_assert!(e <= prev + 1e-5 * scale + 1e-15, "step {k}: {e} J after {prev} J");
            prev = e;
        }
    }

    #[test]
    fn same_inputs_give_bit_identical_outputs(p in params(), v in inputs()) {
        let a = run(&Plant::new(&p).unwrap(), &v);
        let b = run(&Plant::new(&p).unwrap(), &v);
        prop_assert_eq!(a, b);
    }
}
