//! Surface reconstruction end to end on analytic shapes: noisy samples of a sphere and a box →
//! normals → screened Poisson → iso-surface, checked against the true surface.

use glam::Vec3;
use has_host::mesh::{reconstruct, Orientation, PoissonParams, ReconstructParams};
use has_host::metrics::{gaussian_jitter, noisy_sphere, sample_triangles, CloudComparison};
use has_host::shapes::axis_box;
use has_host::Material;

fn params(depth: u32) -> ReconstructParams {
    ReconstructParams {
        normal_k: 16,
        poisson: PoissonParams {
            depth,
            levels: 3,
            ..PoissonParams::default()
        },
        trim: None,
        ..ReconstructParams::default()
    }
}

#[test]
fn noisy_sphere_reconstructs_within_a_cell_and_is_watertight() {
    let c = Vec3::new(3.0, -2.0, 1.0);
    let r = 1.0f32;
    let sigma = 0.01f32;
    let (pts, _) = noisy_sphere(6000, c, r, sigma, 1).unwrap();
    let sensors: Vec<Vec3> = pts.iter().map(|&p| c + (p - c) * 10.0).collect();
    let rec = reconstruct(&pts, None, Orientation::Sensors(&sensors), &params(6)).unwrap();
    let h = rec.poisson.cell_m;
    let top = rec.mesh.topology();
    let radii: Vec<f32> = rec
        .mesh
        .vertices
        .iter()
        .map(|v| (*v - c).length())
        .collect();
    let mean = radii.iter().sum::<f32>() / radii.len() as f32;
    let max_dev = radii.iter().map(|x| (x - r).abs()).fold(0.0, f32::max);
    eprintln!(
        "sphere: h {h} verts {} faces {} top {top:?} mean r {mean} max dev {max_dev} levels {:?} solve {} s",
        rec.mesh.vertex_count(),
        rec.mesh.face_count(),
        rec.poisson.levels,
        rec.poisson.solve_s
    );
    assert!(top.watertight, "{top:?}");
    // Mean radius: the noise is zero-mean (its curvature bias is σ²/R), Poisson smoothing over
    // a kernel of about one cell on a surface of curvature 1/R moves the level set by O(h²/R),
    // and marching tetrahedra adds at most 3h²/(8R): |mean − R| ≤ 2h²/R + σ²/R.
    let mean_bound = 2.0 * h * h / r + sigma * sigma / r;
    assert!(
        (mean - r).abs() <= mean_bound,
        "mean {mean} bound {mean_bound}"
    );
    // Every vertex: the screening pins the iso-surface to the samples (within 3σ of the
    // surface for 99.7 % of them, and averaged over the splat), and the surface is resolved to
    // one cell: |r − R| ≤ h + 3σ.
    let max_bound = h + 3.0 * sigma;
    assert!(max_dev <= max_bound, "max dev {max_dev} bound {max_bound}");
}

#[test]
fn degenerate_inputs_are_clear_errors() {
    use has_host::knn::GeometryError;
    let p = params(5);
    // Fewer points than neighbours.
    let (few, _) = noisy_sphere(10, Vec3::ZERO, 1.0, 0.0, 2).unwrap();
    assert!(matches!(
        reconstruct(&few, None, Orientation::Propagate, &p),
        Err(GeometryError::TooFew {
            field: "points",
            count: 10,
            needed: 16
        })
    ));
    // All points on one plane.
    let flat: Vec<Vec3> = (0..400)
        .map(|i| Vec3::new((i % 20) as f32 * 0.1, (i / 20) as f32 * 0.1, 2.0))
        .collect();
    let e = reconstruct(&flat, None, Orientation::Propagate, &p).unwrap_err();
    assert!(
        matches!(
            e,
            GeometryError::Degenerate {
                field: "points",
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("plane"), "{e}");
    // NaN.
    let (mut nan, _) = noisy_sphere(100, Vec3::ZERO, 1.0, 0.0, 3).unwrap();
    nan[42] = Vec3::new(0.0, f32::NAN, 0.0);
    let e = reconstruct(&nan, None, Orientation::Propagate, &p).unwrap_err();
    assert!(
        matches!(
            e,
            GeometryError::NonFinite {
                field: "points",
                index: 42,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn noisy_box_faces_are_recovered_and_mesh_is_watertight() {
    let lo = Vec3::new(-1.0, -0.75, 0.0);
    let hi = Vec3::new(1.0, 0.75, 1.0);
    let b = axis_box("box", Material::Concrete, lo, hi).unwrap();
    let sigma = 0.01f32;
    let clean = sample_triangles(&b.triangles, 1500.0, 3).unwrap();
    let pts = gaussian_jitter(&clean, sigma, 4).unwrap();
    let rec = reconstruct(&pts, None, Orientation::Propagate, &params(6)).unwrap();
    let h = rec.poisson.cell_m;
    let top = rec.mesh.topology();
    let mut worst = 0f32;
    let mut n = 0;
    for v in &rec.mesh.vertices {
        let dlo = *v - lo;
        let dhi = hi - *v;
        let d = [dlo.x, dlo.y, dlo.z, dhi.x, dhi.y, dhi.z];
        let mut s = d;
        s.sort_by(f32::total_cmp);
        // Face interior: the second-nearest face plane is more than 2 cells away.
        if s[1].abs() > 2.0 * h {
            worst = worst.max(s[0].abs());
            n += 1;
        }
    }
    let truth = sample_triangles(&b.triangles, 400.0, 9).unwrap();
    let s1 = rec.mesh.sample(400.0, 10).unwrap();
    let cmp = CloudComparison::new(&s1, &truth).unwrap();
    eprintln!(
        "box: h {h} verts {} faces {} top {top:?} face-interior verts {n} worst {worst} sqrtcd {} f(2h) {:?}",
        rec.mesh.vertex_count(),
        rec.mesh.face_count(),
        cmp.sqrt_chamfer_m(),
        cmp.fscore(2.0 * h).unwrap()
    );
    assert!(top.watertight, "{top:?}");
    // Face interiors (≥ 2 cells from an edge): the smoothed indicator of a flat face is
    // symmetric about its plane, so the level set lies on it up to the noise along the normal
    // (3σ) and the linear interpolation of a smooth step across a cell (≤ h/2).
    let bound = 0.5 * h + 3.0 * sigma;
    assert!(
        n > 1000 && worst <= bound,
        "{n} vertices, worst {worst}, bound {bound}"
    );
    // Only the rounding of edges and corners can exceed 2h: it lives in a band ≤ 2h wide along
    // the 18 m of box edges, ≤ 18·2h m² of the 13.5 m² surface (≈ 10 %), so F(2h) ≥ 89.
    let f = cmp.fscore(2.0 * h).unwrap();
    assert!(f.fscore_pct >= 89.0, "{f:?}");
}
