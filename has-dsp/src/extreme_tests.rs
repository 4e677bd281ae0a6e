//! Randomized extreme-value test (issue 17): the entry points the fuzzing review found wrong,
//! called with values drawn from 0, ±tiny, ±huge, NaN, ±∞, `usize::MAX`, `i32::MAX`, … by a
//! seeded LCG. Asserts that nothing panics and that every `Ok` carries finite output.
//!
//! Sample data (profiles) stays moderate: the back-projection pushes do not bound the samples
//! they accumulate (samples near `f32::MAX`, or NaN ones, still reach the image), so for them the
//! *configuration* and the *positions* are the extreme part.

use crate::bp::{AccF32, AccQ15, Backprojector, BpConfig, Interp, PhaseEval, Snapshot, VoxelGrid};
use crate::cfar::CaCfar;
use crate::fft::Q15Scaling;
use crate::fixed::{round_shift_i32, round_shift_i64, CQ15, Q15};
use crate::geometry::try_wavelength_m;
use crate::range::{RangeCompressor, RangeConfig, RangeMode};
use crate::template::{Template, TemplateSet};
use crate::window::Window;
use glam::Vec3;
use num_complex::Complex;

/// The tests' LCG ([`crate::test_util::Lcg`]), the high 53 bits as output.
struct Lcg(crate::test_util::Lcg);

impl Lcg {
    fn next(&mut self) -> u64 {
        self.0.next_u64() >> 11
    }

    fn pick<T: Copy>(&mut self, from: &[T]) -> T {
        from[(self.next() % from.len() as u64) as usize]
    }

    /// Half the time from `extreme`, else from `edge` (accepted values at the limits), so that the
    /// data paths run often, not only the checks.
    fn mix<T: Copy>(&mut self, extreme: &[T], edge: &[T]) -> T {
        if self.next() & 1 == 0 {
            self.pick(extreme)
        } else {
            self.pick(edge)
        }
    }

    /// Uniform in [−a, a).
    fn sym(&mut self, a: f32) -> f32 {
        a * ((self.next() >> 29) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0)
    }
}

const F32S: [f32; 22] = [
    0.0,
    -0.0,
    1e-45,
    -1e-45,
    1e-38,
    -1e-38,
    1e-30,
    -1e-30,
    1e-19,
    1.0,
    -1.0,
    0.03,
    0.375,
    1e5,
    1e20,
    -1e20,
    3e38,
    -3e38,
    f32::MAX,
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
];

const F64S: [f64; 14] = [
    0.0,
    -0.0,
    5e-324,
    1e-300,
    -1.0,
    1e-6,
    0.5,
    1.0 - 1e-16,
    1.0,
    10e9,
    f64::MAX,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
];

/// Positive lengths, wavelengths: accepted ones near the limits and typical ones.
const POSITIVE_F32S: [f32; 8] = [1e-38, 1e-33, 1e-31, 1e-30, 0.03, 0.375, 1e20, 3e38];

const USIZES: [usize; 12] = [
    0,
    1,
    2,
    3,
    64,
    65,
    1000,
    usize::MAX / 2 - 64,
    usize::MAX / 2,
    usize::MAX - 1,
    usize::MAX,
    7,
];

const I32S: [i32; 9] = [
    0,
    1,
    -1,
    96,
    -96,
    i32::MAX,
    i32::MAX - 5,
    i32::MIN,
    i32::MIN + 5,
];

fn finite_c32(z: &Complex<f32>) -> bool {
    z.re.is_finite() && z.im.is_finite()
}

fn bp_case(g: &mut Lcg) -> usize {
    let [ox, r0_m] = [g.pick(&F32S), g.pick(&F32S)];
    let [sx, wavelength_m, dr_m] = [0; 3].map(|_| g.mix(&F32S, &POSITIVE_F32S));
    let cfg = BpConfig {
        grid: VoxelGrid {
            origin: Vec3::new(ox, 0.0, 1.0),
            spacing: Vec3::new(sx, 0.25, 0.25),
            dims: [4, 3, 2],
        },
        wavelength_m,
        r0_m,
        dr_m,
        interp: if g.next() & 1 == 0 {
            Interp::Linear
        } else {
            Interp::Nearest
        },
        phase: if g.next() & 1 == 0 {
            PhaseEval::Poly
        } else {
            PhaseEval::Libm
        },
    };
    let Ok(bp) = Backprojector::new(cfg) else {
        return 0;
    };
    let n = bp.voxels();
    let len = 1 + (g.next() % 64) as usize;
    let profile: Vec<Complex<f32>> = (0..len)
        .map(|_| Complex::new(g.sym(1e3), g.sym(1e3)))
        .collect();
    let edge = [0.0, -1e5, 1e5, 1e-38, 3.0];
    let pos = |g: &mut Lcg| Vec3::new(g.mix(&F32S, &edge), g.sym(1e5), g.mix(&F32S, &edge));
    let (tx, rx) = (pos(g), pos(g));
    let mut buf = vec![Complex::new(0.0f32, 0.0); n];
    let mut acc = AccF32::new(&bp, &mut buf).unwrap();
    let pushed = bp.push(&mut acc, &profile, tx, rx).is_ok();
    let naive = bp.push_naive(&mut acc, &profile, tx, rx).is_ok();
    let snap = Snapshot {
        tx,
        rx: core::slice::from_ref(&rx),
        profiles: &profile,
        profile_len: len,
    };
    let mut power = vec![0.0f32; n];
    let with_power = bp
        .push_snapshot_with_power(&mut acc, &mut power, &snap)
        .is_ok();
    assert_eq!(pushed, naive);
    assert_eq!(pushed, with_power);
    assert!(
        buf.iter().all(finite_c32),
        "{cfg:?} tx {tx} rx {rx}: {buf:?}"
    );
    assert!(power.iter().all(|p| p.is_finite()), "{cfg:?}");

    let to64 = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
    let mut r64 = vec![Complex::new(0.0f64, 0.0); n];
    if bp
        .push_reference_f64(&mut r64, &profile, to64(tx), to64(rx))
        .is_ok()
    {
        assert!(r64.iter().all(|z| z.re.is_finite() && z.im.is_finite()));
    }

    let q: Vec<CQ15> = profile
        .iter()
        .map(|z| Complex::new(Q15::from_f32(z.re * 1e-3), Q15::from_f32(z.im * 1e-3)))
        .collect();
    let mut qbuf = vec![Complex::new(0i64, 0); n];
    let mut qacc = AccQ15::new(&bp, &mut qbuf).unwrap();
    let e = g.pick(&I32S);
    if bp.push_q15(&mut qacc, &q, e, tx, rx).is_ok() {
        let mut img = vec![Complex::new(0.0f32, 0.0); n];
        qacc.to_image_f32(&mut img).unwrap();
        assert!(img.iter().all(finite_c32), "{cfg:?} exponent {e}");
    }
    pushed as usize
}

fn template_case(g: &mut Lcg) -> usize {
    let mut oks = 0;
    let bins = 1 + (g.next() % 70) as usize;
    // A template of one extreme level with a random pattern, a frame likewise.
    let (lt, ly) = (g.pick(&F32S), g.pick(&F32S));
    let mut t: Vec<Complex<f32>> = (0..2 * bins)
        .map(|_| Complex::new(lt * g.sym(1.0), lt * g.sym(1.0)))
        .collect();
    let mut y: Vec<Complex<f32>> = (0..2 * bins)
        .map(|_| Complex::new(ly * g.sym(1.0), ly * g.sym(1.0)))
        .collect();
    if g.next().is_multiple_of(4) {
        // The review's case: constant (real) template and frame.
        t[..bins].fill(Complex::new(lt, 0.0));
        y.fill(Complex::new(ly, 0.0));
    }
    let loading = g.pick(&[0.0, 1e-6, 1e300, f64::NAN]);
    if let Ok(set) = Template::new(&t[..bins], bins, loading) {
        let mut frame = y[..bins].to_vec();
        if let Ok(gains) = set.subtract_in_place(&mut frame) {
            oks += 1;
            assert!(gains.iter().all(finite_c32), "gains {gains:?}");
            assert!(frame.iter().all(finite_c32), "t {lt} y {ly}: {frame:?}");
        }
        let mut block = y.clone();
        if let Ok(gains) = set.subtract_block_common(&mut block) {
            assert!(gains.iter().all(finite_c32) && block.iter().all(finite_c32));
        }
        let mut block = y.clone();
        let mut gains = [Complex::new(0.0f32, 0.0); 2];
        if set.subtract_block(&mut block, &mut gains).is_ok() {
            assert!(gains.iter().all(finite_c32) && block.iter().all(finite_c32));
        }
    }
    if let Ok(set) = TemplateSet::<2>::new(&t, bins, loading) {
        let mut frame = y[..bins].to_vec();
        if let Ok(gains) = set.subtract_in_place(&mut frame) {
            assert!(gains.iter().all(finite_c32) && frame.iter().all(finite_c32));
        }
    }
    oks
}

fn cfar_case(g: &mut Lcg) -> usize {
    let train = g.mix(&USIZES, &[1, 2, 64]);
    let guard = g.mix(&USIZES, &[0, 1, 5, 100]);
    let pfa = g.mix(&F64S, &[1e-300, 1e-6, 0.5, 1.0 - 1e-16]);
    let corr = [g.mix(&F64S, &[0.0, 1.0, 0.25]), 0.5];
    let c = if g.next() & 1 == 0 {
        CaCfar::new(train, guard, pfa)
    } else {
        CaCfar::with_power_correlation(train, guard, pfa, &corr)
    };
    let Ok(c) = c else {
        return 0;
    };
    assert!(c.alpha().is_finite() && c.effective_cells().is_finite());
    let len = (g.next() % 300) as usize;
    let level = g.pick(&F32S);
    let power: Vec<f32> = (0..len).map(|_| level * g.sym(1.0).abs()).collect();
    let mut th = vec![0.0f32; len];
    if let Ok(hits) = c.thresholds(&power, &mut th) {
        assert!(hits <= len);
        assert!(
            th.iter().all(|t| t.is_finite()),
            "train {train} guard {guard} pfa {pfa} level {level}"
        );
        return 1;
    }
    0
}

fn range_case(g: &mut Lcg, rc: &RangeCompressor) {
    let n = rc.n_subcarriers();
    let q = |g: &mut Lcg| Q15::from_bits((g.next() >> 7) as i16);
    let y: Vec<CQ15> = (0..n).map(|_| Complex::new(q(g), q(g))).collect();
    let r: Vec<CQ15> = (0..n).map(|_| Complex::new(q(g), q(g))).collect();
    let mut p = vec![CQ15::default(); rc.profile_len()];
    let e_r = g.pick(&I32S);
    if let Ok(e) = rc.compress_q15(&y, &r, e_r, &mut p) {
        // e_F is 0 … log2(len): the sum must be exact, not wrapped.
        let e_f = e as i64 - e_r as i64;
        assert!((0..=12).contains(&e_f), "e_R {e_r} → e {e}");
    } else {
        assert!(e_r > i32::MAX - 13, "e_R {e_r} refused");
    }
}

#[test]
fn extreme_inputs_never_panic_and_every_ok_output_is_finite() {
    let mut g = Lcg(crate::test_util::Lcg(0x0017_f022_2024_0017));
    let rc = RangeCompressor::new(RangeConfig {
        n_subcarriers: 64,
        bandwidth_hz: 400e6,
        zero_pad: 2,
        mode: RangeMode::Matched,
        window: Window::Hann,
        q15_scaling: Q15Scaling::Block,
    })
    .unwrap();
    // Ok outcomes per entry point: the draws must reach the data paths, not only the checks.
    let (mut bp_ok, mut template_ok, mut cfar_ok) = (0, 0, 0);
    // At least seven entry-point calls per round (a back-projector, a template set, a CFAR, a
    // range compression, two rounding shifts, a wavelength). CI runs 3000 rounds; a longer run:
    // `HAS_DSP_EXTREME_ROUNDS=1500000 cargo test --release -p has-dsp extreme_inputs`.
    let rounds: usize = std::env::var("HAS_DSP_EXTREME_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3000);
    for _ in 0..rounds {
        bp_ok += bp_case(&mut g);
        template_ok += template_case(&mut g);
        cfar_ok += cfar_case(&mut g);
        range_case(&mut g, &rc);

        let x = g.pick(&I32S);
        let s = g.pick(&[0u32, 1, 15, 31, 32, 33, 63, 64, 65, 127, 128, u32::MAX]);
        let r = round_shift_i32(x, s);
        assert!(r.unsigned_abs() <= x.unsigned_abs(), "{x} >> {s} = {r}");
        if s >= 32 {
            assert_eq!(r, 0);
        }
        let x64 = (x as i64) << (g.next() % 33);
        let r = round_shift_i64(x64, s);
        assert!(r.unsigned_abs() <= x64.unsigned_abs(), "{x64} >> {s} = {r}");
        if s >= 64 {
            assert_eq!(r, 0);
        }

        let f = g.pick(&F64S);
        if let Ok(l) = try_wavelength_m(f) {
            assert!(l.is_finite() && l > 0.0, "{f} Hz → {l}");
        }
    }
    std::eprintln!(
        "{rounds} rounds: Ok pushes {bp_ok}, template subtractions {template_ok}, CFAR lines {cfar_ok}"
    );
    assert!(bp_ok >= 50 && template_ok >= 100 && cfar_ok >= 100);
}
