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
//! heights around one ground vertex alternate up and down more than once: two higher cells
//! diagonal across the vertex touch along a vertical edge that four walls share. There the
//! upper vertex is split, one copy per fan of faces around it, and so is any vertex where two
//! parts touch at a point: the surface is a closed 2-manifold whose parts may touch along
//! coincident edges, the geometry unchanged ([`crate::mesh::TriMesh::topology`] checks it).
//! Coplanar neighbouring faces are then merged into polygons.

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
    // One pass in cell and ring order (a crossing splits its edge into two parts that cross no
    // more, and two planes cross once along a straight edge), each shared edge once.
    let nb = fp.partition.neighbours();
    let mut cuts: Vec<(usize, usize, u32, u32, DVec2)> = Vec::new();
    let mut done: std::collections::HashSet<(u32, u32)> = Default::default();
    for (c, ring) in fp.partition.cells.iter().enumerate() {
        let Some(rc) = roofs[c] else { continue };
        for k in 0..ring.len() {
            let Some(d) = nb[c][k] else { continue };
            let Some(rd) = roofs[d as usize] else {
                continue;
            };
            let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
            if done.contains(&(b, a)) {
                continue;
            }
            let (pa, pb) = (
                fp.partition.vertices[a as usize],
                fp.partition.vertices[b as usize],
            );
            let fa = rc.z_at(pa) - rd.z_at(pa);
            let fb = rc.z_at(pb) - rd.z_at(pb);
            if (fa > HEIGHT_QUANTUM_M && fb < -HEIGHT_QUANTUM_M)
                || (fa < -HEIGHT_QUANTUM_M && fb > HEIGHT_QUANTUM_M)
            {
                done.insert((a, b));
                cuts.push((c, d as usize, a, b, pa + (pb - pa) * (fa / (fa - fb))));
            }
        }
    }
    for (c, d, a, b, x) in cuts {
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

/// A height's 3-D vertex key at one ground vertex: heights in one [`HEIGHT_QUANTUM_M`] step are
/// one vertex. The levels a wall's side holds are deduplicated and chosen by the same key (every
/// key strictly between its ends), so two heights under a millimetre apart that fall into two
/// keys stay two vertices on every face that passes them.
fn quantum(z: f64) -> i64 {
    (z / HEIGHT_QUANTUM_M).round() as i64
}

struct Vertices {
    map: HashMap<(u32, i64), u32>,
    pos: Vec<DVec3>,
}

impl Vertices {
    fn id(&mut self, v: u32, xy: DVec2, z: f64) -> u32 {
        let key = (v, quantum(z));
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
        l.dedup_by_key(|z| quantum(*z));
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
                        "no point of its plane over this cell; the plane of neighbouring cell {from}, which the seam terms carried here"
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
                .filter(|&&z| quantum(z) > quantum(lb) && quantum(z) < quantum(hb))
            {
                w.push(vx.id(b, xy(b), z));
            }
            w.push(vx.id(b, xy(b), hb));
            w.push(vx.id(a, xy(a), ha));
            for &z in levels[a as usize]
                .iter()
                .rev()
                .filter(|&&z| quantum(z) > quantum(la) && quantum(z) < quantum(ha))
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
    let mut solid = Solid {
        vertices: vx.pos,
        faces,
        buildings: fp.buildings,
    };
    unglue_nonmanifold_edges(&mut solid);
    unglue_nonmanifold_vertices(&mut solid);
    merge_coplanar(&mut solid);
    solid
}

/// Where two parts of the solid touch along a vertical edge only (heights around one ground
/// vertex going up and down twice: two higher cells diagonal across it), four faces share that
/// edge. The upper vertex of each such edge is split into one copy per fan of faces around it
/// (faces joined through edges that two faces share), so each part has its own copy of the
/// edge: the surface becomes a 2-manifold whose two parts touch along coincident edges, the
/// geometry unchanged. Repeated for stacked edges until none is left (or no split helps).
fn unglue_nonmanifold_edges(solid: &mut Solid) {
    for _ in 0..8 {
        let uses = edge_uses(solid);
        let mut tops: Vec<u32> = uses
            .iter()
            .filter(|(_, &n)| n > 2)
            .map(|(&(a, b), _)| {
                if solid.vertices[a as usize].z >= solid.vertices[b as usize].z {
                    a
                } else {
                    b
                }
            })
            .collect();
        tops.sort_unstable();
        tops.dedup();
        if tops.is_empty() {
            return;
        }
        if !split_by_fans(solid, &tops, uses) {
            return;
        }
    }
}

/// Splits each vertex of `candidates` into one copy per fan of the faces around it (faces
/// joined through an edge `uses`, the solid's [`edge_uses`], counts exactly two faces on; kept
/// current as vertices split); whether any was split.
fn split_by_fans(
    solid: &mut Solid,
    candidates: &[u32],
    mut uses: HashMap<(u32, u32), usize>,
) -> bool {
    let mut incident: HashMap<u32, Vec<usize>> = HashMap::new();
    for (i, f) in solid.faces.iter().enumerate() {
        for &x in &f.ring {
            incident.entry(x).or_default().push(i);
        }
    }
    let mut split_any = false;
    for &v in candidates {
        {
            // Faces around v and, for each, its two edges at v.
            let mut around: Vec<usize> = incident.get(&v).cloned().unwrap_or_default();
            around.sort_unstable();
            around.dedup();
            let mut parent: Vec<usize> = (0..around.len()).collect();
            fn root(p: &mut [usize], mut i: usize) -> usize {
                while p[i] != i {
                    p[i] = p[p[i]];
                    i = p[i];
                }
                i
            }
            let mut by_edge: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
            for (j, &i) in around.iter().enumerate() {
                let r = &solid.faces[i].ring;
                let k = r.iter().position(|&x| x == v).expect("face holds v");
                let (prev, next) = (r[(k + r.len() - 1) % r.len()], r[(k + 1) % r.len()]);
                for x in [prev, next] {
                    by_edge.entry((v.min(x), v.max(x))).or_default().push(j);
                }
            }
            for (e, js) in &by_edge {
                if uses.get(e) == Some(&2) && js.len() == 2 {
                    let (a, b) = (root(&mut parent, js[0]), root(&mut parent, js[1]));
                    parent[a.max(b)] = a.min(b);
                }
            }
            let mut fans: Vec<usize> = (0..around.len()).map(|j| root(&mut parent, j)).collect();
            let mut ids: Vec<usize> = fans.clone();
            ids.sort_unstable();
            ids.dedup();
            if ids.len() < 2 {
                continue;
            }
            split_any = true;
            let pos = solid.vertices[v as usize];
            for &fan in &ids[1..] {
                let copy = solid.vertices.len() as u32;
                solid.vertices.push(pos);
                for (j, &i) in around.iter().enumerate() {
                    if fans[j] == fan {
                        let r = &mut solid.faces[i].ring;
                        let k = r.iter().position(|&x| x == v).expect("face holds v");
                        let (prev, next) = (r[(k + r.len() - 1) % r.len()], r[(k + 1) % r.len()]);
                        r[k] = copy;
                        // Keep the edge counts current for the vertices split after this one.
                        for x in [prev, next] {
                            if let Some(n) = uses.get_mut(&(v.min(x), v.max(x))) {
                                *n -= 1;
                            }
                            *uses.entry((copy.min(x), copy.max(x))).or_default() += 1;
                        }
                        fans[j] = usize::MAX;
                    }
                }
            }
        }
    }
    split_any
}

/// Splits every vertex whose faces form more than one fan (two parts touching at a point).
fn unglue_nonmanifold_vertices(solid: &mut Solid) {
    let all: Vec<u32> = (0..solid.vertices.len() as u32).collect();
    let uses = edge_uses(solid);
    split_by_fans(solid, &all, uses);
}

/// How many faces use each undirected edge.
fn edge_uses(solid: &Solid) -> HashMap<(u32, u32), usize> {
    let mut uses: HashMap<(u32, u32), usize> = HashMap::new();
    for f in &solid.faces {
        for k in 0..f.ring.len() {
            let (a, b) = (f.ring[k], f.ring[(k + 1) % f.ring.len()]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    uses
}

/// The boundary (vertex → next vertex) of a piece after absorbing the face `ring`, if it is
/// still one simple loop: `None` when the face touches the piece nowhere along an edge, or the
/// union would pinch at a vertex or enclose a hole.
fn absorbed(boundary: &HashMap<u32, u32>, ring: &[u32]) -> Option<HashMap<u32, u32>> {
    let mut next = boundary.clone();
    let edges = (0..ring.len()).map(|k| (ring[k], ring[(k + 1) % ring.len()]));
    let mut fresh = Vec::new();
    let mut shared = 0;
    for (a, b) in edges {
        if next.get(&b) == Some(&a) {
            next.remove(&b);
            shared += 1;
        } else {
            fresh.push((a, b));
        }
    }
    for (a, b) in fresh {
        if next.insert(a, b).is_some() {
            return None; // two boundary edges leave one vertex: a pinch
        }
    }
    if shared == 0 || next.len() < 3 {
        return None;
    }
    // One loop through every boundary edge.
    let start = *next.keys().next().expect("non-empty");
    let (mut v, mut steps) = (next[&start], 1);
    while v != start {
        v = *next.get(&v)?;
        steps += 1;
        if steps > next.len() {
            return None;
        }
    }
    (steps == next.len()).then_some(next)
}

/// Newell normal (unit) and offset of a face's best plane.
fn face_plane(vertices: &[DVec3], ring: &[u32]) -> (DVec3, f64) {
    let pts: Vec<DVec3> = ring.iter().map(|&v| vertices[v as usize]).collect();
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
    (n, n.dot(c))
}

/// Merges faces of one building and one class that share an edge and lie on one plane (within
/// [`HEIGHT_QUANTUM_M`]) into one polygon, where their union is bounded by a single loop; a
/// boundary vertex between two collinear edges that no other face uses is dropped. The cells of
/// the partition are convex pieces; the model's faces are the planes' whole pieces.
fn merge_coplanar(solid: &mut Solid) {
    let n = solid.faces.len();
    let planes: Vec<(DVec3, f64)> = solid
        .faces
        .iter()
        .map(|f| face_plane(&solid.vertices, &f.ring))
        .collect();
    let mut edge_face: HashMap<(u32, u32), usize> = HashMap::new();
    for (i, f) in solid.faces.iter().enumerate() {
        for k in 0..f.ring.len() {
            edge_face.insert((f.ring[k], f.ring[(k + 1) % f.ring.len()]), i);
        }
    }
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut keys: Vec<(u32, u32)> = edge_face.keys().copied().collect();
    keys.sort_unstable();
    for (a, b) in keys {
        let (i, Some(&j)) = (edge_face[&(a, b)], edge_face.get(&(b, a))) else {
            continue;
        };
        let (fi, fj) = (&solid.faces[i], &solid.faces[j]);
        if i == j || fi.building != fj.building || fi.surface != fj.surface {
            continue;
        }
        let ((ni, di), (nj, dj)) = (planes[i], planes[j]);
        if ni.dot(nj) < 1.0 - 1e-9 || (di - dj).abs() > HEIGHT_QUANTUM_M {
            continue;
        }
        let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
        if ri != rj {
            parent[ri.max(rj)] = ri.min(rj);
        }
    }
    let mut groups: HashMap<usize, Vec<usize>> = HashMap::new();
    for i in 0..n {
        let r = root(&mut parent, i);
        groups.entry(r).or_default().push(i);
    }
    // Faces using each vertex, to keep vertices other faces need.
    let mut users: Vec<Vec<usize>> = vec![Vec::new(); solid.vertices.len()];
    for (i, f) in solid.faces.iter().enumerate() {
        for &v in &f.ring {
            users[v as usize].push(i);
        }
    }
    // Neighbours of each face within its group.
    let mut adjacent: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (&(a, b), &i) in &edge_face {
        if let Some(&j) = edge_face.get(&(b, a)) {
            if i != j && root(&mut parent, i) == root(&mut parent, j) {
                adjacent[i].push(j);
            }
        }
    }
    for a in adjacent.iter_mut() {
        a.sort_unstable();
        a.dedup();
    }
    let mut order: Vec<usize> = groups.keys().copied().collect();
    order.sort_unstable();
    let mut merged: Vec<Option<Vec<u32>>> = vec![None; n];
    let mut provenance: Vec<Option<Provenance>> = vec![None; n];
    let mut dropped = vec![false; n];
    let mut taken = vec![false; n];
    for r in order {
        let members = &groups[&r];
        if members.len() < 2 {
            continue;
        }
        // Pieces grown face by face, each kept one simple loop without holes (a polygon).
        for &seed in members {
            if taken[seed] {
                continue;
            }
            taken[seed] = true;
            let mut piece = vec![seed];
            let mut boundary: HashMap<u32, u32> = HashMap::new();
            let ring = &solid.faces[seed].ring;
            for k in 0..ring.len() {
                boundary.insert(ring[k], ring[(k + 1) % ring.len()]);
            }
            let mut queue: std::collections::VecDeque<usize> =
                adjacent[seed].iter().copied().collect();
            let mut refused: std::collections::HashSet<usize> = Default::default();
            while let Some(f) = queue.pop_front() {
                if taken[f] || refused.contains(&f) {
                    continue;
                }
                if let Some(next) = absorbed(&boundary, &solid.faces[f].ring) {
                    boundary = next;
                    taken[f] = true;
                    piece.push(f);
                    queue.extend(adjacent[f].iter().copied());
                    refused.clear();
                } else {
                    refused.insert(f);
                }
            }
            if piece.len() < 2 {
                continue;
            }
            let inside: std::collections::HashSet<usize> = piece.iter().copied().collect();
            let start = *boundary.keys().min().expect("a loop");
            let mut ring = vec![start];
            let mut v = boundary[&start];
            while v != start {
                ring.push(v);
                v = boundary[&v];
            }
            // Drop collinear boundary vertices no face outside the piece uses.
            let pos = |v: u32| solid.vertices[v as usize];
            let mut k = 0;
            while ring.len() > 3 && k < ring.len() {
                let m = ring.len();
                let (a, b, c) = (ring[(k + m - 1) % m], ring[k], ring[(k + 1) % m]);
                let (u, w) = (pos(b) - pos(a), pos(c) - pos(b));
                let collinear =
                    u.cross(w).length() <= 1e-9 * u.length() * w.length() && u.dot(w) > 0.0;
                if collinear && users[b as usize].iter().all(|f| inside.contains(f)) {
                    ring.remove(k);
                } else {
                    k += 1;
                }
            }
            let keep = *piece.iter().min().expect("non-empty");
            // The piece is supported if any of its cells is: by that plane, with the points
            // over all of them.
            let mut support: Option<(u32, usize)> = None;
            for &i in &piece {
                if let Provenance::Plane { plane, points } = solid.faces[i].provenance {
                    let (p, m) = support.get_or_insert((plane, 0));
                    if *p == plane {
                        // A roof face counts the points over its cell, a wall its plane's.
                        *m = match solid.faces[i].surface {
                            Surface::RoofSurface => *m + points,
                            _ => points,
                        };
                    }
                }
            }
            if let Some((plane, points)) = support {
                provenance[keep] = Some(Provenance::Plane { plane, points });
            }
            merged[keep] = Some(ring);
            for &i in &piece {
                dropped[i] = i != keep;
            }
        }
    }
    let old = std::mem::take(&mut solid.faces);
    for (i, mut f) in old.into_iter().enumerate() {
        if dropped[i] {
            continue;
        }
        if let Some(ring) = merged[i].take() {
            f.ring = ring;
        }
        if let Some(p) = provenance[i].take() {
            f.provenance = p;
        }
        solid.faces.push(f);
    }
}

impl Solid {
    /// The faces `keep` accepts as triangles (ear clipping in each face's plane: merged faces
    /// need not be convex; collinear boundary vertices stay, so neighbouring faces still share
    /// every edge); also returns the face of each triangle.
    pub fn triangulate(&self, keep: impl Fn(&Face) -> bool) -> (TriMesh, Vec<u32>) {
        let vertices: Vec<glam::Vec3> = self.vertices.iter().map(|v| v.as_vec3()).collect();
        let mut faces = Vec::new();
        let mut owner = Vec::new();
        for (fi, f) in self.faces.iter().enumerate() {
            if !keep(f) {
                continue;
            }
            for t in ear_clip(&self.vertices, &f.ring) {
                faces.push(t);
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
            let (n, d) = face_plane(&self.vertices, &f.ring);
            for &v in &f.ring {
                worst = worst.max((n.dot(self.vertices[v as usize]) - d).abs());
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

/// Triangles of the simple planar polygon `ring` (counter-clockwise about its Newell normal) by
/// ear clipping in its plane: an ear is a strictly convex vertex whose triangle holds no other
/// remaining vertex, on its boundary included (so collinear chains are cut, never collapsed).
fn ear_clip(vertices: &[DVec3], ring: &[u32]) -> Vec<[u32; 3]> {
    if ring.len() < 3 {
        return Vec::new();
    }
    let (n, _) = face_plane(vertices, ring);
    let u = n.any_orthonormal_vector();
    let w = n.cross(u);
    let p2 = |v: u32| {
        let p = vertices[v as usize];
        DVec2::new(p.dot(u), p.dot(w))
    };
    let mut idx: Vec<u32> = ring.to_vec();
    let mut out = Vec::with_capacity(ring.len() - 2);
    let scale = idx.iter().map(|&v| p2(v).length()).fold(1.0f64, f64::max);
    let eps = 1e-12 * scale * scale;
    while idx.len() > 3 {
        let m = idx.len();
        let mut best: Option<usize> = None;
        for k in 0..m {
            let (a, b, c) = (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
            let (pa, pb, pc) = (p2(a), p2(b), p2(c));
            let cross = (pb - pa).perp_dot(pc - pb);
            if cross <= eps {
                continue;
            }
            let blocked = idx.iter().any(|&v| {
                if v == a || v == b || v == c {
                    return false;
                }
                let q = p2(v);
                (pb - pa).perp_dot(q - pa) >= -eps
                    && (pc - pb).perp_dot(q - pb) >= -eps
                    && (pa - pc).perp_dot(q - pc) >= -eps
            });
            if !blocked {
                best = Some(k);
                break;
            }
        }
        let k = match best {
            Some(k) => k,
            // Numerically degenerate remainder: clip the most convex vertex.
            None => (0..m)
                .max_by(|&i, &j| {
                    let t = |k: usize| {
                        let (a, b, c) = (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
                        (p2(b) - p2(a)).perp_dot(p2(c) - p2(b))
                    };
                    t(i).total_cmp(&t(j))
                })
                .expect("m > 3"),
        };
        out.push([idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]]);
        idx.remove(k);
    }
    out.push([idx[0], idx[1], idx[2]]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::footprint::{partition, LineSource, SplitLine};
    use crate::twin::planes::Tolerances;

    /// A 2 × 2 block of 10 m cells, the two diagonal ones 12 m high and the other two 6 m: the
    /// tall parts touch along one vertical edge, which four walls would share.
    #[test]
    fn cells_touching_along_a_vertical_edge_make_a_closed_2_manifold() {
        let line = |o: (f64, f64), d: (f64, f64)| SplitLine {
            origin: DVec2::new(o.0, o.1),
            dir: DVec2::new(d.0, d.1),
            t0: -100.0,
            t1: 100.0,
            reach_m: 0.0,
            source: LineSource::Wall(0),
        };
        let part = partition(
            DVec2::splat(-10.0),
            DVec2::splat(10.0),
            &[line((0.0, 0.0), (1.0, 0.0)), line((0.0, 0.0), (0.0, 1.0))],
        );
        assert_eq!(part.cells.len(), 4);
        let n = part.cells.len();
        let fp = Footprint {
            roof_share: vec![1.0; n],
            inside: vec![true; n],
            building: vec![Some(0); n],
            buildings: 1,
            partition: part.clone(),
        };
        let roofs: Vec<Option<CellRoof>> = (0..n)
            .map(|c| {
                let ring = part.ring(c);
                let centre = ring.iter().copied().sum::<DVec2>() / ring.len() as f64;
                let high = (centre.x > 0.0) == (centre.y > 0.0);
                Some(CellRoof {
                    n: DVec3::Z,
                    d: if high { 12.0 } else { 6.0 },
                    plane: None,
                    support: 0,
                    inferred_from: Some(None),
                })
            })
            .collect();
        let set = PlaneSet {
            planes: Vec::new(),
            label: Vec::new(),
            dominant_azimuths: Vec::new(),
            tol: Tolerances::from_voxel(0.5),
        };
        let solid = extrude(&fp, &roofs, &set, 0.0);
        let (mesh, _) = solid.triangulate(|_| true);
        let t = mesh.topology();
        assert!(t.watertight && t.manifold, "{t:?}");
        // 20 × 20 × 6 plus two 10 × 10 × 6 towers.
        assert!((solid.signed_volume_m3() - 3600.0).abs() < 1e-6);
    }
}
