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

/// Below this magnitude [`floor_small`] is exact: `2^51`.
pub(crate) const FLOOR_SMALL_MAX: f64 = 2_251_799_813_685_248.0;

/// `x.floor()` for `|x| <` [`FLOOR_SMALL_MAX`], equal to [`floor_fast`] there: `(x + 1.5·2^52) −
/// 1.5·2^52` rounds `x` to an integer (the sum lies in `[2^52, 2^53)`, where the spacing of `f64`
/// is 1), then one step down if that rounded up. No conversion and no branch, so a loop of it
/// vectorises on baseline x86-64.
#[inline(always)]
pub(crate) fn floor_small(x: f64) -> f64 {
    const M: f64 = 6_755_399_441_055_744.0;
    let t = (x + M) - M;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// Tabulated compressed pulse (see module docs).
#[derive(Clone, Debug)]
pub struct PulseKernel {
    /// Real parts of the taps, `(O + 1) × 2L`: row `φ` holds `p(j − (L − 1) − φ/O)` for
    /// `j = 0..2L` (struct of arrays: the deposit loop vectorises).
    table_re: Vec<f32>,
    /// Imaginary parts, laid out as `table_re`.
    table_im: Vec<f32>,
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
        let mut table_re = Vec::with_capacity((o + 1) * taps);
        let mut table_im = Vec::with_capacity((o + 1) * taps);
        for phi in 0..=o {
            for j in 0..taps {
                let q = (j as i64 - (half as i64 - 1)) * o as i64 - phi as i64;
                let v = p(q);
                table_re.push(v.re as f32);
                table_im.push(v.im as f32);
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
            table_re,
            table_im,
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
        if !Self::deposits(u) {
            return;
        }
        self.deposit_floored(row, u, floor_fast(u), c)
    }

    /// Whether [`Self::deposit`] places anything at `u`: finite, and within `±10^15` bins (beyond,
    /// far outside any profile; the `i64` conversions of the floors would saturate near `2^62`).
    #[inline(always)]
    pub(crate) fn deposits(u: f64) -> bool {
        u.is_finite() && u.abs() <= 1e15
    }

    /// [`Self::deposit`] given `fl = ⌊u⌋`, for a `u` that [`Self::deposits`].
    #[inline(always)]
    pub(crate) fn deposit_floored(&self, row: &mut [Complex32], u: f64, fl: f64, c: Complex32) {
        let (phi, t, first) = self.tap_phase(u, fl);
        let Some(span) = self.span(row.len(), phi, t, first) else {
            return;
        };
        let out = &mut row[span.start..span.start + span.a_re.len()];
        for (k, o) in out.iter_mut().enumerate() {
            let (re, im) = span.tap(k, c);
            o.re += re;
            o.im += im;
        }
    }

    /// [`Self::deposit_floored`] into a row held as separate real and imaginary parts (equally
    /// long), given the scatterer's [`Self::tap_phase`]: the same operations, in a layout whose
    /// loop needs no shuffles.
    #[inline(always)]
    pub(crate) fn deposit_split(
        &self,
        row_re: &mut [f32],
        row_im: &mut [f32],
        (phi, t, first): (u32, f32, i64),
        c: Complex32,
    ) {
        let Some(span) = self.span(row_re.len(), phi, t, first) else {
            return;
        };
        let n = span.a_re.len();
        let out_re = &mut row_re[span.start..span.start + n];
        let out_im = &mut row_im[span.start..span.start + n];
        for k in 0..n {
            let (re, im) = span.tap(k, c);
            out_re[k] += re;
            out_im[k] += im;
        }
    }

    /// Where a scatterer at `u` bins (floor `fl`) falls in the table: the sub-bin phase row `φ`,
    /// the weight `t` toward row `φ + 1`, and the row's first bin. Branch-free and in 32-bit
    /// conversions, so that a loop of it vectorises. `pos` lies in `[0, O]`; a floor beyond
    /// `±2³¹` saturates, which leaves such a scatterer outside every row as before.
    #[inline(always)]
    pub(crate) fn tap_phase(&self, u: f64, fl: f64) -> (u32, f32, i64) {
        let pos = (u - fl) * self.oversample as f64;
        let phi = (pos as i32).min(self.oversample as i32 - 1);
        let t = (pos - phi as f64) as f32;
        (phi as u32, t, fl as i32 as i64 - (self.half as i64 - 1))
    }

    /// The taps of a scatterer at [`Self::tap_phase`] `(phi, t, first)` that fall within a row of
    /// `len` bins.
    #[inline(always)]
    fn span(&self, len: usize, phi: u32, t: f32, first: i64) -> Option<TapSpan<'_>> {
        let phi = phi as usize;
        let taps = 2 * self.half;
        let len = len as i64;
        if first >= len || first + taps as i64 <= 0 {
            return None;
        }
        let j0 = (-first).max(0) as usize;
        let j1 = ((len - first) as usize).min(taps);
        let (a, b) = (phi * taps, (phi + 1) * taps);
        Some(TapSpan {
            start: (first + j0 as i64) as usize,
            a_re: &self.table_re[a + j0..a + j1],
            a_im: &self.table_im[a + j0..a + j1],
            b_re: &self.table_re[b + j0..b + j1],
            b_im: &self.table_im[b + j0..b + j1],
            s: 1.0 - t,
            t,
        })
    }
}

/// The taps one scatterer deposits: bins `start ..` of the row, the two adjacent sub-bin phases
/// of the table and the interpolation weights between them.
struct TapSpan<'a> {
    start: usize,
    a_re: &'a [f32],
    a_im: &'a [f32],
    b_re: &'a [f32],
    b_im: &'a [f32],
    s: f32,
    t: f32,
}

impl TapSpan<'_> {
    /// Tap `k` times `c`: `c · (a·s + b·t)`, the operations of `Complex32`'s `*`.
    #[inline(always)]
    fn tap(&self, k: usize, c: Complex32) -> (f32, f32) {
        let v_re = self.a_re[k] * self.s + self.b_re[k] * self.t;
        let v_im = self.a_im[k] * self.s + self.b_im[k] * self.t;
        (c.re * v_re - c.im * v_im, c.re * v_im + c.im * v_re)
    }
}

#[cfg(test)]
mod tests {
    use super::{floor_fast, floor_small, FLOOR_SMALL_MAX};

    #[test]
    fn the_branch_free_floor_is_the_floor_below_its_stated_bound() {
        let below = FLOOR_SMALL_MAX - 1.0;
        let mut xs = vec![0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.5, -2.5, 1e-300, -1e-300];
        xs.extend([
            0.999_999_999_999_999_9,
            -0.999_999_999_999_999_9,
            1e15 + 0.5,
            -1e15 - 0.5,
        ]);
        xs.extend([
            below,
            -below,
            below - 0.5,
            -below + 0.5,
            123_456.789,
            -987_654.321,
        ]);
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..10_000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let m = (s >> 11) as f64 / (1u64 << 53) as f64;
            let e = (s % 50) as i32;
            xs.push((m - 0.5) * 2f64.powi(e));
        }
        for x in xs {
            assert!(x.abs() < FLOOR_SMALL_MAX);
            let (a, b) = (floor_small(x), x.floor());
            assert_eq!(a, b, "floor_small({x:e})");
            assert_eq!(a.to_bits(), floor_fast(x).to_bits(), "floor_fast({x:e})");
        }
    }
}
