//! Process resource figures for reports: the peak resident set size, read from Linux's
//! `/proc/self/status` (`VmHWM`). Other platforms report `None`.

/// Peak resident set size of this process so far, MiB; `None` where `/proc` is unavailable.
pub fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

#[cfg(test)]
mod tests {
    #[test]
    fn peak_rss_is_positive_on_linux() {
        if cfg!(target_os = "linux") {
            let v = super::peak_rss_mib().expect("VmHWM on Linux");
            assert!(v > 0.1 && v < 1.0e6, "{v}");
        }
    }
}
