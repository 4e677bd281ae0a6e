//! Q15 against f32 on the same quantised frames: the direct-path estimator
//! (`has_dsp::direct_path`).
//!
//! **The bound.** Both paths read the same Q15 subcarriers (the f32 path their exact values), form
//! the same products `Y·conj(S)`, sum in 64 bits and share the search code. They differ only in
//! the rotor: the Q15 path's table rotor errs by ≤ 0.503 Q15 LSB per component
//! (`has_dsp::phase::ROTOR_Q30_MAX_ERR_LSB`), the f32 one by ≤ 2·10⁻⁶.
//! - **Path.** What moves the refined path is the rotor error's *slope*: two neighbouring table
//!   entries err independently by up to 0.503 LSB, so between them the rotor's phase slope errs
//!   by up to `2·0.503·2⁻¹⁵` per table step of `2π/8192`, a relative 0.040 per radian of phase.
//!   Term `k`'s phase turns by `2πs_k/L` per metre of path, so `|C|²` gains a relative slope of at
//!   most `2·0.040·(2π/L)·mean|s_k|` against the relative curvature `2(2π/L)²·mean s_k²` that
//!   holds the optimum: the optimum moves by at most `0.040·mean|s|/((2π/L)·mean s²)` =
//!   `0.040·(n/4)·12/((2π/L)·n²)` = `0.040·3·(c/B)/(2π)` = 14 mm at 400 MHz (every term's error
//!   aligned; independent errors give about that over `√n`: 0.6 mm measured). The carrier phase
//!   is read from `â`, not from the path: a path error `Δr` turns subcarrier `s` by
//!   `2π·s·Δr/L`, which cancels in `â` over the symmetric `s` to first order.
//! - **Amplitude.** The rotor's ≤ 0.503·√2 LSB per term (2.2·10⁻⁵ relative), plus the fall of
//!   `|C|` over a path error of 14 mm (`(2π/L)²·mean s²·Δr²/2` = 6·10⁻⁴ at the worst) and the
//!   second-order phase turn: under 10⁻³ relative.

use has_dsp::direct_path::{DirectPath, DirectPathConfig};
use has_dsp::fixed::{cq15_from_c32, cq15_to_c32, CQ15};
use num_complex::Complex;
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use std::f64::consts::TAU;

type C32 = Complex<f32>;

const B: f64 = 400e6;
const C: f64 = 299_792_458.0;

fn config(cases: u32, seed: u64) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: RngSeed::Fixed(seed),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// One frame in Q15: a direct path of length `r` and amplitude `a = (|a|, arg a)` through a
/// unit-modulus symbol at half scale, plus noise components uniform in ±0.05 (`noise`).
fn frame(
    n: usize,
    r: f64,
    a: (f64, f64),
    phases: &[f64],
    noise: &[(f64, f64)],
) -> (Vec<CQ15>, Vec<CQ15>) {
    let l = C / B * n as f64;
    let mut y = Vec::with_capacity(n);
    let mut s = Vec::with_capacity(n);
    for k in 0..n {
        let signed = if k < n / 2 {
            k as f64
        } else {
            k as f64 - n as f64
        };
        let sym = Complex::from_polar(0.5, phases[k]);
        let path = Complex::from_polar(a.0, a.1 - 2.0 * std::f64::consts::PI * signed * r / l);
        let v = sym * path + Complex::new(noise[k].0, noise[k].1);
        y.push(cq15_from_c32(C32::new(v.re as f32, v.im as f32)));
        s.push(cq15_from_c32(C32::new(sym.re as f32, sym.im as f32)));
    }
    (y, s)
}

type Case = (usize, f64, (f64, f64), Vec<f64>, Vec<(f64, f64)>);

fn case() -> impl Strategy<Value = Case> {
    prop::sample::select(vec![256usize, 1024]).prop_flat_map(|n| {
        (
            Just(n),
            -12.0f64..12.0,
            (0.1f64..0.8, 0.0f64..TAU),
            proptest::collection::vec(0.0f64..TAU, n),
            proptest::collection::vec((-0.05f64..0.05, -0.05f64..0.05), n),
        )
    })
}

proptest! {
    #![proptest_config(config(32, 0xd1_2ec7))]

    /// The Q15 path's direct path and amplitude are the f32 path's on the same frame (module
    /// docs), anywhere in the searched window.
    #[test]
    fn q15_direct_path_matches_f32((n, offset, a, phases, noise) in case()) {
        let est = DirectPath::new(DirectPathConfig {
            n_subcarriers: n,
            bandwidth_hz: B,
            search_half_width_m: 15.0,
        })
        .unwrap();
        let predicted = 143.7;
        let (yq, sq) = frame(n, predicted + offset, a, &phases, &noise);
        let yf: Vec<C32> = yq.iter().map(|z| cq15_to_c32(*z)).collect();
        let sf: Vec<C32> = sq.iter().map(|z| cq15_to_c32(*z)).collect();
        let f = est.estimate(&yf, &sf, predicted).unwrap();
        let q = est.estimate_q15(&yq, &sq, predicted).unwrap();
        prop_assert!((q.path_m - f.path_m).abs() <= 0.014, "{} vs {}", q.path_m, f.path_m);
        let rel = (q.amplitude - f.amplitude).norm() / f.amplitude.norm();
        prop_assert!(rel <= 1e-3, "amplitude {} vs {}: {rel}", q.amplitude, f.amplitude);
        // And the f32 path found the path: within 5 of its Cramér–Rao bounds at the drawn SNR
        // (the signal (|a|/2)² against the noise's 2·0.05²/3 per subcarrier).
        let snr = (0.5 * a.0).powi(2) / (2.0 * 0.05f64.powi(2) / 3.0);
        let crb = est.path_crb_m(snr);
        prop_assert!(
            (f.path_m - predicted - offset).abs() < 5.0 * crb,
            "{} vs {} (CRB {crb} m)", f.path_m, predicted + offset
        );
    }
}
