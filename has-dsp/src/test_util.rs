//! Helpers shared by the unit tests of this crate (compiled only for tests).

use num_complex::Complex;

/// The tests' 64-bit LCG (Knuth's MMIX constants): deterministic draws for a seed.
pub(crate) struct Lcg(pub u64);

impl Lcg {
    /// The next state.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0
    }

    /// A uniform in (0, 1] from the top 53 bits.
    pub fn unit(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    }
}

/// Deterministic complex samples with components uniform in [−a, a) ([`Lcg`]; the top 24 bits
/// as the fraction).
pub(crate) fn lcg_signal(seed: u64, n: usize, a: f32) -> Vec<Complex<f32>> {
    let mut g = Lcg(seed);
    let mut u = || ((g.next_u64() >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0;
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
