//! The start page a study link opens: the study's instructions (Markdown) with a worked example,
//! the informed-consent form when the study has one, optional demographics, and — for a worker
//! who already has an assignment — "continue where you left off".

use askama::Template;
use axum::extract::State;
use axum::response::{IntoResponse, Redirect, Response};
use serde::Deserialize;

use crate::AppState;
use crate::error::{AppError, Result};
use crate::flow::{self, Demographics, Existing, QuestionView, Source, StartOutcome, StartRequest};
use crate::store::db::Db;
use crate::store::ids::{LibraryId, StudyId};
use crate::studies::markdown;
use crate::studies::study::{self, MturkMode, Study};
use crate::web::extract::{ApiForm, ApiPath, ApiQuery};
use crate::web::pages::{page, render};

/// The query string MTurk / Prolific / a direct link put on the start page.
#[derive(Debug, Default, Deserialize)]
pub(super) struct StartQuery {
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

/// A worked example as the page draws it.
struct Example {
    q: QuestionView,
    /// The left picture is the answer (else the right one).
    left_is_answer: bool,
}

#[derive(Template)]
#[template(path = "start.html")]
struct StartPage {
    study: StudyId,
    name: String,
    description: String,
    /// Rendered from the study's Markdown ([`markdown::to_html`]: no raw HTML).
    instructions_html: String,
    example: Option<Example>,
    /// The consent form, when the study asks for consent and the worker has not answered yet.
    consent_html: Option<String>,
    existing: Option<Existing>,
    /// Questions of a HIT started now ([`flow::outlook`]: the settings' number, or fewer when
    /// the study has fewer free tuples or controls left); 0 when none is left.
    questions: usize,
    /// Practice questions of the first attempt (0: no training).
    training: usize,
    preview: bool,
    sandbox: bool,
    hidden: Vec<(&'static str, String)>,
}

/// Researcher-written Markdown as safe HTML, with `item:NAME` images of the study's library.
async fn markdown_html(db: &Db, library: LibraryId, text: &str) -> Result<String> {
    let mut urls = Vec::new();
    for name in markdown::item_references(text) {
        let row = sqlx::query("SELECT id FROM items WHERE library_id = $1 AND name = $2")
            .bind(library.0)
            .bind(&name)
            .fetch_optional(&db.pool)
            .await?;
        if let Some(r) = row {
            let id: i64 = sqlx::Row::try_get(&r, "id")?;
            urls.push((name, format!("/media/items/{id}.png")));
        }
    }
    Ok(markdown::to_html(text, &|name| {
        urls.iter().find(|(n, _)| n == name).map(|(_, u)| u.clone())
    }))
}

pub(super) async fn start_page(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiQuery(q): ApiQuery<StartQuery>,
) -> Response {
    page(
        async {
            let s = study::load(&state.db, id).await?;
            s.check_open()?;
            let mturk = q.turk_submit_to.is_some() || q.assignment_id.is_some();
            let preview = q.assignment_id.as_deref() == Some(flow::MTURK_PREVIEW);
            let sandbox = mturk && s.settings.mturk_mode == MturkMode::Sandbox;
            let worker = q
                .worker_id
                .clone()
                .or(q.prolific_pid.clone())
                .or(q.participant.clone());
            if !preview && worker.is_none() {
                return Err(AppError::BadRequest(
                    "this link has no participant id (workerId, PROLIFIC_PID or participant)"
                        .into(),
                ));
            }
            let source = if mturk {
                Source::Mturk
            } else if q.prolific_pid.is_some() {
                Source::Prolific
            } else {
                Source::Direct
            };
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
            push("worker_id", &worker);
            hidden.push(("source", source.as_str().to_string()));
            let existing = match &worker {
                Some(w) if !preview => flow::existing(&state.db, &s, source, w).await?,
                _ => None,
            };
            render(&page_of(&state.db, &s, preview, sandbox, hidden, existing).await?)
        }
        .await,
    )
}

async fn page_of(
    db: &Db,
    s: &Study,
    preview: bool,
    sandbox: bool,
    hidden: Vec<(&'static str, String)>,
    existing: Option<Existing>,
) -> Result<StartPage> {
    let example = flow::worked_example(db, s).await?.map(|x| Example {
        left_is_answer: x.question.left.id == x.expected,
        q: x.question,
    });
    let outlook = flow::outlook(db, s).await?;
    let consent_html = if s.settings.consent.trim().is_empty() || existing.is_some() {
        None
    } else {
        Some(markdown_html(db, s.library, &s.settings.consent).await?)
    };
    Ok(StartPage {
        study: s.id,
        name: s.name.clone(),
        description: s.settings.description.clone(),
        instructions_html: markdown_html(db, s.library, &s.settings.instructions).await?,
        example,
        consent_html,
        existing,
        questions: outlook.questions,
        training: outlook.practice,
        preview,
        sandbox,
        hidden,
    })
}

/// The start form (and the decline form, which carries the same hidden fields).
#[derive(Debug, Deserialize)]
pub(super) struct StartForm {
    source: Source,
    worker_id: Option<String>,
    assignment_id: Option<String>,
    hit_id: Option<String>,
    turk_submit_to: Option<String>,
    prolific_study_id: Option<String>,
    prolific_session_id: Option<String>,
    gender: Option<String>,
    art_experience: Option<String>,
    /// The consent checkbox: `yes` when ticked.
    consent: Option<String>,
}

impl StartForm {
    fn request(self, consent: Option<bool>) -> Result<StartRequest> {
        let empty_none = |v: Option<String>| v.filter(|x| !x.is_empty());
        let consent = match (consent, self.consent.as_deref()) {
            (Some(answer), _) => Some(answer),
            (None, Some("yes")) => Some(true),
            (None, None) => None,
            (None, Some(other)) => {
                return Err(AppError::BadRequest(format!(
                    "consent: {other:?} is not the checkbox's value"
                )));
            }
        };
        Ok(StartRequest {
            source: Some(self.source),
            worker_id: self.worker_id,
            assignment_id: self.assignment_id,
            hit_id: self.hit_id,
            turk_submit_to: self.turk_submit_to,
            prolific_study_id: self.prolific_study_id,
            prolific_session_id: self.prolific_session_id,
            demographics: Some(Demographics {
                gender: empty_none(self.gender),
                art_experience: empty_none(self.art_experience),
            }),
            consent,
        })
    }
}

/// Starts (or resumes) and goes to the assignment's page.
async fn start_with(state: &AppState, id: StudyId, req: StartRequest) -> Result<Response> {
    let s = study::load(&state.db, id).await?;
    match flow::start(&state.db, &s, req).await {
        Ok(StartOutcome::Started { token, .. }) => {
            Ok(Redirect::to(&format!("/a/{token}")).into_response())
        }
        Ok(StartOutcome::Preview { .. }) => Err(AppError::BadRequest(
            "accept the HIT before starting".into(),
        )),
        Err(AppError::BadRequest(m)) if m.starts_with("consent:") => Err(AppError::BadRequest(
            "Please tick \"I agree\" to take part, or choose \"I do not agree\".".into(),
        )),
        Err(e) => Err(e),
    }
}

pub(super) async fn start_submit(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    form: std::result::Result<ApiForm<StartForm>, AppError>,
) -> Response {
    page(
        async {
            let ApiForm(f) = form?;
            start_with(&state, id, f.request(None)?).await
        }
        .await,
    )
}

/// "I do not agree": recorded, then the no-consent end page.
pub(super) async fn decline_submit(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    form: std::result::Result<ApiForm<StartForm>, AppError>,
) -> Response {
    page(
        async {
            let ApiForm(f) = form?;
            start_with(&state, id, f.request(Some(false))?).await
        }
        .await,
    )
}
