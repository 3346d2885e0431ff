//! One 291-point stepped-sine sweep (10–300 Hz, 1 Hz steps, 10 V_pk, continuous sine) of the
//! reference actuator, with and without backlash. Target (issue 3): ≤ 50 ms with backlash.
//!
//! `cargo bench -p geared-servo-host-tests --bench sweep`

#![allow(missing_docs)] // criterion_group! generates undocumented items

use criterion::{criterion_group, criterion_main, Criterion};
use geared_servo::REFERENCE;
use geared_servo_host::fr::{grid, Bench, SweepOptions};
use std::hint::black_box;

fn sweep(c: &mut Criterion) {
    let freqs = grid(10.0, 300.0, 1.0).unwrap();
    let mut g = c.benchmark_group("sweep_291_points_10v");
    g.sample_size(20);
    for b in [0.0, 0.08] {
        // Cold: bench construction (plant discretisation, describing function) and the 291
        // sine drives (matrix exponentials; `paper` shares them across backlash values through
        // `fr::Drives`, a new bench builds its own) are part of the sweep.
        g.bench_function(format!("backlash_{b}_deg"), |bch| {
            bch.iter(|| {
                let bench =
                    Bench::new(&REFERENCE.with_backlash_deg(b), SweepOptions::default()).unwrap();
                black_box(bench.sweep(black_box(&freqs), &()).unwrap())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, sweep);
criterion_main!(benches);
