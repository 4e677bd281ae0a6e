//! `has-sim channel [SCENARIO] --out DIR [--quick] [--twin MESH.obj]`: the paper's §2 — ray-trace
//! one BS to every UE on the true scene and on the digital twin (the reconstructed mesh, built by
//! `reconstruct` unless `--twin` gives one), match the multipath sets, and report error
//! percentiles, CDFs, the UE map and beam-selection agreement.
//!
//! The experiment is the scenario's `[channel]` table (`has_host::prediction::ChannelSpec`); the
//! comparison is `has_host::prediction::compare_ue` (matching in `has_host::multipath`, beams in
//! `has_host::beam`). Writes into DIR: `report.json` (key `channel`), `report.md`, `errors.csv`
//! (every matched pair), `ues.csv` (every UE), `cdf_delay.svg`, `cdf_angles.svg`, `ue_map.svg`, and `twin/` when the
//! twin is reconstructed here.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use glam::{DVec3, Vec3};
use has_host::beam::DftCodebook;
use has_host::imaging::ImagingScenario;
use has_host::io::obj::read_obj;
use has_host::multipath::{percentile, Match, ParamErrors, PathParams};
use has_host::paths::{Path as RayPath, Tracer, TracerConfig};
use has_host::prediction::{compare_ue, twin_objects, with_material, ChannelSpec, UeOutcome};
use has_host::{Material, Scene};
use indicatif::{ProgressBar, ProgressStyle};
use plotters::style::RGBColor;
use rayon::prelude::*;
use serde_json::{json, Value};

use crate::plot::{self, View};
use crate::reconstruct_cmd::{build_twin, load_scenario};

/// Options of `channel`.
#[derive(Args)]
pub struct ChannelArgs {
    /// Scenario file (TOML with a `[channel]` table). Default: the bundled fixtures/factory.toml.
    pub scenario: Option<PathBuf>,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// The quick preset: `[channel.quick]` overrides (fewer UEs, lower order, fewer rays), and a
    /// quick-preset twin when it is reconstructed here.
    #[arg(long)]
    pub quick: bool,
    /// The twin mesh (OBJ) to ray-trace; default: run `reconstruct` into DIR/twin first.
    #[arg(long)]
    pub twin: Option<PathBuf>,
}

/// The paper's 90th percentiles (§2, Fig. 9) and this project's goal, per parameter.
const PAPER_P90: [(&str, f64); 5] = [
    ("delay_ns", 3.5),
    ("aoa_deg", 3.0),
    ("aod_deg", 3.0),
    ("zoa_deg", 1.0),
    ("zod_deg", 1.0),
];
const GOAL_P90: [(&str, f64); 5] = [
    ("delay_ns", 1.0),
    ("aoa_deg", 1.0),
    ("aod_deg", 1.0),
    ("zoa_deg", 0.5),
    ("zod_deg", 0.5),
];
/// Report keys of the five parameters, in column order.
const KEYS: [&str; 5] = ["delay_ns", "aoa_deg", "aod_deg", "zoa_deg", "zod_deg"];
/// A matched pair farther than this (normalised units: ns / degrees) counts as "unmatched" in
/// the diagnostics: the path has no counterpart in the other model.
const UNMATCHED_DISTANCE: f64 = 5.0;

/// The five errors in report units (ns, degrees), in [`KEYS`] order.
fn in_units(e: &ParamErrors) -> [f64; 5] {
    [
        e.delay_s * 1e9,
        e.aoa.to_degrees(),
        e.aod.to_degrees(),
        e.zoa.to_degrees(),
        e.zod.to_degrees(),
    ]
}

fn load(args: &ChannelArgs) -> Result<(ImagingScenario, ChannelSpec, String)> {
    let (sc, name) = load_scenario(args.scenario.as_deref())?;
    let mut spec = sc
        .channel
        .clone()
        .with_context(|| format!("{name}: no [channel] table"))?;
    if args.quick {
        spec.apply_quick();
    }
    spec.validate()?;
    Ok((sc, spec, name))
}

/// Timings and counts of tracing one scene.
struct Traced {
    paths: Vec<Vec<RayPath>>,
    facets: usize,
    candidates: usize,
    prepare_s: f64,
    trace_s: f64,
}

fn trace_scene(
    label: &str,
    scene: &Scene,
    config: &TracerConfig,
    bs: DVec3,
    ues: &[DVec3],
) -> Result<Traced> {
    let tracer = Tracer::new(scene, config.clone())?;
    let t = Instant::now();
    let cand = tracer.prepare_tx(bs)?;
    let prepare_s = t.elapsed().as_secs_f64();
    let bar = ProgressBar::new(ues.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{prefix:>6} [{bar:40}] {pos}/{len} UEs {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_prefix(label.to_string());
    let t = Instant::now();
    let paths = ues
        .par_iter()
        .map(|&rx| {
            let r = tracer.trace(&cand, rx);
            bar.inc(1);
            r
        })
        .collect::<Result<Vec<_>, _>>()?;
    let trace_s = t.elapsed().as_secs_f64();
    bar.finish();
    Ok(Traced {
        paths,
        facets: tracer.facets().facets.len(),
        candidates: cand.len(),
        prepare_s,
        trace_s,
    })
}

/// p50/p90/p95 and mean of each parameter over `rows` (five values per row).
fn stats(rows: &[[f64; 5]]) -> Result<Value> {
    let mut out = json!({"count": rows.len()});
    for (q, key) in [(50.0, "p50"), (90.0, "p90"), (95.0, "p95")] {
        let mut m = serde_json::Map::new();
        for (k, name) in KEYS.iter().enumerate() {
            let v: Vec<f64> = rows.iter().map(|r| r[k]).collect();
            let x = if v.is_empty() {
                Value::Null
            } else {
                json!(percentile(&v, q)?)
            };
            m.insert(name.to_string(), x);
        }
        out[key] = Value::Object(m);
    }
    let mut m = serde_json::Map::new();
    for (k, name) in KEYS.iter().enumerate() {
        let n = rows.len().max(1) as f64;
        m.insert(
            name.to_string(),
            json!(rows.iter().map(|r| r[k]).sum::<f64>() / n),
        );
    }
    out["mean"] = Value::Object(m);
    Ok(out)
}

/// One line of errors.csv.
fn csv_line(
    ue: usize,
    dir: &str,
    m: &Match,
    src: &[PathParams],
    dst: &[PathParams],
    building: bool,
) -> String {
    let (a, b) = (&src[m.from], &dst[m.to]);
    let e = in_units(&m.errors);
    format!(
        "{ue},{dir},{},{},{},{:.3},{:.4},{},{},{:.4},{:.5},{:.5},{:.5},{:.5},{:.5}\n",
        m.from,
        a.order,
        u8::from(building),
        a.gain_db,
        a.delay_s * 1e9,
        m.to,
        b.order,
        m.distance,
        e[0],
        e[1],
        e[2],
        e[3],
        e[4]
    )
}

/// Runs the command.
pub fn run(args: ChannelArgs) -> Result<()> {
    let t0 = Instant::now();
    let (sc, spec, scenario_name) = load(&args)?;
    let run_dir = crate::run_dir::RunDir::start(
        &args.out,
        &[
            "report.json",
            "report.md",
            "errors.csv",
            "ues.csv",
            "cdf_delay.svg",
            "cdf_angles.svg",
            "ue_map.svg",
        ],
    )?;
    let fc = sc.radar.fc_hz_checked()?;

    let t = Instant::now();
    let twin_path = match &args.twin {
        Some(p) => p.clone(),
        None => build_twin(args.scenario.clone(), &args.out.join("twin"), args.quick)?,
    };
    let twin_s = t.elapsed().as_secs_f64();

    let truth_objects = with_material(sc.scene.build_objects()?, Material::Concrete);
    let mesh = read_obj(&twin_path, Some(Material::Concrete)).context("--twin")?;
    let twin_objs = twin_objects(
        mesh,
        &truth_objects,
        &spec.known_objects,
        Material::Concrete,
    )?;
    let truth = Scene::new(truth_objects)?;
    let twin = Scene::new(twin_objs).with_context(|| format!("twin {}", twin_path.display()))?;
    let ues = spec.ue_positions(&truth)?;
    let bs = spec.bs();
    let config = spec.tracer_config(fc, sc.range_resolution_m()?);
    let codebook = DftCodebook::new(
        spec.codebook_rows,
        spec.codebook_cols,
        spec.codebook_spacing_wl,
        spec.bs_boresight_deg.to_radians(),
    )?;

    let tr = trace_scene("true", &truth, &config, bs, &ues)?;
    let tw = trace_scene("twin", &twin, &config, bs, &ues)?;

    let t = Instant::now();
    let outcomes: Vec<UeOutcome> = tr
        .paths
        .par_iter()
        .zip(&tw.paths)
        .map(|(a, b)| compare_ue(&spec, &codebook, a, b))
        .collect::<Result<_, _>>()?;
    let analysis_s = t.elapsed().as_secs_f64();

    // Statistics.
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
    // A path "via the building" reflects at least once off an object that is not known (the
    // reconstructed part of the twin, the building of the true scene).
    let via_building = |p: &PathParams, known: &[bool]| {
        p.objects()
            .iter()
            .any(|&o| !known.get(o as usize).copied().unwrap_or(false))
    };
    let mut building = Vec::new();
    let mut building_matched = Vec::new();
    let mut all = Vec::new();
    let mut fwd = Vec::new();
    let mut bwd = Vec::new();
    let mut by_order: std::collections::BTreeMap<usize, Vec<[f64; 5]>> = Default::default();
    let mut csv = String::from(
        "ue,direction,path,order,via_building,gain_db,delay_ns,matched_path,matched_order,distance,delay_err_ns,aoa_err_deg,aod_err_deg,zoa_err_deg,zod_err_deg\n",
    );
    let (mut kept, mut twin_empty) = (0usize, 0usize);
    let (mut true_kept_paths, mut twin_kept_paths) = (0usize, 0usize);
    let (mut missing, mut spurious) = (0usize, 0usize);
    let mut missing_by_order: std::collections::BTreeMap<usize, (usize, usize)> =
        Default::default();
    let (mut beam_n, mut beam_agree, mut beam_1db) = (0usize, 0usize, 0usize);
    let mut beam_loss = Vec::new();
    for (i, o) in outcomes.iter().enumerate() {
        if !o.kept {
            continue;
        }
        kept += 1;
        true_kept_paths += o.true_paths.len();
        twin_kept_paths += o.twin_paths.len();
        if o.twin_paths.is_empty() {
            twin_empty += 1;
        }
        for m in &o.matches.forward {
            let e = in_units(&m.errors);
            all.push(e);
            fwd.push(e);
            let vb = via_building(&o.true_paths[m.from], &known_true);
            if vb {
                building.push(e);
                if m.distance <= UNMATCHED_DISTANCE {
                    building_matched.push(e);
                }
            }
            let order = o.true_paths[m.from].order;
            by_order.entry(order).or_default().push(e);
            let slot = missing_by_order.entry(order).or_default();
            slot.0 += 1;
            if m.distance > UNMATCHED_DISTANCE {
                missing += 1;
                slot.1 += 1;
            }
            csv.push_str(&csv_line(
                i,
                "true_to_twin",
                m,
                &o.true_paths,
                &o.twin_paths,
                vb,
            ));
        }
        for m in &o.matches.backward {
            let e = in_units(&m.errors);
            all.push(e);
            bwd.push(e);
            let vb = via_building(&o.twin_paths[m.from], &known_twin);
            if vb {
                building.push(e);
                if m.distance <= UNMATCHED_DISTANCE {
                    building_matched.push(e);
                }
            }
            if m.distance > UNMATCHED_DISTANCE {
                spurious += 1;
            }
            csv.push_str(&csv_line(
                i,
                "twin_to_true",
                m,
                &o.twin_paths,
                &o.true_paths,
                vb,
            ));
        }
        if let Some(b) = &o.beam {
            beam_n += 1;
            if b.agrees() {
                beam_agree += 1;
            }
            let loss = b.loss_db();
            if loss <= 1.0 {
                beam_1db += 1;
            }
            beam_loss.push(loss);
        }
    }
    // Twin UEs without any path lose everything: their loss is infinite, kept as such in the
    // percentiles (a percentile landing there reports null via non-finite JSON).
    let pct = |v: &[f64]| -> Value {
        if v.is_empty() {
            return Value::Null;
        }
        let finite: Vec<f64> = v.iter().map(|x| x.min(1e9)).collect();
        json!({
            "p50": percentile(&finite, 50.0).ok(),
            "p90": percentile(&finite, 90.0).ok(),
            "p95": percentile(&finite, 95.0).ok(),
        })
    };
    let n_true: usize = tr.paths.iter().map(Vec::len).sum();
    let n_twin: usize = tw.paths.iter().map(Vec::len).sum();
    let wall = t0.elapsed().as_secs_f64();
    let all_stats = stats(&all)?;
    let mut by_order_json = serde_json::Map::new();
    for (order, rows) in &by_order {
        let mut s = stats(rows)?;
        let (n, miss) = missing_by_order.get(order).copied().unwrap_or((0, 0));
        s["unmatched"] = json!(miss);
        s["unmatched_pct"] = json!(100.0 * miss as f64 / n.max(1) as f64);
        by_order_json.insert(order.to_string(), s);
    }
    let paper: serde_json::Map<String, Value> = PAPER_P90
        .iter()
        .map(|(k, v)| (k.to_string(), json!(v)))
        .collect();
    let goal: serde_json::Map<String, Value> = GOAL_P90
        .iter()
        .map(|(k, v)| (k.to_string(), json!(v)))
        .collect();
    let channel = json!({
        "scenario": scenario_name,
        "preset": if args.quick { "quick" } else { "default" },
        "twin_mesh": twin_path.display().to_string(),
        "fc_ghz": fc / 1e9,
        "material": "itu_concrete (every object of both scenes)",
        "bs_position": spec.bs_position,
        "bs_boresight_deg": spec.bs_boresight_deg,
        "ues": {
            "total": ues.len(),
            "kept": kept,
            "dropped": ues.len() - kept,
            "kept_without_twin_paths": twin_empty,
            "height_m": spec.ue_height_m,
            "region_min": spec.ue_region_min,
            "region_max": spec.ue_region_max,
            "seed": spec.seed,
        },
        "max_loss_db": spec.max_loss_db,
        "window_db": spec.window_db,
        "paths": {
            "true_total": n_true,
            "twin_total": n_twin,
            "true_kept": true_kept_paths,
            "twin_kept": twin_kept_paths,
            "matched_true_to_twin": fwd.len(),
            "matched_twin_to_true": bwd.len(),
            "unmatched_true": missing,
            "unmatched_twin": spurious,
            "unmatched_distance": UNMATCHED_DISTANCE,
        },
        "count": all.len(),
        "p50": all_stats["p50"],
        "p90": all_stats["p90"],
        "p95": all_stats["p95"],
        "mean": all_stats["mean"],
        "via_building": stats(&building)?,
        "via_building_matched": stats(&building_matched)?,
        "true_to_twin": stats(&fwd)?,
        "twin_to_true": stats(&bwd)?,
        "true_to_twin_by_order": by_order_json,
        "paper_p90": paper,
        "goal_p90": goal,
        "beam": {
            "codebook": format!(
                "{}x{} DFT, spacing {} λ, vertical panel facing azimuth {}°",
                spec.codebook_rows, spec.codebook_cols, spec.codebook_spacing_wl, spec.bs_boresight_deg
            ),
            "ues": beam_n,
            "agreement_pct": 100.0 * beam_agree as f64 / beam_n.max(1) as f64,
            "within_1db_pct": 100.0 * beam_1db as f64 / beam_n.max(1) as f64,
            "loss_db": pct(&beam_loss),
        },
        "tracer": {
            "max_order": spec.max_order,
            "sbr_rays": spec.sbr_rays,
            "facet_angle_deg": spec.facet_angle_deg,
            "facet_dist_m": spec.facet_dist_m,
            "los": true,
            "diffraction": false,
            "facets_true": tr.facets,
            "facets_twin": tw.facets,
            "candidates_true": tr.candidates,
            "candidates_twin": tw.candidates,
            "triangles_true": truth.triangle_count(),
            "triangles_twin": twin.triangle_count(),
        },
        "timings_s": {
            "wall": wall,
            "twin_reconstruction": twin_s,
            "prepare_true": tr.prepare_s,
            "trace_true": tr.trace_s,
            "prepare_twin": tw.prepare_s,
            "trace_twin": tw.trace_s,
            "analysis": analysis_s,
        },
        "paths_per_s": {
            "true": n_true as f64 / tr.trace_s.max(1e-9),
            "twin": n_twin as f64 / tw.trace_s.max(1e-9),
            "true_incl_prepare": n_true as f64 / (tr.trace_s + tr.prepare_s).max(1e-9),
            "twin_incl_prepare": n_twin as f64 / (tw.trace_s + tw.prepare_s).max(1e-9),
        },
        "threads": rayon::current_num_threads(),
        "conventions": {
            "matching": format!(
                "Chamfer-style: every kept true path paired with its nearest kept twin path and every kept twin path with its nearest kept true path (both directions pooled in p50/p90/p95); distance sqrt((Δτ/{} ns)² + Σ (Δangle/{}°)²) over AoA, AoD, ZoA, ZoD",
                spec.match_delay_ns, spec.match_angle_deg
            ),
            "angles": "azimuth from +x toward +y, zenith from +z; azimuth errors wrapped to [0°, 180°]",
            "percentile": "linear interpolation between order statistics (numpy default)",
            "kept": "UE kept if its strongest true path loses < max_loss_db; per UE and model, paths within window_db of that model's strongest",
            "beam": "best beam = argmax over the codebook of |Σ a_p w_bᴴ a(AoD_p, ZoD_p)|² (all paths, carrier phase, isotropic elements); predicted from the twin's paths, judged on the true channel",
            "twin": "reconstructed mesh + known_objects of the true scene",
            "via_building": "pairs whose source path reflects at least once off an object that is not in known_objects (line of sight and ground-only paths excluded)",
            "via_building_matched": "via_building pairs within the unmatched distance (the path has a counterpart in the other model)",
        },
    });
    let report = json!({ "channel": channel });

    // Outputs.
    let text = serde_json::to_string_pretty(&report)?;
    write_text(&args.out.join("report.json"), &text)?;
    write_text(&args.out.join("errors.csv"), &csv)?;
    write_text(&args.out.join("report.md"), &report_md(&report["channel"])?)?;
    write_text(&args.out.join("ues.csv"), &ues_csv(&ues, &outcomes))?;
    let col = |k: usize| -> Vec<f64> { all.iter().map(|r| r[k]).collect() };
    plot::cdf(
        &args.out.join("cdf_delay.svg"),
        "Delay error of matched paths (twin vs true scene)",
        "delay error (ns)",
        &[("delay", &col(0), RGBColor(200, 40, 40))],
        1.0,
    )?;
    plot::cdf(
        &args.out.join("cdf_angles.svg"),
        "Angle errors of matched paths (twin vs true scene)",
        "angle error (degrees)",
        &[
            ("AoA", &col(1), RGBColor(200, 40, 40)),
            ("AoD", &col(2), RGBColor(20, 70, 200)),
            ("ZoA", &col(3), RGBColor(30, 150, 60)),
            ("ZoD", &col(4), RGBColor(150, 60, 170)),
        ],
        1.0,
    )?;
    ue_map(
        &args.out.join("ue_map.svg"),
        &sc,
        &truth,
        &ues,
        &outcomes,
        bs,
    )?;

    let p90 = &report["channel"]["p90"];
    let g = |k: &str| p90[k].as_f64().unwrap_or(f64::NAN);
    println!(
        "channel: {} of {} UEs kept, {} true / {} twin paths in the window; p90 delay {:.2} ns, AoA {:.2}°, AoD {:.2}°, ZoA {:.2}°, ZoD {:.2}°  [paper: 3.5 ns, 3°, 3°, 1°, 1°]",
        kept,
        ues.len(),
        true_kept_paths,
        twin_kept_paths,
        g("delay_ns"),
        g("aoa_deg"),
        g("aod_deg"),
        g("zoa_deg"),
        g("zod_deg")
    );
    println!(
        "beam selection ({}×{} DFT): {:.1} % agree, {:.1} % within 1 dB; {:.0} paths/s; wall {:.1} s; report in {}",
        spec.codebook_rows,
        spec.codebook_cols,
        100.0 * beam_agree as f64 / beam_n.max(1) as f64,
        100.0 * beam_1db as f64 / beam_n.max(1) as f64,
        (n_true + n_twin) as f64 / (tr.trace_s + tw.trace_s).max(1e-9),
        wall,
        args.out.display()
    );
    run_dir.finish()
}

/// One line per UE: position, kept, strongest true path, windowed path counts, beams.
fn ues_csv(ues: &[DVec3], outcomes: &[UeOutcome]) -> String {
    let mut s = String::from(
        "ue,x,y,z,kept,strongest_true_db,true_paths,twin_paths,true_best_beam,predicted_beam,beam_loss_db\n",
    );
    for (i, (p, o)) in ues.iter().zip(outcomes).enumerate() {
        let opt = |v: Option<String>| v.unwrap_or_default();
        s.push_str(&format!(
            "{i},{:.3},{:.3},{:.3},{},{},{},{},{},{},{}\n",
            p.x,
            p.y,
            p.z,
            u8::from(o.kept),
            opt(o.strongest_true_db.map(|g| format!("{g:.3}"))),
            o.true_paths.len(),
            o.twin_paths.len(),
            opt(o.beam.map(|b| b.true_best.to_string())),
            opt(o.beam.and_then(|b| b.predicted).map(|b| b.to_string())),
            opt(o.beam.map(|b| format!("{:.3}", b.loss_db()))),
        ));
    }
    s
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    has_host::io::atomic_write(path, |w| std::io::Write::write_all(w, text.as_bytes()))
        .with_context(|| format!("writing {}", path.display()))
}

/// Top view: the buildings (surface samples of every object not in `known_objects`), kept and
/// dropped UEs, the BS.
fn ue_map(
    path: &Path,
    sc: &ImagingScenario,
    truth: &Scene,
    ues: &[DVec3],
    outcomes: &[UeOutcome],
    bs: DVec3,
) -> Result<()> {
    let known = sc
        .channel
        .as_ref()
        .map(|c| c.known_objects.clone())
        .unwrap_or_default();
    let tris: Vec<[Vec3; 3]> = truth
        .objects
        .iter()
        .filter(|o| !known.contains(&o.name))
        .flat_map(|o| o.triangles.iter().copied())
        .collect();
    let scene_pts = if tris.is_empty() {
        Vec::new()
    } else {
        has_host::metrics::sample_triangles(&tris, 2.0, 1)?
    };
    let (kept, dropped): (Vec<_>, Vec<_>) = ues.iter().zip(outcomes).partition(|(_, o)| o.kept);
    let kept: Vec<Vec3> = kept.iter().map(|(p, _)| p.as_vec3()).collect();
    let dropped: Vec<Vec3> = dropped.iter().map(|(p, _)| p.as_vec3()).collect();
    let bs = [bs.as_vec3()];
    plot::projection(
        path,
        "UEs kept (red: strongest path < max loss) and dropped (blue), BS (black), buildings (grey), top view",
        View::Top,
        &[
            ("buildings", &scene_pts, RGBColor(170, 170, 170), 1),
            ("kept UEs", &kept, RGBColor(200, 40, 40), 3),
            ("dropped UEs", &dropped, RGBColor(20, 70, 200), 3),
            ("BS", &bs, RGBColor(0, 0, 0), 7),
        ],
    )
}

fn report_md(c: &Value) -> Result<String> {
    use std::fmt::Write;
    let mut s = String::new();
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    writeln!(
        s,
        "# has-sim channel — {}\n",
        c["scenario"].as_str().unwrap_or("")
    )?;
    writeln!(
        s,
        "Preset `{}`, twin `{}`, fc {} GHz, all objects concrete; BS at {}, {} UEs of which {} kept (strongest true path loses < {} dB), paths within {} dB of each UE's strongest.\n",
        c["preset"].as_str().unwrap_or(""),
        c["twin_mesh"].as_str().unwrap_or(""),
        c["fc_ghz"],
        c["bs_position"],
        c["ues"]["total"],
        c["ues"]["kept"],
        c["max_loss_db"],
        c["window_db"]
    )?;
    writeln!(
        s,
        "| error of matched paths | p50 | p90 | p95 | paper p90 | goal p90 |"
    )?;
    writeln!(s, "|---|---|---|---|---|---|")?;
    for (k, label) in KEYS
        .iter()
        .zip(["delay (ns)", "AoA (°)", "AoD (°)", "ZoA (°)", "ZoD (°)"])
    {
        writeln!(
            s,
            "| {label} | {:.3} | {:.3} | {:.3} | {} | {} |",
            f(&c["p50"][k]),
            f(&c["p90"][k]),
            f(&c["p95"][k]),
            c["paper_p90"][k],
            c["goal_p90"][k]
        )?;
    }
    let p = &c["paths"];
    writeln!(
        s,
        "\n{} matched pairs ({} true→twin, {} twin→true). Paths in the window: {} true, {} twin (of {} / {} traced). Unmatched (distance > {}): {} true paths without a twin counterpart, {} twin paths without a true one.",
        c["count"], p["matched_true_to_twin"], p["matched_twin_to_true"], p["true_kept"], p["twin_kept"], p["true_total"], p["twin_total"], p["unmatched_distance"], p["unmatched_true"], p["unmatched_twin"]
    )?;
    writeln!(
        s,
        "\n| true→twin by order of the true path | pairs | unmatched % | p90 delay (ns) | p90 AoA (°) | p90 AoD (°) | p90 ZoA (°) | p90 ZoD (°) |"
    )?;
    writeln!(s, "|---|---|---|---|---|---|---|---|")?;
    if let Some(m) = c["true_to_twin_by_order"].as_object() {
        for (order, st) in m {
            writeln!(
                s,
                "| {order} | {} | {:.1} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
                st["count"],
                f(&st["unmatched_pct"]),
                f(&st["p90"]["delay_ns"]),
                f(&st["p90"]["aoa_deg"]),
                f(&st["p90"]["aod_deg"]),
                f(&st["p90"]["zoa_deg"]),
                f(&st["p90"]["zod_deg"])
            )?;
        }
    }
    let vb = &c["via_building"];
    writeln!(
        s,
        "\nPairs whose source path reflects off the building (not only the known ground): {}; p50 / p90 / p95 delay {:.3} / {:.3} / {:.3} ns, AoA {:.2} / {:.2} / {:.2}°, AoD {:.2} / {:.2} / {:.2}°, ZoA {:.2} / {:.2} / {:.2}°, ZoD {:.2} / {:.2} / {:.2}°.",
        vb["count"],
        f(&vb["p50"]["delay_ns"]), f(&vb["p90"]["delay_ns"]), f(&vb["p95"]["delay_ns"]),
        f(&vb["p50"]["aoa_deg"]), f(&vb["p90"]["aoa_deg"]), f(&vb["p95"]["aoa_deg"]),
        f(&vb["p50"]["aod_deg"]), f(&vb["p90"]["aod_deg"]), f(&vb["p95"]["aod_deg"]),
        f(&vb["p50"]["zoa_deg"]), f(&vb["p90"]["zoa_deg"]), f(&vb["p95"]["zoa_deg"]),
        f(&vb["p50"]["zod_deg"]), f(&vb["p90"]["zod_deg"]), f(&vb["p95"]["zod_deg"]),
    )?;
    let vm = &c["via_building_matched"];
    writeln!(
        s,
        "Of those, {} have a counterpart within distance {}: p90 delay {:.3} ns, AoA {:.2}°, AoD {:.2}°, ZoA {:.2}°, ZoD {:.2}°.",
        vm["count"],
        c["paths"]["unmatched_distance"],
        f(&vm["p90"]["delay_ns"]),
        f(&vm["p90"]["aoa_deg"]),
        f(&vm["p90"]["aod_deg"]),
        f(&vm["p90"]["zoa_deg"]),
        f(&vm["p90"]["zod_deg"]),
    )?;
    let b = &c["beam"];
    writeln!(
        s,
        "\nBeam selection ({}): the beam picked from the twin's paths is the true best beam for {:.1} % of {} kept UEs, within 1 dB of it for {:.1} %; loss p50 {:.2} dB, p90 {:.2} dB.",
        b["codebook"].as_str().unwrap_or(""),
        f(&b["agreement_pct"]),
        b["ues"],
        f(&b["within_1db_pct"]),
        f(&b["loss_db"]["p50"]),
        f(&b["loss_db"]["p90"])
    )?;
    let t = &c["timings_s"];
    let tr = &c["tracer"];
    writeln!(
        s,
        "\nTracer: order {}, {} SBR rays, line of sight and specular reflections (no diffraction); {} / {} facets and {} / {} candidate sequences (true / twin). Wall {:.1} s (twin reconstruction {:.1} s, tracing {:.1} + {:.1} s), {:.0} / {:.0} paths/s (true / twin) on {} threads.",
        tr["max_order"], tr["sbr_rays"], tr["facets_true"], tr["facets_twin"], tr["candidates_true"], tr["candidates_twin"],
        f(&t["wall"]), f(&t["twin_reconstruction"]), f(&t["prepare_true"]) + f(&t["trace_true"]), f(&t["prepare_twin"]) + f(&t["trace_twin"]),
        f(&c["paths_per_s"]["true"]), f(&c["paths_per_s"]["twin"]), c["threads"]
    )?;
    let cv = &c["conventions"];
    writeln!(
        s,
        "\nConventions: {}; {}; percentiles: {}; {}.",
        cv["matching"].as_str().unwrap_or(""),
        cv["angles"].as_str().unwrap_or(""),
        cv["percentile"].as_str().unwrap_or(""),
        cv["beam"].as_str().unwrap_or("")
    )?;
    Ok(s)
}
