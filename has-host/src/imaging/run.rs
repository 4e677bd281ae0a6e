//! A whole imaging run: build the world from the scenario, plan the pairs, image each pair,
//! fuse the clouds and score them against the ground truth.
//!
//! **Pairing.** Unless the scenario lists `[[pairs]]`, each aperture is paired with the base
//! station that, together with it, sees the largest area of (non-ground) surface inside the
//! imaging region — visibility from the aperture centre and the array centre, the paper's "which
//! BS pairs with which aperture follows from visibility". Aperture sampling defaults to the
//! Nyquist spacing for the region ([`super::sensors::nyquist_spacing_m`]).
//!
//! **Fusion.** Every pair images on the same voxel lattice, so clouds merge voxel by voxel. A
//! point of pair `k` carries weight `w = (|I|/peak_k) · c_k · q_k`, with `c_k` the pair's coverage
//! relative to the best pair's (square root: area → length scale) and `q_k` the ratio of the
//! finest theoretical resolution cell among pairs to this pair's (geometric mean of range,
//! virtual-aperture and real-aperture cross-range resolutions at the region centre). A fused
//! voxel's weight is the sum over the pairs that kept it; voxels below
//! `imaging.fusion_min_weight` × the largest weight are dropped.
//!
//! **Ground truth.** Uniform area-weighted samples (`imaging.truth_density_per_m2`) on every face of
//! the `imaging.truth_objects` that does not face down (the building's walls and roofs).

use std::collections::HashMap;

use glam::Vec3;

use super::config::ImagingScenario;
use super::driver::{image_pair, ImagingError, PairImage, PairPlan, RunOptions};
use super::sensors::{nyquist_spacing_m, pair_resolution_m};
use rayon::prelude::*;

use crate::echo::{visible_for, ScattererSet};
use crate::scene::Scene;

/// The world a run images.
pub struct World {
    /// The scene with its BVH.
    pub scene: Scene,
    /// Surface scatterers (building density on objects, ground density near the region).
    pub scatterers: ScattererSet,
    /// Ground-truth points on the truth objects.
    pub truth: Vec<Vec3>,
    /// Triangles of the truth objects (for plots).
    pub truth_triangles: Vec<[Vec3; 3]>,
    /// Per object: is it ground.
    pub is_ground: Vec<bool>,
}

/// Errors of a run, beyond the driver's.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The scene could not be built.
    #[error("scene: {0}")]
    Scene(#[from] crate::scenario::SceneSpecError),
    /// Imaging failed.
    #[error(transparent)]
    Imaging(#[from] ImagingError),
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
    /// No pair sees anything.
    #[error("no base station–aperture pair sees the imaging region")]
    NoPairs,
}

/// Builds the scene, the scatterers and the ground truth.
///
/// # Errors
/// [`RunError`] naming what is wrong.
pub fn build_world(sc: &ImagingScenario) -> Result<World, RunError> {
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
    let is_ground: Vec<bool> = scene
        .objects
        .iter()
        .map(|o| sc.imaging.ground_objects.contains(&o.name))
        .collect();
    let (lo, hi) = sc.region();
    let m = sc.imaging.ground_margin_m;
    let ig = is_ground.clone();
    let mut set = ScattererSet::sample_where(
        &scene,
        sc.imaging.scatterer_density_per_m2,
        sc.imaging.seed,
        |o, _| !ig[o as usize],
    )?;
    let ig = is_ground.clone();
    let ground = ScattererSet::sample_where(
        &scene,
        sc.imaging.ground_density_per_m2,
        sc.imaging.seed.wrapping_add(1),
        |o, p| {
            ig[o as usize]
                && p.x >= lo.x - m
                && p.x <= hi.x + m
                && p.y >= lo.y - m
                && p.y <= hi.y + m
        },
    )?;
    set.points.extend(ground.points);
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
    let truth = crate::metrics::sample_triangles(
        &truth_triangles,
        sc.imaging.truth_density_per_m2,
        sc.imaging.seed.wrapping_add(2),
    )?;
    Ok(World {
        scene,
        scatterers: set,
        truth,
        truth_triangles,
        is_ground,
    })
}

/// Nyquist transmit positions of aperture `ai` for the imaging region.
pub fn default_positions(sc: &ImagingScenario, ai: usize) -> usize {
    if let Some(n) = sc.apertures[ai].positions {
        return n;
    }
    let ap = sc.aperture(ai, 2);
    let dir = (ap.end - ap.start).normalize_or_zero();
    let c = ap.centre();
    let (lo, hi) = sc.region();
    let mut max_cos = 0.0f32;
    for i in 0..27 {
        let f = Vec3::new((i % 3) as f32, ((i / 3) % 3) as f32, (i / 9) as f32) * 0.5;
        let p = lo + (hi - lo) * f;
        max_cos = max_cos.max(dir.dot((p - c).normalize_or_zero()).abs());
    }
    let half_angle = max_cos.clamp(1e-3, 1.0).asin();
    let d = nyquist_spacing_m(sc.wavelength_m() as f32, half_angle);
    (ap.length_m() / d).ceil() as usize + 1
}

/// The pairs to image (see module docs), in aperture order.
///
/// # Errors
/// [`RunError::NoPairs`] if no pair sees any surface in the region.
pub fn plan_pairs(sc: &ImagingScenario, world: &World) -> Result<Vec<PairPlan>, RunError> {
    let (lo, hi) = sc.region();
    let coverage = |bs: usize, ai: usize| -> Result<f64, RunError> {
        let a = sc.array(bs);
        let ap = sc.aperture(ai, 2);
        let vis = visible_for(&world.scatterers, &world.scene, ap.centre(), a.centre)?;
        Ok(vis
            .iter()
            .map(|&i| &world.scatterers.points[i as usize])
            .filter(|s| {
                !world.is_ground[s.object as usize]
                    && s.pos.cmpge(lo).all()
                    && s.pos.cmple(hi).all()
            })
            .map(|s| s.area_m2 as f64)
            .sum())
    };
    let mut plans = Vec::new();
    let mk = |bs: usize, ai: usize, cov: f64| pair_plan(sc, bs, ai, cov);
    if sc.pairs.is_empty() {
        for ai in 0..sc.apertures.len() {
            let mut best = (0usize, 0.0f64);
            for bs in 0..sc.base_stations.len() {
                let c = coverage(bs, ai)?;
                if c > best.1 {
                    best = (bs, c);
                }
            }
            if best.1 > 0.0 {
                plans.push(mk(best.0, ai, best.1));
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
            plans.push(mk(bs, ai, coverage(bs, ai)?));
        }
    }
    if plans.is_empty() {
        return Err(RunError::NoPairs);
    }
    Ok(plans)
}

/// Every (base station, aperture) combination of the scenario, whether or not [`plan_pairs`]
/// would image it (coverage left at 0): with [`observable_truth`], how much of the truth any
/// pairing of these sensors could observe — the ceiling of the pairing choice.
pub fn every_pairing(sc: &ImagingScenario) -> Vec<PairPlan> {
    (0..sc.base_stations.len())
        .flat_map(|bs| (0..sc.apertures.len()).map(move |ai| pair_plan(sc, bs, ai, 0.0)))
        .collect()
}

/// The plan of base station `bs` with aperture `ai` (named `"BS-aperture"`, default sampling).
fn pair_plan(sc: &ImagingScenario, bs: usize, ai: usize, coverage_m2: f64) -> PairPlan {
    PairPlan {
        name: format!("{}-{}", sc.base_stations[bs].name, sc.apertures[ai].name),
        bs,
        aperture: ai,
        positions: default_positions(sc, ai),
        coverage_m2,
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
}

/// Fuses the pairs' clouds (module docs).
pub fn fuse(
    sc: &ImagingScenario,
    plans: &[PairPlan],
    images: &[PairImage],
    voxel_m: f32,
) -> FusedCloud {
    let (lo, hi) = sc.region();
    let centre = (lo + hi) * 0.5;
    let best_cov = plans
        .iter()
        .map(|p| p.coverage_m2)
        .fold(0.0, f64::max)
        .max(1e-9);
    let cells: Vec<f32> = plans
        .iter()
        .map(|p| {
            let a = sc.array(p.bs);
            let ap = sc.aperture(p.aperture, p.positions);
            let (r, xv, _xh, xz) = pair_resolution_m(
                centre,
                &a,
                &ap,
                sc.wavelength_m() as f32,
                (sc.radar.bandwidth_mhz * 1e6) as f32,
            );
            (r * xv * xz).cbrt()
        })
        .collect();
    let best_cell = cells.iter().copied().fold(f32::INFINITY, f32::min);
    let factors: Vec<f32> = plans
        .iter()
        .zip(&cells)
        .map(|(p, &c)| ((p.coverage_m2 / best_cov).sqrt() as f32) * (best_cell / c))
        .collect();
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

/// For each fused point, the (aperture centre, panel centre) of every pair that observed it: the
/// transmitter and receiver of its echo.
pub fn observing_pairs(
    sc: &ImagingScenario,
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
pub fn observing_sensors(
    sc: &ImagingScenario,
    plans: &[PairPlan],
    fused: &FusedCloud,
) -> Vec<Vec<Vec3>> {
    observing_pairs(sc, plans, fused)
        .into_iter()
        .map(|pairs| pairs.into_iter().flat_map(|[tx, rx]| [rx, tx]).collect())
        .collect()
}

/// For each ground-truth point, whether some imaged pair could observe it at all: the point sees
/// the pair's panel centre and at least one of the aperture's start, centre and end (both legs of
/// the bistatic path in line of sight; a ray into the solid behind the surface is blocked). The
/// rest of the truth (e.g. valleys of a sawtooth roof below every sensor's line of sight) can only
/// be inferred by the surface reconstruction, never imaged.
pub fn observable_truth(sc: &ImagingScenario, world: &World, plans: &[PairPlan]) -> Vec<bool> {
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
        .map(|&t| {
            sensors.iter().any(|(bs, ap)| {
                world.scene.visible(t, *bs) && ap.iter().any(|&v| world.scene.visible(t, v))
            })
        })
        .collect()
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
    sc: &ImagingScenario,
    world: &World,
    plans: Vec<PairPlan>,
    opts: RunOptions,
    progress: &(dyn Fn(usize, u64, u64) + Sync),
) -> Result<RunResult, RunError> {
    let mut images = Vec::with_capacity(plans.len());
    for (k, p) in plans.iter().enumerate() {
        let img = image_pair(sc, &world.scene, &world.scatterers, p, opts, &|d, t| {
            progress(k, d, t)
        })?;
        images.push(img);
    }
    let fused = fuse(sc, &plans, &images, sc.imaging.voxel_m);
    Ok(RunResult {
        plans,
        images,
        fused,
    })
}
