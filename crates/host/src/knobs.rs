//! The adjustable parameters ("knobs") of a calibration: which ones, their units, their
//! internal coordinate (log for positive quantities), bounds and finite-difference steps, and
//! how each is read from and written into an [`ActuatorParams`].

use crate::error::HostError;
use crate::synth;
use geared_servo::{ActuatorParams, Stiffness};

/// Parameters calibrated by default (those that are non-zero in the file; backlash only when
/// the file gives one). Datasheet constants (k_t, k_b, k_ts, L), the ratio and the armature
/// resistance stay fixed. R is left out on purpose: when L/R is far below the sample period,
/// scaling R by 1/s and every mechanical quantity (inertias, stiffness, friction, effects)
/// by s leaves the voltage-to-tachometer response unchanged (the current scales by s), so the
/// data cannot separate R from the mechanical scale. R is the one an ohmmeter measures.
pub const BASE_KNOBS: [&str; 6] = [
    "motor.inertia_kg_m2",
    "load.inertia_kg_m2",
    "stiffness.k_eq_nm_per_rad",
    "motor.coulomb_friction_nm",
    "load.coulomb_friction_nm",
    "backlash.total_deg",
];

/// Every parameter `diagnose --fit` accepts: the default set, plus the armature resistance and
/// the tachometer constant (for data that can separate them).
pub const FITTABLE: [&str; 8] = [
    "motor.inertia_kg_m2",
    "load.inertia_kg_m2",
    "stiffness.k_eq_nm_per_rad",
    "motor.coulomb_friction_nm",
    "load.coulomb_friction_nm",
    "backlash.total_deg",
    "motor.resistance_ohm",
    "motor.tach_v_s_per_rad",
];

/// One adjustable parameter: its name, scale and bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct Knob {
    /// Key path (`motor.resistance_ohm`) or effect name (`mesh_damping`).
    pub name: String,
    /// Logarithmic internal coordinate (positive quantities).
    pub log: bool,
    /// Lower bound, in the parameter's unit.
    pub lo: f64,
    /// Upper bound, in the parameter's unit.
    pub hi: f64,
    /// Central-difference step in the internal coordinate.
    pub fd_step: f64,
}

impl Knob {
    /// Internal coordinate of value `v` (clamped into bounds).
    pub fn to_z(&self, v: f64) -> f64 {
        let v = v.clamp(self.lo, self.hi);
        if self.log {
            v.ln()
        } else {
            v
        }
    }
    /// Value of internal coordinate `z`, within bounds.
    pub fn from_z(&self, z: f64) -> f64 {
        let v = if self.log { z.exp() } else { z };
        if v.is_nan() {
            self.lo
        } else {
            v.clamp(self.lo, self.hi)
        }
    }
}

/// Replaces geometry by the equivalent measured stiffness (same k1, k2), so that the
/// stiffness can be scaled and written back in the `[stiffness]` form.
pub fn with_measured_stiffness(p: &ActuatorParams) -> Result<ActuatorParams, HostError> {
    let d = p
        .derived()
        .map_err(|e| HostError::input(format!("key `{}` {}", e.field(), e.reason())))?;
    let mut q = *p;
    q.gears.stiffness = Stiffness::Measured {
        k1_nm_per_rad: d.k1_nm_per_rad,
        k2_nm_per_rad: d.k2_nm_per_rad,
    };
    Ok(q)
}

/// Value of parameter `name` in `p` (NaN if unknown).
pub fn get(p: &ActuatorParams, name: &str) -> f64 {
    match name {
        "motor.resistance_ohm" => p.motor.resistance_ohm,
        "motor.inertia_kg_m2" => p.motor.inertia_kg_m2,
        "load.inertia_kg_m2" => p.load.inertia_kg_m2,
        "stiffness.k_eq_nm_per_rad" => p.derived().map(|d| d.k_eq_nm_per_rad).unwrap_or(f64::NAN),
        "motor.coulomb_friction_nm" => p.motor.coulomb_friction_nm,
        "load.coulomb_friction_nm" => p.load.coulomb_friction_nm,
        "backlash.total_deg" => p.backlash_deg,
        "motor.tach_v_s_per_rad" => p.motor.tach_v_s_per_rad,
        _ => synth::effect_value(&p.effects, name).unwrap_or(f64::NAN),
    }
}

/// Sets parameter `name` in `p`. The stiffness scales k1 and k2 together (their ratio, which
/// only splits k_eq between the stages, is not observable from the motor side).
pub fn set(p: &mut ActuatorParams, name: &str, v: f64) {
    match name {
        "motor.resistance_ohm" => p.motor.resistance_ohm = v,
        "motor.inertia_kg_m2" => p.motor.inertia_kg_m2 = v,
        "load.inertia_kg_m2" => p.load.inertia_kg_m2 = v,
        "stiffness.k_eq_nm_per_rad" => {
            let now = get(p, name);
            if let Stiffness::Measured {
                k1_nm_per_rad,
                k2_nm_per_rad,
            } = &mut p.gears.stiffness
            {
                if now.is_finite() && now > 0.0 {
                    *k1_nm_per_rad *= v / now;
                    *k2_nm_per_rad *= v / now;
                }
            }
        }
        "motor.coulomb_friction_nm" => p.motor.coulomb_friction_nm = v,
        "load.coulomb_friction_nm" => p.load.coulomb_friction_nm = v,
        "backlash.total_deg" => p.backlash_deg = v,
        "motor.tach_v_s_per_rad" => p.motor.tach_v_s_per_rad = v,
        _ => {
            let _ = synth::set_effect(&mut p.effects, name, v);
        }
    }
}

/// Unit of parameter `name`.
pub fn unit(name: &str) -> &'static str {
    match name {
        "motor.resistance_ohm" => "ohm",
        "motor.inertia_kg_m2" | "load.inertia_kg_m2" => "kg*m^2",
        "stiffness.k_eq_nm_per_rad" => "N*m/rad",
        "motor.coulomb_friction_nm" | "load.coulomb_friction_nm" => "N*m",
        "backlash.total_deg" => "deg",
        "motor.tach_v_s_per_rad" => "V*s/rad",
        _ => synth::effect_unit(name).unwrap_or(""),
    }
}

/// Natural magnitude of effect `name` for `p` (the scale its search grid is built on):
/// back-EMF damping for viscous friction, critical damping of the gear mode for mesh
/// damping, k_eq for the hinge, one sample for the delay, the largest command for the limit.
pub fn effect_scale(p: &ActuatorParams, name: &str, max_abs_v: f64) -> f64 {
    let m = &p.motor;
    let emf = m.torque_constant_nm_per_a * m.back_emf_v_s_per_rad / m.resistance_ohm;
    let d = p.derived().ok();
    let n = d.map(|d| d.n_total).unwrap_or(1.0);
    let k = d.map(|d| d.k_eq_nm_per_rad).unwrap_or(1.0);
    let (jm_l, jl) = (n * n * m.inertia_kg_m2, p.load.inertia_kg_m2);
    match name {
        "motor_viscous" => emf,
        "load_viscous" => emf * n * n,
        "mesh_damping" => 2.0 * (k * jm_l * jl / (jm_l + jl)).sqrt(),
        "hinge_stiffness" => k,
        "input_delay" => p.sample_period_s,
        "voltage_limit" => max_abs_v,
        _ => 1.0,
    }
}

/// The knob for parameter or effect `name`, with bounds around `p`'s value (or around the
/// effect's natural scale when the effect is off).
pub fn knob(p: &ActuatorParams, name: &str, max_abs_v: f64) -> Knob {
    let v = get(p, name);
    let h = p.sample_period_s;
    match name {
        "input_delay" => Knob {
            name: name.into(),
            log: false,
            lo: 0.0,
            hi: 0.99 * geared_servo::plant::MAX_DELAY_STEPS as f64 * h,
            fd_step: 0.1 * h,
        },
        "tach_gain" => Knob {
            name: name.into(),
            log: false,
            lo: -0.9,
            hi: 3.0,
            fd_step: 0.01,
        },
        "voltage_limit" => Knob {
            name: name.into(),
            log: true,
            lo: 0.02 * max_abs_v.max(1e-3),
            hi: 2.0 * max_abs_v.max(1e-3),
            fd_step: 0.01,
        },
        _ if synth::effect_unit(name).is_some() => {
            let s = effect_scale(p, name, max_abs_v);
            Knob {
                name: name.into(),
                log: true,
                lo: s * 1e-5,
                hi: s * 1e3,
                fd_step: 0.02,
            }
        }
        _ => Knob {
            name: name.into(),
            log: true,
            lo: v / 30.0,
            hi: v * 30.0,
            fd_step: 0.02,
        },
    }
}

/// The default set for `p`: every base parameter that is non-zero there.
pub fn default_knobs(p: &ActuatorParams, max_abs_v: f64) -> Vec<Knob> {
    BASE_KNOBS
        .iter()
        .filter(|n| get(p, n) > 0.0)
        .map(|n| knob(p, n, max_abs_v))
        .collect()
}
