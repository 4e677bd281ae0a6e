//! End to end, as a user runs it: `has-sim localize --quick` on the bundled factory scenario
//! builds the quick digital twin, runs both clutter-suppression modes on the same frames, meets
//! the localization its preset is documented to reach and writes every output. Bad input ends the
//! process with one readable line and a non-zero exit.

mod common;

use std::process::Command;

#[test]
fn quick_localization_meets_its_documented_bounds() {
    let out = common::out_dir("localize-quick");
    let report = common::run_quick("localize", &out);
    let l = &report["localize"];
    let eca = l["eca"]["sqrt_chamfer_m"].as_f64().expect("eca √CD");
    let env = l["env"]["sqrt_chamfer_m"].as_f64().expect("env √CD");
    // Measured on the bundled scenario with the quick twin (deterministic per seed): ECA
    // 1.446 m, environment prior 1.294 m (4 and 67 false alarms; 1.370 m on the twin of the
    // former peak-referenced detection). The bounds fail only if the chain gets worse.
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
            "truth.ply",
            "detections_eca.ply",
            "detections_env.ply",
            "detections_top.svg",
            "detections_eca_top.svg",
            "detections_env_top.svg",
            "rd_slow_before.svg",
            "rd_slow_eca.svg",
            "rd_slow_env.svg",
            "twin/mesh.obj",
        ],
    );
    let _ = std::fs::remove_dir_all(&out);
}

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
    let _ = std::fs::remove_dir_all(&out);
}
