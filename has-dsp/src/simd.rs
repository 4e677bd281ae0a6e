//! Run-time choice of the vector extension for host-side loops that live outside this crate.
//!
//! A [`SimdJob`] is a piece of work whose `run` is `#[inline(always)]`, as are the functions it
//! calls in its hot loop. [`run_simd`] runs it inside a function compiled for AVX2 when the CPU has
//! it (x86-64, feature `std`), so its loops use 256-bit registers, and plainly otherwise. The
//! build differs in instruction selection only: Rust never contracts `a·b + c` into an FMA and
//! AVX2 does not enable FMA, so every IEEE operation and its order are the same and so are the
//! bits. Without `std` (firmware) the job runs plainly.

/// Work to be compiled for the widest vector extension available. Implement `run` with
/// `#[inline(always)]` (and the functions it calls in its loops likewise), or it is compiled once,
/// for the baseline target.
pub trait SimdJob {
    /// What the work returns.
    type Output;
    /// Does the work.
    fn run(self) -> Self::Output;
}

/// Runs `job` in an AVX2 build when the CPU has it, in the baseline build otherwise (module docs).
#[inline]
pub fn run_simd<J: SimdJob>(job: J) -> J::Output {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if std::is_x86_feature_detected!("avx2") {
        return avx2::run(job);
    }
    job.run()
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[allow(unsafe_code)]
mod avx2 {
    use super::SimdJob;

    /// Runs `job` compiled for AVX2. Only called after the CPU was found to have it.
    #[inline]
    pub(super) fn run<J: SimdJob>(job: J) -> J::Output {
        // SAFETY: `run_avx2` needs AVX2 and nothing else; `super::run_simd` checked the CPU.
        unsafe { run_avx2(job) }
    }

    #[target_feature(enable = "avx2")]
    unsafe fn run_avx2<J: SimdJob>(job: J) -> J::Output {
        job.run()
    }
}

#[cfg(test)]
mod tests {
    use super::{run_simd, SimdJob};

    struct Dot<'a>(&'a [f32], &'a [f32]);

    impl SimdJob for Dot<'_> {
        type Output = f32;
        #[inline(always)]
        fn run(self) -> f32 {
            self.0.iter().zip(self.1).map(|(a, b)| a * b).sum()
        }
    }

    #[test]
    fn the_dispatched_job_gives_the_bits_of_the_plain_one() {
        let a: Vec<f32> = (0..1000).map(|i| (i as f32 * 0.37).sin()).collect();
        let b: Vec<f32> = (0..1000).map(|i| (i as f32 * 0.11).cos() * 1e3).collect();
        let plain = Dot(&a, &b).run();
        assert_eq!(run_simd(Dot(&a, &b)).to_bits(), plain.to_bits());
    }
}
