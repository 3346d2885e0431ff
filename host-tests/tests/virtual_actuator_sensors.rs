//! Emulated sensors against the physical values: ADC quantisation and saturation, encoder
//! counts, fixed-point conversion, seeded noise; and the trace ring buffer.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test fails by panicking

use fixed::types::I16F16;
use geared_servo::sensors::{to_fixed, Physical, Sensors};
use geared_servo::trace::{Trace, TraceSample};
use geared_servo::{
    AdcChannel, DriveConfig, EncoderConfig, EncoderShaft, Outputs, Plant, PlantState, SensorConfig,
    VirtualActuator, REFERENCE,
};

/// Outputs with the given tach voltage (V), load angle (rad) and motor angle (rad).
fn outputs(tach_v: f32, load_rad: f32, motor_rad: f32) -> Outputs {
    let plant = Plant::new(&REFERENCE).unwrap();
    let mut o = plant.outputs(&PlantState::REST);
    o.tach_voltage_v = tach_v;
    o.load_angle_rad = load_rad;
    o.motor_angle_rad = motor_rad;
    o
}

#[test]
fn adc_counts_are_the_nearest_code_within_half_an_lsb() {
    let ch = AdcChannel::new(12, -12.0, 12.0);
    assert_eq!(ch.full_scale_counts(), 4095);
    let lsb = ch.lsb();
    assert_eq!(lsb, 24.0 / 4095.0);
    for i in 0..=20_000 {
        let x = -12.0 + 24.0 * i as f32 / 20_000.0;
        let c = ch.convert(x, 0.0);
        let back = ch.to_physical(c);
        // Half an LSB, plus f32 rounding in the conversion and back (a few ulps of the
        // 24 V span: 1e-5 V), which can pick either code right at a decision level.
        assert!(
            (back - x).abs() <= 0.5 * lsb + 1e-5,
            "x {x} counts {c} back {back}"
        );
    }
    assert_eq!(ch.convert(-12.0, 0.0), 0);
    assert_eq!(ch.convert(0.0, 0.0), 2048); // 2047.5 rounds half up
    assert_eq!(ch.convert(12.0, 0.0), 4095);
}

#[test]
fn adc_saturates_at_zero_and_full_scale() {
    for bits in [8u8, 10, 12, 16] {
        let ch = AdcChannel::new(bits, -1.0, 1.0);
        let full = ch.full_scale_counts();
        assert_eq!(u32::from(full), (1u32 << bits) - 1);
        assert_eq!(ch.convert(1.0 + ch.lsb(), 0.0), full);
        assert_eq!(ch.convert(1e30, 0.0), full);
        assert_eq!(ch.convert(f32::INFINITY, 0.0), full);
        assert_eq!(ch.convert(-1.0 - ch.lsb(), 0.0), 0);
        assert_eq!(ch.convert(f32::NEG_INFINITY, 0.0), 0);
        assert_eq!(ch.convert(f32::NAN, 0.0), 0);
    }
}

#[test]
fn adc_offset_shifts_codes_and_firmware_conversion_removes_it() {
    let mut ch = AdcChannel::new(12, 0.0, 4095.0); // 1 unit per count
    ch.offset_counts = 7;
    assert_eq!(ch.convert(100.0, 0.0), 107);
    assert_eq!(ch.to_physical(107), 100.0);
    assert_eq!(ch.convert(4090.0, 0.0), 4095); // saturates with the offset
    ch.offset_counts = -7;
    assert_eq!(ch.convert(3.0, 0.0), 0);
}

#[test]
fn tach_and_pot_read_the_plant_outputs() {
    let cfg = SensorConfig::REFERENCE;
    let o = outputs(3.0, 10f32.to_radians(), 0.0);
    let s = Sensors::new(&cfg, &o).unwrap();
    let r = s.readings();
    assert_eq!(r.tach_counts, cfg.tach.convert(3.0, 0.0));
    // 3 V on ±12 V over 4095 codes: (15/24)·4095 = 2559.375 → 2559.
    assert_eq!(r.tach_counts, 2559);
    // 10° on ±60°: (70/120)·4095 = 2388.75 → 2389.
    assert_eq!(r.pot_counts, 2389);
    let back = cfg.pot.to_physical(r.pot_counts).to_degrees();
    assert!((back - 10.0).abs() <= 0.5 * 120.0 / 4095.0 + 1e-5);
    // Saturation beyond the pot's ±60°.
    let far = Sensors::new(&cfg, &outputs(-20.0, 1.5, 0.0)).unwrap();
    assert_eq!(far.readings().pot_counts, 4095);
    assert_eq!(far.readings().tach_counts, 0);
}

#[test]
fn encoder_counts_floor_of_angle_increments_both_ways() {
    let cfg = SensorConfig {
        encoder: EncoderConfig {
            counts_per_rev: 400,
            shaft: EncoderShaft::Motor,
        },
        ..SensorConfig::REFERENCE
    };
    let mut s = Sensors::new(&cfg, &outputs(0.0, 0.0, 1.0)).unwrap();
    assert_eq!(s.readings().encoder_count, 0, "reads 0 at construction");
    let per_count = core::f64::consts::TAU / 400.0;
    // Forward 10 revolutions and back past the start in uneven increments.
    let mut angle = 1.0f64;
    let mut path: Vec<f64> = (0..2000).map(|_| 0.0314).collect();
    path.extend((0..3000).map(|_| -0.0271));
    for d in path {
        angle += d;
        s.sample(&outputs(0.0, 0.0, angle as f32));
        let expected = ((angle - 1.0) / per_count).floor();
        let got = f64::from(s.readings().encoder_count);
        // ±1 count: the edge positions accumulate f32 rounding of the increments.
        assert!(
            (got - expected).abs() <= 1.0,
            "angle {angle}: {got} vs {expected}"
        );
    }
}

#[test]
fn encoder_tracks_many_motor_revolutions_of_the_plant() {
    let plant = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
    let drive = DriveConfig::REFERENCE;
    let mut act = VirtualActuator::new(plant, &drive, &SensorConfig::REFERENCE).unwrap();
    act.set_signed_duty(-1000).unwrap();
    for _ in 0..4000 {
        act.step();
    }
    // 2 s at full reverse: the motor turns some −360 rev. The count must equal the motor
    // angle in counts within 1 (the angle itself is f32: at 2300 rad its ulp is 2.4e-4 rad,
    // a fiftieth of a count).
    let theta = f64::from(act.outputs().motor_angle_rad);
    let expected = theta * 512.0 / core::f64::consts::TAU;
    let got = f64::from(act.readings().encoder_count);
    assert!(theta < -2000.0, "motor angle {theta}");
    assert!((got - expected).abs() <= 1.0, "{got} vs {expected}");
    assert_eq!(
        act.readings().encoder_count_u16(),
        act.readings().encoder_count as u16
    );
}

#[test]
fn load_encoder_counts_the_load_angle() {
    let cfg = SensorConfig {
        encoder: EncoderConfig {
            counts_per_rev: 4096,
            shaft: EncoderShaft::Load,
        },
        ..SensorConfig::REFERENCE
    };
    let mut s = Sensors::new(&cfg, &outputs(0.0, 0.0, 0.0)).unwrap();
    s.sample(&outputs(0.0, 0.5, 1e6)); // the motor angle must not matter
    assert_eq!(
        s.readings().encoder_count,
        (0.5f64 * 4096.0 / core::f64::consts::TAU).floor() as i32
    );
}

#[test]
fn fixed_point_values_round_to_nearest_and_saturate() {
    assert_eq!(to_fixed(1.5), I16F16::from_num(1.5));
    assert_eq!(to_fixed(-0.25), I16F16::from_num(-0.25));
    for x in [0.1f32, -3.3, 123.456, -32767.9, 1e-6] {
        let f = to_fixed(x);
        assert!(
            (f.to_num::<f64>() - f64::from(x)).abs() <= 0.5 / 65536.0 + 1e-12,
            "{x}"
        );
        // fixed rounds ties to even, we round them away from zero: at most one bit apart
        // (123.456f32 is such a tie).
        assert!((f - I16F16::from_num(x)).abs() <= I16F16::DELTA, "{x}");
    }
    assert_eq!(to_fixed(40_000.0), I16F16::MAX);
    assert_eq!(to_fixed(-40_000.0), I16F16::MIN);
    assert_eq!(to_fixed(f32::INFINITY), I16F16::MAX);
    assert_eq!(to_fixed(f32::NAN), I16F16::ZERO);
}

#[test]
fn physical_values_are_the_outputs_in_q16_16() {
    let plant = Plant::new(&REFERENCE).unwrap();
    let mut act =
        VirtualActuator::new(plant, &DriveConfig::REFERENCE, &SensorConfig::REFERENCE).unwrap();
    act.set_signed_duty(600).unwrap();
    for _ in 0..200 {
        act.step();
    }
    let (p, o): (Physical, Outputs) = (act.physical(), *act.outputs());
    for (f, x) in [
        (p.tach_voltage_v, o.tach_voltage_v),
        (p.motor_speed_rad_s, o.motor_speed_rad_s),
        (p.load_angle_rad, o.load_angle_rad),
        (p.load_speed_rad_s, o.load_speed_rad_s),
        (p.current_a, o.current_a),
    ] {
        assert!(
            (f.to_num::<f64>() - f64::from(x)).abs() <= 0.5 / 65536.0 + 1e-9,
            "{x}"
        );
    }
    assert!(o.motor_speed_rad_s > 100.0);
}

#[test]
fn noise_is_bounded_and_reproducible_from_the_seed() {
    let mut cfg = SensorConfig::REFERENCE;
    cfg.tach.noise_lsb = 2.0;
    cfg.noise_seed = 42;
    let run = |cfg: &SensorConfig| -> Vec<u16> {
        let mut s = Sensors::new(cfg, &outputs(1.0, 0.0, 0.0)).unwrap();
        (0..1000)
            .map(|_| {
                s.sample(&outputs(1.0, 0.0, 0.0));
                s.readings().tach_counts
            })
            .collect()
    };
    let clean = cfg.tach.convert(1.0, 0.0);
    let a = run(&cfg);
    assert_eq!(a, run(&cfg), "same seed, same counts");
    // Uniform ±2 LSB before rounding: codes within ±2 (plus the rounding half count).
    assert!(a
        .iter()
        .all(|&c| (i32::from(c) - i32::from(clean)).abs() <= 2));
    let distinct: std::collections::BTreeSet<u16> = a.iter().copied().collect();
    assert!(
        distinct.len() >= 4,
        "noise must actually spread the codes: {distinct:?}"
    );
    let mut other = cfg;
    other.noise_seed = 43;
    assert_ne!(a, run(&other), "another seed, other counts");
    // The pot has no noise configured: constant.
    let mut s = Sensors::new(&cfg, &outputs(1.0, 0.2, 0.0)).unwrap();
    let p0 = s.readings().pot_counts;
    for _ in 0..100 {
        s.sample(&outputs(1.0, 0.2, 0.0));
        assert_eq!(s.readings().pot_counts, p0);
    }
}

#[test]
fn bad_sensor_configuration_names_the_field() {
    use geared_servo::ParamError;
    let o = outputs(0.0, 0.0, 0.0);
    let mut c = SensorConfig::REFERENCE;
    c.tach.bits = 17;
    assert_eq!(
        Sensors::new(&c, &o).err(),
        Some(ParamError::OutOfRange("sensors.tach.bits"))
    );
    let mut c = SensorConfig::REFERENCE;
    c.pot.max = c.pot.min;
    assert_eq!(
        Sensors::new(&c, &o).err(),
        Some(ParamError::OutOfRange("sensors.pot.max"))
    );
    let mut c = SensorConfig::REFERENCE;
    c.pot.noise_lsb = -1.0;
    assert_eq!(
        Sensors::new(&c, &o).err(),
        Some(ParamError::Negative("sensors.pot.noise_lsb"))
    );
    let mut c = SensorConfig::REFERENCE;
    c.encoder.counts_per_rev = 0;
    assert_eq!(
        Sensors::new(&c, &o).err(),
        Some(ParamError::NonPositive("sensors.encoder.counts_per_rev"))
    );
}

#[test]
fn trace_keeps_the_last_n_steps_oldest_first() {
    let plant = Plant::new(&REFERENCE).unwrap();
    let mut act =
        VirtualActuator::new(plant, &DriveConfig::REFERENCE, &SensorConfig::REFERENCE).unwrap();
    let mut trace: Trace<TraceSample, 16> = Trace::new();
    assert!(trace.is_empty());
    act.set_signed_duty(500).unwrap();
    for _ in 0..40 {
        act.step();
        trace.record(TraceSample::capture(&act));
    }
    assert_eq!(trace.len(), 16);
    let steps: Vec<u32> = trace.oldest_first().map(|s| s.step).collect();
    assert_eq!(steps, (25..=40).collect::<Vec<_>>());
    let last = trace.latest().unwrap();
    assert_eq!(last.load_angle_rad, act.outputs().load_angle_rad);
    assert_eq!(last.pot_counts, act.readings().pot_counts);
    let mut lines = Vec::new();
    trace.dump(|s| lines.push(s.to_string()));
    assert_eq!(lines.len(), 16);
    assert_eq!(
        lines[0].split(' ').count(),
        TraceSample::HEADER.split(' ').count()
    );
    trace.clear();
    assert!(trace.is_empty());
}

#[test]
fn shared_actuator_refuses_reentry_instead_of_panicking() {
    use geared_servo::cortex_m::Shared;
    static ACT: Shared<VirtualActuator> = Shared::new();
    assert_eq!(ACT.with_mut(|a| a.steps()), None, "empty");
    let plant = Plant::new(&REFERENCE).unwrap();
    let act =
        VirtualActuator::new(plant, &DriveConfig::REFERENCE, &SensorConfig::REFERENCE).unwrap();
    assert!(ACT.put(act).unwrap().is_none());
    assert_eq!(ACT.with_mut(|a| a.step().encoder_count), Some(0));
    // Re-entry from inside (as an interrupt preempting the main loop's access would be on a
    // multi-priority system without the critical section): refused, not a panic.
    assert_eq!(ACT.with_mut(|_| ACT.with_mut(|a| a.steps())), Some(None));
    assert_eq!(ACT.with_mut(|_| ACT.take().is_none()), Some(true));
    assert_eq!(ACT.take().map(|a| a.steps()), Some(1));
}
