//! The fin loop meets faults: the `fin_loop` controller tracks a slow sine while a scenario
//! drops the tachometer out, blows a gust on the fin and jams it. Shared by the `fin_loop`
//! example (host and Cortex-M4F) and the host test that compares the printed response with
//! `examples/expected/fin_faults.txt`.

use crate::fin_loop::FinController;
use geared_servo::scenario::{Fault, Scenario, SensorChannel, TorqueProfile};
use geared_servo::{
    math, DriveConfig, Jam, Plant, SensorConfig, SensorFault, VirtualActuator, REFERENCE,
};

/// Backlash of the emulated actuator, degrees at the load.
const BACKLASH_DEG: f64 = 0.08;
/// Command: a 2° sine at 2 Hz about 0.
const AMPLITUDE_DEG: f32 = 2.0;
const FREQ_HZ: f32 = 2.0;
/// Run length, steps at 2 kHz (2 s); step counts below are at 2 kHz (2 steps per ms).
const STEPS: u32 = 4000;

/// The scenario, built in code as firmware would: (step, fault, label) — tachometer dropout
/// 0.5–0.8 s, a 0.3 N·m "1 − cos" gust of 50 ms at 1.0 s, a jam 1.5–1.8 s.
const EVENTS: [(u32, Fault, &str); 5] = [
    (
        1000,
        Fault::Sensor(SensorChannel::Tach, SensorFault::Dropout(false)),
        "tach dropout",
    ),
    (
        1600,
        Fault::Sensor(SensorChannel::Tach, SensorFault::None),
        "tach restored",
    ),
    (
        2000,
        Fault::LoadTorque(TorqueProfile::Gust {
            amplitude_nm: 0.3,
            duration_steps: 100,
        }),
        "gust",
    ),
    (3000, Fault::Jam(Jam::Here), "jam"),
    (3600, Fault::Jam(Jam::None), "jam cleared"),
];

/// Windows the response is summarised over: (first step, end step, label).
const WINDOWS: [(u32, u32, &str); 6] = [
    (400, 1000, "nominal"),
    (1000, 1600, "tach dropout"),
    (1600, 2000, "recovered"),
    (2000, 2400, "gust"),
    (3000, 3600, "jammed"),
    (3600, 4000, "after jam"),
];

#[derive(Clone, Copy, Default)]
struct Window {
    sq: f32,
    max_err: f32,
    i_sq: f32,
    i_max: f32,
    n: u32,
}

/// Runs the scenario and prints, per window, the tracking error (RMS and peak, degrees) and
/// the winding current (RMS and peak, A). Returns false if anything cannot be built or a
/// duty is refused, or if the response is not what the faults must cause (the jam must stall
/// the motor at a higher current than nominal tracking draws).
pub fn run(line: &mut dyn FnMut(core::fmt::Arguments)) -> bool {
    let Ok(plant) = Plant::new(&REFERENCE.with_backlash_deg(BACKLASH_DEG)) else {
        return false;
    };
    let h = plant.sample_period_s();
    let drive = DriveConfig::REFERENCE;
    let sensors = SensorConfig::REFERENCE;
    let Ok(mut act) = VirtualActuator::new(plant, &drive, &sensors) else {
        return false;
    };
    let mut ctl = FinController::new(sensors, &drive);
    let mut scenario: Scenario<8> = Scenario::new();
    for (step, fault, label) in EVENTS {
        if scenario.push(step, fault).is_err() {
            return false;
        }
        line(format_args!(
            "fin_faults: event at {} ms: {}",
            step / 2,
            label
        ));
    }
    let deg = core::f32::consts::PI / 180.0;
    let amp = AMPLITUDE_DEG * deg;
    let w = 2.0 * core::f32::consts::PI * FREQ_HZ;
    let mut stats = [Window::default(); WINDOWS.len()];
    for k in 0..STEPS {
        let t = k as f32 * h;
        let (s, c) = math::sin_cos(w * t);
        let reference = (amp * s, amp * w * c, -amp * w * w * s);
        act.set_faults(scenario.advance(k));
        let parts = act.parts();
        let (mut pwm, mut dir) = (parts.pwm, parts.dir);
        if !ctl.update(reference, parts.readings, &mut pwm, &mut dir) {
            return false;
        }
        act.step();
        let o = act.outputs();
        // Outputs are at the end of step k: compare with the reference there.
        let (s1, _) = math::sin_cos(w * (t + h));
        let e = math::abs(amp * s1 - o.load_angle_rad) / deg;
        let i = math::abs(o.current_a);
        for (win, st) in WINDOWS.iter().zip(stats.iter_mut()) {
            if (win.0..win.1).contains(&k) {
                st.sq += e * e;
                st.max_err = st.max_err.max(e);
                st.i_sq += i * i;
                st.i_max = st.i_max.max(i);
                st.n += 1;
            }
        }
    }
    let mut rms_i = [0.0f32; WINDOWS.len()];
    for ((win, st), r) in WINDOWS.iter().zip(stats.iter()).zip(rms_i.iter_mut()) {
        let n = st.n.max(1) as f32;
        *r = math::sqrt(st.i_sq / n);
        line(format_args!(
            "fin_faults: {}-{} ms {}: tracking_rms_deg {} tracking_max_deg {} current_rms_a {} current_max_a {}",
            win.0 / 2,
            win.1 / 2,
            win.2,
            math::sqrt(st.sq / n),
            st.max_err,
            *r,
            st.i_max
        ));
    }
    let ok = rms_i[4] > rms_i[0];
    line(format_args!(
        "fin_faults: result: {}",
        if ok { "ok" } else { "FAIL" }
    ));
    ok
}
