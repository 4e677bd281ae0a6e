//! Valleys: where a roof slope runs down into a face that rises above it, the slope and the face
//! meet. Added to the mesher's input, like the wall columns ([`super::wall_columns`]).
//!
//! A sawtooth roof's slopes are imaged near their tops and not down in the valley behind each
//! riser: a pair low on the slope's side sees the riser in front hide the slope's lower part, a
//! pair on the other side sees the slope from behind, and the riser itself is hidden by the next
//! tooth. Poisson then bridges from one tooth's imaged top to the next, and the valley — a metre
//! and more under that bridge — is the bulk of what the factory's mesh misses (quick,
//! factory_site: 2 206 of the 2 208 truth points more than 1.5 m from the mesh lie at z 8–9 m,
//! in the valleys; docs/journal/results.md). A slope does not end in the air at its lowest imaged row:
//! it runs on down its fall line until it meets what stands there.
//!
//! From each detected roof sample more than a support distance (`front_m`) above the terrain —
//! its normal more than [`super::wall_columns::WALL_MAX_TILT_DEG`] from the horizontal and more
//! than [`MIN_SLOPE_DEG`] from the vertical, a fall line the normal's error does not decide —
//! [`valleys`] walks down the fall line in steps of one lattice cell, the height falling with the
//! slope, for at most one resolution cell (`2 × front_m`). The normal is the one Poisson fits,
//! over the support distance: a slope's direction is a property of the patch, and the per-sample
//! tests' normals over half of it measured worse (docs/journal/results.md). The walk
//! - ends with nothing where the slope is imaged on (a sample within a cell of the walk's height
//!   in the column reached: a lower sample starts its own walk), where anything was imaged under
//!   the walk (a lower roof, the ground, a wall's face continued down: what the slope runs into
//!   is not higher than it), where it would go under the terrain, or where it leaves the imaging
//!   region;
//! - meets a face where the column reached holds samples only above the walk's height, no more
//!   than a resolution cell above it, and lies past at least one column the cloud holds nothing
//!   of: a face rising above the slope, at whose foot the slope ends, across what no pair imaged
//!   (next to the walker's own column the image is continuous, and what lies above the walk
//!   there is the slab of a roof imaged with poor vertical resolution, not a face).
//!
//! The slope must be the slope imaged: half a support distance up the fall line from the sample
//! (the radius of the per-sample tests' neighbourhoods, [`super::surface::TEST_NORMAL_SUPPORT_FRACTION`])
//! the cloud holds a sample within a cell of the plane's height, in that column or a neighbour —
//! otherwise the normal is the rim of a vertically smeared slab rather than a slope, and its fall
//! line extrapolates nothing.
//!
//! What the walk meets is the met column's lowest sample, read with its normal:
//! - a face (the normal within [`super::wall_columns::WALL_MAX_TILT_DEG`] of the horizontal), or
//!   the top of one — a roof sloping away along the walk, like the tooth before a sawtooth's
//!   valley, whose riser drops from its top edge: the slope is continued with the sample's
//!   normal down to the face, and the face from its lowest sample down to the slope with a
//!   horizontal normal looking back along the walk;
//! - a roof that reaches back toward the walker — flat (less than [`MIN_SLOPE_DEG`] from the
//!   vertical, its direction undecided) or sloping back toward it: that roof, continued back
//!   along the walk, is over the gap too, so the two slopes meet where their planes cross (a
//!   V valley), and both are continued to that line; where the planes do not cross between the
//!   walker and the met column, above the terrain, the walker lies under the roof it met — a
//!   sample at the foot of a riser whose normal, fitted across the corner, tilts away from it
//!   (the fresh site_71's shallow sawtooth: 11° slopes fitted at 30–50°) — and the walk ran under
//!   an unimaged stretch of that roof into the building: nothing is added.
//!
//! Only the mesh uses the added samples; the fused cloud is unchanged. Units: metres, world
//! frame; z up.

use std::collections::{BTreeMap, BTreeSet};

use glam::{Vec2, Vec3};

use super::facing::TEST_NORMAL_SUPPORT_FRACTION;
use super::wall_columns::{neighbours, WallColumns, WALL_MAX_TILT_DEG};

/// Smallest angle between a roof sample's normal and the vertical at which its fall line is
/// walked, degrees: the normals err by several degrees (surface module docs), so a flatter
/// roof's fall direction is noise.
pub const MIN_SLOPE_DEG: f32 = 10.0;

/// The samples that continue each imaged roof slope down its fall line to a face rising above it,
/// and that face down to the slope (module docs). `points`, `normals` (unit, oriented) and
/// `weights` are the mesher's input (detected and added so far); the first `walkers` of them are
/// the detected samples whose slopes are walked; `cell_m` the lattice; `front_m` the support
/// distance; `floor(p)` the known terrain's height under `p` (`None` where unknown: no walk);
/// `imaged(q)` whether the imaging region covers the ground position `q`.
/// Deterministic: walkers in input order, samples along each walk, duplicates on the lattice
/// dropped.
#[allow(clippy::too_many_arguments)]
pub fn valleys(
    points: &[Vec3],
    normals: &[Vec3],
    weights: &[f32],
    walkers: usize,
    cell_m: f32,
    front_m: f32,
    floor: impl Fn(Vec3) -> Option<f32>,
    imaged: impl Fn(Vec2) -> bool,
) -> WallColumns {
    let mut out = WallColumns::default();
    if !(cell_m > 0.0 && cell_m.is_finite() && front_m > 0.0 && front_m.is_finite()) {
        return out;
    }
    let key = |q: Vec2| ((q.x / cell_m).floor() as i64, (q.y / cell_m).floor() as i64);
    let mut cols: BTreeMap<(i64, i64), Vec<f32>> = BTreeMap::new();
    // Each column's lowest sample: what a walk meets there.
    let mut lowest: BTreeMap<(i64, i64), usize> = BTreeMap::new();
    for (j, p) in points.iter().enumerate().filter(|(_, p)| p.is_finite()) {
        let k = key(p.truncate());
        cols.entry(k).or_default().push(p.z);
        let l = lowest.entry(k).or_insert(j);
        if p.z < points[*l].z {
            *l = j;
        }
    }
    let max_tilt = (90.0 - WALL_MAX_TILT_DEG).to_radians();
    let min_tilt = MIN_SLOPE_DEG.to_radians();
    // One resolution cell along the slope and up the face; half a support distance up the slope.
    let (walk_max, rise_max) = (2.0 * front_m, 2.0 * front_m);
    let up = TEST_NORMAL_SUPPORT_FRACTION * front_m;
    let mut taken: BTreeSet<(i64, i64, i64)> = BTreeSet::new();
    let mut push = |out: &mut WallColumns, p: Vec3, n: Vec3, w: f32| {
        let (x, y) = key(p.truncate());
        if taken.insert((x, y, (p.z / cell_m).floor() as i64)) {
            out.points.push(p);
            out.normals.push(n);
            out.weights.push(w);
        }
    };
    for i in 0..walkers.min(points.len()).min(normals.len()) {
        let (p, n) = (points[i], normals[i]);
        if !p.is_finite() || !n.is_finite() || n.z <= 0.0 {
            continue;
        }
        // A roof, not the ground's image: more than a support distance above the terrain.
        let Some(ground) = floor(p).filter(|g| p.z > g + front_m) else {
            continue;
        };
        let tilt = n.z.clamp(-1.0, 1.0).acos();
        if tilt < min_tilt || tilt > max_tilt {
            continue;
        }
        let down = Vec2::new(n.x, n.y).normalize_or_zero();
        if down == Vec2::ZERO {
            continue;
        }
        let fall = tilt.tan();
        // The slope imaged up the fall line.
        let plane = p.z + up * fall;
        let seen = neighbours(key(p.truncate() - down * up))
            .filter_map(|k| cols.get(&k))
            .flatten()
            .any(|&h| (h - plane).abs() <= cell_m);
        if !seen {
            continue;
        }
        // Down the fall line to the first column the cloud holds anything of.
        let mut met = None;
        let mut t = cell_m;
        while t <= walk_max {
            let q = p.truncate() + down * t;
            let z = p.z - t * fall;
            if !imaged(q) || z < ground {
                break;
            }
            if let Some(h) = cols.get(&key(q)) {
                if h.iter().any(|&h| (h - z).abs() <= cell_m || h < z - cell_m) {
                    break;
                }
                let j = lowest[&key(q)];
                if points[j].z - z <= rise_max && t > 1.5 * cell_m {
                    met = Some((t, j));
                }
                break;
            }
            t += cell_m;
        }
        let Some((t_met, j)) = met else {
            continue;
        };
        let w = weights.get(i).copied().unwrap_or(1.0);
        let (low, m) = (points[j], normals.get(j).copied().unwrap_or(Vec3::X));
        let m_tilt = m.z.clamp(-1.0, 1.0).acos();
        let m_down = Vec2::new(m.x, m.y).dot(down);
        // Where the slope ends along the walk; then the roof met continued back to that line
        // (`Some`: the height at 0 and the rise per metre along the walk), or the face.
        let (t_end, roof) =
            if m.is_finite() && m_tilt <= max_tilt && (m_tilt < min_tilt || m_down < 0.0) {
                // A roof met, flat or sloping back toward the walker: the slopes meet where
                // their planes cross, or the walk ran under that roof (module docs).
                let rise = -m_down / m.z;
                let z0 = low.z - (p.truncate() - low.truncate()).dot(Vec2::new(m.x, m.y)) / m.z;
                let t_v = (p.z - z0) / (fall + rise);
                if !(t_v > 0.0 && t_v < t_met) || p.z - t_v * fall < ground {
                    continue;
                }
                (t_v, Some((z0, rise)))
            } else {
                (t_met, None)
            };
        let at = |s: f32| p.truncate() + down * s;
        let mut s = cell_m;
        while s < t_end {
            push(&mut out, at(s).extend(p.z - s * fall), n, w);
            s += cell_m;
        }
        if let Some((z0, rise)) = roof {
            let mut s = t_end;
            while s < t_met - 0.5 * cell_m {
                push(&mut out, at(s).extend(z0 + s * rise), m, w);
                s += cell_m;
            }
        } else {
            let face = (-down).extend(0.0);
            let mut z = p.z - t_met * fall;
            while z < low.z - 0.5 * cell_m {
                push(&mut out, at(t_met).extend(z), face, w);
                z += cell_m;
            }
        }
        out.columns += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lattice and the support distance of the tests (the quick preset's, about).
    const CELL: f32 = 0.5;
    const FRONT: f32 = 2.0;

    /// A sawtooth's tooth rising toward +y from z = 8 at y = 0 to z = 10.5 at y = 4.8, and the
    /// riser of the tooth before it at y = 0 (z 8–10.5, facing +y).
    fn tooth_height(y: f32) -> f32 {
        8.0 + 2.5 * y / 4.8
    }

    /// The slope's normal: up, and toward −y (down the fall line).
    fn slope_normal() -> Vec3 {
        Vec3::new(0.0, -2.5, 4.8).normalize()
    }

    /// Samples at the lattice cells' centres over x 0–5 m, for each `y`, at `z(y)`.
    fn rows(ys: &[f32], z: impl Fn(f32) -> f32, n: Vec3, out: &mut (Vec<Vec3>, Vec<Vec3>)) {
        for &y in ys {
            for k in 0..10 {
                out.0.push(Vec3::new(0.25 + CELL * k as f32, y, z(y)));
                out.1.push(n);
            }
        }
    }

    /// What a sawtooth's pairs image: this tooth's slope from `y_from` up to its top, and the
    /// top of the tooth before it (its slope's last 1.5 m, behind the riser at y = 0).
    fn sawtooth(y_from: f32) -> (Vec<Vec3>, Vec<Vec3>) {
        let mut s = (Vec::new(), Vec::new());
        let ys: Vec<f32> = (0..10)
            .map(|k| y_from + CELL * k as f32)
            .filter(|&y| y < 4.8)
            .collect();
        rows(&ys, tooth_height, slope_normal(), &mut s);
        rows(
            &[-1.25, -0.75, -0.25],
            |y| tooth_height(y + 4.8),
            slope_normal(),
            &mut s,
        );
        s
    }

    fn run(p: &[Vec3], n: &[Vec3]) -> WallColumns {
        valleys(
            p,
            n,
            &vec![1.0; p.len()],
            p.len(),
            CELL,
            FRONT,
            |_| Some(0.0),
            |_| true,
        )
    }

    /// Distance from `p` to the true sawtooth in the y–z plane: this tooth's slope (y 0–4.8 m)
    /// and the riser at y = 0 (z 8–10.5 m).
    fn off_sawtooth(p: Vec3) -> f32 {
        let segment = |a: Vec2, b: Vec2| {
            let q = Vec2::new(p.y, p.z);
            let t = ((q - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
            q.distance(a + (b - a) * t)
        };
        let slope = segment(Vec2::new(0.0, 8.0), Vec2::new(4.8, 10.5));
        let riser = segment(Vec2::new(0.0, 8.0), Vec2::new(0.0, 10.5));
        slope.min(riser)
    }

    #[test]
    fn a_sawtooth_slope_imaged_near_its_top_runs_down_into_the_riser_behind_it() {
        let (p, n) = sawtooth(2.25);
        let v = run(&p, &n);
        assert!(v.points.len() >= 20, "{} samples", v.points.len());
        for q in &v.points {
            assert!(off_sawtooth(*q) < CELL, "{q} is {} m off", off_sawtooth(*q));
        }
        // The valley is reached: the slope continued to within a cell of the riser, and the
        // riser continued down to within a cell of the valley's floor.
        let lowest = v.points.iter().map(|q| q.z).fold(f32::INFINITY, f32::min);
        assert!(lowest < 8.0 + CELL, "lowest added sample at {lowest} m");
        assert!(v.points.iter().any(|q| q.y < 0.0 && q.z > 9.0));
        // Riser samples face the slope (+y), slope samples keep the slope's normal.
        for (q, m) in v.points.iter().zip(&v.normals) {
            assert!(m.abs_diff_eq(Vec3::Y, 1e-6) || m.abs_diff_eq(slope_normal(), 1e-6));
            if m.abs_diff_eq(Vec3::Y, 1e-6) {
                assert!(q.y < 0.5, "{q}");
            }
        }
    }

    #[test]
    fn two_slopes_falling_toward_each_other_meet_where_their_planes_cross() {
        // A V valley at y = 0, z = 8: this tooth's slope (y > 0), imaged from 2.25 m up, and a
        // mirrored slope (y < 0) facing back toward it, imaged from 1.25 m up.
        let (mut p, mut n) = (Vec::new(), Vec::new());
        let mut s = (Vec::new(), Vec::new());
        let ys: Vec<f32> = (0..6).map(|k| 2.25 + CELL * k as f32).collect();
        rows(&ys, tooth_height, slope_normal(), &mut s);
        let mirrored = slope_normal() * Vec3::new(1.0, -1.0, 1.0);
        let ys: Vec<f32> = (0..6).map(|k| -1.25 - CELL * k as f32).collect();
        rows(&ys, |y| tooth_height(-y), mirrored, &mut s);
        p.extend(s.0);
        n.extend(s.1);
        let v = run(&p, &n);
        assert!(v.points.len() >= 20, "{} samples", v.points.len());
        // Distance to the slope on the sample's side of the valley.
        let off_v = |q: Vec3| ((q.z - tooth_height(q.y.abs())) * slope_normal().z).abs();
        for q in &v.points {
            assert!(off_v(*q) < 1e-3, "{q} is {} m off the slopes", off_v(*q));
        }
        // Both slopes reach down to the valley's line.
        for side in [1.0, -1.0] {
            let lowest = v
                .points
                .iter()
                .filter(|q| q.y * side >= 0.0)
                .map(|q| q.z)
                .fold(f32::INFINITY, f32::min);
            assert!(
                lowest < 8.0 + CELL,
                "side {side}: lowest added sample at {lowest} m"
            );
        }
    }

    #[test]
    fn a_walk_under_a_roof_reaching_back_toward_it_adds_nothing() {
        // At the foot of a riser the normal fitted across the corner tilts away from the riser
        // (35° on an 11° sawtooth): its fall line runs under the next stretch of roof, imaged
        // only 3.5 m on at 8.5 m, flat or sloping back down toward the walker.
        for back_deg in [0.0_f32, 11.0] {
            let mut s = (Vec::new(), Vec::new());
            let steep = Vec3::new(0.0, -35f32.to_radians().sin(), 35f32.to_radians().cos());
            let ys: Vec<f32> = (0..4).map(|k| 2.25 + CELL * k as f32).collect();
            rows(
                &ys,
                |y| 7.5 + (y - 2.25) * 35f32.to_radians().tan(),
                steep,
                &mut s,
            );
            let (sin, cos) = back_deg.to_radians().sin_cos();
            let ys: Vec<f32> = (0..4).map(|k| -1.25 - CELL * k as f32).collect();
            let roof = Vec3::new(0.0, sin, cos);
            rows(&ys, |y| 8.5 - (y + 1.25) * sin / cos, roof, &mut s);
            let v = run(&s.0, &s.1);
            assert!(
                v.points.is_empty(),
                "{back_deg}°: {} samples",
                v.points.len()
            );
        }
    }

    #[test]
    fn a_slope_whose_fall_line_meets_nothing_higher_adds_nothing() {
        // A gable's slope over its eave: open air down the fall line.
        let mut s = (Vec::new(), Vec::new());
        let ys: Vec<f32> = (0..6).map(|k| 2.25 + CELL * k as f32).collect();
        rows(&ys, tooth_height, slope_normal(), &mut s);
        assert!(run(&s.0, &s.1).points.is_empty());
    }

    #[test]
    fn a_slope_facing_a_face_imaged_down_to_the_ground_across_a_passage_adds_nothing() {
        // A taller building's face at y = 0 whose image (or its continued wall) reaches down to
        // the ground: what the slope runs toward is not higher than the slope everywhere.
        let (mut p, mut n) = sawtooth(2.25);
        let mut face = (Vec::new(), Vec::new());
        for k in 0..20 {
            rows(&[-0.25], |_| 0.5 * k as f32, Vec3::Y, &mut face);
        }
        p.extend(face.0);
        n.extend(face.1);
        assert!(run(&p, &n).points.is_empty());
    }

    #[test]
    fn a_riser_taller_than_a_resolution_cell_above_the_walk_is_not_met() {
        // The tooth before stands 5 m higher: more than two support distances of face nobody
        // saw between the walk and its lowest sample.
        let (mut p, n) = sawtooth(2.25);
        for q in p.iter_mut().filter(|q| q.y < 0.0) {
            q.z += 5.0;
        }
        assert!(run(&p, &n).points.is_empty());
    }

    #[test]
    fn a_higher_image_in_the_very_next_column_is_a_smeared_slab_and_not_a_face() {
        // Right below the slope's lowest imaged row, the next column holds samples above the
        // walk's height (the roof's image a slab metres thick, not a face across a gap).
        let mut s = sawtooth(2.25);
        let lowest = tooth_height(2.25);
        for dz in [1.0, 1.5] {
            rows(&[1.75], |_| lowest + dz, Vec3::Z, &mut s);
        }
        let v = run(&s.0, &s.1);
        assert!(v.points.is_empty(), "{} samples", v.points.len());
    }

    #[test]
    fn a_tilted_normal_without_its_slope_imaged_up_the_fall_line_walks_nowhere() {
        // One row of samples whose normals tilt (the rim of a vertically smeared flat roof), the
        // higher tooth top ahead as before: up the fall line nothing was imaged on the plane.
        let (p, n) = sawtooth(2.25);
        let keep: Vec<usize> = (0..p.len())
            .filter(|&i| p[i].y < 0.0 || (p[i].y - 2.25).abs() < 1e-3)
            .collect();
        let p: Vec<Vec3> = keep.iter().map(|&i| p[i]).collect();
        let n: Vec<Vec3> = keep.iter().map(|&i| n[i]).collect();
        assert!(run(&p, &n).points.is_empty());
    }

    #[test]
    fn no_lattice_or_no_support_distance_adds_nothing() {
        let (p, n) = sawtooth(2.25);
        let w = vec![1.0; p.len()];
        for (cell, front) in [
            (0.0, FRONT),
            (CELL, 0.0),
            (f32::NAN, FRONT),
            (CELL, f32::INFINITY),
        ] {
            assert!(
                valleys(&p, &n, &w, p.len(), cell, front, |_| Some(0.0), |_| true)
                    .points
                    .is_empty()
            );
        }
    }
}
