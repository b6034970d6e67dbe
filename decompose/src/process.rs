//! Figures about the running process, for benchmarks and examples that report their cost
//! (Linux `/proc`; `None` where it is not available).

/// CPU seconds (user + system, all threads) this process has used, from `/proc/self/stat`.
/// The kernel's clock tick is 100 Hz on every mainstream configuration. On a shared machine
/// this is the honest figure: wall time also counts other people's work.
pub fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let fields: Vec<&str> = s.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Peak resident memory of this process so far, MiB (`VmHWM` of `/proc/self/status`). Writing
/// `5` to `/proc/self/clear_refs` resets it.
pub fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

#[cfg(test)]
mod tests {
    #[test]
    fn figures_are_positive_on_linux() {
        // Burn a little CPU so that at least one tick is counted.
        let mut x = 0u64;
        let start = std::time::Instant::now();
        while start.elapsed().as_millis() < 50 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        assert!(x != 1);
        if cfg!(target_os = "linux") {
            assert!(super::cpu_seconds().unwrap() > 0.0);
            assert!(super::peak_rss_mib().unwrap() > 1.0);
        }
    }
}
