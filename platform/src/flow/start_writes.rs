//! The writes of a start: the worker, the assignment and (without training) its HIT, with the
//! settings re-read and the exclusions checked inside the same transaction.

use super::*;

/// The writes of a [`start`]: worker, assignment and, without training, the HIT.
pub(super) struct Allocation {
    pub(super) new: NewAssignment,
    pub(super) known: Option<WorkerId>,
    pub(super) external: String,
    pub(super) training: bool,
    pub(super) study: Study,
    pub(super) controls: Vec<i64>,
    pub(super) rng: rand_chacha::ChaCha8Rng,
}

/// What an [`Allocation`] did.
pub(super) enum Allocated {
    /// The new assignment's token.
    New(String),
    /// The worker (with this id) already has an assignment in the study: nothing was written
    /// but possibly the worker row, which the caller rolls back or keeps (harmless).
    Raced(WorkerId),
}

impl Allocation {
    /// Runs inside one transaction (PostgreSQL; SQLite: [`Allocation::run_sqlite`]); an error
    /// leaves it to be rolled back.
    pub(super) async fn run(mut self, tx: &mut AnyConnection) -> Result<Allocated> {
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
/// ([`crate::studies::study_edit::edit`]): an edit that locked the row first commits before this read,
/// which then sees it; an edit that comes later waits for this allocation and then sees its
/// assignment (and refuses to change the HIT shape). On SQLite the allocation runs in the
/// answer writer's transaction, which every other writer waits for
/// ([`crate::studies::study::settings_sqlite`]).
pub(super) const SETTINGS_NOW_POSTGRES: &str =
    "SELECT settings FROM studies WHERE id = $1 FOR KEY SHARE";

pub(super) fn parse_settings(json: &str) -> Result<study::StudySettings> {
    serde_json::from_str(json).map_err(AppError::internal)
}

/// Refuses an allocation if, since the request read the study, the settings changed in what
/// shapes a HIT (`questions_per_hit`, `controls_per_hit`) or binds it to an MTurk site, or the
/// worker (`external`, when known) was blocked: the request's checks and the HIT would
/// otherwise follow settings that are no longer the study's. A retry reads the new ones.
pub(super) fn check_unchanged(
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
pub(super) async fn check_exclusions(db: &Db, study: &Study, worker: WorkerId) -> Result<()> {
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
pub(super) struct NewAssignment {
    pub(super) id: AssignmentId,
    pub(super) token: String,
    pub(super) study: StudyId,
    pub(super) source: Source,
    pub(super) sandbox: bool,
    /// `training`, or `active` when the study has no training (the HIT is allocated with it),
    /// or `declined`.
    pub(super) status: &'static str,
    pub(super) demographics: String,
    /// The consent record: (`agreed` or `declined`, version of the text shown).
    pub(super) consent: Option<(&'static str, String)>,
    pub(super) req: StartRequest,
}

/// A new assignment (`$1` id … `$14` start time, in the column order); nothing when the worker
/// already has one in the study.
pub(super) const INSERT_ASSIGNMENT: &str = "INSERT INTO assignments (id, token, study_id, worker_id, \
     source, sandbox, external_assignment, hit_id, submit_to, prolific_study, prolific_session, \
     demographics, status, training_attempts, started_at) \
     VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, 0, $14) \
     ON CONFLICT DO NOTHING";

impl NewAssignment {
    /// MTurk's submit URL as stored: without a trailing slash.
    pub(super) fn submit_to(&self) -> Option<String> {
        self.req
            .turk_submit_to
            .as_deref()
            .map(|s| s.trim_end_matches('/').to_string())
    }

    /// Inserts it; `false` when the worker already has an assignment in this study.
    pub(super) async fn insert(&self, tx: &mut AnyConnection, worker: WorkerId) -> Result<bool> {
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

pub(super) async fn find_worker(
    db: &Db,
    source: Source,
    external: &str,
) -> Result<Option<WorkerId>> {
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
pub(super) const INSERT_WORKER: &str = "INSERT INTO workers (id, source, external_id, created_at) \
     VALUES ($1, $2, $3, $4) ON CONFLICT DO NOTHING";

/// The id of the worker with source `$1` and external id `$2`.
pub(super) const WORKER_ID: &str = "SELECT id FROM workers WHERE source = $1 AND external_id = $2";

pub(super) async fn ensure_worker(
    tx: &mut AnyConnection,
    source: Source,
    external: &str,
) -> Result<WorkerId> {
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

pub(super) async fn existing_token(
    db: &Db,
    study: StudyId,
    worker: WorkerId,
) -> Result<Option<String>> {
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
