//! The screened Poisson solver ([`crate::mesh::screened_poisson`]) with adaptive fine levels
//! against the plain reference, every level a full grid, on the same input: the meshing proxy
//! building ([`crate::shapes::mesh_proxy_building`]) sampled at 8 points/m² with σ = 0.3 m
//! isotropic noise, normals by PCA (k = 24) propagated along a spanning tree. Normal estimation
//! is not timed. Measured per solver: wall seconds of the whole Poisson stage (assembly, solve,
//! extraction, vertex densities), the unknowns of the finest level, the mesh size, and the √CD
//! between the two untrimmed meshes' vertices (how closely the adaptive surface follows the
//! reference), all threads.

use std::time::Instant;

use glam::Vec3;

use super::BenchError;
use crate::mesh::{estimate_normals, screened_poisson, Orientation, PoissonParams};
use crate::metrics::{gaussian_jitter, sample_triangles, CloudComparison};
use crate::shapes::mesh_proxy_building;

/// The grid depth of the benchmark: 7 for a quick run, 8 otherwise.
pub fn depth(quick: bool) -> u32 {
    if quick {
        7
    } else {
        8
    }
}

/// The input of the benchmark: the noisy proxy-building cloud and its oriented normals.
#[derive(Clone, Debug)]
pub struct PoissonInput {
    /// Points, metres.
    pub cloud: Vec<Vec3>,
    /// Unit normals, one per point.
    pub normals: Vec<Vec3>,
}

impl PoissonInput {
    /// Samples, jitters and orients the proxy building (seeds 11 and 12; not timed).
    pub fn new() -> Result<Self, BenchError> {
        let building = mesh_proxy_building()?;
        let clean = sample_triangles(&building.triangles, 8.0, 11)?;
        let cloud = gaussian_jitter(&clean, 0.3, 12)?;
        let normals = estimate_normals(&cloud, 24, Orientation::Propagate)?;
        Ok(PoissonInput { cloud, normals })
    }
}

/// One solver of the benchmark.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PoissonRow {
    /// The solver.
    pub solver: &'static str,
    /// Wall time of the Poisson stage, seconds.
    pub seconds: f64,
    /// The reference's seconds over these (1 for the reference itself).
    pub speedup: f64,
    /// Unknowns of the finest level.
    pub finest_unknowns: usize,
    /// Vertices of the untrimmed mesh.
    pub vertices: usize,
    /// √CD between this mesh's vertices and the reference's, metres (0 for the reference).
    pub sqrt_cd_to_reference_m: f64,
}

/// Runs the full-grid reference, then the adaptive band (w = 2), at grid `depth` on `input`.
pub fn poisson_rows(input: &PoissonInput, depth: u32) -> Result<Vec<PoissonRow>, BenchError> {
    let mut rows = Vec::new();
    let mut reference: Option<(f64, Vec<Vec3>)> = None;
    for (solver, band) in [
        ("full grids (plain reference)", None),
        ("adaptive band, w = 2", Some(2)),
    ] {
        let params = PoissonParams {
            depth,
            band,
            ..PoissonParams::default()
        };
        let t0 = Instant::now();
        let out = screened_poisson(&input.cloud, &input.normals, &params)?;
        let seconds = t0.elapsed().as_secs_f64();
        let (speedup, gap) = match &reference {
            None => (1.0, 0.0),
            Some((s_ref, v_ref)) => (
                s_ref / seconds.max(1e-12),
                CloudComparison::new(&out.mesh.vertices, v_ref)?.sqrt_chamfer_m(),
            ),
        };
        rows.push(PoissonRow {
            solver,
            seconds,
            speedup,
            finest_unknowns: out.levels.last().map_or(0, |l| l.unknowns),
            vertices: out.mesh.vertices.len(),
            sqrt_cd_to_reference_m: gap,
        });
        if reference.is_none() {
            reference = Some((seconds, out.mesh.vertices));
        }
    }
    Ok(rows)
}
