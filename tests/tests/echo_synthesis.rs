//! Echo synthesis: raw OFDM against range compression, direct profiles against OFDM, visibility,
//! sampling density, determinism and input errors.

use glam::Vec3;
use has_dsp::fft::Q15Scaling;
use has_dsp::range::{RangeCompressor, RangeConfig, RangeMode};
use has_dsp::window::Window;
use has_host::echo::{
    bistatic_amplitude, qpsk_symbols, visible_for, zadoff_chu, EchoConfig, EchoError, EchoSynth,
    Noise, PointScatterer, ScattererSet, VisibilityCache,
};
use has_host::{bistatic_range, Material, Object, Scene};
use num_complex::Complex32;

const FC: f64 = 10e9;
const B: f64 = 400e6;
const N: usize = 256;

/// A has-dsp range compressor (matched filter) and the echo configuration that matches it.
fn compressor(n: usize, bw: f64, zp: usize, window: Window) -> (RangeCompressor, EchoConfig) {
    let rc = RangeCompressor::new(RangeConfig {
        n_subcarriers: n,
        bandwidth_hz: bw,
        zero_pad: zp,
        mode: RangeMode::Matched,
        window,
        q15_scaling: Q15Scaling::default(),
    })
    .unwrap();
    let cfg = EchoConfig::for_compressor(FC, &rc).unwrap();
    (rc, cfg)
}

/// has-dsp `f32` range compression of the rows of `y` (each `n` long) with symbol `s`.
fn compress_rows(rc: &RangeCompressor, y: &[Complex32], s: &[Complex32]) -> Vec<Complex32> {
    let n = rc.n_subcarriers();
    let mut reference = vec![Complex32::new(0.0, 0.0); n];
    rc.prepare_reference(s, &mut reference).unwrap();
    let mut out = vec![Complex32::new(0.0, 0.0); y.len() / n * rc.profile_len()];
    for (row, prof) in y.chunks(n).zip(out.chunks_mut(rc.profile_len())) {
        rc.compress(row, &reference, prof).unwrap();
    }
    out
}

/// Bound on the f32 inverse FFT's error per output bin, relative to `Σ|a_p|`: the L2 error of a
/// radix-2 FFT is ≤ c·log₂N·ε·‖x‖₂ (c ≈ 1–2 for careful twiddles; 5 taken), and a unit scatterer
/// has `√N·‖w‖₂/Σw ≤ 1.8` (Hann: `√(2n)·√(3n/8)/(n/2)` = 1.73 at zero_pad 2, 1.22 at 1), plus
/// 2.4e-7 for the f32 storage of `Y` and the reference.
fn fft_error(n_fft: usize) -> f32 {
    5.0 * (n_fft as f32).log2() * f32::EPSILON / 2.0 * 1.8 + 2.4e-7
}

fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    (a + std::f64::consts::PI).rem_euclid(t) - std::f64::consts::PI
}

#[test]
fn raw_ofdm_point_echo_compresses_to_a_peak_at_its_bistatic_range_with_carrier_phase() {
    let zp = 2;
    let (rc, cfg) = compressor(N, B, zp, Window::Hann);
    let synth = EchoSynth::new(cfg.clone()).unwrap();
    let dr = cfg.bin_spacing_m();
    assert_eq!(dr, rc.bin_spacing_m());
    let lambda = cfg.wavelength_m();
    let tx = Vec3::new(0.0, 0.0, 10.0);
    let rx = [Vec3::new(30.0, 5.0, 2.0)];
    let target = Vec3::new(17.3, 21.9, 4.1);
    // Path length in f64 (bistatic_range is f32: 4 µm at 50 m is already 8e-4 rad at 3 cm).
    let (t64, tx64, rx64) = (target.as_dvec3(), tx.as_dvec3(), rx[0].as_dvec3());
    let r = t64.distance(tx64) + t64.distance(rx64);
    assert!((r - bistatic_range(target, tx, rx[0]) as f64).abs() < 1e-4);
    let pts = [PointScatterer {
        pos: target,
        amp: Complex32::new(1.0, 0.0),
    }];
    let s = qpsk_symbols(N, 7);
    // At the peak bin m the profile is e^{−j2π r/λ}·p(m − r/dr) with p real and positive in the
    // main lobe (Hann, Nyquist subcarrier unused), so its phase is −2π r/λ and its magnitude
    // p(m − r/dr), which the tabulated pulse gives to 1e-5.
    let fft = fft_error(N * zp);
    for (noise, tol_mag, tol_phase) in [
        // Noise-free: the f32 FFT bound plus the pulse table's error.
        (Noise::None, fft + 1e-5, fft + 1e-5),
        // SNR 10 dB per subcarrier: after compression the noise has variance
        // σ²·Σw²/(Σw)² = 0.1·(3n/8)/(n/2)² = 0.1·1.5/n ⇒ std 0.0242 at n = 256; 5σ = 0.12 on the
        // magnitude and (over a peak ≥ 0.8) 0.15 rad on the phase.
        (Noise::SnrDb(10.0), 0.13, 0.16),
    ] {
        let mut y = vec![Complex32::new(0.0, 0.0); N];
        synth
            .synth_ofdm_points(&pts, tx, &rx, &s, noise, 99, &mut y)
            .unwrap();
        let prof = compress_rows(&rc, &y, &s);
        let (peak, v) = prof
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.norm().total_cmp(&b.1.norm()))
            .unwrap();
        assert!(
            (peak as f64 * dr - r).abs() <= 0.5 * dr,
            "peak at bin {peak} ({} m), target at {r} m",
            peak as f64 * dr
        );
        let expect_mag = synth.kernel().eval(peak as f64 - r / dr).re;
        assert!(
            (v.norm() - expect_mag).abs() < tol_mag,
            "{noise:?}: |s| = {} at bin {peak}, pulse {expect_mag}",
            v.norm()
        );
        let dphi = wrap(v.arg() as f64 + std::f64::consts::TAU * r / lambda);
        assert!(
            dphi.abs() < tol_phase as f64,
            "{noise:?}: phase error {dphi} rad"
        );
    }
}

#[test]
fn direct_profiles_equal_ofdm_plus_compression_within_kernel_error() {
    let zp = 2;
    let (rc, cfg) = compressor(N, B, zp, Window::Hann);
    let synth = EchoSynth::new(cfg.clone()).unwrap();
    let k = synth.kernel();
    // Hann with a 16-cell half-width: sidelobes there are far below the f32 floor of the bound.
    assert!(k.truncation_error() < 1e-4, "{}", k.truncation_error());
    let tx = Vec3::new(-5.0, 0.0, 8.0);
    let rx: Vec<Vec3> = (0..4)
        .map(|i| Vec3::new(20.0, 0.1 * i as f32, 3.0))
        .collect();
    // Points whose bistatic ranges stay more than the kernel half-width (12 m) inside the
    // 192 m profile, so (b)'s circular wrap and (a)'s truncation meet only through the stated
    // tail bound.
    let pts: Vec<PointScatterer> = (0..12)
        .map(|i| {
            let f = i as f32;
            PointScatterer {
                pos: Vec3::new(10.0 + 3.1 * f, 7.0 - 1.3 * f, 0.5 * f),
                amp: Complex32::from_polar(0.2 + 0.07 * f, 0.9 * f),
            }
        })
        .collect();
    let s = zadoff_chu(N, 25).unwrap();
    let mut a = vec![Complex32::new(0.0, 0.0); rx.len() * cfg.n_bins];
    synth.synth_profiles_points(&pts, tx, &rx, &mut a).unwrap();
    let mut y = vec![Complex32::new(0.0, 0.0); rx.len() * N];
    synth
        .synth_ofdm_points(&pts, tx, &rx, &s, Noise::None, 0, &mut y)
        .unwrap();
    // Each bin of (a) differs from the exact compressed sum by at most Σ|a_p|·error_bound
    // (truncated tail + interpolation + f32 taps + phasor table); (b) is exact up to f32 rounding of Y
    // and has-dsp's f32 FFT ([`fft_error`]).
    let sum_a: f32 = pts.iter().map(|p| p.amp.norm()).sum();
    let bound = sum_a * (synth.error_bound() + fft_error(N * zp));
    let b = compress_rows(&rc, &y, &s);
    let worst = a
        .iter()
        .zip(&b)
        .map(|(va, vb)| (va - vb).norm())
        .fold(0.0f32, f32::max);
    assert!(worst <= bound, "max |a − b| = {worst}, bound {bound}");
    // The comparison is not vacuous: the profiles carry peaks of the amplitudes' size.
    let peak = a.iter().map(|v| v.norm()).fold(0.0f32, f32::max);
    assert!(peak > 0.5, "{peak}");
}

fn quad(z: f32, x0: f32, x1: f32, y0: f32, y1: f32) -> Vec<[Vec3; 3]> {
    let a = Vec3::new(x0, y0, z);
    let b = Vec3::new(x1, y0, z);
    let c = Vec3::new(x1, y1, z);
    let d = Vec3::new(x0, y1, z);
    vec![[a, b, c], [a, c, d]]
}

fn floor_and_wall() -> Scene {
    // Floor z = 0, x ∈ [−10, 10] (normal +z); a wall in the plane x = 0, z ∈ [0.01, 30].
    let w = |y: f32, z: f32| Vec3::new(0.0, y, z);
    Scene::new(vec![
        Object {
            thickness_m: None,
            name: "floor".into(),
            material: Material::Concrete,
            triangles: quad(0.0, -10.0, 10.0, -10.0, 10.0),
        },
        Object {
            thickness_m: None,
            name: "wall".into(),
            material: Material::Brick,
            triangles: vec![
                [w(-30.0, 0.01), w(30.0, 0.01), w(30.0, 30.0)],
                [w(-30.0, 0.01), w(30.0, 30.0), w(-30.0, 30.0)],
            ],
        },
    ])
    .unwrap()
}

#[test]
fn scatterers_behind_a_wall_are_not_visible() {
    let scene = floor_and_wall();
    let set = ScattererSet::sample(&scene, 2.0, 1).unwrap();
    let tx = Vec3::new(20.0, 0.0, 10.0);
    let rx = Vec3::new(25.0, 3.0, 8.0);
    let vis = visible_for(&set, &scene, tx, rx).unwrap();
    let on_floor = |p: &has_host::echo::Scatterer| p.object == 0;
    // Geometry: the segment from a floor point at x_p < 0 to tx crosses x = 0 at height
    // 10·(−x_p)/(20 − x_p) ≥ 0.01 (wall bottom) once x_p ≤ −0.021; points at x > 0 see both ends.
    let mut n_front = 0;
    for (i, p) in set.points.iter().enumerate() {
        if !on_floor(p) {
            continue;
        }
        let seen = vis.binary_search(&(i as u32)).is_ok();
        if p.pos.x < -0.05 {
            assert!(
                !seen,
                "scatterer {i} at {:?} behind the wall is visible",
                p.pos
            );
        } else if p.pos.x > 0.05 {
            assert!(
                seen,
                "scatterer {i} at {:?} in the open is not visible",
                p.pos
            );
            n_front += 1;
        }
    }
    assert!(n_front > 100, "{n_front}");
}

#[test]
fn back_faces_contribute_nothing_unless_two_sided() {
    let scene = floor_and_wall();
    let mut set = ScattererSet::sample(&scene, 1.0, 3).unwrap();
    set.points.retain(|p| p.object == 0 && p.pos.x > 1.0);
    // Both ends below the floor: the floor's front (+z) faces away from them.
    let tx = Vec3::new(5.0, 0.0, -10.0);
    let rx = Vec3::new(6.0, 0.0, -9.0);
    assert!(visible_for(&set, &scene, tx, rx).unwrap().is_empty());
    // Visibility passed by hand still gives no echo: the amplitude path tests the faces too.
    let synth = EchoSynth::new(EchoConfig::new(FC, B, N, 1)).unwrap();
    let all: Vec<u32> = (0..set.len() as u32).collect();
    let mut out = vec![Complex32::new(1.0, 1.0); N];
    synth
        .synth_profiles(&set, &all, tx, &[rx], &mut out)
        .unwrap();
    assert!(out.iter().all(|v| *v == Complex32::new(0.0, 0.0)));
    set.two_sided = true;
    assert_eq!(visible_for(&set, &scene, tx, rx).unwrap().len(), set.len());
}

#[test]
fn sampling_density_is_even_and_areas_add_up() {
    let scene = Scene::new(vec![Object {
        thickness_m: None,
        name: "plate".into(),
        material: Material::Concrete,
        triangles: quad(0.0, 0.0, 20.0, 0.0, 20.0),
    }])
    .unwrap();
    let rho = 10.0;
    let set = ScattererSet::sample(&scene, rho, 11).unwrap();
    // Each of the two 200 m² triangles gets exactly ⌊2000⌋ points; weights add to the area up to
    // f32 rounding of each weight (4000 · 6e-8 relative).
    assert_eq!(set.len(), 4000);
    assert!(
        (set.total_area_m2() - 400.0).abs() < 1e-3,
        "{}",
        set.total_area_m2()
    );
    // 2 m × 2 m cells: 40 expected each. Even for independent uniform points the count is
    // binomial with σ ≤ √40 = 6.3; 5σ = 31.6 is exceeded by any of 100 cells with probability
    // < 1e-4. The low-discrepancy sampler must also beat independent sampling on dispersion:
    // Σ(dev²)/40 (≈ χ² with 99 d.o.f. ≈ 99 ± 14 for independent points) must stay below 50.
    let mut counts = [[0i32; 10]; 10];
    for p in &set.points {
        let (i, j) = ((p.pos.x / 2.0) as usize, (p.pos.y / 2.0) as usize);
        counts[i.min(9)][j.min(9)] += 1;
    }
    let mut chi2 = 0.0;
    for row in counts {
        for c in row {
            let dev = (c - 40) as f64;
            assert!(dev.abs() <= 31.6, "cell count {c}");
            chi2 += dev * dev / 40.0;
        }
    }
    assert!(chi2 < 50.0, "chi² = {chi2}");
}

#[test]
fn small_triangles_keep_the_expected_count() {
    // 4000 triangles of 0.005 m² at 20 /m²: each holds 0 or 1 point with p = 0.1; the total is
    // binomial(4000, 0.1): mean 400, σ = 19; 5σ bound. Area weights are 1/ρ each.
    let mut tris = Vec::new();
    for i in 0..4000 {
        let x = (i % 100) as f32 * 0.2;
        let y = (i / 100) as f32 * 0.2;
        tris.push([
            Vec3::new(x, y, 0.0),
            Vec3::new(x + 0.1, y, 0.0),
            Vec3::new(x, y + 0.1, 0.0),
        ]);
    }
    let scene = Scene::new(vec![Object {
        thickness_m: None,
        name: "gravel".into(),
        material: Material::MediumDryGround,
        triangles: tris,
    }])
    .unwrap();
    let set = ScattererSet::sample(&scene, 20.0, 5).unwrap();
    assert!((set.len() as f64 - 400.0).abs() <= 95.0, "{}", set.len());
    assert!(set.points.iter().all(|p| p.area_m2 == 0.05));
}

#[test]
fn same_seed_gives_the_same_bits() {
    let scene = floor_and_wall();
    let a = ScattererSet::sample(&scene, 3.0, 42).unwrap();
    let b = ScattererSet::sample(&scene, 3.0, 42).unwrap();
    let c = ScattererSet::sample(&scene, 3.0, 43).unwrap();
    let bits = |s: &ScattererSet| -> Vec<u32> {
        s.points
            .iter()
            .flat_map(|p| p.pos.to_array().map(f32::to_bits))
            .collect()
    };
    assert_eq!(bits(&a), bits(&b));
    assert_ne!(bits(&a), bits(&c));
    // Noisy OFDM synthesis is reproducible bit for bit too.
    let synth = EchoSynth::new(EchoConfig::new(FC, B, 64, 1)).unwrap();
    let tx = Vec3::new(20.0, 0.0, 10.0);
    let rx = [Vec3::new(25.0, 3.0, 8.0), Vec3::new(25.0, 3.1, 8.0)];
    let vis = visible_for(&a, &scene, tx, rx[0]).unwrap();
    let s = qpsk_symbols(64, 1);
    let run = |seed| {
        let mut y = vec![Complex32::new(0.0, 0.0); 128];
        synth
            .synth_ofdm(&a, &vis, tx, &rx, &s, Noise::SnrDb(5.0), seed, &mut y)
            .unwrap();
        y.iter()
            .flat_map(|v| [v.re.to_bits(), v.im.to_bits()])
            .collect::<Vec<_>>()
    };
    assert_eq!(run(9), run(9));
    assert_ne!(run(9), run(10));
}

#[test]
fn surface_profiles_equal_surface_ofdm_plus_compression() {
    // The surface path (facing, Fresnel, spreading) feeds (a) and (b) identically.
    let scene = floor_and_wall();
    let set = ScattererSet::sample(&scene, 0.5, 8).unwrap();
    let n = 128;
    let (rc, cfg) = compressor(n, 100e6, 1, Window::Hann);
    let synth = EchoSynth::new(cfg.clone()).unwrap();
    let tx = Vec3::new(60.0, 0.0, 20.0);
    let rx = [Vec3::new(65.0, 3.0, 18.0), Vec3::new(65.0, 3.5, 18.0)];
    let vis = visible_for(&set, &scene, tx, rx[0]).unwrap();
    assert!(vis.len() > 50);
    let s = qpsk_symbols(n, 2);
    let mut a = vec![Complex32::new(0.0, 0.0); 2 * n];
    synth.synth_profiles(&set, &vis, tx, &rx, &mut a).unwrap();
    let mut y = vec![Complex32::new(0.0, 0.0); 2 * n];
    synth
        .synth_ofdm(&set, &vis, tx, &rx, &s, Noise::None, 0, &mut y)
        .unwrap();
    // Bound: Σ|a_p| · (kernel bound + 1e-6). Σ|a_p| is at most (number visible) · max amplitude.
    // Legs are ≥ 50 m (floor 20 m below tx and rx, wall 60 m away), paths 100–150 m against a
    // 384 m unambiguous length, half-width 16 cells = 48 m: every kernel reach stays inside, so
    // the circular wrap of (b) carries only the tail. Area weights are ≤ 1/ρ·(1 + 1/(Aρ)) < 2.5.
    let lambda = cfg.wavelength_m();
    let max_amp = bistatic_amplitude(1.0, 1.0, 1.0, 2.5, 50.0, 50.0, lambda) as f32;
    let bound = vis.len() as f32 * max_amp * (synth.error_bound() + fft_error(n));
    let b = compress_rows(&rc, &y, &s);
    for (va, vb) in a.iter().zip(&b) {
        let d = (va - vb).norm();
        assert!(d <= bound, "{d} > {bound}");
    }
    assert!(a.iter().any(|v| v.norm() > 30.0 * bound));
}

#[test]
fn bistatic_amplitude_is_the_radar_equation_with_lambertian_rcs() {
    // a = √σ·λ/((4π)^{3/2} rV rR), σ = 4|Γ|² cos θi cos θs A.
    let (refl2, ci, cs, area, rv, rr, lam) = (0.2, 0.8, 0.6, 0.3, 40.0, 70.0, 0.03);
    let sigma: f64 = 4.0 * refl2 * ci * cs * area;
    let expect = sigma.sqrt() * lam / ((4.0 * std::f64::consts::PI).powf(1.5) * rv * rr);
    let got = bistatic_amplitude(refl2, ci, cs, area, rv, rr, lam);
    assert!((got / expect - 1.0).abs() < 1e-12, "{got} vs {expect}");
    assert_eq!(bistatic_amplitude(refl2, -0.1, cs, area, rv, rr, lam), 0.0);
}

#[test]
fn snr_sets_the_noise_power_against_the_mean_signal_power() {
    let synth = EchoSynth::new(EchoConfig::new(FC, B, N, 1)).unwrap();
    let pts = [PointScatterer {
        pos: Vec3::new(10.0, 0.0, 0.0),
        amp: Complex32::new(0.5, 0.0),
    }];
    let rx: Vec<Vec3> = (0..16)
        .map(|i| Vec3::new(0.0, 0.01 * i as f32, 0.0))
        .collect();
    let s = qpsk_symbols(N, 3);
    let mut clean = vec![Complex32::new(0.0, 0.0); rx.len() * N];
    synth
        .synth_ofdm_points(&pts, Vec3::ZERO, &rx, &s, Noise::None, 0, &mut clean)
        .unwrap();
    let mut noisy = clean.clone();
    let var = synth
        .synth_ofdm_points(&pts, Vec3::ZERO, &rx, &s, Noise::SnrDb(0.0), 4, &mut noisy)
        .unwrap();
    // |S·H|² = 0.25 on every subcarrier ⇒ σ² = 0.25 at 0 dB.
    assert!((var - 0.25).abs() < 1e-6, "{var}");
    // The measured noise power over 4096 samples: |n|² is exponential (std = mean), so the
    // sample mean has relative std 1/64; 5σ ⇒ ±7.8 %.
    let p: f64 = clean
        .iter()
        .zip(&noisy)
        .map(|(c, n)| (n - c).norm_sqr() as f64)
        .sum::<f64>()
        / clean.len() as f64;
    assert!((p / var - 1.0).abs() < 0.078, "measured {p}, set {var}");
}

#[test]
fn visibility_cache_recomputes_only_after_the_stated_shift() {
    let scene = floor_and_wall();
    let set = ScattererSet::sample(&scene, 1.0, 1).unwrap();
    let rx = Vec3::new(25.0, 3.0, 8.0);
    let mut cache = VisibilityCache::new(0.5);
    for i in 0..31 {
        // A 3 m aperture sampled every 0.1 m: recomputed at 0, 0.6, 1.2, 1.8, 2.4, 3.0 m.
        let tx = Vec3::new(20.0, 0.1 * i as f32, 10.0);
        let list = cache.get(&set, &scene, tx, rx).unwrap().to_vec();
        assert!(!list.is_empty());
    }
    assert_eq!(cache.recomputes(), 6);
}

#[test]
fn pulse_kernel_peaks_at_one_and_states_a_small_error_for_hann() {
    let cfg = EchoConfig::new(FC, B, N, 4)
        .with_window(Window::Hann)
        .unwrap();
    let synth = EchoSynth::new(cfg).unwrap();
    let k = synth.kernel();
    assert!((k.eval(0.0) - Complex32::new(1.0, 0.0)).norm() < 1e-6);
    // Interpolation bound π²·Σ|w|/(8·O²·zp²·Σw) with O = 256, zp = 4: 1.18e-6.
    assert!(
        k.interpolation_error() < 1.2e-6,
        "{}",
        k.interpolation_error()
    );
    // Rectangular window: the 1/(πx) sidelobes at 16 cells leave a tail of about 1/(π·16) = 0.02,
    // stated, not hidden.
    let rect = EchoSynth::new(EchoConfig::new(FC, B, N, 1)).unwrap();
    let t = rect.kernel().truncation_error();
    assert!(t > 0.01 && t < 0.03, "{t}");
}

#[test]
fn bad_input_is_an_error_naming_the_field() {
    let field_of = |e: EchoError| match e {
        EchoError::InvalidParameter { field, .. } | EchoError::LengthMismatch { field, .. } => {
            field
        }
        EchoError::BadIndex { .. } => "visible",
        _ => "other",
    };
    let mut cfg = EchoConfig::new(FC, B, N, 1);
    cfg.bandwidth_hz = 0.0;
    assert_eq!(field_of(EchoSynth::new(cfg).unwrap_err()), "bandwidth_hz");
    let mut cfg = EchoConfig::new(FC, B, N, 1);
    cfg.window.pop();
    assert_eq!(field_of(EchoSynth::new(cfg).unwrap_err()), "window");
    let mut cfg = EchoConfig::new(FC, B, N, 1);
    cfg.zero_pad = 0;
    assert_eq!(field_of(EchoSynth::new(cfg).unwrap_err()), "zero_pad");
    let mut cfg = EchoConfig::new(f64::NAN, B, N, 1);
    cfg.r0_m = 0.0;
    assert_eq!(field_of(EchoSynth::new(cfg).unwrap_err()), "fc_hz");

    let scene = floor_and_wall();
    assert_eq!(
        field_of(ScattererSet::sample(&scene, 0.0, 1).unwrap_err()),
        "density_per_m2"
    );
    let set = ScattererSet::sample(&scene, 0.2, 1).unwrap();
    let nan = Vec3::new(f32::NAN, 0.0, 0.0);
    assert_eq!(
        field_of(visible_for(&set, &scene, nan, Vec3::ONE).unwrap_err()),
        "tx"
    );
    assert_eq!(
        field_of(visible_for(&set, &scene, Vec3::ONE, nan).unwrap_err()),
        "rx_centre"
    );
    let synth = EchoSynth::new(EchoConfig::new(FC, B, N, 1)).unwrap();
    let rx = [Vec3::new(1.0, 2.0, 3.0)];
    let mut out = vec![Complex32::new(0.0, 0.0); N];
    let mut short = vec![Complex32::new(0.0, 0.0); N - 1];
    assert_eq!(
        field_of(
            synth
                .synth_profiles(&set, &[], Vec3::ONE, &rx, &mut short)
                .unwrap_err()
        ),
        "out"
    );
    assert_eq!(
        field_of(
            synth
                .synth_profiles(&set, &[], nan, &rx, &mut out)
                .unwrap_err()
        ),
        "tx"
    );
    assert_eq!(
        field_of(
            synth
                .synth_profiles(&set, &[], Vec3::ONE, &[nan], &mut out)
                .unwrap_err()
        ),
        "rx_elements"
    );
    let bad = [set.len() as u32];
    assert!(matches!(
        synth.synth_profiles(&set, &bad, Vec3::ONE, &rx, &mut out),
        Err(EchoError::BadIndex { position: 0, .. })
    ));
    let p = [PointScatterer {
        pos: nan,
        amp: Complex32::new(1.0, 0.0),
    }];
    assert_eq!(
        field_of(
            synth
                .synth_profiles_points(&p, Vec3::ONE, &rx, &mut out)
                .unwrap_err()
        ),
        "points"
    );
    let s = qpsk_symbols(N - 1, 0);
    assert_eq!(
        field_of(
            synth
                .synth_ofdm(&set, &[], Vec3::ONE, &rx, &s, Noise::None, 0, &mut out)
                .unwrap_err()
        ),
        "symbols"
    );
    let s = qpsk_symbols(N, 0);
    assert_eq!(
        field_of(
            synth
                .synth_ofdm_points(&[], Vec3::ONE, &rx, &s, Noise::Power(-1.0), 0, &mut out)
                .unwrap_err()
        ),
        "noise.power"
    );
    assert_eq!(
        field_of(
            synth
                .synth_ofdm_points(&[], Vec3::ONE, &rx, &s, Noise::None, 0, &mut short)
                .unwrap_err()
        ),
        "out"
    );
    assert_eq!(
        field_of(
            synth
                .add_paths_to_profile(&[(f64::NAN, Complex32::new(1.0, 0.0))], &mut out)
                .unwrap_err()
        ),
        "paths"
    );
    assert_eq!(field_of(zadoff_chu(0, 1).unwrap_err()), "n");
    assert_eq!(field_of(zadoff_chu(8, 0).unwrap_err()), "root");
}

#[test]
fn a_profile_window_is_the_matching_slice_of_the_full_profile() {
    // A window starting at bin 150 (r0 = 150·dr) of 60 bins must equal bins 150..210 of the full
    // profile, including pulses cut by either window edge. Only the rounding of
    // (r − r0)/dr against r/dr − 150 differs (≤ 1e-13 bins ⇒ far below f32 resolution);
    // the tolerance is f32 accumulation over 6 unit scatterers, 6·1e-6.
    let (_, full_cfg) = compressor(N, B, 2, Window::Hann);
    let full = EchoSynth::new(full_cfg.clone()).unwrap();
    let dr = full_cfg.bin_spacing_m();
    let mut win_cfg = full_cfg.clone();
    win_cfg.r0_m = 150.0 * dr;
    win_cfg.n_bins = 60;
    let win = EchoSynth::new(win_cfg).unwrap();
    let tx = Vec3::ZERO;
    let rx = [Vec3::new(0.0, 0.0, 0.0)];
    // Monostatic: r = 2|p|. Pulses centred before, at both edges of, inside and after the window.
    let pts: Vec<PointScatterer> = [140.3, 149.0, 160.7, 185.2, 209.6, 221.0]
        .iter()
        .enumerate()
        .map(|(i, &bin)| PointScatterer {
            pos: Vec3::new((bin * dr / 2.0) as f32, 0.0, 0.0),
            amp: Complex32::from_polar(1.0, i as f32),
        })
        .collect();
    let mut a_full = vec![Complex32::new(0.0, 0.0); full_cfg.n_bins];
    full.synth_profiles_points(&pts, tx, &rx, &mut a_full)
        .unwrap();
    let mut a_win = vec![Complex32::new(0.0, 0.0); 60];
    win.synth_profiles_points(&pts, tx, &rx, &mut a_win)
        .unwrap();
    for (i, (w, f)) in a_win.iter().zip(&a_full[150..210]).enumerate() {
        assert!((w - f).norm() <= 6e-6, "bin {i}: {w} vs {f}");
    }
    assert!(a_win[0].norm() > 0.1 && a_win[59].norm() > 0.1);
}

#[test]
fn blocked_synthesis_gives_the_bits_of_one_path_at_a_time() {
    // Elements on both sides of the wall and above the floor: per element, some scatterers face
    // it and some face away (no path), over many blocks of scatterers.
    let scene = floor_and_wall();
    let set = ScattererSet::sample(&scene, 3.0, 5).unwrap();
    assert!(set.len() > 1000, "{}", set.len());
    let all: Vec<u32> = (0..set.len() as u32).collect();
    let (_, mut cfg) = compressor(N, B, 2, Window::Hann);
    cfg.kernel_half_width_cells = 6;
    cfg.kernel_oversample = 64;
    cfg.r0_m = 5.0;
    cfg.n_bins = 300;
    let synth = EchoSynth::new(cfg.clone()).unwrap();
    let tx = Vec3::new(8.0, -3.0, 12.0);
    let rx: Vec<Vec3> = (0..12)
        .map(|i| {
            Vec3::new(
                if i % 2 == 0 { 6.0 } else { -4.0 },
                0.7 * i as f32 - 4.0,
                3.0 + 0.4 * i as f32,
            )
        })
        .collect();
    let bits = |v: &[Complex32]| -> Vec<u32> {
        v.iter()
            .flat_map(|z| [z.re.to_bits(), z.im.to_bits()])
            .collect()
    };
    let mut fast = vec![Complex32::new(0.0, 0.0); rx.len() * cfg.n_bins];
    let mut plain = fast.clone();
    synth
        .synth_profiles(&set, &all, tx, &rx, &mut fast)
        .unwrap();
    synth
        .synth_profiles_reference(&set, &all, tx, &rx, &mut plain)
        .unwrap();
    assert!(fast.iter().filter(|z| z.norm() > 0.0).count() > rx.len() * 50);
    assert_eq!(bits(&fast), bits(&plain));

    // Free points: the blocked path against paths deposited one at a time.
    let points: Vec<PointScatterer> = set
        .points
        .iter()
        .take(700)
        .enumerate()
        .map(|(i, s)| PointScatterer {
            pos: s.pos,
            amp: Complex32::new(1.0 + 0.01 * i as f32, -0.5),
        })
        .collect();
    let mut fast = vec![Complex32::new(0.0, 0.0); rx.len() * cfg.n_bins];
    synth
        .synth_profiles_points(&points, tx, &rx, &mut fast)
        .unwrap();
    for (e, row) in rx.iter().zip(fast.chunks(cfg.n_bins)) {
        let paths: Vec<(f64, Complex32)> = points
            .iter()
            .map(|p| {
                let pos = p.pos.as_dvec3();
                (
                    pos.distance(tx.as_dvec3()) + (e.as_dvec3() - pos).length(),
                    p.amp,
                )
            })
            .collect();
        let mut one = vec![Complex32::new(0.0, 0.0); cfg.n_bins];
        synth.add_paths_to_profile(&paths, &mut one).unwrap();
        assert_eq!(bits(row), bits(&one));
    }
}
