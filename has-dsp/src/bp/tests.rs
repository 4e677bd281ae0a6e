//! Unit tests of back-projection: focusing of analytic point echoes, equivalence of the batched,
//! tiled and single-profile entry points, fixed point against float, bad input.

use super::*;
use crate::fixed::Q15;

const LAMBDA: f32 = 0.03;
/// Range resolution (bistatic path length) c/B of a 1.5 GHz pulse, and two bins per resolution
/// cell (zero padding ×2).
const RES: f64 = 299_792_458.0 / 1.5e9;
const DR: f32 = (RES / 2.0) as f32;
const BINS: usize = 256;

fn config(interp: Interp, phase: PhaseEval) -> BpConfig {
    BpConfig {
        grid: VoxelGrid {
            origin: Vec3::new(100.0, -50.0, 2.0),
            spacing: Vec3::splat(0.3),
            dims: [8, 8, 8],
        },
        wavelength_m: LAMBDA,
        r0_m: 0.0,
        dr_m: DR,
        interp,
        phase,
    }
}

/// Transmitter positions: a 3 m horizontal virtual aperture along x, 4 m in front of the grid,
/// on the ground; grid-local metres.
fn tx_positions() -> Vec<Vec3> {
    (0..24)
        .map(|k| Vec3::new(-0.5 + 3.0 * k as f32 / 23.0, -4.0, 0.0))
        .collect()
}

/// Receiver elements: an 8 × 8 planar array in the x–z plane, 0.1 m pitch, elevated at z = 3 m.
fn rx_positions() -> Vec<Vec3> {
    let mut v = Vec::new();
    for iz in 0..8 {
        for ix in 0..8 {
            v.push(Vec3::new(
                0.6 + 0.1 * ix as f32,
                -5.0,
                3.0 + 0.1 * iz as f32,
            ));
        }
    }
    v
}

fn dist64(a: Vec3, b: [f64; 3]) -> f64 {
    let d = [a.x as f64 - b[0], a.y as f64 - b[1], a.z as f64 - b[2]];
    libm::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
}

fn v64(v: Vec3) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64]
}

/// Grid-local `f64` position of voxel `(ix, iy, iz)` of the test grid.
fn voxel64(bp: &Backprojector, c: [usize; 3]) -> [f64; 3] {
    let s = bp.grid().spacing;
    [
        s.x as f64 * c[0] as f64,
        s.y as f64 * c[1] as f64,
        s.z as f64 * c[2] as f64,
    ]
}

/// Profiles of one snapshot (element-major) for scatterers `(voxel coords, amplitude)`.
fn snapshot_profiles(
    bp: &Backprojector,
    tx: Vec3,
    rx: &[Vec3],
    targets: &[([usize; 3], f64)],
) -> Vec<Complex<f32>> {
    let mut out = vec![Complex::new(0.0, 0.0); rx.len() * BINS];
    for (a, prof) in rx.iter().zip(out.chunks_exact_mut(BINS)) {
        for &(c, amp) in targets {
            let p = voxel64(bp, c);
            let r = dist64(tx, p) + dist64(*a, p);
            add_point_echo(
                prof,
                0.0,
                DR as f64,
                LAMBDA as f64,
                RES,
                r,
                Complex::new(amp, 0.0),
            )
            .unwrap();
        }
    }
    out
}

fn image_f32(bp: &Backprojector, targets: &[([usize; 3], f64)]) -> Vec<Complex<f32>> {
    let rx = rx_positions();
    let mut buf = vec![Complex::new(0.0, 0.0); bp.voxels()];
    let mut acc = AccF32::new(bp, &mut buf).unwrap();
    for tx in tx_positions() {
        let profiles = snapshot_profiles(bp, tx, &rx, targets);
        let snap = Snapshot {
            tx,
            rx: &rx,
            profiles: &profiles,
            profile_len: BINS,
        };
        bp.push_snapshot(&mut acc, &snap).unwrap();
    }
    assert_eq!(acc.pushes(), (tx_positions().len() * rx.len()) as u64);
    buf
}

fn index(bp: &Backprojector, c: [usize; 3]) -> usize {
    let [nx, ny, _] = bp.grid().dims;
    c[0] + nx * (c[1] + ny * c[2])
}

fn argmax(img: &[Complex<f32>]) -> usize {
    let mut best = 0;
    for (i, z) in img.iter().enumerate() {
        if z.norm() > img[best].norm() {
            best = i;
        }
    }
    best
}

/// Each push adds, at the scatterer's own voxel, the sinc pulse read at most a quarter of a
/// resolution cell off its peak (two bins per cell: nearest is ≤ ½ bin off; linear between two
/// samples ≤ ½ bin off averages two values ≥ sinc(¼)) times a phase that cancels exactly, so
/// `|I| ≥ sinc(¼)·N·a = 0.9003·N·a` up to the f32 phase error (< 10⁻³ relative, see
/// `f32_matches_f64_reference_within_derived_ser`).
#[test]
fn point_scatterer_focuses_on_its_voxel() {
    let pushes = (tx_positions().len() * rx_positions().len()) as f32;
    for (interp, phase) in [
        (Interp::Linear, PhaseEval::Poly),
        (Interp::Nearest, PhaseEval::Libm),
    ] {
        let bp = Backprojector::new(config(interp, phase)).unwrap();
        for c in [[2, 3, 4], [5, 6, 1], [7, 0, 7], [0, 7, 0]] {
            let img = image_f32(&bp, &[(c, 1.0)]);
            let want = index(&bp, c);
            assert_eq!(
                argmax(&img),
                want,
                "{interp:?} {phase:?} scatterer at {c:?}"
            );
            let peak = img[want].norm() / pushes;
            assert!(peak >= 0.9003 * 0.999, "{interp:?}: peak/N = {peak}");
            assert!(peak <= 1.0 + 1e-3, "{interp:?}: peak/N = {peak}");
        }
    }
}

#[test]
fn three_point_scatterers_each_focus_at_a_local_maximum() {
    let bp = Backprojector::new(config(Interp::Linear, PhaseEval::Poly)).unwrap();
    let targets = [([2, 3, 4], 1.0), ([5, 6, 1], 0.7), ([6, 1, 6], 0.5)];
    let img = image_f32(&bp, &targets);
    assert_eq!(argmax(&img), index(&bp, targets[0].0));
    for (c, _) in targets {
        let v = img[index(&bp, c)].norm();
        for dz in -1i32..=1 {
            for dy in -1i32..=1 {
                for dx in -1i32..=1 {
                    let n = [c[0] as i32 + dx, c[1] as i32 + dy, c[2] as i32 + dz];
                    if n.iter().any(|&q| !(0..8).contains(&q)) || (dx, dy, dz) == (0, 0, 0) {
                        continue;
                    }
                    let nb = img[index(&bp, [n[0] as usize, n[1] as usize, n[2] as usize])];
                    assert!(nb.norm() < v, "neighbour {n:?} of {c:?} is brighter");
                }
            }
        }
    }
}

#[test]
fn snapshot_single_pushes_and_tiles_agree_bit_for_bit() {
    let bp = Backprojector::new(config(Interp::Linear, PhaseEval::Poly)).unwrap();
    let rx = rx_positions();
    let tx = tx_positions()[5];
    let profiles = snapshot_profiles(&bp, tx, &rx, &[([3, 3, 3], 1.0), ([1, 6, 2], 0.4)]);
    let snap = Snapshot {
        tx,
        rx: &rx,
        profiles: &profiles,
        profile_len: BINS,
    };
    let mut whole = vec![Complex::new(0.0, 0.0); bp.voxels()];
    let mut acc = AccF32::new(&bp, &mut whole).unwrap();
    bp.push_snapshot(&mut acc, &snap).unwrap();

    let mut single = vec![Complex::new(0.0, 0.0); bp.voxels()];
    let mut acc = AccF32::new(&bp, &mut single).unwrap();
    for (a, p) in rx.iter().zip(profiles.chunks_exact(BINS)) {
        bp.push(&mut acc, p, tx, *a).unwrap();
    }
    assert_eq!(whole, single);

    // Uneven tiles (not multiples of CHUNK nor of a grid row).
    let mut tiled = vec![Complex::new(0.0, 0.0); bp.voxels()];
    let mut first = 0;
    for t in tiled.chunks_mut(77) {
        let len = t.len();
        let mut acc = AccF32::tile(&bp, first, t).unwrap();
        bp.push_snapshot(&mut acc, &snap).unwrap();
        first += len;
    }
    assert_eq!(whole, tiled);
}

/// The AVX2 build of the kernels (chosen at run time on x86-64 with feature `std`) computes the
/// same bits as the baseline build, for every interpolation and phase path, f32 with and without
/// the power sum, and Q15. Without AVX2 on this CPU there is nothing to compare: the test says so.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[test]
fn the_avx2_build_gives_the_baseline_build_bit_for_bit() {
    if !kernel::avx2::available() {
        std::println!("no AVX2 on this CPU: only the baseline build runs");
        return;
    }
    let rx = rx_positions();
    let targets = [([3, 3, 3], 1.0), ([1, 6, 2], 0.4), ([7, 0, 5], 0.2)];
    for interp in [Interp::Linear, Interp::Nearest] {
        for phase in [PhaseEval::Poly, PhaseEval::Libm] {
            let bp = Backprojector::new(config(interp, phase)).unwrap();
            let n = bp.voxels();
            let zero = Complex::new(0.0f32, 0.0);
            let (mut a, mut b) = (vec![zero; n], vec![zero; n]);
            let (mut pa, mut pb) = (vec![0f32; n], vec![0f32; n]);
            let (mut qa, mut qb) = (
                vec![Complex::new(0i64, 0); n],
                vec![Complex::new(0i64, 0); n],
            );
            let mut q = vec![CQ15::default(); rx.len() * BINS];
            let mut exps = vec![0i32; rx.len()];
            for tx in tx_positions() {
                let profiles = snapshot_profiles(&bp, tx, &rx, &targets);
                let snap = Snapshot {
                    tx,
                    rx: &rx,
                    profiles: &profiles,
                    profile_len: BINS,
                };
                assert!(kernel::avx2::run_f32(&bp, 0, &mut a, &mut [], &snap));
                kernel::run_f32_portable(&bp, 0, &mut b, &mut [], &snap);
                assert!(kernel::avx2::run_f32(&bp, 0, &mut a, &mut pa, &snap));
                kernel::run_f32_portable(&bp, 0, &mut b, &mut pb, &snap);
                quantize_snapshot(&profiles, &mut q, &mut exps);
                let snap = Snapshot {
                    tx,
                    rx: &rx,
                    profiles: &q,
                    profile_len: BINS,
                };
                // Both builds get the same state exponent (the snapshot's largest).
                let top = exps.iter().copied().max().unwrap();
                assert!(kernel::avx2::run_q15(&bp, 0, &mut qa, top, &snap, &exps));
                kernel::run_q15_portable(&bp, 0, &mut qb, top, &snap, &exps);
            }
            let bits = |v: &[Complex<f32>]| {
                v.iter()
                    .map(|z| (z.re.to_bits(), z.im.to_bits()))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&a), bits(&b), "{interp:?} {phase:?}");
            assert!(a.iter().any(|z| z.norm() > 0.0));
            let pbits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(pbits(&pa), pbits(&pb), "{interp:?} {phase:?}");
            assert_eq!(qa, qb, "{interp:?} {phase:?}");
            assert!(qa.iter().any(|z| z.re != 0));
        }
    }
}

/// `push_snapshot_with_power` leaves the image exactly as `push_snapshot` does, and its power
/// buffer is, voxel by voxel, the sum over snapshots of each snapshot's own image power (each
/// snapshot imaged alone into a fresh accumulator), to f32 rounding.
#[test]
fn snapshot_power_is_the_sum_of_each_snapshots_own_image_power() {
    let bp = Backprojector::new(config(Interp::Linear, PhaseEval::Poly)).unwrap();
    let rx = rx_positions();
    let targets = [([3, 3, 3], 1.0), ([1, 6, 2], 0.4)];
    let n = bp.voxels();
    let (mut plain, mut with, mut power) = (
        vec![Complex::new(0.0, 0.0); n],
        vec![Complex::new(0.0, 0.0); n],
        vec![0f32; n],
    );
    let mut expected = vec![0f64; n];
    {
        let mut a = AccF32::new(&bp, &mut plain).unwrap();
        // Uneven tiles for the power path: the buffer follows its tile.
        let mut tiles: Vec<(AccF32<'_>, &mut [f32])> = Vec::new();
        let (mut rest, mut prest): (&mut [Complex<f32>], &mut [f32]) = (&mut with, &mut power);
        let mut first = 0;
        while !rest.is_empty() {
            let len = rest.len().min(77);
            let (h, t) = rest.split_at_mut(len);
            let (ph, pt) = prest.split_at_mut(len);
            tiles.push((AccF32::tile(&bp, first, h).unwrap(), ph));
            (rest, prest, first) = (t, pt, first + len);
        }
        for tx in tx_positions() {
            let profiles = snapshot_profiles(&bp, tx, &rx, &targets);
            let snap = Snapshot {
                tx,
                rx: &rx,
                profiles: &profiles,
                profile_len: BINS,
            };
            bp.push_snapshot(&mut a, &snap).unwrap();
            for (acc, p) in tiles.iter_mut() {
                bp.push_snapshot_with_power(acc, p, &snap).unwrap();
            }
            let mut alone = vec![Complex::new(0.0, 0.0); n];
            let mut acc = AccF32::new(&bp, &mut alone).unwrap();
            bp.push_snapshot(&mut acc, &snap).unwrap();
            for (e, z) in expected.iter_mut().zip(&alone) {
                *e += z.norm_sqr() as f64;
            }
        }
    }
    assert_eq!(plain, with);
    let peak = expected.iter().copied().fold(0.0, f64::max);
    assert!(peak > 0.0);
    for (p, e) in power.iter().zip(&expected) {
        assert!((*p as f64 - e).abs() <= 1e-5 * peak, "{p} vs {e}");
    }
    // A point scatterer is focused across the receive array in every snapshot: at its voxel
    // the snapshot power is the image power over the number of snapshots (|Σ_k J_k|² = K·Σ|J_k|²
    // for equal J_k), within the phase drift of the target across the aperture.
    let i = index(&bp, [3, 3, 3]);
    let k = tx_positions().len() as f64;
    let ratio = with[i].norm_sqr() as f64 / power[i] as f64;
    assert!(
        ratio > 0.9 * k && ratio <= k * (1.0 + 1e-4),
        "{ratio} vs {k}"
    );
    let mut bad = vec![0f32; 3];
    let mut acc = AccF32::new(&bp, &mut plain).unwrap();
    let profiles = snapshot_profiles(&bp, tx_positions()[0], &rx, &targets);
    let snap = Snapshot {
        tx: tx_positions()[0],
        rx: &rx,
        profiles: &profiles,
        profile_len: BINS,
    };
    assert!(matches!(
        bp.push_snapshot_with_power(&mut acc, &mut bad, &snap),
        Err(DspError::LengthMismatch { .. })
    ));
}

/// Sum over the test aperture of `|s_p(voxel)|` per voxel, in f64 (linear interpolation of
/// `|profile|`): the worst-case scale of per-update relative errors at each voxel.
fn magnitude_sums(bp: &Backprojector, rx: &[Vec3], targets: &[([usize; 3], f64)]) -> Vec<f64> {
    let mut m = vec![0.0f64; bp.voxels()];
    for tx in tx_positions() {
        let profiles = snapshot_profiles(bp, tx, rx, targets);
        for (a, prof) in rx.iter().zip(profiles.chunks_exact(BINS)) {
            for (i, mi) in m.iter_mut().enumerate() {
                let c = bp.grid().coords(i).unwrap();
                let p = voxel64(bp, c);
                let x = (dist64(tx, p) + dist64(*a, p)) / DR as f64;
                let fl = libm::floor(x);
                let at = |j: f64| {
                    prof.get(j as usize)
                        .filter(|_| j >= 0.0)
                        .map_or(0.0, |z| z.norm() as f64)
                };
                *mi += at(fl).max(at(fl + 1.0));
            }
        }
    }
    m
}

fn image_f64(bp: &Backprojector, targets: &[([usize; 3], f64)]) -> Vec<Complex<f64>> {
    let rx = rx_positions();
    let mut img = vec![Complex::new(0.0, 0.0); bp.voxels()];
    for tx in tx_positions() {
        let profiles = snapshot_profiles(bp, tx, &rx, targets);
        for (a, p) in rx.iter().zip(profiles.chunks_exact(BINS)) {
            bp.push_reference_f64(&mut img, p, v64(tx), v64(*a))
                .unwrap();
        }
    }
    img
}

/// Worst-case per-update relative error of the f32 path at these ranges (r ≤ 14 m, λ = 3 cm):
/// `r_V`, `r_R` each ≤ 2 ulp (squares, sum, sqrt) and their sum ½ ulp: |δr| ≤ 3·ulp(8 m)... ≤
/// 3·9.5·10⁻⁷ m → 2π·δr/λ ≤ 6·10⁻⁴ rad; `t = r/λ` (correctly rounded) adds ½ ulp(467) ≤ 1.6·10⁻⁵
/// cycles = 10⁻⁴ rad; the rotor 2·10⁻⁶ (poly) or ~10⁻⁷ (libm); interpolation weights and
/// the complex multiply a few 10⁻⁷; f32 summation of N = 1536 terms ≤ N·2⁻²⁴ ≈ 9·10⁻⁵.
/// Total ε ≤ 10⁻³. The image error at voxel v is then ≤ ε·M(v), M(v) = Σ_p |s_p(v)|, so
/// SER ≥ 10·log10(Σ|I_ref|² / (ε²·Σ M²)).
#[test]
fn f32_matches_f64_reference_within_derived_ser() {
    let targets = [([2, 3, 4], 1.0), ([5, 6, 1], 0.7), ([6, 1, 6], 0.5)];
    for (interp, phase) in [
        (Interp::Linear, PhaseEval::Poly),
        (Interp::Linear, PhaseEval::Libm),
        (Interp::Nearest, PhaseEval::Poly),
    ] {
        let bp = Backprojector::new(config(interp, phase)).unwrap();
        let img = image_f32(&bp, &targets);
        let reference = image_f64(&bp, &targets);
        let m = magnitude_sums(&bp, &rx_positions(), &targets);
        let sig: f64 = reference.iter().map(|z| z.norm_sqr()).sum();
        let eps = 1e-3;
        let bound = 10.0 * libm::log10(sig / (eps * eps * m.iter().map(|x| x * x).sum::<f64>()));
        let ser = ser_db(&img, &reference).unwrap();
        assert!(
            ser >= bound,
            "{interp:?} {phase:?}: SER {ser:.1} dB < bound {bound:.1} dB"
        );
        std::println!("{interp:?} {phase:?}: SER {ser:.1} dB (worst-case bound {bound:.1} dB)");
    }
}

#[test]
fn naive_loop_matches_fast_path() {
    // Same samples, same formulas in the same order (positions spacing·index, squares summed
    // x + y + z, sqrt, r_R + r_V, t = r/λ, libm rotor, s0·(1 − w) + s1·w, complex product,
    // accumulation) except the fractional bin: naive divides by dr, the fast path multiplies by
    // a rounded 1/dr, so x differs by ≤ 1.5 ulp(x) ≤ 1.5·2⁻¹⁶ (x < 256) and so do the weights;
    // the interpolated sample then differs by ≤ 2.3·10⁻⁵·(|s0| + |s1|) ≤ 5·10⁻⁵·max(|s0|, |s1|)
    // (also where floor(x) differs: the interpolant is continuous). With ε = 5·10⁻⁵ and
    // M(v) = Σ_p max(|s0|, |s1|): SER ≥ 10·log10(Σ|I|² / (ε²·Σ M²)).
    let bp = Backprojector::new(config(Interp::Linear, PhaseEval::Libm)).unwrap();
    let targets = [([2, 3, 4], 1.0)];
    let rx = &rx_positions()[..8];
    let mut fast = vec![Complex::new(0.0, 0.0); bp.voxels()];
    let mut naive = vec![Complex::new(0.0, 0.0); bp.voxels()];
    {
        let mut af = AccF32::new(&bp, &mut fast).unwrap();
        let mut an = AccF32::new(&bp, &mut naive).unwrap();
        for tx in tx_positions() {
            let profiles = snapshot_profiles(&bp, tx, rx, &targets);
            for (a, p) in rx.iter().zip(profiles.chunks_exact(BINS)) {
                bp.push(&mut af, p, tx, *a).unwrap();
                bp.push_naive(&mut an, p, tx, *a).unwrap();
            }
        }
    }
    let reference: Vec<Complex<f64>> = naive
        .iter()
        .map(|z| Complex::new(z.re as f64, z.im as f64))
        .collect();
    let m = magnitude_sums(&bp, rx, &targets);
    let sig: f64 = reference.iter().map(|z| z.norm_sqr()).sum();
    let eps = 5e-5;
    let bound = 10.0 * libm::log10(sig / (eps * eps * m.iter().map(|x| x * x).sum::<f64>()));
    let ser = ser_db(&fast, &reference).unwrap();
    assert!(
        ser >= bound,
        "fast vs naive SER {ser:.1} dB < {bound:.1} dB"
    );
}

fn quantize(p: &[Complex<f32>], out: &mut [CQ15]) -> i32 {
    crate::fixed::cq15_block_from_c32(p, out).unwrap()
}

/// Each element's profile of a snapshot (`BINS` bins each) to Q15 with its block exponent.
fn quantize_snapshot(profiles: &[Complex<f32>], q: &mut [CQ15], exps: &mut [i32]) {
    for ((p, qp), e) in profiles
        .chunks_exact(BINS)
        .zip(q.chunks_exact_mut(BINS))
        .zip(exps.iter_mut())
    {
        *e = quantize(p, qp);
    }
}

#[test]
fn q15_path_focuses_and_matches_f32() {
    let bp = Backprojector::new(config(Interp::Linear, PhaseEval::Poly)).unwrap();
    let targets = [([2, 3, 4], 1.0), ([5, 6, 1], 0.7)];
    let rx = rx_positions();
    let mut buf = vec![Complex::new(0i64, 0); bp.voxels()];
    let mut acc = AccQ15::new(&bp, &mut buf).unwrap();
    let mut q = vec![CQ15::default(); rx.len() * BINS];
    let mut exps = vec![0i32; rx.len()];
    for tx in tx_positions() {
        let profiles = snapshot_profiles(&bp, tx, &rx, &targets);
        quantize_snapshot(&profiles, &mut q, &mut exps);
        let snap = Snapshot {
            tx,
            rx: &rx,
            profiles: &q,
            profile_len: BINS,
        };
        bp.push_snapshot_q15(&mut acc, &snap, &exps).unwrap();
    }
    let mut img = vec![Complex::new(0.0f32, 0.0); bp.voxels()];
    acc.to_image_f32(&mut img).unwrap();
    let f = image_f32(&bp, &targets);
    assert_eq!(argmax(&img), index(&bp, targets[0].0));
    let reference: Vec<Complex<f64>> = f
        .iter()
        .map(|z| Complex::new(z.re as f64, z.im as f64))
        .collect();
    // See tests/tests/bp_fixed_vs_float.rs for the derivation of the 40 dB floor.
    let sqnr = ser_db(&img, &reference).unwrap();
    assert!(sqnr >= 40.0, "Q15 vs f32 SQNR {sqnr:.1} dB");
    std::println!("Q15 vs f32 SQNR {sqnr:.1} dB");
}

#[test]
fn q15_exponents_are_aligned_across_pushes() {
    // The same profile pushed as (q, e) and as (q/2 rounded, e + 1), and once more after a push
    // at a much larger exponent forced the state to renormalise: the images agree within the
    // rounding of those steps (each ≤ ½ LSB of the coarser scale per sample, bounded below).
    let bp = Backprojector::new(config(Interp::Nearest, PhaseEval::Poly)).unwrap();
    let tx = tx_positions()[3];
    let rx = rx_positions()[10];
    let p = snapshot_profiles(&bp, tx, &[rx], &[([4, 4, 4], 1.0)]);
    let mut q = vec![CQ15::default(); BINS];
    let e = quantize(&p, &mut q);
    let half: Vec<CQ15> = q
        .iter()
        .map(|z| {
            Complex::new(
                Q15::from_bits(((z.re.to_bits() as i32 + 1) >> 1) as i16),
                Q15::from_bits(((z.im.to_bits() as i32 + 1) >> 1) as i16),
            )
        })
        .collect();
    let mut b1 = vec![Complex::new(0i64, 0); bp.voxels()];
    let mut b2 = vec![Complex::new(0i64, 0); bp.voxels()];
    let mut a1 = AccQ15::new(&bp, &mut b1).unwrap();
    let mut a2 = AccQ15::new(&bp, &mut b2).unwrap();
    bp.push_q15(&mut a1, &q, e, tx, rx).unwrap();
    bp.push_q15(&mut a1, &q, e, tx, rx).unwrap();
    bp.push_q15(&mut a2, &q, e, tx, rx).unwrap();
    bp.push_q15(&mut a2, &half, e + 1, tx, rx).unwrap();
    assert_eq!(a2.exponent(), e + 1);
    let zero = vec![CQ15::default(); BINS];
    bp.push_q15(&mut a1, &zero, e + 5, tx, rx).unwrap();
    assert_eq!(a1.exponent(), e + 5);
    let mut i1 = vec![Complex::new(0.0f32, 0.0); bp.voxels()];
    let mut i2 = i1.clone();
    a1.to_image_f32(&mut i1).unwrap();
    a2.to_image_f32(&mut i2).unwrap();
    // Per voxel: halving rounds each component by ≤ ½ LSB at e + 1 (= 1 LSB at e), times a
    // rotor ≤ 1, ×√2 for the complex magnitude; the first push's accumulator shifted by 1
    // rounds ≤ ½ unit of 2^(e+1−30) (negligible); renormalising a1 by 4 bits rounds ≤ ½ unit
    // of 2^(e+5−30); the rotor's magnitude is 1 within 10⁻⁴. Bound: (√2 + 10⁻³) LSB(e), plus
    // the f32 rounding of both images (½ ulp per component: ≤ √2·(|x| + |y|)·2⁻²⁴).
    let lsb = libm::ldexpf(1.0, e - 15);
    for (x, y) in i1.iter().zip(&i2) {
        let out_rounding = 2f32.sqrt() * (x.norm() + y.norm()) * libm::ldexpf(1.0, -24);
        let bound = (2f32.sqrt() + 1e-3) * lsb + out_rounding;
        assert!((x - y).norm() <= bound, "{x} vs {y}");
    }
}

#[test]
fn bad_configuration_is_an_error_naming_the_field() {
    let ok = config(Interp::Linear, PhaseEval::Poly);
    let cases: [(BpConfig, &str); 8] = [
        (
            BpConfig {
                wavelength_m: 0.0,
                ..ok
            },
            "config.wavelength_m",
        ),
        (
            BpConfig {
                wavelength_m: f32::NAN,
                ..ok
            },
            "config.wavelength_m",
        ),
        (BpConfig { dr_m: 0.0, ..ok }, "config.dr_m"),
        (BpConfig { dr_m: -0.1, ..ok }, "config.dr_m"),
        (
            BpConfig {
                r0_m: f32::INFINITY,
                ..ok
            },
            "config.r0_m",
        ),
        (
            BpConfig {
                grid: VoxelGrid {
                    spacing: Vec3::new(0.3, 0.0, 0.3),
                    ..ok.grid
                },
                ..ok
            },
            "config.grid.spacing.y",
        ),
        (
            BpConfig {
                grid: VoxelGrid {
                    origin: Vec3::new(f32::NAN, 0.0, 0.0),
                    ..ok.grid
                },
                ..ok
            },
            "config.grid.origin",
        ),
        (
            BpConfig {
                grid: VoxelGrid {
                    dims: [8, 0, 8],
                    ..ok.grid
                },
                ..ok
            },
            "config.grid.dims[1]",
        ),
    ];
    for (cfg, field) in cases {
        let e = Backprojector::new(cfg).unwrap_err();
        let what = match e {
            DspError::OutOfRange { what, .. }
            | DspError::NonFinite { what }
            | DspError::UnsupportedLength { what, .. } => what,
            other => panic!("unexpected {other:?}"),
        };
        assert_eq!(what, field);
    }
    let wide = BpConfig {
        grid: VoxelGrid {
            spacing: Vec3::new(0.3, 1e5, 0.3),
            ..ok.grid
        },
        ..ok
    };
    assert!(matches!(
        Backprojector::new(wide),
        Err(DspError::OutOfRange {
            what: "config.grid extent (spacing · (dims − 1))",
            ..
        })
    ));
    let huge = BpConfig {
        grid: VoxelGrid {
            dims: [usize::MAX, 2, 1],
            ..ok.grid
        },
        ..ok
    };
    assert!(matches!(
        Backprojector::new(huge),
        Err(DspError::UnsupportedLength {
            what: "config.grid.dims",
            ..
        })
    ));
}

#[test]
fn bad_state_and_push_inputs_are_errors_not_panics() {
    let bp = Backprojector::new(config(Interp::Linear, PhaseEval::Poly)).unwrap();
    let n = bp.voxels();
    let mut small = vec![Complex::new(0.0f32, 0.0); n - 1];
    assert_eq!(
        AccF32::new(&bp, &mut small).unwrap_err(),
        DspError::GridTooLarge {
            voxels: n,
            capacity: n - 1
        }
    );
    assert!(matches!(
        AccF32::tile(&bp, 10, &mut small),
        Err(DspError::GridTooLarge { .. })
    ));
    assert!(AccF32::tile(&bp, 0, &mut []).is_err());
    let mut small_q = vec![Complex::new(0i64, 0); n - 1];
    assert!(matches!(
        AccQ15::new(&bp, &mut small_q),
        Err(DspError::GridTooLarge { .. })
    ));
    assert!(matches!(
        AccQ15::tile(&bp, usize::MAX, &mut small_q),
        Err(DspError::GridTooLarge { .. })
    ));

    let mut buf = vec![Complex::new(0.0f32, 0.0); n];
    let mut acc = AccF32::new(&bp, &mut buf).unwrap();
    let p = vec![Complex::new(0.1f32, 0.0); BINS];
    let (tx, rx) = (Vec3::new(0.0, -4.0, 0.0), Vec3::new(1.0, -5.0, 3.0));
    let nan = Vec3::new(0.0, f32::NAN, 0.0);
    assert!(matches!(
        bp.push(&mut acc, &[], tx, rx),
        Err(DspError::UnsupportedLength {
            what: "snapshot.profile_len",
            ..
        })
    ));
    assert_eq!(
        bp.push(&mut acc, &p, nan, rx),
        Err(DspError::NonFinite {
            what: "snapshot.tx"
        })
    );
    assert_eq!(
        bp.push(&mut acc, &p, tx, nan),
        Err(DspError::NonFinite {
            what: "snapshot.rx"
        })
    );
    assert_eq!(
        bp.push(&mut acc, &p, tx, Vec3::new(0.0, 0.0, -2e5)),
        Err(DspError::OutOfRange {
            what: "snapshot.rx",
            value: 2e5
        })
    );
    assert_eq!(
        bp.push_naive(&mut acc, &p, tx, nan),
        Err(DspError::NonFinite {
            what: "snapshot.rx"
        })
    );
    assert!(bp.push_naive(&mut acc, &[], tx, rx).is_err());
    let rxs = [rx, rx];
    let bad = Snapshot {
        tx,
        rx: &rxs,
        profiles: &p,
        profile_len: BINS,
    };
    assert_eq!(
        bp.push_snapshot(&mut acc, &bad),
        Err(DspError::LengthMismatch {
            what: "snapshot.profiles",
            expected: 2 * BINS,
            got: BINS
        })
    );
    // A state made for a larger grid is refused by a smaller configuration.
    let mut big_cfg = config(Interp::Linear, PhaseEval::Poly);
    big_cfg.grid.dims = [16, 8, 8];
    let big = Backprojector::new(big_cfg).unwrap();
    let mut bigbuf = vec![Complex::new(0.0f32, 0.0); big.voxels()];
    let mut bigacc = AccF32::new(&big, &mut bigbuf).unwrap();
    assert!(matches!(
        bp.push(&mut bigacc, &p, tx, rx),
        Err(DspError::GridTooLarge { .. })
    ));
    assert_eq!(acc.pushes(), 0);

    let mut qbuf = vec![Complex::new(0i64, 0); n];
    let mut qacc = AccQ15::new(&bp, &mut qbuf).unwrap();
    let qp = vec![CQ15::default(); BINS];
    assert_eq!(
        bp.push_q15(&mut qacc, &qp, 97, tx, rx),
        Err(DspError::OutOfRange {
            what: "exponents",
            value: 97.0
        })
    );
    assert_eq!(
        bp.push_q15(&mut qacc, &qp, 0, nan, rx),
        Err(DspError::NonFinite {
            what: "snapshot.tx"
        })
    );
    let qsnap = Snapshot {
        tx,
        rx: &rxs,
        profiles: &qp[..],
        profile_len: BINS / 2,
    };
    assert!(matches!(
        bp.push_snapshot_q15(&mut qacc, &qsnap, &[0]),
        Err(DspError::LengthMismatch {
            what: "exponents",
            ..
        })
    ));
    qacc.pushes = MAX_PUSHES_Q15 as u64;
    assert_eq!(
        bp.push_q15(&mut qacc, &qp, 0, tx, rx),
        Err(DspError::AccumulatorOverflow {
            what: "AccQ15",
            max_pushes: MAX_PUSHES_Q15
        })
    );
    let mut short = vec![Complex::new(0.0f32, 0.0); n - 1];
    assert!(matches!(
        qacc.to_image_f32(&mut short),
        Err(DspError::LengthMismatch { what: "image", .. })
    ));

    let mut r64 = vec![Complex::new(0.0f64, 0.0); n];
    assert!(matches!(
        bp.push_reference_f64(&mut r64[..n - 1], &p, v64(tx), v64(rx)),
        Err(DspError::GridTooLarge { .. })
    ));
    assert_eq!(
        bp.push_reference_f64(&mut r64, &p, [0.0, f64::NAN, 0.0], v64(rx)),
        Err(DspError::NonFinite { what: "tx" })
    );
    assert!(bp
        .push_reference_f64(&mut r64, &[], v64(tx), v64(rx))
        .is_err());
    assert!(matches!(
        ser_db(&buf[..3], &r64),
        Err(DspError::LengthMismatch { .. })
    ));
    assert!(matches!(
        ser_db(&buf, &r64),
        Err(DspError::OutOfRange {
            what: "reference energy",
            ..
        })
    ));
    let mut prof = vec![Complex::new(0.0f32, 0.0); 8];
    assert!(add_point_echo(&mut prof, 0.0, 0.0, 0.03, 0.2, 1.0, Complex::new(1.0, 0.0)).is_err());
    assert!(add_point_echo(
        &mut prof,
        0.0,
        0.1,
        0.03,
        0.2,
        f64::NAN,
        Complex::new(1.0, 0.0)
    )
    .is_err());
}

#[test]
fn a_bin_at_either_end_of_the_profile_reads_zero_outside_it_as_the_plain_loop_does() {
    // The fast kernels read a clamped pair of samples with weights that vanish outside the
    // profile; the plain loop reads zero there. With dr a power of two (1/dr exact) both compute
    // the same fractional bin, so with the libm rotor they are the same IEEE operations on every
    // voxel whose bins lie inside, and at the ends a zero weight times a sample adds exactly
    // zero: the images are equal. The grid's ranges (9–15 m) straddle both ends of every
    // profile (r0 = 12 m, 1 to 20 bins of 0.125 m), one-sample and two-sample profiles included.
    // The Q15 path is zero wherever no bin of a voxel's pair lies inside the profile.
    let rx = rx_positions()[5];
    let tx = tx_positions()[7];
    for interp in [Interp::Linear, Interp::Nearest] {
        for len in [1usize, 2, 3, 20] {
            let mut cfg = config(interp, PhaseEval::Libm);
            (cfg.r0_m, cfg.dr_m) = (12.0, 0.125);
            let bp = Backprojector::new(cfg).unwrap();
            let p: Vec<Complex<f32>> = (0..len)
                .map(|i| Complex::from_polar(1.0, 0.7 * i as f32 + 0.3))
                .collect();
            let mut fast = vec![Complex::new(0.0f32, 0.0); bp.voxels()];
            let mut naive = fast.clone();
            bp.push(&mut AccF32::new(&bp, &mut fast).unwrap(), &p, tx, rx)
                .unwrap();
            bp.push_naive(&mut AccF32::new(&bp, &mut naive).unwrap(), &p, tx, rx)
                .unwrap();
            assert_eq!(fast, naive, "{interp:?}, {len} bins");
            let (inside, outside) = fast.iter().fold((0, 0), |(a, b), z| {
                if z.norm_sqr() > 0.0 {
                    (a + 1, b)
                } else {
                    (a, b + 1)
                }
            });
            assert!(
                inside > 0 && outside > 0,
                "{interp:?}, {len}: {inside} / {outside}"
            );
            let mut q = vec![CQ15::default(); len];
            let e = quantize(&p, &mut q);
            let mut buf = vec![Complex::new(0i64, 0); bp.voxels()];
            bp.push_q15(&mut AccQ15::new(&bp, &mut buf).unwrap(), &q, e, tx, rx)
                .unwrap();
            for (z, f) in buf.iter().zip(&fast) {
                if f.norm_sqr() == 0.0 {
                    assert_eq!(*z, Complex::new(0, 0), "{interp:?}, {len} bins");
                }
            }
        }
    }
}

#[test]
fn profile_outside_the_grid_ranges_contributes_nothing() {
    // A profile whose bins all lie beyond every voxel's bistatic range leaves the image zero.
    let mut cfg = config(Interp::Linear, PhaseEval::Poly);
    cfg.r0_m = 100.0;
    let bp = Backprojector::new(cfg).unwrap();
    let mut buf = vec![Complex::new(0.0f32, 0.0); bp.voxels()];
    let mut acc = AccF32::new(&bp, &mut buf).unwrap();
    let p = vec![Complex::new(1.0f32, 1.0); BINS];
    bp.push(&mut acc, &p, Vec3::ZERO, Vec3::ZERO).unwrap();
    assert!(buf.iter().all(|z| *z == Complex::new(0.0, 0.0)));
}

/// Pushes one finite profile through every entry point (f32 fast paths, naive, `f64` reference,
/// Q15) with extreme but accepted positions, and returns whether every image value is finite.
fn every_push_is_finite(bp: &Backprojector) -> bool {
    let n = bp.voxels();
    let p = vec![Complex::new(1.0f32, -1.0); BINS];
    let q = vec![Complex::new(Q15::from_f32(0.5), Q15::from_f32(-0.5)); BINS];
    let far = Vec3::splat(-MAX_LOCAL_M);
    let mut ok = true;
    for (tx, rx) in [(Vec3::ZERO, Vec3::ZERO), (far, Vec3::splat(MAX_LOCAL_M))] {
        let mut buf = vec![Complex::new(0.0f32, 0.0); n];
        let mut power = vec![0.0f32; n];
        let mut acc = AccF32::new(bp, &mut buf).unwrap();
        bp.push(&mut acc, &p, tx, rx).unwrap();
        bp.push_naive(&mut acc, &p, tx, rx).unwrap();
        let rxs = [rx, tx];
        let pp: Vec<_> = p.iter().chain(&p).copied().collect();
        let snap = Snapshot {
            tx,
            rx: &rxs,
            profiles: &pp,
            profile_len: BINS,
        };
        bp.push_snapshot_with_power(&mut acc, &mut power, &snap)
            .unwrap();
        ok &= buf.iter().all(|z| z.re.is_finite() && z.im.is_finite());
        ok &= power.iter().all(|x| x.is_finite());
        let mut r64 = vec![Complex::new(0.0f64, 0.0); n];
        bp.push_reference_f64(&mut r64, &p, v64(tx), v64(rx))
            .unwrap();
        ok &= r64.iter().all(|z| z.re.is_finite() && z.im.is_finite());
        let mut qbuf = vec![Complex::new(0i64, 0); n];
        let mut qacc = AccQ15::new(bp, &mut qbuf).unwrap();
        bp.push_q15(&mut qacc, &q, 3, tx, rx).unwrap();
        let mut img = vec![Complex::new(0.0f32, 0.0); n];
        qacc.to_image_f32(&mut img).unwrap();
        ok &= img.iter().all(|z| z.re.is_finite() && z.im.is_finite());
    }
    ok
}

/// A finite `r0_m = −3·10³⁸` with `dr_m = 10⁻³⁰` used to be accepted, and `(r − r0)/dr`
/// overflowed to ∞ for every voxel: bin weight ∞ − ∞ = NaN, an all-NaN image. Now a range, bin or
/// phase mapping that can leave the finite range is an error naming the field and its value
/// (`dr_m` if no `r0_m` would do, else `r0_m`; `wavelength_m` for `r/λ`), and configurations
/// just inside the limits give finite images from every push.
#[test]
fn a_range_to_bin_mapping_that_overflows_f32_is_an_error() {
    for interp in [Interp::Linear, Interp::Nearest] {
        for phase in [PhaseEval::Poly, PhaseEval::Libm] {
            let ok = config(interp, phase);
            let cases = [
                (-3e38, 1e-30, LAMBDA, "config.r0_m", -3e38),
                (3e38, 1e-30, LAMBDA, "config.r0_m", 3e38),
                (-1e32, 1e-6, LAMBDA, "config.r0_m", -1e32),
                (f32::MAX, 1.0, LAMBDA, "config.r0_m", f32::MAX),
                (0.0, 1e-33, LAMBDA, "config.dr_m", 1e-33),
                (-3e38, 1e-36, LAMBDA, "config.dr_m", 1e-36),
                (0.0, DR, 1e-33, "config.wavelength_m", 1e-33),
            ];
            for (r0_m, dr_m, wavelength_m, field, value) in cases {
                let cfg = BpConfig {
                    r0_m,
                    dr_m,
                    wavelength_m,
                    ..ok
                };
                assert_eq!(
                    Backprojector::new(cfg),
                    Err(DspError::OutOfRange { what: field, value }),
                    "r0 {r0_m} dr {dr_m} λ {wavelength_m}"
                );
            }
            // Just inside: accepted, and every image stays finite.
            for (r0_m, dr_m, wavelength_m) in [
                (0.0, 1e-31, LAMBDA),
                (-1e30, 1.0, LAMBDA),
                (1e36, 1e-0, LAMBDA),
                (0.0, DR, 1e-31),
                (0.0, f32::MAX, f32::MAX),
                (-f32::MAX, 1e30, LAMBDA),
            ] {
                let bp = Backprojector::new(BpConfig {
                    r0_m,
                    dr_m,
                    wavelength_m,
                    ..ok
                })
                .unwrap();
                assert!(
                    every_push_is_finite(&bp),
                    "{interp:?} {phase:?} r0 {r0_m} dr {dr_m} λ {wavelength_m}"
                );
            }
        }
    }
}

/// The `f64` reference refuses positions beyond ±`MAX_LOCAL_M` like every other push (a
/// coordinate of 10²⁰⁰ overflowed the squared distance and gave NaN).
#[test]
fn a_reference_position_beyond_the_local_limit_is_an_error() {
    let bp = Backprojector::new(config(Interp::Linear, PhaseEval::Poly)).unwrap();
    let mut r64 = vec![Complex::new(0.0f64, 0.0); bp.voxels()];
    let p = vec![Complex::new(1.0f32, 0.0); BINS];
    assert_eq!(
        bp.push_reference_f64(&mut r64, &p, [0.0, 1e200, 0.0], [0.0; 3]),
        Err(DspError::OutOfRange {
            what: "tx",
            value: 1e200f64 as f32
        })
    );
    assert_eq!(
        bp.push_reference_f64(&mut r64, &p, [0.0; 3], [-2e5, 0.0, 0.0]),
        Err(DspError::OutOfRange {
            what: "rx",
            value: 2e5
        })
    );
    assert!(r64.iter().all(|z| *z == Complex::new(0.0, 0.0)));
}
