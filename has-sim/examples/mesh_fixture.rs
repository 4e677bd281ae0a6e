//! Writes a noisy factory point cloud and its true surface for `has-sim mesh` experiments:
//! `cargo run --release -p has-sim --example mesh_fixture -- OUT_DIR [SIGMA_M] [POINTS_PER_M2]`
//! writes `OUT_DIR/cloud.ply` (walls and sawtooth roof of a 40 m × 24 m × 10 m building, open at
//! the bottom, isotropic Gaussian noise σ per axis, default 0.3 m, 4 points/m²) and
//! `OUT_DIR/truth.ply` (the true walls and roof as a mesh).

use std::path::PathBuf;

use has_host::io::{ply, PlyData, PlyFormat};
use has_host::metrics::{gaussian_jitter, sample_triangles};
use has_host::shapes::mesh_proxy_building;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().unwrap_or_else(|| "out/mesh_fixture".into()));
    let sigma: f32 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(0.3);
    let density: f64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(4.0);
    std::fs::create_dir_all(&dir)?;
    let b = mesh_proxy_building()?;
    let clean = sample_triangles(&b.triangles, density, 11)?;
    let cloud = gaussian_jitter(&clean, sigma, 12)?;
    ply::write_ply(
        &dir.join("cloud.ply"),
        &PlyData::from_points(cloud.clone()),
        PlyFormat::BinaryLittleEndian,
    )?;
    let mut truth = PlyData::default();
    truth.append_triangles(&b.triangles);
    ply::write_ply(
        &dir.join("truth.ply"),
        &truth,
        PlyFormat::BinaryLittleEndian,
    )?;
    println!(
        "{}: {} points (σ {sigma} m, {density} /m²); truth: {} triangles",
        dir.display(),
        cloud.len(),
        b.triangles.len()
    );
    Ok(())
}
