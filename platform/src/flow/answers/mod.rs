//! Answers to HIT questions: the checks, the durable write through the answer writer's group
//! commit, the next open position and the completion of a HIT after its last answer.
//!
//! On SQLite the whole answer happens inside the writer's batch transaction
//! ([`sqlite_batch::ANSWERS`], a [`Batched`](crate::store::answer_writer::Batched) kind); on PostgreSQL
//! the read comes before and the next position after the group-committed `UPDATE` (see
//! `answer_writer` for why).

use serde::{Deserialize, Serialize};
use sqlx::{AnyConnection, Row};
use utoipa::ToSchema;

use super::{complete_in_sqlite, valid_token};
use crate::error::{AppError, Result};
use crate::flow::qc;
use crate::store::answer_writer::{AnswerWrite, Written};
use crate::store::db::{Backend, Db, now_ms};
use crate::store::ids::{AssignmentId, ItemId, StudyId};
use crate::studies::kind::StudyKind;
use crate::studies::study;

mod sqlite_batch;

use sqlite_batch::AnswerSubmit;

/// An answer to one HIT question.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct AnswerRequest {
    /// The question's position.
    pub position: i64,
    /// The chosen item (`left.id` or `right.id`).
    pub choice: ItemId,
    /// Milliseconds the worker spent on the question (client-measured, optional).
    #[schema(minimum = 0, maximum = 86_400_000)]
    pub elapsed_ms: Option<i64>,
}

/// The server's acknowledgement: the answer is durably stored when this is sent.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct AnswerAck {
    /// The same answer had been stored before (idempotent retry).
    pub duplicate: bool,
    /// Show the reasons questionnaire for this question now.
    pub ask_reasons: bool,
    /// All questions are answered.
    pub completed: bool,
    /// Next unanswered position, if any.
    pub next_position: Option<i64>,
}

/// Who answers a question: the worker's answer request, or the mash-up task's checked
/// submission, whose HIT's one question stands for the composition (§5.7.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AnsweredBy {
    /// `POST …/answers` or the no-script answer form.
    Question,
    /// `POST …/mashup/submit`, after the composition is checked and stored.
    ComposedScene,
    /// `POST …/iconset/submit`, after every set of the tray is finished (§6.6).
    IconSets,
}

/// What the answer path needs to know before writing, read in one query.
pub(crate) struct AnswerTarget {
    pub(crate) assignment: AssignmentId,
    pub(crate) study: StudyId,
    /// The study's kind (`studies.kind`, see [`StudyKind`]).
    pub(crate) kind: String,
    pub(crate) status: String,
    /// `None`: the assignment has no question at that position.
    pub(crate) question: Option<TargetQuestion>,
}

impl AnswerTarget {
    /// Checks an answer against what was read (a mash-up HIT's question is answered only by
    /// its composition, the assignment is answering, `elapsed_ms` is plausible, the question
    /// exists, the choice is one of its two options) and returns the choice as stored: `b` or
    /// `c`.
    pub(crate) fn choose(
        &self,
        choice: i64,
        elapsed_ms: Option<i64>,
        by: AnsweredBy,
    ) -> Result<&'static str> {
        if by == AnsweredBy::Question && self.kind == StudyKind::Mashup.as_str() {
            return Err(AppError::Conflict(
                "a mash-up task ends by submitting the composition (/mashup/submit)".into(),
            ));
        }
        if by == AnsweredBy::Question && self.kind == StudyKind::Iconset.as_str() {
            return Err(AppError::Conflict(
                "an icon-set task ends by submitting the tray (/iconset/submit)".into(),
            ));
        }
        if self.status != "active" && self.status != "completed" {
            return Err(AppError::Conflict(format!(
                "the assignment is {}, not answering questions",
                self.status
            )));
        }
        if let Some(ms) = elapsed_ms
            && !(0..=86_400_000).contains(&ms)
        {
            return Err(AppError::BadRequest("elapsed_ms: 0..=86400000".into()));
        }
        let q = self
            .question
            .as_ref()
            .ok_or(AppError::NotFound("question"))?;
        if choice == q.b {
            Ok("b")
        } else if choice == q.c {
            Ok("c")
        } else {
            Err(AppError::BadRequest(
                "choice: not one of the question's two options".into(),
            ))
        }
    }
}

impl AnswerTarget {
    /// Decodes a row with the assignment's `id`, `study_id` and `status` and the question's
    /// `position` (NULL: no such question), `b`, `c`, `ask_reasons` and `choice`.
    pub(crate) fn from_row(r: &sqlx::any::AnyRow) -> Result<Self> {
        let question = match r.try_get::<Option<i64>, _>("position")? {
            None => None,
            Some(_) => Some(TargetQuestion {
                b: r.try_get("b")?,
                c: r.try_get("c")?,
                ask_reasons: r.try_get::<i64, _>("ask_reasons")? != 0,
                choice: r.try_get("choice")?,
            }),
        };
        Ok(AnswerTarget {
            assignment: AssignmentId(r.try_get("id")?),
            study: StudyId(r.try_get("study_id")?),
            kind: r.try_get("kind")?,
            status: r.try_get("status")?,
            question,
        })
    }
}

impl AnswerTarget {
    /// [`AnswerTarget::from_row`] for a row of the SQLite answer writer's connection.
    pub(crate) fn from_sqlite_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<Self> {
        let question = match r.get::<_, Option<i64>>("position")? {
            None => None,
            Some(_) => Some(TargetQuestion {
                b: r.get("b")?,
                c: r.get("c")?,
                ask_reasons: r.get::<_, i64>("ask_reasons")? != 0,
                choice: r.get("choice")?,
            }),
        };
        Ok(AnswerTarget {
            assignment: AssignmentId(r.get("id")?),
            study: StudyId(r.get("study_id")?),
            kind: r.get("kind")?,
            status: r.get("status")?,
            question,
        })
    }
}

pub(crate) struct TargetQuestion {
    pub(crate) b: i64,
    pub(crate) c: i64,
    pub(crate) ask_reasons: bool,
    pub(crate) choice: Option<String>,
}

/// The assignment behind `$1` (its token), its study's kind and its question at position `$2`,
/// with the question's two options (never a control's expected answer), in one round trip
/// instead of one per table; no row without such an assignment.
pub(crate) const ANSWER_TARGET: &str = "SELECT a.id, a.study_id, s.kind, a.status, q.position, \
     q.choice, q.ask_reasons, t.b, t.c FROM assignments a \
     JOIN studies s ON s.id = a.study_id \
     LEFT JOIN questions q ON q.assignment_id = a.id AND q.position = $2 \
     LEFT JOIN tuples t ON t.id = q.tuple_id \
     WHERE a.token = $1";

/// The row of [`ANSWER_TARGET`] for `token` and `position`.
async fn answer_target(db: &Db, token: &str, position: i64) -> Result<AnswerTarget> {
    if !valid_token(token) {
        return Err(AppError::NotFound("assignment"));
    }
    let r = sqlx::query(ANSWER_TARGET)
        .bind(token)
        .bind(position)
        .fetch_optional(&db.pool)
        .await?
        .ok_or(AppError::NotFound("assignment"))?;
    AnswerTarget::from_row(&r)
}

/// Stores an answer (idempotent: the same answer again is acknowledged as a duplicate; a
/// different one is a conflict). Completes the assignment after its last answer.
///
/// On SQLite the whole answer — read, checks, write, next position, completion — happens in
/// the answer writer's batch transaction (`answer_in_batch`). On PostgreSQL it is one read
/// (`answer_target`), one group-committed write and a read of the next open position; the
/// study is loaded only to complete a HIT.
pub async fn answer(
    db: &Db,
    token: &str,
    req: &AnswerRequest,
    by: AnsweredBy,
) -> Result<AnswerAck> {
    if db.backend == Backend::Sqlite {
        return answer_in_batch(db, token, req, by).await;
    }
    let target = answer_target(db, token, req.position).await?;
    let choice = target.choose(req.choice.0, req.elapsed_ms, by)?;
    let q = target
        .question
        .as_ref()
        .ok_or(AppError::NotFound("question"))?;
    let id = target.assignment;
    let (duplicate, next) = match q.choice.as_deref() {
        Some(p) if p == choice => (true, next_unanswered(db, id).await?),
        Some(_) => return Err(answered_differently()),
        None => store(db, id, req, choice).await?,
    };
    let completed = next.is_none();
    if completed && target.status == "active" {
        complete(db, target.study, id).await?;
    }
    Ok(AnswerAck {
        duplicate,
        ask_reasons: q.ask_reasons && !duplicate,
        completed,
        next_position: next,
    })
}

/// SQLite: the read, the checks and the write of [`answer`] all happen in the answer writer's
/// transaction ([`crate::store::answer_writer::AnswerWriter::submit`]), batched with the other
/// answers of that transaction; nothing is read before or after.
async fn answer_in_batch(
    db: &Db,
    token: &str,
    req: &AnswerRequest,
    by: AnsweredBy,
) -> Result<AnswerAck> {
    if !valid_token(token) {
        return Err(AppError::NotFound("assignment"));
    }
    let s = db
        .answers
        .submit(
            &sqlite_batch::ANSWERS,
            AnswerSubmit {
                token: token.to_string(),
                position: req.position,
                choice: req.choice.0,
                elapsed_ms: req.elapsed_ms,
                by,
            },
        )
        .await?;
    // An assignment whose last question this answered was completed in the same transaction.
    let completed = s.next.is_none();
    Ok(AnswerAck {
        duplicate: s.duplicate,
        ask_reasons: s.ask_reasons,
        completed,
        next_position: s.next,
    })
}

pub(crate) fn answered_differently() -> AppError {
    AppError::Conflict("this question was already answered differently".into())
}

/// Writes an unanswered question's answer through the group commit (see `answer_writer`) and
/// returns (duplicate, next open position) once it is durable.
async fn store(
    db: &Db,
    id: AssignmentId,
    req: &AnswerRequest,
    choice: &'static str,
) -> Result<(bool, Option<i64>)> {
    let written = db
        .answers
        .write(AnswerWrite {
            assignment: id.0,
            position: req.position,
            choice,
            elapsed_ms: req.elapsed_ms,
        })
        .await?;
    match written {
        Written::Stored => Ok((false, next_unanswered(db, id).await?)),
        Written::AlreadyAnswered => {
            // A concurrent request answered it first: the same answer → duplicate, else conflict.
            let again = sqlx::query(
                "SELECT choice FROM questions WHERE assignment_id = $1 AND position = $2",
            )
            .bind(id.0)
            .bind(req.position)
            .fetch_one(&db.pool)
            .await?;
            let now: Option<String> = again.try_get("choice")?;
            if now.as_deref() != Some(choice) {
                return Err(answered_differently());
            }
            Ok((true, next_unanswered(db, id).await?))
        }
    }
}

/// The first open position of an assignment (`questions_open` index); NULL when none is left.
pub(crate) const NEXT_OPEN: &str =
    "SELECT MIN(position) AS p FROM questions WHERE assignment_id = $1 AND choice IS NULL";

async fn next_unanswered(db: &Db, a: AssignmentId) -> Result<Option<i64>> {
    let row = sqlx::query(NEXT_OPEN).bind(a.0).fetch_one(&db.pool).await?;
    Ok(row.try_get::<Option<i64>, _>("p")?)
}

/// Marks an assignment completed and applies the control rule (audited). Loads the study
/// (for its threshold) only when the assignment is still active: once per HIT.
async fn complete(db: &Db, study: StudyId, a: AssignmentId) -> Result<()> {
    let threshold = study::load(db, study)
        .await?
        .settings
        .reject_at_control_errors;
    match db.backend {
        // With the answers' group commit: no fsync of its own, no wait for a turn.
        Backend::Sqlite => {
            db.answers
                .job(move |conn| complete_in_sqlite(conn, a, threshold))
                .await
        }
        Backend::Postgres => {
            let mut tx = db.begin_write().await?;
            complete_in(&mut tx, a, threshold).await?;
            tx.commit().await
        }
    }
}

/// Marks assignment `$2` completed at `$1` if it is active.
pub(crate) const COMPLETE: &str = "UPDATE assignments SET status = 'completed', completed_at = $1 \
     WHERE id = $2 AND status = 'active'";

/// The writes of [`complete`], inside the caller's transaction.
pub(crate) async fn complete_in(
    tx: &mut AnyConnection,
    a: AssignmentId,
    threshold: u32,
) -> Result<()> {
    let done = sqlx::query(COMPLETE)
        .bind(now_ms())
        .bind(a.0)
        .execute(&mut *tx)
        .await?;
    if done.rows_affected() == 1 {
        let errors = qc::control_errors(tx, a).await?;
        qc::record(
            tx,
            a,
            qc::verdict(errors, threshold),
            &qc::rule_name(threshold),
            "rule",
            errors,
        )
        .await?;
    }
    Ok(())
}
