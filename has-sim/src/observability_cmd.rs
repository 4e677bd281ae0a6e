//! `has-sim observability`: how much of the true surface each base station–aperture pairing of a
//! scenario could observe, before imaging anything — the planning question behind "which BS
//! pairs with which aperture follows from visibility" and the ceiling of a reconstruction.
//!
//! The figures are [`has_host::observability`]'s (which states the line-of-sight test and what the
//! percentages count); this command prints them as a table or as JSON.

use std::path::PathBuf;

use anyhow::Result;
use has_host::observability::{observability, ObservabilityReport};
use serde::Serialize;

use crate::reconstruct_cmd::load_scenario;

/// Arguments of `has-sim observability`.
#[derive(clap::Args, Debug)]
pub struct ObservabilityArgs {
    /// Scenario file (TOML, see docs/scenario.md). Default: the bundled fixtures/factory.toml.
    pub scenario: Option<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// The `--json` output: the library's report and the scenario's name.
#[derive(Serialize)]
struct JsonReport<'a> {
    scenario: &'a str,
    #[serde(flatten)]
    report: &'a ObservabilityReport,
}

/// Runs the command.
pub fn run(args: ObservabilityArgs) -> Result<()> {
    let (sc, name) = load_scenario(args.scenario.as_deref())?;
    let r = observability(&sc)?;
    if args.json {
        let v = serde_json::to_value(JsonReport {
            scenario: &name,
            report: &r,
        })?;
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    println!(
        "{name}: share of the true surface ({} samples) each pairing observes; * the pairs \
         `reconstruct` images",
        r.truth_points
    );
    print!("{:<10}", "aperture");
    for b in &sc.base_stations {
        print!("{:>10}", b.name);
    }
    println!();
    for (ai, ap) in sc.apertures.iter().enumerate() {
        print!("{:<10}", ap.name);
        for p in r.pairs.iter().filter(|p| p.aperture == ai) {
            let mark = if p.imaged { "*" } else { " " };
            print!("{:>9}{mark}", format!("{:.1} %", p.observed_pct));
        }
        println!();
    }
    println!("imaged pairs together:  {:.1} %", r.imaged_pairs_pct);
    println!("every pairing together: {:.1} %", r.every_pairing_pct);
    Ok(())
}
