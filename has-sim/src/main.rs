//! `has-sim`: runs hybrid-aperture-sensing scenarios end to end and reports.
//!
//! The binary is thin: it parses arguments, shows progress, writes files and prints summaries;
//! the work lives in `has-host` and `has-dsp`. Every failure ends the process with exit code 1 and
//! one readable line on stderr; a command line clap cannot parse exits 2 with its usage text.
#![forbid(unsafe_code)]

use clap::{Parser, Subcommand};

mod bench_dsp;
mod bench_mesh;
mod bench_pipeline;
mod bench_raytrace;
mod channel_cmd;
mod html_report;
mod localize_cmd;
mod mesh_cmd;
mod observability_cmd;
mod paths_cmd;
mod plot;
mod reconstruct_cmd;
mod resources;
mod run_dir;
mod scene_cmd;
mod suite_cmd;
mod turn_cmd;
mod twin_cmd;

/// Hybrid aperture sensing simulator.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the ITU-R P.2040 radio materials with εr, σ and complex permittivity at a frequency.
    Materials {
        /// Frequency in GHz.
        #[arg(long, default_value_t = 10.0)]
        freq_ghz: f64,
    },
    /// Image the scenario (default: the bundled factory) with every base station–terminal pair,
    /// fuse the point clouds, score them against the true surfaces; write report, PLY and plots.
    Reconstruct(reconstruct_cmd::ReconstructArgs),
    /// Mesh a point cloud (PLY) by screened Poisson reconstruction; write OBJ (and PLY).
    Mesh(mesh_cmd::MeshArgs),
    /// Inspect a scene file or export it as a mesh (OBJ / PLY) for viewing.
    Scene {
        #[command(subcommand)]
        cmd: scene_cmd::SceneCmd,
    },
    /// Benchmarks (`bench dsp`, `bench echo`, `bench raytrace`, `bench mesh`, `bench pipeline`).
    Bench {
        #[command(subcommand)]
        cmd: bench_raytrace::BenchCmd,
    },
    /// Propagation paths (LOS, specular reflections) between a transmitter and a receiver.
    Paths(paths_cmd::PathsArgs),
    /// Channel prediction on the digital twin: ray-trace one BS to many UEs on the true scene
    /// and on the reconstructed mesh, match the multipath sets, report errors and beam selection.
    Channel(channel_cmd::ChannelArgs),
    /// Moving-target sensing by a monostatic base station: ECA vs the environment prior from the
    /// reconstructed twin (paper §3); report, detections PLY, Fig. 11-style plots.
    Localize(localize_cmd::LocalizeArgs),
    /// How much of the true surface each base station–aperture pairing could observe (line of
    /// sight of both legs), the pairs `reconstruct` would image, and all pairings together.
    Observability(observability_cmd::ObservabilityArgs),
    /// Reconstruct every site of the scenario suite (fixtures/suite/*.toml) and write one table
    /// (suite.json, suite.md) of cloud and mesh quality, observability, time and memory.
    Suite(suite_cmd::SuiteArgs),
    /// Write a scenario turned about a vertical axis (everything placed in the plane, the
    /// imaging region as a polygon), to check that results do not depend on the orientation.
    Turn(turn_cmd::TurnArgs),
    /// The planar twin of a finished `reconstruct` run: planes, footprint, roofs, a closed
    /// solid; written as OBJ, PLY and CityJSON 2.0 and scored beside the run's Poisson mesh.
    Twin(twin_cmd::TwinArgs),
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("has-sim: error: {}", one_line(&e));
        std::process::exit(1);
    }
}

/// An error and its causes on one line, joined by ": ", leaving out a cause whose text the line
/// already holds (a library error that prints its source and also returns it from `source()`
/// would otherwise repeat it).
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let c = cause.to_string();
        if line.contains(&c) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&c);
    }
    line
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Materials { freq_ghz } => materials(freq_ghz),
        Command::Mesh(a) => mesh_cmd::run(a),
        Command::Reconstruct(a) => reconstruct_cmd::run_command(a),
        Command::Scene { cmd } => scene_cmd::run(cmd),
        Command::Bench { cmd } => bench_raytrace::run(cmd),
        Command::Paths(args) => paths_cmd::run(args),
        Command::Channel(a) => channel_cmd::run(a),
        Command::Localize(a) => localize_cmd::run(a),
        Command::Observability(a) => observability_cmd::run(a),
        Command::Suite(a) => suite_cmd::run(a),
        Command::Turn(a) => turn_cmd::run(a),
        Command::Twin(a) => twin_cmd::run(a),
    }
}

fn materials(freq_ghz: f64) -> anyhow::Result<()> {
    if !(freq_ghz.is_finite() && freq_ghz > 0.0) {
        anyhow::bail!("--freq-ghz: {freq_ghz} is not a positive frequency");
    }
    // The fits hold only over their stated ranges; outside every one, no row means anything.
    let (lo, hi) = has_host::Material::all()
        .map(has_host::Material::valid_range_ghz)
        .fold((f64::INFINITY, 0.0f64), |(l, h), (a, b)| {
            (l.min(a), h.max(b))
        });
    if !(lo..=hi).contains(&freq_ghz) {
        anyhow::bail!(
            "--freq-ghz: {freq_ghz} GHz is outside every material's ITU-R P.2040 range \
             ({lo} … {hi} GHz)"
        );
    }
    let f = freq_ghz * 1e9;
    println!(
        "{:<20} {:>8} {:>12} {:>22}",
        "material", "εr", "σ (S/m)", "η = εr − jσ/(ε0ω)"
    );
    for m in has_host::Material::all() {
        let (a, b) = m.valid_range_ghz();
        if !(a..=b).contains(&freq_ghz) {
            println!(
                "{:<20} outside its fit's range, {a} … {b} GHz",
                format!("itu_{}", m.name())
            );
            continue;
        }
        let eta = m.complex_permittivity(f);
        println!(
            "{:<20} {:>8.3} {:>12.4e} {:>10.3} {:>+11.3e}j",
            format!("itu_{}", m.name()),
            m.relative_permittivity(f),
            m.conductivity(f),
            eta.re,
            eta.im
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::one_line;

    #[derive(Debug)]
    struct Inner;
    impl std::fmt::Display for Inner {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("inner: bad value 3")
        }
    }
    impl std::error::Error for Inner {}

    /// Prints its source and returns it from `source()`, as thiserror's `{0}` with `#[from]`.
    #[derive(Debug)]
    struct Outer(Inner);
    impl std::fmt::Display for Outer {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "scene: {}", self.0)
        }
    }
    impl std::error::Error for Outer {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn a_cause_the_message_already_holds_is_not_repeated() {
        let e = anyhow::Error::from(Outer(Inner)).context("--scene: f.toml");
        assert_eq!(one_line(&e), "--scene: f.toml: scene: inner: bad value 3");
        let plain = anyhow::anyhow!("one").context("two");
        assert_eq!(one_line(&plain), "two: one");
    }
}
