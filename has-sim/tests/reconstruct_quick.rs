//! End to end, as a user runs it: `has-sim reconstruct --quick` on the bundled factory scenario
//! meets the point-cloud quality its preset is documented to reach, and writes every output.
//! Bad scenario input ends the process with one readable line and a non-zero exit.

mod common;

#[test]
fn quick_factory_reconstruction_meets_its_documented_bounds() {
    let out = common::out_dir("reconstruct-quick");
    let report = common::run_quick("reconstruct", &out);
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
            "fused.ply",
            "ground_truth.ply",
            "fused_top.svg",
            "fused_side.svg",
            "pair_BS1-UAV.ply",
            "mesh.obj",
            "mesh.ply",
            "mesh_top.svg",
            "mesh_input.ply",
        ],
    );
    let _ = std::fs::remove_dir_all(&out);
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
fn malformed_scenario_fails_with_one_line_naming_the_field() {
    let dir = common::out_dir("reconstruct-bad");
    std::fs::create_dir_all(&dir).unwrap();
    let factory = include_str!("../../fixtures/factory.toml");

    let (ok, err) = common::run_on_text(
        "reconstruct",
        &dir,
        &factory.replace("voxel_m = 0.25", "voxel_m = -1.0"),
    );
    assert!(!ok);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("imaging.voxel_m") && err.contains("-1"),
        "{err}"
    );

    let (ok, err) = common::run_on_text(
        "reconstruct",
        &dir,
        &factory.replace("[radar]", "[radar]\nbogus = 1"),
    );
    assert!(!ok);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("bogus"), "{err}");

    let (ok, err) = common::run_on_text(
        "reconstruct",
        &dir,
        &factory.replace(
            "position = [-45.0, -40.0, 20.0]",
            "position = [-45.0, nan, 20.0]",
        ),
    );
    assert!(!ok);
    assert!(err.contains("base_stations[0].position"), "{err}");

    // Accepted-but-wrong input of earlier versions: each a named one-line error now.
    for (from, to, field) in [
        (
            "name = \"BS2\"",
            "name = \"BS1\"",
            "base_stations[1].name: \"BS1\"",
        ),
        (
            "end = [-7.0, -27.0, 1.5]",
            "end = [-10.0, -27.0, 1.5]",
            "apertures[0].end: [-10.0, -27.0, 1.5] (at least a wavelength",
        ),
        // A mast inside the hall, an aperture under the yard.
        (
            "position = [-45.0, -40.0, 20.0]",
            "position = [0.0, 0.0, 4.0]",
            "base_stations[0].position: [0.0, 0.0, 4.0] lies inside or under object 'factory'",
        ),
        (
            "start = [-10.0, -27.0, 1.5]",
            "start = [-10.0, -27.0, -1.5]",
            "apertures[0].start: [-10.0, -27.0, -1.5] lies inside or under object 'yard'",
        ),
        // A site in georeferenced coordinates: refused before imaging, with the limit.
        (
            "position = [-45.0, -40.0, 20.0]",
            "position = [-45.0, 4999960.0, 20.0]",
            "base_stations[0].position: [-45.0, 4999960.0, 20.0] lies 4999960 m from the origin",
        ),
        (
            "fc_ghz = 10.0",
            "fc_ghz = 1e30",
            "radar.fc_ghz: 1000000000000000000000000000000 GHz is outside 1–100 GHz",
        ),
        (
            "scatterer_density_per_m2 = 16.0",
            "scatterer_density_per_m2 = 1e12",
            "imaging.scatterer_density_per_m2: up to",
        ),
    ] {
        assert!(factory.contains(from), "{from}");
        let (ok, err) = common::run_on_text("reconstruct", &dir, &factory.replacen(from, to, 1));
        assert!(!ok, "{to}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(field), "{to}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn options_of_later_stages_and_the_output_directory_fail_before_any_work() {
    // A bad mesh option or an unwritable --out used to fail only after the imaging, leaving
    // result files behind; now the run stops first, with one line naming the option.
    let dir = common::out_dir("reconstruct-late");
    std::fs::create_dir_all(&dir).unwrap();
    let run = |args: &[&str], out: &std::path::Path| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_has-sim"))
            .args(["reconstruct", "--quick"])
            .args(args)
            .arg("--out")
            .arg(out)
            .output()
            .expect("has-sim runs");
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    for (args, field) in [
        (&["--mesh-depth", "0"][..], "--mesh-depth"),
        (&["--mesh-depth", "99"][..], "--mesh-depth"),
        (&["--mesh-trim-median", "NaN"][..], "--mesh-trim-median"),
    ] {
        let out = dir.join("out");
        let (ok, err) = run(args, &out);
        assert!(!ok, "{args:?}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(field), "{err}");
        assert!(!out.join("fused.ply").exists() && !out.join("report.json").exists());
    }
    // --out below a regular file cannot be created.
    let file = dir.join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let (ok, err) = run(&[], &file.join("out"));
    assert!(!ok);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("--out"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
