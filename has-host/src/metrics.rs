//! Reconstruction quality metrics of the paper (§1.3): Chamfer distance (eq. 2), precision,
//! recall and F-score (eq. 3), and uniform area-weighted sampling of triangle meshes, which gives
//! both the ground truth S2 (samples on the true surfaces) and S1 for a reconstructed mesh.
//!
//! Conventions, exactly as the paper:
//! - CD(S1, S2) = mean over x∈S1 of min_y ‖x−y‖² + mean over y∈S2 of min_x ‖x−y‖² (squared
//!   distances, each direction averaged over its own set, the two means summed), in m²; the
//!   reported figure is √CD in metres.
//! - P(d) = 100·|{x∈S1 : min_y ‖x−y‖ < d}| / |S1|, R(d) = 100·|{y∈S2 : min_x ‖x−y‖ < d}| / |S2|
//!   (strict `<`, percent); F = 2PR/(P+R), defined as 0 when P + R = 0.
//!
//! S1 is the reconstruction (mesh samples or the imaging cloud), S2 the ground truth. Nearest
//! neighbours come from a k-d tree ([`PointIndex`]), queries in parallel with rayon; sums are
//! accumulated in f64.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::knn::{GeometryError, PointIndex};

/// F-score thresholds every report carries, metres (the paper's headline is 1.5 m).
pub const REPORT_THRESHOLDS_M: [f32; 3] = [0.5, 1.0, 1.5];

/// Precision, recall and F-score at one distance threshold (eq. 3), in percent.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FScore {
    /// Threshold d, metres.
    pub threshold_m: f32,
    /// P(d), percent of S1 within d of S2.
    pub precision_pct: f64,
    /// R(d), percent of S2 within d of S1.
    pub recall_pct: f64,
    /// 2PR/(P+R), percent (0 when P + R = 0).
    pub fscore_pct: f64,
}

/// Nearest-neighbour distances of S1 → S2 and S2 → S1, from which every metric follows.
#[derive(Clone, Debug)]
pub struct CloudComparison {
    /// For each x∈S1, min over S2 of the squared distance, m².
    pub s1_to_s2_sq_m2: Vec<f32>,
    /// For each y∈S2, min over S1 of the squared distance, m².
    pub s2_to_s1_sq_m2: Vec<f32>,
}

fn mean_f64(v: &[f32]) -> f64 {
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
}

fn pct_below(v: &[f32], thr_sq: f32) -> f64 {
    100.0 * v.iter().filter(|&&x| x < thr_sq).count() as f64 / v.len() as f64
}

impl CloudComparison {
    /// Computes both nearest-neighbour distance sets.
    ///
    /// # Errors
    /// Either set empty or holding a non-finite point (`field` is `"s1"` or `"s2"`).
    pub fn new(s1: &[Vec3], s2: &[Vec3]) -> Result<CloudComparison, GeometryError> {
        let i1 = PointIndex::new("s1", s1)?;
        let i2 = PointIndex::new("s2", s2)?;
        Ok(CloudComparison {
            s1_to_s2_sq_m2: i2.nearest_sq_many(s1),
            s2_to_s1_sq_m2: i1.nearest_sq_many(s2),
        })
    }

    /// Chamfer distance (eq. 2), m².
    pub fn chamfer_m2(&self) -> f64 {
        mean_f64(&self.s1_to_s2_sq_m2) + mean_f64(&self.s2_to_s1_sq_m2)
    }

    /// √CD, metres: the paper's reported figure.
    pub fn sqrt_chamfer_m(&self) -> f64 {
        self.chamfer_m2().sqrt()
    }

    /// Root-mean-square distance from S1 to S2, metres ("accuracy": how far the reconstruction
    /// lies from the truth). √CD² is the sum of the squares of this and [`Self::rms_s2_to_s1_m`].
    pub fn rms_s1_to_s2_m(&self) -> f64 {
        mean_f64(&self.s1_to_s2_sq_m2).sqrt()
    }

    /// Root-mean-square distance from S2 to S1, metres ("completeness": how far the truth lies
    /// from the reconstruction).
    pub fn rms_s2_to_s1_m(&self) -> f64 {
        mean_f64(&self.s2_to_s1_sq_m2).sqrt()
    }

    /// Completeness on a subset of S2 (`keep[i]` for S2 point i): the rms distance from the kept
    /// S2 points to S1 (m) and the percentage of them within `d_m` of S1 (the recall of eq. 3
    /// restricted to them). `None` if `keep` has another length than S2 or keeps nothing.
    pub fn completeness_on(&self, keep: &[bool], d_m: f32) -> Option<(f64, f64)> {
        if keep.len() != self.s2_to_s1_sq_m2.len() {
            return None;
        }
        let kept: Vec<f32> = self
            .s2_to_s1_sq_m2
            .iter()
            .zip(keep)
            .filter(|(_, &k)| k)
            .map(|(&d, _)| d)
            .collect();
        if kept.is_empty() {
            return None;
        }
        Some((mean_f64(&kept).sqrt(), pct_below(&kept, d_m * d_m)))
    }

    /// Precision, recall and F-score at threshold `d_m` (eq. 3).
    ///
    /// # Errors
    /// `d_m` not finite and positive.
    pub fn fscore(&self, d_m: f32) -> Result<FScore, GeometryError> {
        if !(d_m.is_finite() && d_m > 0.0) {
            return Err(GeometryError::BadParameter {
                field: "threshold_m",
                value: d_m as f64,
                expected: "finite and > 0",
            });
        }
        let thr_sq = d_m * d_m;
        let p = pct_below(&self.s1_to_s2_sq_m2, thr_sq);
        let r = pct_below(&self.s2_to_s1_sq_m2, thr_sq);
        let f = if p + r > 0.0 {
            2.0 * p * r / (p + r)
        } else {
            0.0
        };
        Ok(FScore {
            threshold_m: d_m,
            precision_pct: p,
            recall_pct: r,
            fscore_pct: f,
        })
    }
}

/// Precision, recall and F-score at one of [`REPORT_THRESHOLDS_M`], flattened into a report as
/// `fscore_<d>m`, `precision_<d>m`, `recall_<d>m` (`d` with `_` for the point: `0_5`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FScoreFields {
    /// F-score at 0.5 m, percent.
    pub fscore_0_5m: f64,
    /// Precision at 0.5 m, percent.
    pub precision_0_5m: f64,
    /// Recall at 0.5 m, percent.
    pub recall_0_5m: f64,
    /// F-score at 1.0 m, percent.
    pub fscore_1_0m: f64,
    /// Precision at 1.0 m, percent.
    pub precision_1_0m: f64,
    /// Recall at 1.0 m, percent.
    pub recall_1_0m: f64,
    /// F-score at 1.5 m (the paper's headline), percent.
    pub fscore_1_5m: f64,
    /// Precision at 1.5 m, percent.
    pub precision_1_5m: f64,
    /// Recall at 1.5 m, percent.
    pub recall_1_5m: f64,
}

/// A reconstruction (S1) scored against the truth (S2): every figure a report carries.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CloudMetrics {
    /// √CD, metres (eq. 2).
    pub sqrt_chamfer_m: f64,
    /// rms distance S1 → S2 (accuracy), metres.
    pub rms_to_truth_m: f64,
    /// rms distance S2 → S1 (completeness), metres.
    pub rms_from_truth_m: f64,
    /// |S1|.
    pub points: usize,
    /// |S2|.
    pub truth_points: usize,
    /// Eq. 3 at [`REPORT_THRESHOLDS_M`].
    #[serde(flatten)]
    pub fscores: FScoreFields,
}

impl CloudMetrics {
    /// The figures of `c` (S1 of `points`, S2 of `truth_points` points).
    ///
    /// # Errors
    /// None in practice (the thresholds are valid); as [`CloudComparison::fscore`].
    pub fn new(
        c: &CloudComparison,
        points: usize,
        truth_points: usize,
    ) -> Result<CloudMetrics, GeometryError> {
        let [a, b, d] = REPORT_THRESHOLDS_M.map(|t| c.fscore(t));
        let (a, b, d) = (a?, b?, d?);
        Ok(CloudMetrics {
            sqrt_chamfer_m: c.sqrt_chamfer_m(),
            rms_to_truth_m: c.rms_s1_to_s2_m(),
            rms_from_truth_m: c.rms_s2_to_s1_m(),
            points,
            truth_points,
            fscores: FScoreFields {
                fscore_0_5m: a.fscore_pct,
                precision_0_5m: a.precision_pct,
                recall_0_5m: a.recall_pct,
                fscore_1_0m: b.fscore_pct,
                precision_1_0m: b.precision_pct,
                recall_1_0m: b.recall_pct,
                fscore_1_5m: d.fscore_pct,
                precision_1_5m: d.precision_pct,
                recall_1_5m: d.recall_pct,
            },
        })
    }

    /// S1 scored against S2: [`CloudComparison::new`] then [`CloudMetrics::new`] with both
    /// sets' sizes.
    ///
    /// # Errors
    /// As [`CloudComparison::new`].
    pub fn between(s1: &[Vec3], s2: &[Vec3]) -> Result<CloudMetrics, GeometryError> {
        CloudMetrics::new(&CloudComparison::new(s1, s2)?, s1.len(), s2.len())
    }

    /// The F-scores at [`REPORT_THRESHOLDS_M`], in that order.
    pub fn fscores(&self) -> [FScore; 3] {
        let f = &self.fscores;
        let at = |threshold_m, fscore_pct, precision_pct, recall_pct| FScore {
            threshold_m,
            precision_pct,
            recall_pct,
            fscore_pct,
        };
        let [a, b, d] = REPORT_THRESHOLDS_M;
        [
            at(a, f.fscore_0_5m, f.precision_0_5m, f.recall_0_5m),
            at(b, f.fscore_1_0m, f.precision_1_0m, f.recall_1_0m),
            at(d, f.fscore_1_5m, f.precision_1_5m, f.recall_1_5m),
        ]
    }
}

/// Completeness on one part of the truth: rms distance from it to S1 and its recall at 1.5 m.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Completeness {
    /// rms distance from the part's truth points to S1, metres.
    pub rms_from_truth_m: f64,
    /// Percentage of the part's truth points within 1.5 m of S1.
    pub recall_1_5m: f64,
}

/// Completeness on the part of the truth that `observable` flags and on the rest (`None`
/// where a part is empty).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ObservableCompleteness {
    /// On the flagged truth points.
    pub observable: Option<Completeness>,
    /// On the others.
    pub hidden: Option<Completeness>,
}

impl ObservableCompleteness {
    /// Splits `c`'s completeness by `observable` (one flag per S2 point).
    pub fn new(c: &CloudComparison, observable: &[bool]) -> ObservableCompleteness {
        let hidden: Vec<bool> = observable.iter().map(|&o| !o).collect();
        let part = |keep: &[bool]| {
            c.completeness_on(keep, 1.5)
                .map(|(rms_from_truth_m, recall_1_5m)| Completeness {
                    rms_from_truth_m,
                    recall_1_5m,
                })
        };
        ObservableCompleteness {
            observable: part(observable),
            hidden: part(&hidden),
        }
    }
}

/// √CD(S1, S2) in metres (eq. 2).
///
/// # Errors
/// As [`CloudComparison::new`].
pub fn sqrt_chamfer_m(s1: &[Vec3], s2: &[Vec3]) -> Result<f64, GeometryError> {
    Ok(CloudComparison::new(s1, s2)?.sqrt_chamfer_m())
}

/// F-score of S1 against S2 at threshold `d_m` (eq. 3).
///
/// # Errors
/// As [`CloudComparison::new`] and [`CloudComparison::fscore`].
pub fn fscore(s1: &[Vec3], s2: &[Vec3], d_m: f32) -> Result<FScore, GeometryError> {
    CloudComparison::new(s1, s2)?.fscore(d_m)
}

/// Most samples one call may produce (guards against a density typo exhausting memory).
pub const MAX_SAMPLES: f64 = 2.0e8;

/// N(0, σ²) for the noise generators, `sigma_m` checked.
fn zero_mean_normal(sigma_m: f32) -> Result<rand_distr::Normal<f32>, GeometryError> {
    let bad = || GeometryError::BadParameter {
        field: "sigma_m",
        value: sigma_m as f64,
        expected: "finite and ≥ 0",
    };
    if !(sigma_m.is_finite() && sigma_m >= 0.0) {
        return Err(bad());
    }
    rand_distr::Normal::new(0.0f32, sigma_m).map_err(|_| bad())
}

/// `points` moved by isotropic Gaussian noise of standard deviation `sigma_m` per axis (seeded
/// ChaCha8, the x, y, z draws of each point in turn): a stand-in for an imaging cloud in tests,
/// examples and benchmarks.
///
/// # Errors
/// [`GeometryError::BadParameter`] for a `sigma_m` that is negative or not finite.
pub fn gaussian_jitter(
    points: &[Vec3],
    sigma_m: f32,
    seed: u64,
) -> Result<Vec<Vec3>, GeometryError> {
    let normal = zero_mean_normal(sigma_m)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    Ok(points
        .iter()
        .map(|&p| {
            use rand_distr::Distribution;
            p + Vec3::new(
                normal.sample(&mut rng),
                normal.sample(&mut rng),
                normal.sample(&mut rng),
            )
        })
        .collect())
}

/// `n` points uniform on the sphere of centre `centre` and radius `radius_m`, each moved along
/// its radius by N(0, σ²) (seeded ChaCha8: per point the cosine of the polar angle, the azimuth,
/// then the radial noise), and the sphere's outward unit normals there: an oriented noisy cloud
/// for the meshing tests.
///
/// # Errors
/// [`GeometryError::BadParameter`] for a radius not finite and positive or a `sigma_m` negative
/// or not finite.
pub fn noisy_sphere(
    n: usize,
    centre: Vec3,
    radius_m: f32,
    sigma_m: f32,
    seed: u64,
) -> Result<(Vec<Vec3>, Vec<Vec3>), GeometryError> {
    if !(radius_m.is_finite() && radius_m > 0.0) {
        return Err(GeometryError::BadParameter {
            field: "radius_m",
            value: radius_m as f64,
            expected: "finite and > 0",
        });
    }
    let normal = zero_mean_normal(sigma_m)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    Ok((0..n)
        .map(|_| {
            use rand::Rng;
            use rand_distr::Distribution;
            let z: f32 = rng.random_range(-1.0..1.0);
            let phi: f32 = rng.random_range(0.0..std::f32::consts::TAU);
            let s = (1.0 - z * z).sqrt();
            let d = Vec3::new(s * phi.cos(), s * phi.sin(), z);
            (centre + d * (radius_m + normal.sample(&mut rng)), d)
        })
        .unzip())
}

/// Uniform, area-weighted random samples on triangles, `density_per_m2` points per m² on
/// average, reproducible from `seed`.
///
/// Each triangle of area A receives ⌊A·ρ + u⌋ points (u uniform in [0, 1)), so its expected
/// count is exactly A·ρ and the total deviates from the total area × ρ by at most a few
/// √(triangles)/2; a point is v0 + a·(v1 − v0) + b·(v2 − v0) with (a, b) uniform on the unit
/// triangle (square-root warping). Degenerate triangles get no points.
///
/// # Errors
/// Density not finite and positive; a non-finite vertex; more than [`MAX_SAMPLES`] expected.
pub fn sample_triangles(
    triangles: &[[Vec3; 3]],
    density_per_m2: f64,
    seed: u64,
) -> Result<Vec<Vec3>, GeometryError> {
    sample_triangles_oriented(triangles, density_per_m2, seed).map(|(points, _)| points)
}

/// [`sample_triangles`] with each sample's unit normal, its triangle's (right-handed winding:
/// outward on the scene's solids; zero for a degenerate triangle). The points are those of
/// [`sample_triangles`] for the same arguments.
///
/// # Errors
/// As [`sample_triangles`].
pub fn sample_triangles_oriented(
    triangles: &[[Vec3; 3]],
    density_per_m2: f64,
    seed: u64,
) -> Result<(Vec<Vec3>, Vec<Vec3>), GeometryError> {
    if !(density_per_m2.is_finite() && density_per_m2 > 0.0) {
        return Err(GeometryError::BadParameter {
            field: "density_per_m2",
            value: density_per_m2,
            expected: "finite and > 0",
        });
    }
    let mut total_area = 0.0f64;
    for (i, t) in triangles.iter().enumerate() {
        if let Some(v) = t.iter().find(|v| !v.is_finite()) {
            return Err(GeometryError::NonFinite {
                field: "triangles",
                index: i,
                value: *v,
            });
        }
        total_area += triangle_area(t) as f64;
    }
    let expected = total_area * density_per_m2;
    if expected > MAX_SAMPLES {
        return Err(GeometryError::BadParameter {
            field: "density_per_m2",
            value: density_per_m2,
            expected: "small enough that area × density ≤ 2e8 samples",
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let capacity = expected as usize + triangles.len().min(1 << 20);
    let (mut out, mut normals) = (Vec::with_capacity(capacity), Vec::with_capacity(capacity));
    for t in triangles {
        let a = triangle_area(t) as f64;
        let u: f64 = rng.random();
        let n = (a * density_per_m2 + u).floor() as usize;
        let e1 = t[1] - t[0];
        let e2 = t[2] - t[0];
        let normal = e1.cross(e2).normalize_or_zero();
        for _ in 0..n {
            let r1: f32 = rng.random();
            let r2: f32 = rng.random();
            let s = r1.sqrt();
            // Barycentric (1 − s, s(1 − r2), s·r2) is uniform on the triangle.
            out.push(t[0] + e1 * (s * (1.0 - r2)) + e2 * (s * r2));
            normals.push(normal);
        }
    }
    Ok((out, normals))
}

/// [`sample_triangles`] on an indexed mesh (`faces` index into `vertices`).
///
/// # Errors
/// As [`sample_triangles`], plus [`GeometryError::BadFace`] for an out-of-range index.
pub fn sample_mesh(
    vertices: &[Vec3],
    faces: &[[u32; 3]],
    density_per_m2: f64,
    seed: u64,
) -> Result<Vec<Vec3>, GeometryError> {
    let tris = indexed_triangles(vertices, faces)?;
    sample_triangles(&tris, density_per_m2, seed)
}

/// Expands an indexed mesh into triangles, checking every index.
///
/// # Errors
/// [`GeometryError::BadFace`] for an index ≥ `vertices.len()`.
pub fn indexed_triangles(
    vertices: &[Vec3],
    faces: &[[u32; 3]],
) -> Result<Vec<[Vec3; 3]>, GeometryError> {
    faces
        .iter()
        .enumerate()
        .map(|(fi, f)| {
            let mut t = [Vec3::ZERO; 3];
            for (k, &vi) in f.iter().enumerate() {
                t[k] = *vertices.get(vi as usize).ok_or(GeometryError::BadFace {
                    face: fi,
                    vertex: vi,
                    vertex_count: vertices.len(),
                })?;
            }
            Ok(t)
        })
        .collect()
}

/// Area of a triangle, m².
pub fn triangle_area(t: &[Vec3; 3]) -> f32 {
    0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()
}

/// How much of a reconstructed surface is false and how large it is against the truth: the
/// mesh-only metrics of issue 13, beside Chamfer and F-score.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SurfaceAreaMetrics {
    /// Distance beyond which a piece of the reconstruction counts as false, metres.
    pub threshold_m: f32,
    /// Percent of the reconstruction's area farther than `threshold_m` from the nearest truth
    /// point (area-weighted through uniform area samples).
    pub false_surface_pct: f64,
    /// Area of the reconstruction, m².
    pub area_m2: f64,
    /// Area of the true surfaces, m² (the sum of the truth triangles' areas).
    pub truth_area_m2: f64,
    /// `area_m2 / truth_area_m2`: above 1 for sheets and ghost surfaces, below 1 for holes.
    pub area_ratio: f64,
}

/// [`SurfaceAreaMetrics`] of a reconstruction of area `area_m2` given by its uniform,
/// area-weighted samples `samples` (e.g. `TriMesh::sample`), against the truth samples `truth`
/// and the true triangles `truth_triangles`. A sample farther than `threshold_m` (strictly) from
/// every truth point is false surface; since the samples are uniform over the area, their share
/// is the false share of the area (it equals 100 − the precision of eq. 3 at that distance,
/// up to the `<` / `>` boundary).
///
/// # Errors
/// `samples` or `truth` empty or non-finite; `threshold_m` not finite and positive; `area_m2`
/// negative or not finite; a non-finite truth vertex or a truth area of zero.
pub fn surface_area_metrics(
    samples: &[Vec3],
    area_m2: f64,
    truth: &[Vec3],
    truth_triangles: &[[Vec3; 3]],
    threshold_m: f32,
) -> Result<SurfaceAreaMetrics, GeometryError> {
    if !(threshold_m.is_finite() && threshold_m > 0.0) {
        return Err(GeometryError::BadParameter {
            field: "threshold_m",
            value: threshold_m as f64,
            expected: "finite and > 0",
        });
    }
    if !(area_m2.is_finite() && area_m2 >= 0.0) {
        return Err(GeometryError::BadParameter {
            field: "area_m2",
            value: area_m2,
            expected: "finite and ≥ 0",
        });
    }
    let mut truth_area_m2 = 0.0f64;
    for (i, t) in truth_triangles.iter().enumerate() {
        if let Some(v) = t.iter().find(|v| !v.is_finite()) {
            return Err(GeometryError::NonFinite {
                field: "truth_triangles",
                index: i,
                value: *v,
            });
        }
        truth_area_m2 += triangle_area(t) as f64;
    }
    if truth_area_m2 <= 0.0 {
        return Err(GeometryError::BadParameter {
            field: "truth_triangles",
            value: truth_area_m2,
            expected: "a total area > 0",
        });
    }
    let index = PointIndex::new("truth", truth)?;
    PointIndex::new("samples", samples)?;
    let d2 = index.nearest_sq_many(samples);
    let thr_sq = threshold_m * threshold_m;
    let far = d2.iter().filter(|&&d| d > thr_sq).count();
    Ok(SurfaceAreaMetrics {
        threshold_m,
        false_surface_pct: 100.0 * far as f64 / samples.len() as f64,
        area_m2,
        truth_area_m2,
        area_ratio: area_m2 / truth_area_m2,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_metrics_carry_the_fscore_of_each_report_threshold() {
        let truth = grid(20, 0.25, 0.0);
        let cloud: Vec<Vec3> = grid(12, 0.4, 0.7);
        let c = CloudComparison::new(&cloud, &truth).unwrap();
        let m = CloudMetrics::new(&c, cloud.len(), truth.len()).unwrap();
        assert_eq!(m.sqrt_chamfer_m, c.sqrt_chamfer_m());
        for (f, d) in m.fscores().iter().zip(REPORT_THRESHOLDS_M) {
            assert_eq!(*f, c.fscore(d).unwrap(), "threshold {d}");
        }
        // The thresholds straddle the plane offset, so the three scores differ.
        let [a, _, b] = m.fscores();
        assert!(a.fscore_pct < b.fscore_pct);
    }

    #[test]
    fn metrics_between_two_sets_count_each_set_and_score_s1_against_s2() {
        // S1 = {0}, S2 = {0, 2 m along x} (as in `chamfer_is_asymmetric_in_means_as_eq2`):
        // precision(1 m) 100, recall(1 m) 50; the counts are |S1| = 1 and |S2| = 2.
        let s1 = [Vec3::ZERO];
        let s2 = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)];
        let m = CloudMetrics::between(&s1, &s2).unwrap();
        assert_eq!((m.points, m.truth_points), (1, 2));
        assert_eq!(
            (m.fscores.precision_1_0m, m.fscores.recall_1_0m),
            (100.0, 50.0)
        );
        assert_eq!(m.rms_to_truth_m, 0.0);
        assert!(CloudMetrics::between(&[], &s2).is_err());
    }

    /// Points on a regular n×n grid of spacing `s` on the plane z = `z`.
    fn grid(n: usize, s: f32, z: f32) -> Vec<Vec3> {
        let mut v = Vec::new();
        for i in 0..n {
            for j in 0..n {
                v.push(Vec3::new(i as f32 * s, j as f32 * s, z));
            }
        }
        v
    }

    #[test]
    fn parallel_planes_offset_h_give_sqrt_cd_h_sqrt2_and_fscore_step_at_h() {
        // Same grid on z = 0 and z = h with spacing s > h: every nearest neighbour is the point
        // straight across (distance h; any other is √(h² + s²) > h), so each mean of squared
        // distances is h² and CD = 2h², √CD = h√2. Every distance equals h, so F jumps from 0
        // (d < h) to 100 (d > h).
        let h = 0.3f32;
        let a = grid(20, 0.5, 0.0);
        let b = grid(20, 0.5, h);
        let c = CloudComparison::new(&a, &b).unwrap();
        let want = h as f64 * 2f64.sqrt();
        // f32 rounding of h and h²: relative error ≲ 1e-7.
        assert!(
            (c.sqrt_chamfer_m() - want).abs() < 1e-6,
            "{}",
            c.sqrt_chamfer_m()
        );
        let below = c.fscore(0.99 * h).unwrap();
        assert_eq!(
            (below.precision_pct, below.recall_pct, below.fscore_pct),
            (0.0, 0.0, 0.0)
        );
        let above = c.fscore(1.01 * h).unwrap();
        assert_eq!(
            (above.precision_pct, above.recall_pct, above.fscore_pct),
            (100.0, 100.0, 100.0)
        );
    }

    #[test]
    fn chamfer_is_asymmetric_in_means_as_eq2() {
        // S1 = {0}, S2 = {0, 2 m along x}. S1→S2 mean = 0; S2→S1 mean = (0 + 4)/2 = 2 m².
        // CD = 2, √CD = √2. Precision(1 m) = 100, recall(1 m) = 50, F = 2·100·50/150 = 66.67.
        let s1 = [Vec3::ZERO];
        let s2 = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)];
        let c = CloudComparison::new(&s1, &s2).unwrap();
        assert!((c.chamfer_m2() - 2.0).abs() < 1e-12);
        let f = c.fscore(1.0).unwrap();
        assert_eq!(f.precision_pct, 100.0);
        assert_eq!(f.recall_pct, 50.0);
        assert!((f.fscore_pct - 200.0 / 3.0).abs() < 1e-9);
    }

    #[test]
    fn directional_rms_and_subset_completeness_split_eq2() {
        // Same sets as above: S1→S2 rms 0, S2→S1 rms √2; their squares sum to CD.
        let s1 = [Vec3::ZERO];
        let s2 = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)];
        let c = CloudComparison::new(&s1, &s2).unwrap();
        assert_eq!(c.rms_s1_to_s2_m(), 0.0);
        assert!((c.rms_s2_to_s1_m() - 2f64.sqrt()).abs() < 1e-12);
        let sum = c.rms_s1_to_s2_m().powi(2) + c.rms_s2_to_s1_m().powi(2);
        assert!((sum - c.chamfer_m2()).abs() < 1e-12);
        // Keeping only the far point: rms 2 m, recall(1 m) 0 %; only the near one: 0 m, 100 %.
        assert_eq!(c.completeness_on(&[false, true], 1.0), Some((2.0, 0.0)));
        assert_eq!(c.completeness_on(&[true, false], 1.0), Some((0.0, 100.0)));
        assert_eq!(c.completeness_on(&[false, false], 1.0), None);
        assert_eq!(c.completeness_on(&[true], 1.0), None);
    }

    #[test]
    fn identical_sets_have_zero_chamfer() {
        let a = grid(10, 1.0, 2.0);
        assert_eq!(sqrt_chamfer_m(&a, &a).unwrap(), 0.0);
        assert_eq!(fscore(&a, &a, 0.01).unwrap().fscore_pct, 100.0);
    }

    #[test]
    fn metrics_reject_empty_nan_and_bad_threshold() {
        let a = grid(3, 1.0, 0.0);
        assert_eq!(
            sqrt_chamfer_m(&[], &a).unwrap_err(),
            GeometryError::Empty { field: "s1" }
        );
        assert_eq!(
            sqrt_chamfer_m(&a, &[]).unwrap_err(),
            GeometryError::Empty { field: "s2" }
        );
        let mut b = a.clone();
        b[4].y = f32::NAN;
        assert!(matches!(
            fscore(&a, &b, 1.0).unwrap_err(),
            GeometryError::NonFinite {
                field: "s2",
                index: 4,
                ..
            }
        ));
        for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                fscore(&a, &a, bad).unwrap_err(),
                GeometryError::BadParameter {
                    field: "threshold_m",
                    ..
                }
            ));
        }
    }

    #[test]
    fn sampling_is_uniform_by_area_on_the_surface_and_reproducible() {
        // Two triangles of a 10 m × 4 m rectangle in z = 1 (40 m²), split unevenly by area
        // with a third, tiny triangle: at 50 points/m² expect 2000 ± a few.
        let tris = [
            [
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(10.0, 0.0, 1.0),
                Vec3::new(10.0, 4.0, 1.0),
            ],
            [
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(10.0, 4.0, 1.0),
                Vec3::new(0.0, 4.0, 1.0),
            ],
        ];
        let rho = 50.0;
        let p = sample_triangles(&tris, rho, 7).unwrap();
        // Per-triangle stochastic rounding: |total − 2000| < number of triangles.
        assert!((p.len() as i64 - 2000).abs() < 2, "{}", p.len());
        assert!(p.iter().all(|v| (v.z - 1.0).abs() < 1e-6
            && (-1e-4..=10.0001).contains(&v.x)
            && (-1e-4..=4.0001).contains(&v.y)));
        // Uniformity: the half x < 5 holds 50 % of the area; the count there is binomial
        // (n = 2000, p = 0.5), σ = √(2000·0.25) ≈ 22.4; allow 4σ = 90.
        let left = p.iter().filter(|v| v.x < 5.0).count() as i64;
        assert!((left - 1000).abs() < 90, "{left}");
        // A corner quarter (x < 5, y < 2) has 25 %: σ = √(2000·0.1875) ≈ 19.4, 4σ ≈ 78.
        let q = p.iter().filter(|v| v.x < 5.0 && v.y < 2.0).count() as i64;
        assert!((q - 500).abs() < 78, "{q}");
        assert_eq!(p, sample_triangles(&tris, rho, 7).unwrap());
        assert_ne!(p, sample_triangles(&tris, rho, 8).unwrap());
        // The oriented samples are the same points, each with its triangle's normal (+z here).
        let (q, n) = sample_triangles_oriented(&tris, rho, 7).unwrap();
        assert_eq!(q, p);
        assert!(n.len() == p.len() && n.iter().all(|m| m.abs_diff_eq(Vec3::Z, 1e-6)));
    }

    #[test]
    fn sampling_rejects_bad_density_nan_vertices_and_bad_faces() {
        let t = [[Vec3::ZERO, Vec3::X, Vec3::Y]];
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e12] {
            assert!(matches!(
                sample_triangles(&t, bad, 0).unwrap_err(),
                GeometryError::BadParameter {
                    field: "density_per_m2",
                    ..
                }
            ));
        }
        let n = [[Vec3::ZERO, Vec3::new(0.0, f32::NAN, 0.0), Vec3::Y]];
        assert!(matches!(
            sample_triangles(&n, 1.0, 0).unwrap_err(),
            GeometryError::NonFinite { index: 0, .. }
        ));
        assert_eq!(
            sample_mesh(&[Vec3::ZERO, Vec3::X, Vec3::Y], &[[0, 1, 3]], 1.0, 0).unwrap_err(),
            GeometryError::BadFace {
                face: 0,
                vertex: 3,
                vertex_count: 3
            }
        );
    }

    #[test]
    fn gaussian_jitter_has_the_stated_spread_is_reproducible_and_rejects_bad_sigma() {
        // 30 000 draws of N(0, 0.3²) per axis: the sample standard deviation has a relative
        // standard error of 1/√(2n) ≈ 0.4 %; 2 % is five of those. The mean is within 5σ/√n.
        let n = 10_000;
        let pts = vec![Vec3::new(1.0, 2.0, 3.0); n];
        let j = gaussian_jitter(&pts, 0.3, 5).unwrap();
        assert_eq!(j, gaussian_jitter(&pts, 0.3, 5).unwrap());
        let d: Vec<f32> = j
            .iter()
            .zip(&pts)
            .flat_map(|(a, b)| (*a - *b).to_array())
            .collect();
        let mean = d.iter().map(|&x| x as f64).sum::<f64>() / d.len() as f64;
        let sd =
            (d.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>() / d.len() as f64).sqrt();
        assert!(
            mean.abs() < 5.0 * 0.3 / (d.len() as f64).sqrt(),
            "mean {mean}"
        );
        assert!((sd / 0.3 - 1.0).abs() < 0.02, "sd {sd}");
        assert_eq!(gaussian_jitter(&pts, 0.0, 5).unwrap(), pts);
        for bad in [-0.1f32, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                gaussian_jitter(&pts, bad, 5),
                Err(GeometryError::BadParameter {
                    field: "sigma_m",
                    ..
                })
            ));
        }
    }

    #[test]
    fn false_surface_share_and_area_ratio_of_a_unit_square() {
        // Mesh: the unit square [0, 1]² at z = 0 (two triangles, area 1). Truth: the left half
        // [0, 0.5] × [0, 1] (area 0.5), sampled densely on it. At d = 0.25 the part of the square
        // farther than d from the truth is x > 0.75 (the grid spacing 0.005 moves that edge by
        // < 0.0001 m): 25 % of the area. Area ratio 1 / 0.5 = 2. Truth moved 2 m up: all false.
        let (o, x, y, xy) = (Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0));
        let square = [[o, x, xy], [o, xy, y]];
        let samples = sample_triangles(&square, 40_000.0, 5).unwrap();
        let h = Vec3::new(0.5, 0.0, 0.0);
        let half = [[o, h, h + y], [o, h + y, y]];
        let truth: Vec<Vec3> = (0..=100)
            .flat_map(|i| {
                (0..=200).map(move |j| Vec3::new(i as f32 * 0.005, j as f32 * 0.005, 0.0))
            })
            .collect();
        let m = surface_area_metrics(&samples, 1.0, &truth, &half, 0.25).unwrap();
        // 40 000 samples: the binomial standard error of 25 % is 0.22 points.
        assert!((m.false_surface_pct - 25.0).abs() < 1.0, "{m:?}");
        assert!((m.truth_area_m2 - 0.5).abs() < 1e-6 && (m.area_ratio - 2.0).abs() < 1e-5);
        let lifted: Vec<Vec3> = truth.iter().map(|&p| p + Vec3::Z * 2.0).collect();
        let off = surface_area_metrics(&samples, 1.0, &lifted, &half, 0.25).unwrap();
        assert_eq!(off.false_surface_pct, 100.0);
        let on_all = surface_area_metrics(&samples, 1.0, &truth, &half, 1.0).unwrap();
        assert_eq!(on_all.false_surface_pct, 0.0);
        assert!(surface_area_metrics(&samples, 1.0, &truth, &half, 0.0).is_err());
        assert!(surface_area_metrics(&samples, 1.0, &truth, &[], 0.25).is_err());
        assert!(surface_area_metrics(&[], 1.0, &truth, &half, 0.25).is_err());
    }
}
