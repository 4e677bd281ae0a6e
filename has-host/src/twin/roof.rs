//! Stage 3 of the planar twin: one roof plane over each inside cell of the footprint (2.5-D: one
//! roof over every ground point), and the lines where roof planes meet, which cut the partition.
//!
//! Heights in metres, z up; a roof is a plane `n·x = d` with `n.z > 0`.
//!
//! Mechanisms and why:
//! - **Meet lines**: two roof planes whose supports touch (points within the growing radius)
//!   meet where their heights are equal; the ground trace of that line (a ridge, a valley, a
//!   hip) cuts the partition, so that each side can carry its own plane. When the equal-height
//!   line lies farther than the touching points' spread from them, the planes do not meet there
//!   (a step between parallel roofs) and no line is made; nor when the planes are within the
//!   snapping angle of each other (the line's position is then ill-conditioned) or either has
//!   fewer than [`MEET_SUPPORT`] points.
//! - **Support**: a cell's roof is the roof plane with the largest fusion weight among the
//!   points it explains whose ground position lies in the cell — the data term of one roof per
//!   footprint point.
//! - **Inference**: an inside cell with no supported plane takes a level roof at the height its
//!   neighbour's roof has along their shared edge (breadth first from the supported cells, in
//!   cell order), and is marked inferred with that neighbour as its evidence. Level, not the
//!   neighbour's slope: continuing a slope over ground where nothing was seen extrapolates a
//!   plane fitted over a few metres across the whole cell. A plane that would put a corner of the
//!   cell below the ground (plus one voxel) or more than [`HEIGHT_MARGIN_VOXELS`] voxels above the
//!   highest point of the cloud is not accepted there: that is extrapolation, not evidence. A
//!   cell no accepted plane reaches gets a level roof at the median height of the building's
//!   supported points, marked inferred.

use std::collections::HashMap;

use glam::{DVec2, DVec3, Vec3};

use super::footprint::{Footprint, LineSource, SplitLine};
use super::planes::{PlaneKind, PlaneSet, MIN_SUPPORT, SNAP_DEG};
use crate::knn::PointIndex;

/// A roof plane may rise this many voxels above the highest cloud point at a cell corner.
pub const HEIGHT_MARGIN_VOXELS: f64 = 4.0;
/// Fewest points of each of two roof planes for their meet line to cut the partition.
pub const MEET_SUPPORT: usize = 3 * MIN_SUPPORT;
/// Fewest touching point pairs for two roofs to meet.
pub const MIN_CONTACTS: usize = 3;

/// The roof over one cell.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CellRoof {
    /// Unit normal, n.z > 0.
    pub n: DVec3,
    /// Offset: the roof is n·x = d, metres.
    pub d: f64,
    /// The roof plane (index into the plane set), `None` for a level fallback.
    pub plane: Option<u32>,
    /// Points of that plane over this cell (0 when inferred).
    pub support: usize,
    /// `None` when supported by points over the cell; else the evidence: the neighbouring
    /// cell whose plane it took, or `None` inside for the level fallback.
    pub inferred_from: Option<Option<u32>>,
}

impl CellRoof {
    /// Height over (x, y), metres.
    pub fn z_at(&self, p: DVec2) -> f64 {
        (self.d - self.n.x * p.x - self.n.y * p.y) / self.n.z
    }
}

/// The lines where touching roof planes meet (module docs).
pub fn meet_lines(points: &[Vec3], set: &PlaneSet) -> Vec<SplitLine> {
    let roof_pts: Vec<u32> = (0..points.len() as u32)
        .filter(|&i| {
            set.label[i as usize].is_some_and(|k| set.planes[k as usize].kind == PlaneKind::Roof)
        })
        .collect();
    if roof_pts.len() < 2 {
        return Vec::new();
    }
    let pos: Vec<Vec3> = roof_pts.iter().map(|&i| points[i as usize]).collect();
    let Ok(index) = PointIndex::new("roof points", &pos) else {
        return Vec::new();
    };
    let mut contacts: HashMap<(u32, u32), Vec<DVec2>> = HashMap::new();
    for (a, &i) in roof_pts.iter().enumerate() {
        let la = set.label[i as usize].expect("roof point");
        for (b, _) in index.within(pos[a], set.tol.radius_m as f32) {
            let lb = set.label[roof_pts[b as usize] as usize].expect("roof point");
            if la < lb {
                let mid = (pos[a] + pos[b as usize]).as_dvec3() * 0.5;
                contacts.entry((la, lb)).or_default().push(mid.truncate());
            }
        }
    }
    let mut keys: Vec<_> = contacts.keys().copied().collect();
    keys.sort_unstable();
    let mut lines = Vec::new();
    for (a, b) in keys {
        let pts = &contacts[&(a, b)];
        if pts.len() < MIN_CONTACTS {
            continue;
        }
        let (p, q) = (&set.planes[a as usize], &set.planes[b as usize]);
        // Planes within the snapping angle of each other meet along an ill-conditioned line (its
        // position moves by the offsets' noise over the angle), and small planes are as likely
        // noise patches: neither makes a cut.
        if p.n.dot(q.n) > SNAP_DEG.to_radians().cos()
            || p.support.len().min(q.support.len()) < MEET_SUPPORT
        {
            continue;
        }
        // z_p = z_q ⇔ (p.n.xy/p.n.z − q.n.xy/q.n.z)·(x, y) = p.d/p.n.z − q.d/q.n.z.
        let g = DVec2::new(p.n.x / p.n.z - q.n.x / q.n.z, p.n.y / p.n.z - q.n.y / q.n.z);
        let c = p.d / p.n.z - q.d / q.n.z;
        let len = g.length();
        if len < 1e-3 {
            continue; // parallel roofs: a step, not a meeting
        }
        let (m, c) = (g / len, c / len);
        let off = pts.iter().map(|x| (m.dot(*x) - c).abs()).sum::<f64>() / pts.len() as f64;
        if off > 2.0 * set.tol.radius_m {
            continue;
        }
        let origin = m * c;
        let dir = m.perp();
        let ts = pts.iter().map(|x| dir.dot(*x - origin));
        let (t0, t1) = ts.fold((f64::MAX, f64::MIN), |(lo, hi), t| (lo.min(t), hi.max(t)));
        lines.push(SplitLine {
            origin,
            dir,
            t0,
            t1,
            source: LineSource::RoofMeet(a, b),
        });
    }
    lines
}

/// Whether `roof` is accepted over cell `c` (module docs).
fn plausible(fp: &Footprint, c: usize, roof: &CellRoof, z_lo: f64, z_hi: f64) -> bool {
    fp.partition.ring(c).iter().all(|&v| {
        let z = roof.z_at(v);
        z.is_finite() && z >= z_lo && z <= z_hi
    })
}

/// The roof of each cell (`None` outside), given the footprint, the points and their planes,
/// over a ground at `ground_z`.
pub fn assign(
    fp: &Footprint,
    points: &[Vec3],
    weights: &[f32],
    set: &PlaneSet,
    ground_z: f64,
) -> Vec<Option<CellRoof>> {
    let n = fp.partition.cells.len();
    let z_lo = ground_z + set.tol.voxel_m;
    let z_top = points.iter().map(|p| p.z as f64).fold(f64::MIN, f64::max);
    let z_hi = z_top + HEIGHT_MARGIN_VOXELS * set.tol.voxel_m;
    // Bounding boxes for point location.
    let boxes: Vec<(DVec2, DVec2)> = (0..n)
        .map(|c| {
            let r = fp.partition.ring(c);
            let lo = r.iter().fold(DVec2::splat(f64::MAX), |m, &p| m.min(p));
            let hi = r.iter().fold(DVec2::splat(f64::MIN), |m, &p| m.max(p));
            (lo, hi)
        })
        .collect();
    let mut votes: Vec<HashMap<u32, (f64, usize)>> = vec![HashMap::new(); n];
    let mut building_heights: Vec<Vec<f64>> = vec![Vec::new(); fp.buildings];
    for (i, p) in points.iter().enumerate() {
        let Some(k) = set.label[i] else { continue };
        if set.planes[k as usize].kind != PlaneKind::Roof {
            continue;
        }
        let q = p.as_dvec3().truncate();
        let Some(c) = (0..n).find(|&c| {
            fp.inside[c]
                && q.cmpge(boxes[c].0 - 1e-9).all()
                && q.cmple(boxes[c].1 + 1e-9).all()
                && fp.partition.contains(c, q)
        }) else {
            continue;
        };
        let e = votes[c].entry(k).or_insert((0.0, 0));
        e.0 += weights[i] as f64;
        e.1 += 1;
        if let Some(b) = fp.building[c] {
            building_heights[b as usize].push(p.z as f64);
        }
    }
    let mut roofs: Vec<Option<CellRoof>> = vec![None; n];
    for c in 0..n {
        if !fp.inside[c] {
            continue;
        }
        let mut cand: Vec<(u32, f64, usize)> =
            votes[c].iter().map(|(&k, &(w, m))| (k, w, m)).collect();
        cand.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        for (k, _, m) in cand {
            let p = &set.planes[k as usize];
            let r = CellRoof {
                n: p.n,
                d: p.d,
                plane: Some(k),
                support: m,
                inferred_from: None,
            };
            if plausible(fp, c, &r, z_lo, z_hi) {
                roofs[c] = Some(r);
                break;
            }
        }
    }
    // Breadth first from the supported cells.
    let nb = fp.partition.neighbours();
    let mut queue: std::collections::VecDeque<usize> =
        (0..n).filter(|&c| roofs[c].is_some()).collect();
    while let Some(c) = queue.pop_front() {
        let from = roofs[c].expect("queued cells have roofs");
        let ring = &fp.partition.cells[c];
        for (k, &d) in nb[c].iter().enumerate() {
            let Some(d) = d.map(|d| d as usize) else {
                continue;
            };
            if !fp.inside[d] || roofs[d].is_some() {
                continue;
            }
            // Level, at the height the neighbour's roof has along the shared edge.
            let mid = (fp.partition.vertices[ring[k] as usize]
                + fp.partition.vertices[ring[(k + 1) % ring.len()] as usize])
                * 0.5;
            let r = CellRoof {
                n: DVec3::Z,
                d: from.z_at(mid),
                plane: None,
                support: 0,
                inferred_from: Some(Some(c as u32)),
            };
            if plausible(fp, d, &r, z_lo, z_hi) {
                roofs[d] = Some(r);
                queue.push_back(d);
            }
        }
    }
    for (c, slot) in roofs.iter_mut().enumerate() {
        if fp.inside[c] && slot.is_none() {
            let b = fp.building[c].expect("inside cells belong to a building") as usize;
            let h = &mut building_heights[b];
            h.sort_by(|a, b| a.total_cmp(b));
            let z = h
                .get(h.len() / 2)
                .copied()
                .unwrap_or(z_lo)
                .clamp(z_lo, z_hi);
            *slot = Some(CellRoof {
                n: DVec3::Z,
                d: z,
                plane: None,
                support: 0,
                inferred_from: Some(None),
            });
        }
    }
    roofs
}
