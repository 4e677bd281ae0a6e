//! Iso-surface extraction from a scalar field sampled on a regular grid of nodes, by marching
//! tetrahedra: every grid cell is split into the six Kuhn tetrahedra around its main diagonal
//! (corner 0 → corner 7), the same split in every cell, so that neighbouring cells share face
//! diagonals and the surface has no cracks. Tetrahedra have no ambiguous cases, so the result is
//! an edge-manifold, consistently oriented mesh; it is closed (watertight) because the field is
//! padded with one ring of "outside" nodes around the grid.
//!
//! Convention: a node is *inside* when its value is `< iso`; faces are oriented so that their
//! right-hand normals point from inside to outside. A vertex lies on a grid edge (cell edge,
//! face diagonal or cell diagonal) at the linear-interpolation crossing, and is shared by every
//! face using that edge.

use std::collections::HashMap;

use glam::Vec3;

use super::TriMesh;

/// A scalar field on the nodes of a regular grid.
#[derive(Clone, Debug)]
pub struct GridField<'a> {
    /// Node counts along x, y, z.
    pub dims: [usize; 3],
    /// Position of node (0, 0, 0), metres.
    pub origin: Vec3,
    /// Node spacing, metres.
    pub cell_m: f32,
    /// Values, x fastest: index = x + nx·(y + ny·z).
    pub values: &'a [f32],
}

/// The six Kuhn tetrahedra of a cube, as corner numbers c = dx + 2·dy + 4·dz.
const TETS: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

fn corner_offset(c: usize) -> [i64; 3] {
    [(c & 1) as i64, ((c >> 1) & 1) as i64, ((c >> 2) & 1) as i64]
}

/// Sign of det[b − a, c − a, d − a] for integer corner offsets.
fn orient(a: [i64; 3], b: [i64; 3], c: [i64; 3], d: [i64; 3]) -> i64 {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
    u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0])
}

/// Extracts the closed iso-surface `value = iso` (see the module docs). `outside` is the value
/// given to the virtual ring of nodes around the grid; it must be `>= iso`.
pub fn marching_tetrahedra(field: &GridField<'_>, iso: f32, outside: f32) -> TriMesh {
    let [nx, ny, nz] = field.dims;
    // Extended grid: one virtual node on each side.
    let ex = nx + 2;
    let ey = ny + 2;
    let ez = nz + 2;
    let value = |x: usize, y: usize, z: usize| -> f32 {
        if x == 0 || y == 0 || z == 0 || x > nx || y > ny || z > nz {
            outside
        } else {
            field.values[(x - 1) + nx * ((y - 1) + ny * (z - 1))]
        }
    };
    let mut poly = Polygonizer::new(iso, field.origin, field.cell_m, [ex, ey, ez]);
    for z in 0..ez - 1 {
        poly.forget_below(z);
        for y in 0..ey - 1 {
            for x in 0..ex - 1 {
                let mut cv = [0f32; 8];
                for (c, v) in cv.iter_mut().enumerate() {
                    let o = corner_offset(c);
                    *v = value(x + o[0] as usize, y + o[1] as usize, z + o[2] as usize);
                }
                poly.cell([x, y, z], &cv);
            }
        }
    }
    poly.finish()
}

/// Marching tetrahedra one cell at a time, on a grid of nodes addressed by integer coordinates
/// of the grid extended by one virtual node on each side (node (x, y, z) sits at
/// `origin + cell_m·(x − 1, y − 1, z − 1)`, `origin` being the first real node);
/// vertices on an edge are shared by every cell that uses the edge (keyed by the two nodes), so
/// cells may be visited in any order and any subset: a subset whose sign-changing cells are all
/// visited gives the same closed surface as the whole grid.
pub(crate) struct Polygonizer {
    iso: f32,
    origin: Vec3,
    cell_m: f32,
    dims: [usize; 3],
    mesh: TriMesh,
    edge_vertex: HashMap<(u64, u64), u32>,
    /// Tetrahedron orientation signs (constant).
    tet_sign: [i64; 6],
}

impl Polygonizer {
    /// `origin`: position of extended node (1, 1, 1); `dims`: extended node counts (for keys).
    pub(crate) fn new(iso: f32, origin: Vec3, cell_m: f32, dims: [usize; 3]) -> Polygonizer {
        let tet_sign: [i64; 6] = TETS.map(|t| {
            orient(
                corner_offset(t[0]),
                corner_offset(t[1]),
                corner_offset(t[2]),
                corner_offset(t[3]),
            )
        });
        Polygonizer {
            iso,
            origin,
            cell_m,
            dims,
            mesh: TriMesh::default(),
            edge_vertex: HashMap::new(),
            tet_sign,
        }
    }

    /// Drops the shared-vertex entries of edges whose nodes both lie below node layer `z`:
    /// call it when no cell reaching below `z` will be visited any more (cells visited in
    /// z-major order), so that the table holds about one layer of the surface, not all of it.
    pub(crate) fn forget_below(&mut self, z: usize) {
        let layer = (self.dims[0] * self.dims[1]) as u64;
        if z > 0 {
            self.edge_vertex.retain(|&(_, b), _| b / layer >= z as u64);
        }
    }

    /// The mesh built so far.
    pub(crate) fn finish(self) -> TriMesh {
        self.mesh
    }

    /// Polygonises the cell whose lowest corner is node `at`, with corner values `cv` (corner
    /// c = dx + 2·dy + 4·dz).
    pub(crate) fn cell(&mut self, at: [usize; 3], cv: &[f32; 8]) {
        let iso = self.iso;
        let mut inside = 0u8;
        for (c, v) in cv.iter().enumerate() {
            if *v < iso {
                inside |= 1 << c;
            }
        }
        if inside == 0 || inside == 0xff {
            return;
        }
        let [x, y, z] = at;
        let [ex, ey, _] = self.dims;
        let (origin, cell_m) = (self.origin, self.cell_m);
        let node = |c: usize| -> (u64, Vec3, f32) {
            let o = corner_offset(c);
            let (xx, yy, zz) = (x + o[0] as usize, y + o[1] as usize, z + o[2] as usize);
            (
                (xx + ex * (yy + ey * zz)) as u64,
                origin + cell_m * Vec3::new(xx as f32 - 1.0, yy as f32 - 1.0, zz as f32 - 1.0),
                cv[c],
            )
        };
        let mesh = &mut self.mesh;
        let edge_vertex = &mut self.edge_vertex;
        let mut vertex_on = |a: (u64, Vec3, f32), b: (u64, Vec3, f32), mesh: &mut TriMesh| -> u32 {
            let k = if a.0 < b.0 { (a.0, b.0) } else { (b.0, a.0) };
            *edge_vertex.entry(k).or_insert_with(|| {
                // Interpolate from the lower key so that both cells compute the same point.
                let (p, q) = if a.0 < b.0 { (a, b) } else { (b, a) };
                let t = ((iso - p.2) / (q.2 - p.2)).clamp(0.0, 1.0);
                mesh.vertices.push(p.1 + (q.1 - p.1) * t);
                (mesh.vertices.len() - 1) as u32
            })
        };
        let tet_sign = self.tet_sign;
        for (ti, t) in TETS.iter().enumerate() {
            let ins: Vec<usize> = t
                .iter()
                .copied()
                .filter(|&c| inside >> c & 1 == 1)
                .collect();
            let outs: Vec<usize> = t
                .iter()
                .copied()
                .filter(|&c| inside >> c & 1 == 0)
                .collect();
            // Reorder (a, b, c, d) = tet corners so that the odd/first group comes first,
            // then fix the orientation with the sign of the permutation's determinant.
            let positive = |q: [usize; 4]| -> bool {
                let s = orient(
                    corner_offset(q[0]),
                    corner_offset(q[1]),
                    corner_offset(q[2]),
                    corner_offset(q[3]),
                );
                debug_assert!(s != 0 && tet_sign[ti] != 0);
                s > 0
            };
            match (ins.len(), outs.len()) {
                (1, 3) | (3, 1) => {
                    let (o, rest, o_inside) = if ins.len() == 1 {
                        (ins[0], [outs[0], outs[1], outs[2]], true)
                    } else {
                        (outs[0], [ins[0], ins[1], ins[2]], false)
                    };
                    let (x1, mut y1, mut z1) = (rest[0], rest[1], rest[2]);
                    if !positive([o, x1, y1, z1]) {
                        std::mem::swap(&mut y1, &mut z1);
                    }
                    // For a positive tet (o, x, y, z), the triangle (ox, oy, oz) faces
                    // away from o.
                    let vo = node(o);
                    let a = vertex_on(vo, node(x1), mesh);
                    let b = vertex_on(vo, node(y1), mesh);
                    let c = vertex_on(vo, node(z1), mesh);
                    if o_inside {
                        mesh.faces.push([a, b, c]);
                    } else {
                        mesh.faces.push([a, c, b]);
                    }
                }
                (2, 2) => {
                    let (a, b) = (ins[0], ins[1]);
                    let (mut c, mut d) = (outs[0], outs[1]);
                    if !positive([a, b, c, d]) {
                        std::mem::swap(&mut c, &mut d);
                    }
                    // For a positive tet with a, b inside: quad (ac, ad, bd, bc) faces
                    // from the ab edge toward the cd edge, i.e. outward.
                    let (na, nb, nc, nd) = (node(a), node(b), node(c), node(d));
                    let ac = vertex_on(na, nc, mesh);
                    let ad = vertex_on(na, nd, mesh);
                    let bd = vertex_on(nb, nd, mesh);
                    let bc = vertex_on(nb, nc, mesh);
                    mesh.faces.push([ac, ad, bd]);
                    mesh.faces.push([ac, bd, bc]);
                }
                _ => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_distance_field_gives_a_closed_outward_sphere() {
        // f = |p| − R on a grid of spacing h. Along an edge f is convex with f'' ≤ 1/r_min,
        // r_min ≥ R − h√3 the smallest radius an edge crossing the sphere reaches; the linear
        // interpolant's zero v therefore has −L²/(8·r_min) ≤ f(v) ≤ 0 with L ≤ h√3 (the cell
        // diagonal): |‖v‖ − R| ≤ 3h²/(8·r_min).
        let n = 24;
        let h = 0.25f32;
        let r = 2.0f32;
        let origin = Vec3::splat(-(n as f32 - 1.0) * h / 2.0);
        let mut vals = Vec::new();
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let p = origin + h * Vec3::new(x as f32, y as f32, z as f32);
                    vals.push(p.length() - r);
                }
            }
        }
        let f = GridField {
            dims: [n, n, n],
            origin,
            cell_m: h,
            values: &vals,
        };
        let m = marching_tetrahedra(&f, 0.0, 1.0);
        let top = m.topology();
        assert!(top.watertight, "{top:?}");
        let r_min = r - 3f32.sqrt() * h;
        let bound = 3.0 * h * h / (8.0 * r_min) + 1e-5;
        for v in &m.vertices {
            assert!((v.length() - r).abs() <= bound, "{}", v.length());
        }
        // Outward: the signed volume (divergence theorem) is positive. Vertices lie within
        // `bound` inside the sphere and flat faces sag at most another L²/(8R) ≤ `bound`, so
        // the volume lies between 4/3π(R − 2·bound)³ and 4/3πR³.
        let vol: f32 = m
            .faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| m.vertices[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        let want = 4.0 / 3.0 * std::f32::consts::PI * r.powi(3);
        let low = 4.0 / 3.0 * std::f32::consts::PI * (r - 2.0 * bound).powi(3);
        assert!(
            vol > low && vol <= want * 1.0001,
            "{vol} vs [{low}, {want}]"
        );
    }

    #[test]
    fn field_touching_the_grid_border_is_closed_by_the_outside_ring() {
        // Everything inside: the surface is the boundary of the grid box, still watertight.
        let vals = vec![-1.0f32; 27];
        let f = GridField {
            dims: [3, 3, 3],
            origin: Vec3::ZERO,
            cell_m: 1.0,
            values: &vals,
        };
        let m = marching_tetrahedra(&f, 0.0, 1.0);
        assert!(m.topology().watertight);
    }
}
