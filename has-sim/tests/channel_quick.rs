//! Bad `[channel]` input ends `has-sim channel` with one readable line naming the field and the
//! value, before any reconstruction. (The quick run on the bundled factory is held to its
//! numbers in `quick_pipeline.rs`.)

mod common;

use std::process::Command;

/// A twin that is not a mesh (here the scenario file itself) is an error naming the file (read
/// by its extension, as every mesh input is), not a twin with no faces that blocks nothing and
/// scores 0 errors.
#[test]
fn a_twin_that_is_not_a_mesh_fails_with_one_line() {
    let dir = common::out_dir("channel-twin-not-mesh");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .args([
            "channel",
            "--quick",
            "--twin",
            "../fixtures/factory.toml",
            "--out",
        ])
        .arg(&dir)
        .output()
        .expect("has-sim runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("factory.toml: unsupported: file extension 'toml'"),
        "{err}"
    );
    assert!(!dir.join("report.json").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_channel_table_fails_with_one_line_naming_field_and_value() {
    let dir = common::out_dir("channel-bad");
    std::fs::create_dir_all(&dir).unwrap();
    let factory = include_str!("../../fixtures/factory.toml");
    for (from, to, want) in [
        (
            "bs_position = [-45.0, -40.0, 20.0]",
            "bs_position = [-45.0, nan, 20.0]",
            "channel.bs_position: [-45.0, NaN, 20.0]",
        ),
        ("ues = 500", "ues = 0", "channel.ues: 0"),
        (
            "max_loss_db = 110.0",
            "max_loss_db = -110.0",
            "channel.max_loss_db: -110.0",
        ),
        (
            "window_db = 20.0",
            "window_db = nan",
            "channel.window_db: NaN",
        ),
        ("seed = 7", "seed = 7\nbogus = 1", "bogus"),
    ] {
        assert!(factory.contains(from), "{from}");
        let (ok, err) = common::run_on_text("channel", &dir, &factory.replacen(from, to, 1));
        assert!(!ok, "{to}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(want), "{err} (want {want})");
    }
    // A scenario without a [channel] table.
    let cut = factory.find("[channel]").unwrap();
    let (ok, err) = common::run_on_text("channel", &dir, &factory[..cut]);
    assert!(!ok);
    assert!(err.contains("no [channel] table"), "{err}");
    // A twin that does not exist.
    let out = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .args(["channel", "--twin"])
        .arg(dir.join("missing.obj"))
        .arg("--out")
        .arg(dir.join("out"))
        .output()
        .expect("has-sim runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--twin") && err.contains("missing.obj"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
