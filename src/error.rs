//! Parameter errors.
//!
//! Validation happens once, in the constructors; the per-sample path has no `Result`.
//! Every variant carries the offending field as its key path in the parameter file
//! (`"motor.resistance_ohm"`), so the host tool can name file and key without a table.

use crate::effects::Effect;
use core::fmt;

/// A parameter was rejected. The string is the key path of the offending field, exactly as
/// in the parameter file (see `reference-actuator.toml`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ParamError {
    /// NaN or infinite.
    NonFinite(&'static str),
    /// Zero or negative where only a positive value is physical.
    NonPositive(&'static str),
    /// Negative where zero (off) or a positive value is expected.
    Negative(&'static str),
    /// Finite and signed correctly, but outside the range the model supports; the reason is
    /// given by [`ParamError::reason`].
    OutOfRange(&'static str),
    /// The parameters are each valid but together give a discrete model that does not fit in
    /// `f32` (an absurd combination such as a micro-henry winding on a tonne of inertia).
    NotRepresentable(&'static str),
}

impl ParamError {
    /// Key path of the offending field (`"load.inertia_kg_m2"`).
    pub const fn field(&self) -> &'static str {
        match *self {
            ParamError::NonFinite(f)
            | ParamError::NonPositive(f)
            | ParamError::Negative(f)
            | ParamError::OutOfRange(f)
            | ParamError::NotRepresentable(f) => f,
        }
    }

    /// What is wrong with the field, in words.
    pub fn reason(&self) -> &'static str {
        match *self {
            ParamError::NonFinite(_) => "must be a finite number",
            ParamError::NonPositive(_) => "must be greater than zero",
            ParamError::Negative(_) => "must not be negative",
            ParamError::OutOfRange(f) => range_hint(f),
            ParamError::NotRepresentable(_) => {
                "gives a discrete model that overflows f32 together with the other parameters"
            }
        }
    }
}

fn range_hint(field: &str) -> &'static str {
    if let Some(effect) = Effect::from_key(field) {
        return effect.domain().range_hint();
    }
    match field {
        "backlash.total_deg" => {
            "must be below 10 degrees (a dead zone wider than that is not gear backlash)"
        }
        "sample_period_s" => "must be between 1 microsecond and 1 second",
        _ => "is outside the supported range",
    }
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field(), self.reason())
    }
}

impl core::error::Error for ParamError {}
