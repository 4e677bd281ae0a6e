//! The one guard between a run and the files it touches: what it reads is noted as an input of
//! the run, and [`super::atomic_write`] asks [`check_output`] before replacing anything, so that
//! no command writes over a device node, a directory, a fifo, or a file it read; names from a
//! scenario that become parts of file names pass [`check_name_component`].
//!
//! "The run" is the process: a file read once stays an input until the process ends.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// A file's identity: device and inode where the platform has them, else its canonical path.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Identity {
    #[cfg(unix)]
    Inode(u64, u64),
    #[cfg_attr(unix, allow(dead_code))]
    Path(PathBuf),
}

fn identity(meta: &std::fs::Metadata, path: &Path) -> Option<Identity> {
    #[cfg(unix)]
    {
        let _ = path;
        use std::os::unix::fs::MetadataExt;
        Some(Identity::Inode(meta.dev(), meta.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = meta;
        std::fs::canonicalize(path).ok().map(Identity::Path)
    }
}

/// The inputs read so far by this process, with the path each was read as.
static INPUTS: Mutex<Vec<(Identity, PathBuf)>> = Mutex::new(Vec::new());

/// Notes `path` as an input of this run (nothing if it cannot be inspected).
pub(crate) fn note_input(path: &Path) {
    let Ok(meta) = std::fs::metadata(path) else {
        return;
    };
    if let Some(id) = identity(&meta, path) {
        let mut inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
        if !inputs.iter().any(|(i, _)| *i == id) {
            inputs.push((id, path.to_path_buf()));
        }
    }
}

/// Refuses an input that is a directory or a device (reading `/dev/zero` would never end).
fn check_input(path: &Path) -> std::io::Result<()> {
    let meta = std::fs::metadata(path)?;
    let ft = meta.file_type();
    if ft.is_dir() {
        return Err(std::io::Error::other("is a directory, not a file"));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_block_device() || ft.is_char_device() || ft.is_socket() {
            return Err(std::io::Error::other("is a device or socket, not a file"));
        }
    }
    Ok(())
}

/// Reads a whole input file and notes it ([`note_input`]).
///
/// # Errors
/// The OS error, or a directory or device given as the file.
pub fn read_input(path: &Path) -> std::io::Result<Vec<u8>> {
    check_input(path)?;
    let bytes = std::fs::read(path)?;
    note_input(path);
    Ok(bytes)
}

/// [`read_input`] as UTF-8 text.
///
/// # Errors
/// As [`read_input`], or text that is not UTF-8.
pub fn read_input_string(path: &Path) -> std::io::Result<String> {
    String::from_utf8(read_input(path)?)
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidData, "not UTF-8 text"))
}

/// Whether `path` may be replaced by an output: it does not exist, or it is a regular file (a
/// symbolic link is followed) that this run did not read.
///
/// # Errors
/// What is wrong, for a message that names the path.
pub fn check_output(path: &Path) -> Result<(), String> {
    let meta = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e.to_string()),
    };
    if !meta.is_file() {
        let what = if meta.is_dir() {
            "a directory"
        } else {
            "not a regular file (a device, fifo or socket)"
        };
        return Err(format!("it exists and is {what}; refusing to replace it"));
    }
    if let Some(id) = identity(&meta, path) {
        let inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
        // The input must still be there under the name it was read as: a file deleted since
        // (a scratch file) frees its inode for a new, unrelated one.
        let still = |read_as: &Path| {
            std::fs::metadata(read_as)
                .ok()
                .and_then(|m| identity(&m, read_as))
                .is_some_and(|i| i == id)
        };
        if let Some((_, read_as)) = inputs.iter().find(|(i, p)| *i == id && still(p)) {
            return Err(format!(
                "it is {}, an input of this run; refusing to overwrite it",
                read_as.display()
            ));
        }
    }
    Ok(())
}

/// Whether `value` can be part of a file name on every platform the outputs go to: not empty,
/// not `.` or `..`, and without `/`, `\`, NUL or another control character.
///
/// # Errors
/// What is wrong with it.
pub fn check_name_component(value: &str) -> Result<(), &'static str> {
    if value.is_empty() {
        return Err("a non-empty name");
    }
    if value == "." || value == ".." || value.contains("..") {
        return Err("a name without `..` (it becomes part of file names)");
    }
    if value
        .chars()
        .any(|c| c == '/' || c == '\\' || c.is_control())
    {
        return Err(
            "a name without `/`, `\\` or control characters (it becomes part of file names)",
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{atomic_write, testutil::tmp_dir};
    use std::io::Write;

    #[test]
    fn device_nodes_directories_and_fifos_are_not_replaced() {
        let d = tmp_dir("guard-special");
        let sub = d.join("sub");
        std::fs::create_dir(&sub).unwrap();
        let mut targets = vec![sub.clone()];
        if Path::new("/dev/null").exists() {
            targets.push(PathBuf::from("/dev/null"));
            targets.push(PathBuf::from("/dev/full"));
        }
        #[cfg(unix)]
        {
            let fifo = d.join("fifo");
            let ok = std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .is_ok_and(|s| s.success());
            if ok {
                targets.push(fifo);
            }
        }
        for t in &targets {
            if !t.exists() {
                continue;
            }
            let before = std::fs::metadata(t).unwrap().file_type();
            let e = atomic_write(t, |w| w.write_all(b"x"))
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&t.display().to_string()) && e.contains("refusing"),
                "{e}"
            );
            assert_eq!(std::fs::metadata(t).unwrap().file_type(), before);
        }
        // No temporary left beside them.
        let left: Vec<_> = std::fs::read_dir(&d).unwrap().collect();
        assert!(left.len() <= 2, "{left:?}");
    }

    #[test]
    fn a_file_read_by_the_run_is_not_overwritten() {
        let d = tmp_dir("guard-input");
        let (input, other) = (d.join("in.ply"), d.join("other.ply"));
        std::fs::write(&input, "data").unwrap();
        std::fs::write(&other, "data").unwrap();
        read_input(&input).unwrap();
        // Named another way (with `.` in the path), it is the same file.
        let alias = d.join(".").join("in.ply");
        let e = atomic_write(&alias, |w| w.write_all(b"obj"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("an input of this run"), "{e}");
        assert_eq!(std::fs::read_to_string(&input).unwrap(), "data");
        atomic_write(&other, |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read_to_string(&other).unwrap(), "new");
    }

    #[test]
    fn a_directory_or_device_is_not_read_as_a_file() {
        let d = tmp_dir("guard-read");
        assert!(read_input(&d)
            .unwrap_err()
            .to_string()
            .contains("directory"));
        if Path::new("/dev/zero").exists() {
            let e = read_input(Path::new("/dev/zero")).unwrap_err();
            assert!(e.to_string().contains("device"), "{e}");
        }
    }

    #[test]
    fn names_with_separators_dots_or_nothing_are_refused() {
        for bad in [
            "",
            ".",
            "..",
            "../../../tmp/x",
            "a/b",
            "a\\b",
            "a\0b",
            "x..y",
        ] {
            assert!(check_name_component(bad).is_err(), "{bad:?}");
        }
        for good in ["BS1", "V1", "UAV-2", "bs 3", "tür"] {
            assert!(check_name_component(good).is_ok(), "{good:?}");
        }
    }
}
