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

/// The Explore form as posted: one form with both buttons, so either handler receives every
/// field. It posts repeated `labels` fields (checkboxes), which serde's form decoding cannot
/// gather, so it is read pair by pair.
#[derive(Default)]
struct ExploreForm {
    csrf: Option<String>,
    library: String,
    model: Option<String>,
    labels: Vec<String>,
    kappa: Option<String>,
    tau: Option<String>,
    per_label: Option<String>,
    perplexity: Option<String>,
}

impl ExploreForm {
    /// Reads the body, refusing a field the form does not have; then checks the CSRF token.
    fn parse(body: &[u8], admin: &Admin) -> Result<Self> {
        let mut form = Self::default();
        for (k, v) in form_urlencoded::parse(body) {
            let v = v.into_owned();
            match k.as_ref() {
                "csrf" => form.csrf = Some(v),
                "library" => form.library = v,
                "model" => form.model = Some(v),
                "labels" => form.labels.push(v),
                "kappa" => form.kappa = Some(v),
                "tau" => form.tau = Some(v),
                "per_label" => form.per_label = Some(v),
                "perplexity" => form.perplexity = Some(v),
                other => {
                    return Err(AppError::BadRequest(format!(
                        "unknown field {:?}",
                        other.chars().take(40).collect::<String>()
                    )));
                }
            }
        }
        admin.check_csrf(form.csrf.as_deref())?;
        Ok(form)
    }
}

/// The taxonomy form: library, model, labels, κ and τ.
pub(super) async fn build_taxonomy(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    body: Bytes,
) -> Response {
    page(
        async {
            let form = ExploreForm::parse(&body, &admin?)?;
            let req = TaxonomyRequest {
                kappa: number("κ", form.kappa.as_deref())?,
                tau: number("τ", form.tau.as_deref())?,
                library: form.library,
                model: form.model,
                labels: form.labels,
            };
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
            let form = ExploreForm::parse(&body, &admin?)?;
            let perplexity = match form.perplexity.as_deref().map(str::trim) {
                None | Some("") => None,
                Some(v) => Some(v.parse().map_err(|_| {
                    AppError::BadRequest(format!(
                        "perplexity: a number, not {:?}",
                        v.chars().take(40).collect::<String>()
                    ))
                })?),
            };
            let req = MapRequest {
                per_label: number("representatives per label", form.per_label.as_deref())?,
                perplexity,
                library: form.library,
                model: form.model,
                labels: form.labels,
            };
            let (id, _) = map::start(&state, &req).await?;
            Ok(Redirect::to(&format!("/admin/explore/jobs/{id}")).into_response())
        }
        .await,
    )
}
