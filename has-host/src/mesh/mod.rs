//! Surface reconstruction (paper §1.3): oriented normals ([`normals`]), screened Poisson
//! reconstruction of an indicator function ([`poisson`]), iso-surface extraction ([`iso`]) and
//! density trimming, producing a [`TriMesh`] — the digital twin.
//!
//! Units: metres. Faces are counter-clockwise seen from outside (normals by the right-hand rule
//! point out of the reconstructed solid). [`TriMesh::topology`] counts edge uses: a mesh is
//! *edge-manifold* when no undirected edge is used by more than two faces and the two uses run in
//! opposite directions, and *watertight* when, in addition, every edge is used exactly twice.

pub mod iso;
pub mod normals;
pub mod poisson;

use std::collections::HashMap;

use glam::Vec3;

use crate::knn::GeometryError;
use crate::metrics;

pub use normals::{estimate_normals, Orientation};
pub use poisson::{
    screened_poisson, support_density, trim, trim_by_density, PoissonOutput, PoissonParams, Trim,
};

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions, metres.
    pub vertices: Vec<Vec3>,
    /// Triangles as indices into `vertices`, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
}

/// Edge-use counts of a mesh (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Topology {
    /// Undirected edges.
    pub edges: usize,
    /// Edges used by exactly one face (holes, trimmed borders).
    pub boundary_edges: usize,
    /// Edges used by three or more faces.
    pub nonmanifold_edges: usize,
    /// Edges used twice in the same direction (inconsistent orientation).
    pub misoriented_edges: usize,
    /// Faces with a repeated vertex index.
    pub degenerate_faces: usize,
    /// No non-manifold or misoriented edge and no degenerate face.
    pub manifold: bool,
    /// Manifold and without boundary edges (a closed surface), and not empty.
    pub watertight: bool,
}

impl TriMesh {
    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.faces.len()
    }

    /// Checks face indices and vertex finiteness.
    ///
    /// # Errors
    /// [`GeometryError::BadFace`] or [`GeometryError::NonFinite`] (field `"vertices"`).
    pub fn validate(&self) -> Result<(), GeometryError> {
        if let Some((index, &value)) = self
            .vertices
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite())
        {
            return Err(GeometryError::NonFinite {
                field: "vertices",
                index,
                value,
            });
        }
        metrics::indexed_triangles(&self.vertices, &self.faces).map(|_| ())
    }

    /// Edge-use counting (see the module docs). Face indices must be valid ([`Self::validate`]).
    pub fn topology(&self) -> Topology {
        // Per undirected edge: (uses a<b direction, uses b<a direction).
        let mut uses: HashMap<(u32, u32), (u32, u32)> =
            HashMap::with_capacity(self.faces.len() * 3 / 2);
        let mut degenerate_faces = 0;
        for f in &self.faces {
            if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
                degenerate_faces += 1;
                continue;
            }
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                let e = uses.entry((a.min(b), a.max(b))).or_default();
                if a < b {
                    e.0 += 1;
                } else {
                    e.1 += 1;
                }
            }
        }
        let mut t = Topology {
            edges: uses.len(),
            degenerate_faces,
            ..Topology::default()
        };
        for &(fwd, back) in uses.values() {
            match fwd + back {
                1 => t.boundary_edges += 1,
                2 => {
                    if fwd != 1 {
                        t.misoriented_edges += 1;
                    }
                }
                _ => t.nonmanifold_edges += 1,
            }
        }
        t.manifold = t.nonmanifold_edges == 0 && t.misoriented_edges == 0 && degenerate_faces == 0;
        t.watertight = t.manifold && t.boundary_edges == 0 && !self.faces.is_empty();
        t
    }

    /// Total surface area, m².
    pub fn area_m2(&self) -> f64 {
        self.faces
            .iter()
            .map(|f| {
                let t = [
                    self.vertices[f[0] as usize],
                    self.vertices[f[1] as usize],
                    self.vertices[f[2] as usize],
                ];
                metrics::triangle_area(&t) as f64
            })
            .sum()
    }

    /// Uniform area-weighted samples on the faces ([`metrics::sample_mesh`]): S1 for the metrics.
    ///
    /// # Errors
    /// As [`metrics::sample_mesh`].
    pub fn sample(&self, density_per_m2: f64, seed: u64) -> Result<Vec<Vec3>, GeometryError> {
        metrics::sample_mesh(&self.vertices, &self.faces, density_per_m2, seed)
    }

    /// Drops vertices not used by any face and renumbers the faces (kept vertices keep their
    /// relative order).
    pub fn remove_unused_vertices(&mut self) {
        let mut used = vec![false; self.vertices.len()];
        for f in &self.faces {
            for &v in f {
                used[v as usize] = true;
            }
        }
        let mut map = vec![u32::MAX; self.vertices.len()];
        let mut verts = Vec::new();
        for (i, v) in self.vertices.iter().enumerate() {
            if used[i] {
                map[i] = verts.len() as u32;
                verts.push(*v);
            }
        }
        for f in &mut self.faces {
            for v in f.iter_mut() {
                *v = map[*v as usize];
            }
        }
        self.vertices = verts;
    }
}

/// Settings of [`reconstruct`].
#[derive(Clone, Debug)]
pub struct ReconstructParams {
    /// Neighbours used for PCA normals.
    pub normal_k: usize,
    /// Poisson settings.
    pub poisson: PoissonParams,
    /// Density trim ([`Trim`]); `None` keeps the closed surface.
    pub trim: Option<Trim>,
}

impl Default for ReconstructParams {
    fn default() -> Self {
        ReconstructParams {
            normal_k: 16,
            poisson: PoissonParams::default(),
            trim: None,
        }
    }
}

/// Result of [`reconstruct`].
#[derive(Clone, Debug)]
pub struct Reconstruction {
    /// The final mesh (trimmed if asked).
    pub mesh: TriMesh,
    /// The untrimmed Poisson output with its diagnostics.
    pub poisson: PoissonOutput,
    /// Normals used, one per input point.
    pub normals: Vec<Vec3>,
    /// Seconds spent estimating normals.
    pub normals_s: f64,
}

/// Normals → screened Poisson → optional density trim, on an unoriented cloud.
///
/// # Errors
/// As [`estimate_normals`], [`screened_poisson`] and [`trim()`].
pub fn reconstruct(
    points: &[Vec3],
    orientation: Orientation<'_>,
    params: &ReconstructParams,
) -> Result<Reconstruction, GeometryError> {
    let t0 = std::time::Instant::now();
    let normals = estimate_normals(points, params.normal_k, orientation)?;
    let normals_s = t0.elapsed().as_secs_f64();
    let poisson = screened_poisson(points, &normals, &params.poisson)?;
    let mesh = match params.trim {
        Some(rule) => trim(&poisson.mesh, &poisson.vertex_density, rule)?,
        None => poisson.mesh.clone(),
    };
    Ok(Reconstruction {
        mesh,
        poisson,
        normals,
        normals_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> TriMesh {
        TriMesh {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            faces: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        }
    }

    #[test]
    fn closed_tetrahedron_is_watertight_and_open_or_flipped_ones_are_not() {
        let t = tetra();
        let top = t.topology();
        assert!(top.watertight && top.manifold, "{top:?}");
        assert_eq!(top.edges, 6);
        let mut open = t.clone();
        open.faces.pop();
        let o = open.topology();
        assert!(
            o.manifold && !o.watertight && o.boundary_edges == 3,
            "{o:?}"
        );
        let mut flipped = t.clone();
        flipped.faces[0] = [0, 1, 2];
        let f = flipped.topology();
        assert!(!f.manifold && f.misoriented_edges == 3, "{f:?}");
        let mut fin = t.clone();
        fin.faces.push([0, 1, 2]);
        assert_eq!(fin.topology().nonmanifold_edges, 3);
        assert!((t.area_m2() - (1.5 + 3f64.sqrt() / 2.0)).abs() < 1e-6);
    }

    #[test]
    fn validate_rejects_bad_index_and_nan_vertex() {
        let mut t = tetra();
        t.faces[1][2] = 9;
        assert!(matches!(
            t.validate(),
            Err(GeometryError::BadFace {
                face: 1,
                vertex: 9,
                ..
            })
        ));
        let mut t = tetra();
        t.vertices[2].x = f32::NAN;
        assert!(matches!(
            t.validate(),
            Err(GeometryError::NonFinite { index: 2, .. })
        ));
    }
}
