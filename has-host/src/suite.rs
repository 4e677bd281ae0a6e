//! The scenario suite (issue 13) as library types: its sites, one per scenario file (`*.toml`)
//! of a suite directory and named by the file's stem ([`discover`], [`select`]), and the typed
//! table of a suite run, one [`SuiteRow`] per site built from that site's reconstruction report
//! ([`ReconstructReport`]). A site that fails (an error, or a panic: [`run_site`]) is a row
//! marked failed with its error on one line; the other sites still run. `has-sim suite` writes
//! the [`SuiteReport`] as `suite.json` and renders its rows as the Markdown table `suite.md`.
//!
//! Units: metres (√Chamfer distance), percent (F-scores, false surface, observable share),
//! seconds (imaging wall time), MiB (peak resident memory, as measured by the caller). A figure
//! is `None` for a failed site, or when its report lacks it (no mesh).

use std::fmt::Display;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::reconstruction::ReconstructReport;

/// Why the sites of a suite could not be listed or selected.
#[derive(Debug, thiserror::Error)]
pub enum SuiteError {
    /// The suite directory could not be read.
    #[error("suite directory {}", dir.display())]
    ReadDir {
        /// The directory.
        dir: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// An entry of the suite directory could not be read.
    #[error("reading {}", dir.display())]
    ReadEntry {
        /// The directory.
        dir: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The suite directory holds no scenario.
    #[error("suite directory {}: no *.toml scenario in it", dir.display())]
    Empty {
        /// The directory.
        dir: PathBuf,
    },
    /// A selected name is not a site.
    #[error("no site '{name}'; the suite has {known}")]
    UnknownSite {
        /// The name asked for.
        name: String,
        /// The suite's site names, comma-separated.
        known: String,
    },
    /// A site named twice (it would run twice into one directory).
    #[error("site '{name}' is named twice")]
    DuplicateSite {
        /// The name.
        name: String,
    },
}

/// One site of the suite: a scenario file and its name.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Site {
    /// The scenario file's stem.
    pub name: String,
    /// The scenario file.
    pub scenario: PathBuf,
}

/// The sites of the suite directory `dir` (its `*.toml` files), sorted by name.
///
/// # Errors
/// [`SuiteError::ReadDir`], [`SuiteError::ReadEntry`]; [`SuiteError::Empty`] without a
/// scenario.
pub fn discover(dir: &Path) -> Result<Vec<Site>, SuiteError> {
    let entries = std::fs::read_dir(dir).map_err(|source| SuiteError::ReadDir {
        dir: dir.to_path_buf(),
        source,
    })?;
    let mut sites = Vec::new();
    for e in entries {
        let path = e
            .map_err(|source| SuiteError::ReadEntry {
                dir: dir.to_path_buf(),
                source,
            })?
            .path();
        if path.extension().is_some_and(|x| x == "toml") {
            if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
                sites.push(Site {
                    name: stem.to_string(),
                    scenario: path.clone(),
                });
            }
        }
    }
    sites.sort();
    if sites.is_empty() {
        return Err(SuiteError::Empty {
            dir: dir.to_path_buf(),
        });
    }
    Ok(sites)
}

/// `all` restricted to the sites named `names`, in that order (`names` empty: all of them).
///
/// # Errors
/// [`SuiteError::UnknownSite`] for the first name that is not a site of `all`;
/// [`SuiteError::DuplicateSite`] for the first one named twice.
pub fn select(all: &[Site], names: &[String]) -> Result<Vec<Site>, SuiteError> {
    if names.is_empty() {
        return Ok(all.to_vec());
    }
    if let Some((_, n)) = names
        .iter()
        .enumerate()
        .find(|(i, n)| names[..*i].contains(n))
    {
        return Err(SuiteError::DuplicateSite { name: n.clone() });
    }
    names
        .iter()
        .map(|n| {
            all.iter()
                .find(|s| &s.name == n)
                .cloned()
                .ok_or_else(|| SuiteError::UnknownSite {
                    name: n.clone(),
                    known: all
                        .iter()
                        .map(|s| s.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                })
        })
        .collect()
}

/// One site's line of the suite table, from its reconstruction's report (`None`: the site
/// failed, or its report lacks the figure).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
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
    /// The seed the site was run with in place of its scenario's `imaging.seed` (`None`: the
    /// scenario's own).
    pub seed: Option<u64>,
}

impl SuiteRow {
    /// The row of `site`, whose reconstruction reported `r` with a peak resident memory of
    /// `peak_rss_mib` MiB.
    pub fn from_report(site: &Site, r: &ReconstructReport, peak_rss_mib: Option<f64>) -> Self {
        let pc = &r.imaging.point_cloud.metrics;
        let mesh = r.mesh.as_ref();
        SuiteRow {
            site: site.name.clone(),
            scenario: site.scenario.display().to_string(),
            ok: true,
            error: None,
            cloud_sqrt_cd_m: Some(pc.sqrt_chamfer_m),
            cloud_fscore_1_5m: Some(pc.fscores.fscore_1_5m),
            mesh_sqrt_cd_m: mesh.map(|m| m.metrics.sqrt_chamfer_m),
            mesh_fscore_1_5m: mesh.map(|m| m.metrics.fscores.fscore_1_5m),
            mesh_false_surface_pct: mesh.map(|m| m.false_surface_pct_1_5m),
            mesh_area_ratio: mesh.map(|m| m.area_ratio),
            observable_pct: Some(r.imaging.ground_truth.observable_pct),
            imaging_s: Some(r.timings_s.imaging),
            peak_rss_mib,
            seed: None,
        }
    }

    /// The row of `site`, failed with `error` (newlines become spaces).
    pub fn failed(site: &Site, error: &str) -> Self {
        SuiteRow {
            site: site.name.clone(),
            scenario: site.scenario.display().to_string(),
            error: Some(error.replace('\n', " ")),
            ..SuiteRow::default()
        }
    }
}

/// Runs one site's reconstruction `run`, which returns the site's report and its peak resident
/// memory (MiB), and makes its row: a returned error `e` gives a failed row with `{e:#}` (an
/// `anyhow` error with its causes), a panic a failed row with `panicked: <message>`. The
/// panic hook still runs (the default one prints the panic to stderr).
pub fn run_site<E: Display>(
    site: &Site,
    run: impl FnOnce() -> Result<(ReconstructReport, Option<f64>), E>,
) -> SuiteRow {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)) {
        Ok(Ok((r, peak))) => SuiteRow::from_report(site, &r, peak),
        Ok(Err(e)) => SuiteRow::failed(site, &format!("{e:#}")),
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| p.downcast_ref::<&str>().copied())
                .unwrap_or("(no message)");
            SuiteRow::failed(site, &format!("panicked: {msg}"))
        }
    }
}

/// Mean, smallest and largest of a figure over the runs of one site.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Spread {
    /// Arithmetic mean.
    pub mean: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

impl Spread {
    /// The spread of the finite values of `xs` (`None` when there is none).
    pub fn of(xs: impl IntoIterator<Item = f64>) -> Option<Self> {
        let v: Vec<f64> = xs.into_iter().filter(|x| x.is_finite()).collect();
        (!v.is_empty()).then(|| Spread {
            mean: v.iter().sum::<f64>() / v.len() as f64,
            min: v.iter().copied().fold(f64::INFINITY, f64::min),
            max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        })
    }
}

/// One site's figures over its runs with several seeds (`has-sim suite --seeds N`): how much of
/// a figure belongs to the site and how much to one draw of its scatterers and noise.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SeedSpread {
    /// Site name.
    pub site: String,
    /// Runs that finished (failed runs are left out).
    pub runs: usize,
    /// √Chamfer distance of the fused cloud, m.
    pub cloud_sqrt_cd_m: Option<Spread>,
    /// F-score at 1.5 m of the fused cloud, %.
    pub cloud_fscore_1_5m: Option<Spread>,
    /// √Chamfer distance of the mesh, m.
    pub mesh_sqrt_cd_m: Option<Spread>,
    /// F-score at 1.5 m of the mesh, %.
    pub mesh_fscore_1_5m: Option<Spread>,
}

/// Per site that was run with more than one seed, in the order of its first row: the spread of
/// its finished runs' figures.
pub fn seed_spreads(rows: &[SuiteRow]) -> Vec<SeedSpread> {
    let mut names: Vec<&str> = Vec::new();
    for r in rows {
        if r.seed.is_some() && !names.contains(&r.site.as_str()) {
            names.push(&r.site);
        }
    }
    names
        .into_iter()
        .filter_map(|name| {
            let runs: Vec<&SuiteRow> = rows
                .iter()
                .filter(|r| r.site == name && r.ok && r.seed.is_some())
                .collect();
            let spread =
                |f: fn(&SuiteRow) -> Option<f64>| Spread::of(runs.iter().filter_map(|r| f(r)));
            (runs.len() > 1).then(|| SeedSpread {
                site: name.to_string(),
                runs: runs.len(),
                cloud_sqrt_cd_m: spread(|r| r.cloud_sqrt_cd_m),
                cloud_fscore_1_5m: spread(|r| r.cloud_fscore_1_5m),
                mesh_sqrt_cd_m: spread(|r| r.mesh_sqrt_cd_m),
                mesh_fscore_1_5m: spread(|r| r.mesh_fscore_1_5m),
            })
        })
        .collect()
}

/// The whole suite run (`suite.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SuiteReport {
    /// `quick` or `default`.
    pub preset: &'static str,
    /// The suite directory, as given.
    pub suite_dir: String,
    /// One row per site (per site and seed with several seeds), in the order run.
    pub sites: Vec<SuiteRow>,
    /// How many rows failed.
    pub failed: usize,
    /// With several seeds: each site's spread over them ([`seed_spreads`]).
    pub seed_spreads: Vec<SeedSpread>,
}

impl SuiteReport {
    /// The report of `rows`, run with preset `preset` from the suite directory `suite_dir`.
    pub fn new(preset: &'static str, suite_dir: &Path, rows: Vec<SuiteRow>) -> Self {
        SuiteReport {
            preset,
            suite_dir: suite_dir.display().to_string(),
            failed: rows.iter().filter(|r| !r.ok).count(),
            seed_spreads: seed_spreads(&rows),
            sites: rows,
        }
    }

    /// The Markdown page of the run (`suite.md`).
    pub fn markdown(&self) -> String {
        let mut s = markdown(&self.sites, self.preset);
        if !self.seed_spreads.is_empty() {
            s += "\n## Over the seeds\n\n\
                  | site | runs | cloud √CD (m): mean (min–max) | cloud F(1.5 m): mean (min–max) | \
                  mesh √CD (m): mean (min–max) | mesh F(1.5 m): mean (min–max) |\n\
                  |---|---|---|---|---|---|\n";
            let sp = |x: &Option<Spread>, d: usize| match x {
                Some(v) => format!("{:.d$} ({:.d$}–{:.d$})", v.mean, v.min, v.max),
                None => "—".to_string(),
            };
            for r in &self.seed_spreads {
                s += &format!(
                    "| {} | {} | {} | {} | {} | {} |\n",
                    r.site,
                    r.runs,
                    sp(&r.cloud_sqrt_cd_m, 3),
                    sp(&r.cloud_fscore_1_5m, 1),
                    sp(&r.mesh_sqrt_cd_m, 3),
                    sp(&r.mesh_fscore_1_5m, 1),
                );
            }
        }
        s
    }

    /// The names of the sites that failed, in order.
    pub fn failed_sites(&self) -> Vec<&str> {
        self.sites
            .iter()
            .filter(|r| !r.ok)
            .map(|r| r.site.as_str())
            .collect()
    }
}

/// A row's site name, with its seed when it was run with one in place of the scenario's.
fn label(r: &SuiteRow) -> String {
    match r.seed {
        Some(seed) => format!("{} (seed {seed})", r.site),
        None => r.site.clone(),
    }
}

/// `x` with `digits` decimals, or `—`.
fn cell(x: Option<f64>, digits: usize) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{v:.digits$}"),
        _ => "—".to_string(),
    }
}

/// The Markdown page of `rows` run with preset `preset` (`suite.md`: one table, then the
/// failed sites with their errors); [`SuiteReport::markdown`] of a whole run.
pub fn markdown(rows: &[SuiteRow], preset: &str) -> String {
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
                label(r),
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
            s += &format!("| {} | **failed** |  |  |  |  |  |  |  |  |\n", label(r));
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
                label(r),
                r.scenario,
                r.error.as_deref().unwrap_or("")
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn site(name: &str) -> Site {
        Site {
            name: name.into(),
            scenario: PathBuf::from(format!("{name}.toml")),
        }
    }

    #[test]
    fn unknown_site_names_the_known_ones_and_a_selection_keeps_its_order() {
        let all = vec![site("x"), site("y")];
        let e = select(&all, &["z".into()]).unwrap_err().to_string();
        assert_eq!(e, "no site 'z'; the suite has x, y");
        let s = select(&all, &["y".into(), "x".into()]).unwrap();
        assert_eq!(s, [site("y"), site("x")]);
        assert_eq!(select(&all, &[]).unwrap(), all);
        let e = select(&all, &["x".into(), "y".into(), "x".into()]).unwrap_err();
        assert_eq!(e.to_string(), "site 'x' is named twice");
    }

    #[test]
    fn discover_lists_the_toml_files_by_name_and_refuses_an_empty_directory() {
        let d = std::env::temp_dir().join(format!("has-suite-discover-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let e = discover(&d).unwrap_err();
        assert!(matches!(e, SuiteError::Empty { .. }), "{e:?}");
        for f in ["b.toml", "a.toml", "notes.md"] {
            std::fs::write(d.join(f), b"").unwrap();
        }
        let names: Vec<String> = discover(&d).unwrap().into_iter().map(|s| s.name).collect();
        assert_eq!(names, ["a", "b"]);
        let _ = std::fs::remove_dir_all(&d);
        assert!(matches!(
            discover(&d).unwrap_err(),
            SuiteError::ReadDir { .. }
        ));
    }

    #[test]
    fn an_error_or_a_panic_is_a_failed_row_and_counted() {
        let err = run_site(&site("a"), || {
            Err::<(ReconstructReport, _), _>("bad\nscene")
        });
        assert_eq!(
            (err.ok, err.error.as_deref(), err.scenario.as_str()),
            (false, Some("bad scene"), "a.toml")
        );
        assert!(err.cloud_sqrt_cd_m.is_none() && err.peak_rss_mib.is_none());
        let panicked = run_site(&site("b"), || -> Result<_, String> {
            std::panic::panic_any("boom".to_string())
        });
        assert_eq!(panicked.error.as_deref(), Some("panicked: boom"));
        let report = SuiteReport::new("quick", Path::new("suite"), vec![err, panicked]);
        assert_eq!(report.failed, 2);
        assert_eq!(report.failed_sites(), ["a", "b"]);
    }

    #[test]
    fn a_site_run_with_several_seeds_gets_the_mean_and_range_of_its_finished_runs() {
        let row = |seed: u64, cd: f64, ok: bool| SuiteRow {
            site: "s".into(),
            ok,
            cloud_sqrt_cd_m: ok.then_some(cd),
            cloud_fscore_1_5m: ok.then_some(90.0 + cd),
            mesh_sqrt_cd_m: None,
            seed: Some(seed),
            ..SuiteRow::default()
        };
        let alone = SuiteRow {
            site: "t".into(),
            ok: true,
            cloud_sqrt_cd_m: Some(0.5),
            ..SuiteRow::default()
        };
        let rows = vec![
            row(1, 0.8, true),
            row(2, 1.1, true),
            row(3, 9.0, false),
            row(4, 0.9, true),
            alone,
        ];
        let report = SuiteReport::new("quick", Path::new("d"), rows);
        assert_eq!(report.failed, 1);
        // Only the site with several seeds; the failed run is left out.
        assert_eq!(report.seed_spreads.len(), 1);
        let s = &report.seed_spreads[0];
        assert_eq!((s.site.as_str(), s.runs), ("s", 3));
        let cd = s.cloud_sqrt_cd_m.unwrap();
        assert!((cd.mean - 0.9333333333).abs() < 1e-9 && cd.min == 0.8 && cd.max == 1.1);
        assert!(s.mesh_sqrt_cd_m.is_none());
        let md = report.markdown();
        assert!(md.contains("| s (seed 2) | 1.100 |"), "{md}");
        assert!(md.contains("| s (seed 3) | **failed** |"), "{md}");
        assert!(
            md.contains("| s | 3 | 0.933 (0.800–1.100) | 90.9 (90.8–91.1) | — | — |"),
            "{md}"
        );
        assert_eq!(Spread::of([f64::NAN]), None);
    }

    #[test]
    fn a_failed_site_is_a_row_marked_failed_with_its_error() {
        let ok = SuiteRow {
            site: "a".into(),
            ok: true,
            cloud_sqrt_cd_m: Some(1.25),
            cloud_fscore_1_5m: Some(91.04),
            mesh_sqrt_cd_m: Some(1.0),
            mesh_fscore_1_5m: Some(93.0),
            mesh_false_surface_pct: Some(4.0),
            mesh_area_ratio: Some(1.1),
            observable_pct: Some(80.0),
            imaging_s: Some(12.0),
            peak_rss_mib: Some(100.0),
            ..SuiteRow::default()
        };
        let b = Site {
            name: "b".into(),
            scenario: PathBuf::from("b.toml"),
        };
        let md = markdown(&[ok, SuiteRow::failed(&b, "boom")], "quick");
        assert!(md.contains("| a | 1.250 | 91.0 | 1.000 | 93.0 | 4.0 | 1.10 | 80.0 | 12.0 | 100 |"));
        assert!(md.contains("| b | **failed** |"));
        assert!(md.contains("- b (b.toml): boom"));
    }
}
