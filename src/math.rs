//! The one place that decides where transcendental functions come from.
//!
//! `libm` by default, `micromath` with the `micromath` feature. The `std` feature deliberately
//! does not switch to the platform's libm: with `libm` the host and the Cortex-M target compute
//! bit-identical results, which the host/target comparison tests rely on.
//!
//! [`crate::Plant::step`] uses only `abs` (a bit operation) and, on the rare step where the
//! motor breaks away from static friction, `ln` and `exp`. Everything else here serves the
//! one-time construction and the analysis code.

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
