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
//! - **Labelling** (the roof-plane labelling of City3D and 3DBAG's roofer, on the footprint's
//!   cells): every inside cell takes one roof plane, chosen by minimising
//!   - a *data term*: over the roof points above the cell, each point's vertical distance to the
//!     plane in units of the distance tolerance (one voxel), squared and truncated at
//!     [`RESIDUAL_CAP`] (a point two voxels off belongs to another surface), times the area one
//!     voxel sample stands for — so the data are in m²;
//!   - a *seam term* between neighbouring cells with different planes: [`SEAM_COST_M`] per
//!     metre, plus [`STEP_COST`] per m² of the vertical face the two roofs' height difference
//!     stands along the shared edge, reduced by the share of that edge a seen wall supports.
//!     Where two planes meet on the edge (a ridge, a valley) the face vanishes, so roofs change
//!     plane where they meet or where a wall was seen.
//!
//!   - an *outline term*: the points of a wall plane standing on an edge of the cell on the
//!     footprint's outline that lie more than two voxels above the roof there are unexplained,
//!     each costing what a roof point that far off does. A facade seen up to a height carries a
//!     roof at that height, even where no pair saw the roof itself (a flat roof is seen, if at
//!     all, only at its rim).
//!
//!   - a *free-space term*: where a base station's sight line to a point it imaged passes over
//!     the cell lower than the roof there, less the residuals' truncation (two voxels), the roof
//!     would have blocked it ([`super::enclosure::free_heights`]): each such pixel costs what a
//!     roof point that far off does. The pairs saw the air above a roof, not only the roof, so
//!     a cell no point was seen over is not roofed higher than the lines that crossed it.
//!
//!   The seam term is a metric, so α-expansion (Boykov, Veksler & Zabih 2001) minimises the
//!   energy by one minimum cut per label and pass. A cell over which no point was seen takes the
//!   plane its neighbours make cheapest, marked inferred from a neighbour on that plane.
//! - **Plausibility**: a plane that would put a corner of the cell below the ground (plus one
//!   voxel) or more than [`HEIGHT_MARGIN_VOXELS`] voxels above the highest point of the cloud is
//!   not a candidate there: that is extrapolation, not evidence. A cell no plane reaches gets a
//!   level roof at the median height of the building's roof points, marked inferred.

use std::collections::HashMap;

use glam::{DVec2, DVec3, Vec3};

use super::footprint::{Footprint, LabelTerms, LineSource, SplitLine};
use super::max_flow::FlowGraph;
use super::planes::{PlaneKind, PlaneSet, MIN_SUPPORT, SNAP_DEG};
use crate::knn::PointIndex;

/// A roof plane may rise this many voxels above the highest cloud point at a cell corner.
pub const HEIGHT_MARGIN_VOXELS: f64 = 4.0;
/// Residuals are truncated at this many squared distance tolerances: a point farther from a
/// plane than two voxels belongs to another surface, and costs the same however far.
pub const RESIDUAL_CAP: f64 = 4.0;
/// Cost of one metre of seam between two roof labels, m² per metre: 1 % of the footprint's
/// outline cost (of two equal labellings, the one with fewer seams).
pub const SEAM_COST_M: f64 = 0.01 * super::footprint::OUTLINE_COST_M;
/// Cost of one m² of vertical face a step between two roofs stands where no wall was seen,
/// against one m² of roof points explained (the data term's unit).
pub const STEP_COST: f64 = 1.0;
/// Passes of α-expansion over the labels (each pass lowers the energy or ends it).
pub const MAX_SWEEPS: usize = 4;
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
            reach_m: super::footprint::EXTEND_VOXELS * set.tol.voxel_m,
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

/// One shared edge of two cells: its ends and its wall support, 0–1.
type SeamEdge = (DVec2, DVec2, f64);
/// Two neighbouring cells (lower index first) and their shared edges.
type CellPair = ((usize, usize), Vec<SeamEdge>);

/// ∫|g(t)| over a segment of length `len` on which g is linear from `g0` to `g1`.
fn abs_integral(g0: f64, g1: f64, len: f64) -> f64 {
    if g0 * g1 >= 0.0 {
        0.5 * len * (g0.abs() + g1.abs())
    } else {
        0.5 * len * (g0 * g0 + g1 * g1) / (g0.abs() + g1.abs())
    }
}

/// The cost of two labels on either side of the edges `edges` (ends, wall support 0–1) of two
/// neighbouring cells (module docs): the seam's length and the unsupported vertical face a step
/// between the two roofs would stand.
fn seam_cost(p: &CellRoof, q: &CellRoof, edges: &[SeamEdge]) -> f64 {
    edges
        .iter()
        .map(|&(a, b, wall)| {
            let len = a.distance(b);
            SEAM_COST_M * len
                + STEP_COST
                    * (1.0 - wall)
                    * abs_integral(p.z_at(a) - q.z_at(a), p.z_at(b) - q.z_at(b), len)
        })
        .sum()
}

/// The roof of each cell (`None` outside), given the footprint, the points and their planes,
/// over a ground at `ground_z`, with the wall traces `walls` supporting steps (module docs).
pub fn assign(
    fp: &Footprint,
    points: &[Vec3],
    set: &PlaneSet,
    ground_z: f64,
    walls: &[SplitLine],
    terms: &LabelTerms,
    free: &super::enclosure::FreeHeights,
) -> Vec<Option<CellRoof>> {
    let n = fp.partition.cells.len();
    let tol = set.tol;
    let z_lo = ground_z + tol.voxel_m;
    let z_top = points.iter().map(|p| p.z as f64).fold(f64::MIN, f64::max);
    let z_hi = z_top + HEIGHT_MARGIN_VOXELS * tol.voxel_m;
    // The roof points of each inside cell, located through a bucket grid of cell boxes.
    let cell_points = locate(fp, points, set);
    let labels: Vec<u32> = (0..set.planes.len() as u32)
        .filter(|&k| set.planes[k as usize].kind == PlaneKind::Roof)
        .collect();
    let roof_of = |k: u32| {
        let p = &set.planes[k as usize];
        CellRoof {
            n: p.n,
            d: p.d,
            plane: Some(k),
            support: 0,
            inferred_from: None,
        }
    };
    // Data terms: per inside cell, per label, the truncated squared residual of its roof points
    // (m² of voxel area per point); `None` where the plane is not plausible over the cell.
    let sigma = tol.distance_m;
    let area = tol.voxel_m * tol.voxel_m;
    let data: Vec<Vec<Option<f64>>> = (0..n)
        .map(|c| {
            if !fp.inside[c] {
                return Vec::new();
            }
            labels
                .iter()
                .map(|&k| {
                    let r = roof_of(k);
                    plausible(fp, c, &r, z_lo, z_hi).then(|| {
                        cell_points[c]
                            .iter()
                            .map(|&i| {
                                let q = points[i as usize].as_dvec3();
                                let e = (q.z - r.z_at(q.truncate())) / sigma;
                                area * (e * e).min(RESIDUAL_CAP)
                            })
                            .sum()
                    })
                })
                .collect()
        })
        .collect();
    // Wall points along the footprint's outline must lie below the roof there: a wall seen up
    // to a height is a wall up to that height. A point more than the residuals' truncation
    // (two voxels) above the roof is unexplained and costs what a roof point that far off does.
    let mut data = data;
    let reach = RESIDUAL_CAP.sqrt() * sigma;
    // Per cell, (ground position, height) evidence; each one `wrong` judges a roof to
    // contradict costs what a far-off roof point does.
    let mut charge = |per_cell: &[Vec<(DVec2, f64)>], wrong: &dyn Fn(f64, f64) -> bool| {
        for (c, items) in per_cell.iter().enumerate().filter(|(_, v)| !v.is_empty()) {
            for (j, &k) in labels.iter().enumerate() {
                // Outside cells have no data terms.
                let Some(v) = data[c].get_mut(j).and_then(Option::as_mut) else {
                    continue;
                };
                let r = roof_of(k);
                let n = items.iter().filter(|&&(x, h)| wrong(r.z_at(x), h)).count();
                *v += area * RESIDUAL_CAP * n as f64;
            }
        }
    };
    let outline: Vec<Vec<(DVec2, f64)>> = outline_wall_points(fp, points, set)
        .into_iter()
        .map(|pts| pts.into_iter().map(|q| (q.truncate(), q.z)).collect())
        .collect();
    charge(&outline, &|roof, h| h > roof + reach);
    // Sight lines over a cell lower than the roof: each pixel costs a far-off roof point.
    charge(&locate_pixels(fp, free, set), &|roof, h| roof > h + reach);
    // Shared edges between inside cells of one building, with their wall support.
    let nb = fp.partition.neighbours();
    let mut shared: HashMap<(usize, usize), Vec<SeamEdge>> = HashMap::new();
    for (c, around) in nb.iter().enumerate() {
        if !fp.inside[c] {
            continue;
        }
        let ring = &fp.partition.cells[c];
        for (k, d) in around.iter().enumerate() {
            let Some(d) = d.map(|d| d as usize) else {
                continue;
            };
            if d <= c || !fp.inside[d] {
                continue;
            }
            let a = fp.partition.vertices[ring[k] as usize];
            let b = fp.partition.vertices[ring[(k + 1) % ring.len()] as usize];
            let wall = super::footprint::wall_support(a, b, walls, terms);
            shared.entry((c, d)).or_default().push((a, b, wall));
        }
    }
    let mut pairs: Vec<CellPair> = shared.into_iter().collect();
    pairs.sort_by_key(|p| p.0);
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (k, ((c, d), _)) in pairs.iter().enumerate() {
        adj[*c].push(k);
        adj[*d].push(k);
    }
    // Start: each cell its best plausible label; cells with none stay unlabelled (fallback).
    let mut lab: Vec<Option<usize>> = (0..n)
        .map(|c| {
            data[c]
                .iter()
                .enumerate()
                .filter_map(|(j, v)| v.map(|v| (j, v)))
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
                .map(|(j, _)| j)
        })
        .collect();
    let roofs_l: Vec<CellRoof> = labels.iter().map(|&k| roof_of(k)).collect();
    let v = |j: usize, l: usize, e: &[SeamEdge]| {
        if j == l {
            0.0
        } else {
            seam_cost(&roofs_l[j], &roofs_l[l], e)
        }
    };
    // α-expansion (Boykov, Veksler & Zabih 2001): the seam cost is a metric, so each expansion
    // is one minimum cut and the energy never rises.
    let mut current = energy(&lab, &data, &pairs, &v);
    for _sweep in 0..MAX_SWEEPS {
        let mut changed = false;
        for alpha in 0..labels.len() {
            // Variables: labelled cells not on α where α is plausible.
            let mut var = vec![usize::MAX; n];
            let mut cells = Vec::new();
            for c in 0..n {
                if let Some(f) = lab[c] {
                    if f != alpha && data[c][alpha].is_some() {
                        var[c] = cells.len();
                        cells.push(c);
                    }
                }
            }
            if cells.is_empty() {
                continue;
            }
            let m = cells.len();
            let (s, t) = (m, m + 1);
            let mut g = FlowGraph::new(m + 2);
            let mut unary = vec![0.0f64; m]; // cost of x = 1 (take α) minus cost of x = 0
            for (vi, &c) in cells.iter().enumerate() {
                let f = lab[c].expect("variables are labelled");
                unary[vi] += data[c][alpha].expect("plausible") - data[c][f].expect("own label");
            }
            for ((c, d), e) in &pairs {
                let (vc, vd) = (var[*c], var[*d]);
                match (vc != usize::MAX, vd != usize::MAX) {
                    (false, false) => {}
                    (true, false) | (false, true) => {
                        let (x, other) = if vc != usize::MAX { (*c, *d) } else { (*d, *c) };
                        let Some(g_lab) = lab[other] else { continue };
                        let f = lab[x].expect("variable");
                        unary[var[x]] += v(alpha, g_lab, e) - v(f, g_lab, e);
                    }
                    (true, true) => {
                        let (fc, fd) = (lab[*c].expect("var"), lab[*d].expect("var"));
                        let e00 = v(fc, fd, e);
                        let e01 = v(fc, alpha, e);
                        let e10 = v(alpha, fd, e);
                        unary[vc] += e10 - e00;
                        unary[vd] -= e10;
                        let cap = (e01 + e10 - e00).max(0.0);
                        if cap > 0.0 {
                            g.add(vc, vd, cap, 0.0);
                        }
                    }
                }
            }
            for (vi, &u) in unary.iter().enumerate() {
                if u > 0.0 {
                    g.add(s, vi, u, 0.0);
                } else if u < 0.0 {
                    g.add(vi, t, -u, 0.0);
                }
            }
            g.max_flow(s, t);
            let reach = g.reachable(s);
            let take: Vec<usize> = (0..m).filter(|&vi| !reach[vi]).collect();
            if take.is_empty() {
                continue;
            }
            // Accept only a strict decrease (guards against rounding).
            let old = lab.clone();
            for &vi in &take {
                lab[cells[vi]] = Some(alpha);
            }
            let after = energy(&lab, &data, &pairs, &v);
            if after < current - 1e-9 {
                current = after;
                changed = true;
            } else {
                lab = old;
            }
        }
        if !changed {
            break;
        }
    }
    let mut roofs: Vec<Option<CellRoof>> = vec![None; n];
    for c in 0..n {
        if let Some(j) = lab[c] {
            let mut r = roofs_l[j];
            let k = labels[j];
            r.support = cell_points[c]
                .iter()
                .filter(|&&i| set.label[i as usize] == Some(k))
                .count();
            if r.support == 0 {
                // No point of this plane over the cell: the plane was carried here by the seam
                // terms from the neighbour holding the most of its points.
                let from = adj[c]
                    .iter()
                    .map(|&pk| {
                        let (a, b) = pairs[pk].0;
                        if a == c {
                            b
                        } else {
                            a
                        }
                    })
                    .find(|&d| lab[d] == Some(j));
                r.inferred_from = Some(from.map(|d| d as u32));
            }
            roofs[c] = Some(r);
        }
    }
    let mut building_heights: Vec<Vec<f64>> = vec![Vec::new(); fp.buildings];
    for (b, pts) in fp.building.iter().zip(&cell_points) {
        if let Some(b) = b {
            building_heights[*b as usize].extend(pts.iter().map(|&i| points[i as usize].z as f64));
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

/// Total energy of a labelling.
fn energy(
    lab: &[Option<usize>],
    data: &[Vec<Option<f64>>],
    pairs: &[CellPair],
    v: &dyn Fn(usize, usize, &[SeamEdge]) -> f64,
) -> f64 {
    let mut e = 0.0;
    for (c, l) in lab.iter().enumerate() {
        if let Some(j) = l {
            e += data[c][*j].unwrap_or(f64::INFINITY);
        }
    }
    for ((c, d), edges) in pairs {
        if let (Some(a), Some(b)) = (lab[*c], lab[*d]) {
            e += v(a, b, edges);
        }
    }
    e
}

/// Per inside cell, the free-height pixels whose centres it holds: (centre, lowest height).
fn locate_pixels(
    fp: &Footprint,
    free: &super::enclosure::FreeHeights,
    set: &PlaneSet,
) -> Vec<Vec<(DVec2, f64)>> {
    let mut keys: Vec<(&(i64, i64), &f64)> = free.lowest.iter().collect();
    keys.sort_unstable_by_key(|(k, _)| **k);
    let centres: Vec<DVec2> = keys.iter().map(|(k, _)| free.centre(**k)).collect();
    let cells = cells_of(fp, &centres, set);
    let mut out = vec![Vec::new(); fp.partition.cells.len()];
    for ((x, (_, &h)), c) in centres.iter().zip(&keys).zip(cells) {
        if let Some(c) = c {
            out[c].push((*x, h));
        }
    }
    out
}

/// The inside cell holding each ground position, located through a bucket grid of cell boxes.
pub(crate) fn cells_of(fp: &Footprint, xy: &[DVec2], set: &PlaneSet) -> Vec<Option<usize>> {
    let n = fp.partition.cells.len();
    let boxes: Vec<(DVec2, DVec2)> = (0..n)
        .map(|c| {
            let r = fp.partition.ring(c);
            let lo = r.iter().fold(DVec2::splat(f64::MAX), |m, &p| m.min(p));
            let hi = r.iter().fold(DVec2::splat(f64::MIN), |m, &p| m.max(p));
            (lo, hi)
        })
        .collect();
    let bucket = 4.0 * set.tol.voxel_m;
    let key = |p: DVec2| ((p.x / bucket).floor() as i64, (p.y / bucket).floor() as i64);
    let mut grid: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
    for c in (0..n).filter(|&c| fp.inside[c]) {
        let (a, b) = (key(boxes[c].0), key(boxes[c].1));
        for kx in a.0..=b.0 {
            for ky in a.1..=b.1 {
                grid.entry((kx, ky)).or_default().push(c as u32);
            }
        }
    }
    xy.iter()
        .map(|&q| {
            let cands = grid.get(&key(q))?;
            cands.iter().map(|&c| c as usize).find(|&c| {
                q.cmpge(boxes[c].0 - 1e-9).all()
                    && q.cmple(boxes[c].1 + 1e-9).all()
                    && fp.partition.contains(c, q)
            })
        })
        .collect()
}

/// The roof points (points of roof planes) over each inside cell.
fn locate(fp: &Footprint, points: &[Vec3], set: &PlaneSet) -> Vec<Vec<u32>> {
    let roof: Vec<u32> = (0..points.len() as u32)
        .filter(|&i| {
            set.label[i as usize].is_some_and(|k| set.planes[k as usize].kind == PlaneKind::Roof)
        })
        .collect();
    let xy: Vec<DVec2> = roof
        .iter()
        .map(|&i| points[i as usize].as_dvec3().truncate())
        .collect();
    let mut out = vec![Vec::new(); fp.partition.cells.len()];
    for (&i, c) in roof.iter().zip(cells_of(fp, &xy, set)) {
        if let Some(c) = c {
            out[c].push(i);
        }
    }
    out
}

/// For each inside cell, the points of the wall planes standing on its edges on the footprint's
/// outline (where the other side is outside) within the distance tolerance of the edge, as
/// (x, y, z).
fn outline_wall_points(fp: &Footprint, points: &[Vec3], set: &PlaneSet) -> Vec<Vec<DVec3>> {
    let n = fp.partition.cells.len();
    let mut out = vec![Vec::new(); n];
    let pixel = set.tol.voxel_m;
    let key = |p: DVec2| ((p.x / pixel).floor() as i64, (p.y / pixel).floor() as i64);
    let mut grid: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
    for (i, p) in points.iter().enumerate() {
        if set.label[i].is_some_and(|k| set.planes[k as usize].kind == PlaneKind::Wall) {
            grid.entry(key(p.as_dvec3().truncate()))
                .or_default()
                .push(i as u32);
        }
    }
    let nb = fp.partition.neighbours();
    let reach = set.tol.distance_m;
    let span = (reach / pixel).ceil() as i64 + 1;
    for c in 0..n {
        if !fp.inside[c] {
            continue;
        }
        let ring = fp.partition.ring(c);
        let mut seen = std::collections::HashSet::new();
        for k in 0..ring.len() {
            if nb[c][k].is_some_and(|d| fp.inside[d as usize]) {
                continue;
            }
            let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
            let len = a.distance(b);
            if len <= 0.0 {
                continue;
            }
            let dir = (b - a) / len;
            // The wall planes standing on this edge: their trace along it (both ends within the
            // distance tolerance of the plane). Points of other walls near the edge (a taller
            // neighbour's, a ghost between two buildings) say nothing about this roof.
            let on_edge = |k: u32| {
                let p = &set.planes[k as usize];
                p.kind == PlaneKind::Wall
                    && p.distance(a.extend(0.0)).abs() <= reach
                    && p.distance(b.extend(0.0)).abs() <= reach
            };
            let steps = (len / pixel).ceil() as usize;
            for s in 0..=steps {
                let (kx, ky) = key(a + dir * (s as f64 * pixel).min(len));
                for dx in -span..=span {
                    for dy in -span..=span {
                        for &i in grid.get(&(kx + dx, ky + dy)).into_iter().flatten() {
                            let q = points[i as usize].as_dvec3();
                            let t = dir.dot(q.truncate() - a);
                            let off = dir.perp_dot(q.truncate() - a).abs();
                            let own = set.label[i as usize].is_some_and(on_edge);
                            if own && (0.0..=len).contains(&t) && off <= reach && seen.insert(i) {
                                out[c].push(q);
                            }
                        }
                    }
                }
            }
        }
    }
    out
}
