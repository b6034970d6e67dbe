//! What a worker who opens the study link again already has: the start page says "continue
//! where you left off" instead of offering a fresh start.

use sqlx::Row;

use super::Source;
use crate::error::Result;
use crate::store::db::Db;
use crate::studies::study::Study;

/// A worker's assignment in a study, as the start page describes it.
#[derive(Debug, Clone)]
pub struct Existing {
    /// Its status (`training`, `active`, `completed`, …).
    pub status: String,
    /// Questions answered.
    pub answered: i64,
    /// Questions in the HIT (0 before the training is passed).
    pub total: i64,
}

/// The assignment the worker with `external` id from `source` has in `study`, if any.
pub async fn existing(
    db: &Db,
    study: &Study,
    source: Source,
    external: &str,
) -> Result<Option<Existing>> {
    let row = sqlx::query(
        "SELECT a.status, \
           (SELECT CAST(COUNT(*) AS BIGINT) FROM questions q WHERE q.assignment_id = a.id) AS total, \
           (SELECT CAST(COUNT(*) AS BIGINT) FROM questions q WHERE q.assignment_id = a.id \
              AND q.choice IS NOT NULL) AS answered \
         FROM assignments a JOIN workers w ON w.id = a.worker_id \
         WHERE a.study_id = $1 AND w.source = $2 AND w.external_id = $3",
    )
    .bind(study.id.0)
    .bind(source.as_str())
    .bind(external)
    .fetch_optional(&db.pool)
    .await?;
    row.map(|r| {
        Ok(Existing {
            status: r.try_get("status")?,
            answered: r.try_get("answered")?,
            total: r.try_get("total")?,
        })
    })
    .transpose()
}
