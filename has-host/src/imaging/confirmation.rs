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
//! **The test.** Pair `j` *confirms* a fused point `p` when it detected a point within the
//! support distance of `p` (half the coarsest resolution cell of the pairs,
//! [`super::run::support_distance_m`]: the surface that gave `p` lies within it). A point that
//! two pairs kept, or that a pair other than the one that kept it confirms, is a *surface
//! point*: not one pair's false alarm, never questioned. Only the other points — one pair's
//! alone — are. Pair `j` *sees* such a point `p` when `p` lies in front of its panel
//! (`(p − rx)·n̂ > 0`, the array's half-space), and both legs — from the panel's centre and
//! from the aperture's centre to `p` — reach `p` through the known terrain (its scene) and past
//! the surface points: the segment, up to twice the support distance short of `p`, passes
//! within the support distance of none — each stands for its resolution cell's patch of
//! surface, so a wall the cloud holds with holes (a pair saw it in part) still stands between a
//! pair and what lies behind it (the detected surfaces are the only buildings the operator
//! knows; on a courtyard block, legs through the gaps of the wings' shells made 877 of the 923
//! points an earlier test removed look seen, all on the yard's walls). One pair's points block
//! no leg: they are what the test questions, a false-alarm patch would otherwise hide itself,
//! and a vehicle's legs run low over open ground past other pairs' false alarms. A pair that
//! sees `p` and did not detect it *denies* it; `p` is dropped when `denials` or more pairs deny
//! it. Since surface points are never dropped and one pair's points block nothing, one pass
//! decides every point.
//!
//! **Why two.** A seeing pair misses a true surface cell often — grazing incidence, its weaker
//! legs, the detection's own miss rate: on the suite's quick clouds a third to a half of the
//! points a pair sees (by the legs above) were not confirmed by it. One denial is then weak
//! evidence; two independent misses of a true cell are several times rarer, while a false alarm
//! is denied by every pair that sees it.
//!
//! **Why a confirmation outweighs any number of denials.** With `n` pairs that see a true
//! cell, each misses it with probability `1 − q` (a third to a half, above), so a surface
//! collects about `n·(1 − q)` denials: with every base station imaging every terminal (24 pairs
//! on the suite's sites) a count of denials alone dropped true surface, and each dropped point
//! opened legs for more denials — on the factory site, in rounds, the whole cloud. A false
//! alarm is one pair's: another pair detects within the support distance of it only by its own
//! false alarm there (at the stated rate, ≤ 10⁻⁴ per cell). One confirmation therefore makes a
//! false alarm far less likely than a surface, whatever the denials; the denials decide only
//! between a lone pair's point and a surface nobody else detected.
//!
//! Units: metres; points in the world frame.

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
/// `k` kept point `i` (such pairs never deny it); `support_m` is the confirmation radius and
/// the point's own extent along a leg.
pub fn denials(
    points: &[Vec3],
    mask: &[u64],
    sights: &[PairSight<'_>],
    terrain: &Scene,
    support_m: f32,
) -> Vec<u8> {
    let r2 = support_m * support_m;
    let kept_by = |m: u64, k: usize| k >= 64 || (m >> k) & 1 == 1;
    // A point a second pair kept or confirms is not one pair's false alarm: never denied, and
    // the only kind of point that stands for a surface between a pair and another point.
    let surface: Vec<bool> = points
        .par_iter()
        .zip(mask)
        .map(|(&p, &m)| {
            m.count_ones() > 1
                || sights.iter().enumerate().any(|(k, s)| {
                    !kept_by(m, k) && s.detections.is_some_and(|d| d.nearest(p).1 <= r2)
                })
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
    // it; a grazing pair's silence says little anyway). One pair's points — what the test
    // questions — block nothing: a false-alarm patch would otherwise hide itself, and on open
    // ground a vehicle's legs run low past other pairs' false alarms.
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
        let blocked = walls
            .as_ref()
            .is_some_and(|w| (0..=n).any(|k| w.nearest(s + dir * (k as f32 * step)).1 <= r2));
        !blocked && terrain.visible(s, p)
    };
    (0..points.len())
        .into_par_iter()
        .map(|i| {
            let (p, m) = (points[i], mask[i]);
            if surface[i] {
                return 0;
            }
            let mut n = 0u8;
            for (k, s) in sights.iter().enumerate() {
                // A pair past the 64 recorded in the mask may have kept the point: it never
                // denies.
                if kept_by(m, k) || (p - s.rx).dot(s.boresight) <= 0.0 {
                    continue;
                }
                if reaches(s.rx, p) && reaches(s.tx, p) {
                    n = n.saturating_add(1);
                }
            }
            n
        })
        .collect()
}

/// Which points survive the confirmation: those that fewer than `need` pairs deny
/// ([`denials`]; `need` = 0 keeps every point).
pub fn confirmed(
    points: &[Vec3],
    mask: &[u64],
    sights: &[PairSight<'_>],
    terrain: &Scene,
    support_m: f32,
    need: u8,
) -> Vec<bool> {
    if need == 0 {
        return vec![true; points.len()];
    }
    denials(points, mask, sights, terrain, support_m)
        .into_iter()
        .map(|n| n < need)
        .collect()
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
        let d = denials(&pts, &mask, &around(), &open_ground(), 1.5);
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
        let d = denials(&[p], &[1], &sights, &open_ground(), 1.5);
        assert_eq!(d, vec![2]);
    }

    #[test]
    fn a_point_two_pairs_kept_is_never_denied() {
        let p = Vec3::new(0.0, 0.0, 1.0);
        let sights = around();
        // Pairs 0 and 1 kept it; pair 2 sees the place and detected nothing.
        let d = denials(&[p], &[0b11], &sights, &open_ground(), 1.5);
        assert_eq!(d, vec![0]);
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
        // Pair 1 confirms (1 m away): the point is not pair 0's alone, pair 3's miss
        // notwithstanding.
        let d = denials(&[p], &[1], &sights, &open_ground(), 1.5);
        assert_eq!(d, vec![0]);
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
        let keep = confirmed(&[p, q], &[1, 1], &sights, &open_ground(), 1.5, 2);
        assert_eq!(keep, vec![false, false]);
        // p as a surface point (three pairs kept it) stays; q is still denied by pairs 1 and 2
        // (pair 0, whose legs p would block, kept q).
        let keep = confirmed(&[p, q], &[7, 1], &sights, &open_ground(), 1.5, 2);
        assert_eq!(keep, vec![true, false]);
        // Nothing is dropped when no denial is needed to keep a point.
        let keep = confirmed(&[p, q], &[1, 1], &sights, &open_ground(), 1.5, 0);
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
