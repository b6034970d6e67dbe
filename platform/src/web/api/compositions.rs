//! Mash-up compositions over JSON (admin session; §5.7.3): save, list, load, update and delete
//! a library's compositions, and render a document — stored or sent — as SVG (vector clip art)
//! or PNG. Bodies are limited to [`BODY_LIMIT`] before anything is parsed; every document is
//! validated ([`Document::validate`]) and its items checked against the library.

use axum::Json;
use axum::Router;
use axum::extract::{DefaultBodyLimit, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use crate::AppState;
use crate::error::{AppError, ErrorBody, Result};
use crate::mashup::document::MAX_DOCUMENT_BYTES;
use crate::mashup::store::{self, Composition, CompositionSummary};
use crate::mashup::{Document, render};
use crate::search::source::library_by_name;
use crate::store::ids::{CompositionId, LibraryId};
use crate::web::admin::Admin;
use crate::web::extract::{ApiJson, ApiPath, ApiQuery};

/// Largest request body: a document of [`MAX_DOCUMENT_BYTES`] plus its name and library.
pub const BODY_LIMIT: usize = MAX_DOCUMENT_BYTES + 4096;

/// The composition routes, with their own body limit.
pub fn routes() -> Router<AppState> {
    Router::new()
        .route(
            "/api/v1/admin/compositions",
            get(list_compositions).post(create_composition),
        )
        .route(
            "/api/v1/admin/compositions/render",
            post(render_composition),
        )
        .route(
            "/api/v1/admin/compositions/{id}",
            get(get_composition)
                .put(update_composition)
                .delete(delete_composition),
        )
        .route(
            "/api/v1/admin/compositions/{id}/export",
            get(export_composition),
        )
        .layer(DefaultBodyLimit::max(BODY_LIMIT))
}

/// A new composition.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewComposition {
    /// The library its pieces come from (name).
    #[schema(max_length = 200)]
    pub library: String,
    /// Its name (1–200 characters).
    #[schema(min_length = 1, max_length = 200)]
    pub name: String,
    /// The canvas.
    pub document: Document,
}

/// A composition's new name and canvas.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CompositionUpdate {
    /// Its name (1–200 characters).
    #[schema(min_length = 1, max_length = 200)]
    pub name: String,
    /// The canvas.
    pub document: Document,
}

/// A document to render.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RenderRequest {
    /// The library its pieces come from (name).
    #[schema(max_length = 200)]
    pub library: String,
    /// The canvas.
    pub document: Document,
}

/// `?library=NAME`.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct LibraryQuery {
    /// The library (its name).
    #[param(max_length = 200)]
    pub library: String,
}

/// An export format.
#[derive(Debug, Clone, Copy, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum RenderFormat {
    /// SVG; every piece keeps its vector drawing.
    Svg,
    /// PNG at the canvas size.
    Png,
}

/// `?format=svg|png`.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct FormatQuery {
    /// `svg` or `png`.
    #[param(inline)]
    pub format: RenderFormat,
}

/// The compositions of a library.
#[derive(Debug, Serialize, ToSchema)]
pub struct CompositionList {
    /// The library.
    pub library: String,
    /// Most recently changed first.
    pub compositions: Vec<CompositionSummary>,
}

/// The library called `name` (404 when there is none); control characters are a 400.
async fn library(state: &AppState, name: &str) -> Result<LibraryId> {
    if name.chars().any(char::is_control) || name.chars().count() > 200 || name.is_empty() {
        return Err(AppError::BadRequest(
            "library: 1–200 characters, no control characters".into(),
        ));
    }
    library_by_name(&state.db, name).await
}

/// A checked document of `library`.
async fn checked(state: &AppState, library: LibraryId, doc: &Document) -> Result<()> {
    doc.validate()?;
    store::check_items(&state.db, library, doc).await
}

/// Saves a new composition of a library.
#[utoipa::path(post, path = "/api/v1/admin/compositions", request_body = NewComposition,
    responses((status = 201, body = Composition),
        (status = 400, description = "A bad name or document, or an item not in the library",
            body = ErrorBody),
        (status = 404, description = "No such library", body = ErrorBody)))]
pub(super) async fn create_composition(
    _admin: Admin,
    State(state): State<AppState>,
    ApiJson(body): ApiJson<NewComposition>,
) -> Result<(StatusCode, Json<Composition>)> {
    let name = store::check_name(&body.name)?;
    let lib = library(&state, &body.library).await?;
    checked(&state, lib, &body.document).await?;
    let id = store::create(&state.db, lib, &name, &body.document).await?;
    Ok((StatusCode::CREATED, Json(store::get(&state.db, id).await?)))
}

/// The saved compositions of a library, most recently changed first.
#[utoipa::path(get, path = "/api/v1/admin/compositions", params(LibraryQuery),
    responses((status = 200, body = CompositionList),
        (status = 404, description = "No such library", body = ErrorBody)))]
pub(super) async fn list_compositions(
    _admin: Admin,
    State(state): State<AppState>,
    ApiQuery(q): ApiQuery<LibraryQuery>,
) -> Result<Json<CompositionList>> {
    let lib = library(&state, &q.library).await?;
    Ok(Json(CompositionList {
        library: q.library,
        compositions: store::list(&state.db, lib).await?,
    }))
}

/// One saved composition.
#[utoipa::path(get, path = "/api/v1/admin/compositions/{id}", params(("id" = i64, Path)),
    responses((status = 200, body = Composition),
        (status = 404, description = "No such composition", body = ErrorBody)))]
pub(super) async fn get_composition(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<CompositionId>,
) -> Result<Json<Composition>> {
    Ok(Json(store::get(&state.db, id).await?))
}

/// Replaces a composition's name and canvas.
#[utoipa::path(put, path = "/api/v1/admin/compositions/{id}", params(("id" = i64, Path)),
    request_body = CompositionUpdate,
    responses((status = 200, body = Composition),
        (status = 400, description = "A bad name or document, or an item not in the library",
            body = ErrorBody),
        (status = 404, description = "No such composition", body = ErrorBody)))]
pub(super) async fn update_composition(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<CompositionId>,
    ApiJson(body): ApiJson<CompositionUpdate>,
) -> Result<Json<Composition>> {
    let name = store::check_name(&body.name)?;
    let lib = store::library_of(&state.db, id).await?;
    checked(&state, lib, &body.document).await?;
    store::update(&state.db, id, &name, &body.document).await?;
    Ok(Json(store::get(&state.db, id).await?))
}

/// Deletes a composition.
#[utoipa::path(delete, path = "/api/v1/admin/compositions/{id}", params(("id" = i64, Path)),
    responses((status = 204, description = "Deleted"),
        (status = 404, description = "No such composition", body = ErrorBody)))]
pub(super) async fn delete_composition(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<CompositionId>,
) -> Result<StatusCode> {
    store::delete(&state.db, id).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// Renders a document (not stored) as SVG or PNG, as a download.
#[utoipa::path(post, path = "/api/v1/admin/compositions/render", params(FormatQuery),
    request_body = RenderRequest,
    responses((status = 200, description = "The picture, as an attachment", content(
            (String = "image/svg+xml"), (Vec<u8> = "image/png"))),
        (status = 400, description = "A bad document, or an item not in the library",
            body = ErrorBody),
        (status = 404, description = "No such library", body = ErrorBody)))]
pub(super) async fn render_composition(
    _admin: Admin,
    State(state): State<AppState>,
    // The query is checked after the body's content type and JSON, so that a request without
    // a JSON body is a 415 whatever its query, as on every other operation with a body.
    q: std::result::Result<ApiQuery<FormatQuery>, crate::error::AppError>,
    ApiJson(body): ApiJson<RenderRequest>,
) -> Result<Response> {
    let ApiQuery(q) = q?;
    let lib = library(&state, &body.library).await?;
    checked(&state, lib, &body.document).await?;
    picture(&state, body.document, q.format, "composition").await
}

/// A saved composition as SVG or PNG, as a download.
#[utoipa::path(get, path = "/api/v1/admin/compositions/{id}/export",
    params(("id" = i64, Path), FormatQuery),
    responses((status = 200, description = "The picture, as an attachment", content(
            (String = "image/svg+xml"), (Vec<u8> = "image/png"))),
        (status = 404, description = "No such composition", body = ErrorBody)))]
pub(super) async fn export_composition(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<CompositionId>,
    ApiQuery(q): ApiQuery<FormatQuery>,
) -> Result<Response> {
    let composition = store::get(&state.db, id).await?;
    picture(
        &state,
        composition.document,
        q.format,
        &format!("composition-{id}"),
    )
    .await
}

/// Renders `doc` off the async threads and answers it as an attachment `NAME.svg|png`.
async fn picture(
    state: &AppState,
    doc: Document,
    format: RenderFormat,
    name: &str,
) -> Result<Response> {
    let sources = render::load_sources(&state.db, &doc).await?;
    let (bytes, mime, ext) = tokio::task::spawn_blocking(move || match format {
        RenderFormat::Svg => {
            render::svg(&doc, &sources).map(|s| (s.into_bytes(), "image/svg+xml", "svg"))
        }
        RenderFormat::Png => render::png(&doc, &sources).map(|p| (p, "image/png", "png")),
    })
    .await
    .map_err(AppError::internal)??;
    Ok((
        [
            (header::CONTENT_TYPE, mime.to_string()),
            (
                header::CONTENT_DISPOSITION,
                format!("attachment; filename=\"{name}.{ext}\""),
            ),
            (header::CACHE_CONTROL, "no-store".to_string()),
        ],
        bytes,
    )
        .into_response())
}
