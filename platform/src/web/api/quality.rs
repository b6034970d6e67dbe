//! Admin writes of quality control over JSON: the control rule (dry run or apply), decision
//! overrides, curated control and training triplets, and expiring abandoned assignments. Each
//! takes the session cookie and the CSRF header.

use axum::Json;
use axum::extract::State;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::OkBody;
use crate::AppState;
use crate::error::{AppError, ErrorBody, Result};
use crate::flow;
use crate::flow::qc::{self, RuleOutcome};
use crate::store::ids::{AssignmentId, StudyId, TupleId};
use crate::studies::study::{self, MAX_CONTROL_ERRORS};
use crate::web::admin::Admin;
use crate::web::extract::{ApiJson, ApiPath};

/// Re-evaluating the control rule.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct QcRequest {
    /// Reject at this many control errors (default: the study's setting).
    #[schema(minimum = 1, maximum = 500)]
    pub threshold: Option<u32>,
    /// Only report what would change.
    pub dry_run: bool,
}

/// Dry-runs or applies the control rule.
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/qc", params(("study" = i64, Path)),
    request_body = QcRequest,
    responses((status = 200, body = Vec<RuleOutcome>)))]
pub(super) async fn admin_qc(
    admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(req): ApiJson<QcRequest>,
) -> Result<Json<Vec<RuleOutcome>>> {
    if req
        .threshold
        .is_some_and(|t| !(1..=MAX_CONTROL_ERRORS).contains(&t))
    {
        return Err(AppError::BadRequest(format!(
            "threshold: 1..={MAX_CONTROL_ERRORS}"
        )));
    }
    let s = study::load(&state.db, id).await?;
    let threshold = req.threshold.unwrap_or(s.settings.reject_at_control_errors);
    Ok(Json(
        qc::evaluate(
            &state.db,
            id,
            threshold,
            !req.dry_run,
            &format!("admin:{}", admin.username),
        )
        .await?,
    ))
}

/// An admin's decision on a completed assignment.
#[derive(Debug, Clone, Copy, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum Decision {
    /// Approve (pay) the HIT.
    Approved,
    /// Reject the HIT.
    Rejected,
}

impl Decision {
    fn as_str(self) -> &'static str {
        match self {
            Self::Approved => "approved",
            Self::Rejected => "rejected",
        }
    }
}

/// An override.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct DecisionRequest {
    /// The decision.
    pub decision: Decision,
}

/// Overrides one assignment's decision (audited).
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/assignments/{assignment}/decision",
    params(("study" = i64, Path), ("assignment" = i64, Path)), request_body = DecisionRequest,
    responses((status = 200, body = OkBody),
              (status = 404, description = "No such study, or no such assignment in it",
                  body = ErrorBody),
              (status = 409, description = "The assignment is not completed", body = ErrorBody)))]
pub(super) async fn admin_decision(
    admin: Admin,
    State(state): State<AppState>,
    ApiPath((id, assignment)): ApiPath<(StudyId, AssignmentId)>,
    ApiJson(req): ApiJson<DecisionRequest>,
) -> Result<Json<OkBody>> {
    qc::override_decision(
        &state.db,
        id,
        assignment,
        req.decision.as_str(),
        &admin.username,
    )
    .await?;
    Ok(Json(OkBody { ok: true }))
}

/// What a curated triplet is for.
#[derive(Debug, Clone, Copy, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum CuratedKind {
    /// A hidden control question (the expected answer is `b`).
    Control,
    /// A training question (the expected answer is `b`).
    Training,
}

impl CuratedKind {
    fn as_str(self) -> &'static str {
        match self {
            Self::Control => "control",
            Self::Training => "training",
        }
    }
}

/// A curated control or training triplet, by item names; `b` is the expected answer.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CuratedRequest {
    /// What the triplet is for.
    pub kind: CuratedKind,
    /// Reference item name.
    pub a: String,
    /// The item closer in style to `a` (the expected answer).
    pub b: String,
    /// The other item.
    pub c: String,
}

/// The stored curated triplet.
#[derive(Debug, Serialize, ToSchema)]
pub struct CuratedCreated {
    /// Tuple id.
    pub id: TupleId,
}

/// Adds a curated control or training triplet.
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/curated", params(("study" = i64, Path)),
    request_body = CuratedRequest,
    responses((status = 200, body = CuratedCreated),
              (status = 400, description = "An item name is not in the study's library, or the \
                  three are not distinct", body = ErrorBody)))]
pub(super) async fn admin_curated(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(req): ApiJson<CuratedRequest>,
) -> Result<Json<CuratedCreated>> {
    let s = study::load(&state.db, id).await?;
    let tuple =
        study::add_curated(&state.db, &s, req.kind.as_str(), [&req.a, &req.b, &req.c]).await?;
    Ok(Json(CuratedCreated { id: tuple }))
}

/// Longest "abandoned" age: a year.
const MAX_ABANDONED_MINUTES: u32 = 525_600;

/// Expiring abandoned assignments.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ReleaseRequest {
    /// Expire assignments started at least this many minutes ago that are not finished.
    #[schema(minimum = 0, maximum = 525_600)]
    pub older_than_minutes: u32,
}

/// How many assignments were expired.
#[derive(Debug, Serialize, ToSchema)]
pub struct Released {
    /// Expired assignments (their unanswered slots are free again).
    pub released: usize,
}

/// Expires abandoned assignments and frees their unanswered slots.
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/release-abandoned",
    params(("study" = i64, Path)), request_body = ReleaseRequest,
    responses((status = 200, body = Released)))]
pub(super) async fn admin_release(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(req): ApiJson<ReleaseRequest>,
) -> Result<Json<Released>> {
    if req.older_than_minutes > MAX_ABANDONED_MINUTES {
        return Err(AppError::BadRequest(format!(
            "older_than_minutes: 0..={MAX_ABANDONED_MINUTES}"
        )));
    }
    study::load(&state.db, id).await?;
    let released =
        flow::release_abandoned(&state.db, id, i64::from(req.older_than_minutes) * 60_000).await?;
    Ok(Json(Released { released }))
}
