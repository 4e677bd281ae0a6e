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

pub mod report;

use std::collections::{HashMap, HashSet, VecDeque};

use glam::{DMat3, DVec3, Vec3};
use num_complex::Complex64;
use rayon::prelude::*;

use crate::linalg::smallest_eigenvector;
use crate::propagation::{free_space_amplitude, fresnel_reflection};
use crate::scene::{Scene, SURFACE_EPS_M};
use crate::C_M_PER_S;

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
        /// Index into [`Scene::objects`].
        object: u32,
        /// Index into [`Facets::facets`].
        facet: u32,
        /// Reflection point, metres.
        point: DVec3,
    },
    /// Edge diffraction (not produced yet: reserved).
    Diffraction {
        /// Index into [`Scene::objects`].
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
        PathRecord {
            delay_ns: self.delay_s * 1e9,
            gain_db: self.gain_db(),
            phase_rad: self.a.arg(),
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

/// A planar facet: coplanar (within tolerance) adjacent triangles of one object.
#[derive(Clone, Debug)]
pub struct Facet {
    /// Owning object.
    pub object: u32,
    /// Unit normal of the fitted plane.
    pub normal: DVec3,
    /// Plane offset: points `x` of the plane satisfy `normal·x = offset`.
    pub offset: f64,
    /// Largest distance of a vertex of the facet from the plane, metres (0 for exact planes).
    pub thickness: f64,
    /// Bounding box of the facet's vertices.
    pub lo: DVec3,
    /// Bounding box of the facet's vertices.
    pub hi: DVec3,
    /// Triangles (indices into [`Scene::triangles`]).
    pub triangles: Vec<u32>,
}

/// The facets of a scene.
#[derive(Clone, Debug)]
pub struct Facets {
    /// All facets.
    pub facets: Vec<Facet>,
    /// Facet of each triangle of the scene.
    pub tri_facet: Vec<u32>,
}

/// Vertex position quantised to 0.1 mm (edge matching between triangles).
type VertexKey = (i64, i64, i64);

fn tri_vertices(scene: &Scene, t: u32) -> [DVec3; 3] {
    let tri = &scene.triangles[t as usize];
    [
        Vec3::from(tri.v0).as_dvec3(),
        Vec3::from(tri.v1).as_dvec3(),
        Vec3::from(tri.v2).as_dvec3(),
    ]
}

impl Facets {
    /// Groups the scene's triangles into planar facets (see module docs); facets within
    /// `vertical_tol_m` of plumb are made vertical ([`TracerConfig::vertical_tol_m`]).
    pub fn build(
        scene: &Scene,
        angle_tol_rad: f64,
        dist_tol_m: f64,
        vertical_tol_m: f64,
    ) -> Facets {
        let n_tri = scene.triangles.len();
        let verts: Vec<[DVec3; 3]> = (0..n_tri as u32).map(|t| tri_vertices(scene, t)).collect();
        let mut normals = Vec::with_capacity(n_tri);
        let mut areas = Vec::with_capacity(n_tri);
        for v in &verts {
            let c = (v[1] - v[0]).cross(v[2] - v[0]);
            let len = c.length();
            areas.push(0.5 * len);
            normals.push(if len > 0.0 { c / len } else { DVec3::Z });
        }
        // Edge adjacency over quantised vertex positions (0.1 mm grid).
        let key = |p: DVec3| {
            let q = (p * 1e4).round();
            (q.x as i64, q.y as i64, q.z as i64)
        };
        let mut edges: HashMap<(VertexKey, VertexKey), Vec<u32>> = HashMap::new();
        for (t, v) in verts.iter().enumerate() {
            for e in 0..3 {
                let (a, b) = (key(v[e]), key(v[(e + 1) % 3]));
                let k = if a < b { (a, b) } else { (b, a) };
                edges.entry(k).or_default().push(t as u32);
            }
        }
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n_tri];
        for tris in edges.values() {
            for (i, &a) in tris.iter().enumerate() {
                for &b in &tris[i + 1..] {
                    if scene.tri_object[a as usize] == scene.tri_object[b as usize] {
                        adj[a as usize].push(b);
                        adj[b as usize].push(a);
                    }
                }
            }
        }
        // The edge map iterates in a random order: sort the neighbour lists so that the region
        // growing below (and hence the facets of a noisy mesh) is deterministic.
        for a in &mut adj {
            a.sort_unstable();
            a.dedup();
        }
        let cos_tol = angle_tol_rad.cos();
        let mut order: Vec<u32> = (0..n_tri as u32).collect();
        order.sort_by(|&a, &b| areas[b as usize].total_cmp(&areas[a as usize]));
        let mut tri_facet = vec![u32::MAX; n_tri];
        let mut facets = Vec::new();
        let mut queue = VecDeque::new();
        for &seed in &order {
            if tri_facet[seed as usize] != u32::MAX {
                continue;
            }
            let fid = facets.len() as u32;
            let mut nsum = normals[seed as usize] * areas[seed as usize];
            let mut csum =
                (verts[seed as usize][0] + verts[seed as usize][1] + verts[seed as usize][2]) / 3.0
                    * areas[seed as usize];
            let mut asum = areas[seed as usize];
            let mut members = vec![seed];
            tri_facet[seed as usize] = fid;
            queue.clear();
            queue.push_back(seed);
            // The growing region's plane: the mean normal at first, then the least-squares
            // plane, refitted each time the region doubles (O(n log n) in all).
            let mut fitted: Option<DVec3> = None;
            let mut next_refit = 16usize;
            while let Some(t) = queue.pop_front() {
                for &u in &adj[t as usize] {
                    if tri_facet[u as usize] != u32::MAX {
                        continue;
                    }
                    let n = fitted.unwrap_or_else(|| nsum.normalize());
                    let c = csum / asum;
                    let nu = normals[u as usize];
                    let dot = nu.dot(n);
                    if dot.abs() < cos_tol {
                        continue;
                    }
                    if verts[u as usize]
                        .iter()
                        .any(|v| (v - c).dot(n).abs() > dist_tol_m)
                    {
                        continue;
                    }
                    let a = areas[u as usize];
                    nsum += nu * dot.signum() * a;
                    csum += (verts[u as usize][0] + verts[u as usize][1] + verts[u as usize][2])
                        / 3.0
                        * a;
                    asum += a;
                    tri_facet[u as usize] = fid;
                    members.push(u);
                    queue.push_back(u);
                    if members.len() >= next_refit {
                        next_refit *= 2;
                        fitted = Some(fitted_normal(
                            &members,
                            &verts,
                            &areas,
                            csum / asum,
                            nsum.normalize(),
                        ));
                    }
                }
            }
            let centroid = csum / asum;
            let mut normal = fitted_normal(&members, &verts, &areas, centroid, nsum.normalize());
            let mut lo = DVec3::splat(f64::INFINITY);
            let mut hi = DVec3::splat(f64::NEG_INFINITY);
            for &m in &members {
                for v in verts[m as usize] {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            // Out of plumb over the facet's height: h·tan(tilt), tilt = asin|n_z|.
            let nz = normal.z.abs();
            let horizontal = (1.0 - nz * nz).max(0.0).sqrt();
            if vertical_tol_m > 0.0 && nz < 0.5 && (hi.z - lo.z) * nz < vertical_tol_m * horizontal
            {
                normal = DVec3::new(normal.x, normal.y, 0.0).normalize();
            }
            let offset = normal.dot(centroid);
            let mut thickness: f64 = 0.0;
            for &m in &members {
                for v in verts[m as usize] {
                    thickness = thickness.max((normal.dot(v) - offset).abs());
                }
            }
            facets.push(Facet {
                object: scene.tri_object[seed as usize],
                normal,
                offset,
                thickness,
                lo,
                hi,
                triangles: members,
            });
        }
        Facets { facets, tri_facet }
    }
}

/// Normal of the least-squares plane through the triangles `members` (area-weighted second
/// moment about `centroid`, exact for uniform density over each triangle: `A/12·(Σ vvᵀ + ssᵀ)`
/// with `s` the sum of the three vertices): the eigenvector of its smallest eigenvalue, oriented
/// like `mean_normal`. On an exact plane this is the plane's normal; on a noisy surface it is
/// unbiased where the mean of the triangle normals is not (the Poisson walls of the factory twin:
/// mean normal 3–5° off, least-squares plane within 0.4°). Falls back to `mean_normal` when the
/// triangles are (nearly) collinear.
fn fitted_normal(
    members: &[u32],
    verts: &[[DVec3; 3]],
    areas: &[f64],
    centroid: DVec3,
    mean_normal: DVec3,
) -> DVec3 {
    let mut c = [[0.0f64; 3]; 3];
    for &m in members {
        let v = verts[m as usize].map(|p| p - centroid);
        let s = v[0] + v[1] + v[2];
        let w = areas[m as usize] / 12.0;
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] +=
                    w * (v[0][i] * v[0][j] + v[1][i] * v[1][j] + v[2][i] * v[2][j] + s[i] * s[j]);
            }
        }
    }
    match smallest_eigenvector(DMat3::from_cols_array_2d(&c)) {
        Some(n) => {
            if n.dot(mean_normal) < 0.0 {
                -n
            } else {
                n
            }
        }
        None => mean_normal,
    }
}

/// One node of the candidate trie: a facet sequence (this node and its ancestors) with the
/// transmitter's image behind its last facet.
#[derive(Clone, Copy, Debug)]
struct Node {
    facet: u32,
    parent: u32,
    depth: u8,
    image: DVec3,
}

const ROOT: u32 = u32::MAX;

/// Candidate facet sequences for one transmitter, reusable for every receiver.
#[derive(Clone, Debug)]
pub struct TxCandidates {
    /// Transmitter position.
    pub tx: DVec3,
    nodes: Vec<Node>,
}

impl TxCandidates {
    /// Number of candidate facet sequences (all orders).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True if there is no candidate reflection path.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
}

/// Ray tracer of propagation paths over one scene.
pub struct Tracer<'a> {
    scene: &'a Scene,
    facets: Facets,
    config: TracerConfig,
    eta: Vec<Complex64>,
    wavelength_m: f64,
}

fn check_position(what: &'static str, p: DVec3) -> Result<(), PathError> {
    if !p.is_finite() {
        Err(PathError::NonFinitePosition { what, value: p })
    } else if p.abs().max_element() > MAX_COORD_M {
        Err(PathError::FarPosition { what, value: p })
    } else {
        Ok(())
    }
}

/// Facet sequences of orders `1..=k` without immediate repeats over `f` facets,
/// `Σ_j f·(f−1)^(j−1)` (what [`CandidateMode::Exhaustive`] enumerates), in `f64`: no overflow.
fn exhaustive_sequences(f: usize, k: usize) -> f64 {
    let f = f as f64;
    (0..k).map(|j| f * (f - 1.0).max(0.0).powi(j as i32)).sum()
}

/// Bytes the exhaustive search holds per facet sequence at its peak: the sequence in the list of
/// all and in the last order's frontier, its trie node and the trie's index entry.
const EXHAUSTIVE_BYTES_PER_SEQUENCE: usize =
    2 * std::mem::size_of::<([u32; MAX_ORDER], u8)>() + std::mem::size_of::<Node>() + 24;

/// Unit vectors `(θ̂, φ̂)` of direction `d` (unit) and its angles `(θ, φ)`.
fn spherical_basis(d: DVec3) -> (DVec3, DVec3, f64, f64) {
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let phi = d.y.atan2(d.x);
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    (
        DVec3::new(ct * cp, ct * sp, -st),
        DVec3::new(-sp, cp, 0.0),
        theta,
        phi,
    )
}

/// Complex 3-vector (field).
#[derive(Clone, Copy, Debug)]
struct CVec3 {
    re: DVec3,
    im: DVec3,
}

impl CVec3 {
    fn real(v: DVec3) -> Self {
        CVec3 {
            re: v,
            im: DVec3::ZERO,
        }
    }
    fn dot(&self, v: DVec3) -> Complex64 {
        Complex64::new(self.re.dot(v), self.im.dot(v))
    }
    fn scaled(c: Complex64, v: DVec3) -> Self {
        CVec3 {
            re: v * c.re,
            im: v * c.im,
        }
    }
    fn add(self, o: Self) -> Self {
        CVec3 {
            re: self.re + o.re,
            im: self.im + o.im,
        }
    }
}

/// Unit vector perpendicular to unit `k`.
fn any_perpendicular(k: DVec3) -> DVec3 {
    let a = if k.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    k.cross(a).normalize()
}

impl<'a> Tracer<'a> {
    /// Prepares a tracer: checks the configuration and builds the facets.
    ///
    /// # Errors
    /// [`PathError::OutOfRange`] for a frequency that is not finite and positive, `max_order >
    /// MAX_ORDER`, zero SBR rays or negative/non-finite facet tolerances.
    pub fn new(scene: &'a Scene, config: TracerConfig) -> Result<Tracer<'a>, PathError> {
        let f = config.frequency_hz;
        if !(f.is_finite() && f > 0.0) {
            return Err(PathError::OutOfRange {
                what: "frequency_hz",
                value: f,
                expected: "finite and > 0",
            });
        }
        if config.max_order > MAX_ORDER {
            return Err(PathError::OutOfRange {
                what: "max_order",
                value: config.max_order as f64,
                expected: "at most 8",
            });
        }
        if let CandidateMode::Sbr { rays } = config.candidates {
            if rays == 0 || rays > MAX_SBR_RAYS {
                return Err(PathError::OutOfRange {
                    what: "sbr_rays",
                    value: rays as f64,
                    expected: "1 ..= 2^30 (MAX_SBR_RAYS)",
                });
            }
        }
        if let Some((i, (lo, hi))) = scene.material_outside(f) {
            let o = &scene.objects[i];
            return Err(PathError::MaterialFrequency {
                freq_ghz: f / 1e9,
                material: o.material.name(),
                object: o.name.clone(),
                lo_ghz: lo,
                hi_ghz: hi,
            });
        }
        for (what, v) in [
            ("facet_angle_tol_rad", config.facet_angle_tol_rad),
            ("facet_dist_tol_m", config.facet_dist_tol_m),
            ("vertical_tol_m", config.vertical_tol_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(PathError::OutOfRange {
                    what,
                    value: v,
                    expected: "finite and >= 0",
                });
            }
        }
        let facets = Facets::build(
            scene,
            config.facet_angle_tol_rad,
            config.facet_dist_tol_m,
            config.vertical_tol_m,
        );
        if config.candidates == CandidateMode::Exhaustive {
            let count = exhaustive_sequences(facets.facets.len(), config.max_order);
            let need = count * EXHAUSTIVE_BYTES_PER_SEQUENCE as f64;
            if let Some((need_gib, have_gib)) = crate::memory::shortfall(need) {
                return Err(PathError::TooLarge {
                    what: "exhaustive candidates",
                    count,
                    need_gib,
                    have_gib,
                });
            }
        }
        let eta = scene
            .objects
            .iter()
            .map(|o| o.material.complex_permittivity(f))
            .collect();
        Ok(Tracer {
            scene,
            facets,
            wavelength_m: crate::wavelength_m(f),
            config,
            eta,
        })
    }

    /// The facets the tracer reflects on.
    pub fn facets(&self) -> &Facets {
        &self.facets
    }

    /// The configuration.
    pub fn config(&self) -> &TracerConfig {
        &self.config
    }

    /// Candidate facet sequences for transmitter `tx` (see module docs), to be reused for every
    /// receiver with [`Tracer::trace`]. Runs in parallel (rayon).
    ///
    /// # Errors
    /// [`PathError::NonFinitePosition`] for a NaN or infinite `tx`.
    pub fn prepare_tx(&self, tx: DVec3) -> Result<TxCandidates, PathError> {
        check_position("tx", tx)?;
        let k = self.config.max_order;
        let mut nodes = Vec::new();
        if k == 0 {
            return Ok(TxCandidates { tx, nodes });
        }
        let seqs: Vec<([u32; MAX_ORDER], u8)> = match self.config.candidates {
            CandidateMode::Sbr { rays } => self.sbr_sequences(tx, rays),
            CandidateMode::Exhaustive => self.all_sequences(),
        };
        // Insert into a trie (prefixes first: sequences sorted by length then content).
        let mut seqs = seqs;
        seqs.sort_unstable_by(|a, b| a.1.cmp(&b.1).then(a.0.cmp(&b.0)));
        let mut index: HashMap<(u32, u32), u32> = HashMap::new();
        for (seq, len) in seqs {
            let mut parent = ROOT;
            for (d, &f) in seq[..len as usize].iter().enumerate() {
                let id = match index.get(&(parent, f)) {
                    Some(&id) => id,
                    None => {
                        let src = if parent == ROOT {
                            tx
                        } else {
                            nodes[parent as usize].image
                        };
                        let fc = &self.facets.facets[f as usize];
                        let image = src - 2.0 * (fc.normal.dot(src) - fc.offset) * fc.normal;
                        let id = nodes.len() as u32;
                        nodes.push(Node {
                            facet: f,
                            parent,
                            depth: d as u8 + 1,
                            image,
                        });
                        index.insert((parent, f), id);
                        id
                    }
                };
                parent = id;
            }
        }
        Ok(TxCandidates { tx, nodes })
    }

    fn all_sequences(&self) -> Vec<([u32; MAX_ORDER], u8)> {
        let nf = self.facets.facets.len() as u32;
        let mut out = Vec::new();
        let mut frontier: Vec<([u32; MAX_ORDER], u8)> = vec![([0; MAX_ORDER], 0)];
        for _ in 0..self.config.max_order {
            let mut next = Vec::new();
            for (seq, len) in &frontier {
                for f in 0..nf {
                    if *len > 0 && seq[*len as usize - 1] == f {
                        continue;
                    }
                    let mut s = *seq;
                    s[*len as usize] = f;
                    next.push((s, len + 1));
                }
            }
            out.extend_from_slice(&next);
            frontier = next;
        }
        out
    }

    fn sbr_sequences(&self, tx: DVec3, rays: usize) -> Vec<([u32; MAX_ORDER], u8)> {
        let k = self.config.max_order;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let tx32 = tx.as_vec3();
        let set = (0..rays)
            .into_par_iter()
            .fold(
                HashSet::new,
                |mut set: HashSet<([u32; MAX_ORDER], u8)>, i| {
                    let z = 1.0 - 2.0 * (i as f64 + 0.5) / rays as f64;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    let phi = golden * i as f64;
                    let mut dir = DVec3::new(r * phi.cos(), r * phi.sin(), z);
                    let mut origin = tx32;
                    let mut seq = [0u32; MAX_ORDER];
                    let mut prev = u32::MAX;
                    for depth in 0..k {
                        let tf = &self.facets.tri_facet;
                        let Some(hit) = self.scene.closest_hit_skipping(
                            origin,
                            dir.as_vec3(),
                            0.0,
                            f32::INFINITY,
                            |t| tf[t as usize] == prev,
                        ) else {
                            break;
                        };
                        let f = tf[hit.triangle as usize];
                        seq[depth] = f;
                        set.insert((seq, depth as u8 + 1));
                        let n = self.facets.facets[f as usize].normal;
                        dir = (dir - 2.0 * dir.dot(n) * n).normalize();
                        origin = hit.point;
                        prev = f;
                    }
                    set
                },
            )
            .reduce(HashSet::new, |mut a, mut b| {
                if a.len() < b.len() {
                    std::mem::swap(&mut a, &mut b);
                }
                a.extend(b);
                a
            });
        set.into_iter().collect()
    }

    /// Paths from `tx` to `rx` (prepares the candidates for `tx` first; use
    /// [`Tracer::prepare_tx`] + [`Tracer::trace`] for many receivers).
    ///
    /// # Errors
    /// [`PathError::NonFinitePosition`] for a NaN or infinite position.
    pub fn paths(&self, tx: DVec3, rx: DVec3) -> Result<Vec<Path>, PathError> {
        let c = self.prepare_tx(tx)?;
        self.trace(&c, rx)
    }

    /// Paths from the prepared transmitter to every receiver, in parallel over receivers.
    ///
    /// # Errors
    /// [`PathError::NonFinitePosition`] naming the first receiver that is NaN or infinite.
    pub fn trace_many(
        &self,
        cand: &TxCandidates,
        rxs: &[DVec3],
    ) -> Result<Vec<Vec<Path>>, PathError> {
        for &rx in rxs {
            check_position("rx", rx)?;
        }
        rxs.par_iter().map(|&rx| self.trace(cand, rx)).collect()
    }

    /// Paths from the prepared transmitter to `rx`, sorted by delay.
    ///
    /// # Errors
    /// [`PathError::NonFinitePosition`] for a NaN or infinite `rx`.
    pub fn trace(&self, cand: &TxCandidates, rx: DVec3) -> Result<Vec<Path>, PathError> {
        check_position("rx", rx)?;
        let tx = cand.tx;
        let mut paths = Vec::new();
        // The far-field path model needs at least a wavelength between the ends: a receiver
        // on the transmitter (a monostatic radar) has no line-of-sight path, only echoes.
        if self.config.los
            && (rx - tx).length() >= self.wavelength_m
            && self.leg_clear(tx, rx, u32::MAX)
        {
            paths.push(self.make_path(tx, rx, &[], &[], (rx - tx).length()));
        }
        let mut chain = [0u32; MAX_ORDER];
        let mut points = [DVec3::ZERO; MAX_ORDER];
        'cand: for node in &cand.nodes {
            // Collect the chain, deepest first.
            let depth = node.depth as usize;
            let mut id = node;
            for slot in chain[..depth].iter_mut() {
                *slot = id.facet;
                if id.parent != ROOT {
                    id = &cand.nodes[id.parent as usize];
                }
            }
            // chain[0] is the last facet (next to rx). Back-trace the images.
            let mut q = rx;
            let mut nd = node;
            for i in 0..depth {
                let fc = &self.facets.facets[chain[i] as usize];
                let img = nd.image;
                let dq = fc.normal.dot(q) - fc.offset;
                let di = fc.normal.dot(img) - fc.offset;
                if dq * di >= 0.0 || dq.abs() < 1e-9 {
                    continue 'cand;
                }
                let s = dq / (dq - di);
                let p = q + (img - q) * s;
                let pad = fc.thickness + 1e-6 * (1.0 + p.abs().max_element());
                if p.cmplt(fc.lo - pad).any() || p.cmpgt(fc.hi + pad).any() {
                    continue 'cand;
                }
                points[i] = p;
                q = p;
                if nd.parent != ROOT {
                    nd = &cand.nodes[nd.parent as usize];
                }
            }
            // The first facet must see the transmitter from the side the image was made on.
            // (Guaranteed by construction: the image of tx is mirrored through that plane.)
            // BVH validation, receiver side first.
            let mut from = rx;
            let mut from_facet = u32::MAX;
            for i in 0..depth {
                if !self.leg_hits_facet(from, from_facet, points[i], chain[i]) {
                    continue 'cand;
                }
                from = points[i];
                from_facet = chain[i];
            }
            if !self.leg_clear(from, tx, from_facet) {
                continue 'cand;
            }
            // Reverse to transmitter order.
            let mut fwd_f = [0u32; MAX_ORDER];
            let mut fwd_p = [DVec3::ZERO; MAX_ORDER];
            for i in 0..depth {
                fwd_f[i] = chain[depth - 1 - i];
                fwd_p[i] = points[depth - 1 - i];
            }
            // Unfolded length from the last image (exact in f64).
            let length_m = (rx - node.image).length();
            paths.push(self.make_path(tx, rx, &fwd_f[..depth], &fwd_p[..depth], length_m));
        }
        paths.sort_by(|a, b| a.delay_s.total_cmp(&b.delay_s));
        dedup(&mut paths);
        Ok(paths)
    }

    /// True if nothing blocks the segment `a → b` (ignoring facet `skip` at `a`).
    fn leg_clear(&self, a: DVec3, b: DVec3, skip: u32) -> bool {
        let d = b - a;
        let len = d.length();
        if len <= 2.0 * SURFACE_EPS_M as f64 {
            return true;
        }
        let dir = (d / len).as_vec3();
        let tf = &self.facets.tri_facet;
        let tmin = if skip == u32::MAX { SURFACE_EPS_M } else { 0.0 };
        self.scene
            .closest_hit_skipping(
                a.as_vec3(),
                dir,
                tmin,
                (len - SURFACE_EPS_M as f64) as f32,
                |t| tf[t as usize] == skip,
            )
            .is_none()
    }

    /// True if the ray from `a` toward `p` (on facet `f`) first hits facet `f`, near `p`.
    fn leg_hits_facet(&self, a: DVec3, skip: u32, p: DVec3, f: u32) -> bool {
        let d = p - a;
        let len = d.length();
        if len <= SURFACE_EPS_M as f64 {
            return false;
        }
        let dir = d / len;
        let fc = &self.facets.facets[f as usize];
        let cos = dir.dot(fc.normal).abs().max(0.05);
        let tol = (fc.thickness + SURFACE_EPS_M as f64) / cos;
        let tf = &self.facets.tri_facet;
        let tmin = if skip == u32::MAX { SURFACE_EPS_M } else { 0.0 };
        match self.scene.closest_hit_skipping(
            a.as_vec3(),
            dir.as_vec3(),
            tmin,
            (len + tol) as f32,
            |t| tf[t as usize] == skip,
        ) {
            Some(h) => {
                if tf[h.triangle as usize] == f {
                    true
                } else {
                    // Another surface only within the tolerance band around p (e.g. a wall
                    // meeting the facet at p) does not block.
                    (h.t as f64) > len - tol && self.inside_facet(p, f)
                }
            }
            // Crack between two triangles of the facet (non-watertight ray/triangle test).
            None => self.inside_facet(p, f),
        }
    }

    /// Exact test: the projection of `p` on facet `f`'s plane lies in one of its triangles.
    fn inside_facet(&self, p: DVec3, f: u32) -> bool {
        let fc = &self.facets.facets[f as usize];
        let n = fc.normal;
        let u = any_perpendicular(n);
        let v = n.cross(u);
        let to2 = |x: DVec3| (x.dot(u), x.dot(v));
        let (px, py) = to2(p);
        fc.triangles.iter().any(|&t| {
            let [a, b, c] = tri_vertices(self.scene, t);
            let (ax, ay) = to2(a);
            let (bx, by) = to2(b);
            let (cx, cy) = to2(c);
            let det = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay);
            if det == 0.0 {
                return false;
            }
            let l1 = ((px - ax) * (cy - ay) - (cx - ax) * (py - ay)) / det;
            let l2 = ((bx - ax) * (py - ay) - (px - ax) * (by - ay)) / det;
            let eps = 1e-9;
            l1 >= -eps && l2 >= -eps && l1 + l2 <= 1.0 + eps
        })
    }

    /// Builds a path of unfolded length `length_m` through the reflection points: angles, the
    /// polarimetric Fresnel product, free-space spreading and carrier phase.
    fn make_path(
        &self,
        tx: DVec3,
        rx: DVec3,
        facets: &[u32],
        points: &[DVec3],
        length_m: f64,
    ) -> Path {
        let mut verts = Vec::with_capacity(facets.len() + 2);
        verts.push(tx);
        verts.extend_from_slice(points);
        verts.push(rx);
        let k0 = (verts[1] - verts[0]).normalize();
        let (th_t, ph_t, zod, aod) = spherical_basis(k0);
        let mut e = [CVec3::real(th_t), CVec3::real(ph_t)];
        let mut k_in = k0;
        let mut interactions = Vec::with_capacity(facets.len().max(1));
        for (i, &f) in facets.iter().enumerate() {
            let fc = &self.facets.facets[f as usize];
            let n = fc.normal;
            let k_out = (verts[i + 2] - verts[i + 1]).normalize();
            let cos_i = k_in.dot(n).abs();
            let r = fresnel_reflection(self.eta[fc.object as usize], cos_i);
            let sx = k_in.cross(n);
            let s = if sx.length() > 1e-12 {
                sx.normalize()
            } else {
                any_perpendicular(k_in)
            };
            let p_in = s.cross(k_in);
            let p_out = s.cross(k_out);
            for field in e.iter_mut() {
                *field = CVec3::scaled(r.te * field.dot(s), s)
                    .add(CVec3::scaled(r.tm * field.dot(p_in), p_out));
            }
            interactions.push(Interaction::Reflection {
                object: fc.object,
                facet: f,
                point: points[i],
            });
            k_in = k_out;
        }
        if interactions.is_empty() {
            interactions.push(Interaction::Los);
        }
        let (th_r, ph_r, _, _) = spherical_basis(k_in);
        let (_, _, zoa, aoa) = spherical_basis(-k_in);
        let jones = [
            [e[0].dot(th_r), e[1].dot(th_r)],
            [e[0].dot(ph_r), e[1].dot(ph_r)],
        ];
        let mut path = Path {
            delay_s: length_m / C_M_PER_S,
            length_m,
            a: Complex64::new(0.0, 0.0),
            jones,
            aod,
            zod,
            aoa,
            zoa,
            interactions,
        };
        self.apply_spreading(&mut path);
        path
    }

    /// Multiplies the Jones matrix by `λ/(4πL)·e^{−j2π L/λ}` and sets `a`.
    fn apply_spreading(&self, path: &mut Path) {
        let amp = free_space_amplitude(path.length_m, self.wavelength_m);
        let phase = -2.0 * std::f64::consts::PI * (path.length_m / self.wavelength_m).fract();
        let g = Complex64::from_polar(amp, phase);
        for row in path.jones.iter_mut() {
            for x in row.iter_mut() {
                *x *= g;
            }
        }
        path.a = match self.config.polarization {
            Polarization::Vertical => path.jones[0][0],
            Polarization::Horizontal => path.jones[1][1],
        };
    }
}

/// Drops paths equal to an earlier one (same delay within 1e-12 relative, same interaction kinds
/// and points within 1 µm): e.g. one specular point found through two coplanar facets.
fn dedup(paths: &mut Vec<Path>) {
    let mut keep: Vec<Path> = Vec::with_capacity(paths.len());
    'outer: for p in paths.drain(..) {
        for q in keep.iter().rev() {
            if p.delay_s - q.delay_s > 1e-12 * p.delay_s + 1e-18 {
                break;
            }
            if p.interactions.len() == q.interactions.len()
                && p.interactions
                    .iter()
                    .zip(&q.interactions)
                    .all(|(x, y)| same_interaction(x, y))
            {
                continue 'outer;
            }
        }
        keep.push(p);
    }
    *paths = keep;
}

fn same_interaction(x: &Interaction, y: &Interaction) -> bool {
    match (x, y) {
        (Interaction::Los, Interaction::Los) => true,
        (Interaction::Reflection { point: a, .. }, Interaction::Reflection { point: b, .. })
        | (Interaction::Diffraction { point: a, .. }, Interaction::Diffraction { point: b, .. }) => {
            (*a - *b).length() < 1e-6
        }
        _ => false,
    }
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

    /// Rotation taking the z axis to `n` (Rodrigues), as a matrix of columns.
    fn basis(n: DVec3) -> [DVec3; 3] {
        let u = any_perpendicular(n);
        [u, n.cross(u), n]
    }

    /// A 10 m × 8 m wall in the y–z plane at x = 0, its top leaning `tilt_deg` toward +x, and a
    /// 10 m × 10 m flat roof at z = 8 m, as facets with `vertical_tol_m`.
    fn wall_and_roof_facets(tilt_deg: f64, vertical_tol_m: f64) -> Vec<Facet> {
        let t = (tilt_deg.to_radians().tan() * 8.0) as f32;
        let (a, b, c, d) = (
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::new(t, 10.0, 8.0),
            Vec3::new(t, 0.0, 8.0),
        );
        let r = |x: f32, y: f32| Vec3::new(x, y, 8.0);
        let scene = Scene::new(vec![
            crate::scene::Object {
                name: "wall".into(),
                material: crate::material::Material::Concrete,
                triangles: vec![[a, b, c], [a, c, d]],
            },
            crate::scene::Object {
                name: "roof".into(),
                material: crate::material::Material::Concrete,
                triangles: vec![
                    [r(1.0, 0.0), r(11.0, 0.0), r(11.0, 10.0)],
                    [r(1.0, 0.0), r(11.0, 10.0), r(1.0, 10.0)],
                ],
            },
        ])
        .unwrap();
        Facets::build(&scene, 15f64.to_radians(), 0.15, vertical_tol_m).facets
    }

    #[test]
    fn a_wall_tilt_below_the_resolution_is_made_plumb_and_a_resolved_one_is_kept() {
        // 0.5° over 8 m moves the top 7 cm: below a 0.375 m range cell, so plumb.
        let f = wall_and_roof_facets(0.5, 0.375);
        assert_eq!(f.len(), 2);
        let wall = f.iter().find(|f| f.object == 0).unwrap();
        assert!(wall.normal.z.abs() < 1e-12, "{:?}", wall.normal);
        assert!((wall.normal.x.abs() - 1.0).abs() < 1e-12);
        // The plane goes through the centroid (x = 3.5 cm) and the tilt is the thickness.
        assert!((wall.offset.abs() - 0.0349).abs() < 1e-3, "{}", wall.offset);
        assert!(wall.thickness > 0.03 && wall.thickness < 0.04);
        // The roof is not a wall: untouched.
        let roof = f.iter().find(|f| f.object == 1).unwrap();
        assert!((roof.normal.z.abs() - 1.0).abs() < 1e-12);
        // Off: the fitted tilt stays.
        let f = wall_and_roof_facets(0.5, 0.0);
        let wall = f.iter().find(|f| f.object == 0).unwrap();
        assert!((wall.normal.z.abs() - 0.5f64.to_radians().sin()).abs() < 1e-6);
        // 5° moves the top 0.70 m: resolved, kept.
        let f = wall_and_roof_facets(5.0, 0.375);
        let wall = f.iter().find(|f| f.object == 0).unwrap();
        assert!((wall.normal.z.abs() - 5f64.to_radians().sin()).abs() < 1e-6);
    }

    #[test]
    fn fitted_normal_of_exact_and_noisy_planes() {
        // Triangles of a 10 m × 5 m grid on the plane through p0 with normal n.
        let n = DVec3::new(0.2, -0.9, 0.3).normalize();
        let [u, v, _] = basis(n);
        let p0 = DVec3::new(3.0, -7.0, 2.0);
        let grid = |noise: f64| {
            let h = |i: i32, j: i32| {
                let x = ((i * 7919 + j * 104_729) as u32).wrapping_mul(2_654_435_761);
                (x as f64 / u32::MAX as f64 - 0.5) * noise
            };
            let q =
                |i: i32, j: i32| p0 + u * (i as f64 * 0.25) + v * (j as f64 * 0.25) + n * h(i, j);
            let mut t = Vec::new();
            for i in 0..40 {
                for j in 0..20 {
                    t.push([q(i, j), q(i + 1, j), q(i + 1, j + 1)]);
                    t.push([q(i, j), q(i + 1, j + 1), q(i, j + 1)]);
                }
            }
            t
        };
        for (noise, bound) in [(0.0, 1e-12), (0.1, 0.01)] {
            let verts = grid(noise);
            let areas: Vec<f64> = verts
                .iter()
                .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length())
                .collect();
            let members: Vec<u32> = (0..verts.len() as u32).collect();
            let mut c = DVec3::ZERO;
            for (t, a) in verts.iter().zip(&areas) {
                c += (t[0] + t[1] + t[2]) / 3.0 * *a;
            }
            let c = c / areas.iter().sum::<f64>();
            let f = fitted_normal(&members, &verts, &areas, c, -n);
            assert!(f.dot(n) < 0.0, "oriented like the mean normal given");
            // Exact plane: round-off only. Noisy (±5 cm uniform at 0.25 m spacing over 10 m ×
            // 5 m, 861 vertices): the least-squares tilt is about σ_h/(σ_x·√N) ≈ 0.029/(2.9·29)
            // ≈ 3.4e-4 rad per axis; 0.01 rad is ≥ 20 of those.
            let tilt = f.cross(n).length();
            assert!(tilt < bound, "noise {noise}: tilt {tilt}");
        }
    }
}
