//! Changing a study's settings after creation (`platform study edit`, the admin page's settings
//! form, `PATCH /api/v1/admin/studies/{study}/settings`), with an audit row per changed field.
//!
//! Which field may change when follows from what was built from it:
//! - what only steers what happens next — the description, training attempts, the reasons
//!   probability (drawn per question when a HIT is allocated), the control-error threshold
//!   (applied when a HIT completes), the Prolific codes, blocked and excluded workers — may
//!   change at any time;
//! - the HIT shape (`questions_per_hit`, `controls_per_hit`) and the MTurk site (`mturk_mode`)
//!   only while no assignment exists: a started assignment has its HIT cut and its submit
//!   address fixed, and the exports and QC would mix two shapes or two sites;
//! - what the stored tuple pool was generated from (`tuples`, `replication`, `seed`,
//!   `training_questions`) never: changing the number would not change the pool.
//!
//! A field sent with its current value is not a change, so a client may send back the whole
//! settings object it read with only some fields altered.

use serde::{Deserialize, Deserializer, Serialize};
use serde_json::Value;
use sqlx::Row;

use crate::error::{AppError, Result};
use crate::store::db::{Backend, Db, now_ms};
use crate::store::ids::{AssignmentId, SettingsChangeId, StudyId};
use crate::studies::study::{MturkMode, StudySettings};

/// A partial [`StudySettings`]: the fields to change; absent fields stay as they are.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, utoipa::ToSchema)]
#[serde(default, deny_unknown_fields)]
pub struct SettingsPatch {
    /// Text shown to workers before they start (any time).
    #[schema(max_length = 5000)]
    pub description: Option<String>,
    /// Instructions shown on the start page, Markdown (any time).
    pub instructions: Option<String>,
    /// Show a worked example under the instructions (any time).
    pub show_worked_example: Option<bool>,
    /// Informed-consent text, Markdown; empty: no consent step (any time; workers who
    /// already agreed keep their record of the text they agreed to).
    pub consent: Option<String>,
    /// Questions in one HIT, controls included (only while no assignment exists).
    #[schema(minimum = 1, maximum = 500)]
    pub questions_per_hit: Option<u32>,
    /// Hidden controls in one HIT (only while no assignment exists).
    #[schema(minimum = 0, maximum = 499)]
    pub controls_per_hit: Option<u32>,
    /// Training questions (fixed: the training set was drawn at creation).
    #[schema(minimum = 0, maximum = 20)]
    pub training_questions: Option<u32>,
    /// Training attempts before a worker is screened out (any time).
    #[schema(minimum = 1, maximum = 100)]
    pub max_training_attempts: Option<u32>,
    /// Main tuples (fixed: the tuple pool was generated at creation).
    #[schema(minimum = 1, maximum = 1_000_000)]
    pub tuples: Option<u32>,
    /// Replication R (fixed: the slots were created at creation).
    #[schema(minimum = 1, maximum = 100)]
    pub replication: Option<u32>,
    /// Probability of the "why?" questionnaire, for HITs allocated from now on (any time).
    #[schema(minimum = 0, maximum = 1)]
    pub reasons_probability: Option<f64>,
    /// Control errors that reject a HIT, for HITs completed from now on (any time).
    #[schema(minimum = 1, maximum = 500)]
    pub reject_at_control_errors: Option<u32>,
    /// MTurk `sandbox` or `live` (only while no assignment exists).
    pub mturk_mode: Option<MturkMode>,
    /// Prolific completion code; `null` removes it (any time).
    #[serde(deserialize_with = "nullable")]
    #[schema(value_type = Option<crate::web::api::schema::ProlificCode>, nullable = true)]
    pub prolific_completion_code: Option<Option<String>>,
    /// Prolific screen-out code; `null` removes it (any time).
    #[serde(deserialize_with = "nullable")]
    #[schema(value_type = Option<crate::web::api::schema::ProlificCode>, nullable = true)]
    pub prolific_screenout_code: Option<Option<String>>,
    /// Prolific no-consent code; `null` removes it (any time).
    #[serde(deserialize_with = "nullable")]
    #[schema(value_type = Option<String>, nullable = true)]
    pub prolific_noconsent_code: Option<Option<String>>,
    /// The whole list of blocked worker ids (any time; a blocked worker cannot start or resume,
    /// and a HIT they have open in this study ends: further answers are refused).
    #[schema(value_type = Option<Vec<crate::web::api::schema::BlockedWorker>>, max_items = 100_000)]
    pub blocked_workers: Option<Vec<String>>,
    /// The whole list of studies whose workers may not take part (any time).
    #[schema(max_items = 1000)]
    pub exclude_workers_of: Option<Vec<StudyId>>,
    /// Seed of the tuple generation (fixed).
    #[schema(minimum = 0, maximum = 9_007_199_254_740_991_u64)]
    pub seed: Option<u64>,
}

/// A present `null` is `Some(None)` (remove the value); an absent field is `None` (keep it).
fn nullable<'de, D: Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<Option<String>>, D::Error> {
    Option::<String>::deserialize(d).map(Some)
}

/// When a field may change.
#[derive(Debug, Clone, Copy)]
enum When {
    Always,
    /// Only while the study has no assignment; the text says why.
    BeforeStart(&'static str),
    /// Never; the text says why.
    Never(&'static str),
}

/// One changed field.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct FieldChange {
    /// The settings field.
    pub field: String,
    /// Its value before (JSON).
    pub old: Value,
    /// Its value after (JSON).
    pub new: Value,
}

/// The settings after `patch`, and what changed; refuses (409, naming the field and why) a
/// change the rules above forbid, and invalid values (400, from [`StudySettings::validate`]).
/// `started`: whether the study has any assignment.
pub fn apply_patch(
    current: &StudySettings,
    patch: &SettingsPatch,
    started: bool,
) -> Result<(StudySettings, Vec<FieldChange>)> {
    let mut changes = Vec::new();
    let pool = "the stored tuple pool was generated from it when the study was created; \
                create a new study instead";
    let shape = "assignments have started and their HITs were cut with the current shape";
    let site = "assignments have started on the current MTurk site (their submit address \
                and sandbox banner follow it); create a new study for the other site";
    let training = "the training set was drawn from it when the study was created; \
                    create a new study instead";
    let fields: [(&str, When, Option<Value>); 19] = [
        ("description", When::Always, opt(&patch.description)),
        ("instructions", When::Always, opt(&patch.instructions)),
        (
            "show_worked_example",
            When::Always,
            opt(&patch.show_worked_example),
        ),
        ("consent", When::Always, opt(&patch.consent)),
        (
            "questions_per_hit",
            When::BeforeStart(shape),
            opt(&patch.questions_per_hit),
        ),
        (
            "controls_per_hit",
            When::BeforeStart(shape),
            opt(&patch.controls_per_hit),
        ),
        (
            "training_questions",
            When::Never(training),
            opt(&patch.training_questions),
        ),
        (
            "max_training_attempts",
            When::Always,
            opt(&patch.max_training_attempts),
        ),
        ("tuples", When::Never(pool), opt(&patch.tuples)),
        ("replication", When::Never(pool), opt(&patch.replication)),
        (
            "reasons_probability",
            When::Always,
            opt(&patch.reasons_probability),
        ),
        (
            "reject_at_control_errors",
            When::Always,
            opt(&patch.reject_at_control_errors),
        ),
        (
            "mturk_mode",
            When::BeforeStart(site),
            opt(&patch.mturk_mode),
        ),
        (
            "prolific_completion_code",
            When::Always,
            opt(&patch.prolific_completion_code),
        ),
        (
            "prolific_screenout_code",
            When::Always,
            opt(&patch.prolific_screenout_code),
        ),
        (
            "prolific_noconsent_code",
            When::Always,
            opt(&patch.prolific_noconsent_code),
        ),
        ("blocked_workers", When::Always, opt(&patch.blocked_workers)),
        (
            "exclude_workers_of",
            When::Always,
            opt(&patch.exclude_workers_of),
        ),
        ("seed", When::Never(pool), opt(&patch.seed)),
    ];
    let mut merged = match json(current) {
        Value::Object(m) => m,
        _ => return Err(AppError::internal("settings are not a JSON object")),
    };
    for (field, when, value) in fields {
        let Some(value) = value else { continue };
        let old = merged.get(field).cloned().unwrap_or(Value::Null);
        if old == value {
            continue;
        }
        match when {
            When::Always => {}
            When::BeforeStart(why) if started => {
                return Err(AppError::Conflict(format!(
                    "{field}: cannot change any more: {why}"
                )));
            }
            When::BeforeStart(_) => {}
            When::Never(why) => {
                return Err(AppError::Conflict(format!(
                    "{field}: cannot change after creation: {why}"
                )));
            }
        }
        merged.insert(field.to_string(), value.clone());
        changes.push(FieldChange {
            field: field.to_string(),
            old,
            new: value,
        });
    }
    if changes.is_empty() {
        return Ok((current.clone(), changes));
    }
    // Every patch value came from a field of the same type, so this cannot fail on input.
    let new: StudySettings =
        serde_json::from_value(Value::Object(merged)).map_err(AppError::internal)?;
    new.validate()?;
    Ok((new, changes))
}

fn json<T: Serialize + ?Sized>(v: &T) -> Value {
    // Settings types serialise to JSON infallibly (no maps with non-string keys).
    serde_json::to_value(v).unwrap_or(Value::Null)
}

/// A patch field as JSON, if present.
fn opt<T: Serialize>(v: &Option<T>) -> Option<Value> {
    v.as_ref().map(json)
}

/// A recorded change of one settings field.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct SettingsChange {
    /// The settings field.
    pub field: String,
    /// Its value before (JSON).
    pub old: Value,
    /// Its value after (JSON).
    pub new: Value,
    /// Who: `admin:NAME` (web or API) or `cli`.
    pub actor: String,
    /// When (Unix ms).
    pub changed_at: i64,
}

/// The outcome of an edit.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct Edited {
    /// The study's settings now.
    pub settings: StudySettings,
    /// What this edit changed (empty: nothing).
    pub changes: Vec<FieldChange>,
}

/// Whether the study has any assignment (in any state).
async fn has_assignments(conn: &mut sqlx::AnyConnection, study: StudyId) -> Result<bool> {
    Ok(
        sqlx::query("SELECT id FROM assignments WHERE study_id = $1 LIMIT 1")
            .bind(study.0)
            .fetch_optional(&mut *conn)
            .await?
            .is_some(),
    )
}

/// Whether the study has any assignment (for the admin page: which fields it offers).
pub async fn started(db: &Db, study: StudyId) -> Result<bool> {
    has_assignments(&mut *db.pool.acquire().await?, study).await
}

/// Applies `patch` to a study's stored settings in one write transaction and records each
/// changed field (old and new value, `actor`, time).
pub async fn edit(db: &Db, study: StudyId, patch: &SettingsPatch, actor: &str) -> Result<Edited> {
    edit_with(db, study, actor, |_| Ok(patch.clone())).await
}

/// Puts a worker id on the study's block list (`blocked`) or takes it off, as one audited
/// change of `blocked_workers`; blocking also ends the HIT the worker has open in the study
/// (see [`edit`]). The list is read and written in the same transaction, so two admins
/// blocking two workers at once both stay blocked.
pub async fn set_blocked(
    db: &Db,
    study: StudyId,
    worker: &str,
    blocked: bool,
    actor: &str,
) -> Result<Edited> {
    edit_with(db, study, actor, |current| {
        let mut list = current.blocked_workers.clone();
        if blocked && !list.iter().any(|w| w == worker) {
            list.push(worker.to_string());
        }
        if !blocked {
            list.retain(|w| w != worker);
        }
        Ok(SettingsPatch {
            blocked_workers: Some(list),
            ..SettingsPatch::default()
        })
    })
    .await
}

/// A worker's block state after [`block_worker_of`].
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct BlockOutcome {
    /// The worker's id on their crowd platform (the block list's entry).
    pub worker_id: String,
    /// Whether the worker is blocked now.
    pub blocked: bool,
    /// Whether the block list changed (false: the worker already was as asked).
    pub changed: bool,
}

/// Blocks (or unblocks) the worker of `assignment` by their crowd platform id, the way the
/// study's block list names workers: [`set_blocked`].
pub async fn block_worker_of(
    db: &Db,
    study: StudyId,
    assignment: AssignmentId,
    blocked: bool,
    actor: &str,
) -> Result<BlockOutcome> {
    let row = sqlx::query(
        "SELECT w.external_id FROM assignments a JOIN workers w ON w.id = a.worker_id \
         WHERE a.id = $1 AND a.study_id = $2",
    )
    .bind(assignment.0)
    .bind(study.0)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("assignment"))?;
    let worker: String = row.try_get("external_id")?;
    let edited = set_blocked(db, study, &worker, blocked, actor).await?;
    Ok(BlockOutcome {
        worker_id: worker,
        blocked,
        changed: !edited.changes.is_empty(),
    })
}

/// [`edit`] with the patch made from the settings as stored when the transaction read them.
async fn edit_with(
    db: &Db,
    study: StudyId,
    actor: &str,
    make_patch: impl FnOnce(&StudySettings) -> Result<SettingsPatch>,
) -> Result<Edited> {
    let mut tx = db.begin_write().await?;
    // PostgreSQL: lock the row, so two concurrent edits apply one after the other instead of
    // the second overwriting the first (SQLite's BEGIN IMMEDIATE already serialises writers).
    let read = match db.backend {
        Backend::Sqlite => "SELECT settings FROM studies WHERE id = $1",
        Backend::Postgres => "SELECT settings FROM studies WHERE id = $1 FOR UPDATE",
    };
    let row = sqlx::query(read)
        .bind(study.0)
        .fetch_optional(&mut *tx)
        .await?
        .ok_or(AppError::NotFound("study"))?;
    let current: StudySettings =
        serde_json::from_str(&row.try_get::<String, _>("settings")?).map_err(AppError::internal)?;
    let started = has_assignments(&mut tx, study).await?;
    let patch = make_patch(&current)?;
    let (settings, changes) = apply_patch(&current, &patch, started)?;
    if changes.iter().any(|c| c.field == "exclude_workers_of") {
        for other in &settings.exclude_workers_of {
            if *other == study {
                return Err(AppError::BadRequest(
                    "exclude_workers_of: a study cannot exclude its own workers".into(),
                ));
            }
            let exists = sqlx::query("SELECT id FROM studies WHERE id = $1")
                .bind(other.0)
                .fetch_optional(&mut *tx)
                .await?;
            if exists.is_none() {
                return Err(AppError::BadRequest(format!(
                    "exclude_workers_of: no study {other}"
                )));
            }
        }
    }
    if changes.is_empty() {
        tx.rollback().await?;
        return Ok(Edited { settings, changes });
    }
    sqlx::query("UPDATE studies SET settings = $1 WHERE id = $2")
        .bind(serde_json::to_string(&settings).map_err(AppError::internal)?)
        .bind(study.0)
        .execute(&mut *tx)
        .await?;
    // Blocking also ends the HIT a newly blocked worker has open in this study: further
    // answers are refused and its unanswered slots go back to other workers (the answers
    // already given stay, as for an expired assignment).
    for worker in settings
        .blocked_workers
        .iter()
        .filter(|w| !current.blocked_workers.contains(w))
    {
        let open = sqlx::query(
            "SELECT a.id FROM assignments a JOIN workers w ON w.id = a.worker_id \
             WHERE a.study_id = $1 AND w.external_id = $2 AND a.status IN ('training', 'active')",
        )
        .bind(study.0)
        .bind(worker)
        .fetch_all(&mut *tx)
        .await?;
        for row in open {
            crate::flow::end_open_assignment(&mut tx, AssignmentId(row.try_get("id")?)).await?;
        }
    }
    let now = now_ms();
    for c in &changes {
        sqlx::query(
            "INSERT INTO settings_changes (id, study_id, field, old_value, new_value, actor, changed_at) \
             VALUES ($1, $2, $3, $4, $5, $6, $7)",
        )
        .bind(SettingsChangeId::generate().0)
        .bind(study.0)
        .bind(&c.field)
        .bind(c.old.to_string())
        .bind(c.new.to_string())
        .bind(actor)
        .bind(now)
        .execute(&mut *tx)
        .await?;
    }
    tx.commit().await?;
    Ok(Edited { settings, changes })
}

/// A study's settings changes, newest first.
pub async fn changes(db: &Db, study: StudyId) -> Result<Vec<SettingsChange>> {
    let rows = sqlx::query(
        "SELECT field, old_value, new_value, actor, changed_at FROM settings_changes \
         WHERE study_id = $1 ORDER BY changed_at DESC, field",
    )
    .bind(study.0)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| {
            let value = |name: &str| -> Result<Value> {
                serde_json::from_str(&r.try_get::<String, _>(name)?).map_err(AppError::internal)
            };
            Ok(SettingsChange {
                field: r.try_get("field")?,
                old: value("old_value")?,
                new: value("new_value")?,
                actor: r.try_get("actor")?,
                changed_at: r.try_get("changed_at")?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn patch(v: Value) -> SettingsPatch {
        serde_json::from_value(v).expect("patch")
    }

    #[test]
    fn fields_for_what_happens_next_change_any_time() {
        let current = StudySettings::default();
        let p = patch(serde_json::json!({
            "description": "new", "reasons_probability": 0.5, "reject_at_control_errors": 3,
            "blocked_workers": ["W1"], "prolific_completion_code": "C0DE",
            "max_training_attempts": 2
        }));
        let (new, changes) = apply_patch(&current, &p, true).expect("allowed");
        assert_eq!(new.description, "new");
        assert_eq!(new.reasons_probability, 0.5);
        assert_eq!(new.reject_at_control_errors, 3);
        assert_eq!(new.blocked_workers, ["W1"]);
        assert_eq!(new.prolific_completion_code.as_deref(), Some("C0DE"));
        assert_eq!(changes.len(), 6);
        let d = changes
            .iter()
            .find(|c| c.field == "description")
            .expect("description");
        assert_eq!(
            (d.old.as_str(), d.new.as_str()),
            (Some(current.description.as_str()), Some("new"))
        );
        // null removes a Prolific code; an absent field stays.
        let (cleared, _) = apply_patch(
            &new,
            &patch(serde_json::json!({"prolific_completion_code": null})),
            true,
        )
        .expect("allowed");
        assert_eq!(cleared.prolific_completion_code, None);
        assert_eq!(cleared.description, "new");
    }

    #[test]
    fn pool_fields_never_change_and_the_message_says_why() {
        let current = StudySettings::default();
        for field in ["tuples", "replication", "seed", "training_questions"] {
            let e = apply_patch(&current, &patch(serde_json::json!({ field: 7 })), false)
                .expect_err(field);
            assert!(matches!(e, AppError::Conflict(_)), "{field}: {e}");
            assert!(
                e.to_string().starts_with(field) && e.to_string().contains("created"),
                "{e}"
            );
        }
        // The current value is not a change.
        let same = patch(serde_json::json!({"tuples": current.tuples, "seed": current.seed}));
        assert!(
            apply_patch(&current, &same, true)
                .expect("no change")
                .1
                .is_empty()
        );
    }

    #[test]
    fn hit_shape_and_site_change_only_before_the_first_assignment() {
        let current = StudySettings::default();
        let p = patch(
            serde_json::json!({"questions_per_hit": 20, "controls_per_hit": 4, "mturk_mode": "live"}),
        );
        let (new, _) = apply_patch(&current, &p, false).expect("before any assignment");
        assert_eq!(
            (new.questions_per_hit, new.controls_per_hit, new.mturk_mode),
            (20, 4, MturkMode::Live)
        );
        for (field, value) in [
            ("questions_per_hit", serde_json::json!(20)),
            ("mturk_mode", serde_json::json!("live")),
        ] {
            let e = apply_patch(&current, &patch(serde_json::json!({ field: value })), true)
                .expect_err(field);
            assert!(
                matches!(e, AppError::Conflict(_))
                    && e.to_string().contains("assignments have started"),
                "{e}"
            );
        }
    }

    #[test]
    fn edited_settings_are_validated() {
        let current = StudySettings::default();
        for bad in [
            serde_json::json!({"reasons_probability": 1.5}),
            serde_json::json!({"reject_at_control_errors": 0}),
            serde_json::json!({"controls_per_hit": 50}),
            serde_json::json!({"prolific_screenout_code": "not ok!"}),
        ] {
            let e = apply_patch(&current, &patch(bad.clone()), false).expect_err("invalid");
            assert!(matches!(e, AppError::BadRequest(_)), "{bad}: {e}");
        }
        assert!(
            serde_json::from_value::<SettingsPatch>(serde_json::json!({"surprise": 1})).is_err()
        );
    }
}
