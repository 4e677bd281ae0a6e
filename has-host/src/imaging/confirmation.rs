//! Cross-pair confirmation of the fused cloud: a point that pairs which see its place do not
//! confirm is a false alarm, not a surface.
//!
//! **Why.** Each pair's detection holds its false alarms to a stated rate
//! ([`super::detection`]), but a false alarm is one pair's: clutter speckle, a grating or
//! track lobe, a marginal crossing of the clutter model. A surface is not one pair's: every
//! scatterer is Lambertian ([`crate::echo`]), so a wall or roof echoes towards every pair in
//! front of it whose legs reach it. The clouds of the suite's sites show it: the points more than
//! 3 m from any building (the ones that dominate √CD) are all single-pair points on open ground
//! or in free air, and two or more pairs that see their place detected nothing there.
//!
//! **The test.** Pair `j` *confirms* a fused point `p` when it kept `p` or detected a point `q`
//! within the support distance of `p` (half the coarsest resolution cell of the pairs,
//! [`super::run::support_distance_m`]: the surface that gave `p` lies within it) that its own
//! resolution cell cannot tell from `p` ([`PairCell`]; `imaging.resolved_confirmation`): the
//! offset `d = q − p` has `dᵀ J_j d ≤ 1`, with `J_j` pair `j`'s information matrix at `p` over
//! its four resolved directions, each resolution widened by the voxel (`√(δ² + v²)`). Where `p`
//! lies on a surface of its own (normal `n̂`, below) only the offset across it counts,
//! `(d·n̂)²·n̂ᵀJ_j n̂ ≤ 1`: a pair detects a surface's cells sparsely, so its detection of the same
//! surface may lie a cell or two along it. A pair that resolves the offset has placed that echo
//! elsewhere — a UAV's pair that places a roof to half a metre in height says nothing for a point
//! 3 m above the roof, which a vehicle's pair placed there from the smear of the roof's edge;
//! counted as a confirmation, the support distance let the roof's every detection vouch for the
//! smear above it. `k(p)` pairs confirm it. A point that two pairs confirm, or that lies on a patch at least a resolution
//! cell across in two directions (a surface of its own, [`super::facing`]: a false alarm is a
//! blob of one cell), is a *surface point* for the legs below. Pair `j`
//! *sees* `p` when `p` lies in front of its panel (`(p − rx)·n̂ > 0`, the array's half-space),
//! and both legs — from the panel's centre and from the aperture's centre to `p` — reach `p`
//! through the known terrain (its scene) and past the surface points: the segment, up to twice
//! the support distance short of `p`, passes within the support distance of none — each stands
//! for its resolution cell's patch of surface, so a wall the cloud holds with holes (a pair saw
//! it in part) still stands between a pair and what lies behind it (the detected surfaces are
//! the only buildings the operator knows; on a courtyard block, legs through the gaps of the
//! wings' shells made 877 of the 923 points an earlier test removed look seen, all on the
//! yard's walls). Other single-pair points block no leg: they are what the test questions most, a
//! false-alarm blob would otherwise hide itself, and a vehicle's legs run low over open ground
//! past other pairs' false alarms. Nor does a pair see `p` from behind its surface: a Lambertian
//! facet echoes to a pair only when it faces both of the pair's ends ([`super::facing`]), so a
//! pair with an end behind the surface through `p` (its normal over half the support distance,
//! oriented toward the sensors that detected `p`) would have received nothing from it, and its
//! silence says nothing. This is what lets a wall one pair imaged stand: the legs of the pairs on
//! the building's other sides reach it through walls the cloud holds only as single pairs' points
//! (held-out site_86, quick: a face that one pair imaged from its foot to its eave lost 1 042
//! points to the pairs behind the building, and the cloud's √CD was 1.54 m against 0.59 m with
//! the facing). A patch smaller than a resolution cell — one pair's false alarm is such a blob —
//! has no surface of its own ([`super::facing`]) and is seen from every side, as before. A pair
//! that sees `p` and does not confirm it *denies* it; `d(p)` pairs do.
//!
//! **A pair cannot image what it cannot see.** Pair `j`'s detection near `p` confirms `p` only
//! when both of `j`'s legs reach `p` without crossing a surface of the cloud: a patch with a
//! facing ([`super::facing`]) that a leg passes within the support distance of, with the sensor
//! and `p` on opposite sides of that patch's plane, each by more than the support distance. A
//! point inside a closed volume whose walls and roof the pairs imaged, or behind a wall the pair
//! itself imaged, cannot have echoed to that pair; what it detected there is the smear or a
//! sidelobe of the surfaces it does see, and such a confirmation says nothing either way. Only
//! crossing counts: a leg that grazes the surface `p` stands on (a roof seen from a panel 10° over
//! it) keeps `p` on the surface's plane, so it crosses nothing; and the leg must pierce the
//! patch, not pass its edge: where it meets the patch's plane, the patch holds points near that
//! plane within a quarter of the support distance of each of four points half the support
//! distance away from it in the plane, one each way along two directions, with normals within 30°
//! of the patch's (a leg
//! over a wall's top edge to the roof behind it passes within the support distance of the wall
//! without piercing it).
//!
//! **A pair's own terrain echo says nothing.** A detection of pair `j` inside `j`'s own layer
//! over the known terrain, with nothing of the fused cloud rising out of that layer around it
//! ([`super::terrain_echo`] with `j`'s vertical extent), is what `j` would detect of the bare
//! ground there as readily as of a surface: near such a detection `j` neither confirms `p` nor,
//! having detected something, denies it. A vehicle's pair places height to metres, so the
//! ground speckle that passes its test lies inside its layer; counted as confirmations, two
//! vehicles' ground false alarms kept a UAV pair's false alarm 1 m over open ground, 16 m from
//! any building (office_pair's default cloud: 31 points carrying a quarter of its accuracy
//! term; docs/journal/results.md, "A pair's own ground echo confirms nothing"). `p` is dropped when
//! `d(p) ≥ need·k(p)` (`need` = `imaging.cross_pair_denials`). Since the surface points that
//! block legs are fixed before any point is judged, one pass decides every point.
//!
//! **Why `need` denials per confirmation.** Each pair that sees a surface detects it with some
//! probability `q`; each pair has a false alarm within the support distance of a given place
//! with a much smaller probability `f`. With `k` confirmations and `d` denials the likelihood
//! ratio of a surface against coincident false alarms is `(q/f)^k·((1 − q)/(1 − f))^d`: its
//! logarithm is linear in `k` and `d`, so the decision is `d ≥ c·k` for one constant
//! `c = ln(q/f) / ln((1 − f)/(1 − q))`. The one-pair rule measured on the suite — a point one
//! pair kept is dropped when two pairs that see it deny it (a single denial is weak: a seeing pair
//! misses a true cell often, at grazing incidence, on its weaker legs) — sets `c = need = 2`, and
//! the same constant then holds for every `k`. An earlier version let one confirmation outweigh
//! any number of denials (a surface would collect `n·(1 − q)` denials from `n` seeing pairs); it
//! is not so: the legs of a pair that misses a surface cell pass within the support distance of
//! that surface's own shell of points, so on the suite's clouds no point within 1 m of the truth
//! has as many as six denials, while two pairs' false alarms within the support distance of each
//! other are not rare (tens of false clusters per pair image): on tower_hall's default cloud 16
//! points 35 m from any building, kept by BS2-UAV and BS1-V1 at 1–2 m from each other and denied
//! by 10–23 pairs, carried a fifth of the accuracy term (docs/journal/results.md).
//!
//! **Where a pair saw through, a denial whatever the facing** (`imaging.free_space_test`). A
//! second pass adds the positive evidence of free space ([`super::free_space`]): pair `j` denies
//! `p` when one of its legs to a point two pairs kept or confirm, and that the first pass kept,
//! passed through `p` to more than the support distance beyond it, crossing the whole layer in
//! which the surface through `p` may lie (the pairs' resolutions across `p`'s plane; a leg that
//! grazes a roof refutes none of the roof's points). Unlike a seeing pair's silence
//! this needs no facing: the facing protects a surface from pairs behind it, but a leg that ran
//! on through `p` to a surface farther away says that nothing opaque stood at `p`, whichever way
//! a patch through `p` would face. The smear of a bright wall's top edge over a roof has the
//! wall's facing, so the pairs on the roof's side never denied it; a UAV's legs to the roof
//! behind the edge pass through it.
//!
//! Units: metres; points in the world frame.

use glam::Vec3;
use rayon::prelude::*;

use super::facing::faces_a_pair;
use super::free_space::{Across, FreeSpace};
use super::pair_cell::resolution_along_m;
pub use super::pair_cell::PairCell;
use crate::knn::PointIndex;
use crate::scene::Scene;

/// Cosine of the largest angle between the normals of two points of one flat patch (30°): the
/// own-sight test's probes around a leg's crossing find the patch it pierces, not a corner where
/// a wall's and a roof's points meet.
const COPLANAR_COS: f32 = 0.866;

/// What a pair looks from: its panel's centre and boresight, its aperture's centre, and its own
/// detections (`None`: it detected nothing).
pub struct PairSight<'a> {
    /// Panel (receive array) centre, metres.
    pub rx: Vec3,
    /// Panel boresight (unit).
    pub boresight: Vec3,
    /// Aperture (transmit track) centre, metres.
    pub tx: Vec3,
    /// The pair's detected points, without its terrain echoes.
    pub detections: Option<&'a PointIndex>,
    /// The pair's detections that are its own terrain's echoes ([`super::terrain_echo`]: inside
    /// its layer over the terrain, under nothing that rises out of it): a point near one of them
    /// is one the pair cannot tell from the ground, and it neither confirms nor denies it.
    pub ground: Option<&'a PointIndex>,
    /// The pair's resolution cell ([`PairCell`]); `None`: a detection within the support
    /// distance confirms whatever its offset.
    pub cell: Option<PairCell>,
}

/// What the pairs say of one fused point (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    /// Pairs that kept the point or detected within the support distance of it.
    pub confirmed: u8,
    /// Pairs that see the point's place and did not confirm it.
    pub denied: u8,
}

/// Each point's confirmations and denials (module docs). `mask[i]` has bit `k` set when pair `k`
/// kept point `i`; `facing[i]` is the normal of point `i`'s own surface
/// ([`super::facing::own_surface_normals`]; `None`, or past the slice's end, where it has none:
/// seen from every side); `support_m` is the confirmation radius and the point's own extent along
/// a leg.
pub fn tallies(
    points: &[Vec3],
    mask: &[u64],
    facing: &[Option<Vec3>],
    sights: &[PairSight<'_>],
    terrain: &Scene,
    support_m: f32,
    own_sight: bool,
) -> Vec<Tally> {
    count(
        points, mask, facing, sights, terrain, support_m, own_sight, None, None,
    )
}

/// The free-space pass of [`confirmed`] ([`super::free_space`]): legs pass through points within
/// `half_width_m` of them; `planes[i]` is the normal of the plane through point `i` (a
/// [`super::facing::test_normals`]; none past the slice's end: any leg through the point
/// denies it).
#[derive(Clone, Copy, Debug)]
pub struct FreeSpaceTest<'a> {
    /// A leg passes through a point within this distance of it, metres.
    pub half_width_m: f32,
    /// Each point's plane normal.
    pub planes: &'a [Vec3],
    /// Each pair's resolution cell (none past the slice's end: the pair places its points
    /// exactly).
    pub cells: &'a [PairCell],
}

/// Which points survive the confirmation: those whose denials are fewer than `need` per
/// confirmation ([`tallies`], module docs; `need` = 0 keeps every point).
#[allow(clippy::too_many_arguments)]
pub fn confirmed(
    points: &[Vec3],
    mask: &[u64],
    facing: &[Option<Vec3>],
    sights: &[PairSight<'_>],
    terrain: &Scene,
    support_m: f32,
    own_sight: bool,
    need: u8,
    free_space: Option<FreeSpaceTest<'_>>,
) -> Vec<bool> {
    if need == 0 {
        return vec![true; points.len()];
    }
    let first = count(
        points,
        mask,
        facing,
        sights,
        terrain,
        support_m,
        own_sight,
        Some(need),
        None,
    );
    let Some(FreeSpaceTest {
        half_width_m,
        planes,
        cells,
    }) = free_space
    else {
        return first.into_iter().map(|t| kept(t, need)).collect();
    };
    // The legs of the pairs to the points two of them kept or confirm (its confirmations are
    // counted in full before any denial) and that the confirmation kept: the free space the
    // pairs saw through ([`super::free_space`]), a second pass's denials.
    let ends_leg: Vec<bool> = first
        .iter()
        .zip(mask)
        .map(|(&t, m)| kept(t, need) && (m.count_ones() > 1 || t.confirmed > 1))
        .collect();
    let sensors: Vec<[Vec3; 2]> = sights.iter().map(|s| [s.rx, s.tx]).collect();
    let free = FreeSpace::new(
        points,
        mask,
        &ends_leg,
        &sensors,
        cells,
        half_width_m,
        support_m,
    );
    // Each point's plane, and how far across it the point may lie from the surface: the finest
    // resolution across it among the pairs that kept the point (zero where no pair's cell is
    // known: the point is where it was placed).
    let across: Vec<Option<Across>> = points
        .par_iter()
        .zip(mask)
        .enumerate()
        .map(|(i, (&p, &m))| {
            planes.get(i).map(|&normal| Across {
                normal,
                sigma_m: cells
                    .iter()
                    .enumerate()
                    .filter(|&(k, _)| k < 64 && (m >> k) & 1 == 1)
                    .map(|(_, c)| resolution_along_m(&c.information(p), normal))
                    .reduce(f32::min)
                    .unwrap_or(0.0),
            })
        })
        .collect();
    count(
        points,
        mask,
        facing,
        sights,
        terrain,
        support_m,
        own_sight,
        Some(need),
        Some((&free, &across)),
    )
    .into_iter()
    .map(|t| kept(t, need))
    .collect()
}

fn kept(t: Tally, need: u8) -> bool {
    u32::from(t.denied) < u32::from(need) * u32::from(t.confirmed)
}

/// [`tallies`]; with `need`, each point's legs are traced only until its fate is known (its
/// denials reach `need` per confirmation, or the pairs left cannot make them), so its `denied`
/// may fall short of the full count but decides as the full count would.
#[allow(clippy::too_many_arguments)]
fn count(
    points: &[Vec3],
    mask: &[u64],
    facing: &[Option<Vec3>],
    sights: &[PairSight<'_>],
    terrain: &Scene,
    support_m: f32,
    own_sight: bool,
    need: Option<u8>,
    free: Option<(&FreeSpace, &[Option<Across>])>,
) -> Vec<Tally> {
    let r2 = support_m * support_m;
    // A pair past the 64 recorded in the mask may have kept the point: it counts as keeping it.
    let kept_by = |m: u64, k: usize| k >= 64 || (m >> k) & 1 == 1;
    // Pair `k` confirms point `i` where it kept it, or detected within the support distance of it
    // at an offset its resolution cell cannot tell from `i` (a pair that resolves the offset
    // places that echo elsewhere: its detection is not of `i`).
    let confirms = |i: usize, k: usize| {
        let p = points[i];
        kept_by(mask[i], k)
            || sights[k].detections.is_some_and(|d| match &sights[k].cell {
                None => d.nearest(p).1 <= r2,
                Some(cell) => {
                    let normal = facing.get(i).copied().flatten();
                    let mut near = d.within(p, support_m);
                    near.sort_unstable_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
                    near.iter()
                        .any(|&(j, _)| !cell.resolves_apart(p, d.point(j), normal))
                }
            })
    };
    let grounded = |p: Vec3, k: usize| sights[k].ground.is_some_and(|d| d.nearest(p).1 <= r2);
    // A point two pairs kept or confirm is not one pair's false alarm, nor is a point on a patch
    // at least a resolution cell across (one with a facing): the kinds of point that stand for a
    // surface between a pair and another point.
    let surface: Vec<bool> = points
        .par_iter()
        .zip(mask)
        .enumerate()
        .map(|(i, (_, &m))| {
            facing.get(i).is_some_and(Option::is_some)
                || m.count_ones() > 1
                || (0..sights.len())
                    .filter(|&k| confirms(i, k))
                    .nth(1)
                    .is_some()
        })
        .collect();
    let walls: Vec<Vec3> = points
        .iter()
        .zip(&surface)
        .filter(|(_, &s)| s)
        .map(|(&p, _)| p)
        .collect();
    // A fused point stands for the surface patch of its resolution cell (the support distance
    // around it), and the cloud samples a surface with gaps: a wall a pair sees only in part
    // still stands between another pair and what lies behind it. So a leg is blocked where it
    // passes within the support distance of a surface point; it is sampled every half support
    // distance (a point within ~0.97 of it from the line is found), from the sensor to twice
    // the support distance short of `p` — nearer than that, the leg meets `p`'s own surface
    // (whose points lie within the support distance of a leg that arrives at more than 30° to
    // it; a grazing pair's silence says little anyway). One pair's blob of less than a cell
    // blocks nothing: a false alarm would otherwise hide itself, and on open ground a vehicle's
    // legs run low past other pairs' false alarms.
    let near = NearCells::new(&walls, support_m);
    let walls = PointIndex::new("surface points", &walls).ok();
    let step = 0.5 * support_m;
    let reaches = |s: Vec3, p: Vec3| -> bool {
        let d = p - s;
        let len = d.length();
        if len.is_nan() || len <= 2.0 * support_m {
            return terrain.visible(s, p);
        }
        let dir = d / len;
        let n = ((len - 2.0 * support_m) / step).floor() as usize;
        let blocked = walls.as_ref().is_some_and(|w| {
            (0..=n).any(|k| {
                let q = s + dir * (k as f32 * step);
                near.may_hold(q) && w.nearest(q).1 <= r2
            })
        });
        !blocked && terrain.visible(s, p)
    };
    // A pair cannot image what it cannot see: its detection at `p` counts only when neither of
    // its legs crosses a surface of its own (a patch with a facing) on the way, i.e. passes
    // within the support distance of such a patch's point `w` with the sensor and `p` on opposite
    // sides of `w`'s plane, each farther from it than the support distance (`p` on the patch
    // itself, or a sensor on its plane, crosses nothing).
    let faced: Vec<(Vec3, Vec3)> = points
        .iter()
        .take(if own_sight { points.len() } else { 0 })
        .zip(facing.iter().chain(std::iter::repeat(&None)))
        .filter_map(|(&p, n)| n.map(|n| (p, n)))
        .collect();
    let faced_points: Vec<Vec3> = faced.iter().map(|&(p, _)| p).collect();
    let faced_near = NearCells::new(&faced_points, support_m);
    let faced_index = PointIndex::new("faced surface points", &faced_points).ok();
    let crosses_a_surface = |s: Vec3, p: Vec3| -> bool {
        let Some(index) = faced_index.as_ref() else {
            return false;
        };
        let d = p - s;
        let len = d.length();
        if !len.is_finite() || len <= 2.0 * support_m {
            return false;
        }
        let dir = d / len;
        let n = (len / step).floor() as usize;
        (0..=n).any(|k| {
            let q = s + dir * (k as f32 * step);
            if !faced_near.may_hold(q) {
                return false;
            }
            let (j, d2) = index.nearest(q);
            if d2 > r2 {
                return false;
            }
            let (w, nw) = faced[j as usize];
            let (a, b) = ((s - w).dot(nw), (p - w).dot(nw));
            if !(a * b < 0.0 && a.abs() > support_m && b.abs() > support_m) {
                return false;
            }
            // Where the leg meets the patch's plane, the patch must surround it: a leg over a
            // wall's top edge (a panel's grazing view of the roof behind it) passes within the
            // support distance of the wall without piercing it.
            let along = dir.dot(nw);
            if along.abs() < 1e-3 {
                return false;
            }
            let x = s - dir * (a / along);
            let (t1, t2) = nw.any_orthonormal_pair();
            let r = 0.5 * support_m;
            [t1, -t1, t2, -t2].iter().all(|&t| {
                let probe = x + t * r;
                faced_near.may_hold(probe) && {
                    let (k, d2) = index.nearest(probe);
                    let (q, nq) = faced[k as usize];
                    d2 <= 0.25 * r * r
                        && (q - w).dot(nw).abs() <= 0.5 * r
                        && nq.dot(nw).abs() >= COPLANAR_COS
                }
            })
        })
    };
    let sees_through_own_legs = |p: Vec3, k: usize| {
        !crosses_a_surface(sights[k].rx, p) && !crosses_a_surface(sights[k].tx, p)
    };
    (0..points.len())
        .into_par_iter()
        .map(|i| {
            let p = points[i];
            let mut t = Tally::default();
            let mut candidates = Vec::with_capacity(sights.len());
            for (k, s) in sights.iter().enumerate() {
                if confirms(i, k) {
                    if sees_through_own_legs(p, k) {
                        t.confirmed = t.confirmed.saturating_add(1);
                    }
                    // Otherwise its detection here is not an echo from `p` (a sidelobe or
                    // smear of what it does see): no word either way.
                } else if free.is_some_and(|(f, across)| f.pair_saw_through(p, k, across[i])) {
                    // Its leg to a surface beyond `p` passed through `p`: free space
                    // ([`super::free_space`]), a denial whatever `p`'s facing.
                    t.denied = t.denied.saturating_add(1);
                } else if grounded(p, k) {
                    // Its detection here may be the ground's: no word either way.
                } else if (p - s.rx).dot(s.boresight) > 0.0
                    && facing
                        .get(i)
                        .copied()
                        .flatten()
                        .is_none_or(|n| faces_a_pair(p, n, &[[s.tx, s.rx]]))
                {
                    candidates.push(s);
                }
            }
            let target = need.map(|n| u32::from(n) * u32::from(t.confirmed));
            let mut left = candidates.len() as u32;
            for s in candidates {
                if let Some(target) = target {
                    if u32::from(t.denied) >= target || u32::from(t.denied) + left < target {
                        break;
                    }
                }
                left -= 1;
                if reaches(s.rx, p) && reaches(s.tx, p) {
                    t.denied = t.denied.saturating_add(1);
                }
            }
            t
        })
        .collect()
}

/// A lattice over a point set that marks every cell some point lies within `radius` of (by
/// the cell's box against the point's box): a query in an unmarked cell is farther than
/// `radius` from every point, so a leg sample there needs no nearest-neighbour search. Most of
/// a leg runs through free air, where this answers without the tree; the decisions are those of
/// the search alone (the same points are tested wherever a point could lie within `radius`).
struct NearCells {
    min: Vec3,
    inv_cell: f32,
    dims: [usize; 3],
    marked: Vec<bool>,
}

impl NearCells {
    /// At most this many cells: the cell grows past twice the radius on a wide, sparse cloud.
    const MAX_CELLS: f64 = 4.0e6;

    fn new(points: &[Vec3], radius: f32) -> NearCells {
        // A margin over the radius: a point's box covers its ball whatever the roundings.
        let reach = radius * 1.01 + 1e-3;
        let (lo, hi) = points.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        );
        if points.is_empty() || !reach.is_finite() || !(lo.is_finite() && hi.is_finite()) {
            return NearCells {
                min: Vec3::ZERO,
                inv_cell: 0.0,
                dims: [0; 3],
                marked: Vec::new(),
            };
        }
        let (min, size) = (lo - reach, hi - lo + 2.0 * reach);
        let count = |cell: f32| size.to_array().map(|s| (s / cell).floor() as f64 + 1.0);
        let mut cell = 2.0 * reach;
        while count(cell).iter().product::<f64>() > Self::MAX_CELLS {
            cell *= 2.0;
        }
        let inv_cell = 1.0 / cell;
        let dim = |s: f32| ((s * inv_cell).floor() as usize).saturating_add(1);
        let dims = [dim(size.x), dim(size.y), dim(size.z)];
        let mut cells = NearCells {
            min,
            inv_cell,
            dims,
            marked: vec![false; dims[0] * dims[1] * dims[2]],
        };
        for &p in points {
            let (a, b) = (cells.cell(p - reach), cells.cell(p + reach));
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        let i = cells.flat([x, y, z]);
                        cells.marked[i] = true;
                    }
                }
            }
        }
        cells
    }

    /// The cell holding `q`, clamped to the lattice (monotone in each coordinate).
    fn cell(&self, q: Vec3) -> [usize; 3] {
        let u = (q - self.min) * self.inv_cell;
        let at = |v: f32, n: usize| (v.max(0.0) as usize).min(n.saturating_sub(1));
        [
            at(u.x, self.dims[0]),
            at(u.y, self.dims[1]),
            at(u.z, self.dims[2]),
        ]
    }

    fn flat(&self, [x, y, z]: [usize; 3]) -> usize {
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    /// False when no point lies within the radius of `q`; true when one may.
    fn may_hold(&self, q: Vec3) -> bool {
        if self.marked.is_empty() {
            return false;
        }
        let u = (q - self.min) * self.inv_cell;
        let inside = |v: f32, n: usize| v >= 0.0 && v < n as f32;
        if !(inside(u.x, self.dims[0]) && inside(u.y, self.dims[1]) && inside(u.z, self.dims[2])) {
            return false;
        }
        self.marked[self.flat(self.cell(q))]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::imaging::facing::own_surface_normals;
    use crate::scene::Scene;
    use crate::sensors::{PlanarArray, VirtualAperture};

    fn denials(
        points: &[Vec3],
        mask: &[u64],
        sights: &[PairSight<'_>],
        terrain: &Scene,
        support_m: f32,
    ) -> Vec<u8> {
        tallies(points, mask, &[], sights, terrain, support_m, true)
            .iter()
            .map(|t| t.denied)
            .collect()
    }

    fn open_ground() -> Scene {
        let g = crate::shapes::ground(
            "ground",
            crate::material::Material::Concrete,
            glam::Vec2::splat(-100.0),
            glam::Vec2::splat(100.0),
            0.0,
            (1, 1),
        )
        .expect("ground");
        Scene::new(vec![g]).expect("scene")
    }

    fn sight(rx: Vec3, tx: Vec3, det: Option<&PointIndex>) -> PairSight<'_> {
        PairSight {
            rx,
            boresight: (-rx).with_z(0.0).normalize(),
            tx,
            detections: det,
            ground: None,
            cell: None,
        }
    }

    /// Three pairs around the origin (west, east, north), none with a detection.
    fn around() -> [PairSight<'static>; 3] {
        [
            sight(
                Vec3::new(-50.0, 0.0, 20.0),
                Vec3::new(-10.0, 0.0, 1.5),
                None,
            ),
            sight(Vec3::new(50.0, 0.0, 20.0), Vec3::new(10.0, 0.0, 1.5), None),
            sight(Vec3::new(0.0, 50.0, 20.0), Vec3::new(0.0, 10.0, 1.5), None),
        ]
    }

    /// A UAV's pair over the point (its track 60 m up, its panel 60 m west): it places height
    /// to under a metre there.
    fn uav_cell() -> PairCell {
        PairCell {
            array: PlanarArray {
                centre: Vec3::new(-60.0, 0.0, 20.0),
                boresight_az_rad: 0.0,
                rows: 8,
                cols: 8,
                width_m: 0.12,
                height_m: 0.12,
            },
            aperture: VirtualAperture {
                start: Vec3::new(-10.0, 0.0, 60.0),
                end: Vec3::new(10.0, 0.0, 60.0),
                positions: 101,
            },
            wavelength_m: 0.03,
            bandwidth_hz: 400e6,
            voxel_m: 0.25,
        }
    }

    #[test]
    fn a_detection_the_pair_resolves_from_the_point_does_not_confirm_it() {
        let cell = uav_cell();
        let j = cell.information(Vec3::new(0.0, 0.0, 10.0));
        let vertical = 1.0 / j.z_axis.z.sqrt();
        assert!(
            vertical < 1.0,
            "the UAV pair's vertical cell is {vertical} m"
        );
        // Pair 0 kept a point 2.5 m over a roof; pair 1 (the UAV's) detected the roof under it,
        // within the 3 m support distance, and a roof cell 2 m along the roof from a roof point.
        let p_air = Vec3::new(0.0, 0.0, 12.5);
        let p_roof = Vec3::new(2.0, 0.0, 10.0);
        let roof = [Vec3::new(0.0, 0.0, 10.0)];
        let index = PointIndex::new("roof", &roof).expect("index");
        let points = [p_air, p_roof];
        let mask = [1u64, 1];
        let up = Some(Vec3::Z);
        let tally = |cell: Option<PairCell>, facing: &[Option<Vec3>]| {
            let uav = PairSight {
                rx: cell.as_ref().map_or(Vec3::ZERO, |c| c.array.centre),
                boresight: Vec3::X,
                tx: Vec3::new(0.0, 0.0, 60.0),
                detections: Some(&index),
                ground: None,
                cell,
            };
            tallies(
                &points,
                &mask,
                facing,
                &[
                    sight(Vec3::new(50.0, 0.0, 20.0), Vec3::new(10.0, 0.0, 1.5), None),
                    uav,
                ],
                &open_ground(),
                3.0,
                false,
            )
        };
        // Without the cell, anything within the support distance confirms.
        let loose = tally(None, &[None, None]);
        assert_eq!(loose[0].confirmed, 2);
        // With it, the roof 2.5 m under the point is another place for the UAV's pair; the roof
        // cell along the roof is the same surface, faced or not.
        let resolved = tally(Some(uav_cell()), &[None, up]);
        assert_eq!(resolved[0].confirmed, 1, "{resolved:?}");
        assert_eq!(resolved[1].confirmed, 2, "{resolved:?}");
        let unfaced = tally(Some(uav_cell()), &[None, None]);
        assert_eq!(unfaced[0].confirmed, 1, "{unfaced:?}");
    }

    #[test]
    fn a_cell_the_lattice_leaves_unmarked_holds_no_point_within_the_radius() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut at = |h: f32| {
            Vec3::new(
                rng.random_range(-h..h),
                rng.random_range(-h..h),
                rng.random_range(0.0..h / 4.0),
            )
        };
        let points: Vec<Vec3> = (0..300).map(|_| at(20.0)).collect();
        let queries: Vec<Vec3> = (0..20_000).map(|_| at(24.0)).collect();
        for radius in [0.05, 0.3, 1.7] {
            let near = NearCells::new(&points, radius);
            let (mut skipped, mut within) = (0, 0);
            for &q in &queries {
                let d = points
                    .iter()
                    .map(|&p| p.distance(q))
                    .fold(f32::INFINITY, f32::min);
                if d <= radius {
                    within += 1;
                    assert!(
                        near.may_hold(q),
                        "{q} is {d} m from a point, radius {radius}"
                    );
                }
                skipped += usize::from(!near.may_hold(q));
            }
            // With a small radius the lattice skips most of free space; the check saw points
            // within the radius.
            assert!(
                radius > 1.0 || skipped > queries.len() / 2,
                "radius {radius}: {skipped} skipped"
            );
            assert!(
                within > 0 || radius < 0.1,
                "radius {radius}: no query within it"
            );
        }
        assert!(!NearCells::new(&[], 1.0).may_hold(Vec3::ZERO));
    }

    #[test]
    fn a_wall_seen_only_in_part_still_hides_what_lies_behind_it() {
        // The point was detected by pair 0; pairs 1 and 2 look at it through walls (x = 5 and
        // y = 5) that the cloud holds with 2 m holes, one voxel's points on a 2 m lattice: each
        // leg passes 1.2–1.4 m from the nearest wall points, within the support distance
        // (1.5 m) — the wall's own resolution cells — but through gaps far wider than a voxel.
        let p = Vec3::new(0.0, 0.0, 1.0);
        let mut pts = vec![p];
        for a in (-9..=9).step_by(2) {
            for k in 0..6 {
                let (t, z) = (a as f32, 0.25 + 2.0 * k as f32);
                pts.push(Vec3::new(5.0, t, z));
                pts.push(Vec3::new(t, 5.0, z));
            }
        }
        // The walls were detected by pairs 1 and 2 (so they are nobody's single-pair cluster);
        // pairs 1 and 2 detected nothing near the point.
        let mut mask = vec![0b110u64; pts.len()];
        mask[0] = 1;
        let d = denials(&pts, &mask, &around(), &open_ground(), 1.5);
        assert_eq!(
            d[0], 0,
            "a leg through a gap of a seen wall does not reach the point"
        );
    }

    #[test]
    fn a_pair_behind_a_surface_does_not_deny_it_and_pairs_in_front_still_do() {
        // A wall x = 0 (8 × 6 m on a 0.5 m lattice) that pair 0, in front of it (+x), alone
        // imaged; a cluster of three points in free air 10 m in front of it and 20 m to
        // its side (no leg to it crosses the wall), pair 0's too.
        // Pairs 1 and 2 look at both from behind the wall (−x); a leg to a wall point stops
        // twice the support distance (2 m) short of it, so nothing blocks it. The wall spans more
        // than a cell (4 m) both ways: it has a surface of its own.
        let mut points: Vec<Vec3> = (0..16)
            .flat_map(|i| {
                (0..12).map(move |k| Vec3::new(0.0, 0.5 * i as f32 - 4.0, 0.5 * k as f32))
            })
            .collect();
        let wall = points.len();
        points.extend([
            Vec3::new(10.0, 20.0, 3.0),
            Vec3::new(10.0, 20.5, 3.0),
            Vec3::new(10.0, 20.0, 3.5),
        ]);
        let mask = vec![1u64; points.len()];
        let front = (Vec3::new(50.0, 0.0, 20.0), Vec3::new(20.0, 0.0, 1.5));
        let behind = [
            (Vec3::new(-50.0, 5.0, 20.0), Vec3::new(-10.0, 5.0, 1.5)),
            (Vec3::new(-50.0, -5.0, 20.0), Vec3::new(-10.0, -5.0, 1.5)),
        ];
        let mut sights = vec![sight(front.0, front.1, None)];
        sights.extend(behind.iter().map(|&(rx, tx)| sight(rx, tx, None)));
        let observers = vec![vec![front.1, front.0]; points.len()];
        let facing = own_surface_normals(&points, &observers, 2.0, 0.9, 4.0).unwrap();
        assert!(facing[..wall].iter().all(Option::is_some));
        assert!(facing[wall..].iter().all(Option::is_none));
        let keep = confirmed(
            &points,
            &mask,
            &facing,
            &sights,
            &open_ground(),
            2.0,
            true,
            2,
            None,
        );
        assert!(
            keep[..wall].iter().all(|&k| k),
            "the wall is denied from behind"
        );
        assert!(keep[wall..].iter().all(|&k| !k), "the lone cluster stands");
        // Without the facing every point is denied twice.
        let blind = confirmed(
            &points,
            &mask,
            &[],
            &sights,
            &open_ground(),
            2.0,
            true,
            2,
            None,
        );
        assert!(blind.iter().all(|&k| !k));
        // Two more pairs in front of the wall that detected nothing deny it.
        for (rx, tx) in [
            (Vec3::new(50.0, 30.0, 20.0), Vec3::new(15.0, 10.0, 1.5)),
            (Vec3::new(50.0, -30.0, 20.0), Vec3::new(15.0, -10.0, 1.5)),
        ] {
            sights.push(sight(rx, tx, None));
        }
        let keep = confirmed(
            &points,
            &mask,
            &facing,
            &sights,
            &open_ground(),
            2.0,
            true,
            2,
            None,
        );
        assert!(keep.iter().all(|&k| !k), "pairs in front of a wall deny it");
    }

    #[test]
    fn a_pair_does_not_confirm_what_lies_behind_a_surface_on_its_own_legs() {
        // A wall x = 5 (12 × 8 m, 0.5 m lattice) that the east pair imaged, and that pair's
        // detections at q behind the wall (x = 0) and at r on the wall. Its legs to q cross the
        // wall: it cannot have imaged q, so q has no confirmation and is dropped; r stands.
        let (q, r) = (Vec3::new(0.0, 0.0, 3.0), Vec3::new(5.0, 0.0, 3.0));
        let mut points = vec![q];
        points.extend((0..24).flat_map(|i| {
            (0..16).map(move |k| Vec3::new(5.0, 0.5 * i as f32 - 6.0, 0.5 * k as f32))
        }));
        let east = (Vec3::new(50.0, 5.0, 20.0), Vec3::new(15.0, 5.0, 1.5));
        let sights = [sight(east.0, east.1, None)];
        let mask = vec![1u64; points.len()];
        let observers = vec![vec![east.1, east.0]; points.len()];
        let facing = own_surface_normals(&points, &observers, 2.0, 0.9, 4.0).unwrap();
        let t = tallies(&points, &mask, &facing, &sights, &open_ground(), 2.0, true);
        assert_eq!(t[0].confirmed, 0, "the wall stands between the pair and q");
        let on_wall = points.iter().position(|&p| p == r).unwrap();
        assert_eq!(t[on_wall].confirmed, 1, "r is on the wall the pair sees");
        let keep = confirmed(
            &points,
            &mask,
            &facing,
            &sights,
            &open_ground(),
            2.0,
            true,
            2,
            None,
        );
        assert!(!keep[0] && keep[on_wall]);
    }

    #[test]
    fn a_leg_over_a_walls_top_edge_to_the_roof_behind_it_is_not_blocked() {
        // A wall x = 5 from z = 0 to 8 m (y in −6..6) and the roof behind it at z = 8 (x in
        // −7..5), imaged; a panel at (60, 0, 9) views a roof point 6 m behind the eave: its leg
        // passes 0.1 m over the wall's top edge, within the support distance of the wall, without
        // piercing it. The same panel's leg to a point inside, under the roof, pierces the wall.
        let mut points: Vec<Vec3> = (0..24)
            .flat_map(|i| {
                (0..17).map(move |k| Vec3::new(5.0, 0.5 * i as f32 - 6.0, 0.5 * k as f32))
            })
            .collect();
        points.extend((0..24).flat_map(|i| {
            (1..25).map(move |k| Vec3::new(5.0 - 0.5 * k as f32, 0.5 * i as f32 - 6.0, 8.0))
        }));
        let (roof_point, inside) = (Vec3::new(-1.0, 0.0, 8.0), Vec3::new(-1.0, 0.0, 3.0));
        points.push(inside);
        // The pair's other end is a UAV over the roof.
        let pair = (Vec3::new(60.0, 0.0, 9.0), Vec3::new(0.0, -6.0, 40.0));
        let sights = [sight(pair.0, pair.1, None)];
        let mask = vec![1u64; points.len()];
        let observers = vec![vec![pair.1, pair.0]; points.len()];
        let facing = own_surface_normals(&points, &observers, 2.0, 0.9, 4.0).unwrap();
        let t = tallies(&points, &mask, &facing, &sights, &open_ground(), 2.0, true);
        let at = |q: Vec3| points.iter().position(|&p| p.distance(q) < 1e-3).unwrap();
        assert_eq!(t[at(roof_point)].confirmed, 1, "over the eave");
        assert_eq!(t[at(inside)].confirmed, 0, "through the wall");
    }

    #[test]
    fn a_grazing_leg_over_a_roof_does_not_hide_the_roof_from_its_own_pair() {
        // A flat roof z = 8 (12 × 12 m, 0.5 m lattice) seen from a panel 60 m away at 20 m
        // (a 11° grazing leg) and a UAV above: every roof point keeps its confirmation.
        let points: Vec<Vec3> = (0..24)
            .flat_map(|i| {
                (0..24).map(move |j| Vec3::new(0.5 * i as f32 - 6.0, 0.5 * j as f32 - 6.0, 8.0))
            })
            .collect();
        let pair = (Vec3::new(60.0, 0.0, 20.0), Vec3::new(0.0, -6.0, 40.0));
        let sights = [sight(pair.0, pair.1, None)];
        let mask = vec![1u64; points.len()];
        let observers = vec![vec![pair.1, pair.0]; points.len()];
        let facing = own_surface_normals(&points, &observers, 2.0, 0.9, 4.0).unwrap();
        assert!(facing.iter().all(Option::is_some));
        let t = tallies(&points, &mask, &facing, &sights, &open_ground(), 2.0, true);
        assert!(t.iter().all(|t| t.confirmed == 1));
    }

    #[test]
    fn a_wall_one_pair_imaged_hides_what_lies_behind_it_and_a_blob_does_not() {
        // q (pair 0's, west of x = 5) lies behind a wall x = 5 (12 × 8 m, 0.5 m lattice) that
        // pair 3 alone imaged; pairs 1 and 2 look at q from the east, their legs through the
        // wall. Support distance 2 m: the wall is a patch of more than a cell (4 m) both ways.
        let q = Vec3::new(0.0, 0.0, 3.0);
        let mut points = vec![q];
        points.extend((0..24).flat_map(|i| {
            (0..16).map(move |k| Vec3::new(5.0, 0.5 * i as f32 - 6.0, 0.5 * k as f32))
        }));
        let mut mask = vec![1u64 << 3; points.len()];
        mask[0] = 1;
        let west = (Vec3::new(-50.0, 0.0, 20.0), Vec3::new(-10.0, 0.0, 1.5));
        let wall_pair = (Vec3::new(50.0, 20.0, 20.0), Vec3::new(15.0, 10.0, 1.5));
        let sights = [
            sight(west.0, west.1, None),
            sight(Vec3::new(50.0, 5.0, 20.0), Vec3::new(15.0, 5.0, 1.5), None),
            sight(
                Vec3::new(50.0, -5.0, 20.0),
                Vec3::new(15.0, -5.0, 1.5),
                None,
            ),
            sight(wall_pair.0, wall_pair.1, None),
        ];
        let mut observers = vec![vec![wall_pair.1, wall_pair.0]; points.len()];
        observers[0] = vec![west.1, west.0];
        let facing = own_surface_normals(&points, &observers, 2.0, 0.9, 4.0).unwrap();
        assert!(facing[0].is_none() && facing[1..].iter().all(Option::is_some));
        let with = tallies(&points, &mask, &facing, &sights, &open_ground(), 2.0, true);
        assert_eq!(
            with[0].denied, 0,
            "legs through a wall one pair imaged reach q"
        );
        // Without the facing the wall is one pair's points, which block nothing.
        let without = tallies(&points, &mask, &[], &sights, &open_ground(), 2.0, true);
        assert_eq!(without[0].denied, 3);
        // A blob of one cell where the wall was (a 3 × 3 × 3 block of lattice points) has no
        // surface of its own and hides nothing.
        let mut blob = vec![q];
        blob.extend((0..27).map(|i| {
            let (a, b, c) = ((i % 3) as f32, ((i / 3) % 3) as f32, (i / 9) as f32);
            Vec3::new(5.0 + 0.5 * a, -0.5 + 0.5 * b, 3.0 + 0.5 * c)
        }));
        let blob_mask = [vec![1u64], vec![1u64 << 3; 27]].concat();
        let blob_facing =
            own_surface_normals(&blob, &observers[..blob.len()], 2.0, 0.9, 4.0).unwrap();
        assert!(blob_facing.iter().all(Option::is_none));
        let t = tallies(
            &blob,
            &blob_mask,
            &blob_facing,
            &sights,
            &open_ground(),
            2.0,
            true,
        );
        assert_eq!(t[0].denied, 3);
    }

    #[test]
    fn a_point_that_two_seeing_pairs_did_not_detect_is_denied_twice() {
        let p = Vec3::new(0.0, 0.0, 1.0);
        let sights = around();
        // Pair 0 detected it; pairs 1 and 2 see the place and detected nothing.
        let d = denials(&[p], &[1], &sights, &open_ground(), 1.5);
        assert_eq!(d, vec![2]);
    }

    #[test]
    fn each_confirmation_outweighs_need_denials_and_no_more() {
        let p = Vec3::new(0.0, 0.0, 1.0);
        let sights = around();
        // Pairs 0 and 1 kept it; pair 2 sees the place and detected nothing.
        let t = tallies(&[p], &[0b11], &[], &sights, &open_ground(), 1.5, true);
        assert_eq!(
            t,
            vec![Tally {
                confirmed: 2,
                denied: 1
            }]
        );
        assert_eq!(
            confirmed(
                &[p],
                &[0b11],
                &[],
                &sights,
                &open_ground(),
                1.5,
                true,
                2,
                None
            ),
            vec![true]
        );
        // Six pairs around it: two kept it, the other four see it and detected nothing — as
        // unlikely for a surface as two denials of one pair's point.
        let ring: Vec<(Vec3, Vec3)> = (0..6)
            .map(|i| {
                let a = i as f32 * std::f32::consts::FRAC_PI_3;
                let u = Vec3::new(a.cos(), a.sin(), 0.0);
                (u * 50.0 + Vec3::Z * 20.0, u * 10.0 + Vec3::Z * 1.5)
            })
            .collect();
        let six: Vec<PairSight<'_>> = ring.iter().map(|&(rx, tx)| sight(rx, tx, None)).collect();
        let keep = confirmed(&[p], &[0b11], &[], &six, &open_ground(), 1.5, true, 2, None);
        assert_eq!(keep, vec![false]);
        // Three deniers (the sixth pair kept it too): kept.
        let keep = confirmed(
            &[p],
            &[0b100011],
            &[],
            &six,
            &open_ground(),
            1.5,
            true,
            2,
            None,
        );
        assert_eq!(keep, vec![true]);
        let keep = confirmed(
            &[p],
            &[0b111],
            &[],
            &six,
            &open_ground(),
            1.5,
            true,
            2,
            None,
        );
        assert_eq!(keep, vec![true]);
        // The decision that stops tracing legs once the point's fate is known is the full
        // count's, for every set of keepers and every need.
        let masks: Vec<u64> = (1..64).collect();
        let points = vec![p; masks.len()];
        let full = tallies(&points, &masks, &[], &six, &open_ground(), 1.5, true);
        for need in 1..=4 {
            let quick = confirmed(
                &points,
                &masks,
                &[],
                &six,
                &open_ground(),
                1.5,
                true,
                need,
                None,
            );
            let want: Vec<bool> = full.iter().map(|&t| kept(t, need)).collect();
            assert_eq!(quick, want, "need {need}");
        }
    }

    #[test]
    fn a_pair_whose_detection_there_is_its_own_ground_echo_neither_confirms_nor_denies() {
        let p = Vec3::new(0.0, 0.0, 1.0);
        let echo = PointIndex::new("ground echo", &[p + Vec3::new(0.5, 0.0, -0.5)]).unwrap();
        let mut sights = around();
        // Pair 0 kept it; pair 1 detected something there that is its terrain's echo; pair 2
        // sees it and detected nothing: one denial against one confirmation keeps it.
        sights[1].ground = Some(&echo);
        let t = tallies(&[p], &[1], &[], &sights, &open_ground(), 1.5, true);
        assert_eq!(
            t,
            vec![Tally {
                confirmed: 1,
                denied: 1
            }]
        );
        // The same detection counted as pair 1's own would confirm it.
        sights[1].ground = None;
        sights[1].detections = Some(&echo);
        let t = tallies(&[p], &[1], &[], &sights, &open_ground(), 1.5, true);
        assert_eq!(t[0].confirmed, 2);
        // Nothing of pair 1 there: it denies, and with pair 2 the point is dropped.
        sights[1].detections = None;
        assert_eq!(
            confirmed(&[p], &[1], &[], &sights, &open_ground(), 1.5, true, 2, None),
            vec![false]
        );
    }

    #[test]
    fn a_pair_that_detected_something_nearby_confirms_and_a_pair_behind_its_panel_does_not_deny() {
        let p = Vec3::new(0.0, 0.0, 1.0);
        let near = PointIndex::new("near", &[p + Vec3::new(0.0, 0.0, 1.0)]).unwrap();
        let far = PointIndex::new("far", &[p + Vec3::new(5.0, 0.0, 0.0)]).unwrap();
        let mut behind = sight(
            Vec3::new(0.0, -50.0, 20.0),
            Vec3::new(0.0, -10.0, 1.5),
            None,
        );
        behind.boresight = Vec3::NEG_Y; // facing away from p
        let sights = [
            sight(
                Vec3::new(-50.0, 0.0, 20.0),
                Vec3::new(-10.0, 0.0, 1.5),
                None,
            ),
            sight(
                Vec3::new(50.0, 0.0, 20.0),
                Vec3::new(10.0, 0.0, 1.5),
                Some(&near),
            ),
            behind,
            sight(
                Vec3::new(0.0, 50.0, 20.0),
                Vec3::new(0.0, 10.0, 1.5),
                Some(&far),
            ),
        ];
        // Pair 1 confirms (1 m away): the point is not pair 0's alone; pair 3 denies (its point
        // is 5 m off), pair 2 cannot see it; one denial against two confirmations keeps it.
        let t = tallies(&[p], &[1], &[], &sights, &open_ground(), 1.5, true);
        assert_eq!(
            t,
            vec![Tally {
                confirmed: 2,
                denied: 1
            }]
        );
        assert_eq!(
            confirmed(&[p], &[1], &[], &sights, &open_ground(), 1.5, true, 2, None),
            vec![true]
        );
        // Without pair 1's detection: pair 1 denies, pair 2 cannot see it, pair 3 denies (its
        // point is 5 m off).
        let mut sights = sights;
        sights[1].detections = None;
        let d = denials(&[p], &[1], &sights, &open_ground(), 1.5);
        assert_eq!(d, vec![2]);
    }

    #[test]
    fn a_single_pair_cluster_wider_than_the_support_does_not_hide_itself() {
        // A 4 m × 4 m blob of one pair's detections (a false-alarm patch) on open ground: each of
        // its points lies behind others from the pairs at ±x, and is still denied by both.
        let mut pts = Vec::new();
        for i in 0..8 {
            for j in 0..8 {
                pts.push(Vec3::new(i as f32 * 0.5 - 2.0, j as f32 * 0.5 - 2.0, 1.0));
            }
        }
        let mask = vec![1u64; pts.len()];
        let sights = around();
        let d = denials(&pts, &mask, &sights, &open_ground(), 1.5);
        assert!(d.iter().all(|&n| n == 2), "{d:?}");
    }

    #[test]
    fn one_pairs_false_alarm_hides_nothing() {
        // Two of pair 0's false alarms on open ground: q sits on the leg from pair 1's
        // aperture to p. q is one pair's point, not a surface: pair 1 sees p through it.
        let p = Vec3::new(0.0, 0.0, 1.0);
        let q = Vec3::new(5.0, 0.0, 1.25);
        let sights = around();
        let d = denials(&[p, q], &[1, 1], &sights, &open_ground(), 1.5);
        assert_eq!(d, vec![2, 2]);
        let keep = confirmed(
            &[p, q],
            &[1, 1],
            &[],
            &sights,
            &open_ground(),
            1.5,
            true,
            2,
            None,
        );
        assert_eq!(keep, vec![false, false]);
        // p as a surface point (three pairs kept it) stays; q is still denied by pairs 1 and 2
        // (pair 0, whose legs p would block, kept q).
        let keep = confirmed(
            &[p, q],
            &[7, 1],
            &[],
            &sights,
            &open_ground(),
            1.5,
            true,
            2,
            None,
        );
        assert_eq!(keep, vec![true, false]);
        // Nothing is dropped when no denial is needed to keep a point.
        let keep = confirmed(
            &[p, q],
            &[1, 1],
            &[],
            &sights,
            &open_ground(),
            1.5,
            true,
            0,
            None,
        );
        assert_eq!(keep, vec![true, true]);
    }

    #[test]
    fn a_point_hidden_behind_detected_surface_is_not_denied() {
        let p = Vec3::new(0.0, 0.0, 1.0);
        // A detected wall at x = 5 m between p and the pair at +x.
        let mut pts = vec![p];
        for y in -10..=10 {
            for z in 0..=10 {
                pts.push(Vec3::new(5.0, y as f32 * 0.5, z as f32 * 0.5));
            }
        }
        // The wall was kept by pairs 1 and 2 (pair 2 is not among the sights below).
        let mut mask = vec![0b110u64; pts.len()];
        mask[0] = 1;
        let sights = around();
        let d = denials(&pts, &mask, &sights[..2], &open_ground(), 1.5);
        assert_eq!(d[0], 0, "the wall hides p from pair 1");
        // The same wall as one pair's points (pair 1 alone) is no surface: it hides nothing.
        let mut mask = vec![0b10u64; pts.len()];
        mask[0] = 1;
        let d = denials(&pts, &mask, &sights[..2], &open_ground(), 1.5);
        assert_eq!(d[0], 1, "one pair's points hide p from pair 1");
    }
}
