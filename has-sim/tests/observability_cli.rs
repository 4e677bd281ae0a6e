//! `has-sim observability` on the bundled factory: every pairing listed, the imaged ones marked,
//! and the shares consistent with each other (a union observes at least each of its members).

mod common;

use std::process::Command;

fn observability(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .arg("observability")
        .args(args)
        .output()
        .expect("has-sim runs")
}

#[test]
fn every_pairing_observes_at_least_the_imaged_pairs_and_each_pair() {
    let out = observability(&["--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let pairs = r["pairs"].as_array().expect("pairs");
    // 4 base stations × 6 apertures; every panel faces the site, so `reconstruct` images every
    // pairing.
    assert_eq!(pairs.len(), 24);
    let imaged: Vec<&serde_json::Value> = pairs
        .iter()
        .filter(|p| p["imaged"].as_bool() == Some(true))
        .collect();
    assert_eq!(imaged.len(), 24);
    let imaged_pct = r["imaged_pairs_pct"].as_f64().unwrap();
    let every_pct = r["every_pairing_pct"].as_f64().unwrap();
    assert!(imaged_pct <= every_pct && every_pct <= 100.0);
    for p in pairs {
        let s = p["observed_pct"].as_f64().unwrap();
        assert!((0.0..=every_pct).contains(&s), "{p}");
    }
    for p in &imaged {
        assert!(p["observed_pct"].as_f64().unwrap() <= imaged_pct, "{p}");
    }
    // The sawtooth roof's valleys and glazed faces are in no pair's line of sight (measured
    // 66.2 % imaged, 68.8 % for every pairing): the ceiling stated in the README and #5.
    assert!((60.0..75.0).contains(&every_pct), "{every_pct}");
}

#[test]
fn a_missing_scenario_fails_with_one_line() {
    let dir = common::out_dir("observability");
    let out = observability(&[dir.join("nope.toml").to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("nope.toml"), "{err}");
}
