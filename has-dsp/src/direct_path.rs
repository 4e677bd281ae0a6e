//! The direct path's delay and phase in one frame: the reference a base station takes from the
//! terminal's line-of-sight echo, in `f32` and in Q15.
//!
//! **Why.** A terminal and a base station share no clock. Each frame that a base station receives
//! carries the pair's timing offset, carrier-frequency offset and local-oscillator phase on every
//! echo alike, the direct path included. The direct path is the strongest echo (20–40 dB above the
//! facades) and its geometry is known to within the terminal's position error, so its measured
//! delay and phase against the ones the geometry predicts give the frame's offsets: the
//! reference channel of passive radar and bistatic SAR. This module measures them
//! ([`DirectPath::estimate`]), moves the frame so that its direct path lies where the geometry
//! puts it ([`DirectPath::rereference`]: one correction for the timing offset and the frame's
//! common phase on every echo) and subtracts the path ([`DirectPath::cancel`]), which would
//! otherwise lay its range sidelobes over the facades' echoes.
//!
//! **Model and conventions** ([`crate::ofdm`], [`crate::range`]). `n` subcarriers in FFT order,
//! spaced `Δf = B/n`, signed index `s_k` (`k` for `k < n/2`, `k − n` above); the Nyquist
//! subcarrier `n/2` is not used, as in range compression, so the `s_k` used are symmetric about 0.
//! A direct path of bistatic length `r` and complex amplitude `a` gives
//! `Y_k = S_k·a·e^{−j2π s_k r/L}` with `L = c/Δf` the unambiguous path length; `a` carries the
//! carrier's phase `e^{−j2π fc r/c}` and every offset common to the frame.
//!
//! **The estimator** is the maximum-likelihood one for one path in white noise: the path that
//! maximises `|C(r)|`, `C(r) = Σ_k Y_k·conj(S_k)·e^{+j2π s_k r/L}`, and `â = C(r̂)/Σ_k |S_k|²`.
//! It searches `C` on a grid of half a range bin (`c/(2B)`) over the caller's window about the
//! predicted path (a one-path `|C|²` has its main lobe two bins wide, so the grid's best point
//! lies on it), then refines by successive parabolic steps over three points `h` apart, `h` from a
//! quarter bin shrinking fourfold per step, for [`REFINE_STEPS`] steps (to `c/B·4⁻⁷`, 6·10⁻⁵ of
//! a bin). Phases are 32-bit words (`s_k·r/L` in cycles modulo 1 by a wrapping integer product),
//! so a long path loses no phase resolution.
//!
//! **Accuracy.** With noise of power `σ²` per subcarrier and the symmetric `s_k`, the
//! Cramér–Rao bounds are `var(r̂) ≥ σ²L² / (8π²|a|²·Σ|S_k|²s_k²)` and
//! `var(arg â) ≥ σ² / (2|a|²·Σ|S_k|²)` (delay and phase decouple: `Σ|S_k|²s_k = 0` for a flat
//! `|S|`); [`DirectPath::path_crb_m`] and [`DirectPath::phase_crb_rad`] give them. The tests hold
//! the estimator within 2× of both at 0 dB per subcarrier. At 0 dB on 1024 subcarriers of 400 MHz
//! the bound on the path is 9 mm, a third of a 3 cm wavelength; each dB of SNR lowers it by 11 %.
//!
//! **What it assumes.** A line-of-sight path in the window, stronger than anything else there
//! (a blocked direct path returns the strongest echo in the window: the caller judges the
//! amplitude against the prediction); a second path within a bin of it (a ground bounce) biases
//! the delay, which a two-path fit would remove.
//!
//! **Q15 path.** `Y_k·conj(S_k)` is formed exactly in Q30, rotated by the crate's table rotor
//! kept to Q30 ([`crate::phase::rotor_q30_word`], ≤ 0.503 Q15 LSB per component and continuous
//! in the phase: the rounded Q15 rotor's one-LSB steps put ripple into `|C|²` that moved the
//! refined path by up to 0.75 mm) and summed in `i64` (under 2⁴⁷ per term, 2¹² terms: no
//! overflow); the search is the same code as the `f32` path's.
//! The `f32` path sums its `f32` products in `f64`: the refinement compares `|C|²` at points
//! 10⁻⁴ of a bin apart, where an `f32` sum's rounding would decide. The table rotor's entry
//! errors still tilt `|C|²` a little: the Q15 path's estimate lies within 14 mm of the `f32`
//! path's on the same frame (0.6 mm typical; tests/tests/direct_path_fixed_vs_float.rs), so its
//! cancellation of a noiseless path is held to −40 dB (−57 to −75 dB measured) where the `f32`
//! path reaches −90 dB; with noise, both leave the noise.
//!
//! Units: metres of bistatic path, radians, the data's amplitude units over the reference's.

use crate::error::{check_len, check_positive, DspError};
use crate::fixed::{cq15_mul_conj_wide, round_shift_i64, sat_i16, CQ15, Q15};
use crate::geometry::C_M_PER_S;
use crate::phase::{rotor_f32, rotor_q30_word};
use num_complex::Complex;

type C32 = Complex<f32>;
type C64 = Complex<f64>;

/// Successive parabolic refinement steps after the grid search (module docs).
pub const REFINE_STEPS: usize = 7;

/// Configuration of a [`DirectPath`] estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DirectPathConfig {
    /// Subcarriers `n`: even, 4 … 4096.
    pub n_subcarriers: usize,
    /// Occupied bandwidth `B = n·Δf`, Hz (> 0).
    pub bandwidth_hz: f64,
    /// Half-width of the window searched about the predicted path, metres of bistatic path:
    /// the prediction's uncertainty (timing offset × c, position error). At least 0, less than
    /// half the unambiguous path `L`.
    pub search_half_width_m: f64,
}

/// One frame's direct path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectPathEstimate {
    /// Bistatic path length `r̂`, metres (within the searched window; the true path modulo `L`).
    pub path_m: f64,
    /// Complex amplitude `â` (carrier phase and the frame's common offsets included).
    pub amplitude: C32,
}

#[cfg(feature = "defmt")]
impl defmt::Format for DirectPathEstimate {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "DirectPathEstimate {{ path_m: {}, amplitude: {} + {}j }}",
            self.path_m,
            self.amplitude.re,
            self.amplitude.im
        )
    }
}

/// The direct-path estimator (module docs): configuration only; every call works on the
/// caller's buffers and keeps nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectPath {
    cfg: DirectPathConfig,
    /// `c/B`, metres.
    bin_m: f64,
    /// `L = c/Δf`, metres.
    unambiguous_m: f64,
}

/// What the estimator needs of a sample type: `Y·conj(S)·e^{+j2πt}` for a phase word and `|S|²`
/// (the search), a rotation by `e^{+j2πt}·g` (re-referencing) and the subtraction of
/// `a·S·e^{+j2πt}` (cancelling), with the constants `g`, `a` converted once per frame.
trait Sample: Copy {
    /// A complex constant in the sample type's arithmetic.
    type Coef: Copy;
    fn coef(c: C64) -> Result<Self::Coef, DspError>;
    fn rotated(y: Self, s: Self, word: u32) -> C64;
    fn power(s: Self) -> f64;
    fn rotate(y: &mut Self, word: u32, g: Self::Coef);
    fn subtract(y: &mut Self, s: Self, a: Self::Coef, word: u32);
}

impl Sample for C32 {
    type Coef = C32;
    fn coef(c: C64) -> Result<C32, DspError> {
        Ok(C32::new(c.re as f32, c.im as f32))
    }
    #[inline]
    fn rotated(y: C32, s: C32, word: u32) -> C64 {
        let z = y * s.conj() * rotor_f32(cycles(word));
        C64::new(z.re as f64, z.im as f64)
    }
    #[inline]
    fn power(s: C32) -> f64 {
        s.norm_sqr() as f64
    }
    #[inline]
    fn rotate(y: &mut C32, word: u32, g: C32) {
        *y = *y * rotor_f32(cycles(word)) * g;
    }
    #[inline]
    fn subtract(y: &mut C32, s: C32, a: C32, word: u32) {
        *y -= a * s * rotor_f32(cycles(word));
    }
}

/// A phase word as cycles in [0, 1).
#[inline]
fn cycles(word: u32) -> f32 {
    word as f32 * (1.0 / 4_294_967_296.0)
}

impl Sample for CQ15 {
    /// Q2.29: `|re|, |im| < 4`.
    type Coef = Complex<i32>;
    fn coef(c: C64) -> Result<Complex<i32>, DspError> {
        const ONE: f64 = (1u32 << 29) as f64;
        if !(c.re.abs() < 4.0 && c.im.abs() < 4.0) {
            return Err(DspError::OutOfRange {
                what: "amplitude (Q15 path: |re|, |im| < 4)",
                value: c.re.abs().max(c.im.abs()) as f32,
            });
        }
        Ok(Complex::new(
            libm::round(c.re * ONE) as i32,
            libm::round(c.im * ONE) as i32,
        ))
    }
    #[inline]
    fn rotated(y: CQ15, s: CQ15, word: u32) -> C64 {
        // Q30 × Q30 = Q60 (each product < 2⁶¹, their sum < 2⁶²), rounded to Q45 (< 2⁴⁷ a term);
        // scaled to the f32 path's units at the end.
        let p = cmul_i64(cq15_mul_conj_wide(y, s), rotor(word));
        C64::new(
            round_shift_i64(p.re, 15) as f64,
            round_shift_i64(p.im, 15) as f64,
        ) * (1.0 / 35_184_372_088_832.0)
    }
    #[inline]
    fn power(s: CQ15) -> f64 {
        let (re, im) = (s.re.0 as f64, s.im.0 as f64);
        (re * re + im * im) * (1.0 / 1_073_741_824.0)
    }
    #[inline]
    fn rotate(y: &mut CQ15, word: u32, g: Complex<i32>) {
        // rotor (Q30) × g (Q29) → Q30; × y (Q15) → Q45 → Q15, rounded and saturated.
        let rg = cmul_i64(rotor(word), g);
        let rg = Complex::new(
            round_shift_i64(rg.re, 29) as i32,
            round_shift_i64(rg.im, 29) as i32,
        );
        let yw = Complex::new(y.re.0 as i32, y.im.0 as i32);
        *y = q15_of(cmul_i64(yw, rg), 30);
    }
    #[inline]
    fn subtract(y: &mut CQ15, s: CQ15, a: Complex<i32>, word: u32) {
        // a (Q29, parts < 4) × s (Q15) → Q44 → Q28 (|a·s| < 4√2: < 2^30.5); × rotor (Q30) →
        // Q58 (parts < 2^61.5) → Q15.
        let a_s = cmul_i64(a, Complex::new(s.re.0 as i32, s.im.0 as i32));
        let a_s = Complex::new(
            round_shift_i64(a_s.re, 16) as i32,
            round_shift_i64(a_s.im, 16) as i32,
        );
        let t = cmul_i64(a_s, rotor(word));
        let t = Complex::new(round_shift_i64(t.re, 43), round_shift_i64(t.im, 43));
        let sat = |v: i64| sat_i16(v.clamp(i32::MIN as i64, i32::MAX as i64) as i32);
        *y = Complex::new(
            Q15::from_bits(sat(y.re.0 as i64 - t.re)),
            Q15::from_bits(sat(y.im.0 as i64 - t.im)),
        );
    }
}

/// The signed index `s_k` of subcarrier `k` of `n` in FFT order.
#[inline]
fn signed(k: usize, n: usize) -> i64 {
    if k < n / 2 {
        k as i64
    } else {
        k as i64 - n as i64
    }
}

/// The table rotor at a 32-bit phase word, Q30 (its own word has 2²⁸ steps per cycle).
#[inline]
fn rotor(word: u32) -> Complex<i32> {
    let (c, s) = rotor_q30_word(word >> 4);
    Complex::new(c, s)
}

/// A complex product of two `i32` complexes in `i64` (callers keep each part under 2⁶²).
#[inline]
fn cmul_i64(a: Complex<i32>, b: Complex<i32>) -> Complex<i64> {
    let (ar, ai, br, bi) = (a.re as i64, a.im as i64, b.re as i64, b.im as i64);
    Complex::new(ar * br - ai * bi, ar * bi + ai * br)
}

/// A complex with `shift` more fraction bits than Q15 to Q15, rounded and saturated.
#[inline]
fn q15_of(p: Complex<i64>, shift: u32) -> CQ15 {
    let sat =
        |v: i64| sat_i16(round_shift_i64(v, shift).clamp(i32::MIN as i64, i32::MAX as i64) as i32);
    Complex::new(Q15::from_bits(sat(p.re)), Q15::from_bits(sat(p.im)))
}

impl DirectPath {
    /// An estimator for `cfg`.
    ///
    /// # Errors
    /// `UnsupportedLength` for `n_subcarriers` odd or outside 4 … 4096; `OutOfRange` for a
    /// bandwidth that is not finite and positive, or a search half-width that is negative, not
    /// finite or at least half the unambiguous path.
    pub fn new(cfg: DirectPathConfig) -> Result<Self, DspError> {
        let n = cfg.n_subcarriers;
        if !(4..=4096).contains(&n) || !n.is_multiple_of(2) {
            return Err(DspError::UnsupportedLength {
                what: "n_subcarriers",
                len: n,
            });
        }
        check_positive("bandwidth_hz", cfg.bandwidth_hz as f32)?;
        if !cfg.bandwidth_hz.is_finite() {
            return Err(DspError::OutOfRange {
                what: "bandwidth_hz",
                value: cfg.bandwidth_hz as f32,
            });
        }
        let bin_m = C_M_PER_S / cfg.bandwidth_hz;
        let unambiguous_m = bin_m * n as f64;
        let w = cfg.search_half_width_m;
        if !(w.is_finite() && w >= 0.0 && w < 0.5 * unambiguous_m) {
            return Err(DspError::OutOfRange {
                what: "search_half_width_m",
                value: w as f32,
            });
        }
        Ok(Self {
            cfg,
            bin_m,
            unambiguous_m,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &DirectPathConfig {
        &self.cfg
    }

    /// The direct path of one frame: received subcarriers `y` and the transmitted symbol `s`
    /// (FFT order, `n` each) about the `predicted_path_m` (module docs).
    ///
    /// # Errors
    /// `LengthMismatch` for buffers of another length than `n`; `NonFinite`/`OutOfRange` for a
    /// predicted path that is not finite or a reference with no power.
    pub fn estimate(
        &self,
        y: &[C32],
        s: &[C32],
        predicted_path_m: f64,
    ) -> Result<DirectPathEstimate, DspError> {
        self.search(y, s, predicted_path_m)
    }

    /// [`DirectPath::estimate`] on Q15 subcarriers (full scale 1, as the `f32` path's units).
    ///
    /// # Errors
    /// As [`DirectPath::estimate`].
    pub fn estimate_q15(
        &self,
        y: &[CQ15],
        s: &[CQ15],
        predicted_path_m: f64,
    ) -> Result<DirectPathEstimate, DspError> {
        self.search(y, s, predicted_path_m)
    }

    /// Moves frame `y`'s direct path from where `est` measured it to where the geometry puts it
    /// (`predicted_path_m`, carrier phase `predicted_phase_rad`): subcarrier `k` turned by
    /// `e^{+j2π s_k (r̂ − r_pred)/L}·e^{j(φ_pred − arg â)}`. Every echo of the frame moves with
    /// it, so the frame's timing offset and its common phase (the carrier offset's and the
    /// oscillators' over the frame) are gone from all of them; what is left is the error of the
    /// prediction itself (the terminal's position error).
    ///
    /// # Errors
    /// `LengthMismatch` for `y` of another length than `n`; `NonFinite` for a path, phase or
    /// amplitude that is not finite; `OutOfRange` for a zero amplitude.
    pub fn rereference(
        &self,
        y: &mut [C32],
        est: &DirectPathEstimate,
        predicted_path_m: f64,
        predicted_phase_rad: f64,
    ) -> Result<(), DspError> {
        self.rereference_with(y, est, predicted_path_m, predicted_phase_rad)
    }

    /// [`DirectPath::rereference`] on Q15 subcarriers (rounded and saturated).
    ///
    /// # Errors
    /// As [`DirectPath::rereference`].
    pub fn rereference_q15(
        &self,
        y: &mut [CQ15],
        est: &DirectPathEstimate,
        predicted_path_m: f64,
        predicted_phase_rad: f64,
    ) -> Result<(), DspError> {
        self.rereference_with(y, est, predicted_path_m, predicted_phase_rad)
    }

    /// Subtracts the direct path `est` from frame `y` sent with symbol `s`:
    /// `Y_k −= â·S_k·e^{−j2π s_k r̂/L}` on every subcarrier. An estimate from the same frame is the
    /// least-squares fit of one path, so what remains is the frame without it, down to the
    /// noise and the estimate's own error (about `1.5σ²` over the frame at the Cramér–Rao bound:
    /// the amplitude's two degrees of freedom and half of the path's).
    ///
    /// # Errors
    /// `LengthMismatch` for buffers of another length than `n`; `NonFinite` for a path or
    /// amplitude that is not finite; `OutOfRange` on the Q15 path for an amplitude component of
    /// 4 or more.
    pub fn cancel(
        &self,
        y: &mut [C32],
        s: &[C32],
        est: &DirectPathEstimate,
    ) -> Result<(), DspError> {
        self.cancel_with(y, s, est)
    }

    /// [`DirectPath::cancel`] on Q15 subcarriers (rounded and saturated).
    ///
    /// # Errors
    /// As [`DirectPath::cancel`].
    pub fn cancel_q15(
        &self,
        y: &mut [CQ15],
        s: &[CQ15],
        est: &DirectPathEstimate,
    ) -> Result<(), DspError> {
        self.cancel_with(y, s, est)
    }

    fn checked_amplitude(est: &DirectPathEstimate) -> Result<C64, DspError> {
        let a = C64::new(est.amplitude.re as f64, est.amplitude.im as f64);
        if !(est.path_m.is_finite() && a.re.is_finite() && a.im.is_finite()) {
            return Err(DspError::NonFinite {
                what: "direct-path estimate",
            });
        }
        Ok(a)
    }

    fn rereference_with<T: Sample>(
        &self,
        y: &mut [T],
        est: &DirectPathEstimate,
        predicted_path_m: f64,
        predicted_phase_rad: f64,
    ) -> Result<(), DspError> {
        let n = self.cfg.n_subcarriers;
        check_len("y", n, y.len())?;
        let a = Self::checked_amplitude(est)?;
        if !(predicted_path_m.is_finite() && predicted_phase_rad.is_finite()) {
            return Err(DspError::NonFinite {
                what: "predicted path or phase",
            });
        }
        if a.re == 0.0 && a.im == 0.0 {
            return Err(DspError::OutOfRange {
                what: "direct-path amplitude",
                value: 0.0,
            });
        }
        let turn = predicted_phase_rad - libm::atan2(a.im, a.re);
        let g = T::coef(C64::new(libm::cos(turn), libm::sin(turn)))?;
        let u = self.word(est.path_m - predicted_path_m);
        for (k, yk) in y.iter_mut().enumerate() {
            T::rotate(yk, (signed(k, n) as u32).wrapping_mul(u), g);
        }
        Ok(())
    }

    fn cancel_with<T: Sample>(
        &self,
        y: &mut [T],
        s: &[T],
        est: &DirectPathEstimate,
    ) -> Result<(), DspError> {
        let n = self.cfg.n_subcarriers;
        check_len("y", n, y.len())?;
        check_len("s", n, s.len())?;
        let a = T::coef(Self::checked_amplitude(est)?)?;
        let u = self.word(est.path_m);
        for (k, (yk, &sk)) in y.iter_mut().zip(s).enumerate() {
            T::subtract(yk, sk, a, ((-signed(k, n)) as u32).wrapping_mul(u));
        }
        Ok(())
    }

    /// The Cramér–Rao bound on the path's standard deviation, metres, for a reference of
    /// constant `|S|` and `snr = |a|²|S|²/σ²` per subcarrier (linear): `L / (2π·√(2·snr·Σs_k²))`.
    pub fn path_crb_m(&self, snr: f64) -> f64 {
        let n = self.cfg.n_subcarriers as i64;
        let sum_s2: f64 = (1 - n / 2..n / 2).map(|s| (s * s) as f64).sum();
        self.unambiguous_m / (2.0 * core::f64::consts::PI * libm::sqrt(2.0 * snr * sum_s2))
    }

    /// The Cramér–Rao bound on the phase's standard deviation, radians, as
    /// [`DirectPath::path_crb_m`]: `1/√(2·snr·(n − 1))`.
    pub fn phase_crb_rad(&self, snr: f64) -> f64 {
        1.0 / libm::sqrt(2.0 * snr * (self.cfg.n_subcarriers - 1) as f64)
    }

    /// The phase word of path `r`: `r/L` in cycles modulo 1, on 32 bits.
    fn word(&self, r: f64) -> u32 {
        let u = r / self.unambiguous_m;
        let frac = u - libm::floor(u);
        ((frac * 4_294_967_296.0) as u64 & 0xFFFF_FFFF) as u32
    }

    /// `C(r)` (module docs).
    fn correlate<T: Sample>(&self, y: &[T], s: &[T], r: f64) -> C64 {
        let n = self.cfg.n_subcarriers;
        let u = self.word(r);
        let mut acc = C64::new(0.0, 0.0);
        for k in (0..n).filter(|&k| k != n / 2) {
            acc += T::rotated(y[k], s[k], (signed(k, n) as u32).wrapping_mul(u));
        }
        acc
    }

    fn search<T: Sample>(
        &self,
        y: &[T],
        s: &[T],
        predicted_path_m: f64,
    ) -> Result<DirectPathEstimate, DspError> {
        let n = self.cfg.n_subcarriers;
        check_len("y", n, y.len())?;
        check_len("s", n, s.len())?;
        if !predicted_path_m.is_finite() {
            return Err(DspError::NonFinite {
                what: "predicted_path_m",
            });
        }
        let power: f64 = (0..n).filter(|&k| k != n / 2).map(|k| T::power(s[k])).sum();
        if power.is_nan() || power <= 0.0 {
            return Err(DspError::OutOfRange {
                what: "s (reference power)",
                value: power as f32,
            });
        }
        let mag2 = |r: f64| self.correlate(y, s, r).norm_sqr();
        // The grid: half a bin, over the window.
        let step = 0.5 * self.bin_m;
        let w = self.cfg.search_half_width_m;
        let points = libm::floor(2.0 * w / step) as usize + 1;
        let start = predicted_path_m - 0.5 * (points - 1) as f64 * step;
        let (mut r, mut c0) = (predicted_path_m, f64::NEG_INFINITY);
        for i in 0..points {
            let ri = start + i as f64 * step;
            let ci = mag2(ri);
            if ci > c0 {
                (r, c0) = (ri, ci);
            }
        }
        // Successive parabolic refinement.
        let mut h = 0.25 * self.bin_m;
        for _ in 0..REFINE_STEPS {
            let (m, p) = (mag2(r - h), mag2(r + h));
            let curvature = m - 2.0 * c0 + p;
            let delta = if curvature < 0.0 {
                (0.5 * h * (m - p) / curvature).clamp(-h, h)
            } else if m > c0 || p > c0 {
                if m > p {
                    -h
                } else {
                    h
                }
            } else {
                0.0
            };
            if delta != 0.0 {
                let c = mag2(r + delta);
                if c >= c0 {
                    (r, c0) = (r + delta, c);
                }
            }
            h *= 0.25;
        }
        let a = self.correlate(y, s, r) / power;
        Ok(DirectPathEstimate {
            path_m: r,
            amplitude: C32::new(a.re as f32, a.im as f32),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::Lcg;

    const B: f64 = 400e6;

    fn estimator(n: usize, w: f64) -> DirectPath {
        DirectPath::new(DirectPathConfig {
            n_subcarriers: n,
            bandwidth_hz: B,
            search_half_width_m: w,
        })
        .unwrap()
    }

    /// A direct path of length `r` and amplitude `a` through a unit-modulus random-phase symbol,
    /// with complex Gaussian noise of power `sigma2` per subcarrier: `(y, s)`.
    fn frame(n: usize, r: f64, a: C64, sigma2: f64, g: &mut Lcg) -> (Vec<C32>, Vec<C32>) {
        let l = C_M_PER_S / B * n as f64;
        let gauss = |g: &mut Lcg| {
            let (u1, u2) = (g.unit(), g.unit());
            let rad = (-2.0 * u1.ln()).sqrt();
            let th = 2.0 * core::f64::consts::PI * u2;
            C64::new(rad * th.cos(), rad * th.sin()) * (0.5 * sigma2).sqrt()
        };
        let mut y = Vec::with_capacity(n);
        let mut s = Vec::with_capacity(n);
        for k in 0..n {
            let signed = if k < n / 2 {
                k as f64
            } else {
                k as f64 - n as f64
            };
            let sym = C64::from_polar(1.0, 2.0 * core::f64::consts::PI * g.unit());
            let phase = -2.0 * core::f64::consts::PI * signed * r / l;
            let v = sym * a * C64::from_polar(1.0, phase) + gauss(g);
            y.push(C32::new(v.re as f32, v.im as f32));
            s.push(C32::new(sym.re as f32, sym.im as f32));
        }
        (y, s)
    }

    #[test]
    fn a_noiseless_direct_path_is_found_to_a_thousandth_of_a_bin_anywhere_in_the_window() {
        let est = estimator(1024, 40.0);
        let bin = C_M_PER_S / B;
        let mut g = Lcg(7);
        for _ in 0..20 {
            let predicted = 50.0 + 200.0 * g.unit();
            let r = predicted + 70.0 * (g.unit() - 0.5);
            let a = C64::from_polar(0.3, 6.0 * g.unit());
            let (y, s) = frame(1024, r, a, 0.0, &mut g);
            let e = est.estimate(&y, &s, predicted).unwrap();
            assert!((e.path_m - r).abs() < 1e-3 * bin, "{} vs {r}", e.path_m);
            let got = C64::new(e.amplitude.re as f64, e.amplitude.im as f64);
            assert!((got - a).norm() < 1e-4, "{got} vs {a}");
        }
    }

    #[test]
    fn at_0_db_per_subcarrier_the_path_and_phase_are_within_twice_the_cramer_rao_bound() {
        let (n, trials) = (256, 400);
        let est = estimator(n, 10.0);
        let snr = 1.0;
        let (crb_r, crb_p) = (est.path_crb_m(snr), est.phase_crb_rad(snr));
        let mut g = Lcg(11);
        let (mut er2, mut ep2) = (0.0, 0.0);
        for _ in 0..trials {
            let r = 120.0 + 3.0 * (g.unit() - 0.5);
            let a = C64::from_polar(1.0, 6.0 * g.unit());
            let (y, s) = frame(n, r, a, 1.0 / snr, &mut g);
            let e = est.estimate(&y, &s, 120.0).unwrap();
            er2 += (e.path_m - r).powi(2);
            let got = C64::new(e.amplitude.re as f64, e.amplitude.im as f64);
            ep2 += (got / a).arg().powi(2);
        }
        let (sr, sp) = ((er2 / trials as f64).sqrt(), (ep2 / trials as f64).sqrt());
        // The rms over 400 trials is within ±7 % of its expectation (2 standard deviations); an
        // efficient estimator sits at the bound, and nothing unbiased sits below it.
        assert!(
            sr > 0.85 * crb_r && sr < 2.0 * crb_r,
            "path {sr} m, CRB {crb_r} m"
        );
        assert!(
            sp > 0.85 * crb_p && sp < 2.0 * crb_p,
            "phase {sp} rad, CRB {crb_p} rad"
        );
        // The module's figure: 9 mm at 0 dB on 1024 subcarriers of 400 MHz.
        let big = estimator(1024, 10.0);
        assert!(
            (big.path_crb_m(1.0) - 0.0091).abs() < 0.0005,
            "{}",
            big.path_crb_m(1.0)
        );
    }

    #[test]
    fn q15_subcarriers_give_the_f32_estimate() {
        let est = estimator(512, 20.0);
        let mut g = Lcg(3);
        for _ in 0..10 {
            let r = 80.0 + 30.0 * (g.unit() - 0.5);
            let a = C64::from_polar(0.25, 6.0 * g.unit());
            let (y, s) = frame(512, r, a, 1e-4, &mut g);
            let f = est.estimate(&y, &s, 80.0).unwrap();
            let yq: Vec<CQ15> = y.iter().map(|z| crate::fixed::cq15_from_c32(*z)).collect();
            // |S| = 1 is one LSB past Q15: the reference at half scale (the estimate's amplitude
            // doubles).
            let sq: Vec<CQ15> = s
                .iter()
                .map(|z| crate::fixed::cq15_from_c32(*z * 0.5))
                .collect();
            let q = est.estimate_q15(&yq, &sq, 80.0).unwrap();
            // The bounds derived in tests/tests/direct_path_fixed_vs_float.rs: 14 mm, 10⁻³.
            assert!(
                (q.path_m - f.path_m).abs() < 0.014,
                "{} vs {}",
                q.path_m,
                f.path_m
            );
            assert!((q.amplitude * 0.5 - f.amplitude).norm() < 1e-3 * f.amplitude.norm());
        }
    }

    /// SplitMix64's output function: well-separated seeds from consecutive integers.
    fn splitmix64(x: u64) -> u64 {
        let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A frame of two echoes, noise-free: the direct path `(r, a)` and a second echo 25 m
    /// farther, a tenth as strong.
    fn two_echoes(n: usize, r: f64, a: C64, g: &mut Lcg) -> (Vec<C32>, Vec<C32>) {
        let (y1, s) = frame(n, r, a, 0.0, g);
        let l = C_M_PER_S / B * n as f64;
        let y = y1
            .iter()
            .zip(&s)
            .enumerate()
            .map(|(k, (y, s))| {
                let sg = signed(k, n) as f64;
                let e = C64::from_polar(0.1, -2.0 * core::f64::consts::PI * sg * (r + 25.0) / l)
                    * a
                    * C64::new(s.re as f64, s.im as f64);
                *y + C32::new(e.re as f32, e.im as f32)
            })
            .collect();
        (y, s)
    }

    #[test]
    fn rereferencing_moves_every_echo_by_the_measured_offset() {
        let n = 512;
        let est = estimator(n, 10.0);
        let mut g = Lcg(5);
        let (predicted, phase) = (91.3, 0.3);
        let (y, s) = two_echoes(n, predicted + 3.7, C64::from_polar(0.4, 2.0), &mut g);
        // f32: after re-referencing, the direct path is where the geometry says, with its phase,
        // and the second echo moved with it (each estimated where the other's sidelobe biases
        // it alike before and after: the frame moves as a whole).
        let second = DirectPath::new(DirectPathConfig {
            search_half_width_m: 3.0,
            ..*est.config()
        })
        .unwrap();
        let before = second.estimate(&y, &s, predicted + 28.7).unwrap().path_m;
        let mut f = y.clone();
        let e = est.estimate(&f, &s, predicted).unwrap();
        est.rereference(&mut f, &e, predicted, phase).unwrap();
        let d = est.estimate(&f, &s, predicted).unwrap();
        assert!((d.path_m - predicted).abs() < 1e-4, "{}", d.path_m);
        let turn = libm::atan2(d.amplitude.im as f64, d.amplitude.re as f64) - phase;
        assert!(turn.abs() < 1e-4, "{turn}");
        let after = second.estimate(&f, &s, predicted + 25.0).unwrap().path_m;
        let moved = after - (before - (e.path_m - predicted));
        assert!(moved.abs() < 1e-4, "{moved}");
        // Q15, within the Q15 path's bounds (tests/tests/direct_path_fixed_vs_float.rs).
        let mut q: Vec<CQ15> = y.iter().map(|z| crate::fixed::cq15_from_c32(*z)).collect();
        let sq: Vec<CQ15> = s
            .iter()
            .map(|z| crate::fixed::cq15_from_c32(*z * 0.5))
            .collect();
        let e = est.estimate_q15(&q, &sq, predicted).unwrap();
        est.rereference_q15(&mut q, &e, predicted, phase).unwrap();
        let d = est.estimate_q15(&q, &sq, predicted).unwrap();
        assert!((d.path_m - predicted).abs() < 0.014, "{}", d.path_m);
        let turn = libm::atan2(d.amplitude.im as f64, d.amplitude.re as f64) - phase;
        assert!(turn.abs() < 1e-3, "{turn}");
    }

    #[test]
    fn cancelling_leaves_the_noise_and_one_and_a_half_noise_powers_of_estimate_error() {
        // The residual of the fitted path is the noise projected on the fit's three real
        // degrees of freedom (the amplitude's two, the path's one): 1.5σ² over the frame,
        // against the path's n·snr·σ².
        let (n, trials, snr) = (256, 200, 10.0);
        let est = estimator(n, 5.0);
        let mut ratio = 0.0;
        for t in 0..trials {
            // Each trial its own stream: an LCG seeded with another's next state would replay
            // that stream a few draws on, and the trials would share their noise.
            let mut g = Lcg(splitmix64(t));
            let r = 60.0 + 2.0 * (g.unit() - 0.5);
            let a = C64::from_polar(1.0, 6.0 * g.unit());
            let mut g2 = Lcg(splitmix64(t + (1 << 32)));
            let (clean, s) = frame(n, r, a, 0.0, &mut Lcg(g2.0));
            let (mut y, _) = frame(n, r, a, 1.0 / snr, &mut g2);
            let noise: Vec<C32> = y.iter().zip(&clean).map(|(y, c)| y - c).collect();
            let e = est.estimate(&y, &s, 60.0).unwrap();
            est.cancel(&mut y, &s, &e).unwrap();
            let left: f64 = y
                .iter()
                .zip(&noise)
                .map(|(y, w)| (y - w).norm_sqr() as f64)
                .sum();
            ratio += left / (n as f64 * snr * (1.0 / snr));
        }
        let (mean, want) = (ratio / trials as f64, 1.5 / (n as f64 * snr));
        // 200 draws of a 3-degree chi-square: ±5.8 % (one standard deviation) about the mean.
        assert!(mean > 0.8 * want && mean < 1.25 * want, "{mean} vs {want}");
    }

    #[test]
    fn q15_cancelling_of_a_noiseless_path_leaves_at_most_the_rotors_share() {
        // The Q15 fit maximises the correlation through the table rotor, whose entries err by
        // ≤ 0.503 LSB: a relative perturbation of |C|² of at most δ = 2·0.503·√2·2⁻¹⁵ = 4.3·10⁻⁵,
        // so the fitted path gives up at most 2δ of the path's power against the exact fit
        // (−40 dB); the roundings of the input, of the subtracted term and the refinement's last
        // step add under 10⁻⁷. The f32 path leaves −90 dB and less on these frames.
        let n = 1024;
        let est = estimator(n, 10.0);
        let mut g = Lcg(23);
        let delta = 2.0 * 0.503 * core::f64::consts::SQRT_2 / 32768.0;
        for _ in 0..5 {
            let r = 130.0 + 8.0 * (g.unit() - 0.5);
            let (y, s) = frame(n, r, C64::from_polar(0.4, 6.0 * g.unit()), 0.0, &mut g);
            let q15 = |v: &[C32]| -> Vec<CQ15> {
                v.iter()
                    .map(|z| crate::fixed::cq15_from_c32(*z * 0.5))
                    .collect()
            };
            let power = |v: &[CQ15]| -> f64 {
                v.iter()
                    .map(|z| crate::fixed::cq15_to_c32(*z).norm_sqr() as f64)
                    .sum()
            };
            let (mut q, sq) = (q15(&y), q15(&s));
            let path = power(&q);
            let e = est.estimate_q15(&q, &sq, 130.0).unwrap();
            est.cancel_q15(&mut q, &sq, &e).unwrap();
            let left = power(&q) / path;
            assert!(left <= 2.0 * delta + 1e-7, "{} dB", 10.0 * left.log10());
            assert!(left > 0.0);
        }
    }

    #[test]
    fn bad_configurations_and_buffers_are_errors_naming_the_field() {
        let cfg = DirectPathConfig {
            n_subcarriers: 1024,
            bandwidth_hz: B,
            search_half_width_m: 10.0,
        };
        for (bad, what) in [
            (
                DirectPathConfig {
                    n_subcarriers: 1023,
                    ..cfg
                },
                "n_subcarriers",
            ),
            (
                DirectPathConfig {
                    bandwidth_hz: f64::NAN,
                    ..cfg
                },
                "bandwidth_hz",
            ),
            (
                DirectPathConfig {
                    search_half_width_m: 1e9,
                    ..cfg
                },
                "search_half_width_m",
            ),
            (
                DirectPathConfig {
                    search_half_width_m: -1.0,
                    ..cfg
                },
                "search_half_width_m",
            ),
        ] {
            let e = DirectPath::new(bad).unwrap_err();
            assert!(format!("{e:?}").contains(what), "{e:?}");
        }
        let est = DirectPath::new(cfg).unwrap();
        let y = vec![C32::new(0.1, 0.0); 1024];
        assert!(matches!(
            est.estimate(&y[..1000], &y, 0.0),
            Err(DspError::LengthMismatch { what: "y", .. })
        ));
        assert!(matches!(
            est.estimate(&y, &y, f64::INFINITY),
            Err(DspError::NonFinite { .. })
        ));
        let zero = vec![C32::new(0.0, 0.0); 1024];
        assert!(est.estimate(&y, &zero, 0.0).is_err());
    }
}
