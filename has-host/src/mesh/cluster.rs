//! Vertex clustering (Rossignac–Borrel): a coarser copy of a mesh for display. Every vertex
//! moves to the mean of the vertices in its cell of a cubic grid of side `cell_m`; faces whose
//! corners fall into fewer than three cells vanish, and a face repeated (same three cells, either
//! winding) is kept once. The shape is kept to about a cell; topology is not (thin parts may
//! close or open), so this is for looking at a mesh, not for scoring it. Units: metres.

use std::collections::{BTreeMap, HashSet};

use glam::Vec3;

use super::TriMesh;

/// `mesh` with its vertices clustered on a grid of side `cell_m` (module docs). A cell that is
/// not positive and finite returns the mesh unchanged.
pub fn cluster_vertices(mesh: &TriMesh, cell_m: f32) -> TriMesh {
    if !(cell_m > 0.0 && cell_m.is_finite()) {
        return mesh.clone();
    }
    let key = |p: Vec3| {
        let q = (p / cell_m).floor();
        (q.x as i64, q.y as i64, q.z as i64)
    };
    // Cells in sorted order, so the output does not depend on hashing.
    let mut cells: BTreeMap<(i64, i64, i64), (Vec3, u32)> = BTreeMap::new();
    for &p in &mesh.vertices {
        let e = cells.entry(key(p)).or_insert((Vec3::ZERO, 0));
        e.0 += p;
        e.1 += 1;
    }
    let index: BTreeMap<(i64, i64, i64), u32> = cells
        .keys()
        .enumerate()
        .map(|(i, &k)| (k, i as u32))
        .collect();
    let vertices: Vec<Vec3> = cells.values().map(|&(s, n)| s / n as f32).collect();
    let mut seen = HashSet::new();
    let mut faces = Vec::new();
    for f in &mesh.faces {
        let c = f.map(|i| index[&key(mesh.vertices[i as usize])]);
        if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] {
            continue;
        }
        let mut sorted = c;
        sorted.sort_unstable();
        if seen.insert(sorted) {
            faces.push(c);
        }
    }
    TriMesh { vertices, faces }
}

/// `mesh` as is when it has at most `max_faces` faces, else clustered on the finest grid (cells
/// from the mean edge length, growing by √2) that brings it there; with the cell used.
pub fn simplified_to(mesh: &TriMesh, max_faces: usize) -> (TriMesh, Option<f32>) {
    if mesh.faces.len() <= max_faces {
        return (mesh.clone(), None);
    }
    let edges: f64 = mesh
        .faces
        .iter()
        .map(|f| {
            let v = f.map(|i| mesh.vertices[i as usize]);
            f64::from(v[0].distance(v[1]) + v[1].distance(v[2]) + v[2].distance(v[0]))
        })
        .sum::<f64>()
        / (3 * mesh.faces.len()) as f64;
    let mut cell = (edges as f32).max(1e-3);
    loop {
        let m = cluster_vertices(mesh, cell);
        if m.faces.len() <= max_faces || cell > 1e4 {
            return (m, Some(cell));
        }
        cell *= std::f32::consts::SQRT_2;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat n × n grid of unit squares, two faces each.
    fn grid(n: u32) -> TriMesh {
        let vertices = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| Vec3::new(i as f32, j as f32, 0.0)))
            .collect();
        let faces = (0..n)
            .flat_map(|j| {
                (0..n).flat_map(move |i| {
                    let v = j * (n + 1) + i;
                    [[v, v + 1, v + n + 2], [v, v + n + 2, v + n + 1]]
                })
            })
            .collect();
        TriMesh { vertices, faces }
    }

    #[test]
    fn clustering_keeps_the_shape_within_a_cell_and_drops_collapsed_faces() {
        let m = grid(32);
        let c = cluster_vertices(&m, 4.0);
        assert!(c.faces.len() < m.faces.len() / 8, "{}", c.faces.len());
        assert!(!c.faces.is_empty());
        for v in &c.vertices {
            assert!(v.z == 0.0 && v.x >= 0.0 && v.x <= 32.0 && v.y >= 0.0 && v.y <= 32.0);
        }
        for f in &c.faces {
            assert!(f[0] != f[1] && f[1] != f[2] && f[0] != f[2]);
            assert!((f.iter().all(|&i| (i as usize) < c.vertices.len())));
        }
        // Area stays that of the square to within the border cells.
        let area: f32 = c
            .faces
            .iter()
            .map(|f| {
                let v = f.map(|i| c.vertices[i as usize]);
                0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length()
            })
            .sum();
        assert!((area - 1024.0).abs() < 0.25 * 1024.0, "{area}");
    }

    #[test]
    fn a_mesh_over_the_budget_is_simplified_under_it_and_one_under_is_kept() {
        let m = grid(40);
        let (same, cell) = simplified_to(&m, m.faces.len());
        assert_eq!((same, cell), (m.clone(), None));
        let (small, cell) = simplified_to(&m, 500);
        assert!(small.faces.len() <= 500 && !small.faces.is_empty());
        assert!(cell.is_some_and(|c| c > 1.0));
    }
}
