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
//! through the fused cloud itself (no fused voxel on the segment outside `p`'s own support
//! distance: the detected surfaces are the only buildings the operator knows). Pair `j`
//! *confirms* `p` when it detected a point within the support distance of `p` (half the
//! coarsest resolution cell of the pairs, [`super::run::support_distance_m`]: the surface that
//! gave `p` lies within it). A pair that sees `p` and does not confirm it *denies* it. A point
//! is dropped when `denials` or more pairs deny it and none of those that detected it is among
//! them (pairs that kept the fused voxel never deny it).
//!
//! **Why two.** A seeing pair misses a true surface cell often — grazing incidence, its weaker
//! legs, the detection's own miss rate: on the suite's quick clouds a third to a half of the
//! points a pair sees (by the legs above) were not confirmed by it. One denial is then weak
//! evidence; two independent misses of a true cell are several times rarer, while a false alarm
//! is denied by every pair that sees it. Measured (quick suite, docs/results.md): 3–30 points
//! removed per site (≤ 0.4 % of a cloud), cloud √CD down by up to 0.4 m, F unchanged or up.
//!
//! Units: metres; points in the world frame.

use std::collections::HashSet;

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
    // The cloud samples a surface with gaps: a fused voxel within one voxel of the leg is a
    // surface on it, so the occupied set is the cloud's voxels dilated by one (3 × 3 × 3).
    let mut occupied: HashSet<[i64; 3]> = HashSet::with_capacity(points.len() * 4);
    for &p in points {
        let [x, y, z] = key(p);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    occupied.insert([x + dx, y + dy, z + dz]);
                }
            }
        }
    }
    // A leg from `s` reaches `p` unless a fused voxel lies on it short of `p`'s support, or the
    // terrain cuts it.
    let reaches = |s: Vec3, p: Vec3| -> bool {
        let d = p - s;
        let len = d.length();
        if len.is_nan() || len <= support_m {
            return true;
        }
        let dir = d / len;
        // One sample per voxel: the dilated set is three voxels wide, so no sample skips it.
        let n = ((len - support_m) / voxel_m).floor() as usize;
        if (0..=n).any(|i| occupied.contains(&key(s + dir * (i as f32 * voxel_m)))) {
            return false;
        }
        terrain.visible(s, p)
    };
    let r2 = support_m * support_m;
    points
        .par_iter()
        .zip(mask)
        .map(|(&p, &m)| {
            let mut n = 0u8;
            for (k, s) in sights.iter().enumerate() {
                if k < 64 && (m >> k) & 1 == 1 {
                    continue;
                }
                if (p - s.rx).dot(s.boresight) <= 0.0 {
                    continue;
                }
                let confirmed = s.detections.is_some_and(|d| d.nearest(p).1 <= r2);
                if confirmed || !reaches(s.rx, p) || !reaches(s.tx, p) {
                    continue;
                }
                n = n.saturating_add(1);
            }
            n
        })
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

    #[test]
    fn a_point_that_two_seeing_pairs_did_not_detect_is_denied_twice() {
        let p = Vec3::new(0.0, 0.0, 1.0);
        let sights = [
            sight(
                Vec3::new(-50.0, 0.0, 20.0),
                Vec3::new(-10.0, 0.0, 1.5),
                None,
            ),
            sight(Vec3::new(50.0, 0.0, 20.0), Vec3::new(10.0, 0.0, 1.5), None),
            sight(Vec3::new(0.0, 50.0, 20.0), Vec3::new(0.0, 10.0, 1.5), None),
        ];
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
        let sights = [
            sight(
                Vec3::new(-50.0, 0.0, 20.0),
                Vec3::new(-10.0, 0.0, 1.5),
                None,
            ),
            sight(Vec3::new(50.0, 0.0, 20.0), Vec3::new(10.0, 0.0, 1.5), None),
        ];
        let d = denials(&pts, &mask, &sights, &open_ground(), 0.5, 1.5);
        assert_eq!(d[0], 0, "the wall hides p from pair 1");
    }
}
