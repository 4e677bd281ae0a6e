//! Echoes of the known terrain that the detection passed, told from the surfaces of structures by
//! their height: a fused point that lies within the vertical resolution of the pairs that
//! detected it above the terrain, with nothing of the cloud above that layer around it, is the
//! terrain's own echo, not a twin surface (issue 13, item 3).
//!
//! **Why.** The detection ([`super::detection`]) references each voxel to the clutter the bare
//! terrain would give, which holds where the terrain's scatterers are many per resolution cell
//! (exponential speckle). Where they are few — a sparse or smooth ground, or the cell of a track
//! that resolves the ground finely — a single strong ground scatterer is a point target, detected
//! like a corner of a building and confirmed by every pair that sees it (it echoes towards all of
//! them). A pair cannot place it above the terrain more finely than its resolution cell's
//! vertical extent `H`: a strong echo is detected anywhere in its main lobe, up to one cell from
//! its place (the apertures' main lobes reach one cell either side, the Hann range lobe two
//! half-cells), so `H` is the layer over the terrain where a detection may be the terrain itself
//! (the region's lowest voxels hold the upper flank of a ground echo whose peak lies below the
//! region, and pass the local-maximum test there: the voxel below is not imaged). A structure
//! standing on the terrain rises out of that layer — a wall's image continues up the wall — while
//! a ground echo is a blob inside it.
//!
//! **The rule.** For a fused point `p` at height `h(p)` above the terrain (the terrain scene hit
//! straight below it), `H(p)` is the smallest vertical extent among the pairs that detected `p`
//! (`√(J⁻¹)_zz` of the pair's information matrix, [`super::sensors::vertical_extent_m`]). `p` is
//! a terrain echo when `h(p) ≤ H(p)` and no fused point `q` within the support distance of `p`
//! horizontally stands higher than both `H(p)` and its own layer `H(q)` above its own terrain. A
//! `q` inside its own layer is no evidence of a structure: it may be the same ground echo placed
//! higher by a pair that resolves height worse (on tower_hall's default preset, a strong ground
//! echo west of the hall reached 2.8 m in a vehicle pair's image whose layer there is 5 m, and
//! kept the blob that a finer pair placed below it). Measured in docs/journal/results.md.
//!
//! Units: metres; world frame, z up.

use glam::Vec3;
use std::collections::HashMap;

/// A cloud's points bucketed horizontally with their heights above the terrain and their layers,
/// to ask whether a place holds a terrain echo (module docs).
pub struct TerrainLayer<'a> {
    points: &'a [Vec3],
    heights: &'a [f32],
    layers: &'a [f32],
    r: f32,
    grid: HashMap<[i64; 2], Vec<usize>>,
}

impl<'a> TerrainLayer<'a> {
    /// The cloud `points`, `heights[i]` point `i`'s height above the terrain below it (NaN: no
    /// terrain below), `layers[i]` its layer `H`; `support_m` the horizontal radius within which
    /// a higher point makes a place part of a structure.
    pub fn new(points: &'a [Vec3], heights: &'a [f32], layers: &'a [f32], support_m: f32) -> Self {
        let r = support_m.max(1e-3);
        let mut grid: HashMap<[i64; 2], Vec<usize>> = HashMap::new();
        for (i, p) in points.iter().enumerate() {
            if heights[i].is_finite() {
                grid.entry(Self::cell(r, *p)).or_default().push(i);
            }
        }
        TerrainLayer {
            points,
            heights,
            layers,
            r,
            grid,
        }
    }

    fn cell(r: f32, p: Vec3) -> [i64; 2] {
        [(p.x / r).floor() as i64, (p.y / r).floor() as i64]
    }

    /// Whether a detection at `p`, `h` above the terrain, by pairs whose layer there is `layer`,
    /// is the terrain's echo: inside the layer, and no point of the cloud within the support
    /// distance horizontally stands higher than both `layer` and its own layer.
    pub fn is_echo(&self, p: Vec3, h: f32, layer: f32) -> bool {
        if !(h.is_finite() && layer.is_finite()) || h > layer {
            return false;
        }
        let [cx, cy] = Self::cell(self.r, p);
        let rises = (-1..=1).any(|dx| {
            (-1..=1).any(|dy| {
                self.grid.get(&[cx + dx, cy + dy]).is_some_and(|ids| {
                    ids.iter().any(|&j| {
                        let q = self.points[j];
                        self.heights[j] > layer.max(self.layers[j])
                            && (q.x - p.x).hypot(q.y - p.y) <= self.r
                    })
                })
            })
        });
        !rises
    }
}

/// Which fused points are terrain echoes (module docs): `heights[i]` is point `i`'s height above
/// the terrain below it (NaN: no terrain below, never an echo), `layers[i]` its layer `H`,
/// `support_m` the horizontal radius within which a higher point makes `i` part of a structure.
pub fn terrain_echoes(
    points: &[Vec3],
    heights: &[f32],
    layers: &[f32],
    support_m: f32,
) -> Vec<bool> {
    let layer = TerrainLayer::new(points, heights, layers, support_m);
    points
        .iter()
        .enumerate()
        .map(|(i, &p)| layer.is_echo(p, heights[i], layers[i]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blob_on_the_ground_is_the_terrain_and_the_foot_of_a_wall_is_not() {
        let mut points = Vec::new();
        // A wall x = 0 from the ground to 8 m, sampled every 0.5 m.
        for k in 0..16 {
            points.push(Vec3::new(0.0, 0.0, 0.5 + 0.5 * k as f32));
        }
        // A blob on open ground 10 m away, 0.5–1.5 m up.
        for k in 0..3 {
            points.push(Vec3::new(10.0, 0.0, 0.5 + 0.5 * k as f32));
        }
        let heights: Vec<f32> = points.iter().map(|p| p.z).collect();
        let layers = vec![1.75; points.len()];
        let echo = terrain_echoes(&points, &heights, &layers, 1.5);
        assert!(
            echo[..16].iter().all(|&e| !e),
            "the wall's foot rises into the wall"
        );
        assert!(echo[16..].iter().all(|&e| e), "the blob stays in the layer");
        // Pairs that place height to ±0.75 m see the blob rise out of their layer: a structure.
        let layers = vec![0.75; points.len()];
        let echo = terrain_echoes(&points, &heights, &layers, 1.5);
        assert!(echo.iter().all(|&e| !e));
        // A blob a coarser pair placed higher, within its own layer, does not make the finer
        // pair's blob below it a structure: both are the ground's.
        let mut layers = vec![1.25; points.len()];
        layers[18] = 3.0; // the blob's top point, 1.5 m up, from a pair that places height to ±3 m
        let echo = terrain_echoes(&points, &heights, &layers, 1.5);
        assert!(echo[16..].iter().all(|&e| e), "{echo:?}");
        assert!(echo[..16].iter().all(|&e| !e));
        // No terrain below: never an echo.
        let echo = terrain_echoes(&points, &vec![f32::NAN; points.len()], &layers, 1.5);
        assert!(echo.iter().all(|&e| !e));
    }
}
