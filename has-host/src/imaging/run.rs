//! A whole imaging run: build the world from the scenario, plan the pairs, image each pair,
//! fuse the clouds and score them against the ground truth.
//!
//! **Pairing.** Unless the scenario lists `[[pairs]]`, each aperture is paired with the base
//! station of the finest theoretical resolution cell at the region's centre
//! ([`resolution_cell_m`]: range, virtual-aperture and vertical panel cross-range) among the
//! panels that face it. Only what the operator knows goes in (sensor positions and the region):
//! a small bistatic angle gives the finest range cell and the faces that echo towards both ends
//! (a Lambertian face returns `cos θ_tx·cos θ_rx`), a nearer panel the finer vertical cell.
//! Which buildings stand where is not asked, and the choice turns with the site.
//! Aperture sampling defaults to the Nyquist spacing for the region
//! ([`super::sensors::nyquist_spacing_m`]).
//!
//! **Fusion.** Every pair images on the same voxel lattice, so clouds merge voxel by voxel. A
//! point of pair `k` carries weight `w = (|I|/peak_k) · q_k`, with `q_k` the ratio of the
//! finest theoretical resolution cell among pairs to this pair's at the region's centre
//! ([`resolution_cell_m`]). A fused
//! voxel's weight is the sum over the pairs that kept it; voxels below
//! `imaging.fusion_min_weight` × the largest weight are dropped. Then [`confirm`] drops the
//! points that two or more pairs which see their place did not detect
//! ([`super::confirmation`]): one pair's false alarms, not surfaces.
//!
//! **Ground truth.** Uniform area-weighted samples (`imaging.truth_density_per_m2`) on every face of
//! the `imaging.truth_objects` that does not face down (the building's walls and roofs).

use std::collections::HashMap;

use glam::Vec3;

use super::centroid::smear_to_centroid;
use super::confirmation::{confirmed, FreeSpaceTest, PairCell, PairSight};
use super::driver::{image_pair, survey_pair, ImagingError, PairImage, PairPlan, RunOptions};
use super::facing::{own_surfaces, test_normals, SURFACE_POINTS};
use super::finer_height::{heights, Height};
use super::terrain_echo::{terrain_echoes, TerrainLayer};
use super::world::{Terrain, World};
use crate::scenario::{GroundClutter, Pairing, Scenario};
use crate::sensors::{nyquist_spacing_m, pair_resolution_m, vertical_extent_m};
use rayon::prelude::*;

use crate::echo::ScattererSet;
use crate::knn::PointIndex;
use crate::scene::Scene;

/// Errors of a run, beyond the driver's.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The scene could not be built.
    #[error("scene: {0}")]
    Scene(#[from] crate::scenario::SceneSpecError),
    /// Imaging failed.
    #[error(transparent)]
    Imaging(#[from] ImagingError),
    /// A scenario value the scene makes invalid (a site too far from the origin).
    #[error(transparent)]
    Scenario(#[from] crate::scenario::ScenarioError),
    /// Echo synthesis refused the scatterer model.
    #[error("scatterers: {0}")]
    Echo(#[from] crate::echo::EchoError),
    /// A metric could not be computed.
    #[error("metrics: {0}")]
    Metric(#[from] crate::knn::GeometryError),
    /// An object named in the scenario does not exist.
    #[error("{field}: no object named '{name}' in the scene")]
    UnknownObject {
        /// The field.
        field: &'static str,
        /// The name.
        name: String,
    },
    /// The carrier lies outside a scene material's stated ITU-R P.2040 range.
    #[error(
        "radar.fc_ghz: {fc_ghz} GHz is outside {lo_ghz}–{hi_ghz} GHz, where ITU-R P.2040 states \
         the fit of material {material} (object {object})"
    )]
    MaterialFrequency {
        /// The carrier, GHz.
        fc_ghz: f64,
        /// The material's name.
        material: &'static str,
        /// The first object made of it.
        object: String,
        /// The stated range, GHz.
        lo_ghz: f64,
        /// The stated range, GHz.
        hi_ghz: f64,
    },
    /// A sensor lies inside a building or under the ground ([`Scene::enclosing_object`]).
    #[error("{field}: {position:?} lies inside or under object '{object}'")]
    Enclosed {
        /// The field, e.g. `base_stations[0].position`.
        field: String,
        /// The position, m.
        position: [f32; 3],
        /// The enclosing object.
        object: String,
    },
    /// No pair sees anything.
    #[error("no base station–aperture pair sees the imaging region")]
    NoPairs,
    /// One pair's imaging would need more memory than the machine has.
    #[error(
        "imaging: one pair needs up to {need_gib:.1} GiB, more than the {have_gib:.1} GiB \
         available ({voxels} fine voxels of {voxel_m} m: {voxels_gib:.1} GiB; the frames held \
         for pair {pair}: {frames_gib:.1} GiB); {advice}"
    )]
    TooLarge {
        /// Fine voxels of the region's bounding box.
        voxels: usize,
        /// Fine voxel edge, metres.
        voxel_m: f32,
        /// The voxels' part of the estimate, GiB.
        voxels_gib: f64,
        /// The pair holding the most frames.
        pair: String,
        /// Its frames' part of the estimate, GiB.
        frames_gib: f64,
        /// The estimate, GiB.
        need_gib: f64,
        /// Memory available, GiB.
        have_gib: f64,
        /// What to change: the fields of the larger part.
        advice: &'static str,
    },
}

/// Worst-case bytes per fine voxel of one pair's imaging (every brick active): the data, terrain
/// and incoherent images (3 × 8 B), the fixed-point accumulator and its conversion (16 + 8 B),
/// the receive-coherence power image and, in a fixed-point run, that pass's own `f32` image
/// (4 + 8 B), the dense detection arrays (predicted power, its local mean and count, and the
/// two running sums of its second moment's: 5 × 4 B), the bricks' receive positions for two back-projectors (≈ 2 × 12 B × elements / 512
/// voxels, at most 2 × 12 × 1024 / 512 = 48 B) and their transmit positions (12 B × positions
/// / 512 voxels, 12 B at 512 positions).
pub const IMAGING_BYTES_PER_VOXEL: usize = 3 * 8 + 16 + 8 + 4 + 8 + 5 * 4 + 48 + 12;

/// Fine voxels of the region's bounding box and the worst-case bytes one pair's imaging needs:
/// [`IMAGING_BYTES_PER_VOXEL`] per voxel plus the frames the imaging holds for the largest
/// pairing ([`super::driver::held_frames_bytes`]).
pub fn memory_estimate(sc: &Scenario) -> (usize, u64) {
    let m = memory_parts(sc);
    (m.voxels, m.voxel_bytes.saturating_add(m.frame_bytes))
}

/// The two parts of [`memory_estimate`].
struct MemoryParts {
    voxels: usize,
    voxel_bytes: u64,
    /// The largest pairing's held frames, and that pairing.
    frame_bytes: u64,
    pair: String,
}

fn memory_parts(sc: &Scenario) -> MemoryParts {
    // The lattice of the region with the widest guard band any pairing images past it.
    let guard = if sc.imaging.guard_band {
        every_pairing(sc)
            .iter()
            .map(|p| super::driver::region_guard_m(sc, p))
            .fold(0.0f32, f32::max)
    } else {
        0.0
    };
    let (lo, hi) = sc.with_region_grown(guard).region();
    let d = ((hi - lo) / sc.imaging.voxel_m).floor() + Vec3::ONE;
    let voxels = (d.x as f64 * d.y as f64 * d.z as f64).min(usize::MAX as f64) as usize;
    let (frame_bytes, pair) = every_pairing(sc)
        .into_iter()
        .map(|p| (super::driver::held_frames_bytes(sc, &p), p.name))
        .max_by_key(|(b, _)| *b)
        .unwrap_or_default();
    MemoryParts {
        voxels,
        voxel_bytes: (voxels as u64).saturating_mul(IMAGING_BYTES_PER_VOXEL as u64),
        frame_bytes,
        pair,
    }
}

/// Refuses a run whose worst-case imaging memory ([`memory_estimate`]) exceeds the memory
/// available, before anything is allocated.
///
/// # Errors
/// [`RunError::TooLarge`] with the estimate, its two parts and the fields of the larger one.
pub fn check_memory(sc: &Scenario) -> Result<(), RunError> {
    let m = memory_parts(sc);
    let need = m.voxel_bytes.saturating_add(m.frame_bytes);
    if let Some((need_gib, have_gib)) = crate::memory::shortfall(need as f64) {
        let gib = |b: u64| crate::memory::gib(b as f64);
        return Err(RunError::TooLarge {
            voxels: m.voxels,
            voxel_m: sc.imaging.voxel_m,
            voxels_gib: gib(m.voxel_bytes),
            pair: m.pair,
            frames_gib: gib(m.frame_bytes),
            need_gib,
            have_gib,
            advice: if m.voxel_bytes >= m.frame_bytes {
                "shrink imaging.region_min/region_max or coarsen imaging.voxel_m"
            } else {
                "fewer base_stations[].rows/cols or apertures[].positions, or a larger \
                 imaging.element_step/position_step"
            },
        });
    }
    Ok(())
}

/// Builds the scene, the scatterers and the ground truth.
///
/// # Errors
/// [`RunError`] naming what is wrong; [`RunError::TooLarge`] for a region that would not fit in
/// memory ([`check_memory`]), before the scene is built.
pub fn build_world(sc: &Scenario) -> Result<World, RunError> {
    check_memory(sc)?;
    let scene = sc.scene.build()?;
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    for n in &sc.imaging.ground_objects {
        if !names.contains(&n.as_str()) {
            return Err(RunError::UnknownObject {
                field: "imaging.ground_objects",
                name: n.clone(),
            });
        }
    }
    for n in &sc.imaging.truth_objects {
        if !names.contains(&n.as_str()) {
            return Err(RunError::UnknownObject {
                field: "imaging.truth_objects",
                name: n.clone(),
            });
        }
    }
    let fc_hz = sc.radar.fc_ghz * 1e9;
    if let Some((i, (lo, hi))) = scene.material_outside(fc_hz) {
        let o = &scene.objects[i];
        return Err(RunError::MaterialFrequency {
            fc_ghz: sc.radar.fc_ghz,
            material: o.material.name(),
            object: o.name.clone(),
            lo_ghz: lo,
            hi_ghz: hi,
        });
    }
    sc.check_extent()?;
    sc.check_unambiguous()?;
    for (field, p) in sc.sensor_positions() {
        if let Some(o) = scene.enclosing_object(Vec3::from(p)) {
            return Err(RunError::Enclosed {
                field,
                position: p,
                object: scene.objects[o as usize].name.clone(),
            });
        }
    }
    let is_ground: Vec<bool> = scene
        .objects
        .iter()
        .map(|o| sc.imaging.ground_objects.contains(&o.name))
        .collect();
    // A density the memory cannot hold is named by its scenario field.
    let named = |field: &'static str| {
        move |e: crate::echo::EchoError| match e {
            crate::echo::EchoError::TooLarge {
                count,
                need_gib,
                have_gib,
                ..
            } => crate::echo::EchoError::TooLarge {
                field,
                count,
                need_gib,
                have_gib,
            },
            e => e,
        }
    };
    let ig = is_ground.clone();
    let mut set = ScattererSet::sample_where(
        &scene,
        sc.imaging.scatterer_density_per_m2,
        sc.imaging.seed,
        |o, _| !ig[o as usize],
    )
    .map_err(named("imaging.scatterer_density_per_m2"))?;
    let ig = is_ground.clone();
    let mut ground = ScattererSet::sample_where(
        &scene,
        sc.ground_density_per_m2()?,
        sc.imaging.seed.wrapping_add(1),
        |o, p| ig[o as usize] && sc.scatters_as_ground(p),
    )
    .map_err(named("imaging.ground_density_per_m2"))?;
    if sc.imaging.ground_clutter == GroundClutter::Developed {
        ground = ground.speckled(sc.imaging.seed ^ GROUND_SPECKLE_SEED);
    }
    set.points.extend(ground.points);
    let terrain = terrain_model(sc, &scene, &is_ground)?;
    let truth_triangles: Vec<[Vec3; 3]> = scene
        .objects
        .iter()
        .filter(|o| sc.imaging.truth_objects.contains(&o.name))
        .flat_map(|o| o.triangles.iter().copied())
        .filter(|t| {
            let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
            n.z > -0.5
        })
        .collect();
    let (truth, truth_normals) = crate::metrics::sample_triangles_oriented(
        &truth_triangles,
        sc.imaging.truth_density_per_m2,
        sc.imaging.seed.wrapping_add(2),
    )?;
    Ok(World {
        scene,
        scatterers: set,
        truth,
        truth_normals,
        truth_triangles,
        is_ground,
        terrain,
    })
}

/// Seed offset of the terrain model's scatterers: a realisation independent of the true ground's
/// (`seed + 1`), so the model knows the terrain's statistics, not its echoes.
const TERRAIN_MODEL_SEED: u64 = 0x7E22_A1D0_5EED_0001;
/// Mixed into the scenario's seed for the developed ground's speckle draws.
const GROUND_SPECKLE_SEED: u64 = 0x5BEC_C1E0_5EED_0002;

/// The known terrain (module [`World::terrain`]).
fn terrain_model(sc: &Scenario, scene: &Scene, is_ground: &[bool]) -> Result<Terrain, RunError> {
    let ground: Vec<crate::scene::Object> = scene
        .objects
        .iter()
        .zip(is_ground)
        .filter(|(_, &g)| g)
        .map(|(o, _)| o.clone())
        .collect();
    if ground.is_empty() {
        let mut empty = ScattererSet::sample_where(scene, 1.0, 0, |_, _| false)?;
        empty.points.clear();
        return Ok(Terrain {
            scene: Scene::new(scene.objects.clone())
                .map_err(crate::scenario::SceneSpecError::from)?,
            scatterers: empty,
            known: false,
        });
    }
    let tscene = Scene::new(ground).map_err(crate::scenario::SceneSpecError::from)?;
    // The model is the ground's mean echo: developed clutter's patches at their mean power.
    let scatterers = ScattererSet::sample_where(
        &tscene,
        sc.ground_density_per_m2()?,
        sc.imaging.seed ^ TERRAIN_MODEL_SEED,
        |_, p| sc.scatters_as_ground(p),
    )?;
    Ok(Terrain {
        scene: tscene,
        scatterers,
        known: true,
    })
}

/// Nyquist transmit positions of aperture `ai` for the imaging region.
pub fn default_positions(sc: &Scenario, ai: usize) -> usize {
    if let Some(n) = sc.apertures[ai].positions {
        return n;
    }
    let ap = sc.aperture(ai, 2);
    let dir = (ap.end - ap.start).normalize_or_zero();
    let c = ap.centre();
    // The widest angle under which the track sees the region: over the footprint's vertices,
    // edge midpoints and centre, at the region's floor, middle and top — the region itself,
    // not its axis-aligned box (which a turned site's region fills only in part: the box gave
    // the UAV track of the factory site turned by 37° 191 positions against the unturned site's
    // 172). For a box region these are the 27 points of the box (corners, edge and face centres,
    // centre); for a turned region the same points turned with it.
    let (lo, hi) = sc.region();
    let foot = sc.region_footprint();
    let xy: Vec<glam::Vec2> = (0..foot.len())
        .flat_map(|k| {
            let (a, b) = (
                glam::Vec2::from(foot[k]),
                glam::Vec2::from(foot[(k + 1) % foot.len()]),
            );
            [a, a.lerp(b, 0.5)]
        })
        .chain(std::iter::once(sc.region_footprint_centre()))
        .collect();
    let zs = [lo.z, 0.5 * (lo.z + hi.z), hi.z];
    let mut max_cos = 0.0f32;
    for q in &xy {
        for &z in &zs {
            let p = Vec3::new(q.x, q.y, z);
            max_cos = max_cos.max(dir.dot((p - c).normalize_or_zero()).abs());
        }
    }
    let half_angle = max_cos.clamp(1e-3, 1.0).asin();
    let d = nyquist_spacing_m(sc.wavelength_m() as f32, half_angle);
    (ap.length_m() / d).ceil() as usize + 1
}

/// The pairs to image: the scenario's `[[pairs]]` if given, else by `imaging.pairing` —
/// [`every_facing_pair`] (every facing base station with every aperture), [`plan_pairs`] (per
/// aperture the finest resolution cell) or [`survey_pairs`] (per aperture the most detections).
///
/// # Errors
/// [`RunError::NoPairs`] if no pair qualifies; [`RunError`] from the survey.
pub fn choose_pairs(sc: &Scenario, world: &World) -> Result<Vec<PairPlan>, RunError> {
    match sc.imaging.pairing {
        Pairing::Survey if sc.pairs.is_empty() => survey_pairs(sc, world),
        Pairing::Every if sc.pairs.is_empty() => every_facing_pair(sc),
        _ => plan_pairs(sc),
    }
}

/// Every aperture with every base station whose panel faces the region's centre
/// ([`facing_base_stations`]) and whose pair resolves the site at least as finely in range and
/// along the track as the panel does vertically ([`resolves_the_site`]), in aperture then
/// base-station order (`imaging.pairing = "every"`).
///
/// # Errors
/// [`RunError::NoPairs`] if no such pair exists.
pub fn every_facing_pair(sc: &Scenario) -> Result<Vec<PairPlan>, RunError> {
    let plans: Vec<PairPlan> = facing_base_stations(sc)
        .into_iter()
        .enumerate()
        .flat_map(|(ai, candidates)| candidates.into_iter().map(move |(bs, _)| (bs, ai)))
        .filter(|&(bs, ai)| resolves_the_site(sc, bs, ai))
        .map(|(bs, ai)| pair_plan(sc, bs, ai))
        .collect();
    if plans.is_empty() {
        return Err(RunError::NoPairs);
    }
    Ok(plans)
}

/// The pairs to image (see module docs), in aperture order: the scenario's `[[pairs]]` if given,
/// else for each aperture the base station with the finest resolution cell at the region's centre
/// among those whose panel faces it ([`facing_base_stations`]; ties keep the lower index).
///
/// # Errors
/// [`RunError::NoPairs`] if no base station faces the region.
pub fn plan_pairs(sc: &Scenario) -> Result<Vec<PairPlan>, RunError> {
    let mut plans = Vec::new();
    if sc.pairs.is_empty() {
        for (ai, candidates) in facing_base_stations(sc).into_iter().enumerate() {
            let mut best: Option<(usize, f32)> = None;
            for (bs, cell) in candidates {
                if best.is_none_or(|(_, c)| cell < c) {
                    best = Some((bs, cell));
                }
            }
            if let Some((bs, _)) = best {
                plans.push(pair_plan(sc, bs, ai));
            }
        }
    } else {
        for p in &sc.pairs {
            let bs = sc
                .base_stations
                .iter()
                .position(|b| b.name == p.bs)
                .unwrap_or(0);
            let ai = sc
                .apertures
                .iter()
                .position(|a| a.name == p.aperture)
                .unwrap_or(0);
            plans.push(pair_plan(sc, bs, ai));
        }
    }
    if plans.is_empty() {
        return Err(RunError::NoPairs);
    }
    Ok(plans)
}

/// For each aperture, the base station among those whose panel faces the region's centre
/// ([`facing_base_stations`]) whose [`survey_pair`] detects the most of the site (ties: the finer
/// resolution cell, then the lower index); an aperture with one such base station is not
/// surveyed (`imaging.pairing = "survey"`).
///
/// # Errors
/// [`RunError::NoPairs`] if no base station faces the region; [`RunError`] from the survey.
pub fn survey_pairs(sc: &Scenario, world: &World) -> Result<Vec<PairPlan>, RunError> {
    let mut plans = Vec::new();
    for (ai, candidates) in facing_base_stations(sc).into_iter().enumerate() {
        let mut best: Option<(usize, usize, f32)> = None;
        for &(bs, cell) in &candidates {
            let seen = if candidates.len() > 1 {
                survey_pair(sc, world, &pair_plan(sc, bs, ai))?
            } else {
                0
            };
            if best.is_none_or(|(_, s, c)| seen > s || (seen == s && cell < c)) {
                best = Some((bs, seen, cell));
            }
        }
        if let Some((bs, _, _)) = best {
            plans.push(pair_plan(sc, bs, ai));
        }
    }
    if plans.is_empty() {
        return Err(RunError::NoPairs);
    }
    Ok(plans)
}

/// Whether base station `bs` with aperture `ai` resolves the region's centre in bistatic range
/// and along the track (the virtual aperture's cross-range) no more coarsely than the panel
/// resolves it vertically — the coarsest extent every pair's cell has
/// ([`super::sensors::pair_resolution_m`]). A pair that fails it sees the site near forward
/// scatter (the site between the panel and the track: the bistatic range barely changes across
/// it; measured 7.6–72 m range cells on held-out sites) or along its track's axis: its image
/// smears every echo across the site, and its cell would set the support distance of every
/// other pair's points ([`support_distance_m`]).
pub fn resolves_the_site(sc: &Scenario, bs: usize, ai: usize) -> bool {
    let (r, xv, _xh, xz) = pair_resolution_m(
        sc.region_centre(),
        &sc.array(bs),
        &sc.aperture(ai, default_positions(sc, ai)),
        sc.wavelength_m() as f32,
        (sc.radar.bandwidth_mhz * 1e6) as f32,
    );
    r.max(xv) <= xz
}

/// Per aperture, the base stations whose panel faces the region's centre, each with the pair's
/// resolution cell there ([`resolution_cell_m`]), in base-station order.
pub fn facing_base_stations(sc: &Scenario) -> Vec<Vec<(usize, f32)>> {
    let centre = sc.region_centre();
    (0..sc.apertures.len())
        .map(|ai| {
            (0..sc.base_stations.len())
                .filter(|&bs| {
                    let a = sc.array(bs);
                    (centre - a.centre).dot(a.boresight()) > 0.0
                })
                .map(|bs| {
                    let cell = resolution_cell_m(sc, bs, ai, default_positions(sc, ai), centre);
                    (bs, cell)
                })
                .collect()
        })
        .collect()
}

/// The theoretical resolution cell of base station `bs` with aperture `ai` sampled at
/// `positions` at `point`, metres: the geometric mean of the range resolution, the virtual
/// aperture's (horizontal) cross-range and the panel's vertical cross-range
/// ([`super::sensors::pair_resolution_m`]; the panel's horizontal cross-range is the coarser of
/// the two horizontal ones and does not set the cell).
pub fn resolution_cell_m(
    sc: &Scenario,
    bs: usize,
    ai: usize,
    positions: usize,
    point: Vec3,
) -> f32 {
    let (r, xv, _xh, xz) = pair_resolution_m(
        point,
        &sc.array(bs),
        &sc.aperture(ai, positions),
        sc.wavelength_m() as f32,
        (sc.radar.bandwidth_mhz * 1e6) as f32,
    );
    (r * xv * xz).cbrt()
}

/// Every (base station, aperture) combination of the scenario, whether or not [`plan_pairs`]
/// would image it: with [`observable_truth`], how much of the truth any
/// pairing of these sensors could observe — the ceiling of the pairing choice.
pub fn every_pairing(sc: &Scenario) -> Vec<PairPlan> {
    (0..sc.base_stations.len())
        .flat_map(|bs| (0..sc.apertures.len()).map(move |ai| pair_plan(sc, bs, ai)))
        .collect()
}

/// The plan of base station `bs` with aperture `ai` (named `"BS-aperture"`, default sampling).
fn pair_plan(sc: &Scenario, bs: usize, ai: usize) -> PairPlan {
    PairPlan {
        name: format!("{}-{}", sc.base_stations[bs].name, sc.apertures[ai].name),
        bs,
        aperture: ai,
        positions: default_positions(sc, ai),
    }
}

/// The fused cloud.
#[derive(Clone, Debug, Default)]
pub struct FusedCloud {
    /// Points, metres.
    pub points: Vec<Vec3>,
    /// Summed fusion weight of each point.
    pub weight: Vec<f32>,
    /// Largest normalised intensity among the pairs that kept the point.
    pub intensity: Vec<f32>,
    /// How many pairs kept the point.
    pub pairs: Vec<u8>,
    /// Which pairs kept the point: bit `k` for pair `k` (pairs beyond 64 are not recorded).
    pub pair_mask: Vec<u64>,
    /// Per pair: its fusion factor `c_k·q_k`.
    pub pair_factor: Vec<f32>,
    /// Points dropped by the cross-pair confirmation ([`confirm`]).
    pub unconfirmed: usize,
    /// Points dropped as echoes of the known terrain ([`drop_terrain_echoes`]).
    pub terrain_echoes: usize,
    /// The pairs' detections that were their own terrain's echoes, which confirm nothing
    /// ([`confirm`], [`super::confirmation`]), summed over the pairs.
    pub pair_ground_echoes: usize,
    /// Points dropped as copies of a surface a finer pair placed at another height
    /// ([`finer_heights`]).
    pub finer_heights: usize,
    /// Points moved to the information-weighted height of the finer placements of their surface
    /// ([`finer_heights`]).
    pub refined_heights: usize,
}

impl FusedCloud {
    /// The points with `keep[i]` true, each with its weight, intensity and pairs; the per-pair
    /// factors and the counts of removed points carried over.
    pub fn retain(self, keep: &[bool]) -> FusedCloud {
        fn pick<T: Copy>(v: &[T], keep: &[bool]) -> Vec<T> {
            v.iter()
                .zip(keep)
                .filter(|(_, &k)| k)
                .map(|(x, _)| *x)
                .collect()
        }
        FusedCloud {
            points: pick(&self.points, keep),
            weight: pick(&self.weight, keep),
            intensity: pick(&self.intensity, keep),
            pairs: pick(&self.pairs, keep),
            pair_mask: pick(&self.pair_mask, keep),
            ..self
        }
    }
}

/// Fuses the pairs' clouds (module docs).
pub fn fuse(sc: &Scenario, plans: &[PairPlan], images: &[PairImage], voxel_m: f32) -> FusedCloud {
    let centre = sc.region_centre();
    let cells: Vec<f32> = plans
        .iter()
        .map(|p| resolution_cell_m(sc, p.bs, p.aperture, p.positions, centre))
        .collect();
    let best_cell = cells.iter().copied().fold(f32::INFINITY, f32::min);
    let factors: Vec<f32> = cells.iter().map(|&c| best_cell / c).collect();
    let mut map: HashMap<[i64; 3], (Vec3, f32, f32, u8, u64)> = HashMap::new();
    for (k, img) in images.iter().enumerate() {
        for (p, &i) in img.points.iter().zip(&img.intensity) {
            let q = (*p / voxel_m).round();
            let e = map
                .entry([q.x as i64, q.y as i64, q.z as i64])
                .or_insert((*p, 0.0, 0.0, 0, 0));
            e.1 += i * factors[k];
            e.2 = e.2.max(i);
            e.3 = e.3.saturating_add(1);
            if k < 64 {
                e.4 |= 1 << k;
            }
        }
    }
    let wmax = map.values().map(|e| e.1).fold(0.0f32, f32::max);
    let keep = sc.imaging.fusion_min_weight * wmax;
    let mut entries: Vec<_> = map.into_iter().filter(|(_, e)| e.1 >= keep).collect();
    entries.sort_by_key(|(k, _)| *k); // deterministic order
    let mut out = FusedCloud {
        pair_factor: factors,
        ..FusedCloud::default()
    };
    for (_, (p, w, i, n, mask)) in entries {
        out.points.push(p);
        out.weight.push(w);
        out.intensity.push(i);
        out.pairs.push(n);
        out.pair_mask.push(mask);
    }
    out
}

/// The fused cloud without the points that `imaging.cross_pair_denials` or more pairs per
/// confirming pair see and did not detect ([`super::confirmation::confirmed`]); unchanged when
/// that is 0.
pub fn confirm(
    sc: &Scenario,
    world: &World,
    plans: &[PairPlan],
    images: &[PairImage],
    fused: FusedCloud,
) -> FusedCloud {
    let need = sc.imaging.cross_pair_denials;
    if need == 0 || fused.points.is_empty() {
        return fused;
    }
    let support = support_distance_m(sc, plans);
    let own = own_terrain_echoes(sc, world, plans, images, &fused, support);
    let index = |v: &[Vec3]| {
        (!v.is_empty())
            .then(|| PointIndex::new("pair points", v).ok())
            .flatten()
    };
    // Each pair's detections that confirm, and its own terrain echoes (none without the test).
    let indices: Vec<(Option<PointIndex>, Option<PointIndex>)> = match &own {
        Some(own) => own
            .detections
            .iter()
            .map(|(kept, ground)| (index(kept), index(ground)))
            .collect(),
        None => images.iter().map(|im| (index(&im.points), None)).collect(),
    };
    let mask = own.as_ref().map_or(&fused.pair_mask, |o| &o.mask);
    let pair_ground_echoes = own.as_ref().map_or(0, |o| {
        o.detections.iter().map(|(_, ground)| ground.len()).sum()
    });
    let sights: Vec<PairSight<'_>> = plans
        .iter()
        .zip(&indices)
        .zip(pair_sensors(sc, plans))
        .map(|((p, (idx, ground)), [rx, tx])| {
            let a = sc.array(p.bs);
            PairSight {
                rx,
                boresight: a.boresight(),
                tx,
                detections: idx.as_ref(),
                ground: ground.as_ref(),
                cell: sc.imaging.resolved_confirmation.then(|| pair_cell(sc, p)),
            }
        })
        .collect();
    // Which way each point's own surface faces (none for a patch smaller than a resolution
    // cell): a pair behind it receives nothing from it. The fused points are finite voxel
    // positions and every point has a pair unless more than 64 pairs were imaged; then no point
    // has a facing, as before.
    // Two fused points lie on one patch when they are lattice neighbours (diagonals included);
    // a patch is a surface of its own when it spans the coarsest resolution cell.
    // Each point's plane (its PCA normal), whether or not it spans a cell: the free-space test
    // asks how a leg crosses it.
    let cells: Vec<PairCell> = plans.iter().map(|p| pair_cell(sc, p)).collect();
    let planes = test_normals(
        &fused.points,
        &sensors_of(&observing_pairs(sc, plans, &fused)),
        support,
        SURFACE_POINTS,
    )
    .unwrap_or_default();
    let facing = own_surfaces(
        &fused.points,
        &planes,
        1.01 * 3f32.sqrt() * sc.imaging.voxel_m,
        2.0 * support,
    )
    .unwrap_or_else(|_| vec![None; fused.points.len()]);
    let keep = confirmed(
        &fused.points,
        mask,
        &facing,
        &sights,
        &world.terrain.scene,
        support,
        sc.imaging.own_sight_test,
        need,
        sc.imaging.free_space_test.then_some(FreeSpaceTest {
            half_width_m: 0.5 * sc.imaging.voxel_m,
            planes: &planes,
            cells: &cells,
        }),
    );
    let unconfirmed = keep.iter().filter(|&&k| !k).count();
    FusedCloud {
        unconfirmed,
        pair_ground_echoes,
        ..fused.retain(&keep)
    }
}

/// A pair's resolution cell ([`PairCell`]) over the lattice's voxel.
pub(crate) fn pair_cell(sc: &Scenario, plan: &PairPlan) -> PairCell {
    PairCell {
        array: sc.array(plan.bs).clone(),
        aperture: sc.aperture(plan.aperture, plan.positions),
        wavelength_m: sc.wavelength_m() as f32,
        bandwidth_hz: (sc.radar.bandwidth_mhz * 1e6) as f32,
        voxel_m: sc.imaging.voxel_m,
    }
}

/// Where each pair's legs start: its panel's centre and its aperture's centre, metres.
pub(crate) fn pair_sensors(sc: &Scenario, plans: &[PairPlan]) -> Vec<[Vec3; 2]> {
    plans
        .iter()
        .map(|p| [sc.array(p.bs).centre, sc.aperture(p.aperture, 2).centre()])
        .collect()
}

/// Each pair's detections split into what it confirms with and its own terrain echoes, and the
/// fused points' pair masks without the pairs for which the point is their terrain's echo.
struct OwnTerrainEchoes {
    /// Per pair: (its detections that are not its terrain's echoes, those that are).
    detections: Vec<(Vec<Vec3>, Vec<Vec3>)>,
    /// [`FusedCloud::pair_mask`] with bit `k` cleared where the point is pair `k`'s terrain echo.
    mask: Vec<u64>,
}

/// A pair's detection inside its own layer over the known terrain, under nothing of the fused
/// cloud that rises out of that layer, is what the pair would detect of the bare ground
/// ([`super::terrain_echo`] with that pair's layer): it neither confirms nor denies a fused
/// point there ([`super::confirmation`]). `None` without a known terrain or with
/// `imaging.terrain_echo_test` off.
fn own_terrain_echoes(
    sc: &Scenario,
    world: &World,
    plans: &[PairPlan],
    images: &[PairImage],
    fused: &FusedCloud,
    support_m: f32,
) -> Option<OwnTerrainEchoes> {
    if !sc.imaging.terrain_echo_test || !world.terrain.known {
        return None;
    }
    let height = |p: Vec3| world.terrain.below(p).map_or(f32::NAN, |g| p.z - g.z);
    let heights: Vec<f32> = fused.points.par_iter().map(|&p| height(p)).collect();
    let layers = vertical_extents(sc, plans, fused);
    let cloud = TerrainLayer::new(&fused.points, &heights, &layers, support_m);
    let pair_layers = PairLayers::new(sc, plans);
    let echo_of = |k: usize, p: Vec3, h: f32| cloud.is_echo(p, h, pair_layers.at(k, p));
    let detections = images
        .iter()
        .enumerate()
        .map(|(k, im)| {
            let echo: Vec<bool> = im
                .points
                .par_iter()
                .map(|&p| echo_of(k, p, height(p)))
                .collect();
            let (ground, kept): (Vec<_>, Vec<_>) = im.points.iter().zip(&echo).partition(|x| *x.1);
            (
                kept.into_iter().map(|x| *x.0).collect(),
                ground.into_iter().map(|x| *x.0).collect(),
            )
        })
        .collect();
    let mask = fused
        .points
        .par_iter()
        .zip(&fused.pair_mask)
        .zip(&heights)
        .map(|((&p, &m), &h)| {
            (0..plans.len().min(64))
                .filter(|&k| (m >> k) & 1 == 1 && !echo_of(k, p, h))
                .fold(0u64, |acc, k| acc | 1 << k)
        })
        .collect();
    Some(OwnTerrainEchoes { detections, mask })
}

/// The fused cloud without the echoes of the known terrain (`imaging.terrain_echo_test`,
/// [`super::terrain_echo`]): each point's height above the terrain straight below it, its layer
/// the finest vertical extent among the pairs that kept it; unchanged without a known terrain.
pub fn drop_terrain_echoes(
    sc: &Scenario,
    world: &World,
    plans: &[PairPlan],
    fused: FusedCloud,
) -> FusedCloud {
    if !sc.imaging.terrain_echo_test
        || fused.points.is_empty()
        || !world.is_ground.iter().any(|&g| g)
    {
        return fused;
    }
    let layers = vertical_extents(sc, plans, &fused);
    let heights: Vec<f32> = fused
        .points
        .par_iter()
        .map(|&p| world.terrain.below(p).map_or(f32::NAN, |g| p.z - g.z))
        .collect();
    let echo = terrain_echoes(
        &fused.points,
        &heights,
        &layers,
        support_distance_m(sc, plans),
    );
    let keep: Vec<bool> = echo.iter().map(|&e| !e).collect();
    FusedCloud {
        terrain_echoes: echo.iter().filter(|&&e| e).count(),
        ..fused.retain(&keep)
    }
}

/// Each fused point's vertical extent: the finest among the pairs that kept it
/// ([`vertical_extent_m`] at the point; infinite when no recorded pair kept it).
pub fn vertical_extents(sc: &Scenario, plans: &[PairPlan], fused: &FusedCloud) -> Vec<f32> {
    let layers = PairLayers::new(sc, plans);
    fused
        .points
        .par_iter()
        .zip(&fused.pair_mask)
        .map(|(&p, &mask)| {
            (0..plans.len().min(64))
                .filter(|&k| mask & (1 << k) != 0)
                .map(|k| layers.at(k, p))
                .fold(f32::INFINITY, f32::min)
        })
        .collect()
}

/// Each pair's vertical extent at a place ([`vertical_extent_m`]: how finely it places an echo
/// in height there), the pairs' geometry gathered once.
struct PairLayers {
    geometry: Vec<(crate::sensors::PlanarArray, crate::sensors::VirtualAperture)>,
    wavelength_m: f32,
    bandwidth_hz: f32,
}

impl PairLayers {
    fn new(sc: &Scenario, plans: &[PairPlan]) -> Self {
        PairLayers {
            geometry: plans
                .iter()
                .map(|p| (sc.array(p.bs), sc.aperture(p.aperture, p.positions)))
                .collect(),
            wavelength_m: sc.wavelength_m() as f32,
            bandwidth_hz: (sc.radar.bandwidth_mhz * 1e6) as f32,
        }
    }

    /// Pair `k`'s vertical extent at `p`, metres.
    fn at(&self, k: usize, p: Vec3) -> f32 {
        let (a, ap) = &self.geometry[k];
        vertical_extent_m(p, a, ap, self.wavelength_m, self.bandwidth_hz)
    }
}

/// The fused cloud without the points a finer pair places at another height, and with the points
/// whose surface finer pairs placed within their height cell at the information-weighted height
/// of those placements (`imaging.finer_height_test`, [`super::finer_height`]); unchanged when
/// off.
pub fn finer_heights(sc: &Scenario, plans: &[PairPlan], mut fused: FusedCloud) -> FusedCloud {
    if !sc.imaging.finer_height_test || fused.points.is_empty() {
        return fused;
    }
    let extents = vertical_extents(sc, plans, &fused);
    // The fused points are finite voxel positions; an index error leaves the cloud as it is.
    // Normals over a resolution cell, as the mesher's (imaging::surface).
    let radius = support_distance_m(sc, plans);
    let Ok(h) = heights(&fused.points, &extents, sc.imaging.voxel_m, radius) else {
        return fused;
    };
    let keep: Vec<bool> = h.iter().map(|&h| h != Height::Dropped).collect();
    for (p, h) in fused.points.iter_mut().zip(&h) {
        if let Height::Refined(z) = *h {
            p.z = z;
        }
    }
    FusedCloud {
        finer_heights: h.iter().filter(|&&h| h == Height::Dropped).count(),
        refined_heights: h.iter().filter(|h| matches!(h, Height::Refined(_))).count(),
        ..fused.retain(&keep)
    }
}

/// For each fused point, the (aperture centre, panel centre) of every pair that observed it: the
/// transmitter and receiver of its echo.
pub fn observing_pairs(
    sc: &Scenario,
    plans: &[PairPlan],
    fused: &FusedCloud,
) -> Vec<Vec<[Vec3; 2]>> {
    let per_pair: Vec<[Vec3; 2]> = plans
        .iter()
        .map(|p| [sc.aperture(p.aperture, 2).centre(), sc.array(p.bs).centre])
        .collect();
    fused
        .pair_mask
        .iter()
        .map(|&m| {
            per_pair
                .iter()
                .enumerate()
                .filter(|(k, _)| *k < 64 && (m >> k) & 1 == 1)
                .map(|(_, s)| *s)
                .collect()
        })
        .collect()
}

/// For each fused point, the positions of the sensors (panel centre and aperture centre of every
/// pair) that observed it: what surface normals are oriented toward.
pub fn observing_sensors(sc: &Scenario, plans: &[PairPlan], fused: &FusedCloud) -> Vec<Vec<Vec3>> {
    sensors_of(&observing_pairs(sc, plans, fused))
}

/// The sensor positions of each point's observing pairs ([`observing_pairs`]), receiver then
/// transmitter of each pair: [`observing_sensors`] from pairs already at hand.
pub fn sensors_of(observers: &[Vec<[Vec3; 2]>]) -> Vec<Vec<Vec3>> {
    observers
        .iter()
        .map(|pairs| pairs.iter().flat_map(|&[tx, rx]| [rx, tx]).collect())
        .collect()
}

/// For each ground-truth point, whether some imaged pair could observe it at all: the point sees
/// the pair's panel centre and at least one of the aperture's start, centre and end (both legs of
/// the bistatic path in line of sight; a ray into the solid behind the surface is blocked). The
/// rest of the truth (e.g. valleys of a sawtooth roof below every sensor's line of sight) can only
/// be inferred by the surface reconstruction, never imaged.
pub fn observable_truth(sc: &Scenario, world: &World, plans: &[PairPlan]) -> Vec<bool> {
    let sensors: Vec<(Vec3, [Vec3; 3])> = plans
        .iter()
        .map(|p| {
            let a = sc.aperture(p.aperture, 2);
            (sc.array(p.bs).centre, [a.start, a.centre(), a.end])
        })
        .collect();
    world
        .truth
        .par_iter()
        .zip(&world.truth_normals)
        .map(|(&t, &n)| {
            // Lifted off its face like a scatterer (`echo::visible_for`): a point rounded to
            // just under its face would otherwise be hidden by it from a grazing look, and which
            // points round under depends on the site's orientation.
            let t = t + n * crate::scene::SURFACE_EPS_M;
            sensors.iter().any(|(bs, ap)| {
                world.scene.visible(t, *bs) && ap.iter().any(|&v| world.scene.visible(t, v))
            })
        })
        .collect()
}

/// How far from every imaged point a reconstructed surface is still supported by the imaging,
/// metres: half the coarsest theoretical resolution among the imaged pairs at the region's centre
/// (range, virtual-aperture and both real-aperture cross-ranges,
/// [`super::sensors::pair_resolution_m`]). A fused point stands for a resolution cell, so the
/// surface that produced it lies within half the cell's largest extent; mesh farther than that
/// from every point is the mesher's extrapolation (e.g. a Poisson surface closing an open cloud
/// across a site).
pub fn support_distance_m(sc: &Scenario, plans: &[PairPlan]) -> f32 {
    let centre = sc.region_centre();
    plans
        .iter()
        .map(|p| {
            let (r, xv, xh, xz) = pair_resolution_m(
                centre,
                &sc.array(p.bs),
                &sc.aperture(p.aperture, p.positions),
                sc.wavelength_m() as f32,
                (sc.radar.bandwidth_mhz * 1e6) as f32,
            );
            0.5 * r.max(xv).max(xh).max(xz)
        })
        .fold(0.0, f32::max)
}

/// Percentage of `true` flags (of truth points, e.g. from [`observable_truth`]); 0 for none.
pub fn share_pct(flags: &[bool]) -> f64 {
    100.0 * flags.iter().filter(|&&f| f).count() as f64 / flags.len().max(1) as f64
}

/// A run's results.
pub struct RunResult {
    /// The pairs imaged.
    pub plans: Vec<PairPlan>,
    /// Their images.
    pub images: Vec<PairImage>,
    /// The fused cloud.
    pub fused: FusedCloud,
}

/// Images every planned pair in turn and fuses them. `progress(pair, done, total)` reports frames.
///
/// # Errors
/// [`RunError`].
pub fn run_imaging(
    sc: &Scenario,
    world: &World,
    plans: Vec<PairPlan>,
    opts: RunOptions,
    progress: &(dyn Fn(usize, u64, u64) + Sync),
) -> Result<RunResult, RunError> {
    check_memory(sc)?;
    let mut images = Vec::with_capacity(plans.len());
    for (k, p) in plans.iter().enumerate() {
        let img = image_pair(sc, world, p, opts, &|d, t| progress(k, d, t))?;
        images.push(img);
    }
    Ok(fuse_images(sc, world, plans, images))
}

/// The fused cloud of the pairs' images (one per plan, in order): each pair's slabs collapsed
/// ([`smear_to_centroid`], `imaging.smear_centroid`), then [`fuse`], [`confirm`],
/// [`drop_terrain_echoes`], [`finer_heights`] — what [`run_imaging`] does after imaging,
/// also for pair clouds imaged before (e.g. read back from a run's files).
pub fn fuse_images(
    sc: &Scenario,
    world: &World,
    plans: Vec<PairPlan>,
    images: Vec<PairImage>,
) -> RunResult {
    // Each pair's slabs collapsed to their surfaces ([`smear_to_centroid`]); the pairs' own
    // clouds are returned as imaged, so that a run's saved pair clouds fuse again to the same bits.
    let collapsed: Vec<PairImage> = if sc.imaging.smear_centroid {
        images
            .par_iter()
            .zip(&plans)
            .map(|(img, p)| PairImage {
                points: smear_to_centroid(
                    &img.points,
                    &img.intensity,
                    &sc.array(p.bs),
                    &sc.aperture(p.aperture, p.positions),
                    sc.wavelength_m() as f32,
                    (sc.radar.bandwidth_mhz * 1e6) as f32,
                    sc.imaging.voxel_m,
                ),
                intensity: img.intensity.clone(),
                stats: img.stats.clone(),
            })
            .collect()
    } else {
        images.clone()
    };
    let fused = fuse(sc, &plans, &collapsed, sc.imaging.voxel_m);
    let fused = confirm(sc, world, &plans, &collapsed, fused);
    let fused = drop_terrain_echoes(sc, world, &plans, fused);
    let fused = finer_heights(sc, &plans, fused);
    RunResult {
        plans,
        images,
        fused,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn factory() -> Scenario {
        Scenario::from_toml_str(include_str!("../../../fixtures/factory.toml"))
            .expect("bundled factory")
    }

    #[test]
    fn a_pairs_detection_inside_its_own_layer_on_open_ground_is_its_ground_echo_and_confirms_nothing(
    ) {
        let sc = Scenario::from_toml_str(include_str!("../../../fixtures/suite/factory_site.toml"))
            .expect("factory site");
        let world = build_world(&sc).expect("world");
        let plans = plan_pairs(&sc).expect("pairs");
        let layers = PairLayers::new(&sc, &plans);
        let layer = |k: usize, p: Vec3| layers.at(k, p);
        // Open ground in the region's corner, far from the hall.
        let (lo, _) = sc.region();
        let foot = world
            .terrain
            .below(Vec3::new(lo.x + 3.0, lo.y + 3.0, 50.0))
            .expect("terrain under the region");
        // The pair that places height most finely there and the one that does so most coarsely.
        let by_layer = |k: &usize| layer(*k, foot).to_bits();
        let fine = (0..plans.len()).min_by_key(by_layer).unwrap();
        let coarse = (0..plans.len()).max_by_key(by_layer).unwrap();
        let (lf, lc) = (layer(fine, foot), layer(coarse, foot));
        assert!(lc > 2.0 * lf, "layers {lf} and {lc} m");
        // A point above the fine pair's layer and inside the coarse pair's, kept by the fine pair;
        // the coarse pair detected something next to it.
        let h = 0.5 * (lf + lc).min(2.0 * lf + 0.5 * lc);
        let p = foot + Vec3::Z * h;
        assert!(h > layer(fine, p) && h < layer(coarse, p), "height {h} m");
        let q = p + Vec3::new(0.4, 0.0, 0.0);
        let mut images: Vec<PairImage> = plans
            .iter()
            .map(|_| PairImage {
                points: Vec::new(),
                intensity: Vec::new(),
                stats: Default::default(),
            })
            .collect();
        images[fine].points.push(p);
        images[fine].intensity.push(1.0);
        images[coarse].points.push(q);
        images[coarse].intensity.push(1.0);
        let fused = fuse(&sc, &plans, &images, sc.imaging.voxel_m);
        let support = support_distance_m(&sc, &plans);
        assert!(support > 0.4);
        let own = own_terrain_echoes(&sc, &world, &plans, &images, &fused, support)
            .expect("a known terrain");
        assert_eq!(own.detections[fine], (vec![p], vec![]));
        assert_eq!(own.detections[coarse], (vec![], vec![q]));
        // The fused points: each keeps its pair only where it is not that pair's ground echo.
        for (x, (&m, &m_own)) in fused
            .points
            .iter()
            .zip(fused.pair_mask.iter().zip(&own.mask))
        {
            if *x == p {
                assert_eq!(m_own, m);
            } else {
                assert_eq!(m_own, 0, "the coarse pair's own ground echo");
            }
        }
        // Something of the cloud rising out of the coarse pair's layer there (a wall's image)
        // makes its detection a structure's foot: it confirms again.
        images[coarse].points.push(q + Vec3::Z * (lc + 1.0));
        images[coarse].intensity.push(1.0);
        let fused = fuse(&sc, &plans, &images, sc.imaging.voxel_m);
        let own = own_terrain_echoes(&sc, &world, &plans, &images, &fused, support)
            .expect("a known terrain");
        assert_eq!(own.detections[coarse].1, vec![]);
    }

    #[test]
    fn the_pairing_turns_with_the_site_and_never_takes_a_panel_facing_away() {
        let named = |sc: &Scenario| -> Vec<(String, String)> {
            plan_pairs(sc)
                .expect("pairs")
                .iter()
                .map(|p| {
                    (
                        sc.base_stations[p.bs].name.clone(),
                        sc.apertures[p.aperture].name.clone(),
                    )
                })
                .collect()
        };
        let load = |text: &str| Scenario::from_toml_str(text).expect("scenario");
        let site_text = include_str!("../../../fixtures/suite/factory_site.toml");
        let site = load(site_text);
        let turned = load(include_str!("../../../fixtures/suite/factory_rotated.toml"));
        let pairs = named(&site);
        assert_eq!(pairs.len(), site.apertures.len());
        // The whole site turned by 37° (sensors and region with it): the same pairs.
        assert_eq!(named(&turned), pairs);
        // A real site's polygon region, turned by a non-right angle: the same pairs (the
        // centre each pair is judged at turns with the site; its region's box does not).
        let real = load(include_str!("../../../fixtures/real/sf_element_2172.toml"));
        let real_turned = real
            .turned(
                37.0,
                real.region_footprint_centre() + glam::Vec2::new(0.33, -0.55),
            )
            .expect("turned");
        let every = |sc: &Scenario| -> Vec<String> {
            let plans = every_facing_pair(sc).expect("pairs");
            plans.into_iter().map(|p| p.name).collect()
        };
        assert_eq!(named(&real_turned), named(&real));
        assert_eq!(every(&real_turned), every(&real));
        assert!(every(&real).len() > 20);
        // Each aperture's base station has the finest cell among those facing the centre.
        let centre = site.region_centre();
        for p in plan_pairs(&site).expect("pairs") {
            let cell = |bs| resolution_cell_m(&site, bs, p.aperture, p.positions, centre);
            for bs in 0..site.base_stations.len() {
                assert!(cell(p.bs) <= cell(bs), "{} vs BS {bs}", p.name);
            }
        }
        // Turn the base station the UAV chose away from the site: it is never taken, and every
        // aperture is still paired.
        let (uav_bs, _) = pairs.iter().find(|(_, a)| a == "UAV").expect("UAV").clone();
        let k = site
            .base_stations
            .iter()
            .position(|b| b.name == uav_bs)
            .unwrap();
        let mut away = site.clone();
        away.base_stations[k].boresight_deg += 180.0;
        let pairs_away = named(&away);
        assert_eq!(pairs_away.len(), site.apertures.len());
        assert!(
            pairs_away.iter().all(|(b, _)| *b != uav_bs),
            "{pairs_away:?}"
        );
    }

    /// Every base station that faces the site hears every terminal: each such pair is imaged,
    /// the finest-cell choice among them, and a panel turned away from the site never.
    #[test]
    fn every_base_station_facing_the_site_images_every_terminal_and_none_facing_away() {
        let site =
            Scenario::from_toml_str(include_str!("../../../fixtures/suite/factory_site.toml"))
                .expect("scenario");
        let names = |plans: &[PairPlan]| -> Vec<String> {
            plans.iter().map(|p| p.name.clone()).collect::<Vec<_>>()
        };
        let every = every_facing_pair(&site).expect("pairs");
        let centre = site.region_centre();
        let faces = |sc: &Scenario, bs: usize| {
            let a = sc.array(bs);
            (centre - a.centre).dot(a.boresight()) > 0.0
        };
        let facing = (0..site.base_stations.len())
            .filter(|&bs| faces(&site, bs))
            .count();
        assert!(facing >= 2, "{facing} base stations face the factory site");
        assert_eq!(every.len(), facing * site.apertures.len());
        assert!(every.iter().all(|p| faces(&site, p.bs)));
        let mut unique = names(&every);
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), every.len(), "{unique:?}");
        for p in plan_pairs(&site).expect("pairs") {
            assert!(names(&every).contains(&p.name), "{} not imaged", p.name);
        }
        // A pair that sees the street row near forward scatter (BS3 with V1: a range cell of
        // 8.9 m against the panel's 3.7 m vertically) is left out.
        let street =
            Scenario::from_toml_str(include_str!("../../../fixtures/suite/street_row.toml"))
                .expect("scenario");
        let pairs = names(&every_facing_pair(&street).expect("pairs"));
        assert!(!pairs.contains(&"BS3-V1".to_string()), "{pairs:?}");
        assert!(pairs.len() >= 20, "{pairs:?}");
        // One panel turned away: its pairs go, every other stays.
        let k = every[0].bs;
        let mut away = site.clone();
        away.base_stations[k].boresight_deg += 180.0;
        let rest = every_facing_pair(&away).expect("pairs");
        assert_eq!(rest.len(), every.len() - site.apertures.len());
        assert!(rest.iter().all(|p| p.bs != k));
    }

    /// A survey counts what the pair sees: the UAV with a base station that sees the hall, and
    /// the same pair with a screen 4 m in front of that panel (outside the region, 40 m tall,
    /// 30 m wide), which leaves it the bare terrain's clutter and noise to detect.
    #[test]
    fn a_survey_counts_the_site_a_pair_sees_and_nothing_behind_a_screen() {
        let text = include_str!("../../../fixtures/factory.toml");
        let load = |t: &str| {
            let mut sc = Scenario::from_toml_str(t).expect("scenario");
            sc.apply_quick();
            sc
        };
        let sc = load(text);
        let plan = plan_pairs(&sc)
            .expect("pairs")
            .into_iter()
            .find(|p| sc.apertures[p.aperture].name == "UAV")
            .expect("UAV pair");
        let a = sc.array(plan.bs);
        let c = a.centre + a.boresight() * 4.0;
        let screened = format!(
            "{text}\n[[scene.objects]]\nkind = \"box\"\nname = \"screen\"\nmaterial = \"concrete\"\n\
             center = [{}, {}]\nsize = [1.0, 30.0, 40.0]\nyaw_deg = {}\n",
            c.x,
            c.y,
            a.boresight_az_rad.to_degrees()
        );
        let sc_s = load(&screened);
        assert!(!sc_s.in_region(Vec3::new(c.x, c.y, 10.0)));
        let seen = survey_pair(&sc, &build_world(&sc).expect("world"), &plan).expect("survey");
        let blocked =
            survey_pair(&sc_s, &build_world(&sc_s).expect("world"), &plan).expect("survey");
        assert!(seen > 20, "the hall: {seen} coarse voxels");
        assert!(
            blocked * 10 < seen,
            "behind the screen {blocked}, in view {seen}"
        );
    }

    #[test]
    fn a_pair_images_to_the_same_bits_on_one_thread_and_on_two() {
        let mut sc = factory();
        sc.apply_quick();
        let world = build_world(&sc).expect("world");
        let plan = plan_pairs(&sc)
            .expect("pairs")
            .into_iter()
            .find(|p| sc.apertures[p.aperture].name == "UAV")
            .expect("UAV pair");
        let image = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| image_pair(&sc, &world, &plan, RunOptions::default(), &|_, _| {}))
                .expect("image")
        };
        let (one, two) = (image(1), image(2));
        assert!(!one.points.is_empty());
        let bits = |im: &PairImage| -> Vec<u32> {
            im.points
                .iter()
                .flat_map(|p| p.to_array())
                .chain(im.intensity.iter().copied())
                .map(f32::to_bits)
                .collect()
        };
        assert_eq!(bits(&one), bits(&two));
    }

    #[test]
    fn a_region_beyond_the_machines_memory_is_refused_before_anything_is_built() {
        let mut sc = factory();
        sc.imaging.region_min = [-5000.0, -5000.0, 0.0];
        sc.imaging.region_max = [5000.0, 5000.0, 500.0];
        let (voxels, need) = memory_estimate(&sc);
        assert!(voxels > 1_000_000_000_000 && need > voxels as u64);
        match build_world(&sc) {
            Err(e @ RunError::TooLarge { .. }) => {
                let msg = e.to_string();
                assert!(
                    msg.contains("GiB") && msg.contains("imaging.voxel_m"),
                    "{msg}"
                );
                assert_eq!(msg.lines().count(), 1);
            }
            Err(e) => panic!("unexpected error {e}"),
            Ok(_) => panic!("a 10 km region at 0.25 m was accepted"),
        }
        // Panels of 10⁵ × 10⁵ elements: the frames, not the region, are what does not fit,
        // and the message says which fields to change.
        let mut sc = factory();
        for b in &mut sc.base_stations {
            b.rows = 100_000;
            b.cols = 100_000;
        }
        let msg = build_world(&sc).err().expect("refused").to_string();
        assert!(msg.contains("base_stations[].rows/cols"), "{msg}");
        assert!(!msg.contains("imaging.voxel_m"), "{msg}");
    }

    #[test]
    fn a_turned_site_gets_the_transmit_positions_of_the_unturned_one() {
        let load = |t: &str| Scenario::from_toml_str(t).expect("suite site");
        let site = load(include_str!("../../../fixtures/suite/factory_site.toml"));
        let turned = load(include_str!("../../../fixtures/suite/factory_rotated.toml"));
        assert_eq!(site.apertures.len(), turned.apertures.len());
        for ai in 0..site.apertures.len() {
            let (a, b) = (default_positions(&site, ai), default_positions(&turned, ai));
            // The same track against the same region, turned: the same Nyquist count up to the
            // footprint's sampling (one position).
            assert!(a.abs_diff(b) <= 1, "aperture {ai}: {a} vs {b}");
        }
    }

    #[test]
    fn the_bundled_region_fits() {
        let mut sc = factory();
        let (voxels, need) = memory_estimate(&sc);
        let per_voxel = voxels as u64 * IMAGING_BYTES_PER_VOXEL as u64;
        // One pair's frames are held (data and terrain model), counted: half without the
        // terrain model.
        let frames = need - per_voxel;
        assert!(frames > 0);
        sc.imaging.detection = crate::imaging::Detection::Peak;
        assert_eq!(2 * (memory_estimate(&sc).1 - per_voxel), frames);
        assert!(check_memory(&sc).is_ok());
    }
}
