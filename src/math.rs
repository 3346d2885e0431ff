//! The one place that decides where transcendental functions come from.
//!
//! `libm` by default, `micromath` with the `micromath` feature. The `std` feature deliberately
//! does not switch to the platform's libm: with `libm` the host and the Cortex-M target compute
//! bit-identical results, which the host/target comparison tests rely on.
//!
//! The feature changes [`ln`], [`exp`], [`sqrt`], [`sin_cos`] and [`atan2`] ([`abs`],
//! [`fraction`], [`wrap_angle`] and [`sin`] are the same either way). In the crate they are
//! called in three places, so with `micromath` these results move:
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

/// sin x in f32 arithmetic alone, the same on every backend (for the gravity torque, once
/// per step). libm's `sinf` computes in f64, which the Cortex-M4F emulates in software:
/// about 2200 instructions a call, measured, against some 30 here. Reduction by the nearest
/// multiple of 2π in two parts (Cody–Waite), a fold into [−π/2, π/2] and the odd Taylor
/// polynomial to x¹¹ (truncation below 6e-8 there): |error| below 3e-7 for |x| ≤ 100 rad,
/// growing with the ulp of x beyond (`math::tests`). NaN gives NaN, ±∞ NaN.
#[inline]
pub fn sin(x: f32) -> f32 {
    const INV_TAU: f32 = 1.0 / core::f32::consts::TAU;
    // 2π = TAU_HI + TAU_LO with TAU_HI short enough that k · TAU_HI is exact for |k| < 2^15.
    const TAU_HI: f32 = 6.28125;
    const TAU_LO: f32 = 1.935_307_2e-3;
    const PI: f32 = core::f32::consts::PI;
    const HALF_PI: f32 = core::f32::consts::FRAC_PI_2;
    let y = x * INV_TAU;
    // Round to nearest without a library call; `as` saturates (NaN to 0).
    let k = (if y >= 0.0 { y + 0.5 } else { y - 0.5 }) as i32 as f32;
    let mut r = (x - k * TAU_HI) - k * TAU_LO;
    if r > HALF_PI {
        r = PI - r;
    } else if r < -HALF_PI {
        r = -PI - r;
    }
    let r2 = r * r;
    let p = -1.0 / 39_916_800.0f32;
    let p = 1.0 / 362_880.0 + r2 * p;
    let p = -1.0 / 5040.0 + r2 * p;
    let p = 1.0 / 120.0 + r2 * p;
    let p = -1.0 / 6.0 + r2 * p;
    // Beyond the range where k is exact the reduction is meaningless; stay a sine.
    (r + r * r2 * p).clamp(-1.0, 1.0)
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

#[cfg(test)]
mod tests {
    extern crate std;

    /// Against the f64 sine, over ±100 rad (an arm's many turns) on a fine irregular grid,
    /// and at the reduction's folding points.
    #[test]
    fn f32_sine_is_within_3e_7_of_the_f64_sine() {
        let mut worst = 0.0f64;
        let mut k = 0u32;
        let mut x = -100.0f32;
        while x < 100.0 {
            let e = (f64::from(super::sin(x)) - libm::sin(f64::from(x))).abs();
            worst = worst.max(e);
            k += 1;
            x += 0.000_731 * (1.0 + (k % 7) as f32);
        }
        use core::f32::consts::{FRAC_PI_2, PI};
        for x in [
            0.0f32,
            1e-20,
            -1e-3,
            FRAC_PI_2,
            -FRAC_PI_2,
            PI,
            3.0 * FRAC_PI_2,
        ] {
            let e = (f64::from(super::sin(x)) - libm::sin(f64::from(x))).abs();
            worst = worst.max(e);
        }
        std::println!("f32 sine: worst error {worst:.2e} over {k} points");
        // Two f32 roundings of a value near 1 (6e-8 each) and π's (9e-8): measured 2.1e-7.
        assert!(worst < 3e-7, "{worst}");
        assert!(super::sin(f32::NAN).is_nan());
        assert!(super::sin(1e30).abs() <= 1.0);
    }
}
