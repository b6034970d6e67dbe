//! Creating a study: the settings and the library are checked and every triplet drawn first,
//! then the tuple pool is written in chunks of at most [`CHUNK_ROWS`] rows, one write
//! transaction each (issue 16).
//!
//! Why chunks: on SQLite every writer of the file is serialised, and the answer path (answers,
//! HIT starts, allocations) writes through the same lock. One transaction for a 100,000 × 10
//! pool (1.1 million rows) held it for ~31 s, and every worker start of the server waited that
//! long; 1,000,000 × 100 never finished and left a 258 MB WAL. A chunk holds the lock for a few
//! tens of milliseconds, and the process's write turn is FIFO ([`crate::store::db::Db::begin_write`]),
//! so the answer writer's waiting batch goes before the next chunk.
//!
//! The study row is written first with status `creating`; workers cannot start (nor is the
//! study counted as ready) until the transaction of the last chunk sets `ready`. Each chunk
//! adds its rows to `pool_done` and refreshes `pool_beat` in its own transaction, so the progress
//! shown is exact, and a creation whose process died stops refreshing it: it is then marked
//! `failed` and its rows deleted ([`super::recovery`]).

use std::ops::Range;

use rand::SeedableRng;
use rand::seq::SliceRandom;
use serde::Serialize;

use super::rows::{Block, free_block, insert_slots, insert_tuples, outside};
use super::triplets::{NewTuple, distinct_triplets, random_triplets, style_triplets};
use super::{LabelStats, StudySettings, pool_warnings, practice_pool_size, recovery};
use crate::error::{AppError, Result};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{LibraryId, StudyId, TupleId, random_token};
use crate::studies::kind::StudyKind;
use crate::studies::library;

/// Most rows (tuples and slots) written in one transaction. ~4,000 rows take 20–40 ms on
/// SQLite, the longest an answer or a HIT start waits for a chunk; smaller chunks would add a
/// commit (an fsync) per few rows.
pub const CHUNK_ROWS: usize = 4096;

/// What tuple generation produced.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct PoolSummary {
    /// Main tuples.
    pub main: usize,
    /// Slots (main tuples × R).
    pub slots: usize,
    /// Automatic control tuples.
    pub controls: usize,
    /// Training tuples.
    pub training: usize,
}

/// A study whose row, controls and practice triplets are stored, with status `creating`, and
/// whose main tuples and slots are still to be written by [`PendingPool::build`].
#[must_use = "the study stays `creating` (and is failed later) unless its pool is built"]
pub struct PendingPool {
    /// The new study.
    pub id: StudyId,
    /// What the pool will hold.
    pub summary: PoolSummary,
    /// What it lacks against the settings ([`super::pool_warnings`]).
    pub warnings: Vec<String>,
    main: Vec<NewTuple>,
    /// The main tuples' consecutive ids, and their slots' ([`free_block`]).
    ids: Range<i64>,
    slot_ids: Range<i64>,
    replication: u32,
    /// Rows written and to write in all (controls and practice triplets included).
    done: i64,
    total: i64,
}

/// Creates a study over `library` and writes its whole tuple pool before returning (the
/// command line, the demo, the benchmark); the server builds it in the background instead
/// ([`PendingPool::spawn`]).
pub async fn create(
    db: &Db,
    name: &str,
    library: LibraryId,
    settings: StudySettings,
) -> Result<(StudyId, PoolSummary)> {
    let pending = begin(db, name, library, settings).await?;
    let id = pending.id;
    Ok((id, pending.build(db, |_, _| {}).await?))
}

/// How long a create request of the server waits for the pool before it answers with the
/// progress instead (the pool is written on regardless).
pub const CREATE_WAIT: std::time::Duration = std::time::Duration::from_secs(2);

/// A study the server created: its pool may still be being written.
#[derive(Debug, Clone)]
pub struct Started {
    /// The study.
    pub id: StudyId,
    /// What its pool holds (or will).
    pub summary: PoolSummary,
    /// What the pool lacks against the settings.
    pub warnings: Vec<String>,
    /// The pool was complete within `wait`.
    pub ready: bool,
}

/// [`begin`], then the pool written on a task of its own ([`PendingPool::spawn`]), waiting up
/// to `wait` for it: small studies are complete when this returns, large ones go on in the
/// background (the study page and `GET /api/v1/admin/studies/ID` show their progress). An error
/// of the pool within `wait` is returned (the study is then `failed`).
pub async fn start_creation(
    db: &Db,
    name: &str,
    library: LibraryId,
    settings: StudySettings,
    wait: std::time::Duration,
) -> Result<Started> {
    let pending = begin(db, name, library, settings).await?;
    let (id, summary, warnings) = (
        pending.id,
        pending.summary.clone(),
        pending.warnings.clone(),
    );
    let mut task = pending.spawn(db.clone());
    let ready = match tokio::time::timeout(wait, &mut task).await {
        Ok(built) => {
            built.map_err(AppError::internal)??;
            true
        }
        Err(_) => false,
    };
    Ok(Started {
        id,
        summary,
        warnings,
        ready,
    })
}

/// A tuple pool drawn before anything is stored: the main tuples (each replicated R times in
/// slots), the hidden controls and the practice tuples (of both, `b` is the expected answer),
/// and what the pool lacks against the settings. Each study kind draws its own
/// (triplets here, composition pairs in [`crate::studies::rating`]); storing it is shared.
#[derive(Debug, Clone, Default)]
pub struct DrawnPool {
    /// Main tuples.
    pub main: Vec<NewTuple>,
    /// Hidden controls.
    pub controls: Vec<NewTuple>,
    /// Practice tuples (the training gate and the worked example).
    pub training: Vec<NewTuple>,
    /// What the pool lacks against the settings.
    pub warnings: Vec<String>,
}

fn check_name(name: &str) -> Result<&str> {
    let name = name.trim();
    if name.is_empty() || name.len() > 200 {
        return Err(AppError::BadRequest("name: 1-200 characters".into()));
    }
    Ok(name)
}

/// Checks the settings, the name and the library, draws every triplet and stores the study
/// (status `creating`) with its controls and practice triplets in one transaction; the main
/// tuples follow in [`PendingPool::build`]. Refuses more tuples than the library has distinct
/// triplets, and more slots than [`super::MAX_SLOTS`].
pub async fn begin(
    db: &Db,
    name: &str,
    library: LibraryId,
    settings: StudySettings,
) -> Result<PendingPool> {
    settings.validate()?;
    check_name(name)?;
    let items = library::list_items(db, library).await?;
    if items.len() < 3 {
        return Err(AppError::BadRequest(format!(
            "the library has {} items; a study needs at least 3",
            items.len()
        )));
    }
    let distinct = distinct_triplets(items.len());
    if u128::from(settings.tuples) > distinct {
        return Err(AppError::BadRequest(format!(
            "tuples: {} is more than the {distinct} distinct triplets the library's {} items \
             make (n·(n−1)·(n−2)/2); lower tuples or add items",
            settings.tuples,
            items.len()
        )));
    }
    let features = library::item_features(db, library).await?;
    let ids: Vec<_> = items.iter().map(|i| i.id).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(settings.seed);
    let main = random_triplets(&ids, settings.tuples as usize, &mut rng);
    let control_count = (settings.controls_per_hit as usize * 20).max(50);
    let practice_count = practice_pool_size(&settings);
    let mut labelled = style_triplets(&items, &features, control_count + practice_count, &mut rng);
    labelled.shuffle(&mut rng);
    // Practice first: a small library that cannot fill both pools still gets its practice.
    let training: Vec<NewTuple> = labelled.iter().take(practice_count).copied().collect();
    let controls: Vec<NewTuple> = labelled.iter().skip(practice_count).copied().collect();
    let warnings = pool_warnings(
        &settings,
        controls.len(),
        training.len(),
        &LabelStats::of(&items),
    );
    let pool = DrawnPool {
        main,
        controls,
        training,
        warnings,
    };
    store(db, name, library, StudyKind::Triplet, settings, pool).await
}

/// Stores a study of `kind` with a pool its kind drew: the study row (status `creating`), its
/// controls and practice tuples in one transaction; the main tuples follow in
/// [`PendingPool::build`], as for every kind.
pub async fn begin_drawn(
    db: &Db,
    name: &str,
    library: LibraryId,
    kind: StudyKind,
    settings: StudySettings,
    pool: DrawnPool,
) -> Result<PendingPool> {
    settings.validate()?;
    check_name(name)?;
    store(db, name, library, kind, settings, pool).await
}

async fn store(
    db: &Db,
    name: &str,
    library: LibraryId,
    kind: StudyKind,
    settings: StudySettings,
    pool: DrawnPool,
) -> Result<PendingPool> {
    let name = check_name(name)?;
    let DrawnPool {
        main,
        controls,
        training,
        warnings,
    } = pool;
    let replication = settings.replication;
    let small = (controls.len() + training.len()) as i64;
    let total = small + main.len() as i64 * (1 + i64::from(replication));

    let id = StudyId::generate();
    let mut tx = db.begin_write().await?;
    sqlx::query(
        "INSERT INTO studies (id, name, kind, library_id, settings, secret, created_at, status, \
         pool_done, pool_total, pool_beat) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, 'creating', $8, $9, $10)",
    )
    .bind(id.0)
    .bind(name)
    .bind(kind.as_str())
    .bind(library.0)
    .bind(serde_json::to_string(&settings).map_err(AppError::internal)?)
    .bind(format!("{}{}", random_token(), random_token()))
    .bind(now_ms())
    .bind(small)
    .bind(total)
    .bind(now_ms())
    .execute(&mut *tx)
    .await?;
    let block = free_block(&mut tx, Block::Tuples, main.len()).await?;
    let slot_ids = free_block(&mut tx, Block::Slots, main.len() * replication as usize).await?;
    for (kind, tuples) in [("control", &controls), ("training", &training)] {
        let rows: Vec<(TupleId, i64, NewTuple)> = tuples
            .iter()
            .enumerate()
            .map(|(seq, t)| (outside(&block), seq as i64, *t))
            .collect();
        insert_tuples(&mut tx, id, kind, &rows).await?;
    }
    tx.commit().await?;
    Ok(PendingPool {
        id,
        warnings,
        summary: PoolSummary {
            main: main.len(),
            slots: main.len() * replication as usize,
            controls: controls.len(),
            training: training.len(),
        },
        main,
        ids: block,
        slot_ids,
        replication,
        done: small,
        total,
    })
}

impl PendingPool {
    /// Rows written so far and in all.
    pub fn progress(&self) -> (i64, i64) {
        (self.done, self.total)
    }

    /// Writes the main tuples and their slots in chunks, calling `progress(done, total)` after
    /// each; the last chunk's transaction makes the study `ready`. On an error the study is
    /// marked `failed` with the reason and its rows are deleted (in chunks too).
    pub async fn build(
        mut self,
        db: &Db,
        mut progress: impl FnMut(i64, i64),
    ) -> Result<PoolSummary> {
        match self.write_main(db, &mut progress).await {
            Ok(()) => Ok(self.summary),
            Err(e) => {
                let why = format!(
                    "the tuple pool could not be written ({} of {} rows were): {e}",
                    self.done, self.total
                );
                if let Err(also) = recovery::fail(db, self.id, &why).await {
                    eprintln!("study {}: cannot record the failure: {also}", self.id);
                }
                if let Err(also) = recovery::discard(db, self.id).await {
                    eprintln!("study {}: cannot delete the partial pool: {also}", self.id);
                }
                Err(e)
            }
        }
    }

    /// [`PendingPool::build`] on a task of its own (the server: the request that created the
    /// study does not wait for the whole pool).
    pub fn spawn(self, db: Db) -> tokio::task::JoinHandle<Result<PoolSummary>> {
        tokio::spawn(async move {
            let id = self.id;
            let built = self.build(&db, |_, _| {}).await;
            if let Err(e) = &built {
                eprintln!("study {id}: creation failed: {e}");
            }
            built
        })
    }

    async fn write_main(&mut self, db: &Db, progress: &mut impl FnMut(i64, i64)) -> Result<()> {
        let per_row = 1 + self.replication as usize;
        let per_chunk = (CHUNK_ROWS / per_row).max(1);
        let chunks = self.main.len().div_ceil(per_chunk);
        for k in 0..chunks {
            let seqs = k * per_chunk..((k + 1) * per_chunk).min(self.main.len());
            let rows = (seqs.len() * per_row) as i64;
            let mut tx = db.begin_write().await?;
            // First, so that a creation marked failed meanwhile (no progress for too long)
            // stops instead of completing a study nobody watches over.
            let alive = sqlx::query(
                "UPDATE studies SET pool_done = pool_done + $2, pool_beat = $3 \
                 WHERE id = $1 AND status = 'creating'",
            )
            .bind(self.id.0)
            .bind(rows)
            .bind(now_ms())
            .execute(&mut *tx)
            .await?;
            if alive.rows_affected() == 0 {
                return Err(AppError::Conflict(format!(
                    "study {}: the creation was stopped (marked failed after {} s without \
                     progress)",
                    self.id,
                    recovery::STALE_MS / 1000
                )));
            }
            let tuples: Vec<(TupleId, i64, NewTuple)> = seqs
                .clone()
                .map(|seq| {
                    (
                        TupleId(self.ids.start + seq as i64),
                        seq as i64,
                        self.main[seq],
                    )
                })
                .collect();
            insert_tuples(&mut tx, self.id, "main", &tuples).await?;
            let slots = insert_slots(
                &mut tx,
                self.id,
                seqs.clone(),
                self.slot_ids.start,
                self.replication,
            )
            .await?;
            if slots != (seqs.len() * self.replication as usize) as u64 {
                return Err(AppError::Internal(format!(
                    "{slots} slots written for {} tuples × {}",
                    seqs.len(),
                    self.replication
                )));
            }
            if k + 1 == chunks {
                sqlx::query("UPDATE studies SET status = 'ready' WHERE id = $1")
                    .bind(self.id.0)
                    .execute(&mut *tx)
                    .await?;
            }
            tx.commit().await?;
            self.done += rows;
            progress(self.done, self.total);
            // The write turn is FIFO already; this lets the runtime serve the requests that
            // waited on this task's thread.
            tokio::task::yield_now().await;
        }
        Ok(())
    }
}
