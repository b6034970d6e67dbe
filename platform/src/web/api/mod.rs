//! The JSON API under `/api/v1`: the whole worker flow and the admin reads/writes, described
//! by the OpenAPI 3.1 document at `/api/v1/openapi.json` (generated with utoipa from these
//! handlers).
//!
//! The document is the contract the schemathesis run of the test suite holds the server to
//! (tests/tests/platform_openapi.rs): what the schema allows is accepted, what it forbids is
//! refused with a 4xx ([`crate::web::extract::ApiJson`], the validations the field bounds mirror),
//! and every status an operation can answer is listed ([`ApiDoc`]).

use axum::Json;
use axum::Router;
use axum::extract::State;
use axum::http::StatusCode;
use axum::response::IntoResponse;
use axum::routing::{get, post};
use serde::Serialize;
use utoipa::{OpenApi, ToSchema};

use crate::AppState;
use crate::error::ErrorBody;

mod admin;
pub mod compositions;
mod document;
mod explore;
pub(crate) mod iconset_worker;
mod mashup_worker;
mod models;
pub mod quality;
pub mod schema;
pub(crate) mod search;
mod settings;
mod worker;
mod workers;

pub use admin::export_file;
pub use document::ApiDoc;

/// The JSON routes that take an uploaded drawing (mounted by [`crate::app`] with their own
/// body limit, [`crate::search::example::MAX_EXAMPLE_REQUEST`]).
pub fn example_routes() -> Router<AppState> {
    Router::new().route(
        "/api/v1/admin/search/example",
        post(search::admin_search_example),
    )
}

/// The worker and admin JSON routes.
pub fn routes() -> Router<AppState> {
    use admin::*;
    use models::*;
    use quality::*;
    use settings::*;
    use worker::*;
    Router::new()
        .route("/healthz", get(healthz))
        .route("/api/v1/openapi.json", get(openapi))
        .route("/api/v1/studies/{study}", get(study_info))
        .route("/api/v1/studies/{study}/start", post(start))
        .route("/api/v1/assignments/{token}", get(assignment_state))
        .route("/api/v1/assignments/{token}/training", post(training))
        .route("/api/v1/assignments/{token}/give-up", post(give_up))
        .route("/api/v1/assignments/{token}/answers", post(answer))
        .route(
            "/api/v1/assignments/{token}/mashup",
            get(mashup_worker::mashup_task),
        )
        .route(
            "/api/v1/assignments/{token}/mashup/search",
            get(mashup_worker::mashup_search),
        )
        .route(
            "/api/v1/assignments/{token}/mashup/events",
            post(mashup_worker::mashup_event),
        )
        .route(
            "/api/v1/assignments/{token}/mashup/submit",
            post(mashup_worker::mashup_submit),
        )
        .route(
            "/api/v1/assignments/{token}/iconset",
            get(iconset_worker::iconset_task),
        )
        .route(
            "/api/v1/assignments/{token}/iconset/explorer",
            get(iconset_worker::iconset_explorer),
        )
        .route(
            "/api/v1/assignments/{token}/iconset/search",
            get(iconset_worker::iconset_search),
        )
        .route(
            "/api/v1/assignments/{token}/iconset/events",
            post(iconset_worker::iconset_event),
        )
        .route(
            "/api/v1/assignments/{token}/iconset/submit",
            post(iconset_worker::iconset_submit),
        )
        .route("/api/v1/assignments/{token}/reasons", post(reasons))
        .route("/api/v1/admin/session", get(admin_session))
        .route(
            "/api/v1/admin/studies",
            get(admin_studies).post(admin_create_study),
        )
        .route("/api/v1/admin/studies/{study}", get(admin_study))
        .route(
            "/api/v1/admin/studies/{study}/dashboard",
            get(admin_dashboard),
        )
        .route("/api/v1/admin/studies/{study}/workers", get(admin_workers))
        .route(
            "/api/v1/admin/studies/{study}/report",
            get(admin::admin_report),
        )
        .route("/api/v1/admin/studies/{study}/audit", get(admin_audit))
        .route("/api/v1/admin/studies/{study}/qc", post(admin_qc))
        .route(
            "/api/v1/admin/studies/{study}/assignments/{assignment}/decision",
            post(admin_decision),
        )
        .route(
            "/api/v1/admin/studies/{study}/export/{file}",
            get(admin_export),
        )
        .route("/api/v1/admin/studies/{study}/curated", post(admin_curated))
        .route(
            "/api/v1/admin/studies/{study}/release-abandoned",
            post(admin_release),
        )
        .route(
            "/api/v1/admin/studies/{study}/models",
            get(admin_models).post(admin_train),
        )
        .route(
            "/api/v1/admin/studies/{study}/codes/{code}",
            get(admin_verify_code),
        )
        .route(
            "/api/v1/admin/studies/{study}/settings",
            get(admin_settings).patch(admin_edit_settings),
        )
        .route(
            "/api/v1/admin/studies/{study}/settings/changes",
            get(admin_settings_changes),
        )
        .route("/api/v1/admin/search", get(search::admin_search))
        .route(
            "/api/v1/admin/explore/taxonomy",
            post(explore::admin_start_taxonomy),
        )
        .route("/api/v1/admin/explore/map", post(explore::admin_start_map))
        .route("/api/v1/admin/explore/jobs/{job}", get(explore::admin_job))
        .route(
            "/api/v1/admin/explore/jobs/{job}/view",
            get(explore::admin_map_view),
        )
        .route(
            "/api/v1/admin/explore/jobs/{job}/styles/{style}/grid",
            get(explore::admin_grid),
        )
        .merge(workers::routes())
}

async fn openapi() -> Json<utoipa::openapi::OpenApi> {
    Json(ApiDoc::openapi())
}

/// A plain acknowledgement.
#[derive(Debug, Serialize, ToSchema)]
pub struct OkBody {
    /// Always true.
    pub ok: bool,
}

/// Answers 200 when the database is reachable.
#[utoipa::path(get, path = "/healthz",
    responses((status = 200, body = OkBody),
              (status = 503, description = "The database is unreachable", body = ErrorBody)))]
pub(super) async fn healthz(State(state): State<AppState>) -> impl IntoResponse {
    match state.db.ping().await {
        Ok(()) => (StatusCode::OK, Json(OkBody { ok: true })).into_response(),
        Err(_) => (
            StatusCode::SERVICE_UNAVAILABLE,
            Json(ErrorBody {
                error: "database unreachable".into(),
            }),
        )
            .into_response(),
    }
}
