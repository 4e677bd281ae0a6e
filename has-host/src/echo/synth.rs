//! Synthesis of one frame: range-compressed profiles (a) and raw OFDM subcarriers (b), from surface
//! scatterers or from free point scatterers, for one transmitter and many receive elements.
//!
//! Per call, everything that depends only on the transmitter (rV, θi, Fresnel, area, normal) is
//! computed once per scatterer; per element only `rR`, `cos θs`, the phase and the pulse taps.
//! Rayon runs across receive elements (one output row each). Geometry and phase are `f64`, taps
//! and output `f32`.
//!
//! Noise ([`Noise`]) in (b) is complex white Gaussian, `E|n|² = σ²` per subcarrier, seeded: the
//! noise of element `e` is ChaCha8 stream `e` of the caller's seed. `Noise::SnrDb(snr)` sets
//! `σ² = P / 10^{snr/10}` with `P` the mean of `|S[k]·H[k]|²` over all subcarriers and elements of
//! the call.

use std::f64::consts::PI;

use glam::{DVec3, Vec3};
use num_complex::{Complex32, Complex64};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::kernel::floor_fast;
use super::noise::{noise_stream, ComplexGaussian};
use super::{check_pos, EchoConfig, EchoError, PulseKernel, ScattererSet};
use crate::propagation::{free_space_amplitude, fresnel_reflection};
use has_dsp::geometry::C_M_PER_S;

/// A free point scatterer: its amplitude is used as given (no spreading, no facing test); only the
/// path length `|p − tx| + |p − rx|` sets delay and phase.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointScatterer {
    /// Position, metres.
    pub pos: Vec3,
    /// Complex amplitude of the echo at the receiver.
    pub amp: Complex32,
}

/// Receiver noise added to raw OFDM subcarriers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Noise {
    /// Noise-free.
    None,
    /// Per-subcarrier SNR in dB relative to the mean `|S·H|²` of the call (module docs).
    SnrDb(f64),
    /// Absolute noise power `E|n|²` per subcarrier (same units as `|S·H|²`).
    Power(f64),
}

/// Transmit-leg factor of [`bistatic_amplitude`]: `λ/(4π rV) · √(16π |Γ|² cos θi A) / (4π)`.
#[inline]
fn tx_leg(refl2: f64, cos_i: f64, area_m2: f64, rv: f64, lambda: f64) -> f64 {
    free_space_amplitude(rv, lambda) * (16.0 * PI * refl2 * cos_i * area_m2).sqrt() / (4.0 * PI)
}

/// Receive-leg factor of [`bistatic_amplitude`]: `√(cos θs) / rR`.
#[inline]
fn rx_leg(cos_s: f64, rr: f64) -> f64 {
    cos_s.sqrt() / rr
}

/// Echo amplitude of one diffuse scatterer (module docs of [`crate::echo`]):
/// `√σ·λ/((4π)^{3/2} rV rR)` with `σ = 4·refl2·cos θi·cos θs·A`, `refl2` the power reflectivity
/// `|Γ|²`. Angles as cosines (clamped at 0), distances and wavelength in metres, area in m².
pub fn bistatic_amplitude(
    refl2: f64,
    cos_i: f64,
    cos_s: f64,
    area_m2: f64,
    rv: f64,
    rr: f64,
    lambda: f64,
) -> f64 {
    tx_leg(refl2, cos_i.max(0.0), area_m2, rv, lambda) * rx_leg(cos_s.max(0.0), rr)
}

/// A scatterer prepared for one transmitter position.
#[derive(Clone, Copy, Debug)]
struct Prep {
    pos: DVec3,
    /// Front normal (facing the transmitter); unused when `!facing`.
    n: DVec3,
    rv: f64,
    /// Transmit-leg amplitude (surface) or the full amplitude (points).
    amp: Complex32,
    facing: bool,
}

/// Entries of the carrier-phasor table `e^{−j2π i/PHASOR_N}` (linear interpolation between
/// entries: magnitude error ≤ (2π/PHASOR_N)²/8 = 2.9e-7, phase error below f32 rounding).
const PHASOR_N: usize = 4096;
/// Bound on the phasor table's error, relative.
const PHASOR_ERR: f32 = 3e-7;

/// Echo synthesiser for one [`EchoConfig`] (owns the tabulated pulse).
#[derive(Clone, Debug)]
pub struct EchoSynth {
    cfg: EchoConfig,
    kernel: PulseKernel,
    phasor: Vec<Complex32>,
}

fn check_elements(rx: &[Vec3]) -> Result<(), EchoError> {
    if let Some(i) = rx.iter().position(|v| !v.is_finite()) {
        return Err(EchoError::invalid(
            "rx_elements",
            format!("[{i}] = {:?}", rx[i]),
        ));
    }
    Ok(())
}

fn check_out(out_len: usize, rows: usize, row_len: usize) -> Result<(), EchoError> {
    if out_len != rows * row_len {
        return Err(EchoError::LengthMismatch {
            field: "out",
            expected: rows * row_len,
            got: out_len,
        });
    }
    Ok(())
}

impl EchoSynth {
    /// Validates `cfg` and tabulates its pulse.
    ///
    /// # Errors
    /// As [`EchoConfig::validate`].
    pub fn new(cfg: EchoConfig) -> Result<Self, EchoError> {
        let kernel = PulseKernel::new(&cfg)?;
        let phasor = (0..=PHASOR_N)
            .map(|i| {
                let a = -2.0 * PI * i as f64 / PHASOR_N as f64;
                Complex32::new(a.cos() as f32, a.sin() as f32)
            })
            .collect();
        Ok(EchoSynth {
            cfg,
            kernel,
            phasor,
        })
    }

    /// Bound on `|(a) − exact|` per profile bin for one scatterer of unit amplitude: the pulse
    /// kernel's [`PulseKernel::error_bound`] plus the carrier-phasor table's 3e-7.
    pub fn error_bound(&self) -> f32 {
        self.kernel.error_bound() + PHASOR_ERR
    }

    /// The configuration.
    pub fn config(&self) -> &EchoConfig {
        &self.cfg
    }

    /// The tabulated pulse (and its stated error).
    pub fn kernel(&self) -> &PulseKernel {
        &self.kernel
    }

    fn prepare_surface(
        &self,
        set: &ScattererSet,
        visible: &[u32],
        tx: Vec3,
    ) -> Result<Vec<Prep>, EchoError> {
        check_pos("tx", tx)?;
        if let Some((position, &index)) = visible
            .iter()
            .enumerate()
            .find(|(_, &i)| i as usize >= set.len())
        {
            return Err(EchoError::BadIndex {
                position,
                index,
                len: set.len(),
            });
        }
        let lambda = self.cfg.wavelength_m();
        let etas: Vec<Complex64> = set
            .object_materials
            .iter()
            .map(|m| m.complex_permittivity(self.cfg.fc_hz))
            .collect();
        let txd = tx.as_dvec3();
        Ok(visible
            .par_iter()
            .filter_map(|&i| {
                let s = &set.points[i as usize];
                let n = set.front_normal(s, tx)?.as_dvec3();
                let pos = s.pos.as_dvec3();
                let d = txd - pos;
                let rv = d.length();
                let cos_i = (n.dot(d) / rv).clamp(0.0, 1.0);
                let eta = *etas.get(s.object as usize)?;
                let f = fresnel_reflection(eta, cos_i);
                let refl2 = 0.5 * (f.te.norm_sqr() + f.tm.norm_sqr());
                let a = tx_leg(refl2, cos_i, s.area_m2 as f64, rv, lambda);
                Some(Prep {
                    pos,
                    n,
                    rv,
                    amp: Complex32::new(a as f32, 0.0),
                    facing: true,
                })
            })
            .collect())
    }

    fn prepare_points(&self, points: &[PointScatterer], tx: Vec3) -> Result<Vec<Prep>, EchoError> {
        check_pos("tx", tx)?;
        if let Some(i) = points
            .iter()
            .position(|p| !p.pos.is_finite() || !p.amp.re.is_finite() || !p.amp.im.is_finite())
        {
            return Err(EchoError::invalid(
                "points",
                format!("[{i}] = {:?}", points[i]),
            ));
        }
        let txd = tx.as_dvec3();
        Ok(points
            .iter()
            .map(|p| {
                let pos = p.pos.as_dvec3();
                Prep {
                    pos,
                    n: DVec3::ZERO,
                    rv: pos.distance(txd),
                    amp: p.amp,
                    facing: false,
                }
            })
            .collect())
    }

    /// Calls `f(r, a)` for each contribution at element `rx`: bistatic path `r` (m) and complex
    /// amplitude `a` (without the propagation phase).
    #[inline]
    fn for_each_path(prep: &[Prep], rx: DVec3, mut f: impl FnMut(f64, Complex32)) {
        for p in prep {
            let d = rx - p.pos;
            let rr = d.length();
            let amp = if p.facing {
                let cos_s = p.n.dot(d) / rr;
                if cos_s <= 0.0 {
                    continue;
                }
                p.amp * rx_leg(cos_s, rr) as f32
            } else {
                p.amp
            };
            f(p.rv + rr, amp);
        }
    }

    /// `e^{−j2π r/λ}`: the fractional number of wavelengths in `f64`, then the phasor table.
    #[inline]
    fn carrier_phasor(&self, r: f64) -> Complex32 {
        let cycles = r * self.cfg.fc_hz / C_M_PER_S;
        let x = (cycles - floor_fast(cycles)) * PHASOR_N as f64;
        let i = (x as usize).min(PHASOR_N - 1);
        let t = (x - i as f64) as f32;
        let (a, b) = (self.phasor[i], self.phasor[i + 1]);
        a + (b - a) * t
    }

    fn profiles_from(&self, prep: &[Prep], rx: &[Vec3], out: &mut [Complex32]) {
        let n_bins = self.cfg.n_bins;
        let inv_dr = 1.0 / self.cfg.bin_spacing_m();
        let r0 = self.cfg.r0_m;
        out.par_chunks_mut(n_bins)
            .zip(rx.par_iter())
            .for_each(|(row, &e)| {
                row.fill(Complex32::new(0.0, 0.0));
                Self::for_each_path(prep, e.as_dvec3(), |r, a| {
                    self.kernel
                        .deposit(row, (r - r0) * inv_dr, a * self.carrier_phasor(r));
                });
            });
    }

    /// (a) Range-compressed profiles of the scatterers `visible` (indices into `set`, e.g. from
    /// [`super::visible_for`]) for a transmitter at `tx`, one row of `n_bins` per element of
    /// `rx_elements` in `out` (row-major, overwritten).
    ///
    /// # Errors
    /// `InvalidParameter` for non-finite positions, `LengthMismatch` for `out`, `BadIndex` for
    /// an index beyond the set.
    pub fn synth_profiles(
        &self,
        set: &ScattererSet,
        visible: &[u32],
        tx: Vec3,
        rx_elements: &[Vec3],
        out: &mut [Complex32],
    ) -> Result<(), EchoError> {
        check_elements(rx_elements)?;
        check_out(out.len(), rx_elements.len(), self.cfg.n_bins)?;
        let prep = self.prepare_surface(set, visible, tx)?;
        self.profiles_from(&prep, rx_elements, out);
        Ok(())
    }

    /// (a) for free point scatterers (amplitudes as given).
    ///
    /// # Errors
    /// As [`EchoSynth::synth_profiles`]; a non-finite point or amplitude is `InvalidParameter`.
    pub fn synth_profiles_points(
        &self,
        points: &[PointScatterer],
        tx: Vec3,
        rx_elements: &[Vec3],
        out: &mut [Complex32],
    ) -> Result<(), EchoError> {
        check_elements(rx_elements)?;
        check_out(out.len(), rx_elements.len(), self.cfg.n_bins)?;
        let prep = self.prepare_points(points, tx)?;
        self.profiles_from(&prep, rx_elements, out);
        Ok(())
    }

    /// Adds to one profile row (`n_bins` long) the compressed pulses of arbitrary paths
    /// `(bistatic path length m, complex amplitude)` with their carrier phase `e^{−j2π r/λ}` (e.g.
    /// specular multipath from the path tracer).
    ///
    /// # Errors
    /// `LengthMismatch` for `row`, `InvalidParameter` for a non-finite path.
    pub fn add_paths_to_profile(
        &self,
        paths: &[(f64, Complex32)],
        row: &mut [Complex32],
    ) -> Result<(), EchoError> {
        check_out(row.len(), 1, self.cfg.n_bins)?;
        if let Some(i) = paths
            .iter()
            .position(|(r, a)| !r.is_finite() || !a.re.is_finite() || !a.im.is_finite())
        {
            return Err(EchoError::invalid(
                "paths",
                format!("[{i}] = {:?}", paths[i]),
            ));
        }
        let inv_dr = 1.0 / self.cfg.bin_spacing_m();
        for &(r, a) in paths {
            self.kernel.deposit(
                row,
                (r - self.cfg.r0_m) * inv_dr,
                a * self.carrier_phasor(r),
            );
        }
        Ok(())
    }

    fn ofdm_from(
        &self,
        prep: &[Prep],
        rx: &[Vec3],
        symbols: &[Complex32],
        noise: Noise,
        seed: u64,
        out: &mut [Complex32],
    ) -> Result<f64, EchoError> {
        let n = self.cfg.n_subcarriers;
        check_out(symbols.len(), 1, n).map_err(|_| EchoError::LengthMismatch {
            field: "symbols",
            expected: n,
            got: symbols.len(),
        })?;
        check_out(out.len(), rx.len(), n)?;
        match noise {
            Noise::SnrDb(v) if !v.is_finite() => return Err(EchoError::invalid("noise.snr_db", v)),
            Noise::Power(v) if !(v.is_finite() && v >= 0.0) => {
                return Err(EchoError::invalid("noise.power", v))
            }
            _ => {}
        }
        let df = self.cfg.subcarrier_spacing_hz();
        let half = n / 2;
        let neg_start = half as f64 - n as f64;
        let power: f64 = out
            .par_chunks_mut(n)
            .zip(rx.par_iter())
            .map(|(row, &e)| {
                let mut h = vec![Complex64::new(0.0, 0.0); n];
                Self::for_each_path(prep, e.as_dvec3(), |r, a| {
                    let a = Complex64::new(a.re as f64, a.im as f64);
                    let cyc = r * self.cfg.fc_hz / C_M_PER_S;
                    let base = a * Complex64::from_polar(1.0, -2.0 * PI * (cyc - cyc.floor()));
                    let step_cyc = r * df / C_M_PER_S;
                    let step =
                        Complex64::from_polar(1.0, -2.0 * PI * (step_cyc - step_cyc.floor()));
                    let mut v = base;
                    for hk in &mut h[..half] {
                        *hk += v;
                        v *= step;
                    }
                    let c0 = neg_start * step_cyc;
                    let mut v = base * Complex64::from_polar(1.0, -2.0 * PI * (c0 - c0.floor()));
                    for hk in &mut h[half..] {
                        *hk += v;
                        v *= step;
                    }
                });
                let mut p = 0.0;
                for ((y, hk), s) in row.iter_mut().zip(&h).zip(symbols) {
                    let v = Complex64::new(s.re as f64, s.im as f64) * hk;
                    p += v.norm_sqr();
                    *y = Complex32::new(v.re as f32, v.im as f32);
                }
                p
            })
            .sum();
        let mean = power / (n * rx.len()).max(1) as f64;
        let var = match noise {
            Noise::None => 0.0,
            Noise::SnrDb(snr) => mean / 10f64.powf(snr / 10.0),
            Noise::Power(p) => p,
        };
        if var > 0.0 {
            let noise = ComplexGaussian::with_power(var);
            out.par_chunks_mut(n).enumerate().for_each(|(e, row)| {
                let mut rng = noise_stream(seed, e as u64);
                for y in row {
                    *y += noise.sample(&mut rng);
                }
            });
        }
        Ok(var)
    }

    /// (b) Raw OFDM subcarriers `Y[k] = S[k]·H[k] + n[k]` (FFT order) of the scatterers `visible`
    /// for a transmitter at `tx`, one row of `n_subcarriers` per element in `out` (overwritten).
    /// `symbols` is the transmitted frame `S` (`n_subcarriers` long, e.g. [`qpsk_symbols`]);
    /// `seed` seeds the noise. Returns the noise power `σ²` used.
    ///
    /// # Errors
    /// As [`EchoSynth::synth_profiles`]; `LengthMismatch` for `symbols`; `InvalidParameter` for a
    /// non-finite SNR or a negative noise power.
    #[allow(clippy::too_many_arguments)]
    pub fn synth_ofdm(
        &self,
        set: &ScattererSet,
        visible: &[u32],
        tx: Vec3,
        rx_elements: &[Vec3],
        symbols: &[Complex32],
        noise: Noise,
        seed: u64,
        out: &mut [Complex32],
    ) -> Result<f64, EchoError> {
        check_elements(rx_elements)?;
        let prep = self.prepare_surface(set, visible, tx)?;
        self.ofdm_from(&prep, rx_elements, symbols, noise, seed, out)
    }

    /// (b) for free point scatterers (amplitudes as given).
    ///
    /// # Errors
    /// As [`EchoSynth::synth_ofdm`].
    #[allow(clippy::too_many_arguments)]
    pub fn synth_ofdm_points(
        &self,
        points: &[PointScatterer],
        tx: Vec3,
        rx_elements: &[Vec3],
        symbols: &[Complex32],
        noise: Noise,
        seed: u64,
        out: &mut [Complex32],
    ) -> Result<f64, EchoError> {
        check_elements(rx_elements)?;
        let prep = self.prepare_points(points, tx)?;
        self.ofdm_from(&prep, rx_elements, symbols, noise, seed, out)
    }
}

/// `n` QPSK symbols `(±1 ± j)/√2` (unit modulus) from a ChaCha8 stream of `seed`.
pub fn qpsk_symbols(n: usize, seed: u64) -> Vec<Complex32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let a = std::f32::consts::FRAC_1_SQRT_2;
    (0..n)
        .map(|_| {
            let b: u8 = rng.random_range(0..4);
            Complex32::new(
                if b & 1 == 0 { a } else { -a },
                if b & 2 == 0 { a } else { -a },
            )
        })
        .collect()
}

/// A Zadoff–Chu sequence of length `n` and root `u` (unit modulus; constant amplitude in both
/// domains when `gcd(u, n) = 1`): `e^{−jπ u k(k + n mod 2)/n}`, phase reduced exactly in integers.
///
/// # Errors
/// `InvalidParameter` for `n == 0` or `u == 0`.
pub fn zadoff_chu(n: usize, u: u64) -> Result<Vec<Complex32>, EchoError> {
    if n == 0 {
        return Err(EchoError::invalid("n", 0));
    }
    if u == 0 {
        return Err(EchoError::invalid("root", 0));
    }
    let nn = n as u128;
    let cf = nn % 2;
    Ok((0..n as u128)
        .map(|k| {
            let num = (u as u128 * k * (k + cf)) % (2 * nn);
            let ang = -PI * num as f64 / n as f64;
            Complex32::new(ang.cos() as f32, ang.sin() as f32)
        })
        .collect())
}
