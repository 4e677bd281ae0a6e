//! `has-sim mesh` from the command line: a small sphere cloud meshes into a closed OBJ; bad
//! input fails with one readable line naming the problem.

use std::path::PathBuf;
use std::process::Command;

use glam::Vec3;
use has_host::io::{ply, PlyData, PlyFormat};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("has_mesh_cli_{}_{name}", std::process::id()));
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

fn sphere(n: usize) -> Vec<Vec3> {
    let g = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - z * z).sqrt();
            let t = g * i as f32;
            Vec3::new(r * t.cos(), r * t.sin(), z) * 5.0
        })
        .collect()
}

#[test]
fn mesh_command_writes_a_watertight_obj_and_reports_metrics() {
    let d = tmp("ok");
    let cloud = d.join("cloud.ply");
    ply::write_ply(
        &cloud,
        &PlyData::from_points(sphere(3000)),
        PlyFormat::Ascii,
    )
    .unwrap();
    let obj = d.join("mesh.obj");
    let report = d.join("report.json");
    let (ok, out, err) = has_sim(&[
        "mesh",
        cloud.to_str().unwrap(),
        "--out",
        obj.to_str().unwrap(),
        "--depth",
        "5",
        "--truth",
        cloud.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(ok, "{out}\n{err}");
    assert!(out.contains("watertight true"), "{out}");
    let text = std::fs::read_to_string(&obj).unwrap();
    assert!(text.lines().filter(|l| l.starts_with("f ")).count() > 100);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    // Depth 5 on a 5 m sphere: cells = 10 m × 1.2 / 2⁵ = 0.375 m; the mesh lies within a cell of
    // the samples, so √CD against the samples themselves is below one cell.
    let cd = r["metrics"]["mesh"]["sqrt_chamfer_m"].as_f64().unwrap();
    let cell = r["mesh"]["cell_m"].as_f64().unwrap();
    assert!(cd < cell, "√CD {cd} cell {cell}");
    assert_eq!(r["mesh"]["topology"]["watertight"], true);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn mesh_command_rejects_bad_input_with_a_named_error() {
    let d = tmp("bad");
    let (ok, _, err) = has_sim(&["mesh", "/nonexistent/x.ply", "--out", "/tmp/x.obj"]);
    assert!(!ok && err.contains("/nonexistent/x.ply"), "{err}");
    let flat: Vec<Vec3> = (0..400)
        .map(|i| Vec3::new((i % 20) as f32, (i / 20) as f32, 1.0))
        .collect();
    let cloud = d.join("flat.ply");
    ply::write_ply(&cloud, &PlyData::from_points(flat), PlyFormat::Ascii).unwrap();
    let obj = d.join("flat.obj");
    let (ok, _, err) = has_sim(&[
        "mesh",
        cloud.to_str().unwrap(),
        "--out",
        obj.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("plane"), "{err}");
    assert!(!obj.exists());
    let (ok, _, err) = has_sim(&[
        "mesh",
        cloud.to_str().unwrap(),
        "--out",
        obj.to_str().unwrap(),
        "--trim",
        "1.5",
    ]);
    assert!(!ok && err.contains("--trim"), "{err}");
    let (ok, _, err) = has_sim(&[
        "mesh",
        cloud.to_str().unwrap(),
        "--out",
        obj.to_str().unwrap(),
        "--depth",
        "12",
    ]);
    assert!(!ok && err.contains("depth"), "{err}");
    // A missing ground truth is found before any work: no mesh is written.
    let good = d.join("sphere.ply");
    ply::write_ply(&good, &PlyData::from_points(sphere(500)), PlyFormat::Ascii).unwrap();
    let obj = d.join("sphere.obj");
    let (ok, _, err) = has_sim(&[
        "mesh",
        good.to_str().unwrap(),
        "--out",
        obj.to_str().unwrap(),
        "--depth",
        "4",
        "--truth",
        "/nonexistent/truth.ply",
    ]);
    assert!(!ok && err.contains("/nonexistent/truth.ply"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!obj.exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn an_intensity_property_weights_the_samples_unless_told_otherwise() {
    // A sphere of confident samples and a small ball of weak ones 3 m outside it (a sidelobe's
    // cluster): weighted by the cloud's `intensity`, as a pair cloud (`pair_*.ply`) is, the
    // ball leaves no surface; `--unweighted` meshes it; a missing `--weights` property is named.
    let d = tmp("weights");
    let mut pts = sphere(3000);
    let strong = pts.len();
    let ghost = Vec3::new(8.5, 0.0, 0.0);
    pts.extend(sphere(200).iter().map(|&p| ghost + p * 0.1));
    let intensity: Vec<f32> = (0..pts.len())
        .map(|i| if i < strong { 0.8 } else { 0.01 })
        .collect();
    let cloud = d.join("cloud.ply");
    let data = PlyData::from_points(pts).with_property("intensity", intensity);
    ply::write_ply(&cloud, &data, PlyFormat::BinaryLittleEndian).unwrap();
    let run = |extra: &[&str]| {
        let obj = d.join("m.obj");
        let mesh_ply = d.join("m.ply");
        let report = d.join("r.json");
        let mut args = vec![
            "mesh",
            cloud.to_str().unwrap(),
            "--out",
            obj.to_str().unwrap(),
            "--depth",
            "6",
            "--ply",
            mesh_ply.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let (ok, out, err) = has_sim(&args);
        assert!(ok, "{out}\n{err}");
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        let mesh = ply::read_ply(&mesh_ply).unwrap();
        let near = mesh
            .vertices
            .iter()
            .filter(|v| v.distance(ghost) < 1.0)
            .count();
        (r, near)
    };
    let (r, near) = run(&[]);
    assert_eq!(r["weights"]["property"], "intensity");
    assert_eq!(near, 0, "weighted: no vertex near the weak ball");
    let (r, near) = run(&["--unweighted"]);
    assert!(r["weights"].is_null());
    assert!(near > 0, "unweighted: the weak ball is meshed");
    let (ok, _, err) = has_sim(&[
        "mesh",
        cloud.to_str().unwrap(),
        "--out",
        d.join("x.obj").to_str().unwrap(),
        "--weights",
        "snr",
    ]);
    assert!(!ok && err.contains("snr"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    let _ = std::fs::remove_dir_all(&d);
}
