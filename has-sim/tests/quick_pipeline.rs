//! End to end, as a user runs it, with one quick reconstruction of the bundled factory shared by
//! three stages (each would otherwise rebuild the same twin): `has-sim channel --quick`
//! reconstructs the quick twin into `DIR/twin` (the same run as `has-sim reconstruct --quick`)
//! and predicts channels on it; the reconstruction is held to the point-cloud and mesh quality
//! its preset is documented to reach, and its planar twin is that of `has-sim twin` on its files;
//! `has-sim localize --quick --twin DIR/twin/twin.obj` runs
//! both clutter-suppression modes against that twin. Bad input of each command is tested in its
//! own file (`reconstruct_quick.rs`, `channel_quick.rs`, `localize_quick.rs`).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The output directory of `has-sim channel --quick` on the bundled factory, run once per test
/// process (its `twin/` is the quick reconstruction), in cargo's scratch directory for
/// integration tests (emptied first; left for inspection, `cargo clean` removes it).
fn pipeline() -> &'static Path {
    static RUN: OnceLock<PathBuf> = OnceLock::new();
    RUN.get_or_init(|| {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("quick-pipeline");
        let _ = std::fs::remove_dir_all(&out);
        common::run_quick("channel", &out);
        out
    })
}

#[test]
fn quick_factory_reconstruction_meets_its_documented_bounds() {
    let out = pipeline().join("twin");
    let report = common::read_report(&out);
    let pc = &report["imaging"]["point_cloud"];
    let sqrt_cd = pc["sqrt_chamfer_m"].as_f64().expect("sqrt_chamfer_m");
    let f15 = pc["fscore_1_5m"].as_f64().expect("fscore_1_5m");
    // The quick preset (0.5 m voxels, 8×8 of each 32×32 panel, every 4th aperture position) on
    // the bundled site (an 80 m × 64 m region around the hall, not a box fitted to it) is held
    // to issue 13's acceptance for quick runs on any site: √CD at most 1.3 m, F-score(1.5 m) at
    // least 90 (measured 0.927 m / 93.7 with every facing base station imaging every aperture).
    assert!(sqrt_cd <= 1.3, "√CD {sqrt_cd} m");
    assert!(f15 >= 90.0, "F-score(1.5 m) {f15}");
    assert!(pc["fscore_0_5m"].as_f64().is_some() && pc["fscore_1_0m"].as_f64().is_some());
    // All 4 panels face the site: each images each of the 6 apertures.
    assert_eq!(
        report["imaging"]["pairs"].as_array().map(Vec::len),
        Some(24)
    );
    // Every pairing of the 4 base stations and 6 apertures sees at least what the imaged pairs
    // see (here the same pairs: 68.5 %).
    let gt = &report["imaging"]["ground_truth"];
    let seen = gt["observable_pct"].as_f64().expect("observable_pct");
    let any = gt["observable_any_pairing_pct"]
        .as_f64()
        .expect("observable_any_pairing_pct");
    assert!(0.0 < seen && seen <= any && any <= 100.0, "{seen} {any}");
    // The mesh of the quick cloud (imaging::surface: samples weighted by their amplitude, points
    // facing away from their pairs left out, trimmed below 0.1 × the median support density,
    // clipped to the imaging region and
    // to half the coarsest pair resolution cell, components under 2 % of the largest dropped)
    // must be better than the cloud it came from on both figures (paper §1.3's claim, and issue
    // 13's), and within the same quick bounds.
    let mesh = &report["mesh"];
    let mesh_cd = mesh["sqrt_chamfer_m"]
        .as_f64()
        .expect("mesh.sqrt_chamfer_m");
    let mesh_f = mesh["fscore_1_5m"].as_f64().expect("mesh.fscore_1_5m");
    assert!(
        mesh_cd < sqrt_cd,
        "mesh √CD {mesh_cd} m vs cloud {sqrt_cd} m"
    );
    assert!(mesh_f > f15, "mesh F-score(1.5 m) {mesh_f} vs cloud {f15}");
    assert!(mesh_cd <= 1.3, "mesh √CD {mesh_cd} m");
    assert!(mesh_f >= 90.0, "mesh F-score(1.5 m) {mesh_f}");
    assert_eq!(mesh["manifold"].as_bool(), Some(true));
    written_mesh_passes_the_checks_of_tools_that_weld_on_load(&out.join("mesh.obj"));
    // A finished run leaves no marker of an unfinished one (has-sim's run_dir).
    assert!(!out.join("RUNNING").exists());
    common::assert_outputs(
        &out,
        &[
            "report.md",
            "report.html",
            "fused.ply",
            "ground_truth.ply",
            "fused_top.png",
            "fused_side.png",
            "pair_BS1-UAV.ply",
            "mesh.obj",
            "mesh.ply",
            "mesh_top.png",
            "mesh_input.ply",
            "twin.obj",
            "twin.ply",
            "twin.city.json",
            "twin.xml",
            "twin_building_0.ply",
        ],
    );
    common::assert_html_renders(&out);
}

#[test]
fn reading_a_run_s_pair_clouds_back_reproduces_its_cloud_without_imaging() {
    let twin = pipeline().join("twin");
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("quick-pipeline-from-pairs");
    let _ = std::fs::remove_dir_all(&out);
    let run = |args: &[&std::ffi::OsStr]| {
        Command::new(env!("CARGO_BIN_EXE_has-sim"))
            .arg("reconstruct")
            .args(args)
            .output()
            .expect("has-sim runs")
    };
    let o = run(&[
        "--quick".as_ref(),
        "--no-mesh".as_ref(),
        "--from-pairs".as_ref(),
        twin.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (a, b) = (common::read_report(&twin), common::read_report(&out));
    // The same pair clouds through the same fusion and tests: the same cloud, to the bit.
    let pc = |r: &serde_json::Value| r["imaging"]["point_cloud"].clone();
    assert_eq!(pc(&a), pc(&b));
    assert_eq!(b["echo"].as_str(), Some("pair_clouds_read_back"));
    assert_eq!(b["backprojections"].as_f64(), Some(0.0));
    // Another preset's clouds, and the output directory itself, are refused by name.
    let o = run(&[
        "--no-mesh".as_ref(),
        "--from-pairs".as_ref(),
        twin.as_os_str(),
        "--out".as_ref(),
        out.join("default").as_os_str(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("preset quick"), "{err}");
    let o = run(&[
        "--quick".as_ref(),
        "--from-pairs".as_ref(),
        out.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--from-pairs"), "{err}");
    // Another scenario under the run's file name, and another seed, are refused by content: a
    // copy of the run whose report names `other/factory.toml`, and that file with another SNR.
    let other = out.join("other");
    std::fs::create_dir_all(&other).unwrap();
    let factory = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/factory.toml"),
    )
    .unwrap();
    assert!(factory.contains("snr_db = 10.0"));
    let renamed = other.join("factory.toml");
    std::fs::write(&renamed, factory.replace("snr_db = 10.0", "snr_db = 12.0")).unwrap();
    let copy_run = |name: &str| {
        let copy = out.join(name);
        std::fs::create_dir_all(&copy).unwrap();
        for e in std::fs::read_dir(&twin).unwrap() {
            let e = e.unwrap();
            let file = e.file_name().to_string_lossy().into_owned();
            if file.starts_with("pair_") {
                std::fs::copy(e.path(), copy.join(&file)).unwrap();
            }
        }
        let mut report = common::read_report(&twin);
        report["scenario"] = serde_json::Value::from(renamed.to_string_lossy().into_owned());
        std::fs::write(copy.join("report.json"), report.to_string()).unwrap();
        copy
    };
    let again = out.join("again");
    let refused = |args: &[&std::ffi::OsStr], word: &str| {
        let o = run(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(word), "{err}");
        assert!(!again.join("report.json").exists());
    };
    let same_name = copy_run("same_name");
    refused(
        &[
            renamed.as_os_str(),
            "--quick".as_ref(),
            "--no-mesh".as_ref(),
            "--from-pairs".as_ref(),
            same_name.as_os_str(),
            "--out".as_ref(),
            again.as_os_str(),
        ],
        "scenario digest",
    );
    refused(
        &[
            "--quick".as_ref(),
            "--no-mesh".as_ref(),
            "--seed".as_ref(),
            "5".as_ref(),
            "--from-pairs".as_ref(),
            twin.as_os_str(),
            "--out".as_ref(),
            again.as_os_str(),
        ],
        "seed 5",
    );
    // A copy that changes only the fusion's switches fuses the same pair clouds.
    let fusion = other.join("fusion.toml");
    std::fs::write(
        &fusion,
        factory.replace("[imaging]\n", "[imaging]\nsmear_centroid = false\n"),
    )
    .unwrap();
    let fusion_args = [
        fusion.as_os_str(),
        "--quick".as_ref(),
        "--no-mesh".as_ref(),
        "--from-pairs".as_ref(),
        twin.as_os_str(),
        "--out".as_ref(),
        again.as_os_str(),
    ];
    let o = run(&fusion_args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(again.join("report.json").exists());
    std::fs::remove_dir_all(&again).unwrap();
    // A pair cloud with a point far outside the region is refused naming the file.
    let far = out.join("pairs_far");
    std::fs::create_dir_all(&far).unwrap();
    for e in std::fs::read_dir(&twin).unwrap() {
        let e = e.unwrap();
        let file = e.file_name().to_string_lossy().into_owned();
        if file == "report.json" || file.starts_with("pair_") {
            std::fs::copy(e.path(), far.join(&file)).unwrap();
        }
    }
    let victim = std::fs::read_dir(&far)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("pair_")
        })
        .unwrap();
    let mut data = has_host::io::ply::read_ply(&victim).unwrap();
    data.vertices[0] = glam::Vec3::new(1e30, 0.0, 0.0);
    std::fs::remove_file(&victim).unwrap();
    has_host::io::ply::write_ply(&victim, &data, has_host::io::PlyFormat::BinaryLittleEndian)
        .unwrap();
    let name = victim.file_name().unwrap().to_string_lossy().into_owned();
    refused(
        &[
            "--quick".as_ref(),
            "--no-mesh".as_ref(),
            "--from-pairs".as_ref(),
            far.as_os_str(),
            "--out".as_ref(),
            again.as_os_str(),
        ],
        &name,
    );
}

#[test]
fn two_shards_merged_give_the_bits_of_one_run() {
    let one = pipeline().join("twin");
    let base = Path::new(env!("CARGO_TARGET_TMPDIR")).join("quick-pipeline-shards");
    let _ = std::fs::remove_dir_all(&base);
    let run = |args: &[&std::ffi::OsStr]| {
        Command::new(env!("CARGO_BIN_EXE_has-sim"))
            .arg("reconstruct")
            .arg("--quick")
            .args(args)
            .output()
            .expect("has-sim runs")
    };
    let (a, b) = (base.join("shard1"), base.join("shard2"));
    // One after the other here; the README runs them side by side.
    for (shard, dir) in [("1/2", &a), ("2/2", &b)] {
        let o = run(&[
            "--shard".as_ref(),
            shard.as_ref(),
            "--out".as_ref(),
            dir.as_os_str(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let said = String::from_utf8_lossy(&o.stdout);
        assert!(said.contains("no fusion"), "{said}");
        for f in ["fused.ply", "report.json", "mesh.obj", "RUNNING"] {
            assert!(!dir.join(f).exists(), "shard {shard} wrote {f}");
        }
    }
    let record = |dir: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(dir.join("shard.json")).expect("shard.json"))
            .expect("valid JSON")
    };
    let names = |dir: &Path| -> Vec<String> {
        record(dir)["pairs"]
            .as_array()
            .expect("pairs")
            .iter()
            .map(|n| n.as_str().expect("name").to_string())
            .collect()
    };
    // The shards split the run's 24 pairs between them, each pair cloud as the run imaged it.
    let whole: Vec<String> = common::read_report(&one)["imaging"]["pairs"]
        .as_array()
        .expect("pairs")
        .iter()
        .map(|p| p["name"].as_str().expect("name").to_string())
        .collect();
    let (na, nb) = (names(&a), names(&b));
    assert_eq!((na.len(), nb.len()), (12, 12));
    assert_eq!(
        record(&a)["scenario_digest"],
        common::read_report(&one)["scenario_digest"]
    );
    for (k, name) in whole.iter().enumerate() {
        let dir = if k % 2 == 0 { &a } else { &b };
        assert!(names(dir).contains(name), "{name} not in {}", dir.display());
        let file = format!("pair_{name}.ply");
        assert!(
            std::fs::read(one.join(&file)).unwrap() == std::fs::read(dir.join(&file)).unwrap(),
            "{file} differs from the run's"
        );
    }
    // Merged in the other order: the run's cloud and mesh, to the bit.
    let merged = base.join("merged");
    let o = run(&[
        "--from-pairs".as_ref(),
        b.as_os_str(),
        a.as_os_str(),
        "--out".as_ref(),
        merged.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["fused.ply", "mesh.obj", "mesh.ply", "mesh_input.ply"] {
        let (x, y) = (
            std::fs::read(one.join(f)).unwrap(),
            std::fs::read(merged.join(f)).unwrap(),
        );
        assert!(x.len() > 100, "{f} is empty");
        assert!(x == y, "{f} of the merged shards differs from the run's");
    }
    // Refused before anything is written: a shard alone (naming what is missing), a pair in two
    // directories, a shard of another draw or preset, a shard that did not finish.
    let again = base.join("again");
    let refused = |dirs: &[&Path], words: &[&str]| {
        let mut args: Vec<&std::ffi::OsStr> = vec!["--no-mesh".as_ref(), "--from-pairs".as_ref()];
        args.extend(dirs.iter().map(|d| d.as_os_str()));
        args.extend(["--out".as_ref(), again.as_os_str()]);
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        for w in words {
            assert!(err.contains(w), "{err} lacks {w}");
        }
        assert!(!again.exists(), "{err}");
    };
    refused(&[&a], &["12 of 24 pairs", &nb[0], &nb[11]]);
    refused(&[&a, &one], &["is in both", &na[0]]);
    let edited = |name: &str, from: &str, to: &str| {
        let dir = base.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        for e in std::fs::read_dir(&b).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
        }
        let text = std::fs::read_to_string(b.join("shard.json")).unwrap();
        assert!(text.contains(from), "shard.json lacks {from}");
        std::fs::write(dir.join("shard.json"), text.replacen(from, to, 1)).unwrap();
        dir
    };
    let digest = record(&b)["scenario_digest"].as_str().unwrap().to_string();
    let other_draw = edited("other_draw", &digest, "0123456789abcdef");
    refused(&[&a, &other_draw], &["scenario digest", "0123456789abcdef"]);
    let other_preset = edited("other_preset", "\"quick\"", "\"default\"");
    refused(&[&a, &other_preset], &["preset default"]);
    let other_path = edited("other_path", "f32,", "fixed_point_q15,");
    refused(&[&a, &other_path], &["fixed_point_q15"]);
    let killed = edited("killed", "\"pairs\"", "\"pairs\"");
    std::fs::write(killed.join("RUNNING"), "has-sim reconstruct\n").unwrap();
    refused(&[&a, &killed], &["RUNNING"]);
}

/// The written OBJ as Open3D sees it: loaded with bit-identical vertices welded (has's reader,
/// as Open3D's `remove_duplicated_vertices`), it is edge- and vertex-manifold with no degenerate
/// face (`is_edge_manifold`, `is_vertex_manifold`, `remove_degenerate_triangles` a no-op), and
/// every vertex has a normal.
fn written_mesh_passes_the_checks_of_tools_that_weld_on_load(obj: &std::path::Path) {
    let objects = has_host::io::load_objects(obj, None).expect("mesh.obj loads");
    assert_eq!(objects.len(), 1);
    let mut data = has_host::io::PlyData::default();
    data.append_triangles(&objects[0].triangles);
    let mesh = has_host::mesh::TriMesh {
        vertices: data.vertices.clone(),
        faces: data.faces.clone(),
    };
    let top = mesh.topology();
    assert!(
        top.manifold && top.nonmanifold_vertices == 0 && top.degenerate_faces == 0,
        "{top:?}"
    );
    let text = std::fs::read_to_string(obj).unwrap();
    let count = |tag: &str| text.lines().filter(|l| l.starts_with(tag)).count();
    assert_eq!(count("v "), mesh.vertices.len());
    assert_eq!(count("vn "), count("v "));
}

#[test]
fn quick_channel_prediction_reports_errors_beams_and_plots() {
    let out = pipeline().to_path_buf();
    let report = common::read_report(&out);
    let c = &report["channel"];
    let ues = &c["ues"];
    assert_eq!(ues["total"].as_u64(), Some(100));
    let kept = ues["kept"].as_u64().expect("kept");
    assert_eq!(kept + ues["dropped"].as_u64().expect("dropped"), 100);
    // The quick run (100 UEs, order 2) measured 73 kept UEs: every UE in view of the BS keeps its
    // line of sight (< 110 dB up to ~760 m at 10 GHz), the dropped ones are in the hall's shadow
    // with no reflected path either (no diffraction). The UE draw and the true scene do not depend
    // on the twin, so this count is exact.
    assert_eq!(kept, 73);
    let p = &c["paths"];
    assert_eq!(
        p["true_kept"].as_u64(),
        Some(142),
        "true-scene paths are exact"
    );
    let fwd = p["matched_true_to_twin"].as_u64().expect("forward pairs");
    // A true path is paired when the twin has any path for its UE. A spurious twin surface can
    // shadow a UE completely (no twin path at all); most UEs keep their line of sight.
    assert!(
        fwd <= 142 && fwd as f64 >= 0.9 * 142.0,
        "matched true-to-twin paths {fwd} of 142"
    );
    for q in ["p50", "p90", "p95"] {
        for k in ["delay_ns", "aoa_deg", "aod_deg", "zoa_deg", "zod_deg"] {
            let v = c[q][k].as_f64().unwrap_or(f64::NAN);
            assert!(v.is_finite() && v >= 0.0, "channel.{q}.{k} = {v}");
        }
    }
    // Line of sight and the ground bounce (the ground is known to the twin) are identical in both
    // models unless the twin blocks them, and they are most of the kept paths, so the errors are
    // mostly 0; the wall reflections of the quick twin (least-squares facet planes) add small
    // ones. Measured p90 with main's quick twin at 39bb5f6: delay 0.11 ns, AoA 0.14°, AoD 0.01°,
    // ZoA 0.29°, ZoD 0.08° (0.09 ns, 0.003°, 0.04°, 0.09°, 0.02° with the mesh before its
    // visibility-consistency pass: the numbers follow the mesh). The bounds are the goal
    // (1 ns, 1°, 1°, 0.5°, 0.5°), 1.7-100× above the measurement: a twin that loses or misplaces
    // more than ~10 % of the paths (a blocked line of sight pairs with a reflection tens of ns
    // and degrees away) fails them.
    for (k, goal) in [
        ("delay_ns", 1.0),
        ("aoa_deg", 1.0),
        ("aod_deg", 1.0),
        ("zoa_deg", 0.5),
        ("zod_deg", 0.5),
    ] {
        let v = c["p90"][k].as_f64().unwrap_or(f64::NAN);
        assert!(v <= goal, "channel.p90.{k} = {v} > {goal}");
    }
    // Beam selection measured 98.6 % (72 of 73): the true best beam is set by the line of sight,
    // which the twin reproduces; a regression that loses lines of sight fails this.
    let agree = c["beam"]["agreement_pct"].as_f64().expect("agreement_pct");
    assert!(agree >= 90.0, "beam agreement {agree} %");
    assert!(c["paths_per_s"]["true"].as_f64().unwrap_or(0.0) > 0.0);
    let csv = std::fs::read_to_string(out.join("errors.csv")).expect("errors.csv");
    let rows = csv.lines().count() - 1;
    assert_eq!(rows as u64, c["count"].as_u64().expect("count"));
    common::assert_outputs(
        &out,
        &[
            "report.md",
            "report.html",
            "cdf_delay.svg",
            "cdf_angles.svg",
            "ue_map.png",
            "twin/mesh.obj",
            "twin/twin.obj",
        ],
    );
    // Without --twin the channel traces the run's planar twin.
    let traced = c["twin_mesh"].as_str().expect("twin_mesh");
    assert!(traced.ends_with("twin.obj"), "{traced}");
    common::assert_html_renders(&out);
}

#[test]
fn quick_localization_meets_its_documented_bounds() {
    let out = common::out_dir("localize-quick");
    // The planar twin the channel run reconstructed (what localize traces without `--twin`),
    // handed over as a user would with `--twin`.
    let twin = pipeline().join("twin").join("twin.obj");
    let status = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .args(["localize", "--quick", "--twin"])
        .arg(&twin)
        .arg("--out")
        .arg(&out)
        .status()
        .expect("has-sim runs");
    assert!(status.success(), "has-sim localize --quick --twin failed");
    let report = common::read_report(&out);
    let l = &report["localize"];
    let eca = l["eca"]["sqrt_chamfer_m"].as_f64().expect("eca √CD");
    let env = l["env"]["sqrt_chamfer_m"].as_f64().expect("env √CD");
    // Measured on the bundled scenario with the quick planar twin (deterministic per seed): ECA
    // 1.446 m, environment prior 1.322 m (4 and 104 false alarms; 1.298 m and 58 on the quick
    // Poisson mesh). The bounds fail only if the chain gets worse.
    assert!(eca <= 1.5, "ECA √CD {eca} m");
    assert!(env <= 1.4, "env √CD {env} m");
    // With ECA the only false alarms left are noise and target sidelobes: the CFAR holds its
    // design rate, so they stay below the design expectation cells·pfa·frames (46 for this
    // preset; a CFAR blind to the correlation of its range bins gave 220).
    let cube = l["cube_range_beams_doppler"].as_array().expect("cube");
    let cells: f64 = cube.iter().map(|v| v.as_f64().unwrap()).product();
    let pfa = l["spec"]["cfar_pfa"].as_f64().expect("pfa");
    let frames_f = l["frames"].as_array().expect("frames").len() as f64;
    let fa = l["eca"]["false_alarms"].as_f64().expect("false alarms");
    assert!(fa <= cells * pfa * frames_f, "{fa} ECA false alarms");
    assert!(l["improvement_pct"].as_f64().is_some());
    // Every frame of the quick preset sees the target in both modes.
    let frames = l["frames"].as_array().expect("frames").len() as u64;
    assert_eq!(l["eca"]["frames_detected"].as_u64(), Some(frames));
    assert_eq!(l["env"]["frames_detected"].as_u64(), Some(frames));
    assert_eq!(l["eca_variants"].as_array().map(Vec::len), Some(4));
    common::assert_outputs(
        &out,
        &[
            "report.md",
            "report.html",
            "truth.ply",
            "detections_eca.ply",
            "detections_env.ply",
            "detections_top.png",
            "detections_eca_top.png",
            "detections_env_top.png",
            "rd_slow_before.png",
            "rd_slow_eca.png",
            "rd_slow_env.png",
        ],
    );
    common::assert_html_renders(&out);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn the_planar_twin_of_the_run_is_the_twin_command_s_of_its_files() {
    let run = pipeline().join("twin");
    let report = common::read_report(&run);
    let t = &report["planar_twin"];
    assert!(t["error"].is_null(), "{t}");
    assert_eq!(t["watertight"].as_bool(), Some(true), "{t}");
    let cd = t["metrics"]["cloud"]["sqrt_chamfer_m"]
        .as_f64()
        .expect("planar_twin.metrics.cloud.sqrt_chamfer_m");
    assert!(cd.is_finite() && cd > 0.0, "{cd}");
    // `has-sim twin` rebuilds it from the run's files (fused.ply, pair_*.ply, report.json): the
    // same faces, byte for byte.
    let again = Path::new(env!("CARGO_TARGET_TMPDIR")).join("quick-pipeline-twin-again");
    let _ = std::fs::remove_dir_all(&again);
    let o = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .arg("twin")
        .arg(&run)
        .arg("--out")
        .arg(&again)
        .output()
        .expect("has-sim runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "twin.obj",
        "twin.city.json",
        "twin.xml",
        "twin_building_0.ply",
    ] {
        let (a, b) = (
            std::fs::read(run.join(f)).expect(f),
            std::fs::read(again.join(f)).expect(f),
        );
        assert!(a == b, "{f} differs between the run and `has-sim twin`");
    }
}
