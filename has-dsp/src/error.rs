//! The one error type of `has-dsp`.
//!
//! Every variant names the offending field (`what`, a static string such as `"profile"` or
//! `"config.bandwidth_hz"`) and, where there is one, the value, so that a host program can print a
//! single readable line. The enum is `#[non_exhaustive]`: new kernels may add variants.

use core::fmt;

/// Why a `has-dsp` function refused its input.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DspError {
    /// A slice or buffer had the wrong length.
    LengthMismatch {
        /// The argument or field.
        what: &'static str,
        /// The length required.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// A length the kernel does not support (e.g. an FFT size that is not a power of two).
    UnsupportedLength {
        /// The argument or field.
        what: &'static str,
        /// The length given.
        len: usize,
    },
    /// A value that must be finite was NaN or infinite.
    NonFinite {
        /// The argument or field.
        what: &'static str,
    },
    /// A value outside its valid range (zero bandwidth, negative spacing, ...).
    OutOfRange {
        /// The argument or field.
        what: &'static str,
        /// The value given.
        value: f32,
    },
    /// A voxel grid with more voxels than the caller's accumulator buffer holds.
    GridTooLarge {
        /// Voxels the grid describes.
        voxels: usize,
        /// Voxels the buffer holds.
        capacity: usize,
    },
    /// A wide accumulator would overflow: more pushes than the documented maximum.
    AccumulatorOverflow {
        /// The accumulator.
        what: &'static str,
        /// The documented maximum number of pushes.
        max_pushes: u32,
    },
    /// A matrix that must be positive definite was not (singular or ill-conditioned system).
    NotPositiveDefinite {
        /// The matrix.
        what: &'static str,
    },
}

impl fmt::Display for DspError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            DspError::LengthMismatch {
                what,
                expected,
                got,
            } => write!(f, "{what}: length {got}, expected {expected}"),
            DspError::UnsupportedLength { what, len } => {
                write!(f, "{what}: unsupported length {len}")
            }
            DspError::NonFinite { what } => write!(f, "{what}: not finite (NaN or infinite)"),
            DspError::OutOfRange { what, value } => write!(f, "{what}: value {value} out of range"),
            DspError::GridTooLarge { voxels, capacity } => write!(
                f,
                "voxel grid: {voxels} voxels exceed the buffer capacity of {capacity}"
            ),
            DspError::AccumulatorOverflow { what, max_pushes } => write!(
                f,
                "{what}: more than the maximum of {max_pushes} pushes would overflow"
            ),
            DspError::NotPositiveDefinite { what } => {
                write!(f, "{what}: matrix is not positive definite")
            }
        }
    }
}

impl core::error::Error for DspError {}

/// Returns `Err(LengthMismatch)` unless `got == expected`. Kept cold and out of line so that the
/// check costs one compare in hot code.
#[inline]
pub fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), DspError> {
    if expected == got {
        Ok(())
    } else {
        Err(length_mismatch(what, expected, got))
    }
}

#[cold]
#[inline(never)]
fn length_mismatch(what: &'static str, expected: usize, got: usize) -> DspError {
    DspError::LengthMismatch {
        what,
        expected,
        got,
    }
}

/// Returns `Err(NonFinite)` unless `x` is finite.
#[inline]
pub fn check_finite(what: &'static str, x: f32) -> Result<(), DspError> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(DspError::NonFinite { what })
    }
}

/// Returns `Err(NonFinite)` unless every component of `v` is finite.
#[inline]
pub fn check_finite_vec3(what: &'static str, v: glam::Vec3) -> Result<(), DspError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(DspError::NonFinite { what })
    }
}

/// Returns `Err(OutOfRange)` unless `x` is finite and strictly positive.
#[inline]
pub fn check_positive(what: &'static str, x: f32) -> Result<(), DspError> {
    check_finite(what, x)?;
    if x > 0.0 {
        Ok(())
    } else {
        Err(DspError::OutOfRange { what, value: x })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_name_field_and_value() {
        let e = check_positive("config.bandwidth_hz", 0.0).unwrap_err();
        assert_eq!(e.to_string(), "config.bandwidth_hz: value 0 out of range");
        let e = check_len("profile", 1024, 1000).unwrap_err();
        assert_eq!(e.to_string(), "profile: length 1000, expected 1024");
        assert!(check_finite("x", f32::NAN).is_err());
        assert!(check_finite_vec3("tx", glam::Vec3::new(0.0, f32::INFINITY, 0.0)).is_err());
    }
}
