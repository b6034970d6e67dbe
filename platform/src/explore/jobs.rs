//! Explorations as stored background jobs: a row of `explorations` per request, run by the
//! server that received it (a tokio task around a blocking computation), its progress written
//! about every 0.5 s, the result stored as JSON so that every server behind a load balancer
//! reads it. A row left queued or running by a server that stopped is recognised by its stale
//! heartbeat and shown as failed; asking again restarts it.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::Serialize;
use sqlx::Row;
use utoipa::ToSchema;

use crate::AppState;
use crate::error::{AppError, Result};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{ExplorationId, LibraryId, ModelId};

/// How often a running job writes its progress (and so its heartbeat).
pub const HEARTBEAT: Duration = Duration::from_millis(500);

/// A queued or running job whose heartbeat is older than this belongs to a server that stopped
/// (a live one refreshes it every [`HEARTBEAT`], even while its database is slow).
pub const STALE_AFTER_MS: i64 = 60_000;

/// What kind of exploration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// Representative styles (§6.5.1).
    Taxonomy,
    /// A t-SNE style map.
    Map,
}

impl Kind {
    fn as_str(self) -> &'static str {
        match self {
            Kind::Taxonomy => "taxonomy",
            Kind::Map => "map",
        }
    }
}

/// What a job is for: its row's identifying columns.
#[derive(Debug, Clone)]
pub struct JobKey {
    /// The library.
    pub library: LibraryId,
    /// The model, `None` for uniform weights.
    pub model: Option<ModelId>,
    /// The kind.
    pub kind: Kind,
    /// Canonical JSON of the parameters.
    pub params: String,
    /// Items of the library when asked.
    pub library_items: i64,
}

/// A stored exploration as the pages and the API show it.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct Job {
    /// The exploration.
    pub id: ExplorationId,
    /// Its library.
    #[serde(skip)]
    pub library: LibraryId,
    /// The model, `null` for uniform weights.
    pub model: Option<ModelId>,
    /// `taxonomy` or `map`.
    pub kind: String,
    /// The parameters.
    #[schema(value_type = Object)]
    pub params: serde_json::Value,
    /// `queued`, `running`, `done` or `failed` (a job whose server stopped shows `failed`).
    pub status: String,
    /// What the job is doing.
    pub stage: String,
    /// Steps done of `total` in the current stage.
    pub done: i64,
    /// Steps of the current stage.
    pub total: i64,
    /// Why it failed.
    pub error: Option<String>,
    /// When it was asked for (Unix ms).
    pub created_at: i64,
    /// When it ended (Unix ms).
    pub finished_at: Option<i64>,
    /// The result (`done` only).
    #[schema(value_type = Object)]
    pub result: Option<serde_json::Value>,
}

/// The job of row `r`; its result only if the query selected the `result` column (the pages
/// that list jobs or show a map's progress never parse a 200,000-point result).
fn job_of(r: &sqlx::any::AnyRow, now: i64) -> Result<Job> {
    let mut status: String = r.try_get("status")?;
    let mut error: Option<String> = r.try_get("error")?;
    let heartbeat: i64 = r.try_get("heartbeat_at")?;
    if (status == "queued" || status == "running") && heartbeat < now - STALE_AFTER_MS {
        status = "failed".into();
        error = Some(format!(
            "the server running this job stopped (no progress for {} s); build it again to restart",
            (now - heartbeat) / 1000
        ));
    }
    let parse = |text: Option<String>| -> Result<Option<serde_json::Value>> {
        text.map(|t| serde_json::from_str(&t).map_err(AppError::internal))
            .transpose()
    };
    Ok(Job {
        id: ExplorationId(r.try_get("id")?),
        library: LibraryId(r.try_get("library_id")?),
        model: r.try_get::<Option<i64>, _>("model_id")?.map(ModelId),
        kind: r.try_get("kind")?,
        params: parse(Some(r.try_get("params")?))?.unwrap_or_default(),
        status,
        stage: r.try_get("stage")?,
        done: r.try_get("progress_done")?,
        total: r.try_get("progress_total")?,
        error,
        created_at: r.try_get("created_at")?,
        finished_at: r.try_get("finished_at")?,
        result: match r.try_get::<Option<String>, _>("result") {
            Ok(text) => parse(text)?,
            Err(sqlx::Error::ColumnNotFound(_)) => None,
            Err(e) => return Err(e.into()),
        },
    })
}

/// The columns [`job_of`] reads but the result (a macro so that the queries stay literal
/// strings).
macro_rules! status_columns {
    () => {
        "id, library_id, model_id, kind, params, status, stage, progress_done, progress_total, \
         error, created_at, finished_at, heartbeat_at"
    };
}

/// The stored exploration `id` with its result.
pub async fn load(db: &Db, id: ExplorationId) -> Result<Job> {
    let row = sqlx::query(concat!(
        "SELECT ",
        status_columns!(),
        ", result FROM explorations WHERE id = $1"
    ))
    .bind(id.0)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("exploration"))?;
    job_of(&row, now_ms())
}

/// The stored exploration `id` without its result (`result` is `None`).
pub async fn load_status(db: &Db, id: ExplorationId) -> Result<Job> {
    let row = sqlx::query(concat!(
        "SELECT ",
        status_columns!(),
        " FROM explorations WHERE id = $1"
    ))
    .bind(id.0)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("exploration"))?;
    job_of(&row, now_ms())
}

/// The latest explorations of a library, newest first, without their results.
pub async fn recent(db: &Db, library: LibraryId, kind: Kind, limit: i64) -> Result<Vec<Job>> {
    let now = now_ms();
    sqlx::query(concat!(
        "SELECT ",
        status_columns!(),
        " FROM explorations WHERE library_id = $1 AND kind = $2 \
         ORDER BY created_at DESC, id DESC LIMIT $3"
    ))
    .bind(library.0)
    .bind(kind.as_str())
    .bind(limit)
    .fetch_all(&db.pool)
    .await?
    .iter()
    .map(|r| job_of(r, now))
    .collect()
}

/// The job for `key`: a stored one that is done or still alive (identical parameters reuse it),
/// else a new queued row (`true`: the caller must run it).
pub async fn find_or_create(db: &Db, key: &JobKey) -> Result<(ExplorationId, bool)> {
    let mut tx = db.begin_write().await?;
    let now = now_ms();
    // `model_id = NULL` is never true, hence the flag for uniform weights.
    let rows = sqlx::query(
        "SELECT id, status, heartbeat_at FROM explorations WHERE library_id = $1 AND kind = $2 \
         AND params = $3 AND library_items = $4 \
         AND (model_id = $5 OR (model_id IS NULL AND $6 = 1)) \
         ORDER BY created_at DESC, id DESC",
    )
    .bind(key.library.0)
    .bind(key.kind.as_str())
    .bind(&key.params)
    .bind(key.library_items)
    .bind(key.model.map(|m| m.0))
    .bind(i64::from(key.model.is_none()))
    .fetch_all(&mut *tx)
    .await?;
    for r in &rows {
        let status: String = r.try_get("status")?;
        let heartbeat: i64 = r.try_get("heartbeat_at")?;
        let alive =
            (status == "queued" || status == "running") && heartbeat >= now - STALE_AFTER_MS;
        if status == "done" || alive {
            tx.rollback().await?;
            return Ok((ExplorationId(r.try_get("id")?), false));
        }
    }
    let id = ExplorationId::generate();
    sqlx::query(
        "INSERT INTO explorations (id, library_id, model_id, kind, params, library_items, \
         status, progress_done, progress_total, stage, created_at, heartbeat_at) \
         VALUES ($1, $2, $3, $4, $5, $6, 'queued', 0, 0, 'queued', $7, $7)",
    )
    .bind(id.0)
    .bind(key.library.0)
    .bind(key.model.map(|m| m.0))
    .bind(key.kind.as_str())
    .bind(&key.params)
    .bind(key.library_items)
    .bind(now)
    .execute(&mut *tx)
    .await?;
    tx.commit().await?;
    Ok((id, true))
}

/// Where a running computation reports: the stage and its steps.
#[derive(Debug, Default)]
pub struct Progress {
    state: Mutex<(String, i64, i64)>,
}

impl Progress {
    /// Reports `done` of `total` steps of `stage`.
    pub fn set(&self, stage: &str, done: usize, total: usize) {
        if let Ok(mut s) = self.state.lock() {
            if s.0 != stage {
                s.0 = stage.to_owned();
            }
            s.1 = done as i64;
            s.2 = total as i64;
        }
    }

    fn get(&self) -> (String, i64, i64) {
        self.state
            .lock()
            .map(|s| s.clone())
            .unwrap_or_else(|_| ("running".into(), 0, 0))
    }
}

async fn write_progress(db: &Db, id: ExplorationId, p: &Progress) -> Result<()> {
    let (stage, done, total) = p.get();
    let mut tx = db.begin_write().await?;
    sqlx::query(
        "UPDATE explorations SET status = 'running', stage = $2, progress_done = $3, \
         progress_total = $4, heartbeat_at = $5 WHERE id = $1",
    )
    .bind(id.0)
    .bind(if stage.is_empty() { "starting" } else { &stage })
    .bind(done)
    .bind(total)
    .bind(now_ms())
    .execute(&mut *tx)
    .await?;
    tx.commit().await?;
    Ok(())
}

async fn finish(db: &Db, id: ExplorationId, outcome: Result<serde_json::Value>) -> Result<()> {
    let mut tx = db.begin_write().await?;
    let now = now_ms();
    let query = match outcome {
        Ok(v) => sqlx::query(
            "UPDATE explorations SET status = 'done', stage = 'done', result = $2, \
             progress_done = progress_total, heartbeat_at = $3, finished_at = $3 WHERE id = $1",
        )
        .bind(id.0)
        .bind(serde_json::to_string(&v).map_err(AppError::internal)?),
        Err(e) => sqlx::query(
            "UPDATE explorations SET status = 'failed', stage = 'failed', error = $2, \
             heartbeat_at = $3, finished_at = $3 WHERE id = $1",
        )
        .bind(id.0)
        .bind(e.public_message()),
    };
    query.bind(now).execute(&mut *tx).await?;
    tx.commit().await?;
    Ok(())
}

/// Runs job `id` in the background: `prepare` (async: reads what the computation needs) then
/// `work` in a blocking thread, the progress written every [`HEARTBEAT`] meanwhile, and the
/// outcome stored.
pub fn spawn<P, T, W>(state: AppState, id: ExplorationId, prepare: P, work: W)
where
    P: Future<Output = Result<T>> + Send + 'static,
    T: Send + 'static,
    W: FnOnce(T, &Progress) -> Result<serde_json::Value> + Send + 'static,
{
    tokio::spawn(async move {
        let progress = Arc::new(Progress::default());
        progress.set("reading the library", 0, 1);
        let outcome = run(&state.db, id, &progress, prepare, work).await;
        if let Err(e) = finish(&state.db, id, outcome).await {
            eprintln!("error: storing exploration {id}: {e}");
        }
    });
}

async fn run<P, T, W>(
    db: &Db,
    id: ExplorationId,
    progress: &Arc<Progress>,
    prepare: P,
    work: W,
) -> Result<serde_json::Value>
where
    P: Future<Output = Result<T>> + Send + 'static,
    T: Send + 'static,
    W: FnOnce(T, &Progress) -> Result<serde_json::Value> + Send + 'static,
{
    write_progress(db, id, progress).await?;
    let mut prepared = tokio::spawn(prepare);
    let input = loop {
        match tokio::time::timeout(HEARTBEAT, &mut prepared).await {
            Ok(joined) => break joined.map_err(AppError::internal)??,
            Err(_) => write_progress(db, id, progress).await?,
        }
    };
    let p = progress.clone();
    let mut handle = tokio::task::spawn_blocking(move || work(input, &p));
    loop {
        match tokio::time::timeout(HEARTBEAT, &mut handle).await {
            Ok(joined) => return joined.map_err(AppError::internal)?,
            Err(_) => write_progress(db, id, progress).await?,
        }
    }
}
