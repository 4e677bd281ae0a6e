//! Shared helpers of the `has-sim` command-line tests: scratch directories, running a
//! subcommand's quick preset and reading its report, running a subcommand on a scenario text,
//! and checking that outputs were written. Each test binary uses a subset, hence the allow.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// An empty scratch directory path, unique per test process.
pub fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("has-sim-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Runs `has-sim CMD --quick --out OUT`, asserts success and returns the parsed `report.json`.
pub fn run_quick(cmd: &str, out: &Path) -> serde_json::Value {
    let status = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .args([cmd, "--quick", "--out"])
        .arg(out)
        .status()
        .expect("has-sim runs");
    assert!(status.success(), "has-sim {cmd} --quick failed");
    read_report(out)
}

/// The parsed `OUT/report.json` of a finished run.
pub fn read_report(out: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(out.join("report.json")).expect("report.json"))
        .expect("valid JSON")
}

/// Runs `has-sim CMD DIR/bad.toml --out DIR/out` with `text` written to `DIR/bad.toml`;
/// returns (success, stderr).
pub fn run_on_text(cmd: &str, dir: &Path, text: &str) -> (bool, String) {
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .arg(cmd)
        .arg(&bad)
        .arg("--out")
        .arg(dir.join("out"))
        .output()
        .expect("has-sim runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Asserts that each of `files` exists below `out` and holds more than 100 bytes.
pub fn assert_outputs(out: &Path, files: &[&str]) {
    for f in files {
        let len = std::fs::metadata(out.join(f)).map(|m| m.len()).unwrap_or(0);
        assert!(len > 100, "{f} missing or empty");
    }
}
