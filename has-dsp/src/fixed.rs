//! Fixed-point numbers: one newtype `Q<T, F>` with `F` fractional bits stored in `T`.
//!
//! [`Q15`] is `Q<i16, 15>`: a value `x` in \[−1, 1) stored as `round(x · 2¹⁵)`; [`Q31`] is
//! `Q<i32, 31>`. Conventions, the same for every kernel of this crate:
//!
//! * **Conversion from float rounds to nearest and saturates**: `Q15::from_f32(1.0)` is
//!   `Q15::MAX` (1 − 2⁻¹⁵), NaN maps to zero.
//! * **Addition, subtraction and negation saturate** (`−(−1)` is `MAX`); `wrapping_*` forms exist
//!   for code that proves it cannot overflow.
//! * **Multiplication rounds to nearest (half up) and saturates**: `a * b` is
//!   `sat((a·b + 2^(F−1)) >> F)`, so only `−1 · −1` saturates. [`Q15::mul_wide`] returns the exact
//!   Q30 product in an `i32` for accumulation without rounding.
//! * Wide accumulators are plain integers (`i32` / `i64`) whose format is stated where they are
//!   used; [`round_shift_i32`] / [`round_shift_i64`] bring them back with rounding.
//!
//! Complex samples are `Complex<Q15>` ([`CQ15`]); the helpers at the bottom convert to and from
//! `Complex<f32>` and multiply with wide results.

use core::ops::{Add, Neg, Sub};
use num_complex::Complex;

/// A fixed-point number with storage type `T` and `F` fractional bits.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Q<T, const F: u8>(pub T);

/// Signed Q1.15: 16-bit storage, 15 fractional bits, range \[−1, 1).
pub type Q15 = Q<i16, 15>;
/// Signed Q1.31: 32-bit storage, 31 fractional bits, range \[−1, 1).
pub type Q31 = Q<i32, 31>;
/// A complex Q15 sample (real and imaginary parts each Q15).
pub type CQ15 = Complex<Q15>;

macro_rules! impl_q {
    ($t:ty, $wide:ty, $f:literal, $fl:ty) => {
        impl Q<$t, $f> {
            /// Fractional bits.
            pub const FRAC_BITS: u32 = $f;
            /// Zero.
            pub const ZERO: Self = Self(0);
            /// The largest value, 1 − 2^−F.
            pub const MAX: Self = Self(<$t>::MAX);
            /// The smallest value, −1.
            pub const MIN: Self = Self(<$t>::MIN);
            /// One least significant bit, 2^−F, as a float.
            pub const LSB: $fl = 1.0 / ((1u64 << $f) as $fl);

            /// Converts with rounding to nearest and saturation; NaN becomes zero.
            #[inline]
            pub fn from_f32(x: f32) -> Self {
                let scaled = x as $fl * (1u64 << $f) as $fl;
                // `as` from float to int saturates and maps NaN to 0.
                Self(round_half_away(scaled) as $t)
            }

            /// The value as `f32`.
            #[inline]
            pub fn to_f32(self) -> f32 {
                (self.0 as $fl * Self::LSB) as f32
            }

            /// The raw stored integer.
            #[inline]
            pub const fn to_bits(self) -> $t {
                self.0
            }

            /// From the raw stored integer.
            #[inline]
            pub const fn from_bits(bits: $t) -> Self {
                Self(bits)
            }

            /// Exact product in the wide type with `2F` fractional bits (no rounding).
            #[inline]
            pub fn mul_wide(self, rhs: Self) -> $wide {
                self.0 as $wide * rhs.0 as $wide
            }

            /// Wrapping addition, for code that has proved it cannot overflow.
            #[inline]
            pub fn wrapping_add(self, rhs: Self) -> Self {
                Self(self.0.wrapping_add(rhs.0))
            }

            /// Saturates a wide value holding `F` fractional bits back to `Q`.
            #[inline]
            pub fn saturate_from_wide(x: $wide) -> Self {
                Self(x.clamp(<$t>::MIN as $wide, <$t>::MAX as $wide) as $t)
            }
        }

        impl Add for Q<$t, $f> {
            type Output = Self;
            /// Saturating addition.
            #[inline]
            fn add(self, rhs: Self) -> Self {
                Self(self.0.saturating_add(rhs.0))
            }
        }

        impl Sub for Q<$t, $f> {
            type Output = Self;
            /// Saturating subtraction.
            #[inline]
            fn sub(self, rhs: Self) -> Self {
                Self(self.0.saturating_sub(rhs.0))
            }
        }

        impl Neg for Q<$t, $f> {
            type Output = Self;
            /// Saturating negation: −(−1) is `MAX`.
            #[inline]
            fn neg(self) -> Self {
                Self(self.0.saturating_neg())
            }
        }

        impl core::ops::Mul for Q<$t, $f> {
            type Output = Self;
            /// Rounding (half up), saturating product.
            #[inline]
            fn mul(self, rhs: Self) -> Self {
                let p = self.mul_wide(rhs);
                let r = (p + (1 << ($f - 1))) >> $f;
                Self::saturate_from_wide(r)
            }
        }
    };
}

impl_q!(i16, i32, 15, f32);
impl_q!(i32, i64, 31, f64);

#[inline]
fn round_half_away<T: RoundAway>(x: T) -> T {
    x.round_away()
}

trait RoundAway {
    fn round_away(self) -> Self;
}
impl RoundAway for f32 {
    #[inline]
    fn round_away(self) -> Self {
        libm::roundf(self)
    }
}
impl RoundAway for f64 {
    #[inline]
    fn round_away(self) -> Self {
        libm::round(self)
    }
}

/// Arithmetic shift right by `s` with rounding to nearest (half up), for `i32` accumulators:
/// `⌊x / 2^s + ½⌋`, exactly, for every `x` and every `s`.
///
/// `s = 0` returns `x`. A shift at or beyond the width (`s ≥ 32`) is defined, not wrapped:
/// `|x / 2^s| ≤ ½` then, and every `x` rounds to 0 (`i32::MIN >> 32` is exactly −½, which rounds
/// half up to 0). Branch free: the shift is clamped to 32 and `2x + 2^s` is shifted by `s + 1`
/// in `i64`.
#[inline]
pub fn round_shift_i32(x: i32, s: u32) -> i32 {
    let s = s.min(32);
    // ⌊(2x + 2^s) / 2^(s+1)⌋ = ⌊x/2^s + ½⌋; |2x| ≤ 2³², 2^s ≤ 2³², so the sum fits an i64.
    (((x as i64) * 2 + (1i64 << s)) >> (s + 1)) as i32
}

/// Arithmetic shift right by `s` with rounding to nearest (half up), for `i64` accumulators:
/// `⌊x / 2^s + ½⌋`, exactly, for every `x` and every `s`.
///
/// `s = 0` returns `x`; `s ≥ 64` rounds every `x` to 0 (as [`round_shift_i32`] for `s ≥ 32`).
/// Branch free, in `i128`.
#[inline]
pub fn round_shift_i64(x: i64, s: u32) -> i64 {
    let s = s.min(64);
    (((x as i128) * 2 + (1i128 << s)) >> (s + 1)) as i64
}

/// Saturates an `i32` to the `i16` range.
#[inline]
pub fn sat_i16(x: i32) -> i16 {
    x.clamp(i16::MIN as i32, i16::MAX as i32) as i16
}

/// Converts a complex float to Q15 with rounding and saturation per component.
#[inline]
pub fn cq15_from_c32(z: Complex<f32>) -> CQ15 {
    Complex::new(Q15::from_f32(z.re), Q15::from_f32(z.im))
}

/// Converts a Q15 complex to float.
#[inline]
pub fn cq15_to_c32(z: CQ15) -> Complex<f32> {
    Complex::new(z.re.to_f32(), z.im.to_f32())
}

/// Block-floating-point conversion: writes `dst[i] = src[i] · 2^−e` in Q15 (rounded, see
/// [`Q15::from_f32`]) and returns the block exponent `e` (so `src[i] ≈ dst[i] · 2^e`), the
/// smallest for which no component saturates: the largest component lands in \[½, 1). An all-zero
/// block gets `e = 0`.
///
/// # Errors
/// `LengthMismatch` unless the lengths agree; `NonFinite` if a sample is not finite.
pub fn cq15_block_from_c32(
    src: &[Complex<f32>],
    dst: &mut [CQ15],
) -> Result<i32, crate::error::DspError> {
    crate::error::check_len("dst", src.len(), dst.len())?;
    let mut peak = 0.0f32;
    for z in src {
        crate::error::check_finite("src", z.re)?;
        crate::error::check_finite("src", z.im)?;
        peak = peak.max(z.re.abs()).max(z.im.abs());
    }
    if peak == 0.0 {
        dst.fill(CQ15::default());
        return Ok(0);
    }
    // peak = m · 2^k, m in [½, 1); if m rounds to 1.0 in Q15 it would saturate: one more bit.
    let (m, mut e) = libm::frexpf(peak);
    if m >= 1.0 - 0.5 * Q15::LSB {
        e += 1;
    }
    let scale = libm::ldexpf(1.0, -e);
    for (d, z) in dst.iter_mut().zip(src) {
        *d = cq15_from_c32(*z * scale);
    }
    Ok(e)
}

/// Exact complex product of two Q15 values as Q30 in `i32` parts.
///
/// Each part is a sum of two Q30 products, at most 2 · 2³⁰ in magnitude, which fits `i32` except
/// for the single case `(−1 − j)·(−1 + j)`-like extremes reaching exactly 2³¹; to stay exact the
/// sum is formed in `i64` and saturated, so the result is correct to the last bit for every input
/// but those two extreme corners.
#[inline]
pub fn cq15_mul_wide(a: CQ15, b: CQ15) -> Complex<i32> {
    let re = a.re.mul_wide(b.re) as i64 - a.im.mul_wide(b.im) as i64;
    let im = a.re.mul_wide(b.im) as i64 + a.im.mul_wide(b.re) as i64;
    Complex::new(sat_i32(re), sat_i32(im))
}

/// Complex product `a · conj(b)` of two Q15 values as Q30 in `i32` parts (see [`cq15_mul_wide`]).
#[inline]
pub fn cq15_mul_conj_wide(a: CQ15, b: CQ15) -> Complex<i32> {
    let re = a.re.mul_wide(b.re) as i64 + a.im.mul_wide(b.im) as i64;
    let im = a.im.mul_wide(b.re) as i64 - a.re.mul_wide(b.im) as i64;
    Complex::new(sat_i32(re), sat_i32(im))
}

/// Rounding, saturating complex Q15 product.
#[inline]
pub fn cq15_mul(a: CQ15, b: CQ15) -> CQ15 {
    let w = cq15_mul_wide(a, b);
    Complex::new(
        Q(sat_i16(round_shift_i32(w.re, 15))),
        Q(sat_i16(round_shift_i32(w.im, 15))),
    )
}

/// Saturates an `i64` to the `i32` range.
#[inline]
pub fn sat_i32(x: i64) -> i32 {
    x.clamp(i32::MIN as i64, i32::MAX as i64) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn q15_conversion_rounds_and_saturates() {
        assert_eq!(Q15::from_f32(0.5).0, 16384);
        assert_eq!(Q15::from_f32(1.0), Q15::MAX);
        assert_eq!(Q15::from_f32(-1.0), Q15::MIN);
        assert_eq!(Q15::from_f32(-3.0), Q15::MIN);
        assert_eq!(Q15::from_f32(f32::NAN), Q15::ZERO);
        // Half an LSB rounds away from zero.
        assert_eq!(Q15::from_f32(1.5 / 32768.0).0, 2);
        assert!((Q15::from_bits(12345).to_f32() - 12345.0 / 32768.0).abs() < 1e-9);
    }

    #[test]
    fn q15_roundtrip_error_is_at_most_half_an_lsb() {
        let mut x = -1.0f32;
        while x < 0.9999 {
            let e = (Q15::from_f32(x).to_f32() - x).abs();
            assert!(e <= 0.5 * Q15::LSB + 1e-9, "x = {x}, error {e}");
            x += 0.000_37;
        }
    }

    #[test]
    fn q15_multiply_rounds_and_only_minus_one_squared_saturates() {
        let half = Q15::from_f32(0.5);
        assert_eq!((half * half).0, 8192);
        assert_eq!(Q15::MIN * Q15::MIN, Q15::MAX);
        assert_eq!((Q15::MIN * Q15::MAX).0, -32767);
        // 3 LSB · 0.5 = 1.5 LSB rounds to 2.
        assert_eq!((Q15::from_bits(3) * half).0, 2);
        assert_eq!(-Q15::MIN, Q15::MAX);
        assert_eq!(Q15::MAX + Q15::MAX, Q15::MAX);
        assert_eq!(Q15::MIN - Q15::MAX, Q15::MIN);
    }

    #[test]
    fn q31_matches_q15_scaling() {
        assert_eq!(Q31::from_f32(0.5).0, 1 << 30);
        assert_eq!(Q31::from_f32(2.0), Q31::MAX);
        assert_eq!((Q31::from_f32(0.5) * Q31::from_f32(0.5)).0, 1 << 29);
    }

    #[test]
    fn complex_q15_product_matches_float_within_one_lsb() {
        let a = cq15_from_c32(Complex::new(0.3, -0.7));
        let b = cq15_from_c32(Complex::new(-0.45, 0.2));
        let p = cq15_to_c32(cq15_mul(a, b));
        let exact = cq15_to_c32(a) * cq15_to_c32(b);
        assert!((p - exact).norm() <= 1.5 * Q15::LSB);
        let pc = cq15_mul_conj_wide(a, b);
        let exact_c = cq15_to_c32(a) * cq15_to_c32(b).conj();
        assert!((pc.re as f32 / (1u32 << 30) as f32 - exact_c.re).abs() < 1e-6);
        assert!((pc.im as f32 / (1u32 << 30) as f32 - exact_c.im).abs() < 1e-6);
    }

    #[test]
    fn block_conversion_puts_the_peak_in_upper_half_without_saturating() {
        let src = [Complex::new(3.0f32, -0.5), Complex::new(0.1, 2.9)];
        let mut dst = [CQ15::default(); 2];
        let e = cq15_block_from_c32(&src, &mut dst).unwrap();
        assert_eq!(e, 2);
        assert_eq!(dst[0].re.0, 24576); // 3/4
        for (d, s) in dst.iter().zip(&src) {
            let back = cq15_to_c32(*d) * 4.0;
            assert!((back - s).norm() <= 4.0 * Q15::LSB);
        }
        // Exactly a power of two and just below: still no saturation.
        let e = cq15_block_from_c32(&[Complex::new(1.0, 0.0)], &mut dst[..1]).unwrap();
        assert_eq!((e, dst[0].re.0), (1, 16384));
        let e = cq15_block_from_c32(&[Complex::new(0.99999, 0.0)], &mut dst[..1]).unwrap();
        assert_eq!((e, dst[0].re.0), (1, 16384));
        assert_eq!(
            cq15_block_from_c32(&[Complex::new(0.0, 0.0)], &mut dst[..1]),
            Ok(0)
        );
        assert!(cq15_block_from_c32(&src, &mut dst[..1]).is_err());
        assert!(cq15_block_from_c32(&[Complex::new(f32::NAN, 0.0)], &mut dst[..1]).is_err());
    }

    #[test]
    fn round_shift_rounds_half_up() {
        assert_eq!(round_shift_i32(3, 1), 2);
        assert_eq!(round_shift_i32(-3, 1), -1);
        assert_eq!(round_shift_i32(5, 0), 5);
        assert_eq!(round_shift_i64(1 << 40, 10), 1 << 30);
    }

    /// `⌊x/2^s + ½⌋` for every shift: at or beyond the width everything rounds to 0 (the old
    /// code returned `x` for `s = 64` / `128`, where the shift amount wrapped).
    #[test]
    fn a_shift_at_or_beyond_the_width_rounds_to_zero() {
        assert_eq!(round_shift_i32(1000, 64), 0);
        assert_eq!(round_shift_i64(1000, 128), 0);
        for s in [32, 33, 63, 64, 65, 127, 128, 1000, u32::MAX] {
            for x in [i32::MIN, i32::MIN + 1, -1000, -1, 0, 1, 1000, i32::MAX] {
                assert_eq!(round_shift_i32(x, s), 0, "round_shift_i32({x}, {s})");
            }
        }
        for s in [64, 65, 127, 128, 129, 1000, u32::MAX] {
            for x in [i64::MIN, i64::MIN + 1, -1000, -1, 0, 1, 1000, i64::MAX] {
                assert_eq!(round_shift_i64(x, s), 0, "round_shift_i64({x}, {s})");
            }
        }
        // Just below the width the exact rounding still holds: −2³¹/2³¹ = −1, and half up.
        assert_eq!(round_shift_i32(i32::MIN, 31), -1);
        assert_eq!(round_shift_i32(i32::MAX, 31), 1);
        assert_eq!(round_shift_i32(1 << 30, 31), 1);
        assert_eq!(round_shift_i32(-(1 << 30), 31), 0);
        assert_eq!(round_shift_i64(i64::MIN, 63), -1);
        assert_eq!(round_shift_i64(i64::MAX, 63), 1);
        assert_eq!(round_shift_i64(i64::MAX, 0), i64::MAX);
        assert_eq!(round_shift_i64(i64::MIN, 0), i64::MIN);
        assert_eq!(round_shift_i32(i32::MIN, 0), i32::MIN);
    }

    /// Bit-identical to the previous formula `(x + 2^(s−1)) >> s` (widened) wherever that one was
    /// defined: every `s ≥ 1` below the width of the widened type, which for `i32` includes
    /// 32 … 63 (where it gives the 0 now returned without widening far).
    #[test]
    fn round_shift_matches_the_widened_formula_wherever_it_was_defined() {
        let mut g = crate::test_util::Lcg(0x9e37_79b9_7f4a_7c15);
        let mut next = || g.next_u64();
        for _ in 0..2000 {
            let x64 = next() as i64 >> (next() % 64);
            let x32 = x64 as i32;
            for s in 0..=130u32 {
                let want32 = match s {
                    0 => x32,
                    1..=63 => ((x32 as i64 + (1i64 << (s - 1))) >> s) as i32,
                    _ => 0,
                };
                assert_eq!(round_shift_i32(x32, s), want32, "{x32} >> {s}");
                let want64 = match s {
                    0 => x64,
                    1..=127 => ((x64 as i128 + (1i128 << (s - 1))) >> s) as i64,
                    _ => 0,
                };
                assert_eq!(round_shift_i64(x64, s), want64, "{x64} >> {s}");
            }
        }
    }
}
