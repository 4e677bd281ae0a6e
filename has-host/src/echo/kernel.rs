//! The compressed pulse `p(x)` of an OFDM frame, tabulated for direct profile synthesis.
//!
//! Range compression of a unit point scatterer at bistatic path `r_p` (subcarriers
//! `X[k] = e^{−j2π f_k r_p/c}` after `Y·conj(S)`, weights `w_k` in FFT order, zero-padded inverse
//! FFT of length `N = n·zero_pad`, divided by `Σ w_k`) gives at bin `i` (path `i·dr`)
//! `e^{−j2π fc r_p/c} · p(i − r_p/dr)` with
//!
//! `p(x) = Σ_k w_k · e^{+j2π s_k x / N} / Σ_k w_k`,   `s_k` the signed subcarrier index,
//!
//! `x` in profile bins. `p(0) = 1`; `p` is `N`-periodic. [`PulseKernel::new`] samples `p` with
//! one inverse FFT (rustfft, `f64`) of length `N·O` (`O` = oversampling, samples per bin), keeps
//! `2L` taps (`L` = half-width in bins) for each of the `O + 1` sub-bin phases, and
//! [`PulseKernel::deposit`] interpolates linearly between adjacent phases.
//!
//! Error of one deposited unit scatterer, per bin, against the exact `p`:
//! * interpolation ≤ `h²/8 · max|p''|` with `h = 1/O` and
//!   `|p''| ≤ (π/zero_pad)² · Σ|w|/|Σw|` (highest frequency `n/2` of `N`), so
//!   `ε_I = π² Σ|w| / (8 O² zero_pad² |Σw|)` ([`PulseKernel::interpolation_error`]);
//! * truncation: taps at `|x| ≥ L` are dropped; `ε_T = max_{L ≤ |x| ≤ N/2} |p(x)|`, measured on
//!   the fine grid plus `ε_I` ([`PulseKernel::truncation_error`]);
//! * `f32` storage of taps: ≤ 1.2e-7 relative.

use num_complex::{Complex32, Complex64};
use rustfft::FftPlanner;

use super::{EchoConfig, EchoError};

/// Largest fine-grid FFT length; the oversampling is reduced (and the stated error grows) to fit.
const MAX_FINE_LEN: usize = 1 << 22;

/// `x.floor()` for `|x| < 2^62` without a libm call (baseline x86-64 has no SSE4.1 `roundsd`,
/// and `floor` showed up at 8 % of synthesis time).
#[inline(always)]
pub(crate) fn floor_fast(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// Tabulated compressed pulse (see module docs).
#[derive(Clone, Debug)]
pub struct PulseKernel {
    /// Taps `(O + 1) × 2L`, row `φ` holding `p(j − (L − 1) − φ/O)` for `j = 0..2L`.
    table: Vec<Complex32>,
    half: usize,
    oversample: usize,
    truncation_error: f32,
    interpolation_error: f32,
}

impl PulseKernel {
    /// Tabulates the pulse of `cfg` (window, `n`, zero-padding, half-width, oversampling).
    ///
    /// # Errors
    /// As [`EchoConfig::validate`].
    pub fn new(cfg: &EchoConfig) -> Result<Self, EchoError> {
        cfg.validate()?;
        let n = cfg.n_subcarriers;
        let big_n = n * cfg.zero_pad;
        let mut o = cfg.kernel_oversample;
        while big_n * o > MAX_FINE_LEN && o > 1 {
            o /= 2;
        }
        let o = o.max(1);
        let m = big_n * o;
        let mut buf = vec![Complex64::new(0.0, 0.0); m];
        let mut sum_w = 0.0f64;
        let mut sum_abs = 0.0f64;
        for (k, &w) in cfg.window.iter().enumerate() {
            let s = if k < n / 2 {
                k as i64
            } else {
                k as i64 - n as i64
            };
            buf[s.rem_euclid(m as i64) as usize] = Complex64::new(w as f64, 0.0);
            sum_w += w as f64;
            sum_abs += (w as f64).abs();
        }
        FftPlanner::new().plan_fft_inverse(m).process(&mut buf);
        let scale = 1.0 / sum_w;
        // p at fine index q (x = q/O bins, periodic in m).
        let p = |q: i64| buf[q.rem_euclid(m as i64) as usize] * scale;
        let half = (cfg.kernel_half_width_cells * cfg.zero_pad)
            .min(big_n / 2)
            .max(1);
        let taps = 2 * half;
        let mut table = Vec::with_capacity((o + 1) * taps);
        for phi in 0..=o {
            for j in 0..taps {
                let q = (j as i64 - (half as i64 - 1)) * o as i64 - phi as i64;
                let v = p(q);
                table.push(Complex32::new(v.re as f32, v.im as f32));
            }
        }
        let interpolation_error = (std::f64::consts::PI.powi(2) * sum_abs
            / (8.0 * (o * o) as f64 * (cfg.zero_pad * cfg.zero_pad) as f64 * sum_w.abs()))
            as f32;
        let lo = (half * o) as i64;
        let hi = (m / 2) as i64;
        let mut trunc = 0.0f64;
        if lo <= hi {
            for q in lo..=hi {
                trunc = trunc.max(p(q).norm()).max(p(-q).norm());
            }
            trunc += interpolation_error as f64;
        }
        Ok(PulseKernel {
            table,
            half,
            oversample: o,
            truncation_error: trunc as f32,
            interpolation_error,
        })
    }

    /// Half-width `L` in profile bins (the kernel has `2L` taps).
    pub fn half_width_bins(&self) -> usize {
        self.half
    }

    /// Table samples per profile bin actually used (may be below the configured value for very
    /// long frames, see module docs).
    pub fn oversample(&self) -> usize {
        self.oversample
    }

    /// Largest magnitude of the dropped pulse tail (relative to the unit peak).
    pub fn truncation_error(&self) -> f32 {
        self.truncation_error
    }

    /// Bound on the linear-interpolation error (relative to the unit peak).
    pub fn interpolation_error(&self) -> f32 {
        self.interpolation_error
    }

    /// Bound on `|deposited − exact|` per bin for one scatterer of unit amplitude:
    /// truncation + interpolation + `f32` rounding of taps and accumulation.
    pub fn error_bound(&self) -> f32 {
        self.truncation_error + self.interpolation_error + 1e-6
    }

    /// Exact-as-tabulated pulse value at `x` bins (interpolated; 0 outside `±L`).
    pub fn eval(&self, x: f64) -> Complex32 {
        let mut row = [Complex32::new(0.0, 0.0); 1];
        // Deposit a unit scatterer at u = -x and read bin 0: bin 0 holds p(0 - u) = p(x).
        self.deposit(&mut row, -x, Complex32::new(1.0, 0.0));
        row[0]
    }

    /// Adds `c · p(i − u)` to `row[i]` for every bin within the kernel's reach (`u` in bins,
    /// relative to bin 0 of `row`).
    #[inline(always)]
    pub fn deposit(&self, row: &mut [Complex32], u: f64, c: Complex32) {
        if !u.is_finite() {
            return;
        }
        // |u| ≥ 2^62 would saturate the cast; such a scatterer is far outside any profile.
        if u.abs() > 1e15 {
            return;
        }
        let fl = floor_fast(u);
        let frac = u - fl;
        let pos = frac * self.oversample as f64;
        let phi = (pos as usize).min(self.oversample - 1);
        let t = (pos - phi as f64) as f32;
        let taps = 2 * self.half;
        let first = fl as i64 - (self.half as i64 - 1);
        let len = row.len() as i64;
        if first >= len || first + taps as i64 <= 0 {
            return;
        }
        let a = &self.table[phi * taps..(phi + 1) * taps];
        let b = &self.table[(phi + 1) * taps..(phi + 2) * taps];
        let s = 1.0 - t;
        let j0 = (-first).max(0) as usize;
        let j1 = ((len - first) as usize).min(taps);
        let start = (first + j0 as i64) as usize;
        let out = &mut row[start..start + (j1 - j0)];
        for ((o, &ta), &tb) in out.iter_mut().zip(&a[j0..j1]).zip(&b[j0..j1]) {
            let v = Complex32::new(ta.re * s + tb.re * t, ta.im * s + tb.im * t);
            *o += c * v;
        }
    }
}
