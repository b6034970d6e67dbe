//! The study page's page-wide forms: quality control, settings, and the approve/reject
//! override of a worker's row.

use std::collections::BTreeMap;

use axum::extract::State;
use axum::response::{IntoResponse, Redirect, Response};
use serde::Deserialize;

use crate::AppState;
use crate::error::{AppError, Result};
use crate::flow::qc;
use crate::store::ids::{AssignmentId, StudyId};
use crate::studies::study::{MturkMode, StudySettings};
use crate::studies::study_edit::{self, SettingsPatch};
use crate::web::admin::Admin;
use crate::web::extract::{ApiForm, ApiPath};

use super::super::page;
use super::{Submitted, View, form_error, study_page};

/// The admin and the form, once the session and the form's CSRF token are checked. Callers
/// show the plain error page for a failure: it is not the admin's input to correct.
pub(in crate::web::pages) fn checked<F>(
    admin: std::result::Result<Admin, AppError>,
    form: std::result::Result<ApiForm<F>, AppError>,
    csrf: impl FnOnce(&F) -> Option<&str>,
) -> Result<(Admin, F)> {
    let admin = admin?;
    let ApiForm(f) = form?;
    admin.check_csrf(csrf(&f))?;
    Ok((admin, f))
}

#[derive(Debug, Deserialize)]
pub(super) struct QcForm {
    csrf: Option<String>,
    threshold: Option<String>,
    mode: Option<String>,
}

pub(super) async fn admin_qc(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(id): ApiPath<StudyId>,
    form: std::result::Result<ApiForm<QcForm>, AppError>,
) -> Response {
    let (admin, f) = match checked(admin, form, |f| f.csrf.as_deref()) {
        Ok(x) => x,
        Err(e) => return page(Err(e)),
    };
    let threshold = f.threshold.clone().unwrap_or_default();
    let run = async {
        let apply = match f.mode.as_deref() {
            Some("apply") => true,
            Some("dry_run") => false,
            _ => return Err(AppError::BadRequest("mode: dry_run or apply".into())),
        };
        let t: u32 = threshold.trim().parse().map_err(|_| {
            AppError::BadRequest(format!(
                "threshold: {threshold:?} is not a whole number of control errors"
            ))
        })?;
        let actor = format!("admin:{}", admin.username);
        let qc = qc::evaluate(&state.db, id, t, apply, &actor).await?;
        let view = View {
            qc,
            threshold: Some(threshold.clone()),
            ..View::default()
        };
        study_page(&state, &admin, id, view).await
    };
    match run.await {
        Ok(r) => r,
        Err(e) => form_error(&state, &admin, id, Submitted::Qc { threshold }, e).await,
    }
}

/// The settings form of the study page: every field a string, parsed with messages that name
/// the field. Fields the page does not offer (the HIT shape and the site once assignments
/// exist) are absent and stay as they are; a field it never offers is refused by name.
#[derive(Debug, Default, Deserialize)]
pub(in crate::web::pages) struct SettingsForm {
    csrf: Option<String>,
    description: Option<String>,
    /// Markdown.
    instructions: Option<String>,
    /// `yes` or `no`.
    show_worked_example: Option<String>,
    /// Markdown; empty: no consent step.
    consent: Option<String>,
    max_training_attempts: Option<String>,
    reasons_probability: Option<String>,
    reject_at_control_errors: Option<String>,
    prolific_completion_code: Option<String>,
    prolific_screenout_code: Option<String>,
    prolific_noconsent_code: Option<String>,
    /// One worker id per line.
    blocked_workers: Option<String>,
    /// Study ids separated by commas or spaces.
    exclude_workers_of: Option<String>,
    questions_per_hit: Option<String>,
    controls_per_hit: Option<String>,
    mturk_mode: Option<String>,
    /// Anything else (refused, naming the field).
    #[serde(flatten)]
    other: BTreeMap<String, String>,
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
        if let Some(field) = self.other.keys().next() {
            return Err(AppError::BadRequest(format!(
                "{field}: not a setting this form can change"
            )));
        }
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
        let show_worked_example = match self.show_worked_example.as_deref() {
            None => None,
            Some("yes") => Some(true),
            Some("no") => Some(false),
            Some(other) => {
                return Err(AppError::BadRequest(format!(
                    "show_worked_example: {other:?} is not yes or no"
                )));
            }
        };
        Ok(SettingsPatch {
            description: text(&self.description),
            instructions: text(&self.instructions),
            show_worked_example,
            consent: text(&self.consent),
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
            prolific_noconsent_code: code(&self.prolific_noconsent_code),
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

/// The settings form's fields as the page fills them in.
pub(in crate::web::pages) struct SettingsFields {
    pub(super) description: String,
    pub(super) instructions: String,
    /// `yes` or `no`.
    pub(super) show_worked_example: String,
    pub(super) consent: String,
    pub(super) max_training_attempts: String,
    pub(super) reasons_probability: String,
    pub(super) reject_at_control_errors: String,
    pub(super) prolific_completion_code: String,
    pub(super) prolific_screenout_code: String,
    pub(super) prolific_noconsent_code: String,
    /// `blocked_workers`, one per line.
    pub(super) blocked_workers: String,
    /// `exclude_workers_of`, comma-separated.
    pub(super) exclude_workers_of: String,
    pub(super) questions_per_hit: String,
    pub(super) controls_per_hit: String,
    /// `sandbox` or `live`.
    pub(super) mturk_mode: String,
}

impl SettingsFields {
    /// The stored settings.
    pub(super) fn stored(s: &StudySettings) -> Self {
        Self {
            description: s.description.clone(),
            instructions: s.instructions.clone(),
            show_worked_example: if s.show_worked_example { "yes" } else { "no" }.into(),
            consent: s.consent.clone(),
            max_training_attempts: s.max_training_attempts.to_string(),
            reasons_probability: s.reasons_probability.to_string(),
            reject_at_control_errors: s.reject_at_control_errors.to_string(),
            prolific_completion_code: s.prolific_completion_code.clone().unwrap_or_default(),
            prolific_screenout_code: s.prolific_screenout_code.clone().unwrap_or_default(),
            prolific_noconsent_code: s.prolific_noconsent_code.clone().unwrap_or_default(),
            blocked_workers: s.blocked_workers.join("\n"),
            exclude_workers_of: s
                .exclude_workers_of
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", "),
            questions_per_hit: s.questions_per_hit.to_string(),
            controls_per_hit: s.controls_per_hit.to_string(),
            mturk_mode: match s.mturk_mode {
                MturkMode::Sandbox => "sandbox",
                MturkMode::Live => "live",
            }
            .into(),
        }
    }

    /// What the admin sent, over the stored values (for a refused form).
    pub(super) fn keep(&mut self, f: &SettingsForm) {
        let pairs = [
            (&mut self.description, &f.description),
            (&mut self.instructions, &f.instructions),
            (&mut self.show_worked_example, &f.show_worked_example),
            (&mut self.consent, &f.consent),
            (
                &mut self.prolific_noconsent_code,
                &f.prolific_noconsent_code,
            ),
            (&mut self.max_training_attempts, &f.max_training_attempts),
            (&mut self.reasons_probability, &f.reasons_probability),
            (
                &mut self.reject_at_control_errors,
                &f.reject_at_control_errors,
            ),
            (
                &mut self.prolific_completion_code,
                &f.prolific_completion_code,
            ),
            (
                &mut self.prolific_screenout_code,
                &f.prolific_screenout_code,
            ),
            (&mut self.blocked_workers, &f.blocked_workers),
            (&mut self.exclude_workers_of, &f.exclude_workers_of),
            (&mut self.questions_per_hit, &f.questions_per_hit),
            (&mut self.controls_per_hit, &f.controls_per_hit),
            (&mut self.mturk_mode, &f.mturk_mode),
        ];
        for (field, sent) in pairs {
            if let Some(v) = sent {
                *field = v.replace("\r\n", "\n");
            }
        }
    }
}

pub(super) async fn admin_settings(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(id): ApiPath<StudyId>,
    form: std::result::Result<ApiForm<SettingsForm>, AppError>,
) -> Response {
    let (admin, f) = match checked(admin, form, |f| f.csrf.as_deref()) {
        Ok(x) => x,
        Err(e) => return page(Err(e)),
    };
    let run = async {
        let patch = f.patch()?;
        study_edit::edit(&state.db, id, &patch, &format!("admin:{}", admin.username)).await?;
        Ok::<_, AppError>(Redirect::to(&format!("/admin/studies/{id}#settings")).into_response())
    };
    match run.await {
        Ok(r) => r,
        Err(e) => form_error(&state, &admin, id, Submitted::Settings(Box::new(f)), e).await,
    }
}

#[derive(Debug, Deserialize)]
pub(super) struct DecisionForm {
    csrf: Option<String>,
    assignment: Option<String>,
    decision: Option<String>,
}

pub(super) async fn admin_decision(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(id): ApiPath<StudyId>,
    form: std::result::Result<ApiForm<DecisionForm>, AppError>,
) -> Response {
    let (admin, f) = match checked(admin, form, |f| f.csrf.as_deref()) {
        Ok(x) => x,
        Err(e) => return page(Err(e)),
    };
    let assignment: Option<AssignmentId> = f.assignment.as_deref().and_then(|a| a.parse().ok());
    let run = async {
        let assignment = assignment
            .ok_or_else(|| AppError::BadRequest("assignment: not an assignment id".into()))?;
        let decision = f.decision.as_deref().unwrap_or_default();
        qc::override_decision(&state.db, id, assignment, decision, &admin.username).await?;
        Ok::<_, AppError>(
            Redirect::to(&format!("/admin/studies/{id}#worker-{assignment}")).into_response(),
        )
    };
    match run.await {
        Ok(r) => r,
        Err(e) => {
            let assignment = assignment.map_or(0, |a| a.0);
            form_error(&state, &admin, id, Submitted::Decision { assignment }, e).await
        }
    }
}
