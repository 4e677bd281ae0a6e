//! `has-sim bench mesh`: the screened Poisson solver (`has_host::mesh::screened_poisson`) with
//! adaptive fine levels against the plain reference, every level a full grid, on the same input:
//! the meshing proxy building (`has_host::shapes::mesh_proxy_building`) sampled at 8 points/m²
//! with σ = 0.3 m isotropic noise, normals by PCA (k = 24) propagated along a spanning tree.
//! Normal estimation is not timed. Reported per solver: wall seconds of the whole Poisson stage
//! (assembly, solve, extraction, vertex densities), the unknowns of the finest level, the mesh
//! size, and the √CD between the two untrimmed meshes' vertices (how closely the adaptive
//! surface follows the reference), all threads.

use std::time::Instant;

use has_host::mesh::{estimate_normals, screened_poisson, Orientation, PoissonParams};
use has_host::metrics::{gaussian_jitter, sample_triangles, CloudComparison};
use has_host::shapes::mesh_proxy_building;

/// Runs the benchmark at grid `depth` (the quick variant: depth 7).
pub fn run(quick: bool) -> anyhow::Result<()> {
    let depth = if quick { 7 } else { 8 };
    let building = mesh_proxy_building()?;
    let clean = sample_triangles(&building.triangles, 8.0, 11)?;
    let cloud = gaussian_jitter(&clean, 0.3, 12)?;
    let normals = estimate_normals(&cloud, 24, Orientation::Propagate)?;
    println!(
        "has-sim bench mesh — screened Poisson, depth {depth}, {} points (proxy building, σ 0.3 m), {} threads\n",
        cloud.len(),
        rayon::current_num_threads()
    );
    println!(
        "{:<28} {:>9} {:>9} {:>16} {:>10} {:>12}",
        "solver", "seconds", "× plain", "finest unknowns", "vertices", "√CD to ref"
    );
    let mut reference: Option<(f64, Vec<glam::Vec3>)> = None;
    for (label, band) in [
        ("full grids (plain reference)", None),
        ("adaptive band, w = 2", Some(2)),
    ] {
        let params = PoissonParams {
            depth,
            band,
            ..PoissonParams::default()
        };
        let t0 = Instant::now();
        let out = screened_poisson(&cloud, &normals, &params)?;
        let seconds = t0.elapsed().as_secs_f64();
        let finest = out.levels.last().map_or(0, |l| l.unknowns);
        let (speed, gap) = match &reference {
            None => (1.0, 0.0),
            Some((s_ref, v_ref)) => (
                s_ref / seconds.max(1e-12),
                CloudComparison::new(&out.mesh.vertices, v_ref)?.sqrt_chamfer_m(),
            ),
        };
        println!(
            "{label:<28} {seconds:>9.2} {speed:>9.2} {finest:>16} {:>10} {gap:>10.3} m",
            out.mesh.vertices.len()
        );
        if reference.is_none() {
            reference = Some((seconds, out.mesh.vertices.clone()));
        }
    }
    Ok(())
}
