//! The one place that decides where transcendental functions come from.
//!
//! `libm` by default, `micromath` with the `micromath` feature. The `std` feature deliberately
//! does not switch to the platform's libm: with `libm` the host and the Cortex-M target compute
//! bit-identical results, which the host/target comparison tests rely on.
//!
//! The feature changes [`ln`], [`exp`], [`sqrt`], [`sin_cos`] and [`atan2`] ([`abs`],
//! [`fraction`] and [`wrap_angle`] are the same either way). In the crate they are called in
//! three places, so with `micromath` these results move:
//! - [`crate::Plant::step`] and [`crate::Plant::step_with_faults`] (hence
//!   [`crate::VirtualActuator::step`]): `ln` and `exp` on the rare step where the motor breaks
//!   away from static friction (the instant located on the exponential current rise); every
//!   other step uses only `abs` (a bit operation) and arithmetic;
//! - [`crate::Plant::step_sine`]: `sin_cos` of the phase at every call, so every stepped-sine
//!   measurement with [`crate::Hold::Continuous`] (and the host's sweeps and `paper`);
//! - [`crate::scenario::TorqueProfile::at`]: `sin_cos` at every step of a gust.
//!
//! [`crate::Plant::new`], the discretisation, the analyser's own arithmetic, the linear model
//! and the describing function always use `libm` (f64).
//!
//! Measured cost of `micromath` 2.1 (`host-tests/tests/math_backend.rs`, `plant_accuracy.rs`;
//! `docs/math-backend.md` has the tables): `sin`/`cos` 1.1e-3 absolute, `exp` 2.4e-3 relative,
//! `ln` 0.12, `sqrt` 6.1e-2 relative, `atan2` 2.8e-3 rad off libm; the plant's tachometer
//! error against a fine RK4 reference grows from 0.04 % to 0.98 % (80 Hz) and from 0.009 % to
//! 1.15 % (100 Hz) on records where the motor sticks and breaks away every half period; a
//! stepped-sine gain moves by up to 0.0034 dB. In exchange the `fin_loop` firmware image is
//! 7.8 KB smaller; `Plant::step` costs about the same (383 against 384 instructions).
//!
//! The feature is not additive in results: Cargo unifies features, so enabling it anywhere in
//! a build changes the plant's numbers for every crate in that build that uses this one
//! (the host library and tool included). Enable it only in a final firmware binary.

/// |x| by clearing the sign bit (no branch, no library call).
#[inline(always)]
pub fn abs(x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0x7fff_ffff)
}

/// Natural logarithm, f32.
#[inline]
pub fn ln(x: f32) -> f32 {
    #[cfg(feature = "micromath")]
    {
        micromath::F32Ext::ln(x)
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::logf(x)
    }
}

/// e^x, f32.
#[inline]
pub fn exp(x: f32) -> f32 {
    #[cfg(feature = "micromath")]
    {
        micromath::F32Ext::exp(x)
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::expf(x)
    }
}

/// Square root, f32.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(feature = "micromath")]
    {
        micromath::F32Ext::sqrt(x)
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::sqrtf(x)
    }
}

/// (sin x, cos x), f32.
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    #[cfg(feature = "micromath")]
    {
        (micromath::F32Ext::sin(x), micromath::F32Ext::cos(x))
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::sincosf(x)
    }
}

/// atan2(y, x), f32.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    #[cfg(feature = "micromath")]
    {
        micromath::F32Ext::atan2(y, x)
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::atan2f(y, x)
    }
}

/// Angle wrapped into [−π, π), rad.
#[inline]
pub fn wrap_angle(x: f32) -> f32 {
    let tau = core::f32::consts::TAU;
    let r = libm::fmodf(x + core::f32::consts::PI, tau);
    (if r < 0.0 { r + tau } else { r }) - core::f32::consts::PI
}

/// Fraction `num / den` clamped to [0, 1]; 0 when the quotient is NaN (0/0).
#[inline(always)]
pub fn fraction(num: f32, den: f32) -> f32 {
    let a = num / den;
    if a > 0.0 {
        if a < 1.0 {
            a
        } else {
            1.0
        }
    } else {
        0.0
    }
}
