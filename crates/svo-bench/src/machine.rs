//! What the figures were measured on: CPU, cores, memory, threads, date and commit, so that
//! every table in the report can say it.

use std::process::Command;

/// The machine and build the report was made on.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Machine {
    /// CPU model (`/proc/cpuinfo`).
    pub cpu: String,
    /// Logical cores available to this process.
    pub cores: usize,
    /// Total memory, GiB (`/proc/meminfo`).
    pub memory_gib: f64,
    /// Worker threads of the parallel passes.
    pub threads: usize,
    /// The date, UTC, `YYYY-MM-DD`.
    pub date: String,
    /// The source revision (`git describe`), with `-dirty` for uncommitted changes.
    pub commit: String,
}

impl Machine {
    /// Reads the machine it runs on.
    pub fn detect() -> Self {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split(':').nth(1))
                    .map(|s| s.trim().to_string())
            })
            .unwrap_or_else(|| "unknown CPU".into());
        let memory_gib = std::fs::read_to_string("/proc/meminfo")
            .ok()
            .and_then(|s| {
                let l = s.lines().find(|l| l.starts_with("MemTotal:"))?;
                l.split_whitespace().nth(1)?.parse::<f64>().ok()
            })
            .map_or(0.0, |kib| kib / (1024.0 * 1024.0));
        let commit = Command::new("git")
            .args(["describe", "--always", "--dirty"])
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .filter(|s| !s.is_empty())
            .unwrap_or_else(|| "unknown".into());
        Self {
            cpu,
            cores: std::thread::available_parallelism().map_or(1, std::num::NonZero::get),
            memory_gib,
            threads: rayon::current_num_threads(),
            date: today_utc(),
            commit,
        }
    }

    /// One line for the report.
    pub fn line(&self) -> String {
        format!(
            "{}, {} logical cores, {:.0} GiB; {} worker threads; allocator: {}; {} (UTC); source `{}`",
            self.cpu,
            self.cores,
            self.memory_gib,
            self.threads,
            crate::peak_memory::ALLOCATOR,
            self.date,
            self.commit
        )
    }
}

/// Today's date (UTC) from the system clock, as `YYYY-MM-DD` (civil-from-days).
fn today_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let z = (secs / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

#[cfg(test)]
mod tests {
    #[test]
    fn date_is_well_formed() {
        let d = super::today_utc();
        assert_eq!(d.len(), 10, "{d}");
        assert!(d.starts_with("20"), "{d}");
    }
}
