//! Group commit of answers. Every answer is one conditional `UPDATE questions … WHERE choice IS
//! NULL`; committed one by one, SQLite's single writer (one WAL fsync per commit) caps the answer
//! path near 1,500/s on these machines whatever the concurrency. Here the answers that arrive
//! while a commit is in flight are written together in the next transaction, and each caller is
//! answered only after that transaction has committed — so an acknowledged answer is as durable
//! as before, nothing is acknowledged from memory, and a crash loses only unacknowledged
//! answers (the client retries; answers are idempotent).
//!
//! Each statement's outcome (rows affected) is returned to its own caller, so the conditional
//! "first answer wins" logic of [`crate::flow::answer`] is unchanged. A database error aborts the
//! whole batch and every caller in it gets the error (none was acknowledged).

use sqlx::AnyPool;
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

struct Pending {
    write: AnswerWrite,
    reply: oneshot::Sender<Result<u64>>,
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

    /// Stores one answer; returns the rows the conditional `UPDATE` changed (0: the question
    /// already had an answer) once the transaction holding it has committed.
    pub async fn write(&self, write: AnswerWrite) -> Result<u64> {
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
            Ok(counts) => {
                for (p, n) in batch.drain(..).zip(counts) {
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

async fn write_batch(writer: &AnyPool, backend: Backend, batch: &[Pending]) -> Result<Vec<u64>> {
    let mut tx = match backend {
        Backend::Sqlite => writer.begin_with("BEGIN IMMEDIATE").await?,
        Backend::Postgres => writer.begin().await?,
    };
    let at = now_ms();
    let mut counts = Vec::with_capacity(batch.len());
    for p in batch {
        let w = &p.write;
        let done = sqlx::query(
            "UPDATE questions SET choice = $1, answered_at = $2, elapsed_ms = $3 \
             WHERE assignment_id = $4 AND position = $5 AND choice IS NULL",
        )
        .bind(w.choice)
        .bind(at)
        .bind(w.elapsed_ms)
        .bind(w.assignment)
        .bind(w.position)
        .execute(&mut *tx)
        .await?;
        counts.push(done.rows_affected());
    }
    tx.commit().await?;
    Ok(counts)
}
