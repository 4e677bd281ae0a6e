//! Surface reconstruction (paper §1.3): oriented normals ([`normals`]), screened Poisson
//! reconstruction of an indicator function ([`poisson`]), iso-surface extraction ([`iso`]) and
//! density trimming, producing a [`TriMesh`] — the digital twin.
//!
//! Units: metres. Faces are counter-clockwise seen from outside (normals by the right-hand rule
//! point out of the reconstructed solid). [`TriMesh::topology`] counts edge uses: a mesh is
//! *edge-manifold* when no undirected edge is used by more than two faces and the two uses run in
//! opposite directions, and *watertight* when, in addition, every edge is used exactly twice;
//! [`repair`] makes the written mesh pass the vertex-manifold check as well.

pub mod band;
mod cluster;
mod grid;
pub mod iso;
pub mod normals;
pub mod poisson;
pub mod repair;
pub mod visibility;

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use crate::disjoint_sets::DisjointSets;
use crate::knn::GeometryError;
use crate::metrics;

pub use cluster::{cluster_vertices, simplified_to};
pub use normals::{estimate_normals, estimate_normals_over, Neighbourhood, Orientation};
pub use poisson::{
    depth_for_cell, screened_poisson, screened_poisson_weighted, support_density, trim,
    trim_by_density, PoissonOutput, PoissonParams, Trim,
};
pub use visibility::visibility_consistent;

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
    /// Vertices whose faces form two or more fans touching only there (bow-ties,
    /// [`TriMesh::nonmanifold_vertices`]).
    pub nonmanifold_vertices: usize,
    /// No non-manifold or misoriented edge, no degenerate face and no bow-tie vertex (Open3D's
    /// edge- and vertex-manifold checks together).
    pub manifold: bool,
    /// Manifold and without boundary edges (a closed surface), and not empty.
    pub watertight: bool,
}

impl TriMesh {
    /// A mesh of separate triangles (three vertices per face, nothing shared), counter-clockwise
    /// as given.
    pub fn from_triangles(triangles: impl IntoIterator<Item = [Vec3; 3]>) -> Self {
        let vertices: Vec<Vec3> = triangles.into_iter().flatten().collect();
        let faces = (0..vertices.len() as u32 / 3)
            .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
            .collect();
        Self { vertices, faces }
    }

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
        // Directed edges a → b as sorted keys a·2³² + b (8 bytes per face side, no hash table).
        let mut degenerate_faces = 0;
        let mut half: Vec<u64> = Vec::with_capacity(self.faces.len() * 3);
        for f in &self.faces {
            if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
                degenerate_faces += 1;
                continue;
            }
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                half.push((a as u64) << 32 | b as u64);
            }
        }
        half.par_sort_unstable();
        let count = |key: u64| -> u32 {
            (half.partition_point(|&h| h <= key) - half.partition_point(|&h| h < key)) as u32
        };
        let mut t = Topology {
            degenerate_faces,
            ..Topology::default()
        };
        let mut i = 0;
        while i < half.len() {
            let key = half[i];
            let mut j = i + 1;
            while j < half.len() && half[j] == key {
                j += 1;
            }
            let (a, b) = ((key >> 32) as u32, key as u32);
            let n = (j - i) as u32;
            let reverse = count((b as u64) << 32 | a as u64);
            // Each undirected edge once: from its a < b direction, or from the other one when
            // that is its only direction. fwd = uses in the a < b direction.
            if a < b || reverse == 0 {
                let (fwd, back) = if a < b { (n, reverse) } else { (0, n) };
                t.edges += 1;
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
            i = j;
        }
        t.nonmanifold_vertices = self.nonmanifold_vertices();
        t.manifold = t.nonmanifold_edges == 0
            && t.misoriented_edges == 0
            && degenerate_faces == 0
            && t.nonmanifold_vertices == 0;
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

    /// The mesh as one scene object of `material` (its faces as triangles, in face order): a
    /// reconstructed twin handed to the ray tracer (`channel_experiment`, `localize`) without a
    /// file in between.
    ///
    /// # Errors
    /// A face indexing a vertex the mesh does not have.
    pub fn to_object(
        &self,
        name: &str,
        material: crate::Material,
    ) -> Result<crate::Object, GeometryError> {
        Ok(crate::Object {
            thickness_m: None,
            name: name.to_string(),
            material,
            triangles: metrics::indexed_triangles(&self.vertices, &self.faces)?,
        })
    }

    /// Uniform area-weighted samples on the faces ([`metrics::sample_mesh`]): S1 for the metrics.
    ///
    /// # Errors
    /// As [`metrics::sample_mesh`].
    pub fn sample(&self, density_per_m2: f64, seed: u64) -> Result<Vec<Vec3>, GeometryError> {
        metrics::sample_mesh(&self.vertices, &self.faces, density_per_m2, seed)
    }

    /// Connected components of the faces (two faces are connected when they share a vertex):
    /// one label per face, labels 0.. in order of first appearance.
    pub fn face_components(&self) -> Vec<u32> {
        let mut sets = DisjointSets::new(self.vertices.len());
        for f in &self.faces {
            for &v in &f[1..] {
                sets.union(f[0], v);
            }
        }
        let mut label = HashMap::new();
        self.faces
            .iter()
            .map(|f| {
                let root = sets.find(f[0]);
                let next = label.len() as u32;
                *label.entry(root).or_insert(next)
            })
            .collect()
    }

    /// Keeps the connected components ([`Self::face_components`]) whose area is at least
    /// `min_fraction` of the largest component's (Open3D's habit of removing small clusters:
    /// isolated blobs around ghost points and sidelobes), drops unused vertices.
    ///
    /// # Errors
    /// `min_fraction` outside [0, 1].
    pub fn remove_small_components(&self, min_fraction: f32) -> Result<TriMesh, GeometryError> {
        if !(0.0..=1.0).contains(&min_fraction) {
            return Err(GeometryError::BadParameter {
                field: "min_component_fraction",
                value: min_fraction as f64,
                expected: "in [0, 1]",
            });
        }
        let labels = self.face_components();
        let n = labels.iter().map(|&l| l as usize + 1).max().unwrap_or(0);
        let mut area = vec![0.0f64; n];
        for (f, &l) in self.faces.iter().zip(&labels) {
            let t = [
                self.vertices[f[0] as usize],
                self.vertices[f[1] as usize],
                self.vertices[f[2] as usize],
            ];
            area[l as usize] += metrics::triangle_area(&t) as f64;
        }
        let largest = area.iter().copied().fold(0.0, f64::max);
        let keep: Vec<bool> = area
            .iter()
            .map(|&a| a >= min_fraction as f64 * largest)
            .collect();
        let out = self.with_faces_where(|f| keep[labels[f] as usize]);
        Ok(out)
    }

    /// Keeps the faces whose three vertices lie inside the axis-aligned box [`min`, `max`]
    /// (inclusive), drops unused vertices: the mesh is cut back to the region that was imaged,
    /// removing what the closed Poisson surface invented outside it (e.g. a bottom cap below
    /// the imaging region).
    ///
    /// # Errors
    /// A bound not finite, or `min` above `max` on some axis (field `"clip_box"`).
    pub fn clip_to_box(&self, min: Vec3, max: Vec3) -> Result<TriMesh, GeometryError> {
        for (lo, hi) in min.to_array().into_iter().zip(max.to_array()) {
            if !(lo.is_finite() && hi.is_finite()) || lo > hi {
                return Err(GeometryError::BadParameter {
                    field: "clip_box",
                    value: if lo.is_finite() { hi as f64 } else { lo as f64 },
                    expected: "finite bounds with min <= max on every axis",
                });
            }
        }
        Ok(self.clip_to(|v| v.cmpge(min).all() && v.cmple(max).all()))
    }

    /// Keeps the faces whose three vertices `inside` holds, drops the vertices no kept face uses:
    /// the mesh cut back to a region that is not a box (an imaging region drawn on the map as a
    /// polygon), outside which nothing was imaged.
    pub fn clip_to(&self, inside: impl Fn(Vec3) -> bool + Sync) -> TriMesh {
        let kept: Vec<bool> = self.vertices.par_iter().map(|&v| inside(v)).collect();
        self.with_faces_where(|f| self.faces[f].iter().all(|&i| kept[i as usize]))
    }

    /// Drops the faces whose three vertices all lie more than `depth_m` below `ground(v)`, the
    /// height of the known ground under vertex `v` (`None` where it is not known: kept), and
    /// the vertices no face uses. The ground is opaque and known: what the closed Poisson
    /// surface puts under it (the flare at the foot of walls whose samples end at the ground)
    /// was never seen, and on sloping ground the region's floor, a plane at its lowest point,
    /// does not cut it away.
    pub fn clip_below_ground(
        &self,
        ground: impl Fn(Vec3) -> Option<f32> + Sync,
        depth_m: f32,
    ) -> TriMesh {
        let under: Vec<bool> = self
            .vertices
            .par_iter()
            .map(|&v| ground(v).is_some_and(|g| v.z < g - depth_m))
            .collect();
        self.with_faces_where(|f| !self.faces[f].iter().all(|&i| under[i as usize]))
    }

    /// Keeps only the faces whose centroid lies within `max_m` of some point of `support` (the
    /// cloud the surface was reconstructed from): surface farther than that from every sample is
    /// the solver's extrapolation, not something that was measured.
    ///
    /// # Errors
    /// `max_m` not finite and positive (field `"support_distance_m"`); a bad `support` cloud
    /// ([`crate::knn::PointIndex::new`]).
    pub fn clip_to_support(&self, support: &[Vec3], max_m: f32) -> Result<TriMesh, GeometryError> {
        if !(max_m.is_finite() && max_m > 0.0) {
            return Err(GeometryError::BadParameter {
                field: "support_distance_m",
                value: max_m as f64,
                expected: "finite and > 0 m",
            });
        }
        let index = crate::knn::PointIndex::new("support", support)?;
        let centroids: Vec<Vec3> = self
            .faces
            .iter()
            .map(|f| f.iter().map(|&v| self.vertices[v as usize]).sum::<Vec3>() / 3.0)
            .collect();
        let d2 = index.nearest_sq_many(&centroids);
        let out = self.with_faces_where(|f| d2[f] <= max_m * max_m);
        Ok(out)
    }

    /// Keeps only the faces that turn the same way as the samples they were reconstructed from:
    /// a face whose normal (right-hand rule) has a negative dot product with the oriented normal
    /// of the sample nearest its centroid is dropped. Where the samples are an open sheet — a
    /// wall seen from one side — screened Poisson closes a thin solid around them, and the solid's
    /// far side faces away from where the samples' normals say their sensors are: it was never
    /// seen, and it doubles the surface's area. Degenerate faces are kept.
    ///
    /// # Errors
    /// `normals` not one per sample (field `"normals"`); a bad `samples` cloud
    /// ([`crate::knn::PointIndex::new`]).
    pub fn facing_samples(
        &self,
        samples: &[Vec3],
        normals: &[Vec3],
    ) -> Result<TriMesh, GeometryError> {
        if normals.len() != samples.len() {
            return Err(GeometryError::BadParameter {
                field: "normals",
                value: normals.len() as f64,
                expected: "one per sample",
            });
        }
        let index = crate::knn::PointIndex::new("samples", samples)?;
        let keep: Vec<bool> = self
            .faces
            .par_iter()
            .map(|f| {
                let [a, b, c] = f.map(|v| self.vertices[v as usize]);
                let n = (b - a).cross(c - a);
                let (i, _) = index.nearest((a + b + c) / 3.0);
                n.dot(normals[i as usize]) >= 0.0
            })
            .collect();
        let out = self.with_faces_where(|f| keep[f]);
        Ok(out)
    }

    /// The faces `f` (by index) for which `keep(f)` holds, in order, without the vertices no kept
    /// face uses.
    fn with_faces_where(&self, keep: impl Fn(usize) -> bool) -> TriMesh {
        let mut out = TriMesh {
            vertices: self.vertices.clone(),
            faces: (0..self.faces.len())
                .filter(|&f| keep(f))
                .map(|f| self.faces[f])
                .collect(),
        };
        out.remove_unused_vertices();
        out
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
    /// After trimming, keep only faces inside this box (lower, upper corner, metres; see
    /// [`TriMesh::clip_to_box`]); `None` keeps everything.
    pub clip_box: Option<(Vec3, Vec3)>,
    /// After clipping, keep only faces within this distance (m) of an input point
    /// ([`TriMesh::clip_to_support`]); `None` keeps everything.
    pub support_distance_m: Option<f32>,
    /// After clipping, keep only the faces turned as the samples nearest them
    /// ([`TriMesh::facing_samples`]): an open sheet of samples gives one surface, not a thin
    /// closed solid.
    pub facing_samples: bool,
    /// After trimming and clipping, drop connected components smaller than this fraction of the largest
    /// one's area ([`TriMesh::remove_small_components`]); `None` keeps them all.
    pub min_component_fraction: Option<f32>,
}

impl Default for ReconstructParams {
    fn default() -> Self {
        ReconstructParams {
            normal_k: 16,
            poisson: PoissonParams::default(),
            trim: None,
            clip_box: None,
            support_distance_m: None,
            facing_samples: false,
            min_component_fraction: None,
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

/// Normals → screened Poisson → optional density trim, clip and small-component removal, on an
/// unoriented cloud: [`estimate_normals`], then [`reconstruct_oriented`].
///
/// # Errors
/// As [`estimate_normals`] and [`reconstruct_oriented`].
pub fn reconstruct(
    points: &[Vec3],
    weights: Option<&[f32]>,
    orientation: Orientation<'_>,
    params: &ReconstructParams,
) -> Result<Reconstruction, GeometryError> {
    let t0 = std::time::Instant::now();
    let normals = estimate_normals(points, params.normal_k, orientation)?;
    let normals_s = t0.elapsed().as_secs_f64();
    let mut rec = reconstruct_oriented(points, normals, weights, params)?;
    rec.normals_s = normals_s;
    Ok(rec)
}

/// Screened Poisson → optional density trim, box clip, support clip, [`TriMesh::repaired`] and
/// small-component removal, on an oriented cloud (one normal per point; `params.normal_k` is
/// not used). `weights` are the samples' confidences (e.g. a detection's amplitude,
/// [`screened_poisson_weighted`]); `None` weighs every sample alike.
///
/// # Errors
/// As [`screened_poisson_weighted`], [`trim()`], [`TriMesh::clip_to_box`],
/// [`TriMesh::clip_to_support`] and [`TriMesh::remove_small_components`].
pub fn reconstruct_oriented(
    points: &[Vec3],
    normals: Vec<Vec3>,
    weights: Option<&[f32]>,
    params: &ReconstructParams,
) -> Result<Reconstruction, GeometryError> {
    let poisson = screened_poisson_weighted(points, &normals, weights, &params.poisson)?;
    let mesh = match params.trim {
        Some(rule) => trim(&poisson.mesh, &poisson.vertex_density, rule)?,
        None => poisson.mesh.clone(),
    };
    let mesh = match params.clip_box {
        Some((lo, hi)) => mesh.clip_to_box(lo, hi)?,
        None => mesh,
    };
    let mesh = match params.support_distance_m {
        Some(d) => mesh.clip_to_support(points, d)?,
        None => mesh,
    };
    let mesh = if params.facing_samples {
        mesh.facing_samples(points, &normals)?
    } else {
        mesh
    };
    // What other tools reject (coincident vertices, degenerate and duplicate faces, bow-ties),
    // repaired before small components are counted: a fragment that touched the surface at one
    // vertex is then a component of its own.
    let mesh = mesh.repaired();
    let mesh = match params.min_component_fraction {
        Some(f) => mesh.remove_small_components(f)?,
        None => mesh,
    };
    Ok(Reconstruction {
        mesh,
        poisson,
        normals,
        normals_s: 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mesh_becomes_one_traceable_object_with_its_faces_in_order() {
        let m = tetra();
        let o = m.to_object("twin", crate::Material::Concrete).unwrap();
        assert_eq!(
            (o.name.as_str(), o.triangles.len()),
            ("twin", m.faces.len())
        );
        for (t, f) in o.triangles.iter().zip(&m.faces) {
            assert_eq!(*t, f.map(|v| m.vertices[v as usize]));
        }
        // The object builds a scene, and a ray at the mesh hits it.
        let scene = crate::Scene::new(vec![o]).unwrap();
        let c = m.vertices.iter().copied().sum::<Vec3>() / m.vertices.len() as f32;
        assert!(!scene.visible(c + Vec3::new(0.0, 0.0, 10.0), c));
        // A face past the vertices is an error, not a panic.
        let mut bad = m.clone();
        bad.faces[0][1] = 99;
        assert!(bad.to_object("bad", crate::Material::Concrete).is_err());
    }

    #[test]
    fn surface_away_from_every_sample_is_clipped_and_supported_surface_kept() {
        let m = tetra();
        // Support at the first face's centroid only: a radius just above zero keeps that face.
        let c0 = m.faces[0]
            .iter()
            .map(|&v| m.vertices[v as usize])
            .sum::<Vec3>()
            / 3.0;
        let kept = m.clip_to_support(&[c0], 1e-4).unwrap();
        assert_eq!(kept.faces.len(), 1);
        // A radius beyond the mesh's extent keeps every face; bad radii are errors.
        assert_eq!(
            m.clip_to_support(&[c0], 100.0).unwrap().faces.len(),
            m.faces.len()
        );
        assert!(m.clip_to_support(&[c0], 0.0).is_err());
        assert!(m.clip_to_support(&[c0], f32::NAN).is_err());
    }

    #[test]
    fn a_thin_solid_around_an_open_sheet_keeps_only_the_side_its_samples_face() {
        // What Poisson closes around a roof seen from above: a slab 10 × 10 × 0.2 m, samples on
        // its mid-plane with normals up. The top stays, the bottom goes, the rims (normals
        // across the samples') stay; samples turned down keep the bottom instead.
        let slab = crate::shapes::axis_box(
            "slab",
            crate::Material::Concrete,
            Vec3::new(0.0, 0.0, -0.1),
            Vec3::new(10.0, 10.0, 0.1),
        )
        .unwrap();
        let m = TriMesh::from_triangles(slab.triangles);
        let samples: Vec<Vec3> = (0..100)
            .map(|i| Vec3::new((i % 10) as f32 + 0.5, (i / 10) as f32 + 0.5, 0.0))
            .collect();
        let z_of = |m: &TriMesh| -> Vec<i32> {
            m.faces
                .iter()
                .map(|f| {
                    let [a, b, c] = f.map(|v| m.vertices[v as usize]);
                    (b - a).cross(c - a).normalize().z.round() as i32
                })
                .collect()
        };
        let count = |v: &[i32], z: i32| v.iter().filter(|&&x| x == z).count();
        let all = z_of(&m);
        assert_eq!((count(&all, 1), count(&all, -1), count(&all, 0)), (2, 2, 8));
        let up = z_of(&m.facing_samples(&samples, &vec![Vec3::Z; 100]).unwrap());
        assert_eq!((count(&up, 1), count(&up, -1), count(&up, 0)), (2, 0, 8));
        let down = z_of(&m.facing_samples(&samples, &vec![-Vec3::Z; 100]).unwrap());
        assert_eq!(
            (count(&down, 1), count(&down, -1), count(&down, 0)),
            (0, 2, 8)
        );
        assert!(matches!(
            m.facing_samples(&samples, &[Vec3::Z]),
            Err(GeometryError::BadParameter {
                field: "normals",
                ..
            })
        ));
    }

    fn tetra() -> TriMesh {
        TriMesh {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            faces: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        }
    }

    #[test]
    fn faces_wholly_under_the_ground_are_cut_and_faces_reaching_above_it_stay() {
        // Three separate triangles: one 2 m under the ground (z = 1), one crossing it, one
        // under it where the ground is not known (x > 10).
        let tri = |o: Vec3| [o, o + Vec3::X, o + Vec3::Y];
        let m = TriMesh::from_triangles([
            tri(Vec3::new(0.0, 0.0, -1.0)),
            [
                Vec3::new(3.0, 0.0, -1.0),
                Vec3::new(4.0, 0.0, 2.0),
                Vec3::new(3.0, 1.0, -1.0),
            ],
            tri(Vec3::new(20.0, 0.0, -1.0)),
        ]);
        let ground = |v: Vec3| (v.x < 10.0).then_some(1.0);
        let cut = m.clip_below_ground(ground, 0.5);
        assert_eq!(cut.face_count(), 2);
        assert_eq!(cut.vertex_count(), 6);
        assert!(cut.vertices.iter().all(|v| v.x >= 3.0));
        // Within `depth_m` of the ground is kept.
        assert_eq!(m.clip_below_ground(ground, 2.5).face_count(), 3);
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

    /// Edge-use counting with a hash map per undirected edge (the definition, directly).
    fn reference_topology(m: &TriMesh) -> Topology {
        let mut uses: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
        let mut t = Topology::default();
        for f in &m.faces {
            if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
                t.degenerate_faces += 1;
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
        t.edges = uses.len();
        for &(fwd, back) in uses.values() {
            match fwd + back {
                1 => t.boundary_edges += 1,
                2 if fwd != 1 => t.misoriented_edges += 1,
                2 => {}
                _ => t.nonmanifold_edges += 1,
            }
        }
        // Vertex fans are tested in `repair`; the edge counting is what this reference checks.
        t.nonmanifold_vertices = m.nonmanifold_vertices();
        t.manifold = t.nonmanifold_edges == 0
            && t.misoriented_edges == 0
            && t.degenerate_faces == 0
            && t.nonmanifold_vertices == 0;
        t.watertight = t.manifold && t.boundary_edges == 0 && !m.faces.is_empty();
        t
    }

    #[test]
    fn sorted_edge_topology_matches_the_hash_map_definition() {
        use rand::{Rng, SeedableRng};
        // Random face soups over few vertices: every defect (boundary, both-direction and
        // one-direction double uses, fans of 3+, degenerate faces) occurs.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for n_faces in [0, 1, 5, 40, 300] {
            let m = TriMesh {
                vertices: vec![Vec3::ZERO; 12],
                faces: (0..n_faces)
                    .map(|_| [0; 3].map(|_| rng.random_range(0..12u32)))
                    .collect(),
            };
            assert_eq!(m.topology(), reference_topology(&m), "{n_faces} faces");
        }
        let t = tetra();
        assert_eq!(t.topology(), reference_topology(&t));
    }

    #[test]
    fn small_components_are_dropped_and_large_ones_kept() {
        // A unit tetrahedron (area ≈ 2.37 m²) and one scaled by 0.1 (area ≈ 0.024 m², 1 %).
        let big = tetra();
        let mut m = big.clone();
        let off = m.vertices.len() as u32;
        m.vertices
            .extend(big.vertices.iter().map(|&v| v * 0.1 + Vec3::splat(5.0)));
        m.faces.extend(
            big.faces
                .iter()
                .map(|f| [f[0] + off, f[1] + off, f[2] + off]),
        );
        let labels = m.face_components();
        assert_eq!(labels, vec![0, 0, 0, 0, 1, 1, 1, 1]);
        // 2 % of the largest area removes the 1 % tetrahedron, 0.5 % keeps it.
        let kept = m.remove_small_components(0.02).unwrap();
        assert_eq!(kept, big);
        assert_eq!(m.remove_small_components(0.005).unwrap(), m);
        assert!(m.remove_small_components(1.5).is_err());
        assert!(m.remove_small_components(f32::NAN).is_err());
    }

    #[test]
    fn clip_keeps_faces_inside_the_box_only() {
        let t = tetra();
        // The box z ≤ 0.5 excludes vertex 3 (0, 0, 1): only the bottom face remains.
        let c = t
            .clip_to_box(Vec3::splat(-1.0), Vec3::new(2.0, 2.0, 0.5))
            .unwrap();
        assert_eq!(c.faces, vec![[0, 2, 1]]);
        assert_eq!(c.vertices.len(), 3);
        assert_eq!(
            t.clip_to_box(Vec3::splat(-1.0), Vec3::splat(2.0)).unwrap(),
            t
        );
        assert!(t.clip_to_box(Vec3::ONE, Vec3::ZERO).is_err());
        assert!(t
            .clip_to_box(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ONE)
            .is_err());
    }

    #[test]
    fn clip_to_keeps_the_faces_wholly_inside_a_region() {
        let t = tetra();
        // x + y < 0.9 holds at the origin and the apex only, and every face uses vertex 1 or 2:
        // nothing is left.
        let c = t.clip_to(|v| v.x + v.y < 0.9);
        assert!(c.faces.is_empty() && c.vertices.is_empty(), "{c:?}");
        // Below the apex: as the box z ≤ 0.5.
        let c = t.clip_to(|v| v.z < 0.5);
        assert_eq!(c.faces, vec![[0, 2, 1]]);
        assert_eq!(t.clip_to(|_| true), t);
    }

    #[test]
    fn depth_for_cell_picks_the_coarsest_grid_at_least_as_fine_as_asked() {
        // Extent 40 m, padding 0.1: cell(d) = 48 / 2^d: d7 = 0.375, d8 = 0.1875.
        let pts = [Vec3::ZERO, Vec3::new(40.0, 10.0, 5.0)];
        assert_eq!(depth_for_cell(&pts, 0.1, 0.25), 8);
        assert_eq!(depth_for_cell(&pts, 0.1, 0.375), 7);
        assert_eq!(depth_for_cell(&pts, 0.1, 0.5), 7);
        assert_eq!(depth_for_cell(&pts, 0.1, 1e-6), 10);
        assert_eq!(depth_for_cell(&pts[..1], 0.1, 0.25), 1);
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
