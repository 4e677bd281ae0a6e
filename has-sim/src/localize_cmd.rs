//! `has-sim localize [SCENARIO] --out DIR [--quick] [--twin MESH.obj]`: the paper's §3 — a
//! monostatic base station detects and localizes a cylinder crossing the factory yard, with ECA
//! alone and with the environment prior from the digital twin (the planar twin `reconstruct`
//! builds, or the mesh `--twin` names); writes `report.json` (key
//! `localize`), `report.md`, `report.html`, detections PLY and PNG plots (paper Fig. 11 and
//! range–Doppler maps).
//! The run, the report and the files' data are `has_host::localize`'s (`run_localize`,
//! `LocalizeRunReport`, `localize::outputs`); this command adds progress, Markdown and plots.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use has_host::io::save_cloud;
use has_host::localize::{
    run_localize, DetectionCloud, LocalizeReport, LocalizeResult, LocalizeRunReport, LocalizeSpec,
    RdStage,
};
use has_host::scenario::Scenario;
use indicatif::{ProgressBar, ProgressStyle};
use plotters::style::RGBColor;

use crate::plot::{self, View};
use crate::reconstruct_cmd::{build_twin, load_scenario};
use has_host::html::{Layer, MESH_COLOUR};

/// Options of `localize`.
#[derive(Args)]
pub struct LocalizeArgs {
    /// Scenario file with a `[localize]` table (TOML). Default: the bundled fixtures/factory.toml.
    pub scenario: Option<PathBuf>,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// The quick preset (`[localize.quick]` overrides, and a quick twin if one is built); for CI.
    #[arg(long)]
    pub quick: bool,
    /// The digital twin (OBJ/PLY/XML mesh of the reconstructed environment). Default: run
    /// `reconstruct` on the same scenario into DIR/twin and use its planar twin (twin.obj; its
    /// Poisson mesh, mesh.obj, where no planar twin was built).
    #[arg(long, conflicts_with = "truth_twin")]
    pub twin: Option<PathBuf>,
    /// Use the true scene's buildings (every object but the `[localize] ground_objects`) as the
    /// twin: an oracle, the environment prior's ceiling with a perfect reconstruction.
    #[arg(long)]
    pub truth_twin: bool,
}

fn load(args: &LocalizeArgs) -> Result<(Scenario, LocalizeSpec, String)> {
    let (sc, name) = load_scenario(args.scenario.as_deref())?;
    let mut spec = sc
        .localize
        .clone()
        .with_context(|| format!("{name}: no [localize] table"))?;
    if args.quick {
        spec.apply_quick();
    }
    spec.validate()?;
    Ok((sc, spec, name))
}

/// Runs the command.
pub fn run(args: LocalizeArgs) -> Result<()> {
    let t0 = Instant::now();
    let (sc, spec, scenario_name) = load(&args)?;
    let run_dir = crate::run_dir::RunDir::start(
        &args.out,
        &[
            "report.json",
            "report.md",
            "report.html",
            "truth.ply",
            "detections_eca.ply",
            "detections_env.ply",
            "detections_eca_top.png",
            "detections_env_top.png",
            "detections_top.png",
            "detections_side.png",
            "rd_*.png",
        ],
    )?;
    let scene = sc.scene.build()?;
    let (twin_name, twin, twin_built_s) = if args.truth_twin {
        (
            "the true buildings (--truth-twin)".to_string(),
            spec.true_buildings(&scene),
            None,
        )
    } else {
        let (twin_path, built) = match &args.twin {
            Some(p) => (p.clone(), None),
            None => {
                let t = Instant::now();
                let p = build_twin(args.scenario.clone(), &args.out.join("twin"), args.quick)?;
                (p, Some(t.elapsed().as_secs_f64()))
            }
        };
        let twin = has_host::io::load_objects(&twin_path, None).context("--twin")?;
        (twin_path.display().to_string(), twin, built)
    };

    let bar = ProgressBar::new(spec.frames as u64);
    bar.set_style(
        ProgressStyle::with_template("localize [{bar:40}] {pos}/{len} frames {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let twin_view = crate::channel_cmd::triangle_soup(&twin);
    let t1 = Instant::now();
    let result = run_localize(&spec, &scene, twin, &|d, _| bar.set_position(d as u64))?;
    bar.finish_and_clear();
    let run_s = t1.elapsed().as_secs_f64();

    let clouds = write_outputs(&args, &spec, &result)?;
    let mut report = LocalizeRunReport {
        scenario: scenario_name,
        preset: if args.quick { "quick" } else { "default" }.to_string(),
        twin: twin_name,
        localize: LocalizeReport::new(&spec, &result, run_s, twin_built_s),
    };
    let wall = t0.elapsed().as_secs_f64();
    report.localize.timings_s.wall = wall;
    let text = serde_json::to_string_pretty(&serde_json::to_value(&report)?)?;
    has_host::io::atomic_write(&args.out.join("report.json"), |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })?;
    let md = report.markdown(&result);
    has_host::io::atomic_write(&args.out.join("report.md"), |w| {
        std::io::Write::write_all(w, md.as_bytes())
    })?;
    crate::html_report::write(
        &args.out,
        &format!("has-sim localize — {}", report.scenario),
        &md,
        &[
            Layer::mesh("twin (the prior's buildings)", MESH_COLOUR, &twin_view),
            Layer::points("true scattering points", [200, 60, 60], &clouds.truth, 3),
            Layer::points(&clouds.eca_label, [20, 70, 200], &clouds.eca, 4),
            Layer::points("env detections", [20, 150, 60], &clouds.env, 4),
        ],
        &[
            ("detections_eca_top.png", "Without the environment prior"),
            ("detections_env_top.png", "With the environment prior"),
            ("detections_top.png", "Both modes, top view"),
            ("detections_side.png", "Both modes, side view"),
            ("rd_*.png", "Range–Doppler at the target's beam"),
        ],
    )?;
    let (eca, env) = (&report.localize.eca, &report.localize.env);
    let f = |v: Option<f64>| v.map_or("—".to_string(), |x| format!("{x:.3} m"));
    println!(
        "localize: ECA ({}) √CD {}, {} detections, {} false alarms; env prior √CD {}, {} detections, {} false alarms; improvement {}  [paper: 1.73 m → 1.07 m, 40 %]",
        eca.label,
        f(eca.sqrt_chamfer_m),
        eca.detections,
        eca.false_alarms,
        f(env.sqrt_chamfer_m),
        env.detections,
        env.false_alarms,
        report
            .localize
            .improvement_pct
            .map_or("—".to_string(), |p| format!("{p:.1} %")),
    );
    println!("wall {:.1} s; report in {}", wall, args.out.display());
    run_dir.finish()
}

/// The clouds [`write_outputs`] wrote: the true scattering points, the best ECA pass's
/// detections and the environment prior's, with the ECA pass's label.
struct Clouds {
    truth: Vec<glam::Vec3>,
    eca: Vec<glam::Vec3>,
    env: Vec<glam::Vec3>,
    eca_label: String,
}

fn write_outputs(args: &LocalizeArgs, spec: &LocalizeSpec, r: &LocalizeResult) -> Result<Clouds> {
    let truth = r.truth_points();
    save_cloud(&args.out.join("truth.ply"), &truth, vec![])?;
    let save = |file: &str, c: DetectionCloud| -> Result<Vec<glam::Vec3>> {
        let columns = vec![
            ("frame", c.frame),
            ("snr_db", c.snr_db),
            ("doppler_hz", c.doppler_hz),
        ];
        save_cloud(&args.out.join(file), &c.points, columns)?;
        Ok(c.points)
    };
    let grey = RGBColor(200, 60, 60);
    let blue = RGBColor(20, 70, 200);
    let green = RGBColor(20, 150, 60);
    let eca_pts = save("detections_eca.ply", r.detection_cloud(r.eca_best))?;
    let env_pts = save("detections_env.ply", r.detection_cloud(r.env_pass))?;
    let eca_label = format!("{} detections", r.passes[r.eca_best]);
    plot::projection(
        &args.out.join("detections_eca_top.png"),
        "(a) Detections without the environment prior (best ECA), top view; red: true scattering points",
        View::Top,
        &[("truth", &truth, grey, 1), (&eca_label, &eca_pts, blue, 3)],
    )?;
    plot::projection(
        &args.out.join("detections_env_top.png"),
        "(b) Detections with the environment prior, top view; red: true scattering points",
        View::Top,
        &[
            ("truth", &truth, grey, 1),
            ("env detections", &env_pts, green, 3),
        ],
    )?;
    plot::projection(
        &args.out.join("detections_top.png"),
        "(c) Both modes over the true track, top view",
        View::Top,
        &[
            ("truth", &truth, grey, 1),
            (&eca_label, &eca_pts, blue, 3),
            ("env detections", &env_pts, green, 2),
        ],
    )?;
    plot::projection(
        &args.out.join("detections_side.png"),
        "Both modes over the true track, side view from −y",
        View::Side,
        &[
            ("truth", &truth, grey, 1),
            (&eca_label, &eca_pts, blue, 3),
            ("env detections", &env_pts, green, 2),
        ],
    )?;
    // Range–Doppler maps at the beam towards the target, for the frame with the slowest radial
    // speed (where the clutter notch hurts most) and the fastest.
    for m in r.range_doppler_maps(spec) {
        let title = format!(
            "Range–Doppler at the target's beam, frame {} (radial {:.2} m/s), {}",
            m.frame,
            m.radial_speed_mps,
            match m.stage {
                RdStage::Before => "before suppression".to_string(),
                RdStage::Eca => format!("after {}", r.passes[m.pass]),
                RdStage::Env => "after the environment prior + ECA".to_string(),
            }
        );
        plot::heatmap(
            &args
                .out
                .join(format!("rd_{}_{}.png", m.which.name(), m.stage.name())),
            &title,
            ("range (m)", "Doppler (Hz)"),
            (m.range_m[0], m.range_m[1]),
            (m.doppler_hz[0], m.doppler_hz[1]),
            (m.bins[0], m.bins[1]),
            &m.db,
            (-5.0, 60.0),
        )?;
    }
    Ok(Clouds {
        truth,
        eca: eca_pts,
        env: env_pts,
        eca_label,
    })
}
