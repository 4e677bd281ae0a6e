//! Free space: where a pair's legs ran through to a surface it detected farther on, nothing
//! opaque stands.
//!
//! **Why.** Every surface of the site is opaque at the carrier (ITU concrete, brick, glass and
//! metal: tens of dB per wall at 10 GHz, [`crate::material`]), so a pair that detected a surface
//! point `q` had both of its legs — panel centre → `q` and aperture centre → `q` — clear all the
//! way. Any place such a leg passed through is free space, whatever any other pair's image holds
//! there. This is the visibility evidence of volumetric reconstruction from known sensor positions
//! (space carving; Chauve et al. 2010): it says where surface is *not*, which a pair's silence
//! cannot, because a pair that misses a surface cell (grazing incidence, a weak leg, speckle) is
//! common, while a leg to a detected surface beyond is a positive observation. It removes the
//! smear and sidelobes of bright surfaces that other pairs looked through: the plume a vehicle's
//! pair puts over a roof's edge where a UAV's pair reached the roof behind it, a street's air
//! where a pair's poor vertical resolution dropped a facade's image.
//!
//! **The test.** Only points that two pairs kept and that the cross-pair confirmation kept
//! ([`super::confirmation`]) end a leg: one pair's detection may itself be a false alarm or a
//! smear, and a leg to it proves nothing. Pair `k`'s leg from sensor `e` to such a point `q`
//! passes through `p` when the direction `(p − e)/|p − e|` lies within `ε/|p − e|` of
//! `(q − e)/|q − e|` — the leg passes within `ε` of `p` — and `q` lies beyond `p` by more than
//! the support distance ([`super::run::support_distance_m`]: nearer than that, `q` is `p`'s own
//! surface). `ε` is half the imaging voxel: a fused point stands on the voxel lattice, and a leg
//! within half a voxel of it crosses its voxel. Where `p` lies on a patch with a facing `n̂`
//! ([`super::facing`]), the leg must cross that patch: the sensor and `q` on opposite sides of
//! its plane, `q` by more than half the support distance. A leg that grazes along a roof to the
//! roof's far part keeps to the roof's plane, and the roof's imaged points scatter about that
//! plane by up to a resolution cell: such a leg passes near them without crossing anything.
//!
//! Units: metres; world frame.

use glam::Vec3;

use crate::knn::PointIndex;

/// The legs of one pair end, pointing at the points it ends on.
struct Legs {
    /// Unit directions from the sensor to each leg's end.
    directions: PointIndex,
    /// Each leg's end, metres.
    ends: Vec<Vec3>,
}

/// The free space the pairs' legs ran through (module docs).
pub struct FreeSpace {
    /// Per pair: panel centre and aperture centre, metres.
    sensors: Vec<[Vec3; 2]>,
    /// Per pair and sensor: its legs (`None`: no leg).
    legs: Vec<[Option<Legs>; 2]>,
    /// A leg passes through a point within this distance of it, metres.
    half_width_m: f32,
    /// The support distance, metres: a leg's end nearer than this to a point is its own surface.
    support_m: f32,
}

impl FreeSpace {
    /// The legs of every pair `k` (sensors `sensors[k]`: panel centre, aperture centre) to the
    /// points `i` with bit `k` of `mask[i]` set and `ends_leg[i]` true; legs pass through points
    /// within `half_width_m` of them.
    pub fn new(
        points: &[Vec3],
        mask: &[u64],
        ends_leg: &[bool],
        sensors: &[[Vec3; 2]],
        half_width_m: f32,
        support_m: f32,
    ) -> FreeSpace {
        let legs = sensors
            .iter()
            .enumerate()
            .map(|(k, ends)| {
                ends.map(|e| {
                    let (directions, ends): (Vec<Vec3>, Vec<Vec3>) = points
                        .iter()
                        .zip(mask)
                        .zip(ends_leg)
                        .filter(|((_, &m), &l)| l && k < 64 && (m >> k) & 1 == 1)
                        .map(|((&q, _), _)| ((q - e).normalize_or_zero(), q))
                        .filter(|(d, _)| *d != Vec3::ZERO)
                        .unzip();
                    PointIndex::new("legs", &directions)
                        .ok()
                        .map(|directions| Legs { directions, ends })
                })
            })
            .collect();
        FreeSpace {
            sensors: sensors.to_vec(),
            legs,
            half_width_m,
            support_m,
        }
    }

    /// Whether a leg of pair `k` passed through `p` (module docs); `normal`: the facing of the
    /// patch `p` lies on, if it has one.
    pub fn pair_saw_through(&self, p: Vec3, k: usize, normal: Option<Vec3>) -> bool {
        let (Some(sensors), Some(legs)) = (self.sensors.get(k), self.legs.get(k)) else {
            return false;
        };
        sensors.iter().zip(legs).any(|(&e, legs)| {
            let Some(legs) = legs else {
                return false;
            };
            let d = p - e;
            let r = d.length();
            // A point at the sensor (or a NaN) is on no leg.
            if r.is_nan() || r <= self.half_width_m {
                return false;
            }
            legs.directions
                .within(d / r, self.half_width_m / r)
                .iter()
                .any(|&(j, _)| {
                    let q = legs.ends[j as usize];
                    (q - e).length() > r + self.support_m
                        && normal.is_none_or(|n| {
                            let (a, b) = ((e - p).dot(n), (q - p).dot(n));
                            a * b < 0.0 && b.abs() > 0.5 * self.support_m
                        })
                })
        })
    }

    /// Whether any pair's leg passed through `p`.
    pub fn seen_through(&self, p: Vec3, normal: Option<Vec3>) -> bool {
        (0..self.sensors.len()).any(|k| self.pair_saw_through(p, k, normal))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sensor at the origin and a wall of points two pairs kept at x = 20.
    fn wall() -> (Vec<Vec3>, Vec<u64>) {
        let mut pts = Vec::new();
        for y in -10..=10 {
            for z in 0..=10 {
                pts.push(Vec3::new(20.0, y as f32 * 0.5, z as f32 * 0.5));
            }
        }
        let mask = vec![0b11; pts.len()];
        (pts, mask)
    }

    #[test]
    fn a_point_on_a_leg_to_a_surface_behind_it_is_free_space_and_one_beside_it_is_not() {
        let (pts, mask) = wall();
        let sensors = [[Vec3::ZERO, Vec3::new(0.0, 0.0, 0.1)]; 2];
        let fs = FreeSpace::new(&pts, &mask, &vec![true; pts.len()], &sensors, 0.25, 2.0);
        // Halfway along the leg to (20, 1, 2.5).
        assert!(fs.seen_through(Vec3::new(10.0, 0.5, 1.25), None));
        // Off every leg: below the wall's foot, seen from above it.
        assert!(!fs.seen_through(Vec3::new(10.0, 0.5, -3.0), None));
        // Within the support distance of the wall: its own surface.
        assert!(!fs.seen_through(Vec3::new(18.5, 0.9, 2.3), None));
        // Behind the wall: no leg reached it.
        assert!(!fs.seen_through(Vec3::new(30.0, 1.5, 3.75), None));
    }

    #[test]
    fn only_points_that_end_a_leg_carve_and_a_leg_along_a_patch_crosses_nothing() {
        let (pts, mask) = wall();
        let sensors = [[Vec3::ZERO, Vec3::ZERO]];
        let none = FreeSpace::new(&pts, &mask, &vec![false; pts.len()], &sensors, 0.25, 2.0);
        assert!(!none.seen_through(Vec3::new(10.0, 0.5, 1.25), None));
        let fs = FreeSpace::new(&pts, &mask, &vec![true; pts.len()], &sensors, 0.25, 2.0);
        // A patch whose plane holds the leg (normal across it): the leg runs along it.
        let p = Vec3::new(10.0, 0.5, 1.25);
        let along = Vec3::new(0.0, 1.0, -0.2).cross(p).normalize();
        assert!(!fs.seen_through(p, Some(along)));
        // A patch the leg crosses.
        assert!(fs.seen_through(p, Some(Vec3::X)));
    }
}
