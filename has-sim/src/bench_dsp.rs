//! `has-sim bench dsp`: prints the has-dsp kernel rates of [`has_host::bench::dsp`], one thread
//! and all threads, with the accuracy of each back-projection path against the `f64` reference
//! and its ratio against the plain scalar loop; `has-sim bench echo`: the echo-synthesis rates of
//! [`has_host::bench::echo`] against the plain one-path-at-a-time reference.

use anyhow::{Context, Result};
use has_host::bench::{dsp, echo};

/// Runs the DSP benchmark and prints its tables as each is measured.
pub fn run(quick: bool) -> Result<()> {
    let budget = dsp::budget(quick);
    let threads = rayon::current_num_threads();
    println!("has-sim bench dsp — {threads} threads available; rates over ≥ {budget:?} each");
    println!();

    let fft = dsp::fft_1024(budget)?;
    println!("FFT-1024, one thread");
    println!("  f32 (microfft)          {:>12.0} /s", fft.f32_per_s);
    println!(
        "  Q15 (radix-2, block fp) {:>12.0} /s   ({:.2}× f32)",
        fft.q15_per_s,
        fft.q15_per_s / fft.f32_per_s
    );
    println!();

    let rc = dsp::range_compression(budget)?;
    println!("Range compression, N = 1024, Hann, zero-pad ×2, one thread");
    println!(
        "  f32                     {:>12.0} profiles/s",
        rc.f32_profiles_per_s
    );
    println!(
        "  Q15                     {:>12.0} profiles/s   ({:.2}× f32)",
        rc.q15_profiles_per_s,
        rc.q15_profiles_per_s / rc.f32_profiles_per_s
    );
    println!();

    let rows = dsp::bp_rates(quick, budget).context("back-projection benchmark")?;
    let base = rows
        .iter()
        .find(|r| r.name.starts_with("plain"))
        .map(|r| r.one_thread)
        .unwrap_or(f64::NAN);
    println!(
        "Back-projection (voxel × element updates per second, a factorised path's table building \
         included; SER against the f64 reference and against the exact f32 path)"
    );
    println!(
        "  {:<30} {:>14} {:>9} {:>14} {:>9} {:>11}",
        "path",
        "1 thread",
        "× plain",
        format!("{threads} threads"),
        "SER dB",
        "vs exact dB"
    );
    for r in &rows {
        println!(
            "  {:<30} {:>14.3e} {:>9.2} {:>14.3e} {:>9.1} {:>11}",
            r.name,
            r.one_thread,
            r.one_thread / base,
            r.all_threads,
            r.ser_db,
            r.ser_vs_exact_db
                .map_or("—".to_string(), |s| format!("{s:.1}"))
        );
    }
    Ok(())
}

/// Runs the echo-synthesis benchmark and prints its table.
pub fn run_echo(quick: bool) -> Result<()> {
    let budget = dsp::budget(quick);
    let threads = rayon::current_num_threads();
    println!("has-sim bench echo — {threads} threads available; rates over ≥ {budget:?} each");
    let rep = echo::echo_rates(quick, budget).context("echo-synthesis benchmark")?;
    println!(
        "Echo synthesis: {} visible scatterers × {} elements, {} bins (scatterer × element pairs per second)",
        rep.scatterers, rep.elements, rep.bins
    );
    let base = rep.rows.last().map(|r| r.one_thread).unwrap_or(f64::NAN);
    println!(
        "  {:<30} {:>14} {:>9} {:>14}",
        "path",
        "1 thread",
        "× plain",
        format!("{threads} threads")
    );
    for r in &rep.rows {
        println!(
            "  {:<30} {:>14.3e} {:>9.2} {:>14.3e}",
            r.name,
            r.one_thread,
            r.one_thread / base,
            r.all_threads
        );
    }
    println!(
        "  largest |fast − plain| / peak: {:.1e}",
        rep.max_rel_difference
    );
    Ok(())
}
