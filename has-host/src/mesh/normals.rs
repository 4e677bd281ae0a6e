//! Point-cloud normals: PCA over the k nearest neighbours (the eigenvector of the smallest
//! eigenvalue of the neighbourhood covariance), then a consistent orientation.
//!
//! Orientation, in order of preference:
//! - [`Orientation::Sensors`] / [`Orientation::SensorSets`]: the caller knows which sensors saw
//!   each point (BSs, terminal apertures); the normal is flipped so that n·(s − p) > 0, by a
//!   majority vote over the point's sensors when there are several (ties keep the vote of the
//!   nearest sensor).
//! - [`Orientation::Propagate`] (fallback, Hoppe et al. 1992): a minimum spanning tree of the
//!   symmetric k-NN graph with edge cost 1 − |nᵢ·nⱼ| is grown from a seed in each connected
//!   component; the seed is the component's point farthest from the cloud's centroid, oriented
//!   away from the centroid; every other normal is flipped to agree with its tree parent.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::{DMat3, DVec3, Vec3};
use rayon::prelude::*;

use crate::knn::{check_points, GeometryError, PointIndex};

/// How to orient the PCA normals.
#[derive(Clone, Copy, Debug)]
pub enum Orientation<'a> {
    /// One sensor position per point.
    Sensors(&'a [Vec3]),
    /// Per point, the positions of every sensor that observed it (at least one each).
    SensorSets(&'a [Vec<Vec3>]),
    /// No sensor information: MST propagation (see the module docs).
    Propagate,
}

use crate::linalg::symmetric_eigen3;

/// Mean and covariance of points (f64).
pub fn covariance(points: impl Iterator<Item = Vec3> + Clone) -> (DVec3, DMat3) {
    let mut n = 0.0;
    let mut mean = DVec3::ZERO;
    for p in points.clone() {
        mean += p.as_dvec3();
        n += 1.0;
    }
    mean /= n;
    let mut c = DMat3::ZERO;
    for p in points {
        let d = p.as_dvec3() - mean;
        c += DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    }
    (mean, c * (1.0 / n))
}

/// Unoriented PCA normals over the `k` nearest neighbours of each point (the point included).
///
/// A neighbourhood whose two smallest eigenvalues are both zero (collinear points) has no
/// defined normal; it gets the eigenvector of the smallest anyway (some perpendicular).
///
/// # Errors
/// `k < 3`; fewer than `k` points; a non-finite point.
pub fn pca_normals(points: &[Vec3], k: usize) -> Result<(Vec<Vec3>, PointIndex), GeometryError> {
    pca_normals_over(points, Neighbourhood::Nearest(k))
}

/// Oriented unit normals: PCA over `k` neighbours, oriented as `orientation` says (module docs).
///
/// # Errors
/// As [`pca_normals`]; a sensor list whose length differs from the point count, an empty
/// sensor set or a non-finite sensor position (field `"sensors"`).
pub fn estimate_normals(
    points: &[Vec3],
    k: usize,
    orientation: Orientation<'_>,
) -> Result<Vec<Vec3>, GeometryError> {
    estimate_normals_over(points, Neighbourhood::Nearest(k), orientation)
}

/// The points a PCA normal is taken over.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Neighbourhood {
    /// The `k` nearest points (the point included).
    Nearest(usize),
    /// Every point within `radius_m` (metres, the point included), or the `min` nearest where
    /// fewer lie that close.
    Within {
        /// Radius, metres.
        radius_m: f32,
        /// Fewest points of a neighbourhood.
        min: usize,
    },
}

impl Neighbourhood {
    /// The fewest points of any neighbourhood.
    fn min_points(self) -> usize {
        match self {
            Neighbourhood::Nearest(k) => k,
            Neighbourhood::Within { min, .. } => min,
        }
    }
}

/// Unoriented PCA normals over each point's `neighbourhood` (as [`pca_normals`], which is the
/// [`Neighbourhood::Nearest`] case). The covariance sums the neighbours in index order, so the
/// result does not depend on the index's traversal or the thread count.
///
/// # Errors
/// As [`pca_normals`] with `k` the neighbourhood's fewest points; a radius that is not finite
/// and positive.
pub fn pca_normals_over(
    points: &[Vec3],
    neighbourhood: Neighbourhood,
) -> Result<(Vec<Vec3>, PointIndex), GeometryError> {
    let min = neighbourhood.min_points();
    if min < 3 {
        return Err(GeometryError::BadParameter {
            field: "k",
            value: min as f64,
            expected: "at least 3 neighbours",
        });
    }
    check_points("points", points)?;
    if points.len() < min {
        return Err(GeometryError::TooFew {
            field: "points",
            count: points.len(),
            needed: min,
        });
    }
    if let Neighbourhood::Within { radius_m, .. } = neighbourhood {
        if !(radius_m.is_finite() && radius_m > 0.0) {
            return Err(GeometryError::BadParameter {
                field: "radius_m",
                value: radius_m as f64,
                expected: "finite and positive",
            });
        }
    }
    let index = PointIndex::new("points", points)?;
    let normals = points
        .par_iter()
        .map(|&p| match neighbourhood {
            // Summed nearest first.
            Neighbourhood::Nearest(k) => {
                pca_normal(index.knn(p, k).iter().map(|n| points[n.0 as usize]))
            }
            Neighbourhood::Within { radius_m, min } => {
                let mut nb: Vec<u32> = index.within(p, radius_m).into_iter().map(|n| n.0).collect();
                if nb.len() < min {
                    nb = index.knn(p, min).into_iter().map(|n| n.0).collect();
                }
                nb.sort_unstable();
                pca_normal(nb.iter().map(|&i| points[i as usize]))
            }
        })
        .collect();
    Ok((normals, index))
}

/// The eigenvector of the smallest eigenvalue of `points`' covariance (unit, unoriented).
pub(crate) fn pca_normal(points: impl Iterator<Item = Vec3> + Clone) -> Vec3 {
    let (_, c) = covariance(points);
    symmetric_eigen3(c).1[0].as_vec3()
}

/// Oriented unit normals: PCA over each point's `neighbourhood`, oriented as `orientation` says
/// (module docs).
///
/// # Errors
/// As [`estimate_normals`] and [`pca_normals_over`].
pub fn estimate_normals_over(
    points: &[Vec3],
    neighbourhood: Neighbourhood,
    orientation: Orientation<'_>,
) -> Result<Vec<Vec3>, GeometryError> {
    let k = neighbourhood.min_points();
    let bad_len = |n: usize| GeometryError::BadParameter {
        field: "sensors",
        value: n as f64,
        expected: "one entry per point",
    };
    match orientation {
        Orientation::Sensors(s) => {
            if s.len() != points.len() {
                return Err(bad_len(s.len()));
            }
            check_points("sensors", s)?;
        }
        Orientation::SensorSets(s) => {
            if s.len() != points.len() {
                return Err(bad_len(s.len()));
            }
            for (i, set) in s.iter().enumerate() {
                if set.is_empty() {
                    return Err(GeometryError::TooFew {
                        field: "sensors",
                        count: 0,
                        needed: 1,
                    });
                }
                if let Some(v) = set.iter().find(|v| !v.is_finite()) {
                    return Err(GeometryError::NonFinite {
                        field: "sensors",
                        index: i,
                        value: *v,
                    });
                }
            }
        }
        Orientation::Propagate => {}
    }
    let (mut normals, index) = pca_normals_over(points, neighbourhood)?;
    match orientation {
        Orientation::Sensors(s) => {
            normals.par_iter_mut().enumerate().for_each(|(i, n)| {
                if n.dot(s[i] - points[i]) < 0.0 {
                    *n = -*n;
                }
            });
        }
        Orientation::SensorSets(s) => {
            normals.par_iter_mut().enumerate().for_each(|(i, n)| {
                let p = points[i];
                let vote: i32 = s[i]
                    .iter()
                    .map(|&q| if n.dot(q - p) >= 0.0 { 1 } else { -1 })
                    .sum();
                let flip = if vote == 0 {
                    let nearest = s[i]
                        .iter()
                        .min_by(|a, b| a.distance_squared(p).total_cmp(&b.distance_squared(p)))
                        .copied()
                        .unwrap_or(p);
                    n.dot(nearest - p) < 0.0
                } else {
                    vote < 0
                };
                if flip {
                    *n = -*n;
                }
            });
        }
        Orientation::Propagate => propagate(points, &mut normals, &index, k),
    }
    Ok(normals)
}

/// MST orientation propagation over the symmetric k-NN graph (module docs).
fn propagate(points: &[Vec3], normals: &mut [Vec3], index: &PointIndex, k: usize) {
    let n = points.len();
    let nbrs: Vec<Vec<u32>> = points
        .par_iter()
        .map(|&p| index.knn(p, k).into_iter().map(|(i, _)| i).collect())
        .collect();
    // Symmetrise.
    let mut adj: Vec<Vec<u32>> = nbrs.clone();
    for (i, list) in nbrs.iter().enumerate() {
        for &j in list {
            if j as usize != i {
                adj[j as usize].push(i as u32);
            }
        }
    }
    for l in &mut adj {
        l.sort_unstable();
        l.dedup();
    }
    let (centroid, _) = covariance(points.iter().copied());
    let centroid = centroid.as_vec3();
    // Seeds: process points by decreasing distance from the centroid; each not-yet-visited one
    // starts a new component.
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.sort_by(|&a, &b| {
        points[b as usize]
            .distance_squared(centroid)
            .total_cmp(&points[a as usize].distance_squared(centroid))
    });
    let mut visited = vec![false; n];
    let mut heap: BinaryHeap<(Reverse<u32>, u32, u32)> = BinaryHeap::new();
    for &seed in &order {
        if visited[seed as usize] {
            continue;
        }
        let s = seed as usize;
        if normals[s].dot(points[s] - centroid) < 0.0 {
            normals[s] = -normals[s];
        }
        visited[s] = true;
        let push = |heap: &mut BinaryHeap<_>, from: u32, normals: &[Vec3], visited: &[bool]| {
            for &j in &adj[from as usize] {
                if !visited[j as usize] {
                    let w = 1.0 - normals[from as usize].dot(normals[j as usize]).abs();
                    // Costs in [0, 1] quantised to u32 for a total order.
                    let key = (w.clamp(0.0, 1.0) * 1.0e9) as u32;
                    heap.push((Reverse(key), j, from));
                }
            }
        };
        push(&mut heap, seed, normals, &visited);
        while let Some((_, j, parent)) = heap.pop() {
            let ju = j as usize;
            if visited[ju] {
                continue;
            }
            visited[ju] = true;
            if normals[ju].dot(normals[parent as usize]) < 0.0 {
                normals[ju] = -normals[ju];
            }
            push(&mut heap, j, normals, &visited);
        }
    }
}

/// `n` points of a Fibonacci lattice on the sphere of `radius` about `centre` (tests).
#[cfg(test)]
pub(crate) fn fibonacci_sphere(n: usize, centre: Vec3, radius: f32) -> Vec<Vec3> {
    let g = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - z * z).sqrt();
            let t = g * i as f32;
            centre + radius * Vec3::new(r * t.cos(), r * t.sin(), z)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Radius 2 m, centred at (1, 2, 3).
    fn sphere(n: usize) -> Vec<Vec3> {
        fibonacci_sphere(n, Vec3::new(1.0, 2.0, 3.0), 2.0)
    }

    #[test]
    fn sphere_normals_are_radial_and_outward_with_sensors_and_with_propagation() {
        // 4000 points on a 2 m sphere: mean spacing √(4π·4/4000) ≈ 0.11 m; 16 neighbours span
        // ≈ 0.25 m, where the sphere deviates from its tangent plane by r²/2R ≈ 0.016 m: the
        // PCA normal of a symmetric cap is radial up to the Fibonacci lattice's asymmetry, so
        // ask for < 3° (cos > 0.9986).
        let pts = sphere(4000);
        let c = Vec3::new(1.0, 2.0, 3.0);
        let sensors: Vec<Vec3> = pts.iter().map(|&p| c + (p - c) * 5.0).collect();
        for o in [Orientation::Sensors(&sensors), Orientation::Propagate] {
            let n = estimate_normals(&pts, 16, o).unwrap();
            for (p, n) in pts.iter().zip(&n) {
                let radial = (*p - c).normalize();
                assert!(n.dot(radial) > 0.9986, "{p} {n}");
            }
        }
        // Sensors inside the sphere turn every normal inward.
        let inside: Vec<Vec<Vec3>> = pts.iter().map(|_| vec![c, c + Vec3::X * 0.1]).collect();
        let n = estimate_normals(&pts, 16, Orientation::SensorSets(&inside)).unwrap();
        assert!(pts.iter().zip(&n).all(|(p, n)| n.dot(*p - c) < 0.0));
    }

    /// A wall imaged as the fused cloud holds it: samples on a 0.25 m lattice in the plane
    /// x = 0, each displaced across the wall by up to ±0.6 m (a resolution cell's scatter).
    fn scattered_wall() -> Vec<Vec3> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut pts = Vec::new();
        for iy in 0..80 {
            for iz in 0..40 {
                let x = rng.random_range(-0.6f32..0.6);
                pts.push(Vec3::new(x, iy as f32 * 0.25, iz as f32 * 0.25));
            }
        }
        pts
    }

    fn median_tilt_deg(normals: &[Vec3]) -> f32 {
        let mut a: Vec<f32> = normals
            .iter()
            .map(|n| n.x.abs().clamp(0.0, 1.0).acos().to_degrees())
            .collect();
        a.sort_by(f32::total_cmp);
        a[a.len() / 2]
    }

    #[test]
    fn a_scattered_wall_has_its_normal_over_a_cell_and_not_over_sixteen_neighbours() {
        // Sixteen neighbours span ~0.6 m of wall, as much as the scatter across it: their PCA
        // normal is noise. Every sample within 2 m spans the wall's extent well beyond the
        // scatter: tilt ~ σ/(R/2)/√N with σ ≈ 0.35, R = 2, N ≈ 200, about 2°.
        let pts = scattered_wall();
        let (k16, _) = pca_normals(&pts, 16).unwrap();
        let within = Neighbourhood::Within {
            radius_m: 2.0,
            min: 16,
        };
        let (cell, _) = pca_normals_over(&pts, within).unwrap();
        let (t16, tcell) = (median_tilt_deg(&k16), median_tilt_deg(&cell));
        assert!(t16 > 20.0, "16 neighbours: {t16}°");
        assert!(tcell < 6.0, "within 2 m: {tcell}°");
        // A radius that holds fewer than `min` points takes the `min` nearest instead.
        let tiny = Neighbourhood::Within {
            radius_m: 1e-3,
            min: 16,
        };
        let ttiny = median_tilt_deg(&pca_normals_over(&pts, tiny).unwrap().0);
        assert!((ttiny - t16).abs() < 0.01, "{ttiny}° vs {t16}°");
        for radius_m in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                pca_normals_over(&pts, Neighbourhood::Within { radius_m, min: 16 }),
                Err(GeometryError::BadParameter {
                    field: "radius_m",
                    ..
                })
            ));
        }
    }

    #[test]
    fn normals_reject_bad_k_too_few_nan_and_bad_sensors() {
        let pts = sphere(10);
        assert!(matches!(
            estimate_normals(&pts, 2, Orientation::Propagate),
            Err(GeometryError::BadParameter { field: "k", .. })
        ));
        assert_eq!(
            estimate_normals(&pts, 11, Orientation::Propagate).unwrap_err(),
            GeometryError::TooFew {
                field: "points",
                count: 10,
                needed: 11
            }
        );
        let mut bad = pts.clone();
        bad[3].z = f32::INFINITY;
        assert!(matches!(
            estimate_normals(&bad, 5, Orientation::Propagate),
            Err(GeometryError::NonFinite {
                field: "points",
                index: 3,
                ..
            })
        ));
        assert!(matches!(
            estimate_normals(&pts, 5, Orientation::Sensors(&pts[..3])),
            Err(GeometryError::BadParameter {
                field: "sensors",
                ..
            })
        ));
        let empty: Vec<Vec<Vec3>> = vec![Vec::new(); 10];
        assert!(matches!(
            estimate_normals(&pts, 5, Orientation::SensorSets(&empty)),
            Err(GeometryError::TooFew {
                field: "sensors",
                ..
            })
        ));
    }
}
