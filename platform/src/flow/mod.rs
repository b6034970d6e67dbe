//! The worker flow: start (MTurk / Prolific / direct, MTurk preview), training gate, HIT
//! allocation (replicated slots claimed transactionally, hidden controls at random positions),
//! durable idempotent answers, the reasons questionnaire, resume, completion and screen-out
//! codes.
//!
//! Nothing a worker receives says whether a question is a control: controls and main questions
//! have the same shape, and the expected answer is only read inside [`crate::flow::qc`].

use hmac::{Hmac, Mac};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};
use sha2::Sha256;
use sqlx::{Any, AnyConnection, Row};
use utoipa::ToSchema;

use crate::error::{AppError, Result};
use crate::store::db::{Backend, Db, now_ms};
use crate::store::ids::{AssignmentId, ItemId, StudyId, WorkerId, random_token};
use crate::studies::kind::StudyKind;
use crate::studies::study::{self, MturkMode, Study};

mod answers;
mod consent;
mod outlook;
mod resume;
mod sqlite_writes;
mod training;

mod handback;
mod hit;
mod reasons;
mod start;
mod start_writes;
mod training_answers;

pub mod qc;

pub use handback::*;
pub use hit::*;
pub use reasons::*;
pub use start::*;
use start_writes::*;
pub use training_answers::*;

pub(crate) use answers::COMPLETE;
pub use answers::{AnswerAck, AnswerRequest, AnsweredBy, answer};
pub use consent::consent_version;
pub use outlook::{HitOutlook, outlook};
pub use resume::{Existing, existing};
pub use training::{TrainingReview, WorkedExample, worked_example};

pub(crate) use sqlite_writes::complete_in_sqlite;

/// MTurk's assignment id while a worker only previews a HIT.
pub const MTURK_PREVIEW: &str = "ASSIGNMENT_ID_NOT_AVAILABLE";
/// Prolific's completion address.
pub const PROLIFIC_COMPLETE: &str = "https://app.prolific.com/submissions/complete";

/// Where a worker comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// Amazon Mechanical Turk ExternalQuestion.
    Mturk,
    /// Prolific.
    Prolific,
    /// A direct link (lab studies, pilots).
    Direct,
}

impl Source {
    /// As stored.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Mturk => "mturk",
            Self::Prolific => "prolific",
            Self::Direct => "direct",
        }
    }
}

/// An assignment as looked up by its token.
#[derive(Debug, Clone)]
pub struct Assignment {
    /// Id.
    pub id: AssignmentId,
    /// Study.
    pub study: StudyId,
    /// Worker.
    pub worker: WorkerId,
    /// Source.
    pub source: String,
    /// MTurk sandbox.
    pub sandbox: bool,
    /// MTurk assignmentId.
    pub external_assignment: Option<String>,
    /// MTurk turkSubmitTo.
    pub submit_to: Option<String>,
    /// `training`, `active`, `completed`, `screened_out`.
    pub status: String,
    /// Failed training attempts so far.
    pub training_attempts: i64,
}

/// Whether `token` has the shape of a bearer token (32 hex digits): others are not looked up.
fn valid_token(token: &str) -> bool {
    token.len() == 32 && token.bytes().all(|b| b.is_ascii_hexdigit())
}

/// Looks an assignment up by its bearer token.
pub async fn by_token(db: &Db, token: &str) -> Result<Assignment> {
    if !valid_token(token) {
        return Err(AppError::NotFound("assignment"));
    }
    let r = sqlx::query(
        "SELECT id, study_id, worker_id, source, sandbox, external_assignment, submit_to, status, \
         training_attempts FROM assignments WHERE token = $1",
    )
    .bind(token)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("assignment"))?;
    Ok(Assignment {
        id: AssignmentId(r.try_get("id")?),
        study: StudyId(r.try_get("study_id")?),
        worker: WorkerId(r.try_get("worker_id")?),
        source: r.try_get("source")?,
        sandbox: r.try_get::<i64, _>("sandbox")? != 0,
        external_assignment: r.try_get("external_assignment")?,
        submit_to: r.try_get("submit_to")?,
        status: r.try_get("status")?,
        training_attempts: r.try_get("training_attempts")?,
    })
}

/// An image shown to the worker.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ItemRef {
    /// Item id (the value to send back as `choice`).
    pub id: ItemId,
    /// Image address.
    pub url: String,
}

impl ItemRef {
    fn new(id: i64) -> Self {
        Self {
            id: ItemId(id),
            url: format!("/media/items/{id}.png"),
        }
    }
}

/// One tuple as the worker sees it: for a triplet, "Is `reference` more similar in style to
/// `left` or to `right`?"; for a composition pair (no `reference`), `left` against `right`.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct QuestionView {
    /// Position in the HIT (answers are keyed by it); for training, the index.
    pub position: i64,
    /// A (triplets only: a composition pair has none, and the key is absent).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference: Option<ItemRef>,
    /// B or C (display order is randomised per worker).
    pub left: ItemRef,
    /// C or B.
    pub right: ItemRef,
}

fn mix(a: i64, b: i64) -> bool {
    // A stable per-(assignment, tuple) coin so the display order survives reloads.
    let x = (a as u64) ^ (b as u64).rotate_left(17);
    let x = x.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    (x >> 63) == 1
}

/// How `kind` shows the tuple (a, b, c) at `position`, b and c swapped or not.
fn view(kind: StudyKind, position: i64, a: i64, b: i64, c: i64, swapped: bool) -> QuestionView {
    let (left, right) = if swapped { (c, b) } else { (b, c) };
    QuestionView {
        position,
        reference: kind.shows_reference().then(|| ItemRef::new(a)),
        left: ItemRef::new(left),
        right: ItemRef::new(right),
    }
}

/// Loads the study of an assignment.
pub async fn study_of(db: &Db, a: &Assignment) -> Result<Study> {
    study::load(db, a.study).await
}

#[cfg(test)]
pub(crate) mod tests;
