//! Fused points whose height a finer pair places elsewhere: the vertically smeared copies of a
//! roof (or any surface that crosses the vertical) that pairs with a poor vertical resolution
//! detect above and below it, dropped where a finer pair resolves them from it and moved onto
//! it where none does.
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
//! **Placements no pair resolves are one surface's.** Where the finer points in `p`'s column
//! (within `p`'s own height cell, on a surface that crosses the vertical; finer as above: `e(q) ≤
//! e(p)/2`, a cell that fits twice in `p`'s, so that `q`'s placement says where in `p`'s cell the
//! surface is — between two coarse placements it would average one smear with another) all lie
//! within their own extent of `p`, no pair resolves `p` from them: they are placements
//! of one surface by pairs of different vertical resolution, each uncertain by its extent. The
//! estimate of that surface's height from independent placements is their mean weighted by each
//! one's information, `1/e²` ([`Height::Refined`]): a vehicle's pair (`e` ≈ 5 m) that placed a
//! roof 2 m above where a UAV's pair (`e` ≈ 2 m at the quick preset's bandwidth) placed it
//! moves 1.7 m down onto it. Dropping `p` instead would be wrong — the finer pair cannot say
//! that it is not the surface — and keeping it where it is leaves the slab that its pair's
//! resolution spreads above and below a bright roof, which the mesher closes into caps over the
//! roof and sheets inside the building. Only a point on a surface that crosses the vertical
//! itself moves (its own PCA normal within 45° of vertical, as `q`'s): a wall's sample under a
//! roof's edge is a sample of the wall, not a copy of the roof. Only the height changes, and
//! every point is averaged with the placements as fused, not as moved: the order of the points
//! decides nothing.
//!
//! Units: metres, world frame, z up.

use glam::Vec3;
use rayon::prelude::*;

use crate::knn::GeometryError;
use crate::mesh::normals::{pca_normals_over, Neighbourhood};

/// Fewest neighbours of the PCA normal that decides whether a finer point's surface crosses the
/// vertical (as the mesher's normals).
pub const NORMAL_NEIGHBOURS: usize = 16;

/// What the finer pairs say of one fused point's height (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Height {
    /// No finer point in its column speaks to it: kept where its pairs placed it.
    Kept,
    /// A finer point in its column resolves it from the surface it is a copy of: dropped.
    Dropped,
    /// Finer points in its column that do not resolve it from their surface: the point is that
    /// surface, at the information-weighted mean of its own height and theirs (metres).
    Refined(f32),
}

/// Each point's [`Height`] (module docs): `extents[i]` is point `i`'s vertical extent (metres;
/// infinite or NaN: unknown, never a finer placement and never dropped), `voxel_m` the imaging
/// voxel, `normal_radius_m` the reach of the PCA normals.
///
/// # Errors
/// [`GeometryError`] from the neighbour index (non-finite points; a radius not finite and
/// positive; fewer points than [`NORMAL_NEIGHBOURS`] is fine).
pub fn heights(
    points: &[Vec3],
    extents: &[f32],
    voxel_m: f32,
    normal_radius_m: f32,
) -> Result<Vec<Height>, GeometryError> {
    if points.len() < 2 {
        return Ok(vec![Height::Kept; points.len()]);
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
                return Height::Kept;
            }
            // The column's candidates: within the column's radius horizontally and e/2
            // vertically, all inside this sphere.
            let reach = column.hypot(0.5 * e);
            let mut near = index.within(p, reach);
            near.sort_unstable_by_key(|&(j, _)| j);
            let finer = near.into_iter().map(|(j, _)| j as usize).filter(|&j| {
                let q = points[j];
                j != i
                    && crosses[j]
                    && (q.x - p.x).hypot(q.y - p.y) <= column
                    && (p.z - q.z).abs() <= 0.5 * e
                    && extents[j].is_finite()
                    && extents[j] <= 0.5 * e
            });
            // Information-weighted height: each placement weighs 1/extent².
            let (mut num, mut den) = (p.z / (e * e), 1.0 / (e * e));
            let mut refined = false;
            for j in finer {
                let (q, ej) = (points[j], extents[j]);
                if (p.z - q.z).abs() > ej {
                    return Height::Dropped;
                }
                num += q.z / (ej * ej);
                den += 1.0 / (ej * ej);
                refined = true;
            }
            if refined && crosses[i] {
                Height::Refined(num / den)
            } else {
                Height::Kept
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Which points [`heights`] drops.
    fn placed_finer(
        points: &[Vec3],
        extents: &[f32],
        voxel_m: f32,
        normal_radius_m: f32,
    ) -> Result<Vec<bool>, GeometryError> {
        Ok(heights(points, extents, voxel_m, normal_radius_m)?
            .into_iter()
            .map(|h| h == Height::Dropped)
            .collect())
    }

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
    fn a_copy_no_finer_pair_resolves_moves_to_the_weighted_height() {
        // A finer pair's roof at 10 m (extent 2 m) and a coarse pair's copy 1.5 m above (extent
        // 5 m): within the finer extent, so not resolved; its height is the 1/e²-weighted mean
        // of its own and the finer placements in its column.
        let mut points = roof(10.0);
        let n = points.len();
        points.extend(roof(11.5));
        let mut extents = vec![2.0; n];
        extents.extend(vec![5.0; n]);
        // A 0.4 m voxel: the column (radius √2·0.4 m) holds the lattice's plus of five points.
        let h = heights(&points, &extents, 0.4, 1.0).expect("points");
        assert!(
            h[..n].iter().all(|&h| h == Height::Kept),
            "the finer roof stays"
        );
        let i = n + 10 * 20 + 10;
        let (w_fine, w_own) = (1.0 / 4.0, 1.0 / 25.0);
        let want = (11.5 * w_own + 5.0 * 10.0 * w_fine) / (w_own + 5.0 * w_fine);
        match h[i] {
            Height::Refined(z) => assert!((z - want).abs() < 1e-4, "{z} against {want}"),
            other => panic!("{other:?}"),
        }
        // Away from the sheets' edges (where the 16 nearest points of a normal reach the other
        // sheet), every copy moves onto the roof.
        let interior = (3..17).flat_map(|a| (3..17).map(move |b| n + a * 20 + b));
        assert!(interior
            .map(|i| h[i])
            .all(|h| matches!(h, Height::Refined(z) if z < 10.2)));
        // The drop-only view keeps them all.
        assert!(placed_finer(&points, &extents, 0.4, 1.0)
            .expect("points")
            .iter()
            .all(|&d| !d));
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
        let h = heights(&points, &extents, 0.5, 1.0).expect("points");
        assert!(
            h.iter().all(|&h| h == Height::Kept),
            "and stay where they are"
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
