//! Throughput of the has-dsp kernels, one thread and all threads, with the accuracy of each
//! back-projection path against the `f64` reference.
//!
//! Rates are measured by repeating a kernel until at least `budget` seconds have passed
//! ([`budget`]); they are calls (FFTs, profiles) or voxel × profile updates per second of wall
//! time. Nothing here asserts a time; the rows are to read and compare (the plain scalar loop is
//! the baseline of the back-projection rows).

use std::time::Duration;

use glam::Vec3;
use has_dsp::bp::factorised::{grid_box, Factorisation, Factorised, Lattice};
use has_dsp::bp::{add_point_echo, ser_db, AccF32, AccQ15, Backprojector, BpConfig, Interp};
use has_dsp::bp::{PhaseEval, Snapshot, VoxelGrid};
use has_dsp::fft::{fft_c32, fft_q15, Q15Scaling};
use has_dsp::fixed::{cq15_block_from_c32, cq15_from_c32, CQ15};
use has_dsp::range::{RangeCompressor, RangeConfig, RangeMode};
use has_dsp::window::Window;
use has_dsp::DspError;
use num_complex::Complex;
use rayon::prelude::*;

use super::{pool, rate, BenchError};

type C32 = Complex<f32>;

/// The time each rate is measured over: 150 ms for a quick run, 1 s otherwise.
pub fn budget(quick: bool) -> Duration {
    Duration::from_millis(if quick { 150 } else { 1000 })
}

/// Deterministic complex white noise with components uniform in ±`amp` (a 64-bit LCG).
fn noise(n: usize, amp: f32, seed: u64) -> Vec<C32> {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    };
    (0..n)
        .map(|_| C32::new(next() * amp, next() * amp))
        .collect()
}

/// FFT-1024 rates, one thread.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FftRates {
    /// `f32` FFTs (microfft) per second.
    pub f32_per_s: f64,
    /// Q15 FFTs (radix-2, block floating point) per second.
    pub q15_per_s: f64,
}

/// FFT-1024 of white noise, `f32` and Q15 (block scaling), one thread, each over `budget`.
pub fn fft_1024(budget: Duration) -> Result<FftRates, BenchError> {
    let one = pool(1)?;
    let x = noise(1024, 0.5, 1);
    let mut buf = x.clone();
    let f32_per_s = one.install(|| {
        rate(budget, || {
            buf.copy_from_slice(&x);
            fft_c32(&mut buf).expect("1024 is supported");
        })
    });
    let xq: Vec<CQ15> = x.iter().map(|z| cq15_from_c32(*z)).collect();
    let mut bq = xq.clone();
    let q15_per_s = one.install(|| {
        rate(budget, || {
            bq.copy_from_slice(&xq);
            fft_q15(&mut bq, Q15Scaling::Block).expect("1024 is supported");
        })
    });
    Ok(FftRates {
        f32_per_s,
        q15_per_s,
    })
}

/// Range-compression rates, one thread.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RangeRates {
    /// `f32` profiles per second.
    pub f32_profiles_per_s: f64,
    /// Q15 profiles per second.
    pub q15_profiles_per_s: f64,
}

/// Range compression (matched), N = 1024 subcarriers at 400 MHz, Hann, zero-pad ×2 (2048-bin
/// profile), `f32` and Q15, one thread, each over `budget`.
pub fn range_compression(budget: Duration) -> Result<RangeRates, BenchError> {
    let one = pool(1)?;
    let rc = RangeCompressor::new(RangeConfig {
        n_subcarriers: 1024,
        bandwidth_hz: 400e6,
        zero_pad: 2,
        mode: RangeMode::Matched,
        window: Window::Hann,
        q15_scaling: Q15Scaling::Block,
    })?;
    let sym = noise(1024, 0.7, 7)
        .into_iter()
        .map(|z| z / z.norm().max(1e-6) * 0.7)
        .collect::<Vec<_>>();
    let mut reference = vec![C32::new(0.0, 0.0); 1024];
    rc.prepare_reference(&sym, &mut reference)?;
    let y = noise(1024, 0.25, 9);
    let mut profile = vec![C32::new(0.0, 0.0); rc.profile_len()];
    let f32_profiles_per_s = one.install(|| {
        rate(budget, || {
            rc.compress(&y, &reference, &mut profile)
                .expect("lengths checked")
        })
    });
    let symq: Vec<CQ15> = sym.iter().map(|z| cq15_from_c32(*z)).collect();
    let mut refq = vec![cq15_from_c32(C32::new(0.0, 0.0)); 1024];
    let e_r = rc.prepare_reference_q15(&symq, &mut refq)?;
    let yq: Vec<CQ15> = y.iter().map(|z| cq15_from_c32(*z)).collect();
    let mut profq = vec![cq15_from_c32(C32::new(0.0, 0.0)); rc.profile_len()];
    let q15_profiles_per_s = one.install(|| {
        rate(budget, || {
            rc.compress_q15(&yq, &refq, e_r, &mut profq)
                .expect("lengths checked");
        })
    });
    Ok(RangeRates {
        f32_profiles_per_s,
        q15_profiles_per_s,
    })
}

/// The back-projection case: a voxel grid 40 m from a square panel, a transmitter beside the
/// panel, and range-compressed echoes of a few point scatterers in the grid.
struct BpCase {
    bp: Backprojector,
    rx: Vec<Vec3>,
    tx: Vec3,
    profiles: Vec<C32>,
    profile_len: usize,
}

fn bp_case(
    dims: [usize; 3],
    elements_per_side: usize,
    phase: PhaseEval,
) -> Result<BpCase, DspError> {
    let lambda = 0.029_979_246_f32;
    let dr = 0.374_740_6_f32; // c/(B·2): B = 400 MHz, zero-pad 2
    let spacing = Vec3::splat(0.25);
    let origin = Vec3::new(40.0, -0.5 * dims[1] as f32 * 0.25, 0.0);
    let grid = VoxelGrid {
        origin,
        spacing,
        dims,
    };
    let bp = Backprojector::new(BpConfig {
        grid,
        wavelength_m: lambda,
        r0_m: 60.0,
        dr_m: dr,
        interp: Interp::Linear,
        phase,
    })?;
    let n = elements_per_side;
    let rx: Vec<Vec3> = (0..n * n)
        .map(|i| {
            let (r, c) = (i / n, i % n);
            grid.local(Vec3::new(
                0.0,
                (c as f32 - (n as f32 - 1.0) / 2.0) / n as f32,
                10.0 + (r as f32 - (n as f32 - 1.0) / 2.0) * 0.5 / n as f32,
            ))
        })
        .collect();
    let tx = grid.local(Vec3::new(5.0, 3.0, 1.5));
    let profile_len = 256;
    let scatterers = [
        origin + spacing * Vec3::new(3.0, 5.0, 2.0),
        origin + spacing * Vec3::new(dims[0] as f32 * 0.6, dims[1] as f32 * 0.3, 1.0),
        origin + spacing * Vec3::new(dims[0] as f32 * 0.5, dims[1] as f32 * 0.8, 3.0),
    ];
    let mut profiles = vec![C32::new(0.0, 0.0); rx.len() * profile_len];
    for (e, prof) in profiles.chunks_mut(profile_len).enumerate() {
        let rx_world = rx[e] + origin;
        let tx_world = tx + origin;
        for p in scatterers {
            let r = crate::bistatic_range(p, tx_world, rx_world) as f64;
            add_point_echo(
                prof,
                60.0,
                dr as f64,
                lambda as f64,
                2.0 * dr as f64,
                r,
                Complex::new(0.3, 0.0),
            )?;
        }
    }
    Ok(BpCase {
        bp,
        rx,
        tx,
        profiles,
        profile_len,
    })
}

impl BpCase {
    fn snapshot(&self) -> Snapshot<'_, C32> {
        Snapshot {
            tx: self.tx,
            rx: &self.rx,
            profiles: &self.profiles,
            profile_len: self.profile_len,
        }
    }

    fn backprojections(&self) -> f64 {
        (self.bp.voxels() * self.rx.len()) as f64
    }

    /// The profiles in block floating point, one exponent per profile
    /// ([`has_dsp::fixed::cq15_block_from_c32`]).
    fn q15_profiles(&self) -> Result<(Vec<CQ15>, Vec<i32>), DspError> {
        let mut q = vec![CQ15::default(); self.profiles.len()];
        let exps = self
            .profiles
            .chunks(self.profile_len)
            .zip(q.chunks_mut(self.profile_len))
            .map(|(p, d)| cq15_block_from_c32(p, d))
            .collect::<Result<Vec<_>, _>>()?;
        Ok((q, exps))
    }

    /// `f64` reference image of the whole snapshot (positions grid-local, as the kernels take).
    fn reference(&self) -> Result<Vec<Complex<f64>>, DspError> {
        let mut acc = vec![Complex::new(0.0, 0.0); self.bp.voxels()];
        let local = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
        for (e, prof) in self.profiles.chunks(self.profile_len).enumerate() {
            self.bp
                .push_reference_f64(&mut acc, prof, local(self.tx), local(self.rx[e]))?;
        }
        Ok(acc)
    }
}

/// The factorised paths the bench measures: name, subarray side, beam oversampling.
const FACTORISATIONS: [(&str, usize, usize); 5] = [
    ("factorised 4×4, O=8 (f32)", 4, 8),
    ("factorised 8×8, O=4 (f32)", 8, 4),
    ("factorised 8×8, O=8 (f32)", 8, 8),
    ("factorised 16×16, O=4 (f32)", 16, 4),
    ("factorised 16×16, O=8 (f32)", 16, 8),
];

/// One back-projection path: its rates and its accuracy.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BpRow {
    /// The path.
    pub name: &'static str,
    /// Voxel × profile updates per second, one thread.
    pub one_thread: f64,
    /// Voxel × profile updates per second, all of rayon's threads.
    pub all_threads: f64,
    /// Signal-to-error ratio of the image against the `f64` reference, dB.
    pub ser_db: f64,
    /// Signal-to-error ratio against the exact `f32` path (poly rotor), dB: the approximation
    /// of a factorised path (`None` for the exact paths).
    pub ser_vs_exact_db: Option<f64>,
}

/// Back-projection rates of the `f32` paths (polynomial rotor, libm sincos), the Q15 path
/// (interpolated table rotor, `i64` accumulators), the factorised paths (`FACTORISATIONS`: the
/// beam table built once per snapshot, its subarrays in parallel, then read by every tile; rates
/// in voxel × element updates, the table included) and the plain scalar loop (the baseline,
/// last), each over
/// `budget` with one thread and with all threads, on a 64 × 64 × 16 grid and a 32 × 32 panel
/// (quick: 32 × 32 × 8 and 16 × 16).
pub fn bp_rates(quick: bool, budget: Duration) -> Result<Vec<BpRow>, BenchError> {
    let dims = if quick { [32, 32, 8] } else { [64, 64, 16] };
    let side = if quick { 16 } else { 32 };
    let threads = rayon::current_num_threads();
    let one = pool(1)?;
    let mut rows = Vec::new();

    for (name, phase) in [
        ("f32 (poly rotor)", PhaseEval::Poly),
        ("f32 (libm sincos)", PhaseEval::Libm),
    ] {
        let case = bp_case(dims, side, phase)?;
        let snap = case.snapshot();
        let mut buf = vec![C32::new(0.0, 0.0); case.bp.voxels()];
        let run_tiles = |buf: &mut [C32]| {
            let tile = buf.len().div_ceil(threads * 4).max(1);
            buf.par_chunks_mut(tile).enumerate().try_for_each(
                |(i, chunk)| -> Result<(), DspError> {
                    let mut acc = AccF32::tile(&case.bp, i * tile, chunk)?;
                    case.bp.push_snapshot(&mut acc, &snap)
                },
            )
        };
        let r1 = one.install(|| rate(budget, || run_tiles(&mut buf).expect("validated case")));
        let rn = rate(budget, || run_tiles(&mut buf).expect("validated case"));
        let reference = case.reference()?;
        let ser = ser_db(&buf, &reference)?;
        rows.push(BpRow {
            name,
            one_thread: r1 * case.backprojections(),
            all_threads: rn * case.backprojections(),
            ser_db: ser,
            ser_vs_exact_db: None,
        });
    }

    {
        let case = bp_case(dims, side, PhaseEval::Poly)?;
        let (q, exps) = case.q15_profiles()?;
        let snap = Snapshot {
            tx: case.tx,
            rx: &case.rx,
            profiles: &q[..],
            profile_len: case.profile_len,
        };
        let mut buf = vec![Complex::<i64>::new(0, 0); case.bp.voxels()];
        let run_tiles = |buf: &mut [Complex<i64>]| {
            let tile = buf.len().div_ceil(threads * 4).max(1);
            buf.par_chunks_mut(tile).enumerate().try_for_each(
                |(i, chunk)| -> Result<(), DspError> {
                    let mut acc = AccQ15::tile(&case.bp, i * tile, chunk)?;
                    case.bp.push_snapshot_q15(&mut acc, &snap, &exps)
                },
            )
        };
        let r1 = one.install(|| rate(budget, || run_tiles(&mut buf).expect("validated case")));
        let rn = rate(budget, || run_tiles(&mut buf).expect("validated case"));
        // SER: one accumulation over the whole grid, converted to f32.
        let mut acc = AccQ15::new(&case.bp, &mut buf)?;
        case.bp.push_snapshot_q15(&mut acc, &snap, &exps)?;
        let mut img = vec![C32::new(0.0, 0.0); case.bp.voxels()];
        acc.to_image_f32(&mut img)?;
        let ser = ser_db(&img, &case.reference()?)?;
        rows.push(BpRow {
            name: "Q15 (interp. rotor, i64 acc)",
            one_thread: r1 * case.backprojections(),
            all_threads: rn * case.backprojections(),
            ser_db: ser,
            ser_vs_exact_db: None,
        });
    }

    // Factorised: the beam table is built once per snapshot (one thread) and read by every tile.
    {
        let case = bp_case(dims, side, PhaseEval::Poly)?;
        let snap = case.snapshot();
        let mut exact = vec![C32::new(0.0, 0.0); case.bp.voxels()];
        case.bp
            .push_snapshot(&mut AccF32::new(&case.bp, &mut exact)?, &snap)?;
        let exact64: Vec<Complex<f64>> = exact
            .iter()
            .map(|z| Complex::new(z.re as f64, z.im as f64))
            .collect();
        let reference = case.reference()?;
        let lattice = Lattice {
            first: case.rx[0],
            col_step: case.rx[1] - case.rx[0],
            row_step: case.rx[side] - case.rx[0],
            rows: side,
            cols: side,
        };
        let (lo, hi) = grid_box(case.bp.grid());
        for (name, sub, oversample) in FACTORISATIONS {
            if sub > side {
                continue;
            }
            let fact = Factorisation {
                sub_rows: sub,
                sub_cols: sub,
                oversample,
            };
            let f = Factorised::new(lattice, fact, case.bp.config().wavelength_m)?;
            let w = f.window_for_box(&case.bp, lo, hi, lattice.first, case.tx)?;
            let len = f.table_len(&w).ok_or(DspError::UnsupportedLength {
                what: "beam table",
                len: usize::MAX,
            })?;
            let mut table = vec![C32::new(0.0, 0.0); len];
            let per = f.subarray_table_len(&w).unwrap_or(len);
            let mut buf = vec![C32::new(0.0, 0.0); case.bp.voxels()];
            let mut run = |buf: &mut [C32]| -> Result<(), DspError> {
                // One subarray per task, each with its own scratch.
                table.par_chunks_mut(per).enumerate().try_for_each_init(
                    || vec![C32::new(0.0, 0.0); f.scratch_len(&w)],
                    |scratch, (k, part)| {
                        f.build_part(&w, &case.profiles, case.profile_len, k, part, scratch)
                    },
                )?;
                let table = &table;
                let tile = buf.len().div_ceil(threads * 4).max(1);
                buf.par_chunks_mut(tile)
                    .enumerate()
                    .try_for_each(|(i, chunk)| {
                        let mut acc = AccF32::tile(&case.bp, i * tile, chunk)?;
                        f.push(&case.bp, &mut acc, &w, table, lattice.first, case.tx)
                    })
            };
            let r1 = one.install(|| rate(budget, || run(&mut buf).expect("validated case")));
            let rn = rate(budget, || run(&mut buf).expect("validated case"));
            rows.push(BpRow {
                name,
                one_thread: r1 * case.backprojections(),
                all_threads: rn * case.backprojections(),
                ser_db: ser_db(&buf, &reference)?,
                ser_vs_exact_db: Some(ser_db(&buf, &exact64)?),
            });
        }
    }

    {
        let case = bp_case(dims, side, PhaseEval::Libm)?;
        let mut buf = vec![C32::new(0.0, 0.0); case.bp.voxels()];
        let run = |buf: &mut [C32]| -> Result<(), DspError> {
            let tile = buf.len().div_ceil(threads * 4).max(1);
            buf.par_chunks_mut(tile)
                .enumerate()
                .try_for_each(|(i, chunk)| {
                    let mut acc = AccF32::tile(&case.bp, i * tile, chunk)?;
                    for (e, prof) in case.profiles.chunks(case.profile_len).enumerate() {
                        case.bp.push_naive(&mut acc, prof, case.tx, case.rx[e])?;
                    }
                    Ok(())
                })
        };
        let r1 = one.install(|| rate(budget, || run(&mut buf).expect("validated case")));
        let rn = rate(budget, || run(&mut buf).expect("validated case"));
        let ser = ser_db(&buf, &case.reference()?)?;
        rows.push(BpRow {
            name: "plain scalar loop (reference)",
            one_thread: r1 * case.backprojections(),
            all_threads: rn * case.backprojections(),
            ser_db: ser,
            ser_vs_exact_db: None,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bp_path_runs_and_stays_close_to_the_reference() {
        let rows = bp_rates(true, Duration::from_millis(1)).unwrap();
        let names: Vec<_> = rows.iter().map(|r| r.name).collect();
        assert_eq!(
            names,
            [
                "f32 (poly rotor)",
                "f32 (libm sincos)",
                "Q15 (interp. rotor, i64 acc)",
                "factorised 4×4, O=8 (f32)",
                "factorised 8×8, O=4 (f32)",
                "factorised 8×8, O=8 (f32)",
                "factorised 16×16, O=4 (f32)",
                "factorised 16×16, O=8 (f32)",
                "plain scalar loop (reference)"
            ]
        );
        for r in &rows {
            assert!(r.one_thread > 0.0 && r.all_threads > 0.0, "{r:?}");
            // Exact paths: the f32 geometry bounds the SER near 70 dB. Factorised paths: their
            // approximation (module docs of `has_dsp::bp::factorised`), and their image's error
            // against f64 is that against the exact path.
            match r.ser_vs_exact_db {
                None => assert!(r.ser_db > 50.0, "{r:?}"),
                Some(s) => assert!(s > 5.0 && (r.ser_db - s).abs() < 1.0, "{r:?}"),
            }
        }
    }
}
