//! A footprint's wall across the gaps between its imaged pieces.
//!
//! Where a building's imaged walls outline a rectangle ([`super::hidden_roofs`]), each side of
//! the rectangle is one wall from corner to corner, from the roof down to the terrain. What
//! the other rules give of it comes in pieces: the stretches a pair imaged, the walls continued
//! under them ([`super::wall_columns`]) and the walls stood under the roof's edge
//! ([`super::wall_columns::roof_edge_walls`]). Between the pieces lie stretches with no wall at
//! all: a face no pair saw whose roof edge was imaged with its normals turned (the rim of a
//! roof's image, a resolution cell thick, reads as a wall looking into the building, so no
//! roof edge is found there) or was not imaged. On held-out district_55 (quick) three such gaps
//! of 2–4 m along one face of a 20 m block held most of the mesh's completeness error.
//!
//! Along each side of a rectangular footprint, at every lattice cell, the side is *covered*
//! where a wall sample (normal within [`WALL_MAX_TILT_DEG`] of the horizontal) of the mesher's
//! input lies within the support distance of it; a stretch not covered with covered stretches
//! on both sides along the same side is a gap in one wall, and gets a column of samples from a
//! cell under the roof's height down to what it stands on, facing out of the side, with the
//! median weight of the side's covering samples. Only gaps *between* pieces are filled — the
//! pieces say the wall is there; beyond the last piece toward a corner the side may have been
//! placed where the imaged walls ended (a side no wall images), not where the building ends.
//! The walls under the edges of an added roof (one no pair saw, [`super::hidden_roofs`]) are
//! no pieces: that roof ends on the footprint by construction, so they say nothing of where
//! the building ends (on district_51, where a side of a glass block was placed 2.3 m inside the
//! true face, counting them filled 370 m² of false wall along it; docs/journal/results.md).
//! Units: metres, world frame; z up.

use glam::{Vec2, Vec3};

use super::hidden_roofs::{Footprint, Outline};
use super::wall_columns::{WallColumns, WALL_MAX_TILT_DEG};

/// The samples of the walls across the gaps along each rectangular footprint's sides (module
/// docs). `points`, `normals` (unit, oriented) and `weights` are the mesher's input;
/// `footprints` the buildings' ([`super::hidden_roofs::hidden_roofs`]); `added_roofs` the roof
/// samples added over them (a wall sample in a lattice column holding one is no piece);
/// `cell_m` the lattice;
/// `front_m` the support distance; `floor(p)` what a wall at `p` stands on (`None`: unknown,
/// nothing added). Deterministic: footprints, sides and positions in order.
#[allow(clippy::too_many_arguments)]
pub fn outline_walls(
    points: &[Vec3],
    normals: &[Vec3],
    weights: &[f32],
    footprints: &[Footprint],
    added_roofs: &[Vec3],
    cell_m: f32,
    front_m: f32,
    floor: impl Fn(Vec3) -> Option<f32>,
) -> WallColumns {
    let mut out = WallColumns::default();
    if !(cell_m > 0.0 && cell_m.is_finite() && front_m > 0.0 && front_m.is_finite()) {
        return out;
    }
    let max_nz = WALL_MAX_TILT_DEG.to_radians().sin();
    let column = |p: Vec3| ((p.x / cell_m).floor() as i64, (p.y / cell_m).floor() as i64);
    let added: std::collections::HashSet<(i64, i64)> =
        added_roofs.iter().map(|&p| column(p)).collect();
    let walls: Vec<usize> = (0..points.len().min(normals.len()))
        .filter(|&i| points[i].is_finite() && normals[i].z.abs() < max_nz)
        .filter(|&i| !added.contains(&column(points[i])))
        .collect();
    for f in footprints {
        let Outline::Rectangle(c) = f.outline else {
            continue;
        };
        if !f.height_m.is_finite() {
            continue;
        }
        for s in 0..4 {
            let (a, b) = (c[s], c[(s + 1) % 4]);
            let len = a.distance(b);
            if len <= cell_m {
                continue;
            }
            let u = (b - a) / len;
            // Corners counter-clockwise: the outside is to the right of a → b.
            let out_n = Vec2::new(u.y, -u.x);
            let steps = (len / cell_m).floor() as usize;
            let at = |k: usize| a + u * ((k as f32 + 0.5) * cell_m);
            // The wall samples near the side, and which positions they cover.
            let near: Vec<usize> = walls
                .iter()
                .copied()
                .filter(|&i| {
                    let d = points[i].truncate() - a;
                    d.dot(out_n).abs() <= front_m
                        && (-front_m..=len + front_m).contains(&d.dot(u))
                        && points[i].z <= f.height_m + front_m
                })
                .collect();
            let covered: Vec<bool> = (0..steps)
                .map(|k| {
                    let q = at(k);
                    near.iter()
                        .any(|&i| points[i].truncate().distance(q) <= front_m)
                })
                .collect();
            let (Some(first), Some(last)) = (
                covered.iter().position(|&x| x),
                covered.iter().rposition(|&x| x),
            ) else {
                continue;
            };
            let mut w: Vec<f32> = near
                .iter()
                .map(|&i| weights.get(i).copied().unwrap_or(1.0))
                .collect();
            w.sort_by(f32::total_cmp);
            let weight = w.get(w.len() / 2).copied();
            let normal = out_n.extend(0.0);
            for (k, _) in covered
                .iter()
                .enumerate()
                .take(last + 1)
                .skip(first)
                .filter(|(_, &c)| !c)
            {
                let q = at(k).extend(f.height_m);
                let Some(lo) = floor(q) else {
                    continue;
                };
                let hi = f.height_m - cell_m;
                if hi >= lo {
                    out.push_column(q, normal, weight.as_ref(), (hi, lo), cell_m);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const CELL: f32 = 0.5;
    const FRONT: f32 = 1.3;

    /// A 12 × 8 m building 8 m high at the origin.
    fn footprint() -> Footprint {
        Footprint {
            centre: Vec2::new(6.0, 4.0),
            outline: Outline::Rectangle([
                Vec2::new(0.0, 0.0),
                Vec2::new(12.0, 0.0),
                Vec2::new(12.0, 8.0),
                Vec2::new(0.0, 8.0),
            ]),
            height_m: 8.0,
            samples: 0,
            yard: Default::default(),
            yard_cell_m: CELL,
        }
    }

    /// Pieces of the south wall (facing −y) over `x0..x1`, every 0.5 m from 0.5 to 8 m.
    fn piece(p: &mut Vec<Vec3>, n: &mut Vec<Vec3>, x0: f32, x1: f32) {
        let mut x = x0;
        while x <= x1 + 1e-3 {
            for k in 1..=16 {
                p.push(Vec3::new(x, 0.1, 0.5 * k as f32));
                n.push(Vec3::NEG_Y);
            }
            x += CELL;
        }
    }

    fn walls(p: &[Vec3], n: &[Vec3], added: &[Vec3]) -> WallColumns {
        let w = vec![0.5; p.len()];
        outline_walls(p, n, &w, &[footprint()], added, CELL, FRONT, |_| Some(0.0))
    }

    #[test]
    fn a_gap_between_two_pieces_of_a_side_is_walled_from_the_roof_to_the_terrain() {
        let (mut p, mut n) = (Vec::new(), Vec::new());
        piece(&mut p, &mut n, 0.25, 3.0);
        piece(&mut p, &mut n, 9.0, 11.75);
        let c = walls(&p, &n, &[]);
        // The gap is 6 m; the pieces cover the support distance into it from either end.
        let xs: Vec<f32> = c.points.iter().map(|q| q.x).collect();
        let (lo, hi) = xs
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            });
        assert!(
            lo > 3.0 + FRONT - CELL && hi < 9.0 - FRONT + CELL,
            "{lo} {hi}"
        );
        assert!(
            lo < 3.0 + FRONT + CELL && hi > 9.0 - FRONT - CELL,
            "{lo} {hi}"
        );
        for (q, m) in c.points.iter().zip(&c.normals) {
            assert!(q.y.abs() < 1e-4 && (0.0..=7.5 + 1e-4).contains(&q.z), "{q}");
            assert_eq!(*m, Vec3::NEG_Y);
        }
        // From 7.5 m down to the terrain at 0, every 0.5 m.
        assert_eq!(c.points.len(), c.columns * 16);
        assert!(c.weights.iter().all(|&w| w == 0.5));
    }

    #[test]
    fn beyond_the_last_piece_toward_a_corner_nothing_is_added() {
        let (mut p, mut n) = (Vec::new(), Vec::new());
        piece(&mut p, &mut n, 0.25, 3.0);
        assert_eq!(walls(&p, &n, &[]).points.len(), 0);
    }

    #[test]
    fn a_wall_under_an_added_roof_is_no_piece() {
        let (mut p, mut n) = (Vec::new(), Vec::new());
        piece(&mut p, &mut n, 0.25, 3.0);
        piece(&mut p, &mut n, 9.0, 11.75);
        // The east piece stands under the edge of a roof added over the footprint.
        let added: Vec<Vec3> = p
            .iter()
            .filter(|q| q.x > 8.0)
            .map(|q| q.with_z(8.0))
            .collect();
        assert_eq!(walls(&p, &n, &added).points.len(), 0);
        assert!(!walls(&p, &n, &[]).points.is_empty());
    }
}
