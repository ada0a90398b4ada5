//! A check before allocating a run: the memory it will need against what the machine has
//! available, so that an impossible size is a typed error up front instead of an abort
//! in the allocator.

/// The memory the system reports as available (`MemAvailable` of `/proc/meminfo` on
/// Linux), or `None` where it cannot tell.
pub fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
}

/// `Err(message)` when `bytes` exceeds the available memory (no check where it is unknown).
pub fn check(bytes: f64) -> Result<(), String> {
    match available_bytes() {
        Some(avail) if bytes > avail as f64 => Err(format!(
            "the run needs about {:.1} GiB, {:.1} GiB are available",
            bytes / 1024f64.powi(3),
            avail as f64 / 1024f64.powi(3)
        )),
        _ => Ok(()),
    }
}
