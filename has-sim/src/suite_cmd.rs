//! `has-sim suite [--quick] --out DIR [--sites NAME,NAME] [--seeds N]`: the reconstruction of every
//! site of the scenario suite (`fixtures/suite/*.toml`, issue 13) and one table of the results;
//! with `--seeds N` each site N times with successive seeds and its mean and range over them.
//!
//! Each site (a scenario file; its name is the file stem, [`has_host::suite::discover`]) is
//! reconstructed in turn by [`crate::reconstruct_cmd::run`] into `DIR/<site>/`, sorted by name or
//! in the order given by `--sites`. Each site's typed report (the one it wrote to its
//! `report.json`) gives a [`has_host::suite::SuiteRow`]; `DIR/suite.json` holds the [`SuiteReport`] and
//! `DIR/suite.md` its rows as one Markdown table. A site that fails (an error, or a panic) is a
//! row marked failed with its error; the other sites still run and the command exits non-zero at
//! the end. The peak memory of a site is the process's peak since that site started (Linux; see
//! [`crate::resources`]).

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use clap::Args;
use has_host::suite::{self, SuiteReport};

use crate::reconstruct_cmd::ReconstructArgs;

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
    /// Run every site this many times, with its scenario's `imaging.seed` and the next ones
    /// (into `DIR/<site>/seed_<s>/`), and add each site's mean and range over the runs: how much
    /// of a figure is the site's and how much one draw's.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=100))]
    pub seeds: u64,
    /// Every site with the `[impairments]` defaults where it has no such table (as
    /// `reconstruct --impairments`).
    #[arg(long)]
    pub impairments: bool,
    /// Leave every site's impairments uncompensated (as `reconstruct --no-compensation`).
    #[arg(long, requires = "impairments")]
    pub no_compensation: bool,
}

/// The files `suite` writes at the top of its output directory ([`crate::run_dir`]).
pub const OUTPUTS: [&str; 2] = ["suite.json", "suite.md"];

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
    let sites = suite::select(&suite::discover(&dir)?, &args.sites)
        .map_err(|e| anyhow::anyhow!("--sites: {e}"))?;
    // The earlier run's table goes, and a marker shows the run is unfinished until the new
    // table is written.
    let run_dir = crate::run_dir::RunDir::start(&args.out, &OUTPUTS)?;
    let preset = if args.quick { "quick" } else { "default" };
    let mut rows = Vec::new();
    for (k, site) in sites.iter().enumerate() {
        println!("== suite: {} ({}/{}) ==", site.name, k + 1, sites.len());
        // One run with the scenario's own seed, or `--seeds` runs from it on (a scenario that
        // does not load fails in its run, with the reconstruction's error).
        let seeds: Vec<Option<u64>> = if args.seeds == 1 {
            vec![None]
        } else {
            let first =
                has_host::scenario::Scenario::load(&site.scenario).map_or(1, |sc| sc.imaging.seed);
            (0..args.seeds)
                .map(|i| Some(first.wrapping_add(i)))
                .collect()
        };
        for seed in seeds {
            let out = match seed {
                None => args.out.join(&site.name),
                Some(s) => {
                    println!("-- seed {s}");
                    args.out.join(&site.name).join(format!("seed_{s}"))
                }
            };
            crate::resources::reset_peak_rss();
            let mut row = suite::run_site(site, || {
                let mut a =
                    ReconstructArgs::defaults(Some(site.scenario.clone()), &out, args.quick);
                a.seed = seed;
                (a.impairments, a.no_compensation) = (args.impairments, args.no_compensation);
                crate::reconstruct_cmd::run(a).map(|r| (r.reconstruction, r.peak_rss_mib))
            });
            row.seed = seed;
            if let Some(msg) = &row.error {
                eprintln!("has-sim: suite: {} failed: {msg}", site.name);
            }
            rows.push(row);
        }
    }
    let report = SuiteReport::new(preset, &dir, rows);
    let failed = report.failed_sites();
    let json = serde_json::to_string_pretty(&report)?;
    has_host::io::atomic_write(&args.out.join("suite.json"), |w| {
        std::io::Write::write_all(w, json.as_bytes())
    })?;
    let md = report.markdown();
    has_host::io::atomic_write(&args.out.join("suite.md"), |w| {
        std::io::Write::write_all(w, md.as_bytes())
    })?;
    println!("\n{md}");
    // The table is complete, failed sites included.
    run_dir.finish()?;
    if !failed.is_empty() {
        bail!(
            "{} of {} suite sites failed: {} (see {})",
            failed.len(),
            report.sites.len(),
            failed.join(", "),
            args.out.join("suite.md").display()
        );
    }
    Ok(())
}
