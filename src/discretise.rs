//! Exact zero-order-hold discretisation of a small linear system, in `f64`, without allocation.
//!
//! For `ẋ = A x + B u` with `u` held over a step `h`:
//! `x(h) = Φ x(0) + Γ u`, `Φ = e^{Ah}`, `Γ = ∫₀ʰ e^{As} ds B = h φ₁(Ah) B`,
//! where `φ₁(Z) = Σ Zᵏ/(k+1)!`. Both come from one scaling-and-squaring pass:
//! a Taylor series at `Z / 2ˢ` (norm ≤ 1/2), then `s` doublings
//! `φ₁(2Z) = ½ φ₁(Z) (e^Z + I)`, `e^{2Z} = (e^Z)²`. This works for singular `A` (the
//! integrators of angle), which `A⁻¹(Φ − I)` would not.

/// Dimension of the plant state.
pub const N: usize = 5;

/// A square `N × N` matrix, row major (the plant's size by default).
pub type Mat<const D: usize = N> = [[f64; D]; D];

fn zero<const D: usize>() -> Mat<D> {
    [[0.0; D]; D]
}

fn identity<const D: usize>() -> Mat<D> {
    let mut m = zero::<D>();
    for (i, row) in m.iter_mut().enumerate() {
        if let Some(v) = row.get_mut(i) {
            *v = 1.0;
        }
    }
    m
}

fn mul<const D: usize>(a: &Mat<D>, b: &Mat<D>) -> Mat<D> {
    let mut c = zero::<D>();
    for (ci, ai) in c.iter_mut().zip(a.iter()) {
        for (k, aik) in ai.iter().enumerate() {
            if let Some(bk) = b.get(k) {
                for (cij, bkj) in ci.iter_mut().zip(bk.iter()) {
                    *cij += aik * bkj;
                }
            }
        }
    }
    c
}

fn add_scaled<const D: usize>(a: &Mat<D>, b: &Mat<D>, s: f64) -> Mat<D> {
    let mut c = *a;
    for (ci, bi) in c.iter_mut().zip(b.iter()) {
        for (cij, bij) in ci.iter_mut().zip(bi.iter()) {
            *cij += s * bij;
        }
    }
    c
}

fn norm_inf<const D: usize>(a: &Mat<D>) -> f64 {
    a.iter()
        .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// `(Φ, Ψ)` with `Φ = e^{A h}` and `Ψ = ∫₀ʰ e^{As} ds`; `Γ = Ψ B`.
///
/// `A` must be finite; the result is finite unless `A h` is so large that `e^{Ah}`
/// overflows `f64` (callers check).
pub fn exp_and_integral<const D: usize>(a: &Mat<D>, h: f64) -> (Mat<D>, Mat<D>) {
    let mut z = zero::<D>();
    for (zi, ai) in z.iter_mut().zip(a.iter()) {
        for (zij, aij) in zi.iter_mut().zip(ai.iter()) {
            *zij = aij * h;
        }
    }
    let norm = norm_inf(&z);
    let mut squarings = 0u32;
    let mut scale = 1.0;
    while norm * scale > 0.5 && squarings < 200 {
        scale *= 0.5;
        squarings += 1;
    }
    for zi in z.iter_mut() {
        for zij in zi.iter_mut() {
            *zij *= scale;
        }
    }
    // Taylor series of e^Z and φ₁(Z) at ‖Z‖ ≤ 1/2: 20 terms reach below 1e-25 relative.
    let eye = identity();
    let mut e = eye;
    let mut phi = eye;
    let mut term = eye; // Zᵏ / k!
    for k in 1..=20u32 {
        term = mul(&term, &z);
        let inv_k = 1.0 / f64::from(k);
        for ti in term.iter_mut() {
            for tij in ti.iter_mut() {
                *tij *= inv_k;
            }
        }
        e = add_scaled(&e, &term, 1.0);
        // φ₁ term is Zᵏ/(k+1)! = (Zᵏ/k!) / (k+1)
        phi = add_scaled(&phi, &term, 1.0 / f64::from(k + 1));
    }
    for _ in 0..squarings {
        let e_plus_i = add_scaled(&e, &eye, 1.0);
        let p = mul(&phi, &e_plus_i);
        phi = add_scaled(&zero::<D>(), &p, 0.5);
        e = mul(&e, &e);
    }
    // Ψ = h φ₁(A h)
    let psi = add_scaled(&zero::<D>(), &phi, h);
    (e, psi)
}

/// `Ψ b` for a column `b`.
pub fn apply<const D: usize>(psi: &Mat<D>, b: &[f64; D]) -> [f64; D] {
    let mut out = [0.0; D];
    for (o, row) in out.iter_mut().zip(psi.iter()) {
        *o = row.iter().zip(b.iter()).map(|(p, bj)| p * bj).sum();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exponential_of_a_harmonic_oscillator_is_a_rotation() {
        // ẍ = −ω² x as [x, v]: e^{Ah} = [[cos, sin/ω], [−ω sin, cos]].
        let w = 800.0;
        let mut a: Mat = zero();
        a[0][1] = 1.0;
        a[1][0] = -w * w;
        let h = 0.0005;
        let (e, psi) = exp_and_integral(&a, h);
        let (s, c) = libm::sincos(w * h);
        assert!((e[0][0] - c).abs() < 1e-13);
        assert!((e[0][1] - s / w).abs() < 1e-13);
        assert!((e[1][0] + w * s).abs() < 1e-9);
        // ∫ x-row: ∫₀ʰ cos(ws) ds = sin(wh)/w
        assert!((psi[0][0] - s / w).abs() < 1e-13);
        assert!((psi[0][1] - (1.0 - c) / (w * w)).abs() < 1e-13);
    }

    #[test]
    fn integral_of_a_stiff_decay_is_exact() {
        // ẋ = −λ x with λ h = 20 (the motor's electrical mode at the 0.5 ms step).
        let lam = 40_625.0;
        let mut a: Mat = zero();
        a[0][0] = -lam;
        let h = 0.0005;
        let (e, psi) = exp_and_integral(&a, h);
        let exact = libm::exp(-lam * h);
        assert!((e[0][0] - exact).abs() < 1e-15);
        assert!(((psi[0][0] - (1.0 - exact) / lam) * lam).abs() < 1e-13);
    }

    #[test]
    fn pure_integrator_gives_the_step_length() {
        let mut a: Mat = zero();
        a[4][2] = 1.0; // θ̇ = ω
        let (e, psi) = exp_and_integral(&a, 0.25);
        assert_eq!(e[4][2], 0.25);
        assert!((psi[4][2] - 0.25 * 0.25 / 2.0).abs() < 1e-15);
        assert!((psi[2][2] - 0.25).abs() < 1e-15);
    }
}
