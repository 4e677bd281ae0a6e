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

/// An ASCII PLY point cloud: `points` with the per-point `properties` (name, one value per
/// point).
fn ascii_cloud(points: &[[f32; 3]], properties: &[(&str, Vec<f32>)]) -> String {
    let mut text = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\n",
        points.len()
    );
    for (name, values) in properties {
        assert_eq!(values.len(), points.len());
        text += &format!("property float {name}\n");
    }
    text += "end_header\n";
    for (i, p) in points.iter().enumerate() {
        text += &format!("{} {} {}", p[0], p[1], p[2]);
        for (_, values) in properties {
            text += &format!(" {}", values[i]);
        }
        text += "\n";
    }
    text
}

/// Surface samples, `step` apart, of the box [-8, 8] × [-5, 5] × [0, 8] without its base.
fn block(step: f32) -> Vec<[f32; 3]> {
    let n = |l: f32| (l / step).round() as usize;
    let mut p = Vec::new();
    for i in 0..=n(16.0) {
        for j in 0..=n(10.0) {
            p.push([-8.0 + i as f32 * step, -5.0 + j as f32 * step, 8.0]);
        }
    }
    for k in 0..=n(8.0) {
        let z = k as f32 * step;
        for i in 0..=n(16.0) {
            let x = -8.0 + i as f32 * step;
            p.push([x, -5.0, z]);
            p.push([x, 5.0, z]);
        }
        for j in 0..=n(10.0) {
            let y = -5.0 + j as f32 * step;
            p.push([-8.0, y, z]);
            p.push([8.0, y, z]);
        }
    }
    p
}

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
    let imp_nan = write(
        "imp_nan.toml",
        &format!("{factory}\n[impairments]\ncfo_hz = nan\n"),
    );
    let imp_slow = write(
        "imp_slow.toml",
        &format!("{factory}\n[impairments]\nterminal_speed_m_per_s = 1e-30\n"),
    );
    let imp_bias = write(
        "imp_bias.toml",
        &format!(
            "{factory}\n[impairments]\nposition_error = {{ bias_m = 1e30, gm_m = 0.0, gm_tau_s = 1.0, white_m = 0.0 }}\n"
        ),
    );
    let bad_clutter = write(
        "bad_clutter.toml",
        &edit(
            &factory,
            "coarse_voxel_m = 1.0",
            "coarse_voxel_m = 1.0\nground_clutter = \"rough\"",
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
    // A mesh object of the scene, placed by `extra`, loaded from `path` beside the file.
    let with_mesh = |name: &str, path: &str, extra: &str| {
        write(
            name,
            &edit(
                &office,
                "[radar]",
                &format!(
                    "[[scene.objects]]\nkind = \"mesh\"\npath = \"{path}\"\n\
                     material = \"metal\"\n{extra}\n\n[radar]"
                ),
            ),
        )
    };
    let yaw_nan = with_mesh("yaw_nan.toml", "wall.ply", "yaw_deg = nan");
    let yaw_huge = with_mesh("yaw_huge.toml", "wall.ply", "yaw_deg = 1e30");
    std::fs::create_dir_all(d.join("dir.ply")).unwrap();
    let mesh_dir = with_mesh("mesh_dir.toml", "dir.ply", "");
    let known_up = write(
        "known_up.toml",
        &edit(
            &factory,
            "\n[localize]\n",
            "\n[localize]\nknown_objects = [\"../../etc/passwd\"]\n",
        ),
    );
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
    let rx_bad = write("rx_bad.csv", "1,2,1.5\n3,4\n");
    let reduced_deg = 1e30f64.rem_euclid(360.0).to_string();
    // A binary PLY whose second element has 2⁶⁴ − 1 instances and no property: no instance
    // takes a byte, so no end of file stopped the reader.
    let no_props = d.join("no_props.ply");
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
        property float y\nproperty float z\nelement junk 18446744073709551615\nend_header\n"
        .to_vec();
    bytes.extend_from_slice(&[0u8; 36]);
    std::fs::write(&no_props, bytes).unwrap();
    // A finished run for `twin`: the block's 0.5 m voxel centres as fused.ply (with `weight`),
    // its surface samples as the truth, and a report.json naming the bundled factory scenario.
    // The row "twin of a made run directory" shows it is whole, so that each row below fails
    // on the one file it spoils.
    let run_dir = d.join("run");
    std::fs::create_dir_all(&run_dir).unwrap();
    let mut voxels: Vec<[i32; 3]> = block(0.1)
        .iter()
        .map(|p| p.map(|c| (c / 0.5).floor() as i32))
        .collect();
    voxels.sort_unstable();
    voxels.dedup();
    let fused: Vec<[f32; 3]> = voxels
        .iter()
        .map(|k| k.map(|c| (c as f32 + 0.5) * 0.5))
        .filter(|p| p[2] > 0.5)
        .collect();
    let weights = vec![1.0; fused.len()];
    std::fs::write(
        run_dir.join("fused.ply"),
        ascii_cloud(&fused, &[("weight", weights)]),
    )
    .unwrap();
    std::fs::write(
        run_dir.join("ground_truth.ply"),
        ascii_cloud(&block(1.0 / 3.0), &[]),
    )
    .unwrap();
    let report = format!(
        "{{\"scenario\": {:?}, \"preset\": \"quick\", \"seed\": 1, \"imaging\": {{\"voxel_m\": 0.5}}, \
         \"mesh\": {{\"sqrt_chamfer_m\": 0.5, \"fscore_1_5m\": 99.0, \
         \"false_surface_pct_1_5m\": 1.0, \"faces\": 1000, \"sample_density_per_m2\": 9.0}}}}",
        s(&fixture("factory.toml"))
    );
    std::fs::write(run_dir.join("report.json"), &report).unwrap();
    // The same run with one file spoilt.
    let spoilt = |name: &str, file: &str, spoil: &dyn Fn(&Path)| {
        let dir = d.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        for f in ["fused.ply", "ground_truth.ply", "report.json"] {
            if f == file {
                spoil(&dir.join(f));
            } else {
                std::fs::copy(run_dir.join(f), dir.join(f)).unwrap();
            }
        }
        dir
    };
    let mkdir = |p: &Path| std::fs::create_dir(p).unwrap();
    let report_dir = spoilt("run_report_dir", "report.json", &mkdir);
    let truth_dir = spoilt("run_truth_dir", "ground_truth.ply", &mkdir);
    // The whole run with one pair cloud added (the twin reads `pair_*.ply` to orient walls).
    let with_pair = |name: &str, pair_file: &str, spoil: &dyn Fn(&Path)| {
        let dir = spoilt(name, "", &|_| {});
        spoil(&dir.join(pair_file));
        dir
    };
    let pair_dir = with_pair("run_pair_dir", "pair_BS1-V1.ply", &mkdir);
    let pair_stray = with_pair("run_pair_stray", "pair_BS9-X.ply", &|p| {
        std::fs::copy(run_dir.join("fused.ply"), p).unwrap();
    });
    // Pair clouds of a made run of `site.toml` (office_pair imaging one pair, BS1-UAV): a
    // 0.5 m grid on the flat block's roof, its report.json recording the digest of the
    // scenario at the quick preset, as `reconstruct` records it. The row "--from-pairs of a
    // made run" shows it is accepted; a scenario of the same file name and other content, or
    // another seed, must not be.
    let one_pair = edit(
        &office,
        "[radar]",
        "[[pairs]]\nbs = \"BS1\"\naperture = \"UAV\"\n\n[radar]",
    );
    std::fs::create_dir_all(d.join("a")).unwrap();
    std::fs::create_dir_all(d.join("b")).unwrap();
    let site = write("a/site.toml", &one_pair);
    let other_site = write(
        "b/site.toml",
        &edit(&one_pair, "snr_db = 10.0", "snr_db = 12.0"),
    );
    let digest = {
        let mut sc = has_host::scenario::Scenario::load(&site).unwrap();
        sc.apply_quick();
        (sc.digest().unwrap(), sc.imaging.seed)
    };
    let (cos, sin) = (20f32.to_radians().cos(), 20f32.to_radians().sin());
    let roof: Vec<[f32; 3]> = (0..33)
        .flat_map(|i| (0..53).map(move |j| (-8.0 + 0.5 * i as f32, -13.0 + 0.5 * j as f32)))
        .map(|(u, v)| [13.63 + cos * u - sin * v, 4.96 + sin * u + cos * v, 13.0])
        .collect();
    let pairs_run = |name: &str, points: &[[f32; 3]]| {
        let dir = d.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        let intensity = vec![0.5; points.len()];
        std::fs::write(
            dir.join("pair_BS1-UAV.ply"),
            ascii_cloud(points, &[("intensity", intensity)]),
        )
        .unwrap();
        std::fs::write(
            dir.join("report.json"),
            format!(
                "{{\"scenario\": {:?}, \"preset\": \"quick\", \"scenario_digest\": {:?}, \
                 \"seed\": {}, \"imaging\": {{\"pairs\": [{{\"name\": \"BS1-UAV\"}}]}}}}",
                s(&site),
                digest.0,
                digest.1
            ),
        )
        .unwrap();
        dir
    };
    let pairs = pairs_run("pairs", &roof);
    let far: Vec<[f32; 3]> = roof.iter().map(|p| [p[0] + 5000.0, p[1], p[2]]).collect();
    let pairs_far = pairs_run("pairs_far", &far);
    let mut huge = roof.clone();
    huge[0] = [1e30, 0.0, 5.0];
    let pairs_huge = pairs_run("pairs_huge", &huge);
    let pairs_shard_dir = pairs_run("pairs_shard_dir", &roof);
    std::fs::create_dir(pairs_shard_dir.join("shard.json")).unwrap();

    let mut rows = vec![
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
        row(
            "a ground clutter model that does not exist",
            &[
                "reconstruct",
                s(&bad_clutter),
                "--out",
                s(&out("bad_clutter")),
            ],
            1,
            "ground_clutter = \"rough\"",
        )
        .absent(&[&out("bad_clutter/report.json")]),
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
        // `[impairments]`: each field bounded, named in the error; `--no-compensation` needs
        // impairments to leave alone.
        row(
            "impairments: a NaN carrier offset",
            &[
                "reconstruct",
                s(&imp_nan),
                "--quick",
                "--out",
                s(&out("imp_nan")),
            ],
            1,
            "impairments.cfo_hz",
        )
        .absent(&[&out("imp_nan")]),
        row(
            "impairments: a terminal at 1e-30 m/s",
            &[
                "reconstruct",
                s(&imp_slow),
                "--quick",
                "--out",
                s(&out("imp_slow")),
            ],
            1,
            "impairments.terminal_speed_m_per_s",
        )
        .absent(&[&out("imp_slow")]),
        row(
            "impairments: a 1e30 m position bias",
            &[
                "reconstruct",
                s(&imp_bias),
                "--quick",
                "--out",
                s(&out("imp_bias")),
            ],
            1,
            "impairments.position_error.bias_m",
        )
        .absent(&[&out("imp_bias")]),
        row(
            "--no-compensation without impairments",
            &[
                "reconstruct",
                "--quick",
                "--no-compensation",
                "--out",
                s(&out("no_comp")),
            ],
            1,
            "--no-compensation",
        )
        .absent(&[&out("no_comp")]),
        row(
            "suite --no-compensation without --impairments",
            &[
                "suite",
                "--quick",
                "--no-compensation",
                "--out",
                s(&out("suite_nc")),
            ],
            2,
            "--impairments",
        )
        .absent(&[&out("suite_nc")]),
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
        // Sizes through the guard in the other commands that build a scene.
        row(
            "paths, cylinder segments",
            &[
                "paths",
                "--scene",
                s(&cylinder),
                "--tx",
                "0,0,30",
                "--rx",
                "5,1,3",
            ],
            1,
            "segments",
        ),
        row(
            "scene export, cylinder segments",
            &[
                "scene",
                "export",
                "--scene",
                s(&cylinder),
                "--out",
                s(&out("cylinder.obj")),
            ],
            1,
            "segments",
        )
        .absent(&[&out("cylinder.obj")]),
        row(
            "paths, sawtooth teeth",
            &[
                "paths",
                "--scene",
                s(&teeth),
                "--tx",
                "0,0,30",
                "--rx",
                "5,1,3",
            ],
            1,
            "teeth",
        ),
        row(
            "scene export, sawtooth teeth",
            &[
                "scene",
                "export",
                "--scene",
                s(&teeth),
                "--out",
                s(&out("teeth.obj")),
            ],
            1,
            "teeth",
        )
        .absent(&[&out("teeth.obj")]),
        // A bad line of --rx-file names the file and the line, not --rx.
        row(
            "a malformed --rx-file line",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--material",
                "concrete",
                "--tx",
                "5,0,3",
                "--rx-file",
                s(&rx_bad),
            ],
            1,
            "--rx-file: ",
        ),
        row(
            "the malformed --rx-file line is named",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--material",
                "concrete",
                "--tx",
                "5,0,3",
                "--rx-file",
                s(&rx_bad),
            ],
            1,
            "rx_bad.csv line 2: '3,4'",
        ),
        // A PLY twin is read as PLY (it was read as OBJ: "no faces").
        row(
            "channel --twin wall.ply",
            &[
                "channel",
                "--quick",
                "--twin",
                s(&wall),
                "--out",
                s(&out("ply_twin")),
            ],
            0,
            "",
        ),
        // A finer mesh cell than the cascade's levels allow meshes with fewer levels, from
        // `mesh --cell` and from `reconstruct --mesh-cell` alike.
        row(
            "mesh --cell 10",
            &[
                "mesh",
                s(&cloud),
                "--out",
                s(&out("cell10.obj")),
                "--cell",
                "10",
            ],
            0,
            "",
        ),
        // --from-pairs compares the content (the digest of scenario, preset and seed).
        row(
            "--from-pairs of a made run",
            &[
                "reconstruct",
                s(&site),
                "--quick",
                "--no-mesh",
                "--from-pairs",
                s(&pairs),
                "--out",
                s(&out("fused_ok")),
            ],
            0,
            "",
        ),
        row(
            "--from-pairs with --mesh-cell 10",
            &[
                "reconstruct",
                s(&site),
                "--quick",
                "--mesh-cell",
                "10",
                "--from-pairs",
                s(&pairs),
                "--out",
                s(&out("mesh_cell_10")),
            ],
            0,
            "",
        ),
        row(
            "--from-pairs of another scenario of the same file name",
            &[
                "reconstruct",
                s(&other_site),
                "--quick",
                "--no-mesh",
                "--from-pairs",
                s(&pairs),
                "--out",
                s(&out("other_site")),
            ],
            1,
            "scenario digest",
        )
        .absent(&[&out("other_site")]),
        row(
            "--from-pairs with another --seed",
            &[
                "reconstruct",
                s(&site),
                "--quick",
                "--no-mesh",
                "--seed",
                "5",
                "--from-pairs",
                s(&pairs),
                "--out",
                s(&out("other_seed")),
            ],
            1,
            "seed 5",
        )
        .absent(&[&out("other_seed")]),
        row(
            "--from-pairs, a pair cloud 5 km away",
            &[
                "reconstruct",
                s(&site),
                "--quick",
                "--no-mesh",
                "--from-pairs",
                s(&pairs_far),
                "--out",
                s(&out("far")),
            ],
            1,
            "pairs_far/pair_BS1-UAV.ply",
        )
        .absent(&[&out("far/report.json"), &out("far/fused.ply")]),
        row(
            "--from-pairs, a pair cloud with a point at 1e30",
            &[
                "reconstruct",
                s(&site),
                "--quick",
                "--no-mesh",
                "--from-pairs",
                s(&pairs_huge),
                "--out",
                s(&out("huge")),
            ],
            1,
            "pairs_huge/pair_BS1-UAV.ply",
        )
        .absent(&[&out("huge/report.json"), &out("huge/fused.ply")]),
        row(
            "--from-pairs, shard.json a directory",
            &[
                "reconstruct",
                s(&site),
                "--quick",
                "--no-mesh",
                "--from-pairs",
                s(&pairs_shard_dir),
                "--out",
                s(&out("shard_dir")),
            ],
            1,
            "shard.json: is a directory",
        )
        .absent(&[&out("shard_dir")]),
        // `twin RUN_DIR`: a directory or a device where a file should be.
        row(
            "twin of a made run directory",
            &["twin", s(&run_dir), "--out", s(&out("twin_ok"))],
            0,
            "",
        ),
        row(
            "twin of /dev/null",
            &["twin", "/dev/null", "--out", s(&out("twin_null"))],
            1,
            "/dev/null/report.json",
        )
        .absent(&[&out("twin_null")]),
        row(
            "twin of a file",
            &["twin", s(&wall), "--out", s(&out("twin_file"))],
            1,
            "wall.ply/report.json",
        )
        .absent(&[&out("twin_file")]),
        row(
            "twin, report.json a directory",
            &["twin", s(&report_dir), "--out", s(&out("twin_rd"))],
            1,
            "report.json: is a directory",
        )
        .absent(&[&out("twin_rd")]),
        row(
            "twin, ground_truth.ply a directory",
            &["twin", s(&truth_dir), "--out", s(&out("twin_td"))],
            1,
            "ground_truth.ply: is a directory",
        )
        .absent(&[&out("twin_td")]),
        row(
            "twin, a pair cloud a directory",
            &["twin", s(&pair_dir), "--out", s(&out("twin_pd"))],
            1,
            "pair_BS1-V1.ply: is a directory",
        )
        .absent(&[&out("twin_pd")]),
        row(
            "twin, a pair cloud naming no pair of the scenario",
            &["twin", s(&pair_stray), "--out", s(&out("twin_ps"))],
            1,
            "pair_BS9-X.ply names no base station",
        )
        .absent(&[&out("twin_ps")]),
        row(
            "twin --material ../concrete",
            &[
                "twin",
                s(&run_dir),
                "--out",
                s(&out("twin_m1")),
                "--material",
                "../concrete",
            ],
            1,
            "--material = ../concrete",
        )
        .absent(&[&out("twin_m1")]),
        row(
            "twin --material NaN",
            &[
                "twin",
                s(&run_dir),
                "--out",
                s(&out("twin_m2")),
                "--material",
                "NaN",
            ],
            1,
            "not an ITU radio material",
        )
        .absent(&[&out("twin_m2")]),
        row(
            "twin --material ''",
            &[
                "twin",
                s(&run_dir),
                "--out",
                s(&out("twin_m3")),
                "--material",
                "",
            ],
            1,
            "--material = :",
        )
        .absent(&[&out("twin_m3")]),
        row(
            "twin --out /dev/null",
            &["twin", s(&run_dir), "--out", "/dev/null"],
            1,
            "/dev/null",
        ),
        row(
            "twin --out a file",
            &["twin", s(&run_dir), "--out", s(&wall)],
            1,
            "wall.ply",
        ),
        // A huge angle turns positions and boresights alike: the scenario turned by 1e30° is
        // the one turned by 1e30 mod 360 (16°), line for line after the heading that names the
        // angle (checked after the rows).
        row(
            "turn --deg 1e30",
            &[
                "turn",
                s(&fixture("suite/office_pair.toml")),
                "--deg",
                "1e30",
                "--out",
                s(&out("turn_1e30.toml")),
            ],
            0,
            "",
        ),
        row(
            "turn --deg (1e30 mod 360)",
            &[
                "turn",
                s(&fixture("suite/office_pair.toml")),
                "--deg",
                &reduced_deg,
                "--out",
                s(&out("turn_reduced.toml")),
            ],
            0,
            "",
        ),
        // Found by the parser fuzzing: a hang.
        row(
            "a PLY element with 2^64 - 1 instances and no property",
            &["mesh", s(&no_props), "--out", s(&out("no_props.obj"))],
            1,
            "element 'junk'",
        )
        .absent(&[&out("no_props.obj")]),
        // More usage errors: clap's exit code 2 with its usage text or a hint.
        row(
            "bench twin, no repeats",
            &["bench", "twin", "fixtures", "--repeats", "0"],
            1,
            "--repeats 0",
        ),
        row(
            "bench twin, a huge repeat count",
            &["bench", "twin", "fixtures", "--repeats", "1000000000"],
            1,
            "--repeats 1000000000",
        ),
        row(
            "bench twin, repeats not a number",
            &["bench", "twin", "fixtures", "--repeats", "1e30"],
            2,
            "--repeats",
        ),
        row(
            "bench twin, a run without a twin",
            &["bench", "twin", "fixtures"],
            1,
            "twin.obj",
        ),
        row(
            "bench twin, a device as the run",
            &["bench", "twin", "/dev/null"],
            1,
            "twin.obj",
        ),
        row(
            "bench twin, a run up the tree",
            &["bench", "twin", "../no/such/run"],
            1,
            "twin.obj",
        ),
        row("an unknown subcommand", &["frobnicate"], 2, "frobnicate"),
        row("scene without its subcommand", &["scene"], 2, "Usage"),
        row(
            "an unknown flag",
            &["observability", "--bogus"],
            2,
            "--bogus",
        ),
        row(
            "--seed not a number",
            &["reconstruct", "--seed", "abc", "--out", s(&out("u1"))],
            2,
            "--seed",
        )
        .absent(&[&out("u1")]),
        row(
            "--seed negative",
            &["reconstruct", "--seed", "-1", "--out", s(&out("u2"))],
            2,
            "'-1'",
        )
        .absent(&[&out("u2")]),
        row(
            "--from-pairs without a directory",
            &["reconstruct", "--out", s(&out("u3")), "--from-pairs"],
            2,
            "--from-pairs",
        )
        .absent(&[&out("u3")]),
        row(
            "--cfr-subcarriers not a number",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--tx",
                "5,0,3",
                "--rx",
                "5,1,3",
                "--cfr-subcarriers",
                "abc",
            ],
            2,
            "--cfr-subcarriers",
        ),
        row(
            "--cfr-spacing-khz without a value",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--tx",
                "5,0,3",
                "--rx",
                "5,1,3",
                "--cfr-spacing-khz",
            ],
            2,
            "--cfr-spacing-khz",
        ),
        row(
            "--npy without a directory",
            &[
                "paths",
                "--scene",
                s(&wall),
                "--tx",
                "5,0,3",
                "--rx",
                "5,1,3",
                "--npy",
            ],
            2,
            "--npy",
        ),
        row(
            "--clip-min with two values",
            &[
                "mesh",
                s(&cloud),
                "--out",
                s(&out("u4.obj")),
                "--clip-min",
                "5",
                "5",
            ],
            2,
            "--clip-min",
        )
        .absent(&[&out("u4.obj")]),
        row(
            "--min-component not a number",
            &[
                "mesh",
                s(&cloud),
                "--out",
                s(&out("u5.obj")),
                "--min-component",
                "abc",
            ],
            2,
            "--min-component",
        )
        .absent(&[&out("u5.obj")]),
        row(
            "suite --sites without a value",
            &["suite", "--out", s(&out("u6")), "--sites"],
            2,
            "--sites",
        )
        .absent(&[&out("u6")]),
        row(
            "turn without --deg",
            &[
                "turn",
                s(&fixture("suite/office_pair.toml")),
                "--out",
                s(&out("u7.toml")),
            ],
            2,
            "--deg",
        )
        .absent(&[&out("u7.toml")]),
        row(
            "turn without --out",
            &["turn", s(&fixture("suite/office_pair.toml")), "--deg", "10"],
            2,
            "--out",
        ),
        row(
            "twin without RUN_DIR",
            &["twin", "--out", s(&out("u8"))],
            2,
            "RUN_DIR",
        )
        .absent(&[&out("u8")]),
        row(
            "materials --freq-ghz without a value",
            &["materials", "--freq-ghz"],
            2,
            "--freq-ghz",
        ),
        row(
            "observability given two scenarios",
            &[
                "observability",
                s(&fixture("suite/office_pair.toml")),
                s(&fixture("factory.toml")),
            ],
            2,
            "factory.toml",
        ),
        // A mesh object's placement and a known object's name.
        row(
            "scene info: a mesh's yaw_deg NaN",
            &["scene", "info", "--scene", s(&yaw_nan)],
            1,
            "yaw_deg",
        ),
        row(
            "turn: a mesh's yaw_deg NaN",
            &[
                "turn",
                s(&yaw_nan),
                "--deg",
                "10",
                "--out",
                s(&out("yaw_nan_turned.toml")),
            ],
            1,
            "yaw_deg",
        )
        .absent(&[&out("yaw_nan_turned.toml")]),
        row(
            "turn: a mesh's yaw_deg 1e30 is an angle",
            &[
                "turn",
                s(&yaw_huge),
                "--deg",
                "10",
                "--out",
                s(&out("yaw_huge_turned.toml")),
            ],
            0,
            "",
        ),
        row(
            "turn: a mesh path that is a directory",
            &[
                "turn",
                s(&mesh_dir),
                "--deg",
                "10",
                "--out",
                s(&out("mesh_dir_turned.toml")),
            ],
            1,
            "dir.ply",
        )
        .absent(&[&out("mesh_dir_turned.toml")]),
        row(
            "localize: a known object named '../../etc/passwd'",
            &[
                "localize",
                s(&known_up),
                "--quick",
                "--truth-twin",
                "--out",
                s(&out("known_up")),
            ],
            1,
            "localize.known_objects",
        )
        .absent(&[&out("known_up/report.json")]),
    ];
    // Devices where a run reads or writes a file. Written ones are reached through a symbolic
    // link in the scratch directory: a writer that renamed over them (the defect these rows
    // catch) replaces the link there, not the device node, even when the table runs as root.
    #[cfg(unix)]
    {
        use std::os::unix::fs::symlink;
        let link = |name: &str, to: &str| {
            let p = d.join(name);
            symlink(to, &p).unwrap();
            p
        };
        let (full_toml, null_toml) = (
            link("full.toml", "/dev/full"),
            link("null.toml", "/dev/null"),
        );
        let (full_obj, null_ply) = (link("full.obj", "/dev/full"), link("null.ply", "/dev/null"));
        rows.extend([
            row(
                "turn --out a link to /dev/full",
                &[
                    "turn",
                    s(&fixture("suite/office_pair.toml")),
                    "--deg",
                    "10",
                    "--out",
                    s(&full_toml),
                ],
                1,
                "not a regular file",
            ),
            row(
                "turn --out a link to /dev/null",
                &[
                    "turn",
                    s(&fixture("suite/office_pair.toml")),
                    "--deg",
                    "10",
                    "--out",
                    s(&null_toml),
                ],
                1,
                "not a regular file",
            ),
            row(
                "mesh --out a link to /dev/full",
                &["mesh", s(&cloud), "--out", s(&full_obj), "--depth", "5"],
                1,
                "not a regular file",
            ),
            row(
                "mesh --ply a link to /dev/null",
                &[
                    "mesh",
                    s(&cloud),
                    "--out",
                    s(&out("devply.obj")),
                    "--depth",
                    "5",
                    "--ply",
                    s(&null_ply),
                ],
                1,
                "not a regular file",
            )
            .absent(&[&out("devply.obj")]),
        ]);
        let zero_report = spoilt("run_zero_report", "report.json", &|p| {
            symlink("/dev/zero", p).unwrap()
        });
        let zero_fused = spoilt("run_zero_fused", "fused.ply", &|p| {
            symlink("/dev/zero", p).unwrap()
        });
        let zero_pair = with_pair("run_zero_pair", "pair_BS1-V1.ply", &|p| {
            symlink("/dev/zero", p).unwrap()
        });
        let twin_null = d.join("twin_into_null");
        std::fs::create_dir_all(&twin_null).unwrap();
        symlink("/dev/null", twin_null.join("twin.obj")).unwrap();
        let pairs_zero = d.join("pairs_zero");
        std::fs::create_dir_all(&pairs_zero).unwrap();
        symlink("/dev/zero", pairs_zero.join("report.json")).unwrap();
        let export_null = d.join("export_null.obj");
        symlink("/dev/null", &export_null).unwrap();
        let npy_null = d.join("npy_null");
        std::fs::create_dir_all(&npy_null).unwrap();
        symlink("/dev/null", npy_null.join("tau.npy")).unwrap();
        rows.extend([
            row(
                "twin, report.json a link to /dev/zero",
                &["twin", s(&zero_report), "--out", s(&out("twin_zr"))],
                1,
                "report.json: is a device",
            )
            .absent(&[&out("twin_zr")]),
            row(
                "twin, fused.ply a link to /dev/zero",
                &["twin", s(&zero_fused), "--out", s(&out("twin_zf"))],
                1,
                "fused.ply: is a device",
            )
            .absent(&[&out("twin_zf")]),
            row(
                "twin, a pair cloud a link to /dev/zero",
                &["twin", s(&zero_pair), "--out", s(&out("twin_zp"))],
                1,
                "pair_BS1-V1.ply: is a device",
            )
            .absent(&[&out("twin_zp")]),
            row(
                "twin, an output a link to /dev/null",
                &["twin", s(&run_dir), "--out", s(&twin_null)],
                1,
                "not a regular file",
            )
            .absent(&[&twin_null.join("twin_report.json")]),
            row(
                "--from-pairs, report.json a link to /dev/zero",
                &[
                    "reconstruct",
                    s(&site),
                    "--quick",
                    "--no-mesh",
                    "--from-pairs",
                    s(&pairs_zero),
                    "--out",
                    s(&out("pairs_zero_out")),
                ],
                1,
                "is a device",
            )
            .absent(&[&out("pairs_zero_out")]),
            row(
                "scene export onto a link to /dev/null",
                &[
                    "scene",
                    "export",
                    "--scene",
                    s(&fixture("suite/office_pair.toml")),
                    "--out",
                    s(&export_null),
                ],
                1,
                "not a regular file",
            ),
            row(
                "paths --npy onto a link to /dev/null",
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
                    s(&npy_null),
                ],
                1,
                "not a regular file",
            )
            .absent(&[&npy_null.join("a.npy"), &npy_null.join("rx.npy")]),
        ]);
    }

    let mut failures = Vec::new();
    for r in &rows {
        let (code, err) = run(&r.args, r.limit_kib);
        let mut why = Vec::new();
        if code != r.code {
            why.push(format!("exit {code}, expected {}", r.code));
        }
        if code == 1 {
            // One readable line: exactly one error line, holding the word, and nothing after
            // it (a multi-line message, such as a TOML error's quoted source, continues on
            // lines without the word "error").
            let lines: Vec<&str> = err.lines().filter(|l| l.contains("error")).collect();
            if lines.len() != 1 || !lines[0].contains(r.word) {
                why.push(format!("error lines {lines:?} lack {:?}", r.word));
            }
            let after = err
                .lines()
                .skip_while(|l| !l.contains("has-sim: error"))
                .skip(1)
                .filter(|l| !l.trim().is_empty())
                .count();
            if after > 0 {
                why.push(format!("{after} more lines after the error line"));
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
    // What the rows must not have touched, reported with the rows.
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        for dev in ["/dev/null", "/dev/full"] {
            if std::fs::metadata(dev).is_ok_and(|m| !m.file_type().is_char_device()) {
                failures.push(format!("{dev} replaced"));
            }
        }
        for link in [
            "full.toml",
            "null.toml",
            "full.obj",
            "null.ply",
            "export_null.obj",
            "npy_null/tau.npy",
            "twin_into_null/twin.obj",
        ] {
            if !std::fs::symlink_metadata(d.join(link)).is_ok_and(|m| m.file_type().is_symlink()) {
                failures.push(format!("the link {link} was replaced"));
            }
        }
    }
    let body = |name: &str| {
        std::fs::read_to_string(out(name))
            .map(|t| t.lines().skip(1).map(str::to_string).collect::<Vec<_>>())
            .unwrap_or_default()
    };
    let (huge, reduced) = (body("turn_1e30.toml"), body("turn_reduced.toml"));
    if huge.is_empty() || huge != reduced {
        failures.push(format!(
            "turn --deg 1e30 and --deg {reduced_deg} wrote different scenarios"
        ));
    }
    if std::fs::read(&cloud).unwrap() != cloud_before {
        failures.push("mesh overwrote its input".into());
    }
    if Path::new("/tmp/x-V1.ply").exists() {
        failures.push("/tmp/x-V1.ply written".into());
    }
    let _ = std::fs::remove_dir_all(&d);
    assert!(
        failures.is_empty(),
        "{} of {} rows failed:\n{}",
        failures.len(),
        rows.len(),
        failures.join("\n")
    );
}
