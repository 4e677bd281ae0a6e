//! Propagation formulas: free-space amplitude and the Fresnel reflection coefficients.
//!
//! One place for each formula, used by the path tracer, echo synthesis and tests alike.
//! Conventions (ITU-R P.2040-3 §2.2.1, also Sionna RT's): the angle of incidence θ is measured from
//! the surface normal; `η` is the complex relative permittivity of the second medium
//! ([`crate::Material::complex_permittivity`], `Im η ≤ 0`); the first medium is air.
//!
//! * TE (perpendicular, "s", E normal to the plane of incidence):
//!   `R⊥ = (cos θ − √(η − sin²θ)) / (cos θ + √(η − sin²θ))`
//! * TM (parallel, "p", E in the plane of incidence):
//!   `R∥ = (η·cos θ − √(η − sin²θ)) / (η·cos θ + √(η − sin²θ))`
//!
//! With this sign convention both tend to −1 at grazing incidence, `R∥ = −R⊥` at normal incidence,
//! and `R∥` vanishes at the Brewster angle `tan θ_B = √εr` of a lossless medium.

use num_complex::Complex64;

/// Fresnel reflection coefficients of a smooth air/material interface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fresnel {
    /// Perpendicular (TE, s) polarisation.
    pub te: Complex64,
    /// Parallel (TM, p) polarisation.
    pub tm: Complex64,
}

/// Fresnel reflection coefficients for incidence with `cos θ = cos_theta_i` (θ from the normal,
/// `cos_theta_i` clamped to \[0, 1\]) on a material of complex relative permittivity `eta`.
pub fn fresnel_reflection(eta: Complex64, cos_theta_i: f64) -> Fresnel {
    let c = cos_theta_i.clamp(0.0, 1.0);
    let sin2 = 1.0 - c * c;
    let root = (eta - sin2).sqrt();
    let te = (c - root) / (c + root);
    let tm = (eta * c - root) / (eta * c + root);
    Fresnel { te, tm }
}

/// Free-space amplitude factor `λ / (4π d)` of a path of length `d` (metres); its square is the
/// Friis path gain between isotropic antennas.
#[inline]
pub fn free_space_amplitude(distance_m: f64, wavelength_m: f64) -> f64 {
    wavelength_m / (4.0 * std::f64::consts::PI * distance_m)
}

/// Free-space path loss in dB over `distance_m` at `wavelength_m`.
#[inline]
pub fn free_space_loss_db(distance_m: f64, wavelength_m: f64) -> f64 {
    -20.0 * free_space_amplitude(distance_m, wavelength_m).log10()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Material;

    #[test]
    fn normal_incidence_reflection_is_one_minus_root_eta_over_one_plus() {
        let eta = Complex64::new(5.24, 0.0);
        let f = fresnel_reflection(eta, 1.0);
        let expected = (1.0 - 5.24f64.sqrt()) / (1.0 + 5.24f64.sqrt());
        assert!((f.te.re - expected).abs() < 1e-12 && f.te.im.abs() < 1e-12);
        assert!((f.tm + f.te).norm() < 1e-12);
    }

    #[test]
    fn tm_vanishes_at_brewster_angle_of_lossless_dielectric() {
        let er = 5.24f64;
        let theta_b = er.sqrt().atan();
        let f = fresnel_reflection(Complex64::new(er, 0.0), theta_b.cos());
        assert!(f.tm.norm() < 1e-12, "|R_TM| = {}", f.tm.norm());
        assert!(f.te.norm() > 0.5);
    }

    #[test]
    fn grazing_incidence_reflects_totally_with_sign_flip() {
        let eta = Material::Concrete.complex_permittivity(10e9);
        let f = fresnel_reflection(eta, 0.0);
        assert!((f.te + 1.0).norm() < 1e-12);
        assert!((f.tm + 1.0).norm() < 1e-12);
    }

    #[test]
    fn metal_reflects_almost_totally() {
        let eta = Material::Metal.complex_permittivity(10e9);
        let f = fresnel_reflection(eta, 0.7);
        assert!(f.te.norm() > 0.999 && f.tm.norm() > 0.999);
    }

    #[test]
    fn free_space_loss_at_10_ghz_and_100_m_is_92_4_db() {
        let l = free_space_loss_db(100.0, crate::wavelength_m(10e9));
        assert!((l - 92.44).abs() < 0.01, "{l}");
    }
}
