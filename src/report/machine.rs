//! The machine a report ran on, stated once at its top: date, CPU, memory,
//! load, and which voxkit build measured.
//!
//! Everything is read at run time from `/proc` (Linux) and `git`; what
//! cannot be read is reported as "unknown", never an error: a report from a
//! tarball without git, or from another OS, is still a report.

use std::path::Path;
use std::process::Command;
use std::time::{SystemTime, UNIX_EPOCH};

/// Environment variable that names the git commit when `git` cannot
/// (a build from a tarball, a container without the repository).
pub const COMMIT_ENV: &str = "VOXKIT_GIT_COMMIT";

/// What is known about the machine and the build.
#[derive(Clone, Debug, PartialEq)]
pub struct MachineInfo {
    /// Start of the run, UTC, `YYYY-MM-DD HH:MM:SS`.
    pub date_utc: String,
    /// Logical cores available to the process.
    pub cores: usize,
    /// CPU model from `/proc/cpuinfo`, or "unknown".
    pub cpu: String,
    /// Total memory from `/proc/meminfo`, bytes (0 when unknown).
    pub memory_bytes: u64,
    /// 1/5/15-minute load averages at the start (`/proc/loadavg`).
    pub load_start: Option<[f64; 3]>,
    /// The same at the end of the run, filled by [`MachineInfo::finish`].
    pub load_end: Option<[f64; 3]>,
    /// voxkit's version (Cargo).
    pub version: &'static str,
    /// Git commit (short hash, `-dirty` if the tree had changes), or "unknown".
    pub commit: String,
    /// Build profile: "release" (debug assertions off) or "debug".
    pub profile: &'static str,
}

impl MachineInfo {
    /// Reads everything now (the start of a run); `repo` is where `git` is
    /// asked for the commit.
    pub fn collect(repo: &Path) -> Self {
        let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let meminfo = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
        MachineInfo {
            date_utc: utc_now(),
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            cpu: cpu_model(&cpuinfo).unwrap_or_else(|| "unknown".into()),
            memory_bytes: mem_total(&meminfo).unwrap_or(0),
            load_start: load_average(),
            load_end: None,
            version: env!("CARGO_PKG_VERSION"),
            commit: git_commit(repo),
            profile: if cfg!(debug_assertions) {
                "debug"
            } else {
                "release"
            },
        }
    }

    /// Records the load average at the end of the run.
    pub fn finish(&mut self) {
        self.load_end = load_average();
    }

    /// The report's machine paragraph (Markdown).
    pub fn markdown(&self) -> String {
        let load = |l: Option<[f64; 3]>| {
            l.map_or("unknown".to_string(), |[a, b, c]| {
                format!("{a:.2} / {b:.2} / {c:.2}")
            })
        };
        format!(
            "| | |\n|---|---|\n\
             | date (UTC) | {} |\n\
             | CPU | {} |\n\
             | cores | {} |\n\
             | memory | {:.1} GiB |\n\
             | load average 1/5/15 min, start | {} |\n\
             | load average 1/5/15 min, end | {} |\n\
             | voxkit | {} (commit {}) |\n\
             | build profile | {} |\n",
            self.date_utc,
            self.cpu,
            self.cores,
            self.memory_bytes as f64 / (1u64 << 30) as f64,
            load(self.load_start),
            load(self.load_end),
            self.version,
            self.commit,
            self.profile
        )
    }
}

/// The `model name` of the first processor in `/proc/cpuinfo` text.
pub fn cpu_model(cpuinfo: &str) -> Option<String> {
    cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim().to_string())
        .filter(|s| !s.is_empty())
}

/// `MemTotal` in bytes from `/proc/meminfo` text.
pub fn mem_total(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

fn load_average() -> Option<[f64; 3]> {
    let s = std::fs::read_to_string("/proc/loadavg").ok()?;
    let mut it = s.split_whitespace().map(|x| x.parse::<f64>().ok());
    Some([it.next()??, it.next()??, it.next()??])
}

/// The commit from [`COMMIT_ENV`], else `git rev-parse` in `repo`, else
/// "unknown".
fn git_commit(repo: &Path) -> String {
    if let Ok(c) = std::env::var(COMMIT_ENV)
        && !c.trim().is_empty()
    {
        return c.trim().to_string();
    }
    let git = |args: &[&str]| {
        Command::new("git")
            .arg("-C")
            .arg(repo)
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match git(&["rev-parse", "--short=12", "HEAD"]) {
        Some(hash) if !hash.is_empty() => {
            let dirty = git(&["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|s| !s.is_empty());
            if dirty { format!("{hash}-dirty") } else { hash }
        }
        _ => "unknown".into(),
    }
}

fn utc_now() -> String {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    format_utc(secs)
}

/// `YYYY-MM-DD HH:MM:SS` of a Unix time (UTC), by the proleptic Gregorian
/// calendar (H. Hinnant's `civil_from_days`).
///
/// ```
/// use voxkit::report::machine::format_utc;
/// assert_eq!(format_utc(0), "1970-01-01 00:00:00");
/// assert_eq!(format_utc(951_782_400), "2000-02-29 00:00:00");
/// ```
pub fn format_utc(unix_seconds: u64) -> String {
    let days = (unix_seconds / 86_400) as i64;
    let rem = unix_seconds % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_proc_files() {
        let cpu = "processor\t: 0\nvendor_id\t: X\nmodel name\t: AMD EPYC 7B13\nflags\t: a\n";
        assert_eq!(cpu_model(cpu).as_deref(), Some("AMD EPYC 7B13"));
        assert_eq!(cpu_model("processor: 0\n"), None);
        assert_eq!(
            mem_total("MemTotal:       24684084 kB\nMemFree: 1 kB\n"),
            Some(24_684_084 * 1024)
        );
        assert_eq!(mem_total("MemFree: 1 kB\n"), None);
    }

    /// Dates against independently known instants (day boundaries, leap
    /// days, a century).
    #[test]
    fn utc_dates() {
        assert_eq!(format_utc(86_399), "1970-01-01 23:59:59");
        assert_eq!(format_utc(1_709_164_800), "2024-02-29 00:00:00");
        assert_eq!(format_utc(4_107_542_400), "2100-03-01 00:00:00");
        assert_eq!(format_utc(1_798_675_200 + 3_723), "2026-12-31 01:02:03");
    }
}
