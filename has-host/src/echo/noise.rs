//! Complex white Gaussian noise, one definition for every echo the crate synthesises (the
//! imaging frames, raw OFDM subcarriers, the moving target's frames).
//!
//! A sample is `n = (a + jb)·√(σ²/2)` with `a, b ~ N(0, 1)` independent, so `E|n|² = σ²`, the
//! noise power per complex sample (linear, the same units as `|signal|²`). Each receive element
//! draws from its own stream of one seeded ChaCha8 generator ([`noise_stream`]), so a frame's
//! noise does not depend on how its rows are scheduled over threads.

use num_complex::Complex32;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Complex Gaussian samples of a given power (module docs).
#[derive(Clone, Copy, Debug)]
pub struct ComplexGaussian {
    /// Standard deviation of each of the real and imaginary parts, `√(σ²/2)`.
    sd: f64,
}

impl ComplexGaussian {
    /// Samples of power `E|n|² = power` (linear; 0 gives zeros).
    pub fn with_power(power: f64) -> Self {
        Self {
            sd: (power / 2.0).sqrt(),
        }
    }

    /// Whether the samples are not all zero (`power > 0`).
    pub fn is_on(&self) -> bool {
        self.sd > 0.0
    }

    /// One sample from `rng` (two standard normal draws, real part first).
    pub fn sample(&self, rng: &mut impl Rng) -> Complex32 {
        let re: f64 = rng.sample(StandardNormal);
        let im: f64 = rng.sample(StandardNormal);
        Complex32::new((re * self.sd) as f32, (im * self.sd) as f32)
    }
}

/// The noise generator of receive element (or row) `stream` under `seed`: ChaCha8 seeded with
/// `seed`, on stream `stream`.
pub fn noise_stream(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn complex_noise_has_the_stated_power_split_evenly_between_its_parts() {
        let n = ComplexGaussian::with_power(4.0);
        let mut rng = noise_stream(7, 3);
        let k = 200_000;
        let (mut p, mut pr) = (0.0f64, 0.0f64);
        for _ in 0..k {
            let z = n.sample(&mut rng);
            p += z.norm_sqr() as f64;
            pr += (z.re as f64).powi(2);
        }
        let (p, pr) = (p / k as f64, pr / k as f64);
        // Standard error of the mean of |n|² (exponential, sd = σ²) over 2·10⁵ samples: 0.2 %.
        assert!((p / 4.0 - 1.0).abs() < 0.01, "power {p}");
        assert!((pr / 2.0 - 1.0).abs() < 0.02, "real part {pr}");
        assert!(!ComplexGaussian::with_power(0.0).is_on());
    }

    #[test]
    fn each_stream_is_its_own_and_repeats_under_its_seed() {
        let n = ComplexGaussian::with_power(1.0);
        let draw = |seed, stream| n.sample(&mut noise_stream(seed, stream));
        assert_eq!(draw(1, 0), draw(1, 0));
        assert_ne!(draw(1, 0), draw(1, 1));
        assert_ne!(draw(1, 0), draw(2, 0));
    }
}
