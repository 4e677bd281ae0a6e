//! Back-projection throughput and accuracy, one thread: `cargo run --release -p has-dsp
//! --example bp_throughput`.
//!
//! One snapshot of a 32 × 32 array (1024 profiles of 1024 bins, 400 MHz, zero padding ×2, three
//! point scatterers) into a 32³ grid of 0.25 m voxels, the transmitter ~70 m and the array
//! ~110 m from the grid (building scale). Prints backprojections (voxel × profile updates) per
//! second of thread CPU time (Linux `schedstat`, so other load on the machine does not count;
//! best of 3) and each path's image SER against the `f64` reference. The plain scalar loop
//! (`push_naive`) runs on the first 64 elements only and is compared on those.

use glam::Vec3;
use has_dsp::bp::{
    add_point_echo, ser_db, AccF32, AccQ15, Backprojector, BpConfig, Interp, PhaseEval, Snapshot,
    VoxelGrid,
};
use has_dsp::fixed::{cq15_block_from_c32, CQ15};
use num_complex::Complex;

/// CPU time of this thread in ns (falls back to wall time off Linux).
fn cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos() as u64)
        })
}

/// Best-of-`reps` seconds of `f`.
fn best_of(reps: usize, mut f: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = cpu_ns();
            f();
            (cpu_ns() - t) as f64 * 1e-9
        })
        .fold(f64::MAX, f64::min)
}

fn main() -> Result<(), has_dsp::DspError> {
    let lambda = 0.03f32;
    let res = 299_792_458.0 / 400e6;
    let dr = (res / 2.0) as f32;
    let bins = 1024;
    let mk = |phase| {
        Backprojector::new(BpConfig {
            grid: VoxelGrid {
                origin: Vec3::new(100.0, 200.0, 0.0),
                spacing: Vec3::splat(0.25),
                dims: [32, 32, 32],
            },
            wavelength_m: lambda,
            r0_m: 0.0,
            dr_m: dr,
            interp: Interp::Linear,
            phase,
        })
    };
    let bp = mk(PhaseEval::Poly)?;
    let nv = bp.voxels();
    let n_el = 1024;
    let tx = Vec3::new(-60.0, 40.0, 1.5);
    let rx: Vec<Vec3> = (0..n_el)
        .map(|k| {
            let (i, j) = ((k % 32) as f32, (k / 32) as f32);
            Vec3::new(80.0 + 0.015 * i, -70.0, 20.0 + 0.015 * j)
        })
        .collect();
    let pts = [
        Vec3::new(2.0, 3.0, 4.0),
        Vec3::new(5.0, 6.0, 1.0),
        Vec3::new(7.0, 1.0, 6.0),
    ];
    let mut profiles = vec![Complex::new(0.0f32, 0.0); n_el * bins];
    for (a, p) in rx.iter().zip(profiles.chunks_exact_mut(bins)) {
        for q in pts {
            let r = (q.distance(tx) + q.distance(*a)) as f64;
            let one = Complex::new(1.0, 0.0);
            add_point_echo(p, 0.0, dr as f64, lambda as f64, res, r, one)?;
        }
    }
    let v64 = |a: Vec3| [a.x as f64, a.y as f64, a.z as f64];
    let mut reference = vec![Complex::new(0.0f64, 0.0); nv];
    let mut reference_64 = vec![Complex::new(0.0f64, 0.0); nv];
    for (k, (a, p)) in rx.iter().zip(profiles.chunks_exact(bins)).enumerate() {
        bp.push_reference_f64(&mut reference, p, v64(tx), v64(*a))?;
        if k < 64 {
            bp.push_reference_f64(&mut reference_64, p, v64(tx), v64(*a))?;
        }
    }
    let updates = (nv * n_el) as f64;
    let snap = Snapshot {
        tx,
        rx: &rx,
        profiles: &profiles,
        profile_len: bins,
    };
    let mut img = vec![Complex::new(0.0f32, 0.0); nv];
    println!("one snapshot: {nv} voxels x {n_el} profiles of {bins} bins, one thread");
    for (name, phase) in [
        ("f32 (poly rotor)", PhaseEval::Poly),
        ("f32 (libm sincos)", PhaseEval::Libm),
    ] {
        let b = mk(phase)?;
        let s = best_of(3, || {
            let mut acc = AccF32::new(&b, &mut img).unwrap();
            b.push_snapshot(&mut acc, &snap).unwrap();
        });
        let ser = ser_db(&img, &reference)?;
        println!(
            "{name:20} {:8.1} M bp/s   SER {ser:5.1} dB",
            updates / s / 1e6
        );
    }

    let mut q = vec![CQ15::default(); n_el * bins];
    let mut exps = vec![0i32; n_el];
    for ((src, dst), e) in profiles
        .chunks_exact(bins)
        .zip(q.chunks_exact_mut(bins))
        .zip(exps.iter_mut())
    {
        *e = cq15_block_from_c32(src, dst)?;
    }
    let qsnap = Snapshot {
        tx,
        rx: &rx,
        profiles: &q,
        profile_len: bins,
    };
    let mut qbuf = vec![Complex::new(0i64, 0); nv];
    let s = best_of(3, || {
        let mut acc = AccQ15::new(&bp, &mut qbuf).unwrap();
        bp.push_snapshot_q15(&mut acc, &qsnap, &exps).unwrap();
        acc.to_image_f32(&mut img).unwrap();
    });
    let ser = ser_db(&img, &reference)?;
    println!(
        "{:20} {:8.1} M bp/s   SER {ser:5.1} dB",
        "Q15",
        updates / s / 1e6
    );

    let n_naive = 64;
    let s = best_of(1, || {
        let mut acc = AccF32::new(&bp, &mut img).unwrap();
        for (a, p) in rx[..n_naive].iter().zip(profiles.chunks_exact(bins)) {
            bp.push_naive(&mut acc, p, tx, *a).unwrap();
        }
    });
    let ser = ser_db(&img, &reference_64)?;
    let mut acc = AccF32::new(&bp, &mut img)?;
    let sub = Snapshot {
        rx: &rx[..n_naive],
        profiles: &profiles[..n_naive * bins],
        ..snap
    };
    bp.push_snapshot(&mut acc, &sub)?;
    let ser_fast = ser_db(&img, &reference_64)?;
    println!(
        "{:20} {:8.1} M bp/s   SER {ser:5.1} dB (first {n_naive} profiles; f32 path on those: {ser_fast:.1} dB)",
        "plain scalar loop",
        (nv * n_naive) as f64 / s / 1e6
    );
    Ok(())
}
