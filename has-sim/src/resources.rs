//! Process resource figures for reports: the peak resident set size, read from Linux's
//! `/proc/self/status` (`VmHWM`), and its reset (`/proc/self/clear_refs`) so that one process
//! running several reconstructions (`has-sim suite`) reports each one's peak. Other platforms
//! report `None` and do not reset.

/// Peak resident set size of this process so far, MiB; `None` where `/proc` is unavailable.
pub fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Resets the peak resident set size to the current one (Linux ≥ 4.0: `5` written to
/// `/proc/self/clear_refs`); returns whether it did. Later [`peak_rss_mib`] calls report the
/// peak since this call (memory still held then counts from the start).
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
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

    #[test]
    fn a_reset_peak_forgets_a_freed_allocation() {
        if !cfg!(target_os = "linux") {
            return;
        }
        // 256 MiB touched, freed, then the peak reset: the peak falls back below it.
        let big = vec![1u8; 256 << 20];
        std::hint::black_box(&big);
        let high = super::peak_rss_mib().unwrap();
        drop(big);
        if super::reset_peak_rss() {
            let low = super::peak_rss_mib().unwrap();
            assert!(low < high - 128.0, "{low} vs {high}");
        }
    }
}
