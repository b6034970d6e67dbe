//! Style search over JSON (session cookie): the same search as the admin's search page.

use axum::Json;
use axum::extract::State;

use crate::AppState;
use crate::error::{ErrorBody, Result};
use crate::search::{self, SearchAnswer, SearchRequest};
use crate::web::admin::Admin;
use crate::web::extract::ApiQuery;

/// Searches a library: keywords and a style label restrict, `near` orders by mean style
/// distance (eq. 5.5) to those items, and without `near` the results are dealt across the
/// library's style clusters (Garces et al. 2014 §5.7.3). The newest trained model over the
/// library gives the metric unless `model` says otherwise; with none, uniform weights
/// (`uniform: true`).
#[utoipa::path(get, path = "/api/v1/admin/search", params(SearchRequest),
    responses((status = 200, body = SearchAnswer),
        (status = 404, description = "No such library or model", body = ErrorBody),
        (status = 409, description = "The library has no items, the model is not finished, or \
            it does not fit the library's features", body = ErrorBody)))]
pub(super) async fn admin_search(
    _admin: Admin,
    State(state): State<AppState>,
    ApiQuery(req): ApiQuery<SearchRequest>,
) -> Result<Json<SearchAnswer>> {
    Ok(Json(search::run(&state, &req).await?))
}
