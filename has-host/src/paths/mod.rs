//! Propagation paths between a transmitter and a receiver for channel prediction: line of sight
//! and specular reflections up to a configurable order, with exact (image-method) geometry.
//!
//! # Method
//! 1. **Facets.** The scene's triangles are grouped into planar facets ([`Facets::build`]): region
//!    growing over shared edges within one object, a triangle joining when its normal is within
//!    `facet_angle_tol_rad` of the region's normal and its vertices within `facet_dist_tol_m` of
//!    the region's plane (the region's plane: its mean triangle normal while small, its
//!    least-squares plane, refitted as it doubles, from 16 triangles on). A box wall becomes one facet; a noisy wall of a
//!    reconstructed (Poisson) mesh becomes one facet whose plane is the least-squares fit of its
//!    triangles (area-weighted second moment, smallest principal axis), with a
//!    `thickness` (largest vertex distance from that plane) used as the tolerance of its checks.
//!    A near-vertical facet whose plane is out of plumb by less than
//!    [`TracerConfig::vertical_tol_m`] over its height is made vertical (a twin's unresolved tilt).
//! 2. **Candidates, once per transmitter** ([`Tracer::prepare_tx`]). Shoot-and-bounce rays
//!    (`sbr_rays` directions on a Fibonacci sphere, specular bounces off the facet planes up to
//!    `max_order`) record every facet sequence they meet; each sequence gets its chain of
//!    transmitter images. The result is reused for every receiver: with one BS and 500 UEs the
//!    launching is paid once. [`CandidateMode::Exhaustive`] enumerates every sequence instead
//!    (small scenes and reference tests).
//! 3. **Per receiver** ([`Tracer::trace`]): the image method back-traces each candidate from the
//!    receiver (plane crossings in f64, facet bounding box first), then validates the path with
//!    the BVH: the ray from the receiver (or the previous reflection point) towards each
//!    reflection point must first hit a triangle of that facet (this is both the "inside the facet
//!    polygon" and the visibility test; a miss through a crack between two triangles falls back to
//!    an exact point-in-facet test), and the last leg to the transmitter must be unobstructed.
//!    Paths are sorted by delay and exact duplicates dropped.
//!
//! Diffraction is **not** modelled (no edge diffraction paths); [`Interaction::Diffraction`] is
//! reserved for it.
//!
//! # Conventions (Sionna RT's)
//! * Angles in radians: zenith θ from +z, azimuth φ from +x toward +y. AoD/ZoD are the angles of
//!   the departure direction at the transmitter; AoA/ZoA those of the direction from the receiver
//!   toward where the wave comes from (the last interaction point, or the transmitter).
//! * Delay `τ = L / c` with `L` the unfolded path length (receiver to last image).
//! * Polarisation: the field is carried as a 3-vector through every bounce (s/p decomposition per
//!   bounce, Fresnel `R⊥`/`R∥` of [`crate::propagation::fresnel_reflection`], `p = s × k` for both
//!   the incident and the reflected wave, `s ∝ k_in × n`). [`Path::jones`] maps the transmitted
//!   field components on `(θ̂, φ̂)` of the departure direction to the received components on
//!   `(θ̂, φ̂)` of the *propagation* direction at the receiver, so line of sight is the identity and
//!   a single ground bounce gives `diag(R∥, R⊥)` (V = θ̂ ≈ vertical, H = φ̂ horizontal).
//! * [`Path::a`] is the co-polarised entry chosen by [`TracerConfig::polarization`] (vertical by
//!   default: `a = J[0][0]`). Both include the free-space factor `λ / (4π L)` (isotropic antennas)
//!   and the carrier phase `e^{−j2π fc τ}`, as Sionna's path coefficients do; the channel at a
//!   baseband offset `f` is then `Σ a·e^{−j2π f τ}` ([`crate::channel`]). Material parameters and
//!   `λ` are taken at the carrier (narrowband).
//!
//! [`report`] holds the paths as typed reports (`has-sim paths --json`) and the parsers of the
//! points and receivers files that name the ends.

//!
//! Submodules, one step each: [`facets`], [`candidates`], [`trace`] (the [`Tracer`]).

pub mod arrays;
pub mod candidates;
pub mod facets;
pub mod report;
pub mod trace;

use glam::DVec3;
use num_complex::Complex64;

pub use candidates::TxCandidates;
pub use facets::{Facet, Facets};
pub use trace::Tracer;

/// Largest supported reflection order.
pub const MAX_ORDER: usize = 8;

/// Most shoot-and-bounce rays per transmitter, 2³⁰ ≈ 1.1·10⁹: a bound on the work of
/// [`Tracer::prepare_tx`] (one BVH cast per ray and bounce; ≈ 8·10⁶ rays/s at order 3 on the
/// factory fixture on two cores, so about two minutes). Beyond it a run is refused, not left to
/// run for hours.
pub const MAX_SBR_RAYS: usize = 1 << 30;

pub use crate::scene::MAX_COORD_M;

/// Which antenna polarisation [`Path::a`] uses (same at both ends).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Polarization {
    /// Field along θ̂ (vertical for horizontal paths): `a = J[0][0]`.
    Vertical,
    /// Field along φ̂ (horizontal): `a = J[1][1]`.
    Horizontal,
}

/// How candidate facet sequences are found for a transmitter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CandidateMode {
    /// Shoot-and-bounce from the transmitter with this many ray directions.
    Sbr {
        /// Number of launched rays (Fibonacci sphere).
        rays: usize,
    },
    /// Every facet sequence without immediate repeats (`F·(F−1)^(k−1)` of order `k`): complete but
    /// only for scenes with few facets.
    Exhaustive,
}

/// Tracer settings.
#[derive(Clone, Debug, PartialEq)]
pub struct TracerConfig {
    /// Carrier frequency, Hz.
    pub frequency_hz: f64,
    /// Highest number of reflections per path (0 = line of sight only), at most [`MAX_ORDER`].
    pub max_order: usize,
    /// Include the line-of-sight path when unobstructed and the ends are at least a wavelength
    /// apart (far field; coincident ends, a monostatic radar, have echoes only).
    pub los: bool,
    /// Polarisation of [`Path::a`].
    pub polarization: Polarization,
    /// How candidate facet sequences are found.
    pub candidates: CandidateMode,
    /// Facet clustering: largest angle (rad) between a triangle's normal and its facet's normal.
    pub facet_angle_tol_rad: f64,
    /// Facet clustering: largest distance (m) of a triangle vertex from its facet's plane.
    pub facet_dist_tol_m: f64,
    /// A facet within 30° of vertical whose plane moves its top by less than this (m) from
    /// plumb over its height is made vertical (its normal's z component dropped, the plane
    /// refitted through its centroid). For a reconstructed twin this is the resolution the
    /// imaging had across the wall: a tilt below it was never observed (a Poisson mesh rounds a
    /// wall into its roof and its least-squares plane leans by a fraction of a degree, which
    /// doubles in a reflected path's elevation). 0 (default): off.
    pub vertical_tol_m: f64,
}

impl Default for TracerConfig {
    /// 10 GHz, order 3, line of sight on, vertical polarisation, 200 000 SBR rays, facets within
    /// 15° and 0.15 m: exact box walls are unaffected, and walls of a mesh made of 2 m
    /// triangles with vertex noise still cluster into a few facets each (measured on the
    /// city-block fixture, 78 UEs: 372 paths exact, 372 with ±5 cm noise per axis, 369 with
    /// ±10 cm). Curved objects faceted finer than 15°
    /// (cylinders with more than 24 segments) are merged into coarser facets.
    fn default() -> Self {
        TracerConfig {
            frequency_hz: 10e9,
            max_order: 3,
            los: true,
            polarization: Polarization::Vertical,
            candidates: CandidateMode::Sbr { rays: 200_000 },
            facet_angle_tol_rad: 15f64.to_radians(),
            facet_dist_tol_m: 0.15,
            vertical_tol_m: 0.0,
        }
    }
}

/// Why paths could not be computed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PathError {
    /// A position was NaN or infinite.
    #[error("{what}: position ({}, {}, {}) is not finite", value.x, value.y, value.z)]
    NonFinitePosition {
        /// `"tx"` or `"rx"`.
        what: &'static str,
        /// The position.
        value: DVec3,
    },
    /// A position lies farther from the origin than [`MAX_COORD_M`] on some axis.
    #[error(
        "{what}: position ({}, {}, {}) is beyond ±{MAX_COORD_M:e} m (the scene's f32 ray tests \
         resolve no better than 6 cm there)",
        value.x, value.y, value.z
    )]
    FarPosition {
        /// `"tx"` or `"rx"`.
        what: &'static str,
        /// The position.
        value: DVec3,
    },
    /// A configuration value is out of range.
    #[error("{what}: {value} is out of range ({expected})")]
    OutOfRange {
        /// Field name.
        what: &'static str,
        /// The value.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// The frequency lies outside the range over which ITU-R P.2040 states the fit of a
    /// scene material (as Sionna RT, which refuses it too).
    #[error(
        "frequency_hz: {freq_ghz} GHz is outside {lo_ghz}–{hi_ghz} GHz, where ITU-R P.2040 \
         states the fit of material {material} (object {object})"
    )]
    MaterialFrequency {
        /// The frequency, GHz.
        freq_ghz: f64,
        /// The material's name.
        material: &'static str,
        /// The first object made of it.
        object: String,
        /// The stated range, GHz.
        lo_ghz: f64,
        /// The stated range, GHz.
        hi_ghz: f64,
    },
    /// The candidate search would need more memory than the machine has.
    #[error(
        "{what}: {count:.3e} facet sequences need {need_gib:.1} GiB, {have_gib:.1} GiB \
         available (use shoot-and-bounce rays, or a lower max_order)"
    )]
    TooLarge {
        /// What would be enumerated (`"exhaustive candidates"`).
        what: &'static str,
        /// How many sequences.
        count: f64,
        /// Estimated memory, GiB.
        need_gib: f64,
        /// Available memory, GiB.
        have_gib: f64,
    },
}

/// One interaction along a path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Interaction {
    /// Direct path (the only entry of a line-of-sight path).
    Los,
    /// Specular reflection.
    Reflection {
        /// Index into [`crate::Scene::objects`].
        object: u32,
        /// Index into [`Facets::facets`].
        facet: u32,
        /// Reflection point, metres.
        point: DVec3,
    },
    /// Edge diffraction (not produced yet: reserved).
    Diffraction {
        /// Index into [`crate::Scene::objects`].
        object: u32,
        /// Diffraction point on the edge, metres.
        point: DVec3,
    },
}

impl Interaction {
    /// `"los"`, `"reflection"` or `"diffraction"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Interaction::Los => "los",
            Interaction::Reflection { .. } => "reflection",
            Interaction::Diffraction { .. } => "diffraction",
        }
    }
}

/// One propagation path.
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    /// Delay τ, seconds.
    pub delay_s: f64,
    /// Unfolded length, metres (`c·τ`).
    pub length_m: f64,
    /// Complex amplitude for the configured polarisation (see module docs).
    pub a: Complex64,
    /// Full polarimetric amplitude: `jones[rx][tx]`, index 0 = θ̂, 1 = φ̂ (see module docs).
    pub jones: [[Complex64; 2]; 2],
    /// Azimuth of departure, rad.
    pub aod: f64,
    /// Zenith of departure, rad.
    pub zod: f64,
    /// Azimuth of arrival, rad.
    pub aoa: f64,
    /// Zenith of arrival, rad.
    pub zoa: f64,
    /// `[Los]` for the direct path, otherwise the interactions from transmitter to receiver.
    pub interactions: Vec<Interaction>,
}

impl Path {
    /// Path gain `20·log10 |a|`, dB (negative: a loss).
    pub fn gain_db(&self) -> f64 {
        20.0 * self.a.norm().log10()
    }

    /// Number of reflections and diffractions (0 for line of sight).
    pub fn order(&self) -> usize {
        self.interactions
            .iter()
            .filter(|i| !matches!(i, Interaction::Los))
            .count()
    }

    /// The path in report units ([`PathRecord`]); `objects` names the scene's objects.
    pub fn record<'a>(&self, objects: &'a [String]) -> PathRecord<'a> {
        let (names, points) = self
            .interactions
            .iter()
            .map(|i| match i {
                Interaction::Reflection { object, point, .. }
                | Interaction::Diffraction { object, point } => (
                    objects.get(*object as usize).map(String::as_str),
                    Some(point.to_array()),
                ),
                Interaction::Los => (None, None),
            })
            .unzip();
        let c = |z: Complex64| [z.re, z.im];
        PathRecord {
            delay_ns: self.delay_s * 1e9,
            gain_db: self.gain_db(),
            phase_rad: self.a.arg(),
            a: c(self.a),
            jones: self.jones.map(|row| row.map(c)),
            aod_deg: self.aod.to_degrees(),
            zod_deg: self.zod.to_degrees(),
            aoa_deg: self.aoa.to_degrees(),
            zoa_deg: self.zoa.to_degrees(),
            interactions: self.interactions.iter().map(Interaction::kind).collect(),
            objects: names,
            points,
        }
    }
}

/// A [`Path`] in report units ([`Path::record`]), serialized with its fields in this order
/// (`has-sim paths --json`); serde_json writes a non-finite number (the gain of a zero
/// amplitude) as `null`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PathRecord<'a> {
    /// Delay, ns.
    pub delay_ns: f64,
    /// Gain ([`Path::gain_db`]), dB.
    pub gain_db: f64,
    /// Phase of the amplitude, rad in (−π, π].
    pub phase_rad: f64,
    /// The amplitude [`Path::a`] as `[re, im]` (Sionna RT's `cir(normalize_delays=False)` `a`).
    pub a: [f64; 2],
    /// The full polarimetric amplitude [`Path::jones`], `jones[rx][tx] = [re, im]`, index 0 = θ̂,
    /// 1 = φ̂.
    pub jones: [[[f64; 2]; 2]; 2],
    /// Azimuth of departure, degrees.
    pub aod_deg: f64,
    /// Zenith of departure, degrees.
    pub zod_deg: f64,
    /// Azimuth of arrival, degrees.
    pub aoa_deg: f64,
    /// Zenith of arrival, degrees.
    pub zoa_deg: f64,
    /// Per interaction, its kind ([`Interaction::kind`]).
    pub interactions: Vec<&'static str>,
    /// Per interaction, the name of the object it meets (`None` for line of sight or an index
    /// past `objects`).
    pub objects: Vec<Option<&'a str>>,
    /// Per interaction, its point `[x, y, z]` in metres (`None` for line of sight).
    pub points: Vec<Option<[f64; 3]>>,
}

/// A line-of-sight path for tests of the path records: τ = 100 ns, |a| = 1e-3 (−60 dB) at phase
/// π/2; AoD 0.5, ZoD 1, AoA −0.5, ZoA 2 rad.
#[cfg(test)]
pub(crate) fn example_los_path() -> Path {
    Path {
        delay_s: 1e-7,
        length_m: 29.979_245_8,
        a: Complex64::new(0.0, 1e-3),
        jones: [[Complex64::new(0.0, 0.0); 2]; 2],
        aod: 0.5,
        zod: 1.0,
        aoa: -0.5,
        zoa: 2.0,
        interactions: vec![Interaction::Los],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_record_is_in_report_units_and_names_what_each_reflection_meets() {
        let los = example_los_path();
        let names = ["ground".to_string(), "wall".to_string()];
        let r = los.record(&names);
        assert!((r.delay_ns - 100.0).abs() < 1e-9 && (r.gain_db + 60.0).abs() < 1e-9);
        assert!((r.phase_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(r.aod_deg, 0.5f64.to_degrees());
        assert_eq!(r.zoa_deg, 2f64.to_degrees());
        assert_eq!(
            (r.interactions, r.objects, r.points),
            (vec!["los"], vec![None], vec![None])
        );
        let wall = Path {
            interactions: vec![
                Interaction::Reflection {
                    object: 1,
                    facet: 0,
                    point: DVec3::new(1.0, -2.5, 3.0),
                },
                Interaction::Reflection {
                    object: 7,
                    facet: 0,
                    point: DVec3::ZERO,
                },
            ],
            ..los
        };
        let r = wall.record(&names);
        assert_eq!(r.interactions, ["reflection", "reflection"]);
        assert_eq!(r.objects, [Some("wall"), None]);
        assert_eq!(r.points, [Some([1.0, -2.5, 3.0]), Some([0.0; 3])]);
    }
}
