//! Studies: settings (the paper's defaults, `settings`), the tuple pool (uniform random main
//! triplets with R slots each, automatic controls and training triplets from style groups,
//! `triplets`), its creation in chunks that leave the answer path free (`create`), creations
//! that did not finish (`recovery`), what a pool lacks (`warnings`) and curated controls.

use serde::{Deserialize, Serialize};
use sqlx::Row;

use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::store::ids::{LibraryId, StudyId, TupleId};
use crate::studies::kind::StudyKind;

mod create;
mod recovery;
mod rows;
mod settings;
mod triplets;
mod warnings;

pub use create::{
    CHUNK_ROWS, CREATE_WAIT, DrawnPool, PendingPool, PoolSummary, Started, begin, begin_drawn,
    create, start_creation,
};
pub use recovery::{STALE_MS, WATCH_EVERY, recover, watch};
pub use settings::{
    DEFAULT_INSTRUCTIONS, MAX_CONTROL_ERRORS, MAX_SLOTS, MAX_TUPLES, MturkMode, StudySettings,
};
pub use triplets::{NewTuple, distinct_triplets, random_triplets, style_triplets};
pub use warnings::{LabelStats, pool_warnings, warnings};

/// Where a study's tuple pool stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum StudyStatus {
    /// The pool is being written; workers cannot start yet.
    Creating,
    /// The pool is complete: workers may start.
    Ready,
    /// The creation stopped before the pool was complete; the study takes no workers (its
    /// rows are deleted).
    Failed,
}

impl StudyStatus {
    /// The stored form.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Creating => "creating",
            Self::Ready => "ready",
            Self::Failed => "failed",
        }
    }

    fn parse(s: &str) -> Result<Self> {
        match s {
            "creating" => Ok(Self::Creating),
            "ready" => Ok(Self::Ready),
            "failed" => Ok(Self::Failed),
            other => Err(AppError::Internal(format!(
                "unknown study status {other:?}"
            ))),
        }
    }
}

/// How far a study's tuple pool is written (studies created before the pool was written in
/// chunks show 0 of 0).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, utoipa::ToSchema)]
pub struct PoolProgress {
    /// Rows (tuples and slots) written; while a failed study's rows are deleted, the rows left.
    pub rows_done: i64,
    /// Rows of the whole pool.
    pub rows_total: i64,
    /// When the last chunk was written (Unix ms).
    pub updated_at: Option<i64>,
    /// Why the creation failed.
    pub error: Option<String>,
}

impl PoolProgress {
    /// Whole percent written.
    pub fn percent(&self) -> i64 {
        if self.rows_total > 0 {
            self.rows_done * 100 / self.rows_total
        } else {
            100
        }
    }
}

/// A stored study.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct Study {
    /// Id.
    pub id: StudyId,
    /// Name.
    pub name: String,
    /// What the study asks of its workers.
    pub kind: StudyKind,
    /// The library its items come from.
    pub library: LibraryId,
    /// Settings.
    pub settings: StudySettings,
    /// HMAC key of completion codes (never serialised).
    #[serde(skip)]
    pub secret: String,
    /// Creation time (Unix ms).
    pub created_at: i64,
    /// Whether its tuple pool is complete (only a `ready` study takes workers).
    pub status: StudyStatus,
    /// How far its tuple pool is written.
    pub progress: PoolProgress,
}

impl Study {
    /// Refuses workers unless the tuple pool is complete.
    pub fn check_open(&self) -> Result<()> {
        match self.status {
            StudyStatus::Ready => Ok(()),
            StudyStatus::Creating => Err(AppError::Conflict(format!(
                "this study is still being prepared ({}% of its questions are ready); please \
                 try again in a few minutes",
                self.progress.percent()
            ))),
            StudyStatus::Failed => Err(AppError::Conflict(
                "this study could not be set up and takes no workers".into(),
            )),
        }
    }
}

/// Loads a study.
pub async fn load(db: &Db, id: StudyId) -> Result<Study> {
    load_on(&mut *db.pool.acquire().await?, id).await
}

/// Loads a study through `conn` (e.g. inside a write transaction).
pub async fn load_on(conn: &mut sqlx::AnyConnection, id: StudyId) -> Result<Study> {
    let row = sqlx::query(
        "SELECT id, name, kind, library_id, settings, secret, created_at, status, pool_done, \
         pool_total, pool_beat, pool_error FROM studies WHERE id = $1",
    )
    .bind(id.0)
    .fetch_optional(&mut *conn)
    .await?
    .ok_or(AppError::NotFound("study"))?;
    let settings: String = row.try_get("settings")?;
    Ok(Study {
        id: StudyId(row.try_get("id")?),
        name: row.try_get("name")?,
        kind: StudyKind::parse(&row.try_get::<String, _>("kind")?)
            .map_err(|e| AppError::Internal(e.to_string()))?,
        library: LibraryId(row.try_get("library_id")?),
        settings: serde_json::from_str(&settings).map_err(AppError::internal)?,
        secret: row.try_get("secret")?,
        created_at: row.try_get("created_at")?,
        status: StudyStatus::parse(&row.try_get::<String, _>("status")?)?,
        progress: PoolProgress {
            rows_done: row.try_get("pool_done")?,
            rows_total: row.try_get("pool_total")?,
            updated_at: row.try_get("pool_beat")?,
            error: row.try_get("pool_error")?,
        },
    })
}

/// A study's settings as stored now, read on the SQLite answer writer's connection inside its
/// transaction (settings may be edited while a study runs).
pub(crate) fn settings_sqlite(conn: &rusqlite::Connection, id: StudyId) -> Result<StudySettings> {
    let settings = crate::store::sqlite_direct::optional_row(
        conn,
        "SELECT settings FROM studies WHERE id = $1",
        &[&id.0],
        |r| r.get::<_, String>(0),
    )?
    .ok_or(AppError::NotFound("study"))?;
    serde_json::from_str(&settings).map_err(AppError::internal)
}

/// All studies, newest first.
pub async fn list(db: &Db) -> Result<Vec<Study>> {
    let rows = sqlx::query("SELECT id FROM studies ORDER BY created_at DESC")
        .fetch_all(&db.pool)
        .await?;
    let mut out = Vec::with_capacity(rows.len());
    for r in rows {
        out.push(load(db, StudyId(r.try_get("id")?)).await?);
    }
    Ok(out)
}

/// The practice pool a study draws: `training_questions` triplets per attempt for
/// max(`max_training_attempts`, 5) attempts, so that a retry shows other triplets (attempts may
/// be raised later, hence at least 5), and one more, the worked example, which no attempt's
/// block reaches (`flow::training`).
pub fn practice_pool_size(s: &StudySettings) -> usize {
    let n = s.training_questions as usize;
    if n == 0 {
        0
    } else {
        n * s.max_training_attempts.max(5) as usize + 1
    }
}

/// Adds a curated control (or training) triplet given by item names; `b` is the expected answer.
pub async fn add_curated(db: &Db, study: &Study, kind: &str, names: [&str; 3]) -> Result<TupleId> {
    if kind != "control" && kind != "training" {
        return Err(AppError::BadRequest(
            "kind must be 'control' or 'training'".into(),
        ));
    }
    let mut ids = Vec::new();
    for name in names {
        let row = sqlx::query("SELECT id FROM items WHERE library_id = $1 AND name = $2")
            .bind(study.library.0)
            .bind(name)
            .fetch_optional(&db.pool)
            .await?
            .ok_or_else(|| {
                AppError::BadRequest(format!("no item named {name:?} in the library"))
            })?;
        ids.push(row.try_get::<i64, _>("id")?);
    }
    if ids[0] == ids[1] || ids[0] == ids[2] || ids[1] == ids[2] {
        return Err(AppError::BadRequest("a, b and c must be distinct".into()));
    }
    let seq_row = sqlx::query(
        "SELECT CAST(COALESCE(MAX(seq), -1) AS BIGINT) AS m FROM tuples WHERE study_id = $1 AND kind = $2",
    )
    .bind(study.id.0)
    .bind(kind)
    .fetch_one(&db.pool)
    .await?;
    let seq: i64 = seq_row.try_get("m")?;
    let id = TupleId::generate();
    sqlx::query(
        "INSERT INTO tuples (id, study_id, seq, kind, a, b, c, expected, origin) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, 'b', 'curated')",
    )
    .bind(id.0)
    .bind(study.id.0)
    .bind(seq + 1)
    .bind(kind)
    .bind(ids[0])
    .bind(ids[1])
    .bind(ids[2])
    .execute(&mut *db.write_conn().await?)
    .await?;
    Ok(id)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_practice_pool_holds_five_attempts_or_more_and_the_worked_example() {
        let with = |n: u32, attempts: u32| StudySettings {
            training_questions: n,
            max_training_attempts: attempts,
            ..StudySettings::default()
        };
        assert_eq!(practice_pool_size(&with(3, 1)), 16);
        assert_eq!(practice_pool_size(&with(3, 8)), 25);
        assert_eq!(practice_pool_size(&with(0, 8)), 0);
    }
}
