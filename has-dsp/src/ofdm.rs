//! OFDM grid conventions shared by echo synthesis and range compression.
//!
//! A frame has `n` subcarriers spaced `Δf = B / n` around the carrier `fc`. Arrays of subcarriers
//! are kept in **FFT order**: index `k` is at baseband offset `k·Δf` for `k < n/2` and `(k − n)·Δf`
//! for `k ≥ n/2` (see [`subcarrier_offset_hz`]), so an inverse FFT of `Y[k]·conj(S[k])` gives a
//! range profile whose pulse is real and symmetric, carrying the carrier phase `e^{−j2π fc τ}`.
//!
//! Range profiles are indexed by **bistatic path length** `r = c·τ` (metres): with zero-padding
//! factor `p` the bin spacing is `c / (B·p)` and the unambiguous path length `c / Δf`. A monostatic
//! user halves these to get one-way range.

use crate::error::{check_positive, DspError};
use crate::geometry::C_M_PER_S;

/// Baseband frequency offset (Hz) of subcarrier `k` of `n`, in FFT order (see module docs).
#[inline]
pub fn subcarrier_offset_hz(k: usize, n: usize, spacing_hz: f64) -> f64 {
    let signed = if k < n / 2 {
        k as f64
    } else {
        k as f64 - n as f64
    };
    signed * spacing_hz
}

/// Subcarrier spacing `Δf = B / n` in Hz.
///
/// # Errors
/// `OutOfRange` for a bandwidth that is not finite and positive or `n == 0`.
pub fn subcarrier_spacing_hz(bandwidth_hz: f64, n: usize) -> Result<f64, DspError> {
    check_positive("bandwidth_hz", bandwidth_hz as f32)?;
    if n == 0 {
        return Err(DspError::OutOfRange {
            what: "n_subcarriers",
            value: 0.0,
        });
    }
    Ok(bandwidth_hz / n as f64)
}

/// Range-profile bin spacing in metres of bistatic path length: `c / (B·zero_pad)`.
///
/// # Errors
/// `OutOfRange` for a bandwidth that is not finite and positive or `zero_pad == 0`.
pub fn range_bin_spacing_m(bandwidth_hz: f64, zero_pad: usize) -> Result<f64, DspError> {
    check_positive("bandwidth_hz", bandwidth_hz as f32)?;
    if zero_pad == 0 {
        return Err(DspError::OutOfRange {
            what: "zero_pad",
            value: 0.0,
        });
    }
    Ok(bin_spacing_m(bandwidth_hz, zero_pad))
}

/// [`range_bin_spacing_m`] for parameters the caller has already validated (`bandwidth_hz`
/// finite and > 0, `zero_pad` ≥ 1): the one place of the formula `c / (B·zero_pad)`.
pub fn bin_spacing_m(bandwidth_hz: f64, zero_pad: usize) -> f64 {
    C_M_PER_S / (bandwidth_hz * zero_pad as f64)
}

/// Unambiguous bistatic path length `c / Δf = n·c / B` in metres.
///
/// # Errors
/// As [`subcarrier_spacing_hz`].
pub fn unambiguous_path_m(bandwidth_hz: f64, n: usize) -> Result<f64, DspError> {
    Ok(C_M_PER_S / subcarrier_spacing_hz(bandwidth_hz, n)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subcarriers_are_in_fft_order_around_the_carrier() {
        let df = 1.0;
        assert_eq!(subcarrier_offset_hz(0, 8, df), 0.0);
        assert_eq!(subcarrier_offset_hz(3, 8, df), 3.0);
        assert_eq!(subcarrier_offset_hz(4, 8, df), -4.0);
        assert_eq!(subcarrier_offset_hz(7, 8, df), -1.0);
    }

    #[test]
    fn bin_spacing_at_400_mhz_is_75_cm_of_path() {
        let dr = range_bin_spacing_m(400e6, 1).unwrap();
        assert!((dr - 0.749_481_145).abs() < 1e-9);
        assert!((range_bin_spacing_m(400e6, 4).unwrap() - dr / 4.0).abs() < 1e-12);
        let ru = unambiguous_path_m(400e6, 2048).unwrap();
        assert!((ru - 2048.0 * dr).abs() < 1e-6);
    }

    #[test]
    fn zero_bandwidth_and_zero_padding_are_errors() {
        assert!(matches!(
            subcarrier_spacing_hz(0.0, 64),
            Err(DspError::OutOfRange {
                what: "bandwidth_hz",
                ..
            })
        ));
        assert!(subcarrier_spacing_hz(f64::NAN, 64).is_err());
        assert!(subcarrier_spacing_hz(1e6, 0).is_err());
        assert!(range_bin_spacing_m(1e6, 0).is_err());
    }
}
