//! The admin's multipart upload of items into a library.

use axum::extract::{Multipart, State};
use axum::response::Response;

use crate::AppState;
use crate::admin::Admin;
use crate::error::AppError;
use crate::library;

use super::{MessagePage, page, render};

/// The multipart upload handler (mounted by [`crate::app`] with a larger body limit).
pub async fn upload_handler(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    multipart: std::result::Result<Multipart, axum::extract::multipart::MultipartRejection>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let mut multipart = multipart
                .map_err(|e| AppError::BadRequest(format!("expected a multipart form: {e}")))?;
            let mut csrf = None;
            let mut library_name = None;
            let mut stored = Vec::new();
            let mut problems = Vec::new();
            while let Some(field) = multipart
                .next_field()
                .await
                .map_err(|e| AppError::BadRequest(format!("malformed upload: {e}")))?
            {
                let name = field.name().unwrap_or_default().to_string();
                match name.as_str() {
                    "csrf" => {
                        csrf = Some(
                            field
                                .text()
                                .await
                                .map_err(|e| AppError::BadRequest(e.to_string()))?,
                        )
                    }
                    "library" => {
                        library_name = Some(
                            field
                                .text()
                                .await
                                .map_err(|e| AppError::BadRequest(e.to_string()))?,
                        )
                    }
                    "file" => {
                        // Fields arrive in form order: csrf and library precede the files.
                        admin.check_csrf(csrf.as_deref())?;
                        let filename = field
                            .file_name()
                            .map(|f| f.rsplit(['/', '\\']).next().unwrap_or(f).to_string())
                            .filter(|f| !f.is_empty() && f.len() <= 200)
                            .ok_or_else(|| {
                                AppError::BadRequest("file: missing or long name".into())
                            })?;
                        let bytes = field.bytes().await.map_err(|e| {
                            AppError::TooLarge(format!(
                                "{filename}: upload failed or too large: {e}"
                            ))
                        })?;
                        let lib = library::ensure_library(
                            &state.db,
                            library_name.as_deref().unwrap_or("uploads"),
                        )
                        .await?;
                        let fname = filename.clone();
                        let image = tokio::task::spawn_blocking(move || {
                            library::validate_upload(&fname, &bytes)
                        })
                        .await
                        .map_err(AppError::internal)?;
                        match image {
                            Ok(image) => {
                                let item = library::NewItem {
                                    name: filename.clone(),
                                    style: None,
                                    tags: Vec::new(),
                                    image,
                                };
                                match library::insert_item(&state.db, lib, item).await? {
                                    Some(_) => stored.push(filename),
                                    None => problems.push(AppError::Conflict(format!(
                                        "{filename}: already in the library"
                                    ))),
                                }
                            }
                            Err(e) => problems.push(e),
                        }
                    }
                    other => {
                        return Err(AppError::BadRequest(format!("unexpected field {other:?}")));
                    }
                }
            }
            admin.check_csrf(csrf.as_deref())?;
            let messages: Vec<String> = problems.iter().map(AppError::public_message).collect();
            if stored.is_empty() {
                return Err(match problems.len() {
                    0 => AppError::BadRequest("no file uploaded".into()),
                    1 => problems.remove(0),
                    _ => AppError::BadRequest(messages.join("; ")),
                });
            }
            render(&MessagePage {
                title: "Upload",
                message: format!(
                    "Stored {} item(s): {}.{}",
                    stored.len(),
                    stored.join(", "),
                    if messages.is_empty() {
                        String::new()
                    } else {
                        format!(" Refused: {}", messages.join("; "))
                    }
                ),
                class: "ok",
            })
        }
        .await,
    )
}
