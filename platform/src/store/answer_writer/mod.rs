//! Group commit of answers. Every answer is a conditional `UPDATE questions … WHERE choice IS
//! NULL`; committed one by one, SQLite's single writer (one WAL fsync per commit) caps the answer
//! path near 1,500/s on these machines whatever the concurrency. Here the answers that arrive
//! while a commit is in flight are written together in the next transaction, and each caller is
//! answered only after that transaction has committed — so an acknowledged answer is as durable
//! as before, nothing is acknowledged from memory, and a crash loses only unacknowledged
//! answers (the client retries; answers are idempotent). A database error aborts the whole batch
//! and every caller in it gets the error (none was acknowledged).
//!
//! On SQLite (`answer_writer/sqlite.rs`) an answer is handed over as the worker sent it
//! ([`AnswerWriter::submit`], a [`Batched`] kind the worker flow implements) and everything
//! happens inside the writer's `BEGIN IMMEDIATE` transaction: the flow's read of the answer's
//! assignment and question, its checks, the conditional `UPDATE`, the read of the assignment's
//! next open position and the completion of every assignment left without one. What is read is
//! exact: every writer of the file is serialised, so nothing can change between the read and the
//! write, and two answers of one question in the same batch are decided in arrival order (the
//! first is stored, the second is a duplicate or a conflict). The store knows the transaction,
//! not the answers: the writer depends on no module above it. The writer drives its connection
//! directly
//! ([`crate::store::sqlite_direct`]) on a thread of its own, and takes the process's SQLite write turn
//! ([`crate::store::db::Db::begin_write`]) for each batch, so the sqlx writers of the same process queue
//! fairly with it instead of polling SQLite's busy handler.
//!
//! Other SQLite writes that must not wait for their own fsync — HIT allocations, completions —
//! run as jobs ([`AnswerWriter::job`]) in the same transaction, each in a savepoint so that its
//! failure rolls back only its own statements; their callers too are answered after the commit.
//!
//! On PostgreSQL (`answer_writer/postgres.rs`), where several servers write concurrently under READ
//! COMMITTED, a statement's snapshot may miss another server's concurrent answer of the same
//! assignment (both would then see the other's question as open and neither would complete the
//! HIT), so there the caller reads its target before and the next position after the commit, and
//! hands over only the conditional `UPDATE` ([`AnswerWriter::write`]).

mod batched;
mod checkpoint;
mod postgres;
mod sqlite;

pub use batched::Batched;

use std::collections::VecDeque;
use std::path::Path;
use std::sync::Arc;

use sqlx::AnyPool;
use tokio::sync::{mpsc, oneshot};

use crate::error::{AppError, Result};

/// Most answers written in one transaction (bounds the time the writer is held).
pub const MAX_BATCH: usize = 256;

/// Most jobs ([`AnswerWriter::job`]) run in one transaction next to the answers (more wait for
/// the next one, without holding up the answers that arrive after them).
pub const MAX_JOBS: usize = 8;

/// One answer to store (PostgreSQL, [`AnswerWriter::write`]).
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

/// Stores a question's answer if it has none (`$1` choice, `$2` time, `$3` elapsed ms, `$4`
/// assignment, `$5` position): the one statement that writes an answer, on either backend.
pub const STORE_ANSWER: &str = "UPDATE questions SET choice = $1, answered_at = $2, \
     elapsed_ms = $3 WHERE assignment_id = $4 AND position = $5 AND choice IS NULL";

/// What happened to one answer (PostgreSQL), once its transaction has committed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Written {
    /// This answer was stored (the question had none); the caller reads the next open
    /// position after the commit.
    Stored,
    /// The question already had an answer (this one or another); nothing was changed.
    AlreadyAnswered,
}

/// Sends a job's outcome to its caller once the transaction's fate is known (`Err`: the commit
/// failed, with why).
type Deliver = Box<dyn FnOnce(std::result::Result<(), String>) + Send>;

/// A job erased to: run inside the transaction (within its own savepoint), report whether it
/// succeeded, and what to deliver after the commit.
type Job = Box<dyn FnOnce(&rusqlite::Connection) -> (bool, Deliver) + Send>;

enum Pending {
    Write(AnswerWrite, oneshot::Sender<Result<Written>>),
    Batched(Box<dyn batched::Entry>),
    Job(Job),
}

/// Handle to the batching thread (cheap to clone).
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

/// Why a request of the other backend's kind reached a writer (a bug, not a user error).
fn wrong_backend(what: &str) -> AppError {
    AppError::Internal(format!(
        "{what} reached the answer writer of the other backend"
    ))
}

impl AnswerWriter {
    /// Starts the SQLite writer on a thread of its own, with its own connection to the
    /// database file at `path`, its WAL sync thread (see `answer_writer/sqlite.rs`) and its
    /// checkpoint thread (`answer_writer/checkpoint.rs`); each batch holds
    /// `turn` (the process's SQLite write turn, see [`crate::store::db::Db::begin_write`]) while it
    /// writes.
    pub fn start_sqlite(path: &Path, turn: Arc<tokio::sync::Mutex<()>>) -> Result<Self> {
        let conn = crate::store::sqlite_direct::open(path)?;
        // Durability comes from the sync thread's fdatasync before any reply (see `sqlite.rs`).
        conn.pragma_update(None, "synchronous", "NORMAL")?;
        // No `cache_size`: SQLite's default page cache (2 MB) is enough, since a HIT's slot
        // claims share a few pages (consecutive tuple ids, see `study::rows::free_block`), and
        // SQLite scans a larger cache's page table as a commit ends (`pcache1TruncateUnsafe`:
        // 6-14% of the writer's CPU with a 64 MiB cache, under 3% with this one, `perf` at 50
        // closed-loop workers).
        //
        // Checkpoints run on a thread of their own (`answer_writer/checkpoint.rs`).
        conn.pragma_update(None, "wal_autocheckpoint", 0)?;
        let writer_alive = checkpoint::spawn(path, turn.clone())?;
        let mut wal = path.as_os_str().to_owned();
        wal.push("-wal");
        let wal = std::path::PathBuf::from(wal);
        let (to_sync, queued) = std::sync::mpsc::channel();
        std::thread::Builder::new()
            .name("answer-sync".into())
            .spawn(move || sqlite::sync_loop(&wal, &queued))
            .map_err(AppError::internal)?;
        let (queue, rx) = mpsc::unbounded_channel();
        std::thread::Builder::new()
            .name("answer-writer".into())
            .spawn(move || {
                // Dropped when the writer stops: the checkpoint thread's signal to finish.
                let _alive = writer_alive;
                sqlite::run(&conn, &turn, rx, &to_sync)
            })
            .map_err(AppError::internal)?;
        Ok(Self { queue })
    }

    /// Starts the PostgreSQL writer, writing through `pool`, on a thread of its own with a
    /// single-threaded runtime.
    ///
    /// Why a thread: on the server's runtime every one of a batch's awaits queued behind the
    /// HTTP tasks, and the writer, which bounds the answer rate, waited to be polled instead
    /// of writing (`platform bench`, 200 workers: +8% answers/s on its own thread).
    pub fn start_postgres(pool: AnyPool) -> Result<Self> {
        let (queue, rx) = mpsc::unbounded_channel();
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(AppError::internal)?;
        std::thread::Builder::new()
            .name("answer-writer".into())
            .spawn(move || runtime.block_on(postgres::run(pool, rx)))
            .map_err(AppError::internal)?;
        Ok(Self { queue })
    }

    /// PostgreSQL: stores one answer; returns what the conditional `UPDATE` did once the
    /// transaction holding it has committed.
    pub async fn write(&self, write: AnswerWrite) -> Result<Written> {
        let (reply, answer) = oneshot::channel();
        self.queue
            .send(Pending::Write(write, reply))
            .map_err(|_| stopped())?;
        answer.await.map_err(|_| dropped())?
    }

    /// SQLite: hands `request` to `kind`, which writes it with the other requests of its kind
    /// in the writer's next transaction ([`Batched::write`]); replies once that transaction
    /// has committed and is durable. Exact because every SQLite writer is serialised (`BEGIN
    /// IMMEDIATE`); not for PostgreSQL (see the module comment).
    pub async fn submit<B: Batched>(
        &self,
        kind: &'static B,
        request: B::Request,
    ) -> Result<B::Reply> {
        let (reply, answer) = oneshot::channel();
        let entry = batched::Typed {
            kind,
            request,
            reply,
        };
        self.queue
            .send(Pending::Batched(Box::new(entry)))
            .map_err(|_| stopped())?;
        answer.await.map_err(|_| dropped())?
    }

    /// SQLite: runs `f` inside the writer's next transaction, in a savepoint of its own (an
    /// error rolls back `f`'s statements only), and returns its result once that transaction
    /// has committed: a write that shares the answers' group commit (one fsync) instead of
    /// taking turns with them. `f` must not begin or commit a transaction itself.
    pub async fn job<T, F>(&self, f: F) -> Result<T>
    where
        T: Send + 'static,
        F: FnOnce(&rusqlite::Connection) -> Result<T> + Send + 'static,
    {
        let (reply, answer) = oneshot::channel::<Result<T>>();
        let job: Job = Box::new(move |conn: &rusqlite::Connection| {
            let out = f(conn);
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
        });
        self.queue.send(Pending::Job(job)).map_err(|_| stopped())?;
        answer.await.map_err(|_| dropped())?
    }
}

/// One batch, split by kind.
#[derive(Default)]
struct Batch {
    writes: Vec<(AnswerWrite, oneshot::Sender<Result<Written>>)>,
    batched: Vec<Box<dyn batched::Entry>>,
    jobs: Vec<Job>,
}

impl Batch {
    fn len(&self) -> usize {
        self.writes.len() + self.batched.len()
    }

    /// Adds `p`; a job beyond [`MAX_JOBS`] waits in `deferred` for a later batch, so answers
    /// never queue behind a backlog of jobs (HIT starts arriving together).
    fn push(&mut self, p: Pending, deferred: &mut VecDeque<Job>) {
        match p {
            Pending::Write(w, r) => self.writes.push((w, r)),
            Pending::Batched(e) => self.batched.push(e),
            Pending::Job(j) if self.jobs.len() < MAX_JOBS => self.jobs.push(j),
            Pending::Job(j) => deferred.push_back(j),
        }
    }

    fn is_empty(&self) -> bool {
        self.len() == 0 && self.jobs.is_empty()
    }

    /// A batch of the jobs deferred from earlier batches, in arrival order.
    fn with_deferred(deferred: &mut VecDeque<Job>) -> Self {
        let mut batch = Self::default();
        while batch.jobs.len() < MAX_JOBS {
            match deferred.pop_front() {
                Some(j) => batch.jobs.push(j),
                None => break,
            }
        }
        batch
    }

    /// Adds whatever is already queued, up to [`MAX_BATCH`] answers.
    fn fill(&mut self, rx: &mut mpsc::UnboundedReceiver<Pending>, deferred: &mut VecDeque<Job>) {
        while self.len() < MAX_BATCH {
            match rx.try_recv() {
                Ok(p) => self.push(p, deferred),
                Err(_) => break,
            }
        }
    }
}
