//! Group commit of answers. Every answer is one conditional `UPDATE questions … WHERE choice IS
//! NULL`; committed one by one, SQLite's single writer (one WAL fsync per commit) caps the answer
//! path near 1,500/s on these machines whatever the concurrency. Here the answers that arrive
//! while a commit is in flight are written together in the next transaction, and each caller is
//! answered only after that transaction has committed — so an acknowledged answer is as durable
//! as before, nothing is acknowledged from memory, and a crash loses only unacknowledged
//! answers (the client retries; answers are idempotent).
//!
//! Each statement's outcome is returned to its own caller, so the conditional "first answer
//! wins" logic of [`crate::flow::answer`] is unchanged. A database error aborts the whole batch
//! and every caller in it gets the error (none was acknowledged).
//!
//! On SQLite the same statement also returns the assignment's next unanswered position
//! (`RETURNING` with a subquery), so the answer path needs no read after the commit. That value
//! is exact there: every writer of the file is serialised (`BEGIN IMMEDIATE`), so no other
//! answer of the assignment can commit between this statement and the commit. On PostgreSQL,
//! where several servers write concurrently under READ COMMITTED, a statement's snapshot may
//! miss another server's concurrent answer of the same assignment (both would then see the
//! other's question as open and neither would complete the HIT), so the caller reads it after
//! the commit instead ([`Next::ReadAfterCommit`]).

use sqlx::{AnyPool, Row};
use tokio::sync::{mpsc, oneshot};

use crate::db::{Backend, now_ms};
use crate::error::{AppError, Result};

/// Most answers written in one transaction (bounds the time the writer is held).
pub const MAX_BATCH: usize = 256;

/// One answer to store.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AnswerWrite {
    /// Assignment.
    pub assignment: i64,
    /// Question position.
    pub position: i64,
    /// `b` or `c`.
    pub choice: &'static str,
    /// Client-reported time on the question.
    pub elapsed_ms: Option<i64>,
}

/// What happened to one answer, once its transaction has committed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Written {
    /// This answer was stored (the question had none).
    Stored(Next),
    /// The question already had an answer (this one or another); nothing was changed.
    AlreadyAnswered,
}

/// The assignment's next unanswered position after a stored answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Next {
    /// Read in the writing transaction, exact (SQLite); `None`: every question is answered.
    Known(Option<i64>),
    /// Not read (PostgreSQL): read it after the commit.
    ReadAfterCommit,
}

struct Pending {
    write: AnswerWrite,
    reply: oneshot::Sender<Result<Written>>,
}

/// Handle to the batching task (cheap to clone).
#[derive(Debug, Clone)]
pub struct AnswerWriter {
    queue: mpsc::UnboundedSender<Pending>,
}

impl AnswerWriter {
    /// Starts the batching task on the current tokio runtime, writing through `writer`.
    pub fn start(writer: AnyPool, backend: Backend) -> Self {
        let (queue, rx) = mpsc::unbounded_channel();
        tokio::spawn(run(writer, backend, rx));
        Self { queue }
    }

    /// Stores one answer; returns what the conditional `UPDATE` did once the transaction
    /// holding it has committed.
    pub async fn write(&self, write: AnswerWrite) -> Result<Written> {
        let (reply, answer) = oneshot::channel();
        self.queue
            .send(Pending { write, reply })
            .map_err(|_| AppError::Internal("the answer writer has stopped".into()))?;
        answer
            .await
            .map_err(|_| AppError::Internal("the answer writer dropped a request".into()))?
    }
}

async fn run(writer: AnyPool, backend: Backend, mut rx: mpsc::UnboundedReceiver<Pending>) {
    let mut batch = Vec::with_capacity(MAX_BATCH);
    while let Some(first) = rx.recv().await {
        batch.push(first);
        while batch.len() < MAX_BATCH {
            match rx.try_recv() {
                Ok(p) => batch.push(p),
                Err(_) => break,
            }
        }
        match write_batch(&writer, backend, &batch).await {
            Ok(outcomes) => {
                for (p, n) in batch.drain(..).zip(outcomes) {
                    // The caller may have gone (client disconnected): nothing to do.
                    let _ = p.reply.send(Ok(n));
                }
            }
            Err(e) => {
                let why = e.to_string();
                for p in batch.drain(..) {
                    let _ = p.reply.send(Err(AppError::Internal(format!(
                        "storing the answer failed: {why}"
                    ))));
                }
            }
        }
    }
}

/// Stores a question's answer if it has none. The SQLite form also returns the next open
/// position of the assignment (see the module comment for why only there).
const UPDATE_SQLITE: &str = "UPDATE questions SET choice = $1, answered_at = $2, elapsed_ms = $3 \
     WHERE assignment_id = $4 AND position = $5 AND choice IS NULL \
     RETURNING (SELECT MIN(n.position) FROM questions n WHERE n.assignment_id = $4 \
       AND n.choice IS NULL AND n.position <> $5) AS next";
const UPDATE_POSTGRES: &str = "UPDATE questions SET choice = $1, answered_at = $2, \
     elapsed_ms = $3 WHERE assignment_id = $4 AND position = $5 AND choice IS NULL";

async fn write_batch(
    writer: &AnyPool,
    backend: Backend,
    batch: &[Pending],
) -> Result<Vec<Written>> {
    let mut tx = match backend {
        Backend::Sqlite => writer.begin_with("BEGIN IMMEDIATE").await?,
        Backend::Postgres => writer.begin().await?,
    };
    let at = now_ms();
    let mut outcomes = Vec::with_capacity(batch.len());
    for p in batch {
        let w = &p.write;
        let sql = match backend {
            Backend::Sqlite => UPDATE_SQLITE,
            Backend::Postgres => UPDATE_POSTGRES,
        };
        let query = sqlx::query(sql)
            .bind(w.choice)
            .bind(at)
            .bind(w.elapsed_ms)
            .bind(w.assignment)
            .bind(w.position);
        let outcome = match backend {
            Backend::Sqlite => match query.fetch_optional(&mut *tx).await? {
                Some(row) => Written::Stored(Next::Known(row.try_get("next")?)),
                None => Written::AlreadyAnswered,
            },
            Backend::Postgres => match query.execute(&mut *tx).await?.rows_affected() {
                0 => Written::AlreadyAnswered,
                _ => Written::Stored(Next::ReadAfterCommit),
            },
        };
        outcomes.push(outcome);
    }
    tx.commit().await?;
    Ok(outcomes)
}
