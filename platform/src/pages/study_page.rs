//! The admin study page: dashboard, quality control, workers, audit trail, settings, exports
//! and the models list, and the forms it posts.

use askama::Template;
use axum::Router;
use axum::extract::State;
use axum::response::{IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use serde::Deserialize;

use crate::AppState;
use crate::admin::Admin;
use crate::dashboard;
use crate::error::{AppError, Result};
use crate::export::{self, ExportOptions};
use crate::extract::{ApiForm, ApiPath, ApiQuery};
use crate::ids::{AssignmentId, StudyId};
use crate::qc::{self, DecisionRecord, RuleOutcome};
use crate::study::{self, MturkMode, StudySettings};
use crate::study_edit::{self, SettingsChange, SettingsPatch};
use crate::train::{self};

use super::models::ModelRow;
use super::time::{utc_hour, utc_minute};

/// The study page and the forms it posts.
pub(super) fn routes() -> Router<AppState> {
    Router::new()
        .route("/admin/studies/{study}", get(admin_study))
        .route("/admin/studies/{study}/qc", post(admin_qc))
        .route("/admin/studies/{study}/decision", post(admin_decision))
        .route("/admin/studies/{study}/settings", post(admin_settings))
        .route("/admin/studies/{study}/export/{file}", get(admin_export))
}
use super::{page, render};

#[derive(Template)]
#[template(path = "admin_study.html")]
struct AdminStudy {
    id: StudyId,
    name: String,
    csrf: String,
    sandbox: bool,
    worker_link: String,
    d: dashboard::Dashboard,
    rejection_rate: String,
    agreement: String,
    ceiling: String,
    median: String,
    /// Completed HITs by control errors, drawn as `<meter>`s up to `histogram_max`.
    histogram: Vec<dashboard::ErrorCount>,
    histogram_max: i64,
    per_hour: Vec<(String, i64)>,
    threshold: u32,
    qc: Vec<RuleOutcome>,
    workers: Vec<dashboard::WorkerRow>,
    audit: Vec<DecisionRecord>,
    files: &'static [&'static str],
    models: Vec<ModelRow>,
    training_running: bool,
    settings: StudySettings,
    /// Whether the study has assignments (the HIT shape and the site are then fixed).
    started: bool,
    /// `blocked_workers`, one per line (the form's textarea).
    blocked: String,
    /// `exclude_workers_of`, comma-separated.
    excluded: String,
    changes: Vec<ChangeRow>,
}

/// A settings change as the study page lists it.
struct ChangeRow {
    at: String,
    field: String,
    old: String,
    new: String,
    actor: String,
}

impl From<SettingsChange> for ChangeRow {
    fn from(c: SettingsChange) -> Self {
        Self {
            at: utc_minute(c.changed_at),
            field: c.field,
            old: c.old.to_string(),
            new: c.new.to_string(),
            actor: c.actor,
        }
    }
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "—".into(), |x| format!("{x:.3}"))
}

async fn study_page(
    state: &AppState,
    admin: &Admin,
    id: StudyId,
    qc_result: Vec<RuleOutcome>,
) -> Result<Response> {
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
    render(&AdminStudy {
        id,
        name: s.name.clone(),
        csrf: admin.csrf.clone(),
        sandbox: s.settings.mturk_mode == MturkMode::Sandbox,
        worker_link: format!(
            "{}/s/{id}?participant=PARTICIPANT_ID",
            state.settings.public_url.trim_end_matches('/')
        ),
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
        threshold: s.settings.reject_at_control_errors,
        qc: qc_result,
        workers,
        audit: qc::audit(&state.db, id).await?,
        files: export::FILES,
        training_running: models.iter().any(|m| m.status == "running"),
        models: models.into_iter().map(ModelRow::from).collect(),
        started: study_edit::started(&state.db, id).await?,
        blocked: s.settings.blocked_workers.join("\n"),
        excluded: s
            .settings
            .exclude_workers_of
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(", "),
        changes: study_edit::changes(&state.db, id)
            .await?
            .into_iter()
            .map(ChangeRow::from)
            .collect(),
        settings: s.settings,
    })
}

async fn admin_study(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(id): ApiPath<StudyId>,
) -> Response {
    page(async { study_page(&state, &admin?, id, Vec::new()).await }.await)
}

#[derive(Debug, Deserialize)]
struct QcForm {
    csrf: Option<String>,
    threshold: u32,
    mode: String,
}

async fn admin_qc(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(id): ApiPath<StudyId>,
    form: std::result::Result<ApiForm<QcForm>, AppError>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let ApiForm(f) = form?;
            admin.check_csrf(f.csrf.as_deref())?;
            let apply = match f.mode.as_str() {
                "apply" => true,
                "dry_run" => false,
                _ => return Err(AppError::BadRequest("mode: dry_run or apply".into())),
            };
            let result = qc::evaluate(
                &state.db,
                id,
                f.threshold,
                apply,
                &format!("admin:{}", admin.username),
            )
            .await?;
            study_page(&state, &admin, id, result).await
        }
        .await,
    )
}

/// The settings form of the study page: every field a string, parsed with messages that name
/// the field. Fields the page does not offer (the HIT shape and the site once assignments
/// exist) are absent and stay as they are.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SettingsForm {
    csrf: Option<String>,
    description: Option<String>,
    max_training_attempts: Option<String>,
    reasons_probability: Option<String>,
    reject_at_control_errors: Option<String>,
    prolific_completion_code: Option<String>,
    prolific_screenout_code: Option<String>,
    /// One worker id per line.
    blocked_workers: Option<String>,
    /// Study ids separated by commas or spaces.
    exclude_workers_of: Option<String>,
    questions_per_hit: Option<String>,
    controls_per_hit: Option<String>,
    mturk_mode: Option<String>,
}

/// A number field of a form, if sent.
fn form_number<T: std::str::FromStr>(field: &str, value: Option<&str>) -> Result<Option<T>> {
    value
        .map(|v| {
            v.trim()
                .parse()
                .map_err(|_| AppError::BadRequest(format!("{field}: {v:?} is not a valid number")))
        })
        .transpose()
}

impl SettingsForm {
    fn patch(&self) -> Result<SettingsPatch> {
        // Browsers send a textarea's line breaks as CRLF.
        let text = |v: &Option<String>| v.as_ref().map(|v| v.replace("\r\n", "\n"));
        let code = |v: &Option<String>| {
            v.as_ref()
                .map(|v| Some(v.trim().to_string()).filter(|v| !v.is_empty()))
        };
        let exclude_workers_of = match &self.exclude_workers_of {
            None => None,
            Some(list) => Some(
                list.split([',', ' ', '\n', '\r', '\t'])
                    .filter(|x| !x.is_empty())
                    .map(|x| {
                        x.parse().map_err(|_| {
                            AppError::BadRequest(format!(
                                "exclude_workers_of: {x:?} is not a study id"
                            ))
                        })
                    })
                    .collect::<Result<Vec<StudyId>>>()?,
            ),
        };
        let mturk_mode = match self.mturk_mode.as_deref() {
            None => None,
            Some("sandbox") => Some(MturkMode::Sandbox),
            Some("live") => Some(MturkMode::Live),
            Some(other) => {
                return Err(AppError::BadRequest(format!(
                    "mturk_mode: {other:?} is not sandbox or live"
                )));
            }
        };
        Ok(SettingsPatch {
            description: text(&self.description),
            max_training_attempts: form_number(
                "max_training_attempts",
                self.max_training_attempts.as_deref(),
            )?,
            reasons_probability: form_number(
                "reasons_probability",
                self.reasons_probability.as_deref(),
            )?,
            reject_at_control_errors: form_number(
                "reject_at_control_errors",
                self.reject_at_control_errors.as_deref(),
            )?,
            prolific_completion_code: code(&self.prolific_completion_code),
            prolific_screenout_code: code(&self.prolific_screenout_code),
            blocked_workers: text(&self.blocked_workers).map(|v| {
                v.lines()
                    .map(str::trim)
                    .filter(|w| !w.is_empty())
                    .map(str::to_string)
                    .collect()
            }),
            exclude_workers_of,
            questions_per_hit: form_number("questions_per_hit", self.questions_per_hit.as_deref())?,
            controls_per_hit: form_number("controls_per_hit", self.controls_per_hit.as_deref())?,
            mturk_mode,
            ..SettingsPatch::default()
        })
    }
}

async fn admin_settings(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(id): ApiPath<StudyId>,
    form: std::result::Result<ApiForm<SettingsForm>, AppError>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let ApiForm(f) = form?;
            admin.check_csrf(f.csrf.as_deref())?;
            let patch = f.patch()?;
            study_edit::edit(&state.db, id, &patch, &format!("admin:{}", admin.username)).await?;
            Ok(Redirect::to(&format!("/admin/studies/{id}#settings")).into_response())
        }
        .await,
    )
}

#[derive(Debug, Deserialize)]
struct DecisionForm {
    csrf: Option<String>,
    assignment: AssignmentId,
    decision: String,
}

async fn admin_decision(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(id): ApiPath<StudyId>,
    form: std::result::Result<ApiForm<DecisionForm>, AppError>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let ApiForm(f) = form?;
            admin.check_csrf(f.csrf.as_deref())?;
            qc::override_decision(&state.db, id, f.assignment, &f.decision, &admin.username)
                .await?;
            Ok(Redirect::to(&format!("/admin/studies/{id}")).into_response())
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
            Ok(crate::api::export_file(&state, id, &file, opts)
                .await?
                .into_response())
        }
        .await,
    )
}
