//! The quick reconstruction of the bundled factory through the library: image every pair, fuse,
//! mesh, and print √CD and F-score(1.5 m) of the cloud and the mesh against the truth.
//!
//! `cargo run --release -p has-host --example quick_reconstruction [SCENARIO.toml]`

use has_host::reconstruction::{reconstruct, ReconstructOptions};
use has_host::scenario::Scenario;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut sc = match std::env::args().nth(1) {
        Some(path) => Scenario::load(path.as_ref())?,
        None => Scenario::from_toml_str(include_str!("../../fixtures/factory.toml"))?,
    };
    sc.apply_quick();
    sc.validate()?;
    let rec = reconstruct(&sc, &ReconstructOptions::default(), &|_, _, _| {})?;
    let cloud = &rec.report.imaging.point_cloud.metrics;
    println!(
        "cloud: {} points, √CD {:.3} m, F-score(1.5 m) {:.1}",
        cloud.points, cloud.sqrt_chamfer_m, cloud.fscores.fscore_1_5m
    );
    if let Some(mesh) = &rec.report.mesh {
        println!(
            "mesh: {} faces, √CD {:.3} m, F-score(1.5 m) {:.1}",
            mesh.faces, mesh.metrics.sqrt_chamfer_m, mesh.metrics.fscores.fscore_1_5m
        );
    }
    Ok(())
}
