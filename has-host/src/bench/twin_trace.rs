//! Channel tracing on a compact twin against the same site's Poisson mesh: each made into the
//! channel experiment's twin scene (the mesh's objects with the scenario's `known_objects`,
//! [`crate::channel_experiment::comparison::twin_objects`]) and traced with the scenario's
//! `[channel]` tracer from its base station to its UEs, exactly as `has-sim channel` traces a
//! twin.
//!
//! Each stage is timed on its own, in wall seconds: the scene (its BVH), the tracer (its planar
//! facets: region growing over every triangle), the candidate search from the base station
//! (shoot-and-bounce) and the tracing of every UE. The two meshes are measured in turn,
//! `repeats` times, and each stage reports its median, so that a load on the machine during
//! one repeat moves neither side. The speed-up is the Poisson mesh's median over the twin's.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::BenchError;
use crate::channel_experiment::comparison::{twin_objects, with_material};
use crate::paths::{Tracer, TracerConfig};
use crate::scenario::{ChannelSpec, Scenario};
use crate::{Material, Object, Scene};

/// Most turns of each mesh (each turn traces every UE on both).
pub const MAX_REPEATS: usize = 100;

/// One mesh's figures (medians over the repeats).
#[derive(Clone, Debug, serde::Serialize)]
pub struct TwinTraceRow {
    /// Which mesh: `"planar twin"` or `"Poisson mesh"`.
    pub mesh: &'static str,
    /// Triangles of the twin scene (the mesh and the known objects).
    pub triangles: usize,
    /// Planar facets the tracer found in it.
    pub facets: usize,
    /// Candidate facet sequences from the base station.
    pub candidates: usize,
    /// Paths found over every UE.
    pub paths: usize,
    /// Scene (BVH) build, seconds.
    pub scene_s: f64,
    /// Tracer (facets) build, seconds.
    pub facets_s: f64,
    /// Candidate search from the base station, seconds.
    pub prepare_s: f64,
    /// Tracing every UE, seconds.
    pub trace_s: f64,
    /// The four stages together, seconds (median of the repeats' sums).
    pub total_s: f64,
}

/// The whole comparison (`has-sim bench twin`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct TwinTraceReport {
    /// UEs traced.
    pub ues: usize,
    /// Reflection order of the tracer.
    pub max_order: usize,
    /// Repeats of each mesh.
    pub repeats: usize,
    /// Worker threads of the tracing.
    pub threads: usize,
    /// The planar twin's row, then the Poisson mesh's.
    pub rows: [TwinTraceRow; 2],
    /// Poisson mesh total over the twin's.
    pub speedup_total: f64,
    /// Poisson mesh tracing of the UEs over the twin's.
    pub speedup_trace: f64,
}

/// One timed pass over a mesh: (row without medians, per-stage seconds).
fn one_pass(
    name: &'static str,
    mesh: &[Object],
    truth: &[Object],
    spec: &ChannelSpec,
    config: &TracerConfig,
    bs: DVec3,
    ues: &[DVec3],
) -> Result<(TwinTraceRow, [f64; 4]), BenchError> {
    let objects = twin_objects(
        mesh.to_vec(),
        truth,
        &spec.known_objects,
        Material::Concrete,
    )
    .map_err(|e| BenchError::Input(e.to_string()))?;
    let t = Instant::now();
    let scene = Scene::new(objects)?;
    let scene_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let tracer = Tracer::new(&scene, config.clone())?;
    let facets_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let cand = tracer.prepare_tx(bs)?;
    let prepare_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let paths = ues
        .par_iter()
        .map(|&rx| tracer.trace(&cand, rx).map(|p| p.len()))
        .collect::<Result<Vec<_>, _>>()?;
    let trace_s = t.elapsed().as_secs_f64();
    let row = TwinTraceRow {
        mesh: name,
        triangles: scene.triangle_count(),
        facets: tracer.facets().facets.len(),
        candidates: cand.len(),
        paths: paths.iter().sum(),
        scene_s,
        facets_s,
        prepare_s,
        trace_s,
        total_s: 0.0,
    };
    Ok((row, [scene_s, facets_s, prepare_s, trace_s]))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Times the channel tracing of the scenario's `[channel]` experiment (`spec`, already with any
/// preset applied) on `twin` and on `poisson`, each `repeats` times in turn (module docs).
///
/// # Errors
/// [`BenchError::Input`] for `repeats` outside 1 … [`MAX_REPEATS`] or a `known_objects` name missing from the scene; the
/// scene, tracer and scenario errors of the channel experiment.
pub fn run(
    sc: &Scenario,
    spec: &ChannelSpec,
    twin: &[Object],
    poisson: &[Object],
    repeats: usize,
) -> Result<TwinTraceReport, BenchError> {
    if !(1..=MAX_REPEATS).contains(&repeats) {
        return Err(BenchError::Input(format!(
            "--repeats {repeats}: from 1 to {MAX_REPEATS}"
        )));
    }
    let input = |e: crate::scenario::ScenarioError| BenchError::Input(e.to_string());
    let fc = sc.radar.fc_hz_checked().map_err(input)?;
    let truth_objects = with_material(
        sc.scene
            .build_objects()
            .map_err(|e| BenchError::Input(e.to_string()))?,
        Material::Concrete,
    );
    let truth = Scene::new(truth_objects.clone())?;
    let ues = spec.ue_positions(&truth).map_err(input)?;
    let config = spec.tracer_config(fc, sc.range_resolution_m().map_err(input)?);
    let bs = spec.bs();
    let meshes: [(&'static str, &[Object]); 2] = [("planar twin", twin), ("Poisson mesh", poisson)];
    let mut rows: Vec<Option<TwinTraceRow>> = vec![None, None];
    let mut times: [Vec<[f64; 4]>; 2] = [Vec::new(), Vec::new()];
    for _ in 0..repeats {
        for (k, (name, mesh)) in meshes.iter().enumerate() {
            let (row, t) = one_pass(name, mesh, &truth_objects, spec, &config, bs, &ues)?;
            rows[k].get_or_insert(row);
            times[k].push(t);
        }
    }
    let finish = |k: usize| -> TwinTraceRow {
        let mut row = rows[k].clone().expect("one repeat at least");
        let stage = |i: usize| median(times[k].iter().map(|t| t[i]).collect());
        (row.scene_s, row.facets_s, row.prepare_s, row.trace_s) =
            (stage(0), stage(1), stage(2), stage(3));
        row.total_s = median(times[k].iter().map(|t| t.iter().sum()).collect());
        row
    };
    let (tw, pm) = (finish(0), finish(1));
    Ok(TwinTraceReport {
        ues: ues.len(),
        max_order: spec.max_order,
        repeats,
        threads: rayon::current_num_threads(),
        speedup_total: pm.total_s / tw.total_s,
        speedup_trace: pm.trace_s / tw.trace_s,
        rows: [tw, pm],
    })
}

impl TwinTraceReport {
    /// The report as a Markdown table.
    pub fn table(&self) -> String {
        let mut s = format!(
            "{} UEs, order {}, {} threads, median of {} repeats each (wall seconds)\n\n\
             | mesh | triangles | facets | candidates | paths | scene | facets | candidates | UEs | total |\n\
             |---|---|---|---|---|---|---|---|---|---|\n",
            self.ues, self.max_order, self.threads, self.repeats
        );
        for r in &self.rows {
            s += &format!(
                "| {} | {} | {} | {} | {} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} |\n",
                r.mesh,
                r.triangles,
                r.facets,
                r.candidates,
                r.paths,
                r.scene_s,
                r.facets_s,
                r.prepare_s,
                r.trace_s,
                r.total_s
            );
        }
        s += &format!(
            "\nPoisson mesh / planar twin: {:.1}× in total, {:.1}× tracing the UEs\n",
            self.speedup_total, self.speedup_trace
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_of_an_odd_and_an_even_count() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(Vec::new()).is_nan());
    }

    #[test]
    fn the_same_mesh_on_both_sides_gives_the_same_scene_and_paths() {
        let sc = Scenario::from_toml_str(include_str!("../../../fixtures/factory.toml"))
            .expect("bundled");
        let mut spec = sc.channel.clone().expect("channel table");
        spec.apply_quick();
        spec.ues = 20;
        // The true building as the twin: what the known objects leave out.
        let hall: Vec<Object> = sc
            .scene
            .build_objects()
            .expect("objects")
            .into_iter()
            .filter(|o| !spec.known_objects.contains(&o.name))
            .collect();
        assert!(!hall.is_empty());
        let r = run(&sc, &spec, &hall, &hall, 1).expect("bench");
        let [a, b] = &r.rows;
        assert_eq!(
            (a.triangles, a.facets, a.paths),
            (b.triangles, b.facets, b.paths)
        );
        assert!(a.paths > 0 && r.ues == 20 && r.repeats == 1);
        assert!(a.total_s > 0.0 && r.speedup_total.is_finite());
    }

    #[test]
    fn no_repeats_is_refused_naming_the_option() {
        let sc = Scenario::from_toml_str(include_str!("../../../fixtures/factory.toml"))
            .expect("bundled");
        let spec = sc.channel.clone().expect("channel table");
        let e = run(&sc, &spec, &[], &[], 0).unwrap_err();
        assert!(e.to_string().contains("--repeats 0"), "{e}");
    }
}
