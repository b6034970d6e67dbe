//! Style exploration over JSON (session cookie): start a taxonomy job, follow it, lay a
//! representative style's branch on the balanced grid (Garces et al. 2016 §6.5).

use axum::Json;
use axum::extract::State;
use axum::http::StatusCode;
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use crate::AppState;
use crate::error::{ErrorBody, Result};
use crate::explore::grid::{self, BranchGrid};
use crate::explore::jobs::{self, Job};
use crate::explore::map::{self, MapRequest, MapView, ViewQuery};
use crate::explore::taxonomy::{self, TaxonomyRequest};
use crate::store::ids::ExplorationId;
use crate::web::admin::Admin;
use crate::web::extract::{ApiJson, ApiPath, ApiQuery};

/// A job asked for.
#[derive(Debug, Serialize, ToSchema)]
pub struct JobStarted {
    /// The exploration.
    pub id: ExplorationId,
    /// False when a stored job with the same parameters (done or running) was reused.
    pub started: bool,
}

/// Computes the representative styles of a library's items of some labels (§6.5.1) in the
/// background, or reuses the stored job with the same parameters on the same library.
#[utoipa::path(post, path = "/api/v1/admin/explore/taxonomy", request_body = TaxonomyRequest,
    responses((status = 202, body = JobStarted),
        (status = 404, description = "No such library or model", body = ErrorBody),
        (status = 409, description = "The model is not finished", body = ErrorBody)))]
pub(super) async fn admin_start_taxonomy(
    _admin: Admin,
    State(state): State<AppState>,
    ApiJson(req): ApiJson<TaxonomyRequest>,
) -> Result<(StatusCode, Json<JobStarted>)> {
    let (id, started) = taxonomy::start(&state, &req).await?;
    Ok((StatusCode::ACCEPTED, Json(JobStarted { id, started })))
}

/// An exploration: its status and progress, and its result once done. A job whose server
/// stopped shows `failed`; asking for the same exploration again restarts it.
#[utoipa::path(get, path = "/api/v1/admin/explore/jobs/{job}",
    params(("job" = i64, Path, description = "The exploration")),
    responses((status = 200, body = Job),
        (status = 404, description = "No such exploration", body = ErrorBody)))]
pub(super) async fn admin_job(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<ExplorationId>,
) -> Result<Json<Job>> {
    Ok(Json(jobs::load(&state.db, id).await?))
}

/// The shape of a grid.
#[derive(Debug, Default, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct GridQuery {
    /// Rows `M` (with `cols`; default: ⌊√members⌋).
    #[param(minimum = 1)]
    pub rows: Option<usize>,
    /// Columns `N` (with `rows`; `rows·cols` at most the members).
    #[param(minimum = 1)]
    pub cols: Option<usize>,
}

/// The members of representative style `style` (its index in the result) of a finished
/// taxonomy on the balanced grid (§6.5.2): every member once, shown on a node or hidden
/// behind one.
#[utoipa::path(get, path = "/api/v1/admin/explore/jobs/{job}/styles/{style}/grid",
    params(("job" = i64, Path, description = "The exploration"),
        ("style" = u32, Path, description = "The representative style, from 0"), GridQuery),
    responses((status = 200, body = BranchGrid),
        (status = 404, description = "No such exploration or style", body = ErrorBody),
        (status = 409, description = "The taxonomy is not done", body = ErrorBody)))]
pub(super) async fn admin_grid(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath((id, style)): ApiPath<(ExplorationId, usize)>,
    ApiQuery(q): ApiQuery<GridQuery>,
) -> Result<Json<BranchGrid>> {
    let job = jobs::load(&state.db, id).await?;
    Ok(Json(
        grid::layout(&state, &job, style, (q.rows, q.cols)).await?,
    ))
}

/// Computes the style map (t-SNE of a library's items of some labels, or of representatives
/// per label) in the background, or reuses the stored job with the same parameters.
#[utoipa::path(post, path = "/api/v1/admin/explore/map", request_body = MapRequest,
    responses((status = 202, body = JobStarted),
        (status = 404, description = "No such library or model", body = ErrorBody),
        (status = 409, description = "The model is not finished", body = ErrorBody)))]
pub(super) async fn admin_start_map(
    _admin: Admin,
    State(state): State<AppState>,
    ApiJson(req): ApiJson<MapRequest>,
) -> Result<(StatusCode, Json<JobStarted>)> {
    let (id, started) = map::start(&state, &req).await?;
    Ok((StatusCode::ACCEPTED, Json(JobStarted { id, started })))
}

/// What to draw of a finished style map in a viewport: at most one thumbnail per screen cell
/// (at most 2,000), dots for the viewport's other points.
#[utoipa::path(get, path = "/api/v1/admin/explore/jobs/{job}/view",
    params(("job" = i64, Path, description = "The exploration"), ViewQuery),
    responses((status = 200, body = MapView),
        (status = 404, description = "No such exploration or not a map", body = ErrorBody),
        (status = 409, description = "The map is not done", body = ErrorBody)))]
pub(super) async fn admin_map_view(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<ExplorationId>,
    ApiQuery(q): ApiQuery<ViewQuery>,
) -> Result<Json<MapView>> {
    let index = state.explore_maps.get(&state.db, id).await?;
    Ok(Json(index.view(&q)?))
}
