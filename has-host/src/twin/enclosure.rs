//! Which side of each wall the sensors saw, and the ground enclosed between walls' back sides.
//!
//! Ground-plane (x, y) in metres, the run's frame.
//!
//! Mechanisms and why:
//! - **A wall's front.** An echo off a facade reaches the receiver only if the transmitter and
//!   the receiver both see the face it comes from, so the pairs that imaged a wall stand on its
//!   open side. Each pair's cloud ([`PairView`]) votes for the side of the wall plane holding its
//!   base station and the centre of its terminal's track, weighted by how many of the wall's
//!   points it holds (a point of the pair's cloud within the distance tolerance). A wall is
//!   oriented when the votes are not tied; its front normal points to the open side.
//! - **Enclosed ground.** Behind a wall's face is the building's material. From each seen point
//!   of an oriented wall's trace (one sample per voxel along its seen extent), a ray goes straight
//!   back, away from the front. If the first other oriented wall it crosses turns its back to the
//!   ray (its front faces on along the ray), the ray stayed inside one building between two
//!   facades seen from outside, and the ground it crossed is enclosed: evidence of a footprint
//!   even where no roof point was seen (a roof turned away from every pair). If that wall faces
//!   the ray instead, the ray left the building through a face no pair saw, and marks nothing.
//!   A facade no pair saw can still let a ray through into the street and a neighbour whose far
//!   facade turns its back to it; such a ray's ground is enclosed along one direction only. So a
//!   ground pixel (one voxel) counts as enclosed only when rays of two directions at least 45°
//!   apart cross it: it lies between seen facades both ways.
//!   Walls are crossed within their seen extent prolonged by the growing radius.
//! - **Open ground.** An echo's path is free space: from each point of an oriented wall a pair
//!   imaged, the sight lines to the pair's base station and to the centre of its terminal's
//!   track (when on the wall's open side) cross the ground below them. Where such a line passes
//!   lower than the lowest roof plane of the site (less one voxel), no building stands under it
//!   (a building reaches at least that high, and would have blocked the line): the footprint's
//!   cut counts that ground against being inside as a roof point counts for it. A street or an
//!   alley between two facades is then kept open even where no roof edge bounds it.
//! - **Open air over the roofs.** The same sight lines, from the fused points a pair imaged to
//!   that pair's base station, are free space all along: per ground pixel, the height at which
//!   they pass over it bounds any roof there ([`free_heights`]). Only the base station's line
//!   counts: it is one fixed point, while the terminal's track is a stretch of street whose
//!   centre need not see what its ends saw. The first two voxels from the point are left out
//!   (the point's own surface, placed to a voxel). The caller passes only points that the
//!   footprint leaves outside every building (one under a roof could not have been seen, and
//!   its line would cut that roof), and a pixel's height is the second lowest over the base
//!   stations: one receiver's misplaced echoes do not carve a roof.
//! - Nothing here names a shape: any footprint whose facades were seen from outside encloses its
//!   interior, courtyards included (a courtyard's walls face into the courtyard, so rays stop
//!   there).

use glam::{DVec2, DVec3, Vec3};

use super::footprint::SplitLine;
use super::planes::{PlaneKind, PlaneSet};
use crate::knn::PointIndex;

/// What one imaging pair saw: its cloud and where its two ends stood.
#[derive(Clone, Debug)]
pub struct PairView {
    /// The pair's imaged points, metres.
    pub points: Vec<Vec3>,
    /// The base station's panel centre, metres.
    pub receiver: DVec3,
    /// The centre of the terminal's track, metres.
    pub transmitter: DVec3,
}

/// Fewest of a wall's points a pair must hold to vote on its side.
pub const MIN_VOTE_POINTS: usize = 3;

/// Which wall points each pair imaged: per view, per plane (index of `set.planes`; empty for
/// roofs and the ground), the support points with a point of the view's cloud within the
/// distance tolerance. Both the wall fronts and the open ground read it.
pub fn sightings(points: &[Vec3], set: &PlaneSet, views: &[PairView]) -> Vec<Vec<Vec<u32>>> {
    let r2 = (set.tol.distance_m * set.tol.distance_m) as f32;
    views
        .iter()
        .map(|view| {
            let Ok(index) = PointIndex::new("pair view", &view.points) else {
                return vec![Vec::new(); set.planes.len()];
            };
            set.planes
                .iter()
                .map(|p| {
                    if p.kind != PlaneKind::Wall {
                        return Vec::new();
                    }
                    p.support
                        .iter()
                        .copied()
                        .filter(|&i| index.nearest(points[i as usize]).1 <= r2)
                        .collect()
                })
                .collect()
        })
        .collect()
}

/// Per plane (index of `set.planes`), the unit horizontal normal of an oriented wall's open side,
/// `None` for roofs, the ground and walls the views do not orient (`seen`: [`sightings`]).
pub fn wall_fronts(
    set: &PlaneSet,
    views: &[PairView],
    seen: &[Vec<Vec<u32>>],
) -> Vec<Option<DVec2>> {
    let mut votes = vec![0.0f64; set.planes.len()];
    for (view, held) in views.iter().zip(seen) {
        for (k, p) in set.planes.iter().enumerate() {
            let n = held[k].len();
            if p.kind != PlaneKind::Wall || n < MIN_VOTE_POINTS {
                continue;
            }
            let side = |x: DVec3| (p.n.dot(x) - p.d).signum();
            votes[k] += n as f64 * (side(view.receiver) + side(view.transmitter));
        }
    }
    set.planes
        .iter()
        .zip(&votes)
        .map(|(p, &v)| {
            (p.kind == PlaneKind::Wall && v != 0.0).then(|| p.n.truncate().normalize() * v.signum())
        })
        .collect()
}

/// Ground seen through: the pixels (centres, on the raster of `pixel_m`) under the sight lines
/// from each wall point a pair imaged (`seen`: [`sightings`]) to that pair's two ends, where the line passes lower than
/// `below_m` (the lowest roof): no building stands there, or the line would have been blocked.
/// Only oriented walls whose open side holds the sensor count, and the line is walked from one
/// and a half pixels off the wall (the wall's own pixel is not open).
pub fn open_ground(
    points: &[Vec3],
    views: &[PairView],
    seen: &[Vec<Vec<u32>>],
    fronts: &[Option<DVec2>],
    below_m: f64,
    pixel_m: f64,
) -> Vec<DVec2> {
    let key = |p: DVec2| {
        (
            (p.x / pixel_m).floor() as i64,
            (p.y / pixel_m).floor() as i64,
        )
    };
    let mut open: std::collections::HashSet<(i64, i64)> = Default::default();
    for (view, held) in views.iter().zip(seen) {
        for (k, idx) in held.iter().enumerate() {
            let Some(front) = fronts.get(k).copied().flatten() else {
                continue;
            };
            for &i in idx {
                let q = points[i as usize].as_dvec3();
                if q.z >= below_m {
                    continue;
                }
                for sensor in [view.receiver, view.transmitter] {
                    let d = sensor - q;
                    let run = d.truncate().length();
                    if run <= 0.0 || d.truncate().dot(front) <= 0.0 {
                        continue;
                    }
                    let mut t = 1.5 * pixel_m;
                    while t < run {
                        let at = q + d * (t / run);
                        if at.z >= below_m {
                            break;
                        }
                        open.insert(key(at.truncate()));
                        t += pixel_m;
                    }
                }
            }
        }
    }
    let mut keys: Vec<(i64, i64)> = open.into_iter().collect();
    keys.sort_unstable();
    keys.into_iter()
        .map(|(i, j)| DVec2::new((i as f64 + 0.5) * pixel_m, (j as f64 + 0.5) * pixel_m))
        .collect()
}

/// Ground positions (one per voxel step along each ray) enclosed between oriented walls' back
/// sides (module docs). `traces` are the wall traces, `fronts` the planes' open sides.
pub fn enclosed_ground(
    traces: &[SplitLine],
    fronts: &[Option<DVec2>],
    voxel_m: f64,
    reach_m: f64,
) -> Vec<DVec2> {
    use super::footprint::LineSource;
    let oriented: Vec<(&SplitLine, DVec2)> = traces
        .iter()
        .filter_map(|l| match l.source {
            LineSource::Wall(k) => fronts.get(k as usize).copied().flatten().map(|f| (l, f)),
            _ => None,
        })
        .collect();
    let mut marks: std::collections::HashMap<(i64, i64), u32> = Default::default();
    for (a, (wall, front)) in oriented.iter().enumerate() {
        let back = -*front;
        let steps = ((wall.t1 - wall.t0) / voxel_m).floor().max(0.0) as usize;
        for s in 0..steps {
            let start = wall.origin + wall.dir * (wall.t0 + (s as f64 + 0.5) * voxel_m);
            // First crossing of another oriented wall along the ray.
            let mut first: Option<(f64, DVec2)> = None;
            for (b, (other, other_front)) in oriented.iter().enumerate() {
                if a == b {
                    continue;
                }
                let denom = back.perp_dot(other.dir);
                if denom.abs() < 1e-9 {
                    continue; // parallel to the ray
                }
                let w = other.origin - start;
                let t = w.perp_dot(other.dir) / denom; // along the ray
                let u = w.perp_dot(back) / denom; // along the other wall
                if t <= voxel_m
                    || u < other.t0 - reach_m
                    || u > other.t1 + reach_m
                    || first.is_some_and(|(best, _)| t >= best)
                {
                    continue;
                }
                first = Some((t, *other_front));
            }
            let Some((t, other_front)) = first else {
                continue;
            };
            if other_front.dot(back) <= 0.0 {
                continue; // that face looks at the ray: the ray left the building
            }
            // Direction bin of the ray, folded over 180°.
            let bin = ((back.y.atan2(back.x).rem_euclid(std::f64::consts::PI)
                / std::f64::consts::PI
                * DIRECTION_BINS as f64) as usize)
                .min(DIRECTION_BINS - 1);
            let n = (t / voxel_m).floor() as usize;
            for i in 0..n {
                let p = start + back * ((i as f64 + 0.5) * voxel_m);
                let key = (
                    (p.x / voxel_m).floor() as i64,
                    (p.y / voxel_m).floor() as i64,
                );
                *marks.entry(key).or_insert(0u32) |= 1 << bin;
            }
        }
    }
    // Enclosed from two directions at least 45° apart (module docs).
    let apart = |m: u32| {
        (0..DIRECTION_BINS).any(|i| {
            (0..DIRECTION_BINS).any(|j| {
                let gap = (i + DIRECTION_BINS - j) % DIRECTION_BINS;
                m & (1 << i) != 0
                    && m & (1 << j) != 0
                    && (DIRECTION_BINS / 4..=3 * DIRECTION_BINS / 4).contains(&gap)
            })
        })
    };
    let mut keys: Vec<(i64, i64)> = marks
        .iter()
        .filter(|(_, &m)| apart(m))
        .map(|(&k, _)| k)
        .collect();
    keys.sort_unstable();
    keys.into_iter()
        .map(|(i, j)| DVec2::new((i as f64 + 0.5) * voxel_m, (j as f64 + 0.5) * voxel_m))
        .collect()
}

/// Ray directions are binned over 180° into this many bins (22.5° each).
const DIRECTION_BINS: usize = 8;

/// The open air over the site (module docs): per pixel of a raster of `pixel_m` (keys
/// `⌊x/pixel⌋, ⌊y/pixel⌋`), the height, metres, under which sight lines from imaged points to two
/// base stations pass over it ([`free_heights`]). Pixels fewer than two crossed are absent.
#[derive(Clone, Debug, Default)]
pub struct FreeHeights {
    /// Raster pixel, metres.
    pub pixel_m: f64,
    /// Per pixel, the second lowest over the base stations of each one's lowest line, metres.
    pub lowest: std::collections::HashMap<(i64, i64), f64>,
}

impl FreeHeights {
    /// The pixel holding ground position `p`.
    pub fn key(&self, p: DVec2) -> (i64, i64) {
        (
            (p.x / self.pixel_m).floor() as i64,
            (p.y / self.pixel_m).floor() as i64,
        )
    }

    /// The centre of pixel `k`.
    pub fn centre(&self, k: (i64, i64)) -> DVec2 {
        DVec2::new(
            (k.0 as f64 + 0.5) * self.pixel_m,
            (k.1 as f64 + 0.5) * self.pixel_m,
        )
    }
}

/// [`FreeHeights`] of the fused `points` that each view's pair imaged (a point of its cloud
/// within `distance_m`), walked from `skip_m` (horizontal run) off the point towards the base
/// station in steps of `pixel_m`, up to height `below_m` (above it no roof is a candidate). A
/// pixel's height is the second lowest over the base stations (each its own lowest): one
/// receiver's lines can all come from one misplaced echo (a detection of that pair within a
/// voxel of a fused point that is another echo's image), two receivers' seldom do.
///
/// # Errors
/// A non-finite point of a view's cloud.
pub fn free_heights(
    points: &[Vec3],
    views: &[PairView],
    distance_m: f64,
    pixel_m: f64,
    skip_m: f64,
    below_m: f64,
) -> Result<FreeHeights, crate::knn::GeometryError> {
    let mut out = FreeHeights {
        pixel_m,
        ..FreeHeights::default()
    };
    let d2 = (distance_m * distance_m) as f32;
    // Per receiver (in order of first appearance), its lowest line per pixel.
    let mut receivers: Vec<DVec3> = Vec::new();
    let mut per: Vec<std::collections::HashMap<(i64, i64), f64>> = Vec::new();
    for view in views.iter().filter(|v| !v.points.is_empty()) {
        let r = match receivers.iter().position(|&x| x == view.receiver) {
            Some(r) => r,
            None => {
                receivers.push(view.receiver);
                per.push(Default::default());
                receivers.len() - 1
            }
        };
        let index = PointIndex::new("pair cloud", &view.points)?;
        for q in points.iter().filter(|&&q| index.nearest(q).1 <= d2) {
            let q = q.as_dvec3();
            let d = view.receiver - q;
            let run = d.truncate().length();
            let mut t = skip_m;
            while t < run {
                let at = q + d * (t / run);
                if at.z >= below_m && d.z >= 0.0 {
                    break;
                }
                if at.z < below_m {
                    let h = per[r]
                        .entry(out.key(at.truncate()))
                        .or_insert(f64::INFINITY);
                    *h = h.min(at.z);
                }
                t += pixel_m;
            }
        }
    }
    let mut all: std::collections::HashMap<(i64, i64), [f64; 2]> = Default::default();
    for map in &per {
        for (&k, &h) in map {
            let e = all.entry(k).or_insert([f64::INFINITY; 2]);
            if h < e[0] {
                *e = [h, e[0]];
            } else if h < e[1] {
                e[1] = h;
            }
        }
    }
    out.lowest = all
        .into_iter()
        .filter(|(_, e)| e[1].is_finite())
        .map(|(k, e)| (k, e[1]))
        .collect();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::footprint::LineSource;
    use crate::twin::planes::PlaneSet;

    fn wall(o: (f64, f64), d: (f64, f64), len: f64, k: u32) -> SplitLine {
        SplitLine {
            origin: DVec2::new(o.0, o.1),
            dir: DVec2::new(d.0, d.1),
            t0: 0.0,
            t1: len,
            reach_m: 0.0,
            source: LineSource::Wall(k),
        }
    }

    #[test]
    fn sight_lines_from_a_seen_wall_open_the_ground_in_front_of_it_only() {
        use crate::twin::planes::{Plane, Tolerances};
        // A wall x = 0 seen at z 0.5–3 m over y ∈ [−2, 2] by a pair standing at x = 20 (both
        // ends); the lowest roof is at 8 m.
        let pts: Vec<Vec3> = (0..9)
            .flat_map(|j| {
                (1..7).map(move |k| Vec3::new(0.0, -2.0 + 0.5 * j as f32, 0.5 * k as f32))
            })
            .collect();
        let set = PlaneSet {
            planes: vec![Plane {
                n: DVec3::X,
                d: 0.0,
                support: (0..pts.len() as u32).collect(),
                weight: 1.0,
                kind: PlaneKind::Wall,
                snapped: true,
            }],
            label: vec![Some(0); pts.len()],
            dominant_azimuths: vec![0.0],
            tol: Tolerances::from_voxel(0.5),
        };
        let view = PairView {
            points: pts.clone(),
            receiver: DVec3::new(20.0, 0.0, 1.5),
            transmitter: DVec3::new(20.0, 1.0, 1.5),
        };
        let fronts = [Some(DVec2::X)];
        let views = std::slice::from_ref(&view);
        let seen = sightings(&pts, &set, views);
        assert_eq!(wall_fronts(&set, views, &seen), fronts);
        let open = open_ground(&pts, views, &seen, &fronts, 8.0, 0.5);
        assert!(open.len() > 100, "{}", open.len());
        assert!(open.iter().all(|p| p.x > 0.5 && p.x < 20.0), "{open:?}");
        // Sensors behind the wall (its closed side) see nothing through it.
        let behind = PairView {
            receiver: DVec3::new(-20.0, 0.0, 1.5),
            transmitter: DVec3::new(-20.0, 1.0, 1.5),
            ..view
        };
        let seen = sightings(&pts, &set, std::slice::from_ref(&behind));
        assert!(open_ground(&pts, &[behind], &seen, &fronts, 8.0, 0.5).is_empty());
    }

    #[test]
    fn the_ground_between_two_facades_seen_from_outside_is_enclosed() {
        // Walls x = 0 (open to −x) and x = 10 (open to +x), 20 m long.
        let traces = [
            wall((0.0, 0.0), (0.0, 1.0), 20.0, 0),
            wall((10.0, 0.0), (0.0, 1.0), 20.0, 1),
        ];
        let fronts = [Some(DVec2::NEG_X), Some(DVec2::X)];
        // Two facades back to back enclose their gap one way only: not enough.
        assert!(enclosed_ground(&traces, &fronts, 0.5, 1.0).is_empty());
        // With the two end facades y = 0 (open to −y) and y = 20 (open to +y) the box is closed.
        let mut box_walls = traces.to_vec();
        box_walls.push(wall((0.0, 0.0), (1.0, 0.0), 10.0, 2));
        box_walls.push(wall((0.0, 20.0), (1.0, 0.0), 10.0, 3));
        let fronts = [
            Some(DVec2::NEG_X),
            Some(DVec2::X),
            Some(DVec2::NEG_Y),
            Some(DVec2::Y),
        ];
        let g = enclosed_ground(&box_walls, &fronts, 0.5, 1.0);
        assert!(g.len() > 600, "{}", g.len()); // 800 pixels inside, less the rays' last steps
        assert!(g
            .iter()
            .all(|p| p.x > 0.0 && p.x < 10.0 && p.y > 0.0 && p.y < 20.0));
        // Facades facing each other across streets enclose nothing.
        let fronts = [
            Some(DVec2::X),
            Some(DVec2::NEG_X),
            Some(DVec2::Y),
            Some(DVec2::NEG_Y),
        ];
        assert!(enclosed_ground(&box_walls, &fronts, 0.5, 1.0).is_empty());
    }
    #[test]
    fn the_air_over_a_pixel_is_the_second_lowest_line_of_two_receivers() {
        // Two ground points, each imaged by two pairs: one per base station, east and north.
        let q = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.0)];
        let view = |receiver: DVec3| PairView {
            points: vec![Vec3::new(0.0, 0.0, 0.1)],
            receiver,
            transmitter: DVec3::new(0.0, -50.0, 1.5),
        };
        let (east, north) = (DVec3::new(20.0, 0.0, 10.0), DVec3::new(0.0, 20.0, 20.0));
        let one = free_heights(&q[..1], &[view(east)], 0.5, 0.5, 1.0, 100.0).unwrap();
        assert!(one.lowest.is_empty(), "one receiver decides nothing");
        // East's line rises 0.5 m per metre, north's 1 m per metre: no pixel is crossed by both
        // but the point's own (skipped), so still nothing.
        let two = free_heights(&q[..1], &[view(east), view(north)], 0.5, 0.5, 1.0, 100.0).unwrap();
        assert!(two.lowest.is_empty());
        // Two receivers on one side at different heights: over a pixel both cross, the higher.
        let low = DVec3::new(20.0, 0.0, 10.0);
        let high = DVec3::new(20.0, 0.0, 20.0);
        let both = free_heights(&q[..1], &[view(low), view(high)], 0.5, 0.5, 1.0, 100.0).unwrap();
        let k = both.key(DVec2::new(10.2, 0.1));
        let h = both.lowest[&k];
        // At x ≈ 10 the lines stand near 5 m and 10 m: the second lowest is the higher one.
        assert!((h - 10.0).abs() < 0.6, "{h}");
        // Nothing is recorded above the ceiling.
        let capped = free_heights(&q[..1], &[view(low), view(high)], 0.5, 0.5, 1.0, 4.0).unwrap();
        assert!(capped.lowest.values().all(|&h| h < 4.0));
    }
}
