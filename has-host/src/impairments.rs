//! The synchronisation errors of a pair's frames, and the line-of-sight reference that removes
//! them ([`crate::scenario::ImpairmentSpec`] holds the parameters).
//!
//! **What a frame carries.** A terminal and a base station share no clock. Frame `f` of a pair,
//! received at time `t_f` (the terminal's distance along its track over its speed), carries on
//! every echo alike:
//! - a timing offset `τ_f = τ₀ + d·t_f + w_f`: `τ₀` uniform in `±timing_offset_ns`, `d` the
//!   sampling clock's drift (`timing_drift_ppm`), `w_f` a Gaussian random walk of
//!   `timing_walk_ns` per frame. It moves each echo's envelope by `c·τ_f` of bistatic path and
//!   leaves its carrier phase alone (it is the baseband's clock, not the carrier's);
//! - a common phase `φ_f = 2π∫Δf(t)dt + θ_f`: the carrier offset `Δf` uniform in `±cfo_hz` with
//!   a random walk of `cfo_walk_hz_per_sqrt_s`, and with `frame_phase` an independent
//!   local-oscillator phase `θ_f` per frame, uniform in `[0, 2π)`.
//!
//! - a position error `e_f`: the frame is sent from its reported position plus `e_f`
//!   ([`crate::scenario::PositionError`]: a bias per terminal, a Gauss–Markov process and white
//!   noise per axis), while imaging uses the reported position.
//!
//! Uncompensated, the phases alone make the frames incoherent and the timing offset (34 m of path
//! at 114 ns) moves every echo out of the range the geometry assigns it.
//!
//! **The reference.** Each base station receives the terminal's line-of-sight path, the
//! strongest echo of the frame, whose delay and carrier phase the geometry predicts from the
//! terminal's position. Per frame, the panel's beam towards the terminal (all `E` elements
//! coherently) gives the direct path's subcarriers `Y_k = S_k·√E·A·e^{jφ_f}·e^{−j2π fc r_d/c}·
//! e^{−j2π s_k (r_d + cτ_f)/L} + n_k` (`A = λ/(4π r_d)`, `r_d` from where the terminal really
//! was to the panel centre, noise `n_k` of the per-subcarrier power that gives the echoes' profile-bin noise,
//! `σ_k² = σ_p²·(Σw)²/Σw²` for the compression weights `w`). has-dsp's
//! [`has_dsp::direct_path::DirectPath`] measures `r̂` and `â` on it; against the prediction they
//! give the frame's offsets `c·τ̂_f = r̂ − r_p` and `φ̂_f = arg â + 2π fc r_p/c`, `r_p` the path
//! from the reported position. Re-referencing
//! the frame is a linear phase across subcarriers and a common rotation, which commute with the
//! echo synthesis exactly: the compensated frame is synthesised with the residual offsets
//! `(cτ_f − cτ̂_f, φ_f − φ̂_f)` and its noise added after, as the same correction applied to
//! the received subcarriers would leave it (white noise keeps its statistics under both).
//!
//! **What it assumes.** A line of sight from the terminal to the panel centre. A frame whose
//! line of sight is blocked keeps the estimate of the nearest frame before it that had one (or
//! after, at the start of a track): its delay is then off by the walk since, and its phase by the
//! frame's own oscillator phase, so with `frame_phase` such a frame adds incoherently. The echo
//! frames carry no direct path (as in the ideal run), so nothing of it is left to cancel. The
//! prediction uses the reported position, so the reference also takes out the position error's
//! share along the line of sight, `|t + e − c| − |t − c|`, from every echo; what the error adds
//! to each echo's own transmit leg beyond that stays (autofocus's part, not done here).

use std::f64::consts::TAU;

use glam::Vec3;
use num_complex::Complex32;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::echo::noise::ComplexGaussian;
use crate::scenario::ImpairmentSpec;
use crate::scene::Scene;
use has_dsp::direct_path::{DirectPath, DirectPathConfig};
use has_dsp::geometry::C_M_PER_S;

/// Mixed into a pair's seed for its offsets' draws.
const OFFSETS_SEED: u64 = 0x51AC_0FF5_E75E_ED01;
/// Mixed into a pair's seed for the reference's noise.
const REFERENCE_NOISE_SEED: u64 = 0x105E_F00D_5EED;

/// One frame's offsets, or their residual after compensation: metres of bistatic path by which
/// every envelope lies late, and the common phase in radians.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct FrameOffset {
    pub delay_m: f64,
    pub phase_rad: f64,
}

/// The radio a pair's reference is measured with.
#[derive(Clone, Debug)]
pub(crate) struct ReferenceRadio {
    /// Carrier, Hz.
    pub fc_hz: f64,
    /// Occupied bandwidth, Hz.
    pub bandwidth_hz: f64,
    /// The transmitted symbol, FFT order.
    pub symbols: Vec<Complex32>,
    /// The range compressor's weights, FFT order.
    pub weights: Vec<f32>,
    /// Elements of the base station's panel.
    pub elements: usize,
}

/// A pair's offsets per frame and, with compensation, what its reference leaves of them.
#[derive(Clone, Debug)]
pub(crate) struct PairSync {
    truth: Vec<FrameOffset>,
    /// With compensation: the radio, the estimator and the reference's noise seed; the
    /// estimates once the noise level is known.
    reference: Option<(ReferenceRadio, DirectPath, u64)>,
    estimates: Option<Vec<FrameOffset>>,
    /// The transmit positions as reported, one per frame.
    tx: Vec<Vec3>,
    /// Where each frame was really sent from, relative to its reported position.
    position_error: Vec<Vec3>,
}

impl PairSync {
    /// The offsets of a pair whose frames are sent from `tx` (in track order), drawn from the
    /// spec's seed and `pair_seed`.
    ///
    /// # Errors
    /// A one-line message naming the field, for a radio the estimator refuses.
    pub(crate) fn new(
        spec: &ImpairmentSpec,
        pair_seed: u64,
        terminal_seed: u64,
        tx: &[Vec3],
        radio: ReferenceRadio,
    ) -> Result<Self, String> {
        let mut rng = ChaCha8Rng::seed_from_u64(spec.seed ^ pair_seed ^ OFFSETS_SEED);
        let uniform = |rng: &mut ChaCha8Rng, half: f64| (2.0 * rng.random::<f64>() - 1.0) * half;
        let tau0_s = uniform(&mut rng, spec.timing_offset_ns * 1e-9);
        let mut cfo_hz = uniform(&mut rng, spec.cfo_hz);
        let (mut walk_s, mut cfo_phase, mut t_prev) = (0.0f64, 0.0f64, 0.0f64);
        let start = tx.first().copied().unwrap_or(Vec3::ZERO);
        let mut truth = Vec::with_capacity(tx.len());
        for (f, p) in tx.iter().enumerate() {
            let t = f64::from(p.distance(start)) / spec.terminal_speed_m_per_s;
            let dt = (t - t_prev).abs();
            if f > 0 {
                let n: f64 = StandardNormal.sample(&mut rng);
                walk_s += n * spec.timing_walk_ns * 1e-9;
                let m: f64 = StandardNormal.sample(&mut rng);
                cfo_phase += TAU * cfo_hz * dt;
                cfo_hz += m * spec.cfo_walk_hz_per_sqrt_s * dt.sqrt();
            }
            t_prev = t;
            let theta = if spec.frame_phase {
                TAU * rng.random::<f64>()
            } else {
                0.0
            };
            let tau = tau0_s + spec.timing_drift_ppm * 1e-6 * t + walk_s;
            truth.push(FrameOffset {
                delay_m: C_M_PER_S * tau,
                phase_rad: (cfo_phase + theta).rem_euclid(TAU),
            });
        }
        let reference = if spec.compensation {
            // The window searched: the largest offset the spec allows over the track, and four
            // standard deviations of the walk, plus two range bins.
            let t_end = tx
                .iter()
                .map(|p| f64::from(p.distance(start)))
                .fold(0.0, f64::max)
                / spec.terminal_speed_m_per_s;
            let bound_s = spec.timing_offset_ns * 1e-9
                + spec.timing_drift_ppm * 1e-6 * t_end
                + 4.0 * spec.timing_walk_ns * 1e-9 * (tx.len() as f64).sqrt();
            let n = radio.symbols.len();
            let unambiguous_m = C_M_PER_S * n as f64 / radio.bandwidth_hz;
            let half_width = (C_M_PER_S * bound_s + 2.0 * C_M_PER_S / radio.bandwidth_hz)
                .min(0.49 * unambiguous_m);
            let dp = DirectPath::new(DirectPathConfig {
                n_subcarriers: n,
                bandwidth_hz: radio.bandwidth_hz,
                search_half_width_m: half_width,
            })
            .map_err(|e| format!("impairments: the direct-path reference: {e}"))?;
            Some((radio, dp, spec.seed ^ pair_seed ^ REFERENCE_NOISE_SEED))
        } else {
            None
        };
        Ok(PairSync {
            truth,
            reference,
            estimates: None,
            tx: tx.to_vec(),
            position_error: position_errors(spec, terminal_seed, tx),
        })
    }

    /// Where frame `f` was really sent from, relative to its reported position (zero beyond the
    /// track).
    pub(crate) fn position_error(&self, f: usize) -> Vec3 {
        self.position_error.get(f).copied().unwrap_or(Vec3::ZERO)
    }

    /// The offsets frame `f` is synthesised with: the true ones without compensation, their
    /// residual after the line-of-sight reference with it. `noise_var` is the echoes' noise power
    /// per profile bin (the reference's noise follows from it); `centre` the panel's centre and
    /// `scene` what may block the line of sight.
    ///
    /// # Errors
    /// A one-line message for a frame index beyond the track or an estimator failure.
    pub(crate) fn residual(
        &mut self,
        f: usize,
        noise_var: f64,
        centre: Vec3,
        scene: &Scene,
    ) -> Result<FrameOffset, String> {
        let truth = *self.truth.get(f).ok_or_else(|| {
            format!(
                "impairments: frame {f} beyond the track's {}",
                self.truth.len()
            )
        })?;
        if self.reference.is_none() {
            return Ok(truth);
        }
        if self.estimates.is_none() {
            self.estimates = Some(self.estimate_all(noise_var, centre, scene)?);
        }
        let est = self.estimates.as_ref().map(|e| e[f]).unwrap_or_default();
        Ok(FrameOffset {
            delay_m: truth.delay_m - est.delay_m,
            phase_rad: (truth.phase_rad - est.phase_rad).rem_euclid(TAU),
        })
    }

    /// Every frame's estimated offsets (module docs), blocked frames bridged by the nearest
    /// frame before (else after) with a line of sight.
    fn estimate_all(
        &self,
        noise_var: f64,
        centre: Vec3,
        scene: &Scene,
    ) -> Result<Vec<FrameOffset>, String> {
        let Some((radio, dp, seed)) = &self.reference else {
            return Ok(vec![FrameOffset::default(); self.truth.len()]);
        };
        let n = radio.symbols.len();
        let lambda = C_M_PER_S / radio.fc_hz;
        let (sum_w, sum_w2) = radio.weights.iter().fold((0.0f64, 0.0f64), |(a, b), &w| {
            (a + f64::from(w), b + f64::from(w) * f64::from(w))
        });
        let sigma_k2 = noise_var * sum_w * sum_w / sum_w2.max(f64::MIN_POSITIVE);
        let noise = ComplexGaussian::with_power(sigma_k2);
        let unambiguous_m = C_M_PER_S * n as f64 / radio.bandwidth_hz;
        let mut y = vec![Complex32::new(0.0, 0.0); n];
        let mut measured: Vec<Option<FrameOffset>> = Vec::with_capacity(self.truth.len());
        for (f, (&tx, truth)) in self.tx.iter().zip(&self.truth).enumerate() {
            if !scene.visible(tx, centre) {
                measured.push(None);
                continue;
            }
            // The path as it is (from where the terminal really was) and as the geometry
            // predicts it (from where it said it was).
            let r_d =
                (tx.as_dvec3() + self.position_error(f).as_dvec3()).distance(centre.as_dvec3());
            let r_pred = f64::from(tx.distance(centre));
            let amp = (radio.elements as f64).sqrt()
                * crate::propagation::free_space_amplitude(r_d, lambda);
            let carrier = (-TAU * r_d / lambda + truth.phase_rad).rem_euclid(TAU);
            let mut rng =
                ChaCha8Rng::seed_from_u64(*seed ^ (f as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
            for (k, (yk, sk)) in y.iter_mut().zip(&radio.symbols).enumerate() {
                // The signed subcarrier index (an offset in units of the spacing).
                let s_k = has_dsp::ofdm::subcarrier_offset_hz(k, n, 1.0);
                let cycles = (s_k * (r_d + truth.delay_m) / unambiguous_m).rem_euclid(1.0);
                let ph = carrier - TAU * cycles;
                let path = Complex32::from_polar(amp as f32, ph as f32);
                *yk = sk * path + noise.sample(&mut rng);
            }
            let est = dp
                .estimate(&y, &radio.symbols, r_pred)
                .map_err(|e| format!("impairments: frame {f}: the direct path: {e}"))?;
            let phase = f64::from(est.amplitude.arg()) + TAU * r_pred / lambda;
            measured.push(Some(FrameOffset {
                delay_m: est.path_m - r_pred,
                phase_rad: phase.rem_euclid(TAU),
            }));
        }
        let first = measured
            .iter()
            .flatten()
            .next()
            .copied()
            .unwrap_or_default();
        let mut last = first;
        Ok(measured
            .into_iter()
            .map(|m| {
                if let Some(m) = m {
                    last = m;
                }
                last
            })
            .collect())
    }
}

/// Mixed into a terminal's seed for its position error's draws.
const POSITION_SEED: u64 = 0x9051_7105_E7A0_5EED;

/// The position error of each frame sent from `tx` (in track order) by one terminal: a bias, a
/// first-order Gauss–Markov process and white noise per axis
/// ([`crate::scenario::PositionError`]), the process stepped by the time between frames.
fn position_errors(spec: &ImpairmentSpec, terminal_seed: u64, tx: &[Vec3]) -> Vec<Vec3> {
    let st = spec.position_error.stats();
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed ^ terminal_seed ^ POSITION_SEED);
    let gauss3 = |rng: &mut ChaCha8Rng, sd: f64| {
        let mut v = [0.0f64; 3];
        for x in &mut v {
            let n: f64 = StandardNormal.sample(rng);
            *x = n * sd;
        }
        glam::DVec3::from(v)
    };
    let bias = gauss3(&mut rng, st.bias_m);
    let mut gm = gauss3(&mut rng, st.gm_m);
    let start = tx.first().copied().unwrap_or(Vec3::ZERO);
    let mut t_prev = 0.0;
    tx.iter()
        .enumerate()
        .map(|(f, p)| {
            let t = f64::from(p.distance(start)) / spec.terminal_speed_m_per_s;
            if f > 0 && st.gm_m > 0.0 {
                let a = (-(t - t_prev).abs() / st.gm_tau_s).exp();
                gm = gm * a + gauss3(&mut rng, st.gm_m * (1.0 - a * a).sqrt());
            }
            t_prev = t;
            (bias + gm + gauss3(&mut rng, st.white_m)).as_vec3()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Material;
    use crate::scenario::PositionError;

    /// A radio of 1024 subcarriers over 400 MHz at 10 GHz, Hann-weighted, and a 32 × 32 panel.
    fn radio() -> ReferenceRadio {
        let n = 1024;
        ReferenceRadio {
            fc_hz: 10e9,
            bandwidth_hz: 400e6,
            symbols: crate::echo::qpsk_symbols(n, 3),
            weights: (0..n)
                .map(|k| {
                    let x = ((k + n / 2) % n) as f64 / n as f64;
                    (0.5 - 0.5 * (TAU * x).cos()) as f32
                })
                .collect(),
            elements: 1024,
        }
    }

    /// 60 frames along 30 m of track, 60 m from a panel at the origin, 10 m up.
    fn track() -> (Vec<Vec3>, Vec3) {
        let tx = (0..60)
            .map(|i| Vec3::new(60.0, -15.0 + 0.5 * i as f32, 1.5))
            .collect();
        (tx, Vec3::new(0.0, 0.0, 10.0))
    }

    /// A scene with one small box far from every line of sight (the BVH needs a triangle).
    fn open_scene() -> Scene {
        let b = crate::shapes::axis_box(
            "far",
            Material::Concrete,
            Vec3::new(-200.0, -200.0, 0.0),
            Vec3::new(-199.0, -199.0, 1.0),
        )
        .unwrap();
        Scene::new(vec![b]).unwrap()
    }

    /// The default impairments with the terminals' positions exact.
    fn exact_positions() -> ImpairmentSpec {
        ImpairmentSpec {
            position_error: PositionError::Profile(crate::scenario::PositionProfile::None),
            ..ImpairmentSpec::default()
        }
    }

    #[test]
    fn the_reference_removes_the_position_errors_share_along_the_line_of_sight() {
        let (tx, centre) = track();
        let spec = ImpairmentSpec::default();
        let mut sync = PairSync::new(&spec, 3, 30, &tx, radio()).unwrap();
        let scene = open_scene();
        let lambda = C_M_PER_S / 10e9;
        let mut worst = 0.0f64;
        for (f, t) in tx.iter().enumerate() {
            let e = sync.position_error(f);
            worst = worst.max(f64::from(e.length()));
            let dr = (t.as_dvec3() + e.as_dvec3()).distance(centre.as_dvec3())
                - f64::from(t.distance(centre));
            let res = sync.residual(f, 1e-30, centre, &scene).unwrap();
            // What is left moves every echo back by the line-of-sight share of the error.
            assert!(
                (res.delay_m + dr).abs() < 1e-4,
                "frame {f}: {res:?}, Δr {dr}"
            );
            let dphi = (res.phase_rad - TAU * dr / lambda + std::f64::consts::PI).rem_euclid(TAU)
                - std::f64::consts::PI;
            assert!(dphi.abs() < 0.02, "frame {f}: phase off by {dphi}");
        }
        // RTK: centimetres, not metres and not nothing.
        assert!(
            worst > 1e-3 && worst < 0.1,
            "largest position error {worst} m"
        );
    }

    #[test]
    fn uncompensated_offsets_lie_within_their_stated_bounds_and_repeat_under_the_seed() {
        let (tx, centre) = track();
        let spec = ImpairmentSpec {
            compensation: false,
            ..ImpairmentSpec::default()
        };
        let scene = open_scene();
        let mut a = PairSync::new(&spec, 7, 70, &tx, radio()).unwrap();
        let mut b = PairSync::new(&spec, 7, 70, &tx, radio()).unwrap();
        let mut other = PairSync::new(&spec, 8, 80, &tx, radio()).unwrap();
        // 30 m at 10 m/s: 3 s, 0.3 µs of drift... at 0.1 ppm, 0.3 ns; the walk 0.2 ns × √60.
        let bound_m = C_M_PER_S * (114e-9 + 0.1e-6 * 3.0 + 5.0 * 0.2e-9 * 60f64.sqrt());
        let mut phases = Vec::new();
        for f in 0..tx.len() {
            let (x, y) = (
                a.residual(f, 1.0, centre, &scene).unwrap(),
                b.residual(f, 1.0, centre, &scene).unwrap(),
            );
            assert_eq!(x, y);
            assert!(x.delay_m.abs() <= bound_m, "frame {f}: {x:?}");
            assert!((0.0..TAU).contains(&x.phase_rad));
            assert_ne!(x, other.residual(f, 1.0, centre, &scene).unwrap());
            phases.push(x.phase_rad);
        }
        // Independent oscillator phases: their mean resultant is small (1/√60 expected).
        let (c, s) = phases
            .iter()
            .fold((0.0, 0.0), |(c, s), p| (c + p.cos(), s + p.sin()));
        assert!((c * c + s * s).sqrt() / 60.0 < 0.4);
        assert!(a.residual(60, 1.0, centre, &scene).is_err());
    }

    #[test]
    fn the_line_of_sight_reference_leaves_its_cramer_rao_bound() {
        let (tx, centre) = track();
        let spec = exact_positions();
        let scene = open_scene();
        let r = radio();
        // Noise per profile bin such that the beam's direct path has 0 dB per subcarrier at the
        // track's middle: σ_k² = E·A², σ_p² = σ_k²·Σw²/(Σw)².
        let lambda = C_M_PER_S / r.fc_hz;
        let r_mid = f64::from(tx[30].distance(centre));
        let a2 =
            r.elements as f64 * crate::propagation::free_space_amplitude(r_mid, lambda).powi(2);
        let (sw, sw2) = r.weights.iter().fold((0.0, 0.0), |(a, b), &w| {
            (a + f64::from(w), b + f64::from(w).powi(2))
        });
        let noise_var = a2 * sw2 / (sw * sw);
        let mut sync = PairSync::new(&spec, 11, 110, &tx, r.clone()).unwrap();
        let dp = DirectPath::new(DirectPathConfig {
            n_subcarriers: 1024,
            bandwidth_hz: r.bandwidth_hz,
            search_half_width_m: 50.0,
        })
        .unwrap();
        let (crb_m, crb_rad) = (dp.path_crb_m(1.0), dp.phase_crb_rad(1.0));
        let (mut d2, mut p2) = (0.0, 0.0);
        for f in 0..tx.len() {
            let res = sync.residual(f, noise_var, centre, &scene).unwrap();
            d2 += res.delay_m * res.delay_m;
            let p = (res.phase_rad + std::f64::consts::PI).rem_euclid(TAU) - std::f64::consts::PI;
            p2 += p * p;
        }
        let (rms_m, rms_rad) = ((d2 / 60.0).sqrt(), (p2 / 60.0).sqrt());
        // Within 2× the bounds (the SNR varies by ±0.5 dB along the track). Delay and phase
        // decouple over symmetric subcarriers, so the phase's bound is its own.
        assert!(rms_m < 2.0 * crb_m, "delay rms {rms_m} m, CRB {crb_m} m");
        assert!(
            rms_rad < 2.0 * crb_rad,
            "phase rms {rms_rad} rad, CRB {crb_rad} rad"
        );
    }

    #[test]
    fn a_blocked_frame_keeps_the_estimate_of_the_last_frame_that_saw_the_terminal() {
        let (tx, centre) = track();
        // A wall across the lines of sight of frames 20–29 (y from −5 to 0 at x = 60).
        let wall = crate::shapes::axis_box(
            "wall",
            Material::Concrete,
            Vec3::new(30.0, -2.6, 0.0),
            Vec3::new(30.5, -0.1, 20.0),
        )
        .unwrap();
        let scene = Scene::new(vec![wall]).unwrap();
        let blocked: Vec<bool> = tx.iter().map(|&p| !scene.visible(p, centre)).collect();
        assert!(blocked.iter().any(|&b| b) && !blocked[0]);
        let spec = exact_positions();
        let mut sync = PairSync::new(&spec, 5, 50, &tx, radio()).unwrap();
        let mut open = PairSync::new(&spec, 5, 50, &tx, radio()).unwrap();
        let free = open_scene();
        let truth = PairSync::new(
            &ImpairmentSpec {
                compensation: false,
                ..spec
            },
            5,
            50,
            &tx,
            radio(),
        )
        .unwrap()
        .truth;
        let mut last = 0;
        for f in 0..tx.len() {
            let got = sync.residual(f, 1e-30, centre, &scene).unwrap();
            if blocked[f] {
                // The estimate held from frame `last`: the residual is the offsets' change since.
                let want = open.residual(last, 1e-30, centre, &free).unwrap();
                let est = truth[last].delay_m - want.delay_m;
                assert!(
                    (got.delay_m - (truth[f].delay_m - est)).abs() < 1e-9,
                    "frame {f}"
                );
            } else {
                assert!(got.delay_m.abs() < 1e-3, "frame {f}: {got:?}");
                last = f;
            }
        }
    }
}
