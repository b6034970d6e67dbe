//! Creations that did not finish: a study whose pool is no longer being written is marked
//! `failed` (workers could never start it), and the rows it had are deleted, in chunks like
//! they were written so that the answer path is not held up.
//!
//! A creation runs in the process that began it (a server's background task, or `platform
//! study create`), and each of its chunks refreshes `pool_beat`. Several servers may share a
//! PostgreSQL database, so "this server restarted" does not tell whether another process is
//! still writing: a creation without a chunk for [`STALE_MS`] is taken for dead. Every server
//! looks for such creations when it starts and every [`WATCH_EVERY`] after
//! ([`watch`]); a creation that was only slow finds itself failed at its next chunk and stops.

use std::time::Duration;

use sqlx::Row;

use super::create::CHUNK_ROWS;
use crate::error::Result;
use crate::store::db::{Db, now_ms};
use crate::store::ids::StudyId;

/// A creation without a written chunk for this long (ms) has stopped: its process died or was
/// killed. A chunk takes well under a second.
pub const STALE_MS: i64 = 120_000;

/// How often a server looks for stopped creations.
pub const WATCH_EVERY: Duration = Duration::from_secs(60);

/// Marks a study that is still `creating` as `failed`, with the reason shown to admins.
pub(super) async fn fail(db: &Db, id: StudyId, why: &str) -> Result<bool> {
    let done = sqlx::query(
        "UPDATE studies SET status = 'failed', pool_error = $2 \
         WHERE id = $1 AND status = 'creating'",
    )
    .bind(id.0)
    .bind(why)
    .execute(&mut *db.write_conn().await?)
    .await?;
    Ok(done.rows_affected() == 1)
}

/// Deletes the tuples and slots of a `failed` study (it never took a worker: only a `ready`
/// study does), in chunks of at most [`super::CHUNK_ROWS`] rows, from its last main tuple
/// down; `pool_done` counts the rows left and is 0 once all are gone.
pub(super) async fn discard(db: &Db, id: StudyId) -> Result<()> {
    let row = sqlx::query("SELECT status, settings FROM studies WHERE id = $1")
        .bind(id.0)
        .fetch_one(&db.pool)
        .await?;
    if row.try_get::<String, _>("status")? != "failed" {
        return Ok(());
    }
    let settings: super::StudySettings =
        serde_json::from_str(&row.try_get::<String, _>("settings")?)
            .map_err(crate::error::AppError::internal)?;
    let per_chunk = (CHUNK_ROWS / (1 + settings.replication as usize)).max(1) as i64;
    let last: Option<i64> =
        sqlx::query("SELECT MAX(seq) AS m FROM tuples WHERE study_id = $1 AND kind = 'main'")
            .bind(id.0)
            .fetch_one(&db.pool)
            .await?
            .try_get("m")?;
    let mut upper = last.map_or(0, |m| m + 1);
    while upper > 0 {
        let lower = (upper - per_chunk).max(0);
        let mut tx = db.begin_write().await?;
        let slots = sqlx::query(
            "DELETE FROM slots WHERE study_id = $1 AND assignment_id IS NULL \
             AND seq >= $2 AND seq < $3",
        )
        .bind(id.0)
        .bind(lower)
        .bind(upper)
        .execute(&mut *tx)
        .await?
        .rows_affected();
        let tuples = sqlx::query(
            "DELETE FROM tuples WHERE study_id = $1 AND kind = 'main' AND seq >= $2 AND seq < $3",
        )
        .bind(id.0)
        .bind(lower)
        .bind(upper)
        .execute(&mut *tx)
        .await?
        .rows_affected();
        sqlx::query("UPDATE studies SET pool_done = pool_done - $2 WHERE id = $1")
            .bind(id.0)
            .bind((slots + tuples) as i64)
            .execute(&mut *tx)
            .await?;
        tx.commit().await?;
        upper = lower;
        tokio::task::yield_now().await;
    }
    let mut tx = db.begin_write().await?;
    sqlx::query("DELETE FROM tuples WHERE study_id = $1")
        .bind(id.0)
        .execute(&mut *tx)
        .await?;
    sqlx::query("UPDATE studies SET pool_done = 0 WHERE id = $1")
        .bind(id.0)
        .execute(&mut *tx)
        .await?;
    tx.commit().await?;
    Ok(())
}

/// Marks the creations without progress for [`STALE_MS`] as failed and deletes the rows of
/// every failed study that still has some; returns the studies it failed.
pub async fn recover(db: &Db) -> Result<Vec<StudyId>> {
    let cutoff = now_ms() - STALE_MS;
    let stale = sqlx::query("SELECT id FROM studies WHERE status = 'creating' AND pool_beat < $1")
        .bind(cutoff)
        .fetch_all(&db.pool)
        .await?;
    let mut failed = Vec::new();
    for r in stale {
        let id = StudyId(r.try_get("id")?);
        // Conditional again: a chunk may have been written since the read.
        let done = sqlx::query(
            "UPDATE studies SET status = 'failed', pool_error = $2 \
             WHERE id = $1 AND status = 'creating' AND pool_beat < $3",
        )
        .bind(id.0)
        .bind(format!(
            "the creation stopped: no part of the tuple pool was written for {} s (the process \
             writing it ended); the study takes no workers, create it again",
            STALE_MS / 1000
        ))
        .bind(cutoff)
        .execute(&mut *db.write_conn().await?)
        .await?;
        if done.rows_affected() == 1 {
            failed.push(id);
        }
    }
    let leftovers = sqlx::query("SELECT id FROM studies WHERE status = 'failed' AND pool_done > 0")
        .fetch_all(&db.pool)
        .await?;
    for r in leftovers {
        discard(db, StudyId(r.try_get("id")?)).await?;
    }
    Ok(failed)
}

/// Runs [`recover`] now and every [`WATCH_EVERY`] on a task of its own (each server).
pub fn watch(db: Db) -> tokio::task::JoinHandle<()> {
    tokio::spawn(async move {
        loop {
            match recover(&db).await {
                Ok(failed) => {
                    for id in failed {
                        eprintln!(
                            "study {id}: its creation stopped (no progress for {} s); marked \
                             failed, its partial pool deleted",
                            STALE_MS / 1000
                        );
                    }
                }
                Err(e) => eprintln!("looking for stopped study creations: {e}"),
            }
            tokio::time::sleep(WATCH_EVERY).await;
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::studies::library::{self, NewItem};
    use crate::studies::study::{self, StudySettings, StudyStatus};

    /// A SQLite database with a library of 12 labelled swatches (four styles).
    async fn library_db() -> (Db, tempfile::TempDir, crate::store::ids::LibraryId) {
        let dir = tempfile::tempdir().expect("temp dir");
        let url = format!("sqlite://{}", dir.path().join("r.db").display());
        let db = Db::connect(&url, 4).await.expect("sqlite");
        let lib = library::ensure_library(&db, "swatches")
            .await
            .expect("library");
        for i in 0..12_u8 {
            let item = NewItem {
                name: format!("s{i}"),
                style: Some(format!("g{}", i % 4)),
                tags: Vec::new(),
                image: image::RgbImage::from_pixel(
                    400,
                    400,
                    image::Rgb([i * 20, 255 - i * 20, 90]),
                ),
                cutout: None,
                svg: None,
            };
            library::insert_item(&db, lib, item).await.expect("item");
        }
        (db, dir, lib)
    }

    async fn count(db: &Db, sql: &'static str, id: StudyId) -> i64 {
        sqlx::query(sql)
            .bind(id.0)
            .fetch_one(&db.pool)
            .await
            .expect(sql)
            .try_get("n")
            .expect("n")
    }

    const TUPLES: &str = "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM tuples WHERE study_id = $1";
    const SLOTS: &str = "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM slots WHERE study_id = $1";

    fn settings() -> StudySettings {
        StudySettings {
            tuples: 600,
            replication: 10,
            ..StudySettings::default()
        }
    }

    #[tokio::test]
    async fn a_pool_is_written_in_chunks_and_ready_with_its_last_row() {
        let (db, _dir, lib) = library_db().await;
        let pending = study::begin(&db, "s", lib, settings())
            .await
            .expect("begin");
        let id = pending.id;
        assert_eq!(
            study::load(&db, id).await.expect("load").status,
            StudyStatus::Creating
        );
        let mut calls = Vec::new();
        let pool = pending
            .build(&db, |done, total| calls.push((done, total)))
            .await
            .expect("build");
        // 600 tuples of 11 rows, 372 to a chunk of at most 4,096 rows: two chunks.
        assert_eq!(calls.len(), 2, "{calls:?}");
        let s = study::load(&db, id).await.expect("load");
        assert_eq!(s.status, StudyStatus::Ready);
        assert_eq!(s.progress.rows_done, s.progress.rows_total);
        assert_eq!(calls.last().map(|c| c.0), Some(s.progress.rows_total));
        assert_eq!(count(&db, SLOTS, id).await, 6000);
        assert_eq!(
            count(&db, TUPLES, id).await,
            (600 + pool.controls + pool.training) as i64
        );
        assert_eq!(
            s.progress.rows_total,
            6600 + (pool.controls + pool.training) as i64
        );
    }

    #[tokio::test]
    async fn a_creation_without_progress_is_failed_and_its_rows_deleted() {
        let (db, _dir, lib) = library_db().await;
        // The process that began this creation "died" before its first main chunk.
        let pending = study::begin(&db, "s", lib, settings())
            .await
            .expect("begin");
        let id = pending.id;
        drop(pending);
        assert!(
            count(&db, TUPLES, id).await > 0,
            "controls and practice triplets"
        );
        assert!(
            recover(&db).await.expect("recover").is_empty(),
            "too recent to fail"
        );
        sqlx::query("UPDATE studies SET pool_beat = pool_beat - $2 WHERE id = $1")
            .bind(id.0)
            .bind(STALE_MS + 1000)
            .execute(&db.pool)
            .await
            .expect("age");
        assert_eq!(recover(&db).await.expect("recover"), [id]);
        let s = study::load(&db, id).await.expect("load");
        assert_eq!(s.status, StudyStatus::Failed);
        assert_eq!(s.progress.rows_done, 0);
        assert!(
            s.progress
                .error
                .as_deref()
                .unwrap_or_default()
                .contains("creation stopped"),
            "{:?}",
            s.progress.error
        );
        assert_eq!(count(&db, TUPLES, id).await, 0);
        assert!(matches!(
            s.check_open(),
            Err(crate::error::AppError::Conflict(_))
        ));
    }

    #[tokio::test]
    async fn a_creation_failed_meanwhile_stops_at_its_next_chunk() {
        let (db, _dir, lib) = library_db().await;
        let pending = study::begin(&db, "s", lib, settings())
            .await
            .expect("begin");
        let id = pending.id;
        // Another server took it for dead (a creation stalled for minutes).
        assert!(fail(&db, id, "stalled").await.expect("fail"));
        let built = pending.build(&db, |_, _| {}).await;
        assert!(
            matches!(built, Err(crate::error::AppError::Conflict(_))),
            "{built:?}"
        );
        let s = study::load(&db, id).await.expect("load");
        assert_eq!(s.status, StudyStatus::Failed, "never ready");
        assert_eq!(s.progress.error.as_deref(), Some("stalled"));
        assert_eq!(
            count(&db, TUPLES, id).await + count(&db, SLOTS, id).await,
            0
        );
    }
}
