//! `has-sim mesh`: point cloud (PLY) → oriented normals → screened Poisson → OBJ (+ PLY) mesh,
//! with an optional comparison against a ground truth.

use std::path::PathBuf;

use anyhow::{bail, Context};
use glam::Vec3;
use has_host::io::ply;
use has_host::knn::GeometryError;
use has_host::mesh::{PoissonParams, ReconstructParams, Trim};
use has_host::meshing::{
    self, MeshInputError, MeshRunReport, MeshingError, MeshingOptions, WeightsUsed,
};
use has_host::metrics::CloudMetrics;

/// Options of the `mesh` subcommand.
#[derive(clap::Args, Debug)]
pub struct MeshArgs {
    /// Input point cloud (PLY). Normals are taken from `nx`, `ny`, `nz` properties when present
    /// (and `--estimate-normals` is not given); otherwise estimated by PCA and oriented by
    /// minimum-spanning-tree propagation.
    pub input: PathBuf,
    /// Output mesh (OBJ).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the mesh as PLY, with each vertex's support density as a property.
    #[arg(long)]
    pub ply: Option<PathBuf>,
    /// Grid depth: finest cell = 1.2 × largest extent / 2^depth; aim for a cell of 2–3 times
    /// the cloud's noise σ.
    #[arg(long, default_value_t = 7)]
    pub depth: u32,
    /// The finest cell in metres, whatever the cloud's extent (overrides the cell of `--depth`;
    /// `reconstruct` fixes it this way).
    #[arg(long)]
    pub cell: Option<f32>,
    /// Density-trim quantile in [0, 1) (Open3D style): drop vertices whose support density is
    /// below this quantile, with their faces. Omitted (and no `--trim-median`) = keep the closed
    /// surface.
    #[arg(long, conflicts_with = "trim_median")]
    pub trim: Option<f32>,
    /// Density trim relative to the median vertex density, fraction in (0, 1] (e.g. 0.25): also
    /// removes a large extrapolated part such as a building's open bottom.
    #[arg(long)]
    pub trim_median: Option<f32>,
    /// Drop connected components smaller than this fraction of the largest one's area (after
    /// trimming); 0 keeps every component.
    #[arg(long, default_value_t = 0.0)]
    pub min_component: f32,
    /// Keep only faces within this distance (m) of an input point: surface farther from every
    /// sample is extrapolation (`reconstruct` uses half the coarsest resolution cell of its pairs).
    #[arg(long)]
    pub support_distance: Option<f32>,
    /// Keep only the faces turned as the nearest input point's normal (drops the far side of the
    /// thin solid Poisson closes around an open sheet of points; `reconstruct` does this).
    #[arg(long)]
    pub facing_samples: bool,
    /// Keep only faces inside this box, lower corner `x y z` in metres (with `--clip-max`):
    /// typically the imaging region, outside which the closed surface is invented.
    #[arg(
        long,
        num_args = 3,
        requires = "clip_max",
        allow_negative_numbers = true
    )]
    pub clip_min: Option<Vec<f32>>,
    /// Upper corner of the clip box, `x y z` in metres.
    #[arg(
        long,
        num_args = 3,
        requires = "clip_min",
        allow_negative_numbers = true
    )]
    pub clip_max: Option<Vec<f32>>,
    /// Screening weight α (Kazhdan & Hoppe 2013; 0 = unscreened).
    #[arg(long, default_value_t = 4.0)]
    pub screening: f32,
    /// Adaptive fine levels: solve the levels whose full grid would exceed `--dense-max-nodes`
    /// only within this many cells of the samples (1..=64), with the coarser solution as
    /// boundary values.
    #[arg(long, default_value_t = PoissonParams::default().band.unwrap_or(2))]
    pub band: u32,
    /// Solve every level on its full grid (no band): memory and time grow with the box volume.
    #[arg(long)]
    pub full_grid: bool,
    /// With the band: levels of at most this many nodes are solved on their full grid.
    #[arg(long, default_value_t = PoissonParams::default().dense_max_nodes)]
    pub dense_max_nodes: usize,
    /// Neighbours for PCA normals.
    #[arg(long, default_value_t = 16)]
    pub k: usize,
    /// Estimate the normals (PCA over `--k` neighbours) even when the input stores some; stored
    /// normals then only orient the new ones (each is turned to agree with its stored normal),
    /// which re-estimates a sensor-oriented cloud at another scale. Without stored normals the
    /// orientation is propagated along a minimum spanning tree.
    #[arg(long)]
    pub estimate_normals: bool,
    /// Ground truth (PLY mesh, sampled at `--truth-density`, or PLY point cloud used as is):
    /// prints √CD and F-scores of the input cloud and of the mesh against it.
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Sampling density of mesh surfaces for the metrics, points per m² (the default is a
    /// scenario's `imaging.truth_density_per_m2` default, as `reconstruct` scores its mesh).
    #[arg(long, default_value_t = has_host::scenario::DEFAULT_TRUTH_DENSITY_PER_M2)]
    pub truth_density: f64,
    /// Weight each sample by this vertex property of the input, raised to `--weight-power`: weak
    /// samples carry less normal flux, screening and density
    /// ([`has_host::mesh::screened_poisson_weighted`]). Default: the input's `weight` property
    /// (the fusion weight `reconstruct` meshes with, in its `mesh_input.ply` and `fused.ply`),
    /// else its `intensity` (a pair cloud's detection amplitude relative to the pair's peak),
    /// else every sample alike.
    #[arg(long, conflicts_with = "unweighted")]
    pub weights: Option<String>,
    /// Weigh every sample alike even when the input has a `weight` or `intensity` property.
    #[arg(long)]
    pub unweighted: bool,
    /// Exponent applied to the weights (2 turns an amplitude into a power).
    #[arg(long, default_value_t = 1.0)]
    pub weight_power: f32,
    /// Write a JSON summary here.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

/// One line of figures: √CD, rms to / from the truth, F-scores at the report thresholds.
fn summary_line(name: &str, m: &CloudMetrics) -> String {
    let f = &m.fscores;
    format!(
        "{name:<28} √CD {:>7.3} m (rms to/from truth {:.3}/{:.3})   F(0.5 m) {:>6.2}   F(1.0 m) {:>6.2}   F(1.5 m) {:>6.2}",
        m.sqrt_chamfer_m,
        m.rms_to_truth_m,
        m.rms_from_truth_m,
        f.fscore_0_5m,
        f.fscore_1_0m,
        f.fscore_1_5m
    )
}

/// The flag of a library parameter of the mesher ([`has_host::mesh`], [`has_host::metrics`]),
/// so that an error names what the user typed.
fn flag_of(field: &str) -> Option<&'static str> {
    Some(match field {
        "depth" => "--depth",
        "cell_m" => "--cell",
        "screening" => "--screening",
        "band" => "--band",
        "dense_max_nodes" => "--dense-max-nodes",
        "normal_k" | "k" => "--k",
        "trim_quantile" | "quantile" => "--trim",
        "trim_median" | "median_fraction" => "--trim-median",
        "min_component_fraction" => "--min-component",
        "support_distance_m" => "--support-distance",
        "clip_box" => "--clip-min/--clip-max",
        "density_per_m2" => "--truth-density",
        "weight_power" => "--weight-power",
        f if f.starts_with("band") => "--band",
        _ => return None,
    })
}

/// `e` prefixed by the flag of the mesher parameter it names, if it names one.
fn name_flag(e: anyhow::Error) -> anyhow::Error {
    let of = |g: &GeometryError| match g {
        GeometryError::BadParameter { field, .. } => Some(*field),
        _ => None,
    };
    let field = e.chain().find_map(|c| {
        if let Some(g) = c.downcast_ref::<GeometryError>() {
            of(g)
        } else if let Some(MeshingError::Normals(g) | MeshingError::Surface(g)) =
            c.downcast_ref::<MeshingError>()
        {
            of(g)
        } else if let Some(MeshInputError::TruthSamples(g)) = c.downcast_ref::<MeshInputError>() {
            of(g)
        } else {
            None
        }
    });
    match field.and_then(flag_of) {
        Some(flag) => e.context(flag),
        None => e,
    }
}

/// Checks the flags no file is needed for, before reading anything.
fn check_args(a: &MeshArgs) -> anyhow::Result<()> {
    if !(a.min_component.is_finite() && (0.0..1.0).contains(&a.min_component)) {
        bail!(
            "--min-component: {} is not a fraction in [0, 1)",
            a.min_component
        );
    }
    if let Some(c) = a.cell.filter(|c| !(c.is_finite() && *c > 0.0)) {
        bail!("--cell: {c} m is not a positive length");
    }
    if let Some(d) = a.support_distance.filter(|d| !(d.is_finite() && *d > 0.0)) {
        bail!("--support-distance: {d} m is not a positive length");
    }
    if !(a.truth_density.is_finite() && a.truth_density > 0.0) {
        bail!(
            "--truth-density: {} is not a positive density",
            a.truth_density
        );
    }
    if let (Some(lo), Some(hi)) = (&a.clip_min, &a.clip_max) {
        if !lo.iter().chain(hi).all(|v| v.is_finite()) || lo.iter().zip(hi).any(|(l, h)| l > h) {
            bail!("--clip-max: {hi:?} is not finite and at least --clip-min {lo:?} on every axis");
        }
    }
    for (flag, p) in [
        ("--out", Some(&a.out)),
        ("--ply", a.ply.as_ref()),
        ("--report", a.report.as_ref()),
    ] {
        if let Some(p) = p {
            crate::run_dir::check_output_file(flag, p)?;
        }
    }
    Ok(())
}

/// Runs the subcommand.
pub fn run(a: MeshArgs) -> anyhow::Result<()> {
    check_args(&a)?;
    run_checked(a).map_err(name_flag)
}

fn run_checked(a: MeshArgs) -> anyhow::Result<()> {
    if let Some(q) = a.trim {
        if !(0.0..1.0).contains(&q) {
            bail!("--trim: {q} is not a quantile in [0, 1)");
        }
    }
    if let Some(f) = a.trim_median {
        if !(f > 0.0 && f <= 1.0) {
            bail!("--trim-median: {f} is not a fraction in (0, 1]");
        }
    }
    if !(a.weight_power.is_finite() && a.weight_power >= 0.0) {
        bail!("--weight-power: {} is not finite and >= 0", a.weight_power);
    }
    let rule = match (a.trim, a.trim_median) {
        (Some(q), _) => Some(Trim::Quantile(q)),
        (None, Some(f)) => Some(Trim::MedianFraction(f)),
        (None, None) => None,
    };
    let input = ply::read_ply(&a.input)?;
    // The ground truth is read before any work, so a bad `--truth` leaves no mesh behind.
    let truth = match &a.truth {
        Some(p) => Some(meshing::read_truth(p, a.truth_density)?),
        None => None,
    };
    let points = &input.vertices;
    let column = meshing::weight_column(&input, &a.input, a.weights.as_deref(), a.unweighted)
        .map_err(|e| anyhow::anyhow!("--weights: {e}"))?;
    let params = PoissonParams {
        depth: a.depth,
        screening: a.screening,
        band: (!a.full_grid).then_some(a.band),
        dense_max_nodes: a.dense_max_nodes,
        cell_m: a.cell,
        ..PoissonParams::default()
    };
    let opts = MeshingOptions {
        params: ReconstructParams {
            normal_k: a.k,
            poisson: params,
            trim: rule,
            clip_box: match (&a.clip_min, &a.clip_max) {
                (Some(lo), Some(hi)) => Some((Vec3::from_slice(lo), Vec3::from_slice(hi))),
                _ => None,
            },
            support_distance_m: a.support_distance,
            facing_samples: a.facing_samples,
            min_component_fraction: (a.min_component > 0.0).then_some(a.min_component),
        },
        estimate_normals: a.estimate_normals,
        weight_power: a.weight_power,
    };
    // The same stages, in the same order, as `reconstruct`'s mesh
    // ([`has_host::mesh::reconstruct_oriented`]).
    let stored = meshing::stored_normals(&input);
    let mut meshed = meshing::mesh_cloud(points, stored, column.map(|c| c.values), &opts)
        .with_context(|| a.input.display().to_string())?;
    let peak_rss_poisson = crate::resources::peak_rss_mib();
    has_host::io::save_mesh(
        &meshed.mesh,
        &a.out,
        a.ply.as_deref(),
        meshed.vertex_density(),
    )?;
    let (m, t) = (&meshed.report.mesh, &meshed.report.time_s);
    println!(
        "mesh: {} points → {} vertices, {} faces, cell {:.3} m, grid {:?}, watertight {}, manifold {}",
        points.len(),
        m.vertices,
        m.faces,
        m.cell_m,
        m.grid_dims,
        m.topology.watertight,
        m.topology.manifold
    );
    println!(
        "time: normals {:.2} s, solve {:.2} s, extract {:.2} s, total Poisson {:.2} s",
        t.normals, t.solve, t.extract, t.poisson_total
    );
    if let Some(truth) = &truth {
        let s = meshed.score(points, truth, a.truth_density)?;
        println!("{}", summary_line("input cloud", &s.cloud));
        println!("{}", summary_line("mesh (has)", &s.mesh));
        if let Some(u) = &s.mesh_untrimmed {
            println!("{}", summary_line("mesh (has), untrimmed", u));
        }
    }
    let report = MeshRunReport {
        input: a.input.clone(),
        weights: column.map(|c| WeightsUsed {
            property: c.property.to_string(),
            power: a.weight_power,
        }),
        peak_rss_mib: crate::resources::peak_rss_mib(),
        peak_rss_after_poisson_mib: peak_rss_poisson,
        meshing: meshed.report,
    };
    if let Some(r) = &a.report {
        let text = serde_json::to_string_pretty(&serde_json::to_value(&report)?)? + "\n";
        has_host::io::atomic_write(r, |w| std::io::Write::write_all(w, text.as_bytes()))
            .with_context(|| format!("{}: writing report", r.display()))?;
    }
    Ok(())
}
