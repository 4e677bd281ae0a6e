//! Fixed point against float for the clutter cancellers (`has_dsp::eca`, `has_dsp::template`):
//! the Q15 and `f32` paths driven with the same random inputs, agreement asserted within bounds
//! derived from the arithmetic (see each test's comment).
//!
//! Notation: LSB = 2⁻¹⁵. Rounding a uniform-ish value to Q15 adds an error uniform in ±½ LSB per
//! component, variance LSB²/12 per component (≈ −101 dBFS for a full-scale component), i.e.
//! LSB²/6 per complex sample.

use has_dsp::eca::{Eca, EcaVariant, EcaWorkspace};
use has_dsp::fixed::{cq15_from_c32, cq15_to_c32, CQ15};
use has_dsp::template::{Template, TemplateQ15};
use num_complex::Complex;
use proptest::prelude::*;

type C32 = Complex<f32>;

const LSB: f64 = 1.0 / 32768.0;

/// Deterministic complex samples with components uniform in [−a, a) from a seed (64-bit LCG).
fn lcg_signal(seed: u64, n: usize, a: f32) -> Vec<C32> {
    let mut s = seed ^ 0x9E37_79B9_7F4A_7C15;
    let mut u = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    };
    (0..n).map(|_| C32::new(a * u(), a * u())).collect()
}

fn q(v: &[C32]) -> Vec<CQ15> {
    v.iter().map(|&z| cq15_from_c32(z)).collect()
}

fn f(v: &[CQ15]) -> Vec<C32> {
    v.iter().map(|&z| cq15_to_c32(z)).collect()
}

/// Mean squared difference per complex sample.
fn mse(a: &[C32], b: &[C32]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm_sqr() as f64)
        .sum::<f64>()
        / a.len() as f64
}

/// Largest per-component difference, in LSB.
fn max_diff_lsb(a: &[C32], b: &[C32]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| ((x.re - y.re).abs().max((x.im - y.im).abs())) as f64 / LSB)
        .fold(0.0, f64::max)
}

fn variant(choice: u8, batch: usize) -> EcaVariant {
    match choice % 3 {
        0 => EcaVariant::Block,
        1 => EcaVariant::Batched { batch },
        _ => EcaVariant::Sliding {
            batch,
            extra: batch / 2,
        },
    }
}

/// A surveillance channel: zero-Doppler clutter `Σ_k h_k x[n−k]` with `Σ|h_k| ≤ 0.9` plus a
/// "target + noise" part with components uniform in ±0.1, so every component stays below
/// 0.9·0.5·√2 + 0.1 < 0.75 (no Q15 saturation anywhere). Returns (reference, surveillance, Σ|h|²).
fn eca_inputs(seed: u64, n: usize, k: usize, ax: f32) -> (Vec<C32>, Vec<C32>, f64) {
    let x = lcg_signal(seed, n + k - 1, ax);
    let raw = lcg_signal(seed.wrapping_add(1), k, 1.0);
    let sum: f32 = raw.iter().map(|h| h.norm()).sum();
    let h: Vec<C32> = raw.iter().map(|v| v * (0.9 / sum)).collect();
    let r = lcg_signal(seed.wrapping_add(2), n, 0.1);
    let s: Vec<C32> = (0..n)
        .map(|i| (0..k).map(|j| h[j] * x[i + k - 1 - j]).sum::<C32>() + r[i])
        .collect();
    let h2 = h.iter().map(|v| v.norm_sqr() as f64).sum();
    (x, s, h2)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Same Q15 inputs to both paths, D = 1. The zero-Doppler basis is the reference itself in
    /// both paths, and with Q15-valued inputs every product is exact in f64 (30 significant bits)
    /// and the sums are exact below 2⁵³ (N·2³¹ ≪ 2⁵³), so both paths solve the *same* normal
    /// equations exactly as far as f64 goes. The outputs differ only by
    /// * the Q15 path's final rounding: ≤ ½ LSB per component;
    /// * the f32 path's `s − Σ w·b` in f32: K ≤ 8 operations each rounding at 2⁻²⁴ of a partial sum
    ///   below 1, plus the rounding of w to f32 (2⁻²⁴·Σ|w||b| < 2⁻²⁴): < 10·2⁻²⁴ ≈ 0.02 LSB;
    /// * f64 solve differences (none: same data, same order) and the block-floating-point weights
    ///   (relative 2⁻²⁹, < 0.001 LSB).
    ///
    /// Bound: 0.5 + 0.02 + 0.001 → assert ≤ 0.55 LSB per component.
    #[test]
    fn q15_eca_matches_f32_eca_on_the_same_q15_inputs_within_half_an_lsb(
        seed in any::<u64>(),
        k in 1usize..=8,
        ax in 0.2f32..0.5,
        choice in 0u8..3,
    ) {
        let n = 512;
        let (x, s, _) = eca_inputs(seed, n, k, ax);
        let (xq, sq) = (q(&x), q(&s));
        let (xf, sf) = (f(&xq), f(&sq));
        let eca = Eca::<8>::new(k, 1, variant(choice, 128), 0.0).unwrap();
        let mut ws = Box::new(EcaWorkspace::<8>::new());
        let mut out_f = vec![C32::new(0.0, 0.0); n];
        let mut out_q = vec![CQ15::default(); n];
        eca.cancel_f32(&mut ws, &xf, &sf, &mut out_f).unwrap();
        eca.cancel_q15(&mut ws, &xq, &sq, &mut out_q).unwrap();
        let d = max_diff_lsb(&f(&out_q), &out_f);
        prop_assert!(d <= 0.55, "max difference {} LSB", d);
    }

    /// Same *float* inputs; the Q15 path sees them rounded. Error sources of `out_q − out_f`
    /// (independent, each uniform ±½ LSB per component, σ² = LSB²/6 per complex sample):
    /// * rounding of s, passed by the projection almost entirely (a fraction M/L ≤ 24/256 is
    ///   removed): between (1 − M/L) and 1 times σ²;
    /// * rounding of x: the clutter `Σ h_k x[n−k]` is then off the Q15 basis by `Σ h_k q_x[n−k]`
    ///   (the d = 0 columns are the Q15 reference itself), power Σ|h_k|²·σ² (also projected);
    /// * output rounding: σ²;
    /// * weights re-estimated from the perturbed data: relative ≈ M/L of the above;
    /// * the d ≠ 0 columns (D = 3, used with ECA only) are rounded Q15 products x·p, so the basis
    ///   moves by E with σ_e² ≈ σ²(1 + |x|²). To first order the output changes by
    ///   `−P⊥E·w − X·G⁻¹·Eᴴy`, of power σ_e²·(Σ_{d≠0}|w_m|² + ‖y‖²/L·Σ_{d≠0}(G⁻¹)_mm). Over the
    ///   whole CPI the Doppler columns are orthogonal (G ≈ L·P_x·I) and w_{d≠0} is only the chance
    ///   fit of the ±0.1 part, so both terms are ≈ σ²·(P_r/P_x)·2K/L ≤ σ²·0.25·16/512 < 0.01·σ².
    ///   (With short ECA-B/ECA-S batches the Doppler columns are nearly collinear, Σ(G⁻¹)_mm grows
    ///   like the condition number and this term reaches several σ² for a weak reference — a real
    ///   property of the Q15 path, which is why Doppler columns are exercised here with ECA only
    ///   and batches use D = 1, as in the literature.)
    ///
    /// Expected per-sample error power E = σ²·(2 + Σ|h|²), −10 % for the projections; the sample
    /// mean over 2·512 component errors has a relative spread of ≈ 4 %. Assert
    /// 0.75·E ≤ mse ≤ 1.25·E.
    #[test]
    fn q15_eca_error_power_matches_the_input_and_output_rounding_budget(
        seed in any::<u64>(),
        k in 1usize..=8,
        ax in 0.2f32..0.5,
        choice in 0u8..3,
    ) {
        let n = 512;
        let (x, s, h2) = eca_inputs(seed, n, k, ax);
        let v = variant(choice, 256);
        let dopplers = if v == EcaVariant::Block { 3 } else { 1 };
        let eca = Eca::<24>::new(k, dopplers, v, 0.0).unwrap();
        let mut ws = Box::new(EcaWorkspace::<24>::new());
        let mut out_f = vec![C32::new(0.0, 0.0); n];
        let mut out_q = vec![CQ15::default(); n];
        eca.cancel_f32(&mut ws, &x, &s, &mut out_f).unwrap();
        eca.cancel_q15(&mut ws, &q(&x), &q(&s), &mut out_q).unwrap();
        let e = LSB * LSB / 6.0 * (2.0 + h2);
        let m = mse(&f(&out_q), &out_f);
        prop_assert!(m >= 0.75 * e && m <= 1.25 * e, "mse {:.3} of the budget", m / e);
    }

    /// Template subtraction, same Q15 inputs to both paths. The Q15 gain is the exact
    /// least-squares gain; the f32 path's correlations sum f32 products in chunks of 64 (error
    /// ≤ 64·2⁻²⁴ of Σ|t||y| ≤ ‖t‖‖y‖ per chunk sum, Cauchy–Schwarz), so its gain is off by
    /// |Δg| ≤ 3.8·10⁻⁶·‖y‖/‖t‖ ≤ 3.8·10⁻⁶·1.4 (template rms ≥ 0.2, |g| ≤ 1, rest rms ≤ 0.082)
    /// = 5.3·10⁻⁶, times |t[n]| ≤ 0.71: 3.8·10⁻⁶ = 0.12 LSB. Add the Q15 output rounding (½ LSB),
    /// the f32 residual's own rounding (≈ 2·2⁻²⁴ = 0.004 LSB) and the gain quantisation
    /// (2⁻²⁹ relative): ≤ 0.63 LSB per component. Assert ≤ 0.65 LSB.
    #[test]
    fn q15_template_subtraction_matches_f32_on_the_same_q15_inputs(
        seed in any::<u64>(),
        at in 0.25f32..0.5,
        g_mag in 0.0f32..1.0,
        g_phase in -std::f32::consts::PI..std::f32::consts::PI,
        bins in 16usize..600,
    ) {
        let t = lcg_signal(seed, bins, at);
        let g = C32::from_polar(g_mag, g_phase);
        let r = lcg_signal(seed.wrapping_add(7), bins, 0.1);
        let y: Vec<C32> = t.iter().zip(&r).map(|(tv, rv)| g * tv + rv).collect();
        let (tq, mut yq) = (q(&t), q(&y));
        let (tf, mut yf) = (f(&tq), f(&yq));
        Template::new(&tf, bins, 0.0).unwrap().subtract_in_place(&mut yf).unwrap();
        TemplateQ15::new(&tq, bins, 0.0).unwrap().subtract_in_place(&mut yq).unwrap();
        let d = max_diff_lsb(&f(&yq), &yf);
        prop_assert!(d <= 0.65, "max difference {} LSB", d);
    }

    /// The common (whole-block) fit, same Q15 inputs: the same bound as the per-frame fit, since
    /// the f32 path's correlation error is still ≤ 64·2⁻²⁴ of Σ|t||y| per chunk (chunks summed
    /// in f64 across frames) and the gain divides by F·‖t‖² against a numerator of F frames.
    /// Assert ≤ 0.65 LSB per component.
    #[test]
    fn q15_common_template_fit_matches_f32_on_the_same_q15_inputs(
        seed in any::<u64>(),
        at in 0.25f32..0.5,
        g_mag in 0.0f32..1.0,
        g_phase in -std::f32::consts::PI..std::f32::consts::PI,
        bins in 16usize..300,
        frames in 1usize..6,
    ) {
        let t = lcg_signal(seed, bins, at);
        let g = C32::from_polar(g_mag, g_phase);
        let r = lcg_signal(seed.wrapping_add(7), bins * frames, 0.1);
        let y: Vec<C32> = r.iter().enumerate().map(|(i, rv)| g * t[i % bins] + rv).collect();
        let (tq, mut yq) = (q(&t), q(&y));
        let (tf, mut yf) = (f(&tq), f(&yq));
        Template::new(&tf, bins, 0.0).unwrap().subtract_block_common(&mut yf).unwrap();
        TemplateQ15::new(&tq, bins, 0.0).unwrap().subtract_block_common(&mut yq).unwrap();
        let d = max_diff_lsb(&f(&yq), &yf);
        prop_assert!(d <= 0.65, "max difference {} LSB", d);
    }

    /// Template subtraction, same float inputs, Q15 path on the rounded ones. Error sources (each
    /// LSB²/6 per complex sample): rounding of y (passed except a 1/bins fraction), rounding of t
    /// scaled by the gain (|g|²·LSB²/6), output rounding; the gain's own error from the rounded
    /// data is ≈ 1/bins of those. E = LSB²/6·(2 + |g|²); with bins ≥ 256 the mean over ≥ 512
    /// component errors has ≈ 6 % relative spread. Assert 0.7·E ≤ mse ≤ 1.3·E.
    #[test]
    fn q15_template_error_power_matches_the_rounding_budget(
        seed in any::<u64>(),
        at in 0.25f32..0.5,
        g_mag in 0.0f32..1.0,
        g_phase in -std::f32::consts::PI..std::f32::consts::PI,
        bins in 256usize..1024,
    ) {
        let t = lcg_signal(seed, bins, at);
        let g = C32::from_polar(g_mag, g_phase);
        let r = lcg_signal(seed.wrapping_add(7), bins, 0.1);
        let mut yf: Vec<C32> = t.iter().zip(&r).map(|(tv, rv)| g * tv + rv).collect();
        let tq = q(&t);
        let mut yq = q(&yf);
        Template::new(&t, bins, 0.0).unwrap().subtract_in_place(&mut yf).unwrap();
        TemplateQ15::new(&tq, bins, 0.0).unwrap().subtract_in_place(&mut yq).unwrap();
        let e = LSB * LSB / 6.0 * (2.0 + (g_mag as f64).powi(2));
        let m = mse(&f(&yq), &yf);
        prop_assert!(m >= 0.7 * e && m <= 1.3 * e, "mse {:.3} of the budget", m / e);
    }
}
