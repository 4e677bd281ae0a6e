//! Planar facets of a scene (step 1 of the tracer, see [`crate::paths`]): region growing over the
//! triangles of one object, the least-squares plane of a noisy (reconstructed) wall, its
//! thickness, and plumbing of near-vertical facets. Lengths metres, normals unit.

use std::collections::{HashMap, VecDeque};

use glam::{DMat3, DVec3, Vec3};

use crate::linalg::smallest_eigenvector;
use crate::scene::Scene;

/// A planar facet: coplanar (within tolerance) adjacent triangles of one object.
#[derive(Clone, Debug)]
pub struct Facet {
    /// Owning object.
    pub object: u32,
    /// Unit normal of the fitted plane.
    pub normal: DVec3,
    /// Plane offset: points `x` of the plane satisfy `normal·x = offset`.
    pub offset: f64,
    /// Largest distance of a vertex of the facet from the plane, metres (0 for exact planes).
    pub thickness: f64,
    /// Bounding box of the facet's vertices.
    pub lo: DVec3,
    /// Bounding box of the facet's vertices.
    pub hi: DVec3,
    /// Triangles (indices into [`Scene::triangles`]).
    pub triangles: Vec<u32>,
}

/// The facets of a scene.
#[derive(Clone, Debug)]
pub struct Facets {
    /// All facets.
    pub facets: Vec<Facet>,
    /// Facet of each triangle of the scene.
    pub tri_facet: Vec<u32>,
}

/// Vertex position quantised to 0.1 mm (edge matching between triangles).
type VertexKey = (i64, i64, i64);

pub(super) fn tri_vertices(scene: &Scene, t: u32) -> [DVec3; 3] {
    let tri = &scene.triangles[t as usize];
    [
        Vec3::from(tri.v0).as_dvec3(),
        Vec3::from(tri.v1).as_dvec3(),
        Vec3::from(tri.v2).as_dvec3(),
    ]
}

impl Facets {
    /// Groups the scene's triangles into planar facets (see module docs); facets within
    /// `vertical_tol_m` of plumb are made vertical ([`super::TracerConfig::vertical_tol_m`]).
    pub fn build(
        scene: &Scene,
        angle_tol_rad: f64,
        dist_tol_m: f64,
        vertical_tol_m: f64,
    ) -> Facets {
        let n_tri = scene.triangles.len();
        let verts: Vec<[DVec3; 3]> = (0..n_tri as u32).map(|t| tri_vertices(scene, t)).collect();
        let mut normals = Vec::with_capacity(n_tri);
        let mut areas = Vec::with_capacity(n_tri);
        for v in &verts {
            let c = (v[1] - v[0]).cross(v[2] - v[0]);
            let len = c.length();
            areas.push(0.5 * len);
            normals.push(if len > 0.0 { c / len } else { DVec3::Z });
        }
        // Edge adjacency over quantised vertex positions (0.1 mm grid).
        let key = |p: DVec3| {
            let q = (p * 1e4).round();
            (q.x as i64, q.y as i64, q.z as i64)
        };
        let mut edges: HashMap<(VertexKey, VertexKey), Vec<u32>> = HashMap::new();
        for (t, v) in verts.iter().enumerate() {
            for e in 0..3 {
                let (a, b) = (key(v[e]), key(v[(e + 1) % 3]));
                let k = if a < b { (a, b) } else { (b, a) };
                edges.entry(k).or_default().push(t as u32);
            }
        }
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n_tri];
        for tris in edges.values() {
            for (i, &a) in tris.iter().enumerate() {
                for &b in &tris[i + 1..] {
                    if scene.tri_object[a as usize] == scene.tri_object[b as usize] {
                        adj[a as usize].push(b);
                        adj[b as usize].push(a);
                    }
                }
            }
        }
        // The edge map iterates in a random order: sort the neighbour lists so that the region
        // growing below (and hence the facets of a noisy mesh) is deterministic.
        for a in &mut adj {
            a.sort_unstable();
            a.dedup();
        }
        let cos_tol = angle_tol_rad.cos();
        let mut order: Vec<u32> = (0..n_tri as u32).collect();
        order.sort_by(|&a, &b| areas[b as usize].total_cmp(&areas[a as usize]));
        let mut tri_facet = vec![u32::MAX; n_tri];
        let mut facets = Vec::new();
        let mut queue = VecDeque::new();
        for &seed in &order {
            if tri_facet[seed as usize] != u32::MAX {
                continue;
            }
            let fid = facets.len() as u32;
            let mut nsum = normals[seed as usize] * areas[seed as usize];
            let mut csum =
                (verts[seed as usize][0] + verts[seed as usize][1] + verts[seed as usize][2]) / 3.0
                    * areas[seed as usize];
            let mut asum = areas[seed as usize];
            let mut members = vec![seed];
            tri_facet[seed as usize] = fid;
            queue.clear();
            queue.push_back(seed);
            // The growing region's plane: the mean normal at first, then the least-squares
            // plane, refitted each time the region doubles (O(n log n) in all).
            let mut fitted: Option<DVec3> = None;
            let mut next_refit = 16usize;
            while let Some(t) = queue.pop_front() {
                for &u in &adj[t as usize] {
                    if tri_facet[u as usize] != u32::MAX {
                        continue;
                    }
                    let n = fitted.unwrap_or_else(|| nsum.normalize());
                    let c = csum / asum;
                    let nu = normals[u as usize];
                    let dot = nu.dot(n);
                    if dot.abs() < cos_tol {
                        continue;
                    }
                    if verts[u as usize]
                        .iter()
                        .any(|v| (v - c).dot(n).abs() > dist_tol_m)
                    {
                        continue;
                    }
                    let a = areas[u as usize];
                    nsum += nu * dot.signum() * a;
                    csum += (verts[u as usize][0] + verts[u as usize][1] + verts[u as usize][2])
                        / 3.0
                        * a;
                    asum += a;
                    tri_facet[u as usize] = fid;
                    members.push(u);
                    queue.push_back(u);
                    if members.len() >= next_refit {
                        next_refit *= 2;
                        fitted = Some(fitted_normal(
                            &members,
                            &verts,
                            &areas,
                            csum / asum,
                            nsum.normalize(),
                        ));
                    }
                }
            }
            let centroid = csum / asum;
            let mut normal = fitted_normal(&members, &verts, &areas, centroid, nsum.normalize());
            let mut lo = DVec3::splat(f64::INFINITY);
            let mut hi = DVec3::splat(f64::NEG_INFINITY);
            for &m in &members {
                for v in verts[m as usize] {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            // Out of plumb over the facet's height: h·tan(tilt), tilt = asin|n_z|.
            let nz = normal.z.abs();
            let horizontal = (1.0 - nz * nz).max(0.0).sqrt();
            if vertical_tol_m > 0.0 && nz < 0.5 && (hi.z - lo.z) * nz < vertical_tol_m * horizontal
            {
                normal = DVec3::new(normal.x, normal.y, 0.0).normalize();
            }
            let offset = normal.dot(centroid);
            let mut thickness: f64 = 0.0;
            for &m in &members {
                for v in verts[m as usize] {
                    thickness = thickness.max((normal.dot(v) - offset).abs());
                }
            }
            facets.push(Facet {
                object: scene.tri_object[seed as usize],
                normal,
                offset,
                thickness,
                lo,
                hi,
                triangles: members,
            });
        }
        Facets { facets, tri_facet }
    }
}

/// Normal of the least-squares plane through the triangles `members` (area-weighted second
/// moment about `centroid`, exact for uniform density over each triangle: `A/12·(Σ vvᵀ + ssᵀ)`
/// with `s` the sum of the three vertices): the eigenvector of its smallest eigenvalue, oriented
/// like `mean_normal`. On an exact plane this is the plane's normal; on a noisy surface it is
/// unbiased where the mean of the triangle normals is not (the Poisson walls of the factory twin:
/// mean normal 3–5° off, least-squares plane within 0.4°). Falls back to `mean_normal` when the
/// triangles are (nearly) collinear.
fn fitted_normal(
    members: &[u32],
    verts: &[[DVec3; 3]],
    areas: &[f64],
    centroid: DVec3,
    mean_normal: DVec3,
) -> DVec3 {
    let mut c = [[0.0f64; 3]; 3];
    for &m in members {
        let v = verts[m as usize].map(|p| p - centroid);
        let s = v[0] + v[1] + v[2];
        let w = areas[m as usize] / 12.0;
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] +=
                    w * (v[0][i] * v[0][j] + v[1][i] * v[1][j] + v[2][i] * v[2][j] + s[i] * s[j]);
            }
        }
    }
    match smallest_eigenvector(DMat3::from_cols_array_2d(&c)) {
        Some(n) => {
            if n.dot(mean_normal) < 0.0 {
                -n
            } else {
                n
            }
        }
        None => mean_normal,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paths::trace::any_perpendicular;

    /// Rotation taking the z axis to `n` (Rodrigues), as a matrix of columns.
    fn basis(n: DVec3) -> [DVec3; 3] {
        let u = any_perpendicular(n);
        [u, n.cross(u), n]
    }

    /// A 10 m × 8 m wall in the y–z plane at x = 0, its top leaning `tilt_deg` toward +x, and a
    /// 10 m × 10 m flat roof at z = 8 m, as facets with `vertical_tol_m`.
    fn wall_and_roof_facets(tilt_deg: f64, vertical_tol_m: f64) -> Vec<Facet> {
        let t = (tilt_deg.to_radians().tan() * 8.0) as f32;
        let (a, b, c, d) = (
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::new(t, 10.0, 8.0),
            Vec3::new(t, 0.0, 8.0),
        );
        let r = |x: f32, y: f32| Vec3::new(x, y, 8.0);
        let scene = Scene::new(vec![
            crate::scene::Object {
                thickness_m: None,
                name: "wall".into(),
                material: crate::material::Material::Concrete,
                triangles: vec![[a, b, c], [a, c, d]],
            },
            crate::scene::Object {
                thickness_m: None,
                name: "roof".into(),
                material: crate::material::Material::Concrete,
                triangles: vec![
                    [r(1.0, 0.0), r(11.0, 0.0), r(11.0, 10.0)],
                    [r(1.0, 0.0), r(11.0, 10.0), r(1.0, 10.0)],
                ],
            },
        ])
        .unwrap();
        Facets::build(&scene, 15f64.to_radians(), 0.15, vertical_tol_m).facets
    }

    #[test]
    fn a_wall_tilt_below_the_resolution_is_made_plumb_and_a_resolved_one_is_kept() {
        // 0.5° over 8 m moves the top 7 cm: below a 0.375 m range cell, so plumb.
        let f = wall_and_roof_facets(0.5, 0.375);
        assert_eq!(f.len(), 2);
        let wall = f.iter().find(|f| f.object == 0).unwrap();
        assert!(wall.normal.z.abs() < 1e-12, "{:?}", wall.normal);
        assert!((wall.normal.x.abs() - 1.0).abs() < 1e-12);
        // The plane goes through the centroid (x = 3.5 cm) and the tilt is the thickness.
        assert!((wall.offset.abs() - 0.0349).abs() < 1e-3, "{}", wall.offset);
        assert!(wall.thickness > 0.03 && wall.thickness < 0.04);
        // The roof is not a wall: untouched.
        let roof = f.iter().find(|f| f.object == 1).unwrap();
        assert!((roof.normal.z.abs() - 1.0).abs() < 1e-12);
        // Off: the fitted tilt stays.
        let f = wall_and_roof_facets(0.5, 0.0);
        let wall = f.iter().find(|f| f.object == 0).unwrap();
        assert!((wall.normal.z.abs() - 0.5f64.to_radians().sin()).abs() < 1e-6);
        // 5° moves the top 0.70 m: resolved, kept.
        let f = wall_and_roof_facets(5.0, 0.375);
        let wall = f.iter().find(|f| f.object == 0).unwrap();
        assert!((wall.normal.z.abs() - 5f64.to_radians().sin()).abs() < 1e-6);
    }

    #[test]
    fn fitted_normal_of_exact_and_noisy_planes() {
        // Triangles of a 10 m × 5 m grid on the plane through p0 with normal n.
        let n = DVec3::new(0.2, -0.9, 0.3).normalize();
        let [u, v, _] = basis(n);
        let p0 = DVec3::new(3.0, -7.0, 2.0);
        let grid = |noise: f64| {
            let h = |i: i32, j: i32| {
                let x = ((i * 7919 + j * 104_729) as u32).wrapping_mul(2_654_435_761);
                (x as f64 / u32::MAX as f64 - 0.5) * noise
            };
            let q =
                |i: i32, j: i32| p0 + u * (i as f64 * 0.25) + v * (j as f64 * 0.25) + n * h(i, j);
            let mut t = Vec::new();
            for i in 0..40 {
                for j in 0..20 {
                    t.push([q(i, j), q(i + 1, j), q(i + 1, j + 1)]);
                    t.push([q(i, j), q(i + 1, j + 1), q(i, j + 1)]);
                }
            }
            t
        };
        for (noise, bound) in [(0.0, 1e-12), (0.1, 0.01)] {
            let verts = grid(noise);
            let areas: Vec<f64> = verts
                .iter()
                .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length())
                .collect();
            let members: Vec<u32> = (0..verts.len() as u32).collect();
            let mut c = DVec3::ZERO;
            for (t, a) in verts.iter().zip(&areas) {
                c += (t[0] + t[1] + t[2]) / 3.0 * *a;
            }
            let c = c / areas.iter().sum::<f64>();
            let f = fitted_normal(&members, &verts, &areas, c, -n);
            assert!(f.dot(n) < 0.0, "oriented like the mean normal given");
            // Exact plane: round-off only. Noisy (±5 cm uniform at 0.25 m spacing over 10 m ×
            // 5 m, 861 vertices): the least-squares tilt is about σ_h/(σ_x·√N) ≈ 0.029/(2.9·29)
            // ≈ 3.4e-4 rad per axis; 0.01 rad is ≥ 20 of those.
            let tilt = f.cross(n).length();
            assert!(tilt < bound, "noise {noise}: tilt {tilt}");
        }
    }
}
