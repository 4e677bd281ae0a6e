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

/// An `.npy` file's shape and its data as `f64` words (`<f8`/`<i8` one per element, `<c16` two),
/// read as NumPy writes version 1.0 headers.
fn read_npy(path: &std::path::Path) -> (String, Vec<usize>, Vec<u8>) {
    let b = std::fs::read(path).expect("npy file");
    assert_eq!(&b[..8], b"\x93NUMPY\x01\x00", "{}", path.display());
    let n = u16::from_le_bytes([b[8], b[9]]) as usize;
    let header = std::str::from_utf8(&b[10..10 + n]).expect("header");
    let descr = header.split('\'').nth(3).expect("descr").to_string();
    let shape = header
        .split("'shape': (")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .expect("shape")
        .split(',')
        .filter_map(|d| d.trim().parse().ok())
        .collect();
    (descr, shape, b[10 + n..].to_vec())
}

fn f64s(bytes: &[u8]) -> Vec<f64> {
    bytes
        .chunks(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect()
}

#[test]
fn the_npy_arrays_hold_the_json_s_paths_and_their_frequency_response() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("paths-npy");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let rx = dir.join("rx.csv");
    std::fs::write(&rx, "0,-30,10\n20,-35,2\n").unwrap();
    let npy = dir.join("arrays");
    let (ok, json, err) = paths(&[
        "--tx",
        "-20,-30,12",
        "--rx-file",
        rx.to_str().unwrap(),
        "--json",
        "--npy",
        npy.to_str().unwrap(),
        "--cfr-subcarriers",
        "16",
        "--cfr-spacing-khz",
        "120",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).expect("json");
    let receivers = v["receivers"].as_array().expect("receivers");
    // The search is reported: the default ray count, the candidates it found.
    assert_eq!(v["search"]["rays"].as_u64(), Some(200_000));
    assert!(v["search"]["candidate_sequences"].as_u64() > Some(0));
    let (d, shape, counts) = read_npy(&npy.join("num_paths.npy"));
    assert_eq!((d.as_str(), shape.as_slice()), ("<i8", &[2][..]));
    let counts: Vec<usize> = counts
        .chunks(8)
        .map(|c| i64::from_le_bytes(c.try_into().unwrap()) as usize)
        .collect();
    let p = *counts.iter().max().unwrap();
    assert!(p > 0);
    let (d, shape, tau) = read_npy(&npy.join("tau.npy"));
    assert_eq!((d.as_str(), shape.as_slice()), ("<f8", &[2, p][..]));
    let (d, shape, a) = read_npy(&npy.join("a.npy"));
    assert_eq!((d.as_str(), shape.as_slice()), ("<c16", &[2, p][..]));
    let (_, shape, _) = read_npy(&npy.join("jones.npy"));
    assert_eq!(shape, [2, p, 2, 2]);
    let (tau, a) = (f64s(&tau), f64s(&a));
    let (_, _, freqs) = read_npy(&npy.join("freqs_hz.npy"));
    let freqs = f64s(&freqs);
    assert_eq!(freqs.len(), 16);
    assert_eq!((freqs[0], freqs[8]), (-8.0 * 120e3, 0.0));
    let (d, shape, cfr) = read_npy(&npy.join("cfr.npy"));
    assert_eq!((d.as_str(), shape.as_slice()), ("<c16", &[2, 16][..]));
    let cfr = f64s(&cfr);
    for (r, rec) in receivers.iter().enumerate() {
        let list = rec["paths"].as_array().expect("paths");
        assert_eq!(list.len(), counts[r]);
        for i in 0..p {
            let t = tau[r * p + i];
            match list.get(i) {
                Some(path) => {
                    let ns = path["delay_ns"].as_f64().unwrap();
                    assert!((t * 1e9 - ns).abs() < 1e-9 * ns, "{t} s vs {ns} ns");
                    let re_im = [
                        path["a"][0].as_f64().unwrap(),
                        path["a"][1].as_f64().unwrap(),
                    ];
                    // JSON's decimal text reads back to within an ulp.
                    let (ar, ai) = (a[2 * (r * p + i)], a[2 * (r * p + i) + 1]);
                    let tol = 1e-14 * ar.hypot(ai);
                    assert!((ar - re_im[0]).abs() <= tol && (ai - re_im[1]).abs() <= tol);
                }
                None => assert!(t.is_nan()),
            }
        }
        // H(f) = Σ a e^{−j2πfτ} over the receiver's paths.
        for (k, &f) in freqs.iter().enumerate() {
            let (mut re, mut im) = (0.0, 0.0);
            for i in 0..counts[r] {
                let (ar, ai, t) = (a[2 * (r * p + i)], a[2 * (r * p + i) + 1], tau[r * p + i]);
                let ph = -2.0 * std::f64::consts::PI * (f * t).fract();
                re += ar * ph.cos() - ai * ph.sin();
                im += ar * ph.sin() + ai * ph.cos();
            }
            let (hr, hi) = (cfr[2 * (r * 16 + k)], cfr[2 * (r * 16 + k) + 1]);
            let scale = re.hypot(im).max(1e-300);
            assert!((hr - re).hypot(hi - im) < 1e-9 * scale, "rx {r} f {f}");
        }
    }
    let (ok, _, err) = paths(&[
        "--tx",
        "-20,-30,12",
        "--rx",
        "0,-30,10",
        "--npy",
        npy.to_str().unwrap(),
        "--cfr-subcarriers",
        "0",
    ]);
    assert!(
        !ok && err.starts_with("has-sim: error: --cfr-subcarriers: 0 is not in"),
        "{err}"
    );
}
