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

mod measure;
mod phases;
mod setup;
mod worker;

use clap::Args;

use crate::AppState;
use crate::error::{AppError, Result};
use crate::store::db::Db;

pub use measure::Measurement;
use phases::{closed_phase, paced_phase};
pub(crate) use setup::prepare;

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
