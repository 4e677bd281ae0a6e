//! Q15 against f32 on the same random inputs: the radix-2 Q15 FFT (`has_dsp::fft`) and Q15 range
//! compression (`has_dsp::range`), each held to an SQNR bound derived from its arithmetic.
//!
//! ## The Q15 FFT noise bound (used by both tests)
//!
//! Work in LSBs of the output of the **always-scaled** transform (every one of the `ν = log₂N`
//! stages halves; output `DFT/N`). A stage computes `round((a·2¹⁵ ± w·b) / 2¹⁶)` from an exact
//! integer numerator: one rounding per output component. Its error has mean square ≤ 1/8 LSB²: 1/8
//! exactly when the numerator is a multiple of 2¹⁵ (trivial twiddles 1 and −j, error 0 or +½ with
//! equal odds), ≈ 1/12 otherwise. So each stage adds `σ_B² ≤ 2·1/8 = 1/4` LSB² per complex sample.
//! A later stage forms `(a ± w·b)/2` from two samples with independent noise: variance × 2/4 = ½.
//! Noise injected at stage `s` reaches the output scaled by `2^{−(ν−s)}`, so the output noise per
//! bin is `≤ ¼·Σ_{j<ν} 2^{−j} = ½·(1 − 2^{−ν})` LSB². The Q15 twiddles (±½ LSB per component,
//! `|δw| ≤ 2^{−15.5}`) perturb each stage by a relative `2^{−15.5}`; even adding coherently over
//! `ν` stages that is a relative error power `≤ ν²·2⁻³¹` (−72 dB at ν = 12), added as a term.
//! The f32 reference (microfft, relative error ~1e-6 = −120 dB) is exact at this scale.
//!
//! Block floating point never has a larger running exponent than always-scaling for inputs with
//! `|z| ≤ 1` (see `has_dsp::fft` docs), so it injects no more absolute noise: the same bound
//! applies to it.
//!
//! **Statistical allowance.** The bound is on the expected noise power; the measured power is an
//! average of `2N` squared errors (≈ independent), whose relative standard deviation is
//! `√(2/2N) = 1/√N`. The asserted bound allows 4 standard deviations: noise × `(1 + 4/√N)`.
//!
//! **White input at −6 dBFS** (components uniform in \[−½, ½), peak −6 dBFS): mean `|x|²` is
//! `2·(2¹⁴)²/3 = 1.79·10⁸` LSB², the always-scaled output has `|x|²/N` = 174 763 LSB² per bin
//! at N = 1024, against noise ≤ ½ LSB²: **SQNR ≥ 55.4 dB** (55.0 dB with the 4σ allowance).
//! The typical value is ~57 dB (most stages round at 1/12, not 1/8); block scaling does better.

use has_dsp::fft::{fft_c32, fft_q15, Complex32, Q15Scaling};
use has_dsp::fixed::{cq15_to_c32, CQ15, Q};
use has_dsp::range::{RangeCompressor, RangeConfig, RangeMode};
use has_dsp::window::Window;
use num_complex::Complex;
use proptest::prelude::*;
use proptest::test_runner::RngSeed;

type C64 = Complex<f64>;

fn config(cases: u32, seed: u64) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: RngSeed::Fixed(seed),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn cq15(re: i16, im: i16) -> CQ15 {
    Complex::new(Q(re), Q(im))
}

/// `(Σ|ref|², Σ|test − ref|²)`.
fn powers(reference: &[C64], test: &[C64]) -> (f64, f64) {
    reference
        .iter()
        .zip(test)
        .fold((0.0, 0.0), |(s, e), (r, t)| {
            (s + r.norm_sqr(), e + (t - r).norm_sqr())
        })
}

fn db(x: f64) -> f64 {
    10.0 * x.log10()
}

/// Output noise bound of an always-scaled ν-stage Q15 FFT in output LSB² per bin (module docs),
/// for a signal of `signal_lsb2` per bin: rounding plus twiddle terms.
fn fft_noise_bound_lsb2(nu: u32, signal_lsb2: f64) -> f64 {
    let nuf = nu as f64;
    0.5 * (1.0 - 2f64.powi(-(nu as i32))) + nuf * nuf * 2f64.powi(-31) * signal_lsb2
}

/// Inputs at −6 dBFS: components uniform integers in [−2¹⁴, 2¹⁴).
fn white_q15(n: usize) -> impl Strategy<Value = Vec<(i16, i16)>> {
    proptest::collection::vec((-16384i16..16384, -16384i16..16384), n)
}

fn sized_white() -> impl Strategy<Value = Vec<(i16, i16)>> {
    prop::sample::select(vec![64usize, 256, 1024, 4096]).prop_flat_map(white_q15)
}

proptest! {
    #![proptest_config(config(24, 0x0ff7_2024))]

    /// Q15 FFT (both scalings) against the f32 FFT of the same Q15 input: SQNR ≥ the derived
    /// bound for every N, and ≥ 55 dB at N = 1024 (module docs).
    #[test]
    fn q15_fft_matches_f32_within_sqnr_bound(x in sized_white()) {
        let n = x.len();
        let nu = n.trailing_zeros();
        let q: Vec<CQ15> = x.iter().map(|&(r, i)| cq15(r, i)).collect();
        let mut f: Vec<Complex32> = q.iter().map(|z| cq15_to_c32(*z)).collect();
        fft_c32(&mut f).unwrap();
        let want: Vec<C64> = f.iter().map(|z| C64::new(z.re as f64, z.im as f64)).collect();

        // Signal per bin in always-scaled output LSB²: Σ|x_lsb|²/N² (Parseval).
        let sig_lsb2 = x
            .iter()
            .map(|&(r, i)| (r as f64).powi(2) + (i as f64).powi(2))
            .sum::<f64>()
            / (n * n) as f64;
        let noise = fft_noise_bound_lsb2(nu, sig_lsb2) * (1.0 + 4.0 / (n as f64).sqrt());
        let bound_db = db(sig_lsb2 / noise);

        for scaling in [Q15Scaling::Always, Q15Scaling::Block] {
            let mut buf = q.clone();
            let e = fft_q15(&mut buf, scaling).unwrap();
            if scaling == Q15Scaling::Always {
                prop_assert_eq!(e, nu as i32);
            } else {
                prop_assert!(e <= nu as i32);
            }
            let scale = 2f64.powi(e);
            let got: Vec<C64> = buf
                .iter()
                .map(|z| {
                    let c = cq15_to_c32(*z);
                    C64::new(c.re as f64 * scale, c.im as f64 * scale)
                })
                .collect();
            let (s, err) = powers(&want, &got);
            let sqnr = db(s / err);
            prop_assert!(
                sqnr >= bound_db,
                "N = {}, {:?}: SQNR {:.2} dB < bound {:.2} dB", n, scaling, sqnr, bound_db
            );
            if n == 1024 {
                prop_assert!(sqnr >= 55.0, "N = 1024 {:?}: SQNR {:.2} dB < 55 dB", scaling, sqnr);
            }
        }
    }
}

/// A range-compression case: (n, zero_pad, window index, zero-forcing?, Y, S phases).
type RangeCase = (usize, usize, usize, bool, Vec<(i16, i16)>, Vec<u16>);

fn range_case() -> impl Strategy<Value = RangeCase> {
    (
        prop::sample::select(vec![64usize, 256, 1024]),
        prop::sample::select(vec![1usize, 2, 4]),
        0usize..3,
        any::<bool>(),
    )
        .prop_flat_map(|(n, p, w, zf)| {
            (
                Just(n),
                Just(p),
                Just(w),
                Just(zf),
                white_q15(n),
                proptest::collection::vec(any::<u16>(), n),
            )
        })
}

proptest! {
    #![proptest_config(config(24, 0x5a_2024))]

    /// Q15 range compression against f32 on the same Q15 `Y` (−6 dBFS white) and unit-modulus
    /// `S` (random phases, magnitude 0.999), for n = 64 … 1024, zero padding ×1/×2/×4, three
    /// windows, matched and zero-forcing, both FFT scalings.
    ///
    /// Bound, in LSBs of the always-scaled profile (`P = q·2^{ν+e_R}`, ν = log₂(n·zero_pad),
    /// M = n·zero_pad; `R_q·2^{e_R}` the reference, `Z = Y·R_q` in Q15):
    /// * per used subcarrier, `Z` is rounded once (1/12 LSB² per component → 1/6) and carries the
    ///   reference's rounding `Y·δR` (`|δR|² ≈ 1/6` LSB², `|Y|² ≤ ½` full scale → ≤ 1/12): ≤ ¼
    ///   LSB² per subcarrier, passed through the inverse's `(1/M)·Σ` as `n_used·¼/M²` per bin;
    /// * the inverse FFT's own rounding and twiddles: [`fft_noise_bound_lsb2`];
    /// * the f32 path (reference in f64 → f32, microfft) is exact at this scale.
    ///
    /// The signal is the f32 profile's mean power in the same LSBs. Allowance for the noise
    /// estimate: × (1 + 4/√n) (the input-side noise has only 2n degrees of freedom).
    #[test]
    fn q15_range_compression_matches_f32_within_sqnr_bound(
        (n, zero_pad, wi, zf, y, phases) in range_case()
    ) {
        let window = [
            Window::Rectangular,
            Window::Hann,
            Window::Taylor { nbar: 4, sll_db: -35.0 },
        ][wi];
        let mode = if zf {
            RangeMode::ZeroForcing { min_power: 1e-3 }
        } else {
            RangeMode::Matched
        };
        let s = unit_symbol(&phases);
        let yq: Vec<CQ15> = y.iter().map(|&(r, i)| cq15(r, i)).collect();
        for scaling in [Q15Scaling::Always, Q15Scaling::Block] {
            let (sqnr, bound_db) = range_sqnr(n, zero_pad, window, mode, scaling, &yq, &s);
            prop_assert!(
                sqnr >= bound_db,
                "n {} ×{} {:?} {:?} {:?}: SQNR {:.2} dB < bound {:.2} dB",
                n, zero_pad, window, mode, scaling, sqnr, bound_db
            );
        }
    }
}

/// Unit-modulus symbol (magnitude 0.999) from 16-bit phases.
fn unit_symbol(phases: &[u16]) -> Vec<CQ15> {
    phases
        .iter()
        .map(|&p| {
            let th = p as f64 / 65536.0 * std::f64::consts::TAU;
            let v = 0.999 * 32768.0;
            cq15((v * th.cos()).round() as i16, (v * th.sin()).round() as i16)
        })
        .collect()
}

/// Runs both range-compression paths on the same Q15 `y`, `s`; returns (SQNR of Q15 against
/// f32, derived bound), both in dB (bound derivation at the property test).
fn range_sqnr(
    n: usize,
    zero_pad: usize,
    window: Window,
    mode: RangeMode,
    scaling: Q15Scaling,
    yq: &[CQ15],
    s: &[CQ15],
) -> (f64, f64) {
    let sf: Vec<Complex32> = s.iter().map(|z| cq15_to_c32(*z)).collect();
    let yf: Vec<Complex32> = yq.iter().map(|z| cq15_to_c32(*z)).collect();
    let m = n * zero_pad;
    let nu = m.trailing_zeros();
    let mut reference_f = vec![Complex32::new(0.0, 0.0); n];
    let mut profile_f = vec![Complex32::new(0.0, 0.0); m];
    let mut reference_q = vec![CQ15::default(); n];
    let mut profile_q = vec![CQ15::default(); m];
    let rc = RangeCompressor::new(RangeConfig {
        n_subcarriers: n,
        bandwidth_hz: 400e6,
        zero_pad,
        mode,
        window,
        q15_scaling: scaling,
    })
    .unwrap();
    rc.prepare_reference(&sf, &mut reference_f).unwrap();
    rc.compress(&yf, &reference_f, &mut profile_f).unwrap();
    let e_r = rc.prepare_reference_q15(s, &mut reference_q).unwrap();
    let e = rc
        .compress_q15(yq, &reference_q, e_r, &mut profile_q)
        .unwrap();
    if scaling == Q15Scaling::Always {
        assert_eq!(e, nu as i32 + e_r);
    }
    let want: Vec<C64> = profile_f
        .iter()
        .map(|z| C64::new(z.re as f64, z.im as f64))
        .collect();
    let scale = 2f64.powi(e);
    let got: Vec<C64> = profile_q
        .iter()
        .map(|z| {
            let c = cq15_to_c32(*z);
            C64::new(c.re as f64 * scale, c.im as f64 * scale)
        })
        .collect();
    let (s_pow, err) = powers(&want, &got);
    // LSB of the always-scaled profile in true units, and the bound.
    let lsb = 2f64.powi(nu as i32 + e_r - 15);
    let sig_lsb2 = s_pow / m as f64 / (lsb * lsb);
    let n_used = (n - 1) as f64; // the Nyquist subcarrier is not used
    let noise = (n_used * 0.25 / (m * m) as f64 + fft_noise_bound_lsb2(nu, sig_lsb2))
        * (1.0 + 4.0 / (n as f64).sqrt());
    (db(s_pow / err), db(sig_lsb2 / noise))
}

/// Printed range-compression SQNR for the report (n = 1024, Hann, matched; `--nocapture`),
/// asserting the derived bound on one fixed input.
#[test]
fn q15_range_compression_sqnr_summary() {
    let n = 1024;
    let mut state = 0x0bad_cafe_f00d_1234u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let phases: Vec<u16> = (0..n).map(|_| (next() >> 48) as u16).collect();
    let s = unit_symbol(&phases);
    let y: Vec<CQ15> = (0..n)
        .map(|_| {
            cq15(
                ((next() >> 49) as i32 - (1 << 14)) as i16,
                ((next() >> 49) as i32 - (1 << 14)) as i16,
            )
        })
        .collect();
    for zero_pad in [1usize, 4] {
        for scaling in [Q15Scaling::Always, Q15Scaling::Block] {
            let (sqnr, bound) = range_sqnr(
                n,
                zero_pad,
                Window::Hann,
                RangeMode::Matched,
                scaling,
                &y,
                &s,
            );
            println!(
                "Q15 range compression n = 1024 ×{zero_pad}, Hann, matched, {scaling:?}: SQNR {sqnr:.2} dB (bound {bound:.2} dB)"
            );
            assert!(sqnr >= bound);
        }
    }
}

/// A printed summary (run with `--nocapture`): the SQNR achieved at N = 1024, −6 dBFS, for the
/// report. Asserts the same 55 dB as the property test, on one fixed input.
#[test]
fn q15_fft_1024_sqnr_summary() {
    let n = 1024;
    let mut state = 0x1234_5678_9abc_def1u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 49) as i32 - (1 << 14)) as i16 // uniform in [−2¹⁴, 2¹⁴)
    };
    let q: Vec<CQ15> = (0..n).map(|_| cq15(next(), next())).collect();
    let mut f: Vec<Complex32> = q.iter().map(|z| cq15_to_c32(*z)).collect();
    fft_c32(&mut f).unwrap();
    let want: Vec<C64> = f
        .iter()
        .map(|z| C64::new(z.re as f64, z.im as f64))
        .collect();
    for scaling in [Q15Scaling::Always, Q15Scaling::Block] {
        let mut buf = q.clone();
        let e = fft_q15(&mut buf, scaling).unwrap();
        let got: Vec<C64> = buf
            .iter()
            .map(|z| {
                let c = cq15_to_c32(*z);
                C64::new(c.re as f64, c.im as f64) * 2f64.powi(e)
            })
            .collect();
        let (s, err) = powers(&want, &got);
        let sqnr = db(s / err);
        println!("Q15 FFT-1024 at −6 dBFS, {scaling:?}: exponent {e}, SQNR {sqnr:.2} dB");
        assert!(sqnr >= 55.0);
    }
}
