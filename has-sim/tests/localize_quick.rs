//! Bad input to `has-sim localize` ends the process with one readable line and a non-zero exit.
//! (The quick run on the bundled factory is held to its numbers in `quick_pipeline.rs`.)

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
    let _ = std::fs::remove_dir_all(&out);
}
