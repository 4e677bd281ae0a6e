//! `has-sim paths`: propagation paths between one transmitter and one receiver in a scene file
//! (TOML `[scene]` table, see `has_host::scenario`, or a Sionna/Mitsuba XML, OBJ or PLY scene
//! read directly), printed one per line or as JSON. The JSON reports and the parsing of points
//! and receivers files are [`has_host::paths::report`]'s.

use std::path::PathBuf;

use glam::DVec3;
use has_host::paths::report::{self, PathsReport, ReceiversReport};
use has_host::paths::{CandidateMode, PathError, Tracer, TracerConfig};

/// Arguments of `has-sim paths`.
#[derive(clap::Args, Debug)]
pub struct PathsArgs {
    /// Scene file: TOML with a `[scene]` table, a Sionna RT / Mitsuba XML scene, or an OBJ or
    /// PLY mesh.
    #[arg(long)]
    pub scene: PathBuf,
    /// For an OBJ, PLY or XML scene: every object's radio material (ITU-R P.2040 name); a PLY
    /// file carries none and needs it.
    #[arg(long, value_parser = crate::scene_cmd::parse_material)]
    pub material: Option<has_host::Material>,
    /// Transmitter position "X,Y,Z" in metres.
    #[arg(long, allow_hyphen_values = true)]
    pub tx: String,
    /// Receiver position "X,Y,Z" in metres.
    #[arg(
        long,
        allow_hyphen_values = true,
        required_unless_present = "rx_file",
        conflicts_with = "rx_file"
    )]
    pub rx: Option<String>,
    /// Many receivers in one call: a text file with one "X,Y,Z" per line (metres; blank lines
    /// and lines starting with '#' skipped). The transmitter's candidates are searched once and
    /// every receiver traced in parallel; rows (and JSON entries) carry the receiver's index.
    #[arg(long)]
    pub rx_file: Option<PathBuf>,
    /// Highest number of reflections per path.
    #[arg(long, default_value_t = 3)]
    pub max_order: usize,
    /// Carrier frequency in GHz.
    #[arg(long, default_value_t = 10.0)]
    pub freq_ghz: f64,
    /// Shoot-and-bounce rays launched from the transmitter to find candidate facet sequences.
    #[arg(long, default_value_t = 200_000)]
    pub rays: usize,
    /// Enumerate every facet sequence instead of shooting rays (complete; small scenes only).
    #[arg(long)]
    pub exhaustive: bool,
    /// Print JSON `{"paths":[…]}` instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Also write the paths as NumPy arrays into this directory (`tau.npy`, `a.npy`, `jones.npy`,
    /// the angles, `num_paths.npy`, `rx.npy`: one row per receiver, one column per path;
    /// `has_host::paths::arrays`).
    #[arg(long)]
    pub npy: Option<PathBuf>,
    /// With --npy: the channel frequency response on this many subcarriers (`cfr.npy`, at the
    /// baseband offsets of `freqs_hz.npy`, ascending, centred on the carrier).
    #[arg(long, requires = "npy")]
    pub cfr_subcarriers: Option<usize>,
    /// Subcarrier spacing of --cfr-subcarriers, kHz.
    #[arg(long, default_value_t = 30.0, requires = "cfr_subcarriers")]
    pub cfr_spacing_khz: f64,
}

/// Parses `"X,Y,Z"` ([`report::parse_point`]) for flag `flag`.
fn parse_point(flag: &str, s: &str) -> anyhow::Result<DVec3> {
    report::parse_point(s).map_err(|e| anyhow::anyhow!("{flag}: {e}"))
}

/// A tracer result with its error prefixed by the flag it is about (the library names its
/// own fields: `tx`, `frequency_hz`, `sbr_rays`); `rx_flag` is the flag the receivers came
/// from (`--rx` or `--rx-file`).
fn traced<T>(r: Result<T, PathError>, rx_flag: &str) -> anyhow::Result<T> {
    r.map_err(|e| {
        let flag = match &e {
            PathError::NonFinitePosition { what, .. } | PathError::FarPosition { what, .. } => {
                if *what == "tx" {
                    "--tx"
                } else {
                    rx_flag
                }
            }
            PathError::MaterialFrequency { .. } => "--freq-ghz",
            PathError::OutOfRange { what, .. } => match *what {
                "sbr_rays" => "--rays",
                "max_order" => "--max-order",
                "frequency_hz" => "--freq-ghz",
                _ => "--scene",
            },
            PathError::TooLarge { .. } => "--exhaustive",
        };
        anyhow::anyhow!("{flag}: {e}")
    })
}

/// The baseband offsets of --cfr-subcarriers at --cfr-spacing-khz: `(k − N/2)·Δf`, k = 0..N,
/// for `receivers`; the band must stay above 0 Hz (half of it below the carrier), and the
/// arrays must fit in memory.
fn cfr_grid(args: &PathsArgs, receivers: usize) -> anyhow::Result<Option<Vec<f64>>> {
    let Some(n) = args.cfr_subcarriers else {
        return Ok(None);
    };
    if n == 0 || n > 1 << 20 {
        anyhow::bail!("--cfr-subcarriers: {n} is not in 1..={}", 1 << 20);
    }
    let df = args.cfr_spacing_khz * 1e3;
    if !(df.is_finite() && df > 0.0) {
        anyhow::bail!(
            "--cfr-spacing-khz: {} is not a positive spacing",
            args.cfr_spacing_khz
        );
    }
    let half_band = (n / 2).max(1) as f64 * df;
    if half_band >= args.freq_ghz * 1e9 {
        anyhow::bail!(
            "--cfr-spacing-khz: {} kHz × {n} subcarriers spans {:.4e} Hz, more than twice the \
             carrier (--freq-ghz {}): the band must lie above 0 Hz",
            args.cfr_spacing_khz,
            n as f64 * df,
            args.freq_ghz
        );
    }
    // Before tracing: the response alone, whatever the path count.
    has_host::paths::arrays::check_arrays_size(receivers, 0, n)
        .map_err(|e| anyhow::anyhow!("--cfr-subcarriers: {e}"))?;
    Ok(Some(
        (0..n).map(|k| (k as f64 - (n / 2) as f64) * df).collect(),
    ))
}

/// Runs `has-sim paths`.
pub fn run(args: PathsArgs) -> anyhow::Result<()> {
    let tx = parse_point("--tx", &args.tx)?;
    let rxs = match (&args.rx, &args.rx_file) {
        (Some(rx), _) => vec![parse_point("--rx", rx)?],
        (None, Some(file)) => {
            report::read_receivers(file).map_err(|e| anyhow::anyhow!("--rx-file: {e}"))?
        }
        (None, None) => anyhow::bail!("--rx or --rx-file is needed"),
    };
    if !(args.freq_ghz.is_finite() && args.freq_ghz > 0.0) {
        anyhow::bail!("--freq-ghz: {} is not a positive frequency", args.freq_ghz);
    }
    if args.max_order > has_host::paths::MAX_ORDER {
        anyhow::bail!(
            "--max-order: {} is above {}",
            args.max_order,
            has_host::paths::MAX_ORDER
        );
    }
    if args.rays == 0 {
        anyhow::bail!("--rays: 0 (need at least 1)");
    }
    let freqs = cfr_grid(&args, rxs.len())?;
    // Flattened into one line: the scene errors already name the file and the cause.
    let scene = has_host::scenario::load_scene(&args.scene, args.material)
        .map_err(|e| anyhow::anyhow!("--scene: {e}"))?;
    let rx_flag = if args.rx.is_some() {
        "--rx"
    } else {
        "--rx-file"
    };
    let tracer = traced(
        Tracer::new(
            &scene,
            TracerConfig {
                frequency_hz: args.freq_ghz * 1e9,
                max_order: args.max_order,
                candidates: if args.exhaustive {
                    CandidateMode::Exhaustive
                } else {
                    CandidateMode::Sbr { rays: args.rays }
                },
                ..TracerConfig::default()
            },
        ),
        rx_flag,
    )?;
    let ends =
        std::iter::once(("--tx".to_string(), tx)).chain(rxs.iter().enumerate().map(|(i, &p)| {
            let flag = if args.rx.is_some() {
                "--rx".to_string()
            } else {
                format!("--rx-file: receiver {i}")
            };
            (flag, p)
        }));
    for (flag, p) in ends {
        if let Some(o) = scene.enclosing_object(p.as_vec3()) {
            anyhow::bail!(
                "{flag}: ({}, {}, {}) lies inside or under object '{}' (every ray from it meets \
                 a surface from behind)",
                p.x,
                p.y,
                p.z,
                scene.objects[o as usize].name
            );
        }
    }
    let cand = traced(tracer.prepare_tx(tx), rx_flag)?;
    let all = traced(tracer.trace_many(&cand, &rxs), rx_flag)?;
    let lambda = has_host::wavelength_m(args.freq_ghz * 1e9);
    if rxs.iter().any(|&rx| (rx - tx).length() < lambda) {
        eprintln!(
            "note: a receiver within a wavelength of --tx (monostatic) has no line-of-sight path"
        );
    }
    let names: Vec<String> = scene.objects.iter().map(|o| o.name.clone()).collect();
    let search = report::Search {
        rays: (!args.exhaustive).then_some(args.rays),
        candidate_sequences: cand.len(),
    };
    if let Some(dir) = &args.npy {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow::anyhow!("--npy: {}: {e}", dir.display()))?;
        has_host::paths::arrays::write_path_arrays(dir, &rxs, &all, freqs.as_deref())
            .map_err(|e| anyhow::anyhow!("--npy: {e}"))?;
    }
    if args.json {
        // Compact, keys in the records' order (not through `serde_json::Value`, which sorts).
        let text = if args.rx.is_some() {
            serde_json::to_string(&PathsReport::new(&all[0], &names).with_search(search))?
        } else {
            serde_json::to_string(&ReceiversReport::new(&rxs, &all, &names).with_search(search))?
        };
        println!("{text}");
        return Ok(());
    }
    let many = args.rx.is_none();
    eprintln!(
        "{} candidate facet sequences from {}",
        search.candidate_sequences,
        search
            .rays
            .map_or("the exhaustive enumeration".to_string(), |r| format!(
                "{r} shoot-and-bounce rays (--rays)"
            ))
    );
    println!(
        "{}{:>4} {:>11} {:>9} {:>10} {:>8} {:>8} {:>8} {:>8}  interactions",
        if many {
            format!("{:>5} ", "rx")
        } else {
            String::new()
        },
        "#",
        "delay_ns",
        "gain_db",
        "phase_rad",
        "aod_deg",
        "zod_deg",
        "aoa_deg",
        "zoa_deg"
    );
    // The rows are the JSON's records ([`has_host::paths::PathRecord`]), in a table.
    for (r, paths) in all.iter().enumerate() {
        for (i, p) in PathsReport::new(paths, &names).paths.iter().enumerate() {
            let kinds: Vec<String> = (p.interactions.iter().zip(&p.objects))
                .map(|(&kind, object)| match (kind, object) {
                    ("reflection", Some(name)) => format!("reflection({name})"),
                    _ => kind.to_string(),
                })
                .collect();
            println!(
                "{}{:>4} {:>11.4} {:>9.2} {:>10.4} {:>8.2} {:>8.2} {:>8.2} {:>8.2}  {}",
                if many {
                    format!("{r:>5} ")
                } else {
                    String::new()
                },
                i,
                p.delay_ns,
                p.gain_db,
                p.phase_rad,
                p.aod_deg,
                p.zod_deg,
                p.aoa_deg,
                p.zoa_deg,
                kinds.join(" > ")
            );
        }
    }
    Ok(())
}
