//! The computation shared by the `plant_smoke` example (host and Cortex-M4F) and the host
//! test that compares both with `examples/expected/plant_smoke.txt`.

use geared_servo::{math, Plant, PlantState, REFERENCE};

/// Steps the reference actuator with 0.08° of backlash through 400 steps (0.2 s) of a 10 V,
/// 20 Hz sine from rest and reports every 20th step: step, tachometer voltage (V), current
/// (A), load angle (rad), gears in contact. Returns false if the plant cannot be built.
pub fn run(line: &mut dyn FnMut(core::fmt::Arguments)) -> bool {
    let Ok(plant) = Plant::new(&REFERENCE.with_backlash_deg(0.08)) else {
        return false;
    };
    let mut st = PlantState::REST;
    let w = 2.0 * core::f32::consts::PI * 20.0;
    for k in 0..400u32 {
        let (s, _) = math::sin_cos(w * k as f32 * plant.sample_period_s());
        let o = plant.step(&mut st, 10.0 * s);
        if k % 20 == 19 {
            line(format_args!(
                "{} {} {} {} {}",
                k + 1,
                o.tach_voltage_v,
                o.current_a,
                o.load_angle_rad,
                u8::from(o.in_contact)
            ));
        }
    }
    true
}
