//! The HTML pages: the worker flow (start, training, questions, reasons, done) on top of the
//! same [`crate::flow`] functions as the JSON API, and the admin pages (login, studies, upload,
//! dashboard, quality control, exports). Askama escapes every value.

use askama::Template;
use axum::Router;
use axum::extract::{Multipart, State};
use axum::http::{StatusCode, header};
use axum::response::{Html, IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use serde::Deserialize;

use crate::AppState;
use crate::admin::{self, Admin};
use crate::dashboard;
use crate::error::{AppError, Result};
use crate::export::{self, ExportOptions};
use crate::extract::{ApiForm, ApiPath, ApiQuery};
use crate::flow::{self, Demographics, Handback, QuestionView, Source, StartOutcome, StartRequest};
use crate::ids::{AssignmentId, ItemId, ModelId, StudyId};
use crate::library;
use crate::qc::{self, DecisionRecord, RuleOutcome};
use crate::study::{self, MturkMode, StudySettings};
use crate::study_edit::{self, SettingsChange, SettingsPatch};
use crate::train::{self, ModelSummary, TrainOptions};

/// Worker and admin page routes.
pub fn routes() -> Router<AppState> {
    Router::new()
        .route("/", get(home))
        .route("/media/items/{file}", get(media))
        .route("/static/{file}", get(crate::assets::serve))
        .route("/s/{study}", get(start_page))
        .route("/s/{study}/start", post(start_submit))
        .route("/a/{token}", get(assignment_page))
        .route("/a/{token}/training", post(training_submit))
        .route("/a/{token}/give-up", post(give_up_submit))
        .route("/a/{token}/answer", post(answer_submit))
        .route("/a/{token}/reasons", post(reasons_submit))
        .route("/admin/login", get(login_page).post(login_submit))
        .route("/admin/logout", post(logout_submit))
        .route("/admin", get(admin_index))
        .route("/admin/studies", post(admin_create))
        .route("/admin/studies/{study}", get(admin_study))
        .route("/admin/studies/{study}/qc", post(admin_qc))
        .route("/admin/studies/{study}/decision", post(admin_decision))
        .route("/admin/studies/{study}/settings", post(admin_settings))
        .route("/admin/studies/{study}/export/{file}", get(admin_export))
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

fn render(t: &impl Template) -> Result<Response> {
    let html = t.render().map_err(AppError::internal)?;
    Ok(Html(html).into_response())
}

#[derive(Template)]
#[template(path = "message.html")]
struct MessagePage<'a> {
    title: &'a str,
    message: String,
    class: &'a str,
}

/// Renders an error as an HTML page with the error's status.
fn error_page(e: AppError) -> Response {
    let status = e.status();
    if status.is_server_error() {
        eprintln!("error: {e}");
    }
    if matches!(e, AppError::Unauthorized) {
        return Redirect::to("/admin/login").into_response();
    }
    let page = MessagePage {
        title: if status.is_server_error() {
            "Something went wrong"
        } else {
            "Sorry"
        },
        message: e.public_message(),
        class: "error",
    };
    match page.render() {
        Ok(html) => (status, Html(html)).into_response(),
        Err(_) => (status, e.public_message()).into_response(),
    }
}

fn page(r: Result<Response>) -> Response {
    r.unwrap_or_else(error_page)
}

async fn home() -> Response {
    page(render(&MessagePage {
        title: "Style rating studies",
        message: "Workers arrive through a study link; researchers log in at /admin.".into(),
        class: "",
    }))
}

async fn media(State(state): State<AppState>, ApiPath(file): ApiPath<String>) -> Result<Response> {
    let id: ItemId = file
        .strip_suffix(".png")
        .and_then(|s| s.parse().ok())
        .ok_or(AppError::NotFound("item"))?;
    let png = library::item_png(&state.db, id).await?;
    Ok((
        [
            (header::CONTENT_TYPE, "image/png"),
            (header::CACHE_CONTROL, "public, max-age=86400, immutable"),
        ],
        png,
    )
        .into_response())
}

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

#[derive(Template)]
#[template(path = "admin_login.html")]
struct LoginPage {
    failed: bool,
}

async fn login_page() -> Response {
    page(render(&LoginPage { failed: false }))
}

#[derive(Debug, Deserialize)]
struct LoginForm {
    username: String,
    password: String,
}

async fn login_submit(
    State(state): State<AppState>,
    form: std::result::Result<ApiForm<LoginForm>, AppError>,
) -> Response {
    page(
        async {
            let ApiForm(f) = form?;
            match admin::login(&state.db, &f.username, &f.password).await? {
                Some((token, _csrf)) => Ok((
                    StatusCode::SEE_OTHER,
                    [
                        (
                            header::SET_COOKIE,
                            admin::session_cookie(&token, state.settings.secure_cookies),
                        ),
                        (header::LOCATION, "/admin".to_string()),
                    ],
                )
                    .into_response()),
                None => {
                    let mut r = render(&LoginPage { failed: true })?;
                    *r.status_mut() = StatusCode::UNAUTHORIZED;
                    Ok(r)
                }
            }
        }
        .await,
    )
}

#[derive(Debug, Deserialize)]
struct CsrfForm {
    csrf: Option<String>,
}

async fn logout_submit(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    form: std::result::Result<ApiForm<CsrfForm>, AppError>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let ApiForm(f) = form?;
            admin.check_csrf(f.csrf.as_deref())?;
            admin::logout(&state.db, &admin.token).await?;
            Ok((
                StatusCode::SEE_OTHER,
                [
                    (
                        header::SET_COOKIE,
                        format!(
                            "{}=; HttpOnly; SameSite=Strict; Path=/; Max-Age=0",
                            admin::COOKIE
                        ),
                    ),
                    (header::LOCATION, "/admin/login".to_string()),
                ],
            )
                .into_response())
        }
        .await,
    )
}

struct StudyRow {
    id: StudyId,
    name: String,
    questions: u32,
    replication: u32,
    mode: &'static str,
}

#[derive(Template)]
#[template(path = "admin_index.html")]
struct AdminIndex {
    username: String,
    csrf: String,
    studies: Vec<StudyRow>,
    libraries: Vec<String>,
}

async fn admin_index(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let studies = study::list(&state.db)
                .await?
                .into_iter()
                .map(|s| StudyRow {
                    id: s.id,
                    name: s.name,
                    questions: s.settings.questions_per_hit,
                    replication: s.settings.replication,
                    mode: match s.settings.mturk_mode {
                        MturkMode::Sandbox => "sandbox",
                        MturkMode::Live => "LIVE",
                    },
                })
                .collect();
            let rows = sqlx::query("SELECT name FROM libraries ORDER BY name")
                .fetch_all(&state.db.pool)
                .await?;
            let libraries = rows
                .iter()
                .map(|r| sqlx::Row::try_get(r, "name"))
                .collect::<std::result::Result<_, _>>()?;
            render(&AdminIndex {
                username: admin.username,
                csrf: admin.csrf,
                studies,
                libraries,
            })
        }
        .await,
    )
}

#[derive(Debug, Deserialize)]
struct CreateForm {
    csrf: Option<String>,
    name: String,
    library: String,
    questions_per_hit: u32,
    controls_per_hit: u32,
    tuples: u32,
    replication: u32,
    mturk_mode: MturkMode,
}

async fn admin_create(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    form: std::result::Result<ApiForm<CreateForm>, AppError>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let ApiForm(f) = form?;
            admin.check_csrf(f.csrf.as_deref())?;
            let library = library::ensure_existing(&state.db, &f.library).await?;
            let settings = StudySettings {
                questions_per_hit: f.questions_per_hit,
                controls_per_hit: f.controls_per_hit,
                tuples: f.tuples,
                replication: f.replication,
                mturk_mode: f.mturk_mode,
                ..StudySettings::default()
            };
            let (id, _) = study::create(&state.db, &f.name, library, settings).await?;
            Ok(Redirect::to(&format!("/admin/studies/{id}")).into_response())
        }
        .await,
    )
}

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
    /// `(control errors, completed HITs)`, drawn as `<meter>`s up to `histogram_max`.
    histogram: Vec<(i64, i64)>,
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

/// A model as the dashboard lists it (numbers formatted).
struct ModelRow {
    id: ModelId,
    status: String,
    message: String,
    started: String,
    triplets: String,
    lambda: String,
    nonzero: String,
    train_accuracy: String,
    uniform_accuracy: String,
    cv_accuracy: String,
}

impl From<ModelSummary> for ModelRow {
    fn from(m: ModelSummary) -> Self {
        let pct = |v: Option<f64>| v.map_or_else(String::new, |v| format!("{:.1}%", 100.0 * v));
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
            cv_accuracy: pct(m.cv_accuracy),
        }
    }
}

/// `YYYY-MM-DD HH:00 UTC` of a Unix-ms time (civil-from-days, proleptic Gregorian).
fn utc_hour(ms: i64) -> String {
    let (year, month, day, secs) = utc_civil(ms);
    format!("{year:04}-{month:02}-{day:02} {:02}:00 UTC", secs / 3600)
}

/// `YYYY-MM-DD HH:MM UTC` of a Unix-ms time.
fn utc_minute(ms: i64) -> String {
    let (year, month, day, secs) = utc_civil(ms);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02} UTC",
        secs / 3600,
        secs % 3600 / 60
    )
}

/// (year, month, day, seconds into the day) of a Unix-ms time.
fn utc_civil(ms: i64) -> (i64, i64, i64, i64) {
    let secs = ms.div_euclid(1000);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    (year, month, day, rem)
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
        .map(|x| x.1)
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
            .map(|&(h, n)| (utc_hour(h), n))
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
    page(
        async {
            let admin = admin?;
            let ApiForm(f) = form?;
            admin.check_csrf(f.csrf.as_deref())?;
            let lambda =
                match f.lambda.as_deref().map(str::trim) {
                    None | Some("") => None,
                    Some(text) => Some(text.parse::<f64>().map_err(|_| {
                        AppError::BadRequest(format!("λ: {text:?} is not a number"))
                    })?),
                };
            let s = study::load(&state.db, id).await?;
            let opts = TrainOptions {
                lambda,
                ..TrainOptions::default()
            };
            train::start(&state.db, &s, opts).await?;
            Ok(Redirect::to(&format!("/admin/studies/{id}#models")).into_response())
        }
        .await,
    )
}

async fn admin_report_redirect(
    admin: std::result::Result<Admin, AppError>,
    ApiPath((id, model)): ApiPath<(StudyId, ModelId)>,
) -> Response {
    page(admin.map(|_| {
        Redirect::permanent(&format!("/admin/studies/{id}/models/{model}/report/")).into_response()
    }))
}

/// A stored report file. The report is static (no script); the CSP keeps it that way.
async fn report_file(
    state: &AppState,
    id: StudyId,
    model: ModelId,
    file: &str,
) -> Result<Response> {
    let (content_type, bytes) = train::file(&state.db, id, model, file).await?;
    Ok((
        [
            (header::CONTENT_TYPE, content_type),
            (
                header::CONTENT_SECURITY_POLICY,
                "default-src 'none'; img-src 'self'; style-src 'unsafe-inline'",
            ),
        ],
        bytes,
    )
        .into_response())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_hours() {
        assert_eq!(utc_hour(0), "1970-01-01 00:00 UTC");
        // 2026-11-22 03:00:00 UTC.
        assert_eq!(utc_hour(1_795_316_400_000), "2026-11-22 03:00 UTC");
        assert_eq!(utc_hour(951_782_400_000), "2000-02-29 00:00 UTC");
        // 2026-11-22 03:07:59 UTC.
        assert_eq!(utc_minute(1_795_316_879_000), "2026-11-22 03:07 UTC");
    }
}
