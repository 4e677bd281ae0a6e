//! Fused points whose height a finer pair places elsewhere: the vertically smeared copies of a
//! roof (or any surface that crosses the vertical) that pairs with a poor vertical resolution
//! detect above and below it.
//!
//! **Why.** A pair places an echo in height no better than its vertical extent `e`
//! (`√(J⁻¹)_zz` of its information matrix, [`super::sensors::vertical_extent_m`]): several metres
//! for a vehicle's pair, whose bistatic range gradient is nearly horizontal and whose panel is
//! half a metre tall, under a metre for a UAV's pair looking down. A roof seen by a vehicle's pair
//! is therefore a slab up to `e` thick, and the fused cloud holds that slab around the roof: on
//! tower_hall's default preset the hall's roof points 1.5–3 m above and below the roof carried a
//! quarter of the cloud's accuracy term, and the mesh closed caps over them (docs/journal/results.md).
//! Where a finer pair has placed the same surface, the coarse pair's points off it add nothing
//! but error: they lie within the coarse pair's own height cell of the finer placement, which
//! the finer pair resolves from them.
//!
//! **The rule.** For a fused point `p` with vertical extent `e(p)` (the finest among the pairs
//! that kept it), a fused point `q` in `p`'s vertical column (within one voxel diagonal `√2·v`
//! horizontally) *places `p`'s surface finer* when
//! - `q` lies within `p`'s own height cell, `|z_p − z_q| ≤ e(p)/2`,
//! - `q`'s pairs resolve `p`'s height from `q`'s, `|z_p − z_q| > e(q)` (so `e(q) < e(p)/2`),
//! - and `q` lies on a surface that crosses the vertical — its normal (PCA over the fused points
//!   within `normal_radius_m` of it, the run's support distance, at least [`NORMAL_NEIGHBOURS`]
//!   of them: the mesher's rule, [`crate::imaging::surface()`]) within 45° of vertical,
//!   `|n_z| > cos 45°` — a roof, not a wall: a wall contains the column, and a coarse pair's
//!   point on it is a sample of the wall, not a displaced copy of `q`. Over a fixed 16
//!   neighbours the default preset's roof normals were mostly noise and the test passed over
//!   smeared copies (the suite's default clouds 0.004–0.023 m √CD better with
//!   the radius, docs/journal/results.md).
//!
//! `p` is then dropped: a copy of `q`'s surface at the height its pairs could not resolve. The
//! test needs no threshold beyond each pair's own resolution and the bisector between the
//! surfaces a column crosses and those it runs along.
//!
//! Units: metres, world frame, z up.

use glam::Vec3;
use rayon::prelude::*;

use crate::knn::GeometryError;
use crate::mesh::normals::{pca_normals_over, Neighbourhood};

/// Fewest neighbours of the PCA normal that decides whether a finer point's surface crosses the
/// vertical (as the mesher's normals).
pub const NORMAL_NEIGHBOURS: usize = 16;

/// Which points a finer point places elsewhere in height (module docs): `extents[i]` is point
/// `i`'s vertical extent (metres; infinite or NaN: unknown, never a finer placement and never
/// dropped), `voxel_m` the imaging voxel, `normal_radius_m` the reach of the PCA normals.
///
/// # Errors
/// [`GeometryError`] from the neighbour index (non-finite points; a radius not finite and
/// positive; fewer points than [`NORMAL_NEIGHBOURS`] is fine).
pub fn placed_finer(
    points: &[Vec3],
    extents: &[f32],
    voxel_m: f32,
    normal_radius_m: f32,
) -> Result<Vec<bool>, GeometryError> {
    if points.len() < 2 {
        return Ok(vec![false; points.len()]);
    }
    let neighbourhood = Neighbourhood::Within {
        radius_m: normal_radius_m,
        min: NORMAL_NEIGHBOURS.min(points.len()),
    };
    let (normals, index) = pca_normals_over(points, neighbourhood)?;
    let crosses: Vec<bool> = normals
        .iter()
        .map(|n| n.z.abs() > std::f32::consts::FRAC_1_SQRT_2)
        .collect();
    let column = std::f32::consts::SQRT_2 * voxel_m;
    Ok(points
        .par_iter()
        .enumerate()
        .map(|(i, &p)| {
            let e = extents[i];
            if !e.is_finite() {
                return false;
            }
            // The column's candidates: within the column's radius horizontally and e/2
            // vertically, all inside this sphere.
            let reach = column.hypot(0.5 * e);
            index.within(p, reach).into_iter().any(|(j, _)| {
                let j = j as usize;
                let q = points[j];
                let dz = (p.z - q.z).abs();
                j != i
                    && crosses[j]
                    && (q.x - p.x).hypot(q.y - p.y) <= column
                    && dz <= 0.5 * e
                    && extents[j].is_finite()
                    && dz > extents[j]
            })
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat roof at 10 m sampled every 0.5 m over 10 × 10 m.
    fn roof(z: f32) -> Vec<Vec3> {
        (0..20)
            .flat_map(|i| (0..20).map(move |j| Vec3::new(0.5 * i as f32, 0.5 * j as f32, z)))
            .collect()
    }

    #[test]
    fn a_coarse_copy_of_a_roof_a_finer_pair_placed_is_dropped_and_the_roof_kept() {
        // The finer pair's roof (extent 0.8 m) and a coarse pair's copy 2 m above (extent 5 m).
        let mut points = roof(10.0);
        let n = points.len();
        points.extend(roof(12.0));
        let mut extents = vec![0.8; n];
        extents.extend(vec![5.0; n]);
        let drop = placed_finer(&points, &extents, 0.5, 1.0).expect("points");
        assert!(drop[..n].iter().all(|&d| !d), "the finer roof stays");
        assert!(drop[n..].iter().all(|&d| d), "the copy goes");
        // A copy farther than half its own cell: not the finer roof's (another surface).
        let mut far = roof(10.0);
        far.extend(roof(13.0));
        let drop = placed_finer(&far, &extents, 0.5, 1.0).expect("points");
        assert!(drop.iter().all(|&d| !d));
        // A copy the finer pair does not resolve from its roof (closer than its extent) stays.
        let mut near = roof(10.0);
        near.extend(roof(10.5));
        let drop = placed_finer(&near, &extents, 0.5, 1.0).expect("points");
        assert!(drop.iter().all(|&d| !d));
    }

    #[test]
    fn a_wall_under_a_finer_pair_s_points_is_not_a_copy() {
        // A wall x = 0, 0–10 m high, 10 m long, sampled every 0.5 m by a coarse pair
        // (extent 5 m), and a finer pair's points on the same wall (extent 0.8 m) every metre.
        let mut points = Vec::new();
        let mut extents = Vec::new();
        for i in 0..20 {
            for k in 0..20 {
                points.push(Vec3::new(0.0, 0.5 * i as f32, 0.5 * k as f32));
                extents.push(if i % 2 == 0 && k % 2 == 0 { 0.8 } else { 5.0 });
            }
        }
        let drop = placed_finer(&points, &extents, 0.5, 1.0).expect("points");
        assert!(
            drop.iter().all(|&d| !d),
            "a wall's samples along the column stay"
        );
    }

    #[test]
    fn unknown_extents_never_decide() {
        let mut points = roof(10.0);
        let n = points.len();
        points.extend(roof(12.0));
        let mut extents = vec![f32::INFINITY; n];
        extents.extend(vec![5.0; n]);
        let drop = placed_finer(&points, &extents, 0.5, 1.0).expect("points");
        assert!(drop.iter().all(|&d| !d));
        assert_eq!(
            placed_finer(&[], &[], 0.5, 1.0).expect("empty"),
            Vec::<bool>::new()
        );
    }
}
