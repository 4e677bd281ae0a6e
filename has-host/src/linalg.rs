//! Small dense linear algebra: the symmetric 3×3 eigensolver behind every principal-axis
//! computation on the host side (point-cloud normals and the Poisson degeneracy check in
//! [`crate::mesh`], least-squares facet planes in [`crate::paths`], a pair's worst-resolved axis
//! in the imaging driver).

use glam::{DMat3, DVec3};

/// Relative eigenvalue gap below which [`smallest_eigenvector`] reports no unique eigenvector:
/// `λ₁ − λ₀ ≤ 10⁻¹²·max(|λ₀|, |λ₂|)`. Jacobi's eigenvalues are accurate to a few ε·‖M‖
/// (ε = 2.2·10⁻¹⁶), and the eigenvector's angular error is about ε·‖M‖/(λ₁ − λ₀), so at this
/// gap it is ≲ 2·10⁻⁴ rad; below it the two smallest eigenvalues are equal within round-off.
pub const EIGEN_GAP_REL: f64 = 1e-12;

/// Eigen-decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations: eigenvalues
/// ascending and the matching unit eigenvectors (orthonormal also when eigenvalues repeat).
///
/// Sweeps stop when the off-diagonal mass is below 10⁻³⁰ of the diagonal's (at most 32 sweeps;
/// three or four in practice). A non-finite input gives non-finite eigenvalues and zero vectors.
pub fn symmetric_eigen3(m: DMat3) -> ([f64; 3], [DVec3; 3]) {
    let mut a = m.to_cols_array_2d(); // a[col][row]; symmetric, so indexing as a[i][j] is fine
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]; // columns = eigenvectors
    for _sweep in 0..32 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let scale = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= 1e-30 * scale.max(1e-300) {
            break;
        }
        for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J with J the rotation in the (p, q) plane.
            for col in a.iter_mut() {
                let akp = col[p];
                let akq = col[q];
                col[p] = c * akp - s * akq;
                col[q] = s * akp + c * akq;
            }
            let (ap, aq) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * ap[k] - s * aq[k];
                a[q][k] = s * ap[k] + c * aq[k];
            }
            for row in &mut v {
                let vp = row[p];
                let vq = row[q];
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let vals = idx.map(|i| a[i][i]);
    let vecs = idx.map(|i| DVec3::new(v[0][i], v[1][i], v[2][i]).normalize_or_zero());
    (vals, vecs)
}

/// Unit eigenvector of the smallest eigenvalue of the symmetric matrix `m` ([`symmetric_eigen3`]),
/// or `None` when that eigenvalue's eigenspace is not one-dimensional: the gap to the next
/// eigenvalue is within [`EIGEN_GAP_REL`] of the largest `|λ|` (this includes `m = 0` and multiples
/// of the identity), or `m` is not finite. The sign is Jacobi's (arbitrary); orient it yourself.
pub fn smallest_eigenvector(m: DMat3) -> Option<DVec3> {
    let (vals, vecs) = symmetric_eigen3(m);
    let scale = vals[0].abs().max(vals[2].abs());
    let finite = vals.iter().all(|l| l.is_finite());
    if !finite || vals[1] - vals[0] <= EIGEN_GAP_REL * scale {
        return None;
    }
    Some(vecs[0]).filter(|v| v.is_finite() && *v != DVec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `R·diag(l)·Rᵀ` whose eigenvector for `l[2]` is `n` (unit).
    fn with_axes(n: DVec3, l: [f64; 3]) -> DMat3 {
        let (u, v) = n.any_orthonormal_pair();
        let r = DMat3::from_cols(u, v, n);
        r * DMat3::from_diagonal(DVec3::from_array(l)) * r.transpose()
    }

    #[test]
    fn eigen_decomposition_of_a_rotated_diagonal_recovers_its_values_and_axes() {
        // Diagonal (1, 2, 5) rotated: eigenvalues are recovered to f64 round-off (≤ 1e-12).
        let r = DMat3::from_rotation_z(0.4) * DMat3::from_rotation_x(1.1);
        let m = r * DMat3::from_diagonal(DVec3::new(5.0, 1.0, 2.0)) * r.transpose();
        let (vals, vecs) = symmetric_eigen3(m);
        for (got, want) in vals.iter().zip([1.0, 2.0, 5.0]) {
            assert!((got - want).abs() < 1e-12, "{vals:?}");
        }
        for (v, l) in vecs.iter().zip(vals) {
            assert!((m * *v - l * *v).length() < 1e-12, "{v} {l}");
        }
    }

    #[test]
    fn eigenvectors_are_orthonormal_also_for_repeated_eigenvalues() {
        for l in [[1.0, 1.0, 3.0], [2.0, 2.0, 2.0], [0.0, 0.0, 1.0], [0.0; 3]] {
            let m = with_axes(DVec3::new(0.3, -0.5, 0.81).normalize(), l);
            let (_, v) = symmetric_eigen3(m);
            let g = DMat3::from_cols(v[0], v[1], v[2]);
            let e = g.transpose() * g - DMat3::IDENTITY;
            assert!(
                e.to_cols_array().iter().all(|x| x.abs() < 1e-12),
                "{l:?}: {g}"
            );
        }
    }

    #[test]
    fn smallest_eigenvector_of_a_rotated_diagonal_is_its_axis() {
        // Eigen gap ≥ 0.2 and ‖M‖ ≤ 9: the vector's error is ≲ ε·9/0.2 ≈ 1e-14, so 1e-12 holds.
        for (n, l) in [
            (DVec3::new(0.3, -0.5, 0.81), [4.0, 9.0, 0.5]),
            (DVec3::new(1.0, 0.0, 0.0), [2.0, 3.0, 0.0]),
            (DVec3::new(-0.2, 0.9, 0.1), [1.0, 1.0, 0.0]),
            (DVec3::new(0.0, 0.0, 1.0), [5.0, 1.0, 0.2]),
            (DVec3::new(0.6, 0.6, -0.2), [-1.0, 2.0, -3.0]),
        ] {
            let n = n.normalize();
            let e = smallest_eigenvector(with_axes(n, l)).expect("defined");
            assert!(
                e.cross(n).length() < 1e-12 && e.is_normalized(),
                "{e} vs {n}"
            );
        }
    }

    #[test]
    fn smallest_eigenvector_is_none_unless_its_eigenspace_is_one_dimensional() {
        // Two equal smallest eigenvalues (a line's second moment), all equal, zero.
        let line = DMat3::from_cols_array_2d(&[[1.0, 0.0, 0.0], [0.0; 3], [0.0; 3]]);
        assert_eq!(smallest_eigenvector(line), None);
        assert_eq!(smallest_eigenvector(DMat3::IDENTITY * 3.0), None);
        assert_eq!(smallest_eigenvector(DMat3::ZERO), None);
        let n = DVec3::new(0.2, 0.3, -0.9).normalize();
        // Rotated, so the gap is only known to round-off: 1e-14 of ‖M‖ is equal, 1e-6 is not.
        assert_eq!(
            smallest_eigenvector(with_axes(n, [5.0, 1.0 + 5e-14, 1.0])),
            None
        );
        let e = smallest_eigenvector(with_axes(n, [5.0, 1.0 + 1e-6, 1.0])).expect("defined");
        assert!(e.cross(n).length() < 1e-7, "{e} vs {n}");
        // Not finite.
        let mut nan = DMat3::IDENTITY;
        nan.y_axis.y = f64::NAN;
        assert_eq!(smallest_eigenvector(nan), None);
        assert_eq!(smallest_eigenvector(DMat3::IDENTITY * f64::INFINITY), None);
    }
}
