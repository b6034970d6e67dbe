//! Style search over JSON (session cookie): the same search as the admin's search page, by
//! keywords and reference items, or by an uploaded drawing.

use axum::Json;
use axum::extract::multipart::MultipartRejection;
use axum::extract::{Multipart, State};

use crate::AppState;
use crate::error::{AppError, ErrorBody, Result};
use crate::search::example::{self, Example};
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

/// The multipart form of a search by an uploaded drawing.
#[derive(utoipa::ToSchema)]
#[allow(dead_code)] // The schema of the form; the handler reads the fields one by one.
pub(crate) struct ExampleForm {
    /// The library (its name).
    #[schema(max_length = 200)]
    library: String,
    /// `uniform`, a model id, or omitted: the newest trained model over the library.
    model: Option<String>,
    /// Keywords restricting the results.
    #[schema(max_length = 200)]
    q: Option<String>,
    /// Only items with this style label.
    #[schema(max_length = 200)]
    category: Option<String>,
    /// Results wanted (1–200, default 48).
    #[schema(minimum = 1, maximum = 200)]
    limit: Option<u32>,
    /// The drawing: SVG, PNG or JPEG, at most 2 MB.
    #[schema(value_type = String, format = Binary)]
    file: Vec<u8>,
}

/// Searches a library by an uploaded drawing: the file is rendered and described by the same
/// 169 style features as a library import, and the results are ordered by style distance `d`
/// (eq. 5.5) to it, nearest first; keywords and a style label restrict them as in `GET`.
#[utoipa::path(post, path = "/api/v1/admin/search/example",
    request_body(content = inline(ExampleForm), content_type = "multipart/form-data"),
    responses((status = 200, body = SearchAnswer),
        (status = 400, description = "A bad field or file: no file, an empty file, a file over \
            2 MB, not an SVG, PNG or JPEG, a malformed SVG or image, a blank drawing (the \
            message names the file and the reason)", body = ErrorBody),
        (status = 404, description = "No such library or model", body = ErrorBody),
        (status = 409, description = "The library has no items, the model is not finished, or \
            it does not fit the library's features", body = ErrorBody),
        (status = 415, description = "The body is not multipart/form-data", body = ErrorBody)))]
pub(super) async fn admin_search_example(
    _admin: Admin,
    State(state): State<AppState>,
    multipart: std::result::Result<Multipart, MultipartRejection>,
) -> Result<Json<SearchAnswer>> {
    let multipart = multipart.map_err(|e| {
        AppError::UnsupportedMediaType(format!("expected a multipart/form-data body: {e}"))
    })?;
    let form = read_example_form(multipart).await?;
    let example = featurise(form.file).await?;
    Ok(Json(
        search::run_with_examples(&state, &form.request, vec![example.features]).await?,
    ))
}

/// A search-by-drawing form as it arrived.
pub(crate) struct ExampleUpload {
    /// The search's fields (`near` is never set from the form).
    pub request: SearchRequest,
    /// The page's CSRF field, when sent.
    pub csrf: Option<String>,
    /// The file's name and bytes.
    pub file: (String, axum::body::Bytes),
}

/// Reads the form: the search fields, an optional `csrf` (the page's form) and exactly one
/// `file`. The request's size is bounded by the route's body limit: a file that overruns it
/// is "too big".
pub(crate) async fn read_example_form(mut multipart: Multipart) -> Result<ExampleUpload> {
    let mut request = SearchRequest::default();
    let (mut csrf, mut file, mut library) = (None, None, None);
    while let Some(field) = multipart
        .next_field()
        .await
        .map_err(|e| AppError::BadRequest(format!("malformed form: {e}")))?
    {
        let name = field.name().unwrap_or_default().to_string();
        if name == "file" {
            if file.is_some() {
                return Err(AppError::BadRequest("file: upload one drawing".into()));
            }
            let filename = field
                .file_name()
                .map(|f| f.rsplit(['/', '\\']).next().unwrap_or(f))
                .filter(|f| !f.is_empty())
                .map(|f| f.chars().take(100).collect::<String>())
                .unwrap_or_else(|| "the file".into());
            let bytes = field
                .bytes()
                .await
                .map_err(|_| example::too_big(&filename))?;
            file = Some((filename, bytes));
            continue;
        }
        let text = field
            .text()
            .await
            .map_err(|e| AppError::BadRequest(format!("{name}: {e}")))?;
        let text = Some(text).filter(|t| !t.trim().is_empty());
        match name.as_str() {
            "library" => library = text,
            "model" => request.model = text,
            "q" => request.q = text,
            "category" => request.category = text,
            "csrf" => csrf = text,
            "limit" => {
                request.limit = text
                    .map(|t| t.trim().parse::<u32>())
                    .transpose()
                    .map_err(|_| AppError::BadRequest("limit: a whole number 1–200".into()))?
            }
            other => {
                return Err(AppError::BadRequest(format!(
                    "unexpected field {:?}",
                    other.chars().take(40).collect::<String>()
                )));
            }
        }
    }
    request.library = library.unwrap_or_default();
    let file =
        file.ok_or_else(|| AppError::BadRequest("file: choose a drawing to upload".into()))?;
    Ok(ExampleUpload {
        request,
        csrf,
        file,
    })
}

/// [`example::featurise`] off the async threads.
pub(crate) async fn featurise((filename, bytes): (String, axum::body::Bytes)) -> Result<Example> {
    tokio::task::spawn_blocking(move || example::featurise(&filename, &bytes))
        .await
        .map_err(AppError::internal)?
}
