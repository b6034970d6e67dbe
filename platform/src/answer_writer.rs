//! Group commit of answers. Every answer is a conditional `UPDATE questions … WHERE choice IS
//! NULL`; committed one by one, SQLite's single writer (one WAL fsync per commit) caps the answer
//! path near 1,500/s on these machines whatever the concurrency. Here the answers that arrive
//! while a commit is in flight are written together in the next transaction, and each caller is
//! answered only after that transaction has committed — so an acknowledged answer is as durable
//! as before, nothing is acknowledged from memory, and a crash loses only unacknowledged
//! answers (the client retries; answers are idempotent). A database error aborts the whole batch
//! and every caller in it gets the error (none was acknowledged).
//!
//! On SQLite an answer is handed over as the worker sent it ([`AnswerWriter::submit`]) and
//! everything happens inside the writer's `BEGIN IMMEDIATE` transaction, for the whole batch at
//! once: one read of every answer's assignment and question (`json_each` over a JSON array
//! bound as one parameter), the checks of [`crate::flow::answer`] in Rust, one `UPDATE … FROM
//! json_each(…)` of the answers to store, one read of each assignment's next open position,
//! and the completion of every assignment left without one. What is read is exact: every
//! writer of the file is serialised, so nothing can change between the read and the write, and
//! two answers of one question in the same batch are decided in arrival order (the first is
//! stored, the second is a duplicate or a conflict). The answer path thus needs no read of its
//! own before or after the write, and a batch costs five statements, not two per answer.
//!
//! Other SQLite writes that must not wait for their own fsync — HIT allocations — run as jobs
//! ([`AnswerWriter::job`]) in the same transaction, each in a savepoint so that its failure
//! rolls back only its own statements; their callers too are answered after the commit.
//!
//! On PostgreSQL, where several servers write concurrently under READ COMMITTED, a statement's
//! snapshot may miss another server's concurrent answer of the same assignment (both would then
//! see the other's question as open and neither would complete the HIT), so there the caller
//! reads its target before and the next position after the commit, and hands over only the
//! conditional `UPDATE` ([`AnswerWriter::write`], [`Next::ReadAfterCommit`]).

use std::collections::{HashMap, VecDeque};
use std::future::Future;
use std::pin::Pin;

use sqlx::{AnyConnection, AnyPool, Connection, Row};
use tokio::sync::{mpsc, oneshot};

use crate::db::{Backend, json_array_row, now_ms};
use crate::error::{AppError, Result};
use crate::flow::{AnswerTarget, TargetQuestion};
use crate::ids::{AssignmentId, StudyId};

/// Most answers written in one transaction (bounds the time the writer is held).
pub const MAX_BATCH: usize = 256;

/// Most jobs ([`AnswerWriter::job`]) run in one transaction next to the answers (more wait for
/// the next one, without holding up the answers that arrive after them).
pub const MAX_JOBS: usize = 8;

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

/// One answer as the worker sent it (SQLite, [`AnswerWriter::submit`]): looked up, checked and
/// stored inside the writer's transaction.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AnswerSubmit {
    /// The assignment's bearer token (already checked to be 32 hex digits).
    pub token: String,
    /// Question position.
    pub position: i64,
    /// The chosen item id.
    pub choice: i64,
    /// Client-reported time on the question.
    pub elapsed_ms: Option<i64>,
}

/// What a submitted answer did, once its transaction has committed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Submitted {
    /// The assignment.
    pub assignment: AssignmentId,
    /// Its study.
    pub study: StudyId,
    /// Its status when the answer was read (`active` or `completed`); an `active` one without
    /// an open question left is completed in the answer's transaction.
    pub status: String,
    /// The same answer had been stored before (idempotent retry).
    pub duplicate: bool,
    /// The question asks for reasons.
    pub ask_reasons: bool,
    /// The next unanswered position after the commit (exact: read in the same transaction).
    pub next: Option<i64>,
}

/// A future borrowing the writer's connection.
pub type ConnFuture<'c, T> = Pin<Box<dyn Future<Output = T> + Send + 'c>>;

/// Sends a job's outcome to its caller once the transaction's fate is known (`Err`: the commit
/// failed, with why).
type Deliver = Box<dyn FnOnce(std::result::Result<(), String>) + Send>;

/// A job erased to: run inside the transaction (within its own savepoint), report whether it
/// succeeded, and what to deliver after the commit.
type Job = Box<dyn for<'c> FnOnce(&'c mut AnyConnection) -> ConnFuture<'c, (bool, Deliver)> + Send>;

enum Pending {
    Write(AnswerWrite, oneshot::Sender<Result<Written>>),
    Submit(AnswerSubmit, oneshot::Sender<Result<Submitted>>),
    Job(Job),
}

/// Handle to the batching task (cheap to clone).
#[derive(Clone)]
pub struct AnswerWriter {
    queue: mpsc::UnboundedSender<Pending>,
}

impl std::fmt::Debug for AnswerWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AnswerWriter").finish_non_exhaustive()
    }
}

fn stopped() -> AppError {
    AppError::Internal("the answer writer has stopped".into())
}

fn dropped() -> AppError {
    AppError::Internal("the answer writer dropped a request".into())
}

impl AnswerWriter {
    /// Starts the batching task, writing through `writer`, on a thread of its own with a
    /// single-threaded runtime.
    ///
    /// Why a thread: a batch awaits its connection about twenty times (begin, five statements,
    /// each completion's and each job's statements, commit). On the server's runtime every one
    /// of those wake-ups queued behind the HTTP tasks, and the single writer, which bounds the
    /// answer rate, waited to be polled instead of writing (`platform bench`, 200 workers:
    /// +8% answers/s on its own thread).
    pub fn start(writer: AnyPool, backend: Backend) -> Result<Self> {
        let (queue, rx) = mpsc::unbounded_channel();
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(AppError::internal)?;
        std::thread::Builder::new()
            .name("answer-writer".into())
            .spawn(move || runtime.block_on(run(writer, backend, rx)))
            .map_err(AppError::internal)?;
        Ok(Self { queue })
    }

    /// Stores one answer; returns what the conditional `UPDATE` did once the transaction
    /// holding it has committed.
    pub async fn write(&self, write: AnswerWrite) -> Result<Written> {
        let (reply, answer) = oneshot::channel();
        self.queue
            .send(Pending::Write(write, reply))
            .map_err(|_| stopped())?;
        answer.await.map_err(|_| dropped())?
    }

    /// SQLite: looks the answer's assignment and question up, checks it like
    /// [`AnswerTarget::choose`] and stores it if the question has no answer yet, all inside the
    /// writer's transaction (one read, one `UPDATE` and one next-position read for the whole
    /// batch); replies once that transaction has committed. Exact because every SQLite writer
    /// is serialised (`BEGIN IMMEDIATE`); not for PostgreSQL (see the module comment).
    pub async fn submit(&self, submit: AnswerSubmit) -> Result<Submitted> {
        let (reply, answer) = oneshot::channel();
        self.queue
            .send(Pending::Submit(submit, reply))
            .map_err(|_| stopped())?;
        answer.await.map_err(|_| dropped())?
    }

    /// Runs `f` inside the writer's next transaction, in a savepoint of its own (an error rolls
    /// back `f`'s statements only), and returns its result once that transaction has
    /// committed: a write that shares the answers' group commit (one fsync on SQLite) instead
    /// of taking turns with them. `f` must not begin or commit a transaction itself.
    pub async fn job<T, F>(&self, f: F) -> Result<T>
    where
        T: Send + 'static,
        F: for<'c> FnOnce(&'c mut AnyConnection) -> ConnFuture<'c, Result<T>> + Send + 'static,
    {
        let (reply, answer) = oneshot::channel::<Result<T>>();
        let job: Job = Box::new(move |conn: &mut AnyConnection| {
            Box::pin(async move {
                let out = f(conn).await;
                let ok = out.is_ok();
                let deliver: Deliver = Box::new(move |committed| {
                    let _ = reply.send(match committed {
                        Ok(()) => out,
                        Err(why) => Err(AppError::Internal(format!(
                            "the write transaction failed: {why}"
                        ))),
                    });
                });
                (ok, deliver)
            })
        });
        self.queue.send(Pending::Job(job)).map_err(|_| stopped())?;
        answer.await.map_err(|_| dropped())?
    }
}

/// One batch, split by kind.
#[derive(Default)]
struct Batch {
    writes: Vec<(AnswerWrite, oneshot::Sender<Result<Written>>)>,
    submits: Vec<(AnswerSubmit, oneshot::Sender<Result<Submitted>>)>,
    jobs: Vec<Job>,
}

impl Batch {
    fn len(&self) -> usize {
        self.writes.len() + self.submits.len()
    }

    /// Adds `p`; a job beyond [`MAX_JOBS`] waits in `deferred` for a later batch, so answers
    /// never queue behind a backlog of jobs (HIT starts arriving together).
    fn push(&mut self, p: Pending, deferred: &mut VecDeque<Job>) {
        match p {
            Pending::Write(w, r) => self.writes.push((w, r)),
            Pending::Submit(s, r) => self.submits.push((s, r)),
            Pending::Job(j) if self.jobs.len() < MAX_JOBS => self.jobs.push(j),
            Pending::Job(j) => deferred.push_back(j),
        }
    }

    fn is_empty(&self) -> bool {
        self.len() == 0 && self.jobs.is_empty()
    }
}

async fn run(writer: AnyPool, backend: Backend, mut rx: mpsc::UnboundedReceiver<Pending>) {
    let mut deferred: VecDeque<Job> = VecDeque::new();
    loop {
        let mut batch = Batch::default();
        // Jobs deferred from earlier batches first, in arrival order.
        while batch.jobs.len() < MAX_JOBS {
            match deferred.pop_front() {
                Some(j) => batch.jobs.push(j),
                None => break,
            }
        }
        if batch.is_empty() {
            match rx.recv().await {
                Some(p) => batch.push(p, &mut deferred),
                None => break,
            }
        }
        while batch.len() < MAX_BATCH {
            match rx.try_recv() {
                Ok(p) => batch.push(p, &mut deferred),
                Err(_) => break,
            }
        }
        run_batch(&writer, backend, batch).await;
    }
}

/// Runs one batch in one transaction and answers every caller after the commit (or with the
/// error that aborted it: then none of them was stored).
async fn run_batch(writer: &AnyPool, backend: Backend, batch: Batch) {
    let Batch {
        writes,
        submits,
        jobs,
    } = batch;
    let mut delivers: Vec<Deliver> = Vec::with_capacity(jobs.len());
    let outcome: Result<(Vec<Written>, Vec<Result<Submitted>>)> = async {
        let mut tx = match backend {
            Backend::Sqlite => writer.begin_with("BEGIN IMMEDIATE").await?,
            Backend::Postgres => writer.begin().await?,
        };
        let written = write_batch(&mut tx, backend, &writes).await?;
        let submitted = submit_batch(&mut tx, &submits).await?;
        for job in jobs {
            let mut savepoint = Connection::begin(&mut *tx).await?;
            let (ok, deliver) = job(&mut savepoint).await;
            delivers.push(deliver);
            if ok {
                savepoint.commit().await?;
            } else {
                savepoint.rollback().await?;
            }
        }
        tx.commit().await?;
        Ok((written, submitted))
    }
    .await;
    match outcome {
        Ok((written, submitted)) => {
            for ((_, reply), n) in writes.into_iter().zip(written) {
                // The caller may have gone (client disconnected): nothing to do.
                let _ = reply.send(Ok(n));
            }
            for ((_, reply), s) in submits.into_iter().zip(submitted) {
                let _ = reply.send(s);
            }
            for deliver in delivers {
                deliver(Ok(()));
            }
        }
        Err(e) => {
            let why = e.to_string();
            let failed = || AppError::Internal(format!("storing the answer failed: {why}"));
            for (_, reply) in writes {
                let _ = reply.send(Err(failed()));
            }
            for (_, reply) in submits {
                let _ = reply.send(Err(failed()));
            }
            for deliver in delivers {
                deliver(Err(why.clone()));
            }
        }
    }
}

// The batch's reads return one row each: a JSON array with a row per answer or assignment,
// built by `json_group_array`. sqlx hands every result row from the connection's thread to the
// writer through a channel, and each row could wake the writer: three statements of ~75 rows
// each made ~225 hand-offs per batch, against 3 now.

/// The assignment and question of every submitted answer (SQLite, one statement for the
/// batch): `$1` is a JSON array of `[token, position]`; the result one JSON array of
/// `[k, assignment, study, status, position, choice, ask_reasons, b, c]`, `k` the index into
/// `$1` (position and after are null when the assignment has no such question).
const SUBMIT_READ: &str = "SELECT json_group_array(json_array(j.key, a.id, a.study_id, \
     a.status, q.position, q.choice, q.ask_reasons, t.b, t.c)) AS rows \
     FROM json_each($1) j \
     JOIN assignments a ON a.token = j.value ->> 0 \
     LEFT JOIN questions q ON q.assignment_id = a.id AND q.position = j.value ->> 1 \
     LEFT JOIN tuples t ON t.id = q.tuple_id";

/// One row of [`SUBMIT_READ`].
type ReadRow = (
    usize,
    i64,
    i64,
    String,
    Option<i64>,
    Option<String>,
    Option<i64>,
    Option<i64>,
    Option<i64>,
);

/// Stores the answers of `$1` (a JSON array of `[assignment, position, choice, elapsed_ms]`)
/// whose questions have none.
const SUBMIT_UPDATE: &str = "UPDATE questions SET choice = j.value ->> 2, answered_at = $2, \
     elapsed_ms = j.value ->> 3 \
     FROM json_each($1) j \
     WHERE questions.assignment_id = j.value ->> 0 AND questions.position = j.value ->> 1 \
       AND questions.choice IS NULL";

/// The first open position of each assignment of `$1` (a JSON array of ids) that has one, as
/// one JSON array of `[assignment, position]`.
const SUBMIT_NEXT: &str = "SELECT json_group_array(json_array(a, p)) AS rows FROM \
     (SELECT assignment_id AS a, MIN(position) AS p FROM questions \
      WHERE assignment_id IN (SELECT value FROM json_each($1)) AND choice IS NULL \
      GROUP BY assignment_id)";

/// What one submitted answer resolved to before the `UPDATE`.
enum Plan {
    /// Store it (`b` or `c`).
    Store,
    /// Already stored with the same choice.
    Duplicate,
}

/// The SQLite batch of [`AnswerWriter::submit`]: one read, one `UPDATE` and one next-position
/// read for all answers, inside the caller's `BEGIN IMMEDIATE` transaction (so what is read is
/// what is written over). Two answers of the same question in one batch: the first is stored,
/// the second is a duplicate (same choice) or a conflict, exactly as if they had come one
/// after the other.
async fn submit_batch(
    conn: &mut AnyConnection,
    submits: &[(AnswerSubmit, oneshot::Sender<Result<Submitted>>)],
) -> Result<Vec<Result<Submitted>>> {
    if submits.is_empty() {
        return Ok(Vec::new());
    }
    let keys: Vec<(&str, i64)> = submits
        .iter()
        .map(|(s, _)| (s.token.as_str(), s.position))
        .collect();
    let keys = serde_json::to_string(&keys).map_err(AppError::internal)?;
    let rows: Vec<ReadRow> = json_array_row(conn, sqlx::query(SUBMIT_READ).bind(keys)).await?;
    let mut targets: Vec<Option<AnswerTarget>> = (0..submits.len()).map(|_| None).collect();
    for (k, assignment, study, status, position, choice, ask_reasons, b, c) in rows {
        let slot = targets
            .get_mut(k)
            .ok_or_else(|| AppError::Internal("batch read: key out of range".into()))?;
        let question = match (position, b, c) {
            (Some(_), Some(b), Some(c)) => Some(TargetQuestion {
                b,
                c,
                ask_reasons: ask_reasons.unwrap_or(0) != 0,
                choice,
            }),
            _ => None,
        };
        *slot = Some(AnswerTarget {
            assignment: AssignmentId(assignment),
            study: StudyId(study),
            status,
            question,
        });
    }
    // Decide each answer in arrival order; `planned` holds this batch's earlier stores.
    let mut planned: HashMap<(i64, i64), &'static str> = HashMap::new();
    let mut plans: Vec<Result<(AnswerTarget, Plan)>> = Vec::with_capacity(submits.len());
    let mut stores: Vec<(i64, i64, &'static str, Option<i64>)> = Vec::new();
    for ((s, _), target) in submits.iter().zip(targets) {
        let plan = (|| {
            let target = target.ok_or(AppError::NotFound("assignment"))?;
            let choice = target.choose(s.choice, s.elapsed_ms)?;
            let key = (target.assignment.0, s.position);
            let earlier = target
                .question
                .as_ref()
                .and_then(|q| q.choice.as_deref())
                .or_else(|| planned.get(&key).copied());
            let plan = match earlier {
                Some(p) if p == choice => Plan::Duplicate,
                Some(_) => return Err(crate::flow::answered_differently()),
                None => {
                    planned.insert(key, choice);
                    stores.push((key.0, key.1, choice, s.elapsed_ms));
                    Plan::Store
                }
            };
            Ok((target, plan))
        })();
        plans.push(plan);
    }
    if !stores.is_empty() {
        let json = serde_json::to_string(&stores).map_err(AppError::internal)?;
        let done = sqlx::query(SUBMIT_UPDATE)
            .bind(json)
            .bind(now_ms())
            .execute(&mut *conn)
            .await?;
        // Every store was read as open in this very transaction, which no other writer can
        // enter, and `planned` keeps one store per question: all of them must have been
        // written. Anything else aborts the batch (nobody is acknowledged; clients retry).
        if done.rows_affected() != stores.len() as u64 {
            return Err(AppError::Internal(format!(
                "the batch stored {} of {} answers read as open",
                done.rows_affected(),
                stores.len()
            )));
        }
    }
    let mut next: HashMap<i64, Option<i64>> = HashMap::new();
    for (target, _) in plans.iter().flatten() {
        next.insert(target.assignment.0, None);
    }
    if !next.is_empty() {
        let ids: Vec<i64> = next.keys().copied().collect();
        let json = serde_json::to_string(&ids).map_err(AppError::internal)?;
        for (a, p) in
            json_array_row::<(i64, i64)>(conn, sqlx::query(SUBMIT_NEXT).bind(json)).await?
        {
            next.insert(a, Some(p));
        }
    }
    // Completes, in this transaction, every active assignment this batch has left without an
    // open question (also on a retry of its last answer, should an earlier completion have
    // been lost): the acknowledgement of the last answer then implies the completion.
    let mut thresholds: HashMap<StudyId, u32> = HashMap::new();
    let mut completing: std::collections::HashSet<i64> = Default::default();
    for (target, _) in plans.iter().flatten() {
        let a = target.assignment;
        if target.status == "active"
            && next.get(&a.0).copied().flatten().is_none()
            && completing.insert(a.0)
        {
            let threshold = match thresholds.get(&target.study) {
                Some(&t) => t,
                None => {
                    let t = crate::study::load_on(&mut *conn, target.study)
                        .await?
                        .settings
                        .reject_at_control_errors;
                    thresholds.insert(target.study, t);
                    t
                }
            };
            crate::flow::complete_in(&mut *conn, a, threshold).await?;
        }
    }
    Ok(plans
        .into_iter()
        .map(|plan| {
            let (target, plan) = plan?;
            let duplicate = matches!(plan, Plan::Duplicate);
            let ask = target.question.as_ref().is_some_and(|q| q.ask_reasons);
            Ok(Submitted {
                assignment: target.assignment,
                study: target.study,
                next: next.get(&target.assignment.0).copied().flatten(),
                status: target.status,
                duplicate,
                ask_reasons: ask && !duplicate,
            })
        })
        .collect())
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
    conn: &mut AnyConnection,
    backend: Backend,
    batch: &[(AnswerWrite, oneshot::Sender<Result<Written>>)],
) -> Result<Vec<Written>> {
    let at = now_ms();
    let mut outcomes = Vec::with_capacity(batch.len());
    for (w, _) in batch {
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
            Backend::Sqlite => match query.fetch_optional(&mut *conn).await? {
                Some(row) => Written::Stored(Next::Known(row.try_get("next")?)),
                None => Written::AlreadyAnswered,
            },
            Backend::Postgres => match query.execute(&mut *conn).await?.rows_affected() {
                0 => Written::AlreadyAnswered,
                _ => Written::Stored(Next::ReadAfterCommit),
            },
        };
        outcomes.push(outcome);
    }
    Ok(outcomes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::db::Db;
    use crate::flow::{self, AnswerRequest, Source, StartOutcome, StartRequest};
    use crate::ids::ItemId;
    use crate::study;

    /// A fresh SQLite database with a study and `n` started HITs; returns the tokens and, per
    /// token, its questions as (position, b, c, ask_reasons).
    async fn hits(
        n: usize,
    ) -> (
        tempfile::TempDir,
        Db,
        Vec<(String, Vec<(i64, i64, i64, bool)>)>,
    ) {
        let dir = tempfile::tempdir().expect("temp dir");
        let url = format!("sqlite://{}", dir.path().join("w.db").display());
        let db = Db::connect(&url, 4).await.expect("connect");
        let id = crate::bench::prepare(&db, 4, 1).await.expect("study");
        let study = study::load(&db, id).await.expect("load");
        let mut out = Vec::new();
        for w in 0..n {
            let req = StartRequest {
                source: Some(Source::Direct),
                worker_id: Some(format!("w{w}")),
                ..StartRequest::default()
            };
            let StartOutcome::Started { token, .. } =
                flow::start(&db, &study, req).await.expect("start")
            else {
                panic!("preview")
            };
            let rows = sqlx::query(
                "SELECT q.position, t.b, t.c, q.ask_reasons FROM questions q \
                 JOIN tuples t ON t.id = q.tuple_id JOIN assignments a ON a.id = q.assignment_id \
                 WHERE a.token = $1 ORDER BY q.position",
            )
            .bind(&token)
            .fetch_all(&db.pool)
            .await
            .expect("questions");
            let qs = rows
                .iter()
                .map(|r| {
                    (
                        r.get::<i64, _>("position"),
                        r.get::<i64, _>("b"),
                        r.get::<i64, _>("c"),
                        r.get::<i64, _>("ask_reasons") != 0,
                    )
                })
                .collect();
            out.push((token, qs));
        }
        (dir, db, out)
    }

    fn sub(token: &str, position: i64, choice: i64, elapsed_ms: Option<i64>) -> AnswerSubmit {
        AnswerSubmit {
            token: token.to_string(),
            position,
            choice,
            elapsed_ms,
        }
    }

    async fn stored(db: &Db, token: &str, position: i64) -> Option<String> {
        sqlx::query(
            "SELECT q.choice FROM questions q JOIN assignments a ON a.id = q.assignment_id \
             WHERE a.token = $1 AND q.position = $2",
        )
        .bind(token)
        .bind(position)
        .fetch_one(&db.pool)
        .await
        .expect("question")
        .get("choice")
    }

    /// One batch with answers of several assignments, an in-batch duplicate and conflict, and
    /// every kind of refusal: each caller gets its own outcome, and only the valid first
    /// answers are stored.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn one_batch_answers_each_caller() {
        let (_dir, db, h) = hits(3).await;
        let (t0, q0) = (&h[0].0, &h[0].1);
        let (t1, q1) = (&h[1].0, &h[1].1);
        let (t2, q2) = (&h[2].0, &h[2].1);
        let batch: Vec<AnswerSubmit> = vec![
            sub(t0, 0, q0[0].1, Some(1200)),         // stored (b)
            sub(t1, 3, q1[3].2, None),               // stored (c); position 0 still open
            sub(t0, 0, q0[0].1, None),               // same answer again: duplicate
            sub(t0, 0, q0[0].2, None),               // other option: conflict
            sub(&"ab".repeat(16), 0, q0[0].1, None), // no such assignment
            sub(t2, 999, q2[0].1, None),             // no such question
            sub(t2, 0, 12345, None),                 // not one of the two options
            sub(t1, 1, q1[1].1, Some(-5)),           // implausible time
            sub(t2, 1, q2[1].1, None),               // stored (b)
        ];
        let pending: Vec<_> = batch
            .into_iter()
            .map(|s| (s, oneshot::channel().0))
            .collect();
        let mut tx = db
            .writer
            .begin_with("BEGIN IMMEDIATE")
            .await
            .expect("begin");
        let out = submit_batch(&mut tx, &pending).await.expect("batch");
        tx.commit().await.expect("commit");
        assert_eq!(out.len(), 9);
        let ok = |i: usize| out[i].as_ref().expect("stored").clone();
        assert!(!ok(0).duplicate && ok(0).next == Some(1) && ok(0).status == "active");
        assert_eq!(ok(0).ask_reasons, q0[0].3);
        assert!(!ok(1).duplicate && ok(1).next == Some(0));
        assert!(ok(2).duplicate && !ok(2).ask_reasons && ok(2).next == Some(1));
        assert_eq!(ok(2).assignment, ok(0).assignment);
        assert!(matches!(out[3], Err(AppError::Conflict(_))), "{:?}", out[3]);
        assert!(matches!(out[4], Err(AppError::NotFound("assignment"))));
        assert!(matches!(out[5], Err(AppError::NotFound("question"))));
        assert!(matches!(out[6], Err(AppError::BadRequest(_))));
        assert!(matches!(out[7], Err(AppError::BadRequest(_))));
        assert!(!ok(8).duplicate && ok(8).next == Some(0));
        assert_ne!(ok(8).assignment, ok(0).assignment);
        assert_eq!(stored(&db, t0, 0).await.as_deref(), Some("b"));
        assert_eq!(stored(&db, t1, 3).await.as_deref(), Some("c"));
        assert_eq!(stored(&db, t1, 1).await, None);
        assert_eq!(stored(&db, t2, 0).await, None);
        assert_eq!(stored(&db, t2, 1).await.as_deref(), Some("b"));

        // A later batch sees the stored answers: a retry is a duplicate, a change a conflict.
        let again = db
            .answers
            .submit(sub(t0, 0, q0[0].1, None))
            .await
            .expect("retry");
        assert!(again.duplicate && again.next == Some(1));
        let changed = db.answers.submit(sub(t0, 0, q0[0].2, None)).await;
        assert!(matches!(changed, Err(AppError::Conflict(_))), "{changed:?}");
    }

    /// Every answer of a HIT sent at once (so they share batches), each twice: every caller
    /// is acknowledged, exactly one of each pair stores it, and the last answer completes the
    /// assignment (the completion job runs in the writer's transaction).
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn concurrent_answers_and_completion() {
        let (_dir, db, h) = hits(1).await;
        let (token, qs) = h[0].clone();
        let mut set = tokio::task::JoinSet::new();
        for &(position, b, _, _) in &qs {
            for _ in 0..2 {
                let (db, token) = (db.clone(), token.clone());
                set.spawn(async move {
                    let req = AnswerRequest {
                        position,
                        choice: ItemId(b),
                        elapsed_ms: Some(10),
                    };
                    flow::answer(&db, &token, &req).await
                });
            }
        }
        let mut stored_count = 0;
        let mut completed = 0;
        while let Some(r) = set.join_next().await {
            let ack = r.expect("task").expect("acknowledged");
            stored_count += usize::from(!ack.duplicate);
            completed += usize::from(ack.completed);
            assert_eq!(ack.completed, ack.next_position.is_none());
        }
        assert_eq!(stored_count, qs.len());
        assert!(completed >= 1);
        let row = sqlx::query("SELECT status, decision FROM assignments WHERE token = $1")
            .bind(&token)
            .fetch_one(&db.pool)
            .await
            .expect("assignment");
        assert_eq!(row.get::<String, _>("status"), "completed");
        assert!(row.get::<Option<String>, _>("decision").is_some());
        for &(position, ..) in &qs {
            assert_eq!(stored(&db, &token, position).await.as_deref(), Some("b"));
        }
    }

    async fn insert_worker(conn: &mut AnyConnection, name: &str) -> Result<()> {
        sqlx::query(
            "INSERT INTO workers (id, source, external_id, created_at) VALUES ($1, 'direct', $2, 0)",
        )
        .bind(crate::ids::WorkerId::generate().0)
        .bind(name)
        .execute(&mut *conn)
        .await?;
        Ok(())
    }

    /// A failing job is rolled back to its savepoint; the jobs and answers committed with it
    /// are not affected.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn failing_job_rolls_back_alone() {
        let (_dir, db, h) = hits(1).await;
        let (token, qs) = h[0].clone();
        let failing = db.answers.job(|conn| {
            Box::pin(async move {
                insert_worker(conn, "rolled-back").await?;
                Err::<(), _>(AppError::Conflict("no".into()))
            })
        });
        let kept = db
            .answers
            .job(|conn| Box::pin(async move { insert_worker(conn, "kept").await }));
        let answer = db.answers.submit(sub(&token, 0, qs[0].1, None));
        let (failing, kept, answer) = tokio::join!(failing, kept, answer);
        assert!(matches!(failing, Err(AppError::Conflict(_))));
        kept.expect("kept");
        assert!(!answer.expect("answer").duplicate);
        let names: Vec<String> =
            sqlx::query("SELECT external_id FROM workers ORDER BY external_id")
                .fetch_all(&db.pool)
                .await
                .expect("workers")
                .iter()
                .map(|r| r.get("external_id"))
                .collect();
        assert!(names.contains(&"kept".to_string()));
        assert!(!names.contains(&"rolled-back".to_string()));
    }
}
