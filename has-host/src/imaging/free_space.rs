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
//! within half a voxel of it crosses its voxel.
//!
//! **Crossing the layer the surface may lie in.** Where `p` has a plane (its PCA normal `n̂`,
//! [`super::facing::test_normals`]), the leg must cross it: the sensor and `q` on opposite sides
//! of the plane, `q` by more than half the support distance. And the leg must cross the whole
//! layer in which the surface `p` stands for may lie: the pairs that placed `p` placed it to
//! within `σ_p` across `n̂` (the finest of their resolutions along `n̂`, [`super::pair_cell`]),
//! and the leg itself is known to within its end's resolution across `n̂`, scaled by
//! `|p − e|/|q − e|` toward the sensor (`σ_leg`). A leg at angle `θ` to the plane crosses the
//! layer `±σ = ±√(σ_p² + σ_leg²)` over `σ/tan θ` along it on either side of `p`; it pierces the
//! patch `p` stands for (the support distance around it) only when `tan θ ≥ σ/support`. A leg
//! that grazes a roof to a wall beyond it passes through roof points imaged a few decimetres
//! above the roof while clearing the roof itself; with a vehicle's metre-scale vertical cell
//! that roof point is not refuted by any leg flatter than about 25°, with a UAV's decimetre cell
//! by any steeper than a few degrees.
//!
//! Units: metres; world frame.

use glam::{DMat3, Vec3};

use super::pair_cell::{resolution_along_m, PairCell};
use crate::knn::PointIndex;

/// The legs of one pair end, pointing at the points it ends on.
struct Legs {
    /// Unit directions from the sensor to each leg's end.
    directions: PointIndex,
    /// Each leg's end, metres.
    ends: Vec<Vec3>,
    /// The leg's pair's information matrix at each end ([`PairCell`]), where the pair's cell is
    /// known: how far across a surface the end may lie from where the pair placed it.
    information: Vec<Option<DMat3>>,
}

/// The surface a point would stand on: its plane's normal and how far across that plane the
/// point may lie from the surface (the finest resolution across it among the pairs that placed
/// the point), metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Across {
    /// Unit normal of the plane through the point.
    pub normal: Vec3,
    /// The point's uncertainty across the plane, metres.
    pub sigma_m: f32,
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
    /// The legs of every pair `k` (sensors `sensors[k]`: panel centre, aperture centre; its
    /// resolution cell `cells[k]` where known) to the points `i` with bit `k` of `mask[i]` set
    /// and `ends_leg[i]` true; legs pass through points within `half_width_m` of them.
    pub fn new(
        points: &[Vec3],
        mask: &[u64],
        ends_leg: &[bool],
        sensors: &[[Vec3; 2]],
        cells: &[PairCell],
        half_width_m: f32,
        support_m: f32,
    ) -> FreeSpace {
        let legs = sensors
            .iter()
            .enumerate()
            .map(|(k, ends)| {
                let cell = cells.get(k);
                ends.map(|e| {
                    let (directions, ends): (Vec<Vec3>, Vec<Vec3>) = points
                        .iter()
                        .zip(mask)
                        .zip(ends_leg)
                        .filter(|((_, &m), &l)| l && k < 64 && (m >> k) & 1 == 1)
                        .map(|((&q, _), _)| ((q - e).normalize_or_zero(), q))
                        .filter(|(d, _)| *d != Vec3::ZERO)
                        .unzip();
                    let information = ends
                        .iter()
                        .map(|&q| cell.map(|c| c.information(q)))
                        .collect();
                    PointIndex::new("legs", &directions)
                        .ok()
                        .map(|directions| Legs {
                            directions,
                            ends,
                            information,
                        })
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

    /// Whether a leg of pair `k` passed through `p` (module docs); `plane`: the surface `p`
    /// would stand on, if it has one.
    pub fn pair_saw_through(&self, p: Vec3, k: usize, plane: Option<Across>) -> bool {
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
                    let length = (q - e).length();
                    length > r + self.support_m
                        && plane.is_none_or(|Across { normal: n, sigma_m }| {
                            let (a, b) = ((e - p).dot(n), (q - p).dot(n));
                            // The leg's own uncertainty where it passes `p`: its end's across
                            // the plane, scaled down toward the sensor.
                            let leg_m = legs.information[j as usize]
                                .map_or(0.0, |info| resolution_along_m(&info, n) * r / length);
                            let sigma = sigma_m.hypot(leg_m);
                            // The leg crosses the layer the surface may lie in within the
                            // support distance of `p`: tan θ ≥ σ / support, θ the angle
                            // between the leg and the plane.
                            let sin = ((q - e) / length).dot(n).abs();
                            let cos = (1.0 - sin * sin).max(0.0).sqrt();
                            a * b < 0.0
                                && b.abs() > 0.5 * self.support_m
                                && sin * self.support_m >= sigma * cos
                        })
                })
        })
    }

    /// Whether any pair's leg passed through `p`.
    pub fn seen_through(&self, p: Vec3, plane: Option<Across>) -> bool {
        (0..self.sensors.len()).any(|k| self.pair_saw_through(p, k, plane))
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

    /// The legs from `sensors` to the wall's points (every point ends one when `ends`), half
    /// width 0.25 m, support distance 2 m, no pair's cell known.
    fn over_wall(pts: &[Vec3], mask: &[u64], ends: bool, sensors: &[[Vec3; 2]]) -> FreeSpace {
        FreeSpace::new(pts, mask, &vec![ends; pts.len()], sensors, &[], 0.25, 2.0)
    }

    #[test]
    fn a_point_on_a_leg_to_a_surface_behind_it_is_free_space_and_one_beside_it_is_not() {
        let (pts, mask) = wall();
        let sensors = [[Vec3::ZERO, Vec3::new(0.0, 0.0, 0.1)]; 2];
        let fs = over_wall(&pts, &mask, true, &sensors);
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
        let none = over_wall(&pts, &mask, false, &sensors);
        assert!(!none.seen_through(Vec3::new(10.0, 0.5, 1.25), None));
        let fs = over_wall(&pts, &mask, true, &sensors);
        // A patch whose plane holds the leg (normal across it): the leg runs along it.
        let p = Vec3::new(10.0, 0.5, 1.25);
        let along = Vec3::new(0.0, 1.0, -0.2).cross(p).normalize();
        let plane = |normal| {
            Some(Across {
                normal,
                sigma_m: 0.0,
            })
        };
        assert!(!fs.seen_through(p, plane(along)));
        // A patch the leg crosses.
        assert!(fs.seen_through(p, plane(Vec3::X)));
    }

    #[test]
    fn a_leg_flatter_than_the_layer_the_surface_may_lie_in_refutes_nothing() {
        // A sensor 12 m up and a point two pairs kept 40 m on, 8 m up: the leg passes a roof
        // point at (20, 0, 10) at tan θ = 0.1 to the roof's plane.
        let e = Vec3::new(0.0, 0.0, 12.0);
        let q = Vec3::new(40.0, 0.0, 8.0);
        let fs = FreeSpace::new(&[q], &[1], &[true], &[[e, e]], &[], 0.25, 2.0);
        let p = Vec3::new(20.0, 0.0, 10.0);
        let roof = |sigma_m| {
            Some(Across {
                normal: Vec3::Z,
                sigma_m,
            })
        };
        // Placed to 0.1 m across the roof: the leg crosses that layer within 1 m of the point
        // (tan θ 0.1 ≥ 0.1/2).
        assert!(fs.seen_through(p, roof(0.1)));
        // Placed to 0.5 m: the leg may clear a roof 0.5 m lower for 5 m past the point, beyond
        // the support distance; it says nothing.
        assert!(!fs.seen_through(p, roof(0.5)));
        // The same point on a wall the leg crosses at a right angle is refuted at any σ within
        // the support distance.
        let wall = Some(Across {
            normal: (q - e).normalize(),
            sigma_m: 1.9,
        });
        assert!(fs.seen_through(p, wall));
    }
}
