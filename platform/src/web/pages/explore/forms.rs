//! The Explore forms: a taxonomy or a style map of the chosen labels, as a background job.

use axum::body::Bytes;
use axum::extract::State;
use axum::response::{IntoResponse, Redirect, Response};

use super::super::page;
use crate::AppState;
use crate::error::{AppError, Result};
use crate::explore::map::{self, MapRequest};
use crate::explore::taxonomy::{self, TaxonomyRequest};
use crate::web::admin::Admin;

/// A whole number field of the form (empty: the default).
pub(super) fn number(name: &str, value: Option<&str>) -> Result<Option<usize>> {
    match value.map(str::trim) {
        None | Some("") => Ok(None),
        Some(v) => v.parse().map(Some).map_err(|_| {
            AppError::BadRequest(format!(
                "{name}: a whole number, not {:?}",
                v.chars().take(40).collect::<String>()
            ))
        }),
    }
}

/// The form posts repeated `labels` fields (checkboxes), which serde's form decoding cannot
/// gather, so it is read pair by pair.
pub(super) async fn build_taxonomy(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    body: Bytes,
) -> Response {
    page(
        async {
            let admin = admin?;
            let mut req = TaxonomyRequest::default();
            let (mut csrf, mut kappa, mut tau) = (None, None, None);
            for (k, v) in form_urlencoded::parse(&body) {
                match k.as_ref() {
                    "csrf" => csrf = Some(v.into_owned()),
                    "library" => req.library = v.into_owned(),
                    "model" => req.model = Some(v.into_owned()),
                    "labels" => req.labels.push(v.into_owned()),
                    "kappa" => kappa = Some(v.into_owned()),
                    "tau" => tau = Some(v.into_owned()),
                    // The map's fields: one form has both buttons.
                    "per_label" | "perplexity" => {}
                    other => {
                        return Err(AppError::BadRequest(format!(
                            "unknown field {:?}",
                            other.chars().take(40).collect::<String>()
                        )));
                    }
                }
            }
            admin.check_csrf(csrf.as_deref())?;
            req.kappa = number("κ", kappa.as_deref())?;
            req.tau = number("τ", tau.as_deref())?;
            let (id, _) = taxonomy::start(&state, &req).await?;
            Ok(Redirect::to(&format!("/admin/explore/jobs/{id}")).into_response())
        }
        .await,
    )
}

/// The map form: the same library, model and labels, the representatives per label (empty:
/// every item) and the perplexity.
pub(super) async fn build_map(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    body: Bytes,
) -> Response {
    page(
        async {
            let admin = admin?;
            let mut req = MapRequest::default();
            let (mut csrf, mut per_label, mut perplexity) = (None, None, None);
            for (k, v) in form_urlencoded::parse(&body) {
                match k.as_ref() {
                    "csrf" => csrf = Some(v.into_owned()),
                    "library" => req.library = v.into_owned(),
                    "model" => req.model = Some(v.into_owned()),
                    "labels" => req.labels.push(v.into_owned()),
                    "per_label" => per_label = Some(v.into_owned()),
                    "perplexity" => perplexity = Some(v.into_owned()),
                    // The taxonomy's fields: one form has both buttons.
                    "kappa" | "tau" => {}
                    other => {
                        return Err(AppError::BadRequest(format!(
                            "unknown field {:?}",
                            other.chars().take(40).collect::<String>()
                        )));
                    }
                }
            }
            admin.check_csrf(csrf.as_deref())?;
            req.per_label = number("representatives per label", per_label.as_deref())?;
            req.perplexity = match perplexity.as_deref().map(str::trim) {
                None | Some("") => None,
                Some(v) => Some(v.parse().map_err(|_| {
                    AppError::BadRequest(format!(
                        "perplexity: a number, not {:?}",
                        v.chars().take(40).collect::<String>()
                    ))
                })?),
            };
            let (id, _) = map::start(&state, &req).await?;
            Ok(Redirect::to(&format!("/admin/explore/jobs/{id}")).into_response())
        }
        .await,
    )
}
