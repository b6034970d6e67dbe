//! The worker pages: start (MTurk / Prolific / direct), training, questions, the reasons
//! questionnaire and the done page, on top of the same [`crate::flow`] functions as the JSON API.

use askama::Template;
use axum::Router;
use axum::extract::State;
use axum::response::{IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use serde::Deserialize;

use crate::AppState;
use crate::error::{AppError, Result};
use crate::extract::{ApiForm, ApiPath, ApiQuery};
use crate::flow::{self, Demographics, Handback, QuestionView, Source, StartOutcome, StartRequest};
use crate::ids::{ItemId, StudyId};
use crate::study::{self, MturkMode};

/// The worker pages' routes.
pub(super) fn routes() -> Router<AppState> {
    Router::new()
        .route("/s/{study}", get(start_page))
        .route("/s/{study}/start", post(start_submit))
        .route("/a/{token}", get(assignment_page))
        .route("/a/{token}/training", post(training_submit))
        .route("/a/{token}/give-up", post(give_up_submit))
        .route("/a/{token}/answer", post(answer_submit))
        .route("/a/{token}/reasons", post(reasons_submit))
}
use super::{page, render};

/// The query string MTurk / Prolific / a direct link put on the start page.
#[derive(Debug, Default, Deserialize)]
struct StartQuery {
    #[serde(rename = "assignmentId")]
    assignment_id: Option<String>,
    #[serde(rename = "hitId")]
    hit_id: Option<String>,
    #[serde(rename = "workerId")]
    worker_id: Option<String>,
    #[serde(rename = "turkSubmitTo")]
    turk_submit_to: Option<String>,
    #[serde(rename = "PROLIFIC_PID")]
    prolific_pid: Option<String>,
    #[serde(rename = "STUDY_ID")]
    prolific_study: Option<String>,
    #[serde(rename = "SESSION_ID")]
    prolific_session: Option<String>,
    participant: Option<String>,
}

#[derive(Template)]
#[template(path = "start.html")]
struct StartPage {
    study: StudyId,
    name: String,
    description: String,
    questions: u32,
    training: u32,
    preview: bool,
    sandbox: bool,
    hidden: Vec<(&'static str, String)>,
}

async fn start_page(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiQuery(q): ApiQuery<StartQuery>,
) -> Response {
    page(
        async {
            let s = study::load(&state.db, id).await?;
            let mturk = q.turk_submit_to.is_some() || q.assignment_id.is_some();
            let preview = q.assignment_id.as_deref() == Some(flow::MTURK_PREVIEW);
            let sandbox = mturk && s.settings.mturk_mode == MturkMode::Sandbox;
            if !preview
                && q.worker_id.is_none()
                && q.prolific_pid.is_none()
                && q.participant.is_none()
            {
                return Err(AppError::BadRequest(
                    "this link has no participant id (workerId, PROLIFIC_PID or participant)"
                        .into(),
                ));
            }
            let mut hidden = Vec::new();
            let mut push = |k: &'static str, v: &Option<String>| {
                if let Some(v) = v {
                    hidden.push((k, v.clone()));
                }
            };
            push("assignment_id", &q.assignment_id);
            push("hit_id", &q.hit_id);
            push("turk_submit_to", &q.turk_submit_to);
            push("prolific_study_id", &q.prolific_study);
            push("prolific_session_id", &q.prolific_session);
            let worker = q
                .worker_id
                .clone()
                .or(q.prolific_pid.clone())
                .or(q.participant.clone());
            push("worker_id", &worker);
            let source = if mturk {
                "mturk"
            } else if q.prolific_pid.is_some() {
                "prolific"
            } else {
                "direct"
            };
            hidden.push(("source", source.to_string()));
            render(&StartPage {
                study: s.id,
                name: s.name.clone(),
                description: s.settings.description.clone(),
                questions: s.settings.questions_per_hit,
                training: s.settings.training_questions,
                preview,
                sandbox,
                hidden,
            })
        }
        .await,
    )
}

#[derive(Debug, Deserialize)]
struct StartForm {
    source: Source,
    worker_id: Option<String>,
    assignment_id: Option<String>,
    hit_id: Option<String>,
    turk_submit_to: Option<String>,
    prolific_study_id: Option<String>,
    prolific_session_id: Option<String>,
    gender: Option<String>,
    art_experience: Option<String>,
}

async fn start_submit(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    form: std::result::Result<ApiForm<StartForm>, AppError>,
) -> Response {
    page(
        async {
            let ApiForm(f) = form?;
            let s = study::load(&state.db, id).await?;
            let empty_none = |v: Option<String>| v.filter(|x| !x.is_empty());
            let req = StartRequest {
                source: Some(f.source),
                worker_id: f.worker_id,
                assignment_id: f.assignment_id,
                hit_id: f.hit_id,
                turk_submit_to: f.turk_submit_to,
                prolific_study_id: f.prolific_study_id,
                prolific_session_id: f.prolific_session_id,
                demographics: Some(Demographics {
                    gender: empty_none(f.gender),
                    art_experience: empty_none(f.art_experience),
                }),
            };
            match flow::start(&state.db, &s, req).await? {
                StartOutcome::Started { token, .. } => {
                    Ok(Redirect::to(&format!("/a/{token}")).into_response())
                }
                StartOutcome::Preview { .. } => Err(AppError::BadRequest(
                    "accept the HIT before starting".into(),
                )),
            }
        }
        .await,
    )
}

#[derive(Template)]
#[template(path = "training.html")]
struct TrainingPage {
    token: String,
    sandbox: bool,
    attempt: i64,
    max_attempts: i64,
    failed: bool,
    questions: Vec<TrainingItem>,
}

struct TrainingItem {
    view: QuestionView,
    correct: Option<bool>,
}

#[derive(Template)]
#[template(path = "question.html")]
struct QuestionPage {
    token: String,
    sandbox: bool,
    q: QuestionView,
    number: i64,
    total: i64,
    preload: Vec<String>,
}

#[derive(Template)]
#[template(path = "reasons.html")]
struct ReasonsPage {
    token: String,
    sandbox: bool,
    position: i64,
    groups: Vec<(&'static str, Vec<(&'static str, &'static str)>)>,
}

#[derive(Template)]
#[template(path = "done.html")]
struct DonePage {
    sandbox: bool,
    screened_out: bool,
    code: String,
    mturk_action: Option<String>,
    mturk_assignment: String,
    redirect: Option<String>,
}

async fn assignment_page(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
) -> Response {
    page(show_assignment(&state, &token, None).await)
}

async fn show_assignment(
    state: &AppState,
    token: &str,
    feedback: Option<Vec<bool>>,
) -> Result<Response> {
    let a = flow::by_token(&state.db, token).await?;
    let s = flow::study_of(&state.db, &a).await?;
    let st = flow::state(&state.db, &s, &a).await?;
    let sandbox = st.sandbox;
    if st.status == "abandoned" {
        return Err(AppError::Conflict(
            "this assignment has expired; please return the HIT".into(),
        ));
    }
    if st.status == "training" {
        let failed = feedback.is_some();
        let questions = st
            .training
            .into_iter()
            .enumerate()
            .map(|(i, view)| TrainingItem {
                view,
                correct: feedback.as_ref().and_then(|f| f.get(i).copied()),
            })
            .collect();
        return render(&TrainingPage {
            token: token.to_string(),
            sandbox,
            attempt: st.training_attempts + 1,
            max_attempts: st.max_training_attempts,
            failed,
            questions,
        });
    }
    if let Some(position) = st.reasons_for {
        let mut groups: Vec<(&'static str, Vec<(&'static str, &'static str)>)> = Vec::new();
        for &(group, code, label) in flow::REASONS {
            match groups.iter_mut().find(|(g, _)| *g == group) {
                Some((_, v)) => v.push((code, label)),
                None => groups.push((group, vec![(code, label)])),
            }
        }
        return render(&ReasonsPage {
            token: token.to_string(),
            sandbox,
            position,
            groups,
        });
    }
    if let Some(q) = st.question {
        return render(&QuestionPage {
            token: token.to_string(),
            sandbox,
            number: st.answered + 1,
            total: st.total,
            q,
            preload: st.preload,
        });
    }
    let screened_out = st.status == "screened_out";
    let code = st
        .completion_code
        .or(st.screenout_code)
        .ok_or(AppError::Conflict("the assignment is not finished".into()))?;
    let (mut mturk_action, mut mturk_assignment, mut redirect) = (None, String::new(), None);
    match st.handback {
        Some(Handback::MturkForm {
            action,
            assignment_id,
            ..
        }) => {
            mturk_action = Some(action);
            mturk_assignment = assignment_id;
        }
        Some(Handback::Redirect { url }) => redirect = Some(url),
        _ => {}
    }
    render(&DonePage {
        sandbox,
        screened_out,
        code,
        mturk_action,
        mturk_assignment,
        redirect,
    })
}

async fn training_submit(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    form: std::result::Result<ApiForm<Vec<(String, String)>>, AppError>,
) -> Response {
    page(
        async {
            let ApiForm(pairs) = form?;
            let a = flow::by_token(&state.db, &token).await?;
            let s = flow::study_of(&state.db, &a).await?;
            let mut answers = Vec::new();
            for (k, v) in pairs.iter().take(100) {
                let position = k
                    .strip_prefix('q')
                    .and_then(|p| p.parse::<i64>().ok())
                    .ok_or_else(|| AppError::BadRequest(format!("unexpected field {k:?}")))?;
                let choice = v
                    .parse()
                    .map_err(|_| AppError::BadRequest(format!("{k}: not an item id")))?;
                answers.push(flow::TrainingAnswer { position, choice });
            }
            let result = flow::submit_training(&state.db, &s, &a, &answers).await?;
            if result.passed || result.status == "screened_out" {
                return Ok(Redirect::to(&format!("/a/{token}")).into_response());
            }
            show_assignment(
                &state,
                &token,
                Some(result.feedback.iter().map(|f| f.correct).collect()),
            )
            .await
        }
        .await,
    )
}

async fn give_up_submit(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
) -> Response {
    page(
        async {
            let a = flow::by_token(&state.db, &token).await?;
            flow::give_up(&state.db, &a).await?;
            Ok(Redirect::to(&format!("/a/{token}")).into_response())
        }
        .await,
    )
}

#[derive(Debug, Deserialize)]
struct AnswerForm {
    position: i64,
    choice: ItemId,
    elapsed_ms: Option<String>,
}

async fn answer_submit(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    form: std::result::Result<ApiForm<AnswerForm>, AppError>,
) -> Response {
    page(
        async {
            let ApiForm(f) = form?;
            let req = flow::AnswerRequest {
                position: f.position,
                choice: f.choice,
                elapsed_ms: f.elapsed_ms.and_then(|v| v.parse().ok()),
            };
            flow::answer(&state.db, &token, &req).await?;
            Ok(Redirect::to(&format!("/a/{token}")).into_response())
        }
        .await,
    )
}

async fn reasons_submit(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    form: std::result::Result<ApiForm<Vec<(String, String)>>, AppError>,
) -> Response {
    page(
        async {
            let ApiForm(pairs) = form?;
            let a = flow::by_token(&state.db, &token).await?;
            let mut position = None;
            let mut reasons = Vec::new();
            let mut text = None;
            for (k, v) in pairs.into_iter().take(50) {
                match k.as_str() {
                    "position" => {
                        position =
                            Some(v.parse::<i64>().map_err(|_| {
                                AppError::BadRequest("position: not a number".into())
                            })?)
                    }
                    "reason" => reasons.push(v),
                    "text" => text = Some(v),
                    other => {
                        return Err(AppError::BadRequest(format!("unexpected field {other:?}")));
                    }
                }
            }
            let position =
                position.ok_or_else(|| AppError::BadRequest("position: missing".into()))?;
            flow::submit_reasons(
                &state.db,
                &a,
                &flow::ReasonsRequest {
                    position,
                    reasons,
                    text,
                },
            )
            .await?;
            Ok(Redirect::to(&format!("/a/{token}")).into_response())
        }
        .await,
    )
}
