//! `has-sim reconstruct [SCENARIO] --out DIR`: the paper's §1 end to end — imaging of every
//! base station–terminal pair through has-dsp, fusion, and the point-cloud metrics; writes
//! `report.json`, `report.md`, `report.html`, PLY clouds and PNG plots into DIR.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use has_host::html::{Layer, MESH_COLOUR};
use has_host::imaging::{self, RunOptions};
use has_host::io::{save_cloud, save_mesh};
use has_host::material::Material;
use has_host::reconstruction::{
    self, shard, Prepared, ReconstructError, ReconstructOptions, ReconstructRunReport,
    Reconstruction, Shard, ShardRecord,
};
use has_host::scenario::Scenario;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use plotters::style::RGBColor;

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
    /// The fine pass's back-projection, replacing the scenario's `imaging.backprojection`:
    /// `exact` (per element of the thinned panel) or `factorised` (every element, in subarrays;
    /// error stated in has_dsp::bp::factorised).
    #[arg(long, value_parser = ["exact", "factorised"])]
    pub backprojection: Option<String>,
    /// Poisson grid depth of the surface reconstruction (finest cell = 1.2 × largest extent /
    /// 2^depth). Default: a finest cell of half the imaging voxel, whatever the cloud's extent.
    #[arg(long)]
    pub mesh_depth: Option<u32>,
    /// The finest Poisson cell of the surface reconstruction in metres, whatever the cloud's
    /// extent, replacing the default rule.
    #[arg(long, conflicts_with = "mesh_depth")]
    pub mesh_cell: Option<f32>,
    /// Density trim of the mesh, fraction of the median vertex support density, in [0, 1]
    /// (0: no trim, the mesh is only clipped to the support distance of the fused points).
    #[arg(long, default_value_t = imaging::surface::DEFAULT_TRIM_MEDIAN)]
    pub mesh_trim_median: f32,
    /// Before meshing, remove the fused points that a coarser first-pass surface hides from every
    /// sensor that observed them (ghosts; has_host::mesh::visibility). Off by default: on the
    /// bundled factory it helped the quick preset (mesh √CD 1.009 → 0.980 m) but hurt the
    /// default one (0.837 → 0.868 m), removing real roof points along with the ghosts.
    #[arg(long)]
    pub visibility_filter: bool,
    /// Do not continue each wall below its lowest detected sample down to the lower roof or the
    /// known terrain it stands on (`has_host::imaging::wall_columns`).
    #[arg(long)]
    pub no_wall_columns: bool,
    /// Do not stand a wall under each outer edge of an imaged roof down to the terrain
    /// (`has_host::imaging::wall_columns::roof_edge_walls`).
    #[arg(long)]
    pub no_roof_edge_walls: bool,
    /// Do not roof the buildings whose imaged walls outline a rectangle or a circle and whose
    /// roof no pair saw (`has_host::imaging::hidden_roofs`).
    #[arg(long)]
    pub no_hidden_roofs: bool,
    /// Stand the inferred walls inside a building's footprint on the terrain, not on its roof
    /// (`has_host::imaging::hidden_roofs::standing_on`).
    #[arg(long)]
    pub no_inner_walls_on_roofs: bool,
    /// Do not wall the gaps between the imaged pieces of a footprint's sides
    /// (`has_host::imaging::outline_walls`).
    #[arg(long)]
    pub no_outline_walls: bool,
    /// Do not mirror a gable roof's imaged half about its ridge to place the footprint's side
    /// no pair saw (`has_host::imaging::hidden_roofs`).
    #[arg(long)]
    pub no_gables: bool,
    /// Do not continue imaged roof slopes down their fall line to a face rising above them
    /// (`has_host::imaging::valleys`).
    #[arg(long)]
    pub no_valleys: bool,
    /// Skip surface reconstruction.
    #[arg(long)]
    pub no_mesh: bool,
    /// Do not image: read the pair clouds (`pair_*.ply`) that an earlier `reconstruct` of the
    /// same scenario and preset wrote into this directory — or the shards of one (`--shard`)
    /// into these directories: `--from-pairs A B` or `--from-pairs A --from-pairs B`, every
    /// planned pair in exactly one — and fuse, confirm, mesh and score them as after imaging, in
    /// the scenario's pair order whatever the order of the directories. Give the scenario before
    /// this flag. None may be the `--out` directory.
    #[arg(long, num_args = 1.., value_name = "DIR")]
    pub from_pairs: Vec<PathBuf>,
    /// Image only shard I of N of the pairs (pair k, 0-based in the scenario's pair order,
    /// belongs to shard k mod N + 1), write their `pair_*.ply` and `shard.json` (the scenario's
    /// digest, the shard, its pairs), and stop: no fusion, mesh or scores. `--from-pairs` on the
    /// N directories fuses them into the result of one run.
    #[arg(long, value_name = "I/N", conflicts_with = "from_pairs")]
    pub shard: Option<String>,
    /// Seed of the scatterer sampling and the noise, in place of the scenario's
    /// `imaging.seed`: another draw of the same site, to see how much a figure owes to the draw.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Impair every pair with the `[impairments]` defaults (docs/scenario.md) when the scenario
    /// has no such table: unsynchronised terminals, compensated by each base station's
    /// line-of-sight reference.
    #[arg(long)]
    pub impairments: bool,
    /// Leave the pairs' `[impairments]` uncompensated (no line-of-sight reference).
    #[arg(long)]
    pub no_compensation: bool,
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
            backprojection: None,
            from_pairs: Vec::new(),
            shard: None,
            mesh_depth: None,
            mesh_cell: None,
            mesh_trim_median: imaging::surface::DEFAULT_TRIM_MEDIAN,
            visibility_filter: false,
            no_wall_columns: false,
            no_roof_edge_walls: false,
            no_hidden_roofs: false,
            no_inner_walls_on_roofs: false,
            no_outline_walls: false,
            no_gables: false,
            no_valleys: false,
            no_mesh: false,
            seed: None,
            impairments: false,
            no_compensation: false,
        }
    }
}

/// Loads the scenario file at `path`, or the bundled factory without one; returns it with the
/// name reports show.
pub fn load_scenario(path: Option<&Path>) -> Result<(Scenario, String)> {
    Ok(match path {
        Some(p) => (Scenario::load(p)?, p.display().to_string()),
        None => (
            Scenario::from_toml_str(FACTORY_TOML).context("bundled fixtures/factory.toml")?,
            "fixtures/factory.toml (bundled)".to_string(),
        ),
    })
}

fn load(args: &ReconstructArgs) -> Result<(Scenario, String)> {
    let (mut sc, name) = load_scenario(args.scenario.as_deref())?;
    if args.quick {
        sc.apply_quick();
    }
    match args.backprojection.as_deref() {
        Some("factorised") => sc.imaging.backprojection = imaging::Backprojection::Factorised,
        Some("exact") => sc.imaging.backprojection = imaging::Backprojection::Exact,
        _ => {}
    }
    if let Some(seed) = args.seed {
        sc.imaging.seed = seed;
    }
    if args.impairments && sc.impairments.is_none() {
        sc.impairments = Some(has_host::scenario::ImpairmentSpec::default());
    }
    if args.no_compensation {
        match sc.impairments.as_mut() {
            Some(imp) => imp.compensation = false,
            None => anyhow::bail!(
                "--no-compensation: the scenario has no [impairments] (add the table or --impairments)"
            ),
        }
    }
    if args.quick || args.backprojection.is_some() || args.impairments || args.no_compensation {
        sc.validate()?;
    }
    Ok((sc, name))
}

/// `mesh.obj`, `mesh.ply`, `mesh_input.ply` (the oriented and weighted input of the mesher, so
/// that `has-sim mesh mesh_input.ply` reproduces and can vary the surface stage without
/// rerunning the imaging), `mesh_top.png`, `mesh_side.png`.
fn write_mesh_files(out: &Path, rec: &Reconstruction, surf: &imaging::Surface) -> Result<()> {
    let n = &surf.normals;
    save_cloud(
        &out.join("mesh_input.ply"),
        &surf.points,
        vec![
            ("nx", n.iter().map(|v| v.x).collect()),
            ("ny", n.iter().map(|v| v.y).collect()),
            ("nz", n.iter().map(|v| v.z).collect()),
            ("weight", surf.weights.clone()),
        ],
    )?;
    save_mesh(
        &surf.mesh,
        &out.join("mesh.obj"),
        Some(&out.join("mesh.ply")),
        None,
    )?;
    let grey = RGBColor(170, 170, 170);
    let red = RGBColor(200, 40, 40);
    for (file, view, title) in [
        ("mesh_top.png", View::Top, "Reconstructed mesh, area samples (red), over the true surfaces (grey), top view"),
        ("mesh_side.png", View::Side, "Reconstructed mesh, area samples (red), over the true surfaces (grey), side view from −y"),
    ] {
        plot::projection(
            &out.join(file),
            title,
            view,
            &[("ground truth", &rec.world.truth, grey, 1), ("mesh", &rec.mesh_samples, red, 1)],
        )?;
    }
    Ok(())
}

/// `fused.ply`, `pair_*.ply`, `ground_truth.ply`, `fused_top.png`, `fused_side.png`.
fn write_cloud_files(out: &Path, rec: &Reconstruction) -> Result<()> {
    let (world, result) = (&rec.world, &rec.result);
    for (p, img) in result.plans.iter().zip(&result.images) {
        save_cloud(
            &out.join(format!("pair_{}.ply", p.name)),
            &img.points,
            vec![("intensity", img.intensity.clone())],
        )?;
    }
    let fused = &result.fused;
    save_cloud(
        &out.join("fused.ply"),
        &fused.points,
        vec![
            ("intensity", fused.intensity.clone()),
            ("weight", fused.weight.clone()),
            ("pairs", fused.pairs.iter().map(|&n| n as f32).collect()),
        ],
    )?;
    save_cloud(&out.join("ground_truth.ply"), &world.truth, vec![])?;
    let grey = RGBColor(170, 170, 170);
    let blue = RGBColor(20, 70, 200);
    for (file, view, title) in [
        (
            "fused_top.png",
            View::Top,
            "Fused imaging point cloud (blue) over the true surfaces (grey), top view",
        ),
        (
            "fused_side.png",
            View::Side,
            "Fused imaging point cloud (blue) over the true surfaces (grey), side view from −y",
        ),
    ] {
        plot::projection(
            &out.join(file),
            title,
            view,
            &[
                ("ground truth", &world.truth, grey, 1),
                ("fused cloud", &fused.points, blue, 2),
            ],
        )?;
    }
    Ok(())
}

/// `report.html`: the report, the truth, the fused cloud and the mesh in 3D, the plots.
fn write_html(
    out: &Path,
    report: &ReconstructRunReport,
    md: &str,
    (truth, fused): (&[glam::Vec3], &[glam::Vec3]),
    mesh: Option<&has_host::mesh::TriMesh>,
    twin: Option<&has_host::twin::solid::Solid>,
) -> Result<()> {
    use has_host::twin::solid::{Face, Provenance, Surface};
    let mut layers = vec![
        Layer::points("ground truth (area samples)", [150, 150, 150], truth, 2),
        Layer::points("fused cloud", [20, 70, 200], fused, 3),
    ];
    if let Some(mesh) = mesh {
        layers.push(Layer::mesh("Poisson mesh", MESH_COLOUR, mesh));
    }
    // The planar twin's faces on a detected plane and its inferred faces, in two colours.
    let inferred = |f: &Face| matches!(f.provenance, Provenance::Inferred { .. });
    let shown = |f: &Face| f.surface != Surface::GroundSurface;
    let twin_meshes = twin.map(|solid| {
        (
            solid.triangulate(|f| shown(f) && !inferred(f)).0,
            solid.triangulate(|f| shown(f) && inferred(f)).0,
        )
    });
    if let Some((on_plane, guessed)) = &twin_meshes {
        layers.push(Layer::mesh(
            "planar twin: faces on a detected plane",
            [200, 40, 40],
            on_plane,
        ));
        layers.push(Layer::mesh(
            "planar twin: inferred faces",
            [240, 150, 20],
            guessed,
        ));
    }
    crate::html_report::write(
        out,
        &format!("has-sim reconstruct — {}", report.scenario),
        md,
        &layers,
        &[
            ("fused_top.png", "Fused cloud over the truth, top view"),
            ("fused_side.png", "Fused cloud over the truth, side view"),
            ("mesh_top.png", "Mesh area samples over the truth, top view"),
            (
                "mesh_side.png",
                "Mesh area samples over the truth, side view",
            ),
        ],
    )
}

/// Runs `reconstruct` on `scenario` (default: the bundled factory), with the quick preset if
/// `quick`: the library's digital twin ([`Prepared::reconstruct_twin`]), with every file of
/// `reconstruct` written into `out`; returns the path of the twin it wrote, which `channel` and
/// `localize` ray-trace when no twin is given: the planar twin (`out/twin.obj`), or the Poisson
/// mesh (`out/mesh.obj`) where no planar twin could be built (the report says why).
pub fn build_twin(scenario: Option<PathBuf>, out: &Path, quick: bool) -> Result<PathBuf> {
    let args = ReconstructArgs::defaults(scenario, out, quick);
    let report = execute(&args, |p, progress, _| {
        Ok(p.reconstruct_twin(progress)?.into_reconstruction())
    })
    .context("reconstructing the digital twin")?;
    let planar = report
        .reconstruction
        .planar_twin
        .as_ref()
        .is_some_and(|t| t.metrics.is_some());
    Ok(out.join(if planar { "twin.obj" } else { "mesh.obj" }))
}

/// Checks the options that only the later stages use, so that a bad value fails before the
/// imaging rather than after it.
fn check_args(args: &ReconstructArgs) -> Result<()> {
    let f = args.mesh_trim_median;
    if !(0.0..=1.0).contains(&f) {
        anyhow::bail!("--mesh-trim-median: {f} is not a fraction in [0, 1]");
    }
    if let Some(d) = args.mesh_depth {
        if !(1..=10).contains(&d) {
            anyhow::bail!("--mesh-depth: {d} is not in 1..=10");
        }
    }
    if let Some(c) = args
        .mesh_cell
        .filter(|c| !(c.is_finite() && (0.01..=10.0).contains(c)))
    {
        anyhow::bail!("--mesh-cell: {c} m is not in [0.01, 10]");
    }
    shard(args)?;
    let mut seen: Vec<PathBuf> = Vec::new();
    for dir in &args.from_pairs {
        if args.fixed_point || args.raw_ofdm || args.backprojection.is_some() {
            anyhow::bail!(
                "--from-pairs: {} holds imaged pair clouds; --fixed-point, --raw-ofdm and \
                 --backprojection choose how to image and do not apply",
                dir.display()
            );
        }
        let canonical = dir.canonicalize().ok();
        let same = match (&canonical, args.out.canonicalize()) {
            (Some(a), Ok(b)) => *a == b,
            _ => false,
        };
        if same {
            anyhow::bail!(
                "--from-pairs: {} is also --out, whose files the run replaces",
                dir.display()
            );
        }
        if let Some(c) = canonical {
            if seen.contains(&c) {
                anyhow::bail!("--from-pairs: {} is given twice", dir.display());
            }
            seen.push(c);
        }
    }
    Ok(())
}

/// `--shard`, parsed.
fn shard(args: &ReconstructArgs) -> Result<Option<Shard>> {
    args.shard
        .as_deref()
        .map(|s| {
            s.parse::<Shard>()
                .map_err(|e| anyhow::anyhow!("--shard: {e}"))
        })
        .transpose()
}

/// What a `--from-pairs` directory holds: the names of its pair clouds (`None`: every planned
/// pair, a whole run) and, for a shard, how its pairs were imaged.
struct Held {
    pairs: Option<Vec<String>>,
    imaging: Option<String>,
}

/// Refuses pair clouds from a run of another scenario, preset or seed, or from a run that did
/// not finish (its `RUNNING` marker, [`crate::run_dir`]): `dir/shard.json` of a shard
/// ([`ShardRecord`]), else `dir/report.json` of a whole run, must record the same scenario
/// digest ([`Scenario::digest`]) and preset. A run written before digests were recorded is
/// compared by the scenario's file name and the preset, with a note, and refused with `--seed`
/// (its seed is not known). Returns which pairs the directory holds.
fn check_pairs_run(
    dir: &Path,
    args: &ReconstructArgs,
    scenario: &str,
    sc: &Scenario,
) -> Result<Held> {
    /// What `--from-pairs` reads of a run's `report.json` ([`ReconstructRunReport`]'s fields).
    #[derive(serde::Deserialize)]
    struct RunOf {
        scenario: String,
        preset: String,
        scenario_digest: Option<String>,
        seed: Option<u64>,
        imaging: Option<ImagingOf>,
    }
    #[derive(serde::Deserialize)]
    struct ImagingOf {
        pairs: Vec<PairOf>,
    }
    #[derive(serde::Deserialize)]
    struct PairOf {
        name: String,
    }
    let preset = if args.quick { "quick" } else { "default" };
    if dir.join(crate::run_dir::MARKER).exists() {
        anyhow::bail!(
            "--from-pairs: {} holds {}: its run was killed or failed",
            dir.display(),
            crate::run_dir::MARKER
        );
    }
    let shard_path = dir.join(SHARD_RECORD);
    let (path, run, held) = if shard_path.exists() {
        let text = has_host::io::guard::read_input_string(&shard_path)
            .with_context(|| format!("--from-pairs: reading {}", shard_path.display()))?;
        let r: ShardRecord = serde_json::from_str(&text)
            .with_context(|| format!("--from-pairs: parsing {}", shard_path.display()))?;
        let run = RunOf {
            scenario: r.scenario,
            preset: r.preset,
            scenario_digest: Some(r.scenario_digest),
            seed: Some(r.seed),
            imaging: None,
        };
        let held = Held {
            pairs: Some(r.pairs),
            imaging: Some(r.imaging),
        };
        (shard_path, run, held)
    } else {
        let path = dir.join("report.json");
        let text = has_host::io::guard::read_input_string(&path).with_context(|| {
            format!(
                "--from-pairs: reading {} (a directory of `reconstruct` holds report.json, one \
                 of `reconstruct --shard` {SHARD_RECORD})",
                path.display()
            )
        })?;
        let mut run: RunOf = serde_json::from_str(&text)
            .with_context(|| format!("--from-pairs: parsing {}", path.display()))?;
        let held = Held {
            pairs: run
                .imaging
                .take()
                .map(|i| i.pairs.into_iter().map(|p| p.name).collect()),
            imaging: None,
        };
        (path, run, held)
    };
    let digest = sc.digest()?;
    let (run_sc, run_preset) = (run.scenario.as_str(), run.preset.as_str());
    let same = match &run.scenario_digest {
        Some(d) => *d == digest && run_preset == preset,
        None => {
            if args.seed.is_some() {
                anyhow::bail!(
                    "--seed: {} records no seed (an older run), so its pair clouds cannot be \
                     checked against seed {}",
                    path.display(),
                    sc.imaging.seed
                );
            }
            eprintln!(
                "note: {} records no scenario digest (an older run): only the scenario's file \
                 name and the preset are compared",
                path.display()
            );
            let file = |s: &str| Path::new(s).file_name().map(|f| f.to_os_string());
            file(run_sc) == file(scenario) && run_preset == preset
        }
    };
    if !same {
        let of = |d: Option<&str>, seed: Option<u64>| match (d, seed) {
            (Some(d), Some(s)) => format!(", seed {s}, scenario digest {d}"),
            _ => String::new(),
        };
        anyhow::bail!(
            "--from-pairs: {} is a run of {run_sc} (preset {run_preset}{}), not of {scenario} \
             (preset {preset}{})",
            dir.display(),
            of(run.scenario_digest.as_deref(), run.seed),
            of(Some(&digest), Some(sc.imaging.seed)),
        );
    }
    Ok(held)
}

/// For each planned pair of `plans`, the directory of `args.from_pairs` holding its cloud
/// (`held[d]` what directory `d` holds, [`check_pairs_run`]); refuses missing and duplicate
/// pairs and shards imaged along different paths.
fn pair_sources(
    args: &ReconstructArgs,
    plans: &[imaging::PairPlan],
    held: Vec<Held>,
) -> Result<Vec<PathBuf>> {
    let dirs = &args.from_pairs;
    let mut first: Option<(usize, &str)> = None;
    for (d, h) in held.iter().enumerate() {
        let Some(im) = h.imaging.as_deref() else {
            continue;
        };
        match first {
            None => first = Some((d, im)),
            Some((f, fim)) if fim != im => anyhow::bail!(
                "--from-pairs: {} was imaged as `{fim}`, {} as `{im}`",
                dirs[f].display(),
                dirs[d].display()
            ),
            Some(_) => {}
        }
    }
    let names: Vec<Vec<String>> = held
        .into_iter()
        .map(|h| {
            h.pairs
                .unwrap_or_else(|| plans.iter().map(|p| p.name.clone()).collect())
        })
        .collect();
    let owner = shard::assign_pairs(plans, dirs, &names)
        .map_err(|e| anyhow::anyhow!("--from-pairs: {e}"))?;
    Ok(owner.into_iter().map(|d| dirs[d].clone()).collect())
}

/// The record of `reconstruct --shard` ([`ShardRecord`]).
pub const SHARD_RECORD: &str = "shard.json";

/// The files `reconstruct` writes into its output directory ([`crate::run_dir`]); `--shard`
/// writes `pair_*.ply` and [`SHARD_RECORD`], and each mode removes the other's.
pub const OUTPUTS: [&str; 19] = [
    SHARD_RECORD,
    "report.json",
    "report.md",
    "report.html",
    "fused.ply",
    "pair_*.ply",
    "ground_truth.ply",
    "mesh.obj",
    "mesh.ply",
    "mesh_input.ply",
    "fused_top.png",
    "fused_side.png",
    "mesh_top.png",
    "mesh_side.png",
    "twin.xml",
    "twin_building_*.ply",
    "twin.obj",
    "twin.ply",
    "twin.city.json",
];

/// Runs the command line's `reconstruct`: one shard ([`run_shard`]) with `--shard`, else
/// [`run`].
pub fn run_command(args: ReconstructArgs) -> Result<()> {
    check_args(&args)?;
    match shard(&args)? {
        Some(s) => run_shard(&args, s),
        None => run(args).map(|_| ()),
    }
}

/// Runs the command; returns what it wrote to `report.json`.
pub fn run(args: ReconstructArgs) -> Result<ReconstructRunReport> {
    check_args(&args)?;
    if args.shard.is_some() {
        anyhow::bail!("--shard: a shard writes no report.json; run it with `reconstruct --shard`");
    }
    let opts = ReconstructOptions {
        run: run_options(&args),
        surface: (!args.no_mesh).then_some(imaging::SurfaceOptions {
            depth: args.mesh_depth,
            cell_m: args.mesh_cell,
            trim_median: (args.mesh_trim_median > 0.0).then_some(args.mesh_trim_median),
            visibility_filter: args.visibility_filter,
            wall_columns: !args.no_wall_columns,
            roof_edge_walls: !args.no_roof_edge_walls,
            hidden_roofs: !args.no_hidden_roofs,
            inner_walls_on_roofs: !args.no_inner_walls_on_roofs,
            outline_walls: !args.no_outline_walls,
            gables: !args.no_gables,
            valleys: !args.no_valleys,
        }),
    };
    if args.from_pairs.is_empty() {
        execute(&args, |p, progress, _| p.reconstruct(&opts, progress))
    } else {
        execute(&args, |p, _, sources| {
            let dirs: Vec<&Path> = sources.iter().map(PathBuf::as_path).collect();
            let images = reconstruction::read_pair_images_from(&dirs, &p)?;
            p.reconstruct_from_images(images, &opts)
        })
    }
}

/// The imaging options of `args`.
fn run_options(args: &ReconstructArgs) -> RunOptions {
    RunOptions {
        fixed_point: args.fixed_point,
        raw_ofdm: args.raw_ofdm,
    }
}

/// Per-pair progress bars for `names`.
fn progress_bars<'a>(names: impl Iterator<Item = &'a str>) -> Vec<ProgressBar> {
    let multi = MultiProgress::new();
    names
        .map(|name| {
            let b = multi.add(ProgressBar::new(1));
            b.set_style(
                ProgressStyle::with_template("{prefix:>8} [{bar:40}] {pos}/{len} frames {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            b.set_prefix(name.to_string());
            b
        })
        .collect()
}

/// `reconstruct --shard I/N`: images the shard's pairs ([`Prepared::image_shard`]), writes their
/// `pair_*.ply` and [`SHARD_RECORD`] into `args.out`, and prints what it did and what it left
/// to the fusion.
fn run_shard(args: &ReconstructArgs, shard: Shard) -> Result<()> {
    let t0 = Instant::now();
    let (sc, scenario_name) = load(args)?;
    let scenario_digest = sc.digest()?;
    let run_dir = crate::run_dir::RunDir::start(&args.out, &OUTPUTS)?;
    let prepared = reconstruction::prepare(&sc)?;
    let mine = shard.pairs(prepared.plans.len());
    let bars = progress_bars(mine.iter().map(|&k| prepared.plans[k].name.as_str()));
    let bar_of = |k: usize| mine.iter().position(|&m| m == k).map(|b| &bars[b]);
    let opts = run_options(args);
    let imaged = prepared.image_shard(shard, opts, &|k, d, t| {
        if let Some(b) = bar_of(k) {
            b.set_length(t);
            b.set_position(d);
        }
    })?;
    for b in &bars {
        b.finish();
    }
    let mut names = Vec::with_capacity(imaged.pairs.len());
    for (&k, img) in imaged.pairs.iter().zip(&imaged.images) {
        let name = &imaged.planned[k].name;
        save_cloud(
            &args.out.join(format!("pair_{name}.ply")),
            &img.points,
            vec![("intensity", img.intensity.clone())],
        )?;
        names.push(name.clone());
    }
    let backprojection = match sc.imaging.backprojection {
        imaging::Backprojection::Exact => "exact",
        imaging::Backprojection::Factorised => "factorised",
    };
    let record = ShardRecord {
        scenario: scenario_name,
        preset: if args.quick { "quick" } else { "default" }.to_string(),
        scenario_digest,
        seed: sc.imaging.seed,
        shard,
        split: shard::SPLIT.to_string(),
        planned_pairs: imaged.planned.len(),
        pairs: names,
        imaging: format!(
            "{}, {backprojection} back-projection, {}",
            if opts.fixed_point {
                "fixed_point_q15"
            } else {
                "f32"
            },
            if opts.raw_ofdm {
                "raw_ofdm"
            } else {
                "direct_profiles"
            }
        ),
        backprojections: imaged.images.iter().map(|i| i.stats.backprojections).sum(),
        timings_s: imaged.timings_s.clone(),
        peak_rss_mib: crate::resources::peak_rss_mib(),
        pair_stats: imaged.images.iter().map(|i| i.stats.clone()).collect(),
    };
    let text = serde_json::to_string_pretty(&record)?;
    has_host::io::atomic_write(&args.out.join(SHARD_RECORD), |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })?;
    if record.pairs.is_empty() {
        println!(
            "shard {shard}: none of the {} pairs falls to it",
            record.planned_pairs
        );
    } else {
        println!(
            "shard {shard}: {} of {} pairs imaged ({}); {:.3e} backprojections; wall {:.1} s; \
             pair clouds and {SHARD_RECORD} in {}",
            record.pairs.len(),
            record.planned_pairs,
            record.pairs.join(", "),
            record.backprojections,
            t0.elapsed().as_secs_f64(),
            args.out.display()
        );
    }
    println!(
        "no fusion, mesh or scores in a shard: fuse the {} shard directories with \
         `reconstruct --from-pairs DIR...`",
        shard.count
    );
    run_dir.finish()
}

/// Loads the scenario of `args`, has `reconstruct` reconstruct it while per-pair progress bars
/// show, writes the files and the report into `args.out` and prints the summary; returns the
/// report.
fn execute(
    args: &ReconstructArgs,
    reconstruct: impl FnOnce(
        Prepared<'_>,
        &(dyn Fn(usize, u64, u64) + Sync),
        &[PathBuf],
    ) -> Result<Reconstruction, ReconstructError>,
) -> Result<ReconstructRunReport> {
    let t0 = Instant::now();
    let (sc, scenario_name) = load(args)?;
    let held = args
        .from_pairs
        .iter()
        .map(|dir| check_pairs_run(dir, args, &scenario_name, &sc))
        .collect::<Result<Vec<_>>>()?;
    let scenario_digest = sc.digest()?;
    let (run_dir, prepared, sources) = if held.is_empty() {
        let run_dir = crate::run_dir::RunDir::start(&args.out, &OUTPUTS)?;
        (run_dir, reconstruction::prepare(&sc)?, Vec::new())
    } else {
        // Which directory holds each pair, checked before the output directory is touched.
        let prepared = reconstruction::prepare(&sc)?;
        let sources = pair_sources(args, &prepared.plans, held)?;
        let run_dir = crate::run_dir::RunDir::start(&args.out, &OUTPUTS)?;
        (run_dir, prepared, sources)
    };

    let bars = progress_bars(prepared.plans.iter().map(|p| p.name.as_str()));
    let rec = reconstruct(
        prepared,
        &|k, d, t| {
            bars[k].set_length(t);
            bars[k].set_position(d);
        },
        &sources,
    )?;
    for b in &bars {
        b.finish();
    }
    let t_files = Instant::now();
    write_cloud_files(&args.out, &rec)?;
    if let Some(surf) = &rec.surface {
        write_mesh_files(&args.out, &rec, surf)?;
    }
    if let Some(tw) = &rec.planar_twin {
        crate::twin_cmd::write_twin_files(&args.out, &tw.solid, Material::Concrete, Vec::new())?;
    }
    let mut report = ReconstructRunReport {
        scenario: scenario_name,
        preset: if args.quick { "quick" } else { "default" },
        scenario_digest,
        seed: sc.imaging.seed,
        peak_rss_mib: crate::resources::peak_rss_mib(),
        reconstruction: rec.report,
    };
    let r = &mut report.reconstruction;
    r.timings_s.postprocess += t_files.elapsed().as_secs_f64();
    r.timings_s.wall = t0.elapsed().as_secs_f64();
    let text = serde_json::to_string_pretty(&serde_json::to_value(&report)?)?;
    has_host::io::atomic_write(&args.out.join("report.json"), |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })?;
    let md = report.markdown();
    has_host::io::atomic_write(&args.out.join("report.md"), |w| {
        std::io::Write::write_all(w, md.as_bytes())
    })?;
    write_html(
        &args.out,
        &report,
        &md,
        (&rec.world.truth, &rec.result.fused.points),
        rec.surface.as_ref().map(|s| &s.mesh),
        rec.planar_twin.as_ref().map(|t| &t.solid),
    )?;
    let r = &report.reconstruction;
    if let Some(m) = &r.mesh {
        println!(
            "mesh: {} vertices, {} faces, √CD {:.3} m, F-score(1.5 m) {:.1}  [paper: 0.96 m, 96]",
            m.vertices, m.faces, m.metrics.sqrt_chamfer_m, m.metrics.fscores.fscore_1_5m
        );
    }
    let pc = &r.imaging.point_cloud.metrics;
    println!(
        "fused point cloud: {} points, √CD {:.3} m, F-score(1.5 m) {:.1}  [paper: 1.18 m, 94]",
        pc.points, pc.sqrt_chamfer_m, pc.fscores.fscore_1_5m
    );
    println!(
        "{} pairs, {:.3e} backprojections at {:.3e}/s; wall {:.1} s; report in {}",
        r.imaging.pairs.len(),
        r.backprojections,
        r.backprojections_per_s,
        r.timings_s.wall,
        args.out.display()
    );
    run_dir.finish()?;
    Ok(report)
}
