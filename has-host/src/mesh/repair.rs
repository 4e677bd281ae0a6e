//! Mesh repair for other tools: the mesh as written must pass the checks MeshLab, Open3D and
//! trimesh apply to what they load.
//!
//! What a marching-tetrahedra surface, trimmed and clipped, can hold and those tools reject:
//! * **coincident vertices** under different indices (Open3D's `remove_duplicated_vertices`
//!   welds bit-identical positions on load, turning the faces between them into degenerate faces
//!   and their edges into non-manifold ones);
//! * **degenerate faces**: a repeated vertex index, or zero area (three collinear points);
//! * **duplicate faces**: the same three vertices twice (an edge then used three or more times);
//! * **non-manifold edges**: an edge of three or more faces, or of two running the same way,
//!   where the iso-surface pinches at a grid node whose vertices were welded — its faces (slivers
//!   at the node) are dropped;
//! * **non-manifold ("bow-tie") vertices**: the faces around a vertex form two or more fans that
//!   share only that vertex (Open3D's `is_vertex_manifold`; a trim can leave two sheets, or a
//!   fragment, touching at one vertex).
//!
//! [`TriMesh::repaired`] welds bit-identical vertices and the ends of face edges shorter than a few
//! ulps of the coordinates (one point computed twice), drops degenerate and duplicate faces, and
//! at a bow-tie vertex keeps the largest fan and drops the other fans' faces at that vertex (a
//! fragment attached by one vertex loses its faces there and, if small, the small-component rule
//! of [`super::reconstruct`] removes the rest; no coincident vertices are written). [`TriMesh::nonmanifold_vertices`] counts the
//! bow-ties, [`TriMesh::vertex_normals`] gives the area-weighted unit normals that the writers
//! store with each vertex.
//!
//! Units: metres; faces counter-clockwise seen from outside.

use std::collections::HashMap;

use glam::Vec3;

use super::TriMesh;
use crate::disjoint_sets::DisjointSets;

/// Faces of at most this area (m²) are degenerate: collinear vertices, whose normal is undefined.
pub const MIN_FACE_AREA_M2: f32 = 1e-12;

/// Face-edge ends closer than this many ulps of the mesh's largest coordinate are one vertex
/// ([`TriMesh::repaired`]).
const WELD_ULPS: f32 = 8.0;

/// Rounds of bow-tie removal in [`TriMesh::repaired`] (each round can expose a new bow-tie next
/// to a dropped face; measured meshes need one or two).
const BOWTIE_ROUNDS: usize = 16;

impl TriMesh {
    /// The faces around each vertex grouped into fans (faces linked through an edge at that
    /// vertex), in compressed rows: vertex `v`'s incident faces with their fan labels (0, 1, …
    /// in order of first appearance) are `fans[offsets[v]..offsets[v + 1]]`, faces in `faces`
    /// order. One flat array, so a mesh of millions of vertices costs 8 B per incidence.
    fn vertex_fans(&self) -> (Vec<usize>, Vec<(u32, u32)>) {
        let n = self.vertices.len();
        let mut offsets = vec![0usize; n + 1];
        for f in &self.faces {
            for &v in f {
                offsets[v as usize + 1] += 1;
            }
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fans = vec![(0u32, 0u32); offsets[n]];
        let mut fill = offsets.clone();
        for (fi, f) in self.faces.iter().enumerate() {
            for &v in f {
                fans[fill[v as usize]] = (fi as u32, 0);
                fill[v as usize] += 1;
            }
        }
        // Per vertex, union-find over its incident faces: faces sharing the edge (v, w) are in
        // one fan. Valences are small, so the other endpoints are searched linearly.
        let mut sets = DisjointSets::default();
        let mut by_other: Vec<(u32, usize)> = Vec::new();
        let mut roots: Vec<u32> = Vec::new();
        for v in 0..n {
            let row = &mut fans[offsets[v]..offsets[v + 1]];
            sets.reset(row.len());
            by_other.clear();
            for (k, &(fi, _)) in row.iter().enumerate() {
                for &w in &self.faces[fi as usize] {
                    if w as usize == v {
                        continue;
                    }
                    match by_other.iter().find(|&&(o, _)| o == w) {
                        Some(&(_, j)) => sets.union(j as u32, k as u32),
                        None => by_other.push((w, k)),
                    }
                }
            }
            roots.clear();
            for (k, entry) in row.iter_mut().enumerate() {
                let r = sets.find(k as u32);
                let label = match roots.iter().position(|&x| x == r) {
                    Some(l) => l,
                    None => {
                        roots.push(r);
                        roots.len() - 1
                    }
                };
                entry.1 = label as u32;
            }
        }
        (offsets, fans)
    }

    /// Vertices whose incident faces form more than one fan (bow-ties, module docs).
    pub fn nonmanifold_vertices(&self) -> usize {
        let (offsets, fans) = self.vertex_fans();
        offsets
            .windows(2)
            .filter(|r| fans[r[0]..r[1]].iter().any(|&(_, l)| l > 0))
            .count()
    }

    /// The mesh with bit-identical vertices welded, degenerate (repeated index or area ≤
    /// [`MIN_FACE_AREA_M2`]) and duplicate faces dropped, the faces of every fan but the largest
    /// at a bow-tie vertex dropped, and unused vertices dropped (module docs). Kept faces keep
    /// their order and orientation.
    pub fn repaired(&self) -> TriMesh {
        // Weld.
        let mut index: HashMap<[u32; 3], u32> = HashMap::new();
        let mut vertices = Vec::new();
        let map: Vec<u32> = self
            .vertices
            .iter()
            .map(|v| {
                *index
                    .entry([v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
                    .or_insert_with(|| {
                        vertices.push(*v);
                        (vertices.len() - 1) as u32
                    })
            })
            .collect();
        // Near-coincident vertices: the ends of a face edge shorter than a few ulps of the
        // coordinates are one point computed twice (two iso-surface edges crossing at a grid
        // node within rounding; a suite run's rotated site had one edge of four faces from two
        // vertices 3·10⁻⁸ m apart). Joined by union-find, each to its lowest index.
        let scale = vertices
            .iter()
            .fold(0f32, |m, v: &Vec3| m.max(v.abs().max_element()));
        let eps = WELD_ULPS * f32::EPSILON * scale.max(1.0);
        let mut parent: Vec<u32> = (0..vertices.len() as u32).collect();
        fn root(p: &mut [u32], mut a: u32) -> u32 {
            while p[a as usize] != a {
                p[a as usize] = p[p[a as usize] as usize];
                a = p[a as usize];
            }
            a
        }
        for f in &self.faces {
            let f = f.map(|i| map[i as usize]);
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if a != b && vertices[a as usize].distance(vertices[b as usize]) <= eps {
                    let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                    parent[ra.max(rb) as usize] = ra.min(rb);
                }
            }
        }
        let map: Vec<u32> = map.iter().map(|&i| root(&mut parent, i)).collect();
        // Degenerate and duplicate faces.
        let mut seen = std::collections::HashSet::new();
        let faces: Vec<[u32; 3]> = self
            .faces
            .iter()
            .map(|f| f.map(|i| map[i as usize]))
            .filter(|f| {
                if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
                    return false;
                }
                let t = f.map(|i| vertices[i as usize]);
                if crate::metrics::triangle_area(&t) <= MIN_FACE_AREA_M2 {
                    return false;
                }
                let mut key = *f;
                key.sort_unstable();
                seen.insert(key)
            })
            .collect();
        let mut out = TriMesh { vertices, faces };
        // Bow-ties: the faces of every fan but the largest (most faces; the first on a tie) are
        // dropped where they touch the vertex, in rounds, since a dropped face can leave a new
        // bow-tie next to it. Splitting the vertex instead would write coincident copies, which
        // a tool that welds on load (Open3D's `remove_duplicated_vertices`) joins again.
        for _ in 0..BOWTIE_ROUNDS {
            let mut drop = vec![false; out.faces.len()];
            let mut any = false;
            // An edge of more than two faces, or of two running the same way: the iso-surface
            // pinched where it passes a grid node (its vertices there welded); its faces —
            // slivers at the node — are dropped, and the fans this opens are mended below.
            let mut half: Vec<(u64, bool, u32)> = Vec::with_capacity(out.faces.len() * 3);
            for (fi, f) in out.faces.iter().enumerate() {
                for k in 0..3 {
                    let (a, b) = (f[k], f[(k + 1) % 3]);
                    let key = (a.min(b) as u64) << 32 | a.max(b) as u64;
                    half.push((key, a < b, fi as u32));
                }
            }
            half.sort_unstable();
            let mut i = 0;
            while i < half.len() {
                let mut j = i;
                while j < half.len() && half[j].0 == half[i].0 {
                    j += 1;
                }
                let forward = half[i..j].iter().filter(|h| h.1).count();
                if j - i > 2 || (j - i == 2 && forward != 1) {
                    any = true;
                    half[i..j].iter().for_each(|h| drop[h.2 as usize] = true);
                }
                i = j;
            }
            // Applied before the fans are formed: a face dropped here is no fan of its own.
            let mut k = 0;
            out.faces.retain(|_| {
                k += 1;
                !drop[k - 1]
            });
            let mut drop = vec![false; out.faces.len()];
            let (offsets, all) = out.vertex_fans();
            for r in offsets.windows(2) {
                let incid = &all[r[0]..r[1]];
                let fans = incid
                    .iter()
                    .map(|&(_, l)| l as usize + 1)
                    .max()
                    .unwrap_or(0);
                if fans < 2 {
                    continue;
                }
                any = true;
                let mut size = vec![0usize; fans];
                incid.iter().for_each(|&(_, l)| size[l as usize] += 1);
                let keep = (0..fans).fold(0, |b, l| if size[l] > size[b] { l } else { b });
                for &(fi, l) in incid {
                    if l as usize != keep {
                        drop[fi as usize] = true;
                    }
                }
            }
            if !any {
                break;
            }
            let mut k = 0;
            out.faces.retain(|_| {
                k += 1;
                !drop[k - 1]
            });
        }
        out.remove_unused_vertices();
        out
    }

    /// Area-weighted unit vertex normals (the sum of the incident faces' `(b − a) × (c − a)`,
    /// normalised; +z for a vertex without faces): outward for counter-clockwise faces.
    pub fn vertex_normals(&self) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; self.vertices.len()];
        for f in &self.faces {
            let [a, b, c] = f.map(|i| self.vertices[i as usize]);
            let w = (b - a).cross(c - a);
            for &i in f {
                n[i as usize] += w;
            }
        }
        n.into_iter()
            .map(|v| {
                let u = v.normalize_or_zero();
                if u == Vec3::ZERO {
                    Vec3::Z
                } else {
                    u
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles touching only at vertex 0: a bow-tie.
    fn bowtie() -> TriMesh {
        TriMesh {
            vertices: vec![
                Vec3::ZERO,
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 0.0, 0.0),
                Vec3::new(-1.0, -1.0, 0.0),
            ],
            faces: vec![[0, 1, 2], [0, 3, 4]],
        }
    }

    #[test]
    fn a_bow_tie_vertex_is_counted_and_its_smaller_fan_dropped() {
        let mut m = bowtie();
        // A second face on the fan at x < 0 makes it the larger one.
        m.vertices.push(Vec3::new(0.0, -1.0, 0.0));
        m.faces.push([0, 4, 5]);
        assert_eq!(m.nonmanifold_vertices(), 1);
        let r = m.repaired();
        assert_eq!(r.nonmanifold_vertices(), 0);
        // The two faces of the larger fan, in order, at the same positions; no vertex repeated.
        let tri = |m: &TriMesh, k: usize| m.faces[k].map(|i| m.vertices[i as usize]);
        assert_eq!(r.faces.len(), 2);
        assert_eq!(tri(&r, 0), tri(&m, 1));
        assert_eq!(tri(&r, 1), tri(&m, 2));
        assert_eq!(r.vertices.len(), 4);
        // A closed tetrahedron has no bow-tie and is unchanged.
        let t = TriMesh {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            faces: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        };
        assert_eq!(t.nonmanifold_vertices(), 0);
        assert_eq!(t.repaired(), t);
    }

    #[test]
    fn coincident_vertices_are_welded_and_degenerate_and_duplicate_faces_dropped() {
        let m = TriMesh {
            vertices: vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::Y,
                Vec3::X, // a copy of vertex 1
                Vec3::new(2.0, 0.0, 0.0),
            ],
            faces: vec![
                [0, 1, 2],
                [0, 3, 2], // the first face again, through the copy
                [1, 3, 2], // repeated vertex once welded
                [0, 1, 4], // zero area: collinear
            ],
        };
        let r = m.repaired();
        assert_eq!(r.faces, vec![[0, 1, 2]]);
        assert_eq!(r.vertices, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
        let top = r.topology();
        assert!(top.manifold && top.degenerate_faces == 0, "{top:?}");
    }

    #[test]
    fn vertices_an_ulp_apart_are_one_and_their_four_face_edge_goes() {
        // The rotated site's case: two vertices one ulp apart (a node crossed by two iso-surface
        // edges), two sheets of faces meeting at them — the edge between them is used by four
        // faces. Welded, those four are degenerate and dropped; the rest is manifold.
        let a = Vec3::new(-19.8, 0.3, 8.125);
        let b = Vec3::new(a.x, f32::from_bits(a.y.to_bits() + 1), a.z);
        assert!(a != b && a.distance(b) < 1e-7);
        let m = TriMesh {
            vertices: vec![
                a,
                b,
                a + Vec3::new(0.03, 0.0, -0.1),
                a + Vec3::new(0.02, 0.125, 0.0),
                a + Vec3::new(-0.06, 0.06, 0.06),
                a + Vec3::new(0.005, 0.125, 0.005),
            ],
            faces: vec![[2, 0, 1], [3, 1, 0], [0, 4, 1], [1, 5, 0], [2, 3, 4]],
        };
        assert!(!m.topology().manifold);
        let r = m.repaired();
        assert!(r.topology().manifold, "{:?}", r.topology());
        assert_eq!(r.faces.len(), 1);
        // The same pinch with the two vertices 4·10⁻⁵ m apart (beyond the weld; a later run of
        // the rotated site): the edge's four sliver faces are dropped instead.
        let mut apart = m.clone();
        apart.vertices[1] = a + Vec3::new(4e-6, 4e-6, 4e-5);
        let r = apart.repaired();
        assert!(r.topology().manifold, "{:?}", r.topology());
        assert_eq!(r.faces, vec![[0, 1, 2]]);
        assert_eq!(r.vertices, apart.vertices[2..5].to_vec());
        // Vertices farther apart than a few ulps stay apart.
        let far = TriMesh {
            vertices: vec![Vec3::ZERO, Vec3::new(1e-3, 0.0, 0.0), Vec3::Y],
            faces: vec![[0, 1, 2]],
        };
        assert_eq!(far.repaired(), far);
    }

    #[test]
    fn vertex_normals_point_out_of_a_counter_clockwise_solid() {
        let t = TriMesh {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            faces: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        };
        let centre = Vec3::splat(0.25);
        for (v, n) in t.vertices.iter().zip(t.vertex_normals()) {
            assert!((n.length() - 1.0).abs() < 1e-6);
            assert!(n.dot(*v - centre) > 0.0, "{v} {n}");
        }
    }
}
