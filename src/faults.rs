//! Faults of the plant itself — mechanics and winding — switchable at run time.
//!
//! Pass a [`PlantFaults`] to [`crate::Plant::step_with_faults`]; [`crate::Plant::step`] is the
//! same call with [`PlantFaults::NONE`], so a fault that is off costs a comparison. Sensor and
//! drive-electronics faults (stuck sensors, bus sag, PWM stuck) belong to the firmware-facing
//! actuator, which reads and commands this plant.
//!
//! Every value a caller can put in these types is safe to step with: out-of-range numbers
//! are clamped to the physical range each field's documentation states, NaN means "this
//! fault off". The bounds below are the one list of those ranges; the scenario builders
//! ([`crate::scenario::Scenario::push`]) and the host's scenario files refuse values beyond
//! them instead of clamping.

/// Largest external load torque, N·m (a thousand times the hinge moment a fin actuator
/// meets, far beyond anything a gear train survives).
pub const MAX_LOAD_TORQUE_NM: f32 = 1.0e6;

/// Largest factor on the Coulomb frictions.
pub const MAX_FRICTION_FACTOR: f32 = 1.0e3;

/// Largest magnitude of a fault's load angle (jam angle, broken-tooth centre), rad: about
/// 160 000 revolutions, where an `f32` angle resolves no better than 0.06 rad.
pub const MAX_FAULT_ANGLE_RAD: f32 = 1.0e6;

/// Largest worn backlash, degrees at the load (the parameters' own limit,
/// [`crate::params::MAX_BACKLASH_DEG`]).
pub const MAX_BACKLASH_WEAR_DEG: f32 = crate::params::MAX_BACKLASH_DEG as f32;

/// Largest relative gain error of a sensor ([`SensorFault::GainDrift`]); the smallest is −1
/// (the channel reads zero).
pub const MAX_GAIN_DRIFT: f32 = 1.0e3;

/// Largest peak of a [`SensorFault::NoiseBurst`], counts.
pub const MAX_NOISE_PEAK_COUNTS: f32 = 1.0e9;

/// Largest number of lost low bits ([`SensorFault::LostLsbs`]): every bit of a 32-bit count.
pub const MAX_LOST_LSBS: u8 = 31;

/// Largest factor on the bridge's bus voltage.
pub const MAX_BUS_FACTOR: f32 = 10.0;

/// How the load is jammed.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Jam {
    /// Free.
    None,
    /// Held where it is now: its speed drops to zero at once and it does not move, whatever
    /// the torque, while the fault lasts. The motor can still wind up the twist through the
    /// gap and the gear stiffness.
    Here,
    /// Blocked at this load angle, rad: it moves freely until it reaches the angle, then is
    /// held there as with [`Jam::Here`]. Clamped to ±[`MAX_FAULT_ANGLE_RAD`]; NaN or ±∞
    /// blocks nothing.
    AtAngle(f32),
}

/// The motor winding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Winding {
    /// As built.
    Normal,
    /// Open circuit: no current flows whatever the voltage; the rotor coasts.
    Open,
    /// Terminals shorted: the applied voltage is zero whatever is commanded, so the
    /// back-EMF drives a braking current through the resistance.
    Shorted,
}

/// A tooth broken off the output gear: once per revolution of the load, over an angular
/// window, the gears transmit only part of their torque.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BrokenTooth {
    /// Load angle at the centre of the missing tooth, rad (taken modulo one revolution).
    /// Clamped to ±[`MAX_FAULT_ANGLE_RAD`]; NaN or ±∞ is taken as 0.
    pub angle_rad: f32,
    /// Angular width of the window, rad at the load (about one tooth pitch, 2π / teeth).
    /// Clamped to 0–2π; NaN or ±∞ is taken as 0 (no window).
    pub width_rad: f32,
    /// Fraction of the transmitted torque lost inside the window, 0–1 (clamped to it; NaN
    /// or ±∞ is taken as 0, no loss).
    pub torque_loss: f32,
}

/// Run-time faults of the plant. Every field at its `NONE` value means no fault.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PlantFaults {
    /// External torque on the load (gust, hinge-moment step), N·m, positive in the
    /// direction of positive load angle. Held over each step; change it step by step for a
    /// profile. Clamped to ±[`MAX_LOAD_TORQUE_NM`]; NaN or ±∞ is taken as 0.
    pub load_torque_nm: f32,
    /// Load jam.
    pub jam: Jam,
    /// Backlash added by wear, degrees of total backlash at the load. Clamped to
    /// 0–[`MAX_BACKLASH_WEAR_DEG`] (wear does not close a gap); NaN or ±∞ is taken as 0.
    pub extra_backlash_deg: f32,
    /// Factor on both Coulomb frictions (1 = nominal). Clamped to 0–[`MAX_FRICTION_FACTOR`]
    /// (negative friction would feed energy in); NaN or ±∞ is taken as 1.
    pub friction_factor: f32,
    /// Broken output-gear tooth, if any.
    pub broken_tooth: Option<BrokenTooth>,
    /// State of the winding.
    pub winding: Winding,
}

impl PlantFaults {
    /// No fault.
    pub const NONE: PlantFaults = PlantFaults {
        load_torque_nm: 0.0,
        jam: Jam::None,
        extra_backlash_deg: 0.0,
        friction_factor: 1.0,
        broken_tooth: None,
        winding: Winding::Normal,
    };
}

impl Default for PlantFaults {
    fn default() -> Self {
        PlantFaults::NONE
    }
}

/// A fault of one sensor channel, as the firmware would see it in the channel's counts.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SensorFault {
    /// Healthy.
    None,
    /// Reads this many counts whatever the input (clamped to the channel's range).
    StuckAt(i32),
    /// Adds this many counts.
    Offset(i32),
    /// Relative error of the sensitivity: the physical value is scaled by `1 + drift`
    /// before conversion (0.1 = reads 10 % high). Clamped to −1–[`MAX_GAIN_DRIFT`]; NaN or
    /// ±∞ is taken as 0.
    GainDrift(f32),
    /// Reads zero (`false`) or full scale (`true`; for the encoder, `i32::MAX`).
    Dropout(bool),
    /// Adds uniform noise of this peak, counts (deterministic, from the sensors' seed).
    /// Clamped to 0–[`MAX_NOISE_PEAK_COUNTS`]; NaN or ±∞ is taken as 0.
    NoiseBurst(f32),
    /// The lowest this-many bits read as zero (63 or more: all of them).
    LostLsbs(u8),
}

/// Faults of the whole virtual actuator: plant, sensors, bridge.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ActuatorFaults {
    /// Mechanics and winding.
    pub plant: PlantFaults,
    /// Tachometer ADC channel.
    pub tach: SensorFault,
    /// Load potentiometer ADC channel.
    pub pot: SensorFault,
    /// Quadrature encoder count.
    pub encoder: SensorFault,
    /// Factor on the bridge's bus voltage (1 = nominal; 0.7 = a 30 % sag). Clamped to
    /// 0–[`MAX_BUS_FACTOR`]; NaN or ±∞ is taken as 1.
    pub bus_factor: f32,
    /// The bridge ignores duty commands and applies this signed duty, counts.
    pub pwm_stuck: Option<i32>,
}

impl ActuatorFaults {
    /// No fault anywhere.
    pub const NONE: ActuatorFaults = ActuatorFaults {
        plant: PlantFaults::NONE,
        tach: SensorFault::None,
        pot: SensorFault::None,
        encoder: SensorFault::None,
        bus_factor: 1.0,
        pwm_stuck: None,
    };

    /// Whether any sensor or bridge fault (beyond the plant's) is set.
    pub fn has_io_faults(&self) -> bool {
        self.tach != SensorFault::None
            || self.pot != SensorFault::None
            || self.encoder != SensorFault::None
            || self.bus_factor != 1.0
            || self.pwm_stuck.is_some()
    }
}

impl Default for ActuatorFaults {
    fn default() -> Self {
        ActuatorFaults::NONE
    }
}

impl SensorFault {
    /// Applies the post-conversion part of the fault to `counts` within `[lo, hi]`;
    /// `noise` is a uniform sample in [−1, 1). Never panics, whatever the values.
    pub fn apply_counts(&self, counts: i64, lo: i64, hi: i64, noise: f32) -> i64 {
        let c = match *self {
            SensorFault::None | SensorFault::GainDrift(_) => counts,
            SensorFault::StuckAt(v) => i64::from(v),
            SensorFault::Offset(d) => counts.saturating_add(i64::from(d)),
            SensorFault::Dropout(full) => {
                if full {
                    hi
                } else {
                    0
                }
            }
            SensorFault::NoiseBurst(peak) => {
                let n = if peak.is_finite() {
                    peak.clamp(0.0, MAX_NOISE_PEAK_COUNTS) * noise
                } else {
                    0.0
                };
                // Round half away from zero without a library call; `as` saturates.
                let r = if n >= 0.0 { n + 0.5 } else { n - 0.5 };
                counts.saturating_add(r as i64)
            }
            SensorFault::LostLsbs(bits) => {
                let mask = if bits >= 63 { 0 } else { !((1i64 << bits) - 1) };
                counts & mask
            }
        };
        c.clamp(lo, hi)
    }

    /// The pre-conversion scale of the physical value (1 unless [`SensorFault::GainDrift`]).
    pub fn gain(&self) -> f32 {
        match *self {
            SensorFault::GainDrift(g) if g.is_finite() => 1.0 + g.clamp(-1.0, MAX_GAIN_DRIFT),
            _ => 1.0,
        }
    }
}
