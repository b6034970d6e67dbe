//! The SQLite writer: a thread that owns one connection ([`crate::sqlite_direct`]) and writes
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

use std::collections::{HashMap, HashSet, VecDeque};
use std::path::Path;
use std::sync::mpsc as sync_channel;

use rusqlite::Connection;
use tokio::sync::{mpsc, oneshot};

use super::{AnswerSubmit, Batch, Deliver, Job, Pending, Submitted, wrong_backend};
use crate::db::now_ms;
use crate::error::{AppError, Result};
use crate::flow::{ANSWER_TARGET, AnswerTarget, NEXT_OPEN, STORE_ANSWER};
use crate::ids::StudyId;
use crate::sqlite_direct::{execute, optional_row};

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
    submitted: Vec<(oneshot::Sender<Result<Submitted>>, Result<Submitted>)>,
    delivers: Vec<Deliver>,
}

impl Acks {
    /// Replies to every caller: their outcomes if the WAL was synced, else an error (the batch
    /// is committed but its durability unknown; the clients retry, and answers are
    /// idempotent).
    fn send(self, synced: std::result::Result<(), String>) {
        match synced {
            Ok(()) => {
                for (reply, s) in self.submitted {
                    // The caller may have gone (client disconnected): nothing to do.
                    let _ = reply.send(s);
                }
                for deliver in self.delivers {
                    deliver(Ok(()));
                }
            }
            Err(why) => {
                for (reply, _) in self.submitted {
                    let _ = reply.send(Err(AppError::Internal(format!(
                        "the answer could not be made durable: {why}"
                    ))));
                }
                for deliver in self.delivers {
                    deliver(Err(why.clone()));
                }
            }
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
        submits,
        jobs,
    } = batch;
    // PostgreSQL's requests never come here ([`crate::flow`] routes by backend).
    for (_, reply) in writes {
        let _ = reply.send(Err(wrong_backend("an answer write")));
    }
    let mut delivers: Vec<Deliver> = Vec::with_capacity(jobs.len());
    let outcome = transaction(conn, &submits, jobs, &mut delivers);
    if outcome.is_err()
        && !conn.is_autocommit()
        && let Err(e) = execute(conn, "ROLLBACK", &[])
    {
        eprintln!("error: rolling back the answer batch: {e}");
    }
    match outcome {
        Ok(submitted) => Some(Acks {
            submitted: submits
                .into_iter()
                .map(|(_, reply)| reply)
                .zip(submitted)
                .collect(),
            delivers,
        }),
        Err(e) => {
            let why = e.to_string();
            for (_, reply) in submits {
                let _ = reply.send(Err(AppError::Internal(format!(
                    "storing the answer failed: {why}"
                ))));
            }
            for deliver in delivers {
                deliver(Err(why.clone()));
            }
            None
        }
    }
}

/// The batch's transaction: the answers, then each job in a savepoint of its own.
fn transaction(
    conn: &Connection,
    submits: &[(AnswerSubmit, oneshot::Sender<Result<Submitted>>)],
    jobs: Vec<Job>,
    delivers: &mut Vec<Deliver>,
) -> Result<Vec<Result<Submitted>>> {
    execute(conn, "BEGIN IMMEDIATE", &[])?;
    let submitted = submit_batch(conn, submits)?;
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
    Ok(submitted)
}

/// What one submitted answer resolved to.
enum Plan {
    /// Stored now.
    Store,
    /// Already stored with the same choice.
    Duplicate,
}

/// The answers of [`super::AnswerWriter::submit`], inside the caller's `BEGIN IMMEDIATE`
/// transaction (so what is read is what is written over). Each answer is read, checked and
/// stored in arrival order, so a second answer of the same question in the batch reads the
/// first as stored: a duplicate (same choice) or a conflict, exactly as if it had come in a
/// later batch. The next open positions are read after all of them; every active assignment
/// left without one is completed in the same transaction.
pub(super) fn submit_batch(
    conn: &Connection,
    submits: &[(AnswerSubmit, oneshot::Sender<Result<Submitted>>)],
) -> Result<Vec<Result<Submitted>>> {
    let at = now_ms();
    let mut plans: Vec<Result<(AnswerTarget, Plan)>> = Vec::with_capacity(submits.len());
    for (s, _) in submits {
        plans.push(submit_one(conn, s, at)?);
    }
    let mut next: HashMap<i64, Option<i64>> = HashMap::new();
    for (target, _) in plans.iter().flatten() {
        let a = target.assignment.0;
        if let std::collections::hash_map::Entry::Vacant(slot) = next.entry(a) {
            let open = optional_row(conn, NEXT_OPEN, &[&a], |r| r.get::<_, Option<i64>>(0))?;
            slot.insert(open.flatten());
        }
    }
    // Completes every active assignment this batch has left without an open question (also
    // on a retry of its last answer, should an earlier completion have been lost): the
    // acknowledgement of the last answer then implies the completion.
    let mut thresholds: HashMap<StudyId, u32> = HashMap::new();
    let mut completing: HashSet<i64> = HashSet::new();
    for (target, _) in plans.iter().flatten() {
        let a = target.assignment;
        if target.status == "active"
            && next.get(&a.0).copied().flatten().is_none()
            && completing.insert(a.0)
        {
            let threshold = match thresholds.get(&target.study) {
                Some(&t) => t,
                None => {
                    let t =
                        crate::study::settings_sqlite(conn, target.study)?.reject_at_control_errors;
                    thresholds.insert(target.study, t);
                    t
                }
            };
            crate::flow::complete_in_sqlite(conn, a, threshold)?;
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

/// Reads, checks and (if its question is open) stores one answer. The outer error aborts the
/// batch (a database failure); the inner one is this answer's refusal.
fn submit_one(
    conn: &Connection,
    s: &AnswerSubmit,
    at: i64,
) -> Result<Result<(AnswerTarget, Plan)>> {
    let Some(target) = optional_row(
        conn,
        ANSWER_TARGET,
        &[&s.token, &s.position],
        AnswerTarget::from_sqlite_row,
    )?
    else {
        return Ok(Err(AppError::NotFound("assignment")));
    };
    let choice = match target.choose(s.choice, s.elapsed_ms) {
        Ok(c) => c,
        Err(e) => return Ok(Err(e)),
    };
    let earlier = target.question.as_ref().and_then(|q| q.choice.as_deref());
    let plan = match earlier {
        Some(p) if p == choice => Plan::Duplicate,
        Some(_) => return Ok(Err(crate::flow::answered_differently())),
        None => {
            let stored = execute(
                conn,
                STORE_ANSWER,
                &[
                    &choice,
                    &at,
                    &s.elapsed_ms,
                    &target.assignment.0,
                    &s.position,
                ],
            )?;
            // Read as open in this very transaction, which no other writer can enter:
            // anything but one row aborts the batch (nobody is acknowledged; clients retry).
            if stored != 1 {
                return Err(AppError::Internal(format!(
                    "an answer read as open changed {stored} rows"
                )));
            }
            Plan::Store
        }
    };
    Ok(Ok((target, plan)))
}

#[cfg(test)]
mod tests {
    use sqlx::Row;

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
        // The batch on a connection of its own, as the writer thread runs it.
        let conn = crate::sqlite_direct::open(&_dir.path().join("w.db")).expect("open");
        execute(&conn, "BEGIN IMMEDIATE", &[]).expect("begin");
        let out = submit_batch(&conn, &pending).expect("batch");
        execute(&conn, "COMMIT", &[]).expect("commit");
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

    fn insert_worker(conn: &Connection, name: &str) -> Result<()> {
        execute(
            conn,
            "INSERT INTO workers (id, source, external_id, created_at) VALUES ($1, 'direct', $2, 0)",
            &[&crate::ids::WorkerId::generate().0, &name],
        )?;
        Ok(())
    }

    /// A failing job is rolled back to its savepoint; the jobs and answers committed with it
    /// are not affected.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn failing_job_rolls_back_alone() {
        let (_dir, db, h) = hits(1).await;
        let (token, qs) = h[0].clone();
        let failing = db.answers.job(|conn| {
            insert_worker(conn, "rolled-back")?;
            Err::<(), _>(AppError::Conflict("no".into()))
        });
        let kept = db.answers.job(|conn| insert_worker(conn, "kept"));
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
            let (reply, answer) = oneshot::channel();
            let (delivered, job_answer) = oneshot::channel();
            let outcome = Submitted {
                assignment: crate::ids::AssignmentId(7),
                study: StudyId(3),
                status: "active".into(),
                duplicate: false,
                ask_reasons: false,
                next: Some(1),
            };
            let deliver: Deliver = Box::new(move |r| {
                let _ = delivered.send(r);
            });
            let acks = Acks {
                submitted: vec![(reply, Ok(outcome.clone()))],
                delivers: vec![deliver],
            };
            assert!(to_sync.send(acks).is_ok());
            drop(to_sync);
            sync_loop(&path, &queued);
            let got = answer.blocking_recv().expect("reply");
            let job = job_answer.blocking_recv().expect("deliver");
            if synced {
                assert_eq!(got.expect("outcome"), outcome);
                assert_eq!(job, Ok(()));
            } else {
                assert!(
                    matches!(&got, Err(AppError::Internal(m)) if m.contains("durable")),
                    "{got:?}"
                );
                assert!(job.is_err());
            }
        }
    }

    /// sqlx writes of the same process (admin writes, training submissions) run between the
    /// writer's batches under the shared write turn: under a stream of answers every one of
    /// them succeeds, none is refused as busy, and every answer is stored.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn sqlx_writes_take_turns_with_the_writer() {
        let (_dir, db, h) = hits(4).await;
        let mut set = tokio::task::JoinSet::new();
        for (token, qs) in h.clone() {
            let db = db.clone();
            set.spawn(async move {
                for &(position, b, _, _) in &qs {
                    let req = AnswerRequest {
                        position,
                        choice: ItemId(b),
                        elapsed_ms: None,
                    };
                    flow::answer(&db, &token, &req).await?;
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
                    .bind(crate::ids::WorkerId::generate().0)
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
        let side: i64 =
            sqlx::query("SELECT COUNT(*) AS n FROM workers WHERE external_id LIKE 'side-%'")
                .fetch_one(&db.pool)
                .await
                .expect("count")
                .get("n");
        assert_eq!(side, 20);
        for (token, qs) in &h {
            for &(position, ..) in qs {
                assert_eq!(stored(&db, token, position).await.as_deref(), Some("b"));
            }
        }
    }
}
