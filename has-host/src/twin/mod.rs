//! The planar twin (issue 61, first step): a compact building model made of planes and
//! evidence, built from a finished run's fused cloud, beside the Poisson mesh and its rules.
//!
//! The pipeline, each stage one function with typed input and output:
//!
//! ```text
//! fused points + weights, voxel, ground height
//!   ├─ planes::detect        → PlaneSet   walls / roofs / ground, regularised by the data's own
//!   │                                     dominant directions, coplanar pieces merged
//!   ├─ wall_traces + roof::meet_lines + roof_edges
//!   │                        → SplitLine[]  wall traces on the ground, roof meet lines, and
//!   │                                     where roof evidence ends (evidence_edges)
//!   ├─ footprint::partition  → Partition  convex cells of the site's box cut by those lines
//!   ├─ enclosure             → wall fronts from the pair clouds; ground enclosed between
//!   │                                     facades seen from outside; ground seen through
//!   ├─ footprint::label      → Footprint  cells inside by roof, enclosure and open-ground
//!   │                                     evidence, buildings = components
//!   ├─ enclosure::free_heights → the air the base stations saw over each ground pixel
//!   ├─ roof::assign          → CellRoof per inside cell: roof planes by α-expansion over
//!   │                                     data, free-space and seam terms (supported, or
//!   │                                     inferred)
//!   ├─ solid::extrude        → Solid      closed planar polygon surface with provenance
//!   ├─ cityjson::document    → CityJSON 2.0 (one LoD2 Building per footprint)
//!   └─ sionna::scene         → Sionna RT / Mitsuba 3 XML, one PLY mesh per building
//! ```
//!
//! No rule names a shape class: footprints are whatever cells the wall lines cut and the roof
//! points cover, roofs whatever planes the points support. Units: metres, the run's frame, z up.
//! Scoring ([`score`]) reuses [`crate::metrics`] exactly as `reconstruct` scores its mesh.

pub mod cityjson;
pub mod enclosure;
pub mod evidence_edges;
pub mod footprint;
mod max_flow;
pub mod planes;
pub mod roof;
pub mod sionna;
pub mod solid;

use glam::{DVec2, Vec3};

use crate::knn::GeometryError;
use crate::metrics::{surface_area_metrics, CloudComparison, CloudMetrics, SurfaceAreaMetrics};
use footprint::{Footprint, LineSource, SplitLine};
use planes::{PlaneKind, PlaneSet, Tolerances};
use roof::CellRoof;
use solid::{Solid, Surface};

/// What the twin is built from.
#[derive(Clone, Copy, Debug)]
pub struct TwinInput<'a> {
    /// Fused points, metres.
    pub points: &'a [Vec3],
    /// Fusion weight of each point (same length).
    pub weights: &'a [f32],
    /// The imaging voxel edge, metres (all tolerances derive from it).
    pub voxel_m: f64,
    /// Ground height under the site, metres.
    pub ground_z: f64,
    /// What each imaging pair saw and where it stood (empty: walls are not oriented and no
    /// ground counts as enclosed, [`enclosure`]).
    pub views: &'a [enclosure::PairView],
}

/// Errors of the twin's construction.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TwinError {
    /// An input field out of range.
    #[error("{field} = {value} is invalid: must be {expected}")]
    BadInput {
        /// Which input.
        field: &'static str,
        /// Its value.
        value: String,
        /// What it must be.
        expected: &'static str,
    },
    /// A geometric stage failed (too few or non-finite points).
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    /// The evidence gave no building.
    #[error("no building: {planes} planes ({walls} walls, {roofs} roofs) and no cell under roof evidence")]
    Empty {
        /// Planes found.
        planes: usize,
        /// Of which walls.
        walls: usize,
        /// Of which roofs.
        roofs: usize,
    },
}

/// Every stage's result.
#[derive(Clone, Debug)]
pub struct Twin {
    /// Stage 1.
    pub planes: PlaneSet,
    /// Stage 2 input: the cutting lines.
    pub lines: Vec<SplitLine>,
    /// Per plane, an oriented wall's open side (unit horizontal normal).
    pub fronts: Vec<Option<DVec2>>,
    /// Enclosed ground pixels (one voxel each), footprint evidence.
    pub enclosed: Vec<DVec2>,
    /// Stage 2.
    pub footprint: Footprint,
    /// Stage 3: one roof per cell (`None` outside).
    pub roofs: Vec<Option<CellRoof>>,
    /// Stage 4.
    pub solid: Solid,
}

/// Wall planes' traces on the ground, each with its seen extent.
pub fn wall_traces(points: &[Vec3], set: &PlaneSet) -> Vec<SplitLine> {
    let reach_m = footprint::EXTEND_VOXELS * set.tol.voxel_m;
    set.planes
        .iter()
        .enumerate()
        .filter(|(_, p)| p.kind == PlaneKind::Wall)
        .map(|(k, p)| {
            let m = p.n.truncate().normalize();
            let origin = m * p.d;
            let dir = m.perp();
            let (t0, t1) = p.support.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &i| {
                let t = dir.dot(points[i as usize].as_dvec3().truncate() - origin);
                (lo.min(t), hi.max(t))
            });
            SplitLine {
                origin,
                dir,
                t0,
                t1,
                reach_m,
                source: LineSource::Wall(k as u32),
            }
        })
        .collect()
}

/// The parts of line `e` not running beside a line of `others`: parallel within 1°, within
/// `distance_m` of it, inside its extent prolonged by its reach. Parts shorter than
/// [`evidence_edges::MIN_RUN_VOXELS`] voxels are dropped.
fn clear_of(e: &SplitLine, others: &[SplitLine], distance_m: f64, voxel_m: f64) -> Vec<SplitLine> {
    let mut covered: Vec<(f64, f64)> = Vec::new();
    for w in others {
        if e.dir.perp_dot(w.dir).abs() > 1f64.to_radians().sin() {
            continue;
        }
        let m = w.dir.perp();
        if m.dot(e.origin + e.dir * e.t0 - w.origin).abs() > distance_m
            || m.dot(e.origin + e.dir * e.t1 - w.origin).abs() > distance_m
        {
            continue;
        }
        // w's span in e's parameter.
        let at = |t: f64| e.dir.dot(w.origin + w.dir * t - e.origin);
        let (a, b) = (at(w.t0 - w.reach_m), at(w.t1 + w.reach_m));
        covered.push((a.min(b), a.max(b)));
    }
    covered.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut out = Vec::new();
    let mut t = e.t0;
    let min_len = evidence_edges::MIN_RUN_VOXELS as f64 * voxel_m;
    let mut push = |lo: f64, hi: f64| {
        if hi - lo >= min_len {
            out.push(SplitLine {
                t0: lo,
                t1: hi,
                ..*e
            });
        }
    };
    for (lo, hi) in covered {
        if hi <= t {
            continue;
        }
        if lo >= e.t1 {
            break;
        }
        push(t, lo.min(e.t1));
        t = t.max(hi);
    }
    if t < e.t1 {
        push(t, e.t1);
    }
    out
}

/// Where roof evidence ends ([`evidence_edges`]): the edges of all roof points together and of
/// each roof plane with at least [`roof::MEET_SUPPORT`] points.
pub fn roof_edges(points: &[Vec3], set: &PlaneSet) -> Vec<SplitLine> {
    let xy_of = |keep: &dyn Fn(u32) -> bool| -> Vec<DVec2> {
        (0..points.len())
            .filter(|&i| set.label[i].is_some_and(keep))
            .map(|i| points[i].as_dvec3().truncate())
            .collect()
    };
    let is_roof = |k: u32| set.planes[k as usize].kind == PlaneKind::Roof;
    let az = &set.dominant_azimuths;
    let pixel = set.tol.voxel_m;
    let mut out =
        evidence_edges::edge_lines(&xy_of(&is_roof), az, pixel, LineSource::EvidenceEdge(None));
    for (k, p) in set.planes.iter().enumerate() {
        if p.kind == PlaneKind::Roof && p.support.len() >= roof::MEET_SUPPORT {
            let k = k as u32;
            out.extend(evidence_edges::edge_lines(
                &xy_of(&|j| j == k),
                az,
                pixel,
                LineSource::EvidenceEdge(Some(k)),
            ));
        }
    }
    out
}

/// Runs the pipeline (module docs).
///
/// # Errors
/// [`TwinError::BadInput`] for a weight list of another length, a non-positive voxel or a
/// non-finite ground; [`TwinError::Geometry`] for too few or non-finite points;
/// [`TwinError::Empty`] when no cell is under roof evidence.
pub fn build(input: &TwinInput<'_>) -> Result<Twin, TwinError> {
    if input.weights.len() != input.points.len() {
        return Err(TwinError::BadInput {
            field: "weights",
            value: format!(
                "{} values for {} points",
                input.weights.len(),
                input.points.len()
            ),
            expected: "one per point",
        });
    }
    if !(input.voxel_m.is_finite() && input.voxel_m > 0.0) {
        return Err(TwinError::BadInput {
            field: "voxel_m",
            value: input.voxel_m.to_string(),
            expected: "finite and > 0",
        });
    }
    if !input.ground_z.is_finite() {
        return Err(TwinError::BadInput {
            field: "ground_z",
            value: input.ground_z.to_string(),
            expected: "finite",
        });
    }
    let tol = Tolerances::from_voxel(input.voxel_m);
    let (points, weights) = (input.points, input.weights);
    let set = planes::detect(points, weights, input.ground_z, tol)?;
    let mut lines = wall_traces(points, &set);
    lines.extend(roof::meet_lines(points, &set));
    // An edge of roof evidence beside a parallel wall trace is that wall's top seen from above,
    // quantised to the raster: the wall's plane places it better.
    let edges: Vec<SplitLine> = roof_edges(points, &set)
        .into_iter()
        .flat_map(|e| clear_of(&e, &lines, tol.distance_m, tol.voxel_m))
        .collect();
    lines.extend(edges);
    let extend_m = footprint::EXTEND_VOXELS * input.voxel_m;
    let lo = points.iter().fold(DVec2::splat(f64::MAX), |m, p| {
        m.min(p.as_dvec3().truncate())
    }) - DVec2::splat(extend_m);
    let hi = points.iter().fold(DVec2::splat(f64::MIN), |m, p| {
        m.max(p.as_dvec3().truncate())
    }) + DVec2::splat(extend_m);
    let part = footprint::partition(lo, hi, &lines);
    let mut roof_xy: Vec<DVec2> = (0..points.len())
        .filter(|&i| set.label[i].is_some_and(|k| set.planes[k as usize].kind == PlaneKind::Roof))
        .map(|i| points[i].as_dvec3().truncate())
        .collect();
    let walls: Vec<SplitLine> = lines
        .iter()
        .filter(|l| matches!(l.source, LineSource::Wall(_)))
        .copied()
        .collect();
    // Ground enclosed between facades seen from outside is footprint evidence like a roof point.
    let seen = enclosure::sightings(points, &set, input.views);
    let fronts = enclosure::wall_fronts(&set, input.views, &seen);
    let enclosed = enclosure::enclosed_ground(&walls, &fronts, input.voxel_m, tol.radius_m);
    roof_xy.extend_from_slice(&enclosed);
    // Partition edges on a wall's trace lie on it exactly; an edge a quarter of the distance
    // tolerance off is another line (a roof edge, a meet line) beside the wall.
    let terms = footprint::LabelTerms {
        pixel_m: input.voxel_m,
        wall_distance_m: 0.25 * tol.distance_m,
        wall_reach_m: tol.radius_m,
    };
    // Below the lowest roof plane, a sight line from a wall point to its pair's ends crossed open
    // ground.
    let lowest_roof = set
        .planes
        .iter()
        .filter(|p| p.kind == PlaneKind::Roof)
        .map(|p| planes::weighted_offset(points, weights, &p.support, glam::DVec3::Z))
        .fold(f64::INFINITY, f64::min);
    let open = if lowest_roof.is_finite() {
        enclosure::open_ground(
            points,
            input.views,
            &seen,
            &fronts,
            lowest_roof - tol.distance_m,
            input.voxel_m,
        )
    } else {
        Vec::new()
    };
    let fp = footprint::label(part, &roof_xy, &open, &walls, &terms);
    if fp.buildings == 0 {
        let count = |k| set.planes.iter().filter(|p| p.kind == k).count();
        return Err(TwinError::Empty {
            planes: set.planes.len(),
            walls: count(PlaneKind::Wall),
            roofs: count(PlaneKind::Roof),
        });
    }
    // The air the base stations saw over the site, up to where no roof is a candidate.
    let z_top = points.iter().map(|p| p.z as f64).fold(f64::MIN, f64::max);
    // Only points the footprint leaves outside every building: a point under a roof of the
    // model is one its sensors could not have seen, and its line would cut that roof.
    let outside: Vec<Vec3> = {
        let xy: Vec<DVec2> = points.iter().map(|p| p.as_dvec3().truncate()).collect();
        roof::cells_of(&fp, &xy, &set)
            .into_iter()
            .zip(points)
            .filter_map(|(c, &p)| c.is_none().then_some(p))
            .collect()
    };
    let free = enclosure::free_heights(
        &outside,
        input.views,
        tol.distance_m,
        input.voxel_m,
        roof::RESIDUAL_CAP.sqrt() * tol.voxel_m,
        z_top + roof::HEIGHT_MARGIN_VOXELS * tol.voxel_m,
    )?;
    let roofs = roof::assign(&fp, points, &set, input.ground_z, &walls, &terms, &free);
    let solid = solid::extrude(&fp, &roofs, &set, input.ground_z);
    Ok(Twin {
        planes: set,
        lines,
        fronts,
        enclosed,
        footprint: fp,
        roofs,
        solid,
    })
}

/// The height of the known terrain under the centre of `points`' extent: the first surface of
/// `terrain` a ray straight down from above both meets there, metres; `None` where it meets
/// none.
pub fn ground_height_under(terrain: &crate::Scene, points: &[Vec3]) -> Option<f64> {
    if points.is_empty() {
        return None;
    }
    let lo = points.iter().fold(Vec3::splat(f32::MAX), |m, &p| m.min(p));
    let hi = points.iter().fold(Vec3::splat(f32::MIN), |m, &p| m.max(p));
    let c = (lo + hi) * 0.5;
    let top = terrain.bounds().1.z.max(hi.z) + 1.0;
    terrain
        .closest_hit(Vec3::new(c.x, c.y, top), Vec3::NEG_Z, 0.0, f32::INFINITY)
        .map(|h| h.point.z as f64)
}

/// What each imaged pair saw and where it stood, as [`TwinInput::views`] takes it: pair `k`'s
/// points `points[k]`, its base station's position and its terminal track's centre, in the
/// order of the pairs' names (`BS-aperture`), the order `has-sim twin` reads a run's pair files
/// in, so that a twin built from a run's files and one built in the run agree.
pub fn pair_views(
    sc: &crate::scenario::Scenario,
    plans: &[crate::imaging::PairPlan],
    points: &[&[Vec3]],
) -> Vec<enclosure::PairView> {
    let mut named: Vec<(&str, enclosure::PairView)> = plans
        .iter()
        .zip(points)
        .map(|(p, pts)| {
            (
                p.name.as_str(),
                enclosure::PairView {
                    points: pts.to_vec(),
                    receiver: Vec3::from(sc.base_stations[p.bs].position).as_dvec3(),
                    transmitter: sc.aperture(p.aperture, 2).centre().as_dvec3(),
                },
            )
        })
        .collect();
    named.sort_by(|a, b| a.0.cmp(b.0));
    named.into_iter().map(|(_, v)| v).collect()
}

/// The twin scored as `reconstruct` scores its mesh.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TwinMetrics {
    /// √CD, F-scores, precision, recall of the twin's area samples against the truth.
    pub cloud: CloudMetrics,
    /// False surface and area against the truth's.
    pub area: SurfaceAreaMetrics,
}

/// Scores the twin's walls and roofs against the truth samples `truth` and triangles
/// `truth_triangles`: uniform area samples at `density_per_m2` (seed `seed`), then
/// [`CloudMetrics`] and [`surface_area_metrics`] at 1.5 m, as `reconstruct` scores the mesh.
/// Ground faces are left out: the truth holds no face that faces down.
///
/// # Errors
/// As [`crate::metrics::sample_mesh`], [`CloudComparison::new`] and [`surface_area_metrics`].
pub fn score(
    solid: &Solid,
    truth: &[Vec3],
    truth_triangles: &[[Vec3; 3]],
    density_per_m2: f64,
    seed: u64,
) -> Result<TwinMetrics, GeometryError> {
    let (mesh, _) = solid.triangulate(|f| f.surface != Surface::GroundSurface);
    let samples = mesh.sample(density_per_m2, seed)?;
    let cmp = CloudComparison::new(&samples, truth)?;
    let area = surface_area_metrics(&samples, mesh.area_m2(), truth, truth_triangles, 1.5)?;
    Ok(TwinMetrics {
        cloud: CloudMetrics::new(&cmp, samples.len(), truth.len())?,
        area,
    })
}

/// The twin's figures beside the Poisson mesh's of the same run.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TwinReport {
    /// The run directory read.
    pub run: String,
    /// Imaging voxel, metres.
    pub voxel_m: f64,
    /// Ground height used, metres.
    pub ground_z_m: f64,
    /// Planes found: walls, roofs, ground.
    pub planes: [usize; 3],
    /// Dominant wall directions, degrees (folded into [0, 90)).
    pub dominant_azimuths_deg: Vec<f64>,
    /// Pair clouds read (what orients the walls).
    pub pair_views: usize,
    /// Walls whose open side the pair clouds decided, of all walls.
    pub oriented_walls: [usize; 2],
    /// Ground enclosed between facades seen from outside, m².
    pub enclosed_m2: f64,
    /// Footprint cells and inside cells.
    pub cells: [usize; 2],
    /// Buildings (connected footprints).
    pub buildings: usize,
    /// Faces: total, walls, roofs, ground.
    pub faces: [usize; 4],
    /// Faces without plane support (inferred).
    pub inferred_faces: usize,
    /// Edge-use topology of the triangulated solid.
    pub topology: crate::mesh::Topology,
    /// Enclosed volume, m³.
    pub volume_m3: f64,
    /// Largest vertex distance from its face's plane, metres.
    pub max_planarity_error_m: f64,
    /// The twin's metrics (walls and roofs).
    pub twin: Option<TwinMetrics>,
    /// The Poisson mesh's √CD, F(1.5 m), false surface and faces from the run's report.
    pub mesh: Option<MeshFigures>,
    /// Each plane: kind, unit normal, offset (m), supporting points, snapped.
    pub plane_list: Vec<(PlaneKind, [f64; 3], f64, usize, bool)>,
}

/// The figures of the run's Poisson mesh (from its report.json).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeshFigures {
    /// √CD, metres.
    pub sqrt_chamfer_m: f64,
    /// F(1.5 m), percent.
    pub fscore_1_5m: f64,
    /// False surface at 1.5 m, percent.
    pub false_surface_pct_1_5m: f64,
    /// Triangles.
    pub faces: usize,
}

impl TwinReport {
    /// The report's figures of `twin`.
    pub fn new(run: String, input: &TwinInput<'_>, twin: &Twin) -> TwinReport {
        let s = &twin.solid;
        let count = |k| twin.planes.planes.iter().filter(|p| p.kind == k).count();
        let (tri, _) = s.triangulate(|_| true);
        TwinReport {
            run,
            voxel_m: input.voxel_m,
            ground_z_m: input.ground_z,
            planes: [
                count(PlaneKind::Wall),
                count(PlaneKind::Roof),
                count(PlaneKind::Ground),
            ],
            dominant_azimuths_deg: twin
                .planes
                .dominant_azimuths
                .iter()
                .map(|a| a.to_degrees())
                .collect(),
            pair_views: input.views.len(),
            oriented_walls: [twin.fronts.iter().flatten().count(), count(PlaneKind::Wall)],
            enclosed_m2: twin.enclosed.len() as f64 * input.voxel_m * input.voxel_m,
            cells: [
                twin.footprint.inside.len(),
                twin.footprint.inside.iter().filter(|&&i| i).count(),
            ],
            buildings: s.buildings,
            faces: [
                s.faces.len(),
                s.count(Surface::WallSurface),
                s.count(Surface::RoofSurface),
                s.count(Surface::GroundSurface),
            ],
            inferred_faces: s.inferred(),
            topology: tri.topology(),
            volume_m3: s.signed_volume_m3(),
            max_planarity_error_m: s.max_planarity_error_m(),
            twin: None,
            mesh: None,
            plane_list: twin
                .planes
                .planes
                .iter()
                .map(|p| (p.kind, p.n.to_array(), p.d, p.support.len(), p.snapped))
                .collect(),
        }
    }

    /// Markdown.
    pub fn render(&self) -> String {
        let mut o = format!("# Planar twin of {}\n\n", self.run);
        o += &format!(
            "- planes: {} walls, {} roofs, {} ground; dominant wall directions {:?}°\n",
            self.planes[0],
            self.planes[1],
            self.planes[2],
            self.dominant_azimuths_deg
                .iter()
                .map(|a| (a * 10.0).round() / 10.0)
                .collect::<Vec<_>>()
        );
        o += &format!(
            "- walls oriented by {} pair clouds: {} of {}; ground enclosed between their backs: {:.0} m²\n",
            self.pair_views, self.oriented_walls[0], self.oriented_walls[1], self.enclosed_m2
        );
        o += &format!(
            "- footprint: {} of {} cells inside, {} building(s)\n",
            self.cells[1], self.cells[0], self.buildings
        );
        o += &format!(
            "- faces: {} ({} wall, {} roof, {} ground), {} inferred\n",
            self.faces[0], self.faces[1], self.faces[2], self.faces[3], self.inferred_faces
        );
        let t = &self.topology;
        o += &format!(
            "- solid: watertight {}, manifold {} ({} boundary, {} non-manifold, {} misoriented edges), volume {:.0} m³, planarity {:.1e} m\n\n",
            t.watertight, t.manifold, t.boundary_edges, t.nonmanifold_edges, t.misoriented_edges,
            self.volume_m3, self.max_planarity_error_m
        );
        o += "| | √CD (m) | F(1.5 m) | false surface | faces |\n|---|---|---|---|---|\n";
        if let Some(m) = &self.twin {
            o += &format!(
                "| planar twin | {:.3} | {:.1} | {:.1} % | {} |\n",
                m.cloud.sqrt_chamfer_m,
                m.cloud.fscores.fscore_1_5m,
                m.area.false_surface_pct,
                self.faces[0]
            );
        }
        if let Some(m) = &self.mesh {
            o += &format!(
                "| Poisson mesh | {:.3} | {:.1} | {:.1} % | {} |\n",
                m.sqrt_chamfer_m, m.fscore_1_5m, m.false_surface_pct_1_5m, m.faces
            );
        }
        o
    }
}

#[cfg(test)]
mod tests;
