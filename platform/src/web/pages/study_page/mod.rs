//! The admin study page: overview (dashboard), quality control, workers (each managed from its
//! row: approve/reject, block/unblock, bonus), audit trail, settings, exports and the models
//! list, in sections reached from a bar of links at the top; and the forms it posts.
//!
//! A form whose input is refused re-renders the page with the error next to that form and the
//! admin's input kept (with the error's status), instead of a page that only shows the error.
//! Requests that are not the admin's own doing — no session, a wrong CSRF token — still get the
//! plain error page.

use std::collections::HashMap;

use askama::Template;
use axum::Router;
use axum::extract::rejection::QueryRejection;
use axum::extract::{Query, State};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};

use crate::AppState;
use crate::error::{AppError, Result};
use crate::flow::qc::{self, RuleOutcome};
use crate::store::ids::StudyId;
use crate::studies::bonus;
use crate::studies::dashboard;
use crate::studies::export::{self, ExportOptions};
use crate::studies::study::{self, MturkMode, StudySettings};
use crate::studies::study_edit;
use crate::studies::train::{self};
use crate::web::admin::Admin;
use crate::web::extract::{ApiPath, ApiQuery};

use super::models::ModelRow;
use super::{page, render};
use crate::time::{utc_hour, utc_minute};

mod forms;
mod listed;
mod pool;
mod workers;

use listed::{AuditRow, BonusRow, ChangeRow};

pub(super) use forms::checked;
use forms::{SettingsFields, SettingsForm};

/// The study page and the forms it posts.
pub(super) fn routes() -> Router<AppState> {
    Router::new()
        .route("/admin/studies/{study}", get(admin_study))
        .route("/admin/studies/{study}/qc", post(forms::admin_qc))
        .route(
            "/admin/studies/{study}/decision",
            post(forms::admin_decision),
        )
        .route(
            "/admin/studies/{study}/settings",
            post(forms::admin_settings),
        )
        .route(
            "/admin/studies/{study}/workers/{assignment}/block",
            post(workers::admin_block),
        )
        .route(
            "/admin/studies/{study}/workers/{assignment}/bonus",
            post(workers::admin_bonus),
        )
        .route("/admin/studies/{study}/export/{file}", get(admin_export))
}

#[derive(Template)]
#[template(path = "admin_study.html")]
struct AdminStudy {
    id: StudyId,
    name: String,
    csrf: String,
    sandbox: bool,
    worker_link: String,
    /// The pool's progress, failure and warnings.
    pool: pool::PoolView,
    /// A composition-rating study's report (the preference rate and its t-test).
    rating: Option<crate::studies::rating::RatingReport>,
    /// A mash-up study's report (mean position per condition).
    mashup: Option<crate::studies::mashup::MashupReport>,
    /// An icon-set study's report (time and deletions per set per condition).
    iconset: Option<crate::studies::iconset::IconsetReport>,
    d: dashboard::Dashboard,
    rejection_rate: String,
    agreement: String,
    ceiling: String,
    median: String,
    /// Completed HITs by control errors, drawn as `<meter>`s up to `histogram_max`.
    histogram: Vec<dashboard::ErrorCount>,
    histogram_max: i64,
    per_hour: Vec<(String, i64)>,
    /// The QC form's threshold: as last submitted, else the study's.
    threshold: String,
    qc: Vec<RuleOutcome>,
    workers: Vec<dashboard::WorkerRow>,
    bonuses: Vec<BonusRow>,
    audit: Vec<AuditRow>,
    /// The export links' options (the exports form) and their query string.
    export: ExportOptions,
    export_query: String,
    files: Vec<&'static str>,
    models: Vec<ModelRow>,
    training_running: bool,
    settings: StudySettings,
    /// The settings form's fields: the stored settings, or what the admin sent with an error.
    sf: SettingsFields,
    /// Whether the study has assignments (the HIT shape and the site are then fixed).
    started: bool,
    changes: Vec<ChangeRow>,
    /// The refused form, if any.
    error: Option<FormError>,
}

/// What the admin sent with a form the page shows an error for.
pub(super) enum Submitted {
    Settings(Box<SettingsForm>),
    Qc {
        threshold: String,
    },
    Decision {
        assignment: i64,
    },
    Block {
        assignment: i64,
    },
    Bonus {
        assignment: i64,
        amount: String,
        reason: String,
    },
    Train {
        lambda: String,
    },
}

/// A refused form: what was sent and why it was refused.
pub(super) struct FormError {
    submitted: Submitted,
    message: String,
}

impl AdminStudy {
    /// The error of a page-wide form (`settings`, `qc`, `train`).
    fn error_for(&self, form: &str) -> Option<&str> {
        let e = self.error.as_ref()?;
        let matches = matches!(
            (&e.submitted, form),
            (Submitted::Settings(_), "settings")
                | (Submitted::Qc { .. }, "qc")
                | (Submitted::Train { .. }, "train")
        );
        matches.then_some(e.message.as_str())
    }

    /// The error of a form in the worker row of `assignment`.
    fn row_error(&self, assignment: &i64) -> Option<&str> {
        let e = self.error.as_ref()?;
        match e.submitted {
            Submitted::Decision { assignment: a }
            | Submitted::Block { assignment: a }
            | Submitted::Bonus { assignment: a, .. }
                if a == *assignment =>
            {
                Some(e.message.as_str())
            }
            _ => None,
        }
    }

    /// The error of a worker-row form whose row is not on the page (an assignment that does
    /// not exist, or is not this study's): shown above the worker table.
    fn unplaced_row_error(&self) -> Option<&str> {
        let e = self.error.as_ref()?;
        let (Submitted::Decision { assignment }
        | Submitted::Block { assignment }
        | Submitted::Bonus { assignment, .. }) = e.submitted
        else {
            return None;
        };
        (!self.workers.iter().any(|w| w.assignment == assignment)).then_some(e.message.as_str())
    }

    /// The bonus form of `assignment` as the admin filled it in (amount, reason), when it was
    /// refused.
    fn bonus_kept(&self, assignment: &i64) -> Option<(&str, &str)> {
        match &self.error.as_ref()?.submitted {
            Submitted::Bonus {
                assignment: a,
                amount,
                reason,
            } if a == assignment => Some((amount, reason)),
            _ => None,
        }
    }

    fn bonus_amount(&self, assignment: &i64) -> &str {
        self.bonus_kept(assignment).map_or("", |k| k.0)
    }

    fn bonus_reason(&self, assignment: &i64) -> &str {
        self.bonus_kept(assignment).map_or("", |k| k.1)
    }

    /// A worker row's start time, readable.
    fn minute(&self, ms: &i64) -> String {
        utc_minute(*ms)
    }

    /// A worker row's bonus total (empty when none).
    fn bonus_total(&self, cents: &i64) -> String {
        if *cents > 0 {
            bonus::format_cents(*cents)
        } else {
            String::new()
        }
    }

    /// The train form's λ as the admin typed it, when it was refused.
    fn lambda_kept(&self) -> &str {
        match self.error.as_ref().map(|e| &e.submitted) {
            Some(Submitted::Train { lambda }) => lambda,
            _ => "",
        }
    }
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "—".into(), |x| format!("{x:.3}"))
}

/// What the page shows beyond the stored state.
#[derive(Default)]
struct View {
    /// The rule's outcomes of a QC dry run or application, with the threshold used.
    qc: Vec<RuleOutcome>,
    threshold: Option<String>,
    export: ExportOptions,
    error: Option<FormError>,
}

async fn study_page(state: &AppState, admin: &Admin, id: StudyId, view: View) -> Result<Response> {
    let s = study::load(&state.db, id).await?;
    let (d, workers) = dashboard::compute(&state.db, &s).await?;
    let models = train::list(&state.db, id).await?;
    let histogram_max = d
        .control_error_histogram
        .iter()
        .map(|bin| bin.count)
        .max()
        .unwrap_or(1)
        .max(1);
    let mut sf = SettingsFields::stored(&s.settings);
    if let Some(FormError {
        submitted: Submitted::Settings(form),
        ..
    }) = &view.error
    {
        sf.keep(form);
    }
    let threshold = match &view.error {
        Some(FormError {
            submitted: Submitted::Qc { threshold },
            ..
        }) => threshold.clone(),
        _ => view
            .threshold
            .unwrap_or_else(|| s.settings.reject_at_control_errors.to_string()),
    };
    let report = crate::studies::report::report(&state.db, &s).await?;
    render(&AdminStudy {
        id,
        name: s.name.clone(),
        csrf: admin.csrf.clone(),
        sandbox: s.settings.mturk_mode == MturkMode::Sandbox,
        worker_link: format!(
            "{}/s/{id}?participant=PARTICIPANT_ID",
            state.settings.public_url.trim_end_matches('/')
        ),
        pool: pool::PoolView::of(&state.db, &s).await?,
        rating: match &report {
            crate::studies::report::StudyReport::CompositionRating(r) => Some(r.clone()),
            _ => None,
        },
        mashup: match &report {
            crate::studies::report::StudyReport::Mashup(m) => Some(m.clone()),
            _ => None,
        },
        iconset: match report {
            crate::studies::report::StudyReport::Iconset(r) => Some(r),
            _ => None,
        },
        rejection_rate: fmt_opt(d.rejection_rate),
        agreement: fmt_opt(d.agreement_with_majority),
        ceiling: fmt_opt(d.noise_ceiling),
        median: fmt_opt(d.median_seconds_per_question),
        histogram: d.control_error_histogram.clone(),
        histogram_max,
        per_hour: d
            .answers_per_hour
            .iter()
            .map(|h| (utc_hour(h.hour), h.count))
            .collect(),
        d,
        threshold,
        qc: view.qc,
        workers,
        bonuses: bonus::list(&state.db, id)
            .await?
            .into_iter()
            .map(BonusRow::from)
            .collect(),
        audit: qc::audit(&state.db, id)
            .await?
            .into_iter()
            .map(AuditRow::from)
            .collect(),
        export_query: view.export.query(),
        files: export::FILES
            .iter()
            .copied()
            .filter(|f| !(view.export.pseudonymous && export::is_payment_file(f)))
            .collect(),
        export: view.export,
        training_running: models.iter().any(|m| m.status == "running"),
        models: models.into_iter().map(ModelRow::from).collect(),
        started: study_edit::started(&state.db, id).await?,
        sf,
        changes: study_edit::changes(&state.db, id)
            .await?
            .into_iter()
            .map(ChangeRow::from)
            .collect(),
        settings: s.settings,
        error: view.error,
    })
}

/// The response to a refused form: the study page with the error next to the form and the
/// input kept, with the error's status. A missing session or CSRF token, a study that does
/// not exist and server failures get the plain error page.
pub(super) async fn form_error(
    state: &AppState,
    admin: &Admin,
    id: StudyId,
    submitted: Submitted,
    e: AppError,
) -> Response {
    let inline = matches!(
        e,
        AppError::BadRequest(_) | AppError::Conflict(_) | AppError::NotFound(_)
    );
    if !inline {
        return page(Err(e));
    }
    let view = View {
        error: Some(FormError {
            submitted,
            message: e.public_message(),
        }),
        ..View::default()
    };
    match study_page(state, admin, id, view).await {
        Ok(html) => (e.status(), html).into_response(),
        Err(_) => page(Err(e)),
    }
}

/// The export options of the page's exports form, read leniently (`true`, `on` or `1`): a
/// malformed option in the page's address shows the page with the option off.
fn export_options(query: &HashMap<String, String>) -> ExportOptions {
    let on = |k: &str| {
        query
            .get(k)
            .is_some_and(|v| matches!(v.as_str(), "true" | "on" | "1"))
    };
    ExportOptions {
        include_controls: on("include_controls"),
        include_rejected: on("include_rejected"),
        include_incomplete: on("include_incomplete"),
        pseudonymous: on("pseudonymous"),
    }
}

async fn admin_study(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(id): ApiPath<StudyId>,
    query: std::result::Result<Query<HashMap<String, String>>, QueryRejection>,
) -> Response {
    let export = query.map(|Query(q)| export_options(&q)).unwrap_or_default();
    page(
        async {
            let view = View {
                export,
                ..View::default()
            };
            study_page(&state, &admin?, id, view).await
        }
        .await,
    )
}

async fn admin_export(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath((id, file)): ApiPath<(StudyId, String)>,
    ApiQuery(opts): ApiQuery<ExportOptions>,
) -> Response {
    page(
        async {
            admin?;
            Ok(crate::web::api::export_file(&state, id, &file, opts)
                .await?
                .into_response())
        }
        .await,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn export_options_from_the_page_address_are_lenient() {
        let q: HashMap<String, String> = [
            ("include_controls", "true"),
            ("include_rejected", "on"),
            ("include_incomplete", "yes"),
            ("refresh", "5"),
        ]
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
        let o = export_options(&q);
        assert!(o.include_controls && o.include_rejected);
        assert!(!o.include_incomplete && !o.pseudonymous);
    }
}
