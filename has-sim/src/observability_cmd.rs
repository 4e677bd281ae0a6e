//! `has-sim observability`: how much of the true surface each base station–aperture pairing of a
//! scenario could observe, before imaging anything — the planning question behind "which BS
//! pairs with which aperture follows from visibility" and the ceiling of a reconstruction.
//!
//! A truth point counts as observed by a pair when it sees the pair's panel centre and at least
//! one of its aperture's start, centre and end ([`imaging::observable_truth`], the same test as
//! the observable / hidden split of `reconstruct`'s report). Percentages are of the ground-truth
//! samples (`imaging.truth_density_per_m2` on the `imaging.truth_objects`), i.e. of the area.

use std::path::PathBuf;

use anyhow::Result;
use has_host::imaging::{self, PairPlan};
use serde_json::json;

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

/// Runs the command.
pub fn run(args: ObservabilityArgs) -> Result<()> {
    let (sc, name) = load_scenario(args.scenario.as_deref())?;
    let world = imaging::build_world(&sc)?;
    let planned = imaging::plan_pairs(&sc)?;
    let every = imaging::every_pairing(&sc);
    let is_planned = |p: &PairPlan| {
        planned
            .iter()
            .any(|q| q.bs == p.bs && q.aperture == p.aperture)
    };
    // One line-of-sight pass per pairing; the unions are ORs of those.
    let seen: Vec<Vec<bool>> = every
        .iter()
        .map(|p| imaging::observable_truth(&sc, &world, std::slice::from_ref(p)))
        .collect();
    let union = |keep: &dyn Fn(&PairPlan) -> bool| -> f64 {
        let mut any = vec![false; world.truth.len()];
        for (_, s) in every.iter().zip(&seen).filter(|(p, _)| keep(p)) {
            any.iter_mut().zip(s).for_each(|(a, &b)| *a |= b);
        }
        imaging::share_pct(&any)
    };
    let single: Vec<f64> = seen.iter().map(|s| imaging::share_pct(s)).collect();
    let imaged_pct = union(&is_planned);
    let every_pct = union(&|_| true);
    if args.json {
        let pairs: Vec<_> = every
            .iter()
            .zip(&single)
            .map(|(p, &s)| json!({"pair": p.name, "observed_pct": s, "imaged": is_planned(p)}))
            .collect();
        let report = json!({
            "scenario": name,
            "truth_points": world.truth.len(),
            "pairs": pairs,
            "imaged_pairs_pct": imaged_pct,
            "every_pairing_pct": every_pct,
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!(
        "{name}: share of the true surface ({} samples) each pairing observes; * the pairs \
         `reconstruct` images",
        world.truth.len()
    );
    let bs_names: Vec<&str> = sc.base_stations.iter().map(|b| b.name.as_str()).collect();
    print!("{:<10}", "aperture");
    for b in &bs_names {
        print!("{b:>10}");
    }
    println!();
    for (ai, ap) in sc.apertures.iter().enumerate() {
        print!("{:<10}", ap.name);
        for (p, s) in every.iter().zip(&single).filter(|(p, _)| p.aperture == ai) {
            let mark = if is_planned(p) { "*" } else { " " };
            print!("{:>9}{mark}", format!("{s:.1} %"));
        }
        println!();
    }
    println!("imaged pairs together:  {imaged_pct:.1} %");
    println!("every pairing together: {every_pct:.1} %");
    Ok(())
}
