//! Which way the surface through a fused point faces, and which pairs it can echo to.
//!
//! A scatterer's echo is Lambertian ([`crate::echo`]): a facet with unit normal `n` at `p`
//! echoes from a transmitter at `tx` to a receiver at `rx` only when it faces both,
//! `n·(tx − p) > 0` and `n·(rx − p) > 0` ([`faces_a_pair`]). The mesher reads it to leave out
//! samples no pair could have seen as facets (the smear of a neighbouring echo), and the
//! cross-pair confirmation reads it to ask whether a pair's silence about a point says anything:
//! a pair behind a surface receives nothing from it, so it does not deny it (and a surface one
//! pair imaged stands between the pairs and what lies behind it, [`super::confirmation`]).
//!
//! The normals are PCA normals of the fused points over [`TEST_NORMAL_SUPPORT_FRACTION`] of the
//! support distance (at least the 16 nearest points), oriented toward the sensors that observed
//! each point ([`test_normals`]; why this neighbourhood: the module docs of
//! [`super::surface`](mod@super::surface)).
//!
//! **A surface of its own** ([`own_surface_normals`]): a false alarm is one resolution cell of
//! one pair's image — clutter speckle, a sidelobe — a blob at most a cell across, whose PCA
//! "normal" is whichever way its few points happen to spread, and which may face its own pair
//! and away from every other. A surface the pairs imaged spans more. So a point has a facing only
//! when its patch (the fused points joined through lattice neighbours) spreads in two directions
//! at least as a disk one resolution cell across does (second principal spread ≥ a quarter of
//! the cell). The cell is the coarsest of the imaged pairs (twice the support distance): it
//! bounds any pair's blob, the plate of a pair whose track resolves nothing across its panel's
//! cell included. Measured at the default preset on office_pair: one pair's blobs of 14–40
//! points, 8–22 m from any building and 0.8–2 m across, would stand with a facing taken wherever 16
//! points lie within the support distance (cloud √CD 1.001 → 1.159 m); under this rule none has
//! one. Patches of a true surface smaller than a cell have none either (district_75, quick: 165
//! points in 5–28-point patches), and are judged as before.
//!
//! Units: metres, world frame; normals unit length.

use glam::Vec3;
use rayon::prelude::*;

use crate::disjoint_sets::DisjointSets;
use crate::knn::{GeometryError, PointIndex};
use crate::linalg::symmetric_eigen3;
use crate::mesh::normals::{covariance, estimate_normals_over, Neighbourhood, Orientation};

/// The neighbourhood of the normals the per-sample tests read ([`faces_a_pair`], the wall
/// columns, the roof-edge walls, the confirmation's facing), as a fraction of the support
/// distance, with at least [`SURFACE_POINTS`] nearest points (the module docs of
/// [`super::surface`](mod@super::surface)): about a quarter of the coarsest resolution cell, 1 m
/// on the suite's sites.
pub const TEST_NORMAL_SUPPORT_FRACTION: f32 = 0.5;

/// Fewest points a normal is fitted to, the mesher's as well
/// ([`crate::mesh::ReconstructParams::normal_k`]'s default).
pub const SURFACE_POINTS: usize = 16;

/// Whether a surface element at `point` with unit normal `normal` faces both ends — transmitter
/// and receiver, `[tx, rx]` — of at least one of `pairs`: `n·(tx − p) > 0` and `n·(rx − p) > 0`,
/// the condition for a Lambertian facet to echo from one to the other (module docs). A point no
/// pair observed (`pairs` empty) is kept.
pub fn faces_a_pair(point: Vec3, normal: Vec3, pairs: &[[Vec3; 2]]) -> bool {
    pairs.is_empty()
        || pairs
            .iter()
            .any(|[tx, rx]| normal.dot(*tx - point) > 0.0 && normal.dot(*rx - point) > 0.0)
}

/// Each point's normal over [`TEST_NORMAL_SUPPORT_FRACTION`] of `support_m`, with at least `min`
/// points, oriented toward `sensors[i]` (the positions of the sensors that observed point `i`,
/// at least one each).
///
/// # Errors
/// As [`estimate_normals_over`]: non-finite points or sensors, an empty sensor set, a sensor list
/// of another length.
pub fn test_normals(
    points: &[Vec3],
    sensors: &[Vec<Vec3>],
    support_m: f32,
    min: usize,
) -> Result<Vec<Vec3>, GeometryError> {
    estimate_normals_over(
        points,
        Neighbourhood::Within {
            radius_m: TEST_NORMAL_SUPPORT_FRACTION * support_m,
            min,
        },
        Orientation::SensorSets(sensors),
    )
}

/// [`test_normals`] (at least [`SURFACE_POINTS`] points) of the points that belong to a surface
/// patch at least a resolution cell across (module docs), `None` for the others. `link_m`: the
/// distance within which two points are on one patch (the lattice's neighbours); `cell_m`: the
/// resolution cell a patch must span in two directions.
///
/// # Errors
/// As [`test_normals`].
pub fn own_surface_normals(
    points: &[Vec3],
    sensors: &[Vec<Vec3>],
    support_m: f32,
    link_m: f32,
    cell_m: f32,
) -> Result<Vec<Option<Vec3>>, GeometryError> {
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let normals = test_normals(points, sensors, support_m, SURFACE_POINTS)?;
    own_surfaces(points, &normals, link_m, cell_m)
}

/// [`own_surface_normals`] from each point's normal `normals[i]` (a [`test_normals`]).
///
/// # Errors
/// As [`PointIndex::new`]: non-finite points.
pub fn own_surfaces(
    points: &[Vec3],
    normals: &[Vec3],
    link_m: f32,
    cell_m: f32,
) -> Result<Vec<Option<Vec3>>, GeometryError> {
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let index = PointIndex::new("points", points)?;
    let links: Vec<Vec<u32>> = points
        .par_iter()
        .map(|&p| {
            index
                .within(p, link_m)
                .into_iter()
                .map(|(j, _)| j)
                .collect()
        })
        .collect();
    let mut sets = DisjointSets::new(points.len());
    for (i, js) in links.iter().enumerate() {
        for &j in js {
            sets.union(i as u32, j);
        }
    }
    let roots: Vec<u32> = (0..points.len() as u32).map(|i| sets.find(i)).collect();
    // Each component's points under its root (its smallest index).
    let mut members: Vec<Vec<Vec3>> = vec![Vec::new(); points.len()];
    for (&r, &p) in roots.iter().zip(points) {
        members[r as usize].push(p);
    }
    // A patch spans a cell in two directions when its second principal spread is at least that
    // of a disk a cell across (a disk of radius r spreads r/2 along every direction in it).
    let spans: Vec<bool> = members
        .iter()
        .map(|ps| {
            if ps.is_empty() {
                return false;
            }
            let (_, cov) = covariance(ps.iter().copied());
            let mut ev = symmetric_eigen3(cov).0;
            ev.sort_by(f64::total_cmp);
            ev[1].max(0.0).sqrt() >= 0.25 * f64::from(cell_m)
        })
        .collect();
    Ok(roots
        .iter()
        .zip(normals)
        .map(|(&r, &n)| spans[r as usize].then_some(n))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_roof_faces_a_uav_pair_but_not_a_vehicle_pair_below_it() {
        let roof = Vec3::new(0.0, 0.0, 10.0);
        let up = Vec3::Z;
        let bs = Vec3::new(-45.0, -40.0, 20.0);
        let uav = Vec3::new(0.0, -6.0, 40.0);
        let vehicle = Vec3::new(-8.0, -27.0, 1.5);
        assert!(faces_a_pair(roof, up, &[[uav, bs]]));
        // The vehicle is below the roof: a roof facing up cannot echo to it, one facing down
        // (what orienting toward the nearer sensor gives) cannot echo to the mast above it.
        assert!(!faces_a_pair(roof, up, &[[vehicle, bs]]));
        assert!(!faces_a_pair(roof, -up, &[[vehicle, bs]]));
        // One facing pair is enough; an unobserved point is kept.
        assert!(faces_a_pair(roof, up, &[[vehicle, bs], [uav, bs]]));
        assert!(faces_a_pair(roof, up, &[]));
        // A south wall faces the vehicle and the mast south of it.
        let wall = Vec3::new(0.0, -12.0, 4.0);
        assert!(faces_a_pair(wall, -Vec3::Y, &[[vehicle, bs]]));
        assert!(!faces_a_pair(wall, Vec3::Y, &[[vehicle, bs]]));
    }

    #[test]
    fn a_wall_has_a_surface_of_its_own_and_a_blob_a_cell_across_has_none() {
        // A wall x = 0, 8 × 6 m on a 0.5 m lattice, seen from +x; 10 m in front of it a blob
        // of one resolution cell (4 m), a 3 × 3 × 3 block of lattice points.
        let mut points: Vec<Vec3> = (0..16)
            .flat_map(|i| (0..12).map(move |k| Vec3::new(0.0, 0.5 * i as f32, 0.5 * k as f32)))
            .collect();
        let wall = points.len();
        for i in 0..27 {
            let (a, b, c) = ((i % 3) as f32, ((i / 3) % 3) as f32, (i / 9) as f32);
            points.push(Vec3::new(10.0 + 0.5 * a, 4.0 + 0.5 * b, 3.0 + 0.5 * c));
        }
        // A patch 5 m long but one lattice row high spreads in one direction only.
        let blob = points.len();
        points.extend((0..10).map(|i| Vec3::new(20.0, 0.5 * i as f32, 3.0)));
        let sensors = vec![vec![Vec3::new(40.0, 4.0, 10.0)]; points.len()];
        let n = own_surface_normals(&points, &sensors, 2.0, 0.9, 4.0).unwrap();
        for (i, n) in n[..wall].iter().enumerate() {
            let n = n.unwrap_or_else(|| panic!("wall point {i} has no surface"));
            assert!(n.x > 0.95, "wall point {i}: normal {n}");
        }
        assert!(
            n[wall..blob].iter().all(Option::is_none),
            "{:?}",
            &n[wall..blob]
        );
        assert!(n[blob..].iter().all(Option::is_none), "{:?}", &n[blob..]);
        assert!(own_surface_normals(&[], &[], 2.0, 0.9, 4.0)
            .unwrap()
            .is_empty());
    }
}
