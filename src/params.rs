//! Parameters of the geared servo in SI units, as the paper (section II) and the parameter
//! file give them, with validation and the derived quantities N, N_r, k1, k2, k_eq, δ, f_AR, f_R.
//!
//! Parameters are `f64`: they are used once, to build the `f32` plant, and on the host they
//! are what calibration adjusts. Every field's doc comment gives its unit and the key it has
//! in the TOML file.

use crate::effects::{Domain, Effect, Scales};
use crate::error::ParamError;
use crate::stiffness;

pub use crate::effects::Effects;

/// DC motor with a tachometer on its shaft (paper eqs. 7a–7c and 8). TOML table `[motor]`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MotorParams {
    /// Armature resistance R_m, Ω (`motor.resistance_ohm`). Must be > 0.
    pub resistance_ohm: f64,
    /// Armature inductance L_a, H (`motor.inductance_h`). Must be > 0.
    pub inductance_h: f64,
    /// Torque constant k_t, N·m/A (`motor.torque_constant_nm_per_a`).
    pub torque_constant_nm_per_a: f64,
    /// Back-EMF constant k_b, V·s/rad (`motor.back_emf_v_s_per_rad`).
    pub back_emf_v_s_per_rad: f64,
    /// Tachometer sensitivity k_ts, V·s/rad (`motor.tach_v_s_per_rad`).
    pub tach_v_s_per_rad: f64,
    /// Inertia of rotor, tachometer armature and pinion 1, J_m, kg·m² (`motor.inertia_kg_m2`).
    pub inertia_kg_m2: f64,
    /// Coulomb (and static) friction torque T_fm on the motor shaft, N·m
    /// (`motor.coulomb_friction_nm`). Zero turns it off.
    pub coulomb_friction_nm: f64,
}

/// Tooth geometry of one gear pair, for the mesh stiffness of paper eqs. (3)–(4).
/// TOML tables `[gear_stage_1]` and `[gear_stage_2]` (all keys but `ratio` and `revolving`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ToothGeometry {
    /// Pitch circle diameter of the gear d_g, m (`gear_pitch_diameter_m`).
    pub gear_pitch_diameter_m: f64,
    /// Tooth face width t_g, m (`face_width_m`).
    pub face_width_m: f64,
    /// Lewis form factor of the pinion y_p, dimensionless (`pinion_lewis_factor`).
    pub pinion_lewis_factor: f64,
    /// Lewis form factor of the gear y_g, dimensionless (`gear_lewis_factor`).
    pub gear_lewis_factor: f64,
    /// Young's modulus of the pinion E_p, Pa (`pinion_youngs_modulus_pa`).
    pub pinion_youngs_modulus_pa: f64,
    /// Young's modulus of the gear E_g, Pa (`gear_youngs_modulus_pa`).
    pub gear_youngs_modulus_pa: f64,
}

/// A solid round shaft in torsion, paper eq. (5). TOML tables `[rotating_shaft]`, `[fixed_shaft]`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Shaft {
    /// Shear modulus G, Pa (`shear_modulus_pa`).
    pub shear_modulus_pa: f64,
    /// Diameter d, m (`diameter_m`).
    pub diameter_m: f64,
    /// Length between the gears it joins, m (`length_m`).
    pub length_m: f64,
}

/// Where the torsional stiffnesses come from.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Stiffness {
    /// From gear and shaft geometry by paper eqs. (2)–(6).
    Geometry {
        /// Pinion 1 → gear 1.
        stage1: ToothGeometry,
        /// Rotating shaft between gear 1 and pinion 2.
        shaft1: Shaft,
        /// Pinion 2 → gear 2 (the fixed segment gear).
        stage2: ToothGeometry,
        /// Fixed shaft from gear 2 to the fin root.
        shaft2: Shaft,
    },
    /// Measured directly (TOML table `[stiffness]`).
    Measured {
        /// k1: gear 1 and rotating shaft in series, at the rotating shaft, N·m/rad
        /// (`stiffness.k1_nm_per_rad`).
        k1_nm_per_rad: f64,
        /// k2: gear 2 and fixed shaft in series, at the load, N·m/rad (`stiffness.k2_nm_per_rad`).
        k2_nm_per_rad: f64,
    },
}

/// The two-stage reducer: ratios, layout and stiffness.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GearTrain {
    /// Stage 1 ratio N1 (pinion 1 → gear 1), dimensionless (`gear_stage_1.ratio`).
    pub stage1_ratio: f64,
    /// Stage 2 diameter ratio N2 = d_g2 / d_p2, dimensionless (`gear_stage_2.ratio`).
    pub stage2_ratio: f64,
    /// Paper's layout, pinion 2 revolving around the fixed gear 2: N_r = N2 + 1; otherwise
    /// N_r = N2 (`gear_stage_2.revolving`).
    pub revolving: bool,
    /// Torsional stiffness source.
    pub stiffness: Stiffness,
}

/// The fin and its shaft. TOML table `[load]`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoadParams {
    /// Load inertia about the hinge line J_L, kg·m² (`load.inertia_kg_m2`).
    pub inertia_kg_m2: f64,
    /// Coulomb (and static) friction torque T_fL on the load, N·m (`load.coulomb_friction_nm`).
    pub coulomb_friction_nm: f64,
}

/// Everything that defines one actuator. Build a [`crate::Plant`] from it to simulate.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ActuatorParams {
    /// Emulator step (and zero-order-hold period of the voltage), s (`sample_period_s`).
    pub sample_period_s: f64,
    /// Motor and tachometer.
    pub motor: MotorParams,
    /// Two-stage reducer.
    pub gears: GearTrain,
    /// Load (the fin).
    pub load: LoadParams,
    /// Total backlash b_t measured at the load with pinion 1 held, degrees
    /// (`backlash.total_deg`). The half gap is δ = π b_t / 360 rad.
    pub backlash_deg: f64,
    /// Optional effects beyond the paper.
    pub effects: Effects,
}

/// The reference actuator of `reference-actuator.toml`, as a constant for firmware.
/// A host test checks that it equals the file.
pub const REFERENCE: ActuatorParams = ActuatorParams {
    sample_period_s: 0.0005,
    motor: MotorParams {
        resistance_ohm: 32.5,
        inductance_h: 0.8e-3,
        torque_constant_nm_per_a: 0.02,
        back_emf_v_s_per_rad: 0.02,
        tach_v_s_per_rad: 0.01,
        inertia_kg_m2: 2.5e-7,
        coulomb_friction_nm: 2.0e-4,
    },
    gears: GearTrain {
        stage1_ratio: 5.0,
        stage2_ratio: 9.0,
        revolving: true,
        stiffness: Stiffness::Geometry {
            stage1: ToothGeometry {
                gear_pitch_diameter_m: 0.024,
                face_width_m: 0.003,
                pinion_lewis_factor: 0.078,
                gear_lewis_factor: 0.134,
                pinion_youngs_modulus_pa: 206e9,
                gear_youngs_modulus_pa: 206e9,
            },
            shaft1: Shaft {
                shear_modulus_pa: 79.3e9,
                diameter_m: 0.004,
                length_m: 0.025,
            },
            stage2: ToothGeometry {
                gear_pitch_diameter_m: 0.060,
                face_width_m: 0.006,
                pinion_lewis_factor: 0.078,
                gear_lewis_factor: 0.144,
                pinion_youngs_modulus_pa: 206e9,
                gear_youngs_modulus_pa: 206e9,
            },
            shaft2: Shaft {
                shear_modulus_pa: 79.3e9,
                diameter_m: 0.008,
                length_m: 0.045,
            },
        },
    },
    load: LoadParams {
        inertia_kg_m2: 1.0e-3,
        coulomb_friction_nm: 5.0e-3,
    },
    backlash_deg: 0.0,
    effects: Effects::NONE,
};

/// Quantities derived from a validated parameter set.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Derived {
    /// Total ratio N = N1 · N_r, dimensionless.
    pub n_total: f64,
    /// Stage-2 revolution ratio N_r (N2 + 1 in the paper's layout), dimensionless.
    pub n_r: f64,
    /// k1 at the rotating shaft, N·m/rad.
    pub k1_nm_per_rad: f64,
    /// k2 at the load, N·m/rad.
    pub k2_nm_per_rad: f64,
    /// Total equivalent stiffness at the load k_eq, N·m/rad (eq. 16).
    pub k_eq_nm_per_rad: f64,
    /// Half gap δ = π b_t / 360, rad at the load.
    pub delta_rad: f64,
    /// Anti-resonance √(k_eq / J_L) / 2π, Hz (eq. 17a; no backlash, no friction).
    pub f_ar_hz: f64,
    /// Resonance √(k_eq (N² J_m + J_L) / (N² J_m J_L)) / 2π, Hz (eq. 17b).
    pub f_r_hz: f64,
}

/// Largest backlash the model accepts, degrees.
pub const MAX_BACKLASH_DEG: f64 = 10.0;

fn finite(v: f64, f: &'static str) -> Result<f64, ParamError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ParamError::NonFinite(f))
    }
}

fn positive(v: f64, f: &'static str) -> Result<f64, ParamError> {
    if finite(v, f)? > 0.0 {
        Ok(v)
    } else {
        Err(ParamError::NonPositive(f))
    }
}

fn non_negative(v: f64, f: &'static str) -> Result<f64, ParamError> {
    if finite(v, f)? >= 0.0 {
        Ok(v)
    } else {
        Err(ParamError::Negative(f))
    }
}

/// Checks field `$field` of `$s` with `$check`, naming it by its key path in table
/// `$table`: the key is the field's own name, so field and key cannot drift apart.
macro_rules! checked {
    ($check:ident, $table:literal, $s:ident . $field:ident) => {
        $check($s.$field, concat!($table, ".", stringify!($field)))?
    };
    ($check:ident, $table:literal, $field:ident) => {
        $check($field, concat!($table, ".", stringify!($field)))?
    };
}

/// Mesh stiffness of the [`ToothGeometry`] `$g` of table `$table`, N·m/rad (paper eq. 4).
macro_rules! tooth_stiffness {
    ($g:ident, $table:literal) => {{
        let k = stiffness::tooth_stiffness(
            checked!(positive, $table, $g.gear_pitch_diameter_m),
            checked!(positive, $table, $g.face_width_m),
            checked!(positive, $table, $g.pinion_lewis_factor),
            checked!(positive, $table, $g.gear_lewis_factor),
            checked!(positive, $table, $g.pinion_youngs_modulus_pa),
            checked!(positive, $table, $g.gear_youngs_modulus_pa),
        );
        positive(k, concat!($table, ".gear_pitch_diameter_m"))?
    }};
}

/// Torsional stiffness of the [`Shaft`] `$s` of table `$table`, N·m/rad (paper eq. 5).
macro_rules! shaft_stiffness {
    ($s:ident, $table:literal) => {{
        let k = stiffness::shaft_stiffness(
            checked!(positive, $table, $s.shear_modulus_pa),
            checked!(positive, $table, $s.diameter_m),
            checked!(positive, $table, $s.length_m),
        );
        positive(k, concat!($table, ".diameter_m"))?
    }};
}

impl ActuatorParams {
    /// Checks every field and returns the derived quantities. The first invalid field is
    /// reported, in the order of the parameter file.
    pub fn derived(&self) -> Result<Derived, ParamError> {
        let h = positive(self.sample_period_s, "sample_period_s")?;
        if !(1e-6..=1.0).contains(&h) {
            return Err(ParamError::OutOfRange("sample_period_s"));
        }
        let m = &self.motor;
        checked!(positive, "motor", m.resistance_ohm);
        checked!(positive, "motor", m.inductance_h);
        checked!(positive, "motor", m.torque_constant_nm_per_a);
        checked!(positive, "motor", m.back_emf_v_s_per_rad);
        checked!(positive, "motor", m.tach_v_s_per_rad);
        let jm = checked!(positive, "motor", m.inertia_kg_m2);
        checked!(non_negative, "motor", m.coulomb_friction_nm);

        let g = &self.gears;
        let n1 = positive(g.stage1_ratio, "gear_stage_1.ratio")?;
        let n2 = positive(g.stage2_ratio, "gear_stage_2.ratio")?;
        let n_r = if g.revolving { n2 + 1.0 } else { n2 };
        let n_total = n1 * n_r;
        let (k1, k2) = match g.stiffness {
            Stiffness::Geometry {
                stage1,
                shaft1,
                stage2,
                shaft2,
            } => {
                let kg1 = tooth_stiffness!(stage1, "gear_stage_1");
                let ks1 = shaft_stiffness!(shaft1, "rotating_shaft");
                let kg2 = tooth_stiffness!(stage2, "gear_stage_2");
                let ks2 = shaft_stiffness!(shaft2, "fixed_shaft");
                (stiffness::series(kg1, ks1), stiffness::series(kg2, ks2))
            }
            Stiffness::Measured {
                k1_nm_per_rad,
                k2_nm_per_rad,
            } => (
                checked!(positive, "stiffness", k1_nm_per_rad),
                checked!(positive, "stiffness", k2_nm_per_rad),
            ),
        };
        let k_eq = positive(
            stiffness::equivalent(n_r, k1, k2),
            "stiffness.k2_nm_per_rad",
        )?;

        let l = &self.load;
        let jl = checked!(positive, "load", l.inertia_kg_m2);
        checked!(non_negative, "load", l.coulomb_friction_nm);

        let b = non_negative(self.backlash_deg, "backlash.total_deg")?;
        if b > MAX_BACKLASH_DEG {
            return Err(ParamError::OutOfRange("backlash.total_deg"));
        }

        for effect in Effect::ALL {
            let (v, key) = (self.effects.get(effect), effect.key());
            let in_range = match effect.domain() {
                Domain::NonNegative => non_negative(v, key)? >= 0.0,
                Domain::Delay => non_negative(v, key)? <= crate::plant::MAX_DELAY_STEPS as f64 * h,
                Domain::GainError => finite(v, key)? > -1.0,
                Domain::Ratio => {
                    let r = non_negative(v, key)?;
                    r == 0.0 || r >= 1.0
                }
                Domain::Signed => finite(v, key)?.is_finite(),
            };
            if !in_range {
                return Err(ParamError::OutOfRange(key));
            }
        }

        let two_pi = 2.0 * core::f64::consts::PI;
        let n2jm = n_total * n_total * jm;
        let f_ar = libm::sqrt(k_eq / jl) / two_pi;
        let f_r = libm::sqrt(k_eq * (n2jm + jl) / (n2jm * jl)) / two_pi;
        Ok(Derived {
            n_total,
            n_r,
            k1_nm_per_rad: k1,
            k2_nm_per_rad: k2,
            k_eq_nm_per_rad: k_eq,
            delta_rad: core::f64::consts::PI * b / 360.0,
            f_ar_hz: positive(f_ar, "load.inertia_kg_m2")?,
            f_r_hz: positive(f_r, "motor.inertia_kg_m2")?,
        })
    }

    /// The magnitudes the effects' natural scales are made of ([`Effect::natural_scale`]),
    /// for a record whose largest command is `max_abs_voltage_v`, V. Where the parameters are
    /// invalid, N and k_eq are taken as 1.
    pub fn effect_scales(&self, max_abs_voltage_v: f64) -> Scales {
        let m = &self.motor;
        let d = self.derived().ok();
        let n = d.map(|d| d.n_total).unwrap_or(1.0);
        Scales {
            back_emf_damping: m.torque_constant_nm_per_a * m.back_emf_v_s_per_rad
                / m.resistance_ohm,
            n_total: n,
            k_eq_nm_per_rad: d.map(|d| d.k_eq_nm_per_rad).unwrap_or(1.0),
            reflected_motor_inertia_kg_m2: n * n * m.inertia_kg_m2,
            load_inertia_kg_m2: self.load.inertia_kg_m2,
            sample_period_s: self.sample_period_s,
            max_abs_voltage_v,
            stall_torque_per_volt: m.torque_constant_nm_per_a / m.resistance_ohm,
            tach_per_volt: m.tach_v_s_per_rad / m.back_emf_v_s_per_rad,
            resistance_ohm: m.resistance_ohm,
        }
    }

    /// Stiffness from the load to ground about the hanging position, N·m/rad: the hinge
    /// spring plus the gravity torque (−T sin θ_L ≈ −T θ_L for small angles). What the linear
    /// analyses use for the load's restoring torque.
    pub fn ground_stiffness_nm_per_rad(&self) -> f64 {
        self.effects.hinge_stiffness + self.effects.gravity_torque
    }

    /// The same actuator with another total backlash, degrees.
    pub const fn with_backlash_deg(mut self, backlash_deg: f64) -> Self {
        self.backlash_deg = backlash_deg;
        self
    }

    /// The same actuator without Coulomb friction (the paper's linear case of section II.C).
    pub const fn without_friction(mut self) -> Self {
        self.motor.coulomb_friction_nm = 0.0;
        self.load.coulomb_friction_nm = 0.0;
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_derived_values_match_the_file_comment() {
        let d = REFERENCE.derived().unwrap();
        assert_eq!(d.n_total, 50.0);
        assert_eq!(d.n_r, 10.0);
        // The file quotes 127.585 Hz and 205.724 Hz (3 decimals).
        assert!((d.f_ar_hz - 127.585).abs() < 1e-3, "{}", d.f_ar_hz);
        assert!((d.f_r_hz - 205.724).abs() < 1e-3, "{}", d.f_r_hz);
    }

    #[test]
    fn negative_inertia_names_its_field() {
        let mut p = REFERENCE;
        p.load.inertia_kg_m2 = -1.0;
        assert_eq!(
            p.derived(),
            Err(ParamError::NonPositive("load.inertia_kg_m2"))
        );
    }

    #[test]
    fn nan_resistance_names_its_field() {
        let mut p = REFERENCE;
        p.motor.resistance_ohm = f64::NAN;
        assert_eq!(
            p.derived(),
            Err(ParamError::NonFinite("motor.resistance_ohm"))
        );
    }
}
