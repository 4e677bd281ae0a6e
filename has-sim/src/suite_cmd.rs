//! `has-sim suite [--quick] --out DIR [--sites NAME,NAME]`: the reconstruction of every site of
//! the scenario suite (`fixtures/suite/*.toml`, issue 13) and one table of the results.
//!
//! Each site (a scenario file; its name is the file stem) is reconstructed in turn by
//! [`crate::reconstruct_cmd::run`] into `DIR/<site>/`, sorted by name or in the order given by
//! `--sites`. Each site's typed report (the one it wrote to its `report.json`) gives a
//! [`SuiteRow`]; `DIR/suite.json` holds the rows and `DIR/suite.md` the same rows as one
//! Markdown table. A site that fails (an error, or a panic) is a row marked failed with its
//! error; the other sites still run and the command exits non-zero at the end. The peak memory
//! of a site is the process's peak since that site started (Linux; see [`crate::resources`]).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;

use crate::reconstruct_cmd::{ReconstructArgs, RunReport};

/// The suite directory of the source tree, used when `fixtures/suite` is not below the current
/// directory.
const SOURCE_SUITE_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/suite");

/// Options of `suite`.
#[derive(Args)]
pub struct SuiteArgs {
    /// Output directory (created if missing): one subdirectory per site, `suite.json`,
    /// `suite.md`.
    #[arg(long)]
    pub out: PathBuf,
    /// The quick preset of every site (its `[quick]` overrides).
    #[arg(long)]
    pub quick: bool,
    /// Only these sites (file stems in the suite directory), comma-separated, in this order.
    #[arg(long, value_delimiter = ',')]
    pub sites: Vec<String>,
    /// Suite directory. Default: `fixtures/suite` below the current directory, else the source
    /// tree's.
    #[arg(long)]
    pub suite_dir: Option<PathBuf>,
}

/// One site's line of the suite table, from its reconstruction's report (`None`: the site
/// failed, or its report lacks the figure).
#[derive(Clone, Debug, Default, Serialize)]
pub struct SuiteRow {
    /// Site name (scenario file stem).
    pub site: String,
    /// Scenario file.
    pub scenario: String,
    /// Whether the reconstruction finished.
    pub ok: bool,
    /// The error of a failed site, one line.
    pub error: Option<String>,
    /// √Chamfer distance of the fused imaging cloud, m.
    pub cloud_sqrt_cd_m: Option<f64>,
    /// F-score at 1.5 m of the fused cloud, %.
    pub cloud_fscore_1_5m: Option<f64>,
    /// √Chamfer distance of the mesh, m.
    pub mesh_sqrt_cd_m: Option<f64>,
    /// F-score at 1.5 m of the mesh, %.
    pub mesh_fscore_1_5m: Option<f64>,
    /// Share of the mesh area farther than 1.5 m from the truth, %.
    pub mesh_false_surface_pct: Option<f64>,
    /// Mesh area / true surface area.
    pub mesh_area_ratio: Option<f64>,
    /// Share of the true surface in line of sight of some imaged pair, %.
    pub observable_pct: Option<f64>,
    /// Imaging (back-projection of every pair) wall time, s.
    pub imaging_s: Option<f64>,
    /// Peak resident memory during the site's run, MiB.
    pub peak_rss_mib: Option<f64>,
}

impl SuiteRow {
    /// The row of a site whose reconstruction reported `r`.
    fn from_report(site: &str, scenario: &Path, r: &RunReport) -> SuiteRow {
        let rec = &r.reconstruction;
        let pc = &rec.imaging.point_cloud.metrics;
        let mesh = rec.mesh.as_ref();
        SuiteRow {
            site: site.to_string(),
            scenario: scenario.display().to_string(),
            ok: true,
            error: None,
            cloud_sqrt_cd_m: Some(pc.sqrt_chamfer_m),
            cloud_fscore_1_5m: Some(pc.fscores.fscore_1_5m),
            mesh_sqrt_cd_m: mesh.map(|m| m.metrics.sqrt_chamfer_m),
            mesh_fscore_1_5m: mesh.map(|m| m.metrics.fscores.fscore_1_5m),
            mesh_false_surface_pct: mesh.map(|m| m.false_surface_pct_1_5m),
            mesh_area_ratio: mesh.map(|m| m.area_ratio),
            observable_pct: Some(rec.imaging.ground_truth.observable_pct),
            imaging_s: Some(rec.timings_s.imaging),
            peak_rss_mib: r.peak_rss_mib,
        }
    }

    /// The row of a site that failed with `error`.
    fn failed(site: &str, scenario: &Path, error: String) -> SuiteRow {
        SuiteRow {
            site: site.to_string(),
            scenario: scenario.display().to_string(),
            error: Some(error),
            ..SuiteRow::default()
        }
    }
}

/// The whole `suite.json`.
#[derive(Serialize)]
struct SuiteReport<'a> {
    preset: &'static str,
    suite_dir: String,
    sites: &'a [SuiteRow],
    failed: usize,
}

/// The sites of the suite directory: (name, path), sorted by name.
fn discover(dir: &Path) -> Result<Vec<(String, PathBuf)>> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("suite directory {}", dir.display()))?;
    let mut sites = Vec::new();
    for e in entries {
        let path = e
            .with_context(|| format!("reading {}", dir.display()))?
            .path();
        if path.extension().is_some_and(|x| x == "toml") {
            if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
                sites.push((stem.to_string(), path.clone()));
            }
        }
    }
    sites.sort();
    if sites.is_empty() {
        bail!(
            "suite directory {}: no *.toml scenario in it",
            dir.display()
        );
    }
    Ok(sites)
}

/// `all` restricted to `names` (in that order); every name must be a site.
fn select(all: &[(String, PathBuf)], names: &[String]) -> Result<Vec<(String, PathBuf)>> {
    if names.is_empty() {
        return Ok(all.to_vec());
    }
    names
        .iter()
        .map(|n| {
            all.iter().find(|(s, _)| s == n).cloned().with_context(|| {
                let known: Vec<&str> = all.iter().map(|(s, _)| s.as_str()).collect();
                format!("--sites: no site '{n}'; the suite has {}", known.join(", "))
            })
        })
        .collect()
}

/// Reconstructs one site into `out`; a panic becomes an error.
fn run_site(scenario: &Path, out: &Path, quick: bool) -> Result<RunReport> {
    let args = ReconstructArgs::defaults(Some(scenario.to_path_buf()), out, quick);
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        crate::reconstruct_cmd::run(args)
    })) {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| p.downcast_ref::<&str>().copied())
                .unwrap_or("(no message)");
            bail!("panicked: {msg}")
        }
    }
}

/// `x` with `digits` decimals, or `—`.
fn cell(x: Option<f64>, digits: usize) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{v:.digits$}"),
        _ => "—".to_string(),
    }
}

/// The Markdown page of the rows.
pub fn render_md(rows: &[SuiteRow], preset: &str) -> String {
    let mut s = format!(
        "# has-sim suite — preset `{preset}`\n\n\
         | site | cloud √CD (m) | cloud F(1.5 m) | mesh √CD (m) | mesh F(1.5 m) | \
         mesh false surface (%) | mesh area / truth area | observable (%) | imaging (s) | \
         peak memory (MiB) |\n\
         |---|---|---|---|---|---|---|---|---|---|\n"
    );
    for r in rows {
        if r.ok {
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.site,
                cell(r.cloud_sqrt_cd_m, 3),
                cell(r.cloud_fscore_1_5m, 1),
                cell(r.mesh_sqrt_cd_m, 3),
                cell(r.mesh_fscore_1_5m, 1),
                cell(r.mesh_false_surface_pct, 1),
                cell(r.mesh_area_ratio, 2),
                cell(r.observable_pct, 1),
                cell(r.imaging_s, 1),
                cell(r.peak_rss_mib, 0),
            );
        } else {
            s += &format!("| {} | **failed** |  |  |  |  |  |  |  |  |\n", r.site);
        }
    }
    s += "\nF-scores in %; false surface: share of the mesh's area farther than 1.5 m from the \
          true surface; observable: share of the true surface in line of sight of some imaged \
          pair (both legs); peak memory: the process's peak resident set during the site's run.\n";
    let failed: Vec<&SuiteRow> = rows.iter().filter(|r| !r.ok).collect();
    if !failed.is_empty() {
        s += "\n## Failed sites\n\n";
        for r in failed {
            s += &format!(
                "- {} ({}): {}\n",
                r.site,
                r.scenario,
                r.error.as_deref().unwrap_or("")
            );
        }
    }
    s
}

/// Runs the command.
pub fn run(args: SuiteArgs) -> Result<()> {
    let dir = match &args.suite_dir {
        Some(d) => d.clone(),
        None if Path::new("fixtures/suite").is_dir() => PathBuf::from("fixtures/suite"),
        None => PathBuf::from(SOURCE_SUITE_DIR),
    };
    if !dir.is_dir() {
        bail!(
            "suite directory {} not found (give --suite-dir, or run from the workspace root)",
            dir.display()
        );
    }
    let sites = select(&discover(&dir)?, &args.sites)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let preset = if args.quick { "quick" } else { "default" };
    let mut rows = Vec::new();
    for (k, (site, path)) in sites.iter().enumerate() {
        println!("== suite: {site} ({}/{}) ==", k + 1, sites.len());
        let out = args.out.join(site);
        crate::resources::reset_peak_rss();
        let row = match run_site(path, &out, args.quick) {
            Ok(r) => SuiteRow::from_report(site, path, &r),
            Err(e) => {
                let msg = format!("{e:#}").replace('\n', " ");
                eprintln!("has-sim: suite: {site} failed: {msg}");
                SuiteRow::failed(site, path, msg)
            }
        };
        rows.push(row);
    }
    let failed: Vec<&str> = rows
        .iter()
        .filter(|r| !r.ok)
        .map(|r| r.site.as_str())
        .collect();
    let report = SuiteReport {
        preset,
        suite_dir: dir.display().to_string(),
        sites: &rows,
        failed: failed.len(),
    };
    let json = serde_json::to_string_pretty(&report)?;
    has_host::io::atomic_write(&args.out.join("suite.json"), |w| {
        std::io::Write::write_all(w, json.as_bytes())
    })?;
    let md = render_md(&rows, preset);
    has_host::io::atomic_write(&args.out.join("suite.md"), |w| {
        std::io::Write::write_all(w, md.as_bytes())
    })?;
    println!("\n{md}");
    if !failed.is_empty() {
        bail!(
            "{} of {} suite sites failed: {} (see {})",
            failed.len(),
            rows.len(),
            failed.join(", "),
            args.out.join("suite.md").display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_site_is_a_row_marked_failed_with_its_error() {
        let ok = SuiteRow {
            site: "a".into(),
            scenario: "a.toml".into(),
            ok: true,
            error: None,
            cloud_sqrt_cd_m: Some(1.25),
            cloud_fscore_1_5m: Some(91.04),
            mesh_sqrt_cd_m: Some(1.0),
            mesh_fscore_1_5m: Some(93.0),
            mesh_false_surface_pct: Some(4.0),
            mesh_area_ratio: Some(1.1),
            observable_pct: Some(80.0),
            imaging_s: Some(12.0),
            peak_rss_mib: Some(100.0),
        };
        let bad = SuiteRow::failed("b", Path::new("b.toml"), "boom".into());
        let md = render_md(&[ok, bad], "quick");
        assert!(md.contains("| a | 1.250 | 91.0 | 1.000 | 93.0 | 4.0 | 1.10 | 80.0 | 12.0 | 100 |"));
        assert!(md.contains("| b | **failed** |"));
        assert!(md.contains("- b (b.toml): boom"));
    }

    #[test]
    fn unknown_site_names_the_known_ones() {
        let all = vec![
            ("x".to_string(), PathBuf::from("x.toml")),
            ("y".to_string(), PathBuf::from("y.toml")),
        ];
        let e = select(&all, &["z".into()]).unwrap_err().to_string();
        assert!(e.contains("'z'") && e.contains("x, y"), "{e}");
        let s = select(&all, &["y".into(), "x".into()]).unwrap();
        assert_eq!(s[0].0, "y");
    }
}
