//! Cutting lines where roof evidence ends: the edges of what the sensors saw of a roof, along the
//! site's dominant wall directions.
//!
//! Coordinates are ground-plane (x, y) in metres, the run's frame.
//!
//! Mechanisms and why:
//! - A facade is not always imaged (turned away from every pair, occluded, or a low parapet), but
//!   the roof behind it usually ends at it. Nor is a step between two roof pieces (the glazing of
//!   a sawtooth, a lower wing) always imaged as a wall. Where a roof plane's points stop along a
//!   straight line, that line is a candidate edge of a footprint cell; wall traces alone cut the
//!   site only where walls were seen.
//! - **Raster**: each point set (the points of all roof planes together, and those of each roof
//!   plane with at least [`super::roof::MEET_SUPPORT`] points) is rasterised on a grid turned onto
//!   each dominant direction of the site (the walls' own directions, [`super::planes`]), one
//!   pixel per imaging voxel. A fused point is a voxel centre sampled sparsely, so the raster is
//!   closed (dilated then eroded by one pixel): gaps of one pixel are not edges.
//! - **Edges**: along every raster row, each change between empty and occupied is an edge at
//!   that pixel boundary. Edges at the same boundary (± one pixel: the quantisation of a voxel
//!   centre) in consecutive rows (gaps of one row allowed) form a run; a run spanning at least
//!   [`MIN_RUN_VOXELS`] rows is a line, placed at the boundary holding most of its edges. Shorter
//!   runs are the ragged rim of a sparse sample.
//! - No direction is assumed: with no dominant wall direction there is no edge line, and an
//!   outline at another angle is cut only by its walls.

use std::collections::{BTreeMap, HashSet};

use glam::DVec2;

use super::footprint::{LineSource, SplitLine};

/// Fewest raster rows an edge must span to cut the partition: the span a wall plane needs
/// ([`super::planes::MIN_WALL_SPAN_VOXELS`]) and one more, since an edge is one-sided evidence.
pub const MIN_RUN_VOXELS: usize = 4;

/// An edge line cuts this many voxels past its run: the gap a run may bridge (one row) and the
/// quantisation of a voxel centre. Beyond that the data showed no edge.
pub const EDGE_REACH_VOXELS: f64 = 2.0;

/// The edge lines of point set `xy` (ground positions) on a raster of `pixel_m` turned onto each
/// azimuth of `azimuths` (radians: the normal of one family of lines; the other family is
/// perpendicular), tagged `source`.
pub fn edge_lines(
    xy: &[DVec2],
    azimuths: &[f64],
    pixel_m: f64,
    source: LineSource,
) -> Vec<SplitLine> {
    let mut out = Vec::new();
    if xy.is_empty() || pixel_m.is_nan() || pixel_m <= 0.0 {
        return out;
    }
    for &az in azimuths {
        let u = DVec2::new(az.cos(), az.sin());
        let v = u.perp();
        let grid = Raster::new(xy, u, v, pixel_m);
        // Lines u = const (rows along v), then v = const (rows along u).
        for (along_u, normal, dir) in [(true, u, v), (false, v, u)] {
            for run in grid.runs(along_u) {
                // The line: `boundary` pixels along `normal`, its rows' extent along `dir`.
                out.push(SplitLine {
                    origin: normal * (run.boundary as f64 * pixel_m),
                    dir,
                    t0: run.first as f64 * pixel_m,
                    t1: (run.last + 1) as f64 * pixel_m,
                    reach_m: EDGE_REACH_VOXELS * pixel_m,
                    source,
                });
            }
        }
    }
    out
}

/// A run of edges at one pixel boundary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Run {
    /// Pixel boundary index across the rows.
    boundary: i64,
    /// First and last row.
    first: i64,
    last: i64,
}

/// Occupied pixels of a turned raster, closed by one pixel.
struct Raster {
    /// Occupied (i along u, j along v).
    occ: HashSet<(i64, i64)>,
    lo: (i64, i64),
    hi: (i64, i64),
}

impl Raster {
    fn new(xy: &[DVec2], u: DVec2, v: DVec2, pixel_m: f64) -> Raster {
        let mut raw = HashSet::new();
        for p in xy {
            raw.insert((
                (p.dot(u) / pixel_m).floor() as i64,
                (p.dot(v) / pixel_m).floor() as i64,
            ));
        }
        let dilated: HashSet<(i64, i64)> = raw
            .iter()
            .flat_map(|&(i, j)| {
                (-1..=1).flat_map(move |di| (-1..=1).map(move |dj| (i + di, j + dj)))
            })
            .collect();
        let occ: HashSet<(i64, i64)> = dilated
            .iter()
            .copied()
            .filter(|&(i, j)| {
                (-1..=1).all(|di| (-1..=1).all(|dj| dilated.contains(&(i + di, j + dj))))
            })
            .chain(raw.iter().copied())
            .collect();
        let lo = occ
            .iter()
            .fold((i64::MAX, i64::MAX), |m, &(i, j)| (m.0.min(i), m.1.min(j)));
        let hi = occ
            .iter()
            .fold((i64::MIN, i64::MIN), |m, &(i, j)| (m.0.max(i), m.1.max(j)));
        Raster { occ, lo, hi }
    }

    /// Edge runs of lines across the u axis (`along_u`: boundaries between pixels i−1 and i,
    /// rows j) or across the v axis.
    fn runs(&self, along_u: bool) -> Vec<Run> {
        // (boundary, sign) → rows holding that edge.
        let mut edges: BTreeMap<(i64, bool), Vec<i64>> = BTreeMap::new();
        let (a_lo, a_hi, r_lo, r_hi) = if along_u {
            (self.lo.0, self.hi.0, self.lo.1, self.hi.1)
        } else {
            (self.lo.1, self.hi.1, self.lo.0, self.hi.0)
        };
        let at = |a: i64, r: i64| {
            if along_u {
                self.occ.contains(&(a, r))
            } else {
                self.occ.contains(&(r, a))
            }
        };
        for r in r_lo..=r_hi {
            let mut prev = false;
            for a in a_lo..=a_hi + 1 {
                let now = at(a, r);
                if now != prev {
                    edges.entry((a, now)).or_default().push(r);
                }
                prev = now;
            }
        }
        // Strongest boundaries first; each takes the edges of its own and the two adjacent
        // boundaries (same sign) not yet taken.
        let mut order: Vec<(i64, bool)> = edges.keys().copied().collect();
        order.sort_by_key(|k| (std::cmp::Reverse(edges[k].len()), *k));
        let mut taken: HashSet<(i64, bool, i64)> = HashSet::new();
        let mut runs = Vec::new();
        for (b, sign) in order {
            let mut rows: Vec<i64> = (b - 1..=b + 1)
                .flat_map(|bb| edges.get(&(bb, sign)).into_iter().flatten().copied())
                .filter(|&r| !(b - 1..=b + 1).any(|bb| taken.contains(&(bb, sign, r))))
                .collect();
            rows.sort_unstable();
            rows.dedup();
            let mut k = 0;
            while k < rows.len() {
                let mut m = k;
                while m + 1 < rows.len() && rows[m + 1] - rows[m] <= 2 {
                    m += 1;
                }
                if (rows[m] - rows[k] + 1) as usize >= MIN_RUN_VOXELS {
                    runs.push(Run {
                        boundary: b,
                        first: rows[k],
                        last: rows[m],
                    });
                    for &r in &rows[k..=m] {
                        for bb in b - 1..=b + 1 {
                            taken.insert((bb, sign, r));
                        }
                    }
                }
                k = m + 1;
            }
        }
        runs.sort_by_key(|r| (r.boundary, r.first));
        runs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sampled_rectangle_gives_its_four_edges() {
        // Voxel centres of a 10 m × 6 m roof at 0.5 m, every other one missing in a checker.
        let mut xy = Vec::new();
        for i in 0..20 {
            for j in 0..12 {
                if (i + j) % 2 == 0 || i == 0 || j == 0 || i == 19 || j == 11 {
                    xy.push(DVec2::new(i as f64 * 0.5 + 0.25, j as f64 * 0.5 + 0.25));
                }
            }
        }
        let lines = edge_lines(&xy, &[0.0], 0.5, LineSource::Wall(0));
        assert_eq!(lines.len(), 4, "{lines:?}");
        for l in &lines {
            let m = l.dir.perp();
            let off = m.dot(l.origin).abs();
            let ok = [0.0, 10.0, 6.0].iter().any(|&e| (off - e).abs() < 1e-9);
            assert!(ok, "{l:?}");
            assert!((l.t1 - l.t0) >= 5.0, "{l:?}");
        }
    }
}
