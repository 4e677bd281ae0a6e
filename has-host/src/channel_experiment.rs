//! The channel-prediction experiment of a scenario (paper §2) as one library call: ray-trace one
//! BS to every UE on the true scene and on the digital twin, compare every UE
//! ([`crate::channel_experiment::comparison::compare_ue`]), and reduce the matched pairs and beams to a typed report
//! ([`ChannelReport`], serialised as the `channel` key of `has-sim channel`'s `report.json`).
//!
//! # Scenes
//! Both scenes are all ITU concrete. The true scene is the scenario's objects; the twin is the
//! reconstructed mesh plus the true scene's `known_objects` ([`crate::channel_experiment::comparison::twin_objects`]).
//! The UEs, the tracer settings and the codebook come from the `[channel]` table
//! ([`ChannelSpec`]).
//!
//! # Statistics
//! Errors are in report units: delay in nanoseconds, the four angles (AoA, AoD, ZoA, ZoD) in
//! degrees, always in that order ([`KEYS`], [`PerParam`]). Only kept UEs count. Both matching
//! directions are pooled (true → twin, then twin → true, UE by UE); p50/p90/p95 interpolate
//! linearly between order statistics ([`crate::multipath::percentile`]); a percentile of no pairs
//! is `None` (JSON `null`), a mean of no pairs 0. A pair farther than [`UNMATCHED_DISTANCE`]
//! (normalised units of [`crate::multipath`]) counts as unmatched: its source path has no
//! counterpart in the other model. A pair is "via the building" when its source path reflects at
//! least once off an object that is not known (the reconstructed part of the twin, the building
//! of the true scene). Beam losses are dB ≥ 0; a UE whose twin has no path loses an infinite
//! amount, clamped to 10⁹ dB in the percentiles.

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::beam::DftCodebook;
use crate::material::Material;
use crate::multipath::{percentile, Match, MultipathError, ParamErrors, PathParams};
use crate::paths::{Path, PathError, Tracer, TracerConfig};
use crate::scenario::ChannelSpec;
use crate::scenario::SceneSpecError;
use crate::scenario::{Scenario, ScenarioError};
use crate::scene::{Object, Scene, SceneError};
use comparison::{compare_ue, twin_objects, with_material, UeOutcome};

pub mod comparison;
pub mod exports;
mod markdown;

pub use exports::{errors_by_param, errors_csv, ue_map, ues_csv, UeMap};

/// Report keys of the five parameters, in column order (the field names of [`PerParam`]).
pub const KEYS: [&str; 5] = ["delay_ns", "aoa_deg", "aod_deg", "zoa_deg", "zod_deg"];

/// The paper's 90th percentiles (§2, Fig. 9): ns and degrees.
pub const PAPER_P90: PerParam<f64> = PerParam {
    delay_ns: 3.5,
    aoa_deg: 3.0,
    aod_deg: 3.0,
    zoa_deg: 1.0,
    zod_deg: 1.0,
};

/// This project's goal for the 90th percentiles: ns and degrees.
pub const GOAL_P90: PerParam<f64> = PerParam {
    delay_ns: 1.0,
    aoa_deg: 1.0,
    aod_deg: 1.0,
    zoa_deg: 0.5,
    zod_deg: 0.5,
};

/// A matched pair farther than this (normalised units: ns / degrees) counts as unmatched: the
/// path has no counterpart in the other model.
pub const UNMATCHED_DISTANCE: f64 = 5.0;

/// Beam losses above this, dB, are clamped in the percentiles (an infinite loss stays a number).
const LOSS_CLAMP_DB: f64 = 1e9;

/// Why the experiment could not be run. Every variant prints its cause.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ChannelError {
    /// A scenario value is invalid (the carrier, the bandwidth, a `[channel]` field).
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// The true scene's objects could not be built.
    #[error(transparent)]
    SceneSpec(#[from] SceneSpecError),
    /// The true scene is not a valid scene.
    #[error(transparent)]
    TrueScene(SceneError),
    /// The twin (mesh plus known objects) is not a valid scene.
    #[error("twin {twin}")]
    TwinScene {
        /// The twin's label ([`ChannelRunInfo::twin_mesh`]).
        twin: String,
        /// The cause.
        #[source]
        source: SceneError,
    },
    /// The tracer refused a setting or a position.
    #[error(transparent)]
    Trace(#[from] PathError),
    /// The codebook, the window, the matching or a percentile refused its input.
    #[error(transparent)]
    Multipath(#[from] MultipathError),
}

/// What the caller knows of the run, reported as given.
#[derive(Clone, Debug)]
pub struct ChannelRunInfo {
    /// The scenario's name.
    pub scenario: String,
    /// The preset (`"quick"` or `"default"`).
    pub preset: String,
    /// The twin mesh (its path).
    pub twin_mesh: String,
    /// Time spent reconstructing the twin before this call, seconds (0 when it was given).
    pub twin_reconstruction_s: f64,
    /// Start of the run: the report's wall time runs from here to the end of the statistics.
    pub started: Instant,
}

/// The scene being traced, for progress reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceStage {
    /// The true scene.
    True,
    /// The twin.
    Twin,
}

/// The two directions of the Chamfer matching.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MatchDirection {
    /// A true path paired with its nearest twin path.
    TrueToTwin,
    /// A twin path paired with its nearest true path.
    TwinToTrue,
}

impl MatchDirection {
    /// `"true_to_twin"` or `"twin_to_true"`.
    pub fn name(self) -> &'static str {
        match self {
            MatchDirection::TrueToTwin => "true_to_twin",
            MatchDirection::TwinToTrue => "twin_to_true",
        }
    }
}

/// One matched pair of a kept UE.
#[derive(Clone, Debug, PartialEq)]
pub struct MatchedPair {
    /// The UE's index.
    pub ue: usize,
    /// Which set the source path comes from.
    pub direction: MatchDirection,
    /// The match (`from` indexes the source set, `to` the other one, both windowed).
    pub matched: Match,
    /// The source path.
    pub source: PathParams,
    /// Its nearest path in the other set.
    pub target: PathParams,
    /// The source path reflects off an object that is not known (see module docs).
    pub via_building: bool,
}

impl MatchedPair {
    /// The pair's errors in report units, in [`KEYS`] order.
    pub fn errors(&self) -> [f64; 5] {
        errors_in_units(&self.matched.errors)
    }
}

/// The experiment's results: the report and the per-UE and per-pair data behind it.
pub struct ChannelExperiment {
    /// The report.
    pub report: ChannelReport,
    /// The true scene (all concrete).
    pub truth: Scene,
    /// The UE positions, metres.
    pub ues: Vec<DVec3>,
    /// Each UE's comparison, in UE order.
    pub outcomes: Vec<UeOutcome>,
    /// Every matched pair of the kept UEs: UE by UE, true → twin then twin → true.
    pub pairs: Vec<MatchedPair>,
}

/// One value per parameter, serialised under [`KEYS`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PerParam<T> {
    /// Delay, ns.
    pub delay_ns: T,
    /// Azimuth of arrival, degrees.
    pub aoa_deg: T,
    /// Azimuth of departure, degrees.
    pub aod_deg: T,
    /// Zenith of arrival, degrees.
    pub zoa_deg: T,
    /// Zenith of departure, degrees.
    pub zod_deg: T,
}

impl<T> PerParam<T> {
    /// From values in [`KEYS`] order.
    pub fn from_array([delay_ns, aoa_deg, aod_deg, zoa_deg, zod_deg]: [T; 5]) -> Self {
        PerParam {
            delay_ns,
            aoa_deg,
            aod_deg,
            zoa_deg,
            zod_deg,
        }
    }

    /// The values in [`KEYS`] order.
    pub fn to_array(self) -> [T; 5] {
        [
            self.delay_ns,
            self.aoa_deg,
            self.aod_deg,
            self.zoa_deg,
            self.zod_deg,
        ]
    }
}

/// The five errors in report units (ns, degrees), in [`KEYS`] order.
pub fn errors_in_units(e: &ParamErrors) -> [f64; 5] {
    [
        e.delay_s * 1e9,
        e.aoa.to_degrees(),
        e.aod.to_degrees(),
        e.zoa.to_degrees(),
        e.zod.to_degrees(),
    ]
}

/// Percentiles and means of a set of pairs' errors.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ErrorStats {
    /// Number of pairs.
    pub count: usize,
    /// Medians (`None` without pairs).
    pub p50: PerParam<Option<f64>>,
    /// 90th percentiles.
    pub p90: PerParam<Option<f64>>,
    /// 95th percentiles.
    pub p95: PerParam<Option<f64>>,
    /// Means (0 without pairs).
    pub mean: PerParam<f64>,
}

impl ErrorStats {
    /// The statistics of `rows`, five errors per pair in [`KEYS`] order.
    ///
    /// # Errors
    /// [`MultipathError::OutOfRange`] if an error is NaN.
    pub fn of(rows: &[[f64; 5]]) -> Result<ErrorStats, MultipathError> {
        let column = |k: usize| -> Vec<f64> { rows.iter().map(|r| r[k]).collect() };
        let at = |q: f64| -> Result<PerParam<Option<f64>>, MultipathError> {
            let mut out = [None; 5];
            for (k, slot) in out.iter_mut().enumerate() {
                let v = column(k);
                if !v.is_empty() {
                    *slot = Some(percentile(&v, q)?);
                }
            }
            Ok(PerParam::from_array(out))
        };
        let n = rows.len().max(1) as f64;
        let mean = std::array::from_fn(|k| rows.iter().map(|r| r[k]).sum::<f64>() / n);
        Ok(ErrorStats {
            count: rows.len(),
            p50: at(50.0)?,
            p90: at(90.0)?,
            p95: at(95.0)?,
            mean: PerParam::from_array(mean),
        })
    }
}

/// The true → twin statistics of the true paths of one reflection order.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OrderStats {
    /// Percentiles and means of the order's pairs.
    #[serde(flatten)]
    pub stats: ErrorStats,
    /// Pairs farther than [`UNMATCHED_DISTANCE`].
    pub unmatched: usize,
    /// Their share of the order's pairs, percent.
    pub unmatched_pct: f64,
}

/// `channel.ues`: the UE draw and how many were kept.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UeCounts {
    /// UEs drawn.
    pub total: usize,
    /// UEs whose strongest true path loses less than `max_loss_db`.
    pub kept: usize,
    /// The others.
    pub dropped: usize,
    /// Kept UEs for which the twin has no path at all.
    pub kept_without_twin_paths: usize,
    /// UE height, metres.
    pub height_m: f64,
    /// UE region, lower corner, metres.
    pub region_min: [f64; 2],
    /// UE region, upper corner, metres.
    pub region_max: [f64; 2],
    /// Seed of the draw.
    pub seed: u64,
}

/// `channel.paths`: path and pair counts.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PathCounts {
    /// Paths traced on the true scene (every UE).
    pub true_total: usize,
    /// Paths traced on the twin (every UE).
    pub twin_total: usize,
    /// True paths of kept UEs within the window.
    pub true_kept: usize,
    /// Twin paths of kept UEs within the window.
    pub twin_kept: usize,
    /// Pairs true → twin.
    pub matched_true_to_twin: usize,
    /// Pairs twin → true.
    pub matched_twin_to_true: usize,
    /// True → twin pairs farther than `unmatched_distance`.
    pub unmatched_true: usize,
    /// Twin → true pairs farther than `unmatched_distance`.
    pub unmatched_twin: usize,
    /// [`UNMATCHED_DISTANCE`].
    pub unmatched_distance: f64,
}

/// Percentiles of the beam loss, dB.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LossPercentiles {
    /// Median.
    pub p50: Option<f64>,
    /// 90th percentile.
    pub p90: Option<f64>,
    /// 95th percentile.
    pub p95: Option<f64>,
}

/// `channel.beam`: beam selection from the twin judged on the true channel.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BeamReport {
    /// The codebook, in words.
    pub codebook: String,
    /// Kept UEs with a beam outcome.
    pub ues: usize,
    /// Share whose predicted beam is the true best, percent.
    pub agreement_pct: f64,
    /// Share whose predicted beam loses at most 1 dB, percent.
    pub within_1db_pct: f64,
    /// Loss percentiles (`None` without UEs).
    pub loss_db: Option<LossPercentiles>,
}

/// `channel.tracer`: the tracer settings and the size of both scenes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TracerReport {
    /// Highest reflection order.
    pub max_order: usize,
    /// SBR rays of the candidate search.
    pub sbr_rays: usize,
    /// Facet clustering angle, degrees.
    pub facet_angle_deg: f64,
    /// Facet clustering distance, metres.
    pub facet_dist_m: f64,
    /// Line of sight traced.
    pub los: bool,
    /// Diffraction traced.
    pub diffraction: bool,
    /// Facets of the true scene.
    pub facets_true: usize,
    /// Facets of the twin.
    pub facets_twin: usize,
    /// Candidate sequences from the BS, true scene.
    pub candidates_true: usize,
    /// Candidate sequences from the BS, twin.
    pub candidates_twin: usize,
    /// Triangles of the true scene.
    pub triangles_true: usize,
    /// Triangles of the twin.
    pub triangles_twin: usize,
}

/// `channel.timings_s`, seconds.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Timings {
    /// From [`ChannelRunInfo::started`] to the end of the statistics.
    pub wall: f64,
    /// [`ChannelRunInfo::twin_reconstruction_s`].
    pub twin_reconstruction: f64,
    /// Candidate search from the BS, true scene.
    pub prepare_true: f64,
    /// Tracing every UE, true scene.
    pub trace_true: f64,
    /// Candidate search from the BS, twin.
    pub prepare_twin: f64,
    /// Tracing every UE, twin.
    pub trace_twin: f64,
    /// Comparing every UE.
    pub analysis: f64,
}

/// `channel.paths_per_s`: traced paths per second of tracing.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PathsPerSecond {
    /// True scene.
    #[serde(rename = "true")]
    pub true_scene: f64,
    /// Twin.
    pub twin: f64,
    /// True scene, the candidate search included.
    pub true_incl_prepare: f64,
    /// Twin, the candidate search included.
    pub twin_incl_prepare: f64,
}

/// `channel.conventions`: the report's definitions, in words.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Conventions {
    /// The matching and its distance.
    pub matching: String,
    /// Angle conventions.
    pub angles: &'static str,
    /// The percentile definition.
    pub percentile: &'static str,
    /// Which UEs and paths are kept.
    pub kept: &'static str,
    /// Beam selection.
    pub beam: &'static str,
    /// What the twin is.
    pub twin: &'static str,
    /// The via-building subset.
    pub via_building: &'static str,
    /// Its matched part.
    pub via_building_matched: &'static str,
}

/// The report of one experiment (`report.json`'s `channel`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChannelReport {
    /// [`ChannelRunInfo::scenario`].
    pub scenario: String,
    /// [`ChannelRunInfo::preset`].
    pub preset: String,
    /// [`ChannelRunInfo::twin_mesh`].
    pub twin_mesh: String,
    /// Carrier, GHz.
    pub fc_ghz: f64,
    /// The material of both scenes, in words.
    pub material: &'static str,
    /// BS position, metres.
    pub bs_position: [f64; 3],
    /// BS array normal azimuth, degrees.
    pub bs_boresight_deg: f64,
    /// The UEs.
    pub ues: UeCounts,
    /// UE keep threshold, dB.
    pub max_loss_db: f64,
    /// Path window, dB.
    pub window_db: f64,
    /// Path and pair counts.
    pub paths: PathCounts,
    /// Every pair, both directions pooled (`count`, `p50`, `p90`, `p95`, `mean`).
    #[serde(flatten)]
    pub all: ErrorStats,
    /// Pairs whose source path reflects off an unknown object.
    pub via_building: ErrorStats,
    /// Those within [`UNMATCHED_DISTANCE`].
    pub via_building_matched: ErrorStats,
    /// True → twin pairs.
    pub true_to_twin: ErrorStats,
    /// Twin → true pairs.
    pub twin_to_true: ErrorStats,
    /// True → twin pairs by reflection order of the true path.
    pub true_to_twin_by_order: BTreeMap<usize, OrderStats>,
    /// [`PAPER_P90`].
    pub paper_p90: PerParam<f64>,
    /// [`GOAL_P90`].
    pub goal_p90: PerParam<f64>,
    /// Beam selection.
    pub beam: BeamReport,
    /// Tracer settings and scene sizes.
    pub tracer: TracerReport,
    /// Timings.
    pub timings_s: Timings,
    /// Tracing throughput.
    pub paths_per_s: PathsPerSecond,
    /// Rayon threads.
    pub threads: usize,
    /// Definitions.
    pub conventions: Conventions,
}

/// The whole `report.json` of `has-sim channel`: the report under the key `channel`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ChannelReportFile<'a> {
    /// The experiment's report.
    pub channel: &'a ChannelReport,
}

impl ChannelReport {
    /// Paths traced per second over both scenes: every traced path of the true scene and the
    /// twin over the two tracing times (preparation excluded).
    pub fn paths_per_s_both(&self) -> f64 {
        let (p, t) = (&self.paths, &self.timings_s);
        (p.true_total + p.twin_total) as f64 / (t.trace_true + t.trace_twin).max(1e-9)
    }
}

/// One scene traced from the BS to every UE.
struct Traced {
    paths: Vec<Vec<Path>>,
    facets: usize,
    candidates: usize,
    prepare_s: f64,
    trace_s: f64,
}

fn trace_scene(
    stage: TraceStage,
    scene: &Scene,
    config: &TracerConfig,
    bs: DVec3,
    ues: &[DVec3],
    progress: &(dyn Fn(TraceStage, u64, u64) + Sync),
) -> Result<Traced, PathError> {
    let tracer = Tracer::new(scene, config.clone())?;
    let t = Instant::now();
    let cand = tracer.prepare_tx(bs)?;
    let prepare_s = t.elapsed().as_secs_f64();
    let total = ues.len() as u64;
    progress(stage, 0, total);
    // Counted under the lock so the reports arrive in order.
    let done = Mutex::new(0u64);
    let t = Instant::now();
    let paths = ues
        .par_iter()
        .map(|&rx| {
            let r = tracer.trace(&cand, rx);
            let mut d = done
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            *d += 1;
            progress(stage, *d, total);
            r
        })
        .collect::<Result<Vec<_>, _>>()?;
    let trace_s = t.elapsed().as_secs_f64();
    Ok(Traced {
        paths,
        facets: tracer.facets().facets.len(),
        candidates: cand.len(),
        prepare_s,
        trace_s,
    })
}

/// True if `p` reflects at least once off an object whose `known` flag is false (or missing).
fn via_building(p: &PathParams, known: &[bool]) -> bool {
    p.objects()
        .iter()
        .any(|&o| !known.get(o as usize).copied().unwrap_or(false))
}

/// p50/p90/p95 of the beam losses, each clamped to [`LOSS_CLAMP_DB`] (`None` without losses).
fn loss_percentiles(losses: &[f64]) -> Option<LossPercentiles> {
    if losses.is_empty() {
        return None;
    }
    let clamped: Vec<f64> = losses.iter().map(|x| x.min(LOSS_CLAMP_DB)).collect();
    let at = |q| percentile(&clamped, q).ok();
    Some(LossPercentiles {
        p50: at(50.0),
        p90: at(90.0),
        p95: at(95.0),
    })
}

/// The statistics of the kept UEs' outcomes (see module docs).
struct Tally {
    pairs: Vec<MatchedPair>,
    ues_kept: usize,
    kept_without_twin_paths: usize,
    true_kept: usize,
    twin_kept: usize,
    all: Vec<[f64; 5]>,
    forward: Vec<[f64; 5]>,
    backward: Vec<[f64; 5]>,
    building: Vec<[f64; 5]>,
    building_matched: Vec<[f64; 5]>,
    by_order: BTreeMap<usize, Vec<[f64; 5]>>,
    /// Per order of the true path: (pairs, unmatched pairs).
    unmatched_by_order: BTreeMap<usize, (usize, usize)>,
    unmatched_true: usize,
    unmatched_twin: usize,
    beam_ues: usize,
    beam_agree: usize,
    beam_within_1db: usize,
    beam_loss_db: Vec<f64>,
}

impl Tally {
    fn of(outcomes: &[UeOutcome], known_true: &[bool], known_twin: &[bool]) -> Tally {
        let mut t = Tally {
            pairs: Vec::new(),
            ues_kept: 0,
            kept_without_twin_paths: 0,
            true_kept: 0,
            twin_kept: 0,
            all: Vec::new(),
            forward: Vec::new(),
            backward: Vec::new(),
            building: Vec::new(),
            building_matched: Vec::new(),
            by_order: BTreeMap::new(),
            unmatched_by_order: BTreeMap::new(),
            unmatched_true: 0,
            unmatched_twin: 0,
            beam_ues: 0,
            beam_agree: 0,
            beam_within_1db: 0,
            beam_loss_db: Vec::new(),
        };
        for (ue, o) in outcomes.iter().enumerate() {
            if !o.kept {
                continue;
            }
            t.ues_kept += 1;
            t.true_kept += o.true_paths.len();
            t.twin_kept += o.twin_paths.len();
            if o.twin_paths.is_empty() {
                t.kept_without_twin_paths += 1;
            }
            for m in &o.matches.forward {
                let e = t.pair(ue, MatchDirection::TrueToTwin, m, o, known_true);
                let order = o.true_paths[m.from].order;
                t.forward.push(e);
                t.by_order.entry(order).or_default().push(e);
                let slot = t.unmatched_by_order.entry(order).or_default();
                slot.0 += 1;
                if m.distance > UNMATCHED_DISTANCE {
                    t.unmatched_true += 1;
                    slot.1 += 1;
                }
            }
            for m in &o.matches.backward {
                let e = t.pair(ue, MatchDirection::TwinToTrue, m, o, known_twin);
                t.backward.push(e);
                if m.distance > UNMATCHED_DISTANCE {
                    t.unmatched_twin += 1;
                }
            }
            if let Some(b) = &o.beam {
                t.beam_ues += 1;
                if b.agrees() {
                    t.beam_agree += 1;
                }
                let loss = b.loss_db();
                if loss <= 1.0 {
                    t.beam_within_1db += 1;
                }
                t.beam_loss_db.push(loss);
            }
        }
        t
    }

    /// Records the pair `m` of UE `ue` (pooled and via-building errors); returns its errors.
    fn pair(
        &mut self,
        ue: usize,
        direction: MatchDirection,
        m: &Match,
        o: &UeOutcome,
        known_source: &[bool],
    ) -> [f64; 5] {
        let (src, dst) = match direction {
            MatchDirection::TrueToTwin => (&o.true_paths, &o.twin_paths),
            MatchDirection::TwinToTrue => (&o.twin_paths, &o.true_paths),
        };
        let pair = MatchedPair {
            ue,
            direction,
            matched: *m,
            source: src[m.from],
            target: dst[m.to],
            via_building: via_building(&src[m.from], known_source),
        };
        let e = pair.errors();
        self.all.push(e);
        if pair.via_building {
            self.building.push(e);
            if m.distance <= UNMATCHED_DISTANCE {
                self.building_matched.push(e);
            }
        }
        self.pairs.push(pair);
        e
    }
}

/// A share in percent, 0 of nothing.
fn pct(part: usize, whole: usize) -> f64 {
    100.0 * part as f64 / whole.max(1) as f64
}

/// Runs the experiment: builds both scenes (the scenario's objects; `twin_mesh` plus the known
/// objects), draws the UEs, traces both scenes, compares every UE and reduces the outcomes to
/// the report. `progress(stage, done, total)` reports traced UEs, in order within a stage.
///
/// # Errors
/// [`ChannelError`]: an invalid carrier, bandwidth or `[channel]` value, a scene that cannot be
/// built, a tracer, codebook or matching setting out of range, a NaN error.
pub fn run_channel_experiment(
    sc: &Scenario,
    spec: &ChannelSpec,
    twin_mesh: Vec<Object>,
    run: &ChannelRunInfo,
    progress: &(dyn Fn(TraceStage, u64, u64) + Sync),
) -> Result<ChannelExperiment, ChannelError> {
    let fc = sc.radar.fc_hz_checked()?;
    let truth_objects = with_material(sc.scene.build_objects()?, Material::Concrete);
    let twin_objs = twin_objects(
        twin_mesh,
        &truth_objects,
        &spec.known_objects,
        Material::Concrete,
    )?;
    let truth = Scene::new(truth_objects).map_err(ChannelError::TrueScene)?;
    let twin = Scene::new(twin_objs).map_err(|source| ChannelError::TwinScene {
        twin: run.twin_mesh.clone(),
        source,
    })?;
    let ues = spec.ue_positions(&truth)?;
    let bs = spec.bs();
    let config = spec.tracer_config(fc, sc.range_resolution_m()?);
    let codebook = DftCodebook::new(
        spec.codebook_rows,
        spec.codebook_cols,
        spec.codebook_spacing_wl,
        spec.bs_boresight_deg.to_radians(),
    )?;

    let tr = trace_scene(TraceStage::True, &truth, &config, bs, &ues, progress)?;
    let tw = trace_scene(TraceStage::Twin, &twin, &config, bs, &ues, progress)?;

    let t = Instant::now();
    let outcomes: Vec<UeOutcome> = tr
        .paths
        .par_iter()
        .zip(&tw.paths)
        .map(|(a, b)| compare_ue(spec, &codebook, a, b))
        .collect::<Result<_, _>>()?;
    let analysis_s = t.elapsed().as_secs_f64();

    let known_true: Vec<bool> = truth
        .objects
        .iter()
        .map(|o| spec.known_objects.contains(&o.name))
        .collect();
    let known_twin: Vec<bool> = twin
        .objects
        .iter()
        .map(|o| {
            o.name
                .strip_prefix("known/")
                .is_some_and(|n| spec.known_objects.contains(&n.to_string()))
        })
        .collect();
    let tally = Tally::of(&outcomes, &known_true, &known_twin);
    let n_true: usize = tr.paths.iter().map(Vec::len).sum();
    let n_twin: usize = tw.paths.iter().map(Vec::len).sum();
    let wall = run.started.elapsed().as_secs_f64();
    let mut by_order = BTreeMap::new();
    for (&order, rows) in &tally.by_order {
        let (n, unmatched) = tally
            .unmatched_by_order
            .get(&order)
            .copied()
            .unwrap_or((0, 0));
        by_order.insert(
            order,
            OrderStats {
                stats: ErrorStats::of(rows)?,
                unmatched,
                unmatched_pct: pct(unmatched, n),
            },
        );
    }
    let report = ChannelReport {
        scenario: run.scenario.clone(),
        preset: run.preset.clone(),
        twin_mesh: run.twin_mesh.clone(),
        fc_ghz: fc / 1e9,
        material: "itu_concrete (every object of both scenes)",
        bs_position: spec.bs_position,
        bs_boresight_deg: spec.bs_boresight_deg,
        ues: UeCounts {
            total: ues.len(),
            kept: tally.ues_kept,
            dropped: ues.len() - tally.ues_kept,
            kept_without_twin_paths: tally.kept_without_twin_paths,
            height_m: spec.ue_height_m,
            region_min: spec.ue_region_min,
            region_max: spec.ue_region_max,
            seed: spec.seed,
        },
        max_loss_db: spec.max_loss_db,
        window_db: spec.window_db,
        paths: PathCounts {
            true_total: n_true,
            twin_total: n_twin,
            true_kept: tally.true_kept,
            twin_kept: tally.twin_kept,
            matched_true_to_twin: tally.forward.len(),
            matched_twin_to_true: tally.backward.len(),
            unmatched_true: tally.unmatched_true,
            unmatched_twin: tally.unmatched_twin,
            unmatched_distance: UNMATCHED_DISTANCE,
        },
        all: ErrorStats::of(&tally.all)?,
        via_building: ErrorStats::of(&tally.building)?,
        via_building_matched: ErrorStats::of(&tally.building_matched)?,
        true_to_twin: ErrorStats::of(&tally.forward)?,
        twin_to_true: ErrorStats::of(&tally.backward)?,
        true_to_twin_by_order: by_order,
        paper_p90: PAPER_P90,
        goal_p90: GOAL_P90,
        beam: BeamReport {
            codebook: format!(
                "{}x{} DFT, spacing {} λ, vertical panel facing azimuth {}°",
                spec.codebook_rows,
                spec.codebook_cols,
                spec.codebook_spacing_wl,
                spec.bs_boresight_deg
            ),
            ues: tally.beam_ues,
            agreement_pct: pct(tally.beam_agree, tally.beam_ues),
            within_1db_pct: pct(tally.beam_within_1db, tally.beam_ues),
            loss_db: loss_percentiles(&tally.beam_loss_db),
        },
        tracer: TracerReport {
            max_order: spec.max_order,
            sbr_rays: spec.sbr_rays,
            facet_angle_deg: spec.facet_angle_deg,
            facet_dist_m: spec.facet_dist_m,
            los: true,
            diffraction: false,
            facets_true: tr.facets,
            facets_twin: tw.facets,
            candidates_true: tr.candidates,
            candidates_twin: tw.candidates,
            triangles_true: truth.triangle_count(),
            triangles_twin: twin.triangle_count(),
        },
        timings_s: Timings {
            wall,
            twin_reconstruction: run.twin_reconstruction_s,
            prepare_true: tr.prepare_s,
            trace_true: tr.trace_s,
            prepare_twin: tw.prepare_s,
            trace_twin: tw.trace_s,
            analysis: analysis_s,
        },
        paths_per_s: PathsPerSecond {
            true_scene: n_true as f64 / tr.trace_s.max(1e-9),
            twin: n_twin as f64 / tw.trace_s.max(1e-9),
            true_incl_prepare: n_true as f64 / (tr.trace_s + tr.prepare_s).max(1e-9),
            twin_incl_prepare: n_twin as f64 / (tw.trace_s + tw.prepare_s).max(1e-9),
        },
        threads: rayon::current_num_threads(),
        conventions: Conventions {
            matching: format!(
                "Chamfer-style: every kept true path paired with its nearest kept twin path and every kept twin path with its nearest kept true path (both directions pooled in p50/p90/p95); distance sqrt((Δτ/{} ns)² + Σ (Δangle/{}°)²) over AoA, AoD, ZoA, ZoD",
                spec.match_delay_ns, spec.match_angle_deg
            ),
            angles: "azimuth from +x toward +y, zenith from +z; azimuth errors wrapped to [0°, 180°]",
            percentile: "linear interpolation between order statistics (numpy default)",
            kept: "UE kept if its strongest true path loses < max_loss_db; per UE and model, paths within window_db of that model's strongest",
            beam: "best beam = argmax over the codebook of |Σ a_p w_bᴴ a(AoD_p, ZoD_p)|² (all paths, carrier phase, isotropic elements); predicted from the twin's paths, judged on the true channel",
            twin: "reconstructed mesh + known_objects of the true scene",
            via_building: "pairs whose source path reflects at least once off an object that is not in known_objects (line of sight and ground-only paths excluded)",
            via_building_matched: "via_building pairs within the unmatched distance (the path has a counterpart in the other model)",
        },
    };
    Ok(ChannelExperiment {
        report,
        truth,
        ues,
        outcomes,
        pairs: tally.pairs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::channel_experiment::comparison::BeamOutcome;
    use crate::multipath::ChamferMatch;
    use crate::paths::MAX_ORDER;

    /// A path of `order` reflecting off `objects` (first `order` entries).
    fn path(order: usize, objects: &[u32]) -> PathParams {
        let mut o = [u32::MAX; MAX_ORDER];
        o[..objects.len()].copy_from_slice(objects);
        PathParams {
            delay_s: 1e-7,
            gain_db: -80.0,
            aod: 0.0,
            zod: 1.0,
            aoa: 0.0,
            zoa: 1.0,
            order,
            objects: o,
        }
    }

    /// A match at `distance` with a delay error of `delay_ns`.
    fn matched(from: usize, to: usize, distance: f64, delay_ns: f64) -> Match {
        Match {
            from,
            to,
            distance,
            errors: ParamErrors {
                delay_s: delay_ns * 1e-9,
                aoa: 0.0,
                aod: 0.0,
                zoa: 0.0,
                zod: 0.0,
            },
        }
    }

    #[test]
    fn percentiles_interpolate_between_order_statistics_and_are_none_without_pairs() {
        // Delay errors 0, 1, …, 10 ns in shuffled order; AoA 2° everywhere.
        let rows: Vec<[f64; 5]> = [7.0, 0.0, 10.0, 3.0, 5.0, 1.0, 9.0, 2.0, 8.0, 4.0, 6.0]
            .iter()
            .map(|&d| [d, 2.0, 0.0, 0.0, 0.0])
            .collect();
        let s = ErrorStats::of(&rows).expect("finite errors");
        assert_eq!(s.count, 11);
        // Rank q/100 · (n − 1) = 5, 9, 9.5 on the sorted 0…10.
        assert_eq!(s.p50.delay_ns, Some(5.0));
        assert_eq!(s.p90.delay_ns, Some(9.0));
        assert_eq!(s.p95.delay_ns, Some(9.5));
        assert_eq!(s.p90.aoa_deg, Some(2.0));
        assert_eq!(s.mean.delay_ns, 5.0);
        assert_eq!(s.mean.aoa_deg, 2.0);
        let none = ErrorStats::of(&[]).expect("no pairs is no error");
        assert_eq!(none.count, 0);
        assert_eq!(none.p90, PerParam::from_array([None; 5]));
        assert_eq!(none.mean, PerParam::from_array([0.0; 5]));
        let nan = ErrorStats::of(&[[f64::NAN, 0.0, 0.0, 0.0, 0.0]]);
        assert!(matches!(nan, Err(MultipathError::OutOfRange { .. })));
    }

    #[test]
    fn pairs_beyond_the_unmatched_distance_are_counted_per_direction_and_order_of_kept_ues() {
        // Objects: 0 the known ground, 1 the building.
        let known = [true, false];
        let true_paths = vec![path(0, &[]), path(1, &[1]), path(1, &[0])];
        let twin_paths = vec![path(0, &[]), path(2, &[0, 1]), path(0, &[])];
        let kept = UeOutcome {
            strongest_true_db: Some(-80.0),
            kept: true,
            true_paths: true_paths.clone(),
            twin_paths: twin_paths.clone(),
            matches: ChamferMatch {
                forward: vec![
                    matched(0, 0, 0.0, 0.0),
                    matched(1, 1, UNMATCHED_DISTANCE + 1.0, 6.0),
                    matched(2, 0, UNMATCHED_DISTANCE, 5.0),
                ],
                backward: vec![
                    matched(0, 0, 0.0, 0.0),
                    matched(1, 2, 2.0, 3.0),
                    matched(2, 0, 9.0, 9.0),
                ],
            },
            beam: Some(BeamOutcome {
                true_best: 3,
                true_best_gain: 1.0,
                predicted: None,
                predicted_gain_on_true: 0.0,
            }),
        };
        // A dropped UE's pairs do not count.
        let dropped = UeOutcome {
            kept: false,
            ..kept.clone()
        };
        let t = Tally::of(&[dropped, kept], &known, &known);
        assert_eq!(t.ues_kept, 1);
        assert_eq!((t.true_kept, t.twin_kept), (3, 3));
        assert_eq!(t.pairs.len(), 6);
        assert!(t.pairs.iter().all(|p| p.ue == 1));
        // Exactly at the distance is matched; beyond it is not.
        assert_eq!((t.unmatched_true, t.unmatched_twin), (1, 1));
        assert_eq!(t.unmatched_by_order[&0], (1, 0));
        assert_eq!(t.unmatched_by_order[&1], (2, 1));
        assert_eq!(t.forward.len(), 3);
        assert_eq!(t.backward.len(), 3);
        // Pooled forward then backward: delays 0, 6, 5, 0, 3, 9 ns.
        let delays: Vec<f64> = t.all.iter().map(|r| (r[0] * 1e6).round() / 1e6).collect();
        assert_eq!(delays, [0.0, 6.0, 5.0, 0.0, 3.0, 9.0]);
        // Via the building: true path 1 (off object 1, unmatched) and twin path 1 (the ground,
        // then object 1, matched); not the ground bounce nor the lines of sight.
        let via: Vec<[f64; 5]> = t
            .pairs
            .iter()
            .filter(|p| p.via_building)
            .map(MatchedPair::errors)
            .collect();
        assert_eq!(via, t.building);
        assert_eq!(t.building.len(), 2);
        assert_eq!(t.building_matched.len(), 1);
        assert!((t.building_matched[0][0] - 3.0).abs() < 1e-9);
        // A UE whose twin has no prediction loses an infinite amount, clamped in percentiles.
        assert_eq!(t.beam_loss_db, [f64::INFINITY]);
        let loss = loss_percentiles(&t.beam_loss_db).expect("one UE");
        assert_eq!(loss.p90, Some(LOSS_CLAMP_DB));
        assert!(loss_percentiles(&[]).is_none());
    }
}
