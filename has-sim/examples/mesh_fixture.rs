//! Writes a noisy factory point cloud and its true surface for `has-sim mesh` experiments:
//! `cargo run --release -p has-sim --example mesh_fixture -- OUT_DIR [SIGMA_M] [POINTS_PER_M2]`
//! writes `OUT_DIR/cloud.ply` (walls and sawtooth roof of a 40 m × 24 m × 10 m building, open at
//! the bottom, isotropic Gaussian noise σ per axis, default 0.3 m, 4 points/m²) and
//! `OUT_DIR/truth.ply` (the true walls and roof as a mesh).

use std::path::PathBuf;

use glam::Vec3;
use has_host::io::{ply, PlyData, PlyFormat};
use has_host::metrics::sample_triangles;
use has_host::shapes::{building, Building, Direction, Roof};
use has_host::Material;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().unwrap_or_else(|| "out/mesh_fixture".into()));
    let sigma: f32 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(0.3);
    let density: f64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(4.0);
    std::fs::create_dir_all(&dir)?;
    let b = building(
        "factory",
        Material::Concrete,
        &Building {
            base_center: Vec3::ZERO,
            size: Vec3::new(40.0, 24.0, 10.0),
            yaw_rad: 0.3,
            roof: Roof::Sawtooth {
                teeth: 4,
                height: 3.0,
                facing: Direction::PosX,
            },
            bottom: false,
        },
    )?;
    let clean = sample_triangles(&b.triangles, density, 11)?;
    // Gaussian noise by Box–Muller over splitmix64 (fixed seed; the example needs no RNG crate).
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut uniform = || {
        // splitmix64
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let mut gauss = || {
        let (u1, u2) = (uniform(), uniform());
        ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
    };
    let cloud: Vec<Vec3> = clean
        .iter()
        .map(|&p| p + sigma * Vec3::new(gauss(), gauss(), gauss()))
        .collect();
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
