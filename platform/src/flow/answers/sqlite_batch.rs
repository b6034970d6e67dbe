//! The answers' [`Batched`] kind on SQLite: every answer of a writer batch is read, checked and
//! stored inside the writer's transaction, in arrival order, so a second answer of the same
//! question in the batch reads the first as stored: a duplicate (same choice) or a conflict,
//! exactly as if it had come in a later batch. The next open positions are read after all of
//! them; every active assignment left without one is completed in the same transaction.

use std::collections::{HashMap, HashSet};

use rusqlite::Connection;

use super::{ANSWER_TARGET, AnswerTarget, AnsweredBy, NEXT_OPEN};
use crate::error::{AppError, Result};
use crate::store::answer_writer::{Batched, STORE_ANSWER};
use crate::store::db::now_ms;
use crate::store::ids::{AssignmentId, StudyId};
use crate::store::sqlite_direct::{execute, optional_row};

/// One answer as the worker sent it: looked up, checked and stored inside the writer's
/// transaction.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct AnswerSubmit {
    /// The assignment's bearer token (already checked to be 32 hex digits).
    pub(crate) token: String,
    /// Question position.
    pub(crate) position: i64,
    /// The chosen item id.
    pub(crate) choice: i64,
    /// Client-reported time on the question.
    pub(crate) elapsed_ms: Option<i64>,
    /// The answer request or a mash-up task's submission.
    pub(crate) by: AnsweredBy,
}

/// What a submitted answer did, once its transaction has committed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Submitted {
    /// The assignment.
    pub(crate) assignment: AssignmentId,
    /// Its study.
    pub(crate) study: StudyId,
    /// Its status when the answer was read (`active` or `completed`); an `active` one without
    /// an open question left is completed in the answer's transaction.
    pub(crate) status: String,
    /// The same answer had been stored before (idempotent retry).
    pub(crate) duplicate: bool,
    /// The question asks for reasons.
    pub(crate) ask_reasons: bool,
    /// The next unanswered position after the commit (exact: read in the same transaction).
    pub(crate) next: Option<i64>,
}

/// The answers, as the writer batches them.
pub(crate) struct Answers;

/// The one instance the answer path hands to the writer.
pub(crate) static ANSWERS: Answers = Answers;

impl Batched for Answers {
    type Request = AnswerSubmit;
    type Reply = Submitted;

    fn write(
        &self,
        conn: &Connection,
        requests: &[AnswerSubmit],
    ) -> Result<Vec<Result<Submitted>>> {
        submit_batch(conn, requests)
    }
}

/// What one submitted answer resolved to.
enum Plan {
    /// Stored now.
    Store,
    /// Already stored with the same choice.
    Duplicate,
}

/// The answers of a batch, inside the writer's `BEGIN IMMEDIATE` transaction (so what is read
/// is what is written over); see the module comment.
fn submit_batch(conn: &Connection, submits: &[AnswerSubmit]) -> Result<Vec<Result<Submitted>>> {
    let at = now_ms();
    let mut plans: Vec<Result<(AnswerTarget, Plan)>> = Vec::with_capacity(submits.len());
    for s in submits {
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
                    let t = crate::studies::study::settings_sqlite(conn, target.study)?
                        .reject_at_control_errors;
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
    let choice = match target.choose(s.choice, s.elapsed_ms, s.by) {
        Ok(c) => c,
        Err(e) => return Ok(Err(e)),
    };
    let earlier = target.question.as_ref().and_then(|q| q.choice.as_deref());
    let plan = match earlier {
        Some(p) if p == choice => Plan::Duplicate,
        Some(_) => return Ok(Err(super::answered_differently())),
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
    use crate::flow::{self, AnswerRequest, Source, StartOutcome, StartRequest};
    use crate::store::db::Db;
    use crate::store::ids::ItemId;
    use crate::studies::study;

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
        let id = crate::cli::bench::prepare(&db, 4, 1).await.expect("study");
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
            by: AnsweredBy::Question,
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
        // The batch on a connection of its own, as the writer thread runs it.
        let conn = crate::store::sqlite_direct::open(&_dir.path().join("w.db")).expect("open");
        execute(&conn, "BEGIN IMMEDIATE", &[]).expect("begin");
        let out = submit_batch(&conn, &batch).expect("batch");
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
            .submit(&ANSWERS, sub(t0, 0, q0[0].1, None))
            .await
            .expect("retry");
        assert!(again.duplicate && again.next == Some(1));
        let changed = db.answers.submit(&ANSWERS, sub(t0, 0, q0[0].2, None)).await;
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
                    flow::answer(&db, &token, &req, flow::AnsweredBy::Question).await
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
}
