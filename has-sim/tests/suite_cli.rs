//! `has-sim suite --quick` on the scenario suite (`fixtures/suite`, issue 13), as a user runs it:
//! the sites reconstructed, one table with each, every figure finite; the issue's accuracy
//! bounds for the quick preset in a separate test; bad arguments end the process with one
//! readable line. Each suite run happens once per test process and is shared by the tests that
//! need it.
//!
//! The default tests run two sites, [`CI_SITES`] (the bundled factory's quick run is held to the
//! same bounds in `quick_pipeline.rs`): a quick site takes minutes on two cores, and the whole
//! suite would double the test command's time. Every site is held to the bounds by the ignored
//! test, `cargo test --release -p has-sim --test suite_cli -- --ignored`.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// Issue 13's acceptance for `--quick` on every suite site: fused-cloud √CD at most this, m.
const ISSUE_13_QUICK_CLOUD_SQRT_CD_MAX_M: f64 = 1.3;
/// Issue 13's acceptance for `--quick` on every suite site: fused-cloud F-score(1.5 m) at least
/// this, %.
const ISSUE_13_QUICK_CLOUD_FSCORE_1_5M_MIN: f64 = 90.0;

/// The figures of a suite row that must be numbers.
const ROW_METRICS: [&str; 9] = [
    "cloud_sqrt_cd_m",
    "cloud_fscore_1_5m",
    "mesh_sqrt_cd_m",
    "mesh_fscore_1_5m",
    "mesh_false_surface_pct",
    "mesh_area_ratio",
    "observable_pct",
    "imaging_s",
    "peak_rss_mib",
];

/// The sites the default tests run: two besides the bundled factory, a pair of buildings and a
/// street of three.
const CI_SITES: [&str; 2] = ["office_pair", "street_row"];

fn suite_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/suite")
}

/// The site names: the stems of the suite's scenario files, sorted.
fn site_names() -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(suite_dir())
        .expect("fixtures/suite")
        .filter_map(|e| {
            let p = e.ok()?.path();
            (p.extension()? == "toml").then(|| p.file_stem()?.to_str().map(String::from))?
        })
        .collect();
    v.sort();
    v
}

/// One `has-sim suite --quick` run: exit status, stderr, `suite.json`, `suite.md`.
struct SuiteRun {
    success: bool,
    stderr: String,
    report: serde_json::Value,
    md: String,
    /// The sites asked for, in order.
    sites: Vec<String>,
    /// Outputs (site/file) missing or empty.
    missing_outputs: Vec<String>,
}

/// `has-sim suite --quick` on [`CI_SITES`], once per test process.
fn quick_suite() -> &'static SuiteRun {
    static RUN: OnceLock<SuiteRun> = OnceLock::new();
    RUN.get_or_init(|| {
        let sites: Vec<String> = CI_SITES.iter().map(|s| s.to_string()).collect();
        run_suite("suite-quick", &sites)
    })
}

/// `has-sim suite --quick` on every site, once per test process.
fn quick_suite_all() -> &'static SuiteRun {
    static RUN: OnceLock<SuiteRun> = OnceLock::new();
    RUN.get_or_init(|| run_suite("suite-quick-all", &site_names()))
}

fn run_suite(name: &str, sites: &[String]) -> SuiteRun {
    {
        let out = common::out_dir(name);
        let t = std::time::Instant::now();
        let o = Command::new(env!("CARGO_BIN_EXE_has-sim"))
            .args(["suite", "--quick", "--out"])
            .arg(&out)
            .arg("--suite-dir")
            .arg(suite_dir())
            .arg("--sites")
            .arg(sites.join(","))
            .output()
            .expect("has-sim runs");
        let md = std::fs::read_to_string(out.join("suite.md")).unwrap_or_default();
        println!(
            "has-sim suite --quick: {:.0} s\n{md}",
            t.elapsed().as_secs_f64()
        );
        let report = std::fs::read(out.join("suite.json"))
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or(serde_json::Value::Null);
        // Checked here, asserted by the tests: a panic inside the initialisation would make the
        // next test run the suite again.
        let missing_outputs = sites
            .iter()
            .flat_map(|site| {
                ["report.json", "report.md", "mesh.obj", "fused.ply"]
                    .into_iter()
                    .map(move |f| format!("{site}/{f}"))
            })
            .filter(|f| std::fs::metadata(out.join(f)).map_or(true, |m| m.len() <= 100))
            .collect();
        let _ = std::fs::remove_dir_all(&out);
        SuiteRun {
            success: o.status.success(),
            stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
            report,
            md,
            sites: sites.to_vec(),
            missing_outputs,
        }
    }
}

fn rows(run: &SuiteRun) -> &Vec<serde_json::Value> {
    run.report["sites"].as_array().expect("suite.json: sites")
}

#[test]
fn quick_suite_tables_each_site_with_finite_figures() {
    let run = quick_suite();
    assert!(run.success, "has-sim suite --quick failed: {}", run.stderr);
    let names = site_names();
    assert!(names.len() >= 4, "{names:?}");
    for s in CI_SITES {
        assert!(
            names.iter().any(|n| n == s),
            "{s} is not a suite site: {names:?}"
        );
    }
    let got: Vec<&str> = rows(run)
        .iter()
        .map(|r| r["site"].as_str().unwrap_or(""))
        .collect();
    assert_eq!(got, run.sites, "sites in suite.json");
    assert_eq!(run.report["failed"].as_u64(), Some(0));
    assert!(run.missing_outputs.is_empty(), "{:?}", run.missing_outputs);
    for r in rows(run) {
        let site = r["site"].as_str().unwrap();
        assert_eq!(r["ok"].as_bool(), Some(true), "{site}");
        assert!(
            run.md.contains(&format!("| {site} | ")),
            "{site} not in suite.md"
        );
        for k in ROW_METRICS {
            let v = r[k].as_f64().unwrap_or(f64::NAN);
            assert!(v.is_finite(), "{site}: {k} = {}", r[k]);
        }
        let pct = |k: &str| r[k].as_f64().unwrap();
        for k in [
            "cloud_fscore_1_5m",
            "mesh_fscore_1_5m",
            "mesh_false_surface_pct",
        ] {
            assert!((0.0..=100.0).contains(&pct(k)), "{site}: {k}");
        }
        assert!(pct("observable_pct") > 0.0 && pct("observable_pct") <= 100.0);
        assert!(pct("mesh_area_ratio") > 0.0, "{site}: area ratio");
    }
}

#[test]
fn quick_suite_meets_issue_13_bounds() {
    meets_issue_13_bounds(quick_suite());
}

#[test]
#[ignore = "every suite site, quick: about 15 min on two cores"]
fn every_suite_site_meets_issue_13_bounds() {
    let run = quick_suite_all();
    assert_eq!(rows(run).len(), site_names().len(), "{}", run.md);
    meets_issue_13_bounds(run);
}

fn meets_issue_13_bounds(run: &SuiteRun) {
    assert!(run.success, "has-sim suite --quick failed: {}", run.stderr);
    let mut misses = Vec::new();
    for r in rows(run) {
        let site = r["site"].as_str().unwrap_or("?");
        let cd = r["cloud_sqrt_cd_m"].as_f64().unwrap_or(f64::NAN);
        let f = r["cloud_fscore_1_5m"].as_f64().unwrap_or(f64::NAN);
        // A missing figure (NaN) is a miss.
        if cd.is_nan() || cd > ISSUE_13_QUICK_CLOUD_SQRT_CD_MAX_M {
            misses.push(format!("{site}: cloud √CD {cd:.3} m"));
        }
        if f.is_nan() || f < ISSUE_13_QUICK_CLOUD_FSCORE_1_5M_MIN {
            misses.push(format!("{site}: cloud F(1.5 m) {f:.1}"));
        }
    }
    assert!(misses.is_empty(), "{}\n{}", misses.join("\n"), run.md);
}

#[test]
fn bad_suite_arguments_fail_with_one_line() {
    let dir = common::out_dir("suite-bad");
    let suite = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_has-sim"))
            .arg("suite")
            .args(args)
            .arg("--out")
            .arg(&dir)
            .output()
            .expect("has-sim runs")
    };
    let missing = dir.join("no-such-suite");
    let o = suite(&["--suite-dir", missing.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("no-such-suite"), "{err}");

    let o = suite(&[
        "--suite-dir",
        suite_dir().to_str().unwrap(),
        "--sites",
        "nowhere",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("nowhere"), "{err}");
    for site in site_names() {
        assert!(err.contains(&site), "{site} not listed: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_killed_suite_is_marked_unfinished_and_keeps_no_earlier_table() {
    let dir = common::out_dir("suite-killed");
    std::fs::create_dir_all(&dir).unwrap();
    for f in ["suite.json", "suite.md"] {
        std::fs::write(dir.join(f), "an earlier run's table").unwrap();
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .args(["suite", "--quick", "--sites", "office_pair", "--suite-dir"])
        .arg(suite_dir())
        .arg("--out")
        .arg(&dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("has-sim runs");
    // Wait until the site's own run has started (its marker), then kill the suite.
    let t0 = std::time::Instant::now();
    while !dir.join("office_pair").join("RUNNING").exists()
        && t0.elapsed() < std::time::Duration::from_secs(120)
    {
        assert!(child.try_wait().unwrap().is_none(), "suite ended early");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(dir.join("RUNNING").exists(), "no top-level marker");
    assert!(!dir.join("suite.json").exists() && !dir.join("suite.md").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
