//! `has-sim bench pipeline [SCENARIO] [--quick]`: one reconstruction of the scenario (default:
//! the bundled factory), no files written, and where its wall time went
//! ([`has_host::reconstruction::StageTimes`]): setup, echo synthesis, back-projection,
//! detection and fusion, surface, scoring, each with its share.

use std::path::PathBuf;

use anyhow::Context;
use has_host::reconstruction::{self, ReconstructOptions, StageTimes};

/// Runs the reconstruction and prints its stage table.
pub fn run(scenario: Option<PathBuf>, quick: bool) -> anyhow::Result<()> {
    let (mut sc, name) = crate::reconstruct_cmd::load_scenario(scenario.as_deref())?;
    if quick {
        sc.apply_quick();
        sc.validate().context("the scenario's [quick] preset")?;
    }
    let t0 = std::time::Instant::now();
    let rec = reconstruction::reconstruct(&sc, &ReconstructOptions::default(), &|_, _, _| {})?;
    let mut report = rec.report;
    report.timings_s.wall = t0.elapsed().as_secs_f64();
    let stages = StageTimes::of(&report);
    println!(
        "has-sim bench pipeline — {name}, preset {}, {:.3e} backprojections\n",
        if quick { "quick" } else { "default" },
        report.backprojections
    );
    print!("{}", stages.table());
    Ok(())
}
