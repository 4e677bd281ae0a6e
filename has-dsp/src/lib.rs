//! # has-dsp
//!
//! The signal-processing core of hybrid aperture sensing, written as baseband firmware would be:
//! `#![no_std]`, no allocation, every buffer owned by the caller or sized by a const generic.
//! Each kernel has an `f32` path and a fixed-point path (Q15 samples, wide integer accumulators,
//! explicit rounding and saturation). Public entry points that can meet bad input return
//! [`DspError`] rather than panicking.
//!
//! Conventions used throughout: SI units (metres, seconds, hertz), positions as [`glam::Vec3`] in
//! metres, angles and phases in radians, complex baseband with the `e^{+j2πr/λ}` back-projection
//! phase of the paper's eq. 1.
#![cfg_attr(not(test), no_std)]

pub mod bp;
pub mod cfar;
pub mod eca;
pub mod error;
pub mod fft;
pub mod fixed;
pub mod geometry;
pub mod linalg;
pub mod ofdm;
pub mod phase;
pub mod range;
pub mod template;
#[cfg(test)]
mod test_util;
pub mod window;

pub use error::DspError;
pub use fixed::{Q15, Q31};
