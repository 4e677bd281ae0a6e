//! Geometry shared by every stage: the speed of light and the bistatic range.
//!
//! Positions are [`glam::Vec3`] in metres, in one right-handed frame with z up. Where phase
//! accuracy matters (back-projection at building scale) callers pass positions *relative to a
//! local origin* such as the voxel grid's, so that `f32` keeps sub-millimetre resolution.

use glam::Vec3;

/// Speed of light in vacuum, m/s.
pub const C_M_PER_S: f64 = 299_792_458.0;

/// Wavelength in metres of a carrier at `freq_hz`.
#[inline]
pub fn wavelength_m(freq_hz: f64) -> f64 {
    C_M_PER_S / freq_hz
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
}
