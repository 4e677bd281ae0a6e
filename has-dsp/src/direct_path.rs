//! The direct path's delay and phase in one frame: the reference a base station takes from the
//! terminal's line-of-sight echo, in `f32` and in Q15.
//!
//! **Why.** A terminal and a base station share no clock. Each frame that a base station receives
//! carries the pair's timing offset, carrier-frequency offset and local-oscillator phase on every
//! echo alike, the direct path included. The direct path is the strongest echo (20–40 dB above the
//! facades) and its geometry is known to within the terminal's position error, so its measured
//! delay and phase against the ones the geometry predicts give the frame's offsets: the
//! reference channel of passive radar and bistatic SAR. This module measures them; re-referencing
//! the frame and cancelling the path are the caller's.
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
//! 10⁻⁴ of a bin apart, where an `f32` sum's rounding would decide.
//!
//! Units: metres of bistatic path, radians, the data's amplitude units over the reference's.

use crate::error::{check_len, check_positive, DspError};
use crate::fixed::{cq15_mul_conj_wide, CQ15};
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

/// What the search needs of a sample type: `Y·conj(S)·e^{+j2πt}` for a phase word, and `|S|²`.
trait Sample: Copy {
    fn rotated(y: Self, s: Self, word: u32) -> C64;
    fn power(s: Self) -> f64;
}

impl Sample for C32 {
    #[inline]
    fn rotated(y: C32, s: C32, word: u32) -> C64 {
        let z = y * s.conj() * rotor_f32(word as f32 * (1.0 / 4_294_967_296.0));
        C64::new(z.re as f64, z.im as f64)
    }
    #[inline]
    fn power(s: C32) -> f64 {
        s.norm_sqr() as f64
    }
}

impl Sample for CQ15 {
    #[inline]
    fn rotated(y: CQ15, s: CQ15, word: u32) -> C64 {
        // Q30 × Q30 = Q60 (each product < 2⁶¹, their sum < 2⁶²), rounded to Q45 (< 2⁴⁷ a term);
        // scaled to the f32 path's units at the end. The rotor's phase word has 2²⁸ steps per
        // cycle.
        let z = cq15_mul_conj_wide(y, s);
        let (c, sn) = rotor_q30_word(word >> 4);
        let re = z.re as i64 * c as i64 - z.im as i64 * sn as i64;
        let im = z.re as i64 * sn as i64 + z.im as i64 * c as i64;
        let q45 = |v: i64| (v + (1 << 14)) >> 15;
        C64::new(q45(re) as f64, q45(im) as f64) * (1.0 / 35_184_372_088_832.0)
    }
    #[inline]
    fn power(s: CQ15) -> f64 {
        let (re, im) = (s.re.0 as f64, s.im.0 as f64);
        (re * re + im * im) * (1.0 / 1_073_741_824.0)
    }
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
            let signed = if k < n / 2 {
                k as i64
            } else {
                k as i64 - n as i64
            };
            acc += T::rotated(y[k], s[k], (signed as u32).wrapping_mul(u));
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
