//! The study's trained style metrics over JSON: the list, and starting a training (session
//! cookie; starting also the CSRF header).

use axum::Json;
use axum::extract::State;
use axum::http::StatusCode;
use axum::response::IntoResponse;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::AppState;
use crate::error::{AppError, ErrorBody, Result};
use crate::store::ids::{ModelId, StudyId};
use crate::studies::study;
use crate::studies::train::{self, ModelSummary, TrainOptions};
use crate::web::admin::Admin;
use crate::web::extract::{ApiJson, ApiPath};

/// The study's trained style metrics, newest first (status, λ, accuracy; the report is at
/// `/admin/studies/{study}/models/{id}/report/`).
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/models", params(("study" = i64, Path)),
    responses((status = 200, body = Vec<ModelSummary>)))]
pub(super) async fn admin_models(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Vec<ModelSummary>>> {
    study::load(&state.db, id).await?;
    Ok(Json(train::list(&state.db, id).await?))
}

/// Cross-validation folds a training may ask for.
const FOLDS: std::ops::RangeInclusive<usize> = 2..=100;

/// Training options (all optional).
#[derive(Debug, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TrainRequest {
    /// λ of eq. 5.8; omitted: chosen by cross-validation.
    #[schema(minimum = 0)]
    pub lambda: Option<f64>,
    /// Cross-validation folds (default 5).
    #[schema(minimum = 2, maximum = 100, value_type = Option<u32>)]
    pub folds: Option<usize>,
}

/// A training started in the background.
#[derive(Debug, Serialize, ToSchema)]
pub struct TrainStarted {
    /// The model being trained; poll `GET …/models` for its status.
    pub id: ModelId,
}

/// Starts fitting the style metric on the study's answers. Returns at once.
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/models", params(("study" = i64, Path)),
    request_body = TrainRequest,
    responses((status = 202, body = TrainStarted),
        (status = 409, description = "No answers to train on yet (or fewer than the folds), or a \
            training is already running", body = ErrorBody)))]
pub(super) async fn admin_train(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(req): ApiJson<TrainRequest>,
) -> Result<impl IntoResponse> {
    if req.folds.is_some_and(|f| !FOLDS.contains(&f)) {
        return Err(AppError::BadRequest(format!(
            "folds: {}..={}",
            FOLDS.start(),
            FOLDS.end()
        )));
    }
    let s = study::load(&state.db, id).await?;
    let opts = TrainOptions {
        lambda: req.lambda,
        folds: req.folds.unwrap_or(TrainOptions::default().folds),
    };
    let model = train::start(&state.db, &s, opts).await?;
    Ok((StatusCode::ACCEPTED, Json(TrainStarted { id: model })))
}
