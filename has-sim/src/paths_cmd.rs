//! `has-sim paths`: propagation paths between one transmitter and one receiver in a scene file
//! (TOML `[scene]` table, see `has_host::scenario`, or a Sionna/Mitsuba XML, OBJ or PLY scene
//! read directly), printed one per line or as JSON.

use std::path::PathBuf;

use glam::DVec3;
use has_host::paths::{CandidateMode, Path, PathError, PathRecord, Tracer, TracerConfig};
use serde::Serialize;

/// Arguments of `has-sim paths`.
#[derive(clap::Args, Debug)]
pub struct PathsArgs {
    /// Scene file: TOML with a `[scene]` table, a Sionna RT / Mitsuba XML scene, or an OBJ or
    /// PLY mesh.
    #[arg(long)]
    pub scene: PathBuf,
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
}

/// Parses `"X,Y,Z"` (three finite numbers) for flag `flag`.
pub fn parse_point(flag: &str, s: &str) -> anyhow::Result<DVec3> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || anyhow::anyhow!("{flag}: '{s}' is not X,Y,Z (three finite numbers, metres)");
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut v = [0.0f64; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p.parse::<f64>().map_err(|_| bad())?;
        if !slot.is_finite() {
            return Err(bad());
        }
    }
    Ok(DVec3::from_array(v))
}

/// `has-sim paths --json` for one receiver: `{"paths":[…]}`, each path a
/// [`has_host::paths::PathRecord`] (keys in its documented order: `delay_ns, gain_db, phase_rad,
/// aod_deg, zod_deg, aoa_deg, zoa_deg, interactions, objects, points`; per interaction its kind,
/// the name of the object it meets and its point `[x, y, z]` in metres, `null` for line of sight).
#[derive(Serialize)]
pub struct PathsJson<'a> {
    /// The paths, by delay.
    pub paths: Vec<PathRecord<'a>>,
}

/// One receiver of `--rx-file`: its position and its paths.
#[derive(Serialize)]
pub struct ReceiverJson<'a> {
    /// The receiver, metres.
    pub rx: [f64; 3],
    /// Its paths, by delay.
    pub paths: Vec<PathRecord<'a>>,
}

/// `has-sim paths --rx-file … --json`: `{"receivers":[{"rx":[x,y,z],"paths":[…]}, …]}`.
#[derive(Serialize)]
pub struct ReceiversJson<'a> {
    /// Per receiver, in the file's order.
    pub receivers: Vec<ReceiverJson<'a>>,
}

/// The records of `paths`; `objects` names the scene's objects.
pub fn records<'a>(paths: &[Path], objects: &'a [String]) -> Vec<PathRecord<'a>> {
    paths.iter().map(|p| p.record(objects)).collect()
}

/// A tracer result with its error prefixed by the flag it is about (the library names its
/// own fields: `tx`, `frequency_hz`, `sbr_rays`).
fn traced<T>(r: Result<T, PathError>) -> anyhow::Result<T> {
    r.map_err(|e| {
        let flag = match &e {
            PathError::NonFinitePosition { what, .. } | PathError::FarPosition { what, .. } => {
                if *what == "tx" {
                    "--tx"
                } else {
                    "--rx"
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

/// Runs `has-sim paths`.
pub fn run(args: PathsArgs) -> anyhow::Result<()> {
    let tx = parse_point("--tx", &args.tx)?;
    let rxs = match (&args.rx, &args.rx_file) {
        (Some(rx), _) => vec![parse_point("--rx", rx)?],
        (None, Some(file)) => read_receivers(file)?,
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
    // Flattened into one line: the scene errors already name the file and the cause.
    let scene =
        has_host::scenario::load_scene(&args.scene).map_err(|e| anyhow::anyhow!("--scene: {e}"))?;
    let tracer = traced(Tracer::new(
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
    ))?;
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
    let cand = traced(tracer.prepare_tx(tx))?;
    let all = traced(tracer.trace_many(&cand, &rxs))?;
    let lambda = has_host::wavelength_m(args.freq_ghz * 1e9);
    if rxs.iter().any(|&rx| (rx - tx).length() < lambda) {
        eprintln!(
            "note: a receiver within a wavelength of --tx (monostatic) has no line-of-sight path"
        );
    }
    let names: Vec<String> = scene.objects.iter().map(|o| o.name.clone()).collect();
    if args.json {
        // Compact, keys in the records' order (not through `serde_json::Value`, which sorts).
        let text = if args.rx.is_some() {
            serde_json::to_string(&PathsJson {
                paths: records(&all[0], &names),
            })?
        } else {
            serde_json::to_string(&ReceiversJson {
                receivers: rxs
                    .iter()
                    .zip(&all)
                    .map(|(rx, paths)| ReceiverJson {
                        rx: rx.to_array(),
                        paths: records(paths, &names),
                    })
                    .collect(),
            })?
        };
        println!("{text}");
        return Ok(());
    }
    let many = args.rx.is_none();
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
    for (r, paths) in all.iter().enumerate() {
        for (i, p) in paths.iter().enumerate() {
            let kinds: Vec<String> = p
                .interactions
                .iter()
                .map(|it| match it {
                    has_host::paths::Interaction::Reflection { object, .. } => {
                        format!("reflection({})", names[*object as usize])
                    }
                    other => other.kind().to_string(),
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
                p.delay_s * 1e9,
                p.gain_db(),
                p.a.arg(),
                p.aod.to_degrees(),
                p.zod.to_degrees(),
                p.aoa.to_degrees(),
                p.zoa.to_degrees(),
                kinds.join(" > ")
            );
        }
    }
    Ok(())
}

/// The receivers of `--rx-file`: one "X,Y,Z" per line, blank lines and `#` comments skipped; a
/// bad line is an error naming its number.
fn read_receivers(path: &std::path::Path) -> anyhow::Result<Vec<DVec3>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow::anyhow!("--rx-file: {}: {e}", path.display()))?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let flag = format!("--rx-file: {} line {}", path.display(), n + 1);
        out.push(parse_point(&flag, l)?);
    }
    if out.is_empty() {
        anyhow::bail!("--rx-file: {}: no receivers", path.display());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_point_accepts_three_numbers_and_names_flag_otherwise() {
        assert_eq!(
            parse_point("--tx", "1, -2.5,3e1").unwrap(),
            DVec3::new(1.0, -2.5, 30.0)
        );
        for bad in ["1,2", "1,2,3,4", "a,b,c", "NaN,0,0", "1,inf,0", ""] {
            let e = parse_point("--rx", bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--rx: '{bad}'")), "{e}");
        }
    }

    #[test]
    fn json_has_documented_keys_in_order_and_parses() {
        let p = Path {
            delay_s: 1e-7,
            length_m: 29.979_245_8,
            a: num_complex::Complex64::new(0.0, 1e-3),
            jones: [[num_complex::Complex64::new(0.0, 0.0); 2]; 2],
            aod: 0.5,
            zod: 1.0,
            aoa: -0.5,
            zoa: 2.0,
            interactions: vec![has_host::paths::Interaction::Los],
        };
        let wall = Path {
            interactions: vec![has_host::paths::Interaction::Reflection {
                object: 1,
                facet: 0,
                point: DVec3::new(1.0, -2.5, 3.0),
            }],
            ..p.clone()
        };
        // A zero amplitude has no finite gain: written as null.
        let silent = Path {
            a: num_complex::Complex64::new(0.0, 0.0),
            ..p.clone()
        };
        let names = ["ground".to_string(), "wall \"A\"".to_string()];
        let s = serde_json::to_string(&PathsJson {
            paths: records(&[p, wall, silent], &names),
        })
        .unwrap();
        let v: serde_json::Value = serde_json::from_str(&s).unwrap();
        let o = &v["paths"][0];
        assert!((o["delay_ns"].as_f64().unwrap() - 100.0).abs() < 1e-9);
        assert!((o["gain_db"].as_f64().unwrap() + 60.0).abs() < 1e-9);
        assert!((o["phase_rad"].as_f64().unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(o["interactions"][0], "los");
        assert!(o["objects"][0].is_null() && o["points"][0].is_null());
        let r = &v["paths"][1];
        assert_eq!(r["interactions"][0], "reflection");
        assert_eq!(r["objects"][0], "wall \"A\"");
        let point: Vec<f64> = r["points"][0]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(point, [1.0, -2.5, 3.0]);
        assert!(v["paths"][2]["gain_db"].is_null(), "{s}");
        let keys = [
            "delay_ns",
            "gain_db",
            "phase_rad",
            "aod_deg",
            "zod_deg",
            "aoa_deg",
            "zoa_deg",
            "interactions",
            "objects",
            "points",
        ];
        let pos: Vec<usize> = keys
            .iter()
            .map(|k| s.find(&format!("\"{k}\"")).unwrap())
            .collect();
        assert!(pos.windows(2).all(|w| w[0] < w[1]), "{s}");
    }
}
