//! Cost of one `Plant::step` on the host in each regime (issue #2: target ≤ 20 ns/step).
//!
//! `cargo bench -p geared-servo-host-tests --bench step`

#![allow(missing_docs)] // criterion_group! generates undocumented items

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use geared_servo::{Plant, PlantState, REFERENCE};

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
                plant.step(&mut s, black_box(v))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
