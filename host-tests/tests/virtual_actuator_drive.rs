//! The embedded-hal drive of the virtual actuator: duty and direction become the winding
//! voltage of the next step; bad duties are the trait's error, never a panic.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test fails by panicking

use embedded_hal::digital::{OutputPin, StatefulOutputPin};
use embedded_hal::pwm::{Error as _, ErrorKind, SetDutyCycle};
use geared_servo::{
    DriveConfig, DutyError, ParamError, Plant, SensorConfig, VirtualActuator, REFERENCE,
};

const BUS_V: f32 = 24.0;
const MAX_DUTY: u16 = 1000;

fn actuator() -> VirtualActuator {
    let plant = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
    let drive = DriveConfig {
        bus_voltage_v: BUS_V,
        max_duty: MAX_DUTY,
    };
    VirtualActuator::new(plant, &drive, &SensorConfig::REFERENCE).unwrap()
}

/// Voltage the plant applied over the last step (the reference plant has no input delay or
/// voltage limit, so it is the commanded one).
fn applied_after_step(act: &mut VirtualActuator) -> f32 {
    act.step();
    act.outputs().applied_voltage_v
}

#[test]
fn duty_zero_applies_zero_volts() {
    let mut act = actuator();
    act.pwm().set_duty_cycle(0).unwrap();
    assert_eq!(applied_after_step(&mut act), 0.0);
    act.pwm().set_duty_cycle_fully_off().unwrap();
    act.dir().set_high().unwrap();
    // −0.0 == 0.0: no voltage either way.
    assert_eq!(applied_after_step(&mut act), 0.0);
}

#[test]
fn full_duty_applies_the_bus_voltage() {
    let mut act = actuator();
    assert_eq!(act.pwm().max_duty_cycle(), MAX_DUTY);
    act.pwm().set_duty_cycle_fully_on().unwrap();
    assert_eq!(applied_after_step(&mut act), BUS_V);
    act.pwm().set_duty_cycle(MAX_DUTY).unwrap();
    assert_eq!(applied_after_step(&mut act), BUS_V);
}

#[test]
fn partial_duty_applies_bus_times_duty_over_max() {
    let mut act = actuator();
    for duty in [1u16, 250, 333, 999] {
        act.pwm().set_duty_cycle(duty).unwrap();
        let expected = BUS_V * f32::from(duty) / f32::from(MAX_DUTY);
        assert_eq!(applied_after_step(&mut act), expected, "duty {duty}");
    }
    act.pwm().set_duty_cycle_percent(50).unwrap();
    assert_eq!(applied_after_step(&mut act), 12.0);
    act.pwm().set_duty_cycle_fraction(1, 4).unwrap();
    assert_eq!(applied_after_step(&mut act), 6.0);
}

#[test]
fn direction_high_reverses_the_voltage_and_reads_back() {
    let mut act = actuator();
    act.pwm().set_duty_cycle(500).unwrap();
    act.dir().set_high().unwrap();
    assert!(act.dir().is_set_high().unwrap());
    assert_eq!(applied_after_step(&mut act), -12.0);
    act.dir().toggle().unwrap();
    assert!(act.dir().is_set_low().unwrap());
    assert_eq!(applied_after_step(&mut act), 12.0);
}

#[test]
fn signed_duty_sets_magnitude_and_direction() {
    let mut act = actuator();
    act.set_signed_duty(-1000).unwrap();
    assert_eq!(applied_after_step(&mut act), -BUS_V);
    assert!(act.drive().is_reverse());
    act.set_signed_duty(250).unwrap();
    assert_eq!(applied_after_step(&mut act), 6.0);
    assert!(!act.drive().is_reverse());
}

#[test]
fn command_takes_effect_at_the_next_step_not_before() {
    let mut act = actuator();
    act.step();
    let before = *act.outputs();
    act.pwm().set_duty_cycle(MAX_DUTY).unwrap();
    assert_eq!(
        *act.outputs(),
        before,
        "setting the duty must not move the plant"
    );
    assert_eq!(act.drive().voltage_v(), BUS_V);
    assert_eq!(applied_after_step(&mut act), BUS_V);
}

#[test]
fn out_of_range_duty_is_the_trait_error_and_keeps_the_previous_duty() {
    let mut act = actuator();
    act.pwm().set_duty_cycle(400).unwrap();
    let err = act.pwm().set_duty_cycle(MAX_DUTY + 1).unwrap_err();
    assert_eq!(
        err,
        DutyError {
            duty: 1001,
            max_duty: MAX_DUTY
        }
    );
    assert_eq!(err.kind(), ErrorKind::Other);
    assert!(act.pwm().set_duty_cycle(u16::MAX).is_err());
    // The default trait methods would debug-assert on these; ours return the error.
    assert!(act.pwm().set_duty_cycle_percent(101).is_err());
    assert!(act.pwm().set_duty_cycle_fraction(3, 2).is_err());
    assert!(act.pwm().set_duty_cycle_fraction(0, 0).is_err());
    assert!(act.set_signed_duty(-1001).is_err());
    assert!(act.set_signed_duty(i32::MIN).is_err());
    assert!(act.set_signed_duty(i32::MAX).is_err());
    assert_eq!(act.drive().duty(), 400);
    assert_eq!(applied_after_step(&mut act), BUS_V * 0.4);
}

#[test]
fn parts_hands_out_pwm_dir_and_readings_together() {
    let mut act = actuator();
    {
        let parts = act.parts();
        let (mut pwm, mut dir) = (parts.pwm, parts.dir);
        assert_eq!(parts.readings.encoder_count, 0);
        pwm.set_duty_cycle(100).unwrap();
        dir.set_high().unwrap();
    }
    assert_eq!(applied_after_step(&mut act), -2.4);
}

#[test]
fn bad_drive_configuration_names_the_field() {
    let plant = Plant::new(&REFERENCE).unwrap();
    let bad = |bus_voltage_v, max_duty| {
        VirtualActuator::new(
            plant.clone(),
            &DriveConfig {
                bus_voltage_v,
                max_duty,
            },
            &SensorConfig::REFERENCE,
        )
        .err()
    };
    assert_eq!(
        bad(0.0, 100),
        Some(ParamError::NonPositive("drive.bus_voltage_v"))
    );
    assert_eq!(
        bad(f32::NAN, 100),
        Some(ParamError::NonFinite("drive.bus_voltage_v"))
    );
    assert_eq!(
        bad(12.0, 0),
        Some(ParamError::NonPositive("drive.max_duty"))
    );
}
