//! The adjustable parameters ("knobs") of a calibration: which ones, their units, their
//! internal coordinate (log for positive quantities), bounds and finite-difference steps, and
//! how each is read from and written into an [`ActuatorParams`].

use crate::error::HostError;
use geared_servo::{ActuatorParams, Effect, Stiffness};

/// A parameter a calibration can adjust: one of the actuator's own, named by its key path,
/// or an effect. Its [`name`](Param::name) is what `diagnose --fit` takes and its reports
/// print.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Param {
    /// `motor.resistance_ohm`, Ω.
    MotorResistance,
    /// `motor.inertia_kg_m2`, kg·m².
    MotorInertia,
    /// `load.inertia_kg_m2`, kg·m².
    LoadInertia,
    /// `stiffness.k_eq_nm_per_rad`, N·m/rad: k1 and k2 scaled together (their ratio only
    /// splits k_eq between the stages and is not observable from the motor side).
    StiffnessKeq,
    /// `motor.coulomb_friction_nm`, N·m.
    MotorFriction,
    /// `load.coulomb_friction_nm`, N·m.
    LoadFriction,
    /// `backlash.total_deg`, degrees.
    Backlash,
    /// `motor.tach_v_s_per_rad`, V·s/rad.
    TachConstant,
    /// An effect, in its unit.
    Effect(Effect),
}

impl Param {
    /// Key path (`motor.resistance_ohm`) or effect name (`mesh_damping`).
    pub const fn name(self) -> &'static str {
        match self {
            Param::MotorResistance => "motor.resistance_ohm",
            Param::MotorInertia => "motor.inertia_kg_m2",
            Param::LoadInertia => "load.inertia_kg_m2",
            Param::StiffnessKeq => "stiffness.k_eq_nm_per_rad",
            Param::MotorFriction => "motor.coulomb_friction_nm",
            Param::LoadFriction => "load.coulomb_friction_nm",
            Param::Backlash => "backlash.total_deg",
            Param::TachConstant => "motor.tach_v_s_per_rad",
            Param::Effect(e) => e.name(),
        }
    }

    /// Unit, as reports print it.
    pub const fn unit(self) -> &'static str {
        match self {
            Param::MotorResistance => "ohm",
            Param::MotorInertia | Param::LoadInertia => "kg*m^2",
            Param::StiffnessKeq => "N*m/rad",
            Param::MotorFriction | Param::LoadFriction => "N*m",
            Param::Backlash => "deg",
            Param::TachConstant => "V*s/rad",
            Param::Effect(e) => e.unit(),
        }
    }
}

impl std::fmt::Display for Param {
    /// The [`name`](Param::name) (padding and alignment apply).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.name())
    }
}

/// Parameters calibrated by default (those that are non-zero in the file; backlash only when
/// the file gives one). Datasheet constants (k_t, k_b, k_ts, L), the ratio and the armature
/// resistance stay fixed. R is left out on purpose: when L/R is far below the sample period,
/// scaling R by 1/s and every mechanical quantity (inertias, stiffness, friction, effects)
/// by s leaves the voltage-to-tachometer response unchanged (the current scales by s), so the
/// data cannot separate R from the mechanical scale. R is the one an ohmmeter measures.
pub const BASE_KNOBS: [Param; 6] = [
    Param::MotorInertia,
    Param::LoadInertia,
    Param::StiffnessKeq,
    Param::MotorFriction,
    Param::LoadFriction,
    Param::Backlash,
];

/// Every parameter `diagnose --fit` accepts: the default set, plus the armature resistance and
/// the tachometer constant (for data that can separate them).
pub const FITTABLE: [Param; 8] = [
    Param::MotorInertia,
    Param::LoadInertia,
    Param::StiffnessKeq,
    Param::MotorFriction,
    Param::LoadFriction,
    Param::Backlash,
    Param::MotorResistance,
    Param::TachConstant,
];

/// One adjustable parameter: its name, scale and bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct Knob {
    /// The parameter.
    pub param: Param,
    /// Logarithmic internal coordinate (positive quantities).
    pub log: bool,
    /// Lower bound, in the parameter's unit.
    pub lo: f64,
    /// Upper bound, in the parameter's unit.
    pub hi: f64,
    /// Central-difference step in the internal coordinate.
    pub fd_step: f64,
    /// Its lower bound is a legitimate value, not a sign that the fit wanted to go further:
    /// a background quantity that may as well be absent ([`background_damping_knob`]).
    pub floor_ok: bool,
}

impl Knob {
    /// The parameter's [`name`](Param::name).
    pub fn name(&self) -> &'static str {
        self.param.name()
    }

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
    let d = p.derived().map_err(HostError::from)?;
    let mut q = *p;
    q.gears.stiffness = Stiffness::Measured {
        k1_nm_per_rad: d.k1_nm_per_rad,
        k2_nm_per_rad: d.k2_nm_per_rad,
    };
    Ok(q)
}

/// Value of parameter `param` in `p` (k_eq: NaN if `p` is invalid).
pub fn get(p: &ActuatorParams, param: Param) -> f64 {
    match param {
        Param::MotorResistance => p.motor.resistance_ohm,
        Param::MotorInertia => p.motor.inertia_kg_m2,
        Param::LoadInertia => p.load.inertia_kg_m2,
        Param::StiffnessKeq => p.derived().map(|d| d.k_eq_nm_per_rad).unwrap_or(f64::NAN),
        Param::MotorFriction => p.motor.coulomb_friction_nm,
        Param::LoadFriction => p.load.coulomb_friction_nm,
        Param::Backlash => p.backlash_deg,
        Param::TachConstant => p.motor.tach_v_s_per_rad,
        Param::Effect(e) => p.effects.get(e),
    }
}

/// Sets parameter `param` in `p`. The stiffness needs the measured form
/// ([`with_measured_stiffness`]); on geometry (or an invalid `p`) it is left unchanged.
pub fn set(p: &mut ActuatorParams, param: Param, v: f64) {
    match param {
        Param::MotorResistance => p.motor.resistance_ohm = v,
        Param::MotorInertia => p.motor.inertia_kg_m2 = v,
        Param::LoadInertia => p.load.inertia_kg_m2 = v,
        Param::StiffnessKeq => {
            let now = get(p, param);
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
        Param::MotorFriction => p.motor.coulomb_friction_nm = v,
        Param::LoadFriction => p.load.coulomb_friction_nm = v,
        Param::Backlash => p.backlash_deg = v,
        Param::TachConstant => p.motor.tach_v_s_per_rad = v,
        Param::Effect(e) => p.effects.set(e, v),
    }
}

/// Natural magnitude of `effect` for `p` ([`Effect::natural_scale`]) on a record whose
/// largest command is `max_abs_v`, V.
pub fn effect_scale(p: &ActuatorParams, effect: Effect, max_abs_v: f64) -> f64 {
    effect.natural_scale(&p.effect_scales(max_abs_v))
}

/// The knob for `param`, with bounds around `p`'s value (or, for an effect, around its
/// natural scale: an effect to be found is off in `p`). Signed effects (the tachometer's
/// offset and current pickup) are linear knobs symmetric about 0, as wide as their natural
/// scale; the stiction ratio runs from 1 (none) up; the dead band up to the largest command
/// (beyond it nothing moves).
pub fn knob(p: &ActuatorParams, param: Param, max_abs_v: f64) -> Knob {
    let h = p.sample_period_s;
    let vm = max_abs_v.max(1e-3);
    let (log, lo, hi, fd_step) = match param {
        Param::Effect(Effect::InputDelay) => (
            false,
            0.0,
            0.99 * geared_servo::plant::MAX_DELAY_STEPS as f64 * h,
            0.1 * h,
        ),
        Param::Effect(Effect::TachGain) => (false, -0.9, 3.0, 0.01),
        Param::Effect(Effect::VoltageLimit) => (true, 0.02 * vm, 2.0 * vm, 0.01),
        Param::Effect(Effect::StictionRatio) => (true, 1.0, 10.0, 0.02),
        Param::Effect(Effect::DriveDeadband) => (true, 1e-4 * vm, vm, 0.02),
        Param::Effect(e @ (Effect::TachOffset | Effect::TachCurrentCoupling)) => {
            let s = effect_scale(p, e, max_abs_v).abs().max(1e-9);
            (false, -s, s, 0.01 * s)
        }
        Param::Effect(e) => {
            let s = effect_scale(p, e, max_abs_v);
            (true, s * 1e-5, s * 1e3, 0.02)
        }
        _ => {
            let v = get(p, param);
            (true, v / 30.0, v * 30.0, 0.02)
        }
    };
    Knob {
        param,
        log,
        lo,
        hi,
        fd_step,
        floor_ok: false,
    }
}

/// The mesh damping every real gear train has, as shares of the gear mode's critical damping
/// 2 √(k_eq J_m' J_L / (J_m' + J_L)) ([`Effect::natural_scale`]): (lowest, start, highest).
///
/// The paper's model has none, and with backlash and no damping at all the motion is chaotic
/// wherever the gears rattle and the resonance bursts of a stepped sine have coexisting
/// responses (MODEL.md, "Gear rattle"): a model without damping is not a model that can be
/// calibrated against a rig, whose meshes always dissipate something. So when the file
/// declares no mesh damping, the default set carries a *background* damping between 0.1 % and
/// 2 % of critical, starting at 1 % — the lightly damped end of steel spur meshes, whose
/// damping ratios are 3–17 % of critical (the registry's comment on `mesh_damping`). A rig
/// that needs more than 2 % has a mesh damping worth naming: `diagnose` then offers the
/// `mesh_damping` effect with its whole range, judged like every other effect.
pub const BACKGROUND_DAMPING: (f64, f64, f64) = (0.001, 0.01, 0.02);

/// The knob of the background mesh damping for `p` ([`BACKGROUND_DAMPING`]).
pub fn background_damping_knob(p: &ActuatorParams, max_abs_v: f64) -> Knob {
    let c = effect_scale(p, Effect::MeshDamping, max_abs_v);
    let (lo, _, hi) = BACKGROUND_DAMPING;
    Knob {
        param: Param::Effect(Effect::MeshDamping),
        log: true,
        lo: lo * c,
        hi: hi * c,
        fd_step: 0.02,
        floor_ok: true,
    }
}

/// `p` with the background mesh damping's starting value when it declares none
/// ([`BACKGROUND_DAMPING`]); `None` when it declares one (then its value is the start and the
/// default set does not carry the background knob).
pub fn with_background_damping(p: &ActuatorParams, max_abs_v: f64) -> Option<ActuatorParams> {
    if p.effects.mesh_damping != 0.0 {
        return None;
    }
    let mut q = *p;
    let c = effect_scale(p, Effect::MeshDamping, max_abs_v);
    q.effects.mesh_damping = BACKGROUND_DAMPING.1 * c;
    q.derived().ok().map(|_| q)
}

/// Values of `effect` (whose knob is `k`) that a search tries first, for the effects whose
/// natural grid is not the default (multiples of the natural scale from 1e-3 to 3, which a
/// caller supplies itself): both signs for the signed ones, ratios from 1.2 up for
/// stiction, fractions of the largest command for the dead band, fractions of a period to
/// several periods for the tachometer's lag. `None` for the others. Clamped into the knob's
/// bounds.
pub fn effect_grid(
    p: &ActuatorParams,
    effect: Effect,
    k: &Knob,
    max_abs_v: f64,
) -> Option<Vec<f64>> {
    let s = effect_scale(p, effect, max_abs_v);
    let times = |f: &[f64]| -> Vec<f64> { f.iter().map(|x| x * s).collect() };
    let v = match effect {
        Effect::StictionRatio => vec![1.2, 1.5, 2.0, 2.5, 3.0, 4.0],
        Effect::DriveDeadband => times(&[0.005, 0.01, 0.02, 0.05, 0.1, 0.2]),
        Effect::TachLag => times(&[0.05, 0.1, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0]),
        Effect::TachOffset | Effect::TachCurrentCoupling => {
            let f = [1e-3, 3e-3, 0.01, 0.03, 0.1, 0.3];
            f.iter().flat_map(|x| [-x * s, x * s]).collect()
        }
        _ => return None,
    };
    Some(v.into_iter().map(|x| x.clamp(k.lo, k.hi)).collect())
}

/// The default set for `p`: every base parameter that is non-zero there.
pub fn default_knobs(p: &ActuatorParams, max_abs_v: f64) -> Vec<Knob> {
    BASE_KNOBS
        .into_iter()
        .filter(|&n| get(p, n) > 0.0)
        .map(|n| knob(p, n, max_abs_v))
        .collect()
}

/// Outputs that fix the armature resistance: the current. On a record of speeds and angles
/// alone, R and the mechanical scale are one ([`BASE_KNOBS`]); the current is the motor
/// torque over k_t, so with it the scale is measured and R is fitted (foreign suite on the
/// current alone, clean/1: with the file's R, 8 % below the unit's, the calibration ended at
/// NRMSE 0.050 against a floor of 0.020 and added a dead band; with R fitted, 0.030, R
/// within 0.1 % of the unit's).
pub const RESISTANCE_OUTPUTS: [&str; 1] = ["current_a"];

/// [`default_knobs`] for records whose fitted outputs are `measured`: the armature
/// resistance too when one of them fixes it ([`RESISTANCE_OUTPUTS`]).
pub fn default_knobs_measuring(p: &ActuatorParams, max_abs_v: f64, measured: &[&str]) -> Vec<Knob> {
    let mut knobs = default_knobs(p, max_abs_v);
    if measured.iter().any(|m| RESISTANCE_OUTPUTS.contains(m))
        && get(p, Param::MotorResistance) > 0.0
    {
        knobs.push(knob(p, Param::MotorResistance, max_abs_v));
    }
    knobs
}

#[cfg(test)]
mod tests {
    use super::*;
    use geared_servo::REFERENCE;

    /// The resistance joins the default set exactly when the current is measured.
    #[test]
    fn the_current_adds_the_resistance() {
        let names = |m: &[&str]| -> Vec<Param> {
            default_knobs_measuring(&REFERENCE, 10.0, m)
                .iter()
                .map(|k| k.param)
                .collect()
        };
        let plain = names(&["tach_voltage_v", "load_angle_deg"]);
        assert!(!plain.contains(&Param::MotorResistance), "{plain:?}");
        assert_eq!(plain.len(), default_knobs(&REFERENCE, 10.0).len());
        for m in [&["current_a"][..], &["tach_voltage_v", "current_a"][..]] {
            let with = names(m);
            assert_eq!(with.len(), plain.len() + 1, "{m:?}");
            assert_eq!(with.last(), Some(&Param::MotorResistance), "{m:?}");
        }
    }

    /// The signed effects get linear knobs symmetric about 0 and grids of both signs (so a
    /// negative offset or pickup can be found); the stiction ratio never leaves the
    /// physical range (a ratio below 1 is invalid and would fail every simulation); the
    /// dead band stops at the largest command.
    #[test]
    fn bench_effect_knobs_stay_in_their_domains() {
        let p = REFERENCE;
        for e in [Effect::TachOffset, Effect::TachCurrentCoupling] {
            let k = knob(&p, Param::Effect(e), 10.0);
            assert!(!k.log && k.lo == -k.hi && k.hi > 0.0, "{e}: {k:?}");
            let g = effect_grid(&p, e, &k, 10.0).unwrap();
            assert!(
                g.iter().any(|&x| x < 0.0) && g.iter().any(|&x| x > 0.0),
                "{e}"
            );
            // Wide enough for the registry's plausible range.
            let (lo, hi) = e.plausible_range();
            assert!(k.lo <= lo && hi <= k.hi, "{e}: {k:?}");
        }
        let k = knob(&p, Param::Effect(Effect::StictionRatio), 10.0);
        assert_eq!(k.lo, 1.0);
        assert_eq!(k.from_z(f64::NEG_INFINITY), 1.0);
        let mut q = p;
        for x in effect_grid(&p, Effect::StictionRatio, &k, 10.0).unwrap() {
            set(&mut q, k.param, x);
            assert!(q.derived().is_ok(), "stiction {x}");
        }
        let k = knob(&p, Param::Effect(Effect::DriveDeadband), 10.0);
        assert!(k.hi <= 10.0 && k.lo > 0.0);
        assert!(effect_grid(&p, Effect::MeshDamping, &k, 10.0).is_none());
    }
}
