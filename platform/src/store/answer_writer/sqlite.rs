//! The SQLite writer: a thread that owns one connection ([`crate::store::sqlite_direct`]) and writes
//! each batch — answers, completions, jobs — in one `BEGIN IMMEDIATE` transaction, and a
//! second thread that makes the committed batches durable before anyone is answered.
//!
//! Why two threads: with `synchronous=FULL` SQLite fsyncs the WAL inside `COMMIT`, while the
//! write lock is held, so no batch could be written during the previous one's fsync (about
//! half of the writer's time at 200 closed-loop workers: 1.5 ms of ~2.9 ms per batch). The
//! writer's connection uses `synchronous=NORMAL` instead (`COMMIT` writes the WAL frames but
//! does not wait for the disk), and hands the batch's replies to the sync thread, which
//! fdatasyncs the WAL file once for every batch committed before the call, and only then
//! sends their replies. So an acknowledged answer is on disk exactly as with `FULL`, and the
//! next batch is written while the previous one's fsync runs.
//!
//! Why that is durable: a reply goes out only after an fdatasync of the WAL that began after
//! its batch's `COMMIT` returned, i.e. after its frames were written to the file. SQLite may
//! meanwhile checkpoint those frames into the database file and restart the WAL from its
//! start, but in WAL mode even `NORMAL` syncs the WAL before a checkpoint copies it and the
//! database file after (<https://sqlite.org/pragma.html#pragma_synchronous>), so a restarted
//! WAL's earlier frames are already durable in the database file. What `NORMAL` changes is
//! visibility: other connections may read a batch a few milliseconds before its writers are
//! answered, and after a power failure (not a process crash: the frames are then in the OS's
//! cache) such a batch may be gone; none of its callers was answered, and they retry.

use std::collections::VecDeque;
use std::path::Path;
use std::sync::mpsc as sync_channel;

use rusqlite::Connection;
use tokio::sync::mpsc;

use super::{Batch, Deliver, Job, Pending, batched, wrong_backend};
use crate::error::Result;
use crate::store::sqlite_direct::execute;

/// Writes batches until every sender is gone. Each batch holds `turn`, the process's SQLite
/// write turn, so the sqlx writers of this process wait in line for it (fair, FIFO) instead of
/// sleeping in SQLite's busy handler; what arrives while the turn is awaited joins the batch.
pub(super) fn run(
    conn: &Connection,
    turn: &tokio::sync::Mutex<()>,
    mut rx: mpsc::UnboundedReceiver<Pending>,
    to_sync: &sync_channel::Sender<Acks>,
) {
    let mut deferred = VecDeque::new();
    loop {
        let mut batch = Batch::with_deferred(&mut deferred);
        if batch.is_empty() {
            match rx.blocking_recv() {
                Some(p) => batch.push(p, &mut deferred),
                None => break,
            }
        }
        let _turn = turn.blocking_lock();
        batch.fill(&mut rx, &mut deferred);
        if let Some(acks) = run_batch(conn, batch)
            && let Err(sync_channel::SendError(acks)) = to_sync.send(acks)
        {
            // The sync thread is gone (it never stops first): fail safe, unacknowledged.
            acks.send(Err("the WAL sync thread has stopped".into()));
        }
    }
}

/// The replies of one committed batch, sent once the WAL is on disk.
pub(super) struct Acks {
    delivers: Vec<Deliver>,
}

impl Acks {
    /// Replies to every caller: their outcomes if the WAL was synced, else an error (the batch
    /// is committed but its durability unknown; the clients retry, and answers are
    /// idempotent).
    fn send(self, synced: std::result::Result<(), String>) {
        for deliver in self.delivers {
            deliver(synced.clone());
        }
    }
}

/// The sync thread: for everything committed so far (all replies queued before the call),
/// one fdatasync of the WAL file `wal`, then the replies. Runs until the writer is gone.
pub(super) fn sync_loop(wal: &Path, queued: &sync_channel::Receiver<Acks>) {
    while let Ok(first) = queued.recv() {
        let mut ready = vec![first];
        ready.extend(queued.try_iter());
        let synced = std::fs::File::open(wal)
            .and_then(|f| f.sync_data())
            .map_err(|e| format!("syncing {}: {e}", wal.display()));
        if let Err(why) = &synced {
            eprintln!("error: {why}");
        }
        for acks in ready {
            acks.send(synced.clone());
        }
    }
}

/// Runs one batch in one transaction; returns its callers' replies for the sync thread, or
/// answers them at once with the error that aborted it (then none of them was stored).
fn run_batch(conn: &Connection, batch: Batch) -> Option<Acks> {
    let Batch {
        writes,
        batched,
        jobs,
    } = batch;
    // PostgreSQL's requests never come here (their callers route by backend).
    for (_, reply) in writes {
        let _ = reply.send(Err(wrong_backend("an answer write")));
    }
    let mut delivers: Vec<Deliver> = Vec::with_capacity(jobs.len() + 1);
    let outcome = transaction(conn, batched, jobs, &mut delivers);
    if outcome.is_err()
        && !conn.is_autocommit()
        && let Err(e) = execute(conn, "ROLLBACK", &[])
    {
        eprintln!("error: rolling back the answer batch: {e}");
    }
    match outcome {
        Ok(()) => Some(Acks { delivers }),
        Err(e) => {
            let why = e.to_string();
            for deliver in delivers {
                deliver(Err(why.clone()));
            }
            None
        }
    }
}

/// The batch's transaction: the batched requests, one call per kind, then each job in a
/// savepoint of its own.
fn transaction(
    conn: &Connection,
    batched: Vec<Box<dyn batched::Entry>>,
    jobs: Vec<Job>,
    delivers: &mut Vec<Deliver>,
) -> Result<()> {
    execute(conn, "BEGIN IMMEDIATE", &[])?;
    for mut group in batched::by_kind(batched) {
        let first = group.remove(0);
        delivers.push(first.write_with(group, conn)?);
    }
    for job in jobs {
        execute(conn, "SAVEPOINT job", &[])?;
        let (ok, deliver) = job(conn);
        delivers.push(deliver);
        if !ok {
            execute(conn, "ROLLBACK TO job", &[])?;
        }
        execute(conn, "RELEASE job", &[])?;
    }
    execute(conn, "COMMIT", &[])?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use sqlx::Row;
    use tokio::sync::oneshot;

    use super::*;
    use crate::error::AppError;
    use crate::store::answer_writer::Batched;
    use crate::store::db::Db;

    /// A batched kind for the tests: each request names a worker to insert; a name starting
    /// with `bad` is refused (nothing written), `abort` fails the whole batch.
    struct Names;
    static NAMES: Names = Names;

    impl Batched for Names {
        type Request = String;
        type Reply = usize;

        fn write(&self, conn: &Connection, names: &[String]) -> Result<Vec<Result<usize>>> {
            let mut out = Vec::new();
            for (i, name) in names.iter().enumerate() {
                if name == "abort" {
                    return Err(AppError::Internal("abort".into()));
                }
                if name.starts_with("bad") {
                    out.push(Err(AppError::BadRequest(format!("{name}: refused"))));
                    continue;
                }
                insert_worker(conn, name)?;
                out.push(Ok(i));
            }
            Ok(out)
        }
    }

    async fn db() -> (tempfile::TempDir, Db) {
        let dir = tempfile::tempdir().expect("temp dir");
        let url = format!("sqlite://{}", dir.path().join("w.db").display());
        let db = Db::connect(&url, 4).await.expect("connect");
        (dir, db)
    }

    fn insert_worker(conn: &Connection, name: &str) -> Result<()> {
        execute(
            conn,
            "INSERT INTO workers (id, source, external_id, created_at) VALUES ($1, 'direct', $2, 0)",
            &[&crate::store::ids::WorkerId::generate().0, &name],
        )?;
        Ok(())
    }

    async fn names(db: &Db) -> Vec<String> {
        sqlx::query("SELECT external_id FROM workers ORDER BY external_id")
            .fetch_all(&db.pool)
            .await
            .expect("workers")
            .iter()
            .map(|r| r.get("external_id"))
            .collect()
    }

    /// Requests of one kind sent together share a batch and each caller gets its own outcome;
    /// a refused request leaves nothing behind.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn batched_requests_get_their_own_outcomes() {
        let (_dir, db) = db().await;
        let (a, bad, b) = tokio::join!(
            db.answers.submit(&NAMES, "a".to_string()),
            db.answers.submit(&NAMES, "bad-1".to_string()),
            db.answers.submit(&NAMES, "b".to_string()),
        );
        a.expect("a");
        b.expect("b");
        assert!(matches!(bad, Err(AppError::BadRequest(_))), "{bad:?}");
        assert_eq!(names(&db).await, ["a", "b"]);
    }

    /// A batched kind that fails aborts its batch: its callers and the jobs of the same
    /// transaction get errors, and nothing of the batch is stored.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_failing_kind_aborts_its_batch() {
        let (_dir, db) = db().await;
        // Hold the write turn so that everything below queues into one batch.
        let turn = db.begin_write().await.expect("turn");
        let sent = tokio::spawn({
            let db = db.clone();
            async move {
                tokio::join!(
                    db.answers.submit(&NAMES, "x".to_string()),
                    db.answers.submit(&NAMES, "abort".to_string()),
                    db.answers.job(|conn| insert_worker(conn, "job")),
                )
            }
        });
        tokio::time::sleep(std::time::Duration::from_millis(200)).await;
        turn.rollback().await.expect("release");
        let (x, abort, job) = sent.await.expect("task");
        assert!(
            x.is_err() && abort.is_err() && job.is_err(),
            "{x:?} {abort:?} {job:?}"
        );
        assert!(names(&db).await.is_empty());
    }

    /// A failing job is rolled back to its savepoint; the jobs and requests committed with it
    /// are not affected.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn failing_job_rolls_back_alone() {
        let (_dir, db) = db().await;
        let failing = db.answers.job(|conn| {
            insert_worker(conn, "rolled-back")?;
            Err::<(), _>(AppError::Conflict("no".into()))
        });
        let kept = db.answers.job(|conn| insert_worker(conn, "kept"));
        let request = db.answers.submit(&NAMES, "request".to_string());
        let (failing, kept, request) = tokio::join!(failing, kept, request);
        assert!(matches!(failing, Err(AppError::Conflict(_))));
        kept.expect("kept");
        request.expect("request");
        let names = names(&db).await;
        assert!(names.contains(&"kept".to_string()) && names.contains(&"request".to_string()));
        assert!(!names.contains(&"rolled-back".to_string()));
    }

    /// Nobody is answered before the WAL sync: when it fails, the callers of every batch
    /// waiting for it get an error instead of their outcome (the batch is committed, but
    /// they may not rely on it); when it succeeds, their outcomes.
    #[test]
    fn replies_wait_for_the_wal_sync() {
        let dir = tempfile::tempdir().expect("temp dir");
        let wal = dir.path().join("db-wal");
        std::fs::write(&wal, b"frames").expect("wal");
        for (path, synced) in [(dir.path().join("missing-wal"), false), (wal, true)] {
            let (to_sync, queued) = sync_channel::channel();
            let (delivered, outcome) = oneshot::channel();
            let deliver: Deliver = Box::new(move |r| {
                let _ = delivered.send(r);
            });
            assert!(
                to_sync
                    .send(Acks {
                        delivers: vec![deliver]
                    })
                    .is_ok()
            );
            drop(to_sync);
            sync_loop(&path, &queued);
            let got = outcome.blocking_recv().expect("deliver");
            assert_eq!(got.is_ok(), synced, "{got:?}");
        }
    }

    /// sqlx writes of the same process (admin writes, training submissions) run between the
    /// writer's batches under the shared write turn: under a stream of batched requests every
    /// one of them succeeds, none is refused as busy, and every request is stored.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn sqlx_writes_take_turns_with_the_writer() {
        let (_dir, db) = db().await;
        let mut set = tokio::task::JoinSet::new();
        for w in 0..4 {
            let db = db.clone();
            set.spawn(async move {
                for i in 0..50 {
                    db.answers
                        .submit(&NAMES, format!("batched-{w}-{i}"))
                        .await?;
                }
                Ok::<_, AppError>(())
            });
        }
        for i in 0..40 {
            let db = db.clone();
            set.spawn(async move {
                if i % 2 == 0 {
                    let mut tx = db.begin_write().await?;
                    sqlx::query(
                        "INSERT INTO workers (id, source, external_id, created_at) \
                         VALUES ($1, 'direct', $2, 0)",
                    )
                    .bind(crate::store::ids::WorkerId::generate().0)
                    .bind(format!("side-{i}"))
                    .execute(&mut *tx)
                    .await?;
                    tx.commit().await
                } else {
                    sqlx::query("DELETE FROM login_failures WHERE at < $1")
                        .bind(i64::from(i))
                        .execute(&mut *db.write_conn().await?)
                        .await?;
                    Ok(())
                }
            });
        }
        while let Some(r) = set.join_next().await {
            r.expect("task").expect("write");
        }
        let names = names(&db).await;
        assert_eq!(names.iter().filter(|n| n.starts_with("side-")).count(), 20);
        assert_eq!(
            names.iter().filter(|n| n.starts_with("batched-")).count(),
            200
        );
    }
}
