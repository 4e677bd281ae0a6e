//! `has-sim bench raytrace`: the table (or JSON) of [`has_host::bench::raytrace::run`]: BVH
//! build time, closest-hit and visibility (any-hit) throughput on the deterministic benchmark
//! city, and paths per second, with one thread and with all threads.

use clap::{Args, Subcommand};
use has_host::bench::raytrace::BUILDINGS;
use has_host::bench::BenchRow;

/// Benchmark subcommands.
#[derive(Subcommand)]
pub enum BenchCmd {
    /// has-dsp kernels: FFT-1024 (f32, Q15), range compression, back-projection (f32, Q15, plain
    /// scalar loop) with SER against the f64 reference, 1 thread and all threads.
    Dsp {
        /// Shorter runs on smaller problems.
        #[arg(long)]
        quick: bool,
    },
    /// Ray-tracing throughput: BVH build, closest hit and visibility, 1 thread and all threads.
    Raytrace(RaytraceArgs),
    /// Channel tracing on a run's planar twin (RUN/twin.obj) against its Poisson mesh
    /// (RUN/mesh.obj), as `channel` traces a twin: scene, facets, candidates and UEs timed, the
    /// median of --repeats turns each, and the speed-up.
    Twin(TwinArgs),
    /// Screened Poisson: adaptive fine levels against full grids on the same noisy building.
    /// Echo synthesis: scatterer × element pairs per second of the fast (blocked) path against the
    /// plain one-path-at-a-time reference, 1 thread and all threads.
    Echo {
        /// Shorter runs on a smaller panel.
        #[arg(long)]
        quick: bool,
    },
    Mesh {
        /// Depth 7 instead of 8.
        #[arg(long)]
        quick: bool,
    },
    /// One reconstruction (default: the bundled factory) and its wall time by stage: setup,
    /// echo synthesis, back-projection, detection and fusion, surface, scoring.
    Pipeline {
        /// Scenario file (TOML). Default: the bundled fixtures/factory.toml.
        scenario: Option<std::path::PathBuf>,
        /// The scenario's quick preset.
        #[arg(long)]
        quick: bool,
    },
}

/// Options of `bench raytrace`.
#[derive(Args)]
pub struct RaytraceArgs {
    /// Ground heightfield cells per side (2·cells² triangles).
    #[arg(long, default_value_t = 240)]
    pub cells: u32,
    /// Rays (and visibility segments) per measurement.
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
    /// Seed of the scene and rays.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Scene of the paths-per-second measurement (500 UEs, order 3; see `has_host::bench::paths`).
    #[arg(long, default_value = "fixtures/city_block.toml")]
    pub paths_scene: std::path::PathBuf,
}

/// Options of `bench twin`.
#[derive(Args)]
pub struct TwinArgs {
    /// A `reconstruct` output directory holding twin.obj and mesh.obj.
    pub run: std::path::PathBuf,
    /// The run's scenario (TOML with a `[channel]` table). Default: the bundled
    /// fixtures/factory.toml.
    #[arg(long)]
    pub scenario: Option<std::path::PathBuf>,
    /// The `[channel.quick]` preset (fewer UEs, lower order, fewer rays).
    #[arg(long)]
    pub quick: bool,
    /// Turns of each mesh; every stage reports its median.
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Prints rows as an aligned table.
pub fn print_table(rows: &[BenchRow]) {
    println!(
        "{:<24} {:>7} {:>10} {:>10} {:>12} {:>10} {:>14}  note",
        "measurement", "threads", "count", "wall (s)", "per wall s", "cpu (s)", "per cpu s"
    );
    for r in rows {
        let (cpu, per_cpu) = match r.cpu_seconds {
            Some(c) if c > 0.0 => (format!("{c:.2}"), format!("{:.3e}", r.count as f64 / c)),
            _ => ("-".into(), "-".into()),
        };
        println!(
            "{:<24} {:>7} {:>10} {:>10.4} {:>12} {:>10} {:>14}  {}",
            r.name,
            r.threads,
            r.count,
            r.seconds,
            format!("{:.3e}", r.per_second),
            cpu,
            per_cpu,
            r.note
        );
    }
}

/// Runs a benchmark subcommand.
pub fn run(cmd: BenchCmd) -> anyhow::Result<()> {
    match cmd {
        BenchCmd::Raytrace(a) => raytrace(&a),
        BenchCmd::Twin(a) => twin(&a),
        BenchCmd::Dsp { quick } => crate::bench_dsp::run(quick),
        BenchCmd::Echo { quick } => crate::bench_dsp::run_echo(quick),
        BenchCmd::Mesh { quick } => crate::bench_mesh::run(quick),
        BenchCmd::Pipeline { scenario, quick } => crate::bench_pipeline::run(scenario, quick),
    }
}

fn raytrace(a: &RaytraceArgs) -> anyhow::Result<()> {
    if a.cells == 0 || a.rays == 0 {
        anyhow::bail!(
            "--cells ({}) and --rays ({}) must be positive",
            a.cells,
            a.rays
        );
    }
    let paths_scene = has_host::scenario::load_scene(&a.paths_scene, None)
        .map_err(|e| anyhow::anyhow!("--paths-scene: {e}"))?;
    let report = has_host::bench::raytrace::run(a.cells, a.rays, a.seed, &paths_scene)?;
    if a.json {
        let v = serde_json::to_value(&report)?;
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        let s = &report.scene;
        println!(
            "scene: {} triangles ({} objects: {}x{}-cell heightfield + {BUILDINGS} buildings), seed {}",
            s.triangles, s.objects, s.cells, s.cells, s.seed
        );
        print_table(&report.rows);
        println!(
            "per cpu s = count / process CPU time: the throughput per busy core, unaffected by \
             other processes competing for the cores (wall figures are)."
        );
    }
    Ok(())
}

fn twin(a: &TwinArgs) -> anyhow::Result<()> {
    use has_host::bench::twin_trace::MAX_REPEATS;
    if !(1..=MAX_REPEATS).contains(&a.repeats) {
        anyhow::bail!("--repeats {}: from 1 to {MAX_REPEATS}", a.repeats);
    }
    let (sc, spec, name) = crate::channel_cmd::load_channel(a.scenario.as_deref(), a.quick)?;
    // The loader's error names the file.
    let load = |file: &str| {
        has_host::io::load_objects(&a.run.join(file), Some(has_host::Material::Concrete))
    };
    let (twin, poisson) = (load("twin.obj")?, load("mesh.obj")?);
    let report = has_host::bench::twin_trace::run(&sc, &spec, &twin, &poisson, a.repeats)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!("has-sim bench twin — {name}, run {}\n", a.run.display());
        print!("{}", report.table());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_sizes_are_rejected_naming_the_option() {
        let e = run(BenchCmd::Raytrace(RaytraceArgs {
            cells: 0,
            rays: 10,
            seed: 1,
            json: false,
            paths_scene: "fixtures/city_block.toml".into(),
        }))
        .unwrap_err();
        assert!(e.to_string().contains("--cells (0)"), "{e}");
    }
}
