//! Extensive Cancellation Algorithm (ECA): least-squares removal of the direct signal and static
//! multipath from a surveillance channel, in the batch forms of the passive-radar literature.
//!
//! Following Colone, O'Hagan, Lombardo & Baker (IEEE T-AES 45(2), 2009) and the ECA-B / ECA-S
//! variants (Colone, Palmarini, Martelli & Tilli, IEEE T-AES 52(3), 2016; Schwark & Cristallini,
//! 2016): with surveillance `s[n]` (`n = 0 … N−1`) and reference `x`, the clutter subspace is
//! spanned by `M = K·D` basis vectors, the reference delayed by `k = 0 … K−1` samples and shifted
//! by `d = −(D−1)/2 … (D−1)/2` Doppler bins of the CPI:
//!
//! `b_{k,d}[n] = x[n − k] · e^{j2π d n / N}`, column index `m = k·D + (d + (D−1)/2)`.
//!
//! The weights solve the normal equations `(XᴴX)·w = Xᴴs` (Cholesky, [`crate::linalg`], no
//! explicit inverse) and the output is `s − X·w`, the projection of `s` off the clutter subspace.
//! Doppler bins are always those of the whole CPI (spacing `1/N` cycles per sample, `n` the
//! absolute sample index), whatever the variant:
//! * [`EcaVariant::Block`] (ECA): one set of weights estimated over and applied to the whole CPI;
//! * [`EcaVariant::Batched`] (ECA-B): the CPI is cut into batches of `batch` samples, weights are
//!   estimated and applied per batch (tracks slowly varying clutter; usually `D = 1`, since Doppler
//!   columns closer than `1/batch` are nearly collinear over a batch);
//! * [`EcaVariant::Sliding`] (ECA-S): weights for each batch are estimated over the batch widened
//!   by `extra` samples on each side (clipped to the CPI) and applied to the batch only.
//!
//! **Reference layout.** `reference` holds `N + K − 1` samples: `K − 1` samples of history before
//! `s[0]`, then the samples aligned with `s`, i.e. `x[n − k] = reference[n + K − 1 − k]`. Pass zeros
//! as history when there is none.
//!
//! **Arithmetic.**
//! * `f32` path: samples in and out are `f32`; basis samples are promoted to `f64` and `XᴴX`,
//!   `Xᴴs` are accumulated and solved in `f64` (see [`crate::linalg`] for why: the achievable
//!   cancellation is about `κ(XᴴX)·ε`), the output `s − X·w` is formed in `f32`.
//! * Q15 path: samples are [`CQ15`]; basis samples are Q15 (the reference itself for `d = 0`, the
//!   reference times a Q15 phasor, rounded, for `d ≠ 0`); `XᴴX` and `Xᴴs` are exact Q30 sums in
//!   `i64` (each term's parts are at most 2³¹, so an estimation window of up to
//!   [`MAX_Q15_CORR_LEN`] = 2³¹ samples cannot overflow — the maximum CPI of the Block variant);
//!   converted to `f64` and solved there; the weights are quantised to `i32` mantissas with one
//!   shared exponent ([`BlockWeights`], relative error < 2⁻²⁹ of the largest weight) and
//!   `s − X·w` is accumulated exactly in `i64`, rounded to nearest and saturated to Q15 (same
//!   scale as `s`).
//! * Doppler phasors `e^{j2π d n/N}` use the exact integer phase `(d·n) mod N` and `f64`
//!   sine/cosine once per sample and Doppler bin (outside the `M²` inner loop).
//! * The Q15 path's `d ≠ 0` columns carry their own rounding (σ² = LSB²/6 per sample). Clutter
//!   cancellation does not suffer (zero-Doppler clutter lies in the exact `d = 0` columns), but
//!   the projection moves by `−P⊥E·w − X·G⁻¹·Eᴴy` (E the rounding): negligible when the Doppler
//!   columns are orthogonal (ECA over the CPI), several LSB² when short ECA-B/ECA-S batches make
//!   them nearly collinear (Σ(G⁻¹)_mm grows with the condition number) and the reference is
//!   weak. Use `D = 1` with short batches, as the literature does.
//!
//! Who runs which path: the host pipeline (`has_host::localize`) runs the f32 path, since its
//! echoes are synthesised in f32; the Q15 path is for firmware fed by a Q15 front end, and is
//! held to the f32 path by the tests of `tests/eca_template.rs` (the error power of the Q15
//! output within the budget of its input and output rounding).
//!
//! The two paths are one set of kernels (basis, correlations, solve, cancellation) written over
//! the sample type (the crate-private `EcaSample` trait: the accumulator, the phasor rounding,
//! the weights' form and their application are the only parts that differ); the public entry
//! points are the typed `_f32` / `_q15` pairs below.
//!
//! Configuration is `&self` ([`Eca`]); the correlation matrices live in a caller-owned
//! [`EcaWorkspace`] (for `M = 64` about 130 kB: box it on a host). For many surveillance channels
//! sharing one reference (an array), [`Eca::factor_f32`] / [`Eca::factor_q15`] compute the
//! Cholesky factor of every estimation window once, and [`Eca::cancel_with_f32`] /
//! [`Eca::cancel_with_q15`] then cost only `O(N·M)` per channel.
//!
//! Cost: forming `XᴴX` is `N_est·M(M+1)/2` complex multiply-accumulates per window, the solve
//! `M³/6`, the cancellation `N·M`.

use crate::error::{check_len, DspError};
use crate::fixed::{cq15_from_c32, cq15_mul, CQ15};
use crate::linalg::{
    cholesky_in_place, cholesky_solve, q15_conj_mul_i64, q15_sub_weighted, q30_to_f64,
    BlockWeights, MAX_Q15_CORR_LEN,
};
use core::ops::Range;
use num_complex::Complex;

type C32 = Complex<f32>;
type C64 = Complex<f64>;

/// How the CPI is split into estimation and application windows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EcaVariant {
    /// ECA: one window, the whole CPI.
    Block,
    /// ECA-B: consecutive batches of `batch` samples (the CPI length must be a multiple), weights
    /// estimated and applied per batch.
    Batched {
        /// Samples per batch.
        batch: usize,
    },
    /// ECA-S: batches of `batch` samples, each batch's weights estimated over the batch widened by
    /// `extra` samples on both sides (clipped to the CPI).
    Sliding {
        /// Samples per batch.
        batch: usize,
        /// Extra estimation samples on each side of a batch.
        extra: usize,
    },
}

/// ECA configuration: `delays` (K) × `dopplers` (D) basis vectors, at most `M` of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eca<const M: usize> {
    delays: usize,
    dopplers: usize,
    variant: EcaVariant,
    loading: f64,
}

/// The Cholesky factor of one estimation window's `XᴴX` (lower triangle of the active `K·D`
/// block), for reuse across surveillance channels sharing a reference.
#[derive(Clone, Debug, PartialEq)]
pub struct EcaFactor<const M: usize> {
    l: [[C64; M]; M],
}

impl<const M: usize> EcaFactor<M> {
    /// A zeroed factor (not usable until filled by [`Eca::factor_f32`] / [`Eca::factor_q15`]).
    pub const fn new() -> Self {
        Self {
            l: [[C64::new(0.0, 0.0); M]; M],
        }
    }
}

impl<const M: usize> Default for EcaFactor<M> {
    fn default() -> Self {
        Self::new()
    }
}

/// Caller-owned scratch of the one-shot entry points: one factor and the exact `i64` correlation
/// sums of the Q15 path.
#[derive(Clone, Debug)]
pub struct EcaWorkspace<const M: usize> {
    factor: EcaFactor<M>,
    acc: [[Complex<i64>; M]; M],
}

impl<const M: usize> EcaWorkspace<M> {
    /// A zeroed workspace (`M²·32` bytes).
    pub const fn new() -> Self {
        Self {
            factor: EcaFactor::new(),
            acc: [[Complex::new(0, 0); M]; M],
        }
    }
}

impl<const M: usize> Default for EcaWorkspace<M> {
    fn default() -> Self {
        Self::new()
    }
}

/// The sample type the ECA kernels are written over, once: `C32` (correlations summed in
/// `f64`, weights applied in `f32`) or [`CQ15`] (correlations exact in `i64`, weights as
/// [`BlockWeights`] applied with integer multiply-accumulates, module docs). Only these
/// operations differ between the two paths; the windows, basis, sums and solve are shared.
pub(crate) trait EcaSample<const M: usize>: Copy {
    /// Zero sample.
    const ZERO: Self;
    /// The sample as the correlation multiplies it (`C64` for f32, itself for Q15).
    type Wide: Copy;
    /// Zero [`EcaSample::Wide`].
    const WIDE_ZERO: Self::Wide;
    /// Correlation accumulator.
    type Acc: Copy;
    /// Zero accumulator.
    const ACC_ZERO: Self::Acc;
    /// Solved weights in the form the application loop uses.
    type Weights;

    /// The sample widened for the correlation.
    fn widen(self) -> Self::Wide;
    /// `acc + conj(a)·b`.
    fn conj_mul_add(acc: Self::Acc, a: Self::Wide, b: Self::Wide) -> Self::Acc;
    /// A correlation sum as `f64` (in units of the sample squared).
    fn acc_f64(acc: Self::Acc) -> C64;
    /// A Doppler phasor rounded to the sample type (through `f32`).
    fn phasor(z: C64) -> Self;
    /// Basis sample `x·p` of a Doppler column; `centre` is the zero-Doppler column, whose phasor
    /// is exactly 1.
    fn rotate(x: Self, p: Self, centre: bool) -> Self;
    /// The first `m` solved weights in the application form.
    ///
    /// # Errors
    /// As [`BlockWeights::quantize`] for Q15; never for f32.
    fn weights(w: &[C64; M], m: usize) -> Result<Self::Weights, DspError>;
    /// `s − Σ_{i<m} w_i·b_i`.
    fn subtract(s: Self, w: &Self::Weights, b: &[Self; M], m: usize) -> Self;
}

impl<const M: usize> EcaSample<M> for C32 {
    const ZERO: Self = C32::new(0.0, 0.0);
    type Wide = C64;
    const WIDE_ZERO: C64 = C64::new(0.0, 0.0);
    type Acc = C64;
    const ACC_ZERO: C64 = C64::new(0.0, 0.0);
    type Weights = [C32; M];

    #[inline]
    fn widen(self) -> C64 {
        C64::new(self.re as f64, self.im as f64)
    }
    #[inline]
    fn conj_mul_add(acc: C64, a: C64, b: C64) -> C64 {
        acc + a.conj() * b
    }
    #[inline]
    fn acc_f64(acc: C64) -> C64 {
        acc
    }
    #[inline]
    fn phasor(z: C64) -> Self {
        C32::new(z.re as f32, z.im as f32)
    }
    #[inline]
    fn rotate(x: Self, p: Self, _centre: bool) -> Self {
        x * p
    }
    fn weights(w: &[C64; M], _m: usize) -> Result<[C32; M], DspError> {
        let mut w32 = [C32::new(0.0, 0.0); M];
        for (a, z) in w32.iter_mut().zip(w) {
            *a = C32::new(z.re as f32, z.im as f32);
        }
        Ok(w32)
    }
    #[inline]
    fn subtract(s: Self, w: &[C32; M], b: &[Self; M], m: usize) -> Self {
        let mut y = s;
        for (wi, bi) in w.iter().zip(b).take(m) {
            y -= wi * bi;
        }
        y
    }
}

impl<const M: usize> EcaSample<M> for CQ15 {
    const ZERO: Self = CQ15::new(crate::fixed::Q15::ZERO, crate::fixed::Q15::ZERO);
    type Wide = CQ15;
    const WIDE_ZERO: CQ15 = <CQ15 as EcaSample<M>>::ZERO;
    type Acc = Complex<i64>;
    const ACC_ZERO: Complex<i64> = Complex::new(0, 0);
    type Weights = BlockWeights<M>;

    #[inline]
    fn widen(self) -> CQ15 {
        self
    }
    #[inline]
    fn conj_mul_add(acc: Complex<i64>, a: CQ15, b: CQ15) -> Complex<i64> {
        acc + q15_conj_mul_i64(a, b)
    }
    #[inline]
    fn acc_f64(acc: Complex<i64>) -> C64 {
        q30_to_f64(acc)
    }
    #[inline]
    fn phasor(z: C64) -> Self {
        cq15_from_c32(C32::new(z.re as f32, z.im as f32))
    }
    #[inline]
    fn rotate(x: Self, p: Self, centre: bool) -> Self {
        if centre {
            x
        } else {
            cq15_mul(x, p)
        }
    }
    fn weights(w: &[C64; M], m: usize) -> Result<BlockWeights<M>, DspError> {
        BlockWeights::<M>::quantize(w, m)
    }
    #[inline]
    fn subtract(s: Self, w: &BlockWeights<M>, b: &[Self; M], m: usize) -> Self {
        q15_sub_weighted(s, &w.mant[..m], b.iter().copied(), w.frac_bits)
    }
}

/// Estimation and application ranges of one window.
#[derive(Clone, Debug)]
struct Window {
    est: Range<usize>,
    app: Range<usize>,
}

impl<const M: usize> Eca<M> {
    /// A configuration with `delays` K ≥ 1, an odd number of Doppler bins `dopplers` D ≥ 1,
    /// `K·D ≤ M`, the variant and the relative diagonal loading of `XᴴX` (0 for plain least
    /// squares; see [`crate::linalg`]).
    ///
    /// # Errors
    /// [`DspError::UnsupportedLength`] for K = 0, D = 0 or even, `K·D > M`, or a batch shorter
    /// than `K·D` (fewer equations than unknowns); [`DspError::OutOfRange`] for a negative or
    /// non-finite `loading`.
    pub fn new(
        delays: usize,
        dopplers: usize,
        variant: EcaVariant,
        loading: f64,
    ) -> Result<Self, DspError> {
        if delays == 0 {
            return Err(DspError::UnsupportedLength {
                what: "eca.delays",
                len: 0,
            });
        }
        if dopplers & 1 == 0 {
            return Err(DspError::UnsupportedLength {
                what: "eca.dopplers (odd, ≥ 1)",
                len: dopplers,
            });
        }
        let m = delays.saturating_mul(dopplers);
        if m > M {
            return Err(DspError::UnsupportedLength {
                what: "eca.delays · eca.dopplers (at most M)",
                len: m,
            });
        }
        match variant {
            EcaVariant::Block => {}
            EcaVariant::Batched { batch } | EcaVariant::Sliding { batch, .. } => {
                if batch < m {
                    return Err(DspError::UnsupportedLength {
                        what: "eca.batch (at least delays · dopplers)",
                        len: batch,
                    });
                }
            }
        }
        if !loading.is_finite() || loading < 0.0 {
            return Err(DspError::OutOfRange {
                what: "eca.loading",
                value: loading as f32,
            });
        }
        Ok(Self {
            delays,
            dopplers,
            variant,
            loading,
        })
    }

    /// Number of basis vectors `K·D`.
    pub fn columns(&self) -> usize {
        self.delays * self.dopplers
    }

    /// The reference length required for a CPI of `len` samples: `len + K − 1`.
    pub fn reference_len(&self, len: usize) -> usize {
        len.saturating_add(self.delays - 1)
    }

    /// Number of estimation windows (factors) for a CPI of `len` samples.
    ///
    /// # Errors
    /// [`DspError::UnsupportedLength`] if `len` is shorter than `K·D`, not a multiple of the batch
    /// (ECA-B / ECA-S), or an estimation window exceeds 2³¹ samples.
    pub fn windows(&self, len: usize) -> Result<usize, DspError> {
        let m = self.columns();
        if len < m {
            return Err(DspError::UnsupportedLength {
                what: "eca CPI length (at least delays · dopplers)",
                len,
            });
        }
        let (count, longest) = match self.variant {
            EcaVariant::Block => (1, len),
            EcaVariant::Batched { batch } => (len / batch, batch),
            EcaVariant::Sliding { batch, extra } => (
                len / batch,
                batch.saturating_add(extra.saturating_mul(2)).min(len),
            ),
        };
        if let EcaVariant::Batched { batch } | EcaVariant::Sliding { batch, .. } = self.variant {
            if len.checked_rem(batch) != Some(0) {
                return Err(DspError::UnsupportedLength {
                    what: "eca CPI length (a multiple of eca.batch)",
                    len,
                });
            }
        }
        if longest > MAX_Q15_CORR_LEN {
            return Err(DspError::UnsupportedLength {
                what: "eca estimation window (at most 2^31 samples)",
                len: longest,
            });
        }
        Ok(count)
    }

    fn window(&self, len: usize, w: usize) -> Window {
        match self.variant {
            EcaVariant::Block => Window {
                est: 0..len,
                app: 0..len,
            },
            EcaVariant::Batched { batch } => Window {
                est: w * batch..(w + 1) * batch,
                app: w * batch..(w + 1) * batch,
            },
            EcaVariant::Sliding { batch, extra } => Window {
                est: (w * batch).saturating_sub(extra)
                    ..((w + 1) * batch).saturating_add(extra).min(len),
                app: w * batch..(w + 1) * batch,
            },
        }
    }

    /// Checks the common lengths and returns the number of windows.
    fn check(&self, len: usize, reference: usize, out: Option<usize>) -> Result<usize, DspError> {
        let windows = self.windows(len)?;
        check_len(
            "eca reference (CPI + delays − 1)",
            self.reference_len(len),
            reference,
        )?;
        if let Some(o) = out {
            check_len("eca output", len, o)?;
        }
        Ok(windows)
    }

    /// Doppler phasors `e^{j2π d n/len}` for `d = −h … h` at sample `n`, index `d + h`.
    #[inline]
    fn phasors(&self, n: usize, len: usize, p: &mut [C64; M]) {
        let h = (self.dopplers - 1) / 2;
        p[h] = C64::new(1.0, 0.0);
        for d in 1..=h {
            // Exact integer phase: (d·n) mod len < len ≤ 2^31, d·n < 2^63.
            let idx = ((d as u64 * n as u64) % len as u64) as f64;
            let phi = core::f64::consts::TAU * idx / len as f64;
            let (s, c) = (libm::sin(phi), libm::cos(phi));
            p[h + d] = C64::new(c, s);
            p[h - d] = C64::new(c, -s);
        }
    }

    /// Basis samples `b_m[n]` at sample `n`: the reference for `D = 1`, else the reference times
    /// each Doppler phasor, the phasors rounded to the sample type once per Doppler bin.
    #[inline]
    fn basis<S: EcaSample<M>>(
        &self,
        x: &[S],
        n: usize,
        len: usize,
        p: &mut [C64; M],
        b: &mut [S; M],
    ) {
        let (kk, dd) = (self.delays, self.dopplers);
        if dd == 1 {
            for (k, bk) in b.iter_mut().enumerate().take(kk) {
                *bk = x[n + kk - 1 - k];
            }
            return;
        }
        self.phasors(n, len, p);
        let h = (dd - 1) / 2;
        let mut ps = [S::ZERO; M];
        for (q, z) in ps.iter_mut().zip(p.iter()).take(dd) {
            *q = S::phasor(*z);
        }
        for k in 0..kk {
            let xv = x[n + kk - 1 - k];
            for (d, (bm, pd)) in b[k * dd..(k + 1) * dd].iter_mut().zip(&ps).enumerate() {
                *bm = S::rotate(xv, *pd, d == h);
            }
        }
    }

    /// Zeroes `acc` and sums `XᴴX` over `est` into its lower triangle (in the sample type's
    /// accumulator: `f64` for f32 samples, exact `i64` for Q15).
    fn gram<S: EcaSample<M>>(
        &self,
        x: &[S],
        len: usize,
        est: Range<usize>,
        acc: &mut [[S::Acc; M]; M],
    ) {
        let m = self.columns();
        for row in acc.iter_mut().take(m) {
            for v in row.iter_mut().take(m) {
                *v = S::ACC_ZERO;
            }
        }
        let mut p = [C64::new(0.0, 0.0); M];
        let mut b = [S::ZERO; M];
        let mut bw = [S::WIDE_ZERO; M];
        for n in est {
            self.basis(x, n, len, &mut p, &mut b);
            for (w, v) in bw.iter_mut().zip(&b).take(m) {
                *w = v.widen();
            }
            for i in 0..m {
                let bi = bw[i];
                for (g, bj) in acc[i].iter_mut().zip(&bw).take(i + 1) {
                    *g = S::conj_mul_add(*g, bi, *bj);
                }
            }
        }
    }

    /// Forms and factors `XᴴX` over `est` (f32 path: the sums accumulate in the factor itself).
    fn factor_window_f32(
        &self,
        x: &[C32],
        len: usize,
        est: Range<usize>,
        f: &mut EcaFactor<M>,
    ) -> Result<(), DspError> {
        self.gram(x, len, est, &mut f.l);
        self.factor_gram(f)
    }

    /// Forms (exactly, in `i64`) and factors `XᴴX` over `est` (Q15 path).
    fn factor_window_q15(
        &self,
        x: &[CQ15],
        len: usize,
        est: Range<usize>,
        acc: &mut [[Complex<i64>; M]; M],
        f: &mut EcaFactor<M>,
    ) -> Result<(), DspError> {
        self.gram(x, len, est, acc);
        let m = self.columns();
        for (i, (lrow, arow)) in f.l.iter_mut().zip(acc.iter()).take(m).enumerate() {
            for (l, a) in lrow.iter_mut().zip(arow).take(i + 1) {
                *l = <CQ15 as EcaSample<M>>::acc_f64(*a);
            }
        }
        self.factor_gram(f)
    }

    fn factor_gram(&self, f: &mut EcaFactor<M>) -> Result<(), DspError> {
        cholesky_in_place(&mut f.l, self.columns(), self.loading).map_err(|e| match e {
            DspError::NonFinite { .. } => DspError::NonFinite {
                what: "eca reference",
            },
            DspError::NotPositiveDefinite { .. } => DspError::NotPositiveDefinite {
                what: "eca XᴴX (reference too weak or basis dependent; add loading)",
            },
            other => other,
        })
    }

    /// Solves for one window's weights given its factor and `Xᴴs` in `w`.
    fn solve(&self, f: &EcaFactor<M>, w: &mut [C64; M]) -> Result<(), DspError> {
        let m = self.columns();
        for z in w.iter().take(m) {
            if !(z.re.is_finite() && z.im.is_finite()) {
                return Err(DspError::NonFinite {
                    what: "eca surveillance",
                });
            }
        }
        cholesky_solve(&f.l, m, w)
    }

    /// Cancels one window: `Xᴴs` over `est` (in the accumulator type), solve in `f64`, then
    /// `s − X·w` over `app` with the weights in the sample type's form ([`EcaSample::weights`]).
    fn cancel_window<S: EcaSample<M>>(
        &self,
        f: &EcaFactor<M>,
        x: &[S],
        s: &[S],
        out: &mut [S],
        win: &Window,
    ) -> Result<(), DspError> {
        let len = s.len();
        let m = self.columns();
        let mut p = [C64::new(0.0, 0.0); M];
        let mut b = [S::ZERO; M];
        let mut r = [S::ACC_ZERO; M];
        for n in win.est.clone() {
            self.basis(x, n, len, &mut p, &mut b);
            let sn = s[n].widen();
            for (ri, bi) in r.iter_mut().zip(&b).take(m) {
                *ri = S::conj_mul_add(*ri, bi.widen(), sn);
            }
        }
        let mut w = [C64::new(0.0, 0.0); M];
        for (wi, ri) in w.iter_mut().zip(&r) {
            *wi = S::acc_f64(*ri);
        }
        self.solve(f, &mut w)?;
        let weights = S::weights(&w, m)?;
        for n in win.app.clone() {
            self.basis(x, n, len, &mut p, &mut b);
            out[n] = S::subtract(s[n], &weights, &b, m);
        }
        Ok(())
    }

    /// One-shot ECA on `f32` samples: `out = s − X·w` with weights per window of the variant.
    ///
    /// # Errors
    /// [`DspError::UnsupportedLength`] (see [`Eca::windows`]); [`DspError::LengthMismatch`] if
    /// `reference.len() ≠ N + K − 1` or `out.len() ≠ N`; [`DspError::NonFinite`] for a NaN or
    /// infinity in the reference or the surveillance; [`DspError::NotPositiveDefinite`] if `XᴴX`
    /// of a window is singular (e.g. a zero reference) and `loading` is 0.
    pub fn cancel_f32(
        &self,
        ws: &mut EcaWorkspace<M>,
        reference: &[C32],
        surveillance: &[C32],
        out: &mut [C32],
    ) -> Result<(), DspError> {
        let len = surveillance.len();
        let windows = self.check(len, reference.len(), Some(out.len()))?;
        for wi in 0..windows {
            let win = self.window(len, wi);
            self.factor_window_f32(reference, len, win.est.clone(), &mut ws.factor)?;
            self.cancel_window(&ws.factor, reference, surveillance, out, &win)?;
        }
        Ok(())
    }

    /// One-shot ECA on Q15 samples (module docs: exact `i64` correlations, `f64` solve,
    /// block-floating-point weights, rounded and saturated output at the scale of `s`).
    ///
    /// # Errors
    /// As [`Eca::cancel_f32`] (no `NonFinite` for the data, which cannot hold one), plus
    /// [`DspError::OutOfRange`] if a weight reaches 2³⁰.
    pub fn cancel_q15(
        &self,
        ws: &mut EcaWorkspace<M>,
        reference: &[CQ15],
        surveillance: &[CQ15],
        out: &mut [CQ15],
    ) -> Result<(), DspError> {
        let len = surveillance.len();
        let windows = self.check(len, reference.len(), Some(out.len()))?;
        for wi in 0..windows {
            let win = self.window(len, wi);
            self.factor_window_q15(reference, len, win.est.clone(), &mut ws.acc, &mut ws.factor)?;
            self.cancel_window(&ws.factor, reference, surveillance, out, &win)?;
        }
        Ok(())
    }

    /// Factors `XᴴX` of every estimation window of a CPI of `len` samples for an `f32` reference,
    /// into `factors` (one per window, see [`Eca::windows`]), for [`Eca::cancel_with_f32`].
    ///
    /// # Errors
    /// As [`Eca::cancel_f32`], plus [`DspError::LengthMismatch`] if `factors.len()` differs from
    /// the number of windows.
    pub fn factor_f32(
        &self,
        reference: &[C32],
        len: usize,
        factors: &mut [EcaFactor<M>],
    ) -> Result<(), DspError> {
        let windows = self.check(len, reference.len(), None)?;
        check_len("eca factors (one per window)", windows, factors.len())?;
        for (wi, f) in factors.iter_mut().enumerate() {
            let win = self.window(len, wi);
            self.factor_window_f32(reference, len, win.est, f)?;
        }
        Ok(())
    }

    /// ECA of one `f32` surveillance channel with factors from [`Eca::factor_f32`] of the same
    /// reference; identical to [`Eca::cancel_f32`] at `O(N·M)` cost.
    ///
    /// # Errors
    /// As [`Eca::factor_f32`] (lengths checked against `surveillance.len()`).
    pub fn cancel_with_f32(
        &self,
        factors: &[EcaFactor<M>],
        reference: &[C32],
        surveillance: &[C32],
        out: &mut [C32],
    ) -> Result<(), DspError> {
        let len = surveillance.len();
        let windows = self.check(len, reference.len(), Some(out.len()))?;
        check_len("eca factors (one per window)", windows, factors.len())?;
        for (wi, f) in factors.iter().enumerate() {
            let win = self.window(len, wi);
            self.cancel_window(f, reference, surveillance, out, &win)?;
        }
        Ok(())
    }

    /// Factors every estimation window for a Q15 reference (exact `i64` sums in `ws`).
    ///
    /// # Errors
    /// As [`Eca::factor_f32`].
    pub fn factor_q15(
        &self,
        ws: &mut EcaWorkspace<M>,
        reference: &[CQ15],
        len: usize,
        factors: &mut [EcaFactor<M>],
    ) -> Result<(), DspError> {
        let windows = self.check(len, reference.len(), None)?;
        check_len("eca factors (one per window)", windows, factors.len())?;
        for (wi, f) in factors.iter_mut().enumerate() {
            let win = self.window(len, wi);
            self.factor_window_q15(reference, len, win.est, &mut ws.acc, f)?;
        }
        Ok(())
    }

    /// ECA of one Q15 surveillance channel with factors from [`Eca::factor_q15`]; bit-identical to
    /// [`Eca::cancel_q15`].
    ///
    /// # Errors
    /// As [`Eca::cancel_q15`], plus the factor count check.
    pub fn cancel_with_q15(
        &self,
        factors: &[EcaFactor<M>],
        reference: &[CQ15],
        surveillance: &[CQ15],
        out: &mut [CQ15],
    ) -> Result<(), DspError> {
        let len = surveillance.len();
        let windows = self.check(len, reference.len(), Some(out.len()))?;
        check_len("eca factors (one per window)", windows, factors.len())?;
        for (wi, f) in factors.iter().enumerate() {
            let win = self.window(len, wi);
            self.cancel_window(f, reference, surveillance, out, &win)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed::{cq15_to_c32, Q15};
    use crate::linalg::cholesky_solve;

    use crate::test_util::{db, energy, lcg_signal};

    const N: usize = 4096;
    const K: usize = 16;
    /// Target: delay 5 samples, Doppler 203.3 CPI bins (a non-integer, so not orthogonal to any
    /// Doppler column by accident), 20 dB below the direct path.
    const TARGET_DELAY: usize = 5;
    const TARGET_DOPPLER: f64 = 203.3;

    struct Scene {
        reference: Vec<C32>,
        clutter: Vec<C32>,
        target: Vec<C32>,
        noise: Vec<C32>,
    }

    /// Reference: white, −6 dBFS-ish (components uniform in ±0.5). Clutter: direct path and
    /// static multipath at delays 0, 3, 7, 12, 15 (the last at K − 1, which needs the history),
    /// zero Doppler. Noise 60 dB below the clutter power.
    fn scene() -> Scene {
        let reference = lcg_signal(11, N + K - 1, 0.5);
        let x = |n: usize, k: usize| reference[n + K - 1 - k];
        let paths = [
            (0usize, C32::new(0.6, 0.2)),
            (3, C32::new(-0.2, 0.15)),
            (7, C32::new(0.1, -0.12)),
            (12, C32::new(0.05, 0.04)),
            (15, C32::new(-0.03, 0.02)),
        ];
        let clutter: Vec<C32> = (0..N)
            .map(|n| paths.iter().map(|&(k, h)| h * x(n, k)).sum())
            .collect();
        let a_t = C32::new(0.06, 0.0);
        let target: Vec<C32> = (0..N)
            .map(|n| {
                let phi = core::f64::consts::TAU * TARGET_DOPPLER * n as f64 / N as f64;
                a_t * x(n, TARGET_DELAY) * C32::new(phi.cos() as f32, phi.sin() as f32)
            })
            .collect();
        let p_c = energy(&clutter) / N as f64;
        let sigma = (p_c * 1e-6 / 2.0).sqrt() as f32 * 3f32.sqrt(); // uniform: var = a²/3
        let noise = lcg_signal(12, N, sigma);
        Scene {
            reference,
            clutter,
            target,
            noise,
        }
    }

    /// Matched filter (cross-ambiguity) at the target's delay and Doppler.
    fn mf(sc: &Scene, y: &[C32]) -> C64 {
        (0..N)
            .map(|n| {
                let phi = core::f64::consts::TAU * TARGET_DOPPLER * n as f64 / N as f64;
                let r = sc.reference[n + K - 1 - TARGET_DELAY];
                let b = C64::new(r.re as f64, r.im as f64) * C64::new(phi.cos(), phi.sin());
                C64::new(y[n].re as f64, y[n].im as f64) * b.conj()
            })
            .sum()
    }

    fn variants() -> [(&'static str, EcaVariant); 3] {
        [
            ("ECA", EcaVariant::Block),
            ("ECA-B", EcaVariant::Batched { batch: 512 }),
            (
                "ECA-S",
                EcaVariant::Sliding {
                    batch: 512,
                    extra: 256,
                },
            ),
        ]
    }

    /// Cancellation depth and target loss of one configuration (f32 path). Returns
    /// (cancellation dB, target loss dB).
    fn depth_and_loss(sc: &Scene, eca: &Eca<48>) -> (f64, f64) {
        let mut ws = Box::new(EcaWorkspace::<48>::new());
        let mut out = vec![C32::new(0.0, 0.0); N];
        // Clutter + noise only: cancellation = input power / output power (noise-limited at the
        // 60 dB clutter-to-noise ratio).
        let cn: Vec<C32> = (0..N).map(|n| sc.clutter[n] + sc.noise[n]).collect();
        eca.cancel_f32(&mut ws, &sc.reference, &cn, &mut out)
            .unwrap();
        let depth = db(energy(&cn) / energy(&out));
        // Clutter + noise + target: the target's matched-filter response after ECA against the
        // target alone without ECA.
        let all: Vec<C32> = (0..N).map(|n| cn[n] + sc.target[n]).collect();
        eca.cancel_f32(&mut ws, &sc.reference, &all, &mut out)
            .unwrap();
        let loss = db(mf(sc, &sc.target).norm_sqr() / mf(sc, &out).norm_sqr());
        (depth, loss)
    }

    // Why the target survives: ECA removes the projection of s on span{x[n−k]·e^{j2πdn/N}},
    // k < K, |d| ≤ (D−1)/2. A target whose Doppler lies inside those bins (and delay < K) *is* in
    // the span and is cancelled completely; ours is at 203.3 bins, far outside, so only its
    // chance correlation with the M basis vectors is removed: a fraction f ≈ M/L of its energy
    // for an estimation window of L samples (white reference). The matched filter measures
    // <t, P⊥t> = (1 − f)·‖t‖², so the loss is (1 − f)²: 16/4096 → 0.034 dB for ECA,
    // 16/512 → 0.28 dB for ECA-B (batches see the Doppler as 25.4 cycles, still far from the
    // zero-Doppler columns whose resolution is 1/512), in between for ECA-S (wider windows).
    // The requirement is < 1 dB.
    #[test]
    fn eca_variants_cancel_40_db_of_static_clutter_and_keep_a_moving_target() {
        let sc = scene();
        for (name, v) in variants() {
            let eca = Eca::<48>::new(K, 1, v, 0.0).unwrap();
            let (depth, loss) = depth_and_loss(&sc, &eca);
            std::println!("{name}: cancellation {depth:.1} dB, target loss {loss:.3} dB");
            assert!(depth >= 40.0, "{name}: cancellation {depth:.1} dB");
            assert!(loss.abs() < 1.0, "{name}: target loss {loss:.3} dB");
        }
    }

    /// Fraction of the energy of `e^{j2π f n/N}` (white carrier) captured by the Doppler columns
    /// `d = −h … h` over the whole CPI: the columns are orthogonal (integer bins), the projection
    /// on each is the Dirichlet kernel, `|D(f − d)|² = sin²(π(f−d)) / (N² sin²(π(f−d)/N))`.
    fn doppler_capture(f: f64, h: i32) -> f64 {
        (-h..=h)
            .map(|d| {
                let u = core::f64::consts::PI * (f - d as f64);
                (u.sin() / (N as f64 * (u / N as f64).sin())).powi(2)
            })
            .sum()
    }

    #[test]
    fn eca_depth_on_slow_clutter_matches_doppler_capture_theory() {
        // Clutter moving at 0.8 CPI bin (e.g. swaying foliage) is outside the span of the
        // zero-Doppler columns. With a white reference the delay columns are nearly orthogonal, so
        // the residual fraction is 1 − Σ_d |D(0.8 − d)|²: 0.945 for D = 1 (0.24 dB of
        // cancellation) and 0.059 for D = 3 (12.3 dB). Deviations come from the reference's
        // finite-N randomness (|x|² fluctuating about its mean changes each projection by
        // ≈ √(var|x|²/N)/mean ≈ 1 % in amplitude, M/N = 0.4 % chance correlation) and the −60 dB
        // noise: well within ±1 dB of the prediction.
        let sc = scene();
        let slow: Vec<C32> = (0..N)
            .map(|n| {
                let phi = core::f64::consts::TAU * 0.8 * n as f64 / N as f64;
                sc.clutter[n] * C32::new(phi.cos() as f32, phi.sin() as f32) + sc.noise[n]
            })
            .collect();
        let mut ws = Box::new(EcaWorkspace::<48>::new());
        let mut out = vec![C32::new(0.0, 0.0); N];
        for dopplers in [1usize, 3] {
            let eca = Eca::<48>::new(K, dopplers, EcaVariant::Block, 0.0).unwrap();
            eca.cancel_f32(&mut ws, &sc.reference, &slow, &mut out)
                .unwrap();
            let depth = db(energy(&slow) / energy(&out));
            let predicted = -db(1.0 - doppler_capture(0.8, (dopplers as i32 - 1) / 2));
            std::println!("slow clutter, D = {dopplers}: {depth:.2} dB (theory {predicted:.2})");
            assert!((depth - predicted).abs() < 1.0, "D = {dopplers}");
            // The target at 203 bins stays outside the cancelled bins.
            let (depth, loss) = depth_and_loss(&sc, &eca);
            assert!(depth >= 40.0 && loss.abs() < 1.0, "{depth} {loss}");
        }
    }

    #[test]
    fn q15_eca_variants_cancel_40_db() {
        // Same scene in Q15. The clutter (≈ −8 dBFS per component) is 60 dB above the noise;
        // Q15 quantisation adds ≈ −101 dBFS per component to s, x and the output, far below the
        // noise, so the Q15 depth is the same noise-limited ≈ 60 dB.
        let sc = scene();
        let q = |v: &[C32]| -> Vec<CQ15> { v.iter().map(|&z| cq15_from_c32(z)).collect() };
        let xq = q(&sc.reference);
        let cn: Vec<C32> = (0..N).map(|n| sc.clutter[n] + sc.noise[n]).collect();
        let cnq = q(&cn);
        let allq = q(&(0..N).map(|n| cn[n] + sc.target[n]).collect::<Vec<_>>());
        let mut ws = Box::new(EcaWorkspace::<48>::new());
        let mut out = vec![CQ15::default(); N];
        for (name, v) in variants() {
            let eca = Eca::<48>::new(K, 1, v, 0.0).unwrap();
            eca.cancel_q15(&mut ws, &xq, &cnq, &mut out).unwrap();
            let outf: Vec<C32> = out.iter().map(|&z| cq15_to_c32(z)).collect();
            let inf: Vec<C32> = cnq.iter().map(|&z| cq15_to_c32(z)).collect();
            let depth = db(energy(&inf) / energy(&outf));
            eca.cancel_q15(&mut ws, &xq, &allq, &mut out).unwrap();
            let outf: Vec<C32> = out.iter().map(|&z| cq15_to_c32(z)).collect();
            let loss = db(mf(&sc, &sc.target).norm_sqr() / mf(&sc, &outf).norm_sqr());
            std::println!("Q15 {name}: cancellation {depth:.1} dB, target loss {loss:.3} dB");
            assert!(depth >= 40.0, "{name}: {depth:.1} dB");
            assert!(loss.abs() < 1.0, "{name}: {loss:.3} dB");
        }
    }

    #[test]
    fn noise_free_depth_reaches_the_arithmetic_floor() {
        // Clutter exactly in the span, no noise. f32: weights are exact to κ·ε_f64 (κ ≈ 1 for a
        // white reference); the output s − Σ w·b rounds at 2⁻²⁴ relative per operation on
        // values of |s| size, 17 operations → residual below −110 dB: require ≥ 100 dB.
        // Q15: the input's rounding (uniform, LSB²/12 per component) is not in the span and the
        // output adds its own rounding, so the residual power per sample is ≈ 4·LSB²/12 and the
        // depth is P_c / (4·LSB²/12) (±1 dB for the uniform-noise model).
        let sc = scene();
        let mut ws = Box::new(EcaWorkspace::<48>::new());
        let mut out = vec![C32::new(0.0, 0.0); N];
        let eca = Eca::<48>::new(K, 1, EcaVariant::Block, 0.0).unwrap();
        eca.cancel_f32(&mut ws, &sc.reference, &sc.clutter, &mut out)
            .unwrap();
        let depth = db(energy(&sc.clutter) / energy(&out));
        let xq: Vec<CQ15> = sc.reference.iter().map(|&z| cq15_from_c32(z)).collect();
        let cq: Vec<CQ15> = sc.clutter.iter().map(|&z| cq15_from_c32(z)).collect();
        let mut oq = vec![CQ15::default(); N];
        eca.cancel_q15(&mut ws, &xq, &cq, &mut oq).unwrap();
        let oqf: Vec<C32> = oq.iter().map(|&z| cq15_to_c32(z)).collect();
        let depth_q = db(energy(&sc.clutter) / energy(&oqf));
        let lsb = Q15::LSB as f64;
        let predicted_q = db(energy(&sc.clutter) / N as f64 / (4.0 * lsb * lsb / 12.0));
        std::println!(
            "noise-free: f32 {depth:.1} dB, Q15 {depth_q:.1} dB (quantisation limit {predicted_q:.1})"
        );
        assert!(depth >= 100.0);
        assert!((depth_q - predicted_q).abs() < 1.0);
    }

    #[test]
    fn q15_doppler_column_rounding_matches_first_order_perturbation_theory() {
        // The documented sensitivity of the Q15 path with Doppler columns in short batches,
        // checked quantitatively. Both paths get the same Q15-valued inputs, so they differ only
        // in (a) the Q15 output rounding, σ² = LSB²/6 per sample, and (b) the d ≠ 0 basis
        // columns: Q15 rounds x·p_q (p_q the phasor rounded to Q15), f32 keeps x·p; the
        // difference E has σ_e² = σ²·(1 + E|x|²) per sample (product rounding + x times the
        // phasor's rounding). To first order the projection changes by −P⊥E·w − X·G⁻¹·Eᴴy
        // (y the f32 output), two orthogonal terms of expected energy σ_e²·L·Σ_{d≠0}|w_m|² and
        // σ_e²·‖y‖²·Σ_{d≠0}(G⁻¹)_mm per window. The test computes w and G⁻¹ from the f32 path's
        // own factors and asserts the measured mean squared difference is within ±30 % of
        // σ² + (Σ_windows both terms)/N (the spread of the realised quadratic forms is ≈ 10 %).
        // With ECA-B (batches of 128 of a 512 CPI) the d = ±1 columns turn by only ±¼ cycle per
        // batch, so G is ill-conditioned and (b) dominates; with ECA over the CPI it vanishes.
        let n = 512;
        let k = 4;
        let x: Vec<C32> = lcg_signal(31, n + k - 1, 0.2);
        let r = lcg_signal(32, n, 0.1);
        let s: Vec<C32> = (0..n)
            .map(|i| C32::new(0.5, 0.2) * x[i + k - 1] + C32::new(-0.2, 0.1) * x[i + k - 3] + r[i])
            .collect();
        let xq: Vec<CQ15> = x.iter().map(|&z| cq15_from_c32(z)).collect();
        let sq: Vec<CQ15> = s.iter().map(|&z| cq15_from_c32(z)).collect();
        let xf: Vec<C32> = xq.iter().map(|&z| cq15_to_c32(z)).collect();
        let sf: Vec<C32> = sq.iter().map(|&z| cq15_to_c32(z)).collect();
        let sigma2 = (Q15::LSB as f64).powi(2) / 6.0;
        let px = energy(&xf) / xf.len() as f64;
        let sigma_e2 = sigma2 * (1.0 + px);
        for (variant, expect_large) in [
            (EcaVariant::Batched { batch: 128 }, true),
            (EcaVariant::Block, false),
        ] {
            let eca = Eca::<12>::new(k, 3, variant, 0.0).unwrap();
            let mut ws = Box::new(EcaWorkspace::<12>::new());
            let mut out_f = vec![C32::new(0.0, 0.0); n];
            let mut out_q = vec![CQ15::default(); n];
            eca.cancel_f32(&mut ws, &xf, &sf, &mut out_f).unwrap();
            eca.cancel_q15(&mut ws, &xq, &sq, &mut out_q).unwrap();
            let outq: Vec<C32> = out_q.iter().map(|&z| cq15_to_c32(z)).collect();
            let measured: f64 = outq
                .iter()
                .zip(&out_f)
                .map(|(a, b)| (a - b).norm_sqr() as f64)
                .sum::<f64>()
                / n as f64;
            let m = eca.columns();
            let doppler_cols: Vec<usize> = (0..m).filter(|c| c % 3 != 1).collect();
            let mut extra = 0.0;
            let mut f = EcaFactor::<12>::new();
            let mut p = [C64::new(0.0, 0.0); 12];
            let mut b = [C32::new(0.0, 0.0); 12];
            for wi in 0..eca.windows(n).unwrap() {
                let win = eca.window(n, wi);
                eca.factor_window_f32(&xf, n, win.est.clone(), &mut f)
                    .unwrap();
                let mut w = [C64::new(0.0, 0.0); 12];
                for i in win.est.clone() {
                    eca.basis(&xf, i, n, &mut p, &mut b);
                    let si = C64::new(sf[i].re as f64, sf[i].im as f64);
                    for (wm, bm) in w.iter_mut().zip(&b).take(m) {
                        *wm += C64::new(bm.re as f64, -bm.im as f64) * si;
                    }
                }
                eca.solve(&f, &mut w).unwrap();
                let y2 = energy(&out_f[win.app.clone()]);
                let len = win.app.len() as f64;
                for &c in &doppler_cols {
                    let mut e = [C64::new(0.0, 0.0); 12];
                    e[c] = C64::new(1.0, 0.0);
                    cholesky_solve(&f.l, m, &mut e).unwrap();
                    extra += sigma_e2 * (len * w[c].norm_sqr() + y2 * e[c].re);
                }
            }
            let predicted = sigma2 + extra / n as f64;
            std::println!(
                "{variant:?}: measured {:.2} σ², predicted {:.2} σ² (Doppler-column term {:.2} σ²)",
                measured / sigma2,
                predicted / sigma2,
                extra / n as f64 / sigma2
            );
            assert!(
                (measured / predicted - 1.0).abs() < 0.3,
                "{variant:?}: measured {measured:e}, predicted {predicted:e}"
            );
            if expect_large {
                assert!(
                    extra / n as f64 > sigma2,
                    "the batch case should show the effect"
                );
            }
        }
    }

    #[test]
    fn factored_multichannel_path_matches_one_shot() {
        let sc = scene();
        let eca = Eca::<48>::new(
            8,
            3,
            EcaVariant::Sliding {
                batch: 1024,
                extra: 300,
            },
            1e-6,
        )
        .unwrap();
        let x = &sc.reference[K - 8..];
        let s: Vec<C32> = (0..N).map(|n| sc.clutter[n] + sc.target[n]).collect();
        let mut ws = Box::new(EcaWorkspace::<48>::new());
        let mut a = vec![C32::new(0.0, 0.0); N];
        eca.cancel_f32(&mut ws, x, &s, &mut a).unwrap();
        let mut factors = vec![EcaFactor::<48>::new(); eca.windows(N).unwrap()];
        eca.factor_f32(x, N, &mut factors).unwrap();
        let mut b = vec![C32::new(1.0, 1.0); N];
        eca.cancel_with_f32(&factors, x, &s, &mut b).unwrap();
        assert_eq!(a, b);
        // Q15: bit-identical.
        let xq: Vec<CQ15> = x.iter().map(|&z| cq15_from_c32(z)).collect();
        let sq: Vec<CQ15> = s.iter().map(|&z| cq15_from_c32(z)).collect();
        let mut aq = vec![CQ15::default(); N];
        let mut bq = vec![CQ15::default(); N];
        eca.cancel_q15(&mut ws, &xq, &sq, &mut aq).unwrap();
        eca.factor_q15(&mut ws, &xq, N, &mut factors).unwrap();
        eca.cancel_with_q15(&factors, &xq, &sq, &mut bq).unwrap();
        assert_eq!(aq, bq);
    }

    #[test]
    fn bad_inputs_are_errors_not_panics() {
        use EcaVariant::*;
        assert!(Eca::<8>::new(0, 1, Block, 0.0).is_err());
        assert!(Eca::<8>::new(2, 2, Block, 0.0).is_err());
        assert!(Eca::<8>::new(3, 3, Block, 0.0).is_err());
        assert!(Eca::<8>::new(4, 1, Batched { batch: 3 }, 0.0).is_err());
        assert!(Eca::<8>::new(4, 1, Block, f64::NAN).is_err());
        assert!(Eca::<8>::new(4, 1, Block, -1.0).is_err());

        let eca = Eca::<8>::new(4, 1, Batched { batch: 16 }, 0.0).unwrap();
        let mut ws = EcaWorkspace::<8>::new();
        let x = lcg_signal(1, 64 + 3, 0.5);
        let s = lcg_signal(2, 64, 0.5);
        let mut out = vec![C32::new(0.0, 0.0); 64];
        // Wrong reference length, output length, CPI not a multiple of the batch, CPI too short.
        assert!(matches!(
            eca.cancel_f32(&mut ws, &x[1..], &s, &mut out),
            Err(DspError::LengthMismatch { .. })
        ));
        assert!(matches!(
            eca.cancel_f32(&mut ws, &x, &s, &mut out[1..]),
            Err(DspError::LengthMismatch { .. })
        ));
        assert!(matches!(
            eca.cancel_f32(&mut ws, &x[..62], &s[..60], &mut out[..60]),
            Err(DspError::UnsupportedLength { .. })
        ));
        assert!(matches!(
            eca.cancel_f32(&mut ws, &x[..5], &s[..2], &mut out[..2]),
            Err(DspError::UnsupportedLength { .. })
        ));
        // Non-finite reference / surveillance.
        let mut xn = x.clone();
        xn[10].re = f32::NAN;
        assert_eq!(
            eca.cancel_f32(&mut ws, &xn, &s, &mut out),
            Err(DspError::NonFinite {
                what: "eca reference"
            })
        );
        let mut sn = s.clone();
        sn[40].im = f32::INFINITY;
        assert_eq!(
            eca.cancel_f32(&mut ws, &x, &sn, &mut out),
            Err(DspError::NonFinite {
                what: "eca surveillance"
            })
        );
        // Zero reference: singular XᴴX.
        let zero = vec![C32::new(0.0, 0.0); 67];
        assert!(matches!(
            eca.cancel_f32(&mut ws, &zero, &s, &mut out),
            Err(DspError::NotPositiveDefinite { .. })
        ));
        // Factor count.
        let mut factors = vec![EcaFactor::<8>::new(); 3];
        assert!(matches!(
            eca.factor_f32(&x, 64, &mut factors),
            Err(DspError::LengthMismatch { .. })
        ));
        assert!(matches!(
            eca.cancel_with_f32(&factors, &x, &s, &mut out),
            Err(DspError::LengthMismatch { .. })
        ));
        // Q15 entry points.
        let xq: Vec<CQ15> = x.iter().map(|&z| cq15_from_c32(z)).collect();
        let sq: Vec<CQ15> = s.iter().map(|&z| cq15_from_c32(z)).collect();
        let mut oq = vec![CQ15::default(); 64];
        assert!(matches!(
            eca.cancel_q15(&mut ws, &xq[2..], &sq, &mut oq),
            Err(DspError::LengthMismatch { .. })
        ));
        let zq = vec![CQ15::default(); 67];
        assert!(matches!(
            eca.cancel_q15(&mut ws, &zq, &sq, &mut oq),
            Err(DspError::NotPositiveDefinite { .. })
        ));
        assert!(matches!(
            eca.factor_q15(&mut ws, &xq, 64, &mut factors),
            Err(DspError::LengthMismatch { .. })
        ));
        assert!(matches!(
            eca.cancel_with_q15(&factors, &xq, &sq, &mut oq),
            Err(DspError::LengthMismatch { .. })
        ));
        assert!(matches!(
            eca.windows(65),
            Err(DspError::UnsupportedLength { .. })
        ));
    }
}
