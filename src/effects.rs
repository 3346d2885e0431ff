//! The effect registry: every effect beyond the paper's model, declared once.
//!
//! An effect is one line of the `registry!` table below: its field in [`Effects`] (which is
//! also its canonical name, INTERFACES.md "Effect names", and its key in the `[effects]` table
//! of the parameter file), its [`Effect`] variant, unit, [`Domain`] and plausible range. The
//! enum, the struct, [`Effect::ALL`], names, key paths, units and get/set are generated from
//! that line; the natural scale ([`Effect::natural_scale`]) is an arm of one `match` here.
//! Adding an effect therefore means: its line and its scale here, the physics where it acts
//! (`Plant::new`, the modes, the linear model), and its test.
//!
//! This module imports nothing from the crate, so that parameters, errors and the plant can
//! all use it without a cycle.

use core::fmt;

/// Which values of an effect are physical. Each effect is off at 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Domain {
    /// 0 (off) or positive.
    NonNegative,
    /// A delay, s: 0 (off) up to [`crate::plant::MAX_DELAY_STEPS`] sample periods.
    Delay,
    /// A relative gain error, dimensionless: greater than −1 (a gain of zero or below is not
    /// an error of a working sensor).
    GainError,
    /// A ratio to a quantity it cannot fall below, dimensionless: 0 (off) or at least 1
    /// (static friction is never below sliding friction).
    Ratio,
    /// Either sign, any finite value (an offset, a pickup whose sign follows the wiring); 0
    /// is off.
    Signed,
}

impl Domain {
    /// Why a value is out of range ([`crate::ParamError::OutOfRange`]), in words.
    pub const fn range_hint(self) -> &'static str {
        match self {
            Domain::NonNegative => "must be zero (off) or positive",
            // The number is `plant::MAX_DELAY_STEPS` (a test checks it): a `&'static str`
            // cannot be formatted at compile time.
            Domain::Delay => "must be at most 16 sample periods",
            Domain::GainError => {
                "must be greater than -1 (a relative gain error of -100 % or worse)"
            }
            Domain::Ratio => "must be 0 (off) or at least 1",
            Domain::Signed => "must be a finite number",
        }
    }
}

/// Magnitudes of one actuator that the effects' natural scales are made of; see
/// `ActuatorParams::effect_scales`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Scales {
    /// Back-EMF damping on the motor shaft k_t k_b / R_m, N·m·s/rad.
    pub back_emf_damping: f64,
    /// Total ratio N, dimensionless.
    pub n_total: f64,
    /// Equivalent stiffness at the load k_eq, N·m/rad.
    pub k_eq_nm_per_rad: f64,
    /// Motor inertia seen from the load N² J_m, kg·m².
    pub reflected_motor_inertia_kg_m2: f64,
    /// Load inertia J_L, kg·m².
    pub load_inertia_kg_m2: f64,
    /// Sample period h, s.
    pub sample_period_s: f64,
    /// Largest commanded voltage magnitude of the record at hand, V.
    pub max_abs_voltage_v: f64,
    /// Motor torque per applied volt at stall k_t / R_m, N·m/V.
    pub stall_torque_per_volt: f64,
    /// No-load tachometer voltage per applied volt k_ts / k_b, V/V.
    pub tach_per_volt: f64,
    /// Armature resistance R_m, Ω.
    pub resistance_ohm: f64,
}

/// Declares the effects: one line each, `field => Variant, unit, domain, [lo, hi]`, with the
/// doc comment that both the struct field and the enum variant carry.
macro_rules! registry {
    ($(
        $(#[doc = $doc:literal])*
        $field:ident => $variant:ident, $unit:literal, $domain:ident, [$lo:expr, $hi:expr];
    )*) => {
        /// An effect beyond the paper's model (INTERFACES.md, "Effect names").
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum Effect {
            $($(#[doc = $doc])* $variant,)*
        }

        /// The value of every effect (INTERFACES.md, "Effect names"), in its unit. All zero
        /// means off, and an effect that is off costs nothing in [`crate::Plant::step`].
        /// TOML table `[effects]`, one key per field.
        #[derive(Clone, Copy, Debug, PartialEq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct Effects {
            $($(#[doc = $doc])* pub $field: f64,)*
        }

        impl Effect {
            /// Every effect, in canonical order (the order of INTERFACES.md and of the file).
            pub const ALL: [Effect; [$(stringify!($field)),*].len()] = [$(Effect::$variant),*];

            /// Every canonical name, in the order of [`Effect::ALL`].
            pub const NAMES: [&'static str; [$(stringify!($field)),*].len()] =
                [$(stringify!($field)),*];

            /// Canonical name (`"mesh_damping"`): the key in `[effects]`, the name of
            /// `synth --effect` and of `diagnose`'s output.
            pub const fn name(self) -> &'static str {
                match self {
                    $(Effect::$variant => stringify!($field),)*
                }
            }

            /// Key path in the parameter file (`"effects.mesh_damping"`), as
            /// [`crate::ParamError`] names it.
            pub const fn key(self) -> &'static str {
                match self {
                    $(Effect::$variant => concat!("effects.", stringify!($field)),)*
                }
            }

            /// Unit, as the tool prints it (`"N*m*s/rad"`; `"-"` for a dimensionless one).
            pub const fn unit(self) -> &'static str {
                match self {
                    $(Effect::$variant => $unit,)*
                }
            }

            /// Which values are physical.
            pub const fn domain(self) -> Domain {
                match self {
                    $(Effect::$variant => Domain::$domain,)*
                }
            }

            /// Plausible range `(lo, hi)` of the value when the effect is present (0, off, is
            /// always allowed besides), in its unit, for a small servo of the reference
            /// actuator's class: the bounds of a prior. Positive effects span decades, so the
            /// prior is meant log-uniform between `lo` > 0 and `hi`.
            pub const fn plausible_range(self) -> (f64, f64) {
                match self {
                    $(Effect::$variant => ($lo, $hi),)*
                }
            }

            /// Meaning, unit and file key: the effect's doc comment as one line (each doc line
            /// keeps its leading space; trim the result).
            pub const fn meaning(self) -> &'static str {
                match self {
                    $(Effect::$variant => concat!($($doc),*),)*
                }
            }
        }

        impl Effects {
            /// Every effect off.
            pub const NONE: Effects = Effects { $($field: 0.0,)* };

            /// The value of `effect`, in its unit.
            pub const fn get(&self, effect: Effect) -> f64 {
                match effect {
                    $(Effect::$variant => self.$field,)*
                }
            }

            /// Sets `effect` to `value`, in its unit (validated where the parameter set is:
            /// `ActuatorParams::derived`).
            pub fn set(&mut self, effect: Effect, value: f64) {
                match effect {
                    $(Effect::$variant => self.$field = value,)*
                }
            }
        }
    };
}

// Plausible ranges, for the reference class (24 V coreless motor, k_t k_b / R_m = 1.2e-5
// N·m·s/rad, N = 50, J_L = 1e-3 kg·m², k_eq = 640 N·m/rad, 2 kHz loop); each `lo` is about
// where the effect stops being visible in a record, each `hi` where it would dominate what
// it competes with:
// - motor_viscous 1e-8…1e-5: bearing and brush drag of a motor this size is 1e-8…1e-6; at
//   the back-EMF damping (1.2e-5) the motor would lose half its speed to friction.
// - load_viscous 3e-5…0.05: fin bearings, seal and aerodynamic damping; 0.1 % to 1.6 times
//   the back-EMF damping seen from the load (k_t k_b N² / R_m = 0.031).
// - mesh_damping 1e-3…0.2: spur-gear mesh damping ratios are 0.03…0.17 of critical
//   (2 √(k_eq J_red) ≈ 1 N·m·s/rad here).
// - hinge_stiffness 0.01…20: q S c |C_hα| for a fin of some 50 cm² and 5 cm chord is a few
//   N·m/rad at 50 kPa dynamic pressure; 20 stays far below k_eq, so the gear mode stays.
// - input_delay 1e-5…2e-3: computation, PWM update and amplifier latency of a digital loop,
//   up to four periods of the 2 kHz loop (well inside 16 periods, the model's limit).
// - voltage_limit 5…50: amplifier saturation of servos on 12…28 V supplies (with margin).
// - tach_gain −0.2…0.2: tachometer sensitivity tolerance (±10 % on data sheets) plus
//   temperature drift.
// - stiction_ratio 1.1…3: breakaway over running torque of small gear motors and plain
//   bearings (1.2…2 for lubricated steel; up to 3 for dry brushes and seals); below 1.1 the
//   difference hides under the sliding friction's own uncertainty.
// - gravity_torque 1e-3…0.5: an unbalanced arm's m g r; 1e-3 is a fifth of the load's
//   Coulomb friction (5e-3), 0.5 two thirds of the stall torque at the load on a 24 V bus
//   (N k_t V / R_m = 0.74), beyond which the motor could barely lift it.
// - drive_deadband 0.05…3: dead time and the transistor and diode drops of an H bridge, from
//   a MOSFET bridge's few tens of mV to a bipolar L298's ~3 V.
// - tach_offset −0.3…0.3: ADC and amplifier offsets of a tachometer channel spanning ±12 V
//   (0.1 % to 2.5 % of full scale).
// - tach_current_coupling −2…2: a shared return of 0.01…2 Ω between the armature and the
//   tachometer (bench leads, brushes); either sign, as wired. 2 V/A × 0.3 A (stall current
//   at 10 V) is 12 % of the no-load tachometer voltage there.
// - tach_lag 2e-5…5e-3: a tachometer's own armature L/R (tens of µs) up to an RC filter at
//   30 Hz; 2e-5 is a twenty-fifth of the 0.5 ms period, 5e-3 ten periods.
registry! {
    /// Viscous friction on the motor shaft, N·m·s/rad (`effects.motor_viscous`).
    motor_viscous => MotorViscous, "N*m*s/rad", NonNegative, [1e-8, 1e-5];
    /// Viscous friction on the load, N·m·s/rad (`effects.load_viscous`).
    load_viscous => LoadViscous, "N*m*s/rad", NonNegative, [3e-5, 0.05];
    /// Damping on the twist rate while the gears are in contact, N·m·s/rad at the load
    /// (`effects.mesh_damping`).
    mesh_damping => MeshDamping, "N*m*s/rad", NonNegative, [1e-3, 0.2];
    /// Aerodynamic hinge moment: a spring from the load to ground, N·m/rad
    /// (`effects.hinge_stiffness`).
    hinge_stiffness => HingeStiffness, "N*m/rad", NonNegative, [0.01, 20.0];
    /// Pure delay between the commanded and the applied voltage, s (`effects.input_delay`).
    input_delay => InputDelay, "s", Delay, [1e-5, 2e-3];
    /// Amplifier saturation of the applied voltage, V; 0 means no limit
    /// (`effects.voltage_limit`).
    voltage_limit => VoltageLimit, "V", NonNegative, [5.0, 50.0];
    /// Relative error of the tachometer sensitivity, dimensionless: the tachometer reads
    /// `(1 + tach_gain) k_ts ω_m` (`effects.tach_gain`).
    tach_gain => TachGain, "-", GainError, [-0.2, 0.2];
    /// Breakaway (static) friction over sliding Coulomb friction, motor and load,
    /// dimensionless: a stuck body breaks away when its drive exceeds `stiction_ratio` times
    /// its Coulomb friction and slides against the Coulomb friction; 0 (off) is the same as 1
    /// (`effects.stiction_ratio`).
    stiction_ratio => StictionRatio, "-", Ratio, [1.1, 3.0];
    /// Unbalanced load (arm, pendulum), N·m: the load feels −T sin θ_L, θ_L = 0 where it
    /// hangs (`effects.gravity_torque`).
    gravity_torque => GravityTorque, "N*m", NonNegative, [1e-3, 0.5];
    /// Dead band of the drive, V: it applies 0 while |V| ≤ V_db and V − sign(V) V_db above
    /// (`effects.drive_deadband`).
    drive_deadband => DriveDeadband, "V", NonNegative, [0.05, 3.0];
    /// Constant offset of the tachometer output, V (`effects.tach_offset`).
    tach_offset => TachOffset, "V", Signed, [-0.3, 0.3];
    /// Armature current picked up by the tachometer output (ground loop, brushes), V/A:
    /// V_t += r i (`effects.tach_current_coupling`).
    tach_current_coupling => TachCurrentCoupling, "V/A", Signed, [-2.0, 2.0];
    /// Time constant of a first-order low-pass on the tachometer output (filter, tachometer
    /// armature), s (`effects.tach_lag`).
    tach_lag => TachLag, "s", NonNegative, [2e-5, 5e-3];
}

impl Effect {
    /// The effect named `name` (canonical name, `"mesh_damping"`).
    pub fn from_name(name: &str) -> Result<Effect, UnknownEffect<'_>> {
        Effect::ALL
            .into_iter()
            .find(|e| e.name() == name)
            .ok_or(UnknownEffect { name })
    }

    /// The effect whose key path is `key` (`"effects.mesh_damping"`), if any.
    pub fn from_key(key: &str) -> Option<Effect> {
        Effect::ALL.into_iter().find(|e| e.key() == key)
    }

    /// The measured output an effect acts on alone when it is an error of that sensor, as a
    /// record's column names it (INTERFACES.md, "Measured data"): the tachometer's gain,
    /// offset, lag and current pick-up change `tach_voltage_v` and nothing the plant does, so
    /// a record without that column cannot show them. `None` for an effect of the plant or
    /// the drive, which every output shows.
    pub const fn sensor_column(self) -> Option<&'static str> {
        match self {
            Effect::TachGain
            | Effect::TachOffset
            | Effect::TachLag
            | Effect::TachCurrentCoupling => Some("tach_voltage_v"),
            Effect::MotorViscous
            | Effect::LoadViscous
            | Effect::MeshDamping
            | Effect::HingeStiffness
            | Effect::InputDelay
            | Effect::VoltageLimit
            | Effect::StictionRatio
            | Effect::GravityTorque
            | Effect::DriveDeadband => None,
        }
    }

    /// Natural magnitude of the effect on actuator `s` (the scale a calibration's search grid
    /// is built on), in its unit: the back-EMF damping for viscous friction (at the load for
    /// the load's), critical damping of the gear mode for mesh damping, k_eq for the hinge,
    /// one sample for the delay and the lag, the largest command for the limit and the dead
    /// band, 1 for a relative error and the stiction ratio, the stall torque at the load at
    /// the largest command for gravity, the no-load tachometer voltage there for the offset,
    /// and for the current pickup the coupling whose pickup at stall equals that voltage.
    pub fn natural_scale(self, s: &Scales) -> f64 {
        let (n, jm_l, jl) = (
            s.n_total,
            s.reflected_motor_inertia_kg_m2,
            s.load_inertia_kg_m2,
        );
        match self {
            Effect::MotorViscous => s.back_emf_damping,
            Effect::LoadViscous => s.back_emf_damping * n * n,
            Effect::MeshDamping => 2.0 * libm::sqrt(s.k_eq_nm_per_rad * jm_l * jl / (jm_l + jl)),
            Effect::HingeStiffness => s.k_eq_nm_per_rad,
            Effect::InputDelay => s.sample_period_s,
            Effect::VoltageLimit => s.max_abs_voltage_v,
            Effect::TachGain | Effect::StictionRatio => 1.0,
            Effect::GravityTorque => n * s.stall_torque_per_volt * s.max_abs_voltage_v,
            Effect::DriveDeadband => s.max_abs_voltage_v,
            Effect::TachOffset => s.tach_per_volt * s.max_abs_voltage_v,
            Effect::TachCurrentCoupling => s.tach_per_volt * s.resistance_ohm,
            Effect::TachLag => s.sample_period_s,
        }
    }
}

impl fmt::Display for Effect {
    /// The canonical name (padding and alignment apply).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.name())
    }
}

impl Default for Effects {
    fn default() -> Self {
        Effects::NONE
    }
}

/// A name that is no effect's (see [`Effect::from_name`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UnknownEffect<'a> {
    /// The name given.
    pub name: &'a str,
}

impl fmt::Display for UnknownEffect<'_> {
    /// `unknown effect `NAME` (known: motor_viscous, …)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown effect `{}` (known: ", self.name)?;
        for (i, n) in Effect::NAMES.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            f.write_str(n)?;
        }
        f.write_str(")")
    }
}

impl core::error::Error for UnknownEffect<'_> {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_and_key_finds_its_effect_and_nothing_else_does() {
        for e in Effect::ALL {
            assert_eq!(Effect::from_name(e.name()), Ok(e));
            assert_eq!(Effect::from_key(e.key()), Some(e));
            assert_eq!(e.key().strip_prefix("effects."), Some(e.name()));
        }
        assert_eq!(
            Effect::from_name("friction"),
            Err(UnknownEffect { name: "friction" })
        );
        assert_eq!(Effect::from_name("effects.tach_gain").ok(), None);
        assert_eq!(Effect::from_key("tach_gain"), None);
    }

    #[test]
    fn set_then_get_touches_only_that_effect() {
        for (i, e) in Effect::ALL.into_iter().enumerate() {
            let mut x = Effects::NONE;
            x.set(e, 1.5);
            for (j, o) in Effect::ALL.into_iter().enumerate() {
                assert_eq!(x.get(o), if i == j { 1.5 } else { 0.0 }, "{e:?} {o:?}");
            }
        }
    }

    #[test]
    fn plausible_ranges_are_ordered_and_positive_unless_signed() {
        for e in Effect::ALL {
            let (lo, hi) = e.plausible_range();
            assert!(lo < hi, "{e:?}");
            let signed = matches!(e.domain(), Domain::GainError | Domain::Signed);
            assert!(
                lo > 0.0 || signed,
                "{e:?}: a log-uniform prior needs lo > 0"
            );
            if signed {
                assert!(lo < 0.0 && hi > 0.0, "{e:?}: a signed prior spans zero");
            }
            if e.domain() == Domain::Ratio {
                assert!(lo >= 1.0, "{e:?}: a ratio's prior starts at 1");
            }
        }
    }

    #[test]
    fn delay_hint_states_the_plants_limit() {
        let n = Domain::Delay
            .range_hint()
            .split_whitespace()
            .find_map(|w| w.parse::<usize>().ok());
        assert_eq!(n, Some(crate::plant::MAX_DELAY_STEPS));
    }
}
