//! Factorised back-projection over a regular planar receive panel: subarray beams formed once per
//! snapshot, then back-projected from the subarray centres (the idea of fast-factorised BP).
//!
//! # What it computes
//! Exact back-projection ([`Backprojector::push_snapshot`]) adds, per voxel `P` and element `e`,
//! `s_e(r_V + r_e) · e^{+j2π(r_V + r_e)/λ}` with `r_e = |P − e|`. Cut the panel into subarrays of
//! `S_r × S_c` elements; for the subarray with centre `c`, write `e = c + δ`, `R = |P − c|`,
//! `n̂ = (P − c)/R`. The factorised image replaces, for every element of the subarray,
//!
//! * the phase range `r_e` by its far-field part `R − n̂·δ` (the **Fresnel term** dropped), and
//! * the sample `s_e(r_V + r_e)` by `s_e(r_V + R)` (the **range walk** across the subarray dropped),
//!
//! so that the subarray's sum becomes `e^{+j2π(r_V + R)/λ} · B(r_V + R, α, β)` with the *beam*
//! `B(r, α, β) = Σ_{m,n} s_{mn}(r) · e^{−j2π(m′α + n′β)}`, `m′ = m − (S_c − 1)/2` and
//! `n′ = n − (S_r − 1)/2` the element's column and row offsets from the centre, and
//! `α = n̂·col_step/λ`, `β = n̂·row_step/λ` the voxel's direction in cycles per element step.
//! The beam does not depend on the voxel: [`Factorised::build`] samples it once per snapshot on a
//! [`BeamWindow`] — every profile bin the voxels can reach, `α` and `β` in steps of `1/(O·S_c)`
//! and `1/(O·S_r)` ([`Factorisation::oversample`] `O`) — and [`Factorised::push`] reads it per
//! voxel and subarray, linearly in range and bilinearly in direction. Per voxel the work falls from
//! one range, rotor and gather per element to one per subarray: `S_r·S_c` elements at the cost of
//! about six.
//!
//! # Error (derived; measured in the tests and by `has-sim bench dsp`)
//! Per element term, against exact back-projection with the same profiles:
//! * **Fresnel.** `r_e² = (R − n̂·δ)² + |δ|² − (n̂·δ)²`, and `√(a² + b) ≤ a + b/(2a)`, so
//!   `0 ≤ r_e − (R − n̂·δ) ≤ |δ|²/(2(R − |δ|))`: a phase error of at most
//!   `π|δ|²/(λ(R − |δ|))` — with `|δ|` at most half the subarray's diagonal. For a 12.5 cm
//!   subarray at R = 20 m and λ = 3 cm: 0.041 rad (−28 dB); at 60 m, −37 dB.
//! * **Range walk.** The sample is read `|r_e − R| ≤ |δ| + (Fresnel)` away from its own range. A
//!   profile of bandwidth `B` (path-length spatial frequencies within `±B/(2c)`) changes by at most
//!   `π(B/c)·|δ|·max|s|` over that distance (Bernstein's inequality); with the Hann-windowed pulse
//!   the rms change is about a third of that. Only the component of `δ` along `n̂` walks: at
//!   broadside none.
//! * **Direction sampling.** Linear interpolation of `e^{−j2πm′α}` between samples `h = 1/(O·S_c)`
//!   apart errs by at most `h²(2πm′)²/8 ≤ (π/(2O))²/2`; bilinear in `(α, β)` at most the sum of
//!   the two, `π²/(4O²)` (0.154 at `O = 4`, 0.039 at `O = 8`). For `ω = 2πm′h` the error at a
//!   fraction `t` between samples is `≈ ω²t(1 − t)/2`, mean square `ω⁴/120` over `t`, and over
//!   `m′` spread evenly across the subarray `ω_max⁴/600`: an rms of `ω_max²/√600`, a third of the
//!   worst case (−32 dB per axis at `O = 4`, −44 dB at `O = 8`).
//!
//! # Conventions
//! Positions are grid-local (as every push of [`super`]), except that a [`Lattice`]'s steps and a
//! [`BeamWindow`] are frame free (directions and bins). The snapshot's profiles are
//! element-major in the lattice's row-major order: element `(row, col)` is profile
//! `row·cols + col`. Tables are caller-owned (`table_len`, `scratch_len`); nothing allocates.

use super::{check_local, AccF32, Backprojector, Geo, VoxelGrid, CHUNK};
use crate::error::{check_finite_vec3, check_len, check_positive, DspError};
use crate::float;
use crate::phase::{floor_f32, rotor_f32};
use glam::Vec3;
use num_complex::Complex;

/// A regular planar receive lattice: element `(row, col)` at
/// `first + col·col_step + row·row_step`, profile index `row·cols + col`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lattice {
    /// Element (0, 0), metres (grid-local when pushed).
    pub first: Vec3,
    /// From one column to the next, metres.
    pub col_step: Vec3,
    /// From one row to the next, metres.
    pub row_step: Vec3,
    /// Element rows (≥ 1).
    pub rows: usize,
    /// Element columns (≥ 1).
    pub cols: usize,
}

impl Lattice {
    /// Position of element `(row, col)`.
    #[inline]
    pub fn element(&self, row: usize, col: usize) -> Vec3 {
        self.first + self.col_step * col as f32 + self.row_step * row as f32
    }
}

/// How the lattice is cut into subarrays and how finely their beams are sampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Factorisation {
    /// Rows per subarray (divides the lattice's rows).
    pub sub_rows: usize,
    /// Columns per subarray (divides the lattice's columns).
    pub sub_cols: usize,
    /// Beam samples per beamwidth `O` (≥ 1): direction steps `1/(O·S)` cycles per element.
    pub oversample: usize,
}

/// The part of the beam space a table samples: profile bins `bin0 .. bin0 + bins`, directions
/// `α = alpha0 + p/(O·S_c)` for `p < n_alpha` and `β = beta0 + q/(O·S_r)` for `q < n_beta`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BeamWindow {
    /// First profile bin (may be negative or past the profile: such bins are zero).
    pub bin0: i32,
    /// Bins (≥ 2).
    pub bins: usize,
    /// First `α` sample, cycles per column step.
    pub alpha0: f32,
    /// `α` samples (≥ 2).
    pub n_alpha: usize,
    /// First `β` sample, cycles per row step.
    pub beta0: f32,
    /// `β` samples (≥ 2).
    pub n_beta: usize,
}

/// A validated factorisation of one lattice at one wavelength: the `&self` of table building and
/// pushing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Factorised {
    lattice: Lattice,
    fact: Factorisation,
    wavelength_m: f32,
    /// Direction steps per cycle: `O·S_c`, `O·S_r`.
    per_alpha: f32,
    per_beta: f32,
}

/// Bounds of `|x − p|` over the axis-aligned box `[lo, hi]`: (nearest, farthest).
fn box_distances(lo: Vec3, hi: Vec3, p: Vec3) -> (f32, f32) {
    let near = p.clamp(lo, hi).distance(p);
    let far = (p - lo).abs().max((p - hi).abs()).length();
    (near, far)
}

impl Factorised {
    /// Validates the lattice (finite, independent steps), the factorisation (subarrays tile the
    /// lattice, `oversample ≥ 1`) and the wavelength.
    ///
    /// # Errors
    /// [`DspError::UnsupportedLength`] naming `lattice.rows`/`cols` (zero),
    /// `factorisation.sub_rows`/`sub_cols` (zero or not dividing the lattice) or
    /// `factorisation.oversample` (zero); [`DspError::NonFinite`] / [`DspError::OutOfRange`] for a
    /// non-finite or degenerate step or a non-positive wavelength.
    pub fn new(lattice: Lattice, fact: Factorisation, wavelength_m: f32) -> Result<Self, DspError> {
        check_positive("wavelength_m", wavelength_m)?;
        check_finite_vec3("lattice.first", lattice.first)?;
        check_finite_vec3("lattice.col_step", lattice.col_step)?;
        check_finite_vec3("lattice.row_step", lattice.row_step)?;
        for (what, n) in [
            ("lattice.rows", lattice.rows),
            ("lattice.cols", lattice.cols),
        ] {
            if n == 0 {
                return Err(DspError::UnsupportedLength { what, len: 0 });
            }
        }
        for (what, s, n) in [
            ("factorisation.sub_rows", fact.sub_rows, lattice.rows),
            ("factorisation.sub_cols", fact.sub_cols, lattice.cols),
        ] {
            if s == 0 || n % s != 0 {
                return Err(DspError::UnsupportedLength { what, len: s });
            }
        }
        if fact.oversample == 0 || fact.oversample > 1 << 12 {
            return Err(DspError::UnsupportedLength {
                what: "factorisation.oversample",
                len: fact.oversample,
            });
        }
        let cross = lattice.col_step.cross(lattice.row_step).length();
        let scale = lattice.col_step.length() * lattice.row_step.length();
        if cross.is_nan() || cross <= 1e-3 * scale {
            return Err(DspError::OutOfRange {
                what: "lattice.row_step (parallel to col_step)",
                value: cross,
            });
        }
        Ok(Self {
            lattice,
            fact,
            wavelength_m,
            per_alpha: (fact.oversample * fact.sub_cols) as f32,
            per_beta: (fact.oversample * fact.sub_rows) as f32,
        })
    }

    /// The lattice.
    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// The factorisation.
    pub fn factorisation(&self) -> &Factorisation {
        &self.fact
    }

    /// Subarrays (rows × columns of subarrays).
    pub fn subarrays(&self) -> usize {
        (self.lattice.rows / self.fact.sub_rows) * (self.lattice.cols / self.fact.sub_cols)
    }

    /// Centre of subarray `k` (row-major over subarrays) of a lattice whose element (0, 0) is at
    /// `first`.
    #[inline]
    fn centre(&self, first: Vec3, k: usize) -> Vec3 {
        let (sr, sc) = (self.fact.sub_rows, self.fact.sub_cols);
        let per_row = self.lattice.cols / sc;
        let (kr, kc) = (k / per_row, k % per_row);
        first
            + self.lattice.col_step * ((kc * sc) as f32 + 0.5 * (sc - 1) as f32)
            + self.lattice.row_step * ((kr * sr) as f32 + 0.5 * (sr - 1) as f32)
    }

    /// The smallest window (with one sample of margin on every side) that holds every voxel of
    /// the axis-aligned box `[lo, hi]` for a transmitter at `tx` and the lattice's element (0, 0)
    /// at `first` (all in one frame), for profiles of back-projector `bp` (its `r0`, `dr`).
    ///
    /// Directions are bounded by the cone around each subarray's line to the box centre whose
    /// half-angle `asin(half diagonal / distance)` contains the box (the whole sphere when the box
    /// holds the centre); bins by the nearest and farthest box points from the transmitter and
    /// the subarray centres.
    ///
    /// # Errors
    /// [`DspError::NonFinite`] / [`DspError::OutOfRange`] for a position that is not finite or
    /// beyond ±[`super::MAX_LOCAL_M`], or `lo > hi`.
    pub fn window_for_box(
        &self,
        bp: &Backprojector,
        lo: Vec3,
        hi: Vec3,
        first: Vec3,
        tx: Vec3,
    ) -> Result<BeamWindow, DspError> {
        for (what, p) in [("box lo", lo), ("box hi", hi), ("first", first), ("tx", tx)] {
            check_local(what, p)?;
        }
        if !(lo.cmple(hi).all()) {
            return Err(DspError::OutOfRange {
                what: "box hi (below lo)",
                value: (lo - hi).max_element(),
            });
        }
        let (ua, ub) = (
            self.lattice.col_step / self.wavelength_m,
            self.lattice.row_step / self.wavelength_m,
        );
        let (mid, half) = ((lo + hi) * 0.5, ((hi - lo) * 0.5).length());
        let (tx_near, tx_far) = box_distances(lo, hi, tx);
        let (mut a_lo, mut a_hi, mut b_lo, mut b_hi) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        let (mut r_lo, mut r_hi) = (f32::MAX, f32::MIN);
        for k in 0..self.subarrays() {
            let c = self.centre(first, k);
            let (near, far) = box_distances(lo, hi, c);
            r_lo = r_lo.min(tx_near + near);
            r_hi = r_hi.max(tx_far + far);
            let to = mid - c;
            let d = to.length();
            for (u, lo_, hi_) in [(ua, &mut a_lo, &mut a_hi), (ub, &mut b_lo, &mut b_hi)] {
                let ul = u.length();
                let (x0, x1) = if d > half && d > 0.0 {
                    // Angle between u and the line to the centre, widened by the cone.
                    let cos = (to.dot(u) / (d * ul)).clamp(-1.0, 1.0);
                    let ang = libm::acosf(cos);
                    let cone = libm::asinf((half / d).min(1.0));
                    let (a0, a1) = (
                        (ang - cone).max(0.0),
                        (ang + cone).min(core::f32::consts::PI),
                    );
                    (ul * libm::cosf(a1), ul * libm::cosf(a0))
                } else {
                    (-ul, ul)
                };
                *lo_ = lo_.min(x0);
                *hi_ = hi_.max(x1);
            }
        }
        let cfg = bp.config();
        let inv_dr = 1.0 / cfg.dr_m;
        let bin_lo = libm::floorf((r_lo - cfg.r0_m) * inv_dr) as i64 - 1;
        let bin_hi = libm::floorf((r_hi - cfg.r0_m) * inv_dr) as i64 + 2;
        let samples = |lo: f32, hi: f32, per: f32| -> (f32, usize) {
            let p0 = libm::floorf(lo * per) - 1.0;
            let p1 = libm::ceilf(hi * per) + 1.0;
            (p0 / per, (p1 - p0) as usize + 1)
        };
        let (alpha0, n_alpha) = samples(a_lo, a_hi, self.per_alpha);
        let (beta0, n_beta) = samples(b_lo, b_hi, self.per_beta);
        let bins = (bin_hi - bin_lo + 1) as usize;
        if bin_lo < i32::MIN as i64 || bin_hi > i32::MAX as i64 {
            return Err(DspError::OutOfRange {
                what: "beam window bins",
                value: r_hi,
            });
        }
        Ok(BeamWindow {
            bin0: bin_lo as i32,
            bins,
            alpha0,
            n_alpha,
            beta0,
            n_beta,
        })
    }

    /// The union of two windows (the smallest window holding both).
    pub fn union(&self, a: &BeamWindow, b: &BeamWindow) -> BeamWindow {
        let span = |x0: f32, n: usize, per: f32| (x0, x0 + (n - 1) as f32 / per);
        let join = |(a0, a1): (f32, f32), (b0, b1): (f32, f32), per: f32| {
            let lo = a0.min(b0);
            let n = libm::roundf((a1.max(b1) - lo) * per) as usize + 1;
            (lo, n)
        };
        let (alpha0, n_alpha) = join(
            span(a.alpha0, a.n_alpha, self.per_alpha),
            span(b.alpha0, b.n_alpha, self.per_alpha),
            self.per_alpha,
        );
        let (beta0, n_beta) = join(
            span(a.beta0, a.n_beta, self.per_beta),
            span(b.beta0, b.n_beta, self.per_beta),
            self.per_beta,
        );
        let bin0 = a.bin0.min(b.bin0);
        let end = (a.bin0 as i64 + a.bins as i64).max(b.bin0 as i64 + b.bins as i64);
        BeamWindow {
            bin0,
            bins: (end - bin0 as i64) as usize,
            alpha0,
            n_alpha,
            beta0,
            n_beta,
        }
    }

    /// Length of the table of window `w`: subarrays × bins × `n_alpha` × `n_beta` complex samples
    /// (`None` on overflow).
    pub fn table_len(&self, w: &BeamWindow) -> Option<usize> {
        self.subarrays()
            .checked_mul(w.bins)?
            .checked_mul(w.n_alpha)?
            .checked_mul(w.n_beta)
    }

    /// [`Self::table_len`] as a `Result` naming the table.
    fn checked_table_len(&self, w: &BeamWindow) -> Result<usize, DspError> {
        self.table_len(w).ok_or(DspError::UnsupportedLength {
            what: "beam table",
            len: usize::MAX,
        })
    }

    /// Length of one subarray's part of the table of window `w` (`None` on overflow).
    pub fn subarray_table_len(&self, w: &BeamWindow) -> Option<usize> {
        w.bins.checked_mul(w.n_alpha)?.checked_mul(w.n_beta)
    }

    /// Scratch [`Self::build`] needs for window `w`: the two steering tables and one subarray's
    /// row beams.
    pub fn scratch_len(&self, w: &BeamWindow) -> usize {
        w.n_alpha * self.fact.sub_cols
            + w.n_beta * self.fact.sub_rows
            + self.fact.sub_rows * w.n_alpha
    }

    fn check_window(&self, w: &BeamWindow) -> Result<(), DspError> {
        for (what, n) in [
            ("window.bins", w.bins),
            ("window.n_alpha", w.n_alpha),
            ("window.n_beta", w.n_beta),
        ] {
            if n < 2 {
                return Err(DspError::UnsupportedLength { what, len: n });
            }
        }
        if !(w.alpha0.is_finite() && w.beta0.is_finite()) {
            return Err(DspError::NonFinite {
                what: "window.alpha0/beta0",
            });
        }
        Ok(())
    }

    /// Samples every subarray's beam of one snapshot on window `w` into `table`
    /// (`[subarray][bin][α][β]`, β fastest). `profiles` holds the lattice's elements in row-major
    /// order, `profile_len` bins each; bins outside the profile are zero. Steering phases are
    /// formed in `f64` and rounded once; the sums are `f32`.
    ///
    /// # Errors
    /// [`DspError::LengthMismatch`] for `profiles`, `table` or `scratch` of the wrong length
    /// (see [`Self::table_len`], [`Self::scratch_len`]); [`DspError::UnsupportedLength`] for a
    /// zero `profile_len` or a window under two samples along an axis; [`DspError::NonFinite`] for
    /// a non-finite profile sample (the table would be, and so every image it touches).
    pub fn build(
        &self,
        w: &BeamWindow,
        profiles: &[Complex<f32>],
        profile_len: usize,
        table: &mut [Complex<f32>],
        scratch: &mut [Complex<f32>],
    ) -> Result<(), DspError> {
        let want = self.checked_table_len(w)?;
        check_len("beam table", want, table.len())?;
        self.build_part(w, profiles, profile_len, 0, table, scratch)
    }

    /// [`Self::build`] for the subarrays `first_subarray ..` whose tables `part` holds (a whole
    /// number of [`Self::subarray_table_len`]): disjoint parts can be built on different threads,
    /// each with its own scratch, and give the bits of one [`Self::build`].
    ///
    /// # Errors
    /// As [`Self::build`]; [`DspError::LengthMismatch`] naming `beam table part` unless `part`
    /// ends on a subarray boundary within the lattice.
    pub fn build_part(
        &self,
        w: &BeamWindow,
        profiles: &[Complex<f32>],
        profile_len: usize,
        first_subarray: usize,
        part: &mut [Complex<f32>],
        scratch: &mut [Complex<f32>],
    ) -> Result<(), DspError> {
        self.check_window(w)?;
        if profile_len == 0 {
            return Err(DspError::UnsupportedLength {
                what: "profile_len",
                len: 0,
            });
        }
        let elements = self.lattice.rows * self.lattice.cols;
        check_len(
            "profiles",
            elements.saturating_mul(profile_len),
            profiles.len(),
        )?;
        let per = self
            .subarray_table_len(w)
            .ok_or(DspError::UnsupportedLength {
                what: "beam table",
                len: usize::MAX,
            })?;
        let count = part.len() / per.max(1);
        if !part.len().is_multiple_of(per) || first_subarray + count > self.subarrays() {
            return Err(DspError::LengthMismatch {
                what: "beam table part",
                expected: (self.subarrays().saturating_sub(first_subarray)) * per,
                got: part.len(),
            });
        }
        check_len("beam scratch", self.scratch_len(w), scratch.len())?;
        if !profiles
            .iter()
            .all(|z| z.re.is_finite() && z.im.is_finite())
        {
            return Err(DspError::NonFinite { what: "profiles" });
        }
        let table = part;
        let (sr, sc) = (self.fact.sub_rows, self.fact.sub_cols);
        let (na, nb) = (w.n_alpha, w.n_beta);
        let (wa, rest) = scratch.split_at_mut(na * sc);
        let (wb, rows) = rest.split_at_mut(nb * sr);
        // Steering e^{−j2π m′ α_p}, m′ the offset from the subarray's centre; `[m][p]`, p fastest.
        let steer = |out: &mut [Complex<f32>], x0: f32, per: f32, n: usize, s: usize| {
            for (m, row) in out.chunks_exact_mut(n).enumerate().take(s) {
                let off = m as f64 - 0.5 * (s - 1) as f64;
                for (p, z) in row.iter_mut().enumerate() {
                    let cyc = off * (x0 as f64 + p as f64 / per as f64);
                    let ph = -core::f64::consts::TAU * (cyc - libm::round(cyc));
                    *z = Complex::new(libm::cos(ph) as f32, libm::sin(ph) as f32);
                }
            }
        };
        steer(wa, w.alpha0, self.per_alpha, na, sc);
        steer(wb, w.beta0, self.per_beta, nb, sr);
        let per_row = self.lattice.cols / sc;
        let plane = na * nb;
        let zero = Complex::new(0.0f32, 0.0);
        for (i, sub) in table.chunks_exact_mut(w.bins * plane).enumerate() {
            let k = first_subarray + i;
            let (r_first, c_first) = ((k / per_row) * sr, (k % per_row) * sc);
            for (j, out) in sub.chunks_exact_mut(plane).enumerate() {
                let b = w.bin0 as i64 + j as i64;
                if b < 0 || b >= profile_len as i64 {
                    out.fill(zero);
                    continue;
                }
                let b = b as usize;
                // Stage 1: per subarray row n, the beam of its S_c elements at every α.
                for (n, row_beam) in rows.chunks_exact_mut(na).enumerate() {
                    let e0 = (r_first + n) * self.lattice.cols + c_first;
                    row_beam.fill(zero);
                    for (m, st) in wa.chunks_exact(na).enumerate() {
                        let s = profiles[(e0 + m) * profile_len + b];
                        for (o, &st) in row_beam.iter_mut().zip(st) {
                            *o += s * st;
                        }
                    }
                }
                // Stage 2: across the rows at every β.
                for (p, o_row) in out.chunks_exact_mut(nb).enumerate() {
                    o_row.fill(zero);
                    for (n, st) in wb.chunks_exact(nb).enumerate() {
                        let r = rows[n * na + p];
                        for (o, &st) in o_row.iter_mut().zip(st) {
                            *o += r * st;
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Pushes one snapshot's beam table into every voxel of the tile `acc` of back-projector
    /// `bp`: per voxel and subarray, `e^{+j2π(r_V + R)/λ} · B(r_V + R, α, β)` read linearly in
    /// range and bilinearly in direction. `first` is the lattice's element (0, 0) and `tx` the
    /// transmitter, grid-local. `acc.pushes()` grows by the lattice's element count.
    ///
    /// # Errors
    /// [`DspError::OutOfRange`] naming `bp wavelength` if `bp`'s wavelength is not this
    /// factorisation's, or `window (does not hold the grid)` if `w` does not hold
    /// [`Self::window_for_box`] of the grid's box (so no voxel reads outside the table);
    /// [`DspError::LengthMismatch`] for a table of the wrong length; as [`Self::window_for_box`]
    /// for bad positions; [`DspError::GridTooLarge`] for a tile beyond the grid.
    pub fn push(
        &self,
        bp: &Backprojector,
        acc: &mut AccF32<'_>,
        w: &BeamWindow,
        table: &[Complex<f32>],
        first: Vec3,
        tx: Vec3,
    ) -> Result<(), DspError> {
        if bp.config().wavelength_m != self.wavelength_m {
            return Err(DspError::OutOfRange {
                what: "bp wavelength (not the factorisation's)",
                value: bp.config().wavelength_m,
            });
        }
        self.check_window(w)?;
        let want = self.checked_table_len(w)?;
        check_len("beam table", want, table.len())?;
        bp.check_acc_f32(acc)?;
        let (lo, hi) = grid_box(bp.grid());
        let need = self.window_for_box(bp, lo, hi, first, tx)?;
        if !holds(w, &need, self.per_alpha, self.per_beta) {
            return Err(DspError::OutOfRange {
                what: "window (does not hold the grid)",
                value: need.bins as f32,
            });
        }
        let job = Job {
            f: self,
            bp,
            w,
            table,
            first,
            tx,
        };
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        let done = avx2::run(&job, acc.first, acc.data);
        #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
        let done = false;
        if !done {
            run(&job, acc.first, acc.data);
        }
        acc.pushes += (self.lattice.rows * self.lattice.cols) as u64;
        Ok(())
    }
}

/// `true` if window `a` holds every sample of window `b` (both of one factorisation, whose
/// direction steps are `1/per_alpha`, `1/per_beta`), up to a thousandth of a step.
fn holds(a: &BeamWindow, b: &BeamWindow, per_alpha: f32, per_beta: f32) -> bool {
    let axis = |a0: f32, na: usize, b0: f32, nb: usize, per: f32| {
        let (lo, hi) = ((b0 - a0) * per, (b0 - a0) * per + (nb - 1) as f32);
        lo >= -1e-3 && hi <= (na - 1) as f32 + 1e-3
    };
    let bins = b.bin0 >= a.bin0 && b.bin0 as i64 + b.bins as i64 <= a.bin0 as i64 + a.bins as i64;
    bins && axis(a.alpha0, a.n_alpha, b.alpha0, b.n_alpha, per_alpha)
        && axis(a.beta0, a.n_beta, b.beta0, b.n_beta, per_beta)
}

/// One validated push: the factorisation, the tile's back-projector, the table and its window,
/// the lattice's element (0, 0) and the transmitter (grid-local).
struct Job<'a> {
    f: &'a Factorised,
    bp: &'a Backprojector,
    w: &'a BeamWindow,
    table: &'a [Complex<f32>],
    first: Vec3,
    tx: Vec3,
}

/// Bilinear + linear reads of the beam table, per chunk of voxels and subarray. Indexed loops over
/// the chunk's struct of arrays, as in [`super::kernel`]: they vectorise.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn run(job: &Job<'_>, first_voxel: usize, acc: &mut [Complex<f32>]) {
    let Job {
        f,
        bp,
        w,
        table,
        first,
        tx,
    } = *job;
    let cfg = bp.config();
    let (r0, inv_dr) = (cfg.r0_m + w.bin0 as f32 * cfg.dr_m, bp.inv_dr);
    let (ua, ub) = (
        f.lattice.col_step / f.wavelength_m,
        f.lattice.row_step / f.wavelength_m,
    );
    let (na, nb, nbins) = (w.n_alpha, w.n_beta, w.bins);
    let plane = na * nb;
    let (amax, bmax, rmax) = ((na - 2) as f32, (nb - 2) as f32, (nbins - 2) as f32);
    let mut geo = Geo::new();
    let (mut ia, mut wa, mut ib, mut wb) =
        ([0f32; CHUNK], [0f32; CHUNK], [0f32; CHUNK], [0f32; CHUNK]);
    let (mut ir, mut wr, mut c_re, mut c_im) =
        ([0f32; CHUNK], [0f32; CHUNK], [0f32; CHUNK], [0f32; CHUNK]);
    let (mut a_re, mut a_im) = ([0f32; CHUNK], [0f32; CHUNK]);
    let mut rr = [0f32; CHUNK];
    for (ci, acc) in acc.chunks_mut(CHUNK).enumerate() {
        let n = acc.len();
        geo.load(&cfg.grid, first_voxel + ci * CHUNK, n, tx);
        for ((re, im), z) in a_re.iter_mut().zip(a_im.iter_mut()).zip(acc.iter()) {
            (*re, *im) = (z.re, z.im);
        }
        for (j, sub) in table.chunks_exact(nbins * plane).enumerate() {
            let c = f.centre(first, j);
            // Pass A (vectorises): R, direction, fractional indices, rotor.
            for k in 0..n {
                let (dx, dy, dz) = (geo.px[k] - c.x, geo.py[k] - c.y, geo.pz[k] - c.z);
                rr[k] = dx * dx + dy * dy + dz * dz;
            }
            for x in rr[..n].iter_mut() {
                *x = float::sqrt(*x);
            }
            for k in 0..n {
                let (dx, dy, dz) = (geo.px[k] - c.x, geo.py[k] - c.y, geo.pz[k] - c.z);
                let inv = 1.0 / rr[k];
                let a = (dx * ua.x + dy * ua.y + dz * ua.z) * inv;
                let b = (dx * ub.x + dy * ub.y + dz * ub.z) * inv;
                let fa = ((a - w.alpha0) * f.per_alpha).clamp(0.0, amax);
                let fb = ((b - w.beta0) * f.per_beta).clamp(0.0, bmax);
                let r = geo.rv[k] + rr[k];
                let x = ((r - r0) * inv_dr).clamp(0.0, rmax);
                let (fa0, fb0, x0) = (floor_f32(fa), floor_f32(fb), floor_f32(x));
                (ia[k], wa[k], ib[k], wb[k], ir[k], wr[k]) =
                    (fa0, fa - fa0, fb0, fb - fb0, x0, x - x0);
                let z = rotor_f32(bp.cycles(r));
                (c_re[k], c_im[k]) = (z.re, z.im);
            }
            // Pass B (gathers): trilinear read, rotate, accumulate. The indices were clamped to
            // the table (the window holds the grid, checked by the caller).
            for k in 0..n {
                let base = (ir[k] as usize * na + ia[k] as usize) * nb + ib[k] as usize;
                let at = |i: usize| sub.get(i).copied().unwrap_or_default();
                let bil = |o: usize| {
                    let (s00, s01) = (at(o), at(o + 1));
                    let (s10, s11) = (at(o + nb), at(o + nb + 1));
                    let v0 = s00 + (s01 - s00) * wb[k];
                    let v1 = s10 + (s11 - s10) * wb[k];
                    v0 + (v1 - v0) * wa[k]
                };
                let (p0, p1) = (bil(base), bil(base + plane));
                let s = p0 + (p1 - p0) * wr[k];
                a_re[k] += s.re * c_re[k] - s.im * c_im[k];
                a_im[k] += s.re * c_im[k] + s.im * c_re[k];
            }
        }
        for ((z, &re), &im) in acc.iter_mut().zip(&a_re[..n]).zip(&a_im[..n]) {
            *z = Complex::new(re, im);
        }
    }
}

/// [`run`] compiled for AVX2, entered only after the CPU was found to have it (as
/// [`super::kernel`]'s: the same IEEE operations in the same order, so the same bits).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[allow(unsafe_code)]
mod avx2 {
    use super::{Complex, Job};

    /// [`super::run`] in the AVX2 build; `false` (nothing done) if the CPU lacks AVX2.
    pub(super) fn run(job: &Job<'_>, first_voxel: usize, acc: &mut [Complex<f32>]) -> bool {
        if !crate::bp::kernel::avx2::available() {
            return false;
        }
        // SAFETY: `run_avx2` needs AVX2 and nothing else; the CPU has it (checked above).
        unsafe { run_avx2(job, first_voxel, acc) };
        true
    }

    #[target_feature(enable = "avx2")]
    fn run_avx2(job: &Job<'_>, first_voxel: usize, acc: &mut [Complex<f32>]) {
        super::run(job, first_voxel, acc)
    }
}

/// A grid's box in grid-local metres: `[0, spacing·(dims − 1)]`.
pub fn grid_box(grid: &VoxelGrid) -> (Vec3, Vec3) {
    let [nx, ny, nz] = grid.dims;
    (
        Vec3::ZERO,
        grid.spacing * Vec3::new((nx - 1) as f32, (ny - 1) as f32, (nz - 1) as f32),
    )
}

#[cfg(test)]
mod tests {
    use super::super::{add_point_echo, BpConfig, Interp, PhaseEval};
    use super::*;
    extern crate std;
    use std::vec;
    use std::vec::Vec;

    const LAMBDA: f32 = 0.03;
    /// c/B of 400 MHz (bistatic path), two bins per cell.
    const RES: f64 = 299_792_458.0 / 400e6;
    const DR: f32 = (RES / 2.0) as f32;
    const BINS: usize = 512;

    /// The factory's receive panel: 32 × 32 elements over 1 m × 0.5 m (pitch 1.04 λ across,
    /// 0.52 λ up), facing +y from `dist` metres in front of a 4 m × 4 m × 2 m grid, 3 m above
    /// its floor and 1 m to the side; grid-local.
    fn setup(dist: f32) -> (Backprojector, Lattice) {
        let bp = Backprojector::new(BpConfig {
            grid: VoxelGrid {
                origin: Vec3::new(10.0, 20.0, 0.0),
                spacing: Vec3::splat(0.25),
                dims: [16, 16, 8],
            },
            wavelength_m: LAMBDA,
            r0_m: 0.0,
            dr_m: DR,
            interp: Interp::Linear,
            phase: PhaseEval::Poly,
        })
        .unwrap();
        let lattice = Lattice {
            first: Vec3::new(1.0 - 0.5, -dist, 3.0 - 0.25),
            col_step: Vec3::new(1.0 / 32.0, 0.0, 0.0),
            row_step: Vec3::new(0.0, 0.0, 0.5 / 32.0),
            rows: 32,
            cols: 32,
        };
        (bp, lattice)
    }

    /// Transmitter positions: a 3 m track along x, 10 m in front of the grid at 1.5 m.
    fn txs() -> Vec<Vec3> {
        (0..6)
            .map(|k| Vec3::new(0.5 + 0.6 * k as f32, -10.0, 1.5))
            .collect()
    }

    const POINTS: [Vec3; 3] = [
        Vec3::new(1.6, 2.1, 0.9),
        Vec3::new(2.9, 1.0, 1.4),
        Vec3::new(0.7, 3.3, 0.4),
    ];

    /// Profiles of one snapshot (every element, row-major) of the point targets.
    fn profiles(l: &Lattice, tx: Vec3) -> Vec<Complex<f32>> {
        let mut out = vec![Complex::new(0.0f32, 0.0); l.rows * l.cols * BINS];
        for (e, prof) in out.chunks_exact_mut(BINS).enumerate() {
            let rx = l.element(e / l.cols, e % l.cols);
            for p in POINTS {
                let d = |a: Vec3, b: Vec3| {
                    let (x, y, z) = ((a.x - b.x) as f64, (a.y - b.y) as f64, (a.z - b.z) as f64);
                    libm::sqrt(x * x + y * y + z * z)
                };
                let r = d(p, tx) + d(p, rx);
                add_point_echo(
                    prof,
                    0.0,
                    DR as f64,
                    LAMBDA as f64,
                    RES,
                    r,
                    Complex::new(1.0, 0.0),
                )
                .unwrap();
            }
        }
        out
    }

    /// Exact and factorised images of the scene, and the largest sample step `max|s[i+1] − s[i]|`.
    fn images(
        dist: f32,
        fact: Factorisation,
    ) -> (Vec<Complex<f32>>, Vec<Complex<f32>>, f32, Factorised) {
        let (bp, l) = setup(dist);
        let f = Factorised::new(l, fact, LAMBDA).unwrap();
        let rx: Vec<Vec3> = (0..l.rows * l.cols)
            .map(|e| l.element(e / l.cols, e % l.cols))
            .collect();
        let n = bp.voxels();
        let (mut ex, mut fa) = (vec![Complex::default(); n], vec![Complex::default(); n]);
        let mut ae = AccF32::new(&bp, &mut ex).unwrap();
        let mut af = AccF32::new(&bp, &mut fa).unwrap();
        let (lo, hi) = grid_box(bp.grid());
        let mut slope = 0.0f32;
        for tx in txs() {
            let p = profiles(&l, tx);
            for prof in p.chunks_exact(BINS) {
                for w in prof.windows(2) {
                    slope = slope.max((w[1] - w[0]).norm());
                }
            }
            let snap = super::super::Snapshot {
                tx,
                rx: &rx,
                profiles: &p,
                profile_len: BINS,
            };
            bp.push_snapshot(&mut ae, &snap).unwrap();
            let w = f.window_for_box(&bp, lo, hi, l.first, tx).unwrap();
            let mut table = vec![Complex::default(); f.table_len(&w).unwrap()];
            let mut scratch = vec![Complex::default(); f.scratch_len(&w)];
            f.build(&w, &p, BINS, &mut table, &mut scratch).unwrap();
            f.push(&bp, &mut af, &w, &table, l.first, tx).unwrap();
        }
        assert_eq!(ae.pushes(), af.pushes());
        (ex, fa, slope, f)
    }

    fn ser_f32(img: &[Complex<f32>], reference: &[Complex<f32>]) -> f64 {
        let r64: Vec<Complex<f64>> = reference
            .iter()
            .map(|z| Complex::new(z.re as f64, z.im as f64))
            .collect();
        super::super::ser_db(img, &r64).unwrap()
    }

    fn argmax(img: &[Complex<f32>]) -> usize {
        (0..img.len())
            .max_by(|&a, &b| img[a].norm().total_cmp(&img[b].norm()))
            .unwrap()
    }

    #[test]
    fn one_element_subarrays_are_exact_back_projection() {
        let fact = Factorisation {
            sub_rows: 1,
            sub_cols: 1,
            oversample: 1,
        };
        let (ex, fa, _, _) = images(20.0, fact);
        let ser = ser_f32(&fa, &ex);
        std::println!("1 × 1 subarrays: SER against exact {ser:.1} dB");
        // Only f32 roundings differ (the table's first bin shifts r0; the exact push reads the
        // profile directly): far below any approximation of the factorisation.
        assert!(ser > 80.0, "SER {ser:.1} dB");
    }

    /// The per-term bound of the module docs summed over every term of every voxel: with `s` the
    /// linearly interpolated profile, `|δ|` half the subarray's diagonal and `R` the voxel's
    /// distance from the subarray centre (bounded below by `|P − e| − |δ|`), a term errs by at most
    /// `A·(φ_F + ε_I + φ_f32) + (|δ| + d_F)·D/dr`, where `A` is the largest `|s|` and `D` the
    /// largest step `|s[i+1] − s[i]|` within a bin of the element's own range (the walk stays
    /// inside that: `|δ| + d_F < dr`), `φ_F = π|δ|²/(λ(R − |δ|))`, `d_F = |δ|²/(2(R − |δ|))`,
    /// `ε_I = π²/(4O²)`, and `φ_f32 = 10⁻³` rad for the `f32` ranges (ulp 4·10⁻⁶ m at 60 m: 8·10⁻⁴).
    fn bounds(f: &Factorised, bp: &Backprojector) -> Vec<f32> {
        let l = f.lattice();
        let fc = f.factorisation();
        let delta = 0.5
            * (l.col_step * (fc.sub_cols - 1) as f32 + l.row_step * (fc.sub_rows - 1) as f32)
                .length();
        assert!(delta < DR / 2.0);
        let interp = core::f32::consts::PI.powi(2) / (4.0 * (fc.oversample * fc.oversample) as f32);
        let mut out = vec![0.0f32; bp.voxels()];
        for tx in txs() {
            let p = profiles(l, tx);
            for (e, prof) in p.chunks_exact(BINS).enumerate() {
                let rx = l.element(e / l.cols, e % l.cols);
                for (v, o) in out.iter_mut().enumerate() {
                    let pv = bp.grid().voxel_local(v).unwrap();
                    let re = pv.distance(rx);
                    let i = libm::floorf((pv.distance(tx) + re) / DR) as usize;
                    let (lo, hi) = (i.saturating_sub(1), (i + 2).min(BINS - 1));
                    let a = prof[lo..=hi]
                        .iter()
                        .map(|z| z.norm())
                        .fold(0.0f32, f32::max);
                    let d = prof[lo..=hi]
                        .windows(2)
                        .map(|w| (w[1] - w[0]).norm())
                        .fold(0.0f32, f32::max);
                    let r = re - 2.0 * delta;
                    let (phase, walk) = (
                        core::f32::consts::PI * delta * delta / (LAMBDA * r),
                        delta + delta * delta / (2.0 * r),
                    );
                    *o += a * (phase + interp + 1e-3) + walk * d / DR;
                }
            }
        }
        out
    }

    #[test]
    fn factorised_image_is_within_its_derived_error_bound_and_focuses_on_the_same_voxels() {
        for (dist, fact) in [
            (
                20.0,
                Factorisation {
                    sub_rows: 8,
                    sub_cols: 4,
                    oversample: 4,
                },
            ),
            (
                20.0,
                Factorisation {
                    sub_rows: 4,
                    sub_cols: 4,
                    oversample: 8,
                },
            ),
            (
                60.0,
                Factorisation {
                    sub_rows: 8,
                    sub_cols: 8,
                    oversample: 4,
                },
            ),
        ] {
            let (ex, fa, _, f) = images(dist, fact);
            let (bp, _) = setup(dist);
            let b = bounds(&f, &bp);
            let worst = ex
                .iter()
                .zip(&fa)
                .zip(&b)
                .map(|((a, c), b)| (a - c).norm() / b)
                .fold(0.0f32, f32::max);
            let peak = ex[argmax(&ex)].norm();
            let ser = ser_f32(&fa, &ex);
            std::println!(
                "{fact:?} at {dist} m: SER {ser:.1} dB; largest error / its bound {worst:.3}; \
                 bound at the peak / peak {:.3}",
                b[argmax(&ex)] / peak
            );
            assert!(
                worst <= 1.0,
                "{fact:?}: an error exceeds its bound ({worst})"
            );
            assert_eq!(argmax(&fa), argmax(&ex), "{fact:?}: peak moved");
        }
    }

    #[test]
    fn finer_direction_sampling_lowers_the_error() {
        let ser = |o| {
            let (ex, fa, _, _) = images(
                40.0,
                Factorisation {
                    sub_rows: 8,
                    sub_cols: 8,
                    oversample: o,
                },
            );
            ser_f32(&fa, &ex)
        };
        let (s2, s4, s8) = (ser(2), ser(4), ser(8));
        std::println!("8 × 8 at 40 m: SER O=2 {s2:.1}, O=4 {s4:.1}, O=8 {s8:.1} dB");
        assert!(s2 < s4 && s4 < s8, "{s2} {s4} {s8}");
    }

    /// An 8 × 4, O = 4 factorisation of the 20 m panel and the table of transmit position `k`.
    /// (`bp`, `l` and `tx` are read only by the tests of the `std` build.)
    #[cfg_attr(not(feature = "std"), allow(dead_code))]
    struct Built {
        bp: Backprojector,
        l: Lattice,
        f: Factorised,
        tx: Vec3,
        p: Vec<Complex<f32>>,
        w: BeamWindow,
        table: Vec<Complex<f32>>,
    }

    fn built(k: usize) -> Built {
        let (bp, l) = setup(20.0);
        let fact = Factorisation {
            sub_rows: 8,
            sub_cols: 4,
            oversample: 4,
        };
        let f = Factorised::new(l, fact, LAMBDA).unwrap();
        let tx = txs()[k];
        let p = profiles(&l, tx);
        let (lo, hi) = grid_box(bp.grid());
        let w = f.window_for_box(&bp, lo, hi, l.first, tx).unwrap();
        let mut table = vec![Complex::default(); f.table_len(&w).unwrap()];
        let mut scratch = vec![Complex::default(); f.scratch_len(&w)];
        f.build(&w, &p, BINS, &mut table, &mut scratch).unwrap();
        Built {
            bp,
            l,
            f,
            tx,
            p,
            w,
            table,
        }
    }

    fn same_bits(a: &[Complex<f32>], b: &[Complex<f32>]) -> bool {
        a.iter()
            .zip(b)
            .all(|(x, y)| x.re.to_bits() == y.re.to_bits() && x.im.to_bits() == y.im.to_bits())
    }

    #[test]
    fn a_table_built_in_parts_has_the_bits_of_one_build() {
        let Built {
            f,
            p,
            w,
            table: whole,
            ..
        } = built(2);
        let mut scratch = vec![Complex::default(); f.scratch_len(&w)];
        let per = f.subarray_table_len(&w).unwrap();
        let mut parts = vec![Complex::new(9.0f32, 9.0); whole.len()];
        // Uneven parts: 3 subarrays, then 1, then the rest.
        let (a, rest) = parts.split_at_mut(3 * per);
        let (b, c) = rest.split_at_mut(per);
        f.build_part(&w, &p, BINS, 0, a, &mut scratch).unwrap();
        f.build_part(&w, &p, BINS, 3, b, &mut scratch).unwrap();
        f.build_part(&w, &p, BINS, 4, c, &mut scratch).unwrap();
        // A part that runs past the last subarray is refused.
        let e = f.build_part(&w, &p, BINS, 5, c, &mut scratch).unwrap_err();
        assert!(matches!(
            e,
            DspError::LengthMismatch {
                what: "beam table part",
                ..
            }
        ));
        assert!(same_bits(&whole, &parts));
    }

    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    #[test]
    fn the_avx2_build_gives_the_baseline_build_bit_for_bit() {
        if !crate::bp::kernel::avx2::available() {
            return;
        }
        let Built {
            bp,
            l,
            f,
            tx,
            w,
            table,
            ..
        } = built(1);
        let n = bp.voxels();
        let (mut a, mut b) = (vec![Complex::default(); n], vec![Complex::default(); n]);
        let job = Job {
            f: &f,
            bp: &bp,
            w: &w,
            table: &table,
            first: l.first,
            tx,
        };
        run(&job, 0, &mut a);
        assert!(avx2::run(&job, 0, &mut b));
        assert!(same_bits(&a, &b));
        assert!(a.iter().any(|z| z.norm() > 0.0));
    }

    #[test]
    fn bad_factorisations_and_windows_are_refused_by_name() {
        let (bp, l) = setup(20.0);
        let bad = |fact| Factorised::new(l, fact, LAMBDA).unwrap_err();
        assert!(matches!(
            bad(Factorisation {
                sub_rows: 5,
                sub_cols: 4,
                oversample: 4
            }),
            DspError::UnsupportedLength {
                what: "factorisation.sub_rows",
                len: 5
            }
        ));
        assert!(matches!(
            bad(Factorisation {
                sub_rows: 4,
                sub_cols: 0,
                oversample: 4
            }),
            DspError::UnsupportedLength {
                what: "factorisation.sub_cols",
                ..
            }
        ));
        assert!(matches!(
            bad(Factorisation {
                sub_rows: 4,
                sub_cols: 4,
                oversample: 0
            }),
            DspError::UnsupportedLength {
                what: "factorisation.oversample",
                ..
            }
        ));
        let f = Factorised::new(
            l,
            Factorisation {
                sub_rows: 8,
                sub_cols: 8,
                oversample: 2,
            },
            LAMBDA,
        )
        .unwrap();
        let tx = txs()[0];
        let (lo, hi) = grid_box(bp.grid());
        // A window for half the grid does not hold the grid: refused before any voxel is touched.
        let w = f.window_for_box(&bp, lo, hi * 0.5, l.first, tx).unwrap();
        let table = vec![Complex::default(); f.table_len(&w).unwrap()];
        let mut img = vec![Complex::default(); bp.voxels()];
        let mut acc = AccF32::new(&bp, &mut img).unwrap();
        let e = f.push(&bp, &mut acc, &w, &table, l.first, tx).unwrap_err();
        assert!(matches!(
            e,
            DspError::OutOfRange {
                what: "window (does not hold the grid)",
                ..
            }
        ));
        assert_eq!(acc.pushes(), 0);
        assert!(img.iter().all(|z| *z == Complex::default()));
        // A non-finite profile never reaches a table.
        let w = f.window_for_box(&bp, lo, hi, l.first, tx).unwrap();
        let mut table = vec![Complex::default(); f.table_len(&w).unwrap()];
        let mut scratch = vec![Complex::default(); f.scratch_len(&w)];
        let mut p = vec![Complex::new(0.0f32, 0.0); 1024 * 16];
        p[77] = Complex::new(f32::NAN, 0.0);
        let e = f.build(&w, &p, 16, &mut table, &mut scratch).unwrap_err();
        assert!(matches!(e, DspError::NonFinite { what: "profiles" }));
        let e = f
            .build(&w, &p[1..], 16, &mut table, &mut scratch)
            .unwrap_err();
        assert!(matches!(
            e,
            DspError::LengthMismatch {
                what: "profiles",
                ..
            }
        ));
    }
}
