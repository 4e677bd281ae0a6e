//! Geometry shared by every stage: the speed of light and the bistatic range.
//!
//! Positions are [`glam::Vec3`] in metres, in one right-handed frame with z up. Where phase
//! accuracy matters (back-projection at building scale) callers pass positions *relative to a
//! local origin* such as the voxel grid's, so that `f32` keeps sub-millimetre resolution.

use crate::error::DspError;
use glam::Vec3;

/// Speed of light in vacuum, m/s.
pub const C_M_PER_S: f64 = 299_792_458.0;

/// Wavelength in metres of a carrier at `freq_hz`, `c / freq_hz`.
///
/// For a positive, finite `freq_hz` whose wavelength is finite (every frequency above about
/// 1.7·10⁻³⁰⁰ Hz) — the caller's contract, as for a host that validated its configuration. It does
/// not check: 0 Hz gives `+∞`, a negative frequency a negative wavelength, NaN gives NaN. Use
/// [`try_wavelength_m`] where the frequency has not been validated.
#[inline]
pub fn wavelength_m(freq_hz: f64) -> f64 {
    C_M_PER_S / freq_hz
}

/// [`wavelength_m`] for a frequency that may be bad: `Ok(c / freq_hz)`, always finite and > 0.
///
/// # Errors
/// [`DspError::OutOfRange`] (`freq_hz`) unless `freq_hz` is finite and > 0 and the wavelength
/// is finite (a subnormal frequency overflows it).
#[inline]
pub fn try_wavelength_m(freq_hz: f64) -> Result<f64, DspError> {
    let l = C_M_PER_S / freq_hz;
    if freq_hz.is_finite() && freq_hz > 0.0 && l.is_finite() {
        Ok(l)
    } else {
        Err(DspError::OutOfRange {
            what: "freq_hz",
            value: freq_hz as f32,
        })
    }
}

/// Bistatic range `r_V + r_R` of point `p` seen by a transmitter at `tx` and a receiver at `rx`
/// (paper eq. 1), in metres. The one place this formula lives: imaging, echo synthesis and metrics
/// all call it.
#[inline]
pub fn bistatic_range(p: Vec3, tx: Vec3, rx: Vec3) -> f32 {
    p.distance(tx) + p.distance(rx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bistatic_range_of_monostatic_is_twice_the_range() {
        let p = Vec3::new(3.0, 4.0, 0.0);
        assert_eq!(bistatic_range(p, Vec3::ZERO, Vec3::ZERO), 10.0);
    }

    #[test]
    fn wavelength_at_10_ghz_is_about_3_cm() {
        assert!((wavelength_m(10e9) - 0.029_979_245_8).abs() < 1e-12);
    }

    /// The checked wavelength refuses a frequency with no finite positive wavelength (0 Hz gave
    /// `+∞`) and agrees with [`wavelength_m`] bit for bit otherwise.
    #[test]
    fn a_frequency_without_a_finite_wavelength_is_an_error() {
        for f in [
            0.0,
            -0.0,
            -10e9,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE / 4.0, // subnormal: c/f overflows
            1e-300,                  // below c / f64::MAX ≈ 1.7e-300 Hz: likewise
        ] {
            match try_wavelength_m(f) {
                Err(DspError::OutOfRange { what, value }) => {
                    assert_eq!(what, "freq_hz");
                    assert!(
                        value == f as f32 || (value.is_nan() && f.is_nan()),
                        "{value}, {f}"
                    );
                }
                other => panic!("try_wavelength_m({f}) = {other:?}"),
            }
        }
        for f in [1e-299, 1.0, 2.4e9, 10e9, 77e9, f64::MAX] {
            let l = try_wavelength_m(f).unwrap();
            assert_eq!(l.to_bits(), wavelength_m(f).to_bits());
            assert!(l.is_finite() && l > 0.0, "{f} Hz → {l} m");
        }
    }
}
