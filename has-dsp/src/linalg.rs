//! Small dense complex linear algebra for the clutter cancellers: Hermitian positive-definite
//! solves by Cholesky factorisation (no explicit inverse), in `f32` or `f64`, on stack arrays.
//!
//! Matrices are `[[Complex<T>; M]; M]` with a compile-time capacity `M` and a run-time active size
//! `n ≤ M` (the top-left `n × n` block is used, the rest is ignored). Only the **lower triangle**
//! (`a[i][j]`, `j ≤ i`) of a Hermitian input is read; the factor `L` (with `A = L·Lᴴ`) overwrites
//! it. Nothing allocates.
//!
//! **Diagonal loading** is relative: `loading = ε` adds `ε · tr(A)/n` to every diagonal entry, so
//! the same ε means the same thing whatever the signal power (typical values 0 … 1e-3). It bounds
//! the condition number by about `(1 + ε)/ε` at the price of a bias of the same relative order.
//!
//! **Positive-definiteness test**: a pivot `d_i = a_ii − Σ_k |l_ik|²` must exceed
//! `n · ε_T · max_i a_ii` (ε_T the machine epsilon of `T`); below that the pivot is rounding noise
//! and the solve would return meaningless weights, so [`DspError::NotPositiveDefinite`] is returned.
//!
//! **Why `f64` exists next to `f32`.** The backward error of a Cholesky solve is `≈ n·ε_T·‖A‖`, so
//! the *cancellation* an ECA achieves with computed weights is limited to roughly `κ(A)·ε_T` of the
//! clutter power's amplitude (κ the condition number of `XᴴX`). A white reference gives κ ≈ 1–3 and
//! `f32` (ε ≈ 6·10⁻⁸) is plenty, but band-limited OFDM references (guard bands), short ECA-B batches
//! with several Doppler columns or closely spaced delays give κ of 10⁴–10⁶, where `f32` would cap
//! the cancellation at 20–40 dB. The cancellers therefore solve in `f64` (a few thousand flops per
//! batch, negligible next to forming the correlations); `f32` is kept for callers with
//! well-conditioned systems and single-precision-only FPUs.
//!
//! The helpers at the bottom quantise solved weights to `i32` mantissas with one shared exponent
//! (block floating point) for the fixed-point data paths.

// Index loops are the clearest way to write triangular matrix algorithms.
#![allow(clippy::needless_range_loop)]

use crate::error::DspError;
use num_complex::Complex;

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// The real scalar types the solver works in: `f32` and `f64`.
pub trait Real:
    sealed::Sealed
    + Copy
    + PartialOrd
    + core::ops::Add<Output = Self>
    + core::ops::Sub<Output = Self>
    + core::ops::Mul<Output = Self>
    + core::ops::Div<Output = Self>
    + core::ops::Neg<Output = Self>
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Machine epsilon.
    const EPSILON: Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Whether the value is finite.
    fn is_finite(self) -> bool;
    /// From a `usize` (rounded).
    fn from_usize(n: usize) -> Self;
    /// To `f32` (rounded), for error reports.
    fn to_f32(self) -> f32;
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const EPSILON: Self = f32::EPSILON;
    #[inline]
    fn sqrt(self) -> Self {
        libm::sqrtf(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline]
    fn from_usize(n: usize) -> Self {
        n as f32
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const EPSILON: Self = f64::EPSILON;
    #[inline]
    fn sqrt(self) -> Self {
        libm::sqrt(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
    #[inline]
    fn from_usize(n: usize) -> Self {
        n as f64
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self as f32
    }
}

// Complex helpers written on `Real` (num-complex's operators need `num_traits::Num`, which this
// crate does not depend on directly).
#[inline]
fn nsq<T: Real>(z: Complex<T>) -> T {
    z.re * z.re + z.im * z.im
}

/// `s − a·b`.
#[inline]
fn sub_mul<T: Real>(s: Complex<T>, a: Complex<T>, b: Complex<T>) -> Complex<T> {
    Complex::new(
        s.re - (a.re * b.re - a.im * b.im),
        s.im - (a.re * b.im + a.im * b.re),
    )
}

/// `s − a·conj(b)`.
#[inline]
fn sub_mul_conj<T: Real>(s: Complex<T>, a: Complex<T>, b: Complex<T>) -> Complex<T> {
    Complex::new(
        s.re - (a.re * b.re + a.im * b.im),
        s.im - (a.im * b.re - a.re * b.im),
    )
}

#[inline]
fn scale<T: Real>(z: Complex<T>, k: T) -> Complex<T> {
    Complex::new(z.re * k, z.im * k)
}

fn check_size<const M: usize>(n: usize) -> Result<(), DspError> {
    if n == 0 || n > M {
        Err(DspError::UnsupportedLength {
            what: "linalg.n (active size, 1..=M)",
            len: n,
        })
    } else {
        Ok(())
    }
}

/// Factors the Hermitian positive-definite top-left `n × n` block of `a` in place as `A = L·Lᴴ`
/// (lower triangle read, `L` written to the lower triangle; the strict upper triangle is left
/// untouched), after adding the relative diagonal loading `loading · tr(A)/n` (see the module
/// docs).
///
/// # Errors
/// * [`DspError::UnsupportedLength`] if `n` is 0 or exceeds `M`;
/// * [`DspError::OutOfRange`] if `loading` is negative or not finite;
/// * [`DspError::NonFinite`] if a diagonal entry is not finite;
/// * [`DspError::NotPositiveDefinite`] if a pivot is not above the rounding floor (singular,
///   indefinite or numerically rank-deficient matrix). `a` is then partly overwritten.
pub fn cholesky_in_place<T: Real, const M: usize>(
    a: &mut [[Complex<T>; M]; M],
    n: usize,
    loading: T,
) -> Result<(), DspError> {
    check_size::<M>(n)?;
    if !loading.is_finite() || loading < T::ZERO {
        return Err(DspError::OutOfRange {
            what: "linalg.loading",
            value: loading.to_f32(),
        });
    }
    let mut trace = T::ZERO;
    let mut max_diag = T::ZERO;
    for (i, row) in a.iter().enumerate().take(n) {
        let d = row[i].re;
        if !d.is_finite() {
            return Err(DspError::NonFinite {
                what: "linalg.a (diagonal)",
            });
        }
        trace = trace + d;
        if d > max_diag {
            max_diag = d;
        }
    }
    let add = loading * trace / T::from_usize(n);
    let floor = T::from_usize(n) * T::EPSILON * (max_diag + add);
    for i in 0..n {
        // Diagonal pivot.
        let mut d = a[i][i].re + add;
        for k in 0..i {
            d = d - nsq(a[i][k]);
        }
        if d <= floor || !d.is_finite() {
            return Err(DspError::NotPositiveDefinite { what: "linalg.a" });
        }
        let lii = d.sqrt();
        a[i][i] = Complex::new(lii, T::ZERO);
        let inv = T::ONE / lii;
        // Column i below the diagonal: l_ji = (a_ji − Σ_k l_jk·conj(l_ik)) / l_ii.
        for j in i + 1..n {
            let mut s = a[j][i];
            for k in 0..i {
                s = sub_mul_conj(s, a[j][k], a[i][k]);
            }
            a[j][i] = scale(s, inv);
        }
    }
    Ok(())
}

/// Solves `L·Lᴴ·x = b` in place (`b` becomes `x`) for a factor from [`cholesky_in_place`]:
/// forward substitution with `L`, back substitution with `Lᴴ`. Only the first `n` entries of `b`
/// are used.
///
/// # Errors
/// [`DspError::UnsupportedLength`] if `n` is 0 or exceeds `M`; [`DspError::NotPositiveDefinite`]
/// if a diagonal entry of `L` is not positive (not a factor).
pub fn cholesky_solve<T: Real, const M: usize>(
    l: &[[Complex<T>; M]; M],
    n: usize,
    b: &mut [Complex<T>; M],
) -> Result<(), DspError> {
    check_size::<M>(n)?;
    for (i, row) in l.iter().enumerate().take(n) {
        if row[i].re <= T::ZERO || !row[i].re.is_finite() {
            return Err(DspError::NotPositiveDefinite { what: "linalg.l" });
        }
    }
    // L y = b.
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s = sub_mul(s, l[i][k], b[k]);
        }
        b[i] = scale(s, T::ONE / l[i][i].re);
    }
    // Lᴴ x = y: (Lᴴ)_ik = conj(l_ki).
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s = sub_mul_conj(s, b[k], l[k][i]);
        }
        b[i] = scale(s, T::ONE / l[i][i].re);
    }
    Ok(())
}

/// Solves the Hermitian positive-definite system `A·x = b` (top-left `n × n` block, lower triangle
/// read) by Cholesky with relative diagonal loading; `a` is overwritten by the factor and `b` by
/// the solution. See [`cholesky_in_place`] for the errors; additionally
/// [`DspError::NonFinite`] if the solution is not finite.
pub fn solve_hpd<T: Real, const M: usize>(
    a: &mut [[Complex<T>; M]; M],
    n: usize,
    b: &mut [Complex<T>; M],
    loading: T,
) -> Result<(), DspError> {
    cholesky_in_place(a, n, loading)?;
    cholesky_solve(a, n, b)?;
    if b.iter()
        .take(n)
        .all(|z| z.re.is_finite() && z.im.is_finite())
    {
        Ok(())
    } else {
        Err(DspError::NonFinite {
            what: "linalg.b (right-hand side or solution)",
        })
    }
}

/// Complex weights quantised to `i32` mantissas sharing one exponent: weight `m` is
/// `mant[m] · 2^−frac_bits`. Used by the fixed-point data paths to apply solved weights to Q15
/// samples with integer multiply-accumulates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockWeights<const M: usize> {
    /// Mantissas (real and imaginary parts).
    pub mant: [Complex<i32>; M],
    /// Fractional bits of every mantissa, 0..=[`BlockWeights::MAX_FRAC_BITS`].
    pub frac_bits: u32,
}

impl<const M: usize> BlockWeights<M> {
    /// The largest number of fractional bits used (weights below 1 in magnitude get all of them).
    pub const MAX_FRAC_BITS: u32 = 30;

    /// Quantises the first `n` weights with rounding to nearest: the exponent is the largest
    /// `frac_bits ≤ 30` for which every part satisfies `|w|·2^frac_bits < 2³⁰`, so each mantissa
    /// part has at least one bit of headroom and the relative quantisation error of the largest
    /// weight is below 2⁻²⁹. Entries beyond `n` are zero.
    ///
    /// # Errors
    /// [`DspError::NonFinite`] for a non-finite weight; [`DspError::OutOfRange`] if a weight part
    /// reaches 2³⁰ (then even `frac_bits = 0` cannot hold it; such weights only come from a
    /// near-singular system).
    pub fn quantize(w: &[Complex<f64>], n: usize) -> Result<Self, DspError> {
        if n > M || n > w.len() {
            return Err(DspError::UnsupportedLength {
                what: "weights.n",
                len: n,
            });
        }
        let mut max = 0.0f64;
        for z in &w[..n] {
            if !(z.re.is_finite() && z.im.is_finite()) {
                return Err(DspError::NonFinite { what: "weights" });
            }
            max = max.max(z.re.abs()).max(z.im.abs());
        }
        let limit = (1u64 << 30) as f64;
        let mut frac_bits = Self::MAX_FRAC_BITS;
        // Lower the exponent until the largest part (after rounding) fits below 2^30.
        while frac_bits > 0 && libm::round(max * (1u64 << frac_bits) as f64) >= limit {
            frac_bits -= 1;
        }
        if libm::round(max * (1u64 << frac_bits) as f64) >= limit {
            return Err(DspError::OutOfRange {
                what: "weights (magnitude ≥ 2^30)",
                value: max as f32,
            });
        }
        let scale = (1u64 << frac_bits) as f64;
        let mut mant = [Complex::new(0i32, 0i32); M];
        for (m, z) in mant.iter_mut().zip(&w[..n]) {
            *m = Complex::new(
                libm::round(z.re * scale) as i32,
                libm::round(z.im * scale) as i32,
            );
        }
        Ok(Self { mant, frac_bits })
    }
}

/// The longest correlation (number of summed Q15 × Q15 complex products) an `i64` accumulator
/// holds without overflow: each part of `conj(a)·b` is a sum of two Q30 products, so at most
/// 2·(2¹⁵)² = 2³¹ in magnitude, and 2³¹ terms sum to at most 2⁶² < 2⁶³.
pub const MAX_Q15_CORR_LEN: usize = 1 << 31;

/// Chunk length of the `f32` correlations: products are summed in `f32` over this many samples,
/// chunks in `f64`, so the rounding error grows with the chunk length, not the full length.
pub(crate) const F32_CHUNK: usize = 64;

/// `Σ conj(a[i])·b[i]` over the common length, summed in `f32` chunks of [`F32_CHUNK`] and in
/// `f64` across chunks.
#[inline]
pub(crate) fn dot_conj_c32(a: &[Complex<f32>], b: &[Complex<f32>]) -> Complex<f64> {
    let mut total = Complex::new(0.0f64, 0.0f64);
    for (ca, cb) in a.chunks(F32_CHUNK).zip(b.chunks(F32_CHUNK)) {
        let mut s = Complex::new(0.0f32, 0.0f32);
        for (x, y) in ca.iter().zip(cb) {
            s += x.conj() * y;
        }
        total += Complex::new(s.re as f64, s.im as f64);
    }
    total
}

/// Exact `conj(a)·b` of two Q15 samples as Q30 parts in `i64` (no saturation, unlike
/// [`crate::fixed::cq15_mul_conj_wide`]).
#[inline]
pub(crate) fn q15_conj_mul_i64(a: crate::fixed::CQ15, b: crate::fixed::CQ15) -> Complex<i64> {
    let (ar, ai) = (a.re.0 as i64, a.im.0 as i64);
    let (br, bi) = (b.re.0 as i64, b.im.0 as i64);
    Complex::new(ar * br + ai * bi, ar * bi - ai * br)
}

/// Exact `Σ conj(a[i])·b[i]` of Q15 samples as Q30 in `i64`; the caller guarantees the length is at
/// most [`MAX_Q15_CORR_LEN`].
#[inline]
pub(crate) fn dot_conj_q15(a: &[crate::fixed::CQ15], b: &[crate::fixed::CQ15]) -> Complex<i64> {
    let mut s = Complex::new(0i64, 0i64);
    for (x, y) in a.iter().zip(b) {
        s += q15_conj_mul_i64(*x, *y);
    }
    s
}

/// A Q30 `i64` correlation as `f64` in units of Q15² (the value the same sum has in float).
#[inline]
pub(crate) fn q30_to_f64(z: Complex<i64>) -> Complex<f64> {
    const S: f64 = 1.0 / (1u64 << 30) as f64;
    Complex::new(z.re as f64 * S, z.im as f64 * S)
}

/// `y − Σ_m w_m·b_m` for one Q15 sample: `y` is promoted to the weights' format
/// (`2^frac_bits`), the exact products `mant·b` (each part < 2³⁰·2¹⁵·2 = 2⁴⁶) are subtracted in
/// `i64` (M ≤ 2¹⁶ terms cannot overflow), and the result is rounded to nearest (half up) and
/// saturated back to Q15.
#[inline]
pub(crate) fn q15_sub_weighted(
    y: crate::fixed::CQ15,
    w: &[Complex<i32>],
    b: impl Iterator<Item = crate::fixed::CQ15>,
    frac_bits: u32,
) -> crate::fixed::CQ15 {
    use crate::fixed::{round_shift_i64, Q15};
    let mut re = (y.re.0 as i64) << frac_bits;
    let mut im = (y.im.0 as i64) << frac_bits;
    for (wm, bm) in w.iter().zip(b) {
        let (wr, wi) = (wm.re as i64, wm.im as i64);
        let (br, bi) = (bm.re.0 as i64, bm.im.0 as i64);
        re -= wr * br - wi * bi;
        im -= wr * bi + wi * br;
    }
    let sat = |x: i64| -> Q15 {
        Q15::from_bits(round_shift_i64(x, frac_bits).clamp(i16::MIN as i64, i16::MAX as i64) as i16)
    };
    Complex::new(sat(re), sat(im))
}

#[cfg(test)]
mod tests {
    use super::*;

    type C64 = Complex<f64>;

    /// A fixed, well-conditioned Hermitian positive-definite 4×4 matrix (B·Bᴴ + I).
    fn hpd4() -> [[C64; 4]; 4] {
        let b = [
            [C64::new(1.0, 0.5), C64::new(-0.3, 0.2), C64::new(0.1, 0.0)],
            [C64::new(0.2, -0.7), C64::new(0.9, 0.1), C64::new(-0.4, 0.3)],
            [C64::new(-0.5, 0.0), C64::new(0.3, 0.6), C64::new(0.8, -0.2)],
            [C64::new(0.0, 0.4), C64::new(-0.6, -0.1), C64::new(0.2, 0.2)],
        ];
        let mut a = [[C64::new(0.0, 0.0); 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                let mut s = C64::new(if i == j { 1.0 } else { 0.0 }, 0.0);
                for k in 0..3 {
                    s += b[i][k] * b[j][k].conj();
                }
                a[i][j] = s;
            }
        }
        a
    }

    #[test]
    fn cholesky_solve_matches_the_system_to_rounding() {
        let a = hpd4();
        let x_true = [
            C64::new(1.0, -2.0),
            C64::new(0.5, 0.25),
            C64::new(-1.5, 0.0),
            C64::new(0.0, 3.0),
        ];
        let mut b = [C64::new(0.0, 0.0); 4];
        for i in 0..4 {
            for j in 0..4 {
                b[i] += a[i][j] * x_true[j];
            }
        }
        let mut f = a;
        solve_hpd(&mut f, 4, &mut b, 0.0).unwrap();
        // κ(A) is below 10 here, so the f64 forward error is a few hundred ε at most.
        for i in 0..4 {
            assert!((b[i] - x_true[i]).norm() < 1e-12, "{i}: {:?}", b[i]);
        }
        // L·Lᴴ reproduces A.
        for i in 0..4 {
            for j in 0..=i {
                let mut s = C64::new(0.0, 0.0);
                for k in 0..=j {
                    s += f[i][k] * f[j][k].conj();
                }
                assert!((s - a[i][j]).norm() < 1e-12);
            }
        }
    }

    #[test]
    fn f32_solve_agrees_with_f64_within_condition_times_epsilon() {
        let a = hpd4();
        let mut a32 = [[Complex::<f32>::new(0.0, 0.0); 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                a32[i][j] = Complex::new(a[i][j].re as f32, a[i][j].im as f32);
            }
        }
        let mut b = [C64::new(1.0, 0.0); 4];
        let mut b32 = [Complex::<f32>::new(1.0, 0.0); 4];
        let mut f = a;
        solve_hpd(&mut f, 4, &mut b, 0.0).unwrap();
        solve_hpd(&mut a32, 4, &mut b32, 0.0).unwrap();
        // Relative forward error ≤ c·n·κ·ε_f32 with κ < 10, n = 4: < 1e-5 with margin.
        for i in 0..4 {
            let d = Complex::new(b32[i].re as f64, b32[i].im as f64) - b[i];
            assert!(d.norm() < 1e-5 * b[i].norm().max(1.0), "{i}");
        }
    }

    #[test]
    fn active_size_smaller_than_capacity_ignores_the_rest() {
        let mut a = [[C64::new(f64::NAN, f64::NAN); 8]; 8];
        a[0][0] = C64::new(4.0, 0.0);
        a[1][0] = C64::new(2.0, 2.0);
        a[1][1] = C64::new(6.0, 0.0);
        let mut b = [C64::new(f64::NAN, 0.0); 8];
        b[0] = C64::new(4.0, 0.0);
        b[1] = C64::new(2.0, -2.0);
        solve_hpd(&mut a, 2, &mut b, 0.0).unwrap();
        // A = [[4, 2−2j], [2+2j, 6]] (lower triangle given): check A·x = b directly.
        let a00 = C64::new(4.0, 0.0);
        let a01 = C64::new(2.0, -2.0);
        let a10 = C64::new(2.0, 2.0);
        let a11 = C64::new(6.0, 0.0);
        let r0 = a00 * b[0] + a01 * b[1] - C64::new(4.0, 0.0);
        let r1 = a10 * b[0] + a11 * b[1] - C64::new(2.0, -2.0);
        assert!(r0.norm() < 1e-12 && r1.norm() < 1e-12);
    }

    #[test]
    fn singular_or_indefinite_matrix_is_not_positive_definite() {
        // Rank one: [1 1; 1 1].
        let mut a = [[C64::new(1.0, 0.0); 2]; 2];
        let mut b = [C64::new(1.0, 0.0); 2];
        assert_eq!(
            solve_hpd(&mut a, 2, &mut b, 0.0),
            Err(DspError::NotPositiveDefinite { what: "linalg.a" })
        );
        // Diagonal loading makes it solvable.
        let mut a = [[C64::new(1.0, 0.0); 2]; 2];
        let mut b = [C64::new(1.0, 0.0); 2];
        solve_hpd(&mut a, 2, &mut b, 1e-3).unwrap();
        // Indefinite.
        let mut a = [[C64::new(0.0, 0.0); 2]; 2];
        a[0][0] = C64::new(1.0, 0.0);
        a[1][1] = C64::new(-1.0, 0.0);
        assert!(matches!(
            solve_hpd(&mut a, 2, &mut b, 0.0),
            Err(DspError::NotPositiveDefinite { .. })
        ));
    }

    #[test]
    fn bad_sizes_loading_and_nan_are_errors() {
        let mut a = [[C64::new(1.0, 0.0); 2]; 2];
        let mut b = [C64::new(1.0, 0.0); 2];
        assert!(matches!(
            solve_hpd(&mut a, 3, &mut b, 0.0),
            Err(DspError::UnsupportedLength { len: 3, .. })
        ));
        assert!(matches!(
            solve_hpd(&mut a, 0, &mut b, 0.0),
            Err(DspError::UnsupportedLength { len: 0, .. })
        ));
        assert!(matches!(
            cholesky_in_place(&mut a, 2, -1.0),
            Err(DspError::OutOfRange { .. })
        ));
        assert!(matches!(
            cholesky_solve(&[[C64::new(0.0, 0.0); 2]; 2], 2, &mut b),
            Err(DspError::NotPositiveDefinite { .. })
        ));
        let mut a = [[C64::new(1.0, 0.0); 1]; 1];
        a[0][0] = C64::new(f64::NAN, 0.0);
        let mut b = [C64::new(1.0, 0.0); 1];
        assert!(matches!(
            solve_hpd(&mut a, 1, &mut b, 0.0),
            Err(DspError::NonFinite { .. })
        ));
        let mut a = [[C64::new(1.0, 0.0); 1]; 1];
        let mut b = [C64::new(f64::INFINITY, 0.0); 1];
        assert!(matches!(
            solve_hpd(&mut a, 1, &mut b, 0.0),
            Err(DspError::NonFinite { .. })
        ));
    }

    #[test]
    fn block_weights_round_and_share_one_exponent() {
        let w = [C64::new(0.25, -0.5), C64::new(3.0, 0.0)];
        let q = BlockWeights::<4>::quantize(&w, 2).unwrap();
        // 3·2^28 < 2^30 ≤ 3·2^29, so frac_bits = 28.
        assert_eq!(q.frac_bits, 28);
        assert_eq!(q.mant[1].re, 3 << 28);
        assert_eq!(q.mant[0].im, -(1 << 27));
        assert_eq!(q.mant[2], Complex::new(0, 0));
        let small = [C64::new(1e-3, 0.0)];
        assert_eq!(
            BlockWeights::<1>::quantize(&small, 1).unwrap().frac_bits,
            30
        );
        assert!(matches!(
            BlockWeights::<1>::quantize(&[C64::new(2e9, 0.0)], 1),
            Err(DspError::OutOfRange { .. })
        ));
        assert!(matches!(
            BlockWeights::<1>::quantize(&[C64::new(f64::NAN, 0.0)], 1),
            Err(DspError::NonFinite { .. })
        ));
        assert!(matches!(
            BlockWeights::<1>::quantize(&w, 2),
            Err(DspError::UnsupportedLength { .. })
        ));
    }
}
