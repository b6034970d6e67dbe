//! `platform bench search`: the admin's style search over HTTP on a library of the paper's size
//! (Garces et al. 2014 §5.7.3: 194,663 items), against the target of p95 ≤ 50 ms per
//! request on loopback, with the same searches run in process beside it so the cost of HTTP,
//! the session check and JSON is visible.
//!
//! The library is the committed fixture items' real features (200 icons) followed by jittered
//! copies up to `--items`, as `learner bench search` makes its library; the copies share their
//! original's words and style label. Every item's image is the same small placeholder PNG: a
//! search answers with image URLs, it does not send images.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use clap::Args;
use learner::search::Query;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sqlx::Row;

use super::quantile;
use crate::AppState;
use crate::error::{AppError, Result};
use crate::search::{self, SearchRequest};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{ItemId, LibraryId, ModelId, random_token};
use crate::studies::library::{self, read_labels};
use crate::studies::study::{self, StudySettings};
use crate::web::admin;

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
/// Rows per INSERT statement (8 parameters each: within SQLite's and PostgreSQL's limits).
const INSERT_ROWS: usize = 500;

/// Latencies of one measurement, ms, sorted, and its wall time.
struct Timed {
    lat: Vec<f64>,
    wall: Duration,
    errors: usize,
}

impl Timed {
    fn new(mut lat: Vec<f64>, wall: Duration, errors: usize) -> Self {
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

/// Items of the features file.
fn real_count(a: &SearchBenchArgs) -> Result<usize> {
    Ok(learner::table::read_features(&a.features)
        .map_err(|e| AppError::BadRequest(e.to_string()))?
        .len()
        .min(a.items))
}

/// The benchmark library with `--items` items: found, or made (and the seconds the inserts
/// took).
async fn ensure_library(db: &Db, a: &SearchBenchArgs) -> Result<(LibraryId, Option<f64>)> {
    let lib = library::ensure_library(db, LIBRARY).await?;
    let have: i64 = sqlx::query("SELECT COUNT(*) AS n FROM items WHERE library_id = $1")
        .bind(lib.0)
        .fetch_one(&db.pool)
        .await?
        .try_get("n")?;
    if have as usize == a.items {
        return Ok((lib, None));
    }
    if have != 0 {
        return Err(AppError::BadRequest(format!(
            "library {LIBRARY} holds {have} items, not {}: use a fresh database",
            a.items
        )));
    }
    let table = learner::table::read_features(&a.features)
        .map_err(|e| AppError::BadRequest(e.to_string()))?;
    let catalogue: Vec<&str> = learner::features::catalogue()
        .iter()
        .map(|f| f.name)
        .collect();
    if table.names() != catalogue.as_slice() {
        return Err(AppError::BadRequest(format!(
            "{}: not the {} features of `learner features`",
            a.features.display(),
            catalogue.len()
        )));
    }
    let labels = read_labels(&a.labels)?;
    let t = Instant::now();
    let png = placeholder_png()?;
    let dim = table.dim();
    // Per-feature standard deviation over the real items: the unit of the jitter.
    let sd: Vec<f64> = (0..dim)
        .map(|k| {
            let n = table.len() as f64;
            let mean = (0..table.len()).map(|i| table.row(i)[k]).sum::<f64>() / n;
            ((0..table.len())
                .map(|i| (table.row(i)[k] - mean).powi(2))
                .sum::<f64>()
                / n)
                .sqrt()
        })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
    let mut tx = db.begin_write().await?;
    let mut seq = 0usize;
    while seq < a.items {
        let n = INSERT_ROWS.min(a.items - seq);
        let mut sql = String::from(
            "INSERT INTO items (id, library_id, seq, name, style, tags, png, features) VALUES ",
        );
        for r in 0..n {
            let p = r * 8;
            sql.push_str(&format!(
                "{}(${}, ${}, ${}, ${}, ${}, ${}, ${}, ${})",
                if r == 0 { "" } else { ", " },
                p + 1,
                p + 2,
                p + 3,
                p + 4,
                p + 5,
                p + 6,
                p + 7,
                p + 8
            ));
        }
        // Only numbered placeholders are formatted into it; every value is bound.
        let mut query = sqlx::query(sqlx::AssertSqlSafe(sql));
        for s in seq..seq + n {
            let real = s % table.len();
            let copy = s / table.len();
            let id = &table.ids()[real];
            let raw = table.row(real);
            let features: Vec<f64> = if copy == 0 {
                raw.to_vec()
            } else {
                raw.iter()
                    .zip(&sd)
                    .map(|(v, sd)| round6(v + rng.random_range(-1.0..=1.0) * a.jitter * sd))
                    .collect()
            };
            let name = if copy == 0 {
                id.clone()
            } else {
                format!("{id}#{copy}")
            };
            query = query
                .bind(ItemId::generate().0)
                .bind(lib.0)
                .bind(s as i64 + 1)
                .bind(name)
                .bind(labels.styles.get(id).cloned())
                .bind(
                    serde_json::to_string(labels.keywords.get(id).unwrap_or(&Vec::new()))
                        .map_err(AppError::internal)?,
                )
                .bind(png.clone())
                .bind(serde_json::to_string(&features).map_err(AppError::internal)?);
        }
        query.execute(&mut *tx).await?;
        seq += n;
    }
    tx.commit().await?;
    Ok((lib, Some(t.elapsed().as_secs_f64())))
}

/// `v` to 6 significant digits (short JSON; far finer than the jitter).
fn round6(v: f64) -> f64 {
    format!("{v:.5e}").parse().unwrap_or(v)
}

/// A 4×4 grey PNG standing in for every image.
fn placeholder_png() -> Result<Vec<u8>> {
    let mut png = Vec::new();
    image::RgbImage::from_pixel(4, 4, image::Rgb([200, 200, 200]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(AppError::internal)?;
    Ok(png)
}

/// Stores `path` as a finished model of a study over the library, so that searches use it.
async fn store_model(db: &Db, lib: LibraryId, path: &PathBuf) -> Result<ModelId> {
    let bytes = std::fs::read(path)
        .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?;
    let _: learner::metric::Model = serde_json::from_slice(&bytes)
        .map_err(|e| AppError::BadRequest(format!("{}: not a model: {e}", path.display())))?;
    let settings = StudySettings {
        training_questions: 0,
        tuples: 100,
        ..StudySettings::default()
    };
    let (study, _) = study::create(db, "bench search", lib, settings).await?;
    let id = ModelId::generate();
    let now = now_ms();
    let mut tx = db.begin_write().await?;
    sqlx::query(
        "INSERT INTO models (id, study_id, status, started_at, finished_at) \
         VALUES ($1, $2, 'done', $3, $4)",
    )
    .bind(id.0)
    .bind(study.0)
    .bind(now)
    .bind(now)
    .execute(&mut *tx)
    .await?;
    sqlx::query("INSERT INTO model_files (model_id, name, bytes) VALUES ($1, 'model.json', $2)")
        .bind(id.0)
        .bind(bytes)
        .execute(&mut *tx)
        .await?;
    tx.commit().await?;
    Ok(id)
}

/// A new admin account and its session cookie.
async fn admin_session(db: &Db) -> Result<String> {
    let username = format!("bench-{}", now_ms());
    let password = random_token();
    admin::create_admin(db, &username, &password).await?;
    let (token, _csrf) = admin::login(db, &username, &password)
        .await?
        .ok_or_else(|| AppError::Internal("the new admin cannot log in".into()))?;
    Ok(format!("{}={token}", admin::COOKIE))
}

/// `clients` HTTP clients sending the searches, each taking the next one until all are done.
async fn http_phase(
    base: &str,
    cookie: &str,
    requests: &[SearchRequest],
    clients: usize,
) -> Result<Timed> {
    let mut headers = reqwest::header::HeaderMap::new();
    headers.insert(
        reqwest::header::COOKIE,
        cookie.parse().map_err(AppError::internal)?,
    );
    let client = reqwest::Client::builder()
        .default_headers(headers)
        .build()
        .map_err(AppError::internal)?;
    let urls: Arc<Vec<String>> = Arc::new(
        requests
            .iter()
            .map(|r| {
                let mut q = form_urlencoded::Serializer::new(String::new());
                q.append_pair("library", &r.library);
                q.append_pair("q", r.q.as_deref().unwrap_or(""));
                q.append_pair("near", r.near.as_deref().unwrap_or(""));
                q.append_pair("limit", &r.limit.unwrap_or(48).to_string());
                format!("{base}/api/v1/admin/search?{}", q.finish())
            })
            .collect(),
    );
    // One unmeasured request per client opens its connection.
    for _ in 0..clients {
        client
            .get(&urls[0])
            .send()
            .await
            .map_err(AppError::internal)?;
    }
    let next = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let t0 = Instant::now();
    let mut tasks = Vec::new();
    for _ in 0..clients {
        let (client, urls, next) = (client.clone(), urls.clone(), next.clone());
        tasks.push(tokio::spawn(async move {
            let (mut lat, mut errors) = (Vec::new(), 0usize);
            loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(url) = urls.get(i) else { break };
                let t = Instant::now();
                let ok = match client.get(url).send().await {
                    // The body is read: the time includes the whole JSON answer.
                    Ok(r) if r.status().is_success() => r.bytes().await.is_ok(),
                    Ok(r) => {
                        if errors == 0 {
                            eprintln!(
                                "search: {} {}",
                                r.status(),
                                r.text().await.unwrap_or_default()
                            );
                        }
                        false
                    }
                    Err(_) => false,
                };
                if ok {
                    lat.push(t.elapsed().as_secs_f64() * 1e3);
                } else {
                    errors += 1;
                }
            }
            (lat, errors)
        }));
    }
    let (mut lat, mut errors) = (Vec::new(), 0);
    for t in tasks {
        let (l, e) = t.await.map_err(AppError::internal)?;
        lat.extend(l);
        errors += e;
    }
    Ok(Timed::new(lat, t0.elapsed(), errors))
}

/// The engine alone on the same searches: the built index's `search`, no database.
async fn engine_phase(
    state: &AppState,
    lib: LibraryId,
    model: Option<ModelId>,
    requests: &[SearchRequest],
    a: &SearchBenchArgs,
) -> Result<Timed> {
    let built = state
        .search
        .get(
            &state.db,
            search::cache::Key {
                library: lib,
                model,
            },
        )
        .await?;
    let queries: Vec<Query> = requests
        .iter()
        .map(|r| {
            let near = r
                .near
                .as_deref()
                .unwrap_or("")
                .split(',')
                .map(|id| {
                    let id: ItemId = id.parse().map_err(AppError::internal)?;
                    let row = built
                        .row_of(id)
                        .ok_or_else(|| AppError::Internal(format!("item {id} not indexed")))?;
                    Ok(built.index.ids()[row].clone())
                })
                .collect::<Result<Vec<_>>>()?;
            Ok(Query {
                keywords: Some(a.keywords.clone()),
                near,
                limit: a.limit as usize,
                ..Query::default()
            })
        })
        .collect::<Result<_>>()?;
    tokio::task::spawn_blocking(move || {
        let t0 = Instant::now();
        let mut lat = Vec::with_capacity(queries.len());
        for q in &queries {
            let t = Instant::now();
            built.index.search(q).map_err(AppError::internal)?;
            lat.push(t.elapsed().as_secs_f64() * 1e3);
        }
        Ok(Timed::new(lat, t0.elapsed(), 0))
    })
    .await
    .map_err(AppError::internal)?
}
