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
//!
//! **A slab** of thickness `d` in air (ITU-R P.2040-3 eqs. 43–44, as Sionna RT applies every
//! material's `thickness`; [`slab_coefficients`]): with `R` the interface coefficient above and
//! `q = (2π d / λ)·√(η − sin²θ)`, the multiple internal reflections sum to
//! `R_slab = R·(1 − e^{−j2q}) / (1 − R²·e^{−j2q})` and `T_slab = (1 − R²)·e^{−jq} / (1 − R²·e^{−j2q})`,
//! per polarisation. As `d` grows in a lossy medium, `e^{−j2q} → 0` and `R_slab → R` (the
//! half-space, [`fresnel_reflection`]); a lossless slab reflects nothing at `d = mλ/(2√(η − sin²θ))`
//! and conserves energy, `|R_slab|² + |T_slab|² = 1`.

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

/// Reflection and transmission coefficients of a slab ([`slab_coefficients`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slab {
    /// Reflection, both polarisations.
    pub reflection: Fresnel,
    /// Transmission through the slab (the field leaving its far face against the incident one at
    /// its near face), both polarisations.
    pub transmission: Fresnel,
}

/// The coefficients of a slab of thickness `thickness_m` and complex relative permittivity
/// `eta` in air, for incidence with `cos θ = cos_theta_i` (clamped to \[0, 1\]) at wavelength
/// `wavelength_m` (module docs; ITU-R P.2040-3 eqs. 43–44).
pub fn slab_coefficients(
    eta: Complex64,
    cos_theta_i: f64,
    thickness_m: f64,
    wavelength_m: f64,
) -> Slab {
    let c = cos_theta_i.clamp(0.0, 1.0);
    let root = (eta - (1.0 - c * c)).sqrt();
    let q = root * (2.0 * std::f64::consts::PI * thickness_m / wavelength_m);
    let minus_j = Complex64::new(0.0, -1.0);
    let (e1, e2) = ((minus_j * q).exp(), (minus_j * 2.0 * q).exp());
    let r = fresnel_reflection(eta, c);
    let slab = |r: Complex64| {
        let den = 1.0 - r * r * e2;
        (r * (1.0 - e2) / den, (1.0 - r * r) * e1 / den)
    };
    let ((rte, tte), (rtm, ttm)) = (slab(r.te), slab(r.tm));
    Slab {
        reflection: Fresnel { te: rte, tm: rtm },
        transmission: Fresnel { te: tte, tm: ttm },
    }
}

/// The reflection coefficients of a face of a material of complex relative permittivity `eta`
/// and thickness `thickness_m` (`None`: infinitely thick) at wavelength `wavelength_m`: the slab's
/// ([`slab_coefficients`]) or the half-space's ([`fresnel_reflection`]). What the tracer and the
/// echo synthesis call for every reflection.
pub fn reflection(
    eta: Complex64,
    cos_theta_i: f64,
    thickness_m: Option<f64>,
    wavelength_m: f64,
) -> Fresnel {
    match thickness_m {
        Some(d) => slab_coefficients(eta, cos_theta_i, d, wavelength_m).reflection,
        None => fresnel_reflection(eta, cos_theta_i),
    }
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
    fn a_thick_lossy_slab_reflects_like_the_half_space() {
        let lambda = crate::wavelength_m(10e9);
        let eta = Material::Concrete.complex_permittivity(10e9);
        for cos_i in [0.1, 0.5, 0.9, 1.0] {
            let half = fresnel_reflection(eta, cos_i);
            let slab = slab_coefficients(eta, cos_i, 10.0, lambda).reflection;
            assert!((slab.te - half.te).norm() < 1e-9, "{cos_i}");
            assert!((slab.tm - half.tm).norm() < 1e-9, "{cos_i}");
        }
    }

    #[test]
    fn a_lossless_slab_conserves_energy_and_vanishes_at_half_wave_thickness() {
        let lambda = 0.03;
        let eta = Complex64::new(4.0, 0.0);
        for cos_i in [0.2, 0.6, 1.0] {
            for d in [0.004, 0.011, 0.05, 0.1] {
                let s = slab_coefficients(eta, cos_i, d, lambda);
                for (r, t) in [
                    (s.reflection.te, s.transmission.te),
                    (s.reflection.tm, s.transmission.tm),
                ] {
                    let e = r.norm_sqr() + t.norm_sqr();
                    assert!((e - 1.0).abs() < 1e-12, "cos {cos_i} d {d}: {e}");
                }
            }
            // q = π: the two faces' reflections cancel.
            let sin2 = 1.0 - cos_i * cos_i;
            let d = lambda / (2.0 * (4.0 - sin2).sqrt());
            let s = slab_coefficients(eta, cos_i, d, lambda);
            assert!(s.reflection.te.norm() < 1e-12 && s.reflection.tm.norm() < 1e-12);
        }
    }

    #[test]
    fn a_lossy_slab_passes_less_than_it_receives_and_a_thin_one_less_reflects() {
        let lambda = crate::wavelength_m(3.5e9);
        let eta = Material::Brick.complex_permittivity(3.5e9);
        let s = slab_coefficients(eta, 0.8, 0.1, lambda);
        for (r, t) in [
            (s.reflection.te, s.transmission.te),
            (s.reflection.tm, s.transmission.tm),
        ] {
            assert!(r.norm_sqr() + t.norm_sqr() < 1.0);
        }
        let thin = slab_coefficients(eta, 0.8, 1e-5, lambda).reflection;
        assert!(thin.te.norm() < 1e-2 && thin.tm.norm() < 1e-2, "{thin:?}");
    }

    #[test]
    fn free_space_loss_at_10_ghz_and_100_m_is_92_4_db() {
        let l = free_space_loss_db(100.0, crate::wavelength_m(10e9));
        assert!((l - 92.44).abs() < 0.01, "{l}");
    }
}
