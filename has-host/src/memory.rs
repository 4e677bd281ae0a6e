//! What the process may allocate, and the one guard every size a file or flag sets goes through
//! ([`check_size`]) before anything is allocated, so that a run which will not fit is refused
//! with its estimate instead of aborting half-way.
//!
//! The room is the least of three figures, each read on Linux and skipped where absent:
//! `MemAvailable` of `/proc/meminfo`; the process's address-space limit (`RLIMIT_AS`, "Max
//! address space" of `/proc/self/limits`) less the address space it already uses (`VmSize` of
//! `/proc/self/status`); and its cgroup's limit (`memory.max`, or cgroup v1's
//! `memory.limit_in_bytes`) less the cgroup's current use.

/// Which of the limits sets the room.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Limit {
    /// `MemAvailable` of `/proc/meminfo`.
    MemAvailable,
    /// The address-space limit (`ulimit -v`, `prlimit --as`).
    AddressSpace,
    /// The cgroup's memory limit (a container's).
    Cgroup,
}

impl Limit {
    /// How messages name it.
    pub fn describe(self) -> &'static str {
        match self {
            Limit::MemAvailable => "MemAvailable",
            Limit::AddressSpace => "the address-space limit, RLIMIT_AS",
            Limit::Cgroup => "the cgroup's memory.max",
        }
    }
}

/// The first number after `key` on the line of `text` starting with `key` (`/proc` formats).
fn field_after(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    line[key.len()..].split_whitespace().next()?.parse().ok()
}

/// The soft address-space limit in bytes from the text of `/proc/self/limits` (None when
/// unlimited or absent).
fn address_space_limit(limits: &str) -> Option<u64> {
    field_after(limits, "Max address space")
}

/// A cgroup limit file's value in bytes (None for `max` or a v1 "no limit" near 2⁶³).
fn cgroup_limit(text: &str) -> Option<u64> {
    let v: u64 = text.trim().parse().ok()?;
    (v < 1 << 60).then_some(v)
}

/// The room each known limit leaves, bytes.
fn rooms() -> Vec<(u64, Limit)> {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    let mut out = Vec::new();
    if let Some(kib) = read("/proc/meminfo").and_then(|t| field_after(&t, "MemAvailable:")) {
        out.push((kib.saturating_mul(1024), Limit::MemAvailable));
    }
    if let Some(limit) = read("/proc/self/limits").and_then(|t| address_space_limit(&t)) {
        let used = read("/proc/self/status")
            .and_then(|t| field_after(&t, "VmSize:"))
            .unwrap_or(0)
            .saturating_mul(1024);
        out.push((limit.saturating_sub(used), Limit::AddressSpace));
    }
    for (max, current) in [
        ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
        (
            "/sys/fs/cgroup/memory/memory.limit_in_bytes",
            "/sys/fs/cgroup/memory/memory.usage_in_bytes",
        ),
    ] {
        if let Some(limit) = read(max).and_then(|t| cgroup_limit(&t)) {
            let used = read(current)
                .and_then(|t| t.trim().parse::<u64>().ok())
                .unwrap_or(0);
            out.push((limit.saturating_sub(used), Limit::Cgroup));
            break;
        }
    }
    out
}

/// The bytes this process may still allocate and the limit that sets them (module docs); None
/// where no limit is known (not Linux): callers then skip the check.
pub fn room() -> Option<(u64, Limit)> {
    rooms().into_iter().min_by_key(|&(b, _)| b)
}

/// [`room`] in bytes.
pub fn available_memory_bytes() -> Option<u64> {
    room().map(|(b, _)| b)
}

/// Bytes as GiB, for messages.
pub fn gib(bytes: f64) -> f64 {
    bytes / (1u64 << 30) as f64
}

/// `Some((need_gib, have_gib))` when `need_bytes` exceeds the room ([`room`]); `None` when it
/// fits or the machine does not say.
pub fn shortfall(need_bytes: f64) -> Option<(f64, f64)> {
    let have = available_memory_bytes()? as f64;
    (need_bytes.is_nan() || need_bytes > have).then(|| (gib(need_bytes), gib(have)))
}

/// A size a file or flag set that would not fit in memory.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "{field}: {value} needs about {need_gib:.1} GiB, more than the {have_gib:.1} GiB this \
     process may allocate ({})",
    limit.describe()
)]
pub struct TooLarge {
    /// The field or flag, as the user wrote it.
    pub field: String,
    /// Its value.
    pub value: String,
    /// The estimate, GiB.
    pub need_gib: f64,
    /// The room, GiB.
    pub have_gib: f64,
    /// Which limit sets the room.
    pub limit: Limit,
}

/// The one size guard: refuses `field` = `value` when the `need_bytes` it implies exceed what
/// the process may allocate ([`room`]). Call it before allocating.
///
/// # Errors
/// [`TooLarge`] naming the field, the value and both figures.
pub fn check_size(
    field: impl std::fmt::Display,
    value: impl std::fmt::Display,
    need_bytes: f64,
) -> Result<(), TooLarge> {
    let Some((have, limit)) = room() else {
        return Ok(());
    };
    if need_bytes.is_nan() || need_bytes > have as f64 {
        return Err(TooLarge {
            field: field.to_string(),
            value: value.to_string(),
            need_gib: gib(need_bytes),
            have_gib: gib(have as f64),
            limit,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_address_space_and_cgroup_limits_are_read_from_their_files() {
        let limits =
            "Limit                     Soft Limit           Hard Limit           Units     \n\
            Max stack size            8388608              unlimited            bytes     \n\
            Max address space         6442450944           unlimited            bytes     \n";
        assert_eq!(address_space_limit(limits), Some(6_442_450_944));
        let unlimited = limits.replace("6442450944  ", "unlimited   ");
        assert_eq!(address_space_limit(&unlimited), None);
        assert_eq!(cgroup_limit("max\n"), None);
        assert_eq!(cgroup_limit("2147483648\n"), Some(2 << 30));
        assert_eq!(cgroup_limit("9223372036854771712\n"), None);
    }

    #[test]
    fn a_size_beyond_the_room_is_refused_naming_field_value_and_limit() {
        let Some((have, _)) = room() else {
            return;
        };
        let e = check_size(
            "scene.objects[0].cells",
            "[200000, 200000]",
            2.0 * have as f64,
        )
        .unwrap_err();
        let s = e.to_string();
        assert!(
            s.starts_with("scene.objects[0].cells: [200000, 200000] needs about"),
            "{s}"
        );
        assert!(check_size("x", 1, f64::NAN).is_err());
        check_size("x", 1, 1024.0).unwrap();
    }

    #[test]
    fn the_room_is_no_more_than_mem_available() {
        let Some(avail) = std::fs::read_to_string("/proc/meminfo")
            .ok()
            .and_then(|t| field_after(&t, "MemAvailable:"))
        else {
            return;
        };
        // MemAvailable moves between the two reads; allow it a GiB.
        assert!(available_memory_bytes().unwrap() <= avail * 1024 + (1 << 30));
    }
}
