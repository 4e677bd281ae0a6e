//! A pair's detections in the skirt of its point-spread function, moved to the echo's power
//! centroid along the direction the pair resolves worst.
//!
//! **Why.** A pair resolves a place along four directions ([`pair_resolution_axes`]): the bistatic
//! range (≈ 0.4 m here), the track's cross-range (0.2–0.5 m), and the panel's horizontal and
//! vertical cross-ranges (1.8 m and 3.6 m for a 1 m × 0.5 m panel at 60 m). Its image of an echo
//! is therefore an ellipsoid several metres long along the worst-resolved direction — for a
//! vehicle's pair, about vertical. Where the echo is strong, the detection test (against the
//! bare site's clutter, [`super::detection`]) passes the ellipsoid's skirt too: a wall's image
//! runs 1–2 m past its top edge into free air, and at the default preset these points carried
//! ~70 % of the suite clouds' accuracy term (docs/journal/results.md), 73–85 % of them above the truth.
//!
//! **The rule.** For each detection `p` of a pair, take the pair's resolution at `p` as the
//! information matrix `J = Σ_i a_i a_iᵀ / δ_i²` over the four directions `a_i` and resolutions
//! `δ_i`; its weakest eigenvector `ŵ` is the worst-resolved direction and `e = λ_min^{−1/2}` the
//! extent along it. The window is the pair's detections `q` within `±e/2` of `p` along `ŵ` and
//! within one voxel diagonal `√2·v` of the line through `p` along `ŵ` (the voxel column the
//! ellipsoid's axis crosses). A detection whose power `|I(p)|²` is below half the window's
//! strongest, `max |I(q)|²`, lies outside that echo's half-power cell — its resolution cell —
//! and is the skirt of it: it moves to the window's power centroid along `ŵ`,
//! `p + ŵ·Σ|I(q)|²(q − p)·ŵ / Σ|I(q)|²`. Detections at or above half the strongest stay where
//! the image put them: they are the echo's core, or a surface extended along `ŵ` (a wall seen
//! from a vehicle, whose plateau is not moved). Nothing is removed.
//!
//! The window's own points decide, so the rule needs no threshold beyond the half-power
//! definition of a resolution cell. Measured on the suite's saved clouds (docs/journal/results.md):
//! default preset, cloud √CD 0.98 → 0.86 m (factory_site), 0.96 → 0.85 (factory_rotated), 1.18
//! → 1.09 (office_pair), 1.32 → 1.18 (street_row, before its grating-lobe fix); the quick preset,
//! whose thinned arrays detect little more than the cores, within ±0.03 m.
//!
//! **Smear across a surface** (`imaging.smear_centroid`, [`smear_to_centroid`]). The same
//! ellipsoid lies across any surface that crosses `ŵ`: a roof seen by a vehicle's pair, or by a
//! UAV's pair far off its track, is imaged as a slab `e` thick, and within it the speckle of the
//! roof's many scatterers puts detections at any height, each at or above half the power of its
//! column's strongest (a slab, not a skirt). Where the pair's own detections within `e` of `p`
//! (at least [`super::finer_height::NORMAL_NEIGHBOURS`]) form a surface whose normal — their
//! least spread — lies within 45° of `ŵ`, `p` moves to the power centroid along `ŵ` of the
//! pair's detections within `±e` of it along `ŵ` and one voxel diagonal of its axis (the slab,
//! up to `e` thick, lies within that window from any of its detections): the slab's surface,
//! one height per column. Where the normal lies across
//! `ŵ` the surface runs along it (a wall seen from a vehicle) and only the skirt rule applies. The
//! fusion does this to each pair's cloud before fusing ([`crate::imaging::run::fuse_images`]),
//! so pair clouds saved by a run are collapsed when read back.
//!
//! Units: metres, powers relative (`|I|²` of the pair's normalised intensities); world frame.

use glam::{DMat3, DVec3, Vec3};
use rayon::prelude::*;

use crate::knn::PointIndex;
use crate::linalg::symmetric_eigen3;
use crate::mesh::normals::pca_normal;
use crate::sensors::{pair_resolution_axes, PlanarArray, VirtualAperture};

/// The direction a pair resolves worst at `point` (unit) and its extent there, metres: the
/// weakest eigenvector of the pair's information matrix `Σ a aᵀ/δ²` (module docs) and `λ^{−1/2}`.
pub fn worst_axis(
    point: Vec3,
    array: &PlanarArray,
    aperture: &VirtualAperture,
    wavelength_m: f32,
    bandwidth_hz: f32,
) -> (Vec3, f32) {
    let mut j = DMat3::ZERO;
    for (a, d) in pair_resolution_axes(point, array, aperture, wavelength_m, bandwidth_hz) {
        let a = a.as_dvec3();
        let w = 1.0 / (d as f64).powi(2).max(1e-12);
        j += DMat3::from_cols(a * a.x, a * a.y, a * a.z) * w;
    }
    let (vals, vecs) = symmetric_eigen3(j);
    let axis = vecs[0];
    let extent = 1.0 / vals[0].max(1e-12).sqrt();
    let axis = if axis == DVec3::ZERO { DVec3::Z } else { axis };
    (axis.as_vec3(), extent as f32)
}

/// The power of a pair's detections in the column through `p` along `w`: those of `near` within
/// `±reach` of `p` along `w` and within `column` of the axis, summed in `near`'s order.
struct Column {
    /// `Σ |I|²`.
    power: f64,
    /// `Σ |I|²·(q − p)·w`.
    moment: f64,
    /// `max |I|²`.
    max_power: f64,
}

impl Column {
    fn of(
        points: &[Vec3],
        intensity: &[f32],
        near: &[(u32, f32)],
        p: Vec3,
        w: Vec3,
        reach: f32,
        column: f32,
    ) -> Column {
        let mut c = Column {
            power: 0.0,
            moment: 0.0,
            max_power: 0.0,
        };
        for &(k, _) in near {
            let d = points[k as usize] - p;
            let off = d.dot(w);
            if off.abs() > reach || (d - w * off).length() > column {
                continue;
            }
            let pw = (intensity[k as usize] as f64).powi(2);
            c.max_power = c.max_power.max(pw);
            c.power += pw;
            c.moment += pw * off as f64;
        }
        c
    }

    /// `p` moved along `w` to the column's power centroid.
    fn centroid(&self, p: Vec3, w: Vec3) -> Vec3 {
        p + w * (self.moment / self.power) as f32
    }
}

/// The pair's detections with those in a PSF skirt moved to their echo's power centroid (module
/// docs). `intensity` is `|I|` per point (any common scale), `voxel_m` the image's voxel edge.
/// Deterministic: each point depends only on the input, neighbours summed in index order.
pub fn skirt_to_centroid(
    points: &[Vec3],
    intensity: &[f32],
    array: &PlanarArray,
    aperture: &VirtualAperture,
    wavelength_m: f32,
    bandwidth_hz: f32,
    voxel_m: f32,
) -> Vec<Vec3> {
    let Ok(index) = PointIndex::new("pair points", points) else {
        return points.to_vec();
    };
    let column = std::f32::consts::SQRT_2 * voxel_m;
    points
        .par_iter()
        .zip(intensity)
        .map(|(&p, &ip)| {
            let (w, extent) = worst_axis(p, array, aperture, wavelength_m, bandwidth_hz);
            let half = 0.5 * extent;
            let mut near = index.within(p, (half * half + column * column).sqrt());
            near.sort_unstable_by_key(|&(k, _)| k);
            let c = Column::of(points, intensity, &near, p, w, half, column);
            if (ip as f64).powi(2) >= 0.5 * c.max_power || c.power <= 0.0 {
                p
            } else {
                c.centroid(p, w)
            }
        })
        .collect()
}

/// Cosine of the largest angle between a pair's worst-resolved direction and the normal of the
/// surface its own points form there for that surface to *cross* the direction (45°, the
/// bisector between crossing and running along it, as [`super::finer_height`]).
const CROSSING_COS: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// Fewest of the pair's own points within its extent for their surface's normal to be judged
/// (the mesher's neighbourhood, [`super::finer_height::NORMAL_NEIGHBOURS`]).
const SMEAR_NEIGHBOURS: usize = super::finer_height::NORMAL_NEIGHBOURS;

/// The pair's detections on a surface that crosses its worst-resolved direction, each moved to
/// its column's power centroid along that direction (module docs, *Smear across a surface*).
/// Detections where the pair's own points run along the direction, or where fewer than
/// [`SMEAR_NEIGHBOURS`] lie within the extent, stay. Deterministic as [`skirt_to_centroid`].
pub fn smear_to_centroid(
    points: &[Vec3],
    intensity: &[f32],
    array: &PlanarArray,
    aperture: &VirtualAperture,
    wavelength_m: f32,
    bandwidth_hz: f32,
    voxel_m: f32,
) -> Vec<Vec3> {
    let Ok(index) = PointIndex::new("pair points", points) else {
        return points.to_vec();
    };
    let column = std::f32::consts::SQRT_2 * voxel_m;
    points
        .par_iter()
        .map(|&p| {
            let (w, extent) = worst_axis(p, array, aperture, wavelength_m, bandwidth_hz);
            // A slab is up to `e` thick: a window of `±e` about any of its detections holds it.

            let reach = extent;
            let mut near = index.within(p, (reach * reach + column * column).sqrt());
            if near.len() < SMEAR_NEIGHBOURS {
                return p;
            }
            near.sort_unstable_by_key(|&(k, _)| k);
            // The normal of the pair's own points within its extent: a slab one extent thick and
            // at least two across has its least spread across the surface it smears.
            let normal = pca_normal(near.iter().map(|&(k, _)| points[k as usize]));
            if normal.dot(w).abs() < CROSSING_COS {
                return p;
            }
            let c = Column::of(points, intensity, &near, p, w, reach, column);
            if c.power <= 0.0 {
                p
            } else {
                c.centroid(p, w)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair() -> (PlanarArray, VirtualAperture) {
        (
            PlanarArray {
                centre: Vec3::new(-60.0, 0.0, 20.0),
                boresight_az_rad: 0.0,
                rows: 32,
                cols: 32,
                width_m: 1.0,
                height_m: 0.5,
            },
            VirtualAperture {
                start: Vec3::new(-1.5, -20.0, 1.5),
                end: Vec3::new(1.5, -20.0, 1.5),
                positions: 101,
            },
        )
    }

    const LAMBDA: f32 = 0.03;
    const B: f32 = 400e6;

    #[test]
    fn a_vehicle_pair_resolves_the_vertical_worst() {
        let (a, v) = pair();
        let (w, e) = worst_axis(Vec3::new(0.0, 0.0, 8.0), &a, &v, LAMBDA, B);
        assert!(w.z.abs() > 0.9, "worst axis {w}");
        // The panel's vertical cross-range sets it (within the tilt of the line of sight), and
        // it is coarser than the three other resolutions.
        let axes = pair_resolution_axes(Vec3::new(0.0, 0.0, 8.0), &a, &v, LAMBDA, B);
        let vertical = axes[3].1;
        assert!(
            (e / vertical - 1.0).abs() < 0.05,
            "extent {e} vs {vertical}"
        );
        assert!(axes[..3].iter().all(|&(_, d)| d < e), "{axes:?}");
    }

    /// A wall's column as a vehicle pair images it: a plateau of equal power from z 0.5 to 8 m,
    /// and a skirt falling off above the edge. The plateau stays; the skirt moves down toward the
    /// wall, and no point moves away from it.
    #[test]
    fn the_skirt_above_a_wall_moves_toward_it_and_the_plateau_stays() {
        let (a, v) = pair();
        let voxel = 0.25;
        let mut pts = Vec::new();
        let mut amp = Vec::new();
        for k in 0..40 {
            let z = 0.5 + k as f32 * voxel;
            pts.push(Vec3::new(0.0, 0.0, z));
            amp.push(if z <= 8.0 {
                1.0
            } else {
                (-(z - 8.0) / 0.6).exp()
            });
        }
        let out = skirt_to_centroid(&pts, &amp, &a, &v, LAMBDA, B, voxel);
        for ((p, q), &i) in pts.iter().zip(&out).zip(&amp) {
            if i * i >= 0.5 {
                assert_eq!(p, q, "a core point moved");
            } else {
                assert!(q.z < p.z && q.z >= 7.0, "skirt {p} -> {q}");
                assert!((q.x - p.x).abs() < 0.3 && (q.y - p.y).abs() < 0.3);
            }
        }
        // Something did move (the skirt exists in this column).
        assert!(pts.iter().zip(&out).any(|(p, q)| p != q));
    }

    /// A roof 8 m up as the vehicle pair images it: a slab of detections at every height within
    /// its vertical extent, of speckled power. Each column collapses to one height near the
    /// roof. A wall the same pair images (a vertical plateau, the surface along its worst axis)
    /// does not move.
    #[test]
    fn a_slab_across_the_worst_axis_collapses_and_a_wall_along_it_stays() {
        let (a, v) = pair();
        let voxel = 0.25;
        let (_, e) = worst_axis(Vec3::new(0.0, 0.0, 8.0), &a, &v, LAMBDA, B);
        let mut pts = Vec::new();
        let mut amp = Vec::new();
        let mut k = 0u32;
        for i in -8..=8 {
            for j in -8..=8 {
                for h in -3..=3 {
                    k = k.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                    let dz = h as f32 * 0.12 * e;
                    pts.push(Vec3::new(i as f32 * voxel, j as f32 * voxel, 8.0 + dz));
                    amp.push(0.3 + 0.7 * ((k >> 16) % 1000) as f32 / 1000.0);
                }
            }
        }
        let spread = |p: &[Vec3]| {
            (p.iter().map(|q| (q.z - 8.0).powi(2)).sum::<f32>() / p.len() as f32).sqrt()
        };
        let out = smear_to_centroid(&pts, &amp, &a, &v, LAMBDA, B, voxel);
        assert!(
            spread(&out) < 0.35 * spread(&pts),
            "slab rms {} -> {}",
            spread(&pts),
            spread(&out)
        );
        let wall: Vec<Vec3> = (-8..=8)
            .flat_map(|j| {
                (0..32).map(move |h| Vec3::new(0.0, j as f32 * voxel, 0.5 + h as f32 * voxel))
            })
            .collect();
        let flat = vec![1.0; wall.len()];
        assert_eq!(
            smear_to_centroid(&wall, &flat, &a, &v, LAMBDA, B, voxel),
            wall
        );
    }

    #[test]
    fn a_lone_detection_stays() {
        let (a, v) = pair();
        let p = [Vec3::new(1.0, 2.0, 3.0)];
        assert_eq!(skirt_to_centroid(&p, &[0.1], &a, &v, LAMBDA, B, 0.25), p);
    }
}
