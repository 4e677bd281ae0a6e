//! A pair's detections that are the sidelobes of a stronger echo of its own image.
//!
//! **Why.** The detection test ([`super::detection`]) holds each voxel against the bare terrain's
//! clutter and the incoherent floor `P(v)`: the power the range cells through `v` would give if
//! their echoes added with random phases. A point echo's coherent image does not stay under that
//! floor: with `N` (transmit position, receive element) terms the peak is `N²|a|²` and the floor
//! `N|a|²`, so the floor lies `10 log₁₀ N` (≈ 30 dB for a thinned pair) under the peak, while the
//! sidelobes of the panel's aperture along its elevation — the direction a pair resolves worst,
//! 3.6 m for a 0.5 m tall panel at 60 m — fall only as `sinc²` (−13 dB, then −18, −21, …, and a
//! jittered thinned panel has a floor of its own near `1/N_elements`). An echo 20–30 dB above the
//! rest of the site, such as a metal roof's, therefore lays a column of sidelobes over the
//! terrain's clutter and over `P`: a plume of detections standing on the roof.
//!
//! **The test.** The image a pair forms of a point echo at `u` is its point-spread function:
//! `I_u(v) = a Σ_{t,e} p(Δr_{t,e}/δr) e^{j2πΔr_{t,e}/λ}`, over the pair's transmit positions `t`
//! and receive elements `e`, with `Δr_{t,e} = (|v − t| + |v − e|) − (|u − t| + |u − e|)` and `p`
//! the compressed pulse on bins of `δr` (the profile the back-projection reads). Normalised to its
//! peak, `ρ_u(v) = |I_u(v)|² / |I_u(u)|²`. A detection `v` is the sidelobe of a stronger detection
//! `u` of the same pair when it lies outside `u`'s main lobe — at least one resolution cell away in
//! the pair's resolution metric, `Σ_i ((v − u)·â_i / δ_i)² ≥ 1` over the range and cross-range
//! directions and resolutions of [`crate::sensors::pair_resolution_axes`], i.e. past the first
//! null of a uniform aperture — and its power is no more than what `u`'s point-spread function
//! puts there: `|I(v)|² ≤ |I(u)|²·ρ_u(v)`. (The range cell counts with the pulse's main lobe,
//! two cells `c/B` for a Hann window; the apertures are untapered, their first null one cell.) A surface of its own at `v` adds its echo to that
//! sidelobe and stands above it; what the sidelobe alone explains is not evidence of anything at
//! `v`. The reference is the echo that causes the sidelobe, not the noise or the terrain, so the
//! test holds for any surface brightness, metal included; and it uses the pair's own sensors, so
//! it needs no parameter.
//!
//! **What stands outside the region.** The driver images a guard band past the region
//! ([`crate::imaging::driver`]), and its detections there are sources too: the sidelobes a
//! neighbour's facade lays into the region are judged against that facade. For such a source the
//! main lobe counts as well — within its resolution cell the pair cannot separate an echo inside
//! the region from the stronger one outside, and the stronger is where the echo comes from (a
//! wall of the region itself keeps its own peaks, which its image there does not fall below).
//!
//! Cost: `Δr` is bounded by its value between the apertures' centres and the apertures' extent
//! (`|Δr_{t,e} − Δr_c| ≤ |t − t_c|·2 + |e − e_c|·2`), so the full sum is formed only for pairs
//! of detections on nearly the same range shell, which is where a pulse-compressed image puts
//! sidelobes at all. Within the shell, the exact spans of `Δr` over the transmit positions and
//! over the elements bound it again: where `Δr_{t,e}` keeps at least `r` bins from zero for every
//! term, `ρ_u(v) ≤ (max_{|x| ≥ r} |p(x)| / p(0))²`, and a detection stronger than that bound is
//! not `u`'s sidelobe — decided with `N_t + N_e` distances instead of `N_t·N_e` terms, and
//! decided as the sum would. Where the shells overlap, the elements are grouped by their path
//! difference `d_e` into spans of at most [`GROUP_HALF_BINS`] either side of a group centre, and
//! within a group the pulse is replaced by its quadratic through three Chebyshev nodes, so that
//! the inner sum over the group is three moments `Σ_e δ_e^k e^{j2πd_e/λ}` formed once: the sum
//! costs `N_t·G + N_e` for `G` groups. Its error per term is bounded by the tabulated pulse's error
//! `ε` (the kernel's stated bound and the table's linear interpolation, times `1 + Λ` with the
//! nodes' Lebesgue constant `Λ = 5/3`), the interpolation remainder `|p'''|·h³/24` for a group of
//! half-width `h` (`|p'''| ≤ (π/z)³·Σ|w|/|Σw|` for zero padding `z`, the same sum that bounds the
//! kernel's interpolation error) and the `f32` rounding of the full sum; where `a²/b²` lies outside
//! the interval this gives `ρ_u(v)`, the decision is the full sum's without it, and otherwise the
//! full sum is formed. At the default preset (256 elements, 60 transmit positions, thousands of
//! detections per pair) the full sum was most of a pair's imaging time.
//!
//! Units: metres, world frame; intensities `|I|` on any common scale.

use glam::Vec3;
use num_complex::{Complex32, Complex64};
use rayon::prelude::*;

use crate::echo::PulseKernel;
use crate::sensors::{pair_resolution_axes, PlanarArray, VirtualAperture};

/// The pair's imaging geometry as the point-spread function needs it.
pub struct PairPsf<'a> {
    /// Transmit positions the image summed over, metres.
    pub tx: &'a [Vec3],
    /// Receive elements the image summed over, metres.
    pub rx: &'a [Vec3],
    /// The compressed pulse on the profile's bins.
    pub pulse: &'a PulseKernel,
    /// Profile bin spacing (bistatic path), metres.
    pub bin_m: f32,
    /// Carrier wavelength, metres.
    pub wavelength_m: f32,
    /// The panel and track, for the resolution metric.
    pub array: &'a PlanarArray,
    /// The pair's virtual aperture.
    pub aperture: &'a VirtualAperture,
    /// Signal bandwidth, Hz.
    pub bandwidth_hz: f32,
    /// The compressed pulse's main-lobe half-width in range cells `c/B` (first null; Hann: 2).
    pub range_main_lobe_cells: f32,
}

/// Half-width, in profile bins, of an element group of the bounded sum (module docs): the
/// interpolation remainder `|p'''|·h³/24` is then about 3·10⁻⁴ of the pulse's peak for a Hann
/// window at zero padding 2, below the tabulated pulse's own error.
const GROUP_HALF_BINS: f64 = 0.125;

/// Most element groups of the bounded sum; a wider spread of `d_e` goes to the full sum.
const MAX_GROUPS: usize = 64;

/// Most entries (`f32`, 4 bytes each: 256 MiB) of the table of every echo's distances to the
/// sensors; past it, each pair of echoes forms its own.
const DISTANCE_TABLE_MAX: usize = 1 << 26;

/// The pulse sampled finely for fast lookups: `p(x)` at `x = k/STEPS` bins.
struct PulseTable {
    values: Vec<Complex32>,
    half_bins: f32,
    /// `tail[k]`: the largest `|p|` of the samples at least `k/STEPS` bins from the centre.
    tail: Vec<f32>,
    /// Bound on `|at(x) − p(x)|` for the exact pulse `p`, every `x`.
    error: f64,
    /// Bound on `|p'''|`, per bin³.
    third_derivative: f64,
    /// `e^{j2π i/PHASOR_N}`, `i = 0..=PHASOR_N`.
    phasors: Vec<Complex64>,
}

impl PulseTable {
    const STEPS: f32 = 32.0;

    fn new(pulse: &PulseKernel) -> PulseTable {
        let half = pulse.half_width_bins() as f32;
        let n = (2.0 * half * Self::STEPS) as usize + 1;
        let values: Vec<Complex32> = (0..n)
            .map(|k| pulse.eval((k as f32 / Self::STEPS - half) as f64))
            .collect();
        let centre = (half * Self::STEPS) as usize;
        let mut tail = vec![0.0f32; centre + 2];
        for k in (0..=centre).rev() {
            let far = [centre.checked_sub(k), Some(centre + k)]
                .into_iter()
                .flatten()
                .filter_map(|j| values.get(j))
                .map(|v: &Complex32| v.norm())
                .fold(0.0f32, f32::max);
            tail[k] = tail[k + 1].max(far);
        }
        // `|p''| ≤ (π/z)²·Σ|w|/|Σw| = 8·O²·ε_I` (the kernel's interpolation bound `ε_I` at `O`
        // samples per bin), and `|p'''| ≤ (π/z)³·Σ|w|/|Σw| ≤ (8·O²·ε_I)^{3/2}` since
        // `Σ|w|/|Σw| ≥ 1`; 0.1 % over for the bound's `f32` storage.
        let o = pulse.oversample() as f64;
        let second = 8.0 * o * o * pulse.interpolation_error() as f64 * 1.001;
        PulseTable {
            values,
            half_bins: half,
            tail,
            error: pulse.error_bound() as f64
                + second / (8.0 * (Self::STEPS as f64).powi(2))
                + 2e-6,
            third_derivative: second.powf(1.5),
            phasors: (0..=PHASOR_N)
                .map(|i| {
                    Complex64::from_polar(1.0, std::f64::consts::TAU * i as f64 / PHASOR_N as f64)
                })
                .collect(),
        }
    }

    /// An upper bound of `|p(x)|` over every `|x| ≥ r` bins: an interpolated value lies between
    /// two samples each within one step of `x`.
    fn bound_beyond(&self, r: f32) -> f32 {
        let k = ((r * Self::STEPS).floor() - 1.0).max(0.0) as usize;
        self.tail.get(k).copied().unwrap_or(0.0)
    }

    /// The range bound: whether an echo of power `a2` lies above `b2` times the pulse's power
    /// beyond the clearance from zero of path differences in `[lo, hi]` bins (none when the
    /// interval straddles zero).
    fn above_tail(&self, lo: f32, hi: f32, b2: f32, a2: f32) -> bool {
        let r = if lo > 0.0 {
            lo
        } else if hi < 0.0 {
            -hi
        } else {
            return false;
        };
        let p0 = self.at(0.0).norm();
        p0 > 0.0 && a2 > b2 * (self.bound_beyond(r) / p0).powi(2)
    }

    /// `p(x)` at `x` bins, linearly interpolated; 0 beyond the pulse's reach.
    fn at(&self, x: f32) -> Complex32 {
        let u = (x + self.half_bins) * Self::STEPS;
        if u.is_nan() || u < 0.0 {
            return Complex32::new(0.0, 0.0);
        }
        let i = u as usize;
        if i + 1 >= self.values.len() {
            return Complex32::new(0.0, 0.0);
        }
        let f = u - i as f32;
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }
}

/// The centres and radii of a pair's transmit positions and elements ([`PairPsf::apertures`]).
struct Apertures {
    tx_centre: Vec3,
    rx_centre: Vec3,
    tx_radius: f32,
    rx_radius: f32,
}

/// An echo seen from the apertures' centres: distances, metres, and unit vectors from the echo.
struct Sight {
    tx_m: f32,
    tx_dir: Vec3,
    rx_m: f32,
    rx_dir: Vec3,
}

impl Sight {
    fn of(p: Vec3, ap: &Apertures) -> Sight {
        let (t, e) = (ap.tx_centre - p, ap.rx_centre - p);
        Sight {
            tx_m: t.length(),
            tx_dir: t.normalize_or_zero(),
            rx_m: e.length(),
            rx_dir: e.normalize_or_zero(),
        }
    }
}

/// Per-thread buffers of the point-spread function's sums.
#[derive(Default)]
struct Scratch {
    /// Per transmit position: `a_t = |v − t| − |u − t|`, metres, and (after
    /// [`Scratch::phasors`]) its phasor.
    tx: Vec<(f32, Complex32)>,
    /// Per receive element: `d_e = |v − e| − |u − e|`, metres, and its phasor.
    rx: Vec<(f32, Complex32)>,
    /// Per element group of the bounded sum: its moments and element count.
    moments: Vec<([Complex64; 3], usize)>,
    /// Distances from `u` and from `v` to every transmit position, then every element.
    u_dist: Vec<f32>,
    v_dist: Vec<f32>,
}

impl Scratch {
    /// The path differences `|v − s| − |u − s|` through every sensor `s`, from the distances of
    /// `u` and `v` to them ([`PairPsf::distances`]); phasors not yet formed.
    fn fill(&mut self, nt: usize, u_dist: &[f32], v_dist: &[f32]) {
        let diff = |(&dv, &du): (&f32, &f32)| (dv - du, Complex32::new(0.0, 0.0));
        self.tx.clear();
        self.tx
            .extend(v_dist[..nt].iter().zip(&u_dist[..nt]).map(diff));
        self.rx.clear();
        self.rx
            .extend(v_dist[nt..].iter().zip(&u_dist[nt..]).map(diff));
    }

    /// [`Scratch::fill`] for places `u` and `v`.
    fn fill_places(&mut self, psf: &PairPsf<'_>, u: Vec3, v: Vec3) {
        let (mut ud, mut vd) = (
            std::mem::take(&mut self.u_dist),
            std::mem::take(&mut self.v_dist),
        );
        psf.distances(u, &mut ud);
        psf.distances(v, &mut vd);
        self.fill(psf.tx.len(), &ud, &vd);
        (self.u_dist, self.v_dist) = (ud, vd);
    }

    /// The exact phasors of the path differences ([`PairPsf::phasor`]).
    fn phasors(&mut self, psf: &PairPsf<'_>) {
        for (d, ph) in self.tx.iter_mut().chain(self.rx.iter_mut()) {
            *ph = psf.phasor(*d);
        }
    }
}

/// Entries of the bounded sum's phasor table `e^{j2π i/N}` (linear interpolation: magnitude and
/// phase error ≤ (2π/N)²/8 ≈ 3·10⁻⁷).
const PHASOR_N: usize = 4096;

/// `e^{j2π·cycles}` from a table of [`PHASOR_N`] + 1 entries (no libm call).
fn table_phasor(table: &[Complex64], cycles: f64) -> Complex64 {
    let x = (cycles - crate::echo::floor_small(cycles)) * PHASOR_N as f64;
    let i = (x as usize).min(PHASOR_N - 1);
    let t = x - i as f64;
    table[i] + (table[i + 1] - table[i]) * t
}

impl PairPsf<'_> {
    /// `ρ_u(v)`: the pair's point-spread function of an echo at `u`, evaluated at `v`, in power
    /// relative to its peak (module docs). 0 where `v` lies past the pulse's reach in every
    /// term.
    pub fn relative_power(&self, u: Vec3, v: Vec3) -> f32 {
        let table = PulseTable::new(self.pulse);
        self.relative_power_with(&table, u, v, &mut Scratch::default())
    }

    fn centres(&self) -> (Vec3, Vec3, f32) {
        let c = self.apertures();
        (c.tx_centre, c.rx_centre, 2.0 * (c.tx_radius + c.rx_radius))
    }

    /// The centres of the transmit positions and of the elements, and the largest distance of
    /// each from its centre, metres.
    fn apertures(&self) -> Apertures {
        let mean = |s: &[Vec3]| s.iter().copied().sum::<Vec3>() / s.len().max(1) as f32;
        let (tc, ec) = (mean(self.tx), mean(self.rx));
        let spread = |s: &[Vec3], c: Vec3| s.iter().map(|p| p.distance(c)).fold(0.0f32, f32::max);
        Apertures {
            tx_centre: tc,
            rx_centre: ec,
            tx_radius: spread(self.tx, tc),
            rx_radius: spread(self.rx, ec),
        }
    }

    /// Whether the range bound of [`Self::explains_from`] already rejects `u`'s sidelobe at `v`
    /// with the spans of `a_t` and `d_e` bounded from the apertures' centres alone: over a ball
    /// of radius `R` about a centre `c`, `|v − s| − |u − s|` stays within `R·(|n_v − n_u| +
    /// R·(1/(|v − c| − R) + 1/(|u − c| − R)))` of its value at `c` (`n` the unit vectors from the
    /// echo to `c`, each turning at most `1/(distance − R)` per metre). The interval holds the
    /// exact one (with a millimetre for `f32` rounding), so a rejection here is one there.
    fn beyond_reach(
        &self,
        table: &PulseTable,
        ap: &Apertures,
        su: &Sight,
        b2: f32,
        sv: &Sight,
        a2: f32,
    ) -> bool {
        let leg = |dv: f32, du: f32, nv: Vec3, nu: Vec3, r: f32| {
            (dv > r && du > r).then(|| {
                let k = 1.0 / (dv - r) + 1.0 / (du - r);
                (dv - du, r * ((nv - nu).length() + r * k))
            })
        };
        let (Some((ac, ah)), Some((dc, dh))) = (
            leg(sv.tx_m, su.tx_m, sv.tx_dir, su.tx_dir, ap.tx_radius),
            leg(sv.rx_m, su.rx_m, sv.rx_dir, su.rx_dir, ap.rx_radius),
        ) else {
            return false;
        };
        let margin = 1e-3;
        let inv_bin = 1.0 / self.bin_m;
        let (lo, hi) = (
            (ac + dc - ah - dh - margin) * inv_bin,
            (ac + dc + ah + dh + margin) * inv_bin,
        );
        table.above_tail(lo, hi, b2, a2)
    }

    /// Whether an echo of power `a2` at `v` is no stronger than the sidelobe an echo of power
    /// `b2` at `u` puts there, `a2 ≤ b2·ρ_u(v)`. The path differences `a + d` of every transmit
    /// position and element lie in `[min a + min d, max a + max d]`; where that interval keeps
    /// `r` bins from zero, `ρ_u(v) ≤ (max_{|x| ≥ r} |p(x)| / p(0))²`, and an echo above that
    /// bound is decided without the sum. Otherwise the grouped sum's interval decides where it
    /// can ([`Self::relative_power_bounds`]), and the full sum where it cannot: every decision is
    /// the full sum's.
    #[cfg(test)]
    fn explains(
        &self,
        table: &PulseTable,
        u: Vec3,
        b2: f32,
        v: Vec3,
        a2: f32,
        scratch: &mut Scratch,
    ) -> bool {
        let (mut ud, mut vd) = (Vec::new(), Vec::new());
        self.distances(u, &mut ud);
        self.distances(v, &mut vd);
        self.explains_from(table, &ud, b2, &vd, a2, scratch)
    }

    /// The distances from `p` to every transmit position, then every element.
    fn distances(&self, p: Vec3, out: &mut Vec<f32>) {
        out.clear();
        out.extend(self.tx.iter().chain(self.rx).map(|s| p.distance(*s)));
    }

    /// [`Self::explains`] from the distances of `u` and `v` to the sensors
    /// ([`Self::distances`]).
    fn explains_from(
        &self,
        table: &PulseTable,
        u_dist: &[f32],
        b2: f32,
        v_dist: &[f32],
        a2: f32,
        scratch: &mut Scratch,
    ) -> bool {
        if self.tx.is_empty() || self.rx.is_empty() {
            return a2 <= 0.0;
        }
        scratch.fill(self.tx.len(), u_dist, v_dist);
        let span = |s: &[(f32, Complex32)]| {
            s.iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &(d, _)| {
                    (lo.min(d), hi.max(d))
                })
        };
        let ((a_lo, a_hi), (d_lo, d_hi)) = (span(&scratch.tx), span(&scratch.rx));
        let inv_bin = 1.0 / self.bin_m;
        let (lo, hi) = ((a_lo + d_lo) * inv_bin, (a_hi + d_hi) * inv_bin);
        if table.above_tail(lo, hi, b2, a2) {
            return false;
        }
        if let Some((rho_lo, rho_hi)) = self.relative_power_bounds(table, scratch, (d_lo, d_hi)) {
            if a2 > b2 * rho_hi {
                return false;
            }
            if a2 <= b2 * rho_lo {
                return true;
            }
        }
        scratch.phasors(self);
        a2 <= b2 * self.full_sum(table, scratch)
    }

    fn relative_power_with(
        &self,
        table: &PulseTable,
        u: Vec3,
        v: Vec3,
        scratch: &mut Scratch,
    ) -> f32 {
        if self.tx.is_empty() || self.rx.is_empty() {
            return 0.0;
        }
        scratch.fill_places(self, u, v);
        scratch.phasors(self);
        self.full_sum(table, scratch)
    }

    /// The phasor of a path difference of `d` metres: the phase of metres to hundreds of
    /// wavelengths, reduced in cycles first so `f32` keeps its precision.
    fn phasor(&self, d: f32) -> Complex32 {
        let cycles = d / self.wavelength_m;
        let (s, c) = (std::f32::consts::TAU * (cycles - cycles.round())).sin_cos();
        Complex32::new(c, s)
    }

    /// `ρ_u(v)` as the full sum over every transmit position and element, from the path
    /// differences and phasors in `scratch` ([`Scratch::fill`]).
    fn full_sum(&self, table: &PulseTable, scratch: &Scratch) -> f32 {
        let n = self.tx.len() * self.rx.len();
        let inv_bin = 1.0 / self.bin_m;
        let p0 = table.at(0.0).norm();
        let mut sum = Complex32::new(0.0, 0.0);
        for &(a, pa) in &scratch.tx {
            let mut inner = Complex32::new(0.0, 0.0);
            for &(d, ph) in &scratch.rx {
                let p = table.at((a + d) * inv_bin);
                if p.re != 0.0 || p.im != 0.0 {
                    inner += p * ph;
                }
            }
            sum += inner * pa;
        }
        sum.norm_sqr() / (n as f32 * p0).powi(2).max(f32::MIN_POSITIVE)
    }

    /// An interval that holds [`Self::full_sum`]'s value, from the sum with the elements
    /// grouped by path difference and the pulse quadratic within each group (module docs);
    /// `None` where the groups would be too many or the pulse's peak is zero. `d_span` is the
    /// least and largest `d_e`, metres.
    fn relative_power_bounds(
        &self,
        table: &PulseTable,
        scratch: &mut Scratch,
        d_span: (f32, f32),
    ) -> Option<(f32, f32)> {
        let p0 = table.at(0.0).norm();
        if p0 <= 0.0 {
            return None;
        }
        let inv_bin = (1.0 / self.bin_m) as f64;
        let (lo, hi) = (d_span.0 as f64 * inv_bin, d_span.1 as f64 * inv_bin);
        let groups = (((hi - lo) / (2.0 * GROUP_HALF_BINS)).ceil() as usize).max(1);
        if groups > MAX_GROUPS || !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let width = (hi - lo) / groups as f64;
        let inv_width = 1.0 / width;
        let h = 0.5 * width;
        // Moments Σ δ^k·e^{jφ} of each group about its centre, and its element count.
        scratch.moments.clear();
        scratch
            .moments
            .resize(groups, ([Complex64::new(0.0, 0.0); 3], 0));
        let inv_lambda = 1.0 / self.wavelength_m as f64;
        for &(d, _) in &scratch.rx {
            let x = d as f64 * inv_bin;
            let g = if width > 0.0 {
                (((x - lo) * inv_width) as usize).min(groups - 1)
            } else {
                0
            };
            let delta = x - (lo + (g as f64 + 0.5) * width);
            let ph = table_phasor(&table.phasors, d as f64 * inv_lambda);
            let (m, count) = &mut scratch.moments[g];
            m[0] += ph;
            m[1] += ph * delta;
            m[2] += ph * (delta * delta);
            *count += 1;
        }
        let (nt, ne) = (self.tx.len(), self.rx.len());
        // The full sum's phasors take `d/λ` in `f32`: half an ulp of the largest number of
        // cycles, each of its two phasors a term (one ulp each, generously).
        let far = |s: &[(f32, Complex32)]| s.iter().fold(0f32, |m, &(d, _)| m.max(d.abs()));
        let cycles = (far(&scratch.tx) + far(&scratch.rx)) as f64 * inv_lambda;
        let phase_rounding = 2.0 * std::f64::consts::TAU * cycles * f32::EPSILON as f64;
        // Per term: the table's error through the interpolation (1 + Λ), the remainder, the
        // phasor tables' error (two phasors a term, and the full sum's `f32` `sin_cos`), and the
        // full sum's own `f32` rounding (its accumulations, products and argument roundings).
        let per_term = table.error * (1.0 + 5.0 / 3.0)
            + table.third_derivative * h.powi(3) / 24.0
            + phase_rounding
            + (ne + nt + 16) as f64 * 2.4e-7
            + 2e-5;
        let s = h * 3f64.sqrt() / 2.0;
        let reach = table.half_bins as f64 + 2.0 / PulseTable::STEPS as f64;
        let at = |x: f64| {
            let p = table.at(x as f32);
            Complex64::new(p.re as f64, p.im as f64)
        };
        // The quadratic through the nodes `−s, 0, s` (values `g0, g1, g2`) summed against the
        // moments is `g0·w0 + g1·w1 + g2·w2`, with the moments' weights formed once.
        for (m, _) in scratch.moments.iter_mut() {
            *m = if s > 0.0 {
                let (m1, m2) = (m[1] / (2.0 * s), m[2] / (2.0 * s * s));
                [m2 - m1, m[0] - m2 * 2.0, m1 + m2]
            } else {
                [Complex64::new(0.0, 0.0), m[0], Complex64::new(0.0, 0.0)]
            };
        }
        let mut sum = Complex64::new(0.0, 0.0);
        let mut error = 0.0f64;
        for &(a, _) in &scratch.tx {
            let xa = a as f64 * inv_bin;
            let mut inner = Complex64::new(0.0, 0.0);
            for (g, (w, count)) in scratch.moments.iter().enumerate() {
                let xc = xa + lo + (g as f64 + 0.5) * width;
                if *count == 0 || xc - h > reach || xc + h < -reach {
                    // The pulse is zero over the whole group: the full sum adds nothing here.
                    continue;
                }
                inner += at(xc - s) * w[0] + at(xc) * w[1] + at(xc + s) * w[2];
                error += *count as f64 * per_term;
            }
            sum += inner * table_phasor(&table.phasors, a as f64 * inv_lambda);
        }
        let den = ((self.tx.len() * self.rx.len()) as f32 * p0)
            .powi(2)
            .max(f32::MIN_POSITIVE) as f64;
        let mag = sum.norm();
        let lo = ((mag - error).max(0.0).powi(2) / den) * (1.0 - 1e-5);
        let hi = ((mag + error).powi(2) / den) * (1.0 + 1e-5);
        Some((lo as f32, hi as f32))
    }

    /// The pair's resolution axes at `u` with each one's main-lobe half-width, metres: the
    /// range axis comes first, its main lobe the window's; the apertures are untapered (first
    /// null at one cell).
    fn main_lobe_axes(&self, u: Vec3) -> [(Vec3, f32); 4] {
        let mut axes = pair_resolution_axes(
            u,
            self.array,
            self.aperture,
            self.wavelength_m,
            self.bandwidth_hz,
        );
        for (i, (_, delta)) in axes.iter_mut().enumerate() {
            let lobe = if i == 0 {
                self.range_main_lobe_cells
            } else {
                1.0
            };
            *delta = (lobe * *delta).max(1e-6);
        }
        axes
    }

    /// Whether `v` lies at least one resolution cell from `u` in the pair's resolution metric at
    /// `u` (module docs), past the main lobe of `u`'s point-spread function, given `u`'s
    /// [`Self::main_lobe_axes`].
    fn outside_lobe(axes: &[(Vec3, f32); 4], u: Vec3, v: Vec3) -> bool {
        let d = v - u;
        axes.iter()
            .map(|&(a, half)| (d.dot(a) / half).powi(2))
            .sum::<f32>()
            >= 1.0
    }
}

/// Which of `points` (intensities `intensity`, `|I|`) are sidelobes of a stronger detection among
/// `points` and `sources` (detections of the same image outside the region, intensities
/// `source_intensity` on the same scale): `true` marks a sidelobe (module docs). Deterministic:
/// each point's answer depends only on the inputs.
pub fn sidelobes(
    psf: &PairPsf<'_>,
    points: &[Vec3],
    intensity: &[f32],
    sources: &[Vec3],
    source_intensity: &[f32],
) -> Vec<bool> {
    if psf.tx.is_empty() || psf.rx.is_empty() {
        return vec![false; points.len()];
    }
    let table = PulseTable::new(psf.pulse);
    let (tc, ec, spread) = psf.centres();
    let reach_m = table.half_bins * psf.bin_m + spread;
    // Every echo, strongest first.
    let mut all: Vec<(Vec3, f32, bool)> = points
        .iter()
        .zip(intensity)
        .map(|(&p, &a)| (p, a, false))
        .chain(
            sources
                .iter()
                .zip(source_intensity)
                .map(|(&p, &a)| (p, a, true)),
        )
        .filter(|(p, a, _)| p.is_finite() && a.is_finite())
        .collect();
    all.sort_by(|a, b| b.1.total_cmp(&a.1));
    let range_c = |p: Vec3| p.distance(tc) + p.distance(ec);
    let shells: Vec<f32> = all.iter().map(|&(p, _, _)| range_c(p)).collect();
    // Each echo's distances to the sensors, formed once rather than for every pair of echoes,
    // where they fit in `DISTANCE_TABLE_MAX` entries.
    let m = psf.tx.len() + psf.rx.len();
    let table_dist: Vec<f32> = if all.len().saturating_mul(m) <= DISTANCE_TABLE_MAX {
        let mut t = vec![0f32; all.len() * m];
        t.par_chunks_mut(m).zip(all.par_iter()).for_each_init(
            Vec::new,
            |row, (out, &(p, _, _))| {
                psf.distances(p, row);
                out.copy_from_slice(row);
            },
        );
        t
    } else {
        Vec::new()
    };
    let lobes: Vec<[(Vec3, f32); 4]> = all
        .par_iter()
        .map(|&(u, _, _)| psf.main_lobe_axes(u))
        .collect();
    let ap = psf.apertures();
    let sights: Vec<Sight> = all.iter().map(|&(u, _, _)| Sight::of(u, &ap)).collect();
    points
        .par_iter()
        .zip(intensity.par_iter())
        .map_init(Scratch::default, |scratch, (&v, &a)| {
            if !(v.is_finite() && a.is_finite()) {
                return false;
            }
            let rv = range_c(v);
            let a2 = a * a;
            let sv = Sight::of(v, &ap);
            let (mut ud, mut vd) = (
                std::mem::take(&mut scratch.u_dist),
                std::mem::take(&mut scratch.v_dist),
            );
            psf.distances(v, &mut vd);
            let explained = all
                .iter()
                .zip(&shells)
                .enumerate()
                .take_while(|(_, ((_, b, _), _))| *b > a)
                .any(|(i, (&(u, b, outside), &ru))| {
                    (rv - ru).abs() <= reach_m
                        && (outside || PairPsf::outside_lobe(&lobes[i], u, v))
                        && !psf.beyond_reach(&table, &ap, &sights[i], b * b, &sv, a2)
                        && {
                            let u_dist = if table_dist.is_empty() {
                                psf.distances(u, &mut ud);
                                &ud[..]
                            } else {
                                &table_dist[i * m..(i + 1) * m]
                            };
                            psf.explains_from(&table, u_dist, b * b, &vd, a2, scratch)
                        }
                });
            (scratch.u_dist, scratch.v_dist) = (ud, vd);
            explained
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::echo::EchoConfig;

    const LAMBDA: f32 = 0.029_979_246;

    /// The quick preset's pulse: 400 MHz, 1024 subcarriers, Hann, zero padding 2.
    fn hann_pulse() -> (PulseKernel, f32) {
        let cfg = EchoConfig::new(10e9, 400e6, 1024, 2)
            .with_window(has_dsp::window::Window::Hann)
            .unwrap();
        (
            PulseKernel::new(&cfg).unwrap(),
            has_dsp::ofdm::bin_spacing_m(400e6, 2) as f32,
        )
    }

    /// A 16 × 16 λ/2 panel at (60, 0, z0) facing −x, and a transmitter on the plane z = z0.
    fn geometry(z0: f32) -> (PlanarArray, VirtualAperture) {
        let array = PlanarArray {
            centre: Vec3::new(60.0, 0.0, z0),
            boresight_az_rad: std::f32::consts::PI,
            rows: 16,
            cols: 16,
            width_m: 8.0 * LAMBDA,
            height_m: 8.0 * LAMBDA,
        };
        let t = Vec3::new(0.0, -20.0, z0);
        let aperture = VirtualAperture {
            start: t,
            end: t + Vec3::new(0.01, 0.0, 0.0),
            positions: 1,
        };
        (array, aperture)
    }

    /// The panel of [`geometry`] with every element and one transmit position, Hann pulse.
    struct Pair {
        pulse: PulseKernel,
        bin_m: f32,
        array: PlanarArray,
        aperture: VirtualAperture,
        rx: Vec<Vec3>,
        tx: [Vec3; 1],
    }

    impl Pair {
        fn new() -> Pair {
            let (pulse, bin_m) = hann_pulse();
            let (array, aperture) = geometry(10.0);
            Pair {
                pulse,
                bin_m,
                rx: array.elements(1),
                tx: [aperture.start],
                array,
                aperture,
            }
        }

        fn psf(&self) -> PairPsf<'_> {
            PairPsf {
                tx: &self.tx,
                rx: &self.rx,
                pulse: &self.pulse,
                bin_m: self.bin_m,
                wavelength_m: LAMBDA,
                array: &self.array,
                aperture: &self.aperture,
                bandwidth_hz: 400e6,
                range_main_lobe_cells: 2.0,
            }
        }
    }

    /// The range bound decides as the full sum does: over random pairs of places around the
    /// panel's view and powers from −60 to 0 dB, `explains` agrees with `a² ≤ b²·ρ_u(v)`, and the
    /// bound prunes some of them.
    #[test]
    fn the_range_bound_never_changes_a_decision() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let pair = Pair::new();
        let psf = pair.psf();
        let table = PulseTable::new(psf.pulse);
        let mut scratch = Scratch::default();
        let mut pruned = 0;
        for _ in 0..4000 {
            let mut at = || {
                Vec3::new(
                    rng.random_range(-15.0..15.0),
                    rng.random_range(-15.0..15.0),
                    rng.random_range(0.0..20.0),
                )
            };
            let (u, v) = (at(), at());
            let (b2, a2) = (1.0, 10f32.powf(rng.random_range(-6.0..0.0)));
            let rho = psf.relative_power_with(&table, u, v, &mut scratch);
            assert_eq!(
                psf.explains(&table, u, b2, v, a2, &mut scratch),
                a2 <= b2 * rho,
                "u {u} v {v} a² {a2} ρ {rho}"
            );
            let d = |s: &[Vec3]| {
                s.iter()
                    .map(|&t| v.distance(t) - u.distance(t))
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), x| {
                        (l.min(x), h.max(x))
                    })
            };
            let ((al, ah), (dl, dh)) = (d(psf.tx), d(psf.rx));
            let (lo, hi) = ((al + dl) / psf.bin_m, (ah + dh) / psf.bin_m);
            let r = if lo > 0.0 {
                lo
            } else if hi < 0.0 {
                -hi
            } else {
                0.0
            };
            let p0 = table.at(0.0).norm();
            if r > 0.0 && a2 > (table.bound_beyond(r) / p0).powi(2) {
                pruned += 1;
                assert!(rho <= (table.bound_beyond(r) / p0).powi(2) * 1.0001);
            }
        }
        assert!(pruned > 100, "pruned {pruned}");
    }

    /// The grouped sum's interval holds the full sum's value for pairs of places on nearly one
    /// range shell of a pair with a track of transmit positions (where the range bound decides
    /// nothing), tightly enough to decide without the full sum away from the threshold.
    #[test]
    fn the_grouped_bound_holds_the_full_sum() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let pair = Pair::new();
        let track: Vec<Vec3> = (0..24)
            .map(|i| pair.aperture.start + Vec3::new(0.125 * i as f32, 0.0, 0.0))
            .collect();
        let psf = PairPsf {
            tx: &track,
            ..pair.psf()
        };
        let table = PulseTable::new(psf.pulse);
        let mut scratch = Scratch::default();
        let (mut tried, mut rejected) = (0, 0);
        for _ in 0..1500 {
            let u = Vec3::new(
                rng.random_range(-15.0..15.0),
                rng.random_range(-15.0..15.0),
                rng.random_range(0.0..20.0),
            );
            // v on u's shell about the centres, within a few bins.
            let dir = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize_or_zero();
            let v = u + dir * rng.random_range(0.5..12.0);
            let rho = psf.relative_power_with(&table, u, v, &mut scratch);
            let (dl, dh) = scratch
                .rx
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &(d, _)| {
                    (l.min(d), h.max(d))
                });
            let Some((lo, hi)) = psf.relative_power_bounds(&table, &mut scratch, (dl, dh)) else {
                continue;
            };
            tried += 1;
            assert!(
                lo <= rho && rho <= hi,
                "u {u} v {v}: ρ {rho} outside [{lo}, {hi}]"
            );
            // Powers ten times off ρ either way are decided by the interval.
            // A sidelobe of −30 dB or more is placed within ±10 % in power, and an echo within
            // 40 dB of the stronger one is decided against a ρ far below it.
            if rho >= 1e-3 {
                assert!(lo >= 0.9 * rho && hi <= 1.1 * rho, "ρ {rho}: [{lo}, {hi}]");
            } else if rho < 1e-6 {
                assert!(hi < 1e-4, "ρ {rho}: [{lo}, {hi}]");
            }
            for a2 in [0.1 * rho, 0.5 * rho, rho, 2.0 * rho, 10.0 * rho] {
                assert_eq!(psf.explains(&table, u, 1.0, v, a2, &mut scratch), a2 <= rho);
            }
            // The range bound from the centres rejects only what the full sum rejects.
            let ap = psf.apertures();
            let (su, sv) = (Sight::of(u, &ap), Sight::of(v, &ap));
            for a2 in [1e-6, 1e-4, 1e-2, 1.0] {
                if psf.beyond_reach(&table, &ap, &su, 1.0, &sv, a2) {
                    assert!(a2 > rho, "u {u} v {v}: a² {a2} ρ {rho}");
                    rejected += 1;
                }
            }
        }
        assert!(tried > 1000, "tried {tried}");
        assert!(rejected > 100, "rejected {rejected}");
    }

    #[test]
    fn the_point_spread_function_is_the_panels_array_factor_across_its_beam() {
        // u and v 1 m apart vertically, straddling the panel's and the transmitter's height: the
        // transmit leg and the panel's centre see both at one range, and across the panel's rows
        // the path differs by (z_e − z0)·Δz/R — the elevation array factor of 16 rows at λ/2,
        // |sin(Nψ/2)/(N sin(ψ/2))|², ψ = 2π·(λ/2)·Δz/(λR) (far field, 60 m ≫ 2D²/λ = 0.12 m).
        let (u, v) = (Vec3::new(0.0, 0.0, 9.5), Vec3::new(0.0, 0.0, 10.5));
        let pair = Pair::new();
        let psf = pair.psf();
        let array = &pair.array;
        assert!((psf.relative_power(u, u) - 1.0).abs() < 1e-4);
        let r = u.distance(array.centre);
        for dz in [0.3f32, 1.0, 2.2, 4.0] {
            let (u, v) = (
                Vec3::new(0.0, 0.0, 10.0 - dz / 2.0),
                Vec3::new(0.0, 0.0, 10.0 + dz / 2.0),
            );
            let psi = std::f32::consts::PI * dz / r;
            let n = 16.0;
            let af = ((n * psi / 2.0).sin() / (n * (psi / 2.0).sin())).powi(2);
            let got = psf.relative_power(u, v);
            assert!(
                (got - af).abs() < 0.02 * af.max(0.05),
                "Δz {dz} m: ρ {got}, array factor {af}"
            );
        }
        // Off the range shell by more than the pulse reaches (32 bins of 0.375 m): nothing.
        assert_eq!(psf.relative_power(u, v + Vec3::new(-30.0, 0.0, 0.0)), 0.0);
    }

    #[test]
    fn a_detection_no_stronger_than_a_stronger_echos_sidelobe_is_one_and_a_main_lobe_neighbour_is_not(
    ) {
        let pair = Pair::new();
        let psf = pair.psf();
        // The panel's vertical cross-range at 60 m: λR/H = 60·2/16 = 7.5 m; its first sidelobe
        // peaks near 1.43 cells, 10.7 m from the echo, at ρ ≈ 0.047 — on the echo's range shell
        // (both straddle the heights of the panel and the transmitter).
        let u = Vec3::new(0.0, 0.0, 10.0 - 5.35);
        let lobe = Vec3::new(0.0, 0.0, 10.0 + 5.35);
        let near = u + Vec3::new(0.0, 0.0, 3.0);
        let rho = psf.relative_power(u, lobe);
        assert!(rho > 0.02 && rho < 0.08, "first sidelobe ρ {rho}");
        let weak = 0.9 * rho.sqrt();
        let strong = 1.5 * rho.sqrt();
        let points = [u, lobe, near];
        let flags = sidelobes(&psf, &points, &[1.0, weak, 0.01], &[], &[]);
        assert_eq!(flags, [false, true, false]);
        let flags = sidelobes(&psf, &points, &[1.0, strong, 0.01], &[], &[]);
        assert_eq!(flags, [false, false, false]);
        // A source outside the region explains a detection inside it, in its main lobe too.
        let flags = sidelobes(&psf, &[lobe], &[weak], &[u], &[1.0]);
        assert_eq!(flags, [true]);
        let rho_near = psf.relative_power(u, near);
        assert!(rho_near > 0.1, "{rho_near}");
        let flags = sidelobes(&psf, &[near], &[0.9 * rho_near.sqrt()], &[u], &[1.0]);
        assert_eq!(flags, [true]);
        let flags = sidelobes(&psf, &[near], &[1.1 * rho_near.sqrt()], &[u], &[1.0]);
        assert_eq!(flags, [false]);
    }
}
