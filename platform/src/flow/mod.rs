//! The worker flow: start (MTurk / Prolific / direct, MTurk preview), training gate, HIT
//! allocation (replicated slots claimed transactionally, hidden controls at random positions),
//! durable idempotent answers, the reasons questionnaire, resume, completion and screen-out
//! codes.
//!
//! Nothing a worker receives says whether a question is a control: controls and main questions
//! have the same shape, and the expected answer is only read inside [`crate::qc`].

use hmac::{Hmac, Mac};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};
use sha2::Sha256;
use sqlx::{Any, AnyConnection, Row};
use utoipa::ToSchema;

use crate::db::{Backend, Db, now_ms};
use crate::error::{AppError, Result};
use crate::ids::{AssignmentId, ItemId, StudyId, WorkerId, random_token};
use crate::study::{self, MturkMode, Study};

mod answers;
mod consent;
mod outlook;
mod resume;
mod sqlite_writes;
mod training;

pub use answers::{AnswerAck, AnswerRequest, answer};
pub(crate) use answers::COMPLETE;
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

/// The answers the demographics' `gender` accepts (empty: not answered).
pub const GENDERS: &[&str] = &["female", "male", "other", "undisclosed", ""];
/// The answers the demographics' `art_experience` accepts (empty: not answered).
pub const ART_EXPERIENCE: &[&str] = &["none", "some", "professional", ""];

/// Optional demographics asked at the start.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Demographics {
    /// `female`, `male`, `other`, `undisclosed`.
    #[schema(value_type = Option<crate::api::schema::Gender>)]
    pub gender: Option<String>,
    /// `none`, `some`, `professional`.
    #[schema(value_type = Option<crate::api::schema::ArtExperience>)]
    pub art_experience: Option<String>,
}

impl Demographics {
    fn validate(&self) -> Result<()> {
        if let Some(g) = &self.gender
            && !GENDERS.contains(&g.as_str())
        {
            return Err(AppError::BadRequest(
                "gender: one of female, male, other, undisclosed".into(),
            ));
        }
        if let Some(a) = &self.art_experience
            && !ART_EXPERIENCE.contains(&a.as_str())
        {
            return Err(AppError::BadRequest(
                "art_experience: one of none, some, professional".into(),
            ));
        }
        Ok(())
    }
}

/// Start parameters, as the crowd platform passes them (MTurk and Prolific names are accepted
/// by the HTML start page and mapped onto these). Every id present must have the form of an
/// external id (1-128 letters, digits and `-_.:@`), whatever the source.
#[derive(Debug, Clone, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct StartRequest {
    /// `mturk`, `prolific` or `direct` (default: `mturk` with `turk_submit_to` or `hit_id`,
    /// `prolific` with `prolific_session_id`, else `direct`).
    pub source: Option<Source>,
    /// MTurk workerId, Prolific PROLIFIC_PID or a direct participant id; required except in an
    /// MTurk preview.
    #[schema(pattern = "^[A-Za-z0-9._:@-]{1,128}$")]
    pub worker_id: Option<String>,
    /// MTurk assignmentId (`ASSIGNMENT_ID_NOT_AVAILABLE` in preview; required for MTurk).
    #[schema(pattern = "^[A-Za-z0-9._:@-]{1,128}$")]
    pub assignment_id: Option<String>,
    /// MTurk hitId (required for MTurk).
    #[schema(pattern = "^[A-Za-z0-9._:@-]{1,128}$")]
    pub hit_id: Option<String>,
    /// MTurk turkSubmitTo: the MTurk site of the study's `mturk_mode` (required for MTurk).
    #[schema(pattern = "^https://(www|workersandbox)\\.mturk\\.com/*$")]
    pub turk_submit_to: Option<String>,
    /// Prolific STUDY_ID (required for Prolific).
    #[schema(pattern = "^[A-Za-z0-9._:@-]{1,128}$")]
    pub prolific_study_id: Option<String>,
    /// Prolific SESSION_ID (required for Prolific).
    #[schema(pattern = "^[A-Za-z0-9._:@-]{1,128}$")]
    pub prolific_session_id: Option<String>,
    /// Optional demographics.
    pub demographics: Option<Demographics>,
    /// The answer to the study's informed-consent form, when it has one (`consent` in the
    /// settings): `true` agrees and starts, `false` declines (recorded; the task ends with the
    /// no-consent hand-back). Required for a first start of such a study; ignored on resume.
    pub consent: Option<bool>,
}

impl StartRequest {
    /// Checks the form of every field present, whatever the source (the schema describes each
    /// field alone); what the source requires is checked in [`start`].
    fn check_forms(&self) -> Result<()> {
        for (field, value) in [
            ("worker_id", &self.worker_id),
            ("assignment_id", &self.assignment_id),
            ("hit_id", &self.hit_id),
            ("prolific_study_id", &self.prolific_study_id),
            ("prolific_session_id", &self.prolific_session_id),
        ] {
            if let Some(v) = value {
                valid_external(field, v)?;
            }
        }
        if let Some(to) = &self.turk_submit_to {
            submit_site(to)?;
        }
        self.demographics.clone().unwrap_or_default().validate()
    }
}

/// What starting did.
#[derive(Debug, Clone, Serialize, ToSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum StartOutcome {
    /// MTurk preview: nothing stored; show the task description.
    Preview {
        /// Study description.
        description: String,
        /// Whether this is the MTurk sandbox.
        sandbox: bool,
    },
    /// An assignment exists (new or resumed): continue at `/api/v1/assignments/{token}`.
    Started {
        /// The assignment's bearer token (unguessable; keep it secret).
        token: String,
        /// Whether the worker already had this assignment.
        resumed: bool,
    },
}

fn valid_external(field: &str, value: &str) -> Result<()> {
    if value.is_empty()
        || value.len() > 128
        || !value
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.:@".contains(c))
    {
        return Err(AppError::BadRequest(format!(
            "{field}: 1-128 characters of letters, digits and -_.:@"
        )));
    }
    Ok(())
}

/// Whether `turkSubmitTo` is MTurk's sandbox (true) or live site (false).
fn submit_site(value: &str) -> Result<bool> {
    match value.trim_end_matches('/') {
        "https://workersandbox.mturk.com" => Ok(true),
        "https://www.mturk.com" => Ok(false),
        _ => Err(AppError::BadRequest(
            "turk_submit_to: not an MTurk submit address".into(),
        )),
    }
}

/// Parses and checks `turkSubmitTo` against the study's MTurk mode.
fn check_submit_to(value: &str, mode: MturkMode) -> Result<bool> {
    let sandbox = submit_site(value)?;
    if sandbox != (mode == MturkMode::Sandbox) {
        return Err(AppError::BadRequest(format!(
            "this study runs on the MTurk {} site, but the HIT came from the {} site",
            if mode == MturkMode::Sandbox {
                "SANDBOX"
            } else {
                "LIVE"
            },
            if sandbox { "SANDBOX" } else { "LIVE" },
        )));
    }
    Ok(sandbox)
}

/// Starts (or resumes) a worker's assignment.
pub async fn start(db: &Db, study: &Study, req: StartRequest) -> Result<StartOutcome> {
    // A study whose tuple pool is still being written (or failed) has no HIT to give: its
    // first slots would be all there is.
    study.check_open()?;
    req.check_forms()?;
    let source = req
        .source
        .unwrap_or(if req.turk_submit_to.is_some() || req.hit_id.is_some() {
            Source::Mturk
        } else if req.prolific_session_id.is_some() {
            Source::Prolific
        } else {
            Source::Direct
        });
    let sandbox = match source {
        Source::Mturk => {
            let submit = req
                .turk_submit_to
                .as_deref()
                .ok_or_else(|| AppError::BadRequest("turk_submit_to: required for MTurk".into()))?;
            let sandbox = check_submit_to(submit, study.settings.mturk_mode)?;
            if req.assignment_id.as_deref() == Some(MTURK_PREVIEW) {
                return Ok(StartOutcome::Preview {
                    description: study.settings.description.clone(),
                    sandbox,
                });
            }
            valid_external(
                "assignment_id",
                req.assignment_id.as_deref().unwrap_or_default(),
            )?;
            valid_external("hit_id", req.hit_id.as_deref().unwrap_or_default())?;
            sandbox
        }
        Source::Prolific => {
            valid_external(
                "prolific_study_id",
                req.prolific_study_id.as_deref().unwrap_or_default(),
            )?;
            valid_external(
                "prolific_session_id",
                req.prolific_session_id.as_deref().unwrap_or_default(),
            )?;
            false
        }
        Source::Direct => false,
    };
    let external = req.worker_id.as_deref().ok_or_else(|| {
        AppError::BadRequest("worker_id: required (except in an MTurk preview)".into())
    })?;
    valid_external("worker_id", external)?;
    // Validated by `check_forms`.
    let demographics = req.demographics.clone().unwrap_or_default();

    if study.settings.blocked_workers.iter().any(|b| b == external) {
        return Err(AppError::Forbidden(
            "you are not eligible for this study".into(),
        ));
    }
    // Read-only checks first: a worker we have never seen has no earlier assignment.
    let known = find_worker(db, source, external).await?;
    if let Some(worker) = known {
        check_exclusions(db, study, worker).await?;
        if let Some(token) = existing_token(db, study.id, worker).await? {
            return Ok(StartOutcome::Started {
                token,
                resumed: true,
            });
        }
    }
    let consent = match (consent::required(study), req.consent) {
        (false, _) => None,
        (true, Some(true)) => Some(consent_version(&study.settings.consent)),
        (true, Some(false)) => {
            let new = NewAssignment {
                id: AssignmentId::generate(),
                token: random_token(),
                study: study.id,
                source,
                sandbox,
                status: "declined",
                demographics: serde_json::to_string(&demographics).map_err(AppError::internal)?,
                consent: Some(("declined", consent_version(&study.settings.consent))),
                req: req.clone(),
            };
            return consent::decline(db, study, new, external).await;
        }
        (true, None) => {
            return Err(AppError::BadRequest(
                "consent: this study asks for informed consent first; send consent: true to \
                 agree or false to decline"
                    .into(),
            ));
        }
    };
    let training = !training::pool(db, study.id).await?.is_empty();
    let rng = rand_chacha::ChaCha8Rng::seed_from_u64(rand::rng().random());
    let controls = if training {
        Vec::new()
    } else {
        hit_controls(db, study).await?
    };
    let external = external.to_string();
    let new = NewAssignment {
        id: AssignmentId::generate(),
        token: random_token(),
        study: study.id,
        source,
        sandbox,
        status: if training { "training" } else { "active" },
        demographics: serde_json::to_string(&demographics).map_err(AppError::internal)?,
        consent: consent.map(|version| ("agreed", version)),
        req,
    };
    let allocation = Allocation {
        new,
        known,
        external,
        training,
        study: study.clone(),
        controls,
        rng,
    };
    // One write transaction for the worker, the assignment and (without training) the whole
    // HIT: a HIT is never visible half-allocated. On SQLite it is a job of the answer writer,
    // committed together with the answers (one fsync for both) instead of waiting for its
    // turn between their batches.
    let outcome = match db.backend {
        Backend::Sqlite => {
            db.answers
                .job(move |conn| allocation.run_sqlite(conn))
                .await?
        }
        Backend::Postgres => {
            let mut tx = db.begin_write().await?;
            let outcome = allocation.run(&mut tx).await?;
            match outcome {
                Allocated::New(_) => tx.commit().await?,
                Allocated::Raced(_) => tx.rollback().await?,
            }
            outcome
        }
    };
    match outcome {
        Allocated::New(token) => Ok(StartOutcome::Started {
            token,
            resumed: false,
        }),
        Allocated::Raced(worker) => {
            // A concurrent start of the same worker won the race: resume theirs.
            let token = existing_token(db, study.id, worker)
                .await?
                .ok_or(AppError::Internal("assignment vanished".into()))?;
            Ok(StartOutcome::Started {
                token,
                resumed: true,
            })
        }
    }
}

/// The writes of a [`start`]: worker, assignment and, without training, the HIT.
struct Allocation {
    new: NewAssignment,
    known: Option<WorkerId>,
    external: String,
    training: bool,
    study: Study,
    controls: Vec<i64>,
    rng: rand_chacha::ChaCha8Rng,
}

/// What an [`Allocation`] did.
enum Allocated {
    /// The new assignment's token.
    New(String),
    /// The worker (with this id) already has an assignment in the study: nothing was written
    /// but possibly the worker row, which the caller rolls back or keeps (harmless).
    Raced(WorkerId),
}

impl Allocation {
    /// Runs inside one transaction (PostgreSQL; SQLite: [`Allocation::run_sqlite`]); an error
    /// leaves it to be rolled back.
    async fn run(mut self, tx: &mut AnyConnection) -> Result<Allocated> {
        let row = sqlx::query(SETTINGS_NOW_POSTGRES)
            .bind(self.study.id.0)
            .fetch_one(&mut *tx)
            .await?;
        let now = parse_settings(&row.try_get::<String, _>("settings")?)?;
        check_unchanged(&self.study.settings, &now, Some(&self.external))?;
        let worker = match self.known {
            Some(w) => w,
            None => ensure_worker(tx, self.new.source, &self.external).await?,
        };
        if !self.new.insert(tx, worker).await? {
            return Ok(Allocated::Raced(worker));
        }
        if !self.training {
            // No free slot left: the error rolls the assignment back as well.
            fill_hit(
                tx,
                &self.study,
                self.new.id,
                worker,
                &self.controls,
                &mut self.rng,
            )
            .await?;
        }
        Ok(Allocated::New(self.new.token))
    }
}

/// The study's settings as stored now, read first in an allocation's transaction. On
/// PostgreSQL with `FOR KEY SHARE`, which conflicts with the `FOR UPDATE` of a settings edit
/// ([`crate::study_edit::edit`]): an edit that locked the row first commits before this read,
/// which then sees it; an edit that comes later waits for this allocation and then sees its
/// assignment (and refuses to change the HIT shape). On SQLite the allocation runs in the
/// answer writer's transaction, which every other writer waits for
/// ([`crate::study::settings_sqlite`]).
const SETTINGS_NOW_POSTGRES: &str = "SELECT settings FROM studies WHERE id = $1 FOR KEY SHARE";

fn parse_settings(json: &str) -> Result<study::StudySettings> {
    serde_json::from_str(json).map_err(AppError::internal)
}

/// Refuses an allocation if, since the request read the study, the settings changed in what
/// shapes a HIT (`questions_per_hit`, `controls_per_hit`) or binds it to an MTurk site, or the
/// worker (`external`, when known) was blocked: the request's checks and the HIT would
/// otherwise follow settings that are no longer the study's. A retry reads the new ones.
fn check_unchanged(
    used: &study::StudySettings,
    now: &study::StudySettings,
    external: Option<&str>,
) -> Result<()> {
    if used.questions_per_hit != now.questions_per_hit
        || used.controls_per_hit != now.controls_per_hit
        || used.mturk_mode != now.mturk_mode
    {
        return Err(AppError::Conflict(
            "the study's settings changed while this HIT was being started; please retry".into(),
        ));
    }
    if let Some(worker) = external
        && now.blocked_workers.iter().any(|b| b == worker)
    {
        return Err(AppError::Forbidden(
            "you are not eligible for this study".into(),
        ));
    }
    Ok(())
}

/// Refuses workers who took part in one of the studies this one excludes.
async fn check_exclusions(db: &Db, study: &Study, worker: WorkerId) -> Result<()> {
    for earlier in &study.settings.exclude_workers_of {
        let seen = sqlx::query("SELECT id FROM assignments WHERE study_id = $1 AND worker_id = $2")
            .bind(earlier.0)
            .bind(worker.0)
            .fetch_optional(&db.pool)
            .await?;
        if seen.is_some() {
            return Err(AppError::Forbidden(
                "you are not eligible for this study (you took part in an earlier one)".into(),
            ));
        }
    }
    Ok(())
}

/// A new assignment, inserted by [`start`].
struct NewAssignment {
    id: AssignmentId,
    token: String,
    study: StudyId,
    source: Source,
    sandbox: bool,
    /// `training`, or `active` when the study has no training (the HIT is allocated with it),
    /// or `declined`.
    status: &'static str,
    demographics: String,
    /// The consent record: (`agreed` or `declined`, version of the text shown).
    consent: Option<(&'static str, String)>,
    req: StartRequest,
}

/// A new assignment (`$1` id … `$14` start time, in the column order); nothing when the worker
/// already has one in the study.
const INSERT_ASSIGNMENT: &str = "INSERT INTO assignments (id, token, study_id, worker_id, \
     source, sandbox, external_assignment, hit_id, submit_to, prolific_study, prolific_session, \
     demographics, status, training_attempts, started_at) \
     VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, 0, $14) \
     ON CONFLICT DO NOTHING";

impl NewAssignment {
    /// MTurk's submit URL as stored: without a trailing slash.
    fn submit_to(&self) -> Option<String> {
        self.req
            .turk_submit_to
            .as_deref()
            .map(|s| s.trim_end_matches('/').to_string())
    }

    /// Inserts it; `false` when the worker already has an assignment in this study.
    async fn insert(&self, tx: &mut AnyConnection, worker: WorkerId) -> Result<bool> {
        let req = &self.req;
        let inserted = sqlx::query(INSERT_ASSIGNMENT)
            .bind(self.id.0)
            .bind(&self.token)
            .bind(self.study.0)
            .bind(worker.0)
            .bind(self.source.as_str())
            .bind(i64::from(self.sandbox))
            .bind(req.assignment_id.clone())
            .bind(req.hit_id.clone())
            .bind(self.submit_to())
            .bind(req.prolific_study_id.clone())
            .bind(req.prolific_session_id.clone())
            .bind(&self.demographics)
            .bind(self.status)
            .bind(now_ms())
            .execute(&mut *tx)
            .await?;
        if inserted.rows_affected() != 1 {
            return Ok(false);
        }
        if let Some((answer, version)) = &self.consent {
            sqlx::query(consent::RECORD)
                .bind(*answer)
                .bind(version)
                .bind(now_ms())
                .bind(self.id.0)
                .execute(&mut *tx)
                .await?;
        }
        Ok(true)
    }
}

async fn find_worker(db: &Db, source: Source, external: &str) -> Result<Option<WorkerId>> {
    let row = sqlx::query("SELECT id FROM workers WHERE source = $1 AND external_id = $2")
        .bind(source.as_str())
        .bind(external)
        .fetch_optional(&db.pool)
        .await?;
    Ok(match row {
        Some(r) => Some(WorkerId(r.try_get("id")?)),
        None => None,
    })
}

/// Creates the worker unless a concurrent request just did; returns its id.
/// Creates worker `$1` (`$2` source, `$3` external id, `$4` time) unless it exists.
const INSERT_WORKER: &str = "INSERT INTO workers (id, source, external_id, created_at) \
     VALUES ($1, $2, $3, $4) ON CONFLICT DO NOTHING";

/// The id of the worker with source `$1` and external id `$2`.
const WORKER_ID: &str = "SELECT id FROM workers WHERE source = $1 AND external_id = $2";

async fn ensure_worker(tx: &mut AnyConnection, source: Source, external: &str) -> Result<WorkerId> {
    sqlx::query(INSERT_WORKER)
        .bind(WorkerId::generate().0)
        .bind(source.as_str())
        .bind(external)
        .bind(now_ms())
        .execute(&mut *tx)
        .await?;
    let row = sqlx::query(WORKER_ID)
        .bind(source.as_str())
        .bind(external)
        .fetch_one(&mut *tx)
        .await?;
    Ok(WorkerId(row.try_get("id")?))
}

async fn existing_token(db: &Db, study: StudyId, worker: WorkerId) -> Result<Option<String>> {
    let row = sqlx::query("SELECT token FROM assignments WHERE study_id = $1 AND worker_id = $2")
        .bind(study.0)
        .bind(worker.0)
        .fetch_optional(&db.pool)
        .await?;
    Ok(match row {
        Some(r) => Some(r.try_get("token")?),
        None => None,
    })
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

/// One triplet as the worker sees it: "Is `reference` more similar in style to `left` or to
/// `right`?"
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct QuestionView {
    /// Position in the HIT (answers are keyed by it); for training, the index.
    pub position: i64,
    /// A.
    pub reference: ItemRef,
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

fn view(position: i64, a: i64, b: i64, c: i64, swapped: bool) -> QuestionView {
    let (left, right) = if swapped { (c, b) } else { (b, c) };
    QuestionView {
        position,
        reference: ItemRef::new(a),
        left: ItemRef::new(left),
        right: ItemRef::new(right),
    }
}

/// The questions of an assignment's next training attempt.
pub async fn training_questions(db: &Db, a: &Assignment) -> Result<Vec<QuestionView>> {
    training::questions(db, &study::load(db, a.study).await?, a).await
}

/// One training answer.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TrainingAnswer {
    /// The question's position.
    pub position: i64,
    /// The chosen item.
    pub choice: ItemId,
}

/// Feedback on one training answer.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct TrainingFeedback {
    /// The question's position.
    pub position: i64,
    /// Whether the answer was right.
    pub correct: bool,
    /// The right answer (training questions are not controls, so this may be shown).
    pub expected: ItemId,
}

/// The result of a training attempt.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct TrainingResult {
    /// All answers right: the HIT has started.
    pub passed: bool,
    /// Per-question feedback.
    pub feedback: Vec<TrainingFeedback>,
    /// Attempts used so far (including this one).
    pub attempts: i64,
    /// Attempts left before the worker is screened out.
    pub attempts_left: i64,
    /// The assignment's status after this attempt.
    pub status: String,
}

/// Scores a training attempt; all right → the HIT is allocated; too many attempts → screened out.
pub async fn submit_training(
    db: &Db,
    study: &Study,
    a: &Assignment,
    answers: &[TrainingAnswer],
) -> Result<TrainingResult> {
    if a.status != "training" {
        return Err(AppError::Conflict(format!(
            "training is over (assignment is {})",
            a.status
        )));
    }
    let tuples = training::next_attempt(db, study, a).await?;
    if answers.len() != tuples.len() {
        return Err(AppError::BadRequest(format!(
            "expected {} training answers, got {}",
            tuples.len(),
            answers.len()
        )));
    }
    let attempt = a.training_attempts + 1;
    let mut feedback = Vec::with_capacity(tuples.len());
    let mut tx = db.begin_write().await?;
    // Claim the attempt number first: a concurrent duplicate submit finds it taken.
    let bumped = sqlx::query(
        "UPDATE assignments SET training_attempts = $1 WHERE id = $2 AND status = 'training' \
         AND training_attempts = $3",
    )
    .bind(attempt)
    .bind(a.id.0)
    .bind(a.training_attempts)
    .execute(&mut *tx)
    .await?;
    if bumped.rows_affected() == 0 {
        return Err(AppError::Conflict(
            "this training attempt was already submitted".into(),
        ));
    }
    let now = now_ms();
    for (i, (t, _, b, c)) in tuples.iter().enumerate() {
        let answer = answers
            .iter()
            .find(|x| x.position == i as i64)
            .ok_or_else(|| AppError::BadRequest(format!("no answer for training question {i}")))?;
        if answer.choice.0 != *b && answer.choice.0 != *c {
            return Err(AppError::BadRequest(format!(
                "training question {i}: choice is not one of the two options"
            )));
        }
        let correct = answer.choice.0 == *b;
        sqlx::query(
            "INSERT INTO training_answers (assignment_id, attempt, tuple_id, choice, correct, answered_at) \
             VALUES ($1, $2, $3, $4, $5, $6)",
        )
        .bind(a.id.0)
        .bind(attempt)
        .bind(t.0)
        .bind(if correct { "b" } else { "c" })
        .bind(i64::from(correct))
        .bind(now)
        .execute(&mut *tx)
        .await?;
        feedback.push(TrainingFeedback {
            position: i as i64,
            correct,
            expected: ItemId(*b),
        });
    }
    let passed = feedback.iter().all(|f| f.correct);
    let max = i64::from(study.settings.max_training_attempts);
    let status = if passed {
        "training"
    } else if attempt >= max {
        sqlx::query(
            "UPDATE assignments SET status = 'screened_out', completed_at = $1 WHERE id = $2",
        )
        .bind(now)
        .bind(a.id.0)
        .execute(&mut *tx)
        .await?;
        "screened_out"
    } else {
        "training"
    };
    tx.commit().await?;
    let status = if passed {
        allocate(db, study, a.id, a.worker).await?;
        "active"
    } else {
        status
    };
    Ok(TrainingResult {
        passed,
        feedback,
        attempts: attempt,
        attempts_left: (max - attempt).max(0),
        status: status.into(),
    })
}

/// A worker gives up the training: screened out (paid a screen-out, not rejected).
pub async fn give_up(db: &Db, a: &Assignment) -> Result<()> {
    let done = sqlx::query(
        "UPDATE assignments SET status = 'screened_out', completed_at = $1 WHERE id = $2 \
         AND status = 'training'",
    )
    .bind(now_ms())
    .bind(a.id.0)
    .execute(&mut *db.write_conn().await?)
    .await?;
    if done.rows_affected() == 0 && a.status != "screened_out" {
        return Err(AppError::Conflict(format!(
            "only a worker in training can give up (assignment is {})",
            a.status
        )));
    }
    Ok(())
}

/// Expires assignments that started more than `older_than_ms` ago and are still in training or
/// answering: they become `abandoned` (further answers are refused) and the slots of their
/// unanswered questions are freed for other workers. Answers already given are kept. Returns
/// the number of expired assignments.
pub async fn release_abandoned(db: &Db, study: StudyId, older_than_ms: i64) -> Result<usize> {
    let cutoff = now_ms() - older_than_ms.max(0);
    let rows = sqlx::query(
        "SELECT id FROM assignments WHERE study_id = $1 AND status IN ('training', 'active') \
         AND started_at <= $2",
    )
    .bind(study.0)
    .bind(cutoff)
    .fetch_all(&db.pool)
    .await?;
    let mut released = 0;
    for r in rows {
        let id = AssignmentId(r.try_get("id")?);
        let mut tx = db.begin_write().await?;
        if end_open_assignment(&mut tx, id).await? {
            released += 1;
        }
        tx.commit().await?;
    }
    Ok(released)
}

/// Ends an assignment still in training or answering, inside `tx`: it becomes `abandoned`
/// (further answers are refused) and the slots of its unanswered questions are freed for
/// other workers; answers already given are kept. `false` if it was not open.
pub(crate) async fn end_open_assignment(tx: &mut AnyConnection, id: AssignmentId) -> Result<bool> {
    let moved = sqlx::query(
        "UPDATE assignments SET status = 'abandoned', completed_at = $1 WHERE id = $2 \
         AND status IN ('training', 'active')",
    )
    .bind(now_ms())
    .bind(id.0)
    .execute(&mut *tx)
    .await?;
    if moved.rows_affected() == 0 {
        return Ok(false);
    }
    sqlx::query(
        "UPDATE slots SET assignment_id = NULL, worker_id = NULL, claimed_at = NULL \
         WHERE assignment_id = $1 AND id IN \
         (SELECT slot_id FROM questions WHERE assignment_id = $1 AND choice IS NULL \
          AND slot_id IS NOT NULL)",
    )
    .bind(id.0)
    .execute(&mut *tx)
    .await?;
    sqlx::query("UPDATE questions SET slot_id = NULL WHERE assignment_id = $1 AND choice IS NULL")
        .bind(id.0)
        .execute(&mut *tx)
        .await?;
    Ok(true)
}

/// Allocates the HIT of an assignment that has passed its training: moves it from `training`
/// to `active` and fills it, in one write transaction (on SQLite a job of the answer writer,
/// sharing the answers' commit). Returns the number of questions; 0 when a concurrent request
/// had already allocated it.
pub async fn allocate(
    db: &Db,
    study: &Study,
    assignment: AssignmentId,
    worker: WorkerId,
) -> Result<usize> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(rand::rng().random());
    let controls = hit_controls(db, study).await?;
    if db.backend == Backend::Sqlite {
        let study = study.clone();
        return db
            .answers
            .job(move |conn| {
                sqlite_writes::allocate(conn, &study, assignment, worker, &controls, &mut rng)
            })
            .await;
    }
    let mut tx = db.begin_write().await?;
    let row = sqlx::query(SETTINGS_NOW_POSTGRES)
        .bind(study.id.0)
        .fetch_one(&mut *tx)
        .await?;
    check_unchanged(
        &study.settings,
        &parse_settings(&row.try_get::<String, _>("settings")?)?,
        None,
    )?;
    let moved = sqlx::query(ACTIVATE)
        .bind(assignment.0)
        .execute(&mut *tx)
        .await?;
    if moved.rows_affected() == 0 {
        // Already allocated by a concurrent request.
        return Ok(0);
    }
    let n = fill_hit(&mut tx, study, assignment, worker, &controls, &mut rng).await?;
    tx.commit().await?;
    Ok(n)
}

/// Moves assignment `$1` from training to answering.
const ACTIVATE: &str =
    "UPDATE assignments SET status = 'active' WHERE id = $1 AND status = 'training'";

/// The hidden controls of a new HIT, drawn uniformly without replacement (read before the
/// write transaction so that it does not hold the writer). The database draws them: a study
/// has ~100 controls and a HIT 5, and each row a sqlx read returns is one hand-off between
/// threads.
async fn hit_controls(db: &Db, study: &Study) -> Result<Vec<i64>> {
    let rows = sqlx::query(
        "SELECT id FROM tuples WHERE study_id = $1 AND kind = 'control' \
         ORDER BY random() LIMIT $2",
    )
    .bind(study.id.0)
    .bind(i64::from(study.settings.controls_per_hit))
    .fetch_all(&db.pool)
    .await?;
    Ok(rows
        .iter()
        .map(|r| r.try_get("id"))
        .collect::<Result<_, _>>()?)
}

/// One question of a new HIT, at its index's position.
struct NewQuestion {
    tuple: i64,
    /// The claimed slot (`None`: a hidden control).
    slot: Option<i64>,
    /// B and C shown the other way round.
    swapped: bool,
    /// Ask the reasons questionnaire after it.
    ask_reasons: bool,
}

/// The questions of a HIT from its claimed (slot, tuple) pairs and its controls, in random
/// positions, each shown swapped with probability ½ and asking for reasons with the study's
/// probability. No claimed slot is a conflict: the study has no more questions to give.
fn hit_questions(
    claimed: &[(i64, i64)],
    controls: &[i64],
    settings: &study::StudySettings,
    rng: &mut impl Rng,
) -> Result<Vec<NewQuestion>> {
    if claimed.is_empty() {
        return Err(AppError::Conflict(
            "this study has no more questions available".into(),
        ));
    }
    let mut drawn: Vec<(i64, Option<i64>)> = claimed.iter().map(|&(s, t)| (t, Some(s))).collect();
    drawn.extend(controls.iter().map(|&t| (t, None)));
    drawn.shuffle(rng);
    Ok(drawn
        .into_iter()
        .map(|(tuple, slot)| {
            let ask_reasons = rng.random_bool(settings.reasons_probability);
            NewQuestion {
                tuple,
                slot,
                swapped: rng.random_bool(0.5),
                ask_reasons,
            }
        })
        .collect())
}

/// Fills a HIT inside `tx` (PostgreSQL; SQLite: [`sqlite_writes`]): claims up to `questions -
/// controls` free slots of distinct tuples the worker has never seen (conditional `UPDATE`s: a
/// slot is filled by exactly one assignment), adds the hidden controls, shuffles positions. A
/// study without a free slot is a conflict (the caller's transaction is then rolled back).
async fn fill_hit(
    tx: &mut AnyConnection,
    study: &Study,
    assignment: AssignmentId,
    worker: WorkerId,
    controls: &[i64],
    rng: &mut impl Rng,
) -> Result<usize> {
    let claim = SlotClaim::new(study, assignment, worker, rng);
    let claimed = claim.one_per_statement(tx).await?;
    let questions = hit_questions(&claimed, controls, &study.settings, rng)?;
    // One multi-row INSERT instead of one statement per question (one round trip).
    let sql = questions_insert_sql(questions.len());
    let mut insert = sqlx::query(sqlx::AssertSqlSafe(sql));
    for (position, q) in questions.iter().enumerate() {
        insert = insert
            .bind(assignment.0)
            .bind(position as i64)
            .bind(q.tuple)
            .bind(q.slot)
            .bind(i64::from(q.swapped))
            .bind(i64::from(q.ask_reasons));
    }
    insert.execute(&mut *tx).await?;
    Ok(questions.len())
}

/// Claims up to `wanted` free slots of distinct tuples for one assignment, scanning tuples in
/// `seq` order from `start` and wrapping around once. A worker has one assignment per study, so
/// it holds no other slot of this study; the unique index on (tuple_id, worker_id) stays the
/// hard guarantee of distinct tuples, and the outer `assignment_id IS NULL` the final guard
/// against a double fill.
struct SlotClaim {
    assignment: AssignmentId,
    worker: WorkerId,
    study: StudyId,
    now: i64,
    wanted: usize,
    start: i64,
}

impl SlotClaim {
    /// The claim of one HIT: `questions - controls` slots, starting at a random tuple (and
    /// wrapping around once), so that concurrent allocators spread over the table instead of
    /// all scanning (and, on PostgreSQL, skipping) the same first free rows.
    fn new(study: &Study, assignment: AssignmentId, worker: WorkerId, rng: &mut impl Rng) -> Self {
        let s = &study.settings;
        Self {
            assignment,
            worker,
            study: study.id,
            now: now_ms(),
            wanted: (s.questions_per_hit - s.controls_per_hit) as usize,
            start: rng.random_range(-1..i64::from(s.tuples).max(0)),
        }
    }

    /// Binds `$1..$6` of the PostgreSQL claim statement: who claims, when, in which study, and
    /// the open `seq` range.
    fn bind_claim<'q>(
        &self,
        query: sqlx::query::Query<'q, Any, sqlx::any::AnyArguments>,
        lower: i64,
        upper: i64,
    ) -> sqlx::query::Query<'q, Any, sqlx::any::AnyArguments> {
        query
            .bind(self.assignment.0)
            .bind(self.worker.0)
            .bind(self.now)
            .bind(self.study.0)
            .bind(lower)
            .bind(upper)
    }

    /// PostgreSQL: one claim per statement, the first free slot after the previously claimed
    /// tuple; the row lock is taken on that slot only and rows other allocators are claiming
    /// are skipped, so concurrent allocations neither wait on nor deadlock with each other.
    async fn one_per_statement(&self, tx: &mut AnyConnection) -> Result<Vec<(i64, i64)>> {
        let mut claimed = Vec::with_capacity(self.wanted);
        let (mut lower, mut upper) = (self.start, i64::MAX);
        let (mut first_seq, mut wrapped) = (None, false);
        while claimed.len() < self.wanted {
            let query = sqlx::query(
                "UPDATE slots SET assignment_id = $1, worker_id = $2, claimed_at = $3 \
                 WHERE assignment_id IS NULL AND id = (SELECT s.id FROM slots s \
                   WHERE s.study_id = $4 AND s.assignment_id IS NULL AND s.seq > $5 AND s.seq < $6 \
                   ORDER BY s.seq, s.replica LIMIT 1 FOR UPDATE OF s SKIP LOCKED) \
                 RETURNING id, tuple_id, seq",
            );
            let row = self
                .bind_claim(query, lower, upper)
                .fetch_optional(&mut *tx)
                .await?;
            match row {
                Some(r) => {
                    claimed.push((r.try_get("id")?, r.try_get("tuple_id")?));
                    lower = r.try_get("seq")?;
                    first_seq.get_or_insert(lower);
                }
                None if !wrapped => {
                    wrapped = true;
                    upper = first_seq.unwrap_or(self.start + 1);
                    lower = -1;
                }
                None => break,
            }
        }
        Ok(claimed)
    }
}

/// `INSERT INTO questions … VALUES ($1…$6), ($7…$12), …` for `rows` rows. Only placeholders are
/// generated here; every value is bound (a HIT has at most a few hundred questions, far below
/// either database's parameter limit).
fn questions_insert_sql(rows: usize) -> String {
    let mut sql = String::from(
        "INSERT INTO questions (assignment_id, position, tuple_id, slot_id, swapped, ask_reasons) VALUES ",
    );
    for row in 0..rows {
        let p = row * 6;
        if row > 0 {
            sql.push_str(", ");
        }
        sql.push_str(&format!(
            "(${}, ${}, ${}, ${}, ${}, ${})",
            p + 1,
            p + 2,
            p + 3,
            p + 4,
            p + 5,
            p + 6
        ));
    }
    sql
}

/// The reasons a worker may give, grouped by attribute (Garces et al. 2016 §6.3.2).
pub const REASONS: &[(&str, &str, &str)] = &[
    ("colour", "colour_palette", "Similar colours"),
    (
        "colour",
        "colour_saturation",
        "Similar saturation / brightness",
    ),
    ("shading", "shading_flat", "Both flat / both shaded"),
    (
        "shading",
        "shading_gradients",
        "Similar gradients or highlights",
    ),
    ("texture", "texture", "Similar texture or pattern"),
    ("stroke", "stroke_width", "Similar outline thickness"),
    ("stroke", "stroke_presence", "Both have / lack outlines"),
    (
        "shape",
        "shape_geometry",
        "Similar shapes (round, angular…)",
    ),
    ("shape", "shape_detail", "Similar level of detail"),
    ("other", "other", "Something else"),
];

/// Answers to the "why did you choose?" questionnaire.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ReasonsRequest {
    /// The question's position.
    pub position: i64,
    /// Reason codes (may be empty to skip).
    #[schema(value_type = Vec<crate::api::schema::ReasonCode>, max_items = 10)]
    pub reasons: Vec<String>,
    /// Optional free text (at most 1000 characters).
    #[schema(max_length = 1000)]
    pub text: Option<String>,
}

/// Stores the questionnaire of a question that asked for it (idempotent: first answer wins).
pub async fn submit_reasons(db: &Db, a: &Assignment, req: &ReasonsRequest) -> Result<()> {
    if req.reasons.len() > REASONS.len() {
        return Err(AppError::BadRequest("reasons: too many".into()));
    }
    for r in &req.reasons {
        if !REASONS.iter().any(|(_, code, _)| code == r) {
            return Err(AppError::BadRequest(format!("reasons: unknown code {r:?}")));
        }
    }
    // Counted before trimming, as the schema's maxLength counts.
    if req
        .text
        .as_deref()
        .is_some_and(|t| t.chars().count() > 1000)
    {
        return Err(AppError::BadRequest("text: at most 1000 characters".into()));
    }
    let text = req.text.as_deref().map(str::trim).filter(|t| !t.is_empty());
    let row = sqlx::query(
        "SELECT ask_reasons, choice FROM questions WHERE assignment_id = $1 AND position = $2",
    )
    .bind(a.id.0)
    .bind(req.position)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("question"))?;
    if row.try_get::<i64, _>("ask_reasons")? == 0 {
        return Err(AppError::BadRequest(
            "this question has no questionnaire".into(),
        ));
    }
    if row.try_get::<Option<String>, _>("choice")?.is_none() {
        return Err(AppError::Conflict("answer the question first".into()));
    }
    sqlx::query(
        "UPDATE questions SET reasons = $1, reason_text = $2 WHERE assignment_id = $3 \
         AND position = $4 AND reasons IS NULL",
    )
    .bind(serde_json::to_string(&req.reasons).map_err(AppError::internal)?)
    .bind(text)
    .bind(a.id.0)
    .bind(req.position)
    .execute(&mut *db.write_conn().await?)
    .await?;
    Ok(())
}

/// How to hand the worker back to the crowd platform.
#[derive(Debug, Clone, Serialize, ToSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Handback {
    /// POST a form to MTurk's externalSubmit with these fields.
    MturkForm {
        /// Form action.
        action: String,
        /// MTurk assignmentId.
        assignment_id: String,
        /// Our completion code (also sent as a field).
        completion_code: String,
    },
    /// Redirect the browser.
    Redirect {
        /// Address.
        url: String,
    },
    /// Show the code; nothing else to do.
    Code,
    /// Nothing to submit: the worker returns the task on their crowd platform (MTurk HIT,
    /// Prolific study) or closes the page (a participant who did not consent).
    Return,
}

/// Everything the worker client needs to continue: the single source of truth for resume.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct AssignmentState {
    /// `training`, `active`, `completed`, `screened_out`, `declined` (no consent) or
    /// `abandoned` (expired).
    pub status: String,
    /// `mturk`, `prolific`, `direct`.
    pub source: String,
    /// MTurk sandbox (shown as a banner).
    pub sandbox: bool,
    /// Study description.
    pub description: String,
    /// Training questions (while in training).
    pub training: Vec<QuestionView>,
    /// Training attempts used.
    pub training_attempts: i64,
    /// Training attempts allowed.
    pub max_training_attempts: i64,
    /// The questions of the last training attempt with the right answers (after a failed
    /// attempt; empty before the first).
    pub last_training_attempt: Vec<TrainingReview>,
    /// A question whose questionnaire is pending.
    pub reasons_for: Option<i64>,
    /// That question as it was shown.
    pub reasons_question: Option<QuestionView>,
    /// The picture the worker chose in it.
    pub reasons_choice: Option<ItemId>,
    /// The next question to answer.
    pub question: Option<QuestionView>,
    /// Images of the question after it (to preload).
    pub preload: Vec<String>,
    /// Answered questions.
    pub answered: i64,
    /// Questions in the HIT.
    pub total: i64,
    /// Completion code (when completed).
    pub completion_code: Option<String>,
    /// Screen-out code (when screened out).
    pub screenout_code: Option<String>,
    /// How to hand back (when completed or screened out).
    pub handback: Option<Handback>,
}

/// The state of an assignment.
pub async fn state(db: &Db, study: &Study, a: &Assignment) -> Result<AssignmentState> {
    let mut st = AssignmentState {
        status: a.status.clone(),
        source: a.source.clone(),
        sandbox: a.sandbox,
        description: study.settings.description.clone(),
        training: Vec::new(),
        training_attempts: a.training_attempts,
        max_training_attempts: i64::from(study.settings.max_training_attempts),
        last_training_attempt: Vec::new(),
        reasons_for: None,
        reasons_question: None,
        reasons_choice: None,
        question: None,
        preload: Vec::new(),
        answered: 0,
        total: 0,
        completion_code: None,
        screenout_code: None,
        handback: None,
    };
    match a.status.as_str() {
        "training" => {
            st.training = training::questions(db, study, a).await?;
            st.last_training_attempt = training::last_attempt(db, a).await?;
        }
        "abandoned" => {}
        "declined" => st.handback = Some(consent::handback(study, a)),
        "screened_out" => {
            let code = code(&study.secret, "screenout", a.id);
            st.handback = Some(handback(study, a, &code, true));
            st.screenout_code = Some(code);
        }
        _ => {
            let rows = sqlx::query(
                "SELECT q.position, q.swapped, q.choice, q.ask_reasons, q.reasons, t.a, t.b, t.c \
                 FROM questions q JOIN tuples t ON t.id = q.tuple_id WHERE q.assignment_id = $1 \
                 ORDER BY q.position",
            )
            .bind(a.id.0)
            .fetch_all(&db.pool)
            .await?;
            st.total = rows.len() as i64;
            let mut upcoming = Vec::new();
            for r in &rows {
                let position: i64 = r.try_get("position")?;
                let choice: Option<String> = r.try_get("choice")?;
                if choice.is_some() {
                    st.answered += 1;
                    let pending = r.try_get::<i64, _>("ask_reasons")? != 0
                        && r.try_get::<Option<String>, _>("reasons")?.is_none();
                    if pending && st.reasons_for.is_none() {
                        let (b, c): (i64, i64) = (r.try_get("b")?, r.try_get("c")?);
                        st.reasons_for = Some(position);
                        st.reasons_question = Some(view(
                            position,
                            r.try_get("a")?,
                            b,
                            c,
                            r.try_get::<i64, _>("swapped")? != 0,
                        ));
                        st.reasons_choice =
                            Some(ItemId(if choice.as_deref() == Some("b") { b } else { c }));
                    }
                } else if upcoming.len() < 2 {
                    upcoming.push(view(
                        position,
                        r.try_get("a")?,
                        r.try_get("b")?,
                        r.try_get("c")?,
                        r.try_get::<i64, _>("swapped")? != 0,
                    ));
                }
            }
            let mut upcoming = upcoming.into_iter();
            st.question = upcoming.next();
            if let Some(next) = upcoming.next() {
                st.preload = vec![next.reference.url, next.left.url, next.right.url];
            }
            if a.status == "completed" {
                let code = code(&study.secret, "complete", a.id);
                st.handback = Some(handback(study, a, &code, false));
                st.completion_code = Some(code);
            }
        }
    }
    Ok(st)
}

fn handback(study: &Study, a: &Assignment, code: &str, screened_out: bool) -> Handback {
    match a.source.as_str() {
        "mturk" => Handback::MturkForm {
            action: format!(
                "{}/mturk/externalSubmit",
                a.submit_to
                    .as_deref()
                    .unwrap_or(study.settings.mturk_mode.submit_host())
            ),
            assignment_id: a.external_assignment.clone().unwrap_or_default(),
            completion_code: code.to_string(),
        },
        "prolific" => {
            let cc = if screened_out {
                study.settings.prolific_screenout_code.as_deref()
            } else {
                study.settings.prolific_completion_code.as_deref()
            };
            match cc {
                Some(cc) => Handback::Redirect {
                    url: format!("{PROLIFIC_COMPLETE}?cc={cc}"),
                },
                None => Handback::Code,
            }
        }
        _ => Handback::Code,
    }
}

/// The unforgeable code of an assignment: HMAC-SHA256(study secret, `kind:assignment id`),
/// 12 hex characters.
pub fn code(secret: &str, kind: &str, a: AssignmentId) -> String {
    let Ok(mut mac) = Hmac::<Sha256>::new_from_slice(secret.as_bytes()) else {
        // HMAC accepts keys of any length; this branch cannot be taken.
        return String::new();
    };
    mac.update(kind.as_bytes());
    mac.update(b":");
    mac.update(a.0.to_string().as_bytes());
    let out = mac.finalize().into_bytes();
    hex::encode_upper(&out[..6])
}

/// Finds the assignment a completion code belongs to (for requesters checking submissions).
pub async fn verify_code(db: &Db, study: &Study, code_given: &str) -> Result<Option<AssignmentId>> {
    let rows =
        sqlx::query("SELECT id FROM assignments WHERE study_id = $1 AND status = 'completed'")
            .bind(study.id.0)
            .fetch_all(&db.pool)
            .await?;
    let given = code_given.trim().to_ascii_uppercase();
    for r in rows {
        let id = AssignmentId(r.try_get("id")?);
        if code(&study.secret, "complete", id) == given {
            return Ok(Some(id));
        }
    }
    Ok(None)
}

/// Loads the study of an assignment.
pub async fn study_of(db: &Db, a: &Assignment) -> Result<Study> {
    study::load(db, a.study).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn questions_insert_numbers_every_placeholder_once() {
        let sql = questions_insert_sql(3);
        assert!(sql.ends_with("($13, $14, $15, $16, $17, $18)"), "{sql}");
        for n in 1..=18 {
            assert_eq!(
                sql.matches(&format!("${n},")).count() + sql.matches(&format!("${n})")).count(),
                1,
                "${n}"
            );
        }
        assert!(!sql.contains("$19"));
    }

    #[test]
    fn codes_depend_on_secret_kind_and_assignment() {
        let c = code("k", "complete", AssignmentId(7));
        assert_eq!(c.len(), 12);
        assert_eq!(c, code("k", "complete", AssignmentId(7)));
        assert_ne!(c, code("k2", "complete", AssignmentId(7)));
        assert_ne!(c, code("k", "screenout", AssignmentId(7)));
        assert_ne!(c, code("k", "complete", AssignmentId(8)));
    }

    #[test]
    fn submit_addresses_are_checked_against_the_mode() {
        assert_eq!(
            check_submit_to("https://workersandbox.mturk.com/", MturkMode::Sandbox).ok(),
            Some(true)
        );
        assert!(check_submit_to("https://www.mturk.com", MturkMode::Sandbox).is_err());
        assert!(check_submit_to("https://evil.example", MturkMode::Live).is_err());
    }

    #[test]
    fn external_ids_are_restricted() {
        assert!(valid_external("w", "A1B2C3").is_ok());
        assert!(valid_external("w", "").is_err());
        assert!(valid_external("w", "<script>").is_err());
        assert!(valid_external("w", &"x".repeat(129)).is_err());
    }

    /// A fresh SQLite file, and a fresh PostgreSQL database when `TEST_POSTGRES_URL` names a
    /// server (`scripts/test` starts one; CI must have it).
    async fn databases() -> Vec<(Db, Option<tempfile::TempDir>)> {
        let dir = tempfile::tempdir().expect("temp dir");
        let url = format!("sqlite://{}", dir.path().join("f.db").display());
        let mut dbs = vec![(Db::connect(&url, 4).await.expect("sqlite"), Some(dir))];
        match std::env::var("TEST_POSTGRES_URL")
            .ok()
            .filter(|u| !u.is_empty())
        {
            Some(admin) => {
                sqlx::any::install_default_drivers();
                let name = format!("f_{:016x}", rand::rng().random::<u64>());
                let mut conn = <AnyConnection as sqlx::Connection>::connect(&admin)
                    .await
                    .expect("connect to TEST_POSTGRES_URL");
                sqlx::Executor::execute(
                    &mut conn,
                    sqlx::AssertSqlSafe(format!("CREATE DATABASE {name}")),
                )
                .await
                .expect("create database");
                let (head, _) = admin.rsplit_once('/').expect("database path");
                let db = Db::connect(&format!("{head}/{name}"), 4)
                    .await
                    .expect("postgres");
                dbs.push((db, None));
            }
            None => assert!(
                std::env::var("CI").is_err(),
                "TEST_POSTGRES_URL is not set: CI must run the PostgreSQL half"
            ),
        }
        dbs
    }

    async fn assignments_of(db: &Db, worker: &str) -> i64 {
        sqlx::query(
            "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM assignments a \
             JOIN workers w ON w.id = a.worker_id WHERE w.external_id = $1",
        )
        .bind(worker)
        .fetch_one(&db.pool)
        .await
        .expect("count")
        .get("n")
    }

    /// A start that read the study before an edit of its HIT shape, MTurk site or block list
    /// committed allocates nothing with the old settings: the allocation re-reads them in its
    /// own transaction and refuses (409, or 403 for a worker blocked meanwhile); a retry with
    /// the study as it is now gets a HIT of the new shape. On both databases.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn starts_follow_settings_edited_since_the_study_was_read() {
        for (db, _dir) in databases().await {
            let id = crate::bench::prepare(&db, 2, 1).await.expect("study");
            let direct = |worker: &str| StartRequest {
                source: Some(Source::Direct),
                worker_id: Some(worker.to_string()),
                ..StartRequest::default()
            };
            let stale = study::load(&db, id).await.expect("load");
            let shape = crate::study_edit::SettingsPatch {
                questions_per_hit: Some(20),
                ..Default::default()
            };
            crate::study_edit::edit(&db, id, &shape, "test")
                .await
                .expect("edit before any assignment");
            let refused = start(&db, &stale, direct("w1")).await;
            assert!(matches!(refused, Err(AppError::Conflict(_))), "{refused:?}");
            assert_eq!(assignments_of(&db, "w1").await, 0, "{:?}", db.backend);

            let fresh = study::load(&db, id).await.expect("load");
            let Ok(StartOutcome::Started { token, .. }) = start(&db, &fresh, direct("w1")).await
            else {
                panic!("a retry with the current settings starts")
            };
            let questions: i64 = sqlx::query(
                "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM questions q \
                 JOIN assignments a ON a.id = q.assignment_id WHERE a.token = $1",
            )
            .bind(&token)
            .fetch_one(&db.pool)
            .await
            .expect("questions")
            .get("n");
            assert_eq!(questions, 20);

            let block = crate::study_edit::SettingsPatch {
                blocked_workers: Some(vec!["w2".into()]),
                ..Default::default()
            };
            crate::study_edit::edit(&db, id, &block, "test")
                .await
                .expect("block");
            let blocked = start(&db, &fresh, direct("w2")).await;
            assert!(
                matches!(blocked, Err(AppError::Forbidden(_))),
                "{blocked:?}"
            );
            assert_eq!(assignments_of(&db, "w2").await, 0);
        }
    }
}
