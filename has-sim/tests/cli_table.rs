//! Every bad input of issue 62 as one row: the command line, the exit code it must end with
//! (2: clap usage error; 1: input or run error; 0: the input is fine), a word its one-line
//! error must hold, and files that must not exist afterwards. Each command runs under a 6 GiB
//! address-space limit (`ulimit -v`, as the issue's sweep did with `prlimit --as`) and a
//! 120 s timeout: an abort, a hang or an allocation the size guard should have refused fails
//! the row.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Address-space limit of every run, KiB.
const LIMIT_KIB: u64 = 6 << 20;

/// One case.
struct Row {
    what: &'static str,
    args: Vec<String>,
    code: i32,
    word: &'static str,
    absent: Vec<PathBuf>,
    limit_kib: u64,
}

fn row(what: &'static str, args: &[&str], code: i32, word: &'static str) -> Row {
    Row {
        what,
        args: args.iter().map(|s| s.to_string()).collect(),
        code,
        word,
        absent: Vec::new(),
        limit_kib: LIMIT_KIB,
    }
}

impl Row {
    fn absent(mut self, files: &[&Path]) -> Row {
        self.absent = files.iter().map(|p| p.to_path_buf()).collect();
        self
    }

    /// Runs the row under `kib` of address space instead of [`LIMIT_KIB`].
    fn limit(mut self, kib: u64) -> Row {
        self.limit_kib = kib;
        self
    }
}

/// Runs has-sim with `args` under `limit_kib` of address space and the timeout; returns (exit
/// code, stderr). A signal or the timeout is reported as code -1 with what happened.
fn run(args: &[String], limit_kib: u64) -> (i32, String) {
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {limit_kib} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_has-sim"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("sh runs");
    let stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut std::io::BufReader::new(stderr), &mut s).ok();
        s
    });
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if t0.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let err = reader.join().unwrap();
    match status.and_then(|s| s.code()) {
        Some(c) => (c, err),
        None => (
            -1,
            format!("killed by a signal or the 120 s timeout\n{err}"),
        ),
    }
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures")
        .join(name)
}

/// `text` with `from` replaced by `to` once; panics when `from` is not in it, so that a
/// fixture edit cannot silently turn a row into a run of the unchanged scenario.
fn edit(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "fixture lacks {from:?}");
    text.replacen(from, to, 1)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

const WALL_PLY: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
    property float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\n\
    end_header\n0 5 0\n10 5 0\n10 5 6\n0 5 6\n3 0 1 2\n3 0 2 3\n";

#[test]
fn every_bad_input_of_the_issue_ends_as_its_row_says() {
    let d = std::env::temp_dir().join(format!("has-sim-cli-table-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let office = std::fs::read_to_string(fixture("suite/office_pair.toml")).unwrap();
    let factory = std::fs::read_to_string(fixture("factory.toml")).unwrap();
    let write = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let ground = "min = [-150.0, -150.0]\nmax = [150.0, 150.0]\nz = 0.0\n";
    let huge_ground = write(
        "huge_ground.toml",
        &edit(
            &office,
            ground,
            &format!("{ground}cells = [200000, 200000]\n"),
        ),
    );
    let cylinder = write(
        "cylinder.toml",
        &edit(
            &office,
            "[radar]",
            "[[scene.objects]]\nkind = \"cylinder\"\nname = \"mast\"\nmaterial = \"metal\"\n\
             center = [0.0, 40.0]\nradius = 1.0\nheight = 10.0\nsegments = 4000000000\n\n[radar]",
        ),
    );
    let teeth = write(
        "teeth.toml",
        &edit(
            &office,
            "yaw_deg = 20.0\nroof = { kind = \"pitched\", ridge = \"x\", height = 4.0 }",
            "yaw_deg = 20.0\nroof = { kind = \"sawtooth\", teeth = 4000000000, height = 2.0, \
             facing = \"+x\" }",
        ),
    );
    let fine_coarse = write(
        "fine_coarse.toml",
        &edit(&factory, "coarse_voxel_m = 1.0", "coarse_voxel_m = 0.01"),
    );
    let bad_bool = write(
        "bad_bool.toml",
        &edit(
            &factory,
            "coarse_voxel_m = 1.0",
            "coarse_voxel_m = 1.0\nsmear_centroid = \"yes\"",
        ),
    );
    let panels = write(
        "panels.toml",
        &edit(
            &office,
            "boresight_deg = 67.9\n",
            "boresight_deg = 67.9\nrows = 440\ncols = 440\n",
        ),
    );
    let ues = write(
        "ues.toml",
        &edit(&factory, "ues = 500\n", "ues = 1000000000000\n"),
    );
    let escape = write(
        "escape.toml",
        &edit(&office, "name = \"BS1\"", "name = \"../../../tmp/x\""),
    );
    let empty_name = write(
        "empty_name.toml",
        &edit(&office, "name = \"BS1\"", "name = \"\""),
    );
    let twice = write(
        "twice.toml",
        &edit(
            &office,
            "[radar]",
            "[[pairs]]\nbs = \"BS1\"\naperture = \"UAV\"\n\n[[pairs]]\nbs = \"BS1\"\n\
             aperture = \"UAV\"\n\n[radar]",
        ),
    );
    let bow_tie = write(
        "bow_tie.toml",
        &edit(
            &factory,
            "region_max = [40.0, 32.0, 16.0]\n",
            "region_max = [40.0, 32.0, 16.0]\n\
             region_polygon = [[-30.0, -20.0], [30.0, 20.0], [30.0, -10.0], [-30.0, 20.0]]\n",
        ),
    );
    let bad_toml = write("bad_scene.toml", "[scene]\nobjects = [[[\n");
    let wall = write("wall.ply", WALL_PLY);
    let cloud = d.join("cloud.ply");
    // A sphere of 800 points, radius 5 m: meshes at depth 5 in a moment.
    let n = 800;
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let mut pts = String::new();
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
        let (r, t) = ((1.0 - z * z).sqrt(), golden * i as f32);
        pts += &format!("{} {} {}\n", 5.0 * r * t.cos(), 5.0 * r * t.sin(), 5.0 * z);
    }
    std::fs::write(
        &cloud,
        format!(
            "ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n\
             property float z\nend_header\n{pts}"
        ),
    )
    .unwrap();
    let cloud_before = std::fs::read(&cloud).unwrap();
    let rx_many = write(
        "rx_many.csv",
        &(0..1000)
            .map(|i| format!("{},{},1.5\n", -40.0 + i as f64 * 0.05, -20.0))
            .collect::<String>(),
    );
    let rx_far = write("rx_far.csv", "1,2,1.5\n1e9,0,1.5\n");
    let npy = d.join("npy");
    std::fs::create_dir_all(npy.join("tau.npy")).unwrap();
    let out = |name: &str| d.join(name);
    let missing = d.join("missing_dir");

    let rows = vec![
        // Usage errors: clap's exit code 2.
        row("no subcommand", &[], 2, "Usage"),
        row("mesh without --out", &["mesh", s(&cloud)], 2, "--out"),
        row(
            "turn --deg not a number",
            &["turn", "--deg", "abc", "--out", "x.toml"],
            2,
            "--deg",
        ),
        // Aborts: sizes the guard refuses before allocating.
        row(
            "observability, ground cells",
            &["observability", s(&huge_ground)],
            1,
            "cells",
        ),
        row(
            "paths, ground cells",
            &[
                "paths",
                "--scene",
                s(&huge_ground),
                "--tx",
                "0,0,30",
                "--rx",
                "5,1,3",
            ],
            1,
            "cells",
        ),
        row(
            "scene export, ground cells",
            &[
                "scene",
                "export",
                "--scene",
                s(&huge_ground),
                "--out",
                s(&out("ground.obj")),
            ],
            1,
            "cells",
        )
        .absent(&[&out("ground.obj")]),
        row(
            "cylinder segments",
            &["observability", s(&cylinder)],
            1,
            "segments",
        ),
        row("sawtooth teeth", &["observability", s(&teeth)], 1, "teeth"),
        row(
            "coarse grid finer than the fine",
            &[
                "reconstruct",
                s(&fine_coarse),
                "--out",
                s(&out("fine_coarse")),
            ],
            1,
            "coarse_voxel_m",
        )
        .absent(&[&out("fine_coarse/report.json")]),
        row(
            "an imaging switch given a string",
            &["reconstruct", s(&bad_bool), "--out", s(&out("bad_bool"))],
            1,
            "smear_centroid = \"yes\"",
        )
        .absent(&[&out("bad_bool/report.json")]),
        // The quick preset's estimate, 4.7 GiB, is below MemAvailable on most machines: only
        // the address-space limit refuses it.
        row(
            "440 × 440 panels under a 2 GiB address-space limit",
            &[
                "reconstruct",
                s(&panels),
                "--quick",
                "--out",
                s(&out("panels")),
            ],
            1,
            "GiB available",
        )
        .limit(2 << 20)
        .absent(&[&out("panels/report.json")]),
        row(
            "cfr subcarriers × 1000 receivers",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--material",
                "concrete",
                "--tx",
                "5,0,3",
                "--rx-file",
                s(&rx_many),
                "--npy",
                s(&out("cfr")),
                "--cfr-subcarriers",
                "1048576",
                "--cfr-spacing-khz",
                "1",
            ],
            1,
            "--cfr-subcarriers",
        )
        .absent(&[&out("cfr/tau.npy"), &out("cfr/cfr.npy")]),
        row(
            "channel ues",
            &["channel", s(&ues), "--out", s(&out("ues"))],
            1,
            "channel.ues",
        )
        .absent(&[&out("ues/report.json")]),
        // Writing where it must not.
        row(
            "turn --out /dev/full",
            &[
                "turn",
                s(&fixture("suite/office_pair.toml")),
                "--deg",
                "10",
                "--out",
                "/dev/full",
            ],
            1,
            "not a regular file",
        ),
        row(
            "turn --out /dev/null",
            &[
                "turn",
                s(&fixture("suite/office_pair.toml")),
                "--deg",
                "10",
                "--out",
                "/dev/null",
            ],
            1,
            "not a regular file",
        ),
        row(
            "turn --out a directory",
            &[
                "turn",
                s(&fixture("suite/office_pair.toml")),
                "--deg",
                "10",
                "--out",
                s(&d),
            ],
            1,
            "directory",
        ),
        row(
            "mesh over its input",
            &["mesh", s(&cloud), "--out", s(&cloud), "--depth", "5"],
            1,
            "input",
        ),
        row(
            "a name with ..",
            &["observability", s(&escape)],
            1,
            "base_stations[0].name",
        ),
        // Silent wrong answers.
        row("a pair twice", &["observability", s(&twice)], 1, "pairs[1]"),
        row(
            "a site twice",
            &[
                "suite",
                "--sites",
                "office_pair,office_pair",
                "--out",
                s(&out("suite")),
            ],
            1,
            "named twice",
        )
        .absent(&[&out("suite/suite.json"), &out("suite/office_pair")]),
        row(
            "an empty name",
            &["observability", s(&empty_name)],
            1,
            "base_stations[0].name",
        ),
        row(
            "a crossing region polygon",
            &["observability", s(&bow_tie)],
            1,
            "region_polygon",
        ),
        row(
            "mesh --min-component NaN",
            &[
                "mesh",
                s(&cloud),
                "--out",
                s(&out("nan.obj")),
                "--min-component",
                "NaN",
            ],
            1,
            "--min-component",
        )
        .absent(&[&out("nan.obj")]),
        row(
            "materials --freq-ghz 1e30",
            &["materials", "--freq-ghz", "1e30"],
            1,
            "--freq-ghz",
        ),
        row(
            "paths --cfr-spacing-khz 1e30",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--material",
                "concrete",
                "--tx",
                "5,0,3",
                "--rx",
                "5,1,3",
                "--npy",
                s(&out("spacing")),
                "--cfr-subcarriers",
                "64",
                "--cfr-spacing-khz",
                "1e30",
            ],
            1,
            "--cfr-spacing-khz",
        )
        .absent(&[&out("spacing/tau.npy")]),
        // Partial or stale output.
        row(
            "paths --npy failing part-way",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--material",
                "concrete",
                "--tx",
                "5,0,3",
                "--rx",
                "5,1,3",
                "--npy",
                s(&npy),
            ],
            1,
            "tau.npy",
        )
        .absent(&[
            &npy.join("num_paths.npy"),
            &npy.join("rx.npy"),
            &npy.join("a.npy"),
        ]),
        row(
            "mesh --report into a missing directory",
            &[
                "mesh",
                s(&cloud),
                "--out",
                s(&out("r.obj")),
                "--report",
                s(&missing.join("r.json")),
            ],
            1,
            "--report",
        )
        .absent(&[&out("r.obj")]),
        row(
            "mesh --ply into a missing directory",
            &[
                "mesh",
                s(&cloud),
                "--out",
                s(&out("p.obj")),
                "--ply",
                s(&missing.join("p.ply")),
            ],
            1,
            "--ply",
        )
        .absent(&[&out("p.obj")]),
        // Errors that named the wrong thing.
        row(
            "mesh --cell 1e-5",
            &[
                "mesh",
                s(&cloud),
                "--out",
                s(&out("cell.obj")),
                "--cell",
                "1e-5",
            ],
            1,
            "--cell",
        )
        .absent(&[&out("cell.obj")]),
        row(
            "mesh clip box upside down",
            &[
                "mesh",
                s(&cloud),
                "--out",
                s(&out("clip.obj")),
                "--clip-min",
                "5",
                "5",
                "5",
                "--clip-max",
                "0",
                "0",
                "0",
            ],
            1,
            "--clip-max",
        )
        .absent(&[&out("clip.obj")]),
        row(
            "mesh --truth-density 1e12",
            &[
                "mesh",
                s(&cloud),
                "--out",
                s(&out("td.obj")),
                "--truth",
                s(&wall),
                "--truth-density",
                "1e12",
            ],
            1,
            "--truth-density",
        )
        .absent(&[&out("td.obj")]),
        row(
            "a far receiver of --rx-file",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--material",
                "concrete",
                "--tx",
                "5,0,3",
                "--rx-file",
                s(&rx_far),
            ],
            1,
            "--rx-file",
        ),
        row(
            "a PLY scene without a material",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--tx",
                "5,0,3",
                "--rx",
                "5,1,3",
            ],
            1,
            "--material",
        ),
        row(
            "a PLY scene with --material",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--material",
                "concrete",
                "--tx",
                "5,0,3",
                "--rx",
                "5,1,3",
            ],
            0,
            "",
        ),
        // `--shard I/N` needs whole numbers with 1 ≤ I ≤ N; refused before the output
        // directory is made.
        row(
            "shard 0 of 2",
            &[
                "reconstruct",
                "--quick",
                "--shard",
                "0/2",
                "--out",
                s(&out("shard_0_2")),
            ],
            1,
            "--shard: `0/2`",
        )
        .absent(&[&out("shard_0_2")]),
        row(
            "shard 3 of 2",
            &[
                "reconstruct",
                "--quick",
                "--shard",
                "3/2",
                "--out",
                s(&out("shard_3_2")),
            ],
            1,
            "--shard: `3/2`",
        )
        .absent(&[&out("shard_3_2")]),
        row(
            "shard a of b",
            &[
                "reconstruct",
                "--quick",
                "--shard",
                "a/b",
                "--out",
                s(&out("shard_a_b")),
            ],
            1,
            "--shard: `a/b`",
        )
        .absent(&[&out("shard_a_b")]),
        row(
            "shard 1 of 0",
            &[
                "reconstruct",
                "--quick",
                "--shard",
                "1/0",
                "--out",
                s(&out("shard_1_0")),
            ],
            1,
            "--shard: `1/0`",
        )
        .absent(&[&out("shard_1_0")]),
        row(
            "a shard that also fuses",
            &[
                "reconstruct",
                "--quick",
                "--shard",
                "1/2",
                "--from-pairs",
                s(&d),
                "--out",
                s(&out("shard_fuse")),
            ],
            2,
            "--shard",
        )
        .absent(&[&out("shard_fuse")]),
        row(
            "scene info on bad TOML: one line",
            &["scene", "info", "--scene", s(&bad_toml)],
            1,
            "bad_scene.toml",
        ),
    ];

    let mut failures = Vec::new();
    for r in &rows {
        let (code, err) = run(&r.args, r.limit_kib);
        let mut why = Vec::new();
        if code != r.code {
            why.push(format!("exit {code}, expected {}", r.code));
        }
        if code == 1 {
            // One readable line: exactly one error line, holding the word.
            let lines: Vec<&str> = err.lines().filter(|l| l.contains("error")).collect();
            if lines.len() != 1 || !lines[0].contains(r.word) {
                why.push(format!("error lines {lines:?} lack {:?}", r.word));
            }
            if err.contains("panicked") {
                why.push("panicked".into());
            }
        } else if !err.contains(r.word) {
            why.push(format!("stderr lacks {:?}", r.word));
        }
        for f in &r.absent {
            if f.exists() {
                why.push(format!("{} exists", f.display()));
            }
        }
        if !why.is_empty() {
            failures.push(format!(
                "{}: {}\n  stderr: {}",
                r.what,
                why.join("; "),
                err.trim()
            ));
        }
    }
    // What the rows must not have touched.
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        for dev in ["/dev/null", "/dev/full"] {
            if let Ok(m) = std::fs::metadata(dev) {
                assert!(m.file_type().is_char_device(), "{dev} replaced");
            }
        }
    }
    assert_eq!(
        std::fs::read(&cloud).unwrap(),
        cloud_before,
        "mesh overwrote its input"
    );
    assert!(!Path::new("/tmp/x-V1.ply").exists());
    let _ = std::fs::remove_dir_all(&d);
    assert!(
        failures.is_empty(),
        "{} of {} rows failed:\n{}",
        failures.len(),
        rows.len(),
        failures.join("\n")
    );
}
