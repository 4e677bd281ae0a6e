//! What the machine has: the memory a run may allocate, read before anything large is built so
//! that a run which will not fit is refused with its estimate instead of aborting half-way.

/// `MemAvailable` of `/proc/meminfo`, bytes (None where there is no such file, e.g. not Linux:
/// callers then skip the check).
pub fn available_memory_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Bytes as GiB, for messages.
pub fn gib(bytes: f64) -> f64 {
    bytes / (1u64 << 30) as f64
}

/// `Some((need_gib, have_gib))` when `need_bytes` exceeds the memory available; `None` when it
/// fits or the machine does not say.
pub fn shortfall(need_bytes: f64) -> Option<(f64, f64)> {
    let have = available_memory_bytes()? as f64;
    (need_bytes > have).then(|| (gib(need_bytes), gib(have)))
}
