//! Torsional stiffness of the gear train from its geometry (paper eqs. 2–6 and 16).
//!
//! All functions are plain arithmetic on `f64`; they are used once, when a plant is built.

/// Elasticity deformation factor `Z = y / (0.242 + 7.25 y)` of a tooth with Lewis form factor
/// `y` (paper eq. 4), dimensionless.
pub fn deformation_factor(lewis_y: f64) -> f64 {
    lewis_y / (0.242 + 7.25 * lewis_y)
}

/// Torsional mesh stiffness of a gear pair, referred to the gear, N·m/rad (paper eq. 3):
/// `k_g = d² E_p Z_p E_g Z_g / (4 (E_p Z_p + E_g Z_g)) · t`.
///
/// `pitch_diameter_m`: gear pitch circle diameter, m; `face_width_m`: tooth face width, m;
/// moduli in Pa; Lewis form factors dimensionless.
pub fn tooth_stiffness(
    pitch_diameter_m: f64,
    face_width_m: f64,
    pinion_lewis_y: f64,
    gear_lewis_y: f64,
    pinion_youngs_pa: f64,
    gear_youngs_pa: f64,
) -> f64 {
    let ep = pinion_youngs_pa * deformation_factor(pinion_lewis_y);
    let eg = gear_youngs_pa * deformation_factor(gear_lewis_y);
    pitch_diameter_m * pitch_diameter_m * ep * eg / (4.0 * (ep + eg)) * face_width_m
}

/// Torsional stiffness of a solid round shaft, N·m/rad (paper eq. 5): `π G d⁴ / (32 L)`.
pub fn shaft_stiffness(shear_modulus_pa: f64, diameter_m: f64, length_m: f64) -> f64 {
    let d2 = diameter_m * diameter_m;
    core::f64::consts::PI * shear_modulus_pa * d2 * d2 / (32.0 * length_m)
}

/// Two torsional springs in series, N·m/rad (paper eqs. 2 and 6).
pub fn series(a: f64, b: f64) -> f64 {
    a * b / (a + b)
}

/// Total equivalent stiffness at the load, N·m/rad (paper eq. 16):
/// `k_eq = N_r² k1 k2 / (N_r² k1 + k2)`, with `k1` at the rotating shaft and `k2` at the load.
pub fn equivalent(n_r: f64, k1: f64, k2: f64) -> f64 {
    let k1_at_load = n_r * n_r * k1;
    series(k1_at_load, k2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    // Reference numbers: the comment block of `reference-actuator.toml` (computed by hand from
    // the paper's equations when the file was written). They are quoted to 4–5 digits, so the
    // tolerance is 1e-4 relative.
    #[test]
    fn reference_geometry_gives_the_files_stiffnesses() {
        let kg1 = tooth_stiffness(0.024, 0.003, 0.078, 0.134, 206e9, 206e9);
        let ks1 = shaft_stiffness(79.3e9, 0.004, 0.025);
        let kg2 = tooth_stiffness(0.060, 0.006, 0.078, 0.144, 206e9, 206e9);
        let ks2 = shaft_stiffness(79.3e9, 0.008, 0.045);
        assert!(rel(kg1, 4585.2) < 1e-4, "kg1 = {kg1}");
        assert!(rel(ks1, 79.72) < 1e-4, "ks1 = {ks1}");
        assert!(rel(kg2, 57687.8) < 1e-4, "kg2 = {kg2}");
        assert!(rel(ks2, 708.63) < 1e-4, "ks2 = {ks2}");
        let k1 = series(kg1, ks1);
        let k2 = series(kg2, ks2);
        assert!(rel(k1, 78.359) < 1e-4, "k1 = {k1}");
        assert!(rel(k2, 700.03) < 1e-4, "k2 = {k2}");
        assert!(rel(equivalent(10.0, k1, k2), 642.62) < 1e-4);
    }

    #[test]
    fn series_spring_is_softer_than_either() {
        let k = series(3.0, 7.0);
        assert!(k < 3.0 && k > 0.0);
        assert!((k - 2.1).abs() < 1e-12);
    }
}
