//! Runs are deterministic for a given seed at any thread count: `has-sim localize --quick` with
//! the true scene as its twin writes the same detections, bit for bit, on one thread and on two
//! (the imaging driver's own test compares a pair's image the same way).

use std::process::Command;

mod common;

#[test]
fn quick_localization_gives_the_same_bits_on_one_thread_and_on_two() {
    let run = |threads: &str| {
        let out = common::out_dir(&format!("determinism-{threads}"));
        let ok = Command::new(env!("CARGO_BIN_EXE_has-sim"))
            .args(["localize", "--quick", "--truth-twin", "--out"])
            .arg(&out)
            .env("RAYON_NUM_THREADS", threads)
            .status()
            .expect("has-sim runs")
            .success();
        assert!(ok, "localize on {threads} thread(s)");
        out
    };
    let (one, two) = (run("1"), run("2"));
    for f in ["detections_eca.ply", "detections_env.ply", "truth.ply"] {
        let a = std::fs::read(one.join(f)).expect(f);
        let b = std::fs::read(two.join(f)).expect(f);
        assert!(a.len() > 100, "{f} is empty");
        assert!(a == b, "{f} differs between 1 and 2 threads");
    }
    let _ = std::fs::remove_dir_all(&one);
    let _ = std::fs::remove_dir_all(&two);
}
