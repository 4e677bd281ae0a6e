//! Streaming back-projection (paper eq. 1) onto a voxel grid, in `f32` and in fixed point.
//!
//! `I(P) = Σ_{aV} Σ_{aR} s(r_V(P) + r_R(P)) · e^{+j2π (r_V + r_R)/λ}`: every range profile `s`
//! (transmitter at `aV`, receiver element at `aR`) is pushed once, updates every voxel and is
//! discarded.
//!
//! # Conventions
//! * **Frame.** Metres, right-handed, z up. Every position handed to this module (transmitter,
//!   receiver elements) is **grid-local**: world position minus [`VoxelGrid::origin`]. The voxel
//!   `(ix, iy, iz)` sits at `spacing ⊙ (ix, iy, iz)` in that frame; its linear index is
//!   `ix + nx·(iy + ny·iz)` (x fastest). Working relative to the grid keeps `f32` voxel
//!   coordinates small; a host holding `f64` world coordinates should subtract the origin in `f64`
//!   and then round ([`VoxelGrid::local_from_f64`]).
//! * **Range profiles** are indexed by *bistatic path length* `r = r_V + r_R` (metres, `c·τ`):
//!   bin `i` is at `r0 + i·dr` ([`BpConfig::r0_m`], [`BpConfig::dr_m`]); range compression of
//!   this project reports `dr = c / (B · zero_pad)`. The profile is `s` interpolated at `r`
//!   ([`Interp::Nearest`] or [`Interp::Linear`]), extended by zeros outside its bins (linear
//!   interpolation tapers to zero over the one bin beyond each end).
//! * **Phase.** Range compression leaves a scatterer at bistatic range `r_p` with phase
//!   `e^{−j2π r_p/λ}` (times a real symmetric pulse); back-projection multiplies by
//!   `e^{+j2π r/λ}`, so the scatterer focuses (adds in phase) at its voxel.
//!
//! # Paths
//! * `f32` ([`Backprojector::push`], [`Backprojector::push_snapshot`]) with accumulator state
//!   [`AccF32`]. The phase is [`PhaseEval::Poly`] (vectorisable polynomial, stated error
//!   ≤ 2·10⁻⁶, see [`crate::phase`]) or [`PhaseEval::Libm`] (`libm::sincosf`, the exact path).
//! * Fixed point ([`Backprojector::push_q15`], [`Backprojector::push_snapshot_q15`]) with state
//!   [`AccQ15`]: Q15 profiles with a block exponent (value = q · 2^exp), Q15 interpolation with
//!   explicit rounding, rotor interpolated in integers from a compile-time Q15 table (no
//!   `sin`/`cos` at run time), exact Q30 products accumulated in `i64`. Geometry (distances) is
//!   `f32`, as an FPU-equipped baseband processor computes it.
//! * Factorised ([`factorised`]): a regular planar receive lattice cut into subarrays whose beams
//!   are sampled once per snapshot and back-projected from the subarray centres — per voxel one
//!   range, rotor and trilinear table read per subarray instead of per element; its error against
//!   this module's exact `f32` path is derived in [`factorised`] and measured by `has-sim bench
//!   dsp` (8 × 8 subarrays, 8 beam samples per beamwidth: ≈ 34 dB SER at ≈ 8 × the exact rate).
//! * References: [`Backprojector::push_naive`] (scalar loop: per voxel and profile a bistatic
//!   range, `sincos`, interpolation, no reuse: the benchmark baseline) and
//!   [`Backprojector::push_reference_f64`] (all `f64`, for signal-to-error ratios, [`ser_db`]).
//!
//! # Batching and tiles
//! A *snapshot* ([`Snapshot`]) is all the profiles received by an array from one transmitter
//! position: `r_V` is computed once per voxel and reused across every element. Voxels are processed
//! in chunks of [`CHUNK`]: the chunk's coordinates, `r_V` and accumulators (struct of arrays) stay
//! in L1 while the elements stream through; per element, pass A (bistatic range, bin, weight,
//! rotor) vectorises, pass B1 gathers the two samples, pass B2 (interpolate, rotate, accumulate)
//! vectorises. Stack use is about 16 KiB (`f32`, with its 1 KiB index array) / 8 KiB (Q15) at
//! `CHUNK = 256`.
//!
//! Accumulator states cover a *tile*: a contiguous range of linear voxel indices. A host splits
//! the grid into disjoint tiles once, keeps one state per tile alive for the whole run, and pushes
//! every snapshot into every tile (e.g. `states.par_iter_mut()` with rayon); each tile runs the
//! same code and gives bit-for-bit the image the whole grid would. Constructing a state zeroes its
//! buffer.
//!
//! ```
//! use glam::Vec3;
//! use has_dsp::bp::{AccF32, Backprojector, BpConfig, Interp, PhaseEval, Snapshot, VoxelGrid};
//! use num_complex::Complex;
//!
//! let bp = Backprojector::new(BpConfig {
//!     grid: VoxelGrid { origin: Vec3::new(100.0, 50.0, 0.0), spacing: Vec3::splat(0.25), dims: [16, 16, 8] },
//!     wavelength_m: 0.03,
//!     r0_m: 0.0,
//!     dr_m: 0.375,
//!     interp: Interp::Linear,
//!     phase: PhaseEval::Poly,
//! })?;
//! let mut image = [Complex::new(0.0f32, 0.0); 16 * 16 * 8];
//! // Two tiles (a host would use one per thread).
//! let (t0, t1) = image.split_at_mut(1000);
//! let mut tiles = [AccF32::tile(&bp, 0, t0)?, AccF32::tile(&bp, 1000, t1)?];
//! let rx = [Vec3::new(-20.0, 0.0, 10.0), Vec3::new(-20.0, 0.015, 10.0)]; // grid-local
//! let profiles = [Complex::new(0.0f32, 0.0); 2 * 128];
//! let snap = Snapshot { tx: Vec3::new(5.0, -30.0, 1.5), rx: &rx, profiles: &profiles, profile_len: 128 };
//! for tile in &mut tiles {
//!     bp.push_snapshot(tile, &snap)?;
//! }
//! # Ok::<(), has_dsp::DspError>(())
//! ```
//!
//! # Accuracy (measured, see the tests)
//! The `f32` path's error is dominated by `f32` ranges: at r ≲ 15 m the image SER against the
//! `f64` reference is ≈ 70–80 dB; at 100–200 m (ulp of r ≈ 8–15 µm against λ = 3 cm) ≈ 66 dB. The
//! Q15 path adds profile quantization and the interpolated table rotor (≤ 1.01 LSB,
//! [`crate::phase`]): 92–97 dB SQNR against the `f32` path on the property-test scenes (77–82 dB
//! with the former nearest-step rotor, ≤ 14 LSB).

pub mod factorised;
mod kernel;
mod reference;

use kernel::Geo;

pub use reference::{add_point_echo, ser_db};

use crate::error::{check_finite, check_finite_vec3, check_len, check_positive, DspError};
use crate::fixed::CQ15;
use glam::Vec3;
use num_complex::Complex;

/// Voxels processed together: their geometry and scratch are kept on the stack (see module docs).
pub const CHUNK: usize = 256;

/// The largest number of pushes (profiles) an [`AccQ15`] accepts. Each push adds less than 2³¹
/// to each `i64` component (see [`Backprojector::push_q15`]), so `MAX_PUSHES_Q15 · 2³¹ < 2⁶³`.
pub const MAX_PUSHES_Q15: u32 = u32::MAX;

/// Block exponents accepted for Q15 profiles: `|exp| ≤ MAX_ABS_EXPONENT`.
pub const MAX_ABS_EXPONENT: i32 = 96;

/// A regular voxel grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxelGrid {
    /// World position of voxel (0, 0, 0), metres.
    pub origin: Vec3,
    /// Voxel spacing along x, y, z, metres (each > 0).
    pub spacing: Vec3,
    /// Voxels along x, y, z (each ≥ 1).
    pub dims: [usize; 3],
}

// glam's `Vec3` has no `defmt::Format`: print its components as arrays.
#[cfg(feature = "defmt")]
impl defmt::Format for VoxelGrid {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "VoxelGrid {{ origin: {}, spacing: {}, dims: {} }}",
            self.origin.to_array(),
            self.spacing.to_array(),
            self.dims
        )
    }
}

impl VoxelGrid {
    /// Number of voxels, or `None` if `nx·ny·nz` overflows `usize`.
    pub fn voxels(&self) -> Option<usize> {
        self.dims[0]
            .checked_mul(self.dims[1])?
            .checked_mul(self.dims[2])
    }

    /// Grid-local position of a world position (`world − origin`, in `f32`).
    #[inline]
    pub fn local(&self, world: Vec3) -> Vec3 {
        world - self.origin
    }

    /// Grid-local position of a world position given in `f64`: the subtraction is done in `f64`
    /// and only the (small) difference is rounded to `f32`.
    #[inline]
    pub fn local_from_f64(&self, world: [f64; 3]) -> Vec3 {
        Vec3::new(
            (world[0] - self.origin.x as f64) as f32,
            (world[1] - self.origin.y as f64) as f32,
            (world[2] - self.origin.z as f64) as f32,
        )
    }

    /// `(ix, iy, iz)` of linear voxel index `idx`, or `None` outside the grid.
    #[inline]
    pub fn coords(&self, idx: usize) -> Option<[usize; 3]> {
        let [nx, ny, _] = self.dims;
        if idx >= self.voxels()? {
            return None;
        }
        Some([idx % nx, (idx / nx) % ny, idx / (nx * ny)])
    }

    /// Grid-local position of linear voxel index `idx`, or `None` outside the grid.
    #[inline]
    pub fn voxel_local(&self, idx: usize) -> Option<Vec3> {
        let [ix, iy, iz] = self.coords(idx)?;
        Some(self.spacing * Vec3::new(ix as f32, iy as f32, iz as f32))
    }

    /// World position of linear voxel index `idx`, or `None` outside the grid.
    #[inline]
    pub fn voxel_world(&self, idx: usize) -> Option<Vec3> {
        Some(self.origin + self.voxel_local(idx)?)
    }
}

/// How a profile is read at a fractional bin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Interp {
    /// The nearest bin (ties round up).
    Nearest,
    /// Linear between the two neighbouring bins.
    Linear,
}

/// How the `f32` path evaluates `e^{+j2πr/λ}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PhaseEval {
    /// Polynomial rotor [`crate::phase::rotor_f32`], error ≤ 2·10⁻⁶ per component, vectorises.
    Poly,
    /// `libm::sincosf` of the reduced phase: the exact path the fast one is judged against.
    Libm,
}

/// Back-projection configuration (validated by [`Backprojector::new`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BpConfig {
    /// The voxel grid.
    pub grid: VoxelGrid,
    /// Carrier wavelength λ, metres (> 0).
    pub wavelength_m: f32,
    /// Bistatic path length of profile bin 0, metres (finite, any sign).
    pub r0_m: f32,
    /// Bin spacing of the profiles in bistatic path length, metres (> 0).
    pub dr_m: f32,
    /// Interpolation of the profile at the voxel's bistatic range.
    pub interp: Interp,
    /// Phase evaluation of the `f32` path.
    pub phase: PhaseEval,
}

/// A validated back-projection configuration: the `&self` of every push.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Backprojector {
    cfg: BpConfig,
    voxels: usize,
    inv_dr: f32,
}

/// One snapshot: the profiles received by `rx.len()` elements from one transmitter position.
///
/// `profiles` is flat, element-major: the profile of element `e` is
/// `profiles[e·profile_len .. (e+1)·profile_len]`, so `profiles.len()` must be
/// `rx.len() · profile_len`.
#[derive(Debug, Clone, Copy)]
pub struct Snapshot<'a, T> {
    /// Transmitter position aV, grid-local metres.
    pub tx: Vec3,
    /// Receiver element positions aR, grid-local metres.
    pub rx: &'a [Vec3],
    /// The profiles, element-major, `rx.len() · profile_len` samples.
    pub profiles: &'a [T],
    /// Bins per profile (≥ 1).
    pub profile_len: usize,
}

impl<T> Snapshot<'_, T> {
    fn validate(&self) -> Result<(), DspError> {
        check_local("snapshot.tx", self.tx)?;
        if self.profile_len == 0 || self.profile_len > MAX_PROFILE_LEN {
            return Err(DspError::UnsupportedLength {
                what: "snapshot.profile_len",
                len: self.profile_len,
            });
        }
        let want =
            self.rx
                .len()
                .checked_mul(self.profile_len)
                .ok_or(DspError::UnsupportedLength {
                    what: "snapshot.profile_len",
                    len: self.profile_len,
                })?;
        check_len("snapshot.profiles", want, self.profiles.len())?;
        for p in self.rx {
            check_local("snapshot.rx", *p)?;
        }
        Ok(())
    }
}

/// Most bins a profile may have (2²², 4 Mi): the f32 kernel reads a bin index out of an f32's
/// mantissa, exact below 2²³.
pub const MAX_PROFILE_LEN: usize = 1 << 22;

/// Largest grid-local coordinate (and grid extent) accepted, metres. Beyond it an `f32`
/// coordinate's ulp (≥ 7.8 mm) makes the phase meaningless at centimetre wavelengths; the bound
/// also keeps every squared distance finite, so no NaN can reach an accumulator.
pub const MAX_LOCAL_M: f32 = 1.0e5;

/// Bound, with margin, on every bistatic range `r_V + r_R` the kernels can meet, metres: voxels
/// lie in \[0, [`MAX_LOCAL_M`]\]³ and positions in \[−[`MAX_LOCAL_M`], [`MAX_LOCAL_M`]\]³, so each
/// distance is at most `2√3·MAX_LOCAL_M` and their sum `4√3·MAX_LOCAL_M` ≈ 6.93·10⁵ m.
pub const MAX_BISTATIC_RANGE_M: f32 = 8.0 * MAX_LOCAL_M;

/// Largest magnitude [`Backprojector::new`] lets the fractional bin `(r − r0)/dr` and the phase
/// `r/λ` reach for any `r` up to [`MAX_BISTATIC_RANGE_M`]: `f32::MAX / 16`, so that the kernels'
/// `x + 0.5`, `4·t + 0.5` and their roundings stay finite (beyond it a bin weight or a rotor
/// would be `∞ − ∞ = NaN`, and the whole image NaN).
const MAX_MAPPED: f64 = f32::MAX as f64 / 16.0;

/// A grid-local position: finite and every component within ±[`MAX_LOCAL_M`].
fn check_local(what: &'static str, p: Vec3) -> Result<(), DspError> {
    check_finite_vec3(what, p)?;
    let m = p.abs().max_element();
    if m <= MAX_LOCAL_M {
        Ok(())
    } else {
        Err(DspError::OutOfRange { what, value: m })
    }
}

/// `f32` accumulator state of a tile: voxels `first_voxel .. first_voxel + len`.
#[derive(Debug)]
pub struct AccF32<'a> {
    first: usize,
    data: &'a mut [Complex<f32>],
    pushes: u64,
}

/// Fixed-point accumulator state of a tile.
///
/// Each `i64` component holds a value in units of `2^(exp − 30)` (Q30 products at the state's
/// block exponent `exp`, the largest profile exponent pushed so far; when a larger one arrives
/// the accumulators are shifted right, with rounding, to it). At most [`MAX_PUSHES_Q15`] pushes.
#[derive(Debug)]
pub struct AccQ15<'a> {
    first: usize,
    data: &'a mut [Complex<i64>],
    exp: i32,
    pushes: u64,
}

fn tile_bounds(voxels: usize, first: usize, len: usize) -> Result<(), DspError> {
    match first.checked_add(len) {
        Some(end) if end <= voxels => Ok(()),
        _ => Err(DspError::GridTooLarge {
            voxels: first.saturating_add(len),
            capacity: voxels,
        }),
    }
}

impl<'a> AccF32<'a> {
    /// State for the whole grid in `buf[..voxels]` (zeroed here).
    ///
    /// # Errors
    /// [`DspError::GridTooLarge`] if `buf` holds fewer voxels than the grid.
    pub fn new(bp: &Backprojector, buf: &'a mut [Complex<f32>]) -> Result<Self, DspError> {
        if buf.len() < bp.voxels {
            return Err(DspError::GridTooLarge {
                voxels: bp.voxels,
                capacity: buf.len(),
            });
        }
        Self::tile(bp, 0, &mut buf[..bp.voxels])
    }

    /// State for the tile of voxels `first_voxel .. first_voxel + buf.len()` (zeroed here).
    ///
    /// # Errors
    /// [`DspError::GridTooLarge`] if the tile reaches beyond the grid (`voxels` is the tile's end,
    /// `capacity` the grid's voxel count); [`DspError::UnsupportedLength`] for an empty tile.
    pub fn tile(
        bp: &Backprojector,
        first_voxel: usize,
        buf: &'a mut [Complex<f32>],
    ) -> Result<Self, DspError> {
        if buf.is_empty() {
            return Err(DspError::UnsupportedLength {
                what: "tile buffer",
                len: 0,
            });
        }
        tile_bounds(bp.voxels, first_voxel, buf.len())?;
        buf.fill(Complex::new(0.0, 0.0));
        Ok(Self {
            first: first_voxel,
            data: buf,
            pushes: 0,
        })
    }

    /// The accumulated image of the tile (linear voxel order from [`Self::first_voxel`]).
    pub fn image(&self) -> &[Complex<f32>] {
        self.data
    }

    /// Linear index of the tile's first voxel.
    pub fn first_voxel(&self) -> usize {
        self.first
    }

    /// Profiles pushed so far.
    pub fn pushes(&self) -> u64 {
        self.pushes
    }
}

impl<'a> AccQ15<'a> {
    /// State for the whole grid in `buf[..voxels]` (zeroed here).
    ///
    /// # Errors
    /// [`DspError::GridTooLarge`] if `buf` holds fewer voxels than the grid.
    pub fn new(bp: &Backprojector, buf: &'a mut [Complex<i64>]) -> Result<Self, DspError> {
        if buf.len() < bp.voxels {
            return Err(DspError::GridTooLarge {
                voxels: bp.voxels,
                capacity: buf.len(),
            });
        }
        Self::tile(bp, 0, &mut buf[..bp.voxels])
    }

    /// State for the tile of voxels `first_voxel .. first_voxel + buf.len()` (zeroed here).
    ///
    /// # Errors
    /// As [`AccF32::tile`].
    pub fn tile(
        bp: &Backprojector,
        first_voxel: usize,
        buf: &'a mut [Complex<i64>],
    ) -> Result<Self, DspError> {
        if buf.is_empty() {
            return Err(DspError::UnsupportedLength {
                what: "tile buffer",
                len: 0,
            });
        }
        tile_bounds(bp.voxels, first_voxel, buf.len())?;
        buf.fill(Complex::new(0, 0));
        Ok(Self {
            first: first_voxel,
            data: buf,
            exp: 0,
            pushes: 0,
        })
    }

    /// The raw accumulators (units `2^(exponent − 30)`).
    pub fn raw(&self) -> &[Complex<i64>] {
        self.data
    }

    /// The block exponent of the accumulators: value = raw · 2^(exponent − 30).
    pub fn exponent(&self) -> i32 {
        self.exp
    }

    /// Linear index of the tile's first voxel.
    pub fn first_voxel(&self) -> usize {
        self.first
    }

    /// Profiles pushed so far.
    pub fn pushes(&self) -> u64 {
        self.pushes
    }

    /// Writes the tile's image as `f32` (value = raw · 2^(exponent − 30)) into `out`.
    ///
    /// # Errors
    /// [`DspError::LengthMismatch`] unless `out.len()` is the tile's voxel count.
    pub fn to_image_f32(&self, out: &mut [Complex<f32>]) -> Result<(), DspError> {
        check_len("image", self.data.len(), out.len())?;
        let scale = libm::ldexp(1.0, self.exp - 30);
        for (o, a) in out.iter_mut().zip(self.data.iter()) {
            *o = Complex::new((a.re as f64 * scale) as f32, (a.im as f64 * scale) as f32);
        }
        Ok(())
    }

    /// Brings the state to block exponent `e` (≥ current, or any on the first push) so that no
    /// contribution needs a left shift. Rounds half up.
    fn raise_exponent(&mut self, e: i32) {
        if self.pushes == 0 {
            self.exp = e;
            return;
        }
        if e <= self.exp {
            return;
        }
        let k = (e - self.exp).min(63) as u32;
        for a in self.data.iter_mut() {
            a.re = crate::fixed::round_shift_i64(a.re, k);
            a.im = crate::fixed::round_shift_i64(a.im, k);
        }
        self.exp = e;
    }
}

impl Backprojector {
    /// Validates `cfg`.
    ///
    /// # Errors
    /// [`DspError::OutOfRange`] / [`DspError::NonFinite`] naming the field for a non-positive or
    /// non-finite `wavelength_m`, `dr_m`, grid spacing component, non-finite `r0_m` or origin;
    /// [`DspError::UnsupportedLength`] for a zero grid dimension or a voxel count that overflows;
    /// [`DspError::OutOfRange`] for a grid extent beyond [`MAX_LOCAL_M`];
    /// [`DspError::OutOfRange`] when a bistatic range the grid can produce (up to
    /// [`MAX_BISTATIC_RANGE_M`]) would map to a fractional bin `(r − r0)/dr` or a phase `r/λ`
    /// beyond `f32::MAX / 16` — naming `config.dr_m` if `dr_m` is too small for any `r0_m`,
    /// otherwise `config.r0_m` (too far from the grid for that `dr_m`), and `config.wavelength_m`
    /// for a wavelength too small. (Such a configuration used to be accepted and give a NaN image.)
    pub fn new(cfg: BpConfig) -> Result<Self, DspError> {
        check_positive("config.wavelength_m", cfg.wavelength_m)?;
        check_positive("config.dr_m", cfg.dr_m)?;
        check_finite("config.r0_m", cfg.r0_m)?;
        check_finite_vec3("config.grid.origin", cfg.grid.origin)?;
        check_positive("config.grid.spacing.x", cfg.grid.spacing.x)?;
        check_positive("config.grid.spacing.y", cfg.grid.spacing.y)?;
        check_positive("config.grid.spacing.z", cfg.grid.spacing.z)?;
        for (d, name) in cfg.grid.dims.iter().zip([
            "config.grid.dims[0]",
            "config.grid.dims[1]",
            "config.grid.dims[2]",
        ]) {
            if *d == 0 {
                return Err(DspError::UnsupportedLength { what: name, len: 0 });
            }
        }
        let voxels = cfg.grid.voxels().ok_or(DspError::UnsupportedLength {
            what: "config.grid.dims",
            len: usize::MAX,
        })?;
        let [nx, ny, nz] = cfg.grid.dims;
        let extent =
            cfg.grid.spacing * Vec3::new((nx - 1) as f32, (ny - 1) as f32, (nz - 1) as f32);
        check_local("config.grid extent (spacing · (dims − 1))", extent)?;

        // Reciprocal formed in f64 and rounded once: relative error ≤ 2⁻²⁴ (bin positions only).
        let inv_lambda = (1.0 / cfg.wavelength_m as f64) as f32;
        let inv_dr = (1.0 / cfg.dr_m as f64) as f32;
        check_finite("1 / config.wavelength_m", inv_lambda)?;
        check_finite("1 / config.dr_m", inv_dr)?;
        // Every range the grid can produce must map to a finite bin and phase (in f64: exact
        // enough, with the margin of MAX_MAPPED covering the f32 roundings of r − r0 and ·inv_dr).
        let r_max = MAX_BISTATIC_RANGE_M as f64;
        if r_max * inv_dr as f64 > MAX_MAPPED {
            return Err(DspError::OutOfRange {
                what: "config.dr_m",
                value: cfg.dr_m,
            });
        }
        if (r_max + (cfg.r0_m as f64).abs()) * inv_dr as f64 > MAX_MAPPED {
            return Err(DspError::OutOfRange {
                what: "config.r0_m",
                value: cfg.r0_m,
            });
        }
        if r_max / cfg.wavelength_m as f64 > MAX_MAPPED {
            return Err(DspError::OutOfRange {
                what: "config.wavelength_m",
                value: cfg.wavelength_m,
            });
        }
        Ok(Self {
            cfg,
            voxels,
            inv_dr,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &BpConfig {
        &self.cfg
    }

    /// The voxel grid.
    pub fn grid(&self) -> &VoxelGrid {
        &self.cfg.grid
    }

    /// Number of voxels in the grid.
    pub fn voxels(&self) -> usize {
        self.voxels
    }

    /// Phase in cycles `r/λ` of a bistatic range `r` (metres), correctly rounded. A division, not
    /// `r·(1/λ)`: the reciprocal's rounding (≤ 2⁻²⁴ relative) would be a phase error proportional
    /// to `r`, coherent across pushes (2.5 mrad at r = 200 m: −6 dB of SER at building scale),
    /// and a split reciprocal still costs a second rounding of `t`.
    #[inline(always)]
    fn cycles(&self, r: f32) -> f32 {
        r / self.cfg.wavelength_m
    }

    fn check_acc_f32(&self, acc: &AccF32<'_>) -> Result<(), DspError> {
        tile_bounds(self.voxels, acc.first, acc.data.len())
    }

    /// Pushes one profile (transmitter `tx`, receiver `rx`, grid-local metres) into every voxel
    /// of the tile: `acc += s(r_V + r_R) · e^{+j2π(r_V + r_R)/λ}`.
    ///
    /// # Errors
    /// [`DspError::UnsupportedLength`] for an empty profile, [`DspError::NonFinite`] for a
    /// non-finite position, [`DspError::OutOfRange`] for a coordinate beyond ±[`MAX_LOCAL_M`],
    /// [`DspError::GridTooLarge`] if `acc` was made for a larger grid.
    pub fn push(
        &self,
        acc: &mut AccF32<'_>,
        profile: &[Complex<f32>],
        tx: Vec3,
        rx: Vec3,
    ) -> Result<(), DspError> {
        self.push_snapshot(
            acc,
            &Snapshot {
                tx,
                rx: core::slice::from_ref(&rx),
                profiles: profile,
                profile_len: profile.len(),
            },
        )
    }

    /// Pushes a whole snapshot: `r_V` is computed once per voxel and reused for every element.
    /// Equivalent to [`Self::push`] per element (the same arithmetic, bit for bit).
    ///
    /// # Errors
    /// As [`Self::push`], plus [`DspError::LengthMismatch`] if `profiles.len()` is not
    /// `rx.len() · profile_len`.
    pub fn push_snapshot(
        &self,
        acc: &mut AccF32<'_>,
        snap: &Snapshot<'_, Complex<f32>>,
    ) -> Result<(), DspError> {
        snap.validate()?;
        self.check_acc_f32(acc)?;
        kernel::run_f32(self, acc.first, acc.data, &mut [], snap);
        acc.pushes += snap.rx.len() as u64;
        Ok(())
    }

    /// [`Self::push_snapshot`] that also adds, per voxel of the tile, the power of the
    /// snapshot's own image `|Σ_rx s(r_V + r_R) · e^{+j2π(r_V + r_R)/λ}|²` to `power` (one `f32`
    /// per voxel of `acc`, same order). Summed over snapshots this is the image focused across
    /// the receive elements but not across the snapshots: against `|I|²` and the incoherent
    /// power it separates the coherence of the two apertures (e.g. a sidelobe of the receive
    /// array that the transmit aperture focuses). `acc` gets exactly what
    /// [`Self::push_snapshot`] gives it.
    ///
    /// # Errors
    /// As [`Self::push_snapshot`], plus [`DspError::LengthMismatch`] if `power` and the tile
    /// differ in length.
    pub fn push_snapshot_with_power(
        &self,
        acc: &mut AccF32<'_>,
        power: &mut [f32],
        snap: &Snapshot<'_, Complex<f32>>,
    ) -> Result<(), DspError> {
        snap.validate()?;
        self.check_acc_f32(acc)?;
        if power.len() != acc.data.len() {
            return Err(DspError::LengthMismatch {
                what: "snapshot power buffer",
                expected: acc.data.len(),
                got: power.len(),
            });
        }
        kernel::run_f32(self, acc.first, acc.data, power, snap);
        acc.pushes += snap.rx.len() as u64;
        Ok(())
    }

    /// Fixed-point [`Self::push`]: one Q15 profile whose value is `profile · 2^exponent`.
    ///
    /// Per voxel: the profile is read with Q15 interpolation (rounded half up), multiplied exactly
    /// by the Q15 rotor (a Q30 product, each component `< 2³¹` in magnitude since every rotor
    /// component is ≤ 32767) and added to the `i64` accumulator after an arithmetic right shift
    /// by `state exponent − exponent` (rounded half up; no shift when the exponents agree).
    ///
    /// # Errors
    /// As [`Self::push`]; [`DspError::OutOfRange`] if `|exponent|` > [`MAX_ABS_EXPONENT`];
    /// [`DspError::AccumulatorOverflow`] if the state would exceed [`MAX_PUSHES_Q15`] pushes.
    pub fn push_q15(
        &self,
        acc: &mut AccQ15<'_>,
        profile: &[CQ15],
        exponent: i32,
        tx: Vec3,
        rx: Vec3,
    ) -> Result<(), DspError> {
        self.push_snapshot_q15(
            acc,
            &Snapshot {
                tx,
                rx: core::slice::from_ref(&rx),
                profiles: profile,
                profile_len: profile.len(),
            },
            core::slice::from_ref(&exponent),
        )
    }

    /// Fixed-point [`Self::push_snapshot`]: `exponents[e]` is the block exponent of element
    /// `e`'s profile (value = q · 2^exponent).
    ///
    /// # Errors
    /// As [`Self::push_q15`], plus [`DspError::LengthMismatch`] unless
    /// `exponents.len() == rx.len()`.
    pub fn push_snapshot_q15(
        &self,
        acc: &mut AccQ15<'_>,
        snap: &Snapshot<'_, CQ15>,
        exponents: &[i32],
    ) -> Result<(), DspError> {
        snap.validate()?;
        check_len("exponents", snap.rx.len(), exponents.len())?;
        tile_bounds(self.voxels, acc.first, acc.data.len())?;
        let mut max_e = i32::MIN;
        for &e in exponents {
            if e.unsigned_abs() > MAX_ABS_EXPONENT as u32 {
                return Err(DspError::OutOfRange {
                    what: "exponents",
                    value: e as f32,
                });
            }
            max_e = max_e.max(e);
        }
        if acc.pushes + snap.rx.len() as u64 > MAX_PUSHES_Q15 as u64 {
            return Err(DspError::AccumulatorOverflow {
                what: "AccQ15",
                max_pushes: MAX_PUSHES_Q15,
            });
        }
        if snap.rx.is_empty() {
            return Ok(());
        }
        acc.raise_exponent(max_e);
        kernel::run_q15(self, acc.first, acc.data, acc.exp, snap, exponents);
        acc.pushes += snap.rx.len() as u64;
        Ok(())
    }

    /// The benchmark baseline: a plain scalar loop, per voxel [`crate::geometry::bistatic_range`],
    /// interpolation and `libm::sincosf` of the reduced phase, no reuse, no chunking. Same
    /// arguments and errors as [`Self::push`].
    ///
    /// # Errors
    /// As [`Self::push`].
    pub fn push_naive(
        &self,
        acc: &mut AccF32<'_>,
        profile: &[Complex<f32>],
        tx: Vec3,
        rx: Vec3,
    ) -> Result<(), DspError> {
        Snapshot {
            tx,
            rx: core::slice::from_ref(&rx),
            profiles: profile,
            profile_len: profile.len(),
        }
        .validate()?;
        self.check_acc_f32(acc)?;
        reference::naive(self, acc.first, acc.data, profile, tx, rx);
        acc.pushes += 1;
        Ok(())
    }

    /// The `f64` reference: positions (grid-local, metres) and all arithmetic in `f64`, `libm`
    /// `sin`/`cos`; the same profile samples. `acc` covers the whole grid, `acc[..voxels]`.
    ///
    /// # Errors
    /// [`DspError::GridTooLarge`] if `acc` holds fewer voxels than the grid;
    /// [`DspError::UnsupportedLength`] for an empty profile; [`DspError::NonFinite`] for a
    /// non-finite position; [`DspError::OutOfRange`] for a coordinate beyond ±[`MAX_LOCAL_M`]
    /// (as every other push: a larger one could overflow a squared distance).
    pub fn push_reference_f64(
        &self,
        acc: &mut [Complex<f64>],
        profile: &[Complex<f32>],
        tx: [f64; 3],
        rx: [f64; 3],
    ) -> Result<(), DspError> {
        if acc.len() < self.voxels {
            return Err(DspError::GridTooLarge {
                voxels: self.voxels,
                capacity: acc.len(),
            });
        }
        if profile.is_empty() {
            return Err(DspError::UnsupportedLength {
                what: "profile",
                len: 0,
            });
        }
        for (what, p) in [("tx", tx), ("rx", rx)] {
            if !p.iter().all(|x| x.is_finite()) {
                return Err(DspError::NonFinite { what });
            }
            let m = p.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            if m > MAX_LOCAL_M as f64 {
                return Err(DspError::OutOfRange {
                    what,
                    value: m as f32,
                });
            }
        }
        reference::reference_f64(self, &mut acc[..self.voxels], profile, tx, rx);
        Ok(())
    }
}

#[cfg(test)]
mod tests;
