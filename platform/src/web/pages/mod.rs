//! The HTML pages: the worker flow (start, training, questions, reasons, done) on top of the
//! same [`crate::flow`] functions as the JSON API, and the admin pages (login, studies, upload,
//! dashboard, quality control, exports). Askama escapes every value.

use askama::Template;
use axum::Router;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{Html, IntoResponse, Redirect, Response};
use axum::routing::get;

use crate::AppState;
use crate::error::{AppError, Result};
use crate::store::ids::ItemId;
use crate::studies::library;
use crate::web::extract::ApiPath;

mod admin_session;
mod explore;
mod mashup;
mod models;
mod new_study;
mod search;
mod search_example;
mod study_page;
mod upload;
mod worker;

pub use search_example::example_routes;
pub use upload::upload_handler;

/// Worker and admin page routes.
pub fn routes() -> Router<AppState> {
    Router::new()
        .route("/", get(home))
        .route("/media/items/{file}", get(media))
        .route("/static/{file}", get(crate::web::assets::serve))
        .merge(worker::routes())
        .merge(admin_session::routes())
        .merge(study_page::routes())
        .merge(models::routes())
        .merge(search::routes())
        .merge(explore::routes())
        .merge(mashup::routes())
        .merge(new_study::routes())
}

pub(super) fn render(t: &impl Template) -> Result<Response> {
    let html = t.render().map_err(AppError::internal)?;
    Ok(Html(html).into_response())
}

#[derive(Template)]
#[template(path = "message.html")]
pub(super) struct MessagePage<'a> {
    pub(super) title: &'a str,
    pub(super) message: String,
    pub(super) class: &'a str,
}

/// Renders an error as an HTML page with the error's status.
fn error_page(e: AppError) -> Response {
    if e.status().is_server_error() {
        eprintln!("error: {e}");
    }
    status_page(e.status(), e.public_message())
}

/// An error page with `status` showing `message`; the admin login page instead of a 401.
pub(crate) fn status_page(status: StatusCode, message: String) -> Response {
    if status == StatusCode::UNAUTHORIZED {
        return Redirect::to("/admin/login").into_response();
    }
    let page = MessagePage {
        title: if status.is_server_error() {
            "Something went wrong"
        } else {
            "Sorry"
        },
        message,
        class: "error",
    };
    match page.render() {
        Ok(html) => (status, Html(html)).into_response(),
        Err(_) => (status, page.message).into_response(),
    }
}

pub(super) fn page(r: Result<Response>) -> Response {
    r.unwrap_or_else(error_page)
}

async fn home() -> Response {
    page(render(&MessagePage {
        title: "Style rating studies",
        message: "Workers arrive through a study link; researchers log in at /admin.".into(),
        class: "",
    }))
}

async fn media(State(state): State<AppState>, ApiPath(file): ApiPath<String>) -> Result<Response> {
    if let Some(id) = file.strip_suffix(".svg") {
        let id: ItemId = id.parse().map_err(|_| AppError::NotFound("item"))?;
        // The usvg-normalised source stored on import (no scripts); 404 for a raster item.
        let svg = crate::mashup::store::item_svg(&state.db, id)
            .await?
            .ok_or(AppError::NotFound("item SVG"))?;
        return Ok((
            [
                (header::CONTENT_TYPE, "image/svg+xml"),
                (header::CACHE_CONTROL, "public, max-age=86400, immutable"),
                (
                    header::CONTENT_SECURITY_POLICY,
                    "default-src 'none'; img-src data:; style-src 'unsafe-inline'",
                ),
            ],
            svg,
        )
            .into_response());
    }
    // `ID.cutout.png`: a raster item with its transparency, for the mash-up canvas.
    let (id, cutout) = match file.strip_suffix(".cutout.png") {
        Some(id) => (id, true),
        None => (file.strip_suffix(".png").unwrap_or(""), false),
    };
    let id: ItemId = id.parse().map_err(|_| AppError::NotFound("item"))?;
    let png = if cutout {
        crate::mashup::store::item_cutout(&state.db, id).await?
    } else {
        library::item_png(&state.db, id).await?
    };
    Ok((
        [
            (header::CONTENT_TYPE, "image/png"),
            (header::CACHE_CONTROL, "public, max-age=86400, immutable"),
        ],
        png,
    )
        .into_response())
}
