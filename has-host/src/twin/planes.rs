//! Stage 1 of the planar twin: planes found in the fused cloud, classified and regularised.
//!
//! Input: the fused points (metres, z up), each with its fusion `weight` (how much imaging
//! evidence the voxel carries, `imaging::run`), and the imaging voxel edge `voxel_m` from the
//! run's report. Output: [`Plane`]s, each with its unit normal `n` and offset `d` (the plane is
//! `n·x = d`), its support (indices of the points it explains) and its kind.
//!
//! Mechanisms and why:
//! - **Normals** are PCA over the [`NORMAL_NEIGHBOURS`] nearest points (`mesh::normals`): a fused
//!   point is a voxel centre, so one point has no orientation of its own.
//! - **Region growing**: seeds are taken in order of decreasing weight (the best-confirmed
//!   voxels first); a region takes a neighbour within [`Tolerances::radius_m`] whose normal is
//!   within [`NORMAL_TOLERANCE_DEG`] of the region's plane and whose distance to that plane is at
//!   most [`Tolerances::distance_m`]. Both lengths come from the voxel: a fused position is a
//!   voxel centre (quantisation ±voxel/2) and a pair's slab is collapsed to one height per column,
//!   so a point lies up to about one voxel off its true surface; neighbours on a surface sampled
//!   at the voxel pitch are within two voxels. The plane is refitted (weighted PCA) each time the
//!   region doubles.
//! - **Classification**: a plane whose normal is within [`WALL_TILT_DEG`] of horizontal is a
//!   wall (facades are vertical to within construction tolerance; the band absorbs the normal's
//!   noise), any other plane above the ground a roof, a near-horizontal plane within one
//!   tolerance of the ground height the ground.
//! - **Regularisation by evidence**: wall azimuths (folded modulo 90°, so parallel and orthogonal
//!   walls vote together) are histogrammed with their support weight; each peak is a dominant
//!   direction of the site, and a wall within [`SNAP_DEG`] of one is turned onto it (its offset
//!   refitted with the normal held). No direction is assumed: the peaks are the data's. Roofs
//!   within [`SNAP_DEG`] of level are made level. Planes of one kind with the same normal (within
//!   1° for walls, already on shared directions; [`SNAP_DEG`] for roofs) and each one's
//!   centroid within the distance tolerance of the other are merged — walls only when their
//!   supports also come within two radii (one physical facade imaged by several pairs, or split
//!   by a gap), roofs wherever they are (one roof plane seen in pieces, or two roofs at one
//!   height and slope, which the footprint keeps apart); a merged roof is refitted.
//!   Roof planes under [`MIN_ROOF_SUPPORT`] points are then dropped.

use glam::{DMat3, DVec3, Vec3};

use crate::knn::{GeometryError, PointIndex};
use crate::linalg::symmetric_eigen3;

/// Neighbours of the PCA normal of each point.
pub const NORMAL_NEIGHBOURS: usize = 10;
/// Largest angle between a point's normal and its region's plane normal, degrees. Voxel-centre
/// normals over ten neighbours scatter by about 15–20° on a flat facade.
pub const NORMAL_TOLERANCE_DEG: f64 = 25.0;
/// A plane whose normal is within this of horizontal is a wall, degrees.
pub const WALL_TILT_DEG: f64 = 15.0;
/// Walls within this of a dominant direction, and roofs within this of level, are snapped, degrees.
pub const SNAP_DEG: f64 = 8.0;
/// Fewest points a plane must explain: below this a "plane" through voxel centres is as likely
/// a cluster of sidelobes as a surface.
pub const MIN_SUPPORT: usize = 12;

/// A wall plane must span this many voxels both in height and along the ground (module docs).
pub const MIN_WALL_SPAN_VOXELS: f64 = 3.0;
/// Fewest points of a roof plane after merging: at one point per voxel (0.25 m² at 0.5 m) a
/// roof piece of about 6 m², below which the cut and the roof stages would make a face of
/// noise (the patches where a wall meets its roof are this size).
pub const MIN_ROOF_SUPPORT: usize = MIN_SUPPORT;

/// Lengths derived from the imaging voxel (module docs).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Tolerances {
    /// Imaging voxel edge, metres.
    pub voxel_m: f64,
    /// Largest point-to-plane distance of a supporting point: one voxel, metres.
    pub distance_m: f64,
    /// Neighbourhood radius of region growing: two voxels and a half, metres.
    pub radius_m: f64,
}

impl Tolerances {
    /// The tolerances of a cloud imaged at `voxel_m`.
    pub fn from_voxel(voxel_m: f64) -> Tolerances {
        Tolerances {
            voxel_m,
            distance_m: voxel_m,
            radius_m: 2.5 * voxel_m,
        }
    }
}

/// What a plane is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PlaneKind {
    /// Normal within [`WALL_TILT_DEG`] of horizontal.
    Wall,
    /// Any other plane above the ground.
    Roof,
    /// Near level at the ground height.
    Ground,
}

/// One detected plane `n·x = d`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Plane {
    /// Unit normal (walls: horizontal after snapping; roofs: n.z > 0).
    pub n: DVec3,
    /// Offset, metres.
    pub d: f64,
    /// Indices of the supporting points.
    pub support: Vec<u32>,
    /// Summed fusion weight of the support.
    pub weight: f64,
    /// Wall, roof or ground.
    pub kind: PlaneKind,
    /// Whether regularisation changed the normal (snapped to a dominant direction or to level).
    pub snapped: bool,
}

impl Plane {
    /// Signed distance of `p` from the plane, metres.
    pub fn distance(&self, p: DVec3) -> f64 {
        self.n.dot(p) - self.d
    }

    /// Height of a non-vertical plane over (x, y), metres.
    pub fn z_at(&self, x: f64, y: f64) -> f64 {
        (self.d - self.n.x * x - self.n.y * y) / self.n.z
    }
}

/// The planes of a cloud and how they were found.
#[derive(Clone, Debug)]
pub struct PlaneSet {
    /// Walls, roofs and ground, walls first.
    pub planes: Vec<Plane>,
    /// Per point, the plane explaining it (`None`: no plane).
    pub label: Vec<Option<u32>>,
    /// Dominant wall directions (azimuth of the wall normal folded into [0°, 90°)), radians.
    pub dominant_azimuths: Vec<f64>,
    /// The tolerances used.
    pub tol: Tolerances,
}

/// Weighted plane fit: centroid and unit normal (smallest eigenvector of the weighted scatter).
fn fit(points: &[Vec3], weights: &[f32], idx: &[u32]) -> Option<(DVec3, DVec3)> {
    let mut wsum = 0.0;
    let mut c = DVec3::ZERO;
    for &i in idx {
        let w = weights[i as usize].max(1e-6) as f64;
        c += points[i as usize].as_dvec3() * w;
        wsum += w;
    }
    if wsum <= 0.0 {
        return None;
    }
    c /= wsum;
    let mut m = DMat3::ZERO;
    for &i in idx {
        let w = weights[i as usize].max(1e-6) as f64;
        let d = points[i as usize].as_dvec3() - c;
        m += DMat3::from_cols(d * d.x, d * d.y, d * d.z) * w;
    }
    let (_, vecs) = symmetric_eigen3(m * (1.0 / wsum));
    let n = vecs[0];
    (n.length() > 0.5).then_some((c, n.normalize()))
}

/// Detects, classifies and regularises the planes of `points` (weights: fusion weight per
/// point, same length) over a ground at `ground_z`.
///
/// # Errors
/// Fewer than [`NORMAL_NEIGHBOURS`] points or a non-finite point.
pub fn detect(
    points: &[Vec3],
    weights: &[f32],
    ground_z: f64,
    tol: Tolerances,
) -> Result<PlaneSet, GeometryError> {
    let (normals, index) = crate::mesh::normals::pca_normals(points, NORMAL_NEIGHBOURS)?;
    let cos_tol = NORMAL_TOLERANCE_DEG.to_radians().cos();
    let mut label: Vec<Option<u32>> = vec![None; points.len()];
    let mut order: Vec<u32> = (0..points.len() as u32).collect();
    order.sort_by(|&a, &b| {
        weights[b as usize]
            .total_cmp(&weights[a as usize])
            .then(a.cmp(&b))
    });
    let mut visited = vec![false; points.len()];
    let mut regions: Vec<Vec<u32>> = Vec::new();
    for &seed in &order {
        if visited[seed as usize] {
            continue;
        }
        // Local plane of the seed: its PCA normal through it.
        let mut n = normals[seed as usize].as_dvec3();
        let mut c = points[seed as usize].as_dvec3();
        let mut region = vec![seed];
        let mut in_region = std::collections::HashSet::from([seed]);
        let mut front = vec![seed];
        let mut refit_at = 8;
        while let Some(i) = front.pop() {
            for (j, _) in index.within(points[i as usize], tol.radius_m as f32) {
                if visited[j as usize] || in_region.contains(&j) {
                    continue;
                }
                let p = points[j as usize].as_dvec3();
                let nj = normals[j as usize].as_dvec3();
                if nj.dot(n).abs() < cos_tol || (p - c).dot(n).abs() > tol.distance_m {
                    continue;
                }
                in_region.insert(j);
                region.push(j);
                front.push(j);
            }
            if region.len() >= refit_at {
                if let Some((c2, n2)) = fit(points, weights, &region) {
                    c = c2;
                    n = n2;
                }
                refit_at *= 2;
            }
        }
        if region.len() < MIN_SUPPORT {
            continue; // left for a later seed's region
        }
        for &j in &region {
            visited[j as usize] = true;
        }
        regions.push(region);
    }
    let mut planes = Vec::new();
    for region in regions {
        if let Some(p) = make_plane(points, weights, region, ground_z, tol) {
            planes.push(p);
        }
    }
    let dominant_azimuths = snap_walls(points, weights, &mut planes);
    for p in planes.iter_mut().filter(|p| p.kind != PlaneKind::Wall) {
        if p.n.z.acos() < SNAP_DEG.to_radians() && p.n != DVec3::Z {
            p.n = DVec3::Z;
            p.d = weighted_offset(points, weights, &p.support, p.n);
            p.snapped = true;
        }
    }
    let mut planes = merge_coplanar(points, weights, planes, tol);
    planes.sort_by_key(|p| {
        (
            p.kind != PlaneKind::Wall,
            std::cmp::Reverse(p.support.len()),
        )
    });
    for (k, p) in planes.iter().enumerate() {
        for &i in &p.support {
            label[i as usize] = Some(k as u32);
        }
    }
    Ok(PlaneSet {
        planes,
        label,
        dominant_azimuths,
        tol,
    })
}

/// Weighted mean of `n·p` over the points `idx` (the offset of the plane of normal `n` through
/// their weighted centroid), metres; 0 for no weight.
pub(crate) fn weighted_offset(points: &[Vec3], weights: &[f32], idx: &[u32], n: DVec3) -> f64 {
    let (mut s, mut w) = (0.0, 0.0);
    for &i in idx {
        let wi = weights[i as usize].max(1e-6) as f64;
        s += wi * n.dot(points[i as usize].as_dvec3());
        w += wi;
    }
    if w > 0.0 {
        s / w
    } else {
        0.0
    }
}

fn make_plane(
    points: &[Vec3],
    weights: &[f32],
    support: Vec<u32>,
    ground_z: f64,
    tol: Tolerances,
) -> Option<Plane> {
    let (c, mut n) = fit(points, weights, &support)?;
    let horizontal = n.z.abs() < WALL_TILT_DEG.to_radians().sin();
    let kind = if horizontal {
        n.z = 0.0;
        n = n.normalize();
        PlaneKind::Wall
    } else {
        if n.z < 0.0 {
            n = -n;
        }
        if n.z > SNAP_DEG.to_radians().cos() && (c.z - ground_z).abs() <= tol.distance_m {
            PlaneKind::Ground
        } else {
            PlaneKind::Roof
        }
    };
    let weight = support.iter().map(|&i| weights[i as usize] as f64).sum();
    Some(Plane {
        n,
        d: n.dot(c),
        support,
        weight,
        kind,
        snapped: false,
    })
}

/// Azimuth of a horizontal normal folded into [0, π/2).
fn folded_azimuth(n: DVec3) -> f64 {
    n.y.atan2(n.x).rem_euclid(std::f64::consts::FRAC_PI_2)
}

/// The histogram of wall azimuths (1° bins, folded modulo 90°, weighted by support weight),
/// its peaks taken greedily, and every wall within [`SNAP_DEG`] of a peak turned onto it.
/// Returns the peaks (radians).
fn snap_walls(points: &[Vec3], weights: &[f32], planes: &mut [Plane]) -> Vec<f64> {
    const BINS: usize = 90;
    let mut hist = [0.0f64; BINS];
    for p in planes.iter().filter(|p| p.kind == PlaneKind::Wall) {
        let b = (folded_azimuth(p.n).to_degrees().floor() as usize).min(BINS - 1);
        hist[b] += p.weight;
    }
    let total: f64 = hist.iter().sum();
    let window = SNAP_DEG as isize;
    let mut peaks = Vec::new();
    let mut left = hist;
    // A peak must hold a tenth of the wall evidence: smaller ones are single walls, which keep
    // their own direction.
    loop {
        let smoothed: Vec<f64> = (0..BINS as isize)
            .map(|b| {
                (-2..=2)
                    .map(|k| left[(b + k).rem_euclid(BINS as isize) as usize])
                    .sum()
            })
            .collect();
        let (best, &v) = smoothed
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(&a.0)))
            .expect("90 bins");
        if total <= 0.0 || v < 0.1 * total {
            break;
        }
        // The peak's azimuth: weighted circular mean (period 90°) of the walls near the bin.
        let centre = (best as f64 + 0.5).to_radians();
        let (mut s, mut c) = (0.0, 0.0);
        for p in planes.iter().filter(|p| p.kind == PlaneKind::Wall) {
            let a = folded_azimuth(p.n);
            if circular_gap(a, centre) <= 2.5f64.to_radians() {
                s += p.weight * (4.0 * a).sin();
                c += p.weight * (4.0 * a).cos();
            }
        }
        let peak = (s.atan2(c) / 4.0).rem_euclid(std::f64::consts::FRAC_PI_2);
        peaks.push(peak);
        for k in -window..=window {
            left[(best as isize + k).rem_euclid(BINS as isize) as usize] = 0.0;
        }
    }
    for p in planes.iter_mut().filter(|p| p.kind == PlaneKind::Wall) {
        let a = folded_azimuth(p.n);
        let Some(&peak) = peaks
            .iter()
            .filter(|&&q| circular_gap(a, q) <= SNAP_DEG.to_radians())
            .min_by(|&&x, &&y| circular_gap(a, x).total_cmp(&circular_gap(a, y)))
        else {
            continue;
        };
        let full = p.n.y.atan2(p.n.x);
        let turned = full + signed_gap(peak, a);
        p.n = DVec3::new(turned.cos(), turned.sin(), 0.0);
        p.d = weighted_offset(points, weights, &p.support, p.n);
        p.snapped = true;
    }
    peaks
}

/// |a − b| on the circle of period 90°, radians.
fn circular_gap(a: f64, b: f64) -> f64 {
    signed_gap(a, b).abs()
}

/// a − b wrapped into [−45°, 45°), radians.
fn signed_gap(a: f64, b: f64) -> f64 {
    let q = std::f64::consts::FRAC_PI_2;
    (a - b + q / 2.0).rem_euclid(q) - q / 2.0
}

/// Merges planes of one kind with parallel normals (within 1°), offsets within the distance
/// tolerance and supports within two radii of each other; refits the merged offset with the
/// normal of the larger.
fn merge_coplanar(
    points: &[Vec3],
    weights: &[f32],
    mut planes: Vec<Plane>,
    tol: Tolerances,
) -> Vec<Plane> {
    planes.sort_by_key(|p| std::cmp::Reverse(p.support.len()));
    let centroid = |p: &Plane| {
        p.support
            .iter()
            .map(|&i| points[i as usize].as_dvec3())
            .sum::<DVec3>()
            / p.support.len().max(1) as f64
    };
    let mut out: Vec<Plane> = Vec::new();
    'next: for p in planes {
        let cp = centroid(&p);
        for q in out.iter_mut() {
            // Walls are already on shared directions: only equal ones merge. Roofs keep their
            // fitted normals, noisy by up to the snapping angle.
            let angle = if p.kind == PlaneKind::Wall {
                1.0
            } else {
                SNAP_DEG
            };
            if q.kind != p.kind
                || q.n.dot(p.n) < angle.to_radians().cos()
                || q.distance(cp).abs() > tol.distance_m
                || p.distance(centroid(q)).abs() > tol.distance_m
            {
                continue;
            }
            if p.kind == PlaneKind::Wall
                && !supports_touch(points, &q.support, &p.support, 2.0 * tol.radius_m)
            {
                continue;
            }
            q.support.extend_from_slice(&p.support);
            q.weight += p.weight;
            q.snapped |= p.snapped;
            if q.kind == PlaneKind::Roof && !q.snapped {
                if let Some((_, n)) = fit(points, weights, &q.support) {
                    q.n = if n.z < 0.0 { -n } else { n };
                }
            }
            q.d = weighted_offset(points, weights, &q.support, q.n);
            continue 'next;
        }
        out.push(p);
    }
    // A facade stands from the ground to its roof, at least a storey: a near-vertical patch
    // spanning fewer than [`MIN_WALL_SPAN_VOXELS`] voxels in height or along the ground is a roof
    // edge, a parapet or noise, and its trace would cut buildings apart.
    let span = MIN_WALL_SPAN_VOXELS * tol.voxel_m;
    out.retain(|p| {
        if p.kind != PlaneKind::Wall {
            return true;
        }
        let along = DVec3::new(-p.n.y, p.n.x, 0.0);
        let (mut z0, mut z1, mut t0, mut t1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &i in &p.support {
            let q = points[i as usize].as_dvec3();
            (z0, z1) = (z0.min(q.z), z1.max(q.z));
            (t0, t1) = (t0.min(along.dot(q)), t1.max(along.dot(q)));
        }
        z1 - z0 >= span && t1 - t0 >= span
    });
    // Roof pieces too small to be a face of the twin (patches where a wall meets its roof,
    // clusters of noise) are dropped; their points stay unexplained.
    out.retain(|p| p.kind != PlaneKind::Roof || p.support.len() >= MIN_ROOF_SUPPORT);
    out
}

/// Whether some point of `a` is within `r` of some point of `b`.
fn supports_touch(points: &[Vec3], a: &[u32], b: &[u32], r: f64) -> bool {
    let pa: Vec<Vec3> = a.iter().map(|&i| points[i as usize]).collect();
    let Ok(index) = PointIndex::new("support", &pa) else {
        return false;
    };
    let r2 = (r * r) as f32;
    b.iter().any(|&i| index.nearest(points[i as usize]).1 <= r2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on a vertical facade x = 3, y ∈ [0, 10], z ∈ [0, 6] and a level roof z = 6 over
    /// x ∈ [3, 13], at the voxel pitch.
    fn facade_and_roof(voxel: f32) -> Vec<Vec3> {
        let mut pts = Vec::new();
        let n = (10.0 / voxel) as i32;
        for i in 0..=n {
            for k in 0..=(6.0 / voxel) as i32 {
                pts.push(Vec3::new(3.0, i as f32 * voxel, k as f32 * voxel));
            }
            for j in 1..=n {
                pts.push(Vec3::new(3.0 + j as f32 * voxel, i as f32 * voxel, 6.0));
            }
        }
        pts
    }

    #[test]
    fn a_facade_and_a_roof_are_one_wall_and_one_level_roof() {
        let pts = facade_and_roof(0.5);
        let w = vec![1.0; pts.len()];
        let set = detect(&pts, &w, 0.0, Tolerances::from_voxel(0.5)).unwrap();
        let walls: Vec<_> = set
            .planes
            .iter()
            .filter(|p| p.kind == PlaneKind::Wall)
            .collect();
        let roofs: Vec<_> = set
            .planes
            .iter()
            .filter(|p| p.kind == PlaneKind::Roof)
            .collect();
        assert_eq!((walls.len(), roofs.len()), (1, 1), "{:?}", set.planes);
        assert!(walls[0].n.x.abs() > 0.999 && (walls[0].d.abs() - 3.0).abs() < 0.05);
        assert!((roofs[0].z_at(8.0, 5.0) - 6.0).abs() < 0.05);
    }

    #[test]
    fn walls_a_few_degrees_off_a_shared_direction_are_turned_onto_it() {
        let mut planes: Vec<Plane> = [0.0f64, 3.0, 92.0, 40.0]
            .iter()
            .map(|&deg| {
                let a = (30.0 + deg).to_radians();
                Plane {
                    n: DVec3::new(a.cos(), a.sin(), 0.0),
                    d: 0.0,
                    support: vec![],
                    weight: if deg == 40.0 { 0.5 } else { 1.0 },
                    kind: PlaneKind::Wall,
                    snapped: false,
                }
            })
            .collect();
        let peaks = snap_walls(&[], &[], &mut planes);
        assert_eq!(peaks.len(), 2, "{peaks:?}");
        let az = |p: &Plane| folded_azimuth(p.n).to_degrees();
        assert!((az(&planes[0]) - az(&planes[1])).abs() < 1e-9);
        assert!((az(&planes[0]) - az(&planes[2])).abs() < 1e-9);
        // The three agree near 31.7° (weighted mean of 30, 33, 32); 70° is its own direction.
        assert!((az(&planes[0]) - 31.67).abs() < 0.1, "{}", az(&planes[0]));
        assert!(!planes[3].snapped || (az(&planes[3]) - 70.0).abs() < 1e-6);
    }
}
