//! The machine's memory as Linux reports it in `/proc`: what a new process may use, and the
//! most this process has held. Elsewhere both are unknown (`None`).

pub use svo::bake::available_memory;

/// The process's peak resident set (Linux `VmHWM`), in bytes, if known.
pub fn peak_resident() -> Option<u64> {
    proc_bytes("/proc/self/status", "VmHWM:")
}

/// The value of the `key` line (`KEY: N kB`) of a Linux `/proc` file, in bytes.
fn proc_bytes(file: &str, key: &str) -> Option<u64> {
    let s = std::fs::read_to_string(file).ok()?;
    let line = s.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}
