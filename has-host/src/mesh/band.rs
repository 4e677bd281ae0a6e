//! Banded (adaptive) levels of the screened Poisson solve ([`super::poisson`]): on a level that
//! would be too large as a full grid, only the nodes near the samples are unknowns — a sparse,
//! octree-like refinement in which a cell is refined only when it lies near samples.
//!
//! Which nodes. A level's *active cells* are the cells within `w` cells (per axis, i.e. a box
//! of (2w + 1)³ cells) of a cell holding a sample; its *unknowns* are the corners of the active
//! cells; its *ring* is the nodes outside the unknowns that are 7-point neighbours of one. The
//! finest-level cell of each sample is computed once and the coarser ones by integer halving, so
//! that the sample cells of consecutive levels nest exactly. Every unknown and ring node of a
//! banded level then lies in a cell whose parent is active on the coarser level when that level
//! is banded too (a fine cell within w + 1 fine cells of a sample cell has its parent within
//! ⌊w/2⌋ + 1 ≤ w coarse cells of the sample's coarse cell, for w ≥ 1), so the coarser values
//! it is prolonged from are solved unknowns, not extrapolations.
//!
//! What is solved. The same discrete energy as the full grid (module docs of
//! [`super::poisson`]), restricted to the unknowns: the graph Laplacian keeps the full grid's
//! node degrees (natural Neumann only at the box boundary), the ring nodes carry the coarser
//! level's solution trilinearly prolonged (Dirichlet), and their couplings move to the right-hand
//! side. All samples lie in active cells, so the screening and the divergence of every edge at
//! an unknown are assembled exactly as on the full grid. CG stops at the same ‖r‖ ≤ tol·‖h·D·V‖
//! as the full grid (the norm of the divergence part of the right-hand side, not of the ring
//! terms, so the absolute stopping level is the same).
//!
//! The field. Each banded level defines χ on *every* node of its (virtual) full grid: its
//! solution on the unknowns, elsewhere the trilinear prolongation of the coarser level's field.
//! This is continuous across the band's edge (the ring values are exactly that prolongation).
//! Iso-surface extraction visits only the cells of the finest dense level in which this field
//! can change sign — the cells whose own corners straddle the iso-value (between its corners
//! the prolonged field is a convex combination of them), the cells that touch a banded level's
//! unknowns, and border cells with an inside corner (closed by the outside ring) — and
//! polygonises their finest subcells. So the surface follows the fine solution near the samples
//! and the coarse solution where it strays away from them (the closure of open parts, e.g. a
//! building's unsampled bottom), without holes where it leaves the band: the untrimmed mesh is
//! watertight, as on the full grid. Away from the samples it is the coarse surface, only
//! tessellated at the fine cell size.
//!
//! Determinism: sets are sorted `u64` linear node keys (x fastest) searched by bisection; sums
//! over samples run sequentially in input order; rayon only maps independent items.

use glam::Vec3;
use rayon::prelude::*;

use super::grid::{corner_weights, pcg, splat_normals, Grid, MAX_NODES};
use super::iso::Polygonizer;
use super::TriMesh;
use crate::knn::GeometryError;

/// Neighbour slot of a node outside the grid.
const NONE: u32 = u32::MAX;

/// Sorted, deduplicated keys.
fn sort_dedup(mut v: Vec<u64>) -> Vec<u64> {
    v.par_sort_unstable();
    v.dedup();
    v
}

fn decode(key: u64, dims: [usize; 3]) -> [usize; 3] {
    let k = key as usize;
    [
        k % dims[0],
        (k / dims[0]) % dims[1],
        k / (dims[0] * dims[1]),
    ]
}

fn encode(c: [usize; 3], dims: [usize; 3]) -> u64 {
    (c[0] + dims[0] * (c[1] + dims[1] * c[2])) as u64
}

/// The set {k + d : k ∈ keys, d ∈ [lo, hi]³} ∩ grid (a box dilation, done one axis at a time).
fn dilate(keys: Vec<u64>, dims: [usize; 3], lo: i64, hi: i64) -> Vec<u64> {
    let mut cur = keys;
    for axis in 0..3 {
        let stride: u64 = dims[..axis].iter().product::<usize>() as u64;
        let out: Vec<u64> = cur
            .par_iter()
            .flat_map_iter(|&k| {
                let c = decode(k, dims)[axis] as i64;
                (lo..=hi).filter_map(move |d| {
                    let n = c + d;
                    (n >= 0 && n < dims[axis] as i64).then(|| (k as i64 + d * stride as i64) as u64)
                })
            })
            .collect();
        cur = sort_dedup(out);
    }
    cur
}

/// The per-axis parents of fine node index i on the coarser level, with weights (the
/// prolongation stencil; the second entry has weight 0 for even i).
fn axis_parents(i: usize) -> [(usize, f32); 2] {
    if i.is_multiple_of(2) {
        [(i / 2, 1.0), (i / 2, 0.0)]
    } else {
        [(i / 2, 0.5), (i / 2 + 1, 0.5)]
    }
}

/// Σ w·value(parent) over the prolongation stencil of fine node n, in the same order as the
/// full-grid prolongation (x outermost), so that a node gets the same bits on both paths.
fn prolong_at(n: [usize; 3], mut value: impl FnMut([usize; 3]) -> f32) -> f32 {
    let mut s = 0.0;
    for (cx, wx) in axis_parents(n[0]) {
        for (cy, wy) in axis_parents(n[1]) {
            for (cz, wz) in axis_parents(n[2]) {
                let w = wx * wy * wz;
                if w != 0.0 {
                    s += w * value([cx, cy, cz]);
                }
            }
        }
    }
    s
}

/// The unknowns of one banded level and their neighbour table.
pub(super) struct Band {
    /// The level's full (virtual) grid.
    pub grid: Grid,
    /// Unknown nodes, sorted linear keys.
    pub nodes: Vec<u64>,
    /// Ring nodes (Dirichlet), sorted linear keys.
    ring: Vec<u64>,
    /// Per unknown, its −x, +x, −y, +y, −z, +z neighbours: an unknown index (< nodes.len()),
    /// nodes.len() + a ring index, or [`NONE`] outside the grid.
    nbr: Vec<[u32; 6]>,
}

impl Band {
    /// The band of width `w` cells around `sample_cells` (cell coordinates on this level).
    ///
    /// # Errors
    /// [`GeometryError::BadParameter`] (`band`) when the band holds more than `max_cells`
    /// active cells (about its unknowns): checked before its node tables are built, so a depth
    /// too fine for the sampled area fails with an error instead of exhausting memory.
    pub fn new(
        grid: Grid,
        sample_cells: &[[usize; 3]],
        w: u32,
        max_cells: usize,
    ) -> Result<Band, GeometryError> {
        let cdims = grid.dims.map(|d| d - 1);
        let seed = sort_dedup(sample_cells.iter().map(|&c| encode(c, cdims)).collect());
        let cells = dilate(seed, cdims, -(w as i64), w as i64);
        if cells.len() > max_cells {
            return Err(GeometryError::BadParameter {
                field: "band (active cells of a banded level)",
                value: cells.len() as f64,
                expected: "at most MAX_NODES (40 M): lower the depth or the band width",
            });
        }
        // Corners of the active cells: the cells' lower corners dilated by {0, 1}³.
        let lower = cells
            .par_iter()
            .map(|&k| encode(decode(k, cdims), grid.dims))
            .collect();
        drop(cells);
        let nodes = dilate(lower, grid.dims, 0, 1);
        let dims = grid.dims;
        let strides = [1u64, dims[0] as u64, (dims[0] * dims[1]) as u64];
        let neighbours = |k: u64| -> [Option<u64>; 6] {
            let c = decode(k, dims);
            let mut out = [None; 6];
            for a in 0..3 {
                if c[a] > 0 {
                    out[2 * a] = Some(k - strides[a]);
                }
                if c[a] + 1 < dims[a] {
                    out[2 * a + 1] = Some(k + strides[a]);
                }
            }
            out
        };
        let ring = sort_dedup(
            nodes
                .par_iter()
                .flat_map_iter(|&k| {
                    neighbours(k)
                        .into_iter()
                        .flatten()
                        .filter(|q| nodes.binary_search(q).is_err())
                })
                .collect(),
        );
        let n = nodes.len() as u32;
        let nbr = nodes
            .par_iter()
            .enumerate()
            .map(|(i, &k)| {
                neighbours(k).map(|q| match q {
                    None => NONE,
                    // x neighbours are adjacent in the sorted order when present.
                    Some(q) if q + 1 == k && i > 0 && nodes[i - 1] == q => (i - 1) as u32,
                    Some(q) if q == k + 1 && nodes.get(i + 1) == Some(&q) => (i + 1) as u32,
                    Some(q) => match nodes.binary_search(&q) {
                        Ok(j) => j as u32,
                        Err(_) => {
                            n + ring.binary_search(&q).expect("ring holds every neighbour") as u32
                        }
                    },
                })
            })
            .collect();
        Ok(Band {
            grid,
            nodes,
            ring,
            nbr,
        })
    }

    /// Number of unknowns.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Index of node `c` among the unknowns.
    pub fn find(&self, c: [usize; 3]) -> Option<usize> {
        self.nodes.binary_search(&encode(c, self.grid.dims)).ok()
    }
}

/// Solved levels: the finest dense grid and the banded levels finer than it, coarse to fine
/// (band t, 1-based, has cells 2^t times finer than the dense grid).
pub(super) struct Hierarchy {
    /// The finest dense grid.
    pub dense: Grid,
    /// χ on it.
    pub dense_x: Vec<f32>,
    /// Banded levels and χ on their unknowns.
    pub bands: Vec<(Band, Vec<f32>)>,
}

impl Hierarchy {
    /// χ at node n of level t (0 = dense, t ≥ 1 = band t): the solution on an unknown, the
    /// prolonged coarser field elsewhere.
    fn value(&self, t: usize, n: [usize; 3]) -> f32 {
        if t == 0 {
            return self.dense_x[self.dense.idx(n[0], n[1], n[2])];
        }
        let (band, x) = &self.bands[t - 1];
        match band.find(n) {
            Some(i) => x[i],
            None => self.prolonged(t, n),
        }
    }

    /// The coarser field (level t − 1) prolonged to node n of level t.
    fn prolonged(&self, t: usize, n: [usize; 3]) -> f32 {
        prolong_at(n, |p| self.value(t - 1, p))
    }

    /// Largest χ anywhere (the prolonged values are convex combinations of solved ones).
    pub fn max_value(&self) -> f32 {
        self.bands
            .iter()
            .flat_map(|(_, x)| x.iter())
            .chain(&self.dense_x)
            .copied()
            .fold(f32::MIN, f32::max)
    }

    /// Assembles and solves the next banded level (one level finer than the last one) with
    /// band width `w`, starting CG from the prolonged coarser field. `fine_cell` is each
    /// sample's cell on the finest level, `shift` the number of halvings from it to this level.
    /// Returns (unknowns, CG iterations, relative residual).
    ///
    /// # Errors
    /// A band larger than [`MAX_NODES`] cells ([`Band::new`]).
    #[allow(clippy::too_many_arguments)]
    pub fn solve_next(
        &mut self,
        grid: Grid,
        w: u32,
        points: &[Vec3],
        normals: &[Vec3],
        area: &[f32],
        fine_cell: &[[usize; 3]],
        shift: u32,
        alpha: f32,
        tol: f32,
        max_iter: usize,
    ) -> Result<(usize, usize, f64), GeometryError> {
        let t = self.bands.len() + 1;
        let cells: Vec<[usize; 3]> = fine_cell.iter().map(|c| c.map(|v| v >> shift)).collect();
        let band = Band::new(grid, &cells, w, MAX_NODES)?;
        let n = band.len();
        let x_ring: Vec<f32> = band
            .ring
            .par_iter()
            .map(|&k| self.prolonged(t, decode(k, grid.dims)))
            .collect();
        let mut x: Vec<f32> = band
            .nodes
            .par_iter()
            .map(|&k| self.prolonged(t, decode(k, grid.dims)))
            .collect();
        let sys = BandSystem::assemble(&band, &cells, &x_ring, points, normals, area, alpha);
        drop(x_ring);
        let (its, rel) = pcg(
            |v, y| sys.apply(&band, v, y),
            &sys.b,
            &sys.diag,
            sys.bnorm,
            &mut x,
            tol,
            max_iter,
        );
        drop(sys);
        // The neighbour table and the ring serve the solve only.
        let band = Band {
            nbr: Vec::new(),
            ring: Vec::new(),
            ..band
        };
        self.bands.push((band, x));
        Ok((n, its, rel))
    }

    /// Mean of χ on the finest level at the samples (the iso-value).
    pub fn mean_at(
        &self,
        points: &[Vec3],
        weights: Option<&[f32]>,
        fine_cell: &[[usize; 3]],
    ) -> f32 {
        let (band, x) = self.bands.last().expect("at least one band");
        let g = band.grid;
        let (sum, wsum) = points
            .par_iter()
            .zip(fine_cell)
            .enumerate()
            .map(|(i, (&p, c))| {
                let f = frac_in(&g, p, *c);
                let chi: f64 = corner_weights(f)
                    .iter()
                    .map(|(o, w)| {
                        let i = band
                            .find([c[0] + o[0], c[1] + o[1], c[2] + o[2]])
                            .expect("sample cells are active");
                        (w * x[i]) as f64
                    })
                    .sum();
                let w = weights.map_or(1.0, |w| w[i]) as f64;
                (w * chi, w)
            })
            .collect::<Vec<_>>()
            .into_iter()
            // Summed in sample order: the same bits at any thread count.
            .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
        (sum / wsum) as f32
    }

    /// The closed iso-surface χ = iso of the finest level's field (module docs): `outside` is
    /// the value of the virtual ring of nodes around the finest grid (≥ iso).
    pub fn extract(&self, iso: f32, outside: f32) -> TriMesh {
        let levels = self.bands.len();
        let fine = self.bands.last().expect("at least one band").0.grid;
        let f = 1usize << levels;
        let d = self.dense;
        let cd = d.dims.map(|v| v - 1);
        let [nx, ny, nz] = fine.dims;
        // (a) Dense cells whose corners straddle iso, (b) border cells with an inside corner.
        let mut cand: Vec<u64> = (0..cd[2])
            .into_par_iter()
            .flat_map_iter(|z| {
                let mut v = Vec::new();
                for y in 0..cd[1] {
                    for x in 0..cd[0] {
                        let mut ins = 0;
                        for (o, _) in corner_weights(Vec3::ZERO) {
                            if self.dense_x[d.idx(x + o[0], y + o[1], z + o[2])] < iso {
                                ins += 1;
                            }
                        }
                        let border = [x, y, z].iter().zip(cd).any(|(&c, n)| c == 0 || c + 1 == n);
                        if ins > 0 && (ins < 8 || border) {
                            v.push(encode([x, y, z], cd));
                        }
                    }
                }
                v
            })
            .collect();
        // (c) Dense cells holding (on their closure) an unknown of some band.
        for (t, (band, _)) in self.bands.iter().enumerate() {
            let g = 1usize << (t + 1);
            let bd = band.grid.dims;
            let touched: Vec<u64> = band
                .nodes
                .par_iter()
                .flat_map_iter(|&k| {
                    let c = decode(k, bd);
                    let opts = [0, 1, 2].map(|a| {
                        let q = c[a] / g;
                        if c[a].is_multiple_of(g) {
                            [q.checked_sub(1), (q < cd[a]).then_some(q)]
                        } else {
                            [Some(q.min(cd[a] - 1)), None]
                        }
                    });
                    let mut v = Vec::with_capacity(8);
                    for x in opts[0].iter().flatten() {
                        for y in opts[1].iter().flatten() {
                            for z in opts[2].iter().flatten() {
                                v.push(encode([*x, *y, *z], cd));
                            }
                        }
                    }
                    v
                })
                .collect();
            cand.extend(touched);
            cand = sort_dedup(cand);
        }
        let cand = sort_dedup(cand);
        let mut poly = Polygonizer::new(iso, fine.origin, fine.h, [nx + 2, ny + 2, nz + 2]);
        let m = f + 1;
        let mut layer = usize::MAX;
        for chunk in cand.chunks(4096) {
            let blocks: Vec<Vec<f32>> = chunk
                .par_iter()
                .map(|&k| self.block(decode(k, cd)))
                .collect();
            for (&k, block) in chunk.iter().zip(&blocks) {
                let c = decode(k, cd);
                let border = (0..3).any(|a| c[a] == 0 || c[a] + 1 == cd[a]);
                let inside = block.iter().filter(|&&v| v < iso).count();
                if inside == 0 || (inside == block.len() && !border) {
                    // No sign change in the block, nor against the outside ring.
                    continue;
                }
                if c[2] != layer {
                    // Cells are visited in z-major order: nothing below this layer's lowest
                    // extended node (c_z·f + 1; the ring at 0 only for c_z = 0) comes back.
                    layer = c[2];
                    poly.forget_below(c[2] * f);
                }
                let base = c.map(|v| v * f);
                // Extended node coordinates e = fine + 1; the outside ring at 0 and n + 1.
                let lo: [usize; 3] = [0, 1, 2].map(|a| base[a] + 1 - (c[a] == 0) as usize);
                let hi: [usize; 3] =
                    [0, 1, 2].map(|a| base[a] + f + 1 + (c[a] + 1 == cd[a]) as usize);
                let val = |e: [usize; 3]| -> f32 {
                    if (0..3).any(|a| e[a] == 0 || e[a] > fine.dims[a]) {
                        outside
                    } else {
                        let l = [0, 1, 2].map(|a| e[a] - 1 - base[a]);
                        block[l[0] + m * (l[1] + m * l[2])]
                    }
                };
                for z in lo[2]..hi[2] {
                    for y in lo[1]..hi[1] {
                        for x in lo[0]..hi[0] {
                            let mut cv = [0f32; 8];
                            for (ci, (o, _)) in corner_weights(Vec3::ZERO).iter().enumerate() {
                                cv[ci] = val([x + o[0], y + o[1], z + o[2]]);
                            }
                            poly.cell([x, y, z], &cv);
                        }
                    }
                }
            }
        }
        poly.finish()
    }

    /// χ of the finest level on the (2^levels + 1)³ nodes of dense cell `c`, x fastest, refined
    /// level by level: a band's unknowns take their solution, other nodes the prolongation of
    /// the previous block (the same values [`Self::value`] gives, in the same operation order).
    fn block(&self, c: [usize; 3]) -> Vec<f32> {
        let d = self.dense;
        let mut m = 2;
        let mut vals: Vec<f32> = (0..8)
            .map(|i| {
                let o = [i & 1, (i >> 1) & 1, (i >> 2) & 1];
                self.dense_x[d.idx(c[0] + o[0], c[1] + o[1], c[2] + o[2])]
            })
            .collect();
        let mut base = c;
        for (band, x) in &self.bands {
            let mf = 2 * m - 1;
            let fbase = base.map(|v| 2 * v);
            let mut next = vec![0f32; mf * mf * mf];
            for lz in 0..mf {
                for ly in 0..mf {
                    for lx in 0..mf {
                        let g = [fbase[0] + lx, fbase[1] + ly, fbase[2] + lz];
                        next[lx + mf * (ly + mf * lz)] = match band.find(g) {
                            Some(i) => x[i],
                            None => prolong_at(g, |p| {
                                let l = [p[0] - base[0], p[1] - base[1], p[2] - base[2]];
                                vals[l[0] + m * (l[1] + m * l[2])]
                            }),
                        };
                    }
                }
            }
            vals = next;
            m = mf;
            base = fbase;
        }
        vals
    }
}

/// Fractional position of p in cell c of grid g, clamped to [0, 1].
fn frac_in(g: &Grid, p: Vec3, c: [usize; 3]) -> Vec3 {
    let u = (p - g.origin) / g.h;
    Vec3::new(
        (u.x - c[0] as f32).clamp(0.0, 1.0),
        (u.y - c[1] as f32).clamp(0.0, 1.0),
        (u.z - c[2] as f32).clamp(0.0, 1.0),
    )
}

/// The assembled system of one banded level.
struct BandSystem {
    /// Right-hand side: h·D·V on the unknowns plus the ring couplings.
    b: Vec<f32>,
    /// ‖h·D·V‖ on the unknowns (the CG stopping reference).
    bnorm: f64,
    /// Diagonal of the operator.
    diag: Vec<f32>,
    /// Per sample: its cell's 8 corners (unknown indices), trilinear weights, and βₚ/h.
    corners: Vec<[u32; 8]>,
    weights: Vec<[f32; 8]>,
    coef: Vec<f32>,
}

impl BandSystem {
    fn assemble(
        band: &Band,
        cells: &[[usize; 3]],
        x_ring: &[f32],
        points: &[Vec3],
        normals: &[Vec3],
        area: &[f32],
        alpha: f32,
    ) -> BandSystem {
        let grid = band.grid;
        let h = grid.h;
        let n = band.len();
        // Divergence: edge (q, q + e_axis) carrying V subtracts h·V from b_q and adds it to
        // b_{q+e} (b_i = h·(Σ_axis V(i − e_axis) − V(i)), as on the full grid).
        let mut b = vec![0f32; n];
        splat_normals(&grid, points, normals, area, |axis, q, m, w| {
            let mut q1 = q;
            q1[axis] += 1;
            if let Some(i) = band.find(q) {
                b[i] -= h * m * w;
            }
            if let Some(i) = band.find(q1) {
                b[i] += h * m * w;
            }
        });
        let bnorm = b.iter().map(|&v| v as f64 * v as f64).sum::<f64>().sqrt();
        // Ring couplings (the Laplacian's −1 entries to Dirichlet nodes) and the degrees.
        let mut diag = vec![0f32; n];
        b.par_iter_mut()
            .zip(diag.par_iter_mut())
            .zip(&band.nbr)
            .for_each(|((bi, di), nb)| {
                let mut deg = 0u32;
                for &j in nb {
                    if j != NONE {
                        deg += 1;
                        if j as usize >= n {
                            *bi += x_ring[j as usize - n];
                        }
                    }
                }
                *di = deg as f32;
            });
        // Screening.
        let mut corners = Vec::with_capacity(points.len());
        let mut weights = Vec::with_capacity(points.len());
        let mut coef = Vec::with_capacity(points.len());
        for ((&p, c), &a) in points.iter().zip(cells).zip(area) {
            let f = frac_in(&grid, p, *c);
            let k = alpha * a / (h * h);
            let mut ci = [0u32; 8];
            let mut wi = [0f32; 8];
            for (s, (o, w)) in corner_weights(f).into_iter().enumerate() {
                let i = band
                    .find([c[0] + o[0], c[1] + o[1], c[2] + o[2]])
                    .expect("sample cells are active");
                ci[s] = i as u32;
                wi[s] = w;
                diag[i] += k * w * w;
            }
            corners.push(ci);
            weights.push(wi);
            coef.push(k);
        }
        BandSystem {
            b,
            bnorm,
            diag,
            corners,
            weights,
            coef,
        }
    }

    /// y = A·x on the unknowns (ring values are in b).
    fn apply(&self, band: &Band, x: &[f32], y: &mut [f32]) {
        let n = x.len();
        y.par_iter_mut()
            .zip(x)
            .zip(&band.nbr)
            .for_each(|((yi, &xi), nb)| {
                let mut acc = 0.0;
                for &j in nb {
                    if j != NONE {
                        acc += xi - if (j as usize) < n { x[j as usize] } else { 0.0 };
                    }
                }
                *yi = acc;
            });
        for ((ci, wi), k) in self.corners.iter().zip(&self.weights).zip(&self.coef) {
            let mut s = 0.0;
            for (&i, &w) in ci.iter().zip(wi) {
                s += w * x[i as usize];
            }
            let s = k * s;
            for (&i, &w) in ci.iter().zip(wi) {
                y[i as usize] += w * s;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::poisson::{screened_poisson, PoissonParams};
    use super::super::{reconstruct, Orientation, ReconstructParams, TriMesh};
    use super::*;
    use crate::knn::GeometryError;
    use crate::metrics::noisy_sphere;
    use crate::Material;

    fn banded(depth: u32, w: u32, dense_max_nodes: usize) -> PoissonParams {
        PoissonParams {
            depth,
            levels: 3,
            band: Some(w),
            dense_max_nodes,
            ..PoissonParams::default()
        }
    }

    #[test]
    fn dilation_matches_brute_force_and_bands_nest() {
        // A few scattered cells on a 12×9×7-cell grid, some on its border.
        let dims = [13, 10, 8];
        let cdims = dims.map(|d| d - 1);
        let seeds = [[0, 0, 0], [5, 4, 3], [11, 8, 6], [6, 4, 3], [2, 7, 1]];
        for w in 1..=3u32 {
            let keys = seeds.iter().map(|&c| encode(c, cdims)).collect();
            let got = dilate(keys, cdims, -(w as i64), w as i64);
            let mut want = Vec::new();
            for z in 0..cdims[2] {
                for y in 0..cdims[1] {
                    for x in 0..cdims[0] {
                        let near = seeds.iter().any(|s| {
                            [x, y, z]
                                .iter()
                                .zip(s)
                                .all(|(&a, &b)| a.abs_diff(b) <= w as usize)
                        });
                        if near {
                            want.push(encode([x, y, z], cdims));
                        }
                    }
                }
            }
            assert_eq!(got, want, "w = {w}");
            // Nesting (module docs): the prolongation parents of every unknown and ring node of
            // a band are unknowns of the band one level coarser, for sample cells that nest.
            let fine_cells: Vec<[usize; 3]> = seeds.iter().map(|c| c.map(|v| 2 * v + 1)).collect();
            let coarse_cells: Vec<[usize; 3]> =
                fine_cells.iter().map(|c| c.map(|v| v / 2)).collect();
            let g = |dims: [usize; 3], h: f32| Grid {
                dims,
                origin: Vec3::ZERO,
                h,
            };
            let coarse = Band::new(g(dims, 2.0), &coarse_cells, w, MAX_NODES).unwrap();
            let fdims = dims.map(|d| 2 * d - 1);
            let fine = Band::new(g(fdims, 1.0), &fine_cells, w, MAX_NODES).unwrap();
            assert!(!fine.ring.is_empty());
            for &k in fine.nodes.iter().chain(&fine.ring) {
                prolong_at(decode(k, fdims), |p| {
                    assert!(coarse.find(p).is_some(), "w {w}: parent {p:?} of {k}");
                    0.0
                });
            }
            // Every 7-point neighbour of an unknown is an unknown, a ring node or off the grid.
            for (i, nb) in fine.nbr.iter().enumerate() {
                let c = decode(fine.nodes[i], fdims);
                for (s, &j) in nb.iter().enumerate() {
                    let (a, up) = (s / 2, s % 2 == 1);
                    let off = if up { c[a] + 1 >= fdims[a] } else { c[a] == 0 };
                    assert_eq!(j == NONE, off);
                    if j != NONE {
                        let mut q = c;
                        q[a] = if up { q[a] + 1 } else { q[a] - 1 };
                        let key = encode(q, fdims);
                        let got = if (j as usize) < fine.len() {
                            fine.nodes[j as usize]
                        } else {
                            fine.ring[j as usize - fine.len()]
                        };
                        assert_eq!(got, key);
                    }
                }
            }
        }
    }

    /// Largest distance from a vertex of `a` to the nearest vertex of `b`. Both meshes come
    /// from the same grid, so their vertices lie on the same lattice edges: where a crossing
    /// exists in both, the two vertices lie on one edge, and this measures how far the
    /// level set moved along it.
    fn vertex_gap(a: &TriMesh, b: &TriMesh) -> f32 {
        let idx = crate::knn::PointIndex::new("b", &b.vertices).unwrap();
        a.vertices
            .iter()
            .map(|&v| idx.knn(v, 1)[0].1.sqrt())
            .fold(0.0, f32::max)
    }

    /// Mean radius and largest |r − R| of the vertices about `c`.
    fn radius_stats(m: &TriMesh, c: Vec3, r: f32) -> (f32, f32) {
        let radii: Vec<f32> = m.vertices.iter().map(|v| (*v - c).length()).collect();
        let mean = radii.iter().sum::<f32>() / radii.len() as f32;
        (
            mean,
            radii.iter().map(|x| (x - r).abs()).fold(0.0, f32::max),
        )
    }

    #[test]
    fn adaptive_sphere_is_watertight_within_the_full_grid_bounds_and_agrees_with_it() {
        let c = Vec3::new(3.0, -2.0, 1.0);
        let r = 1.0f32;
        let sigma = 0.01f32;
        let (pts, nrm) = noisy_sphere(6000, c, r, sigma, 1).unwrap();
        let full_p = PoissonParams {
            depth: 6,
            levels: 3,
            band: None,
            ..PoissonParams::default()
        };
        let full = screened_poisson(&pts, &nrm, &full_p).unwrap();
        // 73³, 37³ and 19³ nodes exceed 5000: the three finest levels are banded, 10³ is not.
        let ad = screened_poisson(&pts, &nrm, &banded(6, 2, 5000)).unwrap();
        let h = full.cell_m;
        assert_eq!(ad.cell_m, h);
        let unknowns: Vec<usize> = ad.levels.iter().map(|l| l.unknowns).collect();
        let nodes: Vec<usize> = ad.levels.iter().map(|l| l.dims.iter().product()).collect();
        assert!(unknowns[0] == nodes[0] && (1..4).all(|l| unknowns[l] < nodes[l]));
        // The same bounds as the full grid (tests/tests/mesh_reconstruction.rs): mean radius
        // within 2h²/R + σ²/R, every vertex within h + 3σ; closed.
        for (name, out) in [("full", &full), ("banded", &ad)] {
            let (mean, max_dev) = radius_stats(&out.mesh, c, r);
            let top = out.mesh.topology();
            assert!(top.watertight, "{name}: {top:?}");
            assert!(
                (mean - r).abs() <= 2.0 * h * h / r + sigma * sigma / r,
                "{name}: mean {mean}"
            );
            assert!(max_dev <= h + 3.0 * sigma, "{name}: max dev {max_dev}");
        }
        // Agreement (an estimate, not a proof). χ_band − χ_full has no sources in the band
        // (divergence and screening are the same), so by the maximum principle of the
        // (M-matrix) screened Laplacian it is largest on the ring, ≥ w = 2 cells from every
        // sample, where it is the error ε of the prolonged coarser solution: the interpolation
        // error of χ's smoothed step two coarse cells away from it, taken as ≤ 1/16 of the unit
        // jump. χ rises by 1 over the ≈ 2 cells of the splat, |∇χ| ≈ 1/(2h), so the level set
        // moves by ≤ 2h·ε = h/8. Both meshes put their vertices on the same lattice edges; where
        // the move changes which edge crosses, the nearest vertex of the other mesh is up to
        // half a face diagonal (h/√8 ≈ 0.35h) further: gap ≤ 0.48h < h/2. The iso-values (mean
        // of χ at the samples, inside the band) differ by less than ε; asserted ≤ 1/100 of the jump.
        let gap = vertex_gap(&ad.mesh, &full.mesh).max(vertex_gap(&full.mesh, &ad.mesh));
        assert!(gap <= 0.5 * h, "gap {gap} = {} h", gap / h);
        assert!(
            (ad.iso_value - full.iso_value).abs() <= 0.01,
            "{} vs {}",
            ad.iso_value,
            full.iso_value
        );
        // A band that covers the whole grid is the full system: the same start, operator and
        // right-hand side up to the order of float sums (≈ 1e-7 relative per product), so
        // the solutions agree to ~1e-6 of the unit jump and the vertices to ≤ 1e-3·h.
        let all = screened_poisson(&pts, &nrm, &banded(6, 64, 5000)).unwrap();
        assert_eq!(all.levels[3].unknowns, nodes[3]);
        let gap = vertex_gap(&all.mesh, &full.mesh).max(vertex_gap(&full.mesh, &all.mesh));
        assert!(gap <= 1e-3 * h, "gap {gap} = {} h", gap / h);
        // Deterministic: the same bits on a second run.
        let again = screened_poisson(&pts, &nrm, &banded(6, 2, 5000)).unwrap();
        assert_eq!(again.mesh, ad.mesh);
        assert_eq!(again.vertex_density, ad.vertex_density);
    }

    #[test]
    fn banded_finest_level_holds_the_shell_not_the_box() {
        // Depth 7, σ = 0.01 m, w = 2. Every unknown is a corner of a cell within w cells (per
        // axis) of a cell holding a sample, so it lies within t = 3σ (99.7 % of the samples;
        // none of 6000 beyond 4.5σ, use that) + (w + 1)·√3·h of the sphere; the nodes of a shell
        // of half-thickness t number at most its volume grown by half a node cell, /h³:
        // 4/3·π·((R + t')³ − (R − t')³)/h³, t' = t + √3·h/2.
        let c = Vec3::ZERO;
        let r = 1.0f32;
        let sigma = 0.01f32;
        let (pts, nrm) = noisy_sphere(6000, c, r, sigma, 5).unwrap();
        let out = screened_poisson(&pts, &nrm, &banded(7, 2, 1 << 20)).unwrap();
        let fine = out.levels.last().unwrap();
        let h = fine.cell_m;
        let full: usize = fine.dims.iter().product();
        let t = 4.5 * sigma + 3.0 * 3f32.sqrt() * h + 3f32.sqrt() * h / 2.0;
        let shell = 4.0 / 3.0 * std::f32::consts::PI * ((r + t).powi(3) - (r - t).powi(3));
        let bound = (shell / h.powi(3)) as usize;
        eprintln!(
            "unknowns {} bound {bound} full {full} levels {:?}",
            fine.unknowns, out.levels
        );
        assert!(fine.unknowns <= bound, "{} > {bound}", fine.unknowns);
        // Area/volume: ≈ 4πR²·2t/h³ against the (2.4R/h)³ box: here ≤ 1/5 of the full grid.
        assert!(fine.unknowns * 5 <= full, "{} of {full}", fine.unknowns);
        assert!(out.mesh.topology().watertight);
    }

    #[test]
    fn depth_9_band_memory_is_bounded_by_the_samples_where_the_full_grid_is_refused() {
        // 1500 exact samples of a unit sphere: the depth-9 full grid (≈ 513³ nodes) exceeds
        // MAX_NODES, the banded one needs at most (2w + 2)³ unknowns per sample on each banded
        // level (its active cells are the (2w + 1)³ boxes around the sample cells, their corners
        // the (2w + 2)³ boxes), independent of the box: memory O(samples·w³), not O(volume).
        let (pts, nrm) = noisy_sphere(1500, Vec3::ZERO, 1.0, 0.0, 7).unwrap();
        let full = PoissonParams {
            depth: 9,
            band: None,
            levels: 3,
            ..PoissonParams::default()
        };
        assert!(matches!(
            screened_poisson(&pts, &nrm, &full),
            Err(GeometryError::BadParameter { field: "depth", .. })
        ));
        let w = 1;
        let out = screened_poisson(&pts, &nrm, &banded(9, w, 1 << 18)).unwrap();
        let per_sample = (2 * w as usize + 2).pow(3);
        for l in &out.levels {
            let nodes: usize = l.dims.iter().product();
            if l.unknowns < nodes {
                assert!(l.unknowns <= pts.len() * per_sample, "{l:?}");
            }
        }
        let fine = out.levels.last().unwrap();
        assert!(fine.dims.iter().product::<usize>() > MAX_NODES);
        assert!(fine.unknowns <= pts.len() * per_sample);
        // The surface between the sparse samples comes from the coarser levels: still closed.
        let top = out.mesh.topology();
        assert!(top.watertight, "{top:?}");
    }

    #[test]
    fn adaptive_box_faces_within_the_full_grid_bound() {
        // As tests/tests/mesh_reconstruction.rs: face-interior vertices (≥ 2 cells from an
        // edge) within h/2 + 3σ of their face plane, closed.
        let lo = Vec3::new(-1.0, -0.75, 0.0);
        let hi = Vec3::new(1.0, 0.75, 1.0);
        let b = crate::shapes::axis_box("box", Material::Concrete, lo, hi).unwrap();
        let sigma = 0.01f32;
        let clean = crate::metrics::sample_triangles(&b.triangles, 1500.0, 3).unwrap();
        let pts = crate::metrics::gaussian_jitter(&clean, sigma, 4).unwrap();
        let params = ReconstructParams {
            poisson: banded(6, 2, 5000),
            ..ReconstructParams::default()
        };
        let rec = reconstruct(&pts, None, Orientation::Propagate, &params).unwrap();
        assert!(rec.poisson.levels[3].unknowns < rec.poisson.levels[3].dims.iter().product());
        let h = rec.poisson.cell_m;
        let mut worst = 0f32;
        let mut n = 0;
        for v in &rec.mesh.vertices {
            let dlo = *v - lo;
            let dhi = hi - *v;
            let mut s = [dlo.x, dlo.y, dlo.z, dhi.x, dhi.y, dhi.z];
            s.sort_by(f32::total_cmp);
            if s[1].abs() > 2.0 * h {
                worst = worst.max(s[0].abs());
                n += 1;
            }
        }
        assert!(rec.mesh.topology().watertight);
        let bound = 0.5 * h + 3.0 * sigma;
        assert!(
            n > 1000 && worst <= bound,
            "{n} vertices, worst {worst}, bound {bound}"
        );
    }

    #[test]
    fn a_band_larger_than_its_cell_limit_is_an_error_not_an_allocation() {
        // One sample cell in a 40³-cell grid: w = 2 makes a 5³ = 125-cell band.
        let grid = Grid {
            dims: [41, 41, 41],
            origin: Vec3::ZERO,
            h: 1.0,
        };
        let cells = [[20usize, 20, 20]];
        let ok = Band::new(grid, &cells, 2, 125).unwrap();
        assert_eq!(ok.len(), 6 * 6 * 6);
        match Band::new(grid, &cells, 2, 124) {
            Err(GeometryError::BadParameter { field, value, .. }) => {
                assert!(field.starts_with("band"), "{field}");
                assert_eq!(value, 125.0);
            }
            other => panic!("expected an error, got {:?}", other.map(|b| b.len())),
        }
    }

    #[test]
    fn bad_band_parameters_are_named() {
        let (pts, nrm) = noisy_sphere(100, Vec3::ZERO, 1.0, 0.0, 3).unwrap();
        for (w, max) in [(0, 1000), (65, 1000), (2, 0), (2, MAX_NODES + 1)] {
            let e = screened_poisson(&pts, &nrm, &banded(5, w, max)).unwrap_err();
            let want = if max == 1000 {
                "band"
            } else {
                "dense_max_nodes"
            };
            assert!(
                matches!(e, GeometryError::BadParameter { field, .. } if field == want),
                "{e}"
            );
        }
    }
}
