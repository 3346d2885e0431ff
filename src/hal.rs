//! The H-bridge as firmware sees it: a PWM channel ([`embedded_hal::pwm::SetDutyCycle`]) and
//! a direction line ([`embedded_hal::digital::OutputPin`]).
//!
//! The winding voltage is `±bus_voltage_v · duty / max_duty`: positive with the direction line
//! low, negative with it high. Setting the duty or the direction only latches the command; the
//! plant applies it over the next [`crate::VirtualActuator::step`], as a real bridge applies
//! the register written before the next PWM period.
//!
//! The handles ([`Pwm`], [`Dir`]) borrow the bridge mutably, so firmware holds them for as long
//! as it drives and gives them back before stepping: no `RefCell`, no allocation, no panic.
//! An out-of-range duty is refused with [`DutyError`] and leaves the previous duty in force.

use embedded_hal::{digital, pwm};

use crate::ParamError;

/// Bus voltage and PWM resolution of the emulated H-bridge.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DriveConfig {
    /// Supply voltage across the bridge, V; the winding sees ±this at full duty. Positive.
    pub bus_voltage_v: f32,
    /// Duty count at 100 % (the PWM timer's auto-reload value), counts. At least 1.
    pub max_duty: u16,
}

impl DriveConfig {
    /// 24 V bus, 1000 counts full duty (a 2 kHz control loop on a 20 kHz PWM is typical).
    pub const REFERENCE: DriveConfig = DriveConfig {
        bus_voltage_v: 24.0,
        max_duty: 1000,
    };

    /// Checks the fields; errors name them as `drive.<field>`.
    pub fn validate(&self) -> Result<(), ParamError> {
        if !self.bus_voltage_v.is_finite() {
            return Err(ParamError::NonFinite("drive.bus_voltage_v"));
        }
        if self.bus_voltage_v <= 0.0 {
            return Err(ParamError::NonPositive("drive.bus_voltage_v"));
        }
        if self.max_duty == 0 {
            return Err(ParamError::NonPositive("drive.max_duty"));
        }
        Ok(())
    }
}

/// A duty command outside `[-max_duty, max_duty]` (or a fraction above 1 or over 0): refused,
/// the previous duty stays in force.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DutyError {
    /// The refused duty, counts (signed for [`Drive::set_signed_duty`]; for a refused
    /// fraction, the numerator).
    pub duty: i32,
    /// The channel's full-scale duty, counts.
    pub max_duty: u16,
}

impl pwm::Error for DutyError {
    fn kind(&self) -> pwm::ErrorKind {
        pwm::ErrorKind::Other
    }
}

impl core::fmt::Display for DutyError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "duty {} outside the PWM range [0, {}]",
            self.duty, self.max_duty
        )
    }
}

impl core::error::Error for DutyError {}

/// The bridge's latched command: duty and direction.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Drive {
    bus_voltage_v: f32,
    max_duty: u16,
    duty: u16,
    reverse: bool,
}

impl Drive {
    /// A bridge at duty 0, direction forward; the configuration is validated.
    pub fn new(config: &DriveConfig) -> Result<Drive, ParamError> {
        config.validate()?;
        Ok(Drive {
            bus_voltage_v: config.bus_voltage_v,
            max_duty: config.max_duty,
            duty: 0,
            reverse: false,
        })
    }

    /// The configuration this bridge was built with.
    pub fn config(&self) -> DriveConfig {
        DriveConfig {
            bus_voltage_v: self.bus_voltage_v,
            max_duty: self.max_duty,
        }
    }

    /// Voltage the winding will see over the next step, V: `±bus · duty / max_duty`.
    #[inline]
    pub fn voltage_v(&self) -> f32 {
        let v = self.bus_voltage_v * f32::from(self.duty) / f32::from(self.max_duty);
        if self.reverse {
            -v
        } else {
            v
        }
    }

    /// The voltage the bridge would apply at signed duty `duty` (counts, clamped to
    /// ±max_duty), V: what a PWM output stuck at that duty gives.
    pub fn voltage_for_signed_duty(&self, duty: i32) -> f32 {
        let max = i32::from(self.max_duty);
        let d = duty.clamp(-max, max);
        self.bus_voltage_v * d as f32 / max as f32
    }

    /// Duty now latched, counts (0..=max_duty).
    pub fn duty(&self) -> u16 {
        self.duty
    }

    /// True when the direction line is high (negative voltage).
    pub fn is_reverse(&self) -> bool {
        self.reverse
    }

    /// Signed-duty mode: sets duty `|duty|` and the direction from the sign in one call
    /// (negative → reverse), counts. Outside `[-max_duty, max_duty]` → [`DutyError`], nothing
    /// changes.
    pub fn set_signed_duty(&mut self, duty: i32) -> Result<(), DutyError> {
        let magnitude = duty.unsigned_abs();
        if magnitude > u32::from(self.max_duty) {
            return Err(DutyError {
                duty,
                max_duty: self.max_duty,
            });
        }
        // magnitude ≤ max_duty ≤ u16::MAX, so the conversion cannot fail.
        self.duty = u16::try_from(magnitude).unwrap_or(self.max_duty);
        self.reverse = duty < 0;
        Ok(())
    }

    /// The PWM channel handle.
    pub fn pwm(&mut self) -> Pwm<'_> {
        Pwm {
            duty: &mut self.duty,
            max_duty: self.max_duty,
        }
    }

    /// The direction line handle.
    pub fn dir(&mut self) -> Dir<'_> {
        Dir {
            reverse: &mut self.reverse,
        }
    }

    /// Both handles at once, as a HAL's `split()` hands out pins.
    pub fn split(&mut self) -> (Pwm<'_>, Dir<'_>) {
        (
            Pwm {
                duty: &mut self.duty,
                max_duty: self.max_duty,
            },
            Dir {
                reverse: &mut self.reverse,
            },
        )
    }
}

/// PWM channel of the emulated bridge (borrowed from a [`Drive`]).
#[derive(Debug)]
pub struct Pwm<'a> {
    duty: &'a mut u16,
    max_duty: u16,
}

impl pwm::ErrorType for Pwm<'_> {
    type Error = DutyError;
}

impl pwm::SetDutyCycle for Pwm<'_> {
    fn max_duty_cycle(&self) -> u16 {
        self.max_duty
    }

    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), DutyError> {
        if duty > self.max_duty {
            return Err(DutyError {
                duty: i32::from(duty),
                max_duty: self.max_duty,
            });
        }
        *self.duty = duty;
        Ok(())
    }

    /// Overridden so that `num > denom` or `denom == 0` is the trait's error rather than the
    /// default method's debug assertion.
    fn set_duty_cycle_fraction(&mut self, num: u16, denom: u16) -> Result<(), DutyError> {
        if denom == 0 || num > denom {
            return Err(DutyError {
                duty: i32::from(num),
                max_duty: self.max_duty,
            });
        }
        let duty = u32::from(num) * u32::from(self.max_duty) / u32::from(denom);
        self.set_duty_cycle(u16::try_from(duty).unwrap_or(u16::MAX))
    }
}

/// Direction line of the emulated bridge (borrowed from a [`Drive`]): low = forward (positive
/// voltage), high = reverse.
#[derive(Debug)]
pub struct Dir<'a> {
    reverse: &'a mut bool,
}

impl digital::ErrorType for Dir<'_> {
    type Error = core::convert::Infallible;
}

impl digital::OutputPin for Dir<'_> {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        *self.reverse = false;
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Self::Error> {
        *self.reverse = true;
        Ok(())
    }
}

impl digital::StatefulOutputPin for Dir<'_> {
    fn is_set_high(&mut self) -> Result<bool, Self::Error> {
        Ok(*self.reverse)
    }

    fn is_set_low(&mut self) -> Result<bool, Self::Error> {
        Ok(!*self.reverse)
    }
}
