//! `has-sim paths` from the command line on the bundled factory: an end inside the hall or
//! under the yard, a position beyond the tracer's range, a frequency outside the materials'
//! stated fit, a ray count or exhaustive search beyond the machine each fail before any tracing
//! with one line naming the flag and the value; coincident ends (a monostatic radar) give the
//! echoes and say why there is no line-of-sight path.

use std::process::Command;

fn paths(args: &[&str]) -> (bool, String, String) {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/factory.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .args(["paths", "--scene", scene])
        .args(args)
        .output()
        .expect("has-sim runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn impossible_ends_and_unbounded_work_are_named_errors_before_any_tracing() {
    for (args, start) in [
        (
            &["--tx", "0,0,5", "--rx", "0,-30,10"][..],
            "has-sim: error: --tx: (0, 0, 5) lies inside or under object 'factory'",
        ),
        (
            &["--tx", "0,-30,10", "--rx", "0,-30,-5"][..],
            "has-sim: error: --rx: (0, -30, -5) lies inside or under object 'yard'",
        ),
        (
            &["--tx", "1e30,0,5", "--rx", "0,-30,10"][..],
            "has-sim: error: --tx: tx: position (1000000000000000000000000000000, 0, 5) is beyond",
        ),
        (
            &["--tx", "0,-30,10", "--rx", "0,-40,10", "--freq-ghz", "1e3"][..],
            "has-sim: error: --freq-ghz: frequency_hz: 1000 GHz is outside",
        ),
        (
            &[
                "--tx",
                "0,-30,10",
                "--rx",
                "0,-40,10",
                "--rays",
                "10000000000",
            ][..],
            "has-sim: error: --rays: sbr_rays: 10000000000 is out of range",
        ),
    ] {
        let (ok, _, err) = paths(args);
        assert!(!ok, "{args:?} succeeded");
        assert!(err.starts_with(start), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    }
    // The exhaustive enumeration of order 8 over the factory's facets is ~10^10 sequences:
    // refused where the machine says how much memory it has.
    if has_host::memory::available_memory_bytes().is_some() {
        let (ok, _, err) = paths(&[
            "--tx",
            "0,-30,10",
            "--rx",
            "0,-40,10",
            "--exhaustive",
            "--max-order",
            "8",
        ]);
        assert!(!ok);
        assert!(
            err.starts_with("has-sim: error: --exhaustive: exhaustive candidates:"),
            "{err}"
        );
    }
}

#[test]
fn coincident_ends_give_the_echoes_and_say_there_is_no_line_of_sight() {
    let (ok, out, err) = paths(&["--tx", "0,-30,10", "--rx", "0,-30,10"]);
    assert!(ok, "{err}");
    assert!(err.contains("monostatic"), "{err}");
    assert!(out.contains("reflection(yard)"), "{out}");
    assert!(!out.contains(" los"), "{out}");
}

#[test]
fn a_sionna_xml_scene_is_read_directly() {
    let xml = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fixtures/sionna_small/scene.xml"
    );
    let out = Command::new(env!("CARGO_BIN_EXE_has-sim"))
        .args([
            "paths", "--scene", xml, "--tx", "0,-10,5", "--rx", "5,-12,3",
        ])
        .output()
        .expect("has-sim runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains(" los"), "{stdout}");
    assert!(stdout.contains("reflection(wall)"), "{stdout}");
}

#[test]
fn many_receivers_in_one_call_give_each_receivers_own_paths() {
    let dir = std::env::temp_dir().join(format!("has-paths-rx-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("rx.csv");
    std::fs::write(&file, "# x, y, z\n0,-40,10\n\n5,-45,3\n").unwrap();
    let json = |args: &[&str]| -> serde_json::Value {
        let (ok, out, err) = paths(args);
        assert!(ok, "{err}");
        serde_json::from_str(&out).expect("JSON")
    };
    let many = json(&[
        "--tx",
        "0,-30,10",
        "--rx-file",
        file.to_str().unwrap(),
        "--json",
    ]);
    let receivers = many["receivers"].as_array().expect("receivers");
    assert_eq!(receivers.len(), 2);
    for (r, rx) in receivers.iter().zip(["0,-40,10", "5,-45,3"]) {
        let one = json(&["--tx", "0,-30,10", "--rx", rx, "--json"]);
        assert!(!one["paths"].as_array().unwrap().is_empty());
        assert_eq!(r["paths"], one["paths"], "{rx}");
    }
    std::fs::write(&file, "0,-40,10\n1,2\n").unwrap();
    let (ok, _, err) = paths(&["--tx", "0,-30,10", "--rx-file", file.to_str().unwrap()]);
    assert!(!ok);
    assert!(err.contains("line 2: '1,2' is not X,Y,Z"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
