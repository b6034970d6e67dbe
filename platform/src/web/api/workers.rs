//! Managing a worker from the dashboard: block or unblock them by their crowd platform id, and
//! record bonuses (the study page's worker rows post the same operations as forms).

use axum::Json;
use axum::Router;
use axum::extract::State;
use axum::routing::{get, post};
use serde::Deserialize;
use utoipa::ToSchema;

use crate::AppState;
use crate::error::{AppError, ErrorBody, Result};
use crate::store::ids::{AssignmentId, StudyId};
use crate::studies::bonus::{self, BonusRecord};
use crate::studies::study;
use crate::studies::study_edit::{self, BlockOutcome};
use crate::web::admin::Admin;
use crate::web::extract::{ApiJson, ApiPath};

pub(super) fn routes() -> Router<AppState> {
    Router::new()
        .route(
            "/api/v1/admin/studies/{study}/assignments/{assignment}/block",
            post(admin_block),
        )
        .route(
            "/api/v1/admin/studies/{study}/assignments/{assignment}/bonuses",
            post(admin_add_bonus),
        )
        .route("/api/v1/admin/studies/{study}/bonuses", get(admin_bonuses))
}

/// Blocking or unblocking the worker of an assignment.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct BlockRequest {
    /// `true`: put the worker's platform id on the block list (their open HIT in the study
    /// ends); `false`: take it off.
    blocked: bool,
}

/// Blocks or unblocks the worker of an assignment by their crowd platform id (CSRF header
/// required; audited as a change of `blocked_workers`).
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/assignments/{assignment}/block",
    params(("study" = i64, Path), ("assignment" = i64, Path)), request_body = BlockRequest,
    responses((status = 200, body = BlockOutcome), (status = 400, body = ErrorBody),
        (status = 401, body = ErrorBody), (status = 403, body = ErrorBody),
        (status = 404, body = ErrorBody)))]
pub(super) async fn admin_block(
    admin: Admin,
    State(state): State<AppState>,
    ApiPath((id, assignment)): ApiPath<(StudyId, AssignmentId)>,
    ApiJson(req): ApiJson<BlockRequest>,
) -> Result<Json<BlockOutcome>> {
    let actor = format!("admin:{}", admin.username);
    Ok(Json(
        study_edit::block_worker_of(&state.db, id, assignment, req.blocked, &actor).await?,
    ))
}

/// A bonus for the worker of an assignment.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct BonusRequest {
    /// The amount with at most two decimals, as a string (`"1.50"`) or a number; at most
    /// 100.00. MTurk pays US dollars, Prolific the study's currency.
    #[schema(value_type = String, example = "1.50")]
    amount: serde_json::Value,
    /// The reason the worker is shown (one line, at most 500 characters).
    reason: String,
}

/// Records a bonus for the worker of a finished HIT (CSRF header required; stored with who
/// and when). Nothing is paid: the exports `mturk_bonuses.csv` and `prolific_bonuses.csv`
/// list the bonuses in the formats the platforms are paid with. 409 while the HIT is open.
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/assignments/{assignment}/bonuses",
    params(("study" = i64, Path), ("assignment" = i64, Path)), request_body = BonusRequest,
    responses((status = 200, body = BonusRecord), (status = 400, body = ErrorBody),
        (status = 401, body = ErrorBody), (status = 403, body = ErrorBody),
        (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)))]
pub(super) async fn admin_add_bonus(
    admin: Admin,
    State(state): State<AppState>,
    ApiPath((id, assignment)): ApiPath<(StudyId, AssignmentId)>,
    ApiJson(req): ApiJson<BonusRequest>,
) -> Result<Json<BonusRecord>> {
    let amount = match &req.amount {
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Number(n) => n.to_string(),
        _ => {
            return Err(AppError::BadRequest(
                "amount: an amount like \"1.50\"".into(),
            ));
        }
    };
    let cents = bonus::parse_amount(&amount)?;
    let actor = format!("admin:{}", admin.username);
    Ok(Json(
        bonus::record(&state.db, id, assignment, cents, &req.reason, &actor).await?,
    ))
}

/// The study's recorded bonuses, newest first.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/bonuses",
    params(("study" = i64, Path)),
    responses((status = 200, body = Vec<BonusRecord>), (status = 401, body = ErrorBody),
        (status = 404, body = ErrorBody)))]
pub(super) async fn admin_bonuses(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Vec<BonusRecord>>> {
    study::load(&state.db, id).await?;
    Ok(Json(bonus::list(&state.db, id).await?))
}
