//! Sensor and bridge faults of the virtual actuator read exactly as they say, and revert.

use geared_servo::{
    ActuatorFaults, DriveConfig, Plant, SensorConfig, SensorFault, VirtualActuator, REFERENCE,
};

fn actuator() -> VirtualActuator {
    let plant = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
    VirtualActuator::new(plant, &DriveConfig::REFERENCE, &SensorConfig::REFERENCE).unwrap()
}

/// Runs `steps` steps at signed duty `duty` with `faults`, returning the last readings.
fn run(
    act: &mut VirtualActuator,
    duty: i32,
    steps: usize,
    faults: &ActuatorFaults,
) -> geared_servo::Readings {
    act.set_faults(faults);
    act.set_signed_duty(duty).unwrap();
    for _ in 0..steps {
        act.step();
    }
    *act.readings()
}

#[test]
fn each_sensor_fault_reads_as_it_says_and_reverts_when_cleared() {
    let full = (1u32 << SensorConfig::REFERENCE.tach.bits) - 1;
    type Check = Box<dyn Fn(i64, i64) -> bool>;
    let cases: Vec<(&str, SensorFault, Check)> = vec![
        (
            "stuck",
            SensorFault::StuckAt(1234),
            Box::new(|_, got| got == 1234),
        ),
        (
            "offset",
            SensorFault::Offset(-40),
            Box::new(|h, got| got == h - 40),
        ),
        (
            "dropout zero",
            SensorFault::Dropout(false),
            Box::new(|_, got| got == 0),
        ),
        (
            "dropout full",
            SensorFault::Dropout(true),
            Box::new(move |_, got| got == i64::from(full)),
        ),
        (
            "lost lsbs",
            SensorFault::LostLsbs(5),
            Box::new(|h, got| got == h & !31),
        ),
        (
            "noise burst",
            SensorFault::NoiseBurst(20.0),
            Box::new(|h, got| (got - h).abs() <= 20 && got != h),
        ),
    ];
    for (name, fault, check) in cases {
        // Healthy and faulty twins from the same state: the reading differs only by the fault.
        let mut healthy = actuator();
        let mut faulty = actuator();
        let h = run(&mut healthy, 300, 200, &ActuatorFaults::NONE);
        let f = run(
            &mut faulty,
            300,
            200,
            &ActuatorFaults {
                tach: fault,
                pot: fault,
                ..ActuatorFaults::NONE
            },
        );
        assert!(
            check(i64::from(h.tach_counts), i64::from(f.tach_counts)),
            "tach {name}: {} vs {}",
            f.tach_counts,
            h.tach_counts
        );
        assert!(
            check(i64::from(h.pot_counts), i64::from(f.pot_counts)),
            "pot {name}: {} vs {}",
            f.pot_counts,
            h.pot_counts
        );
        // The plant never saw the sensor fault.
        assert_eq!(healthy.state(), faulty.state(), "{name}");
        let h = run(&mut healthy, 300, 1, &ActuatorFaults::NONE);
        let f = run(&mut faulty, 300, 1, &ActuatorFaults::NONE);
        if !matches!(fault, SensorFault::NoiseBurst(_)) {
            assert_eq!(h, f, "{name}: cleared, the readings are healthy again");
        }
    }
}

#[test]
fn encoder_faults_leave_the_true_count_underneath() {
    let mut healthy = actuator();
    let mut faulty = actuator();
    run(&mut healthy, 400, 300, &ActuatorFaults::NONE);
    let f = run(
        &mut faulty,
        400,
        300,
        &ActuatorFaults {
            encoder: SensorFault::Dropout(false),
            ..ActuatorFaults::NONE
        },
    );
    assert_eq!(f.encoder_count, 0);
    let g = run(
        &mut faulty,
        400,
        1,
        &ActuatorFaults {
            encoder: SensorFault::GainDrift(0.5),
            ..ActuatorFaults::NONE
        },
    );
    let h = run(&mut healthy, 400, 1, &ActuatorFaults::NONE);
    assert!(h.encoder_count > 100);
    assert_eq!(g.encoder_count, (h.encoder_count as f32 * 1.5) as i32);
    let f = run(&mut faulty, 400, 1, &ActuatorFaults::NONE);
    let h = run(&mut healthy, 400, 1, &ActuatorFaults::NONE);
    assert_eq!(
        f.encoder_count, h.encoder_count,
        "cleared: the true count, nothing lost"
    );
}

#[test]
fn gain_drift_scales_the_physical_value() {
    let mut healthy = actuator();
    let mut faulty = actuator();
    let h = run(&mut healthy, 500, 400, &ActuatorFaults::NONE);
    let f = run(
        &mut faulty,
        500,
        400,
        &ActuatorFaults {
            tach: SensorFault::GainDrift(0.1),
            ..ActuatorFaults::NONE
        },
    );
    let tach = SensorConfig::REFERENCE.tach;
    let (vh, vf) = (
        tach.to_physical(h.tach_counts),
        tach.to_physical(f.tach_counts),
    );
    // Within one count of 10 % high.
    assert!(
        (vf - 1.1 * vh).abs() <= 1.5 * tach.lsb(),
        "{vf} vs 1.1 × {vh}"
    );
}

#[test]
fn bus_sag_and_stuck_pwm_change_what_the_winding_gets() {
    let mut a = actuator();
    let mut b = actuator();
    run(
        &mut a,
        500,
        1,
        &ActuatorFaults {
            bus_factor: 0.5,
            ..ActuatorFaults::NONE
        },
    );
    run(&mut b, 250, 1, &ActuatorFaults::NONE);
    assert_eq!(
        a.outputs(),
        b.outputs(),
        "half the bus at duty 500 is the full bus at 250"
    );
    let mut c = actuator();
    let mut d = actuator();
    run(
        &mut c,
        900,
        50,
        &ActuatorFaults {
            pwm_stuck: Some(-200),
            ..ActuatorFaults::NONE
        },
    );
    run(&mut d, -200, 50, &ActuatorFaults::NONE);
    assert_eq!(c.state(), d.state(), "stuck at −200 whatever was commanded");
}
