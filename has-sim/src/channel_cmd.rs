//! `has-sim channel [SCENARIO] --out DIR [--quick] [--twin MESH.obj]`: the paper's §2 — ray-trace
//! one BS to every UE on the true scene and on the digital twin (the planar twin `reconstruct`
//! builds, unless `--twin` gives a mesh), match the multipath sets, and report error
//! percentiles, CDFs, the UE map and beam-selection agreement.
//!
//! The experiment is the scenario's `[channel]` table (`has_host::scenario::ChannelSpec`), run
//! by `has_host::channel_experiment::run_channel_experiment` (tracing, matching, statistics), and
//! its tables and plot data come from `has_host::channel_experiment::exports`; this command loads,
//! shows progress, renders the Markdown report and the plots and writes the files. Writes into
//! DIR: `report.json` (key `channel`), `report.md`, `report.html`, `errors.csv` (every matched
//! pair), `ues.csv` (every UE), `cdf_delay.svg`, `cdf_angles.svg`, `ue_map.png`, and `twin/` when
//! the twin is reconstructed here.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use has_host::channel_experiment::{
    errors_by_param, errors_csv, run_channel_experiment, ue_map, ues_csv, ChannelReportFile,
    ChannelRunInfo, TraceStage, UeMap,
};
use has_host::scenario::ChannelSpec;
use has_host::scenario::Scenario;
use has_host::Material;
use indicatif::{ProgressBar, ProgressStyle};
use plotters::style::RGBColor;

use crate::plot::{self, View};
use crate::reconstruct_cmd::{build_twin, load_scenario};
use has_host::html::{Layer, MESH_COLOUR};

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
    /// The twin mesh (OBJ or PLY) to ray-trace; default: run `reconstruct` into DIR/twin first
    /// and trace its planar twin (twin.obj; its Poisson mesh, mesh.obj, where no planar twin was
    /// built).
    #[arg(long)]
    pub twin: Option<PathBuf>,
}

fn load(args: &ChannelArgs) -> Result<(Scenario, ChannelSpec, String)> {
    load_channel(args.scenario.as_deref(), args.quick)
}

/// The scenario (default: the bundled one), its `[channel]` table with the quick preset applied
/// when asked and validated, and the scenario's name.
pub fn load_channel(
    scenario: Option<&Path>,
    quick: bool,
) -> Result<(Scenario, ChannelSpec, String)> {
    let (sc, name) = load_scenario(scenario)?;
    let mut spec = sc
        .channel
        .clone()
        .with_context(|| format!("{name}: no [channel] table"))?;
    if quick {
        spec.apply_quick();
    }
    spec.validate()?;
    Ok((sc, spec, name))
}

/// One progress bar per traced scene, made when its tracing starts.
struct TraceBars([OnceLock<ProgressBar>; 2]);

impl TraceBars {
    fn report(&self, stage: TraceStage, done: u64, total: u64) {
        let (slot, label) = match stage {
            TraceStage::True => (&self.0[0], "true"),
            TraceStage::Twin => (&self.0[1], "twin"),
        };
        let bar = slot.get_or_init(|| {
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template("{prefix:>6} [{bar:40}] {pos}/{len} UEs {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            bar.set_prefix(label);
            bar
        });
        bar.set_position(done);
        if done == total {
            bar.finish();
        }
    }
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
            "report.html",
            "errors.csv",
            "ues.csv",
            "cdf_delay.svg",
            "cdf_angles.svg",
            "ue_map.png",
        ],
    )?;
    // Checked before a twin is reconstructed.
    sc.radar.fc_hz_checked()?;

    let t = Instant::now();
    let twin_path = match &args.twin {
        Some(p) => p.clone(),
        None => build_twin(args.scenario.clone(), &args.out.join("twin"), args.quick)?,
    };
    let twin_s = t.elapsed().as_secs_f64();
    let mesh =
        has_host::io::load_objects(&twin_path, Some(Material::Concrete)).context("--twin")?;
    let twin_view = triangle_soup(&mesh);

    let info = ChannelRunInfo {
        scenario: scenario_name,
        preset: if args.quick { "quick" } else { "default" }.to_string(),
        twin_mesh: twin_path.display().to_string(),
        twin_reconstruction_s: twin_s,
        started: t0,
    };
    let bars = TraceBars(Default::default());
    let exp = run_channel_experiment(&sc, &spec, mesh, &info, &|stage, done, total| {
        bars.report(stage, done, total)
    })?;
    let c = &exp.report;

    // Outputs.
    let text =
        serde_json::to_string_pretty(&serde_json::to_value(ChannelReportFile { channel: c })?)?;
    write_text(&args.out.join("report.json"), &text)?;
    write_text(&args.out.join("errors.csv"), &errors_csv(&exp.pairs))?;
    write_text(&args.out.join("report.md"), &c.markdown())?;
    write_text(&args.out.join("ues.csv"), &ues_csv(&exp.ues, &exp.outcomes))?;
    let e = errors_by_param(&exp.pairs);
    plot::cdf(
        &args.out.join("cdf_delay.svg"),
        "Delay error of matched paths (twin vs true scene)",
        "delay error (ns)",
        &[("delay", &e.delay_ns, RGBColor(200, 40, 40))],
        1.0,
    )?;
    plot::cdf(
        &args.out.join("cdf_angles.svg"),
        "Angle errors of matched paths (twin vs true scene)",
        "angle error (degrees)",
        &[
            ("AoA", &e.aoa_deg, RGBColor(200, 40, 40)),
            ("AoD", &e.aod_deg, RGBColor(20, 70, 200)),
            ("ZoA", &e.zoa_deg, RGBColor(30, 150, 60)),
            ("ZoD", &e.zod_deg, RGBColor(150, 60, 170)),
        ],
        1.0,
    )?;
    let map = ue_map(
        &exp.truth,
        &spec.known_objects,
        &exp.ues,
        &exp.outcomes,
        spec.bs(),
    )?;
    plot_ue_map(&args.out.join("ue_map.png"), &map)?;
    let bs = [map.bs];
    crate::html_report::write(
        &args.out,
        &format!("has-sim channel — {}", c.scenario),
        &c.markdown(),
        &[
            Layer::mesh("twin mesh", MESH_COLOUR, &twin_view),
            Layer::points(
                "true buildings (area samples)",
                [150, 150, 150],
                &map.buildings,
                2,
            ),
            Layer::points("kept UEs", [200, 40, 40], &map.kept, 4),
            Layer::points("dropped UEs", [20, 70, 200], &map.dropped, 4),
            Layer::points("BS", [0, 0, 0], &bs, 9),
        ],
        &[
            ("cdf_delay.svg", "Delay error of matched paths"),
            ("cdf_angles.svg", "Angle errors of matched paths"),
            ("ue_map.png", "UEs and the BS over the buildings, top view"),
        ],
    )?;

    let p90 = c
        .all
        .p90
        .to_array()
        .map(|x| x.filter(|v| v.is_finite()).unwrap_or(f64::NAN));
    let p = &c.paths;
    println!(
        "channel: {} of {} UEs kept, {} true / {} twin paths in the window; p90 delay {:.2} ns, AoA {:.2}°, AoD {:.2}°, ZoA {:.2}°, ZoD {:.2}°  [paper: 3.5 ns, 3°, 3°, 1°, 1°]",
        c.ues.kept,
        c.ues.total,
        p.true_kept,
        p.twin_kept,
        p90[0],
        p90[1],
        p90[2],
        p90[3],
        p90[4]
    );
    println!(
        "beam selection ({}×{} DFT): {:.1} % agree, {:.1} % within 1 dB; {:.0} paths/s; wall {:.1} s; report in {}",
        spec.codebook_rows,
        spec.codebook_cols,
        c.beam.agreement_pct,
        c.beam.within_1db_pct,
        c.paths_per_s_both(),
        c.timings_s.wall,
        args.out.display()
    );
    run_dir.finish()
}

/// The objects' triangles as one mesh, for the 3D view (which welds them).
pub fn triangle_soup(objects: &[has_host::scene::Object]) -> has_host::mesh::TriMesh {
    has_host::mesh::TriMesh::from_triangles(
        objects.iter().flat_map(|o| o.triangles.iter().copied()),
    )
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    has_host::io::atomic_write(path, |w| std::io::Write::write_all(w, text.as_bytes()))
        .with_context(|| format!("writing {}", path.display()))
}

/// Top view: the buildings (surface samples of every object not in `known_objects`), kept and
/// dropped UEs, the BS.
fn plot_ue_map(path: &Path, map: &UeMap) -> Result<()> {
    plot::projection(
        path,
        "UEs kept (red: strongest path < max loss) and dropped (blue), BS (black), buildings (grey), top view",
        View::Top,
        &[
            ("buildings", &map.buildings, RGBColor(170, 170, 170), 1),
            ("kept UEs", &map.kept, RGBColor(200, 40, 40), 3),
            ("dropped UEs", &map.dropped, RGBColor(20, 70, 200), 3),
            ("BS", &[map.bs], RGBColor(0, 0, 0), 7),
        ],
    )
}
