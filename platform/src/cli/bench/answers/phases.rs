//! The answer-path benchmark's phases: the closed loop interleaved with the `/healthz`
//! ceiling, and the paced (open-loop) schedule.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::measure::{
    Measurement, Starts, Tally, collect, join_slice, process_cpu_seconds, start_p99,
};
use super::worker::{BenchWorker, note_error};
use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::store::ids::StudyId;

/// Length of one slice of the closed-loop measurement (see [`closed_phase`]).
const SLICE: Duration = Duration::from_secs(2);

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

/// Closed loop, every worker answering as fast as the server acknowledges, interleaved with
/// the `/healthz` ceiling: `seconds / 2` rounds of a 2-s `/healthz` slice then a 2-s answer
/// slice, by the same number of clients. This machine's speed drifts by up to 2x within a
/// minute (shared host), so a ceiling measured once before the answers could come from a
/// faster or slower spell than they did; interleaved, both see the same spells. Returns the
/// ceiling and the answer path.
pub(super) async fn closed_phase(
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
pub(super) async fn paced_phase(
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
