//! The search page's "Upload a drawing" form: the library ordered by style distance to a
//! drawing that is not in it (issue 17, Garces et al. 2014 §5.7.3), shown with the drawing as
//! the reference. A bad file keeps the page and says what is wrong, with status 400.

use axum::Router;
use axum::extract::multipart::MultipartRejection;
use axum::extract::{Multipart, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::routing::post;

use super::search::{SearchForm, page_of};
use super::{page, render};
use crate::AppState;
use crate::error::AppError;
use crate::search;
use crate::studies::library;
use crate::web::admin::Admin;
use crate::web::api::search::{featurise, read_example_form};

/// The form's route (mounted by [`crate::app`] with the upload's body limit).
pub fn example_routes() -> Router<AppState> {
    Router::new().route("/admin/search/example", post(example_page))
}

async fn example_page(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    multipart: std::result::Result<Multipart, MultipartRejection>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let multipart = multipart
                .map_err(|e| AppError::BadRequest(format!("expected a multipart form: {e}")))?;
            let upload = read_example_form(multipart).await?;
            admin.check_csrf(upload.csrf.as_deref())?;
            let names = library::library_names(&state.db).await?;
            let mut request = upload.request;
            if request.library.trim().is_empty() {
                request.library = names.first().cloned().unwrap_or_default();
            }
            let filename = upload.file.0.clone();
            let (answer, error, thumbnail) = match featurise(upload.file).await {
                Ok(example) => {
                    match search::run_with_examples(&state, &request, vec![example.features]).await
                    {
                        Ok(a) => (Some(a), None, Some(example.thumbnail)),
                        Err(e @ (AppError::BadRequest(_) | AppError::Conflict(_))) => {
                            (None, Some(e.public_message()), Some(example.thumbnail))
                        }
                        Err(e) => return Err(e),
                    }
                }
                Err(e @ AppError::BadRequest(_)) => (None, Some(e.public_message()), None),
                Err(e) => return Err(e),
            };
            let form = SearchForm {
                library: Some(request.library.clone()),
                model: request.model.clone(),
                q: request.q.clone(),
                category: request.category.clone(),
                near: None,
                limit: request.limit,
            };
            let failed = error.is_some();
            let mut page = page_of(
                &request.library,
                &names,
                request.model.as_deref().unwrap_or(""),
                request.category.as_deref().unwrap_or(""),
                &form,
                answer,
                error,
            );
            page.csrf = admin.csrf;
            page.example = thumbnail.map(|t| (filename, t));
            let response = render(&page)?;
            Ok(if failed {
                (StatusCode::BAD_REQUEST, response).into_response()
            } else {
                response
            })
        }
        .await,
    )
}
