//! Training the style metric from the study page, and the stored model reports.

use axum::Router;
use axum::extract::State;
use axum::http::header;
use axum::response::{IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use serde::Deserialize;

use crate::AppState;
use crate::error::{AppError, Result};
use crate::store::ids::{ModelId, StudyId};
use crate::studies::study::{self};
use crate::studies::train::{self, ModelSummary, TrainOptions};
use crate::web::admin::Admin;
use crate::web::extract::{ApiForm, ApiPath};

use super::page;

/// Training and the stored reports.
pub(super) fn routes() -> Router<AppState> {
    Router::new()
        .route("/admin/studies/{study}/train", post(admin_train))
        .route(
            "/admin/studies/{study}/models/{model}/report",
            get(admin_report_redirect),
        )
        .route(
            "/admin/studies/{study}/models/{model}/report/",
            get(admin_report_index),
        )
        .route(
            "/admin/studies/{study}/models/{model}/report/{file}",
            get(admin_report_file),
        )
}
use crate::time::utc_minute;

/// A model as the dashboard lists it (numbers formatted).
pub(super) struct ModelRow {
    pub(super) id: ModelId,
    pub(super) status: String,
    pub(super) message: String,
    pub(super) started: String,
    pub(super) triplets: String,
    pub(super) lambda: String,
    pub(super) nonzero: String,
    pub(super) train_accuracy: String,
    pub(super) uniform_accuracy: String,
    pub(super) cv_accuracy: String,
    pub(super) held_out_uniform: String,
}

impl From<ModelSummary> for ModelRow {
    fn from(m: ModelSummary) -> Self {
        let pct = |v: Option<f64>| v.map_or_else(String::new, |v| format!("{:.1}%", 100.0 * v));
        let interval = |i: &train::Interval| {
            format!(
                "{:.1}% [{:.1}–{:.1}]",
                100.0 * i.value,
                100.0 * i.low,
                100.0 * i.high
            )
        };
        Self {
            id: m.id,
            status: m.status,
            message: m.message.unwrap_or_default(),
            started: utc_minute(m.started_at),
            triplets: m.triplets.map_or_else(String::new, |v| v.to_string()),
            lambda: m.lambda.map_or_else(String::new, |v| format!("{v:.4}")),
            nonzero: m.nonzero.map_or_else(String::new, |v| v.to_string()),
            train_accuracy: pct(m.train_accuracy),
            uniform_accuracy: pct(m.uniform_accuracy),
            // Held out with intervals when recorded (cross-validated λ), else the CV mean.
            cv_accuracy: m
                .held_out
                .as_ref()
                .map_or_else(|| pct(m.cv_accuracy), |h| interval(&h.learned)),
            held_out_uniform: m
                .held_out
                .as_ref()
                .map_or_else(String::new, |h| interval(&h.uniform)),
        }
    }
}

#[derive(Debug, Deserialize)]
struct TrainForm {
    csrf: Option<String>,
    /// Empty: λ by cross-validation.
    lambda: Option<String>,
}

async fn admin_train(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(id): ApiPath<StudyId>,
    form: std::result::Result<ApiForm<TrainForm>, AppError>,
) -> Response {
    let (admin, f) = match super::study_page::checked(admin, form, |f| f.csrf.as_deref()) {
        Ok(x) => x,
        Err(e) => return page(Err(e)),
    };
    let typed = f.lambda.clone().unwrap_or_default();
    let run = async {
        let lambda = match typed.trim() {
            "" => None,
            text => Some(
                text.parse::<f64>()
                    .map_err(|_| AppError::BadRequest(format!("λ: {text:?} is not a number")))?,
            ),
        };
        let s = study::load(&state.db, id).await?;
        let opts = TrainOptions {
            lambda,
            ..TrainOptions::default()
        };
        train::start(&state.db, &s, opts).await?;
        Ok::<_, AppError>(Redirect::to(&format!("/admin/studies/{id}#models")).into_response())
    };
    match run.await {
        Ok(r) => r,
        Err(e) => {
            let submitted = super::study_page::Submitted::Train { lambda: typed };
            super::study_page::form_error(&state, &admin, id, submitted, e).await
        }
    }
}

async fn admin_report_redirect(
    admin: std::result::Result<Admin, AppError>,
    ApiPath((id, model)): ApiPath<(StudyId, ModelId)>,
) -> Response {
    page(admin.map(|_| {
        Redirect::permanent(&format!("/admin/studies/{id}/models/{model}/report/")).into_response()
    }))
}

/// The report's policy: static (no script), its own images, the learner's inline style, and
/// never framed by another page (clickjacking).
const REPORT_CSP: &str =
    "default-src 'none'; img-src 'self'; style-src 'unsafe-inline'; frame-ancestors 'none'";

/// A stored report file. The report is static (no script); the CSP keeps it that way.
async fn report_file(
    state: &AppState,
    id: StudyId,
    model: ModelId,
    file: &str,
) -> Result<Response> {
    let (content_type, bytes) = train::file(&state.db, id, model, file).await?;
    let bytes = if file == "index.html" {
        with_back_link(bytes, id)
    } else {
        bytes
    };
    Ok((
        [
            (header::CONTENT_TYPE, content_type),
            (header::CONTENT_SECURITY_POLICY, REPORT_CSP),
            (header::X_FRAME_OPTIONS, "DENY"),
        ],
        bytes,
    )
        .into_response())
}

/// The learner writes a report that knows nothing of the platform; served here it opens with a
/// link back to its study's models (also for reports stored before the link existed).
fn with_back_link(html: Vec<u8>, id: StudyId) -> Vec<u8> {
    let link = format!("<nav><a href=\"/admin/studies/{id}#models\">← Back to the study</a></nav>");
    let text = String::from_utf8_lossy(&html);
    // After the learner's `<style>` block (the head's last element), else first.
    match text.find("</style>") {
        Some(at) => {
            let at = at + "</style>".len();
            format!("{}{link}{}", &text[..at], &text[at..]).into_bytes()
        }
        None => format!("{link}{text}").into_bytes(),
    }
}

async fn admin_report_index(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath((id, model)): ApiPath<(StudyId, ModelId)>,
) -> Response {
    page(
        async {
            admin?;
            report_file(&state, id, model, "index.html").await
        }
        .await,
    )
}

async fn admin_report_file(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath((id, model, file)): ApiPath<(StudyId, ModelId, String)>,
) -> Response {
    page(
        async {
            admin?;
            report_file(&state, id, model, &file).await
        }
        .await,
    )
}
