//! `platform bench`: a load benchmark of the answer path against the real server on loopback.
//!
//! The server ([`crate::app`]) runs in this process on `127.0.0.1:0`; simulated workers are
//! HTTP clients (reqwest) in the same process, so both share the machine's cores. For each
//! concurrency level it measures `/healthz` (the ceiling: routing + one `SELECT 1`) and then the
//! answer path (`POST /api/v1/assignments/{token}/answers`, durable before acknowledgement),
//! and prints answers/s with p50/p99 latency. Workers that finish their HIT start a new one.
//! The benchmark reads each HIT's questions from the database directly (it plays workers who
//! already know which picture they will click) so that only the answer request is timed.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use clap::Args;
use sqlx::Row;

use crate::AppState;
use crate::db::Db;
use crate::error::{AppError, Result};
use crate::ids::StudyId;
use crate::library::{self, NewItem};
use crate::study::{self, StudySettings};

/// Benchmark settings.
#[derive(Debug, Clone, Args)]
pub struct BenchArgs {
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
}

fn summarise(mut lat: Vec<f64>, errors: usize, elapsed: Duration) -> Measurement {
    lat.sort_by(f64::total_cmp);
    let q = |p: f64| {
        if lat.is_empty() {
            f64::NAN
        } else {
            lat[((lat.len() as f64 - 1.0) * p).round() as usize]
        }
    };
    Measurement {
        per_second: lat.len() as f64 / elapsed.as_secs_f64(),
        p50_ms: q(0.5),
        p99_ms: q(0.99),
        errors,
    }
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
    }
}

async fn prepare(db: &Db, workers: usize, seconds: u64) -> Result<StudyId> {
    let lib = library::ensure_library(db, "bench").await?;
    // 64 items: ~120,000 distinct triplets, enough slots for 1000 concurrent HITs.
    if library::list_items(db, lib).await?.len() < 64 {
        for i in 0..64 {
            library::insert_item(db, lib, swatch(i)).await?;
        }
    }
    // Two HITs for every worker plus headroom for ~6000 answers/s: running out of free
    // slots mid-phase would turn answers into refused starts and flatter the figures.
    let tuples = (workers * 90 + (seconds as usize) * 6000).min(400_000) as u32;
    let settings = StudySettings {
        training_questions: 0,
        tuples,
        seed: crate::db::now_ms() as u64,
        ..StudySettings::default()
    };
    Ok(
        study::create(db, &format!("bench {workers}"), lib, settings)
            .await?
            .0,
    )
}

async fn healthz_phase(base: &str, workers: usize, seconds: u64) -> Measurement {
    let client = reqwest::Client::new();
    let stop = Arc::new(AtomicBool::new(false));
    let start = Instant::now();
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
            (lat, errors)
        }));
    }
    tokio::time::sleep(Duration::from_secs(seconds)).await;
    stop.store(true, Ordering::Relaxed);
    collect(tasks, start.elapsed()).await
}

async fn collect(
    tasks: Vec<tokio::task::JoinHandle<(Vec<f64>, usize)>>,
    elapsed: Duration,
) -> Measurement {
    let (mut lat, mut errors) = (Vec::new(), 0);
    for t in tasks {
        if let Ok((l, e)) = t.await {
            lat.extend(l);
            errors += e;
        }
    }
    summarise(lat, errors, elapsed)
}

async fn answer_phase(
    db: Db,
    base: &str,
    study: StudyId,
    workers: usize,
    seconds: u64,
) -> Measurement {
    let client = reqwest::Client::new();
    let stop = Arc::new(AtomicBool::new(false));
    let start = Instant::now();
    let mut tasks = Vec::new();
    for w in 0..workers {
        let (client, stop, base, db) = (client.clone(), stop.clone(), base.to_string(), db.clone());
        tasks.push(tokio::spawn(async move {
            let (mut lat, mut errors) = (Vec::new(), 0usize);
            let mut hit = 0;
            while !stop.load(Ordering::Relaxed) {
                hit += 1;
                let started = start_hit(&client, &base, study, &format!("bench-{w}-{hit}")).await;
                let Ok(token) = started else {
                    if errors == 0 && w == 0 {
                        eprintln!("first start error: {started:?}");
                    }
                    errors += 1;
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                };
                let Ok(questions) = hit_questions(&db, &token).await else {
                    errors += 1;
                    continue;
                };
                for (position, choice) in questions {
                    if stop.load(Ordering::Relaxed) {
                        break;
                    }
                    let t = Instant::now();
                    let body = serde_json::json!({"position": position, "choice": choice});
                    match client
                        .post(format!("{base}/api/v1/assignments/{token}/answers"))
                        .json(&body)
                        .send()
                        .await
                    {
                        Ok(r) if r.status().is_success() => {
                            lat.push(t.elapsed().as_secs_f64() * 1e3)
                        }
                        other => {
                            if errors == 0 && w == 0 {
                                eprintln!("first answer error: {:?}", other.map(|r| r.status()));
                            }
                            errors += 1
                        }
                    }
                }
            }
            (lat, errors)
        }));
    }
    tokio::time::sleep(Duration::from_secs(seconds)).await;
    stop.store(true, Ordering::Relaxed);
    collect(tasks, start.elapsed()).await
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

/// Runs the benchmark and prints a table.
pub async fn run(args: BenchArgs) -> Result<()> {
    if args.workers.is_empty() || args.workers.iter().any(|&w| w == 0 || w > 5000) {
        return Err(AppError::BadRequest("--workers: 1..=5000 each".into()));
    }
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
        "{:>8} | {:>12} {:>9} {:>9} | {:>12} {:>9} {:>9} {:>7} | {:>8}",
        "workers",
        "healthz/s",
        "p50 ms",
        "p99 ms",
        "answers/s",
        "p50 ms",
        "p99 ms",
        "errors",
        "ratio"
    )?;
    for &w in &args.workers {
        let study = prepare(&db, w, args.seconds).await?;
        let h = healthz_phase(&base, w, args.seconds).await;
        let a = answer_phase(db.clone(), &base, study, w, args.seconds).await;
        outln!(
            "{:>8} | {:>12.0} {:>9.2} {:>9.2} | {:>12.0} {:>9.2} {:>9.2} {:>7} | {:>8.2}",
            w,
            h.per_second,
            h.p50_ms,
            h.p99_ms,
            a.per_second,
            a.p50_ms,
            a.p99_ms,
            a.errors,
            a.per_second / h.per_second
        )?;
    }
    server.abort();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
