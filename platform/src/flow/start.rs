//! The start of a worker: who they are (MTurk, Prolific, a direct link), what they may send,
//! and the decision to resume, refuse or admit them.

use super::*;

/// The answers the demographics' `gender` accepts (empty: not answered).
pub const GENDERS: &[&str] = &["female", "male", "other", "undisclosed", ""];
/// The answers the demographics' `art_experience` accepts (empty: not answered).
pub const ART_EXPERIENCE: &[&str] = &["none", "some", "professional", ""];

/// Optional demographics asked at the start.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Demographics {
    /// `female`, `male`, `other`, `undisclosed`.
    #[schema(value_type = Option<crate::web::api::schema::Gender>)]
    pub gender: Option<String>,
    /// `none`, `some`, `professional`.
    #[schema(value_type = Option<crate::web::api::schema::ArtExperience>)]
    pub art_experience: Option<String>,
}

impl Demographics {
    pub(super) fn validate(&self) -> Result<()> {
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
    pub(super) fn check_forms(&self) -> Result<()> {
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

pub(super) fn valid_external(field: &str, value: &str) -> Result<()> {
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
pub(super) fn submit_site(value: &str) -> Result<bool> {
    match value.trim_end_matches('/') {
        "https://workersandbox.mturk.com" => Ok(true),
        "https://www.mturk.com" => Ok(false),
        _ => Err(AppError::BadRequest(
            "turk_submit_to: not an MTurk submit address".into(),
        )),
    }
}

/// Parses and checks `turkSubmitTo` against the study's MTurk mode.
pub(super) fn check_submit_to(value: &str, mode: MturkMode) -> Result<bool> {
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
