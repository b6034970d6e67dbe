//! `platform bench` (no scenario): a load benchmark of the answer path against the real server
//! on loopback.
//!
//! The server ([`crate::app`]) runs in this process on `127.0.0.1:0`; simulated workers are
//! HTTP clients (reqwest) in the same process, so both share the machine's cores. For each
//! concurrency level it measures the answer path (`POST /api/v1/assignments/{token}/answers`,
//! durable before acknowledgement) in a closed loop, in slices alternating with `/healthz` (the
//! ceiling: routing + one `SELECT 1`), then in paced (open-loop) phases, and prints answers/s
//! with p50/p99 latency. Workers that finish their HIT start a new one.
//! The benchmark reads each HIT's questions from the database directly (it plays workers who
//! already know which picture they will click) so that only the answer request is timed.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use clap::Args;
use sqlx::Row;

use super::quantile;
use crate::AppState;
use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::store::ids::StudyId;
use crate::studies::library::{self, NewItem};
use crate::studies::study::{self, StudySettings};

/// Settings of the answer-path benchmark.
#[derive(Debug, Clone, Args)]
pub struct AnswerArgs {
    /// Database URL for the benchmark (use a fresh SQLite file or PostgreSQL database).
    #[arg(long, default_value = "sqlite://platform-bench.db")]
    pub database_url: String,
    /// Concurrency levels (simulated workers), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "50,200,1000")]
    pub workers: Vec<usize>,
    /// Seconds measured per level and phase.
    #[arg(long, default_value_t = 5)]
    pub seconds: u64,
    /// Server connection pool size.
    #[arg(long, default_value_t = 16)]
    pub max_connections: u32,
    /// Paced (open-loop) phases: total offered answers/s, comma-separated (0: none).
    #[arg(long, value_delimiter = ',', default_value = "1000,2000")]
    pub rates: Vec<f64>,
}

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
fn process_cpu_seconds() -> Option<f64> {
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
type Starts = Arc<std::sync::Mutex<Vec<f64>>>;

/// The p99 of `starts`, emptying it.
fn start_p99(starts: &Starts) -> f64 {
    let mut lat = std::mem::take(&mut *starts.lock().unwrap_or_else(|e| e.into_inner()));
    lat.sort_by(f64::total_cmp);
    quantile(&lat, 0.99)
}

/// A solid-colour item so the benchmark does not depend on fixture files.
fn swatch(i: usize) -> NewItem {
    let colour = [
        (i * 37 % 256) as u8,
        (i * 91 % 256) as u8,
        (i * 53 % 256) as u8,
    ];
    NewItem {
        name: format!("swatch-{i}"),
        style: Some(format!("group-{}", i % 4)),
        tags: Vec::new(),
        image: image::RgbImage::from_pixel(400, 400, image::Rgb(colour)),
        cutout: None,
        svg: None,
    }
}

/// Items of the benchmark's library.
const BENCH_ITEMS: usize = 96;

pub(crate) async fn prepare(db: &Db, workers: usize, seconds: u64) -> Result<StudyId> {
    let lib = library::ensure_library(db, "bench").await?;
    // 96 items: 428,640 distinct triplets (n(n-1)(n-2)/2: a triplet is an anchor and an
    // unordered pair), more than the largest study below asks for.
    let have = library::list_items(db, lib).await?.len();
    if have < BENCH_ITEMS {
        for i in have..BENCH_ITEMS {
            if let library::Inserted::Unusable(why) =
                library::insert_item(db, lib, swatch(i)).await?
            {
                return Err(AppError::Internal(format!("bench swatch {i}: {why}")));
            }
        }
    }
    // Two HITs for every worker plus headroom for ~18,000 answers/s (the SQLite closed loop
    // reaches ~13,500 on 2 cores): running out of free slots mid-phase would turn answers into
    // refused starts and flatter the figures.
    let tuples = (workers * 90 + (seconds as usize) * 18_000).min(400_000) as u32;
    let settings = StudySettings {
        training_questions: 0,
        tuples,
        seed: crate::store::db::now_ms() as u64,
        ..StudySettings::default()
    };
    Ok(
        study::create(db, &format!("bench {workers}"), lib, settings)
            .await?
            .0,
    )
}

/// Length of one slice of the closed-loop measurement (see [`closed_phase`]).
const SLICE: Duration = Duration::from_secs(2);

/// Requests of one kind over the slices of a phase: latencies, errors, wall and CPU time.
struct Tally {
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
    async fn add<F>(&mut self, slice: F)
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

    fn measurement(self) -> Measurement {
        let requests = self.lat.len() as f64;
        let mut m = summarise(self.lat, self.errors, self.elapsed);
        m.cpu_us = match self.cpu {
            Some(cpu) if requests > 0.0 => cpu * 1e6 / requests,
            _ => f64::NAN,
        };
        m
    }
}

/// `workers` clients asking `/healthz` as fast as it answers, for `length`; their latencies
/// and error count.
async fn healthz_slice(
    client: &reqwest::Client,
    base: &str,
    workers: usize,
    length: Duration,
) -> (Vec<f64>, usize) {
    let stop = Arc::new(AtomicBool::new(false));
    let mut tasks = Vec::new();
    for _ in 0..workers {
        let (client, stop, url) = (client.clone(), stop.clone(), format!("{base}/healthz"));
        tasks.push(tokio::spawn(async move {
            let (mut lat, mut errors) = (Vec::new(), 0usize);
            while !stop.load(Ordering::Relaxed) {
                let t = Instant::now();
                match client.get(&url).send().await {
                    Ok(r) if r.status().is_success() => lat.push(t.elapsed().as_secs_f64() * 1e3),
                    _ => errors += 1,
                }
            }
            ((), lat, errors)
        }));
    }
    tokio::time::sleep(length).await;
    stop.store(true, Ordering::Relaxed);
    let (_, lat, errors) = join_slice(tasks).await;
    (lat, errors)
}

/// Joins the tasks of a slice: what each gives back, all latencies and the error count (a
/// task that panicked counts as one error).
async fn join_slice<W>(
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
async fn collect(
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

/// One simulated worker: its current HIT and the answers it will give.
struct BenchWorker {
    client: reqwest::Client,
    base: String,
    db: Db,
    study: StudyId,
    /// Worker index (part of every worker id it uses).
    index: usize,
    /// HITs started so far (each HIT is a new worker id: one assignment per worker and study).
    hits: usize,
    /// Where the start latencies go.
    starts: Starts,
    token: String,
    /// (position, choice) still to send, in order.
    queue: std::collections::VecDeque<(i64, i64)>,
}

impl BenchWorker {
    fn new(
        client: reqwest::Client,
        base: &str,
        db: Db,
        study: StudyId,
        index: usize,
        starts: Starts,
    ) -> Self {
        Self {
            starts,
            client,
            base: base.to_string(),
            db,
            study,
            index,
            hits: 0,
            token: String::new(),
            queue: Default::default(),
        }
    }

    /// Starts the next HIT when the current one is used up.
    async fn ensure_hit(&mut self) -> Result<()> {
        if !self.queue.is_empty() {
            return Ok(());
        }
        self.hits += 1;
        let id = format!("bench-{}-{}", self.index, self.hits);
        let t = Instant::now();
        self.token = start_hit(&self.client, &self.base, self.study, &id).await?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        self.starts
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(ms);
        self.queue = hit_questions(&self.db, &self.token).await?.into();
        Ok(())
    }

    /// Sends the next answer of the current HIT (call [`Self::ensure_hit`] first).
    async fn answer_next(&mut self) -> Result<()> {
        let (position, choice) = self
            .queue
            .pop_front()
            .ok_or_else(|| AppError::Internal("no question left".into()))?;
        let body = serde_json::json!({"position": position, "choice": choice});
        let resp = self
            .client
            .post(format!(
                "{}/api/v1/assignments/{}/answers",
                self.base, self.token
            ))
            .json(&body)
            .send()
            .await
            .map_err(AppError::internal)?;
        if resp.status().is_success() {
            Ok(())
        } else {
            Err(AppError::Internal(format!("answer: {}", resp.status())))
        }
    }
}

/// Counts an error, printing the first few of the run (from any worker: a failure that hits
/// only some workers must still be seen).
fn note_error(errors: &mut usize, what: &str, e: &AppError) {
    static PRINTED: AtomicUsize = AtomicUsize::new(0);
    if PRINTED.fetch_add(1, Ordering::Relaxed) < 5 {
        eprintln!("{what} error: {e}");
    }
    *errors += 1;
}

/// Closed loop, every worker answering as fast as the server acknowledges, interleaved with
/// the `/healthz` ceiling: `seconds / 2` rounds of a 2-s `/healthz` slice then a 2-s answer
/// slice, by the same number of clients. This machine's speed drifts by up to 2x within a
/// minute (shared host), so a ceiling measured once before the answers could come from a
/// faster or slower spell than they did; interleaved, both see the same spells. Returns the
/// ceiling and the answer path.
async fn closed_phase(
    db: Db,
    base: &str,
    study: StudyId,
    workers: usize,
    seconds: u64,
) -> (Measurement, Measurement) {
    let client = reqwest::Client::new();
    let starts = Starts::default();
    let mut pool: Vec<BenchWorker> = (0..workers)
        .map(|w| BenchWorker::new(client.clone(), base, db.clone(), study, w, starts.clone()))
        .collect();
    let (mut healthz, mut answers) = (Tally::default(), Tally::default());
    let rounds = (seconds / SLICE.as_secs()).max(1);
    for _ in 0..rounds {
        healthz
            .add(healthz_slice(&client, base, workers, SLICE))
            .await;
        let mut back = Vec::with_capacity(workers);
        answers.add(answer_slice(pool, SLICE, &mut back)).await;
        pool = back;
    }
    let mut m = answers.measurement();
    m.start_p99_ms = start_p99(&starts);
    (healthz.measurement(), m)
}

/// Every worker of `pool` answers as fast as the server acknowledges for `length`; the
/// workers (with their HITs part answered) are put back in `back` for the next slice.
async fn answer_slice(
    pool: Vec<BenchWorker>,
    length: Duration,
    back: &mut Vec<BenchWorker>,
) -> (Vec<f64>, usize) {
    let stop = Arc::new(AtomicBool::new(false));
    let mut tasks = Vec::new();
    for mut worker in pool {
        let stop = stop.clone();
        tasks.push(tokio::spawn(async move {
            let (mut lat, mut errors) = (Vec::new(), 0usize);
            while !stop.load(Ordering::Relaxed) {
                if let Err(e) = worker.ensure_hit().await {
                    note_error(&mut errors, "start", &e);
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
                let t = Instant::now();
                match worker.answer_next().await {
                    Ok(()) => lat.push(t.elapsed().as_secs_f64() * 1e3),
                    Err(e) => note_error(&mut errors, "answer", &e),
                }
            }
            (worker, lat, errors)
        }));
    }
    tokio::time::sleep(length).await;
    stop.store(true, Ordering::Relaxed);
    // A worker that panicked is gone from the later slices.
    let (workers, lat, errors) = join_slice(tasks).await;
    back.extend(workers);
    (lat, errors)
}

/// Warm-up of the paced mode: worker `w` of `workers` starts a HIT and answers `w / workers` of
/// it (unmeasured), so that HIT ends are spread evenly over the measured schedule.
async fn warm_up(mut worker: BenchWorker, workers: usize) -> Result<BenchWorker> {
    worker.ensure_hit().await?;
    let skip = worker.queue.len() * worker.index / workers;
    for _ in 0..skip {
        worker.answer_next().await?;
    }
    Ok(worker)
}

/// Paced (open loop): `rate` answers/s in total, each worker on a fixed schedule; latency from
/// the scheduled send time.
async fn paced_phase(
    db: Db,
    base: &str,
    study: StudyId,
    workers: usize,
    rate: f64,
    seconds: u64,
) -> Result<Measurement> {
    let client = reqwest::Client::new();
    let starts = Starts::default();
    let mut warming = Vec::new();
    for w in 0..workers {
        let worker = BenchWorker::new(client.clone(), base, db.clone(), study, w, starts.clone());
        warming.push(tokio::spawn(warm_up(worker, workers)));
    }
    let mut ready = Vec::with_capacity(workers);
    for t in warming {
        ready.push(t.await.map_err(AppError::internal)??);
    }
    start_p99(&starts); // the warm-up's starts are not part of the measurement
    let interval = Duration::from_secs_f64(workers as f64 / rate);
    let t0 = Instant::now() + Duration::from_millis(100);
    let cpu = process_cpu_seconds();
    let end = t0 + Duration::from_secs(seconds);
    let mut tasks = Vec::new();
    for mut worker in ready {
        let w = worker.index;
        tasks.push(tokio::spawn(async move {
            let (mut lat, mut errors) = (Vec::new(), 0usize);
            // Phases spread evenly over one interval so the offered load is smooth.
            let mut due = t0 + interval.mul_f64(w as f64 / workers as f64);
            while due < end {
                tokio::time::sleep_until(due.into()).await;
                // Starting the next HIT is part of the worker's time: an answer it delays past
                // its schedule is charged below.
                let sent = match worker.ensure_hit().await {
                    Ok(()) => worker.answer_next().await,
                    Err(e) => Err(e),
                };
                match sent {
                    Ok(()) => lat.push(due.elapsed().as_secs_f64() * 1e3),
                    Err(e) => note_error(&mut errors, "paced", &e),
                }
                due += interval;
            }
            (lat, errors)
        }));
    }
    let mut m = collect(tasks, t0, cpu).await;
    m.start_p99_ms = start_p99(&starts);
    Ok(m)
}

async fn start_hit(
    client: &reqwest::Client,
    base: &str,
    study: StudyId,
    worker: &str,
) -> Result<String> {
    let resp = client
        .post(format!("{base}/api/v1/studies/{study}/start"))
        .json(&serde_json::json!({"source": "direct", "worker_id": worker}))
        .send()
        .await
        .map_err(AppError::internal)?;
    let v: serde_json::Value = resp.json().await.map_err(AppError::internal)?;
    v["token"]
        .as_str()
        .map(str::to_string)
        .ok_or_else(|| AppError::Internal(format!("start failed: {v}")))
}

async fn hit_questions(db: &Db, token: &str) -> Result<Vec<(i64, i64)>> {
    let rows = sqlx::query(
        "SELECT q.position, t.b FROM questions q JOIN tuples t ON t.id = q.tuple_id \
         JOIN assignments a ON a.id = q.assignment_id WHERE a.token = $1 ORDER BY q.position",
    )
    .bind(token)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| Ok((r.try_get("position")?, r.try_get("b")?)))
        .collect()
}

/// One printed row.
fn row(workers: usize, mode: &str, healthz: &Measurement, m: &Measurement) -> Result<()> {
    outln!(
        "{:>8} {:<14} | {:>10.0} {:>8.2} {:>8.2} {:>6} {:>9.1} {:>6.0} | {:>10.0} {:>6.0} | {:>6.2} {:>6.2}",
        workers,
        mode,
        m.per_second,
        m.p50_ms,
        m.p99_ms,
        m.errors,
        m.start_p99_ms,
        m.cpu_us,
        healthz.per_second,
        healthz.cpu_us,
        m.per_second / healthz.per_second,
        healthz.cpu_us / m.cpu_us
    )
}

/// Runs the answer-path benchmark and prints a table.
pub async fn run(args: AnswerArgs) -> Result<()> {
    if args.workers.is_empty() || args.workers.iter().any(|&w| w == 0 || w > 5000) {
        return Err(AppError::BadRequest("--workers: 1..=5000 each".into()));
    }
    if args.rates.iter().any(|r| !(0.0..=100_000.0).contains(r)) {
        return Err(AppError::BadRequest("--rates: 0..=100000 each".into()));
    }
    let rates: Vec<f64> = args.rates.iter().copied().filter(|&r| r > 0.0).collect();
    let db = Db::connect(&args.database_url, args.max_connections).await?;
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .map_err(AppError::internal)?;
    let addr = listener.local_addr().map_err(AppError::internal)?;
    let base = format!("http://{addr}");
    let state = AppState::new(db.clone(), base.clone(), false, 64 * 1024);
    let server = tokio::spawn(async move { axum::serve(listener, crate::app(state)).await });
    outln!(
        "backend: {:?}, pool {}, {} s per phase",
        db.backend,
        args.max_connections,
        args.seconds
    )?;
    outln!(
        "mode closed: no think time (saturation; mean latency = workers / rate by Little's law)"
    )?;
    outln!(
        "mode paced R/s: R answers/s offered in total on a fixed schedule, latency from the \
         scheduled send time"
    )?;
    outln!("start p99: HIT starts (allocations) of the phase, not counted as answers")?;
    outln!(
        "healthz/s: the ceiling, by as many clients, in 2-s slices alternating with the closed \
         loop's (so both see the same machine); ratio = answers/s ÷ healthz/s"
    )?;
    outln!(
        "cpu µs: CPU time of this process (server + clients; not PostgreSQL's own processes) \
         per answer or /healthz request; cpu r. = healthz cpu / answer cpu, the rate ratio on \
         a CPU-bound machine, which other load does not move"
    )?;
    outln!(
        "{:>8} {:<14} | {:>10} {:>8} {:>8} {:>6} {:>9} {:>6} | {:>10} {:>6} | {:>6} {:>6}",
        "workers",
        "mode",
        "answers/s",
        "p50 ms",
        "p99 ms",
        "errors",
        "start p99",
        "cpu µs",
        "healthz/s",
        "cpu µs",
        "ratio",
        "cpu r."
    )?;
    for &w in &args.workers {
        let study = prepare(&db, w, args.seconds).await?;
        let (h, closed) = closed_phase(db.clone(), &base, study, w, args.seconds).await;
        row(w, "closed", &h, &closed)?;
        for &rate in &rates {
            // A fresh study per phase: the previous phase's HITs hold many of the slots.
            let study = prepare(&db, w, args.seconds).await?;
            let paced = paced_phase(db.clone(), &base, study, w, rate, args.seconds).await?;
            row(w, &format!("paced {rate:.0}/s"), &h, &paced)?;
        }
    }
    server.abort();
    Ok(())
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
