//! Complex FFTs for N = 64 … 4096 (powers of two): `f32` through microfft, and a Q15 radix-2 FFT
//! with per-stage scaling and a block exponent.
//!
//! **Sign and scaling conventions.** The forward transform is `X[k] = Σₙ x[n]·e^{−j2πkn/N}`
//! (no scaling). The inverse is `x[n] = (1/N)·Σₖ X[k]·e^{+j2πkn/N}` for `f32` ([`ifft_c32`],
//! microfft's `ifft_N`, which already divides by N), so `ifft_c32(fft_c32(x)) = x`.
//!
//! The Q15 transforms ([`fft_q15`], [`ifft_q15`]) return a **block exponent** `e`: the output
//! `q[k]` (Q15 values, in \[−1, 1)) satisfies `q[k]·2^e = ` the *unscaled* sum (`Σₙ x[n]·e^{∓…}`,
//! no `1/N` in either direction). With [`Q15Scaling::Always`] every one of the `log₂N` radix-2
//! stages halves, so `e = log₂N` and the forward output is `DFT/N` — **the same scaling as
//! CMSIS-DSP's `arm_cfft_q15`** (whose output for N = 1024 is documented as "11.5 format", i.e.
//! DFT/N read as Q15) — and the inverse output is exactly the normalised inverse `(1/N)·Σ`, the
//! convention of [`ifft_c32`]. With [`Q15Scaling::Block`] (block floating point) a stage halves
//! only when its input could overflow, so `e ≤ log₂N` and small or sparse inputs (e.g. zero-padded
//! spectra) keep their precision; multiply by `2^(e − log₂N)` to compare with the `f32` inverse.
//!
//! **Q15 arithmetic.** Decimation in time, in place: a bit-reversal permutation, then stages of
//! butterflies `a ± w·b`. The twiddle product `w·b` is exact in integers (`w` in Q15 with
//! `1.0 = 32768` representable, from [`crate::phase::cos_sin_q15`]: the crate's one quarter-wave
//! sine table, 8192 steps per cycle, built by a `const fn` at compile time — no run-time
//! `sin`/`cos`); `a·2¹⁵ ± w·b` is formed exactly in `i64` and brought back with **one rounding**
//! (to nearest, ties up) by `2^(15+s)`, `s` the stage's shift, then **saturated** to `i16`.
//! Twiddle `1` and `−j` are exact, so the only errors are one rounding per output component per
//! stage and the twiddles' own ±½ LSB.
//!
//! **When a block-floating-point stage shifts.** With `R` the largest magnitude `|z|` in the
//! buffer, a butterfly output obeys `|a ± w·b| ≤ 2R`. So a stage does not shift if `R ≤ 16383`
//! (no output can exceed 32767), and otherwise shifts by one; the first stage shifts by two if
//! `R > 32767` (only inputs can be that large: complex corners reach `|z| = 2¹⁵·√2`). A shifted
//! stage maps `R` to at most `R·(1 + 2⁻¹⁵) + 0.71` (twiddle and rounding excess), so a component
//! can meet the saturation clamp only in a worst-case phase alignment, and then by at most 1 LSB.
//! Consequence used by the tests: for inputs with `|z| ≤ 1`, `Block` never has a larger running
//! exponent than `Always`, hence never more absolute rounding noise. With `Always`, inputs with
//! `|z| > 1 − 2⁻¹⁵` can saturate (by at most a few LSB) exactly as in CMSIS.
//!
//! **Accuracy** (derived in `tests/tests/fft_range_fixed_vs_float.rs`): with `Always` each stage
//! adds at most 1/8 LSB² of rounding noise per component, halved by every later stage, so the
//! output noise is below ½ LSB² per complex bin; white input with components uniform in
//! \[−½, ½) (−6 dBFS peak) at N = 1024 gives SQNR ≥ 55.4 dB. `Block` is never worse.

use crate::error::DspError;
use crate::fixed::{CQ15, Q};
use crate::phase::{cos_sin_q15, PHASE_STEPS};
use num_complex::Complex;

/// `f32` complex sample (microfft's and num-complex's type).
pub type Complex32 = Complex<f32>;

/// Smallest supported transform length.
pub const MIN_FFT_LEN: usize = 64;
/// Largest supported transform length (microfft's enabled `size-4096` feature; the Q15 twiddles
/// come from [`crate::phase::SIN_Q15`], whose circle has a multiple of this many steps).
pub const MAX_FFT_LEN: usize = 4096;

/// `log₂ N` if `len` is a supported transform length (a power of two in
/// [`MIN_FFT_LEN`]`..=`[`MAX_FFT_LEN`]).
///
/// # Errors
/// [`DspError::UnsupportedLength`] naming `what` otherwise.
#[inline]
pub fn check_fft_len(what: &'static str, len: usize) -> Result<u32, DspError> {
    if len.is_power_of_two() && (MIN_FFT_LEN..=MAX_FFT_LEN).contains(&len) {
        Ok(len.trailing_zeros())
    } else {
        Err(unsupported(what, len))
    }
}

#[cold]
#[inline(never)]
fn unsupported(what: &'static str, len: usize) -> DspError {
    DspError::UnsupportedLength { what, len }
}

macro_rules! dispatch_microfft {
    ($buf:expr, $what:literal, $($n:literal => $f:path),* $(,)?) => {
        match $buf.len() {
            $(
                $n => {
                    let arr: &mut [Complex32; $n] =
                        $buf.try_into().map_err(|_| unsupported($what, $n))?;
                    let _ = $f(arr);
                    Ok(())
                }
            )*
            len => Err(unsupported($what, len)),
        }
    };
}

/// In-place forward FFT `X[k] = Σₙ x[n]·e^{−j2πkn/N}` (unscaled) of `buf`, N = 64 … 4096.
///
/// # Errors
/// [`DspError::UnsupportedLength`] (`"fft buffer"`) unless `buf.len()` is a power of two in
/// 64 … 4096; the buffer is then untouched.
pub fn fft_c32(buf: &mut [Complex32]) -> Result<(), DspError> {
    use microfft::complex::*;
    dispatch_microfft!(buf, "fft buffer",
        64 => cfft_64, 128 => cfft_128, 256 => cfft_256, 512 => cfft_512,
        1024 => cfft_1024, 2048 => cfft_2048, 4096 => cfft_4096)
}

/// In-place inverse FFT `x[n] = (1/N)·Σₖ X[k]·e^{+j2πkn/N}` of `buf` (divided by N, so it undoes
/// [`fft_c32`]), N = 64 … 4096.
///
/// # Errors
/// [`DspError::UnsupportedLength`] (`"ifft buffer"`) as [`fft_c32`].
pub fn ifft_c32(buf: &mut [Complex32]) -> Result<(), DspError> {
    use microfft::inverse::*;
    dispatch_microfft!(buf, "ifft buffer",
        64 => ifft_64, 128 => ifft_128, 256 => ifft_256, 512 => ifft_512,
        1024 => ifft_1024, 2048 => ifft_2048, 4096 => ifft_4096)
}

/// How the Q15 FFT keeps its butterflies from overflowing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Q15Scaling {
    /// Halve at every stage (exponent `log₂N`, output `DFT/N` like CMSIS `arm_cfft_q15`).
    Always,
    /// Block floating point: shift a stage only when its input could overflow (see module docs).
    #[default]
    Block,
}

// Every twiddle `e^{∓j2πk/N}`, N ≤ MAX_FFT_LEN, is a step of the shared sine table.
const _: () = assert!((PHASE_STEPS as usize).is_multiple_of(MAX_FFT_LEN));

/// Shift a block-floating-point stage needs given the buffer's largest `|z|²` (module docs).
/// Only the first stage may shift by two (its input may have `|z|` up to `2¹⁵·√2`).
#[inline]
fn block_shift(max_mag_sq: u32, first: bool) -> u32 {
    const NO_SHIFT: u32 = 16383 * 16383;
    const ONE_SHIFT: u32 = 32767 * 32767;
    if max_mag_sq <= NO_SHIFT {
        0
    } else if !first || max_mag_sq <= ONE_SHIFT {
        1
    } else {
        2
    }
}

#[inline(always)]
fn mag_sq(z: CQ15) -> u32 {
    let (re, im) = (z.re.0 as i32, z.im.0 as i32);
    (re * re) as u32 + (im * im) as u32
}

/// `sat(round((a·2¹⁵ + t) / 2^(15+s)))`.
#[inline(always)]
fn round_sat(a: i16, t: i64, s: u32) -> i16 {
    let sh = 15 + s;
    let v = (((a as i64) << 15) + t + (1i64 << (sh - 1))) >> sh;
    v.clamp(i16::MIN as i64, i16::MAX as i64) as i16
}

/// One butterfly `a, b ← a + w·b, a − w·b` with twiddle `(c, wi)` (Q15, `1.0 = 32768`), shift
/// `s`; returns the larger output `|z|²` when `TRACK` (else 0).
#[inline(always)]
fn butterfly<const TRACK: bool>(a: &mut CQ15, b: &mut CQ15, c: i32, wi: i32, s: u32) -> u32 {
    let (br, bi) = (b.re.0 as i64, b.im.0 as i64);
    let tr = c as i64 * br - wi as i64 * bi;
    let ti = c as i64 * bi + wi as i64 * br;
    let (ar, ai) = (a.re.0, a.im.0);
    let top = Complex::new(Q(round_sat(ar, tr, s)), Q(round_sat(ai, ti, s)));
    let bot = Complex::new(Q(round_sat(ar, -tr, s)), Q(round_sat(ai, -ti, s)));
    *a = top;
    *b = bot;
    if TRACK {
        mag_sq(top).max(mag_sq(bot))
    } else {
        0
    }
}

/// One radix-2 stage over butterflies of span `half`, with shift `s`; returns the largest output
/// `|z|²` when `TRACK` (else 0). The twiddle loop is outermost so each twiddle is read once per
/// stage.
#[inline(always)]
fn stage<const INVERSE: bool, const TRACK: bool>(buf: &mut [CQ15], half: usize, s: u32) -> u32 {
    // Twiddle k of a span-`half` stage is e^{∓j2πk/(2·half)}: phase step k·PHASE_STEPS/(2·half).
    let step = PHASE_STEPS as usize / (2 * half);
    let mut max = 0u32;
    for k in 0..half {
        // k·step < PHASE_STEPS/2: the mask changes nothing but tells the compiler the twiddle is
        // in the upper half-plane, which drops two of the table's quadrant selects (measured: the
        // Q15 FFT-1024 about 3 % faster).
        let (c, sn) = cos_sin_q15((k * step) as u32 & (PHASE_STEPS / 2 - 1));
        // Forward twiddle e^{−jθ} = c − j·sn; inverse e^{+jθ} = c + j·sn.
        let wi = if INVERSE { sn } else { -sn };
        for chunk in buf.chunks_exact_mut(2 * half) {
            let (lo, hi) = chunk.split_at_mut(half);
            if let (Some(a), Some(b)) = (lo.get_mut(k), hi.get_mut(k)) {
                max = max.max(butterfly::<TRACK>(a, b, c, wi, s));
            }
        }
    }
    max
}

fn radix2_q15<const INVERSE: bool>(buf: &mut [CQ15], log2n: u32, scaling: Q15Scaling) -> i32 {
    let n = buf.len();
    let mut max = 0u32;
    for i in 0..n {
        let j = i.reverse_bits() >> (usize::BITS - log2n);
        if j > i {
            buf.swap(i, j);
        }
        if scaling == Q15Scaling::Block {
            max = max.max(mag_sq(buf[i]));
        }
    }
    let mut exponent = 0i32;
    let mut half = 1;
    while half < n {
        match scaling {
            Q15Scaling::Always => {
                stage::<INVERSE, false>(buf, half, 1);
                exponent += 1;
            }
            Q15Scaling::Block => {
                let s = block_shift(max, half == 1);
                max = stage::<INVERSE, true>(buf, half, s);
                exponent += s as i32;
            }
        }
        half *= 2;
    }
    exponent
}

/// In-place Q15 forward FFT; returns the block exponent `e` with `q[k]·2^e = Σₙ x[n]·e^{−j2πkn/N}`
/// (see module docs; `Always` gives `e = log₂N`, CMSIS's DFT/N).
///
/// # Errors
/// [`DspError::UnsupportedLength`] (`"fft buffer"`) unless `buf.len()` is a power of two in
/// 64 … 4096; the buffer is then untouched.
pub fn fft_q15(buf: &mut [CQ15], scaling: Q15Scaling) -> Result<i32, DspError> {
    let log2n = check_fft_len("fft buffer", buf.len())?;
    Ok(radix2_q15::<false>(buf, log2n, scaling))
}

/// In-place Q15 inverse FFT; returns the block exponent `e` with
/// `q[n]·2^e = Σₖ X[k]·e^{+j2πkn/N}` (unscaled; `Always` gives `e = log₂N`, i.e. the normalised
/// inverse `(1/N)·Σ` of [`ifft_c32`]).
///
/// # Errors
/// [`DspError::UnsupportedLength`] (`"ifft buffer"`) as [`fft_q15`].
pub fn ifft_q15(buf: &mut [CQ15], scaling: Q15Scaling) -> Result<i32, DspError> {
    let log2n = check_fft_len("ifft buffer", buf.len())?;
    Ok(radix2_q15::<true>(buf, log2n, scaling))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed::{cq15_from_c32, cq15_to_c32};

    /// Deterministic xorshift generator (fixed seed) for test data.
    struct XorShift(u64);
    impl XorShift {
        fn next_f64(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        /// Uniform in [−a, a).
        fn sym(&mut self, a: f64) -> f64 {
            a * (2.0 * self.next_f64() - 1.0)
        }
    }

    fn naive_dft(x: &[Complex<f64>], sign: f64) -> Vec<Complex<f64>> {
        let n = x.len();
        let tw: Vec<Complex<f64>> = (0..n)
            .map(|i| {
                let ph = sign * 2.0 * core::f64::consts::PI * i as f64 / n as f64;
                Complex::new(ph.cos(), ph.sin())
            })
            .collect();
        (0..n)
            .map(|k| x.iter().enumerate().map(|(i, v)| v * tw[(i * k) % n]).sum())
            .collect()
    }

    /// f32 FFT against an f64 naive DFT. microfft's radix-2 error grows like ε·log₂N·‖x‖ per bin
    /// (rms); with ε = 6e-8, N ≤ 4096 and |x| ≤ 1 the rms bin error is ≲ 12·6e-8·√N and the
    /// relative rms error ≲ 1e-6. Asserting 1e-5 relative (rms over bins) leaves a factor 10 for
    /// twiddle errors of microfft's f32 tables.
    #[test]
    fn f32_fft_and_ifft_match_naive_dft() {
        let mut rng = XorShift(0x5eed_1234_abcd_0001);
        for n in [64usize, 128, 256, 512, 1024, 2048] {
            let x64: Vec<Complex<f64>> = (0..n)
                .map(|_| Complex::new(rng.sym(1.0), rng.sym(1.0)))
                .collect();
            let mut buf: Vec<Complex32> = x64
                .iter()
                .map(|z| Complex32::new(z.re as f32, z.im as f32))
                .collect();
            let x64: Vec<Complex<f64>> = buf
                .iter()
                .map(|z| Complex::new(z.re as f64, z.im as f64))
                .collect();
            fft_c32(&mut buf).unwrap();
            let want = naive_dft(&x64, -1.0);
            let rel = rel_rms(&buf, &want);
            assert!(rel < 1e-5, "fft n = {n}: relative rms error {rel}");
            // Inverse of the exact spectrum returns x (divided by N).
            let mut spec: Vec<Complex32> = want
                .iter()
                .map(|z| Complex32::new(z.re as f32, z.im as f32))
                .collect();
            ifft_c32(&mut spec).unwrap();
            let rel = rel_rms(&spec, &x64);
            assert!(rel < 1e-5, "ifft n = {n}: relative rms error {rel}");
        }
    }

    fn rel_rms(got: &[Complex32], want: &[Complex<f64>]) -> f64 {
        let mut err = 0.0;
        let mut sig = 0.0;
        for (g, w) in got.iter().zip(want) {
            err += (Complex::new(g.re as f64, g.im as f64) - w).norm_sqr();
            sig += w.norm_sqr();
        }
        (err / sig).sqrt()
    }

    #[test]
    fn f32_fft_of_unit_impulse_is_flat_and_sign_convention_holds() {
        let n = 256;
        let mut buf = std::vec![Complex32::new(0.0, 0.0); n];
        buf[1] = Complex32::new(1.0, 0.0);
        fft_c32(&mut buf).unwrap();
        // x[n] = δ[n−1] → X[k] = e^{−j2πk/N}.
        let ph = -2.0 * core::f32::consts::PI * 3.0 / n as f32;
        assert!((buf[3] - Complex32::new(ph.cos(), ph.sin())).norm() < 1e-5);
    }

    #[test]
    fn unsupported_lengths_are_errors_not_panics() {
        for len in [0usize, 1, 32, 100, 8192] {
            let mut b = std::vec![Complex32::new(1.0, 0.0); len];
            assert!(matches!(
                fft_c32(&mut b),
                Err(DspError::UnsupportedLength { what: "fft buffer", len: l }) if l == len
            ));
            assert!(matches!(
                ifft_c32(&mut b),
                Err(DspError::UnsupportedLength {
                    what: "ifft buffer",
                    ..
                })
            ));
            let mut q = std::vec![CQ15::default(); len];
            assert!(fft_q15(&mut q, Q15Scaling::Block).is_err());
            assert!(ifft_q15(&mut q, Q15Scaling::Always).is_err());
        }
    }

    #[test]
    fn q15_always_scaling_returns_log2n_and_matches_dft_over_n() {
        let mut rng = XorShift(42);
        for n in [64usize, 256, 1024, 4096] {
            let x: Vec<CQ15> = (0..n)
                .map(|_| cq15_from_c32(Complex32::new(rng.sym(0.5) as f32, rng.sym(0.5) as f32)))
                .collect();
            let xf: Vec<Complex<f64>> = x
                .iter()
                .map(|z| {
                    let c = cq15_to_c32(*z);
                    Complex::new(c.re as f64, c.im as f64)
                })
                .collect();
            for inverse in [false, true] {
                let mut q = x.clone();
                let e = if inverse {
                    ifft_q15(&mut q, Q15Scaling::Always).unwrap()
                } else {
                    fft_q15(&mut q, Q15Scaling::Always).unwrap()
                };
                assert_eq!(e, n.trailing_zeros() as i32);
                let want = naive_dft(&xf, if inverse { 1.0 } else { -1.0 });
                // Noise ≤ ½ LSB² per bin (module docs) → rms error ≤ 0.71 LSB; allow 1 LSB rms.
                let mut err = 0.0;
                for (g, w) in q.iter().zip(&want) {
                    let g = cq15_to_c32(*g);
                    let w = w / n as f64;
                    err += (Complex::new(g.re as f64, g.im as f64) - w).norm_sqr();
                }
                let rms_lsb = (err / n as f64).sqrt() * 32768.0;
                assert!(
                    rms_lsb < 1.0,
                    "n = {n}, inverse {inverse}: rms {rms_lsb} LSB"
                );
            }
        }
    }

    #[test]
    fn q15_block_scaling_skips_shifts_for_small_input_and_never_saturates_full_scale() {
        // An impulse of 1/64 full scale: its spectrum is flat at the same level, no stage needs a
        // shift while |z| ≤ 16383.
        let n = 1024;
        let mut q = std::vec![CQ15::default(); n];
        q[0] = Complex::new(Q(512), Q(0));
        let e = fft_q15(&mut q, Q15Scaling::Block).unwrap();
        assert_eq!(e, 0);
        assert!(q.iter().all(|z| z.re.0 == 512 && z.im.0 == 0));
        // A full-scale complex constant (corner, |z| = 2¹⁵·√2): the DFT is N·x at bin 0. Block
        // scaling must shift 2 at the first stage, then 1 per stage: e = log₂N + 1, no saturation.
        let mut q = std::vec![Complex::new(Q(i16::MIN), Q(i16::MIN)); n];
        let e = fft_q15(&mut q, Q15Scaling::Block).unwrap();
        assert_eq!(e, 11);
        assert_eq!((q[0].re.0, q[0].im.0), (-16384, -16384));
        assert!(q[1..].iter().all(|z| z.re.0 == 0 && z.im.0 == 0));
    }

    /// Round trip `ifft(fft(x))` at N = 64, input components uniform in [−0.45, 0.45) (|z| < 1,
    /// no saturation). With `Always` the result is `x/N` (in LSB, `x_lsb/N`); the forward noise
    /// (≤ ½ LSB² per bin, module docs) is carried through the inverse's `1/N·Σ` as `½·N/N²`, and
    /// the inverse adds its own ≤ ½ LSB², so noise ≤ ½·(1 + 1/N) LSB² against a signal
    /// `mean|x_lsb|²/N²`. Block scaling never shifts more, so it must meet the same bound.
    #[test]
    fn q15_roundtrip_meets_the_rounding_noise_bound() {
        let mut rng = XorShift(7);
        let n = 64usize;
        let x: Vec<CQ15> = (0..n)
            .map(|_| cq15_from_c32(Complex32::new(rng.sym(0.45) as f32, rng.sym(0.45) as f32)))
            .collect();
        let sig_lsb2: f64 = x
            .iter()
            .map(|z| (z.re.0 as f64).powi(2) + (z.im.0 as f64).powi(2))
            .sum::<f64>()
            / n as f64;
        let nf = n as f64;
        let bound_db = 10.0 * ((sig_lsb2 / (nf * nf)) / (0.5 * (1.0 + 1.0 / nf))).log10();
        for scaling in [Q15Scaling::Always, Q15Scaling::Block] {
            let mut q = x.clone();
            let e1 = fft_q15(&mut q, scaling).unwrap();
            let e2 = ifft_q15(&mut q, scaling).unwrap();
            // ifft(fft(x)) = N·x (both unscaled), so q·2^(e1+e2)/N ≈ x.
            let scale = 2f64.powi(e1 + e2) / nf;
            let mut err = 0.0;
            let mut sig = 0.0;
            for (a, b) in q.iter().zip(&x) {
                let (ar, ai) = (a.re.0 as f64 * scale, a.im.0 as f64 * scale);
                let (br, bi) = (b.re.0 as f64, b.im.0 as f64);
                err += (ar - br).powi(2) + (ai - bi).powi(2);
                sig += br * br + bi * bi;
            }
            let snr_db = 10.0 * (sig / err).log10();
            assert!(
                snr_db >= bound_db,
                "{scaling:?}: roundtrip SNR {snr_db:.1} dB < bound {bound_db:.1} dB"
            );
        }
    }
}
