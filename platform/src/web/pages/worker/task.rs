//! The pages of an assignment (`/a/{token}`): the practice questions with feedback on the last
//! attempt, one question at a time, the reasons questionnaire, and the forms they post.

use askama::Template;
use axum::extract::{RawQuery, State};
use axum::response::{IntoResponse, Redirect, Response};
use serde::Deserialize;

use crate::AppState;
use crate::error::{AppError, Result};
use crate::flow::{self, ItemRef, QuestionView, TrainingReview};
use crate::store::ids::ItemId;
use crate::studies::kind::StudyKind;
use crate::web::extract::{ApiForm, ApiPath};
use crate::web::pages::{page, render};

#[derive(Template)]
#[template(path = "training.html")]
struct TrainingPage {
    token: String,
    sandbox: bool,
    attempt: i64,
    max_attempts: i64,
    /// The previous attempt with the right answers (empty at the first attempt).
    review: Vec<TrainingReview>,
    questions: Vec<QuestionView>,
    /// The kind's question (shown when the tuples have no reference).
    prompt: &'static str,
}

#[derive(Template)]
#[template(path = "question.html")]
struct QuestionPage {
    token: String,
    sandbox: bool,
    q: QuestionView,
    /// The kind's question (shown when the tuple has no reference).
    prompt: &'static str,
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
    /// The question the questionnaire is about, and the picture chosen in it.
    question: Option<(QuestionView, ItemRef)>,
    groups: Vec<(&'static str, Vec<(&'static str, &'static str)>)>,
}

pub(super) async fn assignment_page(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    RawQuery(query): RawQuery,
) -> Response {
    page(show_assignment(&state, &token, query.as_deref()).await)
}

/// The page the assignment is at: training, the questionnaire pending, the next question, or
/// the end page.
async fn show_assignment(state: &AppState, token: &str, query: Option<&str>) -> Result<Response> {
    let a = flow::by_token(&state.db, token).await?;
    let s = flow::study_of(&state.db, &a).await?;
    let st = flow::state(&state.db, &s, &a).await?;
    let sandbox = st.sandbox;
    let prompt = s.kind.prompt(s.settings.question.unwrap_or_default());
    if st.status == "abandoned" {
        return Err(AppError::Conflict(
            "this assignment has expired; please return the HIT".into(),
        ));
    }
    if st.status == "training" {
        return render(&TrainingPage {
            token: token.to_string(),
            sandbox,
            attempt: st.training_attempts + 1,
            max_attempts: st.max_training_attempts,
            review: st.last_training_attempt,
            questions: st.training,
            prompt,
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
        let question = st
            .reasons_question
            .zip(st.reasons_choice)
            .map(|(q, chosen)| {
                let picked = if q.left.id == chosen {
                    q.left.clone()
                } else {
                    q.right.clone()
                };
                (q, picked)
            });
        return render(&ReasonsPage {
            token: token.to_string(),
            sandbox,
            position,
            question,
            groups,
        });
    }
    // An icon-set HIT's one question stands for the tray of sets: the tray instead.
    if st.question.is_some()
        && super::iconset::is_iconset(&s)
        && let Some(settings) = &s.settings.iconset
    {
        return super::iconset::render_task(state, token, &a, &s, settings, sandbox, query).await;
    }
    // A mash-up HIT's one question stands for the composition: the canvas instead.
    if let (Some(_), StudyKind::Mashup, Some(m)) = (&st.question, s.kind, s.settings.mashup) {
        let library = crate::search::source::library_name(&state.db, s.library).await?;
        return super::mashup::render_task(token, sandbox, library, m);
    }
    if let Some(q) = st.question {
        return render(&QuestionPage {
            token: token.to_string(),
            sandbox,
            prompt,
            number: st.answered + 1,
            total: st.total,
            q,
            preload: st.preload,
        });
    }
    super::done::render_done(st)
}

pub(super) async fn training_submit(
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
            match flow::submit_training(&state.db, &s, &a, &answers).await {
                // Passed, failed (the page then shows the feedback and the next attempt's
                // questions) or screened out: the assignment's page says which.
                Ok(_) => {}
                // The same attempt sent twice (a double click, a reload of the POST): the
                // first one counted.
                Err(AppError::Conflict(m)) if m.contains("already submitted") => {}
                Err(e) => return Err(e),
            }
            Ok(Redirect::to(&format!("/a/{token}")).into_response())
        }
        .await,
    )
}

pub(super) async fn give_up_submit(
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
pub(super) struct AnswerForm {
    position: i64,
    choice: ItemId,
    elapsed_ms: Option<String>,
}

pub(super) async fn answer_submit(
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
            match flow::answer(&state.db, &token, &req, flow::AnsweredBy::Question).await {
                Ok(_) => {}
                // A second, different input for a question already answered (a double tap
                // without the page's script): the first answer stands and the worker moves on.
                Err(AppError::Conflict(m)) if m.contains("already answered") => {}
                Err(e) => return Err(e),
            }
            Ok(Redirect::to(&format!("/a/{token}")).into_response())
        }
        .await,
    )
}

pub(super) async fn reasons_submit(
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
