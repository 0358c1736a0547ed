//! What a run costs the machine: the CPU time of a thread and the peak memory of the process.
//!
//! Studies, benchmarks and run summaries all read these; they sit below every module that
//! reports a cost.

/// Seconds of CPU time used by the calling thread (`CLOCK_THREAD_CPUTIME_ID`); `None` where
/// the platform does not provide it.
pub fn thread_cpu_seconds() -> Option<f64> {
    #[cfg(unix)]
    {
        use nix::time::{clock_gettime, ClockId};
        clock_gettime(ClockId::CLOCK_THREAD_CPUTIME_ID)
            .ok()
            .map(|ts| ts.tv_sec() as f64 + ts.tv_nsec() as f64 * 1e-9)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// The peak resident memory of this process so far, in bytes: the high-water mark of its
/// address space (`VmHWM` of `/proc/self/status`), else `getrusage`'s `ru_maxrss`; `None`
/// where the platform provides neither.
///
/// `ru_maxrss` is not used first because Linux carries it over `execve` from the process that
/// forked: started by `cargo run` (as `scripts/sweep` does), `sweep` would report cargo's
/// own peak, often larger than the run's. `VmHWM` belongs to the address space, which
/// `execve` replaces.
pub fn peak_memory_bytes() -> Option<u64> {
    #[cfg(target_os = "linux")]
    {
        if let Some(kib) = std::fs::read_to_string("/proc/self/status")
            .ok()
            .as_deref()
            .and_then(vm_hwm_kib)
        {
            return Some(kib * 1024);
        }
        use nix::sys::resource::{getrusage, UsageWho};
        // Linux reports ru_maxrss in kibibytes.
        getrusage(UsageWho::RUSAGE_SELF)
            .ok()
            .and_then(|u| u64::try_from(u.max_rss()).ok())
            .map(|kib| kib * 1024)
    }
    #[cfg(not(target_os = "linux"))]
    {
        None
    }
}

/// The `VmHWM:` line of a `/proc/<pid>/status` text, in kibibytes (the kernel writes "kB").
fn vm_hwm_kib(status: &str) -> Option<u64> {
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let mut words = line["VmHWM:".len()..].split_whitespace();
    let value = words.next()?.parse().ok()?;
    (words.next() == Some("kB")).then_some(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vm_hwm_is_read_in_kibibytes_and_only_from_its_line() {
        let status = "Name:\tsweep\nVmPeak:\t  99999 kB\nVmHWM:\t    8192 kB\nVmRSS:\t 4 kB\n";
        assert_eq!(vm_hwm_kib(status), Some(8192));
        assert_eq!(vm_hwm_kib("VmRSS:\t 4 kB\n"), None);
        assert_eq!(vm_hwm_kib("VmHWM:\t 12 MB\n"), None, "a unit other than kB");
        assert_eq!(vm_hwm_kib("VmHWM:\t x kB\n"), None);
        #[cfg(target_os = "linux")]
        assert!(peak_memory_bytes().is_some_and(|b| b > 0));
    }
}
