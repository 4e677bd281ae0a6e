//! A command's output directory, complete or visibly incomplete and never mixed with an earlier
//! run: [`RunDir::start`] creates it and proves it writable before any work, removes the files an
//! earlier run of the same command wrote there (and the temporaries of `io::atomic_write` that a
//! killed run left), and writes the marker [`MARKER`] holding the command line;
//! [`RunDir::finish`] removes the marker once every output is written. A directory that still
//! holds `RUNNING` is from a run that was killed or failed.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// Name of the marker of an unfinished run.
pub const MARKER: &str = "RUNNING";

/// An output directory being written (module docs).
#[derive(Debug)]
pub struct RunDir {
    marker: PathBuf,
}

/// Whether `name` matches `pattern`: the exact name, or `prefix*suffix` with one `*`.
fn matches(pattern: &str, name: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == name,
        Some((pre, suf)) => {
            name.len() >= pre.len() + suf.len() && name.starts_with(pre) && name.ends_with(suf)
        }
    }
}

/// Whether `name` is a temporary of `io::atomic_write` (`.<file>.<pid>.<seq>.tmp`) for a file
/// matching one of `outputs`.
fn is_stale_temporary(outputs: &[&str], name: &str) -> bool {
    let Some(inner) = name.strip_prefix('.').and_then(|n| n.strip_suffix(".tmp")) else {
        return false;
    };
    // Drop `.<pid>.<seq>`.
    let mut parts = inner.rsplitn(3, '.');
    let (Some(seq), Some(pid), Some(file)) = (parts.next(), parts.next(), parts.next()) else {
        return false;
    };
    let numeric = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    numeric(seq) && numeric(pid) && outputs.iter().any(|p| matches(p, file))
}

impl RunDir {
    /// Prepares `out` for a run writing `outputs` (exact names or `prefix*suffix` patterns).
    ///
    /// # Errors
    /// `--out` named with the path when the directory cannot be created or written, or an
    /// earlier output cannot be removed.
    pub fn start(out: &Path, outputs: &[&str]) -> Result<RunDir> {
        std::fs::create_dir_all(out)
            .with_context(|| format!("--out: creating {}", out.display()))?;
        let entries =
            std::fs::read_dir(out).with_context(|| format!("--out: reading {}", out.display()))?;
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let ours = name == MARKER
                || outputs.iter().any(|p| matches(p, &name))
                || is_stale_temporary(outputs, &name);
            if ours && e.path().is_file() {
                std::fs::remove_file(e.path()).with_context(|| {
                    format!("--out: removing {} of an earlier run", e.path().display())
                })?;
            }
        }
        let marker = out.join(MARKER);
        let line = std::env::args().collect::<Vec<_>>().join(" ");
        has_host::io::atomic_write(&marker, |w| {
            std::io::Write::write_all(w, format!("{line}\n").as_bytes())
        })
        .with_context(|| format!("--out: {} is not writable", out.display()))?;
        Ok(RunDir { marker })
    }

    /// Marks the run complete (removes the marker).
    ///
    /// # Errors
    /// The marker cannot be removed.
    pub fn finish(self) -> Result<()> {
        std::fs::remove_file(&self.marker)
            .with_context(|| format!("removing {}", self.marker.display()))
    }
}

/// Checks, before any work, that the output file of `flag` can be written: its directory
/// exists, and the file is absent or a regular file this run did not read
/// ([`has_host::io::guard::check_output`]).
///
/// # Errors
/// One line naming the flag and the path.
pub fn check_output_file(flag: &str, path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        anyhow::bail!(
            "{flag}: {}: the directory {} does not exist",
            path.display(),
            dir.display()
        );
    }
    has_host::io::guard::check_output(path)
        .map_err(|msg| anyhow::anyhow!("{flag}: {}: {msg}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_and_temporaries_match_only_a_commands_own_files() {
        assert!(matches("pair_*.ply", "pair_BS1-V1.ply"));
        assert!(!matches("pair_*.ply", "pair_.pl"));
        assert!(matches("report.json", "report.json"));
        assert!(!matches("report.json", "report.json.bak"));
        let outputs = ["fused.ply", "pair_*.ply"];
        assert!(is_stale_temporary(&outputs, ".fused.ply.1234.7.tmp"));
        assert!(is_stale_temporary(&outputs, ".pair_BS2-V1.ply.99.0.tmp"));
        assert!(!is_stale_temporary(&outputs, ".notes.txt.1234.7.tmp"));
        assert!(!is_stale_temporary(&outputs, ".fused.ply.abc.7.tmp"));
        assert!(!is_stale_temporary(&outputs, "fused.ply.1234.7.tmp"));
    }

    #[test]
    fn an_earlier_runs_files_go_a_users_stay_and_the_marker_lasts_until_finish() {
        let d = std::env::temp_dir().join(format!("has-run-dir-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        for f in [
            "pair_BS2-V1.ply",
            ".fused.ply.4242.3.tmp",
            "notes.txt",
            MARKER,
        ] {
            std::fs::write(d.join(f), b"x").unwrap();
        }
        let run = RunDir::start(&d, &["fused.ply", "pair_*.ply"]).unwrap();
        let mut left: Vec<String> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, [MARKER, "notes.txt"]);
        run.finish().unwrap();
        assert!(!d.join(MARKER).exists());
        assert!(d.join("notes.txt").exists());
        // Below a regular file, no directory can be made: one error naming --out.
        let e = RunDir::start(&d.join("notes.txt").join("x"), &[]).unwrap_err();
        assert!(format!("{e:#}").contains("--out"), "{e:#}");
        let _ = std::fs::remove_dir_all(&d);
    }
}
