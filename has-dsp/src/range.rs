//! OFDM range compression: received subcarriers `Y[k]` and the known symbol `S[k]` → a range
//! profile indexed by bistatic path length, in `f32` and in Q15.
//!
//! **Conventions** (shared with echo synthesis, see [`crate::ofdm`]): `n` subcarriers in FFT order
//! spaced `Δf = B/n`; an echo is `Y[k] = S[k]·Σ_p a_p·e^{−j2π(fc + f_k)τ_p}`. The profile is
//! `P[m] = (1/Σw)·Σ_k w_k·G_k·Y_k·e^{+j2π f_k m/(B·zero_pad)}` over `m = 0 … n·zero_pad − 1`, with
//! `G_k = conj(S_k)` ([`RangeMode::Matched`]) or `1/S_k` ([`RangeMode::ZeroForcing`]) and `w` the
//! window ([`crate::window`], FFT order, peak 1 at the carrier). Bin `m` is at path length
//! `m · c/(B·zero_pad)` ([`RangeCompressor::bin_spacing_m`]), modulo the unambiguous path length
//! `c/Δf` ([`RangeCompressor::unambiguous_path_m`]). A point scatterer at path `r_p` gives a
//! **real, symmetric pulse** peaking at bin `r_p / bin_spacing`, times `a_p·e^{−j2π fc τ_p}`.
//!
//! **Normalisation.** The sum is divided by the window's sum (over the subcarriers used), so a
//! scatterer with `|a_p| = 1` seen through `|S| = 1` (matched) or any `S` (zero-forcing) has a
//! pulse peak of magnitude 1 whatever the window (exactly 1 when `r_p` falls on a bin). Matched
//! filtering with `|S| ≠ 1` scales the pulse by the window-weighted mean of `|S|²`.
//!
//! **Zero padding** (`zero_pad` ∈ {1, 2, 4}) inserts zeros in the middle of the FFT-ordered
//! spectrum, between offsets `+n/2 − 1` and `−n/2`.
//!
//! **The Nyquist subcarrier** (index `n/2`, offset `−n/2`) has no partner at `+n/2`; it would add
//! an antisymmetric imaginary part `(w_{n/2}/Σw)·sin(πu)` (`u` the offset from the target in bins)
//! to the pulse. It is therefore **not used** (weight 0, left out of `Σw`), which makes the pulse
//! exactly real and symmetric for every window and every target position: it is
//! `Σ_{|s|<n/2} w_s·e^{j2πsu/n} / Σw`. (Hann is 0 there anyway; OFDM usually leaves it empty.)
//!
//! **Reference preparation.** The reference `R_k = w_k·G_k/Σw` (times the inverse FFT's `n·zero_pad`
//! for `f32`) is computed once per reference symbol into a caller-owned buffer
//! ([`RangeCompressor::prepare_reference`], [`RangeCompressor::prepare_reference_q15`]) — setup
//! work in `f64` with `libm` cosines for the window. The per-frame data path
//! ([`RangeCompressor::compress`], [`RangeCompressor::compress_q15`]) is one complex multiply per
//! subcarrier and one inverse FFT into the caller's profile buffer; nothing is allocated or kept.
//! Zero-forcing drops subcarriers with `|S_k|² ≤ min_power` (`R_k = 0`, and they do not count in
//! `Σw`).
//!
//! **Q15 path.** `R` is stored as Q15 mantissas with one exponent `e_R` (`R = R_q·2^e_R`, chosen
//! so that `max |R_q| ≤ 1 − 2⁻¹⁵`); the product `Y·R_q` is rounded to nearest and saturated to Q15;
//! the inverse FFT ([`crate::fft::ifft_q15`], scaling from the config) returns its block exponent
//! `e_F`. [`RangeCompressor::compress_q15`] returns `e = e_R + e_F` with `P[m] = q[m]·2^e` — the
//! same normalised profile as the `f32` path.

use crate::error::{check_len, DspError};
use crate::fft::{check_fft_len, ifft_c32, ifft_q15, Complex32, Q15Scaling};
use crate::fixed::{cq15_mul, CQ15, Q15};
use crate::ofdm;
use crate::window::{Window, WindowEval};
use num_complex::Complex;

/// What the compressor divides the received spectrum by.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RangeMode {
    /// Matched filter `Y·conj(S)`: best SNR in white noise; the pulse inherits `|S|²`.
    #[default]
    Matched,
    /// Zero forcing `Y/S`: removes the symbol's spectrum; subcarriers with `|S_k|² ≤ min_power`
    /// are dropped (guard against dividing by ≈ 0).
    ZeroForcing {
        /// Smallest usable `|S_k|²` (same units as `S`, full scale 1 for Q15); must be > 0.
        min_power: f32,
    },
}

/// Configuration of a [`RangeCompressor`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RangeConfig {
    /// Number of subcarriers `n`: a power of two, 64 … 4096, with `n·zero_pad ≤ 4096`.
    pub n_subcarriers: usize,
    /// Occupied bandwidth `B = n·Δf` in Hz (> 0).
    pub bandwidth_hz: f64,
    /// Zero-padding factor of the inverse FFT: 1, 2 or 4.
    pub zero_pad: usize,
    /// Matched or zero-forcing.
    pub mode: RangeMode,
    /// Spectral taper across subcarriers.
    pub window: Window,
    /// Scaling of the Q15 inverse FFT (ignored by the `f32` path).
    pub q15_scaling: Q15Scaling,
}

/// A validated range-compression configuration (`&self` everywhere; holds no buffers).
#[derive(Clone, Copy, Debug)]
pub struct RangeCompressor {
    cfg: RangeConfig,
    window: WindowEval,
    bin_spacing_m: f64,
    unambiguous_path_m: f64,
}

impl RangeCompressor {
    /// Validates `cfg`.
    ///
    /// # Errors
    /// * `OutOfRange` `config.bandwidth_hz` (not finite and > 0), `config.zero_pad` (not 1, 2, 4),
    ///   `config.mode.min_power` (not finite and > 0), `window.nbar` / `window.sll_db`;
    /// * `UnsupportedLength` `config.n_subcarriers` (not a power of two in 64 … 4096) or
    ///   `config.n_subcarriers · zero_pad` (above 4096).
    pub fn new(cfg: RangeConfig) -> Result<Self, DspError> {
        if !(cfg.bandwidth_hz.is_finite() && cfg.bandwidth_hz > 0.0) {
            return Err(DspError::OutOfRange {
                what: "config.bandwidth_hz",
                value: cfg.bandwidth_hz as f32,
            });
        }
        check_fft_len("config.n_subcarriers", cfg.n_subcarriers)?;
        if !matches!(cfg.zero_pad, 1 | 2 | 4) {
            return Err(DspError::OutOfRange {
                what: "config.zero_pad",
                value: cfg.zero_pad as f32,
            });
        }
        check_fft_len(
            "config.n_subcarriers · zero_pad",
            cfg.n_subcarriers * cfg.zero_pad,
        )?;
        if let RangeMode::ZeroForcing { min_power } = cfg.mode {
            if !(min_power.is_finite() && min_power > 0.0) {
                return Err(DspError::OutOfRange {
                    what: "config.mode.min_power",
                    value: min_power,
                });
            }
        }
        let window = cfg.window.eval()?;
        Ok(Self {
            cfg,
            window,
            bin_spacing_m: ofdm::range_bin_spacing_m(cfg.bandwidth_hz, cfg.zero_pad)?,
            unambiguous_path_m: ofdm::unambiguous_path_m(cfg.bandwidth_hz, cfg.n_subcarriers)?,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &RangeConfig {
        &self.cfg
    }

    /// Number of subcarriers `n` (length of `Y`, `S` and the prepared reference).
    pub fn n_subcarriers(&self) -> usize {
        self.cfg.n_subcarriers
    }

    /// Length of a range profile, `n · zero_pad`.
    pub fn profile_len(&self) -> usize {
        self.cfg.n_subcarriers * self.cfg.zero_pad
    }

    /// Profile bin spacing in metres of bistatic path length, `c/(B·zero_pad)`.
    pub fn bin_spacing_m(&self) -> f64 {
        self.bin_spacing_m
    }

    /// Unambiguous bistatic path length `c/Δf` in metres (the profile's extent).
    pub fn unambiguous_path_m(&self) -> f64 {
        self.unambiguous_path_m
    }

    /// Writes the window weights this compressor applies, per subcarrier in FFT order: the
    /// configured window with the unused Nyquist subcarrier (index `n/2`) set to 0 (before the
    /// `1/Σw` normalisation and before zero-forcing drops). A simulator tabulating the compressed
    /// pulse `Σ_k w_k·e^{j2π s_k x/N}/Σw` should use exactly these weights.
    ///
    /// # Errors
    /// `LengthMismatch` (`weights`: length `n`).
    pub fn fill_weights(&self, weights: &mut [f32]) -> Result<(), DspError> {
        check_len("weights", self.cfg.n_subcarriers, weights.len())?;
        for (k, w) in weights.iter_mut().enumerate() {
            *w = self.weight(k) as f32;
        }
        Ok(())
    }

    /// Window weight of subcarrier `k` (FFT order), 0 for the unused Nyquist subcarrier.
    fn weight(&self, k: usize) -> f64 {
        let n = self.cfg.n_subcarriers;
        if k == n / 2 {
            0.0
        } else {
            self.window.weight(k, n)
        }
    }

    /// Power correlation `|ρ_m|²` of the noise in profile bins `m` apart, written to
    /// `out[m − 1]` for `m = 1 ..= out.len()`: white noise of equal power on every subcarrier,
    /// weighted as [`Self::fill_weights`] and zero-padded, gives
    /// `ρ_m = Σ w_k²·e^{j2π·s_k·m/(n·zero_pad)} / Σ w_k²` (`s_k` the signed subcarrier offset). A
    /// detector whose training cells run along range needs it (`has_dsp::cfar`).
    pub fn noise_power_correlation(&self, out: &mut [f64]) {
        let n = self.cfg.n_subcarriers;
        let padded = (n * self.cfg.zero_pad) as f64;
        let sum_w2: f64 = (0..n).map(|k| self.weight(k) * self.weight(k)).sum();
        for (i, r) in out.iter_mut().enumerate() {
            let m = (i + 1) as f64;
            let (mut re, mut im) = (0.0f64, 0.0f64);
            for k in 0..n {
                let s = if k < n / 2 {
                    k as f64
                } else {
                    k as f64 - n as f64
                };
                let ph = core::f64::consts::TAU * s * m / padded;
                let w = self.weight(k);
                re += w * w * libm::cos(ph);
                im += w * w * libm::sin(ph);
            }
            *r = if sum_w2 > 0.0 {
                ((re * re + im * im) / (sum_w2 * sum_w2)).min(1.0)
            } else {
                0.0
            };
        }
    }

    /// Per-subcarrier filter `w_k·G_k` (before `1/Σw`) and whether the subcarrier is used.
    #[inline]
    fn filter(&self, k: usize, s: Complex<f64>) -> (Complex<f64>, f64) {
        let n = self.cfg.n_subcarriers;
        // The unpaired Nyquist subcarrier is not used (module docs).
        let w = if k == n / 2 {
            0.0
        } else {
            self.window.weight(k, n)
        };
        match self.cfg.mode {
            RangeMode::Matched => (s.conj() * w, w),
            RangeMode::ZeroForcing { min_power } => {
                let p = s.norm_sqr();
                if p <= min_power as f64 {
                    (Complex::new(0.0, 0.0), 0.0)
                } else {
                    (s.conj() * (w / p), w)
                }
            }
        }
    }

    /// `Σw` over the used subcarriers, after checking `S` (shared by both preparations).
    fn window_sum(&self, s: impl Iterator<Item = Complex<f64>>) -> Result<f64, DspError> {
        let mut sum = 0.0;
        for (k, sk) in s.enumerate() {
            if !(sk.re.is_finite() && sk.im.is_finite()) {
                return Err(DspError::NonFinite {
                    what: "reference symbol S",
                });
            }
            sum += self.filter(k, sk).1;
        }
        if sum > 0.0 {
            Ok(sum)
        } else {
            Err(DspError::OutOfRange {
                what: "reference symbol S (no subcarrier above min_power)",
                value: 0.0,
            })
        }
    }

    /// Prepares the `f32` reference `R_k = n·zero_pad·w_k·G_k/Σw` from the known symbol `s`.
    ///
    /// # Errors
    /// `LengthMismatch` (`s`, `reference`: length `n`); `NonFinite` (`reference symbol S`);
    /// `OutOfRange` if zero-forcing drops every subcarrier.
    pub fn prepare_reference(
        &self,
        s: &[Complex32],
        reference: &mut [Complex32],
    ) -> Result<(), DspError> {
        let n = self.cfg.n_subcarriers;
        check_len("s", n, s.len())?;
        check_len("reference", n, reference.len())?;
        let c64 = |z: &Complex32| Complex::new(z.re as f64, z.im as f64);
        let sum = self.window_sum(s.iter().map(c64))?;
        let gain = self.profile_len() as f64 / sum;
        for (k, (r, sk)) in reference.iter_mut().zip(s).enumerate() {
            let g = self.filter(k, c64(sk)).0 * gain;
            *r = Complex32::new(g.re as f32, g.im as f32);
        }
        Ok(())
    }

    /// Range-compresses one received symbol `y` with a reference from
    /// [`RangeCompressor::prepare_reference`] into `profile` (length [`Self::profile_len`]).
    ///
    /// # Errors
    /// `LengthMismatch` (`y`, `reference`: `n`; `profile`: `n·zero_pad`).
    pub fn compress(
        &self,
        y: &[Complex32],
        reference: &[Complex32],
        profile: &mut [Complex32],
    ) -> Result<(), DspError> {
        let n = self.cfg.n_subcarriers;
        check_len("y", n, y.len())?;
        check_len("reference", n, reference.len())?;
        check_len("profile", self.profile_len(), profile.len())?;
        place(
            n,
            self.cfg.zero_pad,
            profile,
            Complex32::new(0.0, 0.0),
            |k| y[k] * reference[k],
        );
        ifft_c32(profile)
    }

    /// Prepares the Q15 reference: writes `R_q` and returns its exponent `e_R`, with
    /// `R_q·2^e_R = w_k·G_k/Σw` and `max |R_q| ≤ 1 − 2⁻¹⁵` (module docs).
    ///
    /// # Errors
    /// As [`RangeCompressor::prepare_reference`].
    pub fn prepare_reference_q15(
        &self,
        s: &[CQ15],
        reference: &mut [CQ15],
    ) -> Result<i32, DspError> {
        let n = self.cfg.n_subcarriers;
        check_len("s", n, s.len())?;
        check_len("reference", n, reference.len())?;
        let c64 = |z: &CQ15| Complex::new(z.re.to_f32() as f64, z.im.to_f32() as f64);
        let sum = self.window_sum(s.iter().map(c64))?;
        let mut max = 0.0f64;
        for (k, sk) in s.iter().enumerate() {
            max = max.max(self.filter(k, c64(sk)).0.norm());
        }
        if max == 0.0 {
            reference.fill(Complex::new(Q15::ZERO, Q15::ZERO));
            return Ok(0);
        }
        // Smallest e with max/Σw · 2^−e ≤ 1 − 2⁻¹⁵.
        let limit = 1.0 - Q15::LSB as f64;
        let peak = max / sum;
        let mut e = libm::ceil(libm::log2(peak / limit)) as i32;
        while peak * libm::exp2(-e as f64) > limit {
            e += 1;
        }
        while peak * libm::exp2(-(e - 1) as f64) <= limit {
            e -= 1;
        }
        let scale = libm::exp2(-e as f64) / sum;
        for (k, (r, sk)) in reference.iter_mut().zip(s).enumerate() {
            let g = self.filter(k, c64(sk)).0 * scale;
            *r = Complex::new(Q15::from_f32(g.re as f32), Q15::from_f32(g.im as f32));
        }
        Ok(e)
    }

    /// Q15 range compression: `profile ← ifft(pad(Y·R_q))` with rounding and saturation; returns
    /// the exponent `e` with `P[m] = profile[m]·2^e` (module docs). `reference_exponent` is the
    /// value [`RangeCompressor::prepare_reference_q15`] returned.
    ///
    /// # Errors
    /// `LengthMismatch` as [`RangeCompressor::compress`]; `OutOfRange` (`reference_exponent`) if
    /// `reference_exponent + e_F` does not fit an `i32` (no reference this compressor prepares
    /// comes near; the check keeps a corrupted exponent from wrapping into a plausible one).
    pub fn compress_q15(
        &self,
        y: &[CQ15],
        reference: &[CQ15],
        reference_exponent: i32,
        profile: &mut [CQ15],
    ) -> Result<i32, DspError> {
        let n = self.cfg.n_subcarriers;
        check_len("y", n, y.len())?;
        check_len("reference", n, reference.len())?;
        check_len("profile", self.profile_len(), profile.len())?;
        place(
            n,
            self.cfg.zero_pad,
            profile,
            Complex::new(Q15::ZERO, Q15::ZERO),
            |k| cq15_mul(y[k], reference[k]),
        );
        let e = ifft_q15(profile, self.cfg.q15_scaling)?;
        e.checked_add(reference_exponent)
            .ok_or(DspError::OutOfRange {
                what: "reference_exponent",
                value: reference_exponent as f32,
            })
    }
}

/// Writes the zero-padded FFT-ordered spectrum `value(k)`, `k < n`, into `profile`
/// (length `n·p`, checked by the caller): offsets `0 … n/2 − 1` at the start, `−n/2 + 1 … −1` at
/// the end, zeros between (including the unused Nyquist slot).
#[inline]
fn place<T: Copy>(n: usize, p: usize, profile: &mut [T], zero: T, value: impl Fn(usize) -> T) {
    let m = n * p;
    let h = n / 2;
    let (front, rest) = profile.split_at_mut(h);
    for (k, z) in front.iter_mut().enumerate() {
        *z = value(k);
    }
    // `rest` starts at index h; offset −n/2 + 1 is at index m − n + h + 1, i.e. m − n + 1 in it.
    let (middle, tail) = rest.split_at_mut(m - n + 1);
    middle.fill(zero);
    for (z, k) in tail.iter_mut().zip(h + 1..n) {
        *z = value(k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::C_M_PER_S;

    const FC: f64 = 10e9;
    const B: f64 = 400e6;

    fn cfg(n: usize, zero_pad: usize, window: Window, mode: RangeMode) -> RangeConfig {
        RangeConfig {
            n_subcarriers: n,
            bandwidth_hz: B,
            zero_pad,
            mode,
            window,
            q15_scaling: Q15Scaling::Block,
        }
    }

    /// Deterministic unit-modulus QPSK-like symbol with random phases (fixed seed).
    fn symbol(n: usize, seed: u64) -> Vec<Complex<f64>> {
        let mut x = seed;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let ph = (x >> 11) as f64 / (1u64 << 53) as f64 * core::f64::consts::TAU;
                Complex::new(ph.cos(), ph.sin())
            })
            .collect()
    }

    /// Test-only echo of point scatterers (`Y = S·Σ a·e^{−j2π(fc + f_k)τ}`), in f64.
    fn echo(s: &[Complex<f64>], targets: &[(f64, Complex<f64>)]) -> Vec<Complex32> {
        let n = s.len();
        let df = B / n as f64;
        s.iter()
            .enumerate()
            .map(|(k, sk)| {
                let f = FC + ofdm::subcarrier_offset_hz(k, n, df);
                let h: Complex<f64> = targets
                    .iter()
                    .map(|&(r, a)| {
                        let ph = -core::f64::consts::TAU * ((f * (r / C_M_PER_S)) % 1.0);
                        a * Complex::new(ph.cos(), ph.sin())
                    })
                    .sum();
                let y = sk * h;
                Complex32::new(y.re as f32, y.im as f32)
            })
            .collect()
    }

    fn compress(rc: &RangeCompressor, s: &[Complex<f64>], y: &[Complex32]) -> Vec<Complex32> {
        let s32: Vec<Complex32> = s
            .iter()
            .map(|z| Complex32::new(z.re as f32, z.im as f32))
            .collect();
        let mut r = vec![Complex32::new(0.0, 0.0); rc.n_subcarriers()];
        rc.prepare_reference(&s32, &mut r).unwrap();
        let mut p = vec![Complex32::new(9.0, -9.0); rc.profile_len()];
        rc.compress(y, &r, &mut p).unwrap();
        p
    }

    fn argmax(p: &[Complex32]) -> usize {
        let mut best = 0;
        for (i, z) in p.iter().enumerate() {
            if z.norm() > p[best].norm() {
                best = i;
            }
        }
        best
    }

    fn wrap_phase(x: f64) -> f64 {
        let t = core::f64::consts::TAU;
        let y = x.rem_euclid(t);
        if y > core::f64::consts::PI {
            y - t
        } else {
            y
        }
    }

    #[test]
    fn noise_power_correlation_matches_the_closed_forms() {
        // Rectangular window, zero-padding 2, Nyquist subcarrier unused (n − 1 equal weights):
        // half a bin apart |ρ|² = |Σ_s e^{jπs/n}|²/(n−1)² → (2/π)²·(n/(n−1))² ≈ 4/π²; a whole
        // bin apart the sum of all n-th roots of unity but one leaves |ρ| = 1/(n − 1).
        let n = 256;
        let rc = RangeCompressor::new(cfg(n, 2, Window::Rectangular, RangeMode::Matched)).unwrap();
        let mut r = [0.0f64; 2];
        rc.noise_power_correlation(&mut r);
        assert!(
            (r[0] - 4.0 / core::f64::consts::PI.powi(2)).abs() < 1e-2,
            "{r:?}"
        );
        assert!(
            (r[1] - 1.0 / ((n - 1) * (n - 1)) as f64).abs() < 1e-9,
            "{r:?}"
        );
        // Hann, zero-padding 2: [0.820, 0.444, 0.151, 0.028] (the same sum evaluated
        // independently in double precision, natural subcarrier order, to 3 decimals).
        let rc = RangeCompressor::new(cfg(n, 2, Window::Hann, RangeMode::Matched)).unwrap();
        let mut r = [0.0f64; 4];
        rc.noise_power_correlation(&mut r);
        for (got, want) in r.iter().zip([0.820, 0.444, 0.151, 0.028]) {
            assert!((got - want).abs() < 2e-3, "{r:?}");
        }
    }

    #[test]
    fn weights_are_the_window_without_the_nyquist_subcarrier() {
        let window = Window::Taylor {
            nbar: 4,
            sll_db: -35.0,
        };
        let rc = RangeCompressor::new(cfg(64, 1, window, RangeMode::Matched)).unwrap();
        let mut w = vec![0.0f32; 64];
        let mut full = vec![0.0f32; 64];
        rc.fill_weights(&mut w).unwrap();
        window.fill_f32(&mut full).unwrap();
        assert_eq!(w[32], 0.0);
        assert!(full[32] > 0.1);
        for k in (0..64).filter(|&k| k != 32) {
            assert_eq!(w[k], full[k]);
        }
    }

    #[test]
    fn bin_spacing_and_unambiguous_path_come_from_ofdm() {
        let rc = RangeCompressor::new(cfg(1024, 4, Window::Hann, RangeMode::Matched)).unwrap();
        assert_eq!(rc.bin_spacing_m(), ofdm::range_bin_spacing_m(B, 4).unwrap());
        assert_eq!(
            rc.unambiguous_path_m(),
            ofdm::unambiguous_path_m(B, 1024).unwrap()
        );
        assert!(
            (rc.bin_spacing_m() * rc.profile_len() as f64 - rc.unambiguous_path_m()).abs() < 1e-6
        );
    }

    /// A unit point scatterer peaks within ½ bin of `r/dr`, with magnitude 1 on the bin grid
    /// (normalisation by Σw) for every window, and with phase `−2π fc τ`: the pulse is real and
    /// positive on its main lobe (module docs), so the phase at the peak is exact up to f32
    /// rounding — relative ≈ 1e-6 from the FFT and 6e-8 from casting Y — far below 1e-3 rad.
    #[test]
    fn point_scatterer_peaks_in_its_bin_with_unit_gain_and_carrier_phase() {
        let n = 256;
        let s = symbol(n, 0x1234_5678);
        for window in [
            Window::Rectangular,
            Window::Hann,
            Window::Taylor {
                nbar: 4,
                sll_db: -35.0,
            },
        ] {
            for zero_pad in [1usize, 2, 4] {
                let rc =
                    RangeCompressor::new(cfg(n, zero_pad, window, RangeMode::Matched)).unwrap();
                let dr = rc.bin_spacing_m();
                for frac_bin in [10.0, 37.25, 100.5, 131.0 + 1.0 / 3.0, 250.75] {
                    let m0 = frac_bin * zero_pad as f64;
                    let r = m0 * dr;
                    let p = compress(&rc, &s, &echo(&s, &[(r, Complex::new(1.0, 0.0))]));
                    let m = argmax(&p);
                    let d = (m as f64 - m0).abs();
                    let d = d.min(p.len() as f64 - d);
                    assert!(
                        d <= 0.5 + 1e-9,
                        "{window:?} ×{zero_pad}: r {r:.3} peak bin {m}, expected {m0}"
                    );
                    let peak = p[m];
                    let on_grid = (m0 - m0.round()).abs() < 1e-9;
                    if on_grid {
                        assert!(
                            (peak.norm() - 1.0).abs() < 1e-4,
                            "{window:?} ×{zero_pad}: on-grid peak {}",
                            peak.norm()
                        );
                    }
                    // Phase of the sample relative to the carrier term −2π fc τ.
                    let want = -core::f64::consts::TAU * ((FC * r / C_M_PER_S) % 1.0);
                    let err = wrap_phase(peak.arg() as f64 - want).abs();
                    let tol = 1e-3;
                    assert!(
                        err <= tol,
                        "{window:?} ×{zero_pad} r {r:.3}: phase error {err:.2e} > {tol:.2e}"
                    );
                }
            }
        }
    }

    /// The pulse is real and symmetric about the target for any target position: after removing
    /// the carrier phase the imaginary part is f32 rounding (≤ 1e-5 of the unit peak; FFT error
    /// ≈ 1e-6), and the profile is mirror-symmetric about an on-grid target to the same accuracy.
    #[test]
    fn pulse_is_real_and_symmetric() {
        let n = 128;
        let s = symbol(n, 99);
        for zero_pad in [1usize, 2, 4] {
            let window = Window::Taylor {
                nbar: 5,
                sll_db: -30.0,
            };
            let rc = RangeCompressor::new(cfg(n, zero_pad, window, RangeMode::Matched)).unwrap();
            for frac in [0.0, 0.3, 0.5] {
                let m0 = 40 * zero_pad;
                let r = (m0 as f64 + frac) * rc.bin_spacing_m();
                let p = compress(&rc, &s, &echo(&s, &[(r, Complex::new(1.0, 0.0))]));
                let ph = -core::f64::consts::TAU * ((FC * r / C_M_PER_S) % 1.0);
                let rot = Complex32::new((-ph).cos() as f32, (-ph).sin() as f32);
                let len = p.len();
                for i in 0..len {
                    let z = p[i] * rot;
                    assert!(
                        z.im.abs() < 1e-5,
                        "×{zero_pad} +{frac}: bin {i} imaginary {}",
                        z.im
                    );
                    if frac == 0.0 {
                        let mirror = p[(2 * m0 + len - i) % len] * rot;
                        assert!((z.re - mirror.re).abs() < 1e-5, "bin {i} not symmetric");
                    }
                }
            }
        }
    }

    /// Peak sidelobe level of the compressed profile (×4 padding). The pulse shape does not
    /// depend on where the target sits (it is `Σ_{|s|<n/2} w_s·e^{j2πsu/n}/Σw`), so stepping the
    /// target through 8 sub-sample positions (1/32 bin) samples the pulse on a 1/32-bin grid: a
    /// sidelobe top is missed by ≤ 1/64 bin, and with curvature ≤ 2π² per bin² (a sinc lobe has
    /// π²) the loss is ≤ 8.686·π²·(1/64)² = 0.021 dB. The peak is sampled exactly (on-grid target,
    /// magnitude 1). Dropping the Nyquist subcarrier and n = 512 samples move the continuous
    /// sidelobe levels by O(1/n) ≈ 0.02 dB. Hence measured ∈ textbook ± 0.05 dB: −13.26 dB (rect),
    /// −31.47 dB (Hann); for Taylor n̄ = 4, −35 dB the design level within its ±0.5 dB ripple.
    #[test]
    fn profile_sidelobes_match_window_textbook_levels() {
        let n = 512;
        let s = symbol(n, 7);
        for (window, lo, hi) in [
            (Window::Rectangular, -13.26 - 0.05, -13.26 + 0.05),
            (Window::Hann, -31.47 - 0.05, -31.47 + 0.05),
            (
                Window::Taylor {
                    nbar: 4,
                    sll_db: -35.0,
                },
                -35.5,
                -34.5,
            ),
        ] {
            let rc = RangeCompressor::new(cfg(n, 4, window, RangeMode::Matched)).unwrap();
            let m0 = 4 * 200;
            let mut peak = 0.0f64;
            let mut side = 0.0f64;
            for j in 0..8 {
                let r = (m0 as f64 + j as f64 / 8.0) * rc.bin_spacing_m();
                let p = compress(&rc, &s, &echo(&s, &[(r, Complex::new(1.0, 0.0))]));
                let mag: Vec<f64> = p.iter().map(|z| z.norm() as f64).collect();
                let len = mag.len() as isize;
                let mp = argmax(&p) as isize;
                if j == 0 {
                    peak = mag[mp as usize];
                }
                let at = |o: isize| mag[(mp + o).rem_euclid(len) as usize];
                // Walk to the first null on each side; everything beyond is sidelobe.
                let (mut right, mut left) = (1isize, 1isize);
                while at(right + 1) < at(right) {
                    right += 1;
                }
                while at(-left - 1) < at(-left) {
                    left += 1;
                }
                for o in right..len - left + 1 {
                    side = side.max(at(o));
                }
            }
            let psl = 20.0 * (side / peak).log10();
            std::eprintln!("{window:?}: compressed-profile PSL {psl:.3} dB");
            assert!(
                psl >= lo && psl <= hi,
                "{window:?}: PSL {psl:.3} dB not in [{lo}, {hi}]"
            );
        }
    }

    /// Zero forcing removes any symbol spectrum (here |S| between 0.2 and 1, one null subcarrier
    /// below `min_power`): a unit scatterer on a bin gives peak 1 (normalised by the used
    /// subcarriers' window sum). Matched filtering of the same data gives the window-weighted
    /// mean of |S|² instead.
    #[test]
    fn zero_forcing_normalises_any_symbol_and_drops_nulls() {
        let n = 256;
        let mut s = symbol(n, 5);
        for (k, z) in s.iter_mut().enumerate() {
            *z *= 0.2 + 0.8 * ((k * 37) % 101) as f64 / 100.0;
        }
        s[17] = Complex::new(1e-4, 0.0);
        let window = Window::Hann;
        let rc = RangeCompressor::new(cfg(
            n,
            2,
            window,
            RangeMode::ZeroForcing { min_power: 1e-6 },
        ))
        .unwrap();
        let m0 = 2 * 77;
        let r = m0 as f64 * rc.bin_spacing_m();
        let y = echo(&s, &[(r, Complex::new(1.0, 0.0))]);
        let p = compress(&rc, &s, &y);
        assert_eq!(argmax(&p), m0);
        assert!(
            (p[m0].norm() - 1.0).abs() < 1e-4,
            "ZF peak {}",
            p[m0].norm()
        );
        let rcm = RangeCompressor::new(cfg(n, 2, window, RangeMode::Matched)).unwrap();
        let pm = compress(&rcm, &s, &y);
        let mut w = vec![0.0f32; n];
        window.fill_f32(&mut w).unwrap();
        let want: f64 = w
            .iter()
            .zip(&s)
            .map(|(&w, z)| w as f64 * z.norm_sqr())
            .sum::<f64>()
            / w.iter().map(|&w| w as f64).sum::<f64>();
        assert!((pm[m0].norm() as f64 - want).abs() < 1e-4);
    }

    #[test]
    fn q15_path_peaks_in_the_same_bin_with_unit_gain() {
        let n = 256;
        let s = symbol(n, 3);
        let window = Window::Hann;
        let rc = RangeCompressor::new(cfg(n, 4, window, RangeMode::Matched)).unwrap();
        let m0 = 4 * 60;
        let y = echo(
            &s,
            &[(m0 as f64 * rc.bin_spacing_m(), Complex::new(0.5, 0.0))],
        );
        let yq: Vec<CQ15> = y.iter().map(|z| crate::fixed::cq15_from_c32(*z)).collect();
        let sq: Vec<CQ15> = s
            .iter()
            .map(|z| crate::fixed::cq15_from_c32(Complex32::new(z.re as f32, z.im as f32) * 0.999))
            .collect();
        let mut r = vec![CQ15::default(); n];
        let er = rc.prepare_reference_q15(&sq, &mut r).unwrap();
        let mut p = vec![CQ15::default(); rc.profile_len()];
        let e = rc.compress_q15(&yq, &r, er, &mut p).unwrap();
        let pf: Vec<Complex32> = p
            .iter()
            .map(|z| crate::fixed::cq15_to_c32(*z) * libm::exp2f(e as f32))
            .collect();
        assert_eq!(argmax(&pf), m0);
        // |a| = 0.5, |S| = 0.999 → peak 0.5·0.998; Q15 errors are ~1e-4 relative here.
        assert!(
            (pf[m0].norm() - 0.5 * 0.998).abs() < 2e-3,
            "peak {}",
            pf[m0].norm()
        );
    }

    #[test]
    fn bad_config_is_an_error_naming_the_field() {
        let good = cfg(256, 2, Window::Hann, RangeMode::Matched);
        let cases: [(RangeConfig, &str); 8] = [
            (
                RangeConfig {
                    bandwidth_hz: 0.0,
                    ..good
                },
                "config.bandwidth_hz",
            ),
            (
                RangeConfig {
                    bandwidth_hz: f64::NAN,
                    ..good
                },
                "config.bandwidth_hz",
            ),
            (
                RangeConfig {
                    n_subcarriers: 100,
                    ..good
                },
                "config.n_subcarriers",
            ),
            (
                RangeConfig {
                    n_subcarriers: 8192,
                    ..good
                },
                "config.n_subcarriers",
            ),
            (
                RangeConfig {
                    zero_pad: 3,
                    ..good
                },
                "config.zero_pad",
            ),
            (
                RangeConfig {
                    zero_pad: 0,
                    ..good
                },
                "config.zero_pad",
            ),
            (
                RangeConfig {
                    n_subcarriers: 2048,
                    zero_pad: 4,
                    ..good
                },
                "config.n_subcarriers · zero_pad",
            ),
            (
                RangeConfig {
                    mode: RangeMode::ZeroForcing { min_power: 0.0 },
                    ..good
                },
                "config.mode.min_power",
            ),
        ];
        for (c, field) in cases {
            let e = RangeCompressor::new(c).unwrap_err();
            let what = match e {
                DspError::OutOfRange { what, .. } | DspError::UnsupportedLength { what, .. } => {
                    what
                }
                other => panic!("unexpected {other:?}"),
            };
            assert_eq!(what, field);
        }
        let bad_window = RangeConfig {
            window: Window::Taylor {
                nbar: 0,
                sll_db: -35.0,
            },
            ..good
        };
        assert!(RangeCompressor::new(bad_window).is_err());
    }

    /// `e_R + e_F` is checked: an exponent near `i32::MAX` (or `MIN`) is an error naming
    /// `reference_exponent`, never a wrapped exponent.
    #[test]
    fn an_exponent_beyond_i32_range_is_an_error() {
        let rc = RangeCompressor::new(cfg(64, 1, Window::Hann, RangeMode::Matched)).unwrap();
        let one = Complex::new(Q15::from_f32(0.5), Q15::ZERO);
        let (y, r) = (vec![one; 64], vec![one; 64]);
        let mut p = vec![CQ15::default(); 64];
        // Block scaling of a DC input: the FFT's block exponent e_F is > 0 here.
        let e_f = rc.compress_q15(&y, &r, 0, &mut p).unwrap();
        assert!(e_f > 0, "e_F {e_f}");
        assert_eq!(rc.compress_q15(&y, &r, -e_f, &mut p), Ok(0));
        assert_eq!(
            rc.compress_q15(&y, &r, i32::MAX - e_f, &mut p),
            Ok(i32::MAX)
        );
        for bad in [i32::MAX, i32::MAX - e_f + 1] {
            let e = rc.compress_q15(&y, &r, bad, &mut p).unwrap_err();
            assert_eq!(
                e,
                DspError::OutOfRange {
                    what: "reference_exponent",
                    value: bad as f32
                }
            );
        }
        // e_F ≥ 0, so i32::MIN itself is fine: the sum stays in range.
        assert!(rc.compress_q15(&y, &r, i32::MIN, &mut p).is_ok());
    }

    #[test]
    fn bad_buffers_are_errors_not_panics() {
        let rc = RangeCompressor::new(cfg(64, 2, Window::Hann, RangeMode::Matched)).unwrap();
        let z = Complex32::new(1.0, 0.0);
        let (s, mut r, mut p) = (vec![z; 64], vec![z; 64], vec![z; 128]);
        let len_err = |e: DspError, field: &str| {
            assert!(
                matches!(e, DspError::LengthMismatch { what, .. } if what == field),
                "{e:?}"
            );
        };
        len_err(rc.prepare_reference(&s[..63], &mut r).unwrap_err(), "s");
        len_err(
            rc.prepare_reference(&s, &mut r[..10]).unwrap_err(),
            "reference",
        );
        len_err(rc.compress(&s[..1], &r, &mut p).unwrap_err(), "y");
        len_err(rc.compress(&s, &r[..1], &mut p).unwrap_err(), "reference");
        len_err(rc.compress(&s, &r, &mut p[..64]).unwrap_err(), "profile");
        let mut w = vec![0.0f32; 63];
        len_err(rc.fill_weights(&mut w).unwrap_err(), "weights");
        let mut nan = s.clone();
        nan[3] = Complex32::new(f32::NAN, 0.0);
        assert!(matches!(
            rc.prepare_reference(&nan, &mut r),
            Err(DspError::NonFinite { .. })
        ));
        let zf = RangeCompressor::new(cfg(
            64,
            1,
            Window::Hann,
            RangeMode::ZeroForcing { min_power: 0.5 },
        ))
        .unwrap();
        let tiny = vec![Complex32::new(0.1, 0.0); 64];
        assert!(matches!(
            zf.prepare_reference(&tiny, &mut r),
            Err(DspError::OutOfRange { .. })
        ));

        let q = CQ15::default();
        let (sq, mut rq, mut pq) = (vec![q; 64], vec![q; 64], vec![q; 128]);
        len_err(
            rc.prepare_reference_q15(&sq[..5], &mut rq).unwrap_err(),
            "s",
        );
        len_err(
            rc.prepare_reference_q15(&sq, &mut rq[..5]).unwrap_err(),
            "reference",
        );
        len_err(rc.compress_q15(&sq[..5], &rq, 0, &mut pq).unwrap_err(), "y");
        len_err(
            rc.compress_q15(&sq, &rq[..5], 0, &mut pq).unwrap_err(),
            "reference",
        );
        len_err(
            rc.compress_q15(&sq, &rq, 0, &mut pq[..5]).unwrap_err(),
            "profile",
        );
        assert!(matches!(
            zf.prepare_reference_q15(&sq, &mut rq),
            Err(DspError::OutOfRange { .. })
        ));
    }
}
