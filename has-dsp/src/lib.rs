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
//!
//! Feature `std` (off by default; the host crates turn it on) changes how fast, never what: square
//! roots in hardware (`sqrtps` instead of libm's scalar routine, both correctly rounded) and, on
//! x86-64, the back-projection kernels (and host loops handed to [`simd::run_simd`]) dispatched at
//! run time to an AVX2 build of the same code.
//! Every path computes the same IEEE operations in the same order (no FMA contraction), so images
//! are bit-identical with and without it.
#![cfg_attr(not(any(test, feature = "std")), no_std)]

pub mod bp;
pub mod cfar;
pub mod direct_path;
pub mod eca;
pub mod error;
#[cfg(test)]
mod extreme_tests;
pub mod fft;
pub mod fixed;
mod float;
pub mod geometry;
pub mod linalg;
pub mod ofdm;
pub mod phase;
pub mod range;
pub mod simd;
pub mod template;
#[cfg(test)]
mod test_util;
pub mod window;

pub use error::DspError;
pub use fixed::{Q15, Q31};
