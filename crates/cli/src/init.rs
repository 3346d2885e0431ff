//! `geared-servo init`: a parameter file from a gear motor's data sheet
//! (`geared_servo_host::datasheet`).

use crate::args::InitArgs;
use crate::common::Report;
use geared_servo_host::datasheet::{derive, DataSheet};
use geared_servo_host::record::write_file;
use geared_servo_host::HostError;

/// `geared-servo init`.
pub fn run(a: &InitArgs) -> Result<Report, HostError> {
    let sheet = DataSheet {
        supply_v: a.supply_v,
        no_load_rpm: a.no_load_rpm,
        stall_torque_nm: a.stall_torque_nm,
        stall_current_a: a.stall_current_a,
        no_load_current_a: a.no_load_current_a,
        gear_ratio: a.gear_ratio,
        load_inertia_kg_m2: a.load_inertia,
        motor_inertia_kg_m2: a.motor_inertia,
        inductance_h: a.inductance_h,
        sample_period_s: a.sample_period,
    };
    let out = derive(&sheet)?;
    write_file(&a.output, &out.to_toml(&sheet)?)?;
    let p = &out.params;
    let m = &p.motor;
    let d = p.derived().map_err(HostError::from)?;
    let guesses: Vec<&str> = out.guesses.iter().map(|(k, _)| *k).collect();
    let json = serde_json::json!({
        "output": a.output.display().to_string(),
        "resistance_ohm": m.resistance_ohm,
        "torque_constant_nm_per_a": m.torque_constant_nm_per_a,
        "back_emf_v_s_per_rad": m.back_emf_v_s_per_rad,
        "motor_inertia_kg_m2": m.inertia_kg_m2,
        "inductance_h": m.inductance_h,
        "motor_coulomb_friction_nm": m.coulomb_friction_nm,
        "n_total": d.n_total,
        "k_eq_nm_per_rad": d.k_eq_nm_per_rad,
        "backlash_deg": p.backlash_deg,
        "stall_efficiency": out.stall_efficiency,
        "guesses": guesses,
    });
    let mut text = format!(
        "wrote {}: R = {:.4} ohm, k_t = k_b = {:.5} N*m/A, motor friction {:.3e} N*m, N = {}, f_AR = {:.1} Hz (guessed stiffness)",
        a.output.display(),
        m.resistance_ohm,
        m.torque_constant_nm_per_a,
        m.coulomb_friction_nm,
        d.n_total,
        d.f_ar_hz
    );
    if let Some(e) = out.stall_efficiency {
        text.push_str(&format!(
            "\ngearbox efficiency at stall (stall torque / N k I_s): {:.0} %",
            100.0 * e
        ));
    }
    text.push_str(&format!(
        "\nguesses, for diagnose to calibrate or to be measured: {}",
        guesses.join(", ")
    ));
    Ok(Report { json, text })
}
