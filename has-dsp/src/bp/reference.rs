//! Reference loops: the plain scalar baseline and the `f64` truth, plus the signal-to-error ratio.

use super::Backprojector;
use crate::error::{check_len, DspError};
use crate::geometry::bistatic_range;
use crate::phase::rotor_f32_libm;
use glam::Vec3;
use num_complex::Complex;

/// Straightforward loop: per voxel its position from the index, the bistatic range, the
/// interpolated sample and `sincos`; nothing reused between voxels or profiles.
pub(super) fn naive(
    bp: &Backprojector,
    first: usize,
    acc: &mut [Complex<f32>],
    profile: &[Complex<f32>],
    tx: Vec3,
    rx: Vec3,
) {
    let cfg = &bp.cfg;
    for (k, a) in acc.iter_mut().enumerate() {
        let Some(p) = cfg.grid.voxel_local(first + k) else {
            return;
        };
        let r = bistatic_range(p, tx, rx);
        let x = (r - cfg.r0_m) / cfg.dr_m;
        let s = match cfg.interp {
            super::Interp::Nearest => {
                let i = libm::floorf(x + 0.5);
                if i >= 0.0 && i < profile.len() as f32 {
                    profile[i as usize]
                } else {
                    Complex::new(0.0, 0.0)
                }
            }
            super::Interp::Linear => {
                let fl = libm::floorf(x);
                let w = x - fl;
                let at = |i: f32| {
                    if i >= 0.0 && i < profile.len() as f32 {
                        profile[i as usize]
                    } else {
                        Complex::new(0.0, 0.0)
                    }
                };
                at(fl) * (1.0 - w) + at(fl + 1.0) * w
            }
        };
        *a += s * rotor_f32_libm(r / cfg.wavelength_m);
    }
}

/// All-`f64` back-projection of one profile onto the whole grid (`acc.len() == voxels`).
pub(super) fn reference_f64(
    bp: &Backprojector,
    acc: &mut [Complex<f64>],
    profile: &[Complex<f32>],
    tx: [f64; 3],
    rx: [f64; 3],
) {
    let cfg = &bp.cfg;
    let [nx, ny, _] = cfg.grid.dims;
    let sp = [
        cfg.grid.spacing.x as f64,
        cfg.grid.spacing.y as f64,
        cfg.grid.spacing.z as f64,
    ];
    let dist = |p: [f64; 3], q: [f64; 3]| {
        let d = [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
        libm::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    };
    let at = |i: f64| {
        if i >= 0.0 && i < profile.len() as f64 {
            let z = profile[i as usize];
            Complex::new(z.re as f64, z.im as f64)
        } else {
            Complex::new(0.0, 0.0)
        }
    };
    let (lambda, r0, dr) = (cfg.wavelength_m as f64, cfg.r0_m as f64, cfg.dr_m as f64);
    for (idx, a) in acc.iter_mut().enumerate() {
        let p = [
            sp[0] * (idx % nx) as f64,
            sp[1] * ((idx / nx) % ny) as f64,
            sp[2] * (idx / (nx * ny)) as f64,
        ];
        let r = dist(p, tx) + dist(p, rx);
        let x = (r - r0) / dr;
        let s = match cfg.interp {
            super::Interp::Nearest => at(libm::floor(x + 0.5)),
            super::Interp::Linear => {
                let fl = libm::floor(x);
                let w = x - fl;
                at(fl) * (1.0 - w) + at(fl + 1.0) * w
            }
        };
        let t = r / lambda;
        let phi = core::f64::consts::TAU * (t - libm::floor(t));
        *a += s * Complex::new(libm::cos(phi), libm::sin(phi));
    }
}

/// Signal-to-error ratio in dB of an image against a reference:
/// `10·log10(Σ|ref|² / Σ|image − ref|²)`; `+∞` when they agree exactly.
///
/// # Errors
/// [`DspError::LengthMismatch`] unless the lengths agree; [`DspError::OutOfRange`] if the
/// reference has no energy.
pub fn ser_db(image: &[Complex<f32>], reference: &[Complex<f64>]) -> Result<f64, DspError> {
    check_len("image", reference.len(), image.len())?;
    let (mut sig, mut err) = (0.0f64, 0.0f64);
    for (a, r) in image.iter().zip(reference) {
        sig += r.norm_sqr();
        err += (Complex::new(a.re as f64, a.im as f64) - r).norm_sqr();
    }
    if sig.is_nan() || sig <= 0.0 {
        return Err(DspError::OutOfRange {
            what: "reference energy",
            value: sig as f32,
        });
    }
    Ok(10.0 * libm::log10(sig / err))
}

/// Adds the analytic range-compressed echo of one point scatterer to `profile`:
/// `s[i] += amp · sinc((r_i − r_p)/res) · e^{−j2π r_p/λ}`, `r_i = r0 + i·dr`, `sinc(x) =
/// sin(πx)/(πx)` (the unwindowed compressed pulse of bandwidth `B = c/res`). Evaluated in `f64`.
/// For tests and benchmarks; the simulator's echo synthesis owns the physical model.
///
/// # Errors
/// [`DspError::OutOfRange`] for non-positive `dr_m`, `wavelength_m` or `res_m`;
/// [`DspError::NonFinite`] for non-finite `r0_m`, `r_p_m` or `amp`.
pub fn add_point_echo(
    profile: &mut [Complex<f32>],
    r0_m: f64,
    dr_m: f64,
    wavelength_m: f64,
    res_m: f64,
    r_p_m: f64,
    amp: Complex<f64>,
) -> Result<(), DspError> {
    for (what, v) in [
        ("dr_m", dr_m),
        ("wavelength_m", wavelength_m),
        ("res_m", res_m),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(DspError::OutOfRange {
                what,
                value: v as f32,
            });
        }
    }
    for (what, v) in [
        ("r0_m", r0_m),
        ("r_p_m", r_p_m),
        ("amp.re", amp.re),
        ("amp.im", amp.im),
    ] {
        if !v.is_finite() {
            return Err(DspError::NonFinite { what });
        }
    }
    let t = r_p_m / wavelength_m;
    let phi = -core::f64::consts::TAU * (t - libm::floor(t));
    let a = amp * Complex::new(libm::cos(phi), libm::sin(phi));
    for (i, s) in profile.iter_mut().enumerate() {
        let x = (r0_m + i as f64 * dr_m - r_p_m) / res_m;
        let px = core::f64::consts::PI * x;
        let sinc = if px.abs() < 1e-9 {
            1.0
        } else {
            libm::sin(px) / px
        };
        let v = a * sinc;
        *s += Complex::new(v.re as f32, v.im as f32);
    }
    Ok(())
}
