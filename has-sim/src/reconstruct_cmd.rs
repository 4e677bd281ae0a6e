//! `has-sim reconstruct [SCENARIO] --out DIR`: the paper's §1 end to end — imaging of every
//! base station–terminal pair through has-dsp, fusion, and the point-cloud metrics; writes
//! `report.json`, `report.md`, PLY clouds and SVG plots into DIR.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use glam::Vec3;
use has_host::imaging::{self, ImagingScenario, RunOptions};
use has_host::io::{ply::write_ply, PlyData, PlyFormat};
use has_host::metrics::{CloudComparison, REPORT_THRESHOLDS_M};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use plotters::style::RGBColor;
use serde_json::json;

use crate::plot::{self, View};

/// The bundled default scenario.
pub const FACTORY_TOML: &str = include_str!("../../fixtures/factory.toml");

/// Options of `reconstruct`.
#[derive(Args)]
pub struct ReconstructArgs {
    /// Scenario file (TOML, see docs/scenario.md). Default: the bundled fixtures/factory.toml.
    pub scenario: Option<PathBuf>,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// The quick preset (the scenario's `[quick]` overrides): coarser voxels, thinned arrays and
    /// apertures; for CI.
    #[arg(long)]
    pub quick: bool,
    /// Q15 profiles and the fixed-point back-projection path.
    #[arg(long)]
    pub fixed_point: bool,
    /// Synthesize raw OFDM subcarriers and range-compress them with has-dsp (slower).
    #[arg(long)]
    pub raw_ofdm: bool,
    /// Poisson grid depth of the surface reconstruction (finest cell = 1.2 × largest extent /
    /// 2^depth). Default: a finest cell of half the imaging voxel, whatever the cloud's extent.
    #[arg(long)]
    pub mesh_depth: Option<u32>,
    /// Density trim of the mesh, fraction of the median vertex support density.
    #[arg(long, default_value_t = imaging::surface::DEFAULT_TRIM_MEDIAN)]
    pub mesh_trim_median: f32,
    /// Before meshing, remove the fused points that a coarser first-pass surface hides from every
    /// sensor that observed them (ghosts; has_host::mesh::visibility). Off by default: on the
    /// bundled factory it helped the quick preset (mesh √CD 1.009 → 0.980 m) but hurt the
    /// default one (0.837 → 0.868 m), removing real roof points along with the ghosts.
    #[arg(long)]
    pub visibility_filter: bool,
    /// Skip surface reconstruction.
    #[arg(long)]
    pub no_mesh: bool,
}

impl ReconstructArgs {
    /// Every option at its command-line default: `reconstruct [SCENARIO] --out OUT [--quick]`.
    pub fn defaults(scenario: Option<PathBuf>, out: &Path, quick: bool) -> Self {
        Self {
            scenario,
            out: out.to_path_buf(),
            quick,
            fixed_point: false,
            raw_ofdm: false,
            mesh_depth: None,
            mesh_trim_median: imaging::surface::DEFAULT_TRIM_MEDIAN,
            visibility_filter: false,
            no_mesh: false,
        }
    }
}

/// Loads the scenario file at `path`, or the bundled factory without one; returns it with the
/// name reports show.
pub fn load_scenario(path: Option<&Path>) -> Result<(ImagingScenario, String)> {
    Ok(match path {
        Some(p) => (ImagingScenario::load(p)?, p.display().to_string()),
        None => (
            ImagingScenario::from_toml_str(FACTORY_TOML)
                .context("bundled fixtures/factory.toml")?,
            "fixtures/factory.toml (bundled)".to_string(),
        ),
    })
}

fn load(args: &ReconstructArgs) -> Result<(ImagingScenario, String)> {
    let (mut sc, name) = load_scenario(args.scenario.as_deref())?;
    if args.quick {
        sc.apply_quick();
        sc.validate()?;
    }
    Ok((sc, name))
}

fn write_cloud(path: &Path, points: &[Vec3], props: Vec<(&str, Vec<f32>)>) -> Result<()> {
    let mut d = PlyData::from_points(points.to_vec());
    for (n, v) in props {
        d = d.with_property(n, v);
    }
    write_ply(path, &d, PlyFormat::BinaryLittleEndian)
        .with_context(|| format!("writing {}", path.display()))
}

fn metrics_json(c: &CloudComparison, n_points: usize, n_truth: usize) -> Result<serde_json::Value> {
    let mut v = json!({
        "sqrt_chamfer_m": c.sqrt_chamfer_m(),
        "rms_to_truth_m": c.rms_s1_to_s2_m(),
        "rms_from_truth_m": c.rms_s2_to_s1_m(),
        "points": n_points,
        "truth_points": n_truth,
    });
    for d in REPORT_THRESHOLDS_M {
        let f = c.fscore(d)?;
        let key = format!("{d:.1}").replace('.', "_");
        v[format!("fscore_{key}m")] = json!(f.fscore_pct);
        v[format!("precision_{key}m")] = json!(f.precision_pct);
        v[format!("recall_{key}m")] = json!(f.recall_pct);
    }
    Ok(v)
}

/// Completeness on the observable and the hidden part of the truth ([`imaging::observable_truth`]):
/// rms distance to the reconstruction and recall at 1.5 m of each part.
fn observable_json(c: &CloudComparison, observable: &[bool]) -> serde_json::Value {
    let hidden: Vec<bool> = observable.iter().map(|&o| !o).collect();
    let part = |keep: &[bool]| match c.completeness_on(keep, 1.5) {
        Some((rms, recall)) => json!({"rms_from_truth_m": rms, "recall_1_5m": recall}),
        None => json!(null),
    };
    json!({"observable": part(observable), "hidden": part(&hidden)})
}

/// Surface reconstruction of the fused cloud (normals oriented toward the sensors that observed
/// each point, screened Poisson, density trim), its metrics against the same ground truth, and
/// `mesh.obj`, `mesh.ply`, `mesh_top.svg`, `mesh_side.svg`.
fn mesh_stage(
    args: &ReconstructArgs,
    sc: &ImagingScenario,
    world: &imaging::World,
    result: &imaging::RunResult,
    observable: &[bool],
) -> Result<serde_json::Value> {
    let opts = imaging::SurfaceOptions {
        depth: args.mesh_depth,
        trim_median: args.mesh_trim_median,
        visibility_filter: args.visibility_filter,
    };
    let surf = imaging::surface(sc, result, &opts).context("surface reconstruction")?;
    let (points, weights, seconds) = (&surf.points, &surf.weights, surf.seconds);
    // The oriented and weighted input of the mesher, so that `has-sim mesh mesh_input.ply`
    // reproduces (and can vary) this stage without rerunning the imaging.
    let n = &surf.normals;
    write_cloud(
        &args.out.join("mesh_input.ply"),
        points,
        vec![
            ("nx", n.iter().map(|v| v.x).collect()),
            ("ny", n.iter().map(|v| v.y).collect()),
            ("nz", n.iter().map(|v| v.z).collect()),
            ("intensity", weights.clone()),
        ],
    )?;
    let density = sc.imaging.truth_density_per_m2;
    let samples = surf.mesh.sample(density, sc.imaging.seed.wrapping_add(3))?;
    let cmp = CloudComparison::new(&samples, &world.truth)?;
    let mut m = metrics_json(&cmp, samples.len(), world.truth.len())?;
    m["observable_truth"] = observable_json(&cmp, observable);
    // False surface (area-weighted share farther than 1.5 m from the truth) and area against
    // the truth's: what Chamfer and F-score average away (a sheet over the ground, ghost walls).
    let area = has_host::metrics::surface_area_metrics(
        &samples,
        surf.mesh.area_m2(),
        &world.truth,
        &world.truth_triangles,
        1.5,
    )?;
    m["false_surface_pct_1_5m"] = json!(area.false_surface_pct);
    m["area_ratio"] = json!(area.area_ratio);
    m["area_m2"] = json!(area.area_m2);
    m["truth_area_m2"] = json!(area.truth_area_m2);
    let topo = surf.mesh.topology();
    m["vertices"] = json!(surf.mesh.vertices.len());
    m["faces"] = json!(surf.mesh.faces.len());
    m["watertight"] = json!(topo.watertight);
    m["manifold"] = json!(topo.manifold);
    m["depth"] = json!(surf.depth);
    m["cell_m"] = json!(surf.cell_m);
    m["clip_box"] = json!([surf.clip_box.0.to_array(), surf.clip_box.1.to_array()]);
    m["support_distance_m"] = json!(Some(surf.support_distance_m));
    m["min_component_fraction"] = json!(imaging::surface::MIN_COMPONENT_FRACTION);
    m["visibility_filter"] = json!(surf.visibility);
    m["facing_away_points"] = json!(surf.facing_away);
    m["trim_median_fraction"] = json!(args.mesh_trim_median);
    m["sample_weights"] = json!("intensity");
    m["sample_density_per_m2"] = json!(density);
    m["seconds"] = json!(seconds);
    crate::mesh_cmd::write_mesh(
        &surf.mesh,
        &args.out.join("mesh.obj"),
        Some(&args.out.join("mesh.ply")),
        None,
    )?;
    let grey = RGBColor(170, 170, 170);
    let red = RGBColor(200, 40, 40);
    for (file, view, title) in [
        ("mesh_top.svg", View::Top, "Reconstructed mesh, area samples (red), over the true surfaces (grey), top view"),
        ("mesh_side.svg", View::Side, "Reconstructed mesh, area samples (red), over the true surfaces (grey), side view from −y"),
    ] {
        plot::projection(
            &args.out.join(file),
            title,
            view,
            &[("ground truth", &world.truth, grey, 1), ("mesh", &samples, red, 1)],
        )?;
    }
    println!(
        "mesh: {} vertices, {} faces, √CD {:.3} m, F-score(1.5 m) {:.1}  [paper: 0.96 m, 96]",
        surf.mesh.vertices.len(),
        surf.mesh.faces.len(),
        cmp.sqrt_chamfer_m(),
        cmp.fscore(1.5)?.fscore_pct
    );
    Ok(m)
}

/// Runs `reconstruct` on `scenario` (default: the bundled factory), with the quick preset if
/// `quick`, writing everything into `out`, and returns the path of the mesh it wrote
/// (`out/mesh.obj`): the digital twin that `channel` and `localize` ray-trace when no mesh is given.
pub fn build_twin(scenario: Option<PathBuf>, out: &Path, quick: bool) -> Result<PathBuf> {
    run(ReconstructArgs::defaults(scenario, out, quick))
        .context("reconstructing the digital twin")?;
    Ok(out.join("mesh.obj"))
}

/// Checks the options that only the later stages use, so that a bad value fails before the
/// imaging rather than after it.
fn check_args(args: &ReconstructArgs) -> Result<()> {
    if !(args.mesh_trim_median > 0.0 && args.mesh_trim_median <= 1.0) {
        anyhow::bail!(
            "--mesh-trim-median: {} is not a fraction in (0, 1]",
            args.mesh_trim_median
        );
    }
    if let Some(d) = args.mesh_depth {
        if !(1..=10).contains(&d) {
            anyhow::bail!("--mesh-depth: {d} is not in 1..=10");
        }
    }
    Ok(())
}

/// The files `reconstruct` writes into its output directory ([`crate::run_dir`]).
pub const OUTPUTS: [&str; 12] = [
    "report.json",
    "report.md",
    "fused.ply",
    "pair_*.ply",
    "ground_truth.ply",
    "mesh.obj",
    "mesh.ply",
    "mesh_input.ply",
    "fused_top.svg",
    "fused_side.svg",
    "mesh_top.svg",
    "mesh_side.svg",
];

/// Runs the command.
pub fn run(args: ReconstructArgs) -> Result<()> {
    let t0 = Instant::now();
    check_args(&args)?;
    let (sc, scenario_name) = load(&args)?;
    let run_dir = crate::run_dir::RunDir::start(&args.out, &OUTPUTS)?;
    let world = imaging::build_world(&sc)?;
    let plans = imaging::plan_pairs(&sc)?;
    let t_setup = t0.elapsed().as_secs_f64();

    let multi = MultiProgress::new();
    let bars: Vec<ProgressBar> = plans
        .iter()
        .map(|p| {
            let b = multi.add(ProgressBar::new(1));
            b.set_style(
                ProgressStyle::with_template("{prefix:>8} [{bar:40}] {pos}/{len} frames {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            b.set_prefix(p.name.clone());
            b
        })
        .collect();
    let opts = RunOptions {
        fixed_point: args.fixed_point,
        raw_ofdm: args.raw_ofdm,
    };
    let t1 = Instant::now();
    let result = imaging::run_imaging(&sc, &world, plans, opts, &|k, d, t| {
        bars[k].set_length(t);
        bars[k].set_position(d);
    })?;
    for b in &bars {
        b.finish();
    }
    let t_imaging = t1.elapsed().as_secs_f64();

    let t2 = Instant::now();
    let fused = &result.fused;
    let cmp = CloudComparison::new(&fused.points, &world.truth)?;
    let mut fused_metrics = metrics_json(&cmp, fused.points.len(), world.truth.len())?;
    let observable = imaging::observable_truth(&sc, &world, &result.plans);
    let observable_pct = imaging::share_pct(&observable);
    fused_metrics["observable_truth"] = observable_json(&cmp, &observable);
    fused_metrics["unconfirmed_removed"] = json!(fused.unconfirmed);
    let any_pairing_pct = imaging::share_pct(&imaging::observable_truth(
        &sc,
        &world,
        &imaging::every_pairing(&sc),
    ));
    let mut pairs_json = Vec::new();
    let mut total_bp = 0.0;
    let region_centre = {
        let (lo, hi) = sc.region();
        (lo + hi) * 0.5
    };
    let mut total_bp_s = 0.0;
    for (k, (p, img)) in result.plans.iter().zip(&result.images).enumerate() {
        total_bp += img.stats.backprojections;
        total_bp_s += img.stats.bp_s;
        let pm = if img.points.is_empty() {
            json!(null)
        } else {
            metrics_json(
                &CloudComparison::new(&img.points, &world.truth)?,
                img.points.len(),
                world.truth.len(),
            )?
        };
        pairs_json.push(json!({
            "name": p.name,
            "base_station": sc.base_stations[p.bs].name,
            "aperture": sc.apertures[p.aperture].name,
            "aperture_positions": p.positions,
            "resolution_cell_m": imaging::resolution_cell_m(&sc, p.bs, p.aperture, p.positions, region_centre),
            "fusion_factor": fused.pair_factor[k],
            "points": img.points.len(),
            "metrics_against_whole_truth": pm,
            "stats": img.stats,
        }));
        write_cloud(
            &args.out.join(format!("pair_{}.ply", p.name)),
            &img.points,
            vec![("intensity", img.intensity.clone())],
        )?;
    }
    write_cloud(
        &args.out.join("fused.ply"),
        &fused.points,
        vec![
            ("intensity", fused.intensity.clone()),
            ("weight", fused.weight.clone()),
            ("pairs", fused.pairs.iter().map(|&n| n as f32).collect()),
        ],
    )?;
    write_cloud(&args.out.join("ground_truth.ply"), &world.truth, vec![])?;
    let grey = RGBColor(170, 170, 170);
    let blue = RGBColor(20, 70, 200);
    for (file, view, title) in [
        (
            "fused_top.svg",
            View::Top,
            "Fused imaging point cloud (blue) over the true surfaces (grey), top view",
        ),
        (
            "fused_side.svg",
            View::Side,
            "Fused imaging point cloud (blue) over the true surfaces (grey), side view from −y",
        ),
    ] {
        plot::projection(
            &args.out.join(file),
            title,
            view,
            &[
                ("ground truth", &world.truth, grey, 1),
                ("fused cloud", &fused.points, blue, 2),
            ],
        )?;
    }
    let t_post = t2.elapsed().as_secs_f64();

    let mesh_json = if args.no_mesh {
        json!(null)
    } else {
        mesh_stage(&args, &sc, &world, &result, &observable)?
    };
    let wall = t0.elapsed().as_secs_f64();

    let report = json!({
        "scenario": scenario_name,
        "preset": if args.quick { "quick" } else { "default" },
        "path": if args.fixed_point { "fixed_point_q15" } else { "f32" },
        "echo": if args.raw_ofdm { "raw_ofdm_range_compressed_by_has_dsp" } else { "direct_range_compressed_profiles" },
        "imaging": {
            "point_cloud": fused_metrics,
            "voxel_m": sc.imaging.voxel_m,
            "pairs": pairs_json,
            "scatterers": world.scatterers.len(),
            "ground_truth": {
                "objects": sc.imaging.truth_objects,
                "density_per_m2": sc.imaging.truth_density_per_m2,
                "surfaces": "every face of the truth objects not facing down (walls and roof)",
                "observable_pct": observable_pct,
                "observable": "truth points in line of sight of some imaged pair's panel and aperture (imaging::observable_truth)",
                "observable_any_pairing_pct": any_pairing_pct,
                "observable_any_pairing": "the same for every base station–aperture combination of the scenario (imaging::every_pairing): the ceiling of the pairing choice",
            },
        },
        "mesh": mesh_json,
        "conventions": {
            "chamfer": "eq. 2: mean over S1 of min squared distance to S2 plus mean over S2 of min squared distance to S1; reported as sqrt (m)",
            "fscore": "eq. 3: 2PR/(P+R), P = % of S1 within d of S2, R = % of S2 within d of S1 (strict <)",
            "s1": "fused imaging point cloud (voxel positions)",
            "s2": "ground-truth samples on the true building surfaces",
        },
        "timings_s": {
            "wall": wall,
            "setup": t_setup,
            "imaging": t_imaging,
            "backprojection": total_bp_s,
            "postprocess": t_post,
        },
        "peak_rss_mib": crate::resources::peak_rss_mib(),
        "backprojections": total_bp,
        "backprojections_per_s": total_bp / total_bp_s.max(1e-9),
        "threads": rayon::current_num_threads(),
    });
    let text = serde_json::to_string_pretty(&report)?;
    has_host::io::atomic_write(&args.out.join("report.json"), |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })?;
    let md = report_md(&report, &cmp)?;
    has_host::io::atomic_write(&args.out.join("report.md"), |w| {
        std::io::Write::write_all(w, md.as_bytes())
    })?;
    let f15 = cmp.fscore(1.5)?;
    println!(
        "fused point cloud: {} points, √CD {:.3} m, F-score(1.5 m) {:.1}  [paper: 1.18 m, 94]",
        fused.points.len(),
        cmp.sqrt_chamfer_m(),
        f15.fscore_pct
    );
    println!(
        "{} pairs, {:.3e} backprojections at {:.3e}/s; wall {:.1} s; report in {}",
        result.plans.len(),
        total_bp,
        total_bp / total_bp_s.max(1e-9),
        wall,
        args.out.display()
    );
    run_dir.finish()
}

fn report_md(r: &serde_json::Value, cmp: &CloudComparison) -> Result<String> {
    use std::fmt::Write;
    let mut s = String::new();
    let pc = &r["imaging"]["point_cloud"];
    writeln!(
        s,
        "# has-sim reconstruct — {}",
        r["scenario"].as_str().unwrap_or("")
    )?;
    writeln!(
        s,
        "\nPreset `{}`, back-projection path `{}`, echoes `{}`, voxel {} m.\n",
        r["preset"].as_str().unwrap_or(""),
        r["path"].as_str().unwrap_or(""),
        r["echo"].as_str().unwrap_or(""),
        r["imaging"]["voxel_m"]
    )?;
    writeln!(s, "| imaging point cloud | this run | paper (Table 1) |")?;
    writeln!(s, "|---|---|---|")?;
    writeln!(
        s,
        "| √Chamfer distance | {:.3} m | 1.18 m |",
        cmp.sqrt_chamfer_m()
    )?;
    for d in REPORT_THRESHOLDS_M {
        let f = cmp.fscore(d)?;
        let paper = if d == 1.5 { "94" } else { "—" };
        writeln!(
            s,
            "| F-score (d = {d} m) | {:.1} (P {:.1}, R {:.1}) | {paper} |",
            f.fscore_pct, f.precision_pct, f.recall_pct
        )?;
    }
    writeln!(
        s,
        "| points | {} ({} unconfirmed by the pairs that see them removed) | — |",
        pc["points"], pc["unconfirmed_removed"]
    )?;
    let m = &r["mesh"];
    if !m.is_null() {
        writeln!(s, "\n| reconstructed mesh | this run | paper (Table 1) |")?;
        writeln!(s, "|---|---|---|")?;
        let g = |k: &str| m[k].as_f64().unwrap_or(f64::NAN);
        writeln!(
            s,
            "| √Chamfer distance | {:.3} m | 0.96 m |",
            g("sqrt_chamfer_m")
        )?;
        for (key, paper) in [("0_5", "—"), ("1_0", "—"), ("1_5", "96")] {
            writeln!(
                s,
                "| F-score (d = {} m) | {:.1} (P {:.1}, R {:.1}) | {paper} |",
                key.replace('_', "."),
                g(&format!("fscore_{key}m")),
                g(&format!("precision_{key}m")),
                g(&format!("recall_{key}m"))
            )?;
        }
        writeln!(
            s,
            "| rms distance to / from the truth | {:.3} / {:.3} m (cloud {:.3} / {:.3} m) | — |",
            g("rms_to_truth_m"),
            g("rms_from_truth_m"),
            pc["rms_to_truth_m"].as_f64().unwrap_or(f64::NAN),
            pc["rms_from_truth_m"].as_f64().unwrap_or(f64::NAN)
        )?;
        writeln!(
            s,
            "| false surface (area > 1.5 m from the truth) / area against the truth's | {:.1} % / {:.2} ({:.0} of {:.0} m²) | — |",
            g("false_surface_pct_1_5m"),
            g("area_ratio"),
            g("area_m2"),
            g("truth_area_m2")
        )?;
        writeln!(
            s,
            "| vertices / faces | {} / {} (watertight: {}) | — |",
            m["vertices"], m["faces"], m["watertight"]
        )?;
        writeln!(
            s,
            "\nMesh: screened Poisson depth {} (cell {:.3} m), trimmed below {:.2} × the median support density, clipped to the imaging region and to {:.2} m (half the coarsest pair resolution cell) of the fused points, components under {:.2} of the largest area dropped; {:.1} s. Sampled at {} points per m² for the metrics.",
            m["depth"],
            g("cell_m"),
            g("trim_median_fraction"),
            g("support_distance_m"),
            g("min_component_fraction"),
            g("seconds"),
            m["sample_density_per_m2"]
        )?;
    }
    if !m.is_null() {
        let v = &m["visibility_filter"];
        if !v.is_null() {
            writeln!(
                s,
                "Visibility consistency: {} of {} fused points were hidden by a first-pass surface from every sensor that observed them (margin {} m) and were left out of the mesh.",
                v["removed_points"], v["input_points"], v["margin_m"]
            )?;
        }
    }
    let obs = |v: &serde_json::Value, part: &str| {
        let p = &v["observable_truth"][part];
        match (p["rms_from_truth_m"].as_f64(), p["recall_1_5m"].as_f64()) {
            (Some(rms), Some(recall)) => format!("{rms:.3} m / {recall:.1} %"),
            _ => "— (no such truth points)".to_string(),
        }
    };
    writeln!(
        s,
        "\n{:.1} % of the ground truth is in line of sight of some imaged pair (both legs), {:.1} % of some pairing of the scenario's base stations and apertures; the rest can only be inferred. Completeness (rms distance from the truth / recall at 1.5 m): observable part — cloud {}, mesh {}; hidden part — cloud {}, mesh {}.",
        r["imaging"]["ground_truth"]["observable_pct"]
            .as_f64()
            .unwrap_or(f64::NAN),
        r["imaging"]["ground_truth"]["observable_any_pairing_pct"]
            .as_f64()
            .unwrap_or(f64::NAN),
        obs(pc, "observable"),
        obs(m, "observable"),
        obs(pc, "hidden"),
        obs(m, "hidden"),
    )?;
    writeln!(s, "\n## Pairs\n")?;
    writeln!(
        s,
        "| pair | positions × elements | resolution cell m | points | fine voxels | BP s | synth s |"
    )?;
    writeln!(s, "|---|---|---|---|---|---|---|")?;
    for p in r["imaging"]["pairs"].as_array().into_iter().flatten() {
        let st = &p["stats"];
        writeln!(
            s,
            "| {} | {} × {} | {:.2} | {} | {} / {} | {:.1} | {:.1} |",
            p["name"].as_str().unwrap_or(""),
            st["frames"],
            st["elements"],
            p["resolution_cell_m"].as_f64().unwrap_or(f64::NAN),
            p["points"],
            st["fine_voxels"],
            st["region_voxels"],
            st["bp_s"].as_f64().unwrap_or(0.0),
            st["synth_s"].as_f64().unwrap_or(0.0),
        )?;
    }
    let t = &r["timings_s"];
    writeln!(
        s,
        "\nWall {:.1} s (imaging {:.1} s, of which back-projection {:.1} s); {:.3e} backprojections at {:.3e}/s on {} threads.",
        t["wall"].as_f64().unwrap_or(0.0),
        t["imaging"].as_f64().unwrap_or(0.0),
        t["backprojection"].as_f64().unwrap_or(0.0),
        r["backprojections"].as_f64().unwrap_or(0.0),
        r["backprojections_per_s"].as_f64().unwrap_or(0.0),
        r["threads"]
    )?;
    if let Some(p) = r["peak_rss_mib"].as_f64() {
        writeln!(s, "Peak resident memory {p:.0} MiB.")?;
    }
    writeln!(
        s,
        "\nGround truth: {} points at {} per m² on {}. Conventions: {}; {}.",
        pc["truth_points"],
        r["imaging"]["ground_truth"]["density_per_m2"],
        r["imaging"]["ground_truth"]["surfaces"]
            .as_str()
            .unwrap_or(""),
        r["conventions"]["chamfer"].as_str().unwrap_or(""),
        r["conventions"]["fscore"].as_str().unwrap_or("")
    )?;
    Ok(s)
}
