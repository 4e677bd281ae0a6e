//! Channel frequency response from propagation paths.
//!
//! `H(f) = Σ_p a_p · e^{−j2π f τ_p}` with `f` the **baseband** offset from the carrier: the path
//! coefficients [`Path::a`] already carry the carrier phase `e^{−j2π fc τ}` (Sionna RT's
//! convention, see [`crate::paths`]). Subcarrier grids follow [`has_dsp::ofdm`]: `n` subcarriers
//! spaced `Δf`, in FFT order (index `k` at [`has_dsp::ofdm::subcarrier_offset_hz`]). Amplitudes
//! are narrowband (material parameters and `λ` at the carrier).

use has_dsp::ofdm::subcarrier_offset_hz;
use num_complex::Complex64;

use crate::paths::{Path, PathError};

/// `H(f)` at each baseband offset `freqs_hz[i]` (Hz).
pub fn frequency_response_at(paths: &[Path], freqs_hz: &[f64]) -> Vec<Complex64> {
    freqs_hz
        .iter()
        .map(|&f| {
            paths
                .iter()
                .map(|p| {
                    // e^{−j2π f τ}, with the turn count reduced first for precision.
                    let turns = (f * p.delay_s).fract();
                    p.a * Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * turns)
                })
                .sum()
        })
        .collect()
}

/// `H` on an OFDM grid of `n` subcarriers spaced `spacing_hz`, in FFT order.
///
/// # Errors
/// [`PathError::OutOfRange`] for `n == 0` or a spacing that is not finite and positive.
pub fn frequency_response(
    paths: &[Path],
    n: usize,
    spacing_hz: f64,
) -> Result<Vec<Complex64>, PathError> {
    if n == 0 {
        return Err(PathError::OutOfRange {
            what: "n_subcarriers",
            value: 0.0,
            expected: "at least 1",
        });
    }
    if !(spacing_hz.is_finite() && spacing_hz > 0.0) {
        return Err(PathError::OutOfRange {
            what: "spacing_hz",
            value: spacing_hz,
            expected: "finite and > 0",
        });
    }
    let freqs: Vec<f64> = (0..n)
        .map(|k| subcarrier_offset_hz(k, n, spacing_hz))
        .collect();
    Ok(frequency_response_at(paths, &freqs))
}
