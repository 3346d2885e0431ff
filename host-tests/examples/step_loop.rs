//! Tight loop of `Plant::step` for profiling (`perf record`, `valgrind --tool=callgrind`).
use geared_servo::{Plant, PlantState, REFERENCE};
fn main() {
    let plant = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
    let mut st = PlantState::REST;
    let mut acc = 0.0f32;
    let n: u32 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(2_000_000);
    let t = std::time::Instant::now();
    for k in 0..n {
        let v = if (k / 4000) % 2 == 0 { 10.0 } else { -10.0 };
        acc += plant.step(&mut st, v).tach_voltage_v;
    }
    let dt = t.elapsed();
    println!("{acc} {:.2} ns/step", dt.as_nanos() as f64 / n as f64);
}
