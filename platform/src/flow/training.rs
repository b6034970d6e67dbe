//! The practice questions of the training gate: which triplets an attempt shows, and the
//! feedback on the previous attempt.
//!
//! A study stores a pool of training triplets (kind `training`, `seq` 0, 1, …; the expected
//! answer is always `b`). An attempt shows `training_questions` of them: attempt k (0-based)
//! takes the k-th block of that size, wrapping around the pool, so a worker who failed sees
//! other practice triplets next time instead of learning the answers of the same ones — the
//! gate then screens out people who do not understand the task, not people who need a retry.
//! A pool no larger than one block (studies created before the pool existed) shows the same
//! triplets every time.

use serde::Serialize;
use sqlx::Row;
use utoipa::ToSchema;

use super::{Assignment, QuestionView, mix, view};
use crate::error::Result;
use crate::store::db::Db;
use crate::store::ids::{ItemId, StudyId, TupleId};
use crate::studies::kind::StudyKind;
use crate::studies::study::Study;

/// A training triplet: (tuple, a, b, c); the expected answer is `b`.
pub(super) type TrainingTuple = (TupleId, i64, i64, i64);

/// The study's whole training pool, in the order it is used.
pub(super) async fn pool(db: &Db, study: StudyId) -> Result<Vec<TrainingTuple>> {
    let rows = sqlx::query(
        "SELECT id, a, b, c FROM tuples WHERE study_id = $1 AND kind = 'training' ORDER BY seq, id",
    )
    .bind(study.0)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| {
            Ok((
                TupleId(r.try_get("id")?),
                r.try_get("a")?,
                r.try_get("b")?,
                r.try_get("c")?,
            ))
        })
        .collect()
}

/// The block of `pool` shown at attempt `attempt` (0-based): `per_attempt` triplets, the
/// `attempt`-th block modulo the number of whole blocks in the pool.
pub(super) fn block(
    pool: &[TrainingTuple],
    per_attempt: usize,
    attempt: i64,
) -> Vec<TrainingTuple> {
    if per_attempt == 0 || pool.len() <= per_attempt {
        return pool.to_vec();
    }
    let blocks = pool.len() / per_attempt;
    let k = attempt.rem_euclid(blocks as i64) as usize;
    pool[k * per_attempt..(k + 1) * per_attempt].to_vec()
}

/// The triplets of the assignment's next attempt.
pub(super) async fn next_attempt(
    db: &Db,
    study: &Study,
    a: &Assignment,
) -> Result<Vec<TrainingTuple>> {
    Ok(block(
        &pool(db, study.id).await?,
        study.settings.training_questions as usize,
        a.training_attempts,
    ))
}

/// The next attempt's questions as the worker sees them (B and C in a stable per-worker order).
pub(super) async fn questions(db: &Db, study: &Study, a: &Assignment) -> Result<Vec<QuestionView>> {
    Ok(next_attempt(db, study, a)
        .await?
        .into_iter()
        .enumerate()
        .map(|(i, (t, x, y, z))| view(study.kind, i as i64, x, y, z, mix(a.id.0, t.0)))
        .collect())
}

/// One question of a finished attempt, with the worker's answer and the right one.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct TrainingReview {
    /// The question as it was shown.
    pub question: QuestionView,
    /// What the worker chose.
    pub chosen: ItemId,
    /// The right answer.
    pub expected: ItemId,
    /// Whether the worker was right.
    pub correct: bool,
}

/// The questions of the assignment's last attempt (empty before the first), in the order shown.
pub(super) async fn last_attempt(
    db: &Db,
    kind: StudyKind,
    a: &Assignment,
) -> Result<Vec<TrainingReview>> {
    if a.training_attempts == 0 {
        return Ok(Vec::new());
    }
    let rows = sqlx::query(
        "SELECT t.id, t.a, t.b, t.c, x.choice, x.correct FROM training_answers x \
         JOIN tuples t ON t.id = x.tuple_id \
         WHERE x.assignment_id = $1 AND x.attempt = $2 ORDER BY t.seq, t.id",
    )
    .bind(a.id.0)
    .bind(a.training_attempts)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .enumerate()
        .map(|(i, r)| {
            let tuple: i64 = r.try_get("id")?;
            let (x, b, c): (i64, i64, i64) = (r.try_get("a")?, r.try_get("b")?, r.try_get("c")?);
            let chose_b = r.try_get::<String, _>("choice")? == "b";
            Ok(TrainingReview {
                question: view(kind, i as i64, x, b, c, mix(a.id.0, tuple)),
                chosen: ItemId(if chose_b { b } else { c }),
                expected: ItemId(b),
                correct: r.try_get::<i64, _>("correct")? != 0,
            })
        })
        .collect()
}

/// A practice triplet shown with its answer under the instructions, as the thesis shows a
/// worked example before the test (Fig. 5.2, left).
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct WorkedExample {
    /// The triplet as shown.
    pub question: QuestionView,
    /// The picture closer in style to the reference.
    pub expected: ItemId,
}

/// The study's worked example: the last triplet of its training pool (the one an attempt
/// reaches last, if ever), or `None` when the study has no training or does not show one.
pub async fn worked_example(db: &Db, study: &Study) -> Result<Option<WorkedExample>> {
    if !study.settings.show_worked_example || !study.kind.has_worked_example() {
        return Ok(None);
    }
    let row = sqlx::query(
        "SELECT id, a, b, c FROM tuples WHERE study_id = $1 AND kind = 'training' \
         ORDER BY seq DESC, id DESC LIMIT 1",
    )
    .bind(study.id.0)
    .fetch_optional(&db.pool)
    .await?;
    let Some(r) = row else { return Ok(None) };
    let tuple: i64 = r.try_get("id")?;
    let b: i64 = r.try_get("b")?;
    Ok(Some(WorkedExample {
        question: view(
            study.kind,
            0,
            r.try_get("a")?,
            b,
            r.try_get("c")?,
            mix(study.id.0, tuple),
        ),
        expected: ItemId(b),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pool_of(n: i64) -> Vec<TrainingTuple> {
        (0..n).map(|i| (TupleId(i), i, i + 100, i + 200)).collect()
    }

    #[test]
    fn attempts_walk_through_the_pool_in_blocks() {
        let pool = pool_of(9);
        let ids = |v: Vec<TrainingTuple>| v.iter().map(|t| t.0.0).collect::<Vec<_>>();
        assert_eq!(ids(block(&pool, 3, 0)), vec![0, 1, 2]);
        assert_eq!(ids(block(&pool, 3, 1)), vec![3, 4, 5]);
        assert_eq!(ids(block(&pool, 3, 2)), vec![6, 7, 8]);
        assert_eq!(ids(block(&pool, 3, 3)), vec![0, 1, 2]);
        // 10 tuples hold three whole blocks of 3; the tenth is never shown.
        assert_eq!(ids(block(&pool_of(10), 3, 3)), vec![0, 1, 2]);
    }

    #[test]
    fn a_pool_of_one_block_repeats() {
        let pool = pool_of(3);
        assert_eq!(block(&pool, 3, 0), pool);
        assert_eq!(block(&pool, 3, 4), pool);
        assert_eq!(block(&pool_of(2), 3, 1).len(), 2);
        assert!(block(&[], 3, 0).is_empty());
    }
}
