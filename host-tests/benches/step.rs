//! Cost of one `Plant::step` on the host in each regime (issue #2: target ≤ 20 ns/step).
//!
//! `cargo bench -p geared-servo-host-tests --bench step`

#![allow(missing_docs)] // criterion_group! generates undocumented items

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use geared_servo::{Plant, PlantState, REFERENCE};

/// A run from rest through `volts`, the state carried from step to step (the tachometer
/// voltages summed, so that nothing is optimised away).
fn run(plant: &Plant, volts: &[f32]) -> f32 {
    let mut s = PlantState::REST;
    let mut acc = 0.0f32;
    for &v in volts {
        acc += black_box(plant).step(&mut s, black_box(v)).tach_voltage_v;
    }
    acc
}

fn bench(c: &mut Criterion) {
    let plant = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
    let d = plant.half_gap_rad();
    // Each start state stays in its regime for the whole step (checked below).
    let mut contact = PlantState::at_rest(0.0, 3.0 * d);
    contact.motor_speed_rad_s = 100.0;
    contact.load_speed_rad_s = 2.0;
    contact.current_a = 0.2;
    let mut gap = PlantState::at_rest(0.0, 0.0);
    gap.motor_speed_rad_s = 50.0;
    gap.load_speed_rad_s = 1.0;
    gap.current_a = 0.1;
    let stuck = PlantState::REST;
    // Twist 0.2δ short of the edge, closing fast: contact starts inside the step.
    let mut event = PlantState::at_rest(0.0, 0.8 * d);
    event.motor_speed_rad_s = 100.0;
    event.current_a = 0.2;

    let check = |name: &str, s0: PlantState, v: f32, contact_after: bool, moving: bool| {
        let mut s = s0;
        let o = plant.step(&mut s, v);
        assert_eq!(o.in_contact, contact_after, "{name}");
        assert_eq!(o.motor_speed_rad_s != 0.0, moving, "{name}");
    };
    check("contact", contact, 10.0, true, true);
    check("gap", gap, 1.0, false, true);
    check("stuck", stuck, 0.1, false, false);
    check("event", event, 10.0, true, true);

    let mut g = c.benchmark_group("step");
    for (name, s0, v) in [
        ("in_contact", contact, 10.0f32),
        ("in_gap", gap, 1.0),
        ("stuck_by_friction", stuck, 0.1),
        ("gap_edge_event", event, 10.0),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut s = black_box(s0);
                // `black_box(&plant)`: the step is inlined here, and nothing of the
                // configuration may be hoisted out of the loop (each call reloads it, as a
                // call from a control interrupt does).
                black_box(&plant).step(&mut s, black_box(v))
            })
        });
    }
    g.finish();

    // A run as firmware or a sweep makes it: the state carried from step to step, a ±10 V
    // square wave (period 40 ms) whose reversals cross the gap, events included.
    // Reported per step.
    const RUN: usize = 2000;
    let volts: Vec<f32> = (0..RUN)
        .map(|k| if (k / 40) % 2 == 0 { 10.0 } else { -10.0 })
        .collect();
    let mut s = PlantState::REST;
    let (mut gap, mut events, mut contact) = (0, 0, false);
    for &v in &volts {
        let o = plant.step(&mut s, v);
        gap += usize::from(!o.in_contact);
        events += usize::from(o.in_contact != contact);
        contact = o.in_contact;
    }
    eprintln!("run: {RUN} steps, {gap} in the gap, {events} contact changes");
    assert!(gap > RUN / 20 && events > 40, "the run must cross the gap");
    let mut g = c.benchmark_group("run");
    g.throughput(Throughput::Elements(RUN as u64));
    g.bench_function("square_10V_25Hz_rattling_per_2000_steps", |b| {
        b.iter(|| run(&plant, &volts))
    });
    g.finish();

    // A bench record's period (5.625 ms, as ../shared/data), longer than the reference's
    // resonance period: every step is sub-stepped (90 sub-steps in blocks of 10, each block
    // tried whole first). The non-chaotic ±10 V, 1 s square wave of plant_accuracy.rs's
    // long-period test, 4 s. Reported per step.
    let mut long = REFERENCE.with_backlash_deg(0.08);
    long.sample_period_s = 0.005625;
    let long = Plant::new(&long).unwrap();
    let steps = (4.0 / 0.005625) as usize;
    let volts: Vec<f32> = (0..steps)
        .map(|k| {
            if ((k as f64 * 0.005625 / 0.5) as usize).is_multiple_of(2) {
                10.0
            } else {
                -10.0
            }
        })
        .collect();
    let mut g = c.benchmark_group("run");
    g.throughput(Throughput::Elements(steps as u64));
    g.bench_function("square_10V_1Hz_at_5.625ms_per_711_steps", |b| {
        b.iter(|| run(&long, &volts))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
