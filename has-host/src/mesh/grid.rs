//! The regular node grid of the Poisson solve and what the full-grid and the banded solvers
//! share on it: the trilinear corner weights, the staggered splat of the normal field, and a
//! deterministic Jacobi-preconditioned conjugate-gradient solver. Lengths metres (the node
//! spacing `h`), grid indices x-fastest.

use glam::Vec3;
use rayon::prelude::*;

/// Largest grid the solver accepts, in nodes (≈ 1.1 GB of f32 work vectors).
pub const MAX_NODES: usize = 40_000_000;

/// A regular grid of nodes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Grid {
    /// Node counts.
    pub dims: [usize; 3],
    /// Position of node (0, 0, 0).
    pub origin: Vec3,
    /// Node spacing.
    pub h: f32,
}

impl Grid {
    /// Edge counts of the x-, y- and z-directed edges.
    pub fn edge_dims(&self) -> [[usize; 3]; 3] {
        let [nx, ny, nz] = self.dims;
        [[nx - 1, ny, nz], [nx, ny - 1, nz], [nx, ny, nz - 1]]
    }

    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }
    pub fn idx(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }
    /// Cell (clamped into the grid) and fractional position of p within it.
    pub fn locate(&self, p: Vec3) -> ([usize; 3], Vec3) {
        let u = (p - self.origin) / self.h;
        let mut c = [0usize; 3];
        let mut f = Vec3::ZERO;
        for a in 0..3 {
            let max_cell = self.dims[a].saturating_sub(2) as f32;
            let fl = u[a].floor().clamp(0.0, max_cell);
            c[a] = fl as usize;
            f[a] = (u[a] - fl).clamp(0.0, 1.0);
        }
        (c, f)
    }
    pub fn interpolate(&self, v: &[f32], p: Vec3) -> f32 {
        let (c, f) = self.locate(p);
        let mut s = 0.0;
        for (o, w) in corner_weights(f) {
            s += w * v[self.idx(c[0] + o[0], c[1] + o[1], c[2] + o[2])];
        }
        s
    }
}

/// The 8 corner offsets of a cell with their trilinear weights at fractional position f.
pub(super) fn corner_weights(f: Vec3) -> [([usize; 3], f32); 8] {
    let mut out = [([0usize; 3], 0f32); 8];
    for (c, slot) in out.iter_mut().enumerate() {
        let o = [c & 1, (c >> 1) & 1, (c >> 2) & 1];
        let w = (if o[0] == 1 { f.x } else { 1.0 - f.x })
            * (if o[1] == 1 { f.y } else { 1.0 - f.y })
            * (if o[2] == 1 { f.z } else { 1.0 - f.z });
        *slot = (o, w);
    }
    out
}

/// The staggered splat of the normal field `V = Σ nₚ·aₚ/h³·δₚ` of `grid`: calls
/// `f(axis, q, m, w)` (the sample's `m = n_axis·aₚ/h³` and its trilinear weight `w`, the share
/// being `m·w`) for every trilinear share of every sample on the `axis`-directed edge
/// `q` (from node `q` to `q + e_axis`; edges lie on the grid of [`Grid::edge_dims`], shifted half
/// a cell along `axis`), in sample, axis, corner order. The one definition used by the full-grid
/// and the banded assembly.
pub(super) fn splat_normals(
    grid: &Grid,
    points: &[Vec3],
    normals: &[Vec3],
    area: &[f32],
    mut f: impl FnMut(usize, [usize; 3], f32, f32),
) {
    let h = grid.h;
    let edge_dims = grid.edge_dims();
    let inv_h3 = 1.0 / (h * h * h);
    for ((&p, &n), &a) in points.iter().zip(normals).zip(area) {
        for axis in 0..3 {
            let d = edge_dims[axis];
            let mut shift = Vec3::ZERO;
            shift[axis] = 0.5 * h;
            let eg = Grid {
                dims: d,
                origin: grid.origin + shift,
                h,
            };
            let (c, w8) = eg.locate(p);
            let m = n[axis] * a * inv_h3;
            for (o, w) in corner_weights(w8) {
                let q = [c[0] + o[0], c[1] + o[1], c[2] + o[2]];
                if q[0] < d[0] && q[1] < d[1] && q[2] < d[2] {
                    f(axis, q, m, w);
                }
            }
        }
    }
}

/// `Σ a·b` in f64, in fixed chunks summed in order: the same bits at any thread count and load
/// (rayon's `sum` splits where work-stealing happens to, so the rounding, and the solver's
/// iterates, could change from run to run).
pub(super) fn dot(a: &[f32], b: &[f32]) -> f64 {
    const CHUNK: usize = 4096;
    a.par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| {
            x.iter()
                .zip(y)
                .map(|(&x, &y)| x as f64 * y as f64)
                .sum::<f64>()
        })
        .collect::<Vec<f64>>()
        .into_iter()
        .sum()
}

/// Jacobi-preconditioned CG on A·x = b (A applied by `apply`, `diag` its diagonal) from the
/// initial guess in `x`, stopping at ‖r‖ ≤ tol·`bnorm`; returns (iterations, ‖r‖/`bnorm`).
pub(super) fn pcg(
    apply: impl Fn(&[f32], &mut [f32]),
    b: &[f32],
    diag: &[f32],
    bnorm: f64,
    x: &mut [f32],
    tol: f32,
    max_iter: usize,
) -> (usize, f64) {
    let n = x.len();
    if bnorm == 0.0 {
        return (0, 0.0);
    }
    let mut ap = vec![0f32; n];
    apply(x, &mut ap);
    let mut r: Vec<f32> = b.par_iter().zip(&ap).map(|(b, a)| b - a).collect();
    let mut z: Vec<f32> = r.par_iter().zip(diag).map(|(r, d)| r / d).collect();
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut rel = dot(&r, &r).sqrt() / bnorm;
    let mut it = 0;
    while it < max_iter && rel > tol as f64 {
        apply(&p, &mut ap);
        let pap = dot(&p, &ap);
        if pap <= 0.0 {
            break;
        }
        let alpha = (rz / pap) as f32;
        x.par_iter_mut().zip(&p).for_each(|(x, p)| *x += alpha * p);
        r.par_iter_mut().zip(&ap).for_each(|(r, a)| *r -= alpha * a);
        z.par_iter_mut()
            .zip(&r)
            .zip(diag)
            .for_each(|((z, r), d)| *z = r / d);
        let rz_new = dot(&r, &z);
        let beta = (rz_new / rz) as f32;
        rz = rz_new;
        p.par_iter_mut()
            .zip(&z)
            .for_each(|(p, z)| *p = z + beta * *p);
        rel = dot(&r, &r).sqrt() / bnorm;
        it += 1;
    }
    (it, rel)
}
