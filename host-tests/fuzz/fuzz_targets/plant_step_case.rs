//! One `plant_step` fuzz case, shared by the fuzz target and the seed replay test
//! (`host-tests/tests/fuzz_seeds.rs`), so that a committed seed is checked on the very code
//! path libFuzzer ran: 16 bytes of parameters, then (voltage, fault) pairs of raw `f32` bits.

use geared_servo::{
    ActuatorParams, BrokenTooth, Jam, Plant, PlantFaults, PlantState, Stiffness, Winding, REFERENCE,
};

/// Reads f32s from raw bits: every bit pattern, including NaN payloads and subnormals.
fn f32s(data: &[u8]) -> impl Iterator<Item = f32> + '_ {
    data.chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
}

/// A parameter set from 16 bytes: each physical quantity of the reference scaled by a factor
/// 10^(−3…3), backlash 0–10°, effects on or off; rejected sets are skipped.
fn params(b: &[u8]) -> ActuatorParams {
    let f = |i: usize| 10f64.powf((f64::from(b[i % b.len()]) / 255.0) * 6.0 - 3.0);
    let mut p = REFERENCE;
    p.motor.resistance_ohm *= f(0);
    p.motor.inductance_h *= f(1);
    p.motor.torque_constant_nm_per_a *= f(2);
    p.motor.back_emf_v_s_per_rad *= f(3);
    p.motor.inertia_kg_m2 *= f(4);
    p.motor.coulomb_friction_nm *= f(5);
    p.load.inertia_kg_m2 *= f(6);
    p.load.coulomb_friction_nm *= f(7);
    p.gears.stiffness = Stiffness::Measured {
        k1_nm_per_rad: 78.0 * f(8),
        k2_nm_per_rad: 700.0 * f(9),
    };
    p.backlash_deg = f64::from(b[10 % b.len()]) / 25.5;
    p.effects.mesh_damping = if b[11 % b.len()] & 1 == 1 {
        0.01 * f(11)
    } else {
        0.0
    };
    p.effects.hinge_stiffness = if b[12 % b.len()] & 1 == 1 {
        10.0 * f(12)
    } else {
        0.0
    };
    p.effects.input_delay = f64::from(b[13 % b.len()] % 20) * 0.0001;
    p.effects.voltage_limit = if b[14 % b.len()] & 1 == 1 {
        30.0 * f(14)
    } else {
        0.0
    };
    p.sample_period_s = 0.0005 * f(15).clamp(0.01, 20.0);
    p
}

/// The faults one `f32` selects: none, or every plant fault set from its bits.
fn faults(x: f32) -> PlantFaults {
    if x.to_bits() & 3 == 0 {
        return PlantFaults::NONE;
    }
    PlantFaults {
        load_torque_nm: x,
        jam: if x.to_bits() & 4 == 0 {
            Jam::None
        } else {
            Jam::AtAngle(x)
        },
        extra_backlash_deg: x,
        friction_factor: x,
        broken_tooth: Some(BrokenTooth {
            angle_rad: x,
            width_rad: x,
            torque_loss: x,
        }),
        winding: match x.to_bits() & 24 {
            0 => Winding::Normal,
            8 => Winding::Open,
            _ => Winding::Shorted,
        },
    }
}

/// Runs the case: up to 64 steps with faults; panics on a non-finite output or state.
pub fn check(data: &[u8]) {
    if data.len() < 16 {
        return;
    }
    let (head, rest) = data.split_at(16);
    let Ok(plant) = Plant::new(&params(head)) else {
        return;
    };
    let mut st = PlantState::REST;
    let mut vals = f32s(rest);
    for _ in 0..64 {
        let Some(v) = vals.next() else { break };
        let f = faults(vals.next().unwrap_or(0.0));
        let o = plant.step_with_faults(&mut st, v, &f);
        let state_finite = [
            st.current_a,
            st.motor_speed_rad_s,
            st.load_speed_rad_s,
            st.twist_rad,
            st.load_angle_rad,
        ]
        .iter()
        .all(|x| x.is_finite());
        assert!(
            o.tach_voltage_v.is_finite()
                && o.motor_speed_rad_s.is_finite()
                && o.motor_angle_rad.is_finite()
                && o.load_speed_rad_s.is_finite()
                && o.current_a.is_finite()
                && o.load_angle_rad.is_finite()
                && o.transmitted_torque_nm.is_finite()
                && o.mean_current_a.is_finite()
                && o.applied_voltage_v.is_finite()
                && state_finite,
            "non-finite output {o:?} or state {st:?} after input {v} with {f:?}"
        );
    }
}
