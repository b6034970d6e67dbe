//! A study's settings over JSON: read, change (audited; session cookie and CSRF header) and
//! the audit of changes.

use axum::Json;
use axum::extract::State;

use crate::AppState;
use crate::error::{ErrorBody, Result};
use crate::store::ids::StudyId;
use crate::studies::study::{self, StudySettings};
use crate::studies::study_edit::{self, Edited, SettingsChange, SettingsPatch};
use crate::web::admin::Admin;
use crate::web::extract::{ApiJson, ApiPath};

/// The study's current settings.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/settings", params(("study" = i64, Path)),
    responses((status = 200, body = StudySettings)))]
pub(super) async fn admin_settings(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<StudySettings>> {
    Ok(Json(study::load(&state.db, id).await?.settings))
}

/// Changes some of a study's settings (every changed field is audited).
/// The description, `max_training_attempts`, `reasons_probability`,
/// `reject_at_control_errors`, the Prolific codes, `blocked_workers` and `exclude_workers_of`
/// may change at any time and apply from the next start, HIT or completion on;
/// `questions_per_hit`, `controls_per_hit` and `mturk_mode` only while the study has no
/// assignment; `tuples`, `replication`, `seed` and `training_questions` never (the stored pool
/// was built from them). A field sent with its current value is no change. Refusals are 409
/// with the field and the reason; invalid values 400.
#[utoipa::path(patch, path = "/api/v1/admin/studies/{study}/settings", params(("study" = i64, Path)),
    request_body = SettingsPatch,
    responses((status = 200, body = Edited),
              (status = 400, description = "An invalid value (the message names the field)",
                  body = ErrorBody),
              (status = 409, description = "The field cannot change any more (the message says \
                  why)", body = ErrorBody)))]
pub(super) async fn admin_edit_settings(
    admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(patch): ApiJson<SettingsPatch>,
) -> Result<Json<Edited>> {
    Ok(Json(
        study_edit::edit(&state.db, id, &patch, &format!("admin:{}", admin.username)).await?,
    ))
}

/// The study's settings changes (who, when, old and new value), newest first.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/settings/changes",
    params(("study" = i64, Path)),
    responses((status = 200, body = Vec<SettingsChange>)))]
pub(super) async fn admin_settings_changes(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Vec<SettingsChange>>> {
    study::load(&state.db, id).await?;
    Ok(Json(study_edit::changes(&state.db, id).await?))
}
