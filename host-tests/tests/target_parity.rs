//! The on-target examples print what the host prints. CI runs them under QEMU and diffs the
//! output with the same `examples/expected/*.txt` files; here the host run is compared with
//! them. Tolerance: none. Host and Cortex-M4F both compute in IEEE-754 `f32` without fused
//! multiply-add (Rust never contracts), with the same `libm`, so the text is identical.

#[path = "../../examples/shared/plant_smoke.rs"]
mod plant_smoke;

fn expected(name: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples/expected")
        .join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn plant_smoke_host_run_matches_the_expected_target_output() {
    let mut out = String::new();
    assert!(plant_smoke::run(&mut |a| {
        out.push_str(&a.to_string());
        out.push('\n');
    }));
    assert_eq!(out, expected("plant_smoke.txt"));
}

#[path = "../../examples/shared/fin_loop.rs"]
#[allow(dead_code)]
mod fin_loop;

#[path = "../../examples/shared/fin_faults.rs"]
mod fin_faults;

#[test]
fn fin_fault_scenario_host_run_matches_the_expected_target_output() {
    let mut out = String::new();
    let ok = fin_faults::run(&mut |a| {
        out.push_str(&a.to_string());
        out.push('\n');
    });
    assert!(ok, "{out}");
    assert_eq!(out, expected("fin_faults.txt"));
}
