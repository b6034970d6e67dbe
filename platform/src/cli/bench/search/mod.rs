//! `platform bench search`: the admin's style search over HTTP on a library of the paper's size
//! (Garces et al. 2014 §5.7.3: 194,663 items), against the target of p95 ≤ 50 ms per
//! request on loopback, with the same searches run in process beside it so the cost of HTTP,
//! the session check and JSON is visible.
//!
//! The library is the committed fixture items' real features (200 icons) followed by jittered
//! copies up to `--items`, as `learner bench search` makes its library; the copies share their
//! original's words and style label. Every item's image is the same small placeholder PNG: a
//! search answers with image URLs, it does not send images.

mod library;
mod phases;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::Args;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sqlx::Row;

use super::quantile;
use crate::AppState;
use crate::error::{AppError, Result};
use crate::search::{self, SearchRequest};
use crate::store::db::Db;
use crate::store::ids::ItemId;
use library::{ensure_library, real_count, store_model};
use phases::{admin_session, engine_phase, http_phase};

/// Settings of `platform bench search`.
#[derive(Debug, Clone, Args)]
pub struct SearchBenchArgs {
    /// Database URL (default: a new SQLite file in a temporary folder, removed afterwards).
    /// With an existing database that already holds the benchmark's library of this size, the
    /// library is reused.
    #[arg(long)]
    pub database_url: Option<String>,
    /// Library size: the fixture's real items, then jittered copies up to this many.
    #[arg(long, default_value_t = 200_000)]
    pub items: usize,
    /// Jitter of a copy: uniform noise of this many standard deviations of each feature.
    #[arg(long, default_value_t = 0.05)]
    pub jitter: f64,
    /// Features of the real items (a `learner features` CSV).
    #[arg(long, default_value = "learner/tests/data/metric/fixture-features.csv")]
    pub features: PathBuf,
    /// Their labels (`file`, `style`, `keywords`).
    #[arg(long, default_value = "fixtures/style/labels.csv")]
    pub labels: PathBuf,
    /// A learner `model.json` stored as the library's trained model (the search then uses
    /// it, as it uses the newest trained model); without it, uniform weights.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Keywords of every search ("vehicle": 20 of the 200 fixture items, so 20,000 hits at
    /// 200,000 items, the largest keyword case).
    #[arg(long, default_value = "vehicle")]
    pub keywords: String,
    /// Canvas items each search is ordered by (mean style distance to them).
    #[arg(long, default_value_t = 5)]
    pub canvas: usize,
    /// Results per search (the page's grid).
    #[arg(long, default_value_t = 48)]
    pub limit: u32,
    /// Concurrent HTTP clients.
    #[arg(long, default_value_t = 4)]
    pub clients: usize,
    /// Searches timed per measurement.
    #[arg(long, default_value_t = 1000)]
    pub requests: usize,
    /// Seed of the copies and of the canvases.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

/// The benchmark library's name.
const LIBRARY: &str = "bench-search";

/// Latencies of one measurement, ms, sorted, and its wall time.
pub(super) struct Timed {
    lat: Vec<f64>,
    wall: Duration,
    errors: usize,
}

impl Timed {
    pub(super) fn new(mut lat: Vec<f64>, wall: Duration, errors: usize) -> Self {
        lat.sort_by(f64::total_cmp);
        Self { lat, wall, errors }
    }
}

/// Runs the benchmark and prints its table.
pub async fn run(a: SearchBenchArgs) -> Result<()> {
    if !(1..=2_000_000).contains(&a.items)
        || !(1..=20).contains(&a.canvas)
        || !(1..=search::MAX_LIMIT).contains(&a.limit)
        || !(1..=256).contains(&a.clients)
        || a.requests == 0
        || !(0.0..=10.0).contains(&a.jitter)
    {
        return Err(AppError::BadRequest(
            "--items 1..=2000000, --canvas 1..=20, --limit 1..=200, --clients 1..=256, \
             --requests ≥ 1, --jitter 0..=10"
                .into(),
        ));
    }
    let temp = tempfile::tempdir().map_err(AppError::internal)?;
    let url = a
        .database_url
        .clone()
        .unwrap_or_else(|| format!("sqlite://{}", temp.path().join("bench-search.db").display()));
    let db = Db::connect(&url, 16).await?;
    let (lib, inserted) = ensure_library(&db, &a).await?;
    let model = match &a.model {
        Some(path) => Some(store_model(&db, lib, path).await?),
        None => None,
    };

    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .map_err(AppError::internal)?;
    let base = format!(
        "http://{}",
        listener.local_addr().map_err(AppError::internal)?
    );
    let state = AppState::new(db.clone(), base.clone(), false, 64 * 1024);
    let server = {
        let app = crate::app(state.clone());
        tokio::spawn(async move { axum::serve(listener, app).await })
    };
    let cookie = admin_session(&db).await?;

    // The canvases: random items of the library, the same for every path measured.
    let ids: Vec<ItemId> = sqlx::query("SELECT id FROM items WHERE library_id = $1 ORDER BY seq")
        .bind(lib.0)
        .fetch_all(&db.pool)
        .await?
        .iter()
        .map(|r| Ok(ItemId(r.try_get("id")?)))
        .collect::<Result<_>>()?;
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed.wrapping_add(1));
    let requests: Vec<SearchRequest> = (0..a.requests)
        .map(|_| SearchRequest {
            library: LIBRARY.into(),
            model: None,
            q: Some(a.keywords.clone()),
            category: None,
            near: Some(
                (0..a.canvas)
                    .map(|_| ids[rng.random_range(0..ids.len())].to_string())
                    .collect::<Vec<_>>()
                    .join(","),
            ),
            limit: Some(a.limit),
        })
        .collect();

    // The first search builds the index (k-means over the library): timed on its own.
    let t = Instant::now();
    let first = search::run(&state, &requests[0]).await?;
    let build_s = t.elapsed().as_secs_f64();

    let http = http_phase(&base, &cookie, &requests, a.clients).await?;
    let in_process = {
        let t0 = Instant::now();
        let mut lat = Vec::with_capacity(requests.len());
        for r in &requests {
            let t = Instant::now();
            search::run(&state, r).await?;
            lat.push(t.elapsed().as_secs_f64() * 1e3);
        }
        Timed::new(lat, t0.elapsed(), 0)
    };
    let engine = engine_phase(&state, lib, model, &requests, &a).await?;
    server.abort();
    let real = real_count(&a)?;

    outln!(
        "library: {} items = {} real (the fixture's features, {}) + {} copies with uniform \
         jitter of {} standard deviations per feature, rounded to 6 significant digits (seed \
         {}); {}",
        ids.len(),
        real,
        a.features.display(),
        ids.len().saturating_sub(real),
        a.jitter,
        a.seed,
        match inserted {
            Some(s) => format!("inserted in {s:.1} s"),
            None => "reused from the database".into(),
        }
    )?;
    outln!(
        "metric: {}; first search (builds the index, two-level k-means) {build_s:.1} s",
        match &a.model {
            Some(p) => format!("{} stored as a trained model", p.display()),
            None => "uniform weights".into(),
        }
    )?;
    outln!(
        "search: keywords {:?} ({} hits) ordered by mean style distance to {} random canvas \
         items, {} results with name, style label, image URL and distance; {} searches per row",
        a.keywords,
        first.matched,
        a.canvas,
        a.limit,
        a.requests
    )?;
    outln!(
        "\n{:<66} {:>7} {:>7} {:>7} {:>10} {:>6}",
        "path",
        "p50 ms",
        "p95 ms",
        "p99 ms",
        "searches/s",
        "errors"
    )?;
    let row = |name: String, t: &Timed| {
        outln!(
            "{name:<66} {:>7.2} {:>7.2} {:>7.2} {:>10.0} {:>6}",
            quantile(&t.lat, 0.5),
            quantile(&t.lat, 0.95),
            quantile(&t.lat, 0.99),
            t.lat.len() as f64 / t.wall.as_secs_f64(),
            t.errors
        )
    };
    row(
        format!(
            "HTTP GET /api/v1/admin/search, {} concurrent clients",
            a.clients
        ),
        &http,
    )?;
    row(
        "in process: search::run (database look-ups + engine), 1 at a time".into(),
        &in_process,
    )?;
    row(
        "engine only: SearchIndex::search, 1 at a time".into(),
        &engine,
    )?;
    outln!(
        "target: HTTP p95 ≤ 50 ms ({})",
        if quantile(&http.lat, 0.95) <= 50.0 && http.errors == 0 {
            "met"
        } else {
            "missed"
        }
    )?;
    drop(temp);
    Ok(())
}
