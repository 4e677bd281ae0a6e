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
//! **The test.** Pair `j` *sees* a fused point `p` when `p` lies in front of its panel
//! (`(p − rx)·n̂ > 0`, the array's half-space), and both legs — from the panel's centre and
//! from the aperture's centre to `p` — reach `p` through the known terrain (its scene) and
//! through the fused cloud itself: the segment, up to twice the support distance short of `p`,
//! passes within the support distance of no fused point — each stands for its resolution
//! cell's patch of surface, so a wall the cloud holds with holes (a pair saw it in part) still
//! stands between a pair and what lies behind it (the detected surfaces are the only buildings
//! the operator knows; on a courtyard block, legs through the gaps of the wings' shells made
//! 877 of the 923 points the test removed look seen, all on the yard's walls). The point's own
//! single-pair cluster — the voxels the same one pair kept, connected to it — does not count,
//! since it is what the test questions, and a false-alarm patch wider than the support distance
//! would otherwise hide itself from every pair. Pair `j`
//! *confirms* `p` when it detected a point within the support distance of `p` (half the
//! coarsest resolution cell of the pairs, [`super::run::support_distance_m`]: the surface that
//! gave `p` lies within it). A pair that sees `p` and does not confirm it *denies* it. A point
//! is dropped when `denials` or more pairs deny it and none of those that detected it is among
//! them (pairs that kept the fused voxel never deny it). [`confirmed`] repeats the test on the
//! points kept until nothing more is dropped: a dropped point no longer blocks a leg.
//!
//! **Why two.** A seeing pair misses a true surface cell often — grazing incidence, its weaker
//! legs, the detection's own miss rate: on the suite's quick clouds a third to a half of the
//! points a pair sees (by the legs above) were not confirmed by it. One denial is then weak
//! evidence; two independent misses of a true cell are several times rarer, while a false alarm
//! is denied by every pair that sees it. Measured (quick suite, docs/results.md): 5–38 points
//! removed per site (≤ 0.5 % of a cloud), cloud √CD down by up to 0.4 m, F unchanged or up.
//!
//! Units: metres; points in the world frame.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use crate::knn::PointIndex;
use crate::scene::Scene;

/// What a pair looks from: its panel's centre and boresight, its aperture's centre, and its own
/// detections (`None`: it detected nothing).
pub struct PairSight<'a> {
    /// Panel (receive array) centre, metres.
    pub rx: Vec3,
    /// Panel boresight (unit).
    pub boresight: Vec3,
    /// Aperture (transmit track) centre, metres.
    pub tx: Vec3,
    /// The pair's detected points.
    pub detections: Option<&'a PointIndex>,
}

/// The number of pairs that deny each point (module docs). `mask[i]` has bit `k` set when pair
/// `k` kept point `i` (such pairs never deny it); `voxel_m` is the fused lattice's edge,
/// `support_m` the confirmation radius and the point's own extent along a leg.
pub fn denials(
    points: &[Vec3],
    mask: &[u64],
    sights: &[PairSight<'_>],
    terrain: &Scene,
    voxel_m: f32,
    support_m: f32,
) -> Vec<u8> {
    let key = |p: Vec3| {
        let q = (p / voxel_m).round();
        [q.x as i64, q.y as i64, q.z as i64]
    };
    // Single-pair clusters: the 26-connected voxels kept by the same one pair. Such a cluster
    // is what the test questions, so it does not hide its own points (a false-alarm cluster
    // wider than the support distance would otherwise shield itself from every pair).
    let index: HashMap<[i64; 3], usize> = points
        .iter()
        .enumerate()
        .map(|(i, &p)| (key(p), i))
        .collect();
    let single = |i: usize| mask[i].count_ones() == 1;
    let mut cluster: Vec<usize> = (0..points.len()).collect();
    fn root(c: &mut [usize], mut i: usize) -> usize {
        while c[i] != i {
            c[i] = c[c[i]];
            i = c[i];
        }
        i
    }
    for (i, &p) in points.iter().enumerate() {
        if !single(i) {
            continue;
        }
        let [x, y, z] = key(p);
        for n in neighbours([x, y, z]) {
            if let Some(&j) = index.get(&n) {
                if single(j) && mask[j] == mask[i] {
                    let (a, b) = (root(&mut cluster, i), root(&mut cluster, j));
                    cluster[a.max(b)] = a.min(b);
                }
            }
        }
    }
    let cluster: Vec<usize> = (0..points.len()).map(|i| root(&mut cluster, i)).collect();
    // A fused point stands for the surface patch of its resolution cell (the support distance
    // around it), and the cloud samples a surface with gaps: a wall a pair sees only in part
    // still stands between another pair and what lies behind it. So a leg is blocked where it
    // passes within the support distance of a fused point of another cluster; it is sampled
    // every half support distance (a point within ~0.97 of it from the line is found), from the
    // sensor to twice the support distance short of `p` — nearer than that, the leg meets
    // `p`'s own surface (whose points lie within the support distance of a leg that arrives
    // at more than 30° to it; a grazing pair's silence says little anyway).
    let all = match PointIndex::new("points", points) {
        Ok(ix) => ix,
        // No finite points: nothing to block, nothing to deny.
        Err(_) => return vec![0; points.len()],
    };
    let step = 0.5 * support_m;
    let reaches = |s: Vec3, i: usize| -> bool {
        let p = points[i];
        let d = p - s;
        let len = d.length();
        if len.is_nan() || len <= 2.0 * support_m {
            return terrain.visible(s, p);
        }
        let dir = d / len;
        let own = single(i).then_some(cluster[i]);
        let n = ((len - 2.0 * support_m) / step).floor() as usize;
        let r2 = support_m * support_m;
        let blocked = (0..=n).any(|k| {
            let q = s + dir * (k as f32 * step);
            match own {
                // Any fused point blocks: the nearest one decides, no list gathered.
                None => all.nearest(q).1 <= r2,
                Some(c) => all
                    .within(q, support_m)
                    .iter()
                    .any(|&(j, _)| !(single(j as usize) && cluster[j as usize] == c)),
            }
        });
        !blocked && terrain.visible(s, p)
    };
    let r2 = support_m * support_m;
    (0..points.len())
        .into_par_iter()
        .map(|i| {
            let (p, m) = (points[i], mask[i]);
            let mut n = 0u8;
            for (k, s) in sights.iter().enumerate() {
                // A pair past the 64 recorded in the mask may have kept the point: it never
                // denies.
                if k >= 64 || (m >> k) & 1 == 1 {
                    continue;
                }
                if (p - s.rx).dot(s.boresight) <= 0.0 {
                    continue;
                }
                let confirmed = s.detections.is_some_and(|d| d.nearest(p).1 <= r2);
                if confirmed || !reaches(s.rx, i) || !reaches(s.tx, i) {
                    continue;
                }
                n = n.saturating_add(1);
            }
            n
        })
        .collect()
}

/// Which points survive the confirmation: [`denials`] in rounds, each on the points the
/// previous rounds kept, until a round drops nothing; a point goes when `need` or more pairs
/// deny it. A dropped point is a false alarm, not a surface, so it no longer blocks the legs
/// it crossed: the points behind it are tested again (each round drops at least one point, so
/// this ends).
pub fn confirmed(
    points: &[Vec3],
    mask: &[u64],
    sights: &[PairSight<'_>],
    terrain: &Scene,
    voxel_m: f32,
    support_m: f32,
    need: u8,
) -> Vec<bool> {
    let mut alive: Vec<usize> = (0..points.len()).collect();
    loop {
        let p: Vec<Vec3> = alive.iter().map(|&i| points[i]).collect();
        let m: Vec<u64> = alive.iter().map(|&i| mask[i]).collect();
        let d = denials(&p, &m, sights, terrain, voxel_m, support_m);
        let before = alive.len();
        alive = alive
            .iter()
            .zip(&d)
            .filter(|(_, &n)| n < need)
            .map(|(&i, _)| i)
            .collect();
        if alive.len() == before {
            break;
        }
    }
    let mut keep = vec![false; points.len()];
    for i in alive {
        keep[i] = true;
    }
    keep
}

/// The voxel keys of `k` and its 26 neighbours.
fn neighbours(k: [i64; 3]) -> impl Iterator<Item = [i64; 3]> {
    (-1..=1).flat_map(move |dz| {
        (-1..=1).flat_map(move |dy| (-1..=1).map(move |dx| [k[0] + dx, k[1] + dy, k[2] + dz]))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

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
        let d = denials(&pts, &mask, &around(), &open_ground(), 0.5, 1.5);
        assert_eq!(
            d[0], 0,
            "a leg through a gap of a seen wall does not reach the point"
        );
    }

    #[test]
    fn a_point_that_two_seeing_pairs_did_not_detect_is_denied_twice() {
        let p = Vec3::new(0.0, 0.0, 1.0);
        let sights = around();
        // Pair 0 detected it; pairs 1 and 2 see the place and detected nothing.
        let d = denials(&[p], &[1], &sights, &open_ground(), 0.5, 1.5);
        assert_eq!(d, vec![2]);
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
        let d = denials(&[p], &[1], &sights, &open_ground(), 0.5, 1.5);
        // Pair 1 confirms (1 m away), pair 2 cannot see it, pair 3 denies (its point is 5 m off).
        assert_eq!(d, vec![1]);
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
        let d = denials(&pts, &mask, &sights, &open_ground(), 0.5, 1.5);
        assert!(d.iter().all(|&n| n == 2), "{d:?}");
    }

    #[test]
    fn a_false_alarm_that_hid_another_from_a_pair_hides_nothing_once_dropped() {
        // Two of pair 0's false alarms on open ground: q sits on the leg from pair 1's
        // aperture to p. In the first round q is denied by pairs 1 and 2 and p by pair 2 alone;
        // without q, pair 1 sees p too.
        let p = Vec3::new(0.0, 0.0, 1.0);
        let q = Vec3::new(5.0, 0.0, 1.25);
        let sights = around();
        let once = denials(&[p, q], &[1, 1], &sights, &open_ground(), 0.5, 1.5);
        assert_eq!(once, vec![1, 2]);
        let keep = confirmed(&[p, q], &[1, 1], &sights, &open_ground(), 0.5, 1.5, 2);
        assert_eq!(keep, vec![false, false]);
        // A surface point that three pairs detected stays whatever the rounds do.
        let keep = confirmed(&[p, q], &[7, 1], &sights, &open_ground(), 0.5, 1.5, 2);
        assert_eq!(keep, vec![true, false]);
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
        let mut mask = vec![2u64; pts.len()];
        mask[0] = 1;
        let sights = around();
        let d = denials(&pts, &mask, &sights[..2], &open_ground(), 0.5, 1.5);
        assert_eq!(d[0], 0, "the wall hides p from pair 1");
    }
}
