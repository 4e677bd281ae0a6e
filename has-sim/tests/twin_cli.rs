//! `has-sim twin` from the command line, on a run directory made here: a 16 × 10 × 8 m block
//! sampled at 0.5 m voxel centres (fused.ply with `weight`), its surface samples as the truth,
//! and a report.json naming the bundled factory scenario (for the ground and the truth area).
//! The twin is written as OBJ, PLY, CityJSON 2.0 and a report; bad input fails with one line
//! naming the file and field.

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::Vec3;
use has_host::io::save_cloud;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("has_twin_cli_{}_{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn has_sim(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `has-sim twin RUN --out OUT` with `extra` arguments.
fn twin(run: &Path, out: &Path, extra: &[&str]) -> (bool, String, String) {
    let mut args = vec![
        "twin",
        run.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    has_sim(&args)
}

/// Surface samples of the box [x0, x0 + 16] × [y0, y0 + 10] × [0, 8] without its base.
fn block(step: f32) -> Vec<Vec3> {
    let (x0, y0, w, d, h) = (-8.0f32, -5.0f32, 16.0f32, 10.0f32, 8.0f32);
    let mut p = Vec::new();
    let n = |l: f32| (l / step).round() as usize;
    for i in 0..=n(w) {
        for j in 0..=n(d) {
            p.push(Vec3::new(x0 + i as f32 * step, y0 + j as f32 * step, h));
        }
    }
    for k in 0..=n(h) {
        let z = k as f32 * step;
        for i in 0..=n(w) {
            let x = x0 + i as f32 * step;
            p.push(Vec3::new(x, y0, z));
            p.push(Vec3::new(x, y0 + d, z));
        }
        for j in 0..=n(d) {
            let y = y0 + j as f32 * step;
            p.push(Vec3::new(x0, y, z));
            p.push(Vec3::new(x0 + w, y, z));
        }
    }
    p
}

fn run_dir(name: &str, voxel: f64, with_weight: bool) -> PathBuf {
    let d = tmp(name);
    let mut seen = std::collections::HashSet::new();
    let fused: Vec<Vec3> = block(0.1)
        .into_iter()
        .filter_map(|p| {
            let k = (p / 0.5).floor().as_ivec3();
            seen.insert(k).then(|| (k.as_vec3() + 0.5) * 0.5)
        })
        .filter(|p| p.z > 0.5)
        .collect();
    let props = if with_weight {
        vec![("weight", vec![1.0; fused.len()])]
    } else {
        vec![]
    };
    save_cloud(&d.join("fused.ply"), &fused, props).unwrap();
    save_cloud(&d.join("ground_truth.ply"), &block(1.0 / 3.0), vec![]).unwrap();
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/factory.toml");
    let report = serde_json::json!({
        "scenario": scenario,
        "preset": "quick",
        "seed": 1,
        "imaging": { "voxel_m": voxel },
        "mesh": { "sqrt_chamfer_m": 0.5, "fscore_1_5m": 99.0, "false_surface_pct_1_5m": 1.0,
                  "faces": 1000, "sample_density_per_m2": 9.0 },
    });
    std::fs::write(d.join("report.json"), report.to_string()).unwrap();
    d
}

#[test]
fn twin_of_a_block_is_written_in_every_format_and_scored() {
    let run = run_dir("ok", 0.5, true);
    let out = run.join("twin");
    let (ok, stdout, stderr) = twin(&run, &out, &[]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("planar twin"), "{stdout}");
    for f in [
        "twin.obj",
        "twin.ply",
        "twin.xml",
        "twin_building_0.ply",
        "twin.city.json",
        "twin_report.json",
        "twin_report.md",
        "twin_top.png",
        "twin_side.png",
        "report.html",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(!out.join("RUNNING").exists());
    let city: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("twin.city.json")).unwrap()).unwrap();
    assert_eq!(city["type"], "CityJSON");
    assert_eq!(city["version"], "2.0");
    assert_eq!(city["CityObjects"].as_object().unwrap().len(), 1);
    let rep: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("twin_report.json")).unwrap()).unwrap();
    let t = &rep["twin"];
    assert_eq!(t["buildings"], 1);
    assert_eq!(t["topology"]["watertight"], true, "{t}");
    // A block: 4 walls, 1 roof, 1 ground at the least; within a voxel of the truth.
    assert!(t["faces"][0].as_u64().unwrap() >= 6);
    let cd = t["twin"]["cloud"]["sqrt_chamfer_m"].as_f64().unwrap();
    assert!(cd < 0.5, "√CD {cd}");
    assert_eq!(t["mesh"]["faces"], 1000);
}

/// The Sionna RT scene reads back as one building whose triangles cover the twin's walls and
/// roof (the block's 16 × 10 roof and 2 · (16 + 10) · 8 walls, within the twin's error), and
/// `has-sim paths` on it finds the reflection off the block's south facade (y = −5).
#[test]
fn the_sionna_scene_reads_back_and_reflects() {
    let run = run_dir("xml", 0.5, true);
    let out = run.join("twin");
    let (ok, _, stderr) = twin(&run, &out, &["--material", "itu_brick"]);
    assert!(ok, "{stderr}");
    let objects = has_host::io::mitsuba::read_mitsuba(&out.join("twin.xml")).unwrap();
    assert_eq!(objects.len(), 1);
    assert_eq!(objects[0].name, "building_0");
    assert_eq!(objects[0].material.name(), "brick");
    let area: f64 = objects[0]
        .triangles
        .iter()
        .map(|t| has_host::metrics::triangle_area(t) as f64)
        .sum();
    let truth = 16.0 * 10.0 + 2.0 * (16.0 + 10.0) * 8.0;
    assert!(
        (area - truth).abs() < 0.1 * truth,
        "area {area} m², truth {truth} m²"
    );
    let xml = out.join("twin.xml");
    let (ok, stdout, stderr) = has_sim(&[
        "paths",
        "--scene",
        xml.to_str().unwrap(),
        "--tx",
        "-4,-25,4",
        "--rx",
        "4,-25,4",
        "--json",
    ]);
    assert!(ok, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let paths = v["paths"].as_array().unwrap();
    let p = paths
        .iter()
        .find(|p| p["interactions"] == serde_json::json!(["reflection"]))
        .unwrap_or_else(|| panic!("no single reflection in {stdout}"));
    assert_eq!(p["objects"][0], "building_0", "{p}");
    let y = p["points"][0][1].as_f64().unwrap();
    assert!((y + 5.0).abs() < 0.5, "reflection point y = {y}");
}

/// Where an interpreter with Sionna RT is named by `HAS_PYTHON`, Sionna RT loads twin.xml with
/// its material; where `cjval` (`cargo install cjval --features build-binary`) is on the PATH,
/// twin.city.json validates against the CityJSON 2.0 schema with no unused or duplicate vertex
/// (the block touches nothing). Each check says it skipped when its tool is absent.
#[test]
fn sionna_rt_loads_the_scene_and_cjval_validates_the_cityjson_when_present() {
    let run = run_dir("peers", 0.5, true);
    let out = run.join("twin");
    let (ok, _, stderr) = twin(&run, &out, &[]);
    assert!(ok, "{stderr}");
    match std::env::var("HAS_PYTHON") {
        Ok(python) => {
            let script = format!(
                "import sionna.rt as rt\ns = rt.load_scene({:?})\nprint(sorted(o.radio_material.name for o in s.objects.values()))",
                out.join("twin.xml").to_str().unwrap()
            );
            let o = Command::new(python).args(["-c", &script]).output().unwrap();
            let text = String::from_utf8_lossy(&o.stdout);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            assert!(text.contains("itu_concrete"), "{text}");
        }
        Err(_) => eprintln!("skipped: HAS_PYTHON (an interpreter with sionna-rt) is not set"),
    }
    match Command::new("cjval")
        .arg("--report")
        .arg(out.join("twin.city.json"))
        .output()
    {
        Ok(o) => {
            let text = String::from_utf8_lossy(&o.stdout).into_owned();
            let report: serde_json::Value = serde_json::from_str(&text)
                .unwrap_or_else(|e| panic!("cjval's report: {e}: {text}"));
            assert_eq!(report["valid"], true, "{text}");
            let warnings = &report["checks"]["warnings"];
            assert_eq!(warnings["unused_vertices"]["valid"], true, "{text}");
            assert_eq!(warnings["duplicate_vertices"]["valid"], true, "{text}");
        }
        Err(_) => eprintln!("skipped: cjval is not on the PATH"),
    }
}

#[test]
fn a_cloud_without_weights_is_refused_naming_the_file_and_property() {
    let run = run_dir("noweight", 0.5, false);
    let out = run.join("twin");
    let (ok, _, stderr) = twin(&run, &out, &[]);
    assert!(!ok);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("fused.ply") && stderr.contains("weight"),
        "{stderr}"
    );
}

#[test]
fn a_bad_voxel_in_the_report_is_refused_naming_the_field_and_value() {
    let run = run_dir("badvoxel", -1.0, true);
    let out = run.join("twin");
    let (ok, _, stderr) = twin(&run, &out, &[]);
    assert!(!ok);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("imaging.voxel_m") && stderr.contains("-1"),
        "{stderr}"
    );
}

/// Two runs on the same input write the same bytes (no hash-map order reaches the output).
#[test]
fn the_twin_is_the_same_bytes_run_twice() {
    let run = run_dir("twice", 0.5, true);
    let outs = [run.join("a"), run.join("b")];
    for out in &outs {
        let (ok, _, stderr) = twin(&run, out, &[]);
        assert!(ok, "{stderr}");
    }
    for f in ["twin.obj", "twin.ply", "twin.xml", "twin.city.json"] {
        let a = std::fs::read(outs[0].join(f)).unwrap();
        let b = std::fs::read(outs[1].join(f)).unwrap();
        assert!(a == b, "{f} differs between two runs");
    }
}
