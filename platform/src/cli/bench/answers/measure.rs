//! What the answer-path benchmark measures: latency quantiles and rates of a phase, the
//! process's CPU time per request from `/proc/self/stat`, and the tallies that add up the
//! slices of a closed-loop phase.

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::super::quantile;

/// Latency and throughput of one phase.
#[derive(Debug, Clone, Copy)]
pub struct Measurement {
    /// Successful requests per second.
    pub per_second: f64,
    /// Median latency, ms.
    pub p50_ms: f64,
    /// 99th percentile latency, ms.
    pub p99_ms: f64,
    /// Failed requests.
    pub errors: usize,
    /// 99th percentile latency of the HIT starts (allocations) in the phase, ms (NaN: none).
    pub start_p99_ms: f64,
    /// CPU time of this whole process (server and simulated clients) per successful request,
    /// µs (NaN where `/proc` is missing). Unlike the rate it does not depend on what else the
    /// machine runs, so the ratio of two of them is the throughput ratio of a CPU-bound server.
    pub cpu_us: f64,
}

/// CPU seconds (user + system) this process has used so far, from `/proc/self/stat`.
pub(super) fn process_cpu_seconds() -> Option<f64> {
    cpu_seconds_of_stat(&std::fs::read_to_string("/proc/self/stat").ok()?)
}

/// utime + stime of a `/proc/PID/stat` line, in seconds (Linux reports them in USER_HZ =
/// 1/100 s).
fn cpu_seconds_of_stat(stat: &str) -> Option<f64> {
    // Fields after the parenthesised command name, which may itself contain spaces and ')'.
    let rest = stat.get(stat.rfind(')')? + 2..)?;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the whole line, 12 and 13 after the name.
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// CPU time since `since` (from [`process_cpu_seconds`]) per request, µs.
fn cpu_per_request(since: Option<f64>, requests: f64) -> f64 {
    match (since, process_cpu_seconds()) {
        (Some(a), Some(b)) if requests > 0.0 => (b - a) * 1e6 / requests,
        _ => f64::NAN,
    }
}

fn summarise(mut lat: Vec<f64>, errors: usize, elapsed: Duration) -> Measurement {
    lat.sort_by(f64::total_cmp);
    Measurement {
        per_second: lat.len() as f64 / elapsed.as_secs_f64(),
        p50_ms: quantile(&lat, 0.5),
        p99_ms: quantile(&lat, 0.99),
        errors,
        start_p99_ms: f64::NAN,
        cpu_us: f64::NAN,
    }
}

/// HIT start latencies of one phase, shared by its workers.
pub(super) type Starts = Arc<std::sync::Mutex<Vec<f64>>>;

/// The p99 of `starts`, emptying it.
pub(super) fn start_p99(starts: &Starts) -> f64 {
    let mut lat = std::mem::take(&mut *starts.lock().unwrap_or_else(|e| e.into_inner()));
    lat.sort_by(f64::total_cmp);
    quantile(&lat, 0.99)
}

/// Requests of one kind over the slices of a phase: latencies, errors, wall and CPU time.
pub(super) struct Tally {
    lat: Vec<f64>,
    errors: usize,
    elapsed: Duration,
    /// CPU seconds of the process; `None` once a reading was missing.
    cpu: Option<f64>,
}

impl Default for Tally {
    fn default() -> Self {
        Self {
            lat: Vec::new(),
            errors: 0,
            elapsed: Duration::ZERO,
            cpu: Some(0.0),
        }
    }
}

impl Tally {
    /// Runs `slice` and adds what it measured: its requests, its wall time from the start
    /// until its last request returned, and the process's CPU time meanwhile.
    pub(super) async fn add<F>(&mut self, slice: F)
    where
        F: std::future::Future<Output = (Vec<f64>, usize)>,
    {
        let (since, cpu_since) = (Instant::now(), process_cpu_seconds());
        let (lat, errors) = slice.await;
        self.elapsed += since.elapsed();
        let cpu = cpu_since.zip(process_cpu_seconds()).map(|(a, b)| b - a);
        self.cpu = self.cpu.zip(cpu).map(|(total, c)| total + c);
        self.lat.extend(lat);
        self.errors += errors;
    }

    pub(super) fn measurement(self) -> Measurement {
        let requests = self.lat.len() as f64;
        let mut m = summarise(self.lat, self.errors, self.elapsed);
        m.cpu_us = match self.cpu {
            Some(cpu) if requests > 0.0 => cpu * 1e6 / requests,
            _ => f64::NAN,
        };
        m
    }
}

/// Joins the tasks of a slice: what each gives back, all latencies and the error count (a
/// task that panicked counts as one error).
pub(super) async fn join_slice<W>(
    tasks: Vec<tokio::task::JoinHandle<(W, Vec<f64>, usize)>>,
) -> (Vec<W>, Vec<f64>, usize) {
    let (mut back, mut lat, mut errors) = (Vec::with_capacity(tasks.len()), Vec::new(), 0);
    for t in tasks {
        match t.await {
            Ok((w, l, e)) => {
                back.push(w);
                lat.extend(l);
                errors += e;
            }
            Err(_) => errors += 1,
        }
    }
    (back, lat, errors)
}

/// Joins the phase's workers; the rate is over the time from `since` until the last of them
/// has its last answer (a paced phase the server cannot keep up with runs over its schedule,
/// and its rate shows it).
pub(super) async fn collect(
    tasks: Vec<tokio::task::JoinHandle<(Vec<f64>, usize)>>,
    since: Instant,
    cpu_since: Option<f64>,
) -> Measurement {
    let (mut lat, mut errors) = (Vec::new(), 0);
    for t in tasks {
        if let Ok((l, e)) = t.await {
            lat.extend(l);
            errors += e;
        }
    }
    let requests = lat.len() as f64;
    let mut m = summarise(lat, errors, since.elapsed());
    m.cpu_us = cpu_per_request(cpu_since, requests);
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// utime and stime are found after a command name with spaces and parentheses; a cut or
    /// garbled line gives `None`; this process's clock reads and never runs backwards.
    #[test]
    fn cpu_time_from_proc_stat() {
        let line = "4242 (my (odd) cmd) S 1 4242 4242 0 -1 4194560 1200 0 0 0 \
                    250 37 0 0 20 0 9 0 100 1000000 500 18446744073709551615";
        assert_eq!(cpu_seconds_of_stat(line), Some(2.87));
        assert_eq!(cpu_seconds_of_stat("4242 (cmd) S 1 2 3"), None);
        assert_eq!(cpu_seconds_of_stat("no parenthesis"), None);
        assert_eq!(cpu_seconds_of_stat("4242 (cmd)"), None);
        let a = process_cpu_seconds().expect("/proc/self/stat");
        let b = process_cpu_seconds().expect("/proc/self/stat");
        assert!(a >= 0.0 && b >= a, "{a} then {b}");
        assert!(cpu_per_request(Some(a), 0.0).is_nan());
        assert!(cpu_per_request(None, 10.0).is_nan());
        assert!(cpu_per_request(Some(b), 10.0) >= 0.0);
    }

    /// Slices add up: every request, the wall time of each slice (not the gaps between them)
    /// and a CPU time per request that is a real reading.
    #[tokio::test]
    async fn slices_add_up() {
        let mut tally = Tally::default();
        for lat in [vec![1.0, 2.0], vec![3.0]] {
            tally
                .add(async {
                    tokio::time::sleep(Duration::from_millis(20)).await;
                    (lat, 1)
                })
                .await;
            tokio::time::sleep(Duration::from_millis(300)).await;
        }
        let m = tally.measurement();
        assert_eq!(m.errors, 2);
        assert_eq!(m.p50_ms, 2.0);
        // 3 requests in two slices of at least 20 ms, not over the 640 ms they spanned.
        assert!(
            m.per_second > 3.0 / 0.6 && m.per_second <= 3.0 / 0.04,
            "{}",
            m.per_second
        );
        assert!(m.cpu_us >= 0.0, "{}", m.cpu_us);
        assert!(Tally::default().measurement().cpu_us.is_nan());
    }

    #[test]
    fn percentiles() {
        let m = summarise(
            (1..=100).map(f64::from).collect(),
            0,
            Duration::from_secs(1),
        );
        assert_eq!(m.per_second, 100.0);
        assert_eq!(m.p50_ms, 51.0);
        assert_eq!(m.p99_ms, 99.0);
    }
}
