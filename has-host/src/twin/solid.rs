//! Stage 4 of the planar twin: the footprint's cells extruded from the ground to their roofs
//! into one closed, consistently oriented polygon surface, each face planar and carrying its
//! provenance.
//!
//! Metres, z up; faces are counter-clockwise seen from outside (normals point out of the
//! building), so the enclosed volume is positive.
//!
//! Construction and why it is closed:
//! - every inside cell gives a **roof** face (its ring lifted onto its roof plane: planar by
//!   construction) and a **ground** face (its ring reversed at the ground height);
//! - along each edge of an inside cell whose other side is lower (a lower roof, or outside,
//!   where the height is the ground's), a vertical **wall** face rises from the lower side's
//!   height to the cell's roof. Top and bottom are straight (both roofs are planes), so the wall
//!   is a convex planar polygon in the vertical plane of the edge;
//! - where two roofs cross along a shared edge the edge is first split at the crossing, so each
//!   part has one higher side;
//! - a vertical side of a wall holds every height other faces have at that ground vertex
//!   (between its bottom and top), so no face ends on another face's edge (no T-junctions);
//! - 3-D vertices are shared by ground vertex and height (to [`HEIGHT_QUANTUM_M`]).
//!
//! Every edge is then used by one face on each side with opposite directions, except where
//! heights around one ground vertex alternate up and down more than once (then that vertical
//! edge has four faces) — counted by [`crate::mesh::TriMesh::topology`] and reported.

use std::collections::HashMap;

use glam::{DVec2, DVec3};

use super::footprint::Footprint;
use super::planes::{PlaneKind, PlaneSet};
use super::roof::CellRoof;
use crate::mesh::TriMesh;

/// Heights closer than this at one ground vertex are one 3-D vertex, metres.
pub const HEIGHT_QUANTUM_M: f64 = 1e-3;

/// Semantic class of a face (CityJSON's names).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Surface {
    /// A roof plane's piece.
    RoofSurface,
    /// A vertical face.
    WallSurface,
    /// The building's base on the ground.
    GroundSurface,
}

/// Why a face exists.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "by")]
pub enum Provenance {
    /// A detected plane, with the number of its points that support this face.
    Plane {
        /// Index into the plane set.
        plane: u32,
        /// Supporting points (for a roof: those over its cell; for a wall: the plane's).
        points: usize,
    },
    /// No plane supports the face; the evidence that put it there.
    Inferred {
        /// What decided it.
        evidence: String,
    },
}

/// One planar face.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Face {
    /// Semantic class.
    pub surface: Surface,
    /// Vertex ring (indices into the solid's vertices), counter-clockwise from outside.
    pub ring: Vec<u32>,
    /// The building (connected footprint) it bounds.
    pub building: u32,
    /// The footprint cell it belongs to.
    pub cell: u32,
    /// Why it exists.
    pub provenance: Provenance,
}

/// The twin's closed polygon surface.
#[derive(Clone, Debug, Default)]
pub struct Solid {
    /// Vertex positions, metres.
    pub vertices: Vec<DVec3>,
    /// Planar faces.
    pub faces: Vec<Face>,
    /// Number of buildings.
    pub buildings: usize,
}

/// Inserts, into both cells holding edge a–b, the vertex where their roofs cross along it.
fn split_crossings(fp: &mut Footprint, roofs: &[Option<CellRoof>]) {
    loop {
        let nb = fp.partition.neighbours();
        let mut cut = None;
        'search: for (c, ring) in fp.partition.cells.iter().enumerate() {
            let Some(rc) = roofs[c] else { continue };
            for k in 0..ring.len() {
                let Some(d) = nb[c][k] else { continue };
                let Some(rd) = roofs[d as usize] else {
                    continue;
                };
                let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
                let (pa, pb) = (
                    fp.partition.vertices[a as usize],
                    fp.partition.vertices[b as usize],
                );
                let fa = rc.z_at(pa) - rd.z_at(pa);
                let fb = rc.z_at(pb) - rd.z_at(pb);
                if (fa > HEIGHT_QUANTUM_M && fb < -HEIGHT_QUANTUM_M)
                    || (fa < -HEIGHT_QUANTUM_M && fb > HEIGHT_QUANTUM_M)
                {
                    cut = Some((c, d as usize, a, b, pa + (pb - pa) * (fa / (fa - fb))));
                    break 'search;
                }
            }
        }
        let Some((c, d, a, b, x)) = cut else { return };
        let v = fp.partition.vertices.len() as u32;
        fp.partition.vertices.push(x);
        for (cell, from, to) in [(c, a, b), (d, b, a)] {
            let ring = &mut fp.partition.cells[cell];
            let k = (0..ring.len())
                .find(|&k| ring[k] == from && ring[(k + 1) % ring.len()] == to)
                .expect("the shared edge is in both rings");
            ring.insert(k + 1, v);
        }
    }
}

struct Vertices {
    map: HashMap<(u32, i64), u32>,
    pos: Vec<DVec3>,
}

impl Vertices {
    fn id(&mut self, v: u32, xy: DVec2, z: f64) -> u32 {
        let key = (v, (z / HEIGHT_QUANTUM_M).round() as i64);
        let pos = &mut self.pos;
        *self.map.entry(key).or_insert_with(|| {
            pos.push(xy.extend(z));
            (pos.len() - 1) as u32
        })
    }
}

/// The wall plane whose ground trace holds segment a–b (within the distance tolerance).
fn wall_plane(set: &PlaneSet, a: DVec2, b: DVec2) -> Option<u32> {
    set.planes
        .iter()
        .enumerate()
        .filter(|(_, p)| p.kind == PlaneKind::Wall)
        .filter(|(_, p)| {
            let n = p.n.truncate();
            (n.dot(a) - p.d).abs() <= set.tol.distance_m
                && (n.dot(b) - p.d).abs() <= set.tol.distance_m
        })
        .min_by(|x, y| {
            let e = |p: &super::planes::Plane| {
                let n = p.n.truncate();
                (n.dot(a) - p.d).abs() + (n.dot(b) - p.d).abs()
            };
            e(x.1).total_cmp(&e(y.1))
        })
        .map(|(k, _)| k as u32)
}

/// Extrudes the footprint's inside cells to their roofs (module docs). `roofs` has one entry
/// per cell (`Some` exactly for inside cells).
pub fn extrude(fp: &Footprint, roofs: &[Option<CellRoof>], set: &PlaneSet, ground_z: f64) -> Solid {
    let mut fp = fp.clone();
    split_crossings(&mut fp, roofs);
    let part = &fp.partition;
    let nb = part.neighbours();
    let height = |c: Option<u32>, v: u32| -> f64 {
        match c.and_then(|c| roofs[c as usize]) {
            Some(r) => r.z_at(part.vertices[v as usize]),
            None => ground_z,
        }
    };
    // Every height at each ground vertex: the ground and each incident inside cell's roof.
    let mut levels: Vec<Vec<f64>> = vec![Vec::new(); part.vertices.len()];
    for (c, ring) in part.cells.iter().enumerate() {
        if roofs[c].is_none() {
            continue;
        }
        for &v in ring {
            levels[v as usize].push(ground_z);
            levels[v as usize].push(height(Some(c as u32), v));
        }
    }
    for l in levels.iter_mut() {
        l.sort_by(|a, b| a.total_cmp(b));
        l.dedup_by(|a, b| (*a - *b).abs() < HEIGHT_QUANTUM_M);
    }
    let mut vx = Vertices {
        map: HashMap::new(),
        pos: Vec::new(),
    };
    let mut faces = Vec::new();
    for (c, ring) in part.cells.iter().enumerate() {
        let Some(roof) = roofs[c] else { continue };
        let building = fp.building[c].expect("inside cells belong to a building");
        let xy = |v: u32| part.vertices[v as usize];
        let roof_ring: Vec<u32> = ring
            .iter()
            .map(|&v| vx.id(v, xy(v), roof.z_at(xy(v))))
            .collect();
        faces.push(Face {
            surface: Surface::RoofSurface,
            ring: roof_ring,
            building,
            cell: c as u32,
            provenance: match (roof.plane, roof.inferred_from) {
                (Some(plane), None) => Provenance::Plane {
                    plane,
                    points: roof.support,
                },
                (_, Some(Some(from))) => Provenance::Inferred {
                    evidence: format!(
                        "no roof point over this cell; level at the height of neighbouring cell {from}'s roof along their shared edge"
                    ),
                },
                _ => Provenance::Inferred {
                    evidence: "no roof plane reaches this cell; level at the building's median roof height".into(),
                },
            },
        });
        let ground_ring: Vec<u32> = ring
            .iter()
            .rev()
            .map(|&v| vx.id(v, xy(v), ground_z))
            .collect();
        faces.push(Face {
            surface: Surface::GroundSurface,
            ring: ground_ring,
            building,
            cell: c as u32,
            provenance: Provenance::Inferred {
                evidence: "the scenario's known terrain height under the footprint".into(),
            },
        });
        for k in 0..ring.len() {
            let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
            let other = nb[c][k];
            let (ha, hb) = (height(Some(c as u32), a), height(Some(c as u32), b));
            let (la, lb) = (height(other, a), height(other, b));
            if ha - la <= HEIGHT_QUANTUM_M && hb - lb <= HEIGHT_QUANTUM_M {
                continue; // not higher here: the other side's wall, or none
            }
            let mut w = vec![vx.id(a, xy(a), la), vx.id(b, xy(b), lb)];
            for &z in levels[b as usize]
                .iter()
                .filter(|&&z| z > lb + HEIGHT_QUANTUM_M / 2.0 && z < hb - HEIGHT_QUANTUM_M / 2.0)
            {
                w.push(vx.id(b, xy(b), z));
            }
            w.push(vx.id(b, xy(b), hb));
            w.push(vx.id(a, xy(a), ha));
            for &z in levels[a as usize]
                .iter()
                .rev()
                .filter(|&&z| z > la + HEIGHT_QUANTUM_M / 2.0 && z < ha - HEIGHT_QUANTUM_M / 2.0)
            {
                w.push(vx.id(a, xy(a), z));
            }
            w.dedup();
            while w.len() > 1 && w.first() == w.last() {
                w.pop();
            }
            if w.len() < 3 {
                continue;
            }
            let provenance = match wall_plane(set, xy(a), xy(b)) {
                Some(plane) => Provenance::Plane {
                    plane,
                    points: set.planes[plane as usize].support.len(),
                },
                None => Provenance::Inferred {
                    evidence: match other.filter(|&d| roofs[d as usize].is_some()) {
                        Some(d) => format!("no wall plane here; the step from this cell's roof down to cell {d}'s"),
                        None => format!(
                            "no wall plane here; the edge between this roof-covered cell ({:.0} % under roof points) and a free one",
                            100.0 * fp.roof_share[c]
                        ),
                    },
                },
            };
            faces.push(Face {
                surface: Surface::WallSurface,
                ring: w,
                building,
                cell: c as u32,
                provenance,
            });
        }
    }
    Solid {
        vertices: vx.pos,
        faces,
        buildings: fp.buildings,
    }
}

impl Solid {
    /// The faces `keep` accepts as triangles: each (convex) face fanned from its centroid,
    /// which is added as a vertex; also returns the face of each triangle.
    pub fn triangulate(&self, keep: impl Fn(&Face) -> bool) -> (TriMesh, Vec<u32>) {
        let mut vertices: Vec<glam::Vec3> = self.vertices.iter().map(|v| v.as_vec3()).collect();
        let mut faces = Vec::new();
        let mut owner = Vec::new();
        for (fi, f) in self.faces.iter().enumerate() {
            if !keep(f) {
                continue;
            }
            if f.ring.len() == 3 {
                faces.push([f.ring[0], f.ring[1], f.ring[2]]);
                owner.push(fi as u32);
                continue;
            }
            let c = f
                .ring
                .iter()
                .map(|&v| self.vertices[v as usize])
                .sum::<DVec3>()
                / f.ring.len() as f64;
            let ci = vertices.len() as u32;
            vertices.push(c.as_vec3());
            for k in 0..f.ring.len() {
                faces.push([ci, f.ring[k], f.ring[(k + 1) % f.ring.len()]]);
                owner.push(fi as u32);
            }
        }
        (TriMesh { vertices, faces }, owner)
    }

    /// Enclosed volume by the divergence theorem over the faces (f64, positive when the faces
    /// point outwards), m³.
    pub fn signed_volume_m3(&self) -> f64 {
        let mut v = 0.0;
        for f in &self.faces {
            let p0 = self.vertices[f.ring[0] as usize];
            for k in 1..f.ring.len() - 1 {
                let (p1, p2) = (
                    self.vertices[f.ring[k] as usize],
                    self.vertices[f.ring[k + 1] as usize],
                );
                v += p0.dot(p1.cross(p2)) / 6.0;
            }
        }
        v
    }

    /// Largest distance of a face's vertex from the face's best plane (Newell normal through
    /// the centroid), metres.
    pub fn max_planarity_error_m(&self) -> f64 {
        let mut worst: f64 = 0.0;
        for f in &self.faces {
            let pts: Vec<DVec3> = f.ring.iter().map(|&v| self.vertices[v as usize]).collect();
            let c = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
            let mut n = DVec3::ZERO;
            for k in 0..pts.len() {
                let (p, q) = (pts[k], pts[(k + 1) % pts.len()]);
                n += DVec3::new(
                    (p.y - q.y) * (p.z + q.z),
                    (p.z - q.z) * (p.x + q.x),
                    (p.x - q.x) * (p.y + q.y),
                );
            }
            let n = n.normalize_or_zero();
            for p in &pts {
                worst = worst.max((*p - c).dot(n).abs());
            }
        }
        worst
    }

    /// Number of faces of `surface`.
    pub fn count(&self, surface: Surface) -> usize {
        self.faces.iter().filter(|f| f.surface == surface).count()
    }

    /// Number of inferred faces.
    pub fn inferred(&self) -> usize {
        self.faces
            .iter()
            .filter(|f| matches!(f.provenance, Provenance::Inferred { .. }))
            .count()
    }
}
