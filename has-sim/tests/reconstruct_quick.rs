//! Bad scenario input to `has-sim reconstruct` ends the process with one readable line and a
//! non-zero exit, before any work. (The quick reconstruction's quality is held in
//! `quick_pipeline.rs`, which shares one reconstruction between the stages.)

mod common;

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
        // Range profiles shorter than the site's paths: echoes would fold onto nearer paths.
        (
            "subcarriers = 1024",
            "subcarriers = 64",
            "radar.subcarriers: 64 (the unambiguous path",
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
