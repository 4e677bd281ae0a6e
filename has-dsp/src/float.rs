//! Float primitives that firmware and host builds compile differently, with the same result.
//!
//! [`sqrt`] is IEEE-754's correctly rounded square root either way: `libm::sqrtf` in `no_std`
//! (firmware), `f32::sqrt` with feature `std`, which LLVM lowers to the hardware instruction and
//! vectorises (`sqrtps`), where libm's call keeps a loop scalar.

/// Correctly rounded `√x` (NaN for `x < 0`).
#[inline(always)]
pub(crate) fn sqrt(x: f32) -> f32 {
    #[cfg(any(test, feature = "std"))]
    {
        x.sqrt()
    }
    #[cfg(not(any(test, feature = "std")))]
    {
        libm::sqrtf(x)
    }
}
