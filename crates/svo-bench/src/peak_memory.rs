//! Peak memory of a measured step: Linux keeps the process's resident high-water mark
//! (`VmHWM`), and writing `5` to `/proc/self/clear_refs` resets it to the current resident
//! set, so the peak of one step is its high-water mark less the resident set before it.
//! Elsewhere (or where the reset is refused) the figure is absent, not made up.

/// Resident kilobytes of `field` (`VmRSS`, `VmHWM`) in `/proc/self/status`.
fn status_kib(field: &str) -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let l = s.lines().find(|l| l.starts_with(field))?;
    l.split_whitespace().nth(1)?.parse().ok()
}

/// Runs `f` and returns its result with the bytes its peak resident set grew by, when the
/// platform can tell.
pub fn measure<T>(f: impl FnOnce() -> T) -> (T, Option<u64>) {
    let reset = std::fs::write("/proc/self/clear_refs", "5").is_ok();
    let before = status_kib("VmRSS:");
    let out = f();
    let peak = status_kib("VmHWM:");
    let grew = match (reset, before, peak) {
        (true, Some(b), Some(p)) => Some(p.saturating_sub(b) * 1024),
        _ => None,
    };
    (out, grew)
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_large_allocation_shows() {
        let (_, grew) = super::measure(|| {
            let v = vec![1u8; 64 << 20];
            std::hint::black_box(&v);
            v.iter().map(|&b| u64::from(b)).sum::<u64>()
        });
        if let Some(g) = grew {
            assert!(g >= 60 << 20, "grew by {g} bytes");
        }
    }
}
