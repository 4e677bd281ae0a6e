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
    assert_plots_open(out);
}

/// Largest plot file a run may write (issue 16: a plot a person opens, not a 10 MB scatter).
pub const MAX_PLOT_BYTES: u64 = 2 * 1024 * 1024;

/// Every plot in `out`: at most [`MAX_PLOT_BYTES`]; a PNG decodes to an RGB image that is not
/// one flat colour, an SVG is an `<svg` document.
pub fn assert_plots_open(out: &Path) {
    for entry in std::fs::read_dir(out).expect("run directory") {
        let path = entry.expect("directory entry").path();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext != "png" && ext != "svg" {
            continue;
        }
        let bytes = std::fs::read(&path).expect("plot file");
        assert!(
            (bytes.len() as u64) <= MAX_PLOT_BYTES,
            "{}: {} bytes, over {MAX_PLOT_BYTES}",
            path.display(),
            bytes.len()
        );
        if ext == "svg" {
            assert!(
                String::from_utf8_lossy(&bytes).contains("<svg"),
                "{} is not SVG",
                path.display()
            );
            continue;
        }
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
            .read_info()
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader
            .next_frame(&mut buf)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(info.color_type, png::ColorType::Rgb, "{}", path.display());
        let px = &buf[..info.buffer_size()];
        assert!(
            px.chunks(3).any(|p| p != &px[..3]),
            "{} is one flat colour",
            path.display()
        );
    }
}

/// A Chromium to open pages with: `$HAS_CHROMIUM`, else the first of `chromium`,
/// `chromium-browser`, `google-chrome` that runs; `None` when there is none.
pub fn chromium() -> Option<String> {
    let candidates = std::env::var("HAS_CHROMIUM").into_iter().chain(
        ["chromium", "chromium-browser", "google-chrome"]
            .iter()
            .map(|s| s.to_string()),
    );
    for c in candidates {
        let ok = Command::new(&c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success());
        if ok {
            return Some(c);
        }
    }
    None
}

/// `DIR/report.html` opens in headless Chromium (software WebGL): the 3D viewer draws at least
/// one layer and reports no error, the browser logs no console message, and a screenshot is not
/// one flat colour. Skipped, saying so, where no Chromium is installed.
pub fn assert_html_renders(dir: &Path) {
    let page = dir.join("report.html");
    assert!(page.is_file(), "{} missing", page.display());
    let Some(chromium) = chromium() else {
        eprintln!(
            "skipped: no Chromium to open {} (install Debian's `chromium` or set HAS_CHROMIUM)",
            page.display()
        );
        return;
    };
    let url = format!(
        "file://{}",
        page.canonicalize().expect("absolute path").display()
    );
    let browser = |extra: &[&str]| {
        let out = Command::new(&chromium)
            .args([
                "--headless",
                "--no-sandbox",
                "--enable-unsafe-swiftshader",
                "--use-angle=swiftshader",
                "--enable-logging=stderr",
                "--v=0",
                "--window-size=1100,1400",
            ])
            .args(extra)
            .arg(&url)
            .output()
            .expect("running chromium");
        assert!(out.status.success(), "chromium failed on {url}");
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        let console: Vec<&str> = stderr.lines().filter(|l| l.contains(":CONSOLE")).collect();
        assert!(console.is_empty(), "{url}: console messages {console:?}");
        out.stdout
    };
    let dom = String::from_utf8_lossy(&browser(&["--dump-dom"])).to_string();
    let body = dom
        .find("<body")
        .map(|i| &dom[i..i + dom[i..].find('>').unwrap_or(0)])
        .unwrap_or("");
    assert!(!body.contains("data-error"), "{url}: {body}");
    let drawn: usize = body
        .split("data-rendered=\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or(0);
    assert!(drawn >= 1, "{url}: the 3D view drew nothing ({body})");
    let shot = dir.join("report-screenshot.png");
    let arg = format!("--screenshot={}", shot.display());
    browser(&[&arg]);
    let bytes = std::fs::read(&shot).expect("screenshot");
    let _ = std::fs::remove_file(&shot);
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .expect("screenshot PNG");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("screenshot pixels");
    let px = &buf[..info.buffer_size()];
    let step = info.color_type.samples();
    assert!(
        px.chunks(step).any(|p| p != &px[..step]),
        "{url}: the screenshot is one flat colour"
    );
}
