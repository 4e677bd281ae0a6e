//! Stage 2 of the planar twin: the ground plan as a partition into convex cells, each labelled
//! inside or outside a building by evidence.
//!
//! Coordinates are ground-plane (x, y) in metres, the run's frame; cells are counter-clockwise.
//!
//! Mechanisms and why:
//! - **Partition** (a simplified kinetic partition, after Bauchet & Lafarge 2020): the site's box
//!   is cut by [`SplitLine`]s — the traces of wall planes on the ground, the lines where two
//!   roof planes meet, and the lines where roof evidence ends ([`super::evidence_edges`]). A
//!   line cuts only the cells its segment, prolonged by its `reach_m` at each end, passes
//!   through: a facade is imaged over part of its length (the rest occluded or outside every
//!   pair's view), so a wall's or a meet line's reaches [`EXTEND_VOXELS`] voxels past what was
//!   seen, but an infinite line would cut every building of the site. Each cut splits a convex
//!   cell into two convex cells, so every cell stays convex.
//! - **Conforming vertices**: cut points computed from the two sides of an edge are welded
//!   within [`WELD_M`], and a vertex lying on another cell's edge is inserted into that edge,
//!   so neighbouring cells share every edge exactly (the solid's walls need it).
//! - **Inside / outside** (after PolyFit's data and complexity terms, Nan & Wonka 2017), a
//!   minimum s–t cut over the cells. Roof evidence: a raster of voxel pixels marks each pixel
//!   holding a roof-plane point, widened by one pixel (the spacing of a sparse voxel sample); a
//!   cell's share `s` is the share of marked pixel centres inside it. Data terms: calling a cell
//!   outside costs its roof-covered area `s·A`; calling it inside costs its bare area
//!   `(1 − s)·A` times [`BARE_INSIDE_COST`], plus its share `o` of ground a sight line crossed
//!   low ([`super::enclosure::open_ground`]) times `A` times [`OPEN_INSIDE_COST`] (an unseen
//!   roof is common, a seen roof where there is
//!   none rare). Complexity term: each metre of outline between an inside and an outside cell
//!   (the site box's border counts as outside) costs [`OUTLINE_COST_M`] times the share of it no
//!   wall trace supports, plus 1 % of it even where a wall does (of two equal cuts, the shorter).
//!   So walls that enclose a courtyard or a hall whose roof was half seen close it, and a roof
//!   patch with no wall around it is not spread over the site. A wall alone does not make a cell
//!   inside (both of its sides see it). Connected inside cells (sharing an edge) are one building.

use std::collections::HashMap;

use glam::DVec2;

use super::max_flow::FlowGraph;

/// A wall trace is prolonged by this many voxels past its seen extent at each end.
pub const EXTEND_VOXELS: f64 = 10.0;
/// Cut points closer than this are one vertex, metres.
pub const WELD_M: f64 = 1e-4;
/// Cost of calling bare (no roof evidence) ground inside, per m², against 1 per m² of calling
/// roof-covered ground outside: the sensors miss many roofs (no UAV pair, a roof turned away),
/// so a missing roof is weaker evidence than a seen one.
pub const BARE_INSIDE_COST: f64 = 0.25;
/// Cost of calling ground a sight line crossed low inside, per m² ([`super::enclosure::open_ground`]):
/// as strong as a roof point is for the other label.
pub const OPEN_INSIDE_COST: f64 = 1.0;
/// Cost of one metre of footprint outline that no wall supports, in m² of the data terms, per
/// metre of outline: a strip this wide of wrongly labelled ground costs as much as one metre of
/// outline nothing was seen on (the complexity term).
pub const OUTLINE_COST_M: f64 = 1.0;

/// The terms of the inside / outside labelling (module docs).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LabelTerms {
    /// Raster pixel of the roof evidence, metres (the imaging voxel).
    pub pixel_m: f64,
    /// A wall supports the outline within this distance of its trace, metres.
    pub wall_distance_m: f64,
    /// A wall's trace supports the outline this far past its seen extent, metres.
    pub wall_reach_m: f64,
}

/// Share of the edge a–b lying on some wall trace (within `terms.wall_distance_m` of the line
/// and within its seen extent prolonged by `terms.wall_reach_m`), 0–1.
pub(crate) fn wall_support(a: DVec2, b: DVec2, walls: &[SplitLine], terms: &LabelTerms) -> f64 {
    let len = a.distance(b);
    if len <= 0.0 {
        return 1.0;
    }
    let mut best: f64 = 0.0;
    for w in walls {
        let m = w.dir.perp();
        if m.dot(a - w.origin).abs() > terms.wall_distance_m
            || m.dot(b - w.origin).abs() > terms.wall_distance_m
        {
            continue;
        }
        let (ta, tb) = (w.dir.dot(a - w.origin), w.dir.dot(b - w.origin));
        let (lo, hi) = (ta.min(tb), ta.max(tb));
        let overlap =
            (hi.min(w.t1 + terms.wall_reach_m) - lo.max(w.t0 - terms.wall_reach_m)).max(0.0);
        best = best.max(overlap / (hi - lo).max(1e-12));
    }
    best.min(1.0)
}

/// Inside / outside by a minimum s–t cut (module docs): source = inside, sink = outside.
fn min_cut_labels(
    part: &Partition,
    nb: &[Vec<Option<u32>>],
    share: &[f64],
    open: &[f64],
    walls: &[SplitLine],
    terms: &LabelTerms,
) -> Vec<bool> {
    let n = part.cells.len();
    let (s, t) = (n, n + 1);
    let mut g = FlowGraph::new(n + 2);
    for c in 0..n {
        let area = part.area(c);
        g.add(s, c, area * share[c], 0.0);
        let mut to_sink =
            BARE_INSIDE_COST * area * (1.0 - share[c]) + OPEN_INSIDE_COST * area * open[c];
        let ring = &part.cells[c];
        for k in 0..ring.len() {
            let (a, b) = (
                part.vertices[ring[k] as usize],
                part.vertices[ring[(k + 1) % ring.len()] as usize],
            );
            let w = OUTLINE_COST_M * a.distance(b) * (1.0 - wall_support(a, b, walls, terms))
                + 0.01 * OUTLINE_COST_M * a.distance(b);
            match nb[c][k] {
                None => to_sink += w,
                // each undirected edge once, both directions
                Some(d) if (d as usize) > c => g.add(c, d as usize, w, w),
                Some(_) => {}
            }
        }
        g.add(c, t, to_sink, 0.0);
    }
    g.max_flow(s, t);
    let reach = g.reachable(s);
    (0..n).map(|c| reach[c]).collect()
}

/// Where a cut line comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LineSource {
    /// The ground trace of wall plane `k`.
    Wall(u32),
    /// Where roof planes `a` and `b` are at equal height.
    RoofMeet(u32, u32),
    /// Where the points of roof plane `k` (`None`: of every roof plane) end
    /// ([`super::evidence_edges`]).
    EvidenceEdge(Option<u32>),
}

/// A segment of a cutting line: `origin + t·dir` for t in [t0, t1] (before prolongation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitLine {
    /// A point of the line, metres.
    pub origin: DVec2,
    /// Unit direction.
    pub dir: DVec2,
    /// Seen extent along `dir`, metres.
    pub t0: f64,
    /// Seen extent along `dir`, metres.
    pub t1: f64,
    /// How far past its seen extent the line cuts, metres (at each end).
    pub reach_m: f64,
    /// What made it.
    pub source: LineSource,
}

/// A conforming partition of the site's box into convex cells.
#[derive(Clone, Debug, Default)]
pub struct Partition {
    /// Vertex positions, metres.
    pub vertices: Vec<DVec2>,
    /// Cells as counter-clockwise vertex rings (collinear vertices kept: they are where a
    /// neighbour's edge ends).
    pub cells: Vec<Vec<u32>>,
}

impl Partition {
    /// Area of cell `c`, m².
    pub fn area(&self, c: usize) -> f64 {
        ring_area(&self.ring(c))
    }

    /// The positions of cell `c`'s ring.
    pub fn ring(&self, c: usize) -> Vec<DVec2> {
        self.cells[c]
            .iter()
            .map(|&v| self.vertices[v as usize])
            .collect()
    }

    /// Whether `p` lies inside (or on) convex cell `c`.
    pub fn contains(&self, c: usize, p: DVec2) -> bool {
        let r = &self.cells[c];
        (0..r.len()).all(|k| {
            let a = self.vertices[r[k] as usize];
            let b = self.vertices[r[(k + 1) % r.len()] as usize];
            (b - a).perp_dot(p - a) >= -1e-9
        })
    }

    /// For each directed edge (a, b) of a cell, the cell on its other side (the one holding
    /// (b, a)), `None` on the box's border.
    pub fn neighbours(&self) -> Vec<Vec<Option<u32>>> {
        let mut owner: HashMap<(u32, u32), u32> = HashMap::new();
        for (c, r) in self.cells.iter().enumerate() {
            for k in 0..r.len() {
                owner.insert((r[k], r[(k + 1) % r.len()]), c as u32);
            }
        }
        self.cells
            .iter()
            .map(|r| {
                (0..r.len())
                    .map(|k| owner.get(&(r[(k + 1) % r.len()], r[k])).copied())
                    .collect()
            })
            .collect()
    }
}

fn ring_area(r: &[DVec2]) -> f64 {
    0.5 * (0..r.len())
        .map(|k| r[k].perp_dot(r[(k + 1) % r.len()]))
        .sum::<f64>()
}

/// Splits convex `poly` by the line through `o` along `d`, if the line crosses its interior
/// within the parameter window [lo, hi].
fn split(poly: &[DVec2], o: DVec2, d: DVec2, lo: f64, hi: f64) -> Option<(Vec<DVec2>, Vec<DVec2>)> {
    const EPS: f64 = 1e-9;
    let s: Vec<f64> = poly.iter().map(|&p| d.perp_dot(p - o)).collect();
    let smax = s.iter().cloned().fold(f64::MIN, f64::max);
    let smin = s.iter().cloned().fold(f64::MAX, f64::min);
    if smax <= 1e-7 || smin >= -1e-7 {
        return None;
    }
    let (mut left, mut right) = (Vec::new(), Vec::new());
    let (mut ta, mut tb) = (f64::MAX, f64::MIN);
    for k in 0..poly.len() {
        let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
        let (sp, sq) = (s[k], s[(k + 1) % poly.len()]);
        if sp >= -EPS {
            left.push(p);
        }
        if sp <= EPS {
            right.push(p);
        }
        if sp.abs() <= EPS {
            let t = d.dot(p - o);
            ta = ta.min(t);
            tb = tb.max(t);
        }
        if (sp > EPS && sq < -EPS) || (sp < -EPS && sq > EPS) {
            let x = p + (q - p) * (sp / (sp - sq));
            left.push(x);
            right.push(x);
            let t = d.dot(x - o);
            ta = ta.min(t);
            tb = tb.max(t);
        }
    }
    if tb < lo || ta > hi || left.len() < 3 || right.len() < 3 {
        return None;
    }
    Some((left, right))
}

/// A spatial hash of vertices for welding and for finding vertices on edges.
struct VertexGrid {
    bin_m: f64,
    bins: HashMap<(i64, i64), Vec<u32>>,
    points: Vec<DVec2>,
}

impl VertexGrid {
    fn new(bin_m: f64) -> Self {
        Self {
            bin_m,
            bins: HashMap::new(),
            points: Vec::new(),
        }
    }
    fn key(&self, p: DVec2) -> (i64, i64) {
        (
            (p.x / self.bin_m).floor() as i64,
            (p.y / self.bin_m).floor() as i64,
        )
    }
    fn weld(&mut self, p: DVec2) -> u32 {
        let (kx, ky) = self.key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                if let Some(v) = self.bins.get(&(kx + dx, ky + dy)) {
                    if let Some(&i) = v
                        .iter()
                        .find(|&&i| self.points[i as usize].distance(p) <= WELD_M)
                    {
                        return i;
                    }
                }
            }
        }
        let i = self.points.len() as u32;
        self.points.push(p);
        self.bins.entry((kx, ky)).or_default().push(i);
        i
    }
    /// Vertices strictly inside segment a–b (within [`WELD_M`] of it), ordered from a.
    fn on_segment(&self, a: u32, b: u32) -> Vec<u32> {
        let (pa, pb) = (self.points[a as usize], self.points[b as usize]);
        let (k0, k1) = (self.key(pa.min(pb)), self.key(pa.max(pb)));
        let len = pa.distance(pb);
        let dir = (pb - pa) / len;
        let mut found = Vec::new();
        for kx in k0.0 - 1..=k1.0 + 1 {
            for ky in k0.1 - 1..=k1.1 + 1 {
                for &i in self.bins.get(&(kx, ky)).into_iter().flatten() {
                    if i == a || i == b {
                        continue;
                    }
                    let p = self.points[i as usize];
                    let t = dir.dot(p - pa);
                    if t > WELD_M && t < len - WELD_M && dir.perp_dot(p - pa).abs() <= WELD_M {
                        found.push((t, i));
                    }
                }
            }
        }
        found.sort_by(|x, y| x.0.total_cmp(&y.0));
        found.into_iter().map(|(_, i)| i).collect()
    }
}

/// The partition of the box [`lo`, `hi`] by `lines`, each prolonged by its `reach_m` at both ends.
pub fn partition(lo: DVec2, hi: DVec2, lines: &[SplitLine]) -> Partition {
    let mut cells: Vec<Vec<DVec2>> =
        vec![vec![lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)]];
    for l in lines {
        let (a, b) = (l.t0 - l.reach_m, l.t1 + l.reach_m);
        let mut next = Vec::with_capacity(cells.len() + 8);
        for c in cells {
            match split(&c, l.origin, l.dir, a, b) {
                Some((x, y)) => {
                    next.push(x);
                    next.push(y);
                }
                None => next.push(c),
            }
        }
        cells = next;
    }
    let mut grid = VertexGrid::new(((hi - lo).max_element() / 64.0).max(1.0));
    let mut rings: Vec<Vec<u32>> = cells
        .iter()
        .map(|c| {
            let mut r: Vec<u32> = c.iter().map(|&p| grid.weld(p)).collect();
            r.dedup();
            while r.len() > 1 && r.first() == r.last() {
                r.pop();
            }
            r
        })
        .collect();
    for r in rings.iter_mut() {
        let mut full = Vec::with_capacity(r.len() + 4);
        for k in 0..r.len() {
            let (a, b) = (r[k], r[(k + 1) % r.len()]);
            full.push(a);
            full.extend(grid.on_segment(a, b));
        }
        *r = full;
    }
    let vertices = grid.points;
    rings.retain(|r| {
        r.len() >= 3
            && ring_area(&r.iter().map(|&v| vertices[v as usize]).collect::<Vec<_>>()) > 1e-6
    });
    Partition {
        vertices,
        cells: rings,
    }
}

/// The cells of a partition labelled inside / outside, and the buildings they form.
#[derive(Clone, Debug)]
pub struct Footprint {
    /// The partition.
    pub partition: Partition,
    /// Per cell, its share under roof evidence, 0–1.
    pub roof_share: Vec<f64>,
    /// Per cell, inside a building.
    pub inside: Vec<bool>,
    /// Per cell, the building (connected inside cells, 0..) or `None` outside.
    pub building: Vec<Option<u32>>,
    /// Number of buildings.
    pub buildings: usize,
}

/// Labels `partition`'s cells from the roof evidence `roof_xy` (ground positions of the points
/// that roof planes explain) on a raster of `pixel_m` (module docs).
pub fn label(
    partition: Partition,
    roof_xy: &[DVec2],
    open_xy: &[DVec2],
    walls: &[SplitLine],
    terms: &LabelTerms,
) -> Footprint {
    let open: std::collections::HashSet<(i64, i64)> = open_xy
        .iter()
        .map(|p| {
            (
                (p.x / terms.pixel_m).floor() as i64,
                (p.y / terms.pixel_m).floor() as i64,
            )
        })
        .collect();
    let pixel_m = terms.pixel_m;
    let mut marked: std::collections::HashSet<(i64, i64)> = std::collections::HashSet::new();
    let key = |p: DVec2| {
        (
            (p.x / pixel_m).floor() as i64,
            (p.y / pixel_m).floor() as i64,
        )
    };
    for &p in roof_xy {
        let (kx, ky) = key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                marked.insert((kx + dx, ky + dy));
            }
        }
    }
    let n = partition.cells.len();
    let mut roof_share = vec![0.0; n];
    let mut open_share = vec![0.0; n];
    for (c, (share, open_s)) in roof_share.iter_mut().zip(open_share.iter_mut()).enumerate() {
        let ring = partition.ring(c);
        let lo = ring.iter().fold(DVec2::splat(f64::MAX), |m, &p| m.min(p));
        let hi = ring.iter().fold(DVec2::splat(f64::MIN), |m, &p| m.max(p));
        let (k0, k1) = (key(lo), key(hi));
        let (mut inside, mut hit, mut seen_through) = (0usize, 0usize, 0usize);
        for kx in k0.0..=k1.0 {
            for ky in k0.1..=k1.1 {
                let centre = DVec2::new((kx as f64 + 0.5) * pixel_m, (ky as f64 + 0.5) * pixel_m);
                if partition.contains(c, centre) {
                    inside += 1;
                    hit += marked.contains(&(kx, ky)) as usize;
                    seen_through += open.contains(&(kx, ky)) as usize;
                }
            }
        }
        if inside == 0 {
            let centroid = ring.iter().copied().sum::<DVec2>() / ring.len() as f64;
            inside = 1;
            hit = marked.contains(&key(centroid)) as usize;
        }
        *share = hit as f64 / inside as f64;
        *open_s = seen_through as f64 / inside as f64;
    }
    let nb = partition.neighbours();
    let inside = min_cut_labels(&partition, &nb, &roof_share, &open_share, walls, terms);
    let mut building = vec![None; n];
    let mut buildings = 0u32;
    for s in 0..n {
        if !inside[s] || building[s].is_some() {
            continue;
        }
        building[s] = Some(buildings);
        let mut stack = vec![s];
        while let Some(c) = stack.pop() {
            for &d in nb[c].iter().flatten() {
                if inside[d as usize] && building[d as usize].is_none() {
                    building[d as usize] = Some(buildings);
                    stack.push(d as usize);
                }
            }
        }
        buildings += 1;
    }
    Footprint {
        partition,
        roof_share,
        inside,
        building,
        buildings: buildings as usize,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(o: (f64, f64), d: (f64, f64), t0: f64, t1: f64) -> SplitLine {
        SplitLine {
            reach_m: 1.0,
            origin: DVec2::new(o.0, o.1),
            dir: DVec2::new(d.0, d.1).normalize(),
            t0,
            t1,
            source: LineSource::Wall(0),
        }
    }

    #[test]
    fn cuts_conform_and_cover_the_box() {
        // A full cut at x = 5 and a short one at y = 5 reaching only x < 5: the right-hand cell
        // gets the short cut's end point as a vertex on its left edge.
        let p = partition(
            DVec2::ZERO,
            DVec2::splat(10.0),
            &[
                line((5.0, 0.0), (0.0, 1.0), 0.0, 10.0),
                line((0.0, 5.0), (1.0, 0.0), 0.0, 2.0),
            ],
        );
        assert_eq!(p.cells.len(), 3);
        let total: f64 = (0..3).map(|c| p.area(c)).sum();
        assert!((total - 100.0).abs() < 1e-9);
        let nb = p.neighbours();
        // Every interior edge has a neighbour: 2 edges on x = 5 seen from the right cell.
        let right = (0..3).find(|&c| p.area(c) > 49.0).unwrap();
        let shared = nb[right].iter().flatten().count();
        assert_eq!(shared, 2, "{:?}", p.cells[right]);
    }

    #[test]
    fn an_l_of_roof_points_is_one_building_of_three_cells() {
        let lines = [
            line((0.0, 0.0), (1.0, 0.0), 0.0, 20.0),
            line((0.0, 0.0), (0.0, 1.0), 0.0, 20.0),
            line((20.0, 0.0), (0.0, 1.0), 0.0, 10.0),
            line((0.0, 20.0), (1.0, 0.0), 0.0, 10.0),
            line((10.0, 10.0), (1.0, 0.0), 0.0, 10.0),
            line((10.0, 10.0), (0.0, 1.0), 0.0, 10.0),
        ];
        let p = partition(DVec2::splat(-5.0), DVec2::splat(25.0), &lines);
        let mut roof = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                let q = DVec2::new(i as f64 * 0.5 + 0.25, j as f64 * 0.5 + 0.25);
                if q.x < 10.0 || q.y < 10.0 {
                    roof.push(q);
                }
            }
        }
        let terms = LabelTerms {
            pixel_m: 0.5,
            wall_distance_m: 0.5,
            wall_reach_m: 1.25,
        };
        let f = label(p, &roof, &[], &lines, &terms);
        assert_eq!(f.buildings, 1);
        let area: f64 = (0..f.inside.len())
            .filter(|&c| f.inside[c])
            .map(|c| f.partition.area(c))
            .sum();
        assert!((area - 300.0).abs() < 1e-6, "{area}");
    }
}
