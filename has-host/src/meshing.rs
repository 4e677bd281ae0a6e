//! A point cloud's surface as one library call, the stage behind `has-sim mesh`: normals (the
//! stored ones, re-estimated ones oriented by the stored ones, or estimated ones oriented by
//! minimum-spanning-tree propagation), sample weights, screened Poisson with its trim and clips
//! ([`mesh::reconstruct_oriented`]), then, given a ground truth, the cloud and the mesh scored
//! against it ([`MeshedCloud::score`]). The figures come back as a typed, `Serialize`
//! [`MeshingReport`].
//!
//! Two steps, so that a caller can write the mesh (and measure memory) before the scoring.
//!
//! Units: metres, seconds; metrics as [`crate::metrics`] (eq. 2 and 3 of the paper, S1 the cloud
//! or the mesh's area samples, S2 the truth). A mesh is scored on uniform area samples at the
//! truth's density, drawn with [`MESH_SAMPLE_SEED`].
//!
//! The inputs of `has-sim mesh` are read here too: the normals a PLY cloud stores
//! ([`stored_normals`]), the vertex property that weighs its samples ([`weight_column`],
//! [`DEFAULT_WEIGHT_PROPERTIES`] unless another is named) and the ground truth, a PLY mesh sampled
//! on its area or a PLY cloud taken as is ([`read_truth`]). [`MeshRunReport`] is the command's
//! `--report`: the [`MeshingReport`] with the input file, the weights and the peak memory.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use crate::io::{ply, MeshIoError, PlyData};
use crate::knn::GeometryError;
use crate::mesh::poisson::LevelStats;
use crate::mesh::{
    self, estimate_normals, Orientation, PoissonOutput, PoissonParams, ReconstructParams, Topology,
    TriMesh, Trim,
};
use crate::metrics::CloudMetrics;

/// Seed of the area samples a mesh is scored on ([`score_mesh`]).
pub const MESH_SAMPLE_SEED: u64 = 2;

/// Why meshing a cloud failed.
#[derive(Debug, thiserror::Error)]
pub enum MeshingError {
    /// Estimating or orienting the normals.
    #[error("normals: {0}")]
    Normals(GeometryError),
    /// The weights, the Poisson solve, the trim or a clip.
    #[error("surface reconstruction: {0}")]
    Surface(GeometryError),
}

/// Vertex properties that weigh the samples when the caller names none, the first the cloud has
/// ([`weight_column`]): `weight`, the fusion weight that `reconstruct` meshes with and writes
/// into `mesh_input.ply` and `fused.ply` (Σ over the pairs that detected the point of its
/// amplitude relative to the pair's peak times the pair's resolution factor,
/// [`crate::imaging::fuse`]); else `intensity`, one pair's amplitude relative to its peak (the
/// pair clouds, and the files of older runs).
pub const DEFAULT_WEIGHT_PROPERTIES: [&str; 2] = ["weight", "intensity"];

/// Seed of the area samples of a ground-truth mesh ([`read_truth`]).
pub const TRUTH_SAMPLE_SEED: u64 = 1;

/// Why the inputs of a meshing run could not be read. Each variant prints its cause unchanged.
#[derive(Debug, thiserror::Error)]
pub enum MeshInputError {
    /// Reading a PLY file.
    #[error(transparent)]
    Read(#[from] MeshIoError),
    /// Sampling the ground-truth mesh (a density that is not positive, an empty mesh).
    #[error(transparent)]
    TruthSamples(GeometryError),
    /// The cloud lacks the named weight property.
    #[error("{} has no vertex property '{name}'", path.display())]
    NoProperty {
        /// The cloud's file.
        path: PathBuf,
        /// The property asked for.
        name: String,
    },
}

/// The normals stored in `cloud`'s `nx`, `ny`, `nz` vertex properties, when it has all three.
pub fn stored_normals(cloud: &PlyData) -> Option<Vec<Vec3>> {
    let (x, y, z) = (
        cloud.property("nx")?,
        cloud.property("ny")?,
        cloud.property("nz")?,
    );
    Some(
        x.iter()
            .zip(y)
            .zip(z)
            .map(|((&x, &y), &z)| Vec3::new(x, y, z))
            .collect(),
    )
}

/// A vertex property chosen to weigh the samples ([`weight_column`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightColumn<'a> {
    /// The property's name.
    pub property: &'a str,
    /// Its values, one per vertex.
    pub values: &'a [f32],
}

/// The sample weights of `cloud`, read from the file `path` (named in errors only): the
/// property `name` when given; otherwise the first of [`DEFAULT_WEIGHT_PROPERTIES`] the cloud
/// has, unless `unweighted`; otherwise none (every sample alike).
///
/// # Errors
/// [`MeshInputError::NoProperty`] when the cloud lacks `name`.
pub fn weight_column<'a>(
    cloud: &'a PlyData,
    path: &Path,
    name: Option<&'a str>,
    unweighted: bool,
) -> Result<Option<WeightColumn<'a>>, MeshInputError> {
    match (name, unweighted) {
        (Some(property), _) => match cloud.property(property) {
            Some(values) => Ok(Some(WeightColumn { property, values })),
            None => Err(MeshInputError::NoProperty {
                path: path.to_path_buf(),
                name: property.to_string(),
            }),
        },
        (None, false) => Ok(DEFAULT_WEIGHT_PROPERTIES.iter().find_map(|&property| {
            cloud
                .property(property)
                .map(|values| WeightColumn { property, values })
        })),
        (None, true) => Ok(None),
    }
}

/// The ground truth in the PLY file `path`: a mesh's surface sampled uniformly at
/// `density_per_m2` points per m² (seed [`TRUTH_SAMPLE_SEED`]), or a point cloud (no faces) as
/// is. Metres.
///
/// # Errors
/// [`MeshInputError::Read`]; [`MeshInputError::TruthSamples`] as
/// [`crate::metrics::sample_triangles`].
pub fn read_truth(path: &Path, density_per_m2: f64) -> Result<Vec<Vec3>, MeshInputError> {
    let t = ply::read_ply(path)?;
    if t.faces.is_empty() {
        return Ok(t.vertices);
    }
    crate::metrics::sample_triangles(&t.triangles(), density_per_m2, TRUTH_SAMPLE_SEED)
        .map_err(MeshInputError::TruthSamples)
}

/// Options of [`mesh_cloud`].
#[derive(Clone, Debug, Default)]
pub struct MeshingOptions {
    /// Normal neighbours, Poisson settings, trim, clips and small-component removal.
    pub params: ReconstructParams,
    /// Estimate the normals (PCA over `params.normal_k` neighbours) even when some are stored;
    /// the stored ones then only orient the new ones.
    pub estimate_normals: bool,
    /// Exponent applied to the sample weights (2 turns an amplitude into a power); finite, ≥ 0.
    pub weight_power: f32,
}

/// The mesh's size, topology and how the solver made it.
#[derive(Clone, Debug, Serialize)]
pub struct MeshSummary {
    /// Vertices.
    pub vertices: usize,
    /// Faces.
    pub faces: usize,
    /// Edge-use counts ([`TriMesh::topology`]).
    pub topology: Topology,
    /// Area, m².
    pub area_m2: f64,
    /// Finest Poisson cell, metres.
    pub cell_m: f32,
    /// Finest grid node counts.
    pub grid_dims: [usize; 3],
    /// Iso-value of the extracted surface.
    pub iso_value: f32,
    /// Solver statistics per level, coarse to fine.
    pub levels: Vec<LevelStats>,
}

/// The cloud and the mesh against the truth ([`MeshedCloud::score`]).
#[derive(Clone, Debug, Serialize)]
pub struct MeshingMetrics {
    /// The input cloud.
    pub cloud: CloudMetrics,
    /// The mesh's area samples.
    pub mesh: CloudMetrics,
    /// The closed Poisson surface before the trim (only when a trim rule was given).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh_untrimmed: Option<CloudMetrics>,
    /// Area samples per m² of the meshes.
    pub mesh_sample_density_per_m2: f64,
}

/// Where the time went, seconds.
#[derive(Clone, Debug, Serialize)]
pub struct MeshingTimings {
    /// Normals (taken, or estimated and oriented).
    pub normals: f64,
    /// Linear solves, all levels.
    pub solve: f64,
    /// Iso-surface extraction and vertex densities.
    pub extract: f64,
    /// Weights, Poisson, trim, clips and repair.
    pub poisson_total: f64,
}

/// Everything [`mesh_cloud`] and [`MeshedCloud::score`] measured.
#[derive(Clone, Debug, Serialize)]
pub struct MeshingReport {
    /// Input points.
    pub points: usize,
    /// Poisson settings.
    pub params: PoissonParams,
    /// Density trim rule, if any.
    pub trim: Option<Trim>,
    /// The mesh.
    pub mesh: MeshSummary,
    /// Truth points, once scored.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth_points: Option<usize>,
    /// The metrics, once scored.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub metrics: Option<MeshingMetrics>,
    /// Timings.
    pub time_s: MeshingTimings,
}

/// What weighed the samples of a meshing run ([`MeshRunReport::weights`]).
#[derive(Clone, Debug, Serialize)]
pub struct WeightsUsed {
    /// The input's vertex property.
    pub property: String,
    /// Its exponent ([`MeshingOptions::weight_power`]).
    pub power: f32,
}

/// The `--report` of `has-sim mesh`: the [`MeshingReport`] (its fields at the top level) with
/// the input file, the weights and the process's peak memory, which only the caller knows.
#[derive(Clone, Debug, Serialize)]
pub struct MeshRunReport {
    /// The input cloud.
    pub input: PathBuf,
    /// The sample weights, if any.
    pub weights: Option<WeightsUsed>,
    /// Peak resident memory of the process, MiB.
    pub peak_rss_mib: Option<f64>,
    /// Peak resident memory right after the Poisson stage, MiB.
    pub peak_rss_after_poisson_mib: Option<f64>,
    /// The meshing's figures.
    #[serde(flatten)]
    pub meshing: MeshingReport,
}

/// What [`mesh_cloud`] produced: the data and its report.
#[derive(Clone, Debug)]
pub struct MeshedCloud {
    /// The final mesh (trimmed, clipped and repaired as asked).
    pub mesh: TriMesh,
    /// The closed Poisson surface with its vertex densities and diagnostics.
    pub poisson: PoissonOutput,
    /// The normals used, one per input point.
    pub normals: Vec<Vec3>,
    /// The figures ([`MeshingReport::metrics`] once [`MeshedCloud::score`] ran).
    pub report: MeshingReport,
    /// Whether the mesh is the Poisson surface itself (no trim, clip or component rule, and no
    /// vertex removed by the repair).
    untouched: bool,
}

/// The normals of `points`: `stored` as given, or PCA normals over `k` neighbours oriented by
/// `stored` (each turned to agree with its stored normal) when `estimate`, or, without stored
/// normals, oriented by propagation along a minimum spanning tree.
///
/// # Errors
/// As [`estimate_normals`].
pub fn oriented_normals(
    points: &[Vec3],
    stored: Option<Vec<Vec3>>,
    estimate: bool,
    k: usize,
) -> Result<Vec<Vec3>, GeometryError> {
    match stored {
        Some(n) if !estimate => Ok(n),
        Some(n) => {
            // A virtual sensor one metre along each stored normal orients the new one.
            let toward: Vec<Vec3> = points.iter().zip(&n).map(|(&p, &n)| p + n).collect();
            estimate_normals(points, k, Orientation::Sensors(&toward))
        }
        None => estimate_normals(points, k, Orientation::Propagate),
    }
}

/// Meshes `points` (module docs): normals as [`oriented_normals`], each sample weighted by its
/// entry of `weights` raised to `opts.weight_power` (`None`: every sample alike), then
/// [`mesh::reconstruct_oriented`] with `opts.params`.
///
/// # Errors
/// [`MeshingError::Normals`]; [`MeshingError::Surface`] for a weight power that is negative or
/// not finite and as [`mesh::reconstruct_oriented`].
pub fn mesh_cloud(
    points: &[Vec3],
    stored_normals: Option<Vec<Vec3>>,
    weights: Option<&[f32]>,
    opts: &MeshingOptions,
) -> Result<MeshedCloud, MeshingError> {
    let p = &opts.params;
    let t0 = Instant::now();
    let normals = oriented_normals(points, stored_normals, opts.estimate_normals, p.normal_k)
        .map_err(MeshingError::Normals)?;
    let normals_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let power = opts.weight_power;
    if weights.is_some() && !(power.is_finite() && power >= 0.0) {
        return Err(MeshingError::Surface(GeometryError::BadParameter {
            field: "weight_power",
            value: power as f64,
            expected: "finite and ≥ 0",
        }));
    }
    let weights: Option<Vec<f32>> = weights.map(|w| w.iter().map(|&w| w.powf(power)).collect());
    let rec = mesh::reconstruct_oriented(points, normals, weights.as_deref(), p)
        .map_err(MeshingError::Surface)?;
    let poisson_s = t1.elapsed().as_secs_f64();
    let (mesh, out) = (rec.mesh, rec.poisson);
    let untouched = p.trim.is_none()
        && p.clip_box.is_none()
        && p.support_distance_m.is_none()
        && p.min_component_fraction.is_none()
        && mesh.vertices.len() == out.mesh.vertices.len();
    let report = MeshingReport {
        points: points.len(),
        params: p.poisson.clone(),
        trim: p.trim,
        mesh: MeshSummary {
            vertices: mesh.vertex_count(),
            faces: mesh.face_count(),
            topology: mesh.topology(),
            area_m2: mesh.area_m2(),
            cell_m: out.cell_m,
            grid_dims: out.dims,
            iso_value: out.iso_value,
            levels: out.levels.clone(),
        },
        truth_points: None,
        metrics: None,
        time_s: MeshingTimings {
            normals: normals_s,
            solve: out.solve_s,
            extract: out.extract_s,
            poisson_total: poisson_s,
        },
    };
    Ok(MeshedCloud {
        mesh,
        poisson: out,
        normals: rec.normals,
        report,
        untouched,
    })
}

/// `mesh` scored against `truth` on its area samples at `density_per_m2` (seed
/// [`MESH_SAMPLE_SEED`]).
///
/// # Errors
/// As [`TriMesh::sample`] and [`CloudMetrics::between`] (an empty mesh or truth).
pub fn score_mesh(
    mesh: &TriMesh,
    truth: &[Vec3],
    density_per_m2: f64,
) -> Result<CloudMetrics, GeometryError> {
    CloudMetrics::between(&mesh.sample(density_per_m2, MESH_SAMPLE_SEED)?, truth)
}

impl MeshedCloud {
    /// The Poisson vertex densities, when they still follow the mesh's vertices (the mesh is
    /// the Poisson surface itself: no trim, clip or component rule, no vertex repaired away).
    pub fn vertex_density(&self) -> Option<&[f32]> {
        self.untouched
            .then_some(self.poisson.vertex_density.as_slice())
    }

    /// Scores the input cloud `points` and the mesh (and, with a trim rule, the untrimmed
    /// Poisson surface) against `truth`, the meshes on area samples at `density_per_m2`
    /// ([`score_mesh`]); records the result in the report and returns it.
    ///
    /// # Errors
    /// As [`score_mesh`]; `points` or `truth` empty or not finite.
    pub fn score(
        &mut self,
        points: &[Vec3],
        truth: &[Vec3],
        density_per_m2: f64,
    ) -> Result<&MeshingMetrics, GeometryError> {
        let cloud = CloudMetrics::between(points, truth)?;
        let mesh = score_mesh(&self.mesh, truth, density_per_m2)?;
        let mesh_untrimmed = match self.report.trim {
            Some(_) => Some(score_mesh(&self.poisson.mesh, truth, density_per_m2)?),
            None => None,
        };
        self.report.truth_points = Some(truth.len());
        Ok(self.report.metrics.insert(MeshingMetrics {
            cloud,
            mesh,
            mesh_untrimmed,
            mesh_sample_density_per_m2: density_per_m2,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` points on a sphere of radius 5 m about the origin (a Fibonacci lattice).
    fn sphere(n: usize) -> Vec<Vec3> {
        crate::mesh::normals::fibonacci_sphere(n, Vec3::ZERO, 5.0)
    }

    fn options(trim: Option<Trim>) -> MeshingOptions {
        MeshingOptions {
            params: ReconstructParams {
                poisson: PoissonParams {
                    depth: 5,
                    ..PoissonParams::default()
                },
                trim,
                ..ReconstructParams::default()
            },
            estimate_normals: false,
            weight_power: 1.0,
        }
    }

    #[test]
    fn the_weights_are_the_named_property_else_weight_else_intensity_and_a_missing_name_is_an_error(
    ) {
        let cloud = PlyData::from_points(vec![Vec3::ZERO; 2])
            .with_property("intensity", vec![1.0, 0.5])
            .with_property("power", vec![4.0, 2.0]);
        let path = Path::new("cloud.ply");
        let w = weight_column(&cloud, path, None, false).unwrap().unwrap();
        assert_eq!((w.property, w.values), ("intensity", &[1.0, 0.5][..]));
        let fused = cloud.clone().with_property("weight", vec![2.0, 0.25]);
        let w = weight_column(&fused, path, None, false).unwrap().unwrap();
        assert_eq!((w.property, w.values), ("weight", &[2.0, 0.25][..]));
        let w = weight_column(&cloud, path, Some("power"), false).unwrap();
        assert_eq!(w.unwrap().values, [4.0, 2.0]);
        assert!(weight_column(&cloud, path, None, true).unwrap().is_none());
        let bare = PlyData::from_points(vec![Vec3::ZERO; 2]);
        assert!(weight_column(&bare, path, None, false).unwrap().is_none());
        let e = weight_column(&bare, path, Some("intensity"), false).unwrap_err();
        assert_eq!(
            e.to_string(),
            "cloud.ply has no vertex property 'intensity'"
        );
        // Normals only with all three components.
        assert!(stored_normals(&cloud).is_none());
        let n = cloud
            .with_property("nx", vec![0.0, 1.0])
            .with_property("ny", vec![0.0, 0.0])
            .with_property("nz", vec![1.0, 0.0]);
        assert_eq!(stored_normals(&n).unwrap(), [Vec3::Z, Vec3::X]);
    }

    #[test]
    fn a_truth_mesh_is_sampled_on_its_area_and_a_truth_cloud_taken_as_is() {
        let d = std::env::temp_dir().join(format!("has-meshing-truth-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        // A 10 m × 10 m square at z = 1 as two triangles, and its four corners as a cloud.
        let corners = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(10.0, 0.0, 1.0),
            Vec3::new(10.0, 10.0, 1.0),
            Vec3::new(0.0, 10.0, 1.0),
        ];
        let mut square = PlyData::from_points(corners.to_vec());
        square.faces = vec![[0, 1, 2], [0, 2, 3]];
        let (mesh_path, cloud_path) = (d.join("square.ply"), d.join("corners.ply"));
        ply::write_ply(&mesh_path, &square, Default::default()).unwrap();
        let cloud = PlyData::from_points(corners.to_vec());
        ply::write_ply(&cloud_path, &cloud, Default::default()).unwrap();
        assert_eq!(read_truth(&cloud_path, 5.0).unwrap(), corners);
        let samples = read_truth(&mesh_path, 5.0).unwrap();
        assert!((400..=600).contains(&samples.len()), "{}", samples.len());
        assert!(samples
            .iter()
            .all(|p| p.z == 1.0 && (0.0..=10.0).contains(&p.x) && (0.0..=10.0).contains(&p.y)));
        assert!(matches!(
            read_truth(&mesh_path, 0.0),
            Err(MeshInputError::TruthSamples(_))
        ));
        assert!(matches!(
            read_truth(&d.join("missing.ply"), 5.0),
            Err(MeshInputError::Read(_))
        ));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn stored_normals_are_kept_or_only_orient_the_re_estimated_ones() {
        // A 10 × 10 grid on z = 0 with stored normals tilted 30° from −z: kept as given, or
        // replaced by the plane's normal turned to agree with them (−z).
        let pts: Vec<Vec3> = (0..100)
            .map(|i| Vec3::new((i % 10) as f32, (i / 10) as f32, 0.0))
            .collect();
        let tilted = Vec3::new(0.5, 0.0, -(0.75f32).sqrt());
        let stored = vec![tilted; pts.len()];
        assert_eq!(
            oriented_normals(&pts, Some(stored.clone()), false, 8).unwrap(),
            stored
        );
        let n = oriented_normals(&pts, Some(stored), true, 8).unwrap();
        assert!(
            n.iter().all(|n| (*n - Vec3::NEG_Z).length() < 1e-5),
            "{n:?}"
        );
        assert!(oriented_normals(&pts, None, false, 8).is_ok());
    }

    #[test]
    fn a_cloud_scored_against_itself_is_exact_and_its_mesh_within_a_cell() {
        // The truth is the cloud itself: the cloud's √CD is 0 and every F-score 100 %. The
        // mesh of a 5 m sphere at depth 5 (cell 1.2·10/32 ≈ 0.38 m) lies within a cell of the
        // samples (1 000 points, spacing ≈ 0.56 m), so its √CD is below a cell and F(1.5 m) 100.
        let pts = sphere(1000);
        let mut m = mesh_cloud(
            &pts,
            Some(pts.iter().map(|p| p.normalize()).collect()),
            None,
            &options(None),
        )
        .unwrap();
        assert!(m.report.metrics.is_none() && m.report.truth_points.is_none());
        assert!(m.vertex_density().is_some());
        let cell = m.report.mesh.cell_m as f64;
        let s = m.score(&pts, &pts, 20.0).unwrap().clone();
        assert_eq!(s.cloud.sqrt_chamfer_m, 0.0);
        assert_eq!(s.cloud.fscores.fscore_0_5m, 100.0);
        assert_eq!((s.cloud.points, s.cloud.truth_points), (1000, 1000));
        assert!(
            s.mesh.sqrt_chamfer_m < cell,
            "{} vs cell {cell}",
            s.mesh.sqrt_chamfer_m
        );
        assert_eq!(s.mesh.fscores.fscore_1_5m, 100.0);
        assert!(s.mesh_untrimmed.is_none());
        assert_eq!(m.report.truth_points, Some(1000));
    }

    #[test]
    fn the_untrimmed_surface_is_scored_only_with_a_trim_rule() {
        let pts = sphere(1000);
        let normals: Vec<Vec3> = pts.iter().map(|p| p.normalize()).collect();
        let mut m = mesh_cloud(
            &pts,
            Some(normals),
            Some(&vec![0.5; pts.len()]),
            &options(Some(Trim::Quantile(0.1))),
        )
        .unwrap();
        // Trimmed: the densities no longer follow the vertices.
        assert!(m.vertex_density().is_none());
        assert!(m.report.mesh.vertices < m.poisson.mesh.vertices.len());
        let s = m.score(&pts, &pts, 20.0).unwrap();
        let u = s
            .mesh_untrimmed
            .expect("untrimmed metrics with a trim rule");
        assert_eq!(u, score_mesh(&m.poisson.mesh, &pts, 20.0).unwrap());
        let bad = MeshingOptions {
            weight_power: -1.0,
            ..options(None)
        };
        let e = mesh_cloud(&pts, None, Some(&vec![0.5; pts.len()]), &bad).unwrap_err();
        assert!(e.to_string().contains("weight_power"), "{e}");
    }
}
