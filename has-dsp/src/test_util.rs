//! Helpers shared by the unit tests of this crate (compiled only for tests).

use num_complex::Complex;

/// Deterministic complex samples with components uniform in [−a, a) (64-bit LCG, Knuth's MMIX
/// constants; the top 24 bits as the fraction).
pub(crate) fn lcg_signal(seed: u64, n: usize, a: f32) -> Vec<Complex<f32>> {
    let mut s = seed;
    let mut u = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    };
    (0..n).map(|_| Complex::new(a * u(), a * u())).collect()
}

/// Σ|z|² in f64.
pub(crate) fn energy(v: &[Complex<f32>]) -> f64 {
    v.iter().map(|z| z.norm_sqr() as f64).sum()
}

/// A power ratio in dB.
pub(crate) fn db(x: f64) -> f64 {
    10.0 * x.log10()
}
