//! Faults of the plant itself — mechanics and winding — switchable at run time.
//!
//! Pass a [`PlantFaults`] to [`crate::Plant::step_with_faults`]; [`crate::Plant::step`] is the
//! same call with [`PlantFaults::NONE`], so a fault that is off costs a comparison. Sensor and
//! drive-electronics faults (stuck sensors, bus sag, PWM stuck) belong to the firmware-facing
//! actuator, which reads and commands this plant.

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
    /// held there as with [`Jam::Here`].
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
    pub angle_rad: f32,
    /// Angular width of the window, rad at the load (about one tooth pitch, 2π / teeth).
    pub width_rad: f32,
    /// Fraction of the transmitted torque lost inside the window, 0–1.
    pub torque_loss: f32,
}

/// Run-time faults of the plant. Every field at its `NONE` value means no fault.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PlantFaults {
    /// External torque on the load (gust, hinge-moment step), N·m, positive in the
    /// direction of positive load angle. Held over each step; change it step by step for a
    /// profile.
    pub load_torque_nm: f32,
    /// Load jam.
    pub jam: Jam,
    /// Backlash added by wear, degrees of total backlash at the load (≥ 0).
    pub extra_backlash_deg: f32,
    /// Factor on both Coulomb frictions (1 = nominal, ≥ 0).
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
