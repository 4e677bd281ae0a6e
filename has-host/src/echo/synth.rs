//! Synthesis of one frame: range-compressed profiles (a) and raw OFDM subcarriers (b), from surface
//! scatterers or from free point scatterers, for one transmitter and many receive elements.
//!
//! Per call, everything that depends only on the transmitter (rV, θi, Fresnel, area, normal) is
//! computed once per scatterer; per element only `rR`, `cos θs`, the phase and the pulse taps.
//! Rayon runs across receive elements (one output row each), each row in the widest vector build
//! the CPU runs ([`has_dsp::simd`]; the same bits). Geometry and phase are `f64`, taps
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

use super::kernel::{floor_fast, floor_small, FLOOR_SMALL_MAX};
use super::noise::{noise_stream, ComplexGaussian};
use super::{check_pos, EchoConfig, EchoError, PulseKernel, ScattererSet};
use crate::propagation::{free_space_amplitude, reflection};
use has_dsp::geometry::C_M_PER_S;
use has_dsp::simd::{run_simd, SimdJob};

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

/// Scatterers prepared for one transmitter position, as a struct of arrays (the per-element pass
/// over them vectorises, see [`EchoSynth::profile_row`]).
#[derive(Clone, Debug, Default)]
struct Prepared {
    /// Positions, metres.
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    /// Front normals (facing the transmitter); empty for free points.
    nx: Vec<f64>,
    ny: Vec<f64>,
    nz: Vec<f64>,
    /// Transmit-leg distances `rV`, metres.
    rv: Vec<f64>,
    /// Transmit-leg amplitude (surface) or the full amplitude (points).
    amp: Vec<Complex32>,
    /// Surface scatterers: the receive leg's facing test and `√cos θs / rR` apply; free points:
    /// the amplitude is used as given.
    facing: bool,
}

impl Prepared {
    fn with_capacity(n: usize, facing: bool) -> Self {
        let v = || Vec::with_capacity(n);
        let (nx, ny, nz) = if facing {
            (v(), v(), v())
        } else {
            Default::default()
        };
        Prepared {
            x: v(),
            y: v(),
            z: v(),
            nx,
            ny,
            nz,
            rv: v(),
            amp: Vec::with_capacity(n),
            facing,
        }
    }

    fn push(&mut self, pos: DVec3, n: DVec3, rv: f64, amp: Complex32) {
        self.x.push(pos.x);
        self.y.push(pos.y);
        self.z.push(pos.z);
        if self.facing {
            self.nx.push(n.x);
            self.ny.push(n.y);
            self.nz.push(n.z);
        }
        self.rv.push(rv);
        self.amp.push(amp);
    }

    fn len(&self) -> usize {
        self.x.len()
    }
}

/// Scatterers per block of the per-element pass (its scratch lives on the stack).
const BLOCK: usize = 128;

/// Receive legs of scatterers `lo .. lo + r.len()` at element `e` (`r`, `scale`, `keep` equally
/// long, at most [`BLOCK`]): the bistatic path `r = rV + rR`, the receive-leg factor
/// (`√cos θs / rR` for surfaces, 1 for points) and whether the path exists (a surface scatterer
/// whose front faces away from the element has none). The same IEEE operations in the same order
/// as [`EchoSynth::for_each_path`], written branch-free over arrays so that it vectorises.
#[inline(always)]
fn receive_legs(
    p: &Prepared,
    lo: usize,
    e: DVec3,
    r: &mut [f64],
    scale: &mut [f32],
    keep: &mut [bool],
) {
    let n = r.len();
    let (x, y, z, rv) = (
        &p.x[lo..lo + n],
        &p.y[lo..lo + n],
        &p.z[lo..lo + n],
        &p.rv[lo..lo + n],
    );
    let mut rr = [0f64; BLOCK];
    let mut dx = [0f64; BLOCK];
    let mut dy = [0f64; BLOCK];
    let mut dz = [0f64; BLOCK];
    for k in 0..n {
        (dx[k], dy[k], dz[k]) = (e.x - x[k], e.y - y[k], e.z - z[k]);
        rr[k] = (dx[k] * dx[k] + dy[k] * dy[k] + dz[k] * dz[k]).sqrt();
        r[k] = rv[k] + rr[k];
    }
    if !p.facing {
        scale[..n].fill(1.0);
        keep[..n].fill(true);
        return;
    }
    let (nx, ny, nz) = (&p.nx[lo..lo + n], &p.ny[lo..lo + n], &p.nz[lo..lo + n]);
    for k in 0..n {
        let cos_s = (nx[k] * dx[k] + ny[k] * dy[k] + nz[k] * dz[k]) / rr[k];
        // Not `cos_s > 0`: a NaN keeps its path, as in `for_each_path`.
        keep[k] = cos_s > 0.0 || cos_s.is_nan();
        let c = if keep[k] { cos_s } else { 0.0 };
        scale[k] = rx_leg(c, rr[k]) as f32;
    }
}

/// Entries of the carrier-phasor table `e^{−j2π i/PHASOR_N}` (linear interpolation between
/// entries: magnitude error ≤ (2π/PHASOR_N)²/8 = 2.9e-7, phase error below f32 rounding).
const PHASOR_N: usize = 4096;
/// Bound on the phasor table's error, relative.
const PHASOR_ERR: f32 = 3e-7;

/// [`EchoSynth::profile_row`] as a job for [`run_simd`]: the row's loops in the widest vector
/// build the CPU runs, with the same bits.
struct ProfileRow<'a> {
    synth: &'a EchoSynth,
    prep: &'a Prepared,
    e: DVec3,
    r0_m: f64,
    row: &'a mut [Complex32],
}

impl SimdJob for ProfileRow<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        self.synth
            .profile_row(self.prep, self.e, self.r0_m, self.row)
    }
}

/// Where `cycles` (floor `fl`) falls in the phasor table: entry `i` and the weight `t` toward
/// `i + 1`. `x` lies in `[0, PHASOR_N]`; branch-free with a 32-bit conversion, so that a loop of
/// it vectorises.
#[inline(always)]
fn phasor_index(cycles: f64, fl: f64) -> (u32, f32) {
    let x = (cycles - fl) * PHASOR_N as f64;
    let i = (x as i32).clamp(0, PHASOR_N as i32 - 1);
    (i as u32, (x - i as f64) as f32)
}

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
    ) -> Result<Prepared, EchoError> {
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
        let rows: Vec<(DVec3, DVec3, f64, f64)> = visible
            .par_iter()
            .filter_map(|&i| {
                let s = &set.points[i as usize];
                let n = set.front_normal(s, tx)?.as_dvec3();
                let pos = s.pos.as_dvec3();
                let d = txd - pos;
                let rv = d.length();
                let cos_i = (n.dot(d) / rv).clamp(0.0, 1.0);
                let eta = *etas.get(s.object as usize)?;
                let thickness = set.object_thickness_m.get(s.object as usize).copied()?;
                let f = reflection(eta, cos_i, thickness, lambda);
                let refl2 = 0.5 * (f.te.norm_sqr() + f.tm.norm_sqr());
                let a = tx_leg(refl2, cos_i, s.area_m2 as f64, rv, lambda);
                Some((pos, n, rv, a))
            })
            .collect();
        let mut prep = Prepared::with_capacity(rows.len(), true);
        for (pos, n, rv, a) in rows {
            prep.push(pos, n, rv, Complex32::new(a as f32, 0.0));
        }
        Ok(prep)
    }

    fn prepare_points(&self, points: &[PointScatterer], tx: Vec3) -> Result<Prepared, EchoError> {
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
        let mut prep = Prepared::with_capacity(points.len(), false);
        for p in points {
            let pos = p.pos.as_dvec3();
            prep.push(pos, DVec3::ZERO, pos.distance(txd), p.amp);
        }
        Ok(prep)
    }

    /// Calls `f(r, a)` for each contribution at element `rx`: bistatic path `r` (m) and complex
    /// amplitude `a` (without the propagation phase). One path at a time: the plain form of
    /// [`receive_legs`], which gives the same bits.
    #[inline]
    fn for_each_path(p: &Prepared, rx: DVec3, mut f: impl FnMut(f64, Complex32)) {
        for k in 0..p.len() {
            let d = rx - DVec3::new(p.x[k], p.y[k], p.z[k]);
            let rr = d.length();
            let amp = if p.facing {
                let cos_s = DVec3::new(p.nx[k], p.ny[k], p.nz[k]).dot(d) / rr;
                if cos_s <= 0.0 {
                    continue;
                }
                p.amp[k] * rx_leg(cos_s, rr) as f32
            } else {
                p.amp[k]
            };
            f(p.rv[k] + rr, amp);
        }
    }

    /// `e^{−j2π r/λ}`: the fractional number of wavelengths in `f64`, then the phasor table.
    #[inline]
    fn carrier_phasor(&self, r: f64) -> Complex32 {
        let cycles = self.cycles(r);
        self.phasor_of(cycles, floor_fast(cycles))
    }

    /// `r/λ`, the number of carrier wavelengths in path `r`.
    #[inline(always)]
    fn cycles(&self, r: f64) -> f64 {
        r * self.cfg.fc_hz / C_M_PER_S
    }

    /// `e^{−j2π·cycles}` from the table, given `fl = ⌊cycles⌋`.
    #[inline(always)]
    fn phasor_of(&self, cycles: f64, fl: f64) -> Complex32 {
        self.phasor_at(phasor_index(cycles, fl))
    }

    /// The table's phasor at [`phasor_index`] `(i, t)`: linear between entries `i` and `i + 1`.
    #[inline(always)]
    fn phasor_at(&self, (i, t): (u32, f32)) -> Complex32 {
        let i = i as usize;
        let (a, b) = (self.phasor[i], self.phasor[i + 1]);
        a + (b - a) * t
    }

    fn profiles_from(&self, prep: &Prepared, rx: &[Vec3], r0_m: f64, out: &mut [Complex32]) {
        out.par_chunks_mut(self.cfg.n_bins)
            .zip(rx.par_iter())
            .for_each(|(row, &e)| {
                run_simd(ProfileRow {
                    synth: self,
                    prep,
                    e: e.as_dvec3(),
                    r0_m,
                    row,
                })
            });
    }

    /// One element's profile (`row`, overwritten): receive legs a block at a time
    /// ([`receive_legs`], vectorised), then each path's phasor and pulse taps.
    #[inline(always)]
    fn profile_row(&self, prep: &Prepared, e: DVec3, r0: f64, row: &mut [Complex32]) {
        let inv_dr = 1.0 / self.cfg.bin_spacing_m();
        let (mut row_re, mut row_im) = (vec![0f32; row.len()], vec![0f32; row.len()]);
        let (mut r, mut scale, mut keep) = ([0f64; BLOCK], [0f32; BLOCK], [false; BLOCK]);
        // Per path: the fractional bin `u`, the carrier cycles, and their floors (exact below
        // `FLOOR_SMALL_MAX`, where pass B takes them; `floor_fast` above).
        let (mut u, mut u_fl) = ([0f64; BLOCK], [0f64; BLOCK]);
        let (mut cyc, mut cyc_fl) = ([0f64; BLOCK], [0f64; BLOCK]);
        // Per path: its place in the pulse table and in the phasor table.
        let mut taps = [(0u32, 0f32, 0i64); BLOCK];
        let mut phasor = [(0u32, 0f32); BLOCK];
        let mut lo = 0;
        while lo < prep.len() {
            let n = BLOCK.min(prep.len() - lo);
            receive_legs(prep, lo, e, &mut r[..n], &mut scale[..n], &mut keep[..n]);
            for k in 0..n {
                u[k] = (r[k] - r0) * inv_dr;
                u_fl[k] = floor_small(u[k]);
                cyc[k] = self.cycles(r[k]);
                cyc_fl[k] = floor_small(cyc[k]);
                taps[k] = self.kernel.tap_phase(u[k], u_fl[k]);
                phasor[k] = phasor_index(cyc[k], cyc_fl[k]);
            }
            for k in 0..n {
                if !keep[k] || !PulseKernel::deposits(u[k]) {
                    continue;
                }
                let a = prep.amp[lo + k] * scale[k];
                let c = cyc[k];
                let ph = if c.abs() < FLOOR_SMALL_MAX {
                    self.phasor_at(phasor[k])
                } else {
                    self.phasor_of(c, floor_fast(c))
                };
                // `|u| ≤ 1e15 < FLOOR_SMALL_MAX`: its floor is exact.
                self.kernel
                    .deposit_split(&mut row_re, &mut row_im, taps[k], a * ph);
            }
            lo += n;
        }
        for ((z, re), im) in row.iter_mut().zip(row_re).zip(row_im) {
            *z = Complex32::new(re, im);
        }
    }

    /// [`Self::profiles_from`] one path at a time ([`Self::for_each_path`]): the plain reference
    /// the blocked path is checked and benchmarked against.
    fn profiles_plain(&self, prep: &Prepared, rx: &[Vec3], out: &mut [Complex32]) {
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
        let prep = self.prepare_profiles(set, visible, tx, rx_elements, out)?;
        self.profiles_from(&prep, rx_elements, self.cfg.r0_m, out);
        Ok(())
    }

    /// [`Self::synth_profiles`] as a receiver whose sampling clock runs `delay_m` of bistatic
    /// path late sees them: every echo's envelope lies `delay_m` farther along the profile, its
    /// carrier phase is unchanged (a timing offset moves the baseband, not the carrier). The
    /// same bits as [`Self::synth_profiles`] at `delay_m = 0`.
    ///
    /// # Errors
    /// As [`Self::synth_profiles`], and `InvalidParameter` for a `delay_m` that is not finite.
    pub fn synth_profiles_delayed(
        &self,
        set: &ScattererSet,
        visible: &[u32],
        tx: Vec3,
        rx_elements: &[Vec3],
        delay_m: f64,
        out: &mut [Complex32],
    ) -> Result<(), EchoError> {
        if !delay_m.is_finite() {
            return Err(EchoError::invalid("delay_m", delay_m));
        }
        let prep = self.prepare_profiles(set, visible, tx, rx_elements, out)?;
        self.profiles_from(&prep, rx_elements, self.cfg.r0_m - delay_m, out);
        Ok(())
    }

    /// [`Self::synth_profiles`] one path at a time (no blocks, no vectorised pass): the plain
    /// reference the fast path is tested against (same bits) and benchmarked against
    /// (`has-sim bench echo`).
    ///
    /// # Errors
    /// As [`Self::synth_profiles`].
    pub fn synth_profiles_reference(
        &self,
        set: &ScattererSet,
        visible: &[u32],
        tx: Vec3,
        rx_elements: &[Vec3],
        out: &mut [Complex32],
    ) -> Result<(), EchoError> {
        let prep = self.prepare_profiles(set, visible, tx, rx_elements, out)?;
        self.profiles_plain(&prep, rx_elements, out);
        Ok(())
    }

    /// The checks of [`Self::synth_profiles`] and its scatterers prepared for `tx`.
    fn prepare_profiles(
        &self,
        set: &ScattererSet,
        visible: &[u32],
        tx: Vec3,
        rx_elements: &[Vec3],
        out: &[Complex32],
    ) -> Result<Prepared, EchoError> {
        check_elements(rx_elements)?;
        check_out(out.len(), rx_elements.len(), self.cfg.n_bins)?;
        self.prepare_surface(set, visible, tx)
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
        self.profiles_from(&prep, rx_elements, self.cfg.r0_m, out);
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
        prep: &Prepared,
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
