//! Benchmarks: how fast the ray tracer, the has-dsp kernels, the channel-prediction tracer and
//! the screened Poisson solver run on fixed, seeded problems (`has-sim bench` prints them).
//!
//! These are measurements, not tests: nothing here asserts a time, and every figure depends on
//! the machine and on whatever else is running on it. Times are wall seconds unless named CPU
//! seconds (process user + system time, [`process_cpu_seconds`]); rates are items per second
//! (rays, segments, triangles, paths, FFTs, profiles, voxel × profile updates); accuracies are
//! dB (SER against an `f64` reference) or metres (√CD between meshes). Each measurement is one
//! function returning a typed, serialisable row or report:
//!
//! - [`raytrace`]: BVH build, closest-hit and visibility throughput on a deterministic city.
//! - [`paths`]: paths per second of the channel-prediction tracer.
//! - [`dsp`]: FFT-1024, range compression and back-projection rates with their SER.
//! - [`echo`]: echo-synthesis rates, the fast path against the plain one.
//! - [`mesh`]: screened Poisson with adaptive fine levels against full grids.
//! - [`twin_trace`]: channel tracing on a planar twin against the same site's Poisson mesh.

use std::time::{Duration, Instant};

pub mod dsp;
pub mod echo;
pub mod mesh;
pub mod paths;
pub mod raytrace;
pub mod twin_trace;

/// One measured line of a throughput table.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchRow {
    /// What was measured.
    pub name: String,
    /// Worker threads used.
    pub threads: usize,
    /// Items processed (rays, segments, builds, ...).
    pub count: usize,
    /// Wall time, seconds.
    pub seconds: f64,
    /// Items per second of wall time.
    pub per_second: f64,
    /// Process CPU time (user + system) spent, seconds, if the OS reports it (Linux).
    pub cpu_seconds: Option<f64>,
    /// A sanity figure (hit fraction, visible fraction, ...), free text.
    pub note: String,
}

impl BenchRow {
    /// A row of `count` items in `seconds` of wall time (CPU time unknown).
    pub fn new(name: &str, threads: usize, count: usize, seconds: f64, note: String) -> Self {
        BenchRow {
            name: name.into(),
            threads,
            count,
            seconds,
            per_second: count as f64 / seconds.max(1e-12),
            cpu_seconds: None,
            note,
        }
    }
}

/// Why a benchmark could not be run. Every variant prints its cause unchanged.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BenchError {
    /// A shape of a benchmark scene could not be built.
    #[error(transparent)]
    Shape(#[from] crate::shapes::ShapeError),
    /// A benchmark scene is not a valid scene.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// The channel-prediction tracer refused its input.
    #[error(transparent)]
    Paths(#[from] crate::paths::PathError),
    /// Echo synthesis refused its input.
    #[error(transparent)]
    Echo(#[from] crate::echo::EchoError),
    /// A has-dsp kernel refused its input.
    #[error(transparent)]
    Dsp(#[from] has_dsp::DspError),
    /// Sampling, normals, Poisson or the cloud comparison refused its input.
    #[error(transparent)]
    Geometry(#[from] crate::knn::GeometryError),
    /// A rayon thread pool could not be built.
    #[error(transparent)]
    ThreadPool(#[from] rayon::ThreadPoolBuildError),
    /// A benchmark's input (an option, a scenario value) is refused; the message names it.
    #[error("{0}")]
    Input(String),
}

/// Process CPU time (user + system), seconds, from `/proc/self/stat` (Linux; clock ticks assumed
/// 100 Hz, the Linux `USER_HZ`); `None` elsewhere. On a shared machine wall time includes waiting
/// for a core; CPU time does not, so `count / cpu_seconds` is the throughput per busy core.
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

/// Runs `work`, returning its result, wall seconds and CPU seconds (if known).
fn timed<T>(work: impl FnOnce() -> T) -> (T, f64, Option<f64>) {
    let c0 = process_cpu_seconds();
    let t = Instant::now();
    let out = work();
    let wall = t.elapsed().as_secs_f64();
    let cpu = c0.and_then(|c0| process_cpu_seconds().map(|c1| c1 - c0));
    (out, wall, cpu)
}

/// Runs `f` repeatedly for at least `budget` (after one warm-up call); returns calls per second.
fn rate(budget: Duration, mut f: impl FnMut()) -> f64 {
    f(); // warm up caches and lazy tables
    let start = Instant::now();
    let mut calls = 0u64;
    while start.elapsed() < budget {
        f();
        calls += 1;
    }
    calls as f64 / start.elapsed().as_secs_f64()
}

/// A rayon pool of `threads` workers.
fn pool(threads: usize) -> Result<rayon::ThreadPool, BenchError> {
    Ok(rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?)
}

#[cfg(test)]
mod tests {
    use super::timed;

    #[test]
    fn cpu_time_is_reported_and_non_negative_on_linux() {
        let (_, _, cpu) = timed(|| (0..20_000_000u64).fold(0u64, |a, b| a ^ b.wrapping_mul(b)));
        if cfg!(target_os = "linux") {
            assert!(cpu.unwrap() >= 0.0);
        }
    }
}
