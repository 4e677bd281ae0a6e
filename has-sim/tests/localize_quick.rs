//! Bad input to `has-sim localize` ends the process with one readable line and a non-zero exit;
//! a real-geometry site's `[localize]` runs end to end. (The quick run on the bundled factory is
//! held to its numbers in `quick_pipeline.rs`.)

mod common;

use std::process::Command;

#[test]
fn bad_input_is_one_readable_line() {
    let out = common::out_dir("localize-bad");
    let missing = out.join("no-such-twin.obj");
    let o = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .args(["localize", "--quick", "--twin"])
        .arg(&missing)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("has-sim runs");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.starts_with("has-sim: error: --twin"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    // A scenario without [localize].
    let scen = out.join("no_localize.toml");
    std::fs::create_dir_all(&out).unwrap();
    let text = include_str!("../../fixtures/factory.toml");
    let cut = text.find("\n[localize]").expect("fixture has [localize]");
    std::fs::write(&scen, &text[..cut]).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .arg("localize")
        .arg(&scen)
        .args(["--twin", "x.obj", "--out"])
        .arg(&out)
        .output()
        .expect("has-sim runs");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no [localize] table"), "{err}");
    // A known object the scene does not have is named with its field.
    let bogus = text.replace(
        "\n[localize]\n",
        "\n[localize]\nknown_objects = [\"nowhere\"]\n",
    );
    assert_ne!(bogus, text);
    std::fs::write(&scen, &bogus).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .arg("localize")
        .arg(&scen)
        .args(["--quick", "--truth-twin", "--out"])
        .arg(out.join("bogus"))
        .output()
        .expect("has-sim runs");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("localize.known_objects") && err.contains("nowhere"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    let _ = std::fs::remove_dir_all(&out);
}

/// A real-geometry site (fixtures/real, OpenStreetMap buildings) carries a `[localize]` table
/// written by its extractor: a street track in sight of one of its base stations, among 35
/// neighbour buildings as clutter. With the true buildings as the twin, the run must suppress
/// the static clutter (without suppression the neighbours flood the detector) and find the
/// target in every frame.
#[test]
fn a_real_site_localizes_its_target_among_its_neighbours() {
    let out = common::out_dir("localize-real");
    let scen = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/real/munich_angerhof.toml");
    let o = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .arg("localize")
        .arg(&scen)
        .args(["--quick", "--truth-twin", "--out"])
        .arg(&out)
        .output()
        .expect("has-sim runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = common::read_report(&out);
    let l = &r["localize"];
    let frames = l["spec"]["frames"].as_u64().expect("frames");
    let none = l["no_suppression"]["false_alarms"]
        .as_u64()
        .expect("false alarms");
    for mode in ["eca", "env"] {
        let m = &l[mode];
        assert_eq!(m["frames_detected"].as_u64(), Some(frames), "{mode}: {m}");
        let fa = m["false_alarms"].as_u64().expect("false alarms");
        // Suppression removes at least nine in ten of the clutter's detections.
        assert!(
            fa * 10 <= none,
            "{mode}: {fa} false alarms against {none} unsuppressed"
        );
        // The target is a 3 m cylinder: its detections lie within its radius of its surface.
        let cd = m["sqrt_chamfer_m"].as_f64().expect("sqrt_chamfer_m");
        assert!(cd.is_finite() && cd <= 3.0, "{mode}: √CD {cd} m");
    }
    let _ = std::fs::remove_dir_all(&out);
}
