//! The PostgreSQL writer: the conditional `UPDATE`s of a batch in one transaction through the
//! sqlx pool (see the module comment of [`super`] for why only the `UPDATE` is batched there).

use std::collections::VecDeque;

use sqlx::{AnyConnection, AnyPool};
use tokio::sync::{mpsc, oneshot};

use super::{AnswerWrite, Batch, Pending, STORE_ANSWER, Written, wrong_backend};
use crate::error::{AppError, Result};

/// Writes batches until every sender is gone.
pub(super) async fn run(pool: AnyPool, mut rx: mpsc::UnboundedReceiver<Pending>) {
    let mut deferred = VecDeque::new();
    loop {
        let mut batch = Batch::with_deferred(&mut deferred);
        if batch.is_empty() {
            match rx.recv().await {
                Some(p) => batch.push(p, &mut deferred),
                None => break,
            }
        }
        batch.fill(&mut rx, &mut deferred);
        run_batch(&pool, batch).await;
    }
}

/// Runs one batch in one transaction and answers every caller after the commit (or with the
/// error that aborted it: then none of them was stored).
async fn run_batch(pool: &AnyPool, batch: Batch) {
    let Batch {
        writes,
        batched,
        jobs,
    } = batch;
    // SQLite's requests never come here (their callers route by backend).
    for entry in batched {
        entry.refuse(wrong_backend("a batched request"));
    }
    if !jobs.is_empty() {
        eprintln!("error: {}", wrong_backend("a job"));
    }
    if writes.is_empty() {
        return;
    }
    let outcome: Result<Vec<Written>> = async {
        let mut tx = pool.begin().await?;
        let written = write_batch(&mut tx, &writes).await?;
        tx.commit().await?;
        Ok(written)
    }
    .await;
    match outcome {
        Ok(written) => {
            for ((_, reply), n) in writes.into_iter().zip(written) {
                // The caller may have gone (client disconnected): nothing to do.
                let _ = reply.send(Ok(n));
            }
        }
        Err(e) => {
            let why = e.to_string();
            for (_, reply) in writes {
                let _ = reply.send(Err(AppError::Internal(format!(
                    "storing the answer failed: {why}"
                ))));
            }
        }
    }
}

async fn write_batch(
    conn: &mut AnyConnection,
    batch: &[(AnswerWrite, oneshot::Sender<Result<Written>>)],
) -> Result<Vec<Written>> {
    let at = crate::store::db::now_ms();
    let mut outcomes = Vec::with_capacity(batch.len());
    for (w, _) in batch {
        let done = sqlx::query(STORE_ANSWER)
            .bind(w.choice)
            .bind(at)
            .bind(w.elapsed_ms)
            .bind(w.assignment)
            .bind(w.position)
            .execute(&mut *conn)
            .await?;
        outcomes.push(match done.rows_affected() {
            0 => Written::AlreadyAnswered,
            _ => Written::Stored,
        });
    }
    Ok(outcomes)
}
