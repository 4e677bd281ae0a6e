//! Nearest-neighbour queries on 3D point sets (a k-d tree, `kiddo`'s immutable tree) and the
//! error type shared by the point-set code (metrics, normals, meshing).
//!
//! Distances returned by [`PointIndex`] are *squared* Euclidean distances in m² unless a name
//! says otherwise; indices are positions in the slice the index was built from. Batched forms run
//! across queries with rayon. Points must be finite: the constructor checks every coordinate.

use std::num::NonZeroUsize;

use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

/// Why a point set, mesh or parameter was rejected.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GeometryError {
    /// A point set that must not be empty is empty.
    #[error("{field}: the point set is empty")]
    Empty {
        /// Which input.
        field: &'static str,
    },
    /// A point has a NaN or infinite coordinate.
    #[error("{field}[{index}] is not finite ({value:?})")]
    NonFinite {
        /// Which input.
        field: &'static str,
        /// Index of the offending point.
        index: usize,
        /// The point.
        value: Vec3,
    },
    /// Too few points for the operation (e.g. fewer than k for k nearest neighbours).
    #[error("{field}: {count} points, at least {needed} are needed")]
    TooFew {
        /// Which input.
        field: &'static str,
        /// Points given.
        count: usize,
        /// Points needed.
        needed: usize,
    },
    /// A scalar parameter is out of its range.
    #[error("{field} = {value} is invalid: must be {expected}")]
    BadParameter {
        /// Parameter name.
        field: &'static str,
        /// The value given.
        value: f64,
        /// The valid range, in words.
        expected: &'static str,
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {vertex}, but the mesh has {vertex_count} vertices")]
    BadFace {
        /// Face index.
        face: usize,
        /// The vertex index it holds.
        vertex: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// A coordinate beyond ±[`crate::scene::MAX_COORD_M`].
    #[error(
        "{field}: point {index} at ({}, {}, {}) lies beyond ±{:e} m (f32 resolves no better than \
         6 cm there)",
        value.x, value.y, value.z, crate::scene::MAX_COORD_M
    )]
    TooFar {
        /// Which input.
        field: &'static str,
        /// Index of the point.
        index: usize,
        /// The point.
        value: Vec3,
    },
    /// The input is degenerate for the operation (e.g. all points on one plane).
    #[error("{field}: degenerate input: {reason}")]
    Degenerate {
        /// Which input.
        field: &'static str,
        /// What is degenerate.
        reason: String,
    },
}

/// Checks that `points` is non-empty and every coordinate is finite and within
/// ±[`crate::scene::MAX_COORD_M`].
pub fn check_points(field: &'static str, points: &[Vec3]) -> Result<(), GeometryError> {
    if points.is_empty() {
        return Err(GeometryError::Empty { field });
    }
    if let Some((index, &value)) = points.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(GeometryError::NonFinite {
            field,
            index,
            value,
        });
    }
    let far = |p: &Vec3| p.abs().max_element() as f64 > crate::scene::MAX_COORD_M;
    if let Some((index, &value)) = points.iter().enumerate().find(|(_, p)| far(p)) {
        return Err(GeometryError::TooFar {
            field,
            index,
            value,
        });
    }
    Ok(())
}

/// A k-d tree over a fixed set of points.
pub struct PointIndex {
    tree: ImmutableKdTree<f32, 3>,
    points: Vec<Vec3>,
}

impl std::fmt::Debug for PointIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PointIndex")
            .field("len", &self.points.len())
            .finish()
    }
}

impl PointIndex {
    /// Builds the tree. `field` names the input in errors.
    ///
    /// # Errors
    /// [`GeometryError::Empty`] or [`GeometryError::NonFinite`]; [`GeometryError::TooFew`] if
    /// there are more than `u32::MAX` points.
    pub fn new(field: &'static str, points: &[Vec3]) -> Result<PointIndex, GeometryError> {
        check_points(field, points)?;
        let arr: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
        let tree =
            ImmutableKdTree::<f32, 3>::new_from_slice(&arr).map_err(|_| GeometryError::TooFew {
                field,
                count: points.len(),
                needed: 0,
            })?;
        Ok(PointIndex {
            tree,
            points: points.to_vec(),
        })
    }

    /// Number of points in the index.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// The indexed point `i` (an index from a query).
    pub fn point(&self, i: u32) -> Vec3 {
        self.points[i as usize]
    }

    /// Always false: an index is never empty.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Nearest point to `q`: (index, squared distance in m²).
    pub fn nearest(&self, q: Vec3) -> (u32, f32) {
        let r = self
            .tree
            .query(&q.to_array())
            .nearest_one::<SquaredEuclidean<f32>>()
            .execute();
        (r.item, r.distance)
    }

    /// Squared distance (m²) from each query to its nearest point in the index, in parallel.
    pub fn nearest_sq_many(&self, queries: &[Vec3]) -> Vec<f32> {
        queries.par_iter().map(|&q| self.nearest(q).1).collect()
    }

    /// The `k` nearest points to `q` (fewer if the index holds fewer), sorted by distance:
    /// (index, squared distance m²). `k = 0` gives an empty list.
    pub fn knn(&self, q: Vec3, k: usize) -> Vec<(u32, f32)> {
        let Some(k) = NonZeroUsize::new(k.min(self.points.len())) else {
            return Vec::new();
        };
        self.tree
            .query(&q.to_array())
            .nearest_n::<SquaredEuclidean<f32>>(k)
            .execute()
            .into_iter()
            .map(|r| (r.item, r.distance))
            .collect()
    }

    /// All points within `radius_m` of `q` (inclusive), unsorted: (index, squared distance m²).
    pub fn within(&self, q: Vec3, radius_m: f32) -> Vec<(u32, f32)> {
        self.tree
            .query(&q.to_array())
            .within::<SquaredEuclidean<f32>>(radius_m * radius_m)
            .unsorted()
            .execute()
            .into_iter()
            .map(|r| (r.item, r.distance))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_and_knn_match_brute_force() {
        let pts: Vec<Vec3> = (0..200)
            .map(|i| {
                let f = i as f32;
                Vec3::new((f * 0.37).sin() * 5.0, (f * 0.11).cos() * 3.0, f * 0.01)
            })
            .collect();
        let idx = PointIndex::new("pts", &pts).unwrap();
        for q in [Vec3::ZERO, Vec3::new(1.0, -2.0, 0.5), Vec3::splat(10.0)] {
            let mut d: Vec<(u32, f32)> = pts
                .iter()
                .enumerate()
                .map(|(i, p)| (i as u32, (*p - q).length_squared()))
                .collect();
            d.sort_by(|a, b| a.1.total_cmp(&b.1));
            assert_eq!(idx.nearest(q).1, d[0].1);
            let k = idx.knn(q, 7);
            assert_eq!(k.len(), 7);
            for (a, b) in k.iter().zip(&d) {
                assert!((a.1 - b.1).abs() <= 1e-6 * b.1.max(1.0));
            }
            let r = d[10].1.sqrt();
            let w = idx.within(q, r);
            assert!(w.len() >= 11 && w.iter().all(|x| x.1 <= r * r * (1.0 + 1e-6)));
        }
    }

    #[test]
    fn empty_and_nan_are_rejected() {
        assert_eq!(
            PointIndex::new("s", &[]).unwrap_err(),
            GeometryError::Empty { field: "s" }
        );
        let e = PointIndex::new("s", &[Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0)]).unwrap_err();
        assert!(matches!(e, GeometryError::NonFinite { index: 1, .. }));
    }
}
