//! The paper's §1 as one library call: image every planned base station–terminal pair, fuse,
//! mesh the fused cloud into the digital twin's surface, and score cloud and mesh against the
//! truth. `has-sim reconstruct` is this call plus files; `channel` and `localize` ray-trace the
//! mesh of a [`Twin`] (the reconstruction with the default options, [`reconstruct_twin`]) when no
//! twin is given.
//!
//! Two steps, so that a caller can show per-pair progress before the long one:
//! [`prepare`] builds the world and plans the pairs ([`Prepared`]); [`Prepared::reconstruct`]
//! runs the imaging (`progress(pair, frames done, frames total)`), the surface and the metrics,
//! and returns a typed, `Serialize` [`ReconstructReport`] beside the data it summarises.
//!
//! Units: metres, seconds; metrics as [`crate::metrics`] (eq. 2 and 3 of the paper, S1 the
//! reconstruction, S2 the truth samples); mesh metrics on area samples of the mesh at the truth's
//! density.

mod run_report;
pub mod shard;
mod stages;

use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use crate::imaging::PairImage;
use crate::imaging::{
    self, FusedCloud, PairPlan, PairStats, RunError, RunOptions, RunResult, Scenario, Surface,
    SurfaceOptions, VisibilityFiltered, World,
};
use crate::knn::GeometryError;
use crate::mesh::TriMesh;
use crate::metrics::{surface_area_metrics, CloudComparison, CloudMetrics, ObservableCompleteness};

pub use run_report::ReconstructRunReport;
pub use shard::{Shard, ShardImages, ShardRecord};
pub use stages::{StageTime, StageTimes};

/// Why a reconstruction failed.
#[derive(Debug, thiserror::Error)]
pub enum ReconstructError {
    /// Building the world, planning or imaging.
    #[error(transparent)]
    Run(#[from] RunError),
    /// Meshing or scoring.
    #[error("surface reconstruction: {0}")]
    Surface(GeometryError),
    /// Scoring the cloud.
    #[error("metrics: {0}")]
    Metrics(GeometryError),
    /// Pair clouds read back that do not match the planned pairs (a missing or unreadable
    /// file, another scenario's run).
    #[error("pair clouds: {0}")]
    PairImages(String),
    /// No fused point survived detection, confirmation and the terrain-echo test: nothing to
    /// score or mesh.
    #[error(
        "imaging: the fused cloud is empty ({pairs} pairs imaged, {detected} points detected, \
         {unconfirmed} unconfirmed and {terrain} terrain echoes removed)"
    )]
    EmptyCloud {
        /// Pairs imaged.
        pairs: usize,
        /// Points the pairs detected, before fusion.
        detected: usize,
        /// Fused points removed by the cross-pair confirmation.
        unconfirmed: usize,
        /// Fused points removed as terrain echoes.
        terrain: usize,
    },
}

/// Options of [`Prepared::reconstruct`].
#[derive(Clone, Debug)]
pub struct ReconstructOptions {
    /// Imaging path (f32 or Q15) and echo kind.
    pub run: RunOptions,
    /// The surface stage; `None` skips it.
    pub surface: Option<SurfaceOptions>,
}

/// The world and the planned pairs of a scenario, ready to image.
pub struct Prepared<'a> {
    /// The scenario.
    pub scenario: &'a Scenario,
    /// Scene, scatterers, truth and terrain.
    pub world: World,
    /// The pairs that will be imaged, in order (the `pair` index of the progress callback).
    pub plans: Vec<PairPlan>,
    t0: Instant,
    setup_s: f64,
}

/// Builds the world and plans the pairs of `sc` (already validated; apply the quick preset
/// before).
///
/// # Errors
/// [`ReconstructError::Run`]: a scene that does not build, a region over the memory budget.
pub fn prepare(sc: &Scenario) -> Result<Prepared<'_>, ReconstructError> {
    let t0 = Instant::now();
    let world = imaging::build_world(sc)?;
    let plans = imaging::choose_pairs(sc, &world)?;
    Ok(Prepared {
        scenario: sc,
        world,
        plans,
        t0,
        setup_s: t0.elapsed().as_secs_f64(),
    })
}

/// [`prepare`] then [`Prepared::reconstruct`], for callers that do not show per-pair progress
/// before the imaging starts.
///
/// # Errors
/// [`ReconstructError`].
pub fn reconstruct(
    sc: &Scenario,
    opts: &ReconstructOptions,
    progress: &(dyn Fn(usize, u64, u64) + Sync),
) -> Result<Reconstruction, ReconstructError> {
    prepare(sc)?.reconstruct(opts, progress)
}

/// The digital twin of `sc`: [`prepare`] then [`Prepared::reconstruct_twin`] (the reconstruction
/// with [`ReconstructOptions::default`]), for callers that do not show per-pair progress before
/// the imaging starts. Apply the quick preset to `sc` before, if wanted.
///
/// # Errors
/// [`ReconstructError`].
pub fn reconstruct_twin(
    sc: &Scenario,
    progress: &(dyn Fn(usize, u64, u64) + Sync),
) -> Result<Twin, ReconstructError> {
    prepare(sc)?.reconstruct_twin(progress)
}

impl Default for ReconstructOptions {
    /// f32 imaging of range-compressed profiles, the surface with its default options.
    fn default() -> Self {
        ReconstructOptions {
            run: RunOptions::default(),
            surface: Some(SurfaceOptions::default()),
        }
    }
}

/// What [`Prepared::reconstruct`] produced: the data and its report.
pub struct Reconstruction {
    /// Scene, scatterers, truth and terrain.
    pub world: World,
    /// The pairs' images and the fused cloud.
    pub result: RunResult,
    /// The meshed surface, unless skipped.
    pub surface: Option<Surface>,
    /// Area samples of the mesh at the truth's density (what its metrics were computed on).
    pub mesh_samples: Vec<Vec3>,
    /// The planar twin ([`crate::twin`]) of the fused cloud, built beside the mesh (`None` where
    /// the surface stage was skipped or the twin could not be built: the report says why).
    pub planar_twin: Option<crate::twin::Twin>,
    /// The figures.
    pub report: ReconstructReport,
}

/// The planar twin's figures in a run ([`crate::twin`]).
#[derive(Clone, Debug, Serialize)]
pub struct PlanarTwinReport {
    /// Its walls and roofs scored as the mesh is (`None` when it was not built).
    pub metrics: Option<crate::twin::TwinMetrics>,
    /// Faces: total, walls, roofs, ground.
    pub faces: [usize; 4],
    /// Faces no detected plane supports (inferred).
    pub inferred_faces: usize,
    /// Buildings (connected footprints).
    pub buildings: usize,
    /// Closed, every edge of two faces.
    pub watertight: bool,
    /// Build and scoring time, seconds.
    pub seconds: f64,
    /// Why the twin was not built, if it was not.
    pub error: Option<String>,
}

/// A digital twin ([`reconstruct_twin`], [`Prepared::reconstruct_twin`]): a reconstruction with
/// [`ReconstructOptions::default`], whose surface stage therefore ran; its mesh is the twin that
/// `channel` and `localize` ray-trace when no mesh is given.
pub struct Twin(Reconstruction);

impl Twin {
    /// The twin's mesh: the reconstructed surface.
    pub fn mesh(&self) -> &TriMesh {
        &self.surface().mesh
    }

    /// The surface stage's result: the mesh and the mesher's input.
    pub fn surface(&self) -> &Surface {
        self.0
            .surface
            .as_ref()
            .expect("a twin is reconstructed with its surface stage")
    }

    /// The whole reconstruction: clouds, surface, report.
    pub fn reconstruction(&self) -> &Reconstruction {
        &self.0
    }

    /// The whole reconstruction, by value.
    pub fn into_reconstruction(self) -> Reconstruction {
        self.0
    }
}

/// One imaged pair in a [`ReconstructReport`].
#[derive(Clone, Debug, Serialize)]
pub struct PairReport {
    /// `BS-aperture`.
    pub name: String,
    /// The base station's name.
    pub base_station: String,
    /// The aperture's name.
    pub aperture: String,
    /// Aperture positions imaged.
    pub aperture_positions: usize,
    /// The pair's theoretical resolution cell at the region's centre, metres
    /// ([`imaging::resolution_cell_m`]).
    pub resolution_cell_m: f32,
    /// The pair's factor in the fusion.
    pub fusion_factor: f32,
    /// Detections.
    pub points: usize,
    /// The pair's own cloud against the whole truth (`None` if it detected nothing).
    pub metrics_against_whole_truth: Option<CloudMetrics>,
    /// Work and timing of the pair.
    pub stats: PairStats,
}

/// The fused cloud's figures.
#[derive(Clone, Debug, Serialize)]
pub struct PointCloudReport {
    /// Against the whole truth.
    #[serde(flatten)]
    pub metrics: CloudMetrics,
    /// Completeness on the observable and the hidden truth.
    pub observable_truth: ObservableCompleteness,
    /// Points the cross-pair confirmation removed.
    pub unconfirmed_removed: usize,
    /// Points removed as echoes of the known terrain (`imaging.terrain_echo_test`).
    pub terrain_echoes_removed: usize,
    /// The pairs' detections that were each pair's own terrain echo (inside its layer over the
    /// terrain, under nothing that rises out of it), which confirm nothing; summed over pairs.
    pub pair_ground_echoes: usize,
    /// Points removed as copies of a surface a finer pair placed at another height
    /// (`imaging.finer_height_test`).
    pub finer_heights_removed: usize,
    /// Points moved to the information-weighted height of the finer placements of their surface
    /// (`imaging.finer_height_test`).
    pub finer_heights_refined: usize,
}

/// What the ground truth is and how much of it the imaged pairs could see.
#[derive(Clone, Debug, Serialize)]
pub struct GroundTruthReport {
    /// The truth objects' names.
    pub objects: Vec<String>,
    /// Sampling density, points per m².
    pub density_per_m2: f64,
    /// Which faces are sampled.
    pub surfaces: &'static str,
    /// Percentage of truth points in line of sight of some imaged pair.
    pub observable_pct: f64,
    /// What `observable_pct` counts.
    pub observable: &'static str,
    /// The same for every base station–aperture combination.
    pub observable_any_pairing_pct: f64,
    /// What `observable_any_pairing_pct` counts.
    pub observable_any_pairing: &'static str,
}

/// The imaging half of a [`ReconstructReport`].
#[derive(Clone, Debug, Serialize)]
pub struct ImagingReport {
    /// The fused cloud.
    pub point_cloud: PointCloudReport,
    /// Fine voxel edge, metres.
    pub voxel_m: f32,
    /// Every imaged pair.
    pub pairs: Vec<PairReport>,
    /// Surface scatterers of the simulated scene.
    pub scatterers: usize,
    /// The truth.
    pub ground_truth: GroundTruthReport,
}

/// The mesh's figures and how it was made.
#[derive(Clone, Debug, Serialize)]
pub struct MeshReport {
    /// Its area samples against the whole truth.
    #[serde(flatten)]
    pub metrics: CloudMetrics,
    /// Completeness on the observable and the hidden truth.
    pub observable_truth: ObservableCompleteness,
    /// Share of the mesh's area farther than 1.5 m from the truth, percent.
    pub false_surface_pct_1_5m: f64,
    /// Mesh area over the truth's.
    pub area_ratio: f64,
    /// Mesh area, m².
    pub area_m2: f64,
    /// Truth area, m².
    pub truth_area_m2: f64,
    /// Vertices.
    pub vertices: usize,
    /// Faces.
    pub faces: usize,
    /// Closed.
    pub watertight: bool,
    /// Every edge of at most two faces, every vertex one fan.
    pub manifold: bool,
    /// Poisson depth.
    pub depth: u32,
    /// Finest Poisson cell, metres.
    pub cell_m: f32,
    /// The box the mesh was clipped to, metres.
    pub clip_box: [[f32; 3]; 2],
    /// Support clip distance, metres.
    pub support_distance_m: Option<f32>,
    /// [`imaging::surface::MIN_COMPONENT_FRACTION`].
    pub min_component_fraction: f32,
    /// What the visibility filter did, if it ran.
    pub visibility_filter: Option<VisibilityFiltered>,
    /// Points left out of the mesher's input by the facing rule.
    pub facing_away_points: usize,
    /// Samples added below the walls down to what they stand on
    /// ([`imaging::wall_columns`]; 0 with the option off or the terrain unknown).
    pub wall_column_samples: usize,
    /// Samples added below the outer edges of the imaged roofs down to what they stand on
    /// ([`imaging::wall_columns::roof_edge_walls`]; 0 with the option off or the terrain
    /// unknown), after the wall columns' in the mesher's input.
    pub roof_edge_samples: usize,
    /// Samples of the roofs added over imaged walls where no pair saw a roof
    /// ([`imaging::hidden_roofs`]; 0 with the option off or the terrain unknown), before the
    /// roof-edge walls' in the mesher's input.
    pub hidden_roof_samples: usize,
    /// Samples of the walls across the gaps along the sides of the footprints
    /// ([`imaging::outline_walls`]; 0 with the option off or the terrain unknown), after the
    /// roof-edge walls' in the mesher's input.
    pub outline_wall_samples: usize,
    /// Samples of the roof slopes continued down to a face rising above them and of that face
    /// down to the slope ([`imaging::valleys`]; 0 with the option off or the terrain unknown).
    pub valley_samples: usize,
    /// Inferred samples left out because a pair's leg passed through them to a surface it
    /// detected farther on ([`imaging::free_space`]).
    pub free_space_samples: usize,
    /// Each building's footprint as read from its imaged walls ([`imaging::hidden_roofs`]):
    /// its roof, and inside it the inferred walls stand on that roof
    /// ([`imaging::hidden_roofs::standing_on`]).
    pub footprints: Vec<imaging::hidden_roofs::Footprint>,
    /// Density trim fraction, if any (none by default).
    pub trim_median_fraction: Option<f32>,
    /// What weighs the samples.
    pub sample_weights: &'static str,
    /// Area samples per m² for the metrics.
    pub sample_density_per_m2: f64,
    /// Surface stage time, seconds.
    pub seconds: f64,
}

/// How the figures are defined.
#[derive(Clone, Debug, Serialize)]
pub struct Conventions {
    /// Eq. 2.
    pub chamfer: &'static str,
    /// Eq. 3.
    pub fscore: &'static str,
    /// S1.
    pub s1: &'static str,
    /// S2.
    pub s2: &'static str,
}

/// Where the time went, seconds. `wall` and `postprocess` are the library's own; a caller that
/// writes files may extend them.
#[derive(Clone, Debug, Serialize)]
pub struct Timings {
    /// From [`prepare`] to the end.
    pub wall: f64,
    /// [`prepare`].
    pub setup: f64,
    /// Imaging and fusion.
    pub imaging: f64,
    /// Back-projection, summed over pairs.
    pub backprojection: f64,
    /// Scoring the cloud (and whatever the caller adds).
    pub postprocess: f64,
}

/// Everything [`Prepared::reconstruct`] measured.
#[derive(Clone, Debug, Serialize)]
pub struct ReconstructReport {
    /// Back-projection path.
    pub path: &'static str,
    /// Echo kind.
    pub echo: &'static str,
    /// Imaging and fused cloud.
    pub imaging: ImagingReport,
    /// The mesh (`None` when skipped).
    pub mesh: Option<MeshReport>,
    /// The planar twin (`None` when the surface stage was skipped).
    pub planar_twin: Option<PlanarTwinReport>,
    /// Definitions.
    pub conventions: Conventions,
    /// Timings.
    pub timings_s: Timings,
    /// Backprojections (voxel × element × position updates).
    pub backprojections: f64,
    /// Their rate over the back-projection time.
    pub backprojections_per_s: f64,
    /// Rayon threads.
    pub threads: usize,
}

impl Prepared<'_> {
    /// The digital twin: [`Prepared::reconstruct`] with [`ReconstructOptions::default`] (f32
    /// imaging of range-compressed profiles, the surface with its default options).
    ///
    /// # Errors
    /// [`ReconstructError`].
    pub fn reconstruct_twin(
        self,
        progress: &(dyn Fn(usize, u64, u64) + Sync),
    ) -> Result<Twin, ReconstructError> {
        self.reconstruct(&ReconstructOptions::default(), progress)
            .map(Twin)
    }

    /// Images, fuses, meshes and scores (module docs). `progress(pair, done, total)` reports
    /// frames of pair `pair` (an index into [`Prepared::plans`]).
    ///
    /// # Errors
    /// [`ReconstructError`].
    pub fn reconstruct(
        self,
        opts: &ReconstructOptions,
        progress: &(dyn Fn(usize, u64, u64) + Sync),
    ) -> Result<Reconstruction, ReconstructError> {
        let t1 = Instant::now();
        let result =
            imaging::run_imaging(self.scenario, &self.world, self.plans, opts.run, progress)?;
        let t_imaging = t1.elapsed().as_secs_f64();
        let echo = if opts.run.raw_ofdm {
            "raw_ofdm_range_compressed_by_has_dsp"
        } else {
            "direct_range_compressed_profiles"
        };
        let run = Imaged {
            scenario: self.scenario,
            world: self.world,
            t0: self.t0,
            setup_s: self.setup_s,
            t_imaging,
            echo,
        };
        run.finish(result, opts)
    }

    /// Images only the pairs of `shard` ([`shard`] module docs) and stops there: no fusion,
    /// surface or scores. The pair clouds are those [`Prepared::reconstruct`] would image (each
    /// pair's draw depends on the pair, not on the others imaged), for
    /// [`Prepared::reconstruct_from_images`] to fuse with the other shards' later.
    /// `progress(pair, done, total)` as [`Prepared::reconstruct`], `pair` an index into
    /// [`Prepared::plans`].
    ///
    /// # Errors
    /// [`ReconstructError::Run`]: a region over the memory budget, imaging.
    pub fn image_shard(
        self,
        shard: Shard,
        opts: RunOptions,
        progress: &(dyn Fn(usize, u64, u64) + Sync),
    ) -> Result<ShardImages, ReconstructError> {
        imaging::check_memory(self.scenario)?;
        let t1 = Instant::now();
        let pairs = shard.pairs(self.plans.len());
        let mut images = Vec::with_capacity(pairs.len());
        for &k in &pairs {
            let img =
                imaging::image_pair(self.scenario, &self.world, &self.plans[k], opts, &|d, t| {
                    progress(k, d, t)
                })
                .map_err(RunError::from)?;
            images.push(img);
        }
        let timings_s = shard::ShardTimings {
            setup: self.setup_s,
            imaging: t1.elapsed().as_secs_f64(),
            synthesis: images.iter().map(|im| im.stats.synth_s).sum(),
            backprojection: images.iter().map(|im| im.stats.bp_s).sum(),
        };
        Ok(ShardImages {
            world: self.world,
            shard,
            planned: self.plans,
            pairs,
            images,
            timings_s,
        })
    }

    /// [`Prepared::reconstruct`] from pair clouds imaged before — `images[k]` the points and
    /// intensities of [`Prepared::plans`]`[k]`, e.g. read back from a run's files with
    /// [`read_pair_images`] — instead of imaging: fusion, confirmation, the terrain-echo and
    /// finer-height tests, the surface and the scores, as after imaging. The report's work and
    /// timing figures of the pairs are zero; its `echo` says where the clouds came from.
    ///
    /// # Errors
    /// [`ReconstructError::PairImages`] when `images` does not hold one cloud per plan;
    /// otherwise as [`Prepared::reconstruct`].
    pub fn reconstruct_from_images(
        self,
        images: Vec<PairImage>,
        opts: &ReconstructOptions,
    ) -> Result<Reconstruction, ReconstructError> {
        if images.len() != self.plans.len() {
            return Err(ReconstructError::PairImages(format!(
                "{} pair clouds for {} planned pairs",
                images.len(),
                self.plans.len()
            )));
        }
        let t1 = Instant::now();
        let result = imaging::fuse_images(self.scenario, &self.world, self.plans, images);
        let run = Imaged {
            scenario: self.scenario,
            world: self.world,
            t0: self.t0,
            setup_s: self.setup_s,
            t_imaging: t1.elapsed().as_secs_f64(),
            echo: "pair_clouds_read_back",
        };
        run.finish(result, opts)
    }
}

/// The pair clouds a reconstruction wrote into `dir` (`pair_<name>.ply`, each vertex with its
/// `intensity`), one per plan of `prepared` in order, for [`Prepared::reconstruct_from_images`].
/// The clouds must come from a run of the same scenario and preset: the pairs are matched by
/// name only (`has-sim reconstruct --from-pairs` compares the run's scenario digest first).
///
/// # Errors
/// [`ReconstructError::PairImages`] naming the file that is missing, unreadable, without an
/// `intensity` property, or with a non-finite point or intensity, or a point far outside the
/// imaging region (by more than a tenth of its largest extent and a coarse voxel: no pair of
/// this scenario imaged it).
pub fn read_pair_images(
    dir: &std::path::Path,
    prepared: &Prepared<'_>,
) -> Result<Vec<PairImage>, ReconstructError> {
    read_pair_images_from(&vec![dir; prepared.plans.len()], prepared)
}

/// [`read_pair_images`] with each pair's cloud read from its own directory: `dirs[k]` holds
/// `pair_<name>.ply` of [`Prepared::plans`]`[k]` (the shards' directories, matched to the pairs
/// by [`shard::assign_pairs`]). The images come back in the scenario's pair order whatever the
/// directories.
///
/// # Errors
/// [`ReconstructError::PairImages`] when `dirs` does not name one directory per plan, or as
/// [`read_pair_images`].
pub fn read_pair_images_from(
    dirs: &[&std::path::Path],
    prepared: &Prepared<'_>,
) -> Result<Vec<PairImage>, ReconstructError> {
    if dirs.len() != prepared.plans.len() {
        return Err(ReconstructError::PairImages(format!(
            "{} directories for {} planned pairs",
            dirs.len(),
            prepared.plans.len()
        )));
    }
    let (lo, hi) = prepared.scenario.region();
    let margin = 0.1 * (hi - lo).max_element() + prepared.scenario.imaging.coarse_voxel_m;
    let (lo, hi) = (lo - Vec3::splat(margin), hi + Vec3::splat(margin));
    prepared
        .plans
        .iter()
        .zip(dirs)
        .map(|(p, dir)| {
            let path = dir.join(format!("pair_{}.ply", p.name));
            let bad =
                |why: String| ReconstructError::PairImages(format!("{}: {why}", path.display()));
            let data = crate::io::ply::read_ply(&path).map_err(|e| bad(e.to_string()))?;
            let intensity = data
                .properties
                .into_iter()
                .find(|(n, _)| n == "intensity")
                .map(|(_, v)| v)
                .ok_or_else(|| bad("no vertex property `intensity`".into()))?;
            if let Some(i) = data.vertices.iter().position(|v| !v.is_finite()) {
                return Err(bad(format!("vertex {i} is not finite")));
            }
            if let Some((i, v)) = data
                .vertices
                .iter()
                .enumerate()
                .find(|(_, v)| !(v.cmpge(lo).all() && v.cmple(hi).all()))
            {
                return Err(bad(format!(
                    "vertex {i} at {v} lies outside the imaging region (within {margin} m): not \
                     a pair cloud of this scenario"
                )));
            }
            if let Some(i) = intensity.iter().position(|v| !v.is_finite()) {
                return Err(bad(format!("intensity of vertex {i} is not finite")));
            }
            Ok(PairImage {
                points: data.vertices,
                intensity,
                stats: Default::default(),
            })
        })
        .collect()
}

/// A scenario's world after imaging (or reading back) its pairs, with the times so far.
struct Imaged<'a> {
    scenario: &'a Scenario,
    world: World,
    t0: Instant,
    setup_s: f64,
    t_imaging: f64,
    echo: &'static str,
}

impl Imaged<'_> {
    /// Scores the fused cloud, meshes and scores the surface, and writes the report.
    fn finish(
        self,
        result: RunResult,
        opts: &ReconstructOptions,
    ) -> Result<Reconstruction, ReconstructError> {
        let sc = self.scenario;
        let world = self.world;
        let t_imaging = self.t_imaging;

        let t2 = Instant::now();
        let fused: &FusedCloud = &result.fused;
        if fused.points.is_empty() {
            return Err(ReconstructError::EmptyCloud {
                pairs: result.plans.len(),
                detected: result.images.iter().map(|im| im.points.len()).sum(),
                unconfirmed: fused.unconfirmed,
                terrain: fused.terrain_echoes,
            });
        }
        let n_truth = world.truth.len();
        let cmp =
            CloudComparison::new(&fused.points, &world.truth).map_err(ReconstructError::Metrics)?;
        let observable = imaging::observable_truth(sc, &world, &result.plans);
        let point_cloud = PointCloudReport {
            metrics: CloudMetrics::new(&cmp, fused.points.len(), n_truth)
                .map_err(ReconstructError::Metrics)?,
            observable_truth: ObservableCompleteness::new(&cmp, &observable),
            unconfirmed_removed: fused.unconfirmed,
            terrain_echoes_removed: fused.terrain_echoes,
            pair_ground_echoes: fused.pair_ground_echoes,
            finer_heights_removed: fused.finer_heights,
            finer_heights_refined: fused.refined_heights,
        };
        let any_pairing_pct = imaging::share_pct(&imaging::observable_truth(
            sc,
            &world,
            &imaging::every_pairing(sc),
        ));
        let region_centre = sc.region_centre();
        let (mut total_bp, mut total_bp_s) = (0.0, 0.0);
        let mut pairs = Vec::with_capacity(result.plans.len());
        for (k, (p, img)) in result.plans.iter().zip(&result.images).enumerate() {
            total_bp += img.stats.backprojections;
            total_bp_s += img.stats.bp_s;
            let metrics_against_whole_truth = if img.points.is_empty() {
                None
            } else {
                let c = CloudComparison::new(&img.points, &world.truth)
                    .map_err(ReconstructError::Metrics)?;
                Some(
                    CloudMetrics::new(&c, img.points.len(), n_truth)
                        .map_err(ReconstructError::Metrics)?,
                )
            };
            pairs.push(PairReport {
                name: p.name.clone(),
                base_station: sc.base_stations[p.bs].name.clone(),
                aperture: sc.apertures[p.aperture].name.clone(),
                aperture_positions: p.positions,
                resolution_cell_m: imaging::resolution_cell_m(
                    sc,
                    p.bs,
                    p.aperture,
                    p.positions,
                    region_centre,
                ),
                fusion_factor: fused.pair_factor[k],
                points: img.points.len(),
                metrics_against_whole_truth,
                stats: img.stats.clone(),
            });
        }
        let imaging = ImagingReport {
            point_cloud,
            voxel_m: sc.imaging.voxel_m,
            pairs,
            scatterers: world.scatterers.len(),
            ground_truth: GroundTruthReport {
                objects: sc.imaging.truth_objects.clone(),
                density_per_m2: sc.imaging.truth_density_per_m2,
                surfaces: "every face of the truth objects not facing down (walls and roof)",
                observable_pct: imaging::share_pct(&observable),
                observable: "truth points in line of sight of some imaged pair's panel and aperture (imaging::observable_truth)",
                observable_any_pairing_pct: any_pairing_pct,
                observable_any_pairing: "the same for every base station–aperture combination of the scenario (imaging::every_pairing): the ceiling of the pairing choice",
            },
        };
        let t_post = t2.elapsed().as_secs_f64();

        let (surface, mesh_samples, mesh) = match &opts.surface {
            None => (None, Vec::new(), None),
            Some(so) => {
                let (surf, samples, m) = mesh_stage(sc, &world, &result, &observable, so)?;
                (Some(surf), samples, Some(m))
            }
        };
        let (planar_twin, planar_twin_report) = match &mesh {
            None => (None, None),
            Some(m) => {
                let (t, r) = planar_twin_stage(sc, &world, &result, m.sample_density_per_m2);
                (t, Some(r))
            }
        };
        let report = ReconstructReport {
            path: if opts.run.fixed_point {
                "fixed_point_q15"
            } else {
                "f32"
            },
            echo: self.echo,
            imaging,
            mesh,
            planar_twin: planar_twin_report,
            conventions: Conventions {
                chamfer: "eq. 2: mean over S1 of min squared distance to S2 plus mean over S2 of min squared distance to S1; reported as sqrt (m)",
                fscore: "eq. 3: 2PR/(P+R), P = % of S1 within d of S2, R = % of S2 within d of S1 (strict <)",
                s1: "fused imaging point cloud (voxel positions)",
                s2: "ground-truth samples on the true building surfaces",
            },
            timings_s: Timings {
                wall: self.t0.elapsed().as_secs_f64(),
                setup: self.setup_s,
                imaging: t_imaging,
                backprojection: total_bp_s,
                postprocess: t_post,
            },
            backprojections: total_bp,
            backprojections_per_s: total_bp / f64::max(total_bp_s, 1e-9),
            threads: rayon::current_num_threads(),
        };
        Ok(Reconstruction {
            world,
            result,
            surface,
            mesh_samples,
            planar_twin,
            report,
        })
    }
}

/// Builds the planar twin of the fused cloud ([`crate::twin::build`]) on the known terrain's
/// height, with the pairs' clouds as its views, and scores it as the mesh is scored (area
/// samples at `density_per_m2`). A twin that cannot be built (no known terrain, no building in
/// the evidence) is not an error of the run: the report says why.
fn planar_twin_stage(
    sc: &Scenario,
    world: &World,
    result: &RunResult,
    density_per_m2: f64,
) -> (Option<crate::twin::Twin>, PlanarTwinReport) {
    use crate::twin::{self, solid::Provenance, TwinError, TwinInput};
    let t = Instant::now();
    let fused = &result.fused;
    let built = (|| -> Result<(twin::Twin, twin::TwinMetrics), TwinError> {
        let ground_z = world
            .terrain
            .known
            .then(|| twin::ground_height_under(&world.terrain.scene, &fused.points))
            .flatten()
            .ok_or_else(|| TwinError::BadInput {
                field: "imaging.ground_objects",
                value: format!("{:?}", sc.imaging.ground_objects),
                expected: "ground objects under the fused cloud's centre",
            })?;
        let points: Vec<&[Vec3]> = result.images.iter().map(|im| &im.points[..]).collect();
        let views = twin::pair_views(sc, &result.plans, &points);
        let tw = twin::build(&TwinInput {
            points: &fused.points,
            weights: &fused.weight,
            voxel_m: f64::from(sc.imaging.voxel_m),
            ground_z,
            views: &views,
        })?;
        let metrics = twin::score(
            &tw.solid,
            &world.truth,
            &world.truth_triangles,
            density_per_m2,
            sc.imaging.seed.wrapping_add(3),
        )?;
        Ok((tw, metrics))
    })();
    match built {
        Ok((tw, metrics)) => {
            let solid = &tw.solid;
            let count = |s| solid.faces.iter().filter(|f| f.surface == s).count();
            let report = PlanarTwinReport {
                metrics: Some(metrics),
                faces: [
                    solid.faces.len(),
                    count(twin::solid::Surface::WallSurface),
                    count(twin::solid::Surface::RoofSurface),
                    count(twin::solid::Surface::GroundSurface),
                ],
                inferred_faces: solid
                    .faces
                    .iter()
                    .filter(|f| matches!(f.provenance, Provenance::Inferred { .. }))
                    .count(),
                buildings: solid.buildings,
                watertight: solid.triangulate(|_| true).0.topology().watertight,
                seconds: t.elapsed().as_secs_f64(),
                error: None,
            };
            (Some(tw), report)
        }
        Err(e) => (
            None,
            PlanarTwinReport {
                metrics: None,
                faces: [0; 4],
                inferred_faces: 0,
                buildings: 0,
                watertight: false,
                seconds: t.elapsed().as_secs_f64(),
                error: Some(e.to_string()),
            },
        ),
    }
}

/// Meshes the fused cloud ([`imaging::surface`]) and scores its area samples.
fn mesh_stage(
    sc: &Scenario,
    world: &World,
    result: &RunResult,
    observable: &[bool],
    opts: &SurfaceOptions,
) -> Result<(Surface, Vec<Vec3>, MeshReport), ReconstructError> {
    let surf = imaging::surface(sc, Some(&world.terrain), result, opts)
        .map_err(ReconstructError::Surface)?;
    let density = sc.imaging.truth_density_per_m2;
    let samples = surf
        .mesh
        .sample(density, sc.imaging.seed.wrapping_add(3))
        .map_err(ReconstructError::Surface)?;
    let cmp = CloudComparison::new(&samples, &world.truth).map_err(ReconstructError::Surface)?;
    // False surface (area-weighted share farther than 1.5 m from the truth) and area against
    // the truth's: what Chamfer and F-score average away (a sheet over the ground, ghost walls).
    let area = surface_area_metrics(
        &samples,
        surf.mesh.area_m2(),
        &world.truth,
        &world.truth_triangles,
        1.5,
    )
    .map_err(ReconstructError::Surface)?;
    let topo = surf.mesh.topology();
    let report = MeshReport {
        metrics: CloudMetrics::new(&cmp, samples.len(), world.truth.len())
            .map_err(ReconstructError::Surface)?,
        observable_truth: ObservableCompleteness::new(&cmp, observable),
        false_surface_pct_1_5m: area.false_surface_pct,
        area_ratio: area.area_ratio,
        area_m2: area.area_m2,
        truth_area_m2: area.truth_area_m2,
        vertices: surf.mesh.vertices.len(),
        faces: surf.mesh.faces.len(),
        watertight: topo.watertight,
        manifold: topo.manifold,
        depth: surf.depth,
        cell_m: surf.cell_m,
        clip_box: [surf.clip_box.0.to_array(), surf.clip_box.1.to_array()],
        support_distance_m: Some(surf.support_distance_m),
        min_component_fraction: imaging::surface::MIN_COMPONENT_FRACTION,
        visibility_filter: surf.visibility,
        facing_away_points: surf.facing_away,
        wall_column_samples: surf.wall_column_samples,
        roof_edge_samples: surf.roof_edge_samples,
        hidden_roof_samples: surf.hidden_roof_samples,
        outline_wall_samples: surf.outline_wall_samples,
        valley_samples: surf.valley_samples,
        free_space_samples: surf.free_space_samples,
        footprints: surf.footprints.clone(),
        trim_median_fraction: opts.trim_median,
        sample_weights: "weight",
        sample_density_per_m2: density,
        seconds: surf.seconds,
    };
    Ok((surf, samples, report))
}
