//! The digital twin's surface from an imaging run: the fused cloud, oriented toward the sensors
//! that observed each point and weighted by each detection's amplitude, meshed by screened
//! Poisson ([`crate::mesh::reconstruct`]) and cut to what the imaging supports.
//!
//! **The rules**, each from the imaging rather than from a site:
//! - the Poisson grid's finest cell is [`CELL_PER_VOXEL`] of the imaging voxel (or a depth the
//!   caller gives), whatever the site's extent;
//! - the normals Poisson fits — PCA normals, oriented toward the sensors that observed each
//!   sample — are taken over the fused points within the support distance (below), not over a
//!   fixed number of neighbours: a fused point stands for a resolution cell and scatters across
//!   its surface by a good part of one (0.3–0.5 m measured across the suite, on a 0.25 m lattice
//!   at the default preset), so the 16 nearest points, half a metre of wall there, gave normals
//!   that were mostly noise (median error 40° on factory_site; 15° at the quick preset's sparser
//!   lattice), and Poisson closed bubbles around the noise (mesh area 2.7–3.6× the truth's). Over
//!   the support distance the median error is 6°. The tests that ask which way the surface
//!   through one sample faces — [`faces_a_pair`], the wall and roof tests of the wall columns and
//!   the roof-edge walls — read normals over half the support distance
//!   ([`TEST_NORMAL_SUPPORT_FRACTION`], at least the 16 nearest points). Not the whole support
//!   distance: at a roof's outer edge that neighbourhood is half a roof slab, its normal turns
//!   outward and the edge reads as a wall (held-out site_42, quick: the wall under such an edge
//!   lost, mesh √CD 0.664 → 0.866 m). Not a fixed count of points either: the tests were built
//!   and checked at the quick preset, whose 0.5 m lattice puts the 16 nearest within about a
//!   metre and gives them a median error of 13° against the truth's normals (factory_site), while
//!   on the default preset's 0.25 m lattice the same 16 span half a metre of a surface scattered
//!   by 0.3–0.5 m and err by 48° (courtyard) — the faces-a-pair test then dropped 18 % of the
//!   courtyard's samples against 12 %. Over half the support distance the default preset's
//!   normals err by 14.5°, the quick preset's are the 16 nearest as before: one rule in metres,
//!   the same accuracy at both lattices. Measured: docs/journal/results.md, "Normals over a resolution
//!   cell";
//! - each sample weighs its fusion weight (the fused cloud's `weight`, [`super::fuse`]): over the
//!   pairs that detected it, the sum of each detection's `|I|` relative to its pair's peak times
//!   the pair's resolution factor — the confidence the fusion already keeps points by. A cluster
//!   of weak detections leaves no surface of its own, and where pairs of different resolution
//!   image the same surface at slightly different places, the surface follows the finer and the
//!   more often confirmed ([`crate::mesh::screened_poisson_weighted`]). Measured against one
//!   pair's `|I|` (the largest) as the weight in docs/journal/results.md;
//! - density trim below [`DEFAULT_TRIM_MEDIAN`] of the median vertex support density
//!   ([`SurfaceOptions::trim_median`]): what the support clip keeps but only scattered weak
//!   detections support — above all the caps Poisson closes over roofs from their vertically
//!   smeared echoes. The fraction is not derived: it was chosen on the whole suite at both
//!   presets (`docs/journal/results.md`, "One mesh rule for every site"), where 0.25 also removed
//!   interpolated true surface (the office's hidden passage) and no trim kept the caps (default
//!   factory_site and street_row meshes worse than their clouds);
//! - clipped to the imaging region — its box, and the polygon drawn on the map where there is
//!   one: nothing was imaged beyond it, and what Poisson closes there is the extrapolation of a
//!   neighbour's smear — and to [`super::support_distance_m`] of the samples
//!   (half the coarsest resolution cell: a fused point stands for a cell, farther is
//!   extrapolation);
//! - only the faces turned as the samples nearest them are kept
//!   ([`crate::mesh::TriMesh::facing_samples`]): where the samples are an open sheet (a wall
//!   seen from outside, a roof seen from above), Poisson closes a thin solid around them whose
//!   far side faces away from every sensor — never seen, and double the area (default preset,
//!   suite and held-out sites: 1.85–2.64× the truth's area → 1.35–1.82×, √CD from 0.025 m
//!   better to 0.009 m worse site by site; docs/journal/results.md, "Normals over a resolution cell");
//! - repaired for other tools, then connected components under [`MIN_COMPONENT_FRACTION`] of the
//!   largest one's area dropped;
//! - where the terrain is known, cut under it: faces whose vertices all lie more than a cell below
//!   the ground ([`crate::mesh::TriMesh::clip_below_ground`]) — the ground is opaque, and the
//!   flare Poisson closes under walls whose samples end at a sloping ground lies above the
//!   region's floor, which is a plane at the ground's lowest point;
//! - a point whose local surface (its PCA normal, oriented toward its sensors) faces away from
//!   the transmitter or the receiver of every pair that detected it is left out of the mesher's
//!   input ([`faces_a_pair`]): a Lambertian facet echoes to a pair only when it faces both of
//!   its ends (`cos θ_tx·cos θ_rx > 0`), so such a point is not a facet its pairs saw but the
//!   smear of a neighbouring echo (a roof's image under a vehicle's poor vertical resolution,
//!   whose normal then points down at the vehicle and closes a slab over the roof). It stays in
//!   the cloud; only the surface does not follow it;
//! - below the lowest sample of each wall, samples down to what the wall stands on — a lower
//!   roof of the cloud or the known terrain ([`super::wall_columns`], on by default,
//!   [`SurfaceOptions::wall_columns`]): what no pair saw of a wall whose upper part they did;
//! - over a building whose imaged walls outline a rectangle or a circle and whose roof no pair
//!   saw, a roof at the walls' top ([`super::hidden_roofs`], on by default,
//!   [`SurfaceOptions::hidden_roofs`]): a terminal on the ground and a base station on a mast
//!   see no roof above the terminal, so without a UAV the roofs are not imaged at all; a
//!   footprint's side no wall images stands, under a gable imaged past its ridge, at the mirror
//!   of the opposite side about the ridge (on by default, [`SurfaceOptions::gables`]);
//! - inside a building whose imaged walls outline a footprint, the walls of the rules above and
//!   below stand on its roof, not on the terrain ([`super::hidden_roofs::standing_on`], on by
//!   default, [`SurfaceOptions::inner_walls_on_roofs`]): a riser or a ridge inside the outline
//!   rises from the roof;
//! - down the fall line of each imaged roof slope to a face rising above it across what no pair
//!   imaged, the slope and that face's foot ([`super::valleys`], on by default,
//!   [`SurfaceOptions::valleys`]): a sawtooth roof's valleys behind its risers, which no pair sees
//!   and Poisson bridged from one tooth's top to the next;
//! - under each outer edge of an imaged or added roof (the imaging region's border is none:
//!   nothing was imaged beyond it), a wall down to the terrain
//!   ([`super::wall_columns::roof_edge_walls`], on by default,
//!   [`SurfaceOptions::roof_edge_walls`]): the walls no pair saw at all;
//! - across the gaps between the pieces of each side of a rectangular footprint (what was
//!   imaged or inferred of the wall there), a wall from the roof down to the terrain
//!   ([`super::outline_walls`], on by default, [`SurfaceOptions::outline_walls`]): a face no pair
//!   saw, under a roof edge whose image's rim reads as a wall looking into the building;
//! - optionally ([`SurfaceOptions::visibility_filter`]) points that a one level coarser first
//!   surface hides from every pair that observed them are left out
//!   ([`crate::mesh::visibility_consistent`], margin [`VISIBILITY_MARGIN_VOXELS`]).
//!
//! Units: metres, world frame.

use std::time::Instant;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::facing::test_normals;
pub use super::facing::{faces_a_pair, TEST_NORMAL_SUPPORT_FRACTION};
use super::free_space::{Across, FreeSpace};
use super::hidden_roofs::{hidden_roofs, standing_on, Footprint, RoofOptions};
use super::outline_walls::outline_walls;
use super::pair_cell::PairCell;
use super::run::{
    observing_pairs, pair_cell, pair_sensors, sensors_of, support_distance_m, RunResult,
};
use super::valleys::valleys;
use super::wall_columns::{roof_edge_walls, wall_columns};
use super::world::Terrain;
use crate::knn::GeometryError;
use crate::mesh::{
    depth_for_cell, estimate_normals_over, reconstruct, reconstruct_oriented,
    visibility_consistent, Neighbourhood, Orientation, PoissonParams, ReconstructParams, TriMesh,
    Trim,
};
use crate::scenario::Scenario;

/// Connected components of the mesh below this fraction of the largest one's area are dropped
/// (blobs around ghost points).
pub const MIN_COMPONENT_FRACTION: f32 = 0.02;
/// Margin of the visibility-consistency filter, in imaging voxels: a leg counts as blocked only
/// if the first-pass surface is hit this far before the point (the cloud is a shell about a
/// resolution cell thick).
pub const VISIBILITY_MARGIN_VOXELS: f32 = 4.0;
/// The Poisson grid's finest cell, in imaging voxels. The cloud samples each surface on the
/// voxel lattice, so half a voxel is the grid that places the indicator's jump between two
/// samples (a cell of one voxel, or one that followed the cloud's extent to anywhere between half
/// and one voxel, measured worse on the suite, quick: mesh √CD 0.979–1.169 m against
/// 0.956–1.167 m).
pub const CELL_PER_VOXEL: f32 = 0.5;

/// Default density trim, fraction of the median vertex support density (module docs).
pub const DEFAULT_TRIM_MEDIAN: f32 = 0.1;

/// Settings of [`surface`].
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceOptions {
    /// Poisson grid depth (finest cell = 1.2 × largest extent / 2^depth); `None`: a finest cell
    /// of [`CELL_PER_VOXEL`] imaging voxels, whatever the cloud's extent.
    pub depth: Option<u32>,
    /// The finest Poisson cell in metres, replacing the default rule (ignored with `depth`).
    pub cell_m: Option<f32>,
    /// Density trim, fraction of the median vertex support density, in (0, 1]; `None`: no trim
    /// (default [`DEFAULT_TRIM_MEDIAN`], module docs).
    pub trim_median: Option<f32>,
    /// Leave out the points a coarser first-pass surface hides from every pair that observed
    /// them (module docs).
    pub visibility_filter: bool,
    /// Continue each wall down to what it stands on (module docs, [`super::wall_columns`]).
    pub wall_columns: bool,
    /// Stand a wall under each outer edge of an imaged roof (module docs,
    /// [`super::wall_columns::roof_edge_walls`]).
    pub roof_edge_walls: bool,
    /// Roof the buildings whose imaged walls outline a rectangle or a circle and whose roof no
    /// pair saw (module docs, [`super::hidden_roofs`]).
    pub hidden_roofs: bool,
    /// Inside a building whose imaged walls outline a footprint, stand the continued walls and
    /// the walls under roof edges on its roof, not on the terrain (module docs,
    /// [`super::hidden_roofs::standing_on`]).
    pub inner_walls_on_roofs: bool,
    /// Wall the gaps between the pieces of each side of a rectangular footprint (module docs,
    /// [`super::outline_walls`]).
    pub outline_walls: bool,
    /// Place a footprint's side no pair saw at the mirror of the opposite side about the ridge
    /// of a gable roof imaged past its ridge (module docs, [`super::hidden_roofs`]).
    pub gables: bool,
    /// Continue each imaged roof slope down its fall line to a face rising above it, and the
    /// face down to it (module docs, [`super::valleys`]).
    pub valleys: bool,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        SurfaceOptions {
            depth: None,
            cell_m: None,
            trim_median: Some(DEFAULT_TRIM_MEDIAN),
            visibility_filter: false,
            wall_columns: true,
            roof_edge_walls: true,
            hidden_roofs: true,
            inner_walls_on_roofs: true,
            outline_walls: true,
            gables: true,
            valleys: true,
        }
    }
}

/// What the visibility filter did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct VisibilityFiltered {
    /// Margin of the test, metres.
    pub margin_m: f32,
    /// Points left out.
    pub removed_points: usize,
    /// Points before the filter.
    pub input_points: usize,
}

/// The surface of an imaging run and the input it was meshed from.
#[derive(Clone, Debug)]
pub struct Surface {
    /// The mesh: clipped (trimmed if asked), repaired.
    pub mesh: TriMesh,
    /// The mesher's input points (the fused cloud, less the visibility filter's ghosts).
    pub points: Vec<Vec3>,
    /// One oriented normal per input point.
    pub normals: Vec<Vec3>,
    /// One weight per input point (the fused `weight`).
    pub weights: Vec<f32>,
    /// Poisson depth used.
    pub depth: u32,
    /// Finest Poisson cell, metres.
    pub cell_m: f32,
    /// The box the mesh was clipped to (the imaging region), lower and upper corner.
    pub clip_box: (Vec3, Vec3),
    /// The support distance the mesh was clipped to, metres.
    pub support_distance_m: f32,
    /// The visibility filter's effect, when it ran.
    pub visibility: Option<VisibilityFiltered>,
    /// Points left out because their local surface faces away from an end of every pair that
    /// detected them ([`faces_a_pair`]).
    pub facing_away: usize,
    /// Samples added below the walls ([`super::wall_columns`]), included in `points`.
    pub wall_column_samples: usize,
    /// Samples added below the roofs' outer edges ([`super::wall_columns::roof_edge_walls`]),
    /// included in `points` after the wall columns'.
    pub roof_edge_samples: usize,
    /// Samples of the roofs added over imaged walls ([`super::hidden_roofs`]), included in
    /// `points`.
    pub hidden_roof_samples: usize,
    /// Samples of the walls across the gaps along the footprints' sides
    /// ([`super::outline_walls`]), included in `points` after the roof-edge walls'.
    pub outline_wall_samples: usize,
    /// Samples of the slopes and faces meeting in valleys ([`super::valleys`]), included in
    /// `points` after the hidden roofs' and before the roof-edge walls'.
    pub valley_samples: usize,
    /// Inferred samples dropped because a pair's leg passed through them to a surface it
    /// detected farther on ([`super::free_space`]; the counts above are before this).
    pub free_space_samples: usize,
    /// Each building's footprint as [`super::hidden_roofs`] read it from its walls (with
    /// [`SurfaceOptions::hidden_roofs`] off, each with 0 samples).
    pub footprints: Vec<Footprint>,
    /// Seconds for the whole stage.
    pub seconds: f64,
}

/// Meshes an imaging run's fused cloud (module docs). `terrain`: the site's known terrain, the
/// floor the walls are continued to (`None`: not known, no wall is continued).
///
/// # Errors
/// A trim fraction outside (0, 1]; as [`reconstruct`] and [`visibility_consistent`].
pub fn surface(
    sc: &Scenario,
    terrain: Option<&Terrain>,
    result: &RunResult,
    opts: &SurfaceOptions,
) -> Result<Surface, GeometryError> {
    if let Some(f) = opts.trim_median.filter(|f| !(*f > 0.0 && *f <= 1.0)) {
        return Err(GeometryError::BadParameter {
            field: "trim_median",
            value: f as f64,
            expected: "in (0, 1]",
        });
    }
    let t = Instant::now();
    let voxel = sc.imaging.voxel_m;
    let padding = PoissonParams::default().padding;
    let cell = opts.cell_m.unwrap_or(CELL_PER_VOXEL * voxel);
    let depth = opts
        .depth
        .unwrap_or_else(|| depth_for_cell(&result.fused.points, padding, cell));
    let clip_box = sc.region();
    let support = support_distance_m(sc, &result.plans);
    let params = ReconstructParams {
        poisson: PoissonParams {
            depth,
            // Without an explicit depth the cell is fixed in metres, whatever the extent.
            cell_m: opts.depth.is_none().then_some(cell),
            ..PoissonParams::default()
        },
        trim: opts.trim_median.map(Trim::MedianFraction),
        clip_box: Some(clip_box),
        support_distance_m: Some(support),
        facing_samples: true,
        min_component_fraction: Some(MIN_COMPONENT_FRACTION),
        ..ReconstructParams::default()
    };
    let mut points = result.fused.points.clone();
    // Each point's confidence, its fusion weight: weak detections (PSF skirts, sidelobes near
    // the threshold), coarse pairs and points one pair alone kept carry less of the surface.
    let mut weights = result.fused.weight.clone();
    let mut observers = observing_pairs(sc, &result.plans, &result.fused);
    let mut sensors = sensors_of(&observers);
    let mut visibility = None;
    if opts.visibility_filter {
        let coarse = ReconstructParams {
            poisson: PoissonParams {
                depth: depth.saturating_sub(1).max(1),
                cell_m: params.poisson.cell_m.map(|c| 2.0 * c),
                ..params.poisson.clone()
            },
            ..params.clone()
        };
        let first = reconstruct(
            &points,
            Some(&weights),
            Orientation::SensorSets(&sensors),
            &coarse,
        )?;
        let margin_m = VISIBILITY_MARGIN_VOXELS * voxel;
        let keep = visibility_consistent(&points, &observers, &first.mesh, margin_m)?;
        visibility = Some(VisibilityFiltered {
            margin_m,
            removed_points: keep.iter().filter(|&&k| !k).count(),
            input_points: points.len(),
        });
        retain_kept(&mut points, &keep);
        retain_kept(&mut sensors, &keep);
        retain_kept(&mut weights, &keep);
        retain_kept(&mut observers, &keep);
    }
    // The normals Poisson fits, over the fused points within the support distance (module docs).
    let neighbourhood = Neighbourhood::Within {
        radius_m: support,
        min: params.normal_k,
    };
    let fit = estimate_normals_over(&points, neighbourhood, Orientation::SensorSets(&sensors))?;
    // Which way the surface through a sample faces, for the tests below (module docs).
    let normals = test_normals(&points, &sensors, support, params.normal_k)?;
    let facing: Vec<bool> = points
        .iter()
        .zip(&normals)
        .zip(&observers)
        .map(|((&p, &n), pairs)| faces_a_pair(p, n, pairs))
        .collect();
    let facing_away = facing.iter().filter(|&&f| !f).count();
    let pick = |v: &[Vec3]| -> Vec<Vec3> {
        v.iter()
            .zip(&facing)
            .filter(|(_, &f)| f)
            .map(|(x, _)| *x)
            .collect()
    };
    let (mut points, mut normals, mut fit) = (pick(&points), pick(&normals), pick(&fit));
    let mut weights: Vec<f32> = weights
        .iter()
        .zip(&facing)
        .filter(|(_, &f)| f)
        .map(|(w, _)| *w)
        .collect();
    let (mut wall_column_samples, mut roof_edge_samples, mut hidden_roof_samples) = (0, 0, 0);
    let (mut outline_wall_samples, mut valley_samples) = (0, 0);
    let mut free_space_samples = 0;
    let mut footprints = Vec::new();
    if let Some(terrain) = terrain {
        let floor = |p: Vec3| terrain.below(p).map(|g| g.z.max(clip_box.0.z));
        // The imaging region's footprint: beyond it nothing was imaged (module docs). It is
        // asked of ground positions: rustc 1.77–1.95 in release builds can let a closure's
        // in-place change of a by-value argument passed by pointer reach the caller's variable
        // (rust-lang/rust#155241); when this took the 3D point and set its height to the
        // region's floor (`p.with_z`), the mirrored roof's test of a point's neighbourhood saw
        // the point at that floor.
        let imaged = |q: Vec2| sc.in_region(q.extend(clip_box.0.z));
        // The footprints are read from what the pairs detected, not from inferred walls.
        let detected = points.len();
        let (roofs, prints) = hidden_roofs(
            &points[..detected],
            &normals[..detected],
            &weights[..detected],
            &RoofOptions {
                cell_m: voxel,
                front_m: support,
                gables: opts.gables,
            },
            floor,
            imaged,
        );
        // Inside a footprint a wall stands on the building's roof (module docs).
        let inside: &[Footprint] = if opts.inner_walls_on_roofs {
            &prints
        } else {
            &[]
        };
        let floor = standing_on(inside, support, floor);
        if opts.wall_columns {
            let w = wall_columns(&points, &normals, &weights, voxel, support, &floor, imaged);
            fit.extend(w.normals.iter().copied());
            wall_column_samples = w.append_to(&mut points, &mut normals, &mut weights);
        }
        footprints = prints.clone();
        if opts.hidden_roofs {
            fit.extend(roofs.normals.iter().copied());
            hidden_roof_samples = roofs.append_to(&mut points, &mut normals, &mut weights);
        }
        if opts.valleys {
            let ground = |p: Vec3| terrain.below(p).map(|g| g.z);
            let v = valleys(
                &points, &fit, &weights, detected, voxel, support, ground, imaged,
            );
            fit.extend(v.normals.iter().copied());
            valley_samples = v.append_to(&mut points, &mut normals, &mut weights);
        }
        if opts.roof_edge_walls {
            let w = roof_edge_walls(&points, &normals, &weights, voxel, support, &floor, imaged);
            fit.extend(w.normals.iter().copied());
            roof_edge_samples = w.append_to(&mut points, &mut normals, &mut weights);
        }
        if opts.outline_walls {
            let a = detected + wall_column_samples;
            let added = &points[a..a + hidden_roof_samples];
            let w = outline_walls(
                &points, &normals, &weights, &prints, added, voxel, support, &floor,
            );
            fit.extend(w.normals.iter().copied());
            outline_wall_samples = w.append_to(&mut points, &mut normals, &mut weights);
        }
        if !opts.hidden_roofs {
            footprints.iter_mut().for_each(|f| f.samples = 0);
        }
        // What no pair detected is not placed where a pair's leg ran through to a surface
        // beyond (module docs): the fused points two pairs kept end the legs.
        if sc.imaging.free_space_test && points.len() > detected {
            let fused = &result.fused;
            let two: Vec<bool> = fused.pairs.iter().map(|&n| n > 1).collect();
            let cells: Vec<PairCell> = result.plans.iter().map(|p| pair_cell(sc, p)).collect();
            let free = FreeSpace::new(
                &fused.points,
                &fused.pair_mask,
                &two,
                &pair_sensors(sc, &result.plans),
                &cells,
                0.5 * voxel,
                support,
            );
            let keep: Vec<bool> = (0..points.len())
                .into_par_iter()
                .map(|i| {
                    i < detected
                        || !free.seen_through(
                            points[i],
                            Some(Across {
                                normal: normals[i],
                                sigma_m: 0.0,
                            }),
                        )
                })
                .collect();
            free_space_samples = keep.iter().filter(|&&k| !k).count();
            retain_kept(&mut points, &keep);
            retain_kept(&mut normals, &keep);
            retain_kept(&mut weights, &keep);
            retain_kept(&mut fit, &keep);
        }
    }
    let normals = fit;
    let mut rec = reconstruct_oriented(&points, normals, Some(&weights), &params)?;
    // Beyond the region's footprint nothing was imaged (module docs).
    rec.mesh = rec.mesh.clip_to(|v| sc.in_region(v));
    if let Some(terrain) = terrain {
        // Under the known terrain, by more than the surface's own cell (module docs).
        let top = clip_box.1.z + 1.0;
        let ground = |v: Vec3| terrain.below(Vec3::new(v.x, v.y, top)).map(|g| g.z);
        rec.mesh = rec
            .mesh
            .clip_below_ground(ground, rec.poisson.cell_m)
            .remove_small_components(MIN_COMPONENT_FRACTION)?;
    }
    Ok(Surface {
        mesh: rec.mesh,
        points,
        normals: rec.normals,
        weights,
        facing_away,
        wall_column_samples,
        roof_edge_samples,
        hidden_roof_samples,
        outline_wall_samples,
        valley_samples,
        free_space_samples,
        footprints,
        depth,
        cell_m: rec.poisson.cell_m,
        clip_box,
        support_distance_m: support,
        visibility,
        seconds: t.elapsed().as_secs_f64(),
    })
}

/// Keeps the elements of `v` whose `keep` is true (an element past `keep`'s end is kept).
fn retain_kept<T>(v: &mut Vec<T>, keep: &[bool]) {
    let mut k = keep.iter();
    v.retain(|_| *k.next().unwrap_or(&true));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_trim_or_an_empty_cloud_is_an_error_naming_it() {
        let sc = Scenario::from_toml_str(include_str!("../../../fixtures/factory.toml")).unwrap();
        let empty = RunResult {
            plans: Vec::new(),
            images: Vec::new(),
            fused: super::super::FusedCloud::default(),
        };
        for bad in [0.0, -0.5, 1.5, f32::NAN] {
            let opts = SurfaceOptions {
                trim_median: Some(bad),
                ..SurfaceOptions::default()
            };
            let e = surface(&sc, None, &empty, &opts).unwrap_err();
            assert!(e.to_string().contains("trim_median"), "{e}");
        }
        let e = surface(&sc, None, &empty, &SurfaceOptions::default()).unwrap_err();
        assert!(e.to_string().contains("points"), "{e}");
    }
}
