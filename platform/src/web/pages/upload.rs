//! The admin's multipart upload of items into a library. Every file is stored or listed with
//! the reason it was refused; one bad file never stops the others.

use askama::Template;
use axum::extract::{Multipart, State};
use axum::response::Response;

use crate::AppState;
use crate::error::AppError;
use crate::studies::library::{self, Inserted};
use crate::web::admin::Admin;

use super::{page, render};

/// What an upload did, file by file.
#[derive(Template)]
#[template(path = "upload_result.html")]
struct UploadResult {
    library: String,
    stored: Vec<String>,
    refused: Vec<(String, String)>,
}

/// The plain message of a request over the upload limit.
fn too_large() -> AppError {
    AppError::TooLarge(format!(
        "upload too large (the limit is {})",
        library::upload_limit_in_words()
    ))
}

/// The form as it arrived: the CSRF token, the library and the files.
#[derive(Default)]
struct UploadForm {
    csrf: Option<String>,
    library: Option<String>,
    files: Vec<(String, axum::body::Bytes)>,
}

/// Reads the whole form before anything is stored, so that a request over a limit stores
/// nothing (the request's size is bounded by the router's body limit).
async fn read_form(mut multipart: Multipart) -> Result<UploadForm, AppError> {
    let mut form = UploadForm::default();
    while let Some(field) = multipart
        .next_field()
        .await
        .map_err(|e| AppError::BadRequest(format!("malformed upload: {e}")))?
    {
        let name = field.name().unwrap_or_default().to_string();
        match name.as_str() {
            "csrf" | "library" => {
                let text = field.text().await.map_err(|_| too_large())?;
                if name == "csrf" {
                    form.csrf = Some(text);
                } else {
                    form.library = Some(text);
                }
            }
            "file" => {
                let filename = field
                    .file_name()
                    .map(|f| f.rsplit(['/', '\\']).next().unwrap_or(f).to_string())
                    .filter(|f| !f.is_empty() && f.len() <= 200)
                    .ok_or_else(|| AppError::BadRequest("file: missing or long name".into()))?;
                if form.files.len() == library::MAX_UPLOAD_FILES {
                    return Err(too_large());
                }
                // Reading a field's body fails on the request's size limit (or a client that
                // went away, which sees no answer anyway).
                let bytes = field.bytes().await.map_err(|_| too_large())?;
                form.files.push((filename, bytes));
            }
            other => return Err(AppError::BadRequest(format!("unexpected field {other:?}"))),
        }
    }
    Ok(form)
}

/// The multipart upload handler (mounted by [`crate::app`] with a larger body limit).
pub async fn upload_handler(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    multipart: std::result::Result<Multipart, axum::extract::multipart::MultipartRejection>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let multipart = multipart
                .map_err(|e| AppError::BadRequest(format!("expected a multipart form: {e}")))?;
            let form = read_form(multipart).await?;
            admin.check_csrf(form.csrf.as_deref())?;
            if form.files.is_empty() {
                return Err(AppError::BadRequest("no file uploaded".into()));
            }
            let library_name = form.library.unwrap_or_else(|| "uploads".into());
            let lib = library::ensure_library(&state.db, &library_name).await?;
            let mut stored = Vec::new();
            let mut refused: Vec<(String, String)> = Vec::new();
            // Whether every refusal was a size limit (the status is then 413, else 400).
            let mut all_too_large = true;
            for (filename, bytes) in form.files {
                let fname = filename.clone();
                let image = tokio::task::spawn_blocking(move || {
                    let (image, cutout) = library::validate_upload(&fname, &bytes)?;
                    // An SVG that rendered also parses: keep its vector source (mash-ups).
                    let svg = fname
                        .to_ascii_lowercase()
                        .ends_with(".svg")
                        .then(|| library::svg_source(&bytes).ok())
                        .flatten();
                    Ok::<_, AppError>((image, cutout, svg))
                })
                .await
                .map_err(AppError::internal)?;
                let (image, cutout, svg) = match image {
                    Ok(image) => image,
                    Err(e) => {
                        all_too_large &= matches!(e, AppError::TooLarge(_));
                        let message = e.public_message();
                        let why = message
                            .strip_prefix(&format!("{filename}: "))
                            .unwrap_or(&message)
                            .to_string();
                        refused.push((filename, why));
                        continue;
                    }
                };
                let item = library::NewItem {
                    name: filename.clone(),
                    style: None,
                    tags: Vec::new(),
                    image,
                    cutout,
                    svg,
                };
                match library::insert_item(&state.db, lib, item).await? {
                    Inserted::New(_) => stored.push(filename),
                    Inserted::AlreadyPresent => {
                        all_too_large = false;
                        refused.push((filename, "already in the library".into()))
                    }
                    Inserted::Unusable(reason) => {
                        all_too_large = false;
                        refused.push((filename, reason))
                    }
                }
            }
            if stored.is_empty() {
                // Nothing stored is a failed upload: say why, file by file.
                let why = refused
                    .iter()
                    .map(|(f, why)| format!("{f}: {why}"))
                    .collect::<Vec<_>>()
                    .join("; ");
                return Err(if all_too_large {
                    AppError::TooLarge(why)
                } else {
                    AppError::BadRequest(why)
                });
            }
            render(&UploadResult {
                library: library_name,
                stored,
                refused,
            })
        }
        .await,
    )
}
