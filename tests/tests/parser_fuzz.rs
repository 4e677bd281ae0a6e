//! Randomised mutation tests of every parser a user's file reaches: PLY, OBJ, Mitsuba XML, the
//! scenario TOML (parsed, validated and its scene built) and the receivers file of
//! `paths --rx-file`. Each starts from real fixtures and applies a few random byte-level and
//! token-level mutations (bit flips, insertions, deletions, duplicated spans, numbers such as
//! `4000000000`, `1e30`, `nan`, `-1` put in place of a number); every input must give a value or
//! an error, never a panic. The short variants run in CI (a few thousand inputs per parser); the
//! `#[ignore]`d long one runs `HAS_FUZZ_INPUTS` per parser (default 10 M), with seed
//! `HAS_FUZZ_SEED`, over the parsers `HAS_FUZZ_PARSERS` names (default
//! `ply,obj,rx,toml,xml`):
//! `cargo test --release -p has-tests --test parser_fuzz -- --ignored --nocapture`. An input
//! that takes longer than `HAS_FUZZ_SLOW_S` seconds (default 5) fails the run as a hang.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures")
}

/// Numbers and tokens a mutation puts into the text.
const TOKENS: [&str; 24] = [
    "4000000000",
    "18446744073709551615",
    "200000",
    "1e30",
    "-1e30",
    "1e-30",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "-1",
    "0",
    "-0",
    "65535",
    "2147483648",
    "\"\"",
    "\"../../x\"",
    "[]",
    "[[",
    "=",
    "\n",
    "\0",
    "element vertex 4000000000\n",
    "f 1 2 3\n",
];

/// `seed` with 1–8 random mutations.
fn mutate(rng: &mut ChaCha8Rng, seed: &[u8]) -> Vec<u8> {
    let mut v = seed.to_vec();
    for _ in 0..rng.random_range(1..=8) {
        let len = v.len().max(1);
        let at = rng.random_range(0..len).min(v.len());
        match rng.random_range(0..7) {
            0 if !v.is_empty() => {
                let i = at.min(v.len() - 1);
                v[i] ^= 1 << rng.random_range(0..8);
            }
            1 if !v.is_empty() => {
                let i = at.min(v.len() - 1);
                v[i] = rng.random();
            }
            2 => {
                let n = rng.random_range(1..=8);
                let bytes: Vec<u8> = (0..n).map(|_| rng.random()).collect();
                v.splice(at..at, bytes);
            }
            3 => {
                let end = (at + rng.random_range(1..=64)).min(v.len());
                v.drain(at..end);
            }
            4 => {
                let end = (at + rng.random_range(1..=256)).min(v.len());
                let span = v[at..end].to_vec();
                v.splice(at..at, span);
            }
            5 => {
                let t = TOKENS[rng.random_range(0..TOKENS.len())].as_bytes();
                v.splice(at..at, t.iter().copied());
            }
            _ => {
                // A number in the text (a run of digits from `at` on) replaced by a token.
                if let Some(start) = v[at..].iter().position(u8::is_ascii_digit).map(|p| at + p) {
                    let end = v[start..]
                        .iter()
                        .position(|b| !(b.is_ascii_digit() || *b == b'.'))
                        .map_or(v.len(), |p| start + p);
                    let t = TOKENS[rng.random_range(0..15)].as_bytes();
                    v.splice(start..end, t.iter().copied());
                }
            }
        }
    }
    v
}

/// Wall time one input may take before it counts as a hang, seconds (`HAS_FUZZ_SLOW_S`,
/// default 5).
fn slow_limit_s() -> f64 {
    std::env::var("HAS_FUZZ_SLOW_S")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5.0)
}

/// Runs `parse` on `inputs` mutations of the seeds, with seed `seed`; panics naming the first
/// input (written beside the test's scratch files) that panicked or took longer than
/// [`slow_limit_s`]. Prints the counts, the wall time and the slowest input, and a progress
/// line every 10⁶ inputs. Returns (ok, err) counts.
fn fuzz(
    name: &str,
    seeds: &[Vec<u8>],
    inputs: u64,
    seed: u64,
    parse: impl Fn(&[u8]) -> bool,
) -> (u64, u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut ok, mut err) = (0, 0);
    let limit = slow_limit_s();
    let t0 = std::time::Instant::now();
    let mut slowest = (0.0f64, 0u64);
    let save = |i: u64, input: &[u8]| {
        let p = std::env::temp_dir().join(format!("has-fuzz-{name}-{seed}-{i}.bin"));
        std::fs::write(&p, input).unwrap();
        p
    };
    for i in 0..inputs {
        let base = &seeds[rng.random_range(0..seeds.len())];
        let input = mutate(&mut rng, base);
        let t = std::time::Instant::now();
        match catch_unwind(AssertUnwindSafe(|| parse(&input))) {
            Ok(true) => ok += 1,
            Ok(false) => err += 1,
            Err(_) => {
                let p = save(i, &input);
                panic!("{name}: input {i} panicked; saved to {}", p.display());
            }
        }
        let dt = t.elapsed().as_secs_f64();
        if dt > slowest.0 {
            slowest = (dt, i);
        }
        if dt > limit {
            let p = save(i, &input);
            panic!(
                "{name}: input {i} took {dt:.1} s (over {limit} s); saved to {}",
                p.display()
            );
        }
        if (i + 1) % 1_000_000 == 0 && i + 1 < inputs {
            eprintln!(
                "{name}: {} inputs, {:.0} s",
                i + 1,
                t0.elapsed().as_secs_f64()
            );
        }
    }
    eprintln!(
        "{name}: {inputs} inputs, {ok} parsed, {err} refused; {:.0} s, slowest input {} ({:.3} s)",
        t0.elapsed().as_secs_f64(),
        slowest.1,
        slowest.0
    );
    (ok, err)
}

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn ply_seeds() -> Vec<Vec<u8>> {
    let f = fixtures();
    let mut v = vec![
        read(&f.join("sionna_small/meshes/wall.ply")),
        read(&f.join("sionna_small/meshes/floor.ply")),
    ];
    v.push(
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
          property float z\nproperty float intensity\nelement face 1\n\
          property list uchar int vertex_indices\nend_header\n0 0 0 1\n1 0 0 0.5\n0 1 0 0.2\n\
          3 0 1 2\n"
            .to_vec(),
    );
    v
}

fn parse_ply(b: &[u8]) -> bool {
    has_host::io::ply::parse_ply(b, Path::new("fuzz.ply")).is_ok()
}

fn obj_seeds() -> Vec<Vec<u8>> {
    vec![
        read(&fixtures().join("holdout/courtyard_ring/courtyard.obj")),
        b"o box\nusemtl itu_concrete\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n\
          f -1 -2 -3\n"
            .to_vec(),
    ]
}

fn parse_obj(b: &[u8]) -> bool {
    let text = String::from_utf8_lossy(b);
    has_host::io::obj::parse_obj(&text, Path::new("fuzz.obj"), None).is_ok()
}

fn xml_seeds() -> Vec<Vec<u8>> {
    vec![read(&fixtures().join("sionna_small/scene.xml"))]
}

fn parse_xml(b: &[u8]) -> bool {
    let text = String::from_utf8_lossy(b);
    // The fixture's path: its mesh files resolve beside it.
    let path = fixtures().join("sionna_small/scene.xml");
    has_host::io::mitsuba::parse_mitsuba(&text, &path).is_ok()
}

fn toml_seeds() -> Vec<Vec<u8>> {
    let f = fixtures();
    [
        "factory.toml",
        "city_block.toml",
        "suite/office_pair.toml",
        "suite/street_row.toml",
    ]
    .iter()
    .map(|n| read(&f.join(n)))
    .collect()
}

fn parse_toml(b: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(b) else {
        return false;
    };
    match has_host::scenario::Scenario::from_toml_str(text) {
        // The scene too: its counts go through the size guard before anything is built.
        Ok(sc) => sc.scene.build_objects().is_ok(),
        Err(_) => has_host::scenario::SceneSpec::from_toml_str(text)
            .is_ok_and(|s| s.build_objects().is_ok()),
    }
}

fn rx_seeds() -> Vec<Vec<u8>> {
    vec![
        b"# receivers\n1,2,1.5\n-40.5,20,1.5\n\n3e1, -2e1, 2\n".to_vec(),
        (0..50)
            .map(|i| format!("{},{},{}\n", i as f64 * 0.5, -(i as f64), 1.5))
            .collect::<String>()
            .into_bytes(),
    ]
}

fn parse_rx(b: &[u8]) -> bool {
    let text = String::from_utf8_lossy(b);
    has_host::paths::report::parse_receivers(&text, Path::new("fuzz.csv")).is_ok()
}

/// Inputs per parser of the short variant.
const SHORT: u64 = 3000;

#[test]
fn mutated_ply_files_never_panic() {
    let (ok, err) = fuzz("ply", &ply_seeds(), SHORT, 1, parse_ply);
    // Both outcomes are reached: the mutations neither all break nor all spare the files.
    assert!(ok > 0 && err > 0, "{ok} / {err}");
}

#[test]
fn mutated_obj_files_never_panic() {
    let (ok, err) = fuzz("obj", &obj_seeds(), SHORT, 2, parse_obj);
    assert!(ok > 0 && err > 0, "{ok} / {err}");
}

#[test]
fn mutated_mitsuba_scenes_never_panic() {
    let (ok, err) = fuzz("xml", &xml_seeds(), SHORT / 3, 3, parse_xml);
    assert!(ok > 0 && err > 0, "{ok} / {err}");
}

#[test]
fn mutated_scenarios_never_panic() {
    let (ok, err) = fuzz("toml", &toml_seeds(), SHORT / 3, 4, parse_toml);
    assert!(ok > 0 && err > 0, "{ok} / {err}");
}

#[test]
fn mutated_receiver_files_never_panic() {
    let (ok, err) = fuzz("rx", &rx_seeds(), SHORT, 5, parse_rx);
    assert!(ok > 0 && err > 0, "{ok} / {err}");
}

#[test]
#[ignore = "long: HAS_FUZZ_INPUTS (default 10 M) inputs per parser"]
fn long_fuzz_of_every_parser() {
    let n: u64 = std::env::var("HAS_FUZZ_INPUTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000_000);
    let seed: u64 = std::env::var("HAS_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(62);
    let which = std::env::var("HAS_FUZZ_PARSERS").unwrap_or("ply,obj,rx,toml,xml".into());
    for name in which.split(',') {
        match name {
            "ply" => fuzz(name, &ply_seeds(), n, seed, parse_ply),
            "obj" => fuzz(name, &obj_seeds(), n, seed, parse_obj),
            "rx" => fuzz(name, &rx_seeds(), n, seed, parse_rx),
            "toml" => fuzz(name, &toml_seeds(), n, seed, parse_toml),
            "xml" => fuzz(name, &xml_seeds(), n, seed, parse_xml),
            other => panic!("HAS_FUZZ_PARSERS: unknown parser '{other}'"),
        };
    }
}
