//! One simulated worker of the answer-path benchmark: it starts HITs over HTTP, reads each
//! HIT's questions from the database (a worker who already knows which picture they will
//! click, so only the answer request is timed) and sends the answers.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use sqlx::Row;

use super::measure::Starts;
use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::store::ids::StudyId;

/// One simulated worker: its current HIT and the answers it will give.
pub(super) struct BenchWorker {
    client: reqwest::Client,
    base: String,
    db: Db,
    study: StudyId,
    /// Worker index (part of every worker id it uses).
    pub(super) index: usize,
    /// HITs started so far (each HIT is a new worker id: one assignment per worker and study).
    hits: usize,
    /// Where the start latencies go.
    starts: Starts,
    token: String,
    /// (position, choice) still to send, in order.
    pub(super) queue: std::collections::VecDeque<(i64, i64)>,
}

impl BenchWorker {
    pub(super) fn new(
        client: reqwest::Client,
        base: &str,
        db: Db,
        study: StudyId,
        index: usize,
        starts: Starts,
    ) -> Self {
        Self {
            starts,
            client,
            base: base.to_string(),
            db,
            study,
            index,
            hits: 0,
            token: String::new(),
            queue: Default::default(),
        }
    }

    /// Starts the next HIT when the current one is used up.
    pub(super) async fn ensure_hit(&mut self) -> Result<()> {
        if !self.queue.is_empty() {
            return Ok(());
        }
        self.hits += 1;
        let id = format!("bench-{}-{}", self.index, self.hits);
        let t = Instant::now();
        self.token = start_hit(&self.client, &self.base, self.study, &id).await?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        self.starts
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(ms);
        self.queue = hit_questions(&self.db, &self.token).await?.into();
        Ok(())
    }

    /// Sends the next answer of the current HIT (call [`Self::ensure_hit`] first).
    pub(super) async fn answer_next(&mut self) -> Result<()> {
        let (position, choice) = self
            .queue
            .pop_front()
            .ok_or_else(|| AppError::Internal("no question left".into()))?;
        let body = serde_json::json!({"position": position, "choice": choice});
        let resp = self
            .client
            .post(format!(
                "{}/api/v1/assignments/{}/answers",
                self.base, self.token
            ))
            .json(&body)
            .send()
            .await
            .map_err(AppError::internal)?;
        if resp.status().is_success() {
            Ok(())
        } else {
            Err(AppError::Internal(format!("answer: {}", resp.status())))
        }
    }
}

/// Counts an error, printing the first few of the run (from any worker: a failure that hits
/// only some workers must still be seen).
pub(super) fn note_error(errors: &mut usize, what: &str, e: &AppError) {
    static PRINTED: AtomicUsize = AtomicUsize::new(0);
    if PRINTED.fetch_add(1, Ordering::Relaxed) < 5 {
        eprintln!("{what} error: {e}");
    }
    *errors += 1;
}

async fn start_hit(
    client: &reqwest::Client,
    base: &str,
    study: StudyId,
    worker: &str,
) -> Result<String> {
    let resp = client
        .post(format!("{base}/api/v1/studies/{study}/start"))
        .json(&serde_json::json!({"source": "direct", "worker_id": worker}))
        .send()
        .await
        .map_err(AppError::internal)?;
    let v: serde_json::Value = resp.json().await.map_err(AppError::internal)?;
    v["token"]
        .as_str()
        .map(str::to_string)
        .ok_or_else(|| AppError::Internal(format!("start failed: {v}")))
}

async fn hit_questions(db: &Db, token: &str) -> Result<Vec<(i64, i64)>> {
    let rows = sqlx::query(
        "SELECT q.position, t.b FROM questions q JOIN tuples t ON t.id = q.tuple_id \
         JOIN assignments a ON a.id = q.assignment_id WHERE a.token = $1 ORDER BY q.position",
    )
    .bind(token)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| Ok((r.try_get("position")?, r.try_get("b")?)))
        .collect()
}
